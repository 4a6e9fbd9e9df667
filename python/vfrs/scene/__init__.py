"""Scenes: what to simulate, read from TOML (or a dict), validated up front into typed objects.

A scene names the bodies (mesh, material, damping, fixed surfaces, prescribed displacements,
surface loads, initial velocity), gravity, rigid obstacles, the optional effects (``[flow]``,
``[contact]``), the time stepping and the outputs. :meth:`Scene.load` checks the whole file
before anything is computed; every error names the file, the key path and what was expected,
and suggests the nearest valid key for a typo. :meth:`Scene.to_dict` gives the resolved scene,
defaults included; ``Scene.from_dict(s.to_dict()).to_dict() == s.to_dict()``.

>>> import vfrs
>>> scene = vfrs.Scene.from_dict({
...     "bodies": [{"name": "beam",
...                 "mesh": {"builtin": "box", "size": [0.1, 0.01, 0.01], "cells": [10, 1, 1]},
...                 "material": {"model": "isotropic", "E": 1e6, "nu": 0.3, "rho": 1000.0},
...                 "fixed": ["xmin"]}],
...     "time": {"mode": "static"}})
>>> scene.time.mode, scene.bodies[0].fixed[0].selector
('static', {'surface': 'xmin'})
>>> vfrs.Scene.from_dict(scene.to_dict()).to_dict() == scene.to_dict()
True

Schema (keys in ``[]`` are optional, with their defaults)::

    title = ""                            # free text
    gravity = [0, 0, 0]                   # m/s^2, on every body
    [[bodies]]
    name = "beam"                         # unique
    mesh = { builtin = "box", size = [...], cells = [...] }   # any vfrs.meshes.PARAMS entry
         # or { path = "folds.msh", length_unit = "m" }        # relative to the scene file
         #    (merge_nodes = true: nodes at one position, an unmerged seam, become one)
         #    (refine = n: every tetrahedron split into eight, n times; surfaces and regions kept)
    material = { model = "isotropic", E = 1e6, nu = 0.3, rho = 1000 }   # any vfrs.MATERIALS entry
         # or { cover = { model = ... }, body = { model = ... } }  per mesh region
    [damping = { a0 = 0.0, a1 = 0.0 }]    # Rayleigh C = a0 M + a1 K (a0 in 1/s, a1 in s)
    [mass = "consistent"]                 # or "lumped"
    [velocity = [0, 0, 0]]                # initial velocity, m/s
    [fixed = []]                          # "surface" or { surface = ... } or
                                          # { axis = "z", below|above|at = ..., [tol] } with
                                          # [components = ["x", "y", "z"]], [displacement = [0,0,0]],
                                          # [ramp = 0.0] (s; quintic smoothstep from 0; 0 = a
                                          # step at t = 0; static runs scale by load factor), [name]
    [loads = []]                          # { type = "pressure", value = Pa } (along -n) or
                                          # { type = "traction", value = [Pa, Pa, Pa] }, on
                                          # surface = ... or an axis selector; [ramp], [name]
    [[obstacles]]                         # rigid planes (need [contact])
    type = "plane"; point = [...]; normal = [...]; [name]
    [flow] / [contact]                    # effects; validated by the registered effect
    [time]
    mode = "dynamic"                      # step, end, [alpha = -0.3] in [-1/3, 0] (HHT-alpha;
                                          # -0.3 is the paper's); ceil(end / step) steps
         # or "static"                    # [load_steps = 1]
                                          # with a finite-strain body (neo_hookean,
                                          # st_venant_kirchhoff, fibre_reinforced)
                                          # either mode runs Newton: [newton = { method = "full",
                                          # residual_tolerance = 1e-8, increment_tolerance = 1e-8,
                                          # max_iterations = 25, refactor_ratio = 0.5, line_search = true }]
    [output]
    [every = 10]                          # field output every N steps (static: each load step)
    [fields = ["displacement", "velocity"]]
    [probes = []]                         # points; the nearest node's history is kept each step
    [energy = true]; [reactions = true]
    [until = "end"]                       # or "limit_cycle": on past [time] end until the last
                                          # [until_cycles = 4] cycles repeat (the summary's
                                          # periodicity test), at most to [until_cap = 4 x end] s
    [errors_from = "STUDY"]               # a converge study of this scene (vfrs converge -o
                                          # STUDY): vfrs run prints each number with its error
    [checks]
    [strict = false]                      # vocal-fold scenes (an m5 body or [flow]): sizes,
                                          # pressures, moduli, densities far outside the
                                          # physiological range (likely unit slips) warn
                                          # (vfrs.PlausibilityWarning); true: they are errors
                                          # (vfrs.PlausibilityError); vfrs.scene.plausibility
"""

