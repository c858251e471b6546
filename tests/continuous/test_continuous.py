"""Tests of adaptid.continuous: continuous TLSM laws and their exact discretisation.

Oracles (none produced by the code under test):
* the recursive core (SlidingWindowRLS, RLS), configured here from closed
  forms derived in adaptid/continuous/__init__.py (weights, forgetting,
  prior scaling): Yamamoto (1991), eqs. 49–52, 69–74;
* the normal equations (5), both sides by adaptive quadrature
  (scipy.integrate.quad_vec) of closed-form weights and signals;
* the defining property of TLSM (exact θ tₙ after a jump, eq. 32 remark)
  and a two-sided bound on the prior's effect derived below;
* for the naive Euler discretisation (eqs. 35–36), the leading term of
  its error, Σₖ ΔₖQₖΔₖ, summed here from exact closed-form Qₖ.

Tolerances: the integrator runs with rtol=1e-10, atol=1e-12. For held
signals the R, b ODE is affine (algorithm 2) or exponential (3, 4) on each
hold interval, so the integration error is ≲ 1e-10 relative and the
continuous/discrete agreement is asserted at the required 1e-7 (observed
~1e-14). Rounding-level comparisons of two exact recursions use 1e-10
(condition numbers here ≲ 1e2, a few hundred steps: ≲ 1e4·eps observed).
"""

import math

import numpy as np
import pytest
from scipy.integrate import quad_vec

import adaptid
import adaptid.continuous as ac
from adaptid import RLS, DefinitenessLossWarning, SlidingWindowRLS
from adaptid.continuous import TLSMResult, discretize, integrate

RTOL, ATOL = 1e-10, 1e-12


def rel_err(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b)))


def core_history(est, V, Y, weights=None, forgetting=None):
    """θ and P after each sample from the core's own `update` (P is not in Trajectory)."""
    th, P = [], []
    for k in range(V.shape[0]):
        kw = {}
        if weights is not None:
            kw["weight"] = float(weights[k])
        if forgetting is not None:
            kw["forgetting"] = float(forgetting[k])
        est.update(V[k], float(Y[k]), **kw)
        th.append(est.theta)
        P.append(est.P)
    return np.array(th), np.array(P)


# --------------------------------------------------------------- public API

def test_public_names_and_no_leaks():
    assert set(ac.__all__) == {"Discretization", "TLSMResult", "discretize", "integrate"}
    for name in ac.__all__:
        assert hasattr(ac, name)
    public = {n for n in dir(ac) if not n.startswith("_")}
    assert public <= set(ac.__all__)
    assert adaptid.continuous is ac


# ----------------------------------------------- sampled data: equals the core

@pytest.fixture(scope="module")
def sampled():
    """Random held data on t = kT, k = 0..N (the last sample is never used)."""
    rng = np.random.default_rng(1991)
    n, N, M, T = 3, 60, 15, 0.1
    V = rng.standard_normal((N + 1, n))
    Y = V @ np.array([1.0, -2.0, 0.5]) + 0.3 * rng.standard_normal(N + 1)
    # prior comparable to a window's information (T·M·E vvᵀ = 1.5 I): a wrong
    # prior scaling would change θ by O(1), see test_prior_scaling_is_needed
    Q0 = np.array([[1.0, 0.2, 0.0], [0.2, 0.8, 0.1], [0.0, 0.1, 0.5]])
    theta0 = np.array([0.3, -0.2, 0.1])
    return dict(n=n, N=N, M=M, T=T, V=V, Y=Y, Q0=Q0, theta0=theta0, t=T * np.arange(N + 1))


@pytest.mark.parametrize("windowed", [True, False], ids=["alg2", "alg2'"])
def test_algorithm2_equals_sliding_window_rls(sampled, windowed):
    s = sampled
    t_n = s["M"] * s["T"] if windowed else None
    res = integrate(s["V"], s["Y"], s["t"], algorithm=2, t_n=t_n, theta0=s["theta0"],
                    Q0=s["Q0"], rtol=RTOL, atol=ATOL)
    # f = 1: a held sample contributes T v vᵀ, the prior Q0⁻¹ → divide by T (eq. 69–70)
    P0 = s["T"] * s["Q0"]
    est = (SlidingWindowRLS(s["n"], s["M"], theta0=s["theta0"], P0=P0) if windowed
           else RLS(s["n"], theta0=s["theta0"], P0=P0))
    traj = est.copy().run(s["V"][:-1], s["Y"][:-1])
    # θ(t_k) is the estimate after k samples = traj.theta[k-1]
    assert rel_err(res.theta[1:], traj.theta) <= 1e-7
    np.testing.assert_array_equal(res.theta[0], s["theta0"])
    th, P = core_history(est, s["V"][:-1], s["Y"][:-1])
    assert rel_err(res.Q[1:], P / s["T"]) <= 1e-7
    assert isinstance(res, TLSMResult) and res.theta.shape == (s["N"] + 1, s["n"])
    assert res.Q.shape == (s["N"] + 1, s["n"], s["n"])


