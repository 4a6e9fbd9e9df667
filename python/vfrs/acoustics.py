"""The vocal tract: a wave-reflection analog driven by the glottal flow, the ``[acoustics]`` effect.

The supraglottal tract (and, optionally, a subglottal one) is a chain of N cylindrical sections
of equal length dx; plane pressure waves cross one section per sample, so the tract is sampled
at ``fs = c / dx`` (Kelly-Lochbaum lattice). At a junction of areas A_k, A_k+1 the waves scatter
with r = (A_k - A_k+1) / (A_k + A_k+1) (pressure and volume velocity continuous); each pass
through a section multiplies a wave by a frequency-independent attenuation exp(-sigma_k dx)
(``losses``), and yielding walls take volume velocity at the junctions (``wall_model``); a
closed side branch, the piriform sinuses, joins one junction as a third port (``piriform``).
At the lips a piston in a baffle (R and L in parallel, trapezoidal in time)
radiates; at the glottis the flow U through the glottal area A_g obeys

    rho U |U| / (2 A_g^2) = p_sub - p_sup,   p_sup = 2 b + Z_1 U,   p_sub = P_lung (or 2 f_s - Z_s U)

(b: the backward wave arriving from the tract, Z_1 = rho c / A_1; with a subglottal tract f_s
is its wave arriving from below), solved in closed form each sample. The radiated pressure at
``distance`` r is that of a simple source, p = rho / (4 pi r) dU_lips/dt.

Synchronisation with the structural step: the [flow] effect calls :meth:`Acoustics.glottis`
once per structural step with the time its load is for (t_next), the glottal area at the
separation point and the lung pressure; the tract advances over all its own samples up to
t_next with the area (and lung pressure) interpolated linearly in time between the previous
call and this one, then solves the glottal junction at t_next itself with the waves arriving
there (interpolated between the two samples around it). With ``coupling = "two_way"`` the
pressures below and above the glottis it returns enter the Bernoulli pressure on the folds in
that same step; with ``coupling = "none"`` it returns nothing and the flow is what it is
without the tract (the tract is driven by the flow's own A_g sqrt(2 P_lung / rho)).

See docs/acoustics.md for the model, its limits and what was measured.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from .analysis import Quantity, _window
from .effects import Effect, register_effect
from .errors import VfrsError
from .params import param

#: Built-in area functions (glottis to lips), cm^2 here, and their section length (m): the male
#: speaker's /i/, /ae/, /a/, /u/ of Story, Titze & Hoffman (1996), JASA 100:537-554, Table III
#: (p. 546), equal sections of 0.396825 cm from the glottis (= 350 m/s / (2 x 44.1 kHz)), 42, 42,
#: 44 and 46 of them (the published tract lengths 16.67, 16.67, 17.46, 18.25 cm). Second-hand:
#: the paper was not read here; the values are those of the MATLAB file
#: getMaleVocalTract_Story1996.m (G. Alzamendi 2020), checked equal, section by section, to a
#: transcription of Table III (ctoth/Qlatt, papers/Story_1996_VocalTractAreaFunctionsMRI/notes.md,
#: which stops at section 44: /u/'s last two, 0.41 and 0.86, are the MATLAB file's and a second
#: copy's); the section length is the one the transcription and a parser of the paper's text
#: (lenzo-ka/ipakit, scripts/areafunctions.py) give for Table III's caption, not the MATLAB file's
#: 0.3977 cm. docs/acoustics.md compares their formants with the paper's Table IV.
STORY_1996 = {
    "a": [0.45, 0.20, 0.26, 0.21, 0.32, 0.30, 0.33, 1.05, 1.12, 0.85, 0.63, 0.39, 0.26, 0.28, 0.23,
          0.32, 0.29, 0.28, 0.40, 0.66, 1.20, 1.05, 1.62, 2.09, 2.56, 2.78, 2.86, 3.02, 3.75, 4.60,
          5.09, 6.02, 6.55, 6.29, 6.27, 5.94, 5.28, 4.70, 3.87, 4.13, 4.25, 4.27, 4.69, 5.03],
    "i": [0.33, 0.30, 0.36, 0.34, 0.68, 0.50, 2.43, 3.15, 2.66, 2.49, 3.39, 3.80, 3.78, 4.35, 4.50,
          4.43, 4.68, 4.52, 4.15, 4.09, 3.51, 2.95, 2.03, 1.66, 1.38, 1.05, 0.60, 0.35, 0.32, 0.12,
          0.10, 0.16, 0.25, 0.24, 0.38, 0.28, 0.36, 0.65, 1.58, 2.05, 2.01, 1.58],
    "u": [0.40, 0.38, 0.28, 0.43, 0.55, 1.72, 2.91, 2.88, 2.37, 2.10, 3.63, 5.86, 5.63, 5.43, 4.80,
          4.56, 4.29, 3.63, 3.37, 3.16, 3.31, 3.22, 2.33, 2.07, 2.07, 1.52, 0.74, 0.23, 0.15, 0.22,
          0.22, 0.37, 0.60, 0.76, 0.86, 1.82, 2.35, 2.55, 3.73, 5.47, 4.46, 2.39, 1.10, 0.77, 0.41,
          0.86],
    "ae": [0.22, 0.26, 0.26, 0.16, 0.13, 0.21, 0.83, 1.50, 1.35, 0.99, 0.69, 1.35, 2.32, 2.13, 1.94,
           2.17, 2.85, 3.26, 3.73, 3.80, 3.69, 3.87, 3.68, 3.20, 3.26, 3.29, 3.19, 3.23, 3.23, 3.40,
           3.78, 3.84, 3.98, 4.41, 4.56, 4.79, 4.39, 4.42, 4.23, 4.56, 4.31, 3.94],
}
STORY_1996_SECTION = 0.396825e-2  # m, Table III's caption (second-hand, above)
#: The ``uniform`` tract: 17.5 cm of 3 cm^2 in 44 sections.
UNIFORM = (0.175, 3e-4, 44)
VOWELS = tuple(sorted(STORY_1996)) + ("uniform",)

# Air (the boundary-layer losses): kinematic viscosity, ratio of specific heats, Prandtl number.
NU_AIR, GAMMA_AIR, PRANDTL_AIR = 1.5e-5, 1.4, 0.71
P_REF = 20e-6  # Pa, the reference of the sound pressure level
FORMANT_CEILING = 5000.0  # Hz: the formants reported are below this
#: Hz: peaks of the transfer function below this are not formants (with yielding walls the
#: tract's air and the walls' stiffness make a broad peak near 40 Hz)
FORMANT_FLOOR = 100.0


def area_function(params) -> tuple:
    """(section lengths (m), areas (m^2)) glottis to lips of the ``[acoustics]`` ``params``:
    ``areas`` (with ``lengths``), ``area_file`` (relative to the working directory), or the
    built-in ``vowel``. Raises ValueError naming the key of a bad one."""
    if params.area_file is not None:
        try:
            data = np.loadtxt(params.area_file, delimiter=",", ndmin=2, comments="#")
        except (OSError, ValueError) as e:
            raise ValueError(f"area_file: cannot read {params.area_file!r} ({e})") from None
        if data.shape[1] != 2:
            raise ValueError(f"area_file: expected two columns (section length m, area m^2), got {data.shape[1]}")
        lengths, areas = data[:, 0], data[:, 1]
        _check_areas(lengths, areas, "area_file")
        return lengths, areas
    if params.areas is not None:
        areas = np.asarray(params.areas, dtype=float)
        if areas.ndim != 1:
            raise ValueError(f"areas: expected a list of numbers, got {params.areas!r}")
        lengths = np.asarray(params.lengths, dtype=float)
        if lengths.ndim > 1 or (lengths.ndim == 1 and len(lengths) != len(areas)):
            raise ValueError(f"lengths: expected one length or one per area ({len(areas)}), got {params.lengths!r}")
        lengths = np.broadcast_to(lengths, areas.shape).copy()
        _check_areas(lengths, areas, "areas")
        return lengths, areas
    if params.vowel == "uniform":
        length, area, n = UNIFORM
        return np.full(n, length / n), np.full(n, area)
    areas = 1e-4 * np.asarray(STORY_1996[params.vowel])
    return np.full(len(areas), STORY_1996_SECTION), areas


def geometry(params) -> tuple:
    """(areas on the tract's equal sections (m^2), the section length (m)) of the
    ``[acoustics]`` ``params``; ValueError naming the key when the tract is shorter than one
    section or its sampling (c / section length) cannot represent it up to
    :data:`FORMANT_CEILING`."""
    lengths, areas = area_function(params)
    total = float(np.sum(lengths))
    dx_wanted = params.section_length if params.section_length is not None else float(np.min(lengths))
    n = int(round(total / dx_wanted))
    if n < 1:
        raise ValueError(f"section_length: the tract ({total:g} m) is shorter than one section ({dx_wanted:g} m)")
    dx = total / n
    fs = params.sound_speed / dx
    if fs < 2.0 * FORMANT_CEILING:
        raise ValueError(f"section_length: sections of {dx * 1e3:.3g} mm sample the tract at {fs:.0f} Hz, which "
                         f"cannot represent it up to {FORMANT_CEILING:g} Hz (sections <= "
                         f"{params.sound_speed / (2 * FORMANT_CEILING) * 1e3:.3g} mm needed)")
    same = len(lengths) == n and np.allclose(lengths, dx, rtol=1e-12, atol=0.0)
    return (np.asarray(areas, dtype=float) if same else resample(lengths, areas, n)), dx


def _check_areas(lengths, areas, key) -> None:
    if len(areas) == 0:
        raise ValueError(f"{key}: no sections")
    if not (np.isfinite(areas).all() and (areas > 0).all()):
        raise ValueError(f"{key}: every area must be > 0 m^2, got {areas.min():g}")
    if not (np.isfinite(lengths).all() and (lengths > 0).all()):
        raise ValueError(f"{key}: every section length must be > 0 m, got {lengths.min():g}")


def resample(lengths, areas, n: int) -> np.ndarray:
    """The area function (piecewise constant over sections of ``lengths``) on ``n`` equal
    sections: each new section's area is the length-weighted mean over it."""
    edges = np.concatenate([[0.0], np.cumsum(lengths)])
    x = np.linspace(0.0, edges[-1], n + 1)
    cum = np.concatenate([[0.0], np.cumsum(np.asarray(lengths) * np.asarray(areas))])  # integral of A dx
    integral = np.interp(x, edges, cum)
    return np.diff(integral) / np.diff(x)


class Tract:
    """The tube(s), their lattice state and the glottal and lip ends: see the module's text.

    ``areas`` (m^2, glottis to lips) on sections of length ``dx``; ``sigma`` (1/m, per
    section) the amplitude attenuation per unit length; ``sub_areas`` the subglottal tract
    (lungs to glottis, same dx) or None; ``radiation``: the lips radiate (else p = 0 there)."""

    def __init__(self, areas, dx, c=350.0, rho=1.2, sigma=0.0, radiation=True, distance=0.3,
                 sub_areas=None, sub_sigma=0.0, coupled=True, walls=None, branch=None):
        self.A = np.asarray(areas, dtype=float)
        self.N = len(self.A)
        self.dx, self.c, self.rho = float(dx), float(c), float(rho)
        self.T = self.dx / self.c
        self.Z = rho * c / self.A
        self.r = (self.A[:-1] - self.A[1:]) / (self.A[:-1] + self.A[1:])
        self.walls = None if walls is None else _Walls.of(walls, self.A, self.dx, self.T, rho, c)
        self.branch = None if branch is None else _Branch(*branch, self.N, self.dx, rho, c)
        # the junctions' admittances and the denominator of their pressure, fixed for the run
        self.Y = 1.0 / self.Z
        self.den = _junction_denominator(self.Y, self.walls, self.branch)
        self.att = np.exp(-np.broadcast_to(np.asarray(sigma, dtype=float), self.A.shape) * self.dx)
        self.fw, self.bw = np.zeros(self.N), np.zeros(self.N)  # waves arriving at each section's right / left end
        self.radiation, self.distance, self.coupled = radiation, float(distance), coupled
        a_lips = self.A[-1]
        self.R = 128.0 * rho * c / (9.0 * math.pi ** 2 * a_lips)  # piston in a baffle: R and L in parallel
        self.L = 8.0 * rho / (3.0 * math.pi * math.sqrt(math.pi * a_lips))
        self.sub = None
        if sub_areas is not None:
            sa = np.asarray(sub_areas, dtype=float)
            self.sub = {"A": sa, "Z": rho * c / sa, "r": (sa[:-1] - sa[1:]) / (sa[:-1] + sa[1:]),
                        "att": np.exp(-np.broadcast_to(np.asarray(sub_sigma, dtype=float), sa.shape) * self.dx),
                        "fw": np.zeros(len(sa)), "bw": np.zeros(len(sa))}
        # the ends' memory: the lip inductance's flow and pressure, the lip flow
        self.i_L = self.p_L = self.u_lips = 0.0
        self.j = 0  # the next sample (at t = j T)
        self.last: tuple | None = None  # (t, glottal area, lung pressure) of the last call
        self.before: tuple | None = None  # (t, glottal area) of the call before
        self.arrived = (0.0, 0.0)  # (b at the glottis from above, f from below) at sample j - 1
        self.out: dict = {"p_rad": [], "u_lips": [], "u_glottis": [], "p_sup": [], "p_sub": []}

    # -- one sample ------------------------------------------------------------------------------

    def flow(self, drive: float, z: float, area: float) -> float:
        """U solving rho U|U| / (2 A^2) + z U = drive (m^3/s); 0 through a closed glottis."""
        za = z * area
        den = za + math.sqrt(za * za + 2.0 * self.rho * abs(drive))
        return 2.0 * drive * area / den if den > 0.0 else 0.0

    def glottal_junction(self, area, p_lung, b, f_sub):
        """(U, p_sub, p_sup) at the glottis for the arriving waves ``b`` (from the tract) and
        ``f_sub`` (from the subglottal tract)."""
        z1 = self.Z[0]
        if self.walls is not None:  # the wall at the glottal end takes g p + h: p_sup = 2 b' + z1' U
            g0, h0 = self.walls.g[0], self.walls.h[0]
            b, z1 = (b - 0.5 * z1 * h0) / (1.0 + z1 * g0), z1 / (1.0 + z1 * g0)
        if self.sub is None:
            p_below, z = p_lung, z1
        else:
            p_below, z = 2.0 * f_sub, z1 + self.sub["Z"][-1]
        if self.coupled:
            u = self.flow(p_below - 2.0 * b, z, area)
        else:  # the flow's own: the pressure drop is the lung pressure
            u = math.copysign(area * math.sqrt(2.0 * abs(p_lung) / self.rho), p_lung)
        p_sup = 2.0 * b + z1 * u
        p_sub = p_lung if self.sub is None else 2.0 * f_sub - self.sub["Z"][-1] * u
        return u, p_sub, p_sup

    def sample(self, area: float, p_lung: float) -> None:
        """Advances the lattice by one sample with the glottal ``area`` and the lung pressure."""
        fw, bw = self.fw, self.bw
        b_g = bw[0]
        f_s = self.sub["fw"][-1] if self.sub is not None else 0.0
        self.arrived = (b_g, f_s)
        u, p_sub, p_sup = self.glottal_junction(area, p_lung, b_g, f_s)
        # the lips
        f_l = fw[-1]
        zl = self.Z[-1]
        walls = self.walls
        gl, hl = (walls.g[-1], walls.h[-1]) if walls is not None else (0.0, 0.0)
        if self.radiation:
            k = self.T / (2.0 * self.L)
            p = (2.0 * f_l / zl - self.i_L - k * self.p_L - hl) / (1.0 / zl + k + 1.0 / self.R + gl)
            self.i_L += k * (self.p_L + p)
            self.p_L = p
        else:
            p = 0.0
        u_lips = (2.0 * f_l - p) / zl - (gl * p + hl)  # what enters the radiation load (less the lip wall's)
        if walls is None and self.branch is None:
            # the junctions: d = r (f_k - b_k+1); f_k+1 out = f_k + d, b_k out = b_k+1 + d; one section's delay
            self.fw, self.bw = _scatter(fw, bw, self.r, self.att, p_sup - b_g, p - f_l)
        else:  # the junctions' pressures with the walls' and the side branch's flows taken out
            self.fw, self.bw, pj = _junctions(fw, bw, self.Y, self.den, self.att, p_sup - b_g, p - f_l, walls,
                                              self.branch)
            if walls is not None:
                walls.update(np.concatenate([[p_sup], pj, [p]]))
            if self.branch is not None:
                self.branch.sample(pj[self.branch.node - 1])
        if self.sub is not None:
            s = self.sub
            s["fw"], s["bw"] = _scatter(s["fw"], s["bw"], s["r"], s["att"], p_lung - s["bw"][0], p_sub - f_s)
        p_rad = self.rho / (4.0 * math.pi * self.distance) * (u_lips - self.u_lips) / self.T
        self.u_lips = u_lips
        o = self.out
        o["p_rad"].append(p_rad)
        o["u_lips"].append(u_lips)
        o["u_glottis"].append(u)
        o["p_sup"].append(p_sup)
        o["p_sub"].append(p_sub)
        self.j += 1

    def advance(self, t: float, area: float, p_lung: float):
        """Every sample up to ``t`` with the glottal area interpolated between the last call's
        and this one's (quadratically through the call before too, clipped at 0, so that the
        flow's derivative, the radiated pressure, has no jumps at the calls), the lung pressure
        linearly; returns (U, p_sub, p_sup) at ``t`` itself."""
        t0, a0, p0 = self.last if self.last is not None else (t, area, p_lung)
        before = self.before
        span = t - t0
        T = self.T
        while self.j * T <= t * (1.0 + 1e-12):
            tj = self.j * T
            w = min(max((tj - t0) / span, 0.0), 1.0) if span > 0.0 else 1.0
            if before is not None and span > 0.0:  # Lagrange through (t_-1, a_-1), (t0, a0), (t, area)
                tm, am = before
                x = w * span
                a_j = (am * x * (x - span) / ((tm - t0) * (tm - t))
                       + a0 * (x - (tm - t0)) * (x - span) / ((t0 - tm) * (t0 - t))
                       + area * (x - (tm - t0)) * x / ((t - tm) * (t - t0)))
                a_j = max(a_j, 0.0)
            else:
                a_j = a0 + w * (area - a0)
            self.sample(a_j, p0 + w * (p_lung - p0))
        if self.last is not None and span > 0.0:
            self.before = (t0, a0)
        self.last = (t, area, p_lung)
        # the waves at t: between those that arrived at sample j - 1 and those arriving at j
        w = (t - (self.j - 1) * T) / T if self.j else 1.0
        b_prev, f_prev = self.arrived
        b = b_prev + w * (self.bw[0] - b_prev)
        f_now = self.sub["fw"][-1] if self.sub is not None else 0.0
        return self.glottal_junction(area, p_lung, b, f_prev + w * (f_now - f_prev))

    def energy(self) -> float:
        """The acoustic energy the tract(s) hold (J): that of the waves in the sections, sum of
        A T (f^2 + b^2) / (rho c), plus what the walls' and the lip inductance's states hold in
        the form the trapezoidal rule conserves (:meth:`_Walls.energy`). Without a source it
        never rises; with no losses and no radiation it changes by exactly T p_sup U a sample."""
        e = float(np.sum(self.A * (self.fw ** 2 + self.bw ** 2)))
        if self.sub is not None:
            s = self.sub
            e += float(np.sum(s["A"] * (s["fw"] ** 2 + s["bw"] ** 2)))
        e *= self.T / (self.rho * self.c)
        if self.branch is not None:
            e += self.branch.energy(self.T)
        if self.walls is not None:
            e += self.walls.energy()
        if self.radiation:  # the lip inductance's, as the trapezoidal rule keeps it: L/2 (i + T p / 2L)^2
            e += 0.5 * self.L * (self.i_L + self.T * self.p_L / (2.0 * self.L)) ** 2
        return e

    # -- the frequency domain -------------------------------------------------------------------

    def transfer(self, f) -> np.ndarray:
        """U_lips / U_glottis of the supraglottal lattice at frequencies ``f`` (Hz), the glottis
        an ideal flow source: the lattice's own z-transform on the unit circle (the lip load
        by the same trapezoidal rule as in time)."""
        f = np.atleast_1d(np.asarray(f, dtype=float))
        z1 = np.exp(-2j * np.pi * f * self.T)  # one sample's delay
        Z, att = self.Z, self.att
        u = np.ones_like(z1)  # U at the lips; p there from the lip load, then back section by section
        s = (2.0 / self.T) * (1.0 - z1) / (1.0 + z1)  # the trapezoidal rule's s
        if self.radiation:
            p = s * self.L * self.R / (self.R + s * self.L) * u
        else:
            p = np.zeros_like(z1)
        yw = self.walls.admittance(s) if self.walls is not None else None
        if yw is not None:
            u = u + yw[-1] * p
        yb = self.branch.admittance(z1) if self.branch is not None else None
        for k in range(self.N - 1, -1, -1):  # (p, U) continuous at junctions; waves cross a section
            p, u = _cross(p, u, Z[k], att[k], z1)
            if yw is not None:  # the wall at the section's left end takes Y_w p
                u = u + yw[k] * p
            if yb is not None and k == self.branch.node:  # and the side branch Y_b p
                u = u + yb * p
        return 1.0 / u

    def formants(self, ceiling: float = FORMANT_CEILING, n: int = 4) -> list:
        """[(frequency, -3 dB bandwidth), ...] (Hz) of the first ``n`` peaks of |U_lips /
        U_glottis| between :data:`FORMANT_FLOOR` and ``ceiling`` (and the lattice's Nyquist
        frequency): a 1 Hz grid, each
        peak refined to 1e-3 Hz; the bandwidth from the half-power points (None when a side
        does not fall 3 dB before rising again)."""
        from scipy.optimize import minimize_scalar

        top = min(ceiling, 0.5 / self.T)
        f = np.arange(FORMANT_FLOOR - 1.0, top, 1.0)
        db = np.abs(self.transfer(f))
        peaks = [i for i in range(1, len(f) - 1) if db[i] >= db[i - 1] and db[i] > db[i + 1]]
        out = []
        for i in peaks[:n]:
            res = minimize_scalar(lambda x: -abs(self.transfer(x)[0]), bounds=(f[i] - 1.0, f[i] + 1.0),
                                  method="bounded", options={"xatol": 1e-3})
            fp = float(res.x)
            out.append((fp, self._bandwidth(fp, abs(self.transfer(fp)[0]) / math.sqrt(2.0))))
        return out

    def _bandwidth(self, fp: float, half: float):
        from scipy.optimize import brentq

        def mag(x):
            return abs(self.transfer(x)[0])

        def side(sign):
            x, step, v = fp, 0.01, mag(fp)
            for _ in range(400):
                x2 = x + sign * step
                v2 = mag(x2)
                if v2 < half:
                    return brentq(lambda y: mag(y) - half, min(x, x2), max(x, x2), xtol=1e-6)
                if v2 > v or x2 <= 0.0:  # rising again (the next peak) before half power
                    return None
                x, v, step = x2, v2, min(step * 1.5, 50.0)
            return None

        lo, hi = side(-1.0), side(1.0)
        return None if lo is None or hi is None else float(hi - lo)

    # -- checkpoints ----------------------------------------------------------------------------

    def state(self) -> dict:
        s = {"fw": self.fw.copy(), "bw": self.bw.copy(), "i_L": self.i_L, "p_L": self.p_L, "u_lips": self.u_lips,
             "j": self.j, "last": self.last, "before": self.before, "arrived": self.arrived,
             "out": {k: list(v) for k, v in self.out.items()}}
        if self.sub is not None:
            s["sub_fw"], s["sub_bw"] = self.sub["fw"].copy(), self.sub["bw"].copy()
        if self.walls is not None:
            s["walls"] = self.walls.state()
        if self.branch is not None:
            s["branch_fw"], s["branch_bw"] = self.branch.fw.copy(), self.branch.bw.copy()
        return s

    def restore(self, s: dict) -> None:
        self.fw, self.bw = s["fw"].copy(), s["bw"].copy()
        self.i_L, self.p_L, self.u_lips, self.j = s["i_L"], s["p_L"], s["u_lips"], s["j"]
        self.last, self.before, self.arrived = s["last"], s["before"], s["arrived"]
        self.out = {k: list(v) for k, v in s["out"].items()}
        if self.sub is not None:
            self.sub["fw"], self.sub["bw"] = s["sub_fw"].copy(), s["sub_bw"].copy()
        if self.walls is not None:
            self.walls.restore(s["walls"])
        if self.branch is not None:
            self.branch.fw, self.branch.bw = s["branch_fw"].copy(), s["branch_bw"].copy()


def _scatter(fw, bw, r, att, into_first, into_last):
    """One sample of a lattice: the waves arriving at each section's right (``fw``) and left
    (``bw``) end scatter at the junctions (reflection ``r``); ``into_first`` enters the first
    section at its left end, ``into_last`` the last at its right end; every wave crosses its
    section (times ``att``). Returns the new (fw, bw)."""
    d = r * (fw[:-1] - bw[1:])
    new_f = np.empty_like(fw)
    new_b = np.empty_like(bw)
    new_f[1:] = fw[:-1] + d
    new_b[:-1] = bw[1:] + d
    new_f[0], new_b[-1] = into_first, into_last
    return new_f * att, new_b * att


def _cross(p, u, Z, att, z1):
    """(p, U) at the left end of a section of impedance ``Z`` from those at its right end, in
    the z-domain (``z1`` one sample's delay, ``att`` the section's attenuation)."""
    fwd, back = (p + Z * u) / (2.0 * att * z1), att * z1 * (p - Z * u) / 2.0
    return fwd + back, (fwd - back) / Z


def _junction_denominator(y, walls, branch) -> np.ndarray:
    """Sum of the admittances at each of a lattice's N - 1 junctions (``y`` the sections'),
    with the walls' g (:class:`_Walls`) and the side branch's first section (:class:`_Branch`):
    the denominator of :func:`_junctions`' pressures, which does not change during a run."""
    den = y[:-1] + y[1:]
    if walls is not None:
        den = den + walls.g[1:-1]
    if branch is not None:
        den[branch.node - 1] += branch.y
    return den


def _junctions(fw, bw, y, den, att, into_first, into_last, walls, branch):
    """One sample of a lattice whose junctions also lose volume velocity to yielding walls
    (U_w = g p + h, :class:`_Walls`) and/or a side branch (:class:`_Branch`): each junction's
    pressure from the flow balance sum Y (2 p_in - p) = U_w, i.e. p = (2 sum Y p_in - h) /
    ``den`` (:func:`_junction_denominator`), the waves leaving it p - p_in. ``y``: the sections'
    admittances. Returns (fw, bw, the junctions' pressures)."""
    f, b = fw[:-1], bw[1:]
    num = 2.0 * (y[:-1] * f + y[1:] * b)
    if walls is not None:
        num = num - walls.h[1:-1]
    if branch is not None:
        num[branch.node - 1] += 2.0 * branch.y * branch.bw[0]
    p = num / den
    new_f = np.empty_like(fw)
    new_b = np.empty_like(bw)
    new_f[1:] = p - b
    new_b[:-1] = p - f
    new_f[0], new_b[-1] = into_first, into_last
    return new_f * att, new_b * att, p


class _Branch:
    """A side branch closed at its far end (the piriform sinuses): a lattice of sections of the
    tract's length with ``areas`` (m^2, from its mouth to its closed end) and attenuation
    ``sigma`` (1/m), its mouth at the tract's junction ``node`` (1..N-1: between sections
    node - 1 and node, counted from 0 at the glottis). At the mouth the branch is one more
    port of the junction (pressure continuous, volume velocities summing to zero); at the
    closed end the waves reflect with +1."""

    def __init__(self, node: int, areas, sigma, n_tract: int, dx: float, rho: float, c: float):
        if not 1 <= node <= n_tract - 1:  # build_tract has said so in the scene's words (piriform_position)
            raise ValueError(f"a side branch joins the tract at a junction 1..{n_tract - 1}, not {node}")
        self.node = int(node)
        self.A = np.asarray(areas, dtype=float)
        self.Z = rho * c / self.A
        self.y = 1.0 / self.Z[0]
        self.r = (self.A[:-1] - self.A[1:]) / (self.A[:-1] + self.A[1:])
        self.att = np.exp(-np.broadcast_to(np.asarray(sigma, dtype=float), self.A.shape) * dx)
        self.fw, self.bw = np.zeros(len(self.A)), np.zeros(len(self.A))
        self.rho, self.c = rho, c

    def sample(self, p_mouth: float) -> None:
        """One sample: the wave p_mouth - (the one that arrived) enters at the mouth; the
        closed end reflects what arrives there."""
        self.fw, self.bw = _scatter(self.fw, self.bw, self.r, self.att, p_mouth - self.bw[0], self.fw[-1])

    def admittance(self, z1) -> np.ndarray:
        """U / p into the branch at its mouth at the delays ``z1`` (the lattice's own)."""
        p, u = np.ones_like(z1), np.zeros_like(z1)  # at the closed end
        for k in range(len(self.A) - 1, -1, -1):
            p, u = _cross(p, u, self.Z[k], self.att[k], z1)
        return u / p

    def energy(self, T: float) -> float:
        return float(np.sum(self.A * (self.fw ** 2 + self.bw ** 2))) * T / (self.rho * self.c)


class _Walls:
    """The yielding walls of a lattice, lumped at its N + 1 nodes (node 0 the glottal end, node
    j the junction of sections j - 1 and j, node N the lips): at each node an acoustic mass M,
    resistance B and stiffness K (Pa s^2/m^3, Pa s/m^3, Pa/m^3) through which the node's pressure
    p drives the volume velocity U into the wall, p = M dU/dt + B U + K X (X the displaced
    volume), integrated with the trapezoidal rule:

        U_n = g p_n + h,   h = g p_n-1 + alpha U_n-1 - beta X_n-1,   X_n = X_n-1 + T (U_n-1 + U_n) / 2

    i.e. the bilinear transform of the wall's admittance, which keeps it passive: :meth:`energy`
    is what its state holds and it only falls by the resistance's work (and with B = 0 is
    conserved to round-off). Two ways to set M, B, K (:meth:`of`):

    - ``("surface", m, b, k)`` (or a bare (m, b, k)): a mass-resistance-spring per unit area
      of the tube's surface (circular sections, perimeter 2 sqrt(pi A)), each node taking half
      of the surface of the sections on either side: M = m / S, B = b / S, K = k / S;
    - ``("sondhi", F_t, r, F_w)``: the wall admittance per unit length proportional to the
      section's area, (A / rho c^2) w_t^2 s / (s^2 + r s + w_w^2) (Sondhi's form), each node
      taking half of the volume V of the sections on either side: M = rho c^2 / (V w_t^2),
      B = r M, K = w_w^2 M. With mass alone every resonance of any area function moves to
      F^2 = F_c^2 + F_t^2 (F_t the closed tract's resonance)."""

    def __init__(self, M, B, K, T: float):
        self.M, self.B, self.K = (np.asarray(x, dtype=float) for x in (M, B, K))
        self.T = float(T)
        d = self.M + 0.5 * T * self.B + 0.25 * T * T * self.K
        self.g = T / (2.0 * d)
        self.alpha = (self.M - 0.5 * T * self.B - 0.25 * T * T * self.K) / d
        self.beta = T * self.K / d
        n = len(self.M)
        self.U, self.X, self.p = np.zeros(n), np.zeros(n), np.zeros(n)
        self.h = np.zeros(n)  # U_next = g p_next + h

    @classmethod
    def of(cls, spec, areas, dx: float, T: float, rho: float, c: float) -> "_Walls":
        areas = np.asarray(areas, dtype=float)
        kind, *values = spec if isinstance(spec[0], str) else ("surface", *spec)
        if kind == "surface":
            m, b, k = values
            half = 0.5 * dx * 2.0 * np.sqrt(np.pi * areas)
            S = np.concatenate([[half[0]], half[:-1] + half[1:], [half[-1]]])  # m^2 of wall at each node
            return cls(m / S, b / S, k / S, T)
        if kind == "sondhi":
            ft, r, fwall = values
            half = 0.5 * dx * areas
            V = np.concatenate([[half[0]], half[:-1] + half[1:], [half[-1]]])  # m^3 of air at each node
            M = rho * c * c / (V * (2.0 * np.pi * ft) ** 2)
            return cls(M, r * M, (2.0 * np.pi * fwall) ** 2 * M, T)
        raise ValueError(f"wall_model: expected 'sondhi' or 'surface', got {kind!r}")

    def admittance(self, s) -> np.ndarray:
        """Y_w (m^3/(s Pa)) of every node at the complex frequencies ``s`` (nodes x len(s))."""
        s = np.asarray(s)[None, :]
        return 1.0 / (self.M[:, None] * s + self.B[:, None] + self.K[:, None] / s)

    def update(self, p) -> None:
        u = self.g * p + self.h
        self.X = self.X + 0.5 * self.T * (self.U + u)
        self.U, self.p = u, p
        self.h = self.g * p + self.alpha * u - self.beta * self.X

    def energy(self) -> float:
        """(J) What the walls hold as the trapezoidal rule conserves it: per node
        (M / 2)(U + T p_m / 2 M)^2 + (K / 2)(X + T U / 2)^2, p_m = p - (B U + K X) the pressure
        across the mass."""
        T = self.T
        p_m = self.p - (self.B * self.U + self.K * self.X)
        e = 0.5 * self.M * (self.U + T * p_m / (2.0 * self.M)) ** 2
        e = e + 0.5 * self.K * (self.X + 0.5 * T * self.U) ** 2
        return float(np.sum(e))

    def state(self) -> dict:
        return {"U": self.U.copy(), "X": self.X.copy(), "p": self.p.copy(), "h": self.h.copy()}

    def restore(self, s: dict) -> None:
        self.U, self.X, self.p, self.h = s["U"].copy(), s["X"].copy(), s["p"].copy(), s["h"].copy()


def boundary_layer_sigma(areas, frequency: float, c: float) -> np.ndarray:
    """Kirchhoff's visco-thermal attenuation per unit length (1/m) of a circular tube of each
    area at ``frequency``: (S / (2 A c)) sqrt(pi f nu) (1 + (gamma - 1) / sqrt(Pr)), S the
    perimeter."""
    areas = np.asarray(areas, dtype=float)
    perimeter = 2.0 * np.sqrt(np.pi * areas)
    return perimeter / (2.0 * areas * c) * math.sqrt(math.pi * frequency * NU_AIR) * \
        (1.0 + (GAMMA_AIR - 1.0) / math.sqrt(PRANDTL_AIR))


def build_tract(params, coupled: bool | None = None) -> Tract:
    """The :class:`Tract` of the ``[acoustics]`` ``params``: the area function on its equal
    sections (``section_length``), its losses, its subglottal tract."""
    try:
        a, dx = geometry(params)
    except ValueError as e:
        raise VfrsError(f"[acoustics] {e}") from None
    c = params.sound_speed
    sigma = _sigma(params, a, c)
    sub = sub_sigma = None
    if params.subglottal_length is not None:
        m = int(round(params.subglottal_length / dx))
        if m < 1:
            raise VfrsError(f"[acoustics] subglottal_length: {params.subglottal_length:g} m is shorter than one "
                            f"section ({dx:g} m)")
        sub = np.full(m, params.subglottal_area)
        sub_sigma = _sigma(params, sub, c)
    walls = wall_spec(params) if params.losses == "walls" else None
    branch = None
    if piriform_on(params):
        node, b_areas = piriform_geometry(params, dx, len(a))
        branch = (node, b_areas, _sigma(params, b_areas, c))
    return Tract(a, dx, c, params.density, sigma, params.radiation, params.distance, sub, sub_sigma,
                 params.coupling == "two_way" if coupled is None else coupled, walls, branch)


def wall_spec(params) -> tuple:
    """The walls of ``losses = "walls"`` as :class:`_Walls` takes them."""
    if params.wall_model == "surface":
        return ("surface", params.wall_mass, params.wall_resistance, params.wall_stiffness)
    return ("sondhi", params.wall_resonance, params.wall_damping, params.wall_spring_frequency)


def piriform_on(params) -> bool:
    """``piriform``, or when unset: on for the built-in vowels of Story, Titze & Hoffman (1996),
    whose published formants were computed with the sinuses, off for ``uniform`` and for an
    area function of the user's."""
    if params.piriform is not None:
        return bool(params.piriform)
    return params.areas is None and params.area_file is None and params.vowel in STORY_1996


def piriform_geometry(params, dx: float, n_tract: int) -> tuple:
    """(the tract junction the sinuses join, their areas on sections of the tract's ``dx``)."""
    b_areas = np.asarray(params.piriform_areas, dtype=float)
    lengths = np.full(len(b_areas), params.piriform_section_length)
    n = max(1, int(round(float(np.sum(lengths)) / dx)))
    if n != len(b_areas) or not math.isclose(params.piriform_section_length, dx, rel_tol=1e-9):
        b_areas = resample(lengths, b_areas, n)
    node = int(round(params.piriform_position / dx))
    if not 1 <= node <= n_tract - 1:
        raise ValueError(f"piriform_position: {params.piriform_position:g} m is junction {node} of the tract's "
                         f"{n_tract} sections of {dx:g} m; the sinuses must join between two sections (junction 1.."
                         f"{n_tract - 1})")
    return node, b_areas


def _sigma(params, areas, c):
    if params.losses == "none":
        return 0.0
    if params.losses == "uniform":  # every resonance of a uniform closed-open tube gets loss_bandwidth
        return math.pi * params.loss_bandwidth / c
    return boundary_layer_sigma(areas, params.loss_frequency, c)  # 'boundary_layer', and 'walls' with it


# -- the [acoustics] effect -------------------------------------------------------------------

WAV_FILE, PRESSURE_FILE = "voice.wav", "voice.npz"


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
    tw, pw = _window(t, np.asarray(h["radiated_pressure"]), run.window_start)
    if len(pw) > 1:
        rms = float(np.sqrt(np.mean((pw - pw.mean()) ** 2)))
        dist = _distance(run)
        where = f" at {dist * 100:g} cm" if dist is not None else ""
        out["spl"] = Quantity(20.0 * math.log10(rms / P_REF) if rms > 0 else float("-inf"), "dB",
                              f"sound pressure level{where} (re 20 uPa, RMS)", over="window")
        cyc = run.cycles
        if len(cyc) >= 3:
            h1h2 = _h1_h2(t, np.asarray(h["radiated_pressure"]), cyc[0], cyc[-1], len(cyc) - 1)
            out["h1_h2"] = Quantity(h1h2, "dB", "H1-H2 of the radiated pressure", over="window")
    _, pt = _window(t, np.asarray(h["tract_pressure"]), run.window_start)
    if len(pt):
        out["peak_tract_pressure"] = Quantity(float(pt.max()), "Pa", "peak tract input pressure", over="window")
    params = _params(run)
    if params is not None:
        for k, (fk, bk) in enumerate(build_tract(params).formants(), start=1):
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


def _h1_h2(t, p, t0, t1, n_cycles) -> float:
    """H1 - H2 (dB) of ``p`` over [t0, t1] (``n_cycles`` whole cycles): the spectrum's
    magnitude at f0 and at 2 f0 (Hann window, the bins of those frequencies)."""
    keep = (t >= t0) & (t < t1)
    x = p[keep] - p[keep].mean()
    if len(x) < 8:
        return float("nan")
    dt = float(np.median(np.diff(t[keep])))
    f0 = n_cycles / (t1 - t0)
    n = 8 * len(x)  # zero-padded: the harmonics fall near bins
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x)), n))
    freqs = np.fft.rfftfreq(n, dt)

    def at(f):
        band = (freqs > f - 0.25 * f0) & (freqs < f + 0.25 * f0)
        return float(spec[band].max()) if band.any() else float("nan")

    h1, h2 = at(f0), at(2.0 * f0)
    return 20.0 * math.log10(h1 / h2) if h1 > 0 and h2 > 0 else float("nan")


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
    def sample_history(cls, scene, t) -> dict:
        """A 200 Hz radiated pressure and tract pressure."""
        wave = np.sin(2 * np.pi * 200.0 * t)
        return {"radiated_pressure": 0.1 * wave + 0.05 * np.sin(4 * np.pi * 200.0 * t),
                "tract_pressure": 100.0 * wave, "glottal_flow": 1e-4 * (1.0 + wave)}


