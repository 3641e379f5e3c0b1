"""Planar curves in arc length (docs/physics.md §5) against closed forms.

Every fixed-step method runs each case; the expected values come from
energy conservation, the exact solution of the circular arc with friction,
the cycloid's tautochrone time, or the y = f(x) kernel (an independent
formulation: state (x, v) instead of (s, u)).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import rampwork as rw
from rampwork.curves import Curve, simulate_curve
from rampwork.errors import ConfigError

G = 9.81
METHODS = ("euler", "semi_implicit_euler", "rk4")
#: step and tolerance per method for the closed-form checks (first-order
#: methods at 1e-4 s: errors ~1e-4; RK4 at 1e-3 s: errors ~1e-12)
STEP = {"euler": 1e-4, "semi_implicit_euler": 1e-4, "rk4": 1e-3}
TOL = {"euler": 2e-3, "semi_implicit_euler": 2e-3, "rk4": 1e-9}
ORDER = {"euler": 1, "semi_implicit_euler": 1, "rk4": 4}
#: dop853 through the closed forms: its error within 10x its rtol
STEP["dop853"] = 1e-3
RTOL = {"dop853": 1e-10}
TOL["dop853"] = 10 * RTOL["dop853"]
CLOSED_FORM_METHODS = METHODS + ("dop853",)


def every(*methods, slow=()):
    """``methods`` as parameters, then ``slow`` ones, with semi-implicit Euler
    and ``slow`` in the slow suite: their kernels cost compile time, and
    explicit Euler keeps the first-order path in the default one (dop853
    runs every closed form of the loop there; on the other families it is
    slow)."""
    return [pytest.param(method, marks=pytest.mark.slow)
            if method == "semi_implicit_euler" or method in slow else method
            for method in methods + tuple(slow)]


# ------------------------------------------------------------------------------
# the frictionless loop: contact over the top iff u_bottom^2 >= 5 g R
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("method", every(*METHODS))
@pytest.mark.parametrize("radius", [0.5, 2.0])
def test_loop_clears_the_top_iff_five_g_r(method, radius):
    loop = Curve.create("loop", radius=radius)
    u_bottom = np.sqrt(np.array([4.8, 5.2]) * G * radius)
    out = simulate_curve(loop, s0=0.0, u0=u_bottom, method=method, dt=STEP[method])
    assert list(out["status_name"]) == ["lifted_off", "exited"]
    # cleared: at the exit (the bottom again) the speed is the entry's, and
    # the normal force stayed >= 0, smallest at the top: m (u_top^2 / R - g)
    assert out["u_end"][1] == pytest.approx(u_bottom[1], rel=TOL[method])
    nu_top = (u_bottom[1] ** 2 - 4 * G * radius) / radius - G
    # sampled at the steps' ends: within a step of the top, (u h)^2 nu'' / 8
    assert nu_top <= out["nu_min"][1] <= nu_top * (1 + max(50 * TOL[method], 1e-4))
    assert out["p_end"][1] == 2 * math.pi * radius


@pytest.mark.parametrize("method", every(*CLOSED_FORM_METHODS))
@pytest.mark.parametrize("ratio", [2.5, 3.0, 4.0, 4.9])
def test_loop_lift_off_angle_by_energy(method, ratio):
    """Too slow (2 g R < u^2 < 5 g R): it leaves where nu = 0, cos theta =
    (2 g R - u^2) / (3 g R), with the speed energy gives there."""
    radius = 1.0
    loop = Curve.create("loop", radius=radius)
    u_bottom = math.sqrt(ratio * G * radius)
    out = simulate_curve(loop, s0=0.0, u0=u_bottom, method=method, dt=STEP[method],
                         rtol=RTOL.get(method, 1e-6))
    theta = math.acos((2 - ratio) / 3)
    assert out["status_name"][()] == "lifted_off"
    assert out["p_lift_off"] == pytest.approx(theta * radius, abs=TOL[method])
    assert out["X_lift_off"] == pytest.approx(radius * math.sin(theta), abs=TOL[method])
    assert out["u_end"] ** 2 == pytest.approx(ratio * G * radius - 2 * G * radius * (1 - math.cos(theta)),
                                              abs=10 * TOL[method])
    assert abs(out["energy_balance_error"]) < 10 * TOL[method]
    assert out["n_reversals"] == 0


@pytest.mark.parametrize("method", every(*METHODS))
def test_loop_below_the_equator_swings_without_leaving(method):
    """u^2 < 2 g R: it reverses below the equator, at cos theta = 1 - u^2 / (2 g R),
    and comes back to the bottom (the arc's entry) with its speed."""
    loop = Curve.create("loop", radius=1.0)
    u_bottom = math.sqrt(1.5 * G)
    out = simulate_curve(loop, s0=0.0, u0=u_bottom, method=method, dt=STEP[method])
    assert out["status_name"][()] == "exited"
    assert out["p_end"] == 0.0 and out["n_reversals"] == 1
    assert out["u_end"] == pytest.approx(-u_bottom, rel=TOL[method])
    assert out["path_length"] == pytest.approx(2 * math.acos(1 - 0.75), rel=10 * TOL[method])
    assert out["nu_min"] > 0


@pytest.mark.parametrize("method, contact", [
    *((method, "one_sided") for method in ("euler", "rk4", "dopri5", "dop853")),
    ("rk4", "two_sided"), ("dopri5", "two_sided"),  # the others' kernels: slow suite
    pytest.param("semi_implicit_euler", "one_sided", marks=pytest.mark.slow),
    *(pytest.param(method, "two_sided", marks=pytest.mark.slow)
      for method in ("euler", "semi_implicit_euler", "dop853"))])
def test_loop_at_exactly_five_g_r_touches_zero_and_goes_over(method, contact):
    """u_bottom^2 = 5 g R: nu = 3 g (1 + cos theta) touches 0 at the top
    without changing sign; the block goes over, for both contacts."""
    loop = Curve.create("loop", radius=1.0)
    out = simulate_curve(loop, s0=0.0, u0=math.sqrt(5 * G), method=method,
                         dt=STEP.get(method, 1e-3), contact=contact,
                         rtol=RTOL.get(method, 1e-6))
    assert out["status_name"][()] == "exited" and out["n_reversals"] == 0
    # nu_min is sampled at the steps' ends: dop853's steps at rtol 1e-6 (0.07 s
    # near the top) pass it at nu ~ 0.2, hence its tighter rtol here
    assert 0.0 <= out["nu_min"] < 0.1


# ------------------------------------------------------------------------------
# a reversal and a fall (outside of a circle): orders 1 and 4
# ------------------------------------------------------------------------------
def _dome_fall(method, dt):
    """Outside of a circle (side right), started past the top moving up: it
    stops at cos a_r = cos a_0 + u_0^2 / (2 g R) (a reversal), slides back
    and leaves at cos a = 2/3 cos a_r (a from the top)."""
    radius = 1.0
    dome = Curve.create("loop", side="right", radius=radius, entry_angle=math.pi / 2,
                        exit_angle=1.5 * math.pi)
    a0 = 0.3
    u0 = -0.5 * math.sqrt(2 * G * radius * (1 - math.cos(a0)))
    out = simulate_curve(dome, s0=radius * (math.pi + a0), u0=u0, method=method, dt=dt)
    cos_r = math.cos(a0) + u0 ** 2 / (2 * G * radius)
    return out, radius * (math.pi + math.acos(2 / 3 * cos_r))


@pytest.mark.parametrize("method", every(*METHODS))
def test_dome_reversal_then_fall_orders(method):
    steps = (4e-3, 2e-3, 1e-3) if method != "rk4" else (4e-2, 2e-2, 1e-2)
    errors = []
    for dt in steps:
        out, p_lift = _dome_fall(method, dt)
        assert out["status_name"][()] == "lifted_off" and out["n_reversals"] == 1
        errors.append(abs(out["p_lift_off"] - p_lift))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - ORDER[method]) < 0.2), (errors, orders)


