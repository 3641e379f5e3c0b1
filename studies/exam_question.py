"""The exam question behind the paper: straight, convex or concave ramp, which costs more?

A block (m = 1 kg) starts from rest at A = (0, H) and slides towards B = (L, 0)
on three ramps through both points: the straight chord, a convex parabola
(f'' = +C) and a concave one (f'' = -C), y = H + s x + c x^2/2 with
s = -H/L - c L/2.  For each friction coefficient mu (mu_s = mu_k) it records the
work against friction and the speed at B.  On the chord the paper's closed forms
hold whatever the slope: W_f = mu m g L (eq. 1) and, from the energy balance,
speed at B = sqrt(2 g (H - mu L)); the script checks both and fails loudly if
they do not hold, or if convex > straight > concave fails where all three reach B.

    python studies/exam_question.py            # ~5 s with compiled kernels cached
    python studies/exam_question.py --full --gallery

Outputs (default folder studies/output/): exam_question.nc and exam_question.png
(and .pdf with --pdf).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import _study

STUDY = "exam_question"
H, L, M, G = 1.0, 2.0, 1.0, 9.81  # m, m, kg, m s-2
C = 0.15  # 1/m, curvature of the convex (+) and concave (-) ramps
MU_MAX = 0.5  # = H / L: beyond it no block leaves A on the chord
MU_HEADLINE = 0.3
MU_LABEL = r"friction coefficient $\mu$"
RAMPS = (("convex", C), ("straight", 0.0), ("concave", -C))


def start_slope(curvature):
    """f'(0) that puts the parabola through B = (L, 0)."""
    return -H / L - np.asarray(curvature) * L / 2


def run(n_mu: int):
    import rampwork as rw

    mu = _study.even(0, MU_MAX, n_mu)
    scene = rw.Scene(
        ramp=rw.Ramp.create("quadratic", curvature=0.0, slope=start_slope(0.0), height=H,
                            domain=(0.0, L)),
        integrator=rw.Integrator("rk4", 1e-3), x0=0.0, v0=0.0, m=M, g=G,
        title=f"Exam question: from rest at (0, {H:g} m) to ({L:g} m, 0) on a straight, a convex "
              "and a concave ramp")
    ds = _study.simulate_grid(scene, lambda p: dict(slope=start_slope(p["curvature"])),
                              curvature=[c for _, c in RAMPS], mu=mu)
    fp_end = start_slope(ds["curvature"]) + ds["curvature"] * L
    ds["speed_end"] = (np.abs(ds["v_end"]) * np.sqrt(1 + fp_end**2)).assign_attrs(
        units="m s-1", long_name="speed along the ramp at the end",
        comment="|v_end| sqrt(1 + f'(x_end)^2)")
    ds["reached_B"] = ((ds["status"] == 2) & (np.abs(ds["x_end"] - L) < 1e-9)).assign_attrs(
        long_name="the block slid all the way to B", units="1")
    _study.note_history(ds, STUDY, "cases reshaped to (curvature, mu); speed_end, reached_B added")
    return ds


def check(ds) -> dict:
    """The closed forms on the chord and the ordering; returns headline numbers."""
    balance = float(np.abs(ds["energy_balance_error"]).max())
    tol = max(1e-9, 100 * balance)
    straight = ds.sel(curvature=0.0)
    moving = straight["mu"] < MU_MAX
    if not bool(straight["reached_B"].where(moving, True).all()):
        _study.fail(STUDY, "a block on the chord with mu < H/L did not reach B")
    w_formula = straight["mu"] * M * G * L
    w_error = float(np.abs(straight["W_friction"] - w_formula).where(moving, 0).max())
    v_formula = np.sqrt(2 * G * np.maximum(H - straight["mu"] * L, 0))
    v_error = float(np.abs(straight["speed_end"] - v_formula).where(moving, 0).max())
    if w_error > tol or v_error > 1e-6:
        _study.fail(STUDY, f"chord: |W_f - mu m g L| = {w_error:.2g} J, |speed - sqrt(2g(H - mu L))|"
                           f" = {v_error:.2g} m/s")
    w = ds["W_friction"]
    all_reach = ds["reached_B"].all("curvature") & (ds["mu"] > 0)
    convex, chord, concave = (w.sel(curvature=c) for _, c in RAMPS)
    ordered = (convex > chord) & (chord > concave)
    if not bool(ordered.where(all_reach, True).all()):
        _study.fail(STUDY, "convex > straight > concave does not hold where all three reach B")
    at = dict(mu=MU_HEADLINE)
    reach_limit = {name: float(ds["mu"].where(ds["reached_B"].sel(curvature=c)).max())
                   for name, c in RAMPS}
    return dict(w_error=w_error, v_error=v_error, balance=balance, reach_limit=reach_limit,
                compared=int(all_reach.sum()),
                **{name: float(w.sel(curvature=c, **at)) for name, c in RAMPS},
                **{f"speed_{name}": float(ds["speed_end"].sel(curvature=c, **at))
                   for name, c in RAMPS})


