"""Jitted ramp families: f(x), f'(x) and f''(x) from plain floats.

Every family NAME has two functions with one fixed signature, which the batch
kernel inlines into its SIMD lane loop:

* ``NAME_height(x, p0, p1, p2, p3, shared) -> f(x)``
* ``NAME_slope_curvature(x, p0, p1, p2, p3, shared) -> (f'(x), f''(x))``

``p0..p3`` are the family's per-trajectory shape parameters in the order of
:mod:`rampwork.ramps` (unused ones are 0.0); ``shared`` is a 1-D float64 array
shared by all trajectories (the spline's knots, sine_modes' coefficient
table; never empty).

Rules for code here: branch-light (simple ``a if c else b`` selects only), no
data-dependent ``while`` loops, no exceptions, allocation or prints, no
fastmath, so that a scalar call and an inlined vector loop agree to the last
bit.  Outside a family's valid domain the result is NaN or a smooth
extension; the Python layer refuses domains that reach a vertical tangent.

Spline ``shared`` layout (n knots, built by :func:`rampwork.ramps.spline_shared`)::

    shared[0]                 n (number of knots, >= 3), as a float
    shared[1]                 k = ceil(log2(n - 1)): bisection steps, as a float
    shared[2       : 2 + n]   x_i  knots, strictly increasing
    shared[2 + n   : 2 + 2n]  y_i  values at the knots
    shared[2 + 2n  : 2 + 3n]  m_i  second derivatives at the knots (m_0 = m_{n-1} = 0)

Outside ``[x_0, x_{n-1}]`` the spline continues with its end intervals' cubics.
"""

from __future__ import annotations

import math

from . import vmath
from .jit import fma, jit

# ---------------------------------------------------------------------------
# straight: y = height + slope * x            p0 = slope, p1 = height


@jit
def straight_height(x, p0, p1, p2, p3, shared):
    return p1 + p0 * x


@jit
def straight_slope_curvature(x, p0, p1, p2, p3, shared):
    return p0, 0.0


# ---------------------------------------------------------------------------
# quadratic: y = height + slope*x + curvature*x**2/2     p0 = curvature, p1 = slope, p2 = height


@jit
def quadratic_height(x, p0, p1, p2, p3, shared):
    return p2 + x * (p1 + 0.5 * p0 * x)


@jit
def quadratic_slope_curvature(x, p0, p1, p2, p3, shared):
    return fma(p0, x, p1), p0


# ---------------------------------------------------------------------------
# circles: p0 = radius R, p1 = x_centre; p2 = y_bottom (the bowl's lowest
# point) or y_centre (the dome's centre); d = x - x_centre.
# R^2 - d^2 is formed as (R - d)(R + d) with d = x - x_centre carried exactly
# as d_hi + d_lo (Knuth's TwoSum): ~1 ulp right up to the tangent points.
# The bowl's height above its bottom, R - sqrt(R^2 - d^2), is formed as
# d^2 / (R + sqrt(R^2 - d^2)): no cancellation near the bottom.


@jit
def _circle_q(x, r, xc):
    """(d, R^2 - d^2) with d = x - xc."""
    d = x - xc
    t = d - x
    d_lo = (x - (d - t)) - (xc + t)
    return d, ((r - d) - d_lo) * ((r + d) + d_lo)


@jit
def circular_bowl_height(x, p0, p1, p2, p3, shared):
    d, q = _circle_q(x, p0, p1)
    return p2 + d * d / (p0 + math.sqrt(q))


@jit
def circular_bowl_slope_curvature(x, p0, p1, p2, p3, shared):
    d, q = _circle_q(x, p0, p1)
    s = math.sqrt(q)
    return d / s, (p0 * p0) / (q * s)


@jit
def circular_dome_height(x, p0, p1, p2, p3, shared):
    d, q = _circle_q(x, p0, p1)
    return p2 + math.sqrt(q)


@jit
def circular_dome_slope_curvature(x, p0, p1, p2, p3, shared):
    d, q = _circle_q(x, p0, p1)
    s = math.sqrt(q)
    return -d / s, -(p0 * p0) / (q * s)


