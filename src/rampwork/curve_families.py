"""Curve families: their named parameters, side, domain, joints and checks (docs/physics.md §5).

:mod:`rampwork.curves` re-exports everything here (``FAMILIES``,
``CurveFamily``); the jitted frame and point of each family are in
:mod:`rampwork.core.curves`.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from .core import curve_track as core_track, curves as core_curves
from .errors import ConfigError
from .ramps import ParameterSpec

TWO_PI = 2.0 * math.pi
#: the sides a block can be on: the one the left normal N points to, or the other
SIDES = {"left": 1.0, "right": -1.0}
CONTACTS = ("one_sided", "two_sided")
#: joints per curve of a family's ``joint`` (core/curve_kernel.py: JOINT,
#: JOINT2); more take the kernel's MANY_JOINTS mode (the family ``track``)
MAX_JOINTS = 2


def _p(name, units, long_name, constraint="finite", default=None):
    return ParameterSpec(name, units, long_name, constraint, default)


class CurveFamily:
    """A curve shape: its parameters, jitted frame and point, the domain of
    its position parameter and the checks of its values."""

    def __init__(self, name, description, parameters, frame, point, domain, *, side="left",
                 position="s", check=None, key=None, cacheable=True, joint=None,
                 point_anywhere=False):
        self.name = name
        self.description = description
        self.parameters = tuple(parameters)
        self.frame = frame
        self.point = point
        self._domain = domain  # (arrays by name) -> (p_lo, p_hi) arrays
        self.side = side
        self.position = position  # what p is: "s" (arc length) or "x"
        self._check = check
        self._joint = joint  # (arrays by name) -> the joint's p (NaN: none), or None
        self.key = key or name
        self.cacheable = cacheable
        #: the point is loop-free and defined at every p, NaN included, so the
        #: lane kernel may evaluate it where its frame is (core/curve_vector.py)
        self.point_anywhere = point_anywhere
        self._evaluator = None

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    def arrays(self, values: Mapping) -> dict[str, np.ndarray]:
        """The parameters as float arrays, each checked (names the parameter,
        the value and what is allowed)."""
        unknown = [k for k in values if k not in self.parameter_names]
        if unknown:
            raise ConfigError(f"curve.{unknown[0]}", f"unknown parameter for curve family "
                              f"{self.name!r}; allowed: {', '.join(self.parameter_names) or '(none)'}")
        arrays = {}
        for spec in self.parameters:
            where = f"curve.{spec.name}"
            if spec.name in values:
                array = np.atleast_1d(np.asarray(values[spec.name]))
                if array.dtype.kind not in "iuf":
                    raise ConfigError(where, f"expected numbers, got {values[spec.name]!r}")
                array = array.astype(np.float64)
            elif spec.default is not None:
                array = np.array([spec.default])
            else:
                raise ConfigError(where, f"required by curve family {self.name!r} "
                                  f"({spec.long_name}, {spec.units})")
            bad = ~np.isfinite(array) | ((array <= 0) if spec.constraint == "positive" else False)
            if bad.any():
                allowed = "a number > 0" if spec.constraint == "positive" else "a finite number"
                raise ConfigError(where, f"must be {allowed}, got {float(array[bad][0])!r}")
            arrays[spec.name] = array
        if self._check is not None:
            self._check(arrays)
        return arrays

    def joint(self, arrays) -> np.ndarray | None:
        """Where the curvature jumps (steps end there): rows of joints (at most
        ``MAX_JOINTS``, in increasing ``p``), NaN where there is none; None
        for a family without joints."""
        if self._joint is None:
            return None
        joints = np.atleast_2d(np.asarray(self._joint(arrays), dtype=np.float64))
        assert joints.shape[0] <= MAX_JOINTS
        return joints

    def domain(self, arrays) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = self._domain(arrays)
        return np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)


def _check_loop(a):
    entry, exit_ = a["entry_angle"], a["exit_angle"]
    entry, exit_ = np.broadcast_arrays(entry, exit_)
    bad = ~(exit_ > entry)
    if bad.any():
        raise ConfigError("curve.exit_angle", f"must be > entry_angle, got exit_angle "
                          f"{float(exit_[bad][0])!r} and entry_angle {float(entry[bad][0])!r}")
    bad = exit_ - entry > TWO_PI * (1 + 1e-15)
    if bad.any():
        raise ConfigError("curve.exit_angle", "the arc may turn at most once (exit_angle - "
                          f"entry_angle <= 2 pi, a longer arc crosses itself), got "
                          f"{float(exit_[bad][0] - entry[bad][0])!r} rad")


def _check_quarter_pipe(a):
    bad = a["flat_length"] < 0
    if bad.any():
        raise ConfigError("curve.flat_length", f"must be >= 0, got {float(a['flat_length'][bad][0])!r}")


def _check_brachistochrone(a):
    t_end = a["end_angle"]
    bad = ~((t_end > 0) & (t_end <= TWO_PI))
    if bad.any():
        raise ConfigError("curve.end_angle", "the rolling circle's angle at the end must be in "
                          f"(0, 2 pi] (pi: the bottom; 2 pi: the next cusp), got {float(t_end[bad][0])!r}")


def _check_clothoid(a):
    length, parameter = np.broadcast_arrays(a["length"], a["clothoid_parameter"])
    turning = np.abs(a["curvature_start"]) * length + 0.5 * length ** 2 / parameter ** 2
    bad = turning > 2 * TWO_PI
    if bad.any():
        raise ConfigError("curve.length", "the clothoid may turn by at most 4 pi (|curvature_start| "
                          f"length + length^2 / (2 A^2)), got {float(turning[bad][0])!r} rad")


def _check_loop_track(a):
    radius, blend = np.broadcast_arrays(a["radius"], a["blend_length"])
    bad = blend < 0
    if bad.any():
        raise ConfigError("curve.blend_length", f"must be >= 0 (0: no blend, the curvature "
                          f"jumps at both ends of the circle), got {float(blend[bad][0])!r}")
    bad = blend >= TWO_PI * radius
    if bad.any():
        raise ConfigError("curve.blend_length", "the blends are too long for the loop: "
                          "blend_length must be < 2 pi radius (the circle between them keeps "
                          f"2 pi radius - blend_length), got {float(blend[bad][0])!r} for radius "
                          f"{float(radius[bad][0])!r}")
    bad = a["run_length"] < 0
    if bad.any():
        raise ConfigError("curve.run_length", f"must be >= 0, got {float(a['run_length'][bad][0])!r}")


def _loop_track_joints(a):
    """Without a blend, the circle's ends s = L and L + 2 pi R; NaN with one."""
    bare = a["blend_length"] + 0 * a["radius"] + 0 * a["run_length"] == 0.0
    start = np.where(bare, a["run_length"] + 0 * a["radius"], np.nan)
    return np.stack(np.broadcast_arrays(start, start + TWO_PI * a["radius"]))


