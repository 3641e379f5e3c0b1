"""Schema registry and netCDF round trips (fast)."""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from rampwork import io, schema
from rampwork.core.status import STATUS_TABLE
from rampwork.errors import ConfigError

SCENE = '[ramp]\nfamily = "parabola"\na = 0.5\n\n[sweep]\nmu = [0.1, 0.2]\n'

EXPECTED_OUTPUTS = [
    "status", "t_end", "x_end", "v_end", "W_friction", "W_energy", "W_linear", "W_excess",
    "W_path", "energy_balance_error", "convexity_mean", "path_length_x", "n_reversals",
    "x_lift_off", "x_lift_off_paper", "steps", "steps_rejected", "W_friction_error_estimate",
    "W_drag",
]  # fmt: skip


@dataclass(frozen=True)
class RampParam:
    name: str
    units: str
    long_name: str


def _fill(name, shape, rng):
    spec = schema.OUTPUTS[name]
    if name == "status":
        return rng.integers(0, len(STATUS_TABLE), size=shape).astype(np.int8)
    if spec.np_dtype.kind in "iu":
        return rng.integers(0, 10_000, size=shape).astype(spec.np_dtype)
    a = rng.standard_normal(shape)
    if name == "x_lift_off":
        a[rng.random(shape) < 0.7] = np.nan
    return a


def _dataset(kind="grid", seed=0):
    rng = np.random.default_rng(seed)
    params = [RampParam("a", "m-1", "curvature of the parabola")]
    if kind == "grid":
        coords = {"mu": np.linspace(0.0, 0.5, 6), "x0": np.linspace(-1.0, 2.0, 7)}
        dims, shape = ("mu", "x0"), (6, 7)
        ds = xr.Dataset(coords={k: (k, v, schema.output_attrs(k)) for k, v in coords.items()})
    else:
        n = 23
        dims, shape = (schema.CASE_DIM,), (n,)
        ds = xr.Dataset(
            coords={
                "mu_k": ((schema.CASE_DIM,), rng.random(n), schema.output_attrs("mu_k")),
                "x0": ((schema.CASE_DIM,), rng.random(n), schema.output_attrs("x0")),
                "a": ((schema.CASE_DIM,), rng.random(n), schema.spec_attrs(schema.axis_spec("a", params))),
            }
        )
    for name in schema.OUTPUTS:
        ds[name] = (dims, _fill(name, shape, rng), schema.output_attrs(name))
    ds.attrs = schema.global_attrs(
        "test sweep",
        SCENE,
        "rampwork run scene.toml",
        {"integrator": {"dt": 1e-3, "adaptive": True, "tol": None, "order": 4}, "seeds": [1, 2, 3]},
    )
    return ds


def _assert_identical_values(a: xr.Dataset, b: xr.Dataset):
    assert set(a.variables) == set(b.variables)
    for name in a.variables:
        va, vb = a[name].values, b[name].values
        assert va.dtype == vb.dtype, name
        assert va.shape == vb.shape, name
        # bit-identical, NaN included
        assert va.tobytes() == vb.tobytes(), name


# ---------------------------------------------------------------- schema


def test_outputs_order_and_dtypes():
    assert list(schema.OUTPUTS) == EXPECTED_OUTPUTS
    # optional outputs only where they apply
    assert "x_lift_off_paper" not in schema.output_names(True)
    assert "W_friction_error_estimate" not in schema.output_names(False, ("x_lift_off_paper",))
    assert "x_lift_off_paper" in schema.output_names(False, ("x_lift_off_paper",))
    assert schema.OUTPUTS["status"].dtype == "int8"
    assert schema.OUTPUTS["n_reversals"].dtype == "int32"
    assert schema.OUTPUTS["steps"].dtype == "int64"
    assert np.isnan(schema.OUTPUTS["x_lift_off"].fill_value)
    assert schema.OUTPUTS["status"].fill_value is None
    with pytest.raises(Exception):
        schema.OUTPUTS["t_end"].units = "min"  # frozen


UDUNITS_LIKE = re.compile(r"^(1|[A-Za-z]+(-?\d+)?( [A-Za-z]+(-?\d+)?)*)$")
ALLOWED_UNITS = {"1", "s", "m", "m s-1", "m s-2", "J", "m-1", "kg", "s-1"}


@pytest.mark.parametrize(
    "table", [schema.OUTPUTS, schema.AXES, schema.TRAJECTORY_RECORD], ids=["outputs", "axes", "trace"]
)
def test_every_variable_has_cf_units_and_long_name(table):
    for name, spec in table.items():
        assert spec.name == name
        assert spec.units and spec.long_name and spec.description, name
        assert UDUNITS_LIKE.match(spec.units), (name, spec.units)
        assert spec.units in ALLOWED_UNITS, (name, spec.units)
        for bad in ("sec", "meter", "/", "^", "**", "joule", "kg*"):
            assert bad not in spec.units.lower(), (name, spec.units)


