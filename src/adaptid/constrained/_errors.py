"""Exception and warning classes of :mod:`adaptid.constrained` (defined in
:mod:`adaptid._exceptions`, re-exported under their old import path)."""

from .._exceptions import IllConditionedWarning, InfeasibleError

__all__ = ["InfeasibleError", "IllConditionedWarning"]
