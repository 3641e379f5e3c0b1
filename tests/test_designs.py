"""Designs kept as recipes (rampwork.designs): case i's values depend on the
recipe and i only, whatever the chunks, threads, workers or a resume; the
qmc designs are scipy's own sequences; size limits and bad recipes are
refused before anything is allocated; the scene text holds the recipe."""

import math
import tracemalloc

import numpy as np
import pytest
from scipy.stats import qmc

import rampwork as rw
from rampwork import runner, streaming
from rampwork.cli import main
from rampwork.designs import DESIGN_KINDS, Design, DesignAxis, strata_permutation
from rampwork.plan import plan_run
from rampwork.scenefile import dump_scene, parse_scene
from rampwork.streaming import partial_path

from test_streaming import _scene, _stop_after, assert_same_data, assert_same_file

RANGES = {"mu": (0.05, 0.4), "curvature": (0.1, 3.0), "x0": (-0.9, -0.1)}
LOG = ("curvature",)


def _design(kind, n, seed=7):
    return Design.from_ranges(kind, n, seed, LOG, **RANGES)


def _n(kind, n):
    """n, or the power of 2 above it for Sobol'."""
    return 1 << (n - 1).bit_length() if kind == "sobol" else n


# ------------------------------------------------------------------------------
# the values: reproducible case by case, and the generators they claim to be
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", DESIGN_KINDS)
def test_values_depend_on_the_case_only_not_on_the_chunks(kind):
    design = _design(kind, _n(kind, 1000))
    whole = design.draw()
    rng = np.random.default_rng(0)
    for size in (1, 7, 100, 333, design.n):
        starts = list(range(0, design.n, size))
        rng.shuffle(starts)  # any order: a chunk does not follow its predecessor
        pieces = {start: design.draw(start, min(start + size, design.n)) for start in starts}
        for name in whole:
            joined = np.concatenate([pieces[start][name] for start in sorted(pieces)])
            assert joined.tobytes() == whole[name].tobytes(), (kind, size, name)
    assert design.draw(design.n, design.n)["mu"].size == 0


@pytest.mark.parametrize("kind", DESIGN_KINDS)
def test_values_lie_in_their_ranges_and_the_seed_matters(kind):
    design = _design(kind, _n(kind, 4096))
    values = design.draw()
    for name, (low, high) in RANGES.items():
        assert values[name].dtype == np.float64 and values[name].shape == (design.n,)
        assert low <= values[name].min() and values[name].max() <= high, name
        # spread over the whole range (a space-filling design reaches both ends)
        assert values[name].max() - values[name].min() > 0.95 * (high - low), name
    other = Design.from_ranges(kind, design.n, design.seed + 1, LOG, **RANGES).draw()
    assert not np.array_equal(values["mu"], other["mu"])


def test_random_design_is_numpys_philox_stream():
    design = _design("random", 1000, seed=11)
    unit = np.random.Generator(np.random.Philox(11)).random((1000, 3))
    values = design.draw()
    assert np.array_equal(design.unit(0, 1000), unit)
    assert np.array_equal(values["mu"], 0.05 + unit[:, 0] * (0.4 - 0.05))
    assert np.array_equal(values["curvature"], np.exp(math.log(0.1) + unit[:, 1] * (math.log(3.0) - math.log(0.1))))
    # a late chunk jumps there (Philox.advance), it does not draw what comes before
    assert np.array_equal(design.unit(997, 1000), unit[997:])


@pytest.mark.parametrize("kind", ["sobol", "halton"])
def test_qmc_designs_are_scipys_scrambled_sequences(kind):
    engine = {"sobol": qmc.Sobol, "halton": qmc.Halton}[kind]
    ranges = {"mu": (0.05, 0.4), "x0": (-0.9, -0.1), "v0": (0.0, 1.5)}
    design = Design.from_ranges(kind, 256, 5, **ranges)
    unit = engine(3, scramble=True, rng=5).random(256)
    expected = qmc.scale(unit, [low for low, _ in ranges.values()], [high for _, high in ranges.values()])
    values = design.draw()
    for j, name in enumerate(ranges):
        assert np.array_equal(values[name], expected[:, j]), name
    assert np.array_equal(design.unit(100, 200), unit[100:200])
    # log-uniform: the same points scaled in the logarithm
    logged = Design.from_ranges(kind, 256, 5, log=("v0",), mu=(0.05, 0.4), v0=(0.01, 10.0)).draw()
    unit = engine(2, scramble=True, rng=5).random(256)
    assert np.allclose(np.log10(logged["v0"]), -2 + 3 * unit[:, 1], rtol=0, atol=1e-12)


