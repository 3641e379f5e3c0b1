"""Peer integrators on rampwork's physics: heyoka (Taylor) and CyRK (Runge-Kutta).

Both integrate the model of docs/physics.md §1 with the event logic of
``rampwork.reference`` (the template: one segment per direction d of motion,
right-hand side smooth within it, ended by a terminal event):

    n  = g + v**2 f''(x),  q = d mu_k (one-sided contact: n > 0 in a segment)
    x' = v,  v' = -n (f' + q) / (1 + f'**2),  W' = q n v  (friction work per unit mass)

events (each > 0 inside a segment, falling through 0): the reversal ``d v``
(then the rest rule: stuck if ``|f'(x)| <= mu_s``, else on in direction
``-sign f'``, a reversal counted when d changes), the exits ``x - x_min`` and
``x_max - x`` (x_end set to the end), and, on ramps with f'' < 0 somewhere,
the contact ``n`` (one-sided: lifted_off).  ``t_max``: timeout; a non-finite
state: diverged.  States: x, v, W (rampwork also integrates the path; the peers
are spared it).

* **heyoka** (``taylor_adaptive_batch``, the recommended SIMD batch size, i.e.
  8 lanes on AVX-512): events are found exactly on the Taylor polynomial of the
  step.  A lane that ends is refilled with the next trajectory (as rampwork's
  lanes are).  In batch mode a terminal event in one lane stops the call for all
  lanes, so the event logic runs in Python between calls.  Run on 2 worker
  processes (like rampwork's 2 threads); an integrator is built once per worker
  and tolerance (its compile is excluded from the timings by a warm-up call).
* **CyRK** (``pysolve_ivp``, its C++ DOP853 / RK45): events as in scipy, located
  (Brent on the dense output) only where an event function changes sign between
  two step ends, so an event whose function comes back within one step is
  missed; such wrong outcomes are counted, not hidden.  The right-hand side and
  the events in C (``_cyrk_ramp.pyx``, built with Cython on first use:
  :func:`cyrk_compiled_chunk`), or, where that does not build, Python functions
  through ``pysolve_ivp`` (:func:`cyrk_chunk`, same steps, about 50x slower);
  2 worker processes.

The ramps: straight, quadratic, circular bowl and dome, sine (closed forms, as
in rampwork.reference).  Needs the optional ``bench`` extra; import errors are
reported by :func:`availability`, never raised at import.
"""

from __future__ import annotations

import math
import time

import numpy as np

STUCK, EXITED, LIFTED_OFF, TIMEOUT, DIVERGED = 1, 2, 3, 4, 5
FAMILIES = ("straight", "quadratic", "circular_bowl", "circular_dome", "sine")
#: worker processes of each peer (rampwork runs on 2 threads)
WORKERS = 2
_EV_REVERSAL, _EV_EXIT_LO, _EV_EXIT_HI, _EV_CONTACT = range(4)


def availability() -> dict:
    """{"heyoka": version or None, "cyrk": ..., "why": {name: reason}}."""
    out = {"why": {}}
    for name, module in (("heyoka", "heyoka"), ("cyrk", "CyRK")):
        try:
            mod = __import__(module)
            out[name] = str(getattr(mod, "__version__", "?"))
        except Exception as error:  # noqa: BLE001 - any import failure means "not available"
            out[name] = None
            out["why"][name] = f"{module} not importable ({error}); pip install -e '.[bench]'"
    return out


# ------------------------------------------------------------------------------
# the ramp: one description for both peers
# ------------------------------------------------------------------------------
def ramp_key(family: str, params: dict, domain, g: float, t_max: float) -> tuple:
    if family not in FAMILIES:
        raise ValueError(f"peers support {FAMILIES}, not {family!r}")
    return (family, tuple(sorted(params.items())), tuple(map(float, domain)), float(g), float(t_max))


def _params(key) -> dict:
    return dict(key[1])


def may_lift_off(key) -> bool:
    """True where f'' < 0 somewhere on the domain (n can reach 0)."""
    family, p = key[0], _params(key)
    if family == "circular_dome":
        return True
    if family == "sine":
        return p["amplitude"] != 0.0 and p["wavenumber"] != 0.0
    return family == "quadratic" and p["curvature"] < 0.0


def slope_curvature(key):
    """Python (f'(x), f''(x)) of the ramp (rampwork.reference's closed forms)."""
    family, p = key[0], _params(key)
    if family == "straight":
        return lambda x: (p["slope"], 0.0)
    if family == "quadratic":
        c, b = p["curvature"], p["slope"]
        return lambda x: (b + c * x, c)
    if family in ("circular_bowl", "circular_dome"):
        r, xc = p["radius"], p["x_centre"]
        sign = -1.0 if family == "circular_bowl" else 1.0

        def sc(x):
            d = x - xc
            q = (r - d) * (r + d)
            s = math.sqrt(q)
            return -sign * d / s, -sign * r * r / (q * s)

        return sc
    slope, amp, k, ph = p["mean_slope"], p["amplitude"], p["wavenumber"], p["phase"]
    return lambda x: (slope + amp * k * math.cos(k * x + ph), -amp * k * k * math.sin(k * x + ph))


