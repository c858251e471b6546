r"""Kernel-regularised least squares with marginal-likelihood hyperparameters."""

from __future__ import annotations

import numpy as np
from scipy import linalg

from ..._validation import check_int, param_error
from .._arx import ARX, single_output_arx

__all__ = ["impulseest", "arx_regul", "kernel_matrix"]

#: hyperparameter names of each kernel, in the order of ``hyperparameters=``
_HYPER = {"TC": ("c", "lam"), "DC": ("c", "lam", "rho"), "SS": ("c", "lam"),
          "SE": ("c", "beta"), "HF": ("c", "lam"), "DI": ("c", "lam")}


def _check_kernel(kernel):
    k = str(kernel).upper() if isinstance(kernel, str) else kernel
    if k not in _HYPER:
        raise param_error("kernel", "one of 'TC', 'DC', 'SS', 'SE', 'HF', 'DI'", kernel)
    return k


def kernel_matrix(kernel, n, hyperparameters):
    r"""Prior covariance P (n × n) of a regularisation kernel, indices 1 … n.

    .. math::

        \text{TC:}\ P_{ij} = c\,\lambda^{\max(i,j)},\qquad
        \text{DC:}\ P_{ij} = c\,\lambda^{(i+j)/2}\rho^{|i-j|},\qquad
        \text{SS:}\ P_{ij} = c\Big(\frac{\lambda^{i+j+\max(i,j)}}{2}
                                   - \frac{\lambda^{3\max(i,j)}}{6}\Big),

    .. math::

        \text{SE:}\ P_{ij} = c\,e^{-(i-j)^2/(2\beta^2)},\qquad
        \text{HF:}\ P_{ij} = c\,(-1)^{i+j}\lambda^{\max(i,j)},\qquad
        \text{DI:}\ P_{ij} = c\,\lambda^i\,\delta_{ij}.

    Parameters
    ----------
    kernel : {"TC", "DC", "SS", "SE", "HF", "DI"}
    n : int
        Number of coefficients, ``>= 1``.
    hyperparameters : sequence of float
        TC, SS, HF and DI: (c, λ); DC: (c, λ, ρ); SE: (c, β); c > 0,
        λ ∈ (0, 1), ρ ∈ (−1, 1), β > 0.

    Returns
    -------
    ndarray, shape (n, n)

    Notes
    -----
    The SS (stable spline) kernel is the second-order spline kernel
    :math:`K(s,t) = st\min(s,t)/2 - \min(s,t)^3/6` with the exponential time
    warping :math:`s = \lambda^i`, :math:`\min(\lambda^i,\lambda^j) =
    \lambda^{\max(i,j)}` (Chen, Ohlsson and Ljung 2012, eq. 17 and
    Pillonetto et al. 2014, sec. 9). The other three are those of MATLAB's
    ``arxRegulOptions`` (its ``RegularizationKernel`` list), with the
    formulas of the public ``rfir`` MATLAB code for regularised FIR
    estimation: SE, the squared-exponential
    (Gaussian) kernel of width β, a smoothness prior with no decay
    (Rasmussen and Williams 2006, sec. 4.2);
    HF, the TC kernel with alternating signs, a prior for impulse responses
    that oscillate at the Nyquist frequency (poles near −1): it is
    :math:`S\,P_{TC}\,S` with :math:`S = \operatorname{diag}((-1)^i)`; DI,
    the diagonal kernel, independent coefficients with exponentially
    decaying variance (Chen, Ohlsson and Ljung 2012).

    References
    ----------
    .. [1] T. Chen, H. Ohlsson and L. Ljung, "On the estimation of transfer
       functions, regularizations and Gaussian processes — Revisited",
       *Automatica* 48(8), 2012, :doi:`10.1016/j.automatica.2012.05.026`.
    .. [2] G. Pillonetto, F. Dinuzzo, T. Chen, G. De Nicolao and L. Ljung,
       "Kernel methods in system identification, machine learning and
       function estimation: a survey", *Automatica* 50(3), 2014,
       :doi:`10.1016/j.automatica.2014.01.001`.
    .. [3] C. E. Rasmussen and C. K. I. Williams, *Gaussian Processes for
       Machine Learning*, MIT Press, 2006.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.models import kernel_matrix
    >>> P = kernel_matrix("TC", 3, (2.0, 0.5))
    >>> bool(np.allclose(P, 2.0 * 0.5 ** np.maximum.outer([1, 2, 3], [1, 2, 3])))
    True
    """
    kernel = _check_kernel(kernel)
    n = check_int(n, "n", low=1)
    h = np.asarray(hyperparameters, dtype=np.float64).reshape(-1)
    if h.size != len(_HYPER[kernel]) or not np.all(np.isfinite(h)):
        raise param_error("hyperparameters", f"{len(_HYPER[kernel])} finite numbers "
                          f"{_HYPER[kernel]} for kernel {kernel!r}", hyperparameters)
    c, lam = h[0], h[1]
    if not c > 0:
        raise param_error("hyperparameters", "with c > 0", hyperparameters)
    i = np.arange(1, n + 1, dtype=np.float64)
    if kernel == "SE":
        if not lam > 0:
            raise param_error("hyperparameters", "with beta > 0", hyperparameters)
        return c * np.exp(-np.subtract.outer(i, i) ** 2 / (2.0 * lam ** 2))
    if not 0 < lam < 1:
        raise param_error("hyperparameters", "with lam in (0, 1)", hyperparameters)
    mx = np.maximum.outer(i, i)
    if kernel == "TC":
        return c * lam ** mx
    if kernel == "HF":
        return c * (-1.0) ** np.add.outer(i, i) * lam ** mx
    if kernel == "DI":
        return np.diag(c * lam ** i)
    if kernel == "DC":
        rho = h[2]
        if not -1 < rho < 1:
            raise param_error("hyperparameters", "with rho in (-1, 1)", hyperparameters)
        return c * lam ** (np.add.outer(i, i) / 2) * rho ** np.abs(np.subtract.outer(i, i))
    s = np.add.outer(i, i)
    return c * (lam ** (s + mx) / 2 - lam ** (3 * mx) / 6)


