"""The [flow] models as a scene chooses them (issue 46, items 1-3): the viscous model against
closed forms on channels between two boxes (Bernoulli with no viscosity, Poiseuille plus
Bernoulli through a straight slit, no pressure where the folds touch), the glottal inertance
against the exact step response, the vocal tract's junction with the pressure recovery and
the viscous loss (the energy balance of lung work, glottal losses, the tract's energy and the
radiated power, sample by sample), and bad input."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import vfrs
from vfrs.acoustics.tract import Tract
from vfrs.errors import PlausibilityWarning, SceneError
from vfrs.flow import BernoulliFlow, GlottalLoss, GlottalSlices, ViscousModel, viscous_flow
from vfrs.flow.effect import FlowParams
from vfrs.flow.models.viscous import AIR_VISCOSITY, slit_integrals

PS = 800.0
RHO = 1.14
G, D, H, LZ = 0.2e-3, 4e-3, 3e-3, 10e-3


def channel(slope=0.0, tilt=0.0, cells=(4, 12, 5)):
    """Two boxes facing each other across x = 0; the right medial face is the plane
    x = G + slope (H - y), the left one its mirror moved by ``tilt (z - LZ / 2)`` towards the
    right (the gap 2 G + 2 slope (H - y) - tilt (z - LZ / 2): with tilt, closed at one end)."""
    folds = []
    for sign, medial in ((1.0, "xmin"), (-1.0, "xmax")):
        b = vfrs.meshes.box((D, H, LZ), cells, origin=(G if sign > 0 else -G - D, 0, 0))
        p = b.points.copy()
        w = 1 - (sign * p[:, 0] - G) / D  # 1 on the medial face, 0 on the lateral wall
        p[:, 0] += sign * w * slope * (H - p[:, 1])
        if sign < 0:
            p[:, 0] += w * tilt * (p[:, 2] - LZ / 2)
        folds.append(vfrs.Mesh(p, b.tets, surfaces={"medial": b.surfaces[medial]}))
    return folds


def viscous(mu=AIR_VISCOSITY, **own):
    common = FlowParams(subglottal_pressure=PS, density=RHO)
    return ViscousModel(ViscousModel.Params(viscosity=mu, **own), common)


def test_without_viscosity_the_viscous_model_is_bernoulli_on_a_convergent_channel():
    """mu = 0 and the pressure on the whole surface: the same forces as the Bernoulli model
    (the same stations, the exact area of a gap linear in z)."""
    r, l = channel(slope=0.05)
    a = BernoulliFlow(r, l, PS, n_stations=50)
    b = GlottalSlices(r, l, viscous(0.0, pressure_on_contact=True), PS, n_stations=50)
    fa, fb = a.forces(r.points, l.points), b.forces(r.points, l.points)
    np.testing.assert_allclose(fb[2].pressure, fa[2].pressure, rtol=1e-10, atol=1e-9)
    for k in (0, 1):
        np.testing.assert_allclose(fb[k], fa[k], rtol=1e-10, atol=1e-12 * np.abs(fa[k]).max())


def test_a_straight_slit_is_poiseuille_plus_bernoulli():
    """A straight slit of width g = 2 G, depth LZ, length H: rho U^2 / (2 A^2) + 12 mu H U /
    (g^3 LZ) = Ps, the pressure falling linearly to 0 at the exit, and the force on each
    fold LZ int p dy (exact: p is linear)."""
    r, l = channel()
    f = GlottalSlices(r, l, viscous(), PS, n_stations=40)
    fr, fl, st = f.forces(r.points, l.points)
    g, A = 2 * G, 2 * G * LZ
    a, b = RHO / (2 * A * A), 12 * AIR_VISCOSITY * H / (g ** 3 * LZ)
    U = (-b + math.sqrt(b * b + 4 * a * PS)) / (2 * a)
    assert st.flow == pytest.approx(U, rel=1e-12)
    assert st.y_separation == pytest.approx(H)
    exact = PS - a * U * U - b * U * st.y / H
    np.testing.assert_allclose(st.pressure, exact, rtol=1e-10, atol=1e-9)
    force = LZ * 0.5 * (exact[0] + 0.0) * H  # the trapezoid of a linear p from p(0) to 0
    assert fr.sum(axis=0) == pytest.approx([force, 0.0, 0.0], rel=1e-9, abs=1e-9 * force)
    assert fl.sum(axis=0) == pytest.approx([-force, 0.0, 0.0], rel=1e-9, abs=1e-9 * force)
    assert 0.05 < b * U / PS < 0.5  # both terms matter at this gap (0.4 mm): the test tells them apart


def test_no_pressure_where_the_folds_touch():
    """A slit closed over part of its depth (the gap g0(y) - tilt (z - LZ / 2) < 0 beyond z =
    LZ / 2 + g0 / tilt, 7.5-9.4 mm): the area is the open part's (exact), the nodes deep in the
    closed part (their neighbours closed too) get no force, and the total force is the open
    part's pressure integrated over it, int p(y) z_open(y) dy, to the mesh's resolution of the
    closure's edge (measured 0.07 %); with ``pressure_on_contact`` the closed part is loaded
    too (Bernoulli's way): int p(y) LZ dy (0.11 %, from the stations' linear p)."""
    tilt = 0.16
    r, l = channel(slope=0.05, tilt=tilt, cells=(4, 12, 20))
    dry = GlottalSlices(r, l, viscous(), PS, n_stations=60, n_z=41)
    wet = GlottalSlices(r, l, viscous(pressure_on_contact=True), PS, n_stations=60, n_z=41)
    fr, _, st = dry.forces(r.points, l.points)
    fr_all, _, _ = wet.forces(r.points, l.points)
    g0 = 2 * G + 2 * 0.05 * (H - st.y)  # the gap at z = LZ / 2
    width = g0[:, None] - tilt * (dry.z[None, :] - LZ / 2)
    z_open = LZ / 2 + g0 / tilt  # where each station's gap closes
    np.testing.assert_allclose(st.area, 0.5 * (width[:, 0]) * (z_open - 0.0), rtol=1e-12)
    nodes = np.unique(r.surface("medial"))
    y_n, z_n = r.points[nodes, 1], r.points[nodes, 2]
    closes = LZ / 2 + (2 * G + 2 * 0.05 * (H - y_n)) / tilt
    deep = nodes[z_n > closes + 2 * LZ / 20]  # two cells beyond the closure: its neighbours are closed too
    assert deep.size and np.abs(fr[deep]).max() == 0.0
    assert np.abs(fr_all[deep]).max() > 0.0
    trapezoid = getattr(np, "trapezoid", None) or getattr(np, "trapz")
    open_force = trapezoid(st.pressure * np.minimum(z_open, LZ), st.y)
    assert fr.sum(axis=0)[0] == pytest.approx(open_force, rel=3e-3)
    assert fr_all.sum(axis=0)[0] == pytest.approx(trapezoid(st.pressure * LZ, st.y), rel=3e-3)
    assert open_force < 0.9 * trapezoid(st.pressure * LZ, st.y)  # the closed part is not a rounding error


def _riccati(t, I, a, b, drive):
    """The exact U(t) of I dU/dt + a U^2 + b U = drive from U(0) = 0."""
    hi = (-b + math.sqrt(b * b + 4 * a * drive)) / (2 * a)
    lo = (-b - math.sqrt(b * b + 4 * a * drive)) / (2 * a)
    K = (hi / lo) * np.exp(-a * (hi - lo) * t / I)
    return (hi - K * lo) / (1 - K)


def test_the_glottal_inertance_gives_the_exact_step_response_at_first_order():
    """A straight slit started from rest by Ps: U(t) of I dU/dt + rho U^2 / 2 A^2 + 12 mu R U
    = Ps (I = rho H / A), whose exact solution is a Riccati one; implicit in U over each step,
    the error at the time constant falls at first order with the step, under 1 % at tau / 50."""
    g, n = 0.1e-3, 11
    y = np.linspace(0.0, H, n)
    A, G3 = slit_integrals(np.array([0.0, LZ]), np.full((n, 2), g))
    I, a, b = RHO * H / A[0], RHO / (2 * A[0] ** 2), 12 * AIR_VISCOSITY * H / G3[0]
    steady = viscous_flow(y, A, G3, PS, RHO).flow
    tau = I / (b + 2 * a * steady)

    def error(dt):
        u, t = 0.0, 0.0
        while t < tau * (1 - 1e-9):
            u = viscous_flow(y, A, G3, PS, RHO, inertance=(dt, u)).flow
            t += dt
        return abs(u - _riccati(t, I, a, b, PS)) / steady

    e1, e2 = error(tau / 50), error(tau / 100)
    assert e1 < 0.01 and 1.8 < e1 / e2 < 2.2, (e1, e2)


def _lossless_tract(recovery: bool, radiation: bool = True) -> Tract:
    return Tract(np.full(17, 2e-4), 1e-2, rho=RHO, radiation=radiation, recovery=recovery)


@pytest.mark.parametrize("recovery", [False, True])
def test_the_tract_s_junction_balances_lung_work_glottal_losses_tract_energy_and_radiation(recovery):
    """A lossless tract with radiating lips driven sample by sample through a glottis of
    varying area with a viscous and an entrance loss: per sample, the lung's work U P_lung T
    is the jet's dissipation (1 - k_r) rho |U|^3 / 2 A^2, the entrance loss q |U|^3, the
    viscous r U^2, and the work p_sup U on the tract; over the run that work is the tract's
    energy gain plus what the lips radiated (p^2 / R through the radiation resistance), to
    round-off. With the recovery, the jet's pressure is below p_sup by k_r rho U|U| / 2 A^2."""
    tract = _lossless_tract(recovery)
    loss = GlottalLoss(quadratic=0.37 * RHO / (2 * (3e-5) ** 2), linear=2e5)
    tract.loss = loss
    p_lung, T = 800.0, tract.T
    work = lost = radiated = 0.0
    e0 = tract.energy()
    for j in range(4000):
        area = 1e-5 * (1.0 - math.cos(2 * math.pi * 140.0 * j * T)) + 1e-7
        tract.sample(area, p_lung)
        u, p_sup = tract.out["u_glottis"][-1], tract.out["p_sup"][-1]
        k_r = tract.recovered(area)
        jet = (1 - k_r) * RHO * abs(u) ** 3 / (2 * area * area)
        glottal = jet + loss.quadratic * abs(u) ** 3 + loss.linear * u * u
        assert u * (p_lung - p_sup) == pytest.approx(glottal, rel=1e-9, abs=1e-15)
        work += T * p_sup * u
        lost += T * glottal
        radiated += T * tract.p_L ** 2 / tract.R  # the lips' pressure this sample, into the radiation resistance
        if recovery and j == 2062:  # the area at its mean, 1e-5 m^2
            assert p_sup - tract.jet_pressure(area, u, p_sup) == pytest.approx(
                k_r * RHO * u * abs(u) / (2 * area * area), rel=1e-12)
            assert k_r > 0.05
    assert work > 0 and radiated > 0.01 * work
    assert tract.energy() - e0 + radiated == pytest.approx(work, rel=1e-9)


