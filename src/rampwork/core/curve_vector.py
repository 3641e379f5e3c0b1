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
    JOINT, JOINT2, KAPNOW, LO, MANY_JOINTS, MUK, NREJ, NUMIN, P, PATH, PATHX, REJB, S0,
    S1, S2, SINNOW, SMALLEST_STEP, SN, STATUS, STEPS, T, U, WORK, XNOW, branch, fresh)
from .curve_fields import field, set_field
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
    scalar), on a view from lane ``first`` on, its fields loaded and stored
    through curve_fields (constant offsets from the view, no wraparound code
    to keep it from vectorising)."""
    lanes = all_lanes[first:]
    for i in range(BLOCK):
        running = field(lanes, STATUS, i) == st.NOT_RUN
        free = running & (field(lanes, FLAG, i) == 0.0)
        p = field(lanes, P, i)
        u = field(lanes, U, i)
        d = field(lanes, D, i)
        sn = field(lanes, SN, i)
        t = field(lanes, T, i)
        h_next = field(lanes, HN, i)
        g = field(lanes, G, i)
        s0 = field(lanes, S0, i)
        s1 = field(lanes, S1, i)
        s2 = field(lanes, S2, i)
        s3 = field(lanes, BRANCH, i)
        p_lo = field(lanes, LO, i)
        p_hi = field(lanes, HI, i)
        b = field(lanes, B, i)
        c = field(lanes, C, i)
        joint = field(lanes, JOINT, i)
        step_size = h_next if t + h_next <= t_max else t_max - t
        q = d * field(lanes, MUK, i) * sn
        if JOINTS:
            s3_before = s3
            if JOINTS == MANY_JOINTS:
                s3, joint = branch_near(p, d, shared, int(joint), int(field(lanes, JOINT2, i)),
                                        s3)
            elif JOINTS == 2:
                s3, joint = branch(p, d, joint, field(lanes, JOINT2, i))
            else:  # one joint: the only one a step may cross
                s3 = branch(p, d, joint, math.nan)[0]
            set_field(lanes, BRANCH, i, s3 if free else s3_before)
        sin_now = field(lanes, SINNOW, i)
        cos_now = field(lanes, COSNOW, i)
        kappa_now = field(lanes, KAPNOW, i)
        dp_ds_now = field(lanes, DPDSNOW, i)
        if JOINTS:  # the frame on the step's own branch, which the last step's end may not be
            frame = curve_frame(p, s0, s1, s2, s3, shared)
        else:
            frame = (sin_now, cos_now, kappa_now, dp_ds_now)
        event = (field(lanes, EVENT, i) != 0.0) if LANE_EVENTS else False  # (never set without)
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
        x_now = field(lanes, XNOW, i)
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
            rejected_before = field(lanes, REJB, i)
            error_previous = field(lanes, EPREV, i)
            h_accepted = step_size * accepted_factor(err, error_previous, rejected_before != 0.0)
            set_field(lanes, HN, i, h_accepted if fast else (h_rejected if rejected else h_next))
            set_field(lanes, EPREV, i, max(err, ERROR_FLOOR) if fast else error_previous)
            set_field(lanes, REJB, i, 0.0 if fast else (1.0 if rejected else rejected_before))
            set_field(lanes, NREJ, i, field(lanes, NREJ, i) + (1.0 if rejected else 0.0))
            frozen = running & (not fast) & (not rejected)
        else:
            frozen = running & (not fast)
        if LANE_EVENTS:  # a step that is not clean begins an event's bracket
            begins = free & (not event) & (not clean) & (t < t_max)
            closed = ce.lane_bracket(lanes, i, locating, begins, clean, step_size, p1, u1, nu1, p,
                                     u, normal_along_n(u, frame[1], frame[2], g))
            frozen = frozen & (closed | (not (locating | begins)))
        set_field(lanes, FLAG, i, 1.0 if frozen else 0.0)
        set_field(lanes, P, i, p1 if fast else p)
        set_field(lanes, U, i, u1 if fast else u)
        set_field(lanes, T, i, t + step_size if fast else t)
        set_field(lanes, STEPS, i, field(lanes, STEPS, i) + (1.0 if fast else 0.0))
        set_field(lanes, INROW, i, 0.0 if fast else field(lanes, INROW, i))
        work = field(lanes, WORK, i)
        set_field(lanes, WORK, i, work + dw if fast else work)
        curvature = field(lanes, CURV, i)
        set_field(lanes, CURV, i, curvature + dk if fast else curvature)
        displacement = field(lanes, DISP, i)
        set_field(lanes, DISP, i, displacement + dx if fast else displacement)
        path = field(lanes, PATH, i)
        set_field(lanes, PATH, i, path + d * dx if fast else path)
        if DRAG:
            drag_work = field(lanes, DRAGW, i)
            set_field(lanes, DRAGW, i, drag_work + dwd if fast else drag_work)
        nu_min = field(lanes, NUMIN, i)
        set_field(lanes, NUMIN, i, min(nu_min, side * nu1) if fast else nu_min)
        path_x = field(lanes, PATHX, i)
        set_field(lanes, PATHX, i, path_x + abs(x1 - x_now) if fast else path_x)
        set_field(lanes, XNOW, i, x1 if fast else x_now)
        set_field(lanes, SINNOW, i, sin1 if fast else sin_now)
        set_field(lanes, COSNOW, i, cos1 if fast else cos_now)
        set_field(lanes, KAPNOW, i, kappa1 if fast else kappa_now)
        set_field(lanes, DPDSNOW, i, dp_ds1 if fast else dp_ds_now)
