"""The ``[flow]`` effect (:class:`GlottalFlow`): the pressure of a flow model
(:mod:`vfrs.flow.models`) on the folds, coupled to a vocal tract through its port
(:mod:`vfrs.flow.port`), and what it gives the output: the summary's ``phonation`` section, the
cycle signal, its figures (:mod:`vfrs.flow.figures`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..signals import (cycle_amplitudes, cycle_peaks, fundamental_frequency, max_flow_declination_rate, open_quotients,
                      peak, window)
from ..summary import Quantity
from ..errors import VfrsError
from ..effects import Effect, register_effect
from ..params import param, param_keys, params_to_dict, read_params
from .model import FLOW_MODELS
from .slices import GlottalSlices
from .figures import glottal_figures
from .port import AIR_DENSITY, GlottisPort


def phonation_measures(run) -> dict:
    """Glottal measures of a run with ``[flow]`` (``run``: a :class:`vfrs.summary.RunView`;
    empty dict without a glottal area): ``f0`` (Hz, from the glottal area), ``amplitude`` (m,
    half the peak-to-peak medio-lateral displacement of the first probe per glottal cycle,
    mean; Results with probes only), ``open_quotient`` and ``closed_quotient``,
    ``max_glottal_area`` and ``min_glottal_area`` (m^2), ``peak_flow`` (m^3/s), ``mfdr``
    (m^3/s^2, maximum flow declination rate); over the window from ``run.window_start``
    (default: the second half of the run), the extremes over its whole cycles
    (:func:`_extremes`). Means over cycles carry each cycle's value (``per_cycle``; for ``f0``
    each cycle's 1 / length). See :mod:`vfrs.summary` for the conventions."""
    h, probe, hysteresis, open_level = run.history, run.probe, run.hysteresis, run.open_level
    if "glottal_area" not in h:
        return {}
    start = run.window_start
    t, area, q = np.asarray(h["t"]), np.asarray(h["glottal_area"]), np.asarray(h["flow_rate"])
    out: dict[str, Quantity] = {}
    cyc = run.cycles
    f0 = fundamental_frequency(t, area, start, hysteresis=hysteresis)
    out["f0"] = Quantity(f0, "Hz", "fundamental frequency (glottal area)",
                         per_cycle=tuple((1.0 / np.diff(cyc)).tolist()) if len(cyc) >= 2 else None, over="window")
    if probe is not None:
        tp, disp, pos = probe
        amp = cycle_amplitudes(tp, disp[:, 0], start, cycles=cyc)  # per glottal cycle
        out["amplitude"] = Quantity(float(amp.mean()) if amp.size else float("nan"), "m",
                                    "amplitude (medio-lateral, probe 0)", position=tuple(float(c) for c in pos),
                                    per_cycle=tuple(amp.tolist()), over="window")
    out.update(_extremes(t, area, q, start, cyc, open_level))
    return out


def whole_cycles(start, cycles) -> tuple:
    """The part of the window the per-cycle extremes are taken over: from the first to the
    last cycle start (whole cycles) with two or more, else the window (``start``, None)."""
    return (float(cycles[0]), float(cycles[-1])) if len(cycles) >= 2 else (start, None)


def _extremes(t, area, q, start, cycles, open_level: float) -> dict:
    """``open_quotient``, ``closed_quotient``, ``max_glottal_area``, ``min_glottal_area``,
    ``peak_flow`` and ``mfdr`` of :func:`phonation_measures`. The extremes are over the window's
    whole glottal cycles (:func:`whole_cycles`): a value at the window's edge (the last sample,
    a closing cut off mid-way) is no cycle's extreme. Without two cycle starts they are the
    window's, and :meth:`FlowOutputs.notes` says which of them sit at its edge (bounds). The
    open level is min + ``open_level`` of the range of these extremes."""
    a, b = whole_cycles(start, cycles)
    out: dict[str, Quantity] = {}
    tw, aw = window(t, area, a, b)
    if len(aw):
        lo, hi = float(aw.min()), float(aw.max())
        oq = open_quotients(t, area, lo + open_level * (hi - lo), start, cycles=cycles)
        oq_mean = float(oq.mean()) if oq.size else float("nan")
        out["open_quotient"] = Quantity(oq_mean, "1", f"open quotient (area > min + {open_level:g} range)",
                                        per_cycle=tuple(oq.tolist()), over="window")
        out["closed_quotient"] = Quantity(1.0 - oq_mean, "1", "closed quotient (1 - open quotient)",
                                          per_cycle=tuple((1.0 - oq).tolist()), over="window")
        out["max_glottal_area"] = Quantity(hi, "m^2", "maximum glottal area", t=float(tw[int(np.argmax(aw))]),
                                           over="window")
        out["min_glottal_area"] = Quantity(lo, "m^2", "minimum glottal area", t=float(tw[int(np.argmin(aw))]),
                                           over="window")
    q_max, t_q = peak(t, q, a, b)
    out["peak_flow"] = Quantity(q_max, "m^3/s", "peak flow rate", t=t_q, over="window", kind="extreme")
    mfdr, t_m = max_flow_declination_rate(t, q, start, within=(a, math.inf if b is None else b))
    out["mfdr"] = Quantity(mfdr, "m^3/s^2", "maximum flow declination rate", t=t_m, over="window", kind="extreme")
    return out


