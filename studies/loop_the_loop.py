"""Loop-the-loop with friction: the smallest entry speed that clears the loop.

A block (m = 1 kg) enters a circle of radius R at its bottom with speed u0,
inside the track (a one-sided curve, family "loop", docs/physics.md §5).
Without friction it keeps contact over the top iff u0 >= sqrt(5 g R); with
Coulomb friction (mu_s = mu_k = mu) it needs more.  For every (mu, R) the
threshold is found by batched bisection on u0: each round is ONE
rw.simulate call over all (mu, R) pairs at their current midpoints (a
``cases`` sweep), until the bracket is narrower than TOL_REL sqrt(5 g R).
For R = 1 m and entry speeds that do not clear, it records where the block
leaves the track (lift-off angle from the bottom) or that it stops and
slides back.  The script checks that the mu = 0 threshold is sqrt(5 g R) to
the bisection tolerance, that the frictionless lift-off angle obeys energy
conservation, cos theta = (2 g R - u0^2) / (3 g R), and that the threshold
grows with mu; it fails loudly otherwise.

    python studies/loop_the_loop.py            # ~10 s with compiled kernels cached
    python studies/loop_the_loop.py --full --gallery

Outputs (default folder studies/output/): loop_the_loop.nc and
loop_the_loop.png (and .pdf with --pdf).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import _study

STUDY = "loop_the_loop"
M, G = 1.0, 9.81  # kg, m s-2
DT = 1e-3  # s, RK4
T_MAX = 5.0  # s: far longer than one turn of the loops here
TOL_REL = 1e-5  # bisection bracket, relative to sqrt(5 g R)
R_LIFT = 1.0  # m, the loop of the lift-off sweep
MU_MAX = 0.4
CLEARED, LIFTED, SLID_BACK = 0, 1, 2
OUTCOMES = "cleared lifted_off slid_back"


def scene(radius=1.0):
    import rampwork as rw
    from rampwork.curve_scene import CurveScene
    from rampwork.curves import Curve

    return CurveScene(curve=Curve.create("loop", radius=radius), s0=0.0, u0=0.0, m=M, g=G,
                      t_max=T_MAX, integrator=rw.Integrator("rk4", DT),
                      title="Loop-the-loop with friction: entry speed at the bottom")


def cleared(ds, radius):
    """Went all the way round: left through the far end of the loop."""
    return (ds["status"].values == 2) & (ds["s_end"].values > np.pi * radius)


def thresholds(mu, radius):
    """Batched bisection on u0 over the (mu, R) mesh; returns the upper end
    of each final bracket (a speed that clears), the width and the rounds."""
    import rampwork as rw

    mu_m, r_m = (a.ravel() for a in np.meshgrid(mu, radius, indexing="ij"))
    free = np.sqrt(5 * G * r_m)
    lo = np.sqrt(2 * G * r_m)  # cannot even reach the side of the loop
    hi = free * np.exp(np.pi * mu_m) * 1.2  # friction drains u^2 by ~exp(-2 pi mu) to the top
    base = scene()
    probe = rw.simulate(base, rw.Sweep.cases(mu=mu_m, radius=r_m, u0=hi))
    if not cleared(probe, r_m).all():
        _study.fail(STUDY, "the upper bracket speed does not clear every loop")
    rounds = 0
    while (hi - lo).max() > TOL_REL * free.min():
        mid = 0.5 * (lo + hi)
        ok = cleared(rw.simulate(base, rw.Sweep.cases(mu=mu_m, radius=r_m, u0=mid)), r_m)
        hi, lo = np.where(ok, mid, hi), np.where(ok, lo, mid)
        rounds += 1
    shape = (len(mu), len(radius))
    return hi.reshape(shape), (hi - lo).reshape(shape), rounds


def run(n_mu, n_r, n_u):
    import xarray as xr

    mu = _study.even(0, MU_MAX, n_mu)
    radius = _study.even(0.5, 2.0, n_r)
    started = time.perf_counter()
    threshold, width, rounds = thresholds(mu, radius)
    bisect_s = time.perf_counter() - started
    u0 = _study.even(0.9 * np.sqrt(2 * G * R_LIFT), 1.05 * np.sqrt(5 * G * R_LIFT) * np.exp(
        np.pi * MU_MAX), n_u)
    ds = _study.simulate_grid(scene(R_LIFT), mu=mu, u0=u0)
    went_round = xr.DataArray(cleared(ds, R_LIFT), dims=ds["status"].dims)
    outcome = xr.where(went_round, CLEARED, xr.where(ds["status"] == 3, LIFTED, SLID_BACK))
    ds["outcome"] = outcome.astype("int8").assign_attrs(
        long_name="what the block did in the loop", units="1",
        flag_values=np.array([CLEARED, LIFTED, SLID_BACK], dtype="int8"), flag_meanings=OUTCOMES)
    ds["lift_off_angle"] = (np.degrees(ds["s_lift_off"] / R_LIFT)).assign_attrs(
        units="degree", long_name="lift-off angle from the bottom of the loop",
        comment=f"s_lift_off / R for R = {R_LIFT:g} m; NaN where the block did not lift off")
    ds = ds.assign_coords(radius=("radius", radius, dict(units="m", long_name="radius of the loop")))
    ds["u0_threshold"] = (("mu", "radius"), threshold, dict(
        units="m s-1", long_name="smallest entry speed that clears the loop",
        comment=f"batched bisection ({rounds} rounds, one rw.simulate call each); the upper end "
                f"of a bracket narrower than {TOL_REL:g} sqrt(5 g R)"))
    ds["u0_threshold_bracket"] = (("mu", "radius"), width, dict(
        units="m s-1", long_name="width of the final bisection bracket"))
    ds["threshold_ratio"] = (ds["u0_threshold"] / np.sqrt(5 * G * ds["radius"])).assign_attrs(
        units="1", long_name="entry speed threshold over the frictionless sqrt(5 g R)")
    ds.attrs["lift_off_radius_m"] = R_LIFT
    _study.note_history(ds, STUDY, f"lift-off sweep at R = {R_LIFT:g} m over (mu, u0); outcome, "
                        f"lift_off_angle added; u0_threshold over (mu, radius) by {rounds} rounds "
                        "of batched bisection")
    return ds, rounds, bisect_s


def check(ds) -> dict:
    free = np.sqrt(5 * G * ds["radius"])
    tol = TOL_REL * float(free.min())
    err0 = float(np.abs(ds["u0_threshold"].sel(mu=0.0) - free).max())
    if err0 > 2 * tol:
        _study.fail(STUDY, f"mu = 0 threshold differs from sqrt(5 g R) by {err0:.2g} m/s "
                           f"(bisection tolerance {tol:.2g} m/s)")
    frictionless = ds.sel(mu=0.0)
    lifted = frictionless["outcome"].values == LIFTED
    u0 = frictionless["u0"].values[lifted]
    cos_closed = (2 * G * R_LIFT - u0**2) / (3 * G * R_LIFT)
    cos_run = np.cos(frictionless["s_lift_off"].values[lifted] / R_LIFT)
    cos_err = float(np.abs(cos_run - cos_closed).max()) if lifted.any() else np.nan
    if not lifted.any() or cos_err > 1e-6:
        _study.fail(STUDY, f"frictionless lift-off: |cos theta - (2gR - u0^2)/(3gR)| = {cos_err:.2g}"
                           f" over {int(lifted.sum())} lift-offs")
    rising = (ds["u0_threshold"].diff("mu") > 0).all()
    if not bool(rising):
        _study.fail(STUDY, "the threshold does not grow with mu for every radius")
    return dict(err0=err0, tol=tol, cos_err=cos_err, n_lifted=int(lifted.sum()))


def figure(ds):
    from rampwork.plotting import new_figure, series

    fig, axes = new_figure(1, 2, size=(11.5, 4.4))
    ax_t, ax_l = axes[0]
    mu = ds["mu"].values
    radii = ds["radius"].values
    pick = radii[np.unique(np.linspace(0, len(radii) - 1, 4).round().astype(int))]
    for k, r in enumerate(pick):
        ax_t.plot(mu, ds["threshold_ratio"].sel(radius=r), **series(k, len(pick)),
                  label=f"R = {r:g} m")
    ax_t.axhline(1.0, color="0.3", lw=1, ls=(0, (2, 2)), label=r"frictionless $\sqrt{5gR}$")
    ax_t.set(xlabel=r"friction coefficient $\mu$", ylabel=r"$u_{0,\min} / \sqrt{5 g R}$",
             title="(a) Entry speed needed to clear the loop")
    ax_t.legend(loc="upper left")
    ax_t.text(0.98, 0.03, "the radii coincide: with Coulomb friction\n"
              r"$u_{0,\min}/\sqrt{gR}$ depends on $\mu$ alone", transform=ax_t.transAxes,
              ha="right", va="bottom", fontsize=8, color="0.3")
    u0 = ds["u0"].values
    mus = mu[np.unique(np.linspace(0, len(mu) - 1, 4).round().astype(int))]
    for k, m in enumerate(mus):
        ax_l.plot(u0, ds["lift_off_angle"].sel(mu=m), **series(k, len(mus)), label=f"mu = {m:g}")
    fine = np.linspace(np.sqrt(2 * G * R_LIFT), np.sqrt(5 * G * R_LIFT), 200)
    ax_l.plot(fine, np.degrees(np.arccos((2 * G * R_LIFT - fine**2) / (3 * G * R_LIFT))),
              color="0.3", lw=1, ls=(0, (2, 2)), zorder=5,
              label=r"$\mu = 0$: $\cos\theta = (2gR - u_0^2)/(3gR)$")
    ax_l.set(xlabel="entry speed u0 (m/s)", ylabel="lift-off angle from the bottom (degree)",
             title=f"(b) Where it leaves the track, R = {R_LIFT:g} m", ylim=(85, 185))
    ax_l.text(0.02, 0.97, "no curve left of a line's start: it slides back;\n"
              "none right of its end: it clears", transform=ax_l.transAxes, ha="left", va="top",
              fontsize=8, color="0.3")
    ax_l.legend(loc="lower right")
    fig.suptitle(f"Loop-the-loop, inside the track, m = {M:g} kg, RK4 dt = {DT * 1e3:g} ms")
    return fig


def main(argv=None) -> int:
    args = _study.parser(__doc__).parse_args(argv)
    started = time.perf_counter()
    n_mu, n_r, n_u = _study.scale(args, (2, 2, 8), (8, 3, 60), (16, 6, 240))
    print(f"{STUDY}: threshold over {n_mu + 1} mu x {n_r + 1} R, lift-off over {n_mu + 1} mu x "
          f"{n_u + 1} u0 at R = {R_LIFT:g} m, RK4 dt = {DT * 1e3:g} ms")
    ds, rounds, bisect_s = run(n_mu, n_r, n_u)
    n = check(ds)
    print(f"  bisection: {rounds} rounds (one rw.simulate each), {bisect_s:.1f} s including "
          f"compile/load; lift-off sweep compile/load {ds.attrs['compile_time_s']:.1f} s, run "
          f"{ds.attrs['run_time_s']:.2f} s")
    print(f"  mu = 0: max |u0_min - sqrt(5gR)| = {n['err0']:.1e} m/s (tolerance {n['tol']:.1e})")
    print(f"  mu = 0 lift-off vs energy conservation: max |cos theta - closed form| = "
          f"{n['cos_err']:.1e} over {n['n_lifted']} entry speeds")
    ratio = ds["threshold_ratio"]
    for r in ds["radius"].values[[0, -1]]:
        print(f"  R = {r:g} m: u0_min / sqrt(5gR) = " + ", ".join(
            f"{ratio.sel(mu=m, radius=r).item():.4f} (mu {m:g})" for m in ds["mu"].values[::max(
                1, len(ds["mu"]) // 4)]))
    _study.finish(STUDY, ds, figure(ds), args, started)
    return 0


if __name__ == "__main__":
    sys.exit(main())
