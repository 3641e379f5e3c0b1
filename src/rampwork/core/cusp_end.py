"""The end angle of each convex cusp candidate (``descent_shapes.CuspCurve``):
the tangent angle phi_B at which the curve's end lies in B's direction.

The curve's end from A, for an end angle phi_B, is the quadrature
(X, Y) = h^2 sum_j W_j e_j sin(theta_j) (sin(theta_j), -cos(theta_j)),
theta_j = h (t_j + 1), h = (phi_B + pi/2) / 2, over the Chebyshev nodes t_j
(weights W_j, e_j = exp(E(t_j)) without c_0, which only scales the curve).
Per candidate: the first sign change of ``miss`` (the end's direction less
B's) on a grid of end angles brackets the root, then Illinois steps narrow
the bracket to adjacent floats.

Why jitted and per candidate: the numpy version evaluated every candidate
at all 96 grid angles (two sines and a cosine per node and angle) and then
took ~60 bisection steps over the whole population; 340 us per candidate,
80 % of ``CuspCurve.evaluate``.  Here the grid stops at the first bracket,
its angles are exact multiples of one step, so each node's (cos, sin) is
advanced by a complex rotation (no trigonometry), and the refinement
converges superlinearly.
"""

from __future__ import annotations

import math

import numpy as np

from .jit import jit


@jit
def _miss(angle, e, nodes, weights, target):
    """Direction of the end from A, less B's (rad), at end angle ``angle``;
    the quadrature in the order of ``curve_families.contract``."""
    half = 0.5 * (angle + 0.5 * math.pi)
    x = 0.0
    y = 0.0
    for j in range(nodes.size):
        theta = half * (nodes[j] + 1.0)
        s = math.sin(theta)
        rate = half * s * e[j]
        x = x + rate * s * weights[j]
        y = y + rate * math.cos(theta) * weights[j]
    return math.atan2(-y, x) - target


@jit
def _grid_values(e, nodes, weights, target, step, n_grid, first_only, values):
    """``miss`` at end angles -pi/2 + (k + 1) step, k = 0 .. n_grid - 1, into
    ``values``, stopping after the first bracket (v_k <= 0 <= v_{k+1}) if
    ``first_only``.  Returns that k, or -1.  The angles' half-spans are
    (k + 1) step / 2, so node j's angle theta_j advances by the same
    rotation r_j every k: (cos, sin) by a complex product (the direction's
    scale h^2 cancels in atan2).  Rounding drifts by ~1e-14 over the grid:
    it only brackets; the root is refined on the exact ``_miss``."""
    n = nodes.size
    cos_r = np.empty(n)
    sin_r = np.empty(n)
    c = np.empty(n)
    s = np.empty(n)
    for j in range(n):
        phi = 0.5 * step * (nodes[j] + 1.0)
        cos_r[j] = math.cos(phi)
        sin_r[j] = math.sin(phi)
        c[j] = cos_r[j]
        s[j] = sin_r[j]
    for k in range(n_grid):
        if k > 0:
            for j in range(n):
                c_new = c[j] * cos_r[j] - s[j] * sin_r[j]
                s[j] = s[j] * cos_r[j] + c[j] * sin_r[j]
                c[j] = c_new
        x = 0.0
        y = 0.0
        for j in range(n):
            rate = s[j] * e[j] * weights[j]
            x = x + rate * s[j]
            y = y + rate * c[j]
        values[k] = math.atan2(-y, x) - target
        if first_only and k > 0 and values[k - 1] <= 0.0 and values[k] >= 0.0:
            return k - 1
    return -1


@jit
def _refine(lo, hi, e, nodes, weights, target):
    """The root of ``_miss`` in [lo, hi] (miss(lo) <= 0 <= miss(hi)) to
    adjacent floats by the Illinois method (a midpoint where its point does
    not fall strictly inside); of the two ends, the one closer to zero."""
    f_lo = _miss(lo, e, nodes, weights, target)
    f_hi = _miss(hi, e, nodes, weights, target)
    if f_lo > 0.0:  # the grid's rounding put the sign change at lo itself
        return lo
    if f_hi < 0.0:
        return hi
    a_lo, a_hi = f_lo, f_hi  # the secant's values (halved where an end sticks)
    side = 0
    for _ in range(200):
        c = lo - a_lo * (hi - lo) / (a_hi - a_lo)
        if not (lo < c < hi):
            c = 0.5 * (lo + hi)
            if not (lo < c < hi):
                break
        fc = _miss(c, e, nodes, weights, target)
        if fc <= 0.0:
            lo, f_lo, a_lo = c, fc, fc
            if side == -1:
                a_hi *= 0.5
            side = -1
        else:
            hi, f_hi, a_hi = c, fc, fc
            if side == 1:
                a_lo *= 0.5
            side = 1
        if fc == 0.0:
            return c
    return lo if abs(f_lo) <= abs(f_hi) else hi


@jit
def cusp_end_angles(exponents, nodes, weights, target, step, n_grid, angles, through):
    """Each row's end angle (``angles``) and whether a bracket was found
    (``through``); without one, the grid angle whose direction came closest.
    ``exponents`` (S, n): exp(E(t_j)) without c_0 per candidate; ``step``:
    the grid's spacing (its angles -pi/2 + (k + 1) step)."""
    values = np.empty(n_grid)
    for row in range(exponents.shape[0]):
        e = exponents[row]
        k = _grid_values(e, nodes, weights, target, step, n_grid, True, values)
        through[row] = k >= 0
        if k >= 0:
            angles[row] = _refine(-0.5 * math.pi + (k + 1) * step, -0.5 * math.pi + (k + 2) * step,
                                  e, nodes, weights, target)
        else:
            best = 0
            for i in range(1, n_grid):
                if abs(values[i]) < abs(values[best]):
                    best = i
            angles[row] = -0.5 * math.pi + (best + 1) * step