@pytest.mark.parametrize("windowed", [True, False], ids=["alg3", "alg3'"])
def test_algorithm3_equals_exponential_forgetting(sampled, windowed):
    s = sampled
    alpha = 0.7
    t_n = s["M"] * s["T"] if windowed else None
    res = integrate(s["V"], s["Y"], s["t"], algorithm=3, t_n=t_n, alpha=alpha,
                    theta0=s["theta0"], Q0=s["Q0"], rtol=RTOL, atol=ATOL)
    lam = math.exp(-alpha * s["T"])
    c = (1.0 - lam) / alpha            # ∫₀ᵀ e^{−αu} du: weight of a held sample
    est = (SlidingWindowRLS(s["n"], s["M"], forgetting=lam, theta0=s["theta0"], P0=c * s["Q0"])
           if windowed else RLS(s["n"], forgetting=lam, theta0=s["theta0"], P0=c * s["Q0"]))
    traj = est.copy().run(s["V"][:-1], s["Y"][:-1])
    assert rel_err(res.theta[1:], traj.theta) <= 1e-7
    _, P = core_history(est, s["V"][:-1], s["Y"][:-1])
    assert rel_err(res.Q[1:], P / c) <= 1e-7


def test_prior_scaling_is_needed(sampled):
    """The same comparison with the unscaled prior P0 = Q0 fails by far (the test can fail)."""
    s = sampled
    res = integrate(s["V"], s["Y"], s["t"], algorithm=2, t_n=s["M"] * s["T"],
                    theta0=s["theta0"], Q0=s["Q0"], rtol=RTOL, atol=ATOL)
    traj = SlidingWindowRLS(s["n"], s["M"], theta0=s["theta0"], P0=s["Q0"]).run(
        s["V"][:-1], s["Y"][:-1])
    assert rel_err(res.theta[1:], traj.theta) > 1e-2
    # and θ(t_k) is not the estimate after k + 1 samples (the index is not arbitrary)
    traj = SlidingWindowRLS(s["n"], s["M"], theta0=s["theta0"], P0=s["T"] * s["Q0"]).run(
        s["V"][1:], s["Y"][1:])
    assert rel_err(res.theta[1:], traj.theta) > 1e-2


@pytest.mark.parametrize("windowed", [True, False], ids=["alg4", "alg4'"])
def test_algorithm4_time_varying_equals_discrete_eq74(windowed):
    rng = np.random.default_rng(74)
    n, N, M, T = 2, 50, 12, 0.05
    V = rng.standard_normal((N + 1, n))
    Y = rng.standard_normal(N + 1)
    L1 = rng.uniform(0.0, 3.0, N + 1)          # held λ₁(t), λ₂(t), really time varying
    L2 = rng.uniform(0.5, 2.0, N + 1)
    Q0, theta0 = 0.1 * np.eye(n), np.array([0.3, -0.2])
    t_n = M * T if windowed else None
    res = integrate(V, Y, T * np.arange(N + 1), algorithm=4, t_n=t_n, lambda1=L1, lambda2=L2,
                    theta0=theta0, Q0=Q0, rtol=RTOL, atol=ATOL)
    # eq. 74: λₖ = e^{−Tλ₁,ₖ} (αₖ = 1/λₖ) and f̄ₖ = "Tλ₂,ₖ" integrated over the hold:
    # ∫₀ᵀ λ₂,ₖ e^{−λ₁,ₖ u} du = λ₂,ₖ (1 − e^{−Tλ₁,ₖ})/λ₁,ₖ; no prior scaling (σ = 1)
    lam = np.exp(-T * L1[:N])
    w = L2[:N] * (-np.expm1(-T * L1[:N])) / L1[:N]
    est = SlidingWindowRLS(n, M, theta0=theta0, P0=Q0) if windowed else RLS(n, theta0=theta0, P0=Q0)
    traj = est.copy().run(V[:N], Y[:N], weights=w, forgetting=lam)
    assert rel_err(res.theta[1:], traj.theta) <= 1e-7
    _, P = core_history(est, V[:N], Y[:N], weights=w, forgetting=lam)
    assert rel_err(res.Q[1:], P) <= 1e-7
    # the literal rectangle weights Tλ₂,ₖ are not exact when λ₁ varies (O(Tλ₁) ~ 5 %)
    traj_rect = SlidingWindowRLS(n, M, theta0=theta0, P0=Q0).run(
        V[:N], Y[:N], weights=T * L2[:N], forgetting=lam) if windowed else RLS(
        n, theta0=theta0, P0=Q0).run(V[:N], Y[:N], weights=T * L2[:N], forgetting=lam)
    assert rel_err(res.theta[1:], traj_rect.theta) > 1e-3


