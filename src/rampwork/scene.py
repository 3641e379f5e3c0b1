"""Settings objects: small frozen dataclasses that validate themselves.

A :class:`Scene` says what is simulated (ramp, friction, contact, integrator,
stop conditions, start values); a :class:`Sweep` says over which values.  Bad
input raises :class:`~rampwork.errors.ConfigError` naming the parameter, the
value and what is allowed, before any work starts.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from . import validate
from .designs import DESIGN_KINDS, Design
from .core import steppers
from .core.steppers import ADAPTIVE_STEPPERS
from .errors import ConfigError
from .ramps import Ramp

METHODS = tuple(steppers.METHODS)
#: fixed-step methods' step when none is given (s)
DEFAULT_DT = 1e-3
#: adaptive methods' relative tolerance when none is given, and the ranges
#: allowed (below 1e-14 the target is under float64 rounding of a step)
DEFAULT_RTOL = 1e-6
RTOL_RANGE = (1e-14, 0.1)
ATOL_RANGE = (1e-20, 1.0)
CONTACTS = ("one_sided", "two_sided")
#: optional per-trajectory diagnostics a scene may ask for (each adds an
#: output variable and the code that computes it; nothing otherwise)
DIAGNOSTICS = ("x_lift_off_paper",)
SWEEP_KINDS = ("grid", "cases") + DESIGN_KINDS
#: sweep axes that are not ramp parameters (schema.AXES holds their units)
SCENE_AXES = ("mu", "mu_k", "mu_s", "x0", "v0", "m", "g", "drag_linear", "drag_quadratic")
#: the largest flat trajectory index (int64)
MAX_FLAT_INDEX = int(np.iinfo(np.int64).max)
#: the most fixed steps one trajectory may take (t_max / dt)
MAX_STEPS_PER_TRAJECTORY = 1e10


@dataclass(frozen=True)
class Friction:
    """Coulomb friction: kinetic ``mu_k`` while sliding, static ``mu_s >= mu_k``
    at rest (``None``: equal to ``mu_k``, the paper's case)."""

    mu_k: float = 0.0
    mu_s: float | None = None

    def __post_init__(self):
        mu_k = validate.nonnegative("friction.mu_k", self.mu_k)
        mu_s = mu_k if self.mu_s is None else validate.nonnegative("friction.mu_s", self.mu_s)
        if mu_s < mu_k:
            raise ConfigError("friction.mu_s", f"must be >= mu_k = {mu_k!r}, got {mu_s!r}")
        object.__setattr__(self, "mu_k", mu_k)
        object.__setattr__(self, "mu_s", mu_s)


@dataclass(frozen=True)
class Drag:
    """Air drag along the path: a tangential force opposing the motion of
    magnitude ``m (linear s' + quadratic s'^2)``, ``s'`` the speed along the
    path; ``linear`` in 1/s, ``quadratic`` in 1/m, both >= 0 (default 0: no
    drag, and none is simulated)."""

    linear: float = 0.0
    quadratic: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "linear", validate.nonnegative("drag.linear", self.linear))
        object.__setattr__(self, "quadratic",
                           validate.nonnegative("drag.quadratic", self.quadratic))

    @property
    def enabled(self) -> bool:
        return self.linear > 0.0 or self.quadratic > 0.0


