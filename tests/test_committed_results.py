"""The committed results are the code's: a small subset of each committed table is re-run
here through the functions that wrote it and compared with the committed numbers, so a
committed result cannot drift from the code silently.

- ``benchmarks/results/accuracy/accuracy.csv`` (``vfrs bench accuracy``): the rows in
  ``ACCURACY_SUBSET``, re-run with :func:`vfrs.studies.accuracy.run_row` in the mode
  ``accuracy.json`` records; every committed ``error`` and ``m_*`` column is compared (never
  wall times). M5 rows are scored against the reference run ``accuracy.json`` records; the
  reference itself is re-run only with ``--runslow`` (minutes).
- ``examples/paper_results/`` (``examples/paper_figures.py``): the rows of
  ``fig3_fig4_summary.csv`` in ``PAPER_SUMMARY_SUBSET`` and a few samples of the columns of
  ``fig2_node_force.csv`` in ``FIG2_SUBSET``, re-run with ``run_case`` in the configuration
  ``run_info.txt`` records.

A failure names the file, the row and both numbers. When the code changes a result on
purpose, regenerate the committed files (and this passes again); do not loosen the
tolerance. ``VFRS_ACCURACY_RESULTS`` / ``VFRS_PAPER_RESULTS`` point the checks at another
folder (a fresh run, before committing it).
"""

import ast
import csv
import importlib.util
import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

from vfrs.studies.accuracy import run_row, run_reference
from vfrs.studies.accuracy.problems import PROBLEMS

ROOT = Path(__file__).resolve().parent.parent
ACCURACY = Path(os.environ.get("VFRS_ACCURACY_RESULTS", ROOT / "benchmarks" / "results" / "accuracy")).resolve()
PAPER = Path(os.environ.get("VFRS_PAPER_RESULTS", ROOT / "examples" / "paper_results")).resolve()

# Deterministic quantities (no wall times): the same code on the same inputs gives them to
# round-off; 1e-6 leaves room for the CSVs' printed digits and for BLAS-free round-off
# differences between machines, and nothing else.
RTOL = 1e-6
ATOL = 1e-15  # values at round-off level (a Lagrange penetration of 1e-16 m)

# -- the subset ---------------------------------------------------------------------------
# accuracy.csv rows by their key columns (problem, setting, level, step) as the CSV prints
# them (step None: static). A few cheap settings of each problem, < 1 s each.
ACCURACY_SUBSET = [
    ("block", "penalty k=1e+08", "(2, 2, 2)", None),
    ("block", "AL N=4 k0=1e+06", "(3, 3, 4)", None),
    ("hertz", "penalty k=1e+09", "8", None),
    ("bars", "lagrange", "20", 0.5),
    ("bars", "penalty k=1e+10", "10", 1.0),
    ("m5", "penalty k=1e+10", "coarse", 1e-4),  # errors against accuracy.json's extrapolated limits
    ("m5", "lagrange", "coarse graded", 1e-4),  # the graded axis
    ("m5_finite", "lagrange", "coarse", 1e-4),  # finite strain, contact inside Newton (about 8 s)
]
# fig3_fig4_summary.csv rows by (ps_Pa, label); the detect-only run normalises the volumes.
# P_1e7 in the paper's plain scheme, LM in the comparison scheme (mass redistribution).
PAPER_SUMMARY_SUBSET = [(800.0, "detect-only"), (800.0, "P_1e7"), (800.0, "LM (mass redist.)")]
# fig2_node_force.csv columns (runs of PAPER_SUMMARY_SUBSET), each checked at FIG2_SAMPLES
# rows: its largest force and rows spread evenly over the stretch where it is nonzero.
FIG2_SUBSET = ["P_1e7", "LM (mass redist.)"]
FIG2_SAMPLES = 6

# Summary columns that are the run's key or its configuration, or not deterministic.
PAPER_NOT_COMPARED = {"ps_Pa", "label", "method", "kappa_Pa_per_m", "augmentations", "scheme", "resolution", "end_s",
                      "wall_s"}


def _rel(path) -> str:
    try:
        return str(Path(path).relative_to(ROOT))
    except ValueError:
        return str(path)


