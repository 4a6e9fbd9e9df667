"""The problems of the accuracy-cost report, each with a closed form or a reference run.

A problem builds a scene for a method setting, a resolution level and a time step, and turns
the result into metrics with one primary ``error``:

- ``block``: a block pressed onto a rigid plane (static). Exact: F = E A d / H (uniform
  stress, which P1 elements reproduce), so only the contact method's error remains.
- ``bars``: two identical elastic bars colliding. Exact: the contact lasts 2 L / c and the
  energy is conserved; error = relative error of the contact duration.
- ``hertz``: a paraboloid pressed on a plane; error against the Hertz force.
- ``m5``: the M5 folds colliding under Bernoulli flow; error = relative error of the
  medio-lateral contact impulse of the first glottal closure (5 to 15 ms) against a reference
  run (Lagrange) on a finer mesh and with a smaller step than every row of the grid, so no
  setting is scored against itself. The reference's own error bar is how far it moves
  between its two finest cells (one mesh level coarser; twice the step).
- ``m5_finite``: the kinematics axis: the same folds with finite-strain tissue (neo-Hookean,
  the same small-strain E and nu), a few settings; scored like ``m5`` against a finite-strain
  Lagrange reference on a finer mesh with a smaller step, and set beside the linear rows of
  the same setting (what large deformation changes, what it costs per step).

Every problem says what its reference is (``reference_text``); the report prints it.

A problem is a class registered in :data:`PROBLEMS` with :func:`register_problem` (the CLI's
``--problem`` choices and the default set of each mode come from there). It declares
``name``, ``levels`` and ``steps`` per mode, ``modes`` (the modes whose default run includes
it), ``kappas`` (the penalty parameters its grid sweeps, Pa/m) and optionally
``extra_settings`` per mode (further ``(label, [contact] table)`` rows) or ``settings`` per
mode (its whole grid of ``(label, [contact] table)``), ``targets`` (the errors it recommends
a setting for; default 1 %), and implements ``scene(contact, level, step)``,
``reference_text(mode, reference)`` and ``measure(res, reference)``. A problem scored against
a reference run also implements ``reference_setting(mode)`` and its two sensitivity checks,
``reference_check_setting(mode)`` (one mesh level coarser) and
``reference_step_check_setting(mode)`` (twice the step), and names the scored metric in
``quantity``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: The problems of the report by name, in report order.
PROBLEMS: dict[str, Any] = {}  # name -> problem class


def register_problem(cls):
    """Class decorator: registers a problem under ``cls.name``."""
    if not getattr(cls, "name", ""):
        raise TypeError(f"{cls.__name__} needs a class attribute `name`")
    PROBLEMS[cls.name] = cls
    return cls


@register_problem
class Block:
    """Block on a rigid plane: 10 mm cube pressed 0.1 mm (static); exact force E A d / H, so
    only the contact method's error shows (penalty: the series spring E/kappa)."""

    name = "block"
    E, nu, H, W, d = 1e4, 0.3, 0.01, 0.01, 1e-4
    levels = {"quick": [(2, 2, 2), (3, 3, 3)], "full": [(2, 2, 2), (3, 3, 4), (4, 4, 6)]}
    steps = {"quick": [None], "full": [None]}
    modes = ("quick", "full")
    kappas = [1e6, 1e8, 1e10]
    detection = "bvh"

    def scene(self, contact, level, step):
        return {
            "title": "block on a rigid plane",
            "bodies": [{
                "name": "block",
                "mesh": {"builtin": "box", "size": [self.W, self.W, self.H], "cells": list(level)},
                "material": {"model": "isotropic", "E": self.E, "nu": self.nu, "rho": 1000.0},
                "fixed": [
                    {"surface": "zmax", "components": ["z"], "displacement": [0, 0, -self.d]},
                    {"surface": "xmin", "components": ["x"]},
                    {"surface": "ymin", "components": ["y"]},
                ],
            }],
            "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}],
            "contact": {**contact, "detection": "bvh", "surface": "zmin"},
            "time": {"mode": "static"},
            "output": {"energy": False, "reactions": False},
        }

    def reference_text(self, mode, reference=None):
        return ("Exact, no run: F = E A d / H (uniform stress, reproduced by P1 elements on every mesh), "
                "so the error is the contact method's alone.")

    def measure(self, res, reference=None):
        exact = self.E * self.W * self.W * self.d / self.H
        F = float(res.history["contact_force.block"][-1][2])
        return {"error": abs(F - exact) / exact, "force": F, "exact": exact,
                "max_penetration": float(res.history["max_penetration"][-1])}