def test_algorithm4_constant_lambda1_rectangle_weights_exact():
    """With constant λ₁ eq. 74's rectangle weights Tλ₂,ₖ are exact, the constant factor
    φ = (1 − e^{−x})/x (x = Tλ₁) going into the prior: P0 = φ Q0."""
    rng = np.random.default_rng(7)
    n, N, M, T, l1 = 2, 40, 10, 0.1, 1.3
    V = rng.standard_normal((N + 1, n))
    Y = rng.standard_normal(N + 1)
    L2 = rng.uniform(0.2, 2.0, N + 1)
    Q0, theta0 = np.eye(n), np.zeros(n)
    res = integrate(V, Y, T * np.arange(N + 1), algorithm=4, t_n=M * T, lambda1=l1,
                    lambda2=L2, theta0=theta0, Q0=Q0, rtol=RTOL, atol=ATOL)
    x = T * l1
    phi = -math.expm1(-x) / x
    traj = SlidingWindowRLS(n, M, forgetting=math.exp(-x), theta0=theta0, P0=phi * Q0).run(
        V[:N], Y[:N], weights=T * L2[:N])
    assert rel_err(res.theta[1:], traj.theta) <= 1e-7


def test_discretize_closed_forms_and_run_equal_integrate(sampled):
    s = sampled
    T, alpha = s["T"], 0.7
    d2 = discretize(T, algorithm=2, t_n=s["M"] * T, theta0=s["theta0"], Q0=s["Q0"])
    assert (d2.window, d2.forgetting, d2.fbar, d2.weights) == (s["M"], 1.0, T, 1.0)
    np.testing.assert_allclose(d2.P0, T * s["Q0"], rtol=1e-15)
    d3 = discretize(T, algorithm=3, t_n=None, alpha=alpha, theta0=s["theta0"], Q0=s["Q0"])
    lam = math.exp(-alpha * T)
    assert d3.window is None
    assert d3.forgetting == pytest.approx(lam, rel=1e-15)
    assert d3.scale == pytest.approx((1 - lam) / alpha, rel=1e-14)
    assert d3.hbar == pytest.approx(lam - 1.0, rel=1e-14)   # eq. 72, read as h̄
    assert isinstance(d3.estimator(), RLS)
    assert isinstance(d2.estimator(), SlidingWindowRLS) and d2.estimator().window == s["M"]
    res = integrate(s["V"], s["Y"], s["t"], algorithm=3, t_n=None, alpha=alpha,
                    theta0=s["theta0"], Q0=s["Q0"], rtol=RTOL, atol=ATOL)
    run = d3.run(s["V"][:-1], s["Y"][:-1])
    np.testing.assert_allclose(run.t, s["t"], rtol=1e-15, atol=1e-15)
    assert rel_err(run.theta, res.theta) <= 1e-7
    assert rel_err(run.Q, res.Q) <= 1e-7


def test_discretize_by_quadrature_matches_closed_form():
    """Algorithm 1 with the f, h of algorithm 4 (callables, by quadrature) gives eq. 74's
    closed form; algorithm 4 with callables likewise."""
    T, N = 0.1, 12
    rng = np.random.default_rng(3)
    L1 = rng.uniform(0.1, 2.0, N)
    L2 = rng.uniform(0.5, 1.5, N)

    def held(a):
        return lambda t: float(a[min(max(int(math.floor(t / T + 1e-9)), 0), N - 1)])

    closed = discretize(T, algorithm=4, t_n=0.4, lambda1=L1, lambda2=L2, theta0=[0.0],
                        Q0=1.0)
    quad4 = discretize(T, algorithm=4, t_n=0.4, lambda1=held(L1), lambda2=held(L2),
                       theta0=[0.0], Q0=1.0, n_samples=N)
    lam1, lam2 = held(L1), held(L2)
    edges = T * np.arange(N + 1)

    def int_l1(s, t):   # ∫ₛᵗ λ₁ for the held λ₁, exact
        total = 0.0
        for k in range(N):
            a, b = max(edges[k], s), min(edges[k + 1], t)
            if b > a:
                total += L1[k] * (b - a)
        return total

    f = lambda t, s: lam2(s) * math.exp(-int_l1(s, t))   # noqa: E731
    h = lambda t: -lam1(t)                              # noqa: E731
    quad1 = discretize(T, algorithm=1, t_n=0.4, f=f, h=h, theta0=[0.0], Q0=1.0, n_samples=N)
    for d in (quad4, quad1):
        np.testing.assert_allclose(d.forgetting, closed.forgetting, rtol=1e-12)
        np.testing.assert_allclose(d.fbar, closed.fbar, rtol=1e-10)
    np.testing.assert_allclose(closed.forgetting, np.exp(-T * L1), rtol=1e-15)


