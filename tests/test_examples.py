"""Every example is a test: import it and check the number it computes."""

import importlib.util
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_stretch_fibres_reproduces_uniform_stress_exactly():
    ex = load("stretch_fibres")
    # Uniform stress is in the P1 space: exact up to round-off, on a perturbed mesh.
    assert ex.elongation == pytest.approx(ex.elongation_exact, rel=1e-9)
    assert ex.lateral_strain == pytest.approx(ex.lateral_strain_exact, rel=1e-8)
