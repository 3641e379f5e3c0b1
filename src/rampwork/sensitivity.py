"""Variance-based (Sobol') sensitivity indices of a study's outputs.

:func:`sobol_indices` says which axes of a design drive a per-trajectory
output of a scene, alone and through interactions: rampwork draws the design
from the axes' ranges, runs it as one ``Sweep.cases`` through
:func:`rampwork.simulate`, checks every trajectory ended cleanly and returns
the indices as a small labelled dataset.  :func:`sobol_indices_of` runs any
vectorised model through the same path (sample -> evaluate -> check ->
analyse -> dataset); :mod:`rampwork.ishigami` is the check with known answers.

The statistics are SALib's: :func:`SALib.sample.sobol.sample` draws Saltelli's
design on a scrambled, seeded Sobol' sequence (``n (D + 2)`` rows for D axes,
``n (2 D + 2)`` with second-order indices); :func:`SALib.analyze.sobol.analyze`
estimates S1, ST (Saltelli et al. 2010; Jansen) and S2 (Saltelli 2002).
``*_conf`` is the half-width ``z std`` of ``num_resamples`` bootstrap
estimates, ``z`` the normal quantile of ``conf_level`` (default 95 %).  Axes
are uniform over their range, or log-uniform (``log=``); the indices refer to
those distributions.

Saltelli's estimators need the output of every row of the design, so a
trajectory that did not end cleanly cannot be left out.  A trajectory counts
when it ended ``stuck`` or ``exited`` (``accept=``) with a finite output;
any other (``lifted_off``, ``timeout``, ``diverged``, a NaN output) raises
:class:`SensitivityError` naming how many of each, before any estimate;
``fill=`` puts a number in their place instead (recorded in the attributes).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
import xarray as xr

from . import schema, validate
from .core.status import STATUS_NAMES
from .designs import DesignAxis
from .errors import ConfigError
from .plan import plan_run
from .runner import scene_text, simulate
from .scene import Record, Scene, Sweep

__all__ = ["sobol_indices", "sobol_indices_of", "SensitivityError", "bar_chart", "ACCEPT",
           "CONF_LEVEL", "NUM_RESAMPLES"]

SAMPLER = "SALib.sample.sobol.sample: Saltelli's scheme on a scrambled Sobol' sequence"
ESTIMATOR = "SALib.analyze.sobol.analyze: S1, ST (Saltelli et al. 2010), S2 (Saltelli 2002)"
#: base sample sizes allowed: powers of two (the Sobol' sequence is balanced for those)
N_RANGE = (8, 1 << 22)
CONF_LEVEL = 0.95
NUM_RESAMPLES = 1000
#: end statuses whose output counts by default: the trajectory ended as the physics says
ACCEPT = ("stuck", "exited")
#: up to this many axes, every corner of the ranges' box is checked as a sweep before sampling
MAX_CORNER_AXES = 10
_CODES = {name: code for code, name in STATUS_NAMES.items()}
#: when an optional output is computed (schema.VariableSpec.present), in words
_PRESENT = {"adaptive": "with an adaptive method, dopri5 or dop853", "drag": "with air drag",
            "diagnostic": "where the scene asks for it in Scene.diagnostics"}


class SensitivityError(ValueError):
    """The outputs cannot give Sobol' indices: flagged trajectories, values
    that are not finite, or an output with no variance.  ``counts``: what was
    found (status name or ``"non-finite"`` -> number of design rows)."""

    def __init__(self, message: str, counts: Mapping[str, int] | None = None):
        super().__init__(message)
        self.counts = dict(counts or {})

    def __reduce__(self):
        return type(self), (str(self), self.counts)


# ------------------------------------------------------------------------------
# the design: ranges -> SALib's sample -> columns
# ------------------------------------------------------------------------------
def _check_ranges(ranges, log) -> tuple[tuple[str, ...], np.ndarray, np.ndarray, np.ndarray]:
    """(names, low, high, is_log) of validated ranges."""
    if not isinstance(ranges, Mapping) or not ranges:
        raise ConfigError("ranges", f"expected a mapping name -> (low, high) with at least one "
                          f"axis, got {ranges!r}")
    if isinstance(log, str) or not isinstance(log, (tuple, list, set, frozenset)):
        raise ConfigError("log", f"expected a list of axis names, got {log!r}")
    unknown = [name for name in log if name not in ranges]
    if unknown:
        raise ConfigError("log", f"names not among the ranges: {', '.join(map(repr, unknown))}; "
                          f"ranges: {', '.join(map(str, ranges))}")
    names, low, high = [], [], []
    for name, bounds in ranges.items():
        if not isinstance(name, str) or not name:
            raise ConfigError("ranges", f"axis names must be non-empty strings, got {name!r}")
        where = f"ranges.{name}"
        if not isinstance(bounds, (tuple, list)) or len(bounds) != 2:
            raise ConfigError(where, f"expected (low, high), got {bounds!r}")
        lo, hi = validate.real(where, bounds[0]), validate.real(where, bounds[1])
        if not lo < hi:
            raise ConfigError(where, f"low must be < high (an axis without spread has no "
                              f"variance to share), got ({lo!r}, {hi!r})")
        if name in log and lo <= 0:
            raise ConfigError(where, f"log-uniform needs low > 0, got {lo!r}")
        names.append(name), low.append(lo), high.append(hi)
    return tuple(names), np.array(low), np.array(high), np.array([n in log for n in names])


def _check_n(n) -> int:
    n = validate.integer("n", n, *N_RANGE)
    if n & (n - 1):
        below = 1 << (n.bit_length() - 1)
        raise ConfigError("n", f"must be a power of 2 (Saltelli's design on a Sobol' sequence is "
                          f"balanced only for those), got {n}; e.g. {below} or {2 * below}")
    return n


def _scale(unit: np.ndarray, low, high, is_log) -> np.ndarray:
    """Points of the unit cube mapped onto the ranges, as a design's axes map
    them (log-uniform axes: in their logarithm)."""
    return np.column_stack([
        DesignAxis(f"axis {j}", lo, hi, "loguniform" if g else "uniform").values(
            np.ascontiguousarray(unit[:, j]))
        for j, (lo, hi, g) in enumerate(zip(low, high, is_log))])


def _salib():
    """SALib's Sobol' sampler and estimator modules (an optional dependency)."""
    try:
        from SALib.analyze import sobol as estimator
        from SALib.sample import sobol as sampler
    except ImportError:
        raise ModuleNotFoundError("Sobol' indices need SALib: pip install 'rampwork[sensitivity]'"
                                  " (or SALib)") from None
    return sampler, estimator


def _bootstrap_seed(seed: int) -> int:
    """SALib's analyze takes ``seed=0`` for "unseeded": derive a non-zero one."""
    return int(np.random.SeedSequence([seed, 1]).generate_state(1)[0]) + 1


