"""The main job's convergence table (examples/m5_convergence.py, docs/convergence.md): its
coarse 50 us row re-run against the code, and what the committed table says about the step.
"""

import csv
import importlib.util
from pathlib import Path

import pytest

from test_committed_results import _close, _fail_if, _mismatch, _num

ROOT = Path(__file__).resolve().parent.parent

CONVERGENCE = ROOT / "examples" / "convergence_results" / "summary.csv"
SMOOTH = ["peak_force_mN", "impulse_per_cycle_uNs", "peak_nodal_pressure_kPa", "peak_sensor_pressure_kPa",
          "force_weighted_pressure_kPa", "max_effective_area_summed_mm2", "contact_duration_ms", "contact_quotient"]
COUNTING = ["mean_pressure_at_peak_force_kPa", "max_contact_area_summed_mm2"]


def _convergence_rows() -> dict:
    with open(CONVERGENCE, newline="") as fh:
        return {(r["resolution"], float(r["step_us"])): r for r in csv.DictReader(fh)}


def _change(rows, resolution, column) -> float:
    a, b = float(rows[(resolution, 50.0)][column]), float(rows[(resolution, 25.0)][column])
    return b / a - 1


@pytest.mark.slow
def test_convergence_row_is_reproduced():
    """The coarse 50 us row of examples/convergence_results/summary.csv, re-run."""
    spec = importlib.util.spec_from_file_location("m5_convergence", ROOT / "examples" / "m5_convergence.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    now = mod.run_row("coarse", 50e-6)
    row = _convergence_rows()[("coarse", 50.0)]
    mismatches = [_mismatch(CONVERGENCE, ("coarse", 50.0), k, _num(row[k]), now[k]) for k in row
                  if k not in ("resolution", "step_us", "wall_s") and not _close(_num(row[k]), float(now[k]))]
    _fail_if(mismatches)


def test_coarse_contact_numbers_converge_in_the_step():
    """The issue's bound: from h = 50 to 25 us the main job's contact numbers move by at most
    3 % (coarse mesh; the committed table). Measured: peak force -1.6 %, impulse per cycle
    -2.1 %, peak nodal and sensor pressure +0.0 %, force-weighted pressure -0.4 %, effective
    area -0.9 %, contact per cycle +0.4 %, contact quotient +0.6 %."""
    rows = _convergence_rows()
    bad = {c: round(100 * _change(rows, "coarse", c), 2) for c in SMOOTH if abs(_change(rows, "coarse", c)) > 0.03}
    assert not bad, bad


@pytest.mark.xfail(strict=True, reason="the numbers that count nodes jump as single nodes join the contact: "
                                       "coarse, 50 -> 25 us, the triangle area -3.7 % (then +14 % at 12.5 us) and "
                                       "the mean over the loaded nodes +8.9 % (then -12 %); the summary reports the "
                                       "effective area and the force-weighted pressure beside them")
def test_coarse_node_counting_numbers_converge_in_the_step():
    rows = _convergence_rows()
    assert all(abs(_change(rows, "coarse", c)) <= 0.03 for c in COUNTING)


@pytest.mark.xfail(strict=True, reason="the medium folds' self-oscillation is not converged in time at 50 us "
                                       "(amplitude +6.3 % from 50 to 25 us): peak force -3.1 %, impulse per cycle "
                                       "+7.2 %, peak nodal pressure +3.8 %, contact quotient -5.0 % (the sensor and "
                                       "force-weighted pressures within 1.5 %); docs/convergence.md")
def test_medium_contact_numbers_converge_in_the_step():
    rows = _convergence_rows()
    assert all(abs(_change(rows, "medium", c)) <= 0.03 for c in SMOOTH)
