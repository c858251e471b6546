"""The contract every recursive estimator keeps (issue 31, point 7).

DESIGN.md's estimator interface, checked for every estimator
:func:`adaptid.estimator` can build — each method of its table with each of
its options varied (every form of RLS, every forgetting strategy of
:mod:`adaptid.forgetting`, ``P_max``, the exact diffuse starts, a matrix
prior, nonzero θ₀), each with one and with two outputs — and for
:class:`adaptid.ConstrainedRLS`:

* ``update`` called N times equals ``run`` bit for bit (θ after every sample,
  the a-priori errors, P, the counts), with per-sample weights, per-sample
  forgetting where the method takes it, and skipped NaN samples; also through
  the narrow step entry of ``compile_update()`` where the method has one;
* ``run_batched`` equals ``run`` on each stream alone, bit for bit;
* stopping in the middle — a state file (``save_state`` / ``load_state``), a
  state dict (``get_state`` / ``from_state``) or a pickle — and going on
  equals one pass, bit for bit (single and batched);
* the NaN policies: ``"raise"`` raises ValueError, ``"skip"`` skips the sample
  and marks it in ``Trajectory.skipped``;
* a refused call (wrong shapes, NaN under ``"raise"``, weights or forgetting
  out of range, a single-stream call on a batched estimator) leaves the state
  exactly as it was;
* ``predict``'s shapes (single φ, a batch Φ, p outputs, B streams) and values
  (φᵀθ);
* ``copy()`` is independent and ``reset()`` restores the prior.

The expected values are the contract's own equivalences (update against run,
stop-and-resume against one pass), never numbers computed the same way. The
case list is generated from the factory's table (:data:`adaptid.METHODS`,
:func:`adaptid.estimators._factory.method_options`): a method or an option the table
knows but this file has no value for fails
:func:`test_every_method_and_option_of_the_factory_has_cases`.
"""

import itertools
import pickle
import re

import numpy as np
import pytest

import adaptid
from adaptid import forgetting as fg
from adaptid.estimators._factory import METHODS, method_of, method_options

N_SAMPLES, N_PARAMS, N_STREAMS = 48, 3, 3
HALF = 21  # where a run stops and resumes (not a multiple of the window)

# ------------------------------------------------------------------ the table
#: values of the options the factory requires (the base case of each method)
REQUIRED = {"window": 12, "process_cov": 1e-4, "step": 0.05}

#: one instance of every strategy of adaptid.forgetting (each needs its own options)
STRATEGIES = {
    "Exponential": {"forgetting": fg.Exponential(0.97)},
    "Directional": {"forgetting": fg.Directional(0.98)},
    "ConstantTrace": {"forgetting": fg.ConstantTrace(0.9, trace=30.0)},
    # EFRA's -delta P^2 term needs P0 <= (1 - alpha)/(lam delta) (the constructor checks)
    "EFRA": {"forgetting": fg.EFRA(), "P0": 10.0},
    "Variable": {"forgetting": fg.Variable(lam_min=0.95, sigma0=0.5, memory=30.0)},
}

#: the forms of RLS besides "auto" (the base case)
FORMS = ("ud", "sqrt", "covariance")


def _spd(n):
    A = np.random.default_rng(5).standard_normal((n, n))
    return A @ A.T + 5.0 * np.eye(n)


