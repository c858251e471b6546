"""The simulated DC-motor data set and the DC-motor physics regressors.

Oracles: scipy.integrate.solve_ivp on the motor's ODEs (independent
integration with event-located speed reversals), scipy.signal.lsim for the
state-variable filter (continuous system, zero-/first-order-hold input),
numpy.linalg.lstsq and the simulator's true parameters.
"""

import time

import numpy as np
import pytest

import adaptid
from adaptid.datasets import dc_motor
from adaptid.datasets._dc_motor import MOTOR_PARAMETERS as PRM
from adaptid.models._dcmotor import DCMotorRegressors, dc_motor_regressors

import pandas as pd  # noqa: E402

PHYS = ("R", "L", "Ke", "J", "B", "tau_c", "tau_0")


@pytest.fixture(scope="module")
def clean():
    return dc_motor(seed=0, noise=False)


@pytest.fixture(scope="module")
def noisy():
    return dc_motor(seed=0)


def _regs(data, **kw):
    return dc_motor_regressors(data.time, data.voltage, data.current, data.speed, **kw)


# --------------------------------------------------------------------------
# the simulator against an independent integration of the physics
# --------------------------------------------------------------------------

def _solve_ivp_segment(data, truth, k0, k1):
    """Integrate the motor ODEs from sample k0 to k1 with solve_ivp (ZOH voltage)."""
    from scipy.integrate import solve_ivp

    Ke, L, tc, t0 = PRM["Ke"], PRM["L"], PRM["tau_c"], PRM["tau_0"]
    R0, alpha, Tamb, Cth, Rth = PRM["R0"], PRM["alpha"], PRM["T_amb"], PRM["C_th"], PRM["R_th"]
    dt = data.attrs["dt"]
    R_k0 = truth.R.iloc[k0]
    x = np.array([data.current.iloc[k0], data.speed.iloc[k0], Tamb + (R_k0 / R0 - 1) / alpha])
    out = [x.copy()]
    n_rev = 0
    for k in range(k0, k1):
        v, J, B = data.voltage.iloc[k], truth.J.iloc[k], truth.B.iloc[k]

        def rhs(t, s, mode):
            i, w, T = s
            R = R0 * (1 + alpha * (T - Tamb))
            dw = (Ke * i - B * w - tc * mode - t0) / J
            return [(v - R * i - Ke * w) / L, dw, (R * i * i - (T - Tamb) / Rth) / Cth]

        t, t_end = k * dt, (k + 1) * dt
        while True:
            mode = np.sign(x[1])
            if mode == 0:
                drive = Ke * x[0] - t0
                assert abs(drive) > tc, "the excitation should never let the rotor stick"
                mode = np.sign(drive)

            def reversal(t, s, mode):
                return s[1]
            reversal.terminal = True
            reversal.direction = -mode  # ω returns through zero against the motion

            sol = solve_ivp(rhs, (t, t_end), x, args=(mode,), method="DOP853",
                            rtol=1e-11, atol=1e-12, events=reversal)
            x = sol.y[:, -1].copy()
            if sol.status == 1 and sol.t[-1] < t_end:  # stopped at ω = 0
                x[1] = 0.0
                t = sol.t[-1]
                n_rev += 1
                continue
            break
        out.append(x.copy())
    return np.array(out), n_rev


def test_simulator_equals_solve_ivp_across_a_reversal(clean):
    data, truth = clean
    w = data.speed.to_numpy()
    # first speed reversal after 2 s
    k_rev = 2000 + int(np.argmax(w[2000:-1] * w[2001:] < 0))
    k0, k1 = k_rev - 100, k_rev + 150
    ref, n_rev = _solve_ivp_segment(data, truth, k0, k1)
    assert n_rev >= 1
    sim = data[["current", "speed"]].to_numpy()[k0:k1 + 1]
    # RK4 with 50 µs sub-steps vs DOP853 at rtol 1e-11 (measured: 4e-11 A, 1e-9 rad/s)
    np.testing.assert_allclose(sim[:, 0], ref[:, 0], rtol=0, atol=1e-8)
    np.testing.assert_allclose(sim[:, 1], ref[:, 1], rtol=0, atol=1e-7)
    R_ref = PRM["R0"] * (1 + PRM["alpha"] * (ref[:, 2] - PRM["T_amb"]))
    np.testing.assert_allclose(truth.R.to_numpy()[k0:k1 + 1], R_ref, rtol=1e-9)


