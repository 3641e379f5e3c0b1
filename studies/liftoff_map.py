"""Where the block lifts off a dome: the contact-force criterion beside the paper's eq. (26).

A block is pushed uphill (along +x) from x0 on the upper half of a circle of
radius R centred at the origin (circular_dome, y = sqrt(R^2 - x^2)), with
friction mu = 0.8, and the run is mapped over the start speed v0 and the
curvature 1/R.  It may turn back and leave by the left end, stop on the top
(|f'| <= mu), slide over and leave by the right end, or lift off.

Two lift-off criteria:

* the contact force (the engine's test, status ``lifted_off``): the block leaves
  where the normal term n = g + v^2 f'' reaches 0;
* the paper's eq. (26): the block leaves where the ramp drops faster than free
  fall, y'' <= -g, which on the ramp is n (1 - d mu f') <= 0 (d = sign v).  It
  agrees with n <= 0 except where d mu f' > 1: climbing a slope steeper than
  1/mu, where it reports lift-off while the surface still pushes.

The paper's criterion is not a kernel diagnostic: this script evaluates it on
every trajectory's recorded states (scene option ``record``: every 10th step and
every event), and marks the region where the two criteria disagree.

    python studies/liftoff_map.py            # ~15 s with compiled kernels cached
    python studies/liftoff_map.py --full --gallery

Outputs (default folder studies/output/): liftoff_map.nc and liftoff_map.png
(and .pdf with --pdf).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import _study

STUDY = "liftoff_map"
M, G, MU = 1.0, 9.81, 0.8  # kg, m s-2, 1
X0 = -0.75  # m, start
HALF_WIDTH = 0.8  # m: the domain is [-HALF_WIDTH, HALF_WIDTH], inside every circle
CURVATURE = (0.4, 1.2)  # 1/m: 1/R, R from 2.5 m down to 0.83 m
V0_MAX = 5.0  # m/s
EVERY = 10  # record a sample every this many steps (and every event)

#: outcome categories of the map: (label, grey, hatch)
OUTCOMES = {0: ("no lift-off by either", "0.92", ""),
            1: ("both: lift-off at the same x", "0.55", ""),
            2: ("eq. (26) only: at the start, n > 0", "0.3", "//")}


def dome(x, radius):
    """f, f', f'' of the upper half circle of ``radius`` about the origin."""
    root = np.sqrt(radius**2 - x**2)
    return root, -x / root, -(radius**2) / root**3


def run(n_v0: int, n_curv: int):
    import rampwork as rw

    curvature = _study.even(*CURVATURE, n_curv)
    v0 = _study.even(V0_MAX / n_v0, V0_MAX, n_v0 - 1)
    size = len(curvature) * len(v0)
    scene = rw.Scene(
        ramp=rw.Ramp.create("circular_dome", radius=1 / CURVATURE[0],
                            domain=(-HALF_WIDTH, HALF_WIDTH)),
        friction=rw.Friction(mu_k=MU), integrator=rw.Integrator("rk4", 1e-3), x0=X0, m=M, g=G,
        t_max=10.0, record=rw.Record(indices=tuple(range(size)), every=EVERY, max_samples=1500),
        title=f"Lift-off from a dome, pushed uphill from x = {X0:g} m with mu = {MU:g}")
    ds = rw.simulate(scene, rw.Sweep.grid(radius=1 / curvature, v0=v0))
    ds = ds.assign_coords(curvature=("radius", curvature, {"units": "m-1", "long_name": "1/R"}))
    ds = ds.swap_dims(radius="curvature")
    paper = paper_lift_off(ds)
    ds["x_lift_off_paper"] = (("curvature", "v0"), paper.reshape(ds["status"].shape), {
        "units": "m", "long_name": "lift-off position by the paper's eq. (26)",
        "comment": "first recorded state with n (1 - sign(v) mu f') <= 0, i.e. y'' <= -g; "
                   f"evaluated by studies/{STUDY}.py on the recorded states (every {EVERY}th step "
                   "and every event), not by the kernel; NaN where it never fires"})
    ds["outcome"] = (("curvature", "v0"), outcome(ds), {
        "units": "1", "long_name": "agreement of the two lift-off criteria",
        "flag_values": np.array(list(OUTCOMES), dtype=np.int8),
        "flag_meanings": "no_lift_off same_place paper_only_at_start"})
    _study.note_history(ds, STUDY, "added x_lift_off_paper (eq. 26 on the recorded states), outcome")
    return ds