# dop853 (its kernel on the cycloid) in the slow suite; on the loop in the default one
@pytest.mark.parametrize("method, rtol", [(method, rtol) if method == "dopri5"
                                          else pytest.param(method, rtol, marks=pytest.mark.slow)
                                          for method in ("dopri5", "dop853")
                                          for rtol in (1e-4, 1e-6, 1e-9)])
def test_adaptive_pairs_within_ten_times_rtol(method, rtol):
    """The adaptive pair on the loop's lift-off, the dome's reversal and
    fall, the arc with friction and the cycloid from its cusp."""
    loop = Curve.create("loop", radius=1.0)
    for ratio in (2.5, 4.0, 4.9):
        out = simulate_curve(loop, s0=0.0, u0=math.sqrt(ratio * G), method=method, rtol=rtol)
        assert out["status_name"][()] == "lifted_off"
        assert abs(out["p_lift_off"] - math.acos((2 - ratio) / 3)) < 10 * rtol
    out, p_lift = _dome_fall(method, 1e-3)  # (the default rtol, 1e-6)
    assert out["n_reversals"] == 1 and abs(out["p_lift_off"] - p_lift) < 1e-5
    arc = Curve.create("loop", radius=0.8, entry_angle=-0.5, exit_angle=1.5)
    out = simulate_curve(arc, s0=-0.4, u0=10.0, mu_k=0.4, method=method, rtol=rtol)
    expected = math.sqrt(_arc_speed_squared(1.5, -0.5, 100.0, 0.4, 0.8))
    assert out["u_end"] == pytest.approx(expected, rel=10 * rtol)
    out = simulate_curve(Curve.create("brachistochrone", radius=1.0), s0=0.0, method=method,
                         rtol=rtol)
    assert out["t_end"] == pytest.approx(math.pi * math.sqrt(1.0 / G), abs=10 * rtol)
    assert out["steps"] < 10 / rtol ** 0.2  # it adapts: ~7 steps at 1e-4, ~50 at 1e-10


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_a_dip_of_nu_inside_one_step_is_a_lift_off(method):
    """u^2 = 4.99 g R at the bottom of the frictionless loop: nu = g (2.99 +
    3 cos theta) < 0 for |theta - pi| < 0.082, so the block leaves before the
    top (cos theta = -2.99/3), whatever the tolerance."""
    loop = Curve.create("loop", radius=1.0)
    for rtol in (1e-4, 1e-6):
        out = simulate_curve(loop, s0=0.0, u0=math.sqrt(4.99 * G), method=method, rtol=rtol)
        assert out["status_name"][()] == "lifted_off"
        assert abs(out["p_lift_off"] - math.acos(-2.99 / 3)) < 10 * rtol