def test_simulator_equals_solve_ivp_across_the_load_step(clean):
    data, truth = clean
    k_load = int(round(data.attrs["load_time"] / data.attrs["dt"]))
    assert truth.J.iloc[k_load - 1] == PRM["J0"] and truth.J.iloc[k_load] == PRM["J1"]
    ref, _ = _solve_ivp_segment(data, truth, k_load - 100, k_load + 200)
    sim = data[["current", "speed"]].to_numpy()[k_load - 100:k_load + 201]
    np.testing.assert_allclose(sim[:, 0], ref[:, 0], rtol=0, atol=1e-8)
    np.testing.assert_allclose(sim[:, 1], ref[:, 1], rtol=0, atol=1e-7)


def test_data_set_layout_and_physics_ranges(noisy):
    data, truth = noisy
    assert list(data.columns) == ["time", "voltage", "current", "speed"]
    assert list(truth.columns) == ["time", "R", "L", "Ke", "Kt", "J", "B", "tau_c", "tau_0"]
    assert len(data) == len(truth) == 60000
    for frame in (data, truth):
        assert frame.attrs == {"load_time": 30.0, "dt": 1e-3, "seed": 0}
    np.testing.assert_array_equal(data.time, truth.time)
    np.testing.assert_allclose(np.diff(data.time), 1e-3, rtol=1e-9)
    rise = truth.R.iloc[-1] / truth.R.iloc[0] - 1
    assert 0.10 <= rise <= 0.20
    # the winding only warms above ambient (it may cool a little in quiet spells)
    assert truth.R.min() == truth.R.iloc[0] and truth.R.iloc[30000] > 1.05 * truth.R.iloc[0]
    np.testing.assert_array_equal(truth.Kt, truth.Ke)
    load = data.time.to_numpy() >= data.attrs["load_time"]
    np.testing.assert_allclose(truth.J[load], 6e-4, rtol=1e-12)
    np.testing.assert_allclose(truth.J[~load], 2e-4, rtol=1e-12)
    np.testing.assert_allclose(truth.B[load], 3e-4, rtol=1e-12)
    np.testing.assert_allclose(truth.B[~load], 1e-4, rtol=1e-12)
    # sensors: 12-bit current ADC, 16384-count encoder differenced every dt
    lsb = 2 * PRM["i_range"] / 2 ** PRM["adc_bits"]
    q = data.current.to_numpy() / lsb
    np.testing.assert_allclose(q, np.round(q), atol=1e-9)
    step = 2 * np.pi / PRM["encoder_counts"] / 1e-3
    c = data.speed.to_numpy() / step
    np.testing.assert_allclose(c, np.round(c), atol=1e-6)
    # the speed reverses (Coulomb friction identifiable) but is mostly positive
    w = data.speed.to_numpy()
    assert 0.6 < np.mean(w > 0) < 0.9
    assert np.sum(np.diff(np.sign(w[w != 0])) != 0) >= 30
    assert np.abs(data.voltage).max() <= PRM["V_bus"]


def test_noise_switch_only_changes_the_sensors(clean, noisy):
    (d0, t0), (d1, t1) = clean, noisy
    pd.testing.assert_frame_equal(t0, t1)
    np.testing.assert_array_equal(d0.voltage, d1.voltage)
    # noisy current = clean + (noise, quantisation); sensor error is small
    err = d1.current - d0.current
    assert 0.005 < err.std() < 0.05
    # encoder speed = mean over the last sample ≈ average of the end points
    w = d0.speed.to_numpy()
    mean_w = 0.5 * (w[1:] + w[:-1])
    assert np.abs(d1.speed.to_numpy()[1:] - mean_w).max() < 0.5  # one count 0.38 rad/s + curvature


