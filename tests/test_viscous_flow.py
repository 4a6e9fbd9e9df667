"""The viscous slit flow's equations (vfrs.flow.models.viscous; issue 46, items 1 and 3): closed forms
(Poiseuille through a parallel slit and through a slit whose width varies linearly along z,
Bernoulli recovered with no viscosity), the balance of the pressure drop, a slit that closes
along z or along y. Not yet a [flow] model: these test the equations it will solve."""

from __future__ import annotations

import numpy as np
import pytest

from vfrs.flow.models.bernoulli import bernoulli_pressure
from vfrs.flow.models.viscous import AIR_VISCOSITY, slit_integrals, viscous_flow

RHO = 1.14  # kg/m^3
LY, LZ = 3e-3, 14e-3  # the slit's length along the flow and across it (m)


def uniform_slit(g, n_y=7, n_z=5):
    """A slit of constant width ``g`` (m): stations along y, its integrals across z."""
    y = np.linspace(0.0, LY, n_y)
    z = np.linspace(0.0, LZ, n_z)
    A, G3 = slit_integrals(z, np.full((n_y, n_z), g))
    return y, A, G3


def profiles():
    rng = np.random.default_rng(3)
    return (np.linspace(8e-6, 2e-6, 12), np.linspace(2e-6, 8e-6, 12), 2e-6 + 6e-6 * rng.random(12))


def test_no_viscosity_is_bernoulli():
    """mu = 0: the pressure is bernoulli_pressure's at every station (convergent, divergent
    and mixed profiles, separation at the narrowest station), and the flow is the separation
    area times sqrt(2 p_s / rho)."""
    y = np.linspace(0.0, LY, 12)
    for area in profiles():
        s = viscous_flow(y, area, np.full(12, 1e-15), 800.0, rho=RHO, mu=0.0)
        p, y_sep, closed = bernoulli_pressure(y, area, 800.0)
        np.testing.assert_allclose(s.pressure, p, rtol=0, atol=1e-10)
        assert (s.y_separation, s.closed) == (y_sep, closed)
        assert s.flow == pytest.approx(area[s.index] * np.sqrt(2 * 800.0 / RHO), rel=1e-14)
        assert s.viscous == 0.0 and s.inertial == pytest.approx(800.0, rel=1e-14)


def test_separation_by_a_ratio_is_where_the_area_reaches_it():
    """mu = 0, separation_ratio = 1.2: the jet leaves where the area, linear between the
    stations, reaches 1.2 A_min (not at the next station, as bernoulli_pressure does), so the
    flow is 1.2 A_min sqrt(2 p_s / rho) on any stations; Bernoulli's pressure up to there, 0
    after; a profile that never reaches it separates at its last station."""
    y = np.linspace(0.0, LY, 12)
    for area in profiles():
        s = viscous_flow(y, area, np.full(12, 1e-15), 800.0, rho=RHO, mu=0.0, separation_ratio=1.2)
        i_min = int(np.argmin(area))
        reach = np.flatnonzero(area[i_min:] >= 1.2 * area[i_min])
        if not reach.size:
            assert s.y_separation == y[-1] and s.flow == pytest.approx(area[-1] * np.sqrt(2 * 800.0 / RHO))
            continue
        i = i_min + int(reach[0])
        a_sep = 1.2 * area[i_min]
        w = (a_sep - area[i - 1]) / (area[i] - area[i - 1])
        assert s.y_separation == pytest.approx(y[i - 1] + w * (y[i] - y[i - 1]), rel=1e-14)
        assert s.flow == pytest.approx(a_sep * np.sqrt(2 * 800.0 / RHO), rel=1e-14)
        attached = np.arange(12) < i
        np.testing.assert_allclose(s.pressure[attached], 800.0 * (1 - (a_sep / area[attached]) ** 2), atol=1e-10)
        assert np.all(s.pressure[~attached] == 0.0)


def test_parallel_slit_is_poiseuille():
    """rho = 0, a slit of constant width g: U = dp g^3 L_z / (12 mu L_y), the pressure falls
    linearly from p_s to p_e (here 100 Pa), on any number of stations."""
    g = 0.1e-3
    for n_y in (2, 5, 11):
        y, A, G3 = uniform_slit(g, n_y=n_y)
        s = viscous_flow(y, A, G3, 900.0, rho=0.0, exit_pressure=100.0)
        assert s.flow == pytest.approx(800.0 * g**3 * LZ / (12 * AIR_VISCOSITY * LY), rel=1e-13)
        np.testing.assert_allclose(s.pressure, 900.0 - 800.0 * y / LY, rtol=0, atol=1e-10)
        assert s.viscous == pytest.approx(800.0, rel=1e-13) and s.inertial == 0.0


