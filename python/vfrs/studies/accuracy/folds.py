"""A contact benchmark of the folds without flow (issue 45, item 3): the two M5 folds of the
systematic mesh family (:mod:`vfrs.meshes.m5_family`, levels ``L0``, ``L1``, ``L2``: every
length 1.5 times smaller per level) pressed together by a smooth medial load, scored against
a limit extrapolated from a ladder of Lagrange runs (:mod:`vfrs.studies.accuracy.reference`).

- ``m5_press``: static. A traction toward the midline on each fold's medial surface (the folds
  held at their lateral, anterior and posterior walls, as in the main job), in load steps;
  scored: the medio-lateral contact force (the primary ``error``), the effective contact area,
  the area where the P1 pressure is positive (once the run records it, history
  ``contact_area_pressed``) and the 1 mm^2 sensor's pressure (``contact_pressure_sensor``;
  over its exact disc, ``contact_pressure_disc``, where the run records it).
- ``m5_pulse`` and ``m5_pulse_strong``: dynamic. The same traction as a pulse rising and
  falling back to zero (``pulse``, sin^2, :func:`vfrs.dynamics.problem.pulse`) at two
  amplitudes; scored: the impulse of the medio-lateral contact force (the primary ``error``, a
  smooth functional), its one-step peak (an extreme), the contact duration (step-counted),
  the effective area at that peak and the sensor's peak (an extreme).

Tissue: the isotropic stand-in of the ``m5`` problem (E = 4 kPa, nu = 0.45, rho = 1070 kg/m^3,
Rayleigh a1 = 1e-5 s), not the main job's transversely isotropic ``vocal_fold``: at nu = 0.45
linear tetrahedra lock by a few per cent only, so the mesh ladder can be in its asymptotic
range on three levels; the main job's tissue is nearly incompressible along the fibres and
locks far more (issue 45: a free static deflection 61 / 72 / 77 um at nu = 0.49 against
126 / 133 / 135 um at 0.45).
"""

from __future__ import annotations

import functools

import numpy as np

from .problems import register_problem

TISSUE = {"model": "isotropic", "E": 4e3, "nu": 0.45, "rho": 1070.0}
DAMPING = {"a0": 0.0, "a1": 1e-5}
#: the systematic family's levels as the tables print them, coarsest first
LEVELS = ("L0", "L1", "L2")
#: the same family's levels with ten-node tetrahedra (``order = 2``: issue 47), coarsest first
P2_LEVELS = ("L0 P2", "L1 P2")


def parse_level(level) -> tuple:
    """(the family's level k, the element order) of a level as the tables print it: ``L<k>``
    (linear tetrahedra) or ``L<k> P2`` (quadratic)."""
    name = str(level)
    quadratic = name.endswith(" P2")
    return int(name.removesuffix(" P2")[1:]), 2 if quadratic else 1
SETTINGS = [("lagrange", {"method": "lagrange"}),
            ("penalty k=1e+08", {"method": "penalty", "kappa": 1e8}),
            ("penalty k=1e+10", {"method": "penalty", "kappa": 1e10}),
            ("AL N=4 k0=1e+08", {"method": "augmented_lagrange", "kappa": 1e8, "max_augmentations": 4, "strict": False})]


def folds_scene(level: str, contact: dict, traction: float, time: dict, profile: dict) -> dict:
    """The two M5 folds (systematic family at ``level``, ``L0``..``L3``; half-gap 50 um) held
    at their lateral, anterior and posterior walls, each pulled toward the other by a
    ``traction`` (Pa) toward the midline on its medial surface with the time ``profile``
    (``{"ramp": s}`` or ``{"pulse": s}``), no flow; ``contact`` is the [contact] table,
    ``time`` the [time] one."""
    k, order = parse_level(level)

    def body(side, sign):  # the right fold lies at x > 0: the midline is toward -x
        return {"name": side,
                "mesh": {"builtin": "m5", "side": side, "family": "systematic", "level": k,
                         "psi": 0.0, "half_gap": 0.05e-3, "length": 14e-3, "depth": 8e-3},
                "material": dict(TISSUE), "damping": dict(DAMPING), "fixed": ["lateral", "anterior", "posterior"],
                "loads": [{"name": "toward the midline", "type": "traction", "surface": "medial",
                           "value": [sign * traction, 0.0, 0.0], **profile}], **({"order": 2} if order == 2 else {})}

    return {"title": "M5 folds pressed together, no flow",
            "bodies": [body("right", -1.0), body("left", 1.0)],
            "contact": {**contact, "detection": "interface_mesh", "pairs": [["right", "left"]]},
            "time": dict(time),
            "output": {"every": 100000, "reactions": True, "energy": False}}


