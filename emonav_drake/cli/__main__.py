"""`python -m emonav_drake.cli ...`: the `emonav` command (`main` in __init__.py)."""

import sys

from emonav_drake.cli import main

sys.exit(main())
