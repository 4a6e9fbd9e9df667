"""Shared pytest options: slow physics checks run only with ``--runslow``; the OpenBLAS
kernels the committed results were computed with.

A colliding run amplifies round-off, and OpenBLAS picks its kernels by CPU: the committed
results (examples/paper_results, benchmarks/results, the README's summary) were computed with
its SkylakeX (AVX-512) kernels, and an AMD EPYC, given the Haswell ones, moves them by up to
a few percent (docs/performance.md, "Reproducibility across versions"). On a CPU with AVX-512
the tests ask for the SkylakeX kernels, as the results were made (set before numpy loads
OpenBLAS). Without AVX-512 they run with what OpenBLAS picks, and the committed-results
tests may then fail by such amounts: that is the machine, not the code.
"""

import os

import pytest


def _has_avx512() -> bool:
    try:
        with open("/proc/cpuinfo") as f:
            return any(line.startswith("flags") and " avx512f" in line for line in f)
    except OSError:
        return False


if _has_avx512():  # replaces an inherited choice (a machine here exports OPENBLAS_CORETYPE=Haswell)
    os.environ["OPENBLAS_CORETYPE"] = "SkylakeX"


def pytest_addoption(parser):
    parser.addoption("--runslow", action="store_true", default=False, help="run tests marked slow")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--runslow"):
        return
    skip = pytest.mark.skip(reason="slow: run with --runslow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
