"""The lane kernel's vector part: fixed steps on every lane of a block.

Each lane's step has no data-dependent branch, so LLVM turns the loop over
lanes into vector code; every step's state goes to a history bank and the
event tests run beside the recurrence, not in it (``kernel.py`` says why).
A lane that was not clean is replayed from its history here, exactly, up to
its first unclean step (``_replay_lane``), and its event is resolved by the
scalar path (``kernel_events.py``).

Templates: their globals (``kernel_globals.py``) are bound per variant by
``kernel.build_kernel``.
"""

from __future__ import annotations

from .jit import flip_sign
from .physics import normal_term
from .layout import *  # noqa: F403 - the lane layout
from .kernel_globals import *  # noqa: F403 - the templates' globals, bound per variant


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
