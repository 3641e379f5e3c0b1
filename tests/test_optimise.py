"""Shape optimisation: the sine_modes ramp family, ChordModes (one batched
call per population) and rw.optimise (differential evolution, penalties,
history, checkpoint and resume)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

import rampwork as rw
from rampwork.brachistochrone import frictional_brachistochrone
from rampwork.core.status import EXITED, LIFTED_OFF, STUCK
from rampwork.errors import ConfigError
from rampwork.optimiser import OptimiseSettings, penalised
from rampwork.ramps import Ramp
from rampwork.reference import reference_trajectory
from rampwork.shapes import SHAPE_OUTPUTS, ChordModes

G = 9.81
TABLE = np.array([[0.1, -0.05, 0.02], [0.0, 0.0, 0.0], [-0.2, 0.03, 0.01]])


def _modes_ramp(row: int, table=TABLE, domain=(0.0, 2.0), ends=(1.0, 0.0)) -> Ramp:
    return Ramp.create("sine_modes", domain=domain, row=row, y_ends=list(ends), n_modes=[table.shape[1]],
                       coefficients=np.asarray(table).ravel())


# -- the sine_modes family ------------------------------------------------------


@pytest.mark.parametrize("row", [0, 1, 2])
def test_modes_family_matches_its_closed_form(row):
    x = np.linspace(-0.3, 2.3, 401)  # beyond the ends too: the smooth extension
    f, fp, fpp = _modes_ramp(row).evaluate(x)
    theta = math.pi * x / 2.0
    j = np.arange(1, 4)
    c = TABLE[row]
    angle = np.outer(theta, j)
    assert np.allclose(f, 1.0 - 0.5 * x + (c * np.sin(angle)).sum(1), rtol=0, atol=1e-15)
    assert np.allclose(fp, -0.5 + (c * j * math.pi / 2 * np.cos(angle)).sum(1), rtol=0, atol=1e-14)
    assert np.allclose(fpp, -(c * (j * math.pi / 2) ** 2 * np.sin(angle)).sum(1), rtol=0, atol=1e-14)
    # the ends are A and B for every row
    ends, _, _ = _modes_ramp(row).evaluate(np.array([0.0, 2.0]))
    assert ends == pytest.approx([1.0, 0.0], abs=1e-15)


def test_modes_family_derivatives_match_finite_differences():
    table = np.random.default_rng(3).uniform(-0.1, 0.1, (1, 24))
    ramp = _modes_ramp(0, table)
    x = np.linspace(0.05, 1.95, 97)
    h = 1e-5
    f = [ramp.evaluate(x + k * h)[0] for k in (-2, -1, 1, 2)]
    fp = [ramp.evaluate(x + k * h)[1] for k in (-2, -1, 1, 2)]
    _, slope, curvature = ramp.evaluate(x)
    five_point = lambda g: (g[0] - 8 * g[1] + 8 * g[2] - g[3]) / (12 * h)  # noqa: E731
    assert np.allclose(slope, five_point(f), rtol=0, atol=1e-8)
    assert np.allclose(curvature, five_point(fp), rtol=0, atol=1e-7)


def test_modes_family_round_trips_and_refuses_bad_data():
    ramp = _modes_ramp(2)
    assert Ramp.from_dict(ramp.to_dict()) == ramp
    with pytest.raises(ConfigError, match="ramp.row"):
        _modes_ramp(3)
    with pytest.raises(ConfigError, match="ramp.row"):
        Ramp.create("sine_modes", domain=(0.0, 2.0), row=0.5, y_ends=[1.0, 0.0], n_modes=[3],
                    coefficients=TABLE.ravel())
    with pytest.raises(ConfigError, match="ramp.n_modes"):
        Ramp.create("sine_modes", domain=(0.0, 2.0), y_ends=[1.0, 0.0], n_modes=[0], coefficients=[1.0])
    with pytest.raises(ConfigError, match="ramp.coefficients"):
        Ramp.create("sine_modes", domain=(0.0, 2.0), y_ends=[1.0, 0.0], n_modes=[2],
                    coefficients=[1.0, 2.0, 3.0])
    with pytest.raises(ConfigError, match="ramp.y_ends"):
        Ramp.create("sine_modes", domain=(0.0, 2.0), y_ends=[1.0], n_modes=[1], coefficients=[1.0])


# -- ChordModes.evaluate ----------------------------------------------------------

SHAPE = ChordModes(start=(0.0, 1.0), end=(2.0, 0.0), k=3, y_bounds=(-0.3, None))
POPULATION = np.array([[0.0, 0.0, 0.0],      # the chord
                       [0.1, -0.05, 0.02],   # a gentle bend
                       [-0.2, 0.03, 0.01],   # a dip
                       [0.9, 0.0, 0.0],      # starts uphill: back out at A
                       [0.0, -0.3, 0.0],     # a hump it sticks before
                       [-0.9, 0.0, 0.0],     # below y = -0.3
                       ])


@pytest.fixture(scope="module")
def evaluated():
    scene = SHAPE.scene(friction=rw.Friction(mu_k=0.2), integrator=rw.Integrator("dopri5", rtol=1e-10))
    return scene, SHAPE.evaluate(POPULATION, scene)


def test_evaluate_keeps_the_protocol(evaluated):
    _, ds = evaluated
    assert ds.sizes["candidate"] == len(POPULATION)
    for name in SHAPE_OUTPUTS:
        assert name in ds, name
    assert "flag_values" in ds["status"].attrs and ds["t_end"].attrs["units"] == "s"
    assert ds["arrived"].values.tolist() == [True, True, True, False, False, True]
    assert ds["inside"].values.tolist() == [True, True, True, True, True, False]
    assert ds["admissible"].values.tolist() == [True, True, True, False, False, False]
    assert ds["status"].values[3] == EXITED and ds["x_end"].values[3] == 0.0
    assert ds["status"].values[4] == STUCK
    for name in ("t_end", "W_friction", "W_excess", "speed_end"):
        assert np.isfinite(ds[name].values).all(), name


def test_the_chord_against_its_closed_form(evaluated):
    scene, ds = evaluated
    mu, dx, dy = 0.2, 2.0, -1.0
    length = math.hypot(dx, dy)
    sin_a, cos_a = -dy / length, dx / length
    acceleration = G * (sin_a - mu * cos_a)
    t = math.sqrt(2 * length / acceleration)
    assert ds["t_end"].values[0] == pytest.approx(t, rel=1e-9)
    assert ds["W_friction"].values[0] == pytest.approx(mu * G * dx, rel=1e-9)  # mu m g L (m = 1)
    assert ds["speed_end"].values[0] == pytest.approx(acceleration * t, rel=1e-9)


@pytest.mark.parametrize("row", [1, 2])
def test_a_bent_candidate_against_the_scipy_reference(evaluated, row):
    scene, ds = evaluated
    ref = reference_trajectory(scene, ramp=SHAPE.ramp(POPULATION[row:row + 1]), x0=0.0)
    assert ref["status"] == EXITED and ref["x_end"] == pytest.approx(2.0)
    assert ds["t_end"].values[row] == pytest.approx(ref["t_end"], rel=1e-8)
    assert ds["W_friction"].values[row] == pytest.approx(ref["W_friction"], rel=1e-7)
    _, slope, _ = SHAPE.profile(POPULATION[row:row + 1], np.array([2.0]))
    speed = abs(ref["v_end"]) * math.sqrt(1 + slope[0] ** 2)
    assert ds["speed_end"].values[row] == pytest.approx(speed, rel=1e-7)


def test_batch_evaluation_equals_one_by_one(evaluated):
    scene, ds = evaluated
    for row in range(len(POPULATION)):
        one = SHAPE.evaluate(POPULATION[row:row + 1], scene)
        for name in ("status", "t_end", "x_end", "W_friction", "W_excess", "speed_end", "admissible"):
            assert one[name].values[0] == ds[name].values[row] or (
                np.isnan(one[name].values[0]) and np.isnan(ds[name].values[row])), (row, name)


def test_evaluate_runs_as_simulate_without_the_scene_text(evaluated):
    """ChordModes.evaluate runs through runner.run_scene(store_scene=False):
    the same numbers, bit for bit, as rw.simulate's run of the same sweep,
    which does store the scene file."""
    from rampwork.runner import SCENE_NOT_STORED, run_scene

    scene, ds = evaluated
    ramp_scene = scene.replace(ramp=SHAPE.ramp(POPULATION), x0=0.0)
    sweep = rw.Sweep.cases(row=np.arange(len(POPULATION), dtype=float))
    full = rw.simulate(ramp_scene, sweep)
    bare = run_scene(ramp_scene, sweep, store_scene=False)
    assert full.attrs["rampwork_scene"].startswith("# rampwork scene file")
    assert bare.attrs["rampwork_scene"] == SCENE_NOT_STORED
    for name in ("status", "t_end", "x_end", "W_friction", "W_excess"):
        np.testing.assert_array_equal(bare[name].values, full[name].values)
        np.testing.assert_array_equal(ds[name].values, full[name].values)


def test_lift_off_is_flagged():
    shape = ChordModes(start=(0.0, 1.0), end=(2.0, 0.0), k=1)
    # a dome: concave enough that the fast block leaves it
    scene = shape.scene(v0=4.0, friction=rw.Friction(mu_k=0.1))
    ds = shape.evaluate(np.array([[0.6]]), scene)
    assert ds["status"].values[0] == LIFTED_OFF
    assert not ds["stayed_on"].values[0] and not ds["admissible"].values[0]
    energies, feasible = penalised(ds, OptimiseSettings(constraints=("stay_on",)))
    assert not feasible[0] and energies[0] >= 1e6 and np.isfinite(energies[0])


# -- penalties -----------------------------------------------------------------------


@pytest.mark.parametrize("objective", ["t_end", "W_friction", "W_excess", "speed_end"])
@pytest.mark.parametrize("sense", ["minimise", "maximise"])
def test_non_admissible_candidates_get_a_finite_penalty(evaluated, objective, sense):
    _, ds = evaluated
    settings = OptimiseSettings(objective=objective, sense=sense)
    energies, feasible = penalised(ds, settings)
    assert np.isfinite(energies).all()
    assert feasible.tolist() == ds["admissible"].values.tolist()
    sign = 1.0 if sense == "minimise" else -1.0
    assert np.array_equal(energies[feasible], sign * ds[objective].values[feasible])
    assert (energies[~feasible] >= settings.penalty).all()
    # the farther from B, the larger the penalty (a direction for the search)
    assert energies[3] > energies[4] > settings.penalty
    # without the arrive constraint, the stuck one counts (it is inside its region)
    _, free = penalised(ds, OptimiseSettings(objective=objective, sense=sense, constraints=()))
    assert free.tolist() == [True, True, True, True, True, False]


# -- the optimiser -----------------------------------------------------------------------


def test_optimiser_finds_the_one_mode_optimum_of_the_scipy_reference():
    """K = 1: the best c1 for the time to B at mu = 0.1, against a 1-D
    minimisation of the scipy reference's time."""
    shape = ChordModes(start=(0.0, 0.0), end=(1.0, -0.5), k=1)
    scene = shape.scene(friction=rw.Friction(mu_k=0.1), integrator=rw.Integrator("dopri5", rtol=1e-11))
    history = rw.optimise(scene, shape, "t_end", seed=2, popsize=10, maxiter=200, tol=1e-12)

    def reference_time(c1):
        ref = reference_trajectory(scene, ramp=shape.ramp(np.array([[c1]])), x0=0.0)
        return ref["t_end"] if ref["status"] == EXITED else 1e3

    best = minimize_scalar(reference_time, bounds=shape.bounds[0], method="bounded",
                           options={"xatol": 1e-9})
    assert history.attrs["converged"]
    assert history["best_parameters"].values[-1, 0] == pytest.approx(best.x, abs=2e-4)
    assert history.attrs["best_objective"] == pytest.approx(best.fun, rel=1e-8)
    assert history["best_objective"].values[-1] == history.attrs["best_objective"]
    # best so far never gets worse
    assert (np.diff(history["best_objective"].values) <= 0).all()