FAMILIES: dict[str, CurveFamily] = {
    "loop": CurveFamily(
        "loop", "circle of radius R, centre (0, R): s = R theta, theta the angle from the "
        "bottom, counter-clockwise; the block inside (side left)",
        (_p("radius", "m", "radius of the loop", "positive"),
         _p("entry_angle", "rad", "angle from the bottom where the arc starts", default=0.0),
         _p("exit_angle", "rad", "angle from the bottom where the arc ends", default=TWO_PI)),
        core_curves.loop_frame, core_curves.loop_point,
        lambda a: (a["radius"] * a["entry_angle"], a["radius"] * a["exit_angle"]),
        check=_check_loop, point_anywhere=True),
    "quarter_pipe": CurveFamily(
        "quarter_pipe", "a flat of length L from the origin, then a quarter circle of radius R "
        "curving up to a vertical tangent (curvature jumps from 0 to 1/R at s = L)",
        (_p("radius", "m", "radius of the quarter circle", "positive"),
         _p("flat_length", "m", "length of the flat before it", default=0.0)),
        core_curves.quarter_pipe_frame, core_curves.quarter_pipe_point,
        lambda a: (np.zeros_like(a["radius"] + a["flat_length"]),
                   a["flat_length"] + 0.5 * math.pi * a["radius"]),
        check=_check_quarter_pipe, point_anywhere=True,
        joint=lambda a: a["flat_length"] + 0 * a["radius"]),  # at 0 too: a start there
    "brachistochrone": CurveFamily(
        "brachistochrone", "cycloid from its cusp at the origin: X = r (t - sin t), "
        "Y = -r (1 - cos t), t in [0, end_angle]; s = 4 r (1 - cos(t/2)), vertical at the cusp",
        (_p("radius", "m", "radius of the rolling circle", "positive"),
         _p("end_angle", "rad", "rolling angle at the end (pi: the bottom)", default=math.pi)),
        core_curves.cycloid_cusp_frame, core_curves.cycloid_cusp_point,
        lambda a: (np.zeros_like(a["radius"] + a["end_angle"]),
                   4.0 * a["radius"] * (1.0 - np.cos(0.5 * a["end_angle"]))),
        check=_check_brachistochrone),
    "clothoid": CurveFamily(
        "clothoid", "Euler spiral from the origin: curvature kappa = curvature_start + s / A^2, "
        "tangent angle phi = start_angle + curvature_start s + s^2 / (2 A^2), s in [0, length]",
        (_p("clothoid_parameter", "m", "clothoid parameter A (kappa grows by 1/A^2 per metre)",
            "positive"),
         _p("length", "m", "arc length of the spiral", "positive"),
         _p("curvature_start", "m-1", "curvature at the start", default=0.0),
         _p("start_angle", "rad", "tangent angle at the start, from the horizontal", default=0.0)),
        core_curves.clothoid_frame, core_curves.clothoid_point,
        lambda a: (np.zeros_like(a["length"] + a["clothoid_parameter"]),
                   a["length"] + 0 * a["clothoid_parameter"]),
        check=_check_clothoid),
    "loop_track": CurveFamily(
        "loop_track", "loop-the-loop: a flat in-run of length run_length from the origin, a "
        "clothoid blend of length blend_length (curvature 0 to 1/R), a circle of radius R "
        "(arc 2 pi R - blend_length), the mirrored blend and a flat out-run of length "
        "run_length; curvature continuous, the block inside (side left); the blends cross "
        "at the loop's foot (a track crossing itself, allowed here); blend_length = 0: no "
        "blend, the curvature jumps at both ends of the circle (two joints)",
        (_p("radius", "m", "radius of the loop's circle", "positive"),
         _p("blend_length", "m", "arc length of each clothoid blend (0: none)"),
         _p("run_length", "m", "length of the flat in-run and of the out-run", default=1.0)),
        core_curves.loop_track_frame, core_curves.loop_track_point,
        lambda a: (np.zeros_like(a["radius"] + a["blend_length"] + a["run_length"]),
                   2.0 * a["run_length"] + a["blend_length"] + TWO_PI * a["radius"]),
        check=_check_loop_track, joint=_loop_track_joints),
}


