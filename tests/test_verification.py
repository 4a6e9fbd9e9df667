"""vfrs.studies.verification: the observed order, Richardson extrapolation and GCI of a three-run study
(Celik et al., J. Fluids Eng. 130, 078001, 2008), checked on sequences of known order, on
oscillatory / divergent / round-off sequences, and on HHT-alpha's second order in time on a
small cantilever (issue 32, item 6)."""

import json
import math
import re

import pytest

from vfrs.studies.verification import FS, next_refinement, observed_order, verify

RATIOS = {
    "constant 2": (1.0, 2.0, 4.0),
    "constant 1.5": (1.0, 1.5, 2.25),
    "r21 1.5, r32 1.8": (1.0, 1.5, 2.7),
    "r21 1.3, r32 1.92": (1.0, 1.3, 2.5),   # the fixed-point iteration does not settle: bisection
    "r21 3, r32 1.17": (1.0, 3.0, 3.5),     # R = e21/e32 > 1, yet converging (docs/converge.md)
}


@pytest.mark.parametrize("p", [1.0, 2.0, 4.0])
@pytest.mark.parametrize("ratios", list(RATIOS), ids=list(RATIOS))
@pytest.mark.parametrize("C", [0.3, -0.05])
def test_known_order_and_limit_recovered(p, ratios, C):
    phi0, h = 2.5, [0.1 * x for x in RATIOS[ratios]]
    v = verify([phi0 + C * hi**p for hi in h], h)
    assert v.kind == "monotone"
    assert v.order == pytest.approx(p, abs=1e-6)
    assert v.extrapolated == pytest.approx(phi0, rel=1e-9)
    assert v.low < phi0 < v.high  # the GCI band about the finest run holds the limit
    assert v.e_ext21 == pytest.approx(abs(C * h[0] ** p / phi0), rel=1e-6)
    assert v.asymptotic_ratio == pytest.approx(1.0, abs=0.1)


@pytest.mark.parametrize("p", [1.0, 2.0, 4.0])
@pytest.mark.parametrize("ratios", ["constant 2", "r21 1.5, r32 1.8"])
def test_small_higher_order_term(p, ratios):
    """phi = phi0 + C h^p + D h^(p+1): the issue's tolerances, 0.1 in order, 1e-3 relative."""
    phi0, h = 1.0, [0.05 * x for x in RATIOS[ratios]]
    v = verify([phi0 + 0.2 * hi**p + 0.05 * hi ** (p + 1) for hi in h], h)  # D h / C <= 5 % here
    assert v.kind == "monotone"
    assert abs(v.order - p) < 0.1
    assert v.extrapolated == pytest.approx(phi0, rel=1e-3)
    assert abs(v.order - p) > 1e-6  # the term is there: not the exact-sequence case again


def test_constant_ratio_takes_one_fixed_point_step():
    p, it = observed_order(0.01, 0.04, 2.0, 2.0)
    assert (p, it) == (pytest.approx(2.0, abs=1e-12), 1)


def test_gci_formulas():
    """GCI21 = Fs e_a21 / (r21^p - 1) and its coarser-pair sibling, spelled out for one case."""
    phi, h = (1.01, 1.04, 1.16), (1.0, 2.0, 4.0)
    v = verify(phi, h)
    assert v.order == pytest.approx(2.0)
    assert v.gci_fine == pytest.approx(FS * (0.03 / 1.01) / 3)
    assert v.gci_medium == pytest.approx(FS * (0.12 / 1.04) / 3)
    assert v.gci_coarse == pytest.approx(FS * (0.12 / 1.16) * 4 / 3)
    assert v.extrapolated == pytest.approx(1.0)
    assert v.extrapolated32 == pytest.approx(1.0)


def test_celik_table_values_second_hand():
    """Celik et al.'s worked example as remembered (not read from the paper in this session:
    docs/converge.md): phi = 6.063, 5.972, 5.863 with r21 = 1.5, r32 = 1.333 (N = 18000, 8000,
    4500 cells in 2-D) give p = 1.53, phi_ext21 = 6.1685, e_a21 = 1.5 %, e_ext21 = 1.7 %,
    GCI21 = 2.2 %, to the digits printed."""
    v = verify([6.063, 5.972, 5.863], [1.0, 1.5, 1.5 * math.sqrt(8000 / 4500)])
    assert round(v.order, 2) == 1.53
    assert round(v.extrapolated, 4) == 6.1685
    assert round(100 * v.e_a21, 1) == 1.5
    assert round(100 * v.e_ext21, 1) == 1.7
    assert round(100 * v.gci_fine, 1) == 2.2


def test_oscillatory_gives_the_band_and_no_extrapolation():
    v = verify([1.00, 1.10, 0.95], [1.0, 2.0, 4.0])
    assert v.kind == "oscillatory" and v.R < 0
    assert v.order is None and v.extrapolated is None and v.gci_fine is None
    assert (v.low, v.high) == (0.95, 1.10)
    assert v.uncertainty == pytest.approx(0.10)
    assert "no extrapolation" in v.describe("x") and "oscillatory" in v.words


