r"""Instrumental-variable ARX estimates: ``iv4`` and ``ivx``."""

from __future__ import annotations

import numpy as np
from scipy import linalg, signal

from ..._validation import as_float_array, param_error
from .._arx import single_output_arx

__all__ = ["iv4", "ivx"]



def _instrument_rows(model, x, U):
    """Instrument rows built like the ARX rows with x in place of y: [-x lags, u lags]."""
    return model._fixed_regression(x, U, model._single)[1]


def _iv_solve(Z, Phi, y):
    r"""θ = (ZᵀΦ)⁻¹Zᵀy, σ̂²(ZᵀΦ)⁻¹(ZᵀZ)(ΦᵀZ)⁻¹ by LU solves (no inverse)."""
    S = Z.T @ Phi
    lu = linalg.lu_factor(S)
    theta = linalg.lu_solve(lu, Z.T @ y)
    eps = y - Phi @ theta
    N, d = Phi.shape
    sigma2 = float(eps @ eps) / max(N - d, 1)
    X = linalg.lu_solve(lu, Z.T @ Z)            # S⁻¹ ZᵀZ
    cov = sigma2 * linalg.lu_solve(lu, X.T)     # S⁻¹ (ZᵀZ) S⁻ᵀ
    return theta, 0.5 * (cov + cov.T), eps, sigma2


def _iv_model(na, nb, nk):
    """An ARX whose rows are formed on the runs of complete samples of each experiment,
    kept for the instrument rows (which then match the regressor rows one for one)."""
    model = single_output_arx(na, nb, nk, where="instrumental-variable estimation")
    model._splits_at_gaps = True
    return model


def _on_pieces(model, f, X, shape=None):
    """``f`` of X on each piece of the fit (experiment, run between gaps); NaN elsewhere."""
    out = np.full(X.shape if shape is None else shape, np.nan)
    for a, b in model._fit_pieces:
        out[a:b] = f(X[a:b])
    return out


def _finish(model, reg, Phi, theta, cov, sigma2, method):
    model.theta = theta
    model.cov = cov
    model.noise_variance = sigma2
    model.residuals = reg.y - Phi @ theta
    model.index = reg.index
    model.names = model._names()
    model.method = method
    return model


def ivx(data, na, nb, nk=1, instruments=None, *, u=None):
    r"""ARX estimate by instrumental variables with given instruments (MATLAB's ``ivx``).

    .. math::

        \hat\theta = \Big(\sum_k \zeta_k\varphi_k^T\Big)^{-1}\sum_k\zeta_k y_k,\qquad
        \operatorname{cov}\hat\theta = \hat\sigma^2(Z^T\Phi)^{-1}(Z^TZ)(\Phi^TZ)^{-1}

    (Ljung 1999, eqs. 7.118 and 9.60 with white ε), with Φ the ARX
    regressors of rows k = s … N−1 (:class:`ARX`) and
    :math:`\hat\sigma^2 = \sum\varepsilon_k^2/(N-s-d)` of the IV
    prediction errors.

    Parameters
    ----------
    data : IDData, or pair (y, u)
    na, nb, nk : int (nb, nk: or per input)
        The ARX orders.
    instruments : array_like, shape (N,) or (N - s, d)
        A signal x shaped like y: the instrument rows are built like the
        ARX rows with x in place of y, :math:`\zeta_k = [-x_{k-1}, …,
        -x_{k-n_a}, u_{k-n_k}, …]` (MATLAB's ``ivx``); or the matrix of
        instrument rows itself, one per regression row.
    u : array_like, optional
        The input when ``data`` is the output.

    Returns
    -------
    ARX
        ``theta``, ``cov`` (the IV covariance above), ``stderr``,
        ``residuals`` (y − Φθ), ``noise_variance`` and ``method="ivx"``.

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, secs. 7.6, 9.5 and 15.3.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import ivx
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(5000); e = rng.standard_normal(5000)
    >>> y = lfilter([0, 1.0], [1, -0.8], u) + lfilter([1, 0.9], [1, -0.8], e)
    >>> x = lfilter([0, 1.0], [1, -0.8], u)          # noise-free output as instrument
    >>> m = ivx((y, u), 1, 1, 1, x)
    >>> bool(np.allclose(m.theta, [-0.8, 1.0], atol=0.05))
    True
    """
    model = _iv_model(na, nb, nk)
    yv, U = model._data(data, u, fitting=True)
    reg, Phi = model._fixed_regression(yv, U, model._single)
    if instruments is None:
        raise param_error("instruments", "a signal shaped like y or a matrix of instrument rows",
                          None, exc=TypeError)
    X = as_float_array(getattr(instruments, "to_numpy", lambda: instruments)(), "instruments",
                       ndim=(1, 2))
    if X.ndim == 1:
        if X.shape[0] != yv.shape[0]:
            raise param_error("instruments", f"a signal of length {yv.shape[0]} (as y)",
                              f"<length {X.shape[0]}>")
        Z = _instrument_rows(model, X, U)
    else:
        if X.shape != Phi.shape:
            raise param_error("instruments", f"a matrix of shape {Phi.shape} (one row per "
                              "regression row)", f"<shape {X.shape}>")
        Z = X
    theta, cov, _, sigma2 = _iv_solve(Z, Phi, reg.y)
    return _finish(model, reg, Phi, theta, cov, sigma2, "ivx")


