"""Steady flow through a rigid M5 glottis (issue 46, item 3): the flow each [flow] model gives
for the convergent, uniform and divergent M5 glottis at the diameters and transglottal
pressures of the M5 physical-model measurements, and the ratio of the divergent glottis's flow
to the convergent's, which the measurements state (docs/model.md, "Glottal flow: a rigid M5
glottis"). Writes benchmarks/results/flow/rigid_m5.csv:

    python examples/rigid_m5_flow.py            (about 10 s)

The folds are the built-in M5 profile (vfrs.meshes.m5, level 1 of the systematic family,
length 14 mm along z) held rigid: psi = +10 (convergent), 0 (uniform), -10 degrees
(divergent), the narrowest gap d = 2 half_gap; the flow of each model at its defaults
(viscous: mu = 1.89e-5 Pa s, no entrance loss), rho = 1.14 kg/m^3, separation at the narrowest
station (ratio 1), at 1.2 times its area, and (viscous) where Thwaites' boundary layer
separates (``separation = "boundary_layer"``). The stations: 480 along the flow (the table's);
the flows at 120 stations differ from them by at most the ``stations_change`` column.
"""

from __future__ import annotations

import csv
import pathlib
import sys

import numpy as np

import vfrs
from vfrs.flow import BernoulliModel, GlottalSlices, ViscousModel
from vfrs.flow.effect import FlowParams

OUT = pathlib.Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "flow" / "rigid_m5.csv"
CM_H2O = 98.0665  # Pa
DIAMETERS_CM = (0.005, 0.01, 0.02, 0.04, 0.08, 0.16, 0.32)
PRESSURES_CM_H2O = (3.0, 10.0, 25.0)
ANGLES = (10.0, 0.0, -10.0)
RHO = 1.14


def folds(psi: float, d: float):
    return [vfrs.meshes.m5(side=side, family="systematic", level=1, psi=psi, half_gap=d / 2) for side in ("right", "left")]


#: (model, separation): the separation at the narrowest station (ratio 1), at 1.2 A_min, and by
#: Thwaites' boundary layer (the viscous model's ``separation = "boundary_layer"``).
VARIANTS = (("bernoulli", 1.0), ("bernoulli", 1.2), ("viscous", 1.0), ("viscous", 1.2), ("viscous", "boundary_layer"))


def flow(meshes, model: str, ratio, dp: float, stations: int) -> float:
    common = FlowParams(subglottal_pressure=dp, density=RHO, separation_ratio=1.0 if isinstance(ratio, str) else ratio)
    own = ViscousModel.Params(separation=ratio) if isinstance(ratio, str) else ViscousModel.Params()
    law = (ViscousModel(own, common) if model == "viscous" else BernoulliModel(None, common))
    r, l = meshes
    st = GlottalSlices(r, l, law, dp, n_stations=stations).state(r.points, l.points)
    if st.flow is not None:
        return st.flow
    return float(np.interp(st.y_separation, st.y, st.area)) * np.sqrt(2.0 * dp / RHO)


def rows():
    for d_cm in DIAMETERS_CM:
        meshes = {psi: folds(psi, d_cm * 1e-2) for psi in ANGLES}
        for p_cm in PRESSURES_CM_H2O:
            for model, ratio in VARIANTS:
                q = {psi: flow(meshes[psi], model, ratio, p_cm * CM_H2O, 480) for psi in ANGLES}
                coarse = {psi: flow(meshes[psi], model, ratio, p_cm * CM_H2O, 120) for psi in ANGLES}
                change = max(abs(coarse[p] / q[p] - 1.0) for p in ANGLES)
                yield {"diameter_cm": d_cm, "pressure_cmH2O": p_cm, "model": model,
                       "separation": "ratio" if not isinstance(ratio, str) else ratio,
                       "separation_ratio": "" if isinstance(ratio, str) else ratio,
                       "flow_convergent_cm3s": q[10.0] * 1e6, "flow_uniform_cm3s": q[0.0] * 1e6,
                       "flow_divergent_cm3s": q[-10.0] * 1e6, "divergent_over_convergent": q[-10.0] / q[10.0],
                       "stations_change": change}


def main(out=OUT) -> None:
    out.parent.mkdir(parents=True, exist_ok=True)
    table = list(rows())
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(table[0]))
        w.writeheader()
        for row in table:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
    print(f"wrote {out} ({len(table)} rows)")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else OUT)
