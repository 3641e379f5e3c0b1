"""The curve kernel beside the y = f(x) kernel on the same physical ramp (issue 20).

Same starts, same method, same dt (or rtol), same run, interleaved:

* ``graph:FAMILY``: a ramp y = f(x) through ``rw.simulate`` (the SIMD lane
  kernel, its specialised tier) and the same ramp wrapped as a curve
  (``Curve.from_ramp``, position parameter x) through the curve kernel;
* ``arc:circular_bowl``: the circular bowl of radius R as y = f(x) against
  the ``loop`` family on the same arc (entry/exit angles +-asin(1/R), s0 =
  R asin(x0/R)).

Speeds convert as u0 = v0 sqrt(1 + f'(x0)^2) (``Curve.evaluate``'s dp/ds).
Each pair's outcomes are compared: the share of equal statuses, and over
trajectories with equal status the largest difference in x_end (X_end),
W_friction and t_end (the method's accuracy, not rounding: the two kernels
integrate different state variables).  Rates are trajectory-steps per
second (accepted steps / kernel time, best of ``--repeat`` interleaved
rounds; ``--cpu-time``: the process's CPU time of the call, steadier on a
shared machine with 1 thread, but for y = f(x) the whole ``rw.simulate`` call
against the curve kernel's call alone); the ratio is y = f(x) / curve, the median of
the per-round ratios beside the ratio of the bests.  Both kernels run in SIMD
lanes and are timed on ``--threads`` (default 1 and 2); the curve kernel's
scalar reference (``vector=False``: every step alone, the same results bit
for bit) is timed on 1 thread beside them, for the lanes' speed-up.
Compile times are taken apart, on the first call, in a fresh NUMBA_CACHE_DIR
(a temporary folder, removed at the end).

``--baseline SRC`` also times the y = f(x) kernel of another source tree
(e.g. a clean worktree of the commit before curves) against this tree's, each
in its own subprocess, alternating, same starts: "no extra cost to scenes
that do not use curves".  ``--scalar-lanes`` adds this tree's y = f(x)
kernel with LLVM's loop and SLP vectorisers off: how much of the gap is SIMD.

    PYTHONPATH=src python benchmarks/curves.py [--n 10000] [--methods euler,rk4,dopri5]
        [--cases graph:quadratic,graph:circular_bowl,graph:sine,arc:circular_bowl]
        [--repeat 3] [--cpu-time] [--threads 1,2] [--baseline /tmp/cbench-base/src]
        [--scalar-lanes]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402

DOMAIN = (-1.0, 1.0)
G = 9.81
#: (family, parameters): bowls and a wave about 1 m wide (as families.py)
RAMPS = {
    "quadratic": dict(curvature=1.0),
    "circular_bowl": dict(radius=2.0),
    "sine": dict(amplitude=0.1, wavenumber=6.0, phase=0.3),
}
DEFAULT_CASES = "graph:quadratic,graph:circular_bowl,graph:sine,arc:circular_bowl"


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=10_000, help="random starts (default %(default)s)")
    p.add_argument("--dt", type=float, default=1e-3, help="fixed step, and the adaptive first step")
    p.add_argument("--rtol", type=float, default=1e-6, help="the adaptive methods' rtol (= atol)")
    p.add_argument("--t-max", type=float, default=5.0)
    p.add_argument("--methods", default="euler,rk4,dopri5")
    p.add_argument("--cases", default=DEFAULT_CASES,
                   help="comma-separated graph:FAMILY or arc:circular_bowl (default %(default)s)")
    p.add_argument("--threads", default="1,2", help="threads of both kernels")
    p.add_argument("--repeat", type=int, default=3, help="interleaved rounds; best of them")
    p.add_argument("--cpu-time", action="store_true",
                   help="time by the process's CPU time (meaningful with 1 thread)")
    p.add_argument("--baseline", type=pathlib.Path, default=None,
                   help="a rampwork src folder whose y = f(x) kernel to time against this tree's")
    p.add_argument("--scalar-lanes", action="store_true",
                   help="also time this tree's y = f(x) kernel compiled without vectorisation")
    p.add_argument("--seed", type=int, default=20)
    p.add_argument("--graph-only", action="store_true", help=argparse.SUPPRESS)  # subprocess mode
    p.add_argument("--out", type=pathlib.Path, default=C.RESULTS_DIR)
    return p.parse_args(argv)


def starts(args):
    import numpy as np

    rng = np.random.default_rng(args.seed)
    return (rng.uniform(-0.9, 0.9, args.n), rng.uniform(-4.0, 4.0, args.n),
            rng.uniform(0.02, 0.3, args.n))


def ramp_scene(family: str, method: str, args):
    import rampwork as rw

    integrator = (rw.Integrator(method, rtol=args.rtol) if method in ("dopri5", "dop853")
                  else rw.Integrator(method, dt=args.dt))
    ramp = rw.Ramp.create(family, domain=DOMAIN, **RAMPS[family])
    return rw.Scene(ramp=ramp, friction=rw.Friction(mu_k=0.2), g=G, t_max=args.t_max,
                    integrator=integrator)


def time_graph(scene, sweep, threads: int, cpu_time: bool):
    """(steps, seconds, dataset) of one rw.simulate call on the specialised kernel."""
    import rampwork as rw

    started = time.process_time()
    ds = rw.simulate(scene, sweep, threads=threads, kernel=C.KERNEL)
    seconds = time.process_time() - started if cpu_time else ds.attrs["run_time_s"]
    assert ds.attrs["kernel_tier"] == "specialised", ds.attrs["kernel_tier"]
    return int(ds.attrs["trajectory_steps"]), seconds, ds


def curve_run(case: str, method: str, args, x0, v0, mu, vector: bool = True):
    """The prepared curve run of ``case`` on the same starts."""
    import numpy as np

    import rampwork as rw
    from rampwork.curves import Curve, prepare_curve_run

    kind, family = case.split(":")
    ramp = rw.Ramp.create(family, domain=DOMAIN, **RAMPS[family])
    wrapped = Curve.from_ramp(ramp)
    u0 = v0 / wrapped.evaluate(x0)["dp_ds"]  # dx/ds = 1 / sqrt(1 + f'^2)
    if kind == "graph":
        curve, s0 = wrapped, x0
    elif kind == "arc" and family == "circular_bowl":
        radius = RAMPS[family]["radius"]
        edge = math.asin(DOMAIN[1] / radius)
        curve = Curve.create("loop", radius=radius, entry_angle=-edge, exit_angle=edge)
        s0 = radius * np.arcsin(x0 / radius)
    else:
        raise SystemExit(f"unknown case {case!r}: graph:FAMILY or arc:circular_bowl")
    return prepare_curve_run(curve, s0=s0, u0=u0, mu_k=mu, g=G, method=method, dt=args.dt,
                             t_max=args.t_max, rtol=args.rtol, vector=vector,
                             kernel="specialised")


def time_curve(run, cpu_time: bool, threads: int = 1):
    """(steps, seconds, outputs) of one curve-kernel call on ``threads`` threads."""
    from rampwork.core import curve_kernel
    from rampwork.core.threads import using_threads

    out, status = curve_kernel.empty_outputs(run.inputs.shape[1])
    started, cpu = time.perf_counter(), time.process_time()
    with using_threads(threads):
        run.kernel(run.inputs, run.shared, *run.arguments, out, status)
    seconds = time.process_time() - cpu if cpu_time else time.perf_counter() - started
    result = {name: out[k] for k, name in enumerate(curve_kernel.OUTPUTS)}
    result["status"] = status
    return int(out[curve_kernel.O_STEPS].sum()), seconds, result


def agreement(ds, curve_out) -> dict:
    """How far the two kernels' outcomes are apart."""
    import numpy as np

    same = ds["status"].values == curve_out["status"]
    def gap(graph_name, curve_name):
        a, b = ds[graph_name].values[same], curve_out[curve_name][same]
        return float(np.max(np.abs(a - b))) if same.any() else None
    return {"status_equal": float(same.mean()), "status_differ": int((~same).sum()),
            "max_dx_end": gap("x_end", "X_end"), "max_dW_friction": gap("W_friction", "W_friction"),
            "max_dt_end": gap("t_end", "t_end")}


