"""The studies of a converge study's runs: for every number of the summary, each row and each
column of the grid of runs is a three-run study (:func:`vfrs.studies.verification.verify`),
and each run's error is its step part plus its mesh part (:func:`analyse`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..verification import Verification, axis_error, verify
from .plan import LEVELS, Plan

# ------------------------------------------------------------------------------------------
# The studies
# ------------------------------------------------------------------------------------------

@dataclass
class Quantity:
    """A number of the summary: its column in the sweep's table, section, key, unit, what."""

    column: str
    section: str
    key: str
    unit: str
    what: str
    #: below this size (SI) the value is round-off (the summary's ``roundoff``): taken as 0
    roundoff: float | None = None

    @property
    def name(self) -> str:
        return f"{self.section}.{self.key}"


def quantities_of(summary: dict) -> list:
    out = []
    for section, items in summary.items():
        if section in ("run", "window", "notes") or not isinstance(items, dict):
            continue
        for key, q in items.items():
            if isinstance(q, dict) and "value" in q:
                unit = q.get("unit") or "1"
                col = f"{section}.{key}" + (f" [{unit}]" if unit != "1" else "")
                out.append(Quantity(col, section, key, unit, str(q.get("what") or key), q.get("roundoff")))
    return out


def finite_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


@dataclass
class Study:
    """One quantity along one axis at a fixed level of the other: ``axis`` ("step" or
    "mesh"), ``at`` (the other axis's rung index), the three ``values`` (coarsest first, None
    where a run has none), ``h`` (coarsest first) and the :class:`Verification` (None when a
    value is missing)."""

    quantity: str
    axis: str
    at: int
    values: list
    h: list
    verification: Verification | None

    def error(self, level: int) -> tuple:
        """(relative error of the run at ``level`` (0: coarsest), is it a bound): the GCI of
        that run when the study is monotone (Celik's GCI21 for the finest, GCI32 for the
        middle one, Roache's coarse-grid form for the coarsest), 0 when converged to
        round-off, else the band of the three values about it (not a bound: False)."""
        v = self.verification
        if v is None:
            return math.nan, False
        value = self.values[level]
        part = axis_error(v, LEVELS - 1 - level)
        if part.gci is not None:
            return float(part.gci), part.bound
        band = max(-part.low, part.high)
        return (band / abs(value) if value else math.inf), part.bound

    def to_row(self) -> dict:
        v = self.verification
        row = {"quantity": self.quantity, "axis": self.axis, "at": self.at,
               **{f"value {k}": x for k, x in enumerate(self.values)}, **{f"h {k}": x for k, x in enumerate(self.h)},
               "kind": "missing" if v is None else v.kind}
        if v is not None:
            row.update(order=v.order, extrapolated=v.extrapolated, gci_finest=v.gci_fine, gci_middle=v.gci_medium,
                       gci_coarsest=v.gci_coarse, asymptotic_ratio=v.asymptotic_ratio, low=v.low, high=v.high,
                       words=v.words)
        return row


def _study(q: Quantity, axis: str, at: int, values: list, h: list) -> Study:
    ver = None
    if all(finite_number(x) for x in values) and len(values) == LEVELS:
        ver = verify(list(reversed(values)), list(reversed(h)))
    return Study(q.name, axis, at, values, h, ver)


def run_value(row: dict | None, q: Quantity):
    if row is None or row.get("status") != "complete":
        return None
    v = row.get(q.column)
    if not (isinstance(v, (int, float)) and finite_number(v)):
        return None
    return 0.0 if q.roundoff is not None and abs(v) < q.roundoff else float(v)  # round-off: zero


def analyse(p: Plan, grid: list, quantities: list) -> tuple:
    """(studies, errors) of every quantity: each column of the grid along the step, each row
    along the mesh, and per run its step part plus its mesh part. Of a cross design
    (``p.design``) only the rows and columns it runs in full are studies, and only its runs
    have errors: a part whose study the design leaves out makes the run's error None."""
    studies, errors = [], []
    nm, ns = len(p.meshes), len(p.steps)
    rows = [i for i in range(nm) if all(p.planned(i, j) for j in range(ns))] if ns == LEVELS else []
    cols = [j for j in range(ns) if all(p.planned(i, j) for i in range(nm))] if nm == LEVELS else []
    for q in quantities:
        vals = [[run_value(grid[i][j], q) for j in range(ns)] for i in range(nm)]
        along_step = {i: _study(q, "step", i, vals[i], [r.h for r in p.steps]) for i in rows}
        along_mesh = {j: _study(q, "mesh", j, [vals[i][j] for i in range(nm)], [r.h for r in p.meshes]) for j in cols}
        studies += list(along_step.values()) + list(along_mesh.values())
        for i in range(nm):
            for j in range(ns):
                if not p.planned(i, j):
                    continue
                e_step, b_step = along_step[i].error(j) if i in along_step else (None, True)
                e_mesh, b_mesh = along_mesh[j].error(i) if j in along_mesh else (None, True)
                parts = [e for e in (e_step, e_mesh) if e is not None]
                missing = (ns == LEVELS and i not in along_step) or (nm == LEVELS and j not in along_mesh)
                errors.append({"quantity": q.name, "mesh_level": i, "step_level": j, "mesh": p.meshes[i].name,
                               "step": p.steps[j].name, "value": vals[i][j],
                               "relative": sum(parts) if parts and vals[i][j] is not None and not missing else None,
                               "step_part": e_step, "mesh_part": e_mesh, "bound": bool(b_step and b_mesh)})
    return studies, errors
