"""Ramps whose convexity changes sign: where does the curved ramp cost the same as the straight one?

A block starts at A = (0, 0) with speed v0 along +x and slides down to
B = (L, -H) on y = -(H/L) x + a sin(k x + phase) with k = 2 pi / L: one full
sine wave laid on the chord, so every ramp passes through A and B, has both
convex (f'' > 0) and concave stretches, and a mean f'' over [0, L] of exactly
zero.  The paper's eq. (14), W_f - mu m g |dx| = mu m int(v^2 f'' dx), weights
f'' by v^2, which grows down the ramp: a wave that is convex where the block is
fast costs more than the chord, one that is convex where it is slow costs less,
and in between there is a phase where it costs the same.  To first order in a
(v^2 from the chord, v^2 = v0^2 + 2 g (s - mu) x / (1 + s^2), s = H/L):

    W_f - mu m g L  ~  2 pi mu m a cos(phase) 2 g (s - mu) / (1 + s^2),

zero at phase = pi/2 and 3 pi/2.  The script sweeps phase, amplitude and mu,
checks that every block reaches B, that the mean convexity is zero and that the
small-amplitude excess follows the first-order formula, and finds the phases of
equal cost by interpolation.

    python studies/sign_changing_convexity.py            # ~10 s with compiled kernels cached
    python studies/sign_changing_convexity.py --full --gallery

Outputs (default folder studies/output/): sign_changing_convexity.nc and
sign_changing_convexity.png (and .pdf with --pdf).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import _study

STUDY = "sign_changing_convexity"
H, L, M, G = 1.0, 2.0, 1.0, 9.81  # m, m, kg, m s-2
V0 = 0.5  # m/s
K = 2 * np.pi / L  # 1/m: one full wave between A and B
A_MAX = 0.05  # m: |f''| <= A_MAX K^2 = 0.49 1/m keeps the block on the ramp
MU_REF = 0.2
SLOPE = H / L
#: bound on (excess - first order) / first order per metre of amplitude (8.4 /m measured)
SECOND_ORDER = 15.0


def first_order(phase, amplitude, mu):
    """The excess work to first order in the amplitude (docstring)."""
    b = 2 * G * (SLOPE - mu) / (1 + SLOPE**2)
    return 2 * np.pi * mu * M * amplitude * np.cos(phase) * b


def run(n_phase: int, n_amp: int, mu):
    import rampwork as rw

    scene = rw.Scene(
        ramp=rw.Ramp.create("sine", amplitude=0.0, wavenumber=K, mean_slope=-SLOPE, domain=(0.0, L)),
        integrator=rw.Integrator("rk4", 1e-3), x0=0.0, v0=V0, m=M, g=G, t_max=30.0,
        title=f"Sine wave on the chord from (0, 0) to ({L:g} m, {-H:g} m): convexity changing sign")
    sweep = rw.Sweep.grid(phase=_study.even(0, 2 * np.pi, n_phase),
                          amplitude=_study.even(0, A_MAX, n_amp), mu=mu)
    ds = rw.simulate(scene, sweep)
    ds["W_excess_first_order"] = first_order(ds["phase"], ds["amplitude"], ds["mu"]).assign_attrs(
        units="J", long_name="excess work to first order in the amplitude",
        comment="2 pi mu m a cos(phase) 2 g (s - mu) / (1 + s^2): eq. (14) with v^2 from the chord")
    _study.note_history(ds, STUDY, "added W_excess_first_order")
    return ds


def equal_cost_phases(excess, phase):
    """Phases where the excess work changes sign along ``phase`` (linear interpolation)."""
    e = np.asarray(excess)
    cross = np.nonzero(np.sign(e[:-1]) * np.sign(e[1:]) < 0)[0]
    return [phase[i] - e[i] * (phase[i + 1] - phase[i]) / (e[i + 1] - e[i]) for i in cross]


def check(ds) -> dict:
    if not bool((ds["status"] == 2).all() & (np.abs(ds["x_end"] - L) < 1e-9).all()):
        _study.fail(STUDY, "a block did not reach B")
    curved = ds["amplitude"] > 0
    mean_f2 = float(np.abs(ds["convexity_mean"]).where(curved).max())
    if mean_f2 > 1e-6:
        _study.fail(STUDY, f"mean f'' along the path is {mean_f2:.2g} 1/m, not 0")
    smallest = ds.sel(amplitude=ds["amplitude"][1])
    scale_ = float(np.abs(smallest["W_excess_first_order"]).max())
    first_error = float(np.abs(smallest["W_excess"] - smallest["W_excess_first_order"]).max()) / scale_
    if first_error > SECOND_ORDER * float(smallest.amplitude):  # the deviation is O(a^2)
        _study.fail(STUDY, f"at a = {float(smallest.amplitude):g} m the excess differs from the "
                           f"first-order formula by {100 * first_error:.0f} % of its size")
    ref = ds.sel(mu=MU_REF, method="nearest")
    top = ref.sel(amplitude=A_MAX, method="nearest")
    phases = equal_cost_phases(top["W_excess"].values, ds["phase"].values)
    return dict(mean_f2=mean_f2, first_error=first_error, amplitude=float(top.amplitude),
                smallest=float(smallest.amplitude), mu=float(ref.mu), phases=phases,
                most=float(top["W_excess"].max()), least=float(top["W_excess"].min()),
                linear=float(top["W_linear"].max()),
                balance=float(np.abs(ds["energy_balance_error"]).max()))


def figure(ds, n):
    import rampwork as rw
    from rampwork.plotting import heatmap, new_figure, series

    fig, axes = new_figure(2, 2, size=(12.5, 9.0))
    ref = ds.sel(mu=MU_REF, method="nearest")
    phase = ds["phase"].values
    excess_label = r"excess work $W_f - \mu m g\,|\Delta x|$ (J)"
    quarter = (0.0, np.pi / 2, np.pi, 3 * np.pi / 2)
    names = ("0", r"$\pi/2$", r"$\pi$", r"$3\pi/2$")

    ax = axes[0, 0]
    x = np.linspace(0, L, 201)
    ax.axhline(0.0, color="k", lw=1, ls=(0, (2, 2)), label="straight chord")
    for k, (p, name) in enumerate(zip(quarter, names)):
        ramp = rw.Ramp.create("sine", amplitude=A_MAX, wavenumber=K, mean_slope=-SLOPE, phase=p,
                              domain=(0.0, L))
        ax.plot(x, ramp.evaluate(x)[0] + SLOPE * x, markevery=25, **series(k, len(quarter)),
                label=f"phase {name}")
    ax.set(xlabel="x (m)", ylabel="height above the chord y + (H/L) x (m)",
           title=f"(a) The waves at a = {A_MAX:g} m (drawn above the chord)",
           ylim=(-1.9 * A_MAX, 1.2 * A_MAX))
    ax.legend(loc="lower center", ncols=3)

    ax = axes[0, 1]
    curved = ref["W_excess"].sel(amplitude=ds["amplitude"] > 0)  # a = 0: the chord, excess 0
    heatmap(ax, curved.transpose("amplitude", "phase").values, phase,
            curved["amplitude"].values, colorbar_label=excess_label, zero=True)
    ax.set(xlabel="phase of the wave (rad)", ylabel="amplitude a (m)", xlim=(0, 2 * np.pi),
           title=rf"(b) $\mu$ = {n['mu']:g}: dashed, costs the same as the chord")

    ax = axes[1, 0]
    amplitudes = ds["amplitude"].values[1:]
    picks = amplitudes[np.unique(np.linspace(0, len(amplitudes) - 1, 4).round().astype(int))]
    fine = np.linspace(0, 2 * np.pi, 200)
    for k, a in enumerate(picks):
        look = series(k, len(picks))
        ax.plot(phase, ref["W_excess"].sel(amplitude=a), markevery=max(1, len(phase) // 16),
                **look | dict(linestyle="none"), label=f"a = {a:g} m")
        ax.plot(fine, first_order(fine, a, n["mu"]), color=look["color"], lw=1.0, ls="-")
    ax.plot([], [], color="0.3", lw=1, label="first order in a")
    ax.axhline(0, color="0.4", lw=0.8)
    ax.set(xlabel="phase of the wave (rad)", ylabel=excess_label,
           title=rf"(c) $\mu$ = {n['mu']:g}: engine (markers) and first-order formula (lines)")
    ax.legend(loc="upper center", ncols=3)
    ax.set_ylim(top=ax.get_ylim()[1] * 1.35)  # room for the legend

    ax = axes[1, 1]
    mus = [m for m in ds["mu"].values if m > 0]
    mus = [mus[i] for i in np.unique(np.linspace(0, len(mus) - 1, 4).round().astype(int))]
    for k, mu in enumerate(mus):
        roots = [equal_cost_phases(ds["W_excess"].sel(mu=mu, amplitude=a).values, phase)
                 for a in amplitudes]
        for branch in (0, 1):
            ax.plot([r[branch] if len(r) == 2 else np.nan for r in roots], amplitudes,
                    **series(k, len(mus)), label=rf"$\mu$ = {mu:g}" if branch == 0 else None)
    for p in (np.pi / 2, 3 * np.pi / 2):
        ax.axvline(p, color="0.3", lw=1, ls=(0, (2, 2)))
    ax.set(xlabel="phase of equal cost (rad)", ylabel="amplitude a (m)", xlim=(0, 2 * np.pi),
           title="(d) Where the wave costs the same as the chord\n(dotted: first order, pi/2 and 3 pi/2)")
    ax.legend(loc="center")
    for ax in (axes[0, 1], axes[1, 0], axes[1, 1]):
        ax.set_xticks(np.arange(5) * np.pi / 2, ["0", r"$\pi/2$", r"$\pi$", r"$3\pi/2$", r"$2\pi$"])
    fig.suptitle(f"A full sine wave on the chord (mean f'' = 0), from (0, 0) to ({L:g} m, {-H:g} m),"
                 f" v0 = {V0:g} m/s, m = {M:g} kg, RK4 dt = 1 ms")
    return fig


def main(argv=None) -> int:
    args = _study.parser(__doc__).parse_args(argv)
    started = time.perf_counter()
    n_phase, n_amp, mu = _study.scale(args, (8, 2, [0.1, 0.2]), (32, 5, [0.1, 0.2, 0.3]),
                                      (128, 25, _study.even(0.025, 0.3, 11)))
    print(f"{STUDY}: {n_phase + 1} phases x {n_amp + 1} amplitudes in [0, {A_MAX:g}] m x "
          f"{len(mu)} mu, RK4 dt = 1 ms")
    ds = run(n_phase, n_amp, np.asarray(mu, dtype=float))
    n = check(ds)
    print(f"  compile/load {ds.attrs['compile_time_s']:.1f} s, run {ds.attrs['run_time_s']:.2f} s")
    print(f"  every block reaches B; mean f'' along the path <= {n['mean_f2']:.1e} 1/m (zero); "
          f"energy balance error <= {n['balance']:.1e} J")
    print(f"  a = {n['smallest']:g} m: excess = first-order formula to {100 * n['first_error']:.1f} % "
          "of its size")
    print(f"  at mu = {n['mu']:g}, a = {n['amplitude']:g} m (mu m g L = {n['linear']:.4f} J): excess "
          f"from {n['least']:+.4f} J to {n['most']:+.4f} J over the phase")
    print("    costs the same as the chord at phase " + ", ".join(
        f"{p:.3f} rad ({p / np.pi:.3f} pi)" for p in n["phases"]) + " (first order: 0.5 pi, 1.5 pi)")
    _study.finish(STUDY, ds, figure(ds, n), args, started)
    return 0


if __name__ == "__main__":
    sys.exit(main())
