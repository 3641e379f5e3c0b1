"""Ramp families and the validated :class:`Ramp` settings object.

A *family* (:class:`RampFamily`, registered in :data:`FAMILIES`) is a shape
y = f(x) with up to four named per-trajectory parameters (passed to the jitted
core as ``p0..p3`` in the order of ``RampFamily.parameters``) and optionally
data shared by all trajectories (the spline's knots, in ``shared``).  A
:class:`Ramp` is one family with all its parameters filled in and a domain.
The family class is in :mod:`rampwork.ramp_family`, the built-in families in
:mod:`rampwork.ramp_families` (both re-exported here).

    >>> ramp = Ramp.create("circular_bowl", radius=2.0, domain=(-1.5, 1.5))
    >>> f, fp, fpp = ramp.evaluate([0.0, 1.0])

User functions: :meth:`Ramp.from_functions` (family ``"callable"``).
"""

from __future__ import annotations

import itertools
import re
from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np

from . import validate
from .core import ramps as core
from .core.jit import jit, specialise
from .errors import ConfigError, RenamedParameterWarning, warn
# the families (re-exported: their public names were this module's)
from .ramp_families import FAMILIES, MAX_MODES, _Callable, spline_arrays, spline_shared  # noqa: F401
from .ramp_family import ParameterSpec, RampFamily, RenamedParameter, _check_domain, _fmt  # noqa: F401
from .userfunctions import content_digest

__all__ = [
    "FAMILIES",
    "ParameterSpec",
    "Ramp",
    "RampFamily",
    "circular_bowl",
    "circular_dome",
    "cycloid",
    "from_functions",
    "quadratic",
    "sine",
    "spline",
    "spline_shared",
    "straight",
]

CALLABLE = "callable"


# ---------------------------------------------------------------------------
# the settings object


