"""Every linear model has the response API of issue 36; the transfer-function model's
step response, roots and draws (against python-control and finite differences)."""

import numpy as np
import pytest
from scipy.signal import lfilter

from adaptid.models import (AR, ARMA, ARMAX, ARX, BJ, OE, FrequencyResponse, IDData, Roots,
                            StateSpaceModel, StepResponse, TransferFunctionModel, arx_regul,
                            impulseest, iv4, n4sid, okid, tfest)

control = pytest.importorskip("control")


def _record(N=600, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(N)
    return IDData(lfilter([0, 1, 0.5], [1, -0.6], u) + 0.1 * rng.standard_normal(N), u)


def _models():
    d = _record()
    y = d.y
    return {"ARX": ARX(1, 2, 1).fit(d), "ARMAX": ARMAX(1, 2, 1, 1).fit(d),
            "OE": OE(2, 1, 1).fit(d), "BJ": BJ(2, 1, 1, 1, 1).fit(d), "AR": AR(2).fit(y),
            "ARMA": ARMA(2, 1).fit(y), "arx_regul": arx_regul(d, 1, 2, 1),
            "iv4": iv4(d, 1, 2, 1), "impulseest": impulseest(d, 10),
            "tfest": tfest(d, 2, 1), "n4sid": n4sid((d.outputs, d.inputs), 2),
            "okid": okid((d.outputs, d.inputs), 2, 8)}


def test_every_linear_model_has_responses_with_bands():
    for name, m in _models().items():
        fr = m.freqresp()
        assert isinstance(fr, FrequencyResponse) and fr.magnitude_sd is not None, name
        sr = m.step_response()
        assert isinstance(sr, StepResponse) and sr.sd is not None, name
        for roots in (m.poles(), m.zeros()):
            assert isinstance(roots, Roots) and roots.sd_real is not None, name
        draws = m.rsample(2, seed=0)
        assert len(draws) == 2 and type(draws[0]) is type(m), name


def _discrete_tf():
    rng = np.random.default_rng(1)
    u = rng.standard_normal(800)
    y = lfilter([0, 0, 1.0, 0.4], [1, -1.2, 0.5], u) + 0.05 * rng.standard_normal(800)
    return tfest(IDData(y, u, dt=0.1), 2, 1, delay=1)


def _step_fd(m, T, h=1e-7):
    """Finite-difference Jacobian of the step response with respect to θ."""
    th, nb = m.theta, m.b.size
    cols = []
    for j in range(th.size):
        e = np.zeros(th.size)
        e[j] = h
        mk = lambda t: TransferFunctionModel(t[:nb], t[nb:], dt=m.dt, delay=m.delay,  # noqa
                                             nk=m.nk)
        cols.append((mk(th + e).step_response(T).response
                     - mk(th - e).step_response(T).response) / (2 * h))
    return np.column_stack(cols)


def test_discrete_tf_step_response_and_sd():
    m = _discrete_tf()
    sr = m.step_response(40)
    t_ref, s_ref = control.step_response(m.to_control(), T=sr.t)
    np.testing.assert_allclose(sr.response, np.squeeze(s_ref), atol=1e-10)
    J = _step_fd(m, 40)
    # central differences: ~1e-9 relative error in J
    np.testing.assert_allclose(sr.sd, np.sqrt(np.einsum("ti,ij,tj->t", J, m.cov, J)),
                               rtol=1e-5, atol=1e-12)


def test_continuous_tf_step_response_with_delay_and_sd():
    num, den, tau = [2.0, 1.0], [1.0, 0.8, 4.0], 0.3
    W = np.logspace(-2, 2, 150)
    H = np.squeeze(control.frequency_response(control.tf(num, den), W).complex)
    H = H * np.exp(-1j * W * tau) * (1 + 0.01 * np.random.default_rng(2).standard_normal(W.size))
    m = tfest(FrequencyResponse(W, H), 2, 1, delay=tau)
    sr = m.step_response(300)
    t = sr.t
    # closed form by partial fractions (simple poles): s(t) = G(0) + Σ r_i/p_i e^{p_i t}
    def closed(theta):
        nb = m.b.size
        num, den = theta[:nb][::-1], np.r_[1.0, theta[nb:][::-1]]
        p = np.roots(den)
        r = np.polyval(num, p) / np.polyval(np.polyder(den), p)
        tt = np.clip(t - tau, 0, None)
        s0 = np.polyval(num, 0) / np.polyval(den, 0) + (np.exp(np.outer(tt, p)) @ (r / p)).real
        return np.where(t >= tau, s0, 0.0)

    np.testing.assert_allclose(sr.response, closed(m.theta), atol=1e-8)
    h = 1e-6
    J = np.column_stack([(closed(m.theta + h * e) - closed(m.theta - h * e)) / (2 * h)
                         for e in np.eye(m.theta.size)])
    # central differences of the closed form: ~1e-9 relative error in J
    np.testing.assert_allclose(sr.sd, np.sqrt(np.einsum("ti,ij,tj->t", J, m.cov, J)),
                               rtol=1e-5, atol=1e-12)


@pytest.mark.parametrize("make", [_discrete_tf, None])
def test_tf_roots_sd_equal_finite_differences(make):
    if make is None:
        W = np.logspace(-2, 2, 150)
        H = np.squeeze(control.frequency_response(control.tf([2.0, 1.0], [1.0, 0.8, 4.0]),
                                                  W).complex)
        H = H * (1 + 0.01 * np.random.default_rng(3).standard_normal(W.size))
        m = tfest(FrequencyResponse(W, H), 2, 1)
    else:
        m = make()
    nb, h = m.b.size, 1e-7
    for which in ("poles", "zeros"):
        R = getattr(m, which)()
        ref = getattr(control, which)(m.to_control())
        ref = ref[np.abs(ref) > 1e-12]                 # python-control's z = 0 of the delay
        np.testing.assert_allclose(np.sort_complex(R.values), np.sort_complex(ref), atol=1e-8)
        g = []
        for j in range(m.theta.size):
            e = np.zeros(m.theta.size)
            e[j] = h
            vals = [getattr(TransferFunctionModel(t[:nb], t[nb:], dt=m.dt, nk=m.nk), which)()
                    .values for t in (m.theta + e, m.theta - e)]
            g.append((vals[0] - vals[1]) / (2 * h))    # roots keep their order under ±h
        g = np.array(g).T
        np.testing.assert_allclose(R.sd_real, np.sqrt(np.einsum("ri,ij,rj->r", g.real, m.cov,
                                                                g.real)), rtol=1e-4)
    draws = m.rsample(3, seed=1)
    assert all(isinstance(d, TransferFunctionModel) and d.cov is m.cov for d in draws)
    with pytest.raises(ValueError, match="cov"):
        TransferFunctionModel([1.0], [0.5], dt=1.0).rsample(2)


def test_state_space_model_is_listed():
    assert hasattr(StateSpaceModel, "rsample") and hasattr(StateSpaceModel, "zeros")
