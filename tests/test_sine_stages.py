"""The sine family's RK4 stage evaluation by the angle sum
(``core.ramps.sine_slope_curvature_near``) against long-double values.

The reference is f', f'' at the exact stage point: the argument at the step's
start as the code rounds it, theta0 = fl(k x0 + phase), plus the exact k dx
(the argument's own rounding is the same for any evaluation at x0).  Errors
are in ulp of the terms' scale: |p0| + |A k| for f' and, for f'', A k^2 +
k |sin(k dx)| (|p0| + |A k|) (u = f'(x0) - p0 carries the rounding of f'(x0)).
The same measure of the direct evaluation at fl(x0 + dx) is printed beside
(measured: near <= 2.7 and 3.0 ulp for |k dx| <= 0.8, direct 1.8 and 2.2).
"""

import numpy as np
import pytest

from rampwork.core import ramps as R
from rampwork.core.jit import jit


@jit
def _evaluate(x, dx, m, a, k, phase, out):
    for i in range(x.size):
        fp, fpp = R.sine_slope_curvature(x[i], m[i], a[i], k[i], phase[i], None)
        out[0, i], out[1, i] = R.sine_slope_curvature_near(x[i] + dx[i], dx[i], fp, fpp,
                                                           m[i], a[i], k[i], phase[i], None)


def errors(n, kdx_max, seed):
    """Max errors (f', f'') in ulp of their scales over n random (x0, dx)."""
    rng = np.random.default_rng(seed)
    m = rng.uniform(-1, 1, n) * 10.0 ** rng.uniform(-3, 1, n)
    a = rng.uniform(-1, 1, n) * 10.0 ** rng.uniform(-3, 0, n)
    k = 10.0 ** rng.uniform(-1, 2, n)
    phase = rng.uniform(-4, 4, n)
    x = rng.uniform(-1, 1, n) * 10.0 ** rng.uniform(-2, 2, n)
    kdx = rng.uniform(-1, 1, n) * 10.0 ** rng.uniform(-6, np.log10(kdx_max), n)
    dx = kdx / k
    out = np.empty((2, n))
    _evaluate(x, dx, m, a, k, phase, out)
    L = np.longdouble
    theta = L(k * x + phase) + L(k) * L(dx)
    fp_exact = L(m) + L(a) * L(k) * np.cos(theta)
    fpp_exact = -L(a) * L(k) * L(k) * np.sin(theta)
    scale_fp = np.abs(m) + np.abs(a * k)
    scale_fpp = np.abs(a) * k * k + k * np.abs(np.sin(k * dx)) * scale_fp
    e_fp = np.abs((out[0] - fp_exact) / np.spacing(scale_fp)).astype(float)
    e_fpp = np.abs((out[1] - fpp_exact) / np.spacing(scale_fpp)).astype(float)
    return e_fp.max(), e_fpp.max()


def test_stage_points_within_a_few_ulp():
    """RK4's stage offsets: |k dx| <= k |v| h, below 0.8 for any step of
    at least 8 per wavelength; measured 2.7 and 3.0 ulp over 10**6 pairs."""
    e_fp, e_fpp = errors(1_000_000, 0.8, seed=31)
    assert e_fp < 4.0 and e_fpp < 4.0, (e_fp, e_fpp)


def test_long_stages_stay_accurate():
    """Beyond pi/4 the short reduction y = n pi/2 + r takes over: a step over
    several wavelengths (|k dx| up to 20) still gives f', f'' to ~10 ulp
    (measured 12.5 and 10.0 over 10**6 pairs: the quadrant's 1 + (cos r - 1)
    and the terms' sum)."""
    e_fp, e_fpp = errors(1_000_000, 20.0, seed=32)
    assert e_fp < 16.0 and e_fpp < 16.0, (e_fp, e_fpp)


@pytest.mark.parametrize("k", [0.0, -0.0])
def test_flat_and_zero_wavenumber(k):
    """k = 0: f' = mean slope, f'' = 0 at every stage, no NaN."""
    x = np.array([0.3, -2.0])
    dx = np.array([0.01, -5.0])
    out = np.empty((2, 2))
    _evaluate(x, dx, np.full(2, 0.2), np.full(2, 0.1), np.full(2, k), np.full(2, 0.4), out)
    assert np.array_equal(out[0], [0.2, 0.2]) and np.all(out[1] == 0.0)