# ------------------------------------------------------------------------------
# the circular arc with friction: d(u^2)/dphi = -2 mu u^2 - 2 g R (sin phi + mu cos phi)
# ------------------------------------------------------------------------------
def _arc_speed_squared(phi, phi0, w0, mu, radius):
    """The exact u^2 at phi inside a circle, moving counter-clockwise in contact."""
    a = 2 * mu

    def primitive(psi):  # ∫ e^{a (psi - phi0)} (sin psi + mu cos psi) dpsi
        return math.exp(a * (psi - phi0)) * ((a * math.sin(psi) - math.cos(psi))
                                             + mu * (a * math.cos(psi) + math.sin(psi))) / (1 + a * a)

    return math.exp(-a * (phi - phi0)) * (w0 - 2 * G * radius * (primitive(phi) - primitive(phi0)))


@pytest.mark.parametrize("method", every(*CLOSED_FORM_METHODS))
@pytest.mark.parametrize("mu", [0.1, 0.4])
def test_circular_arc_with_friction_exit_speed(method, mu):
    radius = 0.8
    arc = Curve.create("loop", radius=radius, entry_angle=-0.5, exit_angle=1.5)
    u0 = 10.0
    out = simulate_curve(arc, s0=-0.5 * radius, u0=u0, mu_k=mu, method=method, dt=STEP[method],
                         rtol=RTOL.get(method, 1e-6))
    assert out["status_name"][()] == "exited"
    expected = math.sqrt(_arc_speed_squared(1.5, -0.5, u0 * u0, mu, radius))
    assert out["u_end"] == pytest.approx(expected, rel=TOL[method])
    # the work against friction is the energy lost
    work = 0.5 * u0 ** 2 - 0.5 * expected ** 2 - G * radius * (math.cos(-0.5) - math.cos(1.5))
    assert out["W_friction"] == pytest.approx(work, rel=10 * TOL[method])
    assert out["curvature_mean"] == pytest.approx(1 / radius, rel=10 * TOL[method])