@pytest.mark.parametrize("kind", ["sobol", "halton"])
def test_a_late_chunk_draws_only_its_own_points(kind, monkeypatch):
    engine = {"sobol": qmc.Sobol, "halton": qmc.Halton}[kind]
    drawn = []
    original = engine._random
    monkeypatch.setattr(engine, "_random", lambda self, n=1, **kwargs: drawn.append(n) or original(self, n, **kwargs))
    design = _design(kind, 1 << 26)
    assert design.unit(design.n - 3, design.n).shape == (3, 3)
    assert drawn == [3]  # not the 2**26 - 3 points before them


def test_sobol_draws_warn_of_nothing_whatever_the_chunk(recwarn):
    design = _design("sobol", 1024)
    design.draw(0, 1000)
    design.draw(1000, 1024)
    assert not [w for w in recwarn if "power of 2" in str(w.message)]


@pytest.mark.parametrize("n", [1, 2, 3, 5, 16, 1000, 1024, 4097])
def test_latin_hypercube_puts_one_case_in_every_stratum_of_every_axis(n):
    design = Design.from_ranges("lhs", n, 3, a=(0.0, 1.0), b=(0.0, 1.0), c=(0.0, 1.0))
    unit = design.unit(0, n)
    assert (unit >= 0).all() and (unit < 1).all()
    strata = np.floor(unit * n).astype(np.int64)
    for j in range(3):
        assert np.array_equal(np.sort(strata[:, j]), np.arange(n)), j
    if n >= 16:  # the axes are paired by independent permutations, not in step
        assert not np.array_equal(strata[:, 0], strata[:, 1])
        assert abs(np.corrcoef(unit.T)[0, 1]) < 0.5


def test_log_uniform_latin_hypercube_has_its_strata_in_the_logarithm():
    values = Design.from_ranges("lhs", 1000, 1, log=("v0",), v0=(1e-3, 1e3)).draw()["v0"]
    strata = np.floor((np.log10(values) + 3) / 6 * 1000 + 1e-9).astype(np.int64)
    assert np.array_equal(np.sort(strata), np.arange(1000))


@pytest.mark.parametrize("n", [1, 2, 7, 64, 1000, 65537])
def test_strata_permutation_is_a_bijection_of_range_n(n):
    keys = np.random.SeedSequence(1).generate_state(6, dtype=np.uint64)
    image = strata_permutation(np.arange(n, dtype=np.uint64), n, keys)
    assert np.array_equal(np.sort(image), np.arange(n, dtype=np.uint64))
    if n >= 64:  # and not the identity, nor a shift of it
        assert (image != np.arange(n)).mean() > 0.9
        assert len(np.unique(np.diff(image.astype(np.int64)))) > n // 4


# ------------------------------------------------------------------------------
# size limits and bad recipes: refused at construction, nothing allocated
# ------------------------------------------------------------------------------
def _peak_bytes(function):
    tracemalloc.start()
    try:
        function()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("kind", DESIGN_KINDS)
def test_a_huge_design_is_refused_by_the_cli_s_limit(kind):
    constructor = getattr(rw.Sweep, kind)
    for n in (10**12, 2**40, 10**8 + 1):
        with pytest.raises(rw.ConfigError) as error:
            constructor(n, x0=(0.0, 1.0))
        assert error.value.where == "sweep.n"
        assert "1e+08" in error.value.problem and str(n) in error.value.problem


@pytest.mark.parametrize("kind", DESIGN_KINDS)
def test_the_largest_design_costs_nothing_to_build_and_plan(kind):
    n = 2**26 if kind == "sobol" else 10**8
    scene = _scene()
    holder = {}

    def build():
        holder["sweep"] = getattr(rw.Sweep, kind)(n, seed=1, log=("v0",), x0=(-0.9, 0.5),
                                                  v0=(0.01, 2.0), mu=(0.0, 0.3))
        holder["plan"] = plan_run(scene, holder["sweep"])

    assert _peak_bytes(build) < 1 << 20  # a recipe, not 8e8 bytes of values
    assert holder["plan"].size == n and holder["sweep"].shape == (n,)
    assert len(dump_scene(scene, holder["sweep"])) < 2000


