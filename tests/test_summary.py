"""The printed results summary says what it means (issue 30, item 6): whole-run and window
quantities under their own headings, per-cycle means with their spread and only the digits
it supports, the contact area as the area of the contact patch (the paper's sum over both
surfaces under its own name), round-off printed as such, and the timings after the results."""

import contextlib
import io
import json
import os

import numpy as np
import pytest
from test_analysis import _synthetic_run
from test_contact_verification import PATCH_D, PATCH_H, PATCH_NU, PATCH_W, patch_run

import vfrs.analysis as an
from vfrs.cli import main

ROOT = os.path.join(os.path.dirname(__file__), "..")


@pytest.mark.parametrize("cells_lower,cells_upper", [((3, 3, 2), (3, 3, 2)), ((4, 4, 2), (3, 3, 2))])
def test_two_blocks_report_their_interface_once(cells_lower, cells_upper):
    """Two W x W blocks pressed together (the patch test: uniform pressure, uniaxial stress):
    every triangle of each block's contact face has loaded vertices, so each block's contact
    patch is its whole face at the current positions, W^2 (1 + nu d / 2H)^2 (lateral
    expansion nu p / E with p = E d / 2H; 100.3 mm^2). The summary's contact area is that
    interface once; the paper's definition, summed over both surfaces, is twice it. The
    effective area (sum p a)^2 / sum p^2 a of a uniform pressure is the reference face W^2,
    per block (the nodal pressures are uniform to 1e-9 in test_patch_lagrange)."""
    r = patch_run(cells_lower, cells_upper)["result"]
    face = PATCH_W**2 * (1 + PATCH_NU * PATCH_D / (2 * PATCH_H)) ** 2
    co = r.results["contact"]
    assert co["max_contact_area"].value == pytest.approx(face, rel=1e-12)
    assert co["max_contact_area"].body in ("lower", "upper")
    assert co["max_contact_area_summed"].value == pytest.approx(2 * face, rel=1e-12)
    for b in ("lower", "upper"):
        assert r.history[f"contact_area.{b}"][-1] == pytest.approx(face, rel=1e-12)
        assert r.history[f"contact_area_effective.{b}"][-1] == pytest.approx(PATCH_W**2, rel=1e-9)
    assert r.history["contact_area"][-1] == pytest.approx(2 * face, rel=1e-12)  # the paper's, unchanged
    assert co["max_effective_area"].value == pytest.approx(PATCH_W**2, rel=1e-9)
    assert co["max_effective_area_summed"].value == pytest.approx(2 * PATCH_W**2, rel=1e-9)
    text = r.results.text()
    assert "maximum contact area (one body's patch)" in text and "100.3 mm^2" in text
    assert "maximum contact area, both surfaces summed (paper)" in text and "200.6 mm^2" in text


def test_per_cycle_means_print_their_spread_and_the_digits_it_supports():
    """The issue's open quotient: per-cycle 1.0, 0.66 and 0.70 printed as 0.7855 with no
    spread. Their standard deviation is 0.19 (n - 1), so the mean is worth two decimals."""
    oq = (1.0, 0.66, 0.70)
    q = an.Quantity(float(np.mean(oq)), "1", "open quotient", per_cycle=oq, over="window")
    assert q.text() == "0.79 (per cycle 0.66-1.00, sd 0.19, 3 cycles)"
    # in display units (ms), with the count of contacts when the means are per contact
    d = an.Quantity(1.8e-3, "s", "contact duration", per_cycle=(0.25e-3, 1.9e-3, 3.25e-3), per="contact")
    assert d.text() == "1.8 ms (per contact 0.2-3.2, sd 1.5, 3 contacts)"
    # one cycle: no spread to give, said so
    assert an.Quantity(0.5, "1", "x", per_cycle=(0.5,)).text() == "0.5 (1 cycle)"
    # a round trip through summary.json keeps the per-cycle values and the grouping
    back = an.Quantity.from_dict(json.loads(json.dumps(q.to_dict())))
    assert back.text() == q.text() and back.over == "window"


