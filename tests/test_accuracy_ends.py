"""Issue 19, item 4: the adaptive pairs at both ends of the accuracy range, on
throughput.py's bowl (y = x^2 / 2 on (-1, 1), g = 9.81) and starts of its
27^3 grid (benchmarks/accuracy_ends.py measures the whole grid).

Expected values: rampwork.reference (scipy DOP853 with events at rtol
2.5e-14, atol 1e-16; its W within 1.3e-14 relative of a long-double Taylor
integration (heyoka) on the 600 of accuracy_cost.py's 20,000 peers starts where
it was worst or drawn at random), the energy balance of a block at rest,
W_f = E0 - g f(x_end), which does not use the integrated work, and the bowl's
closed form along a segment without reversal (closed_form_exit_work).
"""

from __future__ import annotations

import pytest

import rampwork as rw
from rampwork.core.status import EXITED, STUCK

G = 9.81
RAMP = rw.Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0))
GRID_X0 = [-0.95 + k * 1.9 / 26 for k in range(27)]
GRID_V0 = [-7.0 + k * 14.0 / 26 for k in range(27)]
GRID_MU = [0.02 + k * 0.48 / 26 for k in range(27)]
PAIRS = ("dopri5", "dop853")

#: trajectories that end within their first steps, with small W (issue 19's
#: tight-end worst cases): until the step to the event (adaptive.py
#: _step_to_event) x, v and W at the event came from the dense output, whose
#: error is of the tolerance's size, not the step's: W errors 60-300 times
#: the median at rtol 1e-12
SHORT = {
    "exit after 3-9 steps, W = 0.012 J/kg": (GRID_X0[0], GRID_V0[10], GRID_MU[0], EXITED),
    "stuck after 4-27 steps, W = 0.099 J/kg": (GRID_X0[17], GRID_V0[14], GRID_MU[26], STUCK),
    "stuck after 4-27 steps, W = 0.084 J/kg": (GRID_X0[18], GRID_V0[14], GRID_MU[20], STUCK),
}
#: issue 19's target: max W error within 10x the median, the median at rtol
#: 1e-12 being 1e-13 (dop853) to 3e-13 (dopri5) on the grid
TIGHT_W_ERROR = {1e-12: 3e-12, 1e-13: 5e-13}


def simulate_one(method, rtol, x0, v0, mu, atol=None):
    scene = rw.Scene(ramp=RAMP, friction=rw.Friction(mu), x0=x0, v0=v0, t_max=60.0, g=G,
                     integrator=rw.Integrator(method, rtol=rtol, atol=rtol if atol is None else atol,
                                              closed_form=False))
    ds = rw.simulate(scene)
    return scene, {k: ds[k].values.item() for k in ("status", "x_end", "W_friction", "steps")}


def rest_work(x0, v0, x_end):
    """W_f of a block (unit mass) from (x0, v0) to rest at x_end on y = x^2 / 2."""
    return G * x0**2 / 2 + v0**2 * (1 + x0**2) / 2 - G * x_end**2 / 2


@pytest.mark.parametrize("rtol", sorted(TIGHT_W_ERROR))
@pytest.mark.parametrize("method", PAIRS)
@pytest.mark.parametrize("name", list(SHORT))
def test_tight_end_short_trajectories_keep_the_relative_W_error(name, method, rtol, reference):
    x0, v0, mu, status = SHORT[name]
    scene, got = simulate_one(method, rtol, x0, v0, mu)
    ref = reference.reference_trajectory(scene, rtol=2.5e-14, atol=1e-16)
    assert ref["status"] == status and got["status"] == status, (got, ref["status"])
    error = abs(got["W_friction"] - ref["W_friction"]) / ref["W_friction"]
    assert error <= TIGHT_W_ERROR[rtol], (name, got, ref["W_friction"], error)
    if status == STUCK:  # and the energy balance, with the run's own x_end
        balance = rest_work(x0, v0, got["x_end"])
        assert abs(got["W_friction"] - balance) <= TIGHT_W_ERROR[rtol] * balance


