"""The rough-step check's cost (issue 20): a census of the curve kernel's steps,
this tree against a baseline tree, on the same starts, in the same run.

A step whose stages show the normal force dipping through 0 and back while its
end does not is refused and halved (adaptive pairs) or probed at half its size
(fixed steps): docs/physics.md §5.1.  This counts, per trajectory, the steps
taken and rejected by each tree, how many trajectories' outputs changed (bit
for bit) and how many changed status, and times the kernel call (the process's
CPU time, 1 thread, the best of ``--rounds`` rounds, the trees alternating in
fresh subprocesses).  Compile time is the first call's time less a second
call's, in a fresh NUMBA_CACHE_DIR per tree (the first round only).

Cases: ``benchmarks/curves.py``'s curve runs (random starts on wrapped ramps
and the circular arc, friction 0.02-0.3) and the loop of tests/test_curves.py
(radius 1 m, u_bottom^2 from 2.5 to 5.05 g R, frictionless and mu_k = 0.1, a
block and a bead), the pairs at ``--rtol`` and RK4 at ``--dt``.

    PYTHONPATH=src python benchmarks/rough_steps.py --baseline /work/main/src
        [--n 2000] [--rounds 3] [--methods rk4,dopri5,dop853] [--rtol 1e-6] [--dt 1e-3]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402

G = 9.81
CURVE_CASES = "graph:sine,arc:circular_bowl"


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--baseline", type=pathlib.Path, help="the other tree's src folder")
    p.add_argument("--n", type=int, default=2000, help="trajectories per case")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--methods", default="rk4,dopri5,dop853")
    p.add_argument("--cases", default=CURVE_CASES, help="benchmarks/curves.py's cases")
    p.add_argument("--rtol", type=float, default=1e-6)
    p.add_argument("--dt", type=float, default=1e-3)
    p.add_argument("--t-max", type=float, default=5.0)
    p.add_argument("--seed", type=int, default=20, help="as benchmarks/curves.py")
    p.add_argument("--out", type=pathlib.Path, default=C.RESULTS_DIR)
    p.add_argument("--child", type=pathlib.Path, help=argparse.SUPPRESS)
    p.add_argument("--compile", action="store_true", help=argparse.SUPPRESS)
    return p.parse_args(argv)


def prepared_runs(args):
    """(name, prepared curve run) of every case on this tree's code."""
    import numpy as np

    import curves as curve_bench
    from rampwork.curves import Curve, prepare_curve_run

    x0, v0, mu = curve_bench.starts(args)
    loop = Curve.create("loop", radius=1.0)
    rng = np.random.default_rng(args.seed)
    u0 = np.sqrt(rng.uniform(2.5, 5.05, args.n) * G)
    loop_mu = np.where(rng.uniform(size=args.n) < 0.5, 0.0, 0.1)
    for method in args.methods.split(","):
        for case in args.cases.split(","):
            yield f"{case}/{method}", curve_bench.curve_run(case, method, args, x0, v0, mu)
        for contact in ("one_sided", "two_sided"):
            yield f"loop:{contact}/{method}", prepare_curve_run(
                loop, s0=0.0, u0=u0, mu_k=loop_mu, method=method, dt=args.dt, rtol=args.rtol,
                t_max=args.t_max, contact=contact, kernel="specialised")


def child(args):
    """One tree, one round: every case's outputs (saved) and times."""
    import numpy as np

    from rampwork.core import curve_kernel
    from rampwork.core.threads import using_threads

    times, compile_s, arrays = {}, {}, {}
    for name, run in prepared_runs(args):
        seconds = []
        for _ in range(2):
            out, status = curve_kernel.empty_outputs(run.inputs.shape[1])
            started = time.process_time()
            with using_threads(1):
                run.kernel(run.inputs, run.shared, *run.arguments, out, status)
            seconds.append(time.process_time() - started)
        times[name] = seconds[1]
        compile_s[name] = seconds[0] - seconds[1]
        arrays[name + "|out"] = out
        arrays[name + "|status"] = status
    np.savez(args.child, **arrays)
    print("RESULT " + json.dumps({"times": times, "compile_s": compile_s}))


def run_child(args, src: pathlib.Path, cache: pathlib.Path, path: pathlib.Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(src), "NUMBA_CACHE_DIR": str(cache),
           "NUMBA_NUM_THREADS": "1"}
    command = [sys.executable, __file__, "--child", str(path), "--n", str(args.n),
               "--methods", args.methods, "--cases", args.cases, "--rtol", str(args.rtol),
               "--dt", str(args.dt), "--t-max", str(args.t_max), "--seed", str(args.seed)]
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
    line = next(x for x in done.stdout.splitlines() if x.startswith("RESULT "))
    return json.loads(line[len("RESULT "):])


