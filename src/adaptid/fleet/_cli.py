"""Kept under its old path: the ``adaptid fleet`` command lives in :mod:`adaptid.cli._fleet`."""

from ..cli._fleet import fleet_command, resolve_model, summary_text, write_result

__all__ = ["fleet_command", "resolve_model", "summary_text", "write_result"]
