r"""Closed-loop identification with a known controller or a measured reference.

The loop (Ljung 1999, sec. 13.4):

.. math::

    y_k = G_0(q)u_k + v_k,\qquad u_k = r_k - C(q)y_k,\qquad C = X/Y,

with the reference r independent of the noise v. Then
:math:`y = G_0S_0\,r + S_0v` and :math:`u = S_0r - CS_0v`,
:math:`S_0 = 1/(1 + CG_0)` the sensitivity function.
"""

from __future__ import annotations

import numpy as np

from ..._lazy import lazy
from ..._validation import as_float_array, check_choice, check_int, param_error
from .._arx import ARX
from .._iddata import as_signals
from .._oe import OE
from ._controller import as_controller, controller_output

signal = lazy("scipy.signal")
linalg = lazy("scipy.linalg")
optimize = lazy("scipy.optimize")

__all__ = ["indirect", "two_stage"]


def _record(data):
    """(y, u (N,), IDData or None) of a SISO record."""
    y, u, rec = as_signals(data, None, where="data")
    if u is None:
        raise param_error("data", "a record (y, u) with an input", "<no input>", exc=TypeError)
    y = as_float_array(y, "y", ndim=1)
    u = as_float_array(u, "u", ndim=(1, 2))
    if u.ndim == 2:
        if u.shape[1] != 1:
            raise param_error("data", "a record with one input", f"<{u.shape[1]} inputs>")
        u = u[:, 0]
    if u.shape[0] != y.shape[0]:
        raise param_error("data", "y and u of the same length",
                          f"<{y.shape[0]} and {u.shape[0]} samples>")
    return y, u, rec


def _reference(r, N):
    r = as_float_array(getattr(r, "to_numpy", lambda: r)(), "r", ndim=(1, 2))
    if r.ndim == 2:
        if r.shape[1] != 1:
            raise param_error("r", "one reference signal, shape (N,)", f"<shape {r.shape}>")
        r = r[:, 0]
    if r.shape[0] != N:
        raise param_error("r", f"a signal of length {N} (as y)", f"<length {r.shape[0]}>")
    if not np.ptp(r) > 0:
        raise param_error("r", "a reference that varies (it is the only excitation used)",
                          "<a constant signal>")
    return r


def _lagcols(x, lags):
    """Columns x[k - l] for l in ``lags`` (zero before the start)."""
    N = x.shape[0]
    out = np.zeros((N, len(lags)))
    for j, l in enumerate(lags):
        out[l:, j] = x[: N - l] if l < N else 0.0
    return out


def _closed_loop_oe(theta, nb, nf, nk, X, Y, r):
    r"""ŷ = B Y/(F Y + B X) r and its Jacobian (N, nb + nf) with respect to [b, f].

    With w = (Y/D) r, D = FY + BX: ŷ = B w,
    ∂ŷ/∂b_j = q^{-nk-j} (FY/D) w and ∂ŷ/∂f_j = -q^{-j} (Y/D) ŷ.
    """
    B = np.r_[np.zeros(nk), theta[:nb]]
    F = np.r_[1.0, theta[nb:]]
    FY = np.convolve(F, Y)
    BX = np.convolve(B, X)
    L = max(FY.size, BX.size)
    D = np.pad(FY, (0, L - FY.size)) + np.pad(BX, (0, L - BX.size))
    w = signal.lfilter(Y, D, r)
    yhat = signal.lfilter(B, [1.0], w)
    zb = signal.lfilter(FY, D, w)
    zf = signal.lfilter(Y, D, yhat)
    Psi = np.hstack([_lagcols(zb, range(nk, nk + nb)), -_lagcols(zf, range(1, nf + 1))])
    return yhat, Psi, D


def _sandwich_cov(Psi, eps, noise_order):
    r"""Covariance of an output-error fit whose errors ε are coloured (Ljung 1999, ch. 9).

    ε ≈ e/L(q), L an AR(``noise_order``) polynomial fitted by least squares,
    λ its innovation variance; :math:`\tilde\psi_s = \sum_j h_j\psi_{s+j}`
    (ψ filtered by H = 1/L backwards in time) and
    :math:`\operatorname{cov} = \lambda(\Psi^T\Psi)^{-1}\tilde\Psi^T\tilde\Psi(\Psi^T\Psi)^{-1}`,
    computed from the QR factor of Ψ.
    """
    from ..._lstsq import lstsq

    p = noise_order
    E = _lagcols(eps, range(1, p + 1))[p:]
    fit = lstsq(-E, eps[p:])
    Lpoly = np.r_[1.0, np.asarray(fit.theta)]
    lam = float(fit.sigma2)
    Psit = signal.lfilter([1.0], Lpoly, Psi[::-1], axis=0)[::-1]
    R = linalg.qr(Psi, mode="r")[0][: Psi.shape[1]]
    Mt = linalg.solve_triangular(R, linalg.solve_triangular(R, Psit.T, trans="T"))
    cov = lam * (Mt @ Mt.T)
    return 0.5 * (cov + cov.T), Lpoly, lam


