"""Streaming models given a merged record (issue 34, point 1): ``run`` restarts
the lag buffers at each experiment, the estimate and P run on.

The oracles: ``step`` over the samples, with the lag buffers (and only
them) zeroed at each boundary by editing the object's ``get_state`` dict
by hand; and the batch models' ``fit_recursive`` on the merged record
(``start="filled"``), itself checked against per-piece and NumPy oracles in
tests/models/test_plr_experiments.py."""

import numpy as np
import pytest
from scipy.signal import lfilter

import adaptid
from adaptid.models import (AR, ARMA, ARMAX, ARX, BJ, OE, IDData, RecursiveAR, RecursiveARMA,
                            RecursiveARMAX, RecursiveARX, RecursiveBJ, RecursiveOE)

#: kind -> (stream class, batch class, orders, number of parameters, lag buffers)
MODELS = {
    "armax": (RecursiveARMAX, ARMAX, (2, 2, 1, 1), 5, ("ybuf", "ubuf", "vh")),
    "arma": (RecursiveARMA, ARMA, (2, 1), 3, ("ybuf", "ubuf", "vh")),
    "oe": (RecursiveOE, OE, (2, 2, 1), 4, ("ybuf", "ubuf", "vh")),
    "bj": (RecursiveBJ, BJ, (2, 1, 1, 2, 1), 6, ("ybuf", "ubuf", "vh")),
    "arx": (RecursiveARX, ARX, (2, 2, 1), 4, ("ybuf", "ubuf")),
    "ar": (RecursiveAR, AR, (2,), 2, ("ybuf", "ubuf")),
}
SERIES = ("arma", "ar")       # time-series models: step(y), IDData without inputs
SIZES = (150, 90, 120)


@pytest.fixture(scope="module")
def recs():
    rng = np.random.default_rng(34)
    out = []
    for N in SIZES:
        u = rng.standard_normal(N)
        e = 0.1 * rng.standard_normal(N)
        out.append((lfilter([0, 1.0, 0.5], [1, -1.2, 0.5], u)
                    + lfilter([1, 0.4], [1, -0.6], e), u))
    return out


def _merged(kind, recs):
    parts = [IDData(y) if kind in SERIES else IDData(y, u) for y, u in recs]
    return parts[0].merge(*parts[1:])


def _restart_by_hand(obj, kind):
    """The object with its lag buffers zeroed and its fill count at 0, nothing else
    changed: written out on the state dict."""
    st = obj.get_state()
    for key in MODELS[kind][4]:
        st[key] = np.zeros_like(st[key])
    st["options"]["since"] = 0
    return type(obj).from_state(st)


def _updates(obj):
    """Recursion steps made (RecursiveARX: its core estimator's)."""
    return obj.n_updates if hasattr(obj, "n_updates") else obj.estimator.n_updates


def _steps_with_restarts(kind, recs, opts):
    cls, _, orders, _, _ = MODELS[kind]
    obj = cls(*orders, **opts)
    T, Yh = [], []
    for i, (y, u) in enumerate(recs):
        if i:
            obj = _restart_by_hand(obj, kind)
        for k in range(y.size):
            th, yh = obj.step(y[k]) if kind in SERIES else obj.step(y[k], u[k])
            T.append(th)
            Yh.append(yh)
    return obj, np.array(T), np.array(Yh)


OPTS = [dict(), dict(start="filled", forgetting=0.98), dict(method="kalman"),
        dict(window=30, P0="diffuse"), dict(method="ngradient", step=0.3)]


@pytest.mark.parametrize("kind", list(MODELS))
@pytest.mark.parametrize("opts", OPTS)
def test_run_of_merged_record_equals_steps_with_buffers_restarted(recs, kind, opts):
    cls, _, orders, _, _ = MODELS[kind]
    ref, T, Yh = _steps_with_restarts(kind, recs, opts)
    obj = cls(*orders, **opts)
    res = obj.run(_merged(kind, recs))
    np.testing.assert_array_equal(res.theta, T)
    np.testing.assert_array_equal(res.yhat, Yh)
    np.testing.assert_array_equal(obj.theta, ref.theta)
    assert _updates(obj) == _updates(ref)
    if opts.get("start") == "filled":   # the wait again at each experiment: s = 2 samples
        assert np.isnan(res.yhat[[0, 1, 150, 151, 240, 241]]).all()
        assert _updates(obj) == sum(SIZES) - 3 * 2
    # without the restarts (the record as one experiment) the tracks differ
    whole = cls(*orders, **opts).run(*((np.concatenate([y for y, _ in recs]),)
                                       if kind in SERIES else
                                       (np.concatenate([y for y, _ in recs]),
                                        np.concatenate([u for _, u in recs]))))
    assert not np.array_equal(whole.theta, res.theta)


@pytest.mark.parametrize("kind", list(MODELS))
def test_filled_run_of_merged_record_equals_fit_recursive(recs, kind):
    cls, model, orders, n, _ = MODELS[kind]
    obj = cls(*orders, start="filled", forgetting=0.99)
    res = obj.run(_merged(kind, recs))
    traj = model(*orders).fit_recursive(
        _merged(kind, recs), estimator=adaptid.estimator("rls", n, forgetting=0.99))
    used = ~np.isnan(res.yhat)
    np.testing.assert_array_equal(res.theta[used], traj.theta)


def test_state_mid_merged_record_continues(recs, tmp_path):
    # a state saved after a merged run keeps the fill count of the last experiment
    opts = dict(start="filled")
    _, T, _ = _steps_with_restarts("armax", recs, opts)
    obj = RecursiveARMAX(2, 2, 1, 1, **opts)
    data = _merged("armax", recs[:2])
    y3, u3 = recs[2]
    obj.run(data.merge(IDData(y3[:1], u3[:1])))         # one sample into the third
    obj.save_state(tmp_path / "s.npz")
    back = RecursiveARMAX.load_state(tmp_path / "s.npz")
    res = back.run(y3[1:], u3[1:])
    np.testing.assert_array_equal(res.theta, T[241:])
    assert np.isnan(res.yhat[0]) and not np.isnan(res.yhat[1])


@pytest.mark.parametrize("kind", ["armax", "arx"])
def test_failure_in_a_later_experiment_leaves_the_state(recs, kind, monkeypatch):
    cls, _, orders, _, _ = MODELS[kind]
    obj = cls(*orders)
    obj.run(*recs[0])
    before = obj.get_state()
    calls = []
    real = obj._samples

    def failing(y, U):
        calls.append(1)
        if len(calls) == 2:
            raise FloatingPointError("boom")
        return real(y, U)

    monkeypatch.setattr(obj, "_samples", failing)
    with pytest.raises(FloatingPointError):
        obj.run(_merged(kind, recs))
    monkeypatch.undo()
    after = obj.get_state()
    for key in before:
        if isinstance(before[key], np.ndarray):
            np.testing.assert_array_equal(after[key], before[key])
    assert after["options"] == before["options"]
    assert after["inner"]["n_updates"] == before["inner"]["n_updates"]
    np.testing.assert_array_equal(after["inner"]["state"], before["inner"]["state"])


def test_gaps_are_refused(recs):
    y, u = recs[0]
    y = y.copy()
    y[10] = np.nan
    with pytest.raises(ValueError, match="y"):
        RecursiveARMAX(2, 2, 1, 1).run(y, u)
