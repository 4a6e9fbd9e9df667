"""``python -m vfrs``: the same command line as ``vfrs``."""

import sys

from .cli import main

sys.exit(main())