# ---------------------------------------------------------------------------
# cycloid bowl: x = r (u + sin u), y = r (1 - cos u), -pi < u < pi; p0 = r.
#
# u(x), with s = |x| / r, is found in one of two formulations:
#   centre (s < pi/2 + 1, i.e. |u| < pi/2): z + sin z = s for z = |u|;
#   ends   (s >= pi/2 + 1): w - sin w = t for w = pi - |u|, where
#          t = (pi r - |x|) / r is formed to ~1 ulp (cycloid_cusp_gap), so the
#          ends are as accurate as the centre although u(x) is ill-conditioned
#          there (the error is not amplified by rounding of |x| / r).
# Both are  F(z) = alpha*z + beta*S(z) - a = 0  with S(z) = z - sin z summed as
# a series (no cancellation for small w), (alpha, beta) = (2, -1) at the centre
# and (0, 1) at the ends, F'(z) = 2 den^2 with den = cos(z/2) at the centre and
# sin(z/2) at the ends.
#
# No iteration loop and no libm call (the lane loops vectorise): a polynomial
# starting guess z0, accurate to ~1e-9 (centre: z/s as a polynomial in s^2;
# ends: w/c in c^2 with c = (6t)^(1/3), the cube-root law at the cusps, c from
# vmath.inverse_cbrt), then ONE Newton correction dz = -F(z0)/F'(z0), which
# is not added to z0 but folded into the results to second order:
# sin and cos of z/2 = z0/2 + e (e = dz/2, |e| < ~1e-9 z) from those of z0/2
# by the angle sum, tan(z0/2 + e) = t0 + (1 + t0^2) e (1 + e t0) (t0 = tan(z0/2);
# cot likewise).  Newton's error after the step, ~e^2 / z, is far below an ulp;
# what is left is rounding, measured over 1e7 points per range
# (benchmarks/vmath.py): f <= 4.7 ulp, f' <= 4.1, f'' <= 13.9 (near the cusps;
# mean <= 2), about as before with libm and five Newton steps (tests/test_ramps.py).
# One division per evaluation (tan or cot of z0/2), plus 1/r where r is not
# uniform (hoisted out of the lane loops where it is).

PI_HI = math.pi
PI_LO = 1.2246467991473532e-16  # pi - PI_HI
PI_SPLIT_HI = 134217729.0 * PI_HI - (134217729.0 * PI_HI - PI_HI)  # PI_HI in two 26-bit halves
PI_SPLIT_LO = PI_HI - PI_SPLIT_HI
CYCLOID_SPLIT = 0.5 * math.pi + 1.0  # s where |u| = pi/2

# coefficients of (z - sin z) / z^3 as a series in z^2: (-1)^k / (2k+3)!
_S0 = 1.0 / 6.0
_S1 = -1.0 / 120.0
_S2 = 1.0 / 5040.0
_S3 = -1.0 / 362880.0
_S4 = 1.0 / 39916800.0
_S5 = -1.0 / 6227020800.0
_S6 = 1.0 / 1307674368000.0
_S7 = -1.0 / 355687428096000.0
_S8 = 1.0 / 121645100408832000.0
_S9 = -1.0 / 51090942171709440000.0
_S10 = 1.0 / 25852016738884976640000.0

# starting guesses, least-squares fits on Chebyshev nodes (max relative error
# ~8e-10 and ~1e-10): centre z/s in X = s^2 on [0, CYCLOID_SPLIT^2];
# ends w/c in X = c^2, c = (6t)^(1/3), on [0, (6 (pi/2 - 1))^(2/3)]
_GC = (0.5000000002886311, 0.010416652361574155, 0.0005209503002250916, 3.295336852691848e-05,
       3.0168910936191316e-06, -4.143793527868693e-07, 3.85385359558382e-07, -1.496898423055483e-07,
       4.1305560708098214e-08, -7.462684685263945e-09, 8.679888170481831e-10, -5.855086011035084e-11,
       1.7853644709429803e-12)
_GE = (1.0000000000664908, 0.016666663838167176, 0.0007143052714721175, 3.9632185682430656e-05,
       2.5540314691718877e-06, 1.3129346499713012e-07, 2.238102360659865e-08)
(_GC0, _GC1, _GC2, _GC3, _GC4, _GC5, _GC6, _GC7, _GC8, _GC9, _GC10, _GC11, _GC12) = _GC
(_GE0, _GE1, _GE2, _GE3, _GE4, _GE5, _GE6) = _GE
_CBRT6 = 6.0 ** (1.0 / 3.0)


