"""Plausibility of a vocal-fold scene: sizes, pressures, moduli and densities far outside the
physiological range, which are most likely unit slips.

A scene's numbers are SI (metres, pascals, kg/m^3), and nothing in the type checks stops
``length = 14`` (meant: 14 mm) from running 14 m folds, or ``subglottal_pressure = 0.8``
(meant: 0.8 kPa) from running at 0.8 Pa. For a *vocal-fold scene* - one with a body meshed by
the ``m5`` generator, or with a ``[flow]`` section - :func:`check_scene` (at load) and
:func:`check_meshes` (once the meshes are built, for meshes read from files) compare these
values with the physiological range and report each one far outside it as a
:class:`~vfrs.errors.PlausibilityWarning` naming the file, the key, the value with its unit,
the range and the likely slip::

    m5.toml: bodies[0].mesh.length: length = 14 m: a vocal fold is about 10-25 mm long
    (anterior-posterior); did you mean 14 mm = 0.014? (flagged outside 1 mm - 10 cm; ...)

``[checks] strict = true`` makes them a :class:`~vfrs.errors.PlausibilityError` (a
``SceneError``) with the same message. The run writes them to ``run.log`` too. Other scenes
(cantilevers, blocks, balls, steel) are not checked: they may be anything.

The flags are far outside the ranges below (a factor of about 10 or more), so that a real
but unusual fold does not warn:

- fold length (``m5 length``): adult folds about 10-25 mm (membranous fold about 10 mm in women,
  16 mm in men at rest, longer when stretched; Hirano's and Titze's figures, second-hand);
  flagged below 1 mm or above 10 cm. The other M5 sizes (``T``, ``depth``, radii, heights,
  ``half_gap``, ``cover_thickness``) are a fraction of a millimetre to about a centimetre;
  flagged outside the bounds in :data:`M5_SIZES`. A mesh read from a file: its largest extent,
  flagged outside 1 mm - 10 cm, with the ``length_unit`` that would fit.
- subglottal pressure: about 0.3-2 kPa in speech (Titze, Principles of Voice Production,
  second-hand); phonation threshold about 0.36 kPa (3.7 +- 1.4 cm H2O in 20 adults: Rieves,
  Regner & Jiang 2009, Laryngoscope 119:2378, abstract read); 0.3-4 kPa in loud speech and up
  to 10 kPa when shouting (Snelleman, Versnel & Dejonckere, PEVOC 2007 abstract, read);
  flagged below 50 Pa or above 5 kPa (loud shouting and singing can pass 5 kPa: a warning
  there is a question, not an error, unless the scene is strict).
- tissue moduli (every ``Pa`` parameter of a fold's material: ``E``, ``E_p``, ``E_z``,
  ``G_pz``, ``k1``): about 1-100 kPa (human lamina propria at low strain about 1 kPa across
  and 30 kPa along the fibres, shear under 1 kPa, stiffening 10-15 times at high strain:
  PMC3508138, abstract read; the ``vocal_fold`` defaults 2-40 kPa from Alipour, Berry &
  Titze 2000 and Zhang 2016, second-hand); flagged below 100 Pa or above 10 MPa. A zero
  (``k1 = 0``: no fibres) is not flagged.
- density: soft tissue about 1040-1070 kg/m^3 (Alipour et al. 2000, second-hand); flagged
  below 500 or above 3000 kg/m^3.
- the air (``[flow] density``, a viscous flow model's ``viscosity``): about 1.14 kg/m^3 and
  1.89e-5 Pa s at body temperature (the ideal gas at 37 C and 1 atm, 101325 / (287.05 x
  310.15); the viscosity a textbook value, not re-read here); flagged outside 0.1-10 kg/m^3 and 1e-6 - 1e-3 Pa s
  (a viscosity of 0, an inviscid test, is not flagged).
- Poisson ratios (``nu``, ``nu_p``, ``nu_pz``): positive in tissue (isotropic tissue nearly
  incompressible, 0.45-0.5); flagged below 0, with the sign dropped as the slip.
- supports (a dynamic scene, once the problem is built: :func:`check_supports`, called by
  :func:`vfrs.run`): a fold whose fixed DOFs leave some of its six rigid-body motions free
  (``fixed = []``, rollers on one plane). vfrs has no spring supports and contact only pushes,
  so nothing else holds it and the flow carries it away.

>>> import vfrs, warnings
>>> d = {"bodies": [{"name": "right", "mesh": {"builtin": "m5", "resolution": "coarse", "length": 14.0},
...                  "material": {"model": "vocal_fold"}, "fixed": ["lateral"]}],
...      "time": {"mode": "static"}}
>>> with warnings.catch_warnings(record=True) as w:
...     warnings.simplefilter("always")
...     _ = vfrs.Scene.from_dict(d)
>>> print(str(w[0].message)[:107])
<dict>: bodies[0].mesh.length: length = 14 m: a vocal fold is about 10-25 mm long (anterior-posterior); did
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
import types
import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import PlausibilityError, PlausibilityWarning
from ..params import param
from ..params.table import join

__all__ = ["ChecksParams", "Range", "check_scene", "check_meshes", "check_supports", "is_vocal_fold_scene", "M5_SIZES"]


@dataclass(frozen=True)
class ChecksParams:
    """``[checks]``: what the plausibility checks of a vocal-fold scene do."""

    strict: bool = param(False, doc="values far outside the physiological range are errors (PlausibilityError), "
                                    "not warnings")


@dataclass(frozen=True)
class Range:
    """What a quantity should be, and when it is flagged. ``low``/``high``: flagged outside
    (SI; ``None``: no bound); ``centre``: a typical value that ranks the slips; ``slips``:
    (factor to SI, how the value reads in that unit, e.g. ``"{v} mm = {si}"``)."""

    what: str  # "a vocal fold is about 10-25 mm long (anterior-posterior)"
    unit: str  # the scene's unit
    low: float | None
    high: float | None
    centre: float
    slips: tuple = ()

    def flagged(self, v: float) -> bool:
        return (self.low is not None and v < self.low) or (self.high is not None and v > self.high)

    def bounds(self) -> str:
        """``"outside 1 mm - 10 cm"``, ``"above 1 cm"`` or ``"below 50 Pa"``."""
        lo, hi = (None if b is None else _with_unit(b, self.unit) for b in (self.low, self.high))
        return f"outside {lo} - {hi}" if lo and hi else (f"below {lo}" if lo else f"above {hi}")

    def slip(self, v: float) -> str:
        """``"did you mean 14 mm = 0.014?"`` for the slips that land in range, nearest the
        centre first; or what to check."""
        fits = [(abs(math.log(v * f / self.centre)), text.format(v=f"{v:g}", si=_number(v * f)))
                for f, text in self.slips if v * f > 0 and not self.flagged(v * f)]
        if not fits:
            return f"check the value and its unit (the scene's unit is {self.unit})"
        fits.sort()
        return "did you mean " + "? or ".join(t for _, t in fits[:2]) + "?"


def _number(x: float) -> str:
    """4 significant digits, without an exponent where a reader would not write one."""
    return f"{float(f'{x:.4g}'):.12g}"


def _with_unit(x: float, unit: str) -> str:
    """``0.1 m`` -> ``10 cm``; ``5000 Pa`` -> ``5 kPa``: the bound as one reads it."""
    scales = {"m": ((1.0, "m"), (1e-2, "cm"), (1e-3, "mm"), (1e-6, "um")),
              "Pa": ((1e6, "MPa"), (1e3, "kPa"), (1.0, "Pa"))}.get(unit, ((1.0, unit),))
    for s, name in scales:
        if abs(x) >= s * 0.999:
            return f"{x / s:g} {name}".rstrip()
    s, name = scales[-1]
    return f"{x / s:g} {name}".rstrip()


_LENGTH_SLIPS = ((1e-3, "{v} mm = {si}"), (1e-2, "{v} cm = {si}"), (1e-6, "{v} um = {si}"),
                 (1e3, "{si}, 1000 times larger (converted to metres twice)"))

#: The m5 generator's sizes (metres): what each is, and where it is flagged.
M5_SIZES = {
    "length": Range("a vocal fold is about 10-25 mm long (anterior-posterior)", "m", 1e-3, 0.1, 15e-3, _LENGTH_SLIPS),
    "T": Range("the medial surface of an M5 fold is a few mm thick (default 3 mm)", "m", 1e-4, 0.03, 3e-3,
               _LENGTH_SLIPS),
    "depth": Range("a vocal fold is about 5-10 mm deep, medial surface to lateral wall (default 8 mm)", "m", 1e-3, 0.1,
                   8e-3, _LENGTH_SLIPS),
    "R_O": Range("the M5 exit radius is about a millimetre (default 0.987 mm)", "m", 1e-5, 0.03, 1e-3, _LENGTH_SLIPS),
    "R_L": Range("the M5 inferior radius is about a millimetre (default 1.5 mm)", "m", 1e-5, 0.03, 1.5e-3,
                 _LENGTH_SLIPS),
    "inferior_height": Range("the inferior cut of an M5 fold is a few mm below the medial surface (default 5 mm)", "m",
                             1e-4, 0.1, 5e-3, _LENGTH_SLIPS),
    "superior_height": Range("the superior cut of an M5 fold is a few mm above the medial surface (default 2 mm)",
                             "m", 1e-4, 0.1, 2e-3, _LENGTH_SLIPS),
    "half_gap": Range("the prephonatory half-gap of the glottis is at most about a millimetre (default 0.05 mm)", "m",
                      None, 0.01, 0.05e-3, _LENGTH_SLIPS[:3]),
    "cover_thickness": Range("the cover (epithelium and superficial lamina propria) is about 0.5-1 mm thick "
                             "(default 0.5 mm)", "m", None, 0.02, 0.5e-3, _LENGTH_SLIPS[:3]),
}

#: The largest extent of a fold's mesh read from a file (metres).
MESH_EXTENT = Range("a vocal fold is about 10-25 mm across at its largest", "m", 1e-3, 0.1, 15e-3)

SUBGLOTTAL_PRESSURE = Range(
    "speech needs a subglottal pressure of about 0.3-2 kPa (phonation threshold about 0.3 kPa; loud shouting up to "
    "about 10 kPa)", "Pa", 50.0, 5e3, 800.0,
    ((1e3, "{v} kPa = {si}"), (98.0665, "{v} cm H2O = {si}"), (0.1, "{v} dyn/cm^2 = {si}")))

MODULUS = Range(
    "vocal-fold tissue moduli are about 1-100 kPa (the vocal_fold defaults: 2-40 kPa)", "Pa", 100.0, 1e7, 1e4,
    ((1e3, "{v} kPa = {si}"), (1e6, "{v} MPa = {si}"), (0.1, "{v} dyn/cm^2 = {si}"),
     (1e-3, "{si}, 1000 times smaller (converted to Pa twice)")))

DENSITY = Range(
    "soft tissue is about 1000-1100 kg/m^3", "kg/m^3", 500.0, 3000.0, 1070.0,
    ((1e3, "{v} g/cm^3 (= kg/L) = {si}"), (1e-3, "{v} g/m^3 = {si}")))

POISSON = Range(
    "tissue's Poisson ratios are positive (isotropic tissue is nearly incompressible, 0.45-0.5; the vocal_fold "
    "defaults: nu_p = 0.9, nu_pz = 0); a negative one (auxetic: thicker when stretched) is not tissue", "", 0.0, None,
    0.45, ((-1.0, "{si}, without the minus sign"),))

AIR_DENSITY = Range(
    "air in the airway is about 1.1-1.2 kg/m^3 (1.14 at 37 C: ideal gas, dry, 1 atm)", "kg/m^3", 0.1, 10.0, 1.2,
    ((1e3, "{v} g/cm^3 = {si}"), (1e-3, "{v} g/m^3 = {si}")))

AIR_VISCOSITY = Range(
    "air's dynamic viscosity is about 1.8-1.9e-5 Pa s (1.89e-5 at 37 C)", "Pa s", 1e-6, 1e-3, 1.89e-5,
    ((0.1, "{v} poise = {si}"), (1e-3, "{v} cP = {si}"), (1e-6, "{v} uPa s = {si}")))

#: The materials' Poisson ratios (no unit): flagged when negative.
POISSON_RATIOS = ("nu", "nu_p", "nu_pz")


def is_vocal_fold_scene(scene) -> bool:
    """A scene with a body meshed by the ``m5`` generator or with a ``[flow]`` section."""
    return "flow" in scene.effects or any(b.mesh.get("builtin") == "m5" for b in scene.bodies)


def fold_bodies(scene) -> list:
    """The indices of the bodies that are folds: the ``m5`` bodies and those ``[flow] bodies``
    names; every body of a flow scene that names none of them (its meshes come from files)."""
    flow = scene.effects.get("flow")
    named = set(getattr(flow, "bodies", None) or [])
    folds = [i for i, b in enumerate(scene.bodies) if b.mesh.get("builtin") == "m5" or b.name in named]
    if not folds and flow is not None:
        folds = list(range(len(scene.bodies)))
    return folds


#: The end of a finding's message: a warning, or (strict) an error.
AS_WARNING = "[checks] strict = true makes this an error"
AS_ERROR = "an error because [checks] strict = true"


def _finding(source: str, key: str, name: str, v: float, r: Range) -> str:
    value = f"{v:g} {r.unit}".rstrip()
    return f"{source}: {key}: {name} = {value}: {r.what}; {r.slip(v)} (flagged {r.bounds()}; {AS_WARNING})"


def findings(scene) -> list:
    """The plausibility findings of ``scene`` at load (no meshes needed), as messages; none for
    a scene that is not a vocal-fold scene."""
    if not is_vocal_fold_scene(scene):
        return []
    out = []
    for i in fold_bodies(scene):
        body = scene.bodies[i]
        where = body.where or join("bodies", i)
        if body.mesh.get("builtin") == "m5":
            for key, r in M5_SIZES.items():
                v = body.mesh.get(key)
                if isinstance(v, (int, float)) and r.flagged(v):
                    out.append(_finding(scene.source, join(join(where, "mesh"), key), key, float(v), r))
        materials = body.material.items() if isinstance(body.material, dict) else [(None, body.material)]
        for region, material in materials:
            at = join(join(where, "material"), region) if region is not None else join(where, "material")
            for f in dataclasses.fields(material):
                v = getattr(material, f.name)
                if not isinstance(v, (int, float)) or isinstance(v, bool):
                    continue
                rng = MODULUS if f.metadata.get("unit") == "Pa" else (
                    DENSITY if f.name == "rho" else (POISSON if f.name in POISSON_RATIOS else None))
                if rng is not None and v != 0 and rng.flagged(float(v)):
                    out.append(_finding(scene.source, join(at, f.name), f.name, float(v), rng))
    flow = scene.effects.get("flow")
    ps = getattr(flow, "subglottal_pressure", None)
    if isinstance(ps, (int, float)) and ps != 0 and SUBGLOTTAL_PRESSURE.flagged(ps):  # 0: flow off, on purpose
        out.append(_finding(scene.source, "flow.subglottal_pressure", "subglottal_pressure", float(ps),
                            SUBGLOTTAL_PRESSURE))
    for key, rng in (("density", AIR_DENSITY), ("viscosity", AIR_VISCOSITY)):  # the air's ([flow]; 0: inviscid)
        v = getattr(flow, key, None)
        if isinstance(v, (int, float)) and v != 0 and rng.flagged(float(v)):
            out.append(_finding(scene.source, f"flow.{key}", key, float(v), rng))
    return out


def mesh_findings(scene, meshes) -> list:
    """Findings about the folds' meshes read from files: their largest extent, with the
    ``length_unit`` that would put it in range."""
    from ..mesh import LENGTH_UNITS

    if not is_vocal_fold_scene(scene):
        return []
    out = []
    for i in fold_bodies(scene):
        body, mesh = scene.bodies[i], meshes[i]
        if "path" not in body.mesh or mesh.n_points == 0:
            continue
        extent = float((mesh.points.max(axis=0) - mesh.points.min(axis=0)).max())
        if not MESH_EXTENT.flagged(extent):
            continue
        unit = body.mesh["length_unit"]
        raw = extent / LENGTH_UNITS[unit]  # the extent in the file's own numbers
        fits = [u for u, s in LENGTH_UNITS.items() if u != unit and not MESH_EXTENT.flagged(raw * s)]
        fits.sort(key=lambda u: abs(math.log(raw * LENGTH_UNITS[u] / MESH_EXTENT.centre)))
        slip = (f"did you mean length_unit = {fits[0]!r} ({raw:g} {fits[0]} = {raw * LENGTH_UNITS[fits[0]]:g} m)?"
                if fits else "check the file's unit")
        where = join(join(body.where or join("bodies", i), "mesh"), "length_unit")
        out.append(f"{scene.source}: {where}: the mesh of body {body.name!r} ({os.path.basename(body.mesh['path'])}, "
                   f"length_unit = {unit!r}) is {extent:g} m across: {MESH_EXTENT.what}; {slip} (flagged "
                   f"{MESH_EXTENT.bounds()}; {AS_WARNING})")
    return out


def support_findings(scene, problem) -> list:
    """Findings about the folds' supports in a dynamic vocal-fold scene: a fold whose fixed DOFs
    leave some of its six rigid-body motions free (``fixed = []``, or rollers on one plane).
    Nothing else holds them - vfrs has no spring supports, and contact only pushes a fold back
    from the other fold or an obstacle, it does not hold it - so the flow carries the fold away
    (issue 43: the glottal area 1.4 -> 8.5 mm^2, the cycle measures n/a). A static scene's
    factorization already names such a body (:func:`vfrs.run`)."""
    from ..mesh import held_rigid_modes

    if not is_vocal_fold_scene(scene) or not scene.time.dynamic:
        return []
    fixed = np.zeros(problem.n_dofs, dtype=bool)
    fixed[problem.fixed] = True
    out = []
    for i in fold_bodies(scene):
        body, part = scene.bodies[i], problem.bodies[i]
        held = fixed[part.dofs]
        rank = held_rigid_modes(part.mesh.points, held)
        if rank < 6:
            out.append(_loose(scene, i, part.mesh, int(held.sum()), rank))
    return out


def _loose(scene, i: int, mesh, n_held: int, rank: int) -> str:
    """The message of a fold body ``i`` whose ``n_held`` fixed DOFs hold ``rank`` < 6 of its
    rigid-body motions."""
    body = scene.bodies[i]
    holds = "fixed = [] holds none" if n_held == 0 else f"its {n_held} fixed DOFs hold {rank}"
    contact = "; contact only pushes it back, it does not hold it" if "contact" in scene.effects else ""
    away = ("the flow will carry it away (the glottis opens, the cycle measures read n/a)" if "flow" in scene.effects
            else "any load will carry it away")
    fix = ('fix its lateral wall: fixed = ["lateral"]' if "lateral" in mesh.surfaces else
           f"fix a surface (fixed = [\"<surface>\"]; the mesh has {sorted(mesh.surfaces)})")
    return (f"{scene.source}: {join(body.where or join('bodies', i), 'fixed')}: body {body.name!r} can move as a rigid "
            f"body: {6 - rank} of its 6 rigid-body motions are free ({holds}) and nothing else resists them (vfrs has "
            f"no spring supports{contact}), so {away}; {fix} ({AS_WARNING})")


def _stacklevel() -> int:
    """The stack level of the first caller outside vfrs (so a warning points at the user's
    line), counted from the function that calls ``warnings.warn``."""
    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep
    level, frame = 2, sys._getframe(2)  # report's caller
    f: types.FrameType | None = frame
    while f is not None and os.path.abspath(f.f_code.co_filename).startswith(package):
        f, level = f.f_back, level + 1
    return level


def report(scene, messages: list) -> None:
    """Warns (or, for a strict scene, raises :class:`PlausibilityError`) with ``messages``,
    and keeps them in ``scene.plausibility`` for ``run.log``."""
    if not messages:
        return
    if scene.checks.strict:
        more = f" (and {len(messages) - 1} more: {'; '.join(m.split(': ')[1] for m in messages[1:])})" \
            if len(messages) > 1 else ""
        raise PlausibilityError(messages[0].replace(AS_WARNING, AS_ERROR) + more)
    scene.plausibility.extend(m for m in messages if m not in scene.plausibility)  # a scene run twice: once
    level = _stacklevel()
    for m in messages:
        warnings.warn(m, PlausibilityWarning, stacklevel=level)


def check_scene(scene) -> None:
    """At load: :func:`findings`, reported by :func:`report`."""
    report(scene, findings(scene))


def check_meshes(scene, meshes) -> None:
    """Once the meshes are built: :func:`mesh_findings`, reported by :func:`report`."""
    report(scene, mesh_findings(scene, meshes))


def check_supports(scene, problem) -> None:
    """Once the problem is built (its fixed DOFs known): :func:`support_findings`, reported by
    :func:`report`."""
    report(scene, support_findings(scene, problem))
