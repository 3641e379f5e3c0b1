"""One kernel variant: every compile-time choice of a compiled kernel, in one place.

A scene leaves out at compile time what it does not need (air drag, the
contact check, the friction branch, ...), so the kernel that runs it is
specialised to it.  A :class:`KernelVariant` states those choices once; the
templates' constants, the compiled functions' names (and with them numba's
cache files), the runner's kernel table key and the words of the
``kernel_effects`` attribute all derive from it.  Facts about a method (first
order, linear in the step size) live on the method (``steppers.METHODS``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from .layout import (DEFAULT_LANES, FIXED_STEP_LANES, N_SUBSTEPS, N_SUBSTEPS_ADAPTIVE,
                     VECTOR_BLOCK)
from .general import MAXIMAL
from .steppers import ADAPTIVE_STEPPERS, METHODS

#: the method name of the straight ramp's closed form (no stepping)
CLOSED_FORM = "closed_form"
#: the family and fixed-step method names of general kernels (chosen at run time)
ANY_FAMILY = "any_family"
ANY_FIXED_STEP = "fixed_step"


@dataclass(frozen=True)
class KernelVariant:
    """What one compiled kernel simulates and how it is laid out.

    ``family``: the ramp family's key (names the ramp functions uniquely);
    ``method``: a stepping method of ``steppers.METHODS`` or :data:`CLOSED_FORM`.
    The physics choices: ``one_sided`` contact (a block on top; False: a bead
    on a wire); ``check_contact`` (False where n > 0 is known in advance:
    f'' >= 0); ``carry_slope`` (keep f', f'' from the previous step's end
    instead of evaluating them again; adaptive pairs always do);
    ``friction`` (False: mu_k = 0 everywhere, no friction branch);
    ``drag_linear``, ``drag_quadratic`` (air drag's terms);
    ``paper_criterion`` (record where the paper's eq. 26 first holds);
    ``constant_curvature`` (f'' is the same all along the ramp: no curvature
    integral with fixed steps); ``uniform_parameters`` (g and the ramp
    parameters are the run's settings, not per lane); ``short_stages``
    (fixed steps on a family that evaluates a step's stage points and end
    from its start, ``ramps.SLOPE_CURVATURE_NEAR``: the plan has bounded
    every step's angle, so the family's short form
    ``ramps.SLOPE_CURVATURE_SHORT`` serves); ``project_energy`` (adaptive
    pairs only: each accepted step's end is projected onto the energy
    balance, ``adaptive._project_energy``).  Tuning knobs that do not
    change results: ``lanes`` per block, ``substeps`` between scalar
    passes (default by method kind), ``chains`` (lane-loop halves side by
    side), ``unroll`` (fixed steps per lane visit).  ``lanes`` defaults to
    ``layout.FIXED_STEP_LANES`` for a specialised fixed-step kernel and to
    ``DEFAULT_LANES`` for the adaptive pairs and the general kernels.

    ``runtime``: the general kernel of a kind (``general.py``): family
    :data:`ANY_FAMILY`, method :data:`ANY_FIXED_STEP` or an adaptive pair,
    and every choice of ``general.RUNTIME_FLAGS`` read at run time (the
    other flags take their ``general.MAXIMAL`` values); see :meth:`general`."""

    family: str
    method: str
    one_sided: bool = True
    check_contact: bool = True
    carry_slope: bool = True
    friction: bool = True
    drag_linear: bool = False
    drag_quadratic: bool = False
    paper_criterion: bool = False
    constant_curvature: bool = False
    uniform_parameters: bool = False
    short_stages: bool = False
    project_energy: bool = True
    lanes: int | None = None
    substeps: int | None = None
    chains: int = 2
    unroll: int = 1
    runtime: bool = False

    def __post_init__(self):
        if self.runtime:
            if self.family != ANY_FAMILY or not (self.method == ANY_FIXED_STEP
                                                 or self.method in ADAPTIVE_STEPPERS):
                raise ValueError("a runtime (general) variant has family any_family and method "
                                 f"{ANY_FIXED_STEP} or an adaptive pair; got {self.family!r}, "
                                 f"{self.method!r}")
            for name, value in MAXIMAL.items():  # one general variant per kind
                if name.lower() in self.__dataclass_fields__:
                    object.__setattr__(self, name.lower(), value)
        elif self.method != CLOSED_FORM and self.method not in METHODS:
            raise ValueError(f"unknown method {self.method!r}; allowed: "
                             f"{', '.join(METHODS)}, {CLOSED_FORM}")
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if field.type == "bool":
                object.__setattr__(self, field.name, bool(value))
        if self.closed_form:
            # the closed form has none of the stepping choices (friction: only
            # in words, its arithmetic is the same with mu_k = 0)
            for field in dataclasses.fields(self):
                if field.name not in ("family", "method", "paper_criterion", "friction"):
                    object.__setattr__(self, field.name, field.default)
            object.__setattr__(self, "check_contact", False)  # n = g > 0 throughout
            object.__setattr__(self, "project_energy", False)
            return
        if not self.adaptive:
            object.__setattr__(self, "project_energy", False)  # the pairs' option only
        if self.adaptive:
            object.__setattr__(self, "carry_slope", True)  # the last stage evaluates them anyway
            object.__setattr__(self, "short_stages", False)  # stages evaluated afresh
        if self.substeps is None:
            object.__setattr__(self, "substeps",
                               N_SUBSTEPS_ADAPTIVE if self.adaptive else N_SUBSTEPS)
        if self.lanes is None:  # the specialised fixed-step kernels' smaller blocks
            object.__setattr__(self, "lanes", FIXED_STEP_LANES
                               if not (self.adaptive or self.runtime) else DEFAULT_LANES)
        if self.lanes % VECTOR_BLOCK or self.lanes < VECTOR_BLOCK:
            raise ValueError(f"lanes ({self.lanes}) must be a positive multiple of {VECTOR_BLOCK}")
        if self.chains not in (1, 2):
            raise ValueError(f"chains must be 1 or 2, got {self.chains}")
        if self.unroll < 1 or self.substeps % self.unroll:
            raise ValueError(f"substeps ({self.substeps}) must be a multiple of unroll ({self.unroll})")
        if self.adaptive and self.substeps % 2:
            raise ValueError(f"substeps ({self.substeps}) must be even for an adaptive pair: its "
                             "attempts alternate between two banks of the lane state")

    # -- derived facts -----------------------------------------------------

    @property
    def closed_form(self) -> bool:
        return self.method == CLOSED_FORM

    @property
    def adaptive(self) -> bool:
        return self.method in ADAPTIVE_STEPPERS

    @property
    def drag(self) -> bool:
        return self.drag_linear or self.drag_quadratic

    @property
    def first_order(self) -> bool:
        """A first-order step uses the start's n and v: its friction work is
        >= 0 and a step that keeps d v > 0 moves x in direction d."""
        return self.method in METHODS and METHODS[self.method].first_order

    @property
    def linear_events(self) -> bool:
        """x and v linear in the step size: events located in closed form."""
        return self.method in METHODS and METHODS[self.method].linear_in_h

    def general(self) -> "KernelVariant":
        """The general (runtime) variant that can run this one's scenes."""
        return KernelVariant(ANY_FAMILY, self.method if self.adaptive else ANY_FIXED_STEP,
                             runtime=True)

    def replace(self, **changes) -> "KernelVariant":
        return dataclasses.replace(self, **changes)

    # -- what derives from it ----------------------------------------------

    @property
    def name(self) -> str:
        """Unique to the variant: the compiled functions' names (and numba's
        cache files) are built from it."""
        if self.closed_form:
            return f"{self.family}_{CLOSED_FORM}_{'paper' if self.paper_criterion else 'plain'}"
        flags = "".join(suffix for on, suffix in (
            (self.check_contact, "_contact"), (self.carry_slope, "_carry"),
            (self.drag_linear, "_dragb"), (self.drag_quadratic, "_dragc"),
            (self.paper_criterion, "_paper"), (not self.friction, "_nofriction"),
            (self.constant_curvature, "_constk"), (self.linear_events, "_lin"),
            (self.uniform_parameters, "_uniform"), (self.short_stages, "_short"),
            (self.adaptive and not self.project_energy, "_noproj")) if on)
        contact = "one" if self.one_sided else "two"
        if self.runtime:
            flags, contact = "", "runtime"
        return (f"{self.family}_{self.method}_{contact}{flags}_{self.lanes}_{self.substeps}_"
                f"{self.chains}_{self.unroll}")

    def constants(self) -> dict:
        """The templates' compile-time globals (the functions they call are
        bound by the builders)."""
        if self.closed_form:
            return {"PAPER_CRITERION": self.paper_criterion}
        if self.runtime:
            return {**MAXIMAL, "LANES": self.lanes, "ADAPTIVE": self.adaptive,
                    "SUBSTEPS": self.substeps, "CHAINS": self.chains, "UNROLL": self.unroll}
        return {
            "ONE_SIDED": self.one_sided,
            "CHECK_CONTACT": self.check_contact,
            "CARRY_SLOPE": self.carry_slope,
            "LANES": self.lanes,
            "ADAPTIVE": self.adaptive,
            "SUBSTEPS": self.substeps,
            "CHAINS": self.chains,
            "UNROLL": self.unroll,
            "PAPER_CRITERION": self.paper_criterion,
            "FRICTION": self.friction,
            "WORK_SIGN_CHECK": not self.first_order,
            "CONSTANT_CURVATURE": self.constant_curvature,
            "LINEAR_EVENTS": self.linear_events,
            "MONOTONE_STEP": self.first_order,
            "UNIFORM_PARAMETERS": self.uniform_parameters,
            "DRAG_LINEAR": self.drag_linear,
            "DRAG_QUADRATIC": self.drag_quadratic,
            "DRAG": self.drag,
            "PROJECT_ENERGY": self.project_energy,
        }

    @property
    def effects(self) -> tuple[str, ...]:
        """What the kernel simulates, in words (the ``kernel_effects`` attribute)."""
        if self.closed_form:
            words = ["closed form (straight ramp: constant acceleration between events)"]
        else:
            words = [f"stepping: {self.method}"]
        words.append("kinetic friction" if self.friction else "no friction (mu_k = 0)")
        if self.closed_form:
            words.append("contact never lost (n = g > 0)")
        else:
            if self.one_sided:
                words.append("one-sided contact, " + (
                    "lift-off check" if self.check_contact else "no lift-off check (f'' >= 0)"))
            else:
                words.append("two-sided contact (bead on a wire)" + (
                    ", sign switches of n" if self.check_contact else ", n > 0 known in advance"))
            if self.drag:
                words.append("air drag (" + " and ".join(
                    kind for kind, on in (("linear", self.drag_linear),
                                          ("quadratic", self.drag_quadratic)) if on) + ")")
        if self.adaptive and self.project_energy:
            words.append("energy projection")
        if self.paper_criterion:
            words.append("diagnostic x_lift_off_paper")
        return tuple(words)
