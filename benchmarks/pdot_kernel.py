"""A prototype (not the engine's code): the curve lane kernel's fixed-step
vector step in the state (p, p') instead of (p, u) (issue 20; measured by
``pdot_prototype.py``, benchmarks/README.md, curves.py, i20-pdot-11).

With r(p) the curve, r' = dr/dp, r'' = d2r/dp2 and p' = dp/dt, per unit mass
(derivation: docs/physics.md §5 in the state (p, u), u = |r'| p'):

    M   = (r' x r'') p'^2 + g r'_x          (= nu |r'|, nu the normal force)
    p'' = -[(r' . r'') p'^2 + g r'_y + q M] / |r'|^2     (q = d mu_k s_nu)
    friction power  q M p'  (= mu_k |nu| |u|),  turning  kappa u = (r' x r'') p' / |r'|^2

one division and no square root per stage; for y = f(x) (r' = (1, f'),
r'' = (0, f'')) it is the ramp kernel's eq. (10), for an arc-length family
(|r'| = 1) today's (s, u).  The frame here is ``(r'_x, r'_y, r'.r'', r' x r'',
1/|r'|^2)``.  The arc length s(p) is a function of position, not a state: the
prototype's vector step leaves DISP and PATH alone (the design takes them
from s(p) at a mode's ends); the lane's minimum normal force is kept as the
monotone key ``s M |s M| / |r'|^2`` (the square of s nu with its sign).

Only the vector step is in (p, p'): every step it freezes (an event) goes to
the engine's scalar ``curve_kernel._iterate`` in (p, u), the lane converted
there and back (``_pd_iterate``), as are a lane's start and finish.  So the
outputs are the engine's but for DISP, PATH (not accumulated by the vector
step) and rounding; the time per step is what a kernel in (p, p') would take.
Euler and RK4, one-sided, friction, no joints, no drag.
"""

from __future__ import annotations

import hashlib
import math
import pathlib

import rampwork.core.curve_kernel as ck
import rampwork.core.curve_lanes as cl
from rampwork.core import status as st
from rampwork.core.curve_kernel import (
    COSNOW, D, DPDSNOW, EV_LO, FLAG, G, HI, HN, INROW, KAPNOW, LANES, LO, MUK, NUMIN, P, PATHX,
    S0, S1, S2, BRANCH, SINNOW, SN, STATUS, STEPS, T, U, WORK, CURV, XNOW, fresh)
from rampwork.core.jit import fma, specialise

# bound per build
curve_frame = curve_point = pd_frame = pd_step = pd_stage = main_iterate = main_start = None
BLOCK = 8
FRICTION = True
#: the lean variant: no per-step CURV, PATHX (XNOW) nor INROW (what a kernel
#: would form per segment between scalar passes instead; the outputs are
#: then wrong: a measure of their cost only)
LEAN = False
#: the shape parameters and g read once per block (lane 0's: the benchmark's
#: are uniform), as the y = f(x) kernel's uniform parameters; RK4's h / 6 as
#: h * (1 / 6) (no division per lane).  Only for timing
UNIFORM = False
#: a wrapped graph's stage as the y = f(x) kernel's (r'_x = 1, r'.r'' = f' f'':
#: p'' = -M (f' + q) / (1 + f'^2)), not the general form
GRAPH = False
#: the frame's fields in the lanes: r'_x, r'_y, r'.r'', r' x r'', 1/|r'|^2
RX, RY, DOT, CROSS, INV = COSNOW, SINNOW, EV_LO, KAPNOW, DPDSNOW


def graph_pd_frame(p, p0, p1, p2, p3, shared):
    """y = f(x), p = x: r' = (1, f'), r'' = (0, f'')."""
    fp, fpp = ramp_slope_curvature(p, p0, p1, p2, p3, shared)
    return 1.0, fp, fp * fpp, fpp, 1.0 / fma(fp, fp, 1.0)


ramp_slope_curvature = None


def arc_pd_frame(p, p0, p1, p2, p3, shared):
    """An arc-length family: r' = (cos phi, sin phi), r'' = kappa N."""
    sin_phi, cos_phi, kappa, _ = curve_frame(p, p0, p1, p2, p3, shared)
    return cos_phi, sin_phi, 0.0, kappa, 1.0


