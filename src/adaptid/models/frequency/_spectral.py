r"""Nonparametric frequency-response estimates: :func:`spa` and :func:`etfe`."""

from __future__ import annotations

import numpy as np

from ..._validation import as_float_array, check_int, param_error
from ._response import FrequencyResponse, default_grid

__all__ = ["spa", "etfe"]


def _siso(data, where):
    """(y (N,), u (N,), dt, y_name, u_name) from an IDData or a (y, u) pair."""
    from .._iddata import IDData

    if isinstance(data, IDData):
        if data.n_outputs != 1 or data.n_inputs != 1:
            raise param_error("data", f"one output and one input for {where}",
                              f"<{data.n_outputs} outputs, {data.n_inputs} inputs>")
        if data.n_experiments > 1:     # the covariances would reach across the boundary
            raise param_error("data", f"one experiment for {where}",
                              f"<{data.n_experiments} experiments>")
        return (as_float_array(data.outputs[:, 0], "y"), as_float_array(data.inputs[:, 0], "u"),
                data.dt, data.y_names[0], data.u_names[0])
    if not isinstance(data, (tuple, list)) or len(data) != 2:
        raise param_error("data", "an IDData or a (y, u) pair", f"<{type(data).__name__}>",
                          exc=TypeError)
    y = as_float_array(np.ravel(np.asarray(data[0], dtype=float)), "y", ndim=1)
    u = as_float_array(np.ravel(np.asarray(data[1], dtype=float)), "u", ndim=1)
    if y.shape != u.shape:
        raise param_error("u", f"of the length of y ({y.size})", f"<length {u.size}>")
    return y, u, 1.0, "y", "u"


def _covariances(x, z, M):
    r"""Biased covariances :math:`R_{xz}(\tau) = \frac1N\sum_t x_{t+\tau}z_t`, τ = −M … M."""
    N = x.size
    full = np.correlate(x, z, mode="full") / N       # lags −(N−1) … N−1
    return full[N - 1 - M: N + M]


