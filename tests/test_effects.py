"""Scenes compile only the effects they call for (issue 4): the straight-ramp
closed form, the paper's lift-off criterion as a diagnostic, pruned kernels
agreeing with unpruned ones, and the on-disk compile cache."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
from fractions import Fraction

import numpy as np
import pytest

import rampwork as rw
from rampwork import runner
from rampwork.core import kernel as K
from rampwork.core.status import EXITED, LIFTED_OFF, STUCK, TIMEOUT
from rampwork.core.variant import KernelVariant
from rampwork.errors import ConfigError

G = 9.81
DOMAIN = (-2.0, 3.0)


def straight(slope, domain=DOMAIN):
    return rw.Ramp.create("straight", slope=slope, domain=domain)


def stepped(method="rk4", dt=1e-3):
    return rw.Integrator(method, dt, closed_form=False)


# ------------------------------------------------------------------------------
# the straight-ramp closed form
# ------------------------------------------------------------------------------
def test_straight_ramp_uses_the_closed_form_unless_told_not_to():
    sweep = rw.Sweep.grid(v0=[-2.0, 0.5, 3.0])
    exact = rw.simulate(rw.Scene(ramp=straight(-0.3), x0=0.0, friction=rw.Friction(0.2)), sweep)
    steps = rw.simulate(rw.Scene(ramp=straight(-0.3), x0=0.0, friction=rw.Friction(0.2),
                                 integrator=stepped()), sweep)
    assert exact.attrs["kernel_closed_form"] == 1
    assert "closed form" in exact.attrs["kernel_effects"]
    assert int(exact.steps.sum()) == 0  # nothing stepped
    assert steps.attrs["kernel_closed_form"] == 0
    assert int(steps.steps.min()) > 0
    # a quadratic of curvature 0 is straight too: known in advance, same solution
    flat_quadratic = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=0.0, slope=-0.3, domain=DOMAIN),
                              x0=0.0, friction=rw.Friction(0.2))
    again = rw.simulate(flat_quadratic, sweep)
    assert again.attrs["kernel_closed_form"] == 1
    # and a curved ramp is stepped whatever closed_form says
    curved = rw.simulate(flat_quadratic.replace(ramp=rw.Ramp.create(
        "quadratic", curvature=0.5, slope=-0.3, domain=DOMAIN)), sweep)
    assert curved.attrs["kernel_closed_form"] == 0


def _exact_stop(slope, x0, v0, mu_k, g=G):
    """Uphill launch that stops: exact rational arithmetic (Fraction) for the
    stop time, place and friction work per unit mass."""
    slope, x0, v0, mu_k, g = (Fraction(value) for value in (slope, x0, v0, mu_k, g))
    d = 1 if v0 > 0 else -1
    a = -g * (slope + d * mu_k) / (1 + slope * slope)
    t = -v0 / a
    x = x0 + v0 * t + a * t * t / 2
    return float(t), float(x), float(mu_k * g * abs(x - x0))


@pytest.mark.parametrize("slope, v0, mu_k, mu_s", [
    (0.3, 2.0, 0.4, 0.5),    # uphill, friction holds it at the top: stuck
    (-0.25, -1.7, 0.3, 0.3),  # uphill to the left, holds
    (0.0, 1.3, 0.2, 0.2),    # level: stops and stays
])
def test_closed_form_is_exact_to_rounding(slope, v0, mu_k, mu_s):
    x0 = 0.1
    ds = rw.simulate(rw.Scene(ramp=straight(slope), x0=x0, v0=v0, friction=rw.Friction(mu_k, mu_s)))
    t, x, work = _exact_stop(slope, x0, v0, mu_k)
    assert int(ds.status) == STUCK and float(ds.v_end) == 0.0
    assert float(ds.t_end) == pytest.approx(t, rel=4e-16, abs=0)
    assert float(ds.x_end) == pytest.approx(x, rel=4e-16, abs=4e-16)
    assert float(ds.W_friction) == pytest.approx(work, rel=1e-15, abs=0)
    # the energy balance closes to rounding of the energies themselves
    scale = G * abs(slope) * max(abs(x), abs(x0)) + 0.5 * v0 * v0 * (1 + slope * slope)
    assert abs(float(ds.energy_balance_error)) <= 4e-16 * scale


def test_closed_form_timeout_and_exit_are_exact():
    slope, mu_k, x0, v0 = -0.2, 0.1, -1.0, 0.5
    a = Fraction(-G) * (Fraction(slope) + Fraction(mu_k)) / (1 + Fraction(slope) ** 2)
    # downhill (a > 0): at t_max it is still moving
    t_max = 0.75
    ds = rw.simulate(rw.Scene(ramp=straight(slope), x0=x0, v0=v0, friction=rw.Friction(mu_k),
                              t_max=t_max))
    t = Fraction(t_max)
    assert int(ds.status) == TIMEOUT and float(ds.t_end) == t_max
    assert float(ds.x_end) == pytest.approx(float(Fraction(x0) + Fraction(v0) * t + a * t * t / 2), rel=4e-16)
    assert float(ds.v_end) == pytest.approx(float(Fraction(v0) + a * t), rel=4e-16)
    # long enough to reach x_max = 3: v^2 = v0^2 + 2 a (x_max - x0) exactly
    ds = rw.simulate(rw.Scene(ramp=straight(slope), x0=x0, v0=v0, friction=rw.Friction(mu_k)))
    v_exit = math.sqrt(float(Fraction(v0) ** 2 + 2 * a * (Fraction(DOMAIN[1]) - Fraction(x0))))
    assert int(ds.status) == EXITED and float(ds.x_end) == DOMAIN[1]
    assert float(ds.v_end) == pytest.approx(v_exit, rel=1e-15)
    assert float(ds.W_friction) == pytest.approx(mu_k * G * (DOMAIN[1] - x0), rel=1e-15)


def test_closed_form_agrees_with_stepping_everywhere():
    """Over slopes, frictions, static friction and starts (stops, reversals
    that slide back, exits at both ends, starts on an end, timeouts), the
    closed form and RK4 (which integrates constant acceleration exactly and
    locates events to rounding, its 10^3 steps adding up rounding) agree to
    ~1e-11 of the energies involved (up to 50 J/kg here)."""
    sweep = rw.Sweep.grid(slope=[-1.2, -0.3, 0.0, 0.45, 2.0], mu_k=[0.0, 0.25, 0.7],
                          x0=[DOMAIN[0], -0.4, DOMAIN[1]], v0=[-4.0, -0.6, 0.0, 0.9, 5.0])
    scene = rw.Scene(ramp=straight(0.0), friction=rw.Friction(0.0, 0.8), t_max=2.5)
    exact = rw.simulate(scene, sweep)
    steps = rw.simulate(scene.replace(integrator=stepped("rk4", 1e-3)), sweep)
    statuses = set(np.unique(exact.status.values))
    assert {STUCK, EXITED, TIMEOUT} <= statuses
    assert int(exact.n_reversals.max()) == 1  # uphill, then back down
    assert np.array_equal(exact.status.values, steps.status.values)
    assert np.array_equal(exact.n_reversals.values, steps.n_reversals.values)
    for name in ("t_end", "x_end", "v_end", "W_friction", "W_energy", "path_length_x"):
        assert np.allclose(exact[name], steps[name], rtol=1e-10, atol=1e-10), name
    assert np.all(exact.convexity_mean.values == 0.0)
    assert np.all(np.isnan(exact.x_lift_off.values))
    # friction work is mu m g times the path, to rounding
    assert np.allclose(exact.W_friction, exact.W_path, rtol=1e-14, atol=1e-15)


def test_closed_form_records_trajectories():
    scene = rw.Scene(ramp=straight(0.3), x0=0.0, v0=2.0, friction=rw.Friction(0.1, 0.1),
                     record=rw.Record(count=1))
    ds = rw.simulate(scene)
    n = int(ds.trace_length[0])
    t = ds.trace_t.values[0, :n]
    x = ds.trace_x.values[0, :n]
    v = ds.trace_v.values[0, :n]
    assert n > 30 and np.all(np.diff(t) >= 0)
    assert t[0] == 0.0 and x[0] == 0.0 and v[0] == 2.0
    assert (t[-1], x[-1], v[-1]) == (float(ds.t_end), float(ds.x_end), float(ds.v_end))
    assert np.any(v < 0) and np.any(v > 0)  # up, stop, slide back down


# ------------------------------------------------------------------------------
# the paper's lift-off criterion (eq. 26) as a diagnostic
# ------------------------------------------------------------------------------
PAPER = ("x_lift_off_paper",)
DOME = rw.Ramp.create("circular_dome", radius=1.0, domain=(-0.9, 0.9))


def _dome_slope(x):
    return -x / np.sqrt(1.0 - x * x)


# the fixed steps' criterion in the slow suite: the default one locates it
# with Euler on a bowl (test_paper_criterion_located_on_a_bowl)
@pytest.mark.parametrize("integrator", [pytest.param(rw.Integrator("rk4", 1e-3), marks=pytest.mark.slow),
                                        rw.Integrator("dopri5", rtol=1e-9)],
                         ids=["rk4", "dopri5"])
def test_paper_criterion_equals_contact_force_without_friction(integrator):
    """With mu_k = 0, y'' + g = n / (1 + f'^2): both criteria are one."""
    sweep = rw.Sweep.grid(x0=[-0.8, -0.3, 0.0, 0.2], v0=[0.0, 0.4, 1.2, 2.5])
    ds = rw.simulate(rw.Scene(ramp=DOME, integrator=integrator, diagnostics=PAPER), sweep)
    lifted = ds.status.values == LIFTED_OFF
    assert lifted.sum() >= 8
    assert np.array_equal(ds.x_lift_off.values, ds.x_lift_off_paper.values, equal_nan=True)


def test_paper_criterion_disagrees_exactly_where_d_mu_fp_exceeds_one():
    """The criteria differ only where the block slides uphill with d mu_k f' > 1
    (the paper reports lift-off while the surface still pushes); elsewhere the
    paper's criterion fires exactly at the contact-force lift-off."""
    sweep = rw.Sweep.grid(mu=[0.2, 0.6, 0.9, 1.5], x0=np.linspace(-0.88, 0.88, 9),
                          v0=[-3.0, -1.0, 1.0, 3.0])
    ds = rw.simulate(rw.Scene(ramp=DOME, integrator=rw.Integrator("rk4", 1e-3), diagnostics=PAPER),
                     sweep)
    x_paper = ds.x_lift_off_paper.values
    x_lift = ds.x_lift_off.values
    x0 = ds.x0.values[None, :, None] + 0 * x_paper
    mu_k = ds.mu.values[:, None, None] + 0 * x_paper
    differ = ~((x_paper == x_lift) | (np.isnan(x_paper) & np.isnan(x_lift)))
    assert differ.sum() >= 6 and (~differ).sum() >= 100
    # where they differ, the paper's criterion fired first, on a slope where
    # mu |f'| >= 1: either at the start, or exactly where mu |f'| = 1
    assert not np.any(differ & np.isnan(x_paper))
    fires = mu_k[differ] * np.abs(_dome_slope(x_paper[differ]))
    at_start = x_paper[differ] == x0[differ]
    assert np.all(fires[at_start] >= 1.0)
    assert np.allclose(fires[~at_start], 1.0, rtol=1e-12)
    # where mu |f'| < 1 on the whole domain, they can never differ
    never = mu_k * np.abs(_dome_slope(0.9)) < 1.0
    assert np.any(never) and not np.any(differ & never)


def test_paper_criterion_on_a_straight_ramp():
    """Sliding up a slope s with mu_k s > 1 the paper's criterion says lift-off
    at once, while n = g > 0; closed form and stepping say the same."""
    sweep = rw.Sweep.grid(v0=[-2.0, 2.0])  # downhill, uphill
    scene = rw.Scene(ramp=straight(2.0), x0=0.0, friction=rw.Friction(0.6), diagnostics=PAPER)
    for ds in (rw.simulate(scene, sweep), rw.simulate(scene.replace(integrator=stepped()), sweep)):
        assert np.isnan(ds.x_lift_off_paper.values[0]) and ds.x_lift_off_paper.values[1] == 0.0
        assert np.all(np.isnan(ds.x_lift_off.values))


@pytest.mark.parametrize("integrator", [rw.Integrator("euler", 1e-4),
                                        pytest.param(rw.Integrator("dop853", rtol=1e-8),
                                                     marks=pytest.mark.slow)],
                         ids=["euler", "dop853"])
def test_paper_criterion_located_on_a_bowl(integrator):
    """Climbing a bowl y = 2 x^2 the slope steepens: eq. (26) starts to hold
    at mu f'(x) = 1, x = 1 / (4 mu), in the middle of the run (n > 0 all the
    way: a convex ramp is never left).  It is located to rounding, whatever
    the integrator, because it depends on x alone."""
    mu = np.array([1.2, 2.0, 3.0])  # it turns back at x = 0.27, 0.17, 0.11
    sweep = rw.Sweep.grid(mu=mu)
    scene = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=4.0, domain=(-1.0, 1.0)), x0=0.0,
                     v0=6.0, integrator=integrator, diagnostics=PAPER)
    ds = rw.simulate(scene, sweep)
    assert np.all(np.isnan(ds.x_lift_off.values))
    assert np.allclose(ds.x_lift_off_paper.values, 1.0 / (4.0 * mu), rtol=1e-14)


