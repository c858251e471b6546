r"""The :class:`FrequencyResponse` results object and the delta-method helpers."""

from __future__ import annotations

import numpy as np

from ..._validation import as_float_array, check_choice, check_scalar, param_error

__all__ = ["FrequencyResponse", "default_grid", "polar_sd"]


def default_grid(dt):
    r"""MATLAB's default grid: :math:`\omega_k = \frac{k}{128}\frac{\pi}{dt}`, k = 1 … 128.

    Parameters
    ----------
    dt : float
        Sample time (> 0).

    Returns
    -------
    ndarray, shape (128,)
        In rad per time unit of ``dt``, up to the Nyquist frequency π/dt.
    """
    dt = check_scalar(dt, "dt", low=0.0, low_open=True)
    return np.arange(1, 129) / 128.0 * np.pi / dt


def polar_sd(G, c_rr, c_ri, c_ii):
    r"""Standard deviations of :math:`|G|` and :math:`\arg G` from the covariance of (Re G, Im G).

    First-order (delta-method) propagation, MATLAB's convention: with
    :math:`G = x + iy`, :math:`r = |G|`,

    .. math::

        \operatorname{var}|G| \approx \frac{x^2c_{rr} + 2xy\,c_{ri} + y^2c_{ii}}{r^2},\qquad
        \operatorname{var}\arg G \approx \frac{y^2c_{rr} - 2xy\,c_{ri} + x^2c_{ii}}{r^4}.

    Returns
    -------
    (ndarray, ndarray)
        The standard deviations of the magnitude and of the phase (radians).
    """
    x, y = G.real, G.imag
    r2 = x * x + y * y
    with np.errstate(divide="ignore", invalid="ignore"):
        vm = (x * x * c_rr + 2 * x * y * c_ri + y * y * c_ii) / r2
        vp = (y * y * c_rr - 2 * x * y * c_ri + x * x * c_ii) / (r2 * r2)
    return np.sqrt(np.maximum(vm, 0.0)), np.sqrt(np.maximum(vp, 0.0))


def _names(value, default, n, name):
    if value is None:
        return (default,) if n == 1 else tuple(f"{default}{i + 1}" for i in range(n))
    names = (value,) if isinstance(value, str) else tuple(str(v) for v in value)
    if len(names) != n:
        raise param_error(name, f"{n} name(s)", f"<{len(names)} names>")
    return names


def _optional(x, name, shape):
    if x is None:
        return None
    arr = as_float_array(x, name, allow_nan=True)
    if arr.shape != shape:
        raise param_error(name, f"of shape {shape} like the response", f"<shape {arr.shape}>")
    return arr


