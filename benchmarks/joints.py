"""Curves with joints: the cost of each joint mode of the curve kernel (issue 20).

Trajectory-steps per second of the curve kernel (1 thread, the process's CPU
time of the kernel call) on the same physical curves in two forms:

* ``loop``, ``quarter_pipe`` (flat 0.5 m) and ``loop_track`` (blend 0, run
  1 m): the families with 0, 1 and 2 joints (JOINTS = 0, 1, 2);
* ``track:loop``, ``track:quarter_pipe``, ``track:loop_track``: the same
  curves as tracks of pieces, 0, 1 and 2 joints in the MANY_JOINTS mode
  (0 joints compiles JOINTS = 0).

Each case's outcomes are compared between the two forms (the largest
difference in t_end among equal statuses: rounding of different formulas).
``--baseline SRC``: the same cases (those it has) in another source tree,
e.g. a worktree at the branch point, each tree in its own subprocess and
NUMBA_CACHE_DIR, alternating ``--rounds`` times: "no cost to the modes that
were there".  Compile times are taken apart (first call, fresh cache).

    PYTHONPATH=src python benchmarks/joints.py [--n 4000] [--methods rk4,dopri5]
        [--repeat 3] [--rounds 3] [--baseline /tmp/cfeat8-base/src]
        [--cases loop,track:loop,loop_track,track:loop_track]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402

CASES = ("loop", "track:loop", "quarter_pipe", "track:quarter_pipe", "loop_track",
         "track:loop_track")


def _curve(case):
    from rampwork.curves import Curve

    if case == "loop":
        return Curve.create("loop", radius=1.0), 0.0
    if case == "quarter_pipe":
        return Curve.create("quarter_pipe", radius=1.0, flat_length=0.5), 0.0
    if case == "loop_track":
        return Curve.create("loop_track", radius=1.0, blend_length=0.0, run_length=1.0), 0.0
    if not hasattr(Curve, "track"):
        return None, None
    pieces = {"track:loop": [[2 * math.pi, 1.0, 1.0]],
              "track:quarter_pipe": [[0.5, 0.0, 0.0], [0.5 * math.pi, 1.0, 1.0]],
              "track:loop_track": [[1.0, 0.0, 0.0], [2 * math.pi, 1.0, 1.0], [1.0, 0.0, 0.0]]}
    return Curve.track(pieces[case]), 0.0


def worker(args) -> dict:
    """Time every case in this process (its tree on PYTHONPATH)."""
    import numpy as np
    from rampwork.core.threads import using_threads
    from rampwork.curves import prepare_curve_run

    results = {}
    # speeds that clear the loop (exits) and that do not (lift-offs, reversals)
    u0 = np.linspace(3.0, 8.0, args.n)
    for method in args.methods.split(","):
        for case in args.cases.split(","):
            curve, s0 = _curve(case)
            if curve is None:
                continue
            run = prepare_curve_run(curve, s0=s0, u0=u0, mu_k=0.05, method=method, dt=1e-3,
                                    rtol=1e-7, t_max=5.0)
            with using_threads(1):
                started = time.perf_counter()
                run.compile()
                compile_s = time.perf_counter() - started
                times = []
                for _ in range(args.repeat):
                    started = time.process_time()
                    out = run.run()
                    times.append(time.process_time() - started)
            results[f"{method}:{case}"] = {
                "compile_s": compile_s, "best_s": min(times), "steps": float(out["steps"].sum()),
                "t_end": out["t_end"].tolist(), "status": out["status"].tolist()}
    return results


def _run_worker(src, args, cache) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src), NUMBA_CACHE_DIR=cache, NUMBA_NUM_THREADS="1")
    command = [sys.executable, __file__, "--worker", "--n", str(args.n), "--methods",
               args.methods, "--repeat", str(args.repeat), "--cases", args.cases]
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=4000)
    parser.add_argument("--methods", default="rk4,dopri5")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--baseline", default=None, help="another tree's src folder")
    parser.add_argument("--cases", default=",".join(CASES), help="a subset of " + ", ".join(CASES))
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        print(json.dumps(worker(args)))
        return 0
    here = pathlib.Path(__file__).resolve().parents[1] / "src"
    trees = {"this": here} | ({"baseline": pathlib.Path(args.baseline)} if args.baseline else {})
    rounds = {name: [] for name in trees}
    with tempfile.TemporaryDirectory() as caches:
        for k in range(args.rounds):
            for name, src in trees.items():  # alternating; the first round compiles
                rounds[name].append(_run_worker(src, args, f"{caches}/{name}"))
    import numpy as np

    rows, saved = [], {}
    for key in rounds["this"][0]:
        rate = {name: [r[key]["steps"] / r[key]["best_s"] for r in rs if key in r]
                for name, rs in rounds.items()}
        entry = {"compile_s": rounds["this"][0][key]["compile_s"],
                 "rate_best": max(rate["this"]), "rates": rate["this"]}
        ratio = ""
        if rate.get("baseline"):
            per_round = [a / b for a, b in zip(rate["this"], rate["baseline"])]
            entry |= {"baseline_rate_best": max(rate["baseline"]),
                      "ratio_median": statistics.median(per_round),
                      "baseline_compile_s": rounds["baseline"][0][key]["compile_s"]}
            ratio = C.fmt_ratio(entry["ratio_median"])
        method, case = key.split(":", 1)
        twin = f"{method}:{case.split(':')[-1]}" if case.startswith("track:") else None
        agree = ""
        if twin in rounds["this"][0]:
            a, b = rounds["this"][0][key], rounds["this"][0][twin]
            same = np.array(a["status"]) == np.array(b["status"])
            gap = np.abs(np.array(a["t_end"]) - np.array(b["t_end"]))[same].max()
            entry |= {"status_equal_share": same.mean(), "t_end_max_gap_s": gap,
                      "rate_vs_family": max(rate["this"]) / max(
                          r[twin]["steps"] / r[twin]["best_s"] for r in rounds["this"])}
            agree = f"{same.mean():.3f}, {gap:.1e} s; {C.fmt_ratio(entry['rate_vs_family'])}"
        saved[key] = entry
        rows.append([method, case, f"{entry['compile_s']:.1f}", C.fmt_rate(entry["rate_best"]),
                     ratio, agree])
    headers = ["method", "curve", "compile s", "steps/s (best)", "this / baseline (median)",
               "vs family: same status, t_end gap; rate ratio"]
    print(C.text_table(headers, rows))
    path = C.save_json(C.RESULTS_DIR / f"joints-{C.timestamp()}.json",
                       {"machine": C.machine_info(), "args": vars(args), "results": saved})
    print(f"saved {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
