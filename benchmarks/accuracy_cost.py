#!/usr/bin/env python
"""What accuracy costs in time: work-precision diagrams of rampwork's methods.

For four scenes (a straight ramp; a convex circular bowl with several
reversals ending stuck; a concave circular dome ending in lift-off; a sine
ramp whose convexity changes sign), each a small random sweep of x0, v0 and mu
around the scene's case, the benchmark runs in one process

* rampwork's fixed-step methods (euler, semi_implicit_euler, rk4) over a range
  of dt, and the adaptive pairs dopri5 (Dormand-Prince 5(4)) and dop853
  (Dormand-Prince 8(5,3)) over rtol = atol from 1e-3 to 1e-13; time per
  10^5 trajectories is scaled from the kernel's measured ``run_time_s``
  (compile time, from the first call of each kernel, is reported apart);
* an independent reference, ``rampwork.reference.reference_sweep`` (scipy
  DOP853 with events, rtol 2.5e-14, atol 1e-16), on a random subset of each sweep:
  the errors are the median and max over that subset of
  ``|W - W_ref| / max(|W_ref|, 1e-9 J)`` (work against friction) and of
  ``|x_end - x_ref|`` (m; on trajectories whose end is not a domain end);
  trajectories whose status differs from the reference's are left out of the
  errors and counted; reference trajectories that are not valid (an x_end
  outside the domain, a non-final status) are left out of everything and
  counted, and so are those on which it is not converged (status, W or x_end
  change between rtol 1e-13 and 2.5e-14: a start on a knife edge, or an event
  that the looser run missed);
* the peer on the same axes: ``scipy.integrate.solve_ivp`` with the same
  events (``rampwork.reference.reference_trajectory`` with ``method`` RK45 or
  DOP853 at rtol = atol 1e-4 .. 1e-10), timed per trajectory on a subset,
  one process, scaled to 10^5 trajectories;
* at rtol = 1e-8 on the quadratic-bowl grid of ``throughput.py`` (10^6
  trajectories, 10^5 with ``--quick``): dopri5's and dop853's trajectories
  per second on 2 threads (their repeats interleaved, the fastest of each
  counts) beside scipy's rate on a subset, each pair's mean steps and rejected
  steps per trajectory and its error on a reference subset, and whether the
  target of 10^6 trajectories/s is met (by either pair).

* with ``--peers`` (optional extra ``bench``: heyoka and CyRK; skipped with a
  printed line where they are missing): heyoka and CyRK DOP853 on the four
  scenes (2 processes each; their curves join the figure), and
  ``peers_compare.py`` on 20,000 starts of the quadratic-bowl grid: rampwork's
  dopri5 / dop853 against heyoka and CyRK at matched median and max error, by
  kernel time and end to end (``rw.simulate``'s wall time), with every
  system's wrong outcomes counted.

It prints a table as it goes and a summary at the end (what accuracy costs,
and the fastest method for each accuracy target from 1e-3 to 1e-12), and
saves JSON (with the machine), markdown, PNG and netCDF (dims scene x
setting) under ``--out``.

Run from the repository root::

    .venv/bin/python benchmarks/accuracy_cost.py --quick   # smoke run, < 3 min once compiled
    .venv/bin/python benchmarks/accuracy_cost.py           # full run, about 10 min once compiled
"""

from __future__ import annotations

import argparse
import math
import pathlib
import sys
import time
import warnings
from dataclasses import dataclass

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402

# ------------------------------------------------------------------------------
# the scenes
# ------------------------------------------------------------------------------
STATUS_NAMES = {0: "not_run", 1: "stuck", 2: "exited", 3: "lifted_off", 4: "timeout", 5: "diverged"}
STUCK, EXITED, LIFTED_OFF, TIMEOUT, DIVERGED = 1, 2, 3, 4, 5
#: statuses whose x_end is not a domain end by construction: x_end errors are
#: computed on these only
X_INFORMATIVE = (STUCK, LIFTED_OFF, TIMEOUT)
#: floor of |W_ref| in the relative work error (J)
W_FLOOR = 1e-9
#: errors below this are drawn on it (exact to rounding)
PLOT_FLOOR = 1e-16
#: tolerance of the "x_end outside the domain" check (m)
DOMAIN_SLACK = 1e-9


@dataclass(frozen=True)
class SceneSpec:
    key: str
    title: str
    family: str
    params: dict
    domain: tuple
    contact: str
    #: start ranges: (low, high) or a tuple of such intervals (drawn in
    #: proportion to their lengths)
    ranges: dict
    t_max: float = 60.0
    what: str = ""


SCENES = (
    SceneSpec("straight", "(a) straight ramp", "straight", {"slope": -0.5, "height": 0.0}, (-1.0, 1.0),
              "one_sided",
              # mu away from the slope 0.5, where a block decelerates for ever
              {"x0": (-0.9, 0.5), "v0": (-2.5, 2.5), "mu": ((0.1, 0.35), (0.65, 0.9))},
              what="y = -0.5 x on (-1, 1) m; launched up or down the slope: sticks (mu > 0.5) or exits"),
    SceneSpec("bowl", "(b) convex circular bowl", "circular_bowl",
              {"radius": 1.0, "x_centre": 0.0, "y_bottom": 0.0}, (-0.95, 0.95), "one_sided",
              {"x0": (0.6, 0.9), "v0": (-0.5, 0.5), "mu": (0.04, 0.12)},
              what="radius 1 m on (-0.95, 0.95) m, start high, slow, small mu: swings, ends stuck"),
    SceneSpec("dome", "(c) concave circular dome", "circular_dome",
              {"radius": 1.0, "x_centre": 0.0, "y_centre": 0.0}, (-0.95, 0.95), "one_sided",
              {"x0": (-0.2, 0.2), "v0": (0.5, 2.0), "mu": (0.02, 0.3)},
              what="radius 1 m on (-0.95, 0.95) m, start near the top with some speed: lifts off "
                   "(one-sided contact) or sticks near the top"),
    SceneSpec("sine", "(d) sine ramp, convexity changes sign", "sine",
              {"mean_slope": -0.2, "amplitude": 0.05, "wavenumber": 2.0 * math.pi, "phase": 0.0},
              (-2.0, 2.0), "one_sided",
              {"x0": (-1.8, -1.2), "v0": (0.0, 1.5), "mu": (0.05, 0.35)},
              what="y = -0.2 x + 0.05 sin(2 pi x) on (-2, 2) m (f'' up to +-2 /m): sticks in a dip, "
                   "exits or lifts off over a crest"),
)

FIXED_METHODS = ("euler", "semi_implicit_euler", "rk4")
#: the adaptive pairs, over rtol = atol: Dormand-Prince 5(4) and 8(5,3)
ADAPTIVE_METHODS = ("dopri5", "dop853")
RAMPWORK_METHODS = FIXED_METHODS + ADAPTIVE_METHODS
SCIPY_METHODS = ("RK45", "DOP853")
#: peers on the scenes with --peers (benchmarks/peers.py; optional extra 'bench'): heyoka's
#: Taylor integrator over tol and CyRK's DOP853 over rtol = atol, 2 processes each
PEER_METHODS = ("heyoka", "CyRK_DOP853")
ALL_METHODS = RAMPWORK_METHODS + SCIPY_METHODS + PEER_METHODS
METHOD_LABELS = {"euler": "Euler", "semi_implicit_euler": "semi-implicit Euler", "rk4": "RK4",
                 "dopri5": "dopri5", "dop853": "dop853", "RK45": "scipy RK45", "DOP853": "scipy DOP853",
                 "heyoka": "heyoka", "CyRK_DOP853": "CyRK DOP853"}
#: figure styles, readable in greyscale: marker, linestyle, colour, marker filled
STYLES = {"euler": ("o", "-", "C0", True), "semi_implicit_euler": ("s", "--", "C1", True),
          "rk4": ("^", "-.", "C2", True), "dopri5": ("D", ":", "C3", True),
          "dop853": ("X", (0, (7, 2, 1.5, 2, 1.5, 2)), "k", True),
          "RK45": ("v", "none", "C4", False), "DOP853": ("P", "none", "C5", False),
          "heyoka": ("o", (0, (1, 1)), "C6", False), "CyRK_DOP853": ("s", (0, (3, 1)), "C8", False)}

#: reference: rampwork.reference at these tolerances (atol applies to x, v, W and
#: the path: well below rtol, so that a small W is resolved relatively too).  The
#: same trajectories again at the looser REF_CHECK_* tolerances bound the
#: reference's own error, and flag trajectories on which it is not converged
#: (the status or W changes: a start on a knife edge, e.g. a block that barely
#: clears a crest, or an event that the looser run missed): those are left out
#: of every comparison and counted
REF_RTOL = 2.5e-14  # just above scipy's floor (100 machine epsilons)
REF_ATOL = 1e-16
REF_CHECK_RTOL = 1e-13
REF_CHECK_ATOL = 1e-15
#: a reference trajectory whose W (relative) or x_end (m) moves more than this
#: between the two tolerances is not converged
UNCONVERGED = 1e-8

FULL = dict(n=3000, ref_subset=200, scipy_subset=50,
            dts=(1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5),
            rtols=tuple(10.0 ** -k for k in range(3, 14)),
            scipy_rtols=(1e-4, 1e-6, 1e-8, 1e-10),
            tp_n=1_000_000, tp_scipy=200, tp_ref=200, repeat=3)
QUICK = dict(n=1000, ref_subset=40, scipy_subset=10,
             dts=(1e-2, 1e-3, 1e-4),
             rtols=(1e-3, 1e-6, 1e-9, 1e-12),
             scipy_rtols=(1e-4, 1e-8),
             tp_n=100_000, tp_scipy=50, tp_ref=50, repeat=2)

#: accuracy targets of the summary
TARGETS = tuple(10.0 ** -k for k in range(3, 13))
#: the adaptive pairs' trajectories per second on the throughput grid at rtol 1e-8, 2 threads
#: (the target is met if either pair meets it)
TP_RTOL = 1e-8
TP_TARGET = 1e6
TP_THREADS = 2
#: a timed run shorter than this is repeated (up to "repeat" times, fastest counts)
MIN_TIMED_S = 1.0
#: a setting whose run over the scene's sweep takes less than TILE_BELOW_S is
#: timed on the sweep repeated k times (about TILE_TARGET_S a run, at most
#: MAX_TIMED_TRAJECTORIES): per-call overhead and the last, half-empty lane
#: blocks would otherwise dominate the time of a fast method
TILE_BELOW_S = 0.1
TILE_TARGET_S = 0.3
MAX_TIMED_TRAJECTORIES = 500_000


