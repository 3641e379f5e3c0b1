"""The general kernel (choices at run time) against the specialised kernels.

A scene first runs on the general kernel of its kind, compiled once per
machine; large runs hand over to the scene's specialised kernel.  Both are
built from the same templates, so every trajectory must come out equal (to
the sign of a zero: ``array_equal`` treats -0.0 == 0.0, as the pruning tests
do) whatever tier ran it, on event-rich sweeps: stops, reversals, exits,
lift-offs, contact switches, t_max and divergence, with and without drag.
"""

from __future__ import annotations

import numpy as np
import pytest

import rampwork as rw
from rampwork import kernels, runner
from rampwork.core import kernel as K
from rampwork.core.status import DIVERGED, EXITED, LIFTED_OFF, STUCK, TIMEOUT

FIXED = ("euler", "semi_implicit_euler", "rk4")
ADAPTIVE = ("dopri5", "dop853")

RAMPS = {
    "quadratic": dict(curvature=-1.2, slope=0.2, domain=(-1.0, 1.0)),
    "circular_bowl": dict(radius=1.0, domain=(-0.9, 0.9)),
    "circular_dome": dict(radius=1.0, domain=(-0.9, 0.9)),
    "sine": dict(mean_slope=-0.2, amplitude=0.15, wavenumber=6.0, domain=(-1.0, 1.0)),
    "cycloid": dict(radius=0.5, domain=(-1.2, 1.2)),
    "spline": dict(x_points=[-1.0, -0.3, 0.2, 1.0], y_points=[0.6, 0.0, 0.1, 0.5]),
}


def integrator(method, dt=1e-3):
    return rw.Integrator(method, rtol=1e-7) if method in ADAPTIVE else rw.Integrator(method, dt)


def event_rich(family, method, **changes):
    scene = rw.Scene(ramp=rw.Ramp.create(family, **RAMPS[family]), friction=rw.Friction(0.1, 0.3),
                     integrator=integrator(method), t_max=3.0)
    scene = scene.replace(**changes)
    lo, hi = scene.ramp.domain
    rng = np.random.default_rng(5)
    n = 96
    sweep = rw.Sweep.cases(x0=rng.uniform(lo + 0.05 * (hi - lo), hi - 0.05 * (hi - lo), n),
                           v0=rng.uniform(-3.0, 3.0, n), mu=rng.choice([0.0, 0.05, 0.3, 0.6], n))
    return scene, sweep


def both_tiers(scene, sweep):
    """The dataset from the specialised and from the general kernel."""
    return (rw.simulate(scene, sweep, kernel="specialised"),
            rw.simulate(scene, sweep, kernel="general"))


def assert_same(specialised, general):
    assert specialised.attrs["kernel_tier"] == "specialised"
    assert general.attrs["kernel_tier"] == "general"
    for name in specialised.variables:  # recorded trajectories too, where there are any
        assert np.array_equal(specialised[name].values, general[name].values, equal_nan=True), name


# each case compiles a specialised kernel: the dome in the default run, the
# sine (and every other family, effect and method below) in the slow one
@pytest.mark.parametrize("method", FIXED + ADAPTIVE)
@pytest.mark.parametrize("family", ["circular_dome", pytest.param("sine", marks=pytest.mark.slow)])
def test_general_equals_specialised(family, method):
    scene, sweep = event_rich(family, method)
    specialised, general = both_tiers(scene, sweep)
    assert_same(specialised, general)
    statuses = set(specialised.status.values.astype(int))
    assert {STUCK, EXITED} <= statuses, statuses
    assert LIFTED_OFF in statuses or TIMEOUT in statuses


@pytest.mark.parametrize("family", [family if family in ("spline", "cycloid")
                                    else pytest.param(family, marks=pytest.mark.slow)
                                    for family in sorted(RAMPS)])
def test_every_family_through_the_switch(family):
    scene, sweep = event_rich(family, "rk4")
    assert_same(*both_tiers(scene, sweep))


@pytest.mark.parametrize("method", [pytest.param("euler", marks=pytest.mark.slow), "rk4",
                                    pytest.param("dopri5", marks=pytest.mark.slow)])
# one drag term alone (the other a no-op) in the slow suite: two-sided
# without drag has both no-ops, the drag mix both terms
@pytest.mark.parametrize("effects", [dict(contact="two_sided"),
                                     pytest.param(dict(drag=rw.Drag(linear=0.4)), marks=pytest.mark.slow),
                                     pytest.param(dict(drag=rw.Drag(quadratic=0.3)), marks=pytest.mark.slow),
                                     dict(drag=rw.Drag(linear=0.2, quadratic=0.2),
                                          contact="two_sided"),
                                     dict(diagnostics=("x_lift_off_paper",)),
                                     dict(record=rw.Record(count=4, every=25, max_samples=400)),
                                     dict(friction=rw.Friction(0.0))])