def test_bad_flow_input_is_named():
    d = vfrs.Scene.load("examples/m5_steady.toml").to_dict()
    d["flow"]["viscosity"] = 1.8e-5  # the bernoulli model has no viscosity
    with pytest.raises(SceneError, match="'viscosity' is a key of model 'viscous', not of model = 'bernoulli'"):
        vfrs.Scene.from_dict(d)
    d["flow"].update(model="viscous", viscosity=0.018)  # in cP, read as Pa s
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        vfrs.Scene.from_dict(d)
    assert any(issubclass(x.category, PlausibilityWarning) and "flow.viscosity" in str(x.message)
               and "0.018 cP = 1.8e-05" in str(x.message) for x in w)
    d["flow"].update(viscosity=AIR_VISCOSITY, density=1140.0)  # in g/m^3
    with pytest.warns(PlausibilityWarning, match="flow.density.*1140 g/m\\^3 = 1.14"):
        vfrs.Scene.from_dict(d)
    d["flow"].update(density=1.14, inertance=True)
    d["acoustics"] = {"vowel": "a", "coupling": "interactive"}
    with pytest.raises(SceneError, match="flow.inertance"):
        vfrs.Scene.from_dict(d)
    d["acoustics"]["coupling"] = "none"
    vfrs.Scene.from_dict(d)


