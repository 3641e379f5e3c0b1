"""An independent, high-accuracy reference solver (scipy), for tests and benchmarks.

This module re-implements the physics of docs/physics.md §1 from scratch on top of
:func:`scipy.integrate.solve_ivp` (an adaptive embedded Runge-Kutta method,
DOP853 by default) so that the jitted engine can be checked against something
that shares none of its code: not ``rampwork.core.physics``, not the steppers,
not the event location, and (for the built-in families) not even the ramp
formulas, which are written out here again in closed form.  Only the settings
objects (:class:`~rampwork.scene.Scene`, :class:`~rampwork.ramps.Ramp`) and the
integer status codes are shared.

It needs scipy, which is a *test extra*: import it from tests and benchmarks
only, never from the package itself.

The model (per unit mass, state ``(x, v)`` with ``v = dx/dt``)::

    n  = g + v**2 f''(x)                      signed normal term
    a  = -(f' n + d mu_k |n|) / (1 + f'**2)   while moving in direction d
    W' = mu_k |n| |v|                         friction power (work integrated as a state)
    s' = |v|                                  horizontal path length

With air drag (``scene.drag``: b = linear in 1/s, c = quadratic in 1/m) the
tangential force -m (b u + c u**2), u = |v| sqrt(1 + f'**2) the speed along the
path, adds its component along x after projection on the tangent (1, f'),
divided by the mass term (1 + f'**2)::

    a_drag = -d (b u + c u**2) sqrt(1 + f'**2) / (1 + f'**2) = -(b + c u) v
    D' = (b u + c u**2) u                     drag power (drag work as a state)

Within one integration *segment* the direction ``d = sign(v)`` and the contact
sign ``s_n = sign(n)`` are held fixed, so ``|n| = s_n n`` and ``|v| = d v`` and the
right-hand side is smooth; every place where one of them would change is an
event that ends the segment:

* ``v = 0`` (reversal or stop): the rest rule decides.  At rest at ``x`` the
  particle stays for ever if ``|f'(x)| <= mu_s`` (status ``stuck``, ``v = 0``
  exactly); otherwise a new segment starts with ``v = 0`` in direction
  ``-sign(f'(x))`` (a reversal is counted when that direction differs from the
  previous one).  A start with ``v0 = 0`` is treated the same way.
* ``n = 0``: one-sided contact (a block on the surface) -> ``lifted_off``
  (terminal, with ``x_lift_off``); two-sided contact (a bead on a wire) -> the
  sign ``s_n`` flips and a new segment starts.
* ``x = x_min`` or ``x = x_max``: ``exited`` (terminal; ``x_end`` is set to the
  bound exactly).
* ``t = t_max``: ``timeout``.  A failure of the integrator or a non-finite state
  gives ``diverged``.

Events are located by scipy (Brent's method on the method's dense output), so
their accuracy follows ``rtol``/``atol``; the state there is then that of a step
of the method itself from the last step end to the event (an exit's time
corrected by Newton on x), not the dense output's, whose error is of the
tolerance's size (W at exits was off by up to 8e-13 at rtol 2.5e-14; stepped,
within 1.3e-14 of a long-double Taylor integration and of the bowl's closed
form).  Simultaneous events are resolved in
the order exit, contact, reversal.  scipy finds an event only where its
function changes sign between two step ends, so an exit inside a step that goes
past a domain end and back (a reversal just beyond the end) would be missed:
x being monotone within a segment, a segment that ends beyond an end is
recognised as such an exit, located on the dense output.

Main entry points:

* :func:`reference_trajectory` -- one trajectory of a scene (optionally with
  overrides of ``x0``, ``v0``, ``mu_k``, ``mu_s``, ``m``, ``g``, ``t_max``,
  ``contact``), returned as a dict of plain floats and ints.
* :func:`reference_sweep` -- every trajectory of a :class:`~rampwork.scene.Sweep`
  (same expansion as :func:`rampwork.simulate`), returned as a dict of arrays
  shaped like the sweep; for work-precision diagrams.
* :func:`ramp_functions` -- the closed forms ``f(x)`` and ``(f'(x), f''(x))``
  used for a ramp.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from .core.status import DIVERGED, EXITED, LIFTED_OFF, STUCK, TIMEOUT
from .ramps import Ramp
from .scene import Scene, Sweep

__all__ = [
    "RESULT_KEYS",
    "ramp_functions",
    "reference_trajectory",
    "reference_sweep",
]

#: keys of the dict returned by :func:`reference_trajectory` that hold one number
RESULT_KEYS = ("status", "t_end", "x_end", "v_end", "W_friction", "W_energy", "W_path", "path",
               "n_reversals", "x_lift_off", "n_segments", "nfev", "W_drag")

# event indices within one segment, in tie-break order (exit, contact, reversal)
_EV_EXIT_LO, _EV_EXIT_HI, _EV_CONTACT, _EV_REVERSAL = range(4)
_EVENT_NAMES = ("exit_lo", "exit_hi", "contact", "reversal")


# ----------------------------------------------------------------------------
# ramps in closed form
# ----------------------------------------------------------------------------
def _cycloid_half_angle(x: float, r: float) -> tuple[float, float]:
    """(sin(u/2), cos(u/2)) of the cycloid parameter u in (-pi, pi) with
    x = r (u + sin u): Brent's method on the monotone u + sin u, then Newton."""
    s = x / r
    if s == 0.0:
        return 0.0, 1.0
    g = lambda u: u + math.sin(u) - s  # noqa: E731
    u = brentq(g, -math.pi, math.pi, xtol=1e-300, rtol=4.0 * np.finfo(float).eps, maxiter=500)
    for _ in range(2):  # Newton polish (1 + cos u > 0 away from the cusps)
        der = 1.0 + math.cos(u)
        if der > 0.0:
            u -= g(u) / der
    return math.sin(0.5 * u), math.cos(0.5 * u)


