"""Temporary alias of rampwork.runner (removed once the CLI imports runner)."""
from .runner import simulate  # noqa: F401
