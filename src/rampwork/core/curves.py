"""Jitted planar curve families (docs/physics.md §5): the frame of r(p) at a point.

A curve is ``r(p) = (X(p), Y(p))`` with a regular position parameter ``p``:
the arc length ``s`` for the families here (``p = s``), ``x`` for a ramp
``y = f(x)`` wrapped as a curve.  Every family NAME has two functions with one
fixed signature, which the curve kernel (``curve_kernel.py``) inlines:

* ``NAME_frame(p, p0, p1, p2, p3, shared) -> (sin_phi, cos_phi, kappa, dp_ds)``:
  the unit tangent ``(cos phi, sin phi)``, the signed curvature
  ``kappa = dphi/ds`` and ``dp/ds = 1 / |r'(p)|`` (exactly 1.0 in arc length,
  so that ``u * dp_ds`` rounds to ``u``);
* ``NAME_point(p, p0, p1, p2, p3, shared) -> (X, Y)``.

``p0..p3`` are the family's shape parameters in the order of
:mod:`rampwork.curves`.  No function here divides by ``cos phi``: a vertical
tangent is an ordinary point.  The cycloid's cusp has infinite curvature
(``kappa = inf`` at ``s = 0``); ``curve_kernel.normal_along_n`` gives it no
force at rest.  ``sin`` and ``cos`` are :mod:`vmath`'s (within 1 ulp; libm
calls would keep the lane kernel's vector loop scalar); the cycloid's point
still calls ``atan2``.
"""

from __future__ import annotations

import math

from .jit import fma, jit
from . import vmath
from .ramps import _spline_interval

# ---------------------------------------------------------------------------
# loop: a circle of radius R = p0, centre (0, R), bottom at the origin;
# p = s = R theta with theta the angle from the bottom, counter-clockwise, so
# phi = theta and the left normal points to the centre (the inside).


@jit
def loop_frame(p, p0, p1, p2, p3, shared):
    sin_theta, cos_theta = vmath.sincos(p / p0)
    return sin_theta, cos_theta, 1.0 / p0, 1.0


@jit
def loop_point(p, p0, p1, p2, p3, shared):
    theta = p / p0
    half = vmath.sin(0.5 * theta)
    return p0 * vmath.sin(theta), 2.0 * p0 * (half * half)  # R (1 - cos theta), no cancellation


# ---------------------------------------------------------------------------
# quarter pipe: a flat of length L = p1 along y = 0 from the origin, then a
# quarter circle of radius R = p0 curving up to a vertical tangent at
# s = L + pi R / 2.  The curvature jumps from 0 to 1/R at s = L: a joint.
#
# A family with joints reads p3 as the branch, which the kernel sets per
# step (curve_kernel.JOINTS, curve_kernel.branch): 0.0 decides by p; 1.0 the
# piece before the first joint, 2.0 the one after it (3.0 after a second
# joint), each continued smoothly past its ends, so that no stage of a step
# that ends at a joint sees the other piece, and a step that starts on a
# joint sees the piece it moves into.


@jit
def quarter_pipe_frame(p, p0, p1, p2, p3, shared):
    curved = p > p1 if p3 == 0.0 else p3 > 1.5
    sin_theta, cos_theta = vmath.sincos((p - p1) / p0 if curved else 0.0)
    return sin_theta, cos_theta, 1.0 / p0 if curved else 0.0, 1.0


@jit
def quarter_pipe_point(p, p0, p1, p2, p3, shared):
    theta = max(p - p1, 0.0) / p0
    half = vmath.sin(0.5 * theta)
    return min(p, p1) + p0 * vmath.sin(theta), 2.0 * p0 * (half * half)


# ---------------------------------------------------------------------------
# brachistochrone cycloid from its cusp: X = r (t - sin t), Y = -r (1 - cos t),
# r = p0, rolling angle t in [0, t_end].  Its arc length s = 4 r (1 - cos(t/2))
# inverts in closed form: with w = s / (4 r), cos(t/2) = 1 - w, so
# sin phi = -cos(t/2) = w - 1 and cos phi = sin(t/2) = sqrt(w (2 - w)), and
# kappa = 1 / (4 r sin(t/2)).  The tangent is vertical (down) at the cusp.


@jit
def cycloid_cusp_frame(p, p0, p1, p2, p3, shared):
    w = p / (4.0 * p0)
    cos_phi = math.sqrt(w * (2.0 - w))
    return w - 1.0, cos_phi, 1.0 / (4.0 * p0 * cos_phi), 1.0


