"""What drives the excess friction work on a bowl: mu, x0, v0 or the curvature?

A block (m = 1 kg) slides in a parabolic bowl y = c x^2 / 2 (family
``quadratic``, slope 0; its ``curvature`` parameter c = f'' is the bowl's
curvature, the same all along it) from x0 with horizontal velocity v0, swings
back and forth and comes to rest where static friction holds it (|c x| <= mu).
Variance-based (Sobol') sensitivity analysis of the excess work
W_excess = W_f - mu m g |x_end - x0| over

    mu in [0.05, 0.3],  x0 in [0.2, 1] m,  v0 in [-2, 2] m/s,  c in [0.2, 1] 1/m,

each uniform: first-order (S1, the share of the variance an axis causes alone),
total (ST, alone and with the others) and second-order (S2) indices, with 95 %
bootstrap confidence intervals (rampwork.sobol_indices: SALib's Saltelli
design and estimators; the design runs as one Sweep.cases).

Before it touches a trajectory, the script runs the Ishigami function through
the same code path (rampwork.sensitivity.sobol_indices_of) and refuses to go on
unless every estimate lies within its confidence interval + 0.01 of the
analytic index (S1 = 0.3139, 0.4424, 0; ST = 0.5576, 0.4424, 0.2437; S2[x1,
x3] = 0.2437) with intervals no wider than +/- 0.06.  A bowl is convex, so no
block lifts off (n = g + v^2 f'' > 0); the script counts only blocks that
come to rest in the bowl (status stuck) and fails otherwise.

The physics: a block that comes to rest has given all its mechanical energy
above the resting point to friction, W_f = E0 - m g c x_end^2 / 2 with
E0 = m g c x0^2 / 2 + m v0^2 (1 + c^2 x0^2) / 2, whatever mu (mu only sets
where it stops, |x_end| <= mu / c).  So W_f depends on v0, x0 and c and hardly
on mu (its total index for W_f is about 0.01: the figure's panel d).  The straight-ramp
estimate mu m g |x_end - x0| counts only the net displacement, and grows with
mu: the excess W_excess = W_f - mu m g |x_end - x0| is the energy dissipated
in the swings, and mu drives it through the estimate it subtracts.  v0 acts
alone through the kinetic energy; x0 and c act through the potential energy
m g c x0^2 / 2, a product: they interact (S2[x0, curvature] > 0, ST > S1).

The answer (--full, n = 16384: 163,840 trajectories per output, 95 % intervals):
no axis is negligible.  Alone, v0 drives most (S1 = 0.26 +/- 0.01), then x0
(0.19), curvature (0.17) and mu (0.14); a quarter of the variance (1 - sum S1
= 0.24) comes from interactions, so the total indices are close: x0 0.36,
v0 0.35, curvature 0.34 (+/- 0.01 each), mu 0.26.  The largest interaction is
x0 with curvature (S2 = 0.09 +/- 0.03), the potential energy's product.

    python studies/sensitivity_excess_work.py            # ~7 s with the kernel cached
    python studies/sensitivity_excess_work.py --full --gallery    # ~30 s, 2 GB (bootstrap)

Writes studies/output/sensitivity_excess_work.nc and .png (and the .pdf with --pdf).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import _study

STUDY = "sensitivity_excess_work"
M, G = 1.0, 9.81  # kg, m s-2
HALF_WIDTH = 2.5  # m: the bowl's domain [-HALF_WIDTH, HALF_WIDTH] (blocks reach |x| < 1.8 m)
RANGES = {"mu": (0.05, 0.3), "x0": (0.2, 1.0), "v0": (-2.0, 2.0), "curvature": (0.2, 1.0)}
SEED = 0
#: the Ishigami check: its base sample, and the tolerance beyond each confidence interval
ISHIGAMI_N, ISHIGAMI_SLACK, ISHIGAMI_WIDEST = 4096, 0.01, 0.06
#: W_f hardly depends on mu (its total index stays below this)
MU_WF_MAX = 0.05
#: W_f = E0 - m g y_end to this many J (RK4, dt = 1 ms)
ENERGY_TOL = 1e-8


def check_machinery():
    """The Ishigami function through the code path of every rampwork output;
    fails the study if an estimate misses its analytic value."""
    from rampwork import ishigami
    from rampwork.sensitivity import sobol_indices_of

    ds = sobol_indices_of(ishigami.ishigami, ishigami.RANGES, n=ISHIGAMI_N, seed=SEED,
                          second_order=True, name="ishigami")
    misses = ishigami.misses(ds, slack=ISHIGAMI_SLACK, widest=ISHIGAMI_WIDEST)
    if misses:
        _study.fail(STUDY, "the Sobol' machinery misses the Ishigami function's analytic indices "
                           "(not running rampwork): " + "; ".join(misses))
    return ds, ishigami.indices()


def scene():
    import rampwork as rw

    return rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=1.0, domain=(-HALF_WIDTH, HALF_WIDTH)),
                    integrator=rw.Integrator("rk4", 1e-3), x0=0.5, m=M, g=G, t_max=60.0,
                    title="A block in a parabolic bowl y = c x^2/2, from x0 with velocity v0")


def analyse(output: str, n: int, keep_runs: bool):
    import rampwork as rw
    from rampwork.sensitivity import SensitivityError

    try:
        return rw.sobol_indices(scene(), output, RANGES, n=n, seed=SEED, second_order=True,
                                accept=("stuck",), keep_runs=keep_runs)
    except SensitivityError as error:
        _study.fail(STUDY, f"not every block came to rest in the bowl: {error}")


def run(n: int):
    import xarray as xr

    check, exact = check_machinery()
    ds = analyse("W_excess", n, keep_runs=True)
    friction = analyse("W_friction", n, keep_runs=False)
    for key in ("S1", "S1_conf", "ST", "ST_conf", "S2", "S2_conf"):
        ds[f"W_friction_{key}"] = friction[key].assign_attrs(
            long_name=f"{friction[key].attrs['long_name']} of W_friction")
    renamed = check.rename(parameter="ishigami_input", parameter2="ishigami_input2").reset_coords(drop=True)
    for key in ("S1", "S1_conf", "ST", "ST_conf", "S2", "S2_conf"):
        ds[f"ishigami_{key}"] = renamed[key].assign_attrs(
            long_name=f"{check[key].attrs['long_name']} of the Ishigami function (a = 7, b = 0.1)")
    inputs = renamed["ishigami_input"].values
    for key in ("S1", "ST"):
        ds[f"ishigami_{key}_exact"] = xr.DataArray(exact[key], coords={"ishigami_input": inputs},
                                                   dims="ishigami_input",
                                                   attrs={"units": "1", "long_name": f"analytic {key}"})
    ds.attrs.update(ishigami_n=check.attrs["n"], ishigami_n_runs=check.attrs["n_runs"],
                    ishigami_check=f"passed: every estimate within its {check.attrs['conf_level']:.0%} "
                                   f"interval + {ISHIGAMI_SLACK} of the analytic index, intervals "
                                   f"<= +/- {ISHIGAMI_WIDEST}",
                    run_time_s=ds.attrs["run_time_s"] + friction.attrs["run_time_s"])
    _study.note_history(ds, STUDY, "Ishigami check and W_friction indices added")
    return ds


def energy_above_rest(ds):
    """E0 - m g y_end: the mechanical energy a block that comes to rest at
    x_end has lost, E0 = m g c x0^2/2 + m v0^2 (1 + (c x0)^2)/2 (v0 = dx/dt)."""
    c, x0, v0 = ds["curvature"], ds["x0"], ds["v0"]
    e0 = M * G * c * x0**2 / 2 + M * v0**2 * (1 + (c * x0) ** 2) / 2
    return e0 - M * G * c * ds["x_end"] ** 2 / 2


def check(ds) -> dict:
    """The study's claims; returns headline numbers."""
    # the energy argument of the explanation: every block gives friction all
    # its energy above the point where it rests, and static friction holds it there
    energy = float(np.abs(ds["W_friction"] - energy_above_rest(ds)).max())
    if energy > ENERGY_TOL:
        _study.fail(STUDY, f"W_f differs from E0 - m g y_end by up to {energy:.2e} J")
    held = np.abs(ds["curvature"] * ds["x_end"]) <= ds["mu"] + 1e-12
    if not bool(held.all()):
        _study.fail(STUDY, f"{int((~held).sum())} blocks rest where |f'| > mu")
    for prefix in ("", "W_friction_"):
        s1, st, conf = (ds[f"{prefix}{k}"].values for k in ("S1", "ST", "ST_conf"))
        if s1.sum() > 1 + ds[f"{prefix}S1_conf"].values.sum():
            _study.fail(STUDY, f"{prefix or 'W_excess '}S1 sums to {s1.sum():.3f} > 1")
        if np.any(st < s1 - conf - ds[f"{prefix}S1_conf"].values):
            _study.fail(STUDY, f"{prefix or 'W_excess '}ST < S1 beyond their intervals")
    mu_wf = float(ds["W_friction_ST"].sel(parameter="mu"))
    if mu_wf > MU_WF_MAX:
        _study.fail(STUDY, f"W_f depends on mu (ST = {mu_wf:.3f} > {MU_WF_MAX}); the energy "
                           "argument says it should hardly")
    return dict(mu_wf=mu_wf, energy=energy, ranking=[str(p) for p in ds["ST"].sortby(-ds["ST"])["parameter"].values])