EDGE_EXTREMES = ("max_glottal_area", "min_glottal_area", "peak_flow", "mfdr")


def edge_note(run, phonation: dict) -> list:
    """Without two glottal cycle starts the extremes are the window's (:func:`_extremes`); one
    at the window's first or last sample was still growing there: a bound, not the signal's
    extreme, and the note says so (one line, or none)."""
    if len(run.cycles) >= 2:
        return []
    tw, _ = window(run.t, run.history["glottal_area"], run.window_start)
    if not len(tw):
        return []
    at_edge = [phonation[k].what for k in EDGE_EXTREMES
               if k in phonation and phonation[k].t is not None and phonation[k].t in (float(tw[0]), float(tw[-1]))]
    if not at_edge:
        return []
    return [f"fewer than two glottal cycles in the window: {', '.join(at_edge)} sit{'s' if len(at_edge) == 1 else ''} "
            "at its first or last sample, still growing there: a bound (lower for a maximum, upper for a minimum), "
            "not an extreme of the oscillation"]


class FlowOutputs:
    """The [flow] effect's output hooks (:class:`vfrs.effects.Effect`): the ``phonation``
    section of the summary, the glottal area as the cycle signal, each glottal cycle's period
    and peak area for the periodicity test, the note on cycles that do not repeat, and the
    names of its section known before a run."""

    cycle_signal: str | None = "glottal_area"

    @classmethod
    def measures(cls, run) -> dict:
        ph = phonation_measures(run)
        return {"phonation": ph} if ph else {}

    @classmethod
    def cycle_values(cls, run) -> dict:
        """``period`` (s) and ``peak_area`` (m^2, the largest glottal area) of each glottal
        cycle of the window."""
        if "glottal_area" not in run.history:
            return {}
        cyc = run.cycles
        return {"period": ("period", np.diff(cyc)),
                "peak_area": ("peak glottal area", cycle_peaks(run.t, run.history["glottal_area"], cyc))}

    @classmethod
    def notes(cls, run, sections) -> list:
        """A window whose glottal cycles do not repeat (the periodicity test,
        :meth:`vfrs.summary.RunView.periodicity`, fails: fewer cycles than it compares, or
        they spread by more than its tolerance); extremes at the window's edge (:func:`edge_note`)."""
        if "phonation" not in sections or "glottal_area" not in run.history:
            return []
        notes = edge_note(run, sections["phonation"])
        lengths = np.diff(run.cycles)
        test = run.periodicity()
        if len(lengths) and test is not None and not test.periodic:
            few = test.tested < test.needed and test.within  # too few to tell, none yet seen to differ
            notes.insert(0, f"the {len(lengths)} glottal cycle{'s' if len(lengths) != 1 else ''} in the window last "
                         f"{lengths.min() * 1e3:.2f}-{lengths.max() * 1e3:.2f} ms: the oscillation "
                         + (f"is not shown to repeat ({test.needed} cycles needed)" if few else "does not repeat")
                         + ", so f0, the per-cycle means and the contact peaks follow this run's trajectory, which "
                         "the mesh changes (the step hardly: docs/convergence.md)")
        return notes

    @classmethod
    def figures(cls, run, figs) -> None:
        glottal_figures(run, figs)

    @classmethod
    def summary_names(cls, scene) -> dict:
        """The names :func:`phonation_measures` gives (``amplitude`` with an ``[output]`` probe)."""
        return {"phonation": ["f0", *(["amplitude"] if scene.output.probes else []), "open_quotient",
                              "closed_quotient", "max_glottal_area", "min_glottal_area", "peak_flow", "mfdr"]}