def test_determinism():
    a, ta = dc_motor(seed=3, duration=2.0)
    b, tb = dc_motor(seed=3, duration=2.0)
    c, _ = dc_motor(seed=4, duration=2.0)
    pd.testing.assert_frame_equal(a, b)
    pd.testing.assert_frame_equal(ta, tb)
    assert not np.array_equal(a.current, c.current)
    assert not np.array_equal(a.voltage, c.voltage)


def test_speed_smoke(noisy):
    t = time.perf_counter()
    dc_motor(seed=1)
    assert time.perf_counter() - t < 2.0


@pytest.mark.parametrize("kw, name", [
    ({"dt": 0.0}, "dt"), ({"dt": -1e-3}, "dt"), ({"duration": float("nan")}, "duration"),
    ({"duration": 5e-3}, "duration"), ({"seed": -1}, "seed"),
])
def test_dc_motor_bad_arguments(kw, name):
    with pytest.raises(ValueError, match=f"^{name} must be"):
        dc_motor(**kw)


# --------------------------------------------------------------------------
# the regressors
# --------------------------------------------------------------------------

def test_regressor_layout(clean):
    data, _ = clean
    reg = _regs(data)
    assert isinstance(reg, DCMotorRegressors)
    assert reg.electrical.names == ("i", "di/dt", "omega")
    assert reg.mechanical.names == ("domega/dt", "omega", "sign(omega)", "1")
    assert reg.electrical.Phi.shape == (60000, 3) and reg.mechanical.Phi.shape == (60000, 4)
    assert reg.electrical.Phi.flags.c_contiguous and reg.electrical.Phi.dtype == np.float64
    np.testing.assert_array_equal(reg.electrical.index, np.arange(60000))
    np.testing.assert_allclose(reg.mechanical.Phi[:, 3], 1.0, rtol=1e-12)
    assert reg.meta["cutoff"] == pytest.approx(20.0)


