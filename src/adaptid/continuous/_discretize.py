r"""Exact discretisation of the continuous TLSM algorithms (Yamamoto (1991), section 3)."""

from __future__ import annotations

import math
import warnings

import numpy as np
from scipy import integrate as _spi

from .._exceptions import DefinitenessLossWarning
from .._validation import as_float_array, check_int, check_scalar, check_spd, param_error
from ._result import TLSMResult
from ._signals import check_algorithm, make_weighting

__all__ = ["Discretization", "discretize"]


def _phi1(x):
    r""":math:`(1 - e^{-x})/x`, with its limit 1 at x = 0 (elementwise, accurate near 0)."""
    x = np.asarray(x, dtype=float)
    out = np.ones_like(x)
    nz = x != 0.0
    out[nz] = -np.expm1(-x[nz]) / x[nz]
    return out


class Discretization:
    r"""A continuous TLSM algorithm discretised exactly for held signals with sample time T.

    Built by :func:`discretize`; see there and :mod:`adaptid.continuous` for
    the derivation. Sample k (0-based) is held on
    :math:`[t_k, t_{k+1})`, :math:`t_k = t_0 + kT`; processing it advances
    the continuous solution from :math:`t_k` to :math:`t_{k+1}`:

    .. math::

        R_{k+1} = \lambda_k R_k + \bar f_k\, v_k v_k^T
                  - \Big(\bar f_{k-M}\prod_{i=k-M+1}^{k}\lambda_i\Big) v_{k-M}v_{k-M}^T ,

    with :math:`\lambda_k = 1 + \bar h_k = \exp\int_{t_k}^{t_{k+1}} h` and
    :math:`\bar f_k = \int_{t_k}^{t_{k+1}} f(t_{k+1}, s)\,ds`
    (eqs. 50–52 and 56 read exactly; the same for b with y).

    Attributes
    ----------
    algorithm : int
    T : float
    window : int or None
        M = tₙ / T (None for algorithms 1'–4').
    t0 : float
    theta0 : ndarray, shape (n,)
    Q0 : ndarray, shape (n, n)
        The continuous initial Q(t₀).
    forgetting : float or ndarray, shape (N,)
        λₖ = 1 + h̄ₖ ∈ (0, 1], the forgetting of the recursive core
        (the paper's αₖ = 1/λₖ multiplies Q).
    fbar : float or ndarray, shape (N,)
        f̄ₖ, the weight of sample k when it enters (in the units of the
        continuous cost: ≈ T f(tₖ, tₖ)).
    scale : float
        σ > 0 with core weights ``fbar / σ`` and prior ``P0 = σ Q0``: the core
        minimises the continuous cost divided by σ, so θ is the same and
        :math:`Q(t_k) = P_k/\sigma`. σ = f̄ for constant f̄ (algorithms 2, 3
        and 4 with constant λ₁, λ₂: unit weights), else σ = T.
    n_samples : int or None
        Length of the per-sample arrays (None when they are constants).
    """

    def __init__(self, *, algorithm, T, window, t_n, t0, theta0, Q0, forgetting, fbar,
                 weighting, n_samples):
        self.algorithm = algorithm
        self.T = T
        self.window = window
        self.t_n = t_n
        self.t0 = t0
        self.theta0 = theta0
        self.Q0 = Q0
        self.forgetting = forgetting
        self.fbar = fbar
        self.n_samples = n_samples
        self._W = weighting
        if np.ndim(fbar) == 0 and fbar > 0.0:
            self.scale = float(fbar)
        else:
            self.scale = float(T)

    # ------------------------------------------------------------ derived
    @property
    def hbar(self):
        """h̄ₖ = λₖ − 1 (eq. 50, 52)."""
        return self.forgetting - 1.0

    @property
    def weights(self):
        """Per-sample weights wₖ = f̄ₖ / σ of the recursive core (1 for constant f̄)."""
        return self.fbar / self.scale

    @property
    def P0(self):
        """Prior covariance σ Q₀ of the recursive core."""
        return self.scale * self.Q0

    def __repr__(self):
        prime = "" if self.window is not None else "'"
        return (f"Discretization(algorithm {self.algorithm}{prime}, T={self.T:g}, "
                f"window={self.window}, scale={self.scale:.6g})")

    def estimator(self):
        """A fresh recursive estimator of the core for this discretisation.

        Returns
        -------
        SlidingWindowRLS or RLS
            ``window`` M (algorithms 1–4) or none (1'–4'), ``theta0``,
            ``P0 = σ Q0`` and, for a constant λ, ``forgetting = λ``. With
            per-sample λₖ or wₖ, pass ``weights=self.weights`` and
            ``forgetting=self.forgetting`` to its ``run`` (as :meth:`run` does).
        """
        from ..estimators import RLS, SlidingWindowRLS
        n = self.theta0.shape[0]
        lam = float(self.forgetting) if np.ndim(self.forgetting) == 0 else 1.0
        if self.window is None:
            return RLS(n, forgetting=lam, theta0=self.theta0, P0=self.P0)
        return SlidingWindowRLS(n, self.window, forgetting=lam, theta0=self.theta0, P0=self.P0)

    # --------------------------------------------------------------- runs
    def _data(self, v, y):
        n = self.theta0.shape[0]
        v = as_float_array(v, "v", ndim=2)
        if v.shape[1] != n:
            raise param_error("v", f"of shape (N, {n})", f"<shape {v.shape}>")
        N = v.shape[0]
        y = as_float_array(y, "y", shape=(N,))
        if self.n_samples is not None and N > self.n_samples:
            raise param_error("v", f"at most n_samples={self.n_samples} rows (the weights were "
                              "computed for that many samples)", f"<{N} rows>")
        lam = np.broadcast_to(np.asarray(self.forgetting, dtype=float), (self.n_samples or N,))[:N]
        fb = np.broadcast_to(np.asarray(self.fbar, dtype=float), (self.n_samples or N,))[:N]
        return v, y, N, np.ascontiguousarray(lam), np.ascontiguousarray(fb)

    def _times(self, N):
        return self.t0 + self.T * np.arange(N + 1)

    def run(self, v, y):
        r"""Run the recursive core (:class:`~adaptid.SlidingWindowRLS` / :class:`~adaptid.RLS`).

        Parameters
        ----------
        v : array_like, shape (N, n)
            Samples vₖ, held on :math:`[t_k, t_{k+1})`.
        y : array_like, shape (N,)

        Returns
        -------
        TLSMResult
            ``t`` (N+1,) = :math:`t_0 + kT`; ``theta[k]`` the estimate after
            k samples (``theta[0] = θ₀``), equal to the continuous
            :math:`\hat\theta(t_k)`; ``Q[k] = P_k / σ`` = :math:`Q(t_k)`.
            One ``update`` per sample (bit-for-bit the core's ``run``), to
            collect P.
        """
        v, y, N, lam, fb = self._data(v, y)
        est = self.estimator()
        w = fb / self.scale
        n = v.shape[1]
        theta = np.empty((N + 1, n))
        Q = np.empty((N + 1, n, n))
        theta[0], Q[0] = self.theta0, self.Q0
        for k in range(N):
            est.update(v[k], float(y[k]), weight=float(w[k]), forgetting=float(lam[k]))
            theta[k + 1] = est.theta
            Q[k + 1] = est.P / self.scale
        return TLSMResult(t=self._times(N), theta=theta, Q=Q,
                          info={"kind": "discrete (recursive core)", "estimator": repr(est)})

    def run_lemma(self, v, y):
        r"""Iterate the paper's discrete algorithm 1 in Q form (eqs. 62–65, 66–68).

        This is the discretisation of eq. 14 by the lemma (eqs. 40–41,
        59–61): :math:`Q_{k+1} - Q_k = -\bar h_k Q_{k+1} - Q_{k+1}\,\Delta_k\,Q_k`,
        :math:`\Delta_k = \bar f_k v_kv_k^T - \bar f_{k-M} v_{k-M}v_{k-M}^T`,
        solved in closed form by the rank-two inversion lemma (with
        :math:`\alpha_k = 1/\lambda_k`):

        .. math::

            d_k g_{1k} &= (1-\alpha_k\bar f_{k-M}s_{2k})Q_kv_k + \alpha_k\bar f_{k-M}s_{0k}Q_kv_{k-M},\\
            d_k g_{2k} &= (1+\alpha_k\bar f_k s_{1k})Q_kv_{k-M} - \alpha_k\bar f_k s_{0k}Q_kv_k,\\
            Q_{k+1} &= \alpha_k(I - \alpha_k\bar f_k g_{1k}v_k^T + \alpha_k\bar f_{k-M}g_{2k}v_{k-M}^T)Q_k,\\
            \theta_{k+1} &= \theta_k + \alpha_k(\bar f_k g_{1k}e_k - \bar f_{k-M}g_{2k}e_{Mk}).

        The factor :math:`\alpha_k` in the last line is not in the paper's
        eq. 62/66: the g of eq. 65/68 equals :math:`\lambda_k Q_{k+1}v`, not
        the :math:`Q_{k+1}v` of eq. 63 (the two agree for algorithm 2, where
        α = 1). Plain NumPy, in the units of the continuous algorithm
        (:math:`Q_0`, weights f̄).

        Parameters
        ----------
        v : array_like, shape (N, n)
        y : array_like, shape (N,)

        Returns
        -------
        TLSMResult
        """
        v, y, N, lam, fb = self._data(v, y)
        M = self.window
        theta = np.empty((N + 1, v.shape[1]))
        Qs = np.empty((N + 1, v.shape[1], v.shape[1]))
        th = self.theta0.copy()
        Q = self.Q0.copy()
        theta[0], Qs[0] = th, Q
        for k in range(N):
            a = fb[k]
            al = 1.0 / lam[k]
            vk = v[k]
            e = y[k] - vk @ th
            Qv = Q @ vk
            s1 = vk @ Qv
            if M is not None and k >= M:
                c = fb[k - M] * float(np.prod(lam[k - M + 1:k + 1]))
                vn = v[k - M]
                en = y[k - M] - vn @ th
                Qn = Q @ vn
                s0 = vk @ Qn
                s2 = vn @ Qn
                d = (1.0 + al * a * s1) * (1.0 - al * c * s2) + al * al * a * c * s0 * s0
                g1 = ((1.0 - al * c * s2) * Qv + al * c * s0 * Qn) / d
                g2 = ((1.0 + al * a * s1) * Qn - al * a * s0 * Qv) / d
                Q = al * (Q - al * a * np.outer(g1, Qv) + al * c * np.outer(g2, Qn))
                th = th + al * (a * g1 * e - c * g2 * en)
            else:
                g1 = Qv / (1.0 + al * a * s1)
                Q = al * (Q - al * a * np.outer(g1, Qv))
                th = th + al * a * g1 * e
            Q = 0.5 * (Q + Q.T)
            theta[k + 1], Qs[k + 1] = th, Q
        return TLSMResult(t=self._times(N), theta=theta, Q=Qs,
                          info={"kind": "discrete (lemma, eqs. 62-65)"})

    def run_euler(self, v, y):
        r"""The naive forward-Euler discretisation of eq. 14 — the paper's counter-example.

        Replaces the derivative of Q by a forward difference (eqs. 35–36),
        with the rectangle weights :math:`T f(t_k, t_k)`,
        :math:`T f(t_k, t_k - t_n)` and :math:`T h(t_k)`:

        .. math::

            Q_{k+1} = Q_k - T h(t_k) Q_k - Q_k\,\Delta_k\,Q_k,\qquad
            \Delta_k = T f(t_k,t_k)v_kv_k^T - T f(t_k,t_k-t_n)v_{k-M}v_{k-M}^T,

        and θ by eq. 53 with this :math:`Q_{k+1}`. Since
        :math:`(Q_k - Q_k\Delta Q_k)^{-1} = R_k + \Delta + \Delta Q_k\Delta + O(\Delta^3)`,
        each step adds :math:`\Delta_kQ_k\Delta_k = O(T^2)` to the information
        matrix: a first-order error in T overall, unlike the lemma
        (:meth:`run_lemma`), which is exact. Q may even lose definiteness
        when :math:`T f\,v^TQv \ge 1`.

        Parameters
        ----------
        v : array_like, shape (N, n)
        y : array_like, shape (N,)

        Returns
        -------
        TLSMResult
            ``info["lost_definiteness_at"]`` is the first sample after which
            Q was not positive definite (None if it stayed so); from there on
            theta and Q are NaN and a :class:`~adaptid.DefinitenessLossWarning`
            is emitted.
        """
        v, y, N, _, _ = self._data(v, y)
        W, T, M = self._W, self.T, self.window
        tk = self._times(N)
        theta = np.empty((N + 1, v.shape[1]))
        Qs = np.empty((N + 1, v.shape[1], v.shape[1]))
        th = self.theta0.copy()
        Q = self.Q0.copy()
        theta[0], Qs[0] = th, Q
        lost = None
        for k in range(N):
            if lost is not None:     # Q is no longer a covariance: nothing to continue
                theta[k + 1:], Qs[k + 1:] = np.nan, np.nan
                break
            t = tk[k]
            a = T * W.f_now(t)
            hb = T * W.h(t)
            vk = v[k]
            e = y[k] - vk @ th
            D = a * np.outer(vk, vk)
            gain = a * vk * e
            if M is not None and k >= M:
                c = T * W.f_full(t, tk[k - M])
                vn = v[k - M]
                D -= c * np.outer(vn, vn)
                gain -= c * vn * (y[k - M] - vn @ th)
            with np.errstate(over="ignore", invalid="ignore"):
                Q = Q - hb * Q - Q @ D @ Q
                Q = 0.5 * (Q + Q.T)
                th = th + Q @ gain
            theta[k + 1], Qs[k + 1] = th, Q
            if not _is_spd(Q):
                lost = k + 1
        if lost is not None:
            warnings.warn(
                f"run_euler: the naive forward-Euler Q lost positive definiteness at sample "
                f"{lost} (T f vᵀQv too large); theta and Q are NaN from the next sample on. "
                "Use run() or run_lemma(), which are exact.", DefinitenessLossWarning,
                stacklevel=2)
        return TLSMResult(t=tk, theta=theta, Q=Qs,
                          info={"kind": "naive forward Euler of eq. 14 (eqs. 35-36)",
                                "lost_definiteness_at": lost})


