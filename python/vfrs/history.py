"""The per-step record of a run: history, probes and field snapshots.

What is recorded each step: ``t``; with ``output.energy`` the kinetic and elastic energy, the
work of the loads (``external_work``) and, in damped dynamic runs, the energy the damping
dissipated (``damping_work``, >= 0); with ``output.reactions`` the support forces of
each constraint group; the displacement, velocity and every effect's force at the probe
nodes; and whatever the effects' ``record`` hooks add. Field snapshots (``output.fields`` and
the effects' forces) every ``output.every`` steps.
"""

from __future__ import annotations

import time
from collections import defaultdict

import numpy as np

from .linalg import Product, for_products
from .scene import FIELDS


class Dot:
    """x . y without BLAS, into a scratch buffer owned by one run (runs in threads stay apart).

    OpenBLAS's threaded ddot competes with the solver's threads for the cores (docs/performance.md,
    "Measurements behind the code's choices")."""

    def __init__(self):
        self.buffers = {}

    def __call__(self, x, y) -> float:
        buf = self.buffers.get(len(x))
        if buf is None:
            buf = self.buffers[len(x)] = np.empty(len(x))
        np.multiply(x, y, out=buf)
        return float(buf.sum())


def as_arrays(lists: dict) -> dict:
    """Per-step lists as arrays: float where they stack, else object arrays of arrays (ragged
    records, e.g. lists of pairs)."""
    history = {}
    for k, v in lists.items():
        try:
            history[k] = np.asarray(v, dtype=float)
        except (ValueError, TypeError):  # ragged per-step records (e.g. lists of pairs)
            arr = np.empty(len(v), dtype=object)
            arr[:] = [np.asarray(x) for x in v]
            history[k] = arr
    return history