from __future__ import annotations

import copy
import os
import re
from .._compat import tomllib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import meshes as _meshes
from ..effects import KNOWN_SECTIONS, EFFECTS, effect_class
from ..errors import MaterialError, MeshError, SceneError
from ..materials import MATERIALS
from ..params import read_params
from ..mesh import LENGTH_UNITS, check_mesh_path, read_mesh
from . import plausibility as _plausibility
from . import selectors as _sel
from . import sizes as _sizes
from ..params.table import Table, join, suggest
from .toml_writer import dumps

__all__ = ["Scene", "Body", "Constraint", "Load", "Plane", "Time", "Output"]

COMPONENTS = ("x", "y", "z")
#: The state's fields ``[output] fields`` may name: name -> the State attribute that holds it
#: (vfrs.history writes them into the snapshots).
FIELDS = {"displacement": "u", "velocity": "v", "acceleration": "a"}
TOP_KEYS = ("title", "gravity", "bodies", "obstacles", "time", "output", "checks")


@dataclass
class Constraint:
    """Dirichlet condition: the selected nodes' ``components`` follow ``displacement`` (ramped)."""

    name: str
    selector: dict
    components: tuple = ("x", "y", "z")
    displacement: list = field(default_factory=lambda: [0.0, 0.0, 0.0])
    ramp: float = 0.0
    where: str = ""

    @property
    def prescribed(self) -> bool:
        return any(self.displacement[COMPONENTS.index(c)] != 0.0 for c in self.components)

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            **self.selector,
            "components": list(self.components),
            "displacement": list(self.displacement),
            "ramp": self.ramp,
        }


@dataclass
class Load:
    """Surface load: ``pressure`` (scalar, along the inward normal) or ``traction`` (vector)."""

    name: str
    type: str
    selector: dict
    value: object
    ramp: float = 0.0
    where: str = ""

    def to_dict(self) -> dict:
        return {"name": self.name, "type": self.type, **self.selector, "value": self.value, "ramp": self.ramp}


@dataclass
class Body:
    name: str
    mesh: dict  # resolved: a generator's Params as data ({"builtin": name, ...}), or {"path", "length_unit"}
    material: object  # a material, or {region: material}
    damping: dict = field(default_factory=lambda: {"a0": 0.0, "a1": 0.0})
    mass: str = "consistent"
    velocity: list = field(default_factory=lambda: [0.0, 0.0, 0.0])
    fixed: list = field(default_factory=list)
    loads: list = field(default_factory=list)
    where: str = ""

    def material_dict(self):
        if isinstance(self.material, dict):
            return {k: m.to_dict() for k, m in self.material.items()}
        return self.material.to_dict()

    def build_mesh(self, source: str = "<dict>"):
        """Builds (through the generator's Params) or reads the mesh; errors name the scene key."""
        spec = self.mesh
        try:
            if "path" in spec:
                mesh = read_mesh(spec["path"], length_unit=spec["length_unit"], merge_nodes=spec.get("merge_nodes", False))
                return mesh.refined(spec.get("refine", 0))
            return _generator_params(spec).build().refined(spec.get("refine", 0))
        except (MeshError, TypeError, ValueError) as e:
            if isinstance(e, SceneError):
                raise
            key = join(join(self.where, "mesh"), "path") if "path" in spec else join(self.where, "mesh")
            raise SceneError(f"{source}: {key}: {e}") from None

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "mesh": copy.deepcopy(self.mesh),
            "material": self.material_dict(),
            "damping": dict(self.damping),
            "mass": self.mass,
            "velocity": list(self.velocity),
            "fixed": [c.to_dict() for c in self.fixed],
            "loads": [ld.to_dict() for ld in self.loads],
        }


