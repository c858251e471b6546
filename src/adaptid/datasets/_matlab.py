r"""MATLAB-compatible signal helpers for reproducing published procedures.

Published identification procedures (for instance the IDIM-LS script of
the EMPS benchmark, Janot, Gautier & Brunot 2019) are MATLAB scripts; their
printed numbers depend on MATLAB's exact edge handling, which differs from
SciPy's defaults. These helpers reproduce MATLAB's conventions with SciPy:

* :func:`matlab_filtfilt` — ``filtfilt(b, a, x)``: odd reflection padding of
  length ``3*(max(len(a), len(b)) - 1)`` (SciPy's default padding is
  ``3*max(len(a), len(b))``);
* :func:`matlab_decimate` — ``decimate(x, r)``: order-8 Chebyshev type I
  low-pass (0.05 dB ripple, cut-off ``0.8/r``) applied with
  :func:`matlab_filtfilt`, then every r-th sample *ending at the last one*
  (SciPy's :func:`scipy.signal.decimate` starts at the first sample);
* :func:`central_difference` — the ``diffcent`` derivative of the
  benchmark scripts (M. Gautier, 1994).
"""

from __future__ import annotations

import numpy as np

from .._lazy import lazy
from .._validation import as_float_array, check_int, check_scalar, param_error

signal = lazy("scipy.signal")

__all__ = ["matlab_filtfilt", "matlab_decimate", "central_difference"]


def _as_signal(x, name: str) -> np.ndarray:
    return as_float_array(x, name, ndim=(1, 2))


def matlab_filtfilt(b, a, x):
    r"""Zero-phase filtering exactly as MATLAB's ``filtfilt(b, a, x)``.

    Parameters
    ----------
    b : array_like, shape (nb,)
        Numerator coefficients.
    a : array_like, shape (na,)
        Denominator coefficients, ``a[0] != 0``.
    x : array_like, shape (N,) or (N, m)
        Signal; a 2-D array is filtered column by column (MATLAB's
        convention), so ``N`` is the time axis.

    Returns
    -------
    y : ndarray, shape like x
        The signal filtered forward and backward.

    Notes
    -----
    The signal is extended at both ends by odd reflection about its end
    values (``2 x[0] - x[L:0:-1]``) with
    :math:`L = 3(\max(n_a, n_b) - 1)` samples, filtered forward from the
    steady-state initial conditions scaled by the first extended value
    (:func:`scipy.signal.lfilter_zi`), reversed, filtered again the same
    way, reversed, and the extension removed. This is
    ``scipy.signal.filtfilt(b, a, x, padtype="odd", padlen=L)``; SciPy's
    default ``padlen`` is :math:`3\max(n_a, n_b)`, one filter order longer,
    which changes the result near both ends.

    Raises
    ------
    ValueError
        If ``a[0] == 0`` or ``x`` has no more than ``L`` samples (MATLAB
        refuses such signals too).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import butter
    >>> from adaptid.datasets import matlab_filtfilt
    >>> b, a = butter(4, 0.2)
    >>> y = matlab_filtfilt(b, a, np.ones(50))
    >>> bool(np.allclose(y, 1.0))   # unit DC gain, no edge transient
    True
    """
    b = as_float_array(b, "b", ndim=1)
    a = as_float_array(a, "a", ndim=1)
    x = _as_signal(x, "x")
    if b.size == 0:
        raise param_error("b", "non-empty", b)
    if a.size == 0 or a[0] == 0.0:
        raise param_error("a", "non-empty with a[0] != 0", a)
    padlen = 3 * (max(a.size, b.size) - 1)
    if x.shape[0] <= padlen:
        raise param_error("x", f"longer than {padlen} samples (3 times the filter order)",
                          f"<{x.shape[0]} samples>")
    return signal.filtfilt(b, a, x, axis=0, padtype="odd", padlen=padlen)


