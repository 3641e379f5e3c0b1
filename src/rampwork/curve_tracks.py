"""Tracks of pieces (family ``track``, docs/physics.md §5.1): straights,
circular arcs and clothoids in a chain, with a joint at every piece's start
but the first, any number of them (core/curve_track.py).

A piece is ``(length, curvature_start, curvature_end)``: its curvature runs
linearly from one to the other over its length (equal: a straight or an arc).
A track starts at ``start = (X, Y, angle)`` (the tangent angle, rad).  A
population of tracks, one per row, shares one array; :func:`loop_track_pieces`
gives the loop-the-loop with a sloped in-run.
"""

from __future__ import annotations

import math

import numpy as np

from .core import curve_track
from .errors import ConfigError

#: where the population's joints are, per trajectory: the offset of row r's
#: s_1 in ``shared`` is TRACK_HEADER + r * block + 2 (core/curve_track.py)
TRACK_HEADER = 2


def _pieces_rows(pieces) -> list[np.ndarray]:
    """The pieces as a list of (n, 3) arrays, one per track: ``pieces`` one
    track's list of [length, curvature_start, curvature_end], or a list of them."""
    try:
        array = np.asarray(pieces, dtype=np.float64)
        rows = [array] if array.ndim == 2 else list(array) if array.ndim == 3 else None
    except (TypeError, ValueError):  # tracks of different piece counts
        try:
            rows = [np.asarray(track, dtype=np.float64) for track in pieces]
        except (TypeError, ValueError):
            rows = None
    if rows is None or not rows or any(r.ndim != 2 or r.shape[1] != 3 or r.shape[0] == 0
                                       for r in rows):
        raise ConfigError("curve.pieces", "expected a list of [length, curvature_start, "
                          "curvature_end] pieces (or one such list per track)")
    return rows


def check_joints(joints, p_lo: float, p_hi: float, where: str = "curve.joints") -> np.ndarray:
    """Joints must be finite, strictly increasing and strictly inside the
    domain (p_lo, p_hi): a joint at an end or out of it ends no step."""
    joints = np.asarray(joints, dtype=np.float64).ravel()
    if not np.isfinite(joints).all():
        raise ConfigError(where, f"must be finite, got {joints.tolist()!r}")
    bad = np.flatnonzero(~(np.diff(joints) > 0))
    if bad.size:
        k = int(bad[0])
        raise ConfigError(where, f"must be strictly increasing (sorted, no repeats), got "
                          f"{joints[k]!r} then {joints[k + 1]!r} at {k} and {k + 1}")
    outside = np.flatnonzero(~((joints > p_lo) & (joints < p_hi)))
    if outside.size:
        raise ConfigError(where, f"must lie strictly inside the curve's domain ({p_lo!r}, "
                          f"{p_hi!r}), got {joints[outside[0]]!r}")
    return joints


def track_row(pieces: np.ndarray, start) -> np.ndarray:
    """One track's block of ``shared`` (layout: core/curve_track.py)."""
    for column, name in ((0, "length"), (1, "curvature_start"), (2, "curvature_end")):
        if not np.isfinite(pieces[:, column]).all():
            raise ConfigError("curve.pieces", f"each piece's {name} must be finite")
    bad = np.flatnonzero(~(pieces[:, 0] > 0))
    if bad.size:
        raise ConfigError("curve.pieces", f"piece {int(bad[0])}: the length must be > 0, got "
                          f"{pieces[bad[0], 0]!r}")
    n = pieces.shape[0]
    lengths, k0, k1 = pieces.T
    c = (k1 - k0) / lengths
    s = np.concatenate([[0.0], np.cumsum(lengths)])
    check_joints(s[1:-1], 0.0, s[-1], "curve.pieces")
    phi = np.empty(n)
    x = np.empty(n)
    y = np.empty(n)
    x[0], y[0], phi[0] = start
    for k in range(1, n):  # each piece starts where the last one ends
        dx, dy = curve_track.piece_offset(lengths[k - 1], phi[k - 1], k0[k - 1], c[k - 1])
        x[k], y[k] = x[k - 1] + dx, y[k - 1] + dy
        phi[k] = phi[k - 1] + lengths[k - 1] * (k0[k - 1] + 0.5 * c[k - 1] * lengths[k - 1])
    return np.concatenate([[n], s, phi, k0, c, x, y])


