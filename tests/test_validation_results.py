"""The committed pressure sweeps of docs/validation.md (examples/validation_results/, issue 33):
their runs are today's sweep files', the cheapest run re-run against the code reproduces its
committed row, and the numbers docs/validation.md quotes are what examples/validation_figures.py
computes from the committed tables."""

from __future__ import annotations

import csv
import importlib.util
import json
import math
from pathlib import Path

import pytest

import vfrs
from vfrs.studies.sweep import flatten_summary, load_sweep

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "examples" / "validation_results"
SWEEPS = {"medium": ROOT / "examples" / "sweeps" / "validation_pressure.toml",
          "coarse": ROOT / "examples" / "sweeps" / "validation_pressure_coarse.toml",
          "finite": ROOT / "examples" / "sweeps" / "validation_pressure_finite.toml",
          "damping": ROOT / "examples" / "sweeps" / "validation_damping.toml",
          "viscous": ROOT / "examples" / "sweeps" / "validation_pressure_viscous.toml"}
TABLES = {"medium": RESULTS / "summary.csv", "coarse": RESULTS / "summary_coarse.csv",
          "finite": RESULTS / "summary_finite.csv", "damping": RESULTS / "summary_damping.csv",
          "viscous": RESULTS / "summary_viscous.csv"}