# ---------------------------------------------------------------------------
# the parametric spline through points: its data (points, end conditions)
# is shared by all trajectories; it has no swept parameter.

SPLINE_ENDS = ("natural", "clamped")
#: samples per piece for the regularity and crossing checks
SPLINE_SAMPLES = 32
#: the least |r'| allowed: the chord-length parameter's |r'| is near 1, and
#: below this the spline is a hairpin, its curvature ~ 1 / |r'|^2 (a cusp)
SPLINE_MIN_SPEED = 1e-3

SPLINE_FAMILY = CurveFamily(
    "spline", "parametric C2 cubic spline through points (X_k, Y_k) in the chord-length "
    "parameter t (t_{k+1} = t_k + |P_{k+1} - P_k|); dp/ds = 1 / |r'(t)|; a population of "
    "splines, one per row of the points, shares one array (row: which)",
    (_p("row", "1", "row of the points: which spline of the population", default=0.0),),
    core_curves.spline_curve_frame, core_curves.spline_curve_point, None, position="t")

TRACK_FAMILY = CurveFamily(
    "track", "a chain of pieces (straights, circular arcs, clothoids: curvature linear in s "
    "on each) from a start point and angle, a joint at every piece's start but the first; "
    "a population of tracks, one per row, shares one array (row: which)",
    (_p("row", "1", "row of the pieces: which track of the population", default=0.0),),
    core_track.track_frame, core_track.track_point, None)