@pytest.mark.parametrize("method", every(*CLOSED_FORM_METHODS))
def test_circular_arc_with_friction_stops_where_u_vanishes(method):
    """A stop where static friction holds it (tan theta <= mu_s): stuck at
    the angle where the exact u^2 reaches 0."""
    from scipy.optimize import brentq

    radius, mu, u0 = 1.0, 0.3, 2.0
    arc = Curve.create("loop", radius=radius, entry_angle=-1.0, exit_angle=1.0)
    out = simulate_curve(arc, s0=0.0, u0=u0, mu_k=mu, mu_s=1.0, method=method, dt=STEP[method],
                         rtol=RTOL.get(method, 1e-6))
    theta = brentq(lambda phi: _arc_speed_squared(phi, 0.0, u0 * u0, mu, radius), 0.0, 1.0,
                   xtol=1e-15)
    assert math.tan(theta) < 1.0
    assert out["status_name"][()] == "stuck" and out["u_end"] == 0.0
    assert out["p_end"] == pytest.approx(radius * theta, abs=TOL[method])
    assert out["n_reversals"] == 0


# ------------------------------------------------------------------------------
# the brachistochrone cycloid from its cusp: at rest on a vertical tangent
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("method", every(*METHODS, slow=("dop853",)))
@pytest.mark.parametrize("radius", [0.25, 1.0])
def test_cycloid_from_the_cusp_reaches_the_bottom_in_pi_sqrt_r_over_g(method, radius):
    """At rest at the cusp nu = 0 exactly and kappa > 0: it slides off in
    contact (nu > 0 all the way) and reaches the bottom at pi sqrt(r/g)
    with the free-fall speed."""
    curve = Curve.create("brachistochrone", radius=radius)
    assert curve.evaluate(0.0)["cos_phi"][0] == 0.0
    out = simulate_curve(curve, s0=0.0, method=method, dt=STEP[method], rtol=RTOL.get(method, 1e-6))
    assert out["status_name"][()] == "exited"
    assert out["t_end"] == pytest.approx(math.pi * math.sqrt(radius / G), abs=10 * TOL[method])
    assert out["u_end"] == pytest.approx(math.sqrt(4 * G * radius), rel=TOL[method])
    assert out["nu_min"] == 0.0  # at the start, then > 0
    assert out["Y_end"] == pytest.approx(-2 * radius) and out["X_end"] == pytest.approx(math.pi * radius)


@pytest.mark.parametrize("method", every(*METHODS))
def test_cusp_on_the_other_side_leaves_at_once(method):
    """At rest on a vertical tangent bending away from the block (side right:
    kappa side < 0), nothing holds it: lift-off at t = 0."""
    curve = Curve.create("brachistochrone", side="right", radius=1.0)
    out = simulate_curve(curve, s0=0.0, method=method, dt=STEP[method])
    assert out["status_name"][()] == "lifted_off"
    assert out["t_end"] == 0.0 and out["p_lift_off"] == 0.0 and out["steps"] == 0


