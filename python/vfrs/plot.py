"""``vfrs plot OUT``: the standard figures of a run, from its output folder.

Writes PNGs into ``OUT/plots/`` (or ``dest``), each only when the run has what it shows, and
says for each figure it did not draw why (:func:`draw_run`). Each registered effect draws its
own (:meth:`vfrs.effects.Effect.figures`: the glottal flow's, contact's, the voice's, in their
effects' ``figures`` modules); the figures of any run are drawn here:

- ``probes.png`` ([output] probes): the displacement of each probe node vs time;
- ``energy.png`` ([output] energy): the energy balance in J, mJ, uJ or nJ (whichever puts it
  between 1 and 1000): the work of the loads (input work) beside kinetic + elastic +
  dissipated by damping + taken by each effect that does work (contact's), each its change
  since the first record, and below the remainder input work - (their sum)
  (:func:`energy_balance`);
- ``reactions.png`` ([output] reactions): each support's force on its body vs time.

Titles are folded to the figure's width (:func:`vfrs.figures.wrapped`) and the legends of long
series stand outside the axes, so that no text leaves the canvas and no legend covers a curve.

From Python: ``vfrs.plot.plot_run("out/m5_collision")`` returns the paths written;
``draw_run`` returns (paths written, [(figure, why it was not drawn)]).
"""

from __future__ import annotations

import os

import numpy as np

from .output.reader import read_npz
from .effects import EFFECTS
from .errors import VfrsError
from .figures import STYLES, Figures, figure_legend, require_matplotlib, wrapped

__all__ = ["draw_run", "energy_balance", "energy_unit", "load_run", "plot_run", "require_matplotlib"]


def load_run(out):
    """The run in the output folder ``out`` with its summary (:func:`vfrs.summary.load`), or VfrsError, one
    line saying what to do: no history.npz (no run there, or one stopped before it wrote its
    history: :func:`vfrs.output.reader.no_history`), or a file that cannot be read (truncated, not
    a zip, not JSON: :func:`vfrs.output.reader.damaged`)."""
    from .summary import load

    return load(os.fspath(out))  # reads every array once: a damaged file is one line, not a traceback


def plot_run(out, dest=None) -> list:
    """Draws the standard figures of the run in the output folder ``out`` into ``dest``
    (default ``out/plots``); returns the paths written."""
    return draw_run(out, dest)[0]



def draw_run(out, dest=None) -> tuple:
    """Draws every standard figure the run in ``out`` has the data for into ``dest`` (default
    ``out/plots``): returns (paths written, [(figure, why it was not drawn)])."""
    plt = require_matplotlib()
    run = load_run(out)
    h = run.history
    t = np.asarray(h["t"])
    dest = os.path.join(run.out, "plots") if dest is None else os.fspath(dest)
    os.makedirs(dest, exist_ok=True)
    title = run.scene.title or os.path.basename(os.path.abspath(run.out))
    figs = Figures(plt, dest, title, t, run.scene.time.mode == "static")
    x, time_label, static = figs.x, figs.time_label, figs.static

    for name in EFFECTS:  # each effect's own figures (and why the run has none of them)
        EFFECTS[name].figures(run, figs)

    _probes(figs, run, x, time_label, title, static)
    _energy(figs, run, x, time_label, title)
    _reactions(figs, run, x, time_label, title)
    return figs.written, figs.skipped


