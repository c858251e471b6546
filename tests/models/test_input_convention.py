"""One input convention (issue 33, points 2 and 9): every polynomial model's
fit / fit_recursive, compare, resid and select_order take an IDData, arrays
(y, u) as two arguments or one tuple, or pandas (one DataFrame: the output
column first, the inputs after it); y of shape (N, 1) is squeezed."""

import numpy as np
import pandas as pd
import pytest
from scipy.signal import lfilter

from adaptid import IDData
from adaptid.models import AR, ARMA, ARMAX, ARX, BJ, OE, compare, resid, select_order

N = 400


@pytest.fixture(scope="module")
def sig():
    rng = np.random.default_rng(3)
    u = rng.standard_normal(N)
    e = 0.1 * rng.standard_normal(N)
    y = lfilter([0, 1.0, 0.5], [1, -0.7], u) + lfilter([1, 0.3], [1, -0.5], e)
    return y, u


def _forms(y, u):
    """Every accepted spelling of the same record, as (args) tuples."""
    df = pd.DataFrame({"y": y, "u": u})
    return {
        "arrays": (y, u),
        "tuple": ((y, u),),
        "iddata": (IDData(y, u),),
        "series": (df["y"], df["u"]),
        "frame": (df,),
        "frame_pair": (df[["y"]], df[["u"]]),
        "column_y": (y[:, None], u),
    }


MODELS = [
    (lambda: ARX(1, 2, 1), {}),
    (lambda: ARMAX(1, 2, 1, 1), {"refine": False}),
    (lambda: OE(2, 1, 1), {"refine": False}),
    (lambda: BJ(2, 1, 1, 1, 1), {"refine": False}),
]


@pytest.mark.parametrize("make, kw", MODELS, ids=["ARX", "ARMAX", "OE", "BJ"])
def test_fit_takes_every_form_alike(sig, make, kw):
    y, u = sig
    ref = make().fit(y, u, **kw).theta
    for name, args in _forms(y, u).items():
        th = make().fit(*args, **kw).theta
        np.testing.assert_allclose(th, ref, rtol=1e-12, atol=1e-14, err_msg=name)


@pytest.mark.parametrize("make", [lambda: ARX(1, 2, 1), lambda: ARMAX(1, 2, 1, 1)],
                         ids=["ARX", "ARMAX"])
def test_fit_recursive_takes_every_form_alike(sig, make):
    y, u = sig
    ref = make().fit_recursive(y, u).theta
    for name, args in _forms(y, u).items():
        np.testing.assert_array_equal(make().fit_recursive(*args).theta, ref, err_msg=name)


def test_bj_fit_takes_an_iddata(sig):
    y, u = sig
    m = BJ(2, 1, 1, 1, 1).fit(IDData(y, u, 0.5))
    assert m.dt == 0.5
    np.testing.assert_allclose(m.theta, BJ(2, 1, 1, 1, 1).fit(y, u).theta, rtol=1e-10)


def test_arx_fit_takes_a_dataframe_with_names_and_time(sig):
    y, u = sig
    idx = pd.timedelta_range(0, periods=N, freq="80ms")
    df = pd.DataFrame({"temp": y, "heat": u}, index=idx)
    m = ARX(1, 2, 1).fit(df)
    assert m.y_name == "temp" and m.u_names == ("heat",) and m.dt == pytest.approx(0.08)
    np.testing.assert_array_equal(m.theta, ARX(1, 2, 1).fit(y, u).theta)
    # several input columns after the output
    df2 = pd.DataFrame({"y": y, "u1": u, "u2": np.roll(u, 3)})
    m2 = ARX(1, [2, 1], [1, 1]).fit(df2)
    assert m2.u_names == ("u1", "u2")
    np.testing.assert_array_equal(m2.theta, ARX(1, [2, 1], [1, 1]).fit(y, df2[["u1", "u2"]].to_numpy()).theta)


@pytest.mark.parametrize("make, kw", [(lambda: AR(2), {}), (lambda: ARMA(1, 1), {"refine": False})],
                         ids=["AR", "ARMA"])
def test_time_series_models_take_the_output_alone(sig, make, kw):
    y, _ = sig
    ref = make().fit(y, **kw).theta
    for arg in (y[:, None], pd.Series(y, name="y"), pd.DataFrame({"y": y}), IDData(y)):
        np.testing.assert_allclose(make().fit(arg, **kw).theta, ref, rtol=1e-12)
    np.testing.assert_array_equal(make().fit_recursive(y[:, None]).theta,
                                  make().fit_recursive(y).theta)
    with pytest.raises(ValueError, match="y must be an output record without inputs"):
        make().fit(pd.DataFrame({"y": y, "u": y}), **kw)


def test_compare_and_resid_take_every_form(sig):
    y, u = sig
    m = ARX(1, 2, 1).fit(y, u)
    ref = compare(IDData(y, u), m).fit
    rref = resid(IDData(y, u), m)
    for name, args in _forms(y, u).items():
        np.testing.assert_array_equal(compare(*args, m).fit, ref, err_msg=name)
        r = resid(*args, m)
        np.testing.assert_array_equal(r.e, rref.e, err_msg=name)
        assert r.autocorrelation["p_value"] == rref.autocorrelation["p_value"]


def test_resid_takes_several_models(sig):
    y, u = sig
    m1 = ARX(1, 2, 1).fit(y, u)
    m2 = OE(2, 1, 1).fit(y, u, refine=False)
    one = resid((y, u), m1)
    assert type(one).__name__ == "ResidResult"      # one model: the result itself, as before
    both = resid((y, u), m1, m2)
    assert isinstance(both, tuple) and len(both) == 2
    for r, m in zip(both, (m1, m2)):
        alone = resid((y, u), m)
        np.testing.assert_array_equal(r.e, alone.e)
        assert r.start == alone.start and r.autocorrelation["p_value"] == alone.autocorrelation["p_value"]
    with pytest.raises(TypeError, match="models must be at least one fitted model"):
        resid((y, u))
    with pytest.raises(ValueError, match="ax must be None when several models"):
        resid((y, u), m1, m2, ax=object())


def test_select_order_takes_every_form(sig):
    y, u = sig
    ref = select_order((y, u), na=[1, 2], nb=[1, 2], nk=1).table
    for name, args in _forms(y, u).items():
        got = select_order(*args, na=[1, 2], nb=[1, 2], nk=1).table
        np.testing.assert_allclose(got[["loss", "aic"]].to_numpy(), ref[["loss", "aic"]].to_numpy(),
                                   rtol=1e-12, err_msg=name)


def test_one_error_for_anything_else(sig):
    y, u = sig
    m = ARX(1, 2, 1).fit(y, u)
    msg = r"data must be an IDData, arrays \(y, u\) \(two arguments or one tuple\), or pandas"
    for f in (lambda d: compare(d, m), lambda d: resid(d, m),
              lambda d: select_order(d, na=1, nb=1)):
        with pytest.raises(TypeError, match=msg):
            f(np.ones(5))
        with pytest.raises(ValueError, match=msg + r".*a tuple of 3 items"):
            f((y, u, u))
    with pytest.raises(ValueError, match=r"y must be an IDData, arrays \(y, u\).*a tuple of 1 items"):
        ARX(1, 2, 1).fit((y,))
    with pytest.raises(TypeError, match="u must be an input signal"):
        BJ(1, 1, 1, 1).fit(y)


def test_a_tuple_of_numbers_is_still_a_signal(sig):
    y, _ = sig
    np.testing.assert_array_equal(AR(2).fit(tuple(y)).theta, AR(2).fit(y).theta)
