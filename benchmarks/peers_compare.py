"""rampwork against heyoka and CyRK at matched error, on throughput.py's quadratic bowl.

Used by ``accuracy_cost.py --peers`` (see benchmarks/README.md).  On N starts
drawn from throughput.py's bowl grid (x0, v0, mu; 20,000 by default, the
issue's setting) it runs, interleaved, fastest of ``repeat`` runs each:

* rampwork dopri5 and dop853 through ``rw.simulate(scene, Sweep.cases(...))``,
  2 threads, rtol = atol 1e-3 ... 1e-13: the kernel's ``run_time_s`` and the
  wall time of the whole call (compile excluded by a warm-up call);
* heyoka (tol 1e-3 ... 1e-12) and CyRK DOP853 / RK45 (rtol = atol) through
  ``peers``, 2 worker processes each, wall time of the whole batch (warm).

Errors: against ``rampwork.reference`` (scipy DOP853 with events, rtol 2.5e-14)
on every start, the measure of accuracy_cost.py (median and max of
|W - W_ref| / max(|W_ref|, 1e-9 J) where the status agrees); trajectories on
which the reference is not converged (status, W or x_end move between rtol
1e-13 and 2.5e-14) are left out.  Wrong outcomes: status different from the
reference's, or x_end outside the domain, for every system.

Matched-error ratio at a target: the time of a system's cheapest setting whose
error (median, or max) is within the target with no wrong outcome, over the
time of rampwork's cheapest such setting (dopri5 or dop853): the cheapest
setting meeting it, no interpolation.
"""

from __future__ import annotations

import math
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

import accuracy_cost as A
import peers
import throughput as T

RAMPWORK_RTOLS = tuple(10.0 ** -k for k in range(3, 14))
PEER_TOLS = tuple(10.0 ** -k for k in range(3, 13))
TARGETS = tuple(10.0 ** -k for k in range(3, 13))
END_TO_END_TARGETS = (1e-6, 1e-9, 1e-12)
THREADS = 2
PEER_NAMES = {"heyoka": "heyoka", "heyoka_propagate": "heyoka in propagate_until", "cyrk_DOP853": "CyRK DOP853",
              "cyrk_RK45": "CyRK RK45"}


def bowl_key():
    return peers.ramp_key("quadratic", {"curvature": T.CURVATURE, "slope": T.SLOPE, "height": T.HEIGHT},
                          T.DOMAIN, T.G, T.T_MAX)


def reference_chunk(task):
    """rampwork.reference on a chunk of starts (in a worker process)."""
    import warnings

    import rampwork as rw
    from rampwork import reference

    cols, rtol, atol = task
    ramp = rw.Ramp.create("quadratic", curvature=T.CURVATURE, slope=T.SLOPE, height=T.HEIGHT, domain=T.DOMAIN)
    scene = rw.Scene(ramp=ramp, friction=rw.Friction(mu_k=0.2), g=T.G, t_max=T.T_MAX)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = reference.reference_sweep(scene, rw.Sweep.cases(**cols), rtol=rtol, atol=atol)
    return {k: out[k] for k in ("status", "x_end", "W_friction", "t_end", "n_reversals")}


class Workers:
    """WORKERS single-process executors (spawned: no fork of a threaded parent):
    chunk k of a batch always goes to worker k."""

    def __init__(self, n=peers.WORKERS):
        ctx = multiprocessing.get_context("spawn")
        self.pools = [ProcessPoolExecutor(1, mp_context=ctx) for _ in range(n)]

    def map(self, fn, tasks):
        futures = [self.pools[k % len(self.pools)].submit(fn, task) for k, task in enumerate(tasks)]
        return [f.result() for f in futures]

    def close(self):
        for pool in self.pools:
            pool.shutdown()


def _split(cols, parts):
    return [{k: v[i::parts] for k, v in cols.items()} for i in range(parts)]


def _merge(chunks, n):
    """Re-interleave the outputs of _split (chunk i holds starts i, i+parts, ...)."""
    out = {}
    for key in chunks[0]:
        if key in ("compile_s", "propagate_s"):  # the workers run side by side: the slower counts
            out[key] = max(c[key] for c in chunks)
            continue
        arr = np.empty(n, dtype=np.asarray(chunks[0][key]).dtype)
        for i, c in enumerate(chunks):
            arr[i::len(chunks)] = c[key]
        out[key] = arr
    return out


#: CyRK's route: the compiled adapter (_cyrk_ramp.pyx) where it builds, else pysolve_ivp
CYRK_ROUTE = {"compiled": False}


