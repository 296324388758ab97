"""``python -m casadi_sins``: the command line."""

from .console import console

console()
