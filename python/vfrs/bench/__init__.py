"""Benchmarks a user runs: what accuracy costs in time (``vfrs bench accuracy``)."""

from .accuracy import AccuracyReport, run_accuracy
from .pareto import pareto_front

__all__ = ["run_accuracy", "AccuracyReport", "pareto_front"]