def measure_graph_only(args) -> dict:
    """The y = f(x) kernel alone (the subprocess of --baseline / --scalar-lanes)."""
    import rampwork as rw

    x0, v0, mu = starts(args)
    sweep = rw.Sweep.cases(x0=x0, v0=v0, mu=mu)
    families = sorted({case.split(":")[1] for case in args.cases.split(",")})
    runs = {}
    for method in args.methods.split(","):
        for family in families:
            scene = ramp_scene(family, method, args)
            compile_s = rw.simulate(scene, rw.Sweep.cases(x0=[0.1], v0=[0.0], mu=[0.1]),
                                    kernel=C.KERNEL).attrs["compile_time_s"]
            for threads in map(int, args.threads.split(",")):
                best = min(time_graph(scene, sweep, threads, args.cpu_time)[:2]
                           for _ in range(args.repeat))
                runs[f"{method}/{family}/{threads}"] = {
                    "steps": best[0], "seconds": best[1], "steps_per_s": best[0] / best[1],
                    "compile_s": compile_s}
    return {"rampwork": rw.__file__, "runs": runs}


def measure(args) -> dict:
    """Every case and method, y = f(x) and curve interleaved round by round."""
    import numpy as np

    import rampwork as rw

    x0, v0, mu = starts(args)
    sweep = rw.Sweep.cases(x0=x0, v0=v0, mu=mu)
    thread_counts = list(map(int, args.threads.split(",")))
    pairs = {}
    for method in args.methods.split(","):
        for case in args.cases.split(","):
            family = case.split(":")[1]
            scene = ramp_scene(family, method, args)
            graph_compile = rw.simulate(scene, rw.Sweep.cases(x0=[0.1], v0=[0.0], mu=[0.1]),
                                        kernel=C.KERNEL).attrs["compile_time_s"]
            compiled = {}
            for vector in (True, False):
                run = curve_run(case, method, args, x0, v0, mu, vector=vector)
                started = time.perf_counter()
                run.compile()
                compiled[vector] = (run, time.perf_counter() - started)
            pairs[f"{method}/{case}"] = {
                "method": method, "case": case, "scene": scene, "run": compiled[True][0],
                "scalar_run": compiled[False][0], "graph_compile_s": graph_compile,
                "curve_compile_s": compiled[True][1], "scalar_compile_s": compiled[False][1],
                "graph": {t: [] for t in thread_counts}, "curve": {t: [] for t in thread_counts},
                "scalar": []}
    for round_ in range(args.repeat):
        for key, pair in pairs.items():
            # alternate which side goes first, so a slow spell does not favour one
            order = ("graph", "curve", "scalar") if round_ % 2 == 0 else ("scalar", "curve", "graph")
            for side in order:
                if side == "scalar":
                    steps, seconds, out = time_curve(pair["scalar_run"], args.cpu_time)
                    pair["scalar"].append(seconds)
                    lanes = pair.get("curve_out", out)
                    pair["scalar_identical"] = all(  # the same bits (NaN included)
                        np.array_equal(np.asarray(out[k]).view(np.uint8),
                                       np.asarray(lanes[k]).view(np.uint8)) for k in out)
                    continue
                for threads in thread_counts:
                    if side == "curve":
                        steps, seconds, out = time_curve(pair["run"], args.cpu_time, threads)
                        pair["curve"][threads].append(seconds)
                        pair["curve_steps"], pair["curve_out"] = steps, out
                    else:
                        steps, seconds, ds = time_graph(pair["scene"], sweep, threads, args.cpu_time)
                        pair["graph"][threads].append(seconds)
                        pair["graph_steps"], pair["graph_ds"] = steps, ds
        print(f"  round {round_ + 1}/{args.repeat} done", flush=True)
    results = {}
    for key, pair in pairs.items():
        curve_steps = pair["curve_steps"]
        entry = {"method": pair["method"], "case": pair["case"],
                 "graph_compile_s": pair["graph_compile_s"],
                 "curve_compile_s": pair["curve_compile_s"],
                 "scalar_compile_s": pair["scalar_compile_s"],
                 "graph_steps": pair["graph_steps"], "curve_steps": curve_steps,
                 "scalar_steps_per_s": curve_steps / min(pair["scalar"]),
                 "lanes_over_scalar": statistics.median(
                     s / c for s, c in zip(pair["scalar"], pair["curve"][thread_counts[0]])),
                 "scalar_identical": pair["scalar_identical"], "graph": {}, "curve": {},
                 "agreement": agreement(pair["graph_ds"], pair["curve_out"])}
        for threads in thread_counts:
            graph_s, curve_s = pair["graph"][threads], pair["curve"][threads]
            rate = pair["graph_steps"] / min(graph_s)
            curve_rate = curve_steps / min(curve_s)
            per_round = [(pair["graph_steps"] / g) / (curve_steps / c)
                         for g, c in zip(graph_s, curve_s)]
            entry["curve"][threads] = curve_rate
            entry.setdefault("curve_steps_per_s", curve_rate)  # at the first --threads count
            entry["graph"][threads] = {"steps_per_s": rate, "ratio_of_bests": rate / curve_rate,
                                       "ratio_median": statistics.median(per_round)}
        results[key] = entry
    return {"rampwork": rw.__file__, "machine": C.machine_info(), "pairs": results}


