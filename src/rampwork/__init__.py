"""rampwork: parameter studies of Coulomb friction on curved ramps.

A point mass slides on a ramp y = f(x) under gravity with Coulomb friction
(kinetic ``mu_k``, static ``mu_s``).  A jitted batch kernel integrates millions
of (friction, start, ramp shape) combinations with exact stick, reversal,
lift-off and exit events and reduces each to work against friction, energy
balance, excess work beyond ``mu m g |dx|`` and convexity.

    >>> import rampwork as rw
    >>> scene = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=1.0, domain=(-1, 1)),
    ...                  friction=rw.Friction(mu_k=0.2), x0=-0.9)
    >>> ds = rw.simulate(scene, rw.Sweep.grid(mu=[0.1, 0.2, 0.3]))
"""

from ._version import __version__
from .core.status import STATUS_TABLE
from .errors import ClosedFormNotice, ConfigError, RenamedParameterWarning
from .io import open_dataset, write_netcdf
from .ramps import FAMILIES, Ramp
from .scene import Drag, Friction, Integrator, Record, Scene, Sweep
from .scenefile import scene_from_dataset
from .optimiser import OptimiseSettings, optimise
from .shapes import ChordModes
from .runner import simulate
from .sensitivity import sobol_indices
from .streaming import run_to_file
from .zarrstore import write_zarr

__all__ = [
    "__version__",
    "ChordModes",
    "ClosedFormNotice",
    "ConfigError",
    "FAMILIES",
    "Drag",
    "Friction",
    "Integrator",
    "OptimiseSettings",
    "Ramp",
    "Record",
    "RenamedParameterWarning",
    "STATUS_TABLE",
    "Scene",
    "Sweep",
    "open_dataset",
    "optimise",
    "run_to_file",
    "scene_from_dataset",
    "simulate",
    "sobol_indices",
    "write_netcdf",
    "write_zarr",
]
