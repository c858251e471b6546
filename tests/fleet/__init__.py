"""Tests of adaptid.fleet: identification over many devices on Dask."""
