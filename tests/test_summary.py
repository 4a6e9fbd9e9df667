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

from vfrs import summary
from vfrs.cli import load_scene, main

ROOT = os.path.join(os.path.dirname(__file__), "..")


@pytest.mark.parametrize("cells_lower,cells_upper", [((3, 3, 2), (3, 3, 2)), ((4, 4, 2), (3, 3, 2))])
def test_two_blocks_report_their_interface_once(cells_lower, cells_upper):
    """Two W x W blocks pressed together (the patch test: uniform pressure, uniaxial stress):
    every triangle of each block's contact face has loaded vertices, so each block's contact
    patch is its whole face at the current positions, W^2 (1 + nu d / 2H)^2 (lateral
    expansion nu p / E with p = E d / 2H; 100.3 mm^2). The summary's contact area is that
    interface once; the paper's definition, summed over both surfaces, is twice it. The
    effective area (sum p a)^2 / sum p^2 a of a uniform pressure is the reference face W^2,
    per block (the nodal pressures are uniform to 1e-9 in test_patch_lagrange), and so is
    the loaded nodes' tributary area (``contact_area_nodal``: every node of the face is
    loaded). The exact-disc sensor reads that uniform pressure (the force-weighted mean
    pressure of a uniform field is the field), from a disc holding the face's nodes."""
    r = patch_run(cells_lower, cells_upper)["result"]
    face = PATCH_W**2 * (1 + PATCH_NU * PATCH_D / (2 * PATCH_H)) ** 2
    co = r.results["contact"]
    assert co["max_contact_area"].value == pytest.approx(face, rel=1e-12)
    assert co["max_contact_area"].body in ("lower", "upper")
    assert co["max_contact_area_summed"].value == pytest.approx(2 * face, rel=1e-12)
    for b in ("lower", "upper"):
        assert r.history[f"contact_area.{b}"][-1] == pytest.approx(face, rel=1e-12)
        assert r.history[f"contact_area_effective.{b}"][-1] == pytest.approx(PATCH_W**2, rel=1e-9)
        assert r.history[f"contact_area_nodal.{b}"][-1] == pytest.approx(PATCH_W**2, rel=1e-12)
    assert r.history["contact_area_nodal"][-1] == pytest.approx(2 * PATCH_W**2, rel=1e-12)
    disc = r.history["contact_pressure_disc"][-1]
    assert disc == pytest.approx(r.history["contact_pressure_force_weighted"][-1], rel=1e-8) and disc > 0
    assert r.history["contact_pressure_disc_nodes"][-1] >= 1
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
    q = summary.Quantity(float(np.mean(oq)), "1", "open quotient", per_cycle=oq, over="window")
    assert q.text() == "0.79 (per cycle 0.66-1.00, sd 0.19, 3 cycles)"
    # in display units (ms), with the count of contacts when the means are per contact
    d = summary.Quantity(1.8e-3, "s", "contact duration", per_cycle=(0.25e-3, 1.9e-3, 3.25e-3), per="contact")
    assert d.text() == "1.8 ms (per contact 0.2-3.2, sd 1.5, 3 contacts)"
    # one cycle: no spread to give, said so
    assert summary.Quantity(0.5, "1", "x", per_cycle=(0.5,)).text() == "0.5 (1 cycle)"
    # a round trip through summary.json keeps the per-cycle values and the grouping
    back = summary.Quantity.from_dict(json.loads(json.dumps(q.to_dict())))
    assert back.text() == q.text() and back.over == "window"


def test_printed_summary_groups_whole_run_and_window_quantities():
    """The header no longer claims the window for everything: first contact and the peaks
    are over the whole run, under their own heading; f0, the quotients and the per-cycle
    means under the window's, which states its interval and its cycles."""
    h, _, _ = _synthetic_run()
    s = summary.summarize(h)
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
    assert summary.Summary.from_dict(json.loads(json.dumps(s.to_dict()))).text() == text


def test_penetration_at_round_off_prints_as_zero():
    """A Lagrange contact leaves a penetration of round-off (the main job: 4.6e-19 m); below
    1e-12 of the mean tetrahedron edge it prints as 0 (below round-off), the value itself is
    kept in summary.json. A real penetration prints as a length; an exact zero as 0."""
    h, _, _ = _synthetic_run()
    h["max_penetration"] = np.where(h["active_pairs"] > 0, 3.6e-19, 0.0)
    co = summary.contact(h, length_scale=5e-4)
    q = co["max_penetration"]
    assert q.value == 3.6e-19 and q.below_roundoff and q.text() == "0 (below round-off)"
    assert q.roundoff == pytest.approx(5e-16) and "tetrahedron edge" in q.scale
    assert co["max_intersection_volume"].text() == "0 mm^3"  # exactly zero: no round-off to speak of
    h["max_penetration"] = np.where(h["active_pairs"] > 0, 2e-6, 0.0)
    assert summary.contact(h, length_scale=5e-4)["max_penetration"].text().startswith("0.002 mm at t = ")
    # forces: a body whose peak force is round-off of the other's
    h["contact_force.left"] = h["contact_force.right"] * 1e-14
    co = summary.contact(h, length_scale=5e-4)
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
    assert summary.element_size(r) == pytest.approx(float(np.concatenate(edges).mean()), rel=1e-12)
    assert summary.element_size({"t": np.zeros(1)}) is None


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


