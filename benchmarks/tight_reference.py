#!/usr/bin/env python
"""The tight end's W errors against a long-double Taylor reference (issue 19, item 4).

``accuracy_cost.py --peers-only`` and ``accuracy_ends.py`` measure W errors
against rampwork.reference (scipy DOP853 in double precision, rtol 2.5e-14),
whose own error (1e-14 once it stepped to its events; 8e-13 before) is not far
below the errors measured at rtol 1e-13.  This benchmark measures them against
heyoka's Taylor integrator in long double (80-bit on x86-64: tol = its
epsilon, 1.1e-19; events found as roots of the Taylor polynomials), which
shares no code with rampwork or scipy:

* the starts of ``accuracy_cost.py --peers`` (--n of throughput.py's 10^6
  bowl grid, seed 0; 20,000 by default) on its bowl, mu_k = mu_s = mu;
* rampwork's dopri5 and dop853 at rtol 1e-12 and 1e-13, with atol = rtol and
  atol = 1e-4 rtol, each with the energy projection (the default) and without
  (``Integrator(project_energy=False)``; a rampwork without the option runs
  its default once): W error median, maximum, their ratio (issue 19's
  target: <= 10), by the reference's status, the worst start, and the
  kernel's run time on one thread (best of --repeat, settings interleaved);
* rampwork.reference's own W error, where accuracy_cost.py's cached reference
  for the same starts and the current reference.py is in --out.

Needs heyoka (``pip install .[bench]``).  Run from the repository root::

    .venv/bin/python benchmarks/tight_reference.py           # 20,000 starts
    .venv/bin/python benchmarks/tight_reference.py --n 2000
    .venv/bin/python benchmarks/tight_reference.py --methods dop853  # one pair

Results (JSON and markdown) go to benchmarks/results/tight_reference.*.
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402
import throughput as T  # noqa: E402  (the bowl and its grid)

W_FLOOR = 1e-9  # as accuracy_cost.py
SETTINGS = [(m, r, a * r) for m in ("dopri5", "dop853") for r in (1e-12, 1e-13) for a in (1.0, 1e-4)]
STUCK, EXITED, TIMEOUT, DIVERGED = 1, 2, 4, 5


def parse_args(argv=None):
    p = argparse.ArgumentParser(prog="tight_reference.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--n", type=int, default=20_000, help="starts (default %(default)d)")
    p.add_argument("--seed", type=int, default=0, help="as accuracy_cost.py --peers (default 0)")
    p.add_argument("--repeat", type=int, default=3, help="timed runs per setting, interleaved "
                   "(default %(default)d)")
    p.add_argument("--methods", default="dopri5,dop853",
                   help="comma-separated pairs to run (default %(default)s)")
    p.add_argument("--out", type=pathlib.Path, default=C.RESULTS_DIR)
    args = p.parse_args(argv)
    args.methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    unknown = sorted(set(args.methods) - {m for m, _, _ in SETTINGS})
    if unknown or not args.methods:
        p.error(f"--methods: dopri5 and/or dop853, got {args.methods!r}")
    return args


def starts(n, seed):
    """accuracy_cost.py --peers' starts (peers_compare.run)."""
    axes = T.grid_axes(1_000_000, np)
    grid_n = int(np.prod([len(v) for v in axes.values()]))
    return T.flat_columns(axes, np.random.default_rng(seed).permutation(grid_n)[:n], np)


def long_double_reference(cols):
    """(status, W, n_reversals) by heyoka in long double, one trajectory at a
    time, with the rest rule at every v = 0 (docs/physics.md 1.4)."""
    import heyoka as hy

    ld = np.longdouble
    lo, hi = T.DOMAIN
    x, v, w = hy.make_vars("x", "v", "w")
    fp, n = T.SLOPE + T.CURVATURE * x, T.G + v * v * T.CURVATURE
    q, d = hy.par[0], hy.par[1]
    neg = hy.event_direction.negative
    events = [hy.t_event(d * v, direction=neg, fp_type=ld), hy.t_event(x - lo, direction=neg, fp_type=ld),
              hy.t_event(hi - x, direction=neg, fp_type=ld)]
    ta = hy.taylor_adaptive([(x, v), (v, -n * (fp + q) / (1.0 + fp * fp)), (w, q * n * v)],
                            np.zeros(3, dtype=ld), pars=np.ones(2, dtype=ld), t_events=events, fp_type=ld)
    size = cols["x0"].size
    status, work, reversals = np.zeros(size, np.int64), np.zeros(size, ld), np.zeros(size, np.int64)

    def rest(xs, mu):  # the rest rule: 0 stays, else the direction of the pull
        slope = T.SLOPE + T.CURVATURE * float(xs)
        return 0.0 if abs(slope) <= mu else (-1.0 if slope > 0 else 1.0)

    for j in range(size):
        x0, v0, mu = float(cols["x0"][j]), float(cols["v0"][j]), float(cols["mu"][j])
        direction = np.sign(v0) if v0 != 0.0 else rest(x0, mu)
        if direction == 0.0:
            status[j] = STUCK
            continue
        ta.time = ld(0)
        ta.state[:] = np.array([x0, v0, 0.0], dtype=ld)
        ta.pars[:] = np.array([direction * mu, direction], dtype=ld)
        ta.reset_cooldowns()
        while True:
            outcome = ta.propagate_until(ld(T.T_MAX))[0]
            code = int(outcome)
            if outcome == hy.taylor_outcome.time_limit:
                status[j] = TIMEOUT
            elif code in (-2, -3):
                status[j] = EXITED
            elif code == -1:
                turn = rest(ta.state[0], mu)
                if turn != 0.0:
                    reversals[j] += turn != direction
                    direction = turn
                    ta.state[1] = ld(0)
                    ta.pars[:] = np.array([direction * mu, direction], dtype=ld)
                    continue
                status[j] = STUCK
            else:
                status[j] = DIVERGED
            work[j] = ta.state[2]
            break
    return status, work, reversals


