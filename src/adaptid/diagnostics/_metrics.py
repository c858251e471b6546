r"""Fit metrics of model outputs."""

from __future__ import annotations

import numpy as np

from .._validation import as_float_array, param_error

__all__ = ["fit_percent"]


def fit_percent(y, y_hat):
    r"""Normalised fit in percent (MATLAB ``compare``'s NRMSE fit).

    Parameters
    ----------
    y : array_like, shape (N,) or (N, p)
        Measured output.
    y_hat : array_like, shape like y
        Simulated or predicted output.

    Returns
    -------
    fit : float or ndarray, shape (p,)
        Per output,

        .. math::

            \mathrm{fit} = 100\left(1 - \frac{\lVert y - \hat y\rVert_2}
                                           {\lVert y - \bar y\rVert_2}\right),

        100 for a perfect model, 0 for the constant :math:`\bar y`,
        negative for worse.

    Raises
    ------
    ValueError
        If the shapes differ, values are not finite, or an output is
        constant.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.diagnostics import fit_percent
    >>> y = np.array([1.0, 2.0, 3.0, 4.0])
    >>> float(fit_percent(y, y))
    100.0
    """
    y = as_float_array(y, "y", ndim=(1, 2))
    y_hat = as_float_array(y_hat, "y_hat", shape=y.shape)
    dev = np.linalg.norm(y - y.mean(axis=0), axis=0)
    if np.any(dev == 0.0):
        raise param_error("y", "not constant", "<a constant output>")
    from .._teststats import fit_percent as _fit   # the one formula, shared with adaptid.models

    fit = _fit(y, y_hat)
    return float(fit) if y.ndim == 1 else fit
