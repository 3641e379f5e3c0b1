"""The (p, p') prototype of the curve kernel beside the y = f(x) kernel and
the engine's curve kernel (issue 20; pdot_kernel.py; benchmarks/README.md,
curves.py, i20-pdot-11).

Same starts, ramps, steps and timing as ``curves.py`` (its functions): per
method and case, rounds of y = f(x) (``rw.simulate``), the engine's curve
lane kernel and the prototype, interleaved; trajectory-steps per second,
best of the rounds, and the ratios y = f(x) / curve of both.  The
prototype's outputs are compared with the engine's curve kernel (status,
t_end, p_end, u_end, X_end, W_friction, nu_min, steps; not DISP, PATH and
curvature_mean, which its vector step leaves), and both with the y = f(x)
kernel (curves.py's agreement).  ``--lean`` adds the variants ``lean`` (no
per-step CURV, PATHX, INROW), ``leanuniform`` (and the parameters read once
per block) and, on wrapped graphs, ``leangraph`` (lean, the y = f(x)
kernel's stage); ``--block N`` a prototype with N lanes per vector loop.
Only --cpu-time and --threads 1 are meaningful here (1 thread, CPU time).

    PYTHONPATH=src python benchmarks/pdot_prototype.py --n 2000 --repeat 3 --cpu-time \
        --threads 1 --cases graph:quadratic,graph:sine,arc:circular_bowl --methods euler,rk4 \
        [--lean] [--block 8]
    PYTHONPATH=src python benchmarks/pdot_prototype.py --check   # the equations alone
"""

from __future__ import annotations

import pathlib
import statistics
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import curves as CB  # noqa: E402


def pd_kernel(case: str, method: str, **switches):
    import rampwork as rw
    from rampwork.curves import Curve

    import pdot_kernel as PK

    kind, family = case.split(":")
    ramp = rw.Ramp.create(family, domain=CB.DOMAIN, **CB.RAMPS[family])
    if kind == "graph":
        spec = Curve.from_ramp(ramp).spec
        return PK.build_pd_kernel(spec.key, spec.frame, spec.point, PK.graph_pd_frame, method,
                                  extra={"ramp_slope_curvature": ramp.spec.slope_curvature,
                                         **switches})
    spec = Curve.create("loop", radius=2.0, entry_angle=-0.5, exit_angle=0.5).spec
    return PK.build_pd_kernel(spec.key, spec.frame, spec.point, PK.arc_pd_frame, method,
                              extra=switches)


def time_kernel(kernel, run):
    import numpy as np

    from rampwork.core import curve_kernel

    out, status = curve_kernel.empty_outputs(run.inputs.shape[1])
    cpu = time.process_time()
    kernel(run.inputs, run.shared, *run.arguments, out, status)
    seconds = time.process_time() - cpu
    result = {name: out[k] for k, name in enumerate(curve_kernel.OUTPUTS)}
    result["status"] = status
    return int(out[curve_kernel.O_STEPS].sum()), seconds, result


def compare(main, new) -> dict:
    import numpy as np

    same = main["status"] == new["status"]
    gaps = {"status_differ": int((~same).sum())}
    for name in ("t_end", "p_end", "u_end", "X_end", "W_friction", "nu_min",
                 "steps"):
        a, b = main[name][same], new[name][same]
        gaps[name] = float(np.nanmax(np.abs(a - b))) if same.any() else None
    return gaps


def check_equations(n: int = 1000, seed: int = 1) -> float:
    """The (p, p') equations against (s, u) (docs/physics.md §5) at ``n``
    random points of curves r(p) = (a p + b sin p, c p^2 + e cos 2p), whose
    |r'| is not 1: du/dt = |r'| p'' + (r'.r''/|r'|) p'^2, nu = M / |r'|,
    the friction power and the turning.  The largest relative difference."""
    import numpy as np

    rng = np.random.default_rng(seed)
    g = 9.81
    worst = 0.0
    for _ in range(n):
        a, b, c, e = rng.uniform(0.5, 2.0, 4)
        p, v, q = rng.uniform(-2.0, 2.0), rng.uniform(-3.0, 3.0), rng.uniform(-0.3, 0.3)
        r1 = np.array([a + b * np.cos(p), 2 * c * p - 2 * e * np.sin(2 * p)])
        r2 = np.array([-b * np.sin(p), 2 * c - 4 * e * np.cos(2 * p)])
        speed = np.hypot(*r1)
        cross = r1[0] * r2[1] - r1[1] * r2[0]
        dot = r1 @ r2
        # (s, u): the engine's form
        sin_phi, cos_phi, kappa, u = r1[1] / speed, r1[0] / speed, cross / speed ** 3, speed * v
        nu = kappa * u * u + g * cos_phi
        u_dot = -g * sin_phi - q * nu
        # (p, p')
        m = cross * v * v + g * r1[0]
        p_ddot = -(dot * v * v + g * r1[1] + q * m) / speed ** 2
        pairs = ((speed * p_ddot + dot / speed * v * v, u_dot), (m / speed, nu),
                 (q * m * v, q * nu * u), (cross / speed ** 2 * v, kappa * u))
        worst = max(worst, *(abs(x - y) / max(1.0, abs(y)) for x, y in pairs))
    return worst