def run_peer(workers, system, tol, cols, key=None):
    """(result dict, wall seconds) of one peer setting over all starts (of
    the bowl, or of the ramp ``key``)."""
    key = bowl_key() if key is None else key
    parts = _split(cols, len(workers.pools))
    if system == "heyoka":
        tasks = [(key, tol, c["x0"], c["v0"], c["mu"], c["mu"]) for c in parts]
        fn = peers.heyoka_chunk
    else:
        method = system.split("_", 1)[1]
        tasks = [(key, method, tol, c["x0"], c["v0"], c["mu"], c["mu"]) for c in parts]
        fn = peers.cyrk_compiled_chunk if CYRK_ROUTE["compiled"] else peers.cyrk_chunk
    started = time.perf_counter()
    chunks = workers.map(fn, tasks)
    return _merge(chunks, cols["x0"].size), time.perf_counter() - started


_SCENE_WORKERS: list = []


def scene_peer_run(spec, method, tol, cols, repeat):
    """A peer (``heyoka`` or ``CyRK_DOP853``) on one of accuracy_cost.py's
    scenes: (result, fastest wall time of ``repeat`` runs, warm)."""
    if not _SCENE_WORKERS:
        if peers.build_cyrk()[0] is not None:
            CYRK_ROUTE.update(compiled=True)
        _SCENE_WORKERS.append(Workers())
    workers = _SCENE_WORKERS[0]
    key = peers.ramp_key(spec.family, spec.params, spec.domain, 9.81, spec.t_max)
    system = "heyoka" if method == "heyoka" else "cyrk_DOP853"
    run_peer(workers, system, tol, {k: v[:16] for k, v in cols.items()}, key)  # warm-up
    walls = []
    for _ in range(repeat):
        out, wall = run_peer(workers, system, tol, cols, key)
        walls.append(wall)
    return out, min(walls)


def rampwork_scene(rw, method, rtol):
    ramp = rw.Ramp.create("quadratic", curvature=T.CURVATURE, slope=T.SLOPE, height=T.HEIGHT, domain=T.DOMAIN)
    return rw.Scene(ramp=ramp, friction=rw.Friction(mu_k=0.2), integrator=rw.Integrator(method, rtol=rtol, atol=rtol),
                    g=T.G, t_max=T.T_MAX, title=f"peers benchmark: {method} rtol {rtol:g}")


def run_rampwork(rw, method, rtol, cols):
    scene = rampwork_scene(rw, method, rtol)
    sweep = rw.Sweep.cases(**cols)
    started = time.perf_counter()
    ds = rw.simulate(scene, sweep, threads=THREADS, kernel=A.C.KERNEL)
    wall = time.perf_counter() - started
    out = {k: ds[k].values.ravel().copy() for k in ("status", "x_end", "W_friction", "t_end", "steps")}
    out["compile_s"] = float(ds.attrs["compile_time_s"])
    return out, wall, float(ds.attrs["run_time_s"])


def settings(available) -> list[dict]:
    rows = [{"system": m, "tol": r, "label": f"rampwork {m} rtol={A.fmt_e(r)}"}
            for m in A.ADAPTIVE_METHODS for r in RAMPWORK_RTOLS]
    if available.get("heyoka"):
        rows += [{"system": "heyoka", "tol": r, "label": f"heyoka tol={A.fmt_e(r)}"} for r in PEER_TOLS]
    if available.get("cyrk"):
        rows += [{"system": "cyrk_DOP853", "tol": r, "label": f"CyRK DOP853 rtol={A.fmt_e(r)}"} for r in PEER_TOLS]
        rows += [{"system": "cyrk_RK45", "tol": r, "label": f"CyRK RK45 rtol={A.fmt_e(r)}"} for r in PEER_TOLS]
    return rows


def _reference_source() -> bytes:
    """rampwork.reference's source: a cached reference is stale once it changes."""
    from rampwork import reference as module

    return open(module.__file__, "rb").read()