def _indirect_oe(model, y, r, X, Y, s, noise_order):
    nb, nf, nk = model._nb[0], model._nf[0], model._nk[0]
    # start: the ARX form of the indirect method (linear), its A read as F
    ut = controller_output(X, Y, r, y)
    start = ARX(nf, nb, nk).fit(y, ut).theta if nf else ARX(0, nb, nk).fit(y, ut).theta
    from .._pem import stabilize

    f0 = stabilize(np.r_[1.0, start[:nf]])[1:]
    theta0 = np.r_[start[nf:], f0]
    big = 1e6 * max(float(np.std(y)), 1.0)

    def fun(th):
        yhat = _closed_loop_oe(th, nb, nf, nk, X, Y, r)[0]
        res = (y - yhat)[s:]
        return res if np.all(np.isfinite(res)) else np.full(res.size, big)

    def jac(th):
        Psi = _closed_loop_oe(th, nb, nf, nk, X, Y, r)[1][s:]
        return -Psi if np.all(np.isfinite(Psi)) else np.zeros_like(Psi)

    sol = optimize.least_squares(fun, theta0, jac=jac, method="trf", x_scale="jac")
    theta = sol.x
    yhat, Psi, D = _closed_loop_oe(theta, nb, nf, nk, X, Y, r)
    eps = (y - yhat)[s:]
    cov, Lpoly, lam = _sandwich_cov(Psi[s:], eps, noise_order)
    model.theta = theta
    model.cov = cov
    model.residuals = eps
    model.noise_variance = float(eps @ eps) / max(eps.size - theta.size, 1)
    model.closed_loop_denominator = D
    model.refine_result = sol
    return model


def _newey_west(Z, L):
    """Σ_{|h|≤L} (1 − |h|/(L+1)) Σ_k z_k z_{k+h}ᵀ (Bartlett weights; Newey and West 1987)."""
    S = Z.T @ Z
    for h in range(1, min(L, Z.shape[0] - 1) + 1):
        G = Z[h:].T @ Z[:-h]
        S += (1.0 - h / (L + 1.0)) * (G + G.T)
    return S


def _two_stage_cov(m, stage1, r, Phi_fix, reg, bandwidth):
    r"""Covariance of the two-stage estimate with the stage-1 error included.

    Linearising the stage-2 normal equations in θ and in the FIR
    coefficients s, :math:`\hat\theta - \theta \approx \sum_k z_k` with
    :math:`z_k = A\psi_k\varepsilon_k - B\phi_k\nu_k`,
    :math:`A = (\Psi^T\Psi)^{-1}`,
    :math:`B = A\Psi^TG(\hat\theta)\Phi_r(\Phi_r^T\Phi_r)^{-1}` (ν, φ the
    stage-1 residuals and regressors, :math:`G\Phi_r` the stage-1 regressors
    filtered by the plant); both sums are of coloured, mutually correlated
    terms, so the covariance of Σz is estimated with Newey–West weights.
    """
    eps, Psi = m._errors(m.theta, Phi_fix, reg.y)
    n = stage1.theta.size
    Phir = np.column_stack([np.r_[np.zeros(j), r[: r.size - j]] for j in range(n)])
    A, Bs, _, Fs = m._polys()
    GPhi = signal.lfilter(Bs[0], Fs[0], Phir, axis=0)[reg.index]
    R = linalg.qr(Psi, mode="r")[0][: Psi.shape[1]]
    R1 = linalg.qr(Phir[stage1.index], mode="r")[0][:n]

    def inv_gram(Rf, M):          # (RᵀR)⁻¹ M by two triangular solves
        return linalg.solve_triangular(Rf, linalg.solve_triangular(Rf, M, trans="T"))

    Bm = inv_gram(R1, inv_gram(R, Psi.T @ GPhi).T).T
    Z = np.zeros((r.size, Psi.shape[1]))
    Z[reg.index] += inv_gram(R, Psi.T).T * eps[:, None]
    Z[stage1.index] -= (Phir[stage1.index] * np.asarray(stage1.residuals)[:, None]) @ Bm.T
    cov = _newey_west(Z, bandwidth)
    return 0.5 * (cov + cov.T)


