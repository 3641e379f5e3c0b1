# distutils: language = c++
# cython: boundscheck=False, wraparound=False, cdivision=True, language_level=3
"""CyRK's C++ solver on rampwork's physics, compiled (built by peers.build_cyrk).

The same segments and events as peers.cyrk_chunk (see peers.py), with the
right-hand side and the event functions in C and the whole trajectory loop
without the GIL, so that 2 Python threads run 2 chunks at once.
"""
from libc.math cimport sqrt, sin, cos, fabs, copysign, isfinite, NAN
from libcpp.vector cimport vector
from libcpp.memory cimport unique_ptr, make_unique

from CyRK.cy.common cimport PreEvalFunc, MAX_STEP
from CyRK.cy.events cimport Event, EventFunc
from CyRK.cy.cysolver_api cimport CySolverResult, ODEMethod, baseline_cysolve_ivp_noreturn

import numpy as np

cdef enum:
    STRAIGHT = 0
    QUADRATIC = 1
    BOWL = 2
    DOME = 3
    SINE = 4

cdef struct RampArgs:
    double q      # d mu_k
    double d      # direction of motion
    double g
    double lo
    double hi
    double p0, p1, p2, p3
    int family


cdef inline void slope_curvature(const RampArgs* a, double x, double* fp, double* fpp) noexcept nogil:
    cdef double dd, qq, s, sign
    if a.family == STRAIGHT:
        fp[0] = a.p0
        fpp[0] = 0.0
    elif a.family == QUADRATIC:  # p0 curvature, p1 slope
        fp[0] = a.p1 + a.p0 * x
        fpp[0] = a.p0
    elif a.family == BOWL or a.family == DOME:  # p0 radius, p1 x_centre
        sign = -1.0 if a.family == BOWL else 1.0
        dd = x - a.p1
        qq = (a.p0 - dd) * (a.p0 + dd)
        s = sqrt(qq)
        fp[0] = -sign * dd / s
        fpp[0] = -sign * a.p0 * a.p0 / (qq * s)
    else:  # p0 mean slope, p1 amplitude, p2 wavenumber, p3 phase
        fp[0] = a.p0 + a.p1 * a.p2 * cos(a.p2 * x + a.p3)
        fpp[0] = -a.p1 * a.p2 * a.p2 * sin(a.p2 * x + a.p3)


cdef void rhs(double* dy, double t, double* y, char* args, PreEvalFunc pre_eval) noexcept nogil:
    cdef RampArgs* a = <RampArgs*>args
    cdef double fp, fpp, n
    slope_curvature(a, y[0], &fp, &fpp)
    n = a.g + y[1] * y[1] * fpp
    dy[0] = y[1]
    dy[1] = -n * (fp + a.q) / (1.0 + fp * fp)
    dy[2] = a.q * n * y[1]


cdef double ev_reversal(double t, double* y, char* args) noexcept nogil:
    return (<RampArgs*>args).d * y[1]


cdef double ev_exit_lo(double t, double* y, char* args) noexcept nogil:
    return y[0] - (<RampArgs*>args).lo


cdef double ev_exit_hi(double t, double* y, char* args) noexcept nogil:
    return (<RampArgs*>args).hi - y[0]


cdef double ev_contact(double t, double* y, char* args) noexcept nogil:
    cdef RampArgs* a = <RampArgs*>args
    cdef double fp, fpp
    slope_curvature(a, y[0], &fp, &fpp)
    return a.g + y[1] * y[1] * fpp


cdef inline double rest_direction(double fp, double mu_s) noexcept nogil:
    if fabs(fp) <= mu_s:
        return 0.0
    return -1.0 if fp > 0.0 else 1.0