@pytest.mark.parametrize("method", every(*METHODS))
def test_quarter_pipe_top_is_vertical_and_the_block_comes_back(method):
    """Up a quarter pipe to its vertical end: too slow to reach it, it
    reverses on the curve and slides back out over the flat."""
    pipe = Curve.create("quarter_pipe", radius=1.0, flat_length=0.5)
    top = pipe.evaluate(0.5 + 0.5 * math.pi)
    assert abs(top["cos_phi"][0]) < 1e-15 and top["sin_phi"][0] == 1.0
    out = simulate_curve(pipe, s0=0.5, u0=np.array([3.0, 6.0]), method=method, dt=STEP[method])
    assert list(out["status_name"]) == ["exited", "exited"]
    assert out["p_end"][0] == 0.0 and out["n_reversals"][0] == 1
    tol = 10 * TOL[method]
    assert out["u_end"][0] == pytest.approx(-3.0, rel=tol)
    # fast enough: leaves the top vertically with the speed energy leaves it
    assert out["p_end"][1] == pytest.approx(0.5 + 0.5 * math.pi)
    assert out["u_end"][1] == pytest.approx(math.sqrt(36 - 2 * G), rel=tol)
    assert out["Y_end"][1] == pytest.approx(1.0)


@pytest.mark.parametrize("method", every(*METHODS, "dopri5", slow=("dop853",)))
def test_quarter_pipe_with_friction_steps_end_at_the_joint(method):
    """Over the flat u^2 falls by 2 mu g L, then the circular arc's exact
    solution up to the vertical end.  The curvature jump at the joint is an
    event (steps end there), so RK4 keeps its accuracy; its order is
    checked on the same run."""
    radius, flat, mu, u0 = 1.0, 0.5, 0.2, 8.0
    pipe = Curve.create("quarter_pipe", radius=radius, flat_length=flat)
    # no flat: a start on the joint moves into the circle (its first stage too)
    no_flat = Curve.create("quarter_pipe", radius=radius, flat_length=0.0)
    out = simulate_curve(no_flat, s0=0.0, u0=u0, mu_k=mu, method=method, dt=1e-3, rtol=1e-9)
    assert out["u_end"] == pytest.approx(
        math.sqrt(_arc_speed_squared(0.5 * math.pi, 0.0, u0 * u0, mu, radius)),
        rel=1e-8 if method in ("rk4", "dopri5", "dop853") else 1e-2)
    w_joint = u0 * u0 - 2 * mu * G * flat
    expected = math.sqrt(_arc_speed_squared(0.5 * math.pi, 0.0, w_joint, mu, radius))

    def run(dt):
        return simulate_curve(pipe, s0=0.0, u0=u0, mu_k=mu, method=method, dt=dt, rtol=1e-9)

    out = run(STEP[method] if method in STEP else 1e-3)
    assert out["status_name"][()] == "exited"
    assert out["u_end"] == pytest.approx(expected, rel=10 * TOL.get(method, 1e-9))
    if method in ORDER:
        steps = (4e-3, 2e-3, 1e-3) if method != "rk4" else (4e-2, 2e-2, 1e-2)
        errors = np.array([abs(run(dt)["u_end"] - expected) for dt in steps])
        orders = np.log2(errors[:-1] / errors[1:])
        assert np.all(np.abs(orders - ORDER[method]) < 0.25), (errors, orders)


