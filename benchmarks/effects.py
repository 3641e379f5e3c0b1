#!/usr/bin/env python
"""What each effect costs, side by side in one process (issue 4: "simulate
only the effects a scene calls for").

1. Time per trajectory-step with each effect compiled in and out over the same
   sweep, on identical inputs, interleaved repeats (the fastest counts):
   the lift-off check on a convex ramp (results must be identical: asserted),
   one-sided vs two-sided contact on a dome (different physics), the paper's
   eq. (26) diagnostic (results otherwise identical: asserted), static
   friction mu_s > mu_k (same kernel), carrying f', f'' vs re-evaluating them,
   and, where the API exists, air drag and the mu = 0 kernel without a
   friction branch.  Euler and RK4.
2. The straight-ramp closed form against stepping the same sweep with RK4 and
   Euler: time per trajectory and the stepped results' differences from the
   closed form.
3. The minimal scene (explicit Euler, convex quadratic ramp, one-sided, no
   lift-off check, no diagnostics, mu_s = mu_k) against a kernel written by
   hand for exactly that scene, in this file: same results (asserted), timed
   on the same inputs on 1 and 2 threads.
4. Compile times: cold (a fresh process with an empty NUMBA_CACHE_DIR), warm
   (a second fresh process with the same cache dir: numba loads from disk) and
   a repeated in-process build (rampwork's kernel memo).

Run from the repository root::

    .venv/bin/python benchmarks/effects.py --quick   # smoke run (Euler only)
    .venv/bin/python benchmarks/effects.py           # full run (< 10 min once compiled)

JSON (and the markdown tables) go to benchmarks/results/, the figure of a
full run to benchmarks/figures/effects.png.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import pathlib
import subprocess
import sys
import tempfile
import textwrap
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402

# rampwork first: its import sets numba's CPU features (vector width, inlining
# budget) before anything compiles, the hand-written kernel below included
import numba  # noqa: E402
import numpy as np  # noqa: E402

import rampwork as rw  # noqa: E402
from rampwork import kernels, runner  # noqa: E402
from rampwork.core import kernel as K  # noqa: E402
from rampwork.core.variant import KernelVariant  # noqa: E402
from rampwork.core.jit import flip_sign, fma  # noqa: E402  (the hand kernel rounds like rampwork)

FIGURE = pathlib.Path(__file__).resolve().parent / "figures" / "effects.png"

# ------------------------------------------------------------------------------
# scenes and sweeps
# ------------------------------------------------------------------------------
G = 9.81
DT = 1e-3
T_MAX = 60.0
#: throughput.py's quadratic bowl y = x^2 / 2 on (-1, 1): about half the grid sticks
CURVATURE = 1.0
DOMAIN = (-1.0, 1.0)
X0_RANGE = (-0.95, 0.95)
V0_MAX = 7.0
MU_RANGE = (0.02, 0.5)
#: static friction row: mu_s = mu_k + MU_S_EXTRA
MU_S_EXTRA = 0.1
#: dome y = sqrt(1 - x^2) on (-0.9, 0.9): n changes sign at speed
DOME_DOMAIN = (-0.9, 0.9)
DOME_X0 = (-0.85, 0.85)
DOME_V0 = 4.0
#: straight ramp y = 0.3 x on (-1, 1), launched up or down
STRAIGHT_SLOPE = 0.3
STRAIGHT_V0 = 4.0
STRAIGHT_MU = (0.1, 0.6)
#: mu = 0 row: no friction, so nothing sticks; a shorter t_max
FRICTIONLESS_T_MAX = 5.0
#: drag rows (only where rampwork has rw.Drag)
DRAG_LINEAR = 0.2  # 1/s
DRAG_QUADRATIC = 0.1  # 1/m

QUICK = dict(n=27_000, n_dome=27_000, n_straight=27_000, n_hand=27_000, repeat=5, hand_repeat=5,
             target_s=0.05,
             methods=("euler",), probes=("euler_quadratic", "closed_form_straight"))
FULL = dict(n=64_000, n_dome=64_000, n_straight=64_000, n_hand=125_000, repeat=11, hand_repeat=11,
            target_s=0.1,
            methods=("euler", "rk4"),
            probes=("euler_quadratic", "rk4_dome", "dopri5_dome", "closed_form_straight"))

STATUS = {0: "not_run", 1: "stuck", 2: "exited", 3: "lifted_off", 4: "timeout", 5: "diverged"}
#: rows of the kernel's outputs compared for "identical results"
#: (the paper diagnostic's own row is left out of that comparison)
COMPARED_ROWS = tuple(r for r in range(K.N_OUTPUTS) if r != K.OUT_XLIFT_PAPER)


def parse_args(argv=None):
    p = argparse.ArgumentParser(prog="effects.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="smoke run: Euler only, small sweeps, 2 probes")
    p.add_argument("--n", type=int, help="trajectories of the quadratic and dome sweeps of the effect "
                                          "rows (default 64000, quick 27000; the hand-written comparison "
                                          "runs 125000, quick 27000)")
    p.add_argument("--threads", type=int, default=1,
                   help="threads of the effect rows and the closed-form table (default 1: the least "
                        "noisy on a shared machine); the hand-written comparison runs 1 and 2")
    p.add_argument("--repeat", type=int, help="interleaved repeats per timing (default 11, quick 5)")
    p.add_argument("--target", type=float, help="seconds one timed sample lasts at least: short runs are "
                                                "repeated back to back inside a sample (default 0.1, quick 0.05)")
    p.add_argument("--methods", help="comma-separated: euler, rk4 (default both, quick euler)")
    p.add_argument("--no-probes", action="store_true", help="skip the cold/warm compile subprocesses")
    p.add_argument("--out", type=pathlib.Path, default=C.RESULTS_DIR, help="folder for JSON and markdown")
    p.add_argument("--figure", type=pathlib.Path, default=None,
                   help=f"PNG path (default {FIGURE.relative_to(FIGURE.parents[2])} for a full run, "
                        "the results folder for --quick)")
    p.add_argument("--no-figure", action="store_true")
    args = p.parse_args(argv)
    sizes = QUICK if args.quick else FULL
    args.n = args.n or sizes["n"]
    args.n_dome = args.n if args.n != sizes["n"] else sizes["n_dome"]
    args.target = args.target or sizes["target_s"]
    args.n_hand = sizes["n_hand"]
    args.n_straight = sizes["n_straight"]
    args.repeat = args.repeat or sizes["repeat"]
    args.hand_repeat = max(args.repeat, sizes["hand_repeat"])
    args.methods = tuple(m.strip() for m in args.methods.split(",")) if args.methods else sizes["methods"]
    args.probes = () if args.no_probes else sizes["probes"]
    return args


def cube_axes(n, **ranges):
    side = max(2, round(n ** (1.0 / len(ranges))))
    return {name: np.linspace(lo, hi, side) for name, (lo, hi) in ranges.items()}


def quadratic_scene(method, **changes):
    ramp = rw.Ramp.create("quadratic", curvature=CURVATURE, domain=DOMAIN)
    return rw.Scene(ramp=ramp, friction=rw.Friction(0.2), integrator=rw.Integrator(method, DT),
                    g=G, t_max=T_MAX, **changes)


def quadratic_sweep(n):
    return rw.Sweep.grid(**cube_axes(n, x0=X0_RANGE, v0=(-V0_MAX, V0_MAX), mu=MU_RANGE))


def dome_scene(method, contact):
    ramp = rw.Ramp.create("circular_dome", radius=1.0, domain=DOME_DOMAIN)
    return rw.Scene(ramp=ramp, friction=rw.Friction(0.2), integrator=rw.Integrator(method, DT),
                    g=G, t_max=T_MAX, contact=contact)


def dome_sweep(n):
    return rw.Sweep.grid(**cube_axes(n, x0=DOME_X0, v0=(-DOME_V0, DOME_V0), mu=MU_RANGE))


def straight_scene(method=None):
    ramp = rw.Ramp.create("straight", slope=STRAIGHT_SLOPE, domain=DOMAIN)
    integrator = rw.Integrator("rk4", DT) if method is None else rw.Integrator(method, DT, closed_form=False)
    return rw.Scene(ramp=ramp, friction=rw.Friction(0.2), integrator=integrator, g=G, t_max=T_MAX)


def straight_sweep(n):
    return rw.Sweep.grid(**cube_axes(n, x0=X0_RANGE, v0=(-STRAIGHT_V0, STRAIGHT_V0), mu=STRAIGHT_MU))


# ------------------------------------------------------------------------------
# kernels and timing
# ------------------------------------------------------------------------------
BUILD_PARAMETERS = {field.name for field in dataclasses.fields(KernelVariant)} - {"family", "method"}
HAS_FRICTION_FLAG = "friction" in BUILD_PARAMETERS
HAS_DRAG = hasattr(rw, "Drag")


def build(scene, **flags):
    """``build_kernel`` for a scene with explicit compile-time flags; returns
    (run_batch, compile info).  Compile (or disk-cache load) time is the build
    plus a first call on one trajectory, as ``runner.prepare`` measures it."""
    unknown = set(flags) - BUILD_PARAMETERS
    if unknown:
        raise TypeError(f"build_kernel has no {sorted(unknown)}")
    spec = scene.ramp.spec
    started = time.perf_counter()
    variant = KernelVariant(spec.key, scene.integrator.method, **flags)
    run_batch, _ = K.build_kernel(variant, spec.height, spec.slope_curvature)
    return run_batch, warm_up(run_batch, scene, started)


def warm_up(run_batch, scene, started):
    plan = runner.plan_run(scene, rw.Sweep.cases(x0=[0.0], v0=[1.0]))
    inputs = runner.chunk_inputs(plan, 0, 1)
    inputs[K.IN_X0] = scene.ramp.domain[1]  # ends at once
    run_batch(inputs, runner._settings(scene), np.zeros((K.N_OUTPUTS, 1)), scene.ramp.shared_array(), 1)
    return {"seconds": time.perf_counter() - started, "source": cache_source(run_batch)}


def cache_source(dispatcher):
    try:
        hits = sum(dispatcher.stats.cache_hits.values())
        misses = sum(dispatcher.stats.cache_misses.values())
    except Exception:  # noqa: BLE001
        return "?"
    return "disk cache" if hits and not misses else "compiled"


def runner_kernel(scene, sweep):
    """The kernel the runner picks for a scene (get_kernel), compiled."""
    plan = runner.plan_run(scene, sweep)
    started = time.perf_counter()
    (run_batch, _), _ = kernels.get_kernel(plan.variant, plan)
    return plan, run_batch, warm_up(run_batch, scene, started)


def runner_flags(plan):
    """Build flags equal to the runner's pick for a plan: its variant's choices."""
    return {field.name: getattr(plan.variant, field.name)
            for field in dataclasses.fields(plan.variant) if field.type == "bool"}


def variant(label, run_batch, scene, inputs, compile_info, note=""):
    return {"label": label, "run_batch": run_batch, "inputs": inputs, "settings": runner._settings(scene),
            "shared": scene.ramp.shared_array(), "compile": compile_info, "note": note,
            "out": np.zeros((K.N_OUTPUTS, inputs.shape[1]))}


def call(v, threads, inner=1):
    """``inner`` back-to-back runs of a variant on ``threads`` threads:
    (wall s, cpu s) per run."""
    n = v["inputs"].shape[1]
    tile = runner.tile_size(n, threads)
    with runner.using_threads(threads):
        wall0, cpu0 = time.perf_counter(), time.process_time()
        for _ in range(inner):
            if "hand" in v:
                v["hand"](v["inputs"], v["out"], v["params"], tile)
            else:
                v["run_batch"](v["inputs"], v["settings"], v["out"], v["shared"], tile)
        return (time.perf_counter() - wall0) / inner, (time.process_time() - cpu0) / inner


def side_by_side(variants, threads_list, repeat, target_s):
    """Interleaved repeats of every (variant, threads), the order reversed every
    other round; per pair the fastest wall time counts (median kept too).
    An untimed first run per pair warms up (and sets how many back-to-back runs
    make one sample of at least ``target_s``)."""
    walls = {(k, t): [] for k in range(len(variants)) for t in threads_list}
    cpus = {key: [] for key in walls}
    inner = {}
    for key in walls:
        wall, _ = call(variants[key[0]], key[1])
        inner[key] = int(min(10_000, max(1, math.ceil(target_s / max(wall, 1e-7)))))
    for r in range(repeat):
        keys = list(walls)
        for key in (keys if r % 2 == 0 else keys[::-1]):
            wall, cpu = call(variants[key[0]], key[1], inner[key])
            walls[key].append(wall)
            cpus[key].append(cpu)
    timings = {}
    for (k, t), values in walls.items():
        steps = float(variants[k]["out"][K.OUT_STEPS].sum())
        n = variants[k]["inputs"].shape[1]
        best = min(values)
        timings[(k, t)] = {"threads": t, "wall_best_s": best, "wall_median_s": float(np.median(values)),
                           "cpu_best_s": min(cpus[(k, t)]), "walls_s": values, "runs_per_sample": inner[(k, t)],
                           "trajectories": n,
                           "trajectory_steps": steps,
                           "ns_per_step": 1e9 * best / steps if steps else None,
                           "ns_per_trajectory": 1e9 * best / n,
                           "steps_per_s": steps / best if steps else None}
    return timings


def paired_ratio(a, b):
    """Median over rounds of b's time / a's time in the same round (adjacent in
    time, so slow drifts of a shared machine cancel)."""
    return float(np.median(np.asarray(b["walls_s"]) / np.asarray(a["walls_s"])))


def status_fractions(out):
    codes, counts = np.unique(out[K.OUT_STATUS].astype(int), return_counts=True)
    return {STATUS.get(int(c), str(c)): float(k) / out.shape[1] for c, k in zip(codes, counts)}


def identical(a, b, rows=COMPARED_ROWS):
    return bool(np.array_equal(a[list(rows)], b[list(rows)], equal_nan=True))


def max_difference(a, b, row):
    d = np.abs(a[row] - b[row])
    d = d[np.isfinite(d)]
    return float(d.max()) if d.size else 0.0


# ------------------------------------------------------------------------------
# 1. effect rows
# ------------------------------------------------------------------------------
def effect_rows(args, log):
    rows = []
    for method in args.methods:
        scene = quadratic_scene(method)
        sweep = quadratic_sweep(args.n)
        plan, base_batch, base_compile = runner_kernel(scene, sweep)
        base_flags = runner_flags(plan)
        assert not plan.variant.check_contact and not plan.variant.carry_slope, "the runner's pick changed"
        inputs = runner.chunk_inputs(plan, 0, plan.size)
        base = variant("runner's pick", base_batch, scene, inputs, base_compile)
        log(f"[{method}] quadratic sweep {plan.size:,} trajectories; runner's kernel: "
            f"{'; '.join(plan.effects)} ({base_compile['seconds']:.1f} s, {base_compile['source']})")

        def flagged(label, **changes):
            run_batch, info = build(scene, **{**base_flags, **changes})
            log(f"  built {label}: {info['seconds']:.1f} s ({info['source']})")
            return variant(label, run_batch, scene, inputs, info)

        # the noise floor: the same kernel twice, interleaved like every row
        twin = variant("runner's pick again", base_batch, scene, inputs, base_compile)
        rows.append(effect_row(method, "none: same kernel twice (noise floor)", base, twin, args, log,
                               expect_identical=True, runner_pick="-"))
        # lift-off check on a convex ramp: off is the runner's pick
        rows.append(effect_row(method, "lift-off check (convex quadratic)", base,
                               flagged("check_contact=True", check_contact=True),
                               args, log, expect_identical=True, runner_pick="off"))
        # the paper's eq. (26) diagnostic
        rows.append(effect_row(method, "paper eq. (26) diagnostic", base,
                               flagged("paper_criterion=True", paper_criterion=True),
                               args, log, expect_identical=True, runner_pick="off (unless asked)"))
        # carry f', f'' in the lanes instead of re-evaluating them
        rows.append(effect_row(method, "carry f', f'' (vs re-evaluate)", base,
                               flagged("carry_slope=True", carry_slope=True),
                               args, log, expect_identical=None, runner_pick="off (cheap family)"))
        # static friction: same kernel, mu_s = mu_k + 0.1
        static_inputs = inputs.copy()
        static_inputs[K.IN_MUS] = static_inputs[K.IN_MUK] + MU_S_EXTRA
        static = variant(f"mu_s = mu_k + {MU_S_EXTRA}", base_batch, scene, static_inputs, base_compile)
        rows.append(effect_row(method, f"static friction mu_s = mu_k + {MU_S_EXTRA} (same kernel)",
                               base, static, args, log, expect_identical=None,
                               runner_pick="same kernel", physics_differs=True))
        # air drag (when rampwork has it): the runner's kernels with and without
        if HAS_DRAG:
            for label, drag in (("linear", rw.Drag(linear=DRAG_LINEAR, quadratic=0.0)),
                                ("linear + quadratic", rw.Drag(linear=DRAG_LINEAR, quadratic=DRAG_QUADRATIC))):
                drag_scene = scene.replace(drag=drag)
                drag_plan, drag_batch, drag_compile = runner_kernel(drag_scene, sweep)
                log(f"  built drag {label}: {drag_compile['seconds']:.1f} s ({drag_compile['source']}); "
                    f"{'; '.join(drag_plan.effects)}")
                on = variant(f"drag {label}", drag_batch, drag_scene,
                             runner.chunk_inputs(drag_plan, 0, drag_plan.size), drag_compile)
                rows.append(effect_row(method, f"air drag, {label} (b={DRAG_LINEAR}/s"
                                       + (f", c={DRAG_QUADRATIC}/m" if "quadratic" in label else "") + ")",
                                       base, on, args, log, expect_identical=None,
                                       runner_pick="per scene", physics_differs=True))
        # mu = 0: a kernel without the friction branch (when build_kernel has the flag)
        if HAS_FRICTION_FLAG:
            free_scene = scene.replace(friction=rw.Friction(0.0), t_max=FRICTIONLESS_T_MAX)
            free_sweep = rw.Sweep.grid(**cube_axes(args.n // 4, x0=X0_RANGE, v0=(-V0_MAX, V0_MAX)))
            free_plan = runner.plan_run(free_scene, free_sweep)
            free_inputs = runner.chunk_inputs(free_plan, 0, free_plan.size)
            flags = runner_flags(free_plan)
            pruned = []
            for friction in (False, True):
                run_batch, info = build(free_scene, **{**flags, "friction": friction})
                log(f"  built friction={friction}: {info['seconds']:.1f} s ({info['source']})")
                pruned.append(variant(f"friction={friction}", run_batch, free_scene, free_inputs, info))
            rows.append(effect_row(method, f"friction branch at mu = 0 (t_max {FRICTIONLESS_T_MAX:g} s)",
                                   pruned[0], pruned[1], args, log, expect_identical=True,
                                   runner_pick="off" if not free_plan.variant.friction else "on"))
        # one-sided vs two-sided contact on a dome
        d_sweep = dome_sweep(args.n_dome)
        d_variants = []
        for contact in ("one_sided", "two_sided"):
            d_scene = dome_scene(method, contact)
            d_plan, d_batch, d_compile = runner_kernel(d_scene, d_sweep)
            log(f"  built dome {contact}: {d_compile['seconds']:.1f} s ({d_compile['source']}); "
                f"{'; '.join(d_plan.effects)}")
            d_variants.append(variant(contact, d_batch, d_scene, runner.chunk_inputs(d_plan, 0, d_plan.size),
                                      d_compile))
        rows.append(effect_row(method, "two-sided contact (vs one-sided), dome", d_variants[0], d_variants[1],
                               args, log, expect_identical=None, runner_pick="per scene",
                               physics_differs=True))
    return rows


def effect_row(method, effect, off, on, args, log, *, expect_identical, runner_pick, physics_differs=False):
    timings = side_by_side([off, on], [args.threads], args.repeat, args.target)
    t_off, t_on = timings[(0, args.threads)], timings[(1, args.threads)]
    same = identical(off["out"], on["out"])
    if expect_identical:
        assert same, f"{method} {effect}: results differ between on and off"
    row = {"method": method, "effect": effect, "off": off["label"], "on": on["label"],
           "threads": args.threads, "off_timing": t_off, "on_timing": t_on,
           "ratio_on_off": t_on["ns_per_step"] / t_off["ns_per_step"],
           # per step: the paired time ratio scaled by the step counts
           "ratio_on_off_paired_median": (paired_ratio(t_off, t_on) * t_off["trajectory_steps"]
                                          / t_on["trajectory_steps"]),
           "identical": same, "identity_asserted": bool(expect_identical),
           "physics_differs": physics_differs, "runner_pick": runner_pick,
           "compile_off": off["compile"], "compile_on": on["compile"],
           "status_off": status_fractions(off["out"]), "status_on": status_fractions(on["out"]),
           "steps_per_trajectory_off": t_off["trajectory_steps"] / t_off["trajectories"],
           "steps_per_trajectory_on": t_on["trajectory_steps"] / t_on["trajectories"]}
    if not same:
        row["max_abs_difference"] = {name: max_difference(off["out"], on["out"], r) for name, r in
                                     (("x_end", K.OUT_X), ("W_friction", K.OUT_WORK), ("t_end", K.OUT_T))}
        row["status_mismatches"] = int((off["out"][K.OUT_STATUS] != on["out"][K.OUT_STATUS]).sum())
    log(f"  {effect}: off {t_off['ns_per_step']:.3f} ns/step, on {t_on['ns_per_step']:.3f} ns/step, "
        f"on/off {row['ratio_on_off']:.3f} (paired median {row['ratio_on_off_paired_median']:.3f}), "
        f"identical {same}")
    return row


# ------------------------------------------------------------------------------
# 2. the straight-ramp closed form against stepping
# ------------------------------------------------------------------------------
def outcome(out):
    return out[K.OUT_STATUS] * 4.0 + np.where(out[K.OUT_STATUS] == 2, np.sign(out[K.OUT_X]), 0.0)


def closed_form_table(args, log):
    sweep = straight_sweep(args.n_straight)
    variants = []
    for method in (None, "rk4", "euler"):
        scene = straight_scene(method)
        plan, run_batch, info = runner_kernel(scene, sweep)
        assert plan.variant.closed_form == (method is None)
        label = "closed form" if method is None else f"{method} dt={DT:g}"
        log(f"  {label}: {info['seconds']:.1f} s ({info['source']})")
        variants.append(variant(label, run_batch, scene, runner.chunk_inputs(plan, 0, plan.size), info))
    timings = side_by_side(variants, [args.threads], args.repeat, args.target)
    exact = variants[0]["out"]
    rows = []
    for k, v in enumerate(variants):
        t = timings[(k, args.threads)]
        out = v["out"]
        # same outcome: same status and, for an exit, the same end (a launch
        # that just reaches the top in one solver can slide back and leave at
        # the bottom in the other: a knife edge, counted, not differenced)
        same_status = outcome(out) == outcome(exact)
        rows.append({"solver": v["label"], "timing": t, "compile": v["compile"],
                     "speed_up_of_closed_form": t["wall_best_s"] / timings[(0, args.threads)]["wall_best_s"],
                     "steps_per_trajectory": t["trajectory_steps"] / t["trajectories"],
                     "outcome_mismatches": int((~same_status).sum()),
                     "max_abs_x_end_difference": float(np.abs(out[K.OUT_X] - exact[K.OUT_X])[same_status].max()),
                     "max_abs_W_friction_difference":
                         float(np.abs(out[K.OUT_WORK] - exact[K.OUT_WORK])[same_status].max()),
                     "max_abs_t_end_difference": float(np.abs(out[K.OUT_T] - exact[K.OUT_T])[same_status].max())})
        log(f"  {v['label']}: {t['ns_per_trajectory'] / 1e3:.3f} us/trajectory, "
            f"max |dx_end| {rows[-1]['max_abs_x_end_difference']:.2e} m, "
            f"max |dW| {rows[-1]['max_abs_W_friction_difference']:.2e} J/kg")
    return {"sweep_size": variants[0]["inputs"].shape[1], "status": status_fractions(exact), "rows": rows,
            "threads": args.threads}


# ------------------------------------------------------------------------------
# 3. a kernel written by hand for exactly the minimal scene
# ------------------------------------------------------------------------------
# Scene: explicit Euler, y = height + slope x + curvature x^2 / 2 with curvature
# > 0 (n = g + v^2 c > 0: no lift-off possible), one-sided, mu_s = mu_k, g and
# the ramp fixed (scalars, not per-trajectory inputs), x0, v0, mu per
# trajectory.  Built like rampwork's fixed-step kernel, so that the two compare
# like with like: 64 lanes in lock-step, structure of arrays at constant
# offsets.  Every lane takes every step; a step whose event conditions fire
# only raises the lane's flag (freezing the lane with a select against its
# stored state compiles to masked stores, many times slower on AMD Zen).  Every
# 16 steps a scalar pass books the clean lanes' steps, replays a flagged lane
# from the block's checkpoint with the same step function up to its event,
# solves that event inside the step in closed form (Euler: x and v are linear
# in the step size) and refills finished lanes.  Outputs: rampwork's rows (per
# unit mass); the convexity mean is the constant curvature (no integral), the
# path is banked per mode, the work accumulated per step.  Divergence guards as
# rampwork's: non-finite state, speed bound, energy rise, event cascade.
HL = 64  # lanes
HSUB = 16  # steps between scalar passes
HUNROLL = 1  # steps per lane visit, state in registers (1: the fastest here, as for rampwork's Euler)
HCHAINS = 2  # a full block runs its two halves side by side
HVB = 16  # vector block: the tail's span is rounded up to it
# HFLAG: steps of the current block whose event conditions fired;
# HCX .. HCK: the state at the block's start, from which a flagged lane is replayed
(HX, HV, HW, HSTEPS, HD, HQ, HLIM, HFLAG, HTRAJ, HMU, HT0, HSM, HXM, HPATH, HNREV, HE0, HELIM,
 HVLIM2, HCASC, HPC, HPS, HGG, HK, HCX, HCV, HCW, HCK, HQH, HDS, HAH) = range(30)
HNF = 30
#: False: the kernel for the scene.  True (a diagnostic variant, built with
#: build_hand_general): the same kernel with three of rampwork's general
#: features added, to see what the gap is made of: the ramp parameters and g
#: loaded per lane (HPC, HPS, HGG) rather than held as constants, the
#: curvature integral accumulated every step (HK), and the step's friction
#: work checked for sign (dw >= 0)
GENERAL = False
# params array
PC, PS, PH, PG, PXLO, PXHI, PDT, PTMAX, PFMIN, PFMAX = range(10)
EXIT_LO, EXIT_HI, REVERSAL, TIMEOUT, NONE = range(5)
_ST_STUCK, _ST_EXITED, _ST_TIMEOUT, _ST_DIVERGED = 1, 2, 4, 5


def _hand_jit(**options):
    return numba.njit(nogil=True, error_model="numpy", fastmath=False, cache=True, **options)


# scalar helpers take the lane array without reference counting (numba's
# refcount atomics per call cost more than the event arithmetic)
_scalar = _hand_jit(_nrt=False)


@_scalar
def _h_rest(fp, mu, g):
    """Rest rule: 0 (stays) if |f'| <= mu, else -sign(f'), unless the departing
    acceleration rounds to the wrong sign."""
    if abs(fp) <= mu:
        return 0.0
    d = -1.0 if fp > 0.0 else 1.0
    if (-g * ((fp + d * mu) / fma(fp, fp, 1.0))) * d <= 0.0:
        return 0.0
    return d


@_scalar
def _h_empty(ln, i):
    ln[HTRAJ * HL + i] = -1.0
    ln[HD * HL + i] = 0.0
    ln[HX * HL + i] = 0.0
    ln[HV * HL + i] = 0.0


@_scalar
def _h_rebase(ln, i, t_now, dt, t_max):
    x = ln[HX * HL + i]
    ln[HPATH * HL + i] += ln[HD * HL + i] * (x - ln[HXM * HL + i])
    ln[HXM * HL + i] = x
    ln[HT0 * HL + i] = t_now
    ln[HSM * HL + i] = ln[HSTEPS * HL + i]
    ln[HLIM * HL + i] = ln[HSTEPS * HL + i] + max(math.floor((t_max - t_now) / dt), 0.0)


@_scalar
def _h_finish(ln, i, status, outputs, pr):
    j = np.int64(ln[HTRAJ * HL + i])
    c, s, g = pr[PC], pr[PS], pr[PG]
    x = ln[HX * HL + i]
    v = ln[HV * HL + i]
    fp = fma(c, x, s)
    e_end = g * (pr[PH] + x * (s + 0.5 * c * x)) + 0.5 * v * v * (1.0 + fp * fp)
    if not e_end <= ln[HELIM * HL + i]:
        status = _ST_DIVERGED
    outputs[K.OUT_STATUS, j] = status
    outputs[K.OUT_T, j] = ln[HT0 * HL + i]
    outputs[K.OUT_X, j] = x
    outputs[K.OUT_V, j] = v
    outputs[K.OUT_WORK, j] = ln[HW * HL + i]
    outputs[K.OUT_ENERGY_LOSS, j] = ln[HE0 * HL + i] - e_end
    outputs[K.OUT_PATH, j] = ln[HPATH * HL + i] + ln[HD * HL + i] * (x - ln[HXM * HL + i])
    if GENERAL:
        path = outputs[K.OUT_PATH, j]
        outputs[K.OUT_CONVEXITY, j] = ln[HK * HL + i] / path if path > 0.0 else c
    else:
        outputs[K.OUT_CONVEXITY, j] = c  # f'' is constant: its mean over the path is c
    outputs[K.OUT_NREV, j] = ln[HNREV * HL + i]
    outputs[K.OUT_XLIFT, j] = np.nan
    outputs[K.OUT_XLIFT_PAPER, j] = np.nan
    outputs[K.OUT_STEPS, j] = ln[HSTEPS * HL + i]
    outputs[K.OUT_NREJ, j] = 0.0
    outputs[K.OUT_WORK_ERROR, j] = 0.0
    _h_empty(ln, i)


@_scalar
def _h_load(ln, i, j, inputs, outputs, pr):
    """Start trajectory j in lane i; False if it finished at t = 0."""
    c, s, g = pr[PC], pr[PS], pr[PG]
    x = inputs[K.IN_X0, j]
    v = inputs[K.IN_V0, j]
    mu = inputs[K.IN_MUK, j]
    fp = fma(c, x, s)
    f = pr[PH] + x * (s + 0.5 * c * x)
    ln[HTRAJ * HL + i] = j
    ln[HX * HL + i] = x
    ln[HV * HL + i] = v
    ln[HMU * HL + i] = mu
    ln[HW * HL + i] = 0.0
    ln[HPATH * HL + i] = 0.0
    ln[HSTEPS * HL + i] = 0.0
    ln[HNREV * HL + i] = 0.0
    ln[HCASC * HL + i] = 0.0
    ln[HD * HL + i] = 0.0
    if GENERAL:
        ln[HPC * HL + i] = c
        ln[HPS * HL + i] = s
        ln[HGG * HL + i] = g
        ln[HK * HL + i] = 0.0
    _h_rebase(ln, i, 0.0, pr[PDT], pr[PTMAX])
    kinetic = 0.5 * v * v * (1.0 + fp * fp)
    ln[HE0 * HL + i] = g * f + kinetic
    scale = kinetic + g * (max(f, pr[PFMAX]) - min(f, pr[PFMIN]))
    ln[HVLIM2 * HL + i] = 200.0 * scale + 1e-12
    ln[HELIM * HL + i] = ln[HE0 * HL + i] + 0.5 * scale + 1e-12
    if v == 0.0:
        d = _h_rest(fp, mu, g)
        if d == 0.0:
            _h_finish(ln, i, _ST_STUCK, outputs, pr)
            return False
    else:
        d = 1.0 if v > 0.0 else -1.0
    if (x >= pr[PXHI] and d > 0.0) or (x <= pr[PXLO] and d < 0.0):
        _h_finish(ln, i, _ST_EXITED, outputs, pr)
        return False
    _h_set_mode(ln, i, d, pr)
    return True


@_scalar
def _h_set_mode(ln, i, d, pr):
    """Direction d and what the vector loop reads of it: q, h q, d's sign bit
    and the domain end ahead (so it tests d v > 0 with a bit flip, multiplies
    once fewer for the work and compares once fewer for the exits)."""
    ln[HD * HL + i] = d
    ln[HQ * HL + i] = d * ln[HMU * HL + i]
    ln[HQH * HL + i] = pr[PDT] * ln[HQ * HL + i]
    ln[HDS * HL + i] = -0.0 if d < 0.0 else 0.0
    ln[HAH * HL + i] = pr[PXHI] if d > 0.0 else pr[PXLO]


@_scalar
def _h_step(x, v, d, q, qh, ds, ahead, c, s, g, h):
    """One Euler step from (x, v) and whether it is clean (no event condition
    fired): (x1, v1, dw, dk, clean).  The vector loop and the scalar replay
    both call it, so they round alike.  NaN fails every comparison: a
    non-finite step is not clean."""
    fp = fma(c, x, s)
    n = fma(v * v, c, g)
    a = -n * ((fp + q) / fma(fp, fp, 1.0))
    x1 = fma(h, v, x)
    v1 = fma(h, a, v)
    dw = qh * n * v
    # d v1 > 0, and x1 short of the end ahead (an Euler step moves x in
    # direction d): d (ahead - x1) > 0
    clean = (flip_sign(v1, ds) > 0.0) & (flip_sign(ahead - x1, ds) > 0.0)
    dk = 0.0
    if GENERAL:
        clean = clean & (dw >= 0.0)
        dk = h * c * d * v
    return x1, v1, dw, dk, clean


@_scalar
def _h_lane(ln, i, c, s, g, h):
    """HUNROLL Euler steps on lane i, always taken (plain stores); a step that
    is not clean adds 1 to the lane's flag.  An empty lane (D = 0) is never
    clean; the scan ignores it."""
    x = ln[HX * HL + i]
    v = ln[HV * HL + i]
    w = ln[HW * HL + i]
    d = ln[HD * HL + i]
    q = ln[HQ * HL + i]
    qh = ln[HQH * HL + i]
    ds = ln[HDS * HL + i]
    ahead = ln[HAH * HL + i]
    flag = ln[HFLAG * HL + i]
    if GENERAL:
        c = ln[HPC * HL + i]
        s = ln[HPS * HL + i]
        g = ln[HGG * HL + i]
        kk = ln[HK * HL + i]
    for _ in range(HUNROLL):
        x, v, dw, dk, clean = _h_step(x, v, d, q, qh, ds, ahead, c, s, g, h)
        flag += 0.0 if clean else 1.0
        w += dw
        if GENERAL:
            kk += dk
    if GENERAL:
        ln[HK * HL + i] = kk
    ln[HX * HL + i] = x
    ln[HV * HL + i] = v
    ln[HW * HL + i] = w
    ln[HFLAG * HL + i] = flag


@_scalar
def _h_checkpoint(ln, n_active):
    """At a block's start: save what the vector loop changes, clear the flags
    (vectorised)."""
    for i in range(n_active):
        ln[HCX * HL + i] = ln[HX * HL + i]
        ln[HCV * HL + i] = ln[HV * HL + i]
        ln[HCW * HL + i] = ln[HW * HL + i]
        if GENERAL:
            ln[HCK * HL + i] = ln[HK * HL + i]
        ln[HFLAG * HL + i] = 0.0


@_scalar
def _h_replay(ln, i, pr):
    """Lane i's block again, in scalar from its checkpoint: commits clean
    steps while the step count is below the t_max limit, up to HSUB.  Returns
    the steps taken; fewer than HSUB leaves the lane at the start of the step
    that raised the event, for _h_resolve."""
    c, s, g = pr[PC], pr[PS], pr[PG]
    if GENERAL:  # the values the vector loop used
        c = ln[HPC * HL + i]
        s = ln[HPS * HL + i]
        g = ln[HGG * HL + i]
        kk = ln[HCK * HL + i]
    h = pr[PDT]
    x = ln[HCX * HL + i]
    v = ln[HCV * HL + i]
    w = ln[HCW * HL + i]
    d = ln[HD * HL + i]
    q = ln[HQ * HL + i]
    qh = ln[HQH * HL + i]
    ds = ln[HDS * HL + i]
    ahead = ln[HAH * HL + i]
    steps = ln[HSTEPS * HL + i]
    limit = ln[HLIM * HL + i]
    taken = 0
    while taken < HSUB and steps < limit:
        x1, v1, dw, dk, clean = _h_step(x, v, d, q, qh, ds, ahead, c, s, g, h)
        if not clean:
            break
        x = x1
        v = v1
        w += dw
        if GENERAL:
            kk += dk
        steps += 1.0
        taken += 1
    if GENERAL:
        ln[HK * HL + i] = kk
    ln[HX * HL + i] = x
    ln[HV * HL + i] = v
    ln[HW * HL + i] = w
    ln[HSTEPS * HL + i] = steps
    return taken


@_scalar
def _h_advance(ln, n_active, c, s, g, h):
    """HSUB steps on lanes 0 .. n_active-1; a full block runs its two halves
    side by side (two independent division chains)."""
    if HCHAINS == 2 and n_active > HL // 2:
        for _ in range(HSUB // HUNROLL):
            for i in range(HL // 2):
                _h_lane(ln, i, c, s, g, h)
                _h_lane(ln, i + HL // 2, c, s, g, h)
    else:
        for _ in range(HSUB // HUNROLL):
            for i in range(n_active):
                _h_lane(ln, i, c, s, g, h)


@_scalar
def _h_resolve(ln, i, outputs, pr):
    """The step of lane i that raised an event: every event solved inside the
    step in closed form, the earliest applied.  True if the trajectory goes on."""
    c, s, g, h, t_max = pr[PC], pr[PS], pr[PG], pr[PDT], pr[PTMAX]
    x_lo, x_hi = pr[PXLO], pr[PXHI]
    x = ln[HX * HL + i]
    v = ln[HV * HL + i]
    d = ln[HD * HL + i]
    q = ln[HQ * HL + i]
    t_now = ln[HT0 * HL + i] + (ln[HSTEPS * HL + i] - ln[HSM * HL + i]) * h
    ln[HCASC * HL + i] += 1.0
    fp = fma(c, x, s)
    n = fma(v * v, c, g)
    a = -n * ((fp + q) / fma(fp, fp, 1.0))
    x1 = fma(h, v, x)
    v1 = fma(h, a, v)
    if (ln[HCASC * HL + i] > 100.0 or not (math.isfinite(x1) and math.isfinite(v1))
            or v1 * v1 > ln[HVLIM2 * HL + i]):
        _h_rebase(ln, i, t_now, h, t_max)
        _h_finish(ln, i, _ST_DIVERGED, outputs, pr)
        return False
    kind = NONE
    best = h
    if x1 <= x_lo and not (x1 == x_lo and d > 0.0):
        kind = EXIT_LO
        best = min((x_lo - x) / v, h)
    if x1 >= x_hi and not (x1 == x_hi and d < 0.0):
        h_hi = min((x_hi - x) / v, h)
        if kind == NONE or h_hi < best:
            kind = EXIT_HI
            best = h_hi
    if d * v1 <= 0.0:
        h_rev = min(-v / a, h)
        if kind == NONE or h_rev < best:
            kind = REVERSAL
            best = h_rev
    best = max(best, 0.0)
    h_time = t_max - t_now
    if h_time < best or (kind == NONE and h_time <= h):
        kind = TIMEOUT
        best = max(h_time, 0.0)
    if kind == NONE:  # frozen by the step limit with a rounding's worth of time left
        ln[HW * HL + i] += h * q * n * v
        if GENERAL:
            ln[HK * HL + i] += h * c * d * v
        ln[HX * HL + i] = x1
        ln[HV * HL + i] = v1
        ln[HSTEPS * HL + i] += 1.0
        ln[HCASC * HL + i] = 0.0
        _h_rebase(ln, i, t_now + h, h, t_max)
        return True
    if best > 0.0:  # the partial step to the event
        ln[HW * HL + i] += best * q * n * v
        if GENERAL:
            ln[HK * HL + i] += best * c * d * v
        x = fma(best, v, x)
        ln[HV * HL + i] = fma(best, a, v)
        ln[HSTEPS * HL + i] += 1.0
    t_event = t_now + best
    if kind == TIMEOUT:
        t_event = t_max
    elif kind == EXIT_HI:
        x = x_hi
    elif kind == EXIT_LO:
        x = x_lo
    ln[HX * HL + i] = x
    _h_rebase(ln, i, t_event, h, t_max)
    if kind == TIMEOUT:
        _h_finish(ln, i, _ST_TIMEOUT, outputs, pr)
        return False
    if kind != REVERSAL:
        _h_finish(ln, i, _ST_EXITED, outputs, pr)
        return False
    ln[HV * HL + i] = 0.0
    direction = _h_rest(fma(c, x, s), ln[HMU * HL + i], g)
    if direction == 0.0:
        _h_finish(ln, i, _ST_STUCK, outputs, pr)
        return False
    if direction != d:
        ln[HNREV * HL + i] += 1.0
    _h_set_mode(ln, i, direction, pr)
    return True


@_scalar
def _h_scan(ln, outputs, pr, n_active):
    """After HSUB vector steps: book the steps of the clean lanes, replay and
    resolve the pending ones (flagged, or the block would pass the t_max step
    limit) and stop lanes past the speed bound; returns how many lanes were
    freed."""
    attention = 0
    for i in range(n_active):  # vectorised first pass: usually nothing else to do
        steps = ln[HSTEPS * HL + i]
        pending = (ln[HFLAG * HL + i] > 0.0) | (steps + HSUB > ln[HLIM * HL + i])
        # plain stores of selected values (no masked stores)
        ln[HSTEPS * HL + i] = steps + (0.0 if pending else HSUB)
        ln[HFLAG * HL + i] = 1.0 if pending else 0.0
        v = ln[HV * HL + i]
        needs = (ln[HTRAJ * HL + i] >= 0.0) & (pending | (v * v > ln[HVLIM2 * HL + i]))
        attention += 1 if needs else 0
    if attention == 0:
        return 0
    freed = 0
    for i in range(n_active):
        if ln[HTRAJ * HL + i] < 0.0:
            continue
        advanced = _h_replay(ln, i, pr) if ln[HFLAG * HL + i] > 0.0 else HSUB
        if advanced > 0:
            ln[HCASC * HL + i] = 0.0
        if advanced == HSUB:
            v = ln[HV * HL + i]
            if v * v <= ln[HVLIM2 * HL + i]:
                continue
            t_now = ln[HT0 * HL + i] + (ln[HSTEPS * HL + i] - ln[HSM * HL + i]) * pr[PDT]
            _h_rebase(ln, i, t_now, pr[PDT], pr[PTMAX])
            _h_finish(ln, i, _ST_DIVERGED, outputs, pr)
            freed += 1
        elif not _h_resolve(ln, i, outputs, pr):
            freed += 1
    return freed


@_scalar
def _h_compact(ln):
    running = 0
    for i in range(HL):
        if ln[HTRAJ * HL + i] < 0.0:
            continue
        if running != i:
            for field in range(HNF):
                ln[field * HL + running] = ln[field * HL + i]
            _h_empty(ln, i)
        running += 1
    return 0 if running == 0 else min(HL, (running + HVB - 1) // HVB * HVB)


@_scalar
def _h_fill(ln, i, next_j, stop, inputs, outputs, pr):
    while next_j < stop:
        j = next_j
        next_j += 1
        if _h_load(ln, i, j, inputs, outputs, pr):
            break
    return next_j


@_hand_jit()
def _h_tile(start, stop, inputs, outputs, pr):
    ln = np.zeros(HNF * HL)
    for i in range(HL):
        _h_empty(ln, i)
    c, s, g, h = pr[PC], pr[PS], pr[PG], pr[PDT]
    next_j = start
    for i in range(HL):
        next_j = _h_fill(ln, i, next_j, stop, inputs, outputs, pr)
    n_active = HL if next_j < stop else _h_compact(ln)
    while n_active > 0:
        _h_checkpoint(ln, n_active)
        _h_advance(ln, n_active, c, s, g, h)
        if _h_scan(ln, outputs, pr, n_active) == 0:
            continue
        if next_j < stop:
            for i in range(HL):
                if ln[HTRAJ * HL + i] < 0.0:
                    next_j = _h_fill(ln, i, next_j, stop, inputs, outputs, pr)
        if next_j >= stop:
            n_active = _h_compact(ln)


@_hand_jit(parallel=True)
def hand_batch(inputs, outputs, pr, tile_size):
    """The hand-written kernel: tiles of trajectories spread over threads."""
    n = inputs.shape[1]
    n_tiles = (n + tile_size - 1) // tile_size
    for tile in numba.prange(n_tiles):
        start = tile * tile_size
        _h_tile(start, min(n, start + tile_size), inputs, outputs, pr)


def build_hand_general():
    """The diagnostic variant (GENERAL = True): the same templates compiled
    again with GENERAL bound to True (rampwork's ``specialise``: a copy of
    each function with some globals replaced by constants)."""
    from rampwork.core.jit import specialise

    constants = {"GENERAL": True}
    for name in ("_h_rest", "_h_empty", "_h_rebase", "_h_finish", "_h_load", "_h_step", "_h_lane",
                 "_h_checkpoint", "_h_replay", "_h_advance", "_h_resolve", "_h_scan", "_h_compact",
                 "_h_fill"):  # callees before callers: each copy binds the ones already made
        constants[name] = specialise(globals()[name].py_func, f"hand{name}_general", constants, _nrt=False)
    constants["_h_tile"] = specialise(_h_tile.py_func, "hand_h_tile_general", constants)
    return specialise(hand_batch.py_func, "hand_batch_general", constants, parallel=True)


def hand_params(scene):
    ramp = scene.ramp.param_dict()
    c, s, height = ramp["curvature"], ramp["slope"], ramp["height"]
    assert c > 0.0, "the hand kernel is for a convex quadratic ramp"
    lo, hi = scene.ramp.domain
    xs = [lo, hi] + ([-s / c] if lo < -s / c < hi else [])
    heights = [height + x * (s + 0.5 * c * x) for x in xs]
    pr = np.zeros(10)
    pr[[PC, PS, PH, PG, PXLO, PXHI, PDT, PTMAX, PFMIN, PFMAX]] = (
        c, s, height, scene.g, lo, hi, scene.integrator.dt, scene.t_max, min(heights), max(heights))
    return pr


def agreement_of(a, b):
    return {
        "status_equal": bool(np.array_equal(a[K.OUT_STATUS], b[K.OUT_STATUS])),
        "n_reversals_equal": bool(np.array_equal(a[K.OUT_NREV], b[K.OUT_NREV])),
        "steps_equal": bool(np.array_equal(a[K.OUT_STEPS], b[K.OUT_STEPS])),
        **{f"max_abs_{name}_difference": max_difference(a, b, row) for name, row in
           (("x_end", K.OUT_X), ("v_end", K.OUT_V), ("t_end", K.OUT_T), ("W_friction", K.OUT_WORK),
            ("W_energy", K.OUT_ENERGY_LOSS), ("path", K.OUT_PATH), ("convexity_mean", K.OUT_CONVEXITY))},
    }


def check_agreement(agreement, what):
    assert agreement["status_equal"] and agreement["n_reversals_equal"], (what, agreement)
    assert agreement["steps_equal"], f"{what}: step counts differ, steps/s would not compare like with like"
    for name in ("x_end", "v_end", "t_end", "W_friction", "W_energy", "path"):
        assert agreement[f"max_abs_{name}_difference"] <= 1e-9, (what, name, agreement)


def hand_variant(label, batch, scene, inputs):
    v = variant(label, None, scene, inputs, None)
    v["hand"] = batch
    v["params"] = hand_params(scene)
    started = time.perf_counter()
    batch(inputs[:, :1].copy(), np.zeros((K.N_OUTPUTS, 1)), v["params"], 1)
    v["compile"] = {"seconds": time.perf_counter() - started, "source": cache_source(batch)}
    return v


def hand_comparison(args, log):
    scene = quadratic_scene("euler")
    sweep = quadratic_sweep(args.n_hand)
    plan, run_batch, info = runner_kernel(scene, sweep)
    inputs = runner.chunk_inputs(plan, 0, plan.size)
    assert np.array_equal(inputs[K.IN_MUK], inputs[K.IN_MUS]) and np.all(inputs[K.IN_G] == scene.g)
    ours = variant("rampwork (runner's kernel)", run_batch, scene, inputs, info)
    hand = hand_variant("hand-written", hand_batch, scene, inputs)
    general = hand_variant("hand-written + per-lane parameters, curvature integral, dw check",
                           build_hand_general(), scene, inputs)
    log(f"  rampwork kernel: {'; '.join(plan.effects)}; hand kernel compile "
        f"{hand['compile']['seconds']:.1f} s ({hand['compile']['source']}), diagnostic variant "
        f"{general['compile']['seconds']:.1f} s ({general['compile']['source']})")
    threads = sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)})
    timings = side_by_side([ours, hand, general], threads, args.hand_repeat, args.target)
    agreement = agreement_of(ours["out"], hand["out"])
    log("  agreement: " + ", ".join(f"{k} {v}" for k, v in agreement.items()))
    check_agreement(agreement, "hand-written")
    agreement_general = agreement_of(ours["out"], general["out"])
    check_agreement(agreement_general, "hand-written, general variant")
    per_threads = {}
    for t in threads:
        r, h, hg = timings[(0, t)], timings[(1, t)], timings[(2, t)]
        per_threads[str(t)] = {"rampwork": r, "hand": h, "hand_general": hg,
                               "ratio_rampwork_over_hand": r["wall_best_s"] / h["wall_best_s"],
                               "ratio_median": paired_ratio(h, r),
                               "ratio_rampwork_over_hand_general": r["wall_best_s"] / hg["wall_best_s"],
                               "ratio_hand_general_over_hand": hg["wall_best_s"] / h["wall_best_s"]}
        log(f"  {t} thread(s): rampwork {r['steps_per_s']:.3e} steps/s, hand {h['steps_per_s']:.3e} steps/s, "
            f"hand + general {hg['steps_per_s']:.3e}; rampwork/hand time "
            f"{per_threads[str(t)]['ratio_rampwork_over_hand']:.3f} (median "
            f"{per_threads[str(t)]['ratio_median']:.3f}), rampwork/(hand + general) "
            f"{per_threads[str(t)]['ratio_rampwork_over_hand_general']:.3f}")
    # where the gap comes from: short trajectories, each one event (stop, stuck)
    short_sweep = rw.Sweep.grid(**cube_axes(27_000, x0=(-0.2, 0.2), v0=(0.05, 0.5), mu=(0.3, 0.5)))
    short_plan = runner.plan_run(scene, short_sweep)
    short_inputs = runner.chunk_inputs(short_plan, 0, short_plan.size)
    short = [variant("rampwork", run_batch, scene, short_inputs, info),
             hand_variant("hand-written", hand_batch, scene, short_inputs)]
    short_timings = side_by_side(short, [1], args.hand_repeat, args.target)
    check_agreement(agreement_of(short[0]["out"], short[1]["out"]), "hand-written, short trajectories")
    r, h = short_timings[(0, 1)], short_timings[(1, 1)]
    short_result = {"sweep": "x0 in [-0.2, 0.2] m, v0 in [0.05, 0.5] m/s, mu in [0.3, 0.5]: slides, stops, stuck",
                    "trajectories": short_plan.size, "threads": 1,
                    "steps_per_trajectory": r["trajectory_steps"] / r["trajectories"],
                    "status": status_fractions(short[0]["out"]), "rampwork": r, "hand": h,
                    "ratio_rampwork_over_hand": r["wall_best_s"] / h["wall_best_s"],
                    "extra_ns_per_trajectory": r["ns_per_trajectory"] - h["ns_per_trajectory"]}
    log(f"  short trajectories ({short_result['steps_per_trajectory']:.0f} steps, one event each), 1 thread: "
        f"rampwork {r['ns_per_trajectory']:.0f} ns/trajectory, hand {h['ns_per_trajectory']:.0f} ns/trajectory "
        f"(rampwork/hand {short_result['ratio_rampwork_over_hand']:.2f})")
    grid_extra = per_threads["1"]["rampwork"]["ns_per_trajectory"] - per_threads["1"]["hand"]["ns_per_trajectory"]
    return {"scene": "euler, quadratic curvature 1/m on (-1, 1), one-sided, no lift-off check, "
                     "no diagnostics, mu_s = mu_k, dt 1e-3 s, t_max 60 s",
            "short_trajectories": short_result, "grid_extra_ns_per_trajectory_1thread": grid_extra,
            "n_reversals_per_trajectory": float(ours["out"][K.OUT_NREV].mean()),
            "rampwork_effects": list(plan.effects), "trajectories": plan.size,
            "steps_per_trajectory": float(ours["out"][K.OUT_STEPS].mean()),
            "status": status_fractions(ours["out"]),
            "agreement": agreement, "agreement_general": agreement_general, "threads": per_threads,
            "compile_rampwork": ours["compile"], "compile_hand": hand["compile"],
            "compile_hand_general": general["compile"]}


# ------------------------------------------------------------------------------
# 4. cold and warm compile times in fresh processes
# ------------------------------------------------------------------------------
PROBE = textwrap.dedent("""
    import json, sys, time
    started = time.perf_counter()
    import rampwork as rw
    from rampwork import runner
    imported = time.perf_counter() - started
    name = sys.argv[1]
    dome = rw.Ramp.create("circular_dome", radius=1.0, domain=(-0.9, 0.9))
    scenes = {
        "euler_quadratic": rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0)),
                                    x0=0.5, friction=rw.Friction(0.1), integrator=rw.Integrator("euler", 1e-3)),
        "rk4_dome": rw.Scene(ramp=dome, x0=0.1, friction=rw.Friction(0.1), integrator=rw.Integrator("rk4", 1e-3)),
        "dopri5_dome": rw.Scene(ramp=dome, x0=0.1, friction=rw.Friction(0.1),
                                integrator=rw.Integrator("dopri5", rtol=1e-8)),
        "closed_form_straight": rw.Scene(ramp=rw.Ramp.create("straight", slope=0.3, domain=(-1.0, 1.0)),
                                         x0=0.0, v0=1.0, friction=rw.Friction(0.2)),
    }
    scene = scenes[name]
    ds = rw.simulate(scene)
    run_batch = next(iter(kernels._KERNELS.values()))[0]
    again = rw.simulate(scene)
    print(json.dumps({"compile_time_s": ds.attrs["compile_time_s"], "import_s": imported,
                      "effects": ds.attrs["kernel_effects"],
                      "repeat_compile_time_s": again.attrs["compile_time_s"],
                      "cache_hits": sum(run_batch.stats.cache_hits.values()),
                      "cache_misses": sum(run_batch.stats.cache_misses.values()),
                      "process_s": time.perf_counter() - started}))
