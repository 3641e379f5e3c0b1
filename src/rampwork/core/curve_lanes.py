"""The curve kernel in SIMD lanes (docs/physics.md §5): many trajectories on a
planar curve at once, the same results as one at a time, bit for bit.

Why lanes: one trajectory at a time is bound by the latency of its divisions
and its branches (core/kernel.py's docstring says it for ramps).  Here a tile
of trajectories runs through a block of ``LANES`` lanes whose state is a
structure of arrays (curve_kernel.py's layout: field F of lane i at
``lanes[F * LANES + i]``).  The vector loop (:func:`_vector_step`) takes one
step on every lane with no data-dependent branch, so LLVM turns it into
vector code: the scene's own step (``curve_kernel._try_step``, the
``CURVE_STEPPERS`` entry specialised), the end point ``X`` for the
horizontal path, and the lane's "clean" test: no event condition fired
(direction, ends, contact sign, joint), finite, no vertical tangent crossed
(cos phi keeps its sign, so ``|dX|`` is one difference), not past ``t_max``,
and for an adaptive pair an error norm <= 1 (a rejected clean attempt is
also taken here).  A clean step is committed by selects, with the
arithmetic of the scalar code in the same order; any other step freezes
the lane (FLAG) until the next scalar pass, where ``curve_kernel._iterate``
takes it in full: the event located on the step size, the
rest rule, lift-off, exits, divergence.  Every ``SUBSTEPS`` vector steps a
scalar pass resolves frozen lanes, writes finished trajectories out and
refills their lanes from the tile; once the tile has nothing left to load,
the running lanes move to the front so that its tail steps few empty lanes.

So every trajectory sees the same floating-point operations whichever lane,
tile, block or thread runs it, and the same as with the vector loop off
(``vector=False``: every step through ``_iterate``, the scalar kernel the
tests compare with).  Tiles run over threads (core/threads.py).
"""

from __future__ import annotations

import math

import numpy as np

from . import curve_kernel as ck
from . import curve_trace
from . import status as st
from .control import ERROR_FLOOR
from .curve_kernel import (  # the lane layout, the inputs' and outputs' rows
    B, BRANCH, C, COSNOW, CURV, D, DISP, DPDSNOW, DRAGW, E0, EMPTY, EPREV, FLAG, G, HI, HN,
    I_B, I_C, I_G, I_HI, I_JOINT, I_JOINT2, I_LO, I_M, I_MUK, I_MUS, I_P, I_S0, I_S1, I_S2, I_S3, I_U,
    INROW, JOINT, JOINT2, KAPNOW, KAPPA0, LANES, LO, MUK, MUS, N_FIELDS, NREJ, NREV, NUMIN, O_BAL,
    O_DISP, O_KMEAN, O_NREV, O_NUMIN, O_P, O_PATH, O_PLIFT, O_REJECTED, O_STEPS, O_T, O_U,
    O_W, O_WD, O_WE, O_X, O_XLIFT, O_XPATH, O_Y, O_YLIFT, P, PATH, PATHX, PLIFT, REJB, S0, S1,
    S2, SINNOW, SMALLEST_STEP, SN, STATUS, STEPS, T, TRAJ, U, WORK, XNOW, branch, fresh,
    store_frame)
from .curve_steppers import CURVE_STEPPERS, _dop853_stages, _stage, _stage_from, normal_along_n
from .jit import fma, jit, specialise
from .threads import current_threads, run_items

# bound per scene by build_curve_kernel (compile-time constants)
curve_frame = curve_point = try_step = accepted_factor = rejected_factor = None
rest_rule = contact_sign = None
start_lane = iterate = finish_lane = vector_step = vector_pass = run_tile = None
ADAPTIVE = DRAG = False
JOINTS = 0  # the curve's joints (0 to 2)
ONE_SIDED = True
VECTOR = True  # False: every step through curve_kernel._iterate (the scalar reference)
#: vector steps between scalar passes: a lane whose step holds an event waits
#: for the next pass, so fewer, costlier steps want more frequent passes.
#: Fixed steps: 4, not 8: with 8 (or 6, 16) the compiled pass ran 2.5-3.7x
#: slower per step (Euler, RK4; benchmarks/README.md, i20-speed-6), while
#: 1 to 4 are alike, so the pass itself costs little
SUBSTEPS = 4
SUBSTEPS_ADAPTIVE = 4
#: lanes per vector loop: a constant trip count, so that LLVM proves the
#: fields' accesses disjoint (fields lie LANES apart) and vectorises
BLOCK = 16