# ------------------------------------------------------------------------------
# the reduction: a ramp y = f(x) as a curve gives the y = f(x) kernel's answers
# ------------------------------------------------------------------------------
WRAPPED = [
    rw.Ramp.create("quadratic", curvature=1.5, slope=-0.5, domain=(-1.5, 1.5)),
    rw.Ramp.create("quadratic", curvature=-2.0, domain=(-1.0, 1.0)),
    rw.Ramp.create("circular_bowl", radius=1.0, domain=(-0.9, 0.9)),
    rw.Ramp.create("circular_dome", radius=1.0, domain=(-0.9, 0.9)),
    rw.Ramp.create("cycloid", radius=0.5, domain=(-1.2, 1.2)),
    rw.Ramp.create("sine", amplitude=0.2, wavenumber=4.0, domain=(-1.5, 1.5)),
    rw.Ramp.create("spline", x_points=[-1, -0.3, 0.2, 1.0], y_points=[0.5, 0.0, 0.1, 0.6]),
]
#: (method, dt, tolerance on x_end, t_end, W_friction): the two formulations
#: differ by their truncation errors (state (x, v) against (x, u)), so they
#: agree to the method's accuracy; the C2 spline's f''' jumps at its knots,
#: which limits RK4 there
WRAP_RUNS = {"euler": (1e-4, 2e-2), "semi_implicit_euler": (1e-4, 2e-2), "rk4": (1e-3, 1e-8),
             "dopri5": (None, 1e-7), "dop853": (None, 1e-7)}
#: the adaptive pairs' tolerance for the comparison (both kernels)
WRAP_RTOL = 1e-10


def _compare_wrapped(ramp, method, seed):
    dt, tol = WRAP_RUNS[method]
    if ramp.family == "spline" and method == "rk4":
        tol = 1e-5
    adaptive = {"rtol": WRAP_RTOL} if method in ("dopri5", "dop853") else {}
    rng = np.random.default_rng(seed)
    n = 24
    lo, hi = ramp.domain
    mu = rng.uniform(0, 0.5, n)
    x0 = rng.uniform(0.9 * lo, 0.9 * hi, n)
    v0 = rng.uniform(-2, 2, n)
    v0[:6] = 0.0  # starts at rest: the rest rule
    scene = rw.Scene(ramp=ramp, integrator=rw.Integrator(method, dt=dt, closed_form=False,
                                                         **adaptive), t_max=5.0)
    ds = rw.simulate(scene, rw.Sweep.cases(mu=mu, x0=x0, v0=v0))
    _, fp0, _ = ramp.evaluate(x0)
    out = simulate_curve(Curve.from_ramp(ramp), s0=x0, u0=v0 * np.sqrt(1 + fp0 ** 2), mu_k=mu,
                         method=method, dt=dt or 1e-3, t_max=5.0, **adaptive)
    np.testing.assert_array_equal(out["status"], ds.status.values)
    np.testing.assert_array_equal(out["n_reversals"], ds.n_reversals.values)
    np.testing.assert_allclose(out["p_end"], ds.x_end.values, atol=tol)
    np.testing.assert_allclose(out["t_end"], ds.t_end.values, atol=tol)
    np.testing.assert_allclose(out["W_friction"], ds.W_friction.values, atol=tol)
    np.testing.assert_allclose(out["p_lift_off"], ds.x_lift_off.values, atol=tol)
    _, fp_end, _ = ramp.evaluate(ds.x_end.values)
    np.testing.assert_allclose(out["u_end"], ds.v_end.values * np.sqrt(1 + fp_end ** 2),
                               atol=100 * tol)
    return ds


#: RK4 on every wrapped family: those the coverage test below also runs in the
#: default suite, the bowl, the cycloid and the spline (a kernel each) in the slow one
WRAPPED_RK4 = [ramp if ramp.family in ("quadratic", "circular_dome", "sine")
               else pytest.param(ramp, marks=pytest.mark.slow) for ramp in WRAPPED]


@pytest.mark.parametrize("ramp", WRAPPED_RK4, ids=lambda r: r.family)
def test_wrapped_ramps_agree_with_the_ramp_kernel_rk4(ramp):
    _compare_wrapped(ramp, "rk4", seed=7)


#: every method on one wrapped family in the default suite, on two more in the slow
#: suite (each case compiles a ramp and a curve kernel variant; RK4 runs on all)
WRAPPED_METHOD_FAMILIES = [WRAPPED[1]] + [pytest.param(r, marks=pytest.mark.slow)
                                          for r in (WRAPPED[3], WRAPPED[5])]


