"""The dynamic-contact-scheme protocol and its registry (``[contact] scheme``).

A scheme says how contact enters the time integration of a dynamic run; the pair law
(:mod:`~vfrs.enforcement.base`), the detector and the contact solver are the same under every
scheme. One module per scheme in ``vfrs/enforcement/schemes/``:

- ``mass_redistribution`` (the default): the contact-surface nodes carry no mass, so contact
  never stops a node's inertia within one step; the force history converges as h -> 0;
- ``stabilized``: the contact-stabilized predictor (Deuflhard, Krause & Ertel 2008) with the
  usual mass; a constraint's reaction acts within its step;
- ``plain``: the paper's: the usual mass, contact forces at t_{n+1} in the HHT recursion.

A scheme may change the problem before the integrator factors its effective matrix
(:meth:`ContactScheme.prepare`: the mass), may change the predictor before each step's solve
(:meth:`ContactScheme.predict`), and says whether a constraint's reaction stays in the
HHT-alpha recursion or acts within its step (``transient``). Static runs use none of this.
"""

from __future__ import annotations

from ..registry import Registry
from .base import NoParams

SCHEMES = Registry("contact scheme", packages=("vfrs.enforcement.schemes",))
register_scheme = SCHEMES.register

#: The scheme of a dynamic run whose ``[contact]`` names none.
DEFAULT_SCHEME = "mass_redistribution"


class ContactScheme:
    """Base class: ``name`` is the scene's ``[contact] scheme``.

    ``transient``: in this scheme a constraint method's reaction acts within its step only
    (:meth:`vfrs.dynamics.StepContext.add_force`); else every contact force stays in the
    HHT-alpha recursion. ``impulse``: a contact impulse the scheme itself applied this step
    (all DOFs, N s), which the recorded contact force includes, or None.
    """

    name = ""
    Params: type = NoParams
    transient = False
    impulse = None

    def __init__(self, params=None):
        self.params = params

    def prepare(self, problem, surfaces) -> list:
        """Once, after assembly and before the integrator is built (dynamic runs only): may
        change the problem (its mass). Returns lines for the run log."""
        return []

    def setup(self, effect, ctx) -> None:
        """Once, after the integrator is built (dynamic runs with a method that applies
        forces): ``effect`` is the :class:`~vfrs.enforcement.effect.ContactEffect`."""

    def predict(self, step) -> None:
        """Before the step's solve: may change ``step.u_tilde`` / ``step.v_tilde``."""

    def after_correct(self, effect, step, x_start, x_end, found, lam, G) -> None:
        """After the step's contact correction (the effect's ``correct``): ``x_start`` and
        ``x_end`` the positions at the step's ends, ``found``, ``lam`` and ``G`` the last
        round's pairs, forces and constraint matrix (G None without pairs). May add an impulse
        at the end of the step (``step.set_velocity_jump``) and set :attr:`impulse`."""

    def work(self, state, stepped: bool) -> float:
        """After each record (``stepped``: a step was taken; False at the initial row): the
        energy the scheme's own changes of the step gave the bodies (J; ``state`` at the end
        of the step), which the contact work adds; 0 for schemes that change nothing."""
        return 0.0

    def record(self, history: dict) -> None:
        """Appends the scheme's own diagnostics to the step's history (default: none)."""

    @property
    def solves(self) -> int:
        return 0

    @property
    def nbytes(self) -> int:
        return 0

    def state(self) -> dict:
        return {}

    def restore(self, state: dict) -> None:
        """Back to a checkpoint's :meth:`state`."""
