"""Ramp families: closed forms, derivatives, the cycloid inverse, the spline,
bitwise agreement of scalar and vector paths, validation and curvature signs."""

from __future__ import annotations

import json
import math
from decimal import Decimal, getcontext

import numba
import numpy as np
import pytest

from rampwork import ramps
from rampwork.core import cycloid
from rampwork.core import ramps as core
from rampwork.core.jit import specialise
from rampwork.errors import ConfigError
from rampwork.ramps import FAMILIES, Ramp

SAMPLES = {
    "straight": Ramp.create("straight", slope=-0.4, height=1.5, domain=(-2.0, 3.0)),
    "quadratic": Ramp.create("quadratic", curvature=0.7, slope=-0.3, height=0.2, domain=(-2.0, 2.5)),
    "circular_bowl": Ramp.create("circular_bowl", radius=2.0, x_centre=0.3, y_bottom=-1.0, domain=(-1.5, 2.1)),
    "circular_dome": Ramp.create("circular_dome", radius=1.5, x_centre=-0.2, y_centre=0.5, domain=(-1.6, 1.2)),
    "cycloid": Ramp.create("cycloid", radius=0.8, domain=(-2.4, 2.4)),
    "sine": Ramp.create("sine", mean_slope=-0.3, amplitude=0.2, wavenumber=3.0, phase=0.4, domain=(-2.0, 4.0)),
    "spline": Ramp.create("spline", x_points=[-1.0, -0.2, 0.5, 1.0, 2.2, 3.0],
                          y_points=[1.0, 0.3, 0.1, 0.25, 0.2, 0.9]),
}


@numba.njit
def _user_f(x):
    return math.cosh(x) - 1.0


@numba.njit
def _user_fp(x):
    return math.sinh(x)


@numba.njit
def _user_fpp(x):
    return math.cosh(x)


SAMPLES["callable"] = Ramp.from_functions(_user_f, _user_fp, _user_fpp, domain=(-1.0, 1.5), curvature_sign=1)


def _scalar(ramp: Ramp, x: float):
    spec = ramp.spec
    p = ramp.packed()
    shared = ramp.shared_array()
    return (spec.height(x, *p, shared), *spec.slope_curvature(x, *p, shared))


def _interior(ramp: Ramp, n=301, margin=0.02):
    lo, hi = ramp.domain
    w = hi - lo
    return np.linspace(lo + margin * w, hi - margin * w, n)


# -- derivatives against finite differences ------------------------------------


@pytest.mark.parametrize("name", list(SAMPLES))
def test_derivatives_match_finite_differences(name):
    ramp = SAMPLES[name]
    x = _interior(ramp)
    h = 1e-4 * (ramp.domain[1] - ramp.domain[0])
    if name == "spline":  # stay off the knots, where the third derivative jumps
        knots = ramps.spline_arrays(ramp.shared)[0]
        x = x[np.min(np.abs(x[:, None] - knots[None, :]), axis=1) > 3 * h]
    f, fp, fpp = ramp.evaluate(x)
    (f2l, fp2l, _), (fl, fpl, _), (fr, fpr, _), (f2r, fp2r, _) = (ramp.evaluate(x + k * h) for k in (-2, -1, 1, 2))
    # 4th-order central differences: error ~ h^4 |f^(5)| / 30 plus rounding
    np.testing.assert_allclose((f2l - 8 * fl + 8 * fr - f2r) / (12 * h), fp, rtol=1e-8,
                               atol=1e-8 * (1 + np.abs(fp).max()))
    np.testing.assert_allclose((fp2l - 8 * fpl + 8 * fpr - fp2r) / (12 * h), fpp, rtol=1e-8,
                               atol=1e-8 * (1 + np.abs(fpp).max()))
    # and second differences of f
    np.testing.assert_allclose((fr - 2 * f + fl) / h**2, fpp, rtol=1e-5, atol=1e-5 * (1 + np.abs(fpp).max()))


# -- closed forms ---------------------------------------------------------------


