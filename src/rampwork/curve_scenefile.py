"""Curve scenes in scene files: the ``[curve]`` table read into a
:class:`~rampwork.curve_scene.CurveScene` and written back
(:mod:`rampwork.scenefile` calls these for ``[curve]`` scenes)."""

from __future__ import annotations

import re

from .curve_scene import CURVE_SCENE_AXES, CurveScene
from .curves import Curve, FAMILIES as CURVE_FAMILIES
from .errors import ConfigError
from .scene import Drag, Friction

# ------------------------------------------------------------------------------
# scene files: the [curve] table
# ------------------------------------------------------------------------------
#: top-level keys of a curve scene file
CURVE_TOP_KEYS = ("title", "s0", "u0", "m", "g", "t_max", "contact", "curve", "friction", "drag",
                  "integrator", "record", "sweep")
#: keys of [curve] besides the family's parameters
CURVE_KEYS = ("family", "side", "contact")
#: keys of a spline's [curve] table (family = "spline": Curve.through_points)
SPLINE_KEYS = ("x_points", "y_points", "end", "end_tangents", "allow_crossing", "row")


def curve_from_table(table: dict) -> tuple[Curve, str | None]:
    """The curve of a ``[curve]`` table, and its ``contact`` (None: not given there)."""
    from .scenefile import _check_keys, _number, _string

    if "family" not in table:
        raise ConfigError("curve.family", f"required; allowed: {', '.join(CURVE_FAMILIES)}, spline, track")
    family = _string("curve.family", table["family"])
    if family == "spline":
        return _spline_from_table(table)
    if family == "track":
        return _track_from_table(table)
    if family not in CURVE_FAMILIES:
        raise ConfigError("curve.family", f"unknown curve family {family!r}; allowed: "
                          f"{', '.join(CURVE_FAMILIES)}, spline, track")
    spec = CURVE_FAMILIES[family]
    _check_keys("curve", table, CURVE_KEYS + spec.parameter_names)
    params = {name: _number(f"curve.{name}", table[name], sweepable=True)
              for name in spec.parameter_names if name in table}
    side = _string("curve.side", table["side"]) if "side" in table else None
    contact = _string("curve.contact", table["contact"]) if "contact" in table else None
    return Curve.create(family, side=side, **params), contact


#: a spline coordinate's name: x or y and the point's index
COORDINATE = re.compile(r"[xy](0|[1-9][0-9]*)$")


def rows_of(points: list) -> bool:
    return bool(points) and isinstance(points[0], list)


def _spline_from_table(table: dict) -> tuple[Curve, str | None]:
    """A ``[curve]`` table with ``family = "spline"``: the points and end
    conditions of :meth:`Curve.through_points`; a list of lists of points
    is a population, one spline per row, swept by the axis ``row``."""
    from .scenefile import _check_keys, _number, _numbers, _short, _string

    # a coordinate by name (x2 = 0.5: point 2's X) replaces it in every row
    coordinates = {key: table[key] for key in table if COORDINATE.match(key)}
    _check_keys("curve", {k: v for k, v in table.items() if k not in coordinates},
                CURVE_KEYS + SPLINE_KEYS)
    args = {}
    for key in ("x_points", "y_points"):
        if key not in table:
            raise ConfigError(f"curve.{key}", "required for family = \"spline\": the points' coordinates (m)")
        value = table[key]
        rows = isinstance(value, list) and bool(value) and all(isinstance(v, list) for v in value)
        args[key] = ([_numbers(f"curve.{key}[{k}]", v) for k, v in enumerate(value)] if rows
                     else _numbers(f"curve.{key}", value))
    for name, value in coordinates.items():
        key, index = f"{name[0]}_points", int(name[1:])
        number = _number(f"curve.{name}", value, sweepable=True)
        for row in (args[key] if rows_of(args[key]) else [args[key]]):
            if index >= len(row):
                raise ConfigError(f"curve.{name}", f"no such coordinate: the spline has "
                                  f"{len(row)} points")
            row[index] = number
    if "row" in table:
        args["row"] = _number("curve.row", table["row"], sweepable=True)
    if "end" in table:
        args["end"] = _string("curve.end", table["end"])
    if "end_tangents" in table:
        pairs = table["end_tangents"]
        if not isinstance(pairs, list) or len(pairs) != 2:
            raise ConfigError("curve.end_tangents", f"expected two [dX, dY] pairs, got {_short(pairs)}")
        args["end_tangents"] = [_numbers(f"curve.end_tangents[{i}]", pair, 2) for i, pair in enumerate(pairs)]
    if "allow_crossing" in table:
        value = table["allow_crossing"]
        if not isinstance(value, bool):
            raise ConfigError("curve.allow_crossing", f"expected true or false, got {_short(value)}")
        args["allow_crossing"] = value
    side = _string("curve.side", table["side"]) if "side" in table else "left"
    contact = _string("curve.contact", table["contact"]) if "contact" in table else None
    return Curve.through_points(side=side, **args), contact


#: keys of a track's [curve] table (family = "track": Curve.track)
TRACK_KEYS = ("pieces", "start", "row")