def _pd_stage(frame, v, q, d, g):
    """(p'', M, kappa u) at one point."""
    rx, ry, dot, cross, inv = frame
    v2 = v * v
    if GRAPH:
        m = fma(v2, cross, g)
        return -m * ((ry + q) * inv), m, (cross * inv) * v
    m = fma(cross, v2, g * rx)
    tangential = fma(dot, v2, g * ry)
    if FRICTION:
        tangential = fma(q, m, tangential)
    return -tangential * inv, m, (cross * inv) * v


def _pd_euler(p, v, q, d, h, g, s0, s1, s2, s3, shared, frame):
    a, m, turn = pd_stage(frame, v, q, d, g)
    work = h * q * m * v if FRICTION else 0.0
    return fma(h, v, p), fma(h, a, v), work, h * d * turn, math.inf, -math.inf


def _pd_rk4(p, v, q, d, h, g, s0, s1, s2, s3, shared, frame):
    half = 0.5 * h
    a1, m1, k1 = pd_stage(frame, v, q, d, g)
    v2 = fma(half, a1, v)
    a2, m2, k2 = pd_stage(pd_frame(fma(half, v, p), s0, s1, s2, s3, shared), v2, q, d, g)
    v3 = fma(half, a2, v)
    a3, m3, k3 = pd_stage(pd_frame(fma(half, v2, p), s0, s1, s2, s3, shared), v3, q, d, g)
    v4 = fma(h, a3, v)
    a4, m4, k4 = pd_stage(pd_frame(fma(h, v3, p), s0, s1, s2, s3, shared), v4, q, d, g)
    sixth = h * (1.0 / 6.0) if UNIFORM else h / 6.0
    p_new = fma(sixth, v + 2.0 * (v2 + v3) + v4, p)
    v_new = fma(sixth, a1 + 2.0 * (a2 + a3) + a4, v)
    work = (q * sixth * (m1 * v + 2.0 * (m2 * v2 + m3 * v3) + m4 * v4)) if FRICTION else 0.0
    turn = d * sixth * (k1 + 2.0 * (k2 + k3) + k4)
    return p_new, v_new, work, turn, min(m2, m3), max(m2, m3)


