"""Effects: the optional parts of a run (glottal flow, contact, ...) that the march loop calls.

A scene section (``[flow]``, ``[contact]``) names an effect; the run builds and calls an effect
only when its section is present, so a scene without flow runs no flow code and a scene
without contact runs no detection. Effects are classes registered under the section name,
with their scene keys as a typed ``Params`` dataclass (:mod:`vfrs.params`)::

    from dataclasses import dataclass
    from vfrs.effects import Effect, register_effect
    from vfrs.params import param

    @register_effect
    class Wind(Effect):
        name = "wind"                      # the scene section, and the key in res.timings

        @dataclass(frozen=True)
        class Params:
            pressure: float = param(doc="pressure", unit="Pa", nonnegative=True)

        def setup(self, ctx): ...          # once, after assembly and factorization
        def forces(self, state): ...       # explicit nodal forces at t_{n+1}, from the state at t_n

The default :meth:`Effect.resolve` reads ``Params`` from the section (typos are reported with
the nearest key) and :meth:`Effect.to_dict` writes it back into the resolved scene. Effects
live in the modules the :data:`EFFECTS` registry loads (``vfrs.flow.effect``,
``vfrs.enforcement.effect``, ``vfrs.acoustics.effect``); register one of your own with ``register_effect`` before
loading a scene that names it.

Before the integrator is built, ``prepare(problem, dynamic)`` may change the assembled problem
(the contact scheme ``mass_redistribution`` replaces its mass); ``setup(ctx)`` runs after.

The loop calls, per step and only for the hooks an effect overrides:

1. ``forces(state)`` -> full-length force vector (or None): added to the external forces at
   the end of the step (explicit coupling, e.g. Bernoulli pressure on the current geometry).
2. ``predict(step)``: may modify the predictor ``step.u_tilde`` / ``step.v_tilde`` in place before
   the solve (e.g. the contact-stabilized Newmark projection of Deuflhard, Krause & Ertel).
3. ``correct(step)``: after the solve; may add implicit forces with ``step.add_force(f)`` (which
   solves with the factor of the effective matrix and updates ``step.u``), compute responses
   without applying them with ``step.response(f)``, or use ``step.solve(rhs_free)`` directly.
   The forces added here enter the balance at t_{n+1} and, weighted by -alpha, the next step
   (unless added as ``transient``). In a finite-strain (Newton) run the hook is called once
   per Newton iteration (``step.iteration`` 0, 1, ...), each time on the linearised solution
   without implicit forces and with the factor of the current tangent; it adds its forces in
   full each time (the step forgets the last iteration's), and what the last call added is
   the step's. A hook that keeps state between steps must update it only as if each call
   could be the last of the step.
4. ``record(state, history)``: per-step diagnostics (``history`` is a dict of lists).
5. ``finish(result)``: once at the end.

What an effect gives the output is its own too: ``output_fields(fields)`` adds fields to the
VTU snapshots, the class's ``measures(run)`` and ``notes(run, sections)`` its sections of the
summary (``summary.json``), ``cycle_values(run)`` its values per cycle that the periodicity
test compares, ``summary_names(scene)`` the names its sections can hold (known before a run:
:func:`vfrs.summary.summary_names`), ``files`` what it writes into the output folder and
``cycle_signal`` the history key the summary's cycles are found in, ``figures(run, figs)`` its
figures for ``vfrs plot``. A measure that belongs to
no effect is a :class:`vfrs.summary.Measure` registered with ``register_measure``.

Checkpoints (:mod:`vfrs.checkpoint`): ``state() -> dict`` returns what the effect carries from
one step to the next (copies; picklable), ``restore(dict)`` takes it back after ``setup`` in a
resumed run. The default keeps nothing: an effect whose hooks depend only on the current
state (like the explicit flow) need not override them.

What the hooks see. ``ctx`` (in ``setup``): a :class:`SetupContext` with the ``problem``
(``bodies``, ``points``, ``n_dofs``, ``dofmap``, ``K``/``M`` and their free blocks,
``obstacles``, ``scene``) and the integrator's ``constants``, ``factor``, ``force_scale``,
``dynamic``, ... (see :mod:`vfrs.dynamics.integrators`). ``state`` (in ``forces``/``record``): ``t``,
``t_next``, ``step``, ``u``, ``v``, ``a`` over all DOFs, ``points`` (current coordinates).
``step``: see :class:`vfrs.dynamics.StepContext`.

The forces an effect returns from ``forces`` or adds with ``step.add_force`` are its own: the
run keeps them per effect, so probes record ``<name>_force`` and field output writes it;
``res.timings[name]`` is the time spent in all of its hooks.

A scene naming a section with no registered effect fails at load with a :class:`SceneError`
saying the effect is not available.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np

from .errors import SceneError, VfrsError
from .params import params_to_dict, read_params
from .registry import Registry

#: Sections an effect may claim, with what they do (for messages about effects not yet available).
KNOWN_SECTIONS = {
    "flow": "the glottal flow (quasi-steady Bernoulli pressure on the medial surfaces)",
    "contact": "contact detection and enforcement between bodies and obstacles",
    "acoustics": "the vocal tract driven by the glottal flow, its radiated sound and its pressure on the flow",
}

EFFECTS = Registry("effect", modules=("vfrs.flow.effect", "vfrs.enforcement.effect", "vfrs.acoustics.effect"))
register_effect = EFFECTS.register


def unregister_effect(name: str):
    """Removes an effect from the registry (tests use this to restore the registry)."""
    EFFECTS.unregister(name)


def effect_class(name: str, where: str = "", source: str = "<dict>"):
    """The registered effect for a scene section, or a :class:`SceneError` saying it is missing."""
    if name in EFFECTS:
        return EFFECTS[name]
    what = KNOWN_SECTIONS.get(name, "an effect")
    raise SceneError(
        f"{source}: {where or name}: the {name!r} effect ({what}) is not available yet in this "
        f"version of vfrs (registered effects: {sorted(EFFECTS) or 'none'}); remove the [{name}] section"
    )


@dataclass
class SetupContext:
    """What an effect's ``setup`` gets: the assembled ``problem`` and what it needs of the
    integrator that will march it, never the integrator itself: ``constants`` (the time
    discretisation's, :class:`vfrs.dynamics.HHTConstants` or ``StaticConstants``: alpha, the
    step size ``h``, beta, gamma, ``force_scale``, ``predictor_scale``, ``transient_weight``,
    ``step_index(t)``), ``factor`` (of the effective matrix: K_eff in dynamics, K in
    statics), ``effective_matrix``, and ``mass`` (dynamics: M^-1, factored on first use).
    ``ports``: the typed links one effect offers the others (:meth:`offer`, :meth:`port`: the
    [flow] effect's :class:`vfrs.flow.GlottisPort`, which the [acoustics] effect connects its
    tract to); the run sets up an effect after those it :attr:`Effect.needs`."""

    problem: Any
    constants: Any = None
    factor: Any = None
    effective_matrix: Any = None
    mass: Any = None
    ports: dict = field(default_factory=dict)

    def offer(self, port) -> None:
        """Makes ``port`` (one effect's typed link to the others) what :meth:`port` gives for its type."""
        self.ports[type(port)] = port

    def port(self, kind: type[P], who: str) -> P:
        """The port of type ``kind`` an effect set up before offered, or VfrsError saying that
        ``who`` (e.g. "[acoustics]") needs it."""
        if kind not in self.ports:
            raise VfrsError(f"{who} needs the {kind.__name__} of another effect ({kind.__module__}), and no effect "
                            "of this run offers one")
        return self.ports[kind]

    @property
    def force_scale(self) -> float:
        return self.constants.force_scale

    @property
    def dynamic(self) -> bool:
        return self.constants.dynamic

    @property
    def mass_factor(self):
        """The factor of the mass matrix (free DOFs), made on first use and shared with the integrator."""
        return self.mass.factor


P = TypeVar("P")


class Effect:
    """Base class of an effect. Override only the hooks you need; the loop skips the others."""

    #: The scene section this effect reads, and its key in ``res.effects`` / ``res.timings``.
    name: str = ""
    #: The section's keys (a dataclass built with :func:`vfrs.params.param`), or None: any
    #: table, kept as a dict.
    Params: type | None = None
    #: The sections this effect needs in the same scene, {section: why} (a scene without them
    #: is a SceneError when it is read, :meth:`check`); they are set up before it.
    needs: dict = {}

    def __init__(self, params):
        self.params = params

    @property
    def config(self):
        """The effect's parameters (alias of ``params``)."""
        return self.params

    @classmethod
    def resolve(cls, table):
        """Validates the section (a :class:`vfrs.params.table.Table`) into ``Params``."""
        if cls.Params is None:
            return dict(table.data)
        params = read_params(cls.Params, table)
        table.done()
        return params

    @classmethod
    def check(cls, params, effects: dict, error) -> None:
        """When the scene is read: checks this effect's resolved ``params`` against the scene's
        ``effects`` ({section: params}); ``error(message, key)`` makes the SceneError to raise.
        Default: the sections it :attr:`needs` are there."""
        for need, why in cls.needs.items():
            if need not in effects:
                raise error(f"needs a [{need}] section ({why}); add [{need}] or remove [{cls.name}]", cls.name)

    @classmethod
    def to_dict(cls, params) -> dict:
        """The resolved section for ``Scene.to_dict`` (TOML data)."""
        if dataclasses.is_dataclass(params):
            return params_to_dict(params)
        return dict(params)

    def prepare(self, problem, dynamic: bool) -> list:
        """Once, after assembly and before the integrator is built and factors its effective
        matrix: may change the ``problem`` (e.g. its mass, the contact scheme
        ``mass_redistribution``). ``dynamic``: the run has inertia. Returns lines for the run
        log (what it changed)."""
        return []

    def setup(self, ctx: SetupContext) -> None:
        """Once, after assembly and the factorization of the integrator's effective matrix."""

    def forces(self, state):
        """Explicit nodal forces (length ``problem.n_dofs``) for the end of the step, or None."""
        return None

    def predict(self, step) -> None:
        """May modify ``step.u_tilde`` / ``step.v_tilde`` (free DOFs) before the solve."""

    def correct(self, step) -> None:
        """After the solve: may add implicit forces through ``step.add_force``."""

    def record(self, state, history: dict) -> None:
        """Appends per-step diagnostics to ``history`` (a dict of lists)."""

    def finish(self, result) -> None:
        """Once, after the last step."""

    # -- what the effect gives the output (asked by vfrs.history, vfrs.output, vfrs.summary,
    # vfrs.plot and vfrs.studies.sweep; none of them imports an effect's module) ---------------------

    #: Files the effect writes into the output folder (in ``finish``): listed in the manifest,
    #: and replaced by ``overwrite`` like vfrs's own.
    files: tuple = ()
    #: The history key of a periodic signal whose cycles the summary's per-cycle measures are
    #: over (the [flow] effect's ``glottal_area``), or None.
    cycle_signal: str | None = None
    #: The history key of the work the effect does on the bodies (J, from the start), which the
    #: energy balance of ``vfrs plot`` counts (the [contact] effect's ``contact_work``), or None.
    work_key: str | None = None

    def output_fields(self, fields: dict) -> dict:
        """Fields (name -> (n_nodes, 3) or (n_nodes,)) this effect adds to a field snapshot's
        VTU files, from the snapshot's ``fields`` (e.g. the [contact] effect's
        ``contact_pressure`` from its ``contact_force``)."""
        return {}

    @classmethod
    def measures(cls, run) -> dict:
        """The summary sections this effect measures, {section: {name: Quantity}}, from
        ``run`` (a :class:`vfrs.summary.RunView`: the history, scene, window, cycles, ...);
        empty when the history has none of its records (a bare history is asked too)."""
        return {}

    @classmethod
    def notes(cls, run, sections: dict) -> list:
        """Lines the summary prints under ``note:`` about this effect's ``sections``."""
        return []

    @classmethod
    def cycle_values(cls, run) -> dict:
        """This effect's values per cycle of ``run.cycles`` (a :class:`vfrs.summary.RunView`),
        {name: (what, values oldest first)}, whose repetition tells whether the run has reached
        a periodic state (:meth:`vfrs.summary.RunView.periodicity`: the summary's
        ``window.periodic``, and ``[output] until = "limit_cycle"``); empty when it has none."""
        return {}

    @classmethod
    def summary_names(cls, scene) -> dict:
        """{section: [name, ...]}: what :meth:`measures` gives a run of ``scene`` that has what
        each needs (glottal cycles, contact), known without running it
        (:func:`vfrs.summary.summary_names`: what a sweep's derived columns may read)."""
        return {}

    @classmethod
    def figures(cls, run, figs) -> None:
        """Draws this effect's figures of ``run`` (a :class:`vfrs.summary.SummarizedRun`: its
        ``history``, ``scene``, ``summary``, ``out``, ...) with ``figs`` (a
        :class:`vfrs.figures.Figures`: ``plt``, the run's ``title`` and time axis, ``save(fig,
        name)``, ``skip(what, why)``). ``vfrs plot`` (:mod:`vfrs.plot`) asks every registered
        effect, whether the run has its section or not, so that each says which of its figures
        the run lacks and why. Default: none."""

    def state(self) -> dict:
        """What the effect carries from one step to the next, for a checkpoint (default: nothing)."""
        return {}

    def restore(self, state: dict) -> None:
        """Back to a checkpoint's :meth:`state`, after :meth:`setup` (default: nothing to do)."""

    @classmethod
    def overrides(cls, hook: str) -> bool:
        """Whether this class implements ``hook`` (the loop calls only overridden hooks)."""
        return getattr(cls, hook) is not getattr(Effect, hook)


def check_effects(effects: dict, error) -> None:
    """Each effect of a scene's ``effects`` ({section: params}) checked against the others
    (:meth:`Effect.check`: e.g. the sections it needs); ``error(message, key)`` makes the
    :class:`SceneError` raised."""
    for name, params in effects.items():
        EFFECTS[name].check(params, effects, error)


def setup_order(effects) -> list:
    """``effects`` (instances) in the order the run sets them up: each after the ones it
    :attr:`Effect.needs` (which offer it their ports), otherwise as given."""
    pending, order = list(effects), []
    while pending:
        names = {e.name for e in pending}
        ready = next((e for e in pending if not (set(e.needs) & (names - {e.name}))), pending[0])
        order.append(ready)
        pending.remove(ready)
    return order


def zeros_like_dofs(problem) -> np.ndarray:
    """A zero force vector over all DOFs of ``problem``."""
    return np.zeros(problem.n_dofs)
