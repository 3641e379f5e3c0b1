"""The entry point: datasets reproduce from their own stored scene, user
functions run like the equivalent family, and the dataset follows the schema."""

import numba
import numpy as np
import pytest

import rampwork as rw
from rampwork import schema
from rampwork.scenefile import parse_scene


def _bowl_scene(**changes):
    scene = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0)),
                     friction=rw.Friction(0.1, 0.2), x0=-0.9, t_max=20.0)
    return scene.replace(**changes)


@pytest.mark.parametrize("integrator", [rw.Integrator("rk4", dt=1e-3),
                                        rw.Integrator("dopri5", rtol=1e-7, atol=1e-9)])
def test_a_dataset_reproduces_from_its_stored_scene(tmp_path, integrator):
    sweep = rw.Sweep.grid(mu=[0.05, 0.2, 0.4], v0=[-1.0, 0.0, 1.5])
    ds = rw.simulate(_bowl_scene(integrator=integrator), sweep)
    path = rw.write_netcdf(ds, tmp_path / "run.nc")
    stored = rw.open_dataset(path)
    scene, stored_sweep = parse_scene(stored.attrs["rampwork_scene"], "stored")
    assert scene.integrator == integrator
    again = rw.simulate(scene, stored_sweep)
    names = schema.output_names(integrator.adaptive)
    assert set(names) <= set(ds.data_vars)
    for name in names:
        assert np.array_equal(again[name].values, ds[name].values, equal_nan=True), name


def test_user_functions_run_like_the_family():
    @numba.njit
    def f(x):
        return 0.5 * x * x

    @numba.njit
    def fp(x):
        return x

    @numba.njit
    def fpp(x):
        return 1.0

    sweep = rw.Sweep.grid(mu=[0.05, 0.2], x0=[-0.9, 0.5])
    family = rw.simulate(_bowl_scene(), sweep)
    ramp = rw.Ramp.from_functions(f, fp, fpp, domain=(-1.0, 1.0), curvature_sign=1)
    user = rw.simulate(_bowl_scene(ramp=ramp), sweep)
    assert np.array_equal(user.status.values, family.status.values)
    assert np.array_equal(user.n_reversals.values, family.n_reversals.values)
    for name in ("x_end", "t_end", "W_friction", "W_energy"):
        np.testing.assert_allclose(user[name].values, family[name].values, rtol=1e-10, atol=1e-12)
    assert "user functions" in user.attrs["rampwork_scene"]


@pytest.mark.parametrize("integrator", [rw.Integrator("rk4"), rw.Integrator("dopri5")])
def test_every_output_carries_its_schema_attributes(integrator):
    ds = rw.simulate(_bowl_scene(integrator=integrator),
                     rw.Sweep.cases(x0=[-0.9, 0.3], v0=[0.0, 2.0]))
    assert ds.sizes == {"case": 2}
    names = schema.output_names(integrator.adaptive)
    assert [name for name in ds.data_vars if name in schema.OUTPUTS] == list(names)
    for name in names:
        spec = schema.OUTPUTS[name]
        assert ds[name].dtype == spec.np_dtype, name
        assert ds[name].attrs["units"] == spec.units, name
    assert list(ds.status.attrs["flag_meanings"].split())[1:] == [
        "stuck", "exited", "lifted_off", "timeout", "diverged"]
    assert ds.attrs["compile_time_s"] >= 0 and ds.attrs["run_time_s"] >= 0
    assert ds.attrs["trajectory_steps"] == int(ds.steps.sum())


