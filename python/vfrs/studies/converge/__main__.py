"""``python -m vfrs.studies.converge``: the same as ``vfrs converge``."""

import sys

from . import main

sys.exit(main())
