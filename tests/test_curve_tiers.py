"""A curve's two kernel tiers (rampwork.curves.curve_tier) give the same bits.

The general kernel of a curve is its specialised kernel with friction and
both drag terms compiled in; a zero coefficient must make each an exact
no-op.  The adaptive pairs' error norm counts a work integral only for a
trajectory that has it, so a trajectory also steps as it would alone,
whatever the rest of its sweep holds.  The default suite checks the loop
(reversals, stops, lift-offs, exits) with RK4 and dopri5 on both contacts;
the slow suite every method and every family (SLOW_CASES).
"""

from __future__ import annotations

import numpy as np
import pytest

import rampwork as rw
from rampwork import curves
from rampwork.core.curve_steppers import CURVE_STEPPERS
from rampwork.curve_scene import CurveScene
from rampwork.curves import Curve, prepare_curve_run
from rampwork.errors import ConfigError

N = 240
CURVES = {
    "loop": lambda: Curve.create("loop", radius=1.0),
    "quarter_pipe": lambda: Curve.create("quarter_pipe", radius=1.0, flat_length=0.5),
    "graph_sine": lambda: Curve.from_ramp(rw.Ramp.create("sine", domain=(-1.0, 1.0),
                                                         amplitude=0.1, wavenumber=6.0)),
    "loop_track": lambda: Curve.create("loop_track", radius=1.0, blend_length=0.0),
}


def _arguments(curve, method, contact, effects, seed=3):
    """Random starts; ``effects``: which of friction, drag_linear and
    drag_quadratic the sweep has (zero in some of its trajectories)."""
    lo, hi = (float(v[0]) for v in curve.domain())
    rng = np.random.default_rng(seed)
    u0 = rng.uniform(-7.0, 7.0, N)
    u0[::9] = 0.0  # at rest: the rest rule

    def some(values):
        return values * (rng.uniform(size=N) < 0.6)

    return dict(s0=rng.uniform(lo, hi, N), u0=u0, method=method,
                mu_k=some(rng.uniform(0.05, 0.4, N)) if "friction" in effects else 0.0,
                drag_linear=some(rng.uniform(0.0, 0.3, N)) if "drag_linear" in effects else 0.0,
                drag_quadratic=some(rng.uniform(0.0, 0.3, N)) if "drag_quadratic" in effects else 0.0,
                dt=2e-3, rtol=1e-7, t_max=2.0, contact=contact)


def _same_bits(a, b):
    for name in a:
        floats = a[name].dtype.kind == "f"
        assert np.array_equal(a[name], b[name], equal_nan=floats), name


def _tiers_agree(name, method, contact, effects):
    curve = CURVES[name]()
    arguments = _arguments(curve, method, contact, effects)
    general = prepare_curve_run(curve, kernel="general", **arguments)
    specialised = prepare_curve_run(curve, kernel="specialised", **arguments)
    assert (general.tier, specialised.tier) == ("general", "specialised")
    _same_bits(general.run(), specialised.run())


# two-sided RK4 (a specialised variant of its own) in the slow suite
@pytest.mark.parametrize("method, contact", [
    ("rk4", "one_sided"), ("dopri5", "one_sided"), ("dopri5", "two_sided"),
    pytest.param("rk4", "two_sided", marks=pytest.mark.slow)])
def test_general_equals_specialised_on_the_loop(method, contact):
    # friction in some trajectories, no drag: the general kernel's drag terms
    # and (for dopri5) its friction-free trajectories' norms are no-ops
    _tiers_agree("loop", method, contact, ("friction",))


#: every method on the loop with no effect at all (all three terms no-ops),
#: every other family with the two kinds of method (fixed step, adaptive
#: pair) and a different mix, and two-sided contact with both drags' mix: a
#: cover of the no-op gates (each method's stages, the pairs' norm, each
#: family's frame) at 24 kernel variants at most, not the full product's ~200
SLOW_CASES = (
    *((("loop", method, "one_sided", ()) for method in CURVE_STEPPERS)),
    *((("graph_sine", method, "one_sided", ("friction",)) for method in ("rk4", "dopri5"))),
    *((("quarter_pipe", method, "one_sided", ("drag_linear",)) for method in ("rk4", "dopri5"))),
    *((("loop_track", method, "one_sided", ("friction", "drag_quadratic"))
       for method in ("euler", "dop853"))),
    *((("loop", method, "two_sided", ("friction", "drag_quadratic"))
       for method in ("semi_implicit_euler", "dop853"))),
)


