"""The ``rampwork`` command line: run, check, example, info.

Every bad input (a ConfigError, an unreadable scene file, a bad option value)
prints one line ``rampwork: error: <message>`` to stderr and exits with status
2; usage errors exit 2 too; Ctrl-C exits 130 and SIGTERM (what batch
schedulers send) 143, both after saying how to resume an unfinished run.
Nothing is written for a refused run, and an existing output file is replaced
only with ``--overwrite``.  Messages spell options as the command line does
(``--overwrite``, not ``overwrite=True``: :func:`rampwork.errors.option`),
and name the command as it can be typed here (:func:`command_name`).
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import sys
import warnings
from importlib import resources
from pathlib import Path

from ._version import __version__
from .errors import ClosedFormNotice, ConfigError, front_end, option
from .terminal import (Progress, check_lines, format_counts, format_seconds, scene_lines, si,
                       status_counts, stored_sweep, sweep_shape)

EXIT_OK = 0
EXIT_ERROR = 2
EXIT_INTERRUPTED = 130
#: 128 + SIGTERM, the shell's convention for a process ended by SIGTERM
EXIT_TERMINATED = 128 + int(signal.SIGTERM)

DESCRIPTION = """\
rampwork: parameter studies of a point mass sliding with Coulomb friction on a
ramp y = f(x).  A scene file (TOML) describes the ramp, friction, integrator,
start values and a sweep (grid, cases or a random design); `rampwork run`
integrates every trajectory with a compiled kernel and writes one netCDF file
(or Zarr store) of per-trajectory results (status, end state, work against friction, energy
balance, excess work beyond mu m g |dx|, convexity, reversals, lift-off)."""

EPILOG = """\
examples:
  rampwork example                       list the example scenes
  rampwork example bowl_reversals > bowl.toml
  rampwork check bowl.toml               validate, count trajectories
  rampwork run bowl.toml -o bowl.nc      simulate and write netCDF
  rampwork run bowl.toml -o bowl.zarr    the same as a Zarr store
  rampwork run bowl.toml -o bowl.nc --overwrite --set integrator.dt=1e-4
  rampwork info bowl.nc                  summarise a result file

