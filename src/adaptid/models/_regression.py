"""The common result of every regressor builder: (Φ, y) with names."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Regression"]


@dataclass(frozen=True, eq=False)
class Regression:
    r"""A linear regression :math:`y_k = \theta^T\varphi_k + e_k` built from a record.

    Every builder of :mod:`adaptid.models` returns one, ready for
    :func:`adaptid.lstsq` or any recursive estimator's ``run``::

        reg = adaptid.models.arx_regressors(y, u, na=2, nb=2, nk=1)
        adaptid.RLS(reg.n_params).run(reg.Phi, reg.y)

    Attributes
    ----------
    Phi : ndarray, shape (N, n)
        Regressor rows, float64, C-contiguous.
    y : ndarray, shape (N,) or (N, p)
        Regressand.
    names : tuple of str, length n
        One name per column of ``Phi`` (e.g. ``"y[k-1]"``, ``"u0[k-3]"``,
        ``"di/dt"``), used in tables, reports and the CLI's JSON output.
    index : ndarray of int, shape (N,)
        Row ``i`` of ``Phi`` belongs to sample ``index[i]`` of the original
        record (samples needed as lags at the start are not rows).
    meta : dict
        Builder-specific details (orders, filter settings, …).
    """

    Phi: np.ndarray
    y: np.ndarray
    names: tuple
    index: np.ndarray
    meta: dict = field(default_factory=dict, repr=False)

    @property
    def n_params(self) -> int:
        """Number of regressors n."""
        return self.Phi.shape[1]

    def __len__(self) -> int:
        return self.Phi.shape[0]
