"""Errors raised for bad input before any work starts, and how each front
end (Python or the command line) spells the options a message points to."""

from __future__ import annotations

import contextlib
import contextvars
import os
import sys
import warnings


class ConfigError(ValueError):
    """Bad input: says which parameter, what value, and what is allowed.

    The CLI prints the message on one line and exits with status 2.
    """

    def __init__(self, where: str, problem: str):
        self.where = where
        self.problem = problem
        super().__init__(f"{where}: {problem}")

    def __reduce__(self):
        # so that an error raised on a Dask worker reaches the client intact
        return type(self), (self.where, self.problem)


class RenamedParameterWarning(FutureWarning):
    """A scene used a parameter under its old name or meaning; it was read
    as the new one (the warning says how), and will be refused later."""


class ClosedFormNotice(UserWarning):
    """A straight ramp was solved in closed form, not with the integrator the
    scene asked for (shown once a process per integrator)."""


def warn(message: str, category: type[Warning]) -> None:
    """``warnings.warn`` attributed to the first caller outside rampwork, so
    that the warning names the user's line (however deep rampwork found it)."""
    package = os.path.dirname(os.path.abspath(__file__)) + os.sep
    frame, level = sys._getframe(0), 1
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(package):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, category, stacklevel=level)


#: the front end that called rampwork: "python" (the API) or "cli"
_FRONT_END = contextvars.ContextVar("rampwork_front_end", default="python")
FRONT_ENDS = ("python", "cli")

#: an option as each front end spells it where a message asks for it
_OPTIONS = {
    "overwrite": ("overwrite=True", "--overwrite"),
    "resume": ("resume=True", "--resume"),
    "chunk_size": ("chunk_size", "--chunk-size"),
    "threads": ("threads", "--threads"),
    "scheduler": ("scheduler", "--scheduler"),
    "closed_form": ("Integrator(..., closed_form=False)", "closed_form = false under [integrator]"),
}


@contextlib.contextmanager
def front_end(name: str):
    """Within the block, messages spell options as front end ``name`` does
    (:func:`option`); the command line runs every command inside
    ``front_end("cli")``."""
    if name not in FRONT_ENDS:
        raise ValueError(f"front end must be one of {FRONT_ENDS}, got {name!r}")
    token = _FRONT_END.set(name)
    try:
        yield
    finally:
        _FRONT_END.reset(token)


def option(name: str) -> str:
    """Option ``name`` as the calling front end spells it in a message:
    ``option("overwrite")`` is ``overwrite=True`` in Python and
    ``--overwrite`` on the command line."""
    python, cli = _OPTIONS[name]
    return cli if _FRONT_END.get() == "cli" else python
