"""Hostile input to the command line: malformed scene files, absurd sizes,
non-UTF-8 bytes, NaN and infinity in every spelling, paths that cannot be
read or written, bad options.

Every refused run must give exactly one line ``rampwork: error: ...`` on
stderr naming the problem (the file and key, or the option), exit status 2,
no traceback, nothing on stdout, and write nothing: no output file, no
temporary or partial file, and an existing output file left byte for byte
as it was (with or without ``--overwrite``).  Through ``rampwork.cli.main``
in-process, and through real ``python -m rampwork`` processes.

Key-by-key parsing errors are tested in test_scenefile; here each input
goes the whole way through ``rampwork run`` / ``rampwork check``.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from rampwork import kernels, runner, scenefile
from rampwork.cli import main

BASE = """\
title = "adversarial base"
x0 = 0.5
v0 = 0.0
t_max = 2.0

[ramp]
family = "straight"
slope = -0.3
domain = [-1.0, 1.0]

[friction]
mu_k = 0.1

[integrator]
method = "euler"
dt = 1e-3
"""

SWEEP = "\n[sweep]\nkind = \"grid\"\n[sweep.axes]\n"


def with_line(key_line: str, table: str | None = None) -> str:
    """BASE with ``key_line`` added at the top level or at the end of ``[table]``."""
    if table is None:
        return key_line + "\n" + BASE
    head = f"[{table}]\n"
    if head in BASE:
        return BASE.replace(head, head + key_line + "\n")
    return BASE + f"\n{head}{key_line}\n"


def replaced(old: str, new: str) -> str:
    assert old in BASE
    return BASE.replace(old, new)


#: name: (scene file text or bytes, fragments the error line must hold)
BAD_SCENES = {
    # wrong types
    "x0 as a string": (replaced("x0 = 0.5", 'x0 = "0.5"'), ["x0", "'0.5'", "str"]),
    "mu_k as a bool": (replaced("mu_k = 0.1", "mu_k = true"), ["friction.mu_k", "bool"]),
    "dt as a list": (replaced("dt = 1e-3", "dt = [1e-3]"), ["integrator.dt", "list"]),
    "family as a number": (replaced('family = "straight"', "family = 3"), ["ramp.family", "int"]),
    "ramp as a string": ('ramp = "straight"\nx0 = 0.5\n', ["ramp", "table"]),
    "friction as a list": ("friction = [0.1]\n" + replaced("[friction]\nmu_k = 0.1\n", ""), ["friction", "table"]),
    "domain of strings": (replaced("domain = [-1.0, 1.0]", 'domain = ["a", "b"]'), ["ramp.domain[0]", "'a'"]),
    "method as a table": (replaced('method = "euler"', "method = { name = 'euler' }"), ["integrator.method"]),
    "axis of strings": (BASE + SWEEP + 'x0 = ["left", "right"]\n', ["sweep.axes.x0[0]", "'left'"]),
    "record count as a float": (with_line("count = 1.5", "record"), ["record.count", "integer"]),
    "date as a number": (replaced("t_max = 2.0", "t_max = 1979-05-27"), ["t_max", "date"]),
    # unknown keys
    "unknown top-level key": (with_line("colour = 'red'"), ["colour", "top-level", "allowed"]),
    "mistyped key": (replaced("dt = 1e-3", "dtt = 1e-3"), ["[integrator]", "'dtt'", "dt"]),
    "parameter of another family": (replaced("slope = -0.3", "slope = -0.3\nradius = 1.0"), ["[ramp]", "radius"]),
    "unknown table": (BASE + "\n[wind]\nspeed = 0.1\n", ["wind", "top-level"]),
    "unknown key of the drag table": (BASE + "\n[drag]\ncoefficient = 0.1\n",
                                      ["drag", "coefficient", "linear, quadratic"]),
    "unknown axis": (BASE + SWEEP + "radius = [1.0, 2.0]\n", ["[sweep.axes]", "radius"]),
    # NaN and infinity, in every spelling
    "NaN as a string": (replaced("x0 = 0.5", 'x0 = "NaN"'), ["x0", "'NaN'"]),
    "nan literal": (replaced("x0 = 0.5", "x0 = nan"), ["x0", "finite"]),
    "inf as a string": (replaced("dt = 1e-3", 'dt = "inf"'), ["integrator.dt", "'inf'"]),
    "inf literal": (replaced("t_max = 2.0", "t_max = inf"), ["t_max", "finite"]),
    "-inf in a sweep": (BASE + SWEEP + "v0 = [0.0, -inf]\n", ["sweep.axes.v0[1]", "finite"]),
    "1e400 (overflows to inf)": (replaced("mu_k = 0.1", "mu_k = 1e400"), ["friction.mu_k", "finite"]),
    "400-digit integer": (replaced("x0 = 0.5", "x0 = 1" + "0" * 400), ["x0", "too large"]),
    "nan in a domain": (replaced("domain = [-1.0, 1.0]", "domain = [nan, 1.0]"), ["ramp.domain[0]", "finite"]),
    # negative, empty and absurd sizes
    "negative dt": (replaced("dt = 1e-3", "dt = -1e-3"), ["integrator.dt", "> 0"]),
    "zero g": (with_line("g = 0.0"), ["g", "> 0"]),
    "negative mass": (with_line("m = -1.0"), ["m", "> 0"]),
    "negative t_max": (replaced("t_max = 2.0", "t_max = -2.0"), ["t_max", "> 0"]),
    "1e303 steps": (replaced("t_max = 2.0", "t_max = 1e300"), ["t_max", "steps"]),
    "subnormal dt": (replaced("dt = 1e-3", "dt = 5e-324"), ["t_max", "steps"]),
    "reversed domain": (replaced("domain = [-1.0, 1.0]", "domain = [1.0, -1.0]"), ["ramp.domain"]),
    "negative linspace num": (BASE + SWEEP + "x0 = { linspace = [0.0, 0.5, -5] }\n", ["sweep.axes.x0.linspace", ">= 1"]),
    "empty axis": (BASE + SWEEP + "x0 = []\n", ["sweep.axes.x0", "at least one"]),
    "axis of 1e9 points": (BASE + SWEEP + "x0 = { linspace = [0.0, 0.5, 1000000000] }\n", ["sweep.axes.x0", "1e+08"]),
    "grid of 1e16": (BASE + SWEEP + "x0 = { linspace = [-1, 1, 100000000] }\n"
                     "v0 = { linspace = [-1, 1, 100000000] }\n", ["sweep", "1e+16", "1e+09"]),
    "grid of 1.001e9": (BASE + SWEEP + "x0 = { linspace = [-1, 1, 1000] }\nv0 = { linspace = [-1, 1, 1000] }\n"
                        "mu = { linspace = [0, 1, 1001] }\n", ["sweep", "1e+09"]),
    "negative random n": (BASE + '\n[sweep]\nkind = "random"\nn = -3\n[sweep.axes]\nx0 = { uniform = [0, 1] }\n',
                          ["sweep.n", ">= 1"]),
    "random n of 1e12": (BASE + '\n[sweep]\nkind = "random"\nn = 1000000000000\n[sweep.axes]\n'
                         "x0 = { uniform = [0, 1] }\n", ["sweep.n", "1e+08"]),
    "negative record count": (with_line("count = -1", "record"), ["record.count", ">= 0"]),
    "1e11 record samples": (with_line("max_samples = 100000000000", "record"), ["record.max_samples"]),
    "record index beyond 64 bits": (with_line("indices = [99999999999999999999]", "record"),
                                    ["record.indices[0]", "<= "]),
    "record index beyond the sweep": (with_line("indices = [0, 1]", "record"),
                                      ["record.indices[1]", "beyond the sweep's 1 trajectories"]),
    # malformed files
    "empty file": ("", ["ramp", "required"]),
    "TOML syntax error": (BASE + "[integrator\n", ["TOML syntax error"]),
    "NUL character in the text": (BASE + "title2 = 1\0\n", ["TOML syntax error"]),
    "nested 100000 deep": ("x0 = " + "[" * 100_000 + "]" * 100_000 + "\n", ["nested too deeply"]),
    "latin-1 byte": (BASE.encode() + b"# caf\xe9\n", ["not UTF-8", "0xe9", "line 17"]),
    "UTF-16 file": (BASE.encode("utf-16"), ["not UTF-8", "0xff", "line 1"]),
    "binary garbage": (bytes(range(256)) * 4, ["not UTF-8"]),
}


def error_line(capsys, *fragments) -> str:
    """The one error line; checks stdout is empty and no traceback was printed."""
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith("rampwork: error: ") and "Traceback" not in captured.err, captured.err
    assert captured.out == "", captured.out
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    return lines[0]


def write_scene(directory: Path, content, name="scene.toml") -> Path:
    path = directory / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    return path


def listing(directory: Path) -> dict[str, bytes]:
    return {path.name: path.read_bytes() for path in directory.iterdir() if path.is_file()}


@pytest.fixture
def no_runs(monkeypatch):
    """Refused input must be refused before any kernel is built or run."""
    def refuse(*args, **kwargs):
        raise AssertionError("nothing may be compiled or run for a refused input")

    monkeypatch.setattr(kernels, "get_kernel", refuse)
    monkeypatch.setattr(runner, "simulate", refuse)


@pytest.mark.parametrize("name", list(BAD_SCENES))
def test_bad_scene_is_refused_in_one_line_and_writes_nothing(name, tmp_path, capsys, no_runs):
    content, fragments = BAD_SCENES[name]
    scene = write_scene(tmp_path, content)
    output = tmp_path / "out.nc"
    assert main(["check", str(scene)]) == 2
    error_line(capsys, str(scene), *fragments)
    before = listing(tmp_path)
    assert main(["run", str(scene), "-o", str(output)]) == 2
    error_line(capsys, str(scene), *fragments)
    assert listing(tmp_path) == before and not output.exists()


def test_a_refused_run_leaves_an_existing_output_as_it_was(tmp_path, capsys, no_runs):
    """Without --overwrite an existing file is refused even for a good scene;
    with --overwrite a bad scene or a bad option still leaves it untouched."""
    output = tmp_path / "out.nc"
    output.write_bytes(b"precious results")
    good = write_scene(tmp_path, BASE, "good.toml")
    bad = write_scene(tmp_path, replaced("x0 = 0.5", "x0 = nan"), "bad.toml")
    before = listing(tmp_path)
    attempts = [
        (["run", str(good), "-o", str(output)], ["out.nc", "exists", "--overwrite"]),
        (["run", str(bad), "-o", str(output)], ["x0"]),
        (["run", str(bad), "-o", str(output), "--overwrite"], ["x0"]),
        (["run", str(good), "-o", str(output), "--overwrite", "--set", "integrator.dt=-1"], ["integrator.dt"]),
        (["run", str(good), "-o", str(output), "--overwrite", "--threads", "100000"], ["--threads"]),
    ]
    for argv, fragments in attempts:
        assert main(argv) == 2, argv
        error_line(capsys, *fragments)
        assert listing(tmp_path) == before, argv


BAD_PATHS = {
    "missing scene file": (["check", "{dir}/missing.toml"], ["missing.toml", "no such file"]),
    "directory as scene": (["check", "{dir}"], ["is a directory"]),
    "NUL byte in the scene path": (["check", "{dir}/sce\0ne.toml"], ["NUL"]),
    "directory as output": (["run", "{scene}", "-o", "{dir}"], ["is a directory"]),
    "output in a missing directory": (["run", "{scene}", "-o", "{dir}/no/such/out.nc"], ["does not exist"]),
    "output below a file": (["run", "{scene}", "-o", "{scene}/out.nc"], ["not a directory"]),
    "output in /proc": (["run", "{scene}", "-o", "/proc/out.nc"], ["/proc/out.nc", "does not allow new files"]),
    "NUL byte in the output path": (["run", "{scene}", "-o", "{dir}/o\0ut.nc"], ["NUL"]),
    "output name of 300 characters": (["run", "{scene}", "-o", "{dir}/" + "x" * 300 + ".nc"], ["name too long"]),
}


@pytest.mark.parametrize("name", list(BAD_PATHS))
def test_paths_that_cannot_be_read_or_written(name, tmp_path, capsys, no_runs):
    if name == "output in /proc" and not Path("/proc/self").exists():
        pytest.skip("needs Linux /proc")
    argv, fragments = BAD_PATHS[name]
    scene = write_scene(tmp_path, BASE)
    before = listing(tmp_path)
    argv = [arg.format(dir=tmp_path, scene=scene) for arg in argv]
    assert main(argv) == 2
    error_line(capsys, *fragments)
    assert listing(tmp_path) == before


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="needs /dev/zero")
def test_an_endless_scene_file_is_refused_after_a_bounded_read(capsys, no_runs):
    """/dev/zero (or any multi-gigabyte file) as the scene: refused after
    reading MAX_SCENE_BYTES, not read into memory until it runs out."""
    assert main(["check", "/dev/zero"]) == 2
    error_line(capsys, "/dev/zero", f"larger than {scenefile.MAX_SCENE_BYTES >> 20} MiB")


def test_an_empty_output_name(tmp_path, capsys, no_runs):
    scene = write_scene(tmp_path, BASE)
    assert main(["run", str(scene), "-o", ""]) == 2
    error_line(capsys, "not a file name")


BAD_OPTIONS = {
    "threads 0": (["--threads", "0"], ["--threads", "positive integer"]),
    "threads negative": (["--threads", "-3"], ["--threads"]),
    "threads not a number": (["--threads", "many"], ["--threads", "'many'"]),
    "threads a float": (["--threads", "1.5"], ["--threads", "'1.5'"]),
    "threads 10^23": (["--threads", "1" + "0" * 23], ["--threads", "at most"]),
    "set without =": (["--set", "integrator.dt"], ["--set", "KEY=VALUE"]),
    "set of an empty key": (["--set", "=3"], ["--set", "bad key"]),
    "set below a number": (["--set", "friction.mu_k.x=3"], ["--set", "not a table"]),
    "set of a NaN": (["--set", "x0=nan"], ["x0", "finite"]),
    "set of an unknown key": (["--set", "integrator.order=5"], ["[integrator]", "'order'"]),
    "set of a half array": (["--set", "ramp.domain=[0.0,"], ["ramp.domain", "str"]),
    "unknown option": (["--frobnicate"], ["unrecognized arguments", "--frobnicate"]),
}


@pytest.mark.parametrize("name", list(BAD_OPTIONS))
def test_bad_options(name, tmp_path, capsys, no_runs):
    extra, fragments = BAD_OPTIONS[name]
    scene = write_scene(tmp_path, BASE)
    output = tmp_path / "out.nc"
    assert main(["run", str(scene), "-o", str(output), *extra]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]  # argparse prints its usage above its error line
    assert last.startswith(("rampwork: error: ", "rampwork run: error: ")), err
    for fragment in fragments:
        assert fragment in last, (fragment, last)
    assert not output.exists()


# ------------------------------------------------------------------------------
# real processes
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["latin-1 byte", "nested 100000 deep", "1e400 (overflows to inf)"])
def test_a_real_process_exits_2_with_one_line(name, tmp_path):
    content, fragments = BAD_SCENES[name]
    scene = write_scene(tmp_path, content)
    output = tmp_path / "out.nc"
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    proc = subprocess.run([sys.executable, "-m", "rampwork", "run", str(scene), "-o", str(output)],
                          capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 2, proc.stderr
    assert proc.stdout == "" and "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rampwork: error: "), proc.stderr
    assert all(fragment in lines[0] for fragment in fragments), lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml"]
