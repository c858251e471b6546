r"""The σ̂² rule of :func:`adaptid.recursive_fit_stats`, as array arithmetic.

Its own module (no imports from adaptid) so that both
:func:`~adaptid.recursive_fit_stats` (:mod:`._stats`) and the per-sample
statistics of ``run(..., stats=True)`` (:mod:`._windowstats`) use it
without an import cycle through the engine.
"""

import numpy as np

__all__ = ["sigma2_rule"]


def sigma2_rule(ssr, n_eff, n, diag_P, r2=1.0):
    r"""The rule itself, for one fit or for every sample of a run (arrays broadcast).

    :math:`\hat\sigma^2 = \mathrm{ssr}/(n_\mathrm{eff} - n)` (NaN where
    :math:`n_\mathrm{eff} \le n`) and :math:`\mathrm{se} = \sqrt{\hat\sigma^2
    \max(P_{ii}, 0)/R_2}`.

    Parameters
    ----------
    ssr : ndarray, shape (..., p)
    n_eff : ndarray, shape (...)
    n : int
    diag_P : ndarray, shape (..., n)
    r2 : float

    Returns
    -------
    sigma2 : ndarray, shape (..., p)
    stderr : ndarray, shape (..., n, p)
    """
    dof = np.asarray(n_eff, dtype=np.float64)[..., None] - n
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        sigma2 = np.where(dof > 0, ssr / np.where(dof > 0, dof, 1.0), np.nan)
        diag = np.clip(np.asarray(diag_P, dtype=np.float64), 0.0, None)
        stderr = np.sqrt(diag[..., :, None] * (sigma2[..., None, :] / r2))
    return sigma2, stderr
