"""The sine family's evaluation at a fixed step's stage points and end by the
angle sum from the step's start (``core.ramps.sine_slope_curvature_near`` and
its short form ``sine_slope_curvature_short``) against long-double values,
and the plan's bound that selects the short form.

The reference is f', f'' at the exact stage point: the argument at the step's
start as the code rounds it, theta0 = fl(k x0 + phase), plus the exact k dx
(the argument's own rounding is the same for any evaluation at x0).  Errors
are in ulp of the terms' scale: |p0| + |A k| for f' and, for f'', A k^2 +
k |sin(k dx)| (|p0| + |A k|) (u = f'(x0) - p0 carries the rounding of f'(x0)).
The same measure of the direct evaluation at fl(x0 + dx) is printed beside
(measured: near <= 2.7 and 3.0 ulp for |k dx| <= 0.8, direct 1.8 and 2.2;
the short form 3.5 and 3.0 for |k dx| <= 1/16, the same as the reduced
form's on the same pairs).
"""

import numpy as np
import pytest

import rampwork as rw
from rampwork import runner
from rampwork.core import ramps as R
from rampwork.core.jit import jit


@jit
def _evaluate(x, dx, m, a, k, phase, out):
    for i in range(x.size):
        fp, fpp = R.sine_slope_curvature(x[i], m[i], a[i], k[i], phase[i], None)
        out[0, i], out[1, i] = R.sine_slope_curvature_near(x[i] + dx[i], dx[i], fp, fpp,
                                                           m[i], a[i], k[i], phase[i], None)


@jit
def _evaluate_short(x, dx, m, a, k, phase, out):
    for i in range(x.size):
        fp, fpp = R.sine_slope_curvature(x[i], m[i], a[i], k[i], phase[i], None)
        out[0, i], out[1, i] = R.sine_slope_curvature_short(x[i] + dx[i], dx[i], fp, fpp,
                                                            m[i], a[i], k[i], phase[i], None)


