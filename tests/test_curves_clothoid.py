"""The clothoid (Euler spiral) family (docs/physics.md §5): its points against
scipy's Fresnel integrals, its frame by differences, and runs against energy
conservation and an independent high-accuracy integration (scipy DOP853)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.special import fresnel

import rampwork as rw
from rampwork.curve_scene import CurveScene
from rampwork.curves import Curve, simulate_curve
from rampwork.errors import ConfigError

G = 9.81


def _fresnel_point(s, a, k0, phi0):
    """X + i Y = ∫_0^s exp(i phi) ds with phi = phi0 + k0 s + s^2 / (2 a^2):
    completing the square (t = s + k0 a^2) gives scipy's C and S."""
    scale = a * math.sqrt(math.pi)
    t0 = k0 * a * a
    s_hi, c_hi = fresnel((s + t0) / scale)
    s_lo, c_lo = fresnel(t0 / scale)
    chord = scale * ((c_hi - c_lo) + 1j * (s_hi - s_lo))
    z = np.exp(1j * (phi0 - 0.5 * t0 * t0 / (a * a))) * chord
    return z.real, z.imag


@pytest.mark.parametrize("a, k0, phi0", [(1.3, 0.0, 0.0), (0.8, -1.5, 0.4), (2.0, 0.7, -1.2)])
def test_clothoid_points_are_the_fresnel_integrals(a, k0, phi0):
    length = 3.0
    curve = Curve.create("clothoid", clothoid_parameter=a, length=length, curvature_start=k0,
                         start_angle=phi0)
    s = np.linspace(0.0, length, 13)
    here = curve.evaluate(s)
    x, y = _fresnel_point(s, a, k0, phi0)
    np.testing.assert_allclose(here["X"], x, atol=1e-14)
    np.testing.assert_allclose(here["Y"], y, atol=1e-14)
    np.testing.assert_allclose(here["kappa"], k0 + s / a ** 2, rtol=1e-15)
    h = 1e-6
    ahead, behind = curve.evaluate(s[1:-1] + h), curve.evaluate(s[1:-1] - h)
    np.testing.assert_allclose((ahead["X"] - behind["X"]) / (2 * h), here["cos_phi"][1:-1], atol=1e-8)
    np.testing.assert_allclose((ahead["Y"] - behind["Y"]) / (2 * h), here["sin_phi"][1:-1], atol=1e-8)


def _reference(a, length, u0, mu):
    """(t_end, u_end, W_friction per unit mass) by scipy DOP853 at rtol 1e-12
    on (s, u, w): the block inside the turn (side left), moving up to the end."""
    def rhs(t, y):
        s, u, _ = y
        phi = s * s / (2 * a * a)
        nu = (s / a ** 2) * u * u + G * math.cos(phi)
        return [u, -G * math.sin(phi) - mu * abs(nu), mu * abs(nu) * u]

    def end(t, y):
        return y[0] - length
    end.terminal = True
    sol = solve_ivp(rhs, (0.0, 10.0), [0.0, u0, 0.0], method="DOP853", rtol=1e-12, atol=1e-13,
                    events=end)
    return sol.t_events[0][0], sol.y_events[0][0][1], sol.y_events[0][0][2]


# RK4 and dopri5 in the default suite, explicit Euler and dop853 (a kernel
# each, their paths run on the loop there) in the slow one
@pytest.mark.parametrize("method, dt, tol", [("rk4", 1e-3, 1e-9), ("dopri5", 1e-3, 1e-8),
                                             pytest.param("dop853", 1e-3, 1e-8, marks=pytest.mark.slow),
                                             pytest.param("euler", 1e-5, 1e-3, marks=pytest.mark.slow)])
def test_clothoid_run_against_an_independent_reference(method, dt, tol):
    """Up an Euler spiral that turns past the vertical (2 rad): the speed,
    time and friction work at its end; without friction, energy gives
    u_end^2 = u0^2 - 2 g Y(L) with Y from the Fresnel integrals.  Both
    frictions in one call (one kernel variant: mu = 0 in a lane of the
    friction kernel; the frictionless variant is tested on other families)."""
    a, length, u0 = 1.0, 2.0, 9.0
    curve = Curve.create("clothoid", clothoid_parameter=a, length=length)
    mus = np.array([0.0, 0.3])
    out = simulate_curve(curve, s0=0.0, u0=u0, mu_k=mus, method=method, dt=dt, rtol=1e-11)
    for i, mu in enumerate(mus):
        assert out["status_name"][i] == "exited" and out["nu_min"][i] > 0
        t_end, u_end, work = _reference(a, length, u0, mu)
        assert out["u_end"][i] == pytest.approx(u_end, rel=tol)
        assert out["t_end"][i] == pytest.approx(t_end, rel=tol)
        assert out["W_friction"][i] == pytest.approx(work, rel=tol, abs=tol)
        assert out["curvature_mean"][i] == pytest.approx(length / (2 * a * a), rel=tol)
    assert out["W_friction"][0] == 0.0
    _, y_end = _fresnel_point(length, a, 0.0, 0.0)
    assert out["u_end"][0] ** 2 == pytest.approx(u0 ** 2 - 2 * G * y_end, rel=tol)


def test_clothoid_scene_sweeps_its_length():
    scene = CurveScene(curve=Curve.create("clothoid", clothoid_parameter=1.0, length=1.0),
                       s0=0.0, u0=7.0, t_max=3.0)
    ds = rw.simulate(scene, rw.Sweep.grid(length=[1.0, 1.5, 2.0]))
    assert ds.status.dims == ("length",) and (ds.status.values == 2).all()
    x, y = _fresnel_point(np.array([1.0, 1.5, 2.0]), 1.0, 0.0, 0.0)
    np.testing.assert_allclose(ds.X_end.values, x, atol=1e-14)
    # X turns back where phi = s^2 / 2 reaches pi / 2 (s = sqrt(pi)): ∫|dX| = 2 X_max - X_end
    x_max, _ = _fresnel_point(np.minimum([1.0, 1.5, 2.0], math.sqrt(math.pi)), 1.0, 0.0, 0.0)
    np.testing.assert_allclose(ds.path_length_X.values, 2 * x_max - x, atol=1e-14)


@pytest.mark.parametrize("params, where", [
    ({"clothoid_parameter": 0.5, "length": 4.0}, "curve.length"),
    ({"clothoid_parameter": -1.0, "length": 1.0}, "curve.clothoid_parameter"),
    ({"clothoid_parameter": 1.0}, "curve.length"),
])
def test_bad_clothoid_parameters_are_named(params, where):
    with pytest.raises(ConfigError) as error:
        Curve.create("clothoid", **params)
    assert error.value.where == where