def _with_error(q, rel, bound=True, key="x.q"):
    section, name = key.split(".", 1)
    s = summary.Summary({section: {name: q}}).with_errors({key: {"relative": rel, "bound": bound}}, "a study")
    return s, s[section][name].text()


def test_values_have_the_digits_their_error_supports():
    """Issue 43: "2.2 kPa +- 120 %" is "2 kPa (+- 120 %)": a value is rounded to the decimal of
    its error's first significant digit (never past its own first digit); a per-cycle mean and
    its spread likewise; an unknown or zero error leaves the digits as they were."""
    cases = [(summary.Quantity(2228.0, "Pa", "p"), 1.2, True, "2 kPa (+- 120 %)"),  # error 2.7 kPa: units
             (summary.Quantity(0.02458, "N", "f", t=0.0192), 0.31, True, "25 mN (+- 31 %) at t = 19.20 ms"),
             (summary.Quantity(1.85e-3, "s", "t1"), 0.18, False, "1.9 ms (+- 18 %, band)"),  # error 0.33 ms
             (summary.Quantity(0.3726, "m^3/s^2", "mfdr"), 0.056, True, "370 L/s^2 (+- 5.6 %)"),  # error 21: tens
             (summary.Quantity(920.0, "Pa", "p"), 1.75, False, "0.9 kPa (+- 175 %, band)"),  # error 1.6: keeps 0.9
             (summary.Quantity(0.02458, "N", "f"), None, True, "24.58 mN (+- unknown)"),
             (summary.Quantity(0.02458, "N", "f"), 0.0, True, "24.58 mN (+- 0 %)"),
             (summary.Quantity(181.7, "Hz", "f0", per_cycle=(162.0, 219.0, 164.0)), 0.27, False,
              "180 Hz (+- 27 %, band; per cycle 160-220, sd 30, 3 cycles)")]
    for q, rel, bound, text in cases:
        assert _with_error(q, rel, bound)[1] == text
    # without an error, the spread alone decides, as before
    assert summary.Quantity(181.7, "Hz", "f0", per_cycle=(162.0, 219.0, 164.0)).text().startswith("182 Hz (per cycle 162-219")


def test_a_flag_and_a_position_get_no_percentage_error():
    """A 0/1 flag says whether the study's runs agree on it; a position its error in its own
    unit (a percentage of a coordinate depends on the origin); the notes say what "band" and
    these mean; summary.json keeps it all."""
    onset = summary.Quantity(1.0, "1", "self-oscillates (1) or not (0)", over="window")
    s, text = _with_error(onset, float("inf"), False, "phonation.onset")
    assert text == "1 (not the same in every run of the study)" and "%" not in text
    assert _with_error(onset, 0.0, False, "phonation.onset")[1] == "1 (the same in every run of the study)"
    back = summary.Summary.from_dict(json.loads(json.dumps(s.to_dict())))  # an infinite error is saved as a flag's 1
    assert back["phonation"]["onset"].text() == text
    z = summary.Quantity(0.5714, "1", "peak sensor pressure at (z / fold length)")
    assert _with_error(z, 0.12, False, "contact.peak_sensor_pressure_ap")[1] == "0.57 (+- 0.07, band)"
    y = summary.Quantity(1.442e-3, "m", "peak sensor pressure at (below superior edge)")
    s, text = _with_error(y, 0.25, True, "contact.peak_sensor_pressure_below_superior")
    assert text == "1.4 mm (+- 0.4 mm)"  # 0.25 x 1.442 = 0.36 mm
    notes = summary.Summary({"contact": {"a": z}}).with_errors({"contact.a": {"relative": 0.1, "bound": False}}, "a study").notes
    assert any(n.startswith('"band"') and "not a bound" in n for n in notes)
    assert any("0/1 flag" in n and "own unit" in n for n in s.notes)


def test_closed_and_contact_quotient_are_explained_where_they_differ():
    """The closed quotient is of the glottal area, the contact quotient of contact: where their
    printed values differ a note says what each is; where they agree, nothing."""
    cq = summary.Quantity(0.22, "1", "closed quotient (1 - open quotient)", per_cycle=(0.0, 0.34, 0.32), over="run")
    kq = summary.Quantity(0.31, "1", "contact quotient (contact time / cycle)", per_cycle=(0.05, 0.56, 0.32), over="run")
    text = summary.Summary({"phonation": {"closed_quotient": cq}, "contact": {"contact_quotient": kq}}).text()
    note = next(ln for ln in text.splitlines() if "note: the closed quotient" in ln)
    assert "(0.22)" in note and "(0.31)" in note and "folds touch" in note
    same = summary.Summary({"phonation": {"closed_quotient": cq}, "contact": {"contact_quotient": cq}}).text()
    assert "note: the closed quotient" not in same