@functools.lru_cache(maxsize=None)
def level_cells(level: int) -> tuple:
    """Cells per fold (along the medial curve, across, along z) of the family's ``level``, as
    the benchmark's folds are built (``m5(family="systematic", ...)``'s ``family_info``)."""
    from ...meshes.m5 import m5

    mesh = m5("right", family="systematic", level=level, psi=0.0, half_gap=0.05e-3, length=14e-3, depth=8e-3)
    return tuple(getattr(mesh, "family_info")["cells"])


class _Folds:
    """What the folds' problems share: the settings, levels, mesh family, targets and the
    scoring of each metric against the extrapolated limit."""

    modes = ("full",)  # minutes per report: run in quick mode only when asked for
    families: tuple = (LEVELS,)
    targets: tuple = (0.10, 0.05, 0.02)
    detection = "interface_mesh"
    settings = {"quick": SETTINGS[:1] + SETTINGS[2:3], "full": SETTINGS[:1] + SETTINGS[2:]}
    levels = {"quick": ["L0"], "full": ["L0", "L1"]}
    scored: dict = {}

    def scores(self, out: dict, reference) -> dict:
        """``out`` with each scored metric's error column (relative, against ``reference``)."""
        out.setdefault("error", float("nan"))
        if reference is not None:
            for q, col in self.scored.items():
                if q in out and reference.get(q):
                    out[col] = abs(out[q] - reference[q]) / abs(reference[q])
        return out

    def reference_setting(self, mode):
        """(contact, level, step) of the reference study's finest run (the limit scored against
        is extrapolated from the whole study, :meth:`reference_study`)."""
        study = self.reference_study(mode)
        return study.contact, study.meshes[-1], study.mesh_step

    def reference_text(self, mode, reference=None):
        from .reference import step_text, study_text

        steps = getattr(self, "steps_text", step_text)
        return study_text(self.reference_study(mode), reference, self.cells_text, steps)

    @staticmethod
    def cells_text(level) -> str:
        """The cells per fold of a level as printed (along the medial curve x across x along z)."""
        k, order = parse_level(level)
        return " x ".join(str(c) for c in level_cells(k)) + (" ten-node" if order == 2 else "")

    def includes(self, setting, level, step) -> bool:
        return True


@register_problem
class M5Press(_Folds):
    """The M5 folds (systematic family L0 / L1 / L2, isotropic E = 4 kPa, nu = 0.45) pressed
    together statically without flow: a traction of 300 Pa toward the midline on each fold's
    medial surface, the folds held at their lateral, anterior and posterior walls. Its "step"
    is the load increment: contact is detected on the configuration of the last load step, so
    the number of load steps is a discretization of its own (on L0, Lagrange: 16.98 mN in one
    step, 17.06 mN in four); the rows take the load in one step. Scored: the medio-lateral
    contact force on the right fold (``error``), the effective contact area (F^2 over the
    integral of p^2; ``area_effective_error``), the area where the P1 pressure is positive
    (``area_error``, when the run records it) and the pressure on the 1 mm^2 sensor
    (``pressure_error``) and over the sensor's exact disc, where the run records it
    (``disc_pressure_error``). The walls take the rest of the load: the contact force plus the
    lateral, anterior and posterior reactions balance the traction's resultant."""

    name = "m5_press"
    traction = 300.0  # Pa
    #: the rows' meshes: the linear family's levels 0 and 1 and, as the order axis (issue 47),
    #: level 0 with ten-node tetrahedra (its level 1 does not fit in 20 GB: stopped at 20.5 GB)
    levels = {"quick": ["L0"], "full": ["L0", "L1", "L0 P2"]}
    families = (LEVELS, P2_LEVELS)
    steps = {"quick": [1.0], "full": [1.0]}  # load increments: the rows take the load in one step
    #: the study table's step column: the load increment, as the fraction of the load per step
    step_column = ("load increment", lambda h: f"1/{round(1 / h)}")
    scored = {"force": "error", "area_effective": "area_effective_error", "area_pressed": "area_error",
              "sensor_pressure": "pressure_error", "disc_pressure": "disc_pressure_error"}
    quantity = "force"
    settings = {"quick": SETTINGS[:1] + SETTINGS[2:3], "full": SETTINGS}

    @staticmethod
    def steps_text(h: float) -> str:
        """A load increment as the reference's text prints it."""
        return f"{round(1 / h)} load steps"

    def scene(self, contact, level, step):
        """The press with the load in ``round(1 / step)`` steps (``step``: the load increment)."""
        return folds_scene(level, contact, self.traction, {"mode": "static", "load_steps": round(1 / step)}, {})

    def reference_study(self, mode):
        """Lagrange on L0, L1 and L2 in 4 load steps, and on L0 in 2, 3 and 4 (the rows: one)."""
        from .reference import ReferenceStudy

        return ReferenceStudy({"method": "lagrange"}, LEVELS, 1 / 4, (1 / 2, 1 / 3, 1 / 4), step_mesh=LEVELS[0])

    def measure(self, res, reference=None):
        h = res.history
        out = {"force": abs(float(np.asarray(h["contact_force.right"])[-1][0])),
               "force_left": float(np.asarray(h["contact_force.left"])[-1][0]),
               "area_effective": float(np.asarray(h["contact_area_effective"])[-1])}
        for q, key in (("area_pressed", "contact_area_pressed"), ("sensor_pressure", "contact_pressure_sensor"),
                       ("disc_pressure", "contact_pressure_disc")):
            if key in h:
                out[q] = float(np.asarray(h[key], dtype=float)[-1])
        return self.scores(out, reference)


