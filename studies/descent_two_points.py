"""Descent between two points: chord, parabola, circle, cycloid and the frictional optimum.

A block (m = 1 kg) starts from rest at A = (0, 0) and slides to B on five
curves through both points, for mu_s = mu_k = mu from 0 up: the chord (a
straight ramp); the parabola with its vertex at B, y = y_B (1 - (1 - x/x_B)^2)
(horizontal at B); the circular arc that leaves A vertically with its centre
level with A (curve family "loop"); the cycloid from its cusp at A through B;
and the derived fastest curve with friction (rampwork.brachistochrone).  The
chord and parabola run as ramps y = f(x), the arc as a curve, all RK4.  The
cycloid and the optimum run from rest at the cusp itself as convex_cusp
curves (dopri5, rtol 1e-12): the cycloid with all its shape coefficients
zero (rho = 4 r cos phi), the optimum with log(rho / cos phi) of the derived
curve interpolated at 160 Chebyshev points; the optimum's time by quadrature
is kept beside it as a check.
Two end points: B = (1, -1) m and B = (2, -1) m (the optimum dips below B
and climbs back).  Checks: at mu = 0 the cycloid time is theta sqrt(r / g);
the chord time is sqrt(2 L / (g (sin beta - mu cos beta))); the optimum's
engine time is its quadrature's to 1e-9; nothing arriving at B beats the
optimum.

    python studies/descent_two_points.py
    python studies/descent_two_points.py --full --gallery

Outputs (default folder studies/output/): descent_two_points.nc and
descent_two_points.png (and .pdf with --pdf).
"""

from __future__ import annotations

import math
import sys
import time
import warnings

import numpy as np

import _study

STUDY = "descent_two_points"
M, G = 1.0, 9.81  # kg, m s-2
ENDS = ((1.0, -1.0), (2.0, -1.0))  # m
CURVES = ("chord", "parabola", "circle", "cycloid", "optimum")
MU_MAX = 0.6
DT = 1e-4  # s, RK4
T_MAX = 10.0  # s
#: Chebyshev points of the optimum's fit into convex_cusp: near the largest mu that reaches
#: (2, -1) (0.49) 40 points leave 1e-4 in the time, 80 2.5e-9, 160 1e-12
NODES = 160
CUSP_RTOL = 1e-12  # dopri5 on the convex_cusp curves (cycloid, optimum), from rest at the cusp


def cycloid_through(bx, by):
    """(r, theta) of the cycloid from the cusp at the origin through (bx, by)."""
    from scipy.optimize import brentq

    theta = brentq(lambda t: (t - math.sin(t)) * -by - bx * (1 - math.cos(t)), 1e-6, 2 * math.pi - 1e-9)
    return -by / (1 - math.cos(theta)), theta


def arrived(ds, end):
    return (ds["status"].values == 2) & (np.abs(ds[end[0]].values - end[1]) < 1e-9)


def run_end(bx, by, mu):
    """Times, work and status of the four engine curves for one B; rows in CURVES order."""
    import rampwork as rw
    from rampwork.curve_scene import CurveScene
    from rampwork.curves import Curve
    from rampwork.descent_shapes import CuspCurve

    integ = rw.Integrator("rk4", DT)
    rows = []
    # chord and parabola: y = f(x) ramps from rest at x = 0; the chord stepped, not solved
    # in closed form, so that the closed-form check below is independent
    for c, slope in ((0.0, by / bx), (-2 * by / bx**2, 2 * by / bx)):
        scene = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=c, slope=slope, height=0.0,
                                             domain=(0.0, bx)),
                         integrator=rw.Integrator("rk4", DT, closed_form=False), x0=0.0, v0=0.0, m=M, g=G, t_max=T_MAX)
        ds = rw.simulate(scene, rw.Sweep.cases(mu=mu))
        rows.append((ds["t_end"].values, ds["W_friction"].values, ds["status"].values,
                     arrived(ds, ("x_end", bx))))
    # circle: centre (R, 0), through A and B; the loop's angle from its bottom
    R = (bx**2 + by**2) / (2 * bx)
    theta_b = math.atan2(bx / R - 1, -by / R)
    scene = CurveScene(curve=Curve.create("loop", radius=R, entry_angle=-math.pi / 2,
                                          exit_angle=theta_b),
                       s0=-R * math.pi / 2, u0=0.0, m=M, g=G, t_max=T_MAX, integrator=integ)
    ds = rw.simulate(scene, rw.Sweep.cases(mu=mu))
    rows.append((ds["t_end"].values, ds["W_friction"].values, ds["status"].values,
                 arrived(ds, ("s_end", R * theta_b))))
    # the cycloid from its cusp itself: the convex_cusp family with all coefficients zero
    r, theta = cycloid_through(bx, by)
    rows.append(run_convex_cusp(CuspCurve(end=(bx, by), k=1).curves(np.zeros((1, 1))), mu))
    return rows, ds.attrs, (r, theta)


