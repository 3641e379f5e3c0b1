#!/usr/bin/env python
"""Throughput of rampwork's batch kernel beside its peers, in one run.

Acceptance test of the "core engine" issue: trajectory-steps per second for
Euler and RK4 on a quadratic-bowl sweep of 10^6 trajectories with events on (a
start grid x0 x v0 x mu on which about half of the trajectories come to rest
and stick and the rest exit), compilation time reported apart from run time,
accuracy reported beside time, and in the same run:

* scipy.integrate.solve_ivp (DOP853, rtol 1e-8) per trajectory, with the
  reversal/stick and exit events, on a random subset of the same grid:
  compared by trajectories per second (its steps are not rampwork's steps);
* a plain numpy-vectorised fixed-step integrator (same method, same dt) over
  a random subset, with masks for finished trajectories and events snapped to
  step ends: compared by trajectory-steps per second;
* the hardware ceiling: a numba loop of independent float64 divisions on all
  threads (Euler needs 1 division per step, RK4 4);
* rampwork on 1 and 2 threads, to show the scaling.

Targets (2-core machine, events on): RK4 >= 3e8 and Euler >= 1.5e9
trajectory-steps per second.

Run from the repository root::

    .venv/bin/python benchmarks/throughput.py            # full size (10^6)
    .venv/bin/python benchmarks/throughput.py --quick    # smoke run, < 1 min

Results (JSON, markdown table, PNG figure) go to benchmarks/results/.
"""

from __future__ import annotations

import argparse
import functools
import importlib
import importlib.util
import math
import pathlib
import sys
import time
import warnings

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402

# ------------------------------------------------------------------------------
# the benchmark's scene and targets
# ------------------------------------------------------------------------------
#: quadratic bowl y = curvature x^2 / 2 on (-1, 1): f' = x, so a particle at rest
#: at x sticks where |x| <= mu
CURVATURE = 1.0  # 1/m
SLOPE = 0.0
HEIGHT = 0.0
DOMAIN = (-1.0, 1.0)
G = 9.81
T_MAX = 60.0
#: start grid: x0 in X0_RANGE, v0 in (-V0_MAX, V0_MAX), mu in MU_RANGE.  V0_MAX is
#: tuned so that about half of the trajectories stick and the rest exit.
X0_RANGE = (-0.95, 0.95)
V0_MAX = 7.0  # m/s
MU_RANGE = (0.02, 0.5)

#: trajectory-steps per second with events on, 2-core machine
TARGETS = {"euler": 1.5e9, "rk4": 3.0e8}
#: float64 divisions per step of each method (the kernel's only divisions:
#: one per acceleration evaluation)
DIVISIONS_PER_STEP = {"euler": 1, "semi_implicit_euler": 1, "rk4": 4}
METHOD_LABELS = {"euler": "Euler", "semi_implicit_euler": "semi-implicit Euler", "rk4": "RK4"}

#: reference for accuracy: RK4 at dt / REF_REFINE unless rampwork.reference exists
REF_REFINE = 16
SCIPY_METHOD = "DOP853"
SCIPY_RTOL = 1e-8
SCIPY_ATOL = 1e-10

QUICK = dict(n=20_000, scipy_subset=20, numpy_subset=5_000, accuracy_subset=50, uniform=2_000)
FULL = dict(n=1_000_000, scipy_subset=200, numpy_subset=100_000, accuracy_subset=200, uniform=100_000)
#: the identical-trajectory diagnostic: a start that swings about 8 times
#: (about 8.5e3 steps at dt = 1e-3) and sticks; every lane is busy all the time
UNIFORM_START = {"x0": 0.9, "v0": 0.0, "mu": 0.05}

STATUS_STUCK, STATUS_EXITED, STATUS_TIMEOUT, STATUS_DIVERGED = 1, 2, 4, 5


def parse_args(argv=None):
    p = argparse.ArgumentParser(
        prog="throughput.py",
        description=(
            "Trajectory-steps per second of rampwork's batch kernel (Euler, RK4) on a "
            "quadratic-bowl sweep with stick/exit events, compile time apart, accuracy "
            "beside time, and in the same run: scipy solve_ivp per trajectory, a plain "
            "numpy-vectorised integrator, a float64-division hardware ceiling and "
            "1- vs 2-thread scaling. Prints a table of ratios and targets and saves "
            "JSON, markdown and PNG under --out."),
)
    p.add_argument("--n", type=float, default=None,
                   help="trajectories in the start grid x0 x v0 x mu (rounded to a product "
                        f"of three axis lengths; default {FULL['n']:.0e}, --quick {QUICK['n']:.0e})")
    p.add_argument("--dt", type=float, default=1e-3, help="fixed step (s) of every fixed-step run (default %(default)g)")
    p.add_argument("--methods", default="euler,rk4",
                   help="comma-separated rampwork methods: euler, rk4, semi_implicit_euler "
                        "(default %(default)s)")
    p.add_argument("--scipy-subset", type=int, default=None,
                   help=f"trajectories run one by one with scipy solve_ivp ({SCIPY_METHOD}); "
                        f"0 skips it (default {FULL['scipy_subset']}, --quick {QUICK['scipy_subset']})")
    p.add_argument("--numpy-subset", type=int, default=None,
                   help="trajectories run by the numpy-vectorised integrator; 0 skips it "
                        f"(default {FULL['numpy_subset']:.0e}, --quick {QUICK['numpy_subset']})")
    p.add_argument("--accuracy-subset", type=int, default=None,
                   help="trajectories compared against the high-accuracy reference "
                        f"(default {FULL['accuracy_subset']}, --quick {QUICK['accuracy_subset']})")
    p.add_argument("--uniform", type=int, default=None,
                   help="trajectories of the identical-trajectory diagnostic (all lanes busy, "
                        "no tail of long trajectories); 0 skips it "
                        f"(default {FULL['uniform']}, --quick {QUICK['uniform']})")
    p.add_argument("--threads", type=int, default=None,
                   help="threads of the main rampwork runs and the division ceiling "
                        "(default: NUMBA_NUM_THREADS); 1 and 2 threads are run as well")
    p.add_argument("--repeat", type=int, default=1,
                   help="timed repetitions of each main rampwork run; the fastest counts (default 1)")
    p.add_argument("--no-scaling", action="store_true",
                   help="skip the extra 1- and 2-thread rampwork runs")
    p.add_argument("--seed", type=int, default=0, help="seed of the random subsets (default 0)")
    p.add_argument("--out", type=pathlib.Path, default=C.RESULTS_DIR,
                   help="folder for the JSON, markdown and PNG results (default benchmarks/results)")
    p.add_argument("--no-figure", action="store_true", help="do not draw the PNG figure")
    p.add_argument("--quick", action="store_true",
                   help="small sizes for a smoke run (under a minute once compiled)")
    args = p.parse_args(argv)
    sizes = QUICK if args.quick else FULL
    args.n = int(sizes["n"] if args.n is None else args.n)
    for name in ("scipy_subset", "numpy_subset", "accuracy_subset", "uniform"):
        if getattr(args, name) is None:
            setattr(args, name, sizes[name])
    args.methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    if args.n < 1:
        p.error("--n must be >= 1")
    if not args.dt > 0:
        p.error("--dt must be > 0")
    if args.repeat < 1:
        p.error("--repeat must be >= 1")
    unknown = [m for m in args.methods if m not in DIVISIONS_PER_STEP]
    if unknown or not args.methods:
        p.error(f"--methods: unknown {unknown}; choose from {', '.join(DIVISIONS_PER_STEP)}")
    return args


