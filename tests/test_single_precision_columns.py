"""``[contact] column_precision = "single"``: the compliance columns over the bodies' DOFs kept in
float32 (half their memory; docs/performance.md, "A converged answer"). The contact problem of
a step (S and the observed rows: float64) is the same; the whole field's update from the contact
forces is rounded to about 6e-8. What that keeps, for every method and detector, on matching
and non-matching bars (structured) and on the two graded Gmsh balls (curved, unstructured),
at alpha 0 and -0.3 and the stiff penalties of tests/test_contact_dynamic.py:

- the energy never above E0 (1 + 1e-6), as in double precision (the mass-redistribution
  correction holds it);
- impulse = momentum to 1e-7 of a body's momentum (double: 1e-12; measured single: 3.4e-9 on
  the balls, 6.7e-9 / 7.0e-9 on the matching / non-matching bars, Lagrange);
- the peak force and the bars' L1 error within 1e-6 of double precision's (measured 6e-9).

And on the main job (level 0, 20 ms of flow-driven phonation): the history of the motion and of
the contact force within the stated tolerance of double precision's (measured: glottal area
1.4e-4, contact force 3.1e-3 of its largest value; the folds' motion amplifies any round-off:
changing only how the columns are grouped moves them by 6e-5 over 100 ms).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import vfrs
from test_contact_dynamic import BAR_CASES, bars, two_spheres_run

slow = pytest.mark.slow
MOMENTUM = 1e-7
ENERGY = 1e-6
SAME = 1e-6


def _cases(quick):
    out = []
    for method, detection in BAR_CASES:
        for alpha in (0.0, -0.3):
            marks = [] if (method, detection, alpha) == quick else [slow]
            out.append(pytest.param(method, detection, alpha, marks=marks, id=f"{method}-{detection}-a{alpha}"))
    return out


@pytest.mark.filterwarnings("ignore::vfrs.errors.VfrsWarning")
@pytest.mark.parametrize("method,detection,alpha", _cases(("lagrange", "interface_mesh", 0.0)))
def test_two_balls_conserve_with_single_columns(method, detection, alpha):
    double = two_spheres_run(method, detection, alpha, 50)
    single = two_spheres_run(method, detection, alpha, 50, precision="single")
    print(f"\nballs {method} {detection} alpha={alpha}: single {single}")
    assert single["converged"] and single["parted"] and single["balance"] < 1e-10
    assert single["E_max"] <= ENERGY
    assert single["momentum"] < MOMENTUM
    assert single["peak"] == pytest.approx(double["peak"], rel=SAME)


@pytest.mark.filterwarnings("ignore::vfrs.errors.VfrsWarning")
@pytest.mark.parametrize("mesh", ["matching", "4x4-3x3"])
@pytest.mark.parametrize("method,detection,alpha", _cases(("lagrange", "bvh", 0.0)))
def test_bars_conserve_with_single_columns(method, detection, alpha, mesh):
    double = bars(method, mesh, detection=detection, alpha=alpha)
    single = bars(method, mesh, detection=detection, alpha=alpha, precision="single")
    print(f"\nbars {method} {detection} {mesh} alpha={alpha}: single {single}")
    assert single["parted"] and single["E_max"] <= 1 + ENERGY
    assert single["momentum"] < MOMENTUM
    assert single["peak"] == pytest.approx(double["peak"], rel=SAME)
    assert single["l1"] == pytest.approx(double["l1"], rel=SAME)


MAIN_JOB = Path(__file__).resolve().parent.parent / "examples" / "m5_steady.toml"


def _main_job(precision):
    d = vfrs.Scene.load(MAIN_JOB).to_dict()
    d["time"]["end"] = 0.02
    for k in ("until", "until_cycles", "until_cap", "errors_from"):
        d["output"].pop(k, None)
    if precision:
        d["contact"]["column_precision"] = precision
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return vfrs.run(vfrs.Scene.from_dict(d), progress=False)


@pytest.mark.slow
def test_the_main_job_moves_as_in_double_precision():
    double, single = _main_job(None), _main_job("single")
    a, b = double.history, single.history
    rel = {k: float(np.abs(b[k] - a[k]).max() / np.abs(a[k]).max())
           for k in ("glottal_area", "flow_rate", "contact_force.right", "kinetic_energy")}
    print(f"\nmain job, 20 ms, single against double: {rel}")
    assert rel["glottal_area"] < 1e-3 and rel["flow_rate"] < 1e-3 and rel["kinetic_energy"] < 1e-3
    assert rel["contact_force.right"] < 1e-2
    assert (np.asarray(a["active_pairs"]) > 0).any()