def run_convex_cusp(curves, mu):
    """Times, work, status and arrival on convex_cusp curves (``curves``: one
    per mu, or one for all) from rest at the cusp, dopri5 at rtol 1e-12."""
    from rampwork.core import status as st
    from rampwork.curves import Curve, simulate_curve

    n = len(curves["end_angle"])
    curve = Curve.convex_cusp(curves["coefficients"], curves["end_angle"])
    row = np.arange(len(mu)) if n > 1 else 0
    out = simulate_curve(curve, s0=0.0, mu_k=np.asarray(mu, dtype=float), g=G, m=M, method="dopri5",
                         rtol=CUSP_RTOL, t_max=T_MAX, row=row, end_angle=curves["end_angle"][row])
    reached = (out["status"] == st.EXITED) & (out["p_end"] == 1.0 + np.sin(curves["end_angle"][row]))
    return out["t_end"], out["W_friction"], out["status"], reached


def optimum_curves(optima):
    """The derived optima (one per mu) fitted into the convex_cusp family:
    log(rho / cos(phi)) interpolated at NODES Chebyshev points (tests/test_cusp_curve.py:
    40 run in the quadrature's time to 1e-11 at mu = 0.2)."""
    t = np.cos(np.pi * (np.arange(NODES) + 0.5) / NODES)
    coefficients, angles = [], []
    for best in optima:
        extremal, span = best._extremal, best.phi_end + 0.5 * math.pi
        phi = -0.5 * math.pi + (t + 1) / 2 * span
        rho = np.array([extremal.ds_dphi(f) for f in phi]) * best.scale
        coefficients.append(np.polynomial.chebyshev.chebfit(t, np.log(rho / np.cos(phi)), NODES - 1))
        angles.append(best.phi_end)
    return {"coefficients": np.array(coefficients), "end_angle": np.array(angles)}


def optima(bx, by, mu):
    """The derived optimum per mu (None where no curve from rest reaches B)."""
    from rampwork.brachistochrone import frictional_brachistochrone
    from rampwork.errors import ConfigError

    found = []
    with warnings.catch_warnings():
        # scipy's quad flags its removable 0/0 at phi = -alpha (docs/brachistochrone.md)
        warnings.simplefilter("ignore")
        for m in mu:
            try:
                found.append(frictional_brachistochrone((bx, by), float(m), G))
            except ConfigError:  # no admissible optimum: the block cannot reach B at this mu
                found.append(None)
    return found


