#!/usr/bin/env python
"""The adaptive pairs at both ends of the accuracy range (issue 19, item 4).

dopri5 and dop853 at rtol = atol = 1e-3, 1e-4 (the loose end) and 1e-12,
1e-13 (the tight end), and at the tight end again with atol = 1e-4 rtol
(relative control of states and work below 1 in SI units), on throughput.py's
quadratic bowl (curvature 1 on (-1, 1), g = 9.81, t_max = 60 s) and its start
grid x0 x v0 x mu of --n (default 20,000: 27^3 = 19,683) starts, mu_k = mu_s =
mu.  For each run:

* wrong outcomes by kind (reference status -> status), over every start;
* the W error |W - W_ref| / max(|W_ref|, 1e-9) (as accuracy_cost.py): its
  median and maximum over a reference subset, and their ratio (issue 19's
  target at the tight end: max within 10x the median);
* the kernel's run time (compilation apart) and its steps.

References:

* status, over all starts: rampwork's own dop853 at rtol = atol = 1e-13,
  cross-checked with rampwork.reference (scipy DOP853 with events, rtol
  2.5e-14, atol 1e-16: no code shared with the kernel) on every start where
  any run's status differs from it; scipy's status counts where the two
  disagree (printed);
* W: rampwork.reference on --w-subset random starts plus the --w-short
  shortest trajectories (the slow starts that stop or leave within their
  first steps) and the --w-long longest (many reversals: the global error).
  It steps to its events; its W is within 1.3e-14 of a long-double Taylor
  integration (heyoka) on 600 of accuracy_cost.py's peers starts, including
  its former worst.  Its own error is shown by a second reference at rtol
  1e-13, atol 1e-15 on the same starts ("reference self-check").

Run from the repository root::

    .venv/bin/python benchmarks/accuracy_ends.py            # 20,000 starts
    .venv/bin/python benchmarks/accuracy_ends.py --quick    # 1,000 starts

Results (JSON and markdown) go to benchmarks/results/accuracy_ends.*.
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402
import throughput as T  # noqa: E402  (the scene and the grid only)

METHODS = ("dopri5", "dop853")
RTOLS = (1e-3, 1e-4, 1e-12, 1e-13)
#: the tight end again with atol = rtol * TIGHT_ATOL_FACTOR: relative control
#: of states and work well below 1 (SI units), where atol = rtol is absolute
TIGHT_ATOL_FACTOR = 1e-4
STATUS_RTOL = 1e-13  # rampwork dop853: the status reference over every start
REF_RTOL, REF_ATOL = 2.5e-14, 1e-16  # rampwork.reference (scipy DOP853)
CHECK_RTOL, CHECK_ATOL = 1e-13, 1e-15  # the reference's self-check
W_FLOOR = 1e-9  # as accuracy_cost.py
STATUS_NAMES = {1: "stuck", 2: "exited", 3: "lifted_off", 4: "timeout", 5: "diverged"}


def parse_args(argv=None):
    p = argparse.ArgumentParser(prog="accuracy_ends.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--n", type=float, default=20_000, help="starts in the grid (default %(default)g)")
    p.add_argument("--w-subset", type=int, default=300, help="random starts with a scipy W reference")
    p.add_argument("--w-short", type=int, default=100, help="shortest trajectories added to the W subset")
    p.add_argument("--w-long", type=int, default=100, help="longest trajectories added to the W subset")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--quick", action="store_true", help="1,000 starts, 60 + 30 W references")
    p.add_argument("--out", type=pathlib.Path, default=C.RESULTS_DIR)
    args = p.parse_args(argv)
    if args.quick:
        args.n, args.w_subset, args.w_short, args.w_long = 1_000, 60, 30, 30
    return args


def make_scene(rw, method, rtol, atol=None):
    atol = rtol if atol is None else atol
    ramp = rw.Ramp.create("quadratic", curvature=T.CURVATURE, slope=T.SLOPE, height=T.HEIGHT,
                          domain=T.DOMAIN)
    return rw.Scene(ramp=ramp, friction=rw.Friction(0.2), g=T.G, t_max=T.T_MAX,
                    integrator=rw.Integrator(method, rtol=rtol, atol=atol, closed_form=False),
                    title=f"accuracy_ends: {method} at rtol {rtol:g}, atol {atol:g}")


def run(rw, scene, cols):
    """(outputs by name, run time s, compile time s) of one kernel call."""
    started = time.perf_counter()
    rw.simulate(scene, rw.Sweep.cases(**{k: v[:2] for k, v in cols.items()}), kernel=C.KERNEL)
    first_s = time.perf_counter() - started
    ds = rw.simulate(scene, rw.Sweep.cases(**cols), kernel=C.KERNEL)
    out = {k: ds[k].values.ravel().copy() for k in ("status", "x_end", "W_friction", "t_end", "steps")}
    return out, float(ds.attrs["run_time_s"]), first_s


def scipy_reference(rw, reference, cols, index, rtol, atol):
    scene = make_scene(rw, "dop853", 1e-8)  # only the physics is read
    out = {"status": [], "W_friction": [], "x_end": []}
    for j in index:
        r = reference.reference_trajectory(scene, x0=float(cols["x0"][j]), v0=float(cols["v0"][j]),
                                           mu_k=float(cols["mu"][j]), mu_s=float(cols["mu"][j]),
                                           rtol=rtol, atol=atol)
        for k in out:
            out[k].append(r[k])
    return {k: np.asarray(v) for k, v in out.items()}


def w_errors(w, w_ref):
    err = np.abs(w - w_ref) / np.maximum(np.abs(w_ref), W_FLOOR)
    err[(w == 0.0) & (w_ref == 0.0)] = 0.0
    return err


def main(argv=None):
    args = parse_args(argv)
    import rampwork as rw
    from rampwork import reference

    axes = T.grid_axes(int(args.n), np)
    n = int(np.prod([len(v) for v in axes.values()]))
    cols = T.flat_columns(axes, np.arange(n), np)
    print(f"accuracy_ends: throughput.py's bowl, {n:,} starts (x0 x v0 x mu = "
          f"{' x '.join(str(len(v)) for v in axes.values())}), rtol = atol", flush=True)

    ref, ref_s, _ = run(rw, make_scene(rw, "dop853", STATUS_RTOL), cols)
    print(f"status reference: rampwork dop853 at {STATUS_RTOL:g} ({ref_s:.2f} s)", flush=True)
    runs = {}
    for method in METHODS:
        for rtol, atol in [(r, r) for r in RTOLS] + [(r, r * TIGHT_ATOL_FACTOR) for r in RTOLS
                                                     if r < 1e-10]:
            out, run_s, first_s = run(rw, make_scene(rw, method, rtol, atol), cols)
            runs[(method, rtol, atol)] = (out, run_s, first_s)

    # the status reference, cross-checked with scipy where any run disagrees
    disagree = sorted({int(j) for out, _, _ in runs.values()
                       for j in np.flatnonzero(out["status"] != ref["status"])})
    status_ref = ref["status"].copy()
    started = time.perf_counter()
    sci = scipy_reference(rw, reference, cols, disagree, REF_RTOL, REF_ATOL)
    overruled = [j for k, j in enumerate(disagree) if sci["status"][k] != ref["status"][j]]
    status_ref[disagree] = sci["status"]
    print(f"scipy on the {len(disagree)} starts where a run's status differs from the status "
          f"reference ({time.perf_counter() - started:.1f} s): it overrules it on {len(overruled)}",
          flush=True)

    # the W reference subset: random starts and the shortest trajectories
    rng = np.random.default_rng(args.seed)
    by_length = np.argsort(ref["t_end"], kind="stable")
    shortest, longest = by_length[:args.w_short], by_length[::-1][:args.w_long]
    subset = np.unique(np.concatenate([rng.permutation(n)[:args.w_subset], shortest, longest]))
    started = time.perf_counter()
    wref = scipy_reference(rw, reference, cols, subset, REF_RTOL, REF_ATOL)
    wref_s = time.perf_counter() - started
    check = scipy_reference(rw, reference, cols, subset, CHECK_RTOL, CHECK_ATOL)
    same_ref = check["status"] == wref["status"]
    self_err = w_errors(check["W_friction"][same_ref], wref["W_friction"][same_ref])
    print(f"W reference: scipy on {subset.size} starts ({args.w_subset} random, {args.w_short} "
          f"shortest, {args.w_long} longest; {wref_s:.1f} s); self-check at rtol {CHECK_RTOL:g}: W diff median "
          f"{np.median(self_err):.2e}, max {self_err.max():.2e}", flush=True)

    rows, results = [], []
    for (method, rtol, atol), (out, run_s, first_s) in runs.items():
        wrong = np.flatnonzero(out["status"] != status_ref)
        kinds: dict[str, int] = {}
        for j in wrong:
            key = f"{STATUS_NAMES.get(int(status_ref[j]), status_ref[j])}->" \
                  f"{STATUS_NAMES.get(int(out['status'][j]), out['status'][j])}"
            kinds[key] = kinds.get(key, 0) + 1
        same = out["status"][subset] == wref["status"]
        err = w_errors(out["W_friction"][subset][same], wref["W_friction"][same])
        worst = int(subset[same][np.argmax(err)])
        med, top = float(np.median(err)), float(err.max())
        # by the reference's status: stops (W insensitive to the event's time,
        # v = 0) and exits (W' > 0 there) fail in different ways
        by_status = {name: float(err[wref["status"][same] == code].max(initial=0.0))
                     for code, name in ((1, "stuck"), (2, "exited"))}
        results.append({"method": method, "rtol": rtol, "atol": atol, "wrong": int(wrong.size),
                        "wrong_by_kind": kinds, "wrong_index": wrong.tolist()[:20],
                        "W_error_median": med, "W_error_max": top, "W_error_max_by_status": by_status, "max_over_median": top / med if med else None,
                        "worst": {k: float(cols[k][worst]) for k in cols} | {"index": worst},
                        "run_time_s": run_s, "first_call_s": first_s,
                        "steps": int(out["steps"].sum())})
        rows.append([method, f"{rtol:g}", f"{atol:g}", str(wrong.size), ", ".join(f"{k} {v}" for k, v in kinds.items()) or "-",
                     f"{med:.2e}", f"{top:.2e}", f"{by_status['stuck']:.2e}", f"{by_status['exited']:.2e}",
                     f"{top / med:.1f}" if med else "-",
                     f"{run_s:.3f}", f"{out['steps'].sum():,}"])
    headers = ["method", "rtol", "atol", "wrong", "wrong by kind (ref->got)", "W err median", "W err max",
               "max stuck", "max exited", "max/median", "run s", "steps"]
    print()
    print(C.text_table(headers, rows))
    data = {"machine": C.machine_info(), "when": C.utc_now(), "n": n, "grid": {k: [float(v[0]), float(v[-1]), len(v)] for k, v in axes.items()},
            "status_reference": {"kind": f"rampwork dop853 rtol = atol = {STATUS_RTOL:g}",
                                 "scipy_checked": len(disagree), "scipy_overruled": overruled},
            "w_reference": {"kind": f"rampwork.reference DOP853 rtol {REF_RTOL:g} atol {REF_ATOL:g}",
                            "n": int(subset.size), "random": args.w_subset, "shortest": args.w_short,
                            "longest": args.w_long,
                            "self_check_median": float(np.median(self_err)),
                            "self_check_max": float(self_err.max())},
            "results": results}
    args.out.mkdir(parents=True, exist_ok=True)
    C.save_json(args.out / "accuracy_ends.json", data)
    C.save_text(args.out / "accuracy_ends.md", "# accuracy_ends\n\n" + C.markdown_table(headers, rows) + "\n")
    print(f"\nsaved {args.out / 'accuracy_ends.json'} and .md")


if __name__ == "__main__":
    main()