@dataclass(frozen=True)
class FlowParams:
    """The keys of ``[flow]`` every model shares (a model's own: ``FLOW_MODELS[model].Params``)."""

    subglottal_pressure: float = param(doc="subglottal pressure", unit="Pa", nonnegative=True)
    model: str = param("bernoulli", doc="flow model (vfrs.flow.models)", choices=lambda: FLOW_MODELS.choices())
    separation_ratio: float = param(1.0, doc="separation where A reaches this x A_min (1: at the minimum)",
                                    low=1.0, high=10.0)
    surface: str = param("medial", doc="the wetted surface of both folds")
    ramp: float = param(0.0, doc="the pressure rises smoothly over this time", unit="s", nonnegative=True)
    stations: int = param(120, doc="y stations of the 1-D flow", minimum=8)
    bodies: list | None = param(None, doc="[right, left] (default: the two bodies with the surface, right = larger x)")
    density: float = param(AIR_DENSITY, doc="air density (the flow rate's, and a vocal tract's: [acoustics])",
                           unit="kg/m^3", positive=True)
    extrapolate: bool | None = param(None, doc="true: the pressure at the end of a step from the configuration "
                                     "extrapolated to it, u + h v + h^2 a / 2 (unset or false: from the configuration "
                                     "at the step's start)")

    def __post_init__(self):
        b = self.bodies
        if b is not None and (not isinstance(b, list) or len(b) != 2 or not all(isinstance(x, str) for x in b)):
            raise ValueError(f"bodies: expected two body names [right, left], got {b!r}")


@dataclass(frozen=True)
class FlowSettings:
    """The resolved ``[flow]`` section: the shared keys (``common``) and the chosen model's own
    (``own``); ``settings.key`` reads either."""

    common: FlowParams
    own: object = field(default=None)

    def __getattr__(self, key):  # settings.subglottal_pressure, settings.viscosity, ...
        for part in ("common", "own"):
            obj = object.__getattribute__(self, part)
            if obj is not None and key in getattr(obj, "__dataclass_fields__", {}):
                return getattr(obj, key)
        raise AttributeError(key)