def graph_subprocess(args, src: pathlib.Path, cache: pathlib.Path, extra_env=None) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src.resolve()), NUMBA_CACHE_DIR=str(cache),
               **(extra_env or {}))
    argv = [sys.executable, __file__, "--graph-only", "--n", str(args.n), "--dt", str(args.dt),
            "--rtol", str(args.rtol), "--t-max", str(args.t_max), "--methods", args.methods,
            "--cases", args.cases, "--threads", args.threads, "--repeat", str(args.repeat),
            "--seed", str(args.seed), *(["--cpu-time"] if args.cpu_time else [])]
    done = subprocess.run(argv, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"subprocess on {src} failed:\n{done.stderr[-3000:]}")
    line = [ln for ln in done.stdout.splitlines() if ln.startswith("RESULT ")][-1]
    return json.loads(line[len("RESULT "):])


def compare_trees(args, cache_root: pathlib.Path) -> dict:
    """y = f(x) steps/s per tree, best over --repeat alternating subprocess rounds."""
    here = pathlib.Path(__file__).resolve().parents[1] / "src"
    trees = {"this tree": (here, {})}
    if args.baseline is not None:
        trees["baseline"] = (args.baseline, {})
    if args.scalar_lanes:
        trees["scalar lanes"] = (here, {"NUMBA_LOOP_VECTORIZE": "0", "NUMBA_SLP_VECTORIZE": "0"})
    sub_args = argparse.Namespace(**{**vars(args), "repeat": 1})
    best: dict = {}
    names = list(trees)
    for round_ in range(args.repeat):
        for name in (names if round_ % 2 == 0 else names[::-1]):
            src, env = trees[name]
            runs = graph_subprocess(sub_args, src, cache_root / name.replace(" ", "-"), env)["runs"]
            for key, run in runs.items():
                kept = best.setdefault(name, {}).get(key)
                if kept is None or run["steps_per_s"] > kept["steps_per_s"]:
                    best[name][key] = run
        print(f"  tree round {round_ + 1}/{args.repeat} done", flush=True)
    return {"trees": {name: str(src) for name, (src, _) in trees.items()}, "best": best}