LEAN = "--lean" in sys.argv
BLOCKS = []


def main(argv=None):
    import rampwork as rw

    argv = list(sys.argv[1:] if argv is None else argv)
    if "--check" in argv:  # the equations only
        print("largest relative difference, (p, p') against (s, u):", check_equations())
        return
    if "--lean" in argv:
        argv.remove("--lean")
    while "--block" in argv:  # another BLOCK of the prototype's vector step
        k = argv.index("--block")
        BLOCKS.append(int(argv[k + 1]))
        del argv[k:k + 2]
    args = CB.parse_args(argv)
    x0, v0, mu = CB.starts(args)
    sweep = rw.Sweep.cases(x0=x0, v0=v0, mu=mu)
    rows = []
    for method in args.methods.split(","):
        for case in args.cases.split(","):
            family = case.split(":")[1]
            scene = CB.ramp_scene(family, method, args)
            rw.simulate(scene, rw.Sweep.cases(x0=[0.1], v0=[0.0], mu=[0.1]), kernel=CB.C.KERNEL)
            run = CB.curve_run(case, method, args, x0, v0, mu)
            started = time.perf_counter()
            kernels = {"pdot": pd_kernel(case, method)}
            if LEAN:
                kernels["lean"] = pd_kernel(case, method, LEAN=True)
                kernels["leanuniform"] = pd_kernel(case, method, LEAN=True, UNIFORM=True)
                if case.startswith("graph"):
                    kernels["leangraph"] = pd_kernel(case, method, LEAN=True, GRAPH=True)
            for block in BLOCKS:
                kernels[f"block{block}"] = pd_kernel(case, method, BLOCK=block)
            for kernel in kernels.values():
                time_kernel(kernel, run)
            time_kernel(run.kernel, run)
            compile_s = time.perf_counter() - started
            rates = {"graph": [], "main": [], **{k: [] for k in kernels}}
            outs = {}
            for _ in range(args.repeat):
                steps, seconds, ds = CB.time_graph(scene, sweep, 1, True)
                rates["graph"].append(steps / seconds)
                steps, seconds, outs["main"] = time_kernel(run.kernel, run)
                rates["main"].append(steps / seconds)
                for k, kernel in kernels.items():
                    steps, seconds, outs[k] = time_kernel(kernel, run)
                    rates[k].append(steps / seconds)
            best = {k: max(v) for k, v in rates.items()}
            median = {k: statistics.median(g / c for g, c in zip(rates["graph"], v))
                      for k, v in rates.items()}
            row = {"method": method, "case": case, "compile_s": compile_s, **{
                f"{k}_steps_per_s": best[k] for k in best},
                **{f"ratio_{k}": best["graph"] / best[k] for k in best},
                **{f"median_{k}": median[k] for k in median},
                "pdot_vs_main": best["pdot"] / best["main"],
                "agreement": compare(outs["main"], outs["pdot"]),
                # both against the y = f(x) kernel (curves.py's agreement)
                "graph_main": CB.agreement(ds, outs["main"]),
                "graph_pdot": CB.agreement(ds, outs["pdot"])}
            rows.append(row)
            print(row, flush=True)
    print("| method | case | y=f(x) steps/s | main curve steps/s | pdot steps/s | "
          "y=f(x)/curve main (median) | y=f(x)/curve pdot (median) | pdot/main speed |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['method']} | {r['case']} | {r['graph_steps_per_s']:.3g} | "
              f"{r['main_steps_per_s']:.3g} | {r['pdot_steps_per_s']:.3g} | "
              f"{r['ratio_main']:.2f}x ({r['median_main']:.2f}x) | "
              f"{r['ratio_pdot']:.2f}x ({r['median_pdot']:.2f}x) | {r['pdot_vs_main']:.2f}x |")
    for r in rows:
        extra = [k[6:] for k in r if k.startswith("ratio_") and k[6:] not in ("graph", "main", "pdot")]
        if extra:
            print(r["method"], r["case"], ", ".join(
                f"{k}: {r['ratio_' + k]:.2f}x ({r['median_' + k]:.2f}x)" for k in extra))


if __name__ == "__main__":
    main()
