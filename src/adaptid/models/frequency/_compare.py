r"""Models against a measured frequency response: :func:`adaptid.models.compare` with
a :class:`FrequencyResponse` as the data."""

from __future__ import annotations

import numpy as np

from ..._validation import check_choice, check_scalar, param_error
from ._response import FrequencyResponse

__all__ = ["FrequencyCompareResult", "compare_frequency", "frequency_fit"]


def frequency_fit(G, Gm):
    r"""Fit in percent of a model response to a measured one, per channel.

    .. math::

        \mathrm{fit} = 100\left(1 - \frac{\lVert G - \hat G\rVert_2}
        {\lVert G - \bar G\rVert_2}\right),

    norms of complex vectors over the frequencies where G is finite,
    :math:`\bar G` the mean of G over them (MATLAB's NRMSE applied to the
    complex response, as ``compare`` does with frequency-response data).
    """
    G, Gm = np.asarray(G), np.asarray(Gm)
    ok = np.isfinite(G) & np.isfinite(Gm)
    with np.errstate(divide="ignore", invalid="ignore"):
        num = np.sqrt(np.sum(np.where(ok, np.abs(G - Gm) ** 2, 0.0), axis=-1))
        mean = np.sum(np.where(ok, G, 0.0), axis=-1) / np.sum(ok, axis=-1)
        den = np.sqrt(np.sum(np.where(ok, np.abs(G - mean[..., None]) ** 2, 0.0), axis=-1))
        return 100.0 * (1.0 - num / den)


class FrequencyCompareResult:
    r"""Result of :func:`~adaptid.models.compare` on a measured frequency response.

    Attributes
    ----------
    fit : ndarray, shape (n_models,) or (n_models, ny, nu)
        Fit in percent of each model's response to the measured one
        (:func:`frequency_fit`); one per channel for several channels.
    names : tuple of str
    responses : list of FrequencyResponse
        Each model's response at the measured frequencies.
    data : FrequencyResponse
        The measured response.
    """

    def __init__(self, fit, names, responses, data):
        self.fit, self.names, self.responses, self.data = fit, tuple(names), responses, data

    def plot(self, sd=3, *, kind="bode", hz=False, fig=None):
        """Bode (or Nyquist) diagram of the data, its bands, and the models' responses (dashed).

        Returns
        -------
        matplotlib.figure.Figure
        """
        from ._figures import bode, nyquist

        sd = check_scalar(sd, "sd", low=0.0)
        kind = check_choice(kind, "kind", ("bode", "nyquist"))
        overlays = [(f"{n} (fit {np.mean(f):.1f} %)", r)
                    for n, f, r in zip(self.names, self.fit, self.responses)]
        if kind == "nyquist":
            return nyquist(self.data, sd, fig=fig, label="data", overlays=overlays)
        return bode(self.data, sd, hz=hz, fig=fig, label="data", overlays=overlays)

    def to_frame(self):
        """Fit per model (and channel): columns ``model``, ``output``, ``input``, ``fit``."""
        import pandas as pd

        F = np.asarray(self.fit).reshape(len(self.names), len(self.data.y_names), -1)
        rows = [(n, yn, un, float(F[k, i, j])) for k, n in enumerate(self.names)
                for i, yn in enumerate(self.data.y_names)
                for j, un in enumerate(self.data.u_names)]
        return pd.DataFrame(rows, columns=["model", "output", "input", "fit"])

    def summary(self):
        """Text: one line per model with its fit (mean over channels when several)."""
        lines = [f"Frequency-domain comparison at {self.data.w.size} frequencies "
                 "(fit: NRMSE of the complex response, %)"]
        lines += [f"  {n}: {np.mean(f):.2f} %" for n, f in zip(self.names, self.fit)]
        return "\n".join(lines)

    def __repr__(self):
        body = ", ".join(f"{n}: {np.mean(f):.2f} %" for n, f in zip(self.names, self.fit))
        return f"FrequencyCompareResult({body})"


def compare_frequency(data, models, *, names=None):
    """The frequency-domain branch of :func:`adaptid.models.compare` (validated there)."""
    if not models:
        raise param_error("models", "at least one fitted model", "<none>", exc=TypeError)
    if names is None:
        names = tuple(repr(m).split(" [")[0] for m in models)
    else:
        names = tuple(str(v) for v in names)
        if len(names) != len(models):
            raise param_error("names", f"{len(models)} labels", f"<{len(names)} labels>")
    responses, fits = [], []
    for i, m in enumerate(models):
        if not hasattr(m, "freqresp"):
            raise param_error(f"models[{i}]", "a model with freqresp(w)", m, exc=TypeError)
        mdt = getattr(m, "dt", None)
        if (mdt is None) != (data.dt is None) or (mdt is not None
                                                   and not np.isclose(mdt, data.dt)):
            raise param_error(f"models[{i}]", f"a model with the data's dt = {data.dt}",
                              f"<dt = {mdt}>")
        r = m.freqresp(data.w)
        if not isinstance(r, FrequencyResponse):
            r = FrequencyResponse(data.w, np.asarray(r), data.dt)
        if r.response.shape != data.response.shape:
            raise param_error(f"models[{i}]", f"a response of shape {data.response.shape} "
                              "(the data's outputs and inputs)", f"<shape {r.response.shape}>")
        responses.append(r)
        fits.append(frequency_fit(data.response, r.response))
    return FrequencyCompareResult(np.array(fits), names, responses, data)