def _start_lane(lanes, i, inputs, j, shared, h, side):
    """Load trajectory j (column j of ``inputs``) into lane i: its state at
    t = 0 and, at rest, the rest rule's verdict (STATUS stays NOT_RUN while
    it moves).  ``h``: the step (an adaptive pair's first)."""
    p = inputs[I_P, j]
    u = inputs[I_U, j]
    mu_k = inputs[I_MUK, j]
    mu_s = inputs[I_MUS, j]
    g = inputs[I_G, j]
    s0 = inputs[I_S0, j]
    s1 = inputs[I_S1, j]
    s2 = inputs[I_S2, j]
    s3 = inputs[I_S3, j]
    p_lo = inputs[I_LO, j]
    p_hi = inputs[I_HI, j]
    x_now, y0 = curve_point(p, s0, s1, s2, s3, shared)
    status = st.NOT_RUN
    p_lift = math.nan
    frame0 = curve_frame(p, s0, s1, s2, s3, shared)
    _, cos0, kappa0, _ = frame0
    nu = normal_along_n(u, cos0, kappa0, g)
    d = 0.0
    if u == 0.0:
        d, status = rest_rule(p, mu_k, mu_s, g, side, s0, s1, s2, s3, shared)
    else:
        d = 1.0 if u > 0.0 else -1.0
        if ONE_SIDED and side * nu <= 0.0:
            status = st.LIFTED_OFF
    if status == st.LIFTED_OFF:
        p_lift = p
    if status == st.NOT_RUN and ((d > 0.0 and p >= p_hi) or (d < 0.0 and p <= p_lo)):
        status = st.EXITED
    for field in (WORK, CURV, DISP, PATH, PATHX, DRAGW, T, STEPS, NREJ, INROW, NREV, REJB, FLAG):
        lanes[field * LANES + i] = 0.0
    lanes[P * LANES + i] = p
    lanes[U * LANES + i] = u
    lanes[D * LANES + i] = d
    lanes[SN * LANES + i] = contact_sign(nu, kappa0, side)
    lanes[HN * LANES + i] = h
    lanes[EPREV * LANES + i] = ERROR_FLOOR
    lanes[NUMIN * LANES + i] = side * nu
    lanes[XNOW * LANES + i] = x_now
    store_frame(lanes, i, frame0)
    lanes[PLIFT * LANES + i] = p_lift
    lanes[STATUS * LANES + i] = status
    lanes[TRAJ * LANES + i] = j
    lanes[E0 * LANES + i] = fma(g, y0, 0.5 * u * u)
    lanes[KAPPA0 * LANES + i] = kappa0
    lanes[BRANCH * LANES + i] = s3
    lanes[MUK * LANES + i] = mu_k
    lanes[MUS * LANES + i] = mu_s
    lanes[G * LANES + i] = g
    lanes[S0 * LANES + i] = s0
    lanes[S1 * LANES + i] = s1
    lanes[S2 * LANES + i] = s2
    lanes[LO * LANES + i] = p_lo
    lanes[HI * LANES + i] = p_hi
    lanes[B * LANES + i] = inputs[I_B, j]
    lanes[C * LANES + i] = inputs[I_C, j]
    lanes[JOINT * LANES + i] = inputs[I_JOINT, j]
    lanes[JOINT2 * LANES + i] = inputs[I_JOINT2, j]


