"""Compile time of the curve kernels: a fresh process and an empty numba cache
per case, the first ``simulate_curve`` call (``sim``: the specialised lane
kernel) or the first ``prepare_curve_run(...).trace(0)`` (``trace``: the
kernel's ``trace_one``), timed in the process.

With ``--baseline SRC`` the same cases run on another source tree too
(e.g. ``git archive main src``), alternating tree by tree within each
round; the table gives the best of ``--rounds`` per tree and new / base.
On a shared machine compare the ratios, not the seconds.

``--run-time N``: instead, the kernels' run time, so that a change to how
they compile is seen not to cost it: N random starts per case (moving
within the curve for its ``t_max`` of 5 s: a bowl-shaped arc of the loop,
the quarter pipe, two wrapped ramps), each kernel compiled first, then
the process's CPU time of ``run()`` on 1 thread, best of ``--repeat``.

    PYTHONPATH=src python benchmarks/curve_compile.py [--baseline /tmp/base/src]
        [--rounds 2] [--cases loop:rk4:sim,graph:quadratic:dop853:sim,...]
        [--run-time 2000 --repeat 5]
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

HERE = pathlib.Path(__file__).resolve().parent
SRC = HERE.parent / "src"
#: family -> the curve's construction and a start (s0) on it
CURVES = {
    "loop": ("Curve.create('loop', radius=1.0)", 0.1),
    "quarter_pipe": ("Curve.create('quarter_pipe', radius=1.0, flat_length=0.5)", 0.1),
    "graph:quadratic": ("Curve.from_ramp(rw.Ramp.create('quadratic', domain=(-2.0, 2.0), "
                        "curvature=1.0))", 0.3),
}
DEFAULT_CASES = ("loop:euler:sim,loop:rk4:sim,loop:dopri5:sim,quarter_pipe:rk4:sim,"
                 "quarter_pipe:dopri5:sim,graph:quadratic:dop853:sim,loop:rk4:trace,"
                 "graph:quadratic:dopri5:trace")
CHILD = """
import time
import rampwork as rw
from rampwork.curves import Curve, prepare_curve_run, simulate_curve
curve = {curve}
arguments = dict(s0={s0}, u0=2.0, mu_k=0.1, method={method!r}, dt=1e-3, t_max=1.0,
                 kernel="specialised")
start = time.perf_counter()
if {what!r} == "sim":
    simulate_curve(curve, **arguments)
else:
    prepare_curve_run(curve, **arguments).trace(0)
print(time.perf_counter() - start)
"""


RUN_CASES = ("loop:euler,loop:rk4,loop:dopri5,loop:dop853,graph:quadratic:rk4,graph:sine:dopri5,"
             "quarter_pipe:dopri5")
RUN_CHILD = """
import json, sys, time
import numpy as np
import rampwork as rw
from rampwork.core.threads import using_threads
from rampwork.curves import Curve, prepare_curve_run
n, repeat = {n}, {repeat}
rng = np.random.default_rng(3)
curves = {{
    "loop": (lambda: Curve.create("loop", radius=1.0, entry_angle=-1.5, exit_angle=1.5), 1.4),
    "quarter_pipe": (lambda: Curve.create("quarter_pipe", radius=1.0, flat_length=0.5), None),
    "graph:quadratic": (lambda: Curve.from_ramp(rw.Ramp.create("quadratic", domain=(-1.0, 1.0),
                                                               curvature=2.0)), 0.9),
    "graph:sine": (lambda: Curve.from_ramp(rw.Ramp.create("sine", domain=(-1.0, 1.0),
                                                          amplitude=0.2, wavenumber=6.0)), 0.9),
}}
seconds = {{}}
for case in {cases!r}.split(","):
    family, method = case.rsplit(":", 1)
    make, half = curves[family]
    s0 = rng.uniform(0.0, 2.0, n) if half is None else rng.uniform(-half, half, n)
    u0 = rng.normal(0.0, 1.5, n)
    mu_k = rng.uniform(0.0, 0.02, n)
    run = prepare_curve_run(make(), s0=s0, u0=u0, mu_k=mu_k, method=method, dt=1e-3, t_max=5.0,
                            rtol=1e-8, kernel="specialised")
    with using_threads(1):
        run.run()
        best = float("inf")
        for _ in range(repeat):
            start = time.process_time()
            run.run()
            best = min(best, time.process_time() - start)
    seconds[case] = best
