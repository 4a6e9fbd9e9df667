"""The same scene gives the same bits whatever BLAS kernels or numpy SIMD paths the CPU picks.

A colliding run amplifies round-off: a result that depends on the machine's last bits (OpenBLAS
picks FMA or non-FMA kernels by CPU, numpy picks SIMD loops by CPU) ends up different in its
visible digits, and the committed results could only be reproduced on the machine kind that
made them. So nothing in a run may depend on them: the contact LCPs and the Delassus operator
are Rust with sums in index order (``vfrs_core::contact::lcp``, ``vfrs_core::linalg::compliance``), dense
products in Python are numpy elementwise operations and pairwise sums (``vfrs.linalg.dot``,
``combine_columns``), the mesh generators use the C library's functions (``vfrs.meshes.base.libm``).

Each scene runs in a fresh process (OpenBLAS and numpy read these settings at import) under
OpenBLAS's Haswell kernels (fused multiply-adds) and its Sandybridge ones (none), and with
numpy's X86_V3 (AVX2) loops disabled; every history array must be bit for bit the same.
(The x86-64-v4 (AVX-512) paths cannot be forced on a machine without them; the Rust kernels
choose at most AVX2 + FMA, faer included, whose AVX-512 matrix products the factorization
does not take: see docs/performance.md, "Reproducibility across machines".)
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

SCRIPT = r"""
import hashlib, json, sys
import numpy as np
import vfrs
from vfrs.scene import read_toml

def m5(method, detection, end, **extra):
    d = read_toml("examples/m5_collision.toml")
    for b in d["bodies"]:
        b["mesh"]["resolution"] = "coarse"
    d["time"]["end"] = end
    d["contact"] = {"method": method, "detection": detection, **extra}
    d["output"] = {"every": 1000, "reactions": True}
    return vfrs.Scene.from_dict(d, base_dir="examples")

def block(method, **extra):
    return vfrs.Scene.from_dict({
        "bodies": [{"name": "block", "mesh": {"builtin": "box", "size": [0.01, 0.01, 0.01], "cells": [3, 3, 4]},
                    "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0},
                    "fixed": [{"surface": "xmin", "components": ["x"]}, {"surface": "ymin", "components": ["y"]}],
                    "velocity": [0.0, 0.0, -0.05]}],
        "obstacles": [{"type": "plane", "point": [0, 0, -1e-4], "normal": [0.1, 0, 1]}],
        "contact": {"method": method, "detection": "bvh", "surface": "zmin", **extra},
        "time": {"mode": "dynamic", "step": 2e-4, "end": 0.01}})

def loud():
    d = read_toml("examples/m5_loud.toml")
    for b in d["bodies"]:
        b["mesh"]["resolution"] = "coarse"
    d["time"]["end"] = 3e-3
    return vfrs.Scene.from_dict(d, base_dir="examples")

scenes = {
    "m5 lagrange interface_mesh": lambda: m5("lagrange", "interface_mesh", 0.008),
    "m5 augmented_lagrange bvh": lambda: m5("augmented_lagrange", "bvh", 0.004, kappa=1e9),
    "m5 penalty interface_mesh": lambda: m5("penalty", "interface_mesh", 0.004, kappa=1e10),
    "block on a tilted plane, lagrange": lambda: block("lagrange"),
    "block on a tilted plane, augmented_lagrange": lambda: block("augmented_lagrange", kappa=1e9),
    "m5 penalty_volume interface_mesh": lambda: m5("penalty_volume", "interface_mesh", 0.004, kappa=1e10),
    "m5 finite strain (Newton), lagrange": loud,
}
out = {}
for name, make in scenes.items():
    h = hashlib.sha256()
    res = vfrs.run(make(), progress=False)
    for k in sorted(res.history):
        a = np.asarray(res.history[k])
        if a.dtype != object:
            h.update(k.encode())
            h.update(np.ascontiguousarray(a).tobytes())
    out[name] = h.hexdigest()
print(json.dumps(out))
"""

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
VARIANTS = {
    "OpenBLAS Haswell kernels": {"OPENBLAS_CORETYPE": "Haswell"},
    "OpenBLAS Sandybridge kernels": {"OPENBLAS_CORETYPE": "Sandybridge"},
    "numpy without its X86_V3 loops": {"OPENBLAS_CORETYPE": "Haswell", "NPY_DISABLE_CPU_FEATURES": "X86_V3"},
}


def _hashes(env_extra) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")}
    env.update(env_extra)
    env["PYTHONWARNINGS"] = "ignore"
    p = subprocess.run([sys.executable, "-c", SCRIPT], cwd=ROOT, env=env, capture_output=True, text=True,
                       timeout=900)
    assert p.returncode == 0, p.stderr[-3000:]
    return json.loads(p.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_histories_do_not_depend_on_blas_kernels_or_numpy_simd():
    runs = {name: _hashes(env) for name, env in VARIANTS.items()}
    first = next(iter(runs.values()))
    for name, hashes in runs.items():
        differ = [scene for scene in first if hashes[scene] != first[scene]]
        assert not differ, f"{name}: the histories of {differ} differ from {next(iter(runs))}'s"