def census(base, this, names) -> list[dict]:
    """Per case: steps and rejections per tree, and what changed."""
    import numpy as np

    from rampwork.core import curve_kernel as ck

    rows = []
    for name in names:
        a, b = base[name + "|out"], this[name + "|out"]
        changed = ~np.all((a.view(np.int64) == b.view(np.int64)) | (np.isnan(a) & np.isnan(b)),
                          axis=0)
        rows.append({
            "case": name, "n": int(a.shape[1]),
            "steps_base": int(a[ck.O_STEPS].sum()), "steps": int(b[ck.O_STEPS].sum()),
            "rejected_base": int(a[ck.O_REJECTED].sum()), "rejected": int(b[ck.O_REJECTED].sum()),
            "changed": int(changed.sum()),
            "status_changed": int((base[name + "|status"] != this[name + "|status"]).sum())})
        attempts_base = rows[-1]["steps_base"] + rows[-1]["rejected_base"]
        attempts = rows[-1]["steps"] + rows[-1]["rejected"]
        rows[-1]["attempts_change_pct"] = 100.0 * (attempts / attempts_base - 1.0)
        # the same among the trajectories whose outputs did not change
        same = ~changed
        rows[-1]["unchanged_attempts_change_pct"] = 100.0 * (
            (b[ck.O_STEPS, same] + b[ck.O_REJECTED, same]).sum()
            / max((a[ck.O_STEPS, same] + a[ck.O_REJECTED, same]).sum(), 1.0) - 1.0)
    return rows


def main(argv=None):
    args = parse_args(argv)
    if args.child is not None:
        child(args)
        return
    import numpy as np

    if args.baseline is None:
        raise SystemExit("--baseline SRC: the tree to compare with")
    this_src = pathlib.Path(__file__).resolve().parent.parent / "src"
    trees = {"base": args.baseline.resolve(), "this": this_src}
    root = pathlib.Path(tempfile.mkdtemp(prefix="rampwork-rough-"))
    try:
        results = {tree: [] for tree in trees}
        for round_ in range(args.rounds):
            for tree, src in (trees.items() if round_ % 2 == 0 else reversed(trees.items())):
                path = root / f"{tree}-{round_}.npz"
                results[tree].append(run_child(args, src, root / f"cache-{tree}", path))
                print(f"round {round_} {tree}: done", flush=True)
        base = np.load(root / "base-0.npz")
        this = np.load(root / "this-0.npz")
        names = list(results["this"][0]["times"])
        rows = census(base, this, names)
        for row in rows:
            name = row["case"]
            best = {tree: min(r["times"][name] for r in results[tree]) for tree in trees}
            per_round = [t["times"][name] / b["times"][name]
                         for t, b in zip(results["this"], results["base"])]
            row.update(time_base_s=best["base"], time_s=best["this"],
                       time_ratio_of_bests=best["this"] / best["base"],
                       time_ratio_median=float(np.median(per_round)),
                       compile_base_s=results["base"][0]["compile_s"][name],
                       compile_s=results["this"][0]["compile_s"][name])
    finally:
        shutil.rmtree(root, ignore_errors=True)
    headers = ["case", "n", "steps base", "steps", "rej base", "rej", "attempts %",
               "unchanged %", "changed", "status chg", "time ratio (best)", "median",
               "compile base s", "compile s"]
    table = C.text_table(headers, [[
        r["case"], r["n"], r["steps_base"], r["steps"], r["rejected_base"], r["rejected"],
        f"{r['attempts_change_pct']:+.2f}", f"{r['unchanged_attempts_change_pct']:+.2f}",
        r["changed"], r["status_changed"], f"{r['time_ratio_of_bests']:.3f}",
        f"{r['time_ratio_median']:.3f}", f"{r['compile_base_s']:.1f}", f"{r['compile_s']:.1f}"]
        for r in rows])
    print(table)
    stamp = C.timestamp()
    C.save_json(args.out / f"rough_steps-{stamp}.json",
                {"config": {k: str(v) for k, v in vars(args).items()}, "utc": C.utc_now(),
                 "trees": {k: str(v) for k, v in trees.items()}, "rows": rows,
                 "machine": C.machine_info()})
    C.save_text(args.out / f"rough_steps-{stamp}.txt", table + "\n")
    print(f"saved {args.out / f'rough_steps-{stamp}.json'}")


if __name__ == "__main__":
    main()
