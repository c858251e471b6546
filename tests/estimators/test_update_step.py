"""update through its narrow step entry (adaptid._kernels.recursions._step) against run.

DESIGN.md: "``run`` must give bit-for-bit the same result as calling ``update`` N
times". With the step entry compiled (``compile_update``), ``update`` takes it;
these tests hold it to ``run``'s bits for every form that has one, with per-sample
weights and forgetting, several outputs, skipped samples, a state file in the
middle, and the warnings ``run`` gives; and check when it is (not) taken.
"""

import warnings

import numpy as np
import pytest

import adaptid
from adaptid import CovarianceWindupWarning
from adaptid._kernels.toolchain._patches import enabled

#: the tests that need the step entry (patch ``step-entry``); with it switched off
#: (ADAPTID_NUMBA_PATCHES=0, .ci/run) ``update`` is always a run of length 1
needs_step = pytest.mark.skipif(not enabled("step-entry"),
                                reason="patch step-entry is off: no step entry to test")

# (form, n): the U-D stream, Potter's square-root form, the covariance form
CASES = [("ud", 4), ("sqrt", 17), ("covariance", 3)]


def _data(n, p, N=300, seed=0):
    rng = np.random.default_rng(seed)
    Phi = rng.standard_normal((N, n))
    theta = rng.standard_normal((n, p))
    Y = Phi @ theta + 0.05 * rng.standard_normal((N, p))
    w = rng.uniform(0.2, 2.0, N)
    w[::17] = 0.0  # a weight-0 sample only advances the forgetting
    lam = rng.uniform(0.95, 1.0, N)
    return Phi, (Y[:, 0] if p == 1 else Y), w, lam


def _estimator(form, n, p, **kw):
    return adaptid.RLS(n, forgetting=0.99, form=form, n_outputs=None if p == 1 else p, **kw)


def _same(a, b):
    assert np.array_equal(a.theta, b.theta) and np.array_equal(a.P, b.P)
    assert a.n_updates == b.n_updates


@needs_step
@pytest.mark.parametrize("form,n", CASES)
@pytest.mark.parametrize("p", [1, 2])
def test_update_through_the_step_entry_is_run_bit_for_bit(form, n, p):
    Phi, Y, w, lam = _data(n, p)
    ref = _estimator(form, n, p)
    tr = ref.run(Phi, Y, weights=w, forgetting=lam)
    est = _estimator(form, n, p)
    assert est.compile_update() is True
    errors = []
    for k in range(len(w)):
        errors.append(est.update(Phi[k], Y[k], weight=float(w[k]), forgetting=float(lam[k])))
        assert est._step.step_ep is not None  # the step entry, every sample
    _same(est, ref)
    assert np.array_equal(np.array(errors).reshape(tr.error.shape), tr.error)


@needs_step
@pytest.mark.parametrize("form,n", CASES)
def test_skipped_samples_and_a_state_file_in_the_middle(form, n, tmp_path):
    Phi, y, _, _ = _data(n, 1, N=120, seed=3)
    Phi[10, 1] = np.nan
    y[40] = np.inf
    ref = _estimator(form, n, 1, nan_policy="skip")
    tr = ref.run(Phi, y)
    est = _estimator(form, n, 1, nan_policy="skip")
    est.compile_update()
    err = [est.update(Phi[k], y[k]) for k in range(60)]
    est.save_state(tmp_path / "s.adaptid")
    est = adaptid.RLS.load_state(tmp_path / "s.adaptid")  # a new state array: looked up again
    err += [est.update(Phi[k], y[k]) for k in range(60, 120)]
    assert est._step.step_ep is not None
    _same(est, ref)
    assert np.array_equal(np.array(err), tr.error, equal_nan=True)
    assert np.isnan(err[10]) and np.isnan(err[40])
    assert est.n_skipped == ref.n_skipped == 2


@pytest.mark.parametrize("form,n", CASES)
def test_a_refused_sample_leaves_the_state_unchanged(form, n):
    Phi, y, _, _ = _data(n, 1, N=20)
    est = _estimator(form, n, 1)
    est.compile_update()
    for k in range(10):
        est.update(Phi[k], y[k])
    before = est.get_state()
    bad = Phi[10].copy()
    bad[0] = np.nan
    with pytest.raises(ValueError, match="phi"):
        est.update(bad, y[10])
    with pytest.raises(ValueError, match="y"):
        est.update(Phi[10], np.nan)
    with pytest.raises(ValueError, match="phi"):
        est.update(Phi[10][:-1], y[10])  # wrong length
    after = est.get_state()
    assert all(np.array_equal(before[k], after[k]) for k in before if isinstance(before[k], np.ndarray))
    ref = _estimator(form, n, 1)
    ref.run(Phi[:11], y[:11])
    est.update(Phi[10], y[10])
    _same(est, ref)