def errors(n, kdx_max, seed, evaluate=_evaluate, edges=False):
    """Max errors (f', f'') in ulp of their scales over n random (x0, dx)
    (``edges``: with |k dx| = kdx_max exactly, 0 and the smallest normals
    among them)."""
    rng = np.random.default_rng(seed)
    m = rng.uniform(-1, 1, n) * 10.0 ** rng.uniform(-3, 1, n)
    a = rng.uniform(-1, 1, n) * 10.0 ** rng.uniform(-3, 0, n)
    k = 10.0 ** rng.uniform(-1, 2, n)
    phase = rng.uniform(-4, 4, n)
    x = rng.uniform(-1, 1, n) * 10.0 ** rng.uniform(-2, 2, n)
    kdx = rng.uniform(-1, 1, n) * 10.0 ** rng.uniform(-6, np.log10(kdx_max), n)
    dx = kdx / k
    if edges:
        dx[:n // 8] = np.copysign(kdx_max, kdx[:n // 8]) / k[:n // 8]
        dx[n // 8:n // 8 + 100] = 0.0
        dx[n // 8 + 100:n // 8 + 200] = 2.2250738585072014e-308
    out = np.empty((2, n))
    evaluate(x, dx, m, a, k, phase, out)
    L = np.longdouble
    theta = L(k * x + phase) + L(k) * L(dx)
    fp_exact = L(m) + L(a) * L(k) * np.cos(theta)
    fpp_exact = -L(a) * L(k) * L(k) * np.sin(theta)
    scale_fp = np.abs(m) + np.abs(a * k)
    scale_fpp = np.abs(a) * k * k + k * np.abs(np.sin(k * dx)) * scale_fp
    e_fp = np.abs((out[0] - fp_exact) / np.spacing(scale_fp)).astype(float)
    e_fpp = np.abs((out[1] - fpp_exact) / np.spacing(scale_fpp)).astype(float)
    return e_fp.max(), e_fpp.max()


def test_stage_points_within_a_few_ulp():
    """RK4's stage offsets: |k dx| <= k |v| h, below 0.8 for any step of
    at least 8 per wavelength; measured 2.7 and 3.0 ulp over 10**6 pairs."""
    e_fp, e_fpp = errors(1_000_000, 0.8, seed=31)
    assert e_fp < 4.0 and e_fpp < 4.0, (e_fp, e_fpp)


def test_long_stages_stay_accurate():
    """Beyond pi/4 the short reduction y = n pi/2 + r takes over: a step over
    several wavelengths (|k dx| up to 20) still gives f', f'' to ~10 ulp
    (measured 12.5 and 10.0 over 10**6 pairs: the quadrant's 1 + (cos r - 1)
    and the terms' sum)."""
    e_fp, e_fpp = errors(1_000_000, 20.0, seed=32)
    assert e_fp < 16.0 and e_fpp < 16.0, (e_fp, e_fpp)


def test_short_form_within_a_few_ulp():
    """The short form (no reduction, no division, series to z^3 and z^4) for
    |k dx| <= SHORT_STAGE_ANGLE = 1/16, an eighth of the pairs at the bound
    itself: measured 3.5 and 3.0 ulp over 10**6 pairs, the reduced form's
    figures on the same pairs (beyond the bound the series' error grows as
    (k dx)^9: 150 ulp at 1/8)."""
    e_fp, e_fpp = errors(1_000_000, R.SHORT_STAGE_ANGLE, seed=33, evaluate=_evaluate_short,
                         edges=True)
    assert e_fp < 4.0 and e_fpp < 4.0, (e_fp, e_fpp)


@pytest.mark.parametrize("k", [0.0, -0.0])
def test_flat_and_zero_wavenumber(k):
    """k = 0: f' = mean slope, f'' = 0 at every stage, no NaN."""
    x = np.array([0.3, -2.0])
    dx = np.array([0.01, -5.0])
    out = np.empty((2, 2))
    _evaluate(x, dx, np.full(2, 0.2), np.full(2, 0.1), np.full(2, k), np.full(2, 0.4), out)
    assert np.array_equal(out[0], [0.2, 0.2]) and np.all(out[1] == 0.0)
    out = np.empty((2, 2))
    _evaluate_short(x, dx * 1e-3, np.full(2, 0.2), np.full(2, 0.1), np.full(2, k), np.full(2, 0.4),
                    out)
    assert np.array_equal(out[0], [0.2, 0.2]) and np.all(out[1] == 0.0)


# -- the plan's choice of the short form ---------------------------------------

SINE = dict(amplitude=0.1, wavenumber=6.0, phase=0.3)


def sine_scene(dt=1e-3, **ramp):
    return rw.Scene(ramp=rw.Ramp.create("sine", domain=(-1.0, 1.0), **{**SINE, **ramp}),
                    friction=rw.Friction(mu_k=0.2), t_max=3.0, integrator=rw.Integrator("rk4", dt))


def starts(v0_max=4.0, n=9):
    return rw.Sweep.grid(x0=np.linspace(-0.9, 0.9, n), v0=np.linspace(-v0_max, v0_max, n),
                         mu=[0.02, 0.3])


@pytest.mark.parametrize("dt, v0_max, ramp, short", [
    (1e-3, 4.0, {}, True),  # families.py's scene: k dt v ~ 0.03
    (3e-3, 4.0, {}, False),  # three times the step: beyond 1/16
    (1e-3, 20.0, {}, False),  # five times the speed
    (1e-3, 4.0, dict(wavenumber=20.0), False),
    (1e-3, 4.0, dict(amplitude=0.4), False),  # |f''| = A k^2 = 14: faster
])
def test_the_plan_takes_the_short_form_only_where_steps_are_short(dt, v0_max, ramp, short):
    scene = sine_scene(dt, **ramp)
    assert runner.plan_run(scene, starts(v0_max)).variant.short_stages is short
    for method in ("euler", "semi_implicit_euler", "dopri5"):  # fixed steps only
        integrator = (rw.Integrator(method, rtol=1e-6) if method == "dopri5"
                      else rw.Integrator(method, dt))
        plan = runner.plan_run(scene.replace(integrator=integrator), starts(v0_max))
        assert plan.variant.short_stages is (short and method != "dopri5")
    other = rw.Scene(ramp=rw.Ramp.create("circular_bowl", radius=2.0, domain=(-1.0, 1.0)),
                     integrator=rw.Integrator("rk4", dt))
    assert not runner.plan_run(other, starts(v0_max)).variant.short_stages


def test_short_steps_stay_within_the_bound():
    """The bound holds where it matters: every recorded step of an event-rich
    sweep that the plan ran with the short form moves |k dx| <= 1/16; and
    the results agree with the reduced form's (the same RK4 steps, the ramp
    rounded differently) to far below the method's error."""
    scene = sine_scene().replace(record=rw.Record(count=12, every=1))
    sweep = starts()
    assert runner.plan_run(scene, sweep).variant.short_stages
    short = rw.simulate(scene, sweep, kernel="specialised")
    x = short.trace_x.values
    steps = np.abs(np.diff(x, axis=-1))
    steps = steps[np.isfinite(steps)]
    assert steps.size > 5_000
    assert SINE["wavenumber"] * steps.max() <= R.SHORT_STAGE_ANGLE, steps.max()
    spec = scene.ramp.spec
    original = type(spec).short_stages
    try:  # the same run on the reduced form
        type(spec).short_stages = lambda self, *args, **kwargs: False
        assert not runner.plan_run(scene, sweep).variant.short_stages
        reduced = rw.simulate(scene, sweep, kernel="specialised")
    finally:
        type(spec).short_stages = original
    assert np.array_equal(short.status.values, reduced.status.values)
    for name in ("x_end", "W_friction"):
        assert np.allclose(short[name].values, reduced[name].values, rtol=1e-9, atol=1e-11), name