def test_straight_quadratic_sine_closed_forms():
    x = np.linspace(-2.0, 2.0, 41)
    f, fp, fpp = SAMPLES["straight"].evaluate(x)
    np.testing.assert_allclose(f, 1.5 - 0.4 * x, rtol=1e-15, atol=1e-15)
    assert (fp == -0.4).all() and (fpp == 0.0).all()
    f, fp, fpp = SAMPLES["quadratic"].evaluate(x)
    np.testing.assert_allclose(f, 0.2 - 0.3 * x + 0.7 * x**2 / 2, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(fp, -0.3 + 0.7 * x, rtol=1e-14, atol=1e-15)
    assert (fpp == 0.7).all()
    f, fp, fpp = SAMPLES["sine"].evaluate(x)
    theta = 3.0 * x + 0.4
    np.testing.assert_allclose(f, -0.3 * x + 0.2 * np.sin(theta), rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(fp, -0.3 + 0.6 * np.cos(theta), rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(fpp, -1.8 * np.sin(theta), rtol=1e-14, atol=1e-15)


@pytest.mark.parametrize("name, sign", [("circular_bowl", 1), ("circular_dome", -1)])
def test_circle_closed_forms(name, sign):
    ramp = SAMPLES[name]
    p = ramp.param_dict()
    r, xc = p["radius"], p["x_centre"]
    yc = p["y_bottom"] + r if name == "circular_bowl" else p["y_centre"]  # the centre
    lo, hi = ramp.domain
    x = np.concatenate([np.linspace(lo, hi, 201), [xc - r * (1 - 1e-9), xc + r * (1 - 1e-12)]])
    f, fp, fpp = ramp.evaluate(x)
    getcontext().prec = 60
    for xi, fi, fpi, fppi in zip(x, f, fp, fpp):  # 60-digit reference
        d = Decimal(xi) - Decimal(xc)
        root = (Decimal(r) ** 2 - d * d).sqrt()
        assert fi == pytest.approx(float(Decimal(yc) - sign * root), rel=4e-16, abs=4e-16 * (r + abs(yc)))
        assert fpi == pytest.approx(float(sign * d / root), rel=1e-15, abs=1e-300)
        assert fppi == pytest.approx(float(sign * Decimal(r) ** 2 / root**3), rel=1e-15)
    # on the circle: (x - xc)^2 + (y - yc)^2 = r^2, the tangent is perpendicular to the radius
    d = x[:201] - xc
    np.testing.assert_allclose(d**2 + (f[:201] - yc) ** 2, r**2, rtol=1e-13)
    np.testing.assert_allclose(d + (f[:201] - yc) * fp[:201], 0.0, atol=1e-13)


# -- cycloid ------------------------------------------------------------------

getcontext().prec = 60
_PI = Decimal("3.14159265358979323846264338327950288419716939937510582097494459")


def _dsin(x: Decimal) -> Decimal:
    getcontext().prec += 5
    i, last, total, fact, num, sign = 1, 0, x, 1, x, 1
    while total != last:
        last = total
        i += 2
        fact *= i * (i - 1)
        num *= x * x
        sign = -sign
        total += num / fact * sign
    getcontext().prec -= 5
    return +total


def _cycloid_reference(x: float, r: float):
    """|u| and pi - |u| at the float x, by Newton in 60-digit decimals."""
    s = Decimal(abs(x)) / Decimal(r)
    if s == 0:
        return Decimal(0), _PI
    if s < 2:
        u = s / 2
        for _ in range(100):
            new = u - (u + _dsin(u) - s) / (1 + _dsin(_PI / 2 - u))
            if new == u:
                break
            u = new
        return u, _PI - u
    t = _PI - s
    w = (6 * t) ** (Decimal(1) / 3)
    for _ in range(100):
        new = w - (w - _dsin(w) - t) / (1 - _dsin(_PI / 2 - w))
        if new == w:
            break
        w = new
    return _PI - w, w


def _ulps(value: float, exact: Decimal) -> float:
    ref = float(exact)
    return float(abs(Decimal(value) - exact) / Decimal(math.ulp(ref))) if ref != 0 else abs(value) / 5e-324


@pytest.mark.parametrize("r", [1.0, 0.37, 123.4])
def test_cycloid_inverse_to_an_ulp(r):
    """u(x) by fixed-count Newton, against a 60-digit inverse, over the whole
    open domain: the centre, the switch between the two formulations and both
    cusps (where the cube-root guess matters)."""
    rng = np.random.default_rng(7)
    s = np.concatenate([
        np.linspace(-1, 1, 61) * math.pi * (1 - 1e-7),
        rng.uniform(-math.pi, math.pi, 60),
        [math.pi - 10.0**-k for k in range(1, 16)],
        [-(math.pi - 10.0**-k) for k in (3, 9, 15)],
        core.CYCLOID_SPLIT * (1 + np.array([-1e-15, -1e-9, 0.0, 1e-15, 1e-9])),
        [1e-300, 1e-10, 1e-5, np.nextafter(math.pi, 0)],
    ])
    worst = {"z": 0.0, "y": 0.0, "fp": 0.0, "fpp": 0.0}
    for x in s * r:
        x = float(x)
        if not abs(x) < math.pi * r or core.cycloid_cusp_gap(abs(x), r) <= 0:
            continue
        u, w = _cycloid_reference(x, r)
        sin_half, cos_half = cycloid._cycloid_half_angle(x, r)
        if abs(x) / r < core.CYCLOID_SPLIT:  # solved for z = |u|
            z_err = _ulps(2 * math.atan2(sin_half, cos_half), u)
        else:  # solved for z = pi - |u|
            z_err = _ulps(2 * math.atan2(cos_half, sin_half), w)
        y, fp, fpp = _scalar(_cycloid_ramp(r), x)
        sh, ch = _dsin(u / 2), _dsin(w / 2)  # sin(u/2), cos(u/2)
        exact = {"y": 2 * Decimal(r) * sh * sh, "fp": (sh / ch) * (1 if x >= 0 else -1),
                 "fpp": 1 / (4 * Decimal(r) * ch**4)}
        for key, value in (("y", y), ("fp", fp), ("fpp", fpp)):
            worst[key] = max(worst[key], _ulps(value, exact[key]))
        worst["z"] = max(worst["z"], z_err)
    assert worst["z"] <= 3, worst
    assert worst["y"] <= 6 and worst["fp"] <= 6, worst
    assert worst["fpp"] <= 12, worst  # cos(u/2)**4 multiplies the 1-ulp error by 4


def _cycloid_long_double(x, r):
    """(f, f', f'') at x by Newton in long double (64-bit mantissa: 11 bits
    more than a double); r a power of 2, so that |x| / r is exact."""
    L = np.longdouble
    pi_hi = L("3.14159265358979323846264338327950288")
    hi = float(pi_hi)
    pi_lo = L(float(_PI - Decimal(hi) - Decimal(float(pi_hi - L(hi)))))
    s = np.abs(x).astype(L) / L(r)
    centre = s < L(core.CYCLOID_SPLIT)
    z = s / 2
    for _ in range(8):  # z + sin z = s
        z = z - (z + np.sin(z) - s) / (1 + np.cos(z))
    t = np.where(centre, L(1), (pi_hi - s) + pi_lo)  # exact subtraction: Sterbenz
    w = np.cbrt(6 * t)
    for _ in range(10):  # w - sin w = t; w - sin w as a series where it cancels
        w2 = w * w
        series = w * w2 * (L(1) / 6 - w2 * (L(1) / 120 - w2 * (L(1) / 5040 - w2 * (
            L(1) / 362880 - w2 * (L(1) / 39916800 - w2 / L(6227020800))))))
        w = w - (np.where(w < 0.1, series, w - np.sin(w)) - t) / (2 * np.sin(w / 2) ** 2)
    sh = np.where(centre, np.sin(z / 2), np.cos(w / 2))  # sin(u/2), cos(u/2)
    ch = np.where(centre, np.cos(z / 2), np.sin(w / 2))
    return 2 * L(r) * sh * sh, np.copysign(sh / ch, x.astype(L)), 1 / (4 * L(r) * ch**4)


@pytest.mark.skipif(np.finfo(np.longdouble).nmant < 63, reason="needs an 80-bit long double")
@pytest.mark.parametrize("r", [1.0, 0.5])
def test_cycloid_against_long_double(r):
    """f, f', f'' over 3e5 points (uniform, both cusps down to pi - |u| = 1e-5,
    the switch between the formulations, x -> 0), against a long double
    inverse.  Measured over 1e7 points per range (benchmarks/vmath.py): at
    most 4.7, 4.1 and 13.9 ulp (f'' = (1 + f'^2)^2 / 4r multiplies the
    error of f' by up to 4 near the cusps); the mean stays below 2 ulp."""
    rng = np.random.default_rng(8)
    n = 100_000
    w = 10.0 ** rng.uniform(-5.0, math.log10(math.pi / 2), n).astype(np.longdouble)
    x = np.concatenate([rng.uniform(-math.pi * r, math.pi * r, n),
                        (r * (np.longdouble(math.pi) - (w - np.sin(w)))).astype(np.float64),
                        core.CYCLOID_SPLIT * r * (1.0 + rng.uniform(-1e-6, 1e-6, n // 2)),
                        10.0 ** rng.uniform(-300.0, -1.0, n // 2)])
    x = x * rng.choice([-1.0, 1.0], x.size)
    x = x[[abs(v) < math.pi * r and core.cycloid_cusp_gap(abs(float(v)), r) > 0 for v in x]]
    got = _cycloid_ramp(r).evaluate(x)
    for name, value, exact, bound in zip(("f", "f'", "f''"), got, _cycloid_long_double(x, r), (6, 6, 16)):
        ulp = np.spacing(np.abs(exact.astype(np.float64))).astype(np.longdouble)
        err = np.abs((value.astype(np.longdouble) - exact) / ulp).astype(np.float64)
        assert err.max() <= bound, (name, err.max(), x[np.argmax(err)])
        assert err.mean() < 2, (name, err.mean())


def _cycloid_ramp(r):
    return Ramp.create("cycloid", radius=r, domain=(-1e-3, 1e-3))


@pytest.mark.parametrize("r", [0.8, 2.5])
def test_cycloid_parametric_closed_forms(r):
    """At x = r(u + sin u): y = r(1 - cos u), f' = tan(u/2), f'' = 1/(4 r cos^4(u/2)),
    up to the rounding of x itself (amplified by du/dx = 1/(r(1 + cos u)) near the cusps)."""
    ramp = _cycloid_ramp(r)
    # w = pi - |u| down to 1e-4: closer, x(u) itself rounds onto the cusp
    w = np.concatenate([np.linspace(0.05, 0.95, 37) * math.pi, [10.0**-k for k in range(1, 5)]])
    u = np.concatenate([math.pi - w, -(math.pi - w), np.linspace(-1, 1, 21)])
    x = r * (u + np.sin(u))
    y, fp, fpp = ramp.evaluate(x)
    dudx = 1 / (r * (1 + np.cos(u)))
    du = 4 * (np.spacing(np.abs(x)) * dudx + np.spacing(np.abs(u)) + 1e-300)
    u_got = np.array([core.cycloid_parameter(float(xi), r) for xi in x])
    assert (np.abs(u_got - u) <= du).all()
    np.testing.assert_allclose(y, r * (1 - np.cos(u)), rtol=0, atol=1e-14 * r + (r * np.abs(np.sin(u)) * du).max())
    rel = du / np.abs(np.sin(u) + 1e-300) + 1e-14  # d log tan(u/2) / du = 1 / sin u
    assert (np.abs(fp - np.tan(u / 2)) <= rel * np.abs(np.tan(u / 2)) + 1e-15).all()
    rel = 2 * np.abs(np.tan(u / 2)) * du + 1e-14  # d log cos^-4(u/2) / du = 2 tan(u/2)
    assert (np.abs(fpp - 1 / (4 * r * np.cos(u / 2) ** 4)) <= rel * fpp).all()


def test_cycloid_is_smooth_across_the_switch():
    r = 1.0
    ramp = _cycloid_ramp(r)
    x0 = core.CYCLOID_SPLIT * r
    x = x0 + np.arange(-50, 51) * np.spacing(x0)
    f, fp, fpp = ramp.evaluate(x)
    for values in (f, fp, fpp):
        assert np.all(np.diff(values) >= 0)  # monotone: no jump at the switch
        assert values.max() - values.min() < 1e-12 * abs(values).max()


# -- spline --------------------------------------------------------------------


def test_spline_interpolates_is_c2_and_natural():
    ramp = SAMPLES["spline"]
    x_points, y_points, m = ramps.spline_arrays(ramp.shared)
    f, fp, fpp = ramp.evaluate(x_points)
    np.testing.assert_array_equal(f, y_points)
    assert fpp[0] == 0.0 and fpp[-1] == 0.0 and m[0] == 0.0 and m[-1] == 0.0
    left = np.nextafter(x_points[1:-1], -np.inf)
    fl, fpl, fppl = ramp.evaluate(left)
    fr, fpr, fppr = ramp.evaluate(x_points[1:-1])
    np.testing.assert_allclose(fl, fr, rtol=0, atol=1e-14)
    np.testing.assert_allclose(fpl, fpr, rtol=0, atol=1e-13)
    np.testing.assert_allclose(fppl, fppr, rtol=0, atol=1e-12)


def test_spline_matches_scipy_natural_spline():
    interpolate = pytest.importorskip("scipy.interpolate")
    rng = np.random.default_rng(3)
    for n in (3, 4, 5, 17, 100):
        x_points = np.cumsum(rng.uniform(0.1, 1.0, n))
        y_points = rng.normal(size=n)
        ramp = ramps.spline(x_points, y_points)
        reference = interpolate.CubicSpline(x_points, y_points, bc_type="natural")
        x = np.concatenate([rng.uniform(x_points[0], x_points[-1], 500), x_points])
        f, fp, fpp = ramp.evaluate(x)
        scale = 1 + np.abs(y_points).max()
        np.testing.assert_allclose(f, reference(x), rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(fp, reference(x, 1), rtol=0, atol=1e-11 * scale)
        np.testing.assert_allclose(fpp, reference(x, 2), rtol=0, atol=1e-10 * scale)


def test_spline_interval_search_clamps_outside_the_knots():
    ramp = ramps.spline([0.0, 1.0, 2.0, 4.0], [0.0, 1.0, 0.0, 2.0])
    shared = ramp.shared_array()
    for x, expected in [(-5.0, 0), (0.0, 0), (0.99, 0), (1.0, 1), (3.9, 2), (4.0, 2), (10.0, 2)]:
        assert core._spline_interval(x, shared) == expected


def test_spline_domain_defaults_to_knots_and_must_lie_inside():
    ramp = ramps.spline([0.0, 1.0, 3.0], [0.0, 1.0, 0.0])
    assert ramp.domain == (0.0, 3.0)
    assert ramps.spline([0.0, 1.0, 3.0], [0.0, 1.0, 0.0], domain=(0.5, 2.0)).domain == (0.5, 2.0)
    with pytest.raises(ConfigError, match=r"ramp\.domain.*inside the spline's points \[0\.0, 3\.0\]"):
        ramps.spline([0.0, 1.0, 3.0], [0.0, 1.0, 0.0], domain=(-1.0, 2.0))


# -- scalar and vector paths agree to the bit -------------------------------------


@pytest.mark.parametrize("name", list(SAMPLES))
def test_scalar_and_vector_paths_are_bitwise_equal(name):
    ramp = SAMPLES[name]
    lo, hi = ramp.domain
    x = np.concatenate([np.linspace(lo, hi, 97), np.random.default_rng(0).uniform(lo, hi, 64)])
    f, fp, fpp = ramp.evaluate(x)
    scalar = np.array([_scalar(ramp, float(xi)) for xi in x])
    for got, want in zip((f, fp, fpp), scalar.T):
        assert got.tobytes() == np.ascontiguousarray(want).tobytes()


def _lanes_template(x, p0, p1, p2, p3, shared, f, fp, fpp):
    """A lane loop like the batch kernel's: per-lane parameters, vectorisable."""
    for i in range(x.size):
        f[i] = RAMP_HEIGHT(x[i], p0[i], p1[i], p2[i], p3[i], shared)  # noqa: F821
        slope, curvature = RAMP_SLOPE_CURVATURE(x[i], p0[i], p1[i], p2[i], p3[i], shared)  # noqa: F821
        fp[i] = slope
        fpp[i] = curvature


@pytest.mark.parametrize("name", list(SAMPLES))
def test_lane_loop_and_scalar_calls_are_bitwise_equal(name):
    ramp = SAMPLES[name]
    spec = ramp.spec
    lanes = specialise(_lanes_template, f"test_lanes_{spec.key}",
                       {"RAMP_HEIGHT": spec.height, "RAMP_SLOPE_CURVATURE": spec.slope_curvature}, cache=False)
    lo, hi = ramp.domain
    n = 203  # not a multiple of the vector width: the remainder loop too
    x = np.random.default_rng(1).uniform(lo, hi, n)
    scale = np.random.default_rng(2).uniform(0.9, 1.1, n) if spec.parameters else np.ones(n)
    values = {k: v * scale for k, v in ramp.param_dict().items()}
    if name in ("circular_bowl", "circular_dome", "cycloid"):
        values["radius"] = ramp.param_dict()["radius"] * np.maximum(scale, 1.0)  # stay inside the domain
    spec.check_values(values, ramp.domain)
    p = spec.pack(values, n=n)
    out = [np.empty(n) for _ in range(3)]
    lanes(x, *p, ramp.shared_array(), *out)
    scalar = np.array([(spec.height(x[i], p[0][i], p[1][i], p[2][i], p[3][i], ramp.shared_array()),
                        *spec.slope_curvature(x[i], p[0][i], p[1][i], p[2][i], p[3][i], ramp.shared_array()))
                       for i in range(n)])
    for got, want in zip(out, scalar.T):
        assert got.tobytes() == np.ascontiguousarray(want).tobytes()


def test_evaluate_keeps_shape():
    f, fp, fpp = SAMPLES["quadratic"].evaluate(np.zeros((2, 3)))
    assert f.shape == fp.shape == fpp.shape == (2, 3)
    f, _, _ = SAMPLES["quadratic"].evaluate(0.5)
    assert f.shape == ()


# -- validation -------------------------------------------------------------------

BAD = [
    (dict(family="bogus", domain=(0, 1)), r"ramp\.family: unknown ramp family 'bogus'; allowed: 'straight', "
                                          r"'quadratic', 'circular_bowl', 'circular_dome', 'cycloid', 'sine', 'spline'"),
    (dict(family=3, domain=(0, 1)), r"ramp\.family: unknown"),
    (dict(family="callable", domain=(0, 1)), r"ramp\.family: .*from_functions"),
    (dict(family="straight", slope=1.0, slop=2.0, domain=(0, 1)),
     r"ramp\.slop: unknown parameter for ramp family 'straight'; allowed: slope, height"),
    (dict(family="straight", domain=(0, 1)), r"ramp\.slope: required"),
    (dict(family="straight", slope=1.0), r"ramp\.domain: required"),
    (dict(family="quadratic", curvature=float("nan"), domain=(0, 1)), r"ramp\.curvature: .*finite.*nan"),
    (dict(family="quadratic", curvature=1.0, slope=float("inf"), domain=(0, 1)), r"ramp\.slope: .*finite.*inf"),
    (dict(family="sine", amplitude="big", wavenumber=1.0, domain=(0, 1)), r"ramp\.amplitude: .*'big'"),
    (dict(family="sine", amplitude=True, wavenumber=1.0, domain=(0, 1)), r"ramp\.amplitude: .*True"),
    (dict(family="cycloid", radius=-1.0, domain=(0, 1)), r"^ramp\.radius: must be > 0, got -1\.0$"),
    (dict(family="circular_bowl", radius=0.0, domain=(0, 1)), r"ramp\.radius: must be > 0, got 0\.0"),
    (dict(family="circular_bowl", radius=1.5, domain=(-2.0, 2.0)),
     r"^ramp\.domain: \[-2\.0, 2\.0\] reaches \|x - x_centre\| >= radius = 1\.5 \(a vertical tangent\); "
     r"the domain must lie strictly inside \(-1\.5, 1\.5\)$"),
    (dict(family="circular_dome", radius=1.0, x_centre=2.0, domain=(1.5, 3.0)),
     r"ramp\.domain: .*strictly inside \(1\.0, 3\.0\)"),
    (dict(family="circular_bowl", radius=1.0, domain=(-0.5, 1.0)), r"ramp\.domain: .*vertical tangent"),
    (dict(family="cycloid", radius=1.0, domain=(-1.0, math.pi)),
     r"ramp\.domain: .*cusp.*vertical tangent.*strictly inside \(-3\.14159"),
    (dict(family="cycloid", radius=1.0, domain=(-4.0, 1.0)), r"ramp\.domain: .*cusp"),
    (dict(family="spline", x_points=[0.0, 1.0, 1.0, 2.0], y_points=[0, 1, 2, 3]),
     r"ramp\.x_points: must be strictly increasing, got 1\.0 then 1\.0"),
    (dict(family="spline", x_points=[0.0, 2.0, 1.0], y_points=[0, 1, 2]), r"ramp\.x_points: .*increasing"),
    (dict(family="spline", x_points=[0.0, 1.0, 2.0], y_points=[0, 1]), r"ramp\.y_points: .*as many"),
    (dict(family="spline", x_points=[0.0, 1.0], y_points=[0, 1]), r"ramp\.x_points: .*at least 3"),
    (dict(family="spline", x_points=[0.0, float("nan"), 2.0], y_points=[0, 1, 2]), r"ramp\.x_points: .*finite"),
    (dict(family="spline", x_points=[0.0, 1.0, 2.0]), r"ramp\.y_points: required"),
    (dict(family="straight", slope=1.0, domain=(1.0, 1.0)), r"ramp\.domain: x_min must be < x_max"),
    (dict(family="straight", slope=1.0, domain=(2.0, 1.0)), r"ramp\.domain: x_min must be < x_max"),
    (dict(family="straight", slope=1.0, domain=(0.0, float("inf"))), r"ramp\.domain: .*finite"),
    (dict(family="straight", slope=1.0, domain=(0.0,)), r"ramp\.domain: expected two numbers"),
    (dict(family="straight", slope=1.0, domain="0,1"), r"ramp\.domain: expected two numbers"),
]


@pytest.mark.parametrize("kwargs, message", BAD)
def test_bad_input_raises_config_error(kwargs, message):
    with pytest.raises(ConfigError, match=message):
        Ramp.create(**kwargs)


def test_check_values_on_arrays_names_the_offending_value():
    bowl = FAMILIES["circular_bowl"]
    values = {"radius": np.array([2.0, 1.5, 3.0]), "x_centre": np.zeros(3), "y_bottom": np.zeros(3)}
    bowl.check_values({**values, "radius": np.array([2.0, 2.5, 3.0])}, (-1.6, 1.6))
    with pytest.raises(ConfigError, match=r"ramp\.domain: .*radius = 1\.5.*\(value 1 of 3\)"):
        bowl.check_values(values, (-1.6, 1.6))
    with pytest.raises(ConfigError, match=r"ramp\.radius: must be > 0, got -2\.0 \(value 2 of 3\)"):
        bowl.check_values({**values, "radius": np.array([2.0, 2.0, -2.0])}, (-1.0, 1.0))
    with pytest.raises(ConfigError, match=r"ramp\.x_centre: .*finite.*nan"):
        bowl.check_values({**values, "x_centre": np.array([0.0, np.nan, 0.0])}, (-1.0, 1.0))
    with pytest.raises(ConfigError, match=r"ramp\.y_bottom: required"):
        bowl.check_values({"radius": values["radius"], "x_centre": values["x_centre"]}, (-1.0, 1.0))
    with pytest.raises(ConfigError, match=r"ramp\.height: unknown parameter"):
        bowl.check_values({**values, "height": np.zeros(3)}, (-1.0, 1.0))
    cycloid = FAMILIES["cycloid"]
    cycloid.check_values({"radius": np.array([1.0, 2.0])}, (-3.0, 3.0))
    with pytest.raises(ConfigError, match=r"ramp\.domain: .*cusp.*radius = 0\.5 \(value 1 of 2\)"):
        cycloid.check_values({"radius": np.array([1.0, 0.5])}, (-2.0, 2.0))


def test_pack():
    sine = FAMILIES["sine"]
    values = {"mean_slope": np.array([0.1, 0.2]), "amplitude": np.array([1.0, 2.0]),
              "wavenumber": np.array([3.0, 4.0]), "phase": np.array([0.0, 0.5])}
    p = sine.pack(values)
    assert len(p) == 4 and all(a.dtype == np.float64 and a.shape == (2,) for a in p)
    np.testing.assert_array_equal(p[1], [1.0, 2.0])
    p = FAMILIES["cycloid"].pack({"radius": np.array([1.0, 2.0, 3.0])})
    np.testing.assert_array_equal(p[0], [1.0, 2.0, 3.0])
    assert all((a == 0).all() and a.shape == (3,) for a in p[1:])
    p = FAMILIES["spline"].pack({}, n=5)
    assert all(a.shape == (5,) and (a == 0).all() for a in p)


def test_params_filled_and_ordered_and_round_trip():
    ramp = Ramp.create("sine", domain=[0, 1], wavenumber=2, amplitude=1)
    assert ramp.params == (("mean_slope", 0.0), ("amplitude", 1.0), ("wavenumber", 2.0), ("phase", 0.0))
    assert ramp.domain == (0.0, 1.0)
    assert ramp.param_dict()["amplitude"] == 1.0
    assert ramp.shared_array().tolist() == [0.0]
    for name, sample in SAMPLES.items():
        if name == "callable":
            with pytest.raises(ConfigError, match="callable ramps cannot be serialised"):
                sample.to_dict()
            continue
        data = json.loads(json.dumps(sample.to_dict()))
        assert Ramp.from_dict(data) == sample
        assert Ramp.create(**data) == sample
        assert hash(Ramp.from_dict(data)) == hash(sample)


def test_parameter_specs():
    for family in FAMILIES.values():
        assert len(family.parameters) <= 4
        for p in family.parameters:
            assert p.constraint in ("finite", "positive") and p.units and p.long_name
    assert [p.name for p in FAMILIES["quadratic"].parameters] == ["curvature", "slope", "height"]
    assert [p.name for p in FAMILIES["circular_dome"].parameters] == ["radius", "x_centre", "y_centre"]
    assert FAMILIES["straight"].is_straight and not FAMILIES["quadratic"].is_straight


# -- curvature sign ---------------------------------------------------------------


def test_curvature_sign():
    def sign(family, domain=(-1.0, 1.0), **values):
        return FAMILIES[family].curvature_sign({k: np.atleast_1d(np.asarray(v, float)) for k, v in values.items()},
                                               domain)

    assert sign("straight", slope=[1.0, 2.0], height=0.0) == 0
    assert sign("quadratic", curvature=[0.5, 1.0], slope=0, height=0) == 1
    assert sign("quadratic", curvature=[0.0, 1.0], slope=0, height=0) == 1
    assert sign("quadratic", curvature=[-0.5], slope=0, height=0) == -1
    assert sign("quadratic", curvature=[0.0, 0.0], slope=0, height=0) == 0
    assert sign("quadratic", curvature=[-0.5, 0.5], slope=0, height=0) is None
    assert sign("circular_bowl", radius=2.0, x_centre=0, y_bottom=0) == 1
    assert sign("circular_dome", radius=2.0, x_centre=0, y_centre=0) == -1
    assert sign("cycloid", radius=1.0) == 1
    assert sign("sine", mean_slope=0.1, amplitude=0.2, wavenumber=1.0, phase=0.0) is None
    assert sign("sine", mean_slope=0.1, amplitude=[0.0, 0.0], wavenumber=1.0, phase=0.0) == 0
    assert SAMPLES["cycloid"].curvature_sign() == 1
    assert SAMPLES["spline"].curvature_sign() is None
    assert ramps.spline([0, 1, 2, 3], [1, 0, 0, 1]).curvature_sign() == 1
    assert ramps.spline([0, 1, 2, 3], [-1, 0, 0, -1]).curvature_sign() == -1
    assert ramps.spline([0, 1, 2, 3], [0, 1, 2, 3]).curvature_sign() == 0
    assert SAMPLES["callable"].curvature_sign() == 1


# -- user callables -----------------------------------------------------------------


def test_callable_ramp_from_plain_python_functions():
    ramp = ramps.from_functions(lambda x: 0.5 * x * x, lambda x: x, lambda x: 1.0,
                                domain=(-1.0, 2.0), curvature_sign=1, name="parabola")
    f, fp, fpp = ramp.evaluate(np.array([0.0, 1.0]))
    assert f.tolist() == [0.0, 0.5] and fp.tolist() == [0.0, 1.0] and fpp.tolist() == [1.0, 1.0]
    assert ramp.family == "callable" and ramp.spec.name == "parabola"
    # its kernels are cached under a digest of what the functions compute
    assert ramp.spec.cacheable and ramp.spec.key.startswith("callable_")
    assert ramp.spec.parameters == () and ramp.params == ()
    other = ramps.from_functions(lambda x: -x, lambda x: -1.0, lambda x: 0.0, domain=(0.0, 1.0),
                                 curvature_sign=0)
    assert other.spec.is_straight and other.curvature_sign() == 0
    assert other.spec.key != ramp.spec.key


def test_callable_ramp_checks():
    with pytest.raises(ConfigError, match=r"ramp\.fp: does not match the derivative of f"):
        ramps.from_functions(lambda x: x**3, lambda x: 2 * x**2, lambda x: 6 * x, domain=(0.0, 1.0))
    with pytest.raises(ConfigError, match=r"ramp\.fpp: does not match the derivative of fp"):
        ramps.from_functions(lambda x: x**3, lambda x: 3 * x**2, lambda x: 3 * x, domain=(0.0, 1.0))
    with pytest.raises(ConfigError, match=r"ramp\.curvature_sign: declared \+1"):
        ramps.from_functions(lambda x: -x * x, lambda x: -2 * x, lambda x: -2.0, domain=(0.0, 1.0),
                             curvature_sign=1)
    with pytest.raises(ConfigError, match=r"ramp\.curvature_sign: must be"):
        ramps.from_functions(_user_f, _user_fp, _user_fpp, domain=(0.0, 1.0), curvature_sign=2)
    with pytest.raises(ConfigError, match=r"ramp\.fp: not finite"):
        ramps.from_functions(lambda x: -math.sqrt(1 - x * x), lambda x: x / math.sqrt(1 - x * x),
                             lambda x: 1 / (1 - x * x) ** 1.5, domain=(0.0, 1.0))
    with pytest.raises(ConfigError, match=r"ramp\.fpp: expected a function"):
        ramps.from_functions(_user_f, _user_fp, 3.0, domain=(0.0, 1.0))
    with pytest.raises(ConfigError, match=r"ramp\.domain"):
        ramps.from_functions(_user_f, _user_fp, _user_fpp, domain=(1.0, 0.0))
