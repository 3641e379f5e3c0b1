"""Scene files: a :class:`~rampwork.scene.Scene` and a :class:`~rampwork.scene.Sweep`
as TOML text, read with :func:`load_scene` / :func:`parse_scene` and written
with :func:`dump_scene` (which :func:`rampwork.simulate` uses to
store the scene in every dataset, so that a netCDF file alone says how to
reproduce it).

The format
==========

Lengths in m, velocities in m/s, mass in kg, g in m/s^2, times in s::

    title = "Block on a convex bowl"
    x0 = -0.8          # m, start position (may be swept instead)
    v0 = 0.0           # m/s, horizontal velocity dx/dt          (default 0)
    m = 1.0            # kg                                       (default 1)
    g = 9.81           # m/s^2                                    (default 9.81)
    t_max = 30.0       # s, stop a trajectory still moving then   (default 60)
    contact = "one_sided"   # or "two_sided" (bead on a wire)     (default one_sided)
    diagnostics = ["x_lift_off_paper"]  # optional extra outputs    (default none)

    [ramp]             # required
    family = "quadratic"    # straight | quadratic | circular_bowl | circular_dome
                            # | cycloid | sine | spline
    curvature = 1.0         # the family's own parameters (see `rampwork.FAMILIES`)
    slope = 0.0
    domain = [-1.0, 1.0]    # m, [x_min, x_max]; a spline defaults to its points' range
    # spline only: x_points = [...], y_points = [...]

    [friction]         # default mu_k = 0
    mu_k = 0.3
    mu_s = 0.4         # optional, defaults to mu_k; must be >= mu_k

    [drag]             # optional air drag along the path, m (linear s' + quadratic s'^2)
    linear = 0.1       # 1/s, default 0
    quadratic = 0.05   # 1/m, default 0 (s': the speed along the path)

    [integrator]       # default rk4, dt = 1e-3
    method = "rk4"     # euler | semi_implicit_euler | rk4: fixed steps of dt
                       # | dopri5: adaptive (Dormand-Prince 5(4), error control)
                       # | dop853: adaptive (Dormand-Prince 8(5,3), for tight tolerances)
    dt = 1e-3          # s; dopri5, dop853: the first step (default: estimated)
    # dopri5, dop853 only:
    # rtol = 1e-8      # relative tolerance on x, v and the work integrals (default 1e-6)
    # atol = 1e-8      # absolute tolerance, SI units (default: rtol)
    # dt_max = 0.1     # s, the largest step (default: none)
    # project_energy = false # no projection onto the energy balance (default true)
    closed_form = true # a straight ramp is solved exactly, without stepping;
                       # false steps anyway (to measure a method's error)

    [record]           # optional: record a few whole trajectories
    count = 4          # trajectories spread evenly over the sweep (or indices = [...])
    every = 10         # a sample every `every` steps (and at every event)
    max_samples = 20000

    [sweep]            # optional: without it, one trajectory
    kind = "grid"      # "grid" (outer product, one dimension per axis, in file order),
                       # "cases" (all axes one length, one `case` dimension), or a
                       # design: "random", "sobol", "halton", "lhs" (below)
    [sweep.axes]       # names: mu, mu_k, mu_s, x0, v0, m, g, drag_linear,
                       # drag_quadratic, or a ramp parameter
    mu = [0.1, 0.2, 0.3]                           # explicit list
    x0 = { linspace = [-0.9, 0.9, 19] }            # start, stop, num (both ends included)
    v0 = { logspace = [-2, 1, 4] }                 # 10**start .. 10**stop, num
    curvature = { arange = [0.5, 2.0, 0.5] }       # start, stop, step: numpy's arange,
                                                   # stop excluded (careful with float ends)

A design draws ``n`` cases (a ``case`` dimension, like ``kind = "cases"``)
from its recipe, chunk by chunk: case i's values depend on the recipe and i
only (see :mod:`rampwork.designs`)::

    [sweep]
    kind = "random"    # independent uniform draws; or "sobol" (scrambled Sobol',
                       # n a power of 2), "halton" (scrambled Halton) or "lhs"
                       # (Latin hypercube)
    n = 1000           # at most 1e8
    seed = 1           # default 0
    [sweep.axes]
    mu = { uniform = [0.05, 0.4] }
    curvature = { loguniform = [0.1, 3.0] }        # uniform in log; low > 0

``mu`` sets ``mu_k = mu_s``; do not combine it with ``mu_k`` or ``mu_s`` axes.
A swept value replaces the scene's own (``x0`` may then be left out).

Rules: every key is checked; an unknown key, a value of the wrong type, a
NaN or infinite number (TOML's ``nan``/``inf`` literals included), an empty
or negative size, an axis of more than 1e8 points or a sweep of more than 1e9
trajectories is refused with a one-line :class:`~rampwork.errors.ConfigError`
naming the file and the key, before anything is allocated or run.

:func:`dump_scene` writes every setting explicitly (defaults included) and a
design as its recipe (a few lines, whatever ``n``), with exact values (floats
by ``repr``), so that ``parse_scene(dump_scene(scene, sweep))`` gives back
equal objects; an evenly spaced axis is written as its ``linspace`` when that
reproduces the values bit for bit.

Stored scenes
=============

The scene stored with a dataset (``rampwork_scene``, written by
``dump_scene(..., stored=True)``) does not list an axis of more than
:data:`INLINE_VALUES` explicit values (a ``Sweep.cases`` list, a long grid
axis): those values are the dataset's own coordinate of the axis's name, and
the file refers to it, so that the text stays a few lines whatever the
sweep's size::

    [sweep.axes]
    mu = { coordinate = "mu", num = 200000 }   # the dataset's coordinate `mu`

:func:`scene_from_dataset` reads such a scene back with its values (as does
:func:`parse_scene` given ``coordinates``); read without them it is refused
with a ConfigError that says so.
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .designs import DESIGN_KINDS, LAWS, Design, DesignAxis
from .errors import ConfigError
from .ramps import CALLABLE, FAMILIES, Ramp
from .scene import DIAGNOSTICS, SCENE_AXES, Drag, Friction, Integrator, Record, Scene, Sweep
from .validate import MAX_AXIS_POINTS, MAX_TRAJECTORIES

__all__ = [
    "MAX_AXIS_POINTS",
    "MAX_TRAJECTORIES",
    "apply_overrides",
    "dump_scene",
    "load_scene",
    "load_scene_of_dataset",
    "parse_scene",
    "read_toml",
    "scene_from_dataset",
    "scene_from_dict",
]

#: an explicit axis of more values than this is stored by reference to the
#: dataset's coordinate (``{ coordinate = NAME, num = N }``) in a stored scene
INLINE_VALUES = 64
#: the key of such a reference (the coordinate's name) and its length
COORDINATE_KEYS = ("coordinate", "num")

#: the largest scene file read (bytes): a scene is a few lines; this bounds
#: what a wrong path such as /dev/zero or a multi-gigabyte file can cost
MAX_SCENE_BYTES = 64 << 20

TOP_KEYS = ("title", "x0", "v0", "m", "g", "t_max", "contact", "diagnostics",
            "ramp", "friction", "drag", "integrator", "record", "sweep")
FRICTION_KEYS = ("mu_k", "mu_s")
DRAG_KEYS = ("linear", "quadratic")
INTEGRATOR_KEYS = ("method", "dt", "rtol", "atol", "dt_max", "closed_form", "project_energy")
RECORD_KEYS = ("count", "every", "max_samples", "indices")
SWEEP_KEYS = ("kind", "axes", "n", "seed")
FILE_SWEEP_KINDS = ("grid", "cases") + DESIGN_KINDS
GENERATORS = ("linspace", "logspace", "arange")
RANDOM_GENERATORS = LAWS

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


# ----------------------------------------------------------------------------
# reading
# ----------------------------------------------------------------------------


def _one_line(text: Any) -> str:
    return " ".join(str(text).split())


def _located(source: str, error: ConfigError) -> ConfigError:
    """``error`` re-raised as ``ConfigError(source, ...)`` on one line."""
    where, problem = error.where, error.problem
    if not where:
        message = problem
    elif where.startswith("["):
        message = f"{where} {problem}"
    else:
        message = f"{where}: {problem}"
    return ConfigError(source, _one_line(message))


def _unknown(table: str, key: str, allowed: Sequence[str], hint: str = "") -> ConfigError:
    place = f"[{table}]" if table else ""
    what = "unknown key" if table else "unknown top-level key"
    return ConfigError(place, f"{what} {_short(key)}; allowed: {', '.join(allowed)}{hint}")


def _check_keys(table: str, data: Mapping, allowed: Sequence[str], hint: str = "") -> None:
    for key in data:
        if key not in allowed:
            raise _unknown(table, key, allowed, hint)


def _table(where: str, value) -> dict:
    if not isinstance(value, dict):
        raise ConfigError(where, f"expected a table ([{where}] or {{ ... }}), got {_short(value)}")
    return value


def _type_name(value) -> str:
    return type(value).__name__


def _short(value, limit: int = 60) -> str:
    """``repr(value)``, cut to about ``limit`` characters for one-line messages."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 10**30:
        return f"an integer of {len(str(abs(value)))} digits"
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 5] + " ...]" if text[0] == "[" else text[:limit - 4] + " ..."


