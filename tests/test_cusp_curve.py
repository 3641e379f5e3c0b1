"""The convex cusp curve family and the CuspCurve shape family (issue 21):
geometry against finite differences and quadrature, descent times against
closed forms and an independent quadrature, B to rounding, flags, batching."""

import math
import warnings

import numpy as np
import pytest
from numpy.polynomial import chebyshev as C
from scipy.integrate import quad

import rampwork as rw
from rampwork.brachistochrone import frictional_brachistochrone
from rampwork.core import status as st
from rampwork.curve_scene import CurveScene
from rampwork.curves import Curve
from rampwork.descent_shapes import CuspCurve
from rampwork.errors import ConfigError

G = 9.81
RNG = np.random.default_rng(21)
#: E coefficients (c_0 .. c_4) and end angles of three convex cusps
COEFFICIENTS = np.array([[0.3, 0.2, -0.4, 0.1, -0.05], [-0.2, -0.5, 0.3, 0.0, 0.02],
                         [0.0, 0.0, 0.0, 0.0, 0.0]])
END_ANGLES = np.array([0.4, -0.6, 1.2])


def _scene(mu=0.0, rtol=1e-12, **kw):
    return CurveScene(curve=Curve.create("brachistochrone", radius=1.0), g=G,
                      friction=rw.Friction(mu_k=mu), t_max=20.0,
                      integrator=rw.Integrator(method="dopri5", rtol=rtol, atol=rtol), **kw)


def _rho(c, angle):
    """ds/dphi of the family, by numpy: cos(phi) exp(E(t))."""
    span = angle + 0.5 * math.pi
    return lambda phi: math.cos(phi) * math.exp(C.chebval(2 * (phi + 0.5 * math.pi) / span - 1, c))


@pytest.mark.parametrize("row", range(3))
def test_frame_is_the_derivative_of_the_point(row):
    curve = Curve.convex_cusp(COEFFICIENTS, END_ANGLES, row=row)
    p_end = 1 + math.sin(END_ANGLES[row])
    p = np.linspace(0.05, 0.95, 7) * p_end
    h = 1e-6
    at, ahead, behind = (curve.evaluate(q) for q in (p, p + h, p - h))
    ds_dp = 1 / at["dp_ds"]
    tangent_x = (ahead["X"] - behind["X"]) / (2 * h) / ds_dp
    tangent_y = (ahead["Y"] - behind["Y"]) / (2 * h) / ds_dp
    np.testing.assert_allclose(tangent_x, at["cos_phi"], atol=1e-8)
    np.testing.assert_allclose(tangent_y, at["sin_phi"], atol=1e-8)
    np.testing.assert_allclose(at["sin_phi"] ** 2 + at["cos_phi"] ** 2, 1.0, atol=1e-15)
    turning = (np.arctan2(ahead["sin_phi"], ahead["cos_phi"])
               - np.arctan2(behind["sin_phi"], behind["cos_phi"])) / (2 * h) / ds_dp
    np.testing.assert_allclose(turning, at["kappa"], rtol=1e-7)
    assert (at["kappa"] > 0).all()  # convex
    # the cusp: vertical, at A, a curvature whose sign points to the block's side
    cusp = curve.evaluate(0.0)
    assert (cusp["sin_phi"][0], cusp["cos_phi"][0], cusp["X"][0], cusp["Y"][0]) == (-1.0, 0.0, 0.0, 0.0)
    assert cusp["kappa"][0] > 0


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")  # roundoff notes at 1e-16
@pytest.mark.parametrize("row", range(3))
def test_point_against_quad(row):
    c, angle = COEFFICIENTS[row], END_ANGLES[row]
    curve = Curve.convex_cusp(COEFFICIENTS, END_ANGLES, row=row)
    rho = _rho(c, angle)
    opts = dict(epsabs=1e-16, epsrel=1e-15, limit=200)
    for phi in np.linspace(-0.5 * math.pi, angle, 6)[1:]:
        x = quad(lambda f: math.cos(f) * rho(f), -0.5 * math.pi, phi, **opts)[0]
        y = quad(lambda f: math.sin(f) * rho(f), -0.5 * math.pi, phi, **opts)[0]
        point = curve.evaluate(1 + math.sin(phi))
        assert abs(point["X"][0] - x) <= 2e-15 and abs(point["Y"][0] - y) <= 2e-15