def test_diagnostic_changes_nothing_else():
    sweep = rw.Sweep.grid(mu=[0.1, 0.9], x0=[-0.8, 0.1], v0=[0.5, 2.0])
    scene = rw.Scene(ramp=DOME, integrator=rw.Integrator("rk4", 1e-3))
    plain = rw.simulate(scene, sweep)
    with_diagnostic = rw.simulate(scene.replace(diagnostics=PAPER), sweep)
    assert "x_lift_off_paper" not in plain
    for name in plain.data_vars:
        assert np.array_equal(plain[name].values, with_diagnostic[name].values, equal_nan=True), name


# ------------------------------------------------------------------------------
# pruned kernels give the same results as unpruned ones where both apply
# ------------------------------------------------------------------------------
def run_kernel(plan, **flags):
    """The plan's whole sweep through a kernel built with explicit flags:
    the raw output rows (K.N_OUTPUTS, n)."""
    scene = plan.scene
    spec = scene.ramp.spec
    variant = KernelVariant(spec.key, scene.integrator.method,
                            carry_slope=plan.variant.carry_slope, **flags)
    run_batch, _ = K.build_kernel(variant, spec.height, spec.slope_curvature)
    out = np.zeros((K.N_OUTPUTS, plan.size))
    run_batch(runner.chunk_inputs(plan, 0, plan.size), runner._settings(scene), out,
              scene.ramp.shared_array(), 64)
    return out


