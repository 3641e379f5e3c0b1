"""The command line on curve scenes (docs/physics.md §5): ``run`` and ``check``
of a scene file with a ``[curve]`` table.  A curve scene runs in memory in
one piece and is written at once, atomically; chunking, resuming and Dask
are for ramp scenes.
"""

from __future__ import annotations

from . import io
from .curve_scene import check, simulate_curve_scene
from .core.threads import using_threads
from .errors import ConfigError
from .runner import thread_count
from .terminal import check_lines, format_counts, format_seconds, si, status_counts, sweep_shape
from .zarrstore import write_zarr

EXIT_OK = 0


def _checked(path: str, scene, sweep):
    """Every check a curve run makes, before any work; errors name the file."""
    try:
        return check(scene, sweep)
    except ConfigError as error:
        raise ConfigError(path, f"{error.where}: {error.problem}") from None


def run_curve(args, scene, sweep) -> int:
    """``run`` on a curve scene: in memory (in SIMD lanes over ``--threads``
    threads), then written at once, atomically."""
    for given, name in ((args.resume, "--resume"), (args.chunk_size, "--chunk-size"),
                        (args.scheduler, "--scheduler")):
        if given:
            raise ConfigError(name, "not for curve scenes yet: they run in one piece, in memory")
    sweep = _checked(args.scene, scene, sweep)
    zarr = io.output_format(args.output) == "zarr"
    io.check_writable(args.output, args.overwrite, store=zarr)
    if not args.quiet:
        print(f"{scene.title}: {sweep.size:,} trajectories ({sweep_shape(sweep)}) on a "
              f"{scene.curve.family} curve, {scene.integrator.describe()}", flush=True)
    with using_threads(thread_count(args.threads)):
        dataset = simulate_curve_scene(scene, sweep)
    output = (write_zarr if zarr else io.write_netcdf)(dataset, args.output, overwrite=args.overwrite)
    if args.quiet:
        return EXIT_OK
    attrs = dataset.attrs
    run_s, steps = float(attrs["run_time_s"]), int(attrs["trajectory_steps"])
    rate = (f"{si(steps / run_s)} trajectory-steps/s" if run_s > 0 else "trajectory-steps/s n/a")
    print(f"trajectories  {sweep.size:,}")
    print(f"kernel        {attrs['kernel_effects']}")
    print(f"compile time  {format_seconds(float(attrs['compile_time_s']))}")
    print(f"run time      {format_seconds(run_s)}  ({rate}, {steps:,} steps)")
    print(f"status        {format_counts(status_counts(dataset['status'].values))}")
    print(f"wrote         {output}")
    return EXIT_OK


def check_curve(args, scene, sweep) -> int:
    sweep = _checked(args.scene, scene, sweep)
    curve = scene.curve
    params = ", ".join(f"{k} = {v!r}" for k, v in curve.params)
    print(f"{args.scene}: OK")
    print(f"title         {scene.title}")
    print(f"curve         {curve.family} ({params}), block on the {curve.side} side")
    physics, sweep_lines = check_lines(scene, sweep, sweep.shape, sweep.size)
    print("\n".join(physics))
    print(f"integrator    {scene.integrator.describe()}, t_max = {scene.t_max!r} s")
    print("\n".join(sweep_lines))
    return EXIT_OK
