r"""Streaming ARMAX / ARMA / OE / BJ model objects (MATLAB's ``recursiveARMAX`` …)."""

from __future__ import annotations

import numpy as np

from ._plr import _PseudoLinearStream

__all__ = ["RecursiveARMAX", "RecursiveARMA", "RecursiveOE", "RecursiveBJ"]

_DEFAULTS = dict(method="forgetting", forgetting=1.0, noise_cov=0.1, noise_var=1.0, step=1.0,
                 bias=None, window=None, theta0=None, P0=1e4, start="zero")


def _inputs_of(nb, nk):
    """(number of inputs, single input?) of the order arguments, as RecursiveARX reads them."""
    single = np.ndim(nb) == 0 and np.ndim(nk) == 0
    return (1 if single else (len(nb) if np.ndim(nb) else len(nk))), single


def _orders(o, key):
    return o[key][0] if o["single"] else o[key]


class RecursiveARMAX(_PseudoLinearStream):
    r"""Streaming ARMAX model by extended least squares (MATLAB's ``recursiveARMAX`` object).

    The model :math:`A(q)y_k = B(q)u_k + C(q)e_k`, θ = [a₁ … a_na, b₀ …,
    c₁ … c_nc] (as :class:`~adaptid.models.ARMAX`), identified sample by
    sample by recursive extended least squares (RELS) with a-posteriori
    residuals, the recursion of :meth:`ARMAX.fit_recursive
    <adaptid.models.ARMAX.fit_recursive>` (Ljung (1999), sec. 11.3;
    Söderström & Stoica (1989), sec. 9.4):

    .. math::

        \varphi_k = [-y_{k-1}, \dots, -y_{k-n_a},\; u_{k-n_k}, \dots,
                     u_{k-n_k-n_b+1},\; \bar\varepsilon_{k-1}, \dots,
                     \bar\varepsilon_{k-n_c}]^T,

    .. math::

        \hat y_k = \varphi_k^T\hat\theta_{k-1},\qquad
        \varepsilon_k = y_k - \hat y_k,\qquad
        \hat\theta_k = \hat\theta_{k-1} + K_k\varepsilon_k,\qquad
        \bar\varepsilon_k = y_k - \varphi_k^T\hat\theta_k,

    with the gain :math:`K_k` of the method chosen, as in
    :class:`~adaptid.models.RecursiveARX`:

    * ``"forgetting"``: :math:`K_k = P_{k-1}\varphi_k/(\lambda + \varphi_k^TP_{k-1}\varphi_k)`,
      :math:`P_k = (P_{k-1} - K_k\varphi_k^TP_{k-1})/\lambda` (λ = ``forgetting``;
      a strategy of :mod:`adaptid.forgetting` is accepted too);
    * ``"kalman"``: :math:`K_k = P_{k-1}\varphi_k/(R_2 + \varphi_k^TP_{k-1}\varphi_k)`,
      :math:`P_k = P_{k-1} - K_k\varphi_k^TP_{k-1} + R_1` (:math:`R_1` = ``noise_cov``,
      :math:`R_2` = ``noise_var``);
    * ``"ngradient"``: :math:`K_k = \mu\varphi_k/(\beta + \varphi_k^T\varphi_k)`;
      ``"gradient"``: :math:`K_k = \mu\varphi_k` (μ = ``step``, β = ``bias``);
    * ``window=M`` (with ``"forgetting"`` only): least squares over the last
      M regressor rows the recursion formed, as
      :class:`~adaptid.SlidingWindowRLS` (a removal that would lose
      definiteness re-solves the window from its buffer, with a
      :class:`~adaptid.DefinitenessLossWarning`).

    P is propagated in U-D factored form (Bierman's update), as in the core
    estimators. Every method applies to every streaming pseudo-linear model
    (:class:`RecursiveARMAX`, :class:`RecursiveARMA`, :class:`RecursiveOE`,
    :class:`RecursiveBJ`); ``window`` with another method is a ValueError,
    and so is an unknown method.

    **Start.** The lag buffers of y, u and of the residuals start at zero,
    as MATLAB's do: with ``start="zero"`` (default) the first samples are
    used with the unknown past taken as 0. With ``start="filled"`` no update
    is made until the buffers of y and u hold measured data (sample
    :math:`s = \max(n_a, n_k + n_b - 1)` counted from construction or
    :meth:`reset`; the residual lags are then still 0): :meth:`step`
    returns the unchanged θ and ``yhat = NaN`` before it, and :meth:`run`
    over a record equals ``ARMAX(na, nb, nc, nk).fit_recursive(y, u, est)``
    bit for bit (``est`` the core estimator the options describe, e.g.
    ``adaptid.estimator("rls", n, forgetting=λ)``; before root reflection,
    which ``fit_recursive`` applies to the model's final θ only). A merged
    IDData given to :meth:`run` restarts these buffers (and the wait) at
    each experiment while θ and P run on, as ``fit_recursive`` does.

    **MATLAB's recursive objects differ.** MATLAB's ``recursiveARMAX``
    (``recursiveARMA``, ``recursiveOE``, ``recursiveBJ``) runs the recursive
    prediction-error method (RPEM): the same a-priori error and
    a-posteriori regressor, but the gain direction is the gradient
    :math:`\psi_k = \varphi_k/\hat C(q)` (OE: :math:`\varphi_k/\hat F(q)`;
    BJ: the filtered gradient of :class:`~adaptid.models.BJ`) instead of
    :math:`\varphi_k`, with a projection that keeps :math:`\hat C` (:math:`\hat F`)
    stable. The tracks therefore differ sample by sample. Both are
    consistent for the true system; RELS/PLR needs
    :math:`1/C(e^{i\omega}) - 1/2` (:math:`1/F - 1/2`) strictly positive real,
    RPEM does not but costs the filtering. MATLAB offers finite history only
    for ``recursiveAR``/``recursiveARX``; ``window`` here is an adaptid
    extension. ``step`` returns θ as one vector where MATLAB returns
    ``[A, B, C, yhat]``.

    Parameters
    ----------
    na : int
        Order of A, ``>= 0``.
    nb : int or sequence of int
        Number of B coefficients (per input), ``>= 0``.
    nc : int
        Order of C, ``>= 0``.
    nk : int or sequence of int
        Input delay (per input), ``>= 0`` (default 1).
    method : {"forgetting", "kalman", "ngradient", "gradient"}
        MATLAB's ``EstimationMethod`` (default ``"forgetting"``).
    forgetting : float or forgetting strategy
        λ in (0, 1] (``"forgetting"`` and ``window``; default 1).
    noise_cov : float or array_like, shape (n, n)
        :math:`R_1` (``"kalman"``; default 0.1, i.e. 0.1 I as MATLAB's).
    noise_var : float
        :math:`R_2` (``"kalman"``; default 1).
    step : float
        Adaptation gain μ (gradient methods; default 1).
    bias : float, optional
        Normalisation bias β (``"ngradient"``; default machine epsilon).
    window : int, optional
        Finite history of M rows (``M >= n``; ``"forgetting"`` only).
    theta0 : array_like, shape (n,), optional
        Initial parameters (default 0).
    P0 : float, array_like or "diffuse"
        Initial covariance (not for the gradient methods; default 1e4);
        ``"diffuse"`` is the exact diffuse start of ``fit_recursive``.
    start : {"zero", "filled"}
        Lag buffers used from the first sample (MATLAB) or updates only once
        y and u buffers hold measured data.
    dt : float
        Sample time of :meth:`to_model`'s model (default 1.0; an IDData or a
        time-indexed pandas record given to :meth:`run` sets it).

    Attributes
    ----------
    n_params : int
    names : tuple of str
        ``a1 …, b0 …, c1 …`` as the batch model's.
    theta : ndarray, shape (n,)
    P : ndarray, shape (n, n) or None
    n_updates : int

    See Also
    --------
    adaptid.models.ARMAX.fit_recursive : the same recursion over a record.
    adaptid.models.RecursiveARX : the ARX object whose interface this shares.

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, sec. 11.3 (RELS, RPLR, RPEM).
    .. [2] T. Söderström, P. Stoica, *System Identification*, Prentice Hall,
       1989, sec. 9.4.
    .. [3] The MathWorks, System Identification Toolbox, ``recursiveARMAX``
       (behavioural reference: ``[A, B, C, EstimatedOutput] = step(obj, y, u)``).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import RecursiveARMAX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(5000); e = 0.2 * rng.standard_normal(5000)
    >>> y = lfilter([0, 1.0], [1, -0.7], u) + lfilter([1, 0.5], [1, -0.7], e)
    >>> obj = RecursiveARMAX(1, 1, 1, 1)
    >>> theta, yhat = obj.step(y[0], u[0])
    >>> res = obj.run(y[1:], u[1:])
    >>> bool(np.allclose(res.theta[-1], [-0.7, 1.0, 0.5], atol=0.05))
    True
    """

    _kind = "RecursiveARMAX"

    def __init__(self, na, nb, nc, nk=1, *, method="forgetting", forgetting=1.0, noise_cov=0.1,
                 noise_var=1.0, step=1.0, bias=None, window=None, theta0=None, P0=1e4,
                 start="zero", dt=1.0):
        from .._armax import ARMAX

        self._setup((ARMAX(na, nb, nc, nk, dt=dt), *_inputs_of(nb, nk)), method=method,
                    forgetting=forgetting, noise_cov=noise_cov, noise_var=noise_var,
                    step=step, bias=bias, window=window, theta0=theta0, P0=P0, start=start)

    def _options(self):
        return {"na": self.na, "nb": list(self.nb), "nc": self._model.nc, "nk": list(self.nk),
                "single": self._single}

    @classmethod
    def _build(cls, o):
        return cls(o["na"], _orders(o, "nb"), o["nc"], _orders(o, "nk"), method=o["method"],
                   start=o["start"], dt=o["dt"])