@pytest.mark.parametrize("order", [1, 2, 3])
def test_state_variable_filter_equals_lsim(clean, order):
    """Filtered columns = continuous F(s), sF(s) driven by the held input (scipy.signal.lsim)."""
    from scipy.signal import StateSpace, lsim

    data, _ = clean
    n = 3000
    sl = slice(0, n)
    reg = dc_motor_regressors(data.time[sl], data.voltage[sl], data.current[sl],
                              data.speed[sl], cutoff=15.0, filter_order=order)
    wc = 2 * np.pi * 15.0
    # chain of `order` first-order lags wc/(s+wc): states x1..xn, output xn = F u,
    # derivative of the output = wc (x_{n-1} - x_n) (x_0 = u for order 1)
    A = -wc * np.eye(order) + wc * np.eye(order, k=-1)
    Bm = np.zeros((order, 1))
    Bm[0, 0] = wc
    C = np.zeros((2, order))
    C[0, -1] = 1.0
    C[1, -1] = -wc
    D = np.zeros((2, 1))
    if order > 1:
        C[1, -2] = wc
    else:
        D[1, 0] = wc
    sys = StateSpace(A, Bm, C, D)
    t = data.time.to_numpy()[sl]
    i = data.current.to_numpy()[sl]
    v = data.voltage.to_numpy()[sl]
    # steady state at the first sample: all states equal the first value
    _, yi, _ = lsim(sys, i, t, X0=np.full(order, i[0]), interp=True)  # first-order hold
    _, yv, _ = lsim(sys, v, t, X0=np.full(order, v[0]), interp=False)  # zero-order hold
    np.testing.assert_allclose(reg.electrical.Phi[:, 0], yi[:, 0], rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(reg.electrical.Phi[:, 1], yi[:, 1], rtol=1e-7, atol=1e-6)
    np.testing.assert_allclose(reg.electrical.y, yv[:, 0], rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(reg.mechanical.y, reg.electrical.Phi[:, 0])


@pytest.mark.parametrize("window", [(5000, 7000), (20000, 22000), (40000, 42000)])
def test_noise_free_batch_recovers_the_truth(clean, window):
    data, truth = clean
    reg = _regs(data)
    sl = slice(*window)
    te = np.linalg.lstsq(reg.electrical.Phi[sl], reg.electrical.y[sl], rcond=None)[0]
    tm = np.linalg.lstsq(reg.mechanical.Phi[sl], reg.mechanical.y[sl], rcond=None)[0]
    np.testing.assert_allclose(adaptid.lstsq(reg.electrical.Phi[sl], reg.electrical.y[sl]).theta,
                               te, rtol=1e-8)
    est = reg.physical(te, tm)
    true = {k: truth[k].to_numpy()[sl].mean() for k in PHYS}
    # 2 s windows: R drifts ~0.3 % within one; L carries an O((dt/τe)²) ≈ 0.13 %
    # first-order-hold bias (see the Notes of dc_motor_regressors)
    for k, tol in {"R": 5e-3, "L": 5e-3, "Ke": 5e-3, "J": 1e-2, "B": 2e-2, "tau_c": 2e-2}.items():
        assert est[k] == pytest.approx(true[k], rel=tol), k


def test_one_hold_for_every_signal_biases_L(clean):
    """The held voltage filtered like a sampled signal puts it dt/2 ahead: L + R dt/2."""
    data, truth = clean
    sl = slice(20000, 22000)
    te = {}
    for hold in ("zoh", "sampled"):
        reg = _regs(data, voltage_hold=hold)
        te[hold] = np.linalg.lstsq(reg.electrical.Phi[sl], reg.electrical.y[sl], rcond=None)[0]
    R = truth.R.to_numpy()[sl].mean()
    assert te["zoh"][1] == pytest.approx(PRM["L"], rel=5e-3)
    assert te["sampled"][1] == pytest.approx(PRM["L"] + R * 1e-3 / 2, rel=2e-2)


def _rls_final(reg, est_e, est_m, warm=200):
    te = est_e.run(reg.electrical.Phi[warm:], reg.electrical.y[warm:]).theta
    tm = est_m.run(reg.mechanical.Phi[warm:], reg.mechanical.y[warm:]).theta
    return reg.physical(te, tm)


@pytest.mark.parametrize("speed_kind", ["sampled", "interval_mean"])
def test_rls_with_forgetting_ends_within_2_percent(noisy, speed_kind):
    data, truth = noisy
    reg = _regs(data, speed_kind=speed_kind)
    ph = _rls_final(reg, adaptid.RLS(3, forgetting=0.9995, P0=1e4),
                    adaptid.RLS(4, forgetting=0.9995, P0=1e4))
    last = truth.iloc[-1]
    keys = ("R", "Ke", "J") if speed_kind == "sampled" else ("R", "L", "Ke", "J", "B", "tau_c")
    for k in keys:
        assert ph[k][-1] == pytest.approx(last[k], rel=0.02), k
    if speed_kind == "interval_mean":  # the small offset torque: 10 %
        assert ph["tau_0"][-1] == pytest.approx(last["tau_0"], rel=0.10)


def _settle(track, true, start, tol=0.02):
    """Samples after `start` until |track/true - 1| stays below tol."""
    rel = np.abs(track[start:] / true[start:] - 1)
    bad = np.nonzero(rel > tol)[0]
    return int(bad[-1] + 1) if bad.size else 0


def test_window_and_kalman_track_the_load_step(noisy):
    data, truth = noisy
    reg = _regs(data, speed_kind="interval_mean")
    warm = 200
    k_load = int(round(data.attrs["load_time"] / data.attrs["dt"])) - warm
    J = truth.J.to_numpy()[warm:]
    scale_e = np.array([1.1, 8e-3, 0.05])
    scale_m = np.array([8e-3, 4e-3, 0.16, 0.04])
    ests = {
        "window": (adaptid.SlidingWindowRLS(3, 2000, P0=1e4),
                   adaptid.SlidingWindowRLS(4, 2000, P0=1e4), 2100),
        "kalman": (adaptid.KalmanRLS(3, process_cov=np.diag((1e-4 * scale_e) ** 2),
                                     noise_var=2.6e-3, P0=1e4),
                   adaptid.KalmanRLS(4, process_cov=np.diag((1e-4 * scale_m) ** 2),
                                     noise_var=5.4e-5, P0=1e4), 3500),
    }
    for name, (ee, em, max_delay) in ests.items():
        ph = _rls_final(reg, ee, em, warm)
        # converged on the unloaded motor before the step
        np.testing.assert_allclose(ph["J"][k_load - 2000:k_load], J[0], rtol=0.02, err_msg=name)
        delay = _settle(ph["J"], J, k_load)
        assert 0 < delay <= max_delay, (name, delay)
        # R tracked within 2 % over the whole record after 5 s
        np.testing.assert_allclose(ph["R"][5000:], truth.R.to_numpy()[warm:][5000:], rtol=0.02)


def test_physical_mapping():
    reg = DCMotorRegressors(electrical=None, mechanical=None)
    te = np.array([1.2, 3e-3, 0.04])
    tm = np.array([0.01, 0.002, 0.3, -0.05])
    ph = reg.physical(te, tm)
    assert set(ph) == {"R", "L", "Ke", "Kt", "J", "B", "tau_c", "tau_0"}
    assert ph["R"] == 1.2 and ph["L"] == 3e-3 and ph["Ke"] == ph["Kt"] == 0.04
    np.testing.assert_allclose([ph["J"], ph["B"], ph["tau_c"], ph["tau_0"]], 0.04 * tm)
    tracks = reg.physical(np.tile(te, (5, 1)), np.tile(tm, (5, 1)))
    assert tracks["J"].shape == (5,)
    np.testing.assert_allclose(tracks["J"], 0.04 * 0.01)
    with pytest.raises(ValueError, match="^theta_e must be"):
        reg.physical(np.ones(4), tm)
    with pytest.raises(ValueError, match="^theta_m must be"):
        reg.physical(te, np.ones(3))
    with pytest.raises(ValueError, match="^theta_m must be"):
        reg.physical(np.ones((5, 3)), np.ones((4, 4)))


def test_regressors_bad_input():
    t = np.arange(100) * 1e-3
    x = np.sin(t)
    with pytest.raises(ValueError, match="^current must be"):
        dc_motor_regressors(t, x, x[:-1], x)
    with pytest.raises(ValueError, match="^speed must be"):
        dc_motor_regressors(t, x, x, np.r_[x, 0.0])
    t_bad = t.copy()
    t_bad[50] = t_bad[48]
    with pytest.raises(ValueError, match="^time must be strictly increasing"):
        dc_motor_regressors(t_bad, x, x, x)
    t_gap = t.copy()
    t_gap[50:] += 5e-4
    with pytest.raises(ValueError, match="^time must be uniformly sampled"):
        dc_motor_regressors(t_gap, x, x, x)
    for name in ("time", "voltage", "current", "speed"):
        args = {"time": t, "voltage": x, "current": x, "speed": x}
        bad = args[name].copy()
        bad[10] = np.nan
        args[name] = bad
        with pytest.raises(ValueError, match=f"^{name} must be"):
            dc_motor_regressors(**args)
    with pytest.raises(ValueError, match="^cutoff must be"):
        dc_motor_regressors(t, x, x, x, cutoff=600.0)
    with pytest.raises(ValueError, match="^cutoff must be"):
        dc_motor_regressors(t, x, x, x, cutoff=0.0)
    with pytest.raises(ValueError, match="^filter_order must be"):
        dc_motor_regressors(t, x, x, x, filter_order=0)
    with pytest.raises(ValueError, match="^filter_order must be"):
        dc_motor_regressors(t, x, x, x, filter_order=1, speed_kind="interval_mean")
    with pytest.raises(ValueError, match="^voltage_hold must be"):
        dc_motor_regressors(t, x, x, x, voltage_hold="foh")
    with pytest.raises(ValueError, match="^speed_kind must be"):
        dc_motor_regressors(t, x, x, x, speed_kind="encoder")