def _hy_slope_curvature(key, hy, x):
    """heyoka expressions of f'(x), f''(x)."""
    family, p = key[0], _params(key)
    if family == "straight":
        return p["slope"] + 0.0 * x, 0.0 * x
    if family == "quadratic":
        return p["slope"] + p["curvature"] * x, p["curvature"] + 0.0 * x
    if family in ("circular_bowl", "circular_dome"):
        r, xc = p["radius"], p["x_centre"]
        sign = -1.0 if family == "circular_bowl" else 1.0
        d = x - xc
        q = (r - d) * (r + d)
        s = hy.sqrt(q)
        return -sign * d / s, -sign * r * r / (q * s)
    slope, amp, k, ph = p["mean_slope"], p["amplitude"], p["wavenumber"], p["phase"]
    return slope + amp * k * hy.cos(k * x + ph), -amp * k * k * hy.sin(k * x + ph)


# ------------------------------------------------------------------------------
# the start and the rest rule, shared by both peers
# ------------------------------------------------------------------------------
def rest_direction(fp: float, mu_s: float) -> float:
    if abs(fp) <= mu_s:
        return 0.0
    return -1.0 if fp > 0.0 else 1.0


def start(key, sc, x, v, mu_s):
    """(status or 0, d) at t = 0 (rampwork.reference's start)."""
    lo, hi = key[2]
    g = key[3]
    fp, fpp = sc(x)
    if v == 0.0:
        d = rest_direction(fp, mu_s)
        if d == 0.0:
            return STUCK, 0.0
    else:
        d = 1.0 if v > 0.0 else -1.0
    if g + v * v * fpp <= 0.0:
        return LIFTED_OFF, d
    if (x >= hi and d > 0.0) or (x <= lo and d < 0.0):
        return EXITED, d
    return 0, d


def _empty(n):
    return {"status": np.zeros(n, np.int64), "x_end": np.full(n, np.nan), "t_end": np.full(n, np.nan),
            "W_friction": np.full(n, np.nan), "n_reversals": np.zeros(n, np.int64),
            "steps": np.zeros(n, np.int64)}


# ------------------------------------------------------------------------------
# heyoka
# ------------------------------------------------------------------------------
_HY_CACHE: dict = {}


def heyoka_integrator(key, tol):
    """A taylor_adaptive_batch for the ramp (cached per process): parameters
    par[0] = q = d mu_k, par[1] = d."""
    cache_key = (key, float(tol))
    if cache_key not in _HY_CACHE:
        import heyoka as hy

        x, v, w = hy.make_vars("x", "v", "w")
        g = key[3]
        lo, hi = key[2]
        fp, fpp = _hy_slope_curvature(key, hy, x)
        n = g + v * v * fpp
        q, d = hy.par[0], hy.par[1]
        system = [(x, v), (v, -n * (fp + q) / (1.0 + fp * fp)), (w, q * n * v)]
        neg = hy.event_direction.negative
        events = [hy.t_event_batch(d * v, direction=neg), hy.t_event_batch(x - lo, direction=neg),
                  hy.t_event_batch(hi - x, direction=neg)]
        if may_lift_off(key):
            events.append(hy.t_event_batch(n, direction=neg))
        batch = hy.recommended_simd_size()
        state = np.zeros((3, batch))
        state[0] = 0.5 * (lo + hi)
        started = time.perf_counter()
        ta = hy.taylor_adaptive_batch(system, state, pars=np.ones((2, batch)), tol=tol, t_events=events)
        _HY_CACHE[cache_key] = (ta, time.perf_counter() - started)
    return _HY_CACHE[cache_key]


