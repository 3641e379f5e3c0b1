"""Designs: sweeps drawn from a recipe, never stored as lists of values.

A :class:`Design` is the recipe of a sampled sweep: its ``kind``, the number
of cases ``n``, a ``seed`` and one :class:`DesignAxis` per swept name (drawn
uniformly, or uniformly in the logarithm, between ``low`` and ``high``). The
recipe is all that is stored (in the scene text of a dataset, in a partial
file's digest, in a task shipped to a Dask worker); any range of cases is
drawn on its own with :meth:`Design.draw`, and **the values of case i depend
on the recipe and i only**: not on the chunk size, the threads, the Dask
workers, or a resume.

Kinds (:data:`DESIGN_KINDS`), each scrambled and seeded:

``random``
    independent uniform draws: case i, axis j is double ``i*d + j`` of the
    counter-based Philox stream of ``seed`` (``d`` axes), the same values as
    ``numpy.random.Generator(numpy.random.Philox(seed)).random((n, d))``;
    a chunk jumps to its start with ``Philox.advance``.
``sobol``
    scipy's scrambled Sobol' sequence, ``scipy.stats.qmc.Sobol(d,
    scramble=True, rng=seed)``, its first ``n`` points (a chunk uses
    ``fast_forward``). ``n`` must be a power of 2: Sobol' points have their
    balance properties only then (scipy warns; rampwork refuses).
``halton``
    scipy's scrambled Halton sequence, ``qmc.Halton(d, scramble=True,
    rng=seed)``, its first ``n`` points (a chunk sets the engine's
    ``num_generated`` to its start: a Halton point depends on its index only).
``lhs``
    a Latin hypercube: on every axis each of the ``n`` strata ``[k/n,
    (k+1)/n)`` holds exactly one case, at a uniform position within it. The
    strata are not numpy's shuffle (that needs the whole design in memory)
    but a keyed pseudo-random permutation of ``range(n)`` per axis, a
    6-round Feistel network with cycle walking, evaluated at each case's
    index; so the design differs from ``qmc.LatinHypercube``'s for the same
    seed, with the same defining property.

Memory and time per case are flat in ``n`` (a Sobol' chunk's
``fast_forward`` is a loop over the skipped points in scipy's C code:
about 2 ms per million). Validation checks the recipe, not the values: every
value lies in ``[low, high]``.
"""

from __future__ import annotations

import hashlib
import importlib.util
import inspect
import math
from dataclasses import dataclass

import numpy as np

from . import validate
from .errors import ConfigError

__all__ = ["DESIGN_KINDS", "LAWS", "Design", "DesignAxis"]

#: the kinds of design, and what each needs of n
DESIGN_KINDS = ("random", "sobol", "halton", "lhs")
#: how an axis is drawn between low and high
LAWS = ("uniform", "loguniform")
#: the largest seed (a TOML integer is a signed 64-bit one)
MAX_SEED = 2**63 - 1
#: Feistel rounds of the Latin hypercube's strata permutation
LHS_ROUNDS = 6
#: spawn keys of the Latin hypercube's streams under SeedSequence(seed)
_LHS_JITTER, _LHS_STRATA = 0, 1
_KIND_NAMES = {"random": "random", "sobol": "Sobol'", "halton": "Halton", "lhs": "Latin hypercube"}


@dataclass(frozen=True)
class DesignAxis:
    """One swept name of a design: drawn from ``law`` (``"uniform"`` or
    ``"loguniform"``, uniform in the logarithm; low > 0) on ``[low, high]``."""

    name: str
    low: float
    high: float
    law: str = "uniform"

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ConfigError("sweep", f"axis names must be non-empty strings, got {self.name!r}")
        where = f"sweep.{self.name}"
        validate.choice(f"{where} law", self.law, LAWS)
        low, high = validate.real(where, self.low), validate.real(where, self.high)
        if not low <= high:
            raise ConfigError(where, f"low must be <= high, got ({low!r}, {high!r})")
        if not math.isfinite(high - low):
            raise ConfigError(where, f"the range ({low!r}, {high!r}) is wider than the largest float")
        if self.law == "loguniform" and low <= 0:
            raise ConfigError(where, f"log-uniform needs low > 0, got {low!r}")
        object.__setattr__(self, "low", low)
        object.__setattr__(self, "high", high)

    def values(self, unit: np.ndarray) -> np.ndarray:
        """The axis's values at the points ``unit`` of [0, 1) (a new array)."""
        if self.law == "uniform":
            values = self.low + unit * (self.high - self.low)  # as qmc.scale
        else:
            a, b = math.log(self.low), math.log(self.high)
            values = np.exp(a + unit * (b - a))
        # rounding may not leave the range: validation relies on it
        return np.clip(values, self.low, self.high, out=values)

    def describe(self) -> str:
        law = "log-uniform" if self.law == "loguniform" else "uniform"
        return f"{self.name} {law} [{self.low!r}, {self.high!r}]"


