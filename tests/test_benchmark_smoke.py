"""The benchmark scripts run end to end at tiny sizes (issue 19: throughput.py
with --accuracy-subset 0 crashed in build_tables; overhead.py is new)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(script: str, *args: str, out: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    return subprocess.run([sys.executable, str(ROOT / "benchmarks" / script), *args, "--out", str(out)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)


@pytest.mark.slow  # compiles the throughput scene's kernels and the division ceiling's in a subprocess (~60 s)
def test_throughput_skips_the_accuracy_comparison(tmp_path):
    done = _run("throughput.py", "--n", "300", "--methods", "euler", "--accuracy-subset", "0",
                "--scipy-subset", "0", "--numpy-subset", "0", "--uniform", "0", "--no-scaling",
                "--no-figure", out=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "accuracy: not compared (--accuracy-subset 0)" in done.stdout
    saved = json.loads(next(tmp_path.glob("throughput-*.json")).read_text())
    assert "reference" not in saved and "accuracy" not in saved["methods"]["euler"]


@pytest.mark.slow  # compiles two methods' kernels in a subprocess (~15 s)
def test_overhead_benchmark_reports_every_stage(tmp_path):
    done = _run("overhead.py", "--methods", "euler", "dopri5", "--sizes", "100", "400",
                "--repeat", "1", out=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    saved = json.loads(next(tmp_path.glob("overhead-*.json")).read_text())
    points = saved["points"]
    assert [(p["method"], p["n"]) for p in points] == [("euler", 100), ("euler", 400),
                                                       ("dopri5", 100), ("dopri5", 400)]
    for point in points:
        assert 0 < point["run_time_s"] <= point["wall_s"]
        assert point["stages_s"]["kernel"] > 0 and point["stages_s"]["attributes"] > 0
        assert point["stored_scene_bytes"] < 1500  # 400 cases by reference, not listed
    assert set(saved["fits"]) == {"euler", "dopri5"}


def test_events_benchmark_reports_the_ceiling_fractions(tmp_path):
    done = _run("events.py", "--n", "300", "--methods", "euler", "--repeat", "1", out=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    saved = json.loads(next(tmp_path.glob("events-*.json")).read_text())
    euler = saved["best"]["this tree"]["methods"]["euler"]
    assert euler["grid_steps_per_s"] > 0 and euler["identical_steps_per_s"] > 0
    assert euler["grid_of_ceiling"] == euler["grid_steps_per_s"] / saved["best"]["this tree"][
        "division_ceiling_per_s"]


@pytest.mark.slow  # compiles curve and ramp kernels of three methods (about 40 s)
def test_curves_benchmark_pairs_the_kernels_on_the_same_ramp(tmp_path):
    done = _run("curves.py", "--n", "64", "--methods", "rk4",
                "--cases", "graph:circular_bowl,arc:circular_bowl", "--threads", "1",
                "--repeat", "1", "--baseline", str(ROOT / "src"), out=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    saved = json.loads(next(tmp_path.glob("curves-*.json")).read_text())
    assert set(saved["pairs"]) == {"rk4/graph:circular_bowl", "rk4/arc:circular_bowl"}
    for pair in saved["pairs"].values():
        # rk4 at dt = 1 ms: the two kernels agree far below a millimetre and a millijoule
        agree = pair["agreement"]
        assert agree["status_equal"] == 1.0
        assert agree["max_dx_end"] < 1e-8 and agree["max_dW_friction"] < 1e-8
        assert pair["curve_steps"] == pair["graph_steps"] > 64  # fixed steps: the same count
        rate = pair["graph"]["1"]
        assert rate["ratio_of_bests"] == rate["steps_per_s"] / pair["curve_steps_per_s"]
        assert pair["curve_compile_s"] > 0
        # the lanes beside their scalar reference: the same bits, both timed
        assert pair["scalar_identical"] is True
        assert pair["scalar_steps_per_s"] > 0 and pair["lanes_over_scalar"] > 0
    best = saved["trees"]["best"]
    assert set(best) == {"this tree", "baseline"}
    assert set(best["baseline"]) == {"rk4/circular_bowl/1"}
    assert best["baseline"]["rk4/circular_bowl/1"]["steps_per_s"] > 0


@pytest.mark.slow  # compiles the sine_modes kernels of two pairs in a subprocess (~15 s)
def test_shape_evaluations_benchmark_reports_matched_accuracy(tmp_path):
    done = _run("shape_evaluations.py", "--n", "16", "--scipy-n", "2", "--repeat", "1", "--quick", out=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    saved = json.loads(next(tmp_path.glob("shape_evaluations-*.json")).read_text())
    assert len(saved["results"]) == 3
    for result in saved["results"].values():
        assert result["batch_per_s"] > 0 and result["scipy_per_s"] > 0
        assert result["batch_t_end_error"] < 100 * result["rampwork_rtol"]
    # at equal error: each side's cost read off its own error-cost frontier
    matched = saved["matched"]["1e-06"]
    assert matched["scipy_cpu"] > 0 and matched["batch_cpu"] > 0
    assert matched["ratio_batch_cpu"] == matched["scipy_cpu"] / matched["batch_cpu"]
    for front in saved["fronts"].values():  # cheaper points are less accurate
        costs, errors = [c for _, c in front], [e for e, _ in front]
        assert costs == sorted(costs) and errors == sorted(errors, reverse=True)
    assert all(entry["error"] < 1e-4 for entry in saved["cusp"].values())  # against the quadrature
    # the quadrature evaluator's row: its error to its rtol, most candidates by quadrature
    for rtol, entry in saved["quadrature"].items():
        assert entry["error"] < 100 * float(rtol) and entry["share"] > 0.5 and entry["points"] > 0
    assert matched["quadrature_cpu"] > 0 and matched["ratio_quadrature_cpu"] > 0
    assert all(entry["error"] < 1e-5 for entry in saved["scipy_quad"].values())
