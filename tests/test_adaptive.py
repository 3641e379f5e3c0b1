"""The adaptive pairs, Dormand-Prince 5(4) (``dopri5``) and 8(5,3)
(``dop853``), and the fixed-step methods' orders through events.

As in ``test_physics.py``, nothing here compares the engine with its own
earlier output: expected values are closed forms, conservation laws, fitted
convergence orders, or the independent scipy reference solver
(:mod:`rampwork.reference`, DOP853 at a far tighter tolerance).  The one
exception is by design: the determinism test compares dopri5 runs with each
other, bit for bit, under different thread counts, orders and chunkings.

Scales.  ``atol`` defaults to ``rtol`` and both are in SI units, so a
tolerance of ``rtol`` means an error of about ``rtol * max(|value|, 1)`` in
metres, seconds and joules (m = 1 kg here); "10x rtol" below is always against
that scale.

Kernel variants compiled here (numba caches them on disk; a fresh compile
costs 10-50 s each): quadratic x {euler, semi_implicit_euler, rk4, dopri5
(convex, and with contact checks for mixed curvature)}, dopri5 x {straight,
circular_bowl, circular_dome, sine}, dop853 x {quadratic (both), straight,
circular_bowl, circular_dome, sine} (dop853 compiles in 30-60 s), and
straight rk4.  The default part runs
in under 10 s once they are cached; the slow part (``-m slow``: 25 random
batches per family) in about 30 s more.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

import rampwork as rw
from rampwork.core.status import EXITED, LIFTED_OFF, STUCK
from rampwork.errors import ConfigError

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, Phase, given, note, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

G = 9.81
EPS = np.finfo(float).eps
QUANTITIES = ("W_friction", "x_end", "t_end")


def run(scene, sweep=None, **kwargs):
    return rw.simulate(scene, sweep, **kwargs)


def val(ds, name):
    return ds[name].values.item()


def dopri5(rtol, **kwargs):
    return rw.Integrator("dopri5", rtol=rtol, **kwargs)


#: the adaptive pairs; tests parametrised over PAIRS hold both to the same bounds
PAIRS = ("dopri5", "dop853")


def si_scale(value):
    """The size that a tolerance is relative to (atol = rtol, SI units)."""
    return max(1.0, abs(value))


def _slope(xs, errors):
    return np.polyfit(np.log(xs), np.log(errors), 1)[0]


#: the quadratic bowl y = x^2 / 2 on [-1, 1]: from rest at x0 = 0.8 it reverses
#: and then sticks (mu = 0.1: three reversals; mu = 0.15: one)
QUAD_BOWL = rw.Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0))
QUAD_MUS = (0.1, 0.15)


def quad_bowl_scene(integrator, **kwargs):
    kwargs.setdefault("x0", 0.8)
    kwargs.setdefault("friction", rw.Friction(0.1))
    return rw.Scene(ramp=QUAD_BOWL, integrator=integrator, **kwargs)


@pytest.fixture(scope="module")
def quad_bowl_references(reference):
    """Reference runs of the quadratic bowl for each mu in QUAD_MUS, each
    checked for an event sequence worth fitting orders on: at least one
    reversal, a final stick, and every rest decision far from its threshold.
    The reference runs at scipy's tightest tolerance (rtol >= 100 eps); with
    them comes how far the reference is from converged (its change from rtol
    1e-13, an upper estimate of its own error: 2e-14 to 6e-13 here), which
    every fitted error must exceed tenfold."""
    refs, wobble = [], []
    for mu in QUAD_MUS:
        scene = quad_bowl_scene(rw.Integrator("rk4", 1e-3))
        ref = reference.reference_trajectory(scene, mu_k=mu, mu_s=mu, rtol=3e-14, atol=3e-14)
        coarser = reference.reference_trajectory(scene, mu_k=mu, mu_s=mu, rtol=1e-13, atol=1e-13)
        assert ref["status"] == STUCK and ref["n_reversals"] >= 1, ref["events"]
        assert min(abs(e["margin"]) for e in ref["events"] if "margin" in e) > 0.01
        refs.append(ref)
        wobble.append({q: abs(ref[q] - coarser[q]) for q in QUANTITIES})
    return refs, wobble


# ------------------------------------------------------------------------------
# 1. fixed-step orders on runs that contain events
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("method, order, dts", [
    ("euler", 1, [4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4]),
    ("semi_implicit_euler", 1, [4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4]),
    ("rk4", 4, [8e-3, 4e-3, 2e-3]),  # beyond: errors near the reference's own
])
def test_fixed_step_order_through_reversals_and_a_stick(method, order, dts, quad_bowl_references):
    """Fitted log-log slope of the error against dt, within 0.3 of the
    method's order, on the quadratic bowl from rest (reversals, then a stick).

    ``test_physics.py::test_convergence_order`` fits the same three methods on
    the *circular* bowl with ``mu_s > mu_k``, checking x and W for the Eulers
    and t and W for RK4.  This one adds what that does not cover: the
    ``quadratic`` family (a 'cheap' ramp whose f' is re-evaluated rather than
    carried through the events), the paper's ``mu_s = mu_k``, up to three
    reversals, and all of W, x_end and t_end for every method.  Each
    consecutive halving must already show the order (within 0.5): the range
    is asymptotic, not only on average."""
    refs, wobble = quad_bowl_references
    errors = {(k, q): [] for k in range(len(QUAD_MUS)) for q in QUANTITIES}
    for dt in dts:
        ds = run(quad_bowl_scene(rw.Integrator(method, dt)), rw.Sweep.cases(mu=list(QUAD_MUS)))
        for k, ref in enumerate(refs):
            got = ds.isel(case=k)
            assert val(got, "status") == STUCK and val(got, "v_end") == 0.0, (dt, k)
            assert val(got, "n_reversals") == ref["n_reversals"], (dt, k)
            for q in QUANTITIES:
                errors[k, q].append(abs(val(got, q) - ref[q]))
    for (k, q), e in errors.items():
        e = np.array(e)
        n_steps = refs[k]["t_end"] / min(dts)
        rounding = 10 * math.sqrt(n_steps) * EPS * si_scale(refs[k][q])
        assert e.min() > max(rounding, 10 * wobble[k][q]), (q, k, e, rounding, wobble[k][q])
        local = np.log(e[:-1] / e[1:]) / np.log(dts[0] / dts[1])
        fitted = _slope(dts, e)
        where = (method, QUAD_MUS[k], q, e, local)
        assert abs(fitted - order) <= 0.3, (fitted, where)
        assert np.all(np.abs(local - order) <= 0.5), where


# ------------------------------------------------------------------------------
# 2. dopri5 against the reference: tolerance proportionality, random scenes
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("method", PAIRS)
def test_error_is_proportional_to_rtol(method, quad_bowl_references):
    """With the error controlled per step and the higher-order solution carried
    on, the global error scales like rtol (for dopri5 the step like
    rtol^(1/5), the 5th-order error like h^5; for dop853 the combined
    estimate behaves like h^8).  Fitted slope of the error against rtol
    within 0.3 of 1, every error within 10 rtol, and the steps growing as
    the tolerance tightens.  (dop853 stops a decade earlier: at 1e-11 its
    error, 8e-14 J, is below what the reference resolves.)"""
    refs, wobble = quad_bowl_references
    rtols = [10.0**-k for k in (range(5, 12) if method == "dopri5" else range(4, 11))]
    errors = {(k, q): [] for k in range(len(QUAD_MUS)) for q in QUANTITIES}
    steps = []
    for rtol in rtols:
        ds = run(quad_bowl_scene(rw.Integrator(method, rtol=rtol)), rw.Sweep.cases(mu=list(QUAD_MUS)))
        steps.append(ds.steps.values)
        for k, ref in enumerate(refs):
            got = ds.isel(case=k)
            assert val(got, "status") == STUCK and val(got, "v_end") == 0.0, (rtol, k)
            assert val(got, "n_reversals") == ref["n_reversals"], (rtol, k)
            for q in QUANTITIES:
                error = abs(val(got, q) - ref[q])
                assert error <= 10 * rtol * si_scale(ref[q]), (rtol, QUAD_MUS[k], q, error)
                errors[k, q].append(error)
    for (k, q), e in errors.items():
        assert min(e) > 10 * wobble[k][q], (q, k, e, wobble[k][q])
        fitted = _slope(rtols, e)
        assert abs(fitted - 1.0) <= 0.3, (QUAD_MUS[k], q, fitted, e)
    steps = np.array(steps)
    assert np.all(np.diff(steps, axis=0) > 0), steps


# --- random scenes ---------------------------------------------------------------
#: family: (domain, ranges of the shape parameters drawn per case)
FAMILY_SPACE = {
    "quadratic": ((-1.0, 1.0), {"curvature": (-2.0, 3.0), "slope": (-0.5, 0.5)}),
    "circular_bowl": ((-0.9, 0.9), {"radius": (1.0, 3.0)}),
    "circular_dome": ((-0.9, 0.9), {"radius": (1.0, 3.0)}),
    "sine": ((-2.0, 2.0), {"mean_slope": (-0.3, 0.3), "amplitude": (0.05, 0.3),
                           "wavenumber": (1.0, 4.0), "phase": (0.0, 2 * math.pi)}),
}
#: trajectories per hypothesis example (one simulate call per tolerance for all)
BATCH = 6
RANDOM_RTOLS = (1e-4, 1e-6, 1e-8, 1e-10)
#: short enough that global errors have not piled up over many oscillations:
#: the tolerance bounds each step's error, and the global error of a long run
#: grows with its length (scipy's own Dormand-Prince, RK45, reaches 30x rtol
#: on a 10 s, 15-reversal run where rampwork reaches 25x)
T_MAX_RANDOM = 2.0
#: at and above this tolerance steps are 0.1-0.3 s long on these metre-scale
#: ramps and the embedded error estimate is not yet asymptotic: single errors
#: reach a few tens of rtol there for any implementation of the pair (on
#: hypothesis-found 2 s runs with two reversals, scipy's RK45 is 99x rtol off
#: in x_end and 29x in W where rampwork is 65x and 11x).  There each error is
#: held to 100x rtol kappa and the batch median to 10x; below it, every error
#: to 10x.
LOOSE_RTOL = 1e-4
#: relative size of the start / friction perturbations used to measure how
#: sensitive a reference trajectory is (its condition number)
SENSITIVITY_STEP = 1e-6
#: a status may differ where a perturbation of KNIFE_EDGE * rtol changes the
#: reference's own status: 10x the accuracy asked for, times 10 for safety
KNIFE_EDGE = 100.0


def _zero_or(low, high, signed=False):
    """0 exactly, or a magnitude in [low, high] (with either sign): not the
    tiny nonzero values hypothesis likes, which make knife edges by
    construction (a start at v0 = -1e-100 uphill is one reversal away from
    a start at rest; a frictionless start at rest at x0 = 5e-324 in a bowl
    is a Zeno cascade of reversals that the reference refuses)."""
    magnitude = st.floats(low, high)
    if signed:
        magnitude = st.tuples(st.sampled_from((-1.0, 1.0)), magnitude).map(lambda p: p[0] * p[1])
    # zero one time in four: a start at rest on the bottom of a frictionless
    # bowl or the top of a dome is a knife edge that teaches nothing twice
    return st.integers(0, 3).flatmap(lambda k: st.just(0.0) if k == 0 else magnitude)


def _parameter(low, high):
    """A shape parameter in [low, high]; one whose range holds 0 is 0 or at
    least 1e-3 away from it (a slope of 1e-218 makes a motion of 1e-218 m)."""
    if not low < 0.0 < high:
        return st.floats(low, high)
    return st.one_of(_zero_or(1e-3, -low).map(lambda x: -x), _zero_or(1e-3, high))


def case_strategy(family):
    (lo, hi), params = FAMILY_SPACE[family]
    assert lo == -hi
    return st.fixed_dictionaries({
        "x0": _zero_or(1e-3 * hi, 0.95 * hi, signed=True),  # (symmetric domains)
        "v0": _zero_or(0.05, 2.0, signed=True),
        "mu_k": _zero_or(0.01, 0.4),
        "static_extra": _zero_or(0.01, 0.2),  # mu_s - mu_k
        **{name: _parameter(a, b) for name, (a, b) in params.items()},
    })


def _family_scene(family):
    (lo, hi), params = FAMILY_SPACE[family]
    middle = {name: 0.5 * (a + b) for name, (a, b) in params.items()}
    return rw.Scene(ramp=rw.Ramp.create(family, domain=(lo, hi), **middle),
                    friction=rw.Friction(0.0, 1.0), x0=0.0, t_max=T_MAX_RANDOM)


def _case_overrides(family, case):
    (lo, hi), params = FAMILY_SPACE[family]
    ramp = rw.Ramp.create(family, domain=(lo, hi), **{name: case[name] for name in params})
    return dict(x0=case["x0"], v0=case["v0"], mu_k=case["mu_k"],
                mu_s=case["mu_k"] + case["static_extra"], ramp=ramp)


def _perturbed(overrides, step, domain):
    """The case with its start and friction moved by a relative ``step`` (up
    and down, one at a time).  Friction moves mu_k and mu_s together, which
    changes the slow accelerations (|f'| - mu) g near a rest decision by
    mu step g: the kind of change an integration error makes there."""
    lo, hi = domain
    x0, v0, mu_k, mu_s = (overrides[k] for k in ("x0", "v0", "mu_k", "mu_s"))
    for sign in (1.0, -1.0):
        yield dict(overrides, x0=min(max(x0 + sign * step * si_scale(x0), lo), hi))
        if v0 != 0.0:  # a start at rest stays one: nudged uphill it would add a reversal
            yield dict(overrides, v0=v0 + sign * step * si_scale(v0))
        if mu_k > 0.0:
            yield dict(overrides, mu_k=mu_k * (1 + sign * step), mu_s=mu_s * (1 + sign * step))


def _sensitivity(reference, scene, overrides, ref):
    """kappa[q] >= 1: how much more than a relative SENSITIVITY_STEP the
    reference's own W_friction, x_end, t_end move (relative to their SI
    scale) when the start or the friction moves by that much.  A local
    integration error is such a perturbation, so 10 rtol kappa is what
    '10x rtol' means for this trajectory.  It is large where the answer is
    ill-conditioned, e.g. where the motion after a reversal near the rest
    threshold depends strongly on how that reversal came about (measured:
    up to ~60 for W on such runs; slow events, which these perturbations
    miss, are covered by ``_event_timing_kappa``).  None when the
    perturbation changes the event sequence (a knife edge at 1e-6)."""
    kappa = dict.fromkeys(QUANTITIES, 1.0)
    for moved in _perturbed(overrides, SENSITIVITY_STEP, scene.ramp.domain):
        other = reference.reference_trajectory(scene, **moved, rtol=1e-13, atol=1e-13)
        if (other["status"], other["n_reversals"]) != (ref["status"], ref["n_reversals"]):
            return None
        for q in QUANTITIES:
            kappa[q] = max(kappa[q], abs(other[q] - ref[q]) / (SENSITIVITY_STEP * si_scale(ref[q])))
    return kappa


def _event_timing_kappa(ref, mu_k, g=G):
    """A second condition number, for t_end: the error control is absolute
    in v (atol = rtol m/s), and a velocity error dv moves an event that the
    motion approaches with acceleration a by dv / a.  Slow events are thus
    ill-conditioned in time: a stop or reversal approached with a small net
    acceleration, a departure from a rest point that barely fails to hold
    (|f'| - mu_k small: a creep of millimetres over half a second), an exit
    at low speed (dt = dx / v).  Start perturbations miss these, so they are
    read off the reference's events: (1 m/s^2) / |a| and (1 m/s) / |v|.
    Found by hypothesis: a block released on a sine ramp reverses where
    |f'| - mu_k = 0.0057 and creeps 2.5 mm in 0.5 s before it sticks; its
    t_end is off by 17x rtol in rampwork and 27x in scipy's RK45."""
    kappa = 1.0
    d = 0.0
    for e in ref["events"]:
        fp, n = e["fp"], e["n"]
        if e["kind"] == "start":
            if e["v"] != 0.0:
                d = math.copysign(1.0, e["v"])
            elif e["margin"] > 0.0:  # leaves the rest point downhill
                d = -math.copysign(1.0, fp)
                kappa = max(kappa, (1 + fp * fp) / max((abs(fp) - mu_k) * g, 1e-300))
        elif e["kind"] in ("reversal", "stop"):
            kappa = max(kappa, (1 + fp * fp) / max(abs(fp + d * mu_k) * n, 1e-300))
            if e["kind"] == "reversal":
                kappa = max(kappa, (1 + fp * fp) / max((abs(fp) - mu_k) * n, 1e-300))
                d = -math.copysign(1.0, fp)
        elif e["kind"] == "exit":
            kappa = max(kappa, 1.0 / max(abs(e["v"]), 1e-300))
    return kappa


def _knife_edge(reference, scene, overrides, ref, rtol):
    """Whether the reference's event sequence changes under a perturbation of
    KNIFE_EDGE * rtol: then an engine run with errors of order rtol may
    legitimately take the other branch (stick or slide on, exit or stop
    just before the end, lift off or stay on at a grazing normal force,
    an event just before or after t_max).  Also where the whole motion is
    within the tolerance (a path shorter than KNIFE_EDGE * rtol metres, with
    atol = rtol): then where it turns is below what was asked for."""
    if ref["path"] <= KNIFE_EDGE * rtol:
        return True
    for moved in _perturbed(overrides, KNIFE_EDGE * rtol, scene.ramp.domain):
        other = reference.reference_trajectory(scene, **moved, rtol=1e-13, atol=1e-13)
        if (other["status"], other["n_reversals"]) != (ref["status"], ref["n_reversals"]):
            return True
    return False


def _invariants(got, domain, t_max):
    """What every result must satisfy whatever the tolerance."""
    lo, hi = domain
    bad = []
    status, x, v, t = (val(got, k) for k in ("status", "x_end", "v_end", "t_end"))
    if not lo <= x <= hi:
        bad.append(f"x_end = {x!r} outside the domain [{lo}, {hi}] with status {status}")
    if status == STUCK and v != 0.0:
        bad.append(f"stuck with v_end = {v!r}")
    if status == EXITED and x not in (lo, hi):
        bad.append(f"exited at x_end = {x!r}, not at an end")
    if not 0.0 <= t <= t_max:
        bad.append(f"t_end = {t!r}")
    if not val(got, "W_friction") >= 0.0:
        bad.append(f"W_friction = {val(got, 'W_friction')!r}")
    if status == LIFTED_OFF and val(got, "x_lift_off") != x:
        bad.append("x_lift_off != x_end")
    return bad


def check_random_batch(family, cases, reference, method="dopri5"):
    """One simulate call per tolerance over the whole batch; every trajectory
    against the reference (W_friction, x_end, t_end within 10 rtol kappa of
    their SI scale, the same status and reversals unless the reference is at
    a knife edge for that tolerance), and the invariants everywhere."""
    scene = _family_scene(family)
    (lo, hi), params = FAMILY_SPACE[family]
    columns = {name: [case[name] for case in cases] for name in ("x0", "v0", "mu_k", *params)}
    columns["mu_s"] = [case["mu_k"] + case["static_extra"] for case in cases]
    results = {rtol: run(scene.replace(integrator=rw.Integrator(method, rtol=rtol)),
                         rw.Sweep.cases(**columns))
               for rtol in RANDOM_RTOLS}
    failures, skipped, ratios = [], [], {}
    for i, case in enumerate(cases):
        overrides = _case_overrides(family, case)
        ref = reference.reference_trajectory(scene, **overrides, rtol=1e-13, atol=1e-13)
        where = dict(family=family, **{k: float(v) for k, v in case.items()})
        outside = [e for e in ref["events"] if e["kind"] != "exit" and not lo <= e["x"] <= hi]
        if outside:
            # the reference crossed an end and reversed or stopped beyond it
            # within one of its own steps (scipy looks at event signs at step
            # ends only, and the exit's sign is back to positive there): it
            # cannot be compared with; the engine's invariants still are
            skipped.append((i, f"reference {outside[0]['kind']} outside the domain at "
                               f"{outside[0]['x']!r}"))
            ref = None
        kappa = None if ref is None else _sensitivity(reference, scene, overrides, ref)
        if kappa is not None:
            kappa["t_end"] = max(kappa["t_end"], _event_timing_kappa(ref, overrides["mu_k"]))
        for rtol, ds in results.items():
            got = ds.isel(case=i)
            failures += [(rtol, where, text) for text in _invariants(got, (lo, hi), T_MAX_RANDOM)]
            if ref is None:
                continue
            same = (val(got, "status"), val(got, "n_reversals")) == (ref["status"], ref["n_reversals"])
            if not same:
                if _knife_edge(reference, scene, overrides, ref, rtol):
                    skipped.append((i, rtol, "knife edge"))
                else:
                    failures.append((rtol, where, f"status/reversals {val(got, 'status')}/"
                                     f"{val(got, 'n_reversals')}, reference {ref['status']}/"
                                     f"{ref['n_reversals']}, not at a knife edge"))
                continue
            if kappa is None:
                skipped.append((i, rtol, "event sequence changes under a 1e-6 perturbation"))
                continue
            for q in QUANTITIES:
                error = abs(val(got, q) - ref[q])
                ratio = error / (rtol * si_scale(ref[q]) * kappa[q])
                ratios.setdefault(rtol, []).append(ratio)
                if not ratio <= (100.0 if rtol >= LOOSE_RTOL else 10.0):
                    failures.append((rtol, where, f"{q} off by {error:.3g} = {ratio:.1f}x rtol kappa "
                                     f"(kappa {kappa[q]:.3g}), reference {ref[q]!r}"))
    for rtol, values in ratios.items():
        if rtol >= LOOSE_RTOL and not np.median(values) <= 10.0:
            failures.append((rtol, family, f"median error {np.median(values):.1f}x rtol kappa"))
    note(f"skipped: {skipped}")
    for item in skipped:
        hypothesis.event(f"{family}: skipped ({item[-1].split(' at ')[0]})")
    assert not failures, "\n".join(map(str, failures))


RANDOM_SETTINGS = dict(deadline=None, derandomize=True, phases=[Phase.explicit, Phase.generate],
                       suppress_health_check=[HealthCheck.too_slow])


# the default run keeps two families; the _many variant (slow) runs them all
@pytest.mark.parametrize("family", [family if family in ("quadratic", "circular_bowl")
                                    else pytest.param(family, marks=pytest.mark.slow)
                                    for family in FAMILY_SPACE])
@settings(max_examples=2, **RANDOM_SETTINGS)
@given(data=st.data())
def test_dopri5_random_scenes_within_10x_rtol(family, data, reference):
    """Random scenes of four families, rtol = 1e-4 ... 1e-10, against the
    reference: W_friction, x_end and t_end within 10 rtol kappa of their SI
    scale (kappa: the trajectory's condition number, ``_sensitivity`` and
    ``_event_timing_kappa``; 1 for most runs; at rtol = 1e-4 see
    LOOSE_RTOL), the same status and reversals unless the reference itself
    is at a knife edge for that tolerance (``_knife_edge``), and invariants
    that hold at any tolerance (``_invariants``: inside the domain, v = 0
    when stuck, exits on an end, ...).  Without kappa the 10x bound fails
    on ill-conditioned runs only, and there scipy's RK45 (the same pair)
    fails it by as much.

    Each example is a batch of 6 trajectories: one simulate call per
    tolerance, one compilation per family (two for the quadratic: convex
    batches skip the contact checks).  This quick draw takes 2 batches per
    family; the slow variant 25.  Derandomized, so a run is reproducible;
    no shrinking: a failure lists every trajectory and tolerance it
    concerns, with its parameters."""
    check_random_batch(family, data.draw(st.lists(case_strategy(family), min_size=BATCH,
                                                  max_size=BATCH)), reference)


@pytest.mark.slow
@pytest.mark.parametrize("family", list(FAMILY_SPACE))
@settings(max_examples=25, **RANDOM_SETTINGS)
@given(data=st.data())
def test_dopri5_random_scenes_within_10x_rtol_many(family, data, reference):
    """The same with 25 batches (150 trajectories) per family."""
    check_random_batch(family, data.draw(st.lists(case_strategy(family), min_size=BATCH,
                                                  max_size=BATCH)), reference)


@pytest.mark.slow
@pytest.mark.parametrize("family", list(FAMILY_SPACE))
@settings(max_examples=10, **RANDOM_SETTINGS)
@given(data=st.data())
def test_dop853_random_scenes_within_10x_rtol(family, data, reference):
    """dop853 held to the same bounds on 10 batches (60 trajectories) per
    family (slow: one 30-60 s compilation per family)."""
    check_random_batch(family, data.draw(st.lists(case_strategy(family), min_size=BATCH,
                                                  max_size=BATCH)), reference, "dop853")


# ------------------------------------------------------------------------------
# 3. event times and positions to the tolerance
# ------------------------------------------------------------------------------
EVENT_RTOLS = (1e-6, 1e-8, 1e-10)
BOWL = rw.Ramp.create("circular_bowl", radius=1.0, domain=(-0.9, 0.9))


@pytest.mark.parametrize("method", PAIRS)
def test_stick_on_a_bowl_to_the_tolerance(method, reference):
    """A block released on the circular bowl reverses twice and sticks: the
    stick time and place within 10 rtol of the reference, v_end exactly 0,
    held by static friction where it stopped."""
    scene = rw.Scene(ramp=BOWL, friction=rw.Friction(0.1, 0.2), x0=0.7)
    ref = reference.reference_trajectory(scene, rtol=1e-13, atol=1e-13)
    assert ref["status"] == STUCK and ref["n_reversals"] == 2
    assert min(abs(e["margin"]) for e in ref["events"] if "margin" in e) > 0.05
    for rtol in EVENT_RTOLS:
        ds = run(scene.replace(integrator=rw.Integrator(method, rtol=rtol)))
        assert val(ds, "status") == STUCK and val(ds, "n_reversals") == 2
        assert val(ds, "v_end") == 0.0
        for q in ("t_end", "x_end", "W_friction", "W_path"):
            assert abs(val(ds, q) - ref[q]) <= 10 * rtol * si_scale(ref[q]), (rtol, q, val(ds, q), ref[q])
        assert abs(BOWL.evaluate(val(ds, "x_end"))[1]) <= 0.2


@pytest.mark.parametrize("method", PAIRS)
def test_exit_times_to_the_tolerance(method, reference):
    """Exits: on a straight ramp against the closed form (constant
    acceleration: x is quadratic in t, which Dormand-Prince and its dense
    output reproduce to rounding), and on the bowl against the reference."""
    slope, mu, lo, hi = -0.3, 0.1, -2.0, 3.0
    ramp = rw.Ramp.create("straight", slope=slope, domain=(lo, hi))
    a = -G * (slope + mu) / (1 + slope**2)  # moving right, downhill: a > 0
    x0s, v0s = [0.0, -1.5, 2.5], [0.0, 1.0, 3.0]
    exact_t = [(-v + math.sqrt(v * v + 2 * a * (hi - x))) / a for x, v in zip(x0s, v0s)]
    straight = rw.Scene(ramp=ramp, friction=rw.Friction(mu), x0=0.0)
    launched = rw.Scene(ramp=BOWL, friction=rw.Friction(0.1), x0=-0.5, v0=4.0)
    ref = reference.reference_trajectory(launched, rtol=1e-13, atol=1e-13)
    assert ref["status"] == EXITED and ref["n_reversals"] == 0 and ref["v_end"] > 0.5  # no graze
    for rtol in EVENT_RTOLS:
        pair = rw.Integrator(method, rtol=rtol)
        stepped = rw.Integrator(method, rtol=rtol, closed_form=False)  # not the closed form
        ds = run(straight.replace(integrator=stepped), rw.Sweep.cases(x0=x0s, v0=v0s))
        assert np.all(ds.status.values == EXITED) and np.all(ds.x_end.values == hi)
        np.testing.assert_allclose(ds.t_end.values, exact_t, rtol=1e-12)
        np.testing.assert_allclose(ds.v_end.values, np.array(v0s) + a * np.array(exact_t), rtol=1e-12)
        np.testing.assert_allclose(ds.W_friction.values, mu * G * (hi - np.array(x0s)), rtol=1e-12)
        bowl = run(launched.replace(integrator=pair))
        assert val(bowl, "status") == EXITED and val(bowl, "x_end") == BOWL.domain[1]
        for q in ("t_end", "v_end", "W_friction"):
            assert abs(val(bowl, q) - ref[q]) <= 10 * rtol * si_scale(ref[q]), (rtol, q, val(bowl, q), ref[q])


@pytest.mark.parametrize("integrator", [dopri5(1e-4, closed_form=False), dopri5(1e-8, closed_form=False),
                                        dopri5(1e-12, closed_form=False),
                                        rw.Integrator("dop853", rtol=1e-4, closed_form=False),
                                        rw.Integrator("dop853", rtol=1e-12, closed_form=False),
                                        rw.Integrator("rk4", 0.2, closed_form=False)],
                         ids=["dopri5-1e-4", "dopri5-1e-8", "dopri5-1e-12", "dop853-1e-4",
                              "dop853-1e-12", "rk4-dt0.2"])
@pytest.mark.parametrize("overshoot", [1e-3, 1e-1])
def test_exit_is_found_when_the_block_would_stop_beyond_the_end(integrator, overshoot):
    """Launched up a straight ramp fast enough to stop ``overshoot`` metres
    beyond the upper end: it exits there, with speed sqrt(2 a overshoot).

    Within one long step the block can cross the end, stop beyond it and
    slide back below it, so the exit function is positive at both ends of
    the step and only the reversal shows.  An exit must still be found
    before the reversal: a run never ends stuck outside its domain.
    (Dormand-Prince integrates constant acceleration exactly, so its steps
    grow long here whatever the tolerance.)  Regression: until 089d7c3
    dopri5 ended stuck at x = 3.001 / 3.1 at every tolerance (the random
    scenes found the same on a level parabola, and a phantom reversal at
    x = -1.036 outside [-1, 1]); until 1e7bcfe so did rk4 at dt = 0.2 s."""
    slope, mu_k, mu_s, lo, hi = 0.5, 0.2, 0.6, -2.0, 3.0
    a = G * (slope + mu_k) / (1 + slope**2)  # deceleration going up
    v0 = math.sqrt(2 * a * (hi + overshoot))
    t_exit = (v0 - math.sqrt(2 * a * overshoot)) / a
    scene = rw.Scene(ramp=rw.Ramp.create("straight", slope=slope, domain=(lo, hi)),
                     friction=rw.Friction(mu_k, mu_s), x0=0.0, v0=v0, integrator=integrator)
    ds = run(scene)
    got = {k: val(ds, k) for k in ("status", "x_end", "t_end", "v_end", "steps")}
    assert lo <= got["x_end"] <= hi, got
    assert got["status"] == EXITED and got["x_end"] == hi, got
    assert got["t_end"] == pytest.approx(t_exit, rel=1e-9), got
    assert got["v_end"] == pytest.approx(math.sqrt(2 * a * overshoot), rel=1e-6), got


DOME = rw.Ramp.create("circular_dome", radius=1.0, x_centre=0.0, y_centre=0.0, domain=(-0.95, 0.95))


def dome_lift_off_x(x0, v0, radius=1.0, g=G):
    """Frictionless lift-off from a circle (as in test_physics): n = 0 where
    v_t^2 = g R cos(theta); energy gives v_t^2 = v_t0^2 + 2 g R (cos(theta0) -
    cos(theta)), so cos(theta) = (v_t0^2 / (g R) + 2 cos(theta0)) / 3."""
    cos0 = math.sqrt(1.0 - (x0 / radius) ** 2)
    vt0 = v0 / cos0
    cos_l = (vt0**2 / (g * radius) + 2.0 * cos0) / 3.0
    return math.copysign(radius * math.sqrt(1.0 - cos_l**2), v0 if v0 != 0 else x0)


@pytest.mark.parametrize("method", ["dopri5", pytest.param("dop853", marks=pytest.mark.slow)])
def test_lift_off_from_a_dome_to_the_tolerance(method, reference):
    """Frictionless: the lift-off point against the closed form, down to the
    limit cos(theta) = 2/3 from the top; with friction against the reference."""
    x0 = [0.3, -0.2, 1e-2, 1e-3]
    v0 = [0.8, -1.0, 1e-2, 1e-3]
    exact = np.array([dome_lift_off_x(a, b) for a, b in zip(x0, v0)])
    assert abs(exact[-1] - math.sqrt(5.0) / 3.0) < 1e-5  # the limit from the top
    rough = rw.Scene(ramp=DOME, friction=rw.Friction(0.2), x0=0.4, v0=0.5)
    ref = reference.reference_trajectory(rough, rtol=1e-13, atol=1e-13)
    assert ref["status"] == LIFTED_OFF
    for rtol in EVENT_RTOLS:
        pair = rw.Integrator(method, rtol=rtol)
        ds = run(rw.Scene(ramp=DOME, x0=0.0, integrator=pair), rw.Sweep.cases(x0=x0, v0=v0))
        assert np.all(ds.status.values == LIFTED_OFF)
        assert np.array_equal(ds.x_lift_off.values, ds.x_end.values)
        assert np.all(np.abs(ds.x_lift_off.values - exact) <= 10 * rtol), (rtol, ds.x_lift_off.values - exact)
        assert np.all(ds.W_friction.values == 0.0)
        got = run(rough.replace(integrator=pair))
        assert val(got, "status") == LIFTED_OFF
        for q in ("x_lift_off", "t_end", "W_friction"):
            assert abs(val(got, q) - ref[q]) <= 10 * rtol * si_scale(ref[q]), (rtol, q, val(got, q), ref[q])


@pytest.mark.parametrize("method", PAIRS)
def test_lift_off_is_found_when_the_normal_force_dips_inside_one_step(method, reference):
    """A block sliding down a wavy ramp passes a crest where n = g + v^2 f''
    drops below 0 for about 22 ms (to -0.018 m/s^2) and would come back: it
    lifts off there, at x = -0.139 (the reference, and dopri5 at 1e-8).  At
    rtol = 1e-6 each step is accurate enough to see the dip (n to ~1e-5), so a
    dip 0.2 % of g deep is no knife edge (a 1e-4 change of the start or the
    friction does not remove it); a step that straddles the whole dip must
    not step over the lift-off.  Regression: until 1e7bcfe dopri5 at 1e-6
    lifted off at x = -1.784 instead (W_friction 9.74 J for 4.88 J)."""
    ramp = rw.Ramp.create("sine", mean_slope=0.2962077727993549, amplitude=0.18158529065569318,
                          wavenumber=3.686599286299794, phase=2.166264083069422, domain=(-2.0, 2.0))
    scene = rw.Scene(ramp=ramp, friction=rw.Friction(0.20989624352131858), x0=1.6660491696128146,
                     v0=-1.9576545081599797, t_max=T_MAX_RANDOM)
    ref = reference.reference_trajectory(scene, rtol=1e-13, atol=1e-13)
    assert ref["status"] == LIFTED_OFF
    bead = reference.reference_trajectory(scene, contact="two_sided", rtol=1e-13, atol=1e-13,
                                          keep_segments=True)
    contacts = [e["t"] for e in bead["events"] if e["kind"] == "contact"]
    assert contacts[0] == pytest.approx(ref["t_end"], abs=1e-9)  # n < 0 from there ...
    assert 0.005 < contacts[1] - contacts[0] < 0.05  # ... for a few hundredths of a second
    _, slope_curvature = reference.ramp_functions(ramp)
    _, ys = bead["segments"][1]
    dip = min(G + y[1] ** 2 * slope_curvature(y[0])[1] for y in ys.T)
    assert -0.1 < dip < -1e-3  # and clearly negative
    assert not _knife_edge(reference, scene, dict(x0=scene.x0, v0=scene.v0, mu_k=0.20989624352131858,
                                                  mu_s=0.20989624352131858, ramp=ramp), ref, 1e-6)
    for rtol in (1e-6, 1e-8):
        ds = run(scene.replace(integrator=rw.Integrator(method, rtol=rtol)))
        got = {k: val(ds, k) for k in ("status", "x_lift_off", "t_end", "W_friction")}
        assert got["status"] == LIFTED_OFF, (rtol, got)
        assert abs(got["x_lift_off"] - ref["x_lift_off"]) <= 10 * rtol, (rtol, got, ref["x_lift_off"])


# ------------------------------------------------------------------------------
# 4. is the error control honest?
# ------------------------------------------------------------------------------
HONESTY_RTOLS = (1e-4, 1e-6, 1e-8, 1e-10)


def energy_changing_hands(ds, ramp, m=1.0):
    """J: friction work plus the kinetic energies at both ends plus the drop in
    potential energy, the amounts whose rounding and truncation the energy
    balance collects (as in test_physics' two-sided test)."""
    x0 = ds.x0.broadcast_like(ds.x_end).values
    v0 = ds.v0.broadcast_like(ds.x_end).values
    f0, fp0, _ = ramp.evaluate(x0)
    f1, fp1, _ = ramp.evaluate(ds.x_end.values)
    kinetic0 = 0.5 * m * v0**2 * (1 + fp0**2)
    kinetic1 = 0.5 * m * ds.v_end.values**2 * (1 + fp1**2)
    return np.maximum(1.0, ds.W_friction.values) + kinetic0 + kinetic1 + m * G * np.abs(f1 - f0)


def test_error_control_is_honest(reference):
    """On a grid of bowl runs (starts, launches, two frictions):

    * steps grow as the tolerance tightens, like rtol^(-1/5) (slope within
      0.1 of -0.2 for the total), for every trajectory;
    * rejected steps are few (at most 15 % of the accepted ones overall);
    * ``W_friction_error_estimate`` (the sum of the accepted steps' local
      error estimates of W) is finite, positive where there is friction, no
      larger than what the acceptance test lets through (each accepted step's
      scaled error norm <= 1, so |error of W| <= 2 (atol + rtol |W|) per step),
      and of the order of the actual error: the error at most 30x the
      estimate plus one tolerance unit (rtol max(W, 1)), the estimate at
      most 1e3x the error (above 0.1 tolerance unit, under which an error
      may be a lucky cancellation), and the median ratio between 0.1 and
      1e3.  The estimate is of the embedded 4th-order solution while the
      5th-order one is carried on, so it mostly overestimates, increasingly
      so as rtol shrinks (median 3.5x at 1e-4, 18x at 1e-10).  It omits the
      error of the dense output on which the final event is taken: a
      two-step exit at rtol 1e-4 has an estimate of 8e-8 J for an error of
      1.7e-5 J (0.17 rtol, within tolerance, so allowed);
    * the energy balance |W_friction - W_energy| within 10 rtol of the energy
      changing hands."""
    ramp = QUAD_BOWL
    scene = rw.Scene(ramp=ramp, friction=rw.Friction(0.1), x0=0.0, t_max=30.0)
    sweep = rw.Sweep.grid(x0=[-0.9, -0.5, -0.1, 0.3, 0.7], v0=[-1.5, 0.0, 2.0], mu=[0.1, 0.3])
    refs = reference.reference_sweep(scene, sweep, rtol=1e-13, atol=1e-13)
    assert np.all(np.isin(refs["status"], (STUCK, EXITED)))
    moving = refs["t_end"] > 0
    assert moving.sum() >= 20
    totals, ratios = [], []
    for rtol in HONESTY_RTOLS:
        ds = run(scene.replace(integrator=dopri5(rtol)), sweep)
        assert np.array_equal(ds.status.values, refs["status"]), rtol
        steps, rejected = ds.steps.values, ds.steps_rejected.values
        estimate = ds.W_friction_error_estimate.values
        error = np.abs(ds.W_friction.values - refs["W_friction"])
        w = ds.W_friction.values
        totals.append(steps[moving].sum())
        assert np.all(rejected >= 0) and rejected.sum() <= 0.15 * steps.sum(), (rtol, rejected, steps)
        assert np.all(np.isfinite(estimate)) and np.all(estimate >= 0)
        assert np.all(estimate[moving & (w > 0)] > 0)
        allowed = 2 * steps * (rtol + rtol * w)  # atol = rtol, m = 1
        assert np.all(estimate <= allowed), (rtol, estimate / allowed)
        unit = rtol * np.maximum(1, w)
        assert np.all(error <= 30 * estimate + unit), (rtol, error / (30 * estimate + unit))
        floor = 0.1 * unit  # errors below this may be lucky cancellations
        assert np.all(estimate <= 1e3 * np.maximum(error, floor)), (rtol, estimate / np.maximum(error, floor))
        ratios.append(np.median(estimate[moving] / np.maximum(error[moving], 1e-300)))
        balance = np.abs(ds.energy_balance_error.values)
        assert np.all(balance <= 10 * rtol * energy_changing_hands(ds, ramp)), (rtol, balance)
        if rtol == HONESTY_RTOLS[0]:
            previous = first = steps
        else:
            assert np.all(steps[moving] >= previous[moving]), rtol
            previous = steps
    assert np.all(steps[moving] > first[moving])  # 1e-10 takes more steps than 1e-4, every run
    assert abs(_slope(HONESTY_RTOLS, totals) + 0.2) <= 0.1, totals
    assert all(0.1 <= r <= 1e3 for r in ratios), ratios


def test_first_step_and_largest_step_settings(reference):
    """A first step far too large is rejected, not taken, and costs no
    accuracy; dt_max bounds every step (steps >= t_end / dt_max)."""
    scene = quad_bowl_scene(dopri5(1e-8), friction=rw.Friction(0.15))
    ref = reference.reference_trajectory(scene, rtol=1e-13, atol=1e-13)
    for integrator in (dopri5(1e-8, dt=0.5), dopri5(1e-8, dt=1e-7), dopri5(1e-8, dt_max=0.01)):
        ds = run(scene.replace(integrator=integrator))
        assert val(ds, "status") == STUCK and val(ds, "n_reversals") == ref["n_reversals"]
        for q in QUANTITIES:
            assert abs(val(ds, q) - ref[q]) <= 1e-7 * si_scale(ref[q]), (integrator, q)
        if integrator.dt == 0.5:
            assert val(ds, "steps_rejected") >= 1
        if integrator.dt_max is not None:
            assert val(ds, "steps") >= val(ds, "t_end") / integrator.dt_max


# ------------------------------------------------------------------------------
# 5. determinism
# ------------------------------------------------------------------------------
def _assert_identical(a, b, what):
    for name in a.data_vars:
        assert np.array_equal(a[name].values, b[name].values, equal_nan=True), (what, name)


@pytest.mark.parametrize("method", PAIRS)
def test_pairs_bitwise_identical_whatever_threads_order_and_chunks(method, monkeypatch):
    """Each trajectory carries its own step size, so nothing couples lanes:
    the same trajectory gives the same bits alone or in a sweep, as a grid or
    as cases in another order, on 1 or 2 threads, in one chunk or many."""
    scene = rw.Scene(ramp=rw.Ramp.create("sine", mean_slope=-0.2, amplitude=0.15, wavenumber=3.0,
                                         domain=(-2.0, 2.0)),
                     friction=rw.Friction(0.1), x0=0.0, t_max=5.0,
                     integrator=rw.Integrator(method, rtol=1e-7))
    x0 = np.linspace(-1.8, 1.8, 13)
    v0 = np.array([-2.0, -0.5, 0.0, 0.7, 2.5])
    mu = np.array([0.0, 0.05, 0.2, 0.35])
    grid = run(scene, rw.Sweep.grid(x0=x0, v0=v0, mu=mu))
    assert grid.attrs["threads"] == numba.config.NUMBA_NUM_THREADS
    assert len(set(grid.status.values.ravel().tolist())) >= 3  # a mix of outcomes
    flat = {name: grid[name].values.ravel() for name in grid.data_vars}
    X, V, M = (a.ravel() for a in np.meshgrid(x0, v0, mu, indexing="ij"))
    order = np.random.default_rng(7).permutation(X.size)
    inverse = np.argsort(order)
    cases = rw.Sweep.cases(x0=X[order], v0=V[order], mu=M[order])
    runs = [("cases, 2 threads", {})]
    if numba.config.NUMBA_NUM_THREADS >= 2:
        runs.append(("cases, 1 thread", {"threads": 1}))
    for what, kwargs in runs:
        ds = run(scene, cases, **kwargs)
        for name in grid.data_vars:
            assert np.array_equal(ds[name].values[inverse], flat[name], equal_nan=True), (what, name)
    if numba.config.NUMBA_NUM_THREADS >= 2:
        _assert_identical(grid, run(scene, rw.Sweep.grid(x0=x0, v0=v0, mu=mu), threads=1), "grid, 1 thread")
    from rampwork import runner

    monkeypatch.setattr(runner, "CHUNK_SIZE", 17)  # many chunks, each with its own tiles
    _assert_identical(grid, run(scene, rw.Sweep.grid(x0=x0, v0=v0, mu=mu)), "chunks of 17")
    for j in (0, 101, X.size - 1):  # alone
        alone = run(scene.replace(x0=float(X[j]), v0=float(V[j]), friction=rw.Friction(float(M[j]))))
        for name in grid.data_vars:
            assert np.array_equal(alone[name].values, flat[name][j], equal_nan=True), (j, name)


# ------------------------------------------------------------------------------
# 6. settings, scene files, attributes
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, where", [
    (dict(method="rk4", rtol=1e-6), "integrator.rtol"),
    (dict(method="euler", dt=1e-3, atol=1e-6), "integrator.atol"),
    (dict(method="semi_implicit_euler", dt_max=0.1), "integrator.dt_max"),
    (dict(method="dopri5", rtol=0.5), "integrator.rtol"),
    (dict(method="dopri5", rtol=1e-16), "integrator.rtol"),
    (dict(method="dopri5", rtol=0.0), "integrator.rtol"),
    (dict(method="dopri5", rtol=-1e-6), "integrator.rtol"),
    (dict(method="dopri5", rtol=float("nan")), "integrator.rtol"),
    (dict(method="dopri5", rtol=float("inf")), "integrator.rtol"),
    (dict(method="dopri5", rtol="1e-6"), "integrator.rtol"),
    (dict(method="dopri5", atol=-1.0), "integrator.atol"),
    (dict(method="dopri5", atol=10.0), "integrator.atol"),
    (dict(method="dopri5", dt=-1e-3), "integrator.dt"),
    (dict(method="dopri5", dt_max=0.0), "integrator.dt_max"),
    (dict(method="dopri5", dt=0.1, dt_max=0.01), "integrator.dt"),
    (dict(method="dopri45"), "integrator.method"),
])
def test_integrator_settings_are_checked(kwargs, where):
    with pytest.raises(ConfigError) as info:
        rw.Integrator(**kwargs)
    assert info.value.where == where
    assert str(info.value).startswith(where)


