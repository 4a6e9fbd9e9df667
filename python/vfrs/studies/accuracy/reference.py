"""An extrapolated reference: the limit of a problem's scored numbers, estimated by solution
verification (Richardson extrapolation with the GCI, :mod:`vfrs.studies.verification`) from a
ladder of reference runs, for a problem that has no closed form (the M5 folds).

A :class:`ReferenceStudy` names one method (Lagrange multipliers for M5), three meshes of
one family (coarsest first) run at one small step ``mesh_step``, and three steps (largest
first, the last ``mesh_step``) run on one mesh of the family (``step_mesh``, default the
finest; a cheaper one when the finest is too dear to run three times). Optionally a second
family of meshes at ``mesh_step`` (``cross``) is studied the same way as a cross-check (does
the other family converge to the same limit?) without entering the reference.

For each scored quantity, :func:`estimate` combines the two three-run studies about the
finest mesh's run ``phi1`` (the same procedure as ``vfrs converge``'s error = step part + mesh
part, docs/converge.md; with the step ladder on a coarser mesh it assumes, as that does,
that the step's part of the error hardly depends on the mesh):

- an axis whose three runs converge monotonically shifts the value by its extrapolation
  ``phi_ext - phi1`` and contributes the band ``phi1 +- GCI21 |phi1|`` (Celik et al. 2008's
  fine-grid convergence index, Fs = 1.25);
- an axis converged to round-off contributes nothing;
- an oscillatory or divergent axis shifts nothing and contributes the range of its three
  values about ``phi1`` (a band, not a bound).

The reference value is ``phi1`` plus both shifts; the limit lies in ``phi1`` plus both
bands (95 % by Roache's reading of the GCI when both are bounds). The reference's
uncertainty is the largest distance from the value to that band's edges, relative to the
value: a row within ``e`` of the reference is within ``e + uncertainty`` of the limit, and
that sum is what a recommendation must bring under its target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..verification import Verification, axis_error, verify


@dataclass(frozen=True)
class ReferenceStudy:
    """The reference runs of a problem: ``contact`` (the method), ``meshes`` (three levels of
    one family, coarsest first) at ``mesh_step``, ``steps`` (three, largest first, the last
    equal to ``mesh_step``) on ``meshes[-1]``; ``cross``: another family's levels run at
    ``mesh_step`` as a cross-check (not in the reference)."""

    contact: dict
    meshes: tuple
    mesh_step: float
    steps: tuple
    cross: tuple = ()
    step_mesh: str = ""  # the mesh of the step ladder; "" = meshes[-1]

    @property
    def step_level(self) -> str:
        return self.step_mesh or self.meshes[-1]

    def __post_init__(self):
        if len(self.meshes) != 3 or len(self.steps) != 3:
            raise ValueError(f"a reference study takes three meshes and three steps, got {self.meshes}, {self.steps}")
        if not (self.steps[0] > self.steps[1] > self.steps[2]) or not math.isclose(self.steps[2], self.mesh_step):
            raise ValueError(f"steps must shrink to mesh_step = {self.mesh_step:g}, got {self.steps}")

    def cells(self) -> list:
        """Every (level, step) it runs, once each: the mesh ladder, the step ladder, the cross
        family."""
        out = [(lv, self.mesh_step) for lv in self.meshes]
        out += [(self.step_level, h) for h in self.steps if (self.step_level, h) not in out]
        out += [(lv, self.mesh_step) for lv in self.cross if lv not in self.meshes]
        return out


@dataclass(frozen=True)
class Estimate:
    """One quantity's reference: ``value`` (the extrapolated limit, or the finest run where
    no axis extrapolates), ``finest`` (the finest run, phi1), the band ``low``..``high`` the
    limit is taken to lie in, ``uncertainty`` (relative: the value's largest distance to the
    band's edges over |value|), ``bound`` (both axes monotone or converged: a GCI bound, not
    a band), and the two studies (``mesh``, ``step``)."""

    value: float
    finest: float
    low: float
    high: float
    uncertainty: float
    bound: bool
    mesh: Verification
    step: Verification

    def to_dict(self) -> dict:
        return {"value": self.value, "finest": self.finest, "low": self.low, "high": self.high,
                "uncertainty": self.uncertainty, "bound": self.bound,
                "mesh": self.mesh.to_dict(), "step": self.step.to_dict()}


def estimate(mesh_values, mesh_h, step_values, step_h) -> Estimate:
    """The reference of one quantity from its mesh study (``mesh_values`` on sizes ``mesh_h``)
    and its step study (``step_values`` at ``step_h``), each three values coarsest first: the
    last of the mesh study is the finest run ``phi1``; the step study's may be another mesh's
    run, whose extrapolation and band then apply to ``phi1`` as absolute offsets."""
    mesh_values, step_values = [float(v) for v in mesh_values], [float(v) for v in step_values]
    vm = verify(mesh_values[::-1], list(mesh_h)[::-1])
    vs = verify(step_values[::-1], list(step_h)[::-1])
    phi1 = mesh_values[-1]
    mesh, step = axis_error(vm), axis_error(vs)
    value = phi1 + mesh.shift + step.shift
    low, high = phi1 + mesh.low + step.low, phi1 + mesh.high + step.high
    half = max(abs(value - low), abs(high - value))
    unc = half / abs(value) if value != 0 else math.inf
    return Estimate(value, phi1, low, high, unc, mesh.bound and step.bound, vm, vs)


def mesh_size(scene: dict) -> float:
    """The representative element size ``(V / n_tets)^(1/3)`` of a scene's meshes (all bodies),
    as ``vfrs converge`` measures its mesh ladder."""
    from ..converge.plan import representative_size

    return representative_size(scene, "<reference study>")[0]


def _pm(e: dict, scale: float) -> str:
    """An estimate (:meth:`Estimate.to_dict`) as ``value +- uncertainty (bound|band)``."""
    what = "bound" if e["bound"] else "band"
    return f"{e['value'] * scale:.4g} +- {e['uncertainty']:.1%} ({what})"


def _axis_text(v: dict, what: str) -> str:
    """One axis's study (:meth:`Verification.to_dict`) in words."""
    if v["kind"] == "monotone" and v["order"] is not None:
        return f"{what} monotone, order {v['order']:.2f}, GCI {v['gci_fine']:.1%}"
    return f"{what} {v['kind']}"