def ramp_functions(ramp: Ramp) -> tuple[Callable[[float], float], Callable[[float], tuple[float, float]]]:
    """``(f, slope_curvature)``: ``f(x)`` and ``slope_curvature(x) -> (f'(x), f''(x))``
    for scalar ``x``.

    The built-in families are written out here in closed form, independently of
    :mod:`rampwork.core.ramps` (the cycloid through its parameter
    ``x = r (u + sin u)``, ``f' = tan(u/2)``, ``f'' = 1 / (4 r cos(u/2)**4)``);
    the spline and user callables fall back to :meth:`Ramp.evaluate`.
    """
    p = ramp.param_dict()
    family = ramp.family
    if family == "straight":
        slope, height = p["slope"], p["height"]
        return (lambda x: height + slope * x), (lambda x: (slope, 0.0))
    if family == "quadratic":
        c, b, h = p["curvature"], p["slope"], p["height"]
        return (lambda x: h + b * x + 0.5 * c * x * x), (lambda x: (b + c * x, c))
    if family in ("circular_bowl", "circular_dome"):
        r, xc = p["radius"], p["x_centre"]
        # y = yc + sign sqrt(R^2 - d^2); the bowl's centre is radius above its bottom
        yc = p["y_bottom"] + r if family == "circular_bowl" else p["y_centre"]
        sign = -1.0 if family == "circular_bowl" else 1.0

        def f(x):
            d = x - xc
            return yc + sign * math.sqrt((r - d) * (r + d))

        def sc(x):
            d = x - xc
            q = (r - d) * (r + d)
            s = math.sqrt(q)
            return -sign * d / s, -sign * r * r / (q * s)

        return f, sc
    if family == "sine":
        slope, amp, k, phase = p["mean_slope"], p["amplitude"], p["wavenumber"], p["phase"]
        return ((lambda x: slope * x + amp * math.sin(k * x + phase)),
                (lambda x: (slope + amp * k * math.cos(k * x + phase), -amp * k * k * math.sin(k * x + phase))))
    if family == "cycloid":
        r = p["radius"]

        def f(x):
            sh, _ = _cycloid_half_angle(x, r)
            return 2.0 * r * sh * sh

        def sc(x):
            sh, ch = _cycloid_half_angle(x, r)
            c2 = ch * ch
            return sh / ch, 1.0 / (4.0 * r * c2 * c2)

        return f, sc

    # spline, user callables: the ramp's own evaluation
    def f(x):
        return float(ramp.evaluate(np.array([x]))[0][0])

    def sc(x):
        _, fp, fpp = ramp.evaluate(np.array([x]))
        return float(fp[0]), float(fpp[0])

    return f, sc


