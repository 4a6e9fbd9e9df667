"""The registry of built-in mesh generators: a typed ``Params`` dataclass per generator.

A generator is a function returning a :class:`~vfrs.mesh.Mesh` (``box``, ``sphere``, ...) and
its ``Params``: a frozen dataclass whose fields are the function's keyword arguments, with
their types, defaults, units and checks (:func:`vfrs.params.param`). The scene reads a
``mesh = { builtin = "<name>", ... }`` table into the Params (:func:`vfrs.params.read_params`:
a wrong type or a bad value is a :class:`~vfrs.errors.SceneError` naming the key, at load),
writes it back with :meth:`GeneratorParams.to_dict`, and builds the mesh with
:meth:`GeneratorParams.build`. A new generator is one new module in ``vfrs/meshes/``::

    def wedge(angle=30.0, cells=4) -> Mesh: ...

    @register_generator(wedge)
    @dataclass(frozen=True)
    class WedgeParams(GeneratorParams):
        name: ClassVar[str] = "wedge"              # the scene's `builtin`
        angle: float = param(30.0, doc="opening angle", unit="degrees", positive=True)
        cells: int = param(4, doc="cells along the edge", minimum=1)

The registry imports every module of this package on first use, so nothing else changes.

>>> from vfrs.meshes import GENERATORS, PARAMS
>>> p = PARAMS["box"](size=(2.0, 1.0, 1.0), cells=(2, 1, 1))
>>> p.to_dict()["cells"], p.build().n_tets, GENERATORS["box"] is PARAMS["box"].generator
([2, 1, 1], 12, True)
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections.abc import Callable, Iterator, Mapping
from typing import Any, ClassVar

import numpy as np

from ..errors import MeshError
from ..mesh import Mesh
from ..params import check_params, params_to_dict
from ..registry import Registry


def libm(f, *args) -> np.ndarray:
    """``f`` (a :mod:`math` function: the C library's, the same on every CPU) elementwise
    over equally shaped ``args``. numpy picks SIMD versions of some functions by CPU
    (AVX-512), whose last bits can differ from the C library's; a mesh made with them, and
    every result on it, would then depend on the machine."""
    shape = np.shape(args[0])
    flat = [np.ravel(a).tolist() for a in args]
    return np.array([f(*v) for v in zip(*flat)], dtype=float).reshape(shape)

#: Outside a contact zone (:func:`zone_nodes`) cells grow to at most this many times the
#: finest, then stay that size: the grading then changes no cell's shape by more than this
#: factor, which bounds what it costs in element quality.
MAX_GROWTH = 4.0


def _side_count(length: float, h0: float, g: float) -> float:
    """Cells over ``length`` from a zone's edge: the integral of 1 / size, the size growing as
    h0 + g d up to MAX_GROWTH h0 at d_cap = (MAX_GROWTH - 1) h0 / g, constant beyond."""
    d_cap = (MAX_GROWTH - 1.0) * h0 / g
    if length <= d_cap:
        return math.log1p(g * length / h0) / g
    return math.log(MAX_GROWTH) / g + (length - d_cap) / (MAX_GROWTH * h0)


def _side_distance(t: float, h0: float, g: float) -> float:
    """The distance from a zone's edge that :func:`_side_count` gives ``t`` cells."""
    t_cap = math.log(MAX_GROWTH) / g
    if t <= t_cap:
        return h0 / g * math.expm1(g * t)
    return (MAX_GROWTH - 1.0) * h0 / g + (t - t_cap) * MAX_GROWTH * h0


def _zone_count(h0: float, length: float, a: float, b: float, g: float) -> float:
    """Cells over [0, length] whose size is ``h0`` on [a, b] and grows outside it."""
    return (b - a) / h0 + _side_count(a, h0, g) + _side_count(length - b, h0, g)


def bisect(above, lo: float, hi: float, steps: int = 200) -> float:
    """Where ``above`` (true at ``lo``, false at ``hi``, once) turns false, to the last bits:
    bisection until the bracket is 1e-15 of ``hi`` wide (or ``steps`` halvings)."""
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        if above(mid):
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-15 * hi:
            break
    return 0.5 * (lo + hi)


def _zone_h0(length: float, a: float, b: float, n: float, g: float) -> float:
    """The finest size ``h0`` for which :func:`_zone_count` is ``n`` (bisection: the count
    falls as h0 grows, and is at most n at h0 = length / n, every cell being >= h0)."""
    return bisect(lambda h: _zone_count(h, length, a, b, g) > n, length / n * 1e-9, length / n)


def zone_nodes(length: float, a: float, b: float, n: int, ratio: float) -> np.ndarray:
    """``n + 1`` positions from 0 to ``length`` (ends exact): equal cells of the finest size
    ``h0`` on the zone ``[a, b]`` (cut to [0, length]) and, outside it, cells growing by
    ``ratio`` from each one to the next away from the zone, up to :data:`MAX_GROWTH` times
    ``h0``. The cell size is h0 + ln(ratio) d at the distance d from the zone (capped); the
    cell count up to x, the integral of 1 / size, is inverted in closed form at whole
    numbers, so neighbouring cells differ by exactly ``ratio`` a few cells away from the zone
    and by less next to it and at the cap. ``h0`` is what makes ``n`` cells fill the length.
    ``ratio`` 1, or a zone covering everything, gives equal cells. Only the C library's log
    and exp (:mod:`math`): the same bits on every CPU.

    >>> x = zone_nodes(10.0, 4.0, 6.0, 10, 1.5)
    >>> [round(float(v), 3) for v in x[4:7]], round(float(x[1] / (x[2] - x[1])), 3)
    ([4.418, 5.0, 5.582], 1.5)
    """
    a, b = max(0.0, min(a, length)), max(0.0, min(b, length))
    if ratio <= 1.0 or (a <= 0.0 and b >= length):
        return np.array([length * k / n for k in range(n + 1)])
    g = math.log(ratio)
    h0 = _zone_h0(length, a, b, n, g)
    n_left, n_zone = _side_count(a, h0, g), (b - a) / h0
    scale = n / _zone_count(h0, length, a, b, g)  # the bisection's last bits: exactly n cells
    x = []
    for k in range(n + 1):
        t = k / scale
        if t <= n_left:
            x.append(a - _side_distance(n_left - t, h0, g))
        elif t <= n_left + n_zone:
            x.append(a + (t - n_left) * h0)
        else:
            x.append(b + _side_distance(t - n_left - n_zone, h0, g))
    out = np.clip(np.array(x), 0.0, length)
    out[0], out[-1] = 0.0, length
    return out


def zone_nodes_through(length: float, centre: float, half_width: float, n: int, ratio: float) -> np.ndarray:
    """:func:`zone_nodes` for the zone ``[centre - half_width, centre + half_width]`` with one
    node exactly at ``centre`` (0 < centre < length, n >= 2): the cells are counted over the
    whole length, split at the centre, and each side graded on its own with its whole number
    of cells."""
    a, b = max(0.0, centre - half_width), min(length, centre + half_width)
    if ratio <= 1.0 or (a <= 0.0 and b >= length):
        below = n * centre / length
    else:
        g = math.log(ratio)
        h0 = _zone_h0(length, a, b, n, g)
        below = _side_count(a, h0, g) + (centre - a) / h0
    n_below = min(max(int(round(below)), 1), n - 1)
    left = zone_nodes(centre, a, centre, n_below, ratio)
    right = zone_nodes(length - centre, 0.0, b - centre, n - n_below, ratio)
    return np.r_[left, centre + right[1:]]


__all__ = ["GeneratorParams", "PARAMS", "GENERATORS", "register_generator", "option_error"]

#: The generators' Params classes by name (the scene's ``builtin``); every module of
#: ``vfrs.meshes`` is imported on first use.
PARAMS = Registry("mesh generator", packages=("vfrs.meshes",))


class GeneratorParams:
    """Base of a generator's Params (subclasses are frozen dataclasses). ``name`` is the
    scene's ``builtin``; ``generator`` the function the fields are the keyword arguments of
    (set by :func:`register_generator`)."""

    name: ClassVar[str] = ""
    generator: ClassVar[Callable[..., Mesh]]

    def arguments(self) -> dict:
        """The keyword arguments of the generator."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}  # type: ignore[arg-type]

    def check(self) -> None:
        """Raises :class:`~vfrs.errors.MeshError` (from :func:`option_error`, naming the key)
        for values the generator would reject beyond each field's own type and range checks.
        The scene calls it when it is read, before anything is built or written."""

    def estimate(self) -> tuple[int, int] | None:
        """(nodes, tetrahedra) of the mesh this builds, without building it (None: unknown)."""
        return None

    def build(self) -> Mesh:
        """The mesh (a :class:`~vfrs.errors.MeshError` for values the generator rejects)."""
        return type(self).generator(**self.arguments())

    def to_dict(self) -> dict:
        """``{"builtin": name, **parameters}`` as TOML data (unset options left out)."""
        return {"builtin": self.name, **params_to_dict(self)}

    @classmethod
    def from_dict(cls, d: Mapping) -> "GeneratorParams":
        """From resolved data (``to_dict``'s output; ``builtin`` ignored): arrays become tuples."""
        kwargs = {k: tuple(v) if isinstance(v, list) else v for k, v in d.items() if k != "builtin"}
        return cls(**kwargs)


def option_error(key: str, message: str) -> MeshError:
    """A :class:`~vfrs.errors.MeshError` about the generator option ``key`` (``error.key``):
    the scene reports it at ``bodies[i].mesh.<key>``."""
    e = MeshError(f"{key}: {message}")
    e.key = key  # type: ignore[attr-defined]
    return e


def register_generator(function: Callable[..., Mesh]):
    """Class decorator for a generator's Params dataclass: registers it under its ``name``,
    bound to ``function``. The fields must be the function's keyword arguments, with the same
    defaults, and of types a scene can read (checked here, so a mismatch fails at import)."""

    def decorate(cls):
        if not (dataclasses.is_dataclass(cls) and issubclass(cls, GeneratorParams)):
            raise TypeError(f"{cls.__name__}: a generator's Params must be a dataclass deriving from GeneratorParams")
        name = cls.__dict__.get("name")
        if not isinstance(name, str) or not name:
            raise TypeError(f"{cls.__name__}: needs its own class attribute `name` (the scene's `builtin`)")
        check_params(cls)
        sig = {k: p.default for k, p in inspect.signature(function).parameters.items()
               if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
        fields = {f.name: f.default for f in dataclasses.fields(cls)}
        if list(fields) != list(sig):
            raise TypeError(f"{cls.__name__}: fields {list(fields)} are not the arguments {list(sig)} of {function.__name__}()")
        for k, default in fields.items():
            if sig[k] is not inspect.Parameter.empty and default != sig[k]:
                raise TypeError(f"{cls.__name__}.{k}: default {default!r} differs from {function.__name__}()'s {sig[k]!r}")
        cls.generator = staticmethod(function)
        return PARAMS.register(cls)

    return decorate


class _Functions(Mapping):
    """``GENERATORS``: the generator functions by name, a view of :data:`PARAMS`."""

    def __getitem__(self, name: str) -> Callable[..., Mesh]:
        return PARAMS[name].generator

    def __iter__(self) -> Iterator[str]:
        return iter(PARAMS)

    def __len__(self) -> int:
        return len(PARAMS)

    def __repr__(self) -> str:
        return f"GENERATORS({sorted(self)})"


#: The generator functions by name: ``GENERATORS["box"] is vfrs.meshes.box``.
GENERATORS: Mapping[str, Callable[..., Any]] = _Functions()
