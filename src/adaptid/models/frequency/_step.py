r"""Step responses with their standard deviations (first-order propagation).

For a discrete transfer function :math:`G = N/D` in the backward shift
:math:`q^{-1}`, with :math:`D = \prod_l P_l` a product of monic factors,
the step response over T samples is :math:`s = \frac{N}{D}\,\mathbb 1`
(zero initial conditions, a unit step applied at sample 0). It is linear in
the impulse response, and the impulse response's derivatives are filters:

.. math::

    \frac{\partial s}{\partial\theta} = \frac{q^{-k}}{D}\,\mathbb 1
    \quad(\theta\text{ the coefficient of }q^{-k}\text{ in }N),\qquad
    \frac{\partial s}{\partial\theta} = -\frac{q^{-k}}{P_l}\,s
    \quad(\theta\text{ the coefficient of }q^{-k}\text{ in }P_l),

the latter from :math:`\partial G/\partial\theta = -G\,q^{-k}/P_l`. With J
the T × d Jacobian and Σ the parameter covariance,
:math:`\operatorname{var}s_t \approx (J\Sigma J^\top)_{tt}`, exact when s is
linear in θ (FIR models).
"""

from __future__ import annotations

import numpy as np

from ..._lazy import lazy
from ..._validation import check_int, check_scalar
from ..._lazy import pyplot

signal = lazy("scipy.signal")

__all__ = ["StepResponse", "default_length", "step_with_sd"]

#: bounds of the default length (samples)
_T_MIN, _T_MAX = 20, 2000


def default_length(num, den):
    r"""Default number of samples: 10 slowest time constants, within [20, 2000].

    With :math:`r = \max|p|` over the poles (the roots of ``den``), the slowest
    time constant is :math:`\tau = -1/\ln r` samples; the length is
    :math:`\lceil 10\tau\rceil` plus the numerator length (delays), clipped
    to [20, 2000]. Without poles (FIR) it is the numerator length + 10
    (at least 20); unstable or marginal poles (r ≥ 1) give 2000.
    """
    den = np.trim_zeros(np.asarray(den, dtype=float), "b")
    extra = np.asarray(num).size
    r = np.max(np.abs(np.roots(den))) if den.size > 1 else 0.0
    if r <= 0.0:
        T = extra + 10
    elif r >= 1.0:
        T = _T_MAX
    else:
        T = int(np.ceil(-10.0 / np.log(r))) + extra
    return int(min(max(T, _T_MIN), _T_MAX))


def step_with_sd(num, num_par, dens, T, cov=None):
    """Step response (T,) of num/∏dens and its standard deviation (T,) or None.

    ``num`` and ``dens`` as in ``_PolyModel._freq_structure``: coefficient
    arrays in q⁻¹ with ``[(θ index, power), …]``.
    """
    D = np.ones(1)
    for p, _ in dens:
        D = np.convolve(D, p)
    ones = np.ones(T)
    s = signal.lfilter(num, D, ones)
    if cov is None:
        return s, None
    S = np.asarray(cov, dtype=float)
    J = np.zeros((T, S.shape[0]))
    base = signal.lfilter([1.0], D, ones)            # 1/D applied to the step
    for j, k in num_par:
        J[k:, j] += base[: T - k]
    for p, par in dens:
        fs = signal.lfilter([1.0], p, s)              # s / P_l
        for j, k in par:
            J[k:, j] -= fs[: T - k]
    var = np.einsum("ti,ij,tj->t", J, S, J)
    return s, np.sqrt(np.maximum(var, 0.0))


class StepResponse:
    r"""A step response with its standard deviation per sample.

    Parameters
    ----------
    t : ndarray, shape (T,)
        Times ``k·dt``, k = 0 … T−1.
    response : ndarray, shape (T,) or (ny, nu, T)
        Output after a unit step on the input at t = 0 (zero initial conditions).
    sd : ndarray or None
        Standard deviations, the shape of ``response`` (None without a covariance).
    dt : float
        Sample time.
    y_names, u_names : tuple of str
    time_unit : str
        Unit of ``dt`` for the axis label (default ``"s"``).
    """

    def __init__(self, t, response, sd=None, *, dt=1.0, y_names=("y",), u_names=("u",),
                 time_unit="s"):
        self.t = np.asarray(t, dtype=float)
        self.response = np.asarray(response, dtype=float)
        self.sd = None if sd is None else np.asarray(sd, dtype=float)
        self.dt = check_scalar(dt, "dt", low=0.0, low_open=True)
        self.y_names, self.u_names = tuple(y_names), tuple(u_names)
        self.time_unit = time_unit

    def __array__(self, dtype=None, copy=None):
        """``np.asarray(sr)`` is :attr:`response`."""
        return self.response if dtype is None else self.response.astype(dtype)

    def _pairs(self):
        R = self.response.reshape(len(self.y_names), len(self.u_names), -1)
        S = None if self.sd is None else self.sd.reshape(R.shape)
        return [(i, j, f"{un} → {yn}", R[i, j], None if S is None else S[i, j])
                for i, yn in enumerate(self.y_names) for j, un in enumerate(self.u_names)]

    def to_frame(self):
        """The response as a pandas table.

        Columns ``t``, ``response`` and ``sd`` (when known); with several
        channels also ``output`` and ``input`` (long format).
        """
        try:
            import pandas as pd
        except ImportError as err:  # pragma: no cover - depends on the extra
            raise ImportError("to_frame needs pandas: pip install 'adaptid[pandas]'") from err
        frames = []
        for i, j, _, r, s in self._pairs():
            cols = {"t": self.t, "response": r}
            if s is not None:
                cols["sd"] = s
            df = pd.DataFrame(cols)
            if self.response.ndim > 1:
                df.insert(0, "input", self.u_names[j])
                df.insert(0, "output", self.y_names[i])
            frames.append(df)
        return frames[0] if len(frames) == 1 else pd.concat(frames, ignore_index=True)

    def plot(self, sd=3, *, fig=None):
        """Step response(s) as stairs with ±sd bands.

        Parameters
        ----------
        sd : float
            Width of the bands in standard deviations (default 3); 0 draws none.
        fig : matplotlib Figure, optional

        Returns
        -------
        matplotlib.figure.Figure
            One panel per channel on the ny × nu grid, titled
            ``input → output``, the time axis in ``time_unit``, the output
            axis named after the output.
        """
        sd = check_scalar(sd, "sd", low=0.0)
        plt = pyplot()
        if fig is None:
            fig = plt.figure(figsize=(6.5, 3.5), layout="constrained")
        axes = fig.subplots(len(self.y_names), len(self.u_names), squeeze=False)
        for i, j, name, r, s in self._pairs():
            ax = axes[i, j]
            ax.step(self.t, r, where="post", lw=1.2, label="step response")
            if sd > 0 and s is not None:
                ax.fill_between(self.t, r - sd * s, r + sd * s, step="post", alpha=0.25, lw=0,
                                label=f"±{sd:g} sd")
            ax.set_title(name, fontsize=9)
            ax.set_xlabel(f"time ({self.time_unit})")
            ax.set_ylabel(self.y_names[i])
            ax.grid(True, lw=0.3)
            ax.legend(fontsize=8)
        fig.suptitle("Step response", fontsize=10)
        return fig

    def __repr__(self):
        sd = ", with sd" if self.sd is not None else ""
        return f"StepResponse({self.t.size} samples, dt={self.dt:g}{sd})"


def check_length(T):
    """Validate a user-given number of samples."""
    return check_int(T, "T", low=1)