# ------------------------------------------------------------------------------
# the start grid
# ------------------------------------------------------------------------------
def grid_axes(n: int, np):
    """x0, v0, mu axes whose outer product has about n points."""
    side = max(1, round(n ** (1.0 / 3.0)))
    n_mu = max(1, round(n / (side * side)))
    return {"x0": np.linspace(*X0_RANGE, side),
            "v0": np.linspace(-V0_MAX, V0_MAX, side),
            "mu": np.linspace(*MU_RANGE, n_mu)}


def flat_columns(axes, index, np):
    """x0, v0, mu of the flat grid indices ``index`` (grid order x0, v0, mu)."""
    shape = tuple(len(v) for v in axes.values())
    unravelled = np.unravel_index(index, shape)
    return {name: np.asarray(values)[unravelled[k]] for k, (name, values) in enumerate(axes.items())}


# ------------------------------------------------------------------------------
# (c) the hardware ceiling: independent float64 divisions on all threads
# ------------------------------------------------------------------------------
@functools.lru_cache(maxsize=None)
def make_division_kernel():
    """Built only after rampwork is imported, so that it gets the same LLVM
    CPU features (vector width) as rampwork's kernels."""
    import numba
    import numpy as np

    lanes = 64  # as in rampwork's kernel: 64 independent lanes per block

    @numba.njit(parallel=True, error_model="numpy", fastmath=False, cache=False)
    def divide(n_blocks, reps, out):
        for b in numba.prange(n_blocks):
            x = np.empty(lanes)
            for i in range(lanes):
                x[i] = 1.0 + 1e-3 * i + 1e-9 * b
            for _ in range(reps):
                for i in range(lanes):  # 64 independent chains: throughput-bound
                    x[i] = 1.0 / (x[i] + 1.0)
            total = 0.0
            for i in range(lanes):
                total += x[i]
            out[b] = total

    return divide, lanes


def measure_ceilings(threads: int, target_seconds: float) -> list[dict]:
    """The division ceiling on ``threads`` threads and on one thread."""
    out = [measure_division_ceiling(threads, target_seconds)]
    if threads != 1:
        out.append(measure_division_ceiling(1, target_seconds))
    print("  " + ", ".join(f"{c['divisions_per_s']:.3e} div/s on {c['threads']} thread(s)"
                           for c in out), flush=True)
    return out


def measure_division_ceiling(threads: int, target_seconds: float) -> dict:
    import numba
    import numpy as np

    divide, lanes = make_division_kernel()
    started = time.perf_counter()
    divide(threads, 10, np.empty(threads))
    compile_s = time.perf_counter() - started
    n_blocks = 8 * threads
    previous = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        reps = 20_000
        while True:  # calibrate to about target_seconds
            out = np.empty(n_blocks)
            started = time.perf_counter()
            divide(n_blocks, reps, out)
            elapsed = time.perf_counter() - started
            if elapsed >= 0.25 * target_seconds or reps > 1e9:
                break
            reps = int(reps * max(2.0, 0.3 * target_seconds / max(elapsed, 1e-6)))
        best = math.inf
        for _ in range(3):
            started = time.perf_counter()
            divide(n_blocks, reps, out)
            best = min(best, time.perf_counter() - started)
    finally:
        numba.set_num_threads(previous)
    assert np.isfinite(out).all()
    divisions = n_blocks * reps * lanes
    return {"threads": threads, "divisions": divisions, "seconds": best,
            "divisions_per_s": divisions / best, "compile_s": compile_s}


