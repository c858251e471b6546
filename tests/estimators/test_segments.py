"""run_segments: many streams back to back equal each stream run alone."""

import numpy as np
import pytest

import adaptid


def _streams(rng, n, lens, p=None):
    off = np.concatenate([[0], np.cumsum(lens)]).astype(np.int64)
    Phi = rng.standard_normal((off[-1], n))
    theta = np.arange(1.0, n + 1) if p is None else rng.standard_normal((n, p))
    y = Phi @ theta + 0.1 * rng.standard_normal(off[-1] if p is None else (off[-1], p))
    return Phi, y, off


MAKERS = {
    "rls": lambda n, **kw: adaptid.RLS(n, forgetting=0.99, **kw),
    "window": lambda n, **kw: adaptid.SlidingWindowRLS(n, 20, forgetting=0.999, **kw),
    "kalman": lambda n, **kw: adaptid.KalmanRLS(n, process_cov=1e-4, **kw),
}


@pytest.mark.parametrize("kind", sorted(MAKERS))
@pytest.mark.parametrize("p", [None, 2])
def test_segments_equal_single_runs_bit_for_bit(rng, kind, p):
    n = 3
    lens = [0, 5, 300, 1, 250, 77, 0]
    Phi, y, off = _streams(rng, n, lens, p)
    est = MAKERS[kind](n, n_outputs=p)
    est.run(Phi[:10], y[:10])  # the template's own state must not matter
    before = est.get_state()
    res = est.run_segments(Phi, y, off, store=True)
    assert np.array_equal(est.get_state()["state"], before["state"])
    assert len(res) == len(lens)
    for g in range(len(lens)):
        a, b = off[g], off[g + 1]
        alone = est.copy().reset()
        tr = alone.run(Phi[a:b], y[a:b])
        assert np.array_equal(alone.theta, res.theta[g])
        assert np.array_equal(alone.P, res.P[g])
        assert np.array_equal(tr.error, res.error[a:b])
        assert np.array_equal(tr.theta, res.theta_track[a:b])
        assert res.n_samples[g] == b - a and res.n_skipped[g] == 0
        np.testing.assert_allclose(res.sse[g], np.sum(tr.error ** 2, axis=0), rtol=1e-12)


def test_segments_skip_counts_per_segment(rng):
    Phi, y, off = _streams(rng, 2, [50, 60, 40])
    y[[3, 55, 56, 149]] = np.nan
    est = adaptid.RLS(2, nan_policy="skip")
    res = est.run_segments(Phi, y, off)
    assert res.n_skipped.tolist() == [1, 2, 1]
    assert res.n_samples.tolist() == [49, 58, 39]
    assert res.theta_track is None
    for g in range(3):
        a, b = off[g], off[g + 1]
        keep = np.isfinite(y[a:b])
        ref = adaptid.RLS(2).run(Phi[a:b][keep], y[a:b][keep])
        np.testing.assert_array_equal(res.error[a:b][keep], ref.error)


@pytest.mark.parametrize("offsets, match", [
    ([0, 5, 4, 10], "nondecreasing"),
    ([1, 10], "starting at 0"),
    ([0, 9], "ending at N=10"),
    ([[0, 10]], "1-D"),
])
def test_segments_bad_offsets(rng, offsets, match):
    Phi, y, _ = _streams(rng, 2, [10])
    with pytest.raises(ValueError, match="offsets.*" + match):
        adaptid.RLS(2).run_segments(Phi, y, offsets)


def test_segments_float_offsets_rejected(rng):
    Phi, y, _ = _streams(rng, 2, [10])
    with pytest.raises(TypeError, match="offsets must be integers"):
        adaptid.RLS(2).run_segments(Phi, y, [0.0, 4.5, 10.0])


@pytest.mark.parametrize("where", ["Phi", "y"])
@pytest.mark.parametrize("make", [
    lambda: adaptid.RLS(3, forgetting=0.99),              # the SIMD (SoA) path: 20 segments
    lambda: adaptid.KalmanRLS(3, process_cov=1e-4),       # the scalar path
], ids=["rls", "kalman"])
def test_nan_policy_raise_names_the_array_and_sample_as_run_does(make, where):
    """A non-finite sample under nan_policy='raise': the same ValueError as run()
    gives for that sample, and the estimator is unchanged (checked after the kernel)."""
    rng = np.random.default_rng(11)
    N, G = 200, 20
    Phi = rng.standard_normal((N, 3))
    y = Phi @ np.ones(3)
    (Phi if where == "Phi" else y)[137] = np.nan
    off = np.linspace(0, N, G + 1).astype(int)
    est = make()
    before = est.get_state()["state"].copy()
    with pytest.raises(ValueError) as seg:
        est.run_segments(Phi, y, off)
    with pytest.raises(ValueError) as run:
        make().run(Phi, y)
    assert str(seg.value) == str(run.value)
    assert where in str(seg.value) and "137" in str(seg.value)
    np.testing.assert_array_equal(est.get_state()["state"], before)
