"""The structure-of-arrays RLS kernels (``_kernels/_soa.py``) against ``RLS.run``.

Oracle: ``RLS.run`` on one stream (the scalar U-D kernel of ``_kernels/_rls.py``,
not written with the lane kernels): every stream of ``run_batched`` and every
segment of ``run_segments`` must equal it bit for bit (``np.array_equal``, NaN
where the run has NaN), because the lane kernels do the same floating-point
operations in the same order per stream. A tolerance would hide a change of
operation order, so there is none. Each test also checks that the engine
really took the lane kernels (or, for the cases they do not cover, did not).
"""

import warnings

import numpy as np
import pytest

import adaptid
from adaptid import _kernels
from adaptid._kernels import _rls, _soa
from adaptid.forgetting import Directional

pytestmark = pytest.mark.skipif(
    not isinstance(_kernels.tags(2, 1)[0], tuple),
    reason="the lane kernels need compile-time n (tuple tags); off with NUMBA_DISABLE_JIT=1")


def _data(rng, B, N, n, nan_frac=0.05, zero_w_frac=0.1):
    Phi = rng.standard_normal((B, N, n))
    theta = rng.standard_normal(n)
    y = Phi @ theta + 0.1 * rng.standard_normal((B, N))
    Phi[rng.random((B, N)) < nan_frac, rng.integers(0, n)] = np.nan
    y[rng.random((B, N)) < nan_frac] = np.nan
    Phi[rng.random((B, N)) < nan_frac / 2, 0] = np.inf
    w = rng.uniform(0.5, 2.0, (B, N))
    w[rng.random((B, N)) < zero_w_frac] = 0.0
    lam = rng.uniform(0.9, 1.0, (B, N))
    return Phi, y, w, lam


def _same(a, b):
    return np.array_equal(a, b, equal_nan=True)


@pytest.mark.parametrize("n", [1, 3, 8])
def test_batched_equals_run_per_stream(n):
    rng = np.random.default_rng(n)
    B, N = 2 * _soa.LANES + 5, 70  # not a multiple of the lanes: a padded block
    Phi, y, w, lam = _data(rng, B, N, n)
    est = adaptid.RLS(n, forgetting=0.98, P0=100.0, nan_policy="skip",
                      theta0=rng.standard_normal(n))
    assert est._soa_entry("batched", B) is _soa.rls_soa_batched
    assert est._soa_entry("batched", B, store=True) is None  # θ per sample: the old kernel
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", adaptid.CovarianceWindupWarning)
        bat = est.copy()
        tb = bat.run_batched(Phi, y, weights=w, forgetting=lam, store=False)
        # the lane kernel with θ stored, called directly
        args = _kernel_args(est, Phi, y, w, lam)
        _soa.rls_soa_batched(*args)
        for s in range(B):
            one = est.copy()
            tr = one.run(Phi[s], y[s], weights=w[s], forgetting=lam[s])
            assert _same(args[5][s, :, :, 0], tr.theta), s
            assert _same(tb.error[s], tr.error), s
            assert np.array_equal(tb.skipped[s], tr.skipped), s
            assert _same(bat.theta[s], one.theta), s
            assert _same(bat.P[s], one.P), s
    assert tb.skipped.any() and (w == 0).any()  # the cases were exercised


def test_batched_constant_weights_and_forgetting_and_continuation():
    # scalar λ and w (broadcast: reciprocals taken once), no store, then a second call
    rng = np.random.default_rng(7)
    B, N, n = 3 * _soa.LANES, 45, 3
    Phi, y, _, _ = _data(rng, B, N, n, nan_frac=0.0)
    est = adaptid.RLS(n, forgetting=0.97, P0=1e4)
    bat = est.copy()
    t1 = bat.run_batched(Phi[:, :20], y[:, :20], weights=2.0, store=False)
    t2 = bat.run_batched(Phi[:, 20:], y[:, 20:], weights=2.0, store=False)
    for s in range(B):
        one = est.copy()
        r1 = one.run(Phi[s, :20], y[s, :20], weights=2.0)
        r2 = one.run(Phi[s, 20:], y[s, 20:], weights=2.0)
        assert t1.theta.shape[1] == 0
        assert _same(t1.error[s], r1.error) and _same(t2.error[s], r2.error)
        assert _same(bat.theta[s], one.theta) and _same(bat.P[s], one.P)


