"""Reference pages generated from rampwork's own tables, so that they cannot
drift from the code.

* ``scene-file``: every key the scene-file validator accepts
  (:mod:`rampwork.scenefile`'s ``TOP_KEYS``, ``FRICTION_KEYS``, ...,
  ``SWEEP_KEYS``, the ramp families' parameters, the sweep axes, kinds and
  value forms), with the type, default and allowed values read from the
  settings objects (:mod:`rampwork.scene`) and units from the variable
  registry (:mod:`rampwork.schema`) and the families' parameter specs;
* ``variables``: every dataset variable of :mod:`rampwork.schema`'s registry
  (names, units, long names, dtypes, when present, status flags);
* ``families``: the ramp families of :data:`rampwork.FAMILIES`;
* ``cli``: ``rampwork COMMAND --help`` for every command of the parser;
* ``examples``: the example scene files shipped with the package.

Only the one-line descriptions below are written by hand.  A key the
validator accepts without a description here, or a description of a key it
no longer accepts, is a *problem*: the mkdocs hook (``docs/hooks.py``)
reports problems as warnings, which fail ``mkdocs build --strict``, and
``tests/test_docs.py`` fails on them too.

Run as a script to print one page's generated part::

    python docs/gen_reference.py scene-file    # or variables, families, cli, examples
"""

from __future__ import annotations

import dataclasses
import inspect
import io
import os
import sys
import typing
from contextlib import redirect_stdout
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT / "src") not in sys.path:  # describe this checkout, installed or not
    sys.path.insert(0, str(ROOT / "src"))

import rampwork  # noqa: E402
from rampwork import scene as scene_module  # noqa: E402
from rampwork import scenefile, schema  # noqa: E402
from rampwork.core import steppers  # noqa: E402
from rampwork.core.status import STATUS_TABLE  # noqa: E402
from rampwork.errors import ConfigError  # noqa: E402
from rampwork.ramps import FAMILIES  # noqa: E402

#: the command as the docs write it: what works after the quick start, where the
#: virtual environment is not activated (docs/guide/install.md)
COMMAND = ".venv/bin/rampwork"


def _power(value: int) -> str:
    """10^k for a power of ten, else the number with thousands separators."""
    text = str(int(value))
    if text.startswith("1") and set(text[1:]) <= {"0"} and len(text) > 4:
        return f"10^{len(text) - 1}"
    return f"{int(value):,}"


# ---------------------------------------------------------------------------
# the hand-written part: one line per key (Markdown)
# ---------------------------------------------------------------------------

