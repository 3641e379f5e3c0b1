#!/usr/bin/env python
"""How a streamed sweep scales with its size: time per trajectory and peak
memory from 10^3 to 10^7 trajectories, one thread against two, and a local
Dask cluster beside the threaded run, and two threads writing without
compression (zlib costs about as much as a cheap trajectory); the same for a
random and a Sobol' design (kept as their recipes, each chunk drawing its own
cases); and `rampwork check` of a 10^8-case design of every kind.

Each point runs in a fresh subprocess (``--child``), so its peak resident
memory (``resource.getrusage(...).ru_maxrss``) is its own: the process imports
rampwork, loads the kernel (a warm-up run of a few trajectories of the same
kind of sweep: the numba disk cache, the netCDF library and, for a Sobol'
design, scipy.stats.qmc are loaded before the measurement), then writes the
sweep to a netCDF file with :func:`rampwork.run_to_file`. Time per trajectory
is the file's ``run_time_s`` (the chunk loop: computing, compressing, writing
and syncing each chunk; compilation excluded) over the number of trajectories,
and the process's CPU time over the whole call (which other work on a shared
machine inflates less than wall time); flat is the goal. The Dask runs start a ``LocalCluster`` (one worker process
per core, one thread each) inside the child; their time includes the workers
loading the kernel, their memory is the client's (the workers hold one chunk
each), and ``workers_peak_mib`` is the largest peak among the reaped workers.

The scene: a block released at rest in a quadratic bowl with friction, paper's
explicit Euler at dt = 1 ms, until it sticks (a few hundred steps); the grid
sweep is 10 friction values by N/10 start positions, generated per chunk; the
designs draw mu and x0 from the grid's ranges (a Sobol' design has the power
of 2 nearest N cases). The designs' time includes drawing their values and
writing them as coordinates (three more variables than the grid's file).

The check: ``python -m rampwork check`` of a scene file with a small design
(10^3 cases) and the largest allowed (10^8; Sobol': 2^10 and 2^26), its wall
time (the best of three) and CPU time and peak RSS as the user meets them
(interpreter start and imports included), from ``os.wait4``: the same at
both sizes, since a design is checked by its ranges.

Run from the repository root::

    .venv/bin/python benchmarks/scaling.py            # 10^3 .. 10^7 (a few minutes)
    .venv/bin/python benchmarks/scaling.py --quick    # 10^3 .. 10^5, < 1 min
    .venv/bin/python benchmarks/scaling.py --modes "threads=2" "random threads=2" "sobol threads=2"

Prints a table; saves JSON and markdown to benchmarks/results/ and the figure
to benchmarks/figures/scaling.png (``--quick`` or a subset of ``--modes``:
results/ only, unless ``--figure`` names it).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import resource
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402

FIGURES_DIR = pathlib.Path(__file__).resolve().parent / "figures"
#: "[DESIGN ]threads=N[ zlib=0]" or "dask-local"; DESIGN: random or sobol (default: the grid)
MODES = ("threads=1", "threads=2", "dask-local", "threads=2 zlib=0", "random threads=2", "sobol threads=2")
DESIGNS = ("random", "sobol")
MU_VALUES = 10
MU_RANGE, X0_RANGE = (0.2, 0.4), (-0.9, -0.5)
CHUNK_SIZE = 1 << 18  # runner.CHUNK_SIZE: the default
#: the designs `rampwork check` is timed on, at the largest size allowed
CHECK_KINDS = ("random", "sobol", "halton", "lhs")
CHECK_TARGET = {"seconds": 2.0, "peak_mib": 300.0}


def _scene_and_sweep(n: int, design: str = "grid"):
    import numpy as np

    import rampwork as rw

    scene = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0)),
                     friction=rw.Friction(0.3), x0=-0.9, t_max=10.0,
                     integrator=rw.Integrator("euler", dt=1e-3))
    if design == "grid":
        sweep = rw.Sweep.grid(mu=np.linspace(*MU_RANGE, MU_VALUES), x0=np.linspace(*X0_RANGE, n // MU_VALUES))
    else:
        size = 1 << round(math.log2(n)) if design == "sobol" else n
        sweep = getattr(rw.Sweep, design)(size, seed=1, mu=MU_RANGE, x0=X0_RANGE)
    return scene, sweep


def _parse_mode(mode: str) -> tuple[str, int | None, int, str | None]:
    """(design, threads, zlib level, scheduler) of a mode."""
    if mode == "dask-local":
        return "grid", None, 4, "local"
    words = mode.split()
    design = words.pop(0) if words[0] in DESIGNS else "grid"
    settings = dict(word.split("=") for word in words)
    return design, int(settings["threads"]), int(settings.get("zlib", 4)), None


def _cpu_s() -> float:
    """This process's CPU seconds, every thread (less sensitive than wall time
    to other work on a shared machine; a Dask run's workers are not in it)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _peak_mib(who=resource.RUSAGE_SELF) -> float:
    return resource.getrusage(who).ru_maxrss / 1024  # Linux: KiB