# ----------------------------------------------------------------------------
# one trajectory
# ----------------------------------------------------------------------------
def _step_to(rhs, sol, t_target, method, rtol, atol):
    """(state at t_target, rhs evaluations) by stepping the method itself
    from the last step end at or before t_target (not from the dense
    output, whose error is of the tolerance's size: W at an exit taken from
    it was off by up to 8e-13 relative, 100 times the stepped solution's
    error, against a long-double Taylor reference).  ``sol.t[-1]`` is an
    event's time, not a step end, when an event ended the solve."""
    ends = sol.t[:-1] if sol.status == 1 else sol.t
    k = max(int(np.searchsorted(ends, t_target, side="right")) - 1, 0)
    t_start, y_start = float(ends[k]), sol.y[:, k]
    if not t_target > t_start:
        return y_start.copy(), 0
    with np.errstate(all="ignore"):
        step = solve_ivp(rhs, (t_start, t_target), y_start, method=method, rtol=rtol, atol=atol,
                         first_step=t_target - t_start)
    if step.status != 0 or not np.all(np.isfinite(step.y[:, -1])):
        return sol.sol(t_target), step.nfev  # keep the dense output's value
    return step.y[:, -1], step.nfev


def _step_to_exit(rhs, sol, t_event, bound, method, rtol, atol):
    """(time, state, rhs evaluations) at x = bound: a step to the located
    time, then Newton steps on x (its rate: v) from there, as W depends on
    the exit's time (W' = mu |n| |v| > 0 there)."""
    y, nfev = _step_to(rhs, sol, t_event, method, rtol, atol)
    for _ in range(3):
        if y[1] == 0.0:
            break
        correction = (bound - y[0]) / y[1]
        if not abs(correction) <= 1e-6 * max(abs(t_event), 1.0) or correction == 0.0:
            break
        t_event += correction
        y, more = _step_to(rhs, sol, t_event, method, rtol, atol)
        nfev += more
    return t_event, y, nfev


def _unpack(y) -> tuple[float, ...]:
    """(x, v, W, path, drag work) from a state of four (no drag) or five."""
    values = [float(z) for z in y]
    return tuple(values) if len(values) == 5 else (*values, 0.0)


