"""The command line on curve scenes (docs/physics.md §5): what ``run`` and
``check`` of a scene file with a ``[curve]`` table add to a ramp scene's.
A curve scene runs chunk by chunk to its output as a ramp scene does
(:mod:`rampwork.curve_chunks`): ``--chunk-size``, ``--resume``,
``--scheduler`` and ``--threads`` work alike.
"""

from __future__ import annotations

from .curve_scene import check
from .errors import ConfigError
from .terminal import check_lines, sweep_shape

EXIT_OK = 0


def _checked(path: str, scene, sweep):
    """Every check a curve run makes, before any work; errors name the file."""
    try:
        return check(scene, sweep)
    except ConfigError as error:
        raise ConfigError(path, f"{error.where}: {error.problem}") from None


def curve_heading(args, scene, sweep) -> str:
    """Every check of ``run`` on a curve scene (errors name the file), and the
    run's first line; the run itself is a ramp scene's (``cli.cmd_run``:
    chunks, ``--resume``, ``--scheduler``, ``--threads``)."""
    sweep = _checked(args.scene, scene, sweep)
    return (f"{scene.title}: {sweep.size:,} trajectories ({sweep_shape(sweep)}) on a "
            f"{scene.curve.family} curve, {scene.integrator.describe()}")


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