def test_held_callable_with_breakpoints_equals_held_array(sampled):
    s = sampled
    T, N = s["T"], s["N"]
    V, Y = s["V"], s["Y"]

    def idx(t):
        return min(max(int(math.floor(t / T)), 0), N)

    res_arr = integrate(V, Y, s["t"], algorithm=3, t_n=s["M"] * T, alpha=0.4,
                        theta0=s["theta0"], Q0=s["Q0"], rtol=RTOL, atol=ATOL)
    t_out = np.linspace(0.0, N * T, 7 * N + 1)          # outputs also between samples
    res_fn = integrate(lambda t: V[idx(t)], lambda t: Y[idx(t)], t_out, algorithm=3,
                       t_n=s["M"] * T, alpha=0.4, theta0=s["theta0"], Q0=s["Q0"],
                       breakpoints=s["t"], rtol=RTOL, atol=ATOL)
    assert rel_err(res_fn.theta[::7], res_arr.theta) <= 1e-9


def test_algorithm1_smooth_weight_held_signals_equals_core():
    """A weight that varies inside each hold interval (not held itself): the hold
    integral f̄ₖ = ∫ f(t_{k+1}, s) ds, computed here by quad, makes the core exact."""
    rng = np.random.default_rng(11)
    n, N, M, T = 2, 40, 8, 0.1
    V = rng.standard_normal((N + 1, n))
    Y = rng.standard_normal(N + 1)
    Q0, theta0 = np.eye(n), np.zeros(n)
    res = integrate(V, Y, T * np.arange(N + 1), algorithm=1, t_n=M * T, f=_f1, h=_h1,
                    theta0=theta0, Q0=Q0, rtol=RTOL, atol=ATOL)
    edges = T * np.arange(N + 1)
    fbar = np.array([quad_vec(lambda s, b=b: _f1(b, s), a, b, epsabs=0.0, epsrel=1e-13)[0]
                     for a, b in zip(edges[:-1], edges[1:])])
    lam = np.array([_f1(b, a) / _f1(a, a) for a, b in zip(edges[:-1], edges[1:])])  # e^{∫h}
    traj = SlidingWindowRLS(n, M, theta0=theta0, P0=Q0).run(V[:N], Y[:N], weights=fbar,
                                                           forgetting=lam)
    assert rel_err(res.theta[1:], traj.theta) <= 1e-7


def test_exact_initialisation_with_held_past_equals_core_started_earlier():
    """Exact initialisation from M held past samples (y = θ₀ᵀv there, eq. 32) is the core
    run over past + data with a negligible prior: θ(t_k) = estimate after M + k samples."""
    rng = np.random.default_rng(32)
    n, N, M, T, alpha = 3, 30, 10, 0.1, 0.6
    theta0 = np.array([0.5, -1.0, 2.0])
    past = rng.standard_normal((M, n))
    V = rng.standard_normal((N + 1, n))
    Y = rng.standard_normal(N + 1)
    res = integrate(V, Y, T * np.arange(N + 1), algorithm=3, alpha=alpha, t_n=M * T,
                    theta0=theta0, past=past, rtol=RTOL, atol=ATOL)
    lam = math.exp(-alpha * T)
    # prior 1e-12 of a window's information: its effect on θ is ≲ 1e-11
    est = SlidingWindowRLS(n, M, forgetting=lam, theta0=np.zeros(n), P0=1e12)
    traj = est.run(np.vstack([past, V[:N]]), np.concatenate([past @ theta0, Y[:N]]))
    assert rel_err(res.theta[1:], traj.theta[M:]) <= 1e-7
    np.testing.assert_allclose(res.theta[0], theta0, rtol=1e-9)   # b(t0) = R(t0) θ0 exactly


def test_start_time_shift_invariance():
    """Algorithm 2 is time invariant: starting at t0 = 5 gives the same estimates."""
    rng = np.random.default_rng(5)
    V, Y = rng.standard_normal((21, 2)), rng.standard_normal(21)
    t = 0.05 * np.arange(21)
    a = integrate(V, Y, t, algorithm=2, t_n=0.25, theta0=[0.0, 0.0], Q0=1.0, rtol=RTOL,
                  atol=ATOL)
    b = integrate(V, Y, t + 5.0, algorithm=2, t_n=0.25, theta0=[0.0, 0.0], Q0=1.0, rtol=RTOL,
                  atol=ATOL)
    assert rel_err(b.theta, a.theta) <= 1e-9


# ---------------------------------------------- normal equations, smooth data

TH_OLD = np.array([1.0, -0.5, 0.3])
TH_NEW = np.array([0.2, 0.8, -0.4])
T_JUMP = 0.7


