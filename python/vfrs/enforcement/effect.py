"""The ``[contact]`` effect: wires a detector, a method and a contact solver into the step,
and records.

Per step (in the ``correct`` hook, after the contact-free solve u0):

1. detect pairs at the current positions (the chosen detector between bodies, both
   directions; rigid planes too);
2. with the pairs' geometry frozen (xi, zeta, n), the gaps respond linearly to pair forces:
   the contact solver builds the round's reduced problem (g = g0 + W lam);
3. the method decides lam (penalty, Lagrange LCP, Uzawa augmentations, or nothing);
4. the force G^T lam is applied with one solve; detection is repeated at the new positions
   until the loaded pairs stop changing (at most ``max_detections`` times).

In a finite-strain (Newton) step the ``correct`` hook runs once per Newton iteration, on the
linearisation at the iterate (the compliance columns follow the refactored tangent); pairs it
loaded in one iteration start the next with their geometry frozen.

In dynamic runs the scheme (:mod:`vfrs.enforcement.scheme`, ``[contact] scheme``) says how
contact enters the time integration: ``mass_redistribution`` (the default) takes the mass off
the contact nodes before the integrator factors K_eff; ``stabilized`` projects the predictor
first, and a constraint method's reaction acts within its step only; ``plain`` is the
paper's. The effect knows each role only through its protocol: no branch here names a
method, a detector or a scheme.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass, field

import numpy as np

from ..checkpoint import restore_into, state_of
from ..effects import Effect, register_effect
from ..errors import ContactError, ConvergenceError, SceneError
from ..params import param, param_keys, params_to_dict, read_params
from .base import METHODS
from .detector import DETECTORS
from .figures import contact_figures
from .pairs import DetectedPairs
from .planes import PlaneDetector
from .surfaces import ContactSurfaces
from .outputs import ContactOutputs
from .record import ContactRecorder, ContactStep
from .scheme import DEFAULT_SCHEME, SCHEMES
from .solver import SOLVERS


@dataclass(frozen=True)
class ContactParams:
    """The keys of ``[contact]`` every method shares."""

    method: str = param(doc="contact method", choices=lambda: METHODS.choices())
    detection: str = param("bvh", doc="detector between bodies", choices=lambda: DETECTORS.choices())
    pairs: list | None = param(None, doc="body-name pairs that may touch (default: every pair of bodies)")
    surface: object = param("medial", doc="contact surface name, or a table body -> surface (default: the named "
                                          "surface if the mesh has it, else the whole boundary)")
    solver: str = param("compliance", doc="how the reduced problem is solved", choices=lambda: SOLVERS.choices())
    strict: bool = param(True, doc="raise ConvergenceError when a solve does not converge")
    scheme: str | None = param(None, doc=f"dynamic runs: how contact enters the time integration (default "
                               f"{DEFAULT_SCHEME!r}; 'stabilized': the contact-stabilized predictor; 'plain': the "
                               "paper's)", choices=lambda: SCHEMES.choices())
    stabilized: bool | None = param(None, doc="the old spelling of scheme: true = 'stabilized', false = 'plain'")
    max_iterations: int = param(100, doc="iterations of the LCP solver per solve", minimum=1)
    max_detections: int = param(8, doc="detection rounds per step", minimum=1)
    sensor_area: float = param(1e-6, doc="face area of the pressure sensor the record simulates (the largest pressure "
                               "averaged over such a disc: history contact_pressure_sensor)", unit="m^2", positive=True)
    column_memory: float = param(1024.0, doc="memory each contact compliance may keep in its columns over their "
                                 "bodies' DOFs; past it, steps loading new contact DOFs solve with the factor",
                                 unit="MiB", positive=True)
    column_precision: str | None = param(None, doc="precision of the stored compliance columns over the bodies' "
                                         "DOFs: 'double' (default) or 'single' (half the memory and twice the "
                                         "columns under column_memory; the whole field's update from the contact "
                                         "forces rounded to about 6e-8, the contact problem itself unchanged)",
                                         choices=("double", "single"))

    def __post_init__(self):
        if self.stabilized is not None:
            old = "stabilized" if self.stabilized else "plain"
            if self.scheme is not None and self.scheme != old:
                raise ValueError(f"stabilized = {str(self.stabilized).lower()} (scheme {old!r}) contradicts scheme = "
                                 f"{self.scheme!r}; give scheme only")
            object.__setattr__(self, "scheme", old)
            object.__setattr__(self, "stabilized", None)
        if self.scheme is None:
            object.__setattr__(self, "scheme", DEFAULT_SCHEME)
        p = self.pairs
        if p is not None and not (isinstance(p, list) and all(
                isinstance(q, list) and len(q) == 2 and all(isinstance(b, str) for b in q) for q in p)):
            raise ValueError(f"pairs: expected a list of [body, body] pairs, got {p!r}")
        s = self.surface
        if not (isinstance(s, str) or (isinstance(s, dict) and all(isinstance(v, str) for v in s.values()))):
            raise ValueError(f"surface: expected a surface name or a table body -> surface, got {s!r}")


@dataclass(frozen=True)
class ContactSettings:
    """The resolved ``[contact]`` section: the shared keys and the chosen method's, detector's
    and solver's own."""

    common: ContactParams
    method: object = field(default=None)
    detector: object = field(default=None)
    solver: object = field(default=None)

    def __getattr__(self, key):  # settings.kappa, settings.strict, ...
        for part in ("common", "method", "detector", "solver"):
            obj = object.__getattribute__(self, part)
            if obj is not None and key in getattr(obj, "__dataclass_fields__", {}):
                return getattr(obj, key)
        raise AttributeError(key)


