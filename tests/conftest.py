"""Shared pytest options: slow physics checks run only with ``--runslow``.

The committed results (examples/paper_results, benchmarks/results, the README's summary) are
reproduced by the tests on any x86-64 CPU with AVX2 and FMA: nothing in a run takes its bits
from BLAS kernels or numpy's CPU-dispatched loops (tests/test_reproducible.py; docs/performance.md,
"Reproducibility across machines").
"""

import pytest


def pytest_addoption(parser):
    parser.addoption("--runslow", action="store_true", default=False, help="run tests marked slow")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--runslow"):
        return
    skip = pytest.mark.skip(reason="slow: run with --runslow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