def _factor(P):
    """L with P = L Lᵀ: Cholesky, or a symmetric square root when P is numerically singular."""
    try:
        return linalg.cholesky(P, lower=True)
    except linalg.LinAlgError:
        w, V = linalg.eigh(P)
        return V * np.sqrt(np.clip(w, 0.0, None))


class _Gram:
    """ΦᵀΦ, Φᵀy, yᵀy and N: all an evaluation needs, O(n³) per evaluation."""

    def __init__(self, Phi, y):
        self.G = Phi.T @ Phi
        self.b = Phi.T @ y
        self.yy = float(y @ y)
        self.N = y.size

    def solve(self, P, sigma2):
        r"""θ, posterior covariance and log p(y) for prior θ ~ N(0, P), noise σ².

        With P = L Lᵀ and M = LᵀGL + σ²I = R Rᵀ (Cholesky):
        θ = L M⁻¹ Lᵀb, cov = σ² L M⁻¹ Lᵀ, log det Σ = (N − n) log σ² +
        log det M, yᵀΣ⁻¹y = (yᵀy − ‖R⁻¹Lᵀb‖²)/σ² (Woodbury and the matrix
        determinant lemma for Σ = ΦPΦᵀ + σ²I).
        """
        n = P.shape[0]
        L = _factor(P)
        M = L.T @ self.G @ L
        M[np.diag_indices(n)] += sigma2
        R = linalg.cholesky(M, lower=True)
        Lb = L.T @ self.b
        w = linalg.solve_triangular(R, Lb, lower=True)
        theta = L @ linalg.solve_triangular(R, w, lower=True, trans="T")
        RiLt = linalg.solve_triangular(R, L.T, lower=True)
        cov = sigma2 * (RiLt.T @ RiLt)
        logdet = (self.N - n) * np.log(sigma2) + 2.0 * np.sum(np.log(np.diag(R)))
        quad = max(self.yy - float(w @ w), 0.0) / sigma2
        loglik = -0.5 * (quad + logdet + self.N * np.log(2 * np.pi))
        return theta, cov, float(loglik)