@jit
def cycloid_cusp_point(p, p0, p1, p2, p3, shared):
    w = p / (4.0 * p0)
    sin_half = math.sqrt(w * (2.0 - w))
    t = 2.0 * math.atan2(sin_half, 1.0 - w)
    return p0 * (t - 2.0 * sin_half * (1.0 - w)), -2.0 * p0 * (w * (2.0 - w))


# ---------------------------------------------------------------------------
# clothoid (Euler spiral): the curvature grows linearly with arc length,
# kappa = k0 + s / A^2, so phi = phi0 + k0 s + s^2 / (2 A^2) in closed form;
# A = p0, length p1, k0 = p2, phi0 = p3, from the origin.  The frame needs no
# Fresnel integral; the point (X, Y) = ∫ (cos phi, sin phi) ds does: it is
# integrated by Gauss-Legendre (8 nodes) on panels of at most CLOTHOID_PANEL
# rad of phase each, ~1e-16 relative (checked against scipy's Fresnel
# integrals in the tests).  curves.py bounds the phase by 4 pi.

#: the most phase per panel (rad): the 8-node rule's error is ~ panel^16 / 16!
CLOTHOID_PANEL = 0.5
_GL_NODES = (0.18343464249564978, 0.525532409916329, 0.7966664774136267, 0.9602898564975362)
_GL_WEIGHTS = (0.36268378337836166, 0.3137066458778869, 0.22238103445337443, 0.10122853629037706)


@jit
def clothoid_frame(p, p0, p1, p2, p3, shared):
    sin_phi, cos_phi = vmath.sincos(p3 + p * (p2 + 0.5 * p / (p0 * p0)))
    return sin_phi, cos_phi, p2 + p / (p0 * p0), 1.0


@jit
def clothoid_offset(sigma, phi0, k0, c):
    """∫_0^sigma (cos phi, sin phi) with phi = phi0 + t (k0 + c t / 2): the
    8-node Gauss-Legendre rule on panels of at most CLOTHOID_PANEL rad (the
    clothoid family's point, and a track's clothoid pieces)."""
    phase = abs(k0) * abs(sigma) + 0.5 * abs(c) * sigma * sigma
    panels = 1 + int(phase / CLOTHOID_PANEL)
    width = sigma / panels
    x = 0.0
    y = 0.0
    for i in range(panels):
        centre = (i + 0.5) * width
        for j in range(4):
            for sign in (-1.0, 1.0):
                t = centre + sign * (0.5 * width) * _GL_NODES[j]
                sin_phi, cos_phi = vmath.sincos(phi0 + t * (k0 + 0.5 * c * t))
                x += _GL_WEIGHTS[j] * cos_phi
                y += _GL_WEIGHTS[j] * sin_phi
    return 0.5 * width * x, 0.5 * width * y


@jit
def clothoid_point(p, p0, p1, p2, p3, shared):
    return clothoid_offset(p, p3, p2, 1.0 / (p0 * p0))


# ---------------------------------------------------------------------------
# loop-the-loop track: a flat in-run of length L = p2 from the origin along
# +X, a clothoid blend of length b = p1 (kappa from 0 to 1/R, R = p0), a
# circle of radius R over 2 pi R - b, a mirrored blend (kappa back to 0) and a
# flat out-run of length L: total turning 2 pi, curvature continuous, so no
# joint.  The blends' points are the clothoid's (A^2 = b R); the exit blend is
# the entry one run backwards and mirrored, C(b) - C(b - tau) with Y negated.
# With b = 0 the curvature jumps at both ends of the circle: two joints, at
# s = L and L + 2 pi R (curve_families gives them; the branch p3 picks the piece).


@jit
def _track_blend(tau, b, radius):
    return clothoid_point(tau, math.sqrt(b * radius), b, 0.0, 0.0, 0.0)


@jit
def loop_track_frame(p, p0, p1, p2, p3, shared):
    sigma = p - p2
    arc = 2.0 * math.pi * p0 - p1
    if p3 != 0.0:  # no blend (p1 = 0): two joints, the piece p3 continued (see the pipe)
        if p3 == 2.0:
            sin_phi, cos_phi = vmath.sincos(sigma / p0)
            return sin_phi, cos_phi, 1.0 / p0, 1.0
        return 0.0, 1.0, 0.0, 1.0
    if sigma <= 0.0:
        return 0.0, 1.0, 0.0, 1.0
    if sigma <= p1:
        sin_phi, cos_phi = vmath.sincos(0.5 * sigma * sigma / (p1 * p0))
        return sin_phi, cos_phi, sigma / (p1 * p0), 1.0
    if sigma <= p1 + arc:
        sin_phi, cos_phi = vmath.sincos(0.5 * p1 / p0 + (sigma - p1) / p0)
        return sin_phi, cos_phi, 1.0 / p0, 1.0
    rest = 2.0 * p1 + arc - sigma  # arc length left in the exit blend
    if rest >= 0.0:
        sin_phi, cos_phi = vmath.sincos(-0.5 * rest * rest / (p1 * p0))
        return sin_phi, cos_phi, rest / (p1 * p0), 1.0
    return 0.0, 1.0, 0.0, 1.0