def test_optimiser_approaches_the_frictional_brachistochrone():
    """A graph with finite slopes cannot start vertically as the optimum
    does: its time is above the optimum's, and within 1 % of it at K = 4."""
    optimum = frictional_brachistochrone((1.0, -1.0), mu=0.2).time
    shape = ChordModes(start=(0.0, 0.0), end=(1.0, -1.0), k=4)
    scene = shape.scene(friction=rw.Friction(mu_k=0.2), integrator=rw.Integrator("dopri5", rtol=1e-10))
    chord = shape.evaluate(np.zeros((1, 4)), scene)["t_end"].values[0]
    history = rw.optimise(scene, shape, "t_end", seed=1, popsize=10, maxiter=300, tol=1e-8)
    best = history.attrs["best_objective"]
    assert optimum < best < optimum * 1.01 < chord


def test_maximising_flips_the_sign():
    shape = ChordModes(start=(0.0, 1.0), end=(2.0, 0.0), k=2)
    scene = shape.scene(friction=rw.Friction(mu_k=0.2))
    low = rw.optimise(scene, shape, "W_friction", seed=0, popsize=8, maxiter=25)
    high = rw.optimise(scene, shape, "W_friction", sense="maximise", seed=0, popsize=8, maxiter=25)
    chord = 0.2 * G * 2.0
    assert low.attrs["best_objective"] < chord < high.attrs["best_objective"]
    assert high["feasible"].dtype == bool and np.isfinite(high["penalised"].values).all()


