"""Least and most work: which ramp between the exam question's points costs the least, and the most, work against friction?

A block (m = 1 kg) starts from rest at A = (0, 1 m) towards B = (2 m, 0) with
mu = 0.2 (mu_s = mu_k), on ramps y = f(x) through A and B: the chord plus K
sine modes (rampwork.ChordModes), kept inside -0.5 m <= y <= 1.5 m (a floor
and a ceiling) and in contact (no lift-off).  rw.optimise (differential
evolution, one batched kernel call per generation) minimises and maximises
W_friction, with and without the constraint that the block must arrive at B,
at K = 2, 4, 6 (each K started from the previous K's best): how far shape
alone moves the work from the chord's mu m g L = 3.924 J.

Checks (the script fails loudly otherwise): the chord's W_friction against
mu m g L; every best shape's W_friction against an independent scipy DOP853
reference run of the same ramp; the bounds that energy sets: the most work
of a block that arrives is below m g H (it arrives with v >= 0), of one that
need not arrive below m g (H - y_floor) (it cannot stop below the floor); the
least work is >= 0, and shape beats the chord both ways where it must arrive.

    python studies/least_most_work.py            # ~1-2 min with the kernel cached
    python studies/least_most_work.py --full --gallery

Outputs (default folder studies/output/): least_most_work.nc and
least_most_work.png (and .pdf with --pdf).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import _study

STUDY = "least_most_work"
H, L, M, G = 1.0, 2.0, 1.0, 9.81  # m, m, kg, m s-2 (the exam question's)
MU = 0.2
Y_FLOOR, Y_CEILING = -0.5, 1.5  # m: the allowed region
#: (name, sense, constraints)
CASES = (("least, must arrive", "minimise", ("arrive", "stay_on")),
         ("most, must arrive", "maximise", ("arrive", "stay_on")),
         ("least, need not arrive", "minimise", ("stay_on",)),
         ("most, need not arrive", "maximise", ("stay_on",)))
W_CHORD = MU * M * G * L


def shape_of(k: int):
    import rampwork as rw

    return rw.ChordModes(start=(0.0, H), end=(L, 0.0), k=k, y_bounds=(Y_FLOOR, Y_CEILING))


def scene_of(shape):
    import rampwork as rw

    return shape.scene(friction=rw.Friction(mu_k=MU), integrator=rw.Integrator("dopri5", rtol=1e-9),
                       m=M, g=G, title="Least and most work against friction from A = (0, 1 m) to "
                                       "B = (2 m, 0)")


def optimise_ladder(ladder, popsize: int, maxiter: int):
    """Every case at every K of ``ladder``, each K started from the previous
    one's best (zeros appended).  Returns {(case, K): history}."""
    import rampwork as rw

    histories = {}
    for name, sense, constraints in CASES:
        start = None
        for k in ladder:
            shape = shape_of(k)
            x0 = None if start is None else tuple(start) + (0.0,) * (k - len(start))
            started = time.perf_counter()
            history = rw.optimise(scene_of(shape), shape, "W_friction", constraints, sense=sense, seed=1,
                                  popsize=popsize, maxiter=maxiter, tol=1e-7, x0=x0)
            start = history["best_parameters"].values[-1]
            histories[name, k] = history
            print(f"  {name:<24} K = {k:2d}: W_f = {history.attrs['best_objective']:.5f} J after "
                  f"{history.attrs['generations']} generations "
                  f"({'converged' if history.attrs['converged'] else 'maxiter'}), "
                  f"{time.perf_counter() - started:.1f} s")
    return histories