def reference(workers, cols, np_, cache_dir=None):
    """The reference at REF and REF_CHECK tolerances; (ref, valid mask, info).
    Kept in ``cache_dir`` (keyed by the starts' hash): it takes minutes."""
    import hashlib

    n = cols["x0"].size
    parts = 8 * len(workers.pools)
    started = time.perf_counter()
    digest = hashlib.sha1(b"".join(np.ascontiguousarray(cols[k]).tobytes() for k in ("x0", "v0", "mu"))
                          + repr((A.REF_RTOL, A.REF_ATOL, A.REF_CHECK_RTOL, A.REF_CHECK_ATOL)).encode()
                          + _reference_source()).hexdigest()
    cache = None if cache_dir is None else cache_dir / f"peers-reference-{n}-{digest[:12]}.npz"
    if cache is not None and cache.exists():
        saved = np.load(cache)
        ref = {k[4:]: saved[k] for k in saved.files if k.startswith("ref_")}
        check = {k[6:]: saved[k] for k in saved.files if k.startswith("check_")}
    else:
        ref = _merge(workers.map(reference_chunk, [(c, A.REF_RTOL, A.REF_ATOL) for c in _split(cols, parts)]), n)
        check = _merge(workers.map(reference_chunk, [(c, A.REF_CHECK_RTOL, A.REF_CHECK_ATOL)
                                                     for c in _split(cols, parts)]), n)
        if cache is not None:
            cache.parent.mkdir(parents=True, exist_ok=True)
            np.savez(cache, **{f"ref_{k}": v for k, v in ref.items()}, **{f"check_{k}": v for k, v in check.items()})
    usable = A.reference_validity(ref, T.DOMAIN, np_)
    dw = np.abs(check["W_friction"] - ref["W_friction"]) / np.maximum(np.abs(ref["W_friction"]), A.W_FLOOR)
    dx = np.where(np.isin(ref["status"], A.X_INFORMATIVE), np.abs(check["x_end"] - ref["x_end"]), 0.0)
    converged = (check["status"] == ref["status"]) & (dw <= A.UNCONVERGED) & (dx <= A.UNCONVERGED)
    valid = usable & converged
    info = {"seconds": time.perf_counter() - started, "cached": str(cache) if cache is not None else None,
            "invalid": int((~usable).sum()),
            "unconverged": int((usable & ~converged).sum()),
            "check_W_diff_max": float(dw[valid].max()), "check_W_diff_median": float(np.median(dw[valid])),
            "status_counts": {A.STATUS_NAMES[s]: int((ref["status"] == s).sum()) for s in A.STATUS_NAMES
                              if (ref["status"] == s).any()}}
    return ref, valid, info


def matched(rows, targets, time_key, on, strict=True):
    """Per target: each system's cheapest setting with error (``on``: median
    or max) within the target and (``strict``) no wrong outcome, and its time
    over rampwork's best (dopri5 or dop853)."""
    families = {"rampwork": [r for r in rows if r["system"] in A.ADAPTIVE_METHODS]}
    for name in PEER_NAMES:
        if any(r["system"] == name for r in rows):
            families[name] = [r for r in rows if r["system"] == name]
    out = []
    for target in targets:
        entry = {"target": target}
        for fam, rs in families.items():
            fits = [r for r in rs if r[f"W_error_{on}"] <= target and not (strict and r["wrong_outcomes"])]
            best = min(fits, key=lambda r: r[time_key]) if fits else None
            entry[fam] = {"label": best["label"], "time_s": best[time_key]} if best else None
        rw_best = entry["rampwork"]
        for fam in families:
            if fam != "rampwork":
                e = entry[fam]
                entry[f"{fam}_ratio"] = (e["time_s"] / rw_best["time_s"]) if (e and rw_best) else None
        out.append(entry)
    return out


