r"""Continuous-time TLSM adaptive laws and their exact discretisation.

Yamamoto (1991), "Continuous and discrete time adaptive algorithms by the
truncated least squares method (TLSM)" (equation numbers below are the
paper's):

* :func:`integrate` — continuous algorithms 1–4 (eqs. 13–15, 19–20, 23–24,
  27–29) and 1'–4' (``t_n=None``; eqs. 16–18, 21–22, 25–26, 30–31) for given
  signals v(t), y(t), with the usual or the exact initialisation (eq. 32);
* :func:`discretize` — the exact discretisation for held signals (section 3,
  eqs. 47–74), as an estimator of the recursive core
  (:class:`~adaptid.SlidingWindowRLS`, :class:`~adaptid.RLS`), the paper's
  own recursion (eqs. 62–65) and, for comparison, the naive forward-Euler
  discretisation of dQ/dt that the paper warns against (eqs. 35–36);
* :class:`TLSMResult` — ``.t``, ``.theta``, ``.Q`` of either;
  :class:`Discretization` — what :func:`discretize` returns.

Continuous ↔ discrete: the derivation
-------------------------------------
**1. What the continuous algorithm computes.** With
:math:`\partial f/\partial t = h f` (eq. 3) the weight factorises,
:math:`f(t,s) = f(u,s)\,e^{\int_u^t h}` for :math:`s \le u \le t`. The
information matrix :math:`R = Q^{-1}` obeys eq. 11,
:math:`\dot R = hR + f(t,t)vv^T - f(t,t-t_n)v(t-t_n)v(t-t_n)^T`, whose solution
from :math:`R(t_0) = Q_0^{-1}` (usual initialisation; no data before
:math:`t_0`, so the removal term is absent until :math:`t_0 + t_n`) is, by
variation of constants and the factorisation,

.. math::

    R(t) = e^{\int_{t_0}^t h}\,Q_0^{-1}
           + \int_{\max(t_0,\,t-t_n)}^{t} f(t,s)\,v(s)v(s)^T ds ,

and the same for :math:`b(t)` with :math:`v\,y` and :math:`Q_0^{-1}\theta_0`;
:math:`\hat\theta(t) = R(t)^{-1}b(t)` (the normal equations (5) plus the
prior). This is exactly what :func:`integrate` integrates.

**2. Held signals.** Let :math:`v(s) = v_j`, :math:`y(s) = y_j` on
:math:`[t_j, t_{j+1})`, :math:`t_j = t_0 + jT`, and :math:`t_n = MT`. Over one
interval the ODE has constant data, and integrating it exactly from
:math:`t_k` to :math:`t_{k+1}` gives

.. math::

    R(t_{k+1}) = \lambda_k R(t_k) + \bar f_k\,v_kv_k^T - c_k\,v_{k-M}v_{k-M}^T,

    \lambda_k = e^{\int_{t_k}^{t_{k+1}} h},\quad
    \bar f_k = \int_{t_k}^{t_{k+1}} f(t_{k+1},s)\,ds,\quad
    c_k = \int_{t_{k-M}}^{t_{k-M+1}} f(t_{k+1},s)\,ds
        = \bar f_{k-M}\prod_{i=k-M+1}^{k}\lambda_i .

:math:`\lambda_k = f(t_{k+1},s)/f(t_k,s) = 1 + \bar h_k` is eq. 50 (with
eq. 52, :math:`\bar h = Th`), and :math:`\bar f_k` is eq. 52's
:math:`\bar f = Tf` with f integrated over the hold instead of sampled. The
integral of a held signal is the *left* sum of eq. 45: the sample taken at
:math:`t_k` has entered :math:`R` only at :math:`t_{k+1}`, so

.. math::

    R(t_k) = \Big(\prod_{i=0}^{k-1}\lambda_i\Big) Q_0^{-1}
      + \sum_{j=\max(0,k-M)}^{k-1} \bar f_j\Big(\prod_{i=j+1}^{k-1}\lambda_i\Big) v_jv_j^T .

**3. Which discrete estimate, and the prior.** The core's cost after m
samples (1-based), :math:`\sum_{j=m-M+1}^{m}(\prod_{i=j+1}^{m}\lambda_i)w_j
(y_j-\varphi_j^T\theta)^2 + (\prod_{i=1}^{m}\lambda_i)(\theta-\theta_0)^T
P_0^{-1}(\theta-\theta_0)`, is the above divided by any σ > 0 when
sample m of the core is the paper's sample :math:`k = m-1` held on
:math:`[t_{m-1}, t_m)`: :math:`\varphi_m = v_{m-1}`,
:math:`\lambda^{\rm core}_m = \lambda_{m-1}`, :math:`w_m = \bar f_{m-1}/\sigma`
and :math:`P_0 = \sigma Q_0`. Dividing a cost by σ leaves its minimiser
unchanged, so

.. math::

    \hat\theta(t_k) = \text{estimate after } k \text{ samples}
       = \texttt{Trajectory.theta[k-1]},\qquad
    Q(t_k) = P_k/\sigma,

and :math:`\hat\theta(t_0) = \theta_0`. (The paper's :math:`\theta_{k+1}`
is the estimate from data up to k, one index later than adaptid's.) The
window is the same too: the core's holds :math:`\min(m, M)` samples and the
continuous one has no data before :math:`t_0`.

**4. The weightings.** With :math:`x = \alpha T` or :math:`x_k = T\lambda_{1,k}`
and :math:`\phi(x) = (1-e^{-x})/x`:

* algorithm 2, f = 1: :math:`\lambda = 1`, :math:`\bar f = T`; σ = T gives
  unit weights and :math:`P_0 = TQ_0` (discrete algorithm 2, eqs. 69–70);
* algorithm 3, :math:`f = e^{-\alpha(t-s)}`: :math:`\lambda = e^{-\alpha T}`
  (eq. 71, with T explicit), :math:`\bar f = \int_0^T e^{-\alpha u}du
  = (1-\lambda)/\alpha = T\phi(\alpha T)`; σ = f̄ gives unit weights and
  :math:`P_0 = \tfrac{1-\lambda}{\alpha}Q_0` (→ :math:`TQ_0` as α → 0);
* algorithm 4, :math:`f = \lambda_2(s)e^{-\int_s^t\lambda_1}` with λ₁, λ₂ held
  on the grid: :math:`\lambda_k = e^{-T\lambda_{1,k}}` (eq. 74) and
  :math:`\bar f_k = \lambda_{2,k}\int_0^T e^{-\lambda_{1,k}u}du
  = T\lambda_{2,k}\phi(x_k)`. Eq. 74's :math:`\bar f_k = T\lambda_{2,k}` is the
  rectangle rule for this integral; with constant λ₁ the factor
  :math:`\phi(x)` is common to all samples and is absorbed in σ
  (:math:`P_0 = \phi(x)Q_0` with weights :math:`T\lambda_{2,k}` is exact),
  with time-varying λ₁ it must be kept. The removal weight
  :math:`c_k = \bar f_{k-M}\prod_{i=k-M+1}^{k}e^{-T\lambda_{1,i}}`
  is eq. 74's :math:`\bar f_{k-n}`.

**5. Q itself: the lemma.** Step 2 is the lemma of eqs. 40–41 in action:
the forward difference of R (eq. 56) is exact for held signals, and the
matching difference of Q is :math:`Q_{k+1} - Q_k = -\bar h_kQ_{k+1}
- Q_{k+1}\Delta_kQ_k` (eq. 59), i.e. eqs. 61 and 64–65. The naive forward
difference of eq. 14, :math:`Q_{k+1} = Q_k - \bar h_kQ_k - Q_k\Delta_kQ_k`
(eqs. 35–36), instead gives :math:`Q_{k+1}^{-1} = R_k + \Delta_k
+ \Delta_kQ_k\Delta_k + O(T^3)`: an error :math:`O(T^2)` per step, O(T)
overall. :class:`Discretization` offers both (``run_lemma``,
``run_euler``).

Misprints and readings of Yamamoto (1991)
-----------------------------------------
* eq. 61: the last f is f̄; eq. 68: :math:`d_k = 1 + \alpha_k\bar f_ks_{1k}`;
  eq. 72: "h_k = λ − 1" is :math:`\bar h_k`; eq. 74:
  :math:`h_k = (e^{-T\lambda_{1,k}}-1)/T`.
* eqs. 62/66 with 63–65/67–68: the g computed by eq. 65 (or 68) is
  :math:`(Q_k^{-1} + \alpha_kU_kC_kU_k^T)^{-1}v = \lambda_kQ_{k+1}v`, not the
  :math:`Q_{k+1}v` that eq. 63 defines; with it the θ update needs the
  factor :math:`\alpha_k` (invisible for algorithm 2, α = 1). Derived from
  the rank-two inversion lemma and checked against the core in the tests.
* eqs. 51 and 73–74 evaluate the weights at :math:`t_k` where the recursion
  (56) with :math:`\alpha_k = 1/(1+\bar h_k)` needs :math:`t_{k+1}`; read
  literally they shift λ₁'s index by one sample in the removal weight
  (:math:`\sum_{i=k-M}^{k-1}` versus the recursion's
  :math:`\sum_{i=k-M+1}^{k}`). The reading above (forgetting of sample k
  = decay over its own hold interval) is the one in which the recursion,
  the cost (49) and the continuous solution agree.
"""

from ._discretize import Discretization, discretize
from ._integrate import integrate
from ._result import TLSMResult

__all__ = [
    "Discretization",
    "TLSMResult",
    "discretize",
    "integrate",
]
