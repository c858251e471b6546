"""``adaptid export-c STATE_FILE --out DIR [--name NAME] [--float32]``.

Reads a state file written by ``save_state`` and writes the estimator's
recursion as ``NAME.h`` / ``NAME.c`` (see :func:`adaptid.codegen.to_c`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._errors import CLIError

__all__ = ["register", "export_c", "write_c"]


def export_c(state_file: Path, out: Path, name: str = "rls", float32: bool = False):
    """Load ``state_file`` and write the C files; returns their paths. Errors: CLIError."""
    from adaptid.estimators._statefile import load_state_labelled

    from ._targets import c_targets, check_targets

    check_targets([("STATE_FILE", state_file)], c_targets(out, name, "--out"))
    try:
        est, labels = load_state_labelled(state_file)
    except ValueError as err:  # StateFileError: unreadable, damaged, not a state file
        raise CLIError(str(err)) from None
    nk, pending = _fir_delay(est, labels, state_file)
    return write_c(est, out, name, float32, nk=nk, pending=pending)


def _fir_delay(est, labels, state_file):
    """(nk, pending) of a FastRLS saved by ``adaptid fit --fir NB,NK``: its input delay and
    the raw inputs not yet in its line, from the labels; else (0, None)."""
    if (type(est).__name__ != "FastRLS" or labels is None
            or labels.get("saved_by") != "adaptid fit"):
        return 0, None
    try:
        nk = int(labels.get("delay_nk", "0"))
        pending = [float.fromhex(x) for x in labels.get("pending_inputs", [])]
    except (TypeError, ValueError):
        raise CLIError(f"{state_file}: its labels delay_nk and pending_inputs are not an "
                       "integer and hexadecimal floats") from None
    return nk, pending


def write_c(est, out: Path, name: str = "rls", float32: bool = False, option: str = "--out",
            offsets=None, nk=0, pending=None):
    """Write ``est``'s C files (:func:`adaptid.codegen.to_c`); returns their paths. Errors: CLIError.

    ``est`` may be a model or a streaming model object (``offsets``: its y0, u0), or a
    FastRLS (``nk``, ``pending``: its input delay and the raw inputs not yet in its line)."""
    from adaptid.codegen import to_c

    try:
        return to_c(est, out, name=name, dtype="float32" if float32 else "float64",
                    offsets=offsets, nk=nk, pending=pending)
    except (ValueError, TypeError) as err:
        raise CLIError(str(err)) from None
    except OSError as err:
        raise CLIError(f"{option} {str(out)!r} cannot be written: {err.strerror or err}") from None


def register(app: typer.Typer, output, guard):
    """Add the ``export-c`` command to ``app`` (``output``/``guard`` from ``_app``)."""

    @app.command("export-c")
    def export_c_command(
        ctx: typer.Context,
        state_file: Annotated[Path, typer.Argument(help="State file written by save_state.")],
        out: Annotated[Path, typer.Option("--out", "-o", help="Folder for NAME.h and NAME.c.")],
        name: Annotated[str, typer.Option("--name", help="C identifier: file name and prefix.")] = "rls",
        float32: Annotated[bool, typer.Option("--float32", help="Generate single precision.")] = False,
        quiet: Annotated[bool, typer.Option("--quiet", "-q", help="Print nothing but errors.")] = False,
        debug: Annotated[bool, typer.Option("--debug", help="Show the traceback of an error.")] = False,
    ):
        """Write the estimator of STATE_FILE as C99 code (NAME.h, NAME.c).

        The code has no dependencies and continues from the saved state; see
        docs/embedded.md."""
        o = output(ctx, quiet=quiet, debug=debug)
        with guard(o):
            paths = export_c(state_file, out, name, float32)
            if o.chatty:
                o.print("wrote " + ", ".join(str(p) for p in paths))

    return export_c_command
