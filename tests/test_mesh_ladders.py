"""examples/mesh_ladders.py and its committed table (examples/convergence_results/ladders.csv,
docs/convergence.md): the legacy M5 ladder is not a refinement, the systematic family is."""

from __future__ import annotations

import csv
import importlib.util
import os

import pytest

ROOT = os.path.join(os.path.dirname(__file__), "..")


def _script():
    spec = importlib.util.spec_from_file_location("mesh_ladders", os.path.join(ROOT, "examples", "mesh_ladders.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _committed() -> dict:
    with open(os.path.join(ROOT, "examples", "convergence_results", "ladders.csv"), encoding="utf-8") as fh:
        return {r["rung"]: r for r in csv.DictReader(fh)}


def test_committed_rows_are_re_measured():
    """The coarse and level-0 rows, measured again from the meshes, equal the committed
    ones to the digits written (4 significant)."""
    mod = _script()
    table = {r["rung"]: r for r in mod.rows(legacy=("coarse",), levels=(0,))}
    committed = _committed()
    for rung in ("coarse", "level 0"):
        for key in mod.COLUMNS[2:]:
            mine = table[rung][key]
            want = committed[rung][key]
            assert (f"{mine:.4g}" if isinstance(mine, float) else str(mine)) == want, (rung, key)


def test_family_shrinks_every_measured_length_by_the_same_ratio():
    """Levels 0-3 of the committed table: the first layer, the flat's cells and the medial
    surface's mean edge each shrink by 1.5 per level (to the 4 digits written), the arcs'
    faceting error (a sagitta, second order) by 1.5^2 = 2.25; the legacy ladder's first
    layer shrinks by a different ratio at each rung (2.9, 3.6), so it is not a refinement."""
    c = _committed()
    levels = [c[f"level {k}"] for k in range(4)]
    for key, ratio in (("first_layer_um", 1.5), ("flat_cell_um", 1.5), ("medial_edge_um", 1.5),
                       ("facet_error_um", 2.25)):
        v = [float(r[key]) for r in levels]
        for a, b in zip(v, v[1:]):
            assert a / b == pytest.approx(ratio, rel=2e-3), key
    first = [float(c[r]["first_layer_um"]) for r in ("coarse", "medium", "fine")]
    legacy = [a / b for a, b in zip(first, first[1:])]
    assert legacy[0] == pytest.approx(2.88, abs=0.01) and legacy[1] == pytest.approx(3.56, abs=0.01)
    assert max(float(c[r]["facet_error_um"]) for r in ("coarse", "medium")) > 25.0  # against a 50 um half-gap


def test_first_closure_rows_are_re_run():
    """examples/first_closure.py's committed level-0 record (the main job on level 0 of the
    family, h = 25 us): its first 4 ms re-run here equal the committed rows to the 6 digits
    written (the first contact event, 1.6-3.85 ms, included)."""
    import numpy as np

    spec = importlib.util.spec_from_file_location("first_closure", os.path.join(ROOT, "examples", "first_closure.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    committed = mod.read(0)
    rows = mod.run(0, end=4e-3)
    assert len(rows) == 161 and committed["t"][160] == pytest.approx(4e-3)  # t = 0 and 160 steps
    assert max(committed["force_x"][:161]) > 2e-3  # the first graze is in the span
    for k, r in enumerate(rows):
        for key in mod.COLUMNS:
            assert f"{float(r[key]):.6g}" == f"{committed[key][k]:.6g}", (k, key)


def test_fold_deflection_rows_are_re_run_and_grow_with_refinement():
    """examples/fold_deflection.py (one fold under a uniform medial traction, static): levels 0
    and 1 of both tissues re-run equal the committed rows to 1e-9, and the displacement method
    is stiff on the coarser mesh: the deflection at mid-fold grows with every level, by less
    from level 1 to 2 than from 0 to 1, for the main job's tissue and the isotropic one alike."""
    spec = importlib.util.spec_from_file_location("fold_deflection", os.path.join(ROOT, "examples", "fold_deflection.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    with open(mod.CSV, encoding="utf-8") as fh:
        committed = {(r["tissue"], int(r["level"])): r for r in csv.DictReader(fh)}
    for tissue in mod.TISSUES:
        for level in (0, 1):
            now = mod.measure(tissue, level)
            for key in ("u_mid [m]", "u_max [m]", "u_mean [m]"):
                assert now[key] == pytest.approx(float(committed[(tissue, level)][key]), rel=1e-9), (tissue, level, key)
        u = [float(committed[(tissue, k)]["u_mid [m]"]) for k in (0, 1, 2)]
        assert u[0] < u[1] < u[2] and u[2] - u[1] < u[1] - u[0], (tissue, u)
