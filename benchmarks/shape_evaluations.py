"""Candidate evaluations per second of a shape optimisation (issue 21):
``ChordModes.evaluate`` (one batched kernel call per population) against a
loop that calls ``scipy.integrate.solve_ivp`` with events once per candidate
(``rampwork.reference.reference_trajectory``), in the same run, at matched
accuracy: the error of the time to B against a tight reference (scipy DOP853,
rtol = atol = 1e-13) over the same population.

The population: S candidates of K = 6 sine modes on the chord from
A = (0, 1 m) to B = (2 m, 0), mu = 0.2, drawn as a first generation of
differential evolution would be (uniform in the shape's bounds, those that
arrive kept).  Timed in CPU time of this process with one thread
(``threads=1``), the two sides interleaved ``--repeat`` times, best of each;
the batch's compile time apart.

    python benchmarks/shape_evaluations.py                 # ~1-2 min
    python benchmarks/shape_evaluations.py --n 64 --repeat 1 --out /tmp/x   # quick

Prints a table and saves results/shape_evaluations-<timestamp>.json.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import _common

MU = 0.2
K = 6
START, END = (0.0, 1.0), (2.0, 0.0)
#: (label, rampwork dopri5 rtol, scipy solve_ivp method, rtol): pairs whose
#: errors of t_end are compared (the ratio is reported at each pair)
PAIRS = (("rtol 1e-6", 1e-6, "RK45", 1e-6), ("rtol 1e-8", 1e-8, "DOP853", 1e-8),
         ("rtol 1e-10", 1e-10, "DOP853", 1e-10))


def population(shape, scene, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    bounds = np.array(shape.bounds)
    rows = []
    while sum(len(r) for r in rows) < n:
        draw = rng.uniform(bounds[:, 0], bounds[:, 1], (4 * n, K)) * 0.3
        arrived = shape.evaluate(draw, scene)["arrived"].values
        rows.append(draw[arrived])
    return np.vstack(rows)[:n]


def scipy_loop(shape, scene, table, method: str, rtol: float):
    from rampwork.reference import reference_trajectory

    return np.array([reference_trajectory(scene, ramp=shape.ramp(row[None, :]), x0=START[0], method=method,
                                          rtol=rtol, atol=rtol)["t_end"] for row in table])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=256, help="candidates (default 256)")
    parser.add_argument("--scipy-n", type=int, default=32,
                        help="candidates the scipy loop runs (its rate is per candidate; default 32)")
    parser.add_argument("--repeat", type=int, default=3, help="interleaved repeats (best of)")
    parser.add_argument("--out", type=Path, default=_common.RESULTS_DIR)
    args = parser.parse_args(argv)

    import rampwork as rw

    shape = rw.ChordModes(start=START, end=END, k=K)
    base = shape.scene(friction=rw.Friction(mu_k=MU))
    table = population(shape, base, args.n, seed=0)
    subset = table[:args.scipy_n]
    print(f"shape evaluations: {len(table)} candidates (K = {K}, mu = {MU}), scipy loop on {len(subset)}; "
          f"1 thread, CPU time, best of {args.repeat}")
    from rampwork.reference import reference_trajectory

    truth = np.array([reference_trajectory(base, ramp=shape.ramp(row[None, :]), x0=START[0], rtol=1e-13,
                                           atol=1e-13)["t_end"] for row in subset])
    results = {}
    for label, rtol, method, scipy_rtol in PAIRS:
        scene = base.replace(integrator=rw.Integrator("dopri5", rtol=rtol))
        started = time.perf_counter()
        first = shape.evaluate(table, scene, threads=1)
        compile_s = float(first.attrs["compile_time_s"])
        batch_s, loop_s = [], []
        for _ in range(args.repeat):
            t = time.process_time()
            batch = shape.evaluate(table, scene, threads=1)
            batch_s.append(time.process_time() - t)
            t = time.process_time()
            loop = scipy_loop(shape, scene, subset, method, scipy_rtol)
            loop_s.append(time.process_time() - t)
        batch_error = float(np.max(np.abs(batch["t_end"].values[:len(subset)] - truth) / truth))
        loop_error = float(np.max(np.abs(loop - truth) / truth))
        batch_rate, loop_rate = len(table) / min(batch_s), len(subset) / min(loop_s)
        results[label] = dict(rampwork_rtol=rtol, scipy_method=method, scipy_rtol=scipy_rtol,
                              batch_per_s=batch_rate, scipy_per_s=loop_rate, ratio=batch_rate / loop_rate,
                              batch_t_end_error=batch_error, scipy_t_end_error=loop_error,
                              compile_s=compile_s, kernel_run_s=float(batch.attrs["run_time_s"]),
                              first_call_wall_s=time.perf_counter() - started)
        print(f"  {label:<10}: batch {batch_rate:10.0f}/s (max rel error of t_end {batch_error:.1e}), "
              f"scipy {method} loop {loop_rate:8.1f}/s ({loop_error:.1e}): {batch_rate / loop_rate:7.0f}x; "
              f"compile {compile_s:.1f} s")
    path = args.out / f"shape_evaluations-{_common.timestamp()}.json"
    _common.save_json(path, dict(machine=_common.machine_info(), when=_common.utc_now(), n=len(table),
                                 scipy_n=len(subset), repeat=args.repeat, results=results))
    print(f"saved {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