def test_resumed_optimisation_is_identical(tmp_path):
    shape = ChordModes(start=(0.0, 1.0), end=(2.0, 0.0), k=3)
    scene = shape.scene(friction=rw.Friction(mu_k=0.1))
    kwargs = dict(objective="t_end", seed=7, popsize=6, maxiter=12, tol=0.0)
    whole = rw.optimise(scene, shape, **kwargs)

    class Interrupt(Exception):
        pass

    def stop_after_five(line):
        if line.startswith("generation 5/"):
            raise Interrupt

    path = tmp_path / "run.ckpt.npz"
    with pytest.raises(Interrupt):
        rw.optimise(scene, shape, checkpoint=path, progress=stop_after_five, **kwargs)
    lines = []
    resumed = rw.optimise(scene, shape, checkpoint=path, progress=lines.append, **kwargs)
    assert lines[0].startswith("generation 6/12")
    for name in ("best_parameters", "best_objective", "objective_spread", "n_feasible", "evaluations",
                 "population", "penalised", "t_end"):
        assert np.array_equal(whole[name].values, resumed[name].values), name
    # a checkpoint of another optimisation is refused
    with pytest.raises(ConfigError, match="checkpoint"):
        rw.optimise(scene, shape, checkpoint=path, **dict(kwargs, seed=8))