def child(n: int, mode: str) -> dict:
    """One measurement, in this (fresh) process."""
    import rampwork as rw

    design, threads, level, scheduler = _parse_mode(mode)
    scene, sweep = _scene_and_sweep(n, design)
    with tempfile.TemporaryDirectory(prefix="rampwork-scaling-") as directory:
        directory = pathlib.Path(directory)
        # the same kind of sweep (a Sobol' design loads scipy.stats.qmc), one chunk
        warm = _scene_and_sweep(MU_VALUES, design)[1] if design != "grid" else rw.Sweep.grid(mu=[0.3])
        rw.run_to_file(scene, warm, directory / "warm.nc", threads=threads)
        baseline = _peak_mib()
        cpu_before = _cpu_s()
        started = time.perf_counter()
        path = rw.run_to_file(scene, sweep, directory / "run.nc", threads=threads, scheduler=scheduler,
                              compression_level=level)
        wall = time.perf_counter() - started
        cpu = _cpu_s() - cpu_before
        peak = _peak_mib()
        attrs = _attrs(path)
        file_mib = path.stat().st_size / 2**20
    return {"n": sweep.size, "nominal_n": n, "mode": mode, "design": design, "run_time_s": float(attrs["run_time_s"]), "wall_s": wall,
            "cpu_s": cpu,
            "steps": int(attrs["trajectory_steps"]), "baseline_peak_mib": baseline, "peak_mib": peak,
            "workers_peak_mib": _peak_mib(resource.RUSAGE_CHILDREN) if scheduler else None,
            "file_mib": file_mib, "results_mib": sweep.size * _bytes_per_trajectory() / 2**20}


def _attrs(path) -> dict:
    import netCDF4

    with netCDF4.Dataset(path) as nc:  # attributes only, after the peak was read
        return {name: nc.getncattr(name) for name in nc.ncattrs()}


def _bytes_per_trajectory() -> int:
    from rampwork import schema

    return sum(schema.OUTPUTS[name].np_dtype.itemsize for name in schema.output_names(False))


