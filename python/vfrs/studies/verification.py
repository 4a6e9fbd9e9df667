"""Solution verification of a refinement study: the arithmetic of issue 32's ``vfrs converge``.

Three solutions of one quantity, ``phi1`` on the finest grid (or step) ``h1``, ``phi2`` on
``h2`` and ``phi3`` on the coarsest ``h3`` (``h1 < h2 < h3``), give, following Celik et al.,
"Procedure for estimation and reporting of uncertainty due to discretization in CFD
applications", J. Fluids Eng. 130, 078001 (2008) (the same five steps as ASME V&V 20-2009,
section 2-4):

- the refinement ratios ``r21 = h2/h1``, ``r32 = h3/h2`` (constant or not) and the
  differences ``e21 = phi2 - phi1``, ``e32 = phi3 - phi2``;
- the observed (apparent) order ``p`` from ``p = |ln|e32/e21| + q(p)| / ln r21`` with
  ``q(p) = ln((r21^p - s) / (r32^p - s))``, ``s = sign(e32/e21)``, solved by fixed-point
  iteration (``q = 0`` for a constant ratio: one step);
- the extrapolated value ``phi_ext21 = (r21^p phi1 - phi2) / (r21^p - 1)``, the approximate
  relative error ``e_a21 = |(phi1 - phi2)/phi1|``, the extrapolated relative error
  ``e_ext21 = |(phi_ext21 - phi1)/phi_ext21|`` and the fine-grid convergence index
  ``GCI21 = Fs e_a21 / (r21^p - 1)`` with ``Fs = 1.25``; the same for the coarser pair.

What kind of sequence it is decides what is reported (:attr:`Verification.kind`), by the
ratio ``R = e21/e32``: ``monotone`` (``0 < R < 1``: the order, the extrapolation and the
GCIs), ``oscillatory`` (``R < 0``) and ``divergent`` (``R >= 1``), for which nothing is
extrapolated and the band of the three values is reported instead, and ``converged``, when
the finest pair differs by no more than round-off (``tol``). Pure numpy, no vfrs import:
docs/converge.md explains the procedure and how to read it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

#: Celik et al.'s (and Roache's) factor of safety for a three-grid study.
FS = 1.25

KINDS = ("monotone", "oscillatory", "divergent", "converged")

_WORDS = {
    "monotone": "monotone convergence: the three runs approach a limit from one side, "
                "so the limit is extrapolated and the GCI bounds the finest run's error",
    "oscillatory": "oscillatory: the value goes up and down as the step or mesh is refined; "
                   "no extrapolation, the band of the three values is the uncertainty",
    "divergent": "divergent: the change grows as the step or mesh is refined, so the runs are "
                 "not in the asymptotic range; no extrapolation and no error estimate, only "
                 "the band of the three values",
    "converged": "converged to round-off: the finest runs agree within the tolerance; "
                 "nothing left to extrapolate",
}


@dataclass(frozen=True)
class Verification:
    """One quantity's three-run study (index 1 the finest, 3 the coarsest).

    ``kind``: one of :data:`KINDS`; ``order`` (p), ``extrapolated`` (phi_ext21),
    ``extrapolated32``, ``e_ext21``, ``gci_fine`` (GCI21, relative, for ``phi1``),
    ``gci_medium`` (GCI32, relative, for ``phi2``), ``gci_coarse`` (Roache's coarse-grid
    form ``Fs |e32/phi3| r32^p / (r32^p - 1)``, for ``phi3``, the base run) and
    ``asymptotic_ratio`` (``GCI32 / (r21^p GCI21)``, near 1 in the asymptotic range) are None
    unless monotone (or, for the GCIs, zero when converged). ``low`` / ``high``: the band the
    limit is taken to lie in (``phi1 +- GCI21 |phi1|`` when monotone, the three values' range
    otherwise, ``phi1`` itself when converged). ``e_a21`` / ``e_a32``: approximate relative
    errors (always)."""

    phi: tuple
    h: tuple
    r21: float
    r32: float
    e21: float
    e32: float
    R: float
    kind: str
    order: float | None
    iterations: int
    extrapolated: float | None
    extrapolated32: float | None
    e_a21: float
    e_a32: float
    e_ext21: float | None
    gci_fine: float | None
    gci_medium: float | None
    gci_coarse: float | None
    asymptotic_ratio: float | None
    low: float
    high: float
    fs: float = FS

    @property
    def value(self) -> float:
        """The finest run's value, the one the error bar is for."""
        return float(self.phi[0])

    @property
    def uncertainty(self) -> float:
        """Half-width (absolute) of the band about the finest run: ``GCI21 |phi1|`` when
        monotone, ``max |phi_i - phi1|`` otherwise (0 when converged)."""
        if self.kind == "monotone" and self.gci_fine is not None:
            return self.gci_fine * abs(self.value)
        return float(max(abs(v - self.value) for v in self.phi))

    @property
    def words(self) -> str:
        """What was found, in a sentence."""
        return _WORDS[self.kind]

    def to_dict(self) -> dict:
        d = asdict(self)
        d["phi"], d["h"] = list(self.phi), list(self.h)
        d.update(value=self.value, uncertainty=self.uncertainty, words=self.words)
        return d

    def describe(self, name: str, unit: str = "", scale: float = 1.0) -> str:
        """One line: ``peak contact force 18.3 mN +- 0.4 (2.2 %) at the finest run; observed
        order 1.9; monotone``. ``scale`` multiplies the values into ``unit`` (1e3 for N to mN)."""
        u = f" {unit}" if unit else ""
        v, du = self.value * scale, self.uncertainty * abs(scale)
        pct = 100.0 * du / abs(v) if v != 0 else math.inf
        if self.kind == "converged":
            return f"{name} {_num(v)}{u} at the finest run; converged to round-off"
        if self.kind == "monotone":
            order = f"{self.order:.2g}" if self.order is not None else "n/a"
            return (f"{name} {_rounded(v, du)}{u} +- {_num(du, 1)} ({percent_text(pct)} %) at the finest run; "
                    f"observed order {order}; monotone")
        values = " / ".join(_num(p * scale) for p in self.phi)
        return (f"{name} {_rounded(v, du)}{u} at the finest run, {values}{u} from the finest to the "
                f"coarsest (band +- {percent_text(pct)} %); {self.kind}, no extrapolation")


