r"""Spectral analysis with frequency-dependent resolution: :func:`spafdr`."""

from __future__ import annotations

import numpy as np

from ..._validation import as_float_array, param_error
from ._response import FrequencyResponse
from ._spectral import _siso

__all__ = ["spafdr"]

#: number of frequencies of the default (logarithmic) grid
N_DEFAULT = 100


def _grid(w, N, dt):
    if w is None:
        return np.logspace(np.log10(2 * np.pi / (N * dt)), np.log10(np.pi / dt), N_DEFAULT)
    w = as_float_array(w, "w", ndim=1)
    if w.size == 0 or np.any(w < 0) or np.any(np.diff(w) <= 0) or w[-1] > np.pi / dt * (1 + 1e-12):
        raise param_error("w", f"non-empty, increasing frequencies in [0, π/dt = {np.pi / dt:.4g}]",
                          "<out-of-range or unordered frequencies>")
    return w


def _resolution(resolution, w, N, dt):
    floor = 2 * (2 * np.pi / (N * dt))           # a window of at least three DFT frequencies
    if resolution is None:
        if w.size == 1:
            return np.full(1, floor)
        gaps = np.diff(w)
        R = np.maximum(np.r_[gaps[0], gaps], np.r_[gaps, gaps[-1]])
        return np.maximum(R, floor)
    R = as_float_array(resolution, "resolution", ndim=(0, 1))
    R = np.broadcast_to(R, w.shape).astype(float) if R.ndim == 0 else R
    if R.shape != w.shape or np.any(R <= 0):
        raise param_error("resolution", f"positive, a scalar or of the shape of w ({w.size},)",
                          f"<shape {R.shape}>" if R.shape != w.shape else "<non-positive values>")
    return R


def spafdr(data, w=None, resolution=None):
    r"""Spectral analysis with frequency-dependent resolution: MATLAB's ``spafdr``.

    The ETFE smoothed over frequency with a window whose width may change
    from one frequency to the next (Ljung 1999, sec. 6.4, smoothing the
    ETFE with a frequency window; MATLAB's ``spafdr``, whose resolution is
    "the size of the smallest detail that the estimate resolves"). With
    the DFTs :math:`Y_k = \sum_t y_te^{-i\xi_kt}`, :math:`U_k` likewise, at
    :math:`\xi_k = 2\pi k/N` (k = 0 … N − 1, taken in [−π, π)), and at each
    frequency :math:`\omega_j` of ``w`` the Hann frequency window of
    half-width :math:`R_j` (``resolution``, rad per time unit),

    .. math::

        W_{jk} = \tfrac12\bigl(1 + \cos(\pi d_{jk}/R_j)\bigr)\ \text{for}\ |d_{jk}| < R_j,
        \ \text{else } 0,\qquad d_{jk} = \xi_k/dt - \omega_j\ \text{(circular)},

    the smoothed periodograms
    :math:`\hat\Phi_{xz}(\omega_j) = \sum_kW_{jk}X_k\bar Z_k/(N\sum_kW_{jk})` give

    .. math::

        \hat G(\omega_j) = \frac{\hat\Phi_{yu}}{\hat\Phi_u},\qquad
        \hat\Phi_v(\omega_j) = \hat\Phi_y - \frac{|\hat\Phi_{yu}|^2}{\hat\Phi_u},\qquad
        \operatorname{Var}\hat G(\omega_j) \approx
        N\hat\Phi_v\frac{\sum_kW_{jk}^2|U_k|^2}{(\sum_kW_{jk}|U_k|^2)^2}

    (the last from :math:`Y_k = GU_k + V_k` with :math:`\operatorname{E}|V_k|^2
    = N\Phi_v`, independent over k). The estimate is circular complex
    Gaussian, so :math:`\sigma_{|G|} = \sqrt{\operatorname{Var}\hat G/2}`
    and :math:`\sigma_{\arg G} = \sigma_{|G|}/|\hat G|`, as :func:`spa`. The
    noise spectrum is returned as :math:`dt\cdot\hat\Phi_v` (the scaling of
    :func:`spa`). A constant resolution :math:`R = 2\pi/(M\,dt)` is about the
    resolution of :func:`spa` with lag window M: the Hann lag window's
    spectral window has its first zeros at about ±2π/M, and
    :math:`\sum W^2/(\sum W)^2 \approx 0.75M/N` equals spa's
    :math:`\alpha_M/N`. Near ω = 0 the window holds conjugate DFT
    frequencies (±ξ), which are not independent: the variance is then
    underestimated by up to a factor 2.

    Parameters
    ----------
    data : IDData or (y, u)
        One output and one input (arrays: ``dt`` = 1).
    w : array_like, optional
        Frequencies in rad per time unit, increasing, in [0, π/dt].
        Default: 100 logarithmically spaced from 2π/(N·dt) to π/dt.
    resolution : float or array_like, optional
        :math:`R_j` in rad per time unit (a scalar or one per frequency).
        Default: the larger distance from :math:`\omega_j` to its neighbours
        in ``w`` (adjacent windows overlap by half: a logarithmic grid
        gives a resolution proportional to frequency), at least 2·2π/(N·dt).

    Returns
    -------
    FrequencyResponse
        With ``magnitude_sd``, ``phase_sd`` and ``noise_spectrum``; a
        frequency whose window holds no DFT frequency is NaN.

    References
    ----------
    L. Ljung (1999). *System Identification: Theory for the User*, 2nd ed.,
    sec. 6.4. MathWorks, System Identification Toolbox, ``spafdr``.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import spafdr
    >>> u = np.random.default_rng(0).standard_normal(4096)
    >>> fr = spafdr((lfilter([0, 1.0], [1, -0.5], u), u), w=[0.5, 2.0], resolution=0.1)
    >>> bool(np.allclose(fr.response, 1 / (np.exp(1j * fr.w) - 0.5), rtol=0.05))
    True
    """
    y, u, dt, yn, un = _siso(data, "spafdr")
    N = y.size
    if N < 4:
        raise param_error("data", "at least 4 samples", f"<{N} samples>")
    w = _grid(w, N, dt)
    R = _resolution(resolution, w, N, dt)
    Y, U = np.fft.fft(y), np.fft.fft(u)
    xi = 2 * np.pi * np.fft.fftfreq(N)                           # rad/sample in [−π, π)
    dist = np.angle(np.exp(1j * (xi[None, :] - (w * dt)[:, None]))) / dt     # circular, (nw, N)
    W = np.where(np.abs(dist) < R[:, None], 0.5 * (1 + np.cos(np.pi * dist / R[:, None])), 0.0)
    UU, YU, YY = np.abs(U) ** 2, Y * np.conj(U), np.abs(Y) ** 2
    sw = W.sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        phi_u = W @ UU / (N * sw)
        phi_yu = W @ YU / (N * sw)
        phi_y = W @ YY / (N * sw)
        G = phi_yu / phi_u
        phi_v = np.maximum(phi_y - np.abs(phi_yu) ** 2 / phi_u, 0.0)
        var_G = N * phi_v * ((W ** 2) @ UU) / (W @ UU) ** 2
        msd = np.sqrt(np.maximum(var_G, 0.0) / 2.0)
        psd = msd / np.abs(G)
    return FrequencyResponse(w, G, dt, magnitude_sd=msd, phase_sd=psd,
                             noise_spectrum=dt * phi_v, y_names=yn, u_names=un)