def spline_rows(x_points, y_points) -> tuple[np.ndarray, np.ndarray]:
    """The points as (rows, n) arrays: each of ``x_points``, ``y_points`` one
    row of n values (shared by every spline) or one row per spline."""
    arrays = []
    for where, values in (("curve.x_points", x_points), ("curve.y_points", y_points)):
        try:
            array = np.asarray(values, dtype=np.float64)
        except (TypeError, ValueError):
            raise ConfigError(where, "expected numbers: a list, or a list of equally long lists "
                              "(one per spline)") from None
        if array.ndim not in (1, 2) or array.size == 0:
            raise ConfigError(where, "expected a list of numbers, or a list of equally long "
                              f"lists of them (one per spline), got shape {array.shape}")
        arrays.append(np.atleast_2d(array))
    x, y = arrays
    if x.shape[1] != y.shape[1] or (x.shape[0] != y.shape[0] and 1 not in (x.shape[0], y.shape[0])):
        raise ConfigError("curve.y_points", f"as many points as x_points (and one row, or as many "
                          f"rows), got shapes {x.shape} and {y.shape}")
    rows = max(x.shape[0], y.shape[0])
    return np.broadcast_to(x, (rows, x.shape[1])), np.broadcast_to(y, (rows, y.shape[1]))


def spline_population(x_points, y_points, end="natural", end_tangents=None,
                      allow_crossing=False) -> np.ndarray:
    """The ``shared`` data of the splines through each row of the points
    (:func:`spline_rows`; layout in :mod:`rampwork.core.curves`), each row
    checked by :func:`spline_shared`; an error names the spline's row."""
    x, y = spline_rows(x_points, y_points)
    blocks = []
    for k in range(x.shape[0]):
        try:
            blocks.append(spline_shared(x[k], y[k], end, end_tangents, allow_crossing))
        except ConfigError as error:
            if x.shape[0] == 1:
                raise
            raise ConfigError(error.where, f"spline {k} (row {k} of the points): "
                              f"{error.problem}") from None
    return np.concatenate([[len(blocks), len(blocks[0])], np.concatenate(blocks)])