@dataclass(frozen=True)
class Design:
    """The recipe of a sampled sweep (see the module docstring): ``n`` cases
    of ``kind`` drawn with ``seed`` over ``axes`` (:class:`DesignAxis`)."""

    kind: str
    n: int
    seed: int
    axes: tuple[DesignAxis, ...]

    def __post_init__(self):
        validate.choice("sweep.kind", self.kind, DESIGN_KINDS)
        n = validate.integer("sweep.n", self.n, 1)
        if n > validate.MAX_AXIS_POINTS:
            raise ConfigError("sweep.n", f"must be <= {validate.MAX_AXIS_POINTS:.0e} (the most cases one "
                              f"design may draw; split the study into several runs), got {n}")
        if self.kind == "sobol" and n & (n - 1):
            below = 1 << (n.bit_length() - 1)
            raise ConfigError("sweep.n", f"a Sobol' design needs n a power of 2 (its balance "
                              f"properties hold only then), got {n:,}; use {below:,} or {2 * below:,}, "
                              "or a halton, lhs or random design")
        seed = validate.integer("sweep.seed", self.seed, 0, MAX_SEED)
        axes = tuple(self.axes) if isinstance(self.axes, (tuple, list)) else None
        if not axes:
            raise ConfigError("sweep", f"a {self.kind} design needs at least one axis, got {self.axes!r}")
        seen = set()
        for axis in axes:
            if not isinstance(axis, DesignAxis):
                raise ConfigError("sweep", f"expected rampwork.designs.DesignAxis items, got {axis!r}")
            if axis.name in seen:
                raise ConfigError(f"sweep.{axis.name}", "given twice")
            seen.add(axis.name)
        if self.kind in ("sobol", "halton"):
            _require_scipy(self.kind)
        object.__setattr__(self, "n", n)
        object.__setattr__(self, "seed", seed)
        object.__setattr__(self, "axes", axes)

    @classmethod
    def from_ranges(cls, kind: str, n: int, seed: int = 0, log=(), **ranges) -> "Design":
        """``n`` cases of ``kind`` over ``ranges`` (name -> (low, high)); names in
        ``log`` are drawn uniformly in their logarithm (low > 0)."""
        if isinstance(log, str) or not isinstance(log, (tuple, list, set, frozenset)):
            raise ConfigError("sweep.log", f"expected a list of axis names, got {log!r}")
        unknown = set(log) - set(ranges)
        if unknown:
            raise ConfigError("sweep.log", f"names not among the ranges: {sorted(map(str, unknown))}")
        axes = []
        for name, bounds in ranges.items():
            if not isinstance(bounds, (tuple, list)) or len(bounds) != 2:
                raise ConfigError(f"sweep.{name}", f"expected (low, high), got {bounds!r}")
            axes.append(DesignAxis(name, bounds[0], bounds[1], "loguniform" if name in log else "uniform"))
        return cls(kind, n, seed, tuple(axes))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(axis.name for axis in self.axes)

    def axis(self, name: str) -> DesignAxis:
        return next(axis for axis in self.axes if axis.name == name)

    def fingerprint(self) -> str:
        """A digest of a few of the design's values (its first cases and its
        last): another numpy or scipy that would draw other values from the
        same recipe gives another fingerprint (a partial file is resumed only
        with the same, see rampwork.streaming)."""
        head, tail = self.unit(0, min(self.n, 8)), self.unit(self.n - 1, self.n)
        return hashlib.sha256(head.tobytes() + tail.tobytes()).hexdigest()

    def describe(self) -> str:
        """One line: kind, n, seed and each axis's law and range."""
        return (f"{_KIND_NAMES[self.kind]} design of {self.n:,} cases, seed {self.seed}: "
                + ", ".join(axis.describe() for axis in self.axes))

    # -- drawing -------------------------------------------------------------
    def unit(self, start: int, stop: int) -> np.ndarray:
        """The points of cases ``start .. stop-1`` in the unit cube [0, 1)^d, one
        row per case (a ``stop - start`` by ``d`` array)."""
        if not 0 <= start <= stop <= self.n:
            raise ValueError(f"cases {start}..{stop} outside the design's 0..{self.n}")
        d = len(self.axes)
        if start == stop:
            return np.empty((0, d))
        if self.kind == "random":
            return _philox_doubles(np.random.SeedSequence(self.seed), start * d, (stop - start) * d
                                   ).reshape(stop - start, d)
        if self.kind == "lhs":
            return _latin_hypercube(self.seed, self.n, d, start, stop)
        return _scipy_points(self.kind, self.seed, d, start, stop)

    def draw(self, start: int = 0, stop: int | None = None) -> dict[str, np.ndarray]:
        """Each axis's values for cases ``start .. stop-1`` (default: all)."""
        stop = self.n if stop is None else stop
        unit = self.unit(start, stop)
        return {axis.name: axis.values(np.ascontiguousarray(unit[:, j])) for j, axis in enumerate(self.axes)}


