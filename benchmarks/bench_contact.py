"""Contact detection + projection on two facing ~10k-triangle surfaces, vs ipctk.

Two fold-like medial surfaces (y-z sheets, bulging towards the mid-plane x = 0, partly
interpenetrating, non-matching meshes) of about 10k triangles each. Timed, one run each
(plus the steady state of reused detectors):

- vfrs BvhEngine, both directions (each surface's nodes against the other's triangles,
  closest triangle within dhat): first call (builds the BVH) and later calls (refit, buffers
  reused);
- vfrs InterfaceMeshEngine: build once, then detect (inversion test + pairs of inverted tets);
- ipctk NormalCollisions.build(mesh, vertices, dhat) on the same surfaces (vertex-face,
  edge-edge, ... within dhat, default broad phase).

Run: python benchmarks/bench_contact.py  (writes benchmarks/results/bench_contact.json)
"""

from __future__ import annotations

import json
import os
import platform
import time

import numpy as np

import vfrs
from vfrs.contact import BvhEngine, InterfaceMeshEngine

L_Y, L_Z = 10e-3, 14e-3  # sheet size (m)
HALF_GAP = 0.05e-3
BULGE = 0.15e-3  # the middle bulges past the mid-plane by BULGE - HALF_GAP
DHAT = 0.1e-3


def sheet(ny, nz, side):
    """A sheet over [0, L_Y] x [0, L_Z]; side +1: the right fold (normal -x), -1: the left."""
    y, z = np.meshgrid(np.linspace(0, L_Y, ny + 1), np.linspace(0, L_Z, nz + 1), indexing="ij")
    bump = BULGE * np.sin(np.pi * y / L_Y) * np.sin(np.pi * z / L_Z)
    x = side * (HALF_GAP + BULGE / 3 - bump)
    pts = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    idx = np.arange((ny + 1) * (nz + 1)).reshape(ny + 1, nz + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    # counter-clockwise in (y, z) gives normal +x
    tri = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    if side > 0:
        tri = tri[:, [0, 2, 1]]  # right fold: normal -x
    return pts, tri


def timed(f, repeat=1):
    best = np.inf
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main():
    lp, lt = sheet(70, 70, -1)  # 9800 triangles
    rp, rt = sheet(69, 72, +1)  # 9936 triangles
    pts = np.concatenate([lp, rp])
    left, right = lt, rt + len(lp)
    res = {"n_triangles": [len(left), len(right)], "n_points": len(pts), "dhat": DHAT}

    # --- vfrs BVH detector, both directions
    d_rl = BvhEngine(left, slave_triangles=right, points=pts)
    d_lr = BvhEngine(right, slave_triangles=left, points=pts)
    t_first, n = timed(lambda: d_rl.count(pts, DHAT) + d_lr.count(pts, DHAT))
    t_again, n2 = timed(lambda: d_rl.count(pts, DHAT) + d_lr.count(pts, DHAT), repeat=5)
    moved = pts.copy()
    moved[len(lp):, 0] -= 0.02e-3
    t_moved, n3 = timed(lambda: d_rl.count(moved, DHAT) + d_lr.count(moved, DHAT))
    t_arrays, pairs = timed(lambda: (d_rl.detect(pts, DHAT), d_lr.detect(pts, DHAT)), repeat=5)
    res["vfrs_bvh"] = {
        "first_call_s": t_first,
        "steady_call_s": t_again,
        "after_motion_s": t_moved,
        "with_numpy_arrays_s": t_arrays,
        "pairs": n,
        "pairs_after_motion": n3,
        "penetrating": int(sum((p.gap < 0).sum() for p in pairs)),
    }

    # --- the same with a best-first narrow phase
    b_rl = BvhEngine(left, slave_triangles=right, points=pts, best_first=True)
    b_lr = BvhEngine(right, slave_triangles=left, points=pts, best_first=True)
    t_bf_first, nb = timed(lambda: b_rl.count(pts, DHAT) + b_lr.count(pts, DHAT))
    t_bf_again, _ = timed(lambda: b_rl.count(pts, DHAT) + b_lr.count(pts, DHAT), repeat=5)
    res["vfrs_bvh_best_first"] = {"first_call_s": t_bf_first, "steady_call_s": t_bf_again, "pairs": nb}

    # --- vfrs interface mesh
    rest = pts.copy()
    rest[: len(lp), 0] = -HALF_GAP  # flat, non-overlapping reference to build from
    rest[len(lp) :, 0] = HALF_GAP
    t_build, im = timed(lambda: InterfaceMeshEngine(rest, right, left, search_distance=5 * DHAT))
    t_detect, ip = timed(lambda: im.detect(pts), repeat=5)
    t_vol, vol = timed(lambda: im.intersection_volume(pts), repeat=5)
    res["vfrs_interface_mesh"] = {
        "build_s": t_build,
        "detect_s": t_detect,
        "inversion_s": t_vol,
        "n_tets": len(im.tets),
        "inverted": len(ip),
        "intersection_volume_m3": vol,
    }

    # --- ipctk
    try:
        import ipctk
    except ImportError:
        res["ipctk"] = None
    else:
        faces = np.asfortranarray(np.concatenate([left, right]).astype(np.int32))
        edges = np.asfortranarray(ipctk.edges(faces))
        V = np.asfortranarray(pts)
        mesh = ipctk.CollisionMesh(V, edges, faces)

        def build():
            c = ipctk.NormalCollisions()
            c.build(mesh, V, DHAT)
            return c

        t_ipc, c = timed(build)
        t_ipc_best, _ = timed(build, repeat=3)
        res["ipctk"] = {
            "version": getattr(ipctk, "__version__", "?"),
            "build_s": t_ipc,
            "build_best_of_3_s": t_ipc_best,
            "collisions": len(c),
        }
        res["ratio_ipctk_over_vfrs_first_call"] = t_ipc / t_first
        res["ratio_ipctk_over_vfrs_steady"] = t_ipc_best / t_again
    res["machine"] = {"cpus": os.cpu_count(), "python": platform.python_version()}
    return res


if __name__ == "__main__":
    out = main()
    print(json.dumps(out, indent=2))
    path = os.path.join(os.path.dirname(__file__), "results", "bench_contact.json")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        json.dump(out, f, indent=2)