# (each case builds two kernels: RK4 in the default run, the others slow)
@pytest.mark.parametrize("method", [pytest.param("euler", marks=pytest.mark.slow), "rk4",
                                    pytest.param("dopri5", marks=pytest.mark.slow)])
def test_no_lift_off_check_on_convex_ramps_changes_nothing(method):
    """f'' >= 0: the runner leaves the contact check out; the kernel with the
    check gives bit-identical results."""
    integrator = rw.Integrator(method, rtol=1e-8) if method == "dopri5" else rw.Integrator(method, 1e-3)
    scene = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=1.5, domain=(-1.0, 1.0)),
                     friction=rw.Friction(0.15, 0.25), integrator=integrator, t_max=20.0)
    sweep = rw.Sweep.grid(x0=np.linspace(-0.9, 0.9, 7), v0=[-2.0, 0.0, 1.0])
    plan = runner.plan_run(scene, sweep)
    assert not plan.variant.check_contact
    results = [run_kernel(plan, check_contact=check) for check in (False, True)]
    assert np.array_equal(results[0], results[1], equal_nan=True)
    assert set(results[0][K.OUT_STATUS].astype(int)) >= {STUCK}


# (compile-heavy: each case builds two kernels; rk4 stays in the default run)
@pytest.mark.parametrize("method", [pytest.param("euler", marks=pytest.mark.slow), "rk4",
                                    pytest.param("dopri5", marks=pytest.mark.slow),
                                    pytest.param("dop853", marks=pytest.mark.slow)])