#: the values each option of the factory's table takes in a case of its own:
#: label -> the options of that case (besides the required ones)
VARIANTS = {
    "forgetting": {"lam=0.97": {"forgetting": 0.97}, **STRATEGIES},
    "P_max": {"P_max": {"P_max": 50.0, "forgetting": 0.9},
              "P_max+Variable": {"P_max": 50.0, **STRATEGIES["Variable"]},
              "P_max+Directional": {"P_max": 50.0, **STRATEGIES["Directional"]}},
    "form": {f"form={f}": {"form": f} for f in FORMS}
    | {f"form={f}+lam": {"form": f, "forgetting": 0.95} for f in FORMS},
    "P0": {"diffuse": {"P0": "diffuse"},
           "diffuse+lam": {"P0": "diffuse", "forgetting": 0.97},
           "P0=matrix": {"P0": _spd(N_PARAMS)}},
    "theta0": {"theta0": {"theta0": "nonzero"}},  # made (n,) or (n, p) per case
    "windup_threshold": {"windup=inf": {"windup_threshold": np.inf}},
    "window": {"window=3": {"window": N_PARAMS}},
    "process_cov": {"Q=matrix": {"process_cov": np.diag([1e-4, 3e-4, 0.0])}},
    "noise_var": {"noise_var": {"noise_var": 0.25}},
    "step": {"step=0.2": {"step": 0.2}},
    "eps": {"eps": {"eps": 0.5}},
}
#: options every case exercises by itself (both NaN policies; one and two outputs)
EVERY_CASE = {"nan_policy", "n_outputs"}

#: combinations the factory refuses by design (constructor raises ValueError)
REFUSED = {
    ("window", "Directional"), ("window", "ConstantTrace"), ("window", "EFRA"),
    ("window", "Variable"),
}


def _options(method, opts, p):
    out = {k: v for k, v in REQUIRED.items() if k in method_options(method)}
    out.update(opts)
    if isinstance(out.get("theta0"), str):
        shape = (N_PARAMS,) if p == 1 else (N_PARAMS, p)
        out["theta0"] = np.random.default_rng(3).standard_normal(shape)
    if p != 1:
        out["n_outputs"] = p
    return out


def _factory_cases():
    """(id, method, label, options, p) for every case the factory builds; the
    (method, label) pairs it refuses (ValueError) and those it cannot build for
    want of a required option this table has no value for (TypeError)."""
    cases, refused, unbuilt = [], set(), {}
    for method in METHODS:
        variants = [("base", {})]
        for opt in method_options(method):
            for label, opts in VARIANTS.get(opt, {}).items():
                if set(opts) <= set(method_options(method)):
                    variants.append((label, opts))
        for (label, opts), p in itertools.product(variants, (1, 2)):
            kw = _options(method, opts, p)
            try:
                adaptid.estimator(method, N_PARAMS, **kw)
            except ValueError:
                refused.add((method, label))
                continue
            except TypeError as err:
                unbuilt[(method, label)] = str(err)
                continue
            cases.append((f"{method}-{label}-p{p}", method, label, kw, p))
    return cases, refused, unbuilt


FACTORY_CASES, FACTORY_REFUSED, FACTORY_UNBUILT = _factory_cases()
CONSTRAINED = {
    "constrained": {},
    "constrained-lam": {"forgetting": 0.95},
}
CASES = [(c[0], c) for c in FACTORY_CASES] + \
    [(k, (k, "constrained", k, v, 1)) for k, v in CONSTRAINED.items()]
CASE_IDS = [c[0] for c in CASES]


def _make(case, nan_policy="raise"):
    _, method, _, kw, _ = case
    if method == "constrained":
        return adaptid.ConstrainedRLS(N_PARAMS, C=[[1.0, 1.0, 1.0]], d=[1.0],
                                      nan_policy=nan_policy, **kw)
    return adaptid.estimator(method, N_PARAMS, nan_policy=nan_policy, **kw)


def _per_sample_forgetting(case):
    """The case takes λₖ per sample (exponential forgetting, no strategy)."""
    _, method, _, kw, _ = case
    strategy = kw.get("forgetting")
    exponential = not isinstance(strategy, fg.ForgettingStrategy) or \
        isinstance(strategy, fg.Exponential)
    return method in ("rls", "window", "constrained") and exponential