def tables(measured: dict, trees: dict | None, args) -> str:
    fmt = C.fmt_rate
    pairs = measured["pairs"]
    thread_counts = list(map(int, args.threads.split(",")))
    headers = ["method", "case", "scalar curve steps/s 1t"]
    for t in thread_counts:
        headers += [f"curve steps/s {t}t", f"y=f(x) steps/s {t}t", f"ratio {t}t (median)"]
    headers += ["lanes / scalar 1t (median)", "bit-identical"]
    rows = []
    for p in pairs.values():
        row = [p["method"], p["case"], fmt(p["scalar_steps_per_s"])]
        for t in thread_counts:
            g = p["graph"][t]
            row += [fmt(p["curve"][t]), fmt(g["steps_per_s"]),
                    f"{g['ratio_of_bests']:.2f}x ({g['ratio_median']:.2f}x)"]
        row += [f"{p['lanes_over_scalar']:.2f}x", "yes" if p["scalar_identical"] else "NO"]
        rows.append(row)
    clock = "CPU time" if args.cpu_time else "kernel wall time"
    parts = [f"trajectory-steps/s, {args.n} starts, t_max {args.t_max} s, dt {args.dt:g} "
             f"(dopri5: rtol = atol = {args.rtol:g}), best of {args.repeat} interleaved rounds "
             f"({clock}); ratio = y=f(x) / curve (target <= 1.5x); the scalar curve kernel is "
             f"the lanes' reference (vector=False)\n", C.text_table(headers, rows)]
    headers = ["method", "case", "y=f(x) steps", "curve steps", "status equal",
               "max |dx_end| m", "max |dW| J", "max |dt_end| s", "compile y=f(x) s",
               "compile curve s", "compile scalar curve s"]
    rows = []
    for p in pairs.values():
        a = p["agreement"]
        gap = lambda v: "-" if v is None else f"{v:.2g}"  # noqa: E731
        rows.append([p["method"], p["case"], p["graph_steps"], p["curve_steps"],
                     f"{a['status_equal']:.4f} ({a['status_differ']} differ)",
                     gap(a["max_dx_end"]), gap(a["max_dW_friction"]), gap(a["max_dt_end"]),
                     f"{p['graph_compile_s']:.2f}", f"{p['curve_compile_s']:.2f}",
                     f"{p['scalar_compile_s']:.2f}"])
    parts += ["\nagreement (over trajectories of equal status) and compile times "
              "(first call, fresh cache)\n", C.text_table(headers, rows)]
    if trees is not None:
        names = list(trees["best"])
        keys = list(trees["best"][names[0]])
        headers = ["method/ramp/threads", *(f"{n} steps/s" for n in names),
                   *(f"this tree / {n}" for n in names[1:])]
        rows = []
        for key in keys:
            rates = [trees["best"][n][key]["steps_per_s"] for n in names]
            rows.append([key, *map(fmt, rates), *(f"{rates[0] / r:.3f}" for r in rates[1:])])
        parts += ["\ny = f(x) kernel per source tree (subprocesses, alternating rounds): "
                  + ", ".join(f"{n}: {s}" for n, s in trees["trees"].items()) + "\n",
                  C.text_table(headers, rows)]
    return "\n".join(parts)