def _ishigami_panel(ax, ds):
    from rampwork.sensitivity import bar_chart

    view = ds[[f"ishigami_{k}" for k in ("S1", "S1_conf", "ST", "ST_conf")]]
    view = view.rename({f"ishigami_{k}": k for k in ("S1", "S1_conf", "ST", "ST_conf")})
    view = view.rename(ishigami_input="parameter").assign_attrs(output="the Ishigami function",
                                                                conf_level=0.95)
    bar_chart(view, ax)
    x = np.arange(view.sizes["parameter"])
    for k, key in enumerate(("S1", "ST")):
        ax.plot(x + (k - 0.5) * 0.38, ds[f"ishigami_{key}_exact"].values, linestyle="none",
                marker="D", markersize=7, markerfacecolor="white", markeredgecolor="black",
                label="analytic" if k == 0 else None)
    ax.legend(loc="upper right")
    ax.set_title(f"(a) The check: Ishigami function, n = {ds.attrs['ishigami_n']} "
                 f"({ds.attrs['ishigami_n_runs']:,} runs)")


def _s2_panel(ax, ds):
    from rampwork.plotting import pyplot

    s2, conf = ds["S2"].values, ds["S2_conf"].values
    names = [str(p) for p in ds["parameter"].values]
    shown = np.ma.masked_invalid(s2)
    mesh = ax.imshow(shown, cmap=pyplot().get_cmap("cividis").with_extremes(bad="0.93"),
                     vmin=min(0.0, float(np.nanmin(s2))), vmax=max(0.15, float(np.nanmax(s2))))
    ax.figure.colorbar(mesh, ax=ax, label="second-order index $S_2$")
    for i in range(len(names)):
        for j in range(len(names)):
            if i != j:
                ink = "white" if s2[i, j] < 0.6 * mesh.norm.vmax else "black"
                ax.text(j, i, f"{s2[i, j]:.3f}\n± {conf[i, j]:.3f}", ha="center", va="center",
                        fontsize=8, color=ink)
    ax.set_xticks(range(len(names)), names)
    ax.set_yticks(range(len(names)), names)
    ax.grid(False)
    ax.set_title("(c) $W_{excess}$: interactions of two axes ($S_2$)")