# ------------------------------------------------------------------- the data
def _data(case, *, nan=False, batch=None, seed=0):
    """Φ (N, n), y (N,) or (N, p), weights and (if the case takes it) λ per sample;
    with ``nan`` a NaN in φ of one sample and in y of another."""
    p = case[4]
    rng = np.random.default_rng(seed)
    lead = (N_SAMPLES,) if batch is None else (batch, N_SAMPLES)
    Phi = rng.standard_normal(lead + (N_PARAMS,))
    # the first n regressors well conditioned: a diffuse start is identified at
    # sample n with a moderate P (no windup warning; see KalmanRLS's default threshold)
    Phi[..., :N_PARAMS, :] = 2.0 * np.eye(N_PARAMS) + 0.3 * Phi[..., :N_PARAMS, :]
    theta = np.array([1.0, -0.5, 0.25]) if p == 1 else rng.standard_normal((N_PARAMS, p))
    y = Phi @ theta + 0.1 * rng.standard_normal(lead + ((p,) if p != 1 else ()))
    w = rng.uniform(0.5, 1.5, lead)
    w[..., 5] = 0.0  # a sample that only advances the forgetting
    kw = {"weights": w}
    if _per_sample_forgetting(case):
        kw["forgetting"] = rng.uniform(0.95, 1.0, lead)
    if nan:
        Phi[..., 7, 1] = np.nan
        if p == 1:
            y[..., 30] = np.nan
        else:
            y[..., 30, 1] = np.nan
    return Phi, y, kw


def _step_kw(kw, k):
    """The keyword arguments of update for sample k (the run's kw taken at k)."""
    out = {"weight": float(kw["weights"][k])}
    if "forgetting" in kw:
        out["forgetting"] = float(kw["forgetting"][k])
    return out


def _rows(kw, sl):
    return {k: v[sl] for k, v in kw.items()}


# ------------------------------------------------------------------ comparing
def _P(est):
    try:
        return est.P
    except AttributeError:  # the gradient estimators keep no covariance
        return None


def _assert_same_state(a, b):
    """Two estimators hold bit for bit the same state."""
    np.testing.assert_array_equal(a.theta, b.theta)
    Pa, Pb = _P(a), _P(b)
    assert (Pa is None) == (Pb is None)
    if Pa is not None:
        np.testing.assert_array_equal(Pa, Pb)
    assert (a.n_updates, a.n_skipped, a.batch_size) == (b.n_updates, b.n_skipped, b.batch_size)
    _assert_same_dict(a.get_state(), b.get_state())


def _assert_same_dict(a, b):
    if isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys()
        for key in a:
            _assert_same_dict(a[key], b[key])
    elif isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b)
        assert a.dtype == b.dtype and a.shape == b.shape
    else:
        assert type(a) is type(b) and (a == b or (a != a and b != b)), (a, b)


def _assert_same_traj(a, b):
    np.testing.assert_array_equal(a.theta, b.theta)
    np.testing.assert_array_equal(a.error, b.error)
    np.testing.assert_array_equal(a.skipped, b.skipped)


# ---------------------------------------------------------- the table's guard
def _choices(make):
    """The choices an option's ValueError lists ("must be one of 'a', 'b', got ...")."""
    with pytest.raises(ValueError) as err:
        make()
    return set(re.findall(r"'([^']*)'", str(err.value).split(", got")[0]))


def test_every_method_and_option_of_the_factory_has_cases():
    """A new method is picked up from the factory's table; a new option name
    needs its values here (REQUIRED if the method requires it, else VARIANTS)."""
    assert not FACTORY_UNBUILT, f"add the required options to REQUIRED: {FACTORY_UNBUILT}"
    built = {c[1] for c in FACTORY_CASES}
    assert built == set(METHODS), "a method of adaptid.estimator without contract cases"
    for method in METHODS:
        covered = set(EVERY_CASE) | set(REQUIRED)
        for c in FACTORY_CASES:
            if c[1] == method:
                covered |= set(c[3])
        missing = set(method_options(method)) - covered
        assert not missing, f"options of {method!r} without a contract case (add them " \
            f"to VARIANTS): {missing}"
    strategies = {name for name in fg.__all__ if isinstance(getattr(fg, name), type)
                  and issubclass(getattr(fg, name), fg.ForgettingStrategy)
                  and getattr(fg, name) is not fg.ForgettingStrategy}
    assert strategies == set(STRATEGIES), "a forgetting strategy without a contract case"
    assert {f"rls-{s}-p1" for s in STRATEGIES} <= set(CASE_IDS)
    assert _choices(lambda: adaptid.RLS(2, form="?")) == set(FORMS) | {"auto"}
    assert {f"rls-form={f}-p2" for f in FORMS} <= set(CASE_IDS)
    assert _choices(lambda: adaptid.RLS(2, nan_policy="?")) == set(NAN_POLICIES)
    # the diffuse start of every method with a covariance
    assert {m for m in METHODS if "P0" in method_options(m)} == \
        {c[1] for c in FACTORY_CASES if isinstance(c[3].get("P0"), str)}


