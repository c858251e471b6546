"""Terminal output: verbosity, rich tables, the progress bar, one-line messages."""

from __future__ import annotations

import json
import math
import os
import sys
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

__all__ = ["Output", "to_jsonable"]


@dataclass
class Output:
    """Where and how much to print.

    quiet: nothing on stdout but ``--json``; verbose: extra detail;
    json: stdout carries exactly one JSON object.
    """

    quiet: bool = False
    verbose: bool = False
    debug: bool = False
    json: bool = False

    @property
    def console(self):
        from rich.console import Console

        if not hasattr(self, "_console"):
            # a terminal sets its own width; a pipe or file gets wide lines, not 80 columns
            width = None if _isatty(sys.stdout) else int(os.environ.get("COLUMNS", "120") or 120)
            self._console = Console(file=sys.stdout, highlight=False, soft_wrap=False, width=width)
        return self._console

    @property
    def chatty(self) -> bool:
        return not (self.quiet or self.json)

    def print(self, *args, **kw):
        kw.setdefault("markup", False)
        kw.setdefault("soft_wrap", all(isinstance(a, str) for a in args))
        if self.chatty:
            self.console.print(*args, **kw)

    def detail(self, *args, **kw):
        kw.setdefault("markup", False)
        kw.setdefault("soft_wrap", True)
        if self.chatty and self.verbose:
            self.console.print(*args, **kw)

    def warn(self, message: str):
        if not self.quiet:
            print(f"adaptid: warning: {' '.join(str(message).split())}", file=sys.stderr)

    def emit_json(self, obj):
        sys.stdout.write(json.dumps(to_jsonable(obj), allow_nan=False) + "\n")
        sys.stdout.flush()

    @contextmanager
    def progress(self, total: int, description: str):
        """Yield an ``advance(k)`` callable; a rich bar only on a terminal."""
        show = self.chatty and total > 0 and _isatty(sys.stdout)
        if not show:
            yield None
            return
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                                   TimeElapsedColumn)

        with Progress(TextColumn("[progress.description]{task.description}"), BarColumn(),
                      MofNCompleteColumn(), TimeElapsedColumn(), console=self.console,
                      transient=True) as bar:
            task = bar.add_task(description, total=total)
            yield lambda k: bar.update(task, advance=k)


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def to_jsonable(obj):
    """NumPy values → Python; NaN/inf → None (JSON has no NaN)."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        f = float(obj)
        return f if math.isfinite(f) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def rich_table(title, columns, rows, *, left=1, show_header=True):
    """A rich Table whose every cell is plain text (no markup: '[mH]' stays '[mH]')."""
    from rich.table import Table
    from rich.text import Text

    t = Table(title=Text(title) if title else None, title_justify="left", show_header=show_header)
    for i, c in enumerate(columns):
        t.add_column(Text(str(c)), justify="left" if i < left else "right")
    for row in rows:
        t.add_row(*(Text(str(v)) for v in row))
    return t
