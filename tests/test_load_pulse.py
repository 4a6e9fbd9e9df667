"""A load's ``pulse`` (sin^2 rising and falling back to zero over its duration): read,
written and checked with the scene, and applied in a run as its closed form."""

import math

import pytest

import vfrs
from vfrs.dynamics.problem import pulse
from vfrs.errors import SceneError

Q, T, SIDE = 20.0, 2e-3, 0.01  # Pa, s, m


def box(load: dict, fixed=(), step=1e-4, end=3e-3) -> dict:
    """A 10 mm cube with a +z traction Q on its top face, the time profile ``load``."""
    return {"bodies": [{"name": "b", "mesh": {"builtin": "box", "size": [SIDE] * 3, "cells": [2, 2, 2]},
                        "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0},
                        "fixed": list(fixed),
                        "loads": [{"type": "traction", "surface": "zmax", "value": [0.0, 0.0, Q], **load}]}],
            "time": {"mode": "dynamic", "step": step, "end": end, "alpha": -0.3},
            "output": {"every": 100000, "energy": False}}


def test_pulse_is_read_written_and_checked():
    ld = vfrs.Scene.from_dict(box({"pulse": T})).bodies[0].loads[0]
    assert (ld.pulse, ld.ramp) == (T, 0.0) and ld.to_dict()["pulse"] == T
    again = vfrs.Scene.from_dict(vfrs.Scene.from_dict(box({"pulse": T})).to_dict()).bodies[0].loads[0]
    assert again.pulse == T
    assert "pulse" not in vfrs.Scene.from_dict(box({"ramp": T})).bodies[0].loads[0].to_dict()  # scenes as before
    with pytest.raises(SceneError, match=r"bodies\[0\]\.loads\[0\].*pulse.*one time profile"):
        vfrs.Scene.from_dict(box({"pulse": T, "ramp": T}))
    with pytest.raises(SceneError, match="pulse"):
        vfrs.Scene.from_dict(box({"pulse": -T}))


def test_pulse_profile_is_sin_squared_and_its_impulse_half_the_peak_times_the_duration():
    """The applied load of a run (Problem.external_force, what the march applies) is Q A
    sin^2(pi t / T) during the pulse and zero after; a free cube's momentum after it is the
    load's impulse Q A T / 2 to round-off (HHT-alpha sums the load over whole periods of
    sin^2 with the trapezoid rule, exact for it)."""
    res = vfrs.run(vfrs.Scene.from_dict(box({"pulse": T})), progress=False)
    p = res.problem
    for t in (0.0, 0.1 * T, 0.25 * T, 0.5 * T, 0.8 * T, T, 1.3 * T):
        fz = p.external_force(t)[2::3].sum()
        exact = Q * SIDE**2 * (math.sin(math.pi * t / T) ** 2 if t < T else 0.0)
        assert fz == pytest.approx(exact, rel=1e-12, abs=1e-15 * Q * SIDE**2), t
    assert [pulse(t, T) for t in (-T, 0.0, T / 2, T, 2 * T)] == [0.0, 0.0, 1.0, 0.0, 0.0]
    momentum = (p.M @ res.v.ravel())[2::3].sum()
    assert momentum == pytest.approx(Q * SIDE**2 * T / 2, rel=1e-10)