def test_the_factory_refuses_only_the_known_combinations():
    assert FACTORY_REFUSED == REFUSED


def test_method_of_inverts_the_factory():
    for _, method, _, kw, _ in FACTORY_CASES:
        assert method_of(adaptid.estimator(method, N_PARAMS, **kw)) == method


# ------------------------------------------------------------- (a) update = run
NAN_POLICIES = ("raise", "skip")


@pytest.mark.parametrize("nan_policy", NAN_POLICIES)
@pytest.mark.parametrize("case", [c for _, c in CASES], ids=CASE_IDS)
def test_update_n_times_equals_run(case, nan_policy):
    skip = nan_policy == "skip"
    Phi, y, kw = _data(case, nan=skip)
    ran = _make(case, nan_policy)
    traj = ran.run(Phi, y, **kw)
    stepped = _make(case, nan_policy)
    thetas, errors = [], []
    for k in range(N_SAMPLES):
        errors.append(stepped.update(Phi[k], y[k], **_step_kw(kw, k)))
        thetas.append(stepped.theta)
    np.testing.assert_array_equal(traj.theta, np.array(thetas))
    np.testing.assert_array_equal(traj.error, np.array(errors))
    _assert_same_state(ran, stepped)
    skipped = np.zeros(N_SAMPLES, dtype=bool)
    if skip:
        skipped[[7, 30]] = True
    np.testing.assert_array_equal(traj.skipped, skipped)
    assert ran.n_skipped == skipped.sum() and ran.n_updates == N_SAMPLES - skipped.sum()
    if skip:  # a skipped sample leaves θ as it was; its error is NaN
        np.testing.assert_array_equal(traj.theta[7], traj.theta[6])
        assert np.isnan(traj.error[7]).all() and np.isnan(traj.error[30]).all()
    assert np.isfinite(traj.theta).all()


@pytest.mark.parametrize("nan_policy", NAN_POLICIES)
@pytest.mark.parametrize("case", FACTORY_CASES, ids=[c[0] for c in FACTORY_CASES])
def test_update_through_the_step_entry_equals_run(case, nan_policy):
    """With ``compile_update()`` (the narrow step entry, where the method has one)
    ``update`` is still bit for bit a step of ``run``."""
    _, method, _, kw, _ = case
    stepped = _make(case, nan_policy)
    # RLS's fast forms have one: no forgetting strategy, no P_max, a finite prior
    has_one = method == "rls" and _per_sample_forgetting(case) and "P_max" not in kw \
        and not isinstance(kw.get("P0"), str)
    assert stepped.compile_update() == has_one
    if not has_one:
        return
    skip = nan_policy == "skip"
    Phi, y, kw = _data(case, nan=skip, seed=6)
    ran = _make(case, nan_policy)
    traj = ran.run(Phi, y, **kw)
    errors = [stepped.update(Phi[k], y[k], **_step_kw(kw, k)) for k in range(N_SAMPLES)]
    np.testing.assert_array_equal(traj.error, np.array(errors))
    _assert_same_state(ran, stepped)


