"""Candidate evaluations per second of a shape optimisation (issue 21):
``ChordModes.evaluate`` (one batched kernel call per population) against a
loop that calls ``scipy.integrate.solve_ivp`` with events once per candidate
(``rampwork.reference.reference_trajectory``), in the same run, at EQUAL
accuracy: the error of the time to B against a tight reference (scipy DOP853,
rtol = atol = 1e-13) over the same candidates.

Each side runs a grid of tolerances (rampwork dopri5 and dop853; scipy RK45
and DOP853); each side's cheapest cost per candidate that reaches an error E
is read off its error-cost frontier (log-log interpolation between grid
points), and the ratio is taken at E = 1e-6, 1e-8 and 1e-10.  The rtol-paired
table of earlier runs (same rtol on both sides, errors not matched) is kept
beside it.  The batch: 1-thread CPU time (the headline: like for like with
the single-threaded scipy loop) and 2-thread wall time; its compile time
apart.  The quadrature row: ``ChordModes.evaluate(..., evaluator="quadrature")``
(core/descent_quadrature.py: the linear energy equation by panels of
spectral quadrature, the dopri5 kernel at the same rtol for the candidates it
cannot prove valid, in the same call), with its share of candidates by
quadrature and its points per candidate; and, for transparency, a loop of
``scipy.integrate.quad`` over the SAME formula per candidate (nested: E at
each outer point by an inner quad), so the gain of the formula and the gain of
the batch engine show apart.  A second row: ``descent_shapes.CuspCurve`` (the convex_cusp family on
the curve kernel), its error against an independent quadrature of the descent
time (no scipy loop exists for the curve form: its cost per candidate is set
beside the ChordModes loop's at the same error).

The population: S candidates of K = 6 sine modes on the chord from
A = (0, 1 m) to B = (2 m, 0), mu = 0.2, drawn as a first generation of
differential evolution would be (uniform in 0.3 x the shape's bounds, those
that arrive kept).

    python benchmarks/shape_evaluations.py                 # ~2 min
    python benchmarks/shape_evaluations.py --n 64 --scipy-n 2 --repeat 1 --out /tmp/x   # quick

Prints tables and saves results/shape_evaluations-<timestamp>.json.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

import _common

MU = 0.2
K = 6
START, END = (0.0, 1.0), (2.0, 0.0)
#: the cusp row: B relative to A (the curve starts at (0, 0)), its K
CUSP_END, CUSP_K = (2.0, -1.0), 6
G = 9.81
#: (label, rampwork dopri5 rtol, scipy solve_ivp method, rtol): the rtol-paired table
PAIRS = (("rtol 1e-6", 1e-6, "RK45", 1e-6), ("rtol 1e-8", 1e-8, "DOP853", 1e-8),
         ("rtol 1e-10", 1e-10, "DOP853", 1e-10))
#: the errors of t_end at which the two sides' costs are compared
MATCHED_ERRORS = (1e-6, 1e-8, 1e-10)
HALF_DECADES = tuple(10.0 ** (-e / 2) for e in range(8, 23))  # 1e-4 .. 1e-11
GRIDS = {"batch": {"dopri5": HALF_DECADES[2:], "dop853": HALF_DECADES[4:]},
         "scipy": {"RK45": HALF_DECADES[:10], "DOP853": HALF_DECADES[4:]},
         "quadrature": HALF_DECADES[2:], "scipy_quad": (1e-6, 1e-8, 1e-10)}
QUICK_GRIDS = {"batch": {"dopri5": (1e-6, 1e-8, 1e-10)}, "scipy": {"RK45": (1e-6,), "DOP853": (1e-8, 1e-10)},
               "quadrature": (1e-6, 1e-8, 1e-10), "scipy_quad": (1e-6, 1e-10)}


def population(shape, scene, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    bounds = np.array(shape.bounds)
    rows = []
    while sum(len(r) for r in rows) < n:
        draw = rng.uniform(bounds[:, 0], bounds[:, 1], (4 * n, bounds.shape[0])) * 0.3
        arrived = shape.evaluate(draw, scene)["arrived"].values
        rows.append(draw[arrived])
    return np.vstack(rows)[:n]


def scipy_loop(shape, scene, table, method: str, rtol: float):
    from rampwork.reference import reference_trajectory

    return np.array([reference_trajectory(scene, ramp=shape.ramp(row[None, :]), x0=START[0], method=method,
                                          rtol=rtol, atol=rtol)["t_end"] for row in table])


def quad_descent_time(shape, row, rtol):
    """The time to B of ``shape``'s candidate ``row`` from rest by
    ``scipy.integrate.quad`` of the formula core/descent_quadrature.py uses
    (xi = L sigma^2 from A; E(xi) by an inner quad at each outer point)."""
    from scipy.integrate import quad

    length = abs(END[0] - START[0])
    chord = (END[1] - START[1]) / (END[0] - START[0])
    w = math.pi / length
    modes = [(j * w, c * j * w) for j, c in enumerate(row.tolist(), start=1)]

    def slope(x):  # f' in closed form (START[0] = 0 is the domain's low end)
        return chord + sum(a * math.cos(k * x) for k, a in modes)

    slope_a = slope(START[0])
    atan_a = math.atan(slope_a)

    def grow(fp):
        return math.exp(2 * MU * (math.atan(fp) - atan_a))

    def energy_integrand(sigma):
        fp = slope(START[0] + length * sigma * sigma)
        return -G * (fp + MU) * grow(fp) * 2 * length * sigma

    def time_integrand(sigma):
        if sigma == 0.0:
            return math.sqrt(1 + slope_a**2) * 2 * math.sqrt(length / (2 * -G * (slope_a + MU)))
        fp = slope(START[0] + length * sigma * sigma)
        energy = quad(energy_integrand, 0.0, sigma, epsabs=0.0, epsrel=rtol, limit=200)[0] / grow(fp)
        return math.sqrt(1 + fp * fp) * 2 * length * sigma / math.sqrt(2 * energy)

    return quad(time_integrand, 0.0, 1.0, epsabs=0.0, epsrel=rtol, limit=200)[0]


def cusp_descent_time(c, angle, mu, n=96):
    """The cusp's descent time by nested Gauss-Legendre quadrature of the
    linear energy equation dw/dphi = -g rho (sin phi + mu cos phi) - 2 mu w
    (independent of the engine; the same as tests/test_cusp_curve.py's)."""
    from numpy.polynomial import chebyshev

    x, weights = np.polynomial.legendre.leggauss(n)
    span = angle + 0.5 * math.pi
    tau, wt = (x + 1) / 2, weights / 2
    theta = span * tau

    def rho_over_theta(th):
        return np.sinc(th / math.pi) * np.exp(chebyshev.chebval(2 * th / span - 1, c))

    inner = theta[:, None] * tau[None, :]
    phi = inner - 0.5 * math.pi
    zeta = (-G * tau * rho_over_theta(inner) * np.exp(2 * mu * inner)
            * (np.sin(phi) + mu * np.cos(phi))) @ wt
    return float((span * rho_over_theta(theta) / np.sqrt(2 * zeta * np.exp(-2 * mu * theta))) @ wt)


def frontier(points):
    """The (error, cost) points no other point beats on both, cheapest first."""
    front = []
    for error, cost in sorted(points, key=lambda p: p[1]):
        if error > 0 and (not front or error < front[-1][0]):
            front.append((error, cost))
    return front


def cost_at(front, error):
    """The cost of reaching ``error``: log-log interpolation along the
    frontier; the cheapest point's cost where it is more accurate already;
    None beyond the frontier's most accurate point."""
    if not front or error < front[-1][0]:
        return None
    if error >= front[0][0]:
        return front[0][1]
    for (e0, c0), (e1, c1) in zip(front, front[1:]):
        if e1 <= error <= e0:
            w = math.log(e0 / error) / math.log(e0 / e1)
            return math.exp((1 - w) * math.log(c0) + w * math.log(c1))
    return None


def timed(call, clock):
    t = clock()
    result = call()
    return result, clock() - t


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=2048, help="candidates per batch call (default 2048)")
    parser.add_argument("--scipy-n", type=int, default=24,
                        help="candidates the scipy loop and the error run (default 24)")
    parser.add_argument("--cusp-n", type=int, default=512,
                        help="CuspCurve candidates per call (default 512: its cost per candidate is flat in S)")
    parser.add_argument("--quad-n", type=int, default=6,
                        help="candidates the scipy.integrate.quad loop runs (default 6: ~0.1-1 s each)")
    parser.add_argument("--repeat", type=int, default=3, help="interleaved repeats (best of)")
    parser.add_argument("--quick", action="store_true", help="only the rtol-paired grid points")
    parser.add_argument("--out", type=Path, default=_common.RESULTS_DIR)
    args = parser.parse_args(argv)

    import rampwork as rw
    from rampwork.curve_scene import CurveScene
    from rampwork.curves import Curve
    from rampwork.descent_shapes import CuspCurve
    from rampwork.reference import reference_trajectory

    grids = QUICK_GRIDS if args.quick else GRIDS
    shape = rw.ChordModes(start=START, end=END, k=K)
    base = shape.scene(friction=rw.Friction(mu_k=MU))
    table = population(shape, base, args.n, seed=0)
    subset = table[:args.scipy_n]
    cusp = CuspCurve(end=CUSP_END, k=CUSP_K)

    def cusp_scene(method, rtol):
        return CurveScene(curve=Curve.create("brachistochrone", radius=1.0), g=G, friction=rw.Friction(mu_k=MU),
                          t_max=20.0, integrator=rw.Integrator(method=method, rtol=rtol, atol=rtol))

    cusp_table = population(cusp, cusp_scene("dopri5", 1e-8), args.cusp_n, seed=1)
    print(f"shape evaluations: {len(table)} candidates per call (K = {K}, mu = {MU}), scipy loop and errors on "
          f"{len(subset)} (CuspCurve: {len(cusp_table)} per call); batch 1-thread CPU time and 2-thread wall, "
          f"scipy CPU time, best of {args.repeat}")
    truth = np.array([reference_trajectory(base, ramp=shape.ramp(row[None, :]), x0=START[0], rtol=1e-13,
                                           atol=1e-13)["t_end"] for row in subset])
    shapes = cusp.curves(cusp_table[:args.scipy_n])
    cusp_truth = np.array([cusp_descent_time(c, a, MU) for c, a in zip(shapes["coefficients"], shapes["end_angle"])])

    def error_of(t_end, reference):
        return float(np.max(np.abs(t_end[:len(reference)] - reference) / reference))

    batch, scipy_side, cusp_side, quad_side, scipy_quad = {}, {}, {}, {}, {}
    for rtol in grids["quadrature"]:
        scene = base.replace(integrator=rw.Integrator("dopri5", rtol=rtol))
        first = shape.evaluate(table, scene, threads=1, evaluator="quadrature")
        quad_side[rtol] = dict(compile_s=float(first.attrs["compile_time_s"]), cpu=[], wall2=[],
                               error=error_of(first["t_end"].values, truth),
                               share=float(first.attrs["quadrature_share"]),
                               points=float(first.attrs["quadrature_nodes_mean"]))
    quad_subset = subset[:args.quad_n]
    for rtol in grids["scipy_quad"]:
        started = time.process_time()
        values = np.array([quad_descent_time(shape, row, rtol) for row in quad_subset])
        scipy_quad[rtol] = dict(cpu_per_candidate_s=(time.process_time() - started) / len(quad_subset),
                                error=error_of(values, truth[:len(quad_subset)]))
    for method, rtols in grids["batch"].items():
        for rtol in rtols:
            scene = base.replace(integrator=rw.Integrator(method, rtol=rtol))
            first = shape.evaluate(table, scene, threads=1)
            batch[method, rtol] = dict(compile_s=float(first.attrs["compile_time_s"]), cpu=[], wall2=[],
                                       error=error_of(first["t_end"].values, truth))
            cscene = cusp_scene(method, rtol)
            first = cusp.evaluate(cusp_table, cscene, threads=1)
            cusp_side[method, rtol] = dict(cpu=[], wall2=[], error=error_of(first["t_end"].values, cusp_truth),
                                           steps=float(first["steps"].values.mean()))
    for method, rtols in grids["scipy"].items():
        for rtol in rtols:
            scipy_side[method, rtol] = dict(cpu=[], error=error_of(scipy_loop(shape, base, subset, method, rtol),
                                                                   truth))
    for _ in range(args.repeat):  # the sides interleaved, repeat by repeat
        for (method, rtol), entry in batch.items():
            scene = base.replace(integrator=rw.Integrator(method, rtol=rtol))
            entry["cpu"].append(timed(lambda: shape.evaluate(table, scene, threads=1), time.process_time)[1])
            entry["wall2"].append(timed(lambda: shape.evaluate(table, scene, threads=2), time.perf_counter)[1])
            cscene = cusp_scene(method, rtol)
            cusp_side[method, rtol]["cpu"].append(
                timed(lambda: cusp.evaluate(cusp_table, cscene, threads=1), time.process_time)[1])
            cusp_side[method, rtol]["wall2"].append(
                timed(lambda: cusp.evaluate(cusp_table, cscene, threads=2), time.perf_counter)[1])
        for rtol, entry in quad_side.items():
            scene = base.replace(integrator=rw.Integrator("dopri5", rtol=rtol))
            entry["cpu"].append(timed(lambda: shape.evaluate(table, scene, threads=1, evaluator="quadrature"),
                                      time.process_time)[1])
            entry["wall2"].append(timed(lambda: shape.evaluate(table, scene, threads=2, evaluator="quadrature"),
                                        time.perf_counter)[1])
        for (method, rtol), entry in scipy_side.items():
            entry["cpu"].append(timed(lambda: scipy_loop(shape, base, subset, method, rtol), time.process_time)[1])
    for entries, n in ((batch, len(table)), (cusp_side, len(cusp_table)), (scipy_side, len(subset)),
                       (quad_side, len(table))):
        for entry in entries.values():
            entry["cpu_per_candidate_s"] = min(entry.pop("cpu")) / n
            if "wall2" in entry:
                entry["wall2_per_candidate_s"] = min(entry.pop("wall2")) / n

    paired = {}
    for label, rtol, method, scipy_rtol in PAIRS:
        if ("dopri5", rtol) in batch and (method, scipy_rtol) in scipy_side:
            b, s = batch["dopri5", rtol], scipy_side[method, scipy_rtol]
            paired[label] = dict(rampwork_rtol=rtol, scipy_method=method, scipy_rtol=scipy_rtol,
                                 batch_per_s=1 / b["cpu_per_candidate_s"], scipy_per_s=1 / s["cpu_per_candidate_s"],
                                 ratio=s["cpu_per_candidate_s"] / b["cpu_per_candidate_s"],
                                 batch_t_end_error=b["error"], scipy_t_end_error=s["error"],
                                 compile_s=b["compile_s"])
    print("\nrtol-paired (errors not matched), 1-thread CPU time:")
    for label, r in paired.items():
        print(f"  {label:<10}: batch {r['batch_per_s']:9.0f}/s (error {r['batch_t_end_error']:.1e}), scipy "
              f"{r['scipy_method']} {r['scipy_per_s']:7.1f}/s ({r['scipy_t_end_error']:.1e}): {r['ratio']:6.0f}x")

    def front_of(entries, key):
        return frontier([(e["error"], e[key]) for e in entries.values()])

    fronts = {"batch_cpu": front_of(batch, "cpu_per_candidate_s"),
              "batch_wall2": front_of(batch, "wall2_per_candidate_s"),
              "cusp_cpu": front_of(cusp_side, "cpu_per_candidate_s"),
              "cusp_wall2": front_of(cusp_side, "wall2_per_candidate_s"),
              "quadrature_cpu": front_of(quad_side, "cpu_per_candidate_s"),
              "quadrature_wall2": front_of(quad_side, "wall2_per_candidate_s"),
              "scipy_quad_cpu": front_of(scipy_quad, "cpu_per_candidate_s"),
              "scipy_cpu": front_of(scipy_side, "cpu_per_candidate_s")}
    matched = {}
    print("\nat equal error of t_end (each side's cheapest tolerance, log-log interpolated): us per candidate")
    for error in MATCHED_ERRORS:
        costs = {name: cost_at(front, error) for name, front in fronts.items()}
        s = costs["scipy_cpu"]
        row = dict(costs, **{f"ratio_{name}": (s / c if s and c else None)
                             for name, c in costs.items() if name != "scipy_cpu"})
        matched[f"{error:.0e}"] = row

        def us(value):
            return "-" if value is None else f"{value * 1e6:8.1f}"

        def x(value):
            return "-" if value is None else f"{value:6.0f}x"

        print(f"  error {error:.0e}: scipy {us(s)}; ChordModes 1 thread {us(costs['batch_cpu'])} "
              f"({x(row['ratio_batch_cpu'])}), 2 threads wall {us(costs['batch_wall2'])} "
              f"({x(row['ratio_batch_wall2'])}); CuspCurve 1 thread {us(costs['cusp_cpu'])} "
              f"({x(row['ratio_cusp_cpu'])}), 2 threads {us(costs['cusp_wall2'])}")
        print(f"               quadrature 1 thread {us(costs['quadrature_cpu'])} "
              f"({x(row['ratio_quadrature_cpu'])}), 2 threads wall {us(costs['quadrature_wall2'])} "
              f"({x(row['ratio_quadrature_wall2'])}); scipy.integrate.quad of the same formula "
              f"{us(costs['scipy_quad_cpu'])} ({x(row['ratio_scipy_quad_cpu'])})")

    def listing(entries):
        return {f"{method} {rtol:.1e}": entry for (method, rtol), entry in entries.items()}

    print("\nquadrature evaluator by rtol: error of t_end, us per candidate (1 thread), share by quadrature, "
          "points per candidate, compile s")
    for rtol, entry in quad_side.items():
        print(f"  rtol {rtol:.1e}: error {entry['error']:.1e}, {entry['cpu_per_candidate_s'] * 1e6:7.2f} us, "
              f"share {entry['share']:.3f}, {entry['points']:.0f} points, compile {entry['compile_s']:.2f} s")
    for rtol, entry in scipy_quad.items():
        print(f"  scipy.integrate.quad, epsrel {rtol:.1e}: error {entry['error']:.1e}, "
              f"{entry['cpu_per_candidate_s'] * 1e6:9.0f} us per candidate ({len(quad_subset)} candidates)")

    path = args.out / f"shape_evaluations-{_common.timestamp()}.json"
    _common.save_json(path, dict(machine=_common.machine_info(), when=_common.utc_now(), n=len(table),
                                 scipy_n=len(subset), repeat=args.repeat, results=paired, matched=matched,
                                 batch=listing(batch), scipy=listing(scipy_side), cusp=listing(cusp_side),
                                 quadrature={f"{r:.1e}": e for r, e in quad_side.items()},
                                 scipy_quad={f"{r:.1e}": e for r, e in scipy_quad.items()},
                                 fronts=fronts))
    print(f"saved {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
