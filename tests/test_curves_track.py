"""The loop-the-loop track (docs/physics.md §5): geometry continuous across
its pieces, energy conserved without friction, and the frictionless clearing
speed against sqrt(5 g R) as the blends shrink."""

import math

import numpy as np
import pytest

from rampwork.curves import Curve, simulate_curve
from rampwork.errors import ConfigError

G = 9.81


def _ends(radius, blend, run):
    """The arc lengths where the track's pieces meet."""
    arc = 2 * math.pi * radius - blend
    return np.array([run, run + blend, run + blend + arc, run + 2 * blend + arc])


@pytest.mark.parametrize("radius, blend, run", [(1.0, 0.5, 1.0), (2.0, 3.0, 0.5), (0.5, 0.01, 2.0)])
def test_geometry_is_continuous_across_the_pieces(radius, blend, run):
    curve = Curve.create("loop_track", radius=radius, blend_length=blend, run_length=run)
    ends = _ends(radius, blend, run)
    eps = 1e-9
    below, above = curve.evaluate(ends - eps), curve.evaluate(ends + eps)
    for name, tol in (("X", 1e-8), ("Y", 1e-8), ("sin_phi", 1e-8), ("cos_phi", 1e-8)):
        np.testing.assert_allclose(above[name], below[name], atol=tol, err_msg=name)
    # curvature is blended: continuous too (it jumps by 1/R without the blends)
    np.testing.assert_allclose(above["kappa"], below["kappa"], atol=1e-8 / (blend * radius))
    # and the points are the integral of the tangent: compare with a fine trapezoid rule
    s = np.linspace(0.0, ends[-1] + run, 200001)
    frame, points = curve.evaluate(s), curve.evaluate(s)
    ds = np.diff(s)
    x = np.concatenate([[0.0], np.cumsum(0.5 * ds * (frame["cos_phi"][1:] + frame["cos_phi"][:-1]))])
    y = np.concatenate([[0.0], np.cumsum(0.5 * ds * (frame["sin_phi"][1:] + frame["sin_phi"][:-1]))])
    np.testing.assert_allclose(points["X"], x, atol=1e-8 * s[-1])
    np.testing.assert_allclose(points["Y"], y, atol=1e-8 * s[-1])
    # the tangent turns once around, the out-run back at the in-run's height
    end = curve.evaluate([s[-1]])
    assert end["Y"][0] == pytest.approx(0.0, abs=1e-12)
    assert end["X"][0] > run
    top = curve.evaluate([ends[1] + 0.5 * (ends[2] - ends[1])])
    assert top["Y"][0] == pytest.approx(2 * radius + (end["Y"][0]), rel=0.2)


# every method on the loop's closed forms in the default suite (tests/test_curves.py);
# here the track's pieces and joint with two methods, the others in the slow suite
@pytest.mark.parametrize("method, dt, tol", [("rk4", 1e-3, 1e-9), ("dopri5", 1e-3, 1e-6),
                                             pytest.param("dop853", 1e-3, 1e-6, marks=pytest.mark.slow),
                                             pytest.param("semi_implicit_euler", 1e-4, 1e-2,
                                                          marks=pytest.mark.slow)])
def test_energy_is_conserved_without_friction(method, dt, tol):
    curve = Curve.create("loop_track", radius=1.0, blend_length=0.8, run_length=1.0)
    speed = math.sqrt(5.5 * G * 1.0) * np.array([1.0, 1.1, 1.3])
    out = simulate_curve(curve, s0=0.0, u0=speed, method=method, dt=dt, rtol=1e-10)
    assert (out["status_name"] == "exited").all()
    assert out["p_end"] == pytest.approx(2 * 1.0 + 0.8 + 2 * math.pi)
    np.testing.assert_allclose(out["Y_end"], 0.0, atol=1e-12)
    # back at the in-run's height: the same speed, to the method's accuracy
    np.testing.assert_allclose(out["u_end"], speed, rtol=tol)
    assert (out["nu_min"] > 0).all()


def _clears(curve, speed):
    out = simulate_curve(curve, s0=0.0, u0=speed, method="rk4", dt=2e-4, t_max=20.0)
    return out["status_name"] == "exited"


@pytest.mark.parametrize("blend, tol", [(0.05, 1e-4), (0.01, 1e-5)])
def test_minimum_clearing_speed_approaches_sqrt_5gR(blend, tol):
    """Frictionless: nu = u^2 / R - g at the top, u^2 = v0^2 - 4 g R there
    on the circle; the blends shift the clearing speed by a little (measured:
    2e-5 at blend 0.05 R, 8e-7 at 0.01 R, 3e-8 at 0.002 R)."""
    radius = 1.0
    curve = Curve.create("loop_track", radius=radius, blend_length=blend, run_length=0.5)
    v_closed = math.sqrt(5 * G * radius)
    speeds = v_closed * np.linspace(0.99, 1.01, 21)
    cleared = _clears(curve, speeds)
    assert not cleared[0] and cleared[-1]
    assert (np.diff(cleared.astype(int)) >= 0).all()  # faster clears too
    lo, hi = v_closed * 0.999, v_closed * 1.001
    for _ in range(24):  # bisect on the entry speed
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if _clears(curve, mid) else (mid, hi)
    assert abs(hi / v_closed - 1) <= tol


def test_too_slow_lifts_off_in_the_upper_half():
    curve = Curve.create("loop_track", radius=1.0, blend_length=0.2, run_length=0.5)
    out = simulate_curve(curve, s0=0.0, u0=math.sqrt(4.0 * G), method="rk4", dt=1e-3)
    assert out["status_name"][()] == "lifted_off"
    assert 1.0 < out["Y_lift_off"][()] < 2.0  # above the centre: nu = 0 needs cos phi < 0


def test_checks():
    with pytest.raises(ConfigError, match="blend_length"):
        Curve.create("loop_track", radius=1.0, blend_length=7.0)
    with pytest.raises(ConfigError, match="run_length"):
        Curve.create("loop_track", radius=1.0, blend_length=0.5, run_length=-1.0)
    with pytest.raises(ConfigError, match="blend_length"):
        Curve.create("loop_track", radius=1.0, blend_length=-0.1)