def spline_ends(shared: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The last knot t_{n-1} (the end's p) of the spline of each row."""
    block = int(shared[1])
    n = int(shared[2])
    return shared[2 + rows.astype(np.int64) * block + 1 + n]


def check_spline_row(shared: np.ndarray, rows: np.ndarray, what: str = "splines") -> None:
    """Every ``row`` names a spline (or track: ``what``) of the population."""
    count = int(shared[0])
    bad = ~((rows >= 0) & (rows < count) & (rows == np.round(rows)))
    if bad.any():
        raise ConfigError("curve.row", f"must be an integer in [0, {count}) (the {what}' rows), "
                          f"got {float(rows[bad][0])!r}")


def spline_shared(x_points, y_points, end="natural", end_tangents=None,
                  allow_crossing=False) -> tuple[float, ...]:
    """Check the points and build the spline's ``shared`` data (layout in
    :mod:`rampwork.core.curves`).  ``end``: ``natural`` (r'' = 0 at both ends)
    or ``clamped`` (``end_tangents``: the directions at the first and last
    point, scaled to unit length, |r'| of the chord-length parameter).

    Checks: at least 3 finite points, no two equal; the parametrisation
    regular (|r'| >= SPLINE_MIN_SPEED at SPLINE_SAMPLES + 1 points of every piece and at
    the minima of the quartic |r'|^2 on it); without ``allow_crossing``, no
    two non-adjacent pieces cross (their polylines of SPLINE_SAMPLES chords)."""
    from scipy.interpolate import CubicSpline

    points = []
    for where, values in (("curve.x_points", x_points), ("curve.y_points", y_points)):
        array = np.asarray(values, dtype=np.float64).ravel()
        if not np.isfinite(array).all():
            raise ConfigError(where, "must be finite numbers")
        points.append(array)
    x, y = points
    if x.size < 3 or y.size != x.size:
        raise ConfigError("curve.x_points", f"needs at least 3 points and as many y_points, got "
                          f"{x.size} and {y.size}")
    pairs = np.stack([x, y], axis=1)
    _, first = np.unique(pairs, axis=0, return_index=True)
    if first.size != x.size:
        dup = sorted(set(range(x.size)) - set(first.tolist()))[0]
        raise ConfigError("curve.x_points", f"the points must be distinct: point {dup} "
                          f"({x[dup]!r}, {y[dup]!r}) repeats an earlier one")
    t = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    if end not in SPLINE_ENDS:
        raise ConfigError("curve.end", f"must be one of {', '.join(SPLINE_ENDS)}, got {end!r}")
    if end == "clamped":
        tangents = np.asarray(end_tangents, dtype=np.float64) if end_tangents is not None else None
        if tangents is None or tangents.shape != (2, 2) or not np.isfinite(tangents).all() or \
                (np.hypot(*tangents.T) == 0).any():
            raise ConfigError("curve.end_tangents", "clamped ends need two nonzero tangent "
                              f"directions ((dX0, dY0), (dX1, dY1)), got {end_tangents!r}")
        tangents = tangents / np.hypot(*tangents.T)[:, None]
        bc = ((1, tangents[0]), (1, tangents[1]))
    else:
        bc = "natural"
    spline = CubicSpline(t, pairs, bc_type=bc)
    coefficients = spline.c  # (4, pieces, 2): power form in t - t_k
    _check_spline_regular(coefficients, np.diff(t))
    if not allow_crossing:
        _check_spline_crossing(spline, t)
    steps = max(1, int(math.ceil(math.log2(x.size - 1))))
    while (1 << steps) < x.size - 1:
        steps += 1
    return tuple(float(v) for v in np.concatenate(
        [[x.size, steps], t, coefficients[:, :, 0].T.ravel(), coefficients[:, :, 1].T.ravel()]))


def _check_spline_regular(c, widths):
    for k, width in enumerate(widths):
        dx = np.poly1d([3 * c[0, k, 0], 2 * c[1, k, 0], c[2, k, 0]])
        dy = np.poly1d([3 * c[0, k, 1], 2 * c[1, k, 1], c[2, k, 1]])
        speed2 = dx * dx + dy * dy
        stationary = [r.real for r in speed2.deriv().roots if abs(r.imag) < 1e-12 and 0 <= r.real <= width]
        where = np.concatenate([np.linspace(0.0, width, SPLINE_SAMPLES + 1), stationary])
        if not (speed2(where) >= SPLINE_MIN_SPEED ** 2).all():
            raise ConfigError("curve.x_points", f"the spline is not regular (|r'| < {SPLINE_MIN_SPEED}: a hairpin) on the piece "
                              f"between points {k} and {k + 1}: space the points more evenly")


def _segments_cross(a0, a1, b0, b1):
    """Which chords a0-a1 cross which b0-b1 (proper crossings; arrays of points)."""
    def orient(p, q, r):
        return np.sign((q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1])
                       - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0]))
    a0, a1 = a0[:, None], a1[:, None]
    b0, b1 = b0[None], b1[None]
    return ((orient(a0, a1, b0) * orient(a0, a1, b1) < 0)
            & (orient(b0, b1, a0) * orient(b0, b1, a1) < 0))


def _check_spline_crossing(spline, t):
    pieces = t.size - 1
    samples = np.concatenate([np.linspace(t[k], t[k + 1], SPLINE_SAMPLES, endpoint=False)
                              for k in range(pieces)] + [t[-1:]])
    poly = spline(samples)
    piece = np.repeat(np.arange(pieces), SPLINE_SAMPLES)
    cross = _segments_cross(poly[:-1], poly[1:], poly[:-1], poly[1:])
    cross &= np.abs(piece[:, None] - piece[None, :]) > 1  # adjacent pieces share an end
    if cross.any():
        i, j = np.argwhere(cross)[0]
        raise ConfigError("curve.x_points", f"the spline crosses itself (pieces {piece[i]} and "
                          f"{piece[j]}); pass allow_crossing=True where a crossing is meant")


# ---------------------------------------------------------------------------
# the convex cusp (core/curves.py): a population of convex curves from a
# vertical start, rho(phi) = cos(phi) exp(sum c_k T_k(t)), one row of
# ``shared`` each; the swept parameters pick the row and give its end angle.

#: Chebyshev terms of X(t) and Y(t): their integrands are entire (sin, cos and
#: exp of polynomials); tests/test_cusp_curve.py checks 1e-15 against quad
CUSP_TERMS = 64
_NODES = np.cos(math.pi * (np.arange(CUSP_TERMS) + 0.5) / CUSP_TERMS)
#: values at _NODES -> Chebyshev coefficients of the antiderivative from t = -1
_ANTIDERIVATIVE = np.stack([np.polynomial.chebyshev.chebint(column, lbnd=-1.0) for column in
                            np.linalg.inv(np.polynomial.chebyshev.chebvander(
                                _NODES, CUSP_TERMS - 1)).T], axis=1)
