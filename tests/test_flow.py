"""Bernoulli glottal flow against closed forms on straight, convergent and closed channels."""

import numpy as np
import pytest

import vfrs
from vfrs.flow import BernoulliFlow, bernoulli_pressure

PS = 800.0
G, D, H, LZ = 0.2e-3, 4e-3, 3e-3, 10e-3


def channel(slope=0.0, shift_left=0.0):
    """Two boxes facing each other across x = 0; the medial faces are planes whose
    half-gap is G + slope (H - y) (convergent for slope > 0)."""
    folds = []
    for sign, medial in ((1.0, "xmin"), (-1.0, "xmax")):
        b = vfrs.meshes.box((D, H, LZ), (4, 12, 5), origin=(G if sign > 0 else -G - D, 0, 0))
        p = b.points.copy()
        # Move medial faces: right face to x = G + slope (H - y), blending to the lateral wall.
        if sign > 0:
            w = 1 - (p[:, 0] - G) / D
            p[:, 0] += w * slope * (H - p[:, 1])
        else:
            w = 1 - (-G - p[:, 0]) / D
            p[:, 0] -= w * slope * (H - p[:, 1])
            p[:, 0] += w * shift_left
        m = vfrs.Mesh(p, b.tets, surfaces={"medial": b.surfaces[medial]})
        folds.append(m)
    return folds


def test_straight_channel_has_no_pressure():
    r, l = channel()
    f = BernoulliFlow(r, l, PS)
    st = f.state(r.points, l.points)
    assert np.allclose(st.area, 2 * G * LZ, rtol=1e-12)
    assert np.abs(st.pressure).max() == 0.0
    fr, fl, _ = f.forces(r.points, l.points)
    assert np.abs(fr).max() == 0 and np.abs(fl).max() == 0


def test_convergent_channel_follows_bernoulli():
    s = 0.05
    r, l = channel(slope=s)
    f = BernoulliFlow(r, l, PS, n_stations=50)
    st = f.state(r.points, l.points)
    area = 2 * (G + s * (H - st.y)) * LZ
    assert np.allclose(st.area, area, rtol=1e-12)
    exact = PS * (1 - (area.min() / area) ** 2)
    assert np.allclose(st.pressure, exact, rtol=1e-10, atol=1e-9)
    assert st.y_separation == pytest.approx(H)


def test_total_force_equals_the_integral_of_pressure():
    s = 0.05
    r, l = channel(slope=s)
    f = BernoulliFlow(r, l, PS, n_stations=400)
    fr, fl, st = f.forces(r.points, l.points)
    # Exact integral of -p n dA over the right medial plane x = G + s (H - y), whose outward
    # normal is n = (-1, -s, 0)/sqrt(1 + s^2) (it faces the oncoming flow), with
    # dA = sqrt(1 + s^2) dy dz: force = (1, s, 0) * LZ * int p dy.
    y = np.linspace(0, H, 20001)
    area = 2 * (G + s * (H - y)) * LZ
    p = PS * (1 - (area.min() / area) ** 2)
    integral = np.trapezoid(p, y) if hasattr(np, "trapezoid") else np.trapz(p, y)
    expected = np.array([1.0, s, 0.0]) * LZ * integral  # pushed laterally and upwards
    total = fr.sum(axis=0)
    assert np.allclose(total, expected, rtol=2e-3, atol=1e-6 * np.abs(expected).max())
    # Symmetric channel: mirror forces on the left fold.
    assert np.allclose(fl.sum(axis=0), expected * [-1, 1, 1], rtol=2e-3, atol=1e-6 * np.abs(expected).max())


def test_closed_glottis_gives_subglottal_pressure_below_and_none_above():
    s = 0.05
    # Move the left fold across so that the top of the channel closes.
    r, l = channel(slope=s, shift_left=2 * G + 2 * s * 0.5e-3)
    f = BernoulliFlow(r, l, PS, n_stations=61)
    st = f.state(r.points, l.points)
    assert st.closed
    y_close = H - 0.5e-3
    below, above = st.y < y_close - 1e-9, st.y > y_close + H / 60
    assert np.all(st.pressure[below] == PS) and np.all(st.pressure[above] == 0)


def test_separation_ratio_moves_the_jet_downstream():
    y = np.linspace(0, 1, 6)
    A = np.array([4.0, 2.0, 1.0, 1.1, 1.3, 2.0])
    p1, ys1, _ = bernoulli_pressure(y, A, PS, 1.0)
    p2, ys2, _ = bernoulli_pressure(y, A, PS, 1.2)
    assert ys1 == y[2] and ys2 == y[4]
    assert p2[2] < 0  # suction between the minimum and the separation point
    assert p2[4] == pytest.approx(0.0) and p2[5] == 0.0
    with pytest.raises(vfrs.VfrsError, match="separation_ratio"):
        BernoulliFlow(*channel(), PS, separation_ratio=0.5)