# ------------------------------------------------------------------------------
# (b) plain numpy-vectorised fixed-step integrator
# ------------------------------------------------------------------------------
def numpy_peer(method, x0, v0, mu, dt, np):
    """Fixed-step integration of all trajectories at once with numpy arrays.

    Active trajectories are held as rows of one (6, m) array that is compacted
    when some finish.  Events are snapped to step ends: a step whose end has
    the other sign of v is a reversal (v set to 0 there, then the rest rule:
    stick if |f'| <= mu, else go on downhill); a step whose end lies outside the
    domain is an exit (x clipped to the end); t_max gives a timeout; a
    non-finite v gives diverged.  Returns per-trajectory results and counts."""
    c, s, g = CURVATURE, SLOPE, G
    lo, hi = DOMAIN
    n = x0.size
    status = np.zeros(n, np.int8)
    x_end = np.full(n, np.nan)
    w_end = np.zeros(n)
    steps = np.zeros(n, np.int64)
    fp0 = s + c * x0
    d0 = np.where(v0 > 0, 1.0, -1.0)
    rest = v0 == 0.0
    d0[rest] = np.where(np.abs(fp0[rest]) <= mu[rest], 0.0, -np.sign(fp0[rest]))
    start_stuck = d0 == 0.0
    status[start_stuck] = STATUS_STUCK
    x_end[start_stuck] = x0[start_stuck]
    start_exit = ((x0 >= hi) & (d0 > 0)) | ((x0 <= lo) & (d0 < 0))
    status[start_exit] = STATUS_EXITED
    x_end[start_exit] = x0[start_exit]
    ids = np.flatnonzero(~(start_stuck | start_exit))
    # rows: x, v, W, q = d mu, mu, d
    state = np.stack([x0[ids], v0[ids], np.zeros(ids.size), d0[ids] * mu[ids], mu[ids], d0[ids]])
    max_steps = int(math.floor(T_MAX / dt))
    h = dt
    half = 0.5 * h
    sixth = h / 6.0

    def acc(x, v, q):
        fp = s + c * x
        nn = g + v * v * c
        return -nn * (fp + q) / (1.0 + fp * fp), nn

    k = 0
    total_steps = 0
    started = time.perf_counter()
    with np.errstate(all="ignore"):
        while ids.size:
            if k >= max_steps:
                status[ids] = STATUS_TIMEOUT
                x_end[ids] = state[0]
                w_end[ids] = state[2]
                steps[ids] = k
                break
            x, v, w, q = state[0], state[1], state[2], state[3]
            if method == "rk4":
                a1, n1 = acc(x, v, q)
                x2 = x + half * v
                v2 = v + half * a1
                a2, n2 = acc(x2, v2, q)
                x3 = x + half * v2
                v3 = v + half * a2
                a3, n3 = acc(x3, v3, q)
                x4 = x + h * v3
                v4 = v + h * a3
                a4, n4 = acc(x4, v4, q)
                x1 = x + sixth * (v + 2.0 * (v2 + v3) + v4)
                v1 = v + sixth * (a1 + 2.0 * (a2 + a3) + a4)
                w1 = w + q * sixth * (n1 * v + 2.0 * (n2 * v2 + n3 * v3) + n4 * v4)
            else:
                a1, n1 = acc(x, v, q)
                v1 = v + h * a1
                x1 = x + h * (v1 if method == "semi_implicit_euler" else v)
                w1 = w + h * q * n1 * v
            k += 1
            total_steps += ids.size
            state[0] = x1
            state[1] = v1
            state[2] = w1
            exited = (x1 >= hi) | (x1 <= lo)
            reversed_ = state[5] * v1 <= 0.0
            bad = ~np.isfinite(v1)
            event = exited | reversed_ | bad
            if not event.any():
                continue
            done = exited | bad
            rev = np.flatnonzero(reversed_ & ~done)
            if rev.size:
                state[1, rev] = 0.0
                fp = s + c * state[0, rev]
                stick = np.abs(fp) <= state[4, rev]
                direction = np.where(stick, 0.0, -np.sign(fp))
                state[5, rev] = direction
                state[3, rev] = direction * state[4, rev]
                done[rev[stick]] = True
            if done.any():
                where = np.flatnonzero(done)
                finished = ids[where]
                status[finished] = np.where(bad[where], STATUS_DIVERGED,
                                            np.where(exited[where], STATUS_EXITED, STATUS_STUCK))
                x_end[finished] = np.clip(state[0, where], lo, hi)
                w_end[finished] = state[2, where]
                steps[finished] = k
                keep = ~done
                state = state[:, keep]
                ids = ids[keep]
    seconds = time.perf_counter() - started
    return {"status": status, "x_end": x_end, "W_friction": w_end, "steps": steps,
            "trajectory_steps": int(total_steps), "seconds": seconds}


# ------------------------------------------------------------------------------
# (a) scipy solve_ivp, one trajectory at a time
# ------------------------------------------------------------------------------
def scipy_trajectory(x0, v0, mu, solve_ivp):
    """One trajectory with solve_ivp: integrate a mode (direction d fixed)
    until the reversal event v = 0 or an exit event, apply the rest rule
    (stick if |f'| <= mu, else restart downhill), repeat until stuck, exited or
    t_max.  Friction work is integrated as a third state."""
    c, s, g = CURVATURE, SLOPE, G
    lo, hi = DOMAIN
    t, x, v, w = 0.0, float(x0), float(v0), 0.0
    nfev = 0
    if v == 0.0:
        fp = s + c * x
        d = 0.0 if abs(fp) <= mu else -math.copysign(1.0, fp)
    else:
        d = 1.0 if v > 0.0 else -1.0
    while True:
        if d == 0.0:
            return STATUS_STUCK, x, w, nfev
        q = d * mu

        def rhs(_t, y, q=q):
            fp = s + c * y[0]
            nn = g + y[1] * y[1] * c
            return (y[1], -nn * (fp + q) / (1.0 + fp * fp), q * nn * y[1])

        def reversal(_t, y):
            return y[1]

        def exit_hi(_t, y):
            return hi - y[0]

        def exit_lo(_t, y):
            return y[0] - lo

        reversal.terminal = exit_hi.terminal = exit_lo.terminal = True
        reversal.direction = -d  # d v goes from + to -
        exit_hi.direction = exit_lo.direction = -1.0
        sol = solve_ivp(rhs, (t, T_MAX), (x, v, w), method=SCIPY_METHOD, rtol=SCIPY_RTOL,
                        atol=SCIPY_ATOL, events=(reversal, exit_hi, exit_lo))
        nfev += sol.nfev
        if sol.status == 0:
            return STATUS_TIMEOUT, sol.y[0, -1], sol.y[2, -1], nfev
        if sol.status < 0:
            return STATUS_DIVERGED, math.nan, math.nan, nfev
        hits = [(te[0], k) for k, te in enumerate(sol.t_events) if len(te)]
        t, which = min(hits)
        x, v, w = sol.y_events[which][0]
        if which == 1:
            return STATUS_EXITED, hi, w, nfev
        if which == 2:
            return STATUS_EXITED, lo, w, nfev
        v = 0.0
        fp = s + c * x
        d = 0.0 if abs(fp) <= mu else -math.copysign(1.0, fp)


def scipy_peer(x0, v0, mu, np):
    from scipy.integrate import solve_ivp

    n = x0.size
    status = np.zeros(n, np.int8)
    x_end = np.full(n, np.nan)
    w_end = np.full(n, np.nan)
    nfev = 0
    started = time.perf_counter()
    for j in range(n):
        status[j], x_end[j], w_end[j], fev = scipy_trajectory(x0[j], v0[j], mu[j], solve_ivp)
        nfev += fev
    seconds = time.perf_counter() - started
    return {"status": status, "x_end": x_end, "W_friction": w_end, "nfev": nfev, "seconds": seconds}