def _number(where: str, value, sweepable: bool = False) -> float:
    """A finite float from a TOML int or float (bools, strings, NaN, inf refused)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        hint = ""
        if sweepable and isinstance(value, (list, dict)):
            hint = "; to run several values, list them under [sweep.axes]"
        raise ConfigError(where, f"expected a finite number, got {_short(value)} ({_type_name(value)}){hint}")
    try:
        number = float(value)
    except OverflowError:
        raise ConfigError(where, f"number too large: {_short(value)}") from None
    if not math.isfinite(number):
        raise ConfigError(where, f"must be a finite number, got {value!r}")
    return number


def _integer(where: str, value, minimum: int | None = None, maximum: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(where, f"expected an integer, got {_short(value)} ({_type_name(value)})")
    if minimum is not None and value < minimum:
        raise ConfigError(where, f"must be >= {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise ConfigError(where, f"must be <= {maximum:.0e}, got {value}" if maximum >= 10**6
                          else f"must be <= {maximum}, got {value}")
    return value


def _string(where: str, value) -> str:
    if not isinstance(value, str):
        raise ConfigError(where, f"expected a string, got {_short(value)} ({_type_name(value)})")
    return value


def _numbers(where: str, value, length: int | None = None) -> list[float]:
    """A list of finite numbers (of ``length`` items if given)."""
    if not isinstance(value, list):
        raise ConfigError(where, f"expected a list of numbers, got {_short(value)} ({_type_name(value)})")
    if length is not None and len(value) != length:
        raise ConfigError(where, f"expected {length} numbers, got {len(value)}")
    return [_number(f"{where}[{i}]", item) for i, item in enumerate(value)]


def read_toml(text: str, source: str = "<string>") -> dict:
    """The TOML document ``text`` as a dict; syntax errors -> one-line ConfigError."""
    if not isinstance(text, str):
        raise ConfigError(source, f"expected TOML text (str), got {_type_name(text)}")
    if text.startswith("\ufeff"):  # a byte-order mark some editors write
        text = text[1:]
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise ConfigError(source, f"TOML syntax error: {_one_line(error)}") from None
    except RecursionError:  # tomllib parses nested arrays and tables recursively
        raise ConfigError(source, "TOML nested too deeply (arrays or inline tables inside "
                          "each other hundreds of levels deep)") from None


def parse_scene(text: str, source: str = "<string>",
                coordinates: Mapping | None = None) -> tuple[Scene, Sweep]:
    """The scene and sweep described by the TOML ``text`` (format in the module
    docstring).  Errors: :class:`ConfigError` naming ``source`` and the key.
    ``coordinates``: name -> values of the dataset a stored scene came with
    (its axes written as ``{ coordinate = NAME, num = N }`` read them)."""
    return scene_from_dict(read_toml(text, source), source, coordinates)


def scene_from_dataset(dataset, source: str = "the stored scene") -> tuple[Scene, Sweep]:
    """The scene and sweep that made ``dataset`` (an ``xarray.Dataset`` from
    :func:`rampwork.simulate` or :func:`rampwork.open_dataset`): its
    ``rampwork_scene`` attribute, with the axes stored by reference read from
    the dataset's coordinates.  ``rampwork.simulate(*scene_from_dataset(ds))``
    runs it again."""
    attrs = getattr(dataset, "attrs", None)
    if attrs is None or "rampwork_scene" not in attrs:
        raise ConfigError(source, "not a rampwork dataset (no rampwork_scene attribute)")
    return parse_scene(str(attrs["rampwork_scene"]), source, dataset.coords)


def load_scene_of_dataset(path: str | os.PathLike, overrides: Sequence[str] = ()) -> tuple[Scene, Sweep]:
    """The scene and sweep that made the dataset at ``path`` (a netCDF file or
    Zarr store written by rampwork), ``overrides`` applied as in
    :func:`load_scene`; the axes the stored scene refers to are read from the
    dataset's coordinates."""
    from .io import open_dataset

    source = str(path)
    dataset = open_dataset(path)
    data = read_toml(str(dataset.attrs["rampwork_scene"]), source)
    if overrides:
        apply_overrides(data, overrides)
    return scene_from_dict(data, source, dataset.coords)


