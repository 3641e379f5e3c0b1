#!/usr/bin/env python
"""A sweep on a Dask cluster written two ways, side by side: a Zarr store
that each worker writes its chunks into (``-o out.zarr``) against the netCDF
file that the client writes from the results the workers send it (``-o
out.nc``, the way a Dask run wrote before Zarr): wall time, the client's peak
memory (flat in n for Zarr: no results pass through it), the workers' peak,
and whether the two hold the same values bit for bit.

Each point runs in a fresh subprocess (``--child``) that is the Dask client:
it imports rampwork, starts a ``LocalCluster`` of 2 worker processes (one
thread each), runs a 1,000-trajectory warm-up sweep on it (the workers load
the kernel from numba's disk cache and the client loads the netCDF and Zarr
libraries), then runs the sweep with :func:`rampwork.run_to_file` while a
thread samples the client's resident memory every 5 ms (psutil): the client's
growth is the peak during the call less the memory before it (``ru_maxrss``,
the process's high-water mark, is also reported, but it includes building the
sweep). Wall time is the ``run_to_file`` call (the workers' kernel loading for
the new scene included, the cluster's start not). Each mode runs
``--repeat`` times, alternately (ABAB: the machine's other load hits both
alike); the table gives the fastest wall time and the largest growth. The
parent then compares the last two outputs variable by variable, chunk by
chunk, with ``np.array_equal`` (NaNs equal) and checks their attributes,
except those of how the run went.

The scene is scaling.py's: a block released at rest in a quadratic bowl,
Euler at dt = 1 ms until it sticks; a grid of 10 friction values by 10 masses
by n/100 start positions (short axes: a grid's coordinates, and the scene
text that lists them, grow with its axes, not with the results); default
chunks (at most 262,144 trajectories).

    .venv/bin/python benchmarks/zarr_dask.py              # n = 10^5, 10^6, 10^7 (about 5 min on 2 cores)
    .venv/bin/python benchmarks/zarr_dask.py --max 1e6    # n = 10^5, 10^6

Prints a table; saves JSON and markdown to benchmarks/results/.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import resource
import shutil
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402

MODES = {"netcdf-client": "run.nc", "zarr-workers": "run.zarr"}
RUN_ATTRS = {"history", "compile_time_s", "run_time_s", "threads", "scheduler", "kernel_source",
             "kernel_tier"}
WORKERS = 2


def _scene_and_sweep(n: int):
    """scaling.py's scene; a grid of 10 friction values x 10 masses x n/100
    starts (the mass changes no trajectory, only the work's scale): the axes
    stay short, so that what grows with n is the results alone."""
    import numpy as np

    import rampwork as rw

    from scaling import _scene_and_sweep as scaling_scene

    scene, _ = scaling_scene(n)
    sweep = rw.Sweep.grid(mu=np.linspace(0.2, 0.4, 10), m=np.linspace(1.0, 2.0, 10),
                          x0=np.linspace(-0.9, -0.5, n // 100))
    return scene, sweep


def _peak_mib(who=resource.RUSAGE_SELF) -> float:
    return resource.getrusage(who).ru_maxrss / 1024  # Linux: KiB


class _Sampler:
    """The largest resident memory of this process while in the ``with`` block."""

    def __init__(self, interval: float = 0.005):
        import psutil

        self.process, self.interval = psutil.Process(), interval
        self.peak = self.before = self.process.memory_info().rss
        self.stop = threading.Event()

    def _run(self):
        while not self.stop.wait(self.interval):
            self.peak = max(self.peak, self.process.memory_info().rss)

    def __enter__(self):
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join()
        self.peak = max(self.peak, self.process.memory_info().rss)


def child(n: int, mode: str, directory: str) -> dict:
    """One measurement, in this (fresh) process: the Dask client."""
    from distributed import Client, LocalCluster

    import rampwork as rw

    scene, sweep = _scene_and_sweep(n)
    directory = pathlib.Path(directory)
    suffix = pathlib.Path(MODES[mode]).suffix
    with LocalCluster(n_workers=WORKERS, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        warm_scene, warm_sweep = _scene_and_sweep(1000)
        for warm_suffix in (".nc", ".zarr"):  # the kernel on the workers, both formats' libraries here
            rw.run_to_file(warm_scene, warm_sweep, directory / f"warm-{mode}{warm_suffix}", scheduler=client)
        with _Sampler() as sampler:
            started = time.perf_counter()
            path = rw.run_to_file(scene, sweep, directory / MODES[mode], scheduler=client)
            wall = time.perf_counter() - started
        peak = _peak_mib()
    workers = _peak_mib(resource.RUSAGE_CHILDREN)  # the reaped nannies' and workers' largest
    with rw.io.open_lazily(path) as dataset:
        attrs = dict(dataset.attrs)
    size = sum(f.stat().st_size for f in ([path] if path.is_file() else path.rglob("*")) if f.is_file())
    assert suffix == path.suffix
    return {"n": sweep.size, "mode": mode, "wall_s": wall, "run_time_s": float(attrs["run_time_s"]),
            "rss_before_mib": sampler.before / 2**20, "rss_peak_in_run_mib": sampler.peak / 2**20,
            "growth_mib": (sampler.peak - sampler.before) / 2**20, "ru_maxrss_mib": peak,
            "workers_peak_mib": workers,
            "output_mib": size / 2**20, "path": str(path)}


def same_values(first: pathlib.Path, second: pathlib.Path) -> tuple[bool, str]:
    """Whether two outputs hold the same variables, values (bit for bit, by
    chunks of 2^20) and attributes (except how the run went)."""
    import numpy as np

    from rampwork import io

    with io.open_lazily(first) as a, io.open_lazily(second) as b:
        if set(a.variables) != set(b.variables):
            return False, f"variables differ: {sorted(set(a.variables) ^ set(b.variables))}"
        for key in set(a.attrs) | set(b.attrs):
            if key not in RUN_ATTRS and not np.array_equal(np.asarray(a.attrs.get(key)),
                                                           np.asarray(b.attrs.get(key))):
                return False, f"attribute {key} differs"
        for name in a.variables:
            x, y = a[name].variable, b[name].variable
            if x.dims != y.dims or x.dtype != y.dtype or x.shape != y.shape:
                return False, f"{name}: dims, dtype or shape differ"
            flat = int(np.prod(x.shape[1:])) if x.ndim else 1
            step = max(1, (1 << 20) // max(flat, 1))
            for start in range(0, x.shape[0] if x.ndim else 1, step):
                where = (slice(start, start + step),) if x.ndim else ()
                if not np.array_equal(x[where].values, y[where].values, equal_nan=x.dtype.kind == "f"):
                    return False, f"{name} differs at {start}"
    return True, "equal"


def run_point(n: int, mode: str, directory: pathlib.Path) -> dict:
    out = subprocess.run([sys.executable, __file__, "--child", str(n), mode, str(directory)],
                         capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"{mode} at {n}: {out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--max", type=float, default=1e7, help="largest n (default 1e7)")
    parser.add_argument("--repeat", type=int, default=2, help="runs of each mode, alternately (default 2)")
    parser.add_argument("--child", nargs=3, metavar=("N", "MODE", "DIR"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(child(int(args.child[0]), args.child[1], args.child[2])))
        return

    import rampwork  # noqa: F401 - machine_info reads numba's settings after rampwork sets them

    sizes = [10**k for k in range(5, 9) if 10**k <= args.max]
    points, rows = [], []
    for n in sizes:
        directory = pathlib.Path(tempfile.mkdtemp(prefix="rampwork-zarr-dask-"))
        try:
            runs = {mode: [] for mode in MODES}
            for repeat in range(args.repeat):
                for mode in MODES:
                    here = directory / f"{repeat}"
                    here.mkdir(exist_ok=True)
                    point = run_point(n, mode, here)
                    point["repeat"] = repeat
                    runs[mode].append(point)
                    print(f"  {mode:<14} {n:>12,}: wall {point['wall_s']:7.2f} s, client "
                          f"{point['rss_before_mib']:.0f} MiB before the run, +{point['growth_mib']:.1f} MiB "
                          f"in it (ru_maxrss {point['ru_maxrss_mib']:.0f} MiB), workers' peak "
                          f"{point['workers_peak_mib']:.0f} MiB", flush=True)
                if repeat < args.repeat - 1:
                    shutil.rmtree(here)
            equal, why = same_values(pathlib.Path(runs["netcdf-client"][-1]["path"]),
                                     pathlib.Path(runs["zarr-workers"][-1]["path"]))
        finally:
            shutil.rmtree(directory, ignore_errors=True)
        print(f"  {'':<14} {n:>12,}: Zarr written by the workers and netCDF through the client "
              f"bit-identical: {'yes' if equal else 'NO (' + why + ')'}", flush=True)
        for mode, mine in runs.items():
            for point in mine:
                point["bit_identical"], point["comparison"] = equal, why
                points.append(point)
            rows.append([f"{n:,}", mode, " / ".join(f"{p['wall_s']:.2f}" for p in mine),
                         f"{min(p['wall_s'] for p in mine):.2f}",
                         f"{max(p['rss_before_mib'] for p in mine):.0f}",
                         f"{max(p['growth_mib'] for p in mine):.1f}",
                         f"{max(p['workers_peak_mib'] for p in mine):.0f}",
                         f"{mine[-1]['output_mib']:.1f}", "yes" if equal else "NO"])

    headers = ["trajectories", "mode", "wall s (runs)", "best wall s", "client RSS before MiB",
               "client growth in run MiB", "workers' peak MiB", "output MiB", "bit-identical"]
    print()
    print(C.text_table(headers, rows))
    stem = f"zarr_dask-{C.timestamp()}"
    data = {"machine": C.machine_info(), "utc": C.utc_now(), "workers": WORKERS, "threads_per_worker": 1,
            "points": points}
    print("saved", C.save_json(C.RESULTS_DIR / f"{stem}.json", data))
    print("saved", C.save_text(C.RESULTS_DIR / f"{stem}.md", C.markdown_table(headers, rows) + "\n"))
    failed = [p for p in points if not p["bit_identical"]]
    if failed:
        sys.exit(f"not bit-identical: {sorted({p['n'] for p in failed})}")


if __name__ == "__main__":
    main()