@jit
def _z_minus_sin_z(z):
    """z - sin(z) without cancellation for |z| <~ 2 (relative error ~1 ulp)."""
    z2 = z * z
    p = fma(z2, _S10, _S9)
    p = fma(z2, p, _S8)
    p = fma(z2, p, _S7)
    p = fma(z2, p, _S6)
    p = fma(z2, p, _S5)
    p = fma(z2, p, _S4)
    p = fma(z2, p, _S3)
    p = fma(z2, p, _S2)
    p = fma(z2, p, _S1)
    p = fma(z2, p, _S0)
    return p * (z2 * z)


@jit
def cycloid_cusp_gap(ax, r):
    """pi*r - ax for ax >= 0, accurate to ~1 ulp of the result near the cusp
    (ax -> pi*r): pi*r is formed exactly as a double-double (Dekker's product,
    no FMA needed) before the subtraction, which is then exact."""
    p = PI_HI * r
    c = 134217729.0 * r  # 2**27 + 1: Dekker's split of r
    r_hi = c - (c - r)
    r_lo = r - r_hi
    err = ((PI_SPLIT_HI * r_hi - p) + PI_SPLIT_HI * r_lo + PI_SPLIT_LO * r_hi) + PI_SPLIT_LO * r_lo
    return (p - ax) + (err + PI_LO * r)


@jit
def _cycloid_guess(s, t):
    """Starting guesses (centre z0 from s, ends w0 from t), ~1e-9 relative."""
    x2 = s * s
    g = fma(x2, _GC12, _GC11)
    g = fma(x2, g, _GC10)
    g = fma(x2, g, _GC9)
    g = fma(x2, g, _GC8)
    g = fma(x2, g, _GC7)
    g = fma(x2, g, _GC6)
    g = fma(x2, g, _GC5)
    g = fma(x2, g, _GC4)
    g = fma(x2, g, _GC3)
    g = fma(x2, g, _GC2)
    g = fma(x2, g, _GC1)
    z0 = s * fma(x2, g, _GC0)
    # c = (6t)^(1/3) = 6^(1/3) t (t^(-1/3))^2; NaN beyond the cusps (t < 0)
    y = vmath.inverse_cbrt(t)
    c = _CBRT6 * (t * (y * y)) if t >= 0.0 else math.nan
    c2 = c * c
    g = fma(c2, _GE6, _GE5)
    g = fma(c2, g, _GE4)
    g = fma(c2, g, _GE3)
    g = fma(c2, g, _GE2)
    g = fma(c2, g, _GE1)
    w0 = c * fma(c2, g, _GE0)
    return z0, w0


@jit
def _cycloid_solve(ax, r):
    """The pieces every cycloid result is made of, at ax = |x|:
    (centre, sh, ch, t0, e): sh, ch = sin and cos of z0/2 at the guess z0;
    t0 = tan(z0/2) at the centre, cot(z0/2) at the ends; e = half the Newton
    correction of z0 (the exact z/2 is z0/2 + e + O(e^2/z))."""
    inv_r = 1.0 / r  # hoisted out of the lane loops where r is uniform
    s = ax * inv_r
    t = cycloid_cusp_gap(ax, r) * inv_r
    centre = s < CYCLOID_SPLIT
    z0, w0 = _cycloid_guess(s, t)
    z = z0 if centre else w0
    # F(z) = 2z - S(z) - s (2z - s is exact: Sterbenz) or S(z) - t
    sz = _z_minus_sin_z(z)
    f = (2.0 * z - s) - sz if centre else sz - t
    sh = vmath.sin_small(0.5 * z)
    ch = vmath.cos_small(0.5 * z)
    num = sh if centre else ch
    den = ch if centre else sh
    t0 = num / den  # the one division: select first (a select of quotients divides twice)
    # e = -F / (2 F'), F' = 2 den^2 with den = ch (centre) or sh (ends),
    # and 1 / den^2 = 1 + t0^2 in both
    e = -0.25 * f * fma(t0, t0, 1.0)
    return centre, sh, ch, t0, e


@jit
def _cycloid_half_angle(x, r):
    """(sin(u/2), cos(u/2)) of the cycloid parameter u at x, for |u|; the caller
    restores the sign of sin(u/2) from x."""
    centre, sh, ch, t0, e = _cycloid_solve(abs(x), r)
    sin_z = fma(ch, e, sh)  # sin and cos of z/2 = z0/2 + e (e^2 terms < 1e-18)
    cos_z = fma(-sh, e, ch)
    # centre: z = |u|; ends: z = pi - |u|, so sin and cos of u/2 swap
    sin_half = sin_z if centre else cos_z
    cos_half = cos_z if centre else sin_z
    return sin_half, cos_half