# ------------------------------------------------------------------------------
# the one code path: sample -> evaluate -> check -> analyse -> dataset
# ------------------------------------------------------------------------------
def sobol_indices_of(model: Callable[[dict[str, np.ndarray]], np.ndarray], ranges: Mapping,
                     *, n: int = 1024, seed: int = 0, log=(), second_order: bool = False,
                     conf_level: float = CONF_LEVEL, num_resamples: int = NUM_RESAMPLES,
                     name: str = "y", units: str = "1", parameter_units: Mapping | None = None,
                     keep_runs: bool = False, title: str | None = None) -> xr.Dataset:
    """Sobol' indices of a vectorised ``model(columns) -> values``.

    ``ranges``: axis name -> (low, high); ``columns`` maps every axis to a
    1-D array of the design's values (one row per model run), and the model
    returns one finite value per row.  ``n``: SALib's base sample size, a
    power of 2 (the model runs ``n (D + 2)`` rows, ``n (2 D + 2)`` with
    ``second_order``).  ``seed`` seeds the design's scrambling and the
    bootstrap.  ``log``: axes drawn log-uniformly.  ``name``, ``units``,
    ``parameter_units`` label the result; ``keep_runs`` adds the design and
    the values along a ``case`` dimension.

    Returns a Dataset over ``parameter`` (and ``parameter2`` for S2, mirrored:
    S2[i, j] = S2[j, i], NaN on the diagonal) with S1, S1_conf, ST, ST_conf
    (and S2, S2_conf); ``*_conf`` is the half-width of the ``conf_level``
    bootstrap confidence interval.
    """
    names, low, high, is_log = _check_ranges(ranges, log)
    n = _check_n(n)
    seed = validate.integer("seed", seed, 0)
    if not isinstance(second_order, (bool, np.bool_)):
        raise ConfigError("second_order", f"expected true or false, got {second_order!r}")
    if second_order and len(names) < 2:
        raise ConfigError("second_order", "second-order indices need at least two axes")
    conf_level = validate.real("conf_level", conf_level)
    if not 0 < conf_level < 1:
        raise ConfigError("conf_level", f"must be between 0 and 1 (e.g. 0.95), got {conf_level!r}")
    num_resamples = validate.integer("num_resamples", num_resamples, 10, 100_000)
    if not callable(model):
        raise ConfigError("model", f"expected a function columns -> values, got {model!r}")
    parameter_units = dict(parameter_units or {})

    sampler, estimator = _salib()
    problem = {"num_vars": len(names), "names": list(names), "bounds": [[0.0, 1.0]] * len(names)}
    unit = sampler.sample(problem, n, calc_second_order=bool(second_order), scramble=True, seed=seed)
    design = _scale(unit, low, high, is_log)
    columns = {axis: design[:, j].copy() for j, axis in enumerate(names)}
    runs = design.shape[0]

    values = np.asarray(model(columns))
    if values.shape != (runs,) or values.dtype.kind not in "biuf":
        raise ConfigError("model", f"returned {values.dtype} values of shape {values.shape}; "
                          f"expected ({runs},) numbers: one per row of the design")
    values = values.astype(float)
    bad = ~np.isfinite(values)
    if bad.any():
        raise SensitivityError(f"{int(bad.sum())} of {runs} values of {name} are not finite; "
                               "Saltelli's estimators need every row of the design",
                               {"non-finite": int(bad.sum())})
    if np.ptp(values) == 0:
        raise SensitivityError(f"{name} is {values[0]!r} in every one of the {runs} runs: a constant "
                               "has no variance to share, and its Sobol' indices are undefined")
    result = estimator.analyze(problem, values, calc_second_order=bool(second_order),
                               num_resamples=num_resamples, conf_level=conf_level,
                               seed=_bootstrap_seed(seed))

    ds = xr.Dataset(coords={
        "parameter": ("parameter", list(names), {"long_name": "design axis"}),
        "parameter_units": ("parameter", [parameter_units.get(a, "") for a in names],
                            {"long_name": "units of the design axis"}),
        "low": ("parameter", low, {"long_name": "lower end of the axis' range"}),
        "high": ("parameter", high, {"long_name": "upper end of the axis' range"}),
        "distribution": ("parameter", ["log-uniform" if g else "uniform" for g in is_log],
                         {"long_name": "distribution of the axis over its range"}),
    })
    ci = f"half-width of the {conf_level:.0%} bootstrap confidence interval ({num_resamples} resamples)"
    for key, long_name, comment in (
            ("S1", "first-order Sobol' index", f"share of the variance of {name} due to the axis alone"),
            ("ST", "total Sobol' index", f"share of the variance of {name} due to the axis alone "
                                         "and through its interactions with the others")):
        ds[key] = ("parameter", np.asarray(result[key]), dict(units="1", long_name=long_name,
                                                              comment=comment))
        ds[f"{key}_conf"] = ("parameter", np.asarray(result[f"{key}_conf"]),
                             dict(units="1", long_name=f"{long_name}: {ci}"))
    if second_order:
        ds = ds.assign_coords(parameter2=("parameter2", list(names), {"long_name": "design axis"}))
        for key in ("S2", "S2_conf"):
            upper = np.triu(np.nan_to_num(np.asarray(result[key], dtype=float)), 1)
            both = upper + upper.T
            np.fill_diagonal(both, np.nan)
            long_name = "second-order Sobol' index" + (f": {ci}" if key == "S2_conf" else "")
            ds[key] = (("parameter", "parameter2"), both, dict(
                units="1", long_name=long_name,
                comment=f"share of the variance of {name} due to the interaction of the two axes alone"))
    if keep_runs:
        ds = ds.assign_coords({axis: ("case", columns[axis], {"units": parameter_units.get(axis, ""),
                                                              "long_name": f"design value of {axis}"})
                               for axis in names})
        ds[name] = ("case", values, {"units": units, "long_name": f"{name}: the values analysed"})
    from ._version import __version__

    def schema_units(axis):
        return "" if parameter_units.get(axis, "1") in ("", "1") else parameter_units[axis]

    ds.attrs = schema.netcdf_attrs({
        "Conventions": schema.CONVENTIONS,
        "title": title or f"Sobol' indices of {name}",
        "source": f"rampwork {__version__}",
        "history": f"{schema.utc_timestamp()}: rampwork.sensitivity: Sobol' indices of {name} "
                   f"from {runs} model runs",
        "output": name, "output_units": units,
        "output_mean": float(values.mean()), "output_variance": float(values.var()),
        "design": "; ".join(f"{a}: {d} [{lo:g}, {hi:g}] {schema_units(a)}".rstrip()
                            for a, d, lo, hi in zip(names, ds["distribution"].values, low, high)),
        "sampler": SAMPLER, "estimator": ESTIMATOR, "n": n, "seed": seed,
        "n_runs": runs, "second_order": bool(second_order), "conf_level": conf_level,
        "num_resamples": num_resamples,
    })
    return ds


