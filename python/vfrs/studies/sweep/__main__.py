"""``python -m vfrs.studies.sweep``: the same as ``vfrs sweep``. It runs the importable
package's main, so that the tasks sent to the workers are vfrs.studies.sweep.task.run_task
(imported there), not a copy in this __main__ pickled by value."""

import sys

from vfrs.studies.sweep import main

sys.exit(main())
