"""Time integration: HHT-alpha for dynamics, a load-stepped linear solver for statics."""

from .hht import HHTAlpha, hht_parameters
from .problem import Problem, build_problem
from .static import StaticSolver
from .step import StepContext

__all__ = ["HHTAlpha", "hht_parameters", "StaticSolver", "StepContext", "Problem", "build_problem"]
