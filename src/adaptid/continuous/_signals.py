r"""Signals and weightings of the continuous TLSM algorithms, validated once.

A signal is either a callable of time or an array of samples held constant
(zero-order hold) between the instants of a grid. Both are turned into one
callable form here, together with the instants where the signal may jump
(the integrator restarts there).

A weighting is one of Yamamoto's (1991) four cases, eqs. 13–31:

====  ====================================  ==========  ==========================
alg.  f(t, s)                               h(t)        f(t, t − tₙ)
====  ====================================  ==========  ==========================
1     user callable                         user        f(t, t − tₙ)
2     1                                     0           1
3     exp(−α(t − s))                        −α          exp(−α tₙ)
4     λ₂(s) exp(−∫ₛᵗ λ₁)                    −λ₁(t)      λ₂(t − tₙ) exp(−ℓ(t))
====  ====================================  ==========  ==========================

with :math:`\ell(t) = \int_{t-t_n}^t \lambda_1` carried as an extra state by
the integrator (algorithm 4 only).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import integrate as _spi

from .._validation import as_float_array, check_int, check_scalar, param_error

__all__ = [
    "Signal",
    "ScalarFunction",
    "Weighting",
    "as_signal",
    "as_scalar_function",
    "check_algorithm",
    "make_weighting",
]


class Signal:
    """A vector (or scalar) signal of time with its known jump instants.

    Parameters
    ----------
    fn : callable
        ``fn(t) -> ndarray`` of shape ``shape``.
    shape : tuple
        ``(n,)`` for a regressor, ``()`` for an output.
    breakpoints : ndarray, shape (K,)
        Instants where the signal may jump (empty for a smooth callable).
    held : bool
        True for samples held on a grid.
    """

    __slots__ = ("fn", "shape", "breakpoints", "held")

    def __init__(self, fn, shape, breakpoints=(), held=False):
        self.fn = fn
        self.shape = shape
        self.breakpoints = np.asarray(breakpoints, dtype=float)
        self.held = held

    def __call__(self, t):
        return self.fn(t)


class ScalarFunction(Signal):
    """A scalar function of time (a weighting's λ₁, λ₂ or h)."""


def _held(values, grid):
    """Zero-order hold of ``values[k]`` on ``[grid[k], grid[k+1])``.

    Before ``grid[0]`` the first value is held, after ``grid[-1]`` the last.
    """
    last = values.shape[0] - 1

    def fn(t):
        k = int(np.searchsorted(grid, t, side="right")) - 1
        return values[min(max(k, 0), last)]

    return fn


def as_signal(x, name, *, grid, shape, n_desc=None):
    """Validate a signal: a callable of t, or samples held on ``grid``.

    Parameters
    ----------
    x : callable or array_like, shape (len(grid),) + shape
    name : str
    grid : ndarray, shape (K,)
        Sample instants of an array signal (``t_eval`` for the integrator).
    shape : tuple
        ``(n,)`` or ``()``.
    n_desc : str, optional
        How to describe the expected shape in messages.
    """
    want = n_desc or ("a scalar" if shape == () else f"shape {shape}")
    if callable(x):
        t_probe = float(grid[0])
        try:
            probe = np.asarray(x(t_probe), dtype=float)
        except (TypeError, ValueError) as err:
            raise param_error(name, f"a callable of t returning {want} of real numbers",
                              f"<a callable that failed at t={t_probe:g}: {err}>") from err
        if probe.shape != shape and not (shape == () and probe.shape == (1,)):
            raise param_error(name, f"a callable of t returning {want}",
                              f"<a callable returning shape {probe.shape}>")
        if not np.isfinite(probe).all():
            raise param_error(name, "a callable returning finite values",
                              f"<non-finite values at t={t_probe:g}>")
        if shape == ():
            def fn(t, _x=x):
                return float(np.asarray(_x(t), dtype=float).reshape(()))
        else:
            def fn(t, _x=x):
                return np.asarray(_x(t), dtype=float)
        return Signal(fn, shape, (), held=False)
    N = grid.shape[0]
    arr = as_float_array(x, name, shape=(N,) + tuple(shape))
    if shape == ():
        vals = [float(a) for a in arr]
        base = _held(np.arange(N), grid)

        def fn(t, _v=vals, _b=base):
            return _v[_b(t)]
        return Signal(fn, shape, grid, held=True)
    return Signal(_held(arr, grid), shape, grid, held=True)


def as_scalar_function(x, name, *, grid, low=None, what=""):
    """A weighting parameter: a real scalar, a callable of t, or samples on ``grid``."""
    if callable(x):
        sig = as_signal(x, name, grid=grid, shape=())
        return ScalarFunction(sig.fn, (), (), held=False)
    if np.ndim(x) == 0:
        c = check_scalar(x, name, low=low)
        return ScalarFunction(lambda t, _c=c: _c, (), (), held=False)
    sig = as_signal(x, name, grid=grid, shape=(), n_desc=f"a scalar, a callable, or an array "
                    f"of shape ({grid.shape[0]},){what}")
    if low is not None:
        arr = np.asarray(x, dtype=float)
        if (arr < low).any():
            raise param_error(name, f"made of values >= {low}", f"<minimum {arr.min():.6g}>")
    return ScalarFunction(sig.fn, (), grid, held=True)


def check_algorithm(algorithm) -> int:
    """Algorithm number 1..4 (``t_n=None`` selects the primed variants)."""
    a = check_int(algorithm, "algorithm")
    if a not in (1, 2, 3, 4):
        raise param_error("algorithm", "one of 1, 2, 3, 4 (t_n=None gives 1'–4')", algorithm)
    return a


class Weighting:
    r"""The weight f(t, s) of one of algorithms 1–4, evaluated where the ODE needs it.

    Methods give :math:`f(t, t)` (``f_now``), :math:`h(t)` (``h``) and the
    weight :math:`f(t, t - t_n)` of the sample leaving the window
    (``f_leaving``, which for algorithm 4 needs
    :math:`\ell(t) = \int_{t-t_n}^t \lambda_1`). ``f_full(t, s)`` is the
    weight at any pair of times (algorithm 4 integrates λ₁ by quadrature
    there; used only off the integrator's hot path).
    """

    def __init__(self, algorithm, *, alpha=None, lambda1=None, lambda2=None, f=None, h=None,
                 t_n=None, breakpoints=()):
        self.algorithm = algorithm
        self.alpha = alpha
        self.lambda1 = lambda1
        self.lambda2 = lambda2
        self.f = f
        self.h_fn = h
        self.t_n = t_n
        self.uses_ell = algorithm == 4
        self._points = np.asarray(breakpoints, dtype=float)
        if algorithm == 3:
            self._leave = math.exp(-alpha * t_n) if t_n is not None else 0.0

    # ------------------------------------------------------------- hot path
    def f_now(self, t):
        a = self.algorithm
        if a == 2 or a == 3:
            return 1.0
        if a == 4:
            return self.lambda2(t)
        return float(self.f(t, t))

    def h(self, t):
        a = self.algorithm
        if a == 2:
            return 0.0
        if a == 3:
            return -self.alpha
        if a == 4:
            return -self.lambda1(t)
        return float(self.h_fn(t))

    def f_leaving(self, t, tau, ell):
        a = self.algorithm
        if a == 2:
            return 1.0
        if a == 3:
            return self._leave
        if a == 4:
            return self.lambda2(tau) * math.exp(-ell)
        return float(self.f(t, tau))

    # ------------------------------------------------------------ off path
    def breakpoints(self):
        """Jump instants of held weighting parameters."""
        pts = [self._points]
        for fn in (self.lambda1, self.lambda2):
            if fn is not None and fn.held:
                pts.append(fn.breakpoints)
        return np.concatenate(pts) if pts else np.empty(0)

    def int_h(self, a, b):
        r""":math:`\int_a^b h`, in closed form or by adaptive quadrature."""
        alg = self.algorithm
        if alg == 2:
            return 0.0
        if alg == 3:
            return -self.alpha * (b - a)
        fn = (lambda t: -self.lambda1(t)) if alg == 4 else (lambda t: float(self.h_fn(t)))
        return _quad(fn, a, b, self._all_points())

    def f_full(self, t, s):
        """f(t, s) for s ≤ t."""
        alg = self.algorithm
        if alg == 2:
            return 1.0
        if alg == 3:
            return math.exp(-self.alpha * (t - s))
        if alg == 4:
            return self.lambda2(s) * math.exp(self.int_h(s, t))
        return float(self.f(t, s))

    def _all_points(self):
        return np.unique(self.breakpoints())


def _quad(fn, a, b, points=()):
    """∫ₐᵇ fn to ~1e-13 relative, splitting at the given jump instants."""
    if b == a:
        return 0.0
    lo, hi = (a, b) if a < b else (b, a)
    pts = [p for p in np.asarray(points, dtype=float) if lo < p < hi]
    edges = [lo, *sorted(pts), hi]
    total = 0.0
    for u, w in zip(edges[:-1], edges[1:]):
        # a held function is constant on (u, w): evaluate inside, not at the jump
        val, _ = _spi.quad(fn, u, w, epsabs=0.0, epsrel=1e-13, limit=200)
        total += val
    return total if a < b else -total


def make_weighting(algorithm, *, alpha, lambda1, lambda2, f, h, t_n, grid, breakpoints,
                   lam_what=""):
    """Validate the weighting parameters of ``algorithm`` and build a :class:`Weighting`.

    A parameter the algorithm does not use must be None (a silent mix-up
    of, say, ``alpha`` with algorithm 4 would otherwise go unnoticed).
    """
    uses = {1: ("f", "h"), 2: (), 3: ("alpha",), 4: ("lambda1", "lambda2")}[algorithm]
    given = {"alpha": alpha, "lambda1": lambda1, "lambda2": lambda2, "f": f, "h": h}
    for name, value in given.items():
        if name not in uses and value is not None:
            users = {"alpha": "3", "lambda1": "4", "lambda2": "4", "f": "1", "h": "1"}[name]
            raise param_error(name, f"None for algorithm {algorithm} (only algorithm "
                              f"{users} uses it)", value)
        if name in uses and value is None:
            raise param_error(name, f"given for algorithm {algorithm}", value)
    if algorithm == 3:
        alpha = check_scalar(alpha, "alpha", low=0.0)
        return Weighting(3, alpha=alpha, t_n=t_n)
    if algorithm == 4:
        l1 = as_scalar_function(lambda1, "lambda1", grid=grid, what=lam_what)
        l2 = as_scalar_function(lambda2, "lambda2", grid=grid, low=0.0, what=lam_what)
        return Weighting(4, lambda1=l1, lambda2=l2, t_n=t_n, breakpoints=breakpoints)
    if algorithm == 1:
        for name, fn in (("f", f), ("h", h)):
            if not callable(fn):
                raise param_error(name, "a callable", fn, exc=TypeError)
        t0 = float(grid[0])
        try:
            f00 = float(np.asarray(f(t0, t0), dtype=float).reshape(()))
        except (TypeError, ValueError) as err:
            raise param_error("f", "a callable f(t, s) returning a real scalar",
                              f"<a callable that failed at (t, s)=({t0:g}, {t0:g}): {err}>"
                              ) from err
        if not (np.isfinite(f00) and f00 >= 0.0):
            raise param_error("f", "a callable returning finite values >= 0 (eq. 3)",
                              f"<f(t0, t0)={f00!r}>")
        hs = as_signal(h, "h", grid=grid, shape=())
        W = Weighting(1, f=f, h=hs.fn, t_n=t_n, breakpoints=breakpoints)
        _check_rate(W, grid)
        return W
    return Weighting(2, t_n=t_n)


def _check_rate(W, grid):
    r"""Check :math:`\partial f/\partial t = h f` (eq. 3) on one interval.

    ``f(t₁, s) = f(t₀, s) exp(∫_{t₀}^{t₁} h)`` must hold for s = t₀; a
    mismatch beyond 1e-6 means ``h`` is not the rate of ``f`` and every
    result would be silently wrong.
    """
    t0 = float(grid[0])
    t1 = t0 + 0.5 * max(float(grid[-1] - grid[0]), 1e-3)
    f0 = W.f_full(t0, t0)
    f1 = W.f_full(t1, t0)
    if f0 <= 0.0 or not np.isfinite(f1):
        return
    pred = f0 * math.exp(W.int_h(t0, t1))
    if abs(f1 - pred) > 1e-6 * max(abs(pred), abs(f1)):
        raise param_error("h", "the rate of f, ∂f/∂t = h f (Yamamoto (1991), eq. 3)",
                          f"<f(t1, t0)={f1:.6g} but f(t0, t0)·exp(∫h)={pred:.6g}>")