def test_integrator_settings_defaults():
    default = rw.Integrator("dopri5")
    assert default.adaptive and default.rtol == 1e-6 and default.atol == default.rtol
    assert default.dt is None and default.dt_max is None
    tight = rw.Integrator("dopri5", rtol=1e-10)
    assert tight.atol == 1e-10
    assert rw.Integrator("dopri5", rtol=1e-14).rtol == 1e-14 and rw.Integrator("dopri5", rtol=0.1).rtol == 0.1
    assert not rw.Integrator("rk4").adaptive and rw.Integrator("rk4").rtol is None


SCENE_TOML = """
title = "adaptive bowl"
x0 = 0.8
t_max = 20.0

[ramp]
family = "quadratic"
curvature = 1.0
domain = [-1.0, 1.0]

[friction]
mu_k = 0.15

[integrator]
method = "dopri5"
rtol = 1e-7

[sweep]
kind = "grid"
[sweep.axes]
v0 = [0.0, 0.5]
"""


def test_scene_file_with_dopri5_loads_round_trips_and_labels_the_dataset(reference):
    from rampwork.scenefile import dump_scene, parse_scene

    scene, sweep = parse_scene(SCENE_TOML)
    assert scene.integrator == rw.Integrator("dopri5", rtol=1e-7)
    assert scene.integrator.atol == 1e-7 and scene.integrator.dt is None
    text = dump_scene(scene, sweep)
    again, sweep_again = parse_scene(text)
    assert again == scene and sweep_again.axes[0][0] == "v0"
    assert np.array_equal(sweep_again.axes[0][1], sweep.axes[0][1])
    assert dump_scene(again, sweep_again) == text
    # every optional setting survives the round trip too
    full = scene.replace(integrator=rw.Integrator("dopri5", rtol=1e-9, atol=1e-11, dt=1e-4, dt_max=0.05))
    assert parse_scene(dump_scene(full))[0] == full

    ds = run(scene, sweep)
    assert ds.attrs["integrator_method"] == "dopri5"
    assert ds.attrs["integrator_rtol"] == 1e-7 and ds.attrs["integrator_atol"] == 1e-7
    assert ds.attrs["integrator_adaptive"] == 1 and ds.attrs["integrator_order"] == 5
    assert "integrator_dt" not in ds.attrs
    assert "steps_rejected" in ds and "W_friction_error_estimate" in ds
    assert parse_scene(ds.attrs["rampwork_scene"])[0] == scene
    # and the run honours the file's tolerance
    for k, v0 in enumerate(sweep.axes[0][1]):
        ref = reference.reference_trajectory(scene, v0=float(v0), rtol=1e-13, atol=1e-13)
        got = ds.isel(v0=k)
        assert val(got, "status") == ref["status"]
        for q in QUANTITIES:
            assert abs(val(got, q) - ref[q]) <= 10 * 1e-7 * si_scale(ref[q]), q

    with pytest.raises(ConfigError) as info:
        parse_scene(SCENE_TOML.replace('method = "dopri5"', 'method = "rk4"'))
    assert "integrator.rtol" in str(info.value)
    with pytest.raises(ConfigError) as info:
        parse_scene(SCENE_TOML.replace("rtol = 1e-7", "rtol = 1.0"))
    assert "integrator.rtol" in str(info.value)