#: loose tolerances on small mu: swings of a second and steps as long as half
#: of one.  Until the swing bound (adaptive.py) dopri5 at 1e-3 accepted steps
#: of h omega = 1.2 whose error estimate was 28 times too small (W 26 % above
#: the energy balance on the first case); the second is the grid's grazing
#: start (the block turns 44 um before the domain's end: reference stuck,
#: dopri5 exited at 1e-3 and 1e-4 until the swing bound; a margin this thin
#: is below a 1e-3 tolerance, so this case is a canary, not a guarantee);
#: the third issue 19's own (rtol 1e-3, atol 1e-6).
LOOSE = {
    "swings to rest": (GRID_X0[0], GRID_V0[12], GRID_MU[0]),
    "grazing turn 44 um before the end": (GRID_X0[0], GRID_V0[15], GRID_MU[0]),
    "issue 19's grazing start": (-0.6577, 2.154, 0.02),
}
LOOSE_SETTINGS = [(1e-3, 1e-3), (1e-4, 1e-4), (1e-3, 1e-6)]


def loose_params():
    for name in LOOSE:
        for method in PAIRS:
            for rtol, atol in LOOSE_SETTINGS:
                yield pytest.param(name, method, rtol, atol)


@pytest.mark.parametrize("name, method, rtol, atol", list(loose_params()))
def test_loose_end_comes_to_rest_with_the_energy_balance(name, method, rtol, atol, reference):
    x0, v0, mu = LOOSE[name]
    scene, got = simulate_one(method, rtol, x0, v0, mu, atol)
    ref = reference.reference_trajectory(scene, rtol=2.5e-14, atol=1e-16)
    assert ref["status"] == STUCK
    assert got["status"] == STUCK, (got, ref)
    assert abs(got["x_end"]) <= mu + 1e-12
    balance = rest_work(x0, v0, got["x_end"])
    assert got["W_friction"] == pytest.approx(balance, rel=1e-2), got
    assert got["W_friction"] == pytest.approx(ref["W_friction"], rel=1e-2), (got, ref["W_friction"])


#: exits without a reversal on the bowl (starts of accuracy_cost.py's peers
#: benchmark): until rampwork.reference stepped to its events, its W there came
#: from scipy's dense output at the exit, 5e-13 to 8e-13 relative off (the
#: largest errors of that reference on the benchmark's 20,000 starts, measured
#: against a long-double Taylor integration with heyoka), as large as the
#: errors it was used to measure at rtol 1e-13
EXITS = {
    "x0 = 0.91 -> 1": (0.9116161616161615, 5.8686868686868685, 0.1896969696969697),
    "x0 = -0.93 -> -1": (-0.9308080808080808, -6.717171717171717, 0.1703030303030303),
    "x0 = -0.83 -> -1": (-0.8348484848484848, -7.0, 0.20424242424242423),
}
GAUSS_NODES = 80


def closed_form_exit_work(x0, v0, mu):
    """W (J/kg) of a block that slides from (x0, v0) on y = x^2 / 2 off the
    domain's end without reversing.  Along a segment of direction d,
    d(v^2)/dx = 2 a = -2 n (x + d mu) / (1 + x^2) and n = g + v^2, so
    n(x) = (g + v0^2) (1 + x0^2) / (1 + x^2) exp(-2 d mu (atan x - atan x0))
    and W = mu |integral of n dx| (Gauss-Legendre: n is smooth, the sum exact
    to rounding)."""
    import numpy as np

    d = 1.0 if v0 > 0 else -1.0
    end = RAMP.domain[1] if d > 0 else RAMP.domain[0]
    nodes, weights = np.polynomial.legendre.leggauss(GAUSS_NODES)
    x = 0.5 * (end - x0) * nodes + 0.5 * (end + x0)
    n = (G + v0 * v0) * (1 + x0 * x0) / (1 + x * x) * np.exp(-2 * d * mu * (np.arctan(x) - np.arctan(x0)))
    assert n.min() > G  # v^2 = n - g > 0 all the way: no reversal before the end
    return mu * abs(0.5 * (end - x0) * float(np.dot(weights, n)))


@pytest.mark.parametrize("name", list(EXITS))
def test_reference_work_at_an_exit_is_that_of_a_step_to_it(name, reference):
    """rampwork.reference steps to the exit (and corrects the step's length
    by Newton on x) instead of reading the dense output there: its W within
    1e-14 of the closed form (dense output: 5e-13 to 8e-13)."""
    x0, v0, mu = EXITS[name]
    scene = rw.Scene(ramp=RAMP, friction=rw.Friction(mu), x0=x0, v0=v0, t_max=60.0, g=G)
    ref = reference.reference_trajectory(scene, rtol=2.5e-14, atol=1e-16)
    expected = closed_form_exit_work(x0, v0, mu)
    assert ref["status"] == EXITED and ref["n_reversals"] == 0
    assert abs(ref["x_end"]) == 1.0
    assert abs(ref["W_friction"] - expected) <= 1e-14 * expected, (ref["W_friction"], expected)