@register_problem
class M5Pulse(_Folds):
    """The M5 folds (systematic family, isotropic E = 4 kPa, nu = 0.45, Rayleigh a1 = 1e-5 s)
    driven together without flow by a traction pulse toward the midline on each fold's medial
    surface, sin^2 over 6 ms with a peak of 150 Pa, held at their lateral, anterior and
    posterior walls, run to
    10 ms (HHT-alpha -0.3): the first collision, which lasts from about 2 to 7 ms; after the pulse the
    folds rebound and collide again from about 12.6 ms, outside the run. Scored: the impulse of the medio-lateral contact force on the right
    fold over the run (``error``, a smooth functional), its peak (``peak_force_error``, a
    one-step extreme), the contact duration (``duration_error``, step-counted: resolved to one
    step), the effective contact area at the peak (``area_error``) and the peak on the 1 mm^2
    sensor (``pressure_error``, an extreme; over its exact disc ``disc_pressure_error``, where
    the run records it)."""

    name = "m5_pulse"
    amplitude = 150.0  # Pa
    duration = 6e-3  # s
    end = 10e-3  # s: the first collision (L0, 100 us: 2.3-7.1 ms), before the folds rebound into a second one at 12.6 ms
    steps = {"quick": [100e-6], "full": [100e-6, 50e-6]}
    scored = {"impulse": "error", "peak_force": "peak_force_error", "duration": "duration_error",
              "area_at_peak": "area_error", "peak_pressure": "pressure_error",
              "peak_disc_pressure": "disc_pressure_error"}
    quantity = "impulse"

    def scene(self, contact, level, step):
        return folds_scene(level, contact, self.amplitude,
                           {"mode": "dynamic", "step": step, "end": self.end, "alpha": -0.3},
                           {"pulse": self.duration})

    def reference_study(self, mode):
        """Lagrange on L0, L1 and L2 at 20 us (smaller than every row's step, so no study run
        is a row), and on L0 at 80, 40 and 20 us: the step ladder on the cheapest mesh."""
        from .reference import ReferenceStudy

        h = 20e-6
        return ReferenceStudy({"method": "lagrange"}, LEVELS, h, (4 * h, 2 * h, h), step_mesh=LEVELS[0])

    def measure(self, res, reference=None):
        from ...signals import contact_intervals, impulse_per_cycle

        h = res.history
        t = np.asarray(h["t"], dtype=float)
        fx = np.asarray(h["contact_force.right"], dtype=float)[:, 0]
        on = np.abs(fx) > 0
        k = int(np.argmax(np.abs(fx)))
        spans = contact_intervals(t, on)
        out = {"impulse": float(impulse_per_cycle(t, fx, [t[0], t[-1] + 1.0])[0]),
               "peak_force": float(np.abs(fx[k])), "peak_time": float(t[k]),
               "duration": float((spans[:, 1] - spans[:, 0]).sum()) if len(spans) else 0.0,
               "contacts": len(spans),
               "area_at_peak": float(np.asarray(h["contact_area_effective"], dtype=float)[k])}
        for q, key in (("peak_pressure", "contact_pressure_sensor"), ("peak_disc_pressure", "contact_pressure_disc")):
            if key in h:
                out[q] = float(np.max(np.asarray(h[key], dtype=float), initial=0.0))
        return self.scores(out, reference)


@register_problem
class M5PulseStrong(M5Pulse):
    """``m5_pulse`` at twice the amplitude: a sin^2 traction pulse toward the midline over 6 ms
    with a peak of 300 Pa on each fold's medial surface (otherwise the same folds, run and
    scoring)."""

    name = "m5_pulse_strong"
    amplitude = 300.0  # Pa