def percent_text(v: float) -> str:
    """A percentage to two significant digits below 10 (``0.34``, ``3.6``), whole above (``42``)."""
    return "n/a" if not math.isfinite(v) else f"{v:.2g}" if v < 1 else f"{v:.1f}" if v < 10 else f"{v:.0f}"


def _num(v: float, digits: int = 4) -> str:
    return f"{v:.{digits}g}" if math.isfinite(v) else "n/a"


def _rounded(v: float, dv: float) -> str:
    """``v`` to the decimal of ``dv``'s first significant digit (4 significant digits at most)."""
    if not (math.isfinite(v) and math.isfinite(dv)) or dv <= 0 or v == 0:
        return _num(v)
    decimals = -math.floor(math.log10(dv))
    sig = decimals + math.floor(math.log10(abs(v))) + 1
    if decimals <= 0 or sig > 4:
        return _num(v)
    return f"{v:.{decimals}f}"


def _q(p: float, s: float, l21: float, l32: float) -> float:
    """``ln((r21^p - s)/(r32^p - s))`` written as ``p (ln r21 - ln r32) + ln(1 - s r21^-p) -
    ln(1 - s r32^-p)``: no overflow at large p."""
    with np.errstate(all="ignore"):
        return float(p * (l21 - l32) + np.log1p(-s * np.exp(-p * l21)) - np.log1p(-s * np.exp(-p * l32)))


