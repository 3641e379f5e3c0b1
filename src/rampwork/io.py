"""netCDF writing and reading of rampwork datasets, and the choice of format.

Files are netCDF4 (HDF5) written by xarray's ``netcdf4`` engine, every numeric
variable zlib-compressed and chunked to about 1 MiB, written atomically (temp
file in the same directory, fsync, ``os.replace``). An output path ending in
``.zarr`` is a Zarr store instead (:mod:`rampwork.zarrstore`), with the same
variables, attributes and encodings: :func:`output_format` decides.
"""

from __future__ import annotations

import errno
import math
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from rampwork import schema
from rampwork.errors import ConfigError, option

__all__ = ["write_netcdf", "open_dataset", "check_writable", "temp_path", "define_variables",
           "set_attributes", "replace_file", "output_format", "CHUNK_BYTES", "NETCDF_SUFFIXES",
           "ZARR_SUFFIX"]

#: target size of one HDF5 chunk of a large variable
CHUNK_BYTES = 1 << 20

_ENGINE = "netcdf4"
_FORMAT = "NETCDF4"

#: output suffixes (any case) of the two formats; netCDF is the default format
NETCDF_SUFFIXES = (".nc", ".nc4", ".netcdf", ".cdf")
ZARR_SUFFIX = ".zarr"


def output_format(path: str | os.PathLike) -> str:
    """``"netcdf"`` or ``"zarr"``, by ``path``'s suffix; a one-line
    ConfigError for any other suffix (or none)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ZARR_SUFFIX:
        return "zarr"
    if suffix in NETCDF_SUFFIXES:
        return "netcdf"
    got = f"suffix {path.suffix!r}" if path.suffix else "no suffix"
    raise ConfigError(str(path), f"{got}: the output format is chosen by the suffix, "
                      f"{' '.join(NETCDF_SUFFIXES)} for netCDF (the default format) or "
                      f"{ZARR_SUFFIX} for a Zarr store")


def is_zarr_store(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a directory holding a Zarr store (v3 or v2)."""
    path = Path(path)
    return path.is_dir() and any((path / name).is_file() for name in ("zarr.json", ".zgroup", ".zarray"))


def _one_line(text: Any) -> str:
    return " ".join(str(text).split())


def temp_path(path: str | os.PathLike) -> Path:
    """The temporary file ``write_netcdf`` writes before renaming to ``path``."""
    path = Path(path)
    return path.with_name(f".{path.name}.tmp-{os.getpid()}")


def check_writable(path: str | os.PathLike, overwrite: bool = False, *, store: bool = False) -> Path:
    """Raise a one-line ConfigError unless ``path`` can be written.

    Cheap enough to call before a long run: checks the parent directory
    exists and is writable (by creating and removing a probe file), and that
    ``path`` does not exist unless ``overwrite``. ``store``: ``path`` is a
    Zarr store (a directory), and an existing one may be replaced; any other
    directory never is. Returns ``path`` as a Path.
    """
    path = Path(path)
    where = str(path)
    if path.name in ("", ".", ".."):
        raise ConfigError(where, "not a file name")
    parent = path.parent
    if not parent.exists():
        raise ConfigError(where, f"directory {str(parent)!r} does not exist")
    if not parent.is_dir():
        raise ConfigError(where, f"{str(parent)!r} is not a directory")
    if path.is_dir() and not (store and is_zarr_store(path)):
        raise ConfigError(where, "is a directory" + (" that is not a Zarr store; refusing to replace it"
                                                    if store else ""))
    if path.exists() and not overwrite:
        raise ConfigError(where, f"exists; pass {option('overwrite')} to replace it")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ConfigError(where, f"directory {str(parent)!r} is not writable (permission denied)")
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{path.name}.probe-", dir=parent)
    except OSError as exc:
        raise ConfigError(where, _cannot_create(str(parent), exc)) from None
    os.close(fd)
    os.unlink(probe)
    return path


#: why a file cannot be created in a directory that exists, by errno
_CREATE_REASONS = {
    errno.EACCES: "is not writable (permission denied)",
    errno.EPERM: "is not writable (operation not permitted)",
    errno.EROFS: "is on a read-only file system",
    errno.ENOSPC: "is on a full disk (no space left on the device)",
    errno.EDQUOT: "is on a disk whose quota is exhausted",
    # a directory that exists but where new files do not: /proc, /sys
    errno.ENOENT: "exists, but its file system does not allow new files (as in /proc or /sys)",
}


