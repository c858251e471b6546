r"""Result object shared by the continuous integrator and the discretisations."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["TLSMResult"]


@dataclass(frozen=True, eq=False)
class TLSMResult:
    r"""Estimates and gain matrices of a TLSM run at given times.

    Attributes
    ----------
    t : ndarray, shape (K,)
        Output times. For the continuous integrator these are ``t_eval``;
        for a discretisation they are the sample instants
        :math:`t_k = t_0 + kT`, k = 0..N.
    theta : ndarray, shape (K, n)
        :math:`\hat\theta(t)`; row 0 is the initial estimate θ₀.
    Q : ndarray, shape (K, n, n)
        :math:`Q(t) = R(t)^{-1}`, the inverse of the weighted information
        matrix of Yamamoto (1991), eq. 8 (prior term included), in the units
        of the continuous algorithm.
    info : dict
        Diagnostics of the run (e.g. number of right-hand-side evaluations,
        number of integration segments, which recursion was used).
    """

    t: np.ndarray
    theta: np.ndarray
    Q: np.ndarray
    info: dict = field(default_factory=dict, repr=False)

    def __len__(self) -> int:
        return self.t.shape[0]

    def __repr__(self) -> str:
        kind = self.info.get("kind", "run")
        return (f"TLSMResult({kind}: {self.t.shape[0]} times in "
                f"[{self.t[0]:.6g}, {self.t[-1]:.6g}], n={self.theta.shape[1]})")