@register_problem
class Hertz:
    """Hertz: a paraboloid (R = 5 W) pressed onto a rigid plane, static, displacement-controlled
    to a Hertz contact radius of 0.1 W; error = relative error of the total force against
    (4/3) E* sqrt(R) delta^(3/2). Dominated by the mesh at these sizes (P1 elements are too
    stiff): a compliant penalty can land closer to Hertz than Lagrange by cancelling that
    stiffness, which is luck, not accuracy. It shows what resolution costs next to what the
    contact method costs."""

    name = "hertz"
    E, nu, W = 1e4, 0.3, 0.01
    levels = {"quick": [8, 12], "full": [8, 12, 16]}
    steps = {"quick": [None], "full": [None]}
    modes = ("quick", "full")
    kappas = [1e7, 1e9, 1e11]

    @property
    def R(self):
        return 5 * self.W

    @property
    def delta(self):
        return (0.1 * self.W) ** 2 / self.R

    def scene(self, contact, level, step):
        return {
            "title": "Hertz",
            "bodies": [{
                "name": "ball",
                "mesh": {"builtin": "paraboloid_block", "width": self.W, "radius": self.R, "cells": int(level), "grading": 3.0},
                "material": {"model": "isotropic", "E": self.E, "nu": self.nu, "rho": 1000.0},
                "fixed": [
                    {"surface": "zmax", "components": ["z"], "displacement": [0, 0, -self.delta]},
                    {"surface": "xmin", "components": ["x"]},
                    {"surface": "ymin", "components": ["y"]},
                ],
            }],
            "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}],
            "contact": {**contact, "detection": "bvh", "surface": "zmin", "search_distance": 10 * self.delta},
            "time": {"mode": "static"},
            "output": {"energy": False, "reactions": False},
        }

    def reference_text(self, mode, reference=None):
        return ("Exact, no run: the Hertz force (4/3) E* sqrt(R) delta^(3/2) of a paraboloid on a rigid "
                "half-space; no contact method's run is the reference.")

    def measure(self, res, reference=None):
        F = 4.0 * float(res.history["contact_force.ball"][-1][2])  # four quarters
        E_star = self.E / (1 - self.nu**2)
        exact = 4.0 / 3.0 * E_star * np.sqrt(self.R) * self.delta**1.5
        return {"error": abs(F - exact) / exact, "force": F, "exact": exact,
                "max_penetration": float(res.history["max_penetration"][-1])}


