"""The one registry of dataset variables: names, units, long names, dtypes.

Every other module (kernel wrappers, sweep runner, netCDF I/O, plotting, CLI)
reads variable names and attributes from here; nothing else spells them out.

Units are UDUNITS spellings ("s", "m", "m s-1", "J", "m-1", "1"), as CF asks.
Equation numbers refer to the paper in /work/shared/paper.
"""

from __future__ import annotations

import datetime as _dt
import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from rampwork.core.layout import (OUT_CONVEXITY, OUT_DRAG_WORK, OUT_ENERGY_LOSS, OUT_NREJ,
                                  OUT_NREV, OUT_PATH, OUT_STATUS, OUT_STEPS, OUT_T, OUT_V,
                                  OUT_WORK, OUT_WORK_ERROR, OUT_X, OUT_XLIFT, OUT_XLIFT_PAPER)
from rampwork.core.status import STATUS_TABLE
from rampwork.errors import ConfigError

__all__ = [
    "VariableSpec",
    "OUTPUTS",
    "ADAPTIVE_OUTPUTS",
    "CURVE_OUTPUTS",
    "CURVE_AXES",
    "curve_output_names",
    "DRAG_OUTPUTS",
    "output_names",
    "AXES",
    "TRAJECTORY_RECORD",
    "CURVE_RECORD",
    "curve_trace_names",
    "TRACE_DIMS",
    "CASE_DIM",
    "STATUS_FLAG_VALUES",
    "STATUS_FLAG_MEANINGS",
    "STATUS_FLAG_DESCRIPTIONS",
    "CONVENTIONS",
    "axis_spec",
    "traced_attrs",
    "spec_attrs",
    "output_attrs",
    "empty_output",
    "netcdf_attrs",
    "global_attrs",
]

CONVENTIONS = "CF-1.10"

#: dimension of a sweep given as a list of points (random / space-filling designs)
CASE_DIM = "case"

#: dimensions of recorded (sampled) trajectories
TRACE_DIMS = ("traced", "sample")

_NAN = float("nan")


@dataclass(frozen=True)
class VariableSpec:
    """One dataset variable: name, CF ``units`` and ``long_name``, numpy dtype.

    ``fill_value`` is the value for "missing / not computed" (NaN for floats,
    None for integers, which are written without a ``_FillValue``).
    ``present`` says when a per-trajectory output is in a run's dataset:
    ``"always"``, ``"adaptive"`` (adaptive methods only), ``"diagnostic"``
    (when the scene asks for it) or ``"drag"`` (runs with air drag).
    ``row`` is the kernel's output row (``core.layout.OUT_*``) it is read from,
    per unit mass where its units are J; None for the variables
    ``core.reduce`` derives from those (W_linear, W_excess, W_path,
    energy_balance_error).
    """

    name: str
    units: str
    long_name: str
    dtype: str
    description: str
    fill_value: Any = None
    present: str = "always"
    row: int | None = None

    @property
    def np_dtype(self) -> np.dtype:
        return np.dtype(self.dtype)


def _f(name, units, long_name, description, dtype="float64", present="always", row=None):
    return VariableSpec(name, units, long_name, dtype, description, fill_value=_NAN,
                        present=present, row=row)


def _i(name, dtype, long_name, description, units="1", row=None):
    return VariableSpec(name, units, long_name, dtype, description, fill_value=None, row=row)


# ----------------------------------------------------------------------------
# status flags (CF flag_values / flag_meanings), from core.status.STATUS_TABLE
# ----------------------------------------------------------------------------

STATUS_FLAG_VALUES = np.array([code for code, _, _ in STATUS_TABLE], dtype=np.int8)
STATUS_FLAG_MEANINGS = " ".join(name for _, name, _ in STATUS_TABLE)
STATUS_FLAG_DESCRIPTIONS = "; ".join(f"{name}: {meaning}" for _, name, meaning in STATUS_TABLE)

# ----------------------------------------------------------------------------
# per-trajectory outputs, in dataset order
# ----------------------------------------------------------------------------