@jit
def cycloid_height(x, p0, p1, p2, p3, shared):
    sin_half, cos_half = _cycloid_half_angle(x, p0)
    return 2.0 * p0 * sin_half * sin_half  # r (1 - cos u)


@jit
def cycloid_slope_curvature(x, p0, p1, p2, p3, shared):
    centre, sh, ch, t0, e = _cycloid_solve(abs(x), p0)
    sign = 1.0 if centre else -1.0
    # tan(a + e) = t + (1 + t^2) e (1 + e t) + O(e^3); cot(a + e) likewise with -e
    slope = fma(fma(t0, t0, 1.0) * e, fma(e, t0, sign), t0)
    # f'' = 1 / (4 r cos^4(u/2)) = (1 + f'^2)^2 / (4 r): no second division
    # (from 1 / den^4 instead it is a little more accurate near the cusps,
    # ~9.7 against ~13 ulp, but jitters more at the switch between the two
    # formulations, where f'' must stay monotone: test_ramps.py)
    q = fma(slope, slope, 1.0)
    return math.copysign(slope, x), (q * q) * (0.25 / p0)


@jit
def cycloid_slope_curvature_afresh(x, dx, fp, fpp, p0, p1, p2, p3, shared):
    """The cycloid's f', f'' at a fixed step's stage points and end where the
    plan does not bound the steps (``SLOPE_CURVATURE_NEAR``): evaluated
    afresh, the arithmetic of a kernel without the short form."""
    return cycloid_slope_curvature(x, p0, p1, p2, p3, shared)


#: the short form's bound on (CYCLOID_GROWTH_0 + CYCLOID_GROWTH_1 |f'(x0)|) tau,
#: tau = (1 + f'(x0)^2) |dx| / (4 r), for every stage and step end of a run
#: (``rampwork.ramps``'s cycloid ``short_stages``)
CYCLOID_SHORT_BOUND = 1.0 / 64.0
#: the series' coefficients grow by at most this factor per order
#: (~1.27 at f' = 0, the pole at the cusp; ~2.65 |f'| + 0.7 for |f'| >= 1)
CYCLOID_GROWTH_0 = 1.5
CYCLOID_GROWTH_1 = 3.0
# f'(x0 + dx) = T0 + f''(x0) dx (1 + sum_k c_k(T0) tau^(k-1)), the series of
# dz/dtau = (1 + 2 T0 z + (1 + T0^2) z^2)^2 (z = (f' - T0) / (1 + T0^2));
# c_k is a polynomial in T0 of degree k - 1 and parity k - 1 (exact rationals)
_C3 = (2.0 / 3.0, 14.0 / 3.0)
_C4 = (11.0 / 3.0, 35.0 / 3.0)
_C5 = (11.0 / 15.0, 226.0 / 15.0, 91.0 / 3.0)
_C6 = (292.0 / 45.0, 2492.0 / 45.0, 728.0 / 9.0)
_C7 = (292.0 / 315.0, 3952.0 / 105.0, 2884.0 / 15.0, 1976.0 / 9.0)
_C8 = (3548.0 / 315.0, 18986.0 / 105.0, 1936.0 / 3.0, 5434.0 / 9.0)


