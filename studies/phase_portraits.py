"""Phase portraits (v against x) and paths (y against x) with friction: reversals, sticking, lift-off.

Four recorded trajectories (scene option ``record``) on one wavy ramp
y = a sin(pi x / l), a trough (a bowl, f'' > 0) between two crests (f'' < 0):

* released from rest on the trough's side, the block swings back and forth,
  losing energy to friction at every pass, and sticks at the first reversal
  where |f'(x)| <= mu (the rest rule): many reversals for small mu, few for large;
* pushed from the bottom of the trough, it turns back below the crest;
* pushed harder, it reaches the crest fast enough that the normal term
  n = g + v^2 f'' reaches zero before the top: it lifts off (horizontal velocity
  |v| = sqrt(-g / f''(x)) there) and flies on a parabola.

The script checks along every recorded trajectory that the energy balance
holds (mechanical energy + work against friction = initial energy), that the
blocks at rest stay where static friction holds them, and that n = 0 at lift-off.

    python studies/phase_portraits.py            # ~5 s with compiled kernels cached
    python studies/phase_portraits.py --gallery

Outputs (default folder studies/output/): phase_portraits.nc and
phase_portraits.png (and .pdf with --pdf).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import _study

STUDY = "phase_portraits"
M, G = 1.0, 9.81  # kg, m s-2
A, WAVE = 0.5, 2.0  # m: amplitude and wavelength of the ramp
K = 2 * np.pi / WAVE
DOMAIN = (-1.5, 0.5)  # m: crest to crest, the trough at x = -0.5
#: (mu, x0 m, v0 m/s, what happens) of each recorded trajectory
CASES = ((0.05, -1.2, 0.0, "released"), (0.3, -1.2, 0.0, "released"),
         (0.1, -0.5, 3.0, "pushed"), (0.1, -0.5, 5.5, "pushed"))


def ramp(x):
    """f, f', f'' of the wavy ramp."""
    return A * np.sin(K * x), A * K * np.cos(K * x), -A * K**2 * np.sin(K * x)


def run(every: int):
    import rampwork as rw

    columns = {name: np.array([c[k] for c in CASES]) for k, name in enumerate(("mu", "x0", "v0"))}
    scene = rw.Scene(
        ramp=rw.Ramp.create("sine", amplitude=A, wavenumber=K, domain=DOMAIN),
        integrator=rw.Integrator("rk4", 1e-3), m=M, g=G, t_max=30.0,
        record=rw.Record(indices=tuple(range(len(CASES))), every=every, max_samples=40000),
        title=f"Recorded trajectories on the wavy ramp y = {A:g} m sin(pi x / {WAVE / 2:g} m)")
    ds = rw.simulate(scene, rw.Sweep.cases(**columns))
    _study.note_history(ds, STUDY, "no change")
    return ds


def trace(ds, k):
    """Samples of recorded trajectory k: t, x, v, W_friction."""
    n = int(ds["trace_length"][k])
    return [ds[name].isel(traced=k).values[:n] for name in
            ("trace_t", "trace_x", "trace_v", "trace_W_friction")]


def check(ds) -> list[str]:
    lines = []
    for k, (mu, x0, v0, _) in enumerate(CASES):
        t, x, v, w = trace(ds, k)
        f, fp, fpp = ramp(x)
        energy = M * (G * f + v**2 * (1 + fp**2) / 2)
        drift = float(np.abs(energy + w - energy[0]).max())
        if drift > 1e-6:  # J, of about 5 J in play: RK4 at dt = 1 ms over 10^4 steps
            _study.fail(STUDY, f"case {k}: energy + W_f drifts by {drift:.2g} J along the trajectory")
        status = int(ds["status"][k])
        reversals = int(np.sum(v[1:-1] == 0.0))  # recorded with v = 0 exactly; the last: a stop
        if reversals != int(ds["n_reversals"][k]):
            _study.fail(STUDY, f"case {k}: {reversals} recorded reversals, n_reversals = "
                               f"{int(ds['n_reversals'][k])}")
        what = {1: "stuck", 2: "exited", 3: "lifted off"}.get(status, f"status {status}")
        if status == 1:
            if float(ds["v_end"][k]) != 0 or abs(fp[-1]) > mu:
                _study.fail(STUDY, f"case {k} is stuck where |f'| > mu or with v != 0")
            what += f" at x = {x[-1]:+.4f} m (|f'| = {abs(fp[-1]):.3f} <= mu = {mu:g})"
        if status == 3:
            n_end = G + v[-1] ** 2 * fpp[-1]
            if abs(n_end) > 1e-6:
                _study.fail(STUDY, f"case {k} lifted off with n = {n_end:.2g} m/s^2, not 0")
            what += (f" at x = {float(ds['x_lift_off'][k]):+.4f} m with |v| = {abs(v[-1]):.4f} m/s"
                     f" = sqrt(-g/f'') (n = {n_end:.0e})")
        lines.append(f"  mu = {mu:g}, x0 = {x0:g} m, v0 = {v0:g} m/s: {reversals} reversals, "
                     f"{what}; W_f = {float(ds['W_friction'][k]):.4f} J at t = {t[-1]:.2f} s; "
                     f"energy + W_f constant along the path to {drift:.1e} J")
    return lines