_OUTPUT_LIST = (
    _i(
        "status",
        "int8",
        "trajectory end status",
        "how the trajectory ended; see flag_values, flag_meanings and flag_descriptions",
        row=OUT_STATUS,
    ),
    _f("t_end", "s", "time at the end of the trajectory", "time at which the trajectory ended",
       row=OUT_T),
    _f("x_end", "m", "horizontal position at the end", "x at the end of the trajectory",
       row=OUT_X),
    _f(
        "v_end",
        "m s-1",
        "horizontal velocity at the end",
        "horizontal velocity dx/dt at the end of the trajectory",
        row=OUT_V,
    ),
    _f(
        "W_friction",
        "J",
        "work against friction",
        "work done against friction integrated along the trajectory (paper eq. 13)",
        row=OUT_WORK,
    ),
    _f(
        "W_energy",
        "J",
        "mechanical energy lost",
        "initial minus final mechanical energy, kinetic plus potential (paper eq. 19)",
        row=OUT_ENERGY_LOSS,
    ),
    _f(
        "W_linear",
        "J",
        "straight-ramp friction work estimate",
        "mu_k m g |x_end - x0|, the friction work of a straight ramp (paper eq. 1)",
    ),
    _f(
        "W_excess",
        "J",
        "friction work in excess of the straight-ramp estimate",
        "W_friction - W_linear",
    ),
    _f(
        "W_path",
        "J",
        "straight-ramp friction work over the horizontal path travelled",
        "mu_k m g integral of |v| dt (horizontal path length including reversals)",
    ),
    _f(
        "energy_balance_error",
        "J",
        "energy balance error",
        "W_friction - W_energy, or W_friction + W_drag - W_energy in runs with air drag "
        "(all the mechanical energy lost goes to friction and drag), plus, for the adaptive "
        "pairs, the sum of the energy residuals their projection onto that balance removed "
        "after each step (Integrator.project_energy): per-trajectory estimate of the "
        "integration error (the balance error the unprojected integrator would have made, "
        "to first order)",
    ),
    _f(
        "convexity_mean",
        "m-1",
        "mean ramp curvature term f'' over the path travelled",
        "integral of f''(x)|v| dt / integral of |v| dt; f''(x0) where nothing was travelled",
        row=OUT_CONVEXITY,
    ),
    _f(
        "path_length_x",
        "m",
        "horizontal path length travelled",
        "integral of |v| dt: horizontal distance travelled including reversals",
        row=OUT_PATH,
    ),
    _i(
        "n_reversals",
        "int32",
        "number of reversals of direction",
        "number of times the horizontal velocity changed sign",
        row=OUT_NREV,
    ),
    _f(
        "x_lift_off",
        "m",
        "horizontal position of lift-off",
        "x where the normal force reached zero on a one-sided ramp; NaN where no lift-off happened",
        row=OUT_XLIFT,
    ),
    _f(
        "x_lift_off_paper",
        "m",
        "horizontal position where the paper's lift-off criterion first holds (diagnostic)",
        "x where y'' <= -g (the paper's eq. 26) first held: it differs from the contact-force "
        "x_lift_off where d mu_k f' > 1 (sliding up a steep slope: it reports lift-off while the "
        "surface still pushes); NaN where it never held; only when the scene asks for it",
        present="diagnostic",
        row=OUT_XLIFT_PAPER,
    ),
    _i(
        "steps",
        "int64",
        "integrator steps taken",
        "number of integrator steps taken, including partial event steps",
        row=OUT_STEPS,
    ),
    _i(
        "steps_rejected",
        "int64",
        "integrator steps rejected",
        "number of step attempts rejected by the adaptive error control (0 for fixed steps)",
        row=OUT_NREJ,
    ),
    _f(
        "W_friction_error_estimate",
        "J",
        "error estimate of the work against friction",
        "sum over the accepted steps of the embedded pair's local error estimate of W_friction "
        "(adaptive methods only; compare energy_balance_error)",
        present="adaptive",
        row=OUT_WORK_ERROR,
    ),
    _f(
        "W_drag",
        "J",
        "work against air drag",
        "work done against air drag integrated along the trajectory: m times the integral of "
        "(b s'^2 + c s'^3) dt, s' the speed along the path (runs with air drag only; "
        "energy_balance_error is then W_friction + W_drag - W_energy)",
        present="drag",
        row=OUT_DRAG_WORK,
    ),
)