def _descent_time(c, angle, mu, n=96):
    """Independent of the engine: w = u^2/2 along the curve solves the linear
    dw/dphi = -g rho (sin phi + mu cos phi) - 2 mu w (the centripetal friction
    is the -2 mu w); with z = w exp(2 mu phi), w(phi) = (phi + pi/2)^2 zeta(phi),
    zeta smooth, by nested Gauss-Legendre; T = integral rho / sqrt(2 w) dphi."""
    x, weights = np.polynomial.legendre.leggauss(n)
    span = angle + 0.5 * math.pi
    tau, wt = (x + 1) / 2, weights / 2
    theta = span * tau  # phi + pi/2 at the outer nodes

    def rho_over_theta(th):  # rho / theta = (sin(theta) / theta) exp(E)
        return np.sinc(th / math.pi) * np.exp(C.chebval(2 * th / span - 1, c))

    inner = theta[:, None] * tau[None, :]
    phi = inner - 0.5 * math.pi
    zeta = (-G * tau * rho_over_theta(inner) * np.exp(2 * mu * inner)
            * (np.sin(phi) + mu * np.cos(phi))) @ wt  # z / theta^2 (exp(2 mu phi) shifted)
    w_over_theta2 = zeta * np.exp(-2 * mu * theta)
    return float((span * rho_over_theta(theta) / np.sqrt(2 * w_over_theta2)) @ wt)


def test_all_zero_is_the_cycloid_with_its_closed_form_time():
    r = 0.7
    shape = CuspCurve(end=(math.pi * r, -2 * r), k=3)  # to the cycloid's bottom
    curves = shape.curves(np.zeros((1, 3)))
    assert curves["end_angle"][0] == pytest.approx(0.0, abs=1e-15)
    assert curves["coefficients"][0, 0] == pytest.approx(math.log(4 * r), abs=1e-14)  # rho = 4 r cos(phi)
    ds = shape.evaluate(np.zeros((1, 3)), _scene())
    assert ds.t_end.values[0] == pytest.approx(math.pi * math.sqrt(r / G), rel=1e-12)
    assert ds.speed_end.values[0] == pytest.approx(math.sqrt(2 * G * 2 * r), rel=1e-12)
    assert bool(ds.admissible[0]) and ds.status.values[0] == st.EXITED


@pytest.mark.parametrize("mu", [0.1, 0.3])
def test_descent_time_with_friction_against_an_independent_quadrature(mu):
    shape = CuspCurve(end=(2.0, -1.0), k=4)
    population = np.array([[0.0, 0.0, 0.0, 0.0], [0.05, -0.4, 0.0, 0.05], [-0.1, -0.2, 0.1, 0.0]])
    ds = shape.evaluate(population, _scene(mu))
    curves = shape.curves(population)
    for i in range(len(population)):
        reference = _descent_time(curves["coefficients"][i], curves["end_angle"][i], mu)
        assert ds.t_end.values[i] == pytest.approx(reference, rel=2e-11)
    assert ds.admissible.all()
    # the energy balance of the kernel's work: g |dy| = W_f / m + u_B^2 / 2
    np.testing.assert_allclose(ds.W_friction + ds.speed_end ** 2 / 2, G * 1.0, rtol=1e-11)


def test_the_derived_optimum_fitted_in_the_family_runs_in_its_time():
    """A check of the derivation through the engine: the extremal's rho(phi),
    fitted by Chebyshev interpolation, descends in frictional_brachistochrone's time."""
    end, mu = (1.0, -1.0), 0.2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        best = frictional_brachistochrone(end, mu, g=G)
    extremal, span = best._extremal, best.phi_end + 0.5 * math.pi
    t = np.cos(np.pi * (np.arange(40) + 0.5) / 40)
    phi = -0.5 * math.pi + (t + 1) / 2 * span
    rho = np.array([extremal.ds_dphi(f) for f in phi]) * best.scale
    c = C.chebfit(t, np.log(rho / np.cos(phi)), 39)
    curve = Curve.convex_cusp(c[None], [best.phi_end])
    out = rw.curves.simulate_curve(curve, s0=0.0, mu_k=mu, g=G, method="dopri5", rtol=1e-12,
                                   t_max=10.0, row=0, end_angle=best.phi_end)
    assert out["status_name"] == "exited"
    assert (out["X_end"], out["Y_end"]) == (pytest.approx(1.0, abs=1e-14), pytest.approx(-1.0, abs=1e-14))
    assert out["t_end"] == pytest.approx(best.time, rel=1e-11)