def run(rw, args) -> dict:
    """The whole comparison; prints as it goes, returns a JSON-able dict."""
    available = peers.availability()
    for name, why in available["why"].items():
        print(f"peers: {name} skipped: {why}", flush=True)
    n = args.peers_n
    rng = np.random.default_rng(args.seed)
    axes = T.grid_axes(1_000_000, np)
    grid_n = int(np.prod([len(v) for v in axes.values()]))
    cols = T.flat_columns(axes, rng.permutation(grid_n)[:n], np)
    if available.get("cyrk"):
        module, why = peers.build_cyrk()  # before the workers start: they import what it built
        CYRK_ROUTE.update(compiled=module is not None, why=why)
        print("peers: CyRK through " + ("its C++ solver with the right-hand side and events in C "
                                        "(_cyrk_ramp.pyx)" if module else
                                        f"pysolve_ivp with a Python right-hand side: {why}"), flush=True)
    workers = Workers()
    try:
        print(f"\n=== peers on throughput.py's quadratic bowl: {n:,} starts of its 10^6 grid; rampwork "
              f"{THREADS} threads, peers {peers.WORKERS} processes; errors against the reference on every start",
              flush=True)
        ref, valid, ref_info = reference(workers, cols, np, args.out)
        print(f"reference: {ref_info['seconds']:.0f} s; status {ref_info['status_counts']}; invalid "
              f"{ref_info['invalid']}, not converged (left out) {ref_info['unconverged']}; check W diff max "
              f"{ref_info['check_W_diff_max']:.1e}", flush=True)
        rows = settings(available)
        warm = {k: v[:16] for k, v in cols.items()}
        for r in rows:  # warm-up: compile (rampwork kernels, heyoka integrators in every worker)
            if r["system"] in A.ADAPTIVE_METHODS:
                r["compile_s"] = run_rampwork(rw, r["system"], r["tol"], warm)[0]["compile_s"]
            else:  # heyoka builds its integrator, CyRK's workers import their module
                r["compile_s"] = run_peer(workers, r["system"], r["tol"], warm)[0].get("compile_s", math.nan)
        results = {}
        for rep in range(args.peers_repeat):
            order = rows if rep % 2 == 0 else rows[::-1]
            for r in order:
                if r["system"] in A.ADAPTIVE_METHODS:
                    out, wall, kernel = run_rampwork(rw, r["system"], r["tol"], cols)
                else:
                    (out, wall), kernel = run_peer(workers, r["system"], r["tol"], cols), math.nan
                r.setdefault("wall_times_s", []).append(wall)
                r.setdefault("kernel_times_s", []).append(kernel)
                results[r["label"]] = out
                if "propagate_s" in out:
                    r.setdefault("propagate_times_s", []).append(out["propagate_s"])
        for r in rows:
            out = results[r["label"]]
            r["wall_s"] = min(r["wall_times_s"])
            r["kernel_s"] = min(r["kernel_times_s"]) if r["system"] in A.ADAPTIVE_METHODS else r["wall_s"]
            errs = A.errors_against(out, ref, valid, np)
            index = errs.pop("mismatch_index")
            r.update(errs)
            r["mismatch_starts"] = [{"index": int(j), "x0": float(cols["x0"][j]), "v0": float(cols["v0"][j]),
                                     "mu": float(cols["mu"][j]), "status": int(out["status"][j]),
                                     "reference_status": int(ref["status"][j])} for j in index[:20]]
            r["outside_domain"] = int(A.outside_domain(out["x_end"], T.DOMAIN, np).sum())
            r["wrong_outcomes"] = r["status_mismatch"] + r["outside_domain"]
            r["steps_mean"] = float(np.mean(out["steps"]))
            print(f"{r['label']:<28} wall {r['wall_s']:.4f} s, kernel {r['kernel_s']:.4f} s; W err median "
                  f"{A.fmt_err(r['W_error_median'])}, max {A.fmt_err(r['W_error_max'])}; wrong outcomes "
                  f"{r['wrong_outcomes']} (status {r['status_mismatch']}, outside {r['outside_domain']}); "
                  f"steps {r['steps_mean']:.1f}", flush=True)
    finally:
        workers.close()
    for r in [r for r in rows if r["system"] == "heyoka"]:  # heyoka without its Python driver's time
        rows.append(dict(r, system="heyoka_propagate", label="heyoka in propagate " + r["label"].split(" ")[1],
                         wall_s=min(r["propagate_times_s"]), kernel_s=min(r["propagate_times_s"])))
    res = {"n": n, "rampwork_threads": THREADS, "peer_workers": peers.WORKERS, "available": available,
           "cyrk_route": "compiled (_cyrk_ramp.pyx)" if CYRK_ROUTE["compiled"] else "pysolve_ivp (Python rhs)",
           "reference": ref_info, "n_valid": int(valid.sum()), "settings": rows}
    res["matched_kernel"] = {on: matched(rows, TARGETS, "kernel_s", on) for on in ("median", "max")}
    res["matched_end_to_end"] = {on: matched(rows, END_TO_END_TARGETS, "wall_s", on) for on in ("median", "max")}
    res["matched_kernel_ignoring_wrong"] = {on: matched(rows, TARGETS, "kernel_s", on, strict=False)
                                            for on in ("median", "max")}
    return res


# ------------------------------------------------------------------------------
# tables and figure
# ------------------------------------------------------------------------------


def _ratio_cell(entry, fam, lenient=None):
    e, ratio = entry.get(fam), entry.get(f"{fam}_ratio")
    if e is None:
        text = "not reached"
    elif ratio is None:
        text = f"{e['label'].split(' ')[-1]}: {e['time_s']:.3g} s (rampwork: not reached)"
    else:
        text = f"**{ratio:.2f}x** ({e['label'].split(' ')[-1]})"
    if lenient is not None and lenient.get(fam) != e:
        text += "; ignoring wrong outcomes " + _ratio_cell(lenient, fam)
    return text