def test_expected_units():
    u = {k: v.units for k, v in schema.OUTPUTS.items()}
    assert u["t_end"] == "s" and u["x_end"] == "m" and u["v_end"] == "m s-1"
    assert u["W_friction"] == u["W_excess"] == u["energy_balance_error"] == "J"
    assert u["convexity_mean"] == "m-1" and u["status"] == "1" and u["steps"] == "1"
    assert schema.AXES["g"].units == "m s-2" and schema.AXES["mu"].units == "1"


def test_status_flags():
    attrs = schema.output_attrs("status")
    assert attrs["flag_values"].dtype == np.int8
    assert list(attrs["flag_values"]) == [code for code, _, _ in STATUS_TABLE]
    assert attrs["flag_meanings"].split() == [name for _, name, _ in STATUS_TABLE]
    assert attrs["long_name"] == "trajectory end status"
    assert all(meaning in attrs["flag_descriptions"] for _, _, meaning in STATUS_TABLE)


def test_axis_spec():
    params = [RampParam("a", "m-1", "curvature"), RampParam("L", "m", "length")]
    assert schema.axis_spec("mu") is schema.AXES["mu"]
    spec = schema.axis_spec("L", params)
    assert (spec.units, spec.long_name, spec.dtype) == ("m", "length", "float64")
    with pytest.raises(ConfigError) as err:
        schema.axis_spec("nope", params)
    msg = str(err.value)
    assert "nope" in msg and "mu_k" in msg and "L" in msg and "\n" not in msg


