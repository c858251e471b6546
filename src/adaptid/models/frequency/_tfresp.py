r"""Step responses, roots and random draws of a :class:`TransferFunctionModel`.

θ = [b₀ … b_{nz}, a…] as in :func:`~adaptid.models.tfest`. Discrete time:
:math:`G = q^{-n_k}\sum_jb_jq^{-j}/(1 + \sum_ja_jq^{-j})`, the step response
and its Jacobian are filters (:func:`adaptid.models.frequency._step.step_with_sd`).
Continuous time: :math:`G = e^{-s\tau}\sum_jb_js^j/(s^{n_p} + \sum_ja_js^j)`;
the Jacobian's columns are step responses of
:math:`\partial G/\partial b_j = e^{-s\tau}s^j/D` and
:math:`\partial G/\partial a_j = -e^{-s\tau}s^jN/D^2`, each computed exactly
on the time grid by the matrix exponential of its realisation.
"""

from __future__ import annotations

import numpy as np

from ..._lazy import lazy
from ._roots import roots_with_sd
from ._step import StepResponse, check_length, default_length, step_with_sd

sla = lazy("scipy.linalg")
signal = lazy("scipy.signal")

__all__ = ["tf_step", "tf_poles", "tf_zeros", "tf_rsample"]

#: points of a continuous-time step response (default)
T_CONTINUOUS = 200


def _ct_step(num, den, t, delay):
    """Step response of num/den (descending powers of s) at times t − delay (0 before)."""
    num = np.atleast_1d(np.trim_zeros(np.asarray(num, dtype=float), "f"))
    if num.size == 0:
        return np.zeros_like(t)
    A, B, C, D = signal.tf2ss(num, den)
    n = A.shape[0]
    out = np.zeros_like(t)
    tau = t - delay
    on = np.flatnonzero(tau >= 0)
    if on.size == 0:
        return out
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n:] = A, B
    z = np.zeros(n + 1)
    z[n] = 1.0                                          # the step input as a state
    z = sla.expm(M * tau[on[0]]) @ z
    h = t[1] - t[0] if t.size > 1 else 0.0
    Phi = sla.expm(M * h)
    for k in on:
        out[k] = (C @ z[:n]).item() + D.item()
        z = Phi @ z
    return out


def tf_step(model, T=None):
    """The :class:`StepResponse` of a transfer-function model (see the module docstring)."""
    cov = model.cov
    nb, na = model.b.size, model.a.size
    if model.dt is not None:
        T = default_length(model.num, model.den) if T is None else check_length(T)
        num_par = [(j, model.nk + j) for j in range(nb)]
        dens = [(model.den, [(nb + j, j + 1) for j in range(na)])]
        s, sd = step_with_sd(model.num, num_par, dens, T, cov)
        return StepResponse(np.arange(T) * model.dt, s, sd, dt=model.dt,
                            y_names=(model.y_name,), u_names=(model.u_name,))
    T = T_CONTINUOUS if T is None else check_length(T)
    p = np.roots(model.den)
    slow = np.min(np.abs(p.real)) if p.size and np.all(p.real < 0) else None
    t_end = (10.0 / slow if slow else 10.0) + model.delay
    t = np.linspace(0.0, t_end, max(T, 2))[:T]
    D = model.den
    s = _ct_step(model.num, D, t, model.delay)
    sd = None
    if cov is not None:
        J = np.empty((T, nb + na))
        for j in range(nb):
            J[:, j] = _ct_step(np.r_[1.0, np.zeros(j)], D, t, model.delay)
        D2 = np.polymul(D, D)
        for j in range(na):
            J[:, nb + j] = -_ct_step(np.polymul(np.r_[1.0, np.zeros(j)], model.num), D2, t,
                                     model.delay)
        sd = np.sqrt(np.maximum(np.einsum("ti,ij,tj->t", J, cov, J), 0.0))
    dt = t[1] - t[0] if T > 1 else 1.0
    return StepResponse(t, s, sd, dt=dt, y_names=(model.y_name,), u_names=(model.u_name,),
                        time_unit="time units")


def tf_poles(model):
    """Roots of the denominator (in s or z) with first-order standard deviations."""
    nb, na = model.b.size, model.a.size
    if model.dt is not None:      # 1 + Σ a_j z^-j: a_j at position j
        par = [(nb + j, j + 1) for j in range(na)]
    else:                          # s^na + Σ a_j s^j: a_j at position na − j
        par = [(nb + j, na - j) for j in range(na)]
    return roots_with_sd([(model.den, par)], model.cov, nb + na)


def tf_zeros(model):
    """Finite roots of the numerator (in s or z) with first-order standard deviations."""
    nb, na = model.b.size, model.a.size
    if model.dt is not None:      # Σ b_j z^-j (the delay z^-nk adds no finite zero)
        factor = (model.b, [(j, j) for j in range(nb)])
    else:                          # Σ b_j s^j, descending: b_j at position nb − 1 − j
        factor = (model.b[::-1], [(j, nb - 1 - j) for j in range(nb)])
    return roots_with_sd([factor], model.cov, nb + na)


def tf_rsample(model, n, seed=None):
    """n models with θ drawn from N(θ̂, cov) (each keeps this model's cov)."""
    rng = np.random.default_rng(seed)
    nb = model.b.size
    out = []
    for th in rng.multivariate_normal(model.theta, model.cov, size=n, method="eigh"):
        out.append(type(model)(th[:nb], th[nb:], dt=model.dt, delay=model.delay, nk=model.nk,
                               cov=model.cov, loss=model.loss, y_name=model.y_name,
                               u_name=model.u_name))
    return out