class Recorder:
    """Per-step history, probes and field snapshots of one run."""

    def __init__(self, scene, problem, effects):
        self.scene, self.problem, self.effects = scene, problem, effects
        self.out = scene.output
        self.history = defaultdict(list)
        self.record_hooks = [(e.name, e.record) for e in effects if type(e).overrides("record")]
        self.field_hooks = [e.output_fields for e in effects if type(e).overrides("output_fields")]
        self.probe_nodes = sorted({n for n, _ in problem.probe_nodes()})
        self.probe_dofs = {n: np.arange(3 * n, 3 * n + 3) for n in self.probe_nodes}
        self.probes = {n: defaultdict(list) for n in self.probe_nodes}
        self.snapshots = defaultdict(list)
        if self.out.reactions:
            fixed = problem.fixed
            # The fixed rows, node-blocked in Rust where they are (the same numbers as scipy's).
            self.K_rows = Product(problem.K[fixed])
            self.M_rows = Product(for_products(problem.M[fixed]))
            self.C_rows = None if problem.C is None else problem.C[fixed]
        self.work = 0.0
        self.damping_work = 0.0  # energy the damping dissipated so far (J)
        self._damping_state: tuple | None = None  # (u, v, K u, M v or C v) of the last record
        self.dot = Dot()
        self._M = None  # the mass for the kinetic energy's product (made on first use)
        self._K = None  # the stiffness for the elastic energy's (made on first use)

    def record(self, state, effect_forces, F_full, clock, dynamic=True):
        t0 = time.perf_counter()
        p, h = self.problem, self.history
        h["t"].append(state.t)
        u, v, a = state.u, state.v, state.a
        Ku = None  # K u over all DOFs, when the energy needs it (its fixed rows serve the reactions)
        if self.out.energy:
            elastic = state.elastic_energy
            if elastic is None and self._K is None:
                self._K = Product(p.K)  # node-blocked in Rust: the same numbers as scipy's K @ u
            Ku = self._K @ u if elastic is None else None
            if dynamic and self._M is None:
                self._M = Product(for_products(p.M))  # M without its stored zeros: the same numbers, fewer reads
            Mv = self._M @ v if dynamic else None
            h["kinetic_energy"].append(0.5 * self.dot(v, Mv) if dynamic else 0.0)
            h["elastic_energy"].append(0.5 * self.dot(u, Ku) if elastic is None else elastic)
            h["external_work"].append(self.work)
            if dynamic and p.damped:
                self._damping(u, v, Ku, Mv, state.velocity_jump)
                h["damping_work"].append(self.damping_work)
        if self.out.reactions and p.groups:
            if state.internal_force is not None:
                f_int = state.internal_force[p.fixed]
            else:  # K[fixed] @ u row by row is (K @ u)[fixed]: the same numbers
                f_int = self.K_rows @ u if Ku is None else Ku[p.fixed]
            r = f_int - F_full[p.fixed]
            if dynamic:
                r += self.M_rows @ a
                if p.damped:
                    if self.C_rows is not None:
                        r += self.C_rows @ v
                    else:
                        a0, a1 = p.rayleigh
                        if a0:
                            r += a0 * (self.M_rows @ v)
                        if a1:
                            r += a1 * (self.K_rows @ v)
            for g in p.groups:
                # M a + C v + K u = F + R on the fixed DOFs: R is the support's force on the body,
                # each DOF's in the first group that names it (g.own: the groups add up to the total).
                h[f"reaction_force.{g.body}.{g.name}"].append(
                    np.bincount(g.components[g.own], r[g.positions[g.own]], minlength=3))
        for key, value in state.records.items():  # what a nonlinear integrator measured (Newton iterations)
            h[key].append(value)
        for n, dofs in self.probe_dofs.items():
            rec = self.probes[n]
            rec["displacement"].append(u[dofs].copy())
            rec["velocity"].append(v[dofs].copy())
            for name, f in effect_forces.items():
                rec[f"{name}_force"].append(f[dofs].copy() if f is not None else np.zeros(3))
        clock.add("record", t0)
        for name, hook in self.record_hooks:
            t0 = time.perf_counter()
            hook(state, h)
            clock.add(name, t0)

    def _damping(self, u, v, Ku, Mv, jump=None) -> None:
        """Adds the step's damping dissipation, (u1 - u0) . C (v0 + v1) / 2 (the trapezoidal
        rule's, which HHT-alpha with alpha = 0 applies exactly), to ``damping_work``. With
        Rayleigh damping from the K u and M v the energies already formed (K symmetric:
        du . K (v0 + v1) = (v0 + v1) . (K u1 - K u0)); else one product with C. The
        velocities are those the balances saw: less a ``jump`` added after the step."""
        p = self.problem
        last = self._damping_state
        if jump is not None:
            v = v - jump
            if Mv is not None:
                Mv = Mv - self._M @ jump
        if p.rayleigh is not None and Ku is not None:
            a0, a1 = p.rayleigh
            cur = (u.copy(), v.copy(), Ku, Mv)
            if last is not None:
                u0, v0, Ku0, Mv0 = last
                du = u - u0
                w = 0.0
                if a1:
                    w += a1 * (self.dot(v0, Ku) - self.dot(v0, Ku0) + self.dot(v, Ku) - self.dot(v, Ku0))
                if a0:
                    w += a0 * (self.dot(du, Mv0) + self.dot(du, Mv))
                self.damping_work += 0.5 * w
        else:
            cur = (u.copy(), None, None, p.damping_times(v))
            if last is not None:
                self.damping_work += 0.5 * self.dot(u - last[0], last[3] + cur[3])
        self._damping_state = cur

    def snapshot(self, step, state, effect_forces, writer, clock, force=False):
        if not (force or step % self.out.every == 0):
            return
        t0 = time.perf_counter()
        n = self.problem.n_points
        fields = {}
        for name in self.out.fields:
            fields[name] = getattr(state, FIELDS[name]).reshape(n, 3).copy()
        for name, f in effect_forces.items():
            fields[f"{name}_force"] = np.zeros((n, 3)) if f is None else f.reshape(n, 3).copy()
        self.snapshots["t"].append(state.t)
        for k, v in fields.items():
            self.snapshots[k].append(v)
        if writer:  # the VTU files get what the effects add (e.g. contact_pressure); Result.fields not
            extra = {k: v for hook in self.field_hooks for k, v in hook(fields).items()}
            writer.write_fields(step, state.t, {**fields, **extra} if extra else fields)
        clock.add("output", t0)

    def state(self) -> dict:
        """History, probes and field snapshots so far, and the work of the loads (for a
        checkpoint). The per-step lists are :class:`~vfrs.checkpoint.Appended`: a checkpoint
        writes only what was recorded since the previous one."""
        from .checkpoint import Appended

        return {"history": {k: Appended(v) for k, v in self.history.items()},
                "probes": {n: {k: Appended(v) for k, v in r.items()} for n, r in self.probes.items()},
                "snapshots": {k: Appended(v) for k, v in self.snapshots.items()}, "work": self.work,
                "damping_work": self.damping_work, "damping_state": self._damping_state}

    def restore(self, state: dict) -> None:
        from .checkpoint import items_of

        def lists(d):
            return defaultdict(list, {k: list(items_of(v)) for k, v in d.items()})  # keeps the keys' order

        self.history = lists(state["history"])
        self.probes = {n: lists(state["probes"].get(n, {})) for n in self.probe_nodes}
        self.snapshots = lists(state["snapshots"])
        self.work = state["work"]
        self.damping_work = state.get("damping_work", 0.0)
        ds = state.get("damping_state")
        self._damping_state = None if ds is None else tuple(ds)

    @property
    def n_recorded(self) -> int:
        return len(self.history.get("t", ()))

    def rows(self, start: int = 0) -> dict:
        """The history from row ``start`` on, as arrays (see :meth:`finish`)."""
        return as_arrays({k: v[start:] for k, v in self.history.items()})

    def probe_points(self) -> list:
        """(index, point, node, distance) of each ``[output] probes`` point: the node it snapped
        to (nearest, reference configuration) and how far that node is."""
        return [(i, np.asarray(p, dtype=float), n, d)
                for i, (p, (n, d)) in enumerate(zip(self.out.probes, self.problem.probe_nodes()))]

    def finish(self):
        history = as_arrays(self.history)
        probes = {n: {k: np.asarray(v) for k, v in rec.items()} for n, rec in self.probes.items()}
        fields = {}
        for k, v in self.snapshots.items():
            if k == "t":
                fields[k] = np.asarray(v, dtype=float)
            else:
                # effect forces may appear after the first snapshot: pad with zeros
                fields[k] = np.asarray(v)
        return history, fields, probes