def _probes(figs, run, x, time_label, title, static) -> None:
    path = os.path.join(run.out, "probes.npz")
    if not run.scene.output.probes:
        figs.skip("probe displacements", "the scene has no [output] probes")
        return
    if not os.path.exists(path):
        figs.skip("probe displacements", f"{path} is missing")
        return
    try:
        z = read_npz(path)
    except VfrsError as exc:
        figs.skip("probe displacements", str(exc))
        return
    ids = sorted({int(k.split(".")[0].split("_")[1]) for k in z if k.startswith("probe_") and k.endswith(".displacement")})
    if not ids:
        figs.skip("probe displacements", f"{path} holds no displacement")
        return
    tp = np.asarray(z["t"], dtype=float)
    xp = tp if static else tp * 1e3
    plt = figs.plt
    fig, axes = plt.subplots(len(ids), 1, figsize=(8, 2.2 * len(ids) + 1.2), sharex=True, squeeze=False,
                             layout="constrained")
    for ax, i in zip(axes[:, 0], ids):
        d = np.asarray(z[f"probe_{i}.displacement"], dtype=float)
        for c, name in enumerate("xyz"):
            ax.plot(xp[:len(d)], d[:, c] * 1e3, label=f"u_{name}", color=f"C{c}", **STYLES[c])
        pos = np.asarray(z.get(f"probe_{i}.position", np.full(3, np.nan)), dtype=float) * 1e3
        body = str(z[f"probe_{i}.body"]) if f"probe_{i}.body" in z else "?"
        ax.set_ylabel("displacement (mm)")
        ax.set_title(f"probe {i}: node of {body} at ({pos[0]:.3g}, {pos[1]:.3g}, {pos[2]:.3g}) mm", fontsize=9)
    axes[-1, 0].set_xlabel(time_label)
    figure_legend(fig, axes[:, 0])
    fig.suptitle(wrapped(f"{title}\ndisplacement of the probe nodes", 7), fontsize=9)
    figs.save(fig, "probes.png")


#: The history's energy keys and their labels, in the order drawn (then the effects' work,
#: :func:`effect_works`).
ENERGIES = (("kinetic_energy", "kinetic"), ("elastic_energy", "elastic"), ("external_work", "work of the loads"),
            ("damping_work", "dissipated by damping"))


def effect_works() -> dict:
    """{effect name: the history key of the work it does on the bodies} of the registered
    effects that record one (:attr:`vfrs.effects.Effect.work_key`: the [contact] effect's
    ``contact_work``)."""
    return {name: EFFECTS[name].work_key for name in EFFECTS if EFFECTS[name].work_key}


def energy_unit(largest: float) -> tuple:
    """(factor, unit) that puts an energy of size ``largest`` (J) between 1 and 1000: J, mJ, uJ, nJ."""
    for factor, unit in ((1.0, "J"), (1e3, "mJ"), (1e6, "uJ"), (1e9, "nJ")):
        if abs(largest) * factor >= 1.0:
            return factor, unit
    return 1e9, "nJ"


def energy_balance(h) -> dict | None:
    """The terms of the energy balance of a history with ``external_work``, each its change
    since the first record (J per step): "input work" (the loads'), "kinetic", "elastic",
    "dissipated" (by damping, when recorded), per effect that records its work on the bodies
    (:func:`effect_works`) its name (the energy it took, minus that work: "contact", minus
    ``contact_work``) and "remainder", input
    work - (the sum of the others): what the record does not name (round-off with HHT alpha =
    0, tests/test_energy_record.py; with alpha < 0 the integrator's numerical dissipation).
    None without the work of the loads or the energies."""
    if not all(k in h for k in ("external_work", "kinetic_energy", "elastic_energy")):
        return None
    keys = {"input work": ("external_work", 1.0), "kinetic": ("kinetic_energy", 1.0),
            "elastic": ("elastic_energy", 1.0), "dissipated": ("damping_work", 1.0),
            **{name: (key, -1.0) for name, key in effect_works().items()}}
    terms = {}
    for name, (k, sign) in keys.items():
        if k in h:
            v = np.asarray(h[k], dtype=float)
            terms[name] = sign * (v - v[0])
    terms["remainder"] = terms["input work"] - sum(v for k, v in terms.items() if k != "input work")
    return terms