def run_point(n: int, mode: str) -> dict:
    out = subprocess.run([sys.executable, __file__, "--child", str(n), mode], capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"{mode} at {n}: {out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def check_point(kind: str, n: int, directory: pathlib.Path, repeat: int = 3) -> dict:
    """`rampwork check` of an ``n``-case design of ``kind``, each time in a fresh
    process: the best of ``repeat`` wall times (other load only slows a run
    down), that run's CPU seconds and peak RSS (os.wait4: the child's own)."""
    import rampwork as rw
    from rampwork.scenefile import dump_scene

    scene, _ = _scene_and_sweep(1000)
    sweep = getattr(rw.Sweep, kind)(n, seed=1, log=("v0",), mu=MU_RANGE, x0=X0_RANGE, v0=(0.01, 2.0))
    path = directory / f"check-{kind}-{n}.toml"
    path.write_text(dump_scene(scene, sweep), encoding="utf-8")
    runs = []
    for _ in range(repeat):
        started = time.perf_counter()
        process = subprocess.Popen([sys.executable, "-m", "rampwork", "check", str(path)],
                                   stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        _, status, usage = os.wait4(process.pid, 0)  # this child's own rusage
        seconds = time.perf_counter() - started
        out, err = process.stdout.read().decode(), process.stderr.read().decode()
        process.returncode = os.waitstatus_to_exitcode(status)
        if process.returncode != 0 or f"trajectories  {n:,}" not in out:
            raise RuntimeError(f"rampwork check of a {kind} design failed: {err[-2000:]}")
        runs.append({"seconds": seconds, "cpu_s": usage.ru_utime + usage.ru_stime,
                     "peak_mib": usage.ru_maxrss / 1024})
    best = min(runs, key=lambda run: run["seconds"])
    return {"kind": kind, "n": n, **best, "runs": runs, "scene_bytes": path.stat().st_size}


def check_sizes(kind: str) -> tuple[int, int]:
    """A small design and the largest allowed (Sobol': powers of 2)."""
    from rampwork.validate import MAX_AXIS_POINTS

    if kind == "sobol":
        return 1 << 10, 1 << (MAX_AXIS_POINTS.bit_length() - 1)
    return 10**3, MAX_AXIS_POINTS


def figure(points: list[dict], path: pathlib.Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    sizes = sorted({p["n"] for p in points})
    modes = list(dict.fromkeys(p["mode"] for p in points))
    for mode, marker in zip(modes, "osd^vP*X"):
        mine = sorted((p for p in points if p["mode"] == mode), key=lambda p: p["n"])
        n = [p["n"] for p in mine]
        line, = left.plot(n, [1e6 * p["run_time_s"] / p["n"] for p in mine], marker=marker, label=mode)
        if all("cpu_s" in p for p in mine) and not mode.startswith("dask"):
            left.plot(n, [1e6 * p["cpu_s"] / p["n"] for p in mine], ls="--", marker=marker, mfc="none",
                      color=line.get_color(), label=f"{mode}: CPU time")
        right.plot(n, [p["peak_mib"] for p in mine], marker=marker, label=f"{mode}: peak RSS")
    right.plot(sizes, [s * _bytes_per_trajectory() / 2**20 for s in sizes], "k--",
               label="the results held in memory")
    left.set(xscale="log", yscale="log", xlabel="trajectories", ylabel="run time per trajectory (µs)",
             title="(a) time per trajectory (flat is the goal)")
    right.set(xscale="log", yscale="log", xlabel="trajectories", ylabel="MiB",
              title="(b) peak memory of the writing process")
    for axis in (left, right):
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=8)
    fig.suptitle("rampwork.run_to_file: quadratic bowl, Euler dt = 1 ms, until stuck; "
                 f"chunks of {CHUNK_SIZE:,}", fontsize=10)
    fig.savefig(path, dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="10^3 .. 10^5 only")
    parser.add_argument("--child", nargs=2, metavar=("N", "MODE"), help=argparse.SUPPRESS)
    parser.add_argument("--max", type=float, default=None, help="largest size (default 1e7; 1e5 with --quick)")
    parser.add_argument("--modes", nargs="+", choices=MODES, default=list(MODES), metavar="MODE",
                        help=f"which runs (default all: {', '.join(map(repr, MODES))})")
    parser.add_argument("--no-check", action="store_true", help="skip the timed `rampwork check` of 10^8 cases")
    parser.add_argument("--figure", type=pathlib.Path, default=None, help="where to save the figure")
    args = parser.parse_args()
    if args.child:
        print(json.dumps(child(int(args.child[0]), args.child[1])))
        return

    import rampwork  # noqa: F401 - machine_info reads numba's settings after rampwork sets them

    modes = list(dict.fromkeys(args.modes))
    largest = args.max if args.max is not None else (1e5 if args.quick else 1e7)
    sizes = [10**k for k in range(3, 8) if 10**k <= largest]
    points = []
    for n in sizes:
        for mode in modes:
            point = run_point(n, mode)
            points.append(point)
            print(f"  {mode:<16} {point['n']:>10,}: {1e6 * point['run_time_s'] / point['n']:8.3f} "
                  f"µs/trajectory ({1e6 * point['cpu_s'] / point['n']:.3f} CPU), "
                  f"peak {point['peak_mib']:.0f} MiB", flush=True)

    headers = ["trajectories", *(f"µs/traj {m}" for m in modes), *(f"CPU µs/traj {m}" for m in modes),
               *(f"peak MiB {m}" for m in modes), "results MiB", "file MiB"]
    rows = []
    for n in sizes:
        mine = {p["mode"]: p for p in points if p["nominal_n"] == n}
        rows.append([f"{n:,}", *(f"{1e6 * mine[m]['run_time_s'] / mine[m]['n']:.3f}" for m in modes),
                     *(f"{1e6 * mine[m]['cpu_s'] / mine[m]['n']:.3f}" for m in modes),
                     *(f"{mine[m]['peak_mib']:.0f}" for m in modes),
                     f"{mine[modes[0]]['results_mib']:.1f}", f"{mine[modes[0]]['file_mib']:.1f}"])
    print()
    print(C.text_table(headers, rows))
    if any(_parse_mode(m)[0] == "sobol" for m in modes):
        print("(Sobol' designs: the power of 2 nearest each size, "
              + ", ".join(f"{n:,}" for n in sorted({p["n"] for p in points if p["design"] == "sobol"})) + ")")

    checks = []
    if not args.no_check:
        with tempfile.TemporaryDirectory(prefix="rampwork-check-") as directory:
            checks = [check_point(kind, n, pathlib.Path(directory))
                      for kind in CHECK_KINDS for n in check_sizes(kind)]
        check_headers = ["design", "cases", "scene file bytes", "check s (best of 3)", "CPU s",
                         "peak MiB", "target"]
        check_rows = [[c["kind"], f"{c['n']:,}", str(c["scene_bytes"]), f"{c['seconds']:.2f}",
                       f"{c['cpu_s']:.2f}", f"{c['peak_mib']:.0f}",
                       "PASS" if c["seconds"] < CHECK_TARGET["seconds"] and c["peak_mib"] < CHECK_TARGET["peak_mib"]
                       else "FAIL"] for c in checks]
        print()
        print(f"`rampwork check` of a small and the largest design of each kind (target: "
              f"< {CHECK_TARGET['seconds']:g} s, < {CHECK_TARGET['peak_mib']:g} MB; interpreter start and imports "
              "included):")
        print(C.text_table(check_headers, check_rows))

    stem = f"scaling-{C.timestamp()}" + ("-quick" if args.quick else "")
    data = {"machine": C.machine_info(), "utc": C.utc_now(), "chunk_size": CHUNK_SIZE, "points": points,
            "checks": checks, "check_target": CHECK_TARGET}
    print("saved", C.save_json(C.RESULTS_DIR / f"{stem}.json", data))
    text = C.markdown_table(headers, rows) + "\n"
    if checks:
        text += "\n" + C.markdown_table(check_headers, check_rows) + "\n"
    print("saved", C.save_text(C.RESULTS_DIR / f"{stem}.md", text))
    if points:
        partial = args.quick or set(modes) != set(MODES)
        target = args.figure or (C.RESULTS_DIR / f"{stem}.png" if partial else FIGURES_DIR / "scaling.png")
        target.parent.mkdir(parents=True, exist_ok=True)
        figure(points, target)
        print("saved", target)


if __name__ == "__main__":
    main()