def _foreign_key(key, chosen) -> str | None:
    """Which other method/detector/solver ``key`` belongs to, for the error message."""
    for kind, registry, name in (("method", METHODS, chosen["method"]), ("detection", DETECTORS, chosen["detection"]),
                                 ("solver", SOLVERS, chosen["solver"])):
        owners = [n for n, cls in registry.items() if n != name and key in param_keys(cls.Params)]
        if owners:
            mine = param_keys(registry[name].Params)
            return (f"{key!r} is a parameter of {kind} {', '.join(repr(o) for o in sorted(owners))}, not of "
                    f"{kind} = {name!r} (its own keys: {mine or 'none'})")
    return None


@register_effect
class ContactEffect(ContactOutputs, Effect):
    """``[contact]``: the shared keys (:class:`ContactParams`) and the chosen method's,
    detector's and solver's (``vfrs.enforcement.METHODS[name].Params`` etc.)."""

    name = "contact"

    @classmethod
    def resolve(cls, table) -> ContactSettings:
        common = read_params(ContactParams, table)
        method_cls, det_cls, sol_cls = METHODS[common.method], DETECTORS[common.detection], SOLVERS[common.solver]
        if method_cls.detections is not None and common.detection not in method_cls.detections:
            raise table.error(f"{common.method} needs detection = {' or '.join(repr(d) for d in method_cls.detections)}",
                              "method")
        missing = method_cls.uses - sol_cls.provides
        if missing:
            raise table.error(f"solver = {common.solver!r} cannot solve the {'/'.join(sorted(missing))} problems that "
                              f"method = {common.method!r} needs (it solves: {', '.join(sorted(sol_cls.provides))}); "
                              "use solver = \"compliance\"", "solver")
        settings = ContactSettings(common, read_params(method_cls.Params, table), read_params(det_cls.Params, table),
                                   read_params(sol_cls.Params, table))
        for key in table.data:
            if key not in table.read:
                why = _foreign_key(key, {"method": common.method, "detection": common.detection, "solver": common.solver})
                if why:
                    raise table.error(why, key)
        table.done()
        return settings

    @classmethod
    def to_dict(cls, settings) -> dict:
        out = params_to_dict(settings.common)
        for part in (settings.method, settings.detector, settings.solver):
            out.update(params_to_dict(part))
        return out

    @classmethod
    def figures(cls, run, figs) -> None:
        """``contact_force.png``, ``contact_pressure.png``, ``pressure_map.png`` (:mod:`vfrs.enforcement.figures`)."""
        contact_figures(run, figs)

    # -- setup ---------------------------------------------------------------------------
    def prepare(self, problem, dynamic: bool) -> list:
        """The contact surfaces, and the scheme's change of the problem (dynamic runs with a
        method that applies forces): mass_redistribution takes the contact nodes' mass off."""
        c = self.params.common
        self.surfaces = ContactSurfaces(problem, c.surface, c.pairs)
        self.method = METHODS[c.method](self.params.method)
        # The surfaces' contact stiffness scale, before the scheme changes the problem and
        # before any solve: a method derives what the scene left out from it (the run log says what).
        self.kappa_scale = self._kappa_scale(problem)
        lines = self.method.set_stiffness_scale(self.kappa_scale)
        self.scheme = SCHEMES[c.scheme]() if (dynamic and self.method.applies_forces) else None
        return lines + (self.scheme.prepare(problem, self.surfaces) if self.scheme is not None else [])

    def _solver(self, ctx):
        """The contact solver ([contact] solver), with its column budget: ``column_memory`` and,
        when set to "single", ``column_precision`` (passed only then, so a solver registered
        from outside with the older signature keeps working; one that cannot take it is named)."""
        c = self.params.common
        options = {"column_bytes": int(c.column_memory * 2**20), "prefetch": self.surfaces.nearby}
        if c.column_precision == "single":
            options["column_dtype"] = np.float32
            if "column_dtype" not in inspect.signature(SOLVERS[c.solver].__init__).parameters:
                raise SceneError(f"[contact] column_precision = \"single\": the contact solver {c.solver!r} does not "
                                 "take column_dtype (its stored columns' precision); remove column_precision or use "
                                 "solver = \"compliance\"")
        return SOLVERS[c.solver](self.params.solver, ctx, c.max_iterations, self.surfaces.dofs, **options)

    def setup(self, ctx) -> None:
        s = self.params
        c = s.common
        problem = ctx.problem
        if getattr(self, "surfaces", None) is None:  # prepare() was not called (a problem built by hand)
            self.prepare(problem, ctx.dynamic)
        self.problem = problem
        self.constants = ctx.constants
        between = DETECTORS[c.detection](s.detector, self.surfaces)
        self.detectors = [between]
        if problem.obstacles:
            self.detectors.append(PlaneDetector(problem.obstacles, self.surfaces, between.search))
        self.solver = self._solver(ctx) if self.method.applies_forces else None
        if self.scheme is not None:
            self.scheme.setup(self, ctx)
        # Whether a constraint's reaction acts within its step (the stabilized scheme: it must
        # not keep pushing the bodies apart in the next step while they separate) or stays in
        # the HHT-alpha recursion like any force. The recorded contact force is the momentum
        # contact gave each node in the step, over h: a transient force moves it by
        # gamma (1 + alpha) h f, a force in the recursion by h f, the scheme's own impulse
        # (the stabilized predictor's velocity projection) by itself.
        self.transient = self.scheme is not None and self.scheme.transient
        self.force_weight = ctx.constants.transient_weight if self.transient else 1.0
        warning = self.method.stiffness_scale_warning(self.kappa_scale) if self.kappa_scale else None
        if warning:
            import warnings

            from ..errors import VfrsWarning

            warnings.warn(warning, VfrsWarning, stacklevel=3)
        self.x_prev = problem.points.copy()  # the positions after the last correction
        self._x_start: np.ndarray | None = None  # the positions at the start of the step
        self._loaded: DetectedPairs | None = None  # the pairs the last correction loaded
        self.force_full = np.zeros(problem.n_dofs)  # the recorded contact force: the step's impulse / h
        self.balance_force = self.force_full  # the contact force in the step's balance at t_{n+1}
        self.stored_energy = 0.0  # what the pair forces store in the overlap at t_{n+1} (J)
        self.step_start: tuple = (self.balance_force, None, 0.0)
        self.outcome: ContactStep | None = None
        self.recorder = ContactRecorder(problem, self.surfaces, self.detectors,
                                        [n for n, _ in problem.probe_nodes()], c.sensor_area)

    def _kappa_scale(self, problem):
        """The surfaces' contact stiffness scale K_ii / a_i ~ E / h (Pa/m), or None."""
        nodes = self.surfaces.nodes
        a = self.surfaces.areas[nodes]
        diag = problem.K.diagonal().reshape(-1, 3)[nodes].mean(axis=1)
        ok = a > 0
        return float(np.median(diag[ok] / a[ok])) if ok.any() else None

    # -- detection -----------------------------------------------------------------------
    def detect(self, x) -> DetectedPairs:
        transform = self.surfaces.transform  # quadratic surfaces: detection on the transformed nodes
        at = transform.tilde(x) if transform else x
        parts = []
        for i, d in enumerate(self.detectors):
            found = d.detect(at)
            found.source = np.full(len(found), i, dtype=np.int64)
            if transform:
                found.x, found.transform = x, transform
            parts.append(found)
        return parts[0] if len(parts) == 1 else DetectedPairs.concatenate(parts, x)

    # -- the step ------------------------------------------------------------------------
    def predict(self, step) -> None:
        if self.scheme is not None and step.u_tilde is not None:
            self.scheme.predict(step)

    def correct(self, step) -> None:
        """Detection rounds (:class:`_Rounds`) until the loaded pairs stop changing, then the
        step's contact force, positions and stored energy, the scheme's turn and the record."""
        rounds = _Rounds(self, step)
        for detection in range(1, self.params.common.max_detections + 1):
            if rounds.run(detection):
                break
        # Re-detection that does not settle (pairs flickering at the rim of the contact zone)
        # is reported in the history ("contact_settled" = 0), not raised.
        x = rounds.final_positions()
        x_start, found, lam, G, f_applied = rounds.x_start, rounds.found, rounds.lam, rounds.G, rounds.f_applied
        if self.method.applies_forces:
            for d in self.detectors:
                d.after_step(x, x_start, step.t)
        self.x_prev = x.copy()
        self._loaded = found.select(lam > 0) if len(lam) else None
        self.balance_force = f_applied
        # The energy the pair forces store in the overlap they leave, 1/2 sum lam <-g>_+ (a
        # penalty's springs; zero for a constraint met exactly).
        if G is not None and lam.any():
            self.stored_energy = 0.5 * float(np.sum(lam * np.maximum(found.offset - G @ x.ravel(), 0.0)))
        else:
            self.stored_energy = 0.0
        self.force_full = self.force_weight * f_applied
        if self.scheme is not None:
            self.scheme.after_correct(self, step, x_start, x, found, lam, G)
        impulse = self.scheme.impulse if self.scheme is not None else None
        if impulse is not None:
            self.force_full = self.force_full + impulse / self.constants.h
        if self.method.applies_forces:
            step.implicit_by_effect[self.name] = self.force_full.copy()
        info, settled = rounds.info, rounds.settled
        self.outcome = ContactStep(found, lam, info, rounds.detection, settled,
                                   bool(settled and (info is None or info.converged)), G)

    def _start_step(self, step) -> np.ndarray:
        """The positions at the start of the step: in a finite-strain (Newton) step ``correct``
        runs once per iteration, every call from the same start. The detectors begin there."""
        if step.iteration == 0 or self._x_start is None:
            self._x_start = self.x_prev
            # what the step starts from: the contact force in the last balance, the pairs it
            # loaded, the energy stored in their overlap (the scheme's energy check)
            self.step_start = (self.balance_force, self._loaded, self.stored_energy)
        x_start = self._x_start
        for d in self.detectors:
            d.begin_step(x_start)
        return x_start

    def _check_movable(self, step, found, G, g0) -> None:
        """A penetrating pair whose every DOF is fixed cannot be pushed apart by any contact
        force (a Lagrange multiplier would grow without bound): the prescribed motions push
        fixed nodes into each other. Say so, naming the nodes, instead of solving."""
        deep = np.flatnonzero(g0 < 0)
        if not deep.size:
            return
        if getattr(self, "_free_mask", None) is None:
            mask = np.zeros(self.problem.n_dofs)
            mask[self.problem.free] = 1.0
            self._free_mask = mask
        rows = G[deep].tocsr()
        stuck = deep[np.abs(rows).multiply(self._free_mask[None, :]).sum(axis=1).A.ravel() == 0]
        if stuck.size:
            k = int(stuck[0])
            sl = int(found.pairs.slave[k])
            body = self.problem.body_of_node(sl)
            raise ContactError(
                f"step {self.constants.step_index(step.t)}, t = {step.t:.6g}: {stuck.size} contact pair(s) penetrate "
                f"with every DOF fixed (the first: node {sl - body.node_offset} of body {body.name!r} against "
                f"{'a plane' if found.pairs.triangle[k] < 0 else 'a fixed triangle'}, {-g0[k]:.3g} m deep): the "
                "prescribed displacements push fixed nodes into each other, and no contact force can separate them. "
                "Fix fewer nodes on the contact surfaces, or prescribe motions that keep the fixed parts apart")

    def _fail(self, step, found, lam, info):
        nodes = sorted(set(found.pairs.slave[lam > 0].tolist()))[:10]
        raise ConvergenceError(
            f"step {self.constants.step_index(step.t)}, t = {step.t:.6g}: {self.params.common.method} did not "
            f"converge: {info.message}; slave nodes involved {nodes}. {self.method.hint(info, self.kappa_scale)}"
        )

    # -- checkpoints ---------------------------------------------------------------------
    def state(self) -> dict:
        """What carries over between steps: the positions at the end of the last step, the
        contact force in its balance, the pairs it loaded and the energy stored in their
        overlap, each detector's, the contact solver's and the scheme's state (the compliance
        columns computed so far) and the recorder's running contact work."""
        return {"x_prev": self.x_prev.copy(), "detectors": [state_of(d) for d in self.detectors],
                "solver": state_of(self.solver), "scheme": state_of(self.scheme),
                "recorder": self.recorder.state(), "balance_force": self.balance_force.copy(),
                "loaded": _pairs_state(self._loaded), "stored_energy": self.stored_energy}

    def restore(self, state: dict) -> None:
        self.x_prev = state["x_prev"].copy()
        self.balance_force = state["balance_force"].copy()
        self._loaded = _pairs_restored(state["loaded"])
        self.stored_energy = state["stored_energy"]
        for d, s in zip(self.detectors, state["detectors"]):
            restore_into(d, s)
        restore_into(self.solver, state["solver"])
        restore_into(self.scheme, state["scheme"])
        self.recorder.restore(state["recorder"])

    # -- diagnostics ---------------------------------------------------------------------
    def record(self, state, history) -> None:
        outcome = self.outcome
        if outcome is None:
            # The initial row: detection only (no forces yet), so that a body starting inside
            # another shows its penetration from t = 0.
            found = self.detect(state.points)
            outcome = ContactStep(found, np.zeros(len(found)), None, 0, True, True)
        solves = sum(x.solves for x in (self.solver, self.scheme) if x is not None)
        extra = 0.0
        if self.scheme is not None:
            extra = self.scheme.work(state, self.outcome is not None)
        self.recorder.record(history, outcome, self.force_full, solves, self.balance_force, extra)
        if self.scheme is not None:
            self.scheme.record(history)

    def finish(self, result) -> None:
        """Writes the contact state at the peak force (:meth:`ContactRecorder.peak_map`) into
        ``contact_peak.npz`` of the run's output folder, when it has one and contact loaded
        a body (``vfrs plot`` draws the pressure map from it)."""
        peak = self.recorder.peak_map()
        if peak is None or not getattr(result, "out", None):
            return
        import os

        from ..output.atomic import atomic_npz
        from .record import PEAK_FILE

        atomic_npz(os.path.join(os.fspath(result.out), PEAK_FILE), peak)


