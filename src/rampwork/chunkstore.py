"""Where a streamed sweep (:mod:`rampwork.streaming`) writes its chunks: the
output formats behind one small interface, chosen by the output path's suffix.

A chunk store owns the unfinished run ``.NAME.partial`` beside the output:
it creates it with every variable, coordinate and attribute (the values of
the per-trajectory variables come chunk by chunk), writes a chunk's values,
records which chunks are done (only after their data are on disk), reads
that record back to resume, finalises the attributes and renames the
finished run to the output. The sweep (chunking, threads, Dask, the
attributes' values) is :mod:`rampwork.streaming`'s; the stores only write.

- :class:`NetcdfChunkStore` (``.nc``, the default format): one netCDF4 file,
  written by the process that runs the sweep; the done chunks are a bit set
  in a global attribute.
- :class:`rampwork.zarrstore.ZarrChunkStore` (``.zarr``): a Zarr store that
  each chunk is written into where it is computed, Dask workers included;
  the done chunks are a record of their own, one object per chunk.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import xarray as xr

from . import io
from .errors import ConfigError, option

__all__ = ["ChunkStore", "PartialRun", "NetcdfChunkStore", "open_chunk_store", "DIGEST_ATTR",
           "LAYOUT_ATTR", "DONE_ATTR", "RUN_TIME_ATTR"]

#: global attributes of a partial run (all replaced when it is finalised)
DIGEST_ATTR = "rampwork_partial_digest"
LAYOUT_ATTR = "rampwork_partial_chunk_layout"
DONE_ATTR = "rampwork_chunks_done"
RUN_TIME_ATTR = "rampwork_partial_run_time_s"


@dataclass(frozen=True)
class PartialRun:
    """What an unfinished run recorded: the digest of what it computes, its
    chunk layout (``axis``, ``rows``), which chunks are done (``done``, at
    least as long as the layout has chunks) and its run time so far."""

    digest: str
    axis: int
    rows: int
    done: np.ndarray
    run_seconds: float


class ChunkStore(Protocol):
    """What :class:`rampwork.streaming.SweepToFile` asks of an output format.

    ``where`` and ``shape`` place a chunk in the output arrays (see
    ``streaming.ChunkLayout.piece``); ``results`` are its flat values by
    variable name."""

    #: True where a Dask worker writes the chunks it computes (see worker_writer)
    writes_on_workers: bool

    def read_partial(self) -> PartialRun:
        """The unfinished run's record; a one-line ConfigError if unreadable."""

    def create(self, skeleton: xr.Dataset, deferred: tuple[str, ...],
               chunksizes: dict[str, tuple[int, ...]], attrs: dict, done: np.ndarray) -> None:
        """Create the partial run: ``skeleton``'s variables (those in
        ``deferred`` without values, chunked as ``chunksizes`` says), the
        global ``attrs`` and the record of the ``done`` chunks."""

    def open(self) -> None:
        """Open the existing partial run to go on with it."""

    def write(self, index: int, where: tuple, shape: tuple, results: dict[str, np.ndarray]) -> None:
        """Write chunk ``index`` (in this process)."""

    def mark_done(self, index: int, done: np.ndarray, run_seconds: float) -> None:
        """Record, after its data are on disk, that chunk ``index`` is done
        (``done``: every chunk's state), and the run time so far."""

    def steps(self, wheres) -> int:
        """The sum of ``steps`` over the written chunks at ``wheres`` (a
        store that keeps each chunk's count, as the Zarr store does, sums those)."""

    def finalise(self, attrs: dict, traces: xr.Dataset | None) -> None:
        """Replace the bookkeeping with the run's own attributes, add the
        recorded trajectories, and close."""

    def close(self) -> None:
        """Close whatever is open (safe to call twice)."""

    def commit(self, overwrite: bool) -> None:
        """Rename the finished partial run to the output path."""


def open_chunk_store(path: Path, partial: Path, compression_level: int) -> ChunkStore:
    """The store for ``path``'s format (``io.output_format``); raises a
    ConfigError if the format's packages are missing."""
    if io.output_format(path) == "zarr":
        from .zarrstore import ZarrChunkStore

        return ZarrChunkStore(path, partial, compression_level)
    return NetcdfChunkStore(path, partial, compression_level)


