r"""Transfer-function estimation: :func:`tfest` and :class:`TransferFunctionModel`.

The algorithm and the conventions are in :func:`tfest`'s Notes.
"""

from __future__ import annotations

import numpy as np

from ..._lazy import lazy
from ..._validation import as_float_array, check_int, check_scalar, param_error
from ._response import FrequencyResponse, default_grid, polar_sd

signal = lazy("scipy.signal")
optimize = lazy("scipy.optimize")

__all__ = ["tfest", "TransferFunctionModel"]

_SK_ITER, _SK_TOL = 50, 1e-10


class TransferFunctionModel:
    r"""A SISO transfer function with the covariance of its coefficients (from :func:`tfest`).

    Attributes
    ----------
    num, den : ndarray
        Continuous: coefficients in descending powers of s (python-control's
        order), ``den[0] = 1``. Discrete: coefficients in ascending powers of
        :math:`z^{-1}` (like :attr:`adaptid.models.OE.B`/``F``), the
        numerator with its :math:`n_k` leading zeros, ``den[0] = 1``.
    dt : float or None
        Sample time; None for continuous time.
    delay : float or int
        Continuous: the input delay τ in time units (a factor
        :math:`e^{-s\tau}`). Discrete: in samples (already contained in
        ``num``'s leading zeros).
    theta : ndarray, shape (d,)
        ``[b…, a…]`` (see :func:`tfest`).
    cov : ndarray, shape (d, d), or None
    np_, nz, feedthrough
    """

    def __init__(self, b, a, *, dt=None, delay=0, nk=0, cov=None, loss=None,
                 y_name="y", u_name="u"):
        self.b = np.asarray(b, dtype=float)
        self.a = np.asarray(a, dtype=float)
        self.dt, self.delay, self.nk = dt, delay, nk
        self.cov = None if cov is None else np.asarray(cov, dtype=float)
        self.loss = loss
        self.y_name, self.u_name = y_name, u_name
        self.np_, self.nz = self.a.size, self.b.size - 1

    # ---------------------------------------------------------- structure
    @property
    def theta(self):
        """Parameters ``[b…, a…]``."""
        return np.concatenate([self.b, self.a])

    @property
    def stderr(self):
        """√diag(cov) (None without a covariance)."""
        return None if self.cov is None else np.sqrt(np.diag(self.cov))

    @property
    def num(self):
        """Numerator (see the class attributes for the order)."""
        if self.dt is None:
            return self.b[::-1].copy()
        return np.concatenate([np.zeros(self.nk), self.b])

    @property
    def den(self):
        """Monic denominator (see the class attributes for the order)."""
        if self.dt is None:
            return np.concatenate([[1.0], self.a[::-1]])
        return np.concatenate([[1.0], self.a])

    def _x(self, w):
        """The evaluation variable: s = iω (continuous) or z⁻¹ = e^{−iω dt} (discrete)."""
        return 1j * w if self.dt is None else np.exp(-1j * w * self.dt)

    def _eval(self, w, theta=None):
        """G(w) and its complex Jacobian (nw, d) with respect to θ."""
        theta = self.theta if theta is None else theta
        x = self._x(w)
        Pn, Pd, lead = _bases(x, self.b.size, self.a.size, self.dt is None,
                                   self.nk, self.delay, w)
        N = Pn @ theta[: self.b.size]
        D = lead + Pd @ theta[self.b.size:]
        G = N / D
        J = np.hstack([Pn / D[:, None], -(G / D)[:, None] * Pd])
        return G, J

    # ----------------------------------------------------------- responses
    def _default_w(self):
        if self.dt is not None:
            return default_grid(self.dt)
        r = np.abs(np.roots(self.den))
        r = r[r > 0]
        lo, hi = (r.min(), r.max()) if r.size else (1.0, 1.0)
        return np.logspace(np.log10(lo) - 2, np.log10(hi) + 2, 200)

    def freqresp(self, w=None):
        r"""Frequency response with first-order standard deviations of magnitude and phase.

        Parameters
        ----------
        w : array_like, optional
            Frequencies (rad per time unit). Default: MATLAB's 128-point grid
            up to π/dt (discrete); 200 log-spaced points from a hundredth of
            the smallest to a hundred times the largest pole magnitude
            (continuous).

        Returns
        -------
        FrequencyResponse
        """
        w = self._default_w() if w is None else as_float_array(w, "w", ndim=1)
        G, J = self._eval(w)
        msd = psd = None
        if self.cov is not None:
            S = self.cov
            c_rr = np.einsum("wi,ij,wj->w", J.real, S, J.real)
            c_ri = np.einsum("wi,ij,wj->w", J.real, S, J.imag)
            c_ii = np.einsum("wi,ij,wj->w", J.imag, S, J.imag)
            msd, psd = polar_sd(G, c_rr, c_ri, c_ii)
        return FrequencyResponse(w, G, self.dt, magnitude_sd=msd, phase_sd=psd,
                                 y_names=self.y_name, u_names=self.u_name)

    def poles(self):
        """Poles (roots of the denominator in s or z) with first-order sd: :class:`Roots`."""
        from ._tfresp import tf_poles

        return tf_poles(self)

    def zeros(self):
        """Finite zeros (roots of the numerator in s or z) with first-order sd: :class:`Roots`."""
        from ._tfresp import tf_zeros

        return tf_zeros(self)

    def step_response(self, T=None):
        r"""Step response with its first-order standard deviation (from ``cov``).

        Discrete: T samples (default ten slowest time constants, within
        [20, 2000]); continuous: T points (default 200) from 0 to ten
        slowest time constants plus the delay, each exact (matrix
        exponential). The Jacobian columns are the step responses of
        :math:`\partial G/\partial\theta` (see :mod:`._tfresp`).

        Returns
        -------
        StepResponse
        """
        from ._tfresp import tf_step

        return tf_step(self, T)

    def rsample(self, n, seed=None):
        """n models with θ drawn from N(θ̂, ``cov``): MATLAB's ``rsample``.

        Returns
        -------
        list of TransferFunctionModel
        """
        from ._tfresp import tf_rsample

        n = check_int(n, "n", low=1)
        if self.cov is None:
            raise param_error("self", "a model with a parameter covariance (cov)", "<cov None>")
        return tf_rsample(self, n, seed)

    def to_control(self, pade_order=None):
        """The model as a python-control ``TransferFunction``.

        Parameters
        ----------
        pade_order : int, optional
            Continuous time with a delay: python-control has no delay
            element, so the delay is approximated by ``control.pade`` of this
            order (required then; a ValueError otherwise). Discrete delays
            are exact (powers of z⁻¹).
        """
        try:
            import control
        except ImportError as err:  # pragma: no cover - depends on the extra
            raise ImportError("to_control needs python-control: "
                              "pip install 'adaptid[control]'") from err
        io = {"inputs": [self.u_name], "outputs": [self.y_name]}
        if self.dt is not None:
            num, den = self.num, self.den
            L = max(num.size, den.size)
            num = np.concatenate([num, np.zeros(L - num.size)])
            den = np.concatenate([den, np.zeros(L - den.size)])
            return control.tf(num, den, self.dt, **io)
        sys = control.tf(self.num, self.den)
        if self.delay:
            if pade_order is None:
                raise param_error("pade_order", "an integer (the model has a delay of "
                                  f"{self.delay:g}, approximated by control.pade)", None)
            n, d = control.pade(self.delay, check_int(pade_order, "pade_order", low=1))
            sys = sys * control.tf(n, d)
        return control.tf(sys.num[0][0], sys.den[0][0], **io)

    # ------------------------------------------------------------- results
    def _names(self):
        if self.dt is None:
            return ([f"b{j} (s^{j})" for j in range(self.b.size)]
                    + [f"a{j} (s^{j})" for j in range(self.a.size)])
        return ([f"b{j} (z^-{self.nk + j})" for j in range(self.b.size)]
                + [f"a{j + 1} (z^-{j + 1})" for j in range(self.a.size)])

    def to_frame(self):
        """Parameter table: ``name``, ``value``, ``stderr`` (index: the parameter names)."""
        import pandas as pd

        se = self.stderr
        return pd.DataFrame({"value": self.theta,
                             "stderr": np.full(self.theta.size, np.nan) if se is None else se},
                            index=pd.Index(self._names(), name="parameter"))

    def summary(self):
        """A short text: the transfer function, its parameters with standard errors."""
        kind = "continuous" if self.dt is None else f"discrete, dt = {self.dt:g}"
        unit = "time units" if self.dt is None else "samples"
        lines = [f"Transfer function ({kind}): {self.np_} pole(s), {self.nz} zero(s), "
                 f"delay {self.delay:g} {unit}"]
        se = self.stderr
        for k, (name, v) in enumerate(zip(self._names(), self.theta)):
            lines.append(f"  {name:>14s} = {v: .6g}" + ("" if se is None else f"  ± {se[k]:.3g}"))
        if self.loss is not None:
            lines.append(f"  loss = {self.loss:.6g}")
        return "\n".join(lines)

    def plot(self, sd=3, *, w=None, hz=False, fig=None):
        """Bode diagram with ±sd bands (:meth:`FrequencyResponse.plot` of :meth:`freqresp`)."""
        return self.freqresp(w).plot(sd, hz=hz, fig=fig)

    def __repr__(self):
        kind = "continuous" if self.dt is None else f"dt={self.dt:g}"
        return f"TransferFunctionModel(np={self.np_}, nz={self.nz}, {kind}, delay={self.delay:g})"