def spa(data, window=None, w=None):
    r"""Spectral analysis with a Hann lag window (Blackman–Tukey): MATLAB's ``spa``.

    With the biased covariances of the data as given (no detrending)

    .. math::

        R_u(\tau) = \frac1N\sum_t u_{t+\tau}u_t,\qquad
        R_{yu}(\tau) = \frac1N\sum_t y_{t+\tau}u_t,\qquad |\tau|\le M,

    the Hann lag window :math:`W_M(\tau) = \tfrac12(1 + \cos(\pi\tau/M))` and
    :math:`\Phi_{xz}(\omega) = \sum_{|\tau|\le M} W_M(\tau)R_{xz}(\tau)e^{-i\omega\tau\,dt}`:

    .. math::

        \hat G(\omega) = \frac{\Phi_{yu}(\omega)}{\Phi_u(\omega)},\qquad
        \hat\Phi_v(\omega) = \Phi_y(\omega) - \frac{|\Phi_{yu}(\omega)|^2}{\Phi_u(\omega)}

    (Ljung 1999, sec. 6.4). The noise spectrum is returned multiplied by
    ``dt``, :math:`dt\cdot\hat\Phi_v` (MATLAB's scaling of a spectrum of
    sampled data; with ``dt`` = 1 it is the sum above).

    **Uncertainty.** Ljung (1999, eqs. 6.69–6.70): asymptotically
    :math:`\operatorname{Var}\hat G(\omega) \approx \frac{1}{N}\,\alpha_M\,
    \frac{\Phi_v(\omega)}{\Phi_u(\omega)}` with
    :math:`\alpha_M = \sum_{|\tau|\le M}W_M^2(\tau)` (≈ 0.75 M for the Hann
    window), and the estimate is circular complex Gaussian, so Re Ĝ and
    Im Ĝ are uncorrelated with half that variance each. The delta method
    then gives :math:`\sigma_{|G|} = \sqrt{\operatorname{Var}\hat G/2}` and
    :math:`\sigma_{\arg G} = \sigma_{|G|}/|\hat G|` (the estimated
    :math:`\hat\Phi_v`, :math:`\Phi_u` inserted).

    Parameters
    ----------
    data : IDData or (y, u)
        One output and one input (arrays of equal length; ``dt`` = 1 for
        arrays).
    window : int, optional
        Lag-window width M, 1 ≤ M < N (default MATLAB's min(N/10, 30)).
    w : array_like, optional
        Frequencies in rad per time unit (default MATLAB's 128-point grid
        :math:`\frac{k}{128}\frac{\pi}{dt}`, k = 1 … 128).

    Returns
    -------
    FrequencyResponse
        With ``magnitude_sd``, ``phase_sd`` and ``noise_spectrum``.
    """
    y, u, dt, yn, un = _siso(data, "spa")
    N = y.size
    if window is None:
        M = int(max(1, min(N // 10, 30)))
    else:
        M = check_int(window, "window", low=1, high=N - 1)
    w = default_grid(dt) if w is None else as_float_array(w, "w", ndim=1)
    tau = np.arange(-M, M + 1)
    W = 0.5 * (1.0 + np.cos(np.pi * tau / M))
    E = np.exp(-1j * np.outer(w * dt, tau))            # (nw, 2M+1)
    phi_u = (E @ (W * _covariances(u, u, M))).real
    phi_y = (E @ (W * _covariances(y, y, M))).real
    phi_yu = E @ (W * _covariances(y, u, M))
    with np.errstate(divide="ignore", invalid="ignore"):
        G = phi_yu / phi_u
        phi_v = np.maximum(phi_y - np.abs(phi_yu) ** 2 / phi_u, 0.0)
        var_G = float(np.sum(W ** 2)) / N * phi_v / phi_u
        msd = np.sqrt(np.maximum(var_G, 0.0) / 2.0)
        psd = msd / np.abs(G)
    return FrequencyResponse(w, G, dt, magnitude_sd=msd, phase_sd=psd,
                             noise_spectrum=dt * phi_v, y_names=yn, u_names=un)


def _hann_smooth(x, width):
    """Circular smoothing over the DFT grid with a Hann window of half-width ``width``."""
    j = np.arange(-width, width + 1)
    h = 0.5 * (1.0 + np.cos(np.pi * j / (width + 1)))
    N = x.size
    out = np.zeros_like(x)
    for jj, hh in zip(j, h):
        out = out + hh * np.roll(x, jj)
    return out / h.sum() if N else out


def etfe(data, smoothing=None):
    r"""Empirical transfer-function estimate :math:`Y(\omega)/U(\omega)`: MATLAB's ``etfe``.

    With the DFTs :math:`Y_k = \sum_t y_te^{-2\pi ikt/N}`, :math:`U_k`
    likewise, at the DFT frequencies :math:`\omega_k = 2\pi k/(N\,dt)`,
    k = 1 … ⌊N/2⌋:

    .. math::

        \hat G(\omega_k) = \frac{Y_k}{U_k}

    (Ljung 1999, sec. 6.3), exact for noise-free periodic data over an
    integer number of periods at the excited frequencies. Frequencies
    where :math:`|U_k| \le 10^{-10}\max|U|` (not excited) are NaN.

    With ``smoothing`` = s the estimate is the Hann-weighted average over
    the 2s + 1 neighbouring DFT frequencies (weights
    :math:`\tfrac12(1 + \cos(\pi j/(s + 1)))`, :math:`|j| \le s`, circular), weighted
    by :math:`|U|^2` (Ljung 1999, sec. 6.4):
    :math:`\hat G = \overline{Y\bar U}/\overline{|U|^2}`, and the noise
    spectrum
    :math:`\frac{dt}{N}\bigl(\overline{|Y|^2} - |\overline{Y\bar U}|^2/\overline{|U|^2}\bigr)`
    (zero without smoothing: one frequency fits exactly). No standard
    deviations are returned.

    Parameters
    ----------
    data : IDData or (y, u)
        One output and one input.
    smoothing : int, optional
        Half-width s ≥ 1 of the Hann frequency window (default: none).

    Returns
    -------
    FrequencyResponse
        At the DFT frequencies, with ``noise_spectrum``.
    """
    y, u, dt, yn, un = _siso(data, "etfe")
    N = y.size
    if N < 2:
        raise param_error("data", "at least 2 samples", f"<{N} samples>")
    Y, U = np.fft.fft(y), np.fft.fft(u)
    YU, UU, YY = Y * np.conj(U), np.abs(U) ** 2, np.abs(Y) ** 2
    if smoothing is not None:
        s = check_int(smoothing, "smoothing", low=1, high=max(1, N // 2))
        YU, UU, YY = (_hann_smooth(v, s) for v in (YU, UU, YY))
    k = np.arange(1, N // 2 + 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        G = YU[k] / UU[k]
        phi_v = np.maximum(YY[k] - np.abs(YU[k]) ** 2 / UU[k], 0.0) * dt / N
    dead = UU[k] <= (1e-10 * np.sqrt(UU.max())) ** 2
    G[dead] = np.nan
    phi_v[dead] = np.nan
    w = 2 * np.pi * k / (N * dt)
    return FrequencyResponse(w, G, dt, noise_spectrum=phi_v, y_names=yn, u_names=un)