@dataclass(frozen=True)
class Integrator:
    """How trajectories are integrated.

    Fixed-step methods (``euler``, ``semi_implicit_euler``, ``rk4``) take steps
    of ``dt`` (s, default 1e-3).  The adaptive pairs ``dopri5`` (Dormand-Prince
    5(4)) and ``dop853`` (Dormand-Prince 8(5,3), for tight tolerances), with
    PI step-size control per trajectory, keep the local error of x, v and
    the work integrals below ``atol + rtol * |value|`` (``rtol`` default 1e-6,
    ``atol`` default ``rtol``: SI units, so for metre-scale ramps both read as
    relative); ``dt`` is then its first step (default: estimated per
    trajectory) and ``dt_max`` its largest (default: no limit).

    ``closed_form`` (default True): where the scene has an exact solution (a
    straight ramp: constant acceleration between events), use it instead of
    stepping; False steps with ``method`` anyway, e.g. to measure its error.

    ``project_energy`` (adaptive pairs, default True): after each accepted
    step, move the state (x, v and, with friction, W_friction; each by the
    share its tolerance allows) onto the energy balance E(x, v) + W_friction
    + W_drag = E(x0, v0) (docs/physics.md §1.6); energy_balance_error then
    reports the corrections' sum.  False integrates without it (fixed-step
    methods never project, nor does the curve kernel).
    """

    method: str = "rk4"
    dt: float | None = None
    rtol: float | None = None
    atol: float | None = None
    dt_max: float | None = None
    closed_form: bool = True
    project_energy: bool = True

    def __post_init__(self):
        validate.choice("integrator.method", self.method, METHODS)
        for name in ("closed_form", "project_energy"):
            value = getattr(self, name)
            if not isinstance(value, (bool, np.bool_)):
                raise ConfigError(f"integrator.{name}", f"expected true or false, got {value!r}")
            object.__setattr__(self, name, bool(value))
        if self.method in ADAPTIVE_STEPPERS:
            rtol = DEFAULT_RTOL if self.rtol is None else validate.real("integrator.rtol", self.rtol)
            if not RTOL_RANGE[0] <= rtol <= RTOL_RANGE[1]:
                raise ConfigError("integrator.rtol", f"must be in [{RTOL_RANGE[0]:g}, "
                                  f"{RTOL_RANGE[1]:g}], got {rtol!r}")
            atol = rtol if self.atol is None else validate.real("integrator.atol", self.atol)
            if not ATOL_RANGE[0] <= atol <= ATOL_RANGE[1]:
                raise ConfigError("integrator.atol", f"must be in [{ATOL_RANGE[0]:g}, "
                                  f"{ATOL_RANGE[1]:g}], got {atol!r}")
            object.__setattr__(self, "rtol", rtol)
            object.__setattr__(self, "atol", atol)
            if self.dt is not None:
                object.__setattr__(self, "dt", validate.positive("integrator.dt", self.dt))
            if self.dt_max is not None:
                object.__setattr__(self, "dt_max", validate.positive("integrator.dt_max", self.dt_max))
                if self.dt is not None and self.dt > self.dt_max:
                    raise ConfigError("integrator.dt", f"the first step must be <= dt_max = "
                                      f"{self.dt_max!r}, got {self.dt!r}")
            return
        if not self.project_energy:
            raise ConfigError("integrator.project_energy", f"applies to adaptive methods "
                              f"({', '.join(ADAPTIVE_STEPPERS)}); {self.method!r} never projects")
        for name in ("rtol", "atol", "dt_max"):
            if getattr(self, name) is not None:
                raise ConfigError(f"integrator.{name}", f"applies to adaptive methods "
                                  f"({', '.join(ADAPTIVE_STEPPERS)}); {self.method!r} takes "
                                  "fixed steps of dt")
        dt = DEFAULT_DT if self.dt is None else self.dt
        object.__setattr__(self, "dt", validate.positive("integrator.dt", dt))

    @property
    def adaptive(self) -> bool:
        return self.method in ADAPTIVE_STEPPERS

    @property
    def order(self) -> int:
        return steppers.METHODS[self.method].order

    def settings(self) -> dict:
        """The integrator's numeric settings that apply (for attributes and
        scene files; ``closed_form`` apart)."""
        if not self.adaptive:
            return {"method": self.method, "dt": self.dt}
        values = {"method": self.method, "rtol": self.rtol, "atol": self.atol}
        if self.dt is not None:
            values["dt"] = self.dt
        if self.dt_max is not None:
            values["dt_max"] = self.dt_max
        return values

    def describe(self) -> str:
        """One line, e.g. ``rk4, dt = 0.001 s`` or ``dopri5, rtol = 1e-08``."""
        if not self.adaptive:
            return f"{self.method}, dt = {self.dt!r} s"
        text = f"{self.method}, rtol = {self.rtol!r}, atol = {self.atol!r}"
        if self.dt is not None:
            text += f", first step {self.dt!r} s"
        if self.dt_max is not None:
            text += f", dt_max = {self.dt_max!r} s"
        if not self.project_energy:
            text += ", no energy projection"
        return text


