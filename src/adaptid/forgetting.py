r"""Forgetting strategies for :class:`adaptid.RLS` (and, where they apply, the window).

With constant exponential forgetting the information matrix
:math:`R_k = P_k^{-1}` decays by λ in *every* direction at every step, but it
is replenished only in the directions the regressors excite. When excitation
disappears (a motor at constant speed, a plant held at a set point) the
unexcited part of :math:`P` grows like :math:`\lambda^{-k}`: *covariance
windup*, after which the next excitation produces a burst of gain. The
strategies here keep P bounded. Each is a small immutable object given as
``forgetting=`` and executed in the same compiled kernels as the plain
recursion (one compiled call per ``run``):

=====================  =========================================================
``Exponential(lam)``   constant λ (what a float means); bounded by ``P_max``
``Directional(lam)``   forgets only along the excited direction φ (Kulhavý 1987)
``ConstantTrace``      rescales P to a fixed trace (Goodwin & Sin 1984)
``EFRA``               exponential forgetting and resetting (Salgado et al. 1988)
``Variable``           λₖ from the prediction error (Fortescue et al. 1981)
=====================  =========================================================

and ``RLS(..., P_max=...)`` bounds P for the exponential and variable
strategies (pivot-wise conditional forgetting: each pivot :math:`D_i` of
:math:`P = UDU^T` is forgotten at λₖ until it reaches ``P_max``, so
saturated directions stop growing while the others keep forgetting) and
for the directional one (no forgetting in a step that would take a diagonal
element of P past ``P_max``).

:class:`adaptid.SlidingWindowRLS` accepts a float or :class:`Exponential`
only: removing a sample from the window needs the exact product of the
forgetting factors since it entered, which only a scalar λₖ gives.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ._validation import check_scalar, param_error

__all__ = [
    "Exponential",
    "Directional",
    "ConstantTrace",
    "EFRA",
    "Variable",
    "ForgettingStrategy",
    "from_dict",
]

# kernel modes (see adaptid._kernels.recursions._strategy._rls_strategy_stream)
_EXP, _DIR, _CT, _EFRA, _VAR = 0, 1, 2, 3, 4


def _lam(value, name="lam"):
    return check_scalar(value, name, low=0.0, high=1.0, low_open=True)


class ForgettingStrategy:
    """Base class of the strategies (immutable; compare by value)."""

    _mode = -1

    def _params(self) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    def _params_n(self, n) -> np.ndarray:
        """Kernel parameters for n parameters."""
        return self._params()

    def to_dict(self) -> dict:
        """Plain JSON-able description, inverted by :func:`from_dict`."""
        return {"strategy": type(self).__name__, **asdict(self)}


@dataclass(frozen=True)
class Exponential(ForgettingStrategy):
    r"""Constant exponential forgetting, :math:`P_k = (P_{k-1} - K_k\varphi_k^TP_{k-1})/\lambda`.

    The same as passing the float ``lam``. The cost weights sample j by
    :math:`\lambda^{k-j}`: an effective memory of :math:`1/(1-\lambda)`
    samples (Ljung & Söderström 1983, eq. 2.19). Without excitation P grows
    like :math:`\lambda^{-k}` in the unexcited directions — bound it with
    ``RLS(..., P_max=...)`` or use another strategy.

    Parameters
    ----------
    lam : float
        λ ∈ (0, 1].
    """

    lam: float = 1.0
    _mode = _EXP

    def __post_init__(self):
        object.__setattr__(self, "lam", _lam(self.lam))

    def _params(self):
        return np.array([self.lam])


@dataclass(frozen=True)
class Directional(ForgettingStrategy):
    r"""Directional forgetting: forget only in the direction the data excite.

    Kulhavý's restricted exponential forgetting: before the measurement
    update, the information :math:`R = P^{-1}` loses the part carried by
    the new regressor direction,

    .. math::

        \tilde R_{k-1} = R_{k-1} - (1-\lambda)\,
            \frac{\varphi_k\varphi_k^T}{\varphi_k^T P_{k-1}\varphi_k},\qquad
        R_k = \tilde R_{k-1} + w_k\varphi_k\varphi_k^T,

    so that :math:`\varphi_k^T\tilde P\varphi_k = \varphi_k^TP_{k-1}\varphi_k/\lambda`
    (the uncertainty along φ grows exactly as with exponential forgetting)
    while the information in every direction R-orthogonal to φ is kept. P
    does not grow in directions that are not excited. In P form this is a
    rank-one *update* of P, done as a Bierman step of weight
    :math:`-r/(1-\lambda)` on the U-D factors; it is always definite since
    :math:`1 - (1-\lambda) = \lambda > 0`. A zero regressor forgets nothing.

    Parameters
    ----------
    lam : float
        λ ∈ (0, 1].

    References
    ----------
    .. [1] R. Kulhavý, "Restricted exponential forgetting in real-time
       identification", *Automatica* 23(5), 589–600, 1987.
    .. [2] T. Hägglund, *New estimation techniques for adaptive control*,
       PhD thesis, Lund, 1983.
    """

    lam: float = 0.98
    _mode = _DIR

    def __post_init__(self):
        object.__setattr__(self, "lam", _lam(self.lam))

    def _params(self):
        return np.array([self.lam])


@dataclass(frozen=True)
class ConstantTrace(ForgettingStrategy):
    r"""Regularised constant-trace forgetting: P is rescaled to a fixed trace after each update.

    After the measurement update :math:`\bar P_k`,

    .. math::

        P_k = g_k\,\bar P_k + c_2 I,\qquad
        g_k = \min\Big(\frac{c_1}{\operatorname{tr}\bar P_k},\ \frac{1}{\lambda_{\min}}\Big),
        \qquad c_1 = (1-f)\,c,\quad c_2 = f\,c/n,

    so :math:`\operatorname{tr}P_k \le c` (equal to c unless the
    amplification is capped at :math:`1/\lambda_{\min}`) and
    :math:`P_k \succeq c_2 I`. This is the constant-trace algorithm with the
    regularising floor of Lozano-Leal & Goodwin (Goodwin & Sin 1984, §3.7.2):
    without the floor (``floor=0``) a long unexcited stretch lets one
    direction absorb the whole trace and starves the others of forgetting,
    so they cannot track a change afterwards. The reported λₖ is
    :math:`1/g_k`. P is re-factorised after the rescaling (O(n³) per sample).

    Parameters
    ----------
    lam : float
        :math:`\lambda_{\min}` ∈ (0, 1], the fastest forgetting allowed.
    trace : float
        c > 0, the trace P is held at.
    floor : float
        f ∈ [0, 1), the fraction of the trace kept as the floor c₂ I.

    References
    ----------
    .. [1] G. C. Goodwin, K. S. Sin, *Adaptive Filtering, Prediction and
       Control*, Prentice-Hall, 1984, §3.7.
    .. [2] R. Lozano-Leal, G. C. Goodwin, "A globally convergent adaptive
       pole placement algorithm without a persistency of excitation
       requirement", *IEEE Trans. Autom. Control* 30(8), 795–798, 1985.
    """

    lam: float = 0.9
    trace: float = 1.0
    floor: float = 0.01
    _mode = _CT

    def __post_init__(self):
        object.__setattr__(self, "lam", _lam(self.lam))
        object.__setattr__(self, "trace", check_scalar(self.trace, "trace", low=0.0, low_open=True))
        object.__setattr__(self, "floor", check_scalar(self.floor, "floor", low=0.0, high=1.0,
                                                       high_open=True))

    def _params_n(self, n):
        return np.array([self.lam, self.trace, (1 - self.floor) * self.trace,
                         self.floor * self.trace / n])


@dataclass(frozen=True)
class EFRA(ForgettingStrategy):
    r"""Exponential forgetting and resetting algorithm (Salgado, Goodwin & Middleton 1988).

    .. math::

        \hat\theta_k &= \hat\theta_{k-1}
            + \frac{\alpha P_{k-1}\varphi_k}{1/w_k + \varphi_k^TP_{k-1}\varphi_k}\,\varepsilon_k,\\
        P_k &= \frac{1}{\lambda}\Big(P_{k-1}
            - \frac{\alpha P_{k-1}\varphi_k\varphi_k^TP_{k-1}}{1/w_k + \varphi_k^TP_{k-1}\varphi_k}\Big)
            + \beta I - \delta P_{k-1}^2 .

    The βI term keeps P from vanishing, the −δP² term keeps it from
    growing: for 0 < α < 1, β > 0, δ > 0 and λ ∈ (0, 1) P stays between
    two multiples of I whatever the excitation (ibid., Theorem 1), provided
    P starts small enough: ``RLS`` refuses a P0 with an eigenvalue above
    :math:`(1-\alpha)/(\lambda\delta)` (past it the −δP² term makes P
    indefinite; the default P0 = 1e4 is too large — use e.g. P0=1). The
    authors' typical values are the defaults. The measurement part is a
    Bierman step; βI − δP² is added to the formed P and re-factorised
    (O(n³) per sample).

    Parameters
    ----------
    alpha : float
        Gain α ∈ (0, 1].
    beta : float
        β > 0, the floor term.
    delta : float
        δ ≥ 0, the P² term (δ = 0 drops the upper bound).
    lam : float
        λ ∈ (0, 1].

    References
    ----------
    .. [1] M. E. Salgado, G. C. Goodwin, R. H. Middleton, "Modified least
       squares algorithm incorporating exponential resetting and
       forgetting", *Int. J. Control* 47(2), 477–491, 1988.
    """

    alpha: float = 0.5
    beta: float = 0.005
    delta: float = 0.005
    lam: float = 0.95
    _mode = _EFRA

    def __post_init__(self):
        object.__setattr__(self, "alpha", check_scalar(self.alpha, "alpha", low=0.0, high=1.0, low_open=True))
        object.__setattr__(self, "beta", check_scalar(self.beta, "beta", low=0.0, low_open=True))
        object.__setattr__(self, "delta", check_scalar(self.delta, "delta", low=0.0))
        object.__setattr__(self, "lam", _lam(self.lam))

    def _params(self):
        return np.array([self.alpha, self.beta, self.delta, self.lam])


@dataclass(frozen=True)
class Variable(ForgettingStrategy):
    r"""Variable forgetting driven by the prediction error (Fortescue, Kershenbaum & Ydstie 1981).

    The factor is chosen to keep the weighted a-posteriori error sum
    constant at :math:`\Sigma_0 = \sigma_0^2 N_0`:

    .. math::

        \lambda_k = \max\Big(\lambda_{\min},\;
            1 - \frac{w_k\,\bar\varepsilon_k^2}{(1 + w_k\varphi_k^TP_{k-1}\varphi_k)\,\Sigma_0}\Big),

    :math:`\bar\varepsilon_k^2` the mean squared a-priori error over the
    outputs. Small errors (the model fits) give λ ≈ 1 (long memory), large
    ones (a change) shorten the memory. λₖ is then applied as in the
    constant-λ recursion (before the measurement update). Note that
    without excitation and with small errors λₖ → 1, so P does not wind up;
    with excitation lost *and* large errors it can — combine with ``P_max``.

    Parameters
    ----------
    lam_min : float
        Lower bound :math:`\lambda_{\min}` ∈ (0, 1].
    sigma0 : float
        Expected noise standard deviation σ₀ > 0.
    memory : float
        Asymptotic memory :math:`N_0` ≥ 1 samples (the λ of a noise-only
        stream is about :math:`1 - 1/N_0`).

    References
    ----------
    .. [1] T. R. Fortescue, L. S. Kershenbaum, B. E. Ydstie,
       "Implementation of self-tuning regulators with variable forgetting
       factors", *Automatica* 17(6), 831–835, 1981.
    """

    lam_min: float = 0.9
    sigma0: float = 1.0
    memory: float = 1000.0
    _mode = _VAR

    def __post_init__(self):
        object.__setattr__(self, "lam_min", _lam(self.lam_min, "lam_min"))
        object.__setattr__(self, "sigma0", check_scalar(self.sigma0, "sigma0", low=0.0, low_open=True))
        object.__setattr__(self, "memory", check_scalar(self.memory, "memory", low=1.0))

    def _params(self):
        return np.array([self.lam_min, self.sigma0 ** 2 * self.memory])


_CLASSES = {c.__name__: c for c in (Exponential, Directional, ConstantTrace, EFRA, Variable)}


def from_dict(spec: dict) -> ForgettingStrategy:
    """Inverse of :meth:`ForgettingStrategy.to_dict`."""
    if not isinstance(spec, dict) or spec.get("strategy") not in _CLASSES:
        raise param_error("forgetting", f"a dict naming one of {sorted(_CLASSES)}", spec)
    kw = {k: v for k, v in spec.items() if k != "strategy"}
    try:
        return _CLASSES[spec["strategy"]](**kw)
    except TypeError as err:
        raise param_error("forgetting", f"the fields of {spec['strategy']}", f"<{err}>") from None


def resolve(value, *, allow_strategies=True, owner="RLS"):
    """A float or strategy → (public value, exponential λ or None, strategy or None)."""
    if isinstance(value, ForgettingStrategy):
        if isinstance(value, Exponential):
            return value, value.lam, None
        if not allow_strategies:
            raise param_error("forgetting", f"a float or adaptid.forgetting.Exponential for {owner}",
                              f"<{type(value).__name__}>")
        return value, None, value
    if isinstance(value, dict):
        return resolve(from_dict(value), allow_strategies=allow_strategies, owner=owner)
    lam = _lam(value, "forgetting")
    return lam, lam, None

