"""Sweeps of single spline coordinates by name (docs/physics.md §5.2).

A spline through n points (``Curve.through_points``) takes the names
``x0 .. x{n-1}`` and ``y0 .. y{n-1}``, the coordinates of its points, as
shape parameters: ``simulate_curve(curve, y2=[0.4, 0.5])`` or a scene's
sweep axis ``y2``.  Each distinct set of values (with the trajectory's
``row``) becomes one spline of a population built here, and the kernel runs
that population through its ``row`` (no new kernel): bit for bit the run of
the splines built by hand.  A value that makes a spline irregular or
self-crossing is refused, naming the coordinate and the value.
"""

from __future__ import annotations

import re

import numpy as np

from .curve_families import CurveFamily, ParameterSpec, SPLINE_FAMILY, spline_population, spline_rows
from .errors import ConfigError

_NAME = re.compile(r"([xy])(0|[1-9][0-9]*)$")
_FAMILIES: dict[int, CurveFamily] = {}


def coordinate_names(points: int) -> tuple[str, ...]:
    return tuple(f"x{k}" for k in range(points)) + tuple(f"y{k}" for k in range(points))


def spline_family(points: int) -> CurveFamily:
    """The spline family whose parameters are ``row`` and the coordinates of
    ``points`` points (for sweep axes; the kernel is the spline's own)."""
    if points not in _FAMILIES:
        coordinates = tuple(
            ParameterSpec(name, "m", f"{'X' if name[0] == 'x' else 'Y'} of the spline's point "
                          f"{name[1:]}", "finite", None) for name in coordinate_names(points))
        family = CurveFamily("spline", SPLINE_FAMILY.description,
                             SPLINE_FAMILY.parameters + coordinates, SPLINE_FAMILY.frame,
                             SPLINE_FAMILY.point, None, position="t", key=SPLINE_FAMILY.key)
        family._evaluator = SPLINE_FAMILY._evaluator
        _FAMILIES[points] = family
    return _FAMILIES[points]


def split_coordinates(shape: dict, points: int) -> tuple[dict, dict]:
    """(the coordinates among ``shape``'s names, the rest); an ``x``/``y``
    name beyond the spline's points is an error that says which exist."""
    coordinates, rest = {}, {}
    for name, value in shape.items():
        match = _NAME.match(name)
        if match is None:
            if name not in SPLINE_FAMILY.parameter_names:
                raise ConfigError(f"curve.{name}", "unknown parameter for a spline; allowed: "
                                  f"row, x0 .. x{points - 1}, y0 .. y{points - 1} (the "
                                  "coordinates of its points)")
            rest[name] = value
            continue
        if int(match.group(2)) >= points:
            raise ConfigError(f"curve.{name}", f"no such coordinate: the spline has {points} "
                              f"points, named x0 .. x{points - 1} and y0 .. y{points - 1}")
        array = np.asarray(value, dtype=np.float64)
        if not np.isfinite(array).all():
            raise ConfigError(f"curve.{name}", f"must be finite, got {value!r}")
        coordinates[name] = array
    return coordinates, rest


def coordinate_population(points: tuple, rows: np.ndarray, coordinates: dict[str, np.ndarray]
                          ) -> tuple[np.ndarray, np.ndarray]:
    """``(shared, rows)``: the population of one spline per distinct (row,
    coordinates) of the trajectories (``rows`` and the ``coordinates``,
    flat, equally long) and each trajectory's row in it.  ``points``: the
    curve's definition (``Curve.points``)."""
    x_points, y_points, end, tangents, allow_crossing = points
    x, y = spline_rows(x_points, y_points)
    names = sorted(coordinates)
    table = np.stack([rows] + [coordinates[name] for name in names], axis=1)
    distinct, which = np.unique(table, axis=0, return_inverse=True)
    xs = x[distinct[:, 0].astype(np.int64)].copy()
    ys = y[distinct[:, 0].astype(np.int64)].copy()
    for column, name in enumerate(names, start=1):
        target = xs if name[0] == "x" else ys
        target[:, int(name[1:])] = distinct[:, column]
    try:
        return spline_population(xs, ys, end, tangents, allow_crossing), which.ravel().astype(np.float64)
    except ConfigError as error:
        # the spline's row k of the population: name the swept values that made it
        match = re.match(r"spline (\d+) \(row \d+ of the points\): (.*)", error.problem, re.S)
        k = int(match.group(1)) if match else 0
        problem = match.group(2) if match else error.problem
        values = ", ".join(f"{name} = {float(distinct[k, c])!r}" for c, name in enumerate(names, start=1))
        raise ConfigError(f"curve.{names[0]}", f"the spline with {values} (row "
                          f"{int(distinct[k, 0])} of the points): {problem}") from None