def test_fixed_step_datasets_report_no_rejections():
    ds = run(quad_bowl_scene(rw.Integrator("rk4", 1e-3)), rw.Sweep.cases(mu=list(QUAD_MUS)))
    assert np.all(ds.steps_rejected.values == 0) and np.all(ds.steps.values > 0)
    assert "W_friction_error_estimate" not in ds
    assert ds.attrs["integrator_dt"] == 1e-3 and "integrator_rtol" not in ds.attrs


@pytest.mark.parametrize("method", ["dopri5", pytest.param("dop853", marks=pytest.mark.slow)])
def test_two_sided_switches_keep_their_step_size(method, reference):
    """A bead on a sine wire switches the side it presses on several times.
    Right after a switch n grows from 0, and the contact control's variation
    test used to refuse every step size there until the step collapsed
    (status diverged where the reference exits): the first step of the new
    mode is exempt.  Against the scipy reference: statuses, end states and
    work to the tolerance."""
    ramp = rw.Ramp.create("sine", mean_slope=-0.2, amplitude=0.15, wavenumber=6.0, domain=(-1.0, 1.0))
    scene = rw.Scene(ramp=ramp, friction=rw.Friction(0.1, 0.3), contact="two_sided", t_max=20.0,
                     integrator=rw.Integrator(method, rtol=1e-9))
    sweep = rw.Sweep.grid(x0=np.linspace(-0.9, 0.9, 7), v0=[-3.0, -0.5, 1.0, 4.0])
    ds = run(scene, sweep)
    ref = reference.reference_sweep(scene, sweep, rtol=1e-12, atol=1e-12)
    assert np.array_equal(ds.status.values, ref["status"])
    assert set(np.unique(ref["status"])) == {STUCK, EXITED}
    # the step size recovers after each switch: rejections stay below the steps taken
    assert np.all(ds.steps_rejected.values <= ds.steps.values)
    for name in ("t_end", "x_end", "v_end", "W_friction"):
        np.testing.assert_allclose(ds[name].values, ref[name], rtol=1e-6, atol=1e-6, err_msg=name)


