"""The command line, in-process through ``main(argv)`` (and once as a real
``python -m rampwork`` process): help, examples, check, run, info, --set and
the one-line errors with exit status 2."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from rampwork import cli, io, runner
from rampwork.cli import main
from rampwork.scenefile import load_scene, parse_scene

COMMANDS = ("run", "check", "example", "info")
EXAMPLE = "straight"  # 12 short trajectories on one small kernel


def example_path(tmp_path, name=EXAMPLE):
    path = tmp_path / f"{name}.toml"
    path.write_text(cli.example_text(name), encoding="utf-8")
    return path


def error_line(capsys) -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("rampwork: error: "), err
    assert "Traceback" not in err
    return lines[0]


def no_simulation(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("simulate must not run")

    monkeypatch.setattr(runner, "simulate", refuse)


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    """One real run of the example, shared by the tests that read its output."""
    directory = tmp_path_factory.mktemp("run")
    scene = example_path(directory)
    output = directory / "out.nc"
    status = main(["run", str(scene), "-o", str(output), "--threads", "1"])
    assert status == 0
    return scene, output


# ----------------------------------------------------------------------------
# help and usage
# ----------------------------------------------------------------------------


def test_help_lists_every_command(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    for command in COMMANDS:
        assert command in out
    assert "Coulomb friction" in out


@pytest.mark.parametrize("command", COMMANDS)
def test_command_help(capsys, command):
    assert main([command, "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: rampwork {command}")


def test_run_help_explains_every_option(capsys):
    main(["run", "--help"])
    out = capsys.readouterr().out
    for option in ("--output", "--overwrite", "--threads", "--set", "--quiet", "default"):
        assert option in out


@pytest.mark.parametrize("argv", [[], ["run"], ["run", "x.toml"], ["frobnicate"]])
def test_usage_errors_exit_2(capsys, argv):
    assert main(argv) == 2
    assert "usage:" in capsys.readouterr().err


def test_version(capsys):
    assert main(["--version"]) == 0
    assert "rampwork" in capsys.readouterr().out


# ----------------------------------------------------------------------------
# example
# ----------------------------------------------------------------------------


def test_example_lists_the_scenes(capsys):
    assert main(["example"]) == 0
    out = capsys.readouterr().out
    for name in ("straight", "bowl_reversals", "dome_liftoff", "sine", "quadratic_grid", "cycloid",
                 "spline", "random_design"):
        assert name in out


@pytest.mark.parametrize("name", ["bowl_reversals", "cycloid.toml"])
def test_example_prints_a_scene(capsys, name):
    assert main(["example", name]) == 0
    text = capsys.readouterr().out
    scene, sweep = parse_scene(text)
    assert scene.title and sweep.size > 1


def test_unknown_example(capsys):
    assert main(["example", "nope"]) == 2
    line = error_line(capsys)
    assert "nope" in line and "straight" in line


# ----------------------------------------------------------------------------
# check
# ----------------------------------------------------------------------------


def test_check(capsys, tmp_path, monkeypatch):
    no_simulation(monkeypatch)
    path = example_path(tmp_path, "quadratic_grid")
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "OK" in out and "trajectories  45" in out
    assert "(5, 3, 3)" in out and "curvature 5 x mu 3 x x0 3" in out


def test_check_with_set(capsys, tmp_path):
    path = example_path(tmp_path)
    assert main(["check", str(path), "--set", "sweep.axes.mu=[0.1, 0.2]", "--set", "integrator.dt=2e-3"]) == 0
    out = capsys.readouterr().out
    assert "trajectories  2" in out and "dt = 0.002" in out


def test_check_x0_outside_the_domain(capsys, tmp_path):
    path = example_path(tmp_path)
    assert main(["check", str(path), "--set", "x0=5.0"]) == 2
    line = error_line(capsys)
    assert str(path) in line and "x0" in line and "outside" in line


def test_check_bad_scene(capsys, tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(cli.example_text(EXAMPLE).replace("dt = 1e-3", "dtt = 1e-3"), encoding="utf-8")
    assert main(["check", str(path)]) == 2
    assert "[integrator] unknown key 'dtt'" in error_line(capsys)


def test_check_missing_and_non_utf8_files(capsys, tmp_path):
    assert main(["check", str(tmp_path / "missing.toml")]) == 2
    assert "no such file" in error_line(capsys)
    path = tmp_path / "latin1.toml"
    path.write_bytes(b'title = "gliss\xe9e"\n')
    assert main(["check", str(path)]) == 2
    assert "not UTF-8" in error_line(capsys)


# ----------------------------------------------------------------------------
# run
# ----------------------------------------------------------------------------


def test_run_writes_a_readable_dataset(result, capsys):
    scene_path, output = result
    dataset = io.open_dataset(output)
    assert dataset.attrs["n_trajectories"] == 12
    assert dataset.sizes["mu"] == 12
    assert parse_scene(dataset.attrs["rampwork_scene"]) == load_scene(scene_path)
    # W = mu m g |dx| on a straight ramp
    assert abs(dataset["W_excess"]).max() < 1e-9


def test_run_summary(capsys, tmp_path):
    scene = example_path(tmp_path)
    output = tmp_path / "summary.nc"
    assert main(["run", str(scene), "-o", str(output)]) == 0
    out = capsys.readouterr().out
    for fragment in ("trajectories  12", "compile time", "run time", "trajectories/s, closed form",
                     "kernel        closed form", "status", "stuck 2", "exited 10", str(output)):
        assert fragment in out, out
    # the same scene stepped (a straight ramp's closed form turned off)
    stepped = tmp_path / "stepped.nc"
    assert main(["run", str(scene), "-o", str(stepped), "--set", "integrator.closed_form=false"]) == 0
    out = capsys.readouterr().out
    for fragment in ("trajectory-steps/s", "kernel        stepping: rk4", "stuck 2", "exited 10"):
        assert fragment in out, out


def test_run_refuses_to_overwrite(result, capsys, monkeypatch):
    scene, output = result
    before = output.read_bytes()
    no_simulation(monkeypatch)
    assert main(["run", str(scene), "-o", str(output)]) == 2
    line = error_line(capsys)
    assert str(output) in line and "--overwrite" in line
    assert output.read_bytes() == before


def test_run_overwrite_and_set(capsys, tmp_path):
    scene = example_path(tmp_path)
    output = tmp_path / "out.nc"
    output.write_bytes(b"old")
    assert main(["run", str(scene), "-o", str(output), "--overwrite", "--quiet",
                 "--set", "integrator.dt=2e-3", "--set", "sweep.axes.mu=[0.1, 0.3]", "--set", "m=3"]) == 0
    assert capsys.readouterr().out == ""
    dataset = io.open_dataset(output)
    scene2, sweep2 = parse_scene(dataset.attrs["rampwork_scene"])
    assert scene2.integrator.dt == 2e-3 and scene2.m == 3.0
    assert list(dataset["mu"].values) == [0.1, 0.3] and sweep2.names == ("mu",)
    assert not list(tmp_path.glob(".out.nc.*"))  # no temporary files left


def test_bad_scene_writes_nothing(capsys, tmp_path, monkeypatch):
    no_simulation(monkeypatch)
    path = tmp_path / "bad.toml"
    path.write_text(cli.example_text(EXAMPLE).replace("mu_k = 0.2", "mu_k = nan"), encoding="utf-8")
    output = tmp_path / "out.nc"
    assert main(["run", str(path), "-o", str(output)]) == 2
    line = error_line(capsys)
    assert str(path) in line and "friction.mu_k" in line
    assert not output.exists() and os.listdir(tmp_path) == ["bad.toml"]


def test_x0_outside_the_domain_refused_before_running(capsys, tmp_path, monkeypatch):
    no_simulation(monkeypatch)
    scene = example_path(tmp_path)
    output = tmp_path / "out.nc"
    assert main(["run", str(scene), "-o", str(output), "--set", "x0=-1.0"]) == 2
    assert "x0" in error_line(capsys)
    assert not output.exists()


def test_bad_set_value(capsys, tmp_path, monkeypatch):
    no_simulation(monkeypatch)
    scene = example_path(tmp_path)
    assert main(["run", str(scene), "-o", str(tmp_path / "o.nc"), "--set", "integrator.dt=-1"]) == 2
    assert "integrator.dt" in error_line(capsys)
    assert main(["run", str(scene), "-o", str(tmp_path / "o.nc"), "--set", "nonsense"]) == 2
    assert "KEY=VALUE" in error_line(capsys)


def test_unwritable_output_refused_before_running(capsys, tmp_path, monkeypatch):
    no_simulation(monkeypatch)
    scene = example_path(tmp_path)
    assert main(["run", str(scene), "-o", str(tmp_path / "missing" / "out.nc")]) == 2
    assert "does not exist" in error_line(capsys)
    assert main(["run", str(scene), "-o", str(tmp_path)]) == 2
    error_line(capsys)


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root can write anywhere")
def test_read_only_directory_refused_before_running(capsys, tmp_path, monkeypatch):
    no_simulation(monkeypatch)
    scene = example_path(tmp_path)
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        assert main(["run", str(scene), "-o", str(locked / "out.nc")]) == 2
        assert "not writable" in error_line(capsys)
    finally:
        locked.chmod(0o700)


def test_too_many_threads(capsys, tmp_path, monkeypatch):
    no_simulation(monkeypatch)
    scene = example_path(tmp_path)
    assert main(["run", str(scene), "-o", str(tmp_path / "o.nc"), "--threads", "100000"]) == 2
    assert "threads" in error_line(capsys)
    assert not (tmp_path / "o.nc").exists()


def test_interrupt_exits_130(capsys, tmp_path, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    from rampwork import streaming

    monkeypatch.setattr(streaming.SweepToFile, "run", interrupted)  # `run` streams through it
    scene = example_path(tmp_path)
    output = tmp_path / "out.nc"
    assert main(["run", str(scene), "-o", str(output)]) == 130
    assert capsys.readouterr().err.strip().endswith("interrupted")
    assert not output.exists()


# ----------------------------------------------------------------------------
# info
# ----------------------------------------------------------------------------


def test_info(result, capsys):
    _, output = result
    assert main(["info", str(output)]) == 0
    out = capsys.readouterr().out
    for fragment in ("mu = 12", "W_friction", "[J]", "[m s-1]", "stuck 2", "exited 10", "[ramp]",
                     'family = "straight"', "compile", "Block on a straight ramp"):
        assert fragment in out, fragment
    assert main(["info", "--no-scene", str(output)]) == 0
    assert "[ramp]" not in capsys.readouterr().out


def test_info_bad_files(capsys, tmp_path):
    assert main(["info", str(tmp_path / "missing.nc")]) == 2
    assert "no such file" in error_line(capsys)
    junk = tmp_path / "junk.nc"
    junk.write_bytes(b"not netcdf")
    assert main(["info", str(junk)]) == 2
    error_line(capsys)


# ----------------------------------------------------------------------------
# a real process: no traceback, exit status 2
# ----------------------------------------------------------------------------


def test_python_m_rampwork_bad_file(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("[ramp]\nfamily = 'quadratic'\ncurvature = 'steep'\ndomain = [0, 1]\n", encoding="utf-8")
    output = tmp_path / "out.nc"
    proc = subprocess.run([sys.executable, "-m", "rampwork", "run", str(path), "-o", str(output)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rampwork: error: "), proc.stderr
    assert "ramp.curvature" in lines[0] and "Traceback" not in proc.stderr
    assert not output.exists()


def test_set_of_a_swept_value_is_noted(capsys, tmp_path):
    path = example_path(tmp_path)  # sweeps mu
    assert main(["check", str(path), "--set", "friction.mu_k=0.3"]) == 0
    assert "no effect" in capsys.readouterr().err