@register_effect
class GlottalFlow(FlowOutputs, Effect):
    """The ``[flow]`` section: the pressure of a glottal flow model (``model``,
    :mod:`vfrs.flow.models`) on the medial surfaces of two folds.

    Keys: :class:`FlowParams` and the model's own. Coupling is explicit: the pressure at the
    end of a step comes from the configuration at its start, or with ``extrapolate`` from the
    configuration extrapolated to the step's end (u + h v + h^2 a / 2). History: ``glottal_area``
    (minimum area, m^2), ``flow_rate`` (m^3/s: the model's flow, or with the air's ``density``
    A_sep sqrt(2 drop / rho)), ``glottis_closed`` (0/1), ``min_gap`` (m: the smallest distance
    between the medial surfaces across the mid-plane; negative when they overlap, i.e. the
    folds have crossed, which without contact enforcement is how collision shows).
    """

    name = "flow"
    Params = FlowParams
    # Checkpoints: a model with memory (the glottal inertance) keeps it in state() / restore().

    @classmethod
    def resolve(cls, table) -> FlowSettings:
        common = read_params(FlowParams, table)
        model = FLOW_MODELS[common.model]
        own = read_params(model.Params, table) if model.Params is not None else None
        for key in table.data:
            if key not in table.read:
                owners = [n for n, c in FLOW_MODELS.items()
                          if n != common.model and c.Params is not None and key in param_keys(c.Params)]
                if owners:
                    mine = param_keys(model.Params) if model.Params is not None else []
                    raise table.error(f"{key!r} is a key of model {', '.join(repr(o) for o in owners)}, not of model = "
                                      f"{common.model!r} (its own keys: {mine or 'none'})", key)
        table.done()
        return FlowSettings(common, own)

    @classmethod
    def check(cls, params, effects: dict, error) -> None:
        super().check(params, effects, error)
        FLOW_MODELS[params.model].check(params.own, params.common, effects, error)

    @classmethod
    def to_dict(cls, params) -> dict:
        out = params_to_dict(params.common)
        if params.own is not None:
            out.update(params_to_dict(params.own))
        return out

    def setup(self, ctx) -> None:
        from ..dynamics.problem import ramp

        problem = ctx.problem
        self._ramp = ramp
        cfg = self.params
        parts = {p.name: p for p in problem.bodies}
        if cfg.bodies is not None:
            missing = [b for b in cfg.bodies if b not in parts]
            if missing:
                raise VfrsError(f"[flow] bodies: no body named {missing[0]!r}; bodies are {sorted(parts)}")
            right, left = (parts[b] for b in cfg.bodies)
        else:
            with_surface = [p for p in problem.bodies if cfg.surface in p.mesh.surfaces]
            if len(with_surface) != 2:
                raise VfrsError(
                    f"[flow] needs exactly two bodies with a {cfg.surface!r} surface, found "
                    f"{[p.name for p in with_surface]}; name them with bodies = [right, left]"
                )
            right, left = sorted(
                with_surface, key=lambda p: -p.mesh.points[np.unique(p.mesh.surface(cfg.surface)), 0].mean()
            )
        self.right, self.left = right, left
        law = FLOW_MODELS[cfg.model](cfg.own, cfg.common)
        self.model = GlottalSlices(_with_medial(right.mesh, cfg.surface), _with_medial(left.mesh, cfg.surface), law,
                                   cfg.subglottal_pressure, n_stations=cfg.stations)
        self.n_dofs = problem.n_dofs
        self.last = None
        # Per step only the wetted nodes' positions are gathered and only their forces
        # computed (the model's numbers at them; the folds' other nodes get no force).
        self._compact, kept = self.model.compacted()
        self._points = problem.points
        self._nodes = [body.node_offset + k for body, k in zip((right, left), kept)]
        self._dofs = [(3 * n[:, None] + np.arange(3)).ravel() for n in self._nodes]
        # A vocal tract ([acoustics], vfrs.acoustics) connects its glottis(t, A_sep, P_lung) to this port
        self.port = GlottisPort(cfg.density, viscosity=getattr(cfg, "viscosity", None))
        ctx.offer(self.port)

    def forces(self, state):
        u = state.u
        if self.params.extrapolate:  # the configuration at t_next, to second order in the step
            h = state.t_next - state.t
            u = u + h * state.v + (0.5 * h * h) * state.a
        u = u.reshape(-1, 3)
        xr, xl = (self._points[n] + u[n] for n in self._nodes)
        t = state.t_next
        scale = self._ramp(t, self.params.ramp)[0]
        glottis = self.port.tract
        lungs = scale * self.model.ps
        # A model whose pressure is proportional to the drive gets the full Ps and its forces
        # are scaled after (the numbers of runs made before the models were a role); another
        # gets the ramped Ps.
        drive = None if self.model.law.homogeneous else lungs
        if glottis is None:
            fr, fl, st = self._compact.forces(xr, xl, drive=drive, t=t)
        else:  # the tract's pressures below the glottis and in the jet, at this load's time (ramped lungs)
            fr, fl, st = self._compact.forces(xr, xl, lambda a_sep, loss: glottis(t, a_sep, lungs, loss), drive, t)
        if st.drop is not None or drive is not None:
            scale = 1.0  # the pressures are the ramped ones
        self.last = st
        f = np.zeros(self.n_dofs)
        f[self._dofs[0]] = scale * fr.ravel()
        f[self._dofs[1]] = scale * fl.ravel()
        self._scale = scale
        return f

    def state(self) -> dict:
        memory = self.model.law.memory()
        return {"law": memory} if memory else {}

    def restore(self, state: dict) -> None:
        if "law" in state:
            self.model.law.recall(state["law"])

    def record(self, state, history) -> None:
        st = self.last
        if st is None:
            history.setdefault("glottal_area", []).append(np.nan)
            history.setdefault("flow_rate", []).append(np.nan)
            history.setdefault("glottis_closed", []).append(0)
            history.setdefault("min_gap", []).append(np.nan)
            return
        a_sep = 0.0 if st.closed else float(np.interp(st.y_separation, st.y, st.area))
        history.setdefault("glottal_area", []).append(st.min_area)
        # the pressure drop across the glottis: the (ramped) lung pressure, or what a coupled tract
        # left (the jet reverses if it is negative)
        drop = self.model.ps * getattr(self, "_scale", 1.0) if st.drop is None else st.drop
        q = st.flow if st.flow is not None else a_sep * math.copysign(math.sqrt(2.0 * abs(drop) / self.port.density), drop)
        history.setdefault("flow_rate", []).append(q)
        history.setdefault("glottis_closed", []).append(int(st.closed))
        history.setdefault("min_gap", []).append(st.min_gap)


def _with_medial(mesh, surface):
    """The flow model reads the ``medial`` surface; alias another name to it."""
    if surface == "medial":
        return mesh
    import copy

    m = copy.copy(mesh)
    m.surfaces = dict(mesh.surfaces, medial=mesh.surface(surface))
    return m
