"""The cycloid family's short form at a fixed step's stage points and end
(``core.ramps.cycloid_slope_curvature_short``: the Taylor series of f' in dx
from the step start's f', f'') against long-double values, and the plan's
bound that selects it.

The reference is f', f'' at the exact stage point x0 + dx (long double),
by a long-double Newton inverse of x = r (u + sin u) (tests/test_ramps.py);
the short form starts from the code's own f'(x0), f''(x0), so its error
includes theirs.  f' errors are in ulp of |f'(x0)| + |f''(x0) dx| (the
terms' scale: where f' crosses 0 within the step a relative error means
nothing), f'' errors in ulp of f'' itself (always > 0).
"""

import math

import numpy as np
import pytest
from test_ramps import _cycloid_long_double

import rampwork as rw
from rampwork import runner
from rampwork.core import ramps as R
from rampwork.core.jit import jit

pytestmark = pytest.mark.skipif(np.finfo(np.longdouble).nmant < 63,
                                reason="needs an 80-bit long double")


@jit
def _evaluate(x, dx, r, out):
    for i in range(x.size):
        fp, fpp = R.cycloid_slope_curvature(x[i], r, 0.0, 0.0, 0.0, None)
        out[0, i] = fp
        out[1, i] = fpp
        out[2, i], out[3, i] = R.cycloid_slope_curvature_short(x[i] + dx[i], dx[i], fp, fpp,
                                                               r, 0.0, 0.0, 0.0, None)


def _largest_step(fp, r):
    """|dx| where (CYCLOID_GROWTH_0 + CYCLOID_GROWTH_1 |f'|) tau reaches
    CYCLOID_SHORT_BOUND, tau = (1 + f'^2) |dx| / 4r."""
    growth = R.CYCLOID_GROWTH_0 + R.CYCLOID_GROWTH_1 * np.abs(fp)
    return R.CYCLOID_SHORT_BOUND * 4.0 * r / (growth * (1.0 + fp * fp))


