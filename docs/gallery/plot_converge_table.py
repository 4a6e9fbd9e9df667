"""
How close is the collision job: its converge study
==================================================

**Reads committed results; runs nothing.** ``vfrs converge examples/m5_collision.toml``
ran the collision job (the main job until issue 45; medium mesh, 50 ms) on the coarse,
medium and fine meshes at the steps h, h/2 and h/4 (nine runs; their wall times are in the
table below) and wrote ``examples/converge_results/m5_collision/``. This page reads its ``summary.csv`` (one row
per run) and ``converge.md`` (each number with its estimated error); :doc:`/converge` says
how the errors are estimated and how to read them.
"""

import csv
from pathlib import Path

import matplotlib.pyplot as plt


# the repository's examples/ (sphinx-gallery runs this script in docs/gallery)
examples = next(p / "examples" for p in Path.cwd().resolve().parents if (p / "examples").is_dir())
study = examples / "converge_results" / "m5_collision"
with open(study / "summary.csv", newline="") as fh:
    rows = list(csv.DictReader(fh))

# %%
# One row per run: the peak contact force and the peak pressure on a 1 mm² sensor.
meshes = ["coarse", "medium", "fine"]
steps = ["h", "h/2", "h/4"]
key_force, key_sensor = "contact.peak_force.right [N]", "contact.peak_sensor_pressure [Pa]"
table = {(r["mesh"], r["step"]): r for r in rows}
print(f"{'mesh':<8} {'step':<5} {'peak force (mN)':>16} {'sensor (kPa)':>13} {'wall (s)':>9}")
for m in meshes:
    for s in steps:
        r = table.get((m, s))
        if r is not None:
            print(f"{m:<8} {s:<5} {float(r[key_force]) * 1e3:16.2f} {float(r[key_sensor]) / 1e3:13.3f} "
                  f"{float(r['wall_time [s]']):9.1f}")

# %%
# The study's verdict on each number, as ``vfrs converge`` printed it (the first lines).
text = (study / "converge.md").read_text().split("```text", 1)[1].split("```", 1)[0]
print("\n".join(text.strip().splitlines()[:6]))

# %%
# The peak contact force against the step, one line per mesh.
fig, ax = plt.subplots(figsize=(6.4, 3.8))
for m in meshes:
    pts = [(k, float(table[(m, s)][key_force]) * 1e3) for k, s in enumerate(steps) if (m, s) in table]
    if pts:
        ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=f"{m} mesh")
ax.set_xticks(range(len(steps)), steps)
ax.set_xlabel("time step (h = 50 us)")
ax.set_ylabel("peak contact force, right (mN)")
ax.legend()
fig.tight_layout()