def _read_text(path: str | os.PathLike) -> str:
    where = str(path).replace("\0", "\\0")
    if "\0" in str(path):
        raise ConfigError(where, "not a file name: contains a NUL byte")
    path = Path(path)
    try:
        with path.open("rb") as file:
            data = file.read(MAX_SCENE_BYTES + 1)
    except FileNotFoundError:
        raise ConfigError(where, "no such file") from None
    except IsADirectoryError:
        raise ConfigError(where, "is a directory, not a scene file") from None
    except OSError as error:
        raise ConfigError(where, f"cannot be read: {_one_line(error.strerror or error)}") from None
    if len(data) > MAX_SCENE_BYTES:
        raise ConfigError(where, f"larger than {MAX_SCENE_BYTES >> 20} MiB: not a scene file")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        line = data[:error.start].count(b"\n") + 1
        raise ConfigError(where, f"not UTF-8 text: byte 0x{data[error.start]:02x} at line {line} "
                          f"(offset {error.start}): {error.reason}") from None


def load_scene(path: str | os.PathLike, overrides: Sequence[str] = ()) -> tuple[Scene, Sweep]:
    """The scene and sweep in the TOML file ``path``.  ``overrides``:
    ``"KEY=VALUE"`` strings applied before validation (see :func:`apply_overrides`)."""
    source = str(path)
    data = read_toml(_read_text(path), source)
    if overrides:
        apply_overrides(data, overrides)
    return scene_from_dict(data, source)