#: values at _NODES -> the integral over t in [-1, 1] (T_k(1) = 1)
_END_WEIGHTS = _ANTIDERIVATIVE.sum(axis=0)


def contract(values, weights):
    """sum_j values[..., j] weights[..., j] (weights (n,) or (m, n): then
    (..., m)), in a fixed order: a candidate's numbers do not depend on the
    population it is part of (a BLAS product may round rows differently by
    where they fall in its blocks)."""
    weights = np.asarray(weights)
    extra = (None,) if weights.ndim == 2 else ()
    out = 0.0
    for j in range(values.shape[-1]):
        out = out + values[(..., j) + extra] * weights[..., j]
    return out


def _check_convex_cusp(a):
    angle = a["end_angle"]
    bad = ~((angle > -0.5 * math.pi) & (angle < 0.5 * math.pi))
    if bad.any():
        raise ConfigError("curve.end_angle", "the tangent angle at the end must be in (-pi/2, "
                          f"pi/2) (the curve turns from straight down towards up), got "
                          f"{float(angle[bad][0])!r}")


CONVEX_CUSP_FAMILY = CurveFamily(
    "convex_cusp", "a convex curve from a vertical start at the origin (a cusp): radius of "
    "curvature ds/dphi = cos(phi) exp(sum c_k T_k(t)), t = 2 (phi + pi/2) / (end_angle + pi/2) "
    "- 1, one curve per row of the shared data (rampwork.curve_families.convex_cusp_shared); "
    "p = 1 + sin(phi)",
    (_p("row", "1", "row of the shared data: which curve of the population"),
     _p("end_angle", "rad", "tangent angle at the end (the row's; > 0: climbing)")),
    core_curves.convex_cusp_frame, core_curves.convex_cusp_point,
    lambda a: (np.zeros_like(a["row"] + a["end_angle"]), 1.0 + np.sin(a["end_angle"]) + 0 * a["row"]),
    position="1 + sin(phi)", check=_check_convex_cusp)


def _convex_cusp_inputs(coefficients, end_angles):
    c = np.atleast_2d(np.asarray(coefficients, dtype=np.float64))
    angles = np.broadcast_to(np.asarray(end_angles, dtype=np.float64), (c.shape[0],))
    if c.ndim != 2 or not (np.isfinite(c).all() and np.isfinite(angles).all()):
        raise ConfigError("curve.coefficients", "expected finite numbers, one row per curve")
    _check_convex_cusp({"end_angle": angles})
    return c, angles


def convex_cusp_rates(coefficients, end_angles):
    """(dX/dt, dY/dt, ds/dt) at the quadrature nodes, each (rows, CUSP_TERMS)."""
    c, angles = _convex_cusp_inputs(coefficients, end_angles)
    half = 0.5 * (angles + 0.5 * math.pi)[:, None]  # dtheta/dt
    theta = half * (_NODES + 1.0)
    ds_dt = half * np.sin(theta) * np.exp(np.polynomial.chebyshev.chebval(_NODES, c.T))
    return ds_dt * np.sin(theta), -ds_dt * np.cos(theta), ds_dt


def convex_cusp_end(coefficients, end_angles) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(X, Y, arc length) at the end of each row's curve, by the quadrature
    that :func:`convex_cusp_shared` stores (so the kernel's point at the end
    agrees to rounding)."""
    return tuple(contract(rate, _END_WEIGHTS) for rate in convex_cusp_rates(coefficients, end_angles))


def convex_cusp_shared(coefficients, end_angles) -> np.ndarray:
    """The ``shared`` data of a population of convex cusps (layout in
    :mod:`rampwork.core.curves`): ``coefficients`` (rows, nc) of E,
    ``end_angles`` (rows,) their tangent angles at the end (rad)."""
    c, angles = _convex_cusp_inputs(coefficients, end_angles)
    dx, dy, _ = convex_cusp_rates(c, angles)
    block = np.hstack([(angles + 0.5 * math.pi)[:, None], c, contract(dx, _ANTIDERIVATIVE),
                       contract(dy, _ANTIDERIVATIVE)])
    return np.concatenate([[c.shape[0], c.shape[1], CUSP_TERMS + 1, block.shape[1]],
                           block.ravel()])