def test_history_dataset(tmp_path):
    shape = ChordModes(start=(0.0, 1.0), end=(2.0, 0.0), k=2)
    scene = shape.scene(friction=rw.Friction(mu_k=0.1))
    history = rw.optimise(scene, shape, "speed_end", sense="maximise", seed=0, popsize=5, maxiter=4)
    assert history.sizes == {"generation": 4, "parameter": 2, "candidate": 10}
    assert history["best_objective"].attrs["units"] == "m s-1"
    assert history.attrs["source"].startswith("rampwork") and "rampwork.optimise" in history.attrs["history"]
    assert history.attrs["objective"] == "speed_end" and history.attrs["K"] == 2
    path = tmp_path / "history.nc"
    rw.write_netcdf(history, path)
    back = rw.open_dataset(path)
    assert np.array_equal(back["best_parameters"].values, history["best_parameters"].values)


@pytest.mark.parametrize("kwargs, where", [
    (dict(objective="time"), "optimise.objective"),
    (dict(sense="max"), "optimise.sense"),
    (dict(constraints=("fly",)), "optimise.constraints[0]"),
    (dict(constraints="arrive"), "optimise.constraints"),
    (dict(popsize=1), "optimise.popsize"),
    (dict(maxiter=0), "optimise.maxiter"),
    (dict(tol=-1.0), "optimise.tol"),
    (dict(seed=-3), "optimise.seed"),
    (dict(mutation=(0.5, 2.5)), "optimise.mutation"),
    (dict(recombination=1.5), "optimise.recombination"),
    (dict(penalty=0.0), "optimise.penalty"),
    (dict(polish="yes"), "optimise.polish"),
])
def test_bad_settings_are_refused_by_name(kwargs, where):
    with pytest.raises(ConfigError) as error:
        OptimiseSettings(**kwargs)
    assert error.value.where == where
    shape = ChordModes(start=(0.0, 1.0), end=(2.0, 0.0), k=2)
    with pytest.raises(ConfigError) as error:  # before any work: no scene needed to fail
        rw.optimise(None, shape, **kwargs)
    assert error.value.where == where