def _block_prior(kernel, sizes, h):
    """Block-diagonal prior: one kernel (its own hyperparameters) per block."""
    k = len(_HYPER[kernel])
    blocks = [kernel_matrix(kernel, s, h[j * k:(j + 1) * k]) for j, s in enumerate(sizes)]
    return linalg.block_diag(*blocks)


def _to_x(kernel, h, nblocks):
    k = len(_HYPER[kernel])
    x = []
    for j in range(nblocks):
        hj = h[j * k:(j + 1) * k]
        x += [np.log(hj[0]), np.log(hj[1])]
        if kernel == "DC":
            x.append(hj[2])
    return np.array(x)


def _from_x(kernel, x, nblocks):
    k = len(_HYPER[kernel])
    h = []
    for j in range(nblocks):
        xj = x[j * k:(j + 1) * k]
        h += [np.exp(xj[0]), np.exp(xj[1])]
        if kernel == "DC":
            h.append(xj[2])
    return np.array(h)


def _tune(gram, kernel, sizes, sigma2, theta_ls):
    """Maximise log p(y) over (log c, log λ (log β)[, ρ]) per block, from the best point of a grid."""
    from scipy.optimize import minimize

    nb = len(sizes)
    # a starting grid over λ or β (shared by the blocks), c from the LS estimate's size
    c0 = max(float(np.mean(theta_ls ** 2)), 1e-12) * 10
    best = None
    grid = (0.5, 1.0, 2.0, 4.0, 8.0) if kernel == "SE" else (0.3, 0.6, 0.8, 0.9, 0.95, 0.98)
    for lam in grid:
        base = [c0, lam] + ([0.5] if kernel == "DC" else [])
        for cs in (0.1, 1.0, 10.0):
            hb = list(base)
            hb[0] = c0 * cs
            h = np.array(hb * nb)
            try:
                ll = gram.solve(_block_prior(kernel, sizes, h), sigma2)[2]
            except (linalg.LinAlgError, ValueError):
                continue
            if best is None or ll > best[0]:
                best = (ll, h)
    if best is None:
        raise param_error("data", "a record on which the marginal likelihood can be "
                          "evaluated (every starting kernel failed; give hyperparameters=)",
                          "<no finite value>")
    lo_lam, hi_lam = np.log(1e-6), np.log(1 - 1e-9)
    if kernel == "SE":      # the width β from a tenth of a lag to ten record lengths
        lo_lam, hi_lam = np.log(0.1), np.log(10.0 * max(sizes))
    bounds = []
    for _ in range(nb):
        bounds += [(np.log(c0) - 40, np.log(c0) + 40), (lo_lam, hi_lam)]
        if kernel == "DC":
            bounds.append((-0.999, 0.999))

    def nll(x):
        try:
            return -gram.solve(_block_prior(kernel, sizes, _from_x(kernel, x, nb)), sigma2)[2]
        except (linalg.LinAlgError, ValueError):
            return np.inf

    x0 = _to_x(kernel, best[1], nb)
    res = minimize(nll, x0, method="L-BFGS-B", bounds=bounds)
    x = res.x if np.isfinite(res.fun) and res.fun <= nll(x0) else x0
    return _from_x(kernel, x, nb)


def _check_sigma2(noise_variance, default):
    if noise_variance is None:
        return default
    s = float(noise_variance)
    if not (np.isfinite(s) and s > 0):
        raise param_error("noise_variance", "a positive number or None", noise_variance)
    return s