#: "table.key" (top-level keys without a table) -> description
DESCRIPTIONS = {
    # top level
    "title": "Title of the run, stored as the dataset's `title` attribute.",
    "x0": "Start position (horizontal), in the ramp's `domain` (checked when the scene is "
          "made). Required unless `x0` is a sweep axis.",
    "v0": "Start velocity, the horizontal velocity dx/dt (not the speed along the ramp).",
    "m": "Mass of the block. The motion does not depend on it; every work scales with it.",
    "g": "Gravitational acceleration.",
    "t_max": "Time limit: a trajectory still moving then ends with status `timeout`.",
    "contact": "`one_sided`: a block on top of the ramp, which lifts off where the normal "
               "force reaches zero; `two_sided`: a bead on a wire, held on both sides "
               "([physics §1.3](../physics.md#s1-3)).",
    "diagnostics": "Optional extra outputs. `x_lift_off_paper`: where the paper's lift-off "
                   "criterion (eq. 26) first held, beside the contact-force `x_lift_off` "
                   "(not with air drag).",
    "ramp": "The ramp: `family`, its parameters and `domain` (required).",
    "friction": "Coulomb friction coefficients.",
    "drag": "Optional air drag along the path (not in the paper).",
    "integrator": "How trajectories are integrated.",
    "record": "Optional: record a few whole trajectories (the `trace_*` variables).",
    "sweep": "Optional: the values to run the scene over. Without it, one trajectory.",
    # [ramp]
    "ramp.family": "The ramp's shape; each family has its own parameters (below).",
    "ramp.domain": "`[x_min, x_max]`, x_min < x_max: the ends of the ramp, where a trajectory "
                   "exits. Must stay off vertical tangents (the edge of a circle, a cycloid's "
                   "cusp). Required, except for `spline`, where it defaults to the range of its "
                   "points.",
    # [friction]
    "friction.mu_k": "Kinetic friction coefficient, while sliding.",
    "friction.mu_s": "Static friction coefficient: a block at rest stays where "
                     "|f'| <= `mu_s`.",
    # [drag]
    "drag.linear": "b: the linear term of the drag force m (b s' + c s'²), s' the speed "
                   "along the path.",
    "drag.quadratic": "c: the quadratic term of the drag force m (b s' + c s'²).",
    # [integrator]
    "integrator.method": "The stepping method: fixed steps of `dt`, or an adaptive "
                         "Dormand-Prince pair with error control per trajectory.",
    "integrator.dt": "Fixed-step methods: the step. Adaptive methods: the first step. Either way "
                     "shorter than `t_max`.",
    "integrator.rtol": "Adaptive methods only: relative tolerance on x, v and the work "
                       "integrals.",
    "integrator.atol": "Adaptive methods only: absolute tolerance (SI units of each quantity, "
                       "so on metre-scale ramps it reads as relative too).",
    "integrator.dt_max": "Adaptive methods only: the largest step (it may exceed `t_max`, "
                         "which then bounds the steps).",
    "integrator.closed_form": "`true`: a straight ramp without drag is solved exactly, without "
                              "stepping, whatever `method` says (datasets say "
                              "`integrator_used = \"closed_form\"`, `kernel_closed_form = 1`, "
                              "`steps = 0`; `rampwork check` and `run` add \"(not used: ...)\" "
                              "to the integrator); `false` steps with `method` anyway, to measure "
                              "its error.",
    "integrator.project_energy": "Adaptive methods only: `true` (default) projects every "
                                 "accepted step onto the energy balance (docs/physics.md "
                                 "1.6), and `energy_balance_error` sums the residuals it "
                                 "removed; `false` integrates without it.",
    # [record]
    "record.count": "How many trajectories to record, spread evenly over the sweep.",
    "record.every": "A sample every `every` steps (and at every event).",
    "record.max_samples": "At most this many samples per recorded trajectory.",
    "record.indices": "Flat indices (C order over the sweep) of the trajectories to record, "
                      "instead of `count`; each must name a trajectory of the sweep.",
    # [sweep]
    "sweep.kind": "How the axes combine (the kinds below).",
    "sweep.axes": "A table: axis name = its values (the names and value forms below).",
    "sweep.n": "`random` only (required there): the number of cases drawn.",
    "sweep.seed": "`random` only: the seed of the draw; the same seed gives the same cases.",
}

#: sweep kinds of a scene file -> description
SWEEP_KIND_DESCRIPTIONS = {
    "grid": "The outer product of the axes: one output dimension per axis, in file order.",
    "cases": "Points: every axis lists the same number of values, and the i-th values of "
             "all axes make case i; one `case` dimension.",
    "random": "`n` independent cases drawn from the axes' distributions with `seed` (numpy's "
              "Philox stream); one `case` dimension. Case i depends only on the recipe and i.",
    "sobol": "A scrambled Sobol' sequence (scipy.stats.qmc, seeded) of `n` points, `n` a power "
             "of 2, scaled to the axes' ranges; one `case` dimension.",
    "halton": "A scrambled Halton sequence (scipy.stats.qmc, seeded) of `n` points, scaled to "
              "the axes' ranges; one `case` dimension.",
    "lhs": "A Latin hypercube of `n` points (one per stratum on every axis; strata from a "
           "seeded permutation, not scipy's LatinHypercube); one `case` dimension.",
}

