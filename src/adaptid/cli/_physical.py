r"""Physical DC-motor parameters and their standard errors (delta method).

The physical parameters :math:`p = f(\theta_e, \theta_m)` follow from the
electrical and mechanical regression parameters through
``DCMotorRegressors.physical``. The two equations are estimated by separate
estimators, so their estimates are taken as independent and

.. math::

    \operatorname{Var} p \approx \nabla_{\theta_e} f^T C_e \nabla_{\theta_e} f
        + \nabla_{\theta_m} f^T C_m \nabla_{\theta_m} f ,

with the gradients by central differences of ``physical`` itself (so the
mapping is not restated here).
"""

from __future__ import annotations

import numpy as np

__all__ = ["physical_tracks", "physical_estimates"]


def _call(regs, th_e, th_m):
    out = regs.physical(th_e, th_m)
    return {k: np.asarray(v, dtype=np.float64).reshape(-1) for k, v in out.items()}


def physical_tracks(regs, th_e, C_e, th_m, C_m):
    """Values and standard errors along K points.

    Parameters
    ----------
    th_e : ndarray, shape (K, 3); C_e : ndarray, shape (K, 3, 3)
    th_m : ndarray, shape (K, 4); C_m : ndarray, shape (K, 4, 4)

    Returns
    -------
    dict
        name → (values (K,), stderr (K,)).
    """
    th_e = np.atleast_2d(np.asarray(th_e, dtype=np.float64))
    th_m = np.atleast_2d(np.asarray(th_m, dtype=np.float64))
    f0 = _call(regs, th_e, th_m)
    var = {k: np.zeros_like(v) for k, v in f0.items()}
    for which, th, C in (("e", th_e, np.asarray(C_e)), ("m", th_m, np.asarray(C_m))):
        n = th.shape[1]
        grads = {k: np.zeros((th.shape[0], n)) for k in f0}
        for i in range(n):
            h = 1e-6 * np.maximum(np.abs(th[:, i]), 1e-9)
            up, dn = th.copy(), th.copy()
            up[:, i] += h
            dn[:, i] -= h
            fu = _call(regs, up, th_m) if which == "e" else _call(regs, th_e, up)
            fd = _call(regs, dn, th_m) if which == "e" else _call(regs, th_e, dn)
            for k in f0:
                grads[k][:, i] = (fu[k] - fd[k]) / (2 * h)
        for k in f0:
            g = grads[k]
            var[k] = var[k] + np.einsum("ki,kij,kj->k", g, C, g)
    return {k: (f0[k], np.sqrt(np.maximum(var[k], 0.0))) for k in f0}


def physical_estimates(regs, fe, fm):
    """Final physical estimates from the electrical and mechanical fits: name → (value, stderr)."""
    tr = physical_tracks(regs, fe.theta[None], fe.cov[None], fm.theta[None], fm.cov[None])
    return {k: (float(v[0]), float(s[0])) for k, (v, s) in tr.items()}
