"""The ladders of a converge study: the time steps (``h``, ``h/2``, ``h/4``) and the meshes (the
generator's levels or uniform refinement) of a scene, every combination of them as one run
(:func:`plan`), and the key of a scene up to what a study varies (:func:`scene_key`)."""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

from ...errors import VfrsError

#: Levels of each ladder: three runs make a study (Celik et al.; docs/converge.md).
LEVELS = 3
#: What the step is divided by from one rung to the next.
STEP_RATIO = 2


# ------------------------------------------------------------------------------------------
# The ladders
# ------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Rung:
    """One level of a ladder: ``name`` (``"medium"``, ``"refine 1"``, ``"h/2"``), its index
    from the coarsest (0), the key paths it sets (``changes``) and its size ``h`` (the step in
    seconds, or the mesh's representative element size in metres, filled in by :func:`plan`)."""

    name: str
    index: int
    changes: dict
    h: float = math.nan
    dofs: int | None = None


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
    """The mesh rungs of a resolved scene (coarsest first). ``how``: ``"levels"`` (the
    generator's resolutions: every body built in, set by ``resolution``), ``"refine"`` (every
    body's mesh refined uniformly 0, 1, 2 more times than the scene says: 8 and 64 times the
    tetrahedra) or ``"auto"`` (levels where there are at least three, refinement otherwise).
    One level: the scene's own mesh."""
    if levels == 1:
        return [Rung("scene's mesh", 0, {})]
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
    when it starts first)."""

    scene: dict
    source: str
    meshes: list
    steps: list
    base_mesh: int
    base_step: int
    runs: list = field(default_factory=list)

    def label(self, i: int, j: int) -> dict:
        return {"mesh": self.meshes[i].name, "step": self.steps[j].name}


def representative_size(data: dict, source: str) -> tuple:
    """(representative element size ``(V / n_tets)^(1/3)`` over all bodies, DOFs) of a scene."""
    from ...scene import Scene

    meshes = Scene.from_dict(copy.deepcopy(data), source=source).build_meshes()
    volume = sum(abs(m.volume) for m in meshes)
    tets = sum(m.n_tets for m in meshes)
    return (volume / tets) ** (1.0 / 3.0), sum(m.n_dofs for m in meshes)


def plan(scene, *, steps: int = LEVELS, meshes: int = LEVELS, mesh_how: str = "auto", source: str | None = None) -> Plan:
    """The ladders and runs of a study of ``scene`` (a :class:`~vfrs.scene.Scene` or a
    resolved scene dict). ``steps`` / ``meshes``: 3 (a study along that axis) or 1 (the
    scene's own step or mesh only)."""
    from ...scene import Scene
    from ...scene.keypath import set_key

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
    sized = []
    for r in m_rungs:
        d = copy.deepcopy(data)
        for k, v in r.changes.items():
            set_key(d, k, v)
        h, dofs = representative_size(d, source)
        sized.append(Rung(r.name, r.index, r.changes, h, dofs))
    base_step = 0
    base_mesh = next((r.index for r in sized if all(scene_value(data, k) == v for k, v in r.changes.items())), 0)
    p = Plan(data, source, sized, s_rungs, base_mesh, base_step)
    order = sorted(((i, j) for i in range(len(sized)) for j in range(len(s_rungs))),
                   key=lambda ij: -(sized[ij[0]].dofs or 0) * STEP_RATIO ** ij[1])
    for i, j in order:
        d = copy.deepcopy(data)
        for k, v in {**sized[i].changes, **s_rungs[j].changes}.items():
            set_key(d, k, v)
        p.runs.append({"mesh_level": i, "step_level": j, "labels": p.label(i, j), "scene": d})
    return p


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
    """The id of a scene up to its step, its mesh level and its output intervals (what a
    study varies): a run of the same scene at any rung of the study has the same key."""
    from ..sweep import run_id_of

    d = copy.deepcopy(data)
    d.get("time", {}).pop("step", None)
    for key in ("every", "checkpoint_every"):
        d.get("output", {}).pop(key, None)
    for b in d.get("bodies", []):
        b.get("mesh", {}).pop("resolution", None)
        b.get("mesh", {}).pop("refine", None)
    return run_id_of(d)
