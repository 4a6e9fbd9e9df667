"""
Dynamic contact schemes: two bars colliding
===========================================

``examples/contact_schemes.py`` run in full (**nine runs of a tiny problem**, about 20 s on
one core): two elastic bars of 40 cells collide; while their end faces touch they press with
the constant force F0 = A rho c v0 / 2 for 2 L / c. Each ``[contact] scheme`` records the
contact force at three time steps, h = T, T/4 and T/16 (T: a wave's transit of one cell).
With ``mass_redistribution`` (the default) the recorded force has a limit as h falls; with
``stabilized`` its peak grows, and with ``plain`` (the paper's) the energy grows too.
:doc:`/contact` ("Dynamic contact schemes") explains why.

The scenes and the figure are the example's own functions (``scene``, ``run_case``,
``figure``), imported here; only the figure's file name is changed, so that building the
site does not rewrite the committed ``docs/figures/bar_schemes.png``.
"""

import sys
import tempfile
from pathlib import Path

# the repository's examples/ (sphinx-gallery runs this script in docs/gallery)
examples = next(p / "examples" for p in Path.cwd().resolve().parents if (p / "examples").is_dir())
sys.path.insert(0, str(examples))
import contact_schemes  # noqa: E402  (examples/contact_schemes.py)

# %%
# Every scheme at every step: the peak force, the L1 error of the force history over
# F0 2L/c, and the largest energy over the initial one.
runs = [contact_schemes.run_case(s, n) for s in contact_schemes.SCHEMES for n in contact_schemes.SUBSTEPS]
print(f"{'scheme':<20} {'h':>5} {'peak F/F0':>10} {'L1 error':>9} {'max E/E0':>9}")
for r in runs:
    row = r["row"]
    print(f"{row['scheme']:<20} {'T/' + str(row['substeps']):>5} {row['peak_F_over_F0']:10.3f} "
          f"{row['L1_error']:9.4f} {row['E_max_over_E0']:9.3f}")

# %%
# The recorded force against the exact plateau, one panel per scheme.
contact_schemes.FIGURE = str(Path(tempfile.mkdtemp()) / "bar_schemes.png")
contact_schemes.figure(runs)