@pytest.mark.parametrize("nan_policy", NAN_POLICIES)
@pytest.mark.parametrize("case", [c for _, c in CASES], ids=CASE_IDS)
def test_run_batched_equals_each_stream_alone(case, nan_policy):
    Phi, y, kw = _data(case, nan=nan_policy == "skip", batch=N_STREAMS, seed=1)
    est = _make(case, nan_policy)
    tb = est.run_batched(Phi, y, **kw)
    assert est.batch_size == N_STREAMS
    theta, P = est.theta, _P(est)
    for b in range(N_STREAMS):
        one = _make(case, nan_policy)
        t = one.run(Phi[b], y[b], **_rows(kw, b))
        np.testing.assert_array_equal(tb.theta[b], t.theta)
        np.testing.assert_array_equal(tb.error[b], t.error)
        np.testing.assert_array_equal(tb.skipped[b], t.skipped)
        np.testing.assert_array_equal(theta[b], one.theta)
        if P is not None:
            np.testing.assert_array_equal(P[b], one.P)


# ----------------------------------------------------- (b) stop and resume
def _resume_by(how, est, tmp_path):
    if how == "file":
        path = tmp_path / "state.npz"
        est.save_state(path)
        again = type(est).load_state(path)
        _assert_same_dict(adaptid.load_state(path).get_state(), again.get_state())
        return again
    if how == "dict":
        return type(est).from_state(est.get_state())
    return pickle.loads(pickle.dumps(est))


@pytest.mark.parametrize("how", ["file", "dict", "pickle"])
@pytest.mark.parametrize("case", [c for _, c in CASES], ids=CASE_IDS)
def test_stop_and_resume_equals_one_pass(case, how, tmp_path):
    Phi, y, kw = _data(case, nan=True)
    one = _make(case, "skip")
    t = one.run(Phi, y, **kw)
    first = _make(case, "skip")
    t1 = first.run(Phi[:HALF], y[:HALF], **_rows(kw, slice(None, HALF)))
    second = _resume_by(how, first, tmp_path)
    assert type(second) is type(first) and second is not first
    _assert_same_state(second, first)
    t2 = second.run(Phi[HALF:], y[HALF:], **_rows(kw, slice(HALF, None)))
    np.testing.assert_array_equal(np.concatenate([t1.theta, t2.theta]), t.theta)
    np.testing.assert_array_equal(np.concatenate([t1.error, t2.error]), t.error)
    _assert_same_state(second, one)
    # the resumed estimator's updates are the one pass's too
    third = _resume_by(how, first, tmp_path)
    for j in range(HALF, N_SAMPLES):
        third.update(Phi[j], y[j], **_step_kw(kw, j))
    _assert_same_state(third, one)


@pytest.mark.parametrize("how", ["file", "dict", "pickle"])
@pytest.mark.parametrize("case", [c for _, c in CASES], ids=CASE_IDS)
def test_batched_stop_and_resume_equals_one_pass(case, how, tmp_path):
    Phi, y, kw = _data(case, batch=N_STREAMS, seed=2)
    one = _make(case)
    t = one.run_batched(Phi, y, **kw)
    first = _make(case)
    first.run_batched(Phi[:, :HALF], y[:, :HALF], **_rows(kw, (slice(None), slice(None, HALF))))
    second = _resume_by(how, first, tmp_path)
    _assert_same_state(second, first)
    t2 = second.run_batched(Phi[:, HALF:], y[:, HALF:],
                            **_rows(kw, (slice(None), slice(HALF, None))))
    np.testing.assert_array_equal(t2.theta, t.theta[:, HALF:])
    np.testing.assert_array_equal(t2.error, t.error[:, HALF:])
    _assert_same_state(second, one)


