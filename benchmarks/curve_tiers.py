"""What a curve's general kernel costs beside its specialised one (issue 17's
tiers, for curves: ``rampwork.curves.curve_tier``).

A curve's general kernel is its specialised kernel with friction and both
drag terms compiled in (a zero coefficient an exact no-op), so one kernel
serves every scene of a family, method and contact.  This measures, on the
frictionless loop without drag (the scene the general kernel serves worst:
every effect compiled in, none used), per method:

* compile time of each tier (first call, fresh process-private numba cache);
* run time per trajectory-step of each, 1-thread CPU time, the two tiers
  interleaved over ``--repeat`` rounds (best of), and their ratio;
* that the results are the same bits.

    NUMBA_CACHE_DIR is set to a temporary folder (compile times must not
    come from an earlier run's cache).

    python benchmarks/curve_tiers.py                      # ~3 min
    python benchmarks/curve_tiers.py --methods rk4 --n 500 --repeat 2

Prints a table and saves results/curve_tiers-<timestamp>.json.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import sys
import tempfile
import time

import numpy as np

import _common

METHODS = ("euler", "semi_implicit_euler", "rk4", "dopri5", "dop853")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--n", type=int, default=2000, help="trajectories per run")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--out", default=str(_common.RESULTS_DIR))
    args = parser.parse_args(argv)
    os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="rampwork-curve-tiers-")
    os.environ["RAMPWORK_WARMUP"] = "0"
    from rampwork.core.threads import using_threads
    from rampwork.curves import Curve, prepare_curve_run

    loop = Curve.create("loop", radius=1.0)
    rng = np.random.default_rng(7)
    s0 = rng.uniform(0.0, 2.0 * np.pi, args.n)
    u0 = rng.uniform(-8.0, 8.0, args.n)
    rows, records = [], []
    for method in args.methods.split(","):
        runs, compile_s = {}, {}
        for tier in ("specialised", "general"):
            run = prepare_curve_run(loop, s0=s0, u0=u0, method=method, dt=1e-3, rtol=1e-8,
                                    t_max=3.0, kernel=tier)
            started = time.perf_counter()
            run.compile()
            compile_s[tier] = time.perf_counter() - started
            runs[tier] = run
        best = {tier: np.inf for tier in runs}
        outputs = {}
        with using_threads(1):
            for _ in range(args.repeat):
                for tier, run in runs.items():
                    started = time.process_time()
                    outputs[tier] = run.run()
                    best[tier] = min(best[tier], time.process_time() - started)
        same = all(np.array_equal(outputs["general"][k], outputs["specialised"][k],
                                  equal_nan=outputs["general"][k].dtype.kind == "f")
                   for k in outputs["general"])
        steps = float(np.sum(outputs["specialised"]["steps"]))
        record = {"method": method, "compile_s": compile_s, "cpu_s": best, "steps": steps,
                  "general_over_specialised": best["general"] / best["specialised"],
                  "bit_identical": same}
        records.append(record)
        rows.append([method, f"{compile_s['specialised']:.1f}", f"{compile_s['general']:.1f}",
                     f"{steps / best['specialised']:.3g}", f"{steps / best['general']:.3g}",
                     f"{record['general_over_specialised']:.3f}", "yes" if same else "NO"])
        print(rows[-1], flush=True)
    table = _common.markdown_table(
        ["method", "compile specialised (s)", "compile general (s)",
         "steps/s specialised", "steps/s general", "general / specialised time", "same bits"],
        rows)
    print(table)
    path = _common.save_json(
        pathlib.Path(args.out) / f"curve_tiers-{_common.timestamp()}.json",
        {"machine": _common.machine_info(), "n": args.n, "repeat": args.repeat,
         "results": records})
    print(f"saved {path}")
    return 0 if all(r["bit_identical"] for r in records) else 1


if __name__ == "__main__":
    sys.exit(main())
