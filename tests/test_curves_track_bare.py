"""The loop-the-loop track without blends (``blend_length = 0``, docs/physics.md
§5.2): a straight in-run, a circle and a straight out-run meeting at two
curvature jumps, each a joint event.  Against energy conservation and the
loop's contact condition without friction, the closed forms of the straights
and of the circle (a linear ODE in u²) with friction, and the methods'
orders across both joints."""

import math

import numpy as np
import pytest

from rampwork.curves import Curve, curve_kernel_for, prepare_curve_run, simulate_curve
from rampwork.errors import ConfigError

G = 9.81
RADIUS, RUN = 1.0, 1.0


def _track(radius=RADIUS, run=RUN):
    return Curve.create("loop_track", radius=radius, blend_length=0.0, run_length=run)


def _circle_u2(theta, w0, mu, radius=RADIUS):
    """u² after turning theta inside a circle with friction, from u² = w0:
    d(u²)/dtheta = -2 mu u² - 2 g R (sin theta + mu cos theta), exactly."""
    a = 2.0 * mu
    e = np.exp(a * theta)
    sin_part = (e * (a * np.sin(theta) - np.cos(theta)) + 1.0) / (a * a + 1.0)
    cos_part = (e * (a * np.cos(theta) + np.sin(theta)) - a) / (a * a + 1.0)
    return (w0 - 2.0 * G * radius * (sin_part + mu * cos_part)) / e


def _exit_speed(u0, mu, radius=RADIUS, run=RUN):
    """The exact speed at the out-run's end (the block clears the loop)."""
    w1 = u0 * u0 - 2.0 * mu * G * run
    return math.sqrt(_circle_u2(2.0 * math.pi, w1, mu, radius) - 2.0 * mu * G * run)


def test_the_circle_closed_form_against_quadrature():
    from scipy.integrate import solve_ivp

    mu, w0 = 0.15, 90.0
    solution = solve_ivp(lambda th, w: -2 * mu * w - 2 * G * RADIUS * (np.sin(th) + mu * np.cos(th)),
                         (0.0, 2 * math.pi), [w0], rtol=1e-13, atol=1e-12, dense_output=True)
    theta = np.linspace(0.0, 2 * math.pi, 9)
    np.testing.assert_allclose(_circle_u2(theta, w0, mu), solution.sol(theta)[0], rtol=1e-11)


def test_geometry_two_curvature_jumps_and_a_continuous_track():
    track = _track(radius=1.5, run=0.7)
    joints = np.array([0.7, 0.7 + 3 * math.pi])
    eps = 1e-9
    below, above = track.evaluate(joints - eps), track.evaluate(joints + eps)
    for name in ("X", "Y", "sin_phi", "cos_phi"):
        np.testing.assert_allclose(above[name], below[name], atol=1e-8, err_msg=name)
    np.testing.assert_array_equal(below["kappa"], [0.0, 1 / 1.5])
    np.testing.assert_array_equal(above["kappa"], [1 / 1.5, 0.0])
    top = track.evaluate([0.7 + 1.5 * math.pi])
    np.testing.assert_allclose([top["X"][0], top["Y"][0], top["cos_phi"][0]], [0.7, 3.0, -1.0],
                               atol=1e-14)
    end = track.evaluate([2 * 0.7 + 3 * math.pi])
    np.testing.assert_allclose([end["X"][0], end["Y"][0]], [1.4, 0.0], atol=1e-14)
    with pytest.raises(ConfigError, match="blend_length"):
        Curve.create("loop_track", radius=1.0, blend_length=-0.1)


# the first-order methods and dop853 frictionless in the slow suite (the friction
# tests below run Euler-type and the pairs through both joints in the default one)
FRICTIONLESS = [pytest.param("euler", {"dt": 1e-5}, 2e-3, marks=pytest.mark.slow),
                pytest.param("semi_implicit_euler", {"dt": 1e-5}, 2e-3, marks=pytest.mark.slow),
                ("rk4", {"dt": 1e-3}, 1e-9), ("dopri5", {"rtol": 1e-10}, 1e-7),
                pytest.param("dop853", {"rtol": 1e-10}, 1e-7, marks=pytest.mark.slow)]


@pytest.mark.parametrize("method, settings, tol", FRICTIONLESS)
def test_frictionless_clears_iff_five_g_r_and_conserves_energy(method, settings, tol):
    ratios = np.array([4.6, 4.9, 5.1, 5.6])  # u0² / (g R)
    u0 = np.sqrt(ratios * G * RADIUS)
    out = simulate_curve(_track(), s0=0.0, u0=u0, mu_k=0.0, method=method, **settings)
    assert out["status_name"].tolist() == ["lifted_off"] * 2 + ["exited"] * 2
    clear = ratios > 5
    np.testing.assert_allclose(out["u_end"][clear], u0[clear], rtol=tol)
    np.testing.assert_allclose(out["X_end"][clear], 2 * RUN, atol=1e-12)
    # the lift-off angle by energy: u² = u0² - 2 g R (1 - cos θ) and u²/R = -g cos θ
    theta = np.arccos((2.0 - ratios[~clear]) / 3.0)
    np.testing.assert_allclose(out["p_lift_off"][~clear] - RUN, theta, atol=50 * tol)
    assert np.all(np.abs(out["energy_balance_error"]) < 10 * tol * u0 ** 2)