#: outputs that only adaptive methods produce
ADAPTIVE_OUTPUTS = tuple(s.name for s in _OUTPUT_LIST if s.present == "adaptive")
#: outputs computed only when a scene asks for them (Scene.diagnostics)
DIAGNOSTIC_OUTPUTS = tuple(s.name for s in _OUTPUT_LIST if s.present == "diagnostic")
#: outputs that only runs with air drag produce
DRAG_OUTPUTS = tuple(s.name for s in _OUTPUT_LIST if s.present == "drag")


def output_names(adaptive: bool, diagnostics: tuple[str, ...] = (), drag: bool = False) -> tuple[str, ...]:
    """The per-trajectory variables of a run, in dataset order."""
    return tuple(name for name in OUTPUTS
                 if (adaptive or name not in ADAPTIVE_OUTPUTS)
                 and (name in diagnostics or name not in DIAGNOSTIC_OUTPUTS)
                 and (drag or name not in DRAG_OUTPUTS))

OUTPUTS: dict[str, VariableSpec] = {s.name: s for s in _OUTPUT_LIST}

# ----------------------------------------------------------------------------
# per-trajectory outputs of a curve scene (docs/physics.md §5), in dataset
# order: the ramp outputs that keep their meaning, and the curve's own
# ----------------------------------------------------------------------------

_CURVE_OUTPUT_LIST = (
    OUTPUTS["status"],
    OUTPUTS["t_end"],
    _f("s_end", "m", "arc length position at the end", "s at the end of the trajectory"),
    _f("u_end", "m s-1", "speed along the curve at the end",
       "signed speed ds/dt at the end (> 0: towards larger s)"),
    _f("X_end", "m", "horizontal position at the end", "X(s_end)"),
    _f("Y_end", "m", "height at the end", "Y(s_end)"),
    OUTPUTS["W_friction"],
    OUTPUTS["W_energy"],
    _f("W_path", "J", "straight-ramp friction work over the horizontal path travelled",
       "mu_k m g integral of |dX| (horizontal path length including reversals and the turns "
       "of a curve whose X is not monotone)"),
    _f("W_excess", "J", "friction work in excess of the horizontal-path estimate",
       "W_friction - W_path"),
    OUTPUTS["energy_balance_error"],
    _f("curvature_mean", "m-1", "mean signed curvature along the path travelled",
       "integral of kappa |ds| / integral of |ds| (the turning per length); kappa(s0) where "
       "nothing was travelled"),
    _f("path_length", "m", "path length travelled", "integral of |ds|, reversals included"),
    _f("path_length_X", "m", "horizontal path length travelled",
       "integral of |dX|, reversals and vertical tangents included"),
    _f("displacement", "m", "signed arc length travelled", "s_end - s0"),
    _f("nu_min", "N", "smallest normal force along the path",
       "the smallest contact force on the block's side, sampled at the start and at every "
       "step's end (< 0 only on a bead, two_sided)"),
    _f("s_lift_off", "m", "arc length position of lift-off",
       "s where the normal force reached zero on a one-sided curve; NaN where none"),
    _f("X_lift_off", "m", "horizontal position of lift-off", "X(s_lift_off); NaN where none"),
    _f("Y_lift_off", "m", "height of lift-off", "Y(s_lift_off); NaN where none"),
    _i("n_reversals", "int32", "number of reversals of direction",
       "number of times the speed along the curve changed sign"),
    OUTPUTS["steps"],
    OUTPUTS["steps_rejected"],
    OUTPUTS["W_drag"],
)

CURVE_OUTPUTS: dict[str, VariableSpec] = {s.name: s for s in _CURVE_OUTPUT_LIST}
#: sweep axes of a curve scene besides AXES and the curve family's parameters
CURVE_AXES: dict[str, VariableSpec] = {s.name: s for s in (
    VariableSpec("s0", "m", "initial arc length position", "float64", "s at t = 0"),
    VariableSpec("u0", "m s-1", "initial speed along the curve", "float64",
                 "ds/dt at t = 0 (> 0: towards larger s)"),
)}


def curve_output_names(drag: bool = False) -> tuple[str, ...]:
    """The per-trajectory variables of a curve run, in dataset order."""
    return tuple(name for name in CURVE_OUTPUTS if drag or name not in DRAG_OUTPUTS)


# ----------------------------------------------------------------------------
# sweep axes that are not ramp-shape parameters
# ----------------------------------------------------------------------------