def discretize(T, *, algorithm, t_n, theta0, Q0, alpha=None, lambda1=None, lambda2=None,
               f=None, h=None, n_samples=None, t0=0.0):
    r"""Discretise a continuous TLSM algorithm exactly for signals held over T.

    Yamamoto (1991), section 3: with the signals held constant over each
    sample interval, the continuous algorithm of :func:`integrate` becomes
    the discrete algorithm of the same weighting with
    :math:`\bar f = T f`, :math:`\bar h = T h` (eqs. 50–52) — read exactly
    over one hold interval:

    .. math::

        1 + \bar h_k = \lambda_k = \exp\int_{t_k}^{t_{k+1}} h(\tau)\,d\tau
          = \frac{f(t_{k+1},s)}{f(t_k,s)},\qquad
        \bar f_k = \int_{t_k}^{t_{k+1}} f(t_{k+1},s)\,ds .

    The recursive core then reproduces the continuous estimate at the
    sample instants to rounding: ``SlidingWindowRLS(n, M)`` (``RLS`` for
    ``t_n=None``) with per-sample forgetting :math:`\lambda_k` (the paper's
    :math:`\alpha_k = 1/\lambda_k`), weights :math:`w_k = \bar f_k/\sigma` and
    prior :math:`P_0 = \sigma Q_0`:

    * algorithm 2 (eqs. 69–70): :math:`\lambda_k = 1`, :math:`\bar f_k = T`, σ = T;
    * algorithm 3 (eqs. 71–72): :math:`\lambda_k = e^{-\alpha T}`,
      :math:`\bar f_k = (1-e^{-\alpha T})/\alpha`, σ = f̄ (unit weights);
    * algorithm 4 (eqs. 73–74): :math:`\lambda_k = e^{-T\lambda_{1,k}}`,
      :math:`\bar f_k = T\lambda_{2,k}\,(1-e^{-x_k})/x_k` with
      :math:`x_k = T\lambda_{1,k}`, σ = T (σ = f̄ if λ₁, λ₂ are constants);
    * algorithm 1: λₖ and f̄ₖ by adaptive quadrature of h and f, σ = T.

    (Algorithm 4 with λ₁, λ₂ held on the sample grid; with callables, by
    quadrature.) Eq. 74's :math:`\bar f_k = T\lambda_{2,k}` is the rectangle
    rule for the hold integral; the factor :math:`(1-e^{-x})/x` is what makes
    the discretisation exact, and a constant factor (constant λ₁) is
    absorbed in σ.

    Parameters
    ----------
    T : float
        Sample time > 0.
    algorithm : {1, 2, 3, 4}
    t_n : float or None
        Window tₙ, a multiple M T of T with M ≥ n (None: algorithms 1'–4').
    theta0 : array_like, shape (n,)
    Q0 : float or array_like, shape (n, n)
        The continuous algorithm's Q(t₀) (usual initialisation; the exact
        one of eq. 32 has no counterpart in the core, which starts from a
        prior).
    alpha, lambda1, lambda2, f, h
        The weighting, as for :func:`integrate`; array λ₁, λ₂ hold one value
        per sample interval, shape (N,).
    n_samples : int, optional
        N, needed when the weights vary in time and are given by callables
        (algorithm 1, or 4 with callable λ₁, λ₂).
    t0 : float
        Time of the first sample.

    Returns
    -------
    Discretization
        ``.forgetting`` (λₖ), ``.fbar``, ``.hbar``, ``.weights``, ``.P0``,
        ``.scale``, ``.window``; ``.estimator()`` the configured core
        estimator; ``.run(v, y)`` the core on sampled data,
        ``.run_lemma(v, y)`` the paper's eqs. 62–65, ``.run_euler(v, y)`` the
        naive forward Euler of eq. 14 (eqs. 35–36), all as :class:`TLSMResult`
        at :math:`t_k = t_0 + kT`, k = 0..N.

    Raises
    ------
    ValueError
        Bad arguments (naming the argument); a window not a multiple of T
        or shorter than n samples; a weighting that grows
        (:math:`\lambda_k > 1`), which the core's forgetting cannot express.

    References
    ----------
    .. [1] T. Yamamoto, 1991, eqs. 33–74.

    Examples
    --------
    >>> from adaptid.continuous import discretize
    >>> d = discretize(0.1, algorithm=3, t_n=1.0, alpha=0.5, theta0=[0.0], Q0=1.0)
    >>> d.window, round(float(d.forgetting), 6), round(d.scale, 6)
    (10, 0.951229, 0.097541)
    """
    T = check_scalar(T, "T", low=0.0, low_open=True)
    alg = check_algorithm(algorithm)
    theta0 = as_float_array(theta0, "theta0", ndim=1, copy=True)
    n = theta0.shape[0]
    if n < 1:
        raise param_error("theta0", "of length n >= 1", theta0)
    Q0 = check_spd(Q0, "Q0", n)
    t0 = check_scalar(t0, "t0")
    M = None
    if t_n is not None:
        t_n = check_scalar(t_n, "t_n", low=0.0, low_open=True)
        M = int(round(t_n / T))
        if M < 1 or abs(M * T - t_n) > 1e-9 * t_n:
            raise param_error("t_n", f"a positive multiple of T={T:g} (the window holds "
                              "M = t_n/T samples)", t_n)
        if M < n:
            raise param_error("t_n", f">= n*T = {n * T:g} (the discrete window must hold at "
                              f"least n={n} samples)", t_n)
    N = None
    if n_samples is not None:
        N = check_int(n_samples, "n_samples", low=1)
    elif alg == 4:
        for lam in (lambda1, lambda2):
            if lam is not None and not callable(lam) and np.ndim(lam) > 0:
                N = int(np.shape(lam)[0])
                break
    grid = t0 + T * np.arange(N if N is not None else 1)
    W = make_weighting(alg, alpha=alpha, lambda1=lambda1, lambda2=lambda2, f=f, h=h, t_n=t_n,
                       grid=grid, breakpoints=grid if N is not None else np.empty(0),
                       lam_what=" (one value per sample)")

    if alg == 2:
        lam, fbar = 1.0, T
    elif alg == 3:
        lam = math.exp(-W.alpha * T)
        fbar = T * float(_phi1(W.alpha * T))
    elif alg == 4 and not callable(lambda1) and not callable(lambda2):
        if N is None:   # both constants
            l1, l2 = float(lambda1), float(lambda2)
            lam = math.exp(-T * l1)
            fbar = T * l2 * float(_phi1(T * l1))
        else:
            l1 = np.broadcast_to(np.asarray(lambda1, dtype=float), (N,))
            l2 = np.broadcast_to(np.asarray(lambda2, dtype=float), (N,))
            lam = np.exp(-T * l1)
            fbar = T * l2 * _phi1(T * l1)
    else:
        if N is None:
            raise param_error("n_samples", f"given for algorithm {alg} with weights given by "
                              "callables (one weight per sample is computed by quadrature)",
                              n_samples)
        edges = t0 + T * np.arange(N + 1)
        lam = np.array([math.exp(W.int_h(a, b)) for a, b in zip(edges[:-1], edges[1:])])
        fbar = np.array([_hold_integral(W, a, b) for a, b in zip(edges[:-1], edges[1:])])

    lam_arr = np.atleast_1d(np.asarray(lam, dtype=float))
    if not (np.isfinite(lam_arr).all() and (lam_arr > 0.0).all() and (lam_arr <= 1.0).all()):
        who = {1: "h", 3: "alpha", 4: "lambda1"}.get(alg, "h")
        raise param_error(who, "such that the weight does not grow over a sample "
                          "(forgetting λₖ = exp(∫h) in (0, 1])",
                          f"<λₖ in [{lam_arr.min():.6g}, {lam_arr.max():.6g}]>")
    fb_arr = np.atleast_1d(np.asarray(fbar, dtype=float))
    if not (np.isfinite(fb_arr).all() and (fb_arr >= 0.0).all()):
        who = {1: "f", 4: "lambda2"}.get(alg, "f")
        raise param_error(who, "non-negative (eq. 3)", "<a negative sample weight>")
    return Discretization(algorithm=alg, T=T, window=M, t_n=t_n, t0=t0, theta0=theta0, Q0=Q0,
                          forgetting=lam, fbar=fbar, weighting=W, n_samples=N)


def _is_spd(Q):
    if not np.isfinite(Q).all():
        return False
    try:
        np.linalg.cholesky(Q)
    except np.linalg.LinAlgError:
        return False
    return True


def _hold_integral(W, a, b):
    r""":math:`\int_a^b f(b, s)\,ds` by adaptive quadrature (f itself may use quadrature)."""
    val, _ = _spi.quad(lambda s: W.f_full(b, s), a, b, epsabs=0.0, epsrel=1e-12, limit=200)
    return val