def _trace(method, u0, mu, **settings):
    run = prepare_curve_run(_track(), s0=0.0, u0=u0, mu_k=mu, method=method, **settings)
    return run.run(), run.trace(0)


@pytest.mark.parametrize("method, settings, tol", [
    ("rk4", {"dt": 1e-3}, 2e-10), ("dopri5", {"rtol": 1e-10}, 1e-8),
    pytest.param("euler", {"dt": 1e-4}, 2e-3, marks=pytest.mark.slow)])  # its trace variant: slow
def test_with_friction_every_piece_follows_its_closed_form(method, settings, tol):
    u0, mu = 10.0, 0.1
    out, trace = _trace(method, u0, mu, **settings)
    assert out["status_name"] == "exited"
    s, u2 = trace[1], trace[2] ** 2
    joint, joint2 = RUN, RUN + 2 * math.pi * RADIUS
    # steps end just past each joint (within a few ulps), never straddle one
    for j in (joint, joint2):
        assert np.min(np.abs(s - j)) < 1e-14
    into = u0 * u0 - 2 * mu * G * np.minimum(s, joint)
    w1 = u0 * u0 - 2 * mu * G * joint
    on_circle = (s >= joint) & (s <= joint2)
    w2 = _circle_u2(2 * math.pi, w1, mu)
    exact = np.where(s < joint, into, np.where(
        on_circle, _circle_u2((np.clip(s, joint, joint2) - joint) / RADIUS, w1, mu),
        w2 - 2 * mu * G * (s - joint2)))
    # a sample a few ulps past a joint is on the old piece's continuation: same value to 1e-13
    np.testing.assert_allclose(u2, exact, rtol=tol, atol=1e-12)
    np.testing.assert_allclose(out["u_end"], _exit_speed(u0, mu), rtol=tol)


@pytest.mark.parametrize("method, dts, order", [
    ("euler", (4e-4, 2e-4, 1e-4), 1.0),
    pytest.param("semi_implicit_euler", (4e-4, 2e-4, 1e-4), 1.0, marks=pytest.mark.slow),
    ("rk4", (2e-2, 1e-2, 5e-3), 4.0),
])
def test_the_joints_keep_the_methods_order(method, dts, order):
    u0, mu = 10.0, 0.1
    exact = _exit_speed(u0, mu)
    errors = []
    for dt in dts:
        out = simulate_curve(_track(), s0=0.0, u0=u0, mu_k=mu, method=method, dt=dt)
        assert out["status_name"] == "exited"
        errors.append(abs(float(out["u_end"]) - exact))
    observed = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(observed - order) < 0.15), observed


@pytest.mark.parametrize("rtol", [1e-6, 1e-8, 1e-10])
@pytest.mark.parametrize("method", ["dopri5", pytest.param("dop853", marks=pytest.mark.slow)])
def test_adaptive_pairs_within_ten_times_rtol_across_the_joints(method, rtol):
    u0, mu = 10.0, 0.1
    out = simulate_curve(_track(), s0=0.0, u0=u0, mu_k=mu, method=method, dt=1e-3, rtol=rtol)
    assert abs(float(out["u_end"]) / _exit_speed(u0, mu) - 1.0) < 10 * rtol


def test_blended_tracks_compile_without_joints_and_a_mixed_sweep_is_bit_for_bit():
    blended = prepare_curve_run(Curve.create("loop_track", radius=1.0, blend_length=0.4),
                                s0=0.0, u0=9.0, mu_k=0.1, kernel="specialised")
    spec = blended.kernel  # the kernel without the joint logic, as before joints were two
    assert spec is curve_kernel_for(Curve.create("loop_track", radius=1.0, blend_length=0.4).spec,
                                    "rk4", one_sided=True, friction=True, drag_linear=False,
                                    drag_quadratic=False, joints=False)
    assert np.isnan(blended.inputs[-2:]).all()  # no joints
    blends = np.array([0.0, 0.4, 0.0, 0.8])
    u0 = np.array([10.0, 9.0, 6.0, 11.0])
    track = Curve.create("loop_track", radius=1.0, blend_length=0.4)
    together = simulate_curve(track, s0=0.0, u0=u0, mu_k=0.1, blend_length=blends)
    for k in range(blends.size):
        alone = simulate_curve(Curve.create("loop_track", radius=1.0, blend_length=blends[k]),
                               s0=0.0, u0=u0[k], mu_k=0.1)
        for name in ("t_end", "p_end", "u_end", "W_friction", "steps", "path_length_X"):
            assert together[name][k] == alone[name], (name, k)
