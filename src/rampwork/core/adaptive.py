"""The adaptive lane kernel's own parts: per-lane step sizes with error control.

The frame is the fixed-step kernel's (``kernel_tiles.py``: lanes, scans;
``kernel_modes.py``: loading, finishing; ``kernel_events.py``: event
application); :func:`kernel.build_kernel` binds these templates in place of
the fixed-step ones for an embedded pair such as Dormand-Prince 5(4).

In the vector loop every lane attempts one step of its own size ``H`` per
iteration and, without a branch, either commits it (error norm <= 1, no event
inside), rejects it (error norm > 1, or a state that is not finite or breaks
the speed bound) or freezes on it (accepted but an event happens inside).  The
step size is updated by the PI controller of ``control.py`` in every case but
the freeze, so a frozen lane recomputes the same step until the scalar pass
locates the event on the step's dense output, moves the lane there along it and
applies it.  No lane waits for another: each carries its own step size, time
and counts.

Templates: ``step``, ``dense_output``, ``ramp_slope_curvature`` and the helper
names are globals bound per scene by ``build_kernel`` through
``jit.specialise``.
"""

from __future__ import annotations

import math

import numpy as np

from . import status as st
from .control import (ERROR_FLOOR, ERROR_TINY, FACTOR_MAX, PI_DOPRI5, log2_approx,
                      reciprocal_approx, step_factor)
from .layout import *  # noqa: F403 - the lane layout shared with the fixed-step kernel
from .jit import fma
from .physics import acceleration, drag_rate, normal_term, specific_energy

#: contact control: over an accepted step the normal term varies by at most
#: this share of its smallest distance from 0 (at the stages); a step that
#: varies more is refused and shrunk by CONTACT_SHRINK
CONTACT_VARIATION = 0.5
CONTACT_SHRINK = 0.5
#: samples of the dense output searched for a lift-off that a stage saw inside
#: the step but the step's end does not show
N_DIP_SAMPLES = 16

# bound per scene by kernel.build_kernel
step = dense_output = ramp_slope_curvature = ramp_height = None
PROJECT_ENERGY = True  # project accepted steps onto the energy balance
CHECK_CONTACT = True
ONE_SIDED = True
DRAG_LINEAR = DRAG_QUADRATIC = DRAG = False  # air drag (see kernel_globals.py)
LANES = 64
PI_ALPHA, PI_BETA = PI_DOPRI5  # the pair's controller gains
SWING_LIMIT2 = 0.64  # the pair's bound on (h omega)^2 (steppers.AdaptivePair.swing_limit)
CHAINS = 2
(error_norm2, error_norm2_drag, apply_event, rebase, finish_lane, dense_value,
 locate_dense, attempt, dense_point, refresh_slope, set_mode, contact_holds,
 lane_parameters, uniform_parameters, step_to_event, event_step, project_energy) = (None,) * 17

#: log2 of an error norm that is not finite, or of a step that left the speed
#: bound: large enough that the step shrinks by the controller's largest factor
LOG2_ERROR_BAD = 1.0e3
LOG2_ERROR_FLOOR = math.log2(ERROR_FLOOR)
#: an error norm beyond this is treated as not finite
ERROR_NORM_BAD = 1.0e300
#: a step beyond the swing bound is refused and shrunk by this factor
SWING_SHRINK = 0.5
#: two rounding units of x: a smaller change of x is not a measured swing
X_ROUNDING = 4.5e-16