def _cheby1_decimation_filter(r: int):
    # MATLAB decimate.m: order 8, 0.05 dB ripple, cut-off 0.8/r; the order is
    # reduced while the design is degenerate (all b zero) or its gain at the
    # cut-off is not -0.05 dB to 1e-6 dB (an ill-conditioned design).
    ripple = 0.05
    for order in range(8, 0, -1):
        b, a = signal.cheby1(order, ripple, 0.8 / r)
        if np.all(b == 0.0):
            continue
        _, h = signal.freqz(b, a, worN=[np.pi * 0.8 / r])
        if abs(20.0 * np.log10(abs(h[0])) + ripple) <= 1e-6:
            return b, a
    raise param_error("r", "a factor for which a stable Chebyshev filter exists", r)


def matlab_decimate(x, r):
    r"""Decimate by an integer factor exactly as MATLAB's ``decimate(x, r)``.

    Parameters
    ----------
    x : array_like, shape (N,) or (N, m)
        Signal; a 2-D array is decimated column by column.
    r : int
        Decimation factor, ``r >= 1``.

    Returns
    -------
    y : ndarray, shape (ceil(N / r),) or (ceil(N / r), m)
        The low-pass filtered signal at every r-th sample, the last sample
        of ``x`` included.

    Notes
    -----
    MATLAB's default (IIR) method:

    1. design the order-8 Chebyshev type I low-pass
       ``cheby1(8, 0.05, 0.8/r)`` (0.05 dB pass-band ripple, cut-off at 0.8
       times the new Nyquist frequency), lowering the order while the design
       is degenerate (its gain at the cut-off differs from −0.05 dB by more
       than 1e-6 dB), as ``decimate.m`` does;
    2. filter with :func:`matlab_filtfilt` (zero phase);
    3. keep the samples ``nbeg:r:N`` (1-based) with
       :math:`n_{beg} = r - (r\lceil N/r\rceil - N)`, i.e. the grid that ends
       on the last sample.

    :func:`scipy.signal.decimate` instead keeps ``0::r`` (0-based) and pads
    differently, so its output is not MATLAB's. ``r == 1`` returns a copy of
    ``x``.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.datasets import matlab_decimate
    >>> y = matlab_decimate(np.arange(95.0), 10)
    >>> y.shape   # MATLAB keeps samples 5, 15, ..., 95 (1-based)
    (10,)
    """
    x = _as_signal(x, "x")
    r = check_int(r, "r", low=1)
    if r == 1:
        return x.copy()
    b, a = _cheby1_decimation_filter(r)
    y = matlab_filtfilt(b, a, x)
    nd = x.shape[0]
    nbeg = r - (r * -(-nd // r) - nd)  # 1-based, as in decimate.m
    return y[nbeg - 1::r].copy()


def central_difference(y, dt):
    r"""Numerical derivative by central differences (``diffcent``).

    Parameters
    ----------
    y : array_like, shape (N,) or (N, m)
        Samples (column-wise when 2-D), ``N >= 3``.
    dt : float
        Sampling interval, ``dt > 0``.

    Returns
    -------
    yd : ndarray, shape like y
        The derivative estimate

        .. math::

            \dot y_1 = \frac{y_2 - y_1}{\Delta t},\quad
            \dot y_k = \frac{y_{k+1} - y_{k-1}}{2\Delta t}\ (1 < k < N),\quad
            \dot y_N = \frac{y_N - y_{N-1}}{\Delta t}.

    Notes
    -----
    This is ``diffcent.m`` (M. Gautier, LAN Robotique, 1994), used by the
    EMPS benchmark scripts (Janot, Gautier & Brunot 2019). It equals
    ``numpy.gradient(y, dt, axis=0)`` with first-order edges; it is written
    out here so that the operation order matches the MATLAB script.
    """
    y = _as_signal(y, "y")
    dt = check_scalar(dt, "dt", low=0.0, low_open=True)
    if y.shape[0] < 3:
        raise param_error("y", "at least 3 samples long", f"<{y.shape[0]} samples>")
    yd = np.empty_like(y)
    yd[0] = y[1] - y[0]
    yd[1:-1] = (y[2:] - y[:-2]) / 2.0
    yd[-1] = y[-1] - y[-2]
    return yd / dt