def v_smooth(t):
    return np.array([1.0, math.sin(2.3 * t), math.cos(1.7 * t + 0.4 * t * t)])


def y_jump(t):
    return float(v_smooth(t) @ (TH_OLD if t < T_JUMP else TH_NEW))


def _l1(t):
    return 0.5 + 0.3 * math.sin(t)


def _l2(t):
    return 1.0 + 0.5 * math.cos(3.0 * t)


def _f1(t, s):
    """A general weight: λ₂(s) = 1 + 0.5 sin s, λ₁(t) = 0.3 + 0.2 cos t, integrated."""
    return (1 + 0.5 * math.sin(s)) * math.exp(-0.3 * (t - s) - 0.2 * (math.sin(t) - math.sin(s)))


def _h1(t):
    return -(0.3 + 0.2 * math.cos(t))


# Closed-form weights f(t, s) and the parameters that integrate() gets.
WEIGHTINGS = {
    1: (_f1, dict(f=_f1, h=_h1)),
    2: (lambda t, s: 1.0, {}),
    3: (lambda t, s: math.exp(-0.8 * (t - s)), dict(alpha=0.8)),
    # ∫ₛᵗ λ₁ = 0.5 (t − s) − 0.3 (cos t − cos s)
    4: (lambda t, s: _l2(s) * math.exp(-0.5 * (t - s) + 0.3 * (math.cos(t) - math.cos(s))),
        dict(lambda1=_l1, lambda2=_l2)),
}


def quad_normal_equations(fw, t, lo, theta0, Q0, prior_decay):
    """Both sides of eq. 5 (plus the prior term for the usual initialisation) by quad_vec."""
    n = theta0.shape[0]

    def integrand(s):
        vs = v_smooth(s)
        ys = float(vs @ theta0) if s < 0.0 else y_jump(s)   # eq. 32: past consistent with θ₀
        return fw(t, s) * np.concatenate([np.outer(vs, vs).ravel(), vs * ys])

    pts = [p for p in (0.0, T_JUMP) if lo < p < t]
    edges = [lo, *pts, t]
    out = np.zeros(n * n + n)
    for a, b in zip(edges[:-1], edges[1:]):
        out += quad_vec(integrand, a, b, epsabs=0.0, epsrel=1e-12)[0]
    R, b = out[: n * n].reshape(n, n), out[n * n:]
    if Q0 is not None:
        P = prior_decay * np.linalg.inv(Q0)
        R, b = R + P, b + P @ theta0
    return R, b


@pytest.mark.parametrize("init", ["exact", "usual"])
@pytest.mark.parametrize("alg", [1, 2, 3, 4])
def test_normal_equations_hold_at_every_output(alg, init):
    fw, params = WEIGHTINGS[alg]
    t_n = 1.5
    t_eval = np.linspace(0.0, 4.0, 17)
    theta0 = TH_OLD if init == "exact" else np.zeros(3)
    Q0 = None if init == "exact" else np.diag([2.0, 1.0, 0.5])
    res = integrate(v_smooth, y_jump, t_eval, algorithm=alg, t_n=t_n, theta0=theta0, Q0=Q0,
                    past=v_smooth if init == "exact" else None, breakpoints=[T_JUMP],
                    rtol=RTOL, atol=ATOL, **params)
    for k, t in enumerate(t_eval):
        lo = t - t_n if init == "exact" else max(0.0, t - t_n)
        # prior decays as exp(∫₀ᵗ h) = f(t, 0)/f(0, 0)
        decay = fw(t, 0.0) / fw(0.0, 0.0)
        if t == 0.0 and init == "usual":
            R, b = np.linalg.inv(Q0), np.linalg.inv(Q0) @ theta0
        else:
            R, b = quad_normal_equations(fw, t, lo, theta0, Q0, decay)
        resid = np.linalg.norm(R @ res.theta[k] - b)
        # integration error ≲ 1e-10 relative in R and b; observed ≤ 1e-11. A relative
        # error of 1e-8 in θ would show as ≳ 1e-9 here (cond(R) ≤ 20), so 1e-9 has teeth.
        scale = np.linalg.norm(R) * np.linalg.norm(res.theta[k]) + np.linalg.norm(b)
        assert resid <= 1e-9 * scale, (k, t, resid / scale)
        # Q = R⁻¹: observed ≤ 5e-10 relative (the quadrature of R is 1e-12, cond ≤ 20)
        np.testing.assert_allclose(res.Q[k], np.linalg.inv(R), rtol=1e-8,
                                   atol=1e-8 * np.abs(res.Q[k]).max())


