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


#: The paper's HHT-alpha parameter (numerical damping of the high modes).
DEFAULT_ALPHA = -0.3


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


class HHTConstants:
    """The constants of HHT-alpha for one step size ``h``, computed once: what the linear
    (:class:`HHTAlpha`) and the Newton integrators step with and what effects receive
    (:class:`vfrs.effects.SetupContext` ``constants``), the one place the step size is kept.

    - ``alpha``, ``h``, ``beta = (1 - alpha)^2 / 4``, ``gamma = 1/2 - alpha``;
    - ``force_scale = 1 + alpha``: how a force at the end of the step enters K_eff du = force_scale f;
    - ``c_m = 1/(beta h^2)``, ``c_c = (1 + alpha) gamma/(beta h)``: K_eff's factors of M and C
      (a1 = c_m (u1 - u~)); ``gh = gamma h`` (v1 = v~ + gamma h a1);
    - ``u_predictor = h^2 (1/2 - beta)``, ``v_predictor = h (1 - gamma)``: the Newmark
      predictors' weights of a_n (u~ = u_n + h v_n + u_predictor a_n);
    - ``predictor_scale``: how far a force in the predictor moves it (du = predictor_scale
      M^-1 f); the same number as ``u_predictor`` written h**2 (1/2 - beta), which can differ
      from h*h (1/2 - beta) in the last bit: both are kept as the integrators and the
      effects have always computed them, so histories stay bit-identical;
    - ``transient_shift`` (:func:`transient_shift`), ``transient_weight = gamma (1 + alpha)``:
      the momentum a transient force of the step gives, per h;
    - the time grid: ``time(k) = k h``, ``step_index(t)``.
    """

    dynamic = True

    def __init__(self, alpha: float, h: float):
        if not h > 0:
            raise SolverError(f"time step must be positive, got {h}")
        self.beta, self.gamma = hht_parameters(alpha)
        self.alpha, self.h = float(alpha), float(h)
        b, g, h, al = self.beta, self.gamma, self.h, self.alpha
        self.force_scale = 1.0 + al
        self.c_m = 1.0 / (b * h * h)
        self.c_c = (1.0 + al) * g / (b * h)
        self.gh = g * h
        self.u_predictor = h * h * (0.5 - b)
        self.v_predictor = h * (1.0 - g)
        self.predictor_scale = h**2 * (0.5 - b)
        self.transient_shift = transient_shift(al, b, g, h)
        self.transient_weight = g * (1.0 + al)

    def time(self, k: int) -> float:
        return k * self.h

    def step_index(self, t: float) -> int:
        return int(round(t / self.h))

    def __repr__(self):
        return f"HHTConstants(alpha={self.alpha!r}, h={self.h!r})"


class StaticConstants:
    """The statics' counterpart of :class:`HHTConstants`: no inertia, forces enter K u = F
    unscaled, load step k of ``n_steps`` is at load factor k / n_steps."""

    dynamic = False
    force_scale = 1.0
    h = None

    def __init__(self, n_steps: int):
        self.n_steps = int(n_steps)

    def time(self, k: int) -> float:
        return k / self.n_steps

    def step_index(self, t: float) -> int:
        return int(round(t * self.n_steps))


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


class LazyMassFactor:
    """:func:`mass_factor` of ``M``, made on first use and kept: one factor for an integrator
    and the effects that solve with M (``SetupContext.mass_factor``)."""

    def __init__(self, M):
        self.M = M
        self._factor = None

    @property
    def factor(self):
        if self._factor is None:
            self._factor = mass_factor(self.M)
        return self._factor

    def solve(self, b) -> np.ndarray:
        """M^-1 b (free DOFs)."""
        return self.factor.solve(b)


