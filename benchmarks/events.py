"""What events cost the fixed-step kernels (issue 19, item 2), measured in CPU time.

throughput.py's bowl grid (about half of the trajectories stick after a few
reversals, the rest exit) against its identical-trajectory run (every lane
busy on one start that swings about 8 times), and the float64-division
ceiling, all on one thread and timed by the process's CPU time, not the wall
clock: on a shared machine (load well above the core count) wall-clock rates
swing by 2-4x between runs, CPU time by a few per cent.  Each rate is the best
of ``--repeat`` runs; with ``--baseline SRC`` another ``src`` folder (e.g. the
main branch's) is measured the same way in a subprocess, the two interleaved
round by round, so both see the same machine.  Prints the fraction of the
ceiling (divisions per step: Euler 1, RK4 4) and grid/identical per method,
and saves JSON and markdown under --out.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import subprocess
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402
import throughput as TP  # noqa: E402


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--n", type=float, default=216_000, help="trajectories of the grid (default 216000)")
    p.add_argument("--methods", default="euler,rk4,semi_implicit_euler")
    p.add_argument("--repeat", type=int, default=3, help="timed runs per round; the best counts")
    p.add_argument("--rounds", type=int, default=2, help="interleaved rounds with --baseline")
    p.add_argument("--baseline", default=None, help="another rampwork src folder, measured beside")
    p.add_argument("--out", type=pathlib.Path, default=C.RESULTS_DIR)
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    return p.parse_args(argv)


def measure(n: int, methods: list[str], repeat: int) -> dict:
    """Best CPU-time rates of this process's rampwork: grid, identical, ceiling."""
    import numba
    import numpy as np

    import rampwork as rw
    from rampwork import runner
    from rampwork.core import layout
    from rampwork.core.threads import using_threads

    @numba.njit(error_model="numpy", fastmath=False)  # after rampwork: its CPU features
    def divide(reps, x):
        for _ in range(reps):
            for i in range(x.size):  # 64 independent chains: throughput-bound
                x[i] = 1.0 / (x[i] + 1.0)

    x = 1.0 + 1e-3 * np.arange(64.0)
    divide(10, x)
    reps = 2_000_000
    ceiling = 0.0
    for _ in range(repeat):
        started = time.process_time()
        divide(reps, x)
        ceiling = max(ceiling, reps * 64 / (time.process_time() - started))
    axes = TP.grid_axes(n, np)
    sweeps = {"grid": rw.Sweep.grid(**axes),
              "identical": rw.Sweep.cases(**{k: np.full(max(n // 8, 64), v)
                                             for k, v in TP.UNIFORM_START.items()})}
    out = {"division_ceiling_per_s": ceiling, "methods": {}}
    for method in methods:
        scene = TP.make_scene(rw, method, 1e-3)
        rates = {}
        for name, sweep in sweeps.items():
            plan = runner.plan_run(scene, sweep)
            prepared = runner.prepare(plan, kernel="specialised")  # not the general tier
            size = sweep.size
            buffers = runner.ChunkBuffers(plan, size)
            inputs, raw, columns = buffers.arrays(size)
            inputs = runner.chunk_inputs(plan, 0, size, out=inputs,
                                         values=runner.axis_values(plan, 0, size, columns))
            best = 0.0
            with using_threads(1):
                for _ in range(repeat):
                    raw.fill(0.0)
                    started = time.process_time()
                    prepared.run_batch(inputs, prepared.settings, raw, prepared.shared,
                                       runner.tile_size(size, 1))
                    seconds = time.process_time() - started
                    best = max(best, raw[layout.OUT_STEPS].sum() / seconds)
            rates[name] = best
        per_step = TP.DIVISIONS_PER_STEP[method]
        out["methods"][method] = {
            "grid_steps_per_s": rates["grid"], "identical_steps_per_s": rates["identical"],
            "grid_of_ceiling": rates["grid"] * per_step / ceiling,
            "identical_of_ceiling": rates["identical"] * per_step / ceiling,
            "grid_over_identical": rates["grid"] / rates["identical"]}
    return out


def run_source(src: str | None, args) -> dict:
    """measure() in a new process with ``src`` first on the path (None: this tree)."""
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = str(pathlib.Path(src).resolve())
        env["NUMBA_CACHE_DIR"] = env.get("NUMBA_CACHE_DIR", "/tmp/numba-cache") + "-baseline"
    command = [sys.executable, __file__, "--worker", "--n", str(args.n), "--methods",
               ",".join(args.methods), "--repeat", str(args.repeat)]
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def best_of(results: list[dict], ceiling: float) -> dict:
    """Per method and rate, the best over rounds, as fractions of ``ceiling``
    (the best over every round of every tree: one machine)."""
    best = {"division_ceiling_per_s": ceiling, "methods": {}}
    for method in results[0]["methods"]:
        runs = [r["methods"][method] for r in results]
        grid = max(run["grid_steps_per_s"] for run in runs)
        identical = max(run["identical_steps_per_s"] for run in runs)
        per_step = TP.DIVISIONS_PER_STEP[method]
        best["methods"][method] = {
            "grid_steps_per_s": grid, "identical_steps_per_s": identical,
            "grid_of_ceiling": grid * per_step / ceiling,
            "identical_of_ceiling": identical * per_step / ceiling,
            "grid_over_identical": grid / identical}
    return best


def main(argv=None) -> int:
    args = parse_args(argv)
    args.methods = args.methods.split(",")
    n = int(args.n)
    if args.worker:
        print(json.dumps(measure(n, args.methods, args.repeat)))
        return 0
    load = os.getloadavg()
    sources = {"this tree": None} | ({"baseline": args.baseline} if args.baseline else {})
    rounds: dict[str, list] = {name: [] for name in sources}
    for r in range(args.rounds if args.baseline else 1):
        for name, src in sources.items():
            rounds[name].append(run_source(src, args))
            print(f"round {r + 1}: {name} done", flush=True)
    ceiling = max(r["division_ceiling_per_s"] for runs in rounds.values() for r in runs)
    best = {name: best_of(runs, ceiling) for name, runs in rounds.items()}
    head = ["method", "tree", "grid steps/s", "of ceiling", "identical steps/s", "of ceiling",
            "grid/identical"]
    rows = []
    for method in args.methods:
        for name in sources:
            m = best[name]["methods"][method]
            rows.append([TP.METHOD_LABELS[method], name, f"{m['grid_steps_per_s']:.3e}",
                         f"{100 * m['grid_of_ceiling']:.1f}%", f"{m['identical_steps_per_s']:.3e}",
                         f"{100 * m['identical_of_ceiling']:.1f}%",
                         f"{m['grid_over_identical']:.3f}"])
    widths = [max(len(str(x)) for x in col) for col in zip(head, *rows)]
    text = "\n".join("  ".join(str(x).rjust(w) for x, w in zip(row, widths)) for row in [head] + rows)
    ceilings = ", ".join(f"{name} {max(r['division_ceiling_per_s'] for r in rounds[name]):.3e}"
                         for name in sources)
    summary = (f"events benchmark: {n:,}-trajectory grid and identical run, 1 thread, CPU time, "
               f"best of {args.repeat} x {len(rounds['this tree'])} round(s); load average at start "
               f"{load[0]:.1f}/{load[1]:.1f}/{load[2]:.1f}, at end "
               f"{'/'.join(f'{x:.1f}' for x in os.getloadavg())}; division ceiling (div/s, 1 thread, "
               f"best of each tree's processes; the fractions use the best): {ceilings}")
    print(summary + "\n\n" + text)
    stem = f"events-{C.timestamp()}"
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / f"{stem}.json").write_text(json.dumps(
        {"config": {"n": n, "methods": args.methods, "repeat": args.repeat,
                    "baseline": args.baseline}, "load_average_at_start": load,
         "best": best, "rounds": rounds}, indent=1))
    (args.out / f"{stem}.md").write_text(summary + "\n\n```\n" + text + "\n```\n")
    print(f"saved: {args.out / stem}.json, .md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
