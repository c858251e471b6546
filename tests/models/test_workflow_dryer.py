"""The whole workflow on the DaISy dryer (issue 15, points 1-5): load, detrend,
split, select order, fit, compare, resid, summary, python-control."""

import numpy as np
import pytest
from scipy import signal

import adaptid
from adaptid.models import ARMAX, ARX, OE, compare, resid, select_order


@pytest.fixture(scope="module")
def dryer():
    return adaptid.datasets.load_daisy("dryer")


def test_arx_on_the_first_300_samples_matches_source_md(dryer):
    # shared/data/daisy/SOURCE.md, "Our plain LS ... samples 1..300, mean removed"
    # (computed by the data's curator with a separate LS, not a MathWorks print-out:
    # SOURCE.md says no published MATLAB/Ljung coefficients were found), 6 digits
    ze = dryer[:300].detrend("constant")
    np.testing.assert_allclose(ze.y, signal.detrend(dryer.y[:300], type="constant"), atol=1e-12)
    m = ARX(2, 2, 3).fit(ze)
    np.testing.assert_allclose(m.theta, [-1.273739, 0.393546, 0.066618, 0.044482], atol=6e-7)
    np.testing.assert_allclose(m.stderr, [0.0209, 0.0191, 0.0021, 0.0033], atol=6e-5)
    assert m.dt == 0.08


def test_oe_refines_by_default_and_reaches_the_issue_numbers(dryer):
    # issue 15, point 5: OE(2,2,3) on the dryer gives 79.6 % validation fit
    # unrefined and 90.0 % refined. Reproduced with samples 1..500 for
    # estimation and 501..1000 for validation, each detrended on its own
    # (Ljung's case study split, SOURCE.md); printed to 0.1 %.
    ze, zv = dryer[:500].detrend(), dryer[500:].detrend()
    plain = OE(2, 2, 3).fit(ze, refine=False)
    default = OE(2, 2, 3).fit(ze)
    assert plain.fit_percent(zv) == pytest.approx(79.6, abs=0.06)
    assert default.fit_percent(zv) == pytest.approx(90.0, abs=0.06)
    # the default is the refinement: it lowers the prediction-error criterion
    assert default.loss < plain.loss
    np.testing.assert_array_equal(default.theta, OE(2, 2, 3).fit(ze, refine=True).theta)
    # ARMAX too: refine=True is the default, and it does not raise the loss
    a0 = ARMAX(2, 2, 2, 3).fit(ze, refine=False)
    a1 = ARMAX(2, 2, 2, 3).fit(ze)
    assert a1.loss <= a0.loss * (1 + 1e-12)
    np.testing.assert_array_equal(a1.theta, ARMAX(2, 2, 2, 3).fit(ze, refine=True).theta)


def test_the_whole_workflow(dryer, tmp_path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    data = dryer.detrend("constant")
    est, val = data.split(0.5)
    sel = select_order(est, na=range(1, 5), nb=range(1, 5), nk=range(1, 6),
                       criterion="validation", validation=val)
    na, nb, nk = sel.best
    # the fitted best order is at least as good on validation as [2 2 3]
    best = ARX(na, nb, nk).fit(est)
    m223 = ARX(2, 2, 3).fit(est)
    oe = OE(2, 2, 3).fit(est)
    fig, ax = plt.subplots()
    cmp = compare(val, m223, best, oe, ax=ax)
    assert cmp.fit[1] >= cmp.fit[0] - 0.5      # the shared-row selection vs each model's own rows
    assert cmp.fit.min() > 80
    fig.savefig(tmp_path / "compare.png")
    plt.close(fig)
    # OE models no noise, so its residuals on this plant are coloured; an
    # ARMAX noise model C/A whitens them (Ljung 1999, 16.6: the whiteness
    # test judges the noise model): the verdicts of resid tell them apart
    r = resid(val, oe)
    assert not r.white and r.autocorrelation["p_value"] < 1e-10
    ra = resid(val, ARMAX(2, 2, 2, 3).fit(est))
    assert ra.white
    s = oe.summary()
    assert s.names == ("b0", "b1", "f1", "f2") and "FPE" in s.stats
    import control  # the test extra installs it (missing: a failure)
    G = oe.to_control()
    assert isinstance(G, control.TransferFunction) and G.dt == 0.08
    # the transfer function's simulation equals the model's (python-control as oracle)
    _, y_ctrl = control.forced_response(G, U=val.u)
    np.testing.assert_allclose(y_ctrl, oe.simulate(val), atol=1e-10)