def parse_args(argv=None):
    p = argparse.ArgumentParser(
        prog="accuracy_cost.py",
        description=(
            "Work-precision diagrams: error in W_friction and x_end against time per 10^5 "
            "trajectories for rampwork's euler, semi_implicit_euler and rk4 over dt and the "
            "adaptive pairs dopri5 and dop853 over rtol, on four scenes (straight, convex bowl, "
            "concave dome with lift-off, sine), against an independent scipy DOP853 reference, with "
            "scipy solve_ivp as the peer; and dopri5's and dop853's trajectories/s at rtol 1e-8 on "
            "throughput.py's quadratic-bowl grid. Saves JSON, markdown, PNG and netCDF under --out."))
    p.add_argument("--quick", action="store_true",
                   help="small sizes, fewer dt/rtol points (under 3 minutes once compiled)")
    p.add_argument("--out", type=pathlib.Path, default=C.RESULTS_DIR,
                   help="folder for the results (default benchmarks/results)")
    p.add_argument("--n", type=int, default=None,
                   help=f"trajectories per scene sweep (default {FULL['n']}, --quick {QUICK['n']})")
    p.add_argument("--threads", type=int, default=None,
                   help="threads of the rampwork runs (default NUMBA_NUM_THREADS); the rtol 1e-8 "
                        f"throughput line always uses {TP_THREADS}")
    p.add_argument("--scenes", default=",".join(s.key for s in SCENES),
                   help="comma-separated scenes to run (default %(default)s)")
    p.add_argument("--seed", type=int, default=0, help="seed of the sweeps and subsets (default 0)")
    p.add_argument("--no-throughput", action="store_true",
                   help="skip the rtol 1e-8 throughput line on the quadratic-bowl grid")
    p.add_argument("--throughput-only", action="store_true",
                   help="run only the rtol 1e-8 throughput line (no scenes, no figure)")
    p.add_argument("--no-figure", action="store_true", help="do not draw the PNG")
    p.add_argument("--gallery", type=pathlib.Path, default=None,
                   help="also write accuracy_cost.png and a short accuracy_cost.md (picks, throughput "
                        "line, summary) into this folder, e.g. studies/gallery")
    p.add_argument("--peers", action="store_true",
                   help="also compare with heyoka and CyRK (optional extra 'bench') at matched error on "
                        "throughput.py's quadratic bowl (benchmarks/peers_compare.py); skipped, with a line "
                        "saying so, where they are not installed")
    p.add_argument("--peers-only", action="store_true", help="run only the peers comparison")
    p.add_argument("--peers-n", type=int, default=None,
                   help="starts of the peers comparison (default 20000, --quick 2000)")
    p.add_argument("--peers-repeat", type=int, default=3, help="interleaved runs per setting, fastest counts")
    args = p.parse_args(argv)
    if args.peers_only:
        args.peers = args.no_throughput = True
    if args.peers_n is None:
        args.peers_n = 2000 if args.quick else 20_000
    sizes = QUICK if args.quick else FULL
    args.sizes = dict(sizes)
    if args.n is not None:
        if args.n < 10:
            p.error("--n must be >= 10")
        args.sizes["n"] = args.n
    args.sizes["ref_subset"] = min(args.sizes["ref_subset"], args.sizes["n"])
    keys = [k.strip() for k in args.scenes.split(",") if k.strip()]
    known = {s.key: s for s in SCENES}
    unknown = [k for k in keys if k not in known]
    if unknown or not keys:
        p.error(f"--scenes: unknown {unknown}; choose from {', '.join(known)}")
    args.scene_specs = [] if (args.throughput_only or args.peers_only) else [known[k] for k in keys]
    if args.throughput_only and args.no_throughput and not args.peers_only:
        p.error("--throughput-only and --no-throughput exclude each other")
    return args


# ------------------------------------------------------------------------------
# settings (one point of a work-precision curve)
# ------------------------------------------------------------------------------
def fmt_e(value) -> str:
    """1e-03 -> '1e-3', 3e-05 -> '3e-5'."""
    mantissa, exponent = f"{value:.0e}".split("e")
    return f"{mantissa}e{int(exponent)}"


def build_settings(sizes) -> list[dict]:
    settings = []
    for method in FIXED_METHODS:
        for dt in sizes["dts"]:
            settings.append({"label": f"{method} dt={fmt_e(dt)}", "solver": "rampwork", "method": method,
                             "dt": dt, "rtol": math.nan})
    for method in ADAPTIVE_METHODS:
        for rtol in sizes["rtols"]:
            settings.append({"label": f"{method} rtol={fmt_e(rtol)}", "solver": "rampwork",
                             "method": method, "dt": math.nan, "rtol": rtol})
    for method in SCIPY_METHODS:
        for rtol in sizes["scipy_rtols"]:
            settings.append({"label": f"scipy {method} rtol={fmt_e(rtol)}", "solver": "scipy",
                             "method": method, "dt": math.nan, "rtol": rtol})
    for method in PEER_METHODS if sizes.get("peers") else ():
        for rtol in (r for r in sizes["rtols"] if r >= 1e-12):
            settings.append({"label": f"{method} {'tol' if method == 'heyoka' else 'rtol'}={fmt_e(rtol)}",
                             "solver": "peer", "method": method, "dt": math.nan, "rtol": rtol})
    return settings


def make_ramp(rw, spec: SceneSpec):
    return rw.Ramp.create(spec.family, domain=spec.domain, **spec.params)


def make_scene(rw, spec: SceneSpec, method: str, dt=None, rtol=None):
    # each method itself, also on the straight ramp (not its closed form)
    if method in ADAPTIVE_METHODS:
        integrator = rw.Integrator(method, rtol=rtol, atol=rtol, closed_form=False)
    else:
        integrator = rw.Integrator(method, dt=dt, closed_form=False)
    return rw.Scene(ramp=make_ramp(rw, spec), friction=rw.Friction(mu_k=0.1), integrator=integrator,
                    x0=0.5 * (spec.domain[0] + spec.domain[1]), t_max=spec.t_max,
                    contact=spec.contact, title=f"accuracy_cost benchmark: {spec.title}")


def sample_cases(spec: SceneSpec, n: int, seed: int, np) -> dict:
    """x0, v0, mu columns drawn uniformly from the scene's ranges (a union of
    intervals in proportion to their lengths)."""
    rng = np.random.default_rng(seed)
    cols = {}
    for name in ("x0", "v0", "mu"):
        bounds = spec.ranges[name]
        intervals = bounds if isinstance(bounds[0], (tuple, list)) else (bounds,)
        lengths = np.array([hi - lo for lo, hi in intervals], float)
        which = rng.choice(len(intervals), size=n, p=lengths / lengths.sum())
        u = rng.uniform(0.0, 1.0, n)
        lo = np.array([iv[0] for iv in intervals])[which]
        cols[name] = lo + u * lengths[which]
    return cols


# ------------------------------------------------------------------------------
# rampwork runs
# ------------------------------------------------------------------------------
def kernel_source(rw, scene, sweep) -> str:
    """'compiled' or 'disk cache' for the run_batch dispatcher (rampwork
    internals; 'unknown' where they cannot be read)."""
    try:
        from rampwork import kernels, runner

        plan = runner.plan_run(scene, sweep)
        stats = kernels._KERNELS[plan.variant][0].stats
        hits, misses = sum(stats.cache_hits.values()), sum(stats.cache_misses.values())
        return "disk cache" if hits and not misses else ("compiled" if misses else "unknown")
    except Exception:  # noqa: BLE001 - informative only
        return "unknown"


def first_call(rw, scene, cols, threads) -> dict:
    """A tiny simulate that builds (or loads) the kernel: its compile time."""
    sweep = rw.Sweep.cases(**{k: v[:2] for k, v in cols.items()})
    started = time.perf_counter()
    ds = rw.simulate(scene, sweep, threads=threads, kernel=C.KERNEL)
    return {"compile_time_s": float(ds.attrs["compile_time_s"]),
            "first_call_wall_s": time.perf_counter() - started,
            "source": kernel_source(rw, scene, sweep)}


def timed_run(rw, scene, sweep, threads, repeat):
    """The fastest of up to ``repeat`` runs, repeating only while the runs
    together took less than MIN_TIMED_S.  Returns (dataset, runs, run times)."""
    best, times = None, []
    while True:
        ds = rw.simulate(scene, sweep, threads=threads, kernel=C.KERNEL)
        times.append(float(ds.attrs["run_time_s"]))
        if best is None or times[-1] < float(best.attrs["run_time_s"]):
            best = ds
        if len(times) >= repeat or sum(times) >= MIN_TIMED_S:
            return best, times


class OtherCpu:
    """Share of the machine's CPU time used by other processes while the
    block runs (Linux /proc; None elsewhere): 0.5 on 2 cores means another
    process kept one core busy, and timings are pessimistic."""

    @staticmethod
    def _read():
        try:
            with open("/proc/stat", encoding="ascii") as handle:
                fields = [int(v) for v in handle.readline().split()[1:]]
            with open("/proc/self/stat", encoding="ascii") as handle:
                own = handle.read().rsplit(")", 1)[1].split()
            total = sum(fields[:8])
            busy = total - fields[3] - fields[4]
            return total, busy, int(own[11]) + int(own[12])  # utime + stime of this process
        except (OSError, ValueError, IndexError):
            return None

    def __enter__(self):
        self.start = self._read()
        self.share = None
        return self

    def __exit__(self, *exc):
        end = self._read()
        if self.start and end and end[0] > self.start[0]:
            others = (end[1] - self.start[1]) - (end[2] - self.start[2])
            self.share = max(0.0, others / (end[0] - self.start[0]))
        return False


