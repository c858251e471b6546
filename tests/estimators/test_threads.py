"""Estimators and threads (issue 32, point 8), with real threads.

An estimator is not thread-safe and says so: a call of ``update``, ``run`` or
``run_batched`` made while another call on the same object runs raises a
RuntimeError naming the estimator, and leaves the state as the running call
makes it (the oracle: the same run on a fresh estimator, alone). Separate
estimators in separate threads give the results of sequential runs. Under
numba's workqueue threading layer, which aborts the process when two threads
enter parallel code at once, parallel calls are serialised (a child process,
because the layer is chosen once per process).
"""

import os
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import adaptid


def _data(N, n=3, seed=0):
    rng = np.random.default_rng(seed)
    Phi = rng.standard_normal((N, n))
    return Phi, Phi @ np.array([1.0, -2.0, 0.5][:n]) + 0.01 * rng.standard_normal(N)


def _while_busy(est, call):
    """Start ``call`` in a thread; return once ``est`` is inside it (and the thread)."""
    t = threading.Thread(target=call)
    t.start()
    deadline = time.monotonic() + 60
    while not est._busy and t.is_alive() and time.monotonic() < deadline:
        time.sleep(0)
    return t


@pytest.mark.parametrize("make", [lambda: adaptid.RLS(3), lambda: adaptid.NLMS(3, step=0.5),
                                  lambda: adaptid.SlidingWindowRLS(3, 50)],
                         ids=["RLS", "NLMS", "SlidingWindowRLS"])
def test_concurrent_calls_on_one_estimator_are_refused(make):
    Phi, y = _data(2_000_000)
    est = make()
    est.run(Phi[:10], y[:10])  # compiled before the race
    ref = make()
    ref.run(Phi[:10], y[:10])
    ref.run(Phi, y, store=False)
    t = _while_busy(est, lambda: est.run(Phi, y, store=False))
    caught = []
    while t.is_alive():
        for call in (lambda: est.update(Phi[0], y[0]), lambda: est.run(Phi[:5], y[:5]),
                     lambda: est.run_batched(Phi[None, :5], y[None, :5])):
            try:
                call()
            except RuntimeError as exc:
                caught.append(str(exc))
        if len(caught) >= 3:
            break
    t.join()
    name = type(est).__name__
    assert len(caught) >= 3, "the run ended before the concurrent calls: make N larger"
    assert all(f"{name}." in m and "not thread-safe" in m for m in caught)
    assert {m.split("(")[0] for m in caught} >= {f"{name}.update", f"{name}.run",
                                                 f"{name}.run_batched"}
    # the refused calls changed nothing: the state is that of the one run
    assert np.array_equal(est.theta, ref.theta)
    assert est.n_updates == ref.n_updates
    est.update(Phi[0], y[0])  # and the estimator is free again


def test_a_failed_call_frees_the_estimator():
    est = adaptid.RLS(3)
    with pytest.raises(ValueError, match="Phi"):
        est.run(np.ones((4, 2)), np.ones(4))
    with pytest.raises(ValueError, match="phi"):
        est.update([np.nan, 1.0, 2.0], 1.0)
    assert not est._busy
    est.update([1.0, 2.0, 3.0], 1.0)
    assert est.n_updates == 1


def test_separate_estimators_in_threads_equal_sequential_runs():
    datas = [_data(20_000, seed=s) for s in range(4)]
    seq = [adaptid.RLS(3, forgetting=0.999).run(P, y).theta for P, y in datas]
    out = [None] * 4

    def work(i):
        P, y = datas[i]
        est = adaptid.RLS(3, forgetting=0.999)
        est.run_batched(P[None], y[None])
        out[i] = est.theta[0]
    ts = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    for got, want in zip(out, seq):
        assert np.array_equal(got, want[-1])


_WORKQUEUE = textwrap.dedent("""
    import threading, numpy as np, numba, adaptid
    rng = np.random.default_rng(0)
    Phi = rng.standard_normal((8, 400, 3)); y = Phi @ np.array([1.0, 2.0, 3.0])
    flat, flat_y = Phi.reshape(-1, 3), y.reshape(-1)
    offsets = np.arange(0, 3201, 400)
    want = adaptid.RLS(3).run_segments(flat, flat_y, offsets).theta
    assert numba.threading_layer() == "workqueue", numba.threading_layer()
    fast_want = adaptid.FastRLS(3, track_theta=False)
    fast_want.run_fir(Phi[:, :, 0], y)
    fast_want = fast_want.theta
    bad = []
    def work():
        for _ in range(25):
            est = adaptid.RLS(3)
            est.run_batched(Phi, y, store=False)
            got = adaptid.RLS(3).run_segments(flat, flat_y, offsets).theta
            if not (np.array_equal(est.theta, want) and np.array_equal(got, want)):
                bad.append(1)
            fast = adaptid.FastRLS(3, track_theta=False)
            fast.run_fir(Phi[:, :, 0], y)  # FastRLS's own parallel kernel
            if not np.array_equal(fast.theta, fast_want):
                bad.append(2)
    ts = [threading.Thread(target=work) for _ in range(4)]
    [t.start() for t in ts]; [t.join() for t in ts]
    print("ok", len(bad))
""")


def test_workqueue_layer_with_threads_does_not_abort():
    env = dict(os.environ, NUMBA_THREADING_LAYER="workqueue", NUMBA_NUM_THREADS="2")
    src = os.path.join(os.path.dirname(adaptid.__file__), os.pardir)
    env["PYTHONPATH"] = os.path.abspath(src) + os.pathsep + env.get("PYTHONPATH", "")
    res = subprocess.run([sys.executable, "-c", _WORKQUEUE], env=env, capture_output=True,
                         text=True, timeout=600)
    # before: SIGABRT (-6) with "Concurrent access has been detected"
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.split() == ["ok", "0"]


def test_fastrls_concurrent_calls_are_refused():
    """FastRLS (its own class, not the engine's) detects concurrent use the same way."""
    rng = np.random.default_rng(1)
    u = rng.standard_normal(3_000_000)
    y = np.convolve(u, [0.5, -0.3, 0.2])[:u.shape[0]]
    est = adaptid.FastRLS(3, forgetting=0.999, track_theta=False)
    est.run_fir(u[:10], y[:10])
    ref = adaptid.FastRLS(3, forgetting=0.999, track_theta=False)
    ref.run_fir(u[:10], y[:10])
    ref.run_fir(u[10:], y[10:])
    t = _while_busy(est, lambda: est.run_fir(u[10:], y[10:]))
    caught = []
    while t.is_alive() and len(caught) < 2:
        for call in (lambda: est.run_fir(u[:5], y[:5]),
                     lambda: est.run_fir(u[None, :5], y[None, :5])):
            try:
                call()
            except RuntimeError as exc:
                caught.append(str(exc))
    t.join()
    assert len(caught) >= 2, "the run ended before the concurrent calls: make N larger"
    assert all("FastRLS." in m and "not thread-safe" in m for m in caught)
    assert np.array_equal(est.theta, ref.theta) and est.n_updates == ref.n_updates
