"""Excess friction work beyond mu m g |dx| against convexity, for three ramp families.

Every ramp runs from A = (0, 0) to B = (L, -H), bent by one convexity parameter
kappa (1/m; > 0 convex, < 0 concave, 0 the straight chord):

* quadratic     y = s x + kappa x^2/2 (s keeps it through B), f'' = kappa;
* circular arc  through A and B with radius 1/|kappa|: the lower arc of a circle
                (circular_bowl) for kappa > 0, the upper one (circular_dome) for
                kappa < 0; f'' >= |kappa| in size, largest near the ends;
* sine          y = -(H/L) x + a sin(pi x / L), a half wave with the same mean
                f'' = -2 pi a / L^2 = kappa as the parabola.

Each is swept over kappa, the friction coefficient mu and the start speed v0
(along +x).  The paper's eq. (14) says the excess W_f - mu m g |dx| =
mu m int(v^2 f'' dx) for motion without reversal: it has the sign of f'' when
f'' keeps one sign; the script checks that for every block that reaches B.
Heat maps for the parabola over (kappa, mu) and (kappa, v0); line plots of the
excess against the measured mean convexity for all three families.

    python studies/excess_work_map.py            # ~10 s with compiled kernels cached
    python studies/excess_work_map.py --full --gallery

Outputs (default folder studies/output/): excess_work_map.nc and
excess_work_map.png (and .pdf with --pdf).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import _study

STUDY = "excess_work_map"
H, L, M, G = 1.0, 2.0, 1.0, 9.81  # m, m, kg, m s-2
KAPPA_MAX = 0.3  # 1/m
MU_MAX = 0.3
V0_MAX = 2.0  # m/s
MU_REF, V0_REF = 0.2, 0.0  # the cut shown in the line plots and in (b)
FAMILIES = ("quadratic", "circular", "sine")
CHORD = np.hypot(L, H)


def arc_centre(kappa):
    """Centre of the circle of radius 1/|kappa| through A and B: above the chord
    for a convex (lower) arc, below it for a concave (upper) arc."""
    radius = 1 / np.abs(kappa)
    offset = np.sign(kappa) * np.sqrt(radius**2 - CHORD**2 / 4)
    normal = np.array([H, L]) / CHORD  # unit normal to the chord, pointing up
    return L / 2 + offset * normal[0], -H / 2 + offset * normal[1], radius


def run_family(family: str, kappa, mu, v0):
    import rampwork as rw

    base = dict(integrator=rw.Integrator("rk4", 1e-3), x0=0.0, m=M, g=G, t_max=30.0,
                title=f"Excess friction work against convexity from (0, 0) to ({L:g} m, {-H:g} m)")
    axes = dict(mu=mu, v0=v0)
    if family == "quadratic":
        scene = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=0.0, slope=-H / L,
                                             domain=(0.0, L)), **base)
        return _study.simulate_grid(scene, lambda p: dict(slope=-H / L - p["curvature"] * L / 2),
                                    curvature=kappa, **axes).rename(curvature="kappa")
    if family == "sine":
        scene = rw.Scene(ramp=rw.Ramp.create("sine", amplitude=0.0, wavenumber=np.pi / L,
                                             mean_slope=-H / L, domain=(0.0, L)), **base)
        return _study.simulate_grid(scene, None, amplitude=-kappa * L**2 / (2 * np.pi),
                                    **axes).rename(amplitude="kappa").assign_coords(kappa=kappa)
    parts = []  # circular arcs: a bowl for kappa > 0, a dome for kappa < 0
    for name, side in (("circular_dome", kappa < 0), ("circular_bowl", kappa > 0)):
        def centre(p, name=name):
            """Where the circle sits: the dome by its centre, the bowl by its bottom."""
            x, y, r = arc_centre(1 / p["radius"] * (1 if name == "circular_bowl" else -1))
            return dict(x_centre=x, **({"y_bottom": y - r} if name == "circular_bowl" else {"y_centre": y}))

        radius = 1 / abs(kappa[side][0])
        scene = rw.Scene(ramp=rw.Ramp.create(name, radius=radius, **centre({"radius": radius}),
                                             domain=(0.0, L)), **base)

        parts.append(_study.simulate_grid(scene, centre, radius=1 / np.abs(kappa[side]), **axes)
                     .rename(radius="kappa").assign_coords(kappa=kappa[side]))
    import xarray as xr

    ds = xr.concat(parts, "kappa", combine_attrs="override").reindex(kappa=kappa)
    for key in ("compile_time_s", "run_time_s"):
        ds.attrs[key] = sum(float(part.attrs[key]) for part in parts)
    ds.attrs["rampwork_scene_bowl"] = parts[1].attrs["rampwork_scene"]  # the dome's is the main one
    return ds


def run(n_kappa: int, n_mu: int, n_v0: int):
    import xarray as xr

    kappa = _study.even(-KAPPA_MAX, KAPPA_MAX, 2 * n_kappa)
    mu = _study.even(0, MU_MAX, n_mu)
    v0 = _study.even(0, V0_MAX, n_v0)
    runs = [run_family(f, kappa, mu, v0) for f in FAMILIES]
    ds = xr.concat([r.expand_dims(family=[f]) for r, f in zip(runs, FAMILIES)], "family",
                   combine_attrs="override")
    # no circle is straight: the arcs' kappa = 0 cells were not run
    ds["status"] = ds["status"].fillna(0).astype("int8").assign_attrs(runs[0]["status"].attrs)
    ds["kappa"].attrs.update(units="m-1", long_name="convexity parameter kappa",
                             comment="f'' of the parabola, 1/radius of the arc (signed), mean "
                                     "f'' of the sine half wave; > 0 convex")
    ds["reached_B"] = ((ds["status"] == 2) & (np.abs(ds["x_end"] - L) < 1e-9)).assign_attrs(
        long_name="the block slid all the way to B", units="1")
    for key in ("compile_time_s", "run_time_s"):
        ds.attrs[key] = sum(float(r.attrs[key]) for r in runs)
    for family, r in zip(FAMILIES[1:], runs[1:]):  # the quadratic's scene is the main one
        ds.attrs[f"rampwork_scene_{family}"] = r.attrs["rampwork_scene"]
        if "rampwork_scene_bowl" in r.attrs:
            ds.attrs[f"rampwork_scene_{family}_bowl"] = r.attrs["rampwork_scene_bowl"]
    _study.note_history(ds, STUDY, "three families' grids joined along family; reached_B added")
    return ds


def check(ds) -> dict:
    reached = ds["reached_B"] & (ds["mu"] > 0) & (ds["kappa"] != 0)
    excess = ds["W_excess"].where(reached)
    wrong = reached & (np.sign(excess) != np.sign(ds["kappa"]))
    if wrong.any():
        _study.fail(STUDY, f"{int(wrong.sum())} blocks that reach B have an excess whose sign is not "
                           "that of f''")
    cut = ds.sel(mu=MU_REF, v0=V0_REF, method="nearest")
    k = float(ds["kappa"].sel(kappa=0.2, method="nearest"))
    headline = {f: (float(cut["W_excess"].sel(family=f, kappa=k)),
                    float(cut["W_excess"].sel(family=f, kappa=-k))) for f in FAMILIES}
    return dict(checked=int(reached.sum()), total=int(ds["status"].size),
                stopped=int((~ds["reached_B"]).sum()), k=k, headline=headline,
                balance=float(np.abs(ds["energy_balance_error"]).max()),
                chord=float(np.abs(ds["W_excess"].sel(family="quadratic", kappa=0.0)).max()))


def figure(ds):
    from rampwork.plotting import heatmap, label, new_figure, series

    fig, axes = new_figure(2, 2, size=(12.5, 9.0))
    quad = ds.sel(family="quadratic")
    excess = quad["W_excess"].where(quad["reached_B"])
    kappa = ds["kappa"].values
    excess_label = r"excess work $W_f - \mu m g\,|\Delta x|$ (J)"
    relative = (100 * quad["W_excess"] / quad["W_linear"]).where(quad["reached_B"])
    ax = axes[0, 0]
    relative = relative.sel(v0=V0_REF, mu=ds["mu"] > 0).transpose("mu", "kappa")
    heatmap(ax, relative.values, kappa, relative["mu"].values, mask_label="stops before B",
            colorbar_label=r"excess relative to $\mu m g\,|\Delta x|$ (%)")
    ax.set(xlabel=r"curvature $f''$ = kappa (1/m)", ylabel=r"friction coefficient $\mu$",
           title="(a) Parabola, from rest: relative excess")
    ax = axes[0, 1]
    heatmap(ax, excess.sel(mu=MU_REF, method="nearest").transpose("v0", "kappa").values, kappa,
            ds["v0"].values, colorbar_label=excess_label, mask_label="stops before B")
    ax.set(xlabel=r"curvature $f''$ = kappa (1/m)", ylabel="start speed v0, along +x (m/s)",
           title=rf"(b) Parabola, $\mu$ = {MU_REF:g}: excess work")

    ax = axes[1, 0]
    for k, family in enumerate(FAMILIES):
        sel = ds.sel(family=family, mu=MU_REF, v0=V0_REF)
        ok = sel["reached_B"].values
        ax.plot(sel["convexity_mean"].values[ok], sel["W_excess"].values[ok],
                label={"circular": "circular arcs"}.get(family, family),
                markevery=max(1, ok.sum() // 12), **series(k, len(FAMILIES)))
    ax.set(title=rf"(c) Three families, $\mu$ = {MU_REF:g}, from rest")
    ax.legend(loc="upper left")

    ax = axes[1, 1]
    v0s = ds["v0"].values
    for k, v in enumerate(v0s):
        sel = ds.sel(family="circular", mu=MU_REF, v0=v)
        ok = sel["reached_B"].values
        ax.plot(sel["convexity_mean"].values[ok], sel["W_excess"].values[ok],
                label=f"v0 = {v:g} m/s", markevery=max(1, ok.sum() // 12), **series(k, len(v0s)))
    ax.set(title=rf"(d) Circular arcs, $\mu$ = {MU_REF:g}: faster blocks pay more")
    ax.legend(loc="upper left", ncols=2 if len(v0s) > 5 else 1)
    for ax in axes[1]:
        ax.axhline(0, color="0.4", lw=0.8)
        ax.axvline(0, color="0.4", lw=0.8)
        ax.set(xlabel=r"convexity: mean $f''$ along the path (1/m)", ylabel=excess_label)
    fig.suptitle(f"Friction work beyond the straight-ramp value from (0, 0) to ({L:g} m, {-H:g} m),"
                 f" m = {M:g} kg, RK4 dt = 1 ms: the excess has the sign of f''")
    return fig


def main(argv=None) -> int:
    args = _study.parser(__doc__).parse_args(argv)
    started = time.perf_counter()
    n_kappa, n_mu, n_v0 = _study.scale(args, (2, 3, 1), (12, 12, 4), (60, 60, 8))
    print(f"{STUDY}: 3 families x {2 * n_kappa + 1} kappa x {n_mu + 1} mu x {n_v0 + 1} v0, "
          "RK4 dt = 1 ms")
    ds = run(n_kappa, n_mu, n_v0)
    n = check(ds)
    print(f"  compile/load {ds.attrs['compile_time_s']:.1f} s, run {ds.attrs['run_time_s']:.2f} s")
    print(f"  straight chord: max |W_excess| = {n['chord']:.1e} J (paper eq. 1: zero); energy "
          f"balance error <= {n['balance']:.1e} J")
    print(f"  sign of W_excess = sign of f'' for all {n['checked']} blocks with mu > 0, kappa != 0 "
          f"that reach B ({n['stopped']} of {n['total']} stop before B or lift off)")
    print(f"  at mu = {MU_REF:g}, from rest, kappa = +/-{n['k']:g} 1/m (W_linear = "
          f"{MU_REF * M * G * L:.4f} J):")
    for family, (convex, concave) in n["headline"].items():
        print(f"    {family:<10} convex {convex:+.4f} J, concave {concave:+.4f} J")
    _study.finish(STUDY, ds, figure(ds), args, started)
    return 0


if __name__ == "__main__":
    sys.exit(main())