@jit
def cycloid_slope_curvature_short(x, dx, fp, fpp, p0, p1, p2, p3, shared):
    """f', f'' at x = x0 + dx from f', f'' at x0, where the plan bounds
    (CYCLOID_GROWTH_0 + CYCLOID_GROWTH_1 |f'(x0)|) tau by
    CYCLOID_SHORT_BOUND (tau = (1 + f'(x0)^2) |dx| / 4r): no Newton solve, no
    division, no trig.

    f' = tan(u/2) obeys df'/dx = f'' = (1 + f'^2)^2 / 4r, an ODE in f'
    alone, so f'(x0 + dx) is its Taylor series from f'(x0) = T0, whose
    first term f''(x0) dx is carried; the series stops at tau^7 (c_8).  The
    coefficients c_k(T0) are the same for every stage of a step (the
    compiler forms them once).  The first term left out, c_9 tau^8, is
    below 2^-53 of |f'(x0)| + |f''(x0) dx| at the bound; the rest is
    rounding (tests/test_cycloid_stages.py).  f'' = (1 + f'^2)^2 / 4r from f'
    as in ``cycloid_slope_curvature``."""
    a = 0.25 / p0  # hoisted out of the lane loops where r is uniform
    t = fp
    s = t * t
    p = fma(t, t, 1.0)
    tau = (p * a) * dx
    c2 = 2.0 * t
    c3 = fma(s, _C3[1], _C3[0])
    c4 = t * fma(s, _C4[1], _C4[0])
    c5 = fma(s, fma(s, _C5[2], _C5[1]), _C5[0])
    c6 = t * fma(s, fma(s, _C6[2], _C6[1]), _C6[0])
    c7 = fma(s, fma(s, fma(s, _C7[3], _C7[2]), _C7[1]), _C7[0])
    c8 = t * fma(s, fma(s, fma(s, _C8[3], _C8[2]), _C8[1]), _C8[0])
    q = fma(tau, c8, c7)
    q = fma(tau, q, c6)
    q = fma(tau, q, c5)
    q = fma(tau, q, c4)
    q = fma(tau, q, c3)
    q = fma(tau, q, c2)
    lead = fpp * dx
    slope = fma(lead * tau, q, fma(fpp, dx, fp))
    r2 = fma(slope, slope, 1.0)
    return slope, (r2 * r2) * a


@jit
def cycloid_parameter(x, r):
    """The cycloid parameter u(x) in (-pi, pi) (for tests and diagnostics)."""
    sin_half, cos_half = _cycloid_half_angle(x, r)
    return math.copysign(2.0 * math.atan2(sin_half, cos_half), x)


# ---------------------------------------------------------------------------
# sine on a slope: y = mean_slope*x + amplitude*sin(wavenumber*x + phase)
# p0 = mean_slope (dy/dx), p1 = amplitude, p2 = wavenumber, p3 = phase
# sin and cos from vmath (no libm call: the lane loops vectorise), accurate to
# 1 ulp for |wavenumber*x + phase| <= vmath.VALID_ARGUMENT, which the family's
# validation guarantees on the domain (rampwork.ramps._Sine)


@jit
def sine_height(x, p0, p1, p2, p3, shared):
    return p0 * x + p1 * vmath.sin(p2 * x + p3)


@jit
def sine_slope_curvature(x, p0, p1, p2, p3, shared):
    s, c = vmath.sincos(p2 * x + p3)
    return p0 + p1 * p2 * c, -p1 * p2 * p2 * s


@jit
def sine_slope_curvature_near(x, dx, fp, fpp, p0, p1, p2, p3, shared):
    """f', f'' at x = x0 + dx (rounded) from f', f'' at x0, by the angle sum,
    for a fixed-step method's stage points (``steppers.rk4_step``) and step
    end (``kernel._step_and_check``): cheaper than a full sincos, because
    k dx is small (|k dx| <= k |v| h).

    With u = f'(x0) - p0 = A k cos(theta0), f''(x0) = -A k^2 sin(theta0) and
    y = k dx:  f'(x) = f'(x0) + u (cos y - 1) + f''(x0) sin(y)/k  and
    f''(x) = f''(x0) (1 + (cos y - 1)) - k u (k sin(y)/k).  sin and cos - 1 of
    y come from vmath.sin_cos_minus_one_near (a short reduction, then the
    fdlibm kernels' polynomials).  The division f''(x0)/k is the same in
    every stage of a step (the compiler computes it once).  Error
    (tests/test_sine_stages.py): a few ulp of |p0| + |A k| (f') and of
    A k^2 + k |sin y| (|p0| + |A k|) (f'': u carries the rounding of f'(x0)),
    plus those of f'(x0), f''(x0)."""
    sin_y, cos_y_m1 = vmath.sin_cos_minus_one_near(p2 * dx)
    # f''(x0)/k = -A k sin(theta0); where k = 0, f'' = 0 and y = 0 (divide by
    # 1 instead: a select on the divisor keeps the division unconditional)
    fpp_over_k = fpp / (p2 if p2 != 0.0 else 1.0)
    u = fp - p0
    fp_near = fma(u, cos_y_m1, fma(fpp_over_k, sin_y, fp))
    fpp_near = fma(fpp, cos_y_m1, fma(-p2 * u, sin_y, fpp))
    return fp_near, fpp_near