def _finish_lane(lanes, i, inputs, shared, out, status):
    """Write lane i's trajectory (finished) to its column of ``out`` and
    ``status``; the lane becomes empty."""
    j = int(lanes[TRAJ * LANES + i])
    p = lanes[P * LANES + i]
    u = lanes[U * LANES + i]
    g = lanes[G * LANES + i]
    s0 = lanes[S0 * LANES + i]
    s1 = lanes[S1 * LANES + i]
    s2 = lanes[S2 * LANES + i]
    s3 = lanes[BRANCH * LANES + i]
    work = lanes[WORK * LANES + i]
    drag_work = lanes[DRAGW * LANES + i]
    path = lanes[PATH * LANES + i]
    p_lift = lanes[PLIFT * LANES + i]
    energy_start = lanes[E0 * LANES + i]
    m = inputs[I_M, j]
    x_end, y_end = curve_point(p, s0, s1, s2, s3, shared)
    energy_end = fma(g, y_end, 0.5 * u * u)
    out[O_T, j] = lanes[T * LANES + i]
    out[O_P, j] = p
    out[O_U, j] = u
    out[O_X, j] = x_end
    out[O_Y, j] = y_end
    out[O_W, j] = m * work
    out[O_WE, j] = m * (energy_start - energy_end)
    out[O_WD, j] = m * drag_work
    out[O_BAL, j] = m * (work + drag_work - (energy_start - energy_end))
    out[O_DISP, j] = lanes[DISP * LANES + i]
    out[O_PATH, j] = path
    out[O_XPATH, j] = lanes[PATHX * LANES + i]
    out[O_KMEAN, j] = lanes[CURV * LANES + i] / path if path > 0.0 else lanes[KAPPA0 * LANES + i]
    out[O_NUMIN, j] = m * lanes[NUMIN * LANES + i]
    out[O_PLIFT, j] = p_lift
    if p_lift == p_lift:
        x_lift, y_lift = curve_point(p_lift, s0, s1, s2, s3, shared)
        out[O_XLIFT, j] = x_lift
        out[O_YLIFT, j] = y_lift
    else:
        out[O_XLIFT, j] = math.nan
        out[O_YLIFT, j] = math.nan
    out[O_NREV, j] = lanes[NREV * LANES + i]
    out[O_STEPS, j] = lanes[STEPS * LANES + i]
    out[O_REJECTED, j] = lanes[NREJ * LANES + i]
    status[j] = int(lanes[STATUS * LANES + i])
    lanes[STATUS * LANES + i] = EMPTY