def test_exact_initialisation_eq32():
    """θ(t0) = θ0 and Q(t0)⁻¹ = ∫_{−tn}^0 f(0, s) v vᵀ ds (eq. 32), by quadrature."""
    fw, params = WEIGHTINGS[3]
    res = integrate(v_smooth, y_jump, [0.0, 0.1], algorithm=3, t_n=1.5, theta0=TH_OLD,
                    past=v_smooth, rtol=RTOL, atol=ATOL, **params)
    R = quad_vec(lambda s: fw(0.0, s) * np.outer(v_smooth(s), v_smooth(s)), -1.5, 0.0,
                 epsabs=0.0, epsrel=1e-12)[0]
    np.testing.assert_array_equal(res.theta[0], TH_OLD)
    np.testing.assert_allclose(res.Q[0], np.linalg.inv(R), rtol=1e-8)


# ---------------------------------------------- the defining property of TLSM

@pytest.mark.parametrize("alg", [1, 2, 3, 4])
def test_exact_initialisation_recovers_new_theta_tn_after_jump(alg):
    _, params = WEIGHTINGS[alg]
    t_n = 1.5
    t_eval = np.concatenate([T_JUMP + t_n * np.array([0.1, 0.5, 0.9, 0.99]),
                             [T_JUMP + t_n], T_JUMP + t_n + np.array([0.3, 1.0])])
    t_eval = np.concatenate([[0.0, 0.5], t_eval])
    res = integrate(v_smooth, y_jump, t_eval, algorithm=alg, t_n=t_n, theta0=TH_OLD,
                    past=v_smooth, breakpoints=[T_JUMP], rtol=RTOL, atol=ATOL, **params)
    err = np.linalg.norm(res.theta - TH_NEW, axis=1) / np.linalg.norm(TH_NEW)
    # before the jump the exact initialisation gives the old θ exactly
    assert np.linalg.norm(res.theta[:2] - TH_OLD) <= 1e-6
    # not before t0 + tn: old data still in the window (≥ 1e-3 even at 0.99 tn)
    assert np.all(err[2:6] > 1e-3), err
    # at t0 + tn and after: exactly the new θ (integration error ~1e-11 observed)
    assert np.all(err[6:] <= 1e-6), err


@pytest.mark.parametrize("alg", [2, 3])
def test_usual_initialisation_error_bounded_by_prior(alg):
    r"""Usual initialisation: with only new, noise-free data in the window,
    R θ = P θ₀ + W θ_new, R = P + W, so θ − θ_new = (P + W)⁻¹ P (θ₀ − θ_new) with
    P = e^{∫h} Q0⁻¹ (the decayed prior) and W = ∫ f v vᵀ over the window. Hence

        λ_min(P) ‖Δ‖ / (λ_max(W) + λ_max(P)) ≤ ‖θ − θ_new‖ ≤ λ_max(P) ‖Δ‖ / (λ_min(W) + λ_min(P)),

    Δ = θ₀ − θ_new; W by independent quadrature."""
    fw, params = WEIGHTINGS[alg]
    t_n = 1.5
    Q0 = np.diag([100.0, 50.0, 200.0])
    theta0 = np.zeros(3)
    t_star = T_JUMP + t_n
    res = integrate(v_smooth, y_jump, [0.0, t_star], algorithm=alg, t_n=t_n, theta0=theta0,
                    Q0=Q0, breakpoints=[T_JUMP], rtol=RTOL, atol=ATOL, **params)
    W = quad_vec(lambda s: fw(t_star, s) * np.outer(v_smooth(s), v_smooth(s)), T_JUMP, t_star,
                 epsabs=0.0, epsrel=1e-12)[0]
    P = (fw(t_star, 0.0) / fw(0.0, 0.0)) * np.linalg.inv(Q0)
    ew, ep = np.linalg.eigvalsh(W), np.linalg.eigvalsh(P)
    delta = np.linalg.norm(theta0 - TH_NEW)
    err = np.linalg.norm(res.theta[-1] - TH_NEW)
    lower = ep[0] * delta / (ew[-1] + ep[-1])
    upper = ep[-1] * delta / (ew[0] + ep[0])
    assert lower <= err <= upper, (lower, err, upper)
    assert err > 1e-4      # the prior really is felt: not the exact-initialisation result
    # and the identity itself, to the integration accuracy
    np.testing.assert_allclose(res.theta[-1] - TH_NEW,
                               np.linalg.solve(P + W, P @ (theta0 - TH_NEW)), rtol=1e-7, atol=1e-10)


# ------------------------------------------------ lemma vs naive forward Euler

@pytest.mark.parametrize("alg,windowed", [(2, True), (2, False), (3, True), (3, False),
                                          (4, True), (4, False)])