def test_general_equals_specialised_with_effects(method, effects):
    scene, sweep = event_rich("sine", method, **effects)
    if "friction" in effects:  # mu = 0 everywhere: no friction branch in the specialised
        sweep = rw.Sweep.cases(x0=sweep.values("x0"), v0=sweep.values("v0"))
    assert_same(*both_tiers(scene, sweep))


# dopri5's loose end in the slow suite (its tiers are compared in the default
# one by test_general_equals_specialised)
@pytest.mark.parametrize("method", ["euler", pytest.param("dopri5", marks=pytest.mark.slow)])
def test_general_equals_specialised_where_steps_diverge(method):
    """Steps far too large: divergence and the speed bound at block ends."""
    scene, sweep = event_rich("circular_bowl", method)
    scene = scene.replace(integrator=rw.Integrator(method, 0.2) if method == "euler"
                          else rw.Integrator(method, rtol=1e-2, atol=1e-2))
    specialised, general = both_tiers(scene, sweep)
    assert_same(specialised, general)
    if method == "euler":
        assert DIVERGED in set(specialised.status.values.astype(int))


def test_auto_picks_a_ready_general_kernel_until_the_specialised_one_is_cached(monkeypatch):
    monkeypatch.delenv("RAMPWORK_KERNEL", raising=False)  # (CI also runs with it set)
    scene, sweep = event_rich("sine", "semi_implicit_euler", t_max=1.0)
    plan = runner.plan_run(scene, sweep)
    rw.simulate(scene, sweep, kernel="general")  # the general kernel is loaded
    kernels._KERNELS.pop(plan.variant, None)
    monkeypatch.setattr(kernels, "disk_cached", lambda kernel: False)
    assert rw.simulate(scene, sweep).attrs["kernel_tier"] == "general"
    monkeypatch.setattr(kernels, "disk_cached", lambda kernel: True)
    assert rw.simulate(scene, sweep).attrs["kernel_tier"] == "specialised"


def test_a_bad_tier_is_refused():
    scene, sweep = event_rich("sine", "rk4")
    with pytest.raises(rw.ConfigError, match="kernel"):
        rw.simulate(scene, sweep, kernel="fast")


def test_a_long_run_hands_over_to_the_specialised_kernel(monkeypatch):
    """A run that starts on the general kernel compiles its specialised kernel
    in the background and takes it for the chunks after it is ready: the
    dataset equals a run on the specialised kernel alone."""
    monkeypatch.delenv("RAMPWORK_KERNEL", raising=False)
    scene, sweep = event_rich("circular_dome", "rk4")
    rng = np.random.default_rng(9)
    lo, hi = scene.ramp.domain
    sweep = rw.Sweep.cases(x0=rng.uniform(lo + 0.1, hi - 0.1, 3000), v0=rng.uniform(-3, 3, 3000),
                           mu=rng.uniform(0.0, 0.5, 3000))
    alone = rw.simulate(scene, sweep, kernel="specialised")
    choose = kernels.choose_tier
    monkeypatch.setattr(kernels, "choose_tier",  # start on the general kernel once
                        lambda plan, kernel=None: "general" if kernel is None else choose(plan, kernel))
    monkeypatch.setattr(runner, "GENERAL_CHUNK", 16)
    monkeypatch.setattr(runner, "SPECIALISE_AFTER_S", 0.0)
    handed = rw.simulate(scene, sweep)
    assert handed.attrs["kernel_tier"] == "general, then specialised"
    for name in alone.data_vars:
        assert np.array_equal(alone[name].values, handed[name].values, equal_nan=True), name


def test_a_short_or_forced_run_keeps_its_tier():
    scene, sweep = event_rich("circular_dome", "rk4")
    assert rw.simulate(scene, sweep, kernel="general").attrs["kernel_tier"] == "general"


def test_a_failed_background_compilation_loses_nothing(monkeypatch):
    """The hand-over never costs the run: if the specialised kernel does not
    compile, the general kernel finishes the run (with a warning)."""
    monkeypatch.delenv("RAMPWORK_KERNEL", raising=False)
    scene, sweep = event_rich("circular_dome", "rk4")
    alone = rw.simulate(scene, sweep, kernel="specialised")
    choose = kernels.choose_tier
    monkeypatch.setattr(kernels, "choose_tier",
                        lambda plan, kernel=None: "general" if kernel is None else choose(plan, kernel))
    prepare = runner.prepare

    def failing(plan, kernel=None):
        if kernel == "specialised":
            raise MemoryError("no room to compile")
        return prepare(plan, kernel)

    monkeypatch.setattr(runner, "prepare", failing)
    monkeypatch.setattr(runner, "GENERAL_CHUNK", 8)
    monkeypatch.setattr(runner, "SPECIALISE_AFTER_S", 0.0)
    with pytest.warns(RuntimeWarning, match="did not compile"):
        ds = rw.simulate(scene, sweep)
    assert_same(alone, ds)
