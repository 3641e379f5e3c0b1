"""The parametric C2 spline through points (docs/physics.md §5): against the
circle's closed-form frame (orders 4, 3, 2 for point, tangent, curvature),
energy without friction, a vertical tangent inside it, and its checks."""

import math

import numpy as np
import pytest

from rampwork.curves import Curve, simulate_curve
from rampwork.errors import ConfigError

G = 9.81
TURN = 1.5 * math.pi  # an arc of the unit circle from the bottom, past two vertical tangents


def _circle_spline(points, end="clamped"):
    theta = np.linspace(0.0, TURN, points)
    tangents = ((1.0, 0.0), (math.cos(TURN), math.sin(TURN)))
    return Curve.through_points(np.sin(theta), 1.0 - np.cos(theta), end=end,
                                end_tangents=tangents if end == "clamped" else None)


def _errors(curve):
    t = np.linspace(0.0, curve.domain()[1][0], 4001)
    e = curve.evaluate(t)
    theta = np.arctan2(e["X"], 1.0 - e["Y"]) % (2 * math.pi)  # the circle's angle of the point
    radial = np.abs(np.hypot(e["X"], 1.0 - e["Y"]) - 1.0)
    tangent = np.hypot(e["cos_phi"] - np.cos(theta), e["sin_phi"] - np.sin(theta))
    return radial.max(), tangent.max(), np.abs(e["kappa"] - 1.0).max()


def test_circle_frame_to_spline_accuracy():
    coarse, fine = _errors(_circle_spline(25)), _errors(_circle_spline(49))
    orders = [math.log2(c / f) for c, f in zip(coarse, fine)]
    assert orders[0] > 3.7 and orders[1] > 2.7 and orders[2] > 1.7, orders
    assert fine[0] < 1e-6 and fine[1] < 1e-4 and fine[2] < 1e-2


def test_chord_parameter_speed():
    curve = _circle_spline(25)
    e = curve.evaluate(np.linspace(0.0, curve.domain()[1][0], 101))
    # dp/ds = 1 / |r'(t)|: near 1 for the chord-length parameter, not exactly 1
    assert np.all(np.abs(e["dp_ds"] - 1.0) < 5e-3) and np.ptp(e["dp_ds"]) > 0


# every method on the loop's closed forms in the default suite (tests/test_curves.py);
# here the spline's frame with two methods, the others in the slow suite
@pytest.mark.parametrize("method, dt, tol", [("rk4", 1e-3, 1e-8), ("dopri5", 1e-3, 1e-6),
                                             pytest.param("dop853", 1e-3, 1e-6, marks=pytest.mark.slow),
                                             pytest.param("euler", 1e-5, 1e-2, marks=pytest.mark.slow)])
def test_energy_and_vertical_tangents_without_friction(method, dt, tol):
    """Inside the circle spline, fast enough to go round past both vertical
    tangents (theta = pi/2 and 3 pi/2) and out at its end."""
    curve = _circle_spline(25)
    speed = np.array([8.0, 9.0])
    out = simulate_curve(curve, s0=0.0, u0=speed, method=method, dt=dt, rtol=1e-10)
    assert (out["status_name"] == "exited").all()
    assert out["X_end"] == pytest.approx(-1.0, abs=1e-12)
    expected = np.sqrt(speed ** 2 - 2 * G * out["Y_end"])
    np.testing.assert_allclose(out["u_end"], expected, rtol=tol)
    assert (out["nu_min"] > 0).all()


def test_at_rest_inside_near_a_vertical_tangent():
    """At rest inside, just above the vertical tangent, nu = g cos phi < 0:
    it falls off; just below it slides back down, energy kept."""
    curve = _circle_spline(49)
    end = curve.domain()[1][0]
    above = end * (0.5 * math.pi + 0.05) / TURN
    out = simulate_curve(curve, s0=above, u0=0.0, method="rk4", dt=1e-3)
    assert out["status_name"][()] == "lifted_off" and out["t_end"][()] == 0.0
    below = end * (0.5 * math.pi - 0.05) / TURN
    out = simulate_curve(curve, s0=below, u0=0.0, method="rk4", dt=1e-3, t_max=0.5)
    assert out["status_name"][()] == "timeout" and out["u_end"][()] < 0  # sliding back
    assert abs(out["energy_balance_error"][()]) < 1e-9


def test_natural_ends_have_no_curvature():
    e = _circle_spline(13, end="natural").evaluate([0.0])
    assert abs(e["kappa"][0]) < 1e-12


def test_checks():
    with pytest.raises(ConfigError, match="distinct"):
        Curve.through_points([0, 1, 0], [0, 1, 0])
    with pytest.raises(ConfigError, match="at least 3"):
        Curve.through_points([0, 1], [0, 1])
    with pytest.raises(ConfigError, match="crosses itself"):  # a figure eight
        theta = np.linspace(0, 1.9 * math.pi, 30)
        Curve.through_points(np.sin(2 * theta), np.sin(theta))
    theta = np.linspace(0, 1.9 * math.pi, 30)
    Curve.through_points(np.sin(2 * theta), np.sin(theta), allow_crossing=True)
    with pytest.raises(ConfigError, match="regular"):  # a hairpin: min |r'| = 5e-4
        Curve.through_points([0.0, 1.0, 0.0], [0.0, 0.0, 0.001])
    with pytest.raises(ConfigError, match="end_tangents"):
        Curve.through_points([0, 1, 2], [0, 1, 0], end="clamped")
    with pytest.raises(ConfigError, match="s0"):
        simulate_curve(_circle_spline(13), s0=-0.1, u0=1.0)
    with pytest.raises(ConfigError, match="curve.radius"):
        simulate_curve(_circle_spline(13), s0=0.0, u0=1.0, radius=[1.0, 2.0])