def errors(w, w_ref):
    err = np.asarray(np.abs(np.asarray(w, np.longdouble) - w_ref) / np.maximum(np.abs(w_ref), W_FLOOR), float)
    err[(np.asarray(w) == 0.0) & (w_ref == 0.0)] = 0.0
    return err


def summary(err, same, ref_status):
    med, top = float(np.median(err[same])), float(err[same].max())
    by = {name: float(err[same & (ref_status == code)].max(initial=0.0))
          for code, name in ((STUCK, "stuck"), (EXITED, "exited"))}
    return {"median": med, "max": top, "ratio": top / med if med else None, "max_by_status": by,
            "worst": int(np.flatnonzero(same)[np.argmax(err[same])])}


def main(argv=None):
    args = parse_args(argv)
    try:
        import heyoka  # noqa: F401
    except ImportError as error:
        sys.exit(f"tight_reference.py needs heyoka ({error}): pip install .[bench]")
    import rampwork as rw

    cols = starts(args.n, args.seed)
    started = time.perf_counter()
    ref_status, ref_w, _ = long_double_reference(cols)
    print(f"long-double reference (heyoka): {args.n:,} starts in {time.perf_counter() - started:.1f} s; "
          f"stuck {(ref_status == STUCK).sum()}, exited {(ref_status == EXITED).sum()}", flush=True)
    ramp = rw.Ramp.create("quadratic", curvature=T.CURVATURE, slope=T.SLOPE, height=T.HEIGHT, domain=T.DOMAIN)
    headers = ["solver", "rtol", "atol", "projection", "W err median", "W err max", "max stuck",
               "max exited", "max/median", "steps", "run s (1 thread)", "worst (x0, v0, mu)"]
    rows, results = [], []

    def add(label, rtol, atol, out, steps, projection="-", run_s=None):
        same = out["status"] == ref_status
        s = summary(errors(out["W_friction"], ref_w), same, ref_status)
        j = s["worst"]
        s.update(solver=label, rtol=rtol, atol=atol, projection=projection, wrong=int((~same).sum()),
                 steps=steps, run_s=run_s)
        results.append(s)
        rows.append([label, f"{rtol:g}", f"{atol:g}", projection, f"{s['median']:.2e}", f"{s['max']:.2e}",
                     f"{s['max_by_status']['stuck']:.2e}", f"{s['max_by_status']['exited']:.2e}",
                     f"{s['ratio']:.1f}", f"{steps:,}" if steps else "-",
                     "-" if run_s is None else f"{run_s:.3f}",
                     f"{cols['x0'][j]:.4f}, {cols['v0'][j]:.4f}, {cols['mu'][j]:.4f}"])
        print(" | ".join(rows[-1]) + f" | wrong {s['wrong']}", flush=True)

    cached = sorted(args.out.glob(f"peers-reference-{args.n}-*.npz"), key=lambda f: f.stat().st_mtime)
    if cached:  # accuracy_cost.py's scipy reference for the same starts (the newest)
        saved = np.load(cached[-1])
        add(f"rampwork.reference ({cached[-1].name})", 2.5e-14, 1e-16,
            {"status": saved["ref_status"], "W_friction": saved["ref_W_friction"]}, 0)
    runs = []  # (method, rtol, atol, projection label, scene)
    for method, rtol, atol in SETTINGS:
        if method not in args.methods:
            continue
        for projection in (True, False):
            try:
                integrator = rw.Integrator(method, rtol=rtol, atol=atol, closed_form=False,
                                           project_energy=projection)
                label = "on" if projection else "off"
            except TypeError:  # a rampwork without the option: its default, once
                if not projection:
                    continue
                integrator = rw.Integrator(method, rtol=rtol, atol=atol, closed_form=False)
                label = "(none)"
            runs.append((method, rtol, atol, label,
                         rw.Scene(ramp=ramp, friction=rw.Friction(0.2), g=T.G, t_max=T.T_MAX,
                                  integrator=integrator)))
    sweep = rw.Sweep.cases(**cols)
    datasets, times = {}, {}
    for round_ in range(max(args.repeat, 1) + 1):  # round 0 compiles (or loads the cache)
        for k, (_, _, _, _, scene) in enumerate(runs):
            ds = rw.simulate(scene, sweep, threads=1, kernel=C.KERNEL)
            datasets[k] = ds
            if round_:
                times[k] = min(times.get(k, float("inf")), float(ds.attrs["run_time_s"]))
    for k, (method, rtol, atol, label, _) in enumerate(runs):
        ds = datasets[k]
        add(f"rampwork {method}", rtol, atol,
            {"status": ds.status.values, "W_friction": ds.W_friction.values}, int(ds.steps.values.sum()),
            label, times[k])
    print()
    print(C.text_table(headers, rows))
    data = {"machine": C.machine_info(), "when": C.utc_now(), "n": args.n, "seed": args.seed,
            "reference": "heyoka taylor_adaptive, long double, default tol (its epsilon)",
            "reference_status_counts": {"stuck": int((ref_status == STUCK).sum()),
                                        "exited": int((ref_status == EXITED).sum())},
            "results": results}
    args.out.mkdir(parents=True, exist_ok=True)
    C.save_json(args.out / "tight_reference.json", data)
    C.save_text(args.out / "tight_reference.md", "# tight_reference\n\n" + C.markdown_table(headers, rows) + "\n")
    print(f"\nsaved {args.out / 'tight_reference.json'} and .md")


if __name__ == "__main__":
    main()
