"""``rampwork optimise SCENE.toml -o history.nc``: a scene file with an
``[optimise]`` table (docs/optimise.md).  The other tables set the physics
as in ``run`` (friction, drag, integrator, contact, t_max, v0 or u0, m, g);
the ramp or curve is the optimised shape's, so ``[ramp]`` and ``[curve]``
are left out, and a ``[sweep]`` is refused (the population is the sweep).
``shape = "chord_modes"`` optimises ramps y = f(x) (a ramp scene);
``shape = "cusp_curve"`` convex curves from a vertical start at A = (0, 0)
to ``end`` (``rampwork.descent_shapes.CuspCurve``: the family that holds
the frictional brachistochrone), run as a curve scene from rest at A (or
``u0``).

    [optimise]
    shape = "chord_modes"      # the y = f(x) family (rampwork.ChordModes)
    start = [0.0, 1.0]         # A (m); the block starts here
    end = [2.0, 0.0]           # B (m)
    k = 6                      # modes
    objective = "W_friction"   # t_end | W_friction | W_excess | speed_end
    sense = "minimise"         # or "maximise"
    constraints = ["arrive", "stay_on"]
    seed = 0
    popsize = 15
    maxiter = 100

    [optimise]                 # or: the fastest convex curve from A = (0, 0)
    shape = "cusp_curve"
    end = [1.0, -1.0]          # B (m), right of and below A
    k = 8                      # Chebyshev coefficients c_1 .. c_K
    objective = "t_end"
"""

from __future__ import annotations

import copy
import sys
from pathlib import Path

from . import io
from .errors import ConfigError
from .optimiser import OptimiseSettings, optimise
from .scenefile import _read_text, apply_overrides, read_toml, scene_from_dict
from .shapes import ChordModes

SHAPES = ("chord_modes", "cusp_curve")
#: [optimise] keys: the shapes', then the optimiser's (OptimiseSettings)
SHAPE_KEYS = ("shape", "start", "end", "k", "amplitude", "decay", "y_low", "y_high", "bound")
#: the shape keys each shape takes
KEYS_OF_SHAPE = {"chord_modes": ("shape", "start", "end", "k", "amplitude", "decay", "y_low", "y_high"),
                 "cusp_curve": ("shape", "end", "k", "bound", "decay")}
SETTINGS_KEYS = ("objective", "sense", "constraints", "seed", "popsize", "maxiter", "tol", "atol",
                 "mutation", "recombination", "init", "penalty", "polish", "polish_step", "x0", "evaluator")
OPTIMISE_KEYS = SHAPE_KEYS + SETTINGS_KEYS
EXIT_OK = 0


def read_optimisation(data: dict, source: str):
    """(scene, shape, settings) from a parsed scene file with ``[optimise]``;
    errors name the file and the key."""
    try:
        return _read(copy.deepcopy(data))
    except ConfigError as error:
        raise ConfigError(source, f"{error.where}: {error.problem}") from None


def _read(data: dict):
    table = data.pop("optimise", None)
    if not isinstance(table, dict):
        raise ConfigError("[optimise]", "required: the shape family, its end points and what to optimise")
    for key in table:
        if key not in OPTIMISE_KEYS:
            raise ConfigError("[optimise]", f"unknown key {key!r}; allowed: {', '.join(OPTIMISE_KEYS)}")
    if "sweep" in data:
        raise ConfigError("[sweep]", "not in an optimisation: the optimiser's population is the sweep")
    shape_name = table.get("shape", "chord_modes")
    if shape_name not in SHAPES:
        raise ConfigError("optimise.shape", f"unknown shape {shape_name!r}; allowed: {', '.join(SHAPES)}")
    for key in SHAPE_KEYS:
        if key in table and key not in KEYS_OF_SHAPE[shape_name]:
            raise ConfigError(f"optimise.{key}", f"not a key of shape {shape_name!r}; its keys: "
                              f"{', '.join(KEYS_OF_SHAPE[shape_name][1:])}")
    for key in KEYS_OF_SHAPE[shape_name][1:4 if shape_name == "chord_modes" else 3]:
        if key not in table:
            raise ConfigError(f"optimise.{key}", "required")
    if shape_name == "cusp_curve":
        shape = _cusp_curve(table)
    else:
        shape = ChordModes(start=_pair(f"optimise.{'start'}", table["start"]),
                           end=_pair("optimise.end", table["end"]), k=table["k"],
                           amplitude=table.get("amplitude"), decay=table.get("decay", 1.0),
                           y_bounds=(table.get("y_low"), table.get("y_high")))
    settings = {key: table[key] for key in SETTINGS_KEYS if key in table}
    if isinstance(settings.get("constraints"), list):
        settings["constraints"] = tuple(settings["constraints"])
    for key in ("mutation", "x0"):
        if isinstance(settings.get(key), list):
            settings[key] = tuple(settings[key])
    settings = OptimiseSettings(**settings)
    if shape_name == "cusp_curve":
        return _curve_scene(data, shape), shape, settings
    # the ramp is the shape's: the chord stands in while the scene is read
    if "curve" in data:
        raise ConfigError("[curve]", "not with shape 'chord_modes' (ramps y = f(x)); a curve "
                          "scene optimises shape = 'cusp_curve'")
    if "ramp" in data:
        raise ConfigError("[ramp]", "not in an optimisation: the ramp is the optimised shape's "
                          "([optimise] start, end, k)")
    chord = shape.scene()
    data["ramp"] = chord.ramp.to_dict()
    if "x0" in data:
        raise ConfigError("x0", "not in an optimisation: the block starts at [optimise] start")
    data["x0"] = shape.start[0]
    scene, _ = scene_from_dict(data, "<scene>")
    return scene, shape, settings