print(json.dumps(seconds))
"""


def run_seconds(src: pathlib.Path, cases: str, n: int, repeat: int) -> dict:
    cache = tempfile.mkdtemp(prefix="curve-run-")
    try:
        env = {**os.environ, "PYTHONPATH": str(src), "NUMBA_CACHE_DIR": cache,
               "RAMPWORK_WARMUP": "0"}
        code = RUN_CHILD.format(n=n, repeat=repeat, cases=cases)
        out = subprocess.run([sys.executable, "-c", code], env=env, check=True,
                             capture_output=True, text=True).stdout
        return json.loads(out.splitlines()[-1])
    finally:
        shutil.rmtree(cache, ignore_errors=True)


def compile_seconds(src: pathlib.Path, case: str) -> float:
    family, method, what = case.rsplit(":", 2)
    curve, s0 = CURVES[family]
    cache = tempfile.mkdtemp(prefix="curve-compile-")
    try:
        env = {**os.environ, "PYTHONPATH": str(src), "NUMBA_CACHE_DIR": cache,
               "RAMPWORK_WARMUP": "0"}
        code = CHILD.format(curve=curve, s0=s0, method=method, what=what)
        out = subprocess.run([sys.executable, "-c", code], env=env, check=True,
                             capture_output=True, text=True).stdout
        return float(out.split()[-1])
    finally:
        shutil.rmtree(cache, ignore_errors=True)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", default=DEFAULT_CASES, help="family:method:sim|trace, comma-separated")
    p.add_argument("--baseline", type=pathlib.Path, default=None, help="another tree's src")
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--run-time", type=int, default=0, metavar="N",
                   help="time the kernels' runs on N starts instead (cases: RUN_CASES)")
    p.add_argument("--repeat", type=int, default=5, help="--run-time: runs per process, best")
    args = p.parse_args()
    trees = {"new": SRC} if args.baseline is None else {"base": args.baseline, "new": SRC}
    best: dict = {}
    if args.run_time:
        cases = RUN_CASES if args.cases == DEFAULT_CASES else args.cases
        for r in range(args.rounds):
            for tree, src in (trees.items() if r % 2 == 0 else reversed(trees.items())):
                for case, seconds in run_seconds(src, cases, args.run_time, args.repeat).items():
                    best[case, tree] = min(best.get((case, tree), seconds), seconds)
                    print(f"round {r + 1} {case} {tree}: {seconds:.4f} s CPU", flush=True)
        _table(cases.split(","), trees, best, "s CPU")
        return
    for r in range(args.rounds):
        for case in args.cases.split(","):
            for tree, src in (trees.items() if r % 2 == 0 else reversed(trees.items())):
                seconds = compile_seconds(src, case)
                best[case, tree] = min(best.get((case, tree), seconds), seconds)
                print(f"round {r + 1} {case} {tree}: {seconds:.2f} s", flush=True)
    _table(args.cases.split(","), trees, best, "s")


def _table(cases, trees, best, unit) -> None:
    print("\n| case | " + " | ".join(f"{t} {unit}" for t in trees)
          + (" | new / base |" if len(trees) == 2 else " |"))
    print("|---" * (len(trees) + 1 + (len(trees) == 2)) + "|")
    for case in cases:
        row = [f"{best[case, t]:.3g}" for t in trees]
        if len(trees) == 2:
            row.append(f"{best[case, 'new'] / best[case, 'base']:.2f}")
        print(f"| {case} | " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
