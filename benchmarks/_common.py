"""Shared helpers for the benchmark scripts: machine info, timing, saving results.

Nothing here imports rampwork, so a benchmark can decide when the package (and
with it numba's CPU-feature settings) is imported.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import pathlib
import platform
import subprocess
import sys

#: default folder for results (gitignored)
RESULTS_DIR = pathlib.Path(__file__).resolve().parent / "results"
#: the kernel tier of every timed rampwork run: the scene's specialised kernel,
#: its compilation (or disk-cache load) timed apart on the first call.  With
#: rw.simulate's default "auto", a short run of a variant not yet compiled goes
#: to the general kernel (2-4x slower per step on the dome): such timings would
#: measure the tier, not the method
KERNEL = "specialised"


def cpu_model() -> str:
    """The CPU's model name (from /proc/cpuinfo on Linux, else platform)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as handle:
            for line in handle:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - non-Linux
        return os.cpu_count() or 1


def _version(module: str) -> str | None:
    try:
        return __import__(module).__version__
    except Exception:
        return None


def _git_commit() -> str | None:
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, timeout=5, cwd=pathlib.Path(__file__).parent)
        return out.stdout.strip() or None if out.returncode == 0 else None
    except Exception:
        return None


def machine_info() -> dict:
    """What the numbers depend on: CPU, cores, load, versions, numba settings.

    Call it after importing rampwork: ``numba.config.CPU_FEATURES`` then shows
    whether rampwork asked LLVM for 512-bit vectors."""
    import numba

    try:
        load = list(os.getloadavg())
    except OSError:  # pragma: no cover
        load = None
    return {
        "cpu_model": cpu_model(),
        "machine": platform.machine(),
        "os_cpu_count": os.cpu_count(),
        "usable_cores": usable_cores(),
        "load_average_1_5_15min": load,
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "numba": numba.__version__,
        "llvmlite": _version("llvmlite"),
        "numpy": _version("numpy"),
        "scipy": _version("scipy"),
        "rampwork": _version("rampwork"),
        "git_commit": _git_commit(),
        "NUMBA_NUM_THREADS": numba.config.NUMBA_NUM_THREADS,
        "NUMBA_NUM_THREADS_env": os.environ.get("NUMBA_NUM_THREADS"),
        "NUMBA_THREADING_LAYER": numba.config.THREADING_LAYER,
        "numba_cpu_features": numba.config.CPU_FEATURES or None,
        "wide_vectors_512bit": bool(numba.config.CPU_FEATURES
                                    and "-prefer-256-bit" in numba.config.CPU_FEATURES),
        "RAMPWORK_VECTOR_WIDTH_env": os.environ.get("RAMPWORK_VECTOR_WIDTH"),
        "NUMBA_CACHE_DIR_env": os.environ.get("NUMBA_CACHE_DIR"),
    }


def timestamp() -> str:
    return _dt.datetime.now().strftime("%Y%m%d-%H%M%S")


def utc_now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def _jsonable(value):
    """Plain JSON values: numpy scalars/arrays to Python, non-finite floats to None."""
    try:
        import numpy as np
    except ImportError:  # pragma: no cover
        np = None
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if np is not None:
        if isinstance(value, np.ndarray):
            return _jsonable(value.tolist())
        if isinstance(value, np.generic):
            value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, pathlib.Path):
        return str(value)
    return value


def save_json(path: pathlib.Path, data: dict) -> pathlib.Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(_jsonable(data), indent=2) + "\n", encoding="utf-8")
    return path


def save_text(path: pathlib.Path, text: str) -> pathlib.Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


def fmt_rate(value) -> str:
    """A rate in engineering-ish notation: 3.12e+08."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return f"{value:.3g}" if abs(value) < 1e4 else f"{value:.3e}"


def fmt_ratio(value) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    if value >= 100:
        return f"{value:,.0f}x"
    return f"{value:.3g}x"


def markdown_table(headers: list[str], rows: list[list]) -> str:
    """A GitHub-flavoured markdown table."""
    cells = [[str(c) for c in row] for row in rows]
    lines = ["| " + " | ".join(headers) + " |",
             "|" + "|".join("---" for _ in headers) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in cells]
    return "\n".join(lines)


def text_table(headers: list[str], rows: list[list]) -> str:
    """A plain aligned table for the terminal."""
    cells = [[str(c) for c in row] for row in rows]
    widths = [max(len(h), *(len(r[k]) for r in cells)) if cells else len(h)
              for k, h in enumerate(headers)]
    def line(values):
        return "  ".join(v.ljust(w) if k == 0 else v.rjust(w)
                         for k, (v, w) in enumerate(zip(values, widths)))
    out = [line(headers), "  ".join("-" * w for w in widths)]
    out += [line(r) for r in cells]
    return "\n".join(out)