def fit_done(bits: np.ndarray, count: int) -> np.ndarray:
    """A done record as ``count`` booleans (missing ones: not done)."""
    done = np.zeros(count, dtype=bool)
    bits = np.asarray(bits, dtype=bool)[:count]
    done[:bits.size] = bits
    return done


def resume_error(partial: Path, error: BaseException) -> ConfigError:
    return ConfigError(str(partial), f"cannot be resumed ({' '.join(str(error).split())}); remove it "
                       f"or pass {option('overwrite')} to start over")


# ------------------------------------------------------------------------------
# netCDF
# ------------------------------------------------------------------------------
def _open(path: Path, mode: str):
    import netCDF4

    return netCDF4.Dataset(path, mode, format="NETCDF4")


class NetcdfChunkStore:
    """One netCDF4 file ``partial``, written by this process: a chunk is
    exactly one HDF5 chunk per variable (one compressed block, never a
    read-modify-write); after each chunk the file is synced to disk and the
    chunk's bit set in the global attribute ``rampwork_chunks_done``."""

    writes_on_workers = False

    def __init__(self, path: Path, partial: Path, compression_level: int):
        self.path, self.partial, self.compression_level = path, partial, compression_level
        self.nc = None

    def read_partial(self) -> PartialRun:
        try:
            with _open(self.partial, "r") as nc:
                digest = nc.getncattr(DIGEST_ATTR)
                axis, rows = (int(v) for v in np.atleast_1d(nc.getncattr(LAYOUT_ATTR)))
                bits = np.atleast_1d(nc.getncattr(DONE_ATTR)).astype(np.uint8)
                run_seconds = float(nc.getncattr(RUN_TIME_ATTR))
        except (OSError, AttributeError, KeyError, ValueError, RuntimeError) as error:
            raise resume_error(self.partial, error) from None
        return PartialRun(str(digest), axis, rows, np.unpackbits(bits).astype(bool), run_seconds)

    def create(self, skeleton, deferred, chunksizes, attrs, done) -> None:
        self.partial.unlink(missing_ok=True)  # a stale one: overwrite was asked for
        nc = self.nc = _open(self.partial, "w")
        try:
            io.define_variables(nc, skeleton, deferred=deferred, chunksizes=chunksizes,
                                compression_level=self.compression_level)
            io.set_attributes(nc, {**attrs, DONE_ATTR: np.packbits(done)})
            nc.sync()
            io.fsync_file(self.partial)
        except BaseException:
            self.close()
            self.partial.unlink(missing_ok=True)
            raise
        self._no_cache(deferred)

    def open(self) -> None:
        self.nc = _open(self.partial, "a")
        self._no_cache([name for name, var in self.nc.variables.items() if var.chunking() != "contiguous"])

    def _no_cache(self, names) -> None:
        for name in names:
            # each chunk is written whole, once: a cache would only hold on to
            # written chunks (netCDF's default allows 16 MiB per variable)
            self.nc[name].set_var_chunk_cache(size=0)

    def write(self, index, where, shape, results) -> None:
        for name, values in results.items():
            self.nc[name][where] = values.reshape(shape)

    def mark_done(self, index, done, run_seconds) -> None:
        # the data reach the disk before the bit that says they are there
        self.nc.sync()
        self.nc.setncattr(DONE_ATTR, np.packbits(done))
        self.nc.setncattr(RUN_TIME_ATTR, run_seconds)
        self.nc.sync()
        io.fsync_file(self.partial)

    def steps(self, wheres) -> int:
        return sum(int(np.asarray(self.nc["steps"][where], dtype=np.int64).sum()) for where in wheres)

    def finalise(self, attrs: dict[str, Any], traces) -> None:
        if traces is not None:
            io.define_variables(self.nc, traces, compression_level=self.compression_level)
        io.set_attributes(self.nc, attrs)
        self.close()

    def close(self) -> None:
        if self.nc is not None and self.nc.isopen():
            self.nc.close()

    def commit(self, overwrite: bool) -> None:
        io.replace_file(self.partial, self.path, overwrite)

