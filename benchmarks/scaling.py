#!/usr/bin/env python
"""How a streamed sweep scales with its size: time per trajectory and peak
memory from 10^3 to 10^7 trajectories, one thread against two, and a local
Dask cluster beside the threaded run, and two threads writing without
compression (zlib costs about as much as a cheap trajectory).

Each point runs in a fresh subprocess (``--child``), so its peak resident
memory (``resource.getrusage(...).ru_maxrss``) is its own: the process imports
rampwork, loads the kernel (a one-trajectory warm-up run: the numba disk cache
and the netCDF library are loaded before the measurement), then writes the
sweep to a netCDF file with :func:`rampwork.run_to_file`. Time per trajectory
is the file's ``run_time_s`` (the chunk loop: computing, compressing, writing
and syncing each chunk; compilation excluded) over the number of trajectories;
flat is the goal. The Dask runs start a ``LocalCluster`` (one worker process
per core, one thread each) inside the child; their time includes the workers
loading the kernel, their memory is the client's (the workers hold one chunk
each), and ``workers_peak_mib`` is the largest peak among the reaped workers.

The scene: a block released at rest in a quadratic bowl with friction, paper's
explicit Euler at dt = 1 ms, until it sticks (a few hundred steps); the sweep
is a grid of 10 friction values by N/10 start positions, generated per chunk.

Run from the repository root::

    .venv/bin/python benchmarks/scaling.py            # 10^3 .. 10^7 (a few minutes)
    .venv/bin/python benchmarks/scaling.py --quick    # 10^3 .. 10^5, < 1 min

Prints a table; saves JSON and markdown to benchmarks/results/ and the figure
to benchmarks/figures/scaling.png (``--quick``: results/ only).
"""

from __future__ import annotations

import argparse
import json
import pathlib
import resource
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402

FIGURES_DIR = pathlib.Path(__file__).resolve().parent / "figures"
MODES = ("threads=1", "threads=2", "dask-local", "threads=2 zlib=0")
MU_VALUES = 10
CHUNK_SIZE = 1 << 18  # runner.CHUNK_SIZE: the default


def _scene_and_sweep(n: int):
    import numpy as np

    import rampwork as rw

    scene = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0)),
                     friction=rw.Friction(0.3), x0=-0.9, t_max=10.0,
                     integrator=rw.Integrator("euler", dt=1e-3))
    sweep = rw.Sweep.grid(mu=np.linspace(0.2, 0.4, MU_VALUES), x0=np.linspace(-0.9, -0.5, n // MU_VALUES))
    return scene, sweep


def _peak_mib(who=resource.RUSAGE_SELF) -> float:
    return resource.getrusage(who).ru_maxrss / 1024  # Linux: KiB


def child(n: int, mode: str) -> dict:
    """One measurement, in this (fresh) process."""
    import rampwork as rw

    scene, sweep = _scene_and_sweep(n)
    with tempfile.TemporaryDirectory(prefix="rampwork-scaling-") as directory:
        directory = pathlib.Path(directory)
        threads = None if mode == "dask-local" else int(mode.split()[0].split("=")[1])
        scheduler = "local" if mode == "dask-local" else None
        level = 0 if mode.endswith("zlib=0") else 4
        rw.run_to_file(scene, rw.Sweep.grid(mu=[0.3]), directory / "warm.nc", threads=threads)
        baseline = _peak_mib()
        started = time.perf_counter()
        path = rw.run_to_file(scene, sweep, directory / "run.nc", threads=threads, scheduler=scheduler,
                              compression_level=level)
        wall = time.perf_counter() - started
        peak = _peak_mib()
        attrs = _attrs(path)
        file_mib = path.stat().st_size / 2**20
    return {"n": sweep.size, "mode": mode, "run_time_s": float(attrs["run_time_s"]), "wall_s": wall,
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


def figure(points: list[dict], path: pathlib.Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    sizes = sorted({p["n"] for p in points})
    for mode, marker in zip(MODES, "osd^"):
        mine = sorted((p for p in points if p["mode"] == mode), key=lambda p: p["n"])
        n = [p["n"] for p in mine]
        left.plot(n, [1e6 * p["run_time_s"] / p["n"] for p in mine], marker=marker, label=mode)
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
    args = parser.parse_args()
    if args.child:
        print(json.dumps(child(int(args.child[0]), args.child[1])))
        return

    import rampwork  # noqa: F401 - machine_info reads numba's settings after rampwork sets them

    largest = args.max if args.max is not None else (1e5 if args.quick else 1e7)
    sizes = [10**k for k in range(3, 8) if 10**k <= largest]
    points = []
    for n in sizes:
        for mode in MODES:
            point = run_point(n, mode)
            points.append(point)
            print(f"  {mode:<10} {n:>10,}: {1e6 * point['run_time_s'] / n:8.3f} µs/trajectory, "
                  f"peak {point['peak_mib']:.0f} MiB", flush=True)

    headers = ["trajectories", *(f"µs/traj {m}" for m in MODES), *(f"peak MiB {m}" for m in MODES),
               "results MiB", "file MiB"]
    rows = []
    for n in sizes:
        mine = {p["mode"]: p for p in points if p["n"] == n}
        rows.append([f"{n:,}", *(f"{1e6 * mine[m]['run_time_s'] / n:.3f}" for m in MODES),
                     *(f"{mine[m]['peak_mib']:.0f}" for m in MODES),
                     f"{mine[MODES[0]]['results_mib']:.1f}", f"{mine[MODES[0]]['file_mib']:.1f}"])
    print()
    print(C.text_table(headers, rows))
    stem = f"scaling-{C.timestamp()}" + ("-quick" if args.quick else "")
    data = {"machine": C.machine_info(), "utc": C.utc_now(), "chunk_size": CHUNK_SIZE, "points": points}
    print("saved", C.save_json(C.RESULTS_DIR / f"{stem}.json", data))
    print("saved", C.save_text(C.RESULTS_DIR / f"{stem}.md", C.markdown_table(headers, rows) + "\n"))
    target = C.RESULTS_DIR / f"{stem}.png" if args.quick else FIGURES_DIR / "scaling.png"
    target.parent.mkdir(parents=True, exist_ok=True)
    figure(points, target)
    print("saved", target)


if __name__ == "__main__":
    main()
