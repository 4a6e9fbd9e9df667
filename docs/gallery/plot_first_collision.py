"""
A first collision
=================

The collision job (the main job until issue 45), ``examples/m5_collision.toml`` (two M5
folds, ``vocal_fold`` tissue, a Bernoulli flow at 0.8 kPa, Lagrange contact), **shortened to stay fast**: the **coarse** mesh
instead of the medium one and **20 ms** of simulated time instead of 50 ms (about two seconds on
one core). The folds touch lightly at first and collide in earnest once the oscillation has
grown; the summary's window (the second half of the run) holds too few glottal cycles for its
periodic measures (f0, open quotient), which say ``n/a``.

The full run is ``vfrs run examples/m5_collision.toml -o out/m5_collision``; the tutorial
:doc:`/tutorials/first_collision` walks through it.
"""

from pathlib import Path

import matplotlib.pyplot as plt

import vfrs

# the repository's examples/ (sphinx-gallery runs this script in docs/gallery)
examples = next(p / "examples" for p in Path.cwd().resolve().parents if (p / "examples").is_dir())
scene = vfrs.Scene.load(examples / "m5_collision.toml")
print(scene.title)

# %%
# Shorten the run: the coarse mesh, 20 ms. Everything else is the collision job's scene, here as
# the resolved scene's dict (every default filled in).
data = scene.to_dict()
for body in data["bodies"]:
    body["mesh"]["resolution"] = "coarse"
data["time"]["end"] = 20e-3
scene = vfrs.Scene.from_dict(data, source="m5_collision.toml (coarse, 20 ms)")
print(f"{len(scene.bodies)} bodies, {scene.time.n_steps} steps of {scene.time.step * 1e6:g} us")

# %%
# Run it (no output folder: the result stays in memory) and print the summary that
# ``vfrs run`` prints.
result = vfrs.run(scene, progress=False)
print(result.summary())

# %%
# The glottal area and the contact force on the right fold, from the run's history.
h = result.history
t_ms = h["t"] * 1e3
fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(6.4, 5.2))
ax1.plot(t_ms, h["glottal_area"] * 1e6)
ax1.set_ylabel("glottal area (mm$^2$)")
ax2.plot(t_ms, h["contact_force.right"] * 1e3, color="C3")
ax2.set_ylabel("contact force, right (mN)")
ax2.set_xlabel("t (ms)")
fig.suptitle("M5 folds, coarse mesh, first 20 ms")
fig.tight_layout()