def test_printed_summary_groups_whole_run_and_window_quantities():
    """The header no longer claims the window for everything: first contact and the peaks
    are over the whole run, under their own heading; f0, the quotients and the per-cycle
    means under the window's, which states its interval and its cycles."""
    h, _, _ = _synthetic_run()
    s = an.summarize(h)
    text = s.text()
    lines = text.splitlines()
    run = next(i for i, ln in enumerate(lines) if ln.startswith("  over the whole run"))
    window = next(i for i, ln in enumerate(lines) if ln.startswith("  over the window t = 50.0-100.0 ms (6 glottal cycles"))

    def where(what):
        return next(i for i, ln in enumerate(lines) if what in ln)

    for what in ("first contact", "peak contact force on right", "peak nodal contact pressure",
                 "maximum contact area (one body's patch)"):
        assert run < where(what) < window, what
    for what in ("fundamental frequency", "open quotient", "contact duration per glottal cycle",
                 "contact impulse per glottal cycle on left"):
        assert where(what) > window, what
    assert "(per cycle " in lines[where("open quotient")] and "6 cycles)" in lines[where("open quotient")]
    assert s["contact"]["first_contact"].over == "run" and s["phonation"]["f0"].over == "window"
    d = s.to_dict()
    assert {q["over"] for sec in ("phonation", "contact") for q in d[sec].values()} == {"run", "window"}
    assert an.Summary.from_dict(json.loads(json.dumps(s.to_dict()))).text() == text


def test_penetration_at_round_off_prints_as_zero():
    """A Lagrange contact leaves a penetration of round-off (the main job: 4.6e-19 m); below
    1e-12 of the mean tetrahedron edge it prints as 0 (below round-off), the value itself is
    kept in summary.json. A real penetration prints as a length; an exact zero as 0."""
    h, _, _ = _synthetic_run()
    h["max_penetration"] = np.where(h["active_pairs"] > 0, 3.6e-19, 0.0)
    co = an.contact(h, length_scale=5e-4)
    q = co["max_penetration"]
    assert q.value == 3.6e-19 and q.below_roundoff and q.text() == "0 (below round-off)"
    assert q.roundoff == pytest.approx(5e-16) and "tetrahedron edge" in q.scale
    assert co["max_intersection_volume"].text() == "0 mm^3"  # exactly zero: no round-off to speak of
    h["max_penetration"] = np.where(h["active_pairs"] > 0, 2e-6, 0.0)
    assert an.contact(h, length_scale=5e-4)["max_penetration"].text().startswith("0.002 mm at t = ")
    # forces: a body whose peak force is round-off of the other's
    h["contact_force.left"] = h["contact_force.right"] * 1e-14
    co = an.contact(h, length_scale=5e-4)
    assert co["peak_force.left"].text() == "0 (below round-off)"
    assert "(below round-off)" not in co["peak_force.right"].text()


def test_element_size_is_the_mean_tetrahedron_edge():
    r = patch_run((3, 3, 2), (3, 3, 2))["result"]
    edges = []
    for b in r.problem.bodies:
        x, tets = b.mesh.points, b.mesh.tets
        for i in range(4):
            for j in range(i + 1, 4):
                edges.append(np.linalg.norm(x[tets[:, i]] - x[tets[:, j]], axis=1))
    assert an.element_size(r) == pytest.approx(float(np.concatenate(edges).mean()), rel=1e-12)
    assert an.element_size({"t": np.zeros(1)}) is None


def test_vfrs_run_prints_the_timings_after_the_results(tmp_path):
    """`vfrs run` used to open its output with a timings line; the results come first now,
    the timings after them (before the output folder's name)."""
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(["run", os.path.join(ROOT, "examples", "cantilever.toml"), "-o", str(tmp_path / "out"),
                   "--no-progress", "--set", "time.end=0.002"])
    assert rc == 0
    lines = buf.getvalue().splitlines()
    results = next(i for i, ln in enumerate(lines) if ln.startswith("results:"))
    timings = next(i for i, ln in enumerate(lines) if ln.startswith("timings:"))
    assert results < timings and lines[timings + 1].startswith("output: ")
    log = (tmp_path / "out" / "run.log").read_text()
    assert log.index("results:") < log.index("timings:")
