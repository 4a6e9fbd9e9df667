"""Benchmarks a user runs: what accuracy costs in time (``vfrs bench accuracy``)."""

from .accuracy import AccuracyReport, recommend, run_accuracy, run_reference, run_row
from .pareto import pareto_front

__all__ = ["run_accuracy", "run_row", "run_reference", "recommend", "AccuracyReport", "pareto_front"]