def heyoka_chunk(task):
    """Integrate trajectories ``x0, v0, mu_k, mu_s`` (arrays) with heyoka; the
    lanes of one batch integrator are refilled as trajectories end."""
    key, tol, x0, v0, mu_k, mu_s = task
    import heyoka as hy

    ta, compile_s = heyoka_integrator(key, tol)
    sc = slope_curvature(key)
    lo, hi = key[2]
    t_max = key[4]
    n = len(x0)
    out = _empty(n)
    batch = ta.batch_size
    state, pars = ta.state, ta.pars
    new_time = {}  # lanes refilled (time 0) or parked (t_max) since the last call
    lane_of = [-1] * batch  # trajectory in each lane (-1: parked at t_max)
    direction = np.zeros(batch)
    success, time_limit = hy.taylor_outcome.success, int(hy.taylor_outcome.time_limit)
    lanes = range(batch)
    steps_total = 0
    propagate_s = 0.0  # time inside heyoka's propagate_until (the rest is this Python driver)
    following = [0]

    def finish(lane, j, status, t, x, v, w):
        out["status"][j], out["t_end"][j], out["x_end"][j], out["W_friction"][j] = status, t, x, w
        lane_of[lane] = -1
        load(lane)

    def load(lane):
        while following[0] < n:
            j = following[0]
            following[0] += 1
            status, d = start(key, sc, x0[j], v0[j], mu_s[j])
            if status:
                out["status"][j], out["t_end"][j], out["x_end"][j], out["W_friction"][j] = \
                    status, 0.0, x0[j], 0.0
                continue
            lane_of[lane] = j
            state[:, lane] = (x0[j], v0[j], 0.0)
            pars[:, lane] = (d * mu_k[j], d)
            direction[lane] = d
            new_time[lane] = 0.0
            ta.reset_cooldowns(lane)  # else the last trajectory's event cooldown masks this one's events
            return
        state[:, lane] = (0.5 * (lo + hi), 0.0, 0.0)  # parked: no step is taken at t_max
        new_time[lane] = t_max

    for lane in range(batch):
        load(lane)
    while True:
        if new_time:
            now = ta.time.copy()
            for lane, t in new_time.items():
                now[lane] = t
            ta.set_time(now)
            new_time.clear()
        if all(j < 0 for j in lane_of):
            break
        started = time.perf_counter()
        ta.propagate_until(t_max)
        propagate_s += time.perf_counter() - started
        res = ta.propagate_res
        steps_total += sum(r[3] for r in res)
        # the driver is Python: touch only the lanes whose trajectory ended or stopped
        ended = [lane for lane in lanes if res[lane][0] != success and lane_of[lane] >= 0]
        if not ended:
            continue
        now = ta.time
        for lane in ended:
            j = lane_of[lane]
            code = int(res[lane][0])
            x, v, w = state[:, lane]
            t = now[lane]
            if not (math.isfinite(x) and math.isfinite(v) and math.isfinite(w)) or code not in (
                    time_limit, -1 - _EV_REVERSAL, -1 - _EV_EXIT_LO, -1 - _EV_EXIT_HI, -1 - _EV_CONTACT):
                finish(lane, j, DIVERGED, t, x, v, w)
            elif code == time_limit:
                finish(lane, j, TIMEOUT, t, x, v, w)
            elif code in (-1 - _EV_EXIT_LO, -1 - _EV_EXIT_HI):
                finish(lane, j, EXITED, t, lo if code == -1 - _EV_EXIT_LO else hi, v, w)
            elif code == -1 - _EV_CONTACT:
                finish(lane, j, LIFTED_OFF, t, x, v, w)
            else:  # v reached 0: the rest rule
                d = rest_direction(sc(x)[0], mu_s[j])
                if d == 0.0:
                    finish(lane, j, STUCK, t, x, 0.0, w)
                    continue
                out["n_reversals"][j] += d != direction[lane]
                direction[lane] = d
                state[1, lane] = 0.0
                pars[:, lane] = (d * mu_k[j], d)
    # steps are counted per call over all lanes (a lane's own count would cost a
    # Python loop over every lane at every call): the mean per trajectory
    out["steps"][:] = round(steps_total / max(n, 1))
    out["compile_s"], out["propagate_s"] = compile_s, propagate_s
    return out