def test_lemma_recursion_equals_core_to_rounding(alg, windowed):
    rng = np.random.default_rng(62 + alg)
    n, N, M, T = 3, 80, 10, 0.05
    V = rng.standard_normal((N, n))
    Y = rng.standard_normal(N)
    Q0, theta0 = 2.0 * np.eye(n), rng.standard_normal(n)
    kw = {2: {}, 3: dict(alpha=1.5),
          4: dict(lambda1=rng.uniform(0.0, 2.0, N), lambda2=rng.uniform(0.5, 1.5, N))}[alg]
    d = discretize(T, algorithm=alg, t_n=M * T if windowed else None, theta0=theta0, Q0=Q0, **kw)
    lemma = d.run_lemma(V, Y)
    # the core, configured from the closed forms (not from d)
    if alg == 2:
        lam, w, sigma = np.ones(N), np.ones(N), T
    elif alg == 3:
        lam = np.full(N, math.exp(-1.5 * T))
        w, sigma = np.ones(N), (1 - lam[0]) / 1.5
    else:
        lam = np.exp(-T * kw["lambda1"])
        w, sigma = kw["lambda2"] * (-np.expm1(-T * kw["lambda1"])) / kw["lambda1"] / T, T
    est = (SlidingWindowRLS(n, M, theta0=theta0, P0=sigma * Q0) if windowed
           else RLS(n, theta0=theta0, P0=sigma * Q0))
    th, P = core_history(est, V, Y, weights=w, forgetting=lam)
    assert rel_err(lemma.theta[1:], th) <= 1e-10
    assert rel_err(lemma.Q[1:], P / sigma) <= 1e-10


def _euler_case(T, windowed):
    """Algorithm 2(′), smooth v sampled at kT over [0, 3), noise-free y, Q0 = I."""
    tk = T * np.arange(int(round(3.0 / T)))
    V = np.column_stack([np.ones_like(tk), np.sin(2.0 * tk)])
    Y = V @ np.array([0.5, -1.0])
    M = int(round(1.0 / T)) if windowed else None
    d = discretize(T, algorithm=2, t_n=1.0 if windowed else None, theta0=np.zeros(2),
                   Q0=np.eye(2))
    return V, Y, M, d


@pytest.mark.parametrize("windowed", [False, True], ids=["alg2'", "alg2"])
def test_naive_euler_error_has_the_predicted_size(windowed):
    r"""Naive Euler: (Qₖ − QₖΔₖQₖ)⁻¹ = Rₖ + Δₖ + ΔₖQₖΔₖ + O(Δ³), so after N steps
    R_euler − R = Σₖ ΔₖQₖΔₖ·(1 + O(T)) with the exact Qₖ (closed form here:
    Rₖ = Q0⁻¹ + Σ_{j<k} Δⱼ, Δⱼ = T(vⱼvⱼᵀ − v_{j−M}v_{j−M}ᵀ)). Σ ΔQΔ ≈ T ∫ (vᵀQv) vvᵀ dt,
    so the error halves with T."""
    sizes, theta_err = [], []
    for T in (0.02, 0.01):
        V, Y, M, d = _euler_case(T, windowed)
        euler = d.run_euler(V, Y)
        lemma = d.run_lemma(V, Y)
        R = np.eye(2)
        pred = np.zeros((2, 2))
        for k in range(V.shape[0]):
            D = T * np.outer(V[k], V[k])
            if M is not None and k >= M:
                D -= T * np.outer(V[k - M], V[k - M])
            pred += D @ np.linalg.inv(R) @ D
            R = R + D
        err = np.linalg.inv(euler.Q[-1]) - R
        # relative deviation from the leading term is O(T): 1.0 % / 0.5 % observed
        assert np.linalg.norm(err - pred) <= 3.0 * T * np.linalg.norm(pred)
        # the exact (lemma) recursion has no such error
        assert np.linalg.norm(np.linalg.inv(lemma.Q[-1]) - R) <= 1e-12 * np.linalg.norm(R)
        sizes.append(np.linalg.norm(err))
        theta_err.append(np.max(np.abs(euler.theta - lemma.theta)))
    assert 5e-2 <= sizes[0] <= 1e-1          # ≈ 0.055 (2') / 0.070 (2) at T = 0.02
    assert sizes[0] / sizes[1] == pytest.approx(2.0, rel=0.05)       # first order in T
    assert theta_err[0] > 1e-3 and theta_err[0] / theta_err[1] == pytest.approx(2.0, rel=0.1)


