"""Zarr stores: the second output format, for results a cluster writes in parallel.

A rampwork Zarr store (format 3, a directory ``NAME.zarr``) holds the same
variables, coordinates, attributes and CF metadata as the netCDF file:
:func:`write_zarr` writes a dataset in memory, :class:`ZarrChunkStore` a
sweep chunk by chunk (``rampwork.run_to_file(..., "out.zarr")``,
``rampwork run scene.toml -o out.zarr``). Both take their encodings from
:mod:`rampwork.io` (one home for fill values and chunking): floats have NaN
as ``_FillValue``, integers none (Zarr's own fill value, 0, reads as
``status`` NOT_RUN), the compression level 0..9 is Blosc-zstd's with byte
shuffle (0: none). ``xarray.open_zarr`` reads a store, and so do
:func:`rampwork.open_dataset` and ``rampwork info``; its metadata are
consolidated.

Streamed: the client creates the whole store first, ``.NAME.partial``
beside the target, with every array's metadata and one Zarr chunk per chunk
of the run (so that two writers never share a Zarr chunk). Each chunk is then
written where it is computed, by the sweep's writer thread or by the Dask
worker that ran it, straight into its arrays' chunk objects (each written to
a temporary object and renamed, by zarr), which are then synced to disk;
only then is the chunk's own object in the done record
``rampwork_chunks_done`` written. A resume runs every chunk not marked done.
At the end the client adds the recorded trajectories and the final
attributes, drops the done record, consolidates the metadata and renames the
store to the target (a store it replaces is removed after the rename).
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from . import io, schema
from .chunkstore import DIGEST_ATTR, LAYOUT_ATTR, RUN_TIME_ATTR, PartialRun, resume_error
from .errors import ConfigError, option

__all__ = ["write_zarr", "open_store", "ZarrChunkStore", "ZarrChunkWriter", "DONE_ARRAY"]

#: the partial store's record of the chunks done, one object per chunk: the
#: chunk's trajectory steps (so the client never reads the results back), -1
#: where it is not done
DONE_ARRAY = "rampwork_chunks_done"
#: zarr's temporary objects (``KEY.<uuid hex>.partial``) that a killed writer leaves
_TEMPORARY = re.compile(r"\.[0-9a-f]{32}\.partial$")
#: tests only: ``INDEX:SENTINEL`` makes the process that writes chunk INDEX kill
#: itself (SIGKILL) after the chunk's first variable, once: the first writer
#: to create the file SENTINEL
KILL_ENV = "RAMPWORK_TEST_KILL_IN_CHUNK"


def _require(where: str, dask: bool = False):
    """The zarr module (and dask.array's ``empty`` where asked), or a one-line ConfigError."""
    try:
        import zarr

        if int(zarr.__version__.split(".")[0]) < 3:
            raise ImportError(f"zarr {zarr.__version__} is installed")
        if dask:
            import dask.array  # noqa: F401 - the template of a streamed store
    except ImportError as error:
        raise ConfigError(where, f"writing a Zarr store needs zarr>=3{' and dask' if dask else ''} "
                          f"({error}): pip install 'rampwork[zarr]'") from None
    return zarr


def _encoding(ds: xr.Dataset, compression_level: int,
              chunks: dict[str, tuple[int, ...]] | None = None) -> tuple[xr.Dataset, dict]:
    """``ds`` prepared as :func:`rampwork.write_netcdf` prepares it, and its
    Zarr encodings: the same fill values and chunks (``chunks`` replaces
    those of the variables it names), Blosc-zstd for zlib."""
    from zarr.codecs import BloscCodec

    prepared, netcdf = io._prepare(ds, compression_level)
    encoding = {}
    for name, enc in netcdf.items():
        out = {key: enc[key] for key in ("_FillValue",) if key in enc}
        if "chunksizes" in enc:
            out["chunks"] = tuple((chunks or {}).get(name, enc["chunksizes"]))
            out["compressors"] = ([BloscCodec(cname="zstd", clevel=enc["complevel"], typesize=
                                              prepared[name].dtype.itemsize,
                                              shuffle="shuffle" if enc.get("shuffle") else "noshuffle")]
                                  if enc.get("zlib") else None)
        encoding[name] = out
    return prepared, encoding


def _json(attrs: dict[str, Any]) -> dict[str, Any]:
    """Attributes as JSON values (as xarray writes them to Zarr)."""
    return {key: value.tolist() if isinstance(value, np.ndarray)
            else value.item() if isinstance(value, np.generic) else value
            for key, value in attrs.items()}


def _consolidate(root: Path) -> None:
    import zarr

    with warnings.catch_warnings():  # consolidated metadata are not in the v3 spec yet
        warnings.simplefilter("ignore", UserWarning)
        zarr.consolidate_metadata(str(root))


_SYNC_POOL = None


def _fsync(paths, directory: bool = False) -> None:
    """fsync ``paths`` side by side: the file system commits them together
    (a chunk's 19 objects: about 25 ms, against 150 ms one after the other)."""
    global _SYNC_POOL
    if _SYNC_POOL is None:
        from concurrent.futures import ThreadPoolExecutor

        _SYNC_POOL = ThreadPoolExecutor(8, thread_name_prefix="rampwork-fsync")
    sync = (lambda path: io._fsync_dir(Path(path))) if directory else _fsync_one
    for _ in _SYNC_POOL.map(sync, list(paths)):
        pass


def _fsync_one(path) -> None:
    try:
        io.fsync_file(path)
    except FileNotFoundError:  # zarr omits a chunk of fill values
        pass


def _finish_tree(root: Path) -> None:
    """Remove a killed writer's temporary objects; push every file and
    directory of the store to the disk."""
    directories, kept = [], []
    for folder, _, files in os.walk(root):
        directories.append(folder)
        for name in files:
            if _TEMPORARY.search(name):
                os.unlink(os.path.join(folder, name))
            else:
                kept.append(os.path.join(folder, name))
    _fsync(kept)
    _fsync(directories, directory=True)


def remove_tree(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif os.path.lexists(path):
        path.unlink()


def replace_store(source: Path, path: Path, overwrite: bool) -> None:
    """Rename the finished store ``source`` to ``path``; a store (or file)
    already there is moved aside first and removed after the rename."""
    if os.path.lexists(path):
        if not overwrite:  # appeared while we were writing
            raise ConfigError(str(path), f"exists; pass {option('overwrite')} to replace it")
        if path.is_dir() and not io.is_zarr_store(path):
            raise ConfigError(str(path), "is a directory that is not a Zarr store; refusing to replace it")
        old = path.with_name(f".{path.name}.old-{os.getpid()}")
        remove_tree(old)
        os.replace(path, old)
        os.replace(source, path)
        io._fsync_dir(path.parent)
        remove_tree(old)
    else:
        os.replace(source, path)
    io._fsync_dir(path.parent)


def write_zarr(ds: xr.Dataset, path: str | os.PathLike, *, overwrite: bool = False,
               compression_level: int = 4) -> Path:
    """Write ``ds`` to the Zarr store ``path`` (a directory, Zarr format 3),
    atomically: as :func:`rampwork.write_netcdf` writes a netCDF file (the
    same variables, attributes, fill values and chunks; ``compression_level``
    0..9 is Blosc-zstd's, 0: none). Refuses to replace an existing store
    unless ``overwrite``, and never replaces a directory that is not a Zarr
    store. Returns ``path``."""
    io.check_dataset(ds)
    compression_level = io.check_compression_level(compression_level)
    path = io.check_writable(path, overwrite, store=True)
    _require(str(path))
    prepared, encoding = _encoding(ds, compression_level)
    tmp = io.temp_path(path)
    try:
        remove_tree(tmp)
        prepared.to_zarr(tmp, mode="w-", encoding=encoding, consolidated=False, zarr_format=3)
        _consolidate(tmp)
        _finish_tree(tmp)
        replace_store(tmp, path, overwrite)
    except BaseException:
        remove_tree(tmp)
        raise
    return path


def open_store(path: Path) -> xr.Dataset:
    """Load a Zarr store into memory (see :func:`rampwork.open_dataset`)."""
    where = str(path)
    if not path.is_dir():
        raise ConfigError(where, "is not a directory, so not a Zarr store")
    try:
        _require(where)
        with xr.open_zarr(path, chunks=None, decode_times=False, decode_timedelta=False) as ds:
            return ds.load()
    except ConfigError:
        raise
    except Exception as exc:  # noqa: BLE001 - any reader failure means "not readable"
        raise ConfigError(where, f"cannot be read as a Zarr store: {' '.join(str(exc).split())}") from None


# ------------------------------------------------------------------------------
# a sweep written chunk by chunk
# ------------------------------------------------------------------------------
class ZarrChunkWriter:
    """Writes chunks into the partial store at ``root``, in whatever process
    holds it (pickled to Dask workers: a path)."""

    def __init__(self, root: str):
        self.root = os.path.abspath(root)  # the same on every worker of a shared file system
        self._arrays = {}

    def __getstate__(self):
        return {"root": self.root, "_arrays": {}}

    def _array(self, name: str):
        if name not in self._arrays:
            zarr = _require(self.root)
            if not os.path.isdir(os.path.join(self.root, name)):
                raise ConfigError(self.root, f"has no array {name!r} here ({socket.gethostname()}): a "
                                  "store that Dask workers write must be on a file system they all see")
            # every chunk written, fill values or not: an object always holds its last write
            self._arrays[name] = (zarr.open_array(os.path.join(self.root, name), mode="r+")
                                  .with_config({"write_empty_chunks": True}))
        return self._arrays[name]

    def write(self, index: int, where: tuple, shape: tuple, results: dict[str, np.ndarray]) -> None:
        """Chunk ``index``'s values (no CF encoding to apply: the schema's
        variables are stored as they are), then its done mark."""
        files = []
        for k, (name, values) in enumerate(results.items()):
            array = self._array(name)
            array[where] = values.reshape(shape)
            files.append(self._chunk_file(name, array, where))
            if k == 0 and os.environ.get(KILL_ENV):
                _kill_for_test(index)
        _fsync(files)  # the data reach the disk before the mark that says they are there
        _fsync({os.path.dirname(file) for file in files}, directory=True)
        self._array(DONE_ARRAY)[index] = int(np.sum(results["steps"], dtype=np.int64))

    def _chunk_file(self, name: str, array, where: tuple) -> str:
        coords = []
        for k, size in enumerate(array.chunks):
            at = where[k] if k < len(where) else 0
            coords.append((at if isinstance(at, (int, np.integer)) else at.start or 0) // size)
        return os.path.join(self.root, name, array.metadata.encode_chunk_key(tuple(coords)))


def _kill_for_test(index: int) -> None:
    target, _, sentinel = os.environ[KILL_ENV].partition(":")
    if int(target) != index:
        return
    try:
        os.close(os.open(sentinel, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except FileExistsError:
        return
    os.kill(os.getpid(), signal.SIGKILL)


class ZarrChunkStore:
    """The partial store ``partial`` of the Zarr store ``path`` (see the
    module docstring and :class:`rampwork.chunkstore.ChunkStore`)."""

    writes_on_workers = True

    def __init__(self, path: Path, partial: Path, compression_level: int):
        self.path, self.partial, self.compression_level = path, partial, compression_level
        self.zarr = _require(str(path), dask=True)
        if partial.is_dir() and not io.is_zarr_store(partial):
            raise ConfigError(str(partial), "is a directory but not a Zarr store: remove it")
        self.group = None
        self.writer = None

    def _open_group(self):
        self.group = self.zarr.open_group(str(self.partial), mode="r+", use_consolidated=False)

    def read_partial(self) -> PartialRun:
        try:
            self._open_group()
            attrs = self.group.attrs.asdict()
            axis, rows = (int(v) for v in attrs[LAYOUT_ATTR])
            done = np.asarray(self.group[DONE_ARRAY][:]) >= 0
            return PartialRun(str(attrs[DIGEST_ATTR]), axis, rows, done, float(attrs[RUN_TIME_ATTR]))
        except Exception as error:  # noqa: BLE001 - zarr's errors too: not resumable
            raise resume_error(self.partial, error) from None

    def create(self, skeleton, deferred, chunksizes, attrs, done) -> None:
        import dask.array

        template = skeleton.copy()
        for name in deferred:  # lazy stand-ins: xarray writes their metadata alone
            var = skeleton[name]
            template[name] = (var.dims, dask.array.empty(var.shape, dtype=var.dtype,
                                                         chunks=chunksizes.get(name, var.shape)), var.attrs)
        template.attrs = dict(attrs)
        prepared, encoding = _encoding(template, self.compression_level, chunksizes)
        for name in deferred:  # the writers store values as they are: no CF encoding may apply
            fill = encoding[name].get("_FillValue")
            if set(encoding[name]) - {"_FillValue", "chunks", "compressors"} or not (
                    fill is None or (prepared[name].dtype.kind == "f" and np.isnan(fill))):
                raise RuntimeError(f"{name}: encoding {encoding[name]} would change the stored values")
        remove_tree(self.partial)  # a stale one: overwrite was asked for
        try:
            prepared.to_zarr(self.partial, mode="w-", compute=False, encoding=encoding,
                             consolidated=False, zarr_format=3)
            self._open_group()
            self.group.create_array(DONE_ARRAY, shape=(len(done),), chunks=(1,), dtype="int64",
                                    fill_value=-1, compressors=None, dimension_names=["rampwork_chunk"])
            _finish_tree(self.partial)
        except BaseException:
            remove_tree(self.partial)
            raise
        self.writer = ZarrChunkWriter(str(self.partial))

    def open(self) -> None:
        self._open_group()
        self.writer = ZarrChunkWriter(str(self.partial))

    def write(self, index, where, shape, results) -> None:
        self.writer.write(index, where, shape, results)

    def worker_writer(self) -> ZarrChunkWriter:
        return self.writer

    def mark_done(self, index, done, run_seconds) -> None:
        # the writer marked the chunk itself; the client keeps the run time
        self.group.attrs.update({RUN_TIME_ATTR: float(run_seconds)})

    def steps(self, wheres) -> int:
        return int(np.asarray(self.group[DONE_ARRAY][:]).clip(0).sum())  # the writers' own sums

    def finalise(self, attrs: dict[str, Any], traces) -> None:
        missing = int((np.asarray(self.group[DONE_ARRAY][:]) < 0).sum())
        if missing:  # reported done by workers that did not write here
            raise ConfigError(str(self.partial), f"{missing} chunks reported done are not marked in it: "
                              "a store that Dask workers write must be on a file system they all see")
        if traces is not None:
            prepared, encoding = _encoding(traces, self.compression_level)
            prepared.to_zarr(self.partial, mode="a", encoding=encoding, consolidated=False, zarr_format=3)
        shutil.rmtree(self.partial / DONE_ARRAY)
        self.group.attrs.put(_json(schema.netcdf_attrs(attrs)))
        _consolidate(self.partial)
        _finish_tree(self.partial)

    def close(self) -> None:
        self.group = None

    def commit(self, overwrite: bool) -> None:
        replace_store(self.partial, self.path, overwrite)