def _track_from_table(table: dict) -> tuple[Curve, str | None]:
    """A ``[curve]`` table with ``family = "track"``: ``pieces`` (a list of
    [length, curvature_start, curvature_end], or one such list per track)
    and ``start`` ([X, Y, angle], or one per track) of :meth:`Curve.track`."""
    from .scenefile import _check_keys, _number, _numbers, _short, _string

    _check_keys("curve", table, CURVE_KEYS + TRACK_KEYS)
    if "pieces" not in table:
        raise ConfigError("curve.pieces", "required for family = \"track\": a list of "
                          "[length, curvature_start, curvature_end] (m, 1/m, 1/m)")
    pieces = table["pieces"]
    if not isinstance(pieces, list) or not pieces:
        raise ConfigError("curve.pieces", f"expected a list of pieces, got {_short(pieces)}")
    nested = all(isinstance(p, list) and p and all(isinstance(q, list) for q in p) for p in pieces)
    tracks = pieces if nested else [pieces]
    parsed = [[_numbers(f"curve.pieces[{k}][{i}]" if nested else f"curve.pieces[{i}]", piece, 3)
               for i, piece in enumerate(track)] for k, track in enumerate(tracks)]
    args = {}
    if "start" in table:
        start = table["start"]
        rows = isinstance(start, list) and bool(start) and all(isinstance(v, list) for v in start)
        args["start"] = ([_numbers(f"curve.start[{k}]", v, 3) for k, v in enumerate(start)] if rows
                         else _numbers("curve.start", start, 3))
    if "row" in table:
        args["row"] = _number("curve.row", table["row"], sweepable=True)
    side = _string("curve.side", table["side"]) if "side" in table else "left"
    contact = _string("curve.contact", table["contact"]) if "contact" in table else None
    return Curve.track(parsed if nested else parsed[0], side=side, **args), contact


def scene_from_data(data: dict) -> CurveScene:
    """The :class:`CurveScene` of a parsed scene file with a ``[curve]`` table."""
    from .scenefile import _check_keys, _number, _string, _table, integrator_from_table, record_from_table

    _check_keys("", data, CURVE_TOP_KEYS, "; a curve scene starts at s0 with speed u0 along "
                "the curve (x0, v0, [ramp] and diagnostics are for ramps y = f(x))")
    curve, contact = curve_from_table(_table("curve", data["curve"]))
    kwargs: dict = {"curve": curve}
    if contact is not None and "contact" in data:
        raise ConfigError("curve.contact", "given twice: here and at the top level; keep one")
    if "contact" in data:
        contact = _string("contact", data["contact"])
    if contact is not None:
        kwargs["contact"] = contact
    if "title" in data:
        kwargs["title"] = _string("title", data["title"])
    for key in ("s0", "u0", "m", "g", "t_max"):
        if key in data:
            kwargs[key] = _number(key, data[key], sweepable=key in CURVE_SCENE_AXES)
    friction = _table("friction", data.get("friction", {}))
    _check_keys("friction", friction, ("mu_k", "mu_s"))
    kwargs["friction"] = Friction(**{k: _number(f"friction.{k}", v, sweepable=True)
                                     for k, v in friction.items()})
    drag = _table("drag", data.get("drag", {}))
    _check_keys("drag", drag, ("linear", "quadratic"))
    kwargs["drag"] = Drag(**{k: _number(f"drag.{k}", v, sweepable=True) for k, v in drag.items()})
    kwargs["integrator"] = integrator_from_table(_table("integrator", data.get("integrator", {})))
    kwargs["record"] = record_from_table(_table("record", data.get("record", {})))
    return CurveScene(**kwargs)


def dump_curve_lines(scene: CurveScene) -> list[str]:
    """The scene-file lines of everything but the integrator, record and sweep."""
    from .scenefile import _toml_array, _toml_float, _toml_string

    lines = [f"title = {_toml_string(scene.title)}"]
    if scene.s0 is not None:
        lines.append(f"s0 = {_toml_float('s0', scene.s0)}")
    for key in ("u0", "m", "g", "t_max"):
        lines.append(f"{key} = {_toml_float(key, getattr(scene, key))}")
    lines.append(f"contact = {_toml_string(scene.contact)}")
    curve = scene.curve
    lines += ["", "[curve]", f"family = {_toml_string(curve.family)}",
              f"side = {_toml_string(curve.side)}"]
    lines += [f"{name} = {_toml_float(f'curve.{name}', value)}" for name, value in curve.params]
    if curve.family == "track":  # its pieces and start (a population: one list per track)
        pieces, start = curve.points
        lines.append("pieces = " + _toml_nested("curve.pieces", pieces))
        lines.append("start = " + _toml_nested("curve.start", start))
    elif curve.points is not None:  # a spline through points (or a population: rows)
        x_points, y_points, end, tangents, allow_crossing = curve.points
        for key, values in (("x_points", x_points), ("y_points", y_points)):
            if values and isinstance(values[0], tuple):
                lines.append(f"{key} = [\n" + "".join(
                    f"    {_toml_array(f'curve.{key}[{k}]', row)},\n" for k, row in enumerate(values))
                    + "]")
            else:
                lines.append(f"{key} = {_toml_array(f'curve.{key}', values)}")
        lines.append(f"end = {_toml_string(end)}")
        if tangents is not None:
            lines.append("end_tangents = [" + ", ".join(
                _toml_array(f"curve.end_tangents[{i}]", pair) for i, pair in enumerate(tangents)) + "]")
        if allow_crossing:
            lines.append("allow_crossing = true")
    return lines



def _toml_nested(where: str, values) -> str:
    """A (nested) tuple of floats as a TOML array, one line per innermost list's parent."""
    from .scenefile import _toml_array

    if values and isinstance(values[0], tuple):
        inner = [_toml_nested(f"{where}[{k}]", v) for k, v in enumerate(values)]
        if isinstance(values[0][0], tuple):
            return "[\n" + "".join(f"    {line},\n" for line in inner) + "]"
        return "[" + ", ".join(inner) + "]"
    return _toml_array(where, values)
