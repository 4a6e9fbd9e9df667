"""What a run returns: times, per-step history, probes, field snapshots, effects and timings."""

from __future__ import annotations

import numpy as np


class Result:
    """The outcome of :func:`vfrs.run`.

    - ``t``: times of the stored steps (static runs: load factors), shape (n_steps,).
    - ``history``: dict of per-step arrays, first axis = step. Always ``t``; with
      ``output.energy``: ``kinetic_energy``, ``elastic_energy``, ``external_work``
      (work of the loads on the free DOFs, trapezoidal); with ``output.reactions``:
      ``reaction_force.<body>.<constraint>`` (n_steps, 3), the force the support exerts on the
      body (a DOF two constraints fix, on an edge they share, counts in the first one's: the
      constraints' reactions add up to the total); and whatever the effects record (``contact_force``, ``intersection_volume``, ...).
    - ``effects``: names of what ran (``elasticity``, ``inertia``, ``damping``, ``gravity``,
      ``surface_loads``, ``prescribed_displacement``, and the scene's effects such as ``flow``).
    - ``timings``: seconds per part: ``mesh``, ``assembly``, ``factorization``, ``step`` (the
      integrator's steps: right-hand side, solve, update), ``solve`` (the triangular solves
      alone, part of ``step``), ``loads``, each effect by name, ``record`` (history), ``output``,
      ``total``.
    - ``fields``: snapshots every ``output.every`` steps: ``{"t": (k,), "displacement": (k, n, 3), ...}``.
    - ``u``, ``v``: the final displacement and velocity, shape (n_nodes, 3), all bodies.
    - ``results``: what the run measured (:func:`vfrs.summary.summarize`: f0, open quotient,
      peak flow, first contact, peak force and contact pressure, ... with units), computed at
      the end of :func:`vfrs.run` and saved as ``summary.json`` with the output.
    """

    def __init__(self, scene, problem, history, effects, timings, fields, probes, u, v, out=None):
        self.scene = scene
        self.problem = problem
        self.history = history
        self.t = history["t"]
        self.effects = effects
        self.timings = timings
        self.fields = fields
        self._probes = probes  # node -> {"displacement": (n, 3), ...}
        self.u = u
        self.v = v
        self.out = out
        self.results = None  # a vfrs.summary.Summary, set by vfrs.run

    @property
    def points(self) -> np.ndarray:
        """Reference coordinates of all nodes (bodies in scene order)."""
        return self.problem.points

    def node(self, point) -> int:
        """The node nearest to ``point`` (reference configuration), over all bodies."""
        return self.problem.nearest_node(point)

    def probe(self, point) -> dict:
        """History of the node nearest to an initial position ``point``.

        Returns ``{"node", "body", "position", "distance" (m, from ``point`` to that node), "t",
        "displacement" (n, 3), "velocity" (n, 3), and "<effect>_force" (n, 3) for effects that
        apply forces}``; a point that is not finite or lies outside every body (farther than
        two element edges from the nearest node) is a SceneError. Every step if ``point``
        was declared in ``[output] probes`` (or resolves to the same node); otherwise from the
        field snapshots (every ``output.every`` steps, their ``t`` returned).
        """
        n, dist = self.problem.snap(point, "Result.probe(point)")
        part = self.problem.body_of_node(n)
        base = {"node": n, "body": part.name, "position": self.problem.points[n].copy(), "distance": dist}
        if n in self._probes:
            return {**base, "t": self.t.copy(), **{k: v.copy() for k, v in self._probes[n].items()}}
        out = {**base, "t": self.fields["t"].copy()}
        for k, v in self.fields.items():
            if k != "t":
                out[k] = v[:, n, :].copy()
        return out

    def body_of_node(self, node: int) -> str:
        """The name of the body that node ``node`` belongs to."""
        return self.problem.body_of_node(int(node)).name

    def first_probe(self) -> tuple | None:
        """(t, displacement (n, 3), position) of the first ``[output]`` probe when it was
        recorded every step, else None (what :func:`vfrs.summary.summarize` reads the
        amplitude from)."""
        if not self.scene.output.probes:
            return None
        p = self.probe(self.scene.output.probes[0])
        if len(p["t"]) != len(self.t):
            return None
        return np.asarray(p["t"]), np.asarray(p["displacement"]), p["position"]

    def displacement(self, body: str) -> np.ndarray:
        """Final displacement (n, 3) of one body's nodes."""
        for p in self.problem.bodies:
            if p.name == body:
                return self.u[p.nodes]
        raise KeyError(f"no body {body!r}; bodies: {[p.name for p in self.problem.bodies]}")

    def analyse(self, **options):
        """:func:`vfrs.summary.summarize` of this run, with other options (``start``,
        ``open_level``, ...) than the summary computed at the end of the run."""
        from .summary import summarize

        return summarize(self, **options)

    def summary(self, effects: bool = True) -> str:
        """What ran, (``results``) what it measured and, last, what it cost, as printed by
        ``vfrs run``. ``effects=False`` leaves out the list of effects (run.log has it from the
        start)."""
        sizes = self.problem.sizes()
        lines = [f"{len(self.t)} steps, {sizes['nodes']} nodes, {sizes['free_dofs']} free DOFs"]
        if effects:
            lines.append(f"effects: {', '.join(self.effects)}")
        if self.results is not None:
            lines.append(self.results.text())
        lines.append("timings: " + ", ".join(f"{k} {v:.3g} s" for k, v in self.timings.items()))
        return "\n".join(lines)

    def __repr__(self):
        return f"Result(steps={len(self.t)}, effects={self.effects})"
