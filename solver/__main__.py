"""``python3 -m solver``: the command-line interface (see solver.cli)."""

import sys

from solver.cli import main

sys.exit(main())