def _kernel_args(est, Phi, y, w, lam):
    B, N, n = Phi.shape
    S = np.repeat(est.get_state()["state"][None, :], B, axis=0)
    return (S, Phi, y[..., None], lam, w, np.empty((B, N, n, 1)), np.empty((B, N, 1)),
            np.zeros((B, N), dtype=np.bool_), np.empty((B, 0)), est._opt, est._mat,
            np.empty(B, dtype=np.int64), est._ntag, est._ptag)


def test_windup_codes_equal():
    # λ = 0.5 with a small threshold: pivots pass it at different samples per stream
    rng = np.random.default_rng(3)
    B, N, n = _soa.LANES + 3, 60, 3
    Phi, y, w, lam = _data(rng, B, N, n)
    Phi[:, :, 2] *= rng.random((B, 1)) < 0.5  # half the streams never excite direction 2
    lam = np.full((B, N), 0.5)
    est = adaptid.RLS(n, P0=1.0, windup_threshold=1e3, nan_policy="skip")
    a = _kernel_args(est, Phi, y, w, lam)
    b = _kernel_args(est, Phi, y, w, lam)
    _rls.rls_run_batched(*a[:9], None, *a[9:])  # St: no statistics
    _soa.rls_soa_batched(*b)
    for x, z in zip(a, b):
        assert _same(x, z)
    codes = a[11]
    assert (codes >= 0).any() and (codes >= 0).sum() < B  # some streams wound up, some not
    with pytest.warns(adaptid.CovarianceWindupWarning) as soa_w:
        est.copy().run_batched(Phi, y, weights=w, forgetting=lam, store=False)
    first = int(np.argmax(codes >= 0))
    assert f"{int(codes[first])} of stream {first}" in str(soa_w[0].message)


def _offsets(rng, G):
    lengths = rng.integers(0, 40, G)
    lengths[:4] = [0, 1, 0, 1]
    lengths[4] = 97  # one long segment beside many short ones
    rng.shuffle(lengths)
    return np.concatenate([[0], np.cumsum(lengths)])


@pytest.mark.parametrize("n", [1, 5])
@pytest.mark.parametrize("store", [False, True])
def test_segments_equal_run_per_segment(n, store):
    rng = np.random.default_rng(10 + n)
    G = 4 * _soa.LANES + 3
    off = _offsets(rng, G)
    Phi, y, w, _ = _data(rng, 1, int(off[-1]), n)
    Phi, y, w = Phi[0], y[0], w[0]
    est = adaptid.RLS(n, forgetting=0.95, P0=1e3, nan_policy="skip")
    assert est._soa_entry("segments", G) is _soa.rls_soa_segments
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", adaptid.CovarianceWindupWarning)
        if store:  # the engine stores θ with the old kernel: call the lane kernel directly
            res = _segment_kernel_result(est, _soa.rls_soa_segments, Phi, y, off, w)
        else:
            res = est.run_segments(Phi, y, off, weights=w)
        for g in range(G):
            a, z = off[g], off[g + 1]
            one = est.copy().reset()
            tr = one.run(Phi[a:z], y[a:z], weights=w[a:z])
            assert _same(res.theta[g], one.theta), g
            assert _same(res.error[a:z], tr.error), g
            assert np.array_equal(res.skipped[a:z], tr.skipped), g
            if store:
                assert _same(res.theta_track[a:z], tr.theta), g
            else:
                assert _same(res.P[g], one.P), g
                assert res.n_skipped[g] == one.n_skipped