def figure(ds):
    from rampwork.plotting import new_figure, series

    fig, axes = new_figure(1, 3, size=(16.0, 5.2))
    ax_path, ax_phase, ax_work = axes[0]
    xs = np.linspace(*DOMAIN, 301)
    ax_path.plot(xs, ramp(xs)[0], color="0.6", lw=6, alpha=0.5, solid_capstyle="butt",
                 label="ramp")
    crest = xs[ramp(xs)[2] < 0]
    v_lift = np.sqrt(-G / ramp(crest)[2])
    ax_phase.fill_between(crest, v_lift, 6.0, color="0.85", hatch="//", edgecolor="0.6", lw=0,
                          label=r"$n = g + v^2 f'' < 0$: no contact")
    ax_phase.fill_between(crest, -6.0, -v_lift, color="0.85", hatch="//", edgecolor="0.6", lw=0)
    for k, (mu, x0, v0, how) in enumerate(CASES):
        t, x, v, w = trace(ds, k)
        look = series(k, len(CASES))
        line = look | dict(marker=None)
        name = rf"$\mu$ = {mu:g}, " + (f"from rest at x = {x0:g} m" if how == "released"
                                        else f"v0 = {v0:g} m/s at x = {x0:g} m")
        ax_phase.plot(x, v, **line, label=name)
        ax_path.plot(x, ramp(x)[0], **line | dict(linewidth=1.2), label=name)
        ax_work.plot(t, w, **line, label=name)
        turn = np.nonzero(v[1:-1] == 0.0)[0] + 1
        ax_phase.plot(x[turn], v[turn], look["marker"], color=look["color"], mfc="white", ms=6)
        ax_path.plot(x[turn], ramp(x[turn])[0], look["marker"], color=look["color"], mfc="white",
                     ms=6)
        status = int(ds["status"][k])
        if status == 1:
            ax_phase.plot(x[-1], 0.0, "X", color="k", ms=9, zorder=5)
            ax_path.plot(x[-1], ramp(x[-1])[0], "X", color="k", ms=9, zorder=5)
            ax_work.plot(t[-1], w[-1], "X", color="k", ms=9, zorder=5)
        if status == 3:  # free flight: x = xL + v t, y = yL + v f' t - g t^2/2
            f_l, fp_l, _ = ramp(x[-1])
            tau = np.linspace(0, (DOMAIN[1] + 0.15 - x[-1]) / v[-1], 50)
            ax_path.plot(x[-1] + v[-1] * tau, f_l + v[-1] * fp_l * tau - G * tau**2 / 2,
                         color="k", ls=(0, (1, 1)), lw=1.6, label="free flight after lift-off")
            ax_phase.plot(x[-1], v[-1], "^", color="k", ms=9, zorder=5)
            ax_path.plot(x[-1], f_l, "^", color="k", ms=9, zorder=5)
            ax_work.plot(t[-1], w[-1], "^", color="k", ms=9, zorder=5)
    ax_phase.axhline(0, color="0.4", lw=0.8)
    ax_path.set(xlabel="x (m)", ylabel="height y (m)", title="(a) Paths on the ramp",
                ylim=(-0.75, 1.05))
    ax_path.legend(loc="upper left", fontsize=8)
    ax_phase.set(xlabel="x (m)", ylabel="horizontal velocity v = dx/dt (m/s)",
                 title="(b) Phase portraits", ylim=(-4.2, 6.0))
    ax_phase.legend(loc="upper left", fontsize=8)
    ax_work.set(xlabel="time t (s)", ylabel=r"work against friction $W_f$ (J)",
                title="(c) Work against friction along the way")
    fig.suptitle("Open markers: reversals (v = 0); X: stuck (|f'| <= mu); black triangle: lift-off "
                 f"(n = 0), then free flight (dotted); m = {M:g} kg, RK4 dt = 1 ms")
    return fig


def main(argv=None) -> int:
    args = _study.parser(__doc__).parse_args(argv)
    started = time.perf_counter()
    every = _study.scale(args, 20, 5, 1)  # record a sample every this many steps (and every event)
    print(f"{STUDY}: {len(CASES)} recorded trajectories on a wavy ramp, a sample every {every} "
          "steps and at every event, RK4 dt = 1 ms")
    ds = run(every)
    lines = check(ds)
    print(f"  compile/load {ds.attrs['compile_time_s']:.1f} s, run {ds.attrs['run_time_s']:.2f} s, "
          f"recording {ds.attrs['trace_time_s']:.2f} s")
    print("\n".join(lines))
    _study.finish(STUDY, ds, figure(ds), args, started)
    return 0


if __name__ == "__main__":
    sys.exit(main())