# ------------------------------------------------------------------------------
# the generators
# ------------------------------------------------------------------------------
def _philox_doubles(seed: np.random.SeedSequence, first: int, count: int) -> np.ndarray:
    """Doubles ``first .. first+count-1`` of the Philox stream of ``seed``, as
    ``Generator(Philox(seed)).random()`` makes them (53 bits each)."""
    bits = np.random.Philox(seed)
    bits.advance(first // 4)  # one Philox block is four 64-bit outputs
    skip = first % 4
    raw = bits.random_raw(skip + count)[skip:]
    return (raw >> np.uint64(11)) * (1.0 / 9007199254740992.0)


def _require_scipy(kind: str) -> None:
    # found, not imported: scipy.stats costs half a second, and a check or a
    # scene file read draws nothing
    if importlib.util.find_spec("scipy") is None:
        raise ConfigError("sweep.kind", f"a {kind} design needs scipy (scipy.stats.qmc): "
                          "pip install scipy")


def scipy_engine(kind: str, d: int, seed: int):
    """scipy's scrambled engine of a ``sobol`` or ``halton`` design, seeded as
    rampwork seeds it (``rng=seed``; ``seed=seed`` before scipy 1.15)."""
    from scipy.stats import qmc

    engine = qmc.Sobol if kind == "sobol" else qmc.Halton
    keyword = "rng" if "rng" in inspect.signature(engine.__init__).parameters else "seed"
    return engine(d, scramble=True, **{keyword: seed})


def _scipy_points(kind: str, seed: int, d: int, start: int, stop: int) -> np.ndarray:
    engine = scipy_engine(kind, d, seed)
    if start > 0:
        if kind == "halton":
            # a Halton point is computed from its index (van der Corput digits
            # from num_generated on); QMCEngine.fast_forward would draw and
            # drop every point before it, 7 us a point
            engine.num_generated = start
        else:
            engine.fast_forward(start)  # Sobol': a loop over gray-code steps in C
        return engine.random(stop - start)
    # the first point apart: scipy warns of a draw that is not a power of 2
    # only when it starts the sequence, and a chunk's size need not be one
    first = engine.random(1)
    return first if stop == 1 else np.concatenate([first, engine.random(stop - 1)])


_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


def _mix(x: np.ndarray) -> np.ndarray:
    """SplitMix64's finaliser: every output bit depends on every input bit."""
    x = (x ^ (x >> np.uint64(30))) * _MIX1
    x = (x ^ (x >> np.uint64(27))) * _MIX2
    return x ^ (x >> np.uint64(31))


def _feistel(x: np.ndarray, keys: np.ndarray, half: int) -> np.ndarray:
    """A balanced Feistel network on ``2 * half``-bit integers: a bijection."""
    shift, mask = np.uint64(half), np.uint64((1 << half) - 1)
    left, right = x >> shift, x & mask
    for key in keys:
        left, right = right, left ^ (_mix(right ^ key) & mask)
    return (left << shift) | right


def strata_permutation(index: np.ndarray, n: int, keys: np.ndarray) -> np.ndarray:
    """A keyed pseudo-random permutation of ``range(n)`` evaluated at ``index``:
    a Feistel network on the smallest even number of bits that holds ``n``,
    applied again to any value ``>= n`` until it falls inside (cycle walking;
    fewer than four times on average, since the domain is below ``4 n``)."""
    bits = max(2, (n - 1).bit_length())
    half = (bits + 1) // 2
    out = _feistel(np.asarray(index, dtype=np.uint64), keys, half)
    outside = np.flatnonzero(out >= np.uint64(n))
    while outside.size:
        out[outside] = _feistel(out[outside], keys, half)
        outside = outside[out[outside] >= np.uint64(n)]
    return out


def _latin_hypercube(seed: int, n: int, d: int, start: int, stop: int) -> np.ndarray:
    keys = np.random.SeedSequence(seed, spawn_key=(_LHS_STRATA,)).generate_state(
        d * LHS_ROUNDS, dtype=np.uint64).reshape(d, LHS_ROUNDS)
    jitter = _philox_doubles(np.random.SeedSequence(seed, spawn_key=(_LHS_JITTER,)),
                             start * d, (stop - start) * d).reshape(stop - start, d)
    index = np.arange(start, stop, dtype=np.uint64)
    for j in range(d):
        jitter[:, j] += strata_permutation(index, n, keys[j])
    jitter /= n
    return np.minimum(jitter, np.nextafter(1.0, 0.0), out=jitter)  # (n - 1 + v) / n may round to 1
