"""One measured number with its unit, and its text: :class:`Quantity`, the display units
(:data:`DISPLAY`) and the rounding of a value to the digits its spread or error supports."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..signals import json_number

#: What sort of number a :class:`Quantity` is (its ``kind``; the summary prints it as a tag,
#: ``[smooth]`` or ``[extreme]``).
KINDS = ("smooth", "extreme")

#: How each SI unit is shown in text: (factor, unit).
DISPLAY = {
    "s": (1e3, "ms"),
    "m": (1e3, "mm"),
    "m^2": (1e6, "mm^2"),
    "m^3": (1e9, "mm^3"),
    "m^3/s": (1e6, "mL/s"),
    "m^3/s^2": (1e3, "L/s^2"),
    "N": (1e3, "mN"),
    "N s": (1e6, "uN s"),
    "Pa": (1e-3, "kPa"),
    "Hz": (1.0, "Hz"),
    "1": (1.0, ""),
}


@dataclass(frozen=True)
class Quantity:
    """One measured number: ``value`` in SI ``unit`` (``"1"``: dimensionless), ``what`` it is;
    for peaks also when (``t``, s), on which ``body`` and where (``position``, m, reference
    coordinates), and ``per_cycle`` values when it is a mean over cycles (``per``: what one
    of them is over, ``"cycle"`` unless said). ``over``: ``"window"`` (the analysis window)
    or ``"run"`` (the whole run). ``roundoff``: the size (SI) below which the value is
    round-off of the stated ``scale`` (printed ``0 (below round-off)``; the value itself is
    kept). ``error``: its estimated error when one was asked for (:meth:`Summary.with_errors`:
    ``relative``, None when unknown; ``bound``: False when it is only the band of a study's
    runs; ``source``). ``kind``: what sort of number it is, one of :data:`KINDS`: ``"smooth"``
    (a smooth functional of the run: an impulse, a time mean, a band-limited reading; it
    converges as the step and the mesh shrink), ``"extreme"`` (one step's largest value, or the
    larger of two competing events: it can jump between runs), or None (neither said)."""

    value: float
    unit: str
    what: str
    t: float | None = None
    body: str | None = None
    position: tuple | None = None
    per_cycle: tuple | None = None
    over: str | None = None
    roundoff: float | None = None
    scale: str | None = None
    per: str | None = None
    error: dict | None = None
    kind: str | None = None

    def __post_init__(self):
        if self.kind is not None and self.kind not in KINDS:
            raise ValueError(f"Quantity {self.what!r}: kind = {self.kind!r}; give one of {', '.join(KINDS)} or None")

    def __float__(self) -> float:
        return float(self.value)

    @property
    def below_roundoff(self) -> bool:
        """The value is not zero but smaller than its round-off (``roundoff``): zero to the
        run's precision."""
        return self.roundoff is not None and math.isfinite(self.value) and 0 < abs(self.value) < self.roundoff

    def text(self) -> str:
        """The value in display units, with when / where: ``26.2 mN at t = 12.35 ms``; a mean
        over cycles with its spread and as many digits as the spread supports:
        ``0.79 (per cycle 0.66-1.00, sd 0.19, 3 cycles)``; with an error (:meth:`Summary.with_errors`)
        only the digits the error supports: ``2 kPa (+- 120 %)``, ``180 Hz (+- 27 %, band; per
        cycle 160-220, sd 30, 3 cycles)``; a value below its round-off: ``0 (below round-off)``."""
        if self.below_roundoff:
            return "0 (below round-off)"
        factor, unit = DISPLAY.get(self.unit, (1.0, self.unit))
        u = f" {unit}" if unit and math.isfinite(self.value) else ""
        error, at_most = self._error_text(factor, unit)
        if self.per_cycle is not None:
            value, spread = _with_spread(self.value * factor, [c * factor for c in self.per_cycle], self.per or "cycle",
                                         at_most)
        else:
            value, spread = _rounded(self.value * factor, at_most), ""
        said = "; ".join(p for p in (error, spread) if p)
        s = value + u + (f" ({said})" if said else "")
        extra = []
        if self.body is not None:
            extra.append(f"on {self.body}")
        if self.t is not None:
            extra.append(f"at t = {self.t * 1e3:.2f} ms")
        if self.position is not None:
            extra.append("(x, y, z) = (" + ", ".join(f"{c * 1e3:.2f}" for c in self.position) + ") mm")
        return s + (" " + " ".join(extra) if extra else "")

    def _error_text(self, factor: float, unit: str) -> tuple:
        """(the error as text: ``+- 2.1 %``, ``+- 8 %, band`` when not a bound, ``+- unknown``;
        the decimal the value is rounded to, or None). A 0/1 flag says whether the study's runs
        agree, a position gives its error in its own unit (``+- 0.3 mm``): a percentage of
        either means nothing. Empty and None when no error was asked for."""
        if self.error is None:
            return "", None
        rel, band = self.error.get("relative"), ("" if self.error.get("bound", True) else ", band")
        if self.error.get("as") == "flag":
            return ("error unknown" if rel is None else "the same in every run of the study" if rel == 0 else
                    "not the same in every run of the study"), None
        if rel is None or not math.isfinite(rel):
            return "+- unknown", None
        size = abs(rel * self.value * factor)  # the error in display units
        at_most = _first_digit(size)
        if self.error.get("as") == "position":
            return f"+- {_rounded(size, at_most)}{' ' + unit if unit else ''}{band}", at_most
        pct = 100.0 * rel
        return f"+- {pct:.2g} %{band}" if pct < 10 else f"+- {pct:.0f} %{band}", at_most

    def to_dict(self) -> dict:
        d: dict[str, Any] = {"value": json_number(self.value), "unit": self.unit, "what": self.what}
        for k in ("t", "body"):
            v = getattr(self, k)
            if v is not None:
                d[k] = json_number(v) if k == "t" else v
        if self.position is not None:
            d["position"] = [json_number(c) for c in self.position]
        if self.per_cycle is not None:
            d["per_cycle"] = [json_number(c) for c in self.per_cycle]
            if self.per is not None:
                d["per"] = self.per
        if self.over is not None:
            d["over"] = self.over
        if self.roundoff is not None:
            d["roundoff"] = json_number(self.roundoff)
            d["scale"] = self.scale
        if self.error is not None:
            d["error"] = {k: (json_number(v) if isinstance(v, float) else v) for k, v in self.error.items()}
        if self.kind is not None:
            d["kind"] = self.kind
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "Quantity":
        num = lambda v: float("nan") if v is None else float(v)  # noqa: E731
        return cls(num(d["value"]), d["unit"], d["what"], None if d.get("t") is None else float(d["t"]), d.get("body"),
                   None if d.get("position") is None else tuple(num(c) for c in d["position"]),
                   None if d.get("per_cycle") is None else tuple(num(c) for c in d["per_cycle"]),
                   d.get("over"), None if d.get("roundoff") is None else float(d["roundoff"]), d.get("scale"),
                   d.get("per"), d.get("error"), d.get("kind"))


