"""The state layout of :class:`~adaptid.estimators._fastrls.FastRLS`, shared with the
state-file reader (:mod:`._stateread`) without an import cycle."""

from __future__ import annotations

from .._exceptions import StateFileError

METHODS = ("ftf", "lattice")


def layout(method, n, track):
    """State length without the rescue count (see :mod:`adaptid._kernels.recursions._fastrls`)."""
    if method == "ftf":
        return 5 * n + 3
    return 7 * n + 2 + (n * n + n if track else 0)


def state_length(options, n) -> int:
    """Length of ``get_state()["state"]`` (one stream) for a state file's reader."""
    method, track = options.get("method"), options.get("track_theta", True)
    if method not in METHODS or not isinstance(track, bool):
        raise StateFileError(f"header options 'method' and 'track_theta' must be one of "
                             f"{METHODS} and a boolean, got {method!r:.40}, {track!r:.10}")
    return layout(method, n, track) + 1