def _fit_regularised(model, Phi, yv, kernel, sizes, hyperparameters, noise_variance):
    from ..._lstsq import lstsq

    N, d = Phi.shape
    gram = _Gram(Phi, yv)
    if noise_variance is None:
        if N <= d:
            raise param_error("noise_variance", f"given when the record has no more rows ({N}) "
                              f"than coefficients ({d})", None)
        ls = lstsq(Phi, yv)
        sigma2, theta_ls = float(ls.sigma2), np.asarray(ls.theta)
    else:
        sigma2 = _check_sigma2(noise_variance, None)
        theta_ls = np.linalg.lstsq(Phi, yv, rcond=None)[0]
    k = len(_HYPER[kernel])
    if hyperparameters is None:
        h = _tune(gram, kernel, sizes, sigma2, theta_ls)
    else:
        h = np.asarray(hyperparameters, dtype=np.float64).reshape(-1)
        if h.size != k * len(sizes):
            raise param_error("hyperparameters", f"{k * len(sizes)} numbers ({_HYPER[kernel]} "
                              f"for each of {len(sizes)} block(s))", hyperparameters)
    P = _block_prior(kernel, sizes, h)
    theta, cov, ll = gram.solve(P, sigma2)
    model.theta = theta
    model.cov = 0.5 * (cov + cov.T)
    model.noise_variance = sigma2
    model.kernel = kernel
    model.hyperparameters = h
    model.prior = P
    model.marginal_loglik = ll
    return model



def impulseest(data, n, *, u=None, kernel="TC", nk=0, hyperparameters=None,
               noise_variance=None):
    r"""Regularised FIR estimate of an impulse response (MATLAB's ``impulseest``).

    .. math::

        \hat\theta = (\Phi^T\Phi + \sigma^2P^{-1})^{-1}\Phi^Ty,\qquad
        \operatorname{cov}\hat\theta = \sigma^2(\Phi^T\Phi + \sigma^2P^{-1})^{-1},

    the posterior mean and covariance for the prior θ ~ N(0, P) with the
    kernel P of :func:`kernel_matrix` (coefficient :math:`g_{n_k+i-1}` has
    kernel index i = 1 … n). Hyperparameters not given maximise the
    marginal likelihood of :math:`y \sim N(0, \Phi P\Phi^T + \sigma^2I)`.

    Parameters
    ----------
    data : IDData, or pair (y, u)
        One output and one input (or pass y here and ``u=``).
    n : int
        Number of FIR taps, ``>= 1``.
    u : array_like, shape (N,), optional
        The input when ``data`` is the output.
    kernel : {"TC", "DC", "SS", "SE", "HF", "DI"}
        The prior covariance of :func:`kernel_matrix`.
    nk : int
        Delay of the first tap, ``>= 0`` (default 0: a direct term).
    hyperparameters : sequence of float, optional
        Fixed (c, λ) for TC, SS, HF and DI, (c, λ, ρ) for DC, (c, β) for
        SE; default: estimated.
    noise_variance : float, optional
        Fixed σ²; default the residual variance of the plain least-squares
        FIR of the same length (as MATLAB does, which uses a least-squares
        model's noise variance), held fixed during the tuning.

    Returns
    -------
    ARX
        With na = 0, nb = n, nk; ``theta`` the impulse response
        :math:`g_{n_k}, …, g_{n_k+n-1}`, ``cov`` the posterior covariance,
        ``stderr``, ``residuals``, ``noise_variance`` σ², and the extra
        attributes ``kernel``, ``hyperparameters``, ``prior`` (P) and
        ``marginal_loglik`` (log p(y) with all its constants, including
        :math:`-\tfrac N2\log 2\pi`).

    Notes
    -----
    Rows are the samples k = s … N−1 whose lags are all measured,
    :math:`s = n_k + n - 1` (no assumed initial values), as :class:`ARX`.
    With P = LLᵀ (Cholesky; a symmetric square root when P is numerically
    singular, as TC and SS are for small λ) and
    :math:`M = L^T\Phi^T\Phi L + \sigma^2I = RR^T`:
    :math:`\hat\theta = LM^{-1}L^T\Phi^Ty`,
    :math:`\log\det\Sigma = (N-n)\log\sigma^2 + \log\det M` and
    :math:`y^T\Sigma^{-1}y = (y^Ty - \|R^{-1}L^T\Phi^Ty\|^2)/\sigma^2`, so
    no inverse of P and no N × N matrix is formed (O(n³) per evaluation
    after one ΦᵀΦ). The tuning maximises over log c, log λ (and ρ) with
    L-BFGS-B from the best point of a small grid.

    References
    ----------
    Chen, Ohlsson and Ljung (2012); Pillonetto et al. (2014); see
    :func:`kernel_matrix`.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import impulseest
    >>> rng = np.random.default_rng(1)
    >>> u = rng.standard_normal(300)
    >>> y = lfilter([0, 1.0, 0.5], [1, -1.2, 0.5], u) + 0.1 * rng.standard_normal(300)
    >>> g = lfilter([0, 1.0, 0.5], [1, -1.2, 0.5], np.r_[1.0, np.zeros(39)])
    >>> m = impulseest((y, u), 40)
    >>> bool(np.max(np.abs(m.theta - g)) < 0.1)
    True
    """
    n = check_int(n, "n", low=1)
    nk = check_int(nk, "nk", low=0)
    kernel = _check_kernel(kernel)
    model = ARX(0, n, nk)
    yv, U = model._data(data, u, fitting=True)
    if U.shape[1] != 1:
        raise param_error("u", "one input signal", f"<{U.shape[1]} inputs>")
    reg, Phi = model._fixed_regression(yv, U, model._single)
    model.names = model._names()
    model.index = reg.index
    _fit_regularised(model, Phi, reg.y, kernel, [n], hyperparameters, noise_variance)
    model.residuals = reg.y - Phi @ model.theta
    return model