@register_problem
class Bars:
    """Two bars colliding (L = 0.1 m, 10 to 40 elements, lumped mass, alpha = -0.1): error of
    the contact duration against 2 L / c, which a step-counted duration resolves to h / (2L/c)."""

    name = "bars"
    E, rho, L, v0, gap = 1e4, 1000.0, 0.1, 0.1, 1e-4
    levels = {"quick": [10, 20], "full": [10, 20, 40]}
    steps = {"quick": [1.0], "full": [1.0, 0.5]}  # Courant numbers: h = courant L / (c n)
    modes = ("quick", "full")
    kappas = [1e8, 1e10, 1e12]
    detection = "bvh"

    @property
    def c(self):
        return float(np.sqrt(self.E / self.rho))

    def scene(self, contact, level, courant):
        n = int(level)
        h = courant * self.L / self.c / n

        def bar(name, x0, v):
            return {
                "name": name,
                "mesh": {"builtin": "box", "size": [self.L, 0.01, 0.01], "cells": [n, 1, 1], "origin": [x0, 0, 0]},
                "material": {"model": "isotropic", "E": self.E, "nu": 0.0, "rho": self.rho},
                "mass": "lumped", "velocity": [v, 0, 0],
                "fixed": [{"surface": "ymin", "components": ["y"]}, {"surface": "zmin", "components": ["z"]}],
            }

        return {
            "title": "two bars colliding",
            "bodies": [bar("a", -self.L - self.gap / 2, self.v0), bar("b", self.gap / 2, 0.0)],
            "contact": {**contact, "detection": "bvh", "surface": {"a": "xmax", "b": "xmin"}, "search_distance": 0.2 * self.L / n},
            "time": {"mode": "dynamic", "step": h, "end": 3.0 * self.L / self.c, "alpha": -0.1},
            "output": {"every": 100000, "reactions": False},
        }

    def reference_text(self, mode, reference=None):
        return ("Exact, no run: the contact of two identical bars lasts 2 L / c (1-D wave theory); "
                "a step-counted duration resolves it to one step, so the error cannot fall below h / (2 L / c).")

    def measure(self, res, reference=None):
        h = res.history
        t = h["t"]
        dt = t[1] - t[0]
        on = np.flatnonzero(np.abs(h["contact_force.a"][:, 0]) > 0)
        duration = float(t[on[-1]] - t[on[0]] + dt) if on.size else 0.0
        exact = 2 * self.L / self.c
        e0 = 0.5 * self.rho * self.L * 1e-4 * self.v0**2
        energy = h["kinetic_energy"] + h["elastic_energy"]
        return {"error": abs(duration - exact) / exact, "duration": duration, "exact": exact,
                "energy_change": float(energy[-1] / e0 - 1.0), "energy_max": float(energy.max() / e0)}


