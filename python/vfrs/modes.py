"""Modal analysis of a scene's bodies: ``vfrs modes SCENE`` and :func:`modes` (issue 32, item 2).

Each body's linear stiffness K and mass M, assembled as a run assembles them
(:func:`vfrs.dynamics.problem.build_problem`: the body's material, its ``mass = "consistent"``
or ``"lumped"``), with the scene's ``fixed`` conditions removing their DOFs, gives the
generalized eigenproblem K phi = omega^2 M phi; its lowest ``n`` modes per body are found by
shift-invert Lanczos (scipy's ``eigsh``, the shifted matrix factored by vfrs's own sparse
Cholesky) about a small negative shift, so a free body's zero (rigid) modes do not make the
factorization singular. Bodies are uncoupled: contact, flow,
loads, prescribed displacement values (only which DOFs are fixed counts), gravity, damping and
a contact scheme's changed mass are all left out. These are the small-vibration modes of the
bodies about their reference configuration.

Per mode: the frequency f = omega / (2 pi) in Hz; the dominant displacement component (the
share of the mode's kinetic energy phi^T M phi in x, y, z; for the folds x is medio-lateral,
y inferior-superior, z anterior-posterior); and the participation, the effective modal mass of
a rigid translation in x, y, z as a fraction of the body's mass,
(phi^T M r_d)^2 / (phi^T M phi) / (r_d^T M r_d). A mode whose eigenvalue is below
:data:`RIGID_TOLERANCE` times the body's largest diagonal ratio K_ii / M_ii is a rigid (zero)
mode: a free body has six; they are counted and skipped, and the ``n`` modes reported are the
elastic ones.

>>> import vfrs
>>> scene = vfrs.Scene.from_dict({"bodies": [{"name": "bar", "material": {"model": "isotropic", "E": 1e4, "nu": 0.3,
...     "rho": 1000}, "mesh": {"builtin": "box", "size": [0.02, 0.002, 0.002], "cells": [10, 1, 1]},
...     "fixed": ["xmin"]}], "time": {"mode": "dynamic", "step": 1e-4, "end": 1e-3}})
>>> r = modes(scene, n=2)
>>> [m.direction for m in r.bodies[0].modes]
['y', 'z']
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from xml.sax.saxutils import quoteattr

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .errors import VfrsError
from .output.vtu import FieldFileWriter

#: A mode with omega^2 below this times the body's largest K_ii / M_ii is rigid (zero).
RIGID_TOLERANCE = 1e-10
#: The shift-invert shift: minus this times the body's largest K_ii / M_ii.
SHIFT = 1e-8
#: What the components mean for the folds (the M5 generator's axes).
AXES = {"x": "medio-lateral", "y": "inferior-superior", "z": "anterior-posterior"}


@dataclass
class Mode:
    """One elastic mode of one body: ``frequency`` (Hz), ``shape`` (n_points, 3, zero on the
    fixed DOFs, scaled to a largest nodal displacement of 1), ``shares`` (kinetic energy share in
    x, y, z), ``participation`` (effective mass fraction in x, y, z), ``direction`` ("x", "y" or
    "z", the largest share)."""

    number: int
    frequency: float
    shape: np.ndarray
    shares: np.ndarray
    participation: np.ndarray

    @property
    def direction(self) -> str:
        return "xyz"[int(np.argmax(self.shares))]


@dataclass
class BodyModes:
    name: str
    n_points: int
    n_free: int
    n_fixed: int
    rigid: int  # zero modes found (and skipped)
    modes: list = field(default_factory=list)
    rigid_frequencies: list = field(default_factory=list)  # theirs (Hz; round-off from zero)
    mesh: object = None

    @property
    def frequencies(self) -> np.ndarray:
        return np.array([m.frequency for m in self.modes])


@dataclass
class ModesResult:
    """What :func:`modes` found: ``bodies`` (:class:`BodyModes`, in the scene's order)."""

    source: str
    bodies: list

    def table(self) -> str:
        """The modes as a text table, a header line per body."""
        lines = []
        for b in self.bodies:
            rigid = (f"; {b.rigid} rigid (zero) modes skipped" if b.rigid else "")
            lines.append(f"body {b.name!r}: {b.n_points} nodes, {b.n_free} free DOFs, {b.n_fixed} fixed{rigid}")
            lines.append(f"  {'mode':>4}  {'f [Hz]':>10}  {'direction':<22} {'share':>6}  "
                         f"{'eff. mass x':>11} {'y':>6} {'z':>6}")
            for m in b.modes:
                d = m.direction
                p = 100.0 * m.participation
                hz = f"{m.frequency:.1f}" if m.frequency >= 10.0 else f"{m.frequency:.4g}"
                lines.append(f"  {m.number:>4}  {hz:>10}  {d + ' (' + AXES[d] + ')':<22} "
                             f"{100.0 * m.shares.max():>5.1f}%  {p[0]:>10.1f}% {p[1]:>5.1f}% {p[2]:>5.1f}%")
        lines.append("K and M as a run assembles them, the scene's fixed DOFs removed; contact, flow, loads, "
                     "gravity and damping ignored. share: the mode's kinetic energy in its direction; eff. mass: "
                     "effective modal mass of a rigid translation, % of the body's mass.")
        return "\n".join(lines)

    def write(self, out) -> list:
        """One VTU per mode per body (``OUT/<body>_mode_NN.vtu``, point data ``shape``, the mode
        scaled to a largest nodal displacement of 1, and ``magnitude``) and a ``<body>_modes.pvd``
        series (timestep = mode number), and ``modes.csv``; returns the paths written."""
        out = os.fspath(out)
        os.makedirs(out, exist_ok=True)
        written = []
        for b in self.bodies:
            w = FieldFileWriter(b.mesh.points, b.mesh.tets)
            items = []
            for m in b.modes:
                name = f"{b.name}_mode_{m.number:02d}.vtu"
                w.write(os.path.join(out, name), {"shape": m.shape, "magnitude": np.linalg.norm(m.shape, axis=1)})
                written.append(os.path.join(out, name))
                items.append((m.number, m.frequency, name))
            lines = ['<?xml version="1.0"?>', f"<!-- modes of body {b.name!r}: mode number, frequency (Hz) -->",
                     '<VTKFile type="Collection" version="0.1">', "<Collection>"]
            lines += [f'<DataSet timestep="{k}" part="0" file={quoteattr(f)}/><!-- {hz:.6g} Hz -->'
                      for k, hz, f in items]
            lines += ["</Collection>", "</VTKFile>"]
            pvd = os.path.join(out, f"{b.name}_modes.pvd")
            with open(pvd, "w") as fh:
                fh.write("\n".join(lines) + "\n")
            written.append(pvd)
        written.append(self.write_csv(os.path.join(out, "modes.csv")))
        return written

    def write_csv(self, path) -> str:
        """``modes.csv``: a row per mode per body, the numbers as Python floats' shortest
        round-trip text (a numpy scalar's repr would be ``np.float64(...)``); returns ``path``."""
        import csv

        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["body", "mode", "frequency_hz", "direction", "share", "eff_mass_x", "eff_mass_y", "eff_mass_z"])
            for b in self.bodies:
                for m in b.modes:
                    share, px, py, pz = (repr(float(x)) for x in (m.shares.max(), *m.participation))
                    w.writerow([b.name, m.number, repr(float(m.frequency)), m.direction, share, px, py, pz])
        return path


