"""Planar curves beyond y = f(x): families, validation and a direct run (docs/physics.md §5).

A :class:`Curve` is a family, its named shape parameters and the side the
block is on; ``Curve.from_ramp`` wraps any ramp ``y = f(x)`` as a curve
(position parameter x).  :func:`simulate_curve` runs trajectories on one
curve with a fixed-step method and returns plain arrays::

    >>> from rampwork.curves import Curve, simulate_curve
    >>> loop = Curve.create("loop", radius=1.0)
    >>> out = simulate_curve(loop, s0=0.0, u0=[6.0, 7.5], method="rk4", dt=1e-3)
    >>> out["status_name"]      # too slow: lifted_off; fast enough: exited
    array(['lifted_off', 'exited'], dtype='<U10')

Scene files (``[curve]``) and :func:`rampwork.simulate` take curves through
:mod:`rampwork.curve_scene`; DOP853 on curves is not there yet (docs/physics.md §5).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import validate
from .core import curve_kernel, curve_trace, curves as core_curves
from .core.jit import specialise
from .core.status import STATUS_NAMES
from .curve_kernels import GENERAL_MAX_CASES, curve_kernel_for, curve_tier  # noqa: F401 (public)
from .curve_families import (CONTACTS, CONVEX_CUSP_FAMILY, FAMILIES, SIDES,  # noqa: F401 (public)
                             SPLINE_FAMILY, TRACK_FAMILY, TWO_PI, CurveFamily, check_spline_row,
                             convex_cusp_shared, spline_ends, spline_population, spline_shared)
from .curve_tracks import (loop_track_pieces, track_ends, track_joints,  # noqa: F401 (public)
                           track_population)
from .spline_coordinates import coordinate_population, spline_family, split_coordinates
from .errors import ConfigError
from .ramps import Ramp

_GRAPH_FAMILIES: dict[str, CurveFamily] = {}


def _nested(array: np.ndarray) -> tuple:
    """A spline's points as given: a tuple of floats, or of rows of them."""
    if array.ndim > 1:
        return tuple(tuple(row.tolist()) for row in array)
    return tuple(array.ravel().tolist())


def _nested_pieces(pieces) -> tuple:
    """A track's pieces as given: rows of three floats, or a tuple of such per track."""
    array = np.asarray(pieces, dtype=object)
    if array.ndim == 2:
        return tuple(tuple(float(v) for v in piece) for piece in pieces)
    return tuple(_nested_pieces(track) for track in pieces)


def _graph_family(ramp: Ramp) -> CurveFamily:
    """The curve family of a ramp family y = f(x) (position parameter x)."""
    spec = ramp.spec
    key = f"graph_{spec.key}"
    if key not in _GRAPH_FAMILIES or not spec.cacheable:
        options = {} if spec.cacheable else {"cache": False}
        constants = {"ramp_slope_curvature": spec.slope_curvature, "ramp_height": spec.height}
        frame = specialise(core_curves.graph_frame, f"curve_{key}_frame", constants, **options)
        point = specialise(core_curves.graph_point, f"curve_{key}_point", constants, **options)
        family = CurveFamily(key, f"the ramp family {spec.name!r} as a curve (p = x)",
                             spec.parameters, frame, point, None, position="x", key=key,
                             cacheable=spec.cacheable, point_anywhere=True)  # X = p
        if not spec.cacheable:
            return family
        _GRAPH_FAMILIES[key] = family
    return _GRAPH_FAMILIES[key]


