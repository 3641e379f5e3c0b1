"""Scene files: the shipped examples, dump -> parse round trips, sweep
expansions, overrides, and one-line errors naming the file and the key."""

from __future__ import annotations

import math
from importlib import resources

import numpy as np
import pytest

from rampwork import scenefile
from rampwork.errors import ConfigError
from rampwork.ramps import Ramp
from rampwork.scene import Friction, Integrator, Record, Scene, Sweep
from rampwork.scenefile import apply_overrides, dump_scene, load_scene, parse_scene, read_toml

EXAMPLES_DIR = resources.files("rampwork").joinpath("examples")
EXAMPLES = sorted(entry.name[:-5] for entry in EXAMPLES_DIR.iterdir() if entry.name.endswith(".toml"))
REQUIRED_EXAMPLES = ("straight", "bowl_reversals", "dome_liftoff", "sine", "quadratic_grid", "cycloid",
                     "spline", "random_design")


def example_text(name: str) -> str:
    return EXAMPLES_DIR.joinpath(f"{name}.toml").read_text(encoding="utf-8")


BASE = """\
x0 = -0.5
[ramp]
family = "quadratic"
curvature = 1.0
domain = [-1.0, 1.0]
[friction]
mu_k = 0.2
"""


def parse(text: str):
    return parse_scene(text, "scene.toml")


def test_required_examples_are_shipped():
    assert set(REQUIRED_EXAMPLES) <= set(EXAMPLES)


# ----------------------------------------------------------------------------
# examples and round trips
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("name", EXAMPLES)
def test_example_parses(name):
    scene, sweep = parse_scene(example_text(name), f"{name}.toml")
    assert isinstance(scene, Scene) and isinstance(sweep, Sweep)
    assert scene.title and sweep.size >= 1
    lo, hi = scene.ramp.domain
    x0 = sweep.values("x0") if "x0" in sweep.names else np.array([scene.x0])
    assert ((x0 >= lo) & (x0 <= hi)).all()
    assert sweep.size <= 1000  # examples stay quick to run


@pytest.mark.parametrize("name", EXAMPLES)
def test_example_round_trip(name):
    scene, sweep = parse_scene(example_text(name), f"{name}.toml")
    text = dump_scene(scene, sweep)
    again = parse_scene(text, "dumped.toml")
    assert again == (scene, sweep)
    assert dump_scene(*again) == text  # stable


