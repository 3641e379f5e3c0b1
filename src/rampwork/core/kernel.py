"""The batch kernel: many trajectories in lock-step SIMD lanes, reduced on the fly.

Why lanes: a loop that carries one trajectory at a time is bound by the latency
of its divisions.  Here a tile of trajectories is run through a block of
``LANES`` lanes stored as structure of arrays; the inner loop does one step for
every lane with no data-dependent branch, so LLVM turns it into vector code.
Every lane steps every time, and no step is held back where its event
conditions fire (reversal or stop, lift-off, contact switch, exit,
divergence): the lane steps on, each step's state goes to a history bank,
and a per-lane flag records whether all the block's steps were clean; the
tests run beside the recurrence, not in it.  Every ``SUBSTEPS`` steps a
scan takes each clean lane to the block's last state and books its steps;
a lane that was not clean (or reached its ``t_max`` step limit) goes back
to the start of its first unclean step, found exactly in its history, and
its event is resolved there (located inside the step by root finding on
the step size, to rounding); finished lanes are refilled with the next
trajectory of the tile.  Once a tile has nothing left to load, running
lanes are compacted to the front so that its tail does not step empty lanes.

Every trajectory sees the same sequence of floating-point operations whatever
lane, tile, block size or thread runs it, so results are bit-for-bit
independent of those choices.

The functions here are templates: ``step``, ``ramp_height``,
``ramp_slope_curvature``, ``ONE_SIDED`` and the helper names are globals bound
per scene by :func:`build_kernel` through ``jit.specialise``.  So is air drag
(``DRAG_LINEAR``, ``DRAG_QUADRATIC``, ``DRAG``): a scene without it compiles
no drag arithmetic at all (every ``if DRAG:`` block is removed).
"""

from __future__ import annotations

import math

import numpy as np

from . import status as st
from .layout import *  # noqa: F403 - the lane layout, shared with adaptive.py
from .jit import aligned_zeros, flip_sign, fma, specialise
from numba.cpython.unsafe.numbers import trailing_zeros
from . import straight
from .variant import KernelVariant
from . import general
from .threads import TiledKernel
from .physics import (acceleration, acceleration_frictionless, departure_direction, drag_rate,
                      normal_term, specific_energy)
from . import adaptive as adaptive_parts
from . import parameters
from . import steppers
from .ramps import SLOPE_CURVATURE_NEAR, SLOPE_CURVATURE_SHORT
from . import ramps
from .steppers import ADAPTIVE_STEPPERS, STEPPERS

# bound per scene by build_kernel (compile-time constants)
step = ramp_height = ramp_slope_curvature = None
ONE_SIDED = True  # block on top of the ramp (lift-off) rather than a bead on a wire
CHECK_CONTACT = True  # False where n > 0 is known in advance (f'' >= 0)
CARRY_SLOPE = True  # keep f', f'' from the previous step end rather than re-evaluate
LANES = 64  # lanes per block
ADAPTIVE = False  # an embedded pair with per-lane step sizes (adaptive.py)
SUBSTEPS = N_SUBSTEPS  # (attempted) steps between scalar passes
CHAINS = 2  # lane-loop halves run side by side (1: one after the other)
UNROLL = 1  # fixed steps per lane visit, state held in registers
PAPER_CRITERION = False  # record where the paper's eq. (26) would report lift-off
FRICTION = True  # False: mu_k = 0 everywhere, no friction branch (see build_kernel)
# Known in advance for some methods and ramps (see build_kernel):
WORK_SIGN_CHECK = True  # False: each step's friction work is >= 0 by construction
CONSTANT_CURVATURE = False  # f'' is the same all along the ramp: no curvature integral
LINEAR_EVENTS = False  # x and v are linear in the step size: events in closed form
MONOTONE_STEP = False  # a step that keeps d v > 0 moves x in direction d (first-order methods)
UNIFORM_PARAMETERS = False  # g and the ramp parameters are the run's settings, not per lane
DRAG_LINEAR = DRAG_QUADRATIC = DRAG = False  # air drag's terms (DRAG: either)
# f', f'' at a step's end from those at its start (the family's stage
# evaluation, steppers.ramp_slope_curvature_near), where it has one
STAGE_FROM_START = False
ramp_slope_curvature_near = None
# fixed steps: fields per history bank (x, v, W, then WD where the kernel
# has it; no K: the curvature integral is formed per mode, _mode_curvature)
# and where WD sits in a bank (see build_kernel)
N_HIST = 4
HIST_WD = 3
# fixed steps with a split step (RK4: steppers.FixedStepMethod.split): the
# vector loop runs the step's first part for all lanes, then its last part,
# the values between them in N_CARRY fields from CARRY (after the history
# banks; see build_kernel)
SPLIT_STEP = False
CARRY = 0
N_CARRY = 8
first_stages = last_stages = None
(advance_lanes, load_lane, resolve_lane, finish_lane, event_value, locate_event, apply_step,
 run_tile, current_time, rebase, make_empty, set_mode, start_value, fill_lane,
 scan_lanes, compact_lanes, event_values, refresh_slope, active_span,
 trial_step, apply_event, start_adaptive, new_lanes, fixed_step_lane, paper_scan,
 resolve_linear, take_event, step_and_check, start_block, replay_lane,
 attempt_once, lane_parameters, uniform_parameters, locate_earliest,
 runtime_flags, clean_steps, step_from_bank, restore_bank, first_stages_lane,
 checked_step, mode_curvature) = (None,) * 41

#: families whose RK4 runs its vector step in two lane loops (SPLIT_STEP),
#: measured not slower (benchmarks/families.py, 1 thread, CPU time, two
#: runs: quadratic 1.18-1.22x, sine 1.05x, circular bowl 0.99-1.02x, spline
#: 1.05-1.11x).  Not the cycloid (9x slower split while every stage solved
#: for its parameter by Newton; with its short stage form level, 2.64e8
#: against 2.66e8 steps/s, so left as it was) nor user callables (not
#: measured)
SPLIT_STEP_FAMILIES = frozenset((
    ramps.straight_slope_curvature, ramps.quadratic_slope_curvature,
    ramps.circular_bowl_slope_curvature, ramps.circular_dome_slope_curvature,
    ramps.sine_slope_curvature, ramps.spline_slope_curvature))

#: samples of f' per mode where the paper's criterion is looked for (then
#: bisected to rounding); a sign change narrower than a sample can be missed
PAPER_SAMPLES = 64