@dataclass(frozen=True)
class Curve:
    """One curve: a family, its parameters (defaults applied), the side the
    block is on (``"left"``: the side the left normal points to, the family's
    default; ``"right"``: the other), for a wrapped ramp, the ramp, and for
    a spline through points, its ``shared`` data (:meth:`through_points`)."""

    family: str
    params: tuple[tuple[str, float], ...]
    side: str = "left"
    ramp: Ramp | None = field(default=None, repr=False)
    data: tuple[float, ...] | None = field(default=None, repr=False)
    #: a spline's definition as given (x_points, y_points, end, end_tangents,
    #: allow_crossing): what a scene file writes, and reads back to the same data
    points: tuple | None = field(default=None, repr=False)

    @classmethod
    def create(cls, family: str, side: str | None = None, **params) -> "Curve":
        if not isinstance(family, str) or family not in FAMILIES:
            raise ConfigError("curve.family", f"unknown curve family {family!r}; allowed: "
                              f"{', '.join(map(repr, FAMILIES))} (and a ramp via Curve.from_ramp)")
        spec = FAMILIES[family]
        arrays = spec.arrays(params)
        for name, array in arrays.items():
            if array.size != 1:
                raise ConfigError(f"curve.{name}", "one value here; sweep it through "
                                  "simulate_curve's keyword arguments")
        side = spec.side if side is None else validate.choice("curve.side", side, tuple(SIDES))
        return cls(family, tuple((name, float(a[0])) for name, a in arrays.items()), side)

    @classmethod
    def from_ramp(cls, ramp: Ramp) -> "Curve":
        """A ramp y = f(x) as a curve: X = x, Y = f(x), the block on top."""
        if not isinstance(ramp, Ramp):
            raise ConfigError("curve", f"expected a rampwork.Ramp, got {type(ramp).__name__}")
        return cls(f"graph_{ramp.spec.key}", ramp.params, "left", ramp)

    @classmethod
    def through_points(cls, x_points, y_points, *, end: str = "natural", end_tangents=None,
                       side: str = "left", allow_crossing: bool = False, row: int = 0) -> "Curve":
        """The C2 cubic spline through the points (X_k, Y_k), in the
        chord-length parameter t (``s0`` is a t): ``end`` ``natural`` or
        ``clamped`` (``end_tangents``: the directions at both ends).  A
        population: ``x_points`` and/or ``y_points`` given as one row per
        spline (lists of equally many points; a single row is shared), one
        kernel call for all; this curve is spline ``row``, and a sweep over
        ``row`` (simulate_curve's keyword, a scene's sweep axis) runs them
        all.  Each spline is checked by
        :func:`rampwork.curve_families.spline_shared`; an error names its row."""
        data = spline_population(x_points, y_points, end, end_tangents, allow_crossing)
        side = validate.choice("curve.side", side, tuple(SIDES))
        tangents = (None if end_tangents is None else
                    tuple(tuple(float(v) for v in pair) for pair in np.asarray(end_tangents, dtype=np.float64)))
        points = tuple(_nested(np.asarray(values, dtype=np.float64)) for values in (x_points, y_points))
        params = SPLINE_FAMILY.arrays({"row": row})
        check_spline_row(data, params["row"])
        return cls("spline", (("row", float(params["row"][0])),), side, None, tuple(data.tolist()),
                   points + (end, tangents if end == "clamped" else None, bool(allow_crossing)))

    @classmethod
    def track(cls, pieces, *, start=(0.0, 0.0, 0.0), side: str = "left", row: int = 0) -> "Curve":
        """A chain of pieces ``[length, curvature_start, curvature_end]``
        (curvature linear in arc length on each: straights, circular arcs,
        clothoids) from ``start = (X, Y, angle)``, with a joint (an exact
        event: no step crosses it) at every piece's start but the first, any
        number of them (family ``track``, rampwork.curve_tracks).  A
        population: ``pieces`` one list per track (their counts may differ)
        and ``start`` one or one per track; this curve is track ``row``, and
        a sweep over ``row`` runs them all."""
        data = track_population(pieces, start)
        side = validate.choice("curve.side", side, tuple(SIDES))
        params = TRACK_FAMILY.arrays({"row": row})
        check_spline_row(data, params["row"], "tracks")
        nested = _nested_pieces(pieces)
        start = np.asarray(start, dtype=np.float64)
        return cls("track", (("row", float(params["row"][0])),), side, None, tuple(data.tolist()),
                   (nested, _nested(start)))

    @classmethod
    def convex_cusp(cls, coefficients, end_angles, *, row: int = 0) -> "Curve":
        """Convex curves from a vertical start at the origin (family
        ``convex_cusp``, docs/physics.md §5.2): radius of curvature
        ``ds/dphi = cos(phi) exp(sum c_k T_k(t))``, ``t`` mapping the tangent
        angle from -pi/2 to the end angle onto [-1, 1]; one curve per row of
        ``coefficients`` (rows, nc) and ``end_angles`` (rows,).  This one is
        ``row``; sweep ``row`` and ``end_angle`` together through
        :func:`simulate_curve`.  The position parameter is ``p = 1 + sin(phi)``."""
        data = convex_cusp_shared(coefficients, end_angles)
        rows = int(data[0])
        if isinstance(row, bool) or not isinstance(row, (int, np.integer)) or not 0 <= row < rows:
            raise ConfigError("curve.row", f"must be an integer in [0, {rows}), got {row!r}")
        angles = np.broadcast_to(np.asarray(end_angles, dtype=np.float64), (rows,))
        params = CONVEX_CUSP_FAMILY.arrays({"row": row, "end_angle": angles[row]})
        return cls("convex_cusp", tuple((k, float(v[0])) for k, v in params.items()), "left",
                   None, tuple(data.tolist()))

    @property
    def spec(self) -> CurveFamily:
        if self.family == "convex_cusp":
            return CONVEX_CUSP_FAMILY
        if self.family == "track":
            return TRACK_FAMILY
        if self.data is not None:  # a spline: its points' coordinates are parameters too
            return spline_family(self.data_points)
        return _graph_family(self.ramp) if self.ramp is not None else FAMILIES[self.family]

    @property
    def data_points(self) -> int:
        """A spline's number of points."""
        return int(self.data[2])

    def _shared(self) -> np.ndarray:
        if self.data is not None:
            return np.asarray(self.data, dtype=np.float64)
        return self.ramp.shared_array() if self.ramp is not None else np.zeros(1)

    def domain(self, **overrides) -> tuple[np.ndarray, np.ndarray]:
        """(p_lo, p_hi) of the position parameter."""
        if self.ramp is not None:
            return np.array([self.ramp.domain[0]]), np.array([self.ramp.domain[1]])
        if self.family == "spline":
            rows = SPLINE_FAMILY.arrays({**dict(self.params), **overrides})["row"]
            check_spline_row(np.asarray(self.data), rows)
            return np.zeros_like(rows), spline_ends(np.asarray(self.data), rows)
        if self.family == "track":
            rows = TRACK_FAMILY.arrays({**dict(self.params), **overrides})["row"]
            check_spline_row(np.asarray(self.data), rows, "tracks")
            return np.zeros_like(rows), track_ends(np.asarray(self.data), rows)
        return self.spec.domain(self.spec.arrays({**dict(self.params), **overrides}))

    def evaluate(self, p) -> dict[str, np.ndarray]:
        """sin_phi, cos_phi, kappa, dp_ds, X, Y at the positions ``p``, by the
        kernel's own functions."""
        spec = self.spec
        if spec._evaluator is None:
            spec._evaluator = specialise(
                core_curves.evaluate_template, f"curve_evaluate_{spec.key}",
                {"curve_frame": spec.frame, "curve_point": spec.point},
                **({} if spec.cacheable else {"cache": False}))
        p = np.ascontiguousarray(np.atleast_1d(np.asarray(p, dtype=np.float64)).ravel())
        packed = [np.full(p.size, v) for _, v in self.params] + [np.zeros(p.size)] * (4 - len(self.params))
        out = np.empty((6, p.size))
        spec._evaluator(p, *packed, self._shared(), out)
        return dict(zip(("sin_phi", "cos_phi", "kappa", "dp_ds", "X", "Y"), out))


