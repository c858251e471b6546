"""The table reader of the command line: :mod:`adaptid.io` (kept under its old path)."""

from ..io import SUFFIXES, Table, read_table

__all__ = ["Table", "read_table", "SUFFIXES"]
