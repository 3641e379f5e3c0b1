"""The frictional brachistochrone (rampwork.brachistochrone) against closed forms,
the energy balance and an independent direct optimisation."""

import math
import warnings

import numpy as np
import pytest
from numpy.polynomial import chebyshev as C
from scipy.integrate import simpson
from scipy.optimize import brentq, minimize

from rampwork.brachistochrone import frictional_brachistochrone
from rampwork.errors import ConfigError

G = 9.81


@pytest.fixture(autouse=True)
def _quiet_quad():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # quad's roundoff notes near the cusp
        yield


def test_without_friction_it_is_the_cycloid_through_b():
    dx, dy = 2.0, -1.0
    theta = brentq(lambda t: (t - math.sin(t)) / (1 - math.cos(t)) - dx / -dy, 0.1, 2 * math.pi - 1e-3)
    r = -dy / (1 - math.cos(theta))
    best = frictional_brachistochrone((dx, dy), mu=0.0, g=G)
    assert best.time == pytest.approx(theta * math.sqrt(r / G), rel=1e-12)
    assert best.phi_end == pytest.approx(theta / 2 - math.pi / 2, abs=1e-12)  # dips below B
    c = best.curve(41)
    t = 2 * c["phi"] + math.pi  # the cycloid's rolling angle at tangent angle phi
    np.testing.assert_allclose(c["X"], r * (t - np.sin(t)), atol=1e-12)
    np.testing.assert_allclose(c["Y"], -r * (1 - np.cos(t)), atol=1e-12)
    np.testing.assert_allclose(c["u"], np.sqrt(-2 * G * c["Y"]), atol=1e-11)


@pytest.mark.parametrize("mu", [0.1, 0.4])
def test_energy_balance_and_contact_along_the_curve(mu):
    best = frictional_brachistochrone((1.0, -1.0), mu=mu, g=G)
    c = best.curve(121)
    assert c["X"][-1] == pytest.approx(1.0, abs=1e-12) and c["Y"][-1] == pytest.approx(-1.0, abs=1e-12)
    assert np.all(c["u"][1:] > 0) and np.all(c["kappa"] > 0) and np.all(np.diff(c["s"]) > 0)
    # the work against friction from the model's normal force, against the energy the drop lost
    rho = np.concatenate([[0.0], 1 / c["kappa"][1:]])  # ds/dphi
    work = mu * simpson(c["u"] ** 2 + G * np.cos(c["phi"]) * rho, x=c["phi"])  # mu int nu ds
    assert work + c["u"][-1] ** 2 / 2 == pytest.approx(G * 1.0, rel=1e-8)
    nu = c["kappa"][1:] * c["u"][1:] ** 2 + G * np.cos(c["phi"][1:])
    assert np.all(nu > 0)  # the block stays on: the stay-on constraint is not active


# ---- an independent check: a direct optimisation over convex curves ----------------------------
# rho(phi) = ds/dphi = cos(phi) exp(sum c_k T_k), phi from -pi/2 (vertical start) to phi_end;
# with w = u^2 / 2 the model is linear along the curve: dw/dphi = -g rho (sin + mu cos) - 2 mu w.
N = 64
_t = np.cos(np.pi * np.arange(N + 1) / N)[::-1]
_Q = np.stack([C.chebval(_t, C.chebint(col, lbnd=-1)) for col in np.linalg.inv(C.chebvander(_t, N)).T], axis=1)


def _descent(params, mu):
    coef, phi_end = params[:-1], params[-1]
    half = (phi_end + math.pi / 2) / 2
    phi = -math.pi / 2 + (_t + 1) * half
    rho = np.cos(phi) * np.exp(C.chebval(_t, coef))
    x, y = (_Q @ (rho * np.cos(phi))) * half, (_Q @ (rho * np.sin(phi))) * half
    w = (_Q @ (-G * rho * np.exp(2 * mu * phi) * (np.sin(phi) + mu * np.cos(phi)))) * half * np.exp(-2 * mu * phi)
    f = np.empty_like(phi)
    f[1:] = rho[1:] / np.sqrt(2 * np.maximum(w[1:], 1e-300))
    f[0] = math.sqrt(math.exp(C.chebval(-1.0, coef)) / G)  # rho ~ a (phi + pi/2), w ~ g a (phi + pi/2)^2 / 2
    return x[-1], y[-1], ((_Q @ f) * half)[-1], w[1:].min()


def _direct_optimum(mu, end, K):
    """Shape coefficients c_1..c_K free (c_0 = 0: the size follows from B, time scales as
    the root of it); phi_end puts B on the chord's direction."""
    target = math.atan2(end[1], end[0])

    def time(tail):
        coef = np.concatenate([[0.0], tail])
        angle = lambda phi_end: math.atan2(*_descent(np.append(coef, phi_end), mu)[1::-1]) - target
        grid = np.linspace(-math.pi / 2 + 0.05, math.pi / 2 - 1e-3, 40)
        values = [angle(p) for p in grid]
        roots = [brentq(angle, a, b, xtol=1e-15) for a, b, fa, fb in zip(grid, grid[1:], values, values[1:]) if fa * fb < 0]
        x, y, t, w_min = _descent(np.append(coef, roots[0]), mu)
        return t * math.sqrt(math.hypot(*end) / math.hypot(x, y)) if w_min >= 0 else 1e3

    result = minimize(time, np.zeros(K), method="BFGS", options=dict(gtol=1e-12))
    return result.fun


@pytest.mark.parametrize("mu, end", [(0.2, (2.0, -1.0)), pytest.param(0.4, (1.0, -1.0), marks=pytest.mark.slow)])
def test_no_convex_curve_found_directly_is_faster(mu, end):
    best = frictional_brachistochrone(end, mu=mu, g=G)
    direct = _direct_optimum(mu, np.array(end), K=8)
    assert direct >= best.time * (1 - 1e-11)  # nothing beats the extremal ...
    assert direct <= best.time * (1 + 1e-9)  # ... and the direct search finds it (K = 8: 1e-11)


def test_with_friction_the_cycloid_is_no_longer_fastest():
    end = (2.0, -1.0)
    cycloid = frictional_brachistochrone(end, mu=0.0, g=G)
    c = cycloid.curve(2)
    # the frictionless cycloid's rho = 4 r cos(phi): a constant coefficient in _descent
    r = -end[1] / (1 - math.cos(2 * cycloid.phi_end + math.pi))
    params = np.array([math.log(4 * r), cycloid.phi_end])
    assert _descent(params, 0.0)[2] == pytest.approx(cycloid.time, rel=1e-12)
    assert c["X"][-1] == pytest.approx(end[0], abs=1e-12)
    for mu, most in ((0.1, 0.003), (0.2, 0.005)):
        on_cycloid = _descent(params, mu)[2]
        best = frictional_brachistochrone(end, mu=mu, g=G).time
        assert 0 < (on_cycloid - best) / on_cycloid < most


def test_bad_input_is_refused_with_what_is_allowed():
    with pytest.raises(ConfigError, match="mu"):
        frictional_brachistochrone((1.0, -1.0), mu=-0.1)
    with pytest.raises(ConfigError, match="end"):
        frictional_brachistochrone((1.0, 0.5), mu=0.1)
    with pytest.raises(ConfigError, match="at least 22.* degrees below"):
        frictional_brachistochrone((2.0, -0.5), mu=0.4)