def paper_lift_off(ds) -> np.ndarray:
    """x where eq. (26) first fires on each recorded trajectory (NaN: never)."""
    flat_status = ds["status"].values.ravel()
    radius = np.broadcast_to(ds["radius"].values[:, None], ds["status"].shape).ravel()
    out = np.full(flat_status.size, np.nan)
    for k, j in enumerate(ds["traced_index"].values):
        n = int(ds["trace_length"][k])
        x, v = ds["trace_x"].values[k, :n], ds["trace_v"].values[k, :n]
        _, fp, fpp = dome(x, radius[j])
        normal = G + v**2 * fpp
        fires = (v != 0) & (normal * (1 - np.sign(v) * MU * fp) <= 0)
        if flat_status[j] == 3:  # the last state is where n = 0: eq. (26) fires there too
            fires[-1] = True
        hits = np.nonzero(fires)[0]
        if hits.size:
            out[j] = x[hits[0]]
    return out


def outcome(ds) -> np.ndarray:
    contact, paper = ds["x_lift_off"].values, ds["x_lift_off_paper"].values
    codes = np.zeros(contact.shape, dtype=np.int8)
    codes[np.isfinite(contact) & (np.abs(paper - contact) < 1e-12)] = 1
    codes[np.isfinite(paper) & ~(np.abs(paper - contact) < 1e-12)] = 2
    return codes


def boundaries(curvature):
    """Start speed where n(x0) = 0, and the curvature where mu f'(x0) = 1."""
    _, fp, fpp = dome(X0, 1 / curvature)
    r_equal = np.sqrt(X0**2 + (MU * X0) ** 2)  # f'(x0) = -x0 / sqrt(R^2 - x0^2) = 1/mu
    return np.sqrt(G / -fpp), 1 / r_equal


def check(ds) -> dict:
    """The disagreement region is where eq. (26) predicts it: mu f'(x0) > 1 and n(x0) > 0."""
    curvature = ds["curvature"].values[:, None]
    v0 = ds["v0"].values[None, :]
    _, fp, fpp = dome(X0, 1 / curvature)
    expected = (MU * fp > 1) & (G + v0**2 * fpp > 0)
    codes = ds["outcome"].values
    if not np.array_equal(codes == 2, expected):
        _study.fail(STUDY, f"{int(np.sum((codes == 2) != expected))} cells disagree with the "
                           "predicted region mu f'(x0) > 1, n(x0) > 0")
    contact = np.isfinite(ds["x_lift_off"].values)
    names = {code: name for code, name in ((1, "stuck"), (2, "exited"), (3, "lifted_off"))}
    counts = {names.get(int(c), str(c)): int((ds["status"].values == c).sum())
              for c in np.unique(ds["status"].values)}
    return dict(cells=codes.size, contact=int(contact.sum()), paper=int(np.isfinite(
        ds["x_lift_off_paper"].values).sum()), disagree=int((codes == 2).sum()), counts=counts,
        at_start=int((contact & (np.abs(ds["x_lift_off"].values - X0) < 1e-12)).sum()),
        curvature_equal=boundaries(np.array([1.0]))[1],
        force=float(start_normal_force(ds).where(ds["outcome"] == 2).max()))


def start_normal_force(ds):
    """N = m n / sqrt(1 + f'^2) at the start, N."""
    _, fp, fpp = dome(X0, 1 / ds["curvature"])
    return M * (G + ds["v0"] ** 2 * fpp) / np.sqrt(1 + fp**2)