# ------------------------------------------------------------------------------
# CyRK
# ------------------------------------------------------------------------------
def cyrk_chunk(task):
    """Integrate trajectories with CyRK's pysolve_ivp (method "DOP853" or
    "RK45", rtol = atol = tol), one segment per call, scipy-style events."""
    key, method, tol, x0, v0, mu_k, mu_s = task
    from CyRK import pysolve_ivp

    sc = slope_curvature(key)
    g = key[3]
    lo, hi = key[2]
    t_max = key[4]
    lift = may_lift_off(key)
    n = len(x0)
    out = _empty(n)

    def rhs(dy, _t, y, q):
        fp, fpp = sc(y[0])
        nn = g + y[1] * y[1] * fpp
        dy[0] = y[1]
        dy[1] = -nn * (fp + q) / (1.0 + fp * fp)
        dy[2] = q * nn * y[1]

    def ev_reversal(_t, y, q):
        return y[1] if q > 0.0 else -y[1]  # d v (sign of q = d; mu_k = 0 handled by _sign_q)

    def ev_exit_lo(_t, y, q):
        return y[0] - lo

    def ev_exit_hi(_t, y, q):
        return hi - y[0]

    def ev_contact(_t, y, q):
        return g + y[1] * y[1] * sc(y[0])[1]

    events = [ev_reversal, ev_exit_lo, ev_exit_hi] + ([ev_contact] if lift else [])
    for ev in events:
        ev.terminal, ev.direction = 1, -1
    for j in range(n):
        x, v, w, t = float(x0[j]), float(v0[j]), 0.0, 0.0
        status, d = start(key, sc, x, v, mu_s[j])
        steps = 0
        while not status:
            q = _sign_q(d, mu_k[j])
            sol = pysolve_ivp(rhs, (t, t_max), np.array([x, v, w]), method=method, rtol=tol, atol=tol,
                              events=events, args=(q,), pass_dy_as_arg=True)
            steps += sol.steps_taken
            t, (x, v, w) = float(sol.t[-1]), (float(z) for z in sol.y[:, -1])
            if not sol.success or not (math.isfinite(x) and math.isfinite(v) and math.isfinite(w)):
                status = DIVERGED
            elif not sol.event_terminated:
                status = TIMEOUT
            else:
                which = sol.event_terminate_index
                if which in (_EV_EXIT_LO, _EV_EXIT_HI):
                    status, x = EXITED, (lo if which == _EV_EXIT_LO else hi)
                elif which == _EV_CONTACT:
                    status = LIFTED_OFF
                else:
                    v = 0.0
                    new_d = rest_direction(sc(x)[0], mu_s[j])
                    if new_d == 0.0:
                        status = STUCK
                    else:
                        out["n_reversals"][j] += new_d != d
                        d = new_d
        out["status"][j], out["t_end"][j], out["x_end"][j], out["W_friction"][j] = status, t, x, w
        out["steps"][j] = steps
    return out


def _sign_q(d, mu_k):
    """q = d mu_k, carrying d's sign also where mu_k = 0 (the reversal event reads it)."""
    return math.copysign(float(mu_k), d)


# ------------------------------------------------------------------------------
# CyRK, compiled: _cyrk_ramp.pyx (needs Cython and a C++ compiler at first use)
# ------------------------------------------------------------------------------
BUILD_DIR = __import__("pathlib").Path(__file__).resolve().parent / ".build"


def build_cyrk():
    """Import the compiled CyRK adapter, building it into benchmarks/.build on
    first use; (module, None) or (None, why)."""
    import importlib
    import pathlib
    import sys

    here = pathlib.Path(__file__).resolve().parent
    if str(BUILD_DIR) not in sys.path:
        sys.path.insert(0, str(BUILD_DIR))
    try:
        return importlib.import_module("_cyrk_ramp"), None
    except ImportError:
        pass
    try:
        import contextlib
        import io

        import CyRK
        from Cython.Build import cythonize
        from setuptools import Extension
        from setuptools.dist import Distribution

        BUILD_DIR.mkdir(exist_ok=True)
        ext = Extension("_cyrk_ramp", [str(here / "_cyrk_ramp.pyx")],
                        include_dirs=[np.get_include(), *CyRK.get_include()], language="c++",
                        extra_compile_args=["-std=c++20", "-O3", "-w"])
        dist = Distribution({"ext_modules": cythonize([ext], quiet=True, build_dir=str(BUILD_DIR / "c"))})
        cmd = dist.get_command_obj("build_ext")
        cmd.build_lib, cmd.build_temp = str(BUILD_DIR), str(BUILD_DIR / "tmp")
        with contextlib.redirect_stdout(io.StringIO()):
            dist.run_command("build_ext")
        importlib.invalidate_caches()
        return importlib.import_module("_cyrk_ramp"), None
    except Exception as error:  # noqa: BLE001 - no compiler, no Cython...: fall back, say why
        return None, f"compiled CyRK adapter not built ({type(error).__name__}: {error})"


def cyrk_compiled_chunk(task):
    """cyrk_chunk with the compiled adapter (the right-hand side and events in C)."""
    key, method, tol, x0, v0, mu_k, mu_s = task
    module, why = build_cyrk()
    if module is None:
        raise RuntimeError(why)
    p = _params(key)
    family = key[0]
    params = {"straight": (p.get("slope", 0.0), 0.0, 0.0, 0.0),
              "quadratic": (p.get("curvature", 0.0), p.get("slope", 0.0), 0.0, 0.0),
              "sine": (p.get("mean_slope", 0.0), p.get("amplitude", 0.0), p.get("wavenumber", 0.0),
                       p.get("phase", 0.0))}.get(family, (p.get("radius", 1.0), p.get("x_centre", 0.0), 0.0, 0.0))
    lo, hi = key[2]
    return module.solve(family, params, key[3], lo, hi, key[4], may_lift_off(key), method, tol,
                        x0, v0, mu_k, mu_s)