@pytest.mark.parametrize("rtol", sorted(TIGHT_W_ERROR))
@pytest.mark.parametrize("method", PAIRS)
def test_tight_end_exits_against_the_closed_form(method, rtol):
    """The pairs' W at these exits within 2 rtol of the closed form (they
    take 3-5 steps; measured: 0.1-1 rtol)."""
    for name, (x0, v0, mu) in EXITS.items():
        _, got = simulate_one(method, rtol, x0, v0, mu)
        expected = closed_form_exit_work(x0, v0, mu)
        assert got["status"] == EXITED, (name, got)
        assert abs(got["W_friction"] - expected) <= 2 * rtol * expected, (name, got, expected)


def closed_form_work(x0, v0, mu, max_segments=200):
    """(status, W in J/kg, n_reversals) on y = x^2 / 2 with mu_s = mu_k = mu,
    segment by segment: n(x) as in closed_form_exit_work from each segment's
    start (x, v^2), the segment's end where n = g (v = 0; Brent to 4 eps, from
    the maximum of n at x = -d mu on, so the root is the turn ahead) or the
    domain's end, W = mu |integral of n dx|; at rest the rest rule.  Within
    3e-15 of a long-double Taylor integration (heyoka) on the two trajectories
    below (a turn near x = -d mu, where n - g is flat, would not be)."""
    import math

    import numpy as np
    from scipy.optimize import brentq

    assert v0 != 0.0  # a start from rest would need the rest rule first
    nodes, weights = np.polynomial.legendre.leggauss(GAUSS_NODES)
    lo, hi = RAMP.domain
    x, u = x0, v0 * v0
    d = math.copysign(1.0, v0)
    work, reversals = 0.0, 0
    for _ in range(max_segments):
        end = hi if d > 0 else lo

        def n(s, x=x, u=u, d=d):
            return (G + u) * (1 + x * x) / (1 + s * s) * np.exp(-2 * d * mu * (np.arctan(s) - math.atan(x)))

        if n(end) > G:
            x1 = end
        else:
            start = -d * mu if (-d * mu - x) * d > 0 else x
            x1 = brentq(lambda s: n(s) - G, start, end, xtol=1e-300, rtol=8.9e-16, maxiter=500)
        points = 0.5 * (x1 - x) * nodes + 0.5 * (x1 + x)
        work += mu * abs(0.5 * (x1 - x) * float(np.dot(weights, n(points))))
        if x1 == end:
            return EXITED, work, reversals
        if abs(x1) <= mu:
            return STUCK, work, reversals
        reversals += 1  # at rest on a slope steeper than mu: back the other way
        d, x, u = -d, x1, 0.0
    raise RuntimeError("too many segments")


#: slowly damped swings (mu = 0.02): the largest W errors at the tight end,
#: error that adds up over the swings (each step of a pair takes a little
#: energy from the oscillation, which friction then does not take)
LONG = {
    "16 reversals": (0.04797979797979801, 2.191919191919192, 0.02, 16),
    "17 reversals": (-0.22070707070707074, -2.191919191919192, 0.02, 17),
}
#: measured: dopri5 25.2-26.1 rtol at every rtol, dop853 0.1-1.6 rtol
LONG_W_ERROR = {"dopri5": 40.0, "dop853": 3.0}


@pytest.mark.parametrize("method", PAIRS)
@pytest.mark.parametrize("name", list(LONG))
def test_tight_end_long_trajectories_error_is_truncation_not_rounding(name, method):
    """The W error of a many-reversal trajectory against the closed form,
    at rtol = atol 1e-11, 1e-12, 1e-13: within LONG_W_ERROR rtol, and for
    dopri5 falling tenfold (within 30 %) with each decade of rtol, as the
    global truncation error does; accumulated rounding would not."""
    x0, v0, mu, reversals = LONG[name]
    status, expected, n_rev = closed_form_work(x0, v0, mu)
    assert status == STUCK and n_rev == reversals
    errors = []
    for rtol in (1e-11, 1e-12, 1e-13):
        _, got = simulate_one(method, rtol, x0, v0, mu)
        assert got["status"] == STUCK, got
        errors.append(abs(got["W_friction"] - expected) / expected)
        assert errors[-1] <= LONG_W_ERROR[method] * rtol, (rtol, errors)
    if method == "dopri5":
        ratios = [errors[k] / errors[k + 1] for k in range(2)]
        assert all(7.0 <= r <= 13.0 for r in ratios), (errors, ratios)


