"""Effects own their outputs (issue 31, item 2): a measure written outside the package is one
class registered in this file, and a run's summary and summary.json show it; output, plot and
summary ask the effects (their hooks) instead of importing an effect's module."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import numpy as np
import pytest

import vfrs
from vfrs.signals import peak
from vfrs.summary import Measure, MEASURES, Quantity, register_measure

PKG = Path(vfrs.__file__).parent


class PeakKineticEnergy(Measure):
    """A measure from outside the package: the largest kinetic energy of the run."""

    name = "peak_kinetic_energy"

    @classmethod
    def measures(cls, run):
        if "kinetic_energy" not in run.history:
            return {}
        val, when = peak(run.t, run.history["kinetic_energy"])
        return {"motion": {"peak_kinetic_energy": Quantity(val, "J", "peak kinetic energy", t=when, over="run")}}

    @classmethod
    def notes(cls, run, sections):
        return ["the kinetic energy is the bodies' (M v . v / 2)"] if "motion" in sections else []


@pytest.fixture
def measure():
    register_measure(PeakKineticEnergy)
    yield
    MEASURES.unregister("peak_kinetic_energy")


def scene():
    """A block dropped onto its support: one body, a few dynamic steps with energies."""
    return vfrs.Scene.from_dict({
        "bodies": [{"name": "block", "mesh": {"builtin": "box", "size": [0.01, 0.01, 0.005], "cells": [2, 2, 1]},
                    "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0}, "fixed": ["zmin"]}],
        "gravity": [0.0, 0.0, -9.81], "time": {"step": 1e-3, "end": 5e-3}, "output": {"energy": True}})


def test_a_measure_from_outside_is_in_the_summary_and_summary_json(measure, tmp_path):
    res = vfrs.run(scene(), out=tmp_path / "out", progress=False)
    q = res.results["motion"]["peak_kinetic_energy"]
    assert q.value == pytest.approx(float(np.max(res.history["kinetic_energy"])), rel=0, abs=0) and q.value > 0
    saved = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert saved["motion"]["peak_kinetic_energy"]["unit"] == "J"
    assert "the kinetic energy is the bodies' (M v . v / 2)" in saved["notes"]
    assert "peak kinetic energy" in res.summary()
    # read back from the folder: the same section
    assert vfrs.load(tmp_path / "out").summary["motion"]["peak_kinetic_energy"].value == q.value


def test_without_the_measure_the_summary_has_no_such_section(tmp_path):
    res = vfrs.run(scene(), progress=False)
    assert "motion" not in res.results


def test_summary_names_ask_the_effects():
    """sweep.summary_names lists what the effects and measures declare (no list by hand)."""
    from vfrs.studies.sweep import summary_names

    names = summary_names(vfrs.Scene.load(Path(__file__).parents[1] / "examples" / "m5_collision.toml"))
    assert {"phonation.f0", "contact.peak_force.left", "contact.contact_quotient", "window.cycles"} <= set(names)


def imports(path: Path) -> set:
    """The vfrs modules a file imports (absolute names), at any depth of the code."""
    tree = ast.parse(path.read_text())
    package = ".".join(("vfrs",) + path.relative_to(PKG).parent.parts)
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = package.rsplit(".", node.level - 1)[0] if node.level else ""
            mod = ".".join(x for x in (base, node.module or "") if x)
            out.add(mod)
            out.update(f"{mod}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


@pytest.mark.parametrize("path", ["output", "plot.py", "summary", "signals.py", "history.py"])
def test_output_plot_and_analysis_import_no_effect_module(path):
    """They ask the effects through vfrs.effects' hooks (and the registry), not by import: none
    imports a module of a registered effect (tests/registered.py: flow, enforcement, acoustics, ...)."""
    from registered import effect_packages

    effects = tuple(effect_packages())
    assert {"vfrs.flow", "vfrs.enforcement", "vfrs.acoustics"} <= set(effects)
    files = sorted((PKG / path).rglob("*.py")) if (PKG / path).is_dir() else [PKG / path]
    found = set().union(*(imports(f) for f in files))
    assert not [m for m in found if m in effects or m.startswith(tuple(e + "." for e in effects))], sorted(found)


def test_analysis_and_result_are_no_circle():
    for f in [PKG / "signals.py", *sorted((PKG / "summary").rglob("*.py"))]:
        assert not [m for m in imports(f) if m.startswith("vfrs.result")], f


def test_fields_is_defined_once():
    defs = [p for p in PKG.rglob("*.py") if any(isinstance(n, ast.Assign) and any(
        isinstance(t, ast.Name) and t.id == "FIELDS" for t in n.targets) for n in ast.parse(p.read_text()).body)]
    assert [p.relative_to(PKG).as_posix() for p in defs] == ["scene/model.py"]