@jit
def loop_track_point(p, p0, p1, p2, p3, shared):
    sigma = p - p2
    arc = 2.0 * math.pi * p0 - p1
    if sigma <= 0.0:
        return p, 0.0
    if p1 == 0.0:  # no blend: the circle from (L, 0), then the out-run from there
        if sigma <= arc:
            half = vmath.sin(0.5 * sigma / p0)
            return p2 + p0 * vmath.sin(sigma / p0), 2.0 * p0 * (half * half)
        return p - arc, 0.0
    if sigma <= p1:
        x, y = _track_blend(sigma, p1, p0)
        return p2 + x, y
    bx, by = _track_blend(p1, p1, p0)
    phi_in = 0.5 * p1 / p0
    # the circle's centre, from the entry blend's end
    cx = p2 + bx - p0 * vmath.sin(phi_in)
    cy = by + p0 * vmath.cos(phi_in)
    if sigma <= p1 + arc:
        phi = phi_in + (sigma - p1) / p0
        return cx + p0 * vmath.sin(phi), cy - p0 * vmath.cos(phi)
    # the exit blend starts where the circle ends (phi = 2 pi - phi_in)
    x3 = cx - p0 * vmath.sin(phi_in)
    y3 = cy - p0 * vmath.cos(phi_in)
    tau = min(sigma - p1 - arc, p1)
    ex, ey = _track_blend(p1 - tau, p1, p0)
    x4 = x3 + (bx - ex)
    y4 = y3 - (by - ey)
    return x4 + max(sigma - 2.0 * p1 - arc, 0.0), y4


# ---------------------------------------------------------------------------
# parametric cubic splines through points: p = t, the chord-length parameter
# (t_0 = 0, t_{k+1} = t_k + |P_{k+1} - P_k|), so |r'(t)| is near 1 but not 1:
# dp/ds = 1 / |r'(t)|, the kernel's u * dp_ds.  A population of splines (as
# many points each) shares one array, one row per spline (p0: the row, as
# the convex cusp's): ``shared`` holds [rows, block, then per row: n,
# bisection steps, t_0..t_{n-1}, then per piece the power-form coefficients
# (c0 dt^3 + c1 dt^2 + c2 dt + c3) of X, then of Y]
# (rampwork.curve_families.spline_population builds it with scipy's CubicSpline).


@jit
def _spline_piece(p, p0, shared):
    """(the row's data, index of the piece's X and Y coefficients, p - t_i)."""
    row = min(max(int(p0), 0), int(shared[0]) - 1)
    start = 2 + row * int(shared[1])
    data = shared[start:start + int(shared[1])]
    n = int(data[0])
    i = _spline_interval(p, data)
    return data, 2 + n + 4 * i, 2 + n + 4 * (n - 1) + 4 * i, p - data[2 + i]


@jit
def spline_curve_frame(p, p0, p1, p2, p3, shared):
    c, ix, iy, dt = _spline_piece(p, p0, shared)
    dx = (3.0 * c[ix] * dt + 2.0 * c[ix + 1]) * dt + c[ix + 2]
    dy = (3.0 * c[iy] * dt + 2.0 * c[iy + 1]) * dt + c[iy + 2]
    ddx = 6.0 * c[ix] * dt + 2.0 * c[ix + 1]
    ddy = 6.0 * c[iy] * dt + 2.0 * c[iy + 1]
    speed = math.sqrt(dx * dx + dy * dy)
    inverse = 1.0 / speed
    return dy * inverse, dx * inverse, (dx * ddy - dy * ddx) * (inverse * inverse * inverse), inverse


@jit
def spline_curve_point(p, p0, p1, p2, p3, shared):
    c, ix, iy, dt = _spline_piece(p, p0, shared)
    x = ((c[ix] * dt + c[ix + 1]) * dt + c[ix + 2]) * dt + c[ix + 3]
    y = ((c[iy] * dt + c[iy + 1]) * dt + c[iy + 2]) * dt + c[iy + 3]
    return x, y


# ---------------------------------------------------------------------------
# a ramp y = f(x) as a curve, p = x: templates whose ``ramp_slope_curvature``
# and ``ramp_height`` are a ramp family's (bound by ``jit.specialise``).
ramp_slope_curvature = ramp_height = None