# ------------------------------------------------------------------------------
# rampwork runs
# ------------------------------------------------------------------------------
def make_scene(rw, method, dt):
    ramp = rw.Ramp.create("quadratic", curvature=CURVATURE, slope=SLOPE, height=HEIGHT, domain=DOMAIN)
    return rw.Scene(ramp=ramp, friction=rw.Friction(mu_k=0.2), integrator=rw.Integrator(method, dt),
                    g=G, t_max=T_MAX, title=f"throughput benchmark, {method}")


def kernel_cache_info(rw, scene, sweep):
    """Numba's disk-cache hits/misses of the run_batch dispatcher (rampwork
    internals; None where they cannot be read)."""
    try:
        from rampwork import kernels, runner

        plan = runner.plan_run(scene, sweep)
        run_batch = kernels._KERNELS[plan.variant][0]
        stats = run_batch.stats
        hits, misses = sum(stats.cache_hits.values()), sum(stats.cache_misses.values())
        source = "disk cache" if hits and not misses else ("compiled" if misses else "unknown")
        return {"cache_hits": hits, "cache_misses": misses, "source": source}
    except Exception as error:  # noqa: BLE001 - informative only
        return {"source": "unknown", "error": repr(error)}


def first_compile(rw, np, scene):
    """A tiny simulate that loads or compiles the kernel: its compile time."""
    sweep = rw.Sweep.cases(x0=[0.5, -0.5], v0=[0.0, 1.0], mu=[0.1, 0.6])
    started = time.perf_counter()
    ds = rw.simulate(scene, sweep, kernel=C.KERNEL)
    wall = time.perf_counter() - started
    info = kernel_cache_info(rw, scene, sweep)
    info.update(compile_time_s=float(ds.attrs["compile_time_s"]), first_call_wall_s=wall)
    return info


def timed_run(rw, scene, sweep, threads, repeat=1):
    best = None
    for _ in range(repeat):
        ds = rw.simulate(scene, sweep, threads=threads, kernel=C.KERNEL)
        if best is None or ds.attrs["run_time_s"] < best.attrs["run_time_s"]:
            best = ds
    return best


def run_summary(ds, n):
    run_s = float(ds.attrs["run_time_s"])
    steps = int(ds.attrs["trajectory_steps"])
    return {"threads": int(ds.attrs["threads"]), "run_time_s": run_s,
            "compile_time_s": float(ds.attrs["compile_time_s"]),
            "trajectory_steps": steps, "n_trajectories": n,
            "steps_per_s": steps / run_s, "trajectories_per_s": n / run_s}


def status_fractions(status, np):
    status = np.asarray(status).ravel()
    n = max(status.size, 1)
    stuck = float((status == STATUS_STUCK).sum() / n)
    exited = float((status == STATUS_EXITED).sum() / n)
    other = float(((status != STATUS_STUCK) & (status != STATUS_EXITED)).sum() / n)
    return {"stuck": stuck, "exited": exited, "other": other,
            "timeout": float((status == STATUS_TIMEOUT).sum() / n),
            "diverged": float((status == STATUS_DIVERGED).sum() / n)}


def energy_balance_stats(ds, np):
    work = ds["W_friction"].values.ravel()
    err = np.abs(ds["energy_balance_error"].values.ravel())
    moving = work > 1e-12
    rel = err[moving] / work[moving]
    if rel.size == 0:
        return {"median": math.nan, "max": math.nan, "count": 0}
    return {"median": float(np.median(rel)), "max": float(np.max(rel)), "count": int(rel.size)}


def accuracy_against(result, reference, np):
    """x_end and W_friction errors of ``result`` against ``reference`` on
    trajectories with the same final status; status mismatches counted apart
    (they sit on a stick/slide or exit threshold, where any error flips them).
    x_end is compared on the stuck trajectories only (an exit's x_end is the
    domain end in every solver)."""
    same = np.asarray(result["status"]) == np.asarray(reference["status"])
    # x_end of an exit is the domain end by construction: compare stuck ones
    stuck = same & (np.asarray(reference["status"]) == STATUS_STUCK)
    dx = np.abs(np.asarray(result["x_end"]) - np.asarray(reference["x_end"]))[stuck]
    w, w_ref = np.asarray(result["W_friction"])[same], np.asarray(reference["W_friction"])[same]
    dw = np.abs(w - w_ref) / np.maximum(np.abs(w_ref), 1e-12)
    dw[(w == 0) & (w_ref == 0)] = 0.0
    out = {"compared": int(same.size), "status_mismatches": int((~same).sum())}
    for name, values in (("x_end_abs_error_m", dx), ("W_friction_rel_error", dw)):
        finite = values[np.isfinite(values)]
        out[name] = ({"median": float(np.median(finite)), "max": float(np.max(finite))}
                     if finite.size else {"median": math.nan, "max": math.nan})
        out[name]["non_finite"] = int(values.size - finite.size)
    return out


def reference_results(rw, np, cols, dt):
    """High-accuracy x_end, W_friction, status on the accuracy subset:
    rampwork.reference.reference_sweep (an independent scipy DOP853 solver,
    rtol = atol = 1e-12) if it can be imported, else rampwork RK4 at dt / 16."""
    if importlib.util.find_spec("rampwork.reference") is not None:
        try:
            reference = importlib.import_module("rampwork.reference")
            scene = make_scene(rw, "rk4", dt)
            started = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out = reference.reference_sweep(scene, rw.Sweep.cases(**cols))
            return ({name: np.asarray(out[name]).ravel() for name in ("status", "x_end", "W_friction")},
                    {"kind": "rampwork.reference.reference_sweep (scipy DOP853, rtol=atol=1e-12)",
                     "seconds": time.perf_counter() - started})
        except Exception as error:  # noqa: BLE001 - fall back, but say why
            print(f"  rampwork.reference not usable ({error!r}); falling back to RK4 at dt/{REF_REFINE}")
    scene = make_scene(rw, "rk4", dt / REF_REFINE)
    ds = rw.simulate(scene, rw.Sweep.cases(**cols))
    return ({name: ds[name].values.ravel() for name in ("status", "x_end", "W_friction")},
            {"kind": f"rampwork rk4 at dt/{REF_REFINE} = {dt / REF_REFINE:g} s",
             "seconds": float(ds.attrs["run_time_s"])})


