"""The paper's Figs. 2-4 (examples/paper_figures.py) in its quick mode: coarse folds, 15 ms,
Ps = 0.8 kPa, detect-only, LM, penalty at three kappas, A_1 and A_4 (the paper's plain HHT
scheme) and LM in vfrs's default scheme (mass redistribution). Checks what must hold whatever
the tuning."""

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "paper_figures.py"


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    spec = importlib.util.spec_from_file_location("paper_figures", EXAMPLE)
    pf = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(pf)
    out = tmp_path_factory.mktemp("paper")
    rows, fig2, node_xyz, wall = pf.run_all(out, quick=True, log=None)
    pf.plot_all(rows, fig2, node_xyz, out)
    return pf, out, {r["label"]: r for r in rows}, fig2, node_xyz


def test_every_run_completes_with_a_finite_positive_force(quick):
    pf, out, rows, _, _ = quick
    assert set(rows) == {c["label"] for c in pf.cases(quick=True)}
    for lab, r in rows.items():
        assert not r["error"], (lab, r["error"])
        if lab == "detect-only":
            assert r["max_force_x_N"] == 0.0 and r["max_contact_area_m2"] == 0.0
            continue
        # The right fold (x > 0) is pushed laterally: +x, millinewtons for these soft folds.
        assert math.isfinite(r["max_force_x_N"]) and r["max_force_x_N"] > 0, lab
        assert r["max_force_x_N"] < 1.0, lab
        assert 0 < r["max_contact_area_m2"] < 1e-3, lab


def test_normalised_volumes(quick):
    _, _, rows, _, _ = quick
    assert rows["detect-only"]["normalised_volume"] == 1.0
    # The folds do collide without contact forces: a sizeable overlap to normalise by.
    assert rows["detect-only"]["max_intersection_volume_m3"] > 1e-10
    for lab in ("LM", "LM (mass redist.)"):
        assert rows[lab]["normalised_volume"] < 1e-3, (lab, rows[lab]["normalised_volume"])
        assert rows[lab]["max_penetration_m"] < 1e-6, lab
    p = [rows[f"P_1e{e}"]["normalised_volume"] for e in (6, 7, 8)]
    assert p[0] > p[1] > p[2] > rows["LM"]["normalised_volume"], p
    assert p[0] < 1.0
    # A_1 is the penalty run at kappa_0; more augmentations cut the overlap.
    assert rows["A_1"]["normalised_volume"] == pytest.approx(rows["P_1e7"]["normalised_volume"], rel=1e-9)
    assert rows["A_4"]["normalised_volume"] < 0.1 * rows["A_1"]["normalised_volume"]


@pytest.mark.parametrize("lab", [
    pytest.param("LM", marks=pytest.mark.xfail(strict=True, reason=(
        "known defect (the interface mesh's extrapolated weights pull a master node, see below): since the "
        "contact correction is a product with the compliance columns (round-off differs from the solve), the "
        "plain-scheme LM run's node reaches -1.47e-5 N against a peak of 6.54e-3 N (-2.3e-3 of its peak)"))),
    "A_4", "P_1e7", "P_1e8", "LM (mass redist.)"])
def test_fig2_node_is_on_the_right_medial_surface_and_loaded(quick, lab):
    _, _, rows, fig2, node_xyz = quick
    x, y, z = node_xyz
    assert x == pytest.approx(0.05e-3, abs=1e-9)  # the right fold's medial surface
    assert abs(y + 1.36e-3) < 0.5e-3 and abs(z - 6.63e-3) < 1.0e-3
    f = np.asarray(fig2[lab]["node_fx"])
    assert np.isfinite(f).all() and f.max() > 0, lab
    # Contact pushes the right fold laterally (+x); tilted master normals of the deformed
    # left fold may give a node a tiny medial component, never a sizeable one. (The interface
    # mesh's extrapolated weights can pull a master node a little: a strict xfail in
    # test_contact_interface_mesh.py shows it deterministically; in these runs it shows or not
    # with round-off, A_4 once reached -1.6e-3 of its peak.)
    assert f.min() >= -1e-3 * f.max(), (lab, f.min(), f.max())


def test_files_written(quick):
    pf, out, rows, _, _ = quick
    for name in ("fig2_node_force.csv", "fig3_fig4_summary.csv", "fig2_node_force.png", "fig3_force_vs_volume.png",
                 "fig4_area_vs_volume.png"):
        assert (out / name).stat().st_size > 100, name
    back = pf.read_summary(out / "fig3_fig4_summary.csv")
    assert len(back) == len(rows)
    assert {r["label"] for r in back} == set(rows)
    head = (out / "fig2_node_force.csv").read_text().splitlines()
    assert head[0].startswith("#") and head[1].startswith("t_s,")


@pytest.mark.parametrize("lab", ["LM", "A_4"])
def test_the_sweep_gives_the_numbers_of_a_run_in_this_process(quick, lab):
    """run_all runs every case as a task of a dask sweep and measures it from its run folder;
    run_case runs it here: the same scene and measurement, so every number is the same bit
    for bit (wall time aside), and the Fig. 2 series too."""
    pf, _, rows, fig2, _ = quick
    row, series = pf.run_case(pf.case_for(800.0, lab, quick=True), "coarse", 0.015)
    pf.normalise([row, rows["detect-only"]])
    assert {k: v for k, v in row.items() if k != "wall_s"} == {k: v for k, v in rows[lab].items() if k != "wall_s"}
    assert np.array_equal(series["node_fx"], fig2[lab]["node_fx"]) and np.array_equal(series["t"], fig2[lab]["t"])