# ------------------------------------------------------------ (c) NaN policies
@pytest.mark.parametrize("case", [c for _, c in CASES], ids=CASE_IDS)
def test_nan_policies(case):
    Phi, y, kw = _data(case)
    for what in ("phi", "y"):
        bad_phi, bad_y = Phi[0].copy(), y[0].copy() if np.ndim(y[0]) else float(y[0])
        if what == "phi":
            bad_phi[1] = np.nan
        elif np.ndim(bad_y):
            bad_y[-1] = np.inf
        else:
            bad_y = np.inf
        strict = _make(case, "raise")
        with pytest.raises(ValueError, match=what):
            strict.update(bad_phi, bad_y)
        assert strict.n_updates == 0 and strict.n_skipped == 0
        lax = _make(case, "skip")
        before, P = lax.get_state(), _P(lax)
        e = lax.update(bad_phi, bad_y)
        assert np.isnan(e).all() and lax.n_skipped == 1 and lax.n_updates == 0
        after = lax.get_state()
        for d in (before, after):  # the counts differ, nothing else
            (d.get("inner") or d).pop("n_skipped")
        if case[1] == "kalman":
            # KalmanRLS: a missing sample gets the time update only (its docstring):
            # θ unchanged, P grows by R₁ (re-factorised: equal to rounding)
            np.testing.assert_array_equal(lax.theta, before["theta0"].reshape(lax.theta.shape))
            Q = np.broadcast_to(lax.process_cov, P.shape)
            np.testing.assert_allclose(lax.P, np.where(np.isinf(P), P, P + Q), rtol=1e-12)
            continue
        _assert_same_dict(before, after)
    Phi[4, 0] = np.nan
    strict = _make(case, "raise")
    with pytest.raises(ValueError, match="Phi"):
        strict.run(Phi, y, **kw)
    traj = _make(case, "skip").run(Phi, y, **kw)
    assert traj.skipped.tolist() == [k == 4 for k in range(N_SAMPLES)]


def test_nan_policy_is_one_of_the_known_ones():
    with pytest.raises(ValueError, match="nan_policy"):
        adaptid.estimator("rls", 2, nan_policy="ignore")


# ---------------------------------------------- (d) a refused call changes nothing
def _refusals(case, est):
    """Calls that must raise ValueError on ``est`` (single stream)."""
    Phi, y, kw = _data(case, seed=4)
    p, n = case[4], N_PARAMS
    nan_Phi = Phi.copy()
    nan_Phi[N_SAMPLES - 1, 0] = np.nan  # the last sample: the run has gone through the others
    calls = {
        "update phi too short": lambda: est.update(Phi[0, :-1], y[0]),
        "update phi too long": lambda: est.update(np.append(Phi[0], 1.0), y[0]),
        "update NaN phi": lambda: est.update(np.full(n, np.nan), y[0]),
        "update negative weight": lambda: est.update(Phi[0], y[0], weight=-1.0),
        "update y of another shape": lambda: est.update(Phi[0], np.zeros(p + 1)),
        "run Phi of another width": lambda: est.run(Phi[:, :-1], y),
        "run y of another length": lambda: est.run(Phi, y[:-1]),
        "run NaN at the end": lambda: est.run(nan_Phi, y, **kw),
        "run weights out of range": lambda: est.run(Phi, y, weights=-np.ones(N_SAMPLES)),
        "predict phi of another width": lambda: est.predict(Phi[:, :-1]),
        "run_batched NaN": lambda: est.run_batched(nan_Phi[None], y[None]),
    }
    if _per_sample_forgetting(case):
        calls["update forgetting > 1"] = lambda: est.update(Phi[0], y[0], forgetting=1.5)
        calls["run forgetting 0"] = lambda: est.run(Phi, y, forgetting=np.zeros(N_SAMPLES))
    elif case[1] != "constrained" and "forgetting" not in method_options(case[1]):
        calls["update forgetting"] = lambda: est.update(Phi[0], y[0], forgetting=0.9)
    return calls