def build(histories, ladder):
    """The study's dataset: per case the best shape at the largest K (its
    run, profile and history) and the best W_f at every K."""
    import xarray as xr

    from rampwork.reference import reference_trajectory
    from rampwork.runner import scene_text
    from rampwork.scene import Sweep
    from rampwork.schema import global_attrs

    k_top = ladder[-1]
    shape = shape_of(k_top)
    scene = scene_of(shape)
    names = [name for name, _, _ in CASES]
    best = np.array([histories[name, k_top]["best_parameters"].values[-1] for name in names])
    run = shape.evaluate(np.vstack([np.zeros(k_top), best]), scene)  # the chord, then the best shapes
    chord, run = run.isel(candidate=0), run.isel(candidate=slice(1, None))
    reference = np.array([reference_trajectory(scene, ramp=shape.ramp(row[None, :]), x0=0.0,
                                               rtol=1e-12, atol=1e-12)["W_friction"] for row in best])
    x = np.linspace(0.0, L, 201)
    profile, _, _ = shape.profile(best, np.broadcast_to(x, (len(best), x.size)))
    generations = max(histories[name, k_top].sizes["generation"] for name in names)
    trace = np.full((len(names), generations), np.nan)
    for i, name in enumerate(names):
        values = histories[name, k_top]["best_objective"].values
        trace[i, :values.size] = values
    by_k = np.array([[histories[name, k].attrs["best_objective"] for k in ladder] for name in names])
    attrs = dict(units="J")
    ds = xr.Dataset(
        {name: ("case", run[name].values, dict(run[name].attrs))
         for name in ("status", "t_end", "W_friction", "W_excess", "speed_end", "arrived", "admissible")}
        | {"W_friction_reference": ("case", reference, attrs | dict(
               long_name="work against friction, scipy DOP853 reference (rtol 1e-12)")),
           "coefficients": (("case", "mode"), best, dict(units="m", long_name="sine mode amplitudes")),
           "y": (("case", "x"), profile, dict(units="m", long_name="height of the best ramp")),
           "best_W_friction": (("case", "generation"), trace, attrs | dict(
               long_name=f"best W_friction so far at K = {k_top}")),
           "best_W_friction_by_K": (("case", "K"), by_k, attrs | dict(
               long_name="best W_friction found with K modes"))},
        coords={"case": names, "mode": np.arange(1, k_top + 1), "x": ("x", x, dict(units="m")),
                "generation": np.arange(1, generations + 1), "K": list(ladder)},
        attrs=global_attrs(scene.title, scene_text(scene, Sweep.single()), "",
                           {"mu": MU, "H": H, "L": L, "y_floor": Y_FLOOR, "y_ceiling": Y_CEILING,
                            "W_chord": float(chord["W_friction"].values), "K": k_top,
                            "shape": shape.describe()}))
    _study.note_history(ds, STUDY, f"rw.optimise of W_friction, 4 cases x K in {list(ladder)}")
    return ds


def check(ds) -> dict:
    w_chord = ds.attrs["W_chord"]
    if abs(w_chord - W_CHORD) > 1e-7 * W_CHORD:
        _study.fail(STUDY, f"chord: W_f = {w_chord!r} J, not mu m g L = {W_CHORD!r} J")
    w, ref = ds["W_friction"].values, ds["W_friction_reference"].values
    error = float(np.max(np.abs(w - ref) / np.maximum(np.abs(ref), 1e-12 * W_CHORD)))
    if not error < 1e-6:
        _study.fail(STUDY, f"best shapes against the scipy reference: relative W_f error {error:.2g}")
    least, most, free_least, free_most = w
    arrived = ds["arrived"].values
    if not (arrived[0] and arrived[1]):
        _study.fail(STUDY, "a best shape of a case that must arrive did not arrive")
    if not (least < W_CHORD < most <= M * G * H * (1 + 1e-9)):
        _study.fail(STUDY, f"must arrive: expected least {least:.4f} < chord {W_CHORD:.4f} < most "
                           f"{most:.4f} <= m g H = {M * G * H:.4f} J")
    if not (-1e-12 <= free_least and free_most <= M * G * (H - Y_FLOOR) * (1 + 1e-9)):
        _study.fail(STUDY, f"need not arrive: expected 0 <= {free_least:.4f} and {free_most:.4f} <= "
                           f"m g (H - y_floor) = {M * G * (H - Y_FLOOR):.4f} J")
    return dict(error=error, least=least, most=most, free_least=free_least, free_most=free_most)


