"""A dip of the normal force through 0 and back inside one step (docs/physics.md §5.1).

Near u_bottom^2 = 5 g R the frictionless loop's nu = g (u^2 / (g R) - 2 +
3 cos theta) dips below 0 for a short arc at the top: a step that starts
before it and ends after it sees nu > 0 at both ends.  The kernel looks at
the stages inside the step (and the parabolas through them): an adaptive
step is refused and halved, a fixed step probes its first half, until the
event shows at a step's end.  Expected values: energy conservation with
nu = 0 (the lift-off angle), and the exact solution of the circular arc
with friction, piecewise between the zeros of nu (a bead's contact
switches).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from rampwork.curves import Curve, simulate_curve

G = 9.81
ADAPTIVE = ("dopri5", "dop853")


def _lift_off_angle(ratio):
    """The frictionless loop at u_bottom^2 = ratio g R (2 < ratio < 5): where
    nu = 0 first, cos theta = (2 - ratio) / 3."""
    return math.acos((2 - ratio) / 3)


@pytest.mark.parametrize("method", ADAPTIVE)
@pytest.mark.parametrize("ratio", [4.95, 4.99])
def test_a_dip_just_below_five_g_r_lifts_off_at_a_coarse_tolerance(method, ratio):
    """At rtol 1e-4 the pairs take 5 to 8 steps over the loop, longer than
    the arc where nu < 0 (0.16 rad at 4.99 g R): each step's end alone
    misses the dip on some of them (dop853 at 4.99 exited before)."""
    loop = Curve.create("loop", radius=1.0)
    rtol = 1e-4
    out = simulate_curve(loop, s0=0.0, u0=math.sqrt(ratio * G), method=method, rtol=rtol)
    assert out["status_name"][()] == "lifted_off"
    theta = _lift_off_angle(ratio)
    assert abs(out["p_lift_off"] - theta) < 10 * rtol
    # the speed that energy gives there: u^2 = -g R cos theta (nu = 0)
    assert out["u_end"] ** 2 == pytest.approx(-G * math.cos(theta), rel=10 * rtol)


def test_rk4_sees_a_dip_between_its_steps_ends_through_its_midpoint_stages():
    """RK4 keeps its step: where a midpoint stage has nu <= 0 and the end
    not, the half step probes the dip and, where its end sees it, the event
    is located in it.  At 4.99 g R and dt from 0.03 to 0.12 s (the dip lasts
    0.053 s) the step ends alone missed it at 5 of these 19 steps; every
    one now leaves at the closed-form angle to RK4's accuracy."""
    loop = Curve.create("loop", radius=1.0)
    theta = _lift_off_angle(4.99)
    for dt in np.linspace(0.03, 0.12, 19):
        out = simulate_curve(loop, s0=0.0, u0=math.sqrt(4.99 * G), method="rk4", dt=float(dt))
        assert out["status_name"][()] == "lifted_off", dt
        assert abs(out["p_lift_off"] - theta) < 30 * dt ** 4, dt


@pytest.mark.parametrize("method", ("euler", "semi_implicit_euler"))
def test_first_order_methods_see_a_dip_at_their_steps_ends(method):
    """The Euler methods have no stage inside a step: a dip is seen where a
    step ends in it, as with short steps (dt = 1e-4 s, 3e-4 rad at the top,
    against the 0.16 rad of the dip)."""
    loop = Curve.create("loop", radius=1.0)
    out = simulate_curve(loop, s0=0.0, u0=math.sqrt(4.99 * G), method=method, dt=1e-4)
    assert out["status_name"][()] == "lifted_off"
    # first order: the energy error over the climb, ~1e-3 in theta
    assert abs(out["p_lift_off"] - _lift_off_angle(4.99)) < 2e-2


@pytest.mark.parametrize("method", ADAPTIVE)
@pytest.mark.parametrize("contact", ["one_sided", "two_sided"])
@pytest.mark.parametrize("rtol", [1e-5, 1e-7, 1e-9])
def test_a_graze_at_exactly_five_g_r_still_goes_over(method, contact, rtol):
    """u_bottom^2 = 5 g R: nu touches 0 at the top without crossing it.  The
    parabolas through the stages there dip to ~0; a step so refused is
    halved, and the block still goes over, nu never below 0 at a step's end.
    (At rtol 1e-4 dopri5 loses 3e-5 of u^2 on the climb: its own nu does
    cross 0, 0.006 rad before the top, and it leaves there.)"""
    loop = Curve.create("loop", radius=1.0)
    out = simulate_curve(loop, s0=0.0, u0=math.sqrt(5 * G), method=method, rtol=rtol,
                         contact=contact)
    assert out["status_name"][()] == "exited" and out["n_reversals"] == 0
    assert out["u_end"] == pytest.approx(math.sqrt(5 * G), rel=10 * rtol)
    assert 0.0 <= out["nu_min"] < 1.0


# ------------------------------------------------------------------------------
# a bead with friction: nu < 0 on a short arc flips the contact side twice
# ------------------------------------------------------------------------------
def _arc_speed_squared(theta, theta0, w0, mu, radius):
    """u^2 inside a circle at angle theta from the bottom, moving
    counter-clockwise from u^2 = w0 at theta0, with mu the friction
    coefficient times the contact sign: d(u^2)/dtheta = -2 mu u^2 - 2 g R
    (sin theta + mu cos theta), a linear ODE (its exact solution)."""
    a = 2 * mu

    def primitive(psi):
        return (math.exp(a * (psi - theta0)) * ((a * math.sin(psi) - math.cos(psi))
                                                + mu * (a * math.cos(psi) + math.sin(psi)))
                / (1 + a * a))

    return math.exp(-a * (theta - theta0)) * (
        w0 - 2 * G * radius * (primitive(theta) - primitive(theta0)))