class RecursiveARMA(RecursiveARMAX):
    r"""Streaming ARMA model by extended least squares (MATLAB's ``recursiveARMA``).

    :math:`A(q)y_k = C(q)e_k`,
    :math:`\varphi_k = [-y_{k-1}, \dots, -y_{k-n_a}, \bar\varepsilon_{k-1}, \dots,
    \bar\varepsilon_{k-n_c}]^T`, θ = [a₁ …, c₁ …]; ``step(y)`` returns
    ``(theta, yhat)``. Everything else as :class:`RecursiveARMAX` (methods,
    ``window``, ``start``: with ``start="filled"`` the first update is at
    sample :math:`n_a`, and :meth:`run` equals ``ARMA(na, nc).fit_recursive``
    bit for bit; state files); :meth:`to_model` returns an
    :class:`~adaptid.models.ARMA`.

    Parameters
    ----------
    na : int
        Order of A, ``>= 1``.
    nc : int
        Order of C, ``>= 0``.
    **options
        As :class:`RecursiveARMAX` (``method``, ``forgetting``, ``noise_cov``,
        ``noise_var``, ``step``, ``bias``, ``window``, ``theta0``, ``P0``,
        ``start``, ``dt``).

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, sec. 11.3.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import RecursiveARMA
    >>> y = lfilter([1, 0.5], [1, -0.8], np.random.default_rng(1).standard_normal(5000))
    >>> res = RecursiveARMA(1, 1).run(y)
    >>> bool(np.allclose(res.theta[-1], [-0.8, 0.5], atol=0.05))
    True
    """

    _kind = "RecursiveARMA"

    def __init__(self, na, nc, **options):
        from .._ar import ARMA

        dt = options.pop("dt", 1.0)
        self._setup((ARMA(na, nc, dt=dt), 0, True), **{**_DEFAULTS, **options})

    def step(self, y):  # noqa: D102 - documented on RecursiveARMAX
        return super().step(y)

    step.__doc__ = _PseudoLinearStream.step.__doc__

    def run(self, y):  # noqa: D102
        return super().run(y)

    run.__doc__ = _PseudoLinearStream.run.__doc__

    def _options(self):
        return {"na": self.na, "nc": self._model.nc}

    @classmethod
    def _build(cls, o):
        return cls(o["na"], o["nc"], method=o["method"], start=o["start"], dt=o["dt"])