def reference_trajectory(scene: Scene, x0: float | None = None, v0: float | None = None,
                         mu_k: float | None = None, mu_s: float | None = None, *,
                         m: float | None = None, g: float | None = None, t_max: float | None = None,
                         contact: str | None = None, ramp: Ramp | None = None,
                         drag_linear: float | None = None, drag_quadratic: float | None = None,
                         method: str = "DOP853", rtol: float = 1e-12, atol: float = 1e-12,
                         max_segments: int = 100_000, keep_segments: bool = False) -> dict:
    """Integrate one trajectory of ``scene`` to high accuracy with scipy.

    The scene's own values are used where an argument is ``None``
    (``mu_s=None`` with ``mu_k`` given means ``mu_s = max(mu_k, scene's mu_s)``
    unless the scene's ``mu_s`` equals its ``mu_k``, in which case ``mu_s = mu_k``;
    pass both to be explicit).  ``ramp`` replaces the scene's ramp (e.g. with
    other shape parameters).  ``method``, ``rtol``, ``atol`` go to
    :func:`scipy.integrate.solve_ivp` (``atol`` applies to x, v, W and the path).
    The scene's integrator settings are ignored.

    Returns a dict with

    * ``status`` (rampwork's integer codes: 1 stuck, 2 exited, 3 lifted_off,
      4 timeout, 5 diverged), ``t_end`` (s), ``x_end`` (m), ``v_end`` (m/s),
    * ``W_friction`` (J, integrated ``m mu_k |n| |v|``), ``W_energy`` (J,
      mechanical energy lost, ``m (E0 - E_end)``), ``W_path`` (J,
      ``mu_k m g path``), ``path`` (m, ``integral |v| dt``),
    * ``W_drag`` (J, integrated drag power ``m (b u + c u^2) u``, u the speed
      along the path; 0 without drag; ``drag_linear``, ``drag_quadratic``
      override the scene's ``drag``),
    * ``n_reversals``, ``x_lift_off`` (NaN unless lifted off),
    * ``n_segments`` and ``nfev`` (cost: segments integrated, right-hand-side
      evaluations),
    * ``events``: a list of dicts, one per event that ended a segment, with
      ``kind`` ("start", "reversal", "stop", "contact", "lift_off", "exit",
      "timeout", "diverged"), ``t``, ``x``, ``v``, ``fp``, ``fpp``, ``n``, and
      for rest events ``margin = |f'(x)| - mu_s`` (how far the rest rule's
      decision is from its threshold, useful to flag ill-conditioned cases),
    * with ``keep_segments``: ``segments``, a list of
      ``(t, y)`` arrays (``y`` rows x, v, W per unit mass, path, drag work
      per unit mass) per segment.
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"expected a rampwork.Scene, got {type(scene).__name__}")
    ramp = scene.ramp if ramp is None else ramp
    x = float(scene.x0 if x0 is None else x0)
    v = float(scene.v0 if v0 is None else v0)
    if mu_k is None:
        mu_k = scene.friction.mu_k
        mu_s = scene.friction.mu_s if mu_s is None else mu_s
    elif mu_s is None:
        mu_s = mu_k if scene.friction.mu_s == scene.friction.mu_k else max(mu_k, scene.friction.mu_s)
    mu_k, mu_s = float(mu_k), float(mu_s)
    if mu_k < 0 or mu_s < mu_k:
        raise ValueError(f"need 0 <= mu_k <= mu_s, got mu_k={mu_k}, mu_s={mu_s}")
    mass = float(scene.m if m is None else m)
    g = float(scene.g if g is None else g)
    t_max = float(scene.t_max if t_max is None else t_max)
    contact = scene.contact if contact is None else contact
    if contact not in ("one_sided", "two_sided"):
        raise ValueError(f"contact must be 'one_sided' or 'two_sided', got {contact!r}")
    one_sided = contact == "one_sided"
    drag_b = float(scene.drag.linear if drag_linear is None else drag_linear)
    drag_c = float(scene.drag.quadratic if drag_quadratic is None else drag_quadratic)
    if drag_b < 0 or drag_c < 0:
        raise ValueError(f"need drag coefficients >= 0, got {drag_b}, {drag_c}")
    # the drag work is a fifth state only with drag (without it the error norm,
    # and so every result, stays that of four states)
    with_drag = drag_b > 0 or drag_c > 0
    lo, hi = ramp.domain
    if not lo <= x <= hi:
        raise ValueError(f"x0 = {x} outside the domain [{lo}, {hi}]")
    f_of, slope_curvature = ramp_functions(ramp)

    def energy(x, v):
        fp, _ = slope_curvature(x)
        return g * f_of(x) + 0.5 * v * v * (1.0 + fp * fp)

    e0 = energy(x, v)
    t = 0.0
    work = 0.0
    path = 0.0
    drag_work = 0.0
    n_rev = 0
    nfev = 0
    n_segments = 0
    events: list[dict] = []
    segments: list = []

    def note(kind, t, x, v, **extra):
        fp, fpp = slope_curvature(x)
        record = dict(kind=kind, t=t, x=x, v=v, fp=fp, fpp=fpp, n=g + v * v * fpp)
        record.update(extra)
        events.append(record)
        return fp, fpp

    def finish(status, t, x, v, x_lift=math.nan):
        finite = all(math.isfinite(z) for z in (t, x, v, work, path, drag_work))
        if not finite:
            status = DIVERGED
        w_energy = mass * (e0 - energy(x, v)) if finite else math.nan
        out = dict(status=int(status), t_end=float(t), x_end=float(x), v_end=float(v),
                   W_friction=mass * work, W_energy=w_energy, W_path=mu_k * mass * g * path,
                   path=path, n_reversals=n_rev, x_lift_off=float(x_lift), n_segments=n_segments,
                   nfev=nfev, events=events, W_drag=mass * drag_work)
        if keep_segments:
            out["segments"] = segments
        return out

    def rest_direction(fp):
        """The rest rule: 0 (stays) if |f'| <= mu_s, else -sign(f')."""
        if abs(fp) <= mu_s:
            return 0.0
        return -1.0 if fp > 0.0 else 1.0

    # ---- the start
    fp, fpp = slope_curvature(x)
    n = g + v * v * fpp
    if v == 0.0:
        d = rest_direction(fp)
        events.append(dict(kind="start", t=0.0, x=x, v=v, fp=fp, fpp=fpp, n=n, margin=abs(fp) - mu_s))
        if d == 0.0:
            return finish(STUCK, 0.0, x, 0.0)
    else:
        d = 1.0 if v > 0.0 else -1.0
        events.append(dict(kind="start", t=0.0, x=x, v=v, fp=fp, fpp=fpp, n=n))
    if one_sided and n <= 0.0:
        return finish(LIFTED_OFF, 0.0, x, v, x_lift=x)
    s_n = 1.0 if (one_sided or n >= 0.0) else -1.0
    if (x >= hi and d > 0.0) or (x <= lo and d < 0.0):
        return finish(EXITED, 0.0, x, v)

    # ---- segments between events
    while True:
        if t >= t_max:
            note("timeout", t, x, v)
            return finish(TIMEOUT, t_max, x, v)
        if n_segments >= max_segments:
            raise RuntimeError(f"reference_trajectory: more than {max_segments} segments "
                               f"(Zeno-like chattering?) at t = {t}, x = {x}")
        n_segments += 1
        q = d * mu_k * s_n  # |n| = s_n n and |v| = d v within the segment

        def rhs(_t, y, q=q, d=d):
            x_, v_ = y[0], y[1]
            fp_, fpp_ = slope_curvature(x_)
            n_ = g + v_ * v_ * fpp_
            stretch = math.sqrt(1.0 + fp_ * fp_)  # ds/dx along the ramp
            u = d * v_ * stretch  # speed along the path (>= 0 in the segment)
            drag_force = drag_b * u + drag_c * u * u  # per unit mass, against the motion
            # its generalised force on x, (force along the tangent) . (1, f'), over 1 + f'^2
            a_drag = -d * drag_force * stretch / (1.0 + fp_ * fp_)
            rates = [v_, -n_ * (fp_ + q) / (1.0 + fp_ * fp_), q * n_ * v_, d * v_]
            if with_drag:
                rates[1] += a_drag
                rates.append(drag_force * u)
            return rates

        def ev_exit_lo(_t, y):
            return y[0] - lo

        def ev_exit_hi(_t, y):
            return hi - y[0]

        def ev_contact(_t, y, s_n=s_n):
            return s_n * (g + y[1] * y[1] * slope_curvature(y[0])[1])

        def ev_reversal(_t, y, d=d):
            return d * y[1]

        handlers = [ev_exit_lo, ev_exit_hi, ev_contact, ev_reversal]
        for h in handlers:
            h.terminal = True
            h.direction = -1.0  # each is > 0 inside the segment and falls through 0 at the event

        try:
            with np.errstate(all="ignore"):
                start = [x, v, work, path] + ([drag_work] if with_drag else [])
                sol = solve_ivp(rhs, (t, t_max), start, method=method, rtol=rtol,
                                atol=atol, events=handlers, dense_output=True)
        except (ValueError, ZeroDivisionError, OverflowError, FloatingPointError) as error:
            note("diverged", t, x, v, message=str(error))
            return finish(DIVERGED, t, x, v)
        nfev += sol.nfev
        if keep_segments:
            segments.append((sol.t, sol.y))
        if sol.status == -1 or not np.all(np.isfinite(sol.y[:, -1])):
            events.append(dict(kind="diverged", t=float(sol.t[-1]), x=float(sol.y[0, -1]),
                               v=float(sol.y[1, -1]), message=sol.message))
            return finish(DIVERGED, float(sol.t[-1]), float(sol.y[0, -1]), float(sol.y[1, -1]))

        t_start = t
        if sol.status == 0:  # reached t_max
            kind, t_event = None, t_max
            end = sol.y[:, -1]
        else:  # a terminal event: the earliest (ties: exit, contact, reversal)
            kind, t_event = None, math.inf
            for k in range(4):
                if len(sol.t_events[k]) and sol.t_events[k][0] < t_event:
                    kind, t_event = k, float(sol.t_events[k][0])
            if kind in (_EV_EXIT_LO, _EV_EXIT_HI):
                t_event, end, more = _step_to_exit(rhs, sol, t_event,
                                                   lo if kind == _EV_EXIT_LO else hi,
                                                   method, rtol, atol)
            else:  # at a rest or a lift-off the event's time enters to second order
                end, more = _step_to(rhs, sol, t_event, method, rtol, atol)
            nfev += more
        x, v, work, path, drag_work = _unpack(end)
        t = t_event
        if kind not in (_EV_EXIT_LO, _EV_EXIT_HI) and not lo <= x <= hi:
            # x is monotone within a segment (v keeps the sign d), so a segment
            # that ends beyond a domain end crossed it first, inside a step that
            # went past the end and (at a reversal) back: solve_ivp tests an
            # event's sign only at step ends and cannot see that exit.  Locate
            # it on the dense output.
            bound = lo if x < lo else hi
            t = brentq(lambda tt: float(sol.sol(tt)[0]) - bound, t_start, t_event,
                       xtol=1e-300, rtol=4.0 * np.finfo(float).eps, maxiter=500)
            t, end, more = _step_to_exit(rhs, sol, t, bound, method, rtol, atol)
            nfev += more
            _, v, work, path, drag_work = _unpack(end)
            note("exit", t, bound, v, missed_by_sign_test=True)
            return finish(EXITED, t, bound, v)
        if kind is None:
            note("timeout", t, x, v)
            return finish(TIMEOUT, t, x, v)

        if kind in (_EV_EXIT_LO, _EV_EXIT_HI):
            x = lo if kind == _EV_EXIT_LO else hi
            note("exit", t, x, v)
            return finish(EXITED, t, x, v)
        if kind == _EV_CONTACT:
            if one_sided:
                note("lift_off", t, x, v)
                return finish(LIFTED_OFF, t, x, v, x_lift=x)
            note("contact", t, x, v)
            s_n = -s_n
            continue
        # reversal or stop: v reached 0; the rest rule decides
        v = 0.0
        fp, _ = slope_curvature(x)
        direction = rest_direction(fp)
        note("stop" if direction == 0.0 else "reversal", t, x, v, margin=abs(fp) - mu_s)
        if direction == 0.0:
            return finish(STUCK, t, x, 0.0)
        if direction != d:
            n_rev += 1
        d = direction
        s_n = 1.0  # at rest n = g > 0


# ----------------------------------------------------------------------------
# a whole sweep
# ----------------------------------------------------------------------------
_SCENE_NAMES = ("x0", "v0", "m", "g")


def _sweep_points(scene: Scene, sweep: Sweep):
    """Each trajectory's overrides, in the flat order rampwork.simulate uses."""
    axes = sweep.axes
    if sweep.design is not None:
        for start in range(0, sweep.size, 4096):
            values = sweep.design.draw(start, min(start + 4096, sweep.size))
            for j in range(len(next(iter(values.values())))):
                yield {name: column[j] for name, column in values.items()}
        return
    if not axes:
        yield {}
        return
    if sweep.kind == "cases":
        for j in range(sweep.size):
            yield {name: values[j] for name, values in axes}
        return
    shape = sweep.shape
    for j in range(sweep.size):
        index = np.unravel_index(j, shape)
        yield {name: values[index[k]] for k, (name, values) in enumerate(axes)}