@pytest.mark.parametrize("method", every("euler", "semi_implicit_euler"))
@pytest.mark.parametrize("ramp", WRAPPED_METHOD_FAMILIES, ids=lambda r: r.family)
def test_wrapped_ramps_agree_with_the_ramp_kernel_first_order(ramp, method):
    _compare_wrapped(ramp, method, seed=11)


@pytest.mark.parametrize("ramp", WRAPPED_METHOD_FAMILIES, ids=lambda r: r.family)
@pytest.mark.parametrize("method", ["dopri5", pytest.param("dop853", marks=pytest.mark.slow)])
def test_wrapped_ramps_agree_with_the_ramp_kernel_adaptive(ramp, method):
    _compare_wrapped(ramp, method, seed=5)


def test_wrapped_scenes_cover_stops_reversals_and_lift_offs():
    """The random scenes above include every event the comparison is for."""
    statuses = set()
    reversals = 0
    for ramp in (WRAPPED[1], WRAPPED[3], WRAPPED[5]):
        ds = _compare_wrapped(ramp, "rk4", seed=11)
        statuses |= set(ds.status.values.tolist())
        reversals += int(ds.n_reversals.values.sum())
    assert {1, 2, 3} <= statuses and reversals > 0


@pytest.mark.slow
@pytest.mark.parametrize("method", ["euler", "semi_implicit_euler"])
@pytest.mark.parametrize("ramp", [WRAPPED[0], WRAPPED[2], WRAPPED[4], WRAPPED[6]],
                         ids=lambda r: r.family)
def test_wrapped_ramps_agree_first_order_every_family(ramp, method):
    _compare_wrapped(ramp, method, seed=13)


# ------------------------------------------------------------------------------
# contact, drag, geometry and validation
# ------------------------------------------------------------------------------
def test_two_sided_bead_goes_over_the_top_of_a_loop():
    """A bead on a circular wire: nu changes sign near the top (an event, not
    a lift-off) and the frictionless bead keeps its energy all the way."""
    loop = Curve.create("loop", radius=1.0)
    u0 = math.sqrt(4.5 * G)  # under 5 g R: a block would fall, a bead goes on
    out = simulate_curve(loop, s0=0.0, u0=u0, contact="two_sided", method="rk4", dt=1e-3)
    assert out["status_name"][()] == "exited"
    assert out["u_end"] == pytest.approx(u0, rel=1e-10)
    # sampled at the steps' ends, within a step of the top
    assert out["nu_min"] == pytest.approx((4.5 * G - 4 * G) - G, rel=1e-5)


def test_two_sided_friction_uses_the_size_of_nu():
    """With friction the bead loses energy on both signs of nu, and the
    integrated work equals the energy lost."""
    loop = Curve.create("loop", radius=1.0)
    out = simulate_curve(loop, s0=0.0, u0=8.0, mu_k=0.05, contact="two_sided", method="rk4",
                         dt=1e-3)
    assert out["W_friction"] > 0
    assert abs(out["energy_balance_error"]) < 1e-9


def test_air_drag_work_closes_the_energy_balance():
    loop = Curve.create("loop", radius=1.0, exit_angle=math.pi / 2)
    out = simulate_curve(loop, s0=0.0, u0=5.0, mu_k=0.1, drag_linear=0.3, drag_quadratic=0.05,
                         method="rk4", dt=1e-3)
    assert out["W_drag"] > 0 and out["W_friction"] > 0
    assert abs(out["energy_balance_error"]) < 1e-10


def test_sweep_over_a_curve_parameter_broadcasts():
    loop = Curve.create("loop", radius=1.0)
    radii = np.array([0.5, 1.0, 2.0])
    out = simulate_curve(loop, s0=0.0, u0=7.5, radius=radii, method="rk4", dt=1e-3)
    # 7.5^2 = 56.25 against 5 g R = 24.5, 49.1, 98.1
    assert list(out["status_name"]) == ["exited", "exited", "lifted_off"]
    np.testing.assert_allclose(out["p_end"][:2], 2 * math.pi * radii[:2])