def read_toml(path) -> dict:
    """The parsed TOML of a scene file; a missing file or bad TOML is a SceneError."""
    path = os.fspath(path)
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise SceneError(f"{path}: scene file does not exist") from None
    except IsADirectoryError:
        raise SceneError(f"{path}: is a folder; give the scene's .toml file") from None
    except PermissionError:
        raise SceneError(f"{path}: cannot read the scene file (permission denied)") from None
    except UnicodeDecodeError as e:
        raise SceneError(f"{path}: not a text file (byte {e.start} is not UTF-8); a scene is a TOML file") from None
    except tomllib.TOMLDecodeError as e:
        raise SceneError(f"{path}: not valid TOML: {e}") from None
    except OSError as e:
        raise SceneError(f"{path}: cannot read the scene file: {e.strerror or e}") from None


@dataclass
class Plane:
    """A rigid plane obstacle; ``normal`` (unit) points out of the obstacle, into the free side."""

    name: str
    point: list
    normal: list

    def to_dict(self) -> dict:
        return {"name": self.name, "type": "plane", "point": list(self.point), "normal": list(self.normal)}


@dataclass
class Time:
    """``[time]``: the ``mode``, the registered ``integrator`` class that it and the bodies'
    kinematics chose (:func:`vfrs.roles.integrator_for`), and that class's
    ``params`` (its scene keys); those keys read as attributes too (``time.step``,
    ``time.load_steps``, ``time.newton``: whatever the chosen integrator declares)."""

    mode: str
    integrator: Any
    params: Any

    def __getattr__(self, name):
        if name.startswith("_") or name in ("mode", "integrator", "params"):
            raise AttributeError(name)
        try:
            return getattr(self.__dict__["params"], name)
        except (KeyError, AttributeError):
            raise AttributeError(f"[time] mode = {self.__dict__.get('mode')!r} has no key {name!r}") from None

    @property
    def n_steps(self) -> int:
        return self.integrator.count_steps(self.params)

    @property
    def dynamic(self) -> bool:
        """Whether the run has inertia."""
        return bool(self.integrator.dynamic)

    def to_dict(self) -> dict:
        return {"mode": self.mode, **self.integrator.to_dict(self.params)}


#: Compressions of the VTU field files (``[output] compression``).
COMPRESSIONS = ("zlib", "lzma", "none")
#: ``[output] until``: end at ``[time] end``, or run on until the cycles repeat.
UNTIL = ("end", "limit_cycle")
#: ``[output] until_cycles`` unless given: how many of the last cycles must repeat (the
#: summary's periodicity test compares as many; vfrs.analysis.PERIODIC_CYCLES).
UNTIL_CYCLES = 4
#: ``[output] until_cap`` unless given: this many times ``[time] end``.
UNTIL_CAP = 4.0


@dataclass
class Output:
    every: int = 10
    fields: list = field(default_factory=lambda: ["displacement", "velocity"])
    probes: list = field(default_factory=list)
    energy: bool = True
    reactions: bool = True
    checkpoint_every: int = 0  # steps between checkpoints (0: by wall time)
    checkpoint_seconds: float = 60.0  # wall time between checkpoints (0: only on SIGTERM/SIGINT)
    compression: str = "zlib"  # of the VTU field files: "zlib", "lzma" or "none"
    # When the run ends (docs/running.md, "Running on to a limit cycle"): at [time] end, or
    # ("limit_cycle") on past it until the last until_cycles cycles repeat
    # (vfrs.analysis.RunView.periodicity), at the latest at until_cap (s of simulated time).
    until: str = "end"
    until_cycles: int = UNTIL_CYCLES
    until_cap: float | None = None
    # Not in the resolved scene (to_dict): it changes what is printed, not what runs, so a
    # run's id and its study's scene key do not depend on it. Kept as an absolute path.
    errors_from: str | None = field(default=None, compare=False)  # a converge study's folder (vfrs converge; relative to the scene file): vfrs run prints each number's error from it

    def to_dict(self) -> dict:
        d = {
            "every": self.every,
            "fields": list(self.fields),
            "probes": [list(p) for p in self.probes],
            "checkpoint_every": self.checkpoint_every,
            "checkpoint_seconds": self.checkpoint_seconds,
            "compression": self.compression,
            "energy": self.energy,
            "reactions": self.reactions,
        }
        # Only when set: the resolved scenes (and their hashes) of other runs stay as they were.
        if self.until != "end":
            d.update(until=self.until, until_cycles=self.until_cycles, until_cap=self.until_cap)
        elif self.until_cycles != UNTIL_CYCLES:
            d["until_cycles"] = self.until_cycles
        return d