def test_every_candidate_ends_at_b_to_rounding():
    shape = CuspCurve(end=(1.5, -0.8), k=5)
    lo, hi = np.array(shape.bounds).T
    population = lo + (hi - lo) * RNG.random((40, 5)) * 0.5 + (hi - lo) * 0.25
    ds = shape.evaluate(population, _scene(0.05, rtol=1e-8))
    through = ds.through_b.values
    assert through.sum() >= 30
    curves = shape.curves(population[through])
    for i, row in enumerate(np.flatnonzero(through)):
        curve = Curve.convex_cusp(curves["coefficients"], curves["end_angle"], row=i)
        point = curve.evaluate(1 + math.sin(curves["end_angle"][i]))
        # to rounding: the 65-term Clenshaw sums and the end's t = 1 from p = 1 + sin(phi_B)
        assert abs(point["X"][0] - 1.5) <= 1e-14 and abs(point["Y"][0] + 0.8) <= 1e-14
        if ds.arrived.values[row]:  # the trajectory ends there too
            assert abs(ds.X_end.values[row] - 1.5) <= 1e-14 and abs(ds.Y_end.values[row] + 0.8) <= 1e-14


def test_candidates_that_are_not_admissible_are_flagged_with_finite_values():
    shape = CuspCurve(end=(2.0, -1.0), k=2)
    # the cycloid sticks at mu = 0.4 towards (2, -1); a curve that turns up too late misses B
    population = np.array([[0.0, 0.0], [0.0, 0.0], [-4.0, 2.4]])
    ds = shape.evaluate(population, _scene(0.4))
    assert ds.status.values[0] == st.STUCK and not ds.arrived.values[0] and not ds.admissible.values[0]
    assert ds.through_b.values[0] and not ds.through_b.values[2] and not ds.admissible.values[2]
    for name in ("t_end", "W_friction", "W_excess", "speed_end", "end_angle", "length"):
        assert np.isfinite(ds[name].values).all(), name
    assert ds.status.attrs["flag_meanings"].split()[st.STUCK] == "stuck"
    assert ds.sizes == {"candidate": 3} and list(ds.c1.values) == [0.0, 0.0, -4.0]


def test_the_batch_equals_the_candidates_one_by_one():
    shape = CuspCurve(end=(1.0, -1.0), k=4)
    lo, hi = np.array(shape.bounds).T
    population = lo + (hi - lo) * RNG.random((9, 4))
    scene = _scene(0.2, rtol=1e-9)
    batch = shape.evaluate(population, scene)
    for i in range(len(population)):
        one = shape.evaluate(population[i:i + 1], scene)
        for name in ("t_end", "W_friction", "W_excess", "speed_end", "status", "admissible", "end_angle"):
            assert one[name].values[0] == batch[name].values[i] or (
                np.isnan(one[name].values[0]) and np.isnan(batch[name].values[i])), (i, name)


def test_protocol_and_refusals():
    shape = CuspCurve(end=(2.0, -1.0), k=6)
    assert shape.names == ("c1", "c2", "c3", "c4", "c5", "c6") and len(shape.bounds) == 6
    assert all(lo < 0 < hi for lo, hi in shape.bounds)
    with pytest.raises(ConfigError, match="end"):
        CuspCurve(end=(1.0, 0.5))
    with pytest.raises(ConfigError, match="k"):
        CuspCurve(end=(1.0, -1.0), k=0)
    with pytest.raises(ConfigError, match="population"):
        shape.evaluate(np.zeros((3, 5)), _scene())
    with pytest.raises(ConfigError, match="scene"):
        shape.evaluate(np.zeros((3, 6)), object())  # a rampwork.Scene is for y = f(x) shapes
    with pytest.raises(ConfigError, match="end_angle"):
        Curve.convex_cusp(np.zeros((1, 2)), [1.6])
    with pytest.raises(ConfigError, match="row"):
        Curve.convex_cusp(np.zeros((2, 2)), [0.1, 0.2], row=2)