@register_effect
class Acoustics(AcousticsOutputs, Effect):
    """The ``[acoustics]`` section: the vocal tract driven by the [flow] effect's glottal flow.

    History: ``tract_pressure`` (Pa, the tract's input pressure just above the glottis at the
    step's load time), ``subglottal_pressure`` (Pa), ``glottal_flow`` (m^3/s, the tract's), and
    ``radiated_pressure`` (Pa at ``distance``: the tract's last sample up to the step's time).
    Files: ``voice.wav`` (16-bit, ``wav_rate``, normalised to 0.9 of full scale) and
    ``voice.npz`` (the radiated pressure in Pa at the tract's rate and at ``wav_rate``, the
    WAV's full scale in Pa)."""

    name = "acoustics"

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
                              "'none': the flow as without a tract", choices=("two_way", "none"))
        subglottal_length: float | None = param(None, doc="length of a uniform subglottal tract (none if unset)",
                                                unit="m", positive=True)
        subglottal_area: float = param(2.5e-4, doc="area of the subglottal tract", unit="m^2", positive=True)
        sound_speed: float = param(350.0, doc="speed of sound", unit="m/s", positive=True)
        density: float = param(1.2, doc="air density (tract and glottal jet)", unit="kg/m^3", positive=True)
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

    # Checkpoints: the lattice's waves, the ends' memory and the samples so far (state/restore).

    def setup(self, ctx) -> None:
        scene = getattr(ctx.problem, "scene", None)
        if scene is not None and "flow" not in scene.effects:
            raise VfrsError("[acoustics] needs a [flow] section: the tract is driven by the glottal flow")
        self.tract = build_tract(self.params)
        links = getattr(ctx, "links", None)
        if links is None:
            raise VfrsError("[acoustics]: this run's SetupContext has no links to reach the [flow] effect")
        links["glottis"] = self.glottis
        self.now: tuple | None = None  # (U, p_sub, p_sup) at the last call's time

    def glottis(self, t: float, area: float, p_lung: float):
        """The tract at the [flow] effect's load time ``t`` with the glottal ``area`` (m^2, at
        separation; 0 closed) and the lung pressure ``p_lung`` (Pa): (p_sub, p_sup) (Pa) for
        the flow's pressure drop, or None with ``coupling = "none"``."""
        u, p_sub, p_sup = self.tract.advance(t, area, p_lung)
        self.now = (u, p_sub, p_sup)
        return (p_sub, p_sup) if self.tract.coupled else None

    def record(self, state, history) -> None:
        now = self.now
        o = self.tract.out
        u, p_sub, p_sup = now if now is not None else (np.nan, np.nan, np.nan)
        history.setdefault("tract_pressure", []).append(p_sup)
        history.setdefault("subglottal_pressure", []).append(p_sub)
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