def test_bitwise_identical_whatever_the_block_and_tile_size():
    """A trajectory's arithmetic must not depend on its lane, its tile, the
    number of lanes per block, how a tile's tail is compacted, or how often
    the scan resolves the lanes that stopped at an event (6 steps a block,
    two per lane visit: three visits, an odd count of x and v's bank swaps;
    and t_max = 15 s ends some trajectories inside a block: they stop at
    the step limit)."""
    from rampwork import runner
    from rampwork.core import kernel as K
    from rampwork.core.variant import KernelVariant

    scene = rw.Scene(ramp=rw.Ramp.create("circular_bowl", radius=1.0, domain=(-0.9, 0.9)),
                     friction=rw.Friction(0.05, 0.15), x0=0.0, t_max=15.0)
    sweep = rw.Sweep.random(700, seed=11, x0=(-0.85, 0.85), v0=(-3.0, 3.0), mu_k=(0.0, 0.15))
    plan = runner.plan_run(scene, sweep)
    inputs = runner.chunk_inputs(plan, 0, plan.size)
    settings = np.array([-0.9, 0.9, 1e-3, 15.0])
    spec = scene.ramp.spec
    results = []
    for lanes, tile, knobs in ((32, 4096, {}), (64, 37, {}), (16, 1, {}), (16, 250, {}),
                               (64, 37, dict(substeps=6, unroll=2))):
        variant = KernelVariant(spec.key, "rk4", check_contact=False, carry_slope=True,
                                lanes=lanes, **knobs)
        run_batch, _ = K.build_kernel(variant, spec.height, spec.slope_curvature)
        out = np.zeros((K.N_OUTPUTS, plan.size))
        run_batch(inputs, settings, out, scene.ramp.shared_array(), tile)
        results.append(out)
    statuses = set(results[0][K.OUT_STATUS].astype(int))
    assert {1, 2} <= statuses  # the sweep has both stops and exits
    assert results[0][K.OUT_NREV].max() >= 3  # and many reversals
    assert 4 in statuses  # and timeouts (status 4)
    for out in results[1:]:
        assert np.array_equal(out, results[0], equal_nan=True)


