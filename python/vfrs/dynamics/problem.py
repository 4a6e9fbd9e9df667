"""The assembled problem of a scene: all bodies in one DOF space, constraints, loads, probes."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..assembly import mass, stiffness
from ..errors import SceneError
from ..linalg import DofMap
from ..scene import COMPONENTS
from ..scene.selectors import select_faces, select_nodes


def ramp(t: float, duration: float) -> tuple:
    """Smooth ramp from 0 to 1 over ``duration``: (r, r', r'') at time t.

    The quintic smoothstep r = s^3 (10 - 15 s + 6 s^2), s = t / T, starts and ends with zero
    velocity and acceleration, so a ramped load or prescribed motion does not kick the body
    (a cosine ramp jumps in acceleration at both ends and rings). ``duration = 0``: a step.

    >>> ramp(0.5, 1.0), ramp(2.0, 1.0)
    ((0.5, 1.875, 0.0), (1.0, 0.0, 0.0))
    """
    if duration <= 0.0 or t >= duration:
        return (1.0, 0.0, 0.0) if t >= 0.0 else (0.0, 0.0, 0.0)
    if t <= 0.0:
        return 0.0, 0.0, 0.0
    s = t / duration
    r = s**3 * (10.0 - 15.0 * s + 6.0 * s * s)
    dr = 30.0 * s * s * (1.0 - s) ** 2 / duration
    ddr = 60.0 * s * (1.0 - s) * (1.0 - 2.0 * s) / duration**2
    return r, dr, ddr


def pulse(t: float, duration: float) -> float:
    """A load pulse that rises and falls back to zero over ``duration`` (s): sin^2(pi t / T)
    for 0 <= t <= T, zero before and after. Its value and slope are zero at both ends and it
    peaks at 1 at t = T / 2; its integral is T / 2 (a load's impulse is half its peak times T).

    >>> round(pulse(0.25, 1.0), 12), pulse(0.5, 1.0), pulse(1.5, 1.0)
    (0.5, 1.0, 0.0)
    """
    if duration <= 0.0 or t <= 0.0 or t >= duration:
        return 0.0
    return math.sin(math.pi * t / duration) ** 2


@dataclass
class BodyPart:
    """One body in the global numbering: nodes ``node_offset ... node_offset + n_points``."""

    name: str
    mesh: Any
    node_offset: int
    config: Any  # the scene's Body

    @property
    def n_points(self) -> int:
        return self.mesh.n_points

    @property
    def dofs(self) -> slice:
        return slice(3 * self.node_offset, 3 * (self.node_offset + self.mesh.n_points))

    @property
    def nodes(self) -> slice:
        return slice(self.node_offset, self.node_offset + self.mesh.n_points)


@dataclass
class Group:
    """Fixed DOFs of one constraint: ``dofs`` (global), ``values`` (target displacement), ramp."""

    body: str
    name: str
    dofs: np.ndarray
    values: np.ndarray
    ramp: float
    components: Any = None  # 0, 1, 2 per DOF
    own: Any = None  # per DOF: this group is the first to fix it (its prescribed motion is this group's)


@dataclass
class Prescribed:
    """A prescribed (nonzero) constraint group: u_p(t) = r(t) d on its fixed DOFs, and its
    coupling to the free DOFs, K_fp d, C_fp d, M_fp d, computed once."""

    group: Group
    fixed_values: np.ndarray  # d on the fixed DOFs (problem.fixed order)
    kd: np.ndarray
    cd: np.ndarray
    md: np.ndarray


@dataclass
class SurfaceLoad:
    body: str
    name: str
    vector: np.ndarray  # consistent nodal forces, all DOFs
    ramp: float
    pulse: float = 0.0

    def factor(self, t: float) -> float:
        """The load's scale at time t of a dynamic run: its pulse (sin^2, back to zero) if it
        has one, else its ramp (s)."""
        return pulse(t, self.pulse) if self.pulse else ramp(t, self.ramp)[0]


class Problem:
    """All bodies of a scene in one DOF space (node-major, bodies one after the other).

    Attributes effects may use in ``setup``: ``bodies`` (:class:`BodyPart` with ``mesh`` and
    ``node_offset``), ``points`` (reference coordinates, all nodes), ``n_dofs``, ``dofmap``,
    ``K``, ``M`` (all DOFs, csr), ``K_free``, ``M_free``, ``obstacles``, ``scene``. It is
    complete once built; what the integrator factors is the integrator's
    (:class:`vfrs.effects.SetupContext`).
    """

    def __init__(self, scene, meshes):
        self.scene = scene
        self.obstacles = list(scene.obstacles)
        self.bodies = []
        off = 0
        for b, m in zip(scene.bodies, meshes):
            self.bodies.append(BodyPart(b.name, m, off, b))
            off += m.n_points
        self.n_points = off
        self.n_dofs = 3 * off
        self.points = np.concatenate([p.mesh.points for p in self.bodies])
        self._probes: list | None = None
        self.probe_nodes()  # validated before anything is assembled or written
        self._assemble()

    # -- assembly ---------------------------------------------------------------------
    def _assemble(self):
        Ks, Ms, Cs = [], [], []
        damp = []
        for p in self.bodies:
            mat = p.config.material
            Ks.append(stiffness(p.mesh, mat))
            Ms.append(mass(p.mesh, mat, lumped=p.config.mass == "lumped"))
            damp.append((p.config.damping["a0"], p.config.damping["a1"]))
        self.K = sp.block_diag(Ks, format="csr") if len(Ks) > 1 else Ks[0]
        self.M = sp.block_diag(Ms, format="csr") if len(Ms) > 1 else Ms[0]
        self.uniform_damping = all(d == damp[0] for d in damp)
        if self.uniform_damping:
            self.rayleigh = damp[0]
            self.C = None
        else:
            self.rayleigh = None
            self.C = sp.block_diag([a0 * M + a1 * K for (a0, a1), M, K in zip(damp, Ms, Ks)], format="csr")
        self.damped = any(a0 or a1 for a0, a1 in damp)
        self._constraints()
        self._loads()
        self.K_free = self.dofmap.reduce(self.K)
        self.M_free = self.dofmap.reduce(self.M)
        self.C_free = None if self.C is None else self.dofmap.reduce(self.C)

    def set_mass(self, M) -> None:
        """Replaces the mass matrix (all DOFs; a contact scheme's, before the integrator is
        built): the free block, the damping (a0 M), gravity and the prescribed motions'
        couplings follow it. Rows of zeros are allowed (massless nodes): the integrators
        factor the mass on the other DOFs only."""
        self.M = sp.csr_matrix(M)
        self.M_free = self.dofmap.reduce(self.M)
        if self.C is not None:
            blocks = []
            for p in self.bodies:
                a0, a1 = p.config.damping["a0"], p.config.damping["a1"]
                s = p.dofs
                blocks.append(a0 * self.M[s, s] + a1 * self.K[s, s])
            self.C = sp.block_diag(blocks, format="csr")
            self.C_free = self.dofmap.reduce(self.C)
        for pr in self.prescribed:
            d = np.zeros(self.n_dofs)
            d[pr.group.dofs[pr.group.own]] = pr.group.values[pr.group.own]
            pr.md = (self.M @ d)[self.free]
            pr.cd = self.damping_times(d)[self.free]
        g = np.asarray(self.scene.gravity, dtype=float)
        self.gravity = (self.M @ np.tile(g, self.n_points)) if np.any(g) else None

    def damping_times(self, x):
        """C x over all DOFs."""
        if self.C is not None:
            return self.C @ x
        a0, a1 = self.rayleigh
        out = np.zeros_like(x)
        if a0:
            out += a0 * (self.M @ x)
        if a1:
            out += a1 * (self.K @ x)
        return out

    def _constraints(self):
        self.groups = []
        value_of = {}
        for p in self.bodies:
            for c in p.config.fixed:
                nodes = select_nodes(p.mesh, c.selector) + p.node_offset
                comps = np.array([COMPONENTS.index(k) for k in c.components])
                dofs = (3 * nodes[:, None] + comps[None, :]).ravel()
                vals = np.tile(np.asarray(c.displacement)[comps], len(nodes))
                for d, v in zip(dofs.tolist(), vals.tolist()):
                    if d in value_of and value_of[d][0] != v:
                        raise SceneError(
                            f"{self.scene.source}: {c.where}: prescribes {v:g} on DOF {d} (body {p.name!r}), "
                            f"which {value_of[d][1]} already fixes at {value_of[d][0]:g}"
                        )
                    value_of.setdefault(d, (v, c.where))
                self.groups.append(Group(p.name, c.name, dofs, vals, c.ramp, np.tile(comps, len(nodes))))
        fixed = np.array(sorted(value_of), dtype=np.int64)
        self.dofmap = DofMap(self.n_dofs, fixed)
        self.free = self.dofmap.free
        self.fixed = self.dofmap.fixed
        if len(self.free) == 0:
            raise SceneError(f"{self.scene.source}: every DOF is fixed; nothing to solve")
        pos = {d: i for i, d in enumerate(self.fixed.tolist())}
        owner: dict = {}  # a DOF named by several groups (surfaces sharing an edge) moves with the first
        for i, g in enumerate(self.groups):
            g.positions = np.array([pos[d] for d in g.dofs.tolist()], dtype=np.int64)
            own = np.array([owner.setdefault(d, i) == i for d in g.dofs.tolist()], dtype=bool)
            g.own = own
        # Prescribed (nonzero) groups: u_p(t) = r_g(t) d_g on the fixed DOFs the group is the
        # first to name (a DOF on two surfaces that prescribe it the same value moves once, not
        # twice). Their coupling to the free DOFs, K_fp d_g, C_fp d_g, M_fp d_g, is computed once.
        self.prescribed = []
        for g in self.groups:
            if not np.any(g.values[g.own]):
                continue
            d = np.zeros(self.n_dofs)
            d[g.dofs[g.own]] = g.values[g.own]
            kd = (self.K @ d)[self.free]
            md = (self.M @ d)[self.free]
            cd = self.damping_times(d)[self.free]
            self.prescribed.append(Prescribed(g, d[self.fixed], kd, cd, md))

    def fixed_values(self, t: float, derivative: int = 0, static: bool = False) -> np.ndarray:
        """Displacement (or its time derivatives) of the fixed DOFs at time (or load factor) t."""
        out = np.zeros(len(self.fixed))
        for pr in self.prescribed:
            r = (t, 1.0, 0.0) if static else ramp(t, pr.group.ramp)
            if r[derivative]:
                out += r[derivative] * pr.fixed_values
        return out

    def _loads(self):
        self.loads = []
        for p in self.bodies:
            for ld in p.config.loads:
                faces = select_faces(p.mesh, ld.selector)
                f = np.zeros((self.n_points, 3))
                nodes = slice(p.node_offset, p.node_offset + p.mesh.n_points)
                if p.mesh.order == 2:  # consistent with the curved six-node faces (vfrs.quadratic)
                    pressure = np.full(p.mesh.n_points, float(ld.value)) if ld.type == "pressure" else None
                    f[nodes] = p.mesh.quadratic_faces().forces(p.mesh.points, faces, pressure=pressure,
                                                               traction=None if pressure is not None else ld.value)
                else:
                    x = p.mesh.points[faces]
                    cross = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])  # 2 area n
                    if ld.type == "pressure":
                        fn = -ld.value * cross / 6.0  # -p n A / 3 on each node
                    else:
                        area = np.linalg.norm(cross, axis=1) / 2.0
                        fn = np.outer(area / 3.0, ld.value)
                    for k in range(3):
                        np.add.at(f, faces[:, k] + p.node_offset, fn)
                self.loads.append(SurfaceLoad(p.name, ld.name, f.ravel(), ld.ramp, ld.pulse))
        g = np.asarray(self.scene.gravity, dtype=float)
        self.gravity = (self.M @ np.tile(g, self.n_points)) if np.any(g) else None

    def external_force(self, t: float, static: bool = False) -> np.ndarray:
        """Surface loads and gravity at time t (static: scaled by the load factor t), all DOFs."""
        f = np.zeros(self.n_dofs)
        for ld in self.loads:
            r = t if static else ld.factor(t)
            if r:
                f += r * ld.vector
        if self.gravity is not None:
            f += (t if static else 1.0) * self.gravity
        return f

    # -- queries ----------------------------------------------------------------------
    def nearest_node(self, point) -> int:
        d = np.linalg.norm(self.points - np.asarray(point, dtype=float), axis=1)
        return int(np.argmin(d))

    #: A probe is accepted within this many times the longest element edge at its nearest
    #: node (a point inside or on a body is within one such edge of it).
    PROBE_TOLERANCE_EDGES = 2.0

    def probe_nodes(self) -> list:
        """``[(node, distance)]`` for the scene's ``[output] probes``, in order: the global
        node each probe snaps to and its distance from the point (m). A probe farther than
        :attr:`PROBE_TOLERANCE_EDGES` longest element edges at that node from it (outside
        every body) is a SceneError naming the probe and the distance."""
        if self._probes is None:
            self._probes = [self._snap_probe(i, p) for i, p in enumerate(self.scene.output.probes)]
        return list(self._probes)

    def _snap_probe(self, i: int, point) -> tuple:
        return self.snap(point, f"{self.scene.source}: output.probes[{i}]")

    def snap(self, point, where: str = "point") -> tuple:
        """``(node, distance)``: the node nearest to ``point`` (reference configuration) and its
        distance (m); a SceneError naming ``where`` if the point is not finite or lies farther
        than :attr:`PROBE_TOLERANCE_EDGES` longest element edges from that node."""
        x = np.asarray(point, dtype=float)
        if x.shape != (3,) or not np.all(np.isfinite(x)):
            raise SceneError(f"{where}: expected a finite point [x, y, z], got {list(np.ravel(point))}")
        d = np.linalg.norm(self.points - x, axis=1)
        node = int(np.argmin(d))
        dist = float(d[node])
        part = self.body_of_node(node)
        local = node - part.node_offset
        tets = part.mesh.tets[(part.mesh.tets == local).any(axis=1)]
        xt = part.mesh.points[tets]
        pairs = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
        h = max((float(np.linalg.norm(xt[:, a] - xt[:, b], axis=1).max()) for a, b in pairs), default=0.0)
        tol = self.PROBE_TOLERANCE_EDGES * h
        if dist > tol:
            raise SceneError(
                f"{where}: the point {x.tolist()} is {dist:.4g} m from the nearest node (node {local} of body "
                f"{part.name!r}, at {part.mesh.points[local].tolist()}), farther than {tol:.3g} m "
                f"({self.PROBE_TOLERANCE_EDGES:g} element edges there): it is outside every body. Give a point "
                "inside or on a body (coordinates in metres)"
            )
        return node, dist

    def body_of_node(self, node: int) -> BodyPart:
        for p in self.bodies:
            if p.node_offset <= node < p.node_offset + p.n_points:
                return p
        raise IndexError(node)

    def sizes(self) -> dict:
        return {
            "bodies": len(self.bodies),
            "nodes": self.n_points,
            "tetrahedra": sum(p.mesh.n_tets for p in self.bodies),
            "dofs": self.n_dofs,
            "free_dofs": int(len(self.dofmap.free)) if hasattr(self, "dofmap") else None,
        }


def build_problem(scene, meshes=None) -> Problem:
    """Builds the meshes (unless given) and assembles K, M, damping, constraints and loads."""
    if meshes is None:
        meshes = scene.build_meshes()
    return Problem(scene, meshes)
