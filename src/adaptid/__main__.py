"""Command-line entry point: ``python -m adaptid`` / ``adaptid``.

For now this runs the demonstration on generated data (the full command-line
tool with ``adaptid demo``, ``adaptid fit`` and reports comes with the CLI).
"""

from __future__ import annotations

import sys


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in ("-h", "--help"):
        print("usage: adaptid [demo]\n\nRuns RLS, SlidingWindowRLS and KalmanRLS on generated data "
              "with a parameter jump and prints the estimates against the truth.")
        return 0
    if argv and argv[0] != "demo":
        print(f"adaptid: error: unknown command {argv[0]!r} (available: demo)", file=sys.stderr)
        return 2
    from ._demo import demo
    demo()
    return 0


if __name__ == "__main__":
    sys.exit(main())
