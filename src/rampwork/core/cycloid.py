"""The cycloid bowl family's jitted f, f', f'' (``ramps.py`` has the others).

Its own module because u(x) has no closed form: it is solved here without a
loop or a libm call (a polynomial guess and one Newton correction folded into
the results), and fixed steps take f' at their stage points from a Taylor
series (``cycloid_slope_curvature_short``).  The signatures and the rules are
those of ``ramps.py``'s docstring.
"""

from __future__ import annotations

import math

from . import vmath
from .jit import fma, jit

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
#: (``rampwork.ramp_families``' cycloid ``short_stages``)
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