def track_population(pieces, start=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The ``shared`` data of the tracks (``pieces``: one list of pieces, or
    one per track; ``start``: (X, Y, angle), one for all or one per track).
    Rows are padded to the longest; an error names the track's row."""
    rows = _pieces_rows(pieces)
    starts = np.asarray(start, dtype=np.float64)
    if starts.ndim == 1:
        starts = np.broadcast_to(starts, (len(rows), starts.size))
    if starts.shape != (len(rows), 3) or not np.isfinite(starts).all():
        raise ConfigError("curve.start", "expected finite [X, Y, angle] (one, or one per track), "
                          f"got {np.asarray(start).tolist()!r}")
    blocks = []
    for k, (pieces_k, start_k) in enumerate(zip(rows, starts)):
        try:
            blocks.append(track_row(pieces_k, start_k))
        except ConfigError as error:
            if len(rows) == 1:
                raise
            raise ConfigError(error.where, f"track {k} (row {k}): {error.problem}") from None
    block = max(b.size for b in blocks)
    padded = np.zeros((len(blocks), block))
    for k, b in enumerate(blocks):
        padded[k, :b.size] = b
    return np.concatenate([[len(blocks), block], padded.ravel()])


def track_ends(shared: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Each row's track length (the end's s)."""
    starts = TRACK_HEADER + rows.astype(np.int64) * int(shared[1])
    n = shared[starts].astype(np.int64)
    return shared[starts + 1 + n]


def track_joints(shared: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(offset, count) of each row's joints in ``shared``: the kernel's JOINT
    and JOINT2 inputs with MANY_JOINTS."""
    starts = TRACK_HEADER + rows.astype(np.int64) * int(shared[1])
    return (starts + 2).astype(np.float64), shared[starts] - 1.0


def loop_track_pieces(radius: float, in_run_slope: float = 0.0, run_length: float = 1.0,
                      blend_length: float = 0.0,
                      out_run_length: float | None = None) -> tuple[list, tuple]:
    """``(pieces, start)`` of a loop-the-loop whose straight in-run descends
    at ``in_run_slope`` (rad, >= 0) into the circle of ``radius``, tangent
    to it; the circle turns by 2 pi + in_run_slope to its bottom and the flat
    out-run (``out_run_length``, default ``run_length``) leaves there.  The
    start is placed so that the circle's bottom is at Y = 0 without blends
    (its height there: run_length sin(slope) + radius (1 - cos(slope))).  ``blend_length`` > 0: clothoid blends of that
    length at both ends of the circle (curvature continuous, 4 joints);
    0: the curvature jumps at both (2 joints)."""
    for name, value, positive in (("radius", radius, True), ("in_run_slope", in_run_slope, False),
                                  ("run_length", run_length, True),
                                  ("blend_length", blend_length, False)):
        if not (math.isfinite(value) and (value > 0 if positive else value >= 0)):
            raise ConfigError(f"curve.{name}", f"must be {'> 0' if positive else '>= 0'}, got {value!r}")
    if not in_run_slope < 0.5 * math.pi:
        raise ConfigError("curve.in_run_slope", f"must be < pi/2 (a descending in-run), got "
                          f"{in_run_slope!r}")
    turn = 2.0 * math.pi + in_run_slope
    if not blend_length < radius * turn:
        raise ConfigError("curve.blend_length", f"must be < radius (2 pi + in_run_slope) = "
                          f"{radius * turn!r} (the circle between the blends), got {blend_length!r}")
    out = run_length if out_run_length is None else out_run_length
    kappa = 1.0 / radius
    middle = ([[blend_length, 0.0, kappa], [radius * turn - blend_length, kappa, kappa],
               [blend_length, kappa, 0.0]] if blend_length > 0 else [[radius * turn, kappa, kappa]])
    height = run_length * math.sin(in_run_slope) + radius * (1.0 - math.cos(in_run_slope))
    return [[run_length, 0.0, 0.0]] + middle + [[out, 0.0, 0.0]], (0.0, height, -in_run_slope)
