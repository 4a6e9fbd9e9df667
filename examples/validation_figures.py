"""The figures and numbers of docs/validation.md, from the committed pressure sweeps.

Inputs (committed in ``examples/validation_results/``): ``summary.csv`` (the table of
``vfrs sweep examples/sweeps/validation_pressure.toml``: the main job on the medium mesh at ten
subglottal pressures), ``summary_coarse.csv`` (the same sweep on the coarse mesh,
``validation_pressure_coarse.toml``) and ``summaries/<mesh>/<run id>.json`` (each run's
``summary.json``, for the per-cycle values a table has no column for). Outputs, into the same
folder: the PNGs ``fig_*.png`` and ``numbers.md``, the block of tables and fit lines that
docs/validation.md quotes verbatim (tests/test_validation_results.py checks that it does, and
that the block follows from the committed tables).

Run after a sweep (copies its table and summaries in, then draws)::

    vfrs sweep examples/sweeps/validation_pressure.toml -o out/validation_pressure --workers 2
    vfrs sweep examples/sweeps/validation_pressure_coarse.toml -o out/validation_pressure_coarse --workers 2
    python examples/validation_figures.py --medium out/validation_pressure --coarse out/validation_pressure_coarse

or, to redraw from the committed files alone, ``python examples/validation_figures.py``.

The literature's numbers are read from docs/validation/data/ (docs/validation/sources.md says
where each was read, and which are second-hand).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import shutil
from pathlib import Path

import numpy as np

from vfrs.materials import VocalFold
from vfrs.studies.validation import kinematic_hertz_pressure, linear_fit, power_law_fit

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "examples" / "validation_results"
#: The committed pressure sweeps: the linear tissue on the medium and the coarse mesh, and the
#: finite-strain tissue beyond where the linear one runs (``validation_pressure_finite.toml``).
MESHES = {"medium": "summary.csv", "coarse": "summary_coarse.csv", "finite": "summary_finite.csv",
          "viscous": "summary_viscous.csv"}
LABELS = {"medium": "Medium mesh", "coarse": "Coarse mesh",
          "finite": "Finite-strain tissue (fibre-reinforced, stabilized scheme, 25 us), coarse mesh",
          "viscous": "Medium mesh, the viscous flow model (validation_pressure_viscous.toml)"}
#: The damping sweep (``validation_damping.toml``: the medium main job at 0.8 kPa, a1 from 1e-5 s up).
DAMPING = "summary_damping.csv"
TABLES = {**MESHES, "damping": DAMPING}
#: The two converge studies of the sweep's scene at 0.8 kPa (a1 = 6e-5 s, to a repeating cycle), in
#: ``converge_<axis>/``: the mesh ladder at the sweep's step and the step ladder on the medium mesh.
STUDY_AXES = ("mesh", "step")
#: Tao et al.'s lung-pressure range (their abstract): the power law is fitted over it.
TAO_RANGE = (200.0, 2500.0)
#: What marks a run as warned that contact made energy (VfrsWarning: "contact made ... J of energy
#: in one step ...: the step is too large for this impact speed"), in the warning lines of its
#: run.log that :func:`collect` copies into ``summaries/<mesh>/warnings.json``. Such runs stay in
#: the tables and figures, marked, and out of the fits.
ENERGY_WARNING = "energy in one step"
#: The tissue a Hertz estimate from the kinematics assumes, as a clinician would, isotropic: the
#: scene's `vocal_fold` in-plane modulus E_p and density (vfrs.materials.VocalFold's defaults, the
#: plane the medial surface is pressed in) with nu = 0.45, the project's isotropic stand-in's
#: (docs/model.md); the model's own tissue is transversely isotropic (nu_p = 0.9, E_z = 40 kPa).
HERTZ_TISSUE = {"E": VocalFold().E_p, "nu": 0.45, "rho": VocalFold().rho}
#: The numbers whose converge-study errors the block quotes, and their names there.
STUDY_KEYS = {"contact.cycle_peak_sensor_pressure": "per-cycle peak sensor pressure",
              "contact.peak_sensor_pressure": "peak sensor pressure (run)", "phonation.f0": "f0",
              "phonation.amplitude": "amplitude", "phonation.mean_flow": "mean flow",
              "contact.contact_impulse.right": "contact impulse per cycle",
              "contact.peak_force.right": "peak contact force", "phonation.peak_flow": "peak flow"}


# ------------------------------------------------------------------------------------------
# Reading the tables
# ------------------------------------------------------------------------------------------


def _num(v):
    try:
        x = float(v)
    except (TypeError, ValueError):
        return float("nan")
    return x


def read_rows(out: Path = OUT, mesh: str = "medium") -> list:
    """One dict per run of a committed sweep table, sorted by subglottal pressure, with the
    per-cycle peak sensor pressures from the run's committed summary (``cycle_lo``/``cycle_hi``)."""
    rows = []
    logged = out / "summaries" / mesh / "warnings.json"
    logged = json.loads(logged.read_text()) if logged.exists() else {}
    with open(out / TABLES[mesh], newline="") as fh:
        for r in csv.DictReader(fh):
            summary = out / "summaries" / mesh / f"{r['id']}.json"
            per, spread, f0_per = [], {}, []
            if summary.exists():
                s = json.loads(summary.read_text())
                per = [v for v in s.get("contact", {}).get("cycle_peak_sensor_pressure", {}).get("per_cycle", [])
                       if v is not None]
                spread = s.get("window", {}).get("periodicity", {}).get("spread", {})
                f0_per = [v for v in s.get("phonation", {}).get("f0", {}).get("per_cycle", []) if v is not None]
            rows.append({
                "id": r["id"], "mesh": mesh, "ps": _num(r.get("flow.subglottal_pressure")), "status": r["status"],
                "error": r.get("error", ""),
                "t_end": _num(r.get("run.t_end [s]")), "wall": _num(r.get("wall_time [s]")),
                "limit_cycle": r.get("window.periodic", "") == "True", "cycles": _num(r.get("window.cycles")),
                "spread": {k: _num(v) for k, v in spread.items()},
                "f0_lo": min(f0_per) if f0_per else float("nan"), "f0_hi": max(f0_per) if f0_per else float("nan"),
                "a1": _num(r.get("bodies[0].damping.a1")),
                "onset": _num(r.get("phonation.onset")), "growth": _num(r.get("phonation.area_growth")),
                "size": _num(r.get("phonation.area_oscillation")),
                "f0": _num(r.get("phonation.f0 [Hz]")), "amplitude": _num(r.get("phonation.amplitude [m]")),
                "mean_flow": _num(r.get("phonation.mean_flow [m^3/s]")),
                "peak_flow": _num(r.get("phonation.peak_flow [m^3/s]")),
                "cycle_peak": _num(r.get("contact.cycle_peak_sensor_pressure [Pa]")),
                "cycle_lo": min(per) if per else float("nan"), "cycle_hi": max(per) if per else float("nan"),
                "n_cycles_contact": sum(1 for v in per if v > 0), "n_cycles": len(per),
                "peak_sensor": _num(r.get("contact.peak_sensor_pressure [Pa]")),
                "peak_sensor_t": _num(r.get("contact.peak_sensor_pressure.t [s]")),
                "ap": _num(r.get("contact.peak_sensor_pressure_ap")),
                "below": _num(r.get("contact.peak_sensor_pressure_below_superior [m]")),
                "peak_force": _num(r.get("contact.peak_force.right [N]")),
                "contact_quotient": _num(r.get("contact.contact_quotient")),
                "closed_quotient": _num(r.get("phonation.closed_quotient")),
                "impulse": _num(r.get("contact.contact_impulse.right [N s]")),
                "warned": "; ".join(w for w in logged.get(r["id"], []) if ENERGY_WARNING in w),
            })
    rows.sort(key=lambda r: r["ps"])
    return rows


