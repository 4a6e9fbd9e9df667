"""Reading a scene's tables into its parts (:mod:`vfrs.scene.model`): every key checked, every
error naming the file, the key path and what was expected."""

from __future__ import annotations

import os
import re

import numpy as np

from .. import meshes as _meshes
from ..errors import MaterialError, MeshError, SceneError
from ..materials import MATERIALS
from ..params import read_params
from ..mesh import LENGTH_UNITS, check_mesh_path
from . import selectors as _sel
from . import sizes as _sizes
from ..params.table import Table, join, suggest
from .model import Body, COMPONENTS, COMPRESSIONS, Constraint, FIELDS, Load, Output, Plane, Time, UNTIL, UNTIL_CAP, UNTIL_CYCLES, \
    UNTIL_TOLERANCE


BODY_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")


def check_body_name(top: Table, i: int, name) -> None:
    """Body names name output files (``<name>.pvd``, ``fields/<name>_<step>.vtu``): a name,
    never a path."""
    if not (isinstance(name, str) and BODY_NAME.fullmatch(name) and name not in (".", "..")):
        raise top.error(f"body {i}: name {name!r} is not a valid body name: use letters, digits, '_', '.' and '-' "
                        "(not starting with '.' or '-'; no path separators or spaces), e.g. 'right'",
                        join(join("bodies", i), "name"))


def check_contact(settings, surfaces_of: dict, source: str) -> None:
    """``[contact] pairs`` and ``surface`` against the bodies (``surfaces_of``: body name ->
    its mesh's surface names, or None before the meshes are built: then only the names)."""
    from .contact_keys import contact_surface_errors

    common = getattr(settings, "common", None)
    if common is None:
        return
    known = {b: (v if v is not None else []) for b, v in surfaces_of.items()}
    errors = contact_surface_errors(common.surface, common.pairs, known)
    if any(v is None for v in surfaces_of.values()):  # surface names wait for the meshes
        errors = [(k, m) for k, m in errors if not (k == "surface" or ("has no surface" in m))]
    if errors:
        key, message = errors[0]
        raise SceneError(f"{source}: {join('contact', key) if not key.startswith('pairs[') else 'contact.' + key}: {message}")


def _mesh(t: Table, base_dir: str) -> dict:
    if t.has("path"):
        path = t.string("path")
        unit = t.string("length_unit", "m", choices=LENGTH_UNITS)
        merge = t.boolean("merge_nodes", False)
        refine = t.integer("refine", 0, minimum=0)
        t.done()
        full = path if os.path.isabs(path) else os.path.join(base_dir, path)
        full = os.path.normpath(full)
        if not os.path.exists(full):
            raise t.error(f"mesh file {full!r} does not exist (paths are relative to the scene file)", "path")
        try:
            check_mesh_path(full)
        except MeshError as e:
            raise t.error(str(e), "path") from None
        # merge_nodes only when asked: the resolved scene of a run without it (and so its hash) is unchanged
        # likewise refine only when > 0
        return {"path": full, "length_unit": unit, **({"merge_nodes": True} if merge else {}),
                **({"refine": refine} if refine else {})}
    if not t.has("builtin"):
        raise t.error("expected `builtin = \"<generator>\"` (one of "
                      f"{sorted(_meshes.PARAMS)}) or `path = \"file.msh\"`")
    name = t.string("builtin", choices=_meshes.PARAMS)
    refine = t.integer("refine", 0, minimum=0)  # vfrs's, not the generator's: every tetrahedron into eight, n times
    params = read_params(_meshes.PARAMS[name], t)  # the generator's typed Params: types, defaults, checks
    t.done()
    try:  # what the generator would refuse, now rather than when the mesh is built
        params.check()
    except MeshError as e:
        key = getattr(e, "key", None)
        raise t.error(str(e)[len(key) + 2:] if key and str(e).startswith(f"{key}: ") else str(e), key) from None
    size = params.estimate()
    if size is not None:
        size = (size[0] * 8**refine, size[1] * 8**refine)
    if size is not None and size[0] > _sizes.MAX_NODES:
        key = "cells" if t.has("cells") else ("resolution" if t.has("resolution") else None)
        raise t.error(f"the mesh would have {size[0]:,} nodes ({size[1]:,} tetrahedra), more than any machine "
                      f"holds (at most {_sizes.MAX_NODES:,}); give fewer cells", key)
    return {**params.to_dict(), **({"refine": refine} if refine else {})}  # refine only when > 0: hashes unchanged