@dataclass(frozen=True)
class Ramp:
    """One ramp: a family, all its parameters (defaults applied, in family
    order), a domain, and the spline's data.  Build with :meth:`create` or
    :meth:`from_functions`; construction validates."""

    family: str
    params: tuple[tuple[str, float], ...]
    domain: tuple[float, float]
    shared: tuple[float, ...] = ()
    _callable: RampFamily | None = field(default=None, repr=False)

    def __post_init__(self):
        spec = self.spec
        object.__setattr__(self, "domain", _check_domain(self.domain))
        names = tuple(name for name, _ in self.params)
        if names != spec.parameter_names:
            raise ConfigError("ramp", f"parameters {names} do not match family {self.family!r}: "
                              f"expected {spec.parameter_names}")
        object.__setattr__(self, "params", tuple((name, float(value)) for name, value in self.params))
        if isinstance(self.shared, np.ndarray):  # a family's build_shared (ChordModes: 12k numbers a population)
            array = np.array(self.shared, dtype=np.float64).ravel()  # a copy: kept for shared_array()
            object.__setattr__(self, "shared", tuple(array.tolist()))  # Python floats in one pass
            object.__setattr__(self, "_shared_array", array if array.size else None)
        else:  # map: ~3x a generator's speed
            object.__setattr__(self, "shared", tuple(map(float, self.shared)))
        if spec.data_names and not self.shared:
            raise ConfigError("ramp", f"family {self.family!r} needs {', '.join(spec.data_names)}")
        spec.check_values({name: np.array([value]) for name, value in self.params}, self.domain,
                          self.shared or None)

    # -- construction -------------------------------------------------------

    @classmethod
    def create(cls, family: str, domain=None, **params) -> "Ramp":
        """A validated ramp of a registered family.  ``params``: the family's
        parameters by name (defaults fill the rest); for ``"spline"``,
        ``x_points`` and ``y_points`` (``domain`` defaults to their range).

        A ``"straight"`` ramp (or a ``"quadratic"`` of curvature 0) is solved
        in closed form by :func:`rampwork.simulate`, exactly and without
        steps, whatever the scene's integrator; ``Integrator(...,
        closed_form=False)`` steps it with the integrator instead."""
        if family == CALLABLE:
            raise ConfigError("ramp.family", "callable ramps are built with Ramp.from_functions(f, fp, fpp, ...)")
        if not isinstance(family, str) or family not in FAMILIES:
            raise ConfigError("ramp.family", f"unknown ramp family {family!r}; allowed: "
                              f"{', '.join(map(repr, FAMILIES))} (and user functions via Ramp.from_functions)")
        spec = FAMILIES[family]
        allowed = spec.parameter_names + spec.data_names
        old = {name: value for name, value in params.items() if name in spec.renamed}
        params = {name: value for name, value in params.items() if name not in spec.renamed}
        for name in params:
            if name not in allowed:
                raise spec.unknown_parameter(f"ramp.{name}", name, allowed + ("domain",))
        values = []
        for p in spec.parameters:
            where = f"ramp.{p.name}"
            if p.name in params:
                value = validate.real(where, params[p.name])
            elif p.default is not None:
                value = p.default
            else:
                raise ConfigError(where, f"required by ramp family {family!r} ({p.long_name}, {p.units})")
            if p.constraint == "positive":
                value = validate.positive(where, value)
            values.append((p.name, value))
        if old:
            values = _read_renamed(spec, old, set(params), values)
        shared: tuple[float, ...] = ()
        if spec.data_names:
            for name in spec.data_names:
                if name not in params:
                    raise ConfigError(f"ramp.{name}", f"required by ramp family {family!r}")
            shared = spec.build_shared({name: params[name] for name in spec.data_names}, domain)
            if domain is None:
                domain = spec.data_domain(shared)
        if domain is None:
            raise ConfigError("ramp.domain", f"required for ramp family {family!r}: [x_min, x_max] in m")
        return cls(family, tuple(values), _check_domain(domain), shared)

    @classmethod
    def from_functions(cls, f: Callable, fp: Callable, fpp: Callable, domain, curvature_sign=None,
                       name: str = CALLABLE, check: bool = True) -> "Ramp":
        """A ramp from user functions f(x), f'(x), f''(x) of one float (numba
        ``njit``-ed, or plain Python that numba can compile).  ``curvature_sign``
        declares the sign of f'' on the domain (+1, -1, 0 or None = unknown).

        The functions are sampled on the domain (257 points): their values
        must be finite.  With ``check`` (default True) fp and fpp must also
        match finite differences of f and fp to within an error estimate of
        the differences (Richardson extrapolation over halved steps, so steep
        ends near a vertical tangent pass), and f'' must have the declared
        sign.  ``check=False`` skips those two tests, for functions whose
        derivatives are right but that finite differences cannot resolve
        (e.g. noisy or piecewise definitions); the kernels then trust fp and
        fpp as given."""
        where = "ramp.curvature_sign"
        if curvature_sign is not None:
            if isinstance(curvature_sign, bool) or curvature_sign not in (-1, 0, 1):
                raise ConfigError(where, f"must be +1 (convex), -1 (concave), 0 (straight) or None (unknown), "
                                  f"got {curvature_sign!r}")
            curvature_sign = int(curvature_sign)
        if not isinstance(name, str) or not name:
            raise ConfigError("ramp.name", f"expected a non-empty string, got {name!r}")
        domain = _check_domain(domain)
        jitted = [_as_dispatcher(label, g) for label, g in (("f", f), ("fp", fp), ("fpp", fpp))]
        # kernels on them are cached under a digest of what they compute
        # (userfunctions.py); where there is none, compiled in every process
        digest = content_digest(jitted)
        cacheable = digest is not None
        key = (f"callable_{digest or next(_CALLABLE_COUNTER)}_"
               f"{re.sub(r'[^0-9A-Za-z_]', '_', name)}")
        height = specialise(core.callable_height_template, f"{key}_height",
                            {"USER_F": jitted[0]}, cache=cacheable)
        slope_curvature = specialise(core.callable_slope_curvature_template, f"{key}_slope_curvature",
                                     {"USER_FP": jitted[1], "USER_FPP": jitted[2]}, cache=cacheable)
        family = _Callable(name, f"user functions {name!r}", (), height, slope_curvature,
                           is_straight=curvature_sign == 0, cacheable=cacheable, key=key,
                           sign=curvature_sign)
        ramp = cls(CALLABLE, (), domain, (), family)
        ramp._check_functions(curvature_sign, check)
        return ramp

    @classmethod
    def from_dict(cls, data: Mapping) -> "Ramp":
        """Inverse of :meth:`to_dict`."""
        if not isinstance(data, Mapping) or "family" not in data:
            raise ConfigError("ramp", f"expected a table with a 'family' key, got {data!r}")
        return cls.create(**dict(data))

    # -- views --------------------------------------------------------------

    @property
    def spec(self) -> RampFamily:
        """The :class:`RampFamily` (for callable ramps, the one built for its functions)."""
        if self.family == CALLABLE:
            if self._callable is None:
                raise ConfigError("ramp.family", "callable ramps are built with Ramp.from_functions")
            return self._callable
        if self.family not in FAMILIES:
            raise ConfigError("ramp.family", f"unknown ramp family {self.family!r}; allowed: "
                              f"{', '.join(map(repr, FAMILIES))}")
        return FAMILIES[self.family]

    @property
    def is_straight(self) -> bool:
        return self.spec.is_straight

    def param_dict(self) -> dict[str, float]:
        return dict(self.params)

    def shared_array(self) -> np.ndarray:
        """``shared`` as float64 (``np.zeros(1)`` when the family has none),
        converted once per ramp (a population's 12k numbers: 0.25 ms a time);
        read, never written (the kernels and evaluators only read it)."""
        array = self.__dict__.get("_shared_array")
        if array is None:
            array = np.array(self.shared, dtype=np.float64) if self.shared else np.zeros(1)
            object.__setattr__(self, "_shared_array", array)
        return array

    def packed(self) -> tuple[float, float, float, float]:
        """p0..p3 as floats (zeros for unused slots)."""
        values = [value for _, value in self.params]
        return tuple(values + [0.0] * (4 - len(values)))

    def curvature_sign(self) -> int | None:
        """+1 if f'' >= 0 on the domain, -1 if <= 0, 0 if straight, None if mixed/unknown."""
        return self.spec.curvature_sign({k: np.array([v]) for k, v in self.params}, self.domain,
                                        self.shared or None)

    def evaluate(self, x) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """f, f', f'' at the points ``x`` (any shape), by a jitted loop over the
        same core functions the kernel inlines."""
        x = np.asarray(x, dtype=np.float64)
        flat = np.ascontiguousarray(x.ravel())
        f = np.empty_like(flat)
        fp = np.empty_like(flat)
        fpp = np.empty_like(flat)
        self.spec.evaluator()(flat, *self.packed(), self.shared_array(), f, fp, fpp)
        return f.reshape(x.shape), fp.reshape(x.shape), fpp.reshape(x.shape)

    def to_dict(self) -> dict:
        """Plain data for TOML/JSON: ``{"family", "domain", <params>..., [x_points, y_points]}``;
        ``Ramp.create(**ramp.to_dict())`` (or :meth:`from_dict`) rebuilds it."""
        if self.family == CALLABLE:
            raise ConfigError("ramp", "callable ramps cannot be serialised")
        data = {"family": self.family, "domain": [self.domain[0], self.domain[1]]}
        data.update(self.params)
        if self.spec.data_names:
            data.update(self.spec.data_dict(self.shared))
        return data

    # -- callable checks ----------------------------------------------------

    def _check_functions(self, curvature_sign, check: bool) -> None:
        lo, hi = self.domain
        x = np.linspace(lo, hi, 257)
        try:
            f, fp, fpp = self.evaluate(x)
        except ConfigError:
            raise
        except Exception as error:  # numba typing errors, user exceptions
            raise ConfigError("ramp.f", f"could not evaluate the user functions with numba: "
                              f"{type(error).__name__}: {str(error).splitlines()[0] if str(error) else ''}") from None
        for label, values in (("f", f), ("fp", fp), ("fpp", fpp)):
            bad = ~np.isfinite(values)
            if bad.any():
                i = int(np.argmax(bad))
                raise ConfigError(f"ramp.{label}", f"not finite at x = {_fmt(x[i])} (got {_fmt(values[i])}); "
                                  f"the domain [{lo!r}, {hi!r}] must avoid vertical tangents and singularities")
        if not check:
            return
        self._check_derivatives()
        if curvature_sign is not None:
            scale = np.max(np.abs(fpp)) * 1e-12
            ok = {1: fpp >= -scale, -1: fpp <= scale, 0: np.abs(fpp) <= scale}[curvature_sign]
            if not ok.all():
                i = int(np.argmax(~ok))
                raise ConfigError("ramp.curvature_sign", f"declared {curvature_sign:+d} but fpp({_fmt(x[i])}) = "
                                  f"{_fmt(fpp[i])}")

    def _check_derivatives(self, points: int = 101, levels: int = 8, safety: float = 4.0,
                           rtol: float = 1e-6) -> None:
        """fp and fpp against finite differences of f and fp, with an error
        estimate (Richardson): at each point, fourth-order central differences
        with steps h, h/2, ... h/2**(levels-1), the stencil inside the domain;
        the two consecutive steps whose results agree best give the estimate,
        and their difference plus the rounding error of the differences bounds
        its error.  A derivative is refused where it differs from the estimate
        by more than ``safety`` such bounds plus ``rtol`` times its largest
        size on the domain: steep ends (near a vertical tangent, a
        singularity of f'') widen the bound instead of failing the check."""
        lo, hi = self.domain
        x = np.linspace(lo, hi, points)[1:-1]
        # the stencil x +- 2h stays in [lo, hi]
        first = np.minimum(1e-2 * (hi - lo), 0.5 * np.minimum(x - lo, hi - x))
        exact = self.evaluate(x)
        eps = np.finfo(np.float64).eps
        columns = np.arange(x.size)
        for label, index in (("fp", 1), ("fpp", 2)):
            estimates, rounding = [], []
            for level in range(levels):
                h = first / 2.0**level
                g = [self.evaluate(x + k * h)[index - 1] for k in (-2, -1, 1, 2)]
                estimates.append((g[0] - 8 * g[1] + 8 * g[2] - g[3]) / (12 * h))
                rounding.append(eps * (np.abs(g[0]) + 8 * np.abs(g[1]) + 8 * np.abs(g[2])
                                       + np.abs(g[3])) / (12 * h))
            estimates, rounding = np.array(estimates), np.array(rounding)
            error = np.abs(np.diff(estimates, axis=0)) + rounding[1:] + rounding[:-1]
            best = np.argmin(error, axis=0)
            estimate, bound = estimates[best + 1, columns], error[best, columns]
            value = exact[index]
            tolerance = safety * bound + rtol * np.max(np.abs(value))
            bad = ~(np.abs(estimate - value) <= tolerance)
            if bad.any():
                i = int(np.argmax(np.where(bad, np.abs(estimate - value) - tolerance, -np.inf)))
                of = "f" if label == "fp" else "fp"
                raise ConfigError(f"ramp.{label}", f"does not match the derivative of {of}: at x = "
                                  f"{_fmt(x[i])} {label} = {_fmt(value[i])} but finite differences "
                                  f"give {_fmt(estimate[i])} (+- {bound[i]:.2g}); if {label} is "
                                  "right, pass check=False to skip this test")


