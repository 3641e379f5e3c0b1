"""Jitted ramp families: f(x), f'(x) and f''(x) from plain floats.

Every family NAME has two functions with one fixed signature, which the batch
kernel inlines into its SIMD lane loop:

* ``NAME_height(x, p0, p1, p2, p3, shared) -> f(x)``
* ``NAME_slope_curvature(x, p0, p1, p2, p3, shared) -> (f'(x), f''(x))``

``p0..p3`` are the family's per-trajectory shape parameters in the order of
:mod:`rampwork.ramps` (unused ones are 0.0); ``shared`` is a 1-D float64 array
shared by all trajectories (the spline's knots, sine_modes' coefficient
table; never empty).  The cycloid bowl's functions are in ``cycloid.py``
(re-exported here).

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
# the cycloid bowl has a module of its own (cycloid.py): its names are
# re-exported here, where the other families' are, for the registries below
from .cycloid import (CYCLOID_GROWTH_0, CYCLOID_GROWTH_1, CYCLOID_SHORT_BOUND,  # noqa: F401
                      CYCLOID_SPLIT, cycloid_cusp_gap, cycloid_height, cycloid_parameter,
                      cycloid_slope_curvature, cycloid_slope_curvature_afresh,
                      cycloid_slope_curvature_short)
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
# cycloid bowl: x = r (u + sin u), y = r (1 - cos u), -pi < u < pi; p0 = r
# (cycloid.py)


# ---------------------------------------------------------------------------
# sine on a slope: y = mean_slope*x + amplitude*sin(wavenumber*x + phase)
# p0 = mean_slope (dy/dx), p1 = amplitude, p2 = wavenumber, p3 = phase
# sin and cos from vmath (no libm call: the lane loops vectorise), accurate to
# 1 ulp for |wavenumber*x + phase| <= vmath.VALID_ARGUMENT, which the family's
# validation guarantees on the domain (rampwork.ramp_families._Sine)


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
#: (``rampwork.ramp_families``' sine family, ``short_stages``)
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
