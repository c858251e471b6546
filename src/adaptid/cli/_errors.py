"""The command line's exception (defined in :mod:`adaptid._exceptions`, re-exported)."""

from .._exceptions import CLIError

__all__ = ["CLIError"]