def _override_value(text: str):
    try:
        return tomllib.loads(f"value = {text}")["value"]
    except tomllib.TOMLDecodeError:
        return text  # a bare word such as euler or two_sided: taken as a string


def apply_overrides(data: dict, overrides: Sequence[str]) -> dict:
    """Set dotted keys in a parsed scene document, in place: each override is
    ``"KEY=VALUE"`` such as ``"integrator.dt=1e-4"``, ``"friction.mu_k=0.2"``,
    ``"contact=two_sided"``.  VALUE is read as a TOML value (number, string,
    boolean, array, inline table); text that is not one is taken as a string.
    Missing tables are created; the result is validated as usual afterwards."""
    for item in overrides:
        if not isinstance(item, str) or "=" not in item:
            raise ConfigError("--set", f"expected KEY=VALUE, got {item!r}")
        key, _, raw = item.partition("=")
        key = key.strip()
        parts = key.split(".")
        if not key or not all(_BARE_KEY.fullmatch(part) for part in parts):
            raise ConfigError("--set", f"bad key {key!r} in {item!r}: expected dotted names such as "
                              "integrator.dt")
        value = _override_value(raw.strip())
        table = data
        for depth, part in enumerate(parts[:-1]):
            child = table.setdefault(part, {})
            if not isinstance(child, dict):
                raise ConfigError("--set", f"{'.'.join(parts[:depth + 1])} is not a table, "
                                  f"so {key!r} cannot be set")
            table = child
        table[parts[-1]] = value
    return data


def scene_from_dict(data: Mapping, source: str = "<dict>",
                    coordinates: Mapping | None = None) -> tuple[Scene, Sweep]:
    """The scene and sweep described by a parsed TOML document (``coordinates``:
    see :func:`parse_scene`)."""
    try:
        if not isinstance(data, Mapping):
            raise ConfigError("", f"expected a table of settings, got {_type_name(data)}")
        data = dict(data)
        if "curve" in data:  # a planar curve instead of a ramp (docs/physics.md §5)
            from .curve_scene import check_sweep
            from .curve_scenefile import scene_from_data

            if "ramp" in data:
                raise ConfigError("curve", "a scene has exactly one of [ramp] (y = f(x)) and "
                                  "[curve] (a planar curve); this one has both")
            scene = scene_from_data(data)
            sweep = _sweep(data.get("sweep"), scene, coordinates)
            check_sweep(scene, sweep)
            return scene, sweep
        _check_keys("", data, TOP_KEYS)
        scene = _scene(data)
        sweep = _sweep(data.get("sweep"), scene, coordinates)
        _check_record_indices(scene, sweep)
    except ConfigError as error:
        raise _located(source, error) from None
    return scene, sweep


def _check_record_indices(scene: Scene, sweep: Sweep) -> None:
    """Traced indices must name trajectories of the sweep (known only here,
    with both read): refused before the run, not after it."""
    for k, index in enumerate(scene.record.indices or ()):
        if index >= sweep.size:
            raise ConfigError(f"record.indices[{k}]", f"{_short(index)} is beyond the sweep's "
                              f"{sweep.size:,} trajectories (flat indices 0 .. {sweep.size - 1:,})")


def _scene(data: dict) -> Scene:
    if "ramp" not in data:
        raise ConfigError("ramp", "required: a [ramp] table with family, its parameters and domain "
                          "(or a [curve] table: a planar curve)")
    ramp = _ramp(_table("ramp", data["ramp"]))
    kwargs: dict[str, Any] = {"ramp": ramp}
    if "title" in data:
        kwargs["title"] = _string("title", data["title"])
    for key in ("x0", "v0", "m", "g", "t_max"):
        if key in data:
            kwargs[key] = _number(key, data[key], sweepable=key in SCENE_AXES)
    if "contact" in data:
        kwargs["contact"] = _string("contact", data["contact"])
    if "diagnostics" in data:
        names = data["diagnostics"]
        if not isinstance(names, list):
            raise ConfigError("diagnostics", f"expected a list of names ({', '.join(DIAGNOSTICS)}), "
                              f"got {_short(names)}")
        kwargs["diagnostics"] = tuple(_string(f"diagnostics[{k}]", name) for k, name in enumerate(names))

    friction = _table("friction", data.get("friction", {}))
    _check_keys("friction", friction, FRICTION_KEYS,
                "; to sweep friction list mu, mu_k or mu_s under [sweep.axes]" if "mu" in friction else "")
    kwargs["friction"] = Friction(**{key: _number(f"friction.{key}", value, sweepable=True)
                                     for key, value in friction.items()})

    drag = _table("drag", data.get("drag", {}))
    _check_keys("drag", drag, DRAG_KEYS,
                "; to sweep drag list drag_linear or drag_quadratic under [sweep.axes]")
    kwargs["drag"] = Drag(**{key: _number(f"drag.{key}", value, sweepable=True)
                             for key, value in drag.items()})

    kwargs["integrator"] = integrator_from_table(_table("integrator", data.get("integrator", {})))

    kwargs["record"] = record_from_table(_table("record", data.get("record", {})))
    return Scene(**kwargs)


