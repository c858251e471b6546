"""The structure-of-arrays RLS kernels (``_kernels/lanes/_soa.py``) against ``RLS.run``.

Oracle: ``RLS.run`` on one stream (the scalar U-D kernel of ``_kernels/recursions/_rls.py``,
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
from adaptid._kernels.lanes import _soa
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


def _routed(est, kernel):
    """A copy of ``est`` whose batched and segmented runs always take ``kernel``.

    ``kernel`` is a lane kernel (also with θ stored, which the engine itself
    leaves to the scalar kernels) or None (the scalar kernels always). The
    engine still prepares the arguments, so the kernel is called with the
    same argument types as in ordinary use and is compiled once per n.
    """
    routed = est.copy()
    routed._soa_entry = lambda *args, **kwargs: kernel
    return routed


# covariance: n = 3 forms P's rank-one term with 1/d (n <= SQRT_FREE_N), n = 5 with
# c = u/sqrt(d) (_kernels/lanes/_soa_cov.py)
@pytest.mark.parametrize("n, form", [(1, "ud"), (3, "ud"), (8, "ud"), (3, "covariance"),
                                     (5, "covariance")])
def test_batched_equals_run_per_stream(n, form):
    rng = np.random.default_rng(n)
    B, N = 2 * _soa.LANES + 5, 70  # not a multiple of the lanes: a padded block
    Phi, y, w, lam = _data(rng, B, N, n)
    est = adaptid.RLS(n, forgetting=0.98, P0=100.0, nan_policy="skip", form=form,
                      theta0=rng.standard_normal(n))
    lanes = _soa.cov_soa_batched if form == "covariance" else _soa.rls_soa_batched
    assert est._soa_entry("batched", B) is lanes
    assert est._soa_entry("batched", B, store=True) is None  # θ per sample: the old kernel
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", adaptid.CovarianceWindupWarning)
        bat = est.copy()
        tb = bat.run_batched(Phi, y, weights=w, forgetting=lam, store=False)
        # the lane kernel with θ stored
        stored = _routed(est, lanes)
        ts = stored.run_batched(Phi, y, weights=w, forgetting=lam, store=True)
        for s in range(B):
            one = est.copy()
            tr = one.run(Phi[s], y[s], weights=w[s], forgetting=lam[s])
            assert _same(ts.theta[s], tr.theta), s
            assert _same(tb.error[s], tr.error), s
            assert np.array_equal(tb.skipped[s], tr.skipped), s
            assert _same(bat.theta[s], one.theta), s
            assert _same(bat.P[s], one.P), s
            assert _same(stored.theta[s], one.theta), s
            assert _same(stored.P[s], one.P), s
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


def test_windup_codes_equal():
    # λ = 0.5 with a small threshold: pivots pass it at different samples per stream
    rng = np.random.default_rng(3)
    B, N, n = _soa.LANES + 3, 60, 3
    Phi, y, w, lam = _data(rng, B, N, n)
    Phi[:, :, 2] *= rng.random((B, 1)) < 0.5  # half the streams never excite direction 2
    lam = np.full((B, N), 0.5)
    est = adaptid.RLS(n, P0=1.0, windup_threshold=1e3, nan_policy="skip")
    runs, codes, caught = [], [], []
    for kernel in (None, _soa.rls_soa_batched):  # the scalar kernel, then the lanes
        routed = _routed(est, kernel)
        report = routed._report_codes  # record the kernel's per-stream codes on the way

        def record(c, where, report=report):
            codes.append(np.array(c))
            return report(c, where)

        routed._report_codes = record
        with pytest.warns(adaptid.CovarianceWindupWarning) as got:
            tr = routed.run_batched(Phi, y, weights=w, forgetting=lam, store=False)
        runs.append((tr.error, tr.skipped, routed.theta, routed.P))
        caught.append([str(x.message) for x in got])
    for x, z in zip(*runs):
        assert _same(x, z)
    assert np.array_equal(codes[0], codes[1]) and caught[0] == caught[1]
    wound = codes[1] >= 0
    assert wound.any() and wound.sum() < B  # some streams wound up, some not
    first = int(np.argmax(wound))
    assert f"{int(codes[1][first])} of stream {first}" in caught[1][0]


def _offsets(rng, G):
    lengths = rng.integers(0, 40, G)
    lengths[:4] = [0, 1, 0, 1]
    lengths[4] = 97  # one long segment beside many short ones
    rng.shuffle(lengths)
    return np.concatenate([[0], np.cumsum(lengths)])


# n = 3 as the other segment tests: one compilation of the lane kernel for
# segments (n = 1 and 8 of the lane steps it shares are in the batched test)
@pytest.mark.parametrize("n", [3])
@pytest.mark.parametrize("store, form", [(False, "ud"), (True, "ud"), (False, "covariance")])
def test_segments_equal_run_per_segment(n, store, form):
    rng = np.random.default_rng(10 + n)
    G = 4 * _soa.LANES + 3
    off = _offsets(rng, G)
    Phi, y, w, _ = _data(rng, 1, int(off[-1]), n)
    Phi, y, w = Phi[0], y[0], w[0]
    est = adaptid.RLS(n, forgetting=0.95, P0=1e3, nan_policy="skip", form=form)
    lanes = _soa.cov_soa_segments if form == "covariance" else _soa.rls_soa_segments
    assert est._soa_entry("segments", G) is lanes
    assert est._soa_entry("segments", G, store=True) is None  # θ per sample: the old kernel
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", adaptid.CovarianceWindupWarning)
        # with θ stored the engine itself takes the old kernel: route it to the lanes
        routed = _routed(est, lanes) if store else est
        res = routed.run_segments(Phi, y, off, weights=w, store=store)
        for g in range(G):
            a, z = off[g], off[g + 1]
            one = est.copy().reset()
            tr = one.run(Phi[a:z], y[a:z], weights=w[a:z])
            assert _same(res.theta[g], one.theta), g
            assert _same(res.error[a:z], tr.error), g
            assert np.array_equal(res.skipped[a:z], tr.skipped), g
            assert _same(res.P[g], one.P), g
            assert res.n_skipped[g] == one.n_skipped
            if store:
                assert _same(res.theta_track[a:z], tr.theta), g


def test_segments_status_equal():
    rng = np.random.default_rng(5)
    G = 2 * _soa.LANES + 1
    off = _offsets(rng, G)
    n = 3
    Phi, y, w, _ = _data(rng, 1, int(off[-1]), n)
    Phi, y, w = Phi[0], y[0], w[0]
    Phi[:, 1] *= np.repeat(rng.random(G) < 0.5, np.diff(off))
    est = adaptid.RLS(n, forgetting=0.5, P0=1.0, windup_threshold=1e3, nan_policy="skip")
    out = []
    for kernel in (None, _soa.rls_soa_segments):  # the scalar kernel, then the lanes
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", adaptid.CovarianceWindupWarning)
            res = _routed(est, kernel).run_segments(Phi, y, off, weights=w)
        out.append(res)
    for field in ("theta", "P", "n_samples", "n_skipped", "sse", "error", "skipped", "status"):
        assert _same(getattr(out[0], field), getattr(out[1], field)), field
    status = out[1].status
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


# --- the covariance form's lanes (_kernels/lanes/_soa_cov.py) ---
def _covariance_codes(est, kernel, what, *args):
    """Run ``what`` routed to ``kernel`` (None: the scalar kernels); its result and the
    kernel's per-stream codes."""
    routed = _routed(est, kernel)
    codes = []
    report = routed._report_codes

    def record(c, where):
        codes.append(np.array(c))
        return report(c, where)

    routed._report_codes = record
    if what == "segments":
        routed._warn_segments = lambda status: codes.append(np.array(status))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = getattr(routed, f"run_{what}")(*args)
    return routed, out, codes[-1]


