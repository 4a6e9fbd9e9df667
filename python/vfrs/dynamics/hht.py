"""HHT-alpha (Hilber-Hughes-Taylor) for M a + C v + K u = F, with K_eff factored once.

    M a1 + (1+alpha)(C v1 + K u1 - F1) - alpha (C v0 + K u0 - F0) = 0
    u1 = u0 + h v0 + h^2 ((1/2 - beta) a0 + beta a1),   v1 = v0 + h ((1 - gamma) a0 + gamma a1)
    beta = (1 - alpha)^2 / 4,  gamma = 1/2 - alpha,  alpha in [-1/3, 0]

Solved for u1 with the predictors u~ = u0 + h v0 + h^2 (1/2 - beta) a0, v~ = v0 + h (1-gamma) a0:

    K_eff u1 = M u~/(beta h^2) + (1+alpha) C (gamma/(beta h) u~ - v~) + alpha (C v0 + K u0)
               + (1+alpha) F1 - alpha F0,
    K_eff = M/(beta h^2) + (1+alpha) gamma/(beta h) C + (1+alpha) K.

With Rayleigh damping C = a0 M + a1 K the right-hand side costs one product with M and one
with K; the solve is one forward/back substitution.

>>> import numpy as np, scipy.sparse as sp
>>> M, K = sp.csr_matrix([[1.0]]), sp.csr_matrix([[4.0 * np.pi**2]])   # period 1 s
>>> hht = HHTAlpha(M, K, step=0.01, alpha=0.0)
>>> u, v, a = np.array([1.0]), np.array([0.0]), np.array([-4.0 * np.pi**2])
>>> for _ in range(100):
...     hht.step(u, v, a, np.zeros(1), np.zeros(1))
>>> round(float(u[0]), 3)   # one period later (trapezoidal rule: period error 0.03 %)
1.0
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from ..linalg import Product, cholesky, for_products, sum_of_products


def hht_parameters(alpha: float) -> tuple:
    """(beta, gamma) of HHT-alpha; ``alpha`` must lie in [-1/3, 0]."""
    if not (-1.0 / 3.0 - 1e-15 <= alpha <= 0.0):
        raise SolverError(f"HHT alpha = {alpha} must be in [-1/3, 0]")
    return (1.0 - alpha) ** 2 / 4.0, 0.5 - alpha


def transient_shift(alpha: float, beta: float, gamma: float, h: float) -> tuple:
    """How far a transient force f of the last step moves the predictors, per M^-1 f: it left
    (1 + alpha) M^-1 f in the acceleration, and the predictors move with an acceleration by
    h^2 (1/2 - beta) (u~) and h (1 - gamma) (v~)."""
    return (1.0 + alpha) * h**2 * (0.5 - beta), (1.0 + alpha) * h * (1.0 - gamma)


def correct_predictor(u_tilde, v_tilde, pending, shift, mass_solve, ctx=None, predict_hooks=()) -> None:
    """The predictors ``u_tilde``, ``v_tilde`` (free DOFs, changed in place) before a step's
    solve: the effects' ``predict`` hooks run on them (through the step context ``ctx``), and
    the last step's transient forces ``pending`` (free DOFs, or None), which acted in that
    step only, are taken out (``shift``: :func:`transient_shift`). A predict hook may take
    them out itself (with the M^-1 solve it needs anyway); what it leaves in
    ``ctx.transient_prev`` is taken out here with ``mass_solve`` (M^-1)."""
    if ctx is not None:
        ctx.u_tilde, ctx.v_tilde = u_tilde, v_tilde
        ctx.transient_prev, ctx.transient_shift = pending, shift
        for hook in predict_hooks:
            hook(ctx)
        pending, ctx.transient_prev = ctx.transient_prev, None
    if pending is not None:
        r = mass_solve(pending)
        u_tilde -= shift[0] * r
        v_tilde -= shift[1] * r


class MassSolve:
    """M^-1 for a mass matrix (free DOFs) with rows of zeros (massless nodes: the contact
    scheme ``mass_redistribution``): the factor of M on the DOFs that carry mass, and zero on
    the others (their acceleration is not set by a balance with inertia)."""

    def __init__(self, M):
        M = sp.csr_matrix(M)
        self.n = M.shape[0]
        self.massive = np.flatnonzero(M.diagonal() > 0)
        if len(self.massive) == 0:
            raise SolverError("the mass matrix is zero on every free DOF: nothing carries inertia")
        self.factor = cholesky(M[self.massive][:, self.massive], blocks=True)

    def solve(self, b) -> np.ndarray:
        b = np.asarray(b, dtype=float)
        out = np.zeros(b.shape)
        out[self.massive] = self.factor.solve(b[self.massive])
        return out


def mass_factor(M):
    """The Cholesky factor of M (free DOFs), or a :class:`MassSolve` where M has massless rows."""
    d = M.diagonal()
    if np.all(d > 0):
        return cholesky(M, blocks=True)
    return MassSolve(M)


class HHTAlpha:
    """HHT-alpha on fixed (free-DOF) matrices ``M``, ``K`` and damping, for a fixed step.

    Damping: ``rayleigh=(a0, a1)`` (C = a0 M + a1 K, cheapest) or an explicit sparse ``C``.
    :meth:`step` advances ``u, v, a`` in place. ``factor`` is the Cholesky factor of K_eff.
    """

    def __init__(self, M, K, step: float, alpha: float = -0.3, rayleigh=(0.0, 0.0), C=None, ordering="auto"):
        if not step > 0:
            raise SolverError(f"time step must be positive, got {step}")
        self.beta, self.gamma = hht_parameters(alpha)
        self.alpha, self.h = float(alpha), float(step)
        self.M, self.K = sp.csr_matrix(M), sp.csr_matrix(K)
        self.C = None if C is None else sp.csr_matrix(C)
        # M's and K's products: M without its stored zeros, both node-blocked in Rust where
        # they are (the same numbers as scipy's products with M and K).
        self._M_mul = Product(for_products(self.M))
        self._K_mul = Product(self.K)
        self.a0, self.a1 = (0.0, 0.0) if C is not None else (float(rayleigh[0]), float(rayleigh[1]))
        b, g, h, al = self.beta, self.gamma, self.h, self.alpha
        self.c_m = 1.0 / (b * h * h)
        self.c_c = (1.0 + al) * g / (b * h)
        if self.C is None:
            self.K_eff = (self.c_m + self.c_c * self.a0) * self.M + (self.c_c * self.a1 + 1.0 + al) * self.K
        else:
            self.K_eff = self.c_m * self.M + self.c_c * self.C + (1.0 + al) * self.K
        self.factor = cholesky(self.K_eff, ordering=ordering, blocks=True)
        n = self.M.shape[0]
        self.n = n
        self.solve_seconds = 0.0  # time spent in the triangular solves of step()
        # Work arrays, reused every step.
        self.u_tilde = np.empty(n)
        self.v_tilde = np.empty(n)
        self._w = np.empty(n)
        self._x = np.empty(n)
        self._y = np.empty(n)
        self._t = np.empty(n)  # scratch for c * vector terms (same numbers as a temporary)
        self._f_transient: np.ndarray | None = None  # last step's transient forces (free DOFs)
        self.transient_shift = transient_shift(self.alpha, self.beta, self.gamma, self.h)
        self._mass_factor = None

    def state(self) -> dict:
        """What carries over to the next step besides u, v, a: the last step's transient forces."""
        f = self._f_transient
        return {"f_transient": None if f is None else f.copy()}

    def restore(self, state: dict) -> None:
        f = state.get("f_transient")
        self._f_transient = None if f is None else f.copy()

    @property
    def mass_factor(self):
        """The Cholesky factor of M (free DOFs), made on first use and kept."""
        if self._mass_factor is None:
            self._mass_factor = mass_factor(self.M)
        return self._mass_factor

    def mass_solve(self, b) -> np.ndarray:
        """M^-1 b (free DOFs)."""
        return self.mass_factor.solve(b)

    def initial_acceleration(self, u, v, F) -> np.ndarray:
        """a0 from M a0 = F - K u - C v (one factorization of M)."""
        r = np.asarray(F, dtype=float) - self.K @ u - self._damp(v)
        if not np.any(r):
            return np.zeros(self.n)
        return self.mass_factor.solve(r)

    def _damp(self, v):
        if self.C is not None:
            return self.C @ v
        out = np.zeros(self.n)
        if self.a0:
            out += self.a0 * (self._M_mul @ v)
        if self.a1:
            out += self.a1 * (self.K @ v)
        return out

    def predict(self, u, v, a) -> None:
        """Fills ``u_tilde`` and ``v_tilde`` from the state at the start of the step."""
        h, b, g = self.h, self.beta, self.gamma
        ut, vt = self.u_tilde, self.v_tilde
        np.multiply(v, h, out=ut)
        ut += u
        np.multiply(a, h * h * (0.5 - b), out=self._w)
        ut += self._w
        np.multiply(a, h * (1.0 - g), out=vt)
        vt += v

    def rhs(self, u, v, F0, F1, extra=None) -> np.ndarray:
        """The right-hand side of K_eff u1 = rhs, from the predictors (call :meth:`predict` first)."""
        al, b, g, h = self.alpha, self.beta, self.gamma, self.h
        ut, vt, w, x, y, t = self.u_tilde, self.v_tilde, self._w, self._x, self._y, self._t
        # w = gamma/(beta h) u~ - v~  (the part of v1 not proportional to u1)
        np.multiply(ut, g / (b * h), out=w)
        w -= vt
        np.multiply(ut, self.c_m, out=x)
        if self.C is None:
            # x += c * w as x += (c * w) into the scratch t: the same numbers, no temporaries.
            if self.a0:
                x += np.multiply(w, (1.0 + al) * self.a0, out=t)
                if al:
                    x += np.multiply(v, al * self.a0, out=t)
            np.multiply(u, al, out=y)
            if self.a1:
                y += np.multiply(w, (1.0 + al) * self.a1, out=t)
                if al:
                    y += np.multiply(v, al * self.a1, out=t)
            r = sum_of_products([(self._M_mul, x), (self._K_mul, y)])
        else:
            np.multiply(w, 1.0 + al, out=w)
            if al:
                w += al * v
            r = sum_of_products([(self._M_mul, x), (self.C, w)])
            if al:
                r += self.K @ (al * u)
        r += np.multiply(F1, 1.0 + al, out=t)
        if al:
            r -= np.multiply(F0, al, out=t)
        if extra is not None:
            r += extra
        return r

    def step(self, u, v, a, F0, F1, extra=None, ctx=None, predict_hooks=(), correct_hooks=()) -> None:
        """Advances ``u, v, a`` (free DOFs) by one step, in place.

        ``F0``, ``F1``: external forces at the start and end of the step. ``extra``: anything
        else for the right-hand side (prescribed-motion coupling). ``ctx`` (a
        :class:`~vfrs.dynamics.StepContext`) with hooks: effects that change the predictor
        before the solve, or add implicit forces after it (``ctx.force`` must be ``F1``).
        """
        self.predict(u, v, a)
        pending, self._f_transient = self._f_transient, None
        correct_predictor(self.u_tilde, self.v_tilde, pending, self.transient_shift, self.mass_solve, ctx,
                          predict_hooks)
        r = self.rhs(u, v, F0, F1, extra)
        t0 = time.perf_counter()
        u1 = self.factor.solve(r)
        self.solve_seconds += time.perf_counter() - t0
        if ctx is not None:
            ctx.u = u1
            for hook in correct_hooks:
                hook(ctx)
            u1 = ctx.u
        # a1 = (u1 - u~)/(beta h^2),  v1 = v~ + gamma h a1
        np.subtract(u1, self.u_tilde, out=a)
        a *= self.c_m
        np.multiply(a, self.gamma * self.h, out=v)
        v += self.v_tilde
        if ctx is not None and ctx.velocity_jump is not None:
            v += ctx.velocity_jump  # an impulse at t_n+1 (StepContext.set_velocity_jump)
        u[:] = u1
        if ctx is not None and ctx.transient_free is not None:
            # a holds the balance at t_n+1 with the transient forces; the next predictor
            # must not see them (StepContext.add_force).
            self._f_transient = ctx.transient_free.copy()