def observed_order(e21: float, e32: float, r21: float, r32: float, *, rtol: float = 1e-13,
                   max_iter: int = 500) -> tuple:
    """(p, iterations): Celik et al.'s fixed-point iteration
    ``p = |ln|e32/e21| + q(p)| / ln r21``, ``q(p) = ln((r21^p - s)/(r32^p - s))``, started at
    ``q = 0`` (exact in one step for a constant ratio). Where it does not settle in
    ``max_iter`` steps (it need not when ``r32`` is much larger than ``r21``) the same
    equation without the absolute value, ``p ln r21 = ln|e32/e21| + q(p)``, is solved by
    bisection on ``(1e-9, 100)``; ``iterations`` is then negative. NaN when neither finds it."""
    ratio = e32 / e21
    s = 1.0 if ratio > 0 else -1.0
    a, l21, l32 = math.log(abs(ratio)), math.log(r21), math.log(r32)

    def g(p: float) -> float:
        return abs(a + _q(p, s, l21, l32)) / l21

    p = abs(a) / l21
    for i in range(1, max_iter + 1):
        new = g(p)
        if not math.isfinite(new):
            break
        if abs(new - p) <= rtol * max(1.0, abs(new)):
            return new, i
        p = new

    def f(p: float) -> float:
        return p * l21 - a - _q(p, s, l21, l32)

    lo, hi = 1e-9, 100.0
    if not f(lo) < 0 < f(hi):
        return math.nan, -max_iter
    i = 0
    while hi - lo > rtol * max(1.0, hi) and i < 200:
        i += 1
        mid = 0.5 * (lo + hi)
        if f(mid) > 0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi), -i


def verify(phi, h, *, fs: float = FS, rtol: float = 1e-12, atol: float = 0.0) -> Verification:
    """The study of three values ``phi = (phi1, phi2, phi3)`` on ``h = (h1, h2, h3)``, finest
    first (any order of magnitude; only the ratios ``h2/h1``, ``h3/h2`` enter). ``rtol`` /
    ``atol``: a difference no larger than ``atol + rtol max|phi|`` is round-off."""
    phi = tuple(float(v) for v in phi)
    h = tuple(float(v) for v in h)
    if len(phi) != 3 or len(h) != 3:
        raise ValueError("verify needs three values and three grid sizes (finest first)")
    if not all(math.isfinite(v) for v in phi + h):
        raise ValueError(f"verify needs finite values and sizes, got {phi}, {h}")
    if not 0 < h[0] < h[1] < h[2]:
        raise ValueError(f"grid sizes must grow from the finest to the coarsest run, got {h}")
    p1, p2, p3 = phi
    r21, r32 = h[1] / h[0], h[2] / h[1]
    e21, e32 = p2 - p1, p3 - p2
    tol = atol + rtol * max(abs(v) for v in phi)
    e_a21 = abs(e21 / p1) if p1 != 0 else math.inf
    e_a32 = abs(e32 / p2) if p2 != 0 else math.inf
    R = e21 / e32 if e32 != 0 else (0.0 if e21 == 0 else math.copysign(math.inf, e21))
    common: dict = dict(phi=phi, h=h, r21=r21, r32=r32, e21=e21, e32=e32, R=R, e_a21=e_a21, e_a32=e_a32, fs=fs)
    # 0 < R < 1 for a constant ratio; R < ln r21 / ln r32 in general (p > 0 exists, docs/converge.md)
    if abs(e21) <= tol or (abs(e32) <= tol or not 0 < R < math.log(r21) / math.log(r32)):
        kind = "converged" if abs(e21) <= tol else "oscillatory" if R < 0 else "divergent"
        low, high = (p1, p1) if kind == "converged" else (min(phi), max(phi))
        return Verification(kind=kind, order=None, iterations=0, extrapolated=None, extrapolated32=None,
                            e_ext21=None, gci_fine=0.0 if kind == "converged" else None, gci_medium=None,
                            gci_coarse=None, asymptotic_ratio=None, low=low, high=high, **common)
    p, it = observed_order(e21, e32, r21, r32)
    f21, f32 = r21 ** p, r32 ** p
    ext21 = (f21 * p1 - p2) / (f21 - 1)
    ext32 = (f32 * p2 - p3) / (f32 - 1)
    gci21 = fs * e_a21 / (f21 - 1)
    gci32 = fs * e_a32 / (f32 - 1)
    gci_c = fs * abs(e32 / p3) * f32 / (f32 - 1) if p3 != 0 else math.inf
    half = gci21 * abs(p1)
    return Verification(kind="monotone", order=p, iterations=it, extrapolated=ext21, extrapolated32=ext32,
                        e_ext21=abs((ext21 - p1) / ext21) if ext21 != 0 else math.inf,
                        gci_fine=gci21, gci_medium=gci32, gci_coarse=gci_c,
                        asymptotic_ratio=gci32 / (f21 * gci21) if gci21 > 0 else None,
                        low=p1 - half, high=p1 + half, **common)