@dataclass
class Scene:
    """A validated scene. Build with :meth:`load` or :meth:`from_dict`; run with :func:`vfrs.run`."""

    bodies: list
    time: Time
    output: Output = field(default_factory=Output)
    gravity: list = field(default_factory=lambda: [0.0, 0.0, 0.0])
    obstacles: list = field(default_factory=list)
    effects: dict = field(default_factory=dict)  # section name -> the effect's resolved Params
    title: str = ""
    source: str = "<dict>"
    checks: _plausibility.ChecksParams = field(default_factory=_plausibility.ChecksParams)  # [checks]
    #: The plausibility warnings of this scene (:mod:`vfrs.scene.plausibility`), for run.log.
    plausibility: list = field(default_factory=list, repr=False, compare=False)

    # ---- construction -------------------------------------------------------------------
    @classmethod
    def load(cls, path) -> "Scene":
        """Reads and validates a TOML scene; mesh paths are relative to the file's folder."""
        path = os.fspath(path)
        return cls.from_dict(read_toml(path), source=path, base_dir=os.path.dirname(os.path.abspath(path)))

    @classmethod
    def from_dict(cls, data: dict, source: str = "<dict>", base_dir: str | None = None) -> "Scene":
        """Validates a scene given as a dict (the parsed TOML); see the module docstring."""
        return _parse(data, source, base_dir or os.getcwd())

    def to_dict(self) -> dict:
        """The resolved scene, defaults included, as plain TOML-compatible data."""
        d: dict = {"title": self.title, "gravity": list(self.gravity)}
        d["time"] = self.time.to_dict()
        d["output"] = self.output.to_dict()
        for name, params in self.effects.items():
            d[name] = copy.deepcopy(effect_class(name, name, self.source).to_dict(params))
        d["bodies"] = [b.to_dict() for b in self.bodies]
        d["obstacles"] = [o.to_dict() for o in self.obstacles]
        if self.checks != _plausibility.ChecksParams():  # only when set: the resolved scenes (and
            from ..params import params_to_dict  # their hashes) of earlier runs stay as they were

            d["checks"] = params_to_dict(self.checks)
        return d

    def to_toml(self) -> str:
        return dumps(self.to_dict())

    def save(self, path) -> None:
        """Writes the resolved scene as TOML (what every output folder holds as ``scene.toml``)."""
        with open(path, "w") as fh:
            fh.write(f"# resolved vfrs scene (defaults included), from {self.source}\n")
            fh.write(self.to_toml())

    def body(self, name: str) -> Body:
        for b in self.bodies:
            if b.name == name:
                return b
        raise SceneError(f"no body {name!r}; bodies: {[b.name for b in self.bodies]}{suggest(name, [b.name for b in self.bodies])}")

    def build_meshes(self) -> list:
        """The bodies' meshes, with every named surface the scene refers to checked. The
        memory the scene needs is estimated first (:mod:`vfrs.scene.sizes`): past what the
        machine has, a SceneError, before anything is allocated."""
        self.check_size()
        out = []
        for b in self.bodies:
            mesh = b.build_mesh(self.source)
            for item in list(b.fixed) + list(b.loads):
                sel = item.selector
                if "surface" in sel and sel["surface"] not in mesh.surfaces:
                    raise SceneError(
                        f"{self.source}: {join(item.where, 'surface')}: the mesh of body {b.name!r} has no "
                        f"surface {sel['surface']!r}{suggest(sel['surface'], mesh.surfaces)}; it has {sorted(mesh.surfaces)}"
                    )
                if isinstance(item, Constraint) and len(_sel.select_nodes(mesh, sel)) == 0:
                    raise SceneError(f"{self.source}: {item.where}: the selector {sel} selects no node of body {b.name!r}")
                if isinstance(item, Load) and len(_sel.select_faces(mesh, sel)) == 0:
                    raise SceneError(f"{self.source}: {item.where}: the selector {sel} selects no boundary face of body {b.name!r}")
            if isinstance(b.material, dict):
                for region in b.material:
                    if region not in mesh.regions:
                        raise SceneError(
                            f"{self.source}: {join(join(b.where, 'material'), region)}: the mesh of body "
                            f"{b.name!r} has no region {region!r}{suggest(region, mesh.regions)}; it has {sorted(mesh.regions)}"
                        )
            out.append(mesh)
        if "contact" in self.effects:
            _check_contact(self.effects["contact"], {b.name: list(m.surfaces) for b, m in zip(self.bodies, out)},
                           self.source)
        if any("path" in b.mesh for b in self.bodies):  # now with the counts of the files' meshes
            self.check_size([(m.n_points, m.n_tets) for m in out])
            _plausibility.check_meshes(self, out)  # a fold's mesh file read in the wrong length_unit
        return out

    def size_estimate(self, counts=None) -> dict:
        """Nodes, DOFs and the estimated bytes of the matrices, the factors and the meshes
        (:func:`vfrs.scene.sizes.estimate`); meshes read from files count once built
        (``counts``: (nodes, tetrahedra) per body), else as unknown."""
        if counts is None:
            counts = [None if "path" in b.mesh else _generator_estimate(b.mesh) for b in self.bodies]
        return _sizes.estimate(counts)

    def check_size(self, counts=None) -> dict:
        """:meth:`size_estimate`, with a SceneError past the memory limit
        (:func:`vfrs.scene.sizes.memory_limit`: available memory, or ``VFRS_MEMORY_LIMIT``)."""
        if counts is None:
            counts = [None if "path" in b.mesh else _generator_estimate(b.mesh) for b in self.bodies]
        return _sizes.check_memory(self.source, counts, [join(b.where, "mesh") for b in self.bodies])

    @property
    def effect_names(self) -> list:
        return list(self.effects)