def _close(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return abs(a - b) <= RTOL * max(abs(a), abs(b)) + ATOL


def _num(v):
    return float("nan") if v in ("", None) else float(v)


def _mismatch(path, key, column, committed, now) -> str:
    rel = abs(now - committed) / abs(committed) if committed not in (0.0,) and math.isfinite(committed) else float("nan")
    return (f"{_rel(path)}: row {key}: {column} committed {committed!r}, now {now!r}"
            + (f" (relative difference {rel:.3g})" if math.isfinite(rel) else ""))


def _fail_if(mismatches):
    if mismatches:
        pytest.fail("committed results differ from the code:\n  " + "\n  ".join(mismatches), pytrace=False)


# -- accuracy report ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def accuracy():
    csv_path, json_path = ACCURACY / "accuracy.csv", ACCURACY / "accuracy.json"
    with open(csv_path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    data = json.loads(json_path.read_text())
    return rows, data


def _committed_accuracy_row(rows, problem, setting, level, step):
    for r in rows:
        if (r["problem"], r["setting"], r["level"]) != (problem, setting, level):
            continue
        s = None if r["step"] == "" else float(r["step"])
        if (s is None and step is None) or (s is not None and step is not None and math.isclose(s, step, rel_tol=1e-9)):
            return r
    pytest.fail(f"{_rel(ACCURACY / 'accuracy.csv')}: no row {(problem, setting, level, step)}", pytrace=False)


@pytest.mark.parametrize("key", ACCURACY_SUBSET, ids=lambda k: f"{k[0]}|{k[1]}|{k[2]}|{k[3]}")
def test_accuracy_row_is_reproduced(accuracy, key):
    rows, data = accuracy
    path = ACCURACY / "accuracy.csv"
    problem, setting, level, step = key
    committed = _committed_accuracy_row(rows, problem, setting, level, step)
    mismatches = []
    reference = None
    needs_reference = hasattr(PROBLEMS[problem](), "reference_setting")
    if needs_reference:
        reference = ((data.get("references") or {}).get(problem) or {}).get("metrics")
        if reference is None:
            mismatches.append(f"{_rel(ACCURACY)}/accuracy.json records no {problem} reference run, so the "
                              f"committed error {committed['error']} of row {key} cannot be recomputed (regenerate)")
    now = run_row(problem, setting, level, step, mode=data["mode"], reference=reference)
    if committed["failed"] or now.failed:
        if bool(committed["failed"]) != bool(now.failed):
            mismatches.append(f"{_rel(path)}: row {key}: failed committed {committed['failed']!r}, "
                              f"now {now.failed!r}")
        _fail_if(mismatches)
        return
    columns = [c for c in committed if (c == "error" or c.startswith("m_")) and committed[c] != ""]
    if needs_reference and reference is None:
        columns = [c for c in columns if c not in ("error", "m_area_error")]
    for c in columns:
        a = _num(committed[c])
        b = now.error if c == "error" else now.metrics.get(c[2:])
        if b is None:
            mismatches.append(f"{_rel(path)}: row {key}: {c} committed {a!r}, not measured now")
        elif not _close(a, float(b)):
            mismatches.append(_mismatch(path, key, c, a, float(b)))
    _fail_if(mismatches)


def test_accuracy_table_is_the_current_grid(accuracy):
    """The committed table has exactly the rows the current grid (recorded mode) runs."""
    from vfrs.studies.accuracy import grid_cells

    rows, data = accuracy
    mode = data["mode"]
    committed = {(r["problem"], r["setting"], r["level"], None if r["step"] == "" else float(r["step"])) for r in rows}
    problems = list(dict.fromkeys(r["problem"] for r in rows))
    now = {(p, label, str(level), None if step is None else float(step))
           for p in problems for label, _, level, step in grid_cells(mode, p)}
    assert committed == now, (
        f"{_rel(ACCURACY / 'accuracy.csv')} ({mode} mode): rows not in the current grid "
        f"{sorted(committed - now, key=str)[:5]}, grid rows missing from it {sorted(now - committed, key=str)[:5]}")


def test_accuracy_reference_is_recorded_and_outside_the_grid(accuracy):
    """accuracy.json says which reference each problem was scored against, with provenance;
    a reference run is the one the code builds now (finer in mesh and step than every row)."""
    _, data = accuracy
    mode = data["mode"]
    prov = data.get("provenance") or {}
    assert prov.get("commit") and not prov.get("dirty"), (
        f"{_rel(ACCURACY / 'accuracy.json')}: provenance {prov or 'missing'} (want the commit it was run at, "
        "with no uncommitted changes in python/ or rust/)")
    refs = data.get("references") or {}
    problems = list(dict.fromkeys(r["problem"] for r in data["rows"]))
    assert set(refs) == set(problems), f"{_rel(ACCURACY / 'accuracy.json')}: references for {sorted(refs)}, rows for {problems}"
    for name in problems:
        p = PROBLEMS[name]()
        if not hasattr(p, "reference_setting"):
            assert refs[name]["kind"] == "exact", (name, refs[name])
            continue
        rec = refs[name]
        study = p.reference_study(mode)
        if study is not None:  # an extrapolated limit: its runs are the study the code builds now
            ran = sorted((r["level"], r["step"]) for r in rec["runs"])
            assert rec["kind"] == "study" and ran == sorted(study.cells()), (
                f"{_rel(ACCURACY / 'accuracy.json')}: {name} reference study ran {ran}; the code builds "
                f"{sorted(study.cells())}")
            assert set(rec["metrics"]) >= set(p.scored), (name, sorted(rec["metrics"]))
            continue
        contact, level, step = p.reference_setting(mode)
        assert (rec["method"], rec["level"]) == (contact["method"], level) and math.isclose(rec["step"], step), (
            f"{_rel(ACCURACY / 'accuracy.json')}: {name} reference {rec['method']} at {rec['level']}, "
            f"h = {rec['step']}; the code builds {contact['method']} at {level}, h = {step}")


def test_accuracy_reference_limits_are_recomputed_from_their_runs(accuracy):
    """The limits the M5 rows are scored against are the extrapolation of the committed study
    runs' numbers (vfrs.studies.accuracy.reference.estimate, recomputed here from accuracy.json's runs)."""
    from vfrs.studies.accuracy.grid import estimates

    _, data = accuracy
    for name, rec in (data.get("references") or {}).items():
        if rec.get("kind") != "study":
            continue
        p = PROBLEMS[name]()
        again = estimates(p, p.reference_study(data["mode"]), rec["runs"])
        mismatches = [_mismatch(ACCURACY / "accuracy.json", f"references.{name}.metrics", q, float(v), float(again["metrics"][q]))
                      for q, v in rec["metrics"].items() if not _close(float(v), float(again["metrics"][q]))]
        mismatches += [_mismatch(ACCURACY / "accuracy.json", f"references.{name}.quantities.{q}", "uncertainty",
                                 float(e["uncertainty"]), float(again["quantities"][q]["uncertainty"]))
                       for q, e in rec["quantities"].items()
                       if not _close(float(e["uncertainty"]), float(again["quantities"][q]["uncertainty"]))]
        _fail_if(mismatches)


@pytest.mark.slow
def test_accuracy_reference_run_is_reproduced(accuracy):
    """The M5 reference's code path, through its sensitivity check run (medium mesh,
    h = 12.5 us in full mode, about 40 s; the reference itself, on the fine mesh, takes
    about 4 min and goes through the same functions: re-run it with
    ``vfrs.studies.accuracy.run_reference("m5", "full")`` when in doubt)."""
    _, data = accuracy
    refs = data.get("references") or {}
    mismatches = []
    path = ACCURACY / "accuracy.json"
    for name, rec in refs.items():
        if rec.get("kind") != "run":
            continue
        now = run_reference(name, data["mode"], check_only=True)
        if rec.get("kind") == "study":  # the study's cheapest run, against the committed one of that cell
            run = now["runs"][0]
            committed = next(r for r in rec["runs"] if r["level"] == run["level"] and math.isclose(r["step"], run["step"]))
            for k, a in committed["metrics"].items():
                b = run["metrics"].get(k)
                if b is None or not _close(float(a), float(b)):
                    mismatches.append(_mismatch(path, f"references.{name}.runs[{run['level']}, {run['step']:g}]", k,
                                                float(a), float("nan") if b is None else float(b)))
            continue
        for k, a in (rec.get("check") or {}).get("metrics", {}).items():
            b = now["check"]["metrics"].get(k)
            if b is None or not _close(float(a), float(b)):
                mismatches.append(_mismatch(path, f"references.{name}.check", k, float(a), float("nan") if b is None else float(b)))
    _fail_if(mismatches)


# -- paper figures ------------------------------------------------------------------------
def _paper_module():
    spec = importlib.util.spec_from_file_location("paper_figures", ROOT / "examples" / "paper_figures.py")
    pf = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(pf)
    return pf


@pytest.fixture(scope="module")
def paper():
    """The subset's runs, once, in the recorded configuration: {label: (row, series)}."""
    pf = _paper_module()
    info = pf.read_run_info(PAPER / "run_info.txt")
    runs = {}
    for ps, label in PAPER_SUMMARY_SUBSET:
        runs[(ps, label)] = pf.run_case(pf.case_for(ps, label, info["quick"]), info["resolution"], info["end"])
    pf.normalise([row for row, _ in runs.values()])
    return pf, info, runs


def test_paper_run_info_is_clean():
    info = _paper_module().read_run_info(PAPER / "run_info.txt")
    assert not info["dirty"], f"{_rel(PAPER / 'run_info.txt')}: run at {info['commit']} with uncommitted changes"


@pytest.mark.parametrize("key", PAPER_SUMMARY_SUBSET, ids=lambda k: f"{k[0]:g}|{k[1]}")
def test_paper_summary_row_is_reproduced(paper, key):
    pf, _, runs = paper
    path = PAPER / "fig3_fig4_summary.csv"
    committed = [r for r in pf.read_summary(path) if r["ps_Pa"] == key[0] and r["label"] == key[1]]
    assert len(committed) == 1, f"{_rel(path)}: {len(committed)} rows for {key}"
    committed = committed[0]
    now, _ = runs[key]
    mismatches = []
    if (committed.get("error") or "") != (now.get("error") or ""):
        mismatches.append(f"{_rel(path)}: row {key}: error committed {committed.get('error')!r}, now {now.get('error')!r}")
    for c, a in committed.items():
        if c in PAPER_NOT_COMPARED or c == "error" or a is None:
            continue
        b = now.get(c)
        if b is None:
            mismatches.append(f"{_rel(path)}: row {key}: {c} committed {a!r}, not measured now")
        elif not _close(float(a), float(b)):
            mismatches.append(_mismatch(path, key, c, float(a), float(b)))
    _fail_if(mismatches)


def _read_fig2(path):
    lines = path.read_text().splitlines()
    node = ast.literal_eval(lines[0].split("ours at (m)", 1)[1].strip())
    reader = csv.reader(lines[1:])
    header = next(reader)
    table = np.array([[float(v) for v in row] for row in reader])
    return node, header, table


@pytest.mark.parametrize("label", FIG2_SUBSET)
def test_fig2_samples_are_reproduced(paper, label):
    _, _, runs = paper
    path = PAPER / "fig2_node_force.csv"
    node, header, table = _read_fig2(path)
    col = f"Fx_N[{label}]"
    assert col in header, f"{_rel(path)}: no column {col}; it has {header}"
    committed = table[:, header.index(col)]
    t_committed = table[:, 0]
    _, series = next(v for k, v in runs.items() if k[1] == label)
    mismatches = []
    if not all(_close(a, b) for a, b in zip(node, series["node_xyz"])):
        mismatches.append(f"{_rel(path)}: node committed {node}, now {series['node_xyz']}")
    if len(series["t"]) != len(t_committed):
        mismatches.append(f"{_rel(path)}: {len(t_committed)} time rows committed, {len(series['t'])} now")
    on = np.flatnonzero(committed != 0)
    picks = [int(np.argmax(committed))] + ([int(i) for i in on[np.linspace(0, on.size - 1, FIG2_SAMPLES - 1).astype(int)]]
                                           if on.size else [])
    for j in sorted(set(picks)):
        if j >= len(series["t"]):
            continue
        key = f"t_s = {t_committed[j]:g}"
        # The CSV prints t with 6 and forces with 7 significant digits.
        if not math.isclose(t_committed[j], series["t"][j], rel_tol=1e-5, abs_tol=1e-12):
            mismatches.append(_mismatch(path, key, "t_s", float(t_committed[j]), float(series["t"][j])))
        if not _close(float(committed[j]), float(series["node_fx"][j])):
            mismatches.append(_mismatch(path, key, col, float(committed[j]), float(series["node_fx"][j])))
    _fail_if(mismatches)


def _m5_reference_rows(data) -> list:
    """docs/accuracy.md's table of the M5 reference study, as the committed accuracy.json gives it."""
    ref = data["references"]["m5"]
    runs = {(r["level"], r["step"]): r["metrics"] for r in ref["runs"]}
    out = []
    for q, (name, u, s) in {"impulse": ("contact impulse", "µN s", 1e6), "peak_force": ("peak contact force", "mN", 1e3),
                            "peak_pressure": ("peak pressure on a 1 mm^2 sensor", "kPa", 1e-3)}.items():
        e, c = ref["quantities"][q], ref["cross"][q]

        def f(lv, h):
            return f"{runs[(lv, h)][q] * s:.4g}"

        mesh = " / ".join(f(lv, 6.25e-6) for lv in ("medium", "fine", "finer")) + f" {u}, {e['mesh']['kind']}"
        step = " / ".join(f("fine", h) for h in (25e-6, 12.5e-6, 6.25e-6)) + f" {u}, {e['step']['kind']}"
        if e["step"]["kind"] == "monotone":
            step += f" (order {e['step']['order']:.2f}, GCI {e['step']['gci_fine']:.1%})"
        limit = f"{e['value'] * s:.4g} {u} ± {e['uncertainty']:.1%} ({'bound' if e['bound'] else 'band'})"
        cross = " / ".join(f(lv, 6.25e-6) for lv in ("coarse graded", "medium graded", "fine graded")) + f" {u}, {c['kind']}"
        if c["kind"] == "monotone":
            cross += f" (order {c['order']:.2f}, extrapolated {c['extrapolated'] * s:.4g})"
        out.append(f"| {name} | {mesh} | {step} | {limit} | {cross} |")
    return out


def test_accuracy_page_and_readme_headline_are_the_committed_table(accuracy):
    """docs/accuracy.md's numbers for the M5 folds are those of the committed report: the
    reference study's table, the recommendations verbatim, the cost of the methods and of the
    refactoring path (medium mesh, h = 25 us); the README's headline quotes the same."""
    from vfrs.studies.accuracy import AccuracyReport

    rows, data = accuracy
    page = (ROOT / "docs" / "accuracy.md").read_text()
    flat = " ".join(page.split())
    readme = " ".join((ROOT / "README.md").read_text().split())
    m5 = {r["setting"]: r for r in rows if r["problem"] == "m5" and r["level"] == "medium"
          and r["step"] and math.isclose(float(r["step"]), 25e-6)}
    assert m5, "accuracy.csv has no M5 medium h = 25 us rows"
    walls = [float(r["wall_s"]) for k, r in m5.items() if "refactor" not in k]
    refactor, penalty = float(m5["penalty k=1e+10 refactor"]["wall_s"]), float(m5["penalty k=1e+10"]["wall_s"])
    cost, dear = f"{min(walls):.1f}-{max(walls):.1f}", f"{refactor:.1f} s ({refactor / penalty:.0f}x)"
    rep = AccuracyReport.load(ACCURACY)
    recs = [s if s.startswith("m5:") else "m5: " + s
            for t in rep.targets("m5") for s in rep.recommendation("m5", t).split(" m5: ")]
    missing = [line for line in _m5_reference_rows(data) if line not in page]
    missing += [r for r in recs if " ".join(r.split()) not in flat]
    missing += [x for x in (f"took {data['seconds']:.0f} s on 1 worker", f"every method costs {cost} s", dear) if x not in flat]
    assert not missing, f"docs/accuracy.md: not the committed report's numbers: {missing}"
    q = data["references"]["m5"]["quantities"]
    head = [f"{q['impulse']['uncertainty']:.1%} (impulse)", f"{q['peak_force']['uncertainty']:.1%} (peak force)",
            f"{q['peak_pressure']['uncertainty']:.1%} (sensor pressure)", f"{cost} s per run", dear]
    assert not [h for h in head if h not in readme], f"README.md's headline: not the committed report's: {head}"


# -- the two-bar force histories of the contact schemes (examples/contact_schemes.py) ------
SCHEMES_RESULTS = ROOT / "examples" / "schemes_results"
SCHEMES_SUBSET = [("mass_redistribution", 1), ("stabilized", 4)]


@pytest.mark.parametrize("scheme,substeps", SCHEMES_SUBSET)
def test_contact_schemes_row_is_reproduced(scheme, substeps):
    """bars_summary.csv's row and bars_force.csv's history of one run, re-run."""
    spec = importlib.util.spec_from_file_location("contact_schemes", ROOT / "examples" / "contact_schemes.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    now = mod.run_case(scheme, substeps)
    path = SCHEMES_RESULTS / "bars_summary.csv"
    with open(path, newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if (r["scheme"], int(r["substeps"])) == (scheme, substeps)]
    assert len(rows) == 1, f"{_rel(path)}: no row {scheme, substeps}"
    mismatches = [_mismatch(path, (scheme, substeps), k, _num(v), now["row"][k]) for k, v in rows[0].items()
                  if k not in ("scheme", "substeps") and not _close(_num(v), float(now["row"][k]))]
    path = SCHEMES_RESULTS / "bars_force.csv"
    with open(path, newline="") as fh:
        f = [float(r["F_over_F0"]) for r in csv.DictReader(fh) if (r["scheme"], int(r["substeps"])) == (scheme, substeps)]
    if len(f) != len(now["f"]) or not all(_close(a, float(b)) for a, b in zip(f, now["f"])):
        mismatches.append(f"{_rel(path)}: the force history of {scheme, substeps} differs")
    _fail_if(mismatches)

