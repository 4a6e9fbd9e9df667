"""Effects: the optional parts of a run (glottal flow, contact, ...) that the time loop calls.

A scene section (``[flow]``, ``[contact]``) names an effect; the run builds and calls an effect
only when its section is present, so a scene without flow runs no flow code and a scene
without contact runs no detection. Effects are classes registered under the section name::

    from vfrs.effects import Effect, register_effect

    @register_effect
    class Flow(Effect):
        name = "flow"                      # the scene section, and the key in res.timings

        @classmethod
        def resolve(cls, table):           # validate [flow], fill defaults (scene load time)
            ...
            return {"model": "bernoulli", "subglottal_pressure": 800.0}

        def setup(self, problem): ...      # once, after assembly and factorization
        def forces(self, state): ...       # explicit nodal forces at t_{n+1}, from the state at t_n

The loop calls, per step and only for the hooks an effect overrides:

1. ``forces(state)`` -> full-length force vector (or None): added to the external forces at
   the end of the step (explicit coupling, e.g. Bernoulli pressure on the current geometry).
2. ``predict(step)``: may modify the predictor ``step.u_tilde`` / ``step.v_tilde`` in place before
   the solve (e.g. the contact-stabilized Newmark projection of Deuflhard, Krause & Ertel).
3. ``correct(step)``: after the solve; may add implicit forces with ``step.add_force(f)`` (which
   solves with the factor of K_eff and updates ``step.u``), compute responses without applying
   them with ``step.response(f)``, or use ``step.solve(rhs_free)`` directly (a Delassus operator
   ``G K_eff^-1 G^T`` of the contact DOFs, for instance). The forces added here enter the HHT-alpha
   balance at t_{n+1} and, weighted by -alpha, the next step.
4. ``record(state, history)``: per-step diagnostics (``history`` is a dict of lists).
5. ``finish(result)``: once at the end.

What the hooks see. ``problem`` (in ``setup``): ``bodies`` (each with ``mesh``, ``node_offset``),
``points``, ``n_dofs``, ``dofmap``, ``K``/``M`` and their free blocks ``K_free``/``M_free``,
``obstacles``, ``scene``, ``factor`` (of K_eff; of K in statics), ``force_scale`` (1 + alpha;
1 in statics) and ``integrator`` (``h``, ``alpha``, ``beta``, ``gamma`` in dynamics). ``state``
(in ``forces``/``record``): ``t``, ``t_next``, ``step``, ``u``, ``v``, ``a`` over all DOFs,
``points`` (current coordinates). ``step``: see :class:`vfrs.dynamics.StepContext`.

The forces an effect returns from ``forces`` or adds with ``step.add_force`` are its own: the
run keeps them per effect, so probes record ``<name>_force`` and field output writes it;
``res.timings[name]`` is the time spent in all of its hooks.

A scene naming a section with no registered effect fails at load with a :class:`SceneError`
saying the effect is not available.
"""

from __future__ import annotations


import numpy as np

from .errors import SceneError

#: Sections an effect may claim, with what they do (for messages about effects not yet available).
KNOWN_SECTIONS = {
    "flow": "the glottal flow (quasi-steady Bernoulli pressure on the medial surfaces)",
    "contact": "contact detection and enforcement between bodies and obstacles",
}

EFFECTS: dict = {}


def register_effect(cls):
    """Class decorator: registers an :class:`Effect` subclass under ``cls.name`` (its section)."""
    if not getattr(cls, "name", ""):
        raise TypeError(f"{cls.__name__} needs a class attribute `name` (the scene section)")
    EFFECTS[cls.name] = cls
    return cls


def unregister_effect(name: str):
    """Removes an effect from the registry (tests use this to restore the registry)."""
    EFFECTS.pop(name, None)


def effect_class(name: str, where: str = "", source: str = "<dict>"):
    """The registered effect for a scene section, or a :class:`SceneError` saying it is missing."""
    if name in EFFECTS:
        return EFFECTS[name]
    what = KNOWN_SECTIONS.get(name, "an effect")
    raise SceneError(
        f"{source}: {where or name}: the {name!r} effect ({what}) is not available yet in this "
        f"version of vfrs (registered effects: {sorted(EFFECTS) or 'none'}); remove the [{name}] section"
    )


class Effect:
    """Base class of an effect. Override only the hooks you need; the loop skips the others."""

    #: The scene section this effect reads, and its key in ``res.effects`` / ``res.timings``.
    name: str = ""

    def __init__(self, config: dict):
        self.config = config

    @classmethod
    def resolve(cls, table) -> dict:
        """Validates the section (a :class:`vfrs.scene.reader.Table`), returns it with defaults.

        The default accepts any keys; real effects should read each key with ``table.number``
        etc. and call ``table.done()`` so typos are reported with a suggestion.
        """
        return dict(table.data)

    def setup(self, problem) -> None:
        """Once, after assembly and the factorization of K_eff (``problem.factor``)."""

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

    @classmethod
    def overrides(cls, hook: str) -> bool:
        """Whether this class implements ``hook`` (the loop calls only overridden hooks)."""
        return getattr(cls, hook) is not getattr(Effect, hook)


def zeros_like_dofs(problem) -> np.ndarray:
    """A zero force vector over all DOFs of ``problem``."""
    return np.zeros(problem.n_dofs)