def test_no_friction_branch_when_mu_is_zero_changes_nothing(method):
    """mu_k = 0 everywhere: the runner compiles no kinetic friction (the
    acceleration without its friction term, no friction work); the kernel with
    friction, run on the same mu = 0 inputs, gives the same results (to the
    sign of a zero: array_equal treats -0.0 == 0.0).  On a dome with lift-offs,
    reversals, stops (mu_s > 0) and exits, one- and two-sided."""
    integrator = (rw.Integrator(method, rtol=1e-8) if method in ("dopri5", "dop853")
                  else rw.Integrator(method, 1e-3))
    for contact in ("one_sided", "two_sided"):
        scene = rw.Scene(ramp=rw.Ramp.create("sine", mean_slope=-0.2, amplitude=0.15, wavenumber=6.0,
                                             domain=(-1.0, 1.0)),
                         friction=rw.Friction(0.0, 0.3), integrator=integrator, contact=contact,
                         t_max=20.0)
        sweep = rw.Sweep.grid(x0=np.linspace(-0.9, 0.9, 7), v0=[-3.0, -0.5, 0.0, 1.0, 4.0])
        plan = runner.plan_run(scene, sweep)
        assert not plan.variant.friction
        ds = rw.simulate(scene, sweep)
        assert "no friction" in ds.attrs["kernel_effects"]
        assert np.all(ds.W_friction.values == 0.0)
        results = [run_kernel(plan, one_sided=contact == "one_sided",
                              check_contact=plan.variant.check_contact, friction=friction)
                   for friction in (False, True)]
        assert np.array_equal(results[0], results[1], equal_nan=True), contact
        statuses = set(results[0][K.OUT_STATUS].astype(int))
        assert {STUCK, EXITED} <= statuses, statuses
        if contact == "one_sided":
            assert LIFTED_OFF in statuses


