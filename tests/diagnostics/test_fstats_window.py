"""``fstats(from_=, to=)``: R strucchange's asymmetric candidate window (issue 33, point 5).

Oracles: the Chow F statistic of every split computed here by brute force
with ``numpy.linalg.lstsq`` on the two segments, and R's definitions of the
window (a fraction v gives floor(v N); a number ≥ 1 is the 1-based last
observation of the first segment; ``to`` defaults to N − from) and of
λ = (N − from)·to / (from·(N − to)) (``Fstats`` source, Hansen 1997).
"""

import numpy as np
import pytest

from adaptid.diagnostics import fstats


def _rss(X, y):
    r = y - X @ np.linalg.lstsq(X, y, rcond=None)[0]
    return r @ r


@pytest.fixture
def data():
    rng = np.random.default_rng(5)
    N = 120
    X = np.column_stack([np.ones(N), rng.standard_normal(N)])
    y = X @ [1.0, 0.5] + np.where(np.arange(N) >= 80, 0.8, 0.0) + 0.3 * rng.standard_normal(N)
    return X, y


@pytest.mark.parametrize("frm, to, points", [(0.1, 0.5, (12, 60)), (20, 100, (20, 100)),
                                             (0.25, None, (30, 90)), (15, 0.9, (15, 108))])
def test_window_and_brute_force_F(data, frm, to, points):
    X, y = data
    N, n = X.shape
    fs = fstats(X, y, from_=frm, to=to)
    lo, hi = points
    np.testing.assert_array_equal(fs.candidates, np.arange(lo, hi + 1) - 1)
    S = _rss(X, y)
    for j, F in zip(fs.candidates, fs.F):
        u = _rss(X[:j + 1], y[:j + 1]) + _rss(X[j + 1:], y[j + 1:])
        assert F == pytest.approx((S - u) / (u / (N - 2 * n)), rel=1e-9)
    assert fs.lam == pytest.approx((N - lo) * hi / (lo * (N - hi)), rel=1e-15)


def test_trim_equals_symmetric_from(data):
    X, y = data
    a, b = fstats(X, y, trim=0.2), fstats(X, y, from_=0.2)
    np.testing.assert_array_equal(a.F, b.F)
    assert a.lam == b.lam and a.test("supF").pvalue == b.test("supF").pvalue


@pytest.mark.parametrize("kw, name", [({"from_": 0.2, "trim": 0.1}, "from_"),
                                      ({"from_": 2.5}, "from_"),
                                      ({"from_": 60, "to": 50}, "to"),
                                      ({"from_": 0.1, "to": 500}, "to")])
def test_bad_windows_name_the_argument(data, kw, name):
    with pytest.raises(ValueError, match=name):
        fstats(*data, **kw)
