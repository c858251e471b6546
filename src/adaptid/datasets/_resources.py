"""Access to the files of ``adaptid/datasets/data`` (package data)."""

from __future__ import annotations

from importlib import resources

__all__ = ["data_file"]


def data_file(name: str):
    """Return a readable resource (``Traversable``) for a packaged data file."""
    return resources.files("adaptid.datasets").joinpath("data", name)