def test_covariance_lanes_rerun_what_the_scalar_kernel_repairs():
    # λ = 0.5 and a direction that is never excited: P loses definiteness in floating
    # point and the scalar kernel repairs it (test_rls_forms); the lanes leave such a
    # stream to it. Half the streams are of that kind, half are not.
    # (n = 3 as the tests above: the same compiled kernels)
    rng = np.random.default_rng(4)
    B, N, n = 2 * _soa.LANES + 1, 200, 3
    u = rng.standard_normal((B, N))
    Phi = np.stack([u, u, rng.standard_normal((B, N))], axis=2)
    Phi[::2, :, 1] = rng.standard_normal((len(range(0, B, 2)), N))  # excited: no repair
    y = Phi @ np.array([1.0, 2.0, -1.0])
    est = adaptid.RLS(n, forgetting=0.5, P0=1.0, windup_threshold=np.inf, form="covariance")
    runs = [_covariance_codes(est, k, "batched", Phi, y) for k in (None, _soa.cov_soa_batched)]
    (r0, t0, c0), (r1, t1, c1) = runs
    assert _same(t0.error, t1.error) and _same(r0.P, r1.P) and _same(r0.theta, r1.theta)
    assert np.array_equal(c0, c1)
    repaired = c1 <= -2
    assert repaired[1::2].all() and not repaired[::2].any()
    # segments: the same streams back to back
    off = np.arange(B + 1) * N
    segs = [_covariance_codes(est, k, "segments", Phi.reshape(-1, n), y.ravel(), off)
            for k in (None, _soa.cov_soa_segments)]
    (_, s0, c0), (_, s1, c1) = segs
    for field in ("theta", "P", "error", "skipped", "sse"):
        assert _same(getattr(s0, field), getattr(s1, field)), field
    assert np.array_equal(c0, c1) and (c1[1::2] <= -2).all()


def test_covariance_lanes_rerun_a_state_whose_P_is_not_exactly_symmetric():
    # a state P that is symmetric only to rounding (e.g. written by another tool): the
    # scalar kernel updates both triangles, the lanes keep one, so that stream is rerun
    rng = np.random.default_rng(8)
    B, N, n = _soa.MIN_STREAMS, 40, 3
    Phi = rng.standard_normal((B, N, n))
    y = Phi @ rng.standard_normal(n)
    est = adaptid.RLS(n, forgetting=0.99, P0=10.0, form="covariance")
    est.run_batched(Phi[:, :20], y[:, :20], store=False)
    S = est._S
    k = n + 0 * n + 1  # P[0, 1] of the flat state [θ | P | 0] of stream 3
    S[3, k] = np.nextafter(S[3, k], np.inf)
    out = []
    for kernel in (None, _soa.cov_soa_batched):
        routed = _routed(est, kernel)
        tr = routed.run_batched(Phi[:, 20:], y[:, 20:], store=False)
        out.append((tr.error, routed._S))
    assert _same(out[0][0], out[1][0]) and _same(out[0][1], out[1][1])
    assert out[1][1][3, n + 1] != out[1][1][3, n + n]  # it stayed asymmetric (scalar rule)