Run `rampwork COMMAND --help` for the options of each command."""

SET_HELP = """\
override one scene value before validation, as a dotted KEY and a TOML VALUE:
e.g. integrator.dt=1e-4, friction.mu_k=0.2, t_max=5, contact=two_sided,
'sweep.axes.mu=[0.1, 0.2]'.  Bare words are taken as strings.  Repeatable."""


# ----------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------


def _positive_int(option: str, text: str | None) -> int | None:
    """An option's positive integer, checked by the command rather than by
    argparse: a bad value is a one-line error like every other, not argparse's
    usage block."""
    if text is None:
        return None
    try:
        value = int(text)
    except ValueError:
        raise ConfigError(option, f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise ConfigError(option, f"expected a positive integer, got {text!r}")
    return value


def command_name(argv0: str | None = None) -> str:
    """The command as it can be typed here to run rampwork again: ``rampwork``
    where that is on the PATH, else the script that ran (``.venv/bin/rampwork``
    when the virtual environment is not activated), or ``python -m rampwork``
    with the interpreter running it."""
    argv0 = sys.argv[0] if argv0 is None else argv0
    on_path = shutil.which("rampwork")
    script = os.path.basename(argv0).removesuffix(".exe")
    if script == "rampwork" and argv0:
        if on_path and os.path.abspath(on_path) == os.path.abspath(argv0):
            return "rampwork"
        return argv0 if os.sep in argv0 else os.path.join(".", argv0)
    if script != "__main__.py" and on_path:  # main() called in-process
        return "rampwork"
    python = sys.executable or "python3"
    for name in ("python", "python3"):
        found = shutil.which(name)
        if found and os.path.abspath(found) == os.path.abspath(python):
            return f"{name} -m rampwork"
    try:
        relative = os.path.relpath(python)
    except ValueError:  # pragma: no cover - another drive on Windows
        relative = python
    return f"{relative if not relative.startswith('..') else python} -m rampwork"


def _with_command(text: str, prog: str) -> str:
    """Help text whose example commands start with ``prog`` instead of ``rampwork``."""
    import re

    return re.sub(r"(?m)(^  |`)rampwork(?= )", lambda match: match.group(1) + prog, text)


class _Terminated(KeyboardInterrupt):
    """SIGTERM, handled like Ctrl-C: finished chunks stay, the resume hint is printed."""


def _terminate(signum, frame):
    raise _Terminated()


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """Warnings (a renamed scene parameter, ...) as one ``rampwork: warning:`` line."""
    print(f"rampwork: warning: {' '.join(str(message).split())}", file=sys.stderr, flush=True)


def _examples_dir():
    return resources.files("rampwork").joinpath("examples")


#: the folder of the curve scenes' examples (docs/physics.md §5), inside the examples
CURVE_EXAMPLES = "curves"
#: the folder of the optimisations' examples (`rampwork optimise`, docs/optimise.md)
OPTIMISE_EXAMPLES = "optimise"


def _example_files() -> dict:
    """name -> file of every shipped example: the ramp scenes, the curve scenes,
    then the optimisations."""
    files = {}
    for folder in (_examples_dir(), _examples_dir().joinpath(CURVE_EXAMPLES),
                   _examples_dir().joinpath(OPTIMISE_EXAMPLES)):
        for entry in folder.iterdir():
            if entry.name.endswith(".toml"):
                files.setdefault(entry.name[:-5], entry)
    return files


def example_names() -> list[str]:
    """Names of the example scenes shipped with the package."""
    return sorted(_example_files())


def example_text(name: str) -> str:
    """The text of one shipped example scene (``name`` with or without ``.toml``)."""
    stem = name[:-5] if name.endswith(".toml") else name
    files = _example_files()
    if stem not in files:
        raise ConfigError(f"example {name!r}", f"no such example; available: {', '.join(sorted(files))}")
    return files[stem].read_text(encoding="utf-8")


def _title_of(text: str) -> str:
    import tomllib

    try:
        return str(tomllib.loads(text).get("title", ""))
    except tomllib.TOMLDecodeError:  # pragma: no cover - shipped examples parse
        return ""


def _load(path: str, overrides):
    """A scene file, or the scene stored with a rampwork dataset (a netCDF
    file or Zarr store, by its suffix): its long axes read from the dataset."""
    from .io import NETCDF_SUFFIXES, ZARR_SUFFIX
    from .scenefile import load_scene, load_scene_of_dataset

    if Path(path).suffix.lower() in NETCDF_SUFFIXES + (ZARR_SUFFIX,):
        return load_scene_of_dataset(path, overrides or ())
    return load_scene(path, overrides or ())


def _plan(path: str, scene, sweep):
    """Every check the runner makes, before any work; errors name the file."""
    from .runner import plan_run

    try:
        return plan_run(scene, sweep)
    except ConfigError as error:
        raise ConfigError(path, f"{error.where}: {error.problem}") from None


def _compile_notice(plan) -> None:
    """Say so before a kernel is compiled (seconds, where a cached one loads at once)."""
    from .core.jit import cache_location
    from .kernels import WARMUP_ENV, choose_tier, kernel_source, tier_variant, warmup_wanted

    tier = choose_tier(plan)
    if kernel_source(tier_variant(plan, tier), plan) != "compiled":
        return
    what = ("the general kernel for every scene of this kind (once per machine)"
            if tier == "general" else "the kernel for this scene")
    print(f"compiling    {what}: about 2-9 s; later runs load it from {cache_location()}",
          flush=True)
    if tier == "specialised" and warmup_wanted():
        print(f"             and then, in the background, the general kernels (once per machine, "
              f"about 20 s on one core): then a new scene starts in about a second "
              f"({WARMUP_ENV}=0 turns this off)", flush=True)


def _integration(plan) -> str:
    """The integrator in words, and that a straight ramp does not use it (the
    CLI says so here, in its summary, instead of a ClosedFormNotice)."""
    text = plan.scene.integrator.describe()
    if plan.variant.closed_form:
        text += (f" (not used: a straight ramp is solved in closed form; {option('closed_form')} "
                 "steps with it)")
    return text


def _warn_shadowed(overrides, sweep) -> None:
    """--set of a value that a sweep axis replaces has no effect: say so."""
    names = set(sweep.names)
    for item in overrides or ():
        key = item.partition("=")[0].strip()
        if key in ("x0", "v0", "m", "g"):
            axes = {key}
        elif key in ("friction.mu_k", "friction.mu_s"):
            axes = {"mu", key.split(".")[1]}
        elif key in ("drag.linear", "drag.quadratic"):
            axes = {"drag_" + key.split(".")[1]}
        elif key.startswith("ramp."):
            axes = {key[5:]}
        else:
            continue
        for axis in sorted(axes & names):
            print(f"rampwork: note: --set {key} has no effect: sweep axis {axis!r} replaces it",
                  file=sys.stderr)


# ----------------------------------------------------------------------------
# commands
# ----------------------------------------------------------------------------


#: run_to_file's parameters as the command line spells them
_RUN_OPTIONS = {"threads": "--threads", "chunk_size": "--chunk-size", "scheduler": "--scheduler"}


def _run_error(args, error: ConfigError) -> ConfigError:
    """An error of the run named by what the user typed: an option, the
    output file (or its partial file), else the scene file."""
    from .streaming import partial_path

    if error.where in _RUN_OPTIONS:
        return ConfigError(_RUN_OPTIONS[error.where], error.problem)
    output = Path(args.output)
    if error.where == str(output) or (output.name and error.where == str(partial_path(output))):
        return error
    return ConfigError(args.scene, f"{error.where}: {error.problem}")


def _check_output_is_not_an_input(args) -> None:
    """Refuse an output that would replace the scene file it is computed from
    (``-o s.toml --overwrite`` replaced the scene with the results)."""
    output, scene = Path(args.output), Path(args.scene)
    try:
        same = output.exists() and scene.exists() and os.path.samefile(output, scene)
    except OSError:
        same = False
    if same or (output.resolve() == scene.resolve()):
        raise ConfigError(args.output, f"is the scene file {args.scene!r} itself; the results "
                          "would replace it: give -o another file (e.g. OUT.nc)")


def cmd_run(args) -> int:
    from . import io
    from .streaming import SweepToFile

    args.threads = _positive_int("--threads", args.threads)
    args.chunk_size = _positive_int("--chunk-size", args.chunk_size)
    scene, sweep = _load(args.scene, args.set)
    _check_output_is_not_an_input(args)
    _warn_shadowed(args.set, sweep)
    if _is_curve(scene):  # a planar curve: rampwork.curve_cli
        from .curve_cli import curve_heading

        plan, heading = None, curve_heading(args, scene, sweep)
    else:
        plan = _plan(args.scene, scene, sweep)
        heading = (f"{scene.title}: {sweep.size:,} trajectories ({sweep_shape(sweep)}), "
                   f"{_integration(plan)}")
    try:
        job = SweepToFile(scene, sweep, args.output, chunk_size=args.chunk_size, threads=args.threads,
                          resume=args.resume, overwrite=args.overwrite, scheduler=args.scheduler)
    except ConfigError as error:
        raise _run_error(args, error) from None
    if not args.quiet:
        print(heading, flush=True)
        print(f"chunks       {job.layout.describe(job.plan.sweep.dims, args.chunk_size)}", flush=True)
        if job.resuming:
            print(f"resuming     {job.done_chunks} of {job.total_chunks} chunks done in {job.partial}",
                  flush=True)
        if plan is not None:
            _compile_notice(plan)
    progress = Progress() if not args.quiet and (args.progress or sys.stderr.isatty()) else None
    try:
        output = job.run(progress)
    except ConfigError as error:
        raise _run_error(args, error) from None
    except KeyboardInterrupt:  # Ctrl-C, or SIGTERM (_Terminated)
        if job.partial.exists():
            print(f"rampwork: note: {job.done_chunks} of {job.total_chunks} chunks are saved in "
                  f"{job.partial}; run the same command with --resume to finish", file=sys.stderr)
        raise
    if args.quiet:
        return EXIT_OK
    with io.open_lazily(output) as dataset:
        attrs = dict(dataset.attrs)
        counts = status_counts(dataset["status"].values)  # one byte a trajectory
    run_s = float(attrs.get("run_time_s", float("nan")))
    compile_s = float(attrs.get("compile_time_s", float("nan")))
    steps = int(attrs["trajectory_steps"])
    n_trajectories = int(attrs["n_trajectories"])
    if int(attrs.get("kernel_closed_form", 0)):  # solved exactly: nothing stepped
        rate = (f"{si(n_trajectories / run_s)} trajectories/s" if run_s > 0
                else "trajectories/s n/a") + ", closed form, no steps"
    else:
        rate = (f"{si(steps / run_s)} trajectory-steps/s" if run_s > 0
                else "trajectory-steps/s n/a") + f", {steps:,} steps"
    print(f"trajectories  {n_trajectories:,}")
    print(f"kernel        {attrs.get('kernel_effects', '')}")
    print(f"compile time  {format_seconds(compile_s)}")
    print(f"run time      {format_seconds(run_s)}  ({rate})")
    print(f"status        {format_counts(counts)}")
    print(f"wrote         {output}")
    return EXIT_OK


def _is_curve(scene) -> bool:
    from .curve_scene import CurveScene

    return isinstance(scene, CurveScene)


def cmd_check(args) -> int:
    scene, sweep = _load(args.scene, args.set)
    _warn_shadowed(args.set, sweep)
    if _is_curve(scene):
        from .curve_cli import check_curve

        return check_curve(args, scene, sweep)
    plan = _plan(args.scene, scene, sweep)
    ramp = scene.ramp
    params = ", ".join(f"{k} = {v!r}" for k, v in ramp.params)
    integrator = scene.integrator
    steps = ("" if integrator.adaptive or plan.variant.closed_form else
             f" (at most {scene.t_max / integrator.dt:,.0f} steps per trajectory)")
    print(f"{args.scene}: OK")
    print(f"title         {scene.title}")
    print(f"ramp          {ramp.family}" + (f" ({params})" if params else "")
          + f" on [{ramp.domain[0]!r}, {ramp.domain[1]!r}] m")
    physics, sweep_lines = check_lines(scene, sweep, plan.shape, plan.size)
    print("\n".join(physics))
    print(f"integrator    {_integration(plan)}, t_max = {scene.t_max!r} s{steps}")
    print("\n".join(sweep_lines))
    print(f"kernel        {'; '.join(plan.effects)}")
    return EXIT_OK


def cmd_example(args) -> int:
    if args.name is None:
        print(f"example scenes (print one with `{command_name()} example NAME > scene.toml`):")
        names = example_names()
        width = max(map(len, names), default=0)
        for name in names:
            print(f"  {name:<{width}}  {_title_of(example_text(name))}")
        return EXIT_OK
    sys.stdout.write(example_text(args.name))
    sys.stdout.flush()
    return EXIT_OK


def cmd_info(args) -> int:
    from . import io

    dataset = io.open_dataset(args.dataset)
    attrs = dataset.attrs
    print(f"{args.dataset}")
    for key in ("title", "source", "history"):
        if key in attrs:
            print(f"{key:<13} {attrs[key]}")
    dims = ", ".join(f"{name} = {size}" for name, size in dataset.sizes.items())
    print(f"{'dimensions':<13} {dims or '(none: one trajectory)'}")
    if "n_trajectories" in attrs:
        print(f"{'trajectories':<13} {int(attrs['n_trajectories']):,}")
    sweep = stored_sweep(str(attrs.get("rampwork_scene", "")), dataset.coords)
    if sweep is not None:
        print(f"{'sweep':<13} {sweep}")
    timing = []
    for key, label in (("compile_time_s", "compile"), ("run_time_s", "run"), ("trace_time_s", "trace")):
        if key in attrs:
            timing.append(f"{label} {format_seconds(float(attrs[key]))}")
    if timing:
        print(f"{'timing':<13} {', '.join(timing)}"
              + (f" on {int(attrs['threads'])} threads" if "threads" in attrs else ""))
    if "status" in dataset:
        print(f"{'status':<13} {format_counts(status_counts(dataset['status'].values))}")

    def describe(title, names):
        if not names:
            return
        print(f"{title}:")
        width = max(len(str(name)) for name in names)
        for name in names:
            var = dataset[name]
            units = var.attrs.get("units", "")
            dims = f"({', '.join(map(str, var.dims))})" if var.dims else "()"
            units = f"[{units}]" if units else ""
            print(f"  {str(name):<{width}}  {dims:<18} {units:<8} {var.attrs.get('long_name', '')}".rstrip())

    describe("coordinates", list(dataset.coords))
    describe("variables", list(dataset.data_vars))
    if not args.no_scene:
        print("scene:")
        for line in scene_lines(str(attrs.get("rampwork_scene", ""))):
            print(f"  {line}" if line else "")
    return EXIT_OK


# ----------------------------------------------------------------------------
# the parser and main
# ----------------------------------------------------------------------------


def build_parser(prog: str | None = None) -> argparse.ArgumentParser:
    """The parser; ``prog``: the command as shown in usage and examples
    (default :func:`command_name`)."""
    fmt = argparse.RawDescriptionHelpFormatter
    prog = command_name() if prog is None else prog
    parser = argparse.ArgumentParser(prog=prog, description=_with_command(DESCRIPTION, prog),
                                     epilog=_with_command(EPILOG, prog), formatter_class=fmt)
    parser.add_argument("--version", action="version", version=f"rampwork {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", title="commands")
    commands.required = True

    run = commands.add_parser(
        "run", help="simulate a scene file and write the results to netCDF (or Zarr)", formatter_class=fmt,
        description="Load SCENE (TOML), check everything (including that OUTPUT can be written) "
                    "before any work, run every trajectory of its sweep chunk by chunk, writing "
                    "each chunk's results to compressed netCDF4 (or a Zarr store) as it finishes "
                    "(memory stays bounded; an interrupted run continues with --resume), rename the "
                    "finished file to OUTPUT and print a summary: trajectories, compile and run time, "
                    "trajectory-steps per second, end statuses.")
    run.add_argument("scene", metavar="SCENE.toml", help=f"scene file (see `{prog} example`), or a "
                     "dataset rampwork wrote (.nc or .zarr): its stored scene runs again")
    run.add_argument("-o", "--output", metavar="OUT.nc", required=True,
                     help="netCDF file to write (required; .nc, .nc4, .netcdf or .cdf), or a Zarr "
                          "store (.zarr: each chunk written where it is computed, by a Dask worker "
                          "too); its directory must exist")
    run.add_argument("--overwrite", action="store_true",
                     help="replace OUTPUT if it exists (default: refuse, exit status 2)")
    run.add_argument("--threads", metavar="N", default=None,
                     help="worker threads, 1 .. NUMBA_NUM_THREADS (default: all, "
                          f"here {os.cpu_count() or '?'} cores)")
    run.add_argument("--set", metavar="KEY=VALUE", action="append", default=[], help=SET_HELP)
    run.add_argument("-q", "--quiet", action="store_true",
                     help="print nothing but errors (default: a summary on stdout, progress on a "
                          "terminal's stderr)")
    run.add_argument("--progress", action="store_true",
                     help="show the progress bar (rate, time left) on stderr even when it is not a "
                          "terminal: a line every 5 s")
    run.add_argument("--resume", action="store_true",
                     help="finish an interrupted run of OUTPUT: its finished chunks are kept in "
                          ".OUTPUT.partial beside it (a file, or a Zarr store), and only the others run; refused if the scene "
                          "or sweep differ (without a partial file: an ordinary run)")
    run.add_argument("--chunk-size", metavar="N", default=None,
                     help="trajectories per chunk, the unit of writing, resuming and Dask tasks "
                          "(default: 262144; a resumed run keeps its own)")
    run.add_argument("--scheduler", metavar="ADDRESS", default=None,
                     help="run the chunks on a Dask cluster, one task per chunk: a scheduler address "
                          "(tcp://host:8786), or 'local' to start one worker per core here; needs "
                          "pip install 'rampwork[cluster]'")
    run.set_defaults(handler=cmd_run)

    check = commands.add_parser(
        "check", help="validate a scene file without running it", formatter_class=fmt,
        description="Validate SCENE (every check `run` makes before starting, without compiling "
                    "or running anything) and print the ramp, friction, integrator, the sweep's "
                    "shape and the number of trajectories.  Exit status 0 if valid, 2 if not.")
    check.add_argument("scene", metavar="SCENE.toml", help="scene file to validate (or a dataset "
                       "rampwork wrote: its stored scene)")
    check.add_argument("--set", metavar="KEY=VALUE", action="append", default=[], help=SET_HELP)
    check.set_defaults(handler=cmd_check)

    example = commands.add_parser(
        "example", help="list the example scenes, or print one", formatter_class=fmt,
        description="Without NAME: list the example scenes shipped with rampwork.  With NAME: "
                    f"print that scene file to stdout, e.g. `{prog} example straight > my.toml`.")
    example.add_argument("name", metavar="NAME", nargs="?", default=None,
                         help="example to print (with or without .toml; default: list them)")
    example.set_defaults(handler=cmd_example)

    info = commands.add_parser(
        "info", help="summarise a rampwork netCDF file or Zarr store", formatter_class=fmt,
        description="Print a rampwork result file's title, provenance, dimensions, coordinates "
                    "and variables with their units, end-status counts, timing and the stored "
                    "scene (a scene file that reproduces the run).")
    info.add_argument("dataset", metavar="DATASET.nc", help=f"netCDF file (or .zarr store) written by "
                      f"`{prog} run`")
    info.add_argument("--no-scene", action="store_true", help="do not print the stored scene "
                      "(default: print it)")
    info.set_defaults(handler=cmd_info)

    from .optimise_cli import add_optimise_command
    from .plotting import add_plot_command

    add_optimise_command(commands, fmt)
    add_plot_command(commands)
    return parser


def _error(message: str) -> None:
    print(f"rampwork: error: {' '.join(str(message).split())}", file=sys.stderr, flush=True)


def main(argv: list[str] | None = None) -> int:
    """Run the command line with ``argv`` (default: ``sys.argv[1:]``); returns
    the exit status (0 ok, 2 bad input or usage, 130 interrupted, 143
    terminated by SIGTERM)."""
    try:  # SIGTERM as Ctrl-C: the same cleanup and resume hint (main thread only)
        previous = signal.signal(signal.SIGTERM, _terminate)
    except ValueError:  # pragma: no cover - main() called from another thread
        previous = None
    try:
        with front_end("cli"), warnings.catch_warnings():
            warnings.showwarning = _show_warning
            # said in the summary instead, where `check` and `run` describe the integrator
            warnings.simplefilter("ignore", ClosedFormNotice)
            return _main(argv)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _main(argv: list[str] | None) -> int:
    # the command as typed to start this process; main([...]) from Python: its name
    parser = build_parser(None if argv is None else "rampwork")
    for argument in argv or ():
        if isinstance(argument, str) and "\0" in argument:  # only main([...]) can pass one
            _error(f"argument {argument!r} contains a NUL byte: not a file name or value")
            return EXIT_ERROR
    try:
        try:
            args = parser.parse_args(argv)
        except SystemExit as exit_:  # --help, --version, usage errors
            code = exit_.code
            return code if isinstance(code, int) else (0 if code is None else EXIT_ERROR)
        return args.handler(args)
    except ConfigError as error:
        _error(error)
        return EXIT_ERROR
    except OSError as error:
        if isinstance(error, BrokenPipeError):  # e.g. `rampwork example x | head`
            try:
                sys.stdout = open(os.devnull, "w")  # no second error at exit
            except OSError:  # pragma: no cover
                pass
            return EXIT_OK
        name = f"{error.filename}: " if getattr(error, "filename", None) else ""
        _error(f"{name}{error.strerror or error}")
        return EXIT_ERROR
    except _Terminated:
        _error("terminated (SIGTERM)")
        return EXIT_TERMINATED
    except KeyboardInterrupt:
        _error("interrupted")
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
