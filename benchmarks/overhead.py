#!/usr/bin/env python
"""What `rw.simulate` costs beyond its kernel (issue 19, item 1): for each
method and sweep size, the wall time of the call, the kernel's own
``run_time_s`` (the chunk loop), their ratio, and where the rest goes.

The scene: throughput.py's kind of bowl (quadratic, curvature 1, domain
[-1, 1], friction), t_max = 2 s, fixed-step methods at dt = 1 ms and the
adaptive ones at rtol = 1e-6; an explicit case list (``Sweep.cases``) of
n random starts (mu, x0, v0), the sweep built before the timed call (as a
user holds their cases). Each point: the kernel warmed on the same scene
first (its specialised kernel, compilation excluded: what ``auto`` runs once
a first long run has handed over to it), then the best of ``--repeat`` calls
(wall time, and that call's ``run_time_s``).

The stage breakdown is taken on one more call with the runner's stages
wrapped in timers (a few microseconds each): ``plan`` (plan_run and the
memory check), ``prepare`` (loading the compiled kernel, warming it on one
trajectory), ``layout`` (the dataset's coordinates and output arrays),
``inputs`` (per-trajectory parameters: axis_values, chunk_inputs),
``kernel`` (the compiled batch), ``reduce`` (the per-trajectory outputs),
``attributes`` (the global attributes, the stored scene among them) and
``other`` (the rest: the xarray Dataset, thread pools, ...). Outside the
kernel = wall - kernel; a least-squares line through the three sizes gives
the fixed per-call cost and the cost per trajectory outside the kernel.

Run from the repository root::

    .venv/bin/python benchmarks/overhead.py            # 2e3, 2e4, 2e5 cases, every method
    .venv/bin/python benchmarks/overhead.py --sizes 2000 20000 --methods rk4 --repeat 3

Prints a table; saves JSON and markdown to benchmarks/results/.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import pathlib
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402

METHODS = ("euler", "semi_implicit_euler", "rk4", "dopri5", "dop853")
SIZES = (2_000, 20_000, 200_000)
STAGES = ("plan", "prepare", "layout", "inputs", "kernel", "reduce", "attributes")


def scene_for(method: str):
    import rampwork as rw

    integrator = (rw.Integrator(method, rtol=1e-6) if method in ("dopri5", "dop853")
                  else rw.Integrator(method, dt=1e-3))
    return rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0)),
                    friction=rw.Friction(0.2), x0=-0.9, t_max=2.0, integrator=integrator,
                    title="overhead bowl")


def cases(n: int, seed: int = 0):
    import rampwork as rw

    rng = np.random.default_rng(seed)
    return rw.Sweep.cases(mu=rng.uniform(0.05, 0.6, n), x0=rng.uniform(-0.9, 0.9, n),
                          v0=rng.uniform(-1.5, 1.5, n))


@contextlib.contextmanager
def stage_timers():
    """The runner's stages wrapped in timers; yields name -> seconds."""
    from rampwork import runner

    seconds = dict.fromkeys(STAGES, 0.0)
    saved = {}

    def timed(stage, function):
        def wrapper(*args, **kwargs):
            started = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                seconds[stage] += time.perf_counter() - started
        return wrapper

    def patch(name, stage):
        saved[name] = getattr(runner, name)
        setattr(runner, name, timed(stage, saved[name]))

    for name, stage in (("plan_run", "plan"), ("check_memory", "plan"), ("dataset_layout", "layout"),
                        ("empty_results", "layout"), ("axis_values", "inputs"),
                        ("chunk_inputs", "inputs"), ("reduce_outputs", "reduce"),
                        ("attributes", "attributes")):
        patch(name, stage)
    prepare = runner.prepare
    saved["prepare"] = prepare

    def timed_prepare(*args, **kwargs):
        started = time.perf_counter()
        prepared = prepare(*args, **kwargs)
        seconds["prepare"] += time.perf_counter() - started
        return dataclasses.replace(prepared, run_batch=timed("kernel", prepared.run_batch))

    runner.prepare = timed_prepare
    try:
        yield seconds
    finally:
        for name, function in saved.items():
            setattr(runner, name, function)