def _vector_step(lanes, i, shared, t_max, side, rtol, atol):
    """Lane i's next step where it is clean, committed by selects (see the
    module docstring); otherwise FLAG is set and nothing else changes."""
    running = lanes[STATUS * LANES + i] == st.NOT_RUN
    free = running & (lanes[FLAG * LANES + i] == 0.0)
    p = lanes[P * LANES + i]
    u = lanes[U * LANES + i]
    d = lanes[D * LANES + i]
    sn = lanes[SN * LANES + i]
    t = lanes[T * LANES + i]
    h_next = lanes[HN * LANES + i]
    g = lanes[G * LANES + i]
    s0 = lanes[S0 * LANES + i]
    s1 = lanes[S1 * LANES + i]
    s2 = lanes[S2 * LANES + i]
    s3 = lanes[BRANCH * LANES + i]
    p_lo = lanes[LO * LANES + i]
    p_hi = lanes[HI * LANES + i]
    b = lanes[B * LANES + i]
    c = lanes[C * LANES + i]
    joint = lanes[JOINT * LANES + i]
    step_size = h_next if t + h_next <= t_max else t_max - t
    q = d * lanes[MUK * LANES + i] * sn
    if JOINTS:
        s3_before = s3
        if JOINTS > 1:
            s3, joint = branch(p, d, joint, lanes[JOINT2 * LANES + i])
        else:  # one joint: the only one a step may cross
            s3 = branch(p, d, joint, math.nan)[0]
        lanes[BRANCH * LANES + i] = s3 if free else s3_before
    sin_now = lanes[SINNOW * LANES + i]
    cos_now = lanes[COSNOW * LANES + i]
    kappa_now = lanes[KAPNOW * LANES + i]
    dp_ds_now = lanes[DPDSNOW * LANES + i]
    if JOINTS:  # the frame on the step's own branch, which the last step's end may not be
        frame = curve_frame(p, s0, s1, s2, s3, shared)
    else:
        frame = (sin_now, cos_now, kappa_now, dp_ds_now)
    p1, u1, dw, dk, dx, dwd, err, nu1, clean, frame1, rough = try_step(
        p, u, q, d, sn, step_size, g, s0, s1, s2, s3, shared, b, c, p_lo, p_hi, joint, rtol, atol,
        frame)
    sin1, cos1, kappa1, dp_ds1 = frame1
    # X at the step's end, as curve_kernel._x_travelled takes it (a NaN end,
    # never committed, is evaluated at p_lo: a family's point may loop on it)
    p_end = min(max(p1, p_lo), p_hi)
    p_end = p_end if p_end == p_end else p_lo
    x1, _ = curve_point(p_end, s0, s1, s2, s3, shared)
    x_now = lanes[XNOW * LANES + i]
    finite = (math.isfinite(p1) & math.isfinite(u1) & math.isfinite(dw) & (nu1 == nu1)
              & math.isfinite(dk))
    attempt = free & clean & (t < t_max)
    # a rough step (a dip of nu inside it) goes to the scalar code, as there
    fast = attempt & finite & (not (cos_now * cos1 < 0.0)) & (not (rough & (not fresh(lanes, i))))
    if ADAPTIVE:
        accepted = err <= 1.0
        fast = fast & accepted
        h_rejected = step_size * rejected_factor(err)
        rejected = attempt & (not accepted) & (err == err) & (h_rejected > SMALLEST_STEP * max(t, 1.0))
        rejected_before = lanes[REJB * LANES + i]
        error_previous = lanes[EPREV * LANES + i]
        h_accepted = step_size * accepted_factor(err, error_previous, rejected_before != 0.0)
        lanes[HN * LANES + i] = h_accepted if fast else (h_rejected if rejected else h_next)
        lanes[EPREV * LANES + i] = max(err, ERROR_FLOOR) if fast else error_previous
        lanes[REJB * LANES + i] = 0.0 if fast else (1.0 if rejected else rejected_before)
        lanes[NREJ * LANES + i] += 1.0 if rejected else 0.0
        frozen = running & (not fast) & (not rejected)
    else:
        frozen = running & (not fast)
    lanes[FLAG * LANES + i] = 1.0 if frozen else 0.0
    lanes[P * LANES + i] = p1 if fast else p
    lanes[U * LANES + i] = u1 if fast else u
    lanes[T * LANES + i] = t + step_size if fast else t
    lanes[STEPS * LANES + i] += 1.0 if fast else 0.0
    lanes[INROW * LANES + i] = 0.0 if fast else lanes[INROW * LANES + i]
    work = lanes[WORK * LANES + i]
    lanes[WORK * LANES + i] = work + dw if fast else work
    curvature = lanes[CURV * LANES + i]
    lanes[CURV * LANES + i] = curvature + dk if fast else curvature
    displacement = lanes[DISP * LANES + i]
    lanes[DISP * LANES + i] = displacement + dx if fast else displacement
    path = lanes[PATH * LANES + i]
    lanes[PATH * LANES + i] = path + d * dx if fast else path
    if DRAG:
        drag_work = lanes[DRAGW * LANES + i]
        lanes[DRAGW * LANES + i] = drag_work + dwd if fast else drag_work
    nu_min = lanes[NUMIN * LANES + i]
    lanes[NUMIN * LANES + i] = min(nu_min, side * nu1) if fast else nu_min
    path_x = lanes[PATHX * LANES + i]
    lanes[PATHX * LANES + i] = path_x + abs(x1 - x_now) if fast else path_x
    lanes[XNOW * LANES + i] = x1 if fast else x_now
    lanes[SINNOW * LANES + i] = sin1 if fast else sin_now
    lanes[COSNOW * LANES + i] = cos1 if fast else cos_now
    lanes[KAPNOW * LANES + i] = kappa1 if fast else kappa_now
    lanes[DPDSNOW * LANES + i] = dp_ds1 if fast else dp_ds_now