def test_load_scene_reads_a_file(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(example_text("bowl_reversals"), encoding="utf-8")
    assert load_scene(path) == parse_scene(example_text("bowl_reversals"))
    assert load_scene(str(path)) == load_scene(path)


def _every_kind_of_scene():
    spline = Ramp.create("spline", x_points=[0.0, 0.3, 1.1, 2.0], y_points=[1.0, 0.4, 0.35, 0.0])
    bowl = Ramp.create("circular_bowl", radius=1.7, x_centre=0.1, y_bottom=0.3, domain=(-1.5, 1.6))
    tricky = [0.1 + 0.2, 5e-324, -0.0, 1e300, -1.2345678901234567e-200, 2.0 ** 0.5, 1 / 3]
    yield (Scene(ramp=spline, x0=0.05, friction=Friction(0.1, 0.3), record=Record(indices=(0, 2))),
           Sweep.grid(v0=tricky))
    yield (Scene(ramp=bowl, friction=Friction(0.1), integrator=Integrator("euler", 1e-4),
                 contact="two_sided", t_max=1.5, m=0.3, g=1.62,
                 title='quotes " and \\ back\tslash\nnew line, \x01 control, \x7f, ünïcödé ⛰'),
           Sweep.cases(x0=[-1.0, 0.0, 1.0], mu=[0.0, 0.1, 0.2]))
    yield Scene(ramp=bowl, x0=0.3), None
    yield Scene(ramp=bowl, x0=0.3), Sweep.single()
    yield Scene(ramp=bowl, x0=0.3), Sweep((), "cases")
    yield (Scene(ramp=Ramp.create("sine", amplitude=0.1, wavenumber=2.0, domain=(0.0, 3.0)), x0=1e-17),
           Sweep.random(50, 7, log=("wavenumber",), wavenumber=(0.5, 8.0), mu=(0.0, 0.4)))
    yield (Scene(ramp=Ramp.create("straight", slope=-0.3, domain=(0, 1)), x0=0.0),
           Sweep.grid(x0=np.linspace(0.0, 1.0, 1001), mu_k=np.linspace(0.0, 0.3, 7) ** 2))


@pytest.mark.parametrize("scene, sweep", list(_every_kind_of_scene()))
def test_round_trip_is_exact(scene, sweep):
    text = dump_scene(scene, sweep)
    scene2, sweep2 = parse_scene(text)
    assert scene2 == scene
    assert sweep2 == (Sweep.single() if sweep is None else sweep)
    for (name, a), (_, b) in zip((sweep or Sweep.single()).axes, sweep2.axes):
        assert np.asarray(a).tobytes() == np.asarray(b).tobytes(), name  # bit for bit, sign of zero too
    assert "\n" not in scene2.title or scene2.title == scene.title


def test_dump_writes_even_spacing_as_linspace_and_wraps_long_lists():
    scene = Scene(ramp=Ramp.create("straight", slope=-0.3, domain=(0, 1)))
    sweep = Sweep.cases(x0=np.linspace(0.0, 1.0, 200), mu=np.random.default_rng(0).random(200))
    text = dump_scene(scene, sweep)
    assert "x0 = { linspace = [0.0, 1.0, 200] }" in text
    assert max(len(line) for line in text.splitlines()) <= 110
    assert parse_scene(text)[1] == sweep


def test_dump_random_design_as_its_recipe():
    scene, sweep = parse_scene(example_text("random_design"))
    assert sweep.kind == "random" and sweep.design is not None
    text = dump_scene(scene, sweep)
    data = read_toml(text)
    assert {key: data["sweep"][key] for key in ("kind", "n", "seed")} == {"kind": "random", "n": 200, "seed": 1}
    assert data["sweep"]["axes"] == {"mu": {"uniform": [0.05, 0.4]}, "curvature": {"loguniform": [0.1, 3.0]},
                                     "x0": {"uniform": [-0.9, -0.1]}}


def test_dump_refuses_callable_ramps():
    ramp = Ramp.from_functions(lambda x: 0.5 * x * x, lambda x: x, lambda x: 1.0, domain=(-1.0, 1.0),
                               curvature_sign=1)
    with pytest.raises(ConfigError, match="ramp"):
        dump_scene(Scene(ramp=ramp, x0=0.0))


def test_dump_refuses_non_scenes():
    with pytest.raises(ConfigError):
        dump_scene("not a scene")


# ----------------------------------------------------------------------------
# sweep expansions and defaults
# ----------------------------------------------------------------------------


def test_defaults_match_the_dataclasses():
    scene, sweep = parse(BASE)
    assert sweep == Sweep.single()
    assert scene == Scene(ramp=Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0)),
                          friction=Friction(0.2), x0=-0.5)
    assert scene.friction.mu_s == 0.2


def test_linspace_logspace_arange():
    _, sweep = parse(BASE + """
[sweep]
kind = "grid"
[sweep.axes]
x0 = { linspace = [-0.9, 0.9, 19] }
v0 = { logspace = [-2, 1, 4] }
curvature = { arange = [0.5, 2.0, 0.5] }
mu = [0.1, 0.2, 0.3]
m = 2
""")
    assert sweep.kind == "grid" and sweep.names == ("x0", "v0", "curvature", "mu", "m")
    assert sweep.shape == (19, 4, 3, 3, 1)
    np.testing.assert_array_equal(sweep.values("x0"), np.linspace(-0.9, 0.9, 19))
    np.testing.assert_array_equal(sweep.values("v0"), np.logspace(-2, 1, 4))
    np.testing.assert_array_equal(sweep.values("curvature"), [0.5, 1.0, 1.5])  # stop excluded
    np.testing.assert_array_equal(sweep.values("mu"), [0.1, 0.2, 0.3])
    np.testing.assert_array_equal(sweep.values("m"), [2.0])