def _segment_kernel_result(est, kern, Phi, y, off, w):
    """A segmented run through ``kern`` with θ stored (fields as SegmentResult's)."""
    from types import SimpleNamespace
    G, N, n = off.size - 1, Phi.shape[0], Phi.shape[1]
    S0 = est.get_state()["state"]
    Sout, Th, E = np.empty((G, S0.size)), np.empty((N, n, 1)), np.empty((N, 1))
    sk = np.zeros(N, dtype=np.bool_)
    kern(S0, Sout, Phi, y[:, None], off, np.full(N, est.forgetting), w, Th, E, sk,
         np.empty(0), est._opt, est._mat, np.empty(G, dtype=np.int64), est._ntag, est._ptag)
    return SimpleNamespace(theta=Sout[:, :n], error=E[:, 0], skipped=sk, theta_track=Th[..., 0])


def test_segments_status_equal():
    rng = np.random.default_rng(5)
    G = 2 * _soa.LANES + 1
    off = _offsets(rng, G)
    Phi, y, w, _ = _data(rng, 1, int(off[-1]), 2)
    Phi = Phi[0]
    Phi[:, 1] *= np.repeat(rng.random(G) < 0.5, np.diff(off))
    est = adaptid.RLS(2, forgetting=0.5, P0=1.0, windup_threshold=1e3, nan_policy="skip")
    S0 = est.get_state()["state"]
    out = []
    for kern in (_rls.rls_run_segments, _soa.rls_soa_segments):
        N = Phi.shape[0]
        args = (S0, np.empty((G, S0.size)), Phi, y[0][:, None], off, np.full(N, 0.5),
                w[0], np.empty((0, 2, 1)), np.empty((N, 1)), np.zeros(N, dtype=np.bool_),
                np.empty(0), est._opt, est._mat, np.empty(G, dtype=np.int64), est._ntag,
                est._ptag)
        if kern is _rls.rls_run_segments:
            kern(*args[:11], None, *args[11:])  # St: no statistics
        else:
            kern(*args)
        out.append(args)
    for x, z in zip(*out):
        assert _same(x, z)
    status = out[0][13]
    assert (status >= 0).any() and (status < 0).any()


def test_segments_all_empty_and_none():
    est = adaptid.RLS(3, forgetting=0.99)
    res = est.run_segments(np.empty((0, 3)), np.empty(0), np.zeros(_soa.MIN_STREAMS + 1,
                                                                     dtype=int))
    assert np.array_equal(res.theta, np.zeros((_soa.MIN_STREAMS, 3)))
    assert np.array_equal(res.status, np.full(_soa.MIN_STREAMS, -1))


def test_not_routed_where_not_covered():
    n, B = 3, 2 * _soa.MIN_STREAMS
    # several outputs, a forgetting strategy, too few streams, n too large, other algorithms
    assert adaptid.RLS(n, n_outputs=2)._soa_entry("batched", B) is None
    assert adaptid.RLS(n, forgetting=Directional(0.98))._soa_entry("batched", B) is None
    assert adaptid.RLS(n, P_max=1e6)._soa_entry("batched", B) is None
    assert adaptid.RLS(n)._soa_entry("batched", _soa.MIN_STREAMS - 1) is None
    assert adaptid.RLS(_soa.MAX_N + 1)._soa_entry("segments", B) is None
    assert adaptid.KalmanRLS(n, process_cov=1e-3)._soa_entry("batched", B) is None


def test_several_outputs_old_path_equals_run():
    rng = np.random.default_rng(11)
    B, N, n = _soa.MIN_STREAMS + 1, 30, 3
    Phi = rng.standard_normal((B, N, n))
    Y = rng.standard_normal((B, N, 2))
    est = adaptid.RLS(n, n_outputs=2, forgetting=0.99)
    tb = est.copy().run_batched(Phi, Y)
    for s in range(B):
        tr = est.copy().run(Phi[s], Y[s])
        assert _same(tb.theta[s], tr.theta) and _same(tb.error[s], tr.error)