def record_from_table(record: dict) -> Record:
    """The :class:`Record` of a ``[record]`` table (a ramp's or a curve's)."""
    _check_keys("record", record, RECORD_KEYS)
    args = {}
    for key in ("count", "every", "max_samples"):
        if key in record:
            args[key] = _integer(f"record.{key}", record[key])
    if "indices" in record:
        indices = record["indices"]
        if not isinstance(indices, list):
            raise ConfigError("record.indices", f"expected a list of integers, got {_short(indices)}")
        args["indices"] = tuple(_integer(f"record.indices[{i}]", v, 0) for i, v in enumerate(indices))
    return Record(**args)


def integrator_from_table(integrator: dict) -> Integrator:
    """The :class:`Integrator` of an ``[integrator]`` table."""
    _check_keys("integrator", integrator, INTEGRATOR_KEYS)
    args: dict[str, Any] = {}
    if "method" in integrator:
        args["method"] = _string("integrator.method", integrator["method"])
    for key in ("dt", "rtol", "atol", "dt_max"):
        if key in integrator:
            args[key] = _number(f"integrator.{key}", integrator[key])
    for key in ("closed_form", "project_energy"):
        if key in integrator:
            value = integrator[key]
            if not isinstance(value, bool):
                raise ConfigError(f"integrator.{key}", f"expected true or false, got {_short(value)}")
            args[key] = value
    return Integrator(**args)


def _ramp(table: dict) -> Ramp:
    if "family" not in table:
        raise ConfigError("ramp.family", f"required; allowed: {', '.join(FAMILIES)}")
    family = _string("ramp.family", table["family"])
    if family not in FAMILIES:
        raise ConfigError("ramp.family", f"unknown ramp family {_short(family)}; allowed: {', '.join(FAMILIES)}")
    spec = FAMILIES[family]
    allowed = ("family", "domain") + spec.parameter_names + spec.data_names
    _check_keys("ramp", {key: value for key, value in table.items() if key not in spec.renamed},
                allowed)
    kwargs: dict[str, Any] = {}
    if "domain" in table:
        kwargs["domain"] = tuple(_numbers("ramp.domain", table["domain"], 2))
    for name in spec.parameter_names + tuple(spec.renamed):  # old names: read with a warning
        if name in table:
            kwargs[name] = _number(f"ramp.{name}", table[name], sweepable=True)
    for name in spec.data_names:
        if name in table:
            kwargs[name] = _numbers(f"ramp.{name}", table[name])
    return Ramp.create(family, **kwargs)


# -- sweeps -------------------------------------------------------------------


