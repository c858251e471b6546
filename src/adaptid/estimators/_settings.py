"""What a compiled recursion needs to know of an estimator (the engine's public hook)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["KernelSettings"]


@dataclass(frozen=True)
class KernelSettings:
    """Algorithm, options and current state of an estimator (see ``kernel_settings()``)."""

    method: str
    theta: np.ndarray
    U: np.ndarray
    D: np.ndarray
    forgetting: float = 1.0
    strategy_mode: int = -1
    strategy_params: np.ndarray = None
    P_max: float = np.inf
    window: int = 0
    process_cov: np.ndarray = None
    noise_var: float = 1.0
    diffuse_state: np.ndarray = None

    @classmethod
    def of(cls, est, theta, U, D, diffuse_state=None):
        method = type(est).spec.method
        n = est.n_params
        kw = {}
        if method == "kalman":
            kw = {"process_cov": np.array(est.process_cov, dtype=np.float64),
                  "noise_var": float(est.noise_var)}
        else:
            lam = getattr(est, "_lam", None)
            kw["forgetting"] = 1.0 if lam is None else float(lam)
            if method == "window":
                kw["window"] = int(est.window)
            else:
                strat = est._strategy
                if strat is not None or est.P_max is not None:
                    kw["strategy_mode"] = int(strat._mode) if strat is not None else 0
                    kw["strategy_params"] = (strat._params_n(n) if strat is not None
                                             else np.zeros(1))
                    kw["P_max"] = np.inf if est.P_max is None else float(est.P_max)
        kw.setdefault("strategy_params", np.zeros(1))
        kw.setdefault("process_cov", np.zeros((n, n)))
        return cls(method=method, theta=theta, U=U, D=D, diffuse_state=diffuse_state, **kw)
