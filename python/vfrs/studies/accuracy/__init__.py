"""What accuracy costs in time: a grid of contact settings x resolutions x time steps, each
run measured for its error (against a closed form or a reference run), its wall time split
by effect, its iterations and its peak memory.

``vfrs bench accuracy [--quick] -o out/accuracy`` writes ``accuracy.csv``, ``accuracy.json``,
``accuracy.md`` (tables, the Pareto-optimal settings and a recommendation per problem) and
``pareto_<problem>.png``.

A problem's reference is never one of the settings it judges: closed forms for the block,
Hertz and the bars; for the M5 folds a Lagrange run on a finer mesh with a smaller step than
every row (``accuracy.json`` records it under ``references``, with its wall time and its two
sensitivity checks: one mesh level coarser, ``check``, and twice the step, ``step_check``).
One row
can be re-run on its own with :func:`run_row` (what ``tests/test_committed_results.py`` does
to keep the committed tables tied to the code).

The package: :mod:`~vfrs.studies.accuracy.problems` (the benchmark problems and their closed
forms or reference studies), :mod:`~vfrs.studies.accuracy.folds` (the folds' contact benchmark
without flow: a static press and load pulses on the systematic mesh family),
:mod:`~vfrs.studies.accuracy.reference` (an extrapolated
reference), :mod:`~vfrs.studies.accuracy.grid` (the settings, a row run on its own, the
recommendation), :mod:`~vfrs.studies.accuracy.runs` (the report as one sweep of run folders),
:mod:`~vfrs.studies.accuracy.report` (the tables, the text and the figures) and
:mod:`~vfrs.studies.accuracy.pareto` (the Pareto front).
"""

from . import folds  # noqa: F401  (registers the folds' problems after problems.py's)
from .grid import EFFECT_KEYS, Row, grid_cells, method_grid, provenance, recommend, run_reference, run_row
from .pareto import pareto_front
from .report import AccuracyReport, pareto_figure
from .runs import accuracy_sweep, rebuild, run_accuracy

__all__ = ["run_accuracy", "run_row", "run_reference", "recommend", "rebuild", "accuracy_sweep", "AccuracyReport", "Row",
           "grid_cells", "method_grid", "provenance", "pareto_front", "pareto_figure", "EFFECT_KEYS"]
