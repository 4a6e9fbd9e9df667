"""``vfrs modes`` / :func:`vfrs.modes` (issue 32, item 2): the lowest eigenfrequencies and mode
shapes of each body with its fixed conditions."""

from __future__ import annotations

import numpy as np
import pytest

import vfrs
from vfrs.cli import main
from vfrs.errors import VfrsError
from vfrs.modes import modes

# A square steel-like bar, not steel: E 1 MPa, rho 1000 kg/m^3, nu 0 (no Poisson stiffening of
# the section, as Euler-Bernoulli assumes), L / a = 20 (shear and rotary inertia ~0.1 %).
L, A_SIDE, E, RHO = 0.2, 0.01, 1e6, 1000.0
F_EB = 1.8751**2 / (2 * np.pi * L**2) * np.sqrt(E * A_SIDE**4 / 12 / (RHO * A_SIDE**2))  # 1.2771 Hz


def _bar(cells, fixed=("xmin",)):
    return vfrs.Scene.from_dict({
        "bodies": [{"name": "bar", "material": {"model": "isotropic", "E": E, "nu": 0.0, "rho": RHO},
                    "mesh": {"builtin": "box", "size": [L, A_SIDE, A_SIDE], "cells": list(cells)},
                    "fixed": list(fixed)}],
        "time": {"mode": "dynamic", "step": 1e-4, "end": 1e-3}})


def test_cantilever_first_bending_frequency_converges_to_euler_bernoulli():
    """P1 tetrahedra are stiff in bending: on 40x4x4 boxes (six tets each) the first frequency
    is 19.5 % above Euler-Bernoulli's, on 80x8x8 5.1 % (measured: 1.5255 and 1.3425 Hz
    against 1.2771). The error falls by 3.8x per halving (second order), and the Richardson
    extrapolation of the two is within 1 % of the beam's (measured 0.3 %)."""
    coarse, fine = (modes(_bar(c), n=2).bodies[0] for c in [(40, 4, 4), (80, 8, 8)])
    for b in (coarse, fine):
        assert b.rigid == 0
        # the two bending modes of a square bar; the tetrahedra's split pattern turns their
        # axes to the diagonals (measured: half the kinetic energy in y, half in z)
        assert all(m.direction in "yz" and m.shares[1:].sum() > 0.99 for m in b.modes)
    e_coarse, e_fine = coarse.frequencies[0] / F_EB - 1, fine.frequencies[0] / F_EB - 1
    assert 0 < e_fine < 0.06 and e_coarse / e_fine > 3.0
    extrapolated = fine.frequencies[0] - (coarse.frequencies[0] - fine.frequencies[0]) / 3.0
    assert extrapolated == pytest.approx(F_EB, rel=0.01)
    # a cantilever's first bending mode carries 61.3 % of its mass (Euler-Bernoulli); measured 61.4 %
    assert fine.modes[0].participation[1:].sum() == pytest.approx(0.613, abs=0.01)


@pytest.mark.slow
def test_cantilever_within_two_percent_on_a_fine_bar():
    """160x8x8 (38 880 free DOFs, ~11 s): 1.8 % above Euler-Bernoulli (measured 1.2996 Hz)."""
    b = modes(_bar((160, 8, 8)), n=1).bodies[0]
    assert b.frequencies[0] == pytest.approx(F_EB, rel=0.025)


@pytest.mark.parametrize("cells", [(4, 1, 1), (12, 2, 2)])  # dense (60 DOFs) and sparse (351) paths
def test_a_free_body_has_six_zero_modes_skipped(cells):
    free = modes(_bar(cells, fixed=()), n=3).bodies[0]
    assert free.rigid == 6 and free.n_fixed == 0
    assert len(free.modes) == 3
    assert max(free.rigid_frequencies) < 1e-4 * free.frequencies[0]
    assert free.frequencies[0] > 1.0  # a free-free bar's first bending mode is well above the cantilever's
    assert "6 rigid (zero) modes skipped" in vfrs.modes(_bar(cells, fixed=()), n=1).table()


def test_cli_prints_the_table_and_writes_vtu_files(tmp_path, capsys):
    import meshio

    scene = tmp_path / "bar.toml"
    scene.write_text(_bar((10, 2, 2)).to_toml())
    out = tmp_path / "modes"
    assert main(["modes", str(scene), "-n", "3", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "body 'bar'" in text and "f [Hz]" in text and "contact, flow" in text
    assert len([ln for ln in text.splitlines() if ln.strip().split()[:1] in (["1"], ["2"], ["3"])]) == 3
    files = sorted(p.name for p in out.iterdir())
    assert files == ["bar_mode_01.vtu", "bar_mode_02.vtu", "bar_mode_03.vtu", "bar_modes.pvd", "modes.csv"]
    m = meshio.read(out / "bar_mode_01.vtu")
    shape = m.point_data["shape"]
    assert shape.shape == (len(m.points), 3)
    assert np.linalg.norm(shape, axis=1).max() == pytest.approx(1.0)
    assert np.all(shape[np.isclose(m.points[:, 0], 0.0)] == 0.0)  # the clamped end does not move
    assert (out / "bar_modes.pvd").read_text().count("<DataSet") == 3
    assert len((out / "modes.csv").read_text().splitlines()) == 4


def test_bad_n_is_a_clear_error(capsys, tmp_path):
    with pytest.raises(VfrsError, match="expected a whole number of modes, 1 or more"):
        modes(_bar((4, 1, 1)), n=0)
    with pytest.raises(VfrsError, match="1 or more"):
        modes(_bar((4, 1, 1)), n=2.5)
    scene = tmp_path / "bar.toml"
    scene.write_text(_bar((4, 1, 1)).to_toml())
    assert main(["modes", str(scene), "-n", "0"]) == 2
    assert "vfrs modes -n 0: expected 1 or more modes per body" in capsys.readouterr().err


def test_the_module_example_runs():
    import doctest
    import sys

    module = sys.modules["vfrs.modes"]  # the attribute vfrs.modes is the function (like vfrs.run)
    result = doctest.testmod(module)
    assert result.attempted > 0 and result.failed == 0