def study_errors(out: Path = OUT) -> dict:
    """The error of the sweep's medium mesh at its step, per quantity of :data:`STUDY_KEYS`, from
    the two converge studies at 0.8 kPa: (relative error, whether it is a bound, mesh part, step
    part). The mesh part is the mesh ladder's (coarse / medium / fine at the sweep's step), the
    step part the step ladder's (h, h/2, h/4 on the medium mesh); their sum is the error, as
    ``vfrs converge`` sums the two parts of a full grid (docs/converge.md), and it is a bound only
    where both ladders are monotone. Empty when the studies are not committed."""
    parts: dict = {}
    for axis in STUDY_AXES:
        path = out / f"converge_{axis}" / "errors.csv"
        if not path.exists():
            return {}
        with open(path, newline="") as fh:
            for r in csv.DictReader(fh):
                # the mesh ladder's rows carry one step, the step ladder's one mesh: the medium
                # mesh's row of the first, the base step's (h) of the second
                base = r["mesh"] == "medium" if axis == "mesh" else r["step"] == "h"
                if base and r["quantity"] in STUDY_KEYS:
                    part = _num(r["mesh_part"] if axis == "mesh" else r["step_part"])
                    parts.setdefault(r["quantity"], {})[axis] = (part, r["bound"] == "True")
    out = {}
    for q, p in parts.items():
        if "mesh" in p and "step" in p:
            out[q] = (p["mesh"][0] + p["step"][0], p["mesh"][1] and p["step"][1], p["mesh"][0], p["step"][0])
    return out


def fit_rows(rows: list) -> list:
    """The runs a pressure fit uses: complete without a contact-energy warning (:data:`ENERGY_WARNING`),
    in Tao et al.'s range, with contact in every cycle of the window (a per-cycle peak > 0 in
    each)."""
    return [r for r in rows if r["status"] == "complete" and not r["warned"]
            and TAO_RANGE[0] <= r["ps"] <= TAO_RANGE[1]
            and r["n_cycles"] > 0 and r["n_cycles_contact"] == r["n_cycles"]]