#: value forms of a sweep axis -> (TOML form, description)
VALUE_FORM_DESCRIPTIONS = {
    "list": ("`[v1, v2, ...]` or one number", "The values themselves (grid and cases)."),
    "linspace": ("`{ linspace = [start, stop, num] }`",
                 "`num` evenly spaced values, both ends included (numpy's `linspace`)."),
    "logspace": ("`{ logspace = [start, stop, num] }`",
                 "`num` values from 10^start to 10^stop, evenly spaced in the exponent."),
    "arange": ("`{ arange = [start, stop, step] }`",
               "numpy's `arange`: from start in steps of `step`, stop excluded (careful with "
               "float ends)."),
    "uniform": ("`{ uniform = [low, high] }`",
                "Designs (`random`, `sobol`, `halton`, `lhs`) only: uniform in [low, high]."),
    "loguniform": ("`{ loguniform = [low, high] }`",
                   "Designs only: uniform in the logarithm; low > 0."),
}

#: what a default of None means, per key
NONE_MEANS = {
    "x0": "none: required unless swept",
    "friction.mu_s": "= `mu_k` (the paper's case)",
    "integrator.dt": f"{scene_module.DEFAULT_DT!r} s for fixed-step methods; estimated per "
                     "trajectory for adaptive ones",
    "integrator.rtol": f"{scene_module.DEFAULT_RTOL!r}",
    "integrator.atol": "= `rtol`",
    "integrator.dt_max": "no limit",
    "record.indices": "none (use `count`)",
}

#: defaults of keys that no settings object holds
FIXED_DEFAULTS = {
    "ramp": "required",
    "ramp.family": "required",
    "ramp.domain": "required (`spline`: its points' range)",
    "sweep": "none: one trajectory",
    "sweep.n": "required with `random`",
}

#: allowed values that the validator checks with its own numbers: (text,
#: probes, settings).  Each probe (value, accepted) is run through the
#: validator (scenefile.scene_from_dict) with ``settings`` merged into a
#: minimal scene, so a bound written here that the code does not enforce is a
#: problem.
_ADAPTIVE = {"integrator": {"method": "dopri5"}}
_RANDOM = {"sweep": {"kind": "random", "n": 1, "axes": {"mu": {"uniform": [0.1, 0.2]}}}}
BOUNDS = {
    "x0": ("in `ramp.domain`", [(-1.0, True), (1.0, True), (1.5, False), (-1.01, False)], {}),
    "m": ("> 0", [(0.0, False), (1e-9, True)], {}),
    "g": ("> 0", [(0.0, False), (1e-9, True)], {}),
    "t_max": (f"> `dt`; `t_max / dt` <= {_power(scene_module.MAX_STEPS_PER_TRAJECTORY)}",
              [(0.0, False), (1e-3, False), (2e-3, True), (1e7, True), (1.1e7, False)], {}),
    "friction.mu_k": (">= 0", [(-1e-9, False), (0.0, True)], {}),
    "friction.mu_s": (">= `mu_k`", [(0.1, False), (0.2, True)], {"friction": {"mu_k": 0.2}}),
    "drag.linear": (">= 0", [(-1e-9, False), (0.0, True)], {}),
    "drag.quadratic": (">= 0", [(-1e-9, False), (0.0, True)], {}),
    "integrator.dt": ("> 0, < `t_max` (adaptive methods: the first step)",
                      [(0.0, False), (1e-3, True), (1e9, False)], {}),
    "integrator.dt_max": ("> 0, >= `dt`", [(0.0, False), (1e-3, True), (1e3, True)], _ADAPTIVE),
    "integrator.rtol": (f"{scene_module.RTOL_RANGE[0]:g} to {scene_module.RTOL_RANGE[1]:g}",
                        [(scene_module.RTOL_RANGE[0], True), (scene_module.RTOL_RANGE[1], True),
                         (scene_module.RTOL_RANGE[0] / 2, False),
                         (scene_module.RTOL_RANGE[1] * 2, False)], _ADAPTIVE),
    "integrator.atol": (f"{scene_module.ATOL_RANGE[0]:g} to {scene_module.ATOL_RANGE[1]:g}",
                        [(scene_module.ATOL_RANGE[0], True), (scene_module.ATOL_RANGE[1], True),
                         (scene_module.ATOL_RANGE[0] / 2, False),
                         (scene_module.ATOL_RANGE[1] * 2, False)], _ADAPTIVE),
    "record.count": ("0 to 10,000", [(-1, False), (0, True), (10_000, True), (10_001, False)], {}),
    "record.every": (">= 1", [(0, False), (1, True)], {}),
    "record.max_samples": ("2 to 10^7", [(1, False), (2, True), (10**7, True),
                                         (10**7 + 1, False)], {}),
    "record.indices": (">= 0, each naming a trajectory of the sweep",
                       [([-1], False), ([0], True), ([1], False)], {}),
    "sweep.n": (f"1 to {_power(scenefile.MAX_AXIS_POINTS)}",
                [(0, False), (1, True), (scenefile.MAX_AXIS_POINTS + 1, False)], _RANDOM),
    "sweep.seed": (">= 0", [(-1, False), (0, True)], _RANDOM),
}

