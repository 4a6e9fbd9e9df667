"""Linear elastic tissue models, in a registry keyed by ``name`` (the scene's ``model``)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from . import _core


#: Poisson's ratio above which isotropic P1 elements warn about volumetric locking.
NEARLY_INCOMPRESSIBLE = 0.49


@dataclass(frozen=True)
class Isotropic:
    """Isotropic linear elasticity.

    >>> import vfrs
    >>> D = vfrs.Isotropic(E=10e3, nu=0.45, rho=1070).elasticity()
    >>> round(float(D[3, 3]), 3)  # shear modulus E / (2 (1 + nu))
    3448.276
    """

    E: float
    nu: float
    rho: float = 1070.0
    name = "isotropic"

    def __post_init__(self):
        self.elasticity()  # validates, raising MaterialError
        _check_density(self.rho)
        if self.nu >= NEARLY_INCOMPRESSIBLE:
            import warnings

            from .errors import VfrsWarning

            warnings.warn(
                f"nu = {self.nu} is close to 0.5: linear tetrahedra lock (they grow too stiff in "
                f"bending and contact) by a factor that grows like 1/(1 - 2 nu) = {1 / (1 - 2 * self.nu):.0f}; "
                "refine the mesh and compare, or use nu <= 0.45 with a note",
                VfrsWarning,
                stacklevel=3,
            )

    def elasticity(self) -> np.ndarray:
        """6x6 matrix D, Voigt order xx, yy, zz, yz, xz, xy (engineering shear)."""
        return _core.elasticity_isotropic(float(self.E), float(self.nu))

    def to_dict(self) -> dict:
        return {"model": self.name, **asdict(self)}


@dataclass(frozen=True)
class TransverselyIsotropic:
    """Transversely isotropic elasticity about a fibre ``axis`` (default z, anterior-posterior).

    ``E_p``, ``nu_p``: modulus and Poisson's ratio in the plane of isotropy; ``E_z``: along the
    fibre; ``nu_pz``: contraction along the fibre under in-plane stress (``nu_zp = nu_pz E_z/E_p``);
    ``G_pz``: shear modulus in planes containing the fibre. Positive definiteness needs
    ``1 - nu_p - 2 nu_pz**2 E_z / E_p > 0``.
    """

    E_p: float
    E_z: float
    nu_p: float
    nu_pz: float
    G_pz: float
    rho: float = 1070.0
    axis: tuple = field(default=(0.0, 0.0, 1.0))
    name = "transversely_isotropic"

    def __post_init__(self):
        object.__setattr__(self, "axis", tuple(float(a) for a in self.axis))
        if len(self.axis) != 3:
            raise _core.MaterialError(f"axis must have 3 components, got {self.axis!r}")
        self.elasticity()
        _check_density(self.rho)

    def elasticity(self) -> np.ndarray:
        return _core.elasticity_transversely_isotropic(
            float(self.E_p), float(self.E_z), float(self.nu_p), float(self.nu_pz), float(self.G_pz), list(self.axis)
        )

    def to_dict(self) -> dict:
        d = asdict(self)
        d["axis"] = list(self.axis)
        return {"model": self.name, **d}


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
      the values of DESIGN.md's scene sketch, in the range reported for the cover
      (Zhang 2016: tens of kPa along the fibres at rest).
    - ``rho = 1070 kg/m^3``: Alipour et al. (2000) (soft tissue 1040-1070 kg/m^3).

    >>> VocalFold().E_p, VocalFold(G_pz=40e3).G_pz
    (2000.0, 40000.0)
    """

    E_p: float = 2.0e3
    E_z: float = 40.0e3
    nu_p: float = 0.9
    nu_pz: float = 0.0
    G_pz: float = 10.0e3
    rho: float = 1070.0
    axis: tuple = field(default=(0.0, 0.0, 1.0))
    name = "vocal_fold"


def _check_density(rho):
    if not (np.isfinite(rho) and rho > 0):
        raise _core.MaterialError(f"density rho = {rho} must be positive and finite (kg/m^3)")


MATERIALS = {cls.name: cls for cls in (Isotropic, TransverselyIsotropic, VocalFold)}


def material_from_dict(d: dict):
    """Builds a material from ``{"model": name, **parameters}``."""
    d = dict(d)
    model = d.pop("model", "isotropic")
    if model not in MATERIALS:
        raise _core.MaterialError(f"unknown material model {model!r}; choose one of {sorted(MATERIALS)}")
    return MATERIALS[model](**d)