def figure(ds):
    import rampwork as rw
    from rampwork.plotting import label, new_figure, series

    fig, axes = new_figure(1, 3, size=(14.5, 4.4))
    ax_shape, ax_w, ax_v = axes[0]
    x = np.linspace(0, L, 201)
    mu = ds["mu"].values
    for k, (name, c) in enumerate(RAMPS):
        look = series(k, len(RAMPS)) | dict(markevery=20)
        ramp = rw.Ramp.create("quadratic", curvature=c, slope=float(start_slope(c)), height=H,
                              domain=(0.0, L))
        ax_shape.plot(x, ramp.evaluate(x)[0], **look, label=f"{name}, f'' = {c:+g} 1/m")
        reached = ds["reached_B"].sel(curvature=c).values
        for ax, var in ((ax_w, "W_friction"), (ax_v, "speed_end")):
            y = ds[var].sel(curvature=c).values
            ax.plot(mu, np.where(reached, y, np.nan), **look | dict(markevery=max(1, len(mu) // 10)),
                    label=name)
    mu_fine = np.linspace(0, MU_MAX, 101)
    ax_w.plot(mu_fine, mu_fine * M * G * L, color="0.3", lw=1, ls=(0, (2, 2)), zorder=5,
              label=r"chord, paper eq. (1): $\mu m g L$")
    ax_v.plot(mu_fine, np.sqrt(2 * G * (H - mu_fine * L)), color="0.3", lw=1, ls=(0, (2, 2)),
              zorder=5, label=r"chord: $\sqrt{2g(H-\mu L)}$")
    ax_shape.plot([0, L], [H, 0], "ko", ms=5)
    ax_shape.annotate("A (start, at rest)", (0, H), xytext=(6, 4), textcoords="offset points")
    ax_shape.annotate("B", (L, 0), xytext=(-12, 6), textcoords="offset points")
    ax_shape.set(xlabel="x (m)", ylabel="height y (m)", title="(a) Three ramps from A to B",
                 ylim=(-0.05, H * 1.12))
    ax_shape.legend(loc="lower left")
    ax_w.set(xlabel=MU_LABEL, ylabel=label(ds["W_friction"]),
             title="(b) Work against friction, A to B")
    ax_w.legend(loc="upper left")
    ax_v.set(xlabel=MU_LABEL, ylabel="speed along the ramp at B (m/s)",
             title="(c) Speed at B")
    ax_v.legend(loc="lower left")
    for ax in (ax_w, ax_v):
        ax.set_xlim(0, MU_MAX)
        ax.text(0.98, 0.03 if ax is ax_w else 0.97,
                "a curve ends where that block\nstops before B", transform=ax.transAxes,
                ha="right", va="bottom" if ax is ax_w else "top", fontsize=8, color="0.3")
    fig.suptitle(f"Block from rest, m = {M:g} kg, RK4 dt = 1 ms: the convex ramp costs the most "
                 "friction work, the concave one the least")
    return fig


def main(argv=None) -> int:
    args = _study.parser(__doc__).parse_args(argv)
    started = time.perf_counter()
    n_mu = _study.scale(args, 5, 50, 400)
    print(f"{STUDY}: 3 ramps x {n_mu + 1} mu in [0, {MU_MAX:g}], RK4 dt = 1 ms")
    ds = run(n_mu)
    n = check(ds)
    print(f"  compile/load {ds.attrs['compile_time_s']:.1f} s, run {ds.attrs['run_time_s']:.2f} s")
    print(f"  chord, closed forms: max |W_f - mu m g L| = {n['w_error']:.1e} J, "
          f"max |speed_B - sqrt(2g(H - mu L))| = {n['v_error']:.1e} m/s")
    print(f"  at mu = {MU_HEADLINE:g}: W_f convex {n['convex']:.4f} J, straight {n['straight']:.4f} J"
          f" (mu m g L = {MU_HEADLINE * M * G * L:.4f} J), concave {n['concave']:.4f} J")
    print(f"    convex - straight = {n['convex'] - n['straight']:+.4f} J "
          f"({100 * (n['convex'] / n['straight'] - 1):+.1f} %), concave - straight = "
          f"{n['concave'] - n['straight']:+.4f} J ({100 * (n['concave'] / n['straight'] - 1):+.1f} %)")
    print(f"    speed at B: convex {n['speed_convex']:.3f}, straight {n['speed_straight']:.3f}, "
          f"concave {n['speed_concave']:.3f} m/s")
    print("  largest mu that still reaches B: " + ", ".join(
        f"{name} {value:g}" for name, value in n["reach_limit"].items()))
    print(f"  convex > straight > concave holds at all {n['compared']} mu > 0 where all three "
          f"reach B (energy balance error <= {n['balance']:.1e} J)")
    _study.finish(STUDY, ds, figure(ds), args, started)
    return 0


if __name__ == "__main__":
    sys.exit(main())