def test_naive_euler_loses_definiteness_for_large_T_Q():
    """T vᵀQv ≥ 1 makes the forward difference of Q indefinite; the exact one stays SPD."""
    V = np.tile([1.0, 0.5], (20, 1)) + np.outer(np.arange(20) % 3, [0.0, 1.0])
    Y = V @ [1.0, 2.0]
    d = discretize(0.1, algorithm=2, t_n=None, theta0=[0.0, 0.0], Q0=100.0)
    with pytest.warns(DefinitenessLossWarning, match="naive forward-Euler"):
        euler = d.run_euler(V, Y)
    assert euler.info["lost_definiteness_at"] == 1
    assert np.isnan(euler.theta[-1]).all()
    exact = d.run(V, Y)
    assert np.all(np.linalg.eigvalsh(exact.Q[1:]) > 0)
    # the exact answer: the ridge solution (Q0⁻¹ + T Σ v vᵀ)⁻¹ T Σ v y (eq. 51, f = 1)
    ridge = np.linalg.solve(np.eye(2) / 100.0 + 0.1 * V.T @ V, 0.1 * V.T @ Y)
    np.testing.assert_allclose(exact.theta[-1], ridge, rtol=1e-10)


# ------------------------------------------------------------------ bad input

def _ok_args():
    t = np.linspace(0.0, 1.0, 11)
    return dict(v=np.ones((11, 2)), y=np.zeros(11), t_eval=t, algorithm=2, t_n=0.5,
                theta0=np.zeros(2), Q0=1.0)


@pytest.mark.parametrize("change,name,exc", [
    (dict(v=np.ones((10, 2))), "v", ValueError),
    (dict(v=np.ones((11, 3))), "v", ValueError),
    (dict(y=np.zeros(12)), "y", ValueError),
    (dict(v=lambda t: np.ones(3)), "v", ValueError),
    (dict(y=lambda t: np.ones(2)), "y", ValueError),
    (dict(t_eval=np.array([0.0, 0.2, 0.1] + [0.3] * 8)), "t_eval", ValueError),
    (dict(t_eval=np.zeros(11)), "t_eval", ValueError),
    (dict(t_n=0.0), "t_n", ValueError),
    (dict(t_n=-1.0), "t_n", ValueError),
    (dict(algorithm=5), "algorithm", ValueError),
    (dict(algorithm=0), "algorithm", ValueError),
    (dict(algorithm="2"), "algorithm", TypeError),
    (dict(algorithm=3), "alpha", ValueError),                 # alpha missing
    (dict(alpha=0.5), "alpha", ValueError),                   # alpha unused by algorithm 2
    (dict(algorithm=3, alpha=-1.0), "alpha", ValueError),
    (dict(algorithm=4, lambda1=1.0), "lambda2", ValueError),
    (dict(algorithm=4, lambda1=1.0, lambda2=np.ones(5)), "lambda2", ValueError),
    (dict(Q0=None), "Q0", ValueError),
    (dict(Q0=np.array([[1.0, 2.0], [2.0, 1.0]])), "Q0", ValueError),
    (dict(Q0=None, past=lambda t: np.array([1.0, 0.0])), "past", ValueError),  # singular eq. 32
    (dict(past=lambda t: np.ones(2)), "Q0", ValueError),     # both initialisations
    (dict(Q0=None, past=np.ones((4, 2)), t_n=None), "past", ValueError),
    (dict(algorithm=1, f=lambda t, s: math.exp(-(t - s)), h=lambda t: -2.0), "h", ValueError),
    (dict(algorithm=1, f=lambda t, s: 1.0, h=0.0), "h", TypeError),
    (dict(breakpoints=[[0.5]]), "breakpoints", ValueError),
])
def test_bad_input_names_the_argument(change, name, exc):
    args = _ok_args()
    args.update(change)
    v, y, t = args.pop("v"), args.pop("y"), args.pop("t_eval")
    with pytest.raises(exc, match=rf"^{name} must be"):
        integrate(v, y, t, **args)


@pytest.mark.parametrize("kwargs,name", [
    (dict(T=0.0), "T"),
    (dict(t_n=0.35), "t_n"),                     # not a multiple of T
    (dict(t_n=0.1), "t_n"),                      # window of 1 sample < n = 2
    (dict(algorithm=7), "algorithm"),
    (dict(algorithm=1, f=lambda t, s: 1.0, h=lambda t: 0.0), "n_samples"),
    (dict(algorithm=4, lambda1=-1.0, lambda2=1.0), "lambda1"),   # growing weight: λ > 1
])
def test_discretize_bad_input(kwargs, name):
    args = dict(T=0.1, algorithm=2, t_n=0.5, theta0=[0.0, 0.0], Q0=1.0)
    args.update(kwargs)
    T = args.pop("T")
    with pytest.raises(ValueError, match=rf"^{name} must be"):
        discretize(T, **args)


def test_discretization_run_rejects_wrong_data():
    d = discretize(0.1, algorithm=2, t_n=0.5, theta0=[0.0, 0.0], Q0=1.0)
    with pytest.raises(ValueError, match=r"^v must be"):
        d.run(np.ones((5, 3)), np.ones(5))
    with pytest.raises(ValueError, match=r"^y must be"):
        d.run(np.ones((5, 2)), np.ones(4))