@pytest.mark.parametrize("call, where, fragments", [
    (lambda: rw.Sweep.random(0, x0=(0, 1)), "sweep.n", [">= 1"]),
    (lambda: rw.Sweep.random(2.5, x0=(0, 1)), "sweep.n", ["integer"]),
    (lambda: rw.Sweep.random(5, seed=-1, x0=(0, 1)), "sweep.seed", [">= 0"]),
    (lambda: rw.Sweep.random(5, seed=2**63, x0=(0, 1)), "sweep.seed", ["<= 9223372036854775807"]),
    (lambda: rw.Sweep.random(5), "sweep", ["at least one axis"]),
    (lambda: rw.Sweep.random(5, x0=(1, 0)), "sweep.x0", ["low must be <= high"]),
    (lambda: rw.Sweep.random(5, x0=(0, float("nan"))), "sweep.x0", ["finite"]),
    (lambda: rw.Sweep.random(5, x0=(-1e308, 1e308)), "sweep.x0", ["wider than the largest float"]),
    (lambda: rw.Sweep.random(5, x0=[0.0, 0.5, 1.0]), "sweep.x0", ["(low, high)"]),
    (lambda: rw.Sweep.random(5, log=("v0",), v0=(0.0, 1.0)), "sweep.v0", ["log-uniform", "low > 0"]),
    (lambda: rw.Sweep.random(5, log=("mu",), v0=(0.1, 1.0)), "sweep.log", ["'mu'"]),
    (lambda: rw.Sweep.random(5, log="v0", v0=(0.1, 1.0)), "sweep.log", ["list of axis names"]),
    (lambda: rw.Sweep.random(5, mu=(0, 1), mu_k=(0, 1)), "sweep.mu", ["mu_k"]),
    (lambda: rw.Sweep.sobol(1000, x0=(0, 1)), "sweep.n", ["power of 2", "1,000", "512", "1,024"]),
    (lambda: rw.Sweep(kind="random"), "sweep", ["Sweep.random"]),
    (lambda: rw.Sweep((("x0", (0.1,)),), "sobol", Design.from_ranges("sobol", 4, x0=(0, 1))), "sweep", ["recipe"]),
    (lambda: Design("grid", 5, 0, (DesignAxis("x0", 0, 1),)), "sweep.kind", ["'random'", "'lhs'"]),
    (lambda: DesignAxis("x0", 0, 1, "normal"), "sweep.x0 law", ["'uniform'", "'loguniform'"]),
])
def test_bad_recipes_are_refused_with_one_clear_line(call, where, fragments):
    with pytest.raises(rw.ConfigError) as error:
        call()
    assert error.value.where == where
    for fragment in fragments:
        assert fragment in error.value.problem, fragment
    assert "\n" not in str(error.value)


def test_planning_checks_the_ranges_and_says_so():
    scene = _scene()  # a bowl on [-1, 1]
    with pytest.raises(rw.ConfigError) as error:
        plan_run(scene, rw.Sweep.lhs(10**8, x0=(-1.5, 0.5)))
    assert error.value.where == "sweep.x0"
    assert "-1.5" in error.value.problem and "[-1.5, 0.5]" in error.value.problem
    with pytest.raises(rw.ConfigError, match=r"sweep.mu_s.*mu_k.*draws mu_s from \[0.2, 0.5\]"):
        plan_run(scene, rw.Sweep.random(100, mu_k=(0.1, 0.3), mu_s=(0.2, 0.5)))
    with pytest.raises(rw.ConfigError, match="sweep.m: must be > 0"):
        plan_run(scene, rw.Sweep.halton(100, m=(0.0, 1.0)))
    # ramp shape parameters: the ends of the ranges stand for every value
    bowl = rw.Scene(ramp=rw.Ramp.create("circular_bowl", radius=2.0, domain=(-1.0, 1.0)), x0=0.0)
    with pytest.raises(rw.ConfigError, match="ramp.domain"):
        plan_run(bowl, rw.Sweep.random(100, radius=(0.9, 2.0)))
    plan = plan_run(bowl, rw.Sweep.random(100, radius=(1.1, 2.0), x_centre=(-0.05, 0.05)))
    assert not plan.variant.check_contact  # f'' > 0 for every drawn bowl
    quadratic = plan_run(scene, rw.Sweep.random(10, curvature=(-1.0, 1.0)))
    assert quadratic.variant.check_contact  # some drawn curvatures are negative


