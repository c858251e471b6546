r"""Forward regression with orthogonal least squares (FROLS) and the order criteria."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["frols", "FrolsPath", "criteria", "CRITERIA"]

CRITERIA = ("aic", "bic", "fpe", "lilc")

#: a candidate whose squared norm after orthogonalisation is below this fraction of
#: its own squared norm lies (numerically) in the span of the selected terms
DEPENDENT = 1e-10
#: losses below this fraction of yᵀy are round-off (noise-free data): treated as equal
LOSS_FLOOR = 1e-20


@dataclass(frozen=True)
class FrolsPath:
    """The terms chosen in order, their ERR and the least-squares loss after each."""

    selected: np.ndarray   # (s,) candidate indices in the order chosen
    err: np.ndarray        # (s,) error reduction ratio of each
    ssr: np.ndarray        # (s,) residual sum of squares of the LS fit on the first d terms


def frols(basis, y, n_max):
    r"""FROLS: choose up to ``n_max`` candidates by the error reduction ratio.

    At step s every remaining candidate :math:`p_j` is (implicitly)
    orthogonalised against the chosen :math:`w_1 … w_{s-1}`,

    .. math::

        \tilde p_j = p_j - \sum_{r<s} \frac{w_r^T p_j}{w_r^T w_r} w_r,\qquad
        \mathrm{ERR}_j = \frac{(\tilde p_j^T y)^2}{(\tilde p_j^T\tilde p_j)\,(y^T y)},

    and the largest ERR is chosen (Billings, Chen & Korenberg 1989; Billings
    2013, sec. 3.2). The numerators and denominators of every candidate are
    updated by one product :math:`P^T w_s` per step
    (:meth:`MonomialBasis.project`, classical Gram–Schmidt on all candidates
    at once); the chosen column itself is orthogonalised by modified
    Gram–Schmidt, twice, and its ERR recomputed from :math:`w_s`.

    Parameters
    ----------
    basis : MonomialBasis
    y : ndarray, shape (N,)
    n_max : int

    Returns
    -------
    FrolsPath
    """
    sigma = float(y @ y)
    g = basis.project(y)
    r0 = basis.sq_norms()
    r = r0.copy()
    avail = r0 > 0
    W, sel, err, ssr = [], [], [], []
    e = y.copy()
    while len(sel) < n_max:
        with np.errstate(divide="ignore", invalid="ignore"):
            score = g * g / (r * sigma)
        ok = avail & (r > DEPENDENT * r0) & np.isfinite(score)
        if not ok.any():
            break
        score = np.where(ok, score, -np.inf)
        j = int(np.argmax(score))
        w = basis.columns([j])[:, 0]
        for _ in range(2):
            for v, vv in W:
                w -= (v @ w / vv) * v
        ww = float(w @ w)
        avail[j] = False
        if not ww > DEPENDENT * r0[j]:
            continue
        gy = float(w @ y)
        err.append(gy * gy / (ww * sigma))
        e -= (w @ e / ww) * w
        ssr.append(float(e @ e))
        h = basis.project(w)
        g -= h * (gy / ww)
        r -= h * h / ww
        W.append((w, ww))
        sel.append(j)
    return FrolsPath(selected=np.asarray(sel, dtype=np.intp), err=np.asarray(err),
                     ssr=np.asarray(ssr))


def criteria(ssr, n_rows, yty):
    r"""The four criteria for models of d = 1 … s terms, each shape (s,).

    With V = SSR/N (Ljung 1999, sec. 16.4's loss; SSR floored at
    ``LOSS_FLOOR``·yᵀy so that round-off cannot favour larger exact models):

    .. math::

        \mathrm{AIC} = N\log V + 2d,\quad \mathrm{BIC} = N\log V + d\log N,\quad
        \mathrm{FPE} = N\log V + N\log\frac{N+d}{N-d},\quad
        \mathrm{LILC} = N\log V + 2d\log\log N .
    """
    ssr = np.asarray(ssr, dtype=np.float64)
    N = float(n_rows)
    d = np.arange(1, ssr.size + 1, dtype=np.float64)
    V = np.maximum(ssr, LOSS_FLOOR * yty) / N
    base = N * np.log(V)
    with np.errstate(divide="ignore", invalid="ignore"):
        fpe = base + N * np.log((N + d) / (N - d))
    fpe = np.where(d < N, fpe, np.inf)
    return {"aic": base + 2 * d, "bic": base + d * np.log(N), "fpe": fpe,
            "lilc": base + 2 * d * np.log(np.log(N))}
