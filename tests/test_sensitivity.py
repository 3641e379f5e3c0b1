"""Sobol' indices (rampwork.sensitivity): the machinery against functions with
known indices (the Ishigami function, an additive model), and on rampwork's
own outputs, where one axis provably does not enter the output."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

import rampwork as rw
from rampwork import ishigami, schema
from rampwork.sensitivity import SensitivityError, bar_chart, sobol_indices, sobol_indices_of

pytest.importorskip("SALib")

# the literature values (Ishigami and Homma 1990; Sobol' and Levitan 1999), a = 7, b = 0.1
ISHIGAMI_S1 = np.array([0.3139, 0.4424, 0.0])
ISHIGAMI_ST = np.array([0.5576, 0.4424, 0.2437])


@pytest.fixture(scope="module")
def ishigami_run():
    return sobol_indices_of(ishigami.ishigami, ishigami.RANGES, n=4096, seed=0, second_order=True,
                            name="ishigami")


def test_ishigami_analytic_indices_are_the_literature_values():
    exact = ishigami.indices()
    np.testing.assert_allclose(exact["S1"], ISHIGAMI_S1, atol=5e-5)
    np.testing.assert_allclose(exact["ST"], ISHIGAMI_ST, atol=5e-5)
    assert exact["S2"][0, 2] == exact["S2"][2, 0] == pytest.approx(ISHIGAMI_ST[2], abs=5e-5)
    # the variance decomposes into S1 and the one interaction
    assert exact["S1"].sum() + exact["S2"][0, 2] == pytest.approx(1.0)


def test_ishigami_through_the_same_code_path(ishigami_run):
    ds = ishigami_run
    assert list(ds["parameter"].values) == ["x1", "x2", "x3"]
    for key, exact in (("S1", ISHIGAMI_S1), ("ST", ISHIGAMI_ST)):
        error = np.abs(ds[key].values - exact)
        conf = ds[f"{key}_conf"].values
        assert np.all(error <= conf + 0.01), (key, ds[key].values, conf)
        assert np.all(conf < 0.06) and np.all(conf > 0)  # informative intervals
        assert np.all(error < 0.02), (key, ds[key].values)
    # the one interaction, x1 with x3; none between the others
    s2 = ds["S2"]
    assert abs(float(s2.sel(parameter="x1", parameter2="x3")) - ISHIGAMI_ST[2]) < 0.02
    assert abs(float(s2.sel(parameter="x1", parameter2="x2"))) < 0.02
    np.testing.assert_array_equal(s2.values, s2.values.T)
    assert np.isnan(np.diag(s2.values)).all()
    assert ishigami.misses(ds) == []
    assert ds.attrs["n_runs"] == 4096 * (2 * 3 + 2) and ds.attrs["n"] == 4096


def test_ishigami_check_notices_a_wrong_answer(ishigami_run):
    # the same estimates against another function's indices: the check fails
    found = ishigami.misses(ishigami_run, a=5.0, b=0.1)
    assert any(m.startswith("S1[x2]") for m in found), found
    wide = ishigami_run.copy()
    wide["S1_conf"] = wide["S1_conf"] * 0 + 0.2
    assert any("wider than" in m for m in ishigami.misses(wide))


def test_additive_model_has_exact_shares_and_log_axes():
    """y = 3 a - 2 b + ln c + 0 d, a, b uniform, c log-uniform: S1 = ST =
    coefficient^2 var / total, and d (unused) gets exactly 0."""
    ranges = {"a": (0.0, 1.0), "b": (-1.0, 2.0), "c": (0.1, 10.0), "d": (5.0, 6.0)}
    variances = np.array([9 * 1 / 12, 4 * 9 / 12, math.log(100) ** 2 / 12, 0.0])
    shares = variances / variances.sum()

    def model(columns):
        return 3 * columns["a"] - 2 * columns["b"] + np.log(columns["c"]) + 0 * columns["d"]

    ds = sobol_indices_of(model, ranges, n=1024, seed=3, log=["c"], keep_runs=True,
                          parameter_units={"a": "m"})
    np.testing.assert_allclose(ds["S1"].values, shares, atol=0.01)
    np.testing.assert_allclose(ds["ST"].values, shares, atol=0.01)
    assert ds["S1"].sel(parameter="d") == 0 and ds["ST"].sel(parameter="d") == 0
    assert ds["S1_conf"].sel(parameter="d") == 0
    # the design: inside the ranges, the log axis uniform in its logarithm
    assert ds.sizes["case"] == 1024 * (4 + 2)
    for name, (low, high) in ranges.items():
        assert float(ds[name].min()) >= low and float(ds[name].max()) <= high
    assert abs(float(np.log(ds["c"]).mean()) - 0.0) < 0.02  # midpoint of [ln 0.1, ln 10]
    assert abs(float(ds["c"].median()) - 1.0) < 0.05
    assert list(ds["distribution"].values) == ["uniform", "uniform", "log-uniform", "uniform"]
    assert ds["parameter_units"].sel(parameter="a") == "m"
    assert ds["y"].size == ds.sizes["case"]
    assert "c: log-uniform [0.1, 10]" in ds.attrs["design"]


def test_seeded_and_reproducible():
    run = lambda seed: sobol_indices_of(ishigami.ishigami, ishigami.RANGES, n=256, seed=seed)  # noqa: E731
    first, again, other = run(1), run(1), run(2)
    np.testing.assert_array_equal(first["S1"].values, again["S1"].values)
    np.testing.assert_array_equal(first["S1_conf"].values, again["S1_conf"].values)  # bootstrap seeded
    assert not np.array_equal(first["S1"].values, other["S1"].values)
    # seed 0 also seeds the bootstrap (SALib takes seed=0 for "unseeded")
    zero = [sobol_indices_of(ishigami.ishigami, ishigami.RANGES, n=64, seed=0) for _ in range(2)]
    np.testing.assert_array_equal(zero[0]["ST_conf"].values, zero[1]["ST_conf"].values)


# ------------------------------------------------------------------------------
# rampwork's outputs
# ------------------------------------------------------------------------------
def bowl(**changes) -> rw.Scene:
    """A parabolic bowl y = height + x^2 / 2: convex, so nothing lifts off."""
    settings = dict(ramp=rw.Ramp.create("quadratic", curvature=1.0, domain=(-2.0, 2.0)),
                    integrator=rw.Integrator("rk4", 1e-3), x0=0.5, t_max=60.0,
                    title="a bowl")
    return rw.Scene(**{**settings, **changes})


BOWL_RANGES = {"mu": (0.1, 0.3), "x0": (0.5, 1.0), "v0": (-1.0, 1.0), "height": (-5.0, 5.0)}


@pytest.fixture(scope="module")
def bowl_run():
    return sobol_indices(bowl(), "W_excess", BOWL_RANGES, n=16, seed=0, accept=("stuck",),
                         keep_runs=True)


def test_rampwork_path_structure_units_and_attributes(bowl_run, tmp_path):
    ds = bowl_run
    names = list(BOWL_RANGES)
    assert list(ds["parameter"].values) == names
    assert list(ds["parameter_units"].values) == ["1", "m", "m s-1", "m"]
    for key in ("S1", "S1_conf", "ST", "ST_conf"):
        assert ds[key].dims == ("parameter",) and ds[key].attrs["units"] == "1"
    assert "S2" not in ds
    attrs = ds.attrs
    assert attrs["output"] == "W_excess" and attrs["output_units"] == "J"
    assert attrs["n"] == 16 and attrs["seed"] == 0 and attrs["n_runs"] == 16 * (4 + 2)
    assert "SALib" in attrs["sampler"] and "SALib" in attrs["estimator"]
    assert attrs["conf_level"] == 0.95 and attrs["status_counts"] == f"stuck: {16 * 6}"
    assert "[ramp]" in attrs["rampwork_scene"] and 'family = "quadratic"' in attrs["rampwork_scene"]
    assert attrs["n_filled"] == 0
    # the runs: every design row, inside its range, all at rest in the bowl
    assert ds.sizes["case"] == 96 and (ds["status"] == 1).all()
    for name, (low, high) in BOWL_RANGES.items():
        assert low <= float(ds[name].min()) and float(ds[name].max()) <= high
        assert ds[name].attrs["units"] == schema.axis_spec(
            name, rw.FAMILIES["quadratic"].parameters).units
    # the values analysed, and every other output, are simulate's own for the same cases
    direct = rw.simulate(bowl(), rw.Sweep.cases(**{n: ds[n].values for n in names}))
    for name in ("W_excess", "W_friction", "x_end", "steps"):
        np.testing.assert_array_equal(direct[name].values, ds[name].values)
        assert ds[name].attrs["units"] == schema.OUTPUTS[name].units
    # a rampwork dataset: written and read back
    path = rw.write_netcdf(ds, tmp_path / "indices.nc")
    back = rw.open_dataset(path)
    np.testing.assert_array_equal(back["ST"].values, ds["ST"].values)
    assert list(back["parameter"].values) == names


def test_the_ramp_height_does_not_drive_the_excess_work(bowl_run):
    """Only f' and f'' enter the equations of motion and the friction work:
    lifting the whole ramp changes nothing, so both its indices are zero
    (exactly: every run that differs from another only in height gives the
    same W_excess), while the start and friction axes drive it."""
    ds = bowl_run
    assert float(ds["S1"].sel(parameter="height")) == 0.0
    assert float(ds["ST"].sel(parameter="height")) == 0.0
    driven = ds["ST"].sel(parameter=["mu", "x0", "v0"])
    assert (driven > 0.01).all(), driven.values


def test_flagged_trajectories_are_refused_or_filled():
    short = bowl(t_max=0.05)  # every block still moving: timeout
    with pytest.raises(SensitivityError) as error:
        sobol_indices(short, "W_excess", BOWL_RANGES, n=8, seed=0)
    message = str(error.value)
    assert "48 of 48 trajectories" in message and "48 timeout" in message
    assert "fill=" in message and "accept=" in message and "the first at mu = " in message
    assert error.value.counts == {"timeout": 48}
    assert pickle.loads(pickle.dumps(error.value)).counts == {"timeout": 48}
    # counted on request: the work done by t_max
    counted = sobol_indices(short, "W_friction", BOWL_RANGES, n=8, seed=0, accept=["timeout"])
    assert counted.attrs["status_counts"] == "timeout: 48"
    # or filled: every value replaced by a constant leaves no variance
    with pytest.raises(SensitivityError, match="constant"):
        sobol_indices(short, "W_excess", BOWL_RANGES, n=8, seed=0, fill=0.0)


def test_bar_chart_draws_both_indices_with_intervals(bowl_run):
    ax = bar_chart(bowl_run, title="t")
    bars = [p for p in ax.patches]
    assert len(bars) == 2 * 4
    heights = sorted(round(b.get_height(), 12) for b in bars)
    expected = sorted(np.round(np.r_[bowl_run["S1"].values, bowl_run["ST"].values], 12))
    np.testing.assert_allclose(heights, expected)
    assert len(ax.get_legend().get_texts()) == 2 and ax.get_title() == "t"


# ------------------------------------------------------------------------------
# errors: refused before any work, naming the parameter, the value, what is allowed
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, where, words", [
    (dict(output="W_nope"), "output", "unknown output 'W_nope'; allowed: per-trajectory outputs t_end"),
    (dict(output="status"), "output", "a category"),
    (dict(output="W_drag"), "output", "not computed in this run"),
    (dict(output="W_friction_error_estimate"), "output", "not computed in this run"),
    (dict(ranges={"mu": (0.1, 0.2), "radius": (1, 2)}), "ranges.radius", "unknown axis; allowed: mu"),
    (dict(ranges={"mu": (0.3, 0.1)}), "ranges.mu", "low must be < high"),
    (dict(ranges={"mu": (0.1, 0.1)}), "ranges.mu", "low must be < high"),
    (dict(ranges={"mu": (0.1, "x")}), "ranges.mu", "expected a finite number"),
    (dict(ranges={"mu": (0.1, float("nan"))}), "ranges.mu", "must be a finite number"),
    (dict(ranges={"mu": 0.1}), "ranges.mu", "expected (low, high)"),
    (dict(ranges={}), "ranges", "at least one axis"),
    (dict(ranges={"x0": (0.0, 3.0)}), "ranges.x0", "3.0 is outside the ramp's domain"),
    (dict(ranges={"mu": (-0.1, 0.2)}), "ranges.mu", "must be >= 0"),
    (dict(log=["x0"]), "ranges.x0", "log-uniform needs low > 0"),
    (dict(log=["v0"]), "log", "names not among the ranges: 'v0'"),
    (dict(log="mu"), "log", "expected a list of axis names"),
    (dict(n=1000), "n", "must be a power of 2"),
    (dict(n=4), "n", "must be >= 8"),
    (dict(n=16.0), "n", "expected an integer"),
    (dict(seed=-1), "seed", "must be >= 0"),
    (dict(ranges={"mu": (0.1, 0.2)}, second_order=True), "second_order", "at least two axes"),
    (dict(conf_level=95), "conf_level", "between 0 and 1"),
    (dict(accept=["stuck", "flew"]), "accept[1]", "unknown value 'flew'"),
    (dict(accept="stuck"), "accept", "expected a list"),
    (dict(fill=float("nan")), "fill", "finite"),
])
def test_bad_input_is_refused_up_front(kwargs, where, words, monkeypatch):
    monkeypatch.setattr(rw.sensitivity, "simulate", None)  # nothing may run
    arguments = dict(output="W_excess", ranges={"mu": (0.1, 0.2), "x0": (-1.0, 1.0)})
    arguments.update(kwargs)
    with pytest.raises(rw.ConfigError) as error:
        sobol_indices(bowl(), **arguments)
    assert error.value.where == where
    if words:
        assert words in error.value.problem, error.value.problem


def test_n_error_suggests_powers_of_two():
    with pytest.raises(rw.ConfigError, match="e.g. 512 or 1024"):
        sobol_indices_of(ishigami.ishigami, ishigami.RANGES, n=1000)


def test_model_errors():
    with pytest.raises(rw.ConfigError, match=r"expected \(40,\) numbers"):
        sobol_indices_of(lambda c: np.zeros(3), ishigami.RANGES, n=8)
    with pytest.raises(SensitivityError, match="2 of 32 values of y are not finite") as error:
        sobol_indices_of(lambda c: np.where(np.arange(32) < 2, np.nan, c["x1"]),
                         {"x1": (0, 1), "x2": (0, 1)}, n=8)
    assert error.value.counts == {"non-finite": 2}
    with pytest.raises(SensitivityError, match="constant"):
        sobol_indices_of(lambda c: np.ones(32), {"x1": (0, 1), "x2": (0, 1)}, n=8)
    with pytest.raises(rw.ConfigError, match="expected a function"):
        sobol_indices_of("f", {"x1": (0, 1)}, n=8)
    with pytest.raises(rw.ConfigError, match="expected a rampwork.Scene"):
        sobol_indices("scene", "W_excess", {"mu": (0, 1)})
