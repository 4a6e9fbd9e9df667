"""Finite strain: hyperelastic materials and total-Lagrangian assembly (rust/vfrs-py/src/hyperelastic.rs)."""

from collections.abc import Sequence
from typing import Any, final

import numpy as np
from numpy.typing import NDArray

_F64 = NDArray[np.float64]
_I64 = NDArray[np.int64]
_U8 = NDArray[np.uint8]
_Pairs = dict[str, NDArray[Any]]

__all__ = ["HyperelasticMaterial", "FiniteStrainAssembler", "QuadraticFiniteStrainAssembler", "neo_hookean", "neo_hookean_from_young", "st_venant_kirchhoff", "fibre_reinforced"]

@final
class HyperelasticMaterial:
    @property
    def kind(self) -> str: ...

def neo_hookean(mu: float, lam: float) -> HyperelasticMaterial: ...

def neo_hookean_from_young(e: float, nu: float) -> HyperelasticMaterial: ...

def st_venant_kirchhoff(elasticity: _F64) -> HyperelasticMaterial: ...

def fibre_reinforced(
    mu: float, lam: float, k1: float, k2: float, axis: Sequence[float]
) -> HyperelasticMaterial: ...

@final
class FiniteStrainAssembler:
    def __new__(cls, points: _F64, tets: _I64) -> FiniteStrainAssembler: ...
    @property
    def nnz(self) -> int: ...
    def pattern(self) -> tuple[_I64, _I64]: ...
    def internal_force(
        self, u: _F64, materials: Sequence[HyperelasticMaterial], material_of: _I64 | None = None
    ) -> tuple[_F64, float]: ...
    def tangent(
        self, u: _F64, materials: Sequence[HyperelasticMaterial], material_of: _I64 | None = None
    ) -> _F64: ...
    def force_and_tangent(
        self, u: _F64, materials: Sequence[HyperelasticMaterial], material_of: _I64 | None = None
    ) -> tuple[_F64, _F64, float]: ...
    def energy(
        self, u: _F64, materials: Sequence[HyperelasticMaterial], material_of: _I64 | None = None
    ) -> float: ...

@final
class QuadraticFiniteStrainAssembler:
    """FiniteStrainAssembler's calls on ten-node tetrahedra (tets: (m, 10), VTK's node order)."""
    def __new__(cls, points: _F64, tets: _I64) -> QuadraticFiniteStrainAssembler: ...
    @property
    def nnz(self) -> int: ...
    def pattern(self) -> tuple[_I64, _I64]: ...
    def internal_force(
        self, u: _F64, materials: Sequence[HyperelasticMaterial], material_of: _I64 | None = None
    ) -> tuple[_F64, float]: ...
    def tangent(
        self, u: _F64, materials: Sequence[HyperelasticMaterial], material_of: _I64 | None = None
    ) -> _F64: ...
    def force_and_tangent(
        self, u: _F64, materials: Sequence[HyperelasticMaterial], material_of: _I64 | None = None
    ) -> tuple[_F64, _F64, float]: ...
    def energy(
        self, u: _F64, materials: Sequence[HyperelasticMaterial], material_of: _I64 | None = None
    ) -> float: ...