def _vector_pass(lanes, shared, t_max, side, rtol, atol, n_blocks):
    """``SUBSTEPS`` vector steps on lanes 0 .. n_blocks * BLOCK - 1."""
    for _ in range(SUBSTEPS_ADAPTIVE if ADAPTIVE else SUBSTEPS):
        for block in range(n_blocks):
            first = block * BLOCK
            for k in range(BLOCK):
                vector_step(lanes, first + k, shared, t_max, side, rtol, atol)


@jit
def _move_lane(lanes, source, target):
    for field in range(N_FIELDS):
        lanes[field * LANES + target] = lanes[field * LANES + source]


def _run_tile(begin, end, lanes, inputs, shared, h, t_max, side, rtol, atol, out, status):
    """Trajectories begin .. end - 1 through the lanes (see the module docstring)."""
    if not VECTOR:
        for j in range(begin, end):
            start_lane(lanes, 0, inputs, j, shared, h, side)
            while lanes[STATUS * LANES] == st.NOT_RUN:
                iterate(lanes, 0, shared, t_max, side, rtol, atol)
            finish_lane(lanes, 0, inputs, shared, out, status)
        return
    for i in range(LANES):
        lanes[STATUS * LANES + i] = EMPTY
        lanes[FLAG * LANES + i] = 0.0
    next_j = begin
    n_blocks = LANES // BLOCK
    while True:
        running = 0
        for i in range(n_blocks * BLOCK):
            state = lanes[STATUS * LANES + i]
            if state == st.NOT_RUN and lanes[FLAG * LANES + i] != 0.0:
                lanes[FLAG * LANES + i] = 0.0
                iterate(lanes, i, shared, t_max, side, rtol, atol)
                state = lanes[STATUS * LANES + i]
            while state != st.NOT_RUN:
                if state != EMPTY:
                    finish_lane(lanes, i, inputs, shared, out, status)
                if next_j >= end:
                    break
                start_lane(lanes, i, inputs, next_j, shared, h, side)
                next_j += 1
                state = lanes[STATUS * LANES + i]
            if state == st.NOT_RUN:
                running += 1
        if running == 0:
            return
        if next_j >= end and running <= (n_blocks - 1) * BLOCK:
            # nothing left to load: running lanes to the front, fewer blocks
            target = 0
            for i in range(n_blocks * BLOCK):
                if lanes[STATUS * LANES + i] == st.NOT_RUN:
                    if i != target:
                        _move_lane(lanes, i, target)
                        lanes[STATUS * LANES + i] = EMPTY
                    target += 1
            n_blocks = (running + BLOCK - 1) // BLOCK
        vector_pass(lanes, shared, t_max, side, rtol, atol, n_blocks)


def _run_tiles(first_tile, stop_tile, tile_size, inputs, shared, h, t_max, side, rtol, atol,
               out, status):
    """Tiles first_tile .. stop_tile - 1 of the columns of ``inputs``."""
    lanes = np.zeros(N_FIELDS * LANES)
    n = inputs.shape[1]
    for tile in range(first_tile, stop_tile):
        begin = tile * tile_size
        run_tile(begin, min(n, begin + tile_size), lanes, inputs, shared, h, t_max, side, rtol,
                 atol, out, status)