_CALLABLE_COUNTER = itertools.count(1)


def _read_renamed(spec: RampFamily, old: Mapping, given: set, values: list) -> list:
    """``values`` (name, value) with the parameters given under their old
    names converted to the new ones, each with a warning that says how."""
    params = dict(values)
    for name, raw in old.items():
        renamed = spec.renamed[name]
        where = f"ramp.{name}"
        if renamed.new in given:
            raise ConfigError(where, f"{renamed.explain(spec.name)}: give {renamed.new} alone")
        value = renamed.convert(validate.real(where, raw), params)
        params[renamed.new] = value
        warn(f"{where}: {renamed.explain(spec.name)}: read as {renamed.new} = {value!r}; "
             f"write that instead (the old name will be refused in a later version)",
             RenamedParameterWarning)
    return [(name, params[name]) for name, _ in values]


def _as_dispatcher(label: str, function):
    if not callable(function):
        raise ConfigError(f"ramp.{label}", f"expected a function of x, got {function!r}")
    if hasattr(function, "py_func") and hasattr(function, "compile"):  # a numba dispatcher
        return function
    return jit(function, cache=False)


# ---------------------------------------------------------------------------
# convenience constructors


def straight(slope, height=0.0, *, domain) -> Ramp:
    return Ramp.create("straight", domain=domain, slope=slope, height=height)


