"""select_order as MATLAB's arxstruc / selstruc (issue 33, point 7): the
validation loss V = (1/N) sum e^2 of the one-step prediction errors on the
validation record of each structure fitted on the estimation record, and one
AIC definition with summary(). The reference is written out here with
np.linalg.lstsq on ARX regressors built in the test."""

import itertools

import numpy as np
import pandas as pd
import pytest
from scipy.signal import lfilter

from adaptid import IDData
from adaptid.models import ARX, select_order

GRID = dict(na=[1, 2, 3], nb=[1, 2], nk=[1, 2])


@pytest.fixture(scope="module")
def records():
    rng = np.random.default_rng(11)
    n = 1200
    u = rng.standard_normal(n)
    e = 0.1 * rng.standard_normal(n)
    y = lfilter([0, 0, 1.0, 0.5], [1, -1.2, 0.5], u) + lfilter([1, 0.4], [1, -0.6], e)
    return IDData(y[:600], u[:600]), IDData(y[600:], u[600:])


def _regressors(y, u, na, nb, nk, s):
    """[-y(k-1) .. -y(k-na), u(k-nk) .. u(k-nk-nb+1)] and y(k), for k = s .. N-1."""
    k = np.arange(s, y.size)
    cols = [-y[k - j] for j in range(1, na + 1)] + [u[k - nk - j] for j in range(nb)]
    return np.column_stack(cols), y[k]


def _reference(est, val):
    s = max(max(GRID["na"]), max(GRID["nk"]) + max(GRID["nb"]) - 1)
    rows = []
    for na, nb, nk in itertools.product(*GRID.values()):
        Phi, t = _regressors(est.y, est.u, na, nb, nk, s)
        theta, *_ = np.linalg.lstsq(Phi, t, rcond=None)
        r = t - Phi @ theta
        n, d = r.size, na + nb
        V = r @ r / n
        aic = n * np.log(V) + 2 * d + n * (np.log(2 * np.pi) + 1)
        Phi_v, t_v = _regressors(val.y, val.u, na, nb, nk, s)
        e = t_v - Phi_v @ theta                      # one-step prediction errors on validation
        rows.append((na, nb, nk, e @ e / e.size, aic, V))
    return s, np.array(rows)


def test_validation_loss_is_arxstruc_loss(records):
    est, val = records
    s, ref = _reference(est, val)
    sel = select_order(est, **GRID, validation=val)
    got = sel.table[["na", "nb", "nk", "loss", "aic"]].to_numpy()
    np.testing.assert_allclose(got, ref[:, :5], rtol=1e-9)
    assert sel.start == s
    # selstruc(V, 0): the smallest validation loss
    by_loss = select_order(est, **GRID, validation=val, criterion="loss")
    assert by_loss.best == tuple(int(v) for v in ref[np.argmin(ref[:, 3]), :3])
    # without validation the loss stays the estimation loss on the common rows
    plain = select_order(est, **GRID)
    np.testing.assert_allclose(plain.table["loss"].to_numpy(), ref[:, 5], rtol=1e-9)
    np.testing.assert_allclose(plain.table["aic"].to_numpy(), ref[:, 4], rtol=1e-9)


def test_validation_accepts_every_form(records):
    est, val = records
    ref = select_order(est, **GRID, validation=val).table["loss"].to_numpy()
    for v in ((val.y, val.u), pd.DataFrame({"y": val.y, "u": val.u})):
        got = select_order(est, **GRID, validation=v).table["loss"].to_numpy()
        np.testing.assert_array_equal(got, ref)
    with pytest.raises(ValueError, match="validation must be longer than the largest lag"):
        select_order(est, **GRID, validation=val[:3])


def test_aic_of_the_chosen_order_equals_summary(records):
    est, _ = records
    sel = select_order(est, **GRID)
    t = sel.table
    row = t[(t.na == sel.best[0]) & (t.nb == sel.best[1]) & (t.nk == sel.best[2])].iloc[0]
    st = sel.model().summary().stats
    assert st["AIC"] == pytest.approx(row["aic"], rel=1e-12)
    assert st["FPE"] == pytest.approx(row["fpe"], rel=1e-12)
    assert st["loss V"] == pytest.approx(row["loss"], rel=1e-12)
    assert st["N"] == len(est) - sel.start
    # any structure of the grid, not only the best
    for order in ((1, 1, 1), (3, 2, 2)):
        r = t[(t.na == order[0]) & (t.nb == order[1]) & (t.nk == order[2])].iloc[0]
        assert sel.model(order).summary().stats["AIC"] == pytest.approx(r["aic"], rel=1e-12)
    # the whole-record fit has its own (more) rows: its AIC is the same formula at its N
    # ((1, 1, 1) starts at row 1 < s = 3: the −1788 vs −1800 of issue 33)
    m = ARX(1, 1, 1).fit(est)
    r = m.residuals
    n, d = r.size, m.theta.size
    V = r @ r / n
    assert n > sel.model((1, 1, 1)).summary().stats["N"] == len(est) - sel.start
    assert m.summary().stats["AIC"] == pytest.approx(n * np.log(V) + 2 * d + n * (np.log(2 * np.pi) + 1),
                                                     rel=1e-12)