def test_results_do_not_depend_on_the_batch():
    loop = Curve.create("loop", radius=1.0)
    u0 = np.linspace(3.0, 8.0, 9)
    together = simulate_curve(loop, s0=0.0, u0=u0, mu_k=0.1, method="rk4", dt=1e-3)
    for i in (0, 4, 8):
        alone = simulate_curve(loop, s0=0.0, u0=u0[i], mu_k=0.1, method="rk4", dt=1e-3)
        for name in ("t_end", "p_end", "u_end", "W_friction"):
            assert alone[name] == together[name][i]


def test_curve_frames_are_consistent():
    """kappa = dphi/ds and the tangent is dr/ds, by central differences."""
    for curve, points in ((Curve.create("loop", radius=1.5), np.linspace(0.1, 9.0, 7)),
                          (Curve.create("brachistochrone", radius=0.7), np.linspace(0.3, 2.5, 7)),
                          (Curve.create("quarter_pipe", radius=1.0, flat_length=0.4),
                           np.array([0.1, 0.6, 1.2, 1.8]))):
        h = 1e-6
        here, ahead, behind = curve.evaluate(points), curve.evaluate(points + h), curve.evaluate(points - h)
        np.testing.assert_allclose((ahead["X"] - behind["X"]) / (2 * h), here["cos_phi"], atol=1e-8)
        np.testing.assert_allclose((ahead["Y"] - behind["Y"]) / (2 * h), here["sin_phi"], atol=1e-8)
        phi = np.arctan2(ahead["sin_phi"] * behind["cos_phi"] - ahead["cos_phi"] * behind["sin_phi"],
                         ahead["cos_phi"] * behind["cos_phi"] + ahead["sin_phi"] * behind["sin_phi"])
        np.testing.assert_allclose(phi / (2 * h), here["kappa"], rtol=1e-6)


@pytest.mark.parametrize("family, params, where", [
    ("loop", {"radius": -1.0}, "curve.radius"),
    ("loop", {"radius": 1.0, "entry_angle": 1.0, "exit_angle": 0.5}, "curve.exit_angle"),
    ("loop", {"radius": 1.0, "exit_angle": 7.0}, "curve.exit_angle"),
    ("quarter_pipe", {"radius": 1.0, "flat_length": -0.1}, "curve.flat_length"),
    ("brachistochrone", {"radius": 1.0, "end_angle": 7.0}, "curve.end_angle"),
    ("brachistochrone", {"radius": math.nan}, "curve.radius"),
    ("brachistochrone", {"radius": 1.0, "height": 2.0}, "curve.height"),
    ("helix", {}, "curve.family"),
])
def test_bad_curve_parameters_are_refused_with_the_parameter_named(family, params, where):
    with pytest.raises(ConfigError) as error:
        Curve.create(family, **params)
    assert error.value.where == where


def test_bad_runs_are_refused():
    loop = Curve.create("loop", radius=1.0, exit_angle=math.pi)
    with pytest.raises(ConfigError, match="on the curve"):
        simulate_curve(loop, s0=4.0)
    with pytest.raises(ConfigError) as error:
        simulate_curve(loop, s0=0.0, method="leapfrog")
    assert error.value.where == "integrator.method"
    with pytest.raises(ConfigError):
        Curve.create("loop", side="up", radius=1.0)
    with pytest.raises(ConfigError, match="cusp"):
        simulate_curve(Curve.create("brachistochrone", radius=1.0), s0=0.0, mu_k=0.1)
    with pytest.raises(ConfigError) as error:
        simulate_curve(loop, s0=0.0, radius=[1.0, -2.0])
    assert error.value.where == "curve.radius"