# ---- parsing ---------------------------------------------------------------------------
BODY_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")


def _check_body_name(top: Table, i: int, name) -> None:
    """Body names name output files (``<name>.pvd``, ``fields/<name>_<step>.vtu``): a name,
    never a path."""
    if not (isinstance(name, str) and BODY_NAME.fullmatch(name) and name not in (".", "..")):
        raise top.error(f"body {i}: name {name!r} is not a valid body name: use letters, digits, '_', '.' and '-' "
                        "(not starting with '.' or '-'; no path separators or spaces), e.g. 'right'",
                        join(join("bodies", i), "name"))


def _parse(data, source, base_dir) -> Scene:
    top = Table(data, "", source)
    title = top.string("title", "")
    gravity = top.vector("gravity", [0.0, 0.0, 0.0])
    bodies_raw = top.array("bodies")
    if not bodies_raw:
        raise top.error("expected at least one [[bodies]] table", "bodies")
    bodies = [_body(Table(b, join("bodies", i), source), base_dir) for i, b in enumerate(bodies_raw)]
    names = [b.name for b in bodies]
    for i, n in enumerate(names):
        if names.index(n) != i:
            raise top.error(f"body name {n!r} is used twice; names must be unique", join(join("bodies", i), "name"))
        _check_body_name(top, i, n)
    obstacles = [_obstacle(Table(o, join("obstacles", i), source), i) for i, o in enumerate(top.array("obstacles", []))]
    finite = [(i, b) for i, b in enumerate(bodies) if _kinematics(top, b) == "finite"]
    time = _time(top.table("time"), finite)
    output = _output(top.table("output", {}), time, base_dir)
    checks = read_params(_plausibility.ChecksParams, ct := top.table("checks", {}))
    ct.done()

    effects = {}
    sections = set(KNOWN_SECTIONS) | set(EFFECTS)
    for key in data:
        if key in TOP_KEYS:
            continue
        if key in sections:
            top.read.add(key)
            cls = effect_class(key, key, source)
            t = top.table(key)
            effects[key] = cls.resolve(t)
    top.done(set(TOP_KEYS) | sections)
    if "contact" in effects:  # what can be checked without the meshes: pairs, body names
        _check_contact(effects["contact"], {b.name: None for b in bodies}, source)
    if obstacles and "contact" not in effects:
        raise top.error("rigid obstacles act only through contact; add a [contact] section or remove [[obstacles]]", "obstacles")
    if output.until != "end" and not any(getattr(EFFECTS[name], "cycle_signal", None) for name in effects):
        raise top.error(f'until = "{output.until}" runs on until the cycles of a periodic signal repeat, and no effect '
                        "of this scene records one (the glottal area of [flow]); add [flow] or remove it",
                        "output.until")
    scene = Scene(
        bodies=bodies, time=time, output=output, gravity=gravity, obstacles=obstacles,
        effects=effects, title=title, source=source, checks=checks,
    )
    _plausibility.check_scene(scene)  # a vocal-fold scene's unit slips: warnings, or errors when strict
    return scene