#: units of keys that are not sweep axes or ramp parameters (UDUNITS spelling)
UNITS = {
    "t_max": "s",
    "ramp.domain": "m",
    "integrator.dt": "s",
    "integrator.dt_max": "s",
    "integrator.rtol": "1",
    "integrator.atol": "SI",
}

#: keys whose values are numbers the scene may also sweep -> axis name in schema.AXES
AXIS_OF_KEY = {
    "x0": "x0", "v0": "v0", "m": "m", "g": "g",
    "friction.mu_k": "mu_k", "friction.mu_s": "mu_s",
    "drag.linear": "drag_linear", "drag.quadratic": "drag_quadratic",
}

#: the settings object each table of a scene file builds
SETTINGS_OF_TABLE = {
    "": scene_module.Scene,
    "friction": scene_module.Friction,
    "drag": scene_module.Drag,
    "integrator": scene_module.Integrator,
    "record": scene_module.Record,
    "sweep": scene_module.Sweep,
}


# ---------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------


def _cell(text) -> str:
    """Table-cell text: no pipes or newlines."""
    return str(text).replace("|", "\\|").replace("\n", " ")


def _table(header: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(" --- " for _ in header) + "|"]
    lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def _code(values) -> str:
    return ", ".join(f"`{v}`" for v in values)


def _units(units: str) -> str:
    return "" if units in ("", "1") else f"`{units}`"


def _number(value) -> str:
    if isinstance(value, bool):
        return "`true`" if value else "`false`"
    if isinstance(value, str):
        return f'`"{value}"`'
    if isinstance(value, float) and value == int(value) and abs(value) < 1e6:
        return f"`{value!r}`"
    return f"`{value!r}`"


def _toml_type(annotation) -> str:
    """The TOML type of a settings field's Python annotation."""
    args = [a for a in typing.get_args(annotation) if a is not type(None)]
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)) and len(args) == 1:
        return _toml_type(args[0])
    if origin is tuple:
        item = _toml_type(args[0]) if args else "value"
        return f"array of {item}s"
    if annotation is bool:
        return "boolean"
    if annotation is int:
        return "integer"
    if annotation is float:
        return "number"
    if annotation is str:
        return "string"
    if dataclasses.is_dataclass(annotation):
        return "table"
    return getattr(annotation, "__name__", str(annotation))