def test_the_committed_rigid_m5_table_is_the_code_s():
    """benchmarks/results/flow/rigid_m5.csv (examples/rigid_m5_flow.py) re-run for one diameter
    (0.04 cm, the three pressures, both models and separations): the same flows to the CSV's 6 digits. The
    viscous model separating by a ratio or by the boundary layer is converged in the stations
    (the table's 480 against 120 within 3 %), the Bernoulli model separating by a ratio is not
    (it jumps to the next station: up to 21 % in the table), which docs/model.md says."""
    import csv
    import importlib.util
    import pathlib

    root = pathlib.Path(__file__).resolve().parents[1]
    spec = importlib.util.spec_from_file_location("rigid_m5_flow", root / "examples" / "rigid_m5_flow.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    committed = list(csv.DictReader(open(root / "benchmarks" / "results" / "flow" / "rigid_m5.csv")))
    mod.DIAMETERS_CM = (0.04,)
    fresh = list(mod.rows())
    mine = [r for r in committed if float(r["diameter_cm"]) == 0.04]
    assert len(fresh) == len(mine) == 15
    for new, old in zip(fresh, mine):
        for key in ("flow_convergent_cm3s", "flow_uniform_cm3s", "flow_divergent_cm3s"):
            assert new[key] == pytest.approx(float(old[key]), rel=1e-5), (old, key)  # the CSV's 6 digits
    viscous_moved = [float(r["stations_change"]) for r in committed
                     if r["model"] == "viscous" and r["separation"] == "boundary_layer"
                     or r["separation_ratio"] not in ("", "1") and r["model"] == "viscous"]
    bernoulli_ratio = [float(r["stations_change"]) for r in committed
                       if r["model"] == "bernoulli" and r["separation_ratio"] == "1.2"]
    assert max(viscous_moved) < 0.03 < 0.1 < max(bernoulli_ratio)


def test_the_docs_rigid_m5_table_is_the_committed_one():
    """docs/model.md's rigid-M5 table (10 cm H2O, separation at 1.2 A_min, and the viscous
    model's divergent/convergent ratio with the boundary-layer separation) is the committed
    CSV's, to its printed digits."""
    import csv
    import pathlib
    import re

    root = pathlib.Path(__file__).resolve().parents[1]
    rows = {(float(r["diameter_cm"]), r["model"], r["separation"], r["separation_ratio"]): r
            for r in csv.DictReader(open(root / "benchmarks" / "results" / "flow" / "rigid_m5.csv"))
            if float(r["pressure_cmH2O"]) == 10.0}
    text = (root / "docs" / "model.md").read_text()
    lines = re.findall(r"^\| (0\.\d+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \|$",
                       text, re.M)
    assert len(lines) == 6
    for d, *values in lines:
        b, v = rows[(float(d), "bernoulli", "ratio", "1.2")], rows[(float(d), "viscous", "ratio", "1.2")]
        bl = rows[(float(d), "viscous", "boundary_layer", "")]
        expected = [b["flow_convergent_cm3s"], v["flow_convergent_cm3s"], v["flow_uniform_cm3s"],
                    v["flow_divergent_cm3s"], v["divergent_over_convergent"], bl["divergent_over_convergent"]]
        for shown, value in zip(values, expected):
            assert float(shown) == pytest.approx(float(value), rel=6e-4), (d, shown, value)


class _RecordingTract(Tract):
    """A tract that keeps, per sample, the lips' pressure and the flow model's losses it used."""

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        self.lips, self.losses, self.areas = [], [], []

    def sample(self, area, p_lung):
        super().sample(area, p_lung)
        self.lips.append(self.p_L)
        self.losses.append(self.loss)
        self.areas.append(area)


def test_a_coupled_flow_and_tract_balance_lung_work_viscous_dissipation_and_radiation():
    """The viscous model coupled interactively to a lossless radiating tract, between box folds
    whose medial faces swing at 140 Hz (the exit's gap from 0.9 mm open to shut over part of
    each cycle) for 30 ms at 50 us: at every step the flow the folds see is the tract's U (one equation, to 1e-9); over
    the run the lung's work is the jet's, the entrance's and the viscous dissipation plus the
    work on the tract (to 1e-9, the viscous part more than 1 % of it), and that work is the
    tract's energy gain plus what the lips radiated (to 1e-9)."""
    r, l = channel(slope=0.05)
    f = GlottalSlices(r, l, viscous(entrance_loss=0.375), PS, n_stations=60)
    tract = _RecordingTract(np.full(17, 2e-4), 1e-2, rho=RHO, radiation=True, recovery=True)
    e0, h, closed_steps = tract.energy(), 50e-6, 0
    for k in range(1, 601):
        t = k * h
        swing = 0.3e-3 * math.sin(2 * math.pi * 140.0 * t) - 0.05e-3
        xr, xl = r.points.copy(), l.points.copy()
        xr[:, 0] += swing * (1 - (xr[:, 0] - G) / D)
        xl[:, 0] -= swing * (1 - (-G - xl[:, 0]) / D)
        now = {}

        def glottis(a_sep, loss):
            u, p_sub, p_sup = tract.advance(t, a_sep, PS, loss)
            now["u"] = u
            return p_sub, tract.jet_pressure(a_sep, u, p_sup)

        st = f.state(xr, xl, glottis, PS, t)
        closed_steps += int(st.closed)
        assert st.flow == pytest.approx(now["u"], rel=1e-9, abs=1e-15)
    assert 100 < closed_steps < 500  # the glottis shuts and opens
    T = tract.T
    u, p_sup = np.asarray(tract.out["u_glottis"]), np.asarray(tract.out["p_sup"])
    area = np.asarray(tract.areas)
    jet = np.array([(1 - tract.recovered(a)) * RHO * abs(x) ** 3 / (2 * a * a) if a > 0 else 0.0
                    for a, x in zip(area, u)])
    entrance = np.array([lo.quadratic * abs(x) ** 3 for lo, x in zip(tract.losses, u)])
    viscous_part = np.array([lo.linear * x * x for lo, x in zip(tract.losses, u)])
    lung = T * np.sum(PS * u)
    on_tract = T * np.sum(p_sup * u)
    assert lung == pytest.approx(T * np.sum(jet + entrance + viscous_part) + on_tract, rel=1e-9)
    assert T * np.sum(viscous_part) > 0.01 * lung
    radiated = T * np.sum(np.asarray(tract.lips) ** 2) / tract.R
    assert tract.energy() - e0 + radiated == pytest.approx(on_tract, rel=1e-9)
