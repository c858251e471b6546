"""The ``adaptid`` command line: ``adaptid demo``, ``adaptid fit DATA``, ``adaptid info``.

Needs the ``cli`` extra (``pip install 'adaptid[cli]'``: typer, rich, pandas,
pyarrow, matplotlib). :func:`main` is the console script's entry point and
``python -m adaptid``'s.
"""

from __future__ import annotations

import sys

__all__ = ["main"]


def main(argv=None) -> int:
    """Run ``adaptid`` with ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    try:
        from ._app import main as _main
    except ImportError as err:  # pragma: no cover - depends on the install
        print(f"adaptid: error: the command line needs the cli extra "
              f"(pip install 'adaptid[cli]'): {err}", file=sys.stderr)
        return 2
    return _main(argv)
