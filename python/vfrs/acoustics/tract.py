"""The wave-reflection lattice of the vocal tract (:class:`Tract`): its sections, the yielding
walls, the piriform sinuses as a closed side branch, the glottal and lip ends, its transfer
function and formants; :func:`build_tract` makes it from the ``[acoustics]`` parameters (the
model: :mod:`vfrs.acoustics`)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import VfrsError
from ..flow.port import AIR_DENSITY
from .vowels import FORMANT_CEILING, STORY_1996, geometry, resample

# Air (the boundary-layer losses): kinematic viscosity, ratio of specific heats, Prandtl number.
NU_AIR, GAMMA_AIR, PRANDTL_AIR = 1.5e-5, 1.4, 0.71
#: Hz: peaks of the transfer function below this are not formants (with yielding walls the
#: tract's air and the walls' stiffness make a broad peak near 40 Hz)
FORMANT_FLOOR = 100.0


class Tract:
    """The tube(s), their lattice state and the glottal and lip ends: see :mod:`vfrs.acoustics`.

    ``areas`` (m^2, glottis to lips) on sections of length ``dx``; ``sigma`` (1/m, per
    section) the amplitude attenuation per unit length; ``sub_areas`` the subglottal tract
    (lungs to glottis, same dx) or None; ``radiation``: the lips radiate (else p = 0 there)."""

    def __init__(self, areas, dx, c=350.0, rho=AIR_DENSITY, sigma=0.0, radiation=True, distance=0.3,
                 sub_areas=None, sub_sigma=0.0, coupled=True, walls=None, branch=None, recovery=False):
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
        # the pressure recovery at the glottal exit (coupling = "interactive"), and the flow
        # model's losses (vfrs.flow.model.GlottalLoss) the last call gave; None: Bernoulli's
        self.recovery, self.loss = bool(recovery), None
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
        """U solving ``k rho U|U| / (2 A^2) + q U|U| + (z + r) U = drive`` (m^3/s); 0 through a
        closed glottis. ``k`` is 1, or with the pressure recovery (:meth:`recovered`)
        ``1 - 2 x (1 - x)``, ``x = A / A_1`` (the tract's first section); ``q`` and ``r``: the flow
        model's losses (:attr:`loss`), none for Bernoulli's."""
        loss = self.loss
        if loss is None and not self.recovery:
            za = z * area
            den = za + math.sqrt(za * za + 2.0 * self.rho * abs(drive))
            return 2.0 * drive * area / den if den > 0.0 else 0.0
        if area <= 0.0:
            return 0.0
        c2 = (1.0 - self.recovered(area)) * 0.5 * self.rho / (area * area)
        c1 = z
        if loss is not None:
            c2 += loss.quadratic
            c1 += loss.linear
        den = c1 + math.sqrt(c1 * c1 + 4.0 * c2 * abs(drive))
        return 2.0 * drive / den if den > 0.0 else 0.0

    def recovered(self, area: float) -> float:
        """The share of the jet's dynamic pressure ``rho U^2 / (2 A^2)`` recovered where it meets
        the tract: ``2 x (1 - x)``, ``x = A / A_1`` clipped to [0, 1] (Ishizaka & Flanagan 1972;
        the total loss ``(1 - x)^2 + x^2`` of Titze's form); 0 without the recovery."""
        if not self.recovery:
            return 0.0
        x = min(max(area / self.A[0], 0.0), 1.0)
        return 2.0 * x * (1.0 - x)

    def jet_pressure(self, area: float, u: float, p_sup: float) -> float:
        """The pressure in the jet at the glottal exit: the tract's input pressure ``p_sup`` less
        what the jet recovers after it (:meth:`recovered`); ``p_sup`` without the recovery."""
        if area <= 0.0 or not self.recovery:
            return p_sup
        return p_sup - self.recovered(area) * 0.5 * self.rho * u * abs(u) / (area * area)

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

    def advance(self, t: float, area: float, p_lung: float, loss=None):
        """``loss``: the flow model's (:class:`vfrs.flow.model.GlottalLoss`, None: Bernoulli's),
        for the samples up to ``t``. Every sample up to ``t`` with the glottal area interpolated between the last call's
        and this one's (quadratically through the call before too, clipped at 0, so that the
        flow's derivative, the radiated pressure, has no jumps at the calls), the lung pressure
        linearly; returns (U, p_sub, p_sup) at ``t`` itself."""
        self.loss = loss
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


def boundary_layer_sigma(areas, frequency: float, c: float, nu: float = NU_AIR) -> np.ndarray:
    """Kirchhoff's visco-thermal attenuation per unit length (1/m) of a circular tube of each
    area at ``frequency``: (S / (2 A c)) sqrt(pi f nu) (1 + (gamma - 1) / sqrt(Pr)), S the
    perimeter, ``nu`` the kinematic viscosity (m^2/s)."""
    areas = np.asarray(areas, dtype=float)
    perimeter = 2.0 * np.sqrt(np.pi * areas)
    return perimeter / (2.0 * areas * c) * math.sqrt(math.pi * frequency * nu) * \
        (1.0 + (GAMMA_AIR - 1.0) / math.sqrt(PRANDTL_AIR))


def build_tract(params, coupled: bool | None = None, density: float = AIR_DENSITY,
                viscosity: float | None = None) -> Tract:
    """The :class:`Tract` of the ``[acoustics]`` ``params``: the area function on its equal
    sections (``section_length``), its losses, its subglottal tract; ``density`` the air's
    (kg/m^3, ``[flow] density``), ``viscosity`` its dynamic viscosity (Pa s, a viscous flow
    model's: one for the glottal flow and the tract's boundary layers; None: the kinematic
    viscosity ``NU_AIR``)."""
    nu = NU_AIR if viscosity is None else viscosity / density
    try:
        a, dx = geometry(params)
    except ValueError as e:
        raise VfrsError(f"[acoustics] {e}") from None
    c = params.sound_speed
    sigma = _sigma(params, a, c, nu)
    sub = sub_sigma = None
    if params.subglottal_length is not None:
        m = int(round(params.subglottal_length / dx))
        if m < 1:
            raise VfrsError(f"[acoustics] subglottal_length: {params.subglottal_length:g} m is shorter than one "
                            f"section ({dx:g} m)")
        sub = np.full(m, params.subglottal_area)
        sub_sigma = _sigma(params, sub, c, nu)
    walls = wall_spec(params) if params.losses == "walls" else None
    branch = None
    if piriform_on(params):
        node, b_areas = piriform_geometry(params, dx, len(a))
        branch = (node, b_areas, _sigma(params, b_areas, c, nu))
    return Tract(a, dx, c, density, sigma, params.radiation, params.distance, sub, sub_sigma,
                 params.coupling != "none" if coupled is None else coupled, walls, branch,
                 recovery=params.coupling == "interactive")


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


def _sigma(params, areas, c, nu=NU_AIR):
    if params.losses == "none":
        return 0.0
    if params.losses == "uniform":  # every resonance of a uniform closed-open tube gets loss_bandwidth
        return math.pi * params.loss_bandwidth / c
    return boundary_layer_sigma(areas, params.loss_frequency, c, nu)  # 'boundary_layer', and 'walls' with it