def simulate_curve(curve: Curve, *, s0, u0=0.0, mu_k=0.0, mu_s=None, g=9.81, m=1.0,
                   method: str = "rk4", dt: float = 1e-3, t_max: float = 10.0,
                   rtol: float = 1e-6, atol: float | None = None,
                   contact: str = "one_sided", drag_linear=0.0, drag_quadratic=0.0,
                   kernel: str | None = None, **shape) -> dict[str, np.ndarray]:
    """Trajectories on ``curve``: every argument given as an array is swept
    (the arrays broadcast together, as do shape parameters given by name).

    ``s0``: the start's position parameter (the arc length for the curve
    families; x for a wrapped ramp); ``u0``: the signed speed along the
    curve (> 0: towards larger s).  ``mu_s`` defaults to ``mu_k``.
    ``method``: ``euler``, ``semi_implicit_euler``, ``rk4`` (steps of
    ``dt``), ``dopri5`` or ``dop853`` (its first step ``dt``, then a local error of p, u
    and the friction work below ``atol + rtol |value|``; ``atol`` defaults
    to ``rtol``).  ``kernel``: ``"auto"`` (default), ``"general"`` or
    ``"specialised"`` (:func:`curve_tier`; equal results).  Returns
    arrays of the broadcast shape: ``status`` (codes of
    ``rampwork.STATUS_TABLE``), ``status_name`` and
    ``curve_kernel.OUTPUTS`` (``p_end``: the end's position parameter;
    ``nu_min``: the smallest normal force on the block's side along the way,
    in N; ``curvature_mean``: ∫ kappa |ds| / ∫ |ds|; ``path_length_X``:
    ∫ |dX|, exact to rounding from the curve's points)."""
    return prepare_curve_run(curve, s0=s0, u0=u0, mu_k=mu_k, mu_s=mu_s, g=g, m=m, method=method,
                             dt=dt, t_max=t_max, rtol=rtol, atol=atol, contact=contact,
                             drag_linear=drag_linear, drag_quadratic=drag_quadratic,
                             kernel=kernel, **shape).run()