def _messages(est, Phi, y, category):
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        for k in range(len(y)):
            est.update(Phi[k], y[k])
    return [str(w.message) for w in got if issubclass(w.category, category)]


@needs_step
def test_the_windup_warning_is_that_of_update_through_run(monkeypatch):
    """No excitation of the second parameter under forgetting: its pivot passes the
    threshold. The step entry warns as an update through run's entry does, at the
    same sample, and ends in run's bits."""
    from adaptid._kernels.recursions import _step
    N = 400
    Phi = np.column_stack([np.ones(N), np.zeros(N)])
    y = np.ones(N)
    ref = adaptid.RLS(2, forgetting=0.9)
    with pytest.warns(CovarianceWindupWarning):
        ref.run(Phi, y)
    est = adaptid.RLS(2, forgetting=0.9)
    assert est.compile_update()
    fast = _messages(est, Phi, y, CovarianceWindupWarning)
    assert est._step.step_ep is not None
    _same(est, ref)
    monkeypatch.setattr(_step, "entry_point", lambda disp, args: None)
    slow = adaptid.RLS(2, forgetting=0.9)
    assert _messages(slow, Phi, y, CovarianceWindupWarning) == fast and len(fast) == 1
    assert slow._step.step_ep is None


def test_estimators_without_a_step_entry_say_so():
    assert adaptid.SlidingWindowRLS(3, 20).compile_update() is False
    assert adaptid.KalmanRLS(3, process_cov=1e-4).compile_update() is False
    assert adaptid.LMS(3, step=0.1).compile_update() is False
    assert adaptid.RLS(3, forgetting=adaptid.forgetting.EFRA(), P0=1.0).compile_update() is False
    assert adaptid.RLS(3, P0="diffuse").compile_update() is False
    est = adaptid.RLS(3)
    est.run_batched(np.ones((2, 4, 3)), np.ones((2, 4)))
    assert est.compile_update() is False


def test_the_step_entry_is_taken_only_when_it_costs_no_compilation(monkeypatch):
    """Found in this process or a cache: taken. Not found: update does not compile
    it, and goes through run's entry."""
    from adaptid._kernels.recursions import _step
    est = adaptid.RLS(5, form="ud")
    calls = []
    monkeypatch.setattr(_step, "entry_point", lambda disp, args: calls.append(disp) or None)
    Phi, y, _, _ = _data(5, 1, N=30)
    err = [est.update(Phi[k], y[k]) for k in range(30)]
    steps = lambda: [d for d in calls if d is est._kern.step]  # noqa: E731
    assert len(steps()) == 1 and est._step.step_ep is None  # looked up once per state array
    ref = adaptid.RLS(5, form="ud")
    tr = ref.run(Phi, y)
    _same(est, ref)
    assert np.array_equal(np.array(err), tr.error)
    est.reset()  # a new state array: looked up again
    est.update(Phi[0], y[0])
    assert len(steps()) == 2


@needs_step
def test_a_new_windup_threshold_reaches_the_step_entry(monkeypatch):
    """windup_threshold set between updates: the packed sample carries the new one."""
    from adaptid._kernels.recursions import _step
    Phi, y, _, _ = _data(4, 1, N=40, seed=5)

    def messages(est):
        for k in range(20):
            est.update(Phi[k], y[k])
        est.windup_threshold = 1e-3  # below the pivots of P: the next update passes it
        return _messages(est, Phi[20:], y[20:], CovarianceWindupWarning)

    fast = adaptid.RLS(4, forgetting=0.99)
    assert fast.compile_update()
    got = messages(fast)
    assert fast._step.step_ep is not None and got and "sample 21" in got[0]
    monkeypatch.setattr(_step, "entry_point", lambda disp, args: None)
    slow = adaptid.RLS(4, forgetting=0.99)
    assert messages(slow) == got
    _same(fast, slow)