def resample_pressure(p, T: float, t_end: float, rate: int) -> np.ndarray:
    """The pressure ``p`` sampled every ``T`` s from t = 0, on ``round(t_end rate)`` samples at
    ``rate``: when the tract's rate is higher, its spectrum above 0.45 ``rate`` is removed
    first (FFT), then it is linearly interpolated."""
    n = int(round(t_end * rate))
    x = np.asarray(p, dtype=float)
    if len(x) == 0 or n == 0:
        return np.zeros(n)
    if 1.0 / T > rate:
        spec = np.fft.rfft(x)
        spec[np.fft.rfftfreq(len(x), T) > 0.45 * rate] = 0.0
        x = np.fft.irfft(spec, len(x))
    return np.interp(np.arange(n) / rate, np.arange(len(x)) * T, x)


def write_voice(out: str, p_rad, T: float, t_end: float, rate: int, distance: float) -> float:
    """Writes ``voice.wav`` (16-bit PCM at ``rate``, normalised: its peak at 0.9 of full scale)
    and ``voice.npz`` (``p_tract`` Pa at the tract's rate ``fs_tract``, ``p`` Pa at ``rate``,
    ``full_scale`` Pa that the WAV's full scale stands for, ``distance`` m) into ``out``;
    returns the full scale."""
    from scipy.io import wavfile

    p = resample_pressure(p_rad, T, t_end, rate)
    peak = float(np.max(np.abs(p))) if len(p) else 0.0
    full_scale = peak / 0.9 if peak > 0 else 1.0
    pcm = np.round(p / full_scale * 32767.0).astype(np.int16)
    wavfile.write(os.path.join(out, WAV_FILE), rate, pcm)
    np.savez(os.path.join(out, PRESSURE_FILE), p_tract=np.asarray(p_rad, dtype=float), fs_tract=1.0 / T, p=p,
             rate=rate, full_scale=full_scale, distance=distance)
    return full_scale