@dataclass(frozen=True)
class AxisError:
    """One axis's part in the error of one of its study's runs (:func:`axis_error`): ``shift``
    (what the extrapolation moves the run's value by; 0 without one), ``gci`` (relative: the
    run's GCI; None for a band), ``low`` / ``high`` (the band the limit lies in, as offsets
    from the run's value) and ``bound`` (a GCI or round-off, not the range of the runs)."""

    shift: float
    gci: float | None
    low: float
    high: float
    bound: bool


def axis_error(v: Verification, run: int = 0) -> AxisError:
    """The error policy of one axis (the step or the mesh) for its run ``run`` (0 the finest, 2
    the coarsest, as in ``phi``), the one ``vfrs converge`` and the accuracy report's reference
    both apply: converged to round-off, nothing (a bound); monotone, the run's GCI (GCI21 for
    the finest, GCI32 for the middle one, Roache's coarse-grid form for the coarsest) about the
    run, which the extrapolation shifts by ``phi_ext - phi`` (a bound); oscillatory or divergent,
    nothing extrapolated and the range of the three values about the run (a band, not a bound)."""
    phi = v.phi[run]
    if v.kind == "converged":
        return AxisError(0.0, 0.0, 0.0, 0.0, True)
    if v.kind == "monotone" and v.extrapolated is not None:
        gci = (v.gci_fine, v.gci_medium, v.gci_coarse)[run]
        g = math.nan if gci is None else gci * abs(phi)
        return AxisError(v.extrapolated - phi, gci, -g, g, True)
    return AxisError(0.0, None, min(v.phi) - phi, max(v.phi) - phi, False)


@dataclass(frozen=True)
class Cost:
    """What the next refinement buys: ``gain`` (relative, of the value) for ``factor`` times
    the wall time; ``what``: ``"mesh"`` or ``"step"`` (or any noun)."""

    gain: float
    factor: float
    what: str = "mesh"

    def text(self) -> str:
        """``the next mesh buys 1.8 % for 3.4x the time`` (``halving the step`` for a step)."""
        head = "halving the step" if self.what == "step" else f"the next {self.what}"
        pct = 100 * self.gain
        amount = f"{pct:.2g}" if abs(pct) < 10 else f"{pct:.0f}"
        return f"{head} buys {amount} % for {self.factor:.2g}x the time"

    def to_dict(self) -> dict:
        return {**asdict(self), "text": self.text()}


def next_refinement(value: float, next_value: float, time: float, next_time: float,
                    what: str = "mesh", limit: float | None = None) -> Cost:
    """The cost of going from a run (``value`` in ``time`` s of wall time) to the next finer
    one (``next_value`` in ``next_time``). The gain is how much closer to ``limit`` (the
    extrapolated value, when the study has one) the finer run is, relative to it:
    ``(|value - limit| - |next_value - limit|) / |limit|``; without a limit, the change
    ``|next_value - value| / |value|`` (the same when the two approach the limit from one side)."""
    if limit is not None and limit != 0 and math.isfinite(limit):
        gain = (abs(value - limit) - abs(next_value - limit)) / abs(limit)
    else:
        gain = abs(next_value - value) / abs(value) if value != 0 else math.inf
    factor = next_time / time if time > 0 else math.inf
    return Cost(gain=float(gain), factor=float(factor), what=what)