def _check_contact(settings, surfaces_of: dict, source: str) -> None:
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


def _generator_params(spec: dict):
    """The generator's Params of a resolved built-in mesh (without vfrs's own ``refine``)."""
    return _meshes.PARAMS[spec["builtin"]].from_dict({k: v for k, v in spec.items() if k != "refine"})


def _generator_estimate(spec: dict):
    """(nodes, tetrahedra) of a resolved built-in mesh: the generator's estimate, times 8 per
    refinement (an upper bound for the nodes: a refinement adds one node per edge)."""
    size = _generator_params(spec).estimate()
    r = int(spec.get("refine", 0))
    return None if size is None else (size[0] * 8**r, size[1] * 8**r)


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
    t.done()
    return Load(name or f"{kind}:{_sel.describe(sel)}", kind, sel, value, ramp, where)


def _body(t: Table, base_dir) -> Body:
    name = t.string("name")
    mesh = _mesh(t.table("mesh"), base_dir)
    material = _material(t.table("material"))
    d = t.table("damping", {})
    damping = {"a0": d.number("a0", 0.0, nonnegative=True, what=" (1/s)"),
               "a1": d.number("a1", 0.0, nonnegative=True, what=" (s)")}
    d.done()
    mass = t.string("mass", "consistent", choices=("consistent", "lumped"))
    velocity = t.vector("velocity", [0.0, 0.0, 0.0])
    fixed = [_constraint(c, join(join(t.where, "fixed"), i), t.source, i) for i, c in enumerate(t.array("fixed", []))]
    loads = [_load(c, join(join(t.where, "loads"), i), t.source) for i, c in enumerate(t.array("loads", []))]
    t.done()
    return Body(name, mesh, material, damping, mass, velocity, fixed, loads, t.where)


def _obstacle(t: Table, i) -> Plane:
    t.string("type", "plane", choices=("plane",))
    name = t.string("name", f"plane{i}")
    point = t.vector("point")
    normal = np.asarray(t.vector("normal"))
    norm = float(np.sqrt(np.sum(normal * normal)))  # numpy's sum, not BLAS's ddot: the same bits on every CPU
    if norm == 0:
        raise t.error("expected a nonzero normal vector", "normal")
    t.done()
    return Plane(name, point, (normal / norm).tolist())


def _kinematics(top: Table, b) -> str:
    from ..materials import kinematics_of

    try:
        return kinematics_of(b.material)
    except MaterialError as e:
        raise top.error(str(e), join(b.where, "material")) from None


def _time(t: Table, finite=()) -> Time:
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


def _output(t: Table, time: Time, base_dir: str) -> Output:
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
    # VTU field files (vfrs.vtu): zlib (default) about 5x smaller than none and about as fast
    # (medium M5 fold: 3.8 ms vs 3.6 ms per file); lzma 20 % smaller again and 10x slower.
    compression = t.string("compression", "zlib", choices=COMPRESSIONS)
    until, cycles, cap = _until(t, time)
    errors_from = _errors_from(t, base_dir)
    t.done()
    return Output(every, list(fields), pts, energy, reactions, ck_every, ck_seconds, compression, until, cycles, cap,
                  errors_from)


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
    """``until``, ``until_cycles`` and ``until_cap`` (s; None unless until = "limit_cycle",
    whose default is UNTIL_CAP x [time] end): a dynamic run with a cycle signal (an effect's
    ``cycle_signal``, e.g. [flow]'s glottal area) may run on until its cycles repeat."""
    until = t.string("until", "end", choices=UNTIL)
    cycles = t.integer("until_cycles", UNTIL_CYCLES, minimum=2)
    if until == "end":
        if t.has("until_cap"):
            raise t.error('until_cap applies to until = "limit_cycle" only; remove it or set until', "until_cap")
        return until, cycles, None
    if not time.dynamic:
        raise t.error(f'until = "limit_cycle" needs a dynamic run ([time] mode = "dynamic"), not {time.mode!r}',
                      "until")
    end = float(time.end)
    cap = t.number("until_cap", UNTIL_CAP * end, positive=True, what=", s")
    if cap < end:
        raise t.error(f"until_cap = {cap:g} s is before [time] end = {end:g} s; the run would end at end anyway",
                      "until_cap")
    return until, cycles, float(cap)