@register_problem
class M5:
    """The M5 folds colliding under Bernoulli flow (Ps = 0.8 kPa, 15 ms; the isotropic E = 4 kPa
    stand-in, examples/m5_phonation_isotropic.toml, that the committed results were run on),
    scored on three numbers of the first glottal closure, the window 5-15 ms (with Lagrange on
    the coarse, medium and fine meshes at h = 100 to 12.5 us the folds close at 9.2-9.7 ms and
    are open again by 13.2 ms): the medio-lateral contact impulse on the right fold (the
    primary ``error``, the Pareto figure's), its peak medio-lateral contact force
    (``peak_force_error``) and the peak contact pressure on a 1 mm^2 sensor
    (``pressure_error``), each against the limit extrapolated from a reference study (see
    "Reference"), not against one finer run. The rows run on two mesh families at the same
    cell counts: the generator's uniform levels (``coarse``, ``medium``) and meshes graded
    toward the contact zone (``coarse graded``, ``medium graded``: ``contact_zone`` 3 mm,
    ``contact_zone_z`` 10 mm, ``zone_ratio`` and ``medial_ratio`` 1.2, docs/model.md); the
    graded rows for three settings (Lagrange, penalty 1e10, Uzawa N = 4). The window leaves
    out a graze during the pressure ramp (2.0-3.0 ms): with Lagrange it touches on the medium
    and fine meshes only, for 0.1-1.0 uN s against about 18 for the closure."""

    name = "m5"
    levels = {"quick": ["coarse"], "full": ["coarse", "medium", "coarse graded", "medium graded"]}
    steps = {"quick": [100e-6], "full": [100e-6, 50e-6, 25e-6, 12.5e-6]}
    all_levels = ("coarse", "medium", "fine")  # coarse to fine (vfrs.meshes.m5.RESOLUTIONS)
    #: the mesh families of the rows and the reference study, coarsest first; a recommendation
    #: is confirmed on the next finer mesh of its own family
    families = (("coarse", "medium", "fine", "finer"), ("coarse graded", "medium graded", "fine graded"))
    #: levels beyond the generator's named resolutions: cells per fold (along the medial curve,
    #: across, along z); "finer" is "fine" refined by the same 1.5 as medium to fine
    cells = {"finer": (72, 18, 30)}
    #: the grading of the "graded" levels (keys of the M5 generator, docs/model.md)
    graded = {"contact_zone": 3e-3, "contact_zone_z": 10e-3, "zone_ratio": 1.2, "medial_ratio": 1.2}
    #: the settings that also run on the graded levels (the rest: uniform levels only)
    graded_settings = ("lagrange", "penalty k=1e+10", "AL N=4 k0=1e+08")
    #: settings that run on a few cells only, (level, step) each: the refactoring path costs
    #: 17x a row, and one cell shows it
    only_cells = {"penalty k=1e+10 refactor": (("medium", 25e-6),)}
    modes = ("full",)  # minutes per row: run in quick mode only when asked for
    kappas = [1e8, 1e10, 1e12]
    extra_settings = {"full": [("penalty_volume k=1e14", {"method": "penalty_volume", "kappa": 1e14})]}
    end = 0.015
    window = (0.005, 0.015)  # s: the first glottal closure, after the graze of the pressure ramp
    quantity = "impulse"  # the primary metric scored (N s)
    #: metric -> its error column, each scored against the reference study's extrapolation
    scored = {"impulse": "error", "peak_force": "peak_force_error", "peak_pressure": "pressure_error"}
    targets: tuple = (0.10, 0.05, 0.02)  # a recommendation for each error, on each scored metric
    detection = "interface_mesh"

    def includes(self, setting, level, step) -> bool:
        """Whether the grid runs ``setting`` at (level, step): graded levels only for
        :attr:`graded_settings`, the settings of :attr:`only_cells` only there."""
        cells = self.only_cells.get(setting)
        if cells is not None:
            return any(str(level) == lv and step is not None and math.isclose(step, h) for lv, h in cells)
        return not str(level).endswith(" graded") or setting in self.graded_settings

    def reference_study(self, mode):
        """The reference runs (:class:`vfrs.studies.accuracy.reference.ReferenceStudy`): Lagrange on the
        medium, fine and finer uniform meshes (a refinement ratio of 1.5 per axis each) at half
        the grid's smallest step, and on the fine mesh at twice and four times that step; the
        three graded meshes at the same step as a cross-check. The coarse meshes are left out
        of the reference: with them the three-mesh studies were oscillatory (uniform) or of
        order 0.6 (graded), out of the asymptotic range (docs/converge.md, "The accuracy
        report's limit for the folds"). The fine and finer meshes and the reference step are
        finer than every row; the medium meshes are rows' meshes, run here at a step smaller
        than every row's (the extrapolated limit is no run, and no row is one of its runs)."""
        from .reference import ReferenceStudy

        h = min(self.steps[mode]) / 2
        return ReferenceStudy({"method": "lagrange"}, self.families[0][1:], h, (4 * h, 2 * h, h),
                              cross=self.families[1], step_mesh=self.families[0][2])

    def scene(self, contact, level, step):
        from pathlib import Path

        from ...scene import Scene

        path = Path(__file__).resolve().parents[3] / "examples" / "m5_phonation_isotropic.toml"
        if path.exists():
            d = Scene.load(path).to_dict()
        else:  # installed without the examples: the same scene inline
            d = _m5_scene()
        resolution, graded = str(level).removesuffix(" graded"), str(level).endswith(" graded")
        for b in d["bodies"]:
            if resolution in self.cells:
                b["mesh"].pop("resolution", None)
                b["mesh"]["cells"] = list(self.cells[resolution])
            else:
                b["mesh"]["resolution"] = resolution
            if graded:
                b["mesh"].update(self.graded)
        d["time"].update({"step": step, "end": self.end})
        d["output"] = {"every": 100000, "reactions": False, "energy": False}
        d["contact"] = {**contact, "detection": "interface_mesh", "pairs": [["right", "left"]]}
        return d

    def reference_setting(self, mode):
        """(contact, level, step) of the reference: Lagrange on the mesh one level finer than
        the grid's finest and half the grid's smallest step, so it is finer in both than
        every row (a reference is never one of the settings it judges)."""
        finest = max(self.levels[mode], key=self.all_levels.index)
        i = self.all_levels.index(finest) + 1
        if i >= len(self.all_levels):
            raise ValueError(f"m5 {mode}: no mesh finer than {finest!r} for the reference")
        level, step = self.all_levels[i], min(self.steps[mode]) / 2
        assert all(self.all_levels.index(lv) < i for lv in self.levels[mode]) and all(step < h for h in self.steps[mode])
        return {"method": "lagrange"}, level, step

    def reference_check_setting(self, mode):
        """The reference's sensitivity to the mesh: the same run one mesh level coarser (same
        method and step). How far the scored quantity moves between the two bounds what the
        reference can resolve."""
        contact, level, step = self.reference_setting(mode)
        return contact, self.all_levels[self.all_levels.index(level) - 1], step

    def reference_step_check_setting(self, mode):
        """The reference's sensitivity to the step: the same run (same method and mesh) with
        twice its step."""
        contact, level, step = self.reference_setting(mode)
        return contact, level, 2 * step

    def reference_text(self, mode, reference=None):
        from ...meshes.m5 import RESOLUTIONS

        study = self.reference_study(mode)
        if study is not None:
            from .reference import study_text

            def cells(lv):
                name = str(lv).removesuffix(" graded")
                return " x ".join(str(c) for c in self.cells.get(name, RESOLUTIONS.get(name, ())))

            return study_text(study, reference, cells)
        contact, level, step = self.reference_setting(mode)
        finest = max(self.levels[mode], key=self.all_levels.index)
        cells = " x ".join(str(c) for c in RESOLUTIONS[level])
        a, b = self.window
        text = ("A run with Lagrange multipliers (interface-mesh detection, vfrs's default time and contact "
                f"schemes, like every row) on the {level} mesh ({cells} cells per fold) with h = {step * 1e6:g} us: "
                f"finer in mesh and in step than every row of the table (finest row: {finest}, "
                f"h = {min(self.steps[mode]) * 1e6:g} us), so no setting is scored against itself. "
                f"Scored: the medio-lateral contact impulse on the right fold over {a * 1e3:g}-{b * 1e3:g} ms. "
                "Not a Richardson extrapolation: a plain run, whose own error bar is how far it moves between "
                "its two finest cells (below).")
        if reference and "metrics" in reference:
            m = reference["metrics"]
            text += (f" Reference impulse {m['impulse'] * 1e6:.4g} uN s (peak force {m['peak_force'] * 1e3:.4g} mN), "
                     f"its own wall time {reference['wall_s']:.0f} s.")
            moves = []
            for key, what in (("check", "on the {level} mesh (same step)"), ("step_check", "at h = {step} us (same mesh)")):
                chk = reference.get(key)
                if chk and "metrics" in chk:
                    where = what.format(level=chk["level"], step=f"{chk['step'] * 1e6:g}")
                    pf = (chk["metrics"]["peak_force"] - m["peak_force"]) / m["peak_force"]
                    moves.append(f"{where} the impulse is {chk['metrics']['impulse'] * 1e6:.4g} uN s "
                                 f"({chk['change']:.1%} off; the peak force {chk['metrics']['peak_force'] * 1e3:.4g} mN, "
                                 f"{pf:+.1%}), {chk['wall_s']:.0f} s")
            if moves:
                text += (" Its sensitivity: " + "; ".join(moves) + ". Errors below the larger of the two are "
                         "not resolved by this reference.")
        return text

    def measure(self, res, reference=None):
        from ...signals import impulse_per_cycle

        h = res.history
        t = np.asarray(h["t"])
        fx = np.asarray(h["contact_force.right"])[:, 0]
        inside = (t >= self.window[0]) & (t <= self.window[1])
        out = {
            "peak_force": float(np.abs(fx).max()),
            "impulse": float(impulse_per_cycle(t, fx, list(self.window))[0]),
            "max_area": float(h["contact_area"].max()),
            "max_volume": float(h["intersection_volume"].max()),
        }
        if "contact_pressure_sensor" in h:  # the 1 mm^2 sensor's peak over the closure
            out["peak_pressure"] = float(np.max(np.asarray(h["contact_pressure_sensor"], dtype=float)[inside], initial=0.0))
        out["error"] = float("nan")
        if reference is not None:
            for q, col in {**self.scored, "max_area": "area_error"}.items():
                if q in out and reference.get(q):
                    out[col] = abs(out[q] - reference[q]) / abs(reference[q])
        return out


