"""A ramp family: what a shape y = f(x) states about itself (:class:`RampFamily`).

A family has up to four named per-trajectory parameters (:class:`ParameterSpec`,
passed to the jitted core as ``p0..p3`` in their order), its jitted functions
and the checks the plan asks of it (domain, curvature sign, step reach).  The
built-in families are defined in :mod:`rampwork.ramp_families`; the
settings object :class:`~rampwork.ramps.Ramp` is in :mod:`rampwork.ramps`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

from . import validate
from .core import ramps as core
from .core.jit import specialise
from .errors import ConfigError


@dataclass(frozen=True)
class ParameterSpec:
    """One per-trajectory shape parameter of a family."""

    name: str
    units: str  # UDUNITS spelling
    long_name: str
    constraint: str  # "finite" | "positive"
    default: float | None  # None = required


@dataclass(frozen=True)
class RenamedParameter:
    """A parameter a family had under another name or meaning: scenes that
    still give ``old`` are read as ``new = convert(value, parameters)`` (the
    other parameters given, defaults filled in) with a
    :class:`~rampwork.errors.RenamedParameterWarning` that says what changed;
    a sweep over ``old`` is refused with the same explanation."""

    old: str
    new: str
    change: str  # what changed, in words
    convert: Callable[[float, Mapping[str, float]], float]
    formula: str  # new = ... in words, for the messages

    def explain(self, family: str) -> str:
        return (f"the {family} family's {self.old!r} {self.change}; it is now {self.new!r} "
                f"({self.new} = {self.formula})")


def _fmt(value) -> str:
    return repr(float(value))


def _at(values: np.ndarray, index: int) -> str:
    return f" (value {index} of {values.size})" if values.size > 1 else ""


def _real_array(where: str, values) -> np.ndarray:
    """A non-empty 1-D float array of finite numbers (strings, bools refused)."""
    array = np.asarray(values)
    if array.dtype.kind not in "iuf":
        raise ConfigError(where, f"expected finite numbers, got {values!r}")
    array = array.astype(np.float64)
    bad = ~np.isfinite(array)
    if bad.any():
        i = int(np.argmax(bad.ravel()))
        raise ConfigError(where, f"must be finite numbers, got {_fmt(array.ravel()[i])}{_at(array, i)}")
    return validate.real_array(where, array)  # shape checks


def _check_domain(domain) -> tuple[float, float]:
    """Two finite increasing numbers."""
    where = "ramp.domain"
    if isinstance(domain, (str, bytes)) or not hasattr(domain, "__len__") or len(domain) != 2:
        raise ConfigError(where, f"expected two numbers [x_min, x_max], got {domain!r}")
    lo = validate.real(where, domain[0])
    hi = validate.real(where, domain[1])
    if not lo < hi:
        raise ConfigError(where, f"x_min must be < x_max, got [{lo!r}, {hi!r}]")
    return lo, hi


class RampFamily:
    """A ramp shape: its parameters, jitted core functions and checks.

    ``height`` and ``slope_curvature`` are the jitted core functions with the
    signature ``(x, p0, p1, p2, p3, shared)``.  ``cacheable`` is False for user
    callables whose values have no stable name (kernels built on them need
    ``cache=False``; see userfunctions.py); ``key`` is a name unique to what
    the family computes, usable in compiled kernels' names.
    ``data_names`` are the non-swept inputs that build ``shared`` (spline).
    """

    #: f', f'' cost less to evaluate again than to carry in the kernel's lanes
    cheap_slope = False
    #: f'' is the same all along the ramp (no curvature integral needed)
    constant_curvature = False
    #: one of the families the general kernels switch between (kernels.py)
    general = True
    #: units and description of each of ``data_names`` (reference docs)
    data_docs: Mapping[str, tuple[str, str]] = {}

    def __init__(self, name: str, description: str, parameters: tuple[ParameterSpec, ...],
                 height, slope_curvature, *, is_straight: bool = False,
                 data_names: tuple[str, ...] = (), cacheable: bool = True, key: str | None = None,
                 renamed: tuple[RenamedParameter, ...] = ()):
        if len(parameters) > 4:
            raise ValueError("a ramp family has at most four parameters")
        self.name = name
        self.description = description
        self.parameters = tuple(parameters)
        self.height = height
        self.slope_curvature = slope_curvature
        self.is_straight = is_straight
        self.data_names = tuple(data_names)
        self.cacheable = cacheable
        self.key = key or name
        #: old parameter names still read (see RenamedParameter), by old name
        self.renamed = {r.old: r for r in renamed}
        self._evaluator = None

    def __repr__(self) -> str:
        return f"<RampFamily {self.name}: {', '.join(p.name for p in self.parameters) or 'no parameters'}>"

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    # -- validation ---------------------------------------------------------

    def unknown_parameter(self, where: str, name: str, allowed) -> ConfigError:
        """The error for a parameter ``name`` this family does not have (one
        it had under that name says what it is now)."""
        if name in self.renamed:
            return ConfigError(where, self.renamed[name].explain(self.name))
        return ConfigError(where, f"unknown parameter for ramp family {self.name!r}; "
                           f"allowed: {', '.join(allowed) or '(none)'}")

    def _arrays(self, values: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        names = self.parameter_names
        unknown = [k for k in values if k not in names]
        if unknown:
            raise self.unknown_parameter(f"ramp.{unknown[0]}", unknown[0], names)
        arrays = {}
        for spec in self.parameters:
            where = f"ramp.{spec.name}"
            if spec.name not in values:
                raise ConfigError(where, f"required by ramp family {self.name!r}")
            array = _real_array(where, values[spec.name])
            if spec.constraint == "positive" and not (array > 0).all():
                i = int(np.argmax(~(array > 0)))
                raise ConfigError(where, f"must be > 0, got {_fmt(array[i])}{_at(array, i)}")
            arrays[spec.name] = array
        sizes = {a.size for a in arrays.values()} - {1}
        if len(sizes) > 1:
            raise ConfigError("ramp", f"parameter arrays differ in length: "
                              f"{ {k: a.size for k, a in arrays.items()} }")
        return arrays

    def check_values(self, values: Mapping[str, np.ndarray], domain, shared=None) -> None:
        """Raise :class:`ConfigError` unless every set of values is a valid ramp
        on ``domain`` (names the parameter, the offending value and what is
        allowed).  ``shared``: the spline's data (checked against the domain)."""
        arrays = self._arrays(values)
        lo, hi = _check_domain(domain)
        self._check_family(arrays, lo, hi, shared)

    def _check_family(self, arrays, lo, hi, shared) -> None:
        pass

    def build_shared(self, data: Mapping, domain) -> tuple[float, ...] | np.ndarray:
        """``shared`` from the family's ``data_names`` values (validated;
        floats, or a float64 array that Ramp turns into them); ``domain`` as
        given (None where the family supplies its own)."""
        raise ConfigError("ramp", f"ramp family {self.name!r} takes no data")

    def data_domain(self, shared) -> tuple[float, float] | None:
        """The domain a family with data has when none is given (None: required)."""
        return None

    def data_dict(self, shared) -> dict:
        """``data_names`` -> plain values (lists) that rebuild ``shared``."""
        return {}

    def pack(self, values: Mapping[str, np.ndarray], n: int | None = None):
        """p0..p3 float64 arrays for the kernel (unused slots zeros of the same
        length).  ``n`` gives the length for a family without parameters."""
        arrays = [np.asarray(values[p.name], dtype=np.float64).ravel() for p in self.parameters]
        if n is None:
            if not arrays:
                raise ValueError(f"ramp family {self.name!r} has no parameters: pass n")
            n = max(a.size for a in arrays)
        packed = [np.ascontiguousarray(np.broadcast_to(a, (n,)), dtype=np.float64) for a in arrays]
        packed += [np.zeros(n) for _ in range(4 - len(packed))]
        return tuple(packed)

    def short_stages(self, values: Mapping[str, np.ndarray], domain, *, dt: float, v0: float,
                     g: float, mu: float, drag_linear: float, drag_quadratic: float) -> bool:
        """Whether fixed steps of size ``dt`` may evaluate f', f'' at their
        stage points and ends by the short form of the family's evaluation
        from the step's start (``core.ramps.SLOPE_CURVATURE_SHORT``): only
        where a bound on every step proves it accurate.  ``v0``, ``g``,
        ``mu`` and the drag coefficients: the largest magnitudes in the run."""
        return False

    def curvature_sign(self, values: Mapping[str, np.ndarray], domain, shared=None) -> int | None:
        """+1 if f'' >= 0 on the whole domain for all values, -1 if <= 0, 0 if
        f'' == 0 (straight), None if mixed or unknown."""
        return None

    # -- evaluation ---------------------------------------------------------

    def evaluator(self):
        """A jitted ``(x, p0, p1, p2, p3, shared, f, fp, fpp)`` loop over x."""
        if self._evaluator is None:
            self._evaluator = specialise(
                core.evaluate_template, f"ramp_evaluate_{self.key}",
                {"RAMP_HEIGHT": self.height, "RAMP_SLOPE_CURVATURE": self.slope_curvature},
                **({} if self.cacheable else {"cache": False}))
        return self._evaluator


def _sign_of(curvatures_nonneg: bool, curvatures_nonpos: bool) -> int | None:
    if curvatures_nonneg and curvatures_nonpos:
        return 0
    if curvatures_nonneg:
        return 1
    if curvatures_nonpos:
        return -1
    return None


def _p(name, units, long_name, constraint="finite", default=None):
    return ParameterSpec(name, units, long_name, constraint, default)