def reference_sweep(scene: Scene, sweep: Sweep | None = None, **options) -> dict[str, np.ndarray]:
    """:func:`reference_trajectory` for every trajectory of ``sweep`` (default:
    the scene's single trajectory).  Axes are expanded as by
    :func:`rampwork.simulate` (``mu`` sets ``mu_k`` and ``mu_s``; ramp shape
    parameters rebuild the ramp).  ``options`` go to :func:`reference_trajectory`.

    Returns a dict of arrays shaped like the sweep (``()`` for no sweep), one
    per key of :data:`RESULT_KEYS`.
    """
    sweep = Sweep.single() if sweep is None else sweep
    shape = sweep.shape if sweep.names else ()
    base_params = scene.ramp.param_dict()
    results: dict[str, list] = {key: [] for key in RESULT_KEYS}
    for point in _sweep_points(scene, sweep):
        kwargs = {name: point[name] for name in _SCENE_NAMES if name in point}
        for name in ("drag_linear", "drag_quadratic"):
            if name in point:
                kwargs[name] = point[name]
        if "mu" in point:
            kwargs["mu_k"] = kwargs["mu_s"] = point["mu"]
        else:
            mu_k = point.get("mu_k", scene.friction.mu_k)
            mu_s = point.get("mu_s", scene.friction.mu_s)
            kwargs["mu_k"], kwargs["mu_s"] = mu_k, mu_s
        shape_params = {name: point[name] for name in base_params if name in point}
        if shape_params:
            params = dict(base_params, **shape_params)
            kwargs["ramp"] = Ramp.create(scene.ramp.family, domain=scene.ramp.domain, **params)
        out = reference_trajectory(scene, **kwargs, **options)
        for key in RESULT_KEYS:
            results[key].append(out[key])
    arrays = {}
    for key, values in results.items():
        dtype = np.int64 if key in ("status", "n_reversals", "n_segments", "nfev") else np.float64
        arrays[key] = np.asarray(values, dtype=dtype).reshape(shape)
    return arrays