@pytest.mark.parametrize("case", [c for _, c in CASES], ids=CASE_IDS)
def test_a_refused_call_leaves_the_state_unchanged(case):
    Phi, y, kw = _data(case, seed=3)
    est = _make(case)
    est.run(Phi[:HALF], y[:HALF], **_rows(kw, slice(None, HALF)))
    for name, call in _refusals(case, est).items():
        before = est.copy()
        with pytest.raises(ValueError):
            call()
        try:
            _assert_same_state(est, before)
        except AssertionError as err:
            raise AssertionError(f"{name}: {err}") from None
    # the estimator still works as if nothing had been tried
    ref = _make(case)
    ref.run(Phi[:HALF], y[:HALF], **_rows(kw, slice(None, HALF)))
    for e in (est, ref):
        e.run(Phi[HALF:], y[HALF:], **_rows(kw, slice(HALF, None)))
    _assert_same_state(est, ref)
    # a batched estimator refuses the single-stream calls, unchanged
    est.run_batched(Phi[None], y[None])
    for call in (lambda: est.update(Phi[0], y[0]), lambda: est.run(Phi, y)):
        before = est.copy()
        with pytest.raises(ValueError):
            call()
        _assert_same_state(est, before)


# -------------------------------------------------------------- (e) predict
@pytest.mark.parametrize("case", [c for _, c in CASES], ids=CASE_IDS)
def test_predict_shapes_and_values(case):
    p = case[4]
    out = () if p == 1 else (p,)
    Phi, y, kw = _data(case)
    est = _make(case)
    est.run(Phi, y, **kw)
    theta = est.theta
    one = est.predict(Phi[0])
    assert np.shape(one) == out
    if p == 1:
        assert type(one) is float
    np.testing.assert_array_equal(one, Phi[0] @ theta)
    many = est.predict(Phi[:5])
    assert many.shape == (5,) + out
    np.testing.assert_array_equal(many, Phi[:5] @ theta)
    PhiB, yB, kwB = _data(case, batch=N_STREAMS, seed=5)
    est.reset().run_batched(PhiB, yB, **kwB)
    assert est.predict(PhiB[:, 0]).shape == (N_STREAMS,) + out
    assert est.predict(PhiB[:, :5]).shape == (N_STREAMS, 5) + out
    np.testing.assert_allclose(est.predict(PhiB[:, 0]),
                               np.einsum("bi,bi...->b...", PhiB[:, 0], est.theta),
                               rtol=1e-13, atol=0)


# -------------------------------------------------------- (f) pickling
@pytest.mark.parametrize("case", [c for _, c in CASES], ids=CASE_IDS)
def test_pickle_round_trips(case):
    Phi, y, kw = _data(case)
    est = _make(case, "skip")
    est.run(Phi[:HALF], y[:HALF], **_rows(kw, slice(None, HALF)))
    again = pickle.loads(pickle.dumps(est))
    assert repr(again) == repr(est)
    _assert_same_state(again, est)
    fresh = pickle.loads(pickle.dumps(_make(case, "skip")))
    _assert_same_state(fresh, _make(case, "skip"))


# ------------------------------------------------------- (g) copy and reset
@pytest.mark.parametrize("case", [c for _, c in CASES], ids=CASE_IDS)
def test_copy_is_independent_and_reset_restores_the_prior(case):
    Phi, y, kw = _data(case)
    est = _make(case)
    est.run(Phi[:HALF], y[:HALF], **_rows(kw, slice(None, HALF)))
    snapshot = est.get_state()
    twin = est.copy()
    twin.run(Phi[HALF:], y[HALF:], **_rows(kw, slice(HALF, None)))
    _assert_same_dict(est.get_state(), snapshot)  # the original did not move
    est.run(Phi[HALF:], y[HALF:], **_rows(kw, slice(HALF, None)))
    _assert_same_state(est, twin)  # and follows the same path
    assert est.reset() is est
    _assert_same_state(est, _make(case))
    est.run_batched(Phi[None], y[None])
    est.reset()
    assert est.batch_size is None
    _assert_same_state(est, _make(case))
    t = est.run(Phi, y, **kw)  # after reset, a fresh estimator's run
    _assert_same_traj(t, _make(case).run(Phi, y, **kw))