#: how each scored metric is printed: (unit, scale from SI, words)
UNITS = {"impulse": ("uN s", 1e6, "contact impulse"), "peak_force": ("mN", 1e3, "peak contact force"),
         "peak_pressure": ("kPa", 1e-3, "peak pressure on a 1 mm^2 sensor"), "max_area": ("mm^2", 1e6, "maximum area"),
         "force": ("mN", 1e3, "contact force"), "area_effective": ("mm^2", 1e6, "effective contact area"),
         "area_pressed": ("mm^2", 1e6, "area of positive pressure"),
         "sensor_pressure": ("kPa", 1e-3, "pressure on a 1 mm^2 sensor"),
         "disc_pressure": ("kPa", 1e-3, "pressure on the 1 mm^2 sensor's exact disc"),
         "peak_disc_pressure": ("kPa", 1e-3, "peak pressure on the 1 mm^2 sensor's exact disc"),
         "duration": ("ms", 1e3, "contact duration"), "area_at_peak": ("mm^2", 1e6, "effective area at the peak force")}


def step_text(h: float) -> str:
    """A time step as the report prints it: ``h = 25 us``."""
    return f"h = {h * 1e6:g} us"


def study_text(study: ReferenceStudy, reference: dict | None, cells_of, steps_text=step_text) -> str:
    """The report's words for a reference study and, with the measured ``reference`` record,
    what it found per scored metric. ``cells_of(level)``: the cells per fold of a level, as
    printed; ``steps_text(h)``: a step as printed (a static problem's step is its load
    increment)."""
    fam = ", ".join(f"{lv} ({cells_of(lv)})" for lv in study.meshes)
    steps = " / ".join(steps_text(h) for h in study.steps)
    text = (f"The limit of each scored number, extrapolated from a reference study (Richardson extrapolation with "
            f"Celik et al.'s grid convergence index, J. Fluids Eng. 130, 078001, 2008; docs/converge.md): "
            f"{study.contact['method']} on the meshes {fam} at {steps_text(study.mesh_step)}, and on the "
            f"{study.step_level} mesh at {steps}. The value scored against is the finest run plus what "
            "each monotone axis extrapolates; its uncertainty is the distance to the edge of the band the limit lies "
            "in (the GCI of a monotone axis, the range of the three runs of an oscillatory or divergent one: then "
            "'band', not a bound). A row's error plus that uncertainty bounds its distance to the limit.")
    if study.cross:
        text += (f" The meshes {', '.join(study.cross)} are run at the same step as a cross-check: do they converge "
                 "to the same limit?")
    if not reference or "quantities" not in reference:
        return text
    parts = []
    for q, e in reference["quantities"].items():
        unit, scale, words = UNITS.get(q, ("", 1.0, q))
        line = (f"{words}: {_pm(e, scale)} {unit} (finest run {e['finest'] * scale:.4g}; "
                f"{_axis_text(e['mesh'], 'mesh')}; {_axis_text(e['step'], 'step')})")
        cross = (reference.get("cross") or {}).get(q)
        if cross:
            vals = " / ".join(f"{v * scale:.4g}" for v in cross["phi"][::-1])
            inside = e["low"] <= cross["phi"][0] <= e["high"]
            line += (f"; the cross-check meshes give {vals} {unit} coarse to fine, {cross['kind']}, their finest "
                     + ("inside the band" if inside else f"outside the band ({e['low'] * scale:.4g}-{e['high'] * scale:.4g})"))
        parts.append(line)
    return text + " Found: " + "; ".join(parts) + "."