def run(n_mu):
    import xarray as xr

    mu = _study.even(0, MU_MAX, n_mu)
    shape = (len(ENDS), len(CURVES), len(mu))
    t, w = np.full(shape, np.nan), np.full(shape, np.nan)
    status = np.zeros(shape, dtype="int8")
    reached = np.zeros(shape, dtype=bool)
    quadrature = np.full((len(ENDS), len(mu)), np.nan)
    cycloids = []
    for i, (bx, by) in enumerate(ENDS):
        rows, attrs, cyc = run_end(bx, by, mu)
        cycloids.append(cyc)
        for j, (tt, ww, st, ok) in enumerate(rows):
            t[i, j] = np.where(ok, tt, np.nan)
            w[i, j] = np.where(ok, ww, np.nan)
            status[i, j], reached[i, j] = st, ok
        best = optima(bx, by, mu)
        some = np.array([b is not None for b in best])
        quadrature[i, some] = [b.time for b in best if b is not None]
        tt, ww, st, ok = run_convex_cusp(optimum_curves([b for b in best if b is not None]), mu[some])
        t[i, 4, some], w[i, 4, some] = np.where(ok, tt, np.nan), np.where(ok, ww, np.nan)
        status[i, 4, some], reached[i, 4, some] = st, ok
    dims = ("end", "curve", "mu")
    ds = xr.Dataset(
        dict(time=(dims, t, dict(units="s", long_name="descent time from A to B",
                                 comment="NaN where the block does not reach B")),
             optimum_time_quadrature=(("end", "mu"), quadrature, dict(
                 units="s", long_name="the derived optimum's time by quadrature",
                 comment="rampwork.brachistochrone; NaN where no curve from rest reaches B")),
             W_friction=(dims, w, dict(units="J", long_name="work against friction, A to B",
                                       comment="NaN where the block does not reach B or not run")),
             status=(dims, status, dict(long_name="end status (rampwork STATUS_TABLE)", units="1",
                                        comment="0 (not_run) for the optimum where none exists")),
             reached_B=(dims, reached, dict(long_name="the block arrives at B", units="1"))),
        coords=dict(mu=("mu", mu, dict(units="1", long_name="friction coefficient")),
                    curve=("curve", list(CURVES)),
                    end=("end", [f"B = ({bx:g}, {by:g}) m" for bx, by in ENDS]),
                    B_x=("end", [e[0] for e in ENDS], dict(units="m")),
                    B_y=("end", [e[1] for e in ENDS], dict(units="m"))),
        attrs={k: v for k, v in attrs.items() if k not in ("study",)})
    ds.attrs["title"] = "Descent between two points: chord, parabola, circle, cycloid, optimum"
    ds.attrs["cycloid_radius_m"] = [c[0] for c in cycloids]
    ds.attrs["cycloid_end_angle_rad"] = [c[1] for c in cycloids]
    _study.note_history(ds, STUDY, "five curves run per end point (the optimum fitted into "
                        "convex_cusp), gathered over (end, curve, mu)")
    return ds, cycloids


def check(ds, cycloids) -> dict:
    t = ds["time"]
    errs = []
    for i, ((bx, by), (r, theta)) in enumerate(zip(ENDS, cycloids)):
        e = abs(float(t.isel(end=i).sel(curve="cycloid", mu=0.0)) - theta * math.sqrt(r / G))
        errs.append(e)
        L, beta = math.hypot(bx, by), math.atan2(-by, bx)
        mu = ds["mu"].values
        drive = G * (np.sin(beta) - mu * np.cos(beta))
        closed = np.where(drive > 0, np.sqrt(2 * L / np.where(drive > 0, drive, 1)), np.nan)
        chord = t.isel(end=i).sel(curve="chord").values
        both = np.isfinite(chord) & np.isfinite(closed)
        chord_err = float(np.abs(chord - closed)[both].max())
        if chord_err > 1e-6 or (np.isfinite(chord) != np.isfinite(closed)).any():
            _study.fail(STUDY, f"chord to {ds['end'].values[i]}: |t - sqrt(2L/(g(sin - mu cos)))| "
                               f"= {chord_err:.2g} s")
        errs.append(chord_err)
    cyc_err = max(errs[0::2])
    if cyc_err > 1e-6:
        _study.fail(STUDY, f"mu = 0 cycloid time differs from theta sqrt(r/g) by {cyc_err:.2g} s")
    # the optimum through the engine against its quadrature (two independent computations)
    quadrature = ds["optimum_time_quadrature"]
    engine = t.sel(curve="optimum")
    if bool((quadrature.notnull() != engine.notnull()).any()):
        _study.fail(STUDY, "the derived optimum does not arrive through the engine where it exists")
    opt_err = float(np.abs(engine / quadrature - 1).max())
    if opt_err > 1e-9:
        _study.fail(STUDY, f"the optimum's engine time differs from its quadrature by {opt_err:.2g} relative")
    beaten = (t.sel(curve=list(CURVES[:4])) < t.sel(curve="optimum") * (1 - 1e-6)).any()
    if bool(beaten):
        _study.fail(STUDY, "a curve reaches B faster than the frictional optimum")
    excess = 100 * (t.sel(curve="cycloid") / t.sel(curve="optimum") - 1)
    return dict(cyc_err=cyc_err, chord_err=max(errs[1::2]), opt_err=opt_err, excess=excess)


