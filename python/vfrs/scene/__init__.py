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
    [order = 1]                           # 2: ten-node (quadratic) tetrahedra, mid-edge nodes on the
                                          # generator's true geometry (M5 family, sphere) or midpoints
    [velocity = [0, 0, 0]]                # initial velocity, m/s
    [fixed = []]                          # "surface" or { surface = ... } or
                                          # { axis = "z", below|above|at = ..., [tol] } with
                                          # [components = ["x", "y", "z"]], [displacement = [0,0,0]],
                                          # [ramp = 0.0] (s; quintic smoothstep from 0; 0 = a
                                          # step at t = 0; static runs scale by load factor), [name]
    [loads = []]                          # { type = "pressure", value = Pa } (along -n) or
                                          # { type = "traction", value = [Pa, Pa, Pa] }, on
                                          # surface = ... or an axis selector; [ramp], [name],
                                          # [pulse = 0.0] (s; sin^2 rise and fall back to 0
                                          # over it, then 0; instead of ramp)
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
                                          # periodicity test) within [until_tolerance = 0.05]
                                          # (each per-cycle value's (max - min) / mean), at most
                                          # to [until_cap = 4 x end] s
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
from .._compat import tomllib
from dataclasses import dataclass, field


from ..effects import KNOWN_SECTIONS, EFFECTS, check_effects, effect_class
from ..errors import SceneError
from ..params import read_params
from . import plausibility as _plausibility
from . import selectors as _sel
from . import sizes as _sizes
from ..params.table import Table, join, suggest
from .toml_writer import dumps

__all__ = ["Scene", "Body", "Constraint", "Load", "Plane", "Time", "Output"]

from .model import (COMPONENTS, COMPRESSIONS, FIELDS, TOP_KEYS, UNTIL, UNTIL_CAP, UNTIL_CYCLES, Body,  # noqa: F401
                    Constraint, Load, Output, Plane, Time, generator_estimate)
from .parse import check_body_name, check_contact, kinematics, read_body, read_obstacle, read_output, read_time


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
            check_contact(self.effects["contact"], {b.name: list(m.surfaces) for b, m in zip(self.bodies, out)},
                           self.source)
        if any("path" in b.mesh for b in self.bodies):  # now with the counts of the files' meshes
            self.check_size([(m.n_points, m.n_tets, m.order) for m in out])
            _plausibility.check_meshes(self, out)  # a fold's mesh file read in the wrong length_unit
        return out

    def size_estimate(self, counts=None) -> dict:
        """Nodes, DOFs and the estimated bytes of the matrices, the factors and the meshes
        (:func:`vfrs.scene.sizes.estimate`); meshes read from files count once built
        (``counts``: (nodes, tetrahedra) per body), else as unknown."""
        if counts is None:
            counts = [None if "path" in b.mesh else generator_estimate(b.mesh, b.order) for b in self.bodies]
        return _sizes.estimate(counts)

    def check_size(self, counts=None) -> dict:
        """:meth:`size_estimate`, with a SceneError past the memory limit
        (:func:`vfrs.scene.sizes.memory_limit`: available memory, or ``VFRS_MEMORY_LIMIT``)."""
        if counts is None:
            counts = [None if "path" in b.mesh else generator_estimate(b.mesh, b.order) for b in self.bodies]
        return _sizes.check_memory(self.source, counts, [join(b.where, "mesh") for b in self.bodies])

    @property
    def effect_names(self) -> list:
        return list(self.effects)


def _parse(data, source, base_dir) -> Scene:
    top = Table(data, "", source)
    title = top.string("title", "")
    gravity = top.vector("gravity", [0.0, 0.0, 0.0])
    bodies_raw = top.array("bodies")
    if not bodies_raw:
        raise top.error("expected at least one [[bodies]] table", "bodies")
    bodies = [read_body(Table(b, join("bodies", i), source), base_dir) for i, b in enumerate(bodies_raw)]
    names = [b.name for b in bodies]
    for i, n in enumerate(names):
        if names.index(n) != i:
            raise top.error(f"body name {n!r} is used twice; names must be unique", join(join("bodies", i), "name"))
        check_body_name(top, i, n)
    obstacles = [read_obstacle(Table(o, join("obstacles", i), source), i) for i, o in enumerate(top.array("obstacles", []))]
    finite = [(i, b) for i, b in enumerate(bodies) if kinematics(top, b) == "finite"]
    time = read_time(top.table("time"), finite)
    output = read_output(top.table("output", {}), time, base_dir)
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
    check_effects(effects, top.error)  # e.g. [acoustics] needs [flow]
    if "contact" in effects:  # what can be checked without the meshes: pairs, body names
        check_contact(effects["contact"], {b.name: None for b in bodies}, source)
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
