"""core.vmath and core.vmath_exp: vectorisable sin, cos, sincos, cbrt, inverse_cbrt, sin_small, cos_small, exp and atan
against numpy (and long double).

The default test draws over 10**6 arguments: uniform in [-1e5, 1e5], log-spaced
magnitudes from 1e-300 to 1e5, and the range reduction's hard cases (the
nearest doubles to k*pi/2 and k*pi/4 and their neighbours, for every k up to
the largest valid argument; zeros, tiny and subnormal numbers; the largest
valid argument).  benchmarks/vmath.py prints the error table over 10**7
arguments per range.
"""

import math

import numpy as np
import pytest

import rampwork as rw
from rampwork.core import vmath, vmath_exp
from rampwork.core.jit import jit

LIMIT = vmath.VALID_ARGUMENT
BOUND = vmath.VALID_ULP


@jit
def _sincos_loop(x, s, c, s1, c1):
    for i in range(x.size):
        s[i], c[i] = vmath.sincos(x[i])
        s1[i] = vmath.sin(x[i])
        c1[i] = vmath.cos(x[i])


@jit
def _cbrt_loop(x, out):
    for i in range(x.size):
        out[i] = vmath.cbrt(x[i])


def evaluate(x):
    s, c, s1, c1 = (np.empty_like(x) for _ in range(4))
    _sincos_loop(x, s, c, s1, c1)
    return s, c, s1, c1


def ulp_distance(a, b):
    """|a - b| in ulps of the smaller magnitude's binade (exact for doubles)."""
    small = np.minimum(np.abs(a), np.abs(b))
    return np.abs(a - b) / np.spacing(small)


def ulp_error(got, exact):
    """|got - exact| in ulps of the exact value's binade (exact: long double)."""
    exact64 = exact.astype(np.float64)
    exponent = np.frexp(np.abs(exact64))[1] - 1  # exact64 = m * 2**exponent, 1 <= m < 2
    ulp = np.ldexp(np.ones_like(exact64), np.maximum(exponent, -1022) - 52)
    return np.abs((got.astype(np.longdouble) - exact) / ulp.astype(np.longdouble)).astype(np.float64)


def hard_arguments():
    """The nearest doubles to k*pi/2 and k*pi/4 (and 2 neighbours each side)
    for every k with k*pi/4 <= LIMIT, signed; zeros, tiny numbers, the limit."""
    k = np.arange(1, int(LIMIT / (math.pi / 4)) + 1, dtype=np.longdouble)
    quarter = np.longdouble("0.785398163397448309615660845819875721")  # pi/4
    centres = (k * quarter).astype(np.float64)  # nearest doubles (to long double precision)
    near = [centres]
    for steps in (1, 2):
        up = centres.copy()
        down = centres.copy()
        for _ in range(steps):
            up = np.nextafter(up, np.inf)
            down = np.nextafter(down, -np.inf)
        near += [up, down]
    near = np.concatenate(near)
    special = np.array([0.0, 5e-324, 1e-310, 2.2250738585072014e-308, 1e-300, 1e-20, 1e-8, 1e-4,
                        math.pi / 4, math.pi / 2, math.pi, 2 * math.pi, LIMIT,
                        np.nextafter(LIMIT, 0.0), np.nextafter(LIMIT, 2 * LIMIT)])
    return np.concatenate([near, -near, special, -special])