def test_warnings_are_kept_in_summary_json_and_old_files_load(tmp_path):
    """summary.json holds the run's warnings (a list); one written before they were kept (no
    such key) loads with none; the text after the summary lists them one a line."""
    s = summary.Summary({"contact": {"f": summary.Quantity(0.01, "N", "force")}}, warnings=["VfrsWarning: nu = 0.49 ..."])
    s.save(tmp_path / "summary.json")
    assert json.loads((tmp_path / "summary.json").read_text())["warnings"] == ["VfrsWarning: nu = 0.49 ..."]
    back = summary.Summary.load(tmp_path / "summary.json")
    assert back.warnings == s.warnings and set(back.sections) == {"contact"}
    assert back.warnings_text().splitlines() == ["warnings (1; shown above as they came, kept in summary.json):",
                                                 "  VfrsWarning: nu = 0.49 ..."]
    old = s.to_dict()
    del old["warnings"]
    assert summary.Summary.from_dict(old).warnings == [] and summary.Summary.from_dict(old).warnings_text() == ""


def test_vfrs_run_repeats_the_warnings_after_the_summary(tmp_path):
    """A plausibility warning (a subglottal pressure typed in kPa) is printed at load, above
    the summary; vfrs run repeats it after the summary, one line under a heading, after the
    line that says how to get error bars (the scene names no converge study), and
    summary.json keeps it."""
    import subprocess
    import sys

    out = tmp_path / "out"
    sets = ['bodies[0].mesh.resolution="coarse"', 'bodies[1].mesh.resolution="coarse"', "flow.subglottal_pressure=0.8",
            "time.end=0.002"]
    p = subprocess.run([sys.executable, "-m", "vfrs", "run", "examples/m5_phonation.toml", "-o", str(out), "--no-progress",
                        *[a for s in sets for a in ("--set", s)]], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert "vfrs: warning: PlausibilityWarning: examples/m5_phonation.toml: flow.subglottal_pressure" in p.stderr
    lines = p.stdout.splitlines()
    at = lines.index("warnings (1; shown above as they came, kept in summary.json):")
    assert lines[at + 1].startswith("  PlausibilityWarning: examples/m5_phonation.toml: flow.subglottal_pressure: ")
    assert at + 2 == len(lines)  # the last thing printed
    assert lines[at - 1].startswith("error bars: none (the scene names no converge study); `vfrs converge ")
    assert lines.index(f"output: {out}") < at - 1 and lines.index("results:") < at
    saved = json.loads((out / "summary.json").read_text())["warnings"]
    assert saved == [lines[at + 1].strip()]


def test_a_run_keeps_the_warnings_it_showed():
    """vfrs.run (no command line): the scene's plausibility warnings and those shown while it
    ran are in res.results.warnings, each once."""
    import warnings

    import vfrs
    from vfrs.errors import VfrsWarning

    with pytest.warns(vfrs.PlausibilityWarning):
        scene = load_scene(os.path.join(ROOT, "examples", "m5_phonation.toml"),
                                    ['bodies[0].mesh.resolution="coarse"', 'bodies[1].mesh.resolution="coarse"',
                                     "flow.subglottal_pressure=0.8", "time.end=0.001"])

    from vfrs.run.lifecycle import warnings_kept

    seen: list = []
    with pytest.warns(VfrsWarning, match="x"), warnings_kept(seen):  # shown as before, and kept
        warnings.warn("x", VfrsWarning)
    assert seen == ["VfrsWarning: x"]
    res = vfrs.run(scene, progress=False)
    assert res.results.warnings == [f"PlausibilityWarning: {scene.plausibility[0]}"]


def test_a_warning_of_the_build_is_kept_once():
    """A fold with no support (issue 43, item 5) is warned about once the problem is built,
    inside vfrs.run: the summary keeps that warning once (it is also one of the scene's
    plausibility warnings)."""
    import vfrs

    scene = load_scene(os.path.join(ROOT, "examples", "m5_phonation.toml"),
                                ['bodies[0].mesh.resolution="coarse"', 'bodies[1].mesh.resolution="coarse"',
                                 "bodies[0].fixed=[]", "time.end=0.0005"])
    with pytest.warns(vfrs.PlausibilityWarning) as caught:
        res = vfrs.run(scene, progress=False)
    shown = [f"PlausibilityWarning: {w.message}" for w in caught if issubclass(w.category, vfrs.PlausibilityWarning)]
    assert shown and res.results.warnings == list(dict.fromkeys(shown))
    assert any("body 'right'" in w for w in res.results.warnings)