def _material(t: Table):
    if not t.has("model") and t.data and all(isinstance(v, dict) for v in t.data.values()):
        return {region: _material(t.table(region)) for region in list(t.data)}
    model = t.string("model", choices=MATERIALS)
    try:  # the registered class's fields are its parameters: their types, defaults and checks
        material = read_params(MATERIALS[model], t)
    except MaterialError as e:
        raise t.error(str(e)) from None
    t.done()
    return material


def _ramp(t: Table) -> float:
    return t.number("ramp", 0.0, nonnegative=True, what=" (seconds)")


def _constraint(item, where, source, index) -> Constraint:
    if isinstance(item, str):
        item = {"surface": item}
    t = Table(item, where, source)
    name = t.string("name", None)
    sel = _sel.read_selector(t)
    comps = t.array("components", list(COMPONENTS))
    if not comps or any(c not in COMPONENTS for c in comps) or len(set(comps)) != len(comps):
        raise t.error(f"expected distinct components from {list(COMPONENTS)}, got {comps!r}", "components")
    comps = tuple(c for c in COMPONENTS if c in comps)
    disp = t.vector("displacement", [0.0, 0.0, 0.0])
    ramp = _ramp(t)
    t.done()
    return Constraint(name or _sel.describe(sel), sel, comps, disp, ramp, where)


def _load(item, where, source) -> Load:
    t = Table(item, where, source)
    kind = t.string("type", choices=("pressure", "traction"))
    name = t.string("name", None)
    sel = _sel.read_selector(t)
    if kind == "pressure":
        value = t.number("value", what=" (pressure in Pa, positive pushes into the body)")
    else:
        value = t.vector("value")
    ramp = _ramp(t)
    pulse = t.number("pulse", 0.0, nonnegative=True, what=" (seconds: sin^2 rise and fall back to zero)")
    if ramp and pulse:
        raise t.error(f"ramp = {ramp:g} s and pulse = {pulse:g} s: a load has one time profile; give one of them",
                      "pulse")
    t.done()
    return Load(name or f"{kind}:{_sel.describe(sel)}", kind, sel, value, ramp, where, pulse)


def read_body(t: Table, base_dir) -> Body:
    name = t.string("name")
    mesh = _mesh(t.table("mesh"), base_dir)
    material = _material(t.table("material"))
    d = t.table("damping", {})
    damping = {"a0": d.number("a0", 0.0, nonnegative=True, what=" (1/s)"),
               "a1": d.number("a1", 0.0, nonnegative=True, what=" (s)")}
    d.done()
    mass = t.string("mass", "consistent", choices=("consistent", "lumped"))
    order = t.integer("order", 1, choices=(1, 2),
                      what=" (1: linear, four-node tetrahedra; 2: quadratic, ten-node, docs/quadratic.md)")
    velocity = t.vector("velocity", [0.0, 0.0, 0.0])
    fixed = [_constraint(c, join(join(t.where, "fixed"), i), t.source, i) for i, c in enumerate(t.array("fixed", []))]
    loads = [_load(c, join(join(t.where, "loads"), i), t.source) for i, c in enumerate(t.array("loads", []))]
    t.done()
    return Body(name, mesh, material, damping, mass, velocity, fixed, loads, t.where, order if order == 2 else None)


def read_obstacle(t: Table, i) -> Plane:
    t.string("type", "plane", choices=("plane",))
    name = t.string("name", f"plane{i}")
    point = t.vector("point")
    normal = np.asarray(t.vector("normal"))
    norm = float(np.sqrt(np.sum(normal * normal)))  # numpy's sum, not BLAS's ddot: the same bits on every CPU
    if norm == 0:
        raise t.error("expected a nonzero normal vector", "normal")
    t.done()
    return Plane(name, point, (normal / norm).tolist())


def kinematics(top: Table, b) -> str:
    from ..materials import kinematics_of

    try:
        return kinematics_of(b.material)
    except MaterialError as e:
        raise top.error(str(e), join(b.where, "material")) from None


def read_time(t: Table, finite=()) -> Time:
    """``[time]``: ``mode`` picks the registered integrators of that mode, the bodies'
    kinematics one of them (finite strain: the Newton integrator), whose ``Params`` are the
    other keys."""
    # Read lazily: vfrs.dynamics assembles problems from scenes (dynamics.problem imports this package).
    from ..roles import INTEGRATORS, integrator_for, mode_of, modes

    mode = t.string("mode", "dynamic", choices=modes())
    kinematics = "finite" if finite else "linear"
    cls = integrator_for(mode, kinematics)
    if cls is None:
        raise t.error(f"mode = {mode!r} has no integrator for {kinematics}-strain bodies (registered integrators: "
                      f"{sorted(INTEGRATORS)})", "mode")
    for other in INTEGRATORS.values():
        if other is not cls and mode_of(other) == mode:
            other.refuse_keys(t)  # a key of the mode's other integrator: say why it does not apply
    params = cls.resolve(t)
    t.done()
    return Time(mode, cls, params)