def _bead_exit_speed_squared(w0, mu, radius):
    """The bead's u^2 after one turn, piecewise exact: s_nu = +1, then -1
    between the two zeros of nu near the top, then +1; and the two zeros."""
    def nu(theta, theta0, w, s_nu):
        w_theta = _arc_speed_squared(theta, theta0, w, s_nu * mu, radius)
        return w_theta / radius + G * math.cos(theta)

    # nu on the first branch is smallest just before the top: the zeros bracket it
    grid = np.linspace(0.5 * math.pi, 1.5 * math.pi, 20001)
    values = np.array([nu(t, 0.0, w0, 1.0) for t in grid])
    k = int(np.argmin(values))
    assert values[k] < 0.0, "the premise: nu dips below 0"
    first = brentq(nu, grid[0], grid[k], args=(0.0, w0, 1.0), xtol=1e-15, rtol=1e-15)
    w_first = _arc_speed_squared(first, 0.0, w0, mu, radius)
    second = brentq(nu, first + 1e-9, 1.5 * math.pi, args=(first, w_first, -1.0), xtol=1e-15,
                    rtol=1e-15)
    w_second = _arc_speed_squared(second, first, w_first, -mu, radius)
    return _arc_speed_squared(2 * math.pi, second, w_second, mu, radius), first, second


#: a bead on a loop of radius 1 m with mu_k = 0.1, launched at 8.45 m/s: nu
#: dips to about -0.1 m/s^2 over 0.2 rad at the top
BEAD = dict(radius=1.0, mu=0.1, u0=8.45)


#: the pairs' rtol, RK4's steps (the dip lasts about 0.025 s)
BEAD_STEPS = {"dopri5": (1e-3, 1e-4), "dop853": (1e-3, 1e-4),
              "rk4": tuple(np.linspace(0.03, 0.12, 19))}


@pytest.mark.parametrize("method", BEAD_STEPS)
def test_a_bead_with_friction_flips_its_contact_side_inside_one_step(method):
    """Two-sided: the dip is two contact switches, where friction's sign
    flips.  Both are located, so a step ends on each (nu_min <= 0, no lower
    than the exact solution's smallest nu); with a switch missed the bead
    would run on with friction pushing it.  The speed after one turn is the
    piecewise exact solution's.  Before the rough-step check both pairs at
    these tolerances and RK4 at 5 of these 19 steps stepped over this dip
    (nu_min 0.01 to 4.6 m/s^2, at the steps' ends)."""
    radius, mu, u0 = BEAD["radius"], BEAD["mu"], BEAD["u0"]
    exact, first, second = _bead_exit_speed_squared(u0 * u0, mu, radius)
    assert 0.1 < second - first < 0.3  # a short arc: a step of either pair spans it
    w_first = _arc_speed_squared(first, 0.0, u0 * u0, mu, radius)
    deepest = min(_arc_speed_squared(t, first, w_first, -mu, radius) / radius + G * math.cos(t)
                  for t in np.linspace(first, second, 2001))
    loop = Curve.create("loop", radius=radius)
    for step in BEAD_STEPS[method]:
        out = simulate_curve(loop, s0=0.0, u0=u0, mu_k=mu, method=method, rtol=step,
                             dt=float(step), contact="two_sided")
        assert out["status_name"][()] == "exited" and out["n_reversals"] == 0
        tolerance = 10 * step if method != "rk4" else 30 * step ** 4
        assert out["u_end"] ** 2 == pytest.approx(exact, rel=tolerance), step
        assert deepest - 1e-2 <= out["nu_min"] <= 0.0, step


# ------------------------------------------------------------------------------
# the lane kernel's vector loop leaves rough steps to the scalar code
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("method, contact", [
    ("dop853", "one_sided"), ("rk4", "two_sided"),
    pytest.param("dopri5", "one_sided", marks=pytest.mark.slow),
    pytest.param("dopri5", "two_sided", marks=pytest.mark.slow),
    pytest.param("dop853", "two_sided", marks=pytest.mark.slow),
    pytest.param("rk4", "one_sided", marks=pytest.mark.slow)])
def test_rough_steps_give_the_scalar_references_bits(method, contact):
    """Starts about 5 g R (dips, grazes, clean passes) at coarse steps: the
    lane kernel (a rough step is not clean in its vector loop) and the
    scalar reference give the same bits."""
    from rampwork.curves import prepare_curve_run

    rng = np.random.default_rng(7)
    n = 200
    loop = Curve.create("loop", radius=1.0)
    args = dict(s0=0.0, u0=np.sqrt(rng.uniform(4.8, 5.05, n) * G),
                mu_k=np.where(rng.uniform(size=n) < 0.5, 0.0, rng.uniform(0.0, 0.1, n)),
                method=method, dt=0.06, rtol=1e-4, contact=contact)
    lanes = prepare_curve_run(loop, **args).run()
    scalar = prepare_curve_run(loop, vector=False, **args).run()
    for key, value in scalar.items():
        if value.dtype.kind == "f":
            assert np.array_equal(value.view(np.int64), lanes[key].view(np.int64)), key
        else:
            assert np.array_equal(value, lanes[key]), key
    if contact == "one_sided":  # dips and clean passes both
        assert {"lifted_off", "exited"} <= set(scalar["status_name"].tolist())
    assert (scalar["steps_rejected"] > 0).any() or method == "rk4"