def graph_frame(p, p0, p1, p2, p3, shared):
    """|r'| = sqrt(1 + f'^2): tangent (1, f') / |r'|, kappa = f'' / |r'|^3."""
    fp, fpp = ramp_slope_curvature(p, p0, p1, p2, p3, shared)
    w = fma(fp, fp, 1.0)
    inverse = 1.0 / math.sqrt(w)
    return fp * inverse, inverse, fpp * (inverse / w), inverse


def graph_point(p, p0, p1, p2, p3, shared):
    return p, ramp_height(p, p0, p1, p2, p3, shared)


def evaluate_template(p, p0, p1, p2, p3, shared, out):
    """Frame and point at every ``p`` (rows of ``out``: sin phi, cos phi,
    kappa, dp/ds, X, Y), with the kernel's own functions (``curve_frame``,
    ``curve_point`` bound by ``jit.specialise``)."""
    for i in range(p.size):
        sin_phi, cos_phi, kappa, dp_ds = curve_frame(p[i], p0[i], p1[i], p2[i], p3[i], shared)
        x, y = curve_point(p[i], p0[i], p1[i], p2[i], p3[i], shared)
        out[0, i] = sin_phi
        out[1, i] = cos_phi
        out[2, i] = kappa
        out[3, i] = dp_ds
        out[4, i] = x
        out[5, i] = y


curve_frame = curve_point = None  # bound per family by jit.specialise


# ---------------------------------------------------------------------------
# convex cusp: a convex curve from a vertical start at the origin (a cusp, as
# the cycloid's), given by its radius of curvature as a function of the
# tangent angle, rho = ds/dphi = cos(phi) exp(E(t)), E = sum c_k T_k(t) with
# t = 2 theta / theta_B - 1, theta = phi + pi/2 in [0, theta_B] (the form of
# the frictional brachistochrone's direct check, docs/brachistochrone.md).
# Its position parameter is p = 1 + sin(phi) = 1 - cos(theta): regular, as
# dp/ds = cos(phi) / rho = exp(-E) needs no division, and it gives the
# tangent without cancellation: sin phi = p - 1, cos phi = sqrt(p (2 - p)).
# One row of ``shared`` per curve (p0: the row), so a population shares one
# array: [rows, nc, nx, block, then per row: theta_B, c_0..c_{nc-1}, the nx
# Chebyshev coefficients in t of X, then of Y (m)]
# (rampwork.curve_families.convex_cusp_shared builds it).  kappa = 1 / rho
# is infinite at the cusp itself, where only a Runge-Kutta stage off the
# trajectory (p = 0 with u != 0, a second stage) evaluates it with a speed:
# it gets CUSP_CURVATURE, whose sign (towards the block) the rest rule reads
# and whose force rounds to 0, as the cycloid's nu = g cos phi at rest.

#: the curvature given at the cusp itself (m-1): its sign is what matters
CUSP_CURVATURE = 1e-300


@jit
def _cusp_row(p0, shared):
    """(start of the row's block, nc, nx); a row out of range is clamped."""
    row = min(max(int(p0), 0), int(shared[0]) - 1)
    return 4 + row * int(shared[3]), int(shared[1]), int(shared[2])


@jit
def _chebyshev_sum(shared, start, n, t):
    """sum_{k < n} shared[start + k] T_k(t), by Clenshaw's recurrence."""
    b1 = 0.0
    b2 = 0.0
    two_t = 2.0 * t
    for k in range(n - 1, 0, -1):
        b1, b2 = fma(two_t, b1, shared[start + k] - b2), b1
    return fma(t, b1, shared[start] - b2)


@jit
def _cusp_t(p, theta_end):
    return 4.0 * math.asin(math.sqrt(0.5 * p)) / theta_end - 1.0  # theta = 2 asin(sqrt(p/2))


@jit
def convex_cusp_frame(p, p0, p1, p2, p3, shared):
    start, nc, nx = _cusp_row(p0, shared)
    e = math.exp(_chebyshev_sum(shared, start + 1, nc, _cusp_t(p, shared[start])))
    cos_phi = math.sqrt(p * (2.0 - p))
    kappa = CUSP_CURVATURE if p == 0.0 else 1.0 / (cos_phi * e)
    return p - 1.0, cos_phi, kappa, 1.0 / e


@jit
def convex_cusp_point(p, p0, p1, p2, p3, shared):
    if p == 0.0:
        return 0.0, 0.0  # A, exactly
    start, nc, nx = _cusp_row(p0, shared)
    t = _cusp_t(p, shared[start])
    start += 1 + nc
    return _chebyshev_sum(shared, start, nx, t), _chebyshev_sum(shared, start + nx, nx, t)
