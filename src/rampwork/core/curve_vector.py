"""One step of a block of curve lanes (docs/physics.md §5; the lane kernel
is core/curve_lanes.py): the vector loop, with no data-dependent branch, so
LLVM turns it into vector code.

Each lane takes the scene's own step (``curve_kernel._try_step``), the end
point ``X`` for the horizontal path, and the "clean" test: no event
condition fired (direction, ends, contact sign, joint), finite, no
vertical tangent crossed (cos phi keeps its sign, so ``|dX|`` is one
difference), not past ``t_max``, and for an adaptive pair an error norm
<= 1 (a rejected clean attempt is also taken here).  A clean step is
committed by selects, with the arithmetic of the scalar code in the same
order.  With ``LANE_EVENTS`` (the adaptive pairs), a step that is not
clean starts locating its event in the lane (curve_events.py: the bracket
in lane fields, each trial step a step of this loop beside the other
lanes'), and the lane goes to the scalar pass once the bracket is closed,
where ``curve_kernel._iterate`` commits the located step.  Any other step
freezes the lane (FLAG) until the next scalar pass, where ``_iterate``
takes it in full (fixed-step methods: the event located there too).

The function is a template: the names below are bound per scene by
``curve_lanes.build_curve_kernel``.
"""

from __future__ import annotations

import math

from . import curve_events as ce
from . import status as st
from .control import ERROR_FLOOR
from .curve_kernel import (  # the lane layout
    B, BRANCH, C, COSNOW, CURV, D, DISP, DPDSNOW, DRAGW, EPREV, EVENT, FLAG, G, HI, HN, INROW,
    JOINT, JOINT2, KAPNOW, LANES, LO, MANY_JOINTS, MUK, NREJ, NUMIN, P, PATH, PATHX, REJB, S0,
    S1, S2, SINNOW, SMALLEST_STEP, SN, STATUS, STEPS, T, U, WORK, XNOW, branch, fresh)
from .curve_steppers import normal_along_n
from .curve_track import branch_near

# bound per scene by curve_lanes.build_curve_kernel (compile-time constants)
curve_frame = curve_point = try_step = accepted_factor = rejected_factor = lane_trial = None
ADAPTIVE = DRAG = False
#: the family's point is loop-free and defined at every p, NaN included
#: (curve_families.CurveFamily.point_anywhere)
POINT_ANYWHERE = False
JOINTS = 0  # the curve's joints (0, 1, 2 or MANY_JOINTS)
#: events located in the lanes (curve_events.py): each trial step a step of
#: the vector loop, the scalar pass committing the located step.  On for the
#: adaptive pairs, whose scalar trial steps were ~75 % of their time
#: (benchmarks/README.md, curves.py, i20-speed-8 and i20-speed-9)
LANE_EVENTS = False
#: lanes per vector loop: a constant trip count, so that LLVM proves the
#: fields' accesses disjoint (fields lie LANES apart) and vectorises; bound
#: per scene by curve_lanes.build_curve_kernel, this or BLOCK_FIRST_ORDER
BLOCK = 16
#: BLOCK for the first-order methods: one AVX-512 vector; Euler's step then
#: fits the 32 vector registers, where two interleaved vectors (16) spilled
#: and ran 1.10-1.15x slower (RK4: 8 ran 0.75-1.06x of 16; benchmarks/README.md,
#: curves.py, i20-speed-10)
BLOCK_FIRST_ORDER = 8


def _vector_step(all_lanes, first, shared, t_max, side, rtol, atol):
    """The next step of lanes first .. first + BLOCK - 1, each where it is
    clean, committed by selects (see the module docstring); otherwise FLAG
    is set and nothing else changes.  The loop is here, not in the caller
    (a step this long is not inlined, and a loop that calls it stays
    scalar), on a view from lane ``first`` on: LLVM sees its indices
    nonnegative, so there is no wraparound to keep it from vectorising."""
    lanes = all_lanes[first:]
    for i in range(BLOCK):
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
            if JOINTS == MANY_JOINTS:
                s3, joint = branch_near(p, d, shared, int(joint), int(lanes[JOINT2 * LANES + i]),
                                        s3)
            elif JOINTS == 2:
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
        event = (lanes[EVENT * LANES + i] != 0.0) if LANE_EVENTS else False  # (never set without)
        locating = free & event
        if LANE_EVENTS:  # a locating lane's step: its bracket's next trial
            step_size = lane_trial(lanes, i, locating, step_size, p, d, sn, p_lo, p_hi, joint)
        p1, u1, dw, dk, dx, dwd, err, nu1, clean, frame1, rough = try_step(
            p, u, q, d, sn, step_size, g, s0, s1, s2, s3, shared, b, c, p_lo, p_hi, joint, rtol,
            atol, frame)
        sin1, cos1, kappa1, dp_ds1 = frame1
        # X at the step's end, as curve_kernel._x_travelled takes it: a committed
        # step's p1 lies within the ends, so where the family's point is safe at
        # any p (POINT_ANYWHERE) it is evaluated at p1, the frame's own argument,
        # and the compiler shares their work (the loop's p / R and its sincos);
        # otherwise a NaN end, never committed, is evaluated at p_lo (a family's
        # point may loop on it)
        if POINT_ANYWHERE:
            x1, _ = curve_point(p1, s0, s1, s2, s3, shared)
        else:
            p_end = min(max(p1, p_lo), p_hi)
            p_end = p_end if p_end == p_end else p_lo
            x1, _ = curve_point(p_end, s0, s1, s2, s3, shared)
        x_now = lanes[XNOW * LANES + i]
        # finite: one sum for four isfinite tests (inf or NaN anywhere makes it
        # so; an overflow of finite terms only sends the step to the scalar
        # code, which takes it the same); nu may be +-inf at a cusp, not NaN
        total = (p1 + u1) + (dw + dk)
        finite = (total - total == 0.0) & (nu1 == nu1)
        attempt = free & (not event) & clean & (t < t_max)
        # a rough step (a dip of nu inside it) goes to the scalar code, as there
        fast = (attempt & finite & (not (cos_now * cos1 < 0.0))
                & (not (rough & (not fresh(lanes, i)))))
        if ADAPTIVE:
            accepted = err <= 1.0
            fast = fast & accepted
            h_rejected = step_size * rejected_factor(err)
            rejected = (attempt & (not accepted) & (err == err)
                        & (h_rejected > SMALLEST_STEP * max(t, 1.0)))
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
        if LANE_EVENTS:  # a step that is not clean begins an event's bracket
            begins = free & (not event) & (not clean) & (t < t_max)
            closed = ce.lane_bracket(lanes, i, locating, begins, clean, step_size, p1, u1, nu1, p,
                                     u, normal_along_n(u, frame[1], frame[2], g))
            frozen = frozen & (closed | (not (locating | begins)))
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
