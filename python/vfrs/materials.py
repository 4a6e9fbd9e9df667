"""Linear elastic tissue models, in a registry keyed by ``name`` (the scene's ``model``).

A material is a frozen dataclass: its fields are its typed parameters (its ``Params``), each
declared with :func:`vfrs.params.param` (description, unit, checks). The scene reads a
``material`` table into them with :func:`vfrs.params.read_params` and writes them back with
:meth:`Material.to_dict`. A new linear material is one class, registered with
:func:`register_material` (here, or in any module the user imports)::

    @register_material
    @dataclass(frozen=True)
    class Cubic(Material):
        name: ClassVar[str] = "cubic"      # the scene's `model`
        C11: float = param(doc="stiffness C11", unit="Pa", positive=True)
        ...
        rho: float = param(1070.0, doc="density", unit="kg/m^3", positive=True)

        def elasticity(self) -> np.ndarray: ...   # the 6x6 matrix D (Voigt)

>>> sorted(MATERIALS)
['fibre_reinforced', 'isotropic', 'neo_hookean', 'st_venant_kirchhoff', 'transversely_isotropic', 'vocal_fold']
>>> material_from_dict({"model": "isotropic", "E": 1e4, "nu": 0.3}).to_dict()
{'model': 'isotropic', 'E': 10000.0, 'nu': 0.3, 'rho': 1070.0}
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from . import _core
from .params import Vec3, check_params, param, params_to_dict
from .registry import Registry

__all__ = [
    "Material", "Isotropic", "TransverselyIsotropic", "VocalFold", "MATERIALS", "register_material",
    "unregister_material", "material_from_dict", "NEARLY_INCOMPRESSIBLE", "NeoHookean", "StVenantKirchhoff",
    "FibreReinforced", "kinematics_of",
]

#: Poisson's ratio above which isotropic P1 elements warn about volumetric locking.
NEARLY_INCOMPRESSIBLE = 0.49

#: The registered materials by ``name`` (the scene's ``model``).
MATERIALS = Registry("material")


def register_material(cls):
    """Class decorator: registers a material class under its own ``name``.

    The class must be a dataclass with its own ``name`` (not one inherited from the class it
    extends), an ``elasticity()`` method, and fields of types the scene can read (``float``,
    ``int``, ``bool``, ``str``, ``Vec3``, ...).
    """
    if not dataclasses.is_dataclass(cls):
        raise TypeError(f"{cls.__name__}: a material must be a dataclass (its fields are its parameters)")
    name = cls.__dict__.get("name")
    if not isinstance(name, str) or not name:
        raise TypeError(f"{cls.__name__}: a material needs its own class attribute `name` (the scene's `model`)")
    if not callable(getattr(cls, "elasticity", None)):
        raise TypeError(f"{cls.__name__}: a material needs an `elasticity()` method (the 6x6 matrix D)")
    check_params(cls)
    if name in MATERIALS and MATERIALS[name] is not cls:
        raise ValueError(f"material {name!r} is already registered ({MATERIALS[name].__name__})")
    return MATERIALS.register(cls)


def unregister_material(name: str) -> None:
    """Removes a material from the registry (tests use this to restore it)."""
    MATERIALS.unregister(name)


class Material:
    """Base of the linear materials: ``name`` (the scene's ``model``), ``elasticity()`` and
    ``to_dict()``. Subclasses are frozen dataclasses whose fields are the parameters, with a
    density ``rho`` (kg/m^3)."""

    name: ClassVar[str] = ""
    #: ``"linear"`` (small strain: K assembled and factored once) or ``"finite"`` (a
    #: hyperelastic law, total Lagrangian: statics by Newton, :mod:`vfrs.dynamics.newton`).
    kinematics: ClassVar[str] = "linear"
    rho: float

    def hyperelastic(self):
        """The Rust law (``vfrs._core.HyperelasticMaterial``) of a finite-strain material."""
        raise NotImplementedError(f"material {self.name!r} is linear (small strain); it has no hyperelastic law")

    def elasticity(self) -> np.ndarray:
        """6x6 matrix D, Voigt order xx, yy, zz, yz, xz, xy (engineering shear)."""
        raise NotImplementedError

    def to_dict(self) -> dict:
        """``{"model": name, **parameters}`` (arrays as lists): what ``material_from_dict`` reads."""
        return {"model": self.name, **params_to_dict(self)}


@register_material
@dataclass(frozen=True)
class Isotropic(Material):
    """Isotropic linear elasticity.

    >>> import vfrs
    >>> D = vfrs.Isotropic(E=10e3, nu=0.45, rho=1070).elasticity()
    >>> round(float(D[3, 3]), 3)  # shear modulus E / (2 (1 + nu))
    3448.276
    """

    name: ClassVar[str] = "isotropic"
    E: float = param(doc="Young's modulus", unit="Pa")
    nu: float = param(doc="Poisson's ratio")
    rho: float = param(1070.0, doc="density", unit="kg/m^3", positive=True)

    def __post_init__(self):
        self.elasticity()  # validates, raising MaterialError
        _check_density(self.rho)
        _warn_locking(self.nu)

    def elasticity(self) -> np.ndarray:
        """6x6 matrix D, Voigt order xx, yy, zz, yz, xz, xy (engineering shear)."""
        return _core.fem.elasticity_isotropic(float(self.E), float(self.nu))


@register_material
@dataclass(frozen=True)
class TransverselyIsotropic(Material):
    """Transversely isotropic elasticity about a fibre ``axis`` (default z, anterior-posterior).

    ``E_p``, ``nu_p``: modulus and Poisson's ratio in the plane of isotropy; ``E_z``: along the
    fibre; ``nu_pz``: contraction along the fibre under in-plane stress (``nu_zp = nu_pz E_z/E_p``);
    ``G_pz``: shear modulus in planes containing the fibre. Positive definiteness needs
    ``1 - nu_p - 2 nu_pz**2 E_z / E_p > 0``.
    """

    name: ClassVar[str] = "transversely_isotropic"
    E_p: float = param(doc="in-plane Young's modulus", unit="Pa")
    E_z: float = param(doc="Young's modulus along the fibre", unit="Pa")
    nu_p: float = param(doc="in-plane Poisson's ratio")
    nu_pz: float = param(doc="Poisson's ratio, fibre contraction under in-plane stress")
    G_pz: float = param(doc="shear modulus in planes containing the fibre", unit="Pa")
    rho: float = param(1070.0, doc="density", unit="kg/m^3", positive=True)
    axis: Vec3 = param((0.0, 0.0, 1.0), doc="fibre direction")

    def __post_init__(self):
        _set_axis(self)
        self.elasticity()
        _check_density(self.rho)

    def elasticity(self) -> np.ndarray:
        return _core.fem.elasticity_transversely_isotropic(
            float(self.E_p), float(self.E_z), float(self.nu_p), float(self.nu_pz), float(self.G_pz), list(self.axis)
        )


@register_material
@dataclass(frozen=True)
class VocalFold(TransverselyIsotropic):
    """Vocal-fold tissue with literature defaults: transversely isotropic about the fibre
    (anterior-posterior, z) axis.

    Defaults and where they come from (values as used in the fold models that the paper
    follows; check the originals before quoting them as measurements):

    - ``E_p = 2 kPa``, in-plane (transverse) Young's modulus, and ``nu_p = 0.9``, the in-plane
      Poisson's ratio: Alipour, Berry & Titze (2000), J. Acoust. Soc. Am. 108, 3003-3012.
    - ``G_pz = 10 kPa``, longitudinal shear modulus: Alipour et al. (2000); Zhang (2016,
      J. Acoust. Soc. Am. 139, 1493) discusses 10-40 kPa for cover and body.
    - ``E_z = 40 kPa``, longitudinal Young's modulus (fibre stiffness) and ``nu_pz = 0``:
      this project's choice (docs/design.md, "Balance and tissue"), in the range reported for the cover
      (Zhang 2016: tens of kPa along the fibres at rest).
    - ``rho = 1070 kg/m^3``: Alipour et al. (2000) (soft tissue 1040-1070 kg/m^3).

    >>> VocalFold().E_p, VocalFold(G_pz=40e3).G_pz
    (2000.0, 40000.0)
    """

    name: ClassVar[str] = "vocal_fold"
    E_p: float = param(2.0e3, doc="in-plane Young's modulus", unit="Pa")
    E_z: float = param(40.0e3, doc="Young's modulus along the fibre", unit="Pa")
    nu_p: float = param(0.9, doc="in-plane Poisson's ratio")
    nu_pz: float = param(0.0, doc="Poisson's ratio, fibre contraction under in-plane stress")
    G_pz: float = param(10.0e3, doc="shear modulus in planes containing the fibre", unit="Pa")
    rho: float = param(1070.0, doc="density", unit="kg/m^3", positive=True)
    axis: Vec3 = param((0.0, 0.0, 1.0), doc="fibre direction")


@register_material
@dataclass(frozen=True)
class NeoHookean(Material):
    """Compressible neo-Hookean (finite strain), with the small-strain constants E, nu:
    ``W = mu/2 (I1 - 3) - mu ln J + lambda/2 (ln J)^2``, ``mu = E / (2 (1 + nu))``,
    ``lambda = E nu / ((1 + nu)(1 - 2 nu))``. Its tangent at F = I (``elasticity()``) is the
    isotropic linear material's, so small strains reproduce the linear results.

    >>> m = NeoHookean(E=3e3, nu=0.25)
    >>> m.kinematics, m.hyperelastic().kind
    ('finite', 'neo_hookean')
    """

    name: ClassVar[str] = "neo_hookean"
    kinematics: ClassVar[str] = "finite"
    E: float = param(doc="Young's modulus (small-strain limit)", unit="Pa")
    nu: float = param(doc="Poisson's ratio (small-strain limit)")
    rho: float = param(1070.0, doc="density", unit="kg/m^3", positive=True)

    def __post_init__(self):
        self.elasticity()  # validates E, nu, raising MaterialError
        _check_density(self.rho)
        _warn_locking(self.nu)

    def elasticity(self) -> np.ndarray:
        return _core.fem.elasticity_isotropic(float(self.E), float(self.nu))

    def hyperelastic(self):
        return _core.hyperelastic.neo_hookean_from_young(float(self.E), float(self.nu))


@register_material
@dataclass(frozen=True)
class StVenantKirchhoff(TransverselyIsotropic):
    """St Venant-Kirchhoff (finite strain) with the transversely isotropic constants: the
    linear law ``S = D : E`` applied to the Green-Lagrange strain ``E = (F^T F - I) / 2``,
    ``W = E : D : E / 2``. Exact under large rotations; softens in strong compression (not
    polyconvex), so meant for large rotations with moderate strains."""

    name: ClassVar[str] = "st_venant_kirchhoff"
    kinematics: ClassVar[str] = "finite"

    def hyperelastic(self):
        return _core.hyperelastic.st_venant_kirchhoff(self.elasticity())


@register_material
@dataclass(frozen=True)
class FibreReinforced(Material):
    """Transversely isotropic hyperelastic tissue (finite strain): a compressible neo-Hookean
    matrix (small-strain constants ``E``, ``nu``, as :class:`NeoHookean`) plus one family of
    fibres along the reference ``axis`` (default z, anterior-posterior, as the linear
    ``transversely_isotropic`` and ``vocal_fold`` materials) that resist stretch only:

    ``W = W_NH(F) + k1 / (2 k2) (exp(k2 (I4 - 1)^2) - 1)`` for ``I4 = |F a0|^2 > 1``, the
    fibre term 0 for ``I4 <= 1`` (``a0 = axis / |axis|``, a material direction: it turns with
    the body). The fibre term is Holzapfel, Gasser & Ogden's (2000, J. Elasticity 61:1-48) on
    the full invariant I4 (FEBio's ``fiber-exp-pow`` with beta = 2); the Rust law is
    ``vfrs._core.fibre_reinforced``.

    Small strains: the fibre term has zero stress and zero stiffness at ``F = I`` when
    approached in compression, and adds ``4 k1`` to the axial modulus in tension (uniaxial
    tension along the fibre: ``E + 4 k1``), so the law is bilinear about ``F = I``.
    ``elasticity()`` is the matrix's isotropic D, which is the Rust tangent at ``F = I``
    exactly (the fibre switches on for ``I4 > 1`` only): the linear K made at setup (Rayleigh
    damping ``C = a0 M + a1 K_0``) is the matrix's. To match the linear ``vocal_fold`` tissue's
    fibre modulus in tension take ``k1 = (E_z - E) / 4`` (docs/model.md, "Finite strain").

    >>> m = FibreReinforced(E=2e3, nu=0.45, k1=9.5e3, k2=1.0)
    >>> m.kinematics, m.hyperelastic().kind, m.axis
    ('finite', 'fibre_reinforced', (0.0, 0.0, 1.0))
    """

    name: ClassVar[str] = "fibre_reinforced"
    kinematics: ClassVar[str] = "finite"
    E: float = param(doc="matrix Young's modulus (small-strain limit)", unit="Pa")
    nu: float = param(doc="matrix Poisson's ratio (small-strain limit)")
    k1: float = param(doc="fibre stiffness (adds 4 k1 to the axial modulus in tension)", unit="Pa", nonnegative=True)
    k2: float = param(doc="fibre exponential stiffening coefficient (dimensionless)", positive=True)
    rho: float = param(1070.0, doc="density", unit="kg/m^3", positive=True)
    axis: Vec3 = param((0.0, 0.0, 1.0), doc="fibre direction in the reference configuration (normalised)")

    def __post_init__(self):
        _set_axis(self)
        norm = float(np.linalg.norm(self.axis))
        if not (np.isfinite(norm) and norm > 0):
            raise _core.errors.MaterialError(f"fibre axis = {list(self.axis)} must be a finite nonzero vector "
                                      "(e.g. [0, 0, 1], anterior-posterior)")
        for key in ("k1", "k2"):
            value = float(getattr(self, key))
            if not np.isfinite(value) or value < 0 or (key == "k2" and value == 0):
                need = "finite and >= 0 (Pa; 0 switches the fibres off)" if key == "k1" else "positive and finite"
                raise _core.errors.MaterialError(f"fibre parameter {key} = {value} must be {need}")
        self.elasticity()  # validates E, nu, raising MaterialError
        _check_density(self.rho)
        _warn_locking(self.nu)
        self.hyperelastic()  # the Rust law's own checks

    def elasticity(self) -> np.ndarray:
        return _core.fem.elasticity_isotropic(float(self.E), float(self.nu))

    def hyperelastic(self):
        E, nu = float(self.E), float(self.nu)
        mu, lam = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
        return _core.hyperelastic.fibre_reinforced(mu, lam, float(self.k1), float(self.k2), list(self.axis))


def finite_models() -> list:
    """The names of the registered finite-strain materials, sorted."""
    return sorted(name for name in MATERIALS if MATERIALS[name].kinematics == "finite")


def kinematics_of(material) -> str:
    """``"linear"`` or ``"finite"`` for a material or a ``{region: material}`` dict; a
    MaterialError if the regions of one body mix the two (not supported)."""
    kinds = {m.kinematics for m in (material.values() if isinstance(material, dict) else [material])}
    if len(kinds) > 1:
        raise _core.errors.MaterialError("the regions of one body mix linear and finite-strain materials; give every region "
                                  f"a finite-strain model ({', '.join(finite_models())}) or none")
    return kinds.pop()


def _warn_locking(nu):
    if nu >= NEARLY_INCOMPRESSIBLE:
        import warnings

        from .errors import VfrsWarning

        warnings.warn(
            f"nu = {nu} is close to 0.5: linear tetrahedra lock (they grow too stiff in "
            f"bending and contact) by a factor that grows like 1/(1 - 2 nu) = {1 / (1 - 2 * nu):.0f}; "
            "refine the mesh and compare, or use nu <= 0.45 with a note",
            VfrsWarning,
            stacklevel=4,
        )


def _set_axis(material) -> None:
    """Stores a frozen material's fibre ``axis`` as a tuple of 3 floats (MaterialError otherwise)."""
    object.__setattr__(material, "axis", tuple(float(a) for a in material.axis))
    if len(material.axis) != 3:
        raise _core.errors.MaterialError(f"axis must have 3 components, got {material.axis!r}")


def _check_density(rho):
    if not (np.isfinite(rho) and rho > 0):
        raise _core.errors.MaterialError(f"density rho = {rho} must be positive and finite (kg/m^3)")


def material_from_dict(d: dict) -> Material:
    """Builds a material from ``{"model": name, **parameters}`` (what ``to_dict`` writes)."""
    d = dict(d)
    model = d.pop("model", "isotropic")
    if model not in MATERIALS:
        raise _core.errors.MaterialError(f"unknown material model {model!r}; choose one of {sorted(MATERIALS)}")
    return MATERIALS[model](**d)
