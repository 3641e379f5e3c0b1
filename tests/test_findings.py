"""Issue 18's findings on paths that lose or refuse work badly and on a
newcomer's friction: each test failed before its fix.

None of these compiles a kernel: settings objects, plans, the command line's
checks and ``Ramp.evaluate`` run without one (the SIGTERM test is in
test_streaming.py, beside the kill test whose kernel it shares; the traced
coordinates' units in test_physics.py; the studies' PDF in test_studies.py).
"""

from __future__ import annotations

import errno
import math
import os
import re
import shlex
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import rampwork as rw
from rampwork import cli, io, plan, runner, streaming
from rampwork.cli import main
from rampwork.errors import ClosedFormNotice, ConfigError, RenamedParameterWarning
from rampwork.scenefile import load_scene, parse_scene


def example(tmp_path, name="straight", file="scene.toml") -> Path:
    path = tmp_path / file
    path.write_text(cli.example_text(name), encoding="utf-8")
    return path


def one_line(capsys, kind="error") -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"rampwork: {kind}: "), err
    assert "usage:" not in err and "Traceback" not in err
    return lines[0]


@pytest.fixture
def no_runs(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("nothing may run")

    monkeypatch.setattr(streaming.SweepToFile, "run", refuse)
    monkeypatch.setattr(runner, "simulate", refuse)


# ------------------------------------------------------------------------------
# `rampwork run s.toml -o s.toml --overwrite` replaced the scene with the results
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("spelling", ["same", "dotted", "symlink"])
def test_output_that_is_the_scene_file_is_refused(tmp_path, capsys, monkeypatch, no_runs, spelling):
    scene = example(tmp_path)
    before = scene.read_bytes()
    monkeypatch.chdir(tmp_path)
    output = {"same": "scene.toml", "dotted": "./scene.toml", "symlink": "link.toml"}[spelling]
    if spelling == "symlink":
        (tmp_path / "link.toml").symlink_to(scene)
    assert main(["run", "scene.toml", "-o", output, "--overwrite"]) == 2
    line = one_line(capsys)
    assert "is the scene file" in line and output in line
    assert scene.read_bytes() == before


def test_a_directory_as_output_is_refused(tmp_path, capsys, no_runs):
    scene = example(tmp_path)
    assert main(["run", str(scene), "-o", str(tmp_path), "--overwrite"]) == 2
    assert "is a directory" in one_line(capsys)


# ------------------------------------------------------------------------------
# dt = 1e300, or dt > t_max, passed `rampwork check` and diverged every trajectory
# ------------------------------------------------------------------------------
def _straight_scene(**kwargs):
    return rw.Scene(ramp=rw.Ramp.create("straight", slope=-0.5, domain=(0.0, 2.0)), x0=0.0, **kwargs)


@pytest.mark.parametrize("integrator, t_max", [
    (rw.Integrator("rk4", dt=1e300), 60.0),
    (rw.Integrator("euler", dt=20.0), 10.0),
    (rw.Integrator("rk4", dt=10.0), 10.0),
    (rw.Integrator("dopri5", dt=1e300), 60.0),  # the adaptive pairs' first step
    (rw.Integrator("dop853", dt=11.0, dt_max=20.0), 10.0),
])
def test_a_step_not_shorter_than_t_max_is_refused(integrator, t_max):
    with pytest.raises(ConfigError, match=r"^integrator\.dt: .*shorter than t_max") as error:
        _straight_scene(integrator=integrator, t_max=t_max)
    assert repr(t_max) in str(error.value)


def test_steps_shorter_than_t_max_and_a_large_dt_max_are_accepted():
    _straight_scene(integrator=rw.Integrator("euler", dt=9.0), t_max=10.0)
    _straight_scene(integrator=rw.Integrator("dopri5", dt_max=1e300), t_max=10.0)  # a bound only


def test_check_refuses_dt_beyond_t_max(tmp_path, capsys, no_runs):
    scene = example(tmp_path)
    for value in ("1e300", "10.0", "11.0"):  # the example's t_max is 10 s
        assert main(["check", str(scene), "--set", f"integrator.dt={value}"]) == 2
        line = one_line(capsys)
        assert "integrator.dt" in line and "t_max" in line


# ------------------------------------------------------------------------------
# --threads 0 and --chunk-size 0 printed argparse's usage block
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("option, value", [("--threads", "0"), ("--chunk-size", "0"),
                                           ("--threads", "-2"), ("--chunk-size", "many")])
def test_bad_integer_options_are_one_line_errors(tmp_path, capsys, no_runs, option, value):
    scene = example(tmp_path)
    assert main(["run", str(scene), "-o", str(tmp_path / "out.nc"), option, value]) == 2
    line = one_line(capsys)
    assert line == f"rampwork: error: {option}: expected a positive integer, got {value!r}"
    assert not (tmp_path / "out.nc").exists()


# ------------------------------------------------------------------------------
# rw.write_netcdf({'a': 1}, path) raised a raw AttributeError
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("data", [{"a": 1}, None, xr.DataArray([1.0])])
def test_write_netcdf_refuses_what_is_not_a_dataset(tmp_path, data):
    with pytest.raises(ConfigError, match=r"expected an xarray\.Dataset made by rampwork"):
        rw.write_netcdf(data, tmp_path / "out.nc")
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------------
# -o /proc/x.nc: "not writable: No such file or directory"
# ------------------------------------------------------------------------------
@pytest.mark.skipif(not Path("/proc/self").exists(), reason="needs Linux /proc")
def test_a_folder_that_takes_no_new_files_says_so():
    with pytest.raises(ConfigError) as error:
        io.check_writable("/proc/x.nc")
    message = str(error.value)
    assert message.startswith("/proc/x.nc: cannot create a file in directory '/proc'")
    assert "does not allow new files" in message and "No such file" not in message


@pytest.mark.parametrize("code, words", [(errno.EROFS, "read-only file system"),
                                         (errno.EACCES, "not writable (permission denied)"),
                                         (errno.ENOSPC, "no space left")])
def test_why_no_file_can_be_created(tmp_path, monkeypatch, code, words):
    def refuse(*args, **kwargs):
        raise OSError(code, os.strerror(code))

    monkeypatch.setattr(io.tempfile, "mkstemp", refuse)
    with pytest.raises(ConfigError, match=re.escape(words)):
        io.check_writable(tmp_path / "out.nc")


def test_a_folder_without_write_permission_says_permission_denied(tmp_path, monkeypatch):
    monkeypatch.setattr(io.os, "access", lambda *args, **kwargs: False)
    with pytest.raises(ConfigError, match=r"is not writable \(permission denied\)"):
        io.check_writable(tmp_path / "out.nc")


def test_a_missing_folder_says_it_does_not_exist(tmp_path):
    with pytest.raises(ConfigError, match=r"directory .*missing' does not exist"):
        io.check_writable(tmp_path / "missing" / "out.nc")


# ------------------------------------------------------------------------------
# Scene(x0=10) outside the domain was accepted until simulate
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("x0", [10.0, -0.001, 2.0000001])
def test_a_start_outside_the_domain_is_refused_when_the_scene_is_built(x0):
    with pytest.raises(ConfigError, match=r"^x0: .* is outside the ramp's domain \[0\.0, 2\.0\]"):
        rw.Scene(ramp=rw.Ramp.create("straight", slope=-0.5, domain=(0.0, 2.0)), x0=x0)


def test_a_start_on_the_domain_ends_is_accepted():
    ramp = rw.Ramp.create("straight", slope=-0.5, domain=(0.0, 2.0))
    assert rw.Scene(ramp=ramp, x0=0.0).x0 == 0.0 and rw.Scene(ramp=ramp, x0=2.0).x0 == 2.0


# ------------------------------------------------------------------------------
# `rampwork` is not on the PATH after the quick start: the help shows a command that works
# ------------------------------------------------------------------------------
def test_command_name_is_what_can_be_typed(monkeypatch):
    monkeypatch.setattr(cli.shutil, "which", lambda name: None)
    assert cli.command_name(".venv/bin/rampwork") == ".venv/bin/rampwork"
    assert cli.command_name("rampwork") == "./rampwork"
    python = os.path.relpath(sys.executable)
    expected = python if not python.startswith("..") else sys.executable
    assert cli.command_name("/x/rampwork/__main__.py") == f"{expected} -m rampwork"
    monkeypatch.setattr(cli.shutil, "which", lambda name: {"rampwork": os.path.abspath(".venv/bin/rampwork"),
                                                           "python": sys.executable}.get(name))
    assert cli.command_name(".venv/bin/rampwork") == "rampwork"
    assert cli.command_name("/x/rampwork/__main__.py") == "python -m rampwork"


def _environment_without_rampwork() -> dict:
    env = dict(os.environ)
    folders = [folder for folder in env.get("PATH", "").split(os.pathsep)
               if folder and not (Path(folder) / "rampwork").exists()]
    env["PATH"] = os.pathsep.join(folders)
    # this rampwork, from any folder (a relative PYTHONPATH=src would not reach it)
    env["PYTHONPATH"] = os.pathsep.join([str(Path(rw.__file__).resolve().parents[1])]
                                        + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    return env


def test_the_help_shows_commands_that_work_without_rampwork_on_the_path(tmp_path):
    env = _environment_without_rampwork()
    shown = subprocess.run([sys.executable, "-m", "rampwork", "--help"], capture_output=True, text=True,
                           env=env, cwd=tmp_path, timeout=120)
    assert shown.returncode == 0, shown.stderr
    examples = shown.stdout.split("examples:")[1].splitlines()
    command = next(line for line in examples if "list the example scenes" in line)
    command = command.split("  list the example scenes")[0].strip()
    assert command.endswith(" example") and not command.startswith("rampwork ")
    ran = subprocess.run(shlex.split(command), capture_output=True, text=True, env=env, cwd=tmp_path,
                         timeout=120)
    assert ran.returncode == 0, ran.stderr
    assert "bowl_reversals" in ran.stdout
    assert f"`{command} NAME > scene.toml`" in ran.stdout  # its own hint, the same command
    usage = subprocess.run(shlex.split(command.removesuffix(" example")) + ["run", "--help"],
                           capture_output=True, text=True, env=env, cwd=tmp_path, timeout=120)
    assert usage.stdout.startswith(f"usage: {command.removesuffix(' example')} run")


# ------------------------------------------------------------------------------
# CLI errors used the API's wording ("pass overwrite=True")
# ------------------------------------------------------------------------------
def test_an_existing_output_is_named_in_each_front_ends_words(tmp_path, capsys, no_runs):
    scene = example(tmp_path)
    output = tmp_path / "out.nc"
    output.write_bytes(b"results")
    assert main(["run", str(scene), "-o", str(output)]) == 2
    line = one_line(capsys)
    assert "pass --overwrite" in line and "overwrite=True" not in line and "CLI" not in line
    with pytest.raises(ConfigError) as error:
        rw.write_netcdf(xr.Dataset(), output)
    assert "pass overwrite=True" in str(error.value) and "--overwrite" not in str(error.value)


def test_an_unfinished_run_is_named_in_each_front_ends_words(tmp_path, capsys, no_runs):
    scene = example(tmp_path)
    output = tmp_path / "out.nc"
    streaming.partial_path(output).write_bytes(b"an unfinished run")
    assert main(["run", str(scene), "-o", str(output)]) == 2
    line = one_line(capsys)
    assert "pass --resume" in line and "--overwrite" in line and "=True" not in line
    with pytest.raises(ConfigError) as error:
        rw.run_to_file(*load_scene(scene), output)
    message = str(error.value)
    assert "resume=True" in message and "overwrite=True" in message and "--" not in message


# ------------------------------------------------------------------------------
# sine's slope was the downhill slope; the bowl's bottom sat at -R by default
# ------------------------------------------------------------------------------
def test_sine_mean_slope_is_dy_dx_like_straight_and_quadratic():
    x = np.array([0.0, 1.0, 2.0])
    sine = rw.Ramp.create("sine", mean_slope=0.3, amplitude=0.0, wavenumber=1.0, domain=(0.0, 2.0))
    straight = rw.Ramp.create("straight", slope=0.3, domain=(0.0, 2.0))
    quadratic = rw.Ramp.create("quadratic", slope=0.3, curvature=0.0, domain=(0.0, 2.0))
    for ramp in (sine, straight, quadratic):
        f, fp, _ = ramp.evaluate(x)
        assert f.tolist() == [0.0, 0.3, 0.6] and fp.tolist() == [0.3, 0.3, 0.3], ramp.family
    assert rw.FAMILIES["sine"].parameter_names[0] == "mean_slope"


def test_sine_old_slope_reads_as_minus_mean_slope_with_a_warning():
    with pytest.warns(RenamedParameterWarning, match=r"ramp\.slope: .*downhill slope.*now 'mean_slope'"
                                                     r".*read as mean_slope = -0\.3"):
        old = rw.Ramp.create("sine", slope=0.3, amplitude=0.1, wavenumber=2.0, domain=(0.0, 2.0))
    new = rw.Ramp.create("sine", mean_slope=-0.3, amplitude=0.1, wavenumber=2.0, domain=(0.0, 2.0))
    assert old == new
    with pytest.raises(ConfigError, match=r"ramp\.slope: .*give mean_slope alone"):
        rw.Ramp.create("sine", slope=0.3, mean_slope=-0.3, amplitude=0.1, wavenumber=2.0,
                       domain=(0.0, 2.0))


OLD_SINE_FILE = """\
x0 = 0.0
[ramp]
family = "sine"
slope = 0.3
amplitude = 0.03
wavenumber = 5.0
domain = [0.0, 4.0]
"""


def test_an_old_sine_scene_file_still_runs_with_a_warning(tmp_path, capsys):
    with pytest.warns(RenamedParameterWarning):
        scene, _ = parse_scene(OLD_SINE_FILE)
    assert scene.ramp.param_dict()["mean_slope"] == -0.3
    path = tmp_path / "old.toml"
    path.write_text(OLD_SINE_FILE, encoding="utf-8")
    assert main(["check", str(path)]) == 0
    out, err = capsys.readouterr()
    assert "OK" in out and "mean_slope = -0.3" in out
    assert err.startswith("rampwork: warning: ramp.slope: the sine family's 'slope' was the downhill")
    assert len(err.strip().splitlines()) == 1


def test_a_sweep_over_the_old_names_says_what_changed(tmp_path):
    text = OLD_SINE_FILE.replace("slope = 0.3\n", "") + "[sweep.axes]\nslope = [0.1, 0.2]\n"
    with pytest.raises(ConfigError, match=r"sweep\.axes\.slope: the sine family's 'slope' was the "
                                          r"downhill slope.*now 'mean_slope' \(mean_slope = -slope"):
        parse_scene(text)
    scene = rw.Scene(ramp=rw.Ramp.create("circular_bowl", radius=1.0, domain=(-0.9, 0.9)), x0=0.0)
    with pytest.raises(ConfigError, match=r"sweep\.y_centre: .*now 'y_bottom' \(y_bottom = "
                                          r"y_centre - radius"):
        plan.plan_run(scene, rw.Sweep.grid(y_centre=[0.0, 1.0]))


def test_the_bowl_stands_on_y_equals_zero_by_default():
    ramp = rw.Ramp.create("circular_bowl", radius=2.0, x_centre=0.5, domain=(-1.0, 1.5))
    f, fp, _ = ramp.evaluate([0.5, -1.0])
    assert f[0] == 0.0 and fp[0] == 0.0 and f[1] == pytest.approx(2.0 - math.sqrt(4.0 - 2.25), rel=1e-15)
    lifted = rw.Ramp.create("circular_bowl", radius=2.0, x_centre=0.5, y_bottom=1.0, domain=(-1.0, 1.5))
    assert lifted.evaluate([0.5])[0][0] == 1.0


def test_the_bowl_old_y_centre_reads_as_y_bottom_with_a_warning():
    with pytest.warns(RenamedParameterWarning, match=r"ramp\.y_centre: .*height of the circle's "
                                                     r"centre.*read as y_bottom = -1\.5"):
        old = rw.Ramp.create("circular_bowl", radius=2.0, y_centre=0.5, domain=(-1.0, 1.0))
    assert old == rw.Ramp.create("circular_bowl", radius=2.0, y_bottom=-1.5, domain=(-1.0, 1.0))
    # the dome keeps its centre, whose default puts the dome on y = 0
    dome = rw.Ramp.create("circular_dome", radius=2.0, domain=(-1.0, 1.0))
    assert dome.param_dict()["y_centre"] == 0.0


# ------------------------------------------------------------------------------
# Ramp.from_functions' self-check refused exact derivatives near steep ends
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("edge", [0.99, 0.9999, 1.0 - 1e-7])
def test_exact_derivatives_near_a_vertical_tangent_pass_the_check(edge):
    ramp = rw.Ramp.from_functions(lambda x: -math.sqrt(1.0 - x * x),
                                  lambda x: x / math.sqrt(1.0 - x * x),
                                  lambda x: 1.0 / (1.0 - x * x) ** 1.5,
                                  domain=(-edge, edge), curvature_sign=1)
    assert ramp.curvature_sign() == 1


def test_exact_derivatives_near_a_singular_curvature_pass_the_check():
    rw.Ramp.from_functions(lambda x: x**1.5, lambda x: 1.5 * x**0.5, lambda x: 0.75 / x**0.5,
                           domain=(1e-6, 1.0))


def test_wrong_derivatives_are_still_refused_and_the_error_says_how_to_skip():
    with pytest.raises(ConfigError, match=r"ramp\.fp: does not match .*pass check=False"):
        rw.Ramp.from_functions(lambda x: math.sin(x), lambda x: 1.001 * math.cos(x), lambda x: -math.sin(x),
                               domain=(0.0, 3.0))
    rw.Ramp.from_functions(lambda x: math.sin(x), lambda x: 1.001 * math.cos(x), lambda x: -math.sin(x),
                           domain=(0.0, 3.0), check=False)
    assert "check=False" in rw.Ramp.from_functions.__doc__


# ------------------------------------------------------------------------------
# straight ramps ignored the requested integrator silently
# ------------------------------------------------------------------------------
def _notices(integrator):
    scene = _straight_scene(integrator=integrator)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = plan.plan_run(scene, rw.Sweep.grid(mu=[0.1, 0.2]))
    attrs = runner.attributes(run, 0.0, 0.0, 1, 0)
    return [w for w in caught if issubclass(w.category, ClosedFormNotice)], attrs


def test_a_straight_ramp_says_its_integrator_is_not_used():
    notices, attrs = _notices(rw.Integrator("euler", dt=1e-2))
    assert len(notices) == 1
    assert re.search(r"closed form .*\(euler, dt = 0\.01 s\) is not used; "
                     r"Integrator\(\.\.\., closed_form=False\) steps", str(notices[0].message))
    assert attrs["integrator_used"] == "closed_form" and attrs["integrator_method"] == "euler"
    assert "closed form" in attrs["history"] and "euler not used" in attrs["history"]
    notices, attrs = _notices(rw.Integrator())  # nothing asked for: nothing to say
    assert notices == [] and attrs["integrator_used"] == "closed_form"
    notices, attrs = _notices(rw.Integrator("euler", dt=1e-2, closed_form=False))
    assert notices == [] and attrs["integrator_used"] == "euler"
    for doc in (rw.simulate.__doc__, rw.Ramp.create.__doc__):
        assert "closed form" in doc and "closed_form=False" in doc


def test_the_cli_says_so_where_it_describes_the_integrator(tmp_path, capsys):
    scene = example(tmp_path)
    assert main(["check", str(scene), "--set", "integrator.method=euler"]) == 0
    out, err = capsys.readouterr()
    assert err == ""  # no warning besides: the summary says it
    line = next(line for line in out.splitlines() if line.startswith("integrator"))
    assert line.startswith("integrator    euler, dt = 0.001 s (not used: a straight ramp is solved in "
                           "closed form; closed_form = false under [integrator] steps with it)")
    assert "Integrator(" not in out and "steps per trajectory" not in line


def test_warnings_name_the_users_line(recwarn):
    """ClosedFormNotice and RenamedParameterWarning point at the caller's line,
    not at rampwork's own code (however deep rampwork found them)."""
    import warnings

    import rampwork as rw

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rw.Ramp.create("sine", slope=0.3, amplitude=0.01, wavenumber=3.0, domain=(0.0, 1.0))
        scene = rw.Scene(ramp=rw.Ramp.create("straight", slope=-0.5, domain=(0.0, 1.0)),
                         integrator=rw.Integrator("euler", dt=1e-3), x0=0.0, t_max=5.0)
        rw.simulate(scene)
    kinds = {w.category: w for w in caught}
    assert {rw.RenamedParameterWarning, rw.ClosedFormNotice} <= set(kinds)
    for warning in kinds.values():
        assert warning.filename == __file__, (warning.category, warning.filename)


def test_write_zarr_refuses_what_is_not_a_dataset_before_anything_else(tmp_path):
    import rampwork as rw
    from rampwork.errors import ConfigError

    with pytest.raises(ConfigError, match="made by rampwork"):
        rw.write_zarr({"a": 1}, tmp_path / "no-such-folder" / "x.zarr")


def test_a_chunk_size_that_a_grid_cannot_honour_is_explained(tmp_path, capsys):
    """--chunk-size 20000 on rows of 12,000 gives 12,000-trajectory chunks:
    the run says so, and why (it used to say nothing)."""
    layout = streaming.ChunkLayout.for_shape((10, 12000), 20000)
    assert layout.trajectories == 12000 and layout.count == 10
    text = layout.describe(("mu", "x0"), 20000)
    assert "10 chunks of 12,000 trajectories" in text and "20,000 is rounded down" in text
    assert streaming.ChunkLayout.for_shape((10, 12000), 24000).describe(("mu", "x0"), 24000) == \
        "5 chunks of 24,000 trajectories"
    scene = tmp_path / "grid.toml"
    scene.write_text('title = "chunks"\nt_max = 0.05\n[ramp]\nfamily = "quadratic"\n'
                     'domain = [-1.0, 1.0]\ncurvature = 1.0\n[friction]\nmu_k = 0.1\n'
                     '[integrator]\nmethod = "euler"\ndt = 0.01\n[sweep]\nkind = "grid"\n'
                     '[sweep.axes]\nmu = [0.1, 0.2, 0.3]\nx0 = { linspace = [-0.9, 0.9, 70] }\n')
    assert main(["run", str(scene), "-o", str(tmp_path / "out.nc"), "--chunk-size", "100"]) == 0
    out = capsys.readouterr().out
    assert "chunks       3 chunks of 70 trajectories (1 mu value x the whole x0 (70)" in out