_AXIS_LIST = (
    VariableSpec(
        "mu", "1", "friction coefficient", "float64", "sets both mu_k and mu_s to this value"
    ),
    VariableSpec("mu_k", "1", "kinetic friction coefficient", "float64", "Coulomb kinetic friction coefficient"),
    VariableSpec("mu_s", "1", "static friction coefficient", "float64", "Coulomb static friction coefficient"),
    VariableSpec("x0", "m", "initial horizontal position", "float64", "x at t = 0"),
    VariableSpec("v0", "m s-1", "initial horizontal velocity", "float64", "dx/dt at t = 0"),
    VariableSpec("m", "kg", "mass", "float64", "mass of the point"),
    VariableSpec("g", "m s-2", "gravitational acceleration", "float64", "gravitational acceleration"),
    VariableSpec("drag_linear", "s-1", "linear air drag coefficient", "float64",
                 "b in the drag force m (b s' + c s'^2) along the path, s' the speed along the path"),
    VariableSpec("drag_quadratic", "m-1", "quadratic air drag coefficient", "float64",
                 "c in the drag force m (b s' + c s'^2) along the path, s' the speed along the path"),
)

AXES: dict[str, VariableSpec] = {s.name: s for s in _AXIS_LIST}

# ----------------------------------------------------------------------------
# recorded trajectories, over dims TRACE_DIMS = ("traced", "sample")
# ----------------------------------------------------------------------------

_TRACE_LIST = (
    _f("trace_t", "s", "time along recorded trajectory", "sampled time; NaN past the end of the trajectory"),
    _f("trace_x", "m", "horizontal position along recorded trajectory", "sampled x; NaN past the end"),
    _f(
        "trace_v",
        "m s-1",
        "horizontal velocity along recorded trajectory",
        "sampled dx/dt; NaN past the end",
    ),
    _f(
        "trace_W_friction",
        "J",
        "work against friction along recorded trajectory",
        "friction work accumulated up to the sample (paper eq. 13); NaN past the end",
    ),
)

TRAJECTORY_RECORD: dict[str, VariableSpec] = {s.name: s for s in _TRACE_LIST}

#: recorded trajectories of a curve scene (same dims; trace_<row> for each row
#: of core/curve_trace.TRACE_ROWS, in that order; trace_W_drag only with drag)
_CURVE_TRACE_LIST = (
    TRAJECTORY_RECORD["trace_t"],
    _f("trace_s", "m", "arc length position along recorded trajectory",
       "sampled position parameter, as s_end (the arc length, or a curve's own parameter p: "
       "a spline's chord-length t); NaN past the end"),
    _f("trace_u", "m s-1", "speed along the curve along recorded trajectory",
       "sampled ds/dt (signed, > 0 towards larger s); NaN past the end"),
    _f("trace_X", "m", "horizontal position along recorded trajectory", "sampled X(s); NaN past the end"),
    _f("trace_Y", "m", "height along recorded trajectory", "sampled Y(s); NaN past the end"),
    TRAJECTORY_RECORD["trace_W_friction"],
    _f("trace_nu", "N", "normal force along recorded trajectory",
       "m times the normal force per unit mass on the block's side at the sample; NaN past the end"),
    _f("trace_W_drag", "J", "work against air drag along recorded trajectory",
       "drag work accumulated up to the sample; NaN past the end", present="drag"),
)
CURVE_RECORD: dict[str, VariableSpec] = {s.name: s for s in _CURVE_TRACE_LIST}


def curve_trace_names(drag: bool = False) -> tuple[str, ...]:
    """The trace variables of a curve scene, in the rows' order."""
    return tuple(name for name in CURVE_RECORD if drag or name != "trace_W_drag")

# ----------------------------------------------------------------------------
# shape optimisation (rampwork.shapes, rampwork.optimise): per candidate of a
# population and per generation of an optimisation
# ----------------------------------------------------------------------------

def _b(name, long_name, description):
    return VariableSpec(name, "1", long_name, "bool", description)