# ------------------------------------------------------------------------------
# a scene's outputs
# ------------------------------------------------------------------------------
def _corners(low, high, names) -> dict[str, np.ndarray]:
    """Every corner of the ranges' box (only the two ends per axis beyond MAX_CORNER_AXES)."""
    if len(names) > MAX_CORNER_AXES:
        return {a: np.array([lo, hi]) for a, lo, hi in zip(names, low, high)}
    mesh = np.meshgrid(*[(lo, hi) for lo, hi in zip(low, high)], indexing="ij")
    return {a: m.ravel() for a, m in zip(names, mesh)}


def sobol_indices(scene: Scene, output: str, ranges: Mapping, *, n: int = 1024, seed: int = 0,
                  log=(), second_order: bool = False, accept=ACCEPT, fill: float | None = None,
                  conf_level: float = CONF_LEVEL, num_resamples: int = NUM_RESAMPLES,
                  threads: int | None = None, keep_runs: bool = False) -> xr.Dataset:
    """Sobol' indices of a per-trajectory ``output`` of ``scene`` (a variable
    of :data:`rampwork.schema.OUTPUTS`, e.g. ``"W_excess"``) with respect to
    the sweep axes in ``ranges`` (name -> (low, high); any name a sweep of
    the scene may use: mu, x0, v0, the ramp's parameters, ...).

    rampwork draws SALib's design (see :func:`sobol_indices_of` for ``n``,
    ``seed``, ``log``, ``second_order``, ``conf_level``, ``num_resamples``)
    and runs it as ``Sweep.cases`` through :func:`rampwork.simulate`
    (``threads``).  A trajectory counts where its status is in ``accept``
    (default ``stuck``, ``exited``) and its output is finite; any other
    raises :class:`SensitivityError` naming how many of each status, unless
    ``fill`` gives a value to put in their place.  ``keep_runs`` adds the
    design and every per-trajectory variable of the run along ``case`` (as
    simulate returns them: flagged values before any ``fill``).  Ranges
    whose ends the scene cannot run (x0 off the domain, an invalid ramp, ...)
    are refused with a :class:`~rampwork.errors.ConfigError` before any run.
    """
    if not isinstance(scene, Scene):
        raise ConfigError("scene", f"expected a rampwork.Scene, got {type(scene).__name__}")
    names, low, high, _ = _check_ranges(ranges, log)
    allowed = scene.axis_names
    for axis in names:
        if axis not in allowed:
            raise ConfigError(f"ranges.{axis}", f"unknown axis; allowed: {', '.join(allowed)}")
    scene = scene.replace(record=Record())  # no traces: only the output is wanted
    try:  # every corner of the box runs, before any sample is drawn
        plan = plan_run(scene, Sweep.cases(**_corners(low, high, names)))
    except ConfigError as error:
        where = error.where
        raise ConfigError(where.replace("sweep.", "ranges.", 1) if where.startswith("sweep.")
                          else where, error.problem) from None
    if output not in schema.OUTPUTS or schema.OUTPUTS[output].np_dtype.kind not in "iuf":
        raise ConfigError("output", f"unknown output {output!r}; allowed: per-trajectory outputs "
                          f"{', '.join(k for k in plan.output_names if k != 'status')}")
    if output == "status":
        raise ConfigError("output", "status is a category (how a trajectory ended), not a quantity")
    if output not in plan.output_names:
        raise ConfigError("output", f"{output!r} is not computed in this run (only "
                          f"{_PRESENT[schema.OUTPUTS[output].present]}); this run has "
                          f"{', '.join(k for k in plan.output_names if k != 'status')}")
    if isinstance(accept, str) or not isinstance(accept, (tuple, list, set, frozenset)):
        raise ConfigError("accept", f"expected a list of end statuses, got {accept!r}")
    if not accept:
        raise ConfigError("accept", "name at least one end status whose trajectories count")
    for k, status in enumerate(accept):
        validate.choice(f"accept[{k}]", status, [s for s in _CODES if s != "not_run"])
    fill = None if fill is None else validate.real("fill", fill)
    spec = schema.OUTPUTS[output]
    parameter_units = {a: schema.axis_spec(a, scene.ramp.spec.parameters).units for a in names}
    counted = np.array([_CODES[s] for s in accept], dtype=np.int8)
    runs = {}

    def model(columns):
        ds = simulate(scene, Sweep.cases(**columns), threads=threads)
        status, values = ds["status"].values, ds[output].values.astype(float)
        refused = ~np.isin(status, counted)
        flagged = refused | ~np.isfinite(values)
        counts = {STATUS_NAMES[int(c)]: int((refused & (status == c)).sum()) for c in np.unique(status)}
        counts["non-finite"] = int((flagged & ~refused).sum())
        counts = {s: k for s, k in counts.items() if k}
        runs.update(dataset=ds, flagged=int(flagged.sum()))
        if flagged.any() and fill is None:
            first = int(np.argmax(flagged))
            where = ", ".join(f"{a} = {columns[a][first]:.6g}" for a in names)
            raise SensitivityError(
                f"{int(flagged.sum())} of {status.size} trajectories cannot count towards the "
                f"indices of {output}: " + ", ".join(
                    f"{k} {'with a non-finite ' + output if s == 'non-finite' else s}"
                    for s, k in counts.items())
                + f" (end statuses that count: {', '.join(accept)}); the first at {where}.  "
                "Saltelli's estimators need every row of the design: narrow the ranges, pass "
                "accept=(...) to count those statuses, or fill=VALUE to replace their values",
                counts)
        return np.where(flagged, fill if fill is not None else 0.0, values)

    result = sobol_indices_of(model, ranges, n=n, seed=seed, log=log, second_order=second_order,
                              conf_level=conf_level, num_resamples=num_resamples, name=output,
                              units=spec.units, parameter_units=parameter_units,
                              keep_runs=keep_runs,
                              title=f"Sobol' indices of {output} ({spec.long_name}): {scene.title}")
    ds = runs["dataset"]
    if keep_runs:  # every per-trajectory variable of the run, as simulate gives it
        result = result.drop_vars(output).assign({k: ("case", v.values, v.attrs)
                                                  for k, v in ds.data_vars.items()})
    statuses = {STATUS_NAMES[int(c)]: int((ds["status"] == c).sum())
                for c in np.unique(ds["status"].values)}
    result.attrs.update(schema.netcdf_attrs({
        "rampwork_scene": scene_text(scene, Sweep.single()),
        "output_long_name": spec.long_name,
        "accept": ", ".join(accept),
        "status_counts": ", ".join(f"{s}: {k}" for s, k in statuses.items()),
        "n_filled": runs["flagged"] if fill is not None else 0,
        "fill_value": fill,
        "ramp_family": scene.ramp.family,
        "integrator": scene.integrator.describe(),
        "compile_time_s": float(ds.attrs["compile_time_s"]),
        "run_time_s": float(ds.attrs["run_time_s"]),
    }))
    return result


