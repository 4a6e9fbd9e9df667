"""
Contact methods compared on a tiny problem
==========================================

The first collisions of the M5 folds (**coarse mesh, 20 ms** instead of the collision job's medium
mesh and 50 ms: about ten seconds for all four methods on one core) with each contact method of ``[contact] method``: Lagrange multipliers
(the gaps closed exactly), penalty at two stiffnesses (the folds overlap by about the force
over ``kappa``) and augmented Lagrange (penalty steps repeated until the overlap is below
``gap_tol``). The table gives what each costs (wall time of the contact work) and how far
the folds overlap; :doc:`/contact` says why, and :doc:`/performance` what it costs on the
medium and fine meshes.
"""

import time
from pathlib import Path

import matplotlib.pyplot as plt

import vfrs

# the repository's examples/ (sphinx-gallery runs this script in docs/gallery)
examples = next(p / "examples" for p in Path.cwd().resolve().parents if (p / "examples").is_dir())
base = vfrs.Scene.load(examples / "m5_collision.toml").to_dict()  # the resolved scene, as a dict
for body in base["bodies"]:
    body["mesh"]["resolution"] = "coarse"
base["time"]["end"] = 20e-3

methods = {
    "lagrange": {"method": "lagrange", "detection": "interface_mesh"},
    "penalty, kappa 1e8 Pa/m": {"method": "penalty", "kappa": 1e8, "detection": "bvh"},
    "penalty, kappa 1e10 Pa/m": {"method": "penalty", "kappa": 1e10, "detection": "bvh"},
    "augmented_lagrange": {"method": "augmented_lagrange", "detection": "bvh"},
}

# %%
# One run per method; only ``[contact]`` changes.
runs = {}
for label, contact in methods.items():
    data = {**base, "contact": {"pairs": [["right", "left"]], "surface": "medial", **contact}}
    scene = vfrs.Scene.from_dict(data, source=f"m5_collision.toml ({label})")
    start = time.perf_counter()
    runs[label] = (vfrs.run(scene, progress=False), time.perf_counter() - start)

print(f"{'method':<26} {'peak force (mN)':>16} {'max overlap (um)':>17} {'contact (s)':>12} {'run (s)':>8}")
for label, (res, wall) in runs.items():
    h = res.history
    print(f"{label:<26} {h['contact_force.right'].max() * 1e3:16.4f} {h['max_penetration'].max() * 1e6:17.4f} "
          f"{res.timings['contact']:12.3f} {wall:8.2f}")

# %%
# The contact force on the right fold through the hardest collision of the run.
fig, ax = plt.subplots(figsize=(6.4, 3.8))
for label, (res, _) in runs.items():
    ax.plot(res.history["t"] * 1e3, res.history["contact_force.right"] * 1e3, label=label)
ax.set_xlim(14.0, 20.0)
ax.set_xlabel("t (ms)")
ax.set_ylabel("contact force, right (mN)")
ax.legend(fontsize="small")
fig.tight_layout()