@pytest.mark.slow
@pytest.mark.parametrize("name, method, contact, effects", SLOW_CASES)
def test_general_equals_specialised_everywhere(name, method, contact, effects):
    _tiers_agree(name, method, contact, effects)


# dopri5 beside friction (the variant of the tier test above), dop853 (slow)
# beside friction and drag: each integral the RMS may count, in one of them
@pytest.mark.parametrize("method, effects", [
    ("dopri5", ("friction",)),
    pytest.param("dop853", ("friction", "drag_linear"), marks=pytest.mark.slow)])
def test_a_trajectory_steps_as_it_would_alone(method, effects):
    """Without friction or drag, an adaptive trajectory's steps do not depend
    on its neighbours having them (before, the RMS counted their integrals)."""
    curve = CURVES["loop"]()
    mixed = _arguments(curve, method, "one_sided", effects)
    bare = (mixed["mu_k"] == 0.0) & (mixed["drag_linear"] == 0.0)
    assert 20 < bare.sum() < N - 20
    together = prepare_curve_run(curve, kernel="specialised", **mixed).run()
    alone_arguments = {**mixed, "s0": mixed["s0"][bare], "u0": mixed["u0"][bare],
                       "mu_k": 0.0, "drag_linear": 0.0}
    alone = prepare_curve_run(curve, kernel="specialised", **alone_arguments)
    assert alone.kernel is not together  # the friction-free variant
    result = alone.run()
    _same_bits(result, {name: values[bare] for name, values in together.items()})
    assert len(set(result["status_name"])) >= 2  # not one outcome only


def test_auto_runs_small_sweeps_on_the_general_kernel_until_the_specialised_is_compiled(
        monkeypatch):
    curve = CURVES["loop"]()
    spec = curve.spec
    effects = dict(one_sided=True, friction=False, drag_linear=True, drag_quadratic=False,
                   joints=0)
    specialised = curves.curve_kernel_for(spec, "semi_implicit_euler", **effects)
    if specialised.run_tiles.overloads:
        pytest.skip("this process compiled the specialised kernel already")
    monkeypatch.delenv("RAMPWORK_KERNEL", raising=False)  # CI runs the suite with it set
    monkeypatch.setattr("rampwork.core.jit.disk_cached", lambda dispatcher: False)
    tier = curves.curve_tier
    assert tier(spec, "semi_implicit_euler", None, 100, **effects) == "general"
    assert tier(spec, "semi_implicit_euler", "auto", curves.GENERAL_MAX_CASES, **effects) == "general"
    assert tier(spec, "semi_implicit_euler", "auto", curves.GENERAL_MAX_CASES + 1,
                **effects) == "specialised"  # a long run: the specialised kernel pays
    assert tier(spec, "semi_implicit_euler", "specialised", 100, **effects) == "specialised"
    monkeypatch.setattr("rampwork.core.jit.disk_cached", lambda dispatcher: True)
    assert tier(spec, "semi_implicit_euler", "auto", 100, **effects) == "specialised"
    monkeypatch.setenv("RAMPWORK_KERNEL", "general")
    assert tier(spec, "semi_implicit_euler", None, 100, **effects) == "general"
    with pytest.raises(ConfigError, match="unknown kernel tier 'fast'"):
        tier(spec, "semi_implicit_euler", "fast", 100, **effects)


def test_a_curve_scene_says_which_tier_ran():
    scene = CurveScene(curve=CURVES["loop"](), s0=0.0, u0=6.0,
                       integrator=rw.Integrator("rk4", dt=2e-3), t_max=2.0)
    sweep = rw.Sweep.grid(mu=[0.0, 0.1])
    general = rw.simulate(scene, sweep, kernel="general")
    specialised = rw.simulate(scene, sweep, kernel="specialised")
    assert general.attrs["kernel_tier"] == "general"
    assert specialised.attrs["kernel_tier"] == "specialised"
    for name in general.data_vars:
        assert np.array_equal(general[name].values, specialised[name].values), name