def test_global_attrs_flattened():
    attrs = schema.global_attrs(
        "t", SCENE, "rampwork run x.toml",
        {"a": True, "b": None, "c": {"d": 1.5, "e": [1, 2]}, "f": ["x", "y"], "g": False},
    )  # fmt: skip
    assert attrs["Conventions"] == "CF-1.10"
    assert attrs["source"].startswith("rampwork ")
    assert re.match(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ: rampwork run x.toml$", attrs["history"])
    assert attrs["rampwork_scene"] == SCENE
    assert attrs["a"] == 1 and attrs["g"] == 0 and "b" not in attrs
    assert attrs["c_d"] == 1.5 and list(attrs["c_e"]) == [1, 2]
    assert attrs["f"] == "x, y"
    for v in attrs.values():
        assert isinstance(v, (str, int, float, np.ndarray, np.number)) and not isinstance(v, bool)


def test_empty_output():
    assert np.isnan(schema.empty_output("W_friction", (2, 3))).all()
    s = schema.empty_output("status", 4)
    assert s.dtype == np.int8 and (s == 0).all()


# ---------------------------------------------------------------- io


@pytest.mark.parametrize("kind", ["grid", "case"])
def test_round_trip(tmp_path, kind):
    ds = _dataset(kind)
    path = tmp_path / "out.nc"
    assert io.write_netcdf(ds, path) == path
    back = io.open_dataset(path)
    _assert_identical_values(ds, back)
    assert back["status"].dtype == np.int8
    for name in ds.variables:
        for key in ("units", "long_name"):
            assert back[name].attrs[key] == ds[name].attrs[key], (name, key)
    np.testing.assert_array_equal(back["status"].attrs["flag_values"], schema.STATUS_FLAG_VALUES)
    assert back["status"].attrs["flag_values"].dtype == np.int8
    assert back["status"].attrs["flag_meanings"] == schema.STATUS_FLAG_MEANINGS
    for key in ("Conventions", "title", "source", "history", "rampwork_scene"):
        assert back.attrs[key] == ds.attrs[key], key
    assert back.attrs["integrator_adaptive"] == 1 and "integrator_tol" not in back.attrs
    # encoding: compressed, NaN fill for floats, none for ints
    for name in schema.OUTPUTS:
        enc = back[name].encoding
        assert enc.get("zlib") is True, name
        if schema.OUTPUTS[name].np_dtype.kind == "f":
            assert np.isnan(enc["_FillValue"]), name
        else:
            assert "_FillValue" not in enc, name
    # a loaded dataset can be written again, identically
    path2 = tmp_path / "again.nc"
    io.write_netcdf(back, path2)
    _assert_identical_values(ds, io.open_dataset(path2))


def test_file_closed_after_open(tmp_path):
    path = tmp_path / "out.nc"
    io.write_netcdf(_dataset(), path)
    back = io.open_dataset(path)
    fd_dir = Path("/proc/self/fd")
    if fd_dir.is_dir():
        targets = {os.path.realpath(fd_dir / fd) for fd in os.listdir(fd_dir)}
        assert os.path.realpath(path) not in targets
    path.unlink()
    _assert_identical_values(_dataset(), back)  # data are in memory


def test_compression_on(tmp_path):
    big = xr.Dataset({"W_friction": (("mu", "x0"), np.zeros((400, 500)), schema.output_attrs("W_friction"))})
    big.attrs = schema.global_attrs("t", SCENE, "x", {})
    path = tmp_path / "c.nc"
    io.write_netcdf(big, path)
    assert path.stat().st_size < big["W_friction"].nbytes / 20
    enc = io.open_dataset(path)["W_friction"].encoding
    assert enc["zlib"] and enc["complevel"] == 4
    chunk_bytes = np.prod(enc["chunksizes"]) * 8
    assert chunk_bytes <= io.CHUNK_BYTES


def test_chunksizes():
    assert io._chunksizes((10,), 8) == (10,)
    assert io._chunksizes((1_000_000,), 8) == (131072,)
    c = io._chunksizes((1000, 1000, 7), 8)
    assert np.prod(c) * 8 <= io.CHUNK_BYTES and c[1:] == (1000, 7)


def test_refuses_overwrite_then_overwrites(tmp_path):
    path = tmp_path / "out.nc"
    io.write_netcdf(_dataset(seed=1), path)
    before = path.read_bytes()
    with pytest.raises(ConfigError) as err:
        io.write_netcdf(_dataset(seed=2), path)
    assert str(err.value) == f"{path}: exists; pass overwrite=True to replace it"
    assert path.read_bytes() == before
    io.write_netcdf(_dataset(seed=2), path, overwrite=True)
    _assert_identical_values(_dataset(seed=2), io.open_dataset(path))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.nc"]


@pytest.mark.parametrize("exc", [RuntimeError("disk full"), KeyboardInterrupt()])
@pytest.mark.parametrize("existing", [False, True])
def test_atomic_on_failure(tmp_path, monkeypatch, exc, existing):
    path = tmp_path / "out.nc"
    if existing:
        io.write_netcdf(_dataset(seed=1), path)
    before = path.read_bytes() if existing else None
    real = xr.Dataset.to_netcdf

    def failing(self, target, *args, **kwargs):
        real(self, target, *args, **kwargs)  # leave a half-finished temp file behind
        assert Path(target) == io.temp_path(path) and Path(target).exists()
        raise exc

    monkeypatch.setattr(xr.Dataset, "to_netcdf", failing)
    with pytest.raises(type(exc)):
        io.write_netcdf(_dataset(seed=2), path, overwrite=True)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == (["out.nc"] if existing else [])
    if existing:
        assert path.read_bytes() == before


def test_unwritable_directory(tmp_path, monkeypatch):
    missing = tmp_path / "no" / "such" / "out.nc"
    with pytest.raises(ConfigError) as err:
        io.check_writable(missing, overwrite=False)
    assert "does not exist" in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(ConfigError):
        io.write_netcdf(_dataset(), missing)

    monkeypatch.setattr(io.os, "access", lambda *a, **k: False)
    with pytest.raises(ConfigError) as err:
        io.write_netcdf(_dataset(), tmp_path / "out.nc")
    msg = str(err.value)
    assert msg.startswith(str(tmp_path / "out.nc")) and "not writable" in msg and "\n" not in msg
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root can write anywhere")
def test_unwritable_directory_chmod(tmp_path):
    d = tmp_path / "ro"
    d.mkdir()
    d.chmod(0o500)
    try:
        with pytest.raises(ConfigError, match="not writable"):
            io.check_writable(d / "out.nc", overwrite=False)
    finally:
        d.chmod(0o700)


def test_open_errors(tmp_path):
    with pytest.raises(ConfigError, match="no such file"):
        io.open_dataset(tmp_path / "missing.nc")
    junk = tmp_path / "junk.nc"
    junk.write_text("not netcdf")
    with pytest.raises(ConfigError, match="cannot be read"):
        io.open_dataset(junk)
    foreign = tmp_path / "foreign.nc"
    xr.Dataset({"a": ("x", np.arange(3.0))}).to_netcdf(foreign, engine="netcdf4")
    with pytest.raises(ConfigError, match="not a rampwork dataset"):
        io.open_dataset(foreign)


def test_bad_compression_level(tmp_path):
    with pytest.raises(ConfigError, match="compression_level"):
        io.write_netcdf(_dataset(), tmp_path / "x.nc", compression_level=12)