#: |k dx| up to which ``sine_slope_curvature_short`` holds its accuracy; the
#: plan selects it where every step's |k dx| is bounded by it
#: (``rampwork.ramps``'s sine family, ``short_stages``)
SHORT_STAGE_ANGLE = 0.0625
# Taylor coefficients: sin(y)/y = 1 + z (_SC1 + z (_SC2 + z _SC3)) and
# cos(y) - 1 = z (-1/2 + z (_CC2 + z (_CC3 + z _CC4))), z = y^2
_SC1 = -1.0 / 6.0
_SC2 = 1.0 / 120.0
_SC3 = -1.0 / 5040.0
_CC2 = 1.0 / 24.0
_CC3 = -1.0 / 720.0
_CC4 = 1.0 / 40320.0


@jit
def sine_slope_curvature_short(x, dx, fp, fpp, p0, p1, p2, p3, shared):
    """:func:`sine_slope_curvature_near` for |k dx| <= SHORT_STAGE_ANGLE: no
    reduction, no division, short series.

    With y = k dx, z = y^2 = k^2 dx^2:  sin(y)/k = dx (sin y / y) and
    k u sin(y) = k^2 u dx (sin y / y), so  f'(x) = f'(x0) + u (cos y - 1)
    + f''(x0) dx (sin y / y)  and  f''(x) = f''(x0) (1 + (cos y - 1))
    - k^2 u dx (sin y / y).  The series stop at z^3 and z^4: the first terms
    left out, z^4/9! and z^5/10!, are <= 6.4e-16 and 2.5e-19 at
    |y| = 1/16, and they enter f', f'' multiplied by |y| and y^2, below
    4e-17 of |A k| (and of A k^2).  Error (tests/test_sine_stages.py, 10**6
    pairs): f' <= 3.5 ulp of |p0| + |A k|, f'' <= 3.0 ulp of A k^2 + k |sin y|
    (|p0| + |A k|), the reduced form's figures on the same pairs; beyond the
    bound the series' error grows as y^9 (150 ulp at |y| = 1/8)."""
    k2 = p2 * p2
    u = fp - p0
    z = k2 * (dx * dx)
    sinc_y = fma(z, fma(z, fma(z, _SC3, _SC2), _SC1), 1.0)
    cos_y_m1 = z * fma(z, fma(z, fma(z, _CC4, _CC3), _CC2), -0.5)
    sin_y_over_k = dx * sinc_y
    fp_near = fma(fpp, sin_y_over_k, fma(u, cos_y_m1, fp))
    fpp_near = fma(fpp, cos_y_m1, fma(-k2 * u, sin_y_over_k, fpp))
    return fp_near, fpp_near


#: a family's f', f'' function -> its evaluation at a fixed step's stage
#: points and end from the step start's f', f''
#: (``steppers.ramp_slope_curvature_near``), for the families that have one.  Keyed by the function so that every kernel built on it gets
#: it (the kernels' cache names derive from the family, not from the caller);
#: ``general.build_switches`` adds its switch.
SLOPE_CURVATURE_NEAR = {sine_slope_curvature: sine_slope_curvature_near,
                        cycloid_slope_curvature: cycloid_slope_curvature_afresh}
#: the same for steps whose |k dx| the plan bounds by SHORT_STAGE_ANGLE
#: (``KernelVariant.short_stages``)
SLOPE_CURVATURE_SHORT = {sine_slope_curvature: sine_slope_curvature_short,
                         cycloid_slope_curvature: cycloid_slope_curvature_short}


# ---------------------------------------------------------------------------
# natural cubic spline, data in ``shared`` (layout in the module docstring)


@jit
def _spline_interval(x, shared):
    """Index i of the interval [x_i, x_{i+1}] holding x, clamped to [0, n-2]:
    a bisection with a fixed number of steps (shared[1])."""
    n = int(shared[0])
    steps = int(shared[1])
    last = n - 2
    i = 0
    step = 1 << steps
    for _ in range(steps):
        step >>= 1
        j = i + step
        i = j if (j <= last and x >= shared[2 + min(j, last)]) else i
    return i


@jit
def spline_height(x, p0, p1, p2, p3, shared):
    n = int(shared[0])
    i = _spline_interval(x, shared)
    x0 = shared[2 + i]
    x1 = shared[3 + i]
    y0 = shared[2 + n + i]
    y1 = shared[3 + n + i]
    m0 = shared[2 + 2 * n + i]
    m1 = shared[3 + 2 * n + i]
    h = x1 - x0
    a = (x1 - x) / h
    b = (x - x0) / h
    return a * y0 + b * y1 + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * (h * h) * (1.0 / 6.0)