# 6 attempts (a kernel variant of its own) in the slow suite
@pytest.mark.parametrize("attempts", [2, pytest.param(6, marks=pytest.mark.slow)])
def test_attempts_per_block_change_nothing_and_must_be_even(attempts):
    """Attempts alternate between the two banks of the lane state, and a
    frozen lane's repeated attempts change nothing: 2 or 6 attempts between
    scans give the bits of the default 4 (t_max 0.4 s ends some trajectories
    inside a block); an odd count would leave the state in the other bank and
    is refused before anything is built."""
    from rampwork import runner
    from rampwork.core import kernel as K
    from rampwork.core.variant import KernelVariant

    scene = rw.Scene(ramp=rw.Ramp.create("circular_dome", radius=1.0, domain=(-0.9, 0.9)),
                     friction=rw.Friction(0.1), t_max=0.4, integrator=rw.Integrator("dopri5", rtol=1e-7))
    rng = np.random.default_rng(3)
    sweep = rw.Sweep.cases(x0=rng.uniform(-0.8, 0.8, 300), v0=rng.uniform(-2.0, 2.0, 300),
                           mu=rng.uniform(0.0, 0.4, 300))
    plan = runner.plan_run(scene, sweep)
    inputs = runner.chunk_inputs(plan, 0, plan.size)
    spec = scene.ramp.spec
    results = []
    for substeps in (4, attempts):
        run_batch, _ = K.build_kernel(KernelVariant(spec.key, "dopri5", substeps=substeps),
                                      spec.height, spec.slope_curvature)
        out = np.zeros((K.N_OUTPUTS, plan.size))
        run_batch(inputs, runner._settings(scene), out, scene.ramp.shared_array(), 37)
        results.append(out)
    assert {2, 3, 4} <= set(results[0][K.OUT_STATUS].astype(int))  # exit, lift-off, t_max
    for out in results[1:]:
        assert np.array_equal(out, results[0], equal_nan=True)
    with pytest.raises(ValueError, match="even"):
        KernelVariant(spec.key, "dopri5", substeps=3)