def _cannot_create(parent: str, error: OSError) -> str:
    """What is wrong when no file can be created in the existing ``parent``."""
    reason = _CREATE_REASONS.get(error.errno)
    if reason is None:
        return f"cannot create a file in directory {parent!r}: {_one_line(error.strerror or error)}"
    return f"cannot create a file in directory {parent!r}: it {reason}"


def _chunksizes(shape: tuple[int, ...], itemsize: int) -> tuple[int, ...]:
    """C-order chunks of about CHUNK_BYTES: shrink leading dimensions first."""
    target = max(1, CHUNK_BYTES // max(1, itemsize))
    chunks = list(shape)
    for i in range(len(chunks)):
        if math.prod(chunks) <= target:
            break
        rest = math.prod(chunks[i + 1 :])
        chunks[i] = max(1, target // rest)
    return tuple(int(c) for c in chunks)


def _schema_fill(name: str) -> Any:
    for table in (schema.OUTPUTS, schema.TRAJECTORY_RECORD):
        if name in table:
            return table[name].fill_value
    return None


def _encoding(var: xr.Variable, name: str, original: dict, complevel: int) -> dict:
    """netCDF encoding of one variable (replaces whatever it carried)."""
    enc: dict[str, Any] = {}
    dtype = var.dtype
    kind = dtype.kind
    if kind not in "biufcMm":  # strings / objects: written as they are
        return enc
    if kind == "f":
        enc["_FillValue"] = np.nan
    elif kind in "iu":
        fill = original.get("_FillValue", var.attrs.get("_FillValue", _schema_fill(name)))
        enc["_FillValue"] = fill
    elif kind == "b":
        enc["_FillValue"] = None
    if var.ndim == 0 or var.size == 0:
        return enc
    if complevel > 0:
        enc["zlib"] = True
        enc["complevel"] = complevel
        enc["shuffle"] = True
    itemsize = 8 if kind in "Mm" else dtype.itemsize
    enc["chunksizes"] = _chunksizes(tuple(var.shape), itemsize)
    return enc


def _prepare(ds: xr.Dataset, complevel: int) -> tuple[xr.Dataset, dict]:
    originals = {name: dict(ds.variables[name].encoding) for name in ds.variables}
    out = ds.copy(deep=False).drop_encoding()
    out.attrs = schema.netcdf_attrs(ds.attrs)
    encoding = {}
    for name in out.variables:
        var = out.variables[name]
        attrs = dict(var.attrs)
        fill_attr = attrs.pop("_FillValue", None)
        var.attrs = schema.netcdf_attrs(attrs)
        if fill_attr is not None and var.dtype.kind in "iu":
            originals[name].setdefault("_FillValue", fill_attr)
        encoding[name] = _encoding(var, str(name), originals[name], complevel)
    return out, encoding


def check_compression_level(compression_level) -> int:
    if isinstance(compression_level, bool) or not isinstance(compression_level, (int, np.integer)) or not (
        0 <= compression_level <= 9
    ):
        raise ConfigError("compression_level", f"{compression_level!r} is not an integer 0..9")
    return int(compression_level)


def define_variables(
    nc,
    ds: xr.Dataset,
    *,
    deferred: tuple[str, ...] = (),
    chunksizes: Mapping[str, tuple[int, ...]] | None = None,
    compression_level: int = 4,
) -> None:
    """Add ``ds``'s dimensions, variables and attributes to the open
    ``netCDF4.Dataset`` ``nc`` with the encoding :func:`write_netcdf` gives
    them, and write their values except those of ``deferred`` variables
    (whose data in ``ds`` may be a zero-stride stand-in such as
    ``np.broadcast_to``; the caller writes them later, piece by piece).
    ``chunksizes`` replaces the chunk shape of the variables it names.
    Global attributes: :func:`set_attributes`."""
    prepared, encoding = _prepare(ds, check_compression_level(compression_level))
    for dim, size in prepared.sizes.items():
        if dim not in nc.dimensions:
            nc.createDimension(dim, size)
    coordinates = [name for name in prepared.coords if name not in prepared.dims]
    for name, var in prepared.variables.items():
        enc = encoding[name]
        chunks = (chunksizes or {}).get(name, enc.get("chunksizes"))
        target = nc.createVariable(
            name, var.dtype, var.dims, fill_value=enc.get("_FillValue"),
            compression="zlib" if enc.get("zlib") else None, complevel=enc.get("complevel", 4),
            shuffle=enc.get("shuffle", False), chunksizes=chunks)
        attrs = dict(var.attrs)
        # xarray's rule: a variable lists the non-index coordinates within its dimensions
        listed = [c for c in coordinates if c != name and set(prepared[c].dims) <= set(var.dims)]
        if name in prepared.data_vars and listed:
            attrs["coordinates"] = " ".join(listed)
        target.setncatts(attrs)
        if name not in deferred:
            target[...] = var.values


def set_attributes(nc, attrs: Mapping[str, Any]) -> None:
    """Replace the open file's global attributes with ``attrs`` (flattened to
    netCDF-legal names and values as :func:`write_netcdf` does)."""
    for name in list(nc.ncattrs()):
        nc.delncattr(name)
    nc.setncatts(schema.netcdf_attrs(attrs))


def fsync_file(path: str | os.PathLike) -> None:
    """Push a file's written data to the disk (through another descriptor:
    the netCDF library does not expose its own)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def replace_file(source: Path, path: Path, overwrite: bool) -> None:
    """Rename the finished ``source`` to ``path`` atomically, refusing to
    replace a ``path`` that appeared meanwhile unless ``overwrite``."""
    fsync_file(source)
    if not overwrite and path.exists():  # appeared while we were writing
        raise ConfigError(str(path), f"exists; pass {option('overwrite')} to replace it")
    os.replace(source, path)
    _fsync_dir(path.parent)


def check_dataset(ds) -> None:
    """Refuse what the writers cannot write, before anything is touched."""
    if not isinstance(ds, xr.Dataset):
        raise ConfigError("ds", f"expected an xarray.Dataset made by rampwork (rampwork.simulate, "
                          f"rampwork.open_dataset), got {type(ds).__name__}")


def write_netcdf(
    ds: xr.Dataset,
    path: str | os.PathLike,
    *,
    overwrite: bool = False,
    compression_level: int = 4,
) -> Path:
    """Write ``ds``, an ``xarray.Dataset`` such as :func:`rampwork.simulate`
    returns (anything else is refused with ConfigError), to ``path`` as
    compressed netCDF4, atomically.

    Floats get NaN as ``_FillValue``; integers get none unless their encoding,
    a ``_FillValue`` attribute or the schema specifies one. Attributes are
    flattened to netCDF-legal types (see :func:`schema.netcdf_attrs`).
    Refuses to replace an existing file unless ``overwrite``. Returns ``path``.
    """
    check_dataset(ds)
    compression_level = check_compression_level(compression_level)
    path = check_writable(path, overwrite)
    prepared, encoding = _prepare(ds, compression_level)
    tmp = temp_path(path)
    try:
        prepared.to_netcdf(tmp, mode="w", format=_FORMAT, engine=_ENGINE, encoding=encoding)
        replace_file(tmp, path, overwrite)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return path


def _fsync_dir(directory: Path) -> None:
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _is_zarr(path: Path) -> bool:
    return path.suffix.lower() == ZARR_SUFFIX or is_zarr_store(path)


def open_lazily(path: str | os.PathLike) -> xr.Dataset:
    """Open a result file or store without loading its values (close it, or
    use ``with``); no checks: see :func:`open_dataset`."""
    path = Path(path)
    engine = "zarr" if _is_zarr(path) else _ENGINE
    return xr.open_dataset(path, engine=engine, decode_times=False, decode_timedelta=False, chunks=None)


def open_dataset(path: str | os.PathLike) -> xr.Dataset:
    """Load a rampwork netCDF file, or Zarr store, into memory (the file is
    closed on return).

    ``status`` stays int8 with its flag attributes. Raises ConfigError for a
    missing file, a file netCDF (or Zarr) cannot read, or one that is not a
    rampwork dataset (no ``rampwork_scene`` global attribute).
    """
    path = Path(path)
    where = str(path)
    if not path.exists():
        raise ConfigError(where, "no such file")
    if _is_zarr(path):
        from .zarrstore import open_store

        ds = open_store(path)
    elif path.is_dir():
        raise ConfigError(where, "is a directory, not a netCDF file or a Zarr store")
    else:
        try:
            ds = xr.load_dataset(path, engine=_ENGINE, decode_times=False, decode_timedelta=False)
        except Exception as exc:  # noqa: BLE001 - any reader failure means "not readable"
            raise ConfigError(where, f"cannot be read as netCDF: {_one_line(exc)}") from None
    if "rampwork_scene" not in ds.attrs:
        raise ConfigError(where, "not a rampwork dataset (no rampwork_scene attribute)")
    return ds