def _energy(figs, run, x, time_label, title) -> None:
    h = run.history
    works = tuple((key, f"work of {name}") for name, key in effect_works().items())
    keys = [(k, label) for k, label in ENERGIES + works if k in h]
    if not keys:
        figs.skip("energies", "the history has none ([output] energy = false)")
        return
    terms = energy_balance(h)
    if terms is None:  # no balance to draw: the energies there are
        terms = {label: np.asarray(h[k], dtype=float) for k, label in keys}
    factor, unit = energy_unit(max(float(np.abs(v).max(initial=0.0)) for v in terms.values()))
    plt = figs.plt
    balance = "remainder" in terms
    fig, axes = plt.subplots(2 if balance else 1, 1, figsize=(8, 6.4 if balance else 4.6), sharex=True, squeeze=False,
                             layout="constrained", height_ratios=[2, 1] if balance else None)
    ax = axes[0, 0]
    parts = [k for k in terms if k not in ("input work", "remainder")]
    if balance:
        ax.plot(x, terms["input work"] * factor, color="k", lw=2.4, label="input work (the loads')")
        ax.plot(x, sum(terms[k] for k in parts) * factor, color="0.6", lw=1.0, ls=(0, (4, 2)),
                label=" + ".join(parts))
    for i, k in enumerate(parts):
        label = {"kinetic": "kinetic", "elastic": "elastic",
                 "dissipated": "dissipated by damping"}.get(k, f"taken by {k} (- its work)") if balance else k
        ax.plot(x, terms[k] * factor, label=label, color=f"C{i}", **STYLES[i % len(STYLES)])
    ax.set_ylabel(f"energy ({unit})")
    head = (f"energy balance: input work = {' + '.join(parts)} (changes since the first record)"
            if balance else "energies and work")
    fig.suptitle(wrapped(f"{title}\n{head}", 7.5), fontsize=9)
    if balance:
        _remainder_panel(axes[1, 0], run, x, terms["remainder"], factor, unit, parts)
    axes[-1, 0].set_xlabel(time_label)
    figure_legend(fig, axes[:, 0], "bottom", ncol=2)
    figs.save(fig, "energy.png")


def _remainder_panel(ax, run, x, remainder, factor, unit, parts) -> None:
    """The energy balance's remainder, labelled with what it is."""
    alpha = float(getattr(run.scene.time, "alpha", 0.0) or 0.0)
    what = (f"HHT alpha = {alpha:g}: the integrator's numerical dissipation" if alpha < 0 and
            run.scene.time.mode != "static" else "round-off when the record closes")
    ax.axhline(0.0, color="0.7", lw=0.6)
    ax.plot(x, remainder * factor, color="k", lw=1.2, label=f"remainder ({what})")
    ax.set_ylabel(f"remainder ({unit})")
    ax.set_title(f"input work - ({' + '.join(parts)})", fontsize=9)


def _reactions(figs, run, x, time_label, title) -> None:
    h = run.history
    keys = [k for k in h if k.startswith("reaction_force.")]
    if not keys:
        why = ("[output] reactions = false" if not run.scene.output.reactions
               else "the scene fixes no DOF, so there is no support force")
        figs.skip("reactions", why)
        return
    plt = figs.plt
    fig, axes = plt.subplots(len(keys), 1, figsize=(8, 2.2 * len(keys) + 1.2), sharex=True, squeeze=False,
                             layout="constrained")
    for ax, k in zip(axes[:, 0], keys):
        R = np.asarray(h[k], dtype=float)
        for c, name in enumerate("xyz"):
            ax.plot(x, R[:, c] * 1e3, label=f"R_{name}", color=f"C{c}", **STYLES[c])
        ax.set_ylabel("force (mN)")
        _, body, group = k.split(".", 2)
        ax.set_title(f"support {group!r} on {body}", fontsize=9)
    axes[-1, 0].set_xlabel(time_label)
    figure_legend(fig, axes[:, 0])
    fig.suptitle(wrapped(f"{title}\nthe supports' forces on the bodies (reactions)", 7), fontsize=9)
    figs.save(fig, "reactions.png")