def test_linspace_of_one_point_and_negative_step_arange():
    _, sweep = parse(BASE + "[sweep.axes]\nx0 = { linspace = [0.25, 0.9, 1] }\n"
                            "mu = { arange = [0.3, 0.0, -0.1] }\n")
    np.testing.assert_array_equal(sweep.values("x0"), [0.25])
    np.testing.assert_array_equal(sweep.values("mu"), np.arange(0.3, 0.0, -0.1))


def test_cases():
    _, sweep = parse(BASE + "[sweep]\nkind = 'cases'\n[sweep.axes]\nx0 = [0.1, 0.2]\n"
                            "mu = { linspace = [0.0, 0.5, 2] }\n")
    assert sweep == Sweep.cases(x0=[0.1, 0.2], mu=[0.0, 0.5])
    assert sweep.dims == ("case",)


def test_random_design_matches_sweep_random():
    _, sweep = parse(BASE + """
[sweep]
kind = "random"
n = 100
seed = 3
[sweep.axes]
mu = { uniform = [0.05, 0.4] }
curvature = { loguniform = [0.1, 3.0] }
""")
    expected = Sweep.random(100, 3, log=("curvature",), mu=(0.05, 0.4), curvature=(0.1, 3.0))
    assert sweep == expected
    assert sweep.kind == "random" and sweep.shape == (100,) and sweep.dims == ("case",)
    assert 0.05 <= sweep.values("mu").min() and sweep.values("mu").max() <= 0.4
    c = sweep.values("curvature")
    assert 0.1 <= c.min() and c.max() <= 3.0
    # default seed 0, reproducible
    text = BASE + "[sweep]\nkind = 'random'\nn = 5\n[sweep.axes]\nx0 = { uniform = [-1, 1] }\n"
    assert parse(text) == parse(text)
    assert parse(text)[1] == Sweep.random(5, 0, x0=(-1, 1))


def test_random_example_is_reproducible_from_its_dump():
    scene, sweep = parse_scene(example_text("random_design"))
    assert sweep.size == 200
    assert parse_scene(dump_scene(scene, sweep)) == (scene, sweep)


def test_x0_may_be_left_to_the_sweep():
    scene, sweep = parse(BASE.replace("x0 = -0.5\n", "") + "[sweep.axes]\nx0 = [0.0, 0.5]\n")
    assert scene.x0 is None and sweep.names == ("x0",)


def test_bom_and_int_values_are_accepted():
    scene, _ = parse("\ufeff" + BASE.replace("x0 = -0.5", "x0 = 0\nt_max = 5"))
    assert scene.x0 == 0.0 and isinstance(scene.x0, float) and scene.t_max == 5.0


# ----------------------------------------------------------------------------
# overrides
# ----------------------------------------------------------------------------


def test_apply_overrides():
    data = read_toml(BASE)
    apply_overrides(data, ["integrator.dt=1e-4", "friction.mu_k=0.25", "contact=two_sided",
                           "title=a study", "record.count=2", "sweep.axes.mu=[0.1, 0.2]",
                           'integrator.method="euler"'])
    scene, sweep = scenefile.scene_from_dict(data, "scene.toml")
    assert scene.integrator == Integrator("euler", 1e-4)
    assert scene.friction.mu_k == 0.25 and scene.contact == "two_sided"
    assert scene.title == "a study" and scene.record.count == 2
    assert sweep == Sweep.grid(mu=[0.1, 0.2])


