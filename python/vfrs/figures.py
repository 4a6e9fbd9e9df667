"""What a run's figures are drawn with (:mod:`vfrs.plot` and the effects' ``figures`` hooks,
:meth:`vfrs.effects.Effect.figures`): :class:`Figures`, which a figure is saved into or skipped
with and which carries the run's title and time axis; titles folded to a figure's width
(:func:`wrapped`); one legend outside the axes (:func:`figure_legend`); the line styles of
curves drawn over each other (:data:`STYLES`); matplotlib with the Agg backend
(:func:`require_matplotlib`)."""

from __future__ import annotations

import os

import numpy as np

from .errors import VfrsError


def require_matplotlib():
    """Imports matplotlib with the Agg backend, or raises VfrsError saying how to install it."""
    try:
        import matplotlib
    except ImportError:
        raise VfrsError("plotting needs matplotlib, which is not installed: pip install matplotlib "
                        "(it is a dependency of vfrs; an install with --no-deps leaves it out)") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


#: Line styles of the bodies' curves, in turn: a second curve on top of the first stays visible.
STYLES = ({"ls": "-", "lw": 2.2}, {"ls": (0, (5, 3)), "lw": 1.3}, {"ls": ":", "lw": 1.3}, {"ls": "-.", "lw": 1.0})

#: Width of a character of a title, in em (DejaVu Sans averages about 0.45 em over text with
#: digits; 0.5 leaves a margin): what :func:`wrapped` folds a figure's title lines to.
CHAR_WIDTH_EM = 0.5


def wrapped(text: str, width_inches: float, fontsize: float = 9.0) -> str:
    """``text`` with each of its lines folded to fit ``width_inches`` at ``fontsize`` points,
    at its "; " where it can, else at spaces (a summary's line with per-cycle values is longer
    than a figure is wide, and a title that does not fit is clipped by the canvas)."""
    import textwrap

    chars = max(20, int(width_inches * 72.0 / (CHAR_WIDTH_EM * fontsize)))
    out: list = []
    for line in text.split("\n"):
        current = ""
        for part in line.split("; "):
            joined = f"{current}; {part}" if current else part
            if len(joined) <= chars or not current:
                current = joined
            else:
                out.append(current + ";")
                current = part
        out.extend(textwrap.wrap(current, chars, break_on_hyphens=False) or [""])
    return "\n".join(out)


def figure_legend(fig, axes, where: str = "right", **kw):
    """One legend for the figure, outside the axes (``where``: "right" or "bottom"; the figure's
    constrained layout makes room for it), from the labelled artists of ``axes`` without
    repeats: a legend inside the axes covers the curves of a long series."""
    handles, labels = [], []
    for ax in axes:
        for h, label in zip(*ax.get_legend_handles_labels()):
            if label not in labels:
                handles.append(h)
                labels.append(label)
    loc = "outside right upper" if where == "right" else "outside lower center"
    return fig.legend(handles, labels, loc=loc, fontsize=8, **kw)



class Figures:
    """What one ``vfrs plot`` draws with, wrote and skipped: ``plt`` (matplotlib.pyplot, Agg),
    ``dest`` (the folder), and of the run: its ``title``, its times ``t`` (s) and the time axis
    ``x`` with its ``time_label`` (ms, or the load factor of a static run, ``static``) and
    ``time_scale`` (x = t * time_scale). :meth:`save` writes a figure, :meth:`skip` says why one
    was not drawn."""

    def __init__(self, plt, dest, title: str = "", t=None, static: bool = False):
        self.plt, self.dest = plt, dest
        self.written: list = []
        self.skipped: list = []
        self.title, self.static = title, static
        self.t = np.zeros(0) if t is None else np.asarray(t)
        self.time_scale = 1.0 if static else 1e3
        self.x = self.t * self.time_scale if not static else self.t
        self.time_label = "load factor" if static else "t (ms)"

    def save(self, fig, name) -> None:
        path = os.path.join(self.dest, name)
        fig.savefig(path, dpi=120)
        self.plt.close(fig)
        self.written.append(path)

    def skip(self, what: str, why: str) -> None:
        self.skipped.append((what, why))