def fits(rows: list) -> dict:
    """The power laws of the per-cycle and the run's peak sensor pressure against Ps, and the
    straight line of the per-cycle peak against the amplitude (None with fewer than 3 runs)."""
    sel = fit_rows(rows)
    out: dict = {"n": len(sel), "ps": [r["ps"] for r in sel]}
    if len(sel) < 3:
        return {**out, "cycle": None, "peak": None, "amplitude": None}
    ps = [r["ps"] for r in sel]
    out["cycle"] = power_law_fit(ps, [r["cycle_peak"] for r in sel])
    out["peak"] = power_law_fit(ps, [r["peak_sensor"] for r in sel])
    amp = [(r["amplitude"], r["cycle_peak"]) for r in sel if math.isfinite(r["amplitude"])]
    out["amplitude"] = linear_fit([a for a, _ in amp], [p for _, p in amp]) if len(amp) >= 3 else None
    return out


def onset_bracket(rows: list) -> tuple:
    """(highest Ps below the lowest self-oscillating run, that run's Ps) among complete runs;
    None where there is none."""
    done = [r for r in rows if r["status"] == "complete"]
    on = [r["ps"] for r in done if r["onset"] == 1.0]
    if not on:
        return None, None
    first = min(on)
    below = [r["ps"] for r in done if r["ps"] < first]
    return (max(below) if below else None), first


# ------------------------------------------------------------------------------------------
# The numbers block
# ------------------------------------------------------------------------------------------


def _f(x, fmt="{:.3g}"):
    return "—" if x is None or (isinstance(x, float) and not math.isfinite(x)) else fmt.format(x)


def _fit_line(name: str, f) -> str:
    if f is None:
        return f"- {name}: fewer than 3 runs to fit"
    return (f"- {name}: p = {f.a:.4g} Pa x (Ps / Pa)^b, b = {f.b:.3f}, 95 % interval {f.b_ci[0]:.3f} to "
            f"{f.b_ci[1]:.3f} (n = {f.n}, r² = {f.r2:.3f}); 0.5 (Tao et al.) is "
            f"{'inside' if f.contains(0.5) else 'outside'} it")


def meshes(out: Path = OUT) -> list:
    """The pressure sweeps committed in ``out`` (:data:`MESHES` whose table exists)."""
    return [m for m in MESHES if (out / MESHES[m]).exists()]


def numbers_block(out: Path = OUT) -> str:
    """The markdown docs/validation.md quotes: one table per sweep, the fits, the onset bracket,
    the converge studies' errors at 0.8 kPa, the damping sweep, the Hertz estimate."""
    lines = []
    for mesh in meshes(out):
        rows = read_rows(out, mesh)
        lines += [f"**{LABELS[mesh]}** ({len(rows)} runs, "
                  f"{sum(r['status'] == 'complete' for r in rows)} complete; wall time of the runs "
                  f"{sum(r['wall'] for r in rows if math.isfinite(r['wall'])):.0f} s in sum):", "",
                  "| Ps (kPa) | status | end (ms) | limit cycle | cycles | onset | growth / cycle | p2p area / mean "
                  "| f0 (Hz) | amplitude (mm) | mean flow (mL/s) | per-cycle peak sensor p (kPa), mean [range] "
                  "| run's peak sensor p (kPa) | at z / L | below sup. edge (mm) | peak force (mN) |",
                  "|" + "---|" * 16]
        for r in rows:
            if r["status"] != "complete":
                lines.append(f"| {r['ps'] / 1e3:g} | failed: {r['error'][:80]} |" + " |" * 14)
                continue
            cyc = (f"{_f(r['cycle_peak'] / 1e3)} [{_f(r['cycle_lo'] / 1e3)}-{_f(r['cycle_hi'] / 1e3)}]"
                   if math.isfinite(r["cycle_peak"]) else "—")
            lines.append(
                f"| {r['ps'] / 1e3:g} | complete{' (warned)' if r['warned'] else ''} | {r['t_end'] * 1e3:.1f} "
                f"| {'yes' if r['limit_cycle'] else 'no'} "
                f"| {_f(r['cycles'], '{:.0f}')} | {_f(r['onset'], '{:.0f}')} | {_f(r['growth'])} | {_f(r['size'])} "
                f"| {_f(r['f0'], '{:.0f}')} | {_f(r['amplitude'] * 1e3)} | {_f(r['mean_flow'] * 1e6)} | {cyc} "
                f"| {_f(r['peak_sensor'] / 1e3)} | {_f(r['ap'], '{:.2f}')} | {_f(r['below'] * 1e3, '{:.2f}')} "
                f"| {_f(r['peak_force'] * 1e3)} |")
        f = fits(rows)
        lo, hi = onset_bracket(rows)
        warned = [f"{r['ps'] / 1e3:g} kPa ({r['warned']})" for r in rows if r["warned"]]
        periodic = [r["ps"] for r in fit_rows(rows) if r["limit_cycle"]]
        lines += ["", f"Fits over the {f['n']} complete runs with Ps in 0.2-2.5 kPa, contact in every cycle of "
                  f"the window and no contact-energy warning (Ps = {', '.join(f'{p / 1e3:g}' for p in f['ps'])} kPa; "
                  f"{len(periodic)} of them reached a repeating cycle"
                  + (f": {', '.join(f'{p / 1e3:g}' for p in periodic)} kPa)" if 0 < len(periodic) < f["n"] else ")")
                  + (f"; left out, with the warning: {'; '.join(warned)}" if warned else "") + ":", "",
                  _fit_line("per-cycle peak sensor pressure vs Ps", f["cycle"]),
                  _fit_line("run's peak sensor pressure vs Ps", f["peak"])]
        a = f["amplitude"]
        lines.append("- per-cycle peak sensor pressure vs amplitude: fewer than 3 runs to fit" if a is None else
                     f"- per-cycle peak sensor pressure vs amplitude: slope {a.slope / 1e3 * 1e-3:.3g} kPa/mm "
                     f"(95 % {a.slope_ci[0] * 1e-6:.3g} to {a.slope_ci[1] * 1e-6:.3g}), intercept "
                     f"{a.intercept / 1e3:.3g} kPa (95 % {a.intercept_ci[0] / 1e3:.3g} to {a.intercept_ci[1] / 1e3:.3g}), "
                     f"r² = {a.r2:.3f}, n = {a.n}")
        lines.append("- onset (the criterion of vfrs.summary.fold): " +
                     ("no run self-oscillates" if hi is None else
                      f"lowest self-oscillating run at {hi / 1e3:g} kPa" +
                      (f", the next lower run ({lo / 1e3:g} kPa) does not" if lo is not None else
                       " (the lowest pressure of the sweep: onset is below it)")))
        lines.append("")
    errs = study_errors(out)
    tail = ["", hertz_block(out)]
    if errs:
        lines.append("The errors of the medium mesh at h = 50 us, measured at Ps = 0.8 kPa only, each the mesh "
                     "ladder's part (coarse / medium / fine at 50 us) plus the step ladder's (50 / 25 / 12.5 us on "
                     "the medium mesh), each run to a repeating cycle or 300 ms (examples/validation_results/"
                     "converge_mesh, converge_step: their converge.txt says which repeat; \"band\": not a bound, the spread of the runs of a ladder that is not "
                     "monotone): " +
                     "; ".join(f"{STUDY_KEYS[k]} {errs[k][0] * 100:.0f} % (mesh {errs[k][2] * 100:.0f} + step "
                               f"{errs[k][3] * 100:.0f}){'' if errs[k][1] else ', band'}"
                               for k in STUDY_KEYS if k in errs) + ".")
    lines.append(damping_block(out))
    models = models_block(out)
    if models:
        lines.append(models)
    return "\n".join(lines + tail)