@pytest.mark.parametrize("override, match", [
    ("integrator", "KEY=VALUE"),
    ("=3", "bad key"),
    ("x0.y=3", "x0 is not a table"),
    ("integrator.dtt=1", r"\[integrator\] unknown key 'dtt'"),
    ("x0=nan", "x0"),
    ("friction.mu_k=lots", "friction.mu_k"),
])
def test_bad_overrides(tmp_path, override, match):
    path = tmp_path / "scene.toml"
    path.write_text(BASE, encoding="utf-8")
    with pytest.raises(ConfigError, match=match):
        load_scene(path, [override])


# ----------------------------------------------------------------------------
# errors: one line, naming the file and the key
# ----------------------------------------------------------------------------

BAD = {
    "unknown top-level key": ("colour = 'red'\n" + BASE, ["colour", "top-level", "allowed", "t_max"]),
    "mistyped integrator key": (BASE + "[integrator]\ndtt = 1e-3\n",
                                ["[integrator] unknown key 'dtt'", "allowed: method, dt"]),
    "unknown family": (BASE.replace('"quadratic"', '"parabola"'), ["ramp.family", "parabola", "quadratic"]),
    "unknown ramp parameter": (BASE.replace("curvature = 1.0", "curvature = 1.0\nradius = 2.0"),
                               ["[ramp]", "radius", "curvature"]),
    "missing ramp parameter": (BASE.replace("curvature = 1.0\n", ""), ["ramp.curvature", "required"]),
    "negative mu": (BASE.replace("mu_k = 0.2", "mu_k = -0.2"), ["friction.mu_k", ">= 0"]),
    "mu_s below mu_k": (BASE.replace("mu_k = 0.2", "mu_k = 0.2\nmu_s = 0.1"), ["friction.mu_s", "mu_k"]),
    "nan literal": (BASE.replace("x0 = -0.5", "x0 = nan"), ["x0", "finite"]),
    "nan string": (BASE.replace("x0 = -0.5", 'x0 = "nan"'), ["x0", "'nan'"]),
    "inf": (BASE.replace("mu_k = 0.2", "mu_k = inf"), ["friction.mu_k", "finite"]),
    "inf in a sweep": (BASE + "[sweep.axes]\nv0 = [1.0, -inf]\n", ["sweep.axes.v0[1]", "finite"]),
    "dt zero": (BASE + "[integrator]\ndt = 0.0\n", ["integrator.dt", "> 0"]),
    "dt negative": (BASE + "[integrator]\ndt = -1e-3\n", ["integrator.dt", "> 0"]),
    "dt string": (BASE + "[integrator]\ndt = '1e-3'\n", ["integrator.dt", "'1e-3'"]),
    "unknown method": (BASE + "[integrator]\nmethod = 'rk45'\n", ["integrator.method", "rk4"]),
    "unknown contact": ("contact = 'three_sided'\n" + BASE, ["contact", "two_sided"]),
    "bool as number": (BASE.replace("x0 = -0.5", "x0 = true"), ["x0", "bool"]),
    "huge integer": (BASE.replace("x0 = -0.5", "x0 = 1" + "0" * 400), ["x0", "too large"]),
    "domain of three": (BASE.replace("[-1.0, 1.0]", "[-1.0, 0.0, 1.0]"), ["ramp.domain", "2"]),
    "circle domain reaching the rim": (BASE.replace('"quadratic"', '"circular_bowl"').replace("curvature", "radius"),
                                       ["ramp.domain", "vertical tangent"]),
    "no ramp": ("x0 = 0.0\n", ["ramp", "required"]),
    "ramp not a table": ("ramp = 'quadratic'\n", ["ramp", "table"]),
    "list for a scalar": (BASE.replace("curvature = 1.0", "curvature = [1.0, 2.0]"),
                          ["ramp.curvature", "[sweep.axes]"]),
    "axis outside [sweep.axes]": (BASE + "[sweep]\nmu = [0.1]\n", ["[sweep]", "'mu'", "[sweep.axes]"]),
    "unknown axis": (BASE + "[sweep.axes]\nradius = [0.1]\n", ["[sweep.axes]", "radius", "curvature"]),
    "unknown sweep kind": (BASE + "[sweep]\nkind = 'latin'\n", ["sweep.kind", "random"]),
    "unknown generator": (BASE + "[sweep.axes]\nx0 = { lnspace = [0, 1, 3] }\n",
                          ["[sweep.axes.x0]", "lnspace", "linspace"]),
    "two generators": (BASE + "[sweep.axes]\nx0 = { linspace = [0, 1, 3], arange = [0, 1, 0.5] }\n",
                       ["sweep.axes.x0", "exactly one"]),
    "linspace num zero": (BASE + "[sweep.axes]\nx0 = { linspace = [0.0, 1.0, 0] }\n",
                          ["sweep.axes.x0.linspace", "num", ">= 1"]),
    "linspace num negative": (BASE + "[sweep.axes]\nx0 = { linspace = [0.0, 1.0, -5] }\n",
                              ["sweep.axes.x0.linspace", "num"]),
    "linspace num float": (BASE + "[sweep.axes]\nx0 = { linspace = [0.0, 1.0, 5.0] }\n",
                           ["sweep.axes.x0.linspace", "integer"]),
    "linspace of two": (BASE + "[sweep.axes]\nx0 = { linspace = [0.0, 1.0] }\n",
                        ["sweep.axes.x0.linspace", "[start, stop, num]"]),
    "empty list": (BASE + "[sweep.axes]\nx0 = []\n", ["sweep.axes.x0", "at least one"]),
    "mixed list": (BASE + "[sweep.axes]\nx0 = [0.1, 'a']\n", ["sweep.axes.x0[1]", "'a'"]),
    "arange step zero": (BASE + "[sweep.axes]\nx0 = { arange = [0.0, 1.0, 0.0] }\n",
                         ["sweep.axes.x0.arange", "step"]),
    "arange empty": (BASE + "[sweep.axes]\nx0 = { arange = [1.0, 0.0, 0.1] }\n",
                     ["sweep.axes.x0.arange", "no values"]),
    "arange too long": (BASE + "[sweep.axes]\nx0 = { arange = [0.0, 1.0, 1e-12] }\n",
                        ["sweep.axes.x0.arange", "1e+08"]),
    "axis too long": (BASE + "[sweep.axes]\nx0 = { linspace = [0.0, 1.0, 1000000000] }\n",
                      ["sweep.axes.x0.linspace", "1e+08"]),
    "1e12-point grid": (BASE + "[sweep.axes]\nx0 = { linspace = [-1, 1, 1000000] }\n"
                               "mu = { linspace = [0, 1, 1000000] }\n", ["sweep", "1e+12", "1e+09"]),
    "logspace overflow": (BASE + "[sweep.axes]\nv0 = { logspace = [0, 400, 3] }\n",
                          ["sweep.axes.v0.logspace", "308"]),
    "cases of unequal length": (BASE + "[sweep]\nkind = 'cases'\n[sweep.axes]\nx0 = [0.1, 0.2]\nmu = [0.1]\n",
                                ["sweep", "one length"]),
    "mu with mu_k": (BASE + "[sweep.axes]\nmu = [0.1]\nmu_k = [0.1]\n", ["mu", "mu_k"]),
    "n without random": (BASE + "[sweep]\nn = 10\n", ["sweep.n", "random"]),
    "random n zero": (BASE + "[sweep]\nkind = 'random'\nn = 0\n[sweep.axes]\nx0 = { uniform = [0, 1] }\n",
                      ["sweep.n", ">= 1"]),
    "random n huge": (BASE + "[sweep]\nkind = 'random'\nn = 1000000000000\n[sweep.axes]\n"
                             "x0 = { uniform = [0, 1] }\n", ["sweep.n", "1e+08"]),
    "random without n": (BASE + "[sweep]\nkind = 'random'\n[sweep.axes]\nx0 = { uniform = [0, 1] }\n",
                         ["sweep.n", "required"]),
    "random with a list": (BASE + "[sweep]\nkind = 'random'\nn = 3\n[sweep.axes]\nx0 = [0.1]\n",
                           ["sweep.axes.x0", "uniform"]),
    "random low above high": (BASE + "[sweep]\nkind = 'random'\nn = 3\n[sweep.axes]\n"
                                     "x0 = { uniform = [1, 0] }\n", ["sweep.axes.x0", "low"]),
    "loguniform from zero": (BASE + "[sweep]\nkind = 'random'\nn = 3\n[sweep.axes]\n"
                                    "v0 = { loguniform = [0, 1] }\n", ["sweep.axes.v0", "low > 0"]),
    "random seed negative": (BASE + "[sweep]\nkind = 'random'\nn = 3\nseed = -1\n[sweep.axes]\n"
                                    "x0 = { uniform = [0, 1] }\n", ["sweep.seed"]),
    "record count float": (BASE + "[record]\ncount = 1.5\n", ["record.count", "integer"]),
    "record unknown key": (BASE + "[record]\nevery_n = 3\n", ["[record]", "every_n", "every"]),
    "friction mu key": (BASE.replace("mu_k = 0.2", "mu = 0.2"), ["[friction]", "'mu'", "mu_k"]),
    "title not a string": ("title = 3\n" + BASE, ["title", "string"]),
    "spline nested list": (BASE.replace('family = "quadratic"\ncurvature = 1.0',
                                        'family = "spline"\nx_points = [0, [1], 2]\ny_points = [0, 1, 2]'),
                           ["ramp.x_points[1]"]),
    "toml syntax error": (BASE + "[integrator\n", ["TOML syntax error", "line 8"]),
    "duplicate key": ("x0 = 1.0\n" + BASE, ["TOML syntax error", "line 2"]),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_input_names_the_key(case):
    text, fragments = BAD[case]
    with pytest.raises(ConfigError) as info:
        parse(text)
    message = str(info.value)
    assert message.startswith("scene.toml: ")
    assert "\n" not in message and len(message) < 400
    for fragment in fragments:
        assert fragment in message, (case, message)


def test_grid_size_is_refused_before_allocating(monkeypatch):
    def boom(*args, **kwargs):  # nothing may be expanded for a refused grid
        raise AssertionError("expanded an axis of a refused grid")

    monkeypatch.setattr(scenefile, "_expand", boom)
    with pytest.raises(ConfigError, match="1e\\+15"):
        parse(BASE + "[sweep.axes]\nx0 = { linspace = [-1, 1, 100000] }\nmu = { linspace = [0, 1, 100000] }\n"
                     "v0 = { linspace = [0, 1, 100000] }\n")


def test_non_utf8_file(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes(BASE.encode() + 'title = "Rampe glissée"\n'.encode("latin-1"))
    with pytest.raises(ConfigError) as info:
        load_scene(path)
    message = str(info.value)
    assert message.startswith(str(path)) and "not UTF-8 text" in message and "line 8" in message
    assert "\n" not in message


def test_missing_file_and_directory(tmp_path):
    with pytest.raises(ConfigError, match="no such file"):
        load_scene(tmp_path / "nope.toml")
    with pytest.raises(ConfigError, match="directory"):
        load_scene(tmp_path)


def test_parse_refuses_non_text():
    with pytest.raises(ConfigError):
        parse_scene(b"x0 = 1")  # type: ignore[arg-type]


def test_module_docstring_documents_the_format():
    doc = scenefile.__doc__
    for word in ("[ramp]", "[friction]", "[integrator]", "[record]", "[sweep]", "[sweep.axes]", "linspace",
                 "logspace", "arange", "uniform", "loguniform", "random", "cases", "grid"):
        assert word in doc
    assert math.isfinite(scenefile.MAX_TRAJECTORIES) and scenefile.MAX_AXIS_POINTS < scenefile.MAX_TRAJECTORIES