def errors(n, r, seed):
    """Max errors (f', f'') in ulp over n random (x0, dx): a third of the x0
    uniform on (-pi r, pi r), a third near the cusps (pi - |u| from 1e-4 to
    pi/2), a third near 0 (|x0| from 1e-12 r to r, where f' crosses 0 within
    a step); |dx| up to the bound, an eighth of them at the bound itself."""
    rng = np.random.default_rng(seed)
    third = n // 3
    w = 10.0 ** rng.uniform(-4.0, math.log10(math.pi / 2), third).astype(np.longdouble)
    x = np.concatenate([rng.uniform(-1.0, 1.0, third) * math.pi * r,
                        (r * (np.longdouble(math.pi) - (w - np.sin(w)))).astype(np.float64),
                        r * 10.0 ** rng.uniform(-12.0, 0.0, n - 2 * third)])
    x = x * rng.choice([-1.0, 1.0], n)
    x = x[[R.cycloid_cusp_gap(abs(float(v)), r) > 0 for v in x]]
    out = np.empty((4, x.size))
    _evaluate(x, np.zeros(x.size), r, out)
    step = _largest_step(out[0], r)
    dx = rng.uniform(-1.0, 1.0, x.size) * step
    dx[:x.size // 8] = np.copysign(step[:x.size // 8], dx[:x.size // 8])
    # x0 + dx exact in long double (near the cusps f' changes by ~f'^4 / 4r
    # times the rounding of x: the reference needs the very point)
    L = np.longdouble
    dx = ((x.astype(L) + dx.astype(L)) - x.astype(L)).astype(np.float64)
    _evaluate(x, dx, r, out)
    _, fp_exact, fpp_exact = _cycloid_long_double(x.astype(L) + dx.astype(L), r)
    scale = np.abs(out[0]) + np.abs(out[1] * dx)
    e_fp = np.abs((out[2] - fp_exact) / np.spacing(scale)).astype(float)
    e_fpp = np.abs((out[3] - fpp_exact) / np.spacing(fpp_exact.astype(float))).astype(float)
    return e_fp.max(), e_fpp.max(), x.size


@pytest.mark.parametrize("r, seed", [(0.5, 41), (1.0, 42)])
def test_short_form_within_a_few_ulp(r, seed):
    """Measured over 2 x 6e5 pairs: f' <= 3.5 ulp of |f'(x0)| + |f''(x0) dx|,
    f'' <= 13 ulp (f'' = (1 + f'^2)^2 / 4r multiplies the error of f' by up
    to 4 near the cusps, as in the direct evaluation; tests/test_ramps.py
    allows 16 there).  The series' first term left out is below 2^-53 of
    the scale at the bound."""
    e_fp, e_fpp, n = errors(600_000, r, seed)
    assert n > 590_000
    assert e_fp < 4.5 and e_fpp < 16.0, (e_fp, e_fpp)


def test_afresh_form_is_the_direct_evaluation():
    """Without the plan's bound the kernels evaluate the cycloid afresh at
    every stage: the arithmetic of a kernel without a short form."""
    for x in (0.0, 0.3, -1.2, 1.5):
        assert (R.cycloid_slope_curvature_afresh(x, 0.1, 9.0, 9.0, 0.5, 0.0, 0.0, 0.0, None)
                == R.cycloid_slope_curvature(x, 0.5, 0.0, 0.0, 0.0, None))


# -- the plan's choice of the short form ---------------------------------------


def cycloid_scene(dt=1e-3, radius=0.5, domain=(-1.0, 1.0), method="rk4"):
    return rw.Scene(ramp=rw.Ramp.create("cycloid", domain=domain, radius=radius),
                    friction=rw.Friction(mu_k=0.2), t_max=3.0, integrator=rw.Integrator(method, dt))


def starts(v0_max=4.0, n=9):
    return rw.Sweep.grid(x0=np.linspace(-0.9, 0.9, n), v0=np.linspace(-v0_max, v0_max, n),
                         mu=[0.02, 0.3])


@pytest.mark.parametrize("dt, v0_max, ramp, short", [
    (1e-3, 4.0, {}, True),  # families.py's scene: (1.5 + 3 |f'|) tau ~ 0.013
    (2e-3, 4.0, {}, False),  # twice the step: beyond 1/64
    (1e-3, 8.0, {}, False),  # twice the speed
    (1e-3, 4.0, dict(domain=(-1.5, 1.5)), False),  # near the cusps at +-pi/2: f' ~ 6
    (1e-3, 4.0, dict(radius=2.0), True),  # a flatter bowl
])
def test_the_plan_takes_the_short_form_only_where_steps_are_short(dt, v0_max, ramp, short):
    scene = cycloid_scene(dt, **ramp)
    assert runner.plan_run(scene, starts(v0_max)).variant.short_stages is short
    for method in ("euler", "semi_implicit_euler"):
        plan = runner.plan_run(scene.replace(integrator=rw.Integrator(method, dt)), starts(v0_max))
        assert plan.variant.short_stages is short


@pytest.mark.slow  # compiles two recording RK4 cycloid kernels (~35 s)
def test_short_steps_stay_within_the_bound():
    """The bound holds where it matters: every recorded step of an event-rich
    sweep that the plan ran with the short form has (1.5 + 3 |f'|) tau <=
    1/64; and the results agree with the direct evaluation's (the same RK4
    steps, the ramp rounded differently) to far below the method's error,
    with the same statuses."""
    scene = cycloid_scene().replace(record=rw.Record(count=12, every=1))
    sweep = starts()
    assert runner.plan_run(scene, sweep).variant.short_stages
    short = rw.simulate(scene, sweep, kernel="specialised")
    x = short.trace_x.values
    steps = np.abs(np.diff(x, axis=-1))
    ok = np.isfinite(steps)
    x0 = x[..., :-1][ok]
    steps = steps[ok]
    assert steps.size > 5_000
    fp = np.array([R.cycloid_slope_curvature(v, 0.5, 0.0, 0.0, 0.0, None)[0] for v in x0])
    assert np.all(steps <= _largest_step(fp, 0.5)), (steps / _largest_step(fp, 0.5)).max()
    spec = scene.ramp.spec
    original = type(spec).short_stages
    try:  # the same run evaluating afresh
        type(spec).short_stages = lambda self, *args, **kwargs: False
        assert not runner.plan_run(scene, sweep).variant.short_stages
        afresh = rw.simulate(scene, sweep, kernel="specialised")
    finally:
        type(spec).short_stages = original
    assert np.array_equal(short.status.values, afresh.status.values)
    assert np.count_nonzero(short.n_reversals.values) > 10
    for name in ("x_end", "W_friction", "convexity_mean"):
        assert np.allclose(short[name].values, afresh[name].values, rtol=1e-9, atol=1e-11), name