def _pd_vector_step(all_lanes, first, shared, t_max, side, rtol, atol):
    """curve_vector._vector_step in (p, p'), fixed steps, no joints, no drag."""
    lanes = all_lanes[first:]
    uniform = (lanes[G * LANES], lanes[S0 * LANES], lanes[S1 * LANES], lanes[S2 * LANES],
               lanes[BRANCH * LANES])  # (read before the loop: a load inside stays scalar)
    for i in range(BLOCK):
        running = lanes[STATUS * LANES + i] == st.NOT_RUN
        free = running & (lanes[FLAG * LANES + i] == 0.0)
        p = lanes[P * LANES + i]
        v = lanes[U * LANES + i]
        d = lanes[D * LANES + i]
        sn = lanes[SN * LANES + i]
        t = lanes[T * LANES + i]
        h_next = lanes[HN * LANES + i]
        if UNIFORM:
            g, s0, s1, s2, s3 = uniform
        else:
            g = lanes[G * LANES + i]
            s0 = lanes[S0 * LANES + i]
            s1 = lanes[S1 * LANES + i]
            s2 = lanes[S2 * LANES + i]
            s3 = lanes[BRANCH * LANES + i]
        p_lo = lanes[LO * LANES + i]
        p_hi = lanes[HI * LANES + i]
        step_size = h_next if t + h_next <= t_max else t_max - t
        q = d * lanes[MUK * LANES + i] * sn
        rx = lanes[RX * LANES + i]
        ry = lanes[RY * LANES + i]
        dot = lanes[DOT * LANES + i]
        cross = lanes[CROSS * LANES + i]
        inv = lanes[INV * LANES + i]
        p1, v1, dw, dk, m_low, m_high = pd_step(p, v, q, d, step_size, g, s0, s1, s2, s3, shared,
                                                (rx, ry, dot, cross, inv))
        frame1 = pd_frame(p1, s0, s1, s2, s3, shared)
        rx1, ry1, dot1, cross1, inv1 = frame1
        m1 = fma(cross1, v1 * v1, g * rx1)
        clean = (d * v1 > 0.0) & (p1 >= p_lo) & (p1 <= p_hi) & (sn * m1 > 0.0)
        rough = clean & ((m_low <= 0.0) if sn > 0.0 else (m_high >= 0.0))
        x1, _ = curve_point(p1, s0, s1, s2, s3, shared)
        x_now = lanes[XNOW * LANES + i]
        total = (p1 + v1) + (dw + (0.0 if LEAN else dk))
        finite = (total - total == 0.0) & (m1 == m1)
        attempt = free & clean & (t < t_max)
        fast = (attempt & finite & (not (rx * rx1 < 0.0))
                & (not (rough & (not fresh(lanes, i)))))
        frozen = running & (not fast)
        lanes[FLAG * LANES + i] = 1.0 if frozen else 0.0
        lanes[P * LANES + i] = p1 if fast else p
        lanes[U * LANES + i] = v1 if fast else v
        lanes[T * LANES + i] = t + step_size if fast else t
        lanes[STEPS * LANES + i] += 1.0 if fast else 0.0
        if not LEAN:
            lanes[INROW * LANES + i] = 0.0 if fast else lanes[INROW * LANES + i]
        work = lanes[WORK * LANES + i]
        lanes[WORK * LANES + i] = work + dw if fast else work
        if not LEAN:
            curvature = lanes[CURV * LANES + i]
            lanes[CURV * LANES + i] = curvature + dk if fast else curvature
        key = (side * m1) * abs(side * m1) * inv1  # (s nu)|s nu|: monotone in s nu
        nu_min = lanes[NUMIN * LANES + i]
        lanes[NUMIN * LANES + i] = min(nu_min, key) if fast else nu_min
        if not LEAN:
            path_x = lanes[PATHX * LANES + i]
            lanes[PATHX * LANES + i] = path_x + abs(x1 - x_now) if fast else path_x
            lanes[XNOW * LANES + i] = x1 if fast else x_now
        lanes[RX * LANES + i] = rx1 if fast else rx
        lanes[RY * LANES + i] = ry1 if fast else ry
        lanes[DOT * LANES + i] = dot1 if fast else dot
        lanes[CROSS * LANES + i] = cross1 if fast else cross
        lanes[INV * LANES + i] = inv1 if fast else inv


def _to_pd(lanes, i, shared):
    """Lane i from (p, u) to (p, p'), its frame and minimum-nu key."""
    p = lanes[P * LANES + i]
    frame = pd_frame(p, lanes[S0 * LANES + i], lanes[S1 * LANES + i], lanes[S2 * LANES + i],
                     lanes[BRANCH * LANES + i], shared)
    lanes[U * LANES + i] = lanes[U * LANES + i] * lanes[DPDSNOW * LANES + i]
    lanes[RX * LANES + i] = frame[0]
    lanes[RY * LANES + i] = frame[1]
    lanes[DOT * LANES + i] = frame[2]
    lanes[CROSS * LANES + i] = frame[3]
    lanes[INV * LANES + i] = frame[4]
    nu = lanes[NUMIN * LANES + i]
    lanes[NUMIN * LANES + i] = nu * abs(nu)


def _to_pu(lanes, i, shared):
    """Lane i back from (p, p') to (p, u)."""
    frame = curve_frame(lanes[P * LANES + i], lanes[S0 * LANES + i], lanes[S1 * LANES + i],
                        lanes[S2 * LANES + i], lanes[BRANCH * LANES + i], shared)
    lanes[U * LANES + i] = lanes[U * LANES + i] / frame[3]
    ck.store_frame(lanes, i, frame)
    key = lanes[NUMIN * LANES + i]
    lanes[NUMIN * LANES + i] = math.copysign(math.sqrt(abs(key)), key)