_OPTIMISE_LIST = (
    _f("speed_end", "m s-1", "speed at the end of the trajectory",
       "speed along the ramp when the trajectory ended (at B where it arrived)"),
    _b("arrived", "reached B", "the trajectory exited the ramp at B"),
    _b("stayed_on", "stayed in contact", "the block never left the ramp (no lift-off)"),
    _b("inside", "inside the allowed region", "the candidate's ramp stays within the shape's y bounds"),
    _b("admissible", "admissible candidate",
       "a valid shape through A and B that kept the block in contact until it arrived at B"),
    _f("shortfall", "1", "share of the way to B not covered",
       "|x_B - x_end| / |x_B - x_A| where the block did not arrive, 0 where it did"),
    _f("coefficients", "m", "shape parameters of the candidate", "the candidate's K shape parameters"),
    _f("best_parameters", "m", "best shape parameters so far", "the best feasible candidate after each generation"),
    _f("best_objective", "1", "best objective so far",
       "the objective of best_parameters (its variable's units; see the attribute objective)"),
    _f("objective_spread", "1", "spread of the population's objectives",
       "standard deviation of the population's penalised objectives (scipy's convergence measure)"),
    _i("n_feasible", "int32", "feasible candidates in the population",
       "candidates that met every constraint, after the generation"),
    _i("evaluations", "int64", "candidate evaluations so far", "trajectories run, cumulative"),
    _f("objective", "1", "objective of the final candidate",
       "the objective variable of each candidate of the final population (NaN where it has no meaning)"),
    _f("penalised", "1", "penalised objective (minimised)",
       "what the optimiser minimised: +-objective where feasible, penalty * (1 + violation) otherwise"),
    _b("feasible", "met every constraint", "the candidate met every constraint of the optimisation"),
)

OPTIMISE_OUTPUTS: dict[str, VariableSpec] = {s.name: s for s in _OPTIMISE_LIST}


# ----------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------


def axis_spec(name: str, ramp_parameters: Iterable[Any] = ()) -> VariableSpec:
    """The spec of sweep axis ``name``: one of AXES or a ramp shape parameter.

    ``ramp_parameters`` are the ramp family's parameter specs: any objects with
    attributes ``name``, ``units``, ``long_name`` (and optionally
    ``description``).
    """
    if name in AXES:
        return AXES[name]
    params = list(ramp_parameters)
    for p in params:
        if p.name == name:
            return VariableSpec(
                name=p.name,
                units=str(p.units),
                long_name=str(p.long_name),
                dtype="float64",
                description=str(getattr(p, "description", "") or f"ramp shape parameter {p.name}"),
            )
    allowed = list(AXES) + [p.name for p in params]
    raise ConfigError(f"axis {name!r}", f"unknown axis; allowed: {', '.join(allowed)}")


def traced_attrs(name: str, ramp_parameters: Iterable[Any] = ()) -> dict[str, Any]:
    """CF attributes of the trace coordinate ``traced_<name>``: sweep axis
    ``name``'s value for each recorded trajectory, in the axis's units."""
    spec = axis_spec(name, ramp_parameters)
    return {"units": spec.units, "long_name": f"{spec.long_name} of the traced trajectory"}


def spec_attrs(spec: VariableSpec) -> dict[str, Any]:
    """CF attributes of one spec: units, long_name, comment (+ flags for status)."""
    attrs: dict[str, Any] = {"units": spec.units, "long_name": spec.long_name}
    if spec.name == "status":
        attrs["flag_values"] = STATUS_FLAG_VALUES.copy()
        attrs["flag_meanings"] = STATUS_FLAG_MEANINGS
        attrs["flag_descriptions"] = STATUS_FLAG_DESCRIPTIONS
    if spec.description:
        attrs["comment"] = spec.description
    return attrs


def _lookup(name: str, ramp_parameters: Iterable[Any] = ()) -> VariableSpec:
    if name in OUTPUTS:
        return OUTPUTS[name]
    if name in CURVE_OUTPUTS:
        return CURVE_OUTPUTS[name]
    if name in CURVE_AXES:
        return CURVE_AXES[name]
    if name in TRAJECTORY_RECORD:
        return TRAJECTORY_RECORD[name]
    if name in CURVE_RECORD:
        return CURVE_RECORD[name]
    try:
        return axis_spec(name, ramp_parameters)
    except ConfigError:
        params = [p.name for p in ramp_parameters]
        allowed = list(OUTPUTS) + list(TRAJECTORY_RECORD) + list(AXES) + params
        raise ConfigError(
            f"variable {name!r}", f"unknown variable; allowed: {', '.join(allowed)}"
        ) from None


