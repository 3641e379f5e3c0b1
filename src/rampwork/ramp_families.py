"""The built-in ramp families (:data:`FAMILIES`) and the spline's data.

Each family is a :class:`~rampwork.ramp_family.RampFamily` with its
parameters, its jitted functions (:mod:`rampwork.core.ramps`) and the checks
that differ from the base class's: its domain, the sign of its curvature, and
whether fixed steps may take its short stage form.
"""

from __future__ import annotations

import math

import numpy as np

from .core import ramps as core
from .core.layout import ENERGY_RISE_FACTOR
from .core.vmath import VALID_ARGUMENT as VALID_SINE_ARGUMENT
from .errors import ConfigError
from .ramp_family import (ParameterSpec, RampFamily, RenamedParameter, _at, _check_domain, _fmt,
                          _p, _real_array, _sign_of)


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
        core.cycloid.CYCLOID_SHORT_BOUND for every step, with |f'| at its
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
        return np.concatenate(  # an array: Ramp makes it a tuple in one pass and keeps it for shared_array
            [[k, lo, hi, ends[0], ends[1], (ends[1] - ends[0]) / (hi - lo), math.pi / (hi - lo)], table],
            dtype=np.float64)

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