""")


def compile_probes(args, log):
    out = {}
    src = str(pathlib.Path(rw.__file__).resolve().parents[1])
    for name in args.probes:
        with tempfile.TemporaryDirectory(prefix="rampwork-numba-cache-") as cache:
            env = {**os.environ, "NUMBA_CACHE_DIR": cache,
                   "PYTHONPATH": src + os.pathsep + os.environ.get("PYTHONPATH", "")}
            runs = {}
            for which in ("cold", "warm"):
                started = time.perf_counter()
                done = subprocess.run([sys.executable, "-c", PROBE, name], env=env, capture_output=True,
                                      text=True, timeout=900)
                wall = time.perf_counter() - started
                if done.returncode != 0:
                    raise RuntimeError(f"compile probe {name} ({which}) failed:\n{done.stderr[-3000:]}")
                result = json.loads(done.stdout.strip().splitlines()[-1])
                result["process_wall_s"] = wall
                runs[which] = result
            out[name] = runs
            log(f"  {name}: cold {runs['cold']['compile_time_s']:.1f} s (process {runs['cold']['process_wall_s']:.1f} s, "
                f"misses {runs['cold']['cache_misses']}), warm {runs['warm']['compile_time_s']:.2f} s "
                f"(process {runs['warm']['process_wall_s']:.1f} s, hits {runs['warm']['cache_hits']}), "
                f"repeat in-process {runs['warm']['repeat_compile_time_s']:.2g} s")
    return out


# ------------------------------------------------------------------------------
# tables and figure
# ------------------------------------------------------------------------------
def _ns(t):
    return f"{t:.3f}" if t is not None else "-"


def build_tables(res):
    parts = []
    rows = []
    for r in res["effects"]:
        same = ("yes (asserted)" if r["identity_asserted"] else "yes") if r["identical"] else (
            "no: different physics" if r["physics_differs"] else "no")
        rows.append([r["effect"], r["method"], _ns(r["off_timing"]["ns_per_step"]),
                     _ns(r["on_timing"]["ns_per_step"]), f"{r['ratio_on_off']:.3f}",
                     f"{r['ratio_on_off_paired_median']:.3f}",
                     f"{r['steps_per_trajectory_off']:.0f} / {r['steps_per_trajectory_on']:.0f}",
                     same, r["runner_pick"]])
    parts.append(f"### Effects: time per trajectory-step, off vs on ({res['config']['threads']} thread(s), "
                 f"best of {res['config']['repeat']} interleaved samples; paired: median over rounds of "
                 f"on/off time per step in the same round)\n\n"
                 + C.markdown_table(["effect", "method", "off ns/step", "on ns/step", "on/off (best)",
                                     "on/off (median of paired)",
                                     "steps/traj off / on", "identical results", "runner picks"], rows))
    notes = [f"- {n}" for n in res.get("skipped", [])]
    if notes:
        parts.append("\n".join(notes))
    cf = res.get("closed_form")
    if cf:
        rows = [[r["solver"], f"{r['timing']['ns_per_trajectory'] / 1e3:.3f}", f"{r['speed_up_of_closed_form']:.1f}x",
                 f"{r['steps_per_trajectory']:.0f}", f"{r['max_abs_x_end_difference']:.2e}",
                 f"{r['max_abs_W_friction_difference']:.2e}", str(r["outcome_mismatches"])] for r in cf["rows"]]
        parts.append(f"### Straight ramp: closed form vs stepping ({cf['sweep_size']:,} trajectories, "
                     f"{cf['threads']} thread(s))\n\n"
                     + C.markdown_table(["solver", "us/trajectory", "time / closed form", "steps/traj",
                                         "max abs x_end diff (m)", "max abs W_friction diff (J/kg)",
                                         "outcome mismatches"], rows)
                     + "\n\nDifferences from the closed form over trajectories with the same outcome "
                       "(status, and for an exit the same end); an outcome mismatch is a knife-edge start "
                       "(e.g. a launch that just reaches the top end in one solver and stops short in the other).")
    hand = res.get("hand")
    if hand:
        rows = []
        for t, d in hand["threads"].items():
            rows.append([t, f"{d['rampwork']['steps_per_s']:.3e}", f"{d['hand']['steps_per_s']:.3e}",
                         f"{d['rampwork']['ns_per_step']:.3f}", f"{d['hand']['ns_per_step']:.3f}",
                         f"{d['ratio_rampwork_over_hand']:.3f}", f"{d['ratio_median']:.3f}",
                         f"{d['hand_general']['ns_per_step']:.3f}",
                         f"{d['ratio_rampwork_over_hand_general']:.3f}"])
        ag = hand["agreement"]
        parts.append(f"### Minimal scene vs a kernel written by hand ({hand['trajectories']:,} trajectories, "
                     f"{hand['steps_per_trajectory']:.0f} steps each on average)\n\n"
                     + C.markdown_table(["threads", "rampwork steps/s", "hand steps/s", "rampwork ns/step",
                                         "hand ns/step", "rampwork / hand time (best)", "(median of paired)",
                                         "diagnostic: hand + general ns/step", "rampwork / (hand + general)"],
                                        rows)
                     + f"\n\nAgreement: statuses equal {ag['status_equal']}, reversals equal "
                       f"{ag['n_reversals_equal']}, steps equal {ag['steps_equal']}; max |diff| x_end "
                       f"{ag['max_abs_x_end_difference']:.1e} m, v_end {ag['max_abs_v_end_difference']:.1e} m/s, "
                       f"t_end {ag['max_abs_t_end_difference']:.1e} s, W_friction "
                       f"{ag['max_abs_W_friction_difference']:.1e} J/kg. The diagnostic variant "
                       "\"hand + general\" is the same hand kernel with three of rampwork's general "
                       "features added (ramp parameters and g loaded per lane, the curvature integral "
                       "accumulated every step, the sign check on each step's friction work); "
                       "it agrees with rampwork as closely.\n\n"
                     + (lambda sh: f"Where the gap comes from: on {sh['trajectories']:,} short trajectories "
                        f"({sh['steps_per_trajectory']:.0f} steps each, one event: slide, stop, stuck; 1 thread) "
                        f"rampwork takes {sh['rampwork']['ns_per_trajectory']:.0f} ns per trajectory, the hand "
                        f"kernel {sh['hand']['ns_per_trajectory']:.0f} ns ({sh['ratio_rampwork_over_hand']:.2f}x): "
                        f"{sh['extra_ns_per_trajectory']:.0f} ns more per trajectory, most of it per-trajectory and "
                        f"per-event work rather than steps (loading a lane, locating and applying the event, "
                        f"finishing). On the "
                        f"grid (about "
                        f"{hand['n_reversals_per_trajectory']:.1f} reversals per trajectory besides the final "
                        f"event) rampwork takes {hand['grid_extra_ns_per_trajectory_1thread']:.0f} ns more per "
                        f"trajectory on 1 thread.")(hand["short_trajectories"])
                     + "\n\n" + hand["verdict"])
    probes = res.get("compile")
    if probes:
        rows = []
        for name, d in probes.items():
            rows.append([name, f"{d['cold']['compile_time_s']:.1f}", f"{d['cold']['process_wall_s']:.1f}",
                         f"{d['warm']['compile_time_s']:.2f}", f"{d['warm']['process_wall_s']:.1f}",
                         f"{d['warm']['repeat_compile_time_s']:.1g}"])
        parts.append("### Compile times (fresh processes, empty then reused NUMBA_CACHE_DIR)\n\n"
                     + C.markdown_table(["scene", "cold compile_time_s", "cold process wall s",
                                         "warm compile_time_s (disk cache)", "warm process wall s",
                                         "repeat in-process s"], rows))
    return "\n\n".join(parts) + "\n"


def draw_figure(res, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    effects = res["effects"]
    fig = plt.figure(figsize=(15, 7.5), layout="constrained")
    grid = fig.add_gridspec(2, 2, width_ratios=[2.2, 1])
    ax = fig.add_subplot(grid[:, 0])
    labels = [f"{r['effect']}\n[{r['method']}]" for r in effects]
    ys = np.arange(len(effects))
    off = [r["off_timing"]["ns_per_step"] for r in effects]
    on = [r["on_timing"]["ns_per_step"] for r in effects]
    ax.barh(ys - 0.2, off, 0.4, label="off", color="C0")
    ax.barh(ys + 0.2, on, 0.4, label="on", color="C1")
    for y, a, b, r in zip(ys, off, on, effects):
        ax.annotate(f"{b / a:.2f}x (paired {r['ratio_on_off_paired_median']:.2f}x)"
                    + ("" if r["identical"] else " *"), (max(a, b), y), xytext=(3, 0),
                    textcoords="offset points", va="center", fontsize=8)
    ax.set_yticks(ys, labels, fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel(f"ns per trajectory-step ({res['config']['threads']} thread(s), best of interleaved repeats)")
    ax.set_title("effect off vs on, same sweep and inputs; on/off best (paired median); "
                 "* results differ: different physics", fontsize=9)
    ax.set_xlim(0, 1.3 * max(off + on))
    ax.legend(fontsize=8)
    ax.grid(axis="x", alpha=0.3)

    ax = fig.add_subplot(grid[0, 1])
    probes = res.get("compile") or {}
    names = list(probes)
    xs = np.arange(len(names))
    cold = [probes[n]["cold"]["compile_time_s"] for n in names]
    warm = [probes[n]["warm"]["compile_time_s"] for n in names]
    ax.bar(xs - 0.2, cold, 0.4, label="cold (empty cache)", color="C3")
    ax.bar(xs + 0.2, warm, 0.4, label="warm (disk cache)", color="C2")
    for x, a, b in zip(xs, cold, warm):
        ax.annotate(f"{a:.1f}", (x - 0.2, a), ha="center", va="bottom", fontsize=8)
        ax.annotate(f"{b:.2f}", (x + 0.2, b), ha="center", va="bottom", fontsize=8)
    ax.set_xticks(xs, [n.replace("_", "\n", 1).replace("_", " ") for n in names], fontsize=7)
    ax.set_ylabel("compile_time_s (s, log)")
    ax.set_yscale("log")
    if cold:
        ax.set_ylim(0.1, 6 * max(cold))
    ax.set_title("compile time, fresh processes\n(in-process repeat: ~0)", fontsize=9)
    ax.legend(fontsize=8, ncol=2, loc="upper left")

    ax = fig.add_subplot(grid[1, 1])
    hand = res.get("hand")
    if hand:
        threads = list(hand["threads"])
        xs = np.arange(len(threads))
        ours = [hand["threads"][t]["rampwork"]["ns_per_step"] for t in threads]
        theirs = [hand["threads"][t]["hand"]["ns_per_step"] for t in threads]
        ax.bar(xs - 0.2, ours, 0.4, label="rampwork (runner's kernel)", color="C0")
        ax.bar(xs + 0.2, theirs, 0.4, label="written by hand for the scene", color="C7")
        for x, t, a in zip(xs, threads, ours):
            ax.annotate(f"x{hand['threads'][t]['ratio_rampwork_over_hand']:.3f}", (x - 0.2, a), ha="center",
                        va="bottom", fontsize=8)
        ax.set_xticks(xs, [f"{t} thread(s)" for t in threads], fontsize=8)
        ax.set_ylabel("ns per trajectory-step (wall)")
        ax.set_title("minimal scene (Euler, convex quadratic)\nrampwork vs written by hand", fontsize=9)
        ax.set_ylim(0, 1.4 * max(ours + theirs))
        ax.legend(fontsize=7, loc="upper center", ncol=2)
    load = res["machine"]["load_average_1_5_15min"] or []
    fig.suptitle(f"rampwork effects benchmark: {res['machine']['cpu_model']}, {res['machine']['usable_cores']} "
                 f"cores, load average {' '.join(f'{x:.2f}' for x in load)} at start, {res['started_utc']}",
                 fontsize=9)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# ------------------------------------------------------------------------------
# main
# ------------------------------------------------------------------------------
def main(argv=None):
    args = parse_args(argv)
    started = time.perf_counter()

    def log(text):
        print(f"[{time.perf_counter() - started:6.1f} s] {text}", flush=True)

    res = {"benchmark": "effects", "started_utc": C.utc_now(), "machine": C.machine_info(),
           "config": {"quick": args.quick, "n": args.n, "n_dome": args.n_dome, "n_straight": args.n_straight,
                      "threads": args.threads, "repeat": args.repeat, "hand_repeat": args.hand_repeat,
                      "target_s": args.target,
                      "methods": list(args.methods), "dt": DT, "t_max": T_MAX, "probes": list(args.probes)},
           "api": {"drag": HAS_DRAG, "friction_flag": HAS_FRICTION_FLAG,
                   "build_kernel_parameters": sorted(BUILD_PARAMETERS)},
           "skipped": []}
    if not HAS_DRAG:
        res["skipped"].append("air drag: rampwork has no rw.Drag yet (rows skipped)")
    if not HAS_FRICTION_FLAG:
        res["skipped"].append("mu = 0 pruning: build_kernel has no 'friction' flag yet (rows skipped)")
    for note in res["skipped"]:
        log("NOTE " + note)

    log("1. effects on/off")
    res["effects"] = effect_rows(args, log)
    log("2. straight ramp: closed form vs stepping")
    res["closed_form"] = closed_form_table(args, log)
    log("3. minimal scene vs hand-written kernel")
    res["hand"] = hand_comparison(args, log)
    worst = max(d["ratio_rampwork_over_hand"] for d in res["hand"]["threads"].values())
    if worst > 1.05:
        verdict = (f"rampwork is MORE than 5 % slower than the hand-written kernel: up to "
                   f"{100 * (worst - 1):.1f} % slower (best-of times; see the table per thread count).")
    elif worst > 1.0:
        verdict = f"rampwork is within 5 % of the hand-written kernel (at most {100 * (worst - 1):.1f} % slower)."
    else:
        verdict = f"rampwork is not slower than the hand-written kernel (ratio at most {worst:.3f})."
    res["hand"]["verdict"] = verdict
    res["hand"]["within_5_percent"] = worst <= 1.05
    log("  " + verdict)
    if args.probes:
        log("4. compile times in fresh processes")
        res["compile"] = compile_probes(args, log)
    res["machine"]["load_average_at_end"] = list(os.getloadavg())
    res["total_wall_s"] = time.perf_counter() - started

    md = build_tables(res)
    print("\n" + md)
    stem = f"effects-{C.timestamp()}" + ("-quick" if args.quick else "")
    paths = [C.save_json(args.out / f"{stem}.json", res), C.save_text(args.out / f"{stem}.md", md)]
    if not args.no_figure:
        figure = args.figure or (args.out / f"{stem}.png" if args.quick else FIGURE)
        try:
            paths.append(draw_figure(res, figure))
        except Exception as error:  # noqa: BLE001 - the numbers matter more than the figure
            print(f"figure not drawn: {error!r}", file=sys.stderr)
    print("saved: " + ", ".join(str(p) for p in paths))
    print(f"total wall time {res['total_wall_s']:.1f} s; load average at end {res['machine']['load_average_at_end']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