@register_problem
class M5Finite(M5):
    """The kinematics axis: the M5 collision of ``m5`` (Ps = 0.8 kPa, 15 ms, Bernoulli flow)
    with finite-strain tissue, neo-Hookean with the stand-in's E = 4 kPa, nu = 0.45 (so small
    strains reproduce the linear folds), HHT-alpha with modified Newton and contact inside
    the Newton iteration. Error: of the medio-lateral contact impulse on the right fold over
    the first glottal closure (5-15 ms, as for ``m5``) against a finite-strain Lagrange run on
    a finer mesh with a smaller step than every row (see "Reference"). The table "Kinematics"
    below sets each row beside the linear ``m5`` row of the same setting, mesh and step: how
    far the peak force and the impulse move, and what a step costs."""

    name = "m5_finite"
    levels = {"quick": ["coarse"], "full": ["coarse"]}
    scored = {"impulse": "error"}  # scored against one finer run (below), on the impulse only
    targets = (0.01, 0.05)
    steps = {"quick": [100e-6], "full": [100e-6, 50e-6]}
    modes = ("full",)
    linear = "m5"  # the problem whose rows are this one's linear counterparts (same labels)
    settings = {"quick": [("lagrange", {"method": "lagrange"}),
                          ("penalty k=1e+10", {"method": "penalty", "kappa": 1e10})],
                "full": [("lagrange", {"method": "lagrange"}),
                         ("penalty k=1e+10", {"method": "penalty", "kappa": 1e10}),
                         ("AL N=4 k0=1e+08", {"method": "augmented_lagrange", "kappa": 1e8, "max_augmentations": 4,
                                              "strict": False}),
                         ("penalty_volume k=1e14", {"method": "penalty_volume", "kappa": 1e14})]}

    def scene(self, contact, level, step):
        d = super().scene(contact, level, step)
        for b in d["bodies"]:
            m = b["material"]
            b["material"] = {"model": "neo_hookean", "E": m["E"], "nu": m["nu"], "rho": m["rho"]}
        d["time"]["newton"] = {"method": "modified"}
        return d

    def reference_study(self, mode):
        """None: a finite-strain reference study (three meshes up to the fine one) would cost
        more than the whole report; the reference is one finer run (:meth:`reference_setting`)."""
        return None

    def reference_text(self, mode, reference=None):
        return "Finite strain (neo-Hookean, modified Newton), otherwise as for m5: " + super().reference_text(mode, reference)

    def measure(self, res, reference=None):
        out = super().measure(res, reference)
        its = np.asarray(res.history["newton_iterations"], dtype=float)[1:]
        out["newton_iterations"] = float(its.mean()) if its.size else 0.0
        return out


def _m5_scene():
    body = lambda side: {  # noqa: E731
        "name": side,
        "mesh": {"builtin": "m5", "side": side, "resolution": "coarse", "half_gap": 0.05e-3},
        "material": {"model": "isotropic", "E": 4e3, "nu": 0.45, "rho": 1070.0},
        "damping": {"a0": 0.0, "a1": 1e-5},
        "fixed": ["lateral", "anterior", "posterior"],
    }
    return {
        "bodies": [body("right"), body("left")],
        "flow": {"model": "bernoulli", "subglottal_pressure": 800.0, "ramp": 2e-3},
        "time": {"mode": "dynamic", "step": 50e-6, "end": 0.015, "alpha": -0.3},
        "output": {},
    }