def tile_size(n: int, threads: int) -> int:
    """Trajectories per tile: enough tiles for every thread to stay busy
    (dynamic scheduling), each big enough to keep its lanes full."""
    return int(min(16384, max(4 * LANES, -(-n // (8 * max(threads, 1))))))


class CurveKernel:
    """``kernel(inputs, shared, h, t_max, side, rtol, atol, out, status)``:
    every column of ``inputs`` (rows ``curve_kernel.INPUTS``) into ``out``
    (rows ``curve_kernel.OUTPUTS``) and ``status``, in tiles over
    :func:`threads.current_threads` threads (``threads.using_threads``)."""

    def __init__(self, run_tiles, trace_one=None):
        self.run_tiles = run_tiles
        #: ``trace_one(j, inputs, shared, h, t_max, side, rtol, atol, every, trace)``:
        #: one trajectory recorded (core/curve_trace.py), compiled on first use
        self.trace_one = trace_one

    def __call__(self, inputs, shared, h, t_max, side, rtol, atol, out, status):
        n = inputs.shape[1]
        if n == 0:
            return
        size = tile_size(n, current_threads())
        run_items(self.run_tiles, -(-n // size), size, inputs, shared, float(h), float(t_max),
                  float(side), float(rtol), float(atol), out, status)


def build_curve_kernel(key: str, frame, point, method: str, *, one_sided: bool = True,
                       friction: bool = True, drag_linear: bool = False,
                       drag_quadratic: bool = False, joints: int = 0, cache: bool = True,
                       vector: bool = True) -> CurveKernel:
    """The :class:`CurveKernel` of one curve family (``key`` names it uniquely;
    ``frame``, ``point`` its jitted functions) and ``method`` (any
    ``CURVE_STEPPERS`` entry), compiled with only the effects asked for.
    ``vector=False``: the scalar reference (every step through ``_iterate``);
    ``joints``: the curve's joints (0 to 2; with one, the second's logic is
    compiled out, with none all of it)."""
    if method not in CURVE_STEPPERS:
        raise ValueError(f"unknown curve method {method!r}; allowed: {', '.join(CURVE_STEPPERS)}")
    step, _, adaptive, control = CURVE_STEPPERS[method]
    flags = "".join(suffix for on, suffix in (
        (one_sided, "_one"), (friction, "_friction"), (drag_linear, "_dragb"),
        (drag_quadratic, "_dragc"), (joints == 1, "_joints"), (joints > 1, f"_joints{int(joints)}"),
        (not vector, "_scalar")) if on)
    name = f"curve_{key}_{method}{flags}"
    alpha, beta, shrink = control if adaptive else (0.0, 0.0, 0.0)
    constants = {"curve_frame": frame, "curve_point": point, "ONE_SIDED": one_sided,
                 "ADAPTIVE": adaptive, "JOINTS": int(joints), "FRICTION": friction,
                 "DRAG_LINEAR": drag_linear, "DRAG_QUADRATIC": drag_quadratic,
                 "DRAG": drag_linear or drag_quadratic, "VECTOR": vector, "PI_ALPHA": alpha,
                 "PI_BETA": beta, "REJECT_EXPONENT": shrink}
    options = {} if cache else {"cache": False}

    def build(template, suffix, **more):
        constants.update(more)
        return specialise(template, f"{name}_{suffix}", dict(constants), **options)

    code = step.__code__  # a step without the frame argument works too, one frame dearer
    constants["STEP_TAKES_FRAME"] = "frame" in code.co_varnames[:code.co_argcount]
    built_stage_from = build(_stage_from, "stage_from")
    built_stage = build(_stage, "stage", stage_from=built_stage_from)
    # dop853's twelve stages, apart from its error norm (compiled only where a step calls them)
    built_rates = build(_dop853_stages, "rates", stage=built_stage, stage_from=built_stage_from)
    constants["curve_step"] = build(step, "step", stage=built_stage, stage_rates=built_rates)
    constants["try_step"] = build(ck._try_step, "try")
    for template, bound in ((ck._rest_rule, "rest_rule"), (ck._contact_sign, "contact_sign"),
                            (ck._x_travelled, "x_travelled"),
                            (ck._event_guess, "event_guess"), (ck._locate_event, "locate_event"),
                            (ck._accepted_factor, "accepted_factor"),
                            (ck._rejected_factor, "rejected_factor"),
                            (_start_lane, "start_lane"), (ck._iterate, "iterate"),
                            (_finish_lane, "finish_lane"), (_vector_step, "vector_step"),
                            (_vector_pass, "vector_pass"), (_run_tile, "run_tile")):
        constants[bound] = build(template, bound)
    trace_one = build(curve_trace._trace_one, "trace",
                      sample=build(curve_trace._sample, "trace_sample"))
    return CurveKernel(build(_run_tiles, "tiles"), trace_one)