# ------------------------------------------------------------------------------
# scene files: the recipe, for every kind
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", DESIGN_KINDS)
def test_scene_files_hold_the_recipe(kind):
    scene = _scene()
    sweep = getattr(rw.Sweep, kind)(_n(kind, 10**7), 12345, ("v0",), x0=(-0.9, -0.1), v0=(0.1, 2.0))
    text = dump_scene(scene, sweep)
    assert f'kind = "{kind}"' in text and f"n = {sweep.size}" in text and "seed = 12345" in text
    assert "x0 = { uniform = [-0.9, -0.1] }" in text and "v0 = { loguniform = [0.1, 2.0] }" in text
    assert len(text) < 1500
    assert parse_scene(text) == (scene, sweep)


def test_a_sobol_file_of_another_n_is_refused_naming_the_file():
    text = dump_scene(_scene(), rw.Sweep.sobol(1024, x0=(-0.9, 0.1))).replace("n = 1024", "n = 1000")
    with pytest.raises(rw.ConfigError) as error:
        parse_scene(text, "s.toml")
    assert error.value.where == "s.toml" and "sweep.n" in error.value.problem
    assert "power of 2" in error.value.problem


def test_old_files_with_the_drawn_values_still_load_as_cases():
    values = {"x0": [-0.5, -0.25, -0.125], "mu": [0.1, 0.2, 0.3]}
    text = dump_scene(_scene(), rw.Sweep.cases(**values))
    _, sweep = parse_scene(text)
    assert sweep.kind == "cases" and sweep.design is None
    assert np.array_equal(sweep.values("x0"), values["x0"])


# ------------------------------------------------------------------------------
# runs: the same values whatever the chunks, threads, workers, or a resume
# ------------------------------------------------------------------------------
SCENE = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0)),
                 friction=rw.Friction(0.1, 0.2), x0=-0.9, t_max=5.0)
SOBOL = rw.Sweep.sobol(128, seed=3, x0=(-0.9, 0.9), v0=(-1.0, 1.0), mu=(0.0, 0.3))


def test_a_design_runs_as_the_cases_it_draws():
    dataset = rw.simulate(SCENE, SOBOL)
    drawn = SOBOL.design.draw()
    cases = rw.simulate(SCENE, rw.Sweep.cases(**drawn))
    assert_same_data(cases, dataset)  # the same coordinates (mu, x0, v0, case) and results
    assert dataset.attrs["sweep_kind"] == "sobol"
    assert 'kind = "sobol"' in dataset.attrs["rampwork_scene"]
    assert "n = 128" in dataset.attrs["rampwork_scene"]


def test_the_reference_solver_runs_a_design_as_its_cases(reference):
    sweep = rw.Sweep.lhs(5, seed=1, x0=(-0.9, 0.5), mu=(0.05, 0.3))
    drawn = reference.reference_sweep(SCENE, sweep)
    cases = reference.reference_sweep(SCENE, rw.Sweep.cases(**sweep.design.draw()))
    assert drawn.keys() == cases.keys() and drawn["x_end"].shape == (5,)
    for key in drawn:
        assert np.array_equal(drawn[key], cases[key], equal_nan=True), key


def test_file_runs_are_identical_whatever_the_chunk_size_and_threads(tmp_path):
    scene = SCENE.replace(record=rw.Record(count=3, every=50))
    expected = rw.simulate(scene, SOBOL)
    most = min(2, runner.max_threads())
    for chunk_size, threads in ((16, 1), (37, most), (None, most)):
        path = rw.run_to_file(scene, SOBOL, tmp_path / f"{chunk_size}-{threads}.nc",
                              chunk_size=chunk_size, threads=threads)
        assert_same_file(expected, rw.open_dataset(path))


