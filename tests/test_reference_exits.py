"""rampwork.reference finds an exit inside a step that goes past a domain end
and back.  solve_ivp sees an event only where its function changes sign
between two step ends; on a straight ramp (one step, the right-hand side is
constant) a block launched up to just beyond the end turned there, and the
reference reported it stuck outside the domain (on the quadratic bowl of
accuracy_cost.py --peers, stuck inside it, after an exit that heyoka,
rampwork and CyRK RK45 all found)."""

from __future__ import annotations

import math

import pytest

import rampwork as rw
from rampwork.core.status import EXITED, STUCK

G = 9.81


@pytest.mark.parametrize("overshoot", [1e-3, 1e-4, 1e-6])
def test_exit_just_before_the_turning_point_is_found(reference, overshoot):
    mu, slope, x0 = 0.7, -0.5, 0.5
    ramp = rw.Ramp.create("straight", slope=slope, height=0.0, domain=(-1.0, 1.0))
    scene = rw.Scene(ramp=ramp, friction=rw.Friction(mu_k=mu), t_max=60.0, g=G)
    # moving left (d = -1) up the slope: dv/dt = -(f' + d mu) g / (1 + f'^2) = a > 0
    a = -(slope - mu) * G / (1.0 + slope * slope)
    x_turn = -1.0 - overshoot
    v0 = -math.sqrt(2.0 * a * (x0 - x_turn))
    out = reference.reference_trajectory(scene, x0=x0, v0=v0, mu_k=mu, mu_s=mu, rtol=1e-12, atol=1e-12)
    # closed form: the first root of x0 + v0 t + a t^2 / 2 = -1
    t_exit = (-v0 - math.sqrt(v0 * v0 - 2.0 * a * (x0 + 1.0))) / a
    assert out["status"] == EXITED
    assert out["x_end"] == -1.0
    assert out["t_end"] == pytest.approx(t_exit, rel=1e-11)
    assert out["v_end"] == pytest.approx(v0 + a * t_exit, rel=1e-9)
    assert out["W_friction"] == pytest.approx(mu * G * (x0 + 1.0), rel=1e-11)  # m = 1 kg, n = g
    assert out["events"][-1]["kind"] == "exit"


def test_turning_inside_the_domain_is_still_a_stop(reference):
    """The same launch with the turning point just inside the end: stuck there."""
    mu, slope, x0 = 0.7, -0.5, 0.5
    ramp = rw.Ramp.create("straight", slope=slope, height=0.0, domain=(-1.0, 1.0))
    scene = rw.Scene(ramp=ramp, friction=rw.Friction(mu_k=mu), t_max=60.0, g=G)
    a = -(slope - mu) * G / (1.0 + slope * slope)
    x_turn = -1.0 + 1e-4
    v0 = -math.sqrt(2.0 * a * (x0 - x_turn))
    out = reference.reference_trajectory(scene, x0=x0, v0=v0, mu_k=mu, mu_s=mu, rtol=1e-12, atol=1e-12)
    assert out["status"] == STUCK
    assert out["x_end"] == pytest.approx(x_turn, abs=1e-12)
