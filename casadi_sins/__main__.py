"""``python -m casadi_sins``: the command line."""

import sys

from .cli import main

sys.exit(main())
