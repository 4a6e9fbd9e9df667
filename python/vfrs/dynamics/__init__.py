"""Time integration: the integrators the march loop drives (HHT-alpha for dynamics, a
load-stepped linear solver for statics), the assembled problem, the state and the step
context effects see."""

from .hht import HHTAlpha, hht_parameters
from .integrators import INTEGRATORS, Integrator
from .problem import Problem, build_problem
from .state import State
from .static import StaticSolver
from .step import StepContext

__all__ = ["HHTAlpha", "hht_parameters", "StaticSolver", "StepContext", "Problem", "build_problem", "INTEGRATORS",
           "Integrator", "State"]