def arx_regul(data, na, nb, nk=1, *, u=None, kernel="TC", hyperparameters=None,
              noise_variance=None):
    r"""Regularised ARX estimate (MATLAB's ``arxRegul`` and ``arx`` with its result).

    The prior θ ~ N(0, P) is block diagonal: one kernel for the a
    coefficients (indices 1 … na) and one for each input's b coefficients
    (indices 1 … nb), each block with its own hyperparameters, tuned by the
    marginal likelihood as in :func:`impulseest`. The estimate and
    posterior covariance are those of :func:`impulseest` with the ARX
    regressors (rows k = s … N−1 of :class:`ARX`).

    Parameters
    ----------
    data : IDData, or pair (y, u)
    na : int
        Order of A, ``>= 0``.
    nb : int or sequence of int
        B coefficients per input, ``>= 1``.
    nk : int or sequence of int
        Input delay per input.
    u : array_like, optional
        The input when ``data`` is the output.
    kernel : {"TC", "DC", "SS", "SE", "HF", "DI"}
    hyperparameters : sequence of float, optional
        The blocks' hyperparameters concatenated, A first (omitted when
        na = 0), then each input's B: e.g. TC ``(c_a, λ_a, c_b, λ_b)``.
    noise_variance : float, optional
        Fixed σ²; default the residual variance of the least-squares ARX of
        the same orders.

    Returns
    -------
    ARX
        ``theta``, posterior ``cov``, ``stderr`` and the attributes of
        :func:`impulseest` (``kernel``, ``hyperparameters``, ``prior``,
        ``marginal_loglik``).

    Notes
    -----
    MATLAB's ``arxRegul`` tunes the A and B blocks' kernels jointly in the
    same way (its default noise variance also comes from an ARX fit); the
    a-block here treats the past outputs as regressors, i.e. the marginal
    likelihood is conditional on the measured outputs.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import arx_regul
    >>> rng = np.random.default_rng(2)
    >>> u = rng.standard_normal(400); e = 0.1 * rng.standard_normal(400)
    >>> y = lfilter([0, 1.0, 0.5], [1, -1.2, 0.5], u) + lfilter([1], [1, -1.2, 0.5], e)
    >>> m = arx_regul((y, u), 2, 10, 1)
    >>> bool(np.allclose(m.theta[:4], [-1.2, 0.5, 1.0, 0.5], atol=0.1))
    True
    """
    kernel = _check_kernel(kernel)
    model = single_output_arx(na, nb, nk, where="arx_regul")
    yv, U = model._data(data, u, fitting=True)
    if min(model._nb) < 1:
        raise param_error("nb", ">= 1 for every input", nb)
    reg, Phi = model._fixed_regression(yv, U, model._single)
    sizes = ([model.na] if model.na else []) + list(model._nb)
    model.names = model._names()
    model.index = reg.index
    _fit_regularised(model, Phi, reg.y, kernel, sizes, hyperparameters, noise_variance)
    model.residuals = reg.y - Phi @ model.theta
    return model