def main(argv=None):
    args = parse_args(argv)
    if args.graph_only:
        print("RESULT " + json.dumps(C._jsonable(measure_graph_only(args))))
        return
    cache_root = pathlib.Path(tempfile.mkdtemp(prefix="rampwork-curves-bench-"))
    # compile times of a first call, not of a cache load; set before numba is imported
    os.environ["NUMBA_CACHE_DIR"] = str(cache_root / "main")
    try:
        print("curve kernel beside the y = f(x) kernel:", flush=True)
        measured = measure(args)
        trees = None
        if args.baseline is not None or args.scalar_lanes:
            print("y = f(x) kernel per source tree:", flush=True)
            trees = compare_trees(args, cache_root)
    finally:
        shutil.rmtree(cache_root, ignore_errors=True)
    text = tables(measured, trees, args)
    print(text)
    results = {"config": {k: (str(v) if isinstance(v, pathlib.Path) else v)
                          for k, v in vars(args).items()},
               "utc": C.utc_now(), **measured, "trees": trees}
    stamp = C.timestamp()
    C.save_json(args.out / f"curves-{stamp}.json", results)
    C.save_text(args.out / f"curves-{stamp}.txt", text + "\n")
    print(f"saved {args.out / f'curves-{stamp}.json'}")


if __name__ == "__main__":
    main()
