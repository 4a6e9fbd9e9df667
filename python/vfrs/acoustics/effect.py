"""The ``[acoustics]`` effect: the vocal tract (:mod:`vfrs.acoustics.tract`) driven by the
[flow] effect's glottal flow, its summary section and the sound it writes.

Synchronisation with the structural step: the [flow] effect calls :meth:`Acoustics.glottis`
once per structural step with the time its load is for (t_next), the glottal area at the
separation point and the lung pressure; the tract advances over all its own samples up to
t_next with the area (and lung pressure) interpolated linearly in time between the previous
call and this one, then solves the glottal junction at t_next itself with the waves arriving
there (interpolated between the two samples around it). With ``coupling = "two_way"`` the
pressures below and above the glottis it returns enter the Bernoulli pressure on the folds in
that same step; with ``coupling = "none"`` it returns nothing and the flow is what it is
without the tract (the tract is driven by the flow's own A_g sqrt(2 P_lung / rho)).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from ..signals import window
from ..summary import Quantity
from ..effects import Effect, register_effect
from ..params import param
from ..flow.port import AIR_DENSITY, GlottisPort
from .figures import voice_figures
from .tract import build_tract, piriform_geometry, piriform_on
from .voice import P_REF, PRESSURE_FILE, WAV_FILE, h1_h2, write_voice
from .vowels import VOWELS, geometry


def acoustic_measures(run) -> dict:
    """The ``acoustics`` section of a run with ``[acoustics]`` (empty without a radiated
    pressure): ``spl`` (dB re 20 uPa, the RMS radiated pressure over the window at the
    scene's distance), ``h1_h2`` (dB: the first two harmonics of the radiated pressure over
    the window's whole cycles, Hann window), ``peak_tract_pressure`` (Pa, tract input),
    and ``F1``.. ``F4`` (Hz, with ``B1``.. bandwidths) of the tract's transfer function."""
    h = run.history
    if "radiated_pressure" not in h:
        return {}
    t = np.asarray(h["t"])
    out: dict[str, Quantity] = {}
    tw, pw = window(t, np.asarray(h["radiated_pressure"]), run.window_start)
    if len(pw) > 1:
        rms = float(np.sqrt(np.mean((pw - pw.mean()) ** 2)))
        dist = _distance(run)
        where = f" at {dist * 100:g} cm" if dist is not None else ""
        out["spl"] = Quantity(20.0 * math.log10(rms / P_REF) if rms > 0 else float("-inf"), "dB",
                              f"sound pressure level{where} (re 20 uPa, RMS)", over="window")
        cyc = run.cycles
        if len(cyc) >= 3:
            h1h2 = h1_h2(t, np.asarray(h["radiated_pressure"]), cyc[0], cyc[-1], len(cyc) - 1)
            out["h1_h2"] = Quantity(h1h2, "dB", "H1-H2 of the radiated pressure", over="window")
    _, pt = window(t, np.asarray(h["tract_pressure"]), run.window_start)
    if len(pt):
        out["peak_tract_pressure"] = Quantity(float(pt.max()), "Pa", "peak tract input pressure", over="window")
    params = _params(run)
    if params is not None:
        flow = run.scene.effects.get("flow")
        density = AIR_DENSITY if flow is None else flow.density
        viscosity = None if flow is None else getattr(flow, "viscosity", None)
        for k, (fk, bk) in enumerate(build_tract(params, density=density, viscosity=viscosity).formants(), start=1):
            out[f"F{k}"] = Quantity(fk, "Hz", f"formant {k} (tract transfer function)", over="run")
            if bk is not None:
                out[f"B{k}"] = Quantity(bk, "Hz", f"bandwidth of formant {k} (-3 dB)", over="run")
    return out


def _params(run):
    scene = run.scene
    return None if scene is None else scene.effects.get("acoustics")


def _distance(run):
    p = _params(run)
    return None if p is None else p.distance



class AcousticsOutputs:
    """The [acoustics] effect's output hooks (:class:`vfrs.effects.Effect`)."""

    files = (WAV_FILE, PRESSURE_FILE)

    @classmethod
    def measures(cls, run) -> dict:
        ac = acoustic_measures(run)
        return {"acoustics": ac} if ac else {}

    @classmethod
    def notes(cls, run, sections) -> list:
        if "acoustics" not in sections or _params(run) is None:
            return []
        p = _params(run)
        return [f"acoustics: coupling = {p.coupling!r}, losses = {p.losses!r}; formants of the tract alone (glottis "
                "closed); the radiated pressure is that of a simple source in free field (docs/acoustics.md)"]

    @classmethod
    def figures(cls, run, figs) -> None:
        voice_figures(run, figs)

    @classmethod
    def summary_names(cls, scene) -> dict:
        """The names :func:`acoustic_measures` gives: a formant and its bandwidth for each of the
        tract's (``F1``, ``B1``, ...)."""
        names = ["spl", "h1_h2", "peak_tract_pressure"]
        for k, (_, bandwidth) in enumerate(build_tract(scene.effects["acoustics"]).formants(), start=1):
            names += [f"F{k}", *([f"B{k}"] if bandwidth is not None else [])]
        return {"acoustics": names}


@register_effect
class Acoustics(AcousticsOutputs, Effect):
    """The ``[acoustics]`` section: the vocal tract driven by the [flow] effect's glottal flow.

    History: ``tract_pressure`` (Pa, the tract's input pressure just above the glottis at the
    step's load time), ``tract_subglottal_pressure`` (Pa, below the glottis: the lung pressure, or
    the subglottal tract's), ``glottal_flow`` (m^3/s, the tract's), and
    ``radiated_pressure`` (Pa at ``distance``: the tract's last sample up to the step's time).
    Files: ``voice.wav`` (16-bit, ``wav_rate``, normalised to 0.9 of full scale) and
    ``voice.npz`` (the radiated pressure in Pa at the tract's rate and at ``wav_rate``, the
    WAV's full scale in Pa)."""

    name = "acoustics"
    needs = {"flow": "the tract is driven by the glottal flow"}

    @dataclass(frozen=True)
    class Params:
        vowel: str = param("a", doc="built-in area function (Story, Titze & Hoffman 1996) or 'uniform'",
                           choices=VOWELS)
        areas: list | None = param(None, doc="area function, glottis to lips (m^2), instead of vowel")
        lengths: list | float | None = param(None, doc="section lengths of areas (m): one per area, or one for all")
        area_file: str | None = param(None, doc="CSV of the area function: section length (m), area (m^2) per line")
        section_length: float | None = param(None, doc="the tract's section length (default: the area function's "
                                             "shortest); sets its sampling, c / section_length", unit="m",
                                             positive=True)
        losses: str = param("walls", doc="'walls': yielding walls (wall_model) "
                            "and the boundary-layer attenuation; 'boundary_layer' (visco-thermal at "
                            "loss_frequency) alone; 'uniform' (loss_bandwidth); 'none'",
                            choices=("walls", "boundary_layer", "uniform", "none"))
        wall_model: str = param("sondhi", doc="'sondhi': the wall admittance per unit length proportional to the "
                                "area (wall_resonance, wall_damping, wall_spring_frequency; the form of Story's "
                                "models); 'surface': a mass-resistance-spring per unit area of the tube's surface "
                                "(wall_mass, wall_resistance, wall_stiffness)", choices=("sondhi", "surface"))
        wall_resonance: float = param(250.0, doc="'sondhi' walls: the closed tract's resonance on walls of mass "
                                      "alone", unit="Hz", positive=True)
        wall_damping: float = param(408.0, doc="'sondhi' walls: the wall's resistance over its mass", unit="1/s",
                                    nonnegative=True)
        wall_spring_frequency: float = param(15.0, doc="'sondhi' walls: sqrt(stiffness / mass) / 2 pi of the wall",
                                             unit="Hz", nonnegative=True)
        wall_mass: float = param(15.0, doc="'surface' walls: the wall's mass per unit area", unit="kg/m^2",
                                 positive=True)
        wall_resistance: float = param(1.6e4, doc="'surface' walls: the wall's resistance per unit area",
                                       unit="Pa s/m", nonnegative=True)
        wall_stiffness: float = param(3.0e6, doc="'surface' walls: the wall's stiffness per unit area", unit="Pa/m",
                                      nonnegative=True)
        piriform: bool | None = param(None, doc="the piriform sinuses as a closed side branch (default: on for the "
                                      "built-in vowels, off for 'uniform' and areas of your own)")
        piriform_areas: list = param([0.8e-4, 0.8e-4, 0.7e-4, 0.4e-4], doc="the sinuses' areas, their mouth to "
                                     "their closed end (m^2)")
        piriform_section_length: float = param(0.396825e-2, doc="length of each of piriform_areas' sections",
                                               unit="m", positive=True)
        piriform_position: float = param(6 * 0.396825e-2, doc="distance of the sinuses' mouth from the glottis",
                                         unit="m", positive=True)
        loss_frequency: float = param(500.0, doc="frequency the boundary-layer losses are evaluated at", unit="Hz",
                                      positive=True)
        loss_bandwidth: float = param(50.0, doc="'uniform' losses: the bandwidth each resonance gets", unit="Hz",
                                      nonnegative=True)
        radiation: bool = param(True, doc="the lips radiate (piston in a baffle); false: p = 0 at the lips")
        distance: float = param(0.3, doc="distance of the radiated pressure from the lips", unit="m", positive=True)
        coupling: str = param("two_way", doc="'two_way': the tract's pressures enter the glottal pressure drop; "
                              "'interactive': and the jet recovers pressure where it meets the tract "
                              "(Ishizaka-Flanagan); 'none': the flow as without a tract",
                              choices=("two_way", "interactive", "none"))
        subglottal_length: float | None = param(None, doc="length of a uniform subglottal tract (none if unset)",
                                                unit="m", positive=True)
        subglottal_area: float = param(2.5e-4, doc="area of the subglottal tract", unit="m^2", positive=True)
        sound_speed: float = param(350.0, doc="speed of sound", unit="m/s", positive=True)
        density: float | None = param(None, doc="the air's density is [flow] density (the glottal jet's and the "
                                      "tract's); a value here must equal it (scenes written before it moved there)",
                                      unit="kg/m^3", positive=True)
        wav_rate: int = param(44100, doc="sample rate of voice.wav (44100 or 48000)", unit="Hz")

        def __post_init__(self):
            if self.wav_rate not in (44100, 48000):
                raise ValueError(f"wav_rate: expected 44100 or 48000 (Hz), got {self.wav_rate!r}")
            if (self.areas is None) != (self.lengths is None):
                raise ValueError("areas and lengths: give both (areas in m^2, lengths in m)")
            if self.areas is not None and self.area_file is not None:
                raise ValueError("area_file: give either areas (with lengths) or area_file, not both")
            a, dx = geometry(self)  # the area function, its sections and their sampling
            pa = np.asarray(self.piriform_areas, dtype=float)
            if pa.ndim != 1 or len(pa) == 0 or not (np.isfinite(pa).all() and (pa > 0).all()):
                raise ValueError(f"piriform_areas: expected a list of areas > 0 m^2, got {self.piriform_areas!r}")
            if piriform_on(self):
                piriform_geometry(self, dx, len(a))
            if self.subglottal_length is not None and round(self.subglottal_length / dx) < 1:
                raise ValueError(f"subglottal_length: {self.subglottal_length:g} m is shorter than one section")

    @classmethod
    def check(cls, params, effects: dict, error) -> None:
        """[flow] is there (:attr:`needs`), and a ``density`` here is [flow]'s: the air's density
        is one, the glottal jet's and the tract's."""
        super().check(params, effects, error)
        flow = effects["flow"].density
        if params.density is not None and params.density != flow:
            raise error(f"density = {params.density:g} kg/m^3 differs from [flow] density = {flow:g} kg/m^3: the air's "
                        "density is one, the glottal jet's and the tract's; set it as [flow] density", "acoustics.density")

    # Checkpoints: the lattice's waves, the ends' memory and the samples so far (state/restore).

    def setup(self, ctx) -> None:
        port = ctx.port(GlottisPort, "[acoustics]")  # the [flow] effect's: the tract is driven by the glottal flow
        self.tract = build_tract(self.params, density=port.density, viscosity=port.viscosity)
        port.connect(self.glottis)
        self.now: tuple | None = None  # (U, p_sub, p_sup) at the last call's time

    def glottis(self, t: float, area: float, p_lung: float, loss=None):
        """The tract at the [flow] effect's load time ``t`` with the glottal ``area`` (m^2, at
        separation; 0 closed), the lung pressure ``p_lung`` (Pa) and the flow model's ``loss``
        (:class:`vfrs.flow.model.GlottalLoss`, None: Bernoulli's): (p_sub, p_jet) (Pa), the
        pressures below the glottis and in its jet (the tract's input pressure, less the
        recovery with ``coupling = "interactive"``), for the flow's pressure drop; or None with
        ``coupling = "none"``."""
        u, p_sub, p_sup = self.tract.advance(t, area, p_lung, loss)
        self.now = (u, p_sub, p_sup)
        return (p_sub, self.tract.jet_pressure(area, u, p_sup)) if self.tract.coupled else None

    def record(self, state, history) -> None:
        now = self.now
        o = self.tract.out
        u, p_sub, p_sup = now if now is not None else (np.nan, np.nan, np.nan)
        history.setdefault("tract_pressure", []).append(p_sup)
        history.setdefault("tract_subglottal_pressure", []).append(p_sub)
        history.setdefault("glottal_flow", []).append(u)
        history.setdefault("radiated_pressure", []).append(o["p_rad"][-1] if o["p_rad"] else np.nan)

    def finish(self, result) -> None:
        out = getattr(result, "out", None)
        if out is None:
            return
        t_end = float(result.t[-1]) if len(result.t) else 0.0
        write_voice(os.fspath(out), np.asarray(self.tract.out["p_rad"]), self.tract.T, t_end, self.params.wav_rate,
                    self.params.distance)

    def state(self) -> dict:
        return {"tract": self.tract.state(), "now": self.now}

    def restore(self, state: dict) -> None:
        self.tract.restore(state["tract"])
        self.now = state["now"]

