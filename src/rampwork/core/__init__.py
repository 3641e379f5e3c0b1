"""Jitted core: plain floats and arrays in SI units.  No xarray, matplotlib or
dask imports here (checked by tests/test_architecture.py)."""