# ------------------------------------------------------------------------------
# the figure
# ------------------------------------------------------------------------------
def bar_chart(ds: xr.Dataset, ax=None, title: str | None = None):
    """S1 and ST of a :func:`sobol_indices` dataset as bars with their
    confidence intervals (error bars); a new figure where ``ax`` is None.
    Returns the axes."""
    from .plotting import new_figure, pyplot

    if ax is None:
        _, axes = new_figure()
        ax = axes[0, 0]
    names = [str(p) for p in ds["parameter"].values]
    x = np.arange(len(names))
    width = 0.38
    colours = pyplot().get_cmap("viridis")
    looks = (("S1", "first order $S_1$: alone", colours(0.2), ""),
             ("ST", "total $S_T$: alone and with others", colours(0.75), "//"))
    for k, (key, text, colour, hatch) in enumerate(looks):
        ax.bar(x + (k - 0.5) * width, ds[key].values, width, yerr=ds[f"{key}_conf"].values,
               capsize=4, color=colour, hatch=hatch, edgecolor="0.15", label=text,
               error_kw=dict(elinewidth=1.1, ecolor="0.1"))
    ax.set_xticks(x, names)
    ax.axhline(0.0, color="0.3", lw=0.8)
    ax.set_ylim(min(0.0, float((ds["S1"] - ds["S1_conf"]).min()) - 0.02),
                max(1.0, float((ds["ST"] + ds["ST_conf"]).max()) + 0.05))
    ax.set_ylabel(f"share of the variance of {ds.attrs.get('output', 'the output')}")
    ax.set_xlabel(f"design axis (error bars: {float(ds.attrs.get('conf_level', 0.95)):.0%} "
                  "confidence intervals)")
    ax.grid(axis="x", visible=False)
    ax.legend(loc="upper right")
    if title:
        ax.set_title(title)
    return ax