def quadratic(curvature, slope=0.0, height=0.0, *, domain) -> Ramp:
    return Ramp.create("quadratic", domain=domain, curvature=curvature, slope=slope, height=height)


def circular_bowl(radius, x_centre=0.0, *, y_bottom=None, domain, **old) -> Ramp:
    """The lower half circle whose lowest point is (x_centre, y_bottom); ``old``:
    ``y_centre``, read with a warning (see :class:`RenamedParameter`)."""
    bottom = {} if y_bottom is None else {"y_bottom": y_bottom}
    return Ramp.create("circular_bowl", domain=domain, radius=radius, x_centre=x_centre, **bottom, **old)


def circular_dome(radius, x_centre=0.0, y_centre=0.0, *, domain) -> Ramp:
    return Ramp.create("circular_dome", domain=domain, radius=radius, x_centre=x_centre, y_centre=y_centre)


def cycloid(radius, *, domain) -> Ramp:
    return Ramp.create("cycloid", domain=domain, radius=radius)


def sine(amplitude, wavenumber, *, mean_slope=None, phase=0.0, domain, **old) -> Ramp:
    """y = mean_slope*x + amplitude*sin(wavenumber*x + phase); ``old``: ``slope``
    (the downhill slope, -mean_slope), read with a warning (see :class:`RenamedParameter`)."""
    slope = {} if mean_slope is None else {"mean_slope": mean_slope}
    return Ramp.create("sine", domain=domain, amplitude=amplitude, wavenumber=wavenumber, phase=phase,
                       **slope, **old)


def spline(x_points, y_points, *, domain=None) -> Ramp:
    return Ramp.create("spline", domain=domain, x_points=x_points, y_points=y_points)


def from_functions(f, fp, fpp, *, domain, curvature_sign=None, name=CALLABLE, check=True) -> Ramp:
    return Ramp.from_functions(f, fp, fpp, domain, curvature_sign=curvature_sign, name=name, check=check)