class RecursiveOE(RecursiveARMAX):
    r"""Streaming output-error model by pseudo-linear regression (MATLAB's ``recursiveOE``).

    :math:`y_k = B(q)/F(q)\,u_k + e_k`, θ = [b₀ …, f₁ …] (per input, as
    :class:`~adaptid.models.OE`), with the simulated output
    :math:`\bar w_k = \varphi_k^T\hat\theta_k` formed a posteriori and

    .. math::

        \varphi_k = [u_{k-n_k}, \dots, u_{k-n_k-n_b+1},\;
                     -\bar w_{k-1}, \dots, -\bar w_{k-n_f}]^T

    (one w per input); the update as :class:`RecursiveARMAX` (Landau's
    output-error algorithm, the recursion of :meth:`OE.fit_recursive
    <adaptid.models.OE.fit_recursive>`). With ``start="filled"`` the first
    update is at sample :math:`\max_i(n_{k,i} + n_{b,i}) - 1` and :meth:`run`
    equals ``OE(nb, nf, nk).fit_recursive`` bit for bit. MATLAB's
    ``recursiveOE`` uses RPEM (gradient :math:`\varphi_k/\hat F(q)`, see
    :class:`RecursiveARMAX`).

    Parameters
    ----------
    nb : int or sequence of int
        Number of B coefficients (per input), ``>= 1``.
    nf : int or sequence of int
        Order of F (per input), ``>= 0``.
    nk : int or sequence of int
        Input delay (per input), ``>= 0`` (default 1).
    **options
        As :class:`RecursiveARMAX`.

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, sec. 11.3.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import RecursiveOE
    >>> rng = np.random.default_rng(2)
    >>> u = rng.standard_normal(4000)
    >>> y = lfilter([0, 1.0], [1, -0.6], u) + 0.1 * rng.standard_normal(4000)
    >>> res = RecursiveOE(1, 1, 1).run(y, u)
    >>> bool(np.allclose(res.theta[-1], [1.0, -0.6], atol=0.05))
    True
    """

    _kind = "RecursiveOE"

    def __init__(self, nb, nf, nk=1, **options):
        from .._oe import OE

        dt = options.pop("dt", 1.0)
        self._setup((OE(nb, nf, nk, dt=dt), *_inputs_of(nb, nk)), **{**_DEFAULTS, **options})

    def _options(self):
        return {"nb": list(self.nb), "nf": list(self._model._nf), "nk": list(self.nk),
                "single": self._single}

    @classmethod
    def _build(cls, o):
        return cls(_orders(o, "nb"), _orders(o, "nf"), _orders(o, "nk"), method=o["method"],
                   start=o["start"], dt=o["dt"])