@pytest.mark.parametrize("n_z", [2, 3, 8])
def test_slit_linear_along_z(n_z):
    """A slit whose width grows linearly across z, g0 = 20 um to g1 = 200 um, the same at every
    station: A = L_z (g0 + g1) / 2 and G3 = L_z (g1^4 - g0^4) / (4 (g1 - g0)) exactly on any
    sampling of z, and the Poiseuille flow U = dp G3 / (12 mu L_y)."""
    g0, g1 = 20e-6, 200e-6
    z = np.linspace(0.0, LZ, n_z)
    gap = np.tile(g0 + (g1 - g0) * z / LZ, (4, 1))
    A, G3 = slit_integrals(z, gap)
    np.testing.assert_allclose(A, LZ * (g0 + g1) / 2, rtol=1e-14)
    g3 = LZ * (g1**4 - g0**4) / (4 * (g1 - g0))
    np.testing.assert_allclose(G3, g3, rtol=1e-14)
    s = viscous_flow(np.linspace(0.0, LY, 4), A, G3, 800.0, rho=0.0)
    assert s.flow == pytest.approx(800.0 * g3 / (12 * AIR_VISCOSITY * LY), rel=1e-13)


def test_a_slit_closed_over_part_of_z_counts_its_open_part_only():
    """A gap going linearly from -100 um to +100 um across z (the folds touching over the first
    half): the open half is a triangle, A = L_z / 2 * 100 um / 2, G3 = L_z / 2 * (100 um)^3 / 4,
    whether or not a sample falls on the zero crossing."""
    h = 100e-6
    for z in (np.array([0.0, LZ]), np.linspace(0.0, LZ, 3), np.array([0.0, 0.3 * LZ, LZ])):
        A, G3 = slit_integrals(z, [-h + 2 * h * z / LZ])
        assert A[0] == pytest.approx(LZ / 2 * h / 2, rel=1e-13)
        assert G3[0] == pytest.approx(LZ / 2 * h**3 / 4, rel=1e-13)
    A, G3 = slit_integrals(np.array([0.0, LZ]), [[-h, -h / 2]])
    assert A[0] == 0.0 and G3[0] == 0.0


def test_the_drop_is_inertial_plus_viscous_and_viscosity_rules_a_narrow_slit():
    """Air through a 3 mm deep, 14 mm long uniform slit at 800 Pa: the inertial part (rho U^2 /
    2 A^2) and the viscous part (12 mu U L_y / G3) sum to the drive; the viscous part is a few
    per cent at 1 mm, most of it at 20 um, where Bernoulli alone would let through an order of
    magnitude more air."""
    share = {}
    for g in (1e-3, 0.2e-3, 20e-6):
        y, A, G3 = uniform_slit(g)
        s = viscous_flow(y, A, G3, 800.0, rho=RHO)
        assert s.inertial + s.viscous == pytest.approx(800.0, rel=1e-12)
        assert s.inertial == pytest.approx(0.5 * RHO * (s.flow / A[s.index]) ** 2, rel=1e-12)
        share[g] = s.viscous / 800.0
        bernoulli = A[0] * np.sqrt(2 * 800.0 / RHO)
        assert s.flow < bernoulli
    assert share[1e-3] < 0.05 < 0.9 < share[20e-6] and share[1e-3] < share[0.2e-3] < share[20e-6]
    y, A, G3 = uniform_slit(20e-6)
    assert viscous_flow(y, A, G3, 800.0, rho=RHO).flow < 0.1 * A[0] * np.sqrt(2 * 800.0 / RHO)


def test_a_closed_station_stops_the_flow():
    y = np.linspace(0.0, LY, 5)
    area = np.array([4e-6, 2e-6, 0.0, 1e-6, 3e-6])
    s = viscous_flow(y, area, area**3, 800.0, rho=RHO)
    assert s.closed and s.flow == 0.0 and s.y_separation == y[2]
    np.testing.assert_array_equal(s.pressure, [800.0, 800.0, 0.0, 0.0, 0.0])


def test_bad_arguments_are_refused():
    y = np.linspace(0.0, LY, 3)
    with pytest.raises(ValueError, match="same length"):
        viscous_flow(y, np.ones(2), np.ones(3), 800.0, rho=RHO)
    with pytest.raises(ValueError, match="rho, mu and entrance_loss must be >= 0"):
        viscous_flow(y, np.ones(3), np.ones(3), 800.0, rho=RHO, mu=-1.0)
    with pytest.raises(ValueError, match="increasing"):
        slit_integrals(np.array([0.0, 0.0]), np.ones((1, 2)))