def _first_digit(size: float) -> int | None:
    """The decimal of the first significant digit of an error ``size`` (2 for 0.034, -1 for
    49): the last digit of a value that the error supports. None for 0 or not finite."""
    return -math.floor(math.log10(size)) if size > 0 and math.isfinite(size) else None


def _rounded(v: float, decimals: int | None) -> str:
    """``v`` to ``decimals`` decimals (negative: to tens, hundreds, ...), but never past its
    own first significant digit (``0.9 +- 1.6`` stays 0.9) nor to more than :func:`_fmt`'s 4
    significant digits; None: as :func:`_fmt`."""
    if decimals is None or v is None or not math.isfinite(v) or v == 0:
        return _fmt(v)
    lead = math.floor(math.log10(abs(v)))
    decimals = max(decimals, -lead)
    if lead + decimals + 1 > 4 or abs(v) >= 1e4 or abs(v) < 1e-3:
        return _fmt(v)
    return f"{v:.{decimals}f}" if decimals >= 0 else f"{round(v, decimals):.0f}"


def _fmt(v: float) -> str:
    if v is None or not math.isfinite(v):
        return "n/a"
    if v == 0:
        return "0"
    if abs(v) >= 1e4 or abs(v) < 1e-3:
        return f"{v:.3e}"
    return f"{v:.4g}" if abs(v) < 1000 else f"{v:.0f}"


def _with_spread(mean: float, values, per: str = "cycle", at_most: int | None = None) -> tuple:
    """(the mean as text, its spread as text) in the same units: the mean rounded to the
    decimal of the first significant digit of the values' standard deviation plus one (no
    more than :func:`_fmt`'s 4 significant digits, nor than ``at_most`` decimals: an error's),
    with their range, that deviation (n - 1 in the denominator) and how many there are:
    ``("0.79", "per cycle 0.66-1.00, sd 0.19, 3 cycles")``. One value, or equal values: the
    mean as :func:`_fmt` shows it (rounded to ``at_most``)."""
    v = np.asarray([c for c in values if c is not None and math.isfinite(c)], dtype=float)
    n = len(v)
    if n == 0 or not math.isfinite(mean):
        return _rounded(mean, at_most), ""
    if n == 1:
        return _rounded(mean, at_most), f"1 {per}"
    sd = float(v.std(ddof=1))
    if sd == 0.0:
        return _rounded(mean, at_most), f"{n} {per}s, all equal"
    decimals = 1 - math.floor(math.log10(sd))
    if at_most is not None:  # no more digits than the error supports, but the mean's first
        lead = -math.floor(math.log10(abs(mean))) if mean != 0 else at_most
        decimals = min(decimals, max(at_most, lead))
    if mean != 0 and math.floor(math.log10(abs(mean))) + decimals + 1 > 4:  # more than 4 significant digits
        return _fmt(mean), f"per {per} {_fmt(v.min())}-{_fmt(v.max())}, sd {sd:.2g}, {n} {per}s"

    def r(x: float) -> str:
        return f"{x:.{max(decimals, 0)}f}" if decimals >= 0 else f"{round(x, decimals):.0f}"

    sd_text = r(sd) if float(r(sd)) != 0 else f"{sd:.1g}"  # an error's rounding can swallow it
    return r(mean), f"per {per} {r(v.min())}-{r(v.max())}, sd {sd_text}, {n} {per}s"