def _project_energy(x1, v1, w, w1, fp1, fpp1, q, work, e0, g, p0, p1, p2, p3, shared, rtol,
                    atol):
    """(x, v, w, residual): a step's end (x1, v1, w1) moved onto the energy
    balance E(x, v) + work = e0 (``work``: w1 plus the drag work), and the
    residual E(x1, v1) + work - e0 that it removed; where that move would be
    longer than one unit of the error norm, (x1, v1, w1, 0): nothing moved.

    Why: the pairs conserve no invariant; over thousands of steps (small mu,
    long trajectories) the energy they lose or gain per step adds up, and so
    does the error of where the block stops, hence of W (dopri5 at rtol
    1e-12: max W error 80-90 times the median).  One Newton step onto the
    invariant of the augmented system (Hairer, Lubich & Wanner, "Geometric
    Numerical Integration", IV.4) puts the state back on it to rounding and
    keeps the pair's order.  The direction: the shortest move in the error
    norm's own metric (component c scaled by s_c = atol + rtol |c|), i.e.
    delta_c = -residual s_c^2 dPhi/dc / sum_c (s_c dPhi/dc)^2 over x, v and W
    (dPhi/dx = f' (g + v^2 f''), dPhi/dv = v (1 + f'^2), dPhi/dW = 1): each
    component takes the share of the correction that its tolerance allows.
    A correction of v alone, r / (v (1 + f'^2)), is unbounded near a
    turning point (v -> 0); here the x term takes over there, and at rest at
    a bottom (f' = v = 0) the W term (without friction: no move).  (f'
    and f'' are not evaluated again at the moved point: the move is of the
    local error's size, and the next step's first stage carries it only
    multiplied by h.  W is not moved without friction (q = 0: it stays 0)
    nor below its value w at the step's start: friction work never
    decreases; the drag work is not moved.)"""
    residual = specific_energy(ramp_height(x1, p0, p1, p2, p3, shared), fp1, v1, g) + work - e0
    sx = atol + rtol * abs(x1)
    sv = atol + rtol * abs(v1)
    sw = atol + rtol * abs(w1) if q != 0.0 else 0.0
    grad_x = fp1 * fma(v1 * v1, fpp1, g) * sx
    grad_v = v1 * fma(fp1, fp1, 1.0) * sv
    norm2 = fma(grad_x, grad_x, fma(grad_v, grad_v, sw * sw))
    usable = (residual * residual <= norm2) & (norm2 > 0.0)
    # the shift needs a few digits only (1e-10 leaves 1e-10 of the residual):
    # no division, the lane loop's bottleneck
    shift = residual * reciprocal_approx(norm2) if usable else 0.0
    return (x1 - shift * grad_x * sx, v1 - shift * grad_v * sv,
            max(w1 - shift * (sw * sw), w), residual if usable else 0.0)


def _contact_holds(sn, n_end, n_low, n_high):
    """The contact's sign ``sn`` held at the step's end and at every stage
    (n_low, n_high: the stages' range of the normal term)."""
    return (sn * n_end > 0.0) & ((n_low > 0.0) if sn > 0.0 else (n_high < 0.0))


