"""``vfrs.summary``: what a run measured, as numbers with units.

:func:`summarize` takes a :class:`vfrs.Result`, an output folder (``vfrs run ... -o OUT``;
read back with its summary by :func:`load`, also ``vfrs.load``) or a history mapping, asks every effect and every registered
:class:`Measure` for its sections (through a :class:`RunView` of the run) and returns a
:class:`Summary` of :class:`Quantity` values (SI value, unit, what it is, and when / where for
peaks). A :class:`Summary` prints itself (``vfrs run`` shows it) and is saved as
``summary.json``. The signal functions it is built on (cycles, peaks, contact intervals,
periodicity) are :mod:`vfrs.signals`.

- ``vfrs.summary.quantity``: :class:`Quantity`, display units, the digits a spread or an
  error supports;
- ``vfrs.summary.report``: :class:`Summary` (text, ``summary.json``, error bars);
- ``vfrs.summary.measures``: :class:`RunView`, :class:`Measure`, :data:`MEASURES`,
  :func:`summarize`;
- ``vfrs.summary.fold``: the registered measures for the comparison with measurements
  (sensor pressure per cycle and where it peaks, mean flow, onset);
- ``vfrs.summary.closure``: the registered band-limited peaks (:mod:`vfrs.bandlimit`) and the
  first closure's stages.
"""

from .measures import (MEASURES, ROUNDOFF, Measure, RunView, SummarizedRun, contact, default_start, element_size, load,
                       measure_sources, phonation, register_measure, summarize, summary_names)
from .quantity import DISPLAY, Quantity
from .report import ERROR_AS, Summary

__all__ = ["Quantity", "DISPLAY", "Summary", "ERROR_AS", "RunView", "Measure", "MEASURES", "register_measure",
           "measure_sources", "summarize", "summary_names", "phonation", "contact", "default_start",
           "element_size", "ROUNDOFF", "load", "SummarizedRun"]