def models_block(out: Path = OUT) -> str:
    """The medium sweep with each flow model side by side (when the viscous sweep is committed):
    per Ps, f0, the closed quotient, the contact impulse per cycle and the per-cycle peak sensor
    pressure of each, and the exponent of the sensor pressure against Ps of each."""
    if not all((out / MESHES[m]).exists() for m in ("medium", "viscous")):
        return ""
    b, v = ({r["ps"]: r for r in read_rows(out, m)} for m in ("medium", "viscous"))

    def cell(r, key, scale, fmt):
        if r is None or r["status"] != "complete":
            return "failed" if r is not None else "—"
        return _f(r[key] * scale, fmt)

    lines = ["", "**The flow models side by side** (medium mesh; Bernoulli | viscous; a run without a repeating "
             "cycle marked *):", "",
             "| Ps (kPa) | f0 (Hz) | closed quotient | contact impulse per cycle (uN s) "
             "| per-cycle peak sensor p (kPa) |", "|---|---|---|---|---|"]
    for ps in sorted(set(b) | set(v)):
        rb, rv = b.get(ps), v.get(ps)
        mark = ["" if r is None or r["limit_cycle"] else "*" for r in (rb, rv)]
        lines.append(f"| {ps / 1e3:g} | " + " | ".join(
            f"{cell(rb, k, sc, fm)}{mark[0]} \\| {cell(rv, k, sc, fm)}{mark[1]}"
            for k, sc, fm in (("f0", 1.0, "{:.0f}"), ("closed_quotient", 1.0, "{:.2f}"), ("impulse", 1e6, "{:.3g}"),
                              ("cycle_peak", 1e-3, "{:.3g}"))) + " |")
    lines.append("")
    for m in ("medium", "viscous"):
        lines.append(_fit_line(f"{LABELS[m]}: per-cycle peak sensor pressure vs Ps", fits(read_rows(out, m))["cycle"]))
    return "\n".join(lines)