def _figures():
    spec = importlib.util.spec_from_file_location("validation_figures", ROOT / "examples" / "validation_figures.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _rows(mesh: str) -> list:
    with open(TABLES[mesh], newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.parametrize("mesh", list(SWEEPS))
def test_the_tables_are_the_sweep_files_runs(mesh):
    """The committed ids are the ids of today's sweep files' runs (the same resolved scenes),
    one row each, in the sweep's order, each with its committed summary."""
    sweep = load_sweep(SWEEPS[mesh])
    rows = _rows(mesh)
    assert [r["id"] for r in rows] == [r["id"] for r in sweep.runs]
    for row, run in zip(rows, sweep.runs):
        assert {k: float(row[k]) for k in run["params"]} == run["params"]
    for r in rows:
        if r["status"] == "complete":
            assert (RESULTS / "summaries" / mesh / f"{r['id']}.json").exists(), r["id"]


def test_cheapest_run_is_reproduced():
    """The coarse run with the shortest run time, re-run: every number of its summary as
    committed (to 1e-9 relative: the same bits on the same kind of CPU, docs/results.md), and
    its summary as the committed summary.json."""
    sweep = load_sweep(SWEEPS["coarse"])
    rows = [r for r in _rows("coarse") if r["status"] == "complete"]
    row = min(rows, key=lambda r: float(r["run.wall_time [s]"]))
    spec = next(r for r in sweep.runs if r["id"] == row["id"])
    res = vfrs.run(vfrs.Scene.from_dict(spec["scene"]), progress=False)
    now = flatten_summary(res.results.to_dict())
    bad = []
    for key, value in now.items():
        if key.startswith("run.") or not isinstance(value, float) or key not in row:
            continue
        was = _figures()._num(row[key])
        if not math.isclose(was, value, rel_tol=1e-9, abs_tol=1e-300):
            bad.append((key, was, value))
    assert not bad, bad
    committed = json.loads((RESULTS / "summaries" / "coarse" / f"{row['id']}.json").read_text())
    per = res.results["contact"]["cycle_peak_sensor_pressure"].per_cycle
    assert per == pytest.approx(committed["contact"]["cycle_peak_sensor_pressure"]["per_cycle"], rel=1e-9)


def test_the_docs_numbers_are_the_tables():
    """numbers.md is what the script computes from the committed tables and summaries, and
    docs/validation.md quotes it verbatim."""
    block = _figures().numbers_block(RESULTS)
    assert (RESULTS / "numbers.md").read_text() == block
    doc = (ROOT / "docs" / "validation.md").read_text()
    assert block.strip() in doc
    # the README's line quotes the medium mesh's exponent of the per-cycle peak with its interval
    import re

    b, lo, hi = (float(x) for x in re.search(r"per-cycle peak sensor pressure vs Ps: .*?b = ([0-9.]+), 95 % interval "
                                             r"([0-9.]+) to ([0-9.]+)", block).groups())
    quoted = f"Ps^{b:.2f} (95 % {lo:.2f}-{hi:.2f})"
    assert quoted in " ".join((ROOT / "README.md").read_text().split()), f"README.md does not quote {quoted}"


def test_every_figure_the_docs_show_is_committed():
    doc = (ROOT / "docs" / "validation.md").read_text()
    for name in ("fig_pressure_vs_ps", "fig_pressure_vs_amplitude", "fig_location", "fig_magnitude", "fig_onset_f0",
                 "fig_pressure_vs_flow", "fig_hertz_estimate"):
        assert (RESULTS / f"{name}.png").exists(), name
        assert f"{name}.png" in doc, name


def test_the_hertz_estimate_is_the_closed_form_of_each_rows_kinematics():
    """The estimator block's estimates are the two-sphere Hertz pressure, written out here again,
    of each fitted run's f0 and amplitude with the scene's in-plane modulus and density (not hand
    typed: a re-run sweep with other numbers gives other estimates), and they cover the fitted runs."""
    from vfrs.materials import VocalFold

    figs = _figures()
    E, rho, nu = VocalFold().E_p, VocalFold().rho, figs.HERTZ_TISSUE["nu"]
    E_star = E / (2.0 * (1.0 - nu**2))
    for mesh in figs.meshes(RESULTS):
        rows = figs.read_rows(RESULTS, mesh)
        est = figs.hertz_estimates(rows)
        assert [r["ps"] for r in est] == [r["ps"] for r in figs.fit_rows(rows)]
        for r in est:
            v = 4.0 * math.pi * r["f0"] * r["amplitude"]
            p0 = 2.0 * math.sqrt(2.0) * E_star / math.pi * (5.0 * math.sqrt(2.0) * math.pi * rho * v**2 / (8.0 * E_star)) ** 0.2
            assert r["hertz"] == pytest.approx(p0, rel=1e-12)
            assert r["ratio_cycle"] == pytest.approx(p0 / r["cycle_peak"], rel=1e-12)


def test_the_estimator_row_quotes_the_block():
    """docs/validation.md's estimator row quotes the medians and ranges of the medium mesh's
    ratios as the block computes them (so a regenerated table makes a stale row fail)."""
    import re

    block = _figures().hertz_block(RESULTS)
    medium = block.split("Coarse mesh:")[0]
    cyc = re.search(r"estimate / per-cycle peak: median ([0-9.]+), range ([0-9.]+)-([0-9.]+)", medium).groups()
    run = re.search(r"estimate / run's peak: median ([0-9.]+), range ([0-9.]+)-([0-9.]+)", medium).groups()
    row = next(line for line in (ROOT / "docs" / "validation.md").read_text().splitlines()
               if line.startswith("| a clinician's estimate from kinematics |"))
    assert f"median {cyc[0]}, range {cyc[1]}-{cyc[2]}" in row
    assert f"{run[0]}, {run[1]}-{run[2]}" in row


def test_the_converge_studies_are_of_the_sweep_s_scene():
    """The two converge studies the block's errors come from ran the medium sweep's 0.8 kPa run as
    their base (the same resolved scene, so the same id): the mesh ladder's medium run and the
    step ladder's run at h are that run, and the damping sweep's a1 = 6e-5 s run is it too."""
    base = next(r["id"] for r in _rows("medium") if float(r["flow.subglottal_pressure"]) == 800.0)
    with open(RESULTS / "converge_mesh" / "summary.csv", newline="") as fh:
        mesh = {r["mesh"]: r["id"] for r in csv.DictReader(fh)}
    with open(RESULTS / "converge_step" / "summary.csv", newline="") as fh:
        step = {r["step"]: r["id"] for r in csv.DictReader(fh)}
    assert mesh["medium"] == base and step["h"] == base
    assert base in [r["id"] for r in _rows("damping") if float(r["bodies[0].damping.a1"]) == 6e-5]


def test_the_viscous_sweep_s_quickest_row_is_reproduced():
    """The viscous sweep's run at 2.5 kPa (validation_pressure_viscous.toml), the quickest of its
    rows (it fails within 70 steps), re-run: it fails as committed, with the same error at the
    same step and time (the linear tissue diverges), so the table's rows are this code's."""
    sweep = load_sweep(SWEEPS["viscous"])
    row = next(r for r in _rows("viscous") if float(r["flow.subglottal_pressure"]) == 2500.0)
    assert row["status"] == "failed"
    spec = next(r for r in sweep.runs if r["id"] == row["id"])
    import warnings

    with pytest.raises(vfrs.VfrsError) as err, warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the contact-energy warning before it diverges, as in the sweep's run
        vfrs.run(vfrs.Scene.from_dict(spec["scene"]), progress=False)
    assert str(err.value).split(":")[0] in row["error"] and str(err.value)[:60] in row["error"], (err.value, row["error"])