def figure(ds):
    from rampwork.plotting import new_figure, series

    fig, axes = new_figure(2, 2, size=(11.5, 8.4))
    mu = ds["mu"].values
    for i in range(len(ENDS)):
        ax_t, ax_w = axes[0, i], axes[1, i]
        for k, name in enumerate(CURVES):
            look = series(k, len(CURVES)) | dict(markevery=max(1, len(mu) // 10))
            ax_t.plot(mu, ds["time"].isel(end=i).sel(curve=name), **look, label=name)
            if name != "optimum":
                ax_w.plot(mu, ds["W_friction"].isel(end=i).sel(curve=name), **look, label=name)
        ax_t.set(xlabel=r"friction coefficient $\mu$", ylabel="time from A to B (s)",
                 title=f"({'ab'[i]}) Descent time, {ds['end'].values[i]}")
        ax_w.set(xlabel=r"friction coefficient $\mu$", ylabel="work against friction (J)",
                 title=f"({'cd'[i]}) Work against friction, {ds['end'].values[i]}")
        ax_t.set_ylim(top=2.2 * float(ds["time"].isel(end=i).sel(curve="optimum", mu=0.0)))
        ax_t.legend(loc="upper left")
        ax_w.legend(loc="upper left")
    fig.suptitle(f"From rest at A = (0, 0) to B, m = {M:g} kg, RK4 dt = {DT * 1e3:g} ms; a line "
                 "ends where that block no longer arrives;\ncycloid and optimum: convex_cusp curves from "
                 "the cusp, dopri5 rtol 1e-12")
    return fig


def main(argv=None) -> int:
    args = _study.parser(__doc__).parse_args(argv)
    started = time.perf_counter()
    n_mu = _study.scale(args, 3, 24, 60)
    print(f"{STUDY}: 5 curves x {len(ENDS)} end points x {n_mu + 1} mu in [0, {MU_MAX:g}]")
    ds, cycloids = run(n_mu)
    n = check(ds, cycloids)
    print(f"  mu = 0 cycloid: max |t - theta sqrt(r/g)| = {n['cyc_err']:.1e} s; chord: max "
          f"|t - sqrt(2L/(g(sin - mu cos)))| = {n['chord_err']:.1e} s; optimum: engine over quadrature "
          f"within {n['opt_err']:.1e}; nothing beats the optimum")
    for i in range(len(ENDS)):
        sub = ds.isel(end=i)
        last = {c: float(sub["mu"].where(sub["reached_B"].sel(curve=c)).max()) for c in CURVES}
        engine = sub["time"].sel(curve=list(CURVES[:4]))
        fastest = engine.fillna(np.inf).argmin("curve").where(engine.notnull().any("curve"), -1)
        print(f"  {sub['end'].item()}: largest mu that arrives: " +
              ", ".join(f"{c} {v:g}" for c, v in last.items()))
        print("    cycloid over optimum (%): " + ", ".join(
            f"{v:.3f} (mu {m:g})" for m, v in zip(sub["mu"].values, n["excess"].isel(end=i).values)
            if np.isfinite(v) and any(abs(m - x) < 1e-9 for x in (0.1, 0.2, 0.3))))
        names = [CURVES[int(k)] if k >= 0 else "none" for k in fastest.values]
        print("    fastest of chord, parabola, circle and cycloid from mu = " + ", ".join(
            f"{m:g}: {name}" for k, (m, name) in enumerate(zip(sub["mu"].values, names))
            if k == 0 or name != names[k - 1]))
    _study.finish(STUDY, ds, figure(ds), args, started)
    return 0


if __name__ == "__main__":
    sys.exit(main())