def output_attrs(name: str, ramp_parameters: Iterable[Any] = ()) -> dict[str, Any]:
    """CF attributes for variable ``name`` (an output, trace variable or axis)."""
    return spec_attrs(_lookup(name, list(ramp_parameters)))


def empty_output(name: str, shape) -> np.ndarray:
    """An array for output/trace ``name`` filled with its "not computed" value.

    Floats: NaN; ``status``: NOT_RUN (0); other integers: 0.
    """
    spec = _lookup(name)
    fill = spec.fill_value if spec.fill_value is not None else 0
    return np.full(shape, fill, dtype=spec.np_dtype)


# ----------------------------------------------------------------------------
# global attributes
# ----------------------------------------------------------------------------

_ATTR_NAME_BAD = re.compile(r"[^A-Za-z0-9_]")


def _attr_name(key: Any) -> str:
    name = _ATTR_NAME_BAD.sub("_", str(key))
    if not name or not name[0].isalpha():
        name = "a_" + name
    return name


def _attr_value(value: Any) -> Any:
    """A netCDF-legal attribute value, or None to omit it.

    str stays; bool -> int 0/1; numbers stay (numpy scalars keep their type); numeric
    sequences/arrays -> numpy arrays (bool arrays -> int8); anything else -> str.
    """
    if value is None:
        return None
    if isinstance(value, (bool, np.bool_)):
        return int(bool(value))
    if isinstance(value, str):
        return value
    if isinstance(value, (np.integer, np.floating)):
        return value  # keep the numpy type (e.g. an int8 valid_min)
    if isinstance(value, int):
        return value if -(2**63) <= value < 2**63 else str(value)
    if isinstance(value, float):
        return value
    if isinstance(value, np.ndarray) or (
        isinstance(value, (list, tuple)) and len(value) > 0
    ):
        arr = np.asarray(value)
        if arr.dtype == bool:
            return arr.astype(np.int8).ravel()
        if arr.dtype.kind in "iuf":
            return arr.ravel()
        if isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value):
            return ", ".join(value)
        return str(value if not isinstance(value, np.ndarray) else value.tolist())
    return str(value)


def _flatten(prefix: str, value: Any, out: dict[str, Any]) -> None:
    if isinstance(value, Mapping):
        for k, v in value.items():
            _flatten(f"{prefix}_{k}" if prefix else str(k), v, out)
        return
    v = _attr_value(value)
    if v is not None:
        out[_attr_name(prefix)] = v


def netcdf_attrs(attrs: Mapping[str, Any]) -> dict[str, Any]:
    """Flatten ``attrs`` to netCDF-legal names and values.

    Nested dicts become ``outer_inner`` keys; bool -> 0/1; None -> omitted;
    numeric lists -> numpy arrays; other objects -> str.
    """
    out: dict[str, Any] = {}
    for k, v in attrs.items():
        _flatten(str(k), v, out)
    return out


def utc_timestamp() -> str:
    return _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def global_attrs(
    title: str,
    scene_text: str,
    history_line: str,
    extra: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """Global attributes of a rampwork dataset.

    ``scene_text`` is the scene as TOML text (stored as ``rampwork_scene``);
    ``extra`` settings (e.g. integrator settings, possibly nested) are
    flattened by :func:`netcdf_attrs`. Extra keys may not replace the
    standard attributes.
    """
    from rampwork._version import __version__

    attrs: dict[str, Any] = {
        "Conventions": CONVENTIONS,
        "title": str(title),
        "source": f"rampwork {__version__}",
        "history": f"{utc_timestamp()}: {history_line}" if history_line else utc_timestamp(),
        "rampwork_scene": str(scene_text),
    }
    for k, v in netcdf_attrs(extra or {}).items():
        if k in attrs:
            raise ValueError(f"global_attrs: extra attribute {k!r} would replace a standard one")
        attrs[k] = v
    return attrs


def _check_registry() -> None:  # import-time sanity check of the tables above
    for table in (OUTPUTS, AXES, TRAJECTORY_RECORD, CURVE_OUTPUTS, CURVE_AXES, CURVE_RECORD,
                  OPTIMISE_OUTPUTS):
        for key, spec in table.items():
            assert key == spec.name and spec.units and spec.long_name, spec
            np.dtype(spec.dtype)
            if spec.np_dtype.kind == "f":
                assert spec.fill_value is None or math.isnan(spec.fill_value), spec


_check_registry()