def _setup(model, y, u, rec):
    """Fix the model's inputs and names as its ``fit`` would on (y, u)."""
    model._data(rec if rec is not None else y, None if rec is not None else u, fitting=True)
    reg, _ = model._fixed_regression(y, u.reshape(-1, 1), True)
    model.index = reg.index
    model.names = model._names()
    return reg.index[0]


def indirect(data, controller, *, r=None, na, nb, nk=1, model="oe", noise_order=10):
    r"""The indirect method: identify r → y with the known controller, solve for the plant.

    The closed loop from the reference to the output is
    :math:`G_c = G/(1 + CG)`. With the plant parametrised as
    :math:`G(\theta) = B(q)/F(q)` (``model="oe"``) the closed loop is the
    output-error model

    .. math::

        y_k = \frac{B(q)Y(q)}{F(q)Y(q) + B(q)X(q)}\,r_k + w_k,\qquad
        \hat\theta = \arg\min_\theta\sum_k\big(y_k - G_c(q,\theta)r_k\big)^2,

    in the *open-loop* parameters θ = [b₀ … b_{nb−1}, f₁ … f_na] (Ljung
    1999, sec. 13.5: the closed loop parametrised by the plant,
    so that solving for G is part of the fit and no cancellation between
    the estimated closed loop and the controller is needed). r is
    independent of the noise, so :math:`\hat\theta` is consistent whatever
    the colour of the noise :math:`w = S_0v`; the fit is a Gauss–Newton
    least squares (:func:`scipy.optimize.least_squares`) with the
    analytic gradient :math:`\partial\hat y/\partial b_j = q^{-n_k-j}
    (FY/D)\,w`, :math:`\partial\hat y/\partial f_j = -q^{-j}(Y/D)\,\hat y`,
    D = FY + BX, :math:`w = (Y/D)r`, started from the ``model="arx"``
    estimate.

    With ``model="arx"`` the plant is :math:`A(q)y = B(q)u + e`; the closed
    loop is then :math:`(AY + BX)y = BYr + Ye`, whose prediction error is
    :math:`A(q)y_k - B(q)\tilde u_k` with :math:`\tilde u = r - Cy` the
    controller output recomputed from r and y: linear least squares, the
    same estimate as the direct ARX fit when the measured u obeys the
    controller exactly (Ljung 1999, sec. 13.5).

    Parameters
    ----------
    data : IDData, (y, u) tuple, or DataFrame (output column first)
        The closed-loop record, one output and one input.
    controller : float, (num, den), or control.TransferFunction
        C(q) in :math:`u_k = r_k - C(q)y_k` (negative feedback): a gain,
        a pair of polynomials in :math:`q^{-1}` (``den[0] != 0``), or a
        discrete SISO python-control transfer function (powers of z).
    r : array_like, shape (N,), optional
        The reference. Default: reconstructed from the record as
        :math:`r = u + C(q)y` (exact when the measured u is the
        controller's output; give r when it is not, e.g. under
        saturation).
    na : int
        Order of the plant's denominator (F for ``"oe"``, A for ``"arx"``), ``>= 0``.
    nb : int
        Number of B coefficients, ``>= 1``.
    nk : int
        Plant delay, ``>= 0`` (default 1).
    model : {"oe", "arx"}
        Plant parametrisation (default ``"oe"``).
    noise_order : int
        Order of the AR model of the closed-loop output error used for the
        covariance of ``"oe"`` (default 10).

    Returns
    -------
    OE or ARX
        The plant (``"oe"``: an :class:`OE` with nb, nf = na, nk) with
        ``theta``, ``cov``, ``stderr``, ``residuals`` (the closed-loop
        errors :math:`y - G_c(\hat\theta)r` for ``"oe"``), ``method =
        "indirect"``, ``controller`` (X, Y) and ``reference`` r. For
        ``"oe"`` the covariance is the sandwich
        :math:`\lambda(\Psi^T\Psi)^{-1}\tilde\Psi^T\tilde\Psi(\Psi^T\Psi)^{-1}`
        of an output-error fit with coloured errors (Ljung 1999, ch. 9),
        Ψ the Jacobian above and :math:`\tilde\Psi` Ψ filtered
        backwards by the AR noise model; for ``"arx"`` the least-squares
        covariance.

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, secs. 13.4–13.5.
    .. [2] U. Forssell and L. Ljung, "Closed-loop identification revisited",
       *Automatica* 35(7), 1999, :doi:`10.1016/S0005-1098(99)00022-9`.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import indirect
    >>> rng = np.random.default_rng(0)
    >>> N = 3000; r = rng.standard_normal(N); v = lfilter([1], [1, -0.9], 0.3 * rng.standard_normal(N))
    >>> y = np.zeros(N); u = np.zeros(N); x = 0.0
    >>> for k in range(N):               # G = 0.5 q^-1 / (1 - 0.8 q^-1), u = r - 0.4 y
    ...     x = 0.8 * x + (0.5 * u[k - 1] if k else 0.0)
    ...     y[k] = x + v[k]; u[k] = r[k] - 0.4 * y[k]
    >>> m = indirect((y, u), 0.4, r=r, na=1, nb=1)
    >>> bool(np.allclose(m.theta, [0.5, -0.8], atol=0.05))
    True
    """
    y, u, rec = _record(data)
    X, Y = as_controller(controller)
    model = check_choice(model, "model", ("oe", "arx"))
    na = check_int(na, "na", low=0)
    nb = check_int(nb, "nb", low=1)
    nk = check_int(nk, "nk", low=0)
    noise_order = check_int(noise_order, "noise_order", low=1)
    r = u + signal.lfilter(X, Y, y) if r is None else _reference(r, y.size)
    if not np.ptp(r) > 0:
        raise param_error("r", "a reference that varies", "<a constant signal>")
    if y.size < 4 * (na + nb + nk) + 2 * noise_order + 10:
        raise param_error("data", f"a record longer than {4 * (na + nb + nk) + 2 * noise_order + 10}"
                          " samples for these orders", f"<{y.size} samples>")
    if model == "arx":
        ut = controller_output(X, Y, r, y)
        m = ARX(na, nb, nk).fit(y, ut)
        if rec is not None:
            m.y_name, m.u_names, m.dt = rec.y_names[0], rec.u_names, rec.dt
    else:
        m = OE(nb, na, nk)
        s = _setup(m, y, u, rec)
        _indirect_oe(m, y, r, X, Y, s, noise_order)
    m.method = "indirect"
    m.controller = (X, Y)
    m.reference = r
    return m