# ------------------------------------------------------------------------------
# vector part
# ------------------------------------------------------------------------------
def _advance_lanes(lanes, history, settings, shared, n_substeps, n_active):
    """``n_substeps`` fixed steps on lanes 0 .. n_active-1 (all LANES lanes
    with ``CHAINS = 2``).

    Branch-free per lane so that it vectorises (see :func:`_fixed_step_lane`).
    No step is held back where its event conditions fire: every lane steps
    on, step j of the block reading state bank j and writing bank j + 1
    (layout.HIST), and a lane's CLEAN records whether all its steps were
    clean; the scan takes a lane that was not back to the state at the start
    of its first unclean step.  So the recurrence x, v -> x1, v1, the chain
    of dependent divisions that bounds the loop, carries no event test and
    no select: the tests run beside it.  The first visit reads the lane's
    own fields and keeps them as bank 0, later ones read the history, at
    offsets affine in the step index (banks live after the lane fields, in
    the same array: ``history`` is ``lanes``).  With ``CHAINS = 2`` every
    visit steps all LANES lanes, empty ones too, in two halves side by side:
    two independent chains keep the divider busy where one would wait on
    latency, and loops with a constant trip count get constant offsets that
    LLVM can prove disjoint (with a run-time count and the history's
    run-time offsets it would not vectorise)."""
    x_lo = settings[SET_XLO]
    x_hi = settings[SET_XHI]
    h = settings[SET_DT]
    uniform = uniform_parameters(settings)  # see parameters.py
    visits = n_substeps // UNROLL
    # the first visit: from the lane's own fields
    if SPLIT_STEP:
        first_stages_all(lanes, lanes, X, V, shared, h, uniform, n_active)
    if CHAINS == 2 and n_active > 0:
        for i in range(LANES // 2):  # constant offsets: provably disjoint halves
            fixed_step_lane(lanes, lanes, history, i, X, V, W, WD, HIST + N_HIST, True, shared,
                            x_lo, x_hi, h, uniform)
            fixed_step_lane(lanes, lanes, history, i + LANES // 2, X, V, W, WD, HIST + N_HIST,
                            True, shared, x_lo, x_hi, h, uniform)
    else:
        for i in range(n_active):
            fixed_step_lane(lanes, lanes, history, i, X, V, W, WD, HIST + N_HIST, True, shared,
                            x_lo, x_hi, h, uniform)
    for visit in range(1, visits):
        src = HIST + N_HIST * visit * UNROLL  # the bank after the previous visit's last step
        dst = src + N_HIST
        if SPLIT_STEP:
            first_stages_all(lanes, history, src + HIST_X, src + HIST_V, shared, h, uniform,
                             n_active)
        if CHAINS == 2 and n_active > 0:
            for i in range(LANES // 2):
                fixed_step_lane(lanes, history, history, i, src + HIST_X, src + HIST_V,
                                src + HIST_W, src + HIST_WD, dst, False, shared, x_lo,
                                x_hi, h, uniform)
                fixed_step_lane(lanes, history, history, i + LANES // 2, src + HIST_X,
                                src + HIST_V, src + HIST_W, src + HIST_WD, dst,
                                False, shared, x_lo, x_hi, h, uniform)
        else:
            for i in range(n_active):
                fixed_step_lane(lanes, history, history, i, src + HIST_X, src + HIST_V,
                                src + HIST_W, src + HIST_WD, dst, False, shared, x_lo,
                                x_hi, h, uniform)


def _first_stages_all(lanes, source, src_x, src_v, shared, h, uniform, n_active):
    """SPLIT_STEP: the first part of the step on every lane (CHAINS = 2:
    all LANES lanes in two halves, as :func:`_advance_lanes`), from x, v at
    fields ``src_x``, ``src_v`` of ``source``; its values go to the CARRY
    fields, where :func:`_fixed_step_lane` takes them.  Two lane loops with
    half the step each keep more independent work in flight than one loop
    with the whole step, whose four dependent stages hold the out-of-order
    window to few lanes (RK4)."""
    if CHAINS == 2 and n_active > 0:
        for i in range(LANES // 2):
            first_stages_lane(lanes, source, i, src_x, src_v, shared, h, uniform)
            first_stages_lane(lanes, source, i + LANES // 2, src_x, src_v, shared, h, uniform)
    else:
        for i in range(n_active):
            first_stages_lane(lanes, source, i, src_x, src_v, shared, h, uniform)


def _first_stages_lane(lanes, source, i, src_x, src_v, shared, h, uniform):
    """The step's first part on lane i (see :func:`_first_stages_all`)."""
    g, p0, p1, p2, p3 = lane_parameters(lanes, i, uniform)
    x = source[src_x * LANES + i]
    if CARRY_SLOPE:
        fp = lanes[FP * LANES + i]
        fpp = lanes[FPP * LANES + i]
    else:
        fp, fpp = ramp_slope_curvature(x, p0, p1, p2, p3, shared)
    a1, v2, a2, n1v, n2v2, fpp2v2, pd1, pd2 = first_stages(
        x, source[src_v * LANES + i], fp, fpp, lanes[Q * LANES + i], lanes[D * LANES + i], h, g,
        p0, p1, p2, p3, shared, lanes[DRAG_B * LANES + i], lanes[DRAG_C * LANES + i])
    # in the order of the stepper's tuple; only those this kernel reads
    lanes[CARRY * LANES + i] = a1
    lanes[(CARRY + 1) * LANES + i] = v2
    lanes[(CARRY + 2) * LANES + i] = a2
    lanes[(CARRY + 3) * LANES + i] = n1v
    lanes[(CARRY + 4) * LANES + i] = n2v2
    # not fpp2v2 (field CARRY + 5 unused): fixed steps form the curvature
    # integral per mode (_mode_curvature), not from the stages
    if DRAG:
        lanes[(CARRY + 6) * LANES + i] = pd1
        lanes[(CARRY + 7) * LANES + i] = pd2


def _step_and_check(x, v, fp, fpp, q, qh, d, dsign, ahead, sn, h, g, p0, p1, p2, p3, shared,
                    drag_b, drag_c, x_lo, x_hi, block_end_exit=False):
    """One fixed step from (x, v) and whether it is clean, i.e. no event
    condition fired: ``(x1, v1, dw, dwd, fp1, fpp1, ok)`` (not the stepper's
    curvature integral: fixed steps form it per mode, _mode_curvature).  The
    vector loop and the scalar replay both call this, so they round alike.
    ``dw < 0``: a step too long for the mode's signs (see _event_values).
    NaN makes every comparison false, so a non-finite step is not clean.
    ``qh`` = h q, ``dsign`` = D's sign bit, ``ahead`` the domain's end
    ahead (layout's QH, DSIGN, AHEAD).  ``block_end_exit`` (the vector
    loop, first-order methods): leave out the exit test, which the scan
    makes once on the block's last state (x moves monotonically while
    d v > 0, so the last state is past the end ahead if any is)."""
    if not CARRY_SLOPE:
        fp, fpp = ramp_slope_curvature(x, p0, p1, p2, p3, shared)
    x1, v1, dw, _, dwd = step(x, v, fp, fpp, q, qh, d, h, g, p0, p1, p2, p3, shared,
                              drag_b, drag_c)
    return checked_step(x, x1, v1, dw, dwd, fp, fpp, dsign, ahead, sn, g, p0, p1, p2, p3,
                        shared, x_lo, x_hi, block_end_exit)


def _checked_step(x, x1, v1, dw, dwd, fp, fpp, dsign, ahead, sn, g, p0, p1, p2, p3, shared,
                  x_lo, x_hi, block_end_exit):
    """:func:`_step_and_check` after the step from x to ``x1, v1`` (with
    f', f'' = ``fp, fpp`` at x): the tests, and f', f'' at x1."""
    ok = flip_sign(v1, dsign) > 0.0  # d v1 > 0
    if MONOTONE_STEP and block_end_exit:
        pass
    elif MONOTONE_STEP:
        # x1 moves in direction d from x, so only the end ahead can be passed:
        # d (ahead - x1) > 0, the same test as x1 < x_hi (d > 0) or
        # x1 > x_lo (d < 0), exact (a difference of floats is 0 only
        # when they are equal), with one comparison instead of two
        ok = ok & (flip_sign(ahead - x1, dsign) > 0.0)
    else:
        ok = ok & (x1 < x_hi) & (x1 > x_lo)
    if WORK_SIGN_CHECK:
        ok = ok & (dw >= 0.0)
    if DRAG:
        ok = ok & (dwd >= 0.0)  # drag's power is >= 0 within a mode, as friction's
    fp1 = fpp1 = 0.0
    if STAGE_FROM_START and (CHECK_CONTACT or CARRY_SLOPE):
        # from the start's, as the stages (cheaper than afresh; the start's
        # are carried, so rounding adds up over a mode's steps, a few ulp
        # times the root of their count: lanes that stop evaluate afresh)
        fp1, fpp1 = ramp_slope_curvature_near(x1, x1 - x, fp, fpp, p0, p1, p2, p3, shared)
    elif CHECK_CONTACT or CARRY_SLOPE:
        fp1, fpp1 = ramp_slope_curvature(x1, p0, p1, p2, p3, shared)
    if CHECK_CONTACT:
        ok = ok & (sn * normal_term(v1, fpp1, g) > 0.0)
    return x1, v1, dw, dwd, fp1, fpp1, ok


def _fixed_step_lane(lanes, source, history, i, src_x, src_v, src_w, src_wd, dst,
                     keep_start, shared, x_lo, x_hi, h, uniform):
    """UNROLL fixed steps on lane i: the state read from fields ``src_x``,
    ``src_v``, ``src_w``, ``src_wd`` of ``source`` (the lanes or
    the history) and each step's result written to the next history bank,
    the first at field ``dst`` of ``history``; ``keep_start`` (the block's
    first visit): the state read goes to bank 0 as well.  Every
    step is taken from the previous one's result whether it was clean or
    not; ``CLEAN`` drops to 0.0 at the first step that was not (a blend
    beside the recurrence, not in it).  The steps after an unclean one are
    never used: the scan goes back to the state before it.  An empty lane
    has D = 0 and is never clean; the scan ignores it."""
    x = source[src_x * LANES + i]
    v = source[src_v * LANES + i]
    d = lanes[D * LANES + i]
    q = lanes[Q * LANES + i]
    qh = lanes[QH * LANES + i]
    dsign = lanes[DSIGN * LANES + i]
    ahead = lanes[AHEAD * LANES + i]
    sn = lanes[SN * LANES + i]
    g, p0, p1, p2, p3 = lane_parameters(lanes, i, uniform)
    work = source[src_w * LANES + i]
    drag_b = lanes[DRAG_B * LANES + i]
    drag_c = lanes[DRAG_C * LANES + i]
    drag_work = source[src_wd * LANES + i] if DRAG else 0.0
    # f', f'' are carried along the unclean steps too: the scan evaluates
    # them again at a lane's state that it goes back to
    fp = lanes[FP * LANES + i] if CARRY_SLOPE else 0.0
    fpp = lanes[FPP * LANES + i] if CARRY_SLOPE else 0.0
    clean = lanes[CLEAN * LANES + i]
    if keep_start:
        history[(HIST + HIST_X) * LANES + i] = x
        history[(HIST + HIST_V) * LANES + i] = v
        history[(HIST + HIST_W) * LANES + i] = work
        if DRAG:
            history[(HIST + HIST_WD) * LANES + i] = drag_work
    # UNROLL steps with the state in registers: one load of each field per visit
    for u in range(UNROLL):
        if SPLIT_STEP:  # UNROLL = 1: the step's first part is in CARRY (_first_stages_all)
            if not CARRY_SLOPE:
                fp, fpp = ramp_slope_curvature(x, p0, p1, p2, p3, shared)
            x1, v1, dw, _, dwd = last_stages(
                x, v, fp, fpp, q, d, h, g, p0, p1, p2, p3, shared, drag_b, drag_c,
                lanes[CARRY * LANES + i], lanes[(CARRY + 1) * LANES + i],
                lanes[(CARRY + 2) * LANES + i], lanes[(CARRY + 3) * LANES + i],
                lanes[(CARRY + 4) * LANES + i],
                0.0,  # fpp2v2: only the unused curvature integral reads it
                lanes[(CARRY + 6) * LANES + i] if DRAG else 0.0,
                lanes[(CARRY + 7) * LANES + i] if DRAG else 0.0)
            x, v, dw, dwd, fp, fpp, ok = checked_step(
                x, x1, v1, dw, dwd, fp, fpp, dsign, ahead, sn, g, p0, p1, p2, p3, shared,
                x_lo, x_hi, True)
        else:
            x, v, dw, dwd, fp, fpp, ok = step_and_check(
                x, v, fp, fpp, q, qh, d, dsign, ahead, sn, h, g, p0, p1, p2, p3, shared, drag_b,
                drag_c, x_lo, x_hi, True)
        # an add, not a select against the loaded value: that would become
        # a masked load, which waits for the previous visit's store
        clean += 0.0 if ok else -1.0
        work += dw
        bank = (dst + N_HIST * u) * LANES + i
        history[bank + HIST_X * LANES] = x
        history[bank + HIST_V * LANES] = v
        history[bank + HIST_W * LANES] = work
        if DRAG:
            drag_work += dwd
            history[bank + HIST_WD * LANES] = drag_work
    if CARRY_SLOPE:
        lanes[FP * LANES + i] = fp
        lanes[FPP * LANES + i] = fpp
    lanes[CLEAN * LANES + i] = clean


def _start_block(lanes, n_active):
    """Every lane clean at a block's start (vectorised: plain stores)."""
    for i in range(n_active):
        lanes[CLEAN * LANES + i] = 0.0


def _clean_steps(lanes, history, i, settings, shared, n_steps):
    """How many of the block's first ``n_steps`` steps of lane i were clean:
    the index of the first that was not (or ``n_steps``), found from the
    history banks with the vector loop's own tests, exactly.  Each state
    after step j is in bank j + 1; the friction and drag works' signs
    (tested where they are not >= 0 by construction) follow from the
    banked sums where these grew (fl(w + dw) > w only if dw > 0); where a
    sum did not, the step is taken again from its start (the same
    arithmetic, the same values)."""
    g, p0, p1, p2, p3 = lane_parameters(lanes, i, uniform_parameters(settings))
    x_lo = settings[SET_XLO]
    x_hi = settings[SET_XHI]
    dsign = lanes[DSIGN * LANES + i]
    ahead = lanes[AHEAD * LANES + i]
    sn = lanes[SN * LANES + i]
    for j in range(n_steps):
        bank = HIST + N_HIST * (j + 1)  # the state after step j
        x1 = history[(bank + HIST_X) * LANES + i]
        v1 = history[(bank + HIST_V) * LANES + i]
        ok = flip_sign(v1, dsign) > 0.0
        if MONOTONE_STEP:
            ok = ok and flip_sign(ahead - x1, dsign) > 0.0
        else:
            ok = ok and x1 < x_hi and x1 > x_lo
        if CHECK_CONTACT:
            _, fpp1 = ramp_slope_curvature(x1, p0, p1, p2, p3, shared)
            ok = ok and sn * normal_term(v1, fpp1, g) > 0.0
        if not ok:
            return j
        if WORK_SIGN_CHECK or DRAG:
            grew = True
            if WORK_SIGN_CHECK:
                before = history[(bank - N_HIST + HIST_W) * LANES + i]
                grew = history[(bank + HIST_W) * LANES + i] > before
            if DRAG:
                before = history[(bank - N_HIST + HIST_WD) * LANES + i]
                grew = grew and history[(bank + HIST_WD) * LANES + i] > before
            if not grew and not step_from_bank(lanes, history, i, j, settings, shared):
                return j
    return n_steps


def _step_from_bank(lanes, history, i, j, settings, shared):
    """Whether lane i's step j of the block, taken again from bank j, is
    clean (the vector loop's arithmetic and tests)."""
    g, p0, p1, p2, p3 = lane_parameters(lanes, i, uniform_parameters(settings))
    x = history[(HIST + N_HIST * j + HIST_X) * LANES + i]
    v = history[(HIST + N_HIST * j + HIST_V) * LANES + i]
    fp, fpp = ramp_slope_curvature(x, p0, p1, p2, p3, shared)
    return step_and_check(
        x, v, fp, fpp, lanes[Q * LANES + i], lanes[QH * LANES + i], lanes[D * LANES + i],
        lanes[DSIGN * LANES + i], lanes[AHEAD * LANES + i], lanes[SN * LANES + i],
        settings[SET_DT], g, p0, p1, p2, p3, shared, lanes[DRAG_B * LANES + i],
        lanes[DRAG_C * LANES + i], settings[SET_XLO], settings[SET_XHI])[6]


def _restore_bank(lanes, history, i, j):
    """Lane i's state back to bank j (the start of the block's step j)."""
    bank = HIST + N_HIST * j
    lanes[X * LANES + i] = history[(bank + HIST_X) * LANES + i]
    lanes[V * LANES + i] = history[(bank + HIST_V) * LANES + i]
    lanes[W * LANES + i] = history[(bank + HIST_W) * LANES + i]
    if DRAG:
        lanes[WD * LANES + i] = history[(bank + HIST_WD) * LANES + i]


def _replay_lane(lanes, i, settings, shared, n_steps):
    """Lane i's steps in scalar (to record one trajectory step by step),
    committing each clean step while the step count stays below the t_max
    limit, up to ``n_steps``.  Returns the steps taken: fewer than
    ``n_steps`` leaves the lane at the start of the step that raised an
    event, for :func:`_resolve_lane`.  The same arithmetic as the vector
    loop's, so a recorded trajectory is bit-identical to one run in a batch."""
    # the values the vector loop used
    g, p0, p1, p2, p3 = lane_parameters(lanes, i, uniform_parameters(settings))
    x_lo = settings[SET_XLO]
    x_hi = settings[SET_XHI]
    h = settings[SET_DT]
    d = lanes[D * LANES + i]
    q = lanes[Q * LANES + i]
    qh = lanes[QH * LANES + i]
    dsign = lanes[DSIGN * LANES + i]
    ahead = lanes[AHEAD * LANES + i]
    sn = lanes[SN * LANES + i]
    drag_b = lanes[DRAG_B * LANES + i]
    drag_c = lanes[DRAG_C * LANES + i]
    limit = lanes[LIMIT * LANES + i]
    steps = lanes[STEPS * LANES + i]
    x = lanes[X * LANES + i]
    v = lanes[V * LANES + i]
    fp = lanes[FP * LANES + i] if CARRY_SLOPE else 0.0
    fpp = lanes[FPP * LANES + i] if CARRY_SLOPE else 0.0
    taken = 0
    for _ in range(n_steps):
        if not steps < limit:
            break
        x1, v1, dw, dwd, fp1, fpp1, ok = step_and_check(
            x, v, fp, fpp, q, qh, d, dsign, ahead, sn, h, g, p0, p1, p2, p3, shared, drag_b, drag_c,
            x_lo, x_hi)
        if not ok:
            break
        x = x1
        v = v1
        fp = fp1
        fpp = fpp1
        lanes[W * LANES + i] += dw
        if DRAG:
            lanes[WD * LANES + i] += dwd
        steps += 1.0
        taken += 1
    lanes[X * LANES + i] = x
    lanes[V * LANES + i] = v
    if CARRY_SLOPE:
        lanes[FP * LANES + i] = fp
        lanes[FPP * LANES + i] = fpp
    lanes[STEPS * LANES + i] = steps
    return taken


# ------------------------------------------------------------------------------
# scalar part: events, loading and finishing lanes
# ------------------------------------------------------------------------------
def _current_time(lanes, i, h):
    """t = time at mode start + (steps since) * h: no accumulated rounding.
    (Adaptive methods keep the current time itself.)"""
    if ADAPTIVE:
        return lanes[T * LANES + i]
    return lanes[T * LANES + i] + (lanes[STEPS * LANES + i] - lanes[SM * LANES + i]) * h


def _mode_curvature(lanes, i, x, shared):
    """The curvature integral of lane i's mode so far, from its start XM to x:
    the integral of f'' d v dt = d df' is d (f'(x) - f'(XM)), exactly, as d
    is constant within a mode (fixed steps: the one place where it is formed;
    the adaptive pairs integrate it, as part of their error norm)."""
    d = lanes[D * LANES + i]
    if d == 0.0:  # no mode yet (a lane being loaded): XM is not set
        return 0.0
    p0 = lanes[P0 * LANES + i]
    p1 = lanes[P1 * LANES + i]
    p2 = lanes[P2 * LANES + i]
    p3 = lanes[P3 * LANES + i]
    fp_end, _ = ramp_slope_curvature(x, p0, p1, p2, p3, shared)
    fp_start, _ = ramp_slope_curvature(lanes[XM * LANES + i], p0, p1, p2, p3, shared)
    return d * (fp_end - fp_start)


def _rebase(lanes, i, t_now, settings, shared):
    """Start a new mode (after an event) at time t_now and the lane's current x:
    bank the path travelled (and, with fixed steps, the mode's curvature
    integral), reset the time base and the step limit."""
    x = lanes[X * LANES + i]
    if not ADAPTIVE and not CONSTANT_CURVATURE:
        lanes[K * LANES + i] += mode_curvature(lanes, i, x, shared)
    lanes[S * LANES + i] += lanes[D * LANES + i] * (x - lanes[XM * LANES + i])
    lanes[XM * LANES + i] = x
    lanes[T * LANES + i] = t_now
    if ADAPTIVE:
        return
    lanes[SM * LANES + i] = lanes[STEPS * LANES + i]
    remaining = math.floor((settings[SET_TMAX] - t_now) / settings[SET_DT])
    lanes[LIMIT * LANES + i] = lanes[STEPS * LANES + i] + max(remaining, 0.0)


def _refresh_slope(lanes, i, shared):
    """Evaluate f', f'' at lane i's x, store them in the lane and return them."""
    fp, fpp = ramp_slope_curvature(lanes[X * LANES + i], lanes[P0 * LANES + i],
                                   lanes[P1 * LANES + i], lanes[P2 * LANES + i],
                                   lanes[P3 * LANES + i], shared)
    lanes[FP * LANES + i] = fp
    lanes[FPP * LANES + i] = fpp
    return fp, fpp


def _trial_step(lanes, i, h, shared):
    """One step of size h from lane i's state, not committed:
    ``(x, v, friction_work, curvature_integral, drag_work)`` as the stepper
    returns them."""
    q = lanes[Q * LANES + i]
    return step(
        lanes[X * LANES + i], lanes[V * LANES + i], lanes[FP * LANES + i], lanes[FPP * LANES + i],
        q, h * q, lanes[D * LANES + i], h, lanes[G * LANES + i],
        lanes[P0 * LANES + i], lanes[P1 * LANES + i], lanes[P2 * LANES + i], lanes[P3 * LANES + i],
        shared, lanes[DRAG_B * LANES + i], lanes[DRAG_C * LANES + i])


def _apply_step(lanes, i, h, shared):
    """One step of size h from lane i's state, committed (events only)."""
    x1, v1, dw, dk, dwd = trial_step(lanes, i, h, shared)
    lanes[X * LANES + i] = x1
    lanes[V * LANES + i] = v1
    lanes[W * LANES + i] += dw
    if DRAG:
        lanes[WD * LANES + i] += dwd
    lanes[STEPS * LANES + i] += 1.0


def _event_values(lanes, i, h, settings, shared):
    """One trial step h from lane i's state and every event function after it:
    ``(bounded, exit_lo, exit_hi, contact, reversal)``, each function > 0
    before its event and <= 0 once it has happened.  ``bounded`` is False where
    the state stops being finite, passes the speed bound, or the step's
    friction work comes out negative (within a mode its integrand is
    mu |n| |v| >= 0: a step so long that its stages leave the mode's signs)."""
    x1, v1, dw, dk, dwd = trial_step(lanes, i, h, shared)
    fp1, fpp1 = ramp_slope_curvature(x1, lanes[P0 * LANES + i], lanes[P1 * LANES + i],
                                     lanes[P2 * LANES + i], lanes[P3 * LANES + i], shared)
    bounded = (math.isfinite(x1) and math.isfinite(v1) and math.isfinite(fp1)
               and math.isfinite(fpp1) and math.isfinite(dw) and math.isfinite(dk)
               and v1 * v1 <= lanes[VLIM2 * LANES + i] and dw >= 0.0)
    if DRAG:  # drag's work as friction's: finite and >= 0 within a mode
        bounded = bounded and math.isfinite(dwd) and dwd >= 0.0
    contact = (lanes[SN * LANES + i] * normal_term(v1, fpp1, lanes[G * LANES + i])
               if CHECK_CONTACT else 1.0)
    d = lanes[D * LANES + i]
    exit_lo = x1 - settings[SET_XLO]
    exit_hi = settings[SET_XHI] - x1
    # still on the end it started from, moving inward (explicit Euler's first
    # step from rest does not move x): not an exit
    if exit_lo == 0.0 and d > 0.0:
        exit_lo = 1.0
    if exit_hi == 0.0 and d < 0.0:
        exit_hi = 1.0
    return bounded, exit_lo, exit_hi, contact, d * v1


def _event_value(kind, lanes, i, h, settings, shared):
    """Event function ``kind`` after a trial step h (EV_DIVERGED: +1 while the
    state is bounded, -1 after; it is located by bisection)."""
    bounded, exit_lo, exit_hi, contact, reversal = event_values(lanes, i, h, settings, shared)
    if kind == EV_REVERSAL:
        return reversal
    if kind == EV_EXIT_HI:
        return exit_hi
    if kind == EV_EXIT_LO:
        return exit_lo
    if kind == EV_CONTACT:
        return contact
    return 1.0 if bounded else -1.0


def _start_value(kind, lanes, i, settings):
    """Event function at step size 0 (the step start), without a trial step."""
    if kind == EV_REVERSAL:
        return lanes[D * LANES + i] * lanes[V * LANES + i]
    if kind == EV_EXIT_HI:
        return settings[SET_XHI] - lanes[X * LANES + i]
    if kind == EV_EXIT_LO:
        return lanes[X * LANES + i] - settings[SET_XLO]
    if kind == EV_CONTACT:
        n = normal_term(lanes[V * LANES + i], lanes[FPP * LANES + i], lanes[G * LANES + i])
        return lanes[SN * LANES + i] * n
    return 1.0


def _locate_event(kind, lanes, i, h_end, value_end, settings, shared):
    """Smallest step size in (0, h_end] at which event ``kind`` has happened.

    Illinois (modified regula falsi) on the step size: each evaluation is one
    step of the scene's own method from the step start, so the event is found
    to the method's accuracy and the root to rounding.  Returns the bracket end
    on the event side, so the event condition holds exactly where it is applied.
    """
    a = 0.0
    fa = start_value(kind, lanes, i, settings)
    if not fa > 0.0:
        return 0.0
    b = h_end
    fb = value_end
    # a residual this small is rounding: the root is found (a linear event
    # function, as in Euler's steps, is hit in one or two iterations)
    tolerance = 1e-15 * (abs(fa) + abs(fb)) if math.isfinite(fb) else 0.0
    side = 0
    for _ in range(200):
        if kind == EV_DIVERGED or not math.isfinite(fb):
            c = 0.5 * (a + b)
        else:
            c = (a * fb - b * fa) / (fb - fa)
            if not (a < c < b):
                c = 0.5 * (a + b)
        if not (a < c < b):
            break  # the bracket is down to adjacent floats
        fc = event_value(kind, lanes, i, c, settings, shared)
        if fc > 0.0:
            a = c
            fa = fc
            if side == 1:
                fb *= 0.5
            side = 1
        else:
            b = c
            fb = fc
            if side == -1:
                fa *= 0.5
            side = -1
            if fc >= -tolerance:
                break
        if b - a <= 4.0e-16 * h_end:
            break
    return b


def _finish_lane(lanes, i, status, x_lift, outputs, shared):
    """Write lane i's trajectory to the outputs; the lane becomes empty."""
    j = np.int64(lanes[TRAJ * LANES + i])
    x = lanes[X * LANES + i]
    v = lanes[V * LANES + i]
    x_paper = np.nan
    if PAPER_CRITERION:
        paper_scan(lanes, i, x, shared)
        x_paper = lanes[XP * LANES + i]
        if status == st.LIFTED_OFF and math.isnan(x_paper):
            x_paper = x_lift  # n = 0 there: y'' = -g, so eq. (26) holds too
    p0 = lanes[P0 * LANES + i]
    p1 = lanes[P1 * LANES + i]
    p2 = lanes[P2 * LANES + i]
    p3 = lanes[P3 * LANES + i]
    fp, fpp = ramp_slope_curvature(x, p0, p1, p2, p3, shared)
    f = ramp_height(x, p0, p1, p2, p3, shared)
    energy_end = specific_energy(f, fp, v, lanes[G * LANES + i])
    if not energy_end <= lanes[ELIM * LANES + i]:
        status = st.DIVERGED  # whatever event ended it, the energy says the step was too large
    path = lanes[S * LANES + i] + lanes[D * LANES + i] * (x - lanes[XM * LANES + i])
    outputs[OUT_STATUS, j] = status
    outputs[OUT_T, j] = lanes[T * LANES + i]
    outputs[OUT_X, j] = x
    outputs[OUT_V, j] = v
    outputs[OUT_WORK, j] = lanes[W * LANES + i]
    outputs[OUT_ENERGY_LOSS, j] = lanes[E0 * LANES + i] - energy_end
    outputs[OUT_PATH, j] = path
    # mean f'' over the path; its limit f''(x0) where nothing was travelled
    if CONSTANT_CURVATURE:  # the mean of a constant
        outputs[OUT_CONVEXITY, j] = lanes[FPP0 * LANES + i]
    else:
        curvature = lanes[K * LANES + i]
        if not ADAPTIVE:  # the last mode's, not yet banked (_mode_curvature)
            curvature += mode_curvature(lanes, i, x, shared)
        outputs[OUT_CONVEXITY, j] = curvature / path if path > 0.0 else lanes[FPP0 * LANES + i]
    outputs[OUT_NREV, j] = lanes[NREV * LANES + i]
    outputs[OUT_XLIFT, j] = x_lift
    outputs[OUT_XLIFT_PAPER, j] = x_paper
    outputs[OUT_STEPS, j] = lanes[STEPS * LANES + i]
    outputs[OUT_NREJ, j] = lanes[NREJ * LANES + i]
    outputs[OUT_WORK_ERROR, j] = lanes[EEST * LANES + i]
    outputs[OUT_DRAG_WORK, j] = lanes[WD * LANES + i]
    outputs[OUT_PROJECTED, j] = lanes[EPROJ * LANES + i]
    make_empty(lanes, i)


def _new_lanes():
    """A block of LANES empty lanes and its tile scratch (nothing cached),
    starting on a cache line (``jit.aligned_zeros``)."""
    lanes = aligned_zeros(N_LANE_FIELDS * LANES + N_SCRATCH)
    for i in range(LANES):
        make_empty(lanes, i)
    lanes[N_LANE_FIELDS * LANES:] = np.nan
    return lanes


def _make_empty(lanes, i):
    """Mark lane i empty: D = 0 fails d * v1 > 0, so it never steps."""
    lanes[TRAJ * LANES + i] = -1.0
    lanes[D * LANES + i] = 0.0
    lanes[X * LANES + i] = 0.0
    lanes[V * LANES + i] = 0.0
    lanes[H * LANES + i] = 0.0
    lanes[PENDING * LANES + i] = 0.0


def _set_mode(lanes, i, direction, settings):
    """Direction of motion and signed friction coefficient of the coming mode."""
    lanes[D * LANES + i] = direction
    lanes[Q * LANES + i] = direction * lanes[MUK * LANES + i] * lanes[SN * LANES + i]
    if not ADAPTIVE:  # the vector loop's forms of D and Q (see layout)
        lanes[DSIGN * LANES + i] = -0.0 if direction < 0.0 else 0.0
        lanes[QH * LANES + i] = settings[SET_DT] * lanes[Q * LANES + i]
        lanes[AHEAD * LANES + i] = settings[SET_XHI] if direction > 0.0 else settings[SET_XLO]
    if ADAPTIVE:  # the first stage of the coming step (f', f'' are current)
        n = normal_term(lanes[V * LANES + i], lanes[FPP * LANES + i], lanes[G * LANES + i])
        lanes[A1 * LANES + i] = acceleration(n, lanes[FP * LANES + i], lanes[Q * LANES + i])
        if DRAG:  # as steppers._with_drag
            v = lanes[V * LANES + i]
            kd = drag_rate(v, lanes[FP * LANES + i], lanes[DRAG_B * LANES + i],
                           lanes[DRAG_C * LANES + i], direction, DRAG_LINEAR, DRAG_QUADRATIC)
            lanes[A1 * LANES + i] = fma(-kd, v, lanes[A1 * LANES + i])


def _load_lane(lanes, i, j, inputs, settings, outputs, shared):
    """Start trajectory j in lane i.  Returns True if it is running, False if
    it finished at t = 0 (stuck, exited or lifted off at the start)."""
    x = inputs[IN_X0, j]
    v = inputs[IN_V0, j]
    g = inputs[IN_G, j]
    p0 = inputs[IN_P0, j]
    p1 = inputs[IN_P1, j]
    p2 = inputs[IN_P2, j]
    p3 = inputs[IN_P3, j]
    x_lo = settings[SET_XLO]
    x_hi = settings[SET_XHI]
    fp, fpp = ramp_slope_curvature(x, p0, p1, p2, p3, shared)
    f = ramp_height(x, p0, p1, p2, p3, shared)
    lanes[TRAJ * LANES + i] = j
    lanes[X * LANES + i] = x
    lanes[V * LANES + i] = v
    lanes[FP * LANES + i] = fp
    lanes[FPP * LANES + i] = fpp
    lanes[FPP0 * LANES + i] = fpp
    lanes[G * LANES + i] = g
    lanes[P0 * LANES + i] = p0
    lanes[P1 * LANES + i] = p1
    lanes[P2 * LANES + i] = p2
    lanes[P3 * LANES + i] = p3
    lanes[MUK * LANES + i] = inputs[IN_MUK, j]
    lanes[MUS * LANES + i] = inputs[IN_MUS, j]
    lanes[DRAG_B * LANES + i] = inputs[IN_DRAG_B, j] if DRAG_LINEAR else 0.0
    lanes[DRAG_C * LANES + i] = inputs[IN_DRAG_C, j] if DRAG_QUADRATIC else 0.0
    lanes[WD * LANES + i] = 0.0
    lanes[W * LANES + i] = 0.0
    lanes[S * LANES + i] = 0.0
    lanes[K * LANES + i] = 0.0
    lanes[STEPS * LANES + i] = 0.0
    lanes[NREV * LANES + i] = 0.0
    lanes[CASCADE * LANES + i] = 0.0
    lanes[NREJ * LANES + i] = 0.0
    lanes[EEST * LANES + i] = 0.0
    lanes[EPROJ * LANES + i] = 0.0
    lanes[PENDING * LANES + i] = 0.0
    lanes[FRESH * LANES + i] = 0.0
    lanes[D * LANES + i] = 0.0
    if PAPER_CRITERION:
        lanes[XP * LANES + i] = np.nan
        lanes[PXM * LANES + i] = x
    rebase(lanes, i, 0.0, settings, shared)
    lanes[E0 * LANES + i] = specific_energy(f, fp, v, g)
    # divergence bound: the speed can never exceed what the energy allows
    scratch = N_LANE_FIELDS * LANES
    if not (lanes[scratch + RANGE_P0] == p0 and lanes[scratch + RANGE_P1] == p1
            and lanes[scratch + RANGE_P2] == p2 and lanes[scratch + RANGE_P3] == p3):
        f_low = math.inf
        f_high = -math.inf
        spacing = (x_hi - x_lo) / (N_RANGE_SAMPLES - 1)
        for k in range(N_RANGE_SAMPLES):
            fs = ramp_height(x_lo + spacing * k, p0, p1, p2, p3, shared)
            f_low = min(f_low, fs)
            f_high = max(f_high, fs)
        lanes[scratch + RANGE_P0] = p0
        lanes[scratch + RANGE_P1] = p1
        lanes[scratch + RANGE_P2] = p2
        lanes[scratch + RANGE_P3] = p3
        lanes[scratch + RANGE_FMIN] = f_low
        lanes[scratch + RANGE_FMAX] = f_high
    f_min = min(f, lanes[scratch + RANGE_FMIN])
    f_max = max(f, lanes[scratch + RANGE_FMAX])
    energy_scale = 0.5 * v * v * (1.0 + fp * fp) + g * (f_max - f_min)
    lanes[VLIM2 * LANES + i] = SPEED_BOUND_FACTOR ** 2 * 2.0 * energy_scale + 1e-12
    lanes[ELIM * LANES + i] = lanes[E0 * LANES + i] + ENERGY_RISE_FACTOR * energy_scale + 1e-12

    n = normal_term(v, fpp, g)
    lanes[SN * LANES + i] = 1.0 if (ONE_SIDED or n >= 0.0) else -1.0
    if v == 0.0:
        direction = departure_direction(fp, inputs[IN_MUS, j], inputs[IN_MUK, j], g)
        if direction == 0.0:
            finish_lane(lanes, i, st.STUCK, np.nan, outputs, shared)
            return False
    else:
        direction = 1.0 if v > 0.0 else -1.0
    if ONE_SIDED and n <= 0.0:
        finish_lane(lanes, i, st.LIFTED_OFF, x, outputs, shared)
        return False
    if (x >= x_hi and direction > 0.0) or (x <= x_lo and direction < 0.0):
        finish_lane(lanes, i, st.EXITED, np.nan, outputs, shared)
        return False
    set_mode(lanes, i, direction, settings)
    if ADAPTIVE:
        start_adaptive(lanes, i, settings, shared)
    return True


def _resolve_lane(lanes, i, settings, outputs, shared):
    """Handle the step of lane i that raised an event.  Returns True if the
    trajectory goes on (new mode), False if it finished."""
    h = settings[SET_DT]
    t_now = current_time(lanes, i, h)
    lanes[CASCADE * LANES + i] += 1.0
    if lanes[CASCADE * LANES + i] > MAX_EVENT_CASCADE:
        rebase(lanes, i, t_now, settings, shared)
        finish_lane(lanes, i, st.DIVERGED, np.nan, outputs, shared)
        return False
    if not CARRY_SLOPE:
        refresh_slope(lanes, i, shared)  # the vector loop did not store f', f''
    # 1. the largest usable step: where the state stays finite and bounded
    h_end = h
    bounded, exit_lo, exit_hi, contact, reversal = event_values(lanes, i, h, settings, shared)
    if LINEAR_EVENTS and bounded and contact > 0.0:  # the whole step is usable
        return resolve_linear(lanes, i, t_now, exit_lo, exit_hi, reversal, settings, outputs, shared)
    if not bounded:
        # Most often an event came first: a step that stops early, whose later
        # stages run on past the stop with the mode's signs, ends with
        # friction work < 0.  The earliest event that shows at the step's
        # end, located on [0, h], is a usable end if the state is bounded
        # there; only otherwise is the bound itself bisected (to rounding:
        # about 50 trial steps).
        h_end = locate_earliest(lanes, i, h, exit_lo, exit_hi, contact, reversal, settings,
                                shared)
        if h_end > 0.0:
            bounded, exit_lo, exit_hi, contact, reversal = event_values(lanes, i, h_end, settings,
                                                                        shared)
            if not (bounded and min(exit_lo, exit_hi, contact, reversal) <= 0.0):
                h_end = h  # no usable end found this way: bisect the bound
                bounded = False
    if not bounded:
        diverged = np.int64(EV_DIVERGED)  # one argument type for every call: one compilation
        h_end = locate_event(diverged, lanes, i, h, -1.0, settings, shared)
        h_end = h_end * (1.0 - 1e-12)  # the first bad size; step back to a good one
        while h_end > 0.0 and event_value(diverged, lanes, i, h_end, settings, shared) <= 0.0:
            h_end *= 0.5
        bounded, exit_lo, exit_hi, contact, reversal = event_values(lanes, i, h_end, settings, shared)
    # 2. the earliest event within [0, h_end] (ties: the order below)
    values = (exit_lo, exit_hi, contact, reversal)  # the order of EV_EXIT_LO .. EV_REVERSAL
    best_kind = EV_NONE
    best_h = h_end
    if h_end > 0.0:
        for k in range(4):
            value = values[k]
            if value <= 0.0:
                kind = np.int64(EV_EXIT_LO + k)
                h_k = locate_event(kind, lanes, i, h_end, value, settings, shared)
                if best_kind == EV_NONE or h_k < best_h:
                    best_h = h_k
                    best_kind = kind
    # A long step can hold two events of which its end shows only one (a
    # block that passes the domain's end and comes back shows only its
    # reversal): check every event function at the earliest event found.
    checked_h = -1.0  # the step at which bounded_there was evaluated
    bounded_there = True
    for _ in range(4):
        if best_kind == EV_NONE or best_h <= 0.0:
            break
        bounded_there, exit_lo, exit_hi, contact, reversal = event_values(lanes, i, best_h,
                                                                          settings, shared)
        checked_h = best_h
        values = (exit_lo, exit_hi, contact, reversal)
        earlier = False
        for k in range(4):
            kind = np.int64(EV_EXIT_LO + k)
            if kind != best_kind and not values[k] > 0.0:
                best_h = locate_event(kind, lanes, i, best_h, values[k], settings, shared)
                best_kind = kind
                earlier = True
                break
        if not earlier:
            break
    if best_kind != EV_NONE and best_h > 0.0:
        if checked_h != best_h:
            bounded_there = event_values(lanes, i, best_h, settings, shared)[0]
        if not bounded_there:
            # the partial step to the event is itself unusable (a step far too
            # long: e.g. its friction work comes out negative)
            rebase(lanes, i, t_now, settings, shared)
            finish_lane(lanes, i, st.DIVERGED, np.nan, outputs, shared)
            return False
    return take_event(lanes, i, best_kind, best_h, h_end, t_now, settings, outputs, shared)


def _locate_earliest(lanes, i, h, exit_lo, exit_hi, contact, reversal, settings, shared):
    """The smallest step size in (0, h] at which one of the event functions
    whose values after a step h are given (<= 0: it happened) has happened;
    0 if none did."""
    values = (exit_lo, exit_hi, contact, reversal)  # the order of EV_EXIT_LO .. EV_REVERSAL
    earliest = 0.0
    for k in range(4):
        value = values[k]
        if value <= 0.0:
            h_k = locate_event(np.int64(EV_EXIT_LO + k), lanes, i, h, value, settings, shared)
            if h_k > 0.0 and (earliest == 0.0 or h_k < earliest):
                earliest = h_k
    return earliest


def _take_event(lanes, i, best_kind, best_h, h_end, t_now, settings, outputs, shared):
    """The end of resolving lane i's frozen step, whose earliest event is
    ``best_kind`` at step size ``best_h`` (EV_NONE: none within the usable
    size ``h_end``): t_max may come first; then take the partial step to the
    event and apply it.  Returns True if the trajectory goes on."""
    h = settings[SET_DT]
    h_time = settings[SET_TMAX] - t_now
    if h_time < best_h or (best_kind == EV_NONE and h_time <= h_end):
        best_h = max(h_time, 0.0)
        best_kind = EV_TIMEOUT
    if best_kind == EV_NONE and h_end >= h:
        # frozen only by the step limit, with a rounding's worth of time left
        apply_step(lanes, i, h, shared)
        lanes[CASCADE * LANES + i] = 0.0
        rebase(lanes, i, t_now + h, settings, shared)
        refresh_slope(lanes, i, shared)
        return True
    if best_kind == EV_NONE:
        # the state goes bad within this step and no event comes first
        rebase(lanes, i, t_now, settings, shared)
        finish_lane(lanes, i, st.DIVERGED, np.nan, outputs, shared)
        return False
    if best_h > 0.0:
        apply_step(lanes, i, best_h, shared)
    return apply_event(lanes, i, best_kind, t_now + best_h, settings, outputs, shared)


def _resolve_linear(lanes, i, t_now, exit_lo, exit_hi, reversal, settings, outputs, shared):
    """:func:`_resolve_lane` for explicit Euler, whose full step is bounded
    and keeps contact.  Within the step x(h) = x + h v and v(h) = v + h a
    are linear in h (a is the step start's, drag included), so an exit or a
    reversal happens at one h, found in closed form instead of by root
    finding; each is monotone within the step, so the earliest is the first."""
    h = settings[SET_DT]
    x = lanes[X * LANES + i]
    v = lanes[V * LANES + i]
    best_kind = EV_NONE
    best_h = h
    # ties go to the first in the order exit_lo, exit_hi, reversal (as in _resolve_lane)
    # (v = 0: a departure from rest, whose first step does not move x; it
    # can only exit where it already is, at h = 0)
    if exit_lo <= 0.0:
        best_kind = np.int64(EV_EXIT_LO)
        best_h = min((settings[SET_XLO] - x) / v, h) if v != 0.0 else 0.0
    if exit_hi <= 0.0:
        h_hi = min((settings[SET_XHI] - x) / v, h) if v != 0.0 else 0.0
        if best_kind == EV_NONE or h_hi < best_h:
            best_kind = np.int64(EV_EXIT_HI)
            best_h = h_hi
    if reversal <= 0.0:
        n = normal_term(v, lanes[FPP * LANES + i], lanes[G * LANES + i])
        a = acceleration(n, lanes[FP * LANES + i], lanes[Q * LANES + i])
        if DRAG:  # as in steppers.euler_step (zero drag leaves a exactly as it is)
            kd = drag_rate(v, lanes[FP * LANES + i], lanes[DRAG_B * LANES + i],
                           lanes[DRAG_C * LANES + i], lanes[D * LANES + i], DRAG_LINEAR, DRAG_QUADRATIC)
            a = fma(-kd, v, a)
        h_stop = min(-v / a, h)
        if best_kind == EV_NONE or h_stop < best_h:
            best_kind = np.int64(EV_REVERSAL)
            best_h = h_stop
    # the whole step is usable: h_end = h
    return take_event(lanes, i, best_kind, max(best_h, 0.0), h, t_now, settings, outputs, shared)


def _apply_event(lanes, i, kind, t_event, settings, outputs, shared):
    """Apply an event of ``kind`` to lane i, which is at the event (at time
    t_event; t_max for a timeout).  Returns True if the trajectory goes on."""
    if kind == EV_TIMEOUT:
        t_event = settings[SET_TMAX]
    if kind == EV_EXIT_HI:
        lanes[X * LANES + i] = settings[SET_XHI]
    elif kind == EV_EXIT_LO:
        lanes[X * LANES + i] = settings[SET_XLO]
    elif kind == EV_REVERSAL:
        # Within a mode x moves only in direction d.  A stop located to the
        # rounding of the step, in a mode shorter than that (a launch at
        # v0 = -1e-200), can leave x a rounding behind the mode's start.
        if lanes[D * LANES + i] * (lanes[X * LANES + i] - lanes[XM * LANES + i]) < 0.0:
            lanes[X * LANES + i] = lanes[XM * LANES + i]
    if PAPER_CRITERION:  # the mode ends here: look for eq. (26) along it
        paper_scan(lanes, i, lanes[X * LANES + i], shared)
    rebase(lanes, i, t_event, settings, shared)
    if kind == EV_TIMEOUT:
        finish_lane(lanes, i, st.TIMEOUT, np.nan, outputs, shared)
        return False
    if kind == EV_EXIT_HI or kind == EV_EXIT_LO:
        finish_lane(lanes, i, st.EXITED, np.nan, outputs, shared)
        return False
    x = lanes[X * LANES + i]
    fp, fpp = refresh_slope(lanes, i, shared)
    if kind == EV_CONTACT:
        if ONE_SIDED:
            finish_lane(lanes, i, st.LIFTED_OFF, x, outputs, shared)
            return False
        # two-sided: the sign inside |n| flips and the motion goes on
        lanes[SN * LANES + i] = -lanes[SN * LANES + i]
        lanes[FRESH * LANES + i] = 1.0  # n starts from 0 (adaptive.py's contact control)
        set_mode(lanes, i, lanes[D * LANES + i], settings)
        return True
    # reversal: v reached 0 and the rest rule decides
    lanes[V * LANES + i] = 0.0
    lanes[SN * LANES + i] = 1.0  # at rest n = g > 0
    direction = departure_direction(fp, lanes[MUS * LANES + i], lanes[MUK * LANES + i],
                                    lanes[G * LANES + i])
    if direction == 0.0:
        finish_lane(lanes, i, st.STUCK, np.nan, outputs, shared)
        return False
    if direction != lanes[D * LANES + i]:
        lanes[NREV * LANES + i] += 1.0
    set_mode(lanes, i, direction, settings)
    return True


def _paper_holds(lanes, i, x, shared):
    """Whether the paper's lift-off criterion (eq. 26, y'' <= -g) holds at x
    in lane i's mode.  y'' + g = n (1 - q f') / (1 + f'^2) with q = d mu_k s_n,
    and n keeps its sign s_n within a mode: so it holds where
    s_n (1 - q f'(x)) <= 0, a condition on x alone."""
    fp, _ = ramp_slope_curvature(x, lanes[P0 * LANES + i], lanes[P1 * LANES + i],
                                 lanes[P2 * LANES + i], lanes[P3 * LANES + i], shared)
    return lanes[SN * LANES + i] * (1.0 - lanes[Q * LANES + i] * fp) <= 0.0


def _paper_scan(lanes, i, x_end, shared):
    """A diagnostic beside the contact-force criterion (docs/physics.md §1.3): the first
    x of the mode's path from PXM to ``x_end`` where eq. (26) holds, into XP
    unless it held before.  Because the condition depends on x alone within
    a mode, it is found by sampling f' along the path and bisecting on x, to
    rounding, without touching the integration.  It differs from the
    contact-force lift-off where d mu_k f' > 1 (sliding up a steep slope)."""
    x_start = lanes[PXM * LANES + i]
    lanes[PXM * LANES + i] = x_end
    if not math.isnan(lanes[XP * LANES + i]) or lanes[D * LANES + i] == 0.0:
        return
    previous = x_start
    for k in range(PAPER_SAMPLES + 1):
        x = x_end if k == PAPER_SAMPLES else x_start + (x_end - x_start) * (k / PAPER_SAMPLES)
        if _paper_holds(lanes, i, x, shared):
            if k > 0:
                # bisect [previous (does not hold), x (holds)] down to adjacent floats
                outside = previous
                for _ in range(1100):
                    middle = 0.5 * (outside + x)
                    if middle == outside or middle == x:
                        break
                    if _paper_holds(lanes, i, middle, shared):
                        x = middle
                    else:
                        outside = middle
            lanes[XP * LANES + i] = x
            return
        previous = x


def _fill_lane(lanes, i, next_j, stop, inputs, settings, outputs, shared):
    """Load trajectories into lane i until one runs; returns the next index."""
    while next_j < stop:
        j = next_j
        next_j += 1
        if load_lane(lanes, i, j, inputs, settings, outputs, shared):
            break
    return next_j


def _scan_lanes(lanes, history, settings, outputs, shared, n_substeps, n_active):
    """After ``n_substeps`` vector steps: resolve lanes with a pending event
    and stop lanes past the speed bound.  Returns the lanes that finished
    (now empty) as bits, lane k at bit k (with LANES > 64: every bit set
    where any lane finished), so that the refill visits only those.

    A vectorised pass over each word of up to 64 lanes books what every lane
    needs booked and sets one bit per lane that needs attention; the scalar
    work then visits only those lanes, found by their bits (on an event-rich
    sweep one or two of 64 lanes in most blocks: a scalar visit of every
    lane would cost about as much as the block's vector steps).  For fixed
    steps a lane whose steps were all clean, with its t_max step limit
    beyond the block (and, for first-order methods, its last state short of
    the end ahead), takes the block's last state and its steps; any other
    lane is pending: the scalar work finds its first unclean step (or the
    limit) in the history banks, takes the state before it and resolves the
    event from there.  A lane that stepped in the block has made progress:
    its event cascade count restarts."""
    freed = np.uint64(0)
    # the block's last state (SUBSTEPS, a constant: constant offsets, which vectorise)
    last = HIST + N_HIST * SUBSTEPS
    for word in range((LANES + 63) // 64):  # a constant count: one word for 64 lanes
        base = 64 * word
        bits = np.uint64(0)
        for k in range(min(64, n_active - base)):
            i = base + k
            if ADAPTIVE:
                v = lanes[V * LANES + i]
                pending = lanes[PENDING * LANES + i] > 0.0
                stepped = lanes[STEPS * LANES + i] > lanes[BLOCK_STEPS * LANES + i]
            else:
                x_end = history[(last + HIST_X) * LANES + i]
                clean = (lanes[CLEAN * LANES + i] == 0.0) & (
                    lanes[LIMIT * LANES + i] - lanes[STEPS * LANES + i] >= n_substeps)
                if MONOTONE_STEP:  # the exit test left out of the vector loop
                    clean = clean & (flip_sign(lanes[AHEAD * LANES + i] - x_end,
                                               lanes[DSIGN * LANES + i]) > 0.0)
                # the block's last state, whether clean or not (plain
                # stores: a select against the stored value would be a
                # masked store); the scalar work takes a lane that was not
                # back to the start of its first unclean step
                v = history[(last + HIST_V) * LANES + i]
                lanes[X * LANES + i] = x_end
                lanes[V * LANES + i] = v
                lanes[W * LANES + i] = history[(last + HIST_W) * LANES + i]
                if DRAG:
                    lanes[WD * LANES + i] = history[(last + HIST_WD) * LANES + i]
                lanes[STEPS * LANES + i] += n_substeps if clean else 0.0
                lanes[CLEAN * LANES + i] = 0.0 if clean else -1.0  # for the scalar work
                pending = not clean
                stepped = clean
            # a product, not a select against the loaded value (a masked store)
            lanes[CASCADE * LANES + i] *= 0.0 if stepped else 1.0
            attention = (lanes[TRAJ * LANES + i] >= 0.0) & (
                pending | (v * v > lanes[VLIM2 * LANES + i]))
            bits |= np.uint64(1 if attention else 0) << np.uint64(k)
        while bits != 0:
            k = np.int64(trailing_zeros(bits))
            bits &= bits - np.uint64(1)
            i = base + k
            if ADAPTIVE:
                clean = lanes[PENDING * LANES + i] == 0.0
            else:
                clean = lanes[CLEAN * LANES + i] == 0.0  # took the block: past the speed bound
                if not clean:
                    # the clean steps before the first unclean one or the step limit
                    left = lanes[LIMIT * LANES + i] - lanes[STEPS * LANES + i]
                    taken = clean_steps(lanes, history, i, settings, shared,
                                        np.int64(min(max(left, 0.0), float(n_substeps))))
                    restore_bank(lanes, history, i, taken)
                    lanes[STEPS * LANES + i] += taken
                    if taken > 0:
                        lanes[CASCADE * LANES + i] = 0.0
                    if CARRY_SLOPE:
                        # the vector loop carried f', f'' on past this state
                        # (from the step start by the angle sum where
                        # STAGE_FROM_START): evaluated afresh at x, as
                        # _trace_one does
                        refresh_slope(lanes, i, shared)
                    if taken == n_substeps:  # (a lane is pending for an unclean step)
                        v = lanes[V * LANES + i]
                        if not v * v > lanes[VLIM2 * LANES + i]:
                            continue
                        clean = True
            # this lane's bit in the mask of finished lanes (all bits past 64 lanes)
            lane_bit = np.uint64(1) << np.uint64(k) if LANES <= 64 else ~np.uint64(0)
            if clean:
                # past the speed bound: the step is far too large
                rebase(lanes, i, current_time(lanes, i, settings[SET_DT]), settings, shared)
                finish_lane(lanes, i, st.DIVERGED, np.nan, outputs, shared)
                freed |= lane_bit
            elif not resolve_lane(lanes, i, settings, outputs, shared):
                freed |= lane_bit
    return freed



def _compact_lanes(lanes):
    """Move running lanes to the front, in order; returns how many run.

    Used once a tile has no trajectories left to load, so that the vector loop
    stops stepping empty lanes at the tile's tail (and on small sweeps).  A
    trajectory's arithmetic does not depend on its lane, so results do not
    change."""
    running = 0
    for i in range(LANES):
        if lanes[TRAJ * LANES + i] < 0.0:
            continue
        if running != i:
            for field in range(N_FIELDS):
                lanes[field * LANES + running] = lanes[field * LANES + i]
            make_empty(lanes, i)
        running += 1
    return running


def _active_span(running):
    """Lanes the vector loop covers for ``running`` running lanes at the front:
    rounded up to whole vector blocks, because stepping a few empty lanes in
    vector code costs far less than the scalar remainder loop would."""
    if running == 0:
        return 0
    return min(LANES, (running + VECTOR_BLOCK - 1) // VECTOR_BLOCK * VECTOR_BLOCK)


def _run_tile(start, stop, inputs, settings, outputs, shared):
    """Run trajectories start..stop-1 through one block of LANES lanes."""
    lanes = new_lanes()
    runtime_flags(lanes, settings)  # a general kernel's choices (general.py)
    # fixed steps: the states of a block's steps (see _advance_lanes)
    history = lanes
    next_j = start
    for i in range(LANES):
        next_j = fill_lane(lanes, i, next_j, stop, inputs, settings, outputs, shared)
    n_active = LANES if next_j < stop else active_span(compact_lanes(lanes))
    while n_active > 0:
        if ADAPTIVE:  # the step counts at the block's start (for CASCADE)
            for i in range(n_active):
                lanes[BLOCK_STEPS * LANES + i] = lanes[STEPS * LANES + i]
        else:
            start_block(lanes, n_active)
        if ADAPTIVE:
            advance_lanes(lanes, settings, shared, SUBSTEPS, n_active)
        else:
            advance_lanes(lanes, history, settings, shared, SUBSTEPS, n_active)
        freed = scan_lanes(lanes, history, settings, outputs, shared, SUBSTEPS, n_active)
        if freed == 0:
            continue
        if next_j < stop and LANES <= 64:
            # while trajectories are left every lane runs but those just
            # finished: refill them by their bits, in lane order
            while freed != 0:
                i = np.int64(trailing_zeros(freed))
                freed &= freed - np.uint64(1)
                next_j = fill_lane(lanes, i, next_j, stop, inputs, settings, outputs, shared)
        elif next_j < stop:
            for i in range(LANES):
                if lanes[TRAJ * LANES + i] < 0.0:
                    next_j = fill_lane(lanes, i, next_j, stop, inputs, settings, outputs, shared)
        if next_j >= stop:
            n_active = active_span(compact_lanes(lanes))


def _run_tiles(first_tile, stop_tile, tile_size, inputs, settings, outputs, shared):
    """Tiles first_tile .. stop_tile - 1 of the trajectories (columns of
    ``inputs``); ``threads.TiledKernel`` spreads the tiles over threads."""
    n = inputs.shape[1]
    for tile in range(first_tile, stop_tile):
        start = tile * tile_size
        stop = min(n, start + tile_size)
        run_tile(start, stop, inputs, settings, outputs, shared)


def _trace_one(j, inputs, settings, shared, every, trace):
    """Run trajectory j alone (lane 0) and record (t, x, v, W) at the start,
    every ``every`` steps and at every event, into ``trace`` (4, max_samples).
    Returns the number of samples written."""
    outputs = np.zeros((N_OUTPUTS, inputs.shape[1]))
    lanes = new_lanes()
    runtime_flags(lanes, settings)
    max_samples = trace.shape[1]
    h = settings[SET_DT]
    count = 0
    running = load_lane(lanes, 0, j, inputs, settings, outputs, shared)
    if max_samples > 0:
        trace[0, 0] = 0.0
        trace[1, 0] = inputs[IN_X0, j]
        trace[2, 0] = inputs[IN_V0, j]
        trace[3, 0] = 0.0
        count = 1
    while running:
        before = lanes[STEPS * LANES]
        if ADAPTIVE:  # a rejected attempt also takes no step
            attempt_once(lanes, 0, settings, shared)
            event = lanes[PENDING * LANES] > 0.0
        else:
            event = replay_lane(lanes, 0, settings, shared, 1) == 0
            if CARRY_SLOPE and event:
                # f', f'' afresh at x, as the scan does for a lane the vector
                # loop stopped: the event is resolved from the same values
                refresh_slope(lanes, 0, shared)
        stepped = lanes[STEPS * LANES] > before
        if stepped:
            lanes[CASCADE * LANES] = 0.0
        if event:
            running = resolve_lane(lanes, 0, settings, outputs, shared)
        if count < max_samples and (
                event or (stepped and np.int64(lanes[STEPS * LANES]) % every == 0)):
            if running:
                trace[0, count] = current_time(lanes, 0, h)
                trace[1, count] = lanes[X * LANES]
                trace[2, count] = lanes[V * LANES]
                trace[3, count] = lanes[W * LANES]
            else:
                trace[0, count] = outputs[OUT_T, j]
                trace[1, count] = outputs[OUT_X, j]
                trace[2, count] = outputs[OUT_V, j]
                trace[3, count] = outputs[OUT_WORK, j]
            count += 1
    return count


def _no_adaptive_start(lanes, i, settings, shared):
    """Fixed-step methods have no step-control state."""


def build_kernel(variant: KernelVariant, ramp_height_fn, ramp_slope_curvature_fn, *,
                 cache: bool = True):
    """Compile (or load from numba's on-disk cache) the kernels of one variant.

    ``variant`` (:class:`~rampwork.core.variant.KernelVariant`) holds every
    compile-time choice; ``ramp_height_fn`` and ``ramp_slope_curvature_fn``
    are its family's jitted functions (``variant.family`` names them
    uniquely); ``cache=False`` for functions that cannot be found again
    (user callables).  RK4 takes f', f'' at its stage points from those at
    the step's start where the family has such a function
    (``ramps.SLOPE_CURVATURE_NEAR``, ``steppers.STAGE_FROM_START``).  A
    closed-form variant is built by ``straight.build_closed_form``.  Returns ``(run_batch, trace_one)``:
    ``run_batch(inputs, settings, outputs, shared, tile_size)`` fills
    ``outputs`` (N_OUTPUTS, n) from ``inputs`` (N_INPUTS, n), tiles spread
    over threads; ``trace_one(j, inputs, settings, shared, every, trace)``
    records one.  Without drag the inputs' drag rows are ignored; without
    ``paper_criterion`` the OUT_XLIFT_PAPER row is NaN; ``friction=False``
    gives the same results but perhaps the sign of a zero;
    ``constant_curvature`` reports f'' itself as convexity_mean.  Fixed
    steps form the curvature integral per mode, exactly (``_mode_curvature``),
    not per step; the adaptive pairs integrate it (it is part of their error
    norm).
    """
    if variant.closed_form:
        return straight.build_closed_form(variant, ramp_height_fn, ramp_slope_curvature_fn,
                                          cache=cache)
    # fixed steps: the history banks of a block's steps, only the fields the
    # kernel integrates (not the curvature integral: _mode_curvature)
    drag = variant.drag or variant.runtime
    n_hist = 3 + drag
    n_lane_fields = (N_LANE_FIELDS if variant.adaptive
                     else HIST + n_hist * (variant.substeps + 1))
    # RK4's step in two lane loops (not in the general kernel, whose step
    # is chosen at run time); their values pass through N_CARRY fields
    # after the banks: constant offsets, as the lane fields'
    split = (None if variant.adaptive or variant.runtime or variant.unroll != 1
             or ramp_slope_curvature_fn not in SPLIT_STEP_FAMILIES
             else STEPPERS[variant.method].split)
    carry = n_lane_fields
    if split is not None:
        n_lane_fields += N_CARRY
    constants = {
        **variant.constants(),
        "ramp_height": ramp_height_fn,
        "ramp_slope_curvature": ramp_slope_curvature_fn,
        "STAGE_FROM_START": ramp_slope_curvature_fn in SLOPE_CURVATURE_NEAR,
        "ramp_slope_curvature_near": (SLOPE_CURVATURE_SHORT if variant.short_stages
                                      else SLOPE_CURVATURE_NEAR).get(ramp_slope_curvature_fn,
                                                                     steppers.no_stage_shortcut),
        # the lane array: fixed-step kernels leave out the adaptive bank B
        # (a smaller block stays in the L1 cache)
        "N_LANE_FIELDS": n_lane_fields,
        "N_HIST": n_hist, "HIST_WD": 3,
        "SPLIT_STEP": split is not None, "CARRY": carry,
        # every template calls `acceleration` by this global name
        "acceleration": acceleration if variant.friction else acceleration_frictionless,
    }
    name = variant.name
    if variant.runtime:  # general.py: the runtime flags after the lane scratch
        constants.update(N_SCRATCH=N_SCRATCH + general.N_RUNTIME, SET_RUNTIME=N_SETTINGS,
                         RUNTIME_BASE=n_lane_fields * variant.lanes + N_SCRATCH)

    def add(key, function, **options):
        if variant.runtime:
            function = general.read_at_run_time(function)
        constants[key] = specialise(function, f"{key}_{name}", constants, cache=cache, **options)
        return constants[key]

    # Helpers are only called from jitted code: no Python or C wrappers, and
    # no machine code of their own (jit.INTERNAL_OPTIONS).  The scalar
    # helpers allocate nothing, so they are compiled without numba's
    # reference counting: otherwise every call passing the lane array does
    # atomic incref/decref pairs, which cost more than the event arithmetic
    # itself (measured: 20-25 % of the whole run on an event-rich sweep).
    internal = {"internal": True}
    no_refcount = {"_nrt": False, **internal}
    add("runtime_flags", general._copy_runtime_flags if variant.runtime
        else general._no_runtime_flags, **no_refcount)
    add("lane_parameters", parameters._lane_parameters, **no_refcount)
    add("uniform_parameters", parameters._uniform_parameters, **no_refcount)

    if variant.adaptive:
        pair = ADAPTIVE_STEPPERS[variant.method]
        constants["PI_ALPHA"], constants["PI_BETA"] = pair.pi_gains
        constants["SWING_LIMIT2"] = pair.swing_limit ** 2
        for key, template in pair.helpers:
            add(key, template, **no_refcount)
        add("step", pair.step, **no_refcount)
        # a copy of its own for the scalar step to an event: a second call
        # site of `step` keeps LLVM from inlining it into the lane loop
        add("event_step", pair.step, **no_refcount)
        add("dense_output", pair.dense, **no_refcount)
        add("dense_point", pair.dense_point, **no_refcount)
        constants["error_norm2"] = pair.error_norm2  # jitted already: no scene constants
        constants["error_norm2_drag"] = pair.error_norm2_drag
        method_parts = (
            ("contact_holds", adaptive_parts._contact_holds),
            ("project_energy", adaptive_parts._project_energy),
            ("attempt", adaptive_parts._attempt),
            ("attempt_once", adaptive_parts._attempt_once),
            ("start_adaptive", adaptive_parts._start_adaptive),
            ("dense_value", adaptive_parts._dense_value),
            ("locate_dense", adaptive_parts._locate_dense),
            ("step_to_event", adaptive_parts._step_to_event),
        )
    else:
        add("_with_drag", steppers._with_drag, **no_refcount)
        # RK4's two parts, which its step calls (and the split vector loop)
        add("rk4_first_stages", steppers._rk4_first_stages, **no_refcount)
        add("rk4_last_stages", steppers._rk4_last_stages, **no_refcount)
        constants["first_stages"] = constants["rk4_first_stages"]
        constants["last_stages"] = constants["rk4_last_stages"]
        if variant.runtime:  # the method by its id in shared[1]
            for k, method in enumerate(STEPPERS.values()):
                add(f"STEP_{k}", method.step, **no_refcount)
            add("step", general._switch_step, **no_refcount)
        else:
            add("step", STEPPERS[variant.method].step, **no_refcount)
        method_parts = (
            ("start_value", _start_value), ("trial_step", _trial_step),
            ("event_values", _event_values), ("event_value", _event_value),
            ("locate_event", _locate_event), ("locate_earliest", _locate_earliest),
            ("apply_step", _apply_step),
            ("start_adaptive", _no_adaptive_start),
            ("checked_step", _checked_step), ("step_and_check", _step_and_check),
            ("first_stages_lane", _first_stages_lane), ("first_stages_all", _first_stages_all),
            ("fixed_step_lane", _fixed_step_lane),
            ("start_block", _start_block), ("replay_lane", _replay_lane),
            ("step_from_bank", _step_from_bank), ("clean_steps", _clean_steps),
            ("restore_bank", _restore_bank),
        )
    if variant.paper_criterion or variant.runtime:
        add("_paper_holds", _paper_holds, **no_refcount)
        add("paper_scan", _paper_scan, **no_refcount)
    for key, function in method_parts + (
        ("current_time", _current_time), ("mode_curvature", _mode_curvature), ("rebase", _rebase), ("make_empty", _make_empty),
        ("new_lanes", _new_lanes),
        ("set_mode", _set_mode), ("refresh_slope", _refresh_slope),
        ("finish_lane", _finish_lane), ("apply_event", _apply_event),
        ("take_event", _take_event), ("resolve_linear", _resolve_linear),
        ("load_lane", _load_lane),
        ("resolve_lane",
         adaptive_parts._resolve_lane_adaptive if variant.adaptive else _resolve_lane),
        ("fill_lane", _fill_lane),
        ("advance_lanes",
         adaptive_parts._advance_lanes_adaptive if variant.adaptive else _advance_lanes),
        ("scan_lanes", _scan_lanes), ("compact_lanes", _compact_lanes),
        ("active_span", _active_span), ("run_tile", _run_tile),
    ):
        options = dict(internal) if key in ("run_tile", "new_lanes") else dict(no_refcount)
        add(key, function, **options)
    run_batch = TiledKernel(add("run_tiles", _run_tiles))
    trace_one = add("trace_one", _trace_one)
    return run_batch, trace_one