def damping_block(out: Path = OUT) -> str:
    """The damping sweep's table: at each a1, whether the medium main job at 0.8 kPa reached a
    repeating cycle, when, how far its last cycles differ, and its per-cycle numbers."""
    path = out / DAMPING
    if not path.exists():
        return ""
    rows = sorted(read_rows(out, "damping"), key=lambda r: r["a1"])
    lines = ["", f"**Damping** (the medium main job at Ps = 0.8 kPa, {len(rows)} runs; the damping ratio of "
             "a mode at f0 is pi a1 f0):", "",
             "| a1 (s) | damping ratio at f0 | end (ms) | repeating cycle | last 4 cycles differ: period, "
             "peak area, peak force | cycles | f0 (Hz), mean [per-cycle range] | amplitude (mm) "
             "| per-cycle peak sensor p (kPa), mean [range] |", "|" + "---|" * 9]
    for r in rows:
        if r["status"] != "complete":
            lines.append(f"| {r['a1']:g} | failed: {r['error'][:80]} |" + " |" * 7)
            continue
        sp = r["spread"]
        spread = ", ".join(_f(sp.get(k, float("nan")) * 100, "{:.2g} %") for k in ("period", "peak_area",
                                                                                   "peak_force"))
        cyc = (f"{_f(r['cycle_peak'] / 1e3)} [{_f(r['cycle_lo'] / 1e3)}-{_f(r['cycle_hi'] / 1e3)}]"
               if math.isfinite(r["cycle_peak"]) and r["cycle_peak"] > 0 else "no contact")
        lines.append(f"| {r['a1']:g} | {_f(math.pi * r['a1'] * r['f0'] * 100, '{:.2g} %')} | {r['t_end'] * 1e3:.1f} "
                     f"| {'yes' if r['limit_cycle'] else 'no'} | {spread} | {_f(r['cycles'], '{:.0f}')} "
                     f"| {_f(r['f0'], '{:.1f}')} [{_f(r['f0_lo'], '{:.0f}')}-{_f(r['f0_hi'], '{:.0f}')}] "
                     f"| {_f(r['amplitude'] * 1e3)} | {cyc} |")
    lines += [f"- a1 = {r['a1']:g} s: warned, {r['warned'][:160]}" for r in rows if r["warned"]]
    return "\n".join(lines)


def hertz_estimates(rows: list) -> list:
    """The Hertz estimate from each run's kinematics (f0 and the mid-length probe's amplitude, what
    a video of the superior view gives; :func:`vfrs.studies.validation.kinematic_hertz_pressure` with
    :data:`HERTZ_TISSUE`) beside the model's computed sensor pressure, for the runs a fit uses
    (:func:`fit_rows`: contact in every cycle)."""
    out = []
    for r in fit_rows(rows):
        if not (math.isfinite(r["f0"]) and math.isfinite(r["amplitude"]) and r["amplitude"] > 0):
            continue
        p0, v = kinematic_hertz_pressure(r["f0"], r["amplitude"], HERTZ_TISSUE["rho"], HERTZ_TISSUE["E"],
                                         HERTZ_TISSUE["nu"])
        out.append({**r, "hertz": p0, "speed": v, "ratio_cycle": p0 / r["cycle_peak"],
                    "ratio_peak": p0 / r["peak_sensor"]})
    return out


def _ratio_line(name: str, values: list) -> str:
    if not values:
        return f"- {name}: no run to compare"
    return (f"- {name}: median {np.median(values):.2f}, range {min(values):.2f}-{max(values):.2f} "
            f"(n = {len(values)})")


def hertz_block(out: Path = OUT) -> str:
    """The estimator's comparison docs/validation.md quotes: per mesh, the estimate from f0 and
    amplitude against the computed per-cycle and run's peak sensor pressure, and their ratios."""
    t = HERTZ_TISSUE
    lines = [f"**A Hertz estimate from the kinematics** (vfrs.studies.validation.kinematic_hertz_pressure: both folds "
             f"closing at 2 pi f0 A, two like tissue spheres; isotropic E = {t['E'] / 1e3:g} kPa, nu = {t['nu']:g}, "
             f"rho = {t['rho']:g} kg/m^3), against the model's own 1 mm² sensor, on the runs the fits use:", ""]
    for mesh in meshes(out):
        est = hertz_estimates(read_rows(out, mesh))
        lines += [f"{LABELS[mesh]}:", "",
                  "| Ps (kPa) | f0 (Hz) | amplitude (mm) | closing speed, both folds (m/s) | estimate (kPa) "
                  "| per-cycle peak, computed (kPa) | estimate / per-cycle peak | run's peak, computed (kPa) "
                  "| estimate / run's peak |", "|" + "---|" * 9]
        for r in est:
            lines.append(f"| {r['ps'] / 1e3:g} | {r['f0']:.0f} | {_f(r['amplitude'] * 1e3)} | {_f(r['speed'])} "
                         f"| {_f(r['hertz'] / 1e3)} | {_f(r['cycle_peak'] / 1e3)} | {r['ratio_cycle']:.2f} "
                         f"| {_f(r['peak_sensor'] / 1e3)} | {r['ratio_peak']:.2f} |")
        lines += ["", _ratio_line("estimate / per-cycle peak", [r["ratio_cycle"] for r in est]),
                  _ratio_line("estimate / run's peak", [r["ratio_peak"] for r in est])]
        if len(est) >= 3:
            fe = power_law_fit([r["ps"] for r in est], [r["hertz"] for r in est])
            fc = power_law_fit([r["ps"] for r in est], [r["cycle_peak"] for r in est])
            lines.append(f"- against Ps: the estimate grows as Ps^{fe.b:.2f} (95 % {fe.b_ci[0]:.2f} to "
                         f"{fe.b_ci[1]:.2f}), the computed per-cycle peak as Ps^{fc.b:.2f} (95 % {fc.b_ci[0]:.2f} to "
                         f"{fc.b_ci[1]:.2f}) over the same runs")
        lines.append("")
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------
# Figures
# ------------------------------------------------------------------------------------------