def _pd_iterate(lanes, i, shared, t_max, side, rtol, atol):
    to_pu(lanes, i, shared)
    main_iterate(lanes, i, shared, t_max, side, rtol, atol)
    if lanes[STATUS * LANES + i] == st.NOT_RUN:
        to_pd(lanes, i, shared)


def _pd_start(lanes, i, inputs, j, shared, h, side):
    main_start(lanes, i, inputs, j, shared, h, side)
    if lanes[STATUS * LANES + i] == st.NOT_RUN:
        to_pd(lanes, i, shared)


to_pu = to_pd = None


def build_pd_kernel(key, frame, point, pd_frame_template, method, *, friction=True,
                    extra=None):
    """The prototype's CurveKernel: the engine's lane kernel (one-sided, no
    joints, no drag) with the vector step above."""
    step, order, adaptive, control = ck.CURVE_STEPPERS[method]
    assert not adaptive
    name = f"pdot_{key}_{method}{'_friction' if friction else ''}"
    # the source's digest: numba's cache of the engine's templates (curve_lanes.py)
    # would otherwise keep an older build of this file's functions inlined
    name += "_" + hashlib.sha256(pathlib.Path(__file__).read_bytes()).hexdigest()[:8]
    for k, value in sorted((extra or {}).items()):
        if k.isupper():
            name += f"_{k.lower()}{value!s}"
    constants = {"curve_frame": frame, "curve_point": point, "ONE_SIDED": True,
                 "ADAPTIVE": False, "LANE_EVENTS": False, "JOINTS": 0, "FRICTION": friction,
                 "POINT_ANYWHERE": True, "DRAG_LINEAR": False, "DRAG_QUADRATIC": False,
                 "DRAG": False, "VECTOR": True, "PI_ALPHA": 0.0, "PI_BETA": 0.0,
                 "REJECT_EXPONENT": 0.0, "STEP_TAKES_FRAME": True,
                 "BLOCK": cl.BLOCK_FIRST_ORDER if order == 1 else cl.BLOCK}
    constants.update(extra or {})

    def build(template, suffix, **more):
        constants.update(more)
        return specialise(template, f"{name}_{suffix}", dict(constants))

    from rampwork.core.curve_steppers import _dop853_stages, _stage, _stage_from
    stage_from = build(_stage_from, "stage_from")
    stage = build(_stage, "stage", stage_from=stage_from)
    rates = build(_dop853_stages, "rates", stage=stage, stage_from=stage_from)
    constants["curve_step"] = build(step, "step", stage=stage, stage_rates=rates)
    constants["try_step"] = build(ck._try_step, "try")
    import rampwork.core.curve_events as ce
    for template, bound in ((ck._rest_rule, "rest_rule"), (ck._contact_sign, "contact_sign"),
                            (ck._x_travelled, "x_travelled"), (ce._event_guess, "event_guess"),
                            (ce._event_trial, "event_trial"), (ce._locate_event, "locate_event"),
                            (ce._lane_trial, "lane_trial"),
                            (ck._accepted_factor, "accepted_factor"),
                            (ck._rejected_factor, "rejected_factor")):
        constants[bound] = build(template, bound)
    constants["main_start"] = build(cl._start_lane, "main_start")
    constants["main_iterate"] = build(ck._iterate, "main_iterate")
    constants["finish_lane"] = build(cl._finish_lane, "finish_lane")
    constants["pd_frame"] = build(pd_frame_template, "pd_frame")
    constants["pd_stage"] = build(_pd_stage, "pd_stage")
    constants["pd_step"] = build({"euler": _pd_euler, "rk4": _pd_rk4}[method], "pd_step")
    constants["to_pd"] = build(_to_pd, "to_pd")
    constants["to_pu"] = build(_to_pu, "to_pu")
    constants["iterate"] = build(_pd_iterate, "iterate")
    constants["start_lane"] = build(_pd_start, "start_lane")
    constants["vector_step"] = build(_pd_vector_step, "vector_step")
    constants["vector_pass"] = build(cl._vector_pass, "vector_pass")
    constants["run_tile"] = build(cl._run_tile, "run_tile")
    return cl.CurveKernel(build(cl._run_tiles, "tiles"))