def _cusp_curve(table: dict):
    from .descent_shapes import CuspCurve

    options = {key: table[key] for key in ("bound", "decay") if key in table}
    try:
        return CuspCurve(end=_pair("optimise.end", table["end"]), k=table["k"], **options)
    except ConfigError as error:  # CuspCurve names its argument; the file's key is optimise.<name>
        raise ConfigError(f"optimise.{error.where}", error.problem) from None


def _curve_scene(data: dict, shape):
    """The curve scene the candidates run in: the block starts at A's cusp
    (s0 = 0, at rest or u0); the curve is each candidate's, the cycloid
    through B stands in while the scene is read."""
    import math

    from scipy.optimize import brentq

    for key, why in (("ramp", "the curve is the optimised shape's ([optimise] end, k)"),
                     ("curve", "the curve is the optimised shape's ([optimise] end, k)"),
                     ("s0", "the block starts at A, the curve's vertical start"),
                     ("x0", "the block starts at A, the curve's vertical start")):
        if key in data:
            raise ConfigError(f"[{key}]" if key in ("ramp", "curve") else key,
                              f"not in a cusp_curve optimisation: {why}")
    bx, by = shape.end
    theta = brentq(lambda t: (t - math.sin(t)) * -by - bx * (1 - math.cos(t)), 1e-6, 2 * math.pi - 1e-9)
    data["curve"] = {"family": "brachistochrone", "radius": -by / (1 - math.cos(theta)), "end_angle": theta}
    data["s0"] = 0.0  # the cusp; each candidate starts at its own
    scene, _ = scene_from_dict(data, "<scene>")
    return scene


def _pair(where: str, value):
    if not isinstance(value, list) or len(value) != 2:
        raise ConfigError(where, f"expected a point [x, y] in m, got {value!r}")
    return tuple(value)


def cmd_optimise(args) -> int:
    """``optimise``: validate everything (the output included), then run."""
    from .cli import _positive_int

    threads = _positive_int("--threads", args.threads)
    data = read_toml(_read_text(args.scene), args.scene)
    if args.set:
        apply_overrides(data, args.set)
    scene, shape, settings = read_optimisation(data, args.scene)
    io.check_writable(args.output, args.overwrite, store=False)
    checkpoint = Path(args.checkpoint) if args.checkpoint else None
    if not args.quiet:
        print(f"{scene.title}: {settings.sense} {settings.objective} ({', '.join(settings.constraints) or 'no'} "
              f"constraints) over {shape.describe()}; {scene.integrator.describe()}", flush=True)
    progress = None if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))
    history = optimise(scene, shape, settings=settings, checkpoint=checkpoint, resume=args.resume,
                       progress=progress, threads=threads)
    output = io.write_netcdf(history, args.output, overwrite=args.overwrite)
    if not args.quiet:
        attrs = history.attrs
        best = attrs["best_objective"]
        print(f"generations   {attrs['generations']} ({'converged' if attrs['converged'] else 'maxiter reached'})")
        print(f"evaluations   {attrs['n_evaluations']:,} in {attrs['run_time_s']:.1f} s")
        print(f"best          {settings.objective} = {best:.10g} {attrs['objective_units']}")
        print(f"wrote         {output}")
    return EXIT_OK


def add_optimise_command(commands, fmt) -> None:
    parser = commands.add_parser(
        "optimise", help="optimise a ramp's shape (an [optimise] table) and write the history",
        formatter_class=fmt,
        description="Load SCENE (TOML) with an [optimise] table (the shape family, A, B, K, the "
                    "objective, sense, constraints and the optimiser's settings), check everything "
                    "before any work, run differential evolution (one batched kernel call per "
                    "generation, a progress line per generation on stderr) and write the history "
                    "dataset to OUTPUT (docs/optimise.md).")
    parser.add_argument("scene", metavar="SCENE.toml", help="scene file with an [optimise] table")
    parser.add_argument("-o", "--output", metavar="HISTORY.nc", required=True,
                        help="netCDF file to write the history to (its directory must exist)")
    parser.add_argument("--overwrite", action="store_true", help="replace OUTPUT if it exists")
    parser.add_argument("--threads", metavar="N", default=None, help="worker threads (default: all)")
    parser.add_argument("--set", metavar="KEY=VALUE", action="append", default=[],
                        help="override a key before validation, e.g. --set optimise.maxiter=20")
    parser.add_argument("--checkpoint", metavar="FILE.npz", default=None,
                        help="write a checkpoint every generation; an existing one of the same "
                             "optimisation is continued (see --restart)")
    parser.add_argument("--restart", dest="resume", action="store_false",
                        help="with --checkpoint: start afresh even where the file exists")
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    parser.set_defaults(handler=cmd_optimise)