def matched_tables(res) -> str:
    """Markdown: matched-error ratios (kernel and end-to-end), wrong outcomes."""
    fams = [f for f in PEER_NAMES if any(r["system"] == f for r in res["settings"])]
    lines = []
    for title, key in (("kernel time (rampwork: the kernel's run_time_s; peers: wall time of the batch)",
                        "matched_kernel"),
                       ("end to end (rampwork: wall time of rw.simulate; peers: wall time of the batch)",
                        "matched_end_to_end")):
        for on in ("median", "max"):
            head = ["W error target", "rampwork best (s)"] + [f"{PEER_NAMES[f]} / rampwork" for f in fams]
            lenient = res["matched_kernel_ignoring_wrong"][on] if key == "matched_kernel" else None
            rows = []
            for k, entry in enumerate(res[key][on]):
                rwb = entry["rampwork"]
                rows.append([A.fmt_e(entry["target"]),
                             f"{rwb['label'].split(' ', 1)[1]} ({rwb['time_s']:.3g} s)" if rwb else "not reached"]
                            + [_ratio_cell(entry, f, lenient[k] if lenient else None) for f in fams])
            lines += [f"Matched {on} error, {title}; {res['n']:,} starts; the cheapest setting within the "
                      "target with no wrong outcome:", "", A.C.markdown_table(head, rows), ""]
    head = ["setting", "wall s", "kernel s", "W err median", "W err max", "wrong outcomes (status, outside)", "steps"]
    rows = [[r["label"], f"{r['wall_s']:.4f}", f"{r['kernel_s']:.4f}", A.fmt_err(r["W_error_median"]),
             A.fmt_err(r["W_error_max"]), f"{r['wrong_outcomes']} ({r['status_mismatch']}, {r['outside_domain']})",
             f"{r['steps_mean']:.1f}"] for r in res["settings"]]
    lines += [f"Every setting ({res['n_valid']:,} of {res['n']:,} starts compared; the reference left out "
              f"{res['reference']['unconverged']} not converged and {res['reference']['invalid']} invalid):", "",
              A.C.markdown_table(head, rows), ""]
    return "\n".join(lines)


STYLE = {"dopri5": ("D", "C3", "rampwork dopri5"), "dop853": ("X", "k", "rampwork dop853"),
         "heyoka": ("o", "C0", "heyoka (batch, 2 processes)"),
         "heyoka_propagate": ("o", "C9", "heyoka, time inside propagate_until only"),
         "cyrk_DOP853": ("s", "C1", "CyRK DOP853 (2 processes)"),
         "cyrk_RK45": ("^", "C2", "CyRK RK45 (2 processes)")}


def draw(res, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 5.2), layout="constrained")
    for ax, on in zip(axes, ("median", "max")):
        for system, (marker, color, label) in STYLE.items():
            rs = [r for r in res["settings"] if r["system"] == system]
            if not rs:
                continue
            err = np.maximum([r[f"W_error_{on}"] for r in rs], A.PLOT_FLOOR)
            for key, ls, suffix in (("wall_s", "-", ""), ("kernel_s", ":", " (kernel)")):
                if key == "kernel_s" and system not in A.ADAPTIVE_METHODS:
                    continue
                t = np.array([r[key] for r in rs]) * 1e5 / res["n"]
                ax.plot(t, err, marker=marker, color=color, linestyle="--" if system == "heyoka_propagate" else ls,
                        label=label + suffix,
                        markerfacecolor=color if key == "wall_s" else "white")
                bad = np.array([r["wrong_outcomes"] > 0 for r in rs])
                if bad.any():
                    ax.plot(t[bad], err[bad], "o", ms=12, mfc="none", mec="k", mew=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(alpha=0.3)
        ax.set_xlabel("time per 10$^5$ trajectories (s): solid wall time, dotted rampwork's kernel time")
        ax.set_ylabel(f"{on} relative error of W_friction")
        ax.set_title(f"{on} over {res['n_valid']:,} starts (ringed: wrong outcomes)", fontsize=10)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"rampwork against heyoka and CyRK on throughput.py's quadratic bowl, {res['n']:,} starts; "
                 f"rampwork {res['rampwork_threads']} threads, peers {res['peer_workers']} processes", fontsize=10.5)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
