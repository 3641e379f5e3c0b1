"""Descent between two points: chord, parabola, circle, cycloid and the frictional optimum.

A block (m = 1 kg) starts from rest at A = (0, 0) and slides to B on five
curves through both points, for mu_s = mu_k = mu from 0 up: the chord (a
straight ramp); the parabola with its vertex at B, y = y_B (1 - (1 - x/x_B)^2)
(horizontal at B); the circular arc that leaves A vertically with its centre
level with A (curve family "loop"); the cycloid from its cusp at A through B
(family "brachistochrone", radius and end angle solved for B); and the
derived fastest curve with friction (rampwork.brachistochrone, its time by
quadrature).  No curve family can represent the optimum yet, so it is not
run through the engine: its time is the quadrature's only.  The cycloid run
starts 1e-6 r of arc below the cusp (where the curvature is infinite) with
the frictionless speed there, and adds the frictionless time of that piece.
Two end points: B = (1, -1) m and B = (2, -1) m (the optimum dips below B
and climbs back).  Checks: at mu = 0 the cycloid time is theta sqrt(r / g);
the chord time is sqrt(2 L / (g (sin beta - mu cos beta))); nothing arriving
at B beats the optimum.

    python studies/descent_two_points.py
    python studies/descent_two_points.py --full --gallery

Outputs (default folder studies/output/): descent_two_points.nc and
descent_two_points.png (and .pdf with --pdf).
"""

from __future__ import annotations

import math
import sys
import time

import numpy as np

import _study

STUDY = "descent_two_points"
M, G = 1.0, 9.81  # kg, m s-2
ENDS = ((1.0, -1.0), (2.0, -1.0))  # m
CURVES = ("chord", "parabola", "circle", "cycloid", "optimum")
MU_MAX = 0.6
DT = 1e-4  # s, RK4
T_MAX = 10.0  # s
EPS = 1e-6  # cycloid start below the cusp, in units of r


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
    # cycloid from just below its cusp, entering with the frictionless speed there
    r, theta = cycloid_through(bx, by)
    s0 = EPS * r
    t0 = 2 * math.acos(1 - s0 / (4 * r))  # rolling angle at s0
    scene = CurveScene(curve=Curve.create("brachistochrone", radius=r, end_angle=theta),
                       s0=s0, u0=math.sqrt(2 * G * r * (1 - math.cos(t0))), m=M, g=G,
                       t_max=T_MAX, integrator=integ)
    ds = rw.simulate(scene, rw.Sweep.cases(mu=mu))
    rows.append((ds["t_end"].values + t0 * math.sqrt(r / G), ds["W_friction"].values,
                 ds["status"].values, arrived(ds, ("s_end", 4 * r * (1 - math.cos(theta / 2))))))
    return rows, ds.attrs, (r, theta, t0)


def optimum_times(bx, by, mu):
    from rampwork.brachistochrone import frictional_brachistochrone

    import warnings

    out = np.full(len(mu), np.nan)
    for k, m in enumerate(mu):
        # scipy's quad flags its removable 0/0 at phi = -alpha (docs/brachistochrone.md)
        warnings.filterwarnings("ignore", category=__import__("scipy").integrate.IntegrationWarning)
        try:
            out[k] = frictional_brachistochrone((bx, by), float(m), G).time
        except Exception:  # no admissible optimum: the block cannot reach B at this mu
            pass
    return out


def run(n_mu):
    import xarray as xr

    mu = _study.even(0, MU_MAX, n_mu)
    shape = (len(ENDS), len(CURVES), len(mu))
    t, w = np.full(shape, np.nan), np.full(shape, np.nan)
    status = np.zeros(shape, dtype="int8")
    reached = np.zeros(shape, dtype=bool)
    cycloids = []
    for i, (bx, by) in enumerate(ENDS):
        rows, attrs, cyc = run_end(bx, by, mu)
        cycloids.append(cyc)
        for j, (tt, ww, st, ok) in enumerate(rows):
            t[i, j] = np.where(ok, tt, np.nan)
            w[i, j] = np.where(ok, ww, np.nan)
            status[i, j], reached[i, j] = st, ok
        t[i, 4] = optimum_times(bx, by, mu)
        reached[i, 4] = np.isfinite(t[i, 4])
    dims = ("end", "curve", "mu")
    ds = xr.Dataset(
        dict(time=(dims, t, dict(units="s", long_name="descent time from A to B",
                                 comment="NaN where the block does not reach B; optimum: quadrature")),
             W_friction=(dims, w, dict(units="J", long_name="work against friction, A to B",
                                       comment="NaN where the block does not reach B or not run")),
             status=(dims, status, dict(long_name="end status (rampwork STATUS_TABLE)", units="1",
                                        comment="0 (not_run) for the optimum: quadrature only")),
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
    _study.note_history(ds, STUDY, "four curves run per end point, optimum by quadrature, "
                        "gathered over (end, curve, mu)")
    return ds, cycloids


def check(ds, cycloids) -> dict:
    t = ds["time"]
    errs = []
    for i, ((bx, by), (r, theta, _)) in enumerate(zip(ENDS, cycloids)):
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
    beaten = (t.sel(curve=list(CURVES[:4])) < t.sel(curve="optimum") * (1 - 1e-6)).any()
    if bool(beaten):
        _study.fail(STUDY, "a curve reaches B faster than the frictional optimum")
    excess = 100 * (t.sel(curve="cycloid") / t.sel(curve="optimum") - 1)
    return dict(cyc_err=cyc_err, chord_err=max(errs[1::2]), excess=excess)


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
                 "ends where that block no longer arrives; optimum: quadrature (not run)")
    return fig


def main(argv=None) -> int:
    args = _study.parser(__doc__).parse_args(argv)
    started = time.perf_counter()
    n_mu = _study.scale(args, 3, 24, 60)
    print(f"{STUDY}: 5 curves x {len(ENDS)} end points x {n_mu + 1} mu in [0, {MU_MAX:g}]")
    ds, cycloids = run(n_mu)
    n = check(ds, cycloids)
    print(f"  mu = 0 cycloid: max |t - theta sqrt(r/g)| = {n['cyc_err']:.1e} s; chord: max "
          f"|t - sqrt(2L/(g(sin - mu cos)))| = {n['chord_err']:.1e} s; nothing beats the optimum")
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
        print("    fastest engine curve from mu = " + ", ".join(
            f"{m:g}: {name}" for k, (m, name) in enumerate(zip(sub["mu"].values, names))
            if k == 0 or name != names[k - 1]))
    _study.finish(STUDY, ds, figure(ds), args, started)
    return 0


if __name__ == "__main__":
    sys.exit(main())