def figure(ds):
    from rampwork.plotting import new_figure, series

    fig, axes = new_figure(1, 3, size=(14.5, 4.4))
    ax_shape, ax_gen, ax_k = axes[0]
    cases = list(ds["case"].values)
    x = ds["x"].values
    ax_shape.plot([0, L], [H, 0], color="0.3", lw=1, ls=(0, (2, 2)), label=f"chord: {W_CHORD:.3f} J")
    for i, name in enumerate(cases):
        look = series(i, len(cases)) | dict(markevery=20)
        w = float(ds["W_friction"].values[i])
        ax_shape.plot(x, ds["y"].values[i], **look, label=f"{name}: {w:.3f} J")
        ax_gen.plot(ds["generation"].values, ds["best_W_friction"].values[i] / W_CHORD,
                    **look | dict(markevery=max(1, ds.sizes["generation"] // 10)), label=name)
        ax_k.plot(ds["K"].values, ds["best_W_friction_by_K"].values[i] / W_CHORD, **look | dict(markevery=1),
                  label=name)
    ax_shape.axhspan(Y_FLOOR - 0.2, Y_FLOOR, color="0.85", lw=0)
    ax_shape.plot([0, L], [H, 0], "ko", ms=5)
    ax_shape.annotate("A", (0, H), xytext=(6, 4), textcoords="offset points")
    ax_shape.annotate("B", (L, 0), xytext=(-12, 6), textcoords="offset points")
    ax_shape.set(xlabel="x (m)", ylabel="height y (m)", ylim=(Y_FLOOR - 0.1, 1.55),
                 title=f"(a) Best ramps at K = {ds.attrs['K']}, mu = {MU:g}")
    ax_shape.legend(loc="upper right", fontsize=7)
    for ax in (ax_gen, ax_k):
        for value, text in ((1.0, r"chord $\mu m g L$"), (M * G * H / W_CHORD, r"$m g H$"),
                            (M * G * (H - Y_FLOOR) / W_CHORD, r"$m g (H - y_{floor})$")):
            ax.axhline(value, color="0.3", lw=1, ls=(0, (2, 2)))
            ax.text(ax.get_xlim()[1] if ax is ax_k else 1, value, text, fontsize=7, va="bottom",
                    ha="right" if ax is ax_k else "left", color="0.3")
    ax_gen.set(xlabel="generation", ylabel=r"best $W_f$ / $\mu m g L$",
               title=f"(b) Convergence at K = {ds.attrs['K']}")
    ax_k.set(xlabel="K (sine modes)", ylabel=r"best $W_f$ / $\mu m g L$", title="(c) Convergence in K")
    ax_gen.legend(loc="center right", fontsize=7)
    fig.suptitle("Shape alone moves the work against friction between A and B: from rest, m = 1 kg, "
                 f"mu = {MU:g}, -0.5 m <= y <= 1.5 m, no lift-off")
    return fig


def main(argv=None) -> int:
    args = _study.parser(__doc__).parse_args(argv)
    started = time.perf_counter()
    ladder = _study.scale(args, (1, 2), (2, 4, 6), (2, 4, 6, 8))
    popsize, maxiter = _study.scale(args, (6, 15), (12, 300), (15, 600))
    print(f"{STUDY}: min and max W_friction, mu = {MU:g}, K in {list(ladder)}, popsize {popsize}, "
          f"maxiter {maxiter}")
    histories = optimise_ladder(ladder, popsize, maxiter)
    ds = build(histories, ladder)
    n = check(ds)
    print(f"  chord: W_f = {ds.attrs['W_chord']:.6f} J = mu m g L")
    print(f"  must arrive:    least {n['least']:.4f} J ({100 * (n['least'] / W_CHORD - 1):+.1f} %), most "
          f"{n['most']:.4f} J ({100 * (n['most'] / W_CHORD - 1):+.1f} %; m g H = {M * G * H:.4f} J)")
    print(f"  need not arrive: least {n['free_least']:.4f} J, most {n['free_most']:.4f} J "
          f"(m g (H - y_floor) = {M * G * (H - Y_FLOOR):.4f} J)")
    print(f"  best shapes against the scipy reference: max relative W_f error {n['error']:.1e}")
    _study.finish(STUDY, ds, figure(ds), args, started)
    return 0


if __name__ == "__main__":
    sys.exit(main())