class RecursiveBJ(RecursiveARMAX):
    r"""Streaming Box–Jenkins model by pseudo-linear regression (MATLAB's ``recursiveBJ``).

    :math:`y_k = B(q)/F(q)\,u_k + C(q)/D(q)\,e_k`, θ = [b₀ …, c₁ …, d₁ …, f₁ …]
    (as :class:`~adaptid.models.BJ`). With the signals formed a posteriori
    from the estimate after each sample — the simulated output
    :math:`\bar w`, the noise :math:`\bar v = y - \bar w` and the residual
    :math:`\bar\varepsilon = y - \varphi^T\hat\theta` —

    .. math::

        \varphi_k = [u_{k-n_k}, \dots,\; \bar\varepsilon_{k-1}, \dots, \bar\varepsilon_{k-n_c},\;
                     -\bar v_{k-1}, \dots, -\bar v_{k-n_d},\;
                     -\bar w_{k-1}, \dots, -\bar w_{k-n_f}]^T,

    the recursion of :meth:`BJ.fit_recursive <adaptid.models.BJ.fit_recursive>`
    (Ljung (1999), eq. 4.44 and sec. 11.3); the update as
    :class:`RecursiveARMAX`. With ``start="filled"`` the first update is at
    sample :math:`\max_i(n_{k,i} + n_{b,i}) - 1` and :meth:`run` equals
    ``BJ(nb, nc, nd, nf, nk).fit_recursive`` bit for bit. MATLAB's
    ``recursiveBJ`` uses RPEM (see :class:`RecursiveARMAX`).

    Parameters
    ----------
    nb : int or sequence of int
        Number of B coefficients (per input), ``>= 1``.
    nc, nd : int
        Orders of C and D, ``>= 0``.
    nf : int or sequence of int
        Order of F (per input), ``>= 0``.
    nk : int or sequence of int
        Input delay (per input), ``>= 0`` (default 1).
    **options
        As :class:`RecursiveARMAX`.

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, sec. 11.3.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.models import RecursiveBJ
    >>> obj = RecursiveBJ(2, 1, 1, 1, 1)
    >>> obj.names
    ('b0', 'b1', 'c1', 'd1', 'f1')
    >>> theta, yhat = obj.step(0.5, 1.0)
    >>> theta.shape
    (5,)
    """

    _kind = "RecursiveBJ"

    def __init__(self, nb, nc, nd, nf, nk=1, **options):
        from .._bj import BJ

        dt = options.pop("dt", 1.0)
        self._setup((BJ(nb, nc, nd, nf, nk, dt=dt), *_inputs_of(nb, nk)),
                    **{**_DEFAULTS, **options})

    def _options(self):
        return {"nb": list(self.nb), "nc": self._model.nc, "nd": self._model.nd,
                "nf": list(self._model._nf), "nk": list(self.nk), "single": self._single}

    @classmethod
    def _build(cls, o):
        return cls(_orders(o, "nb"), o["nc"], o["nd"], _orders(o, "nf"), _orders(o, "nk"),
                   method=o["method"], start=o["start"], dt=o["dt"])