# ------------------------------------------------------------------------------
# vector part
# ------------------------------------------------------------------------------
def _advance_lanes_adaptive(lanes, settings, shared, n_attempts, n_active):
    """``n_attempts`` (even) step attempts on lanes 0 .. n_active-1, each lane
    with its own step size.

    Attempts alternate between the two banks of the state (layout.BANK_B):
    the first reads bank A and writes bank B, the next reads B and writes A,
    so the state is back in bank A for the scan.  Why: an attempt that keeps
    the old state where it does not commit, written back in place (``x = x1
    if commit else x``), compiles to masked stores, which some CPUs (AMD Zen)
    run many times slower than plain ones; written to the other bank it is a
    blend and a plain store.  The bank offsets are constants here, so the
    compiler sees that reads and writes do not overlap.

    Each attempt is a chain of seven dependent divisions (about 500 cycles of
    latency for one vector of lanes), longer than the core's reorder window,
    so one vector at a time leaves the divider idle.  The loop therefore
    carries the two halves of the block side by side: two independent chains.
    (Empty lanes step too: they never commit.)"""
    x_lo = settings[SET_XLO]
    x_hi = settings[SET_XHI]
    t_max = settings[SET_TMAX]
    rtol = settings[SET_RTOL]
    atol = settings[SET_ATOL]
    h_max = settings[SET_HMAX]
    h_min = settings[SET_HMIN]
    uniform = uniform_parameters(settings)  # see parameters.py
    limits = (x_lo, x_hi, t_max, rtol, atol, h_max, h_min)
    if CHAINS == 2 and n_active > LANES // 2:
        for _ in range(n_attempts // 2):
            for i in range(LANES // 2):  # constant offsets: provably disjoint halves
                attempt(lanes, i, 0, BANK_B, shared, limits, uniform)
                attempt(lanes, i + LANES // 2, 0, BANK_B, shared, limits, uniform)
            for i in range(LANES // 2):
                attempt(lanes, i, BANK_B, 0, shared, limits, uniform)
                attempt(lanes, i + LANES // 2, BANK_B, 0, shared, limits, uniform)
    else:  # a tile's tail
        for _ in range(n_attempts // 2):
            for i in range(n_active):
                attempt(lanes, i, 0, BANK_B, shared, limits, uniform)
            for i in range(n_active):
                attempt(lanes, i, BANK_B, 0, shared, limits, uniform)


def _attempt_once(lanes, i, settings, shared):
    """One step attempt on lane i alone, its state back in bank A (for
    recording a single trajectory, attempt by attempt)."""
    uniform = uniform_parameters(settings)
    limits = (settings[SET_XLO], settings[SET_XHI], settings[SET_TMAX], settings[SET_RTOL],
              settings[SET_ATOL], settings[SET_HMAX], settings[SET_HMIN])
    attempt(lanes, i, 0, BANK_B, shared, limits, uniform)
    for field in range(N_BANKED):
        if (field == WD and not DRAG) or (field == FRESH and not (CHECK_CONTACT and not ONE_SIDED)):
            continue  # fields this kernel's attempt does not carry
        lanes[field * LANES + i] = lanes[(field + BANK_B) * LANES + i]


def _attempt(lanes, i, src, dst, shared, limits, uniform):
    """One step attempt on lane i: the banked state (layout.N_BANKED) read
    from bank ``src``, written to bank ``dst``; the counts in place.
    Branch-free, as in the fixed-step kernel: the outcome (commit, reject or
    freeze) is selected, not branched on."""
    x_lo, x_hi, t_max, rtol, atol, h_max, h_min = limits
    x = lanes[(X + src) * LANES + i]
    v = lanes[(V + src) * LANES + i]
    d = lanes[D * LANES + i]
    g, p0, p1, p2, p3 = lane_parameters(lanes, i, uniform)
    fp = lanes[(FP + src) * LANES + i]
    fpp = lanes[(FPP + src) * LANES + i]
    a1 = lanes[(A1 + src) * LANES + i]
    h = lanes[(H + src) * LANES + i]
    t = lanes[(T + src) * LANES + i]
    w = lanes[(W + src) * LANES + i]
    k = lanes[(K + src) * LANES + i]
    wd = lanes[(WD + src) * LANES + i] if DRAG else 0.0
    last_log2_error = lanes[(LERR + src) * LANES + i]
    rejected_before = lanes[(REJ + src) * LANES + i]
    two_sided_contact = CHECK_CONTACT and not ONE_SIDED
    fresh = lanes[(FRESH + src) * LANES + i] if two_sided_contact else 0.0
    frozen = lanes[PENDING * LANES + i] > 0.0
    (x1, v1, dw, dk, a7, fp7, fpp7, ex, ev, ew, ek, n_low, n_high, fx, fv, fw, fk,
     dwd, ed, fd) = step(
        x, v, fp, fpp, a1, lanes[Q * LANES + i], d, h, g, p0, p1, p2, p3, shared,
        lanes[DRAG_B * LANES + i], lanes[DRAG_C * LANES + i])
    # the friction power is >= 0 within a mode; stage weights of both signs
    # can round a sum of denormal powers below 0 (mu_k = 5e-324): never W < 0
    w1 = w + (dw if dw > 0.0 else 0.0)
    k1 = k + dk
    if DRAG:
        wd1 = wd + dwd
        err2 = error_norm2_drag(x, v, w, k, wd, x1, v1, w1, k1, wd1, ex, ev, ew, ek, ed,
                                fx, fv, fw, fk, fd, rtol, atol)
    else:
        err2 = error_norm2(x, v, w, k, x1, v1, w1, k1, ex, ev, ew, ek, fx, fv, fw, fk, rtol,
                           atol)
    bounded = (v1 * v1 <= lanes[VLIM2 * LANES + i]) & (err2 <= ERROR_NORM_BAD)
    accepted = bounded & (err2 <= 1.0)
    event = ((d * v1 <= 0.0) | (x1 >= x_hi) | (x1 <= x_lo) | (t + h >= t_max))
    rough = False
    if CHECK_CONTACT:
        sn = lanes[SN * LANES + i]
        holds = contact_holds(sn, normal_term(v1, fpp7, g), n_low, n_high)
        event = event | (not holds)
        # Where contact holds, the normal term may vary over the step by at
        # most a share of its distance from 0: otherwise a dip through 0 and
        # back could hide between the stages.  Such a step is refused (its
        # size halved) unless it already shows the lift-off as an event.
        margin = sn * (n_low if sn > 0.0 else n_high)
        rough = holds & (not n_high - n_low <= CONTACT_VARIATION * margin)
        if not ONE_SIDED:
            # Just after a two-sided switch n starts from 0 and grows: its
            # variation is then always several times its smallest stage value,
            # whatever the step size, so the test would shrink the step to
            # nothing.  The first step of the new mode is exempt (a sign change
            # at any stage or at its end is still caught by `holds`).
            rough = rough & (not fresh > 0.0)
        accepted = accepted & (not rough)
    # The swing bound: h omega <= SWING_LIMIT, omega^2 = |a1 - a7| / |x1 - x|
    # the step's secant of the restoring acceleration.  Beyond it a pair's
    # embedded estimate stops growing with h while its true error explodes
    # (dopri5 at rtol 1e-3 on a bowl: h omega = 1.2, estimate 0.64, true 18),
    # so a loose tolerance would accept steps that gain energy.  Compared as
    # products (no division, no logarithm: this is the lane loop); the next
    # step may grow only as far as stays below the bound, so the controller
    # does not grow into it again.  (A step that moves x by less than its
    # rounding, from rest on a straight ramp whose pull is 1e-16 g, sees only
    # the rounding of a: no test there.)
    swing2 = h * h * abs(a7 - a1)
    bound2 = SWING_LIMIT2 * (abs(x1 - x) + X_ROUNDING * abs(x))
    swing = swing2 > bound2
    # the largest of (1, 2, 4, 8, 10) that keeps (h omega)^2 within the bound,
    # as a min of flat selects (a nested chain is not if-converted: it kept
    # the lane loop from vectorising, 7x slower per step for dop853)
    growth = min(min(SWING_SHRINK if swing else FACTOR_MAX,
                     1.0 if 4.0 * swing2 > bound2 else FACTOR_MAX),
                 min(min(2.0 if 16.0 * swing2 > bound2 else FACTOR_MAX,
                         4.0 if 64.0 * swing2 > bound2 else FACTOR_MAX),
                     8.0 if 100.0 * swing2 > bound2 else FACTOR_MAX))
    accepted = accepted & (not swing)
    commit = accepted & (not event) & (not frozen)
    hold = frozen | (accepted & event)
    log2_error = (0.5 * log2_approx(err2 if err2 > ERROR_TINY else ERROR_TINY)
                  if bounded else LOG2_ERROR_BAD)
    factor = step_factor(log2_error, last_log2_error, accepted, rejected_before > 0.0,
                         PI_ALPHA, PI_BETA)
    factor = min(factor, growth)
    factor = min(factor, CONTACT_SHRINK) if rough else factor
    h_new = min(h * factor, h_max)
    if PROJECT_ENERGY:
        work1 = w1
        if DRAG:
            work1 = w1 + wd1
        x1, v1, w1, removed = project_energy(
            x1, v1, w, w1, fp7, fpp7, lanes[Q * LANES + i], work1, lanes[E0 * LANES + i], g,
            p0, p1, p2, p3, shared, rtol, atol)
        lanes[EPROJ * LANES + i] += removed if commit else 0.0
    lanes[(X + dst) * LANES + i] = x1 if commit else x
    lanes[(V + dst) * LANES + i] = v1 if commit else v
    lanes[(W + dst) * LANES + i] = w1 if commit else w
    lanes[(K + dst) * LANES + i] = k1 if commit else k
    if DRAG:
        lanes[(WD + dst) * LANES + i] = wd1 if commit else wd
    lanes[(FP + dst) * LANES + i] = fp7 if commit else fp
    lanes[(FPP + dst) * LANES + i] = fpp7 if commit else fpp
    lanes[(A1 + dst) * LANES + i] = a7 if commit else a1
    lanes[(T + dst) * LANES + i] = t + h if commit else t
    if two_sided_contact:
        lanes[(FRESH + dst) * LANES + i] = 0.0 if commit else fresh
    lanes[(LERR + dst) * LANES + i] = (max(log2_error, LOG2_ERROR_FLOOR) if commit
                                       else last_log2_error)
    lanes[(REJ + dst) * LANES + i] = rejected_before if hold else (0.0 if accepted else 1.0)
    lanes[(H + dst) * LANES + i] = h if hold else h_new
    lanes[STEPS * LANES + i] += 1.0 if commit else 0.0
    lanes[EEST * LANES + i] += abs(ew) if commit else 0.0
    lanes[NREJ * LANES + i] += 0.0 if (accepted | frozen) else 1.0
    lanes[PENDING * LANES + i] = 1.0 if (hold | (h_new < h_min)) else 0.0


# ------------------------------------------------------------------------------
# scalar part
# ------------------------------------------------------------------------------
def _start_adaptive(lanes, i, settings, shared):
    """Step-control state of a freshly loaded lane (after its mode is set).

    The first step is the user's, or estimated as in Hairer, Norsett & Wanner
    ("Solving ODEs I", II.4): from the sizes of the state, its derivative and
    the derivative's change over a small explicit Euler step, for x and v."""
    lanes[LERR * LANES + i] = LOG2_ERROR_FLOOR
    lanes[REJ * LANES + i] = 0.0
    lanes[PENDING * LANES + i] = 0.0
    h_max = settings[SET_HMAX]
    if settings[SET_DT] > 0.0:
        lanes[H * LANES + i] = min(settings[SET_DT], h_max)
        return
    rtol = settings[SET_RTOL]
    atol = settings[SET_ATOL]
    x = lanes[X * LANES + i]
    v = lanes[V * LANES + i]
    a = lanes[A1 * LANES + i]
    sx = atol + rtol * abs(x)
    sv = atol + rtol * abs(v)
    d0 = math.sqrt(0.5 * ((x / sx) ** 2 + (v / sv) ** 2))
    d1 = math.sqrt(0.5 * ((v / sx) ** 2 + (a / sv) ** 2))
    h0 = 0.01 * d0 / d1 if (d0 >= 1e-5 and d1 >= 1e-5) else 1e-6
    h0 = min(h0, h_max)
    # f at an explicit Euler step h0 ahead (d as set by the mode)
    x1 = x + h0 * v
    v1 = v + h0 * a
    fp1, fpp1 = ramp_slope_curvature(x1, lanes[P0 * LANES + i], lanes[P1 * LANES + i],
                                     lanes[P2 * LANES + i], lanes[P3 * LANES + i], shared)
    a_1 = acceleration(normal_term(v1, fpp1, lanes[G * LANES + i]), fp1, lanes[Q * LANES + i])
    if DRAG:
        kd = drag_rate(v1, fp1, lanes[DRAG_B * LANES + i], lanes[DRAG_C * LANES + i],
                       lanes[D * LANES + i], DRAG_LINEAR, DRAG_QUADRATIC)
        a_1 = fma(-kd, v1, a_1)
    d2 = math.sqrt(0.5 * (((v1 - v) / sx) ** 2 + ((a_1 - a) / sv) ** 2)) / h0
    if not math.isfinite(d2):
        d2 = 0.0
    if max(d1, d2) <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** 0.2
    lanes[H * LANES + i] = min(100.0 * h0, h1, h_max)


def _dense_value(kind, lanes, i, dense, h, theta, settings, shared):
    """Event function ``kind`` on the dense output at theta in [0, 1] of a step
    of size h from lane i's state."""
    x = lanes[X * LANES + i] + dense_point(dense, h, theta, 0)
    if kind == EV_EXIT_HI:
        return settings[SET_XHI] - x
    if kind == EV_EXIT_LO:
        return x - settings[SET_XLO]
    v = lanes[V * LANES + i] + dense_point(dense, h, theta, 1)
    if kind == EV_REVERSAL:
        return lanes[D * LANES + i] * v
    _, fpp = ramp_slope_curvature(x, lanes[P0 * LANES + i], lanes[P1 * LANES + i],
                                  lanes[P2 * LANES + i], lanes[P3 * LANES + i], shared)
    return lanes[SN * LANES + i] * normal_term(v, fpp, lanes[G * LANES + i])


def _locate_dense(kind, lanes, i, dense, h, theta_end, value_end, settings, shared):
    """Smallest theta in (0, theta_end] at which event ``kind`` has happened
    on the step's dense output, given its value there (Illinois, to a bracket
    of a few rounding units; the dense output itself is accurate to the
    tolerance).  Returns the bracket end on the event side; 0 if the event
    holds at the step start."""
    a = 0.0
    fa = dense_value(kind, lanes, i, dense, h, 0.0, settings, shared)
    # A departure from rest has d v = 0 at the start and > 0 just after it
    # (the acceleration points along d): the reversal that the step's end
    # shows is the return later in the step (a long step at a loose
    # tolerance swings there and back), not the start; answering 0 would rest
    # and depart again until the block was declared diverged.  (With fa = 0
    # the first trial point is the bracket's middle.)
    if not (fa > 0.0 or (kind == EV_REVERSAL and fa == 0.0)):
        return 0.0
    b = theta_end
    fb = value_end
    side = 0
    for _ in range(100):
        c = (a * fb - b * fa) / (fb - fa)
        if not (a < c < b):
            c = 0.5 * (a + b)
        if not (a < c < b):
            break
        fc = dense_value(kind, lanes, i, dense, h, c, settings, shared)
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
            if fc == 0.0:
                break
        if b - a <= 4.0e-16:
            break
    return b


def _resolve_lane_adaptive(lanes, i, settings, outputs, shared):
    """Handle lane i's frozen step: locate the earliest event inside it on the
    step's dense output, move the lane there (x, v and the work integrals from
    the dense output: no further step) and apply the event.  Returns True if
    the trajectory goes on, False if it finished."""
    t_now = lanes[T * LANES + i]
    t_max = settings[SET_TMAX]
    lanes[PENDING * LANES + i] = 0.0
    lanes[CASCADE * LANES + i] += 1.0
    h = lanes[H * LANES + i]
    if lanes[CASCADE * LANES + i] > MAX_EVENT_CASCADE or not h >= settings[SET_HMIN]:
        # the step size collapsed, or events keep coming without progress
        rebase(lanes, i, t_now, settings, shared)
        finish_lane(lanes, i, st.DIVERGED, np.nan, outputs, shared)
        return False
    h_end = min(h, t_max - t_now)
    dense, x1, v1, fpp1, err_work, n_low, n_high = dense_output(
        lanes[X * LANES + i], lanes[V * LANES + i], lanes[FP * LANES + i],
        lanes[FPP * LANES + i], lanes[A1 * LANES + i], lanes[Q * LANES + i],
        lanes[D * LANES + i], h_end, lanes[G * LANES + i], lanes[P0 * LANES + i],
        lanes[P1 * LANES + i], lanes[P2 * LANES + i], lanes[P3 * LANES + i], shared,
        lanes[DRAG_B * LANES + i], lanes[DRAG_C * LANES + i])
    sn = lanes[SN * LANES + i]
    contact = sn * normal_term(v1, fpp1, lanes[G * LANES + i]) if CHECK_CONTACT else 1.0
    contact_end = 1.0
    if CHECK_CONTACT and contact > 0.0 and not contact_holds(sn, contact * sn, n_low, n_high):
        # a stage saw the normal term change sign inside the step: look for the
        # first sample of the dense output where it has
        for j in range(1, N_DIP_SAMPLES + 1):
            theta = j / N_DIP_SAMPLES
            value = dense_value(np.int64(EV_CONTACT), lanes, i, dense, h_end, theta, settings,
                                shared)
            if not value > 0.0:
                contact = value
                contact_end = theta
                break
    values = (x1 - settings[SET_XLO], settings[SET_XHI] - x1, contact, lanes[D * LANES + i] * v1)
    ends = (1.0, 1.0, contact_end, 1.0)
    best_kind = EV_NONE
    best_theta = 1.0
    for k in range(4):
        if not values[k] > 0.0:
            kind = np.int64(EV_EXIT_LO + k)  # one argument type: one compilation
            theta = locate_dense(kind, lanes, i, dense, h_end, ends[k], values[k], settings,
                                 shared)
            if best_kind == EV_NONE or theta < best_theta:
                best_theta = theta
                best_kind = kind
    # A long step can hold two events of which the end shows only one: a block
    # that passes the domain's end and comes back before the step ends shows
    # its reversal but not its exit.  Check every event function at the
    # earliest event found; one that has already happened there came first.
    for _ in range(4):
        if best_kind == EV_NONE or best_theta <= 0.0:
            break
        earlier = False
        for k in range(4):
            kind = np.int64(EV_EXIT_LO + k)
            if kind == best_kind or (kind == EV_CONTACT and not CHECK_CONTACT):
                continue
            value = dense_value(kind, lanes, i, dense, h_end, best_theta, settings, shared)
            if not value > 0.0:
                best_theta = locate_dense(kind, lanes, i, dense, h_end, best_theta, value,
                                          settings, shared)
                best_kind = kind
                earlier = True
                break
        if not earlier:
            break
    if best_kind == EV_NONE:
        if t_now + h < t_max:
            # only a stage's sign of n flagged the step and the dense output
            # shows no lift-off: the step stands
            lanes[X * LANES + i] = x1
            lanes[V * LANES + i] = v1
            lanes[W * LANES + i] += max(dense_point(dense, h_end, 1.0, 2), 0.0)
            lanes[K * LANES + i] += dense_point(dense, h_end, 1.0, 3)
            if DRAG:
                lanes[WD * LANES + i] += dense_point(dense, h_end, 1.0, 4)
            lanes[STEPS * LANES + i] += 1.0
            lanes[EEST * LANES + i] += abs(err_work)
            lanes[T * LANES + i] = t_now + h_end
            refresh_slope(lanes, i, shared)
            set_mode(lanes, i, lanes[D * LANES + i], settings)
            return True
        best_kind = np.int64(EV_TIMEOUT)  # the step reaches t_max with nothing before
    h_event = best_theta * h_end
    if best_theta > 0.0 and best_kind != EV_CONTACT:
        h_event = step_to_event(lanes, i, best_kind, h_event, h_end, settings, shared)
        lanes[EEST * LANES + i] += abs(err_work)  # the whole step's: an upper bound
    elif best_theta > 0.0:
        lanes[X * LANES + i] += dense_point(dense, h_end, best_theta, 0)
        lanes[V * LANES + i] += dense_point(dense, h_end, best_theta, 1)
        lanes[W * LANES + i] += max(dense_point(dense, h_end, best_theta, 2), 0.0)
        lanes[K * LANES + i] += dense_point(dense, h_end, best_theta, 3)
        if DRAG:
            lanes[WD * LANES + i] += dense_point(dense, h_end, best_theta, 4)
        lanes[STEPS * LANES + i] += 1.0
        lanes[EEST * LANES + i] += abs(err_work)  # the whole step's: an upper bound
    t_event = t_now + h_event
    lanes[T * LANES + i] = t_event
    return apply_event(lanes, i, best_kind, t_event, settings, outputs, shared)


def _step_to_event(lanes, i, kind, h_event, h_end, settings, shared):
    """Move lane i to the event ``kind`` located at h_event on the dense
    output by a step of the pair itself (not along the dense output), after
    one Newton correction of its size from the end of a first such step.
    Returns the step's size.

    Why: the dense output is of lower order than the step (dopri5: 4 against
    5) and its error is of the size of the step's error estimate, i.e. of the
    tolerance; x, v and W taken from it at the event carried that error, so
    trajectories that end within their first steps (small W) had relative W
    errors up to 300 times the median at rtol 1e-12.  A step of the pair
    to the event is as accurate as any committed step.  The event's time
    itself matters little: at a reversal v = 0, so x and W change only to
    second order in the time's error (no Newton step); at an exit the Newton
    step puts x on the end to the pair's accuracy.  A timeout steps to t_max
    exactly.  (A lift-off keeps the dense output: n, its event function,
    is no state the step's end could be corrected on cheaply.)"""
    x = lanes[X * LANES + i]
    v = lanes[V * LANES + i]
    d = lanes[D * LANES + i]
    h = h_end if kind == EV_TIMEOUT else h_event
    for attempt_ in range(2):
        (x1, v1, dw, dk, _, fp1, fpp1, _, _, _, _, _, _, _, _, _, _, dwd, _, _) = event_step(
            x, v, lanes[FP * LANES + i], lanes[FPP * LANES + i], lanes[A1 * LANES + i],
            lanes[Q * LANES + i], d, h, lanes[G * LANES + i], lanes[P0 * LANES + i],
            lanes[P1 * LANES + i], lanes[P2 * LANES + i], lanes[P3 * LANES + i], shared,
            lanes[DRAG_B * LANES + i], lanes[DRAG_C * LANES + i])
        if attempt_ == 1 or kind == EV_TIMEOUT or kind == EV_REVERSAL:
            break
        # an exit: Newton on x at the first step's end (its rate there: v); a
        # correction beyond a quarter of the step means the located event is
        # not trusted: keep the first step
        target = settings[SET_XHI] if kind == EV_EXIT_HI else settings[SET_XLO]
        correction = (target - x1) / v1 if v1 != 0.0 else 0.0
        h_new = h + correction
        if not (abs(correction) <= 0.25 * h and 0.0 < h_new <= h_end):
            break
        h = h_new
    w1 = lanes[W * LANES + i] + max(dw, 0.0)
    if DRAG:
        lanes[WD * LANES + i] += dwd
    if PROJECT_ENERGY and (kind == EV_REVERSAL or kind == EV_TIMEOUT):
        # as every accepted step (an exit puts x on the domain's end instead)
        work1 = w1
        if DRAG:
            work1 = w1 + lanes[WD * LANES + i]
        x1, v1, w1, removed = project_energy(
            x1, v1, lanes[W * LANES + i], w1, fp1, fpp1, lanes[Q * LANES + i], work1,
            lanes[E0 * LANES + i], lanes[G * LANES + i], lanes[P0 * LANES + i],
            lanes[P1 * LANES + i], lanes[P2 * LANES + i], lanes[P3 * LANES + i], shared,
            settings[SET_RTOL], settings[SET_ATOL])
        lanes[EPROJ * LANES + i] += removed
    lanes[X * LANES + i] = x1
    lanes[V * LANES + i] = v1
    lanes[W * LANES + i] = w1
    lanes[K * LANES + i] += dk
    lanes[STEPS * LANES + i] += 1.0
    return h