@dataclass
class CurveRun:
    """A checked curve run, ready: its compiled kernel and packed inputs.
    :meth:`compile` builds (or loads) the kernel apart from :meth:`run`."""

    kernel: object
    inputs: np.ndarray
    shared: np.ndarray
    arguments: tuple  # (dt, t_max, side, rtol, atol)
    shape: tuple
    tier: str = "specialised"  # or "general": see curve_tier

    def compile(self) -> None:
        """Compile the kernel on the first trajectory with no time to run."""
        out, status = curve_kernel.empty_outputs(1)
        dt, _, side, rtol, atol = self.arguments
        self.kernel(np.ascontiguousarray(self.inputs[:, :1]), self.shared, dt, 0.0, side, rtol,
                    atol, out, status)

    def run(self) -> dict[str, np.ndarray]:
        out, status = curve_kernel.empty_outputs(self.inputs.shape[1])
        self.kernel(self.inputs, self.shared, *self.arguments, out, status)
        result = {name: out[k].reshape(self.shape) for k, name in enumerate(curve_kernel.OUTPUTS)}
        result["status"] = status.reshape(self.shape)
        result["status_name"] = np.array([STATUS_NAMES[int(c)] for c in status]).reshape(self.shape)
        return result

    def trace(self, index: int, every: int = 1, max_samples: int = 20000) -> np.ndarray:
        """Trajectory ``index`` (flat) recorded: rows ``curve_trace.TRACE_ROWS``
        (t, s, u, X, Y, W_friction, nu, W_drag), its samples as columns (the
        start, every ``every`` steps, every event step, the end: at most
        ``max_samples``); its last column is the batch's outputs, bit for bit."""
        trace = np.full((len(curve_trace.TRACE_ROWS), max_samples), np.nan)
        inputs = np.ascontiguousarray(self.inputs[:, index:index + 1])
        count = self.kernel.trace_one(0, inputs, self.shared, *self.arguments, int(every), trace)
        return trace[:, :count]


