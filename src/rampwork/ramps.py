"""Ramp families and the validated :class:`Ramp` settings object.

A *family* (:class:`RampFamily`, registered in :data:`FAMILIES`) is a shape
y = f(x) with up to four named per-trajectory parameters (passed to the jitted
core as ``p0..p3`` in the order of ``RampFamily.parameters``) and optionally
data shared by all trajectories (the spline's knots, in ``shared``).  A
:class:`Ramp` is one family with all its parameters filled in and a domain.

    >>> ramp = Ramp.create("circular_bowl", radius=2.0, domain=(-1.5, 1.5))
    >>> f, fp, fpp = ramp.evaluate([0.0, 1.0])

User functions: :meth:`Ramp.from_functions` (family ``"callable"``).
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np

from . import validate
from .core import ramps as core
from .core.layout import ENERGY_RISE_FACTOR
from .core.vmath import VALID_ARGUMENT as VALID_SINE_ARGUMENT
from .core.jit import jit, specialise
from .errors import ConfigError, RenamedParameterWarning, warn
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

    def build_shared(self, data: Mapping, domain) -> tuple[float, ...]:
        """``shared`` from the family's ``data_names`` values (validated);
        ``domain`` as given (None where the family supplies its own)."""
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


class _Straight(RampFamily):
    cheap_slope = constant_curvature = True

    def curvature_sign(self, values, domain, shared=None):
        return 0


class _Quadratic(RampFamily):
    cheap_slope = constant_curvature = True

    def curvature_sign(self, values, domain, shared=None):
        k = np.asarray(values["curvature"], dtype=float)
        return _sign_of(bool((k >= 0).all()), bool((k <= 0).all()))


class _Circle(RampFamily):
    def __init__(self, *args, sign: int, **kwargs):
        super().__init__(*args, **kwargs)
        self._sign = sign

    def _check_family(self, arrays, lo, hi, shared):
        radius, xc = np.broadcast_arrays(arrays["radius"], arrays["x_centre"])

        def inside(x):  # also by the core's own arithmetic: R^2 - d^2 > 0
            d = x - xc
            t = d - x
            d_lo = (x - (d - t)) - (xc + t)
            q = ((radius - d) - d_lo) * ((radius + d) + d_lo)
            return (q > 0) & (x > xc - radius) & (x < xc + radius)

        bad = ~(inside(lo) & inside(hi))
        if bad.any():
            i = int(np.argmax(bad))
            raise ConfigError(
                "ramp.domain",
                f"[{lo!r}, {hi!r}] reaches |x - x_centre| >= radius = {_fmt(radius[i])} (a vertical tangent); "
                f"the domain must lie strictly inside ({_fmt(xc[i] - radius[i])}, {_fmt(xc[i] + radius[i])})"
                + (f" for radius = {_fmt(radius[i])}, x_centre = {_fmt(xc[i])}{_at(radius, i)}" if radius.size > 1 else ""))

    def curvature_sign(self, values, domain, shared=None):
        return self._sign


def _step_reach(*, dt, v0, g, mu, drag_linear, drag_quadratic, slope, curvature, rise):
    """A bound on |dx| of every stage point and step end of fixed steps of
    size dt from the step's start (inf where none is proven), for bounds
    ``slope`` on |f'|, ``curvature`` on |f''| and ``rise`` on the height
    range.  The mechanical energy g f + v^2 (1 + f'^2)/2 never grows
    (friction and drag remove it; the kernel reports a trajectory whose
    energy rose by ENERGY_RISE_FACTOR of its scale as diverged), so v^2 <=
    v_e^2 = (1 + ENERGY_RISE_FACTOR) (v0^2 (1 + f'^2) + 2 g rise).  A stage's
    speed is at most v_e + dt A, with A a bound on |dv/dt| at speeds up to
    2 v_e (held if dt A <= v_e), and every stage point and step end lies
    within dt times that of the step's start."""
    v_e = np.sqrt((1.0 + ENERGY_RISE_FACTOR) * (v0 * v0 * (1.0 + slope * slope) + 2.0 * g * rise))
    fast = 2.0 * v_e
    # |dv/dt| <= (|f'| |n| + mu |n|) / (1 + f'^2) + drag, |f'| / (1 + f'^2) <= 1/2
    accel = ((0.5 + mu) * (g + fast * fast * curvature)
             + (drag_linear + drag_quadratic * fast * np.sqrt(1.0 + slope * slope)) * fast)
    return np.where(dt * accel <= v_e, dt * (v_e + dt * accel), np.inf)


class _Cycloid(RampFamily):
    def _check_family(self, arrays, lo, hi, shared):
        r = arrays["radius"]
        ax = max(abs(lo), abs(hi))
        unique, inverse = np.unique(r, return_inverse=True)
        # the core's own arithmetic for pi*r - |x| (> 0 strictly inside)
        ok = np.array([ax < math.pi * ri and core.cycloid_cusp_gap(ax, float(ri)) > 0 for ri in unique])
        bad = ~ok[inverse.ravel()]
        if bad.any():
            i = int(np.argmax(bad))
            lim = _fmt(math.pi * r[i])
            raise ConfigError(
                "ramp.domain",
                f"[{lo!r}, {hi!r}] reaches a cusp of the cycloid at |x| = pi*radius = {lim} with radius = "
                f"{_fmt(r[i])}{_at(r, i)} (a vertical tangent); the domain must lie strictly inside "
                f"(-{lim}, {lim})")

    def short_stages(self, values, domain, *, dt, v0, g, mu, drag_linear, drag_quadratic):
        """(CYCLOID_GROWTH_0 + CYCLOID_GROWTH_1 |f'|) (1 + f'^2) |dx| / 4r <=
        core.ramps.CYCLOID_SHORT_BOUND for every step, with |f'| at its
        largest on the domain (at its largest |x|) and |dx| bounded by
        :func:`_step_reach`."""
        r = np.abs(np.asarray(values["radius"], dtype=float))
        ax = max(abs(domain[0]), abs(domain[1]))
        unique, inverse = np.unique(r, return_inverse=True)
        # the core's own f' and f at the largest |x| (f = 0 at x = 0: its lowest)
        slope = np.array([core.cycloid_slope_curvature(ax, ri, 0.0, 0.0, 0.0, None)[0]
                          for ri in unique])[inverse.ravel()]
        rise = np.array([core.cycloid_height(ax, ri, 0.0, 0.0, 0.0, None)
                         for ri in unique])[inverse.ravel()]
        r = r.ravel()
        p = 1.0 + slope * slope
        reach = _step_reach(dt=dt, v0=v0, g=g, mu=mu, drag_linear=drag_linear,
                            drag_quadratic=drag_quadratic, slope=slope,
                            curvature=p * p / (4.0 * r), rise=rise)
        growth = core.CYCLOID_GROWTH_0 + core.CYCLOID_GROWTH_1 * slope
        return bool(np.all(growth * p * reach / (4.0 * r) <= core.CYCLOID_SHORT_BOUND))

    def curvature_sign(self, values, domain, shared=None):
        return 1


class _Sine(RampFamily):
    def _check_family(self, arrays, lo, hi, shared):
        # the core's sin/cos (core.vmath) are accurate to 1 ulp for arguments
        # within +-VALID_ARGUMENT; the argument k*x + phase is linear in x, so
        # its extremes on the domain are at the ends (the core's arithmetic)
        k, phase = np.broadcast_arrays(arrays["wavenumber"], arrays["phase"])
        theta = np.maximum(np.abs(k * lo + phase), np.abs(k * hi + phase))
        bad = ~(theta <= VALID_SINE_ARGUMENT)
        if bad.any():
            i = int(np.argmax(bad))
            raise ConfigError(
                "ramp.wavenumber",
                f"wavenumber*x + phase reaches {_fmt(theta.ravel()[i])} on the domain [{lo!r}, {hi!r}] with "
                f"wavenumber = {_fmt(k.ravel()[i])}, phase = {_fmt(phase.ravel()[i])}{_at(k.ravel(), i)}; "
                f"it must stay within +-{VALID_SINE_ARGUMENT:g} rad (where sin and cos are accurate to 1 ulp)")

    def short_stages(self, values, domain, *, dt, v0, g, mu, drag_linear, drag_quadratic):
        """|k dx| <= core.ramps.SHORT_STAGE_ANGLE for every step, from a bound
        on the step's reach (:func:`_step_reach`)."""
        m, a, k = (np.abs(np.asarray(values[name], dtype=float))
                   for name in ("mean_slope", "amplitude", "wavenumber"))
        lo, hi = domain
        slope = m + a * k  # bounds |f'|, |f''| and the height range
        reach = _step_reach(dt=dt, v0=v0, g=g, mu=mu, drag_linear=drag_linear,
                            drag_quadratic=drag_quadratic, slope=slope, curvature=a * k * k,
                            rise=m * (hi - lo) + 2.0 * a)
        return bool(np.all(k * reach <= core.SHORT_STAGE_ANGLE))

    def curvature_sign(self, values, domain, shared=None):
        a = np.asarray(values["amplitude"], dtype=float)
        k = np.asarray(values["wavenumber"], dtype=float)
        if ((a == 0) | (k == 0)).all():
            return 0
        return None


class _Spline(RampFamily):
    data_docs = {"x_points": ("m", "the spline's points"),
                 "y_points": ("m", "the spline's points")}

    def build_shared(self, data, domain):
        return spline_shared(data["x_points"], data["y_points"])

    def data_domain(self, shared):
        x_points, _, _ = spline_arrays(shared)
        return float(x_points[0]), float(x_points[-1])

    def data_dict(self, shared):
        x_points, y_points, _ = spline_arrays(shared)
        return {"x_points": x_points.tolist(), "y_points": y_points.tolist()}

    def _check_family(self, arrays, lo, hi, shared):
        if shared is None:
            return
        x_points, _, _ = spline_arrays(shared)
        if lo < x_points[0] or hi > x_points[-1]:
            raise ConfigError("ramp.domain", f"[{lo!r}, {hi!r}] must lie inside the spline's points "
                              f"[{_fmt(x_points[0])}, {_fmt(x_points[-1])}]")

    def curvature_sign(self, values, domain, shared=None):
        if shared is None:
            return None
        x_points, _, m = spline_arrays(shared)
        lo, hi = domain
        # f'' is linear between knots: its extremes are at the knots inside the
        # domain and at the domain's ends.
        inner = m[(x_points > lo) & (x_points < hi)]
        ends = np.array([_spline_fpp(shared, lo), _spline_fpp(shared, hi)])
        fpp = np.concatenate([inner, ends])
        return _sign_of(bool((fpp >= 0).all()), bool((fpp <= 0).all()))


def _spline_fpp(shared, x: float) -> float:
    return core.spline_slope_curvature(float(x), 0.0, 0.0, 0.0, 0.0, np.asarray(shared, dtype=np.float64))[1]


#: the most modes a sine_modes row may have (the recurrence's rounding grows as K^2)
MAX_MODES = 64


class _SineModes(RampFamily):
    """f = chord + sum of K sine modes; the coefficient table in ``shared``
    (layout in :mod:`rampwork.core.ramps`), the trajectory's ``row`` picks one
    row: a population of shapes runs as one sweep over ``row``."""

    general = False  # its own kernel: the general ones stay at their families
    data_docs = {"y_ends": ("m", "heights [y(x_min), y(x_max)] of the chord's ends"),
                 "n_modes": ("1", "K, the number of sine modes per row: one integer in a list, [K]"),
                 "coefficients": ("m", "the table of mode amplitudes c_1..c_K, row after row "
                                       "(rows x K numbers)")}

    def build_shared(self, data, domain):
        if domain is None:
            raise ConfigError("ramp.domain", f"required for ramp family {self.name!r}: "
                              "[x_min, x_max] in m, the chord's ends")
        lo, hi = _check_domain(domain)
        ends = _real_array("ramp.y_ends", data["y_ends"])
        if ends.size != 2:
            raise ConfigError("ramp.y_ends", f"expected two heights [y(x_min), y(x_max)], got {ends.size}")
        n_modes = np.asarray(data["n_modes"]).ravel()
        if (n_modes.size != 1 or n_modes.dtype.kind not in "iuf" or not np.isfinite(n_modes[0])
                or not float(n_modes[0]).is_integer() or not 1 <= n_modes[0] <= MAX_MODES):
            raise ConfigError("ramp.n_modes", f"expected one integer in [1, {MAX_MODES}] (written "
                              f"[K]), got {data['n_modes']!r}")
        k = int(n_modes[0])
        table = _real_array("ramp.coefficients", np.asarray(data["coefficients"]).ravel())
        if table.size % k:
            raise ConfigError("ramp.coefficients", f"expected rows of n_modes = {k} numbers, got "
                              f"{table.size} numbers")
        return tuple(np.concatenate(  # tolist: Python floats, as float(v) each, in one pass
            [[k, lo, hi, ends[0], ends[1], (ends[1] - ends[0]) / (hi - lo), math.pi / (hi - lo)], table],
            dtype=np.float64).tolist())

    def data_dict(self, shared):
        k = int(shared[0])
        return {"y_ends": [shared[3], shared[4]], "n_modes": [float(k)],
                "coefficients": list(shared[core.MODES_HEADER:])}

    def _check_family(self, arrays, lo, hi, shared):
        if shared is None:
            return
        rows = (len(shared) - core.MODES_HEADER) // int(shared[0])
        if (lo, hi) != (shared[1], shared[2]):
            raise ConfigError("ramp.domain", f"[{lo!r}, {hi!r}] must be the chord's ends "
                              f"[{_fmt(shared[1])}, {_fmt(shared[2])}]")
        row = arrays["row"]
        bad = ~((row >= 0) & (row < rows) & (row == np.floor(row)))
        if bad.any():
            i = int(np.argmax(bad))
            raise ConfigError("ramp.row", f"must be an integer in [0, {rows - 1}] (a row of the "
                              f"coefficient table), got {_fmt(row.ravel()[i])}{_at(row, i)}")


class _Callable(RampFamily):
    def __init__(self, *args, sign: int | None, **kwargs):
        super().__init__(*args, **kwargs)
        self._sign = sign

    def curvature_sign(self, values, domain, shared=None):
        return self._sign


def _p(name, units, long_name, constraint="finite", default=None):
    return ParameterSpec(name, units, long_name, constraint, default)


def _circle_parameters(where: str) -> tuple[ParameterSpec, ...]:
    return (_p("radius", "m", "radius of the circle", "positive"),
            _p("x_centre", "m", "x of the centre of the circle", default=0.0),
            _p("y_centre", "m", f"y of the centre of the circle ({where})", default=0.0))


#: the bowl stands on y = y_bottom (default 0); before, it hung from its
#: centre at y_centre (default 0: the bottom at y = -radius)
_BOWL_PARAMETERS = (_p("radius", "m", "radius of the circle", "positive"),
                    _p("x_centre", "m", "x of the centre of the circle (and of the bottom)",
                       default=0.0),
                    _p("y_bottom", "m", "height of the lowest point of the bowl", default=0.0))
_BOWL_Y_CENTRE = RenamedParameter(
    "y_centre", "y_bottom", "was the height of the circle's centre (default 0 put the bottom at "
    "y = -radius)", lambda value, params: value - params["radius"], "y_centre - radius; default 0: "
    "the bottom at y = 0")
_SINE_SLOPE = RenamedParameter(
    "slope", "mean_slope", "was the downhill slope -dy/dx (y = -slope*x + ...)",
    lambda value, params: -value, "-slope, the mean dy/dx, as straight's and quadratic's slope: "
    "y = mean_slope*x + amplitude*sin(wavenumber*x + phase)")


#: The registered families by name (user callables are not registered: see
#: :meth:`Ramp.from_functions`).
FAMILIES: dict[str, RampFamily] = {
    family.name: family
    for family in (
        _Straight("straight", "straight ramp y = height + slope*x",
                  (_p("slope", "1", "slope dy/dx of the ramp"),
                   _p("height", "m", "height of the ramp at x = 0", default=0.0)),
                  core.straight_height, core.straight_slope_curvature, is_straight=True),
        _Quadratic("quadratic", "parabola y = height + slope*x + curvature*x**2/2",
                   (_p("curvature", "m-1", "second derivative d2y/dx2 of the ramp"),
                    _p("slope", "1", "slope dy/dx of the ramp at x = 0", default=0.0),
                    _p("height", "m", "height of the ramp at x = 0", default=0.0)),
                   core.quadratic_height, core.quadratic_slope_curvature),
        _Circle("circular_bowl", "lower half circle y = y_bottom + radius - sqrt(radius**2 - (x - x_centre)**2)",
                _BOWL_PARAMETERS,
                core.circular_bowl_height, core.circular_bowl_slope_curvature, sign=1,
                renamed=(_BOWL_Y_CENTRE,)),
        _Circle("circular_dome", "upper half circle y = y_centre + sqrt(radius**2 - (x - x_centre)**2)",
                _circle_parameters("below the dome"),
                core.circular_dome_height, core.circular_dome_slope_curvature, sign=-1),
        _Cycloid("cycloid", "cycloid bowl x = radius*(u + sin u), y = radius*(1 - cos u), -pi < u < pi",
                 (_p("radius", "m", "radius of the cycloid's rolling circle", "positive"),),
                 core.cycloid_height, core.cycloid_slope_curvature),
        _Sine("sine", "sine on a slope y = mean_slope*x + amplitude*sin(wavenumber*x + phase)",
              (_p("mean_slope", "1", "mean slope dy/dx of the ramp", default=0.0),
               _p("amplitude", "m", "amplitude of the sine"),
               _p("wavenumber", "m-1", "angular wavenumber of the sine"),
               _p("phase", "rad", "phase of the sine at x = 0", default=0.0)),
              core.sine_height, core.sine_slope_curvature, renamed=(_SINE_SLOPE,)),
        _Spline("spline", "natural cubic spline through given points (x_points, y_points)", (),
                core.spline_height, core.spline_slope_curvature, data_names=("x_points", "y_points")),
        _SineModes("sine_modes", "a chord plus K sine modes y = y_lo + (y_hi - y_lo) (x - x_min) / "
                   "(x_max - x_min) + sum_j c_j sin(j pi (x - x_min) / (x_max - x_min)), the c_j "
                   "from one row of a table (rampwork.shapes.ChordModes)",
                   (_p("row", "1", "row of the coefficient table", default=0.0),),
                   core.sine_modes_height, core.sine_modes_slope_curvature,
                   data_names=("y_ends", "n_modes", "coefficients")),
    )
}


# ---------------------------------------------------------------------------
# spline data


def spline_shared(x_points, y_points) -> tuple[float, ...]:
    """Validate the points and build the spline's ``shared`` data (layout in
    :mod:`rampwork.core.ramps`): natural end conditions, f'' = 0 at both ends."""
    x = _real_array("ramp.x_points", x_points)
    y = _real_array("ramp.y_points", y_points)
    if x.size < 3:
        raise ConfigError("ramp.x_points", f"a spline needs at least 3 points, got {x.size}")
    if y.size != x.size:
        raise ConfigError("ramp.y_points", f"must have as many values as x_points ({x.size}), got {y.size}")
    steps = np.diff(x)
    if not (steps > 0).all():
        i = int(np.argmax(~(steps > 0)))
        raise ConfigError("ramp.x_points", f"must be strictly increasing, got {_fmt(x[i])} then {_fmt(x[i + 1])} "
                          f"at index {i}")
    n = x.size
    h = steps
    # Tridiagonal system for the interior second derivatives m_1..m_{n-2}
    # (Thomas algorithm; diagonally dominant, so no pivoting).
    rhs = 6.0 * np.diff(np.diff(y) / h)
    diag = 2.0 * (h[:-1] + h[1:])
    off = h[1:-1]
    k = n - 2
    c = np.zeros(k)
    d = np.zeros(k)
    for i in range(k):
        denom = diag[i] - (off[i - 1] * c[i - 1] if i > 0 else 0.0)
        c[i] = off[i] / denom if i < k - 1 else 0.0
        d[i] = (rhs[i] - (off[i - 1] * d[i - 1] if i > 0 else 0.0)) / denom
    m = np.zeros(n)
    for i in range(k - 1, -1, -1):
        m[i + 1] = d[i] - (c[i] * m[i + 2] if i < k - 1 else 0.0)
    steps_needed = int(math.ceil(math.log2(n - 1)))
    while (1 << steps_needed) < n - 1:  # guard against log2 rounding
        steps_needed += 1
    return tuple(float(v) for v in np.concatenate([[n, steps_needed], x, y, m]))


def spline_arrays(shared) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x_points, y_points, second derivatives) from a spline's ``shared``."""
    shared = np.asarray(shared, dtype=np.float64)
    n = int(shared[0])
    return shared[2:2 + n], shared[2 + n:2 + 2 * n], shared[2 + 2 * n:2 + 3 * n]


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
        object.__setattr__(self, "shared", tuple(float(v) for v in self.shared))
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
        """``shared`` as float64 (``np.zeros(1)`` when the family has none)."""
        return np.array(self.shared, dtype=np.float64) if self.shared else np.zeros(1)

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
