"""A track of pieces (docs/physics.md §5.1): the jitted frame and point of the
curve family ``track`` and the joints' search of the curve kernel.

A track is a chain of pieces, each with a curvature linear in arc length
(``kappa = k0 + c sigma``, ``sigma`` the arc length from the piece's start):
a straight (k0 = c = 0), a circular arc (c = 0) or a clothoid.  Its tangent
angle is ``phi = phi_k + sigma (k0 + c sigma / 2)`` in closed form.  p = s.

Nothing here loops on data, so the lane kernel's vector loop keeps its
width (curve_lanes.py): the piece is the kernel's branch p3 (below) or, at
p3 = 0, a cell of a uniform table over s; the point is a panel's start point
(stored) plus the rest of the way by a 3-node Gauss-Legendre rule: each
piece is cut into panels over which the tangent turns by at most
PANEL_TURN, so the rule's error is ~5e-7 PANEL_TURN^6 of the panel (~1e-19)
and each node needs only the small-angle sin and cos (vmath.sin_small).
Every read of ``shared`` goes through :func:`rampwork.core.readonly.read`.

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
``shared`` = [rows, block, 1 / cell width, cells M, then per row: n
(pieces), s_0..s_n (the pieces' starts and the end), then per piece (each a
run of n) phi_k, k0, c, its first panel's offset in the row, its panel
count, panel width and 1 / width; then the M cells (the piece at a
cell's start less half a cell, then the next joint, +inf: none); then per
panel X, Y, cos phi, sin phi at its start], built by
``rampwork.curve_tracks.track_population``.  The cells are at most a third
of the shortest inner piece wide, so two of them hold at most one joint.
"""

from __future__ import annotations

import math

import numpy as np

from . import vmath
from .curves import clothoid_offset
from .jit import float_bits, jit
from .readonly import read

#: the population's header: rows, block, 1 / cell width, cells per row
TRACK_HEADER = 4
#: the most the tangent turns over one panel (rad)
PANEL_TURN = 0.01
#: values per panel: X, Y, cos phi, sin phi at its start
PANEL_FIELDS = 4
_SHIFT = 4503599627370496.0  # 2**52: x + 2**52 holds the integer x in its low bits
_NODE = 0.3872983346207417  # the 3-node rule's outer nodes, 1/2 -+ sqrt(3/5)/2 of the panel
_OUTER = 5.0 / 18.0
_MIDDLE = 8.0 / 18.0


@jit
def _clamped(x, top):
    """floor(x) clamped to [0, top] (NaN: 0)."""
    x = np.floor(x)  # (math.floor gives an int in numba: two conversions)
    x = x if x > 0.0 else 0.0
    return x if x < top else top


@jit
def _whole(x, top):
    """:func:`_clamped` as an int: float operations and a bit cast, which
    vectorise where a conversion may not (AVX2 has no double to int64)."""
    return float_bits(_clamped(x, top) + _SHIFT) - float_bits(_SHIFT)


@jit
def track_row(p0, shared):
    """(start of the row's block, its pieces n); a row out of range is clamped."""
    start = TRACK_HEADER + _whole(p0, read(shared, 0) - 1.0) * int(read(shared, 1))
    return start, _whole(read(shared, start), _SHIFT)


@jit(internal=True, refcount=False)
def joints_behind(p, d, shared, first, count):
    """The joints ``shared[first:first + count]`` (sorted) behind p for a
    step in direction d: those < p, and one == p when d > 0 (a step from a
    joint moves onto the piece ahead of it).  Bisection (a trajectory's
    start, in scalar code)."""
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