def default_arguments(n=600_000, seed=19):
    rng = np.random.default_rng(seed)
    uniform = rng.uniform(-LIMIT, LIMIT, n)
    magnitudes = 10.0 ** rng.uniform(-300.0, math.log10(LIMIT), n // 2)
    logs = magnitudes * rng.choice([-1.0, 1.0], magnitudes.size)
    small = rng.uniform(-4.0, 4.0, n // 4)
    return np.concatenate([uniform, logs, small, hard_arguments()])


@pytest.fixture(scope="module")
def results():
    x = default_arguments()
    assert x.size >= 1_000_000
    assert np.abs(x).max() <= np.nextafter(LIMIT, np.inf)  # the limit and one past it
    return x, evaluate(x)


def test_sin_cos_within_one_ulp_of_numpy(results):
    x, (s, c, _, _) = results
    with np.errstate(invalid="ignore", divide="ignore"):
        ds = ulp_distance(s, np.sin(x))
        dc = ulp_distance(c, np.cos(x))
    worst_s, worst_c = int(np.argmax(ds)), int(np.argmax(dc))
    assert ds.max() <= BOUND, (x[worst_s], s[worst_s], np.sin(x[worst_s]))
    assert dc.max() <= BOUND, (x[worst_c], c[worst_c], np.cos(x[worst_c]))
    # most results are numpy's own (correctly rounded ones, where numpy is)
    assert (s == np.sin(x)).mean() > 0.9 and (c == np.cos(x)).mean() > 0.9


@pytest.mark.skipif(np.finfo(np.longdouble).nmant < 63, reason="needs an 80-bit long double")
def test_sin_cos_error_against_long_double(results):
    """The documented bound, against the exact values (long double sinl/cosl:
    11 more bits than a double)."""
    x, (s, c, _, _) = results
    xl = x.astype(np.longdouble)
    es = ulp_error(s, np.sin(xl))
    ec = ulp_error(c, np.cos(xl))
    assert es.max() <= BOUND and ec.max() <= BOUND, (es.max(), ec.max())
    assert es.max() < 0.9 and ec.max() < 0.9  # measured: about 0.78 (numpy: 0.52)


def test_sincos_equals_sin_and_cos(results):
    x, (s, c, s1, c1) = results
    assert np.array_equal(s, s1) and np.array_equal(c, c1)


def test_special_values():
    x = np.array([0.0, -0.0, 5e-324, -5e-324, np.inf, -np.inf, np.nan])
    s, c, _, _ = evaluate(x)
    assert np.array_equal(np.signbit(s[:4]), [False, True, False, True])  # sin(+-0) = +-0
    assert np.array_equal(s[:4], x[:4]) and np.array_equal(c[:4], np.ones(4))
    assert np.isnan(s[4:]).all() and np.isnan(c[4:]).all()


def test_symmetry():
    x = default_arguments(n=100_000, seed=3)
    s, c, _, _ = evaluate(x)
    sm, cm, _, _ = evaluate(-x)
    assert np.array_equal(sm, -s) and np.array_equal(cm, c)


@pytest.mark.parametrize("magnitude", [1e7, 1e10, 1e14])
def test_beyond_the_valid_range(magnitude):
    """Documented, not guaranteed: the reduction stays accurate far beyond
    VALID_ARGUMENT (the shifter trick fails only above 2**51)."""
    x = np.random.default_rng(7).uniform(-magnitude, magnitude, 200_000)
    s, c, _, _ = evaluate(x)
    assert ulp_distance(s, np.sin(x)).max() <= BOUND
    assert ulp_distance(c, np.cos(x)).max() <= BOUND


@pytest.mark.skipif(np.finfo(np.longdouble).nmant < 63, reason="needs an 80-bit long double")
def test_cbrt():
    """Within 1 ulp of cbrt in long double.  (Not against numpy's double
    cbrt: it is not correctly rounded, and on a CPU without AVX-512 it is
    3.2 ulp off at worst, measured on these arguments.)"""
    rng = np.random.default_rng(5)
    x = np.concatenate([10.0 ** rng.uniform(-300, 300, 300_000), rng.uniform(0, 20, 100_000),
                        np.array([1.0, 8.0, 27.0, 1e-16, 2.2250738585072014e-308])])
    out = np.empty_like(x)
    _cbrt_loop(x, out)
    error = ulp_error(out, np.cbrt(x.astype(np.longdouble)))
    assert error.max() <= 1.0, error.max()
    assert np.median(error) <= 0.5
    zero = np.array([0.0, np.nan])
    _cbrt_loop(zero, out[:2])
    assert out[0] == 0.0 and np.isnan(out[1])


@jit
def _inverse_cbrt_loop(x, out):
    for i in range(x.size):
        out[i] = vmath.inverse_cbrt(x[i])


@jit
def _small_loop(x, s, c):
    for i in range(x.size):
        s[i] = vmath.sin_small(x[i])
        c[i] = vmath.cos_small(x[i])


def test_inverse_cbrt():
    """Division-free a**(-1/3) (the cycloid's cusp guess): a few ulps over
    600 decades, against 1/cbrt in long double."""
    rng = np.random.default_rng(11)
    x = np.concatenate([10.0 ** rng.uniform(-300, 300, 300_000), rng.uniform(0.5, 8.5, 100_000),
                        np.array([1.0, 8.0, 27.0, 1e-16, 2.2250738585072014e-308])])
    out = np.empty_like(x)
    _inverse_cbrt_loop(x, out)
    exact = 1 / np.cbrt(x.astype(np.longdouble))
    relative = np.abs((out.astype(np.longdouble) - exact) / exact).astype(np.float64)
    assert relative.max() < 1e-15, relative.max()  # measured: 1.8 ulp (4e-16)
    assert np.median(relative) < 2.3e-16


@pytest.mark.skipif(np.finfo(np.longdouble).nmant < 63, reason="needs an 80-bit long double")
def test_small_kernels_within_one_ulp():
    """sin_small, cos_small on [-pi/4, pi/4] (no reduction): within 1 ulp of
    the exact values, and sin_small odd, cos_small even."""
    rng = np.random.default_rng(12)
    x = np.concatenate([rng.uniform(-math.pi / 4, math.pi / 4, 1_000_000),
                        10.0 ** rng.uniform(-300, -0.11, 100_000), [0.0, -0.0, math.pi / 4, -math.pi / 4]])
    s, c = np.empty_like(x), np.empty_like(x)
    _small_loop(x, s, c)
    xl = x.astype(np.longdouble)
    assert ulp_error(s, np.sin(xl)).max() < 0.9 and ulp_error(c, np.cos(xl)).max() < 0.9
    sm, cm = np.empty_like(x), np.empty_like(x)
    _small_loop(-x, sm, cm)
    assert np.array_equal(sm, -s) and np.array_equal(cm, c)


def test_sine_family_limits_its_argument():
    rw.Ramp.create("sine", domain=(-1.0, 1.0), amplitude=0.1, wavenumber=LIMIT)  # reaches LIMIT: fine
    with pytest.raises(rw.ConfigError, match="wavenumber"):
        rw.Ramp.create("sine", domain=(-1.0, 1.0), amplitude=0.1, wavenumber=2 * LIMIT)
    with pytest.raises(rw.ConfigError, match="wavenumber"):
        rw.Ramp.create("sine", domain=(0.0, 1.0), amplitude=0.1, wavenumber=1.0, phase=-LIMIT - 1.0)
    scene = rw.Scene(ramp=rw.Ramp.create("sine", domain=(-1.0, 1.0), amplitude=0.1, wavenumber=6.0),
                     t_max=0.1, integrator=rw.Integrator("rk4", 1e-3))
    with pytest.raises(rw.ConfigError, match="wavenumber"):
        rw.simulate(scene, rw.Sweep.grid(wavenumber=[6.0, 3 * LIMIT], x0=[0.1]))


# -- core.vmath_exp: exp and atan ----------------------------------------------


@jit
def _exp_atan_loop(x, e, a):
    for i in range(x.size):
        e[i] = vmath_exp.exp(x[i])
        a[i] = vmath_exp.atan(x[i])


def exp_atan(x):
    e, a = np.empty_like(x), np.empty_like(x)
    _exp_atan_loop(x, e, a)
    return e, a


@pytest.mark.skipif(np.finfo(np.longdouble).nmant < 63, reason="needs an 80-bit long double")
def test_exp_within_one_ulp_of_the_exact_value():
    """10**6 arguments per range (the normal results, |x| <= 2 (the
    quadrature's), and the subnormal ones) against long double expl."""
    rng = np.random.default_rng(21)
    for x in (rng.uniform(-708.0, 709.7, 1_000_000), rng.uniform(-2.0, 2.0, 1_000_000),
              rng.uniform(vmath_exp.EXP_UNDERFLOW, -708.4, 1_000_000)):
        e, _ = exp_atan(x)
        error = ulp_error(e, np.exp(x.astype(np.longdouble)))
        assert error.max() <= vmath_exp.EXP_ULP, (error.max(), x[np.argmax(error)])
        assert (e == np.exp(x)).mean() > 0.85  # mostly correctly rounded (numpy/glibc is, to 0.51 ulp)


@pytest.mark.skipif(np.finfo(np.longdouble).nmant < 63, reason="needs an 80-bit long double")
def test_atan_within_one_ulp_of_the_exact_value():
    """10**6 arguments per range: |x| <= 3 (every reduction interval, the
    quadrature's slopes), |x| <= 100, and log-spaced 1e-300 .. 1e300."""
    rng = np.random.default_rng(22)
    logs = 10.0 ** rng.uniform(-300.0, 300.0, 1_000_000) * rng.choice([-1.0, 1.0], 1_000_000)
    for x in (rng.uniform(-3.0, 3.0, 1_000_000), rng.uniform(-100.0, 100.0, 1_000_000), logs):
        _, a = exp_atan(x)
        error = ulp_error(a, np.arctan(x.astype(np.longdouble)))
        assert error.max() <= vmath_exp.ATAN_ULP, (error.max(), x[np.argmax(error)])
        _, minus = exp_atan(-x)
        assert np.array_equal(minus, -a)  # odd, bit for bit


def test_exp_edges():
    big, tiny = vmath_exp.EXP_OVERFLOW, vmath_exp.EXP_UNDERFLOW
    x = np.array([0.0, -0.0, big, np.nextafter(big, np.inf), np.inf, 1000.0,
                  np.nextafter(tiny, 0.0), tiny, np.nextafter(tiny, -np.inf), -np.inf, -1000.0, np.nan])
    e, _ = exp_atan(x)
    assert e[0] == 1.0 and e[1] == 1.0
    assert np.isfinite(e[2]) and e[2] > 1.79e308  # log(DBL_MAX): finite, the largest results
    assert np.isposinf(e[3:6]).all()
    assert e[6] == 5e-324  # the smallest subnormal
    assert (e[7:11] == 0.0).all()
    assert np.isnan(e[11])
    with np.errstate(over="ignore"):
        assert np.array_equal(e[:11], np.exp(x[:11]))


def test_atan_edges():
    x = np.array([0.0, -0.0, 5e-324, -5e-324, 1e-300, 1.0, -1.0, 0.4375, 0.6875, 1.1875, 2.4375,
                  2.0**66, 1e300, np.inf, -np.inf, np.nan])
    _, a = exp_atan(x)
    assert np.array_equal(np.signbit(a[:4]), [False, True, False, True]) and np.array_equal(a[:5], x[:5])
    assert a[5] == math.pi / 4 and a[6] == -math.pi / 4
    assert np.array_equal(a[11:15], [math.pi / 2, math.pi / 2, math.pi / 2, -math.pi / 2])
    assert np.isnan(a[15])
    assert np.array_equal(a[:15], np.arctan(x[:15]))
