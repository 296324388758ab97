"""``python -m casadi_sins``: the command line."""

from .cli import console

console()