def _bases(x, nb, na, continuous, nk, delay, w):
    """Numerator basis (nw, nb), denominator basis (nw, na) and the monic lead term."""
    if continuous:
        Pn = x[:, None] ** np.arange(nb)
        if delay:
            Pn = Pn * np.exp(-1j * w * delay)[:, None]
        Pd = x[:, None] ** np.arange(na)
        lead = x ** na
    else:
        Pn = x[:, None] ** (nk + np.arange(nb))
        Pd = x[:, None] ** (1 + np.arange(na))
        lead = np.ones_like(x)
    return Pn, Pd, lead


def _linear_fit(H, Pn, Pd, lead, weight):
    r"""min Σ weight |N − H D|² (D = lead + Pd a): real least squares in [b, a]."""
    M = np.hstack([Pn, -H[:, None] * Pd]) * weight[:, None]
    rhs = H * lead * weight
    A = np.vstack([M.real, M.imag])
    r = np.concatenate([rhs.real, rhs.imag])
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    sol = np.linalg.lstsq(A / scale, r, rcond=None)[0]
    return sol / scale


def tfest(data, np, nz=None, *, dt=None, delay=0, feedthrough=False, refine=True,  # noqa: C901
          weights=None):
    r"""Estimate a transfer function from a frequency response or from time-domain data.

    Parameters
    ----------
    data : FrequencyResponse or IDData
        A SISO frequency response (continuous when its ``dt`` is None and no
        ``dt`` is given, discrete otherwise), or time-domain data (one input
        and one output; discrete time with the data's ``dt``).
    np : int
        Number of poles, ``>= 1``.
    nz : int, optional
        Number of zeros (default ``np − 1``, as MATLAB's ``tfest``).
    dt : float, optional
        Sample time for a discrete-time fit of a frequency response (by
        default the response's own ``dt``; None for continuous time).
        Continuous-time fits of time-domain data are not supported.
    delay : float or int
        Input delay: time units (continuous, a factor :math:`e^{-s\tau}`)
        or samples (discrete, an integer). Known, not estimated.
    feedthrough : bool
        Continuous: allow ``nz == np`` (a direct term). Discrete: the
        numerator starts at :math:`z^{0}` (else at :math:`z^{-1}`).
    refine : bool
        Refine the linear estimate (Sanathanan–Koerner for frequency data,
        Steiglitz–McBride for time data) by nonlinear least squares
        (default True); the covariance is computed either way from the
        final residual's Jacobian.
    weights : array_like, shape (nw,), optional
        Frequency data: positive weights :math:`w_k` of the residuals
        (e.g. ``1 / response.magnitude_sd``); every stage then minimises
        :math:`\sum_k w_k^2|\cdot|^2`. Default: all 1.

    Returns
    -------
    TransferFunctionModel

    Notes
    -----
    From a frequency response (:class:`FrequencyResponse`, continuous or
    discrete) the fit is in three stages:

    1. **Levy's linear least squares** (Levy 1959): with :math:`G = N/D`,
       minimise :math:`\sum_k |N(x_k) - H_k D(x_k)|^2` over the numerator and
       denominator coefficients (D monic), a linear problem in real
       coefficients (real and imaginary parts stacked). Continuous-time fits
       use the normalised variable :math:`s/\omega_c` (:math:`\omega_c` the
       largest frequency) for conditioning; the coefficients are mapped back.
    2. **Sanathanan–Koerner iterations** (Sanathanan & Koerner 1963): repeat
       the linear fit with weights :math:`1/|D_{prev}(x_k)|^2`, which removes
       Levy's bias towards high frequencies; at most 50 iterations, until the
       relative change of the coefficients is below 1e-10.
    3. **Nonlinear least squares** (``refine=True``): minimise
       :math:`\sum_k w_k^2|G(x_k;\theta) - H_k|^2` with
       :func:`scipy.optimize.least_squares` (real and imaginary parts of the
       residual), started from the SK estimate. The covariance of the
       parameters is :math:`\hat\sigma^2(J^\top J)^{-1}` with J that problem's
       Jacobian and :math:`\hat\sigma^2 = \lVert r\rVert^2/(2n_w - d)`.

    From time-domain data (:class:`IDData`, discrete time) the model is an
    output-error model: initialised by the Steiglitz–McBride iterations of
    :class:`adaptid.models.OE` (``fit(refine=False)``), then refined by
    minimising the simulation error :math:`\sum_k (y_k - \hat y_k(\theta))^2`
    over the whole record with zero initial conditions (signals zero before
    the first sample, the convention of ``simulate``), with the analytic
    Jacobian (:math:`\partial\hat y/\partial b_j = q^{-n_k-j}u/F`,
    :math:`\partial\hat y/\partial a_j = -q^{-j}\hat y/F`); the covariance
    is :math:`\hat\sigma^2(J^\top J)^{-1}` from that Jacobian.

    Conventions. Continuous time (``dt=None``):

    .. math::

        G(s) = e^{-s\tau}\frac{b_{n_z}s^{n_z} + \dots + b_0}{s^{n_p} + a_{n_p-1}s^{n_p-1} + \dots + a_0},

    with :math:`n_z < n_p` unless ``feedthrough=True`` (then :math:`n_z \le n_p`).
    Discrete time:

    .. math::

        G(z) = z^{-n_k}\frac{b_0 + b_1z^{-1} + \dots + b_{n_z}z^{-n_z}}{1 + a_1z^{-1} + \dots + a_{n_p}z^{-n_p}},
        \qquad n_k = \text{delay} + (0 \text{ if feedthrough else } 1),

    i.e. an OE model with ``nb = nz + 1``, ``nf = np`` and ``nk`` as above.
    The parameter vector is ``[b…, a…]`` in the order written above (numerator
    first, by increasing power of :math:`s`, or of :math:`z^{-1}`).

    References
    ----------
    E. C. Levy, "Complex-curve fitting", IRE Trans. Automatic Control 4 (1959)
    37–43. C. K. Sanathanan and J. Koerner, "Transfer function synthesis as a
    ratio of two complex polynomials", IEEE Trans. Automatic Control 8 (1963)
    56–58, doi:10.1109/TAC.1963.1105517.
    """
    import numpy
    from .._iddata import IDData

    n_p = check_int(np, "np", low=1)
    n_z = n_p - 1 if nz is None else check_int(nz, "nz", low=0)
    if not isinstance(feedthrough, (bool, numpy.bool_)):
        raise param_error("feedthrough", "True or False", feedthrough)
    if isinstance(data, IDData):
        return _tfest_time(data, n_p, n_z, dt, delay, bool(feedthrough), refine)
    if not isinstance(data, FrequencyResponse):
        raise param_error("data", "a FrequencyResponse or an IDData", data, exc=TypeError)
    if not data.is_siso:
        raise param_error("data", "a single-input single-output response",
                          f"<{len(data.y_names)}×{len(data.u_names)} response>")
    dt = data.dt if dt is None else check_scalar(dt, "dt", low=0.0, low_open=True)
    continuous = dt is None
    if continuous:
        delay = check_scalar(delay, "delay", low=0.0)
        if n_z > n_p or (n_z == n_p and not feedthrough):
            raise param_error("nz", f"< np = {n_p} (<= np with feedthrough=True)", n_z)
        nk = 0
    else:
        delay = check_int(delay, "delay", low=0)
        nk = delay + (0 if feedthrough else 1)
    w, H = data.w, data.response
    d = n_z + 1 + n_p
    if 2 * w.size < d:
        raise param_error("data", f"at least {(d + 1) // 2} frequencies for {d} parameters",
                          f"<{w.size} frequencies>")
    # normalised variable for conditioning (continuous): s' = s / wc
    wc = float(w.max()) if continuous and w.max() > 0 else 1.0
    ws = w / wc
    x = 1j * ws if continuous else numpy.exp(-1j * w * dt)
    Pn, Pd, lead = _bases(x, n_z + 1, n_p, continuous, nk, 0, w)
    if continuous and delay:
        Pn = Pn * numpy.exp(-1j * w * delay)[:, None]
    if weights is None:
        wk = numpy.ones(w.size)
    else:
        wk = as_float_array(weights, "weights", shape=(w.size,))
        if numpy.any(wk <= 0):
            raise param_error("weights", "positive", "<a weight <= 0>")
    # 1. Levy, 2. Sanathanan–Koerner
    th = _linear_fit(H, Pn, Pd, lead, wk)
    for _ in range(_SK_ITER):
        D = lead + Pd @ th[n_z + 1:]
        weight = wk / numpy.maximum(numpy.abs(D), numpy.finfo(float).tiny)
        new = _linear_fit(H, Pn, Pd, lead, weight)
        done = numpy.linalg.norm(new - th) <= _SK_TOL * max(numpy.linalg.norm(new), 1.0)
        th = new
        if done:
            break

    # 3. nonlinear least squares on the complex residual
    def resid(t):
        G = (Pn @ t[: n_z + 1]) / (lead + Pd @ t[n_z + 1:])
        r = wk * (G - H)
        return numpy.concatenate([r.real, r.imag])

    def jac(t):
        D = lead + Pd @ t[n_z + 1:]
        G = (Pn @ t[: n_z + 1]) / D
        J = wk[:, None] * numpy.hstack([Pn / D[:, None], -(G / D)[:, None] * Pd])
        return numpy.vstack([J.real, J.imag])

    if refine:
        from scipy.optimize import least_squares

        th = least_squares(resid, th, jac=jac, method="lm", xtol=1e-15, ftol=1e-15,
                           gtol=1e-15).x
    r = resid(th)
    J = jac(th)
    dof = max(r.size - d, 1)
    sigma2 = float(r @ r) / dof
    cov_s = sigma2 * numpy.linalg.pinv(J.T @ J)
    # back to s from s' = s / wc: D(s) = wc^-np (s^np + Σ a'_j wc^(np-j) s^j), same for b
    if continuous:
        scale = numpy.concatenate([wc ** (n_p - numpy.arange(n_z + 1)),
                                   wc ** (n_p - numpy.arange(n_p))])
    else:
        scale = numpy.ones(d)
    theta = th * scale
    cov = cov_s * numpy.outer(scale, scale)
    return TransferFunctionModel(theta[: n_z + 1], theta[n_z + 1:], dt=dt, delay=delay, nk=nk,
                                 cov=cov, loss=float(r @ r) / w.size,
                                 y_name=data.y_names[0], u_name=data.u_names[0])