def _literature():
    pts = {}
    with open(ROOT / "docs" / "validation" / "data" / "literature_points.csv", newline="") as fh:
        for r in csv.DictReader(fh):
            pts.setdefault(r["source"], []).append(r)
    return pts


def _kpa_range(pts, source, quantity_start):
    for r in pts.get(source, []):
        if r["quantity"].startswith(quantity_start):
            lo, hi = float(r["low"]), float(r["high"])
            return (lo, hi) if r["unit"] == "kPa" else (lo * 0.0980665, hi * 0.0980665)
    raise KeyError((source, quantity_start))


def _complete(rows):
    return [r for r in rows if r["status"] == "complete"]


def _plain_log(ax, axes="xy"):
    """Log axes labelled 0.2, 0.5, 1, 2 instead of powers of ten."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    for name in axes:
        axis = ax.xaxis if name == "x" else ax.yaxis
        axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        axis.set_minor_formatter(NullFormatter())


def _label(ax, xlabel: str, ylabel: str, title: str) -> None:
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=7)


STYLE = {"medium": dict(marker="o", color="C0", label="medium mesh"),
         "coarse": dict(marker="s", color="C1", mfc="none", label="coarse mesh"),
         "finite": dict(marker="^", color="C3", label="finite strain, coarse mesh"),
         "viscous": dict(marker="D", color="C2", mfc="none", label="medium mesh, viscous flow")}


def plot_all(out: Path = OUT) -> list:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    data = {m: read_rows(out, m) for m in meshes(out)}
    lit = _literature()
    written = []

    def save(fig, name):
        fig.tight_layout()
        path = out / name
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)

    # 1. pressure vs Ps, log-log, power law and Tao's square root
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    for mesh, rows in data.items():
        rs = [r for r in _complete(rows) if r["cycle_peak"] > 0]
        ps = np.array([r["ps"] for r in rs]) / 1e3
        mid = np.array([r["cycle_peak"] for r in rs]) / 1e3
        lo = mid - np.array([r["cycle_lo"] for r in rs]) / 1e3
        hi = np.array([r["cycle_hi"] for r in rs]) / 1e3 - mid
        st = STYLE[mesh]
        ax.errorbar(ps, mid, yerr=[lo, hi], ls="none", capsize=3, marker=st["marker"], color=st["color"],
                    mfc=st.get("mfc", st["color"]), label=f"{st['label']}: per-cycle peak, mean [range]")
        bad = [r for r in rs if r["warned"]]
        if bad:
            ax.plot([r["ps"] / 1e3 for r in bad], [r["cycle_peak"] / 1e3 for r in bad], "x", color="red", ms=10,
                    label="contact-energy warning (left out of the fit)")
        f = fits(rows)["cycle"]
        if f is not None:
            fitted = fits(rows)["ps"]
            x = np.geomspace(min(fitted), max(fitted), 50)  # over the fitted runs' pressures only
            ax.plot(x / 1e3, f.a * x**f.b / 1e3, color=st["color"], lw=1,
                    label=f"{mesh} fit: b = {f.b:.2f} [{f.b_ci[0]:.2f}, {f.b_ci[1]:.2f}]")
            xc = math.exp(np.mean(np.log(fits(rows)["ps"])))
            yc = f.a * xc**f.b
            ax.plot(x / 1e3, yc * (x / xc) ** 0.5 / 1e3, color=st["color"], lw=1, ls=":",
                    label="b = 0.5 (Tao et al. 2006) through the fit's centre" if mesh == "medium" else None)
    ax.set_xscale("log")
    ax.set_yscale("log")
    _plain_log(ax)
    _label(ax, "subglottal pressure Ps (kPa)", "peak contact pressure, 1 mm² sensor (kPa)",
           "Contact pressure vs subglottal pressure")
    save(fig, "fig_pressure_vs_ps.png")

    # 2. pressure vs amplitude, linear (Jiang & Titze, second-hand)
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    for mesh, rows in data.items():
        rs = fit_rows(rows)
        st = STYLE[mesh]
        amp = np.array([r["amplitude"] for r in rs]) * 1e3
        p = np.array([r["cycle_peak"] for r in rs]) / 1e3
        ax.plot(amp, p, ls="none", marker=st["marker"], color=st["color"], mfc=st.get("mfc", st["color"]),
                label=st["label"])
        for r, a_, p_ in zip(rs, amp, p):
            ax.annotate(f"{r['ps'] / 1e3:g}", (a_, p_), fontsize=6, xytext=(3, 2), textcoords="offset points")
        f = fits(rows)["amplitude"]
        if f is not None and len(amp):
            x = np.linspace(0.0, amp.max() * 1.1, 20)
            ax.plot(x, (f.slope * x * 1e-3 + f.intercept) / 1e3, color=st["color"], lw=1,
                    label=f"{mesh} line: r² = {f.r2:.2f}")
    _label(ax, "amplitude, medio-lateral, probe at mid-length (mm)", "per-cycle peak sensor pressure (kPa)",
           "Contact pressure vs amplitude (labels: Ps, kPa)")
    save(fig, "fig_pressure_vs_amplitude.png")

    # 3. where the largest pressure is
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 4))
    for mesh, rows in data.items():
        rs = [r for r in _complete(rows) if r["peak_sensor"] > 0]
        st = STYLE[mesh]
        kw = dict(ls="none", marker=st["marker"], color=st["color"], mfc=st.get("mfc", st["color"]), label=st["label"])
        a1.plot([r["ps"] / 1e3 for r in rs], [r["ap"] for r in rs], **kw)
        a2.plot([r["ps"] / 1e3 for r in rs], [r["below"] * 1e3 for r in rs], **kw)
    a1.axhline(0.5, color="k", lw=0.8, ls="--", label="mid-length (Tao et al. 2006; Gunter 2004)")
    a1.set_ylim(0, 1)
    _label(a1, "Ps (kPa)", "z / fold length (0 anterior, 1 posterior)", "Along the fold")
    a2.axhline(0.0, color="k", lw=0.8, ls="--", label="superior medial edge (Gunter 2004)")
    a2.axhspan(0.0, 3.0, color="0.9", label="straight medial surface (T = 3 mm)")
    a2.invert_yaxis()
    _label(a2, "Ps (kPa)", "below the superior medial edge (mm)", "Inferior-superior")
    fig.suptitle("Where the run's peak sensor pressure is")
    save(fig, "fig_location.png")

    # 4. magnitudes against the 0.5-5 kPa (second-hand)
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    jt = _kpa_range(lit, "jiang_titze_1994", "peak contact pressure")
    ax.axhspan(*jt, color="0.88", label=f"{jt[0]:g}-{jt[1]:g} kPa, Jiang & Titze 1994 (canine, second-hand)")
    for mesh, rows in data.items():
        rs = [r for r in _complete(rows) if r["peak_sensor"] > 0]
        st = STYLE[mesh]
        ax.plot([r["ps"] / 1e3 for r in rs], [r["peak_sensor"] / 1e3 for r in rs], marker=st["marker"],
                color=st["color"], mfc=st.get("mfc", st["color"]), label=f"{st['label']}: run's peak sensor p")
        ax.plot([r["ps"] / 1e3 for r in rs], [r["cycle_peak"] / 1e3 for r in rs], marker=st["marker"], ls=":",
                color=st["color"], mfc="none", label=f"{st['label']}: per-cycle peak, mean")
        bad = [r for r in rs if r["warned"]]
        if bad:
            ax.plot([r["ps"] / 1e3 for r in bad], [r["peak_sensor"] / 1e3 for r in bad], "x", color="red", ms=10,
                    label="contact-energy warning")
    ax.set_yscale("log")
    _plain_log(ax, "y")
    _label(ax, "Ps (kPa)", "contact pressure, 1 mm² sensor (kPa)", "Magnitudes")
    save(fig, "fig_magnitude.png")

    # 5. onset and f0
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 4))
    for src, lab, col in (("ptp_semi_occluded_2009", "humans, 0.2-0.5 kPa (summary of earlier work)", "C2"),
                          ("chan_titze_titze_1996", "physical model, Chan & Titze 1996", "C4")):
        rng = _kpa_range(lit, src, "")
        a1.axvspan(*rng, color=col, alpha=0.2, label=lab)
    for mesh, rows in data.items():
        rs = _complete(rows)
        st = STYLE[mesh]
        kw = dict(marker=st["marker"], color=st["color"], mfc=st.get("mfc", st["color"]), label=st["label"])
        a1.plot([r["ps"] / 1e3 for r in rs], [r["growth"] for r in rs], **kw)
        a2.plot([r["ps"] / 1e3 for r in rs], [r["f0"] for r in rs], **kw)
    from vfrs.summary.fold import ONSET_GROWTH

    a1.axhline(ONSET_GROWTH, color="k", lw=0.8, ls="--", label=f"onset criterion, growth >= {ONSET_GROWTH:g}")
    a1.set_xscale("log")
    _plain_log(a1, "x")
    _label(a1, "Ps (kPa)", "growth of the peak-to-peak glottal area per cycle", "Onset")
    a2.set_xscale("log")
    _plain_log(a2, "x")
    _label(a2, "Ps (kPa)", "f0 (Hz)", "f0 (glottal area) over the window")
    save(fig, "fig_onset_f0.png")

    # 6. pressure vs mean flow (Scheible et al.'s direction)
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for mesh, rows in data.items():
        rs = [r for r in _complete(rows) if r["cycle_peak"] > 0]
        st = STYLE[mesh]
        ax.plot([r["mean_flow"] * 1e6 for r in rs], [r["cycle_peak"] / 1e3 for r in rs], marker=st["marker"],
                color=st["color"], mfc=st.get("mfc", st["color"]), label=st["label"])
    _label(ax, "mean glottal flow over the window (mL/s)", "per-cycle peak sensor pressure, mean (kPa)",
           "Contact pressure vs flow")
    save(fig, "fig_pressure_vs_flow.png")

    # 7. the Hertz estimate from f0 and amplitude against the computed pressure
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    every = []
    for mesh, rows in data.items():
        est = hertz_estimates(rows)
        st = STYLE[mesh]
        mid = np.array([r["cycle_peak"] for r in est]) / 1e3
        ax.errorbar(mid, [r["hertz"] / 1e3 for r in est],
                    xerr=[mid - np.array([r["cycle_lo"] for r in est]) / 1e3,
                          np.array([r["cycle_hi"] for r in est]) / 1e3 - mid],
                    ls="none", capsize=3, marker=st["marker"], color=st["color"], mfc=st.get("mfc", st["color"]),
                    label=f"{st['label']}: per-cycle peak, mean [range]")
        for r in est:
            ax.annotate(f"{r['ps'] / 1e3:g}", (r["cycle_peak"] / 1e3, r["hertz"] / 1e3), fontsize=6, xytext=(3, 2),
                        textcoords="offset points")
        every += [r["cycle_lo"] / 1e3 for r in est if r["cycle_lo"] > 0] + [r["cycle_hi"] / 1e3 for r in est]
        every += [r["hertz"] / 1e3 for r in est]
    if every:
        x = np.geomspace(min(every) / 1.5, max(every) * 1.5, 10)
        ax.plot(x, x, color="k", lw=0.8, label="estimate = computed")
        ax.plot(x, 2 * x, color="k", lw=0.6, ls=":", label="factor 2")
        ax.plot(x, x / 2, color="k", lw=0.6, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    _plain_log(ax)
    _label(ax, "computed, 1 mm² sensor (kPa)", "Hertz estimate from f0 and amplitude (kPa)",
           "A kinematic Hertz estimate vs the model's pressure (labels: Ps, kPa)")
    save(fig, "fig_hertz_estimate.png")
    return written


# ------------------------------------------------------------------------------------------


def collect(sweep_out: Path, mesh: str, out: Path = OUT) -> None:
    """Copy a finished sweep's table and its runs' summaries into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(sweep_out / "summary.csv", out / TABLES[mesh])
    dest = out / "summaries" / mesh
    if dest.exists():
        shutil.rmtree(dest)
    dest.mkdir(parents=True)
    warned = {}
    with open(sweep_out / "summary.csv", newline="") as fh:
        for r in csv.DictReader(fh):
            src = sweep_out / "runs" / r["id"] / "summary.json"
            if src.exists():
                shutil.copyfile(src, dest / f"{r['id']}.json")
            log = sweep_out / "runs" / r["id"] / "run.log"
            lines = [ln[len("warning: "):].strip() for ln in (log.read_text().splitlines() if log.exists() else [])
                     if ln.startswith("warning: ")]
            if lines:
                warned[r["id"]] = lines
    (dest / "warnings.json").write_text(json.dumps(warned, indent=1) + "\n")


