"""Studies: many runs of a scene and what they say together.

- :mod:`vfrs.studies.sweep`: a grid of scenes (``sweep.toml``) run on dask or serially into one
  table of results (``vfrs sweep``);
- :mod:`vfrs.studies.derived`: the table's derived columns (``[derived]`` expressions);
- :mod:`vfrs.studies.converge`: the step and mesh ladders of a scene and its error bars
  (``vfrs converge``);
- :mod:`vfrs.studies.verification`: the arithmetic of a three-run study (observed order,
  Richardson extrapolation, GCI) and the error policy of one axis;
- :mod:`vfrs.studies.validation`: estimators to compare a study's numbers with measurements;
- :mod:`vfrs.studies.accuracy`: the accuracy report of the contact methods (``vfrs bench accuracy``).
- :mod:`vfrs.studies.extra`: the ``sweep`` extra (dask.distributed, pyarrow), or a one-line error
  naming it (``pip install "vfrs[sweep]"``).

This ``__init__`` imports nothing, so that importing one study (the pure-numpy verification)
does not import the others.
"""
