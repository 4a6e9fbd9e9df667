"""The ladders of a converge study: the time steps (``h``, ``h/2``, ``h/4``) and the meshes (the
systematic M5 family's levels, the generator's resolutions or uniform refinement) of a scene,
every combination of them as one run (:func:`plan`), what the plan is in words
(:func:`plan_lines`), and the key of a scene up to what a study varies (:func:`scene_key`)."""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field, replace

from ...errors import VfrsError
from .family import (LEGACY_SHRINK, contact_surface_size, family_kind, family_rungs, level_changes, nominal_size,
                     rung_level, size_ratio)

#: Levels of each ladder: three runs make a study (Celik et al.; docs/converge.md).
LEVELS = 3
#: What the step is divided by from one rung to the next.
STEP_RATIO = 2


# ------------------------------------------------------------------------------------------
# The ladders
# ------------------------------------------------------------------------------------------

#: The ways of building the mesh ladder (``--mesh-ladder``).
MESH_LADDERS = ("auto", "family", "levels", "refine")
#: Which runs of the grid a study makes (``--design``): ``grid``, every mesh at every step
#: (each run gets its error); ``cross``, the base run's mesh at every step and the base run's
#: step on every mesh (5 runs of 9: the base run's error only, the finest mesh never at the
#: smallest step).
DESIGNS = ("grid", "cross")


@dataclass(frozen=True)
class Rung:
    """One level of a ladder: ``name`` (``"level 1"``, ``"medium"``, ``"refined 1x"``,
    ``"h/2"``), its index from the coarsest (0), the key paths it sets (``changes``) and
    removes (``drops``) and its size ``h`` (the step in seconds, or the mesh's element size in
    metres, filled in by :func:`plan`: the representative size ``(V / n_tets)^(1/3)``, or on
    the M5 family its nominal size, level 0's divided by 1.5 per level, beside the measured
    ``measured_h``). ``surface``: the element size of the scene's contact surface on this mesh
    (:func:`vfrs.studies.converge.family.contact_surface_size`, metres), None without contact."""

    name: str
    index: int
    changes: dict
    h: float = math.nan
    dofs: int | None = None
    drops: tuple = ()
    measured_h: float = math.nan
    surface: dict | None = None


def _resolution_levels(data: dict) -> list | None:
    """The generator's levels (coarsest first) shared by every body's built-in mesh that is
    set by ``resolution`` (not by ``cells``), or None."""
    from ...meshes import PARAMS

    levels = None
    for b in data["bodies"]:
        mesh = b["mesh"]
        if "builtin" not in mesh or "resolution" not in mesh or mesh.get("refine", 0):
            return None
        cls = PARAMS[mesh["builtin"]]
        meta = cls.__dataclass_fields__["resolution"].metadata
        choices = meta.get("choices")
        choices = list(choices() if callable(choices) else choices or ())
        sizes = [cls.from_dict({**{k: v for k, v in mesh.items() if k != "refine"}, "resolution": c}).estimate()
                 for c in choices]
        ordered = [c for _, c in sorted(zip([s[1] for s in sizes], choices))]  # by tetrahedra, coarsest first
        if levels is None:
            levels = ordered
        elif levels != ordered:
            return None
    return levels