# (each case builds two kernels: RK4 in the default run, the others slow)
@pytest.mark.parametrize("method", [pytest.param("euler", marks=pytest.mark.slow), "rk4",
                                    pytest.param("dopri5", marks=pytest.mark.slow),
                                    pytest.param("dop853", marks=pytest.mark.slow)])
def test_uniform_parameters_in_registers_change_nothing(method):
    """g and the ramp's shape not swept: the lane loops take them from the
    run's settings instead of each lane; bit-identical results."""
    integrator = (rw.Integrator(method, rtol=1e-8) if method in ("dopri5", "dop853")
                  else rw.Integrator(method, 1e-3))
    scene = rw.Scene(ramp=rw.Ramp.create("sine", mean_slope=-0.2, amplitude=0.15, wavenumber=6.0,
                                         domain=(-1.0, 1.0)),
                     friction=rw.Friction(0.1, 0.3), integrator=integrator, t_max=20.0)
    sweep = rw.Sweep.grid(x0=np.linspace(-0.9, 0.9, 7), v0=[-3.0, -0.5, 0.0, 1.0, 4.0])
    plan = runner.plan_run(scene, sweep)
    assert plan.variant.uniform_parameters
    assert not runner.plan_run(scene, rw.Sweep.grid(x0=[0.1], g=[9.81, 3.7])).variant.uniform_parameters
    results = [run_kernel(plan, check_contact=plan.variant.check_contact, uniform_parameters=uniform)
               for uniform in (False, True)]
    assert np.array_equal(results[0], results[1], equal_nan=True)
    assert {STUCK, EXITED, LIFTED_OFF} <= set(results[0][K.OUT_STATUS].astype(int))


@pytest.mark.parametrize("method", ["euler", pytest.param("rk4", marks=pytest.mark.slow), "dopri5",
                                    pytest.param("dop853", marks=pytest.mark.slow)])
def test_constant_curvature_needs_no_curvature_integral(method):
    """A quadratic ramp's f'' is one number: the kernel built for that
    reports f'' itself as its mean; fixed-step kernels also skip the
    curvature integral.  Every other output is bit-identical.  (Adaptive
    pairs keep integrating it: it is a component of their error norm, and
    dropping it would change the step sizes and so the results.)"""
    adaptive = method in ("dopri5", "dop853")
    integrator = rw.Integrator(method, rtol=1e-9, atol=1e-9) if adaptive else rw.Integrator(method, 1e-3)
    curvature = 1.5
    scene = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=curvature, slope=0.3,
                                         domain=(-1.0, 1.0)),
                     friction=rw.Friction(0.15, 0.25), integrator=integrator, t_max=20.0)
    sweep = rw.Sweep.grid(x0=np.linspace(-0.9, 0.9, 7), v0=[-3.0, -1.0, 0.0, 1.0, 4.0])
    plan = runner.plan_run(scene, sweep)
    general, constant = (run_kernel(plan, check_contact=plan.variant.check_contact,
                                    constant_curvature=flag) for flag in (False, True))
    assert np.all(constant[K.OUT_CONVEXITY] == curvature)
    moved = general[K.OUT_PATH] > 0.0
    assert moved.sum() > 20
    np.testing.assert_allclose(general[K.OUT_CONVEXITY][moved], curvature, rtol=1e-9)
    assert {STUCK, EXITED} <= set(general[K.OUT_STATUS].astype(int))
    others = [row for row in range(K.N_OUTPUTS) if row != K.OUT_CONVEXITY]
    assert np.array_equal(general[others], constant[others], equal_nan=True)


