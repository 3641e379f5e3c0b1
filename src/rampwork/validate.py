"""Small checks that raise :class:`~rampwork.errors.ConfigError` naming the
parameter, the value and what is allowed.  Used by every settings object."""

from __future__ import annotations

import math
import os
from numbers import Real

import numpy as np

from .errors import ConfigError

#: the most values one sweep axis (or cases one design) may have
MAX_AXIS_POINTS = 10**8
#: the most trajectories one grid sweep may have
MAX_TRAJECTORIES = 10**9
#: the kernel tiers a run may ask for (rampwork.kernels; rampwork.curves.curve_tier)
KERNEL_TIERS = ("auto", "general", "specialised")
#: the environment variable that sets the default tier
KERNEL_ENV = "RAMPWORK_KERNEL"


def kernel_tier(kernel: str | None) -> str:
    """``kernel``, or the environment's default (``auto`` without one), checked."""
    tier = kernel if kernel is not None else os.environ.get(KERNEL_ENV, "auto")
    if tier not in KERNEL_TIERS:
        where = "kernel" if kernel is not None else KERNEL_ENV
        raise ConfigError(where, f"unknown kernel tier {tier!r}; allowed: {', '.join(KERNEL_TIERS)}")
    return tier


def real(where: str, value) -> float:
    """A finite real number (bools, strings and NaN/inf refused)."""
    if isinstance(value, bool) or not isinstance(value, (Real, np.floating, np.integer)):
        raise ConfigError(where, f"expected a finite number, got {value!r} ({type(value).__name__})")
    value = float(value)  # also turns numpy scalars into plain floats for messages
    if not math.isfinite(value):
        raise ConfigError(where, f"must be a finite number, got {value!r}")
    return value


def positive(where: str, value) -> float:
    value = real(where, value)
    if value <= 0:
        raise ConfigError(where, f"must be > 0, got {value!r}")
    return value


def nonnegative(where: str, value) -> float:
    value = real(where, value)
    if value < 0:
        raise ConfigError(where, f"must be >= 0, got {value!r}")
    return value


def integer(where: str, value, minimum: int | None = None, maximum: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ConfigError(where, f"expected an integer, got {value!r} ({type(value).__name__})")
    value = int(value)
    if minimum is not None and value < minimum:
        raise ConfigError(where, f"must be >= {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise ConfigError(where, f"must be <= {maximum}, got {value}")
    return value


def choice(where: str, value, allowed) -> str:
    allowed = tuple(allowed)
    if not isinstance(value, str) or value not in allowed:
        raise ConfigError(where, f"unknown value {value!r}; allowed: {', '.join(map(repr, allowed))}")
    return value


def real_array(where: str, values) -> np.ndarray:
    """A non-empty 1-D array of finite floats."""
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(where, f"expected a list of finite numbers, got {values!r}") from None
    if array.ndim == 0:
        array = array.reshape(1)
    if array.ndim != 1 or array.size == 0:
        raise ConfigError(where, f"expected a non-empty 1-D list of numbers, got shape {array.shape}")
    bad = ~np.isfinite(array)
    if bad.any():
        raise ConfigError(where, f"must be finite, got {float(array[bad][0])!r} at index {int(np.argmax(bad))}")
    return array
