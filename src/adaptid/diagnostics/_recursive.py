r"""Brown–Durbin–Evans recursive residuals."""

from __future__ import annotations

import warnings

import numpy as np

from .._exceptions import ExcitationWarning
from .._validation import as_float_array, param_error
from .._kernels.layers._residuals import recursive_residuals_kernel

__all__ = ["recursive_residuals"]


def recursive_residuals(Phi, y):
    r"""Recursive residuals of a linear regression (Brown, Durbin & Evans).

    Parameters
    ----------
    Phi : array_like, shape (N, n)
        Regressors, one row :math:`\varphi_k^T` per sample, ``N > n``.
    y : array_like, shape (N,)
        Observations.

    Returns
    -------
    w : ndarray, shape (N - n,)
        ``w[k - n - 1]`` is the recursive residual of sample k (1-based,
        k = n+1 … N):

        .. math::

            w_k = \frac{y_k - \varphi_k^T \hat\theta_{k-1}}
                       {\sqrt{1 + \varphi_k^T
                        (\Phi_{k-1}^T \Phi_{k-1})^{-1} \varphi_k}},

        where :math:`\Phi_{k-1}` holds the first k−1 rows and
        :math:`\hat\theta_{k-1}` is the exact least-squares estimate on
        them. Entries whose :math:`\Phi_{k-1}` does not have full column
        rank are NaN (with an :class:`~adaptid.ExcitationWarning`).

    Raises
    ------
    ValueError
        If the shapes disagree, ``N <= n``, the data are not finite, or
        ``Phi`` does not have full column rank on its first N−1 rows.
    TypeError
        If the data are not real numbers.

    Warns
    -----
    ExcitationWarning
        If the first n rows are rank deficient, so that the first
        residuals are undefined (NaN).

    Notes
    -----
    Under the model :math:`y = \Phi\theta + e`, :math:`e \sim N(0, \sigma^2
    I)` with constant θ, the :math:`w_k` are independent
    :math:`N(0, \sigma^2)` (Brown, Durbin & Evans 1975, Lemma 1), and
    :math:`\sum_k w_k^2` equals the residual sum of squares of the
    least-squares fit on all N samples. They are the input of
    :func:`cusum` and :func:`cusum_squares`.

    Algorithm: the triangular factor of the augmented matrix
    :math:`[\Phi_k\ y_k]` is updated by Givens rotations, one sample at a
    time, in one compiled loop; after rotating sample k into the factor of
    samples 1..k−1, the last entry of the rotated row *is* :math:`w_k`
    (the product of the rotations' cosines is
    :math:`1/\sqrt{1 + \varphi_k^T(\Phi_{k-1}^T\Phi_{k-1})^{-1}\varphi_k}`).
    The start is exact (the QR factor of the first n samples, not a
    diffuse prior), no inverse and no normal equations are formed, and the
    cost is :math:`O(N n^2)`. Rank is judged on the diagonal of the factor:
    :math:`|R_{ii}| \le \max(N, n)\,\epsilon\,\|\Phi_{:,i}\|_2` counts as
    zero.

    References
    ----------
    .. [1] R. L. Brown, J. Durbin, J. M. Evans, "Techniques for testing the
       constancy of regression relationships over time", J. R. Statist.
       Soc. B 37(2):149–192, 1975.
    .. [2] F. Kianifard, W. H. Swallow, "A review of the development and
       application of recursive residuals in linear models", J. Am.
       Statist. Assoc. 91(433):391–400, 1996.
    .. [3] Å. Björck, *Numerical Methods for Least Squares Problems*, SIAM,
       1996, §3.2 (updating the QR factorisation).

    Examples
    --------
    The squared recursive residuals add up to the least-squares residual
    sum of squares:

    >>> import numpy as np
    >>> from adaptid.diagnostics import recursive_residuals
    >>> rng = np.random.default_rng(0)
    >>> Phi = rng.standard_normal((50, 3)); y = Phi @ [1.0, -2.0, 0.5] + rng.standard_normal(50)
    >>> w = recursive_residuals(Phi, y)
    >>> r = y - Phi @ np.linalg.lstsq(Phi, y, rcond=None)[0]
    >>> bool(np.isclose(w @ w, r @ r))
    True
    """
    Phi = as_float_array(Phi, "Phi", ndim=2)
    N, n = Phi.shape
    if n < 1:
        raise param_error("Phi", "of shape (N, n) with n >= 1", f"<shape {Phi.shape}>")
    if N <= n:
        raise param_error("Phi", f"taller than wide (N > n = {n} rows)", f"<shape {Phi.shape}>")
    y = as_float_array(y, "y", shape=(N,))
    colnorm = np.sqrt(np.einsum("ij,ij->j", Phi, Phi))
    tol = np.ascontiguousarray(max(N, n) * np.finfo(np.float64).eps * colnorm)
    R = np.zeros((n, n + 1))
    w = np.empty(N - n)
    n_undefined = recursive_residuals_kernel(Phi, y, tol, R, w)
    if n_undefined == N - n:
        raise param_error("Phi", f"of full column rank {n} on its first N-1 = {N - 1} rows",
                          "<a rank-deficient matrix>")
    if n_undefined:
        warnings.warn(
            f"the first {n + n_undefined} rows of Phi do not have full column rank "
            f"{n}: the first {n_undefined} recursive residuals are undefined (NaN); "
            f"drop them (w[{n_undefined}:]) before cusum or cusum_squares",
            ExcitationWarning, stacklevel=2)
    return w
