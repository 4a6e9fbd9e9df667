"""Every CSV the package writes reads back as numbers (issue 43, item 10): ``modes.csv`` held
``np.float64(0.966...)`` strings where numbers belong. Each file is made by the package's own
code on a small fast case - ``vfrs modes`` (modes.csv), a run folder (history.csv), a sweep of
the main job, coarse, 3 ms (summary.csv), a convergence study of a small cantilever
(converge.csv, errors.csv and its sweep's summary.csv) and the quick accuracy report of the
block (accuracy.csv) - and read back with the csv module (pandas is not a dependency): no cell
holds Python's or numpy's repr (``np.float64(``, ``array(``), and every cell of a numeric
column is the number the package holds (the run's history.npz, the Parquet twin of a table,
the :class:`~vfrs.modes.ModesResult`) bit for bit, 'nan' only where that number is a NaN and
an empty cell only where it is missing."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest

import vfrs
import vfrs.studies.sweep as sw
from vfrs.studies import converge as cv
from vfrs.cli import load_scene

pq = pytest.importorskip("pyarrow.parquet")
ROOT = Path(__file__).resolve().parent.parent
REPRS = ("np.float", "np.int", "np.bool", "np.str", "array(")

from test_converge import CANTILEVER, TIP
from test_sweep import SWEEP as MAIN_JOB_SWEEP

# test_sweep's sweep of the main job, coarse, 3 ms, without its contact.detection axis: two runs.
SWEEP = MAIN_JOB_SWEEP.replace('[[axes]]\nkey = "contact.detection"\nvalues = ["interface_mesh", "bvh"]\n', "")


def read_csv(path) -> tuple:
    """(header, rows as lists of strings), every cell checked for a Python or numpy repr."""
    with open(path, newline="") as fh:
        header, *rows = list(csv.reader(fh))
    assert rows, f"{path}: no rows"
    for row in rows:
        assert len(row) == len(header), f"{path}: a row of {len(row)} cells under {len(header)} columns"
        for name, cell in zip(header, row):
            assert not any(r in cell for r in REPRS), f"{path}: column {name!r} holds {cell!r}"
    return header, rows


def number(cell: str) -> float:
    """A cell of a numeric column as a float ('' is missing: None)."""
    return None if cell == "" else float(cell)


def same_number(cell: str, value) -> bool:
    """The cell holds ``value`` (a number, NaN or None) exactly."""
    got = number(cell)
    if value is None or got is None:
        return got is None and value is None
    if math.isnan(value):
        return math.isnan(got)
    return got == float(value)


def assert_table_matches_parquet(folder: Path, name: str) -> None:
    """``<name>.csv`` holds, column by column, the numbers of ``<name>.parquet`` (the same
    table, written from the same rows): numeric columns read back as those numbers."""
    header, rows = read_csv(folder / f"{name}.csv")
    table = pq.read_table(folder / f"{name}.parquet")
    assert sorted(header) == sorted(table.column_names)  # accuracy.csv's columns are sorted
    numeric = 0
    for k, col in enumerate(header):
        kind = str(table.schema.field(col).type)
        values = table.column(col).to_pylist()
        if kind.startswith(("double", "float", "int")):
            numeric += 1
            bad = [(r[k], v) for r, v in zip(rows, values) if not same_number(r[k], v)]
            assert not bad, f"{name}.csv: column {col!r}: cells {bad[:3]} are not the table's numbers"
    assert numeric >= 3, f"{name}.csv: only {numeric} numeric columns"


@pytest.fixture(scope="module")
def sweep_out(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("sweep")
    (tmp / "sweep.toml").write_text(SWEEP)
    res = sw.run_sweep(tmp / "sweep.toml", tmp / "out", serial=True, log=lambda m: None)
    assert [r["status"] for r in res.rows] == ["complete", "complete"]
    return tmp / "out"


def test_modes_csv_holds_the_modes_numbers(tmp_path):
    scene = vfrs.Scene.from_dict({
        "bodies": [{"name": "bar", "material": {"model": "isotropic", "E": 1e6, "nu": 0.0, "rho": 1000.0},
                    "mesh": {"builtin": "box", "size": [0.2, 0.01, 0.01], "cells": [8, 1, 1]}, "fixed": ["xmin"]}],
        "time": {"mode": "dynamic", "step": 1e-4, "end": 1e-3}})
    res = vfrs.modes(scene, n=3, out=tmp_path)
    header, rows = read_csv(tmp_path / "modes.csv")
    assert header == ["body", "mode", "frequency_hz", "direction", "share", "eff_mass_x", "eff_mass_y", "eff_mass_z"]
    assert len(rows) == 3
    for row, m in zip(rows, res.bodies[0].modes):
        assert row[0] == "bar" and int(row[1]) == m.number and row[3] == m.direction
        expected = [m.frequency, m.shares.max(), *m.participation]
        assert [float(c) for c in row[2:3] + row[4:]] == [float(x) for x in expected]


def test_history_csv_holds_the_run_history(sweep_out):
    """history.csv of a run folder (a run of the sweep) against its history.npz, column by column."""
    run = next(d for d in sorted((sweep_out / "runs").iterdir()) if d.is_dir())
    header, rows = read_csv(run / "history.csv")
    history = dict(np.load(run / "history.npz"))
    cells = np.array([[float(c) for c in row] for row in rows])  # every column numeric
    checked = 0
    for k, col in enumerate(header):
        values = history[col] if col in history else history[col[:-2]][:, "xyz".index(col[-1])]
        np.testing.assert_array_equal(cells[:, k], values, err_msg=f"history.csv: column {col!r}")
        checked += 1
    assert checked == len(header) > 5 and len(rows) == len(history["t"])


def test_sweep_summary_csv_holds_the_table(sweep_out):
    assert_table_matches_parquet(sweep_out, "summary")


def test_converge_tables_hold_their_numbers(tmp_path):
    scene = load_scene(str(ROOT / "examples" / "cantilever.toml"), [*CANTILEVER, "time.step=1e-3"])
    cv.converge(scene, tmp_path / "cv", meshes=1, serial=True, quantities={"tip": TIP}, log=lambda m: None,
                figures=False)
    for name in ("converge", "errors", "summary"):
        assert_table_matches_parquet(tmp_path / "cv", name)


def test_accuracy_csv_holds_the_report(tmp_path):
    from vfrs.studies.accuracy import run_accuracy

    run_accuracy("quick", problems=["block"], out=str(tmp_path), progress=False, serial=True)
    assert_table_matches_parquet(tmp_path, "accuracy")