@dataclass(frozen=True)
class Record:
    """Record whole trajectories for a few members of a sweep: ``count``
    trajectories evenly spread over the sweep (or the flat ``indices``), a
    sample every ``every`` steps and at every event, at most ``max_samples``."""

    count: int = 0
    every: int = 1
    max_samples: int = 20000
    indices: tuple[int, ...] | None = None

    def __post_init__(self):
        validate.integer("record.count", self.count, 0, 10_000)
        validate.integer("record.every", self.every, 1)
        validate.integer("record.max_samples", self.max_samples, 2, 10_000_000)
        if self.indices is not None:
            # int64 flat indices (larger ones cannot name a trajectory)
            indices = tuple(validate.integer(f"record.indices[{k}]", i, 0, MAX_FLAT_INDEX)
                            for k, i in enumerate(self.indices))
            object.__setattr__(self, "indices", indices)

    @property
    def enabled(self) -> bool:
        return self.count > 0 or bool(self.indices)


@dataclass(frozen=True)
class Scene:
    """One physical set-up.  Start values ``x0`` (m), ``v0`` (m/s, horizontal
    velocity dx/dt), mass ``m`` (kg) and gravity ``g`` (m/s^2) are the values
    used where a sweep does not set them.  ``diagnostics`` names optional
    outputs to compute (:data:`DIAGNOSTICS`): ``x_lift_off_paper``, where the
    paper's lift-off criterion (eq. 26) would first report lift-off, beside
    the contact-force ``x_lift_off``."""

    ramp: Ramp
    friction: Friction = field(default_factory=Friction)
    integrator: Integrator = field(default_factory=Integrator)
    x0: float | None = None
    v0: float = 0.0
    m: float = 1.0
    g: float = 9.81
    t_max: float = 60.0
    contact: str = "one_sided"
    record: Record = field(default_factory=Record)
    title: str = "rampwork simulation"
    diagnostics: tuple[str, ...] = ()
    drag: Drag = field(default_factory=Drag)

    def __post_init__(self):
        if not isinstance(self.ramp, Ramp):
            raise ConfigError("ramp", f"expected a rampwork.Ramp, got {type(self.ramp).__name__}")
        for name, kind in (("friction", Friction), ("integrator", Integrator), ("record", Record),
                           ("drag", Drag)):
            if not isinstance(getattr(self, name), kind):
                raise ConfigError(name, f"expected a rampwork.{kind.__name__}, got {getattr(self, name)!r}")
        if self.x0 is not None:
            x0 = validate.real("x0", self.x0)
            lo, hi = self.ramp.domain
            if not lo <= x0 <= hi:  # refused here, not later by simulate
                raise ConfigError("x0", f"{x0!r} is outside the ramp's domain [{lo!r}, {hi!r}]")
            object.__setattr__(self, "x0", x0)
        object.__setattr__(self, "v0", validate.real("v0", self.v0))
        object.__setattr__(self, "m", validate.positive("m", self.m))
        object.__setattr__(self, "g", validate.positive("g", self.g))
        t_max = validate.positive("t_max", self.t_max)
        object.__setattr__(self, "t_max", t_max)
        validate.choice("contact", self.contact, CONTACTS)
        if isinstance(self.diagnostics, str) or not isinstance(self.diagnostics, (tuple, list)):
            raise ConfigError("diagnostics", f"expected a list of names ({', '.join(DIAGNOSTICS)}), "
                              f"got {self.diagnostics!r}")
        for k, name in enumerate(self.diagnostics):
            validate.choice(f"diagnostics[{k}]", name, DIAGNOSTICS)
        object.__setattr__(self, "diagnostics", tuple(dict.fromkeys(self.diagnostics)))
        if not isinstance(self.title, str):
            raise ConfigError("title", f"expected a string, got {self.title!r}")
        dt = self.integrator.dt
        if dt is not None and not dt < t_max:
            # a step of t_max or more is not a step of the motion (dt_max may
            # exceed t_max: a bound on steps, which t_max then bounds)
            what = "the first step" if self.integrator.adaptive else "the step"
            raise ConfigError("integrator.dt", f"{what} {dt!r} s must be shorter than t_max = "
                              f"{t_max!r} s (the longest a trajectory runs)")
        if (not self.integrator.adaptive
                and t_max / self.integrator.dt > MAX_STEPS_PER_TRAJECTORY):
            raise ConfigError("t_max", f"t_max / dt = {t_max / self.integrator.dt:.3g} steps per "
                              f"trajectory; at most {MAX_STEPS_PER_TRAJECTORY:.0e} allowed")

    def replace(self, **changes) -> "Scene":
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    @property
    def axis_names(self) -> tuple[str, ...]:
        """Every name a sweep may use with this scene."""
        return SCENE_AXES + self.ramp.spec.parameter_names