def mesh_ladder(data: dict, levels: int = LEVELS, how: str = "auto") -> list:
    """The mesh rungs of a resolved scene (coarsest first). ``how``: ``"family"`` (the
    systematic M5 family's levels, :mod:`vfrs.studies.converge.family`: every body a built-in
    m5 mesh set by ``resolution`` or by ``family``/``level``), ``"levels"`` (the generator's
    resolutions: every body built in, set by ``resolution``), ``"refine"`` (every body's mesh
    refined uniformly 0, 1, 2 more times than the scene says: 8 and 64 times the tetrahedra)
    or ``"auto"`` (the family where the scene takes it, else levels where there are at least
    three, else refinement). One level: the scene's own mesh."""
    if how not in MESH_LADDERS:
        raise VfrsError(f"--mesh-ladder {how}: choose one of {', '.join(MESH_LADDERS)}")
    if levels == 1:
        return [Rung("scene's mesh", 0, {})]
    if how in ("auto", "family"):
        kind, why = family_kind(data)
        if kind is not None:
            return [Rung(name, i, changes, drops=drops) for i, (name, changes, drops) in
                    enumerate(family_rungs(data, levels))]
        if how == "family":
            raise VfrsError(f"--mesh-ladder family: {why}; the family is the built-in m5 mesh's "
                            "(bodies[i].mesh.builtin = \"m5\" set by `resolution` or by `family` and `level`): use "
                            "--mesh-ladder levels or refine for this scene")
    names = _resolution_levels(data) if how in ("auto", "levels") else None
    if how == "levels" and (names is None or len(names) < levels):
        raise VfrsError("--meshes levels: every body must use a built-in mesh set by `resolution` (with at least "
                        f"{levels} levels); use --meshes refine for uniform refinement")
    n_bodies = len(data["bodies"])
    if names is not None and len(names) >= levels:
        base = data["bodies"][0]["mesh"]["resolution"]
        i = names.index(base)
        first = min(max(i - (levels - 1) // 2, 0), len(names) - levels)  # the base in the middle where it can be
        return [Rung(name, k, {f"bodies[{b}].mesh.resolution": name for b in range(n_bodies)})
                for k, name in enumerate(names[first:first + levels])]
    rungs = []
    for k in range(levels):
        changes = {f"bodies[{b}].mesh.refine": int(data["bodies"][b]["mesh"].get("refine", 0)) + k
                   for b in range(n_bodies)}
        rungs.append(Rung("scene's mesh" if k == 0 else f"refined {k}x", k, changes))
    return rungs


def step_ladder(data: dict, levels: int = LEVELS, ratio: int = STEP_RATIO) -> list:
    """The step rungs (coarsest first): the scene's step divided by 1, ``ratio``,
    ``ratio^2``; ``[output] every`` (and ``checkpoint_every``) multiplied alike, so the fields
    are written at the same times. A static scene, or ``levels = 1``: the scene's step only."""
    time = data.get("time", {})
    if levels == 1 or time.get("mode") != "dynamic":
        return [Rung("scene's step", 0, {})]
    h = float(time["step"])
    out = data.get("output", {})
    rungs = []
    for k in range(levels):
        f = ratio ** k
        changes: dict = {"time.step": h / f}
        if k and "every" in out:
            changes["output.every"] = int(out["every"]) * f
        if k and int(out.get("checkpoint_every", 0) or 0):
            changes["output.checkpoint_every"] = int(out["checkpoint_every"]) * f
        rungs.append(Rung("h" if k == 0 else f"h/{f}", k, changes, h / f))
    return rungs


@dataclass
class Plan:
    """The runs of a study: ``meshes`` and ``steps`` (rungs, coarsest first), the base
    rungs' indices and, per run, its labels and scene (a dict). ``runs`` are in the order
    they are submitted: the most expensive first (the sweep's wall time is the longest run's
    when it starts first). ``notes``: what the plan chose and why, in words (printed by
    :func:`plan_lines`)."""

    scene: dict
    source: str
    meshes: list
    steps: list
    base_mesh: int
    base_step: int
    runs: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    design: str = "grid"

    def label(self, i: int, j: int) -> dict:
        return {"mesh": self.meshes[i].name, "step": self.steps[j].name}

    def planned(self, i: int, j: int) -> bool:
        """Whether the run of mesh ``i`` and step ``j`` is one of the study's (:data:`DESIGNS`)."""
        return self.design == "grid" or i == self.base_mesh or j == self.base_step


def mesh_sizes(data: dict, source: str) -> dict:
    """A scene's meshes measured: ``h`` (the representative element size ``(V /
    n_tets)^(1/3)`` over all bodies, metres), ``dofs``, ``tets`` and ``surface`` (its contact
    surface's element size, :func:`vfrs.studies.converge.family.contact_surface_size`)."""
    from ...scene import Scene

    meshes = Scene.from_dict(copy.deepcopy(data), source=source).build_meshes()
    volume = sum(abs(m.volume) for m in meshes)
    tets = sum(m.n_tets for m in meshes)
    return {"h": (volume / tets) ** (1.0 / 3.0), "dofs": sum(m.n_dofs for m in meshes), "tets": tets,
            "surface": contact_surface_size(data, meshes)}


def representative_size(data: dict, source: str) -> tuple:
    """(representative element size ``(V / n_tets)^(1/3)`` over all bodies, DOFs) of a scene."""
    s = mesh_sizes(data, source)
    return s["h"], s["dofs"]


def applied(data: dict, *rungs) -> dict:
    """A copy of the resolved scene ``data`` with the rungs' changes set and drops removed."""
    from ...scene.keypath import key_path, set_key

    d = copy.deepcopy(data)
    for r in rungs:
        for path in r.drops:
            *parents, last = key_path(path)
            node = d
            for k in parents:
                node = node[k]
            node.pop(last, None)
        for k, v in r.changes.items():
            set_key(d, k, v)
    return d


def _sized_meshes(data: dict, rungs: list, source: str) -> list:
    """The mesh rungs with their sizes: measured, and on the family its nominal size (level
    0's measured size over 1.5 per level: its ratios are exactly 1.5, where the measured
    sizes' also carry the arcs' faceting, which changes the volume a little per level)."""
    sized = []
    for r in rungs:
        s = mesh_sizes(applied(data, r), source)
        sized.append(replace(r, h=s["h"], measured_h=s["h"], dofs=s["dofs"], surface=s["surface"]))
    if rungs and rung_level(rungs[0]) is not None:
        zero = Rung("level 0", 0, level_changes(len(data["bodies"]), 0), drops=rungs[0].drops)
        h0 = next((r.measured_h for r in sized if rung_level(r) == 0), None) or \
            mesh_sizes(applied(data, zero), source)["h"]
        levels = [rung_level(r) for r in sized]
        sized = [replace(r, h=nominal_size(h0, k)) for r, k in zip(sized, levels) if k is not None]
    return sized


def _base_mesh(data: dict, sized: list, source: str) -> tuple:
    """(index of the rung that is the scene's own mesh, notes): where no rung is (a scene on
    the generator's resolutions, studied on the family), the rung nearest it in DOFs."""
    own = next((r.index for r in sized if all(scene_value(data, k) == v for k, v in r.changes.items())), None)
    if own is not None or rung_level(sized[0]) is None:
        return (0 if own is None else own), []
    s = mesh_sizes(data, source)
    near = min(sized, key=lambda r: abs(math.log(r.dofs / s["dofs"])))
    res = sorted({b["mesh"].get("resolution") for b in data["bodies"]} - {None})
    surf = "" if s["surface"] is None else f", contact surface edges mean {s['surface']['mean'] * 1e6:.1f} um"
    notes = [f"the mesh ladder is the systematic M5 family (every length 1.5 times smaller per level, "
             f"vfrs.meshes.m5_family); it replaces the generator's resolutions, which are not a refinement: their "
             f"first element layer under the medial surface shrinks {LEGACY_SHRINK[0]}x and {LEGACY_SHRINK[1]}x from "
             f"coarse to medium to fine ({LEGACY_SHRINK[2]}x on to a 72 x 18 x 30 mesh), not by one ratio "
             "(docs/converge.md); --mesh-ladder levels keeps them",
             f"the scene's own mesh (resolution {', '.join(res)}: {s['dofs']} DOFs{surf}) is not a rung: the base run "
             f"is {near.name} ({near.dofs} DOFs), the rung nearest it in DOFs"]
    dropped = sorted({p.rsplit(".", 1)[1] for p in sized[0].drops} - {"resolution"})
    if dropped:
        notes.append(f"left out on the family's rungs: {', '.join(dropped)} (the family grades along the medial curve "
                     "itself: equal cells on the arcs and the flat)")
    return near.index, notes


def plan(scene, *, steps: int = LEVELS, meshes: int = LEVELS, mesh_how: str = "auto", source: str | None = None,
         design: str = "grid") -> Plan:
    """The ladders and runs of a study of ``scene`` (a :class:`~vfrs.scene.Scene` or a
    resolved scene dict). ``steps`` / ``meshes``: 3 (a study along that axis) or 1 (the
    scene's own step or mesh only); ``mesh_how``: see :func:`mesh_ladder`; ``design``: which
    runs of the grid (:data:`DESIGNS`)."""
    from ...scene import Scene

    if design not in DESIGNS:
        raise VfrsError(f"--design {design}: choose one of {', '.join(DESIGNS)}")
    for what, n in (("--steps", steps), ("--meshes", meshes)):
        if n not in (1, LEVELS):
            raise VfrsError(f"{what} {n}: a study takes {LEVELS} levels (or 1: not along this axis)")
    if isinstance(scene, Scene):
        source = source or scene.source
        data = scene.to_dict()
    else:
        data = copy.deepcopy(scene)
        source = source or "<dict>"
    m_rungs = mesh_ladder(data, meshes, mesh_how)
    s_rungs = step_ladder(data, steps)
    if len(m_rungs) == 1 and len(s_rungs) == 1:
        raise VfrsError(f"{source}: nothing to study: a static scene has no step ladder, and --meshes 1 leaves no "
                        "mesh ladder")
    sized = _sized_meshes(data, m_rungs, source)
    base_mesh, notes = _base_mesh(data, sized, source)
    p = Plan(data, source, sized, s_rungs, base_mesh, 0, notes=notes, design=design)
    if design == "cross" and len(sized) == LEVELS and len(s_rungs) == LEVELS:
        p.notes.append(f"design cross: the base mesh ({sized[base_mesh].name}) at every step and the base step on "
                       "every mesh, 5 runs of the 9: the base run's error only (its step part and its mesh part); "
                       "the other runs' errors need the grid (--design grid)")
    order = sorted(((i, j) for i in range(len(sized)) for j in range(len(s_rungs)) if p.planned(i, j)),
                   key=lambda ij: -(sized[ij[0]].dofs or 0) * STEP_RATIO ** ij[1])
    for i, j in order:
        d = applied(data, sized[i], s_rungs[j])
        p.runs.append({"mesh_level": i, "step_level": j, "labels": p.label(i, j), "scene": d})
    return p


def mesh_rows(p: Plan) -> list:
    """One dict per mesh rung (coarsest first), as meshes.csv and the printed plan give them:
    ``h [m]`` and ``measured_h [m]``, ``dofs``, the contact surface's ``contact_surface``
    (names), ``contact_edge_mean [m]`` and ``contact_edge_max [m]``, and each size's ratio to
    the coarser rung's (``... ratio``, NaN on the coarsest)."""
    rows: list = []
    for k, r in enumerate(p.meshes):
        sf = r.surface or {}
        row = {"mesh": r.name, "index": r.index, "base": r.index == p.base_mesh, "h [m]": r.h,
               "measured_h [m]": r.measured_h, "dofs": r.dofs,
               "contact_surface": ", ".join(sorted(set(sf.get("surfaces", {}).values()))) or None,
               "contact_edge_mean [m]": sf.get("mean"), "contact_edge_max [m]": sf.get("max")}
        prev = rows[k - 1] if k else {}
        for key in ("h [m]", "contact_edge_mean [m]", "contact_edge_max [m]"):
            row[key.replace(" [m]", " ratio")] = size_ratio(prev.get(key), row[key])
        rows.append(row)
    return rows


def plan_lines(p: Plan) -> list:
    """The plan in words: the mesh rungs (element size ``h`` and its ratio to the coarser
    rung's, DOFs, the contact surface's mean and largest edge in um and their ratios), the
    steps, the notes."""
    family = rung_level(p.meshes[0]) is not None
    keys = {k.rsplit(".", 1)[-1] for r in p.meshes for k in r.changes}
    what = ("the systematic M5 family" if family else "uniform refinement" if "refine" in keys else
            "the generator's resolutions" if "resolution" in keys else "the scene's mesh")
    lines = [f"meshes ({what}; h = " + ("the family's nominal size: level 0's (V / n_tets)^(1/3) / 1.5^level"
                                        if family else "(V / n_tets)^(1/3)") + "; the contact surface's edges):"]

    def ratio(x, digits):
        return "" if not math.isfinite(x) else f" (x{x:.{digits}f})"

    for row in mesh_rows(p):
        text = f"  {row['mesh']:>14}  h = {row['h [m]'] * 1e3:.4g} mm{ratio(row['h ratio'], 4)}"
        if family:
            text += f", measured {row['measured_h [m]'] * 1e3:.4g} mm"
        text += f", {row['dofs']} DOFs"
        if row["contact_surface"] is None:
            text += ", no contact surface"
        else:
            text += (f"; contact surface ({row['contact_surface']}) mean {row['contact_edge_mean [m]'] * 1e6:.1f} um"
                     f"{ratio(row['contact_edge_mean ratio'], 3)}, max {row['contact_edge_max [m]'] * 1e6:.1f} um"
                     f"{ratio(row['contact_edge_max ratio'], 3)}")
        lines.append(text + ("  <- base" if row["base"] else ""))
    lines.append("steps: " + ", ".join(f"{r.name}" + (f" = {r.h * 1e6:.4g} us" if math.isfinite(r.h) else "")
                                       for r in p.steps))
    lines += [f"note: {n}" for n in p.notes]
    return lines


def scene_value(data: dict, path: str):
    """The value at a key path of a resolved scene; a mesh's ``refine``, left out at 0, is 0."""
    from ...scene.keypath import key_path

    node = data
    for part in key_path(path):
        try:
            node = node[part]
        except (KeyError, IndexError, TypeError):
            return 0 if path.endswith(".mesh.refine") else None
    return node



def scene_key(data: dict) -> str:
    """The id of a scene up to its step, its mesh level (``resolution``, ``refine``, the M5
    family's ``family`` and ``level``) and its output intervals (what a study varies): a run
    of the same scene at any rung of the study has the same key (a key the family's rungs
    drop, ``contact_zone``, is kept: the study's key is its runs')."""
    from ..sweep import run_id_of

    d = copy.deepcopy(data)
    d.get("time", {}).pop("step", None)
    for key in ("every", "checkpoint_every"):
        d.get("output", {}).pop(key, None)
    for b in d.get("bodies", []):
        for key in ("resolution", "refine", "family", "level"):
            b.get("mesh", {}).pop(key, None)
    return run_id_of(d)