def iv4(data, na, nb, nk=1, *, u=None):
    r"""ARX estimate by Ljung's four-stage instrumental-variable method (MATLAB's ``iv4``).

    1. least-squares ARX: :math:`\hat A_1, \hat B_1`;
    2. IV with instruments from the stage-1 model simulated on u,
       :math:`x = (\hat B_1/\hat A_1)u`: :math:`\hat A_2, \hat B_2`;
    3. an AR model :math:`L(q)v_k = e_k` of order na + nb (over all inputs'
       nb) of the stage-2 residuals :math:`v_k = \hat A_2(q)y_k - \hat
       B_2(q)u_k` (rows k = s … N−1) by least squares;
    4. IV with instruments from the stage-2 model, :math:`x =
       (\hat B_2/\hat A_2)u`, where y, u and x are all prefiltered by
       L(q) before the regressor and instrument rows are built.

    Every filter (simulation and prefilter) starts from zero on the whole
    record; the rows are k = s … N−1 as in :class:`ARX`. A merged record
    (:meth:`IDData.merge`) and one with NaN gaps are taken piece by piece
    (each experiment, each run of complete samples between gaps): every
    filter restarts and the rows of each piece are stacked.

    Parameters
    ----------
    data : IDData, or pair (y, u)
    na, nb, nk : int (nb, nk: or per input)
    u : array_like, optional
        The input when ``data`` is the output.

    Returns
    -------
    ARX
        The stage-4 estimate with the IV covariance
        :math:`\hat\sigma^2(Z^T\Phi)^{-1}(Z^TZ)(\Phi^TZ)^{-1}` of the
        prefiltered rows (σ̂² from their prediction errors, which L(q)
        whitens), ``residuals`` the unfiltered y − Φθ, ``method="iv4"``
        and ``prefilter`` (L, leading 1).

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, sec. 15.3, eqs. 15.21–15.26.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import iv4
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(5000); e = rng.standard_normal(5000)
    >>> y = lfilter([0, 1.0], [1, -0.8], u) + lfilter([1, 0.9], [1, -0.8], e)
    >>> m = iv4((y, u), 1, 1, 1)
    >>> bool(np.allclose(m.theta, [-0.8, 1.0], atol=0.05))
    True
    """
    from ..._lstsq import lstsq

    model = _iv_model(na, nb, nk)
    yv, U = model._data(data, u, fitting=True)
    reg, Phi = model._fixed_regression(yv, U, model._single)
    # stage 1: least squares
    theta = np.asarray(lstsq(Phi, reg.y).theta, dtype=np.float64)
    # stage 2: instruments simulated from the stage-1 model (restarted in each piece)
    model.theta = theta
    x = _on_pieces(model, model.simulate, U, U.shape[:1])
    theta, *_ = _iv_solve(_instrument_rows(model, x, U), Phi, reg.y)
    # stage 3: AR(na + nb) of the stage-2 residuals by least squares, inside each piece
    v = reg.y - Phi @ theta
    nl = model.na + sum(model._nb)
    rb = model._row_bounds
    vs = [v[a:b] for a, b in zip(rb[:-1], rb[1:]) if b - a > nl]
    if sum(w.size - nl for w in vs) <= nl:
        raise param_error("data", f"a record with more than {2 * nl} rows for the stage-3 AR "
                          f"model of order {nl}", f"<{v.size} rows>")
    V = np.vstack([np.column_stack([w[nl - j - 1: w.size - j - 1] for j in range(nl)])
                   for w in vs])
    ell = np.asarray(lstsq(-V, np.concatenate([w[nl:] for w in vs])).theta, dtype=np.float64)
    Lpoly = np.r_[1.0, ell]
    # stage 4: IV with instruments of the stage-2 model, everything prefiltered by L
    model.theta = theta
    x = _on_pieces(model, model.simulate, U, U.shape[:1])

    def prefilter(X):
        return signal.lfilter(Lpoly, [1.0], X, axis=0)

    yf, Uf, xf = (_on_pieces(model, prefilter, X) for X in (yv, U, x))
    regf, Phif = model._fixed_regression(yf, Uf, model._single)
    Zf = _instrument_rows(model, xf, Uf)
    theta, cov, _, sigma2 = _iv_solve(Zf, Phif, regf.y)
    model.prefilter = Lpoly
    return _finish(model, reg, Phi, theta, cov, sigma2, "iv4")
