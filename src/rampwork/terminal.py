"""What the command line prints: numbers and times, end-status counts, the
progress bar, and summaries of a stored scene (for ``rampwork info``)."""

from __future__ import annotations

import sys
import time

from .errors import ConfigError


def format_seconds(seconds: float) -> str:
    return f"{seconds * 1e3:.1f} ms" if seconds < 1 else f"{seconds:.2f} s"


def si(value: float) -> str:
    for factor, prefix in ((1e9, " G"), (1e6, " M"), (1e3, " k")):
        if abs(value) >= factor:
            return f"{value / factor:.3g}{prefix}"
    return f"{value:.3g}"


def sweep_shape(sweep) -> str:
    if sweep.design is not None:
        return sweep.design.describe()
    if not sweep.axes:
        return "single trajectory (no sweep axes)"
    if sweep.kind == "cases":
        return f"cases: {sweep.size} x ({', '.join(sweep.names)})"
    return "grid: " + " x ".join(f"{name} {len(values)}" for name, values in sweep.axes)


def check_lines(scene, sweep, shape, size) -> tuple[list[str], list[str]]:
    """The lines ``rampwork check`` prints for ramp and curve scenes alike:
    (friction and drag, sweep and size); ``shape``, ``size``: the run's."""
    lines = [f"friction      mu_k = {scene.friction.mu_k!r}, mu_s = {scene.friction.mu_s!r}; "
             f"contact {scene.contact}"]
    if scene.drag.enabled:
        lines.append(f"drag          linear = {scene.drag.linear!r} s-1, "
                     f"quadratic = {scene.drag.quadratic!r} m-1")
    dims = f"dims ({', '.join(sweep.dims)}), shape {tuple(shape)}" if sweep.names else "no dims"
    return lines, [f"sweep         {sweep_shape(sweep)}; {dims}", f"trajectories  {size:,}"]


def status_counts(status) -> dict[str, int]:
    import numpy as np

    from .core.status import STATUS_NAMES

    values = np.asarray(status).ravel()
    codes, counts = np.unique(values, return_counts=True)
    return {STATUS_NAMES.get(int(code), f"code {int(code)}"): int(count) for code, count in zip(codes, counts)}


def format_counts(counts: dict[str, int]) -> str:
    return ", ".join(f"{name} {count}" for name, count in counts.items()) or "(none)"


def clock(seconds: float) -> str:
    seconds = int(round(seconds))
    hours, rest = divmod(seconds, 3600)
    return f"{hours}:{rest // 60:02d}:{rest % 60:02d}" if hours else f"{rest // 60}:{rest % 60:02d}"


class Progress:
    """``progress(done, total)``: a bar with the rate and the time left on
    stderr, rewritten in place on a terminal, a line every few seconds
    elsewhere (``--progress`` into a log)."""

    WIDTH = 24

    def __init__(self, stream=None):
        self.stream = sys.stderr if stream is None else stream
        self.tty = self.stream.isatty()
        self.interval = 0.2 if self.tty else 5.0
        self.first = None  # (time, done) at the first call: the rate counts this run's work only
        self.last = -float("inf")
        self.longest = 0

    def __call__(self, done: int, total: int) -> None:
        now = time.perf_counter()
        if self.first is None:
            self.first = (now, done)
        if done < total and now - self.last < self.interval:
            return
        self.last = now
        started, done_before = self.first
        rate = (done - done_before) / (now - started) if done > done_before and now > started else 0.0
        share = done / max(total, 1)
        filled = int(self.WIDTH * share)
        left = clock((total - done) / rate) if rate > 0 else "?"
        line = (f"[{'#' * filled}{'-' * (self.WIDTH - filled)}] {100 * share:3.0f}%  "
                f"{si(done)}/{si(total)} trajectories  {si(rate)}/s  "
                f"{clock(now - started)} elapsed, {left} left")
        if self.tty:  # padded over a longer previous line
            self.longest = max(self.longest, len(line))
            print(f"\r{line:<{self.longest}}", end="\n" if done >= total else "", file=self.stream, flush=True)
        else:
            print(line, file=self.stream, flush=True)


#: a stored scene larger than this is not parsed for `info`'s sweep line
#: (files of rampwork <= 0.1 stored a random design's every value)
_SUMMARY_SCENE_BYTES = 1 << 20
#: the lines of one array that `info` prints before it elides the rest
_ARRAY_LINES = 6


def stored_sweep(text: str, coordinates=None) -> str | None:
    """The sweep line of a stored scene (a design: its recipe), or None
    (``coordinates``: the dataset's, which long axes refer to)."""
    from .scenefile import parse_scene

    if len(text) > _SUMMARY_SCENE_BYTES:
        return None
    try:
        _, sweep = parse_scene(text, "the stored scene", coordinates)
    except ConfigError:
        return None
    return sweep_shape(sweep)


def scene_lines(text: str) -> list[str]:
    """A stored scene's lines, each array of more than a few lines cut short
    (a design is stored as its recipe; older files listed every value)."""
    lines, kept = [], 0
    for line in text.rstrip("\n").splitlines():
        if kept and line.strip() != "]":
            kept += 1
            if kept <= _ARRAY_LINES:
                lines.append(line)
            continue
        if kept > _ARRAY_LINES:
            lines.append(f"    # ... {kept - _ARRAY_LINES:,} more lines of values")
        kept = 1 if line.rstrip().endswith("= [") else 0
        lines.append(line)
    return lines
