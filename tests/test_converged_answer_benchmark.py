"""The committed cost of a converged answer (``benchmarks/bench_converged_answer.py``,
``benchmarks/results/converged_answer/answer.{json,md}``, ``history.csv``) is the code's: its
selection is recomputed from the committed converge studies and compared, the numbers it asks
to converge are the summary's smooth ones (a short run of the main job's scene is summarized and
its tags read), and the history holds the committed run. Wall times are never re-measured.

When a study or the summary changes on purpose, re-run the benchmark and commit its results.
"""

from __future__ import annotations

import csv
import importlib.util
import json
import math
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "converged_answer"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_converged_answer",
                                                  ROOT / "benchmarks" / "bench_converged_answer.py")
    assert spec and spec.loader
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def committed():
    return json.loads((RESULTS / "answer.json").read_text())


def test_selection_is_recomputed_from_the_committed_studies(bench, committed):
    res = bench.answer(ROOT / committed["scene"], ROOT / committed["meshes_study"],
                       [ROOT / s for s in committed["step_studies"]], committed["over"])
    assert res["numbers"] == committed["numbers"] and res["no_value"] == committed["no_value"]
    assert len(res["answers"]) == len(committed["answers"]) == len(bench.TARGETS)
    pairs = list(zip(res["answers"], committed["answers"]))
    if committed["over"] == "all":
        pairs += list(zip(res["limit_cycle_answers"], committed["limit_cycle_answers"], strict=True))
    for now, was in pairs:
        assert (now["target"], now["setting"], now["closest"]) == (was["target"], was["setting"], was["closest"])
        assert now["worst"] == pytest.approx(was["worst"], rel=1e-12)
        assert set(now["above_target"]) == set(was["above_target"])
        assert now["wall_s"] == pytest.approx(was["wall_s"], rel=1e-12)


def test_a_setting_within_a_target_holds_every_number_within_it(bench, committed):
    """The selection's rule, on the committed settings: a named setting has no number above its
    target; a target with none has no setting whose every number is within it."""
    for a in committed["answers"]:
        assert set(a["errors_there"]) == set(committed["numbers"])
        ok = [r for r in committed["settings"] if all(e <= a["target"] for e in r["errors"].values())]
        if a["setting"] is None:
            assert not ok
            assert a["above_target"]
        else:
            assert not a["above_target"]
            assert min(r["wall_s"] for r in ok) == pytest.approx(a["wall_s"])


def test_the_numbers_are_the_summarys_smooth_ones(bench):
    """A 3 ms run of the main job's scene (level 0): every number tagged [smooth] is asked to
    converge, every one asked is tagged smooth or is an untagged mean over the cycles. The
    closed phase's mean pressure and the contact quotient need glottal cycles, which 3 ms does
    not have: they are absent from this summary (outputs.py makes the first with kind "smooth",
    the second untagged, as a mean over the cycles)."""
    import vfrs

    warnings.simplefilter("ignore")
    res = vfrs.run(vfrs.Scene.from_dict(bench.window_scene(bench.SCENE, 0, 3e-3)), progress=False)
    kinds = {f"{sec}.{k}": q.get("kind") for sec, items in res.results.to_dict().items() if isinstance(items, dict)
             for k, q in items.items() if isinstance(q, dict) and "value" in q}
    tagged = {q for q, kind in kinds.items() if kind == "smooth"}
    needs_cycles = {"contact.closed_phase_pressure", "contact.contact_quotient"}
    assert not needs_cycles & set(kinds)
    assert tagged == set(bench.SMOOTH) - needs_cycles
    assert all(kinds[q] is None for q in set(bench.CYCLE_MEANS) - needs_cycles)
    assert set(bench.smooth_numbers("all")) == set(bench.SMOOTH) | set(bench.CYCLE_MEANS)


def test_history_holds_the_committed_run(committed):
    with open(RESULTS / "history.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    mine = [r for r in rows if r["commit"] == committed["commit"][:10] and r["over"] == committed["over"]
            and not r.get("lever")]
    assert [float(r["target"]) for r in mine[-len(committed["answers"]):]] == [a["target"] for a in committed["answers"]]
    for r, a in zip(mine[-len(committed["answers"]):], committed["answers"]):
        assert r["setting"] == (a["setting"] or "none")
        assert float(r["worst"]) == pytest.approx(a["worst"], rel=1e-3)


def test_measured_windows_compare_with_cholmod(committed):
    """Every measured level has its K_eff solved by vfrs and by CHOLMOD to the same solution."""
    assert committed["measured"], "the committed results measured no window"
    for m in committed["measured"]:
        assert m["status"] == "ok"
        assert m["solve_vs_cholmod"] > 0 and math.isfinite(m["factor_vs_cholmod"])
        assert m["solution_difference"] < 1e-8


LEVERS = sorted(RESULTS.glob("answer_*.json"))


@pytest.mark.parametrize("path", LEVERS, ids=[p.stem for p in LEVERS])
def test_a_lever_is_measured_on_the_same_benchmark(bench, committed, path):
    """A lever's run (``--lever``): the same selection from the same studies as the baseline
    (a lever changes what a setting costs, not which settings exist), its windows measured
    with the lever's setting, its rows in the history under its name."""
    lever = json.loads(path.read_text())
    assert lever["lever"] and set(lever["lever"]) <= {"contact.column_precision"}
    assert [a["setting"] for a in lever["answers"]] == [a["setting"] for a in committed["answers"]]
    assert [a["closest"] for a in lever["answers"]] == [a["closest"] for a in committed["answers"]]
    assert all(m["status"] == "ok" and m["solution_difference"] < 1e-8 for m in lever["measured"])
    scene = bench.window_scene(bench.SCENE, 0, 1e-3, lever["lever"])
    for key, value in lever["lever"].items():
        section, name = key.split(".", 1)
        assert scene[section][name] == value
    with open(RESULTS / "history.csv", newline="") as fh:
        names = {r["lever"] for r in csv.DictReader(fh) if r["commit"] == lever["commit"][:10]}
    assert bench._lever_name(lever["lever"]) in names


def test_the_performance_page_quotes_the_committed_answer(committed):
    """docs/performance.md, "A converged answer": its closest setting, worst numbers, walls and
    memory are the committed answer's (regenerate the page's numbers with the results)."""
    page = " ".join((ROOT / "docs" / "performance.md").read_text().split())
    a, lc = committed["answers"][2], committed["limit_cycle_answers"][2]
    for text in (f"is {a['closest']}: its worst number is the first closure's impulse ({a['worst']:.0%})",
                 f"the 1 kHz band-limited peak force ({lc['worst']:.0%})", f"{a['wall_s']:.0f} s estimated",
                 f"{a['wall_now_s']:.0f} s projected", f"{a['wall_now_in_cholmod_solves']:.2g} CHOLMOD solves",
                 f"peak memory {a['peak_rss_mb']:.0f} MB", f"at {committed['commit'][:7]}"):
        assert text in page, text
    for m in committed["measured"]:
        assert f"| {m['level']} | {m['free_dofs']:,} | {m['step_s'] * 1e3:.1f} ms |" in page


def test_the_readme_quotes_the_committed_answer(committed):
    readme = " ".join((ROOT / "README.md").read_text().split())
    a, lc = committed["answers"][0], committed["limit_cycle_answers"][0]
    assert a["setting"] is None and "no setting of its studies holds every smooth number within 10 %" in readme
    label = a["closest"].replace(", ", " at ").replace(" us", " µs")
    assert f"the closest, {label}, misses by {100 * lc['worst']:.0f} %" in readme
    assert f"about {a['wall_s']:,.0f} s here" in readme