class HHTAlpha:
    """HHT-alpha on fixed (free-DOF) matrices ``M``, ``K`` and damping, for a fixed step.

    Damping: ``rayleigh=(a0, a1)`` (C = a0 M + a1 K, cheapest) or an explicit sparse ``C``.
    :meth:`step` advances ``u, v, a`` in place. ``factor`` is the Cholesky factor of K_eff;
    ``constants`` (:class:`HHTConstants`) the scheme's constants, step size included.
    """

    def __init__(self, M, K, step: float, alpha: float = DEFAULT_ALPHA, rayleigh=(0.0, 0.0), C=None, ordering="auto"):
        self.constants = c = HHTConstants(alpha, step)
        self.M, self.K = sp.csr_matrix(M), sp.csr_matrix(K)
        self.C = None if C is None else sp.csr_matrix(C)
        # M's and K's products: M without its stored zeros, both node-blocked in Rust where
        # they are (the same numbers as scipy's products with M and K).
        self._M_mul = Product(for_products(self.M))
        self._K_mul = Product(self.K)
        self.a0, self.a1 = (0.0, 0.0) if C is not None else (float(rayleigh[0]), float(rayleigh[1]))
        al, c_m, c_c = c.alpha, c.c_m, c.c_c
        if self.C is None:
            self.K_eff = (c_m + c_c * self.a0) * self.M + (c_c * self.a1 + 1.0 + al) * self.K
        else:
            self.K_eff = c_m * self.M + c_c * self.C + (1.0 + al) * self.K
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
        self.mass = LazyMassFactor(self.M)

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
        return self.mass.factor

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
        c = self.constants
        ut, vt = self.u_tilde, self.v_tilde
        np.multiply(v, c.h, out=ut)
        ut += u
        np.multiply(a, c.u_predictor, out=self._w)
        ut += self._w
        np.multiply(a, c.v_predictor, out=vt)
        vt += v

    def rhs(self, u, v, F0, F1, extra=None) -> np.ndarray:
        """The right-hand side of K_eff u1 = rhs, from the predictors (call :meth:`predict` first)."""
        c = self.constants
        al, b, g, h = c.alpha, c.beta, c.gamma, c.h
        ut, vt, w, x, y, t = self.u_tilde, self.v_tilde, self._w, self._x, self._y, self._t
        # w = gamma/(beta h) u~ - v~  (the part of v1 not proportional to u1)
        np.multiply(ut, g / (b * h), out=w)
        w -= vt
        np.multiply(ut, c.c_m, out=x)
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
        correct_predictor(self.u_tilde, self.v_tilde, pending, self.constants.transient_shift, self.mass.solve, ctx,
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
        a *= self.constants.c_m
        np.multiply(a, self.constants.gh, out=v)
        v += self.v_tilde
        if ctx is not None and ctx.velocity_jump is not None:
            v += ctx.velocity_jump  # an impulse at t_n+1 (StepContext.set_velocity_jump)
        u[:] = u1
        if ctx is not None and ctx.transient_free is not None:
            # a holds the balance at t_n+1 with the transient forces; the next predictor
            # must not see them (StepContext.add_force).
            self._f_transient = ctx.transient_free.copy()


# ---- the balance of a step with nonlinear internal forces (the Newton integrator's) ----
def _on_pattern(A, indptr, indices, n: int) -> np.ndarray:
    """The values of the sparse ``A`` (n x n) on the CSC pattern ``(indptr, indices)``, which
    must hold every entry of A (zeros elsewhere)."""
    A = sp.csc_matrix(A)
    A.sum_duplicates()
    keys = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr)) * n + indices
    order = np.argsort(keys, kind="stable")
    a_keys = np.repeat(np.arange(n, dtype=np.int64), np.diff(A.indptr)) * n + A.indices
    at = np.minimum(np.searchsorted(keys[order], a_keys), len(keys) - 1)
    pos = order[at]
    if not np.array_equal(keys[pos], a_keys):
        raise SolverError("the mass or damping matrix has entries outside the stiffness pattern")
    out = np.zeros(len(indices))
    out[pos] = A.data
    return out


