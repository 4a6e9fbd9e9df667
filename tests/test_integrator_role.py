"""[time] is a registry role (issue 31, item 1): ``mode`` picks a registered integrator whose
``Params`` are the section's keys, the bodies' kinematics choose the Newton sibling, and an
integrator written outside the package runs a scene without touching any other file."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import vfrs
from vfrs.dynamics import INTEGRATORS
from vfrs.dynamics.integrators import HHTIntegrator, NewtonHHTIntegrator, NewtonStaticIntegrator, StaticIntegrator
from vfrs.params import param

PKG = Path(vfrs.__file__).parent


class TrapezoidalIntegrator(HHTIntegrator):
    """An integrator written outside the package: the trapezoidal rule (HHT-alpha at
    alpha = 0), with its own mode and keys (no ``alpha``)."""

    name = "trapezoidal"

    @dataclass(frozen=True)
    class Params:
        step: float = param(doc="time step", unit="s", positive=True)
        end: float = param(doc="end time", unit="s", positive=True)
        alpha = 0.0  # not a key: the rule's own

    @classmethod
    def describe(cls, params, n_steps: int) -> str:
        return f"trapezoidal rule, step {params.step:g} s, {n_steps} steps"


@pytest.fixture
def trapezoidal():
    INTEGRATORS.register(TrapezoidalIntegrator)
    yield
    INTEGRATORS.unregister("trapezoidal")


def beam(time, material=None):
    return {"bodies": [{"name": "beam", "mesh": {"builtin": "box", "size": [0.1, 0.01, 0.01], "cells": [8, 1, 1]},
                        "material": material or {"model": "isotropic", "E": 1e6, "nu": 0.3, "rho": 1000.0},
                        "fixed": ["xmin"], "loads": [{"type": "pressure", "value": 10.0, "surface": "zmax"}]}],
            "time": time, "output": {"probes": [[0.1, 0.005, 0.005]]}}


def test_an_integrator_registered_outside_runs_a_scene(trapezoidal):
    """The outside class is a mode of its own: the scene reads its keys only, writes them
    back, says what it runs, and its run equals HHT-alpha at alpha = 0 bit for bit."""
    scene = vfrs.Scene.from_dict(beam({"mode": "trapezoidal", "step": 1e-3, "end": 1e-2}))
    assert scene.time.integrator is TrapezoidalIntegrator and scene.time.n_steps == 10
    assert scene.to_dict()["time"] == {"mode": "trapezoidal", "step": 1e-3, "end": 1e-2}
    assert vfrs.Scene.from_dict(scene.to_dict()).to_dict() == scene.to_dict()
    with pytest.raises(vfrs.SceneError, match=r"time\.alpha: unknown key"):
        vfrs.Scene.from_dict(beam({"mode": "trapezoidal", "step": 1e-3, "end": 1e-2, "alpha": -0.1}))
    ours = vfrs.run(scene, progress=False).history
    ref = vfrs.run(vfrs.Scene.from_dict(beam({"mode": "dynamic", "step": 1e-3, "end": 1e-2, "alpha": 0.0})),
                   progress=False).history
    assert set(ours) == set(ref)
    for key in ref:
        np.testing.assert_array_equal(ours[key], ref[key], err_msg=key)

    from vfrs.cli import info_text

    assert "time: trapezoidal rule, step 0.001 s, 10 steps" in info_text(scene)


def test_a_mode_without_a_finite_strain_integrator_says_so(trapezoidal):
    neo = {"model": "neo_hookean", "E": 1e6, "nu": 0.3, "rho": 1000.0}
    with pytest.raises(vfrs.SceneError, match=r"time\.mode: mode = 'trapezoidal' has no integrator for finite-strain"):
        vfrs.Scene.from_dict(beam({"mode": "trapezoidal", "step": 1e-3, "end": 1e-2}, neo))


def test_mode_and_kinematics_choose_the_registered_integrator():
    """No __new__: the scene chooses the class, and the choices of mode come from the registry."""
    neo = {"model": "neo_hookean", "E": 1e6, "nu": 0.3, "rho": 1000.0}
    dyn = {"mode": "dynamic", "step": 1e-3, "end": 1e-2}
    assert vfrs.Scene.from_dict(beam(dyn)).time.integrator is HHTIntegrator
    assert vfrs.Scene.from_dict(beam(dyn, neo)).time.integrator is NewtonHHTIntegrator
    assert vfrs.Scene.from_dict(beam({"mode": "static"})).time.integrator is StaticIntegrator
    assert vfrs.Scene.from_dict(beam({"mode": "static"}, neo)).time.integrator is NewtonStaticIntegrator
    assert "__new__" not in vars(HHTIntegrator) and "__new__" not in vars(StaticIntegrator)
    with pytest.raises(vfrs.SceneError, match=r"time\.mode: 'implicit' is not one of \['dynamic', 'static'\]"):
        vfrs.Scene.from_dict(beam({"mode": "implicit"}))


def test_no_mode_name_is_branched_on_outside_the_integrators():
    """The scene reader, the CLI and the march loop ask the chosen integrator; they do not
    compare the mode with "dynamic" or "static"."""
    branch = re.compile(r"""(==|!=|\bin\b)\s*[\(\[]?\s*["'](dynamic|static)["']|choices=\(["']dynamic""")
    for path in [PKG / "scene" / "__init__.py", PKG / "cli.py", *sorted((PKG / "run").rglob("*.py"))]:
        code = path.read_text()
        code = re.sub(r'"""(.*?)"""', "", code, flags=re.S)
        assert not branch.findall(code), path


def test_effects_receive_the_constants_not_the_integrator():
    """Effects read the scheme's constants through their setup context; no file of a
    registered effect's modules (tests/registered.py: flow, enforcement, acoustics, ...)
    reaches for the integrator object."""
    from registered import effect_files

    files = effect_files()
    assert {p.relative_to(PKG).parts[0].removesuffix(".py") for p in files} >= {"flow", "enforcement", "acoustics"}
    for path in files:
        code = path.read_text()
        assert "ctx.integrator" not in code and "self.integrator" not in code, path