def test_effects_in_words_and_refused_combinations():
    bowl = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0)), x0=0.5)
    words = runner.plan_run(bowl.replace(friction=rw.Friction(0.2), drag=rw.Drag(quadratic=0.1))).effects
    assert "kinetic friction" in words and "air drag (quadratic)" in words
    assert "one-sided contact, no lift-off check (f'' >= 0)" in words
    # drag makes a straight ramp stepped
    assert not runner.plan_run(rw.Scene(ramp=straight(0.1), x0=0.0, drag=rw.Drag(linear=0.5))).variant.closed_form
    # eq. (26) is the paper's, for friction without drag
    with pytest.raises(ConfigError, match="diagnostics.*drag"):
        rw.simulate(bowl.replace(drag=rw.Drag(linear=0.5), diagnostics=PAPER))


# ------------------------------------------------------------------------------
# compile cache: a second process loads the kernel instead of compiling it
# ------------------------------------------------------------------------------
_CACHE_PROBE = textwrap.dedent("""
    import json, rampwork as rw
    from rampwork import kernels
    scene = rw.Scene(ramp=rw.Ramp.create("straight", slope=0.3, domain=(-1.0, 1.0)), x0=0.0, v0=1.0,
                     friction=rw.Friction(0.2))
    ds = rw.simulate(scene)
    run_batch = next(iter(kernels._KERNELS.values()))[0]
    print(json.dumps({"compile": ds.attrs["compile_time_s"], "hits": sum(run_batch.stats.cache_hits.values()),
                      "misses": sum(run_batch.stats.cache_misses.values())}))
""")


def test_second_process_loads_the_kernel_from_the_disk_cache(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    runs = []
    for _ in range(2):
        done = subprocess.run([sys.executable, "-c", _CACHE_PROBE], env=env, capture_output=True,
                              text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
    cold, warm = runs
    assert cold["misses"] >= 1 and cold["hits"] == 0
    assert warm["misses"] == 0 and warm["hits"] >= 1
    assert warm["compile"] < cold["compile"]


# ------------------------------------------------------------------------------
# bad input
# ------------------------------------------------------------------------------
def test_bad_effect_settings_are_refused():
    with pytest.raises(ConfigError, match=r"diagnostics\[0\].*x_lift_off_paper"):
        rw.Scene(ramp=DOME, diagnostics=("lift_off_eq26",))
    with pytest.raises(ConfigError, match="diagnostics"):
        rw.Scene(ramp=DOME, diagnostics="x_lift_off_paper")
    with pytest.raises(ConfigError, match="integrator.closed_form"):
        rw.Integrator("rk4", closed_form="yes")


def test_scene_file_round_trip_keeps_the_effects():
    from rampwork.scenefile import dump_scene, parse_scene

    scene = rw.Scene(ramp=straight(0.2), x0=0.0, integrator=stepped("euler", 1e-4), diagnostics=PAPER)
    text = dump_scene(scene)
    assert "closed_form = false" in text and 'diagnostics = ["x_lift_off_paper"]' in text
    again, _ = parse_scene(text)
    assert again == scene
    with pytest.raises(ConfigError, match="integrator.closed_form"):
        parse_scene(text.replace("closed_form = false", "closed_form = 0"))
    with pytest.raises(ConfigError, match="diagnostics"):
        parse_scene(text.replace('diagnostics = ["x_lift_off_paper"]', 'diagnostics = "x_lift_off_paper"'))
