"""Every example scene validates, and the small ones run as they are and show their physics."""

from pathlib import Path

import numpy as np
import pytest

import vfrs
from vfrs.cli import info_text

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.toml")), ids=lambda p: p.name)
def test_every_example_scene_validates_and_builds(path):
    scene = vfrs.Scene.load(path)
    assert "effects that would run" in info_text(scene)


def test_cantilever_swings_about_its_static_deflection():
    res = vfrs.run(EXAMPLES / "cantilever.toml", progress=False)
    z = res.probe([0.02, 0.004, 0.002])["displacement"][:, 2]
    scene = vfrs.Scene.load(EXAMPLES / "cantilever.toml").to_dict()
    scene["time"] = {"mode": "static", "load_steps": 1}
    static = vfrs.run(vfrs.Scene.from_dict(scene), progress=False).probe([0.02, 0.004, 0.002])["displacement"][-1, 2]
    assert z.min() == pytest.approx(2 * static, rel=0.05)  # a sudden load overshoots to twice
    # The first turn comes half a period of the first mode (6.97 Hz by eigsh) after the load.
    assert res.t[np.argmin(z)] == pytest.approx(0.5 / 6.97, rel=0.05)


def test_bar_static_matches_FL_over_EA():
    res = vfrs.run(EXAMPLES / "bar_static.toml", progress=False)
    tip = res.probe([0.05, 0.01, 0.02])["displacement"]
    np.testing.assert_allclose(tip[:, 0], np.array([1, 2, 3]) / 3 * 300.0 * 0.05 / 20e3, rtol=1e-9)


def test_sphere_drop_sags_and_holds_its_weight():
    res = vfrs.run(EXAMPLES / "sphere_drop.toml", progress=False)
    R = res.history["reaction_force.ball.cap"]
    weight = 1070.0 * 9.81 * res.problem.bodies[0].mesh.volume
    assert R[-1, 2] == pytest.approx(weight, rel=0.05)  # damped: close to the static balance
    assert res.probe([0.0, 0.0, -0.01])["displacement"][-1, 2] < 0


def test_asymmetric_collision_example():
    """examples/m5_asymmetric.toml at a coarse resolution (right fold "coarse", 20 x 5 x 8
    cells; left fold 16 x 4 x 7, twice as stiff), 25 ms: the folds collide (Lagrange, interface
    mesh, both directions); at every step the contact forces on the two folds balance (1e-12 of
    the peak), the right fold is pushed towards +x only, no pair penetrates beyond gap_tol
    (Lagrange: round-off), every step converged, kinetic + elastic energy never exceeds the
    work the flow has done, and the contact forces' work never turns positive.
    Measured: first contact at 2.55 ms, peak |Fx| on the right fold 15.6 mN."""
    d = vfrs.Scene.load(EXAMPLES / "m5_asymmetric.toml").to_dict()
    d["bodies"][0]["mesh"]["resolution"] = "coarse"
    d["bodies"][1]["mesh"]["cells"] = [16, 4, 7]
    d["time"]["end"] = 0.025
    res = vfrs.run(vfrs.Scene.from_dict(d), progress=False)
    h = res.history
    Fr, Fl = h["contact_force.right"], h["contact_force.left"]
    peak = np.abs(Fr).max()
    on = np.flatnonzero(h["active_pairs"] > 0)
    print(f"\nasymmetric: first contact {h['t'][on[0]] * 1e3:.2f} ms, peak |Fx| {np.abs(Fr[:, 0]).max() * 1e3:.1f} mN")
    assert on.size > 20 and peak > 1e-3  # they collide, with mN forces
    assert np.abs(Fr + Fl).max() <= 1e-12 * peak
    assert Fr[:, 0].min() >= -1e-12 * peak
    assert h["max_penetration"].max() <= 1e-12
    assert h["contact_converged"].min() == 1
    excess = h["kinetic_energy"] + h["elastic_energy"] - h["external_work"]
    scale = h["external_work"].max()
    assert excess.max() <= 1e-9 * scale
    # Damping and HHT dissipation leave a wide margin in that bound, so also: the work of the
    # recorded contact forces never turns positive (measured: it ends at -6.2e-7 J; the
    # paper's plain scheme puts 4.3e-6 J in on this run).
    assert h["contact_work"].max() <= 1e-9 * scale
