"""The paper's exam question: does a curved ramp cost more friction work than a straight one?

A block (m = 1 kg) starts from rest at A = (0, H) and slides to B = (L, 0) on
ramps through both points: the straight chord and the parabolas

    y = H + s x + c x^2 / 2,   s = (-H - c L^2 / 2) / L   (so that y(L) = 0),

for curvatures c from concave (f'' < 0) to convex (f'' > 0), each for a range of
friction coefficients mu (mu_s = mu_k = mu, the paper's case).  The paper's
eq. (16) says W_f = mu m g |dx| + mu m int(v^2 f'' dx): on the chord (c = 0) the
work is mu m g L whatever the slope, a convex ramp costs more, a concave one less.
This script runs the sweep, checks those claims numerically (and fails loudly if
they do not hold or if a block does not slide all the way to B), writes a netCDF
file and a three-panel figure, and prints the headline numbers.

    python studies/convexity_comparison.py            # ~15 s cold (numba compile), ~3 s cached
    python studies/convexity_comparison.py --full --pdf

Outputs (default folder studies/output/): convexity_comparison.nc and
convexity_comparison.png (and .pdf with --pdf).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

STUDY = "convexity_comparison"
DEFAULT_OUT = Path(__file__).resolve().parent / "output"

# -- the set-up ---------------------------------------------------------------
H = 1.0  # m, height of the start A = (0, H)
L = 2.0  # m, horizontal distance to the end B = (L, 0)
M = 1.0  # kg
G = 9.81  # m s-2
C_MAX = 0.2  # 1/m: curvatures in [-C_MAX, C_MAX]
MU_MAX = 0.28  # largest friction coefficient (< min |f'(0)| = H/L - C_MAX L/2 = 0.3)
C_SHOW = 0.2  # the convex / concave ramps of panel (a) and of the summary
MU_HEADLINE = 0.3  # the summary quotes the mu nearest to this in the sweep
MU_LINES = (0.0, 0.07, 0.14, 0.21, 0.28)  # mu values drawn in panels (b) and (c)


def grids(full: bool) -> tuple[np.ndarray, np.ndarray]:
    """Curvatures (1/m) and friction coefficients, built from integers so that
    c = 0 (the chord) and mu = 0 are exact grid values."""
    steps = 400 if full else 100  # grid spacing 1/steps
    n_c = round(C_MAX * steps)
    n_mu = round(MU_MAX * steps)
    curvature = np.arange(-n_c, n_c + 1) / steps
    mu = np.arange(0, n_mu + 1) / steps
    return curvature, mu


def slope_for(curvature):
    """Slope at x = 0 that puts the parabola through B = (L, 0)."""
    return (-H - np.asarray(curvature) * L**2 / 2) / L


def fail(message: str) -> None:
    sys.exit(f"{STUDY}: FAILED: {message}")


# -- the run --------------------------------------------------------------------
def run(curvature: np.ndarray, mu: np.ndarray, dt: float):
    import xarray as xr

    import rampwork as rw
    from rampwork.schema import utc_timestamp

    # every block must start moving: |f'(0)| > mu_s for every (c, mu)
    start_slope = np.abs(slope_for(curvature))
    if start_slope.min() <= mu.max():
        fail(f"|f'(0)| = {start_slope.min():.3g} <= mu = {mu.max():.3g}: some blocks would "
             "never start; narrow the curvature or mu range")

    c_grid, mu_grid = np.meshgrid(curvature, mu, indexing="ij")
    sweep = rw.Sweep.cases(curvature=c_grid.ravel(), slope=slope_for(c_grid.ravel()),
                           mu=mu_grid.ravel())
    scene = rw.Scene(
        ramp=rw.Ramp.create("quadratic", curvature=0.0, slope=slope_for(0.0), height=H,
                            domain=(0.0, L)),
        integrator=rw.Integrator("rk4", dt),
        x0=0.0, v0=0.0, m=M, g=G,
        title=(f"Friction work from A = (0, {H:g} m) to B = ({L:g} m, 0): straight chord vs "
               "convex and concave parabolas"),
    )
    ds = rw.simulate(scene, sweep)

    # cases -> dims (curvature, mu); slope depends on curvature only
    ds = ds.drop_vars("case").set_index(case=["curvature", "mu"]).unstack("case")
    slope = ds["slope"]
    if not np.allclose(slope, slope.isel(mu=[0])):
        fail("slope varies along mu after reshaping the sweep (internal error)")
    ds = ds.assign_coords(slope=("curvature", slope.isel(mu=0).values, slope.attrs))
    ds = ds.transpose("curvature", "mu")

    # a derived variable: the path speed at B
    fp_end = ds["slope"] + ds["curvature"] * L
    ds["speed_end"] = (np.abs(ds["v_end"]) * np.sqrt(1 + fp_end**2)).assign_attrs(
        units="m s-1", long_name="speed along the ramp at the end",
        comment="|v_end| sqrt(1 + f'(x_end)^2): the path speed |ds/dt| at B; computed by "
                f"studies/{STUDY}.py")
    ds.attrs.update(
        study=f"studies/{STUDY}.py",
        comment=("Exam question of the paper (section 1, eq. 16): a block from rest at "
                 f"A = (0, {H:g} m) slides to B = ({L:g} m, 0) on y = H + slope x + curvature "
                 "x^2/2 through both points; curvature = 0 is the straight chord."),
        study_H_m=H, study_L_m=L,
    )
    ds.attrs["history"] += (f"\n{utc_timestamp()}: studies/{STUDY}.py: reshaped the cases "
                            "to (curvature, mu), added speed_end")
    return xr, ds


def check(ds) -> dict:
    """The contract of the study and the paper's claims; returns headline numbers."""
    import rampwork as rw

    names = {code: name for code, name, _ in rw.STATUS_TABLE}
    exited_code = next(code for code, name, _ in rw.STATUS_TABLE if name == "exited")
    bad = (ds["status"] != exited_code) | (np.abs(ds["x_end"] - L) > 1e-9 * L)
    if bad.any():
        where = ds["status"].where(bad, drop=True).stack(point=("curvature", "mu")).dropna("point")
        examples = ", ".join(f"c={float(p.curvature):+.3f} mu={float(p.mu):.3f}: "
                             f"{names.get(int(p), int(p))}" for p in where[:5])
        fail(f"{int(bad.sum())} of {bad.size} blocks did not slide to B (x = L): {examples}")

    w = ds["W_friction"]
    # accuracy of the run: integrated vs energy-balance work
    balance = float(np.abs(ds["energy_balance_error"]).max())
    tol = max(1e-9, 100 * balance)

    # eq. (1): on the chord W_f = mu m g L whatever the slope
    chord = w.sel(curvature=0.0)
    formula = ds["mu"] * M * G * L
    chord_error = float(np.abs(chord - formula).max())
    if chord_error > tol:
        fail(f"straight chord: |W_f - mu m g L| up to {chord_error:.3g} J (> {tol:.3g} J)")

    # eq. (16): sign of the excess work is the sign of the curvature, for mu > 0
    excess = ds["W_excess"].sel(mu=ds["mu"] > 0)
    sign_c = np.sign(ds["curvature"])
    wrong = (np.sign(excess) != sign_c) & (sign_c != 0)
    if wrong.any():
        fail(f"eq. (16) sign claim violated in {int(wrong.sum())} cases: W_f - mu m g L does not "
             "have the sign of f'' (convex > straight > concave)")
    convex, concave = w.sel(curvature=C_SHOW), w.sel(curvature=-C_SHOW)
    positive = ds["mu"] > 0
    gaps = np.minimum(convex - chord, chord - concave).where(positive)
    resolution = float(np.abs(gaps).min())
    if balance > 0.1 * resolution:
        fail(f"step too large: the energy balance error ({balance:.2g} J) is not small against "
             f"the smallest difference compared ({resolution:.2g} J); use a smaller --dt")
    ordered = (convex > chord) & (chord > concave)
    if not bool(ordered.where(positive, True).all()):
        first = float(ds["mu"].where(positive & ~ordered, drop=True)[0])
        fail(f"at mu = {first:g}: not W(convex c=+{C_SHOW}) > W(straight) > W(concave c=-{C_SHOW})")

    mu_h = float(ds["mu"].sel(mu=MU_HEADLINE, method="nearest"))
    at = dict(mu=mu_h)
    speed = ds["speed_end"]
    return dict(
        mu=mu_h, chord=float(chord.sel(at)), convex=float(convex.sel(at)),
        concave=float(concave.sel(at)), chord_error=chord_error, balance=balance,
        speed_chord=float(speed.sel(mu=mu_h, curvature=0.0)),
        speed_convex=float(speed.sel(mu=mu_h, curvature=C_SHOW)),
        speed_concave=float(speed.sel(mu=mu_h, curvature=-C_SHOW)),
        speed_free=float(np.abs(speed.sel(mu=0.0) - np.sqrt(2 * G * H)).max()),
    )


