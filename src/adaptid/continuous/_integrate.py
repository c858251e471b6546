r"""Continuous-time TLSM algorithms 1–4 and 1'–4' integrated as ODEs."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.linalg as sla
from scipy.integrate import solve_ivp

from .._exceptions import DefinitenessLossWarning
from .._validation import (
    as_float_array,
    check_choice,
    check_scalar,
    check_spd,
    param_error,
)
from ._result import TLSMResult
from ._signals import Signal, Weighting, as_signal, check_algorithm, make_weighting

__all__ = ["integrate"]

_METHODS = ("DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA")
#: Times closer than this (relative to the time scale of the run) are one
#: breakpoint; signals are sampled 4 such units inside each segment, so that
#: a held signal is never read on the wrong side of its jump.
_TINY = 1e-12


def integrate(v, y, t_eval, *, algorithm, t_n, theta0, Q0=None, alpha=None, lambda1=None,
              lambda2=None, f=None, h=None, past=None, breakpoints=None, rtol=1e-8,
              atol=1e-10, method="DOP853"):
    r"""Integrate a continuous TLSM adaptive law (Yamamoto (1991), algorithms 1–4, 1'–4').

    The estimate at time t minimises the truncated, weighted cost of
    eq. 2 (plus the prior term of the usual initialisation),

    .. math::

        J(t,\theta) = \int_{\max(t-t_n,\,t_d)}^{t} f(t,s)\,\{y(s)-\theta^T v(s)\}^2\,ds
          + e^{\int_{t_0}^{t}h}\,(\theta-\theta_0)^T Q_0^{-1}(\theta-\theta_0),

    with :math:`\partial f/\partial t = h f` (eq. 3), so that it obeys the
    normal equations (5) :math:`R(t)\hat\theta(t) = b(t)` and the adaptive law
    of eqs. 13–15,

    .. math::

        \dot{\hat\theta} = Q\{f(t,t)\,v\,e - f(t,t-t_n)\,v(t-t_n)\,e_n\},\qquad
        \dot Q = -hQ - Q\{f(t,t)\,vv^T - f(t,t-t_n)\,v(t-t_n)v(t-t_n)^T\}Q .

    **What is integrated, and why.** Not Q and θ, but the information
    matrix :math:`R = Q^{-1}` and the right-hand side b of the normal
    equations (eqs. 8 and 11),

    .. math::

        \dot R = hR + f(t,t)\,vv^T - f(t,t-t_n)\,v(t-t_n)v(t-t_n)^T,\qquad
        \dot b = hb + f(t,t)\,v\,y - f(t,t-t_n)\,v(t-t_n)\,y(t-t_n),

    and θ, Q are recovered at each output time from a Cholesky
    factorisation of R. Reasons: (i) these ODEs are *linear*, their exact
    solution is the decayed prior plus the window integral, so the
    integrator only approximates an integral and its error is of size
    ``rtol·|R|``; the Riccati equation (14) for Q is quadratic and stiff
    while Q is large (right after the usual initialisation Q(0) = large·I
    the time scale is 1/(vᵀQv)), and nothing in it stops Q from losing
    definiteness when the removal term dominates. (ii) Only the upper
    triangle of R is integrated, so R (and Q) are symmetric exactly, and R
    is positive definite whenever the window's information exceeds the
    integration error; this is checked by the Cholesky factorisation at
    every output (a :class:`~adaptid.DefinitenessLossWarning` and NaN rows
    otherwise). (iii) θ from the normal equations satisfies eq. 5 at every
    output to the accuracy of R and b, whereas integrating eq. 13 lets an
    error in θ persist: :math:`\tfrac{d}{dt}(R\theta - b) = h(R\theta-b)`,
    which does not decay when h = 0. A Cholesky factor of R as the state
    would keep definiteness only as long as its diagonal stays non-zero, at
    the price of a nonlinear ODE — no gain over the linear one. Algorithm 4
    carries one more state, :math:`\ell(t) = \int_{t-t_n}^t \lambda_1`
    (:math:`\dot\ell = \lambda_1(t) - \lambda_1(t-t_n)`), for the weight
    :math:`f(t,t-t_n) = \lambda_2(t-t_n)e^{-\ell}` of eq. 28.

    The integrator restarts at every breakpoint: the given ``breakpoints``,
    the same instants shifted by ``t_n`` (where the delayed signals jump),
    the sample instants of array signals (and shifted by ``t_n``), and
    ``t0 + t_n``. Between restarts the signals are smooth, and they are read
    strictly inside each segment, so held signals are integrated exactly to
    the tolerance (for algorithm 2 the solution is affine on each hold
    interval and Runge–Kutta steps reproduce it to rounding).

    Parameters
    ----------
    v : callable or array_like, shape (len(t_eval), n)
        Regressor v(t): a callable ``v(t) -> (n,)``, or samples held
        constant on ``[t_eval[k], t_eval[k+1])`` (zero-order hold).
    y : callable or array_like, shape (len(t_eval),)
        Output y(t), a callable returning a float or held samples.
    t_eval : array_like, shape (K,)
        Strictly increasing output times, K ≥ 2. ``t_eval[0]`` is the initial
        time t₀: row 0 of the result is the initial state.
    algorithm : {1, 2, 3, 4}
        Weighting: 1 general (``f``, ``h``), 2 ``f = 1``, 3
        ``f = exp(−α(t−s))`` (``alpha``), 4 ``f = λ₂(s) exp(−∫ₛᵗ λ₁)``
        (``lambda1``, ``lambda2``); eqs. 13–15, 19–20, 23–24, 27–29.
    t_n : float or None
        Window length tₙ > 0. None gives algorithms 1'–4' (tₙ → ∞, no
        removal term; eqs. 16–18, 21–22, 25–26, 30–31).
    theta0 : array_like, shape (n,)
        Initial estimate θ₀ (it fixes n).
    Q0 : float or array_like, shape (n, n), optional
        Usual initialisation Q(t₀) = Q₀ (a scalar c means c·I), SPD. The
        prior term then decays as :math:`e^{\int h}`. Required unless
        ``past`` is given; must be None if it is.
    alpha : float, optional
        α ≥ 0 of algorithm 3.
    lambda1, lambda2 : float, callable or array_like, shape (len(t_eval),), optional
        λ₁(t) and λ₂(t) ≥ 0 of algorithm 4: constants, callables of t, or
        samples held like the signals (before ``t_eval[0]`` the first
        sample is held).
    f : callable, optional
        Algorithm 1: ``f(t, s) -> float`` ≥ 0 for s ≤ t.
    h : callable, optional
        Algorithm 1: ``h(t) -> float`` with ∂f/∂t = h f (eq. 3; checked once
        by quadrature, ValueError if violated).
    past : callable or array_like, shape (m, n), optional
        Exact initialisation (eq. 32): the regressor on
        :math:`[t_0 - t_n, t_0)` — a callable, or m samples held on m equal
        sub-intervals. As in the paper, the past outputs are taken
        consistent with θ₀, :math:`y(s) = \theta_0^T v(s)`, so that
        :math:`\hat\theta(t_0) = \theta_0` and
        :math:`Q(t_0)^{-1} = \int_{t_0-t_n}^{t_0} f(t_0,s)vv^T ds`, which must
        be non-singular. There is no prior term then: with noise-free data
        the estimate is exact tₙ after any abrupt change.
    breakpoints : array_like, shape (B,), optional
        Instants where v, y or the weighting parameters jump (for callables;
        array signals bring their own).
    rtol, atol : float
        Tolerances of :func:`scipy.integrate.solve_ivp`, applied to the
        entries of R and b (and ℓ). ``atol`` should be well below the
        smallest eigenvalue of R that matters (e.g. of :math:`Q_0^{-1}`).
    method : str
        Integration method of :func:`scipy.integrate.solve_ivp` (default
        ``"DOP853"``, an explicit 8th-order Runge–Kutta method: R's ODE is
        not stiff unless h is large and negative).

    Returns
    -------
    TLSMResult
        ``.t`` (K,) = t_eval, ``.theta`` (K, n), ``.Q`` (K, n, n);
        ``.info`` holds ``nfev`` and ``n_segments``.

    Raises
    ------
    ValueError
        For bad arguments (naming the argument), or a singular initial
        matrix from ``past``.
    RuntimeError
        If the integrator fails.

    Notes
    -----
    Sampled at :math:`t_k = t_0 + kT` with held signals and :math:`t_n = MT`,
    the result coincides with the discrete algorithm of the same weighting
    (see :mod:`adaptid.continuous` for the derivation and
    :func:`~adaptid.continuous.discretize`): ``theta[k]`` equals the
    recursive estimate after k samples.

    References
    ----------
    .. [1] T. Yamamoto, "Continuous and discrete time adaptive algorithms by
       the truncated least squares method (TLSM)", 1991, eqs. 2–32.

    Examples
    --------
    Algorithm 2 with noise-free data and the exact initialisation recovers
    θ exactly tₙ after the start:

    >>> import numpy as np
    >>> from adaptid.continuous import integrate
    >>> v = lambda t: np.array([1.0, np.sin(3 * t)])
    >>> y = lambda t: v(t) @ [2.0, -1.0]
    >>> res = integrate(v, y, [0.0, 0.5, 1.0], algorithm=2, t_n=1.0,
    ...                 theta0=[0.0, 0.0], past=v, rtol=1e-10, atol=1e-12)
    >>> bool(np.allclose(res.theta[-1], [2.0, -1.0], atol=1e-8))
    True
    """
    p = _validate(v, y, t_eval, algorithm=algorithm, t_n=t_n, theta0=theta0, Q0=Q0,
                  alpha=alpha, lambda1=lambda1, lambda2=lambda2, f=f, h=h, past=past,
                  breakpoints=breakpoints, rtol=rtol, atol=atol, method=method)
    lay = _Layout.of(p.n, p.W.uses_ell)
    solver = _SegmentSolver(p, lay)
    z, Q_init = _initial_state(p, lay, solver)
    Z = _main_phase(p, solver, z)
    theta, Q = _solve_outputs(Z, p.n, lay.m, lay.iu0, lay.iu1)
    theta[0], Q[0] = p.theta0, Q_init
    return TLSMResult(t=p.t_eval.copy(), theta=theta, Q=Q,
                      info={"kind": f"continuous algorithm {p.alg}{'' if p.windowed else chr(39)}",
                            "nfev": solver.nfev, "n_segments": solver.n_seg,
                            "initialisation": "exact (eq. 32)" if p.ps is not None else "usual"})


# ------------------------------------------------------------------ validation

@dataclass(frozen=True, eq=False)
class _Problem:
    """The validated arguments of :func:`integrate` and the quantities derived from them."""

    alg: int
    t_eval: np.ndarray
    t_n: float | None
    theta0: np.ndarray
    n: int
    rtol: float
    atol: float
    method: str
    vs: Signal                 # v(t)
    ys: Signal                 # y(t)
    bps: np.ndarray            # the user's breakpoints
    W: Weighting
    ps: Signal | None          # the past regressor of eq. 32, or None (usual initialisation)
    past_y: Callable[[float], float] | None  # y on [t0 - t_n, t0) consistent with theta0
    Q0: np.ndarray | None
    t0: float
    t_end: float
    t_d: float                 # where the data begin
    tiny: float                # times closer than this are one breakpoint

    @property
    def windowed(self):
        return self.t_n is not None


def _validate(v, y, t_eval, *, algorithm, t_n, theta0, Q0, alpha, lambda1, lambda2, f, h, past,
              breakpoints, rtol, atol, method) -> _Problem:
    """Check every argument (in the order the checks always ran) and derive the set-up."""
    alg = check_algorithm(algorithm)
    t_eval = _check_t_eval(t_eval)
    if t_n is not None:
        t_n = check_scalar(t_n, "t_n", low=0.0, low_open=True)
    theta0 = as_float_array(theta0, "theta0", ndim=1, copy=True)
    n = theta0.shape[0]
    if n < 1:
        raise param_error("theta0", "of length n >= 1", theta0)
    rtol = check_scalar(rtol, "rtol", low=0.0, high=1.0, low_open=True, high_open=True)
    atol = check_scalar(atol, "atol", low=0.0, low_open=True)
    method = check_choice(method, "method", _METHODS)
    vs = as_signal(v, "v", grid=t_eval, shape=(n,), n_desc=f"shape (n,) with n=len(theta0)={n}")
    ys = as_signal(y, "y", grid=t_eval, shape=())
    if breakpoints is None:
        bps = np.empty(0)
    else:
        bps = as_float_array(breakpoints, "breakpoints", ndim=1)
    W = make_weighting(alg, alpha=alpha, lambda1=lambda1, lambda2=lambda2, f=f, h=h, t_n=t_n,
                       grid=t_eval, breakpoints=bps)
    t0, t_end = float(t_eval[0]), float(t_eval[-1])
    ps, Q0 = _check_initialisation(past, Q0, n, t0, t_n)
    t_d = t0 - t_n if ps is not None else t0          # where the data begin
    scale = max(abs(t_d), abs(t_end), t_end - t_d)
    return _Problem(alg=alg, t_eval=t_eval, t_n=t_n, theta0=theta0, n=n, rtol=rtol, atol=atol,
                    method=method, vs=vs, ys=ys, bps=bps, W=W, ps=ps,
                    past_y=_consistent_past_output(theta0, ps), Q0=Q0, t0=t0, t_end=t_end,
                    t_d=t_d, tiny=_TINY * scale)


def _check_t_eval(t_eval):
    """Output times: a strictly increasing float vector of at least 2 entries."""
    t_eval = as_float_array(t_eval, "t_eval", ndim=1)
    if t_eval.shape[0] < 2:
        raise param_error("t_eval", "strictly increasing with at least 2 entries", t_eval)
    if np.any(np.diff(t_eval) <= 0.0):
        i = int(np.flatnonzero(np.diff(t_eval) <= 0.0)[0])
        raise param_error("t_eval", "strictly increasing with at least 2 entries",
                          f"<t_eval[{i + 1}]={t_eval[i + 1]!r} after t_eval[{i}]={t_eval[i]!r}>")
    return t_eval


def _check_initialisation(past, Q0, n, t0, t_n):
    """The exact (``past``, eq. 32) or the usual (``Q0``) initialisation: exactly one of them."""
    if past is not None:
        if t_n is None:
            raise param_error("past", "None when t_n is None (algorithms 1'–4' have no "
                              "window to initialise, eq. 32)", "<a past signal>")
        if Q0 is not None:
            raise param_error("Q0", "None when past is given (eq. 32 fixes Q(t0) from the "
                              "past data)", Q0)
        return _past_signal(past, n, t0, t_n), None
    if Q0 is None:
        raise param_error("Q0", "given (a positive scalar or an SPD matrix) unless past "
                          "is given", Q0)
    return None, check_spd(Q0, "Q0", n)


def _past_signal(past, n, t0, t_n) -> Signal:
    """The regressor on [t0 − tn, t0): a callable, or m samples on m equal sub-intervals."""
    if callable(past):
        return as_signal(past, "past", grid=np.array([t0 - t_n]), shape=(n,),
                         n_desc=f"shape (n,) with n={n}")
    arr = as_float_array(past, "past", ndim=2)
    if arr.shape[0] < 1 or arr.shape[1] != n:
        raise param_error("past", f"a callable or an array of shape (m, {n})",
                          f"<shape {arr.shape}>")
    grid = t0 - t_n + t_n * np.arange(arr.shape[0]) / arr.shape[0]
    return as_signal(arr, "past", grid=grid, shape=(n,))


def _consistent_past_output(theta0, ps):
    """The past output of eq. 32, y(s) = θ₀ᵀ v(s) on [t0 − tn, t0) (None without ``past``)."""
    if ps is None:
        return None

    def past_y(t):
        return float(theta0 @ ps(t))

    return past_y


# --------------------------------------------------- the ODE of R and b, solved

class _Layout(NamedTuple):
    """The integrated state z = [upper triangle of R (m) | b (n) | ℓ (algorithm 4 only)]."""

    n: int
    m: int
    iu0: np.ndarray
    iu1: np.ndarray
    ell: bool
    size: int

    @classmethod
    def of(cls, n, ell):
        iu0, iu1 = np.triu_indices(n)
        m = iu0.shape[0]
        return cls(n, m, iu0, iu1, ell, m + n + (1 if ell else 0))


def _make_rhs(lay, W, t_n, tiny, a, b, cur_v, cur_y, remove, del_v, del_y):
    """Right-hand side of the R, b (and ℓ) ODE on the segment [a, b] (eqs. 8, 11).

    The signals are read strictly inside the segment (4·tiny from its ends),
    so that a held signal is never read on the wrong side of its jump.
    ``remove`` adds the removal term of the sample leaving the window,
    read from ``del_v``, ``del_y`` at t − tₙ.
    """
    if b - a > 8.0 * tiny:
        lo_c, hi_c = a + 4.0 * tiny, b - 4.0 * tiny
    else:
        lo_c = hi_c = 0.5 * (a + b)
    f_now, h_of, f_leaving = W.f_now, W.h, W.f_leaving
    l1 = W.lambda1
    n, m, iu0, iu1, ell, size = lay

    def rhs(t, z):
        tc = lo_c if t < lo_c else (hi_c if t > hi_c else t)
        vv = cur_v(tc)
        fw = f_now(tc)
        hh = h_of(tc)
        dz = np.empty(size)
        dz[:m] = hh * z[:m] + fw * (vv[iu0] * vv[iu1])
        dz[m:m + n] = hh * z[m:m + n] + (fw * cur_y(tc)) * vv
        if remove:
            tau = tc - t_n
            vn = del_v(tau)
            fl = f_leaving(tc, tau, z[-1] if ell else 0.0)
            dz[:m] -= fl * (vn[iu0] * vn[iu1])
            dz[m:m + n] -= (fl * del_y(tau)) * vn
        if ell:
            dz[-1] = l1(tc) - (l1(tc - t_n) if remove else 0.0)
        return dz

    return rhs


class _SegmentSolver:
    """:func:`scipy.integrate.solve_ivp` from one restart to the next, counting the work."""

    def __init__(self, p: _Problem, lay: _Layout):
        self.p = p
        self.lay = lay
        self.nfev = 0
        self.n_seg = 0

    def advance(self, z, a, b, cur_v, cur_y, remove, del_v, del_y, t_out):
        """State at b from z at a, and the states at the times ``t_out`` inside (a, b)."""
        p = self.p
        rhs = _make_rhs(self.lay, p.W, p.t_n, p.tiny, a, b, cur_v, cur_y, remove, del_v, del_y)
        sol = solve_ivp(rhs, (a, b), z, method=p.method, rtol=p.rtol, atol=p.atol,
                        dense_output=t_out.shape[0] > 0)
        self.nfev += sol.nfev
        self.n_seg += 1
        if sol.status != 0:
            raise RuntimeError(f"integrate: solve_ivp failed on [{a:.10g}, {b:.10g}]: "
                               f"{sol.message}")
        z_end = sol.y[:, -1].copy()
        if not np.isfinite(z_end).all():
            raise param_error("v, y and the weighting", f"finite on [{a:.10g}, {b:.10g}]",
                              "<non-finite values in the integrated R, b>")
        inner = sol.sol(t_out).T if t_out.shape[0] else np.empty((0, self.lay.size))
        return z_end, inner


# ------------------------------------------------------------- initial state

def _initial_state(p: _Problem, lay: _Layout, solver: _SegmentSolver):
    """The state z at t0 and Q(t0): from ``past`` (eq. 32) or from ``Q0``."""
    n, m, iu0, iu1 = lay.n, lay.m, lay.iu0, lay.iu1
    z = np.zeros(lay.size)
    if p.ps is None:
        R_init = sla.cho_solve(sla.cho_factor(p.Q0), np.eye(n))
        R_init = 0.5 * (R_init + R_init.T)
        z[:m] = R_init[iu0, iu1]
        z[m:m + n] = R_init @ p.theta0
        return z, p.Q0
    # eq. 32: R(t0) = ∫_{t0−tn}^{t0} f(t0, s) v vᵀ ds, as the solution at t0
    # of the growing-window ODE started from R = 0 at t0 − tn.
    pts = [p.bps, p.W.breakpoints(), p.ps.breakpoints]
    ends = _segment_ends(p.t_d, p.t0, pts, p.tiny)
    for a, b in zip(ends[:-1], ends[1:]):
        z, _ = solver.advance(z, a, b, p.ps, p.past_y, False, None, None, np.empty(0))
    R_init = _unpack(z[:m], n, iu0, iu1)
    try:
        c = sla.cho_factor(R_init)
    except np.linalg.LinAlgError:
        raise param_error("past", "a regressor on [t0 - t_n, t0) that makes Q(t0)^-1 of "
                          "eq. 32 non-singular", "<a singular initial information "
                          "matrix>") from None
    z[m:m + n] = R_init @ p.theta0
    Q_init = sla.cho_solve(c, np.eye(n))
    return z, 0.5 * (Q_init + Q_init.T)


# ---------------------------------------------------------------- main phase

def _segment_ends(lo, hi, point_sets, tiny):
    """Sorted restart instants in [lo, hi]; points closer than `tiny` are one."""
    pts = np.concatenate([np.asarray(p, dtype=float).ravel() for p in point_sets]) \
        if point_sets else np.empty(0)
    pts = np.sort(pts[(pts > lo + tiny) & (pts < hi - tiny)])
    ends = [lo]
    for p in pts:
        if p - ends[-1] > tiny:
            ends.append(float(p))
    ends.append(hi)
    return np.asarray(ends)


def _main_segment_ends(p: _Problem):
    """Restart instants in [t0, t_end]: every jump of the signals, and shifted by tₙ."""
    pts = [p.bps, p.W.breakpoints(), p.vs.breakpoints, p.ys.breakpoints]
    if p.windowed:
        t_n = p.t_n
        pts += [p.bps + t_n, p.W.breakpoints() + t_n, p.vs.breakpoints + t_n,
                p.ys.breakpoints + t_n, np.array([p.t0 + t_n])]
        if p.ps is not None:
            pts.append(p.ps.breakpoints + t_n)
    return _segment_ends(p.t0, p.t_end, pts, p.tiny)


def _output_slots(ends, t_eval, tiny):
    """For each output time: its segment, and the index of the segment end it sits on (or −1).

    Each output time is either (within ``tiny`` of) a segment end or inside one segment.
    """
    seg_of = np.searchsorted(ends, t_eval, side="right") - 1
    right = np.minimum(seg_of + 1, ends.shape[0] - 1)
    near_left = np.abs(t_eval - ends[seg_of]) <= tiny
    near_right = np.abs(ends[right] - t_eval) <= tiny
    end_idx = np.where(near_left, seg_of, np.where(near_right, right, -1))
    return seg_of, end_idx


def _main_phase(p: _Problem, solver: _SegmentSolver, z):
    """Integrate from t0 to t_end, segment by segment; the state z at every output time."""
    ends = _main_segment_ends(p)
    seg_of, end_idx = _output_slots(ends, p.t_eval, p.tiny)
    at_end = end_idx >= 0
    Z = np.empty((p.t_eval.shape[0], solver.lay.size))
    Z[0] = z
    for j, (a, b) in enumerate(zip(ends[:-1], ends[1:])):
        inside = np.flatnonzero((seg_of == j) & ~at_end)
        mid = 0.5 * (a + b)
        remove = p.windowed and (mid - p.t_n > p.t_d)
        if remove and p.ps is not None and mid - p.t_n < p.t0:
            del_v, del_y = p.ps, p.past_y
        else:
            del_v, del_y = p.vs, p.ys
        z, inner = solver.advance(z, a, b, p.vs, p.ys, remove, del_v, del_y, p.t_eval[inside])
        Z[inside] = inner
        Z[at_end & (end_idx == j + 1)] = z
    return Z


# ------------------------------------------------------------- result assembly

def _unpack(r, n, iu0, iu1):
    R = np.zeros((n, n))
    R[iu0, iu1] = r
    R[iu1, iu0] = r
    return R


def _solve_outputs(Z, n, m, iu0, iu1):
    """θ and Q from R and b at each output (Cholesky); NaN and a warning if R is not PD."""
    K = Z.shape[0]
    theta = np.empty((K, n))
    Q = np.empty((K, n, n))
    eye = np.eye(n)
    bad = []
    for i in range(K):
        R = _unpack(Z[i, :m], n, iu0, iu1)
        try:
            c = sla.cho_factor(R)
        except np.linalg.LinAlgError:
            theta[i] = np.nan
            Q[i] = np.nan
            bad.append(i)
            continue
        theta[i] = sla.cho_solve(c, Z[i, m:m + n])
        Qi = sla.cho_solve(c, eye)
        Q[i] = 0.5 * (Qi + Qi.T)
    if bad:
        warnings.warn(
            f"integrate: R = Q⁻¹ is not positive definite at {len(bad)} output time(s) "
            f"(first: index {bad[0]}); the window does not excite every direction beyond the "
            "integration tolerance. theta and Q are NaN there.", DefinitenessLossWarning,
            stacklevel=3)
    return theta, Q