@jit(internal=True, refcount=False)
def branch_near(p, d, shared, first, count, s3):
    """``(s3, ahead)`` as curve_kernel.branch, for any number of joints:
    ``s3`` (1 + the joints behind) from the last step's ``s3``, which is off
    by at most one (no step crosses a joint: it ends just past it), and the
    next joint ahead in direction d (NaN: none).  No loop, so the lane
    kernel's vector loop keeps its width."""
    behind_f = _clamped(s3 - 1.0, _SHIFT)  # the joints behind, as a float and an int
    k = float_bits(behind_f + _SHIFT) - float_bits(_SHIFT)
    valid = k <= count  # (an empty lane's s3 may be anything)
    k = k if valid else 0
    behind_f = behind_f if valid else 0.0
    # four joints around k, read unconditionally at clamped offsets (a
    # conditional read is a masked gather, which LLVM's cost model refuses)
    last = count - 1
    before = read(shared, first + max(k - 2, 0))
    behind = read(shared, first + max(k - 1, 0))
    ahead = read(shared, first + min(k, last))
    after = read(shared, first + min(k + 1, last))
    behind = behind if k > 0 else -math.inf
    ahead = ahead if k < count else math.inf
    up = p > ahead or (p == ahead and d > 0.0)
    down = (not up) and k > 0 and not (p > behind or (p == behind and d > 0.0))
    k = k + 1 if up else (k - 1 if down else k)
    behind_f = behind_f + 1.0 if up else (behind_f - 1.0 if down else behind_f)
    if d > 0.0:  # the joint k (of the new k), NaN past the last
        joint = after if up else (behind if down else ahead)
        joint = joint if k < count else math.nan
    else:  # the joint k - 1, NaN before the first
        joint = ahead if up else (before if down else behind)
        joint = joint if k > 0 else math.nan
    return 1.0 + behind_f, joint


@jit
def _track_piece(p, p0, p3, shared):
    """(row start, n, piece k, sigma = p - s_k): piece p3 - 1 (the branch),
    or with p3 = 0 the piece holding p (the last one starting at or before
    it), from its cell: the cell's piece, or the next one past its joint."""
    start, n = track_row(p0, shared)
    cells = read(shared, 3)
    cell = _whole(p * read(shared, 2), cells - 1.0)
    table = start + 8 * n + 2 + cell
    found = read(shared, table) + (1.0 if p >= read(shared, table + int(cells)) else 0.0)
    k = _whole(p3 - 1.0 if p3 != 0.0 else found, n - 1.0)
    return start, n, k, p - read(shared, start + 1 + k)


@jit
def track_frame(p, p0, p1, p2, p3, shared):
    start, n, k, sigma = _track_piece(p, p0, p3, shared)
    base = start + 2 + n + k
    k0 = read(shared, base + n)
    c = read(shared, base + 2 * n)
    sin_phi, cos_phi = vmath.sincos(read(shared, base) + sigma * (k0 + 0.5 * c * sigma))
    return sin_phi, cos_phi, k0 + c * sigma, 1.0


@jit
def piece_offset(sigma, phi0, k0, c):
    """The point's offset along a piece, for the panels' start points (set-up,
    not the kernel): for a straight or an arc (c = 0) in closed form, the
    chord 2 sin(k0 sigma / 2) / k0 at the mean angle; for a clothoid,
    :func:`rampwork.core.curves.clothoid_offset`."""
    if c != 0.0:
        return clothoid_offset(sigma, phi0, k0, c)
    half = 0.5 * k0 * sigma
    chord = sigma if k0 == 0.0 else 2.0 * vmath.sin(half) / k0
    sin_mean, cos_mean = vmath.sincos(phi0 + half)
    return chord * cos_mean, chord * sin_mean


@jit
def _turned(t, kappa, c):
    """(cos psi - 1, sin psi) of the turn psi = t (kappa + c t / 2), small."""
    psi = t * (kappa + 0.5 * c * t)
    return vmath.cos_minus_one_small(psi), vmath.sin_small(psi)


@jit
def track_point(p, p0, p1, p2, p3, shared):
    start, n, k, sigma = _track_piece(p, p0, p3, shared)
    base = start + 2 + n + k
    k0 = read(shared, base + n)
    c = read(shared, base + 2 * n)
    count = read(shared, base + 4 * n)
    width = read(shared, base + 5 * n)
    panel = _clamped(sigma * read(shared, base + 6 * n), count - 1.0)
    at = (start + _whole(read(shared, base + 3 * n), _SHIFT)
          + PANEL_FIELDS * (float_bits(panel + _SHIFT) - float_bits(_SHIFT)))
    corner = panel * width  # the panel's start, sigma_j, as the set-up took it
    tau = sigma - corner
    kappa = k0 + c * corner
    cm1, s1 = _turned(tau * (0.5 - _NODE), kappa, c)
    cm2, s2 = _turned(tau * 0.5, kappa, c)
    cm3, s3 = _turned(tau * (0.5 + _NODE), kappa, c)
    along = tau + tau * (_OUTER * (cm1 + cm3) + _MIDDLE * cm2)
    across = tau * (_OUTER * (s1 + s3) + _MIDDLE * s2)
    cos_j = read(shared, at + 2)
    sin_j = read(shared, at + 3)
    return (read(shared, at) + (cos_j * along - sin_j * across),
            read(shared, at + 1) + (sin_j * along + cos_j * across))