def test_a_resumed_design_run_is_identical_to_an_uninterrupted_one(tmp_path, monkeypatch):
    sweep = rw.Sweep.random(150, seed=9, log=("v0",), x0=(-0.9, 0.5), v0=(0.01, 2.0), mu=(0.0, 0.3))
    path = tmp_path / "out.nc"
    with pytest.raises(KeyboardInterrupt):
        rw.run_to_file(SCENE, sweep, path, chunk_size=20, progress=_stop_after(3))
    assert not path.exists()
    job = streaming.SweepToFile(SCENE, sweep, path, resume=True)
    assert job.resuming and job.done_chunks == 3 and job.total_chunks == 8

    ran = []
    run_chunk = runner.run_chunk
    monkeypatch.setattr(runner, "run_chunk", lambda prepared, start, stop, *a, **k:
                        ran.append(start) or run_chunk(prepared, start, stop, *a, **k))
    job.run()
    assert sorted(ran) == [60, 80, 100, 120, 140]  # only the chunks not yet done, each drawn on its own
    assert not partial_path(path).exists()
    whole = rw.run_to_file(SCENE, sweep, tmp_path / "whole.nc", chunk_size=20)
    assert_same_file(rw.open_dataset(whole), rw.open_dataset(path))
    assert_same_data(rw.simulate(SCENE, sweep), rw.open_dataset(path))


def test_a_partial_file_of_a_design_is_resumed_only_with_the_same_values(tmp_path, monkeypatch):
    sweep = rw.Sweep.random(60, seed=9, x0=(-0.9, 0.5), mu=(0.0, 0.3))
    path = tmp_path / "out.nc"
    with pytest.raises(KeyboardInterrupt):
        rw.run_to_file(SCENE, sweep, path, chunk_size=20, progress=_stop_after(1))
    import netCDF4

    with netCDF4.Dataset(partial_path(path)) as nc:  # the partial file holds the recipe
        assert 'kind = "random"' in nc.getncattr("rampwork_scene") and len(nc.getncattr("rampwork_scene")) < 1500
    # the same recipe, but a generator that draws other values (another numpy, say)
    from rampwork import designs

    drawn = designs._philox_doubles
    monkeypatch.setattr(designs, "_philox_doubles", lambda *args: np.nextafter(drawn(*args), 0.0))
    with pytest.raises(rw.ConfigError, match="numpy or scipy that draws other values"):
        streaming.SweepToFile(SCENE, sweep, path, resume=True)
    monkeypatch.undo()
    assert streaming.SweepToFile(SCENE, sweep, path, resume=True).done_chunks == 1


def test_a_design_on_a_dask_cluster_writes_the_same_file(tmp_path):
    distributed = pytest.importorskip("distributed")
    threaded = rw.run_to_file(SCENE, SOBOL, tmp_path / "threads.nc", chunk_size=30)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        path = rw.run_to_file(SCENE, SOBOL, tmp_path / "dask.nc", chunk_size=30, scheduler=client)
    assert_same_file(rw.open_dataset(threaded), rw.open_dataset(path))


# ------------------------------------------------------------------------------
# the command line: check and info summarise a design
# ------------------------------------------------------------------------------
def test_check_of_the_largest_design_summarises_it(tmp_path, capsys):
    path = tmp_path / "big.toml"
    path.write_text(dump_scene(_scene(), rw.Sweep.random(10**8, seed=4, x0=(-0.9, 0.5), mu=(0.0, 0.3))))
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "random design of 100,000,000 cases, seed 4: x0 uniform [-0.9, 0.5], mu uniform [0.0, 0.3]" in out
    assert "trajectories  100,000,000" in out
    assert main(["check", str(path), "--set", "sweep.kind=sobol"]) == 2
    assert "sweep.n" in capsys.readouterr().err


def test_info_summarises_a_design_and_cuts_long_value_lists(tmp_path, capsys):
    sweep = rw.Sweep.lhs(40, seed=2, x0=(-0.9, 0.5), mu=(0.0, 0.3))
    path = rw.run_to_file(SCENE, sweep, tmp_path / "lhs.nc")
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "sweep         Latin hypercube design of 40 cases, seed 2: x0 uniform [-0.9, 0.5]" in out
    assert 'kind = "lhs"' in out and "n = 40" in out
    # a file that lists its values (cases; rampwork <= 0.1 stored random designs so)
    values = sweep.design.draw()
    listed = rw.run_to_file(SCENE, rw.Sweep.cases(**values), tmp_path / "cases.nc")
    assert main(["info", str(listed)]) == 0
    out = capsys.readouterr().out
    assert "sweep         cases: 40 x (x0, mu)" in out
    assert "more lines of values" in out
    assert repr(float(values["mu"][-1])) not in out.split("scene:")[1]
    assert len(out.splitlines()) < 120
