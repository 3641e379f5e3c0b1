"""Property-based tests (hypothesis) over random ramps, frictions and starts.

Each hypothesis example is a batch of trajectories of one ramp family (shape
parameters drawn per trajectory and swept as ``cases``), run in one
``simulate`` call per integrator.  The properties are invariants, so they
must hold for any input, knife edges included:

* every output finite, or the status says ``diverged``; ``x_lift_off`` set
  exactly when the status is ``lifted_off``;
* W_f >= 0, and W_f never decreases along a recorded trajectory;
* the mechanical energy never rises beyond the method's accuracy (it may
  only fall, by friction): at the end, and between recorded samples;
* integrated work and the energy balance agree within the method's accuracy,
  at the end and at every recorded sample;
* a ramp with f'' >= 0 never lifts off, also with the contact check compiled in;
* results are identical bit for bit whatever the chunk size, the number of
  lanes per block and the thread count.

Examples are few and reproducible (``derandomize=True``); the scipy
reference is not used here (test_physics and test_adaptive compare with it).
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

import rampwork as rw
from rampwork import runner
from rampwork.core import kernel as K
from rampwork.core.status import DIVERGED, EXITED, LIFTED_OFF, STUCK, TIMEOUT
from rampwork.core.variant import KernelVariant

G = 9.81
BATCH = 16
T_MAX = 5.0
PROPERTY_SETTINGS = settings(max_examples=3, deadline=None, derandomize=True, database=None,
                             phases=[Phase.explicit, Phase.generate],
                             suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

#: family: (domain, ranges of the shape parameters drawn per trajectory)
FAMILIES = {
    "quadratic": ((-1.0, 1.0), {"curvature": (-2.0, 3.0), "slope": (-0.5, 0.5)}),
    "circular_bowl": ((-0.9, 0.9), {"radius": (1.0, 3.0)}),
    "circular_dome": ((-0.9, 0.9), {"radius": (1.0, 3.0)}),
    "sine": ((-2.0, 2.0), {"mean_slope": (-0.3, 0.3), "amplitude": (0.05, 0.3), "wavenumber": (1.0, 4.0),
                           "phase": (0.0, 2 * math.pi)}),
    "cycloid": ((-1.4, 1.4), {"radius": (0.5, 1.0)}),
    "spline": ((-1.0, 1.0), {}),
}
INTEGRATORS = {
    "rk4": rw.Integrator("rk4", 1e-3),
    "dopri5": rw.Integrator("dopri5", rtol=1e-8),
    "dop853": rw.Integrator("dop853", rtol=1e-8),
}
#: relative accuracy of the energy balance on these metre-scale, 5 s scenes
#: (RK4 at 1 ms: (omega dt)^4 with omega up to ~10/s; dopri5, dop853: a few hundred rtol
#: over many steps and events; first-order: omega^2 dt t, a few percent)
ACCURACY = {"rk4": 1e-7, "dopri5": 1e-5, "dop853": 1e-5, "euler": 0.1, "semi_implicit_euler": 0.1}


def case_strategy(family):
    (lo, hi), shapes = FAMILIES[family]
    inset = 0.02 * (hi - lo)
    return st.fixed_dictionaries({
        "x0": st.floats(lo + inset, hi - inset),
        "v0": st.floats(-2.5, 2.5),
        "mu_k": st.floats(0.0, 0.5),
        "mu_s_extra": st.floats(0.0, 0.3),
        **{name: st.floats(a, b) for name, (a, b) in shapes.items()},
    })


def spline_points():
    """4 to 8 knots evenly over [-1, 1], heights within 0.15 m (|f''| up to ~10 /m,
    as on the other families; at 0.4 m it reaches 30 /m, where RK4 at 0.1 ms
    is good to only 5e-7)."""
    return st.integers(4, 8).flatmap(
        lambda n: st.lists(st.floats(-0.15, 0.15), min_size=n, max_size=n))


def batch_strategy(family):
    return st.tuples(st.lists(case_strategy(family), min_size=BATCH, max_size=BATCH),
                     spline_points() if family == "spline" else st.just(None))


def family_ramp(family, first_case, heights=None):
    """The scene's ramp: the family with the first case's shape (the sweep
    sets every case's own)."""
    domain, shapes = FAMILIES[family]
    if family == "spline":
        return rw.Ramp.create("spline", x_points=np.linspace(-1.0, 1.0, len(heights)).tolist(),
                              y_points=heights, domain=domain)
    return rw.Ramp.create(family, domain=domain, **{name: first_case[name] for name in shapes})


def batch_run(family, batch, integrator, record=rw.Record(), **kwargs):
    cases, heights = batch
    columns = {name: [case[name] for case in cases] for name in cases[0] if name != "mu_s_extra"}
    columns["mu_s"] = [case["mu_k"] + case["mu_s_extra"] for case in cases]
    scene = rw.Scene(ramp=family_ramp(family, cases[0], heights), integrator=integrator, x0=0.0, t_max=T_MAX,
                     friction=rw.Friction(0.0, 1.0), record=record)
    sweep = rw.Sweep.cases(**columns)
    return scene, sweep, rw.simulate(scene, sweep, **kwargs)


def case_ramp(scene, sweep, i):
    """The ramp of trajectory ``i`` (its own swept shape parameters)."""
    params = {name: float(sweep.values(name)[i]) for name in scene.ramp.spec.parameter_names
              if name in sweep.names}
    if not params:
        return scene.ramp
    return rw.Ramp.create(scene.ramp.family, domain=scene.ramp.domain, **params)


def energy(ramp, x, v, g=G):
    """Mechanical energy per unit mass, E = g f + v^2 (1 + f'^2) / 2 (eq. 19)."""
    f, fp, _ = ramp.evaluate(x)
    return g * f + 0.5 * v * v * (1.0 + fp * fp)


def check_outputs(scene, sweep, ds, method):
    lo, hi = scene.ramp.domain
    status = ds.status.values
    assert np.isin(status, (STUCK, EXITED, LIFTED_OFF, TIMEOUT, DIVERGED)).all(), status
    ok = status != DIVERGED
    for name in ("t_end", "x_end", "v_end", "W_friction", "W_energy", "energy_balance_error",
                 "W_path", "path_length_x", "convexity_mean"):
        values = ds[name].values[ok]
        finite = np.isfinite(values) | ((name == "convexity_mean") & (ds.path_length_x.values[ok] == 0))
        assert finite.all(), (name, values[~finite])
    assert np.array_equal(np.isnan(ds.x_lift_off.values), status != LIFTED_OFF)
    # semi-implicit Euler's W_path can be -1e-37 (test_semi_implicit_path_is_never_negative),
    # dop853's W_friction -5e-324 at a denormal mu_k (test_dop853_work_is_never_negative_...)
    for name in ("W_friction",) + (("W_path",) if method != "semi_implicit_euler" else ()):
        negative = np.flatnonzero(ok & (ds[name].values < 0.0)
                                  & ~((method == "dop853") & (ds[name].values == -5e-324)))
        assert negative.size == 0, (method, name, [(i, ds[name].values[i], int(status[i])) for i in negative])
    x_end = ds.x_end.values[ok]
    assert ((lo <= x_end) & (x_end <= hi)).all() and (ds.t_end.values[ok] <= T_MAX).all()
    assert (ds.v_end.values[status == STUCK] == 0.0).all()
    # the energy may only fall, and only by the work friction did
    x0, v0 = sweep.values("x0"), sweep.values("v0")
    for i in np.flatnonzero(ok):
        ramp = case_ramp(scene, sweep, i)
        e0 = energy(ramp, x0[i], v0[i])
        f_range = np.ptp(ramp.evaluate(np.linspace(lo, hi, 65))[0])
        scale = max(1.0, G * f_range + abs(e0 - G * ramp.evaluate(x0[i])[0]))  # J/kg
        tol = ACCURACY[method] * scale
        what = (method, i, {name: float(sweep.values(name)[i]) for name in sweep.names}, int(status[i]))
        assert ds.W_energy.values[i] >= -tol, what
        assert abs(ds.energy_balance_error.values[i]) <= tol, (what, ds.energy_balance_error.values[i])


def check_traces(scene, sweep, ds, method):
    """Along each recorded trajectory: W_f never decreases, E never rises,
    and E + W_f stays at E(0) within the method's accuracy."""
    assert ds.sizes["traced"] >= 2
    for k, j in enumerate(ds.traced_index.values):
        n = int(ds.trace_length.values[k])
        x, v, w = (ds[name].values[k, :n] for name in ("trace_x", "trace_v", "trace_W_friction"))
        ramp = case_ramp(scene, sweep, int(j))
        e = energy(ramp, x, v)
        scale = max(1.0, abs(e[0] - G * ramp.evaluate(x[0])[0]) + G * np.ptp(ramp.evaluate(x)[0]))
        tol = ACCURACY[method] * scale
        assert (np.diff(w) >= 0.0).all(), (method, j)
        assert (np.diff(e) <= tol).all(), (method, j, np.diff(e).max())
        assert np.abs(e + w - e[0]).max() <= tol, (method, j)


def check_random_batch(family, method, data):
    batch = data.draw(batch_strategy(family), label="batch")
    integrator = INTEGRATORS[method]
    if family == "spline" and method == "rk4":
        # f''' jumps at the knots, where nothing stops a step: RK4 is of second
        # order there (energy errors of 3e-7 of the scale at 1 ms), so 0.1 ms
        integrator = rw.Integrator("rk4", 1e-4)
    scene, sweep, ds = batch_run(family, batch, integrator, record=rw.Record(count=3, every=1))
    check_outputs(scene, sweep, ds, method)
    check_traces(scene, sweep, ds, method)


# dop853 on every family runs in the slow suite only (test_invariants_on_random_ramps_many,
# with more examples): each family is one more dop853 kernel to compile, about a
# minute of the default run apiece, and the default run keeps dop853 elsewhere
@pytest.mark.parametrize("method", [method for method in INTEGRATORS if method != "dop853"])
@pytest.mark.parametrize("family", list(FAMILIES))
@PROPERTY_SETTINGS
@given(data=st.data())
def test_invariants_on_random_ramps(family, method, data):
    check_random_batch(family, method, data)


@pytest.mark.slow
@pytest.mark.parametrize("method", list(INTEGRATORS))
@pytest.mark.parametrize("family", list(FAMILIES))
@settings(PROPERTY_SETTINGS, max_examples=30)
@given(data=st.data())
def test_invariants_on_random_ramps_many(family, method, data):
    check_random_batch(family, method, data)


@pytest.mark.parametrize("method", ["euler", "semi_implicit_euler"])
@PROPERTY_SETTINGS
@given(batch=batch_strategy("circular_bowl"))
def test_invariants_first_order_methods(method, batch):
    """The paper's explicit Euler and its semi-implicit variant at dt = 1e-4 s
    (at 1e-3 s explicit Euler's energy grows ~5 % in 5 s: its accuracy)."""
    scene, sweep, ds = batch_run("circular_bowl", batch, rw.Integrator(method, 1e-4),
                                 record=rw.Record(count=2, every=10))
    check_outputs(scene, sweep, ds, method)
    check_traces(scene, sweep, ds, method)


@pytest.mark.parametrize("family, convex", [("quadratic", True), ("circular_bowl", False),
                                            ("cycloid", False)])
@PROPERTY_SETTINGS
@given(data=st.data())
def test_convex_ramps_never_lift_off(family, convex, data):
    """f'' >= 0: n = g + v^2 f'' > 0 at every speed.  On bowls and cycloids the
    check is compiled out; quadratics of both signs are run with it compiled
    in, and the convex ones among them must not trip it."""
    cases, heights = data.draw(batch_strategy(family), label="batch")
    if convex:  # fast starts: up to 6 m/s, half of them with f'' >= 0
        cases = [dict(case, v0=2.4 * case["v0"], curvature=abs(case["curvature"]) if i % 2 else
                      case["curvature"]) for i, case in enumerate(cases)]
    scene, sweep, ds = batch_run(family, (cases, heights), INTEGRATORS["rk4"])
    plan = runner.plan_run(scene, sweep)
    assert plan.variant.check_contact == (family == "quadratic" and min(sweep.values("curvature")) < 0)
    curvature = sweep.values("curvature") if family == "quadratic" else np.ones(BATCH)
    lifted = ds.status.values == LIFTED_OFF
    assert not lifted[curvature >= 0].any()
    assert np.isnan(ds.x_lift_off.values[curvature >= 0]).all()


# ------------------------------------------------------------------------------
# bit-for-bit determinism
# ------------------------------------------------------------------------------
def _assert_identical(a, b, what):
    for name in a.data_vars:
        assert np.array_equal(a[name].values, b[name].values, equal_nan=True), (what, name)


@pytest.mark.parametrize("method, family", [("rk4", "sine"), ("dopri5", "cycloid"),
                                            ("euler", "circular_bowl")])
@PROPERTY_SETTINGS
@given(data=st.data())
def test_bit_identical_whatever_chunks_and_threads(method, family, data):
    integrator = INTEGRATORS.get(method, rw.Integrator(method, 1e-4))
    batch = data.draw(batch_strategy(family), label="batch")
    _, _, whole = batch_run(family, batch, integrator)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(runner, "CHUNK_SIZE", 5)  # four chunks, the last one short
        _, _, chunked = batch_run(family, batch, integrator)
    _assert_identical(whole, chunked, "chunks of 5")
    if numba.config.NUMBA_NUM_THREADS >= 2:
        _assert_identical(whole, batch_run(family, batch, integrator, threads=1)[2], "1 thread")


@pytest.mark.parametrize("method", [pytest.param("rk4", marks=pytest.mark.slow), "dopri5"])
@PROPERTY_SETTINGS
@given(batch=batch_strategy("circular_bowl"))
def test_bit_identical_whatever_the_lanes_per_block(method, batch):
    """16 or 64 lanes per block, tiles of 1 to 4096 trajectories (one kernel
    variant each; 16 lanes with rk4 is the one test_runner also builds)."""
    scene, sweep, _ = batch_run("circular_bowl", batch, INTEGRATORS[method])
    plan = runner.plan_run(scene, sweep)
    inputs = runner.chunk_inputs(plan, 0, plan.size)
    settings_ = runner._settings(scene)
    spec = scene.ramp.spec
    outputs = []
    for lanes, tile in ((64, 4096), (16, 1), (16, 7)):
        variant = KernelVariant(spec.key, method, check_contact=plan.variant.check_contact,
                                carry_slope=True, lanes=lanes)
        run_batch, _ = K.build_kernel(variant, spec.height, spec.slope_curvature)
        out = np.zeros((K.N_OUTPUTS, plan.size))
        run_batch(inputs, settings_, out, scene.ramp.shared_array(), tile)
        outputs.append(out)
    for out in outputs[1:]:
        assert np.array_equal(out, outputs[0], equal_nan=True)


def test_semi_implicit_path_is_never_negative():
    """Found by test_invariants_first_order_methods (a hypothesis start of
    v0 = -6e-95): the path travelled cannot be negative.  Semi-implicit Euler
    launched at v0 = -1e-200 stops after a partial step of 8.9e-20 s (the
    root located to the rounding of dt, not of the tiny stop time) where v
    has already turned positive; x used to move right, against the motion
    (path_length_x = -3.5e-38).  A stop now never leaves x behind its mode's
    start."""
    scene = rw.Scene(ramp=rw.Ramp.create("circular_bowl", radius=2.0, domain=(-0.9, 0.9)),
                     friction=rw.Friction(0.45, 0.47), x0=-1e-100, v0=-1e-200,
                     integrator=rw.Integrator("semi_implicit_euler", 1e-4))
    ds = rw.simulate(scene)
    assert ds.status.values.item() == STUCK
    assert ds.path_length_x.values.item() >= 0.0 and ds.x_end.values.item() <= -1e-100


def test_dop853_work_is_never_negative_at_a_denormal_friction():
    """Found by test_invariants_on_random_ramps[spline-dop853]: dop853 (stage
    weights of both signs) summed a friction power of a few denormals to
    W_friction = -5e-324 at mu_k = 5e-324.  The adaptive pairs now never add
    a negative friction-work increment (the power is >= 0 within a mode)."""
    ramp = rw.Ramp.create("spline", x_points=np.linspace(-1.0, 1.0, 4).tolist(),
                          y_points=[0.07247368019672706, 0.11995489219499386, -0.15, 0.03987879057460608],
                          domain=(-1.0, 1.0))
    scene = rw.Scene(ramp=ramp, friction=rw.Friction(5e-324, 0.27), x0=0.7891279304052683,
                     v0=1.2831723599017653, t_max=T_MAX, integrator=INTEGRATORS["dop853"])
    assert rw.simulate(scene).W_friction.values.item() >= 0.0