# ------------------------------------------------------------------------------
# report
# ------------------------------------------------------------------------------
def build_tables(res) -> tuple[str, str]:
    """(terminal text, markdown) of the results."""
    f, r = C.fmt_rate, C.fmt_ratio
    main_threads = res["config"]["threads"]
    ceiling = res["division_ceiling"]

    thr_head = ["method", "compile s (source)", "run s", "traj-steps/s", "traj/s",
                "1 thr steps/s", "2 thr steps/s", "2/1 speedup", "identical-traj steps/s (2/1)",
                "div ceiling", "of ceiling", "identical of ceiling", "grid/identical", "target",
                "met"]
    thr_rows = []
    peer_head = ["method", "rampwork steps/s", "numpy steps/s", "rampwork/numpy",
                 "rampwork traj/s", "scipy traj/s", "rampwork/scipy", "scipy equiv steps/s"]
    peer_rows = []
    acc_head = ["method / run", "|EB err|/W med", "|EB err|/W max", "stuck x_end err med (m)",
                "stuck x_end err max (m)", "W rel err med", "W rel err max", "status mismatch"]
    acc_rows = []
    for method, m in res["methods"].items():
        main = m["main"]
        comp = m["first_compile"]
        scaling = m.get("scaling", {})
        s1 = scaling.get("1", {}).get("steps_per_s")
        s2 = scaling.get("2", {}).get("steps_per_s")
        target = TARGETS.get(method)
        uniform = m.get("uniform") or {}
        u_main = uniform.get(str(main_threads), {}).get("steps_per_s")
        u1, u2 = (uniform.get(k, {}).get("steps_per_s") for k in ("1", "2"))
        uniform_cell = (f(u_main) + (f" ({r(u2 / u1)})" if u1 and u2 else "")) if u_main else "-"
        thr_rows.append([
            METHOD_LABELS[method], f"{comp['compile_time_s']:.2f} ({comp['source']})",
            f"{main['run_time_s']:.3f}", f(main["steps_per_s"]), f(main["trajectories_per_s"]),
            f(s1), f(s2), r(s2 / s1) if s1 and s2 else "-", uniform_cell,
            f(m["ceiling_steps_per_s"]), f"{100 * m['fraction_of_ceiling']:.0f}%",
            f"{100 * m['uniform_fraction_of_ceiling']:.0f}%" if "uniform_fraction_of_ceiling" in m
            else "-",
            f"{m['grid_over_uniform']:.2f}" if "grid_over_uniform" in m else "-",
            f(target) if target else "-",
            ("YES" if m["target_met"] else "NO") if target else "-"])
        numpy_ = m.get("numpy")
        scipy_ = res.get("scipy")
        peer_rows.append([
            METHOD_LABELS[method], f(main["steps_per_s"]),
            f(numpy_["steps_per_s"]) if numpy_ else "-",
            r(m["ratio_vs_numpy_steps"]) if numpy_ else "-",
            f(main["trajectories_per_s"]),
            f(scipy_["trajectories_per_s"]) if scipy_ else "-",
            r(m["ratio_vs_scipy_trajectories"]) if scipy_ else "-",
            f(m.get("scipy_equivalent_steps_per_s")) if scipy_ else "-"])
        eb = m["energy_balance"]
        a = m.get("accuracy")  # absent with --accuracy-subset 0
        acc_rows.append([f"rampwork {method}", f"{eb['median']:.2e}", f"{eb['max']:.2e}"] + (
            [f"{a['x_end_abs_error_m']['median']:.1e}", f"{a['x_end_abs_error_m']['max']:.1e}",
             f"{a['W_friction_rel_error']['median']:.1e}", f"{a['W_friction_rel_error']['max']:.1e}",
             f"{a['status_mismatches']}/{a['compared']}"] if a else ["-"] * 5))
        if numpy_ and numpy_.get("accuracy"):
            a = numpy_["accuracy"]
            acc_rows.append([f"numpy {method}", "-", "-",
                             f"{a['x_end_abs_error_m']['median']:.1e}", f"{a['x_end_abs_error_m']['max']:.1e}",
                             f"{a['W_friction_rel_error']['median']:.1e}",
                             f"{a['W_friction_rel_error']['max']:.1e}",
                             f"{a['status_mismatches']}/{a['compared']}"])
    if res.get("scipy") and res["scipy"].get("accuracy"):
        a = res["scipy"]["accuracy"]
        acc_rows.append([f"scipy {SCIPY_METHOD}", "-", "-",
                         f"{a['x_end_abs_error_m']['median']:.1e}", f"{a['x_end_abs_error_m']['max']:.1e}",
                         f"{a['W_friction_rel_error']['median']:.1e}",
                         f"{a['W_friction_rel_error']['max']:.1e}",
                         f"{a['status_mismatches']}/{a['compared']}"])

    cfg = res["config"]
    grid = res["grid"]
    sf = res["status_fractions"]
    header = [
        f"rampwork throughput: quadratic bowl (curvature {CURVATURE} /m on {DOMAIN}), "
        f"{grid['n']:,} trajectories = x0[{grid['shape'][0]}] x v0[{grid['shape'][1]}] x mu[{grid['shape'][2]}], "
        f"dt = {cfg['dt']:g} s, t_max = {T_MAX:g} s, {main_threads} thread(s)",
        f"machine: {res['machine']['cpu_model']}, {res['machine']['usable_cores']} usable cores, "
        f"numba {res['machine']['numba']}, 512-bit vectors: {res['machine']['wide_vectors_512bit']}, "
        f"load avg (1/5/15 min) at start "
        f"{'/'.join(f'{x:.1f}' for x in res['machine']['load_average_1_5_15min'] or [])}, at end "
        f"{'/'.join(f'{x:.1f}' for x in res['machine'].get('load_average_at_end') or [])}",
        "status fractions: " + "; ".join(
            f"{meth}: stuck {v['stuck']:.3f}, exited {v['exited']:.3f}, other {v['other']:.3f}"
            for meth, v in sf.items()),
        f"division ceiling (best of start and end): {f(ceiling['divisions_per_s'])} div/s on "
        f"{ceiling['threads']} thread(s), {f(res['division_ceiling_1thread']['divisions_per_s'])} "
        "div/s on 1 thread (ceiling steps/s = div/s / divisions per step: Euler 1, RK4 4)",
        "steps per trajectory: " + "; ".join(
            f"{meth}: mean {v['steps_per_trajectory']['mean']:.0f}, median "
            f"{v['steps_per_trajectory']['median']:.0f}, p99 {v['steps_per_trajectory']['p99']:.0f}, "
            f"max {v['steps_per_trajectory']['max']}" for meth, v in res["methods"].items()),
    ]
    notes = [
        "compile: first tiny simulate's compile_time_s (kernel built or loaded from numba's disk cache); "
        "run s / rates: the timed big run, compile excluded.",
        "identical-traj: the same start repeated (every lane busy, no tail of long trajectories), "
        f"{res['config'].get('uniform', 0):,} trajectories of about "
        f"{res['config'].get('uniform_steps', 0):.0f} steps: the kernel's per-step speed without "
        "load imbalance and with few events (about 8 per trajectory); grid/identical: the grid's "
        "rate over it, the share of the speed that the grid's events and tail leave.",
        "numpy: plain numpy-vectorised fixed-step integrator, same method and dt, "
        f"{res.get('numpy_subset', 0):,} trajectories, events snapped to step ends.",
        f"scipy: solve_ivp {SCIPY_METHOD} rtol {SCIPY_RTOL:g} atol {SCIPY_ATOL:g} per trajectory with "
        f"reversal/stick and exit events, {res.get('scipy_subset', 0)} trajectories; compared by "
        "trajectories/s (equiv steps/s = its traj/s x rampwork's steps per trajectory).",
        (f"accuracy: {res['reference']['kind']} on {res['accuracy_subset']} trajectories; errors on "
         "trajectories with the reference's status; "
         if "reference" in res else "accuracy: not compared (--accuracy-subset 0); ")
        + "EB err = energy_balance_error over the whole grid.",
    ]
    text = "\n".join(header) + "\n\nTHROUGHPUT\n" + C.text_table(thr_head, thr_rows) \
        + "\n\nPEERS (ratios = rampwork / peer)\n" + C.text_table(peer_head, peer_rows) \
        + "\n\nACCURACY\n" + C.text_table(acc_head, acc_rows) + "\n\n" + "\n".join(notes)
    md = "# rampwork throughput benchmark\n\n" + "\n".join(f"- {h}" for h in header) \
        + "\n\n## Throughput\n\n" + C.markdown_table(thr_head, thr_rows) \
        + "\n\n## Peers (ratios = rampwork / peer)\n\n" + C.markdown_table(peer_head, peer_rows) \
        + "\n\n## Accuracy\n\n" + C.markdown_table(acc_head, acc_rows) \
        + "\n\n" + "\n".join(f"- {n}" for n in notes) + "\n"
    return text, md