def collect_study(study_out: Path, axis: str, out: Path = OUT) -> None:
    """Copy a finished converge study's text files (the report, its tables, the runs' table) into
    ``out/converge_<axis>``."""
    dest = out / f"converge_{axis}"
    dest.mkdir(parents=True, exist_ok=True)
    for name in ("converge.txt", "converge.md", "converge.csv", "errors.csv", "summary.csv", "sweep.json"):
        shutil.copyfile(study_out / name, dest / name)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--medium", type=Path, help="a finished sweep folder of validation_pressure.toml to copy in")
    ap.add_argument("--coarse", type=Path, help="the same for validation_pressure_coarse.toml")
    ap.add_argument("--finite", type=Path, help="the same for validation_pressure_finite.toml")
    ap.add_argument("--damping", type=Path, help="the same for validation_damping.toml")
    ap.add_argument("--viscous", type=Path, help="the same for validation_pressure_viscous.toml")
    ap.add_argument("--converge-mesh", type=Path, help="a finished `vfrs converge --steps 1` study at 0.8 kPa to copy in")
    ap.add_argument("--converge-step", type=Path, help="the same for `vfrs converge --meshes 1`")
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    for mesh in TABLES:
        src = getattr(args, mesh)
        if src is not None:
            collect(src, mesh, args.out)
    for axis in STUDY_AXES:
        src = getattr(args, f"converge_{axis}")
        if src is not None:
            collect_study(src, axis, args.out)
    block = numbers_block(args.out)
    (args.out / "numbers.md").write_text(block)
    print(block)
    for p in plot_all(args.out):
        print("wrote", os.path.relpath(p))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