# ------------------------------------------------------------------------------
# the array passes around the kernel (core.reduce) against numpy's formulas
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("shape", [(7,), (3, 5), (4, 1, 6), (2, 3, 2, 5)])
def test_grid_columns_are_numpys_unravelled_indices(shape):
    from rampwork.core import reduce

    rng = np.random.default_rng(len(shape))
    axes = [rng.normal(size=n) for n in shape]
    lengths = np.array(shape, dtype=np.int64)
    values = np.zeros((len(shape), max(shape)))
    for row, axis in enumerate(axes):
        values[row, :len(axis)] = axis
    size = int(np.prod(shape))
    for start, stop in ((0, size), (1, size), (size // 2, size)):
        columns = np.empty((len(shape), stop - start))
        reduce.grid_columns(start, lengths, values, columns)
        index = np.unravel_index(np.arange(start, stop), shape)
        for row, axis in enumerate(axes):
            assert np.array_equal(columns[row], axis[index[row]])


@pytest.mark.parametrize("drag", [False, True])
def test_reduction_follows_the_dataset_definitions(drag):
    """W_linear = mu_k m g |x_end - x0|, W_excess = W_friction - W_linear,
    W_path = mu_k m g path_length_x, the energy balance with and without drag,
    integer variables from the kernel's float rows; variables a run does not
    have are left alone."""
    from rampwork import runner
    from rampwork.core import kernel as K

    rng = np.random.default_rng(5)
    n = 20_001  # more than one parallel block, and not a multiple of it
    raw = rng.uniform(-2.0, 2.0, size=(K.N_OUTPUTS, n))
    raw[K.OUT_STATUS] = rng.integers(0, 6, n)
    raw[K.OUT_NREV] = rng.integers(0, 30, n)
    raw[K.OUT_STEPS] = rng.integers(0, 10**9, n)
    raw[K.OUT_NREJ] = rng.integers(0, 10, n)
    inputs = rng.uniform(0.1, 2.0, size=(K.N_INPUTS, n))
    mass = rng.uniform(0.5, 3.0, n)
    names = schema.output_names(adaptive=True, drag=drag)
    out = {name: np.full(n, 7, dtype=schema.OUTPUTS[name].np_dtype) for name in names}
    runner.reduce_outputs(raw, inputs, mass, out=out)
    x0, mu_k, g = inputs[K.IN_X0], inputs[K.IN_MUK], inputs[K.IN_G]
    assert out["status"].dtype == np.int8 and np.array_equal(out["status"], raw[K.OUT_STATUS])
    assert np.array_equal(out["n_reversals"], raw[K.OUT_NREV])
    assert np.array_equal(out["steps"], raw[K.OUT_STEPS])
    assert np.array_equal(out["steps_rejected"], raw[K.OUT_NREJ])
    assert np.array_equal(out["x_end"], raw[K.OUT_X])
    np.testing.assert_allclose(out["W_friction"], mass * raw[K.OUT_WORK], rtol=1e-15)
    np.testing.assert_allclose(out["W_linear"], mu_k * mass * g * np.abs(raw[K.OUT_X] - x0),
                               rtol=1e-14)
    np.testing.assert_allclose(out["W_excess"], out["W_friction"] - out["W_linear"],
                               rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(out["W_path"], mu_k * mass * g * raw[K.OUT_PATH], rtol=1e-14)
    lost = mass * raw[K.OUT_ENERGY_LOSS]
    dissipated = out["W_friction"] + (mass * raw[K.OUT_DRAG_WORK] if drag else 0.0)
    # plus the residuals the adaptive pairs' energy projection removed (docs/physics.md 1.6)
    projected = mass * raw[K.OUT_PROJECTED]
    np.testing.assert_allclose(out["energy_balance_error"], dissipated - lost + projected,
                               rtol=1e-12, atol=1e-14)
    if drag:
        np.testing.assert_allclose(out["W_drag"], mass * raw[K.OUT_DRAG_WORK], rtol=1e-15)
    else:
        assert "W_drag" not in out
    assert "x_lift_off_paper" not in out  # not asked for: not written anywhere


def test_reduce_rows_takes_the_outputs_in_the_schema_order():
    """The runner passes the schema's variables to core.reduce.reduce_rows in
    the schema's order: its parameters after the inputs must be those names."""
    import inspect

    from rampwork.core import reduce

    parameters = list(inspect.signature(reduce.reduce_rows).parameters)
    assert parameters[:5] == ["raw", "x0", "mu_k", "g", "mass"]
    assert parameters[5:] == [name.lower() for name in schema.OUTPUTS]


def test_kernel_variant_derives_its_facts_and_refuses_bad_knobs():
    from rampwork.core.variant import CLOSED_FORM, KernelVariant

    euler = KernelVariant("quadratic", "euler")
    assert euler.first_order and euler.linear_events and not euler.adaptive
    assert euler.replace(drag_linear=True).linear_events  # drag rate of the step start: linear in h
    assert not euler.replace(method="semi_implicit_euler").linear_events  # x gains h^2 a
    rk4 = KernelVariant("quadratic", "rk4", carry_slope=False)
    assert not rk4.first_order and not rk4.linear_events and not rk4.carry_slope
    assert rk4.constants()["WORK_SIGN_CHECK"] and not rk4.constants()["MONOTONE_STEP"]
    dopri5 = KernelVariant("quadratic", "dopri5", carry_slope=False)
    assert dopri5.carry_slope and dopri5.substeps % 2 == 0  # adaptive pairs carry f', f''
    # one name per variant, and equal variants are one table key
    variants = {KernelVariant("sine", method, one_sided=side, drag_quadratic=drag)
                for method in ("euler", "rk4", "dop853") for side in (True, False)
                for drag in (True, False)}
    assert len({v.name for v in variants}) == len(variants) == 12
    assert KernelVariant("sine", "rk4") == KernelVariant("sine", "rk4", substeps=None)
    # the closed form has none of the stepping choices
    closed = KernelVariant("straight", CLOSED_FORM, check_contact=False, lanes=16)
    assert closed == KernelVariant("straight", CLOSED_FORM) and closed.closed_form
    words = KernelVariant("sine", "rk4", one_sided=False, drag_linear=True).effects
    assert "two-sided contact (bead on a wire), sign switches of n" in words
    assert "air drag (linear)" in words
    for knobs, message in ((dict(method="leapfrog"), "unknown method"),
                           (dict(method="rk4", lanes=24), "multiple of 16"),
                           (dict(method="rk4", substeps=16, unroll=3), "multiple of unroll"),
                           (dict(method="dopri5", substeps=3), "even"),
                           (dict(method="rk4", chains=3), "chains")):
        with pytest.raises(ValueError, match=message):
            KernelVariant("sine", **knobs)


def test_each_output_comes_from_the_kernel_row_the_schema_names():
    """schema.OUTPUTS says once which kernel row each variable is read from
    (per unit mass where it is in J); core.reduce must follow it."""
    from rampwork import runner
    from rampwork.core import kernel as K

    rng = np.random.default_rng(4)
    n = 50
    raw = rng.uniform(-5.0, 5.0, (K.N_OUTPUTS, n)).round(3)
    inputs = rng.uniform(0.1, 2.0, (K.N_INPUTS, n))
    mass = rng.uniform(0.5, 3.0, n)
    out = runner.reduce_outputs(raw, inputs, mass)
    with_row = [name for name, spec in schema.OUTPUTS.items() if spec.row is not None]
    assert len(with_row) == 15 and {"W_linear", "W_excess", "W_path"}.isdisjoint(with_row)
    for name in with_row:
        spec = schema.OUTPUTS[name]
        expected = raw[spec.row] * (mass if spec.units == "J" else 1.0)
        np.testing.assert_array_equal(out[name], expected.astype(spec.np_dtype), err_msg=name)