def figure(ds):
    from rampwork.plotting import category_map, heatmap, new_figure, status_map

    fig, axes = new_figure(1, 3, size=(17.0, 5.4))
    v0, curvature = ds["v0"].values, ds["curvature"].values
    v_start, k_equal = boundaries(curvature)
    status_map(axes[0, 0], ds["status"].transpose("v0", "curvature").values, curvature, v0)
    axes[0, 0].set_title("(a) End status (contact-force criterion n = 0)")
    legend = category_map(axes[0, 1], ds["outcome"].transpose("v0", "curvature").values,
                          curvature, v0, OUTCOMES)
    axes[0, 1].set_title("(b) Contact force against the paper's eq. (26)")
    force = start_normal_force(ds).where(ds["outcome"] == 2)
    heatmap(axes[0, 2], force.transpose("v0", "curvature").values, curvature, v0,
            colorbar_label="normal force at the start (N)")
    axes[0, 2].set_title("(c) Where eq. (26) says 'lifted off':\nthe surface still pushes")
    for ax in axes[0]:
        ax.plot(curvature, v_start, color="k", lw=1.4, ls="--")
        ax.axvline(k_equal, color="k", lw=1.4, ls=":")
        ax.set(xlabel="dome curvature 1/R (1/m)", ylabel="start speed v0, uphill (m/s)",
               ylim=(v0[0] - (v0[1] - v0[0]) / 2, v0[-1] + (v0[1] - v0[0]) / 2))
    from matplotlib.lines import Line2D

    handles = list(legend.legend_handles) + [
        Line2D([], [], color="k", lw=1.4, ls="--", label="n(x0) = 0: lift-off at the start"),
        Line2D([], [], color="k", lw=1.4, ls=":", label=r"$\mu f'(x_0) = 1$")]
    legend.remove()
    axes[0, 1].legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.16),
                      frameon=False, ncols=2, fontsize=8)
    fig.suptitle(f"Block pushed uphill from x0 = {X0:g} m on a dome y = sqrt(R² - x²), mu = {MU:g}, "
                 "RK4 dt = 1 ms.\nEq. (26) is evaluated by this script on the recorded states "
                 f"(every {EVERY}th step and every event); it is not a kernel diagnostic")
    return fig


def main(argv=None) -> int:
    args = _study.parser(__doc__).parse_args(argv)
    started = time.perf_counter()
    n_v0, n_curv = _study.scale(args, (8, 5), (40, 40), (96, 96))
    print(f"{STUDY}: {n_curv + 1} curvatures in [{CURVATURE[0]:g}, {CURVATURE[1]:g}] 1/m x {n_v0} "
          f"start speeds in (0, {V0_MAX:g}] m/s, all recorded, mu = {MU:g}, RK4 dt = 1 ms")
    ds = run(n_v0, n_curv)
    n = check(ds)
    print(f"  compile/load {ds.attrs['compile_time_s']:.1f} s, run {ds.attrs['run_time_s']:.2f} s, "
          f"recording {ds.attrs['trace_time_s']:.2f} s")
    print(f"  end status: {n['counts']}")
    print(f"  contact criterion: {n['contact']} of {n['cells']} lift off ({n['at_start']} at the "
          f"start); eq. (26): {n['paper']}")
    print(f"  they disagree in {n['disagree']} cells ({100 * n['disagree'] / n['cells']:.0f} %), "
          f"exactly where mu f'(x0) > 1 (1/R > {n['curvature_equal']:.4f} 1/m) and n(x0) > 0: "
          "eq. (26) reports lift-off at the start while the surface still pushes "
          f"(with up to {n['force']:.2f} N on the {M:g} kg block)")
    _study.finish(STUDY, ds, figure(ds), args, started)
    return 0


if __name__ == "__main__":
    sys.exit(main())