class Reference:
    """Builds the pages; collects :attr:`problems` (missing or stale
    descriptions) instead of failing at the first."""

    def __init__(self):
        self.problems: list[str] = []
        self._described: set[str] = set()

    # -- descriptions --------------------------------------------------------

    def describe(self, key: str) -> str:
        self._described.add(key)
        if key not in DESCRIPTIONS:
            self.problems.append(f"scene-file key {key!r} is accepted by the validator but has no "
                                 f"description in docs/gen_reference.py DESCRIPTIONS")
            return "(no description yet)"
        return DESCRIPTIONS[key]

    def check_stale(self) -> None:
        for key in DESCRIPTIONS:
            if key not in self._described:
                self.problems.append(f"docs/gen_reference.py describes scene-file key {key!r}, "
                                     "which the validator no longer accepts")

    # -- one table of keys ---------------------------------------------------

    def _field(self, table: str, key: str):
        cls = SETTINGS_OF_TABLE.get(table)
        if cls is None:
            return None, None
        hints = typing.get_type_hints(cls)
        for field in dataclasses.fields(cls):
            if field.name == key:
                return field, hints[field.name]
        return None, None

    def _default(self, full: str, field) -> str:
        if full in FIXED_DEFAULTS:
            return FIXED_DEFAULTS[full]
        if field is None and full.startswith("sweep."):  # Sweep.random's arguments
            parameter = inspect.signature(scene_module.Sweep.random).parameters.get(full[6:])
            if parameter is not None and parameter.default is not inspect.Parameter.empty:
                return _number(parameter.default)
        if field is None:
            return ""
        if field.default is not dataclasses.MISSING:
            if field.default is None:
                if full not in NONE_MEANS:
                    self.problems.append(f"scene-file key {full!r} defaults to None: say what that "
                                         "means in docs/gen_reference.py NONE_MEANS")
                    return "none"
                return NONE_MEANS[full]
            if isinstance(field.default, tuple) and not field.default:
                return "none"
            return _number(field.default)
        if field.default_factory is not dataclasses.MISSING:
            return "(the table's defaults)"
        return "required"

    def _units_of(self, full: str) -> str:
        if full in AXIS_OF_KEY:
            return _units(schema.AXES[AXIS_OF_KEY[full]].units)
        return _units(UNITS.get(full, ""))

    def _allowed(self, full: str) -> str:
        scene = scene_module
        if full in BOUNDS:
            text, probes, settings = BOUNDS[full]
            self._probe(full, probes, settings)
            return text
        if full == "contact":
            return _code(scene.CONTACTS)
        if full == "diagnostics":
            return _code(scene.DIAGNOSTICS)
        if full == "integrator.method":
            return _code(scene.METHODS)
        if full == "ramp.family":
            return _code(FAMILIES)
        if full == "sweep.kind":
            return _code(scenefile.FILE_SWEEP_KINDS)
        return ""

    def _probe(self, full: str, probes, settings) -> None:
        """Check the bounds documented for ``full`` against the validator."""
        for value, accepted in probes:
            document = {"x0": 0.0, "ramp": {"family": "straight", "slope": -0.5,
                                            "domain": [-1.0, 1.0]}}
            for table, values in settings.items():
                document[table] = dict(values) if isinstance(values, dict) else values
            table, _, key = full.rpartition(".")
            target = document.setdefault(table, {}) if table else document
            target[key] = value
            try:
                scenefile.scene_from_dict(document, "<probe>")
                ok = True
            except ConfigError:
                ok = False
            if ok != accepted:
                self.problems.append(f"docs/gen_reference.py BOUNDS says {full} = {value!r} is "
                                     f"{'allowed' if accepted else 'refused'}, but the validator "
                                     f"{'refuses' if accepted else 'accepts'} it")

    def keys_table(self, table: str, keys, types: dict[str, str] | None = None) -> str:
        rows = []
        for key in keys:
            full = f"{table}.{key}" if table else key
            field, annotation = self._field(table, key)
            if types and key in types:
                kind = types[key]
            elif annotation is not None:
                kind = _toml_type(annotation)
            else:
                kind = ""
            if kind == "table":
                name = f"[`[{full}]`](#{full.replace('.', '-')})"
            else:
                name = f"`{key}`"
            rows.append([name, kind, self._default(full, field), self._units_of(full),
                         self._allowed(full), self.describe(full)])
        return _table(["key", "type", "default", "units", "allowed", "description"], rows)

    # -- the pages ----------------------------------------------------------

    def scene_file(self) -> str:
        sf = scenefile
        out = []
        top_types = {"ramp": "table", "sweep": "table"}
        out.append("## Top level {#top-level}\n")
        out.append(self.keys_table("", sf.TOP_KEYS, top_types))

        out.append("\n## `[ramp]` {#ramp}\n")
        out.append(self.keys_table("ramp", ("family", "domain"),
                                   {"family": "string", "domain": "array of 2 numbers"}))
        out.append("\nBesides `family` and `domain`, `[ramp]` takes the chosen family's own "
                   "parameters; a parameter without a default is required. Every parameter "
                   "may also be a sweep axis.\n")
        for name, family in FAMILIES.items():
            out.append(f"\n### `{name}` {{#family-{name}}}\n")
            out.append(f"{family.description[0].upper()}{family.description[1:]}.\n")
            rows = []
            for p in family.parameters:
                default = "required" if p.default is None else _number(p.default)
                allowed = "> 0" if p.constraint == "positive" else "finite"
                rows.append([f"`{p.name}`", "number", default, _units(p.units), allowed,
                             p.long_name])
            for data in family.data_names:
                units, text = family.data_docs[data]
                rows.append([f"`{data}`", "array of numbers", "required", f"`{units}`", "",
                             f"{text} (not sweepable)"])
            if rows:
                out.append(_table(["key", "type", "default", "units", "allowed", "description"],
                                  rows))
            for r in family.renamed.values():  # old names the family still reads
                out.append(f"\n**Old name `{r.old}`**: it {r.change}; it is now `{r.new}` "
                           f"({r.new} = {r.formula}). A scene that still gives `{r.old}` is read "
                           f"that way, with a `RenamedParameterWarning`; a sweep over `{r.old}` is "
                           "refused.\n")

        for table, keys in (("friction", sf.FRICTION_KEYS), ("drag", sf.DRAG_KEYS),
                            ("integrator", sf.INTEGRATOR_KEYS), ("record", sf.RECORD_KEYS)):
            out.append(f"\n## `[{table}]` {{#{table}}}\n")
            out.append(self.keys_table(table, keys))
            if table == "integrator":
                rows = []
                for method, stepper in steppers.METHODS.items():
                    adaptive = method in steppers.ADAPTIVE_STEPPERS
                    rows.append([f"`{method}`", stepper.order,
                                 "adaptive: `rtol`, `atol`, `dt` (first step), `dt_max`"
                                 if adaptive else "fixed steps of `dt`"])
                out.append("\nMethods (`method`):\n")
                out.append(_table(["method", "order", "settings"], rows))

        out.append("\n## `[sweep]` {#sweep}\n")
        out.append(self.keys_table("sweep", sf.SWEEP_KEYS,
                                   {"kind": "string", "axes": "table", "n": "integer",
                                    "seed": "integer"}))
        out.append("\n### Kinds {#sweep-kinds}\n")
        rows = []
        for kind in sf.FILE_SWEEP_KINDS:
            if kind not in SWEEP_KIND_DESCRIPTIONS:
                self.problems.append(f"sweep kind {kind!r} has no description in "
                                     "docs/gen_reference.py SWEEP_KIND_DESCRIPTIONS")
            rows.append([f"`{kind}`", SWEEP_KIND_DESCRIPTIONS.get(kind, "(no description yet)")])
        for kind in SWEEP_KIND_DESCRIPTIONS:
            if kind not in sf.FILE_SWEEP_KINDS:
                self.problems.append(f"docs/gen_reference.py describes sweep kind {kind!r}, which "
                                     "the validator no longer accepts")
        out.append(_table(["kind", "meaning"], rows))

        out.append("\n### `[sweep.axes]`: names {#sweep-axes}\n")
        out.append("Any of these names, or a parameter of the ramp's family (see "
                   "[`[ramp]`](#ramp)). `mu` sets `mu_k = mu_s`; do not combine it with `mu_k` or "
                   "`mu_s`. A swept value replaces the scene's own.\n")
        rows = [[f"`{name}`", _units(schema.AXES[name].units), schema.AXES[name].long_name,
                 schema.AXES[name].description] for name in scene_module.SCENE_AXES]
        out.append(_table(["axis", "units", "long name", "description"], rows))

        out.append("\n### `[sweep.axes]`: values {#sweep-values}\n")
        forms = ("list",) + tuple(sf.GENERATORS) + tuple(sf.RANDOM_GENERATORS)
        rows = []
        for form in forms:
            if form not in VALUE_FORM_DESCRIPTIONS:
                self.problems.append(f"sweep value form {form!r} has no description in "
                                     "docs/gen_reference.py VALUE_FORM_DESCRIPTIONS")
            toml, text = VALUE_FORM_DESCRIPTIONS.get(form, (f"`{{ {form} = [...] }}`",
                                                            "(no description yet)"))
            rows.append([toml, text])
        for form in VALUE_FORM_DESCRIPTIONS:
            if form not in forms:
                self.problems.append(f"docs/gen_reference.py describes sweep value form {form!r}, "
                                     "which the validator no longer accepts")
        out.append(_table(["form", "values"], rows))

        out.append("\n## Limits {#limits}\n")
        out.append(_table(["what", "limit"], [
            ["values of one sweep axis, or cases of a random design",
             f"{_power(sf.MAX_AXIS_POINTS)} (`scenefile.MAX_AXIS_POINTS`)"],
            ["trajectories of one sweep", f"{_power(sf.MAX_TRAJECTORIES)} (`scenefile.MAX_TRAJECTORIES`)"],
            ["size of a scene file", f"{sf.MAX_SCENE_BYTES >> 20} MiB (`scenefile.MAX_SCENE_BYTES`)"],
            ["fixed steps per trajectory, `t_max / dt`",
             f"{_power(scene_module.MAX_STEPS_PER_TRAJECTORY)} (`scene.MAX_STEPS_PER_TRAJECTORY`)"],
        ]))
        self.check_stale()
        return "\n".join(out) + "\n"

    def variables(self) -> str:
        present = {
            "always": "always",
            "adaptive": "adaptive methods only",
            "diagnostic": "when the scene asks for it (`diagnostics`)",
            "drag": "runs with air drag only",
        }
        out = ["## Per-trajectory outputs {#outputs}\n",
               "One value per trajectory, over the sweep's dimensions (its grid axes, or "
               f"`{schema.CASE_DIM}`), in dataset order.\n"]
        rows = []
        for spec in schema.OUTPUTS.values():
            fill = "" if spec.fill_value is None else "NaN"
            rows.append([f"`{spec.name}`", _units(spec.units) or "`1`", spec.long_name,
                         f"`{spec.dtype}`", present.get(spec.present, spec.present),
                         fill, spec.description])
        out.append(_table(["name", "units", "long_name", "dtype", "present", "missing",
                           "comment"], rows))

        out.append("\n## Status flags {#status}\n")
        out.append("`status` carries CF `flag_values`, `flag_meanings` and `flag_descriptions`:\n")
        out.append(_table(["flag_value", "flag_meaning", "description"],
                          [[code, f"`{name}`", meaning] for code, name, meaning in STATUS_TABLE]))

        out.append("\n## Sweep coordinates {#axes}\n")
        out.append("Each swept axis is a coordinate: over its own dimension in a grid, over "
                   f"`{schema.CASE_DIM}` in cases and random designs.\n")
        rows = [[f"`{s.name}`", _units(s.units) or "`1`", s.long_name, s.description]
                for s in schema.AXES.values()]
        seen = set()
        for family in FAMILIES.values():
            for p in family.parameters:
                if (p.name, p.long_name) in seen:
                    continue
                seen.add((p.name, p.long_name))
                owners = [f"`{n}`" for n, f in FAMILIES.items()
                          if any((q.name, q.long_name) == (p.name, p.long_name)
                                 for q in f.parameters)]
                rows.append([f"`{p.name}`", _units(p.units) or "`1`", p.long_name,
                             f"ramp parameter of {', '.join(owners)}"])
        out.append(_table(["name", "units", "long_name", "description"], rows))

        out.append("\n## Recorded trajectories {#traces}\n")
        out.append(f"With `[record]`: over the dimensions `{schema.TRACE_DIMS[0]}` (one per "
                   f"recorded trajectory) and `{schema.TRACE_DIMS[1]}`.\n")
        rows = [[f"`{s.name}`", _units(s.units) or "`1`", s.long_name, s.description]
                for s in schema.TRAJECTORY_RECORD.values()]
        out.append(_table(["name", "units", "long_name", "comment"], rows))
        out.append("\nA curve scene's recorded trajectories ([physics §5.2](../physics.md#s5-2)) "
                   "have, over the same dimensions:\n")
        rows = [[f"`{s.name}`", _units(s.units) or "`1`", s.long_name, s.description]
                for s in schema.CURVE_RECORD.values()]
        out.append(_table(["name", "units", "long_name", "comment"], rows))
        out.append("\nThey have the coordinates `traced_index` (the flat index of the trajectory "
                   "in the sweep), `trace_length` (the number of samples recorded) and "
                   "`traced_<axis>` for each swept axis.")
        out.append(f"\nGlobal attribute `Conventions = \"{schema.CONVENTIONS}\"`.")
        return "\n".join(out) + "\n"

    def families(self) -> str:
        rows = []
        for name, family in FAMILIES.items():
            params = []
            for p in family.parameters:
                bits = [p.units] if p.units not in ("", "1") else []
                if p.default is not None:
                    bits.append(f"default {p.default!r}")
                if p.constraint == "positive":
                    bits.append("> 0")
                params.append(f"`{p.name}`" + (f" ({', '.join(bits)})" if bits else ""))
            params += [f"`{d}`" for d in family.data_names]
            rows.append([f"[`{name}`](../reference/scene-file.md#family-{name})",
                         family.description, "; ".join(params)])
        return _table(["family", "shape", "parameters"], rows) + "\n"

    def cli(self) -> str:
        from rampwork.cli import build_parser

        old = os.environ.get("COLUMNS")
        os.environ["COLUMNS"] = "96"
        try:
            # the command as typed after the quick start (the venv not activated), not as
            # this process was started (build_parser() would name mkdocs' interpreter)
            parser = build_parser(COMMAND)
            out = ["## `rampwork` {#rampwork}\n", "```text", parser.format_help().rstrip(), "```"]
            commands = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
            for name, sub in commands.choices.items():
                out += [f"\n## `rampwork {name}` {{#{name}}}\n", "```text",
                        sub.format_help().rstrip(), "```"]
            # the parser's help names this machine's core count: not the reader's
            cores = f"here {os.cpu_count() or '?'} cores"
            out = [line.replace(cores, "here: this machine's cores") for line in out]
        finally:
            if old is None:
                del os.environ["COLUMNS"]
            else:
                os.environ["COLUMNS"] = old
        return "\n".join(out) + "\n"

    def examples(self) -> str:
        from rampwork.cli import example_names, example_text

        out = []
        for name in example_names():
            text = example_text(name)
            out += [f"\n### `{name}` {{#example-{name.replace('_', '-')}}}\n",
                    f"`{COMMAND} example {name} > {name}.toml`\n", "```toml", text.rstrip(), "```"]
        return "\n".join(out) + "\n"


#: page part name -> method of Reference
PARTS = {
    "scene-file": Reference.scene_file,
    "variables": Reference.variables,
    "families": Reference.families,
    "cli": Reference.cli,
    "examples": Reference.examples,
}


def generate(part: str) -> tuple[str, list[str]]:
    """(Markdown, problems) of one generated part."""
    if part not in PARTS:
        raise KeyError(f"unknown generated part {part!r}; known: {', '.join(PARTS)}")
    reference = Reference()
    buffer = io.StringIO()
    with redirect_stdout(buffer):  # nothing may print into the page
        text = PARTS[part](reference)
    return text, reference.problems


def main(argv: list[str]) -> int:
    if len(argv) != 1 or argv[0] not in PARTS:
        print(f"usage: python docs/gen_reference.py {{{','.join(PARTS)}}}", file=sys.stderr)
        return 2
    text, problems = generate(argv[0])
    print(text)
    for problem in problems:
        print(f"problem: {problem}", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