def prepare_curve_run(curve: Curve, *, s0, u0=0.0, mu_k=0.0, mu_s=None, g=9.81, m=1.0,
                      method: str = "rk4", dt: float = 1e-3, t_max: float = 10.0,
                      rtol: float = 1e-6, atol: float | None = None,
                      contact: str = "one_sided", drag_linear=0.0, drag_quadratic=0.0,
                      vector: bool = True, kernel: str | None = None, sweep_size: int | None = None,
                      **shape) -> CurveRun:
    """Every check of :func:`simulate_curve` (same arguments), before any
    work: the :class:`CurveRun` to compile and run.  ``vector=False``: the
    scalar reference kernel (every step alone; the same results, bit for bit).
    ``kernel``: the tier (:func:`curve_tier`), chosen for ``sweep_size``
    trajectories (default: these)."""
    if not isinstance(curve, Curve):
        raise ConfigError("curve", f"expected a rampwork.curves.Curve, got {type(curve).__name__}")
    if method not in curve_kernel.CURVE_STEPPERS:
        raise ConfigError("integrator.method", f"curves run with "
                          f"{', '.join(curve_kernel.CURVE_STEPPERS)}; got {method!r}")
    validate.choice("contact", contact, CONTACTS)
    dt = validate.positive("integrator.dt", dt)
    t_max = validate.positive("t_max", t_max)
    rtol = validate.positive("integrator.rtol", rtol)
    atol = rtol if atol is None else validate.positive("integrator.atol", atol)
    spec = curve.spec
    fixed = curve.ramp is not None
    if fixed and shape:
        raise ConfigError(f"curve.{next(iter(shape))}", "no shape parameter to sweep here (sweep "
                          "a wrapped ramp's parameters with rampwork.simulate on the ramp)")
    coordinates = {}
    if curve.family == "spline":  # swept coordinates of the points: rows of a population
        coordinates, shape = split_coordinates(shape, curve.data_points)
        spec = SPLINE_FAMILY
    arrays = spec.arrays({**dict(curve.params), **shape}) if not fixed else {
        name: np.array([value]) for name, value in curve.params}
    scalars = {}
    for name, value in (("s0", s0), ("u0", u0), ("mu_k", mu_k), ("mu_s", mu_k if mu_s is None else mu_s),
                        ("g", g), ("m", m), ("drag_linear", drag_linear),
                        ("drag_quadratic", drag_quadratic)):
        array = np.asarray(value, dtype=np.float64)
        if not np.isfinite(array).all():
            raise ConfigError(name, f"must be finite, got {value!r}")
        scalars[name] = array
    for name in ("mu_k", "m", "drag_linear", "drag_quadratic"):
        if (scalars[name] < 0).any():
            raise ConfigError(name, f"must be >= 0, got {float(scalars[name].min())!r}")
    if (scalars["g"] <= 0).any() or (scalars["m"] <= 0).any():
        raise ConfigError("g" if (scalars["g"] <= 0).any() else "m", "must be > 0")
    if (scalars["mu_s"] < scalars["mu_k"]).any():
        raise ConfigError("mu_s", "must be >= mu_k")
    shape_out = np.broadcast_shapes(*(a.shape for a in scalars.values()),
                                    *(a.shape if a.size > 1 else () for a in arrays.values()),
                                    *(a.shape for a in coordinates.values()))
    n = int(np.prod(shape_out, dtype=np.int64))
    flat = {k: np.broadcast_to(v, shape_out).ravel() for k, v in scalars.items()}
    params = [np.broadcast_to(a if a.size > 1 else a.reshape(()), shape_out).ravel()
              for a in arrays.values()]
    joint = None
    shared_override = None
    if coordinates:
        shared_override, params[0] = coordinate_population(
            curve.points, params[0], {k: np.broadcast_to(v, shape_out).ravel()
                                      for k, v in coordinates.items()})
    if fixed:
        lo, hi = curve.domain()
        p_lo, p_hi = np.full(n, lo[0]), np.full(n, hi[0])
        shared = curve._shared()
    else:
        shared = np.zeros(1) if curve.data is None else curve._shared()  # convex_cusp: its rows
        if shared_override is not None:  # each case's spline of the swept coordinates
            shared = shared_override
            lo, hi = np.zeros(n), spline_ends(shared, params[0])
        elif curve.family in ("spline", "track"):  # each case's curve of the population
            lo, hi = curve.domain(row=params[0])
        else:
            lo, hi = spec.domain({k: a for k, a in zip(arrays, params)})
        p_lo, p_hi = np.broadcast_to(lo, (n,)), np.broadcast_to(hi, (n,))
        joint = spec.joint({k: a for k, a in zip(arrays, params)})
    # the kernel's joint count: the family's, where any trajectory has a joint
    joints = joint.shape[0] if joint is not None and np.isfinite(joint).any() else 0
    joint_rows = [np.nan, np.nan]  # the kernel's two joints per trajectory (NaN: none)
    if joints:
        for k, row in enumerate(joint):
            joint_rows[k] = np.broadcast_to(row, (n,))
    if curve.family == "track":  # any number: offset and count of each row's in ``shared``
        # (written even where no row has a joint: a chunk may run on the sweep's MANY kernel)
        offsets, counts = track_joints(shared, params[0])
        joint_rows = [offsets, counts]
        joints = curve_kernel.MANY_JOINTS if (counts > 0).any() else 0
    start = flat["s0"]
    off = ~((start >= p_lo) & (start <= p_hi))
    if off.any():
        i = int(np.argmax(off))
        raise ConfigError("s0", f"the start must lie on the curve, in [{p_lo[i]!r}, {p_hi[i]!r}] "
                          f"({spec.position}), got {start[i]!r}")
    if curve.family == "brachistochrone":
        cusp_friction = (start == 0.0) & (flat["mu_k"] > 0.0)
        if cusp_friction.any():
            raise ConfigError("s0", "a start exactly at the cusp (s0 = 0) with friction is not "
                              "supported yet: the curvature is infinite there (start at s0 > 0)")
    inputs = np.zeros((len(curve_kernel.INPUTS), n))
    for row, values in ((curve_kernel.I_P, start), (curve_kernel.I_U, flat["u0"]),
                        (curve_kernel.I_MUK, flat["mu_k"]), (curve_kernel.I_MUS, flat["mu_s"]),
                        (curve_kernel.I_G, flat["g"]), (curve_kernel.I_M, flat["m"]),
                        (curve_kernel.I_LO, p_lo), (curve_kernel.I_HI, p_hi),
                        (curve_kernel.I_B, flat["drag_linear"]),
                        (curve_kernel.I_C, flat["drag_quadratic"]),
                        (curve_kernel.I_JOINT, joint_rows[0]),
                        (curve_kernel.I_JOINT2, joint_rows[1])):
        inputs[row] = values
    for k, values in enumerate(params):
        inputs[curve_kernel.I_S0 + k] = values
    effects = dict(one_sided=contact == "one_sided", friction=bool((flat["mu_k"] > 0).any()),
                   drag_linear=bool((flat["drag_linear"] > 0).any()),
                   drag_quadratic=bool((flat["drag_quadratic"] > 0).any()), joints=joints,
                   vector=vector)
    tier = curve_tier(spec, method, kernel, n if sweep_size is None else sweep_size, **effects)
    if tier == "general":
        effects.update(friction=True, drag_linear=True, drag_quadratic=True)
    return CurveRun(curve_kernel_for(spec, method, **effects), inputs, shared,
                    (dt, t_max, SIDES[curve.side], rtol, atol), shape_out, tier)