def test_a_local_optimisation_through_the_engine_finds_the_derived_optimum():
    """BFGS over c_1..c_4 from the cycloid, each value and central-difference
    gradient one kernel call (9 candidates): the frictional brachistochrone's
    time to 1e-9 (benchmarks/cusp_optimise.py: DE and larger K)."""
    from scipy.optimize import minimize

    end, mu, k = (1.0, -1.0), 0.1, 4
    shape, scene = CuspCurve(end=end, k=k), _scene(mu)
    calls = []

    def value_and_gradient(x, step=1e-5):
        rows = np.vstack([x, x + step * np.eye(k), x - step * np.eye(k)])
        ds = shape.evaluate(rows, scene)
        calls.append(ds.sizes["candidate"])
        assert ds.admissible.all()
        t = ds.t_end.values
        return t[0], (t[1:k + 1] - t[k + 1:]) / (2 * step)

    result = minimize(value_and_gradient, np.zeros(k), jac=True, method="BFGS", options=dict(gtol=1e-9))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        best = frictional_brachistochrone(end, mu, g=G).time
    cycloid = shape.evaluate(np.zeros((1, k)), scene).t_end.values[0]
    assert cycloid / best - 1 > 1e-5  # the cycloid is slower by 0.005 % ...
    assert -1e-11 < result.fun / best - 1 < 1e-9  # ... the optimum found is the derived one
    assert set(calls) == {2 * k + 1}


def _cycloid_time(end):
    """theta sqrt(r / g) of the cycloid from its cusp at A through B (closed form, r and theta by brentq)."""
    from scipy.optimize import brentq

    bx, by = end
    theta = brentq(lambda t: (t - math.sin(t)) * -by - bx * (1 - math.cos(t)), 1e-6, 2 * math.pi - 1e-9)
    return theta * math.sqrt(-by / (1 - math.cos(theta)) / G)


def test_rw_optimise_with_the_curve_shape_recovers_the_cycloid_without_friction():
    """Through rw.optimise (DE from a random population, then the batched
    central-difference polish): the cycloid's closed-form time to 1e-6."""
    end = (2.0, -1.0)
    history = rw.optimise(_scene(0.0), CuspCurve(end=end, k=2), "t_end", seed=1, popsize=5,
                          maxiter=20, tol=1e-12, polish=True, threads=1)
    best, cycloid = history.attrs["best_objective"], _cycloid_time(end)
    assert abs(best / cycloid - 1) < 1e-6
    assert best > cycloid * (1 - 1e-11)  # nothing through B beats the cycloid without friction
    assert np.abs(history.attrs["best_parameters_final"]).max() < 0.05  # all zero is the cycloid


def test_rw_optimise_with_the_curve_shape_lands_on_the_frictional_optimum():
    """mu = 0.2 towards (1, -1), K = 2: within 1e-6 of the derived optimum's
    time, and no candidate that arrives (final population or best) beats it
    beyond the integrator's rounding (rtol 1e-12)."""
    end, mu = (1.0, -1.0), 0.2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        optimum = frictional_brachistochrone(end, mu, g=G).time
    scene = _scene(mu)
    history = rw.optimise(scene, CuspCurve(end=end, k=2), "t_end", seed=1, popsize=6, maxiter=30,
                          tol=1e-12, polish=True, threads=1)
    best = history.attrs["best_objective"]
    assert optimum * (1 - 1e-10) < best < optimum * (1 + 1e-6)
    arrived = history["feasible"].values
    assert arrived.sum() >= 6
    assert (history["objective"].values[arrived] > optimum * (1 - 1e-10)).all()
    cycloid = CuspCurve(end=end, k=2).evaluate(np.zeros((1, 2)), scene).t_end.values[0]
    assert best < cycloid  # and it beats the frictionless cycloid through B


def test_end_angles_against_scipy_root_finding_on_the_numpy_quadrature():
    """The jitted end-angle search (core/cusp_end.py) against scipy's brentq
    on the end's direction by ``convex_cusp_end`` (numpy), per candidate."""
    from scipy.optimize import brentq

    from rampwork.curve_families import convex_cusp_end

    shape = CuspCurve(end=(2.0, -1.0), k=6)
    lo, hi = np.array(shape.bounds).T
    population = lo + (hi - lo) * RNG.random((24, 6)) * 0.3 + (hi - lo) * 0.35
    curves = shape.curves(population)
    assert curves["through_b"].all()
    target = math.atan2(-1.0, 2.0)

    def miss(angle, row):
        x, y, _ = convex_cusp_end(np.hstack([[0.0], row])[None], np.array([angle]))
        return math.atan2(y[0], x[0]) - target

    for row, angle in zip(population, curves["end_angle"]):
        found = brentq(miss, -0.5 * math.pi + 1e-6, 0.5 * math.pi - 1e-3, args=(row,), xtol=1e-15, rtol=1e-15)
        assert angle == pytest.approx(found, abs=1e-13)
        assert abs(miss(angle, row)) <= 1e-14
