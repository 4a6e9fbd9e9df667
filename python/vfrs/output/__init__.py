"""``vfrs.output``: a run folder, written and read back.

- :mod:`vfrs.output.writer`: the folder a run writes (``vfrs run ... -o OUT``: the resolved
  scene, history, summary, VTU series, manifest, log), locked while it runs, and how
  ``overwrite`` and ``resume`` treat a folder that holds another run;
- :mod:`vfrs.output.reader`: :func:`load` reads it back (:class:`RunOutput`), and every file of
  it is read through one function that answers a damaged file with one line naming it;
- :mod:`vfrs.output.vtu`: the field snapshots as VTU files;
- :mod:`vfrs.output.atomic`: files written whole or not at all.

``vfrs.load`` (:func:`vfrs.summary.load`) reads a folder back with its summary.
"""

from .reader import RunOutput, load

__all__ = ["load", "RunOutput"]