@dataclass(frozen=True, eq=False)
class Sweep:
    """Values to run a scene over: a full ``grid`` (outer product of the axes,
    one output dimension per axis, in the given order), ``cases`` (every axis
    the same length, one ``case`` dimension), or a design drawn from its
    recipe (``design``, a :class:`~rampwork.designs.Design`; one ``case``
    dimension, and ``kind`` is the design's: ``random``, ``sobol``,
    ``halton`` or ``lhs``).  Build with :meth:`grid`, :meth:`cases`,
    :meth:`single`, or a design's :meth:`random`, :meth:`sobol`,
    :meth:`halton`, :meth:`lhs`.

    ``axes``: (name, values) pairs, the values a read-only float64 copy of
    those given (an array, not a tuple of Python floats: a sweep of 1e6
    cases costs no per-value Python work).  Sweeps are equal when their
    kinds, designs, names and values (``np.array_equal``) are."""

    axes: tuple[tuple[str, np.ndarray], ...] = ()
    kind: str = "grid"
    design: Design | None = None

    def __post_init__(self):
        validate.choice("sweep.kind", self.kind, SWEEP_KINDS)
        if self.kind in DESIGN_KINDS or self.design is not None:
            if not isinstance(self.design, Design) or self.design.kind != self.kind or self.axes:
                raise ConfigError("sweep", f"a design is given as its recipe alone: use Sweep.{self.kind}"
                                  "(n, seed, **ranges) or Sweep.from_design(design), got "
                                  f"kind = {self.kind!r}, design = {self.design!r} and {len(self.axes)} axes")
            _check_mu_names(set(self.design.names))
            return
        seen = set()
        axes = []
        for name, values in self.axes:
            if not isinstance(name, str) or not name:
                raise ConfigError("sweep", f"axis names must be non-empty strings, got {name!r}")
            if name in seen:
                raise ConfigError(f"sweep.{name}", "given twice")
            seen.add(name)
            array = np.array(validate.real_array(f"sweep.{name}", values), dtype=np.float64)
            array.flags.writeable = False  # a copy the caller cannot change under the sweep
            axes.append((name, array))
        _check_mu_names(seen)
        if self.kind == "cases" and axes:
            lengths = {len(values) for _, values in axes}
            if len(lengths) > 1:
                raise ConfigError("sweep", "cases need axes of one length, got "
                                  + ", ".join(f"{n}: {len(v)}" for n, v in axes))
        object.__setattr__(self, "axes", tuple(axes))

    def __eq__(self, other) -> bool:
        if not isinstance(other, Sweep):
            return NotImplemented
        return (self.kind == other.kind and self.design == other.design
                and len(self.axes) == len(other.axes)
                and all(a == b and np.array_equal(u, v)
                        for (a, u), (b, v) in zip(self.axes, other.axes)))

    def __hash__(self) -> int:
        return hash((self.kind, self.design,
                     tuple((name, values.tobytes()) for name, values in self.axes)))

    @classmethod
    def grid(cls, **axes) -> "Sweep":
        return cls(tuple(axes.items()), "grid")

    @classmethod
    def cases(cls, **columns) -> "Sweep":
        return cls(tuple(columns.items()), "cases")

    @classmethod
    def single(cls) -> "Sweep":
        """No axes: one trajectory with the scene's own values."""
        return cls((), "grid")

    @classmethod
    def from_design(cls, design: Design) -> "Sweep":
        """The sweep of a :class:`~rampwork.designs.Design` (its recipe)."""
        if not isinstance(design, Design):
            raise ConfigError("sweep", f"expected a rampwork.designs.Design, got {type(design).__name__}")
        return cls((), design.kind, design)

    @classmethod
    def random(cls, n: int, seed: int = 0, log: tuple[str, ...] = (), **ranges) -> "Sweep":
        """``n`` cases drawn independently and uniformly from ``ranges`` (name ->
        (low, high)); names in ``log`` are drawn uniformly in their logarithm
        (low > 0).  Stored as its recipe and drawn chunk by chunk: case i's
        values depend on (n, seed, ranges) and i only (see
        :mod:`rampwork.designs`); at most 1e8 cases."""
        return cls.from_design(Design.from_ranges("random", n, seed, log, **ranges))

    @classmethod
    def sobol(cls, n: int, seed: int = 0, log: tuple[str, ...] = (), **ranges) -> "Sweep":
        """A scrambled Sobol' design of ``n`` cases (a power of 2), scipy's
        ``qmc.Sobol(d, scramble=True, rng=seed)`` scaled to ``ranges``; as
        :meth:`random` otherwise."""
        return cls.from_design(Design.from_ranges("sobol", n, seed, log, **ranges))

    @classmethod
    def halton(cls, n: int, seed: int = 0, log: tuple[str, ...] = (), **ranges) -> "Sweep":
        """A scrambled Halton design, scipy's ``qmc.Halton(d, scramble=True,
        rng=seed)`` scaled to ``ranges``; as :meth:`random` otherwise."""
        return cls.from_design(Design.from_ranges("halton", n, seed, log, **ranges))

    @classmethod
    def lhs(cls, n: int, seed: int = 0, log: tuple[str, ...] = (), **ranges) -> "Sweep":
        """A Latin hypercube design of ``n`` cases: on each axis every one of
        ``n`` equal strata (in the logarithm for ``log`` names) holds one case;
        as :meth:`random` otherwise (strata: see :mod:`rampwork.designs`)."""
        return cls.from_design(Design.from_ranges("lhs", n, seed, log, **ranges))

    @property
    def names(self) -> tuple[str, ...]:
        if self.design is not None:
            return self.design.names
        return tuple(name for name, _ in self.axes)

    def values(self, name: str) -> np.ndarray:
        """One axis's values (a design's are drawn: all ``n`` of them)."""
        if self.design is not None:
            if name not in self.design.names:
                raise KeyError(name)
            return self.design.draw()[name]
        return np.array(dict(self.axes)[name])

    @property
    def shape(self) -> tuple[int, ...]:
        if self.design is not None:
            return (self.design.n,)
        if self.kind == "cases":
            return (len(self.axes[0][1]),) if self.axes else (1,)
        return tuple(len(values) for _, values in self.axes)

    @property
    def size(self) -> int:
        return int(np.prod(self.shape, dtype=np.int64))

    @property
    def dims(self) -> tuple[str, ...]:
        if self.kind != "grid":
            return ("case",)
        return self.names


def _check_mu_names(names: set) -> None:
    if {"mu", "mu_k"} <= names or {"mu", "mu_s"} <= names:
        raise ConfigError("sweep.mu", "sets mu_k = mu_s; do not combine it with mu_k or mu_s axes")