def draw_figure(res, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = list(res["methods"])
    series = [("rampwork, %d thread(s)" % res["config"]["threads"], "C0",
               lambda m: res["methods"][m]["main"]["steps_per_s"]),
              ("rampwork, 1 thread", "C9",
               lambda m: res["methods"][m].get("scaling", {}).get("1", {}).get("steps_per_s")),
              ("rampwork, %d thread(s), identical trajectories\n(all lanes busy: no load imbalance)"
               % res["config"]["threads"], "C4",
               lambda m: (res["methods"][m].get("uniform") or {}).get(
                   str(res["config"]["threads"]), {}).get("steps_per_s")),
              ("numpy vectorised, same method and dt", "C1",
               lambda m: (res["methods"][m].get("numpy") or {}).get("steps_per_s")),
              (f"scipy solve_ivp {SCIPY_METHOD} per trajectory\n(equivalent: traj/s x rampwork steps/traj)",
               "C2", lambda m: res["methods"][m].get("scipy_equivalent_steps_per_s"))]
    fig, ax = plt.subplots(figsize=(10, 6.8), layout="constrained")
    width = 0.8 / len(series)
    for k, (label, color, get) in enumerate(series):
        xs, ys = [], []
        for i, m in enumerate(methods):
            value = get(m)
            if value:
                xs.append(i - 0.4 + (k + 0.5) * width)
                ys.append(value)
        bars = ax.bar(xs, ys, width * 0.95, label=label, color=color)
        for bar, value in zip(bars, ys):
            ax.annotate(f"{value:.2g}", (bar.get_x() + bar.get_width() / 2, value),
                        ha="center", va="bottom", fontsize=8, xytext=(0, 2),
                        textcoords="offset points")
    for i, m in enumerate(methods):
        ceiling = res["methods"][m]["ceiling_steps_per_s"]
        ax.hlines(ceiling, i - 0.45, i + 0.45, colors="k", linestyles=":", linewidth=2,
                  label="division ceiling (div/s / divisions per step)" if i == 0 else None)
        ax.annotate(f"ceiling {ceiling:.2g}", (i + 0.45, ceiling), ha="right", va="top",
                    fontsize=8, xytext=(0, -2), textcoords="offset points")
        if m in TARGETS:
            ax.hlines(TARGETS[m], i - 0.45, i + 0.45, colors="C3", linestyles="--", linewidth=2,
                      label="target (2-core machine)" if not any(
                          mm in TARGETS for mm in methods[:i]) else None)
            ax.annotate(f"target {TARGETS[m]:.2g}", (i - 0.45, TARGETS[m]), ha="left",
                        va="bottom", fontsize=8, color="C3", xytext=(0, 2),
                        textcoords="offset points")
    ax.set_yscale("log")
    ax.set_xticks(range(len(methods)), [METHOD_LABELS[m] for m in methods])
    ax.set_ylabel("trajectory-steps per second (log scale)")
    grid = res["grid"]
    ax.set_title(f"rampwork throughput, quadratic bowl with stick/exit events\n"
                 f"{grid['n']:,} trajectories, dt = {res['config']['dt']:g} s; "
                 f"{res['machine']['cpu_model']}, {res['machine']['usable_cores']} cores", fontsize=10)
    ax.grid(axis="y", which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.07), ncol=2, frameon=False)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


