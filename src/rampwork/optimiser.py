"""Shape optimisation on the batch engine: ``rw.optimise(scene, shape, ...)``.

scipy's differential evolution (``DifferentialEvolutionSolver``, driven one
generation at a time, ``vectorized=True``): each generation is ONE call of
``shape.evaluate`` (one batched kernel run over the population).  A
candidate that misses a constraint (or whose shape is not admissible) gets
the finite penalty ``penalty * (1 + violation)``, worse than every feasible
one, never NaN.  A checkpoint written every generation (atomically) lets an
interrupted optimisation resume to the identical result (docs/optimise.md).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr
from scipy.optimize import minimize
from scipy.optimize._differentialevolution import DifferentialEvolutionSolver

from . import validate
from .core.status import LIFTED_OFF
from .errors import ConfigError
from .schema import OPTIMISE_OUTPUTS, global_attrs, spec_attrs
from .shapes import ChordModes

__all__ = ["CONSTRAINTS", "OBJECTIVES", "OptimiseSettings", "SENSES", "optimise", "penalised"]

#: objective variable -> its units (the shape's ``evaluate`` returns each)
OBJECTIVES = {"t_end": "s", "W_friction": "J", "W_excess": "J", "speed_end": "m s-1"}
SENSES = ("minimise", "maximise")
CONSTRAINTS = ("arrive", "stay_on")
INITS = ("latinhypercube", "sobol", "halton", "random")
#: L-BFGS-B iterations of the polish at most (each one or a few batched calls of 2K + 1)
POLISH_MAXITER = 200
#: what a checkpoint file holds, by version (a file of another version is refused)
CHECKPOINT_VERSION = 1


@dataclass(frozen=True)
class OptimiseSettings:
    """What to optimise and how; validates itself (a bad value raises
    :class:`~rampwork.errors.ConfigError` naming it before any work).

    ``objective`` (:data:`OBJECTIVES`), ``sense`` (``minimise`` or
    ``maximise``), ``constraints`` (a subset of ``arrive``: the block must
    reach B; ``stay_on``: no lift-off).  ``seed``, ``popsize`` (candidates
    per parameter: S = popsize * K), ``maxiter`` (generations), ``tol`` and
    ``atol`` (stop once the std of the population's penalised objectives
    <= atol + tol * |their mean|), ``mutation`` (F, or its dither range),
    ``recombination`` and ``init``: scipy's differential evolution's.
    ``penalty``: the value of a candidate that misses a constraint, times
    (1 + its violation); it must exceed every feasible |objective|.
    ``polish``: refine the best candidate by L-BFGS-B with central
    differences of step ``polish_step`` (share of each bound's width), each
    gradient ONE batched call of 2K + 1 candidates.  ``x0``: a candidate
    (K numbers, inside the shape's bounds) that replaces one member of the
    first population, e.g. the optimum of a smaller K padded with zeros.
    ``evaluator``: how a ChordModes population is run (``kernel``, the
    default, or ``quadrature``: see ``ChordModes.evaluate``)."""

    objective: str = "t_end"
    sense: str = "minimise"
    constraints: tuple[str, ...] = ("arrive", "stay_on")
    seed: int = 0
    popsize: int = 15
    maxiter: int = 100
    tol: float = 1e-6
    atol: float = 0.0
    mutation: float | tuple[float, float] = (0.5, 1.0)
    recombination: float = 0.7
    init: str = "latinhypercube"
    penalty: float = 1e6
    polish: bool = False
    polish_step: float = 1e-5
    x0: tuple[float, ...] | None = None
    evaluator: str = "kernel"

    def __post_init__(self):
        validate.choice("optimise.evaluator", self.evaluator, ("kernel", "quadrature"))
        validate.choice("optimise.objective", self.objective, OBJECTIVES)
        validate.choice("optimise.sense", self.sense, SENSES)
        constraints = self.constraints
        if isinstance(constraints, str) or not isinstance(constraints, (tuple, list)):
            raise ConfigError("optimise.constraints", f"expected a list of names ({', '.join(CONSTRAINTS)}), "
                              f"got {constraints!r}")
        for k, name in enumerate(constraints):
            validate.choice(f"optimise.constraints[{k}]", name, CONSTRAINTS)
        object.__setattr__(self, "constraints", tuple(dict.fromkeys(constraints)))
        object.__setattr__(self, "seed", validate.integer("optimise.seed", self.seed, 0, 2**63 - 1))
        object.__setattr__(self, "popsize", validate.integer("optimise.popsize", self.popsize, 2, 10_000))
        object.__setattr__(self, "maxiter", validate.integer("optimise.maxiter", self.maxiter, 1, 10**7))
        object.__setattr__(self, "tol", validate.nonnegative("optimise.tol", self.tol))
        object.__setattr__(self, "atol", validate.nonnegative("optimise.atol", self.atol))
        mutation = self.mutation
        if isinstance(mutation, (tuple, list)):
            if len(mutation) != 2:
                raise ConfigError("optimise.mutation", f"expected F or a dither range [low, high], got {mutation!r}")
            low, high = (validate.real(f"optimise.mutation[{i}]", v) for i, v in enumerate(mutation))
            if not 0 <= low <= high < 2:
                raise ConfigError("optimise.mutation", f"a dither range needs 0 <= low <= high < 2, got "
                                  f"[{low!r}, {high!r}]")
            mutation = (low, high)
        else:
            mutation = validate.real("optimise.mutation", mutation)
            if not 0 <= mutation < 2:
                raise ConfigError("optimise.mutation", f"must be in [0, 2), got {mutation!r}")
        object.__setattr__(self, "mutation", mutation)
        recombination = validate.real("optimise.recombination", self.recombination)
        if not 0 <= recombination <= 1:
            raise ConfigError("optimise.recombination", f"must be in [0, 1], got {recombination!r}")
        object.__setattr__(self, "recombination", recombination)
        validate.choice("optimise.init", self.init, INITS)
        object.__setattr__(self, "penalty", validate.positive("optimise.penalty", self.penalty))
        if not isinstance(self.polish, (bool, np.bool_)):
            raise ConfigError("optimise.polish", f"expected true or false, got {self.polish!r}")
        object.__setattr__(self, "polish", bool(self.polish))
        step = validate.positive("optimise.polish_step", self.polish_step)
        if not step < 0.5:
            raise ConfigError("optimise.polish_step", f"a share of the bounds' width, must be < 0.5, got {step!r}")
        object.__setattr__(self, "polish_step", step)
        if self.x0 is not None:
            if isinstance(self.x0, (str, bytes)) or not hasattr(self.x0, "__len__") or len(self.x0) == 0:
                raise ConfigError("optimise.x0", f"expected the K parameters of a start candidate, got {self.x0!r}")
            object.__setattr__(self, "x0", tuple(validate.real(f"optimise.x0[{i}]", v)
                                                 for i, v in enumerate(self.x0)))

    def to_dict(self) -> dict:
        data = dataclasses.asdict(self)
        data["constraints"] = list(self.constraints)
        if isinstance(self.mutation, tuple):
            data["mutation"] = list(self.mutation)
        if self.x0 is not None:
            data["x0"] = list(self.x0)
        return data


def penalised(dataset: xr.Dataset, settings: OptimiseSettings) -> tuple[np.ndarray, np.ndarray]:
    """(energies to minimise, feasible) of an evaluated population: the signed
    objective where every constraint holds and it is finite, else
    ``penalty * (1 + violation)`` (violation: one per constraint missed, the
    share of the way to B not covered for ``arrive``, one for a shape outside
    its region, one for a meaningless objective)."""
    values = np.asarray(dataset[settings.objective].values, dtype=np.float64)
    signed = values if settings.sense == "minimise" else -values
    finite = np.isfinite(signed)
    feasible = finite.copy()
    violation = (~finite).astype(np.float64)
    if "inside" in dataset:
        inside = dataset["inside"].values.astype(bool)
        feasible &= inside
        violation += ~inside
    if "arrive" in settings.constraints:
        arrived = dataset["arrived"].values.astype(bool)
        feasible &= arrived
        short = dataset["shortfall"].values if "shortfall" in dataset else np.ones(arrived.size)
        violation += np.where(arrived, 0.0, np.maximum(np.nan_to_num(short, nan=1.0), 1e-3))
    if "stay_on" in settings.constraints:
        stayed = (dataset["stayed_on"].values.astype(bool) if "stayed_on" in dataset
                  else dataset["status"].values != LIFTED_OFF)
        feasible &= stayed
        violation += ~stayed
    energies = np.where(feasible, np.where(finite, signed, 0.0), settings.penalty * (1.0 + violation))
    return energies, feasible


def _fingerprint(scene, shape, settings: OptimiseSettings) -> str:
    """What makes a checkpoint belong to this optimisation (but maxiter,
    which a resumed run may raise)."""
    data = settings.to_dict()
    data.pop("maxiter")
    if data["evaluator"] == "kernel":  # as before the setting existed: older checkpoints resume
        data.pop("evaluator")
    text = json.dumps([repr(scene), shape.describe(), list(map(list, shape.bounds)), data], sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def _write_checkpoint(path: Path, state: dict) -> None:
    """``state`` as an .npz file, written beside ``path`` and renamed over it
    (a reader never sees half a file)."""
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(handle, "wb") as stream:
            np.savez(stream, **state)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def _read_checkpoint(path: Path, fingerprint: str) -> dict:
    try:
        with np.load(path, allow_pickle=False) as data:
            state = {key: data[key] for key in data.files}
    except (OSError, ValueError) as error:
        raise ConfigError("checkpoint", f"cannot read {str(path)!r}: {error}") from None
    if int(state.get("version", -1)) != CHECKPOINT_VERSION:
        raise ConfigError("checkpoint", f"{str(path)!r} is not a rampwork optimisation checkpoint "
                          f"(version {CHECKPOINT_VERSION})")
    if str(state["fingerprint"]) != fingerprint:
        raise ConfigError("checkpoint", f"{str(path)!r} was written by another optimisation (scene, shape "
                          "or settings differ); delete it or pass resume=False")
    return state


class _Run:
    """One optimisation: the solver, its evaluations and its history."""

    def __init__(self, scene, shape, settings: OptimiseSettings, threads):
        self.scene, self.shape, self.settings, self.threads = scene, shape, settings, threads
        self.last = None  # the dataset of the latest evaluation
        self.evaluations = 0
        self.history = {name: [] for name in ("best_parameters", "best_objective", "objective_spread",
                                              "n_feasible", "evaluations")}
        self.solver = DifferentialEvolutionSolver(
            self._energies, list(shape.bounds), strategy="best1bin", maxiter=settings.maxiter,
            popsize=settings.popsize, tol=settings.tol, atol=settings.atol, mutation=settings.mutation,
            recombination=settings.recombination, rng=np.random.default_rng(settings.seed),
            polish=False, init=settings.init, updating="deferred", vectorized=True,
            x0=None if settings.x0 is None else np.array(settings.x0))

    def evaluate(self, population: np.ndarray) -> xr.Dataset:
        if self.settings.evaluator == "kernel":
            dataset = self.shape.evaluate(population, self.scene, threads=self.threads)
        else:
            dataset = self.shape.evaluate(population, self.scene, threads=self.threads,
                                          evaluator=self.settings.evaluator)
        self.evaluations += population.shape[0]
        return dataset

    def _energies(self, parameters: np.ndarray) -> np.ndarray:
        # vectorized: parameters is (K, S)
        self.last = self.evaluate(np.ascontiguousarray(np.atleast_2d(parameters).T))
        energies, _ = penalised(self.last, self.settings)
        return energies

    def state(self, generation: int, fingerprint: str) -> dict:
        solver = self.solver
        state = {"version": CHECKPOINT_VERSION, "fingerprint": fingerprint, "generation": generation,
                 "population": solver.population, "energies": solver.population_energies,
                 "nfev": solver._nfev, "evaluations": self.evaluations, "scale": solver.scale,
                 # scipy shuffles this index in place to draw the mutation's members
                 "sample_order": solver._random_population_index,
                 "rng": json.dumps(solver.random_number_generator.bit_generator.state)}
        state.update({f"history_{name}": np.asarray(values) for name, values in self.history.items()})
        return state

    def restore(self, state: dict) -> int:
        solver = self.solver
        solver.population[...] = state["population"]
        solver.population_energies[...] = state["energies"]
        solver.feasible[...] = True
        solver.constraint_violation[...] = 0.0
        solver._nfev = int(state["nfev"])
        solver.scale = state["scale"].item() if state["scale"].ndim == 0 else tuple(state["scale"])
        solver._random_population_index[...] = state["sample_order"]
        solver.random_number_generator.bit_generator.state = json.loads(str(state["rng"]))
        self.evaluations = int(state["evaluations"])
        for name in self.history:
            self.history[name] = list(state[f"history_{name}"])
        return int(state["generation"])

    def record(self) -> None:
        solver, settings = self.solver, self.settings
        energies = solver.population_energies
        best = float(energies[0])
        sign = 1.0 if settings.sense == "minimise" else -1.0
        self.history["best_parameters"].append(np.array(solver.x))
        self.history["best_objective"].append(sign * best if best < settings.penalty else math.nan)
        self.history["objective_spread"].append(float(np.std(energies)))
        self.history["n_feasible"].append(int(np.sum(energies < settings.penalty)))
        self.history["evaluations"].append(self.evaluations)

    def line(self, generation: int, elapsed: float) -> str:
        h, s = self.history, self.settings
        best = h["best_objective"][-1]
        units = OBJECTIVES[s.objective]
        best_text = f"{best:.10g} {units}" if math.isfinite(best) else "none feasible"
        return (f"generation {generation}/{s.maxiter}: best {s.objective} = {best_text}, feasible "
                f"{h['n_feasible'][-1]}/{self.solver.num_population_members}, spread "
                f"{h['objective_spread'][-1]:.3g}, {h['evaluations'][-1]:,} evaluations, {elapsed:.1f} s")


def _polish(run: _Run, x: np.ndarray, energy: float) -> tuple[np.ndarray, float, int]:
    """L-BFGS-B from ``x`` with central differences, each gradient one batched
    call of 2K + 1 candidates; kept only where feasible and better."""
    settings = run.settings
    bounds = np.array(run.shape.bounds, dtype=np.float64)
    step = settings.polish_step * (bounds[:, 1] - bounds[:, 0])
    k = x.size
    calls = 0

    def value_and_gradient(point):
        nonlocal calls
        calls += 1
        plus = np.minimum(point + step, bounds[:, 1])
        minus = np.maximum(point - step, bounds[:, 0])
        population = np.vstack([point, point + np.diag(plus - point), point + np.diag(minus - point)])
        energies, _ = penalised(run.evaluate(population), settings)
        gradient = (energies[1:k + 1] - energies[k + 1:]) / (plus - minus)
        return float(energies[0]), gradient

    # tolerances at rounding: L-BFGS-B's defaults (pgtol 1e-5) stop at the first gradient of a
    # descent time, whose slopes are below 1e-5 s per unit coefficient near the optimum
    result = minimize(value_and_gradient, x, jac=True, method="L-BFGS-B", bounds=bounds,
                      options=dict(ftol=1e-15, gtol=1e-12, maxiter=POLISH_MAXITER))
    if result.fun < energy and result.fun < settings.penalty:
        return np.asarray(result.x), float(result.fun), calls
    return x, energy, calls


def optimise(scene, shape, objective: str = "t_end", constraints=("arrive", "stay_on"), *,
             sense: str = "minimise", seed: int = 0, popsize: int = 15, maxiter: int = 100,
             tol: float = 1e-6, polish: bool = False, settings: OptimiseSettings | None = None,
             checkpoint=None, resume: bool = True, progress=None, threads: int | None = None,
             **more) -> xr.Dataset:
    """Optimise ``shape``'s K parameters for ``scene``'s physics: minimise or
    maximise ``objective`` under ``constraints`` by differential evolution,
    one batched kernel call per generation.  Returns the history Dataset
    (docs/optimise.md): per generation the best parameters, objective and
    the population's spread; the final population with its objectives and
    flags; the best candidate in ``best_parameters[-1]`` and the attribute
    ``best_objective``.

    ``settings``: an :class:`OptimiseSettings` (then the keyword settings are
    not given); ``more``: its other fields.  ``checkpoint``: a file written
    every generation; with ``resume`` (default) an existing one of the same
    optimisation is continued (identical result to an uninterrupted run).
    ``progress``: True prints a line per generation on stderr, a callable
    receives the line."""
    if settings is None:
        settings = OptimiseSettings(objective=objective, sense=sense, constraints=tuple(constraints)
                                    if not isinstance(constraints, str) else constraints, seed=seed,
                                    popsize=popsize, maxiter=maxiter, tol=tol, polish=polish, **more)
    elif not isinstance(settings, OptimiseSettings):
        raise ConfigError("settings", f"expected a rampwork.optimise.OptimiseSettings, got {settings!r}")
    for name in ("names", "bounds", "evaluate"):
        if not hasattr(shape, name):
            raise ConfigError("shape", f"expected a shape family (names, bounds, evaluate), got "
                              f"{type(shape).__name__} without {name!r}")
    if settings.evaluator != "kernel" and not isinstance(shape, ChordModes):
        raise ConfigError("optimise.evaluator", f"{settings.evaluator!r} evaluates ChordModes shapes only, "
                          f"not {type(shape).__name__}; use 'kernel'")
    if settings.x0 is not None:
        bounds = np.array(shape.bounds, dtype=np.float64)
        x0 = np.array(settings.x0)
        if x0.size != len(shape.names) or not ((bounds[:, 0] <= x0) & (x0 <= bounds[:, 1])).all():
            raise ConfigError("optimise.x0", f"expected {len(shape.names)} numbers inside the shape's "
                              f"bounds {[list(b) for b in shape.bounds]}, got {list(settings.x0)}")
    path = None if checkpoint is None else Path(checkpoint)
    if path is not None and not path.parent.is_dir():
        raise ConfigError("checkpoint", f"the folder {str(path.parent)!r} does not exist")
    if progress is True:
        def progress(line):
            print(line, file=sys.stderr, flush=True)
    elif progress is not None and progress is not False and not callable(progress):
        raise ConfigError("progress", f"expected True, None or a callable, got {progress!r}")

    started = time.perf_counter()
    run = _Run(scene, shape, settings, threads)
    fingerprint = _fingerprint(scene, shape, settings)
    generation = 0
    if path is not None and resume and path.exists():
        generation = run.restore(_read_checkpoint(path, fingerprint))
    converged = generation > 0 and run.solver.converged()
    while generation < settings.maxiter and not converged:
        next(run.solver)
        generation += 1
        run.record()
        converged = run.solver.converged()
        if path is not None:
            _write_checkpoint(path, run.state(generation, fingerprint))
        if progress:
            progress(run.line(generation, time.perf_counter() - started))
    return _history(run, generation, converged, started)


def _history(run: _Run, generations: int, converged: bool, started: float) -> xr.Dataset:
    settings, shape, solver = run.settings, run.shape, run.solver
    population = np.array([solver._scale_parameters(member) for member in solver.population])
    best_x, best_energy = np.array(solver.x), float(solver.population_energies[0])
    polish_calls = 0
    if settings.polish and best_energy < settings.penalty:
        best_x, best_energy, polish_calls = _polish(run, best_x, best_energy)
    final = run.evaluate(population)
    energies, feasible = penalised(final, settings)
    sign = 1.0 if settings.sense == "minimise" else -1.0
    best_objective = sign * best_energy if best_energy < settings.penalty else math.nan

    def attrs(name, units=None):
        values = spec_attrs(OPTIMISE_OUTPUTS[name])
        if units is not None:
            values["units"] = units
        return values

    units = OBJECTIVES[settings.objective]
    history = run.history
    data = {
        "best_parameters": (("generation", "parameter"), np.array(history["best_parameters"]).reshape(-1, len(shape.names)),
                            attrs("best_parameters")),
        "best_objective": ("generation", np.array(history["best_objective"], dtype=np.float64),
                           attrs("best_objective", units)),
        "objective_spread": ("generation", np.array(history["objective_spread"], dtype=np.float64),
                             attrs("objective_spread")),
        "n_feasible": ("generation", np.array(history["n_feasible"], dtype=np.int32), attrs("n_feasible")),
        "evaluations": ("generation", np.array(history["evaluations"], dtype=np.int64), attrs("evaluations")),
        "population": (("candidate", "parameter"), population, attrs("coefficients")),
        "objective": ("candidate", final[settings.objective].values, attrs("objective", units)),
        "penalised": ("candidate", energies, attrs("penalised")),
        "feasible": ("candidate", feasible, attrs("feasible")),
    }
    for name in final.data_vars:
        if name not in ("coefficients",) and name not in data and final[name].dims == ("candidate",):
            data[name] = ("candidate", final[name].values, dict(final[name].attrs))
    scene_text = _scene_text(run.scene)
    extra = {"objective": settings.objective, "objective_units": units, "sense": settings.sense,
             "constraints": ", ".join(settings.constraints) or "(none)", "shape": shape.describe(),
             "K": len(shape.names), "population_size": int(population.shape[0]),
             "generations": generations, "converged": converged,
             "best_objective": best_objective, "best_parameters_final": np.asarray(best_x),
             "polished": settings.polish, "polish_calls": polish_calls,
             "n_evaluations": run.evaluations, "run_time_s": time.perf_counter() - started,
             **{f"optimise_{key}": value for key, value in settings.to_dict().items()
                if key not in ("objective", "sense", "constraints")}}
    title = f"rampwork optimisation: {settings.sense} {settings.objective}"
    history_line = (f"rampwork.optimise: {generations} generations of {population.shape[0]} candidates, "
                    f"{settings.sense} {settings.objective}")
    coords = {"generation": np.arange(1, generations + 1), "parameter": list(shape.names),
              "candidate": np.arange(population.shape[0])}
    return xr.Dataset(data, coords=coords, attrs=global_attrs(title, scene_text, history_line, extra))


def _scene_text(scene) -> str:
    from .runner import scene_text
    from .scene import Scene, Sweep

    if isinstance(scene, Scene):
        return scene_text(scene, Sweep.single())
    return repr(scene)
