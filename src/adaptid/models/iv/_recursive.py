r"""Recursive instrumental variables with an auxiliary model: :class:`RecursiveIV`."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..._validation import as_float_array, check_int, check_scalar, check_spd, param_error
from ...estimators._statefile import StateFileMethods
from ..streaming._arx import RecursiveARX, StreamResult

__all__ = ["RecursiveIV", "RecursiveIVResult"]

#: |λ + φᵀPζ| at or below this fraction of λ + Σ|φᵢ(Pζ)ᵢ| is a singular IV update (skipped)
_SINGULAR_RTOL = 1e-10
_OK, _SIGN, _SINGULAR = 0, 1, 2


@dataclass(frozen=True)
class RecursiveIVResult(StreamResult):
    r"""The tracks of :meth:`RecursiveIV.run` (a :class:`~adaptid.models.StreamResult` plus
    the instruments).

    Attributes
    ----------
    theta : ndarray, shape (N, n)
        ``theta[k]``: the estimate after sample k.
    yhat : ndarray, shape (N,)
        ``yhat[k]``: :math:`\varphi_k^T\hat\theta_{k-1}`, made before ``y[k]`` is used.
    names : tuple of str
    x : ndarray, shape (N,)
        The auxiliary model's output :math:`x_k = \zeta^{x\,T}_k\hat\theta_k`.
    instruments : ndarray, shape (N, n)
        The instrument row ζₖ each update used (φₖ during the warm-up).
    status : ndarray of int, shape (N,)
        0: a regular update; 1: :math:`\lambda + \varphi_k^TP\zeta_k \le 0`
        (the IV matrix changed the sign of its determinant: P is no longer
        a covariance); 2: a singular update, not made.
    """

    x: np.ndarray
    instruments: np.ndarray
    status: np.ndarray

    def to_frame(self):
        """A pandas DataFrame: one column per parameter, then ``yhat``, ``x``, ``status``."""
        frame = super().to_frame()
        frame["x"] = self.x
        frame["status"] = self.status
        return frame

    def plot(self, *, ax=None):
        """The parameter tracks (:func:`adaptid.plot.tracks`); returns the Figure."""
        from ...estimators._hooks import upward
        tracks = upward("adaptid.plot").tracks  # drawing lives in layer 7

        return tracks(np.arange(1, self.theta.shape[0] + 1), self.theta, self.names,
                      label="RIV", ax=ax)

    def summary(self) -> str:
        """A few lines: samples, final estimate, how many updates were irregular."""
        lines = [f"Recursive IV: {self.theta.shape[0]} samples"]
        if self.theta.shape[0]:
            lines += [f"  {n:>8s} = {v: .6g}" for n, v in zip(self.names, self.theta[-1])]
        lines.append(f"  P sign flips: {int(np.sum(self.status == _SIGN))}, singular "
                     f"updates skipped: {int(np.sum(self.status == _SINGULAR))}")
        return "\n".join(lines)


class RecursiveIV(StateFileMethods):
    r"""Recursive instrumental-variable ARX estimator with an auxiliary model.

    For the ARX structure of :class:`~adaptid.models.RecursiveARX`,
    :math:`\varphi_k = [-y_{k-1}, \dots, -y_{k-n_a}, u_{k-n_k}, \dots,
    u_{k-n_k-n_b+1}]^T` and :math:`\theta = [a_1, \dots, a_{n_a}, b_0, \dots]`,
    the instruments are the regressors of the auxiliary model's noise-free
    output x, simulated with the estimate after each sample (Ljung and
    Söderström (1983); Ljung (1999), sec. 11.3):

    .. math::

        \zeta_k = [-x_{k-1}, \dots, -x_{k-n_a}, u_{k-n_k}, \dots,
                   u_{k-n_k-n_b+1}]^T,\qquad x_k = \zeta_k^T\hat\theta_k,

    .. math::

        L_k = \frac{P_{k-1}\zeta_k}{\lambda + \varphi_k^TP_{k-1}\zeta_k},\qquad
        \hat\theta_k = \hat\theta_{k-1} + L_k\,(y_k - \varphi_k^T\hat\theta_{k-1}),

    .. math::

        P_k = \frac{1}{\lambda}\Big(P_{k-1} - \frac{P_{k-1}\zeta_k\varphi_k^TP_{k-1}}
              {\lambda + \varphi_k^TP_{k-1}\zeta_k}\Big).

    This is the matrix inversion lemma for
    :math:`R_k = \lambda R_{k-1} + \zeta_k\varphi_k^T`, :math:`P_k = R_k^{-1}`,
    so after samples 1 … k the estimate solves the IV normal equations with
    the prior,

    .. math::

        \Big(\lambda^kP_0^{-1} + \sum_{j\le k}\lambda^{k-j}\zeta_j\varphi_j^T\Big)\hat\theta_k
        = \lambda^kP_0^{-1}\theta_0 + \sum_{j\le k}\lambda^{k-j}\zeta_jy_j .

    **P is not symmetric** (:math:`R_k` is not): it is not a covariance and is
    never symmetrised. It loses its meaning when :math:`R_k` becomes
    singular: :math:`\det R_k = \det(\lambda R_{k-1})\,
    (\lambda + \varphi_k^TP_{k-1}\zeta_k)/\lambda`. A denominator at or
    below :math:`10^{-10}(\lambda + \sum_i|\varphi_{k,i}(P_{k-1}\zeta_k)_i|)`
    in magnitude is a singular update: it is **not made** (θ, P and the sums
    unchanged; status 2); a negative one is made but flips the sign of
    :math:`\det R_k` (status 1). While :math:`\det R_k` has the opposite
    sign of :math:`\det P_0^{-1}` (an odd number of flips, :attr:`regular`
    False), P no longer describes the uncertainty and :meth:`to_model` gives
    no covariance. Both events emit a :class:`~adaptid.DefinitenessLossWarning`
    naming the samples; :class:`RecursiveIVResult` keeps the status of each.
    They happen mostly in the first samples, when the instruments come from
    a poor auxiliary model: the warm-up below avoids them.

    **Start.** The lag buffers of y, u and x start at zero (as
    :class:`~adaptid.models.RecursiveARX`'s ``start="zero"``), and the
    auxiliary model runs from the first sample with the current estimate
    (from θ₀ on). The first ``warmup`` samples use :math:`\zeta_k = \varphi_k`,
    i.e. plain recursive least squares, so that the auxiliary model is built
    from a least-squares estimate before its instruments are used, as Ljung
    and Söderström recommend; ``warmup=0`` uses the auxiliary instruments
    from the first sample (with θ₀ = 0 their −x part is zero until the b
    estimates move). The warm-up samples stay in the sums above with
    :math:`\zeta_j = \varphi_j` (their least-squares bias fades only with
    forgetting or against the later samples' weight).

    :meth:`to_model` gives the IV covariance estimate
    :math:`\hat\sigma^2P_kS_kP_k^T`,
    :math:`S_k = \sum_j\lambda^{k-j}\zeta_j\zeta_j^T`,
    :math:`\hat\sigma^2 = \sum_j\lambda^{k-j}(y_j - \varphi_j^T\hat\theta_k)^2/(w_k - n)`,
    :math:`w_k = \sum_j\lambda^{k-j}` (Ljung (1999), eq. 9.60 with white
    noise: with a negligible prior and λ = 1 it is the covariance of
    :func:`~adaptid.models.ivx` on the same instrument rows).

    Parameters
    ----------
    na : int
        Order of A, ``>= 0``.
    nb : int or sequence of int
        Number of B coefficients (per input); at least one input with
        ``nb >= 1`` (the instruments are built from u).
    nk : int or sequence of int
        Input delay (per input), ``>= 0`` (default 1).
    P0 : float or array_like, shape (n, n)
        Initial P (a scalar c means c I; symmetric positive definite;
        default 1e4).
    theta0 : array_like, shape (n,), optional
        Initial estimate (default 0); it also drives the first auxiliary outputs.
    forgetting : float
        λ in (0, 1] (default 1).
    warmup : int
        Number of first samples (counted from construction or
        :meth:`reset`) with ζ = φ (default ``10 * n``; 0: none).
    dt : float
        Sample time of the model :meth:`to_model` returns (default 1.0;
        replaced by the ``dt`` of an IDData or time-indexed record given to
        :meth:`run`).

    Attributes
    ----------
    n_params : int
    names : tuple of str
    n_updates : int
        Samples used so far (those skipped as singular not counted).

    References
    ----------
    .. [1] L. Ljung and T. Söderström, *Theory and Practice of Recursive
       Identification*, MIT Press, 1983 (the recursive IV method with an
       auxiliary model).
    .. [2] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, sec. 11.3 and eq. 9.60.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import RecursiveIV
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(4000); e = rng.standard_normal(4000)
    >>> y = lfilter([0, 1.0], [1, -0.8], u) + lfilter([1, 0.9], [1, -0.8], e)
    >>> obj = RecursiveIV(1, 1, 1)
    >>> res = obj.run((y, u))
    >>> bool(np.allclose(res.theta[-1], [-0.8, 1.0], atol=0.05))
    True
    >>> obj.to_model().stderr.shape
    (2,)
    """

    _kind = "RecursiveIV"
    _make_model = RecursiveARX._make_model
    _init_structure = RecursiveARX._init_structure
    _inputs = RecursiveARX._inputs

    def __init__(self, na, nb, nk=1, *, P0=1e4, theta0=None, forgetting=1.0, warmup=None,
                 dt=1.0):
        self._init_structure(*self._make_model(na, nb, nk, dt))
        if not any(self.nb):
            raise param_error("nb", ">= 1 for at least one input (the instruments are built "
                              "from u)", nb)
        n = self.n_params
        self.dt = self._model.dt
        self.forgetting = check_scalar(forgetting, "forgetting", low=0.0, low_open=True,
                                       high=1.0)
        self.warmup = 10 * n if warmup is None else check_int(warmup, "warmup", low=0)
        self.P0 = check_spd(P0, "P0", n)
        self.theta0 = (np.zeros(n) if theta0 is None
                       else as_float_array(theta0, "theta0", shape=(n,), copy=True))
        self.reset()

    # ------------------------------------------------------------ state
    def reset(self):
        """Back to the prior (θ₀, P₀): zero lag buffers and sums, the warm-up again."""
        n = self.n_params
        self._theta = self.theta0.copy()
        self._P = self.P0.copy()
        self._S = np.zeros((n, n))
        self._Sff = np.zeros((n, n))
        self._sfy = np.zeros(n)
        self._acc = np.array([0.0, 0.0, 1.0])        # Σ λ^(k-j) y², Σ λ^(k-j), sign det R
        self._ybuf = np.zeros(self.na)               # y(k-1), …, y(k-na)
        self._xbuf = np.zeros(self.na)               # x(k-1), …, x(k-na)
        self._ubuf = np.zeros((self._m, self._Lu))   # u(k-1), …, u(k-Lu) per input
        self._count = 0
        self._flags = [0, 0]                         # samples of status 1 and 2 so far

    @property
    def theta(self):
        """The current estimate, shape (n,) (a copy)."""
        return self._theta.copy()

    @property
    def P(self):
        r"""The current :math:`P_k = R_k^{-1}` (not symmetric), shape (n, n) (a copy)."""
        return self._P.copy()

    @property
    def regular(self) -> bool:
        r"""True while :math:`\det R_k` has the sign of :math:`\det P_0^{-1}` (an even
        number of updates with :math:`\lambda + \varphi_k^TP\zeta_k < 0`)."""
        return bool(self._acc[2] > 0)

    @property
    def n_updates(self) -> int:
        """Samples used so far (singular updates, which are not made, not counted)."""
        return self._count - self._flags[1]

    # ------------------------------------------------------------ use
    def _advance(self, y, U):
        """Run the kernel over validated samples on copies of the state; commit after."""
        from ..._kernels.layers._riv import riv_run

        N, n = y.shape[0], self.n_params
        st = [a.copy() for a in (self._theta, self._P, self._S, self._Sff, self._sfy, self._acc,
                                 self._ybuf, self._xbuf, self._ubuf)]
        out = (np.empty((N, n)), np.empty(N), np.empty(N), np.empty((N, n)),
               np.empty(N, dtype=np.int64))
        warm = min(max(self.warmup - self._count, 0), N)
        riv_run(*st, y, np.ascontiguousarray(U, dtype=np.float64),
                np.asarray(self.nb, dtype=np.int64), np.asarray(self.nk, dtype=np.int64),
                self.forgetting, _SINGULAR_RTOL, warm, *out)
        (self._theta, self._P, self._S, self._Sff, self._sfy, self._acc, self._ybuf,
         self._xbuf, self._ubuf) = st
        status = out[4]
        self._warn(status)
        self._flags[0] += int(np.sum(status == _SIGN))
        self._flags[1] += int(np.sum(status == _SINGULAR))
        self._count += N
        return out

    def _warn(self, status):
        for code, what in ((_SIGN, "had λ + φᵀPζ <= 0 and changed the sign of det R (R = "
                            "P⁻¹, the IV matrix)"),
                           (_SINGULAR, "were singular (λ + φᵀPζ ≈ 0) and were not made")):
            bad = np.flatnonzero(status == code) + self._count
            if bad.size:
                from ..._exceptions import DefinitenessLossWarning
                now = ("" if code == _SINGULAR else "; det R now has the sign of det P0⁻¹"
                       if self.regular else "; det R now has the opposite sign of det P0⁻¹: "
                       "P is no longer a covariance")
                warnings.warn(DefinitenessLossWarning(
                    f"RecursiveIV: the updates of samples {bad[:5].tolist()}"
                    f"{' …' if bad.size > 5 else ''} (counted from 0 since reset) {what}{now}; "
                    "check the excitation, the orders and the warm-up"), stacklevel=4)

    def step(self, y, u=None):
        r"""One sample.

        Parameters
        ----------
        y : float
            Output y(k).
        u : float or array_like, shape (m,)
            Input(s) u(k).

        Returns
        -------
        theta : ndarray, shape (n,)
            The estimate after y(k) is used (a copy).
        yhat : float
            The one-step prediction :math:`\varphi_k^T\hat\theta_{k-1}` made
            before y(k) is used.
        """
        yv = as_float_array(y, "y").reshape(-1)
        if yv.shape != (1,):
            raise param_error("y", "one output sample (a scalar)", f"<shape {np.shape(y)}>")
        U = self._inputs(None if u is None else np.reshape(as_float_array(u, "u"), (1, -1)), 1)
        out = self._advance(yv, U)
        return self.theta, float(out[1][0])

    def run(self, y, u=None):
        """A record in one compiled pass: equal bit for bit to one :meth:`step` per sample.

        Parameters
        ----------
        y : array_like, shape (N,); pandas; IDData; tuple ``(y, u)``; DataFrame
            The output, or the whole record (the input convention of
            :func:`adaptid.models._iddata.as_signals`); an IDData or a
            pandas record indexed by time sets ``dt``.
        u : array_like, shape (N,) or (N, m), optional

        Returns
        -------
        RecursiveIVResult
            ``theta`` (N, n), ``yhat``, ``x``, ``instruments``, ``status``.
        """
        from .._iddata import as_signals

        yy, uu, data = as_signals(y, u)
        if getattr(data, "n_experiments", 1) > 1:  # the instrument simulation would run across
            raise param_error("y", "one experiment (run each: data.experiment(k))",
                              f"<a merged record of {data.n_experiments} experiments>")
        yy = as_float_array(yy, "y", ndim=1)
        U = self._inputs(uu, yy.shape[0])
        theta, yhat, x, Z, status = self._advance(yy, U)
        if data is not None and getattr(data, "dt", None) is not None:
            self.dt = float(data.dt)
        return RecursiveIVResult(theta=theta, yhat=yhat, names=self.names, x=x,
                                 instruments=Z, status=status)

    def to_model(self):
        r"""The :class:`~adaptid.models.ARX` with the current θ and the IV covariance.

        ``cov`` is :math:`\hat\sigma^2P_kS_kP_k^T` (see the class), with
        ``noise_variance`` σ̂²; both None before more than n samples were
        used, and ``cov`` None while :attr:`regular` is False. ``method``
        is ``"riv"``.
        """
        import copy

        model = copy.deepcopy(self._model)
        model.dt = self.dt
        model.theta = self.theta
        model.names = self.names
        model.method = "riv"
        model.cov = model.noise_variance = None
        n, th = self.n_params, self._theta
        weight = self._acc[1]
        if self.n_updates > n and weight > n:
            ssr = self._acc[0] - 2.0 * th @ self._sfy + th @ self._Sff @ th
            sigma2 = max(float(ssr), 0.0) / (weight - n)
            model.noise_variance = sigma2
            if self.regular:
                model.cov = sigma2 * (self._P @ self._S @ self._P.T)
        return model

    # ---------------------------------------------------- state files
    _STATE_FILE_ARRAYS = {k: k for k in ("P", "P0", "S", "Sff", "sfy", "acc", "ybuf", "xbuf",
                                         "ubuf")}

    def get_state(self) -> dict:
        """Everything needed to resume exactly (plain values, float64 arrays); θ and θ₀
        travel as the state of a core :class:`~adaptid.LMS` (the file container's core)."""
        from ...estimators._factory import estimator

        core = estimator("lms", self.n_params, theta0=self.theta0, step=1.0)
        inner = core.get_state()
        inner["state"] = self._theta.copy()
        inner["n_updates"] = self.n_updates
        o = {"na": self.na, "nb": list(self.nb), "nk": list(self.nk), "single": self._single,
             "forgetting": self.forgetting, "warmup": self.warmup, "dt": self.dt,
             "count": self._count, "flags": list(self._flags)}
        return {"estimator": self._kind, "format": self._STATE_FORMAT,
                # the file container bounds each side of the own arrays by this
                "n_params": max(self.n_params, self.na, self._Lu, self._m, self._acc.size),
                "options": o, "inner": inner, "P": self._P.copy(), "P0": self.P0.copy(),
                "S": self._S.copy(), "Sff": self._Sff.copy(), "sfy": self._sfy.reshape(1, -1),
                "acc": self._acc.reshape(1, -1), "ybuf": self._ybuf.reshape(1, -1),
                "xbuf": self._xbuf.reshape(1, -1), "ubuf": self._ubuf.copy()}

    @classmethod
    def from_state(cls, state: dict):
        """Rebuild from :meth:`get_state`'s dict (exact round trip)."""
        return _restore(cls, state)

    def __repr__(self):
        return (f"RecursiveIV(na={self.na}, nb={self.nb}, nk={self.nk}, forgetting="
                f"{self.forgetting}, warmup={self.warmup}, n_updates={self.n_updates})")


def _restore(cls, state):
    """:meth:`RecursiveIV.from_state`: check the dict, rebuild, put the arrays back."""
    from ...estimators._statefile import estimator_from_state

    cls._check_state(state)
    try:
        o = dict(state["options"])
        inner = estimator_from_state(state["inner"])
        nb = o["nb"][0] if o["single"] else o["nb"]
        nk = o["nk"][0] if o["single"] else o["nk"]
        obj = cls(o["na"], nb, nk, P0=np.asarray(state["P0"], dtype=np.float64),
                  theta0=np.asarray(inner.theta0, dtype=np.float64).reshape(-1),
                  forgetting=o["forgetting"], warmup=o["warmup"], dt=o["dt"])
        arrays = {k: np.array(state[k], dtype=np.float64) for k in cls._STATE_FILE_ARRAYS}
        count, flags = o["count"], o["flags"]
    except KeyError as err:
        raise param_error("state", "a complete dict from get_state()",
                          f"<missing key {err.args[0]!r}>") from None
    mine = {"P": obj._P, "S": obj._S, "Sff": obj._Sff, "sfy": obj._sfy, "acc": obj._acc,
            "ybuf": obj._ybuf, "xbuf": obj._xbuf, "ubuf": obj._ubuf}
    for key, like in mine.items():
        a = arrays[key].reshape(like.shape) if arrays[key].size == like.size else arrays[key]
        if a.shape != like.shape or not np.isfinite(a).all():
            raise param_error(f"state[{key!r}]", f"finite, of shape {like.shape}",
                              f"<shape {arrays[key].shape}>")
        mine[key] = a
    if abs(mine["acc"][2]) != 1.0:
        raise param_error("state['acc'][2]", "the sign of det R (1.0 or -1.0)", mine["acc"][2])
    theta = np.asarray(inner.theta, dtype=np.float64).reshape(-1)
    if theta.shape != (obj.n_params,):
        raise param_error("state['inner']", f"an estimate of {obj.n_params} parameters",
                          f"<{theta.size} parameters>")
    if (type(count) is not int or count < 0 or not isinstance(flags, list) or len(flags) != 2
            or any(type(f) is not int or f < 0 for f in flags)):
        raise param_error("state['options']", "'count' and 'flags' counts >= 0",
                          f"<{count!r}, {flags!r}>")
    (obj._P, obj._S, obj._Sff, obj._sfy, obj._acc, obj._ybuf, obj._xbuf,
     obj._ubuf) = mine.values()
    obj._theta, obj._count, obj._flags = theta.copy(), count, list(flags)
    return obj
