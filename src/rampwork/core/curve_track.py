"""A track of pieces (docs/physics.md §5.1): the jitted frame and point of the
curve family ``track`` and the joints' search of the curve kernel.

A track is a chain of pieces, each with a curvature linear in arc length
(``kappa = k0 + c sigma``, ``sigma`` the arc length from the piece's start):
a straight (k0 = c = 0), a circular arc (c = 0) or a clothoid.  Its tangent
angle is ``phi = phi_k + sigma (k0 + c sigma / 2)`` in closed form; its point
is the piece's start point plus ``∫ (cos phi, sin phi) dsigma``: the chord
in closed form on a straight or an arc, by Gauss-Legendre panels on a
clothoid (core/curves.py's clothoid rule).  p = s.

Every piece's start but the first is a joint (the curvature or its slope
jumps there), any number of them: the kernel's ``JOINTS = MANY_JOINTS``
mode (curve_kernel.py), where a trajectory's joints are a sorted run of
``shared`` (its offset and count in the inputs' JOINT and JOINT2 rows), the
next one ahead found by :func:`joints_behind` at the start and kept up by
:func:`branch_near` from step to step.  The frame reads its shape parameter
p3 as the branch (1 + the joints behind: the piece), as the other families
with joints do, so the stages of a step that ends at a joint see the piece
the step started on, continued.

A population of tracks shares one array, one row per track (p0: the row):
``shared`` = [rows, block, then per row: n (pieces), s_0..s_n (the pieces'
starts and the end), then per piece phi_k, k0, c, X_k, Y_k] (each a run of n),
built by ``rampwork.curve_families.track_population``.
"""

from __future__ import annotations

import math

from . import vmath
from .curves import clothoid_offset as track_offset
from .jit import jit


@jit
def track_row(p0, shared):
    """(start of the row's block, its pieces n); a row out of range is clamped."""
    row = min(max(int(p0), 0), int(shared[0]) - 1)
    start = 2 + row * int(shared[1])
    return start, int(shared[start])


@jit
def joints_behind(p, d, shared, first, count):
    """The joints ``shared[first:first + count]`` (sorted) behind p for a
    step in direction d: those < p, and one == p when d > 0 (a step from a
    joint moves onto the piece ahead of it).  Bisection."""
    lo = 0
    hi = count
    while lo < hi:  # the first joint >= p
        mid = (lo + hi) // 2
        if shared[first + mid] < p:
            lo = mid + 1
        else:
            hi = mid
    if lo < count and shared[first + lo] == p and d > 0.0:
        lo += 1
    return lo


@jit
def branch_near(p, d, shared, first, count, s3):
    """``(s3, ahead)`` as curve_kernel.branch, for any number of joints:
    ``s3`` (1 + the joints behind) from the last step's ``s3``, which is off
    by at most one (no step crosses a joint: it ends just past it), and the
    next joint ahead in direction d (NaN: none).  No loop, so the lane
    kernel's vector loop keeps its width."""
    k = min(max(int(s3) - 1, 0), count)  # (an empty lane's s3 may be anything)
    if k < count and (p > shared[first + k] or (p == shared[first + k] and d > 0.0)):
        k += 1
    elif k > 0 and not (p > shared[first + k - 1] or (p == shared[first + k - 1] and d > 0.0)):
        k -= 1
    if d > 0.0:
        ahead = shared[first + k] if k < count else math.nan
    else:
        ahead = shared[first + k - 1] if k > 0 else math.nan
    return 1.0 + k, ahead


@jit
def _track_piece(p, p0, p3, shared):
    """(row start, n, piece k, sigma = p - s_k): piece p3 - 1 (the branch),
    or with p3 = 0 the piece holding p (the last one starting at or before it)."""
    start, n = track_row(p0, shared)
    if p3 != 0.0:
        k = min(max(int(p3) - 1, 0), n - 1)
    else:
        k = joints_behind(p, 1.0, shared, start + 2, n - 1)
    return start, n, k, p - shared[start + 1 + k]


@jit
def track_frame(p, p0, p1, p2, p3, shared):
    start, n, k, sigma = _track_piece(p, p0, p3, shared)
    base = start + 2 + n + k
    k0 = shared[base + n]
    c = shared[base + 2 * n]
    sin_phi, cos_phi = vmath.sincos(shared[base] + sigma * (k0 + 0.5 * c * sigma))
    return sin_phi, cos_phi, k0 + c * sigma, 1.0


@jit
def piece_offset(sigma, phi0, k0, c):
    """The point's offset along a piece: for a straight or an arc (c = 0) in
    closed form, the chord 2 sin(k0 sigma / 2) / k0 at the mean angle (no
    cancellation, one sincos where the quadrature takes 8 or more); for a
    clothoid, :func:`rampwork.core.curves.clothoid_offset`."""
    if c != 0.0:
        return track_offset(sigma, phi0, k0, c)
    half = 0.5 * k0 * sigma
    chord = sigma if k0 == 0.0 else 2.0 * vmath.sin(half) / k0
    sin_mean, cos_mean = vmath.sincos(phi0 + half)
    return chord * cos_mean, chord * sin_mean


@jit
def track_point(p, p0, p1, p2, p3, shared):
    start, n, k, sigma = _track_piece(p, p0, p3, shared)
    base = start + 2 + n + k
    dx, dy = piece_offset(sigma, shared[base], shared[base + n], shared[base + 2 * n])
    return shared[base + 3 * n] + dx, shared[base + 4 * n] + dy