def timing(rw, scene, cols, threads, repeat, first_run_s, np):
    """(run times, trajectories per run) of the timed runs of one setting:
    the scene's sweep again (if its first run took long enough, that run
    counts too) or, for a fast setting, the sweep repeated k times."""
    n = cols["x0"].size
    if first_run_s >= TILE_BELOW_S:
        if first_run_s >= MIN_TIMED_S:
            return [first_run_s], n
        _, times = timed_run(rw, scene, rw.Sweep.cases(**cols), threads, repeat - 1)
        return [first_run_s, *times], n
    k = max(1, min(math.ceil(TILE_TARGET_S / max(first_run_s, 1e-5)), MAX_TIMED_TRAJECTORIES // n))
    sweep = rw.Sweep.cases(**{name: np.tile(values, k) for name, values in cols.items()})
    _, times = timed_run(rw, scene, sweep, threads, repeat)
    return times, k * n


def outside_domain(x, domain, np):
    x = np.asarray(x, float)
    return (x < domain[0] - DOMAIN_SLACK) | (x > domain[1] + DOMAIN_SLACK)


# ------------------------------------------------------------------------------
# reference and errors
# ------------------------------------------------------------------------------
def reference_on(rw, reference, spec, cols, rtol, atol, np) -> dict:
    scene = make_scene(rw, spec, "rk4", dt=1e-3)  # the integrator is ignored by the reference
    started = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = reference.reference_sweep(scene, rw.Sweep.cases(**cols), rtol=rtol, atol=atol)
    out = {k: np.asarray(v).ravel() for k, v in out.items()}
    out["seconds"] = time.perf_counter() - started
    return out


def reference_validity(ref, domain, np):
    """True where the reference trajectory is usable: a final status other
    than diverged, finite work, and an x_end inside the domain."""
    st = ref["status"]
    ok = (st >= STUCK) & (st <= TIMEOUT)
    ok &= np.isfinite(ref["W_friction"]) & np.isfinite(ref["x_end"])
    ok &= ~outside_domain(ref["x_end"], domain, np)
    return ok


def errors_against(result, ref, valid, np) -> dict:
    """Errors of ``result`` (arrays on the reference subset) where the
    reference is valid and the status agrees; status mismatches counted."""
    st, st_ref = np.asarray(result["status"]), ref["status"]
    same = valid & (st == st_ref)
    mismatch = valid & (st != st_ref)
    w, w_ref = np.asarray(result["W_friction"], float), ref["W_friction"]
    dw = np.abs(w - w_ref) / np.maximum(np.abs(w_ref), W_FLOOR)
    dw[(w == 0.0) & (w_ref == 0.0)] = 0.0
    dw = dw[same]
    x_mask = same & np.isin(st_ref, X_INFORMATIVE)
    dx = np.abs(np.asarray(result["x_end"], float) - ref["x_end"])[x_mask]
    out = {"n_valid": int(valid.sum()), "n_compared": int(same.sum()),
           "status_mismatch": int(mismatch.sum()), "n_x_compared": int(x_mask.sum()),
           "mismatch_index": np.flatnonzero(mismatch).tolist()}
    for name, values in (("W", dw), ("x", dx)):
        finite = values[np.isfinite(values)]
        out[f"{name}_error_median"] = float(np.median(finite)) if finite.size else math.nan
        out[f"{name}_error_max"] = float(np.max(finite)) if finite.size else math.nan
        out[f"{name}_error_nonfinite"] = int(values.size - finite.size)
    return out


def scipy_run(reference, scene, cols, method, rtol, np) -> dict:
    """solve_ivp with events, one trajectory at a time (rampwork.reference's
    segment loop at the given method and rtol = atol)."""
    n = cols["x0"].size
    out = {k: np.empty(n) for k in ("status", "t_end", "x_end", "W_friction", "nfev")}
    started = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for j in range(n):
            r = reference.reference_trajectory(scene, x0=cols["x0"][j], v0=cols["v0"][j],
                                               mu_k=cols["mu"][j], mu_s=cols["mu"][j],
                                               method=method, rtol=rtol, atol=rtol)
            for k in out:
                out[k][j] = r[k]
    out["seconds"] = time.perf_counter() - started
    out["status"] = out["status"].astype(np.int64)
    return out


def mismatch_details(reference, scene, cols, result, ref, indices, limit=5) -> list[dict]:
    """A few status mismatches with the reference's last event (and its
    rest-rule margin |f'| - mu_s where there is one): enough to tell a
    threshold case from a wrong result."""
    details = []
    for j in indices[:limit]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = reference.reference_trajectory(scene, x0=cols["x0"][j], v0=cols["v0"][j],
                                               mu_k=cols["mu"][j], mu_s=cols["mu"][j],
                                               rtol=REF_RTOL, atol=REF_ATOL)
        last = r["events"][-1]
        details.append({
            "x0": float(cols["x0"][j]), "v0": float(cols["v0"][j]), "mu": float(cols["mu"][j]),
            "status": STATUS_NAMES[int(result["status"][j])],
            "x_end": float(result["x_end"][j]), "t_end": float(result["t_end"][j]),
            "W_friction": float(result["W_friction"][j]),
            "reference_status": STATUS_NAMES[int(ref["status"][j])],
            "reference_x_end": float(ref["x_end"][j]), "reference_t_end": float(ref["t_end"][j]),
            "reference_W_friction": float(ref["W_friction"][j]),
            "reference_last_event": last["kind"], "reference_margin": last.get("margin")})
    return details


# ------------------------------------------------------------------------------
# one scene
# ------------------------------------------------------------------------------
ROW_HEAD = ["scene", "setting", "time/1e5 s", "steps", "rejected", "W err med", "W err max",
            "x err med m", "x err max m", "mismatch", "outside"]


def fmt_err(value) -> str:
    if value is None or not math.isfinite(value):
        return "-"
    return "0" if value == 0.0 else f"{value:.1e}"


def row_cells(scene_key, r) -> list[str]:
    steps = r.get("steps_mean")
    rejected = r.get("steps_rejected_mean")
    return [scene_key, r["label"], f"{r['time_per_1e5_s']:.3g}",
            f"{steps:.4g}" if steps is not None and math.isfinite(steps) else "-",
            f"{rejected:.3g}" if rejected is not None and math.isfinite(rejected) else "-",
            fmt_err(r["W_error_median"]), fmt_err(r["W_error_max"]),
            fmt_err(r["x_error_median"]), fmt_err(r["x_error_max"]),
            f"{r['status_mismatch']}/{r['n_valid']}", str(r.get("outside_domain", "-"))]


def print_row(cells, widths=(8, 26, 10, 8, 8, 9, 9, 11, 11, 9, 7)):
    print("  ".join(c.ljust(w) if k < 2 else c.rjust(w) for k, (c, w) in enumerate(zip(cells, widths))),
          flush=True)


def _load():
    try:
        import os

        return [round(x, 2) for x in os.getloadavg()]
    except OSError:  # pragma: no cover
        return None


def run_scene(rw, reference, np, spec: SceneSpec, settings, args, threads) -> dict:
    sizes = args.sizes
    n = sizes["n"]
    cols = sample_cases(spec, n, args.seed, np)
    sweep = rw.Sweep.cases(**cols)
    ref_cols = {k: v[:sizes["ref_subset"]] for k, v in cols.items()}
    scipy_n = min(sizes["scipy_subset"], sizes["ref_subset"])
    scipy_cols = {k: v[:scipy_n] for k, v in cols.items()}
    out = {"key": spec.key, "title": spec.title, "what": spec.what, "family": spec.family,
           "params": spec.params, "domain": spec.domain, "contact": spec.contact,
           "ranges": spec.ranges, "t_max": spec.t_max, "n": n, "ref_subset": sizes["ref_subset"],
           "scipy_subset": scipy_n, "compile": {}, "results": []}

    out["load_average_at_start"] = _load()
    print(f"\n=== {spec.title}: {spec.family} {spec.params}, domain {spec.domain}, {spec.contact}; "
          f"{n} trajectories, x0 {spec.ranges['x0']}, v0 {spec.ranges['v0']}, mu {spec.ranges['mu']}",
          flush=True)
    ref = reference_on(rw, reference, spec, ref_cols, REF_RTOL, REF_ATOL, np)
    usable = reference_validity(ref, spec.domain, np)
    check = reference_on(rw, reference, spec, ref_cols, REF_CHECK_RTOL, REF_CHECK_ATOL, np)
    same = usable & reference_validity(check, spec.domain, np) & (check["status"] == ref["status"])
    dw_all = np.abs(check["W_friction"] - ref["W_friction"]) / np.maximum(np.abs(ref["W_friction"]), W_FLOOR)
    dx_all = np.where(np.isin(ref["status"], X_INFORMATIVE), np.abs(check["x_end"] - ref["x_end"]), 0.0)
    converged = same & (dw_all <= UNCONVERGED) & (dx_all <= UNCONVERGED)
    unconverged = usable & ~converged
    valid = usable & converged
    dw = dw_all[valid]
    dx = dx_all[valid & np.isin(ref["status"], X_INFORMATIVE)]

    def detail(j, **extra):
        return {"x0": float(ref_cols["x0"][j]), "v0": float(ref_cols["v0"][j]), "mu": float(ref_cols["mu"][j]),
                "status": STATUS_NAMES[int(ref["status"][j])], "x_end": float(ref["x_end"][j]),
                "W_friction": float(ref["W_friction"][j]), **extra}

    out["reference"] = {
        "kind": f"rampwork.reference.reference_sweep (scipy DOP853 with events, rtol {REF_RTOL:g}, "
                f"atol {REF_ATOL:g})",
        "seconds": ref["seconds"], "seconds_per_trajectory": ref["seconds"] / max(valid.size, 1),
        "invalid": int((~usable).sum()),
        "invalid_detail": [detail(j) for j in np.flatnonzero(~usable)[:10]],
        "unconverged": int(unconverged.sum()),
        "unconverged_check_outside_domain": int((unconverged & ~reference_validity(check, spec.domain, np)).sum()),
        "unconverged_detail": [detail(j, check_status=STATUS_NAMES[int(check["status"][j])],
                                      check_x_end=float(check["x_end"][j]),
                                      check_W_friction=float(check["W_friction"][j]))
                               for j in np.flatnonzero(unconverged)[:10]],
        "status_counts": {STATUS_NAMES[s]: int((ref["status"] == s).sum()) for s in STATUS_NAMES
                          if (ref["status"] == s).any()},
        "reversals_median": float(np.median(ref["n_reversals"])),
        "t_end_median_s": float(np.median(ref["t_end"])),
        "check": {"rtol": REF_CHECK_RTOL, "atol": REF_CHECK_ATOL, "seconds": check["seconds"],
                  "trajectories": int(valid.size),
                  "status_differs": int((usable & (check["status"] != ref["status"])).sum()),
                  "W_diff_max": float(dw.max()) if dw.size else math.nan,
                  "W_diff_median": float(np.median(dw)) if dw.size else math.nan,
                  "x_diff_max": float(dx.max()) if dx.size else math.nan},
    }
    rinfo = out["reference"]
    print(f"reference: {ref['seconds']:.1f} s for {valid.size} trajectories; status "
          f"{rinfo['status_counts']}, median {rinfo['reversals_median']:.0f} reversals, "
          f"t_end median {rinfo['t_end_median_s']:.2f} s; invalid {rinfo['invalid']}"
          + (f" (e.g. {rinfo['invalid_detail'][0]})" if rinfo["invalid"] else ""), flush=True)
    print(f"reference check (rtol {REF_CHECK_RTOL:g}, atol {REF_CHECK_ATOL:g} vs rtol {REF_RTOL:g}, atol "
          f"{REF_ATOL:g}; {check['seconds']:.1f} s): W diff max {fmt_err(rinfo['check']['W_diff_max'])}, "
          f"x diff max {fmt_err(rinfo['check']['x_diff_max'])} m over converged trajectories; status "
          f"differs on {rinfo['check']['status_differs']}; not converged (left out) {rinfo['unconverged']}"
          + (f" (e.g. {rinfo['unconverged_detail'][0]})" if rinfo["unconverged"] else ""), flush=True)
    print_row(ROW_HEAD)

    status_counts_sweep = {}
    for setting in settings:
        r = dict(setting)
        if setting["solver"] == "rampwork":
            method = setting["method"]
            scene = make_scene(rw, spec, method, dt=setting["dt"], rtol=setting["rtol"])
            if method not in out["compile"]:
                out["compile"][method] = first_call(rw, scene, cols, threads)
            with OtherCpu() as other:
                ds = rw.simulate(scene, sweep, threads=threads, kernel=C.KERNEL)
                times, timed_n = timing(rw, scene, cols, threads, sizes["repeat"],
                                        float(ds.attrs["run_time_s"]), np)
            st = ds["status"].values
            flat = {k: ds[k].values.ravel() for k in ("status", "x_end", "W_friction", "t_end")}
            sub = {k: v[:sizes["ref_subset"]] for k, v in flat.items()}
            r.update(run_time_s=min(times), run_times_s=times, threads=int(ds.attrs["threads"]),
                     trajectories=n, timed_trajectories=timed_n, other_cpu_share=other.share,
                     time_per_1e5_s=min(times) * 1e5 / timed_n,
                     trajectory_steps=int(ds.attrs["trajectory_steps"]),
                     steps_mean=float(ds["steps"].values.mean()),
                     steps_rejected_mean=float(ds["steps_rejected"].values.mean()),
                     outside_domain=int(outside_domain(flat["x_end"], spec.domain, np).sum()),
                     status_counts_sweep={STATUS_NAMES[s]: int((st == s).sum()) for s in STATUS_NAMES
                                          if (st == s).any()})
            if "W_friction_error_estimate" in ds:
                est = np.abs(ds["W_friction_error_estimate"].values.ravel()[:sizes["ref_subset"]])
                rel = est / np.maximum(np.abs(sub["W_friction"]), W_FLOOR)
                r["W_error_estimate_median"] = float(np.nanmedian(rel))
            status_counts_sweep[setting["label"]] = r["status_counts_sweep"]
            del ds
        elif setting["solver"] == "peer":
            import peers_compare

            res, wall = peers_compare.scene_peer_run(spec, setting["method"], setting["rtol"], cols,
                                                     sizes["repeat"])
            sub = {k: v[:sizes["ref_subset"]] for k, v in res.items() if np.ndim(v)}
            r.update(run_time_s=wall, threads=None, processes=2, trajectories=n, time_per_1e5_s=wall * 1e5 / n,
                     steps_mean=float(np.mean(res["steps"])), steps_rejected_mean=math.nan,
                     outside_domain=int(outside_domain(res["x_end"], spec.domain, np).sum()))
        else:
            scene = make_scene(rw, spec, "rk4", dt=1e-3)
            res = scipy_run(reference, scene, scipy_cols, setting["method"], setting["rtol"], np)
            sub = res
            r.update(run_time_s=res["seconds"], threads=1, trajectories=scipy_n,
                     time_per_1e5_s=res["seconds"] * 1e5 / scipy_n, steps_mean=math.nan,
                     steps_rejected_mean=math.nan, rhs_evaluations_mean=float(res["nfev"].mean()),
                     outside_domain=int(outside_domain(res["x_end"], spec.domain, np).sum()))
        k = sub["status"].size
        errs = errors_against(sub, {key: v[:k] for key, v in ref.items() if key != "seconds"},
                              valid[:k], np)
        if errs["status_mismatch"]:
            errs["mismatch_details"] = mismatch_details(
                reference, make_scene(rw, spec, "rk4", dt=1e-3), ref_cols, sub, ref,
                errs["mismatch_index"])
        r.update(errs)
        out["results"].append(r)
        print_row(row_cells(spec.key, r))
    shares = [r["other_cpu_share"] for r in out["results"] if r.get("other_cpu_share") is not None]
    if shares:
        out["other_cpu_share_max"] = max(shares)
        out["other_cpu_share_mean"] = sum(shares) / len(shares)
        print(f"other processes' share of the CPU during the rampwork timings: mean "
              f"{100 * out['other_cpu_share_mean']:.0f}%, max {100 * out['other_cpu_share_max']:.0f}% "
              "(0% = quiet machine)", flush=True)
    comp = out["compile"]
    print("compile (first call of each kernel): " + ", ".join(
        f"{METHOD_LABELS[k]} {v['compile_time_s']:.1f} s ({v['source']})" for k, v in comp.items()),
        flush=True)
    return out


# ------------------------------------------------------------------------------
# rtol 1e-8 throughput on throughput.py's quadratic-bowl grid
# ------------------------------------------------------------------------------
def throughput_line(rw, reference, np, args) -> dict:
    import numba

    import throughput as T

    sizes = args.sizes
    threads = min(TP_THREADS, numba.config.NUMBA_NUM_THREADS)
    axes = T.grid_axes(sizes["tp_n"], np)
    shape = tuple(len(v) for v in axes.values())
    n = int(np.prod(shape))
    sweep = rw.Sweep.grid(**axes)
    ramp = rw.Ramp.create("quadratic", curvature=T.CURVATURE, slope=T.SLOPE, height=T.HEIGHT,
                          domain=T.DOMAIN)
    scenes = {m: rw.Scene(ramp=ramp, friction=rw.Friction(mu_k=0.2),
                          integrator=rw.Integrator(m, rtol=TP_RTOL, atol=TP_RTOL),
                          g=T.G, t_max=T.T_MAX, title=f"accuracy_cost benchmark: {m} throughput at rtol 1e-8")
              for m in ADAPTIVE_METHODS}
    print(f"\n=== throughput at rtol {TP_RTOL:g}: throughput.py's quadratic bowl grid, {n:,} trajectories "
          f"= x0[{shape[0]}] x v0[{shape[1]}] x mu[{shape[2]}], {threads} threads; "
          f"{', '.join(ADAPTIVE_METHODS)} interleaved, 3 runs each", flush=True)
    rng = np.random.default_rng(args.seed)
    order = rng.permutation(n)
    sub_idx = order[:max(sizes["tp_scipy"], sizes["tp_ref"])]
    cols = T.flat_columns(axes, sub_idx, np)
    comp = {m: first_call(rw, scenes[m], {k: v[:2] for k, v in cols.items()}, threads)
            for m in ADAPTIVE_METHODS}
    best = dict.fromkeys(ADAPTIVE_METHODS)
    times = {m: [] for m in ADAPTIVE_METHODS}
    shares = {m: [] for m in ADAPTIVE_METHODS}
    for rep_ in range(3):  # always three runs of each, interleaved, the fastest counts
        for m in (ADAPTIVE_METHODS if rep_ % 2 == 0 else ADAPTIVE_METHODS[::-1]):
            with OtherCpu() as other:
                ds = rw.simulate(scenes[m], sweep, threads=threads, kernel=C.KERNEL)
            shares[m].append(other.share)
            times[m].append(float(ds.attrs["run_time_s"]))
            if best[m] is None or times[m][-1] <= min(times[m]):
                best[m] = {k: ds[k].values.ravel().copy() for k in
                           ("status", "x_end", "W_friction", "t_end", "steps", "steps_rejected",
                            "W_friction_error_estimate") if k in ds}
                best[m]["trajectory_steps"] = int(ds.attrs["trajectory_steps"])
            del ds
    out = {"grid_n": n, "grid_shape": shape, "rtol": TP_RTOL, "atol": TP_RTOL, "threads": threads,
           "methods": {}, "target_trajectories_per_s": TP_TARGET}
    for m in ADAPTIVE_METHODS:
        flat = best[m]
        run_s = min(times[m])
        st = flat["status"]
        out["methods"][m] = {
            "compile": comp[m], "run_time_s": run_s, "run_times_s": times[m],
            "other_cpu_share_runs": shares[m], "other_cpu_share": shares[m][times[m].index(run_s)],
            "trajectories_per_s": n / run_s,
            "steps_mean": float(flat["steps"].mean()),
            "steps_rejected_mean": float(flat["steps_rejected"].mean()),
            "steps_per_s": flat["trajectory_steps"] / run_s,
            "status_fractions": {STATUS_NAMES[s_]: float((st == s_).mean()) for s_ in STATUS_NAMES
                                 if (st == s_).any()},
            "outside_domain": int(outside_domain(flat["x_end"], T.DOMAIN, np).sum())}
        t = out["methods"][m]
        t["target_met"] = t["trajectories_per_s"] >= TP_TARGET
        print(f"{m}: compile {comp[m]['compile_time_s']:.1f} s ({comp[m]['source']}); run {run_s:.3f} s "
              f"(runs {', '.join(f'{x:.3f}' for x in times[m])}; other processes' CPU share "
              f"{', '.join('-' if v is None else f'{100 * v:.0f}%' for v in shares[m])}); "
              f"{t['trajectories_per_s']:.3e} traj/s; "
              f"steps/traj mean {t['steps_mean']:.1f}, rejected {t['steps_rejected_mean']:.2f}; "
              f"status {', '.join(f'{k} {v:.3f}' for k, v in t['status_fractions'].items())}", flush=True)
    out["target_met"] = any(t["target_met"] for t in out["methods"].values())
    out["fastest"] = max(ADAPTIVE_METHODS, key=lambda m: out["methods"][m]["trajectories_per_s"])

    # accuracy of each run on a subset, against the reference
    ref_cols = {k: v[:sizes["tp_ref"]] for k, v in cols.items()}
    spec = SceneSpec("throughput", "quadratic bowl", "quadratic",
                     {"curvature": T.CURVATURE, "slope": T.SLOPE, "height": T.HEIGHT}, T.DOMAIN,
                     "one_sided", {}, T.T_MAX)
    ref = reference_on(rw, reference, spec, ref_cols, REF_RTOL, REF_ATOL, np)
    valid = reference_validity(ref, T.DOMAIN, np)
    for m in ADAPTIVE_METHODS:
        flat = best[m]
        sub = {k: flat[k][sub_idx[:sizes["tp_ref"]]] for k in ("status", "x_end", "W_friction", "t_end")}
        acc = errors_against(sub, {k: v for k, v in ref.items() if k != "seconds"}, valid, np)
        acc["reference_invalid"] = int((~valid).sum())
        if "W_friction_error_estimate" in flat:
            est = np.abs(flat["W_friction_error_estimate"][sub_idx[:sizes["tp_ref"]]])
            acc["W_error_estimate_median"] = float(np.nanmedian(
                est / np.maximum(np.abs(sub["W_friction"]), W_FLOOR)))
        out["methods"][m]["accuracy"] = a = acc
        print(f"{m} accuracy on {valid.size} trajectories: W err median {fmt_err(a['W_error_median'])}, "
              f"max {fmt_err(a['W_error_max'])}; stuck x_end err median {fmt_err(a['x_error_median'])} m, "
              f"max {fmt_err(a['x_error_max'])} m; status mismatch {a['status_mismatch']}/{a['n_valid']}",
              flush=True)
    del best

    # scipy at the same rtol on a subset: rampwork.reference's event loop (all
    # events, 4 states) and throughput.py's lean quadratic-only loop
    scene = scenes[ADAPTIVE_METHODS[0]]
    sc_cols = {k: v[:sizes["tp_scipy"]] for k, v in cols.items()}
    res = scipy_run(reference, scene, sc_cols, "DOP853", TP_RTOL, np)
    out["scipy_reference_loop"] = {
        "what": "rampwork.reference.reference_trajectory, solve_ivp DOP853, rtol = atol = 1e-8, "
                "events: reversal/stop, exits, contact",
        "trajectories": int(sc_cols["x0"].size), "seconds": res["seconds"],
        "trajectories_per_s": sc_cols["x0"].size / res["seconds"]}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lean = T.scipy_peer(sc_cols["x0"], sc_cols["v0"], sc_cols["mu"], np)
    out["scipy_lean_loop"] = {
        "what": f"throughput.py's scipy_peer: solve_ivp {T.SCIPY_METHOD}, rtol {T.SCIPY_RTOL:g}, "
                f"atol {T.SCIPY_ATOL:g}, quadratic bowl only, reversal/stick and exit events",
        "trajectories": int(sc_cols["x0"].size), "seconds": lean["seconds"],
        "trajectories_per_s": sc_cols["x0"].size / lean["seconds"]}
    for m in ADAPTIVE_METHODS:
        out["methods"][m]["ratio_vs_scipy"] = (out["methods"][m]["trajectories_per_s"]
                                               / out["scipy_lean_loop"]["trajectories_per_s"])
    print(f"scipy DOP853 rtol 1e-8 per trajectory ({sc_cols['x0'].size} trajectories, 1 process): "
          f"{out['scipy_reference_loop']['trajectories_per_s']:.3g} traj/s (reference loop), "
          f"{out['scipy_lean_loop']['trajectories_per_s']:.3g} traj/s (throughput.py's lean loop)",
          flush=True)
    return out


def throughput_sentence(tp) -> str:
    per = []
    for m in ADAPTIVE_METHODS:
        t = tp["methods"][m]
        acc = t["accuracy"]
        per.append(
            f"{m} {t['trajectories_per_s']:.3e} trajectories/s ({t['trajectories_per_s'] / TP_TARGET:.3g} of "
            f"target; mean {t['steps_mean']:.1f} steps and {t['steps_rejected_mean']:.2f} rejected steps per "
            f"trajectory; W error median {fmt_err(acc['W_error_median'])}, max {fmt_err(acc['W_error_max'])}"
            + (f", its own estimate median {fmt_err(acc['W_error_estimate_median'])}"
               if acc.get("W_error_estimate_median") is not None else "")
            + f", status mismatch {acc['status_mismatch']}/{acc['n_valid']}; "
            f"{C.fmt_ratio(t['ratio_vs_scipy'])} scipy's rate"
            + (f"; other processes used {100 * t['other_cpu_share']:.0f}% of the CPU during its fastest run"
               if t.get("other_cpu_share") is not None else "") + ")")
    met = [m for m in ADAPTIVE_METHODS if tp["methods"][m]["target_met"]]
    return (f"THROUGHPUT AT RTOL 1e-8 (throughput.py's quadratic bowl grid, {tp['grid_n']:,} trajectories, "
            f"{tp['threads']} threads, the two pairs' runs interleaved, fastest of 3 each): "
            + "; ".join(per)
            + f". Target {TP_TARGET:.0e} trajectories/s: "
            + (f"MET by {' and '.join(met)}" if met else "NOT MET by either pair")
            + f". scipy solve_ivp DOP853 per trajectory: {tp['scipy_lean_loop']['trajectories_per_s']:.3g} "
            f"trajectories/s (throughput.py's loop; {tp['scipy_reference_loop']['trajectories_per_s']:.3g} "
            "with rampwork.reference's loop).")


# ------------------------------------------------------------------------------
# analysis: what accuracy costs, and the fastest method per target
# ------------------------------------------------------------------------------
def family_of(r) -> str:
    """The curve a setting belongs to: a rampwork method or a scipy method."""
    return r["method"]


def wrong_outcomes(r) -> int:
    """Trajectories with a qualitatively wrong end: a status that differs
    from the reference's (on the subset), or an x_end outside the domain
    (anywhere in the sweep: an exit missed)."""
    return int(r["status_mismatch"]) + int(r.get("outside_domain") or 0)


def meets(r, target, allow_mismatch=False) -> bool:
    """Worst-case errors (max over the compared subset) within target, and no
    wrong outcome (status mismatch, x_end outside the domain) unless allowed."""
    if r["n_compared"] == 0:
        return False
    if not allow_mismatch and wrong_outcomes(r):
        return False
    w, x = r["W_error_max"], r["x_error_max"]
    if not math.isfinite(w) or w > target:
        return False
    if r["n_x_compared"] and (not math.isfinite(x) or x > target):
        return False
    return True


def cheapest(results, family, target, allow_mismatch=False):
    fits = [r for r in results if family_of(r) == family and meets(r, target, allow_mismatch)]
    return min(fits, key=lambda r: r["time_per_1e5_s"]) if fits else None


def picks(scenes, allow_mismatch=False) -> list[dict]:
    """For each target: each method's cheapest setting per scene, and the
    method with the least total time over all scenes (None where a method
    misses a scene)."""
    families = list(ALL_METHODS)
    rows = []
    for target in TARGETS:
        per_family = {}
        for fam in families:
            chosen = {s["key"]: cheapest(s["results"], fam, target, allow_mismatch) for s in scenes}
            total = (sum(c["time_per_1e5_s"] for c in chosen.values())
                     if all(chosen.values()) else None)
            per_family[fam] = {"total_time_per_1e5_s": total,
                               "settings": {k: (c["label"] if c else None) for k, c in chosen.items()},
                               "times": {k: (c["time_per_1e5_s"] if c else None) for k, c in chosen.items()},
                               "missed": [k for k, c in chosen.items() if c is None]}
        per_scene = {}
        for s in scenes:
            best = None
            for fam in families:
                c = cheapest(s["results"], fam, target, allow_mismatch)
                if c and (best is None or c["time_per_1e5_s"] < best["time_per_1e5_s"]):
                    best = c
            per_scene[s["key"]] = ({"setting": best["label"], "time_per_1e5_s": best["time_per_1e5_s"]}
                                   if best else None)
        ranked = sorted((f for f in families if per_family[f]["total_time_per_1e5_s"] is not None),
                        key=lambda f: per_family[f]["total_time_per_1e5_s"])
        rows.append({"target": target, "best": ranked[0] if ranked else None, "ranked": ranked,
                     "per_method": per_family, "per_scene": per_scene})
    return rows


def cost_slopes(scenes, np) -> dict:
    """Per method, the fitted exponent b of time ~ error^b (median W error,
    points clear of the reference's floor and of rounding, no status
    mismatch), median over the scenes; 10**-b is the time factor per decade."""
    out = {}
    for fam in ALL_METHODS:
        slopes = {}
        for s in scenes:
            floor = max(s["reference"]["check"]["W_diff_max"] or 0.0, 1e-13)
            pts = [(r["W_error_median"], r["time_per_1e5_s"]) for r in s["results"]
                   if family_of(r) == fam and r["status_mismatch"] == 0
                   and math.isfinite(r["W_error_median"]) and r["W_error_median"] > floor]
            if len(pts) >= 2:
                e, t = np.log10(np.array(pts)).T
                if np.ptp(e) > 0.5:
                    slopes[s["key"]] = float(np.polyfit(e, t, 1)[0])
        med = float(np.median(list(slopes.values()))) if slopes else math.nan
        out[fam] = {"per_scene": slopes, "median": med,
                    "time_factor_per_decade": 10 ** (-med) if math.isfinite(med) else math.nan}
    return out


def summary_paragraph(res) -> str:
    scenes = res["scenes"]
    strict, loose = res["picks"], res["picks_ignoring_mismatch"]
    slopes = res["cost_slopes"]
    threads = res["config"]["threads"]
    names = ", ".join(s["key"] for s in scenes)

    def t(v):
        return f"{v:.2g} s"

    parts = [f"What accuracy costs ({len(scenes)} scene{'s' if len(scenes) != 1 else ''}: {names}; "
             "worst-case error over each scene's "
             f"reference subset, W_friction relative and x_end in m; time per 10^5 trajectories summed "
             f"over the scenes, rampwork on {threads} threads, scipy on one core): "]
    growth = []
    for fam in RAMPWORK_METHODS:
        s = slopes[fam]
        if math.isfinite(s["median"]):
            growth.append(f"{METHOD_LABELS[fam]} x{s['time_factor_per_decade']:.2g} "
                          f"(time ~ error^{s['median']:.2f})")
    if growth:
        straight = any(s["family"] == "straight" for s in scenes)
        parts.append("each further decade of accuracy multiplies the time by about "
                     + ", ".join(growth) + " (median over the scenes"
                     + ("; the straight ramp, which RK4 and the adaptive pairs integrate exactly, gives no slope"
                        if straight else "") + "). ")
    def settings_text(pm):
        values = [v.split(" ", 1)[-1] if v else "-" for v in pm["settings"].values()]
        if len(set(values)) == 1:
            return f"{values[0]} on every scene"
        return ", ".join(f"{k} {v}" for k, v in zip(pm["settings"], values))

    def target_text(row, lrow):
        if row["best"]:
            best = row["best"]
            pm = row["per_method"][best]
            text = f"{METHOD_LABELS[best]} ({settings_text(pm)}; {t(pm['total_time_per_1e5_s'])}"
            if len(row["ranked"]) > 1:
                nxt = row["ranked"][1]
                ratio = row["per_method"][nxt]["total_time_per_1e5_s"] / pm["total_time_per_1e5_s"]
                text += f"; next {METHOD_LABELS[nxt]}, {ratio:.1f}x the time"
            text += ")"
        else:
            text = "no method reaches it on every scene"
            missing = [s for s in scenes if row["per_scene"][s["key"]] is None]
            floors = [f"{s['key']} {fmt_err(s['reference']['check']['W_diff_max'])}" for s in missing
                      if (s["reference"]["check"]["W_diff_max"] or 0) > 0.1 * row["target"]]
            if missing:
                text += f" (missed on {', '.join(s['key'] for s in missing)}"
                text += (f"; the reference's own W error there, estimated: {', '.join(floors)})"
                         if floors else ")")
        if lrow["best"] and lrow["best"] != row["best"]:
            lb = lrow["best"]
            text += (f" [ignoring wrong outcomes: {METHOD_LABELS[lb]} ({settings_text(lrow['per_method'][lb])}; "
                     f"{t(lrow['per_method'][lb]['total_time_per_1e5_s'])})]")
        return text

    # consecutive targets with the same answer are merged: "1e-3 to 1e-5: ..."
    groups = []
    for row, lrow in zip(strict, loose):
        text = target_text(row, lrow)
        if groups and groups[-1][2] == text:
            groups[-1][1] = row["target"]
        else:
            groups.append([row["target"], row["target"], text])
    lines = [(fmt_e(a) if a == b else f"{fmt_e(a)} to {fmt_e(b)}") + ": " + text for a, b, text in groups]
    parts.append("Fastest method reaching a worst-case target on every scene with no wrong outcome "
                 "(status as the reference's, x_end inside the domain), time summed over the scenes: "
                 + "; ".join(lines) + ". ")
    wins = {}
    for row in strict:
        for key, p in row["per_scene"].items():
            if p:
                fam = next(f for f in METHOD_LABELS if p["setting"].split(" ")[0] == f
                           or p["setting"].startswith(f"scipy {f} "))
                wins.setdefault(fam, []).append(key)
    total = len(strict) * len(scenes)
    if wins:
        parts.append(f"Scene by scene ({total} scene-target pairs), the fastest is "
                     + ", ".join(f"{METHOD_LABELS[f]} in {len(v)}"
                                 + (f" (on {', '.join(sorted(set(v), key=[s['key'] for s in scenes].index))})"
                                    if len(set(v)) < len(scenes) else "")
                                 for f, v in sorted(wins.items(), key=lambda kv: -len(kv[1])))
                     + f", none in {total - sum(len(v) for v in wins.values())}. ")
    # who is disqualified by mismatches, and where
    mism = []
    for fam in ALL_METHODS:
        where = {}
        for s in scenes:
            rs = [r for r in s["results"] if family_of(r) == fam]
            bad = [r for r in rs if r["status_mismatch"]]
            if bad:
                where[s["key"]] = f"{len(bad)}/{len(rs)} settings"
        if where:
            mism.append(f"{METHOD_LABELS[fam]} ({', '.join(f'{k}: {v}' for k, v in where.items())})")
    if mism:
        parts.append("Status mismatches with the reference (a trajectory that ends stuck, exited or "
                     "lifted off where the reference says otherwise) disqualify: " + "; ".join(mism) + ". ")
    for fam in ADAPTIVE_METHODS:
        drift = []
        for s in scenes:
            rs = [r for r in s["results"] if family_of(r) == fam]
            if len(rs) < 2:
                continue
            tight = rs[-1]["status_counts_sweep"]
            worst = None
            for r in rs[:-1]:
                diff = sum(abs(r["status_counts_sweep"].get(k, 0) - tight.get(k, 0))
                           for k in set(tight) | set(r["status_counts_sweep"])) // 2
                if diff and (worst is None or diff > worst[0]):
                    worst = (diff, r["label"].split(" ", 1)[1])
            if worst:
                drift.append(f"{s['key']} up to {worst[0]} of {s['n']} at {worst[1]}")
        if drift:
            parts.append(f"Over the whole sweep, {METHOD_LABELS[fam]}'s status counts differ from those at "
                         "its tightest rtol on: " + "; ".join(drift) + ". ")
    outside = []
    for s in scenes:
        for fam in ADAPTIVE_METHODS + SCIPY_METHODS:
            rs = [r for r in s["results"] if family_of(r) == fam and r.get("outside_domain")]
            if rs:
                outside.append(f"{METHOD_LABELS[fam]} on {s['key']} ({len(rs)} settings, up to "
                               f"{max(r['outside_domain'] for r in rs)} of "
                               f"{max(r['trajectories'] for r in rs)} trajectories)")
        if s["reference"]["invalid"]:
            outside.append(f"the reference on {s['key']} ({s['reference']['invalid']} of "
                           f"{s['ref_subset']}, left out)")
    if outside:
        parts.append("Trajectories ending outside the domain (an exit event missed inside a long "
                     "step): " + "; ".join(outside) + ". ")
    unconv = [f"{s['key']} {s['reference']['unconverged']} of {s['ref_subset']}"
              + (f" ({s['reference']['unconverged_check_outside_domain']} with the looser run's x_end "
                 "outside the domain)" if s["reference"].get("unconverged_check_outside_domain") else "")
              for s in scenes if s["reference"].get("unconverged")]
    if unconv:
        parts.append("Reference trajectories not converged (status, W or x_end differ between the "
                     f"reference at rtol {REF_CHECK_RTOL:g} and at {REF_RTOL:g}: a start on a knife edge, or "
                     "an event the looser run missed) are left out of every comparison: "
                     + ", ".join(unconv) + ". ")
    # dop853 against dopri5, target by target (where both reach it on every scene)
    versus = []
    for row in strict:
        a, b = (row["per_method"][f]["total_time_per_1e5_s"] for f in ADAPTIVE_METHODS)
        if a and b:
            versus.append(f"{fmt_e(row['target'])}: {b / a:.2g}")
        elif a or b:
            versus.append(f"{fmt_e(row['target'])}: only {METHOD_LABELS[ADAPTIVE_METHODS[0 if a else 1]]}")
    if versus:
        parts.append(f"Time of {METHOD_LABELS[ADAPTIVE_METHODS[1]]} over that of "
                     f"{METHOD_LABELS[ADAPTIVE_METHODS[0]]} at each target (summed over the scenes): "
                     + ", ".join(versus) + ". ")
    # scipy vs the faster adaptive pair at matched accuracy
    cmp_ = []
    for row in loose:
        ds_ = [row["per_method"][f]["total_time_per_1e5_s"] for f in ADAPTIVE_METHODS]
        ds_ = [v for v in ds_ if v]
        sc = [row["per_method"][f]["total_time_per_1e5_s"] for f in SCIPY_METHODS]
        sc = [v for v in sc if v is not None]
        if ds_ and sc:
            cmp_.append(f"{fmt_e(row['target'])}: {min(sc) / min(ds_):,.0f}x")
    if cmp_:
        parts.append("At matched accuracy (wrong outcomes ignored) the best scipy solve_ivp setting "
                     "needs more time than the faster adaptive pair by " + ", ".join(cmp_) + ".")
    return "".join(parts)


# ------------------------------------------------------------------------------
# report
# ------------------------------------------------------------------------------
def build_tables(res) -> tuple[str, str]:
    rows = [row_cells(s["key"], r) for s in res["scenes"] for r in s["results"]]
    head = ["scene", "setting", "time per 1e5 traj (s)", "steps/traj", "rejected/traj",
            "W rel err median", "W rel err max", "x_end err median (m)", "x_end err max (m)",
            "status mismatch", "x_end outside domain"]
    header = [
        f"machine: {res['machine']['cpu_model']}, {res['machine']['usable_cores']} usable cores, "
        f"numba {res['machine']['numba']}, scipy {res['machine']['scipy']}, git {res['machine']['git_commit']}, "
        f"load avg at start {'/'.join(f'{x:.1f}' for x in res['machine']['load_average_1_5_15min'] or [])}"
        + (f"; src/ files modified in the working tree: {', '.join(res['src_modified_in_working_tree'])}"
           if res.get("src_modified_in_working_tree") else ""),
        f"rampwork on {res['config']['threads']} threads; time per 10^5 trajectories = fastest kernel "
        f"run_time_s (compile excluded) x 10^5 / trajectories in the sweep; scipy: one process, timed on "
        f"its subset",
        f"reference: rampwork.reference.reference_sweep, scipy DOP853 with events, rtol {REF_RTOL:g}, "
        f"atol {REF_ATOL:g} (left out where not valid or not converged: see each scene); W error = |W - W_ref| / max(|W_ref|, {W_FLOOR:g} J); x_end error on "
        f"stuck / lifted-off / timed-out trajectories only; errors over trajectories whose status "
        f"matches the reference's; 'status mismatch' = k / valid reference trajectories; "
        f"'outside' = x_end outside the domain (whole sweep for rampwork, subset for scipy)",
    ]
    scene_lines = []
    for s in res["scenes"]:
        ref = s["reference"]
        comp = ", ".join(f"{METHOD_LABELS[k]} {v['compile_time_s']:.1f} s ({v['source']})"
                         for k, v in s["compile"].items())
        scene_lines.append(
            f"{s['key']}: {s['what']}; x0 {s['ranges']['x0']}, v0 {s['ranges']['v0']} m/s, mu "
            f"{s['ranges']['mu']}; {s['n']} trajectories, reference on {s['ref_subset']} "
            f"({ref['seconds']:.1f} s; status {ref['status_counts']}; median "
            f"{ref['reversals_median']:.0f} reversals; invalid {ref['invalid']}, not converged "
            f"{ref.get('unconverged', 0)} (left out); check at rtol "
            f"{REF_CHECK_RTOL:g}: W diff max {fmt_err(ref['check']['W_diff_max'])}, x diff max "
            f"{fmt_err(ref['check']['x_diff_max'])} m), scipy on {s['scipy_subset']}; compile: {comp}"
            + (f"; other processes' CPU share during the rampwork timings: mean "
               f"{100 * s['other_cpu_share_mean']:.0f}%, max {100 * s['other_cpu_share_max']:.0f}%"
               if s.get("other_cpu_share_mean") is not None else ""))
    pick_head = ["target"] + [s["key"] for s in res["scenes"]] + ["all scenes: fastest (total s/1e5)"]
    pick_rows = []
    for row in res["picks"]:
        cells = [fmt_e(row["target"])]
        for s in res["scenes"]:
            p = row["per_scene"][s["key"]]
            cells.append(f"{p['setting']} ({p['time_per_1e5_s']:.2g} s)" if p else "none")
        if row["best"]:
            cells.append(f"{METHOD_LABELS[row['best']]} "
                         f"({row['per_method'][row['best']]['total_time_per_1e5_s']:.2g} s)")
        else:
            cells.append("none")
        pick_rows.append(cells)
    text = ("\n".join(header) + "\n" + "\n".join(scene_lines) + "\n\nWORK-PRECISION\n"
            + C.text_table(ROW_HEAD, rows)
            + "\n\nFASTEST SETTING PER WORST-CASE TARGET (no wrong outcome; time per 1e5 trajectories)\n"
            + C.text_table(pick_head, pick_rows))
    md = ("# rampwork accuracy-cost benchmark\n\n" + "\n".join(f"- {h}" for h in header + scene_lines)
          + "\n\n## Work-precision\n\n" + C.markdown_table(head, rows)
          + "\n\n## Fastest setting per worst-case target (no wrong outcome: status as the reference's, "
            "x_end inside the domain)\n\n"
          + C.markdown_table(pick_head, pick_rows) + "\n")
    if res.get("throughput"):
        sentence = throughput_sentence(res["throughput"])
        text += "\n\n" + sentence
        md += "\n## Throughput at rtol 1e-8\n\n" + sentence + "\n"
    md += "\n## Summary\n\n" + res["summary"] + "\n"
    return text, md


def gallery_markdown(res, figure_name="accuracy_cost.png") -> str:
    """The short committed page: how it was made, the picks, the throughput
    line and the summary."""
    m = res["machine"]
    cfg = res["config"]
    lines = [
        "# What accuracy costs: rampwork work-precision",
        "",
        f"![work-precision diagrams]({figure_name})",
        "",
        f"Made by `benchmarks/accuracy_cost.py{' --quick' if cfg['quick'] else ''}` on {res['started_utc']} "
        f"(git {m['git_commit']}" + (", kernel sources modified in the working tree" if
                                     res.get("src_modified_in_working_tree") else "")
        + f"), {m['cpu_model']}, {m['usable_cores']} cores, rampwork on {cfg['threads']} threads, "
        f"numba {m['numba']}, scipy {m['scipy']}; load average at start "
        f"{'/'.join(f'{x:.1f}' for x in m['load_average_1_5_15min'] or [])}. Every number, the "
        "machine and the per-setting table are in the benchmark's JSON, markdown and netCDF outputs "
        "(`benchmarks/results/`, not committed); `benchmarks/README.md` says how each is measured.",
        "",
        "Scenes (one-sided contact, random sweeps of x0, v0, mu):",
        "",
    ]
    for s in res["scenes"]:
        ref = s["reference"]
        total = sum(ref["status_counts"].values())
        mix = ", ".join(f"{100 * v / total:.0f}% {k.replace('_', ' ')}" for k, v in ref["status_counts"].items())
        lines.append(f"- **{s['key']}**: {s['what']}; {s['n']} trajectories, errors on {s['ref_subset']} "
                     f"({mix}; median {ref['reversals_median']:.0f} reversals).")
    pick_head = ["worst-case target"] + [s["key"] for s in res["scenes"]] + ["all scenes (s per 10^5, summed)"]
    rows = []
    for row in res["picks"]:
        cells = [fmt_e(row["target"])]
        for s in res["scenes"]:
            p = row["per_scene"][s["key"]]
            cells.append(f"{p['setting']} ({p['time_per_1e5_s']:.2g} s)" if p else "none")
        cells.append(f"{METHOD_LABELS[row['best']]} ({row['per_method'][row['best']]['total_time_per_1e5_s']:.2g} s)"
                     if row["best"] else "none")
        rows.append(cells)
    lines += ["", "Fastest setting reaching each worst-case target (max relative W_friction error and max "
              "x_end error in m within the target over the reference subset, no status mismatch, no x_end "
              "outside the domain), time per 10^5 trajectories:", "", C.markdown_table(pick_head, rows), ""]
    if res.get("throughput"):
        lines += [throughput_sentence(res["throughput"]), ""]
    lines += ["**Summary.** " + res["summary"], ""]
    return "\n".join(lines)


def draw_figure(res, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.lines import Line2D

    scenes = res["scenes"]
    fig, axes = plt.subplots(2, len(scenes), figsize=(4.6 * len(scenes), 9.4), squeeze=False,
                             layout="constrained")
    families = list(ALL_METHODS)
    for col, s in enumerate(scenes):
        ref = s["reference"]
        for row, (var, ylabel) in enumerate((("W", "relative error of W_friction"),
                                             ("x", "error of x_end (m)"))):
            ax = axes[row, col]
            for fam in families:
                rs = [r for r in s["results"] if family_of(r) == fam]
                if not rs:
                    continue
                marker, ls, color, filled = STYLES[fam]
                t = np.array([r["time_per_1e5_s"] for r in rs])
                med = np.array([r[f"{var}_error_median"] for r in rs], float)
                mx = np.array([r[f"{var}_error_max"] for r in rs], float)
                ok = np.isfinite(med)
                if not ok.any():
                    continue
                med_p = np.maximum(med[ok], PLOT_FLOOR)
                mx_p = np.maximum(mx[ok], PLOT_FLOOR)
                ax.vlines(t[ok], med_p, mx_p, colors=color, linewidth=1.0, alpha=0.45)
                ax.plot(t[ok], med_p, linestyle=ls if ls != "none" else "", marker=marker, color=color,
                        markersize=6, markerfacecolor=color if filled else "white", markeredgewidth=1.3,
                        linewidth=1.4)
                mism = np.array([wrong_outcomes(r) > 0 for r in rs])[ok]
                if mism.any():  # settings with wrong outcomes: ringed
                    ax.plot(t[ok][mism], med_p[mism], linestyle="", marker="o", markersize=12,
                            markerfacecolor="none", markeredgecolor="k", markeredgewidth=0.8)
                # the loosest and tightest dt / rtol of each curve, written beside it
                key = "dt" if fam in FIXED_METHODS else "rtol"
                idx = np.flatnonzero(ok)
                for j in sorted({idx[0], idx[-1]}):
                    ax.annotate(fmt_e(rs[j][key]), (t[j], max(med[j], PLOT_FLOOR)), fontsize=6.5,
                                color=color, xytext=(4, 3), textcoords="offset points")
            floor = ref["check"][f"{var}_diff_max"]
            if floor is not None and math.isfinite(floor):
                ax.axhline(max(floor, PLOT_FLOOR), color="0.4", linestyle=(0, (2, 2)), linewidth=0.9)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_ylim(bottom=PLOT_FLOOR / 3)
            ax.grid(which="major", alpha=0.3)
            ax.set_xlabel("time per 10$^5$ trajectories (s)")
            ax.set_ylabel(ylabel)
            if row == 0:
                counts = ref["status_counts"]
                total = sum(counts.values())
                mix = ", ".join(f"{100 * v / total:.0f}% {k.replace('_', ' ')}" for k, v in counts.items())
                ax.set_title(f"{s['title']}\n{s['family'].replace('_', ' ')}; reference: {mix}",
                             fontsize=9.5)
            if row == 1 and not any(r["n_x_compared"] for r in s["results"]):
                ax.text(0.5, 0.5, "no stuck / lifted-off\ntrajectories", transform=ax.transAxes,
                        ha="center", va="center")
    handles = []
    for fam in families:
        marker, ls, color, filled = STYLES[fam]
        if not any(family_of(r) == fam for s in scenes for r in s["results"]):
            continue
        label = METHOD_LABELS[fam] + (" (over dt)" if fam in FIXED_METHODS else
                                      " (over rtol = atol)" if fam in ADAPTIVE_METHODS else
                                      ", 2 processes (over tol)" if fam in PEER_METHODS else
                                      ", 1 process (rtol = atol)")
        handles.append(Line2D([], [], color=color, marker=marker, linestyle=ls if ls != "none" else "",
                              markerfacecolor=color if filled else "white", markeredgewidth=1.3,
                              label=label))
    handles.append(Line2D([], [], color="0.4", alpha=0.6, linewidth=1.0, marker="",
                          label="thin bar: up to the max over the subset"))
    handles.append(Line2D([], [], color="0.4", linestyle=(0, (2, 2)), linewidth=0.9,
                          label=f"reference check: max |ref(rtol {REF_CHECK_RTOL:g}) - ref({REF_RTOL:g})|"))
    handles.append(Line2D([], [], linestyle="", marker="o", markersize=10, markerfacecolor="none",
                          markeredgecolor="k",
                          label="ringed: a wrong outcome (status differs from the\nreference's, or x_end outside the domain)"))
    fig.legend(handles=handles, loc="outside lower center", ncol=5, fontsize=8.5, frameon=False)
    m = res["machine"]
    fig.suptitle(f"What accuracy costs: rampwork work-precision on four scenes (markers: median error "
                 f"over {res['scenes'][0]['ref_subset']} reference trajectories per scene; errors below "
                 f"{PLOT_FLOOR:g} drawn at {PLOT_FLOOR:g})\n{m['cpu_model']}, rampwork on "
                 f"{res['config']['threads']} threads; reference: scipy DOP853 with events, rtol {REF_RTOL:g}, "
                 f"atol {REF_ATOL:g}",
                 fontsize=10.5)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def write_dataset(rw, res, path, np):
    import xarray as xr

    scenes = res["scenes"]
    labels = [r["label"] for r in scenes[0]["results"]]
    by = {s["key"]: {r["label"]: r for r in s["results"]} for s in scenes}
    variables = {
        "time_per_1e5_s": ("s", "time per 10^5 trajectories (rampwork: kernel run time, compile excluded; "
                                "scipy: one process)"),
        "W_error_median": ("1", "median relative error of W_friction against the reference"),
        "W_error_max": ("1", "maximum relative error of W_friction against the reference"),
        "x_error_median": ("m", "median absolute error of x_end (stuck, lifted-off, timed-out trajectories)"),
        "x_error_max": ("m", "maximum absolute error of x_end (stuck, lifted-off, timed-out trajectories)"),
        "status_mismatch": ("1", "reference trajectories whose final status differs"),
        "n_compared": ("1", "reference trajectories with the same status (errors taken over these)"),
        "outside_domain": ("1", "trajectories whose x_end lies outside the ramp's domain"),
        "steps_mean": ("1", "mean accepted steps per trajectory (rampwork)"),
        "steps_rejected_mean": ("1", "mean rejected steps per trajectory (rampwork's adaptive pairs)"),
        "W_error_estimate_median": ("1", "median of the adaptive pair's W_friction_error_estimate / W_friction (dop853: sum of its 5th-order estimates)"),
    }
    data = {}
    for name, (units, long_name) in variables.items():
        integer = name in ("status_mismatch", "n_compared", "outside_domain")
        arr = np.full((len(scenes), len(labels)), -1 if integer else np.nan,
                      dtype=np.int64 if integer else np.float64)
        for i, s in enumerate(scenes):
            for j, lab in enumerate(labels):
                v = by[s["key"]][lab].get(name)
                if v is not None:
                    arr[i, j] = v
        data[name] = (("scene", "setting"), arr, {"units": units, "long_name": long_name})
    methods = list(RAMPWORK_METHODS)
    comp = np.array([[s["compile"].get(mm, {}).get("compile_time_s", np.nan) for mm in methods]
                     for s in scenes])
    data["compile_time_s"] = (("scene", "rampwork_method"), comp,
                              {"units": "s", "long_name": "first call's compile (or disk-cache load) time"})
    first = scenes[0]["results"]
    ds = xr.Dataset(data, coords={
        "scene": ("scene", [s["key"] for s in scenes], {"long_name": "scene"}),
        "setting": ("setting", labels, {"long_name": "method and its step or tolerance"}),
        "solver": ("setting", [r["solver"] for r in first]),
        "method": ("setting", [r["method"] for r in first]),
        "dt": ("setting", np.array([r["dt"] for r in first], float), {"units": "s", "long_name": "fixed step"}),
        "rtol": ("setting", np.array([r["rtol"] for r in first], float),
                 {"units": "1", "long_name": "relative tolerance (atol = rtol)"}),
        "rampwork_method": ("rampwork_method", methods),
        "scene_title": ("scene", [s["title"] for s in scenes]),
    })
    ds.attrs = {"title": "rampwork accuracy-cost benchmark (work-precision)",
                "benchmark": "accuracy_cost", "created_utc": res["started_utc"],
                "reference": f"rampwork.reference.reference_sweep, scipy DOP853, rtol {REF_RTOL:g}",
                "threads": res["config"]["threads"], "quick": int(res["config"]["quick"]),
                "machine": {k: v for k, v in res["machine"].items() if v is not None},
                "summary": res["summary"]}
    return rw.write_netcdf(ds, path, overwrite=True)


# ------------------------------------------------------------------------------
# main
# ------------------------------------------------------------------------------
def modified_sources() -> list[str] | None:
    """Files under src/ that differ from the commit (the kernel measured is
    the working tree's, not necessarily the commit's)."""
    import subprocess

    try:
        out = subprocess.run(["git", "status", "--porcelain", "--", "src"], capture_output=True, text=True,
                             timeout=10, cwd=pathlib.Path(__file__).resolve().parent.parent)
        return [line[3:] for line in out.stdout.splitlines()] if out.returncode == 0 else None
    except Exception:  # noqa: BLE001
        return None


def peers_wired(rw, res, args) -> bool:
    """The peers comparison (peers_compare.py): run, print, save its JSON,
    markdown and figure.  False (with a printed line) where no peer is installed."""
    import peers
    import peers_compare

    available = peers.availability()
    if not (available["heyoka"] or available["cyrk"]):
        print("peers comparison skipped: neither heyoka nor CyRK is installed "
              "(pip install -e '.[bench]')", flush=True)
        return False
    res["peers"] = peers_res = peers_compare.run(rw, args)
    md = peers_compare.matched_tables(peers_res)
    print("\n" + md, flush=True)
    stem = f"accuracy_cost-{C.timestamp()}-peers" + ("-quick" if args.quick else "")
    args.out.mkdir(parents=True, exist_ok=True)
    paths = [C.save_json(args.out / f"{stem}.json", {k: v for k, v in res.items() if k != "scenes"}),
             C.save_text(args.out / f"{stem}.md", md)]
    if not args.no_figure:
        paths.append(peers_compare.draw(peers_res, args.out / f"{stem}.png"))
    print("\nsaved: " + ", ".join(str(p) for p in paths), flush=True)
    return True


def main(argv=None) -> int:
    args = parse_args(argv)
    wall_started = time.perf_counter()
    import numba
    import numpy as np

    import rampwork as rw

    try:
        from rampwork import reference
    except ImportError as error:
        print(f"rampwork.reference needs scipy ({error}); install the test extra", file=sys.stderr)
        return 2
    threads = args.threads or numba.config.NUMBA_NUM_THREADS
    if not 1 <= threads <= numba.config.NUMBA_NUM_THREADS:
        print(f"--threads must be in 1..{numba.config.NUMBA_NUM_THREADS}", file=sys.stderr)
        return 2
    if args.peers and args.scene_specs:
        import peers

        available = peers.availability()
        args.sizes["peers"] = bool(available["heyoka"] and available["cyrk"])
        if not args.sizes["peers"]:
            print("peers on the scenes skipped: heyoka and CyRK are both needed "
                  f"({'; '.join(available['why'].values())})", flush=True)
    settings = build_settings(args.sizes)
    res = {"benchmark": "accuracy_cost", "started_utc": C.utc_now(), "machine": C.machine_info(),
           "src_modified_in_working_tree": modified_sources(),
           "config": {"quick": args.quick, "threads": threads, "seed": args.seed, **args.sizes,
                      "reference_rtol": REF_RTOL, "reference_atol": REF_ATOL,
                      "reference_check_rtol": REF_CHECK_RTOL, "reference_check_atol": REF_CHECK_ATOL,
                      "reference_unconverged_threshold": UNCONVERGED, "W_floor_J": W_FLOOR},
           "settings": settings, "scenes": []}
    print(f"accuracy_cost: {len(args.scene_specs)} scenes x {len(settings)} settings, "
          f"{args.sizes['n']} trajectories per scene, {threads} threads"
          + (" (quick)" if args.quick else ""), flush=True)
    for spec in args.scene_specs:
        res["scenes"].append(run_scene(rw, reference, np, spec, settings, args, threads))
    if not args.no_throughput:
        res["throughput"] = throughput_line(rw, reference, np, args)
    if args.peers:
        if not peers_wired(rw, res, args):
            return 0
        if args.peers_only:
            return 0
    if not res["scenes"]:  # --throughput-only
        sentence = throughput_sentence(res["throughput"])
        print("\n" + sentence)
        stem = f"accuracy_cost-{C.timestamp()}-throughput" + ("-quick" if args.quick else "")
        res["total_wall_s"] = time.perf_counter() - wall_started
        paths = [C.save_json(args.out / f"{stem}.json", res)]
        print("\nsaved: " + ", ".join(str(p) for p in paths))
        return 0
    res["picks"] = picks(res["scenes"])
    res["picks_ignoring_mismatch"] = picks(res["scenes"], allow_mismatch=True)
    res["cost_slopes"] = cost_slopes(res["scenes"], np)
    res["summary"] = summary_paragraph(res)
    res["total_wall_s"] = time.perf_counter() - wall_started
    try:
        import os

        res["machine"]["load_average_at_end"] = list(os.getloadavg())
    except OSError:
        pass
    text, md = build_tables(res)
    print("\n" + text)
    print("\nSUMMARY\n" + res["summary"])

    stem = f"accuracy_cost-{C.timestamp()}" + ("-quick" if args.quick else "")
    out_dir = args.out
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = [C.save_json(out_dir / f"{stem}.json", res), C.save_text(out_dir / f"{stem}.md", md)]
    try:
        paths.append(write_dataset(rw, res, out_dir / f"{stem}.nc", np))
    except Exception as error:  # noqa: BLE001 - the numbers matter more than the file
        print(f"netCDF not written: {error!r}", file=sys.stderr)
    if not args.no_figure:
        try:
            paths.append(draw_figure(res, out_dir / f"{stem}.png"))
        except Exception as error:  # noqa: BLE001
            print(f"figure not drawn: {error!r}", file=sys.stderr)
    if args.gallery is not None:
        args.gallery.mkdir(parents=True, exist_ok=True)
        paths.append(C.save_text(args.gallery / "accuracy_cost.md", gallery_markdown(res)))
        if not args.no_figure:
            try:
                paths.append(draw_figure(res, args.gallery / "accuracy_cost.png"))
            except Exception as error:  # noqa: BLE001
                print(f"gallery figure not drawn: {error!r}", file=sys.stderr)
    print("\nsaved: " + ", ".join(str(p) for p in paths))
    print(f"total wall time {res['total_wall_s']:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