def figure(ds):
    from rampwork.plotting import new_figure
    from rampwork.sensitivity import bar_chart

    fig, axes = new_figure(2, 2, size=(12.5, 9.0))
    _ishigami_panel(axes[0, 0], ds)
    bar_chart(ds, axes[0, 1], title=f"(b) What drives the excess work $W_{{excess}}$ "
                                    f"({ds.attrs['n_runs']:,} trajectories)")
    _s2_panel(axes[1, 0], ds)
    friction = ds[[f"W_friction_{k}" for k in ("S1", "S1_conf", "ST", "ST_conf")]]
    friction = friction.rename({f"W_friction_{k}": k for k in ("S1", "S1_conf", "ST", "ST_conf")})
    bar_chart(friction.assign_attrs(output="W_friction", conf_level=ds.attrs["conf_level"]),
              axes[1, 1], title="(d) ... and the friction work $W_f$: mu hardly matters")
    ranges = ", ".join(f"{a} in [{lo:g}, {hi:g}]" for a, (lo, hi) in RANGES.items())
    fig.suptitle(f"Sobol' indices on a parabolic bowl y = c x²/2 (c = curvature), each axis uniform: "
                 f"{ranges}\nm = {M:g} kg, RK4 dt = 1 ms; every block comes to rest in the bowl; "
                 f"error bars: {ds.attrs['conf_level']:.0%} bootstrap confidence intervals")
    return fig


def main(argv=None) -> int:
    args = _study.parser(__doc__).parse_args(argv)
    started = time.perf_counter()
    n = _study.scale(args, 64, 4096, 16384)
    print(f"{STUDY}: Ishigami check (n = {ISHIGAMI_N}), then W_excess and W_friction on a bowl, "
          f"n = {n} ({n * (2 * len(RANGES) + 2):,} trajectories each), RK4 dt = 1 ms")
    ds = run(n)
    for key in ("S1", "ST"):
        pairs = zip(ds[f"ishigami_{key}"].values, ds[f"ishigami_{key}_conf"].values,
                    ds[f"ishigami_{key}_exact"].values)
        print(f"  Ishigami {key}: " + ", ".join(f"{e:.4f} +/- {c:.4f} (analytic {x:.4f})"
                                                for e, c, x in pairs))
    headline = check(ds)
    print(f"  compile/load {ds.attrs['compile_time_s']:.1f} s, run {ds.attrs['run_time_s']:.2f} s "
          f"for 2 x {ds.attrs['n_runs']:,} trajectories ({ds.attrs['status_counts']})")
    for name in ds["parameter"].values:
        cell = ds.sel(parameter=name)
        print(f"  {name:>9}: W_excess S1 = {float(cell['S1']):.3f} +/- {float(cell['S1_conf']):.3f}, "
              f"ST = {float(cell['ST']):.3f} +/- {float(cell['ST_conf']):.3f};  W_f ST = "
              f"{float(cell['W_friction_ST']):.3f} +/- {float(cell['W_friction_ST_conf']):.3f}")
    print(f"  every block at rest with W_f = E0 - m g y_end to {headline['energy']:.1e} J; "
          f"W_excess ranked by ST: {', '.join(headline['ranking'])}")
    _study.finish(STUDY, ds, figure(ds), args, started)
    return 0


if __name__ == "__main__":
    sys.exit(main())