@pytest.mark.parametrize("kwargs, where", [
    (dict(k=0), "shape.k"),
    (dict(end=(0.0, 0.0)), "shape.end"),
    (dict(amplitude=-1.0), "shape.amplitude"),
    (dict(y_bounds=(0.5, None)), "shape.y_bounds"),
    (dict(basis="chebyshev"), "shape.basis"),
])
def test_bad_shapes_are_refused_by_name(kwargs, where):
    with pytest.raises(ConfigError) as error:
        ChordModes(**dict(dict(start=(0.0, 1.0), end=(2.0, 0.0), k=2), **kwargs))
    assert error.value.where == where


# -- the command line ----------------------------------------------------------------


def test_cli_optimise_writes_the_history(tmp_path, capsys):
    from rampwork.cli import example_text, main

    scene = tmp_path / "least_work.toml"
    scene.write_text(example_text("least_work"), encoding="utf-8")
    out = tmp_path / "history.nc"
    code = main(["optimise", str(scene), "-o", str(out), "--set", "optimise.maxiter=3",
                 "--checkpoint", str(tmp_path / "run.npz")])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "generation 3/3" in captured.err and "best          W_friction" in captured.out
    history = rw.open_dataset(out)
    assert history.sizes["generation"] == 3 and history.attrs["objective"] == "W_friction"
    assert history.attrs["rampwork_scene"].startswith("# rampwork scene file")
    # bad input: one line naming the file and the key, before any work
    for override, where in (("optimise.popsize=1", "optimise.popsize"), ("optimise.k=0", "shape.k"),
                            ("optimise.colour=1", "[optimise]"), ("x0=0.5", "x0")):
        assert main(["optimise", str(scene), "-o", str(tmp_path / "x.nc"), "--set", override]) == 2
        err = capsys.readouterr().err
        assert str(scene) in err and where in err, (override, err)
    assert not (tmp_path / "x.nc").exists()


def test_cli_optimise_a_cusp_curve_finds_the_frictional_brachistochrone(tmp_path, capsys):
    """``shape = "cusp_curve"`` on a curve scene: the example's optimisation
    lands within 1e-6 of the derived optimum's time and not below it."""
    from rampwork.cli import example_text, main

    scene = tmp_path / "fastest_descent.toml"
    scene.write_text(example_text("fastest_descent"), encoding="utf-8")
    out = tmp_path / "history.nc"
    code = main(["optimise", str(scene), "-o", str(out), "--set", "optimise.maxiter=20", "--threads", "1"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "generation 20/20" in captured.err and "best          t_end" in captured.out
    history = rw.open_dataset(out)
    optimum = frictional_brachistochrone((1.0, -1.0), mu=0.2).time
    best = history.attrs["best_objective"]
    assert optimum * (1 - 1e-10) < best < optimum * (1 + 1e-6)
    assert history.attrs["K"] == 4 and "CuspCurve" in history.attrs["shape"]
    # bad input: one line naming the file and the key, before any work
    for override, where in (("optimise.k=0", "optimise.k"), ("optimise.end=[1.0, 0.5]", "optimise.end"),
                            ("optimise.start=[0.0, 0.0]", "optimise.start"), ("s0=0.1", "s0"),
                            ("curve.family='loop'", "[curve]"), ("optimise.amplitude=1.0", "optimise.amplitude")):
        assert main(["optimise", str(scene), "-o", str(tmp_path / "x.nc"), "--set", override]) == 2
        err = capsys.readouterr().err
        assert str(scene) in err and where in err, (override, err)
    assert not (tmp_path / "x.nc").exists()
