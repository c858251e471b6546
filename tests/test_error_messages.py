"""Errors that name the argument (issue 32): no OverflowError, ZeroDivisionError
or AttributeError from careless input, one ValueError/TypeError naming it."""

import warnings

import numpy as np
import pytest

import adaptid
from adaptid import models
from adaptid.diagnostics import efp


@pytest.mark.parametrize("kw", ["forgetting", "P0"])
def test_huge_int_option_names_it(kw):
    with pytest.raises(ValueError, match=f"^{kw} must be a finite real number"):
        adaptid.RLS(3, **{kw: 10 ** 400})


def test_huge_negative_int_names_it():
    with pytest.raises(ValueError, match="^forgetting must be"):
        adaptid.RLS(3, forgetting=-(10 ** 400))


def test_check_scalar_huge_int_without_finite():
    from adaptid._validation import check_scalar
    assert check_scalar(10 ** 400, "x", finite=False) == np.inf
    with pytest.raises(ValueError, match=r"^x must be in \[-inf, 1"):
        check_scalar(10 ** 400, "x", high=1.0, finite=False)


def test_saturated_lstsq_summary_prints_nan():
    res = adaptid.lstsq(np.eye(2), np.array([1.0, 2.0]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        text = str(res.summary())
    assert res.dof == 0
    assert np.isnan(res.rsquared_adj)
    assert "dof" in text and "nan" in text


@pytest.mark.parametrize("kind,n,need", [("rec-cusum", 1, 3), ("rec-cusum", 2, 4),
                                         ("rec-mosum", 2, 5), ("rec-mosum", 3, 7)])
def test_efp_too_few_samples_names_x(kind, n, need):
    rng = np.random.default_rng(0)
    X = rng.standard_normal((need - 1, n))
    y = rng.standard_normal(need - 1)
    with pytest.raises(ValueError, match=f"^X must be at least {need} rows long"):
        efp(X, y, kind=kind, h=0.9)
    X = rng.standard_normal((need, n))
    y = rng.standard_normal(need)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.isfinite(efp(X, y, kind=kind, h=0.9).statistic)


def test_compare_model_name_names_models():
    rng = np.random.default_rng(0)
    u = rng.standard_normal(100)
    y = np.convolve(u, [0.0, 1.0, 0.5])[:100]
    with pytest.raises(TypeError, match="^models must be fitted models"):
        models.compare((y, u), "ARX")
    with pytest.raises(TypeError, match=r"^models\[0\] must be a fitted model"):
        models.compare(y, u, "ARX")


@pytest.mark.parametrize("path", ["a\0b", b"a\0b"])
def test_nul_byte_in_state_path(tmp_path, path):
    est = adaptid.RLS(2)
    with pytest.raises(ValueError, match="^path must be a file name without NUL"):
        est.save_state(path)
    with pytest.raises(adaptid.StateFileError, match="^path must be a file name without NUL"):
        adaptid.load_state(path)
    with pytest.raises(adaptid.StateFileError, match="^path must be"):
        adaptid.RLS.load_state(path)


def test_sklearn_refuses_numeric_strings():
    pytest.importorskip("sklearn")
    from adaptid.sklearn import RLSRegressor
    X = np.array([["1", "2"], ["3", "4"], ["5", "6"]])
    with pytest.raises(TypeError, match=r"^X must be a real numeric array \(not text\)"):
        RLSRegressor().fit(X, [1.0, 2.0, 3.0])
    with pytest.raises(TypeError, match=r"^y must be a real numeric array \(not text\)"):
        RLSRegressor().fit(np.ones((3, 2)), ["1", "2", "3"])
    with pytest.raises(TypeError, match=r"^X must be"):
        RLSRegressor().fit(X.astype(object), [1.0, 2.0, 3.0])
    reg = RLSRegressor().fit(np.arange(6.0).reshape(3, 2), [1.0, 2.0, 3.0])
    with pytest.raises(TypeError, match=r"^X must be"):
        reg.predict(X)
    # numbers held in an object array stay accepted (scikit-learn's convention)
    RLSRegressor().fit(np.arange(6.0).reshape(3, 2).astype(object), [1.0, 2.0, 3.0])


def test_bad_max_specialised_n_env_warns_and_falls_back():
    import os
    import subprocess
    import sys
    env = dict(os.environ, ADAPTID_MAX_SPECIALISED_N="abc")
    code = "import adaptid._config as c; print(c.MAX_SPECIALISED_N)"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "16"
    assert "ADAPTID_MAX_SPECIALISED_N must be an integer" in proc.stderr
    assert "'abc'" in proc.stderr
