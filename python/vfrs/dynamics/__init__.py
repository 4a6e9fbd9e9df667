"""Time integration: the integrators the march loop drives (HHT-alpha for dynamics, a
load-stepped linear solver for statics, and their Newton siblings for finite strain), the
constants of the time discretisation effects receive, the assembled problem, the state and
the step context effects see."""

from .hht import DEFAULT_ALPHA, HHTAlpha, HHTConstants, StaticConstants, hht_parameters
from .integrators import INTEGRATORS, Integrator, integrator_for
from .problem import Problem, build_problem
from .state import State
from .static import StaticSolver
from .step import StepContext

__all__ = ["DEFAULT_ALPHA", "HHTAlpha", "HHTConstants", "StaticConstants", "hht_parameters", "StaticSolver",
           "StepContext", "Problem", "build_problem", "INTEGRATORS", "Integrator", "integrator_for", "State"]