def test_accuracy_ends_benchmark_runs_and_counts_no_wrong_outcome(tmp_path):
    """benchmarks/accuracy_ends.py --quick end to end: every pair and tolerance
    reported, no wrong outcome on its 1,000 starts, median W error within
    rtol, maximum within 10 rtol at the loose end (main: 140 rtol at 1e-3),
    and at the tight end as below."""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=str(root / "src"))
    done = subprocess.run([sys.executable, str(root / "benchmarks" / "accuracy_ends.py"), "--quick",
                           "--out", str(tmp_path)], cwd=root, env=env, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    results = json.loads((tmp_path / "accuracy_ends.json").read_text())["results"]
    assert sorted((r["method"], r["rtol"], r["atol"]) for r in results) == sorted(
        [(m, r, r) for m in PAIRS for r in (1e-3, 1e-4, 1e-12, 1e-13)]
        + [(m, r, r * 1e-4) for m in PAIRS for r in (1e-12, 1e-13)])
    for r in results:
        assert r["wrong"] == 0, r
        assert r["W_error_median"] <= r["rtol"], r
        if r["rtol"] >= 1e-4:
            assert r["W_error_max"] <= 10 * r["rtol"], r
            continue
        # tight end: exits (short trajectories; main: 2e-11 on the full grid)
        # within 1e-12, which holds the scipy reference's own error there
        # (4.5e-13); dop853's stops within 5 rtol (main: 3.7e-11 at 1e-12).
        # dopri5's stops: the global error of 2,500 steps (not asserted).
        assert r["W_error_max_by_status"]["exited"] <= 1e-12, r
        if r["method"] == "dop853":
            assert r["W_error_max_by_status"]["stuck"] <= 5 * r["rtol"], r


#: dop853's worst W errors on tight_reference.py's 20,000 starts with atol =
#: 1e-4 rtol: exits after 6-10 steps and stops after 8-11, from W = 0, whose
#: W-limited first steps dop853.f's single-ratio norm let through at 0.12-0.28
#: rtol, 10-25 times the median (control.error_norm2_two_estimates)
TIGHT_SHORT = {
    "exit, W = 0.18 J/kg": (0.8156565656565655, 1.4848484848484844, 0.08787878787878788),
    "exit, W = 0.19 J/kg": (-0.8348484848484848, -1.4848484848484853, 0.10727272727272728),
    "exit, W = 0.36 J/kg": (-0.7772727272727272, -1.7676767676767682, 0.1412121212121212),
    "exit, W = 0.43 J/kg": (0.7580808080808079, 1.9090909090909083, 0.1509090909090909),
    "stop, W = 0.32 J/kg": (-0.31666666666666665, 0.4949494949494948, 0.48060606060606065),
    "stop, W = 0.34 J/kg": (0.33585858585858586, -0.4949494949494948, 0.4903030303030303),
}
#: issue 19's target: every W error within 10x the median, which is 0.006 rtol
#: (1e-12) and 0.008 rtol (1e-13) on those starts (measured: at most 0.053
#: rtol here, 0.12-0.28 before i19-tight-10)
TIGHT_SHORT_W_ERROR = 0.1


@pytest.mark.parametrize("rtol", sorted(TIGHT_W_ERROR))
def test_tight_end_dop853_short_trajectories_within_10x_the_median(rtol):
    """dop853 at atol = 1e-4 rtol on TIGHT_SHORT against the closed form
    (the stops at rtol 1e-12 only: their closed form's turning point, a root
    to 4 eps, is 3e-15 off in W, a quarter of the bound at 1e-13)."""
    cases = [(name, start) for name, start in TIGHT_SHORT.items()
             if rtol == 1e-12 or name.startswith("exit")]
    x0, v0, mu = (list(column) for column in zip(*(start for _, start in cases)))
    scene = rw.Scene(ramp=RAMP, friction=rw.Friction(0.2), t_max=60.0, g=G,
                     integrator=rw.Integrator("dop853", rtol=rtol, atol=1e-4 * rtol,
                                              closed_form=False))
    ds = rw.simulate(scene, rw.Sweep.cases(x0=x0, v0=v0, mu=mu))
    for k, (name, start) in enumerate(cases):
        status, expected, _ = closed_form_work(*start)
        got = ds.isel(case=k)
        assert int(got.status) == status, (name, int(got.status))
        error = abs(float(got.W_friction) - expected) / expected
        assert error <= TIGHT_SHORT_W_ERROR * rtol, (name, error / rtol)
