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
TRACK_HEADER = curve_track.TRACK_HEADER
#: the most cells of the piece table per track (core/curve_track.py): the
#: shortest inner piece is at least 3 / MAX_CELLS of the longest track
MAX_CELLS = 1 << 16


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
    """One track's block of ``shared`` without its cells (layout:
    core/curve_track.py; :func:`track_population` adds them)."""
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
    x, y, phi[0] = start
    # panels: the tangent turns by at most PANEL_TURN over each (a straight: one)
    turn = lengths * (np.maximum(np.abs(k0), np.abs(k1)) + 0.5 * np.abs(c) * lengths)
    count = np.maximum(1.0, np.ceil(turn / curve_track.PANEL_TURN))
    width = lengths / count
    panels = []
    for k in range(n):  # each piece starts where the last one ends
        corners = np.arange(count[k]) * width[k]
        offsets = np.array([curve_track.piece_offset(corner, phi[k], k0[k], c[k])
                            for corner in corners]).reshape(-1, 2)
        angles = phi[k] + corners * (k0[k] + 0.5 * c[k] * corners)
        panels.append(np.stack([x + offsets[:, 0], y + offsets[:, 1], np.cos(angles),
                                np.sin(angles)], axis=1).ravel())
        dx, dy = curve_track.piece_offset(lengths[k], phi[k], k0[k], c[k])
        x, y = x + dx, y + dy
        if k + 1 < n:
            phi[k + 1] = phi[k] + lengths[k] * (k0[k] + 0.5 * c[k] * lengths[k])
    first = np.concatenate([[0.0], np.cumsum(count[:-1])]) * curve_track.PANEL_FIELDS
    return np.concatenate([[n], s, phi, k0, c, first, count, width, count / lengths,
                           np.concatenate(panels)])


def _cells(blocks) -> tuple[float, int, list]:
    """(1 / cell width, cells M, each row's cells): the width at most a third
    of the shortest inner piece of any track (two cells hold at most one
    joint), M cells cover the longest track."""
    gaps = np.concatenate([np.diff(b[2:int(b[0]) + 1]) for b in blocks] + [[math.inf]])
    longest = max(b[int(b[0]) + 1] for b in blocks)
    width = min(gaps.min(), longest) / 3.0
    cells = int(math.floor(longest / width)) + 2
    if cells > MAX_CELLS:
        raise ConfigError("curve.pieces", f"a piece is too short beside the longest track: "
                          f"the shortest inner piece ({gaps.min()!r} m) must be at least "
                          f"{3.0 * longest / MAX_CELLS!r} m (1/{MAX_CELLS // 3} of {longest!r} m)")
    tables = []
    for b in blocks:
        n = int(b[0])
        joints = b[2:n + 1]
        corners = (np.arange(cells) - 0.5) * width  # a cell's start less half a cell
        piece = np.searchsorted(joints, corners, side="right")
        after = np.append(joints, math.inf)[piece]
        tables.append(np.concatenate([piece.astype(np.float64), after]))
    return 1.0 / width, cells, tables


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
    inverse_width, cells, tables = _cells(blocks)
    for k, (b, table) in enumerate(zip(blocks, tables)):  # the cells before the panels
        n = int(b[0])
        head = 8 * n + 2
        b[4 * n + 2:5 * n + 2] += head + table.size  # the panels' offsets in the row
        blocks[k] = np.concatenate([b[:head], table, b[head:]])
    block = max(b.size for b in blocks)
    padded = np.zeros((len(blocks), block))
    for k, b in enumerate(blocks):
        padded[k, :b.size] = b
    return np.concatenate([[len(blocks), block, inverse_width, cells], padded.ravel()])


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
