"""A scene's parts as typed objects: bodies (with their constraints and loads), obstacles,
[time] and [output], and the constants of their keys. :mod:`vfrs.scene.parse` reads them from
a scene's tables; :class:`vfrs.scene.Scene` holds them."""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Any


from .. import meshes as _meshes
from ..errors import MeshError, SceneError
from ..mesh import read_mesh
from ..params.table import join
from . import sizes as _sizes


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
    """Surface load: ``pressure`` (scalar, along the inward normal, Pa) or ``traction`` (vector,
    Pa). Its time profile in a dynamic run: ``ramp`` (s) rises smoothly to the full value and
    stays (0: a step at t = 0); ``pulse`` (s) instead rises and falls back to zero over that
    duration, ``sin^2(pi t / pulse)`` (:func:`vfrs.dynamics.problem.pulse`), and is zero after.
    A static run scales either by its load factor (the pulse's peak is reached at the last
    load step)."""

    name: str
    type: str
    selector: dict
    value: object
    ramp: float = 0.0
    where: str = ""
    pulse: float = 0.0

    def to_dict(self) -> dict:
        d = {"name": self.name, "type": self.type, **self.selector, "value": self.value, "ramp": self.ramp}
        if self.pulse:  # only when given: scenes without a pulse read and hash as before
            d["pulse"] = self.pulse
        return d


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
    #: 2: ten-node tetrahedra (:func:`vfrs.meshes.quadratic.quadratic_mesh`); None: linear (left out
    #: of the resolved scene, so that scenes without the key hash as before)
    order: int | None = None

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
                mesh = mesh.refined(spec.get("refine", 0))
            else:
                mesh = generator_params(spec).build().refined(spec.get("refine", 0))
            return self._at_order(mesh, source)
        except (MeshError, TypeError, ValueError) as e:
            if isinstance(e, SceneError):
                raise
            key = join(join(self.where, "mesh"), "path") if "path" in spec else join(self.where, "mesh")
            raise SceneError(f"{source}: {key}: {e}") from None

    def _at_order(self, mesh, source: str):
        """The mesh at the body's ``order``: a linear mesh made quadratic for ``order = 2``; a
        quadratic file with ``order`` unset or 1 refused (the body would not be what it says)."""
        if self.order == 2:
            if getattr(mesh, "midpoint", None) is None and mesh.order == 1 and self.mesh.get("builtin") == "m5":
                raise SceneError(f"{source}: {join(self.where, 'order')}: order = 2 on the M5 folds needs the "
                                 "systematic family (mesh = { builtin = \"m5\", family = \"systematic\", level = k }): "
                                 "its mid-edge nodes are placed on the folds' true arcs, the ladder meshes' are not")
            from ..meshes.quadratic import quadratic_mesh

            return quadratic_mesh(mesh)
        if mesh.order == 2:
            raise SceneError(f"{source}: {join(self.where, 'order')}: the mesh file holds ten-node tetrahedra; set "
                             "order = 2 for this body (or give a linear mesh)")
        return mesh

    def to_dict(self) -> dict:
        d = self._to_dict()
        if self.order is not None:
            d["order"] = self.order
        return d

    def _to_dict(self) -> dict:
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
#: summary's periodicity test compares as many; vfrs.signals.PERIODIC_CYCLES).
UNTIL_CYCLES = 4
#: ``[output] until_cap`` unless given: this many times ``[time] end``.
UNTIL_CAP = 4.0
#: ``[output] until_tolerance`` unless given: the largest spread, (max - min) / mean, of each
#: per-cycle value over the last cycles (vfrs.signals.PERIODIC_TOLERANCE, the summary's own).
UNTIL_TOLERANCE = 0.05


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
    # ("limit_cycle") on past it until the last until_cycles cycles repeat within
    # until_tolerance (vfrs.summary.RunView.periodicity), at the latest at until_cap (s of
    # simulated time). The summary's periodicity verdict uses the same tolerance.
    until: str = "end"
    until_cycles: int = UNTIL_CYCLES
    until_cap: float | None = None
    until_tolerance: float = UNTIL_TOLERANCE
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
            if self.until_tolerance != UNTIL_TOLERANCE:
                d["until_tolerance"] = self.until_tolerance
        elif self.until_cycles != UNTIL_CYCLES:
            d["until_cycles"] = self.until_cycles
        return d


def generator_params(spec: dict):
    """The generator's Params of a resolved built-in mesh (without vfrs's own ``refine``)."""
    return _meshes.PARAMS[spec["builtin"]].from_dict({k: v for k, v in spec.items() if k != "refine"})


def generator_estimate(spec: dict, order: int | None = None):
    """(nodes, tetrahedra, order) of a resolved built-in mesh: the generator's estimate, times 8
    per refinement (an upper bound for the nodes: a refinement adds one node per edge), and
    the nodes times 8 again at order 2 (a mid-edge node per edge)."""
    size = generator_params(spec).estimate()
    r = int(spec.get("refine", 0))
    if size is None:
        return None
    quadratic = order == 2
    return (size[0] * 8**r * (_sizes.QUADRATIC_NODES if quadratic else 1), size[1] * 8**r, 2 if quadratic else 1)