@pytest.mark.parametrize("phi,h", [
    ([1.00, 1.10, 1.15], [1.0, 2.0, 4.0]),           # the change grows as h falls
    ([2.0 + 0.1 / x for x in (1.0, 2.0, 4.0)], [1.0, 2.0, 4.0]),  # error ~ 1/h
    ([1.0 + x for x in (1.0, 1.6, 2.0)], [1.0, 1.6, 2.0]),  # p = 1 but r32 < r21 breaks R < 1 only
])
def test_divergent_gives_no_extrapolation(phi, h):
    v = verify(phi, h)
    if h == [1.0, 1.6, 2.0]:  # R = 1.5 > 1, yet monotone for these ratios: the general test
        assert v.kind == "monotone" and v.order == pytest.approx(1.0)
        return
    assert v.kind == "divergent"
    assert v.order is None and v.extrapolated is None and v.gci_fine is None
    assert (v.low, v.high) == (min(phi), max(phi))
    assert "divergent" in v.describe("x")


def test_round_off_is_converged():
    v = verify([3.0, 3.0 * (1 + 1e-15), 3.0 * (1 - 1e-15)], [1.0, 2.0, 4.0])
    assert v.kind == "converged" and v.extrapolated is None and v.gci_fine == 0.0
    assert v.describe("f0", "Hz").endswith("converged to round-off")
    assert verify([3.0, 3.001, 3.004], [1.0, 2.0, 4.0]).kind == "monotone"


def test_describe_and_to_dict():
    v = verify([18.3e-3, 18.6e-3, 19.8e-3], [1.0, 2.0, 4.0])
    line = v.describe("peak contact force", "mN", 1e3)
    assert re.fullmatch(r"peak contact force 18\.3 mN \+- 0\.1 \(0\.68 %\) at the finest run; "
                        r"observed order 2; monotone", line), line
    d = json.loads(json.dumps(v.to_dict()))
    assert d["kind"] == "monotone" and d["order"] == pytest.approx(2.0) and d["phi"][0] == 18.3e-3
    assert d["uncertainty"] == pytest.approx(v.gci_fine * 18.3e-3)


def test_cost_text():
    assert next_refinement(18.6, 18.3, 10.0, 34.0).text() == "the next mesh buys 1.6 % for 3.4x the time"
    assert next_refinement(18.6, 18.3, 10.0, 20.0, "step").text() == "halving the step buys 1.6 % for 2x the time"
    # with the limit: how much closer the finer run is, relative to the limit
    c = next_refinement(18.6, 18.3, 10.0, 34.0, limit=18.2)
    assert c.gain == pytest.approx(0.3 / 18.2) and c.to_dict()["factor"] == pytest.approx(3.4)


@pytest.mark.parametrize("phi,h", [([1, 2], [1, 2]), ([1, 2, 3], [2, 1, 4]), ([1, math.nan, 3], [1, 2, 4])])
def test_bad_input(phi, h):
    with pytest.raises(ValueError):
        verify(phi, h)


def _tip(h: float) -> float:
    import vfrs
    from vfrs.cli import load_scene

    scene = load_scene("examples/cantilever.toml", [
        "bodies[0].mesh.cells=[6, 2, 2]", f"time.step={h}", "time.end=0.04", "output.every=1000000",
        # a smooth (quintic) ramp: a sudden load makes the first step's O(h) error dominate
        "bodies[0].loads=[{ type = 'traction', surface = 'xmax', value = [0.0, 0.0, -50.0], ramp = 0.02 }]"])
    result = vfrs.run(scene, progress=False)
    return float(result.displacement("beam")[result.node((0.02, 0.004, 0.002)), 2])


def test_hht_second_order_on_a_cantilever():
    """HHT-alpha (alpha = -0.1) is second order in the step: the tip deflection at 40 ms on
    steps h, h/2, h/4 (h = 1 ms) gives p within 0.1 of 2, and the extrapolated value agrees
    with a run at h/16 to 1e-4 relative (the finest of the three is off by 1e-4)."""
    h = [2.5e-4, 5e-4, 1e-3]
    v = verify([_tip(x) for x in h], h)
    assert v.kind == "monotone"
    assert abs(v.order - 2.0) < 0.1
    reference = _tip(6.25e-5)
    assert v.extrapolated == pytest.approx(reference, rel=1e-4)
    assert abs(v.value - reference) > abs(v.extrapolated - reference)
    assert v.low < reference < v.high


def test_one_error_policy_for_an_axis():
    """axis_error is the one reading of an axis's study (vfrs converge's error of a run and
    the accuracy report's reference both use it): the run's GCI and the extrapolation when
    monotone, nothing when converged, the range of the three values otherwise (not a bound)."""
    from vfrs.studies.verification import axis_error

    mono = verify([1.0, 1.1, 1.5], [1.0, 2.0, 4.0])
    part = axis_error(mono)
    assert part.bound and part.gci == mono.gci_fine and part.shift == mono.extrapolated - 1.0
    assert part.high == -part.low == mono.gci_fine * 1.0
    assert axis_error(mono, 2).gci == mono.gci_coarse
    osc = axis_error(verify([1.0, 1.2, 0.9], [1.0, 2.0, 4.0]), 1)
    assert (osc.gci, osc.shift, osc.low, osc.high, osc.bound) == (None, 0.0, 0.9 - 1.2, 0.0, False)
    flat = axis_error(verify([2.0, 2.0, 2.0], [1.0, 2.0, 4.0]))
    assert (flat.gci, flat.low, flat.high, flat.bound) == (0.0, 0.0, 0.0, True)