@jit
def spline_slope_curvature(x, p0, p1, p2, p3, shared):
    n = int(shared[0])
    i = _spline_interval(x, shared)
    x0 = shared[2 + i]
    x1 = shared[3 + i]
    y0 = shared[2 + n + i]
    y1 = shared[3 + n + i]
    m0 = shared[2 + 2 * n + i]
    m1 = shared[3 + 2 * n + i]
    h = x1 - x0
    a = (x1 - x) / h
    b = (x - x0) / h
    slope = (y1 - y0) / h + ((1.0 - 3.0 * a * a) * m0 + (3.0 * b * b - 1.0) * m1) * h * (1.0 / 6.0)
    return slope, a * m0 + b * m1


# ---------------------------------------------------------------------------
# sine modes on a chord, data in ``shared`` (a table of coefficient rows; the
# trajectory's p0 is its row): with theta = pi (x - x_lo) / (x_hi - x_lo),
#   f(x) = y_lo + chord_slope (x - x_lo) + sum_{j=1..K} c_j sin(j theta)
# through (x_lo, y_lo) and (x_hi, y_hi) for every row (every mode vanishes at
# both ends).  sin(j theta), cos(j theta) by the Chebyshev recurrence from one
# vmath.sincos (no libm call: the lane loops vectorise; the error grows as
# ~j^2 ulp, a few hundred ulp of the coefficients' size at K = 32).
#
#     shared[0]   K (modes per row, >= 1), as a float
#     shared[1:5] x_lo, x_hi, y_lo, y_hi
#     shared[5]   chord_slope = (y_hi - y_lo) / (x_hi - x_lo)
#     shared[6]   wavenumber = pi / (x_hi - x_lo)
#     shared[7 + r K + (j - 1)]   c_j of row r

MODES_HEADER = 7


@jit
def sine_modes_height(x, p0, p1, p2, p3, shared):
    k = int(shared[0])
    base = MODES_HEADER + int(p0) * k
    d = x - shared[1]
    s1, c1 = vmath.sincos(shared[6] * d)
    two_c = 2.0 * c1
    s_prev = 0.0
    s = s1
    total = 0.0
    for j in range(k):
        total = fma(shared[base + j], s, total)
        s_next = fma(two_c, s, -s_prev)
        s_prev = s
        s = s_next
    return fma(shared[5], d, shared[3]) + total


@jit
def sine_modes_slope_curvature(x, p0, p1, p2, p3, shared):
    k = int(shared[0])
    base = MODES_HEADER + int(p0) * k
    w = shared[6]
    s1, c1 = vmath.sincos(w * (x - shared[1]))
    two_c = 2.0 * c1
    s_prev = 0.0
    s = s1
    c_prev = 1.0
    c = c1
    slope = 0.0  # sum j c_j cos(j theta)
    bend = 0.0  # sum j^2 c_j sin(j theta)
    for j in range(k):
        order = float(j + 1)
        coefficient = shared[base + j] * order
        slope = fma(coefficient, c, slope)
        bend = fma(coefficient * order, s, bend)
        s_next = fma(two_c, s, -s_prev)
        c_next = fma(two_c, c, -c_prev)
        s_prev = s
        s = s_next
        c_prev = c
        c = c_next
    return fma(w, slope, shared[5]), -(w * w) * bend


# ---------------------------------------------------------------------------
# user callables: templates for ``specialise`` (USER_F, USER_FP, USER_FPP are
# bound to the user's jitted functions there; they are not defined here).


def callable_height_template(x, p0, p1, p2, p3, shared):
    return float(USER_F(x))  # noqa: F821


def callable_slope_curvature_template(x, p0, p1, p2, p3, shared):
    return float(USER_FP(x)), float(USER_FPP(x))  # noqa: F821


# ---------------------------------------------------------------------------
# evaluation on an array: template for ``specialise`` (RAMP_HEIGHT and
# RAMP_SLOPE_CURVATURE are bound to one family's functions).


def evaluate_template(x, p0, p1, p2, p3, shared, f, fp, fpp):
    for i in range(x.size):
        f[i] = RAMP_HEIGHT(x[i], p0, p1, p2, p3, shared)  # noqa: F821
        slope, curvature = RAMP_SLOPE_CURVATURE(x[i], p0, p1, p2, p3, shared)  # noqa: F821
        fp[i] = slope
        fpp[i] = curvature