def _tfest_time(data, n_p, n_z, dt, delay, feedthrough, refine):
    """Discrete-time fit of time-domain data through an OE model."""
    from .._oe import OE

    if dt is not None and not _same(dt, data.dt):
        raise param_error("dt", f"None or the data's sample time {data.dt:g} (continuous-time "
                          "fits of time-domain data are not supported)", dt)
    if len(data.y_names) != 1 or len(data.u_names) != 1:
        raise param_error("data", "one input and one output", "<a MIMO IDData>")
    if data.n_experiments > 1 or np.isnan(data.outputs).any() or np.isnan(data.inputs).any():
        raise param_error("data", "one experiment without NaN gaps for tfest (OE fits "
                          "several)", f"<{data.n_experiments} experiments>"
                          if data.n_experiments > 1 else "<NaN samples>")
    delay = check_int(delay, "delay", low=0)
    nk = delay + (0 if feedthrough else 1)
    y = np.asarray(data.y, dtype=float).reshape(-1)
    u = np.asarray(data.u, dtype=float).reshape(-1)
    m = OE(n_z + 1, n_p, nk, dt=data.dt).fit(data, refine=False)
    idx = m._split(np.arange(m.theta.size))          # θ order of OE: [b…, f…]
    order = np.concatenate([idx[1][0], idx[3][0]]).astype(int)
    th0 = m.theta[order]
    nb = n_z + 1

    def sim(t):
        B = np.concatenate([np.zeros(nk), t[:nb]])
        F = np.concatenate([[1.0], t[nb:]])
        return signal.lfilter(B, F, u), F

    def resid(t):
        return y - sim(t)[0]

    def jac(t):
        yh, F = sim(t)
        uf = signal.lfilter([1.0], F, u)
        yf = signal.lfilter([1.0], F, yh)
        J = np.zeros((y.size, t.size))
        for j in range(nb):
            k = nk + j
            J[k:, j] = uf[: y.size - k]
        for j in range(n_p):
            k = j + 1
            J[k:, nb + j] = -yf[: y.size - k]
        return -J

    theta = th0 if not refine else optimize.least_squares(
        resid, th0, jac=jac, method="trf", x_scale="jac", xtol=1e-15, ftol=1e-15, gtol=1e-15).x
    r, J = resid(theta), jac(theta)
    sigma2 = float(r @ r) / max(r.size - theta.size, 1)
    cov = sigma2 * np.linalg.pinv(J.T @ J)
    return TransferFunctionModel(theta[: n_z + 1], theta[n_z + 1:], dt=data.dt, delay=delay,
                                 nk=nk, cov=cov, loss=float(r @ r) / r.size,
                                 y_name=data.y_names[0], u_name=data.u_names[0])


def _same(a, b):
    return abs(float(a) - float(b)) <= 1e-12 * max(abs(float(a)), abs(float(b)))