cdef void run_chunk(RampArgs base, int method, double tol, double t_max, bint lift, const double[::1] x0,
                    const double[::1] v0, const double[::1] mu_k, const double[::1] mu_s, long[::1] status,
                    double[::1] x_end, double[::1] t_end, double[::1] w_end, long[::1] n_rev,
                    long[::1] steps) noexcept nogil:
    cdef vector[Event] events
    events.push_back(Event(<EventFunc>ev_reversal, 1, -1))
    events.push_back(Event(<EventFunc>ev_exit_lo, 1, -1))
    events.push_back(Event(<EventFunc>ev_exit_hi, 1, -1))
    if lift:
        events.push_back(Event(<EventFunc>ev_contact, 1, -1))
    cdef vector[double] tols = vector[double](1, tol)
    cdef vector[double] no_t_eval
    cdef vector[char] args_vec = vector[char](sizeof(RampArgs))
    cdef RampArgs* a = <RampArgs*>args_vec.data()
    cdef vector[double] y0 = vector[double](3)
    cdef unique_ptr[CySolverResult] sol = make_unique[CySolverResult](<ODEMethod>method)
    cdef CySolverResult* s = sol.get()
    cdef Py_ssize_t j, last
    cdef double x, v, w, t, d, fp, fpp
    cdef long st
    cdef size_t which
    for j in range(x0.shape[0]):
        x = x0[j]; v = v0[j]; w = 0.0; t = 0.0; st = 0
        a[0] = base
        slope_curvature(a, x, &fp, &fpp)
        if v == 0.0:
            d = rest_direction(fp, mu_s[j])
            if d == 0.0:
                st = 1
        else:
            d = 1.0 if v > 0.0 else -1.0
        if st == 0 and base.g + v * v * fpp <= 0.0:
            st = 3
        if st == 0 and ((x >= base.hi and d > 0.0) or (x <= base.lo and d < 0.0)):
            st = 2
        while st == 0:
            a.d = d
            a.q = copysign(mu_k[j], d)
            y0[0] = x; y0[1] = v; y0[2] = w
            baseline_cysolve_ivp_noreturn(s, rhs, t, t_max, y0, 0, 0, args_vec, 0, 2000, False, no_t_eval,
                                          NULL, events, tols, tols, MAX_STEP, 0.0, True, NULL)
            steps[j] += s.steps_taken
            last = s.size - 1
            t = s.time_domain_vec[last]
            x = s.solution[3 * last]; v = s.solution[3 * last + 1]; w = s.solution[3 * last + 2]
            if not s.success or not (isfinite(x) and isfinite(v) and isfinite(w)):
                st = 5
            elif not s.event_terminated:
                st = 4
            else:
                which = s.event_terminate_index
                if which == 1 or which == 2:
                    st = 2
                    x = base.lo if which == 1 else base.hi
                elif which == 3:
                    st = 3
                else:
                    v = 0.0
                    slope_curvature(a, x, &fp, &fpp)
                    fp = rest_direction(fp, mu_s[j])
                    if fp == 0.0:
                        st = 1
                    else:
                        if fp != d:
                            n_rev[j] += 1
                        d = fp
        status[j] = st; x_end[j] = x; t_end[j] = t; w_end[j] = w


FAMILY_CODES = {"straight": STRAIGHT, "quadratic": QUADRATIC, "circular_bowl": BOWL, "circular_dome": DOME,
                "sine": SINE}
METHOD_CODES = {"RK45": <int>ODEMethod.RK45, "DOP853": <int>ODEMethod.DOP853}


def solve(family, params, double g, double lo, double hi, double t_max, bint lift, method, double tol,
          x0, v0, mu_k, mu_s):
    """Integrate the trajectories; returns a dict of arrays (peers' layout)."""
    cdef RampArgs base
    base.q = 0.0; base.d = 1.0; base.g = g; base.lo = lo; base.hi = hi
    base.family = FAMILY_CODES[family]
    base.p0, base.p1, base.p2, base.p3 = params
    n = len(x0)
    out = {"status": np.zeros(n, np.int64), "x_end": np.full(n, np.nan), "t_end": np.full(n, np.nan),
           "W_friction": np.full(n, np.nan), "n_reversals": np.zeros(n, np.int64), "steps": np.zeros(n, np.int64)}
    cdef const double[::1] cx0 = np.ascontiguousarray(x0, float)
    cdef const double[::1] cv0 = np.ascontiguousarray(v0, float)
    cdef const double[::1] cmk = np.ascontiguousarray(mu_k, float)
    cdef const double[::1] cms = np.ascontiguousarray(mu_s, float)
    cdef long[::1] st = out["status"]
    cdef double[::1] xe = out["x_end"]
    cdef double[::1] te = out["t_end"]
    cdef double[::1] we = out["W_friction"]
    cdef long[::1] nr = out["n_reversals"]
    cdef long[::1] sp = out["steps"]
    cdef int m = METHOD_CODES[method]
    with nogil:
        run_chunk(base, m, tol, t_max, lift, cx0, cv0, cmk, cms, st, xe, te, we, nr, sp)
    return out