class _Rounds:
    """What one ``ContactEffect.correct`` carries from detection round to detection round: the
    contact-free solution u0, what the pair forces move (du), the force applied so far, the
    last round's pairs, multipliers and constraint matrix, the loaded pairs carried on, and
    whether the rounds settled."""

    def __init__(self, effect, step):
        p = effect.problem
        self.effect, self.step, self.p = effect, step, p
        self.free = step.free
        # the contact-free solution, all DOFs
        self.u0 = step.dofmap.expand(step.u, p.fixed_values(step.t, static=step.u_tilde is None))
        self.du = np.zeros(p.n_dofs)  # what the pair forces move, all DOFs (surface DOFs while deferred)
        # With a compliance that sees every surface DOF, the detection rounds move the
        # surfaces by dense products and the final forces move the whole field by a product
        # with the loaded DOFs' columns (the solver's apply, else one solve at the end);
        # otherwise every round applies its forces with a solve.
        self.deferred = effect.solver is not None and effect.solver.observed is not None
        self.x_start = effect._start_step(step)
        self.f_applied = np.zeros(p.n_dofs)
        self.info = None
        self.loaded_prev: set | None = None
        self.carried: DetectedPairs | None = None
        # A later Newton iteration starts from the pairs the last one loaded, their geometry
        # frozen (as between detection rounds): its linearisation differs from the last
        # one's by the motion only, and a node on the edge of two master triangles cannot
        # flip between them with round-off and keep the iteration from converging.
        self.inherited = effect._loaded if step.iteration > 0 else None
        self.found, self.lam, self.G = DetectedPairs.empty(self.x_start), np.zeros(0), None
        self.settled = False
        self.x_free: np.ndarray | None = None  # the positions of the first round, before any pair force moved them
        self.moved = False  # whether a force was added to step.u
        self.detection = 0  # the rounds so far

    def positions(self) -> np.ndarray:
        return self.p.points + (self.u0 + self.du).reshape(-1, 3)

    def run(self, detection: int) -> bool:
        """Round ``detection``: detect at the current positions, solve and apply the forces.
        True when the rounds are over (no pair to load, or the loaded pairs did not change)."""
        self.detection = detection
        x = self.positions()
        if self.x_free is None:
            self.x_free = x
        self.G = None  # this round's constraint matrix, kept for the record
        self.found = self.effect.detect(x)
        if self.carried is not None:
            # By slave: a loaded slave keeps its master triangle, frozen, for the rest of
            # the step. By (slave, triangle), a node on the edge between two triangles that
            # round-off assigned to the other one in a later round came back as a second
            # pair, and a penalty then pushed that node with twice its force law.
            self.found = self.carried.merge(self.found, self.p.n_points, by_slave=True)
        elif self.inherited is not None:
            self.found = self.inherited.merge(self.found, self.p.n_points, by_slave=True)
        if not self.effect.method.applies_forces or len(self.found) == 0:
            self.release()
            return True
        self.solve_and_apply()
        return self.loaded_unchanged()

    def release(self) -> None:
        """No pair to load: take back any force applied in an earlier round."""
        self.lam = np.zeros(len(self.found))
        if self.f_applied.any() and not self.deferred:
            self.step.add_force(-self.f_applied, transient=self.effect.transient)
            self.moved = True
        self.f_applied[:] = 0.0
        self.du[:] = 0.0
        self.settled = True

    def solve_and_apply(self) -> None:
        """The round's reduced problem with the pairs' geometry frozen, the method's
        multipliers, and the force G^T lam applied (or its surface response, deferred)."""
        effect, step, found = self.effect, self.step, self.found
        G = found.constraint(self.p.n_points)
        self.G = G
        # Gaps of the contact-free solution with this geometry frozen.
        g0 = found.pairs.gap - G @ self.du
        effect._check_movable(step, found, G, g0)
        assert effect.solver is not None  # every method that applies forces has one
        lam, info = effect.method.solve(effect.solver.problem(G, g0, step), found)
        self.lam, self.info = lam, info
        if not info.converged and effect.params.common.strict:
            effect._fail(step, found, lam, info)
        f_new = G.T @ lam
        if self.deferred:
            self.du[:] = 0.0
            self.du[effect.solver.observed] = effect.solver.response(f_new)
        else:
            step.add_force(f_new - self.f_applied, transient=effect.transient)
            self.moved = True
            self.du[self.free] = step.u - self.u0[self.free]
        self.f_applied = f_new

    def loaded_unchanged(self) -> bool:
        """Carries the loaded pairs into the next round; True (settled) when they are the
        last round's."""
        found, lam = self.found, self.lam
        # Loaded pairs stay in the next round even if they no longer penetrate (the
        # interface mesh reports inverted tets only, and enforcement brings them to g = 0).
        self.carried = found.select(lam > 0)
        loaded = set(zip(found.pairs.slave[lam > 0].tolist(), found.pairs.triangle[lam > 0].tolist()))
        if loaded == self.loaded_prev:
            self.settled = True
            return True
        self.loaded_prev = loaded
        return False

    def final_positions(self) -> np.ndarray:
        """The deferred forces applied to the whole field, and the positions at the end of
        the rounds (also the last round's pairs' positions)."""
        step, p = self.step, self.p
        if self.deferred and self.f_applied.any():
            # The whole field from the loaded DOFs' compliance columns (no solve).
            assert self.effect.solver is not None  # deferred: a solver with observed DOFs
            step.add_force(self.f_applied, du_full=self.effect.solver.apply(self.f_applied),
                           transient=self.effect.transient)
            self.moved = True
        if self.moved or self.x_free is None:
            x = p.points + (self.u0 + step.dofmap.expand(step.u - self.u0[self.free])).reshape(-1, 3)
        else:  # no force was applied: the same numbers as the first round's positions
            x = self.x_free
        self.found.x = x
        return x


def _pairs_state(found: DetectedPairs | None) -> dict | None:
    """``found`` as arrays, for a checkpoint (its pairs' fields, weight, offset, x, source)."""
    if found is None:
        return None
    import dataclasses

    return {"pairs": {f.name: getattr(found.pairs, f.name) for f in dataclasses.fields(found.pairs)},
            "weight": found.weight, "offset": found.offset, "x": found.x, "source": found.source}


def _pairs_restored(state) -> DetectedPairs | None:
    """:func:`_pairs_state`'s inverse."""
    if state is None:
        return None
    from ..contact.geometry import ContactPairs

    return DetectedPairs(ContactPairs(**state["pairs"]), state["weight"], state["offset"], state["x"], state["source"])
