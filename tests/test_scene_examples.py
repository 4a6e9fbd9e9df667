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