def _stage2(y, u_hat, nb, nf, nk, n_fir):
    """The output-error fit of y on û, started from an OE fit to a FIR model's simulation.

    The Steiglitz–McBride iteration of :meth:`OE.fit` on the noisy y can
    drift towards F = 1 − q⁻¹ when the output error is strongly coloured;
    on the FIR model's noise-free simulation (y on û by least squares,
    consistent as û is independent of the noise) it starts well, and the
    prediction-error refinement then minimises Σ(y − B/F û)² on y itself.
    """
    fir = ARX(0, n_fir, nk).fit(y, u_hat)
    m = OE(nb, nf, nk).fit(fir.simulate(u_hat), u_hat, refine=False)
    y, U = m._data(y, u_hat, fitting=True)
    reg, Phi_fix = m._fixed_regression(y, U, True)
    m._finish(m._refine(m.theta, Phi_fix, reg.y), Phi_fix, reg.y, reg)
    return m


def two_stage(data, r, *, nb, nf, nk=1, n_fir=30, bandwidth=30):
    r"""The two-stage (projection) method: project u on r, then fit the plant as output error.

    Stage 1 estimates the map from the reference to the input, here a
    high-order FIR model :math:`u_k = \sum_{j=0}^{n-1} s_jr_{k-j} + \nu_k`
    (least squares; :math:`S_0r` is the part of u driven by r, ν the part
    driven by the noise), and simulates the noise-free input
    :math:`\hat u = \hat S(q)r`. Stage 2 fits the plant
    :math:`y_k = \frac{B(q)}{F(q)}\hat u_k + \tilde w_k` by the
    output-error method on (y, û): minimum of
    :math:`\sum_k(y_k - \frac{B}{F}\hat u_k)^2` (:class:`OE`'s
    prediction-error refinement), started from an OE fit to the
    simulation of a FIR model of y on û (the Steiglitz–McBride iteration
    run on y itself can drift to F = 1 − q⁻¹ when the output error is
    strongly coloured, as it is here). As r is independent of
    the noise, û is too, and the estimate is consistent whatever the
    noise's colour (Van den Hof and Schrama 1993; Forssell and Ljung
    1999, sec. 5).

    The second stage is output error, not ARX, on purpose: an ARX model's
    regressor holds past outputs, which carry the noise, so least squares
    on (y, û) would be biased by the noise as on the raw closed-loop data;
    an output-error predictor uses û alone.

    Parameters
    ----------
    data : IDData, (y, u) tuple, or DataFrame (output column first)
        The closed-loop record, one output and one input.
    r : array_like, shape (N,)
        The reference (an external signal independent of the noise).
    nb, nf, nk : int
        Orders of the plant B/F (``nb >= 1``, ``nf >= 0``) and its delay
        (``nk >= 0``, default 1).
    n_fir : int
        Length n of the stage-1 FIR model (default 30), ``>= 1``; it must
        cover the sensitivity function's impulse response.
    bandwidth : int
        Number of lags L of the Newey–West estimate of the covariance
        (default 30), ``>= 0``; it should cover the correlation time of
        the noise.

    Returns
    -------
    OE
        The stage-2 model with ``theta``, ``cov``, ``stderr``, ``method =
        "two_stage"``, ``u_hat`` (û) and ``stage1`` (the FIR model, an
        :class:`ARX`). ``cov`` includes the stage-1 error: with the
        stage-2 normal equations linearised in θ and in the FIR
        coefficients, :math:`\hat\theta - \theta \approx \sum_k z_k`,
        :math:`z_k = A\psi_k\varepsilon_k - B\phi_k\nu_k` (ψ the
        output-error gradient, ε its errors, φ and ν the stage-1 regressors
        and residuals, A and B the sensitivity matrices), and
        :math:`\operatorname{cov} = \sum_{|h|\le L}(1 - \tfrac{|h|}{L+1})
        \sum_k z_kz_{k+h}^T` (Newey and West 1987).

    References
    ----------
    .. [1] P. M. J. Van den Hof and R. J. P. Schrama, "An indirect method
       for transfer function estimation from closed loop data",
       *Automatica* 29(6), 1993, :doi:`10.1016/0005-1098(93)90050-W`.
    .. [2] U. Forssell and L. Ljung, "Closed-loop identification revisited",
       *Automatica* 35(7), 1999, :doi:`10.1016/S0005-1098(99)00022-9`.
    .. [3] W. K. Newey and K. D. West, "A simple, positive semi-definite,
       heteroskedasticity and autocorrelation consistent covariance
       matrix", *Econometrica* 55(3), 1987, :doi:`10.2307/1913610`.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import two_stage
    >>> rng = np.random.default_rng(0)
    >>> N = 3000; r = rng.standard_normal(N); v = lfilter([1], [1, -0.9], 0.3 * rng.standard_normal(N))
    >>> y = np.zeros(N); u = np.zeros(N); x = 0.0
    >>> for k in range(N):               # G = 0.5 q^-1 / (1 - 0.8 q^-1), u = r - 0.4 y
    ...     x = 0.8 * x + (0.5 * u[k - 1] if k else 0.0)
    ...     y[k] = x + v[k]; u[k] = r[k] - 0.4 * y[k]
    >>> m = two_stage((y, u), r, nb=1, nf=1)
    >>> bool(np.allclose(m.theta, [0.5, -0.8], atol=0.05))
    True
    """
    y, u, rec = _record(data)
    r = _reference(r, y.size)
    nb = check_int(nb, "nb", low=1)
    nf = check_int(nf, "nf", low=0)
    nk = check_int(nk, "nk", low=0)
    n_fir = check_int(n_fir, "n_fir", low=1)
    bandwidth = check_int(bandwidth, "bandwidth", low=0)
    if y.size < 4 * (n_fir + nb + nf + nk) + 10:
        raise param_error("data", f"a record longer than {4 * (n_fir + nb + nf + nk)} samples "
                          f"(4 times the stage-1 and stage-2 parameters)", f"<{y.size} samples>")
    stage1 = ARX(0, n_fir, 0).fit(u, r)
    u_hat = stage1.simulate(r)
    m = _stage2(y, u_hat, nb, nf, nk, n_fir)
    if rec is not None:
        m.y_name, m.u_names, m.dt = rec.y_names[0], rec.u_names, rec.dt
    reg, Phi_fix = m._fixed_regression(y, u_hat.reshape(-1, 1), True)
    m.cov = _two_stage_cov(m, stage1, r, Phi_fix, reg, bandwidth)
    m.method = "two_stage"
    m.u_hat = u_hat
    m.stage1 = stage1
    return m
