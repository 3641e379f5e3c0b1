"""Hard cases on curves (docs/physics.md §5) not covered by test_curves.py:
at rest on a vertical tangent with friction, and coming to rest exactly at
the top of a loop.  (A normal force that touches 0 without crossing it and
a curvature jump at a joint are in test_curves.py.)  Expected values: the
exact solution of the circular arc with friction, and an independent
high-accuracy integration (scipy's DOP853) of the same ODE in u^2."""

from __future__ import annotations

import math

import pytest
from scipy.integrate import solve_ivp

from rampwork.curves import Curve, simulate_curve

G = 9.81
METHODS = ("euler", "semi_implicit_euler", "rk4", "dopri5", "dop853")
STEP = {"euler": 1e-5, "semi_implicit_euler": 1e-5, "rk4": 1e-3, "dopri5": 1e-3, "dop853": 1e-3}
TOL = {"euler": 2e-3, "semi_implicit_euler": 2e-3, "rk4": 1e-9, "dopri5": 1e-7, "dop853": 1e-7}
RTOL = 1e-11  # the adaptive pairs'


def _arc_speed_squared(theta, theta0, w0, mu, radius, d):
    """u^2 on the inside of a circle at angle theta from the bottom, moving
    with direction d (+1: counter-clockwise) from u^2 = w0 at theta0, where
    nu > 0: d(u^2)/dtheta = -2 d mu u^2 - 2 g R (sin theta + d mu cos theta),
    a linear ODE (its exact solution)."""
    mu = d * mu
    a = 2 * mu

    def primitive(psi):
        return math.exp(a * (psi - theta0)) * ((a * math.sin(psi) - math.cos(psi))
                                               + mu * (a * math.cos(psi) + math.sin(psi))) / (1 + a * a)

    return math.exp(-a * (theta - theta0)) * (w0 - 2 * G * radius * (primitive(theta) - primitive(theta0)))


def _run(curve, method, **kwargs):
    return simulate_curve(curve, method=method, dt=STEP[method], rtol=RTOL, **kwargs)


# ------------------------------------------------------------------------------
# at rest exactly on a vertical tangent, with friction
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("method", METHODS)
def test_at_rest_on_a_vertical_tangent_with_friction_slides_down_in_contact(method):
    """Inside a circle at its equator (theta = pi/2): at rest nu = g cos phi
    is 0 (to rounding), so friction holds nothing and the block starts down;
    the surface curves towards it, so nu grows from 0 and it stays in
    contact down to the bottom, with the exact solution's speed there."""
    radius, mu = 0.9, 0.3
    arc = Curve.create("loop", radius=radius, entry_angle=0.0, exit_angle=0.5 * math.pi)
    top = arc.domain()[1][0]
    frame = arc.evaluate(top)
    assert abs(frame["cos_phi"][0]) < 1e-16 and frame["sin_phi"][0] == 1.0
    out = _run(arc, method, s0=top, u0=0.0, mu_k=mu, mu_s=mu)
    assert out["status_name"][()] == "exited" and out["p_end"] == 0.0
    assert out["nu_min"] >= 0.0 and out["n_reversals"] == 0
    expected = -math.sqrt(_arc_speed_squared(0.0, 0.5 * math.pi, 0.0, mu, radius, -1.0))
    assert out["u_end"] == pytest.approx(expected, rel=TOL[method])
    work = 0.5 * expected ** 2 - G * radius  # energy lost: g R at the start, u^2/2 at the bottom
    assert out["W_friction"] == pytest.approx(-work, rel=10 * TOL[method])
    assert out["path_length_X"] == pytest.approx(radius, rel=1e-14)


@pytest.mark.parametrize("method", METHODS)
def test_at_rest_on_a_vertical_tangent_bending_away_leaves_at_once(method):
    """The outside of a circle at its equator (side right): nothing holds the
    block, whatever the friction: lift-off at t = 0."""
    arc = Curve.create("loop", side="right", radius=1.0, entry_angle=0.0, exit_angle=0.5 * math.pi)
    top = arc.domain()[1][0]
    out = _run(arc, method, s0=top, u0=0.0, mu_k=0.5, mu_s=0.8)
    assert out["status_name"][()] == "lifted_off"
    assert out["t_end"] == 0.0 and out["steps"] == 0 and out["p_lift_off"] == top


# ------------------------------------------------------------------------------
# coming to rest exactly at the top of a loop
# ------------------------------------------------------------------------------
def _bead_speed_to_stop_at_the_top(radius, mu):
    """The bottom speed of a bead (two-sided) that comes to rest exactly at
    the top: d(u^2)/dtheta = -2 g R sin theta - 2 mu R |nu|, nu = u^2 / R +
    g cos theta, integrated backwards from u^2 = 0 at theta = pi (DOP853,
    rtol 1e-13, the kink of |nu| located as an event)."""
    def rhs(theta, w):
        return [-2 * G * radius * math.sin(theta) - 2 * mu * abs(w[0] + G * radius * math.cos(theta))]

    def switch(theta, w):
        return w[0] + G * radius * math.cos(theta)

    first = solve_ivp(rhs, (math.pi, 0.0), [0.0], method="DOP853", rtol=1e-13, atol=1e-14,
                      events=switch)
    theta_switch, w_switch = first.t_events[0][0], first.y_events[0][0][0]
    second = solve_ivp(rhs, (theta_switch, 0.0), [w_switch], method="DOP853", rtol=1e-13,
                       atol=1e-14)
    return math.sqrt(second.y[0, -1])


@pytest.mark.parametrize("method", METHODS)
def test_a_bead_with_friction_comes_to_rest_at_the_top_of_a_loop(method):
    """A bead on a circular wire, launched from the bottom with just the
    speed to reach the top: nu changes sign on the way (an event that flips
    the contact side), it stops at the top, where static friction holds it
    (tan 0 <= mu_s)."""
    radius, mu = 1.0, 0.2
    u0 = _bead_speed_to_stop_at_the_top(radius, mu)
    assert u0 ** 2 > 5 * G * radius  # friction: more than the frictionless loop needs
    loop = Curve.create("loop", radius=radius)
    out = _run(loop, method, s0=0.0, u0=u0, mu_k=mu, contact="two_sided")
    assert out["status_name"][()] == "stuck" and out["u_end"] == 0.0
    assert out["p_end"] == pytest.approx(math.pi * radius, abs=10 * TOL[method])
    assert out["nu_min"] < 0  # pulled from the other side near the top
    assert out["Y_end"] == pytest.approx(2 * radius, abs=10 * TOL[method])
    assert abs(out["energy_balance_error"]) < 10 * TOL[method] * u0 ** 2


@pytest.mark.parametrize("method", ("rk4", "dopri5", "dop853"))
def test_a_block_inside_cannot_come_to_rest_at_the_top(method):
    """The same start on the inside (one-sided): nu reaches 0 before the
    top, at the angle where u^2 = -g R cos theta, and the block leaves."""
    radius, mu = 1.0, 0.2
    u0 = _bead_speed_to_stop_at_the_top(radius, mu)
    out = _run(Curve.create("loop", radius=radius), method, s0=0.0, u0=u0, mu_k=mu)
    assert out["status_name"][()] == "lifted_off"
    theta = out["p_lift_off"] / radius
    assert 0.5 * math.pi < theta < math.pi
    assert out["u_end"] ** 2 == pytest.approx(-G * radius * math.cos(theta), rel=1e-8)
    w = _arc_speed_squared(theta, 0.0, u0 * u0, mu, radius, 1.0)
    assert out["u_end"] ** 2 == pytest.approx(w, rel=1e-7)