class HHTBalance:
    """The HHT-alpha balance of one time step, as a model for
    :func:`~vfrs.dynamics.newton.newton_solve` (``model``: a
    :class:`~vfrs.finite_strain.FiniteStrainModel`):

        g(u) = M a(u) + (1 + alpha) (f_int(u) + C v(u)),
        a(u) = (u - u~) / (beta h^2),  v(u) = v~ + gamma h a(u)   on the free DOFs

    (``u_tilde``, ``v_tilde``: the Newmark predictors, set per step; on the fixed DOFs a and v
    are the prescribed motion's, ``a_fixed``, ``v_fixed``), so the step solves g(u_n+1) = the
    step's constant forces. Its tangent on the free DOFs is
    ``K_eff = M/(beta h^2) + (1 + alpha)(gamma/(beta h) C + K_T)``, on the fixed pattern of
    K_T (M and C are scattered into it once). ``tangent_full`` is the derivative of g with
    respect to the fixed DOFs (the columns ``newton_solve`` multiplies it by):
    ``(1 + alpha) K_T``, the prescribed velocity and acceleration not depending on u.
    C is the problem's damping (Rayleigh, C = a0 M + a1 K with K the initial tangent)."""

    def __init__(self, model, problem, constants: HHTConstants):
        self.model = model
        self.free, self.fixed, self.n = model.free, model.fixed, model.n
        self.opa, self.c_m, self.gh = constants.force_scale, constants.c_m, constants.gh
        self.M = sp.csr_matrix(problem.M)
        if not problem.damped:
            self.C = None
        elif problem.C is not None:
            self.C = sp.csr_matrix(problem.C)
        else:
            a0, a1 = problem.rayleigh
            self.C = sp.csr_matrix(a0 * problem.M + a1 * problem.K)
        mc = self.c_m * self.M
        if self.C is not None:
            mc = mc + constants.c_c * self.C
        self._mc = _on_pattern(mc, model.indptr, model.indices, model.n)
        nf, nx = len(self.free), len(self.fixed)
        self.u_tilde, self.v_tilde = np.zeros(nf), np.zeros(nf)
        self.a_fixed, self.v_fixed = np.zeros(nx), np.zeros(nx)
        self.a, self.v = np.zeros(self.n), np.zeros(self.n)  # of the last evaluation, all DOFs
        self.last: tuple | None = None  # (u, f_int, strain energy) of the last evaluation

    def motion(self, u) -> None:
        """a(u) and v(u) (all DOFs) into ``self.a``, ``self.v``."""
        a, v, free = self.a, self.v, self.free
        a[free] = self.c_m * (u[free] - self.u_tilde)
        a[self.fixed] = self.a_fixed
        v[free] = self.v_tilde + self.gh * a[free]
        v[self.fixed] = self.v_fixed

    def damping(self, v) -> np.ndarray | None:
        """C v (all DOFs), or None without damping."""
        return None if self.C is None else self.C @ v

    def _balance(self, u, f, w):
        self.last = (u.copy(), f, w)
        self.motion(u)
        g = self.M @ self.a
        g += self.opa * f
        cv = self.damping(self.v)
        if cv is not None:
            g += self.opa * cv
        return g, w

    def force(self, u) -> tuple:
        return self._balance(u, *self.model.force(u))

    def force_and_tangent(self, u) -> tuple:
        return self._balance(u, *self.model.force_and_tangent(u))

    def internal_force(self, u) -> tuple:
        """``(f_int, strain energy)`` at u: from the last evaluation if it was at u."""
        if self.last is not None and np.array_equal(self.last[0], u):
            return self.last[1], self.last[2]
        return self.model.force(u)

    def tangent_free(self) -> sp.csc_matrix:
        cp, ri = self.model._free_pattern
        data = self.opa * self.model.data
        data += self._mc
        return sp.csc_matrix((data[self.model._src], ri, cp), shape=(len(self.free),) * 2)

    def tangent_full(self) -> sp.csc_matrix:
        return self.opa * self.model.tangent_full()