# ------------------------------------------------------------------------------
# main
# ------------------------------------------------------------------------------
def main(argv=None) -> int:
    args = parse_args(argv)
    wall_started = time.perf_counter()
    # rampwork first: its import sets numba's CPU features before anything compiles
    import numba
    import numpy as np

    import rampwork as rw

    threads = args.threads or numba.config.NUMBA_NUM_THREADS
    if not 1 <= threads <= numba.config.NUMBA_NUM_THREADS:
        print(f"--threads must be in 1..{numba.config.NUMBA_NUM_THREADS}", file=sys.stderr)
        return 2
    machine = C.machine_info()
    axes = grid_axes(args.n, np)
    shape = tuple(len(v) for v in axes.values())
    n = int(np.prod(shape))
    sweep = rw.Sweep.grid(**axes)
    rng = np.random.default_rng(args.seed)
    order = rng.permutation(n)
    subsets = {name: order[:min(size, n)] for name, size in
               (("scipy", args.scipy_subset), ("numpy", args.numpy_subset),
                ("accuracy", args.accuracy_subset))}
    # the accuracy subset lies inside the numpy and scipy subsets where they are larger
    print(f"grid: {n:,} trajectories = x0 {shape[0]} x v0 {shape[1]} x mu {shape[2]}; "
          f"dt {args.dt:g} s; methods {', '.join(args.methods)}; {threads} thread(s)", flush=True)

    res = {"benchmark": "throughput", "started_utc": C.utc_now(), "machine": machine,
           "config": {"n_requested": args.n, "dt": args.dt, "methods": args.methods,
                      "threads": threads, "repeat": args.repeat, "seed": args.seed,
                      "quick": args.quick, "scaling": not args.no_scaling,
                      "uniform": args.uniform},
           "scene": {"ramp": "quadratic", "curvature_per_m": CURVATURE, "slope": SLOPE,
                     "height_m": HEIGHT, "domain_m": DOMAIN, "g": G, "t_max_s": T_MAX,
                     "contact": "one_sided", "mu_s": "= mu_k (swept as mu)"},
           "grid": {"n": n, "shape": shape, "x0_range_m": X0_RANGE, "v0_range_m_s": (-V0_MAX, V0_MAX),
                    "mu_range": MU_RANGE},
           "targets_steps_per_s": TARGETS, "divisions_per_step": DIVISIONS_PER_STEP,
           "scipy_subset": int(subsets["scipy"].size), "numpy_subset": int(subsets["numpy"].size),
           "accuracy_subset": int(subsets["accuracy"].size),
           "methods": {}, "status_fractions": {}}

    # (c) hardware ceiling, on the main thread count and on one thread
    print("division ceiling ...", flush=True)
    ceiling_seconds = 0.5 if args.quick else 1.5
    ceilings = measure_ceilings(threads, ceiling_seconds)

    scaling_threads = [] if args.no_scaling else sorted(
        {t for t in (1, 2) if t <= numba.config.NUMBA_NUM_THREADS} - {threads})
    on_accuracy_subset = {}
    for method in args.methods:
        print(f"rampwork {method} ...", flush=True)
        scene = make_scene(rw, method, args.dt)
        m = {"first_compile": first_compile(rw, np, scene)}
        print(f"  compile {m['first_compile']['compile_time_s']:.2f} s "
              f"({m['first_compile']['source']})", flush=True)
        ds = timed_run(rw, scene, sweep, threads, args.repeat)
        m["main"] = run_summary(ds, n)
        m["steps_per_trajectory_mean"] = m["main"]["trajectory_steps"] / n
        steps = ds["steps"].values.ravel()
        m["steps_per_trajectory"] = {"mean": float(steps.mean()), "median": float(np.median(steps)),
                                     "p99": float(np.percentile(steps, 99)), "max": int(steps.max())}
        print(f"  {m['main']['run_time_s']:.3f} s, {m['main']['steps_per_s']:.3e} steps/s", flush=True)
        res["status_fractions"][method] = status_fractions(ds["status"].values, np)
        m["energy_balance"] = energy_balance_stats(ds, np)
        flat = {name: ds[name].values.ravel() for name in ("status", "x_end", "W_friction", "steps")}
        on_accuracy_subset[method] = {k: v[subsets["accuracy"]] for k, v in flat.items()}
        m["scipy_subset_steps_per_trajectory"] = float(flat["steps"][subsets["scipy"]].mean()) \
            if subsets["scipy"].size else None
        m["scaling"] = {str(threads): m["main"]}
        for t in scaling_threads:
            m["scaling"][str(t)] = run_summary(timed_run(rw, scene, sweep, t), n)
            print(f"  {t} thread(s): {m['scaling'][str(t)]['steps_per_s']:.3e} steps/s", flush=True)
        del ds, flat, steps
        if args.uniform:
            uniform = rw.Sweep.cases(**{k: np.full(args.uniform, v) for k, v in UNIFORM_START.items()})
            m["uniform"] = {"start": UNIFORM_START}
            for t in sorted({threads, *scaling_threads}):
                m["uniform"][str(t)] = run_summary(timed_run(rw, scene, uniform, t), args.uniform)
            res["config"]["uniform_steps"] = (m["uniform"][str(threads)]["trajectory_steps"]
                                              / args.uniform)
            print("  identical trajectories: " + ", ".join(
                f"{t} thread(s) {m['uniform'][str(t)]['steps_per_s']:.3e} steps/s"
                for t in sorted({threads, *scaling_threads})), flush=True)
        m["target_steps_per_s"] = TARGETS.get(method)
        m["target_met"] = (m["main"]["steps_per_s"] >= TARGETS[method]) if method in TARGETS else None
        res["methods"][method] = m

    # reference for the accuracy subset (after the first compiles, which it would hide)
    reference = None
    if subsets["accuracy"].size:
        acc_cols = flat_columns(axes, subsets["accuracy"], np)
        print("reference for accuracy ...", flush=True)
        reference, res["reference"] = reference_results(rw, np, acc_cols, args.dt)
        res["reference"]["status_fractions"] = status_fractions(reference["status"], np)
        for method, m in res["methods"].items():
            m["accuracy"] = accuracy_against(on_accuracy_subset[method], reference, np)

    # (b) numpy-vectorised peer, per method, same dt
    if subsets["numpy"].size:
        cols = flat_columns(axes, subsets["numpy"], np)
        in_acc = np.isin(subsets["numpy"], subsets["accuracy"])
        acc_pos = {j: k for k, j in enumerate(subsets["accuracy"])}
        for method in args.methods:
            print(f"numpy {method} on {subsets['numpy'].size:,} trajectories ...", flush=True)
            out = numpy_peer(method, cols["x0"], cols["v0"], cols["mu"], args.dt, np)
            peer = {"trajectories": int(subsets["numpy"].size), "seconds": out["seconds"],
                    "trajectory_steps": out["trajectory_steps"],
                    "steps_per_s": out["trajectory_steps"] / out["seconds"],
                    "trajectories_per_s": subsets["numpy"].size / out["seconds"],
                    "status_fractions": status_fractions(out["status"], np)}
            if in_acc.any():
                ref_index = [acc_pos[j] for j in subsets["numpy"][in_acc]]
                peer["accuracy"] = accuracy_against(
                    {k: out[k][in_acc] for k in ("status", "x_end", "W_friction")},
                    {k: v[ref_index] for k, v in reference.items()}, np)
            print(f"  {out['seconds']:.2f} s, {peer['steps_per_s']:.3e} steps/s", flush=True)
            m = res["methods"][method]
            m["numpy"] = peer
            m["ratio_vs_numpy_steps"] = m["main"]["steps_per_s"] / peer["steps_per_s"]

    # (a) scipy solve_ivp per trajectory
    if subsets["scipy"].size:
        if importlib.util.find_spec("scipy") is None:
            print("scipy not installed: skipping the solve_ivp peer", flush=True)
        else:
            cols = flat_columns(axes, subsets["scipy"], np)
            print(f"scipy solve_ivp {SCIPY_METHOD} on {subsets['scipy'].size} trajectories ...", flush=True)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out = scipy_peer(cols["x0"], cols["v0"], cols["mu"], np)
            peer = {"method": SCIPY_METHOD, "rtol": SCIPY_RTOL, "atol": SCIPY_ATOL,
                    "trajectories": int(subsets["scipy"].size), "seconds": out["seconds"],
                    "trajectories_per_s": subsets["scipy"].size / out["seconds"],
                    "rhs_evaluations": out["nfev"],
                    "status_fractions": status_fractions(out["status"], np)}
            in_acc = np.isin(subsets["scipy"], subsets["accuracy"])
            if in_acc.any():
                acc_pos = {j: k for k, j in enumerate(subsets["accuracy"])}
                ref_index = [acc_pos[j] for j in subsets["scipy"][in_acc]]
                peer["accuracy"] = accuracy_against(
                    {k: out[k][in_acc] for k in ("status", "x_end", "W_friction")},
                    {k: v[ref_index] for k, v in reference.items()}, np)
            print(f"  {out['seconds']:.2f} s, {peer['trajectories_per_s']:.3g} trajectories/s", flush=True)
            res["scipy"] = peer
            for method, m in res["methods"].items():
                m["ratio_vs_scipy_trajectories"] = (m["main"]["trajectories_per_s"]
                                                    / peer["trajectories_per_s"])
                m["scipy_equivalent_steps_per_s"] = (peer["trajectories_per_s"]
                                                     * m["scipy_subset_steps_per_trajectory"])

    # the ceiling again at the end: the machine is shared, the best of the two counts
    print("division ceiling again ...", flush=True)
    ceilings += measure_ceilings(threads, ceiling_seconds)
    res["division_ceiling_all"] = ceilings
    res["division_ceiling"] = max((c for c in ceilings if c["threads"] == threads),
                                  key=lambda c: c["divisions_per_s"])
    res["division_ceiling_1thread"] = max((c for c in ceilings if c["threads"] == 1),
                                          key=lambda c: c["divisions_per_s"])
    for method, m in res["methods"].items():
        m["ceiling_steps_per_s"] = (res["division_ceiling"]["divisions_per_s"]
                                    / DIVISIONS_PER_STEP[method])
        m["fraction_of_ceiling"] = m["main"]["steps_per_s"] / m["ceiling_steps_per_s"]
        busy = (m.get("uniform") or {}).get(str(threads))
        if busy:  # every lane busy (few events): what the events cost, as a ratio in one run
            m["uniform_fraction_of_ceiling"] = busy["steps_per_s"] / m["ceiling_steps_per_s"]
            m["grid_over_uniform"] = m["main"]["steps_per_s"] / busy["steps_per_s"]
    res["total_wall_s"] = time.perf_counter() - wall_started
    try:
        res["machine"]["threading_layer_used"] = numba.threading_layer()
    except ValueError:
        pass
    try:
        import os

        res["machine"]["load_average_at_end"] = list(os.getloadavg())
    except OSError:
        pass
    text, md = build_tables(res)
    print("\n" + text)
    print("\nTARGETS")
    for method, m in res["methods"].items():
        if method in TARGETS:
            print(f"  {METHOD_LABELS[method]:>5}: {m['main']['steps_per_s']:.3e} trajectory-steps/s "
                  f"vs target {TARGETS[method]:.1e}: {'MET' if m['target_met'] else 'NOT MET'} "
                  f"({m['main']['steps_per_s'] / TARGETS[method]:.2f} of target, "
                  f"{100 * m['fraction_of_ceiling']:.0f}% of the division ceiling)")

    stem = f"throughput-{C.timestamp()}" + ("-quick" if args.quick else "")
    out_dir = args.out
    paths = [C.save_json(out_dir / f"{stem}.json", res), C.save_text(out_dir / f"{stem}.md", md)]
    if not args.no_figure:
        try:
            paths.append(draw_figure(res, out_dir / f"{stem}.png"))
        except Exception as error:  # noqa: BLE001 - the numbers matter more than the figure
            print(f"figure not drawn: {error!r}", file=sys.stderr)
    print("\nsaved: " + ", ".join(str(p) for p in paths))
    print(f"total wall time {res['total_wall_s']:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