# -- the figure -----------------------------------------------------------------
def figure(ds, path_png: Path, pdf: bool) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 10, "axes.titlesize": 11, "legend.fontsize": 9})
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.9), constrained_layout=True)
    mu = ds["mu"].values
    curv = ds["curvature"].values

    # (a) W_f vs mu: convex, straight, concave and the paper's formula
    ax = axes[0]
    mu_fine = np.linspace(0, mu.max(), 2)
    ax.plot(mu_fine, mu_fine * M * G * L, color="0.4", lw=1.2, ls="--", zorder=1,
            label=r"paper eq. (1): $\mu m g L$")
    styles = ((C_SHOW, "convex", "#1b4f72", "^", "-"),
              (0.0, "straight chord", "0.1", "o", "none"),
              (-C_SHOW, "concave", "#b35806", "v", "-"))
    for c, label, color, marker, ls in styles:
        w = ds["W_friction"].sel(curvature=c)
        name = f"{label}, c = {c:+.1f} 1/m" if c else f"{label}, c = 0"
        ax.plot(mu, w, color=color, marker=marker, ls=ls, ms=4.5, lw=1.4,
                markevery=max(1, len(mu) // 10), label=name, zorder=2)
    ax.set_xlabel(r"friction coefficient $\mu$")
    ax.set_ylabel(r"work against friction $W_f$ (J)")
    ax.set_title("(a) Work against friction, A to B")
    ax.legend(loc="upper left", frameon=False)
    ax.set_xlim(0, mu.max() * 1.02)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)

    # (b) excess work vs mean curvature, (c) speed at B vs curvature, colour = mu
    cmap = plt.get_cmap("viridis")
    mus = sorted({float(ds["mu"].sel(mu=m, method="nearest")) for m in MU_LINES})
    markers = "osD^v<>p"
    every = max(1, len(curv) // 8)
    for k, m in enumerate(mus):
        color = cmap(0.8 * k / max(1, len(mus) - 1))
        sel = ds.sel(mu=m)
        kw = dict(color=color, marker=markers[k % len(markers)], ms=4.5, lw=1.4,
                  markevery=every, label=rf"$\mu$ = {m:.2f}")
        axes[1].plot(sel["convexity_mean"], sel["W_excess"], **kw)
        axes[2].plot(curv, sel["speed_end"], **kw)

    ax = axes[1]
    ax.axhline(0, color="0.5", lw=0.8)
    ax.axvline(0, color="0.5", lw=0.8)
    ax.set_xlabel(r"convexity: mean $f''$ along the path (1/m)")
    ax.set_ylabel(r"excess work $W_f - \mu m g\,|\Delta x|$ (J)")
    ax.set_title("(b) Excess over the straight-ramp work")
    ax.text(0.54, 0.96, "convex ($f''>0$):\ncosts more than the chord", transform=ax.transAxes,
            ha="left", va="top")
    ax.text(0.03, 0.03, "concave ($f''<0$):\ncosts less than the chord", transform=ax.transAxes,
            ha="left", va="bottom")
    lo, hi = float(ds["W_excess"].min()), float(ds["W_excess"].max())
    ax.set_ylim(lo - 0.25 * (hi - lo), hi + 0.05 * (hi - lo))  # room for the text below
    ax.legend(loc="upper left", frameon=False)
    ax.grid(alpha=0.3)

    ax = axes[2]
    ax.set_xlabel(r"ramp curvature $c = f''$ (1/m)")
    ax.set_ylabel("speed along the ramp at B (m/s)")
    ax.set_title("(c) Exit speed at B")
    # label each curve directly (a legend would cover the lowest curve)
    for k, m in enumerate(mus):
        y = float(ds["speed_end"].sel(mu=m).isel(curvature=0))
        text = rf"$\mu$ = {m:.2f}" + (r": $\sqrt{2gH}$ for every shape" if m == 0 else "")
        ax.annotate(text, xy=(curv[0], y), xytext=(4, -7), textcoords="offset points",
                    ha="left", va="top", color=cmap(0.8 * k / max(1, len(mus) - 1)) if m else "k")
    ax.grid(alpha=0.3)

    fig.suptitle(f"Block from rest at A = (0, {H:g} m) to B = ({L:g} m, 0) on "
                 rf"$y = H + s x + c x^2/2$ through A and B   (m = {M:g} kg, "
                 f"RK4, dt = {ds.attrs['integrator_dt']:g} s)", fontsize=12)
    written = [path_png]
    fig.savefig(path_png, dpi=110)
    if pdf:
        written.append(path_png.with_suffix(".pdf"))
        fig.savefig(written[-1])
    plt.close(fig)
    return written


# -- main -----------------------------------------------------------------------
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help="output folder (default: studies/output; created if missing)")
    parser.add_argument("--dt", type=float, default=1e-3, help="RK4 time step in s (default 1e-3)")
    parser.add_argument("--full", action="store_true",
                        help="finer grids for publication (161 curvatures x 113 mu instead of 41 x 29)")
    parser.add_argument("--pdf", action="store_true", help="also write the figure as PDF")
    args = parser.parse_args(argv)
    if not args.dt > 0:
        parser.error(f"--dt must be > 0, got {args.dt}")

    started = time.perf_counter()
    args.out.mkdir(parents=True, exist_ok=True)
    curvature, mu = grids(args.full)
    print(f"{STUDY}: {curvature.size} curvatures in [{curvature[0]:g}, {curvature[-1]:g}] 1/m x "
          f"{mu.size} mu in [{mu[0]:g}, {mu[-1]:g}] = {curvature.size * mu.size} trajectories, "
          f"RK4 dt = {args.dt:g} s")
    _, ds = run(curvature, mu, args.dt)
    numbers = check(ds)

    import rampwork as rw

    nc = rw.write_netcdf(ds, args.out / f"{STUDY}.nc", overwrite=True)
    pictures = figure(ds, args.out / f"{STUDY}.png", args.pdf)
    total = time.perf_counter() - started

    n = numbers
    more = 100 * (n["convex"] / n["chord"] - 1)
    less = 100 * (1 - n["concave"] / n["chord"])
    print(f"  time: compile/load {ds.attrs['compile_time_s']:.1f} s, run "
          f"{ds.attrs['run_time_s']:.2f} s on {ds.attrs['threads']} threads, total {total:.1f} s")
    print(f"  at mu = {n['mu']:g}: straight chord W_f = {n['chord']:.3f} J (= mu m g L to "
          f"{n['chord_error']:.1e} J)")
    print(f"    convex  (c = +{C_SHOW:g} 1/m) costs {n['convex']:.3f} J = {more:.1f} % more")
    print(f"    concave (c = -{C_SHOW:g} 1/m) costs {n['concave']:.3f} J = {less:.1f} % less")
    print(f"    speed at B: concave {n['speed_concave']:.3f}, straight {n['speed_chord']:.3f}, "
          f"convex {n['speed_convex']:.3f} m/s (mu = 0: sqrt(2gH) = {np.sqrt(2 * G * H):.3f} m/s "
          f"for every shape, to {n['speed_free']:.0e})")
    print("  eq. (16) checked: W_f - mu m g L has the sign of f'' for every mu > 0 "
          f"(energy balance error <= {n['balance']:.1e} J)")
    for path in (nc, *pictures):
        print(f"  wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