def read_output(t: Table, time: Time, base_dir: str) -> Output:
    every = t.integer("every", 10 if time.dynamic else 1, minimum=1)
    fields = t.array("fields", ["displacement", "velocity"])
    for i, f in enumerate(fields):
        if f not in FIELDS:
            raise t.error(f"{f!r} is not a field; choose from {list(FIELDS)}{suggest(f, FIELDS)}", join("fields", i))
    probes = t.array("probes", [])
    pts = []
    for i, p in enumerate(probes):
        if not (isinstance(p, list) and len(p) == 3 and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in p)):
            raise t.error(f"expected a point [x, y, z], got {p!r}", join("probes", i))
        pts.append(Table({i: p}, join(t.where, "probes"), t.source).vector(i))  # finite, in range

    energy = t.boolean("energy", True)
    reactions = t.boolean("reactions", True)
    # Checkpoints of a run with an output folder (docs/running.md): every so many steps, or
    # by default every so many seconds of wall time; the command line's --checkpoint-every /
    # --checkpoint-seconds override these.
    ck_every = t.integer("checkpoint_every", 0, minimum=0)
    ck_seconds = t.number("checkpoint_seconds", 60.0, nonnegative=True, what="wall time between checkpoints, s")
    # VTU field files (vfrs.output.vtu): zlib (default) about 5x smaller than none and about as fast
    # (medium M5 fold: 3.8 ms vs 3.6 ms per file); lzma 20 % smaller again and 10x slower.
    compression = t.string("compression", "zlib", choices=COMPRESSIONS)
    until, cycles, cap, tolerance = _until(t, time)
    errors_from = _errors_from(t, base_dir)
    t.done()
    return Output(every, list(fields), pts, energy, reactions, ck_every, ck_seconds, compression, until, cycles, cap,
                  tolerance, errors_from)


def _errors_from(t: Table, base_dir: str) -> str | None:
    """``errors_from``: the folder of a converge study of this scene (``vfrs converge``; relative
    to the scene file), as an absolute path; None when not given."""
    path = t.string("errors_from", None)
    if path is None:
        return None
    full = os.path.normpath(path if os.path.isabs(path) else os.path.join(base_dir, path))
    fix = f"make the study with `vfrs converge SCENE -o {full}`, or remove the key (paths are relative to the scene file)"
    if not os.path.isdir(full):
        raise t.error(f"the converge study folder {full!r} does not exist; {fix}", "errors_from")
    if not os.path.isfile(os.path.join(full, "converge.json")):
        raise t.error(f"{full!r} holds no converge study (no converge.json); {fix}", "errors_from")
    return full


def _until(t: Table, time: Time) -> tuple:
    """``until``, ``until_cycles``, ``until_cap`` (s; None unless until = "limit_cycle",
    whose default is UNTIL_CAP x [time] end) and ``until_tolerance``: a dynamic run with a cycle
    signal (an effect's ``cycle_signal``, e.g. [flow]'s glottal area) may run on until its
    cycles repeat."""
    until = t.string("until", "end", choices=UNTIL)
    cycles = t.integer("until_cycles", UNTIL_CYCLES, minimum=2)
    if until == "end":
        for key in ("until_cap", "until_tolerance"):
            if t.has(key):
                raise t.error(f'{key} applies to until = "limit_cycle" only; remove it or set until', key)
        return until, cycles, None, UNTIL_TOLERANCE
    tolerance = t.number("until_tolerance", UNTIL_TOLERANCE, positive=True,
                         what=" (a fraction: 0.02 for 2 %)")
    if tolerance >= 1.0:
        raise t.error(f"until_tolerance = {tolerance:g} is a fraction, not a percentage: 0.02 for 2 %; below 1",
                      "until_tolerance")
    if not time.dynamic:
        raise t.error(f'until = "limit_cycle" needs a dynamic run ([time] mode = "dynamic"), not {time.mode!r}',
                      "until")
    end = float(time.end)
    cap = t.number("until_cap", UNTIL_CAP * end, positive=True, what=", s")
    if cap < end:
        raise t.error(f"until_cap = {cap:g} s is before [time] end = {end:g} s; the run would end at end anyway",
                      "until_cap")
    return until, cycles, float(cap), float(tolerance)
