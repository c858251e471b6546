"""The documented places where a lower layer calls into a later one, by name.

Results that draw themselves (``Trajectory.plot``, statsmodels' style) and
estimators that export themselves (``est.to_c``) belong to layer 2, while
the figures (:mod:`adaptid.plot`) and the C generator
(:mod:`adaptid.codegen`) live in layer 7. Those methods load the later
module by name when they are called, through :func:`upward`, and nowhere
else; ``tests/test_architecture.py`` checks that :func:`upward` names only
the modules listed in :data:`ALLOWED`.
"""

from __future__ import annotations

import importlib

__all__ = ["upward", "ALLOWED"]

#: the only later-layer modules a lower layer may load, and why
ALLOWED = {
    "adaptid.plot": "results that plot themselves (Trajectory.plot, compare/resid results)",
    "adaptid.codegen": "estimators that export themselves as C (est.to_c)",
}


def upward(module: str):
    """Import one of the :data:`ALLOWED` later-layer modules on first use."""
    if module not in ALLOWED:  # pragma: no cover - guards the rule above
        raise ImportError(f"{module} is not an allowed upward hook")
    return importlib.import_module(module)