def measure(method: str, n: int, repeat: int, threads: int | None) -> dict:
    import rampwork as rw

    scene, sweep = scene_for(method), cases(n)
    # the specialised kernel loaded (compiled or from numba's disk cache) and warm:
    # "auto" then takes it, as it does once a first long run has handed over to it
    rw.simulate(scene, cases(64, seed=1), threads=threads, kernel="specialised")
    best = None
    for _ in range(repeat):
        started = time.perf_counter()
        ds = rw.simulate(scene, sweep, threads=threads)
        wall = time.perf_counter() - started
        if best is None or wall < best[0]:
            best = (wall, float(ds.attrs["run_time_s"]), int(ds.attrs["trajectory_steps"]),
                    str(ds.attrs["kernel_tier"]))
    wall, run, steps, tier = best
    with stage_timers() as stages:
        started = time.perf_counter()
        ds = rw.simulate(scene, sweep, threads=threads)
        staged_wall = time.perf_counter() - started
    stages = dict(stages)
    stages["other"] = staged_wall - sum(stages.values())
    return {"method": method, "n": n, "wall_s": wall, "run_time_s": run, "ratio": wall / run,
            "outside_kernel_s": wall - run, "trajectory_steps": steps, "kernel_tier": tier,
            "stored_scene_bytes": len(ds.attrs["rampwork_scene"]),
            "staged_wall_s": staged_wall, "stages_s": stages}


def fit(points: list[dict]) -> dict:
    """Outside-kernel seconds = fixed + per_trajectory * n (least squares)."""
    n = np.array([p["n"] for p in points], dtype=float)
    outside = np.array([p["outside_kernel_s"] for p in points])
    if len(n) < 2:
        return {"fixed_s": float(outside[0]), "per_trajectory_s": None}
    slope, intercept = np.polyfit(n, outside, 1)
    return {"fixed_s": float(intercept), "per_trajectory_s": float(slope)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    parser.add_argument("--sizes", nargs="+", type=lambda s: int(float(s)), default=list(SIZES))
    parser.add_argument("--repeat", type=int, default=5, help="calls per point; the best is kept")
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--label", default="", help="added to the result files' names")
    parser.add_argument("--out", type=pathlib.Path, default=C.RESULTS_DIR,
                        help="folder for the JSON and markdown results (default benchmarks/results)")
    args = parser.parse_args(argv)

    import rampwork  # noqa: F401 - machine_info reads numba's settings after rampwork sets them

    points, fits = [], {}
    for method in args.methods:
        mine = []
        for n in args.sizes:
            point = measure(method, n, args.repeat, args.threads)
            mine.append(point)
            stages = " ".join(f"{k} {v * 1e3:.1f}" for k, v in point["stages_s"].items())
            print(f"{method:<20} n {n:>8,}  wall {point['wall_s'] * 1e3:8.2f} ms  run_time_s "
                  f"{point['run_time_s'] * 1e3:8.2f} ms  ratio {point['ratio']:.3f}  [ms: {stages}]",
                  flush=True)
        points += mine
        fits[method] = fit(mine)

    headers = ["method", "n", "wall ms", "run_time_s ms", "ratio", "outside kernel ms"] + \
        [f"{s} ms" for s in STAGES + ("other",)]
    rows = [[p["method"], f"{p['n']:,}", f"{p['wall_s'] * 1e3:.2f}", f"{p['run_time_s'] * 1e3:.2f}",
             f"{p['ratio']:.3f}", f"{p['outside_kernel_s'] * 1e3:.2f}"]
            + [f"{p['stages_s'][s] * 1e3:.2f}" for s in STAGES + ("other",)] for p in points]
    fit_rows = [[m, f"{f['fixed_s'] * 1e3:.2f}",
                 "" if f["per_trajectory_s"] is None else f"{f['per_trajectory_s'] * 1e9:.1f}"]
                for m, f in fits.items()]
    fit_headers = ["method", "fixed ms (outside kernel)", "ns per trajectory (outside kernel)"]
    print()
    print(C.text_table(headers, rows))
    print()
    print(C.text_table(fit_headers, fit_rows))
    worst = max((p["ratio"] for p in points if p["n"] >= 20_000), default=None)
    if worst is not None:
        print(f"\nworst wall / run_time_s at n >= 2e4: {worst:.3f} (target <= 1.5)")

    stem = f"overhead-{C.timestamp()}" + (f"-{args.label}" if args.label else "")
    data = {"machine": C.machine_info(), "utc": C.utc_now(), "repeat": args.repeat,
            "threads": args.threads, "points": points, "fits": fits}
    print("saved", C.save_json(args.out / f"{stem}.json", data))
    text = (f"# rw.simulate overhead ({C.utc_now()})\n\n" + C.markdown_table(headers, rows) + "\n\n"
            + C.markdown_table(fit_headers, fit_rows) + "\n")
    print("saved", C.save_text(args.out / f"{stem}.md", text))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