def modes(scene, n: int = 10, out=None) -> ModesResult:
    """The lowest ``n`` elastic modes of each body of ``scene`` (a :class:`vfrs.Scene` or a
    scene file) with its fixed conditions; ``out``: a folder for the VTU/PVD files and
    ``modes.csv`` (:meth:`ModesResult.write`). See the module's docstring for what is left out."""
    from .dynamics.problem import build_problem
    from .scene import Scene

    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise VfrsError(f"modes: n = {n!r}: expected a whole number of modes, 1 or more")
    if not isinstance(scene, Scene):
        scene = Scene.load(scene)
    problem = build_problem(scene)
    fixed = np.zeros(problem.n_dofs, dtype=bool)
    fixed[problem.fixed] = True
    bodies = [_body_modes(p, problem.K, problem.M, fixed, int(n)) for p in problem.bodies]
    result = ModesResult(scene.source, bodies)
    if out is not None:
        result.write(out)
    return result


def _body_modes(part, K, M, fixed_all, n: int) -> BodyModes:
    s = part.dofs
    Kb = sp.csr_matrix(K[s, s])
    Mb = sp.csr_matrix(M[s, s])
    fixed = fixed_all[s]
    free = np.flatnonzero(~fixed)
    nf = len(free)
    body = BodyModes(part.name, part.n_points, nf, int(fixed.sum()), 0, mesh=part.mesh)
    if nf == 0:
        return body
    Kf = sp.csc_matrix(Kb[free][:, free])
    Mf = sp.csc_matrix(Mb[free][:, free])
    kd, md = Kf.diagonal(), Mf.diagonal()
    if np.any(md <= 0.0):
        raise VfrsError(f"modes: body {part.name!r} has free DOFs without mass (M_ii <= 0)")
    scale = float(np.max(kd / md))
    want = min(n + 6, nf)  # room for up to six rigid modes
    if nf <= 200 or want >= nf - 1:
        w, v = _dense(Kf, Mf)
        w, v = w[:want], v[:, :want]
    else:
        w, v = _shift_invert(Kf, Mf, want, -SHIFT * scale)
    order = np.argsort(w)
    w, v = w[order], v[:, order]
    rigid = w < RIGID_TOLERANCE * scale
    body.rigid = int(rigid.sum())
    body.rigid_frequencies = [float(np.sqrt(abs(x)) / (2.0 * np.pi)) for x in w[rigid]]
    w, v = w[~rigid][:n], v[:, ~rigid][:, :n]
    total = np.zeros(3)
    r = np.zeros((3 * part.n_points, 3))
    for c in range(3):
        r[c::3, c] = 1.0
        total[c] = r[:, c] @ (Mb @ r[:, c])
    for i in range(len(w)):
        phi = np.zeros(3 * part.n_points)
        phi[free] = v[:, i]
        Mphi = Mb @ phi
        mm = float(phi @ Mphi)
        shares = np.array([float(phi[c::3] @ Mphi[c::3]) for c in range(3)]) / mm
        part_ = (r.T @ Mphi) ** 2 / mm / total
        shape = phi.reshape(-1, 3)
        peak = np.linalg.norm(shape, axis=1).max()
        shape = shape / peak if peak > 0 else shape
        k = int(np.argmax(np.abs(shape).ravel()))
        if shape.ravel()[k] < 0:  # a fixed sign: the largest component positive
            shape = -shape
        body.modes.append(Mode(i + 1, float(np.sqrt(max(w[i], 0.0)) / (2.0 * np.pi)), shape, shares, part_))
    return body


def _shift_invert(Kf, Mf, k: int, sigma: float):
    """The ``k`` eigenpairs of K phi = lambda M phi nearest ``sigma`` by Lanczos (scipy's
    ``eigsh``) with the shift-invert operator (K - sigma M)^-1 factored by vfrs's own sparse
    Cholesky (:func:`vfrs.linalg.cholesky`, the runs' solver; K - sigma M is positive definite
    for sigma < 0), not by scipy's SuperLU, whose fill made a quadratic fold of 280 000 free DOFs
    need 15 GB (6 GB here; the same frequencies to 1e-12)."""
    from .linalg import cholesky

    factor = cholesky(sp.csc_matrix(Kf - sigma * Mf))
    op = spla.LinearOperator(Kf.shape, matvec=factor.solve, dtype=float)
    return spla.eigsh(Kf, k=k, M=Mf, sigma=sigma, which="LM", OPinv=op)


def _dense(Kf, Mf):
    from scipy.linalg import eigh

    return eigh(Kf.toarray(), Mf.toarray())
