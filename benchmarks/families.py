"""Trajectory-steps/s of the fixed-step kernels per ramp family (issue 19, item 3).

Runs the same grid of starts (x0, v0, mu) with one method on a quadratic bowl,
a sine ramp and a cycloid bowl of similar size, and prints steps/s and the ratio
of each family's speed to the quadratic's.  ``--baseline SRC`` runs the same
measurement, in a subprocess in the same invocation, on another rampwork
source tree (e.g. the branch base exported with ``git archive``), and prints
both side by side.

    PYTHONPATH=src python benchmarks/families.py [--n 20000] [--methods rk4]
        [--threads 1] [--repeat 3] [--cpu-time] [--baseline /tmp/rampwork-base/src]
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

DOMAIN = (-1.0, 1.0)
G = 9.81
T_MAX = 20.0
#: (family, parameters): all bowls or waves about 1 m wide
FAMILIES = {
    "quadratic": dict(curvature=1.0),
    "sine": dict(amplitude=0.1, wavenumber=6.0, phase=0.3),
    "cycloid": dict(radius=0.5),
    # not in the default set: to check that other families keep their speed
    "circular_bowl": dict(radius=2.0),
    "spline": dict(x_points=[-1.0, -0.3, 0.2, 1.0], y_points=[0.6, 0.0, 0.1, 0.5]),
}
DEFAULT_FAMILIES = "quadratic,sine,cycloid"


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=20_000, help="starts in the grid (default %(default)s)")
    p.add_argument("--dt", type=float, default=1e-3)
    p.add_argument("--methods", default="rk4", help="comma-separated fixed-step methods (default rk4)")
    p.add_argument("--families", default=DEFAULT_FAMILIES,
                   help=f"comma-separated, of {', '.join(FAMILIES)} (default %(default)s)")
    p.add_argument("--cpu-time", action="store_true",
                   help="time each run by the process's CPU time (with --threads 1: steadier "
                        "than the kernel's wall time on a shared machine)")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    p.add_argument("--baseline", type=pathlib.Path, default=None,
                   help="a rampwork src folder to measure too, in a subprocess")
    p.add_argument("--json", action="store_true", help=argparse.SUPPRESS)  # the subprocess's output
    p.add_argument("--out", type=pathlib.Path, default=C.RESULTS_DIR)
    return p.parse_args(argv)


def measure(args) -> dict:
    import numpy as np

    import rampwork as rw

    side = max(2, round(args.n ** (1 / 3)))
    sweep = rw.Sweep.grid(x0=np.linspace(-0.9, 0.9, side), v0=np.linspace(-4.0, 4.0, side),
                          mu=np.linspace(0.02, 0.3, max(1, round(args.n / side ** 2))))
    out = {"rampwork": rw.__file__, "machine": C.machine_info(), "runs": {}}
    for method in args.methods.split(","):
        for family in args.families.split(","):
            ramp = rw.Ramp.create(family, domain=DOMAIN, **FAMILIES[family])
            scene = rw.Scene(ramp=ramp, friction=rw.Friction(mu_k=0.2), g=G, t_max=T_MAX,
                             integrator=rw.Integrator(method, args.dt))
            rw.simulate(scene, rw.Sweep.cases(x0=[0.1], v0=[0.0], mu=[0.1]), kernel="specialised")  # compile or load
            best = None
            for _ in range(args.repeat):
                started = time.process_time()
                ds = rw.simulate(scene, sweep, threads=args.threads, kernel="specialised")
                seconds = time.process_time() - started if args.cpu_time else ds.attrs["run_time_s"]
                if best is None or seconds < best[1]:
                    best = ds, seconds
            best, seconds = best
            steps = int(best.attrs["trajectory_steps"])
            assert best.attrs["kernel_tier"] == "specialised", best.attrs["kernel_tier"]
            out["runs"][f"{method}/{family}"] = {"steps": steps, "seconds": seconds,
                                                 "steps_per_s": steps / seconds}
            if not args.json:
                print(f"  {method:6s} {family:10s} {steps / seconds:.3e} steps/s", flush=True)
    return out


def main(argv=None):
    args = parse_args(argv)
    if args.json:
        print("RESULT " + json.dumps(C._jsonable(measure(args))))
        return
    results = {}
    if args.baseline is not None:
        env = dict(os.environ, PYTHONPATH=str(args.baseline.resolve()))
        argv_sub = [a for a in (argv if argv is not None else sys.argv[1:])]
        i = argv_sub.index("--baseline")
        del argv_sub[i:i + 2]
        print(f"baseline ({args.baseline}):", flush=True)
        done = subprocess.run([sys.executable, __file__, *argv_sub, "--json"], env=env,
                              capture_output=True, text=True, check=True)
        line = [ln for ln in done.stdout.splitlines() if ln.startswith("RESULT ")][-1]
        results["baseline"] = json.loads(line[len("RESULT "):])
        for key, run in results["baseline"]["runs"].items():
            print(f"  {key:18s} {run['steps_per_s']:.3e} steps/s", flush=True)
    print("this tree:", flush=True)
    results["current"] = measure(args)
    rows = []
    for key in results["current"]["runs"]:
        method, family = key.split("/")
        row = [method, family]
        for which in ("baseline", "current"):
            if which not in results:
                continue
            runs = results[which]["runs"]
            rate = runs[key]["steps_per_s"]
            ratio = runs[f"{method}/quadratic"]["steps_per_s"] / rate if f"{method}/quadratic" in runs else None
            row += [C.fmt_rate(rate), "-" if ratio is None else f"{ratio:.2f}"]
        rows.append(row)
    headers = ["method", "family"]
    for which in ("baseline", "current"):
        if which in results:
            headers += [f"{which} steps/s", f"{which} quadratic/family"]
    table = C.text_table(headers, rows)
    print(table)
    results["config"] = {k: (str(v) if isinstance(v, pathlib.Path) else v) for k, v in vars(args).items()}
    results["utc"] = C.utc_now()
    stamp = C.timestamp()
    C.save_json(args.out / f"families-{stamp}.json", results)
    C.save_text(args.out / f"families-{stamp}.txt", table + "\n")
    print(f"saved {args.out / f'families-{stamp}.json'}")


if __name__ == "__main__":
    main()