def _stored_axis(where: str, spec: dict, coordinates: Mapping | None) -> tuple[str, Any, int]:
    """An axis stored as ``{ coordinate = NAME, num = N }``: the dataset's
    coordinate NAME, which must hold N finite values."""
    for key in spec:
        if key not in COORDINATE_KEYS:
            raise _unknown(where, key, COORDINATE_KEYS)
    if "num" not in spec:
        raise ConfigError(where, "{ coordinate = NAME, num = N } needs num, the number of values")
    name = _string(f"{where}.coordinate", spec["coordinate"])
    num = _integer(f"{where}.num", spec["num"], 1, MAX_TRAJECTORIES)
    if coordinates is None:
        raise ConfigError(where, f"the {num:,} values are the dataset's coordinate {name!r} (a "
                          "scene stored with its dataset): read it with "
                          "rampwork.scene_from_dataset(dataset)")
    if name not in coordinates:
        raise ConfigError(where, f"the dataset has no coordinate {name!r}")
    try:
        values = np.asarray(coordinates[name], dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ConfigError(where, f"coordinate {name!r} is not numbers: {_one_line(error)}") from None
    if values.ndim != 1 or values.size != num:
        raise ConfigError(where, f"coordinate {name!r} has shape {values.shape}, expected ({num},)")
    if not np.isfinite(values).all():
        raise ConfigError(where, f"coordinate {name!r} holds NaN or infinite values")
    return "list", values, num


def _axis_length(where: str, spec, random: bool,
                 coordinates: Mapping | None = None) -> tuple[str, Any, int]:
    """(kind, arguments, number of values) of one axis, checked, not expanded
    (``random``: of a design; ``coordinates``: a stored scene's dataset's)."""
    if not random and isinstance(spec, dict) and "coordinate" in spec:
        return _stored_axis(where, spec, coordinates)
    if random:
        if not isinstance(spec, dict):
            raise ConfigError(where, f"a design draws each axis from {{ uniform = [low, high] }} "
                              f"or {{ loguniform = [low, high] }}, got {_short(spec)}")
        allowed = RANDOM_GENERATORS
    elif isinstance(spec, list):
        values = _numbers(where, spec)
        if not values:
            raise ConfigError(where, "expected at least one value, got []")
        return "list", values, len(values)
    elif isinstance(spec, (int, float)) and not isinstance(spec, bool):
        return "list", [_number(where, spec)], 1
    elif not isinstance(spec, dict):
        raise ConfigError(where, f"expected a list of numbers or {{ linspace | logspace | arange = "
                          f"[...] }}, got {_short(spec)} ({_type_name(spec)})")
    else:
        allowed = GENERATORS
    for key in spec:
        if key not in allowed:
            raise _unknown(where, key, allowed)
    if len(spec) != 1:
        raise ConfigError(where, f"expected exactly one of {', '.join(allowed)}, got "
                          f"{', '.join(spec) or 'none'}")
    (kind, args), = spec.items()
    at = f"{where}.{kind}"
    if kind in RANDOM_GENERATORS:
        low, high = _numbers(at, args, 2)
        return kind, (low, high), 0
    if kind in ("linspace", "logspace"):
        if not isinstance(args, list) or len(args) != 3:
            raise ConfigError(at, f"expected [start, stop, num], got {_short(args)}")
        start, stop = _number(f"{at}[0]", args[0]), _number(f"{at}[1]", args[1])
        num = _integer(f"{at}[2] (num)", args[2], 1, MAX_AXIS_POINTS)
        if kind == "logspace" and max(start, stop) > 308:
            raise ConfigError(at, f"10**{max(start, stop)!r} is not a finite float; exponents must "
                              "be <= 308")
        return kind, (start, stop, num), num
    # arange
    if not isinstance(args, list) or len(args) != 3:
        raise ConfigError(at, f"expected [start, stop, step], got {_short(args)}")
    start, stop, step = _numbers(at, args, 3)
    if step == 0:
        raise ConfigError(f"{at}[2] (step)", "must not be 0")
    count = math.ceil((stop - start) / step)
    if not math.isfinite(count) or count < 1:
        raise ConfigError(at, f"[{start!r}, {stop!r}, {step!r}] gives no values (stop is excluded; "
                          "step must point from start towards stop)")
    if count > MAX_AXIS_POINTS:
        raise ConfigError(at, f"gives {count:.3g} values; at most {MAX_AXIS_POINTS:.0e} per axis")
    return kind, (start, stop, step), count


def _expand(kind: str, args) -> np.ndarray:
    if kind == "list":
        return np.asarray(args, dtype=np.float64)
    if kind == "linspace":
        return np.linspace(args[0], args[1], args[2])
    if kind == "logspace":
        return np.logspace(args[0], args[1], args[2])
    return np.arange(args[0], args[1], args[2], dtype=np.float64)


def _sweep_where(error: ConfigError, names: Sequence[str]) -> ConfigError:
    """Sweep's own errors say ``sweep.<axis>``; the file's key is ``sweep.axes.<axis>``."""
    head, _, rest = error.where.partition(".")
    if head == "sweep" and rest.split("[")[0] in names:
        return ConfigError(f"sweep.axes.{rest}", error.problem)
    return error


def _sweep(table, scene: Scene, coordinates: Mapping | None = None) -> Sweep:
    if table is None:
        return Sweep.single()
    table = _table("sweep", table)
    _check_keys("sweep", table, SWEEP_KEYS,
                " (axes go in [sweep.axes])" if any(k in scene.axis_names for k in table) else "")
    kind = _string("sweep.kind", table.get("kind", "grid"))
    if kind not in FILE_SWEEP_KINDS:
        raise ConfigError("sweep.kind", f"unknown value {_short(kind)}; allowed: "
                          f"{', '.join(map(repr, FILE_SWEEP_KINDS))}")
    random = kind in DESIGN_KINDS
    if not random:
        for key in ("n", "seed"):
            if key in table:
                raise ConfigError(f"sweep.{key}", f"only used by a design (kind = "
                                  f"{' | '.join(map(repr, DESIGN_KINDS))}; this sweep is {_short(kind)})")
    axes = _table("sweep.axes", table.get("axes", {}))
    allowed = scene.axis_names
    for name in axes:
        if name not in allowed:
            if isinstance(scene, Scene) and name in scene.ramp.spec.renamed:  # an old name
                raise scene.ramp.spec.unknown_parameter(f"sweep.axes.{name}", name, allowed)
            raise ConfigError("[sweep.axes]", f"unknown axis {_short(name)}; allowed: {', '.join(allowed)}")
    plans = {name: _axis_length(f"sweep.axes.{name}", spec, random, coordinates)
             for name, spec in axes.items()}

    try:
        if random:
            if "n" not in table:
                raise ConfigError("sweep.n", f"required with kind = {kind!r}: the number of cases")
            n = _integer("sweep.n", table["n"], 1)  # the design checks the rest
            seed = _integer("sweep.seed", table.get("seed", 0), 0)
            if not plans:
                raise ConfigError("[sweep.axes]", f"a {kind} design needs at least one axis")
            axes = tuple(DesignAxis(name, *args, law) for name, (law, args, _) in plans.items())
            return Sweep.from_design(Design(kind, n, seed, axes))

        lengths = {name: length for name, (_, _, length) in plans.items()}
        if kind == "grid":
            total = math.prod(lengths.values())
            if total > MAX_TRAJECTORIES:
                shape = " x ".join(f"{name} {length}" for name, length in lengths.items())
                raise ConfigError("sweep", f"a grid of {shape} = {total:.3g} trajectories; at most "
                                  f"{MAX_TRAJECTORIES:.0e} (split the study into several runs)")
        elif len(set(lengths.values())) > 1:
            raise ConfigError("sweep", "cases need axes of one length, got "
                              + ", ".join(f"{name}: {length}" for name, length in lengths.items()))
        columns = []
        for name, (gen, args, length) in plans.items():
            values = _expand(gen, args)
            if values.size != length or not np.isfinite(values).all():  # pragma: no cover - guarded above
                raise ConfigError(f"sweep.axes.{name}", f"{gen} {args!r} did not give {length} finite values")
            columns.append((name, values))
        return Sweep(tuple(columns), kind)
    except ConfigError as error:
        raise _sweep_where(error, list(axes)) from None


# ----------------------------------------------------------------------------
# writing
# ----------------------------------------------------------------------------

_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def _toml_string(text: str) -> str:
    out = []
    for char in text:
        if char in _ESCAPES:
            out.append(_ESCAPES[char])
        elif ord(char) < 0x20 or ord(char) == 0x7F:
            out.append(f"\\u{ord(char):04X}")
        else:
            out.append(char)
    return '"' + "".join(out) + '"'


def _toml_key(key: str) -> str:
    return key if _BARE_KEY.fullmatch(key) else _toml_string(key)


def _toml_float(where: str, value) -> str:
    value = float(value)
    if not math.isfinite(value):
        raise ConfigError(where, f"cannot write a non-finite number ({value!r}) to a scene file")
    return repr(value)  # shortest text that reads back to the same float


def _toml_value(where: str, value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return _toml_float(where, value)
    raise ConfigError(where, f"cannot write {value!r} ({_type_name(value)}) to a scene file")


def _toml_array(where: str, values, width: int = 96) -> str:
    if all(type(v) is float for v in values) and all(map(math.isfinite, values)):
        # the common case (a shape population's table: 10^4 numbers per call),
        # the same text as _toml_float's without a call and a message per number
        items = list(map(repr, values))
    else:
        items = [_toml_value(f"{where}[{i}]", v) for i, v in enumerate(values)]
    line = "[" + ", ".join(items) + "]"
    if len(line) <= width:
        return line
    # greedy rows of at most ``width`` characters ("item, " each), cut by
    # lengths alone: one join per row, not a string grown item by item
    rows, start, used = [], 0, 0
    for i, item in enumerate(items):
        size = len(item) + 2
        if used and used + size > width:
            rows.append(", ".join(items[start:i]) + ",")
            start, used = i, 0
        used += size
    rows.append(", ".join(items[start:]) + ",")
    return "[\n" + "".join(f"    {r}\n" for r in rows) + "]"


def _evenly_spaced(array: np.ndarray) -> bool:
    """Whether ``np.linspace(first, last, size)`` gives ``array`` bit for bit
    (a few values checked first: most lists that are not fail there)."""
    size = array.size
    probe = np.unique(np.linspace(0, size - 1, min(size, 9)).round().astype(np.int64))
    step = (array[-1] - array[0]) / (size - 1)
    scale = max(abs(array[0]), abs(array[-1]))
    if not np.allclose(array[probe], array[0] + probe * step, rtol=1e-9, atol=1e-9 * scale):
        return False
    spaced = np.linspace(array[0], array[-1], size)
    return bool(np.array_equal(spaced.view(np.int64), array.view(np.int64)))


def _axis_text(name: str, values: Sequence[float], stored: bool = False) -> str:
    array = np.asarray(values, dtype=np.float64)
    if array.size >= 4 and _evenly_spaced(array):
            return (f"{{ linspace = [{_toml_float(name, array[0])}, {_toml_float(name, array[-1])}, "
                    f"{array.size}] }}")
    if stored and array.size > INLINE_VALUES:
        return f"{{ coordinate = {_toml_string(name)}, num = {array.size} }}"
    return _toml_array(f"sweep.axes.{name}", [float(v) for v in values])


def dump_scene(scene: Scene, sweep: Sweep | None = None, *, stored: bool = False) -> str:
    """``scene`` and ``sweep`` as scene-file TOML text that :func:`parse_scene`
    reads back to equal objects.  Callable ramps cannot be written.

    ``stored``: the text stored with the dataset of the run: an axis of more
    than :data:`INLINE_VALUES` explicit values refers to the dataset's
    coordinate instead of listing them (read back by :func:`scene_from_dataset`)."""
    from .curve_scene import CurveScene
    from .curve_scenefile import dump_curve_lines

    if not isinstance(scene, (Scene, CurveScene)):
        raise ConfigError("scene", f"expected a rampwork.Scene, got {_type_name(scene)}")
    if sweep is not None and not isinstance(sweep, Sweep):
        raise ConfigError("sweep", f"expected a rampwork.Sweep or None, got {_type_name(sweep)}")
    if isinstance(scene, CurveScene):
        lines = ["# rampwork scene file (TOML): run it with `rampwork run FILE -o OUT.nc`"]
        record = scene.record if scene.record.enabled else None
        lines += dump_curve_lines(scene) + _tail_lines(scene, record, sweep, stored)
        return "\n".join(lines) + "\n"
    if scene.ramp.family == CALLABLE:
        raise ConfigError("ramp", "a ramp of user functions (Ramp.from_functions) cannot be written "
                          "to a scene file; only the registered families can")
    lines = ["# rampwork scene file (TOML): run it with `rampwork run FILE -o OUT.nc`",
             f"title = {_toml_string(scene.title)}"]
    if scene.x0 is not None:
        lines.append(f"x0 = {_toml_float('x0', scene.x0)}")
    for key in ("v0", "m", "g", "t_max"):
        lines.append(f"{key} = {_toml_float(key, getattr(scene, key))}")
    lines.append(f"contact = {_toml_string(scene.contact)}")
    if scene.diagnostics:
        lines.append("diagnostics = [" + ", ".join(_toml_string(n) for n in scene.diagnostics) + "]")

    ramp = scene.ramp.to_dict()
    lines += ["", "[ramp]", f"family = {_toml_string(ramp.pop('family'))}",
              f"domain = {_toml_array('ramp.domain', [float(v) for v in ramp.pop('domain')])}"]
    for key, value in ramp.items():
        text = (_toml_array(f"ramp.{key}", [float(v) for v in value]) if isinstance(value, (list, tuple))
                else _toml_float(f"ramp.{key}", value))
        lines.append(f"{_toml_key(key)} = {text}")

    return "\n".join(lines + _tail_lines(scene, scene.record, sweep, stored)) + "\n"


def _tail_lines(scene, record: Record | None, sweep: Sweep | None, stored: bool) -> list[str]:
    """Friction, drag, integrator, record and sweep (a ramp's or a curve's)."""
    lines: list[str] = []
    friction = scene.friction
    lines += ["", "[friction]", f"mu_k = {_toml_float('friction.mu_k', friction.mu_k)}",
              f"mu_s = {_toml_float('friction.mu_s', friction.mu_s)}"]
    drag = scene.drag
    if drag.enabled:
        lines += ["", "[drag]", f"linear = {_toml_float('drag.linear', drag.linear)}",
                  f"quadratic = {_toml_float('drag.quadratic', drag.quadratic)}"]
    integrator = scene.integrator
    lines += ["", "[integrator]"]
    for key, value in integrator.settings().items():
        lines.append(f"{key} = " + (_toml_string(value) if key == "method"
                                    else _toml_float(f"integrator.{key}", value)))
    if not integrator.closed_form:
        lines.append("closed_form = false")
    if not integrator.project_energy:
        lines.append("project_energy = false")
    if record is not None:
        lines += ["", "[record]", f"count = {int(record.count)}", f"every = {int(record.every)}",
                  f"max_samples = {int(record.max_samples)}"]
        if record.indices is not None:
            lines.append(f"indices = {_toml_array('record.indices', [int(i) for i in record.indices])}")

    if sweep is not None and sweep.design is not None:
        design = sweep.design
        lines += ["", "[sweep]", f"kind = {_toml_string(design.kind)}", f"n = {design.n}",
                  f"seed = {design.seed}", "", "[sweep.axes]"]
        for axis in design.axes:
            where = f"sweep.axes.{axis.name}"
            lines.append(f"{_toml_key(axis.name)} = {{ {axis.law} = [{_toml_float(where, axis.low)}, "
                         f"{_toml_float(where, axis.high)}] }}")
    elif sweep is not None:
        lines += ["", "[sweep]", f"kind = {_toml_string(sweep.kind)}", "", "[sweep.axes]"]
        texts = [(name, _axis_text(name, values, stored)) for name, values in sweep.axes]
        if any(text.startswith("{ coordinate") for _, text in texts):
            lines.append("# { coordinate = NAME, num = N }: the values are the dataset's coordinate NAME "
                         "(rampwork.scene_from_dataset reads them)")
        lines += [f"{_toml_key(name)} = {text}" for name, text in texts]
    return lines