class FrequencyResponse:
    r"""A frequency response with the standard deviations of its magnitude and phase.

    Parameters
    ----------
    w : array_like, shape (nw,)
        Frequencies in rad per time unit (of ``dt`` for a discrete response),
        positive and increasing.
    response : array_like of complex, shape (nw,) or (ny, nu, nw)
        :math:`G(e^{i\omega\,dt})` (discrete) or :math:`G(i\omega)`
        (continuous, ``dt=None``); (nw,) for one input and one output.
    dt : float, optional
        Sample time; None for a continuous-time (or unspecified) response.
    magnitude_sd, phase_sd : array_like, optional
        Standard deviations of :math:`|G|` and of the phase (radians), the
        shape of ``response``.
    noise_spectrum : array_like, optional
        The output disturbance spectrum :math:`\Phi_v(\omega)`, shape (nw,)
        (or (ny, nw)).
    y_names, u_names : str or sequence of str, optional
        Output and input names (default ``y``/``u``, numbered when several).

    Attributes
    ----------
    w, response, dt, magnitude_sd, phase_sd, noise_spectrum, y_names, u_names
    magnitude : ndarray
        :math:`|G|`.
    phase : ndarray
        :math:`\arg G` in radians, unwrapped along the frequency axis.
    """

    def __init__(self, w, response, dt=None, *, magnitude_sd=None, phase_sd=None,
                 noise_spectrum=None, y_names=None, u_names=None):
        self.w = as_float_array(w, "w", ndim=1)
        if self.w.size and (np.any(self.w < 0) or np.any(np.diff(self.w) <= 0)):
            raise param_error("w", "non-negative and increasing", "<unordered frequencies>")
        G = np.asarray(response, dtype=complex)
        nw = self.w.size
        if G.shape == (nw,):
            ny = nu = 1
        elif G.ndim == 3 and G.shape[2] == nw:
            ny, nu = G.shape[:2]
        else:
            raise param_error("response", f"of shape ({nw},) or (ny, nu, {nw})",
                              f"<shape {G.shape}>")
        self.response = G
        self.dt = None if dt is None else check_scalar(dt, "dt", low=0.0, low_open=True)
        self.magnitude_sd = _optional(magnitude_sd, "magnitude_sd", G.shape)
        self.phase_sd = _optional(phase_sd, "phase_sd", G.shape)
        if noise_spectrum is not None:
            ns = as_float_array(noise_spectrum, "noise_spectrum", allow_nan=True)
            if ns.shape not in ((nw,), (ny, nw)):
                raise param_error("noise_spectrum", f"of shape ({nw},) or ({ny}, {nw})",
                                  f"<shape {ns.shape}>")
            noise_spectrum = ns
        self.noise_spectrum = noise_spectrum
        self.y_names = _names(y_names, "y", ny, "y_names")
        self.u_names = _names(u_names, "u", nu, "u_names")

    # ------------------------------------------------------------ derived
    @property
    def magnitude(self):
        """:math:`|G|`, the shape of ``response``."""
        return np.abs(self.response)

    @property
    def phase(self):
        """Phase of G in radians, unwrapped along the frequency axis."""
        return np.unwrap(np.angle(self.response), axis=-1)

    def __array__(self, dtype=None, copy=None):
        """``np.asarray(fr)`` is :attr:`response`."""
        return self.response if dtype is None else self.response.astype(dtype)

    @property
    def is_siso(self):
        """True when ``response`` has shape (nw,)."""
        return self.response.ndim == 1

    def _pairs(self):
        """[(output index, input index, name, G, |G| sd, phase sd)] for every channel."""
        G3 = self.response.reshape(len(self.y_names), len(self.u_names), -1)
        sds = [None if s is None else s.reshape(G3.shape)
               for s in (self.magnitude_sd, self.phase_sd)]
        out = []
        for i, yn in enumerate(self.y_names):
            for j, un in enumerate(self.u_names):
                out.append((i, j, f"{un} → {yn}", G3[i, j],
                            None if sds[0] is None else sds[0][i, j],
                            None if sds[1] is None else sds[1][i, j]))
        return out

    # ------------------------------------------------------------ results
    def to_frame(self):
        """The response as a pandas table.

        Columns ``w``, ``magnitude``, ``phase`` (radians), ``magnitude_sd``,
        ``phase_sd`` (when known) and ``noise_spectrum`` (when known); with
        several channels also ``output`` and ``input`` (long format).
        """
        try:
            import pandas as pd
        except ImportError as err:  # pragma: no cover - depends on the extra
            raise ImportError("to_frame needs pandas: pip install 'adaptid[pandas]'") from err
        frames = []
        ns = self.noise_spectrum
        for i, _, _, G, msd, psd in self._pairs():
            cols = {"w": self.w, "magnitude": np.abs(G), "phase": np.unwrap(np.angle(G))}
            if msd is not None:
                cols["magnitude_sd"] = msd
            if psd is not None:
                cols["phase_sd"] = psd
            if ns is not None:
                cols["noise_spectrum"] = ns if ns.ndim == 1 else ns[i]
            frames.append(cols)
        if self.is_siso:
            return pd.DataFrame(frames[0])
        rows = []
        for (i, j, *_), cols in zip(self._pairs(), frames):
            df = pd.DataFrame(cols)
            df.insert(0, "input", self.u_names[j])
            df.insert(0, "output", self.y_names[i])
            rows.append(df)
        return pd.concat(rows, ignore_index=True)

    def summary(self):
        """A short text description (frequencies, channels, peak gain, uncertainty)."""
        lines = [f"Frequency response: {len(self.y_names)} output(s) × {len(self.u_names)} "
                 f"input(s), {self.w.size} frequencies"]
        if self.w.size:
            unit = "rad/s" if self.dt is not None else "rad/time unit"
            lines.append(f"  w = {self.w[0]:.4g} … {self.w[-1]:.4g} {unit}"
                         + (f", dt = {self.dt:g}" if self.dt is not None else " (continuous)"))
            for *_, name, G, msd, _ in self._pairs():
                mag = np.abs(G)
                k = int(np.nanargmax(mag)) if np.any(np.isfinite(mag)) else 0
                sd = "" if msd is None else f" ± {msd[k]:.3g} (1 sd)"
                lines.append(f"  {name}: peak |G| = {mag[k]:.4g}{sd} at w = {self.w[k]:.4g}")
        lines.append("  standard deviations: " + ("yes" if self.magnitude_sd is not None else "no")
                     + "; noise spectrum: " + ("yes" if self.noise_spectrum is not None else "no"))
        return "\n".join(lines)

    def __repr__(self):
        sd = ", with sd" if self.magnitude_sd is not None else ""
        return (f"FrequencyResponse({len(self.y_names)}×{len(self.u_names)}, "
                f"{self.w.size} frequencies, dt={self.dt}{sd})")

    def plot(self, sd=3, *, kind="bode", hz=False, fig=None):
        r"""Bode (magnitude in dB, phase in degrees) or Nyquist diagram, with ±sd bands.

        One magnitude–phase pair (Bode) or one panel (Nyquist) per channel,
        on the ny × nu grid of outputs and inputs, titled ``input → output``;
        every axis carries its quantity and unit (rad/s or Hz when ``dt`` is
        known, else per time unit).

        Parameters
        ----------
        sd : float
            Width of the confidence bands in standard deviations (default 3,
            MATLAB's ``showConfidence``); 0 draws no bands. The magnitude
            band is :math:`|G| \pm sd\cdot\sigma_{|G|}` (its lower edge
            clipped just above 0 for the dB scale), the phase band
            :math:`\arg G \pm sd\cdot\sigma_{\arg G}`; in a Nyquist diagram
            ellipses with half-axes :math:`sd\cdot\sigma_{|G|}` along G and
            :math:`sd\cdot|G|\sigma_{\arg G}` across it, at 12 frequencies.
        kind : {"bode", "nyquist"}
        hz : bool
            Bode frequency axis in Hz (``w / 2π``) instead of rad/s.
        fig : matplotlib Figure, optional

        Returns
        -------
        matplotlib.figure.Figure
        """
        from ._figures import bode, nyquist

        sd = check_scalar(sd, "sd", low=0.0)
        kind = check_choice(kind, "kind", ("bode", "nyquist"))
        if kind == "nyquist":
            return nyquist(self, sd, fig=fig)
        return bode(self, sd, hz=hz, fig=fig)

    def plot_nyquist(self, sd=3, *, fig=None):
        """Nyquist diagram with ±sd ellipses: ``plot(sd, kind="nyquist")``."""
        return self.plot(sd, kind="nyquist", fig=fig)
