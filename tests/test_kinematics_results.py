"""The committed linear vs finite-strain comparison of the colliding folds
(``examples/kinematics_results``, made by ``examples/m5_kinematics.py``) against the code:

- every case's first ``HEAD_TIME`` (2.5 ms, through the first contact) is run again on the
  committed resolution and must give the committed contact force and probe displacement
  (1e-6 relative; the runs are deterministic, the CSV prints every digit);
- the table in docs/model.md ("The folds at finite strain") quotes summary.csv.
"""

from __future__ import annotations

import csv
import importlib.util
from pathlib import Path

import numpy as np
import pytest

import vfrs

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "examples" / "kinematics_results"


def _script():
    spec = importlib.util.spec_from_file_location("m5_kinematics", ROOT / "examples" / "m5_kinematics.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _info() -> dict:
    out = {}
    for line in (RESULTS / "run_info.txt").read_text().splitlines():
        k, _, v = line.partition(" = ")
        out[k.strip()] = v.strip()
    return out


def _summary() -> list:
    with open(RESULTS / "summary.csv") as fh:
        return list(csv.DictReader(fh))


def test_run_info_is_clean():
    info = _info()
    assert info["dirty"] == "False" and len(info["commit"]) == 40, info


@pytest.mark.parametrize("case", ["isotropic", "neo-Hookean", "vocal_fold", "fibre-reinforced",
                                  pytest.param("loud", marks=pytest.mark.slow)])
def test_first_steps_are_reproduced(case):
    mod = _script()
    info = _info()
    with open(RESULTS / "head.csv") as fh:
        rows = [r for r in csv.DictReader(fh) if r["case"] == case]
    end = float(rows[-1]["t"])
    assert end == pytest.approx(mod.HEAD_TIME)
    res = vfrs.run(mod.scene(case, info["resolution"], end), progress=False)
    now = mod.head(res)
    assert len(now["t"]) == len(rows)
    for key in ("t", "force_x", "probe_ux"):
        committed = np.array([float(r[key]) for r in rows])
        scale = np.abs(committed).max() or 1.0
        assert np.allclose(now[key], committed, rtol=1e-6, atol=1e-9 * scale), (case, key)
    assert np.abs(now["force_x"]).max() > 0, f"{case}: no contact in the first {mod.HEAD_TIME * 1e3:g} ms"


def test_docs_quote_the_summary():
    text = " ".join((ROOT / "docs" / "model.md").read_text().split())
    missing = []
    for r in _summary():
        if r["case"] == "loud":
            cells = [f"{float(r['peak_force_mN']):.1f} mN", f"{float(r['peak_pressure_kPa']):.2f} kPa",
                     f"{float(r['f0_Hz']):.0f} Hz", f"{float(r['newton_iterations']):.1f} Newton iterations"]
            missing += [c for c in cells if c not in text]
            continue
        cells = [f"| {r['case']} |", f"{float(r['f0_Hz']):.0f} Hz", f"{float(r['amplitude_mm']):.2f} mm",
                 f"{float(r['peak_force_mN']):.1f} mN", f"{float(r['peak_pressure_kPa']):.2f} kPa",
                 f"{float(r['ms_per_step']):.0f} ms"]
        missing += [c for c in cells if c not in text]
    assert not missing, f"docs/model.md does not quote examples/kinematics_results/summary.csv: {missing}"
