"""The finite-strain model of a problem: internal force, consistent tangent and strain energy
of all its bodies (total Lagrangian), beside the linear assembly (:mod:`vfrs.assembly`).

Finite-strain bodies (``kinematics = "finite"``: ``neo_hookean``, ``st_venant_kirchhoff``,
``fibre_reinforced``) are evaluated by the Rust core (:class:`vfrs._core.FiniteStrainAssembler`);
linear bodies of the same problem contribute ``K u`` and ``K``. The Newton solver
(:func:`vfrs.dynamics.newton.newton_solve`) iterates on it; the Newton integrators
(:mod:`vfrs.dynamics.integrators`) build it.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from . import _core
from .assembly import element_materials, sparsity_pattern, stiffness
from .linalg import dot
from .materials import kinematics_of

__all__ = ["FiniteStrainModel", "has_finite_strain"]


def has_finite_strain(problem) -> bool:
    """Whether any body of the problem has a finite-strain material."""
    return any(kinematics_of(b.config.material) == "finite" for b in problem.bodies)


class FiniteStrainModel:
    """Internal force, tangent and strain energy of all bodies of a problem: finite-strain
    bodies by the Rust assembler, linear ones by their K. The tangent of all DOFs lives on
    one fixed block-diagonal CSC pattern (the bodies' P1 patterns), its free-free block on a
    pattern computed once (:meth:`vfrs.DofMap` ``reduce_pattern``), so a tangent is a gather
    and a numeric refactorization."""

    def __init__(self, problem):
        self.problem = problem
        self.free, self.fixed = problem.free, problem.fixed
        self.parts = []
        indptrs, indices = [np.zeros(1, dtype=np.int64)], []
        nnz = 0
        for b in problem.bodies:
            mesh = b.mesh
            if kinematics_of(b.config.material) == "finite":
                mats, of = element_materials(mesh, b.config.material)
                kind = (_core.hyperelastic.QuadraticFiniteStrainAssembler if mesh.order == 2
                        else _core.hyperelastic.FiniteStrainAssembler)  # ten-node: the same calls
                asm = kind(mesh.points, mesh.tets)
                self.parts.append((b.dofs, asm, [m.hyperelastic() for m in mats], of, None))
                ip, ix = asm.pattern()
            else:
                K = stiffness(mesh, b.config.material)
                self.parts.append((b.dofs, None, None, None, K))
                ip, ix = sparsity_pattern(mesh)
            indptrs.append(np.asarray(ip[1:], dtype=np.int64) + nnz)
            indices.append(np.asarray(ix, dtype=np.int64) + b.dofs.start)
            nnz += int(ip[-1])
        n = problem.n_dofs
        self.indptr, self.indices = np.concatenate(indptrs), np.concatenate(indices)
        self.data = np.zeros(nnz)
        self.n = n
        cp, ri, self._src = problem.dofmap._m.reduce_pattern(self.indptr, self.indices)
        self._free_pattern = (np.asarray(cp), np.asarray(ri))

    def _evaluate(self, u, tangent: bool):
        f = np.zeros(self.n)
        energy = 0.0
        pos = 0
        for dofs, asm, laws, of, K in self.parts:
            ub = np.ascontiguousarray(u[dofs])
            if asm is not None:
                if tangent:
                    fb, kb, w = asm.force_and_tangent(ub, laws, of)
                    self.data[pos:pos + len(kb)] = kb
                    pos += len(kb)
                else:
                    fb, w = asm.internal_force(ub, laws, of)
                f[dofs] = fb
                energy += float(w)
            else:
                fb = K @ ub
                f[dofs] = fb
                energy += 0.5 * dot(ub, fb)
                if tangent:
                    self.data[pos:pos + K.nnz] = K.data
                    pos += K.nnz
        return f, energy

    def force(self, u) -> tuple:
        """``(f_int, energy)`` at the displacement ``u`` (all DOFs)."""
        return self._evaluate(u, tangent=False)

    def force_and_tangent(self, u) -> tuple:
        """``(f_int, energy)``; the tangent's values stay in :meth:`tangent_free` / :meth:`tangent_full`."""
        return self._evaluate(u, tangent=True)

    def tangent_full(self) -> sp.csc_matrix:
        """K_T of all DOFs (from the last :meth:`force_and_tangent`)."""
        return sp.csc_matrix((self.data, self.indices, self.indptr), shape=(self.n, self.n))

    def tangent_free(self) -> sp.csc_matrix:
        """K_T,ff (from the last :meth:`force_and_tangent`), on the fixed free pattern."""
        cp, ri = self._free_pattern
        m = len(self.free)
        return sp.csc_matrix((self.data[self._src], ri, cp), shape=(m, m))
