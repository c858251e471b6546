r"""Regressors of the permanent-magnet DC motor's physics (electrical and mechanical)."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from .._validation import as_float_array, check_int, check_scalar, param_error
from ._regression import Regression

__all__ = ["DCMotorRegressors", "dc_motor_regressors", "state_variable_filter"]

_PHYSICAL = ("R", "L", "Ke", "Kt", "J", "B", "tau_c", "tau_0")


@dataclass(frozen=True, eq=False)
class DCMotorRegressors:
    r"""The two linear regressions of a DC motor (see :func:`dc_motor_regressors`).

    Attributes
    ----------
    electrical : Regression
        :math:`y = v_f`, :math:`\varphi = [i_f,\ (di/dt)_f,\ \omega_f]`,
        :math:`\theta = [R, L, K_e]`; names ``("i", "di/dt", "omega")``.
    mechanical : Regression
        :math:`y = i_f`,
        :math:`\varphi = [(d\omega/dt)_f,\ \omega_f,\ \mathrm{sign}(\omega)_f,\ 1]`,
        :math:`\theta = [J/K_t, B/K_t, \tau_c/K_t, \tau_0/K_t]`; names
        ``("domega/dt", "omega", "sign(omega)", "1")``.
    meta : dict
        ``dt``, ``cutoff`` (Hz), ``filter_order``, ``voltage_hold``.
    """

    electrical: Regression
    mechanical: Regression
    meta: dict = field(default_factory=dict, repr=False)

    #: names of the physical parameters returned by :meth:`physical`
    parameter_names = _PHYSICAL

    def physical(self, theta_e, theta_m) -> dict:
        r"""Map regression estimates to the physical motor parameters.

        Parameters
        ----------
        theta_e : array_like, shape (3,) or (N, 3)
            Estimate(s) of the electrical regression, :math:`[R, L, K_e]`.
        theta_m : array_like, shape (4,) or (N, 4)
            Estimate(s) of the mechanical regression,
            :math:`[J/K_t, B/K_t, \tau_c/K_t, \tau_0/K_t]`; the same leading
            shape as ``theta_e`` (e.g. two ``Trajectory.theta`` tracks).

        Returns
        -------
        dict of str to ndarray, each of shape () or (N,)
            ``R, L, Ke, Kt, J, B, tau_c, tau_0``, with :math:`K_t = \hat K_e`
            (SI units) and :math:`J = K_t\,\hat\theta_{m,1}`,
            :math:`B = K_t\,\hat\theta_{m,2}`, :math:`\tau_c = K_t\,\hat\theta_{m,3}`,
            :math:`\tau_0 = K_t\,\hat\theta_{m,4}`.

        Raises
        ------
        ValueError
            If the last axes are not 3 and 4, or the leading shapes differ.
        """
        te = as_float_array(theta_e, "theta_e", ndim=(1, 2), finite=False)
        tm = as_float_array(theta_m, "theta_m", ndim=(1, 2), finite=False)
        if te.shape[-1] != 3:
            raise param_error("theta_e", "of shape (3,) or (N, 3)", f"<shape {te.shape}>")
        if tm.shape[-1] != 4:
            raise param_error("theta_m", "of shape (4,) or (N, 4)", f"<shape {tm.shape}>")
        if te.shape[:-1] != tm.shape[:-1]:
            raise param_error("theta_m", f"of the same leading shape as theta_e {te.shape[:-1]}",
                              f"<shape {tm.shape}>")
        R, L, Ke = te[..., 0], te[..., 1], te[..., 2]
        Kt = Ke.copy()
        return {"R": R.copy(), "L": L.copy(), "Ke": Ke.copy(), "Kt": Kt,
                "J": Kt * tm[..., 0], "B": Kt * tm[..., 1],
                "tau_c": Kt * tm[..., 2], "tau_0": Kt * tm[..., 3]}


def state_variable_filter(dt, cutoff, order=2, method="zoh"):
    r"""Discrete state-variable filter: a low-pass and its exact derivative.

    Parameters
    ----------
    dt : float
        Sample time, s.
    cutoff : float
        Frequency of the filter's ``order``-fold real pole, Hz
        (:math:`\omega_c = 2\pi\,\mathrm{cutoff}`).
    order : int, default 2
        Filter order n ≥ 1.
    method : {"zoh", "foh", "bilinear"}, default "zoh"
        Discretisation of both transfer functions (:func:`scipy.signal.cont2discrete`).

    Returns
    -------
    (b, a), (bd, a) : tuples of ndarray
        Numerator/denominator of the discretised
        :math:`F(s) = \omega_c^n/(s + \omega_c)^n` and of :math:`s\,F(s)`, for
        :func:`scipy.signal.lfilter`; they share the denominator ``a``.
    """
    from scipy.signal import cont2discrete

    wc = 2.0 * math.pi * cutoff
    den = np.poly(np.full(order, -wc)).real
    num = np.array([wc ** order])
    numd = np.array([wc ** order, 0.0])
    b, a, _ = cont2discrete((num, den), dt, method=method)
    bd, ad, _ = cont2discrete((numd, den), dt, method=method)
    b, bd = np.ravel(b), np.ravel(bd)
    a = np.asarray(a, dtype=float)
    # the two share the characteristic polynomial; use one copy exactly
    return (b, a), (bd, a)


def _second_derivative_filter(dt, cutoff, order):
    """First-order-hold discretisation of s²F(s) (needs order >= 2)."""
    from scipy.signal import cont2discrete

    wc = 2.0 * math.pi * cutoff
    den = np.poly(np.full(order, -wc)).real
    b2, a2, _ = cont2discrete((np.array([wc ** order, 0.0, 0.0]), den), dt, method="foh")
    return np.ravel(b2), np.asarray(a2, dtype=float)


def _filter_columns(b, a, X):
    """Filter every column of X, each starting in steady state at its first value."""
    from scipy.signal import lfilter, lfilter_zi

    zi = lfilter_zi(b, a)
    out = np.empty_like(X)
    for j in range(X.shape[1]):  # a handful of columns, each one compiled lfilter
        out[:, j], _ = lfilter(b, a, X[:, j], zi=zi * X[0, j])
    return out


def dc_motor_regressors(time, voltage, current, speed, *, cutoff=None, filter_order=2,
                        voltage_hold="zoh", speed_kind="sampled"):
    r"""Electrical and mechanical regressors of a permanent-magnet DC motor.

    Builds, from sampled voltage, current and speed, the two linear-in-the-
    parameters equations of the motor, with every signal of an equation passed
    through the same causal low-pass filter and the derivatives taken exactly
    on the filtered signals:

    .. math::

        v_f &= R\,i_f + L\,(di/dt)_f + K_e\,\omega_f, \\
        i_f &= \frac{J}{K_t}\,(d\omega/dt)_f + \frac{B}{K_t}\,\omega_f
              + \frac{\tau_c}{K_t}\,\mathrm{sign}(\omega)_f + \frac{\tau_0}{K_t}.

    Parameters
    ----------
    time : array_like, shape (N,)
        Sample times, s; strictly increasing with a constant step (a relative
        jitter up to 1e-6 of the step is accepted).
    voltage : array_like, shape (N,)
        Applied (averaged) motor voltage, V.
    current : array_like, shape (N,)
        Motor current, A.
    speed : array_like, shape (N,)
        Shaft speed, rad/s.
    cutoff : float, optional
        Pole frequency of the filter, Hz, in (0, fs/2); default ``fs / 50``
        (20 Hz at 1 kHz).
    filter_order : int, default 2
        Order n ≥ 1 of the filter :math:`\omega_c^n/(s+\omega_c)^n`.
    voltage_hold : {"zoh", "sampled"}, default "zoh"
        How ``voltage`` relates to the continuous voltage: ``"zoh"``,
        ``voltage[k]`` is the (PWM-averaged) voltage applied over
        :math:`[t_k, t_{k+1})`, as a drive's duty command; ``"sampled"``, a
        sample at :math:`t_k` of a continuous voltage, like the other signals.

    Returns
    -------
    DCMotorRegressors
        ``.electrical`` (:math:`\theta = [R, L, K_e]`, names
        ``("i", "di/dt", "omega")``), ``.mechanical``
        (:math:`\theta = [J, B, \tau_c, \tau_0]/K_t`, names
        ``("domega/dt", "omega", "sign(omega)", "1")``), each a
        :class:`~adaptid.models.Regression` with all N rows (``index`` =
        0..N−1), and ``.physical(theta_e, theta_m)`` mapping estimates (or
        tracks) to ``R, L, Ke, Kt, J, B, tau_c, tau_0``.

    Raises
    ------
    ValueError
        Arrays of different lengths or not 1-D (names the argument), NaN or
        infinite values, a time vector that is not strictly increasing with a
        constant step, fewer than 2 samples, ``cutoff`` outside (0, fs/2),
        ``filter_order`` < 1, an unknown ``voltage_hold``.

    Notes
    -----
    **Normalisation.** The mechanical equation is divided by :math:`K_t` so
    that its regressand is the measured current and its regressors are
    functions of the speed only; :math:`K_t` itself is not identifiable from
    that equation alone. For a permanent-magnet motor :math:`K_t = K_e` in SI
    units (N·m/A = V·s/rad, by the power balance), so
    :meth:`DCMotorRegressors.physical` takes :math:`K_t = \hat K_e` from the
    electrical equation and scales :math:`J, B, \tau_c, \tau_0` by it.

    **Filtering and derivatives.** Differencing noisy, quantised samples
    amplifies the noise, and a two-sided (zero-phase) filter is not available
    on line. Instead a state-variable filter (SVF) is used: the causal
    continuous-time filter :math:`F(s) = \omega_c^n/(s+\omega_c)^n` realised so
    that the derivative of its output, :math:`s\,F(s)\,x`, is available as
    well (:func:`state_variable_filter`). Every column and the regressand of one
    equation go through this same filter, so the continuous-time equation
    holds exactly for the filtered signals, instead of being broken by a
    derivative approximated on raw data. The filter is discretised exactly
    (:func:`scipy.signal.cont2discrete`) for the inter-sample behaviour of
    each input, so that each filtered sample equals the continuous filter's
    output at :math:`t_k`: a zero-order hold for the voltage (exact for a
    voltage held over the sample interval), a first-order hold (linear
    interpolation) for the measured current and speed, whose error is
    :math:`O(dt^2)` — for the current it biases :math:`\hat L` by about
    :math:`(dt/\tau_e)^2/12` relative (:math:`\tau_e = L/R`; 0.13 % at
    :math:`\tau_e = 8\,dt`). Discretising every signal with one rule instead
    would put the held voltage half a sample ahead of the sampled current and
    bias :math:`\hat L` by :math:`R\,dt/2`. The filters run with
    :func:`scipy.signal.lfilter` (one compiled pass per column, causal,
    sample by sample as an on-line estimator sees the data; each column
    starts in steady state at its first value, as an on-line filter
    initialised on its first sample would). The non-linear column
    :math:`\mathrm{sign}(\omega)` is formed from the raw speed and then
    filtered like the other columns (filtering the product column, not the
    speed before the sign); the constant column 1 is filtered too and stays
    1. The regressions keep all N rows: the first few filter time constants
    (:math:`\approx 5n/\omega_c`, 80 ms at the default) are a transient that an
    estimator should skip. A speed obtained by differencing encoder counts is
    the mean over the last sample interval, i.e. delayed by :math:`dt/2`;
    this biases :math:`\hat R` by about :math:`K_e K_t\,dt/(2J)` (0.2–0.6 %
    on :func:`adaptid.datasets.dc_motor`).

    The default cutoff ``fs / 50`` lies well above the mechanical bandwidth
    and a decade below the sensor noise band; raise it for fast electrical
    dynamics, lower it for noisier sensors.

    References
    ----------
    P. C. Young, "Parameter estimation for continuous-time models — a
    survey", *Automatica* 17(1), 23–39, 1981 (state-variable filters).
    H. Garnier, M. Mensler, A. Richard, "Continuous-time model identification
    from sampled data: implementation issues and performance evaluation",
    *Int. J. Control* 76(13), 1337–1357, 2003.

    Examples
    --------
    >>> import adaptid
    >>> from adaptid.datasets import dc_motor
    >>> from adaptid.models._dcmotor import dc_motor_regressors
    >>> data, truth = dc_motor(seed=0, duration=10.0, noise=False)
    >>> reg = dc_motor_regressors(data.time, data.voltage, data.current, data.speed)
    >>> th = adaptid.lstsq(reg.electrical.Phi[500:3000], reg.electrical.y[500:3000]).theta
    >>> bool(abs(th[2] / truth.Ke[0] - 1) < 1e-2)
    True
    """
    v, i, w, dt = _check_signals(time, voltage, current, speed)
    order, cutoff = _check_options(dt, cutoff, filter_order, voltage_hold, speed_kind)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            cols = _filtered_columns(dt, cutoff, order, voltage_hold, speed_kind, v, i, w)
    except np.linalg.LinAlgError:
        # poles exp(-2π·cutoff·dt) that round to 1: the filter's steady state is singular
        raise param_error("cutoff", f"large enough for the filter to be discretised "
                          f"(above about fs·1e-8 = {1e-8 / dt:.3g} Hz)", cutoff) from None
    for rec in caught:  # the warnings of a filter that worked, as they were
        warnings.warn_explicit(rec.message, rec.category, rec.filename, rec.lineno)
    meta = {"dt": dt, "cutoff": cutoff, "filter_order": order,
            "voltage_hold": voltage_hold, "speed_kind": speed_kind}
    index = np.arange(v.shape[0])
    electrical = Regression(
        Phi=np.ascontiguousarray(np.column_stack([cols["i"], cols["di/dt"], cols["omega"]])),
        y=cols["v"], names=("i", "di/dt", "omega"), index=index,
        meta={**meta, "equation": "electrical", "theta": ("R", "L", "Ke")})
    mechanical = Regression(
        Phi=np.ascontiguousarray(np.column_stack([cols["domega/dt"], cols["omega"],
                                                  cols["sign(omega)"], cols["1"]])),
        y=cols["i"].copy(), names=("domega/dt", "omega", "sign(omega)", "1"),
        index=index.copy(),
        meta={**meta, "equation": "mechanical",
              "theta": ("J/Kt", "B/Kt", "tau_c/Kt", "tau_0/Kt")})
    return DCMotorRegressors(electrical=electrical, mechanical=mechanical, meta=meta)


def _check_signals(time, voltage, current, speed):
    """Voltage, current and speed as 1-D arrays of the time's length, and the constant step."""
    t = as_float_array(time, "time", ndim=1)
    n = t.shape[0]
    sig = {}
    for name, x in (("voltage", voltage), ("current", current), ("speed", speed)):
        arr = as_float_array(x, name, ndim=1)
        if arr.shape[0] != n:
            raise param_error(name, f"of the same length as time ({n})", f"<length {arr.shape[0]}>")
        sig[name] = arr
    if n < 2:
        raise param_error("time", "at least 2 samples long", f"<length {n}>")
    steps = np.diff(t)
    if not np.all(steps > 0):
        k = int(np.argmax(steps <= 0))
        raise param_error("time", "strictly increasing",
                          f"<time[{k + 1}] = {t[k + 1]!r} after time[{k}] = {t[k]!r}>")
    dt = float((t[-1] - t[0]) / (n - 1))
    if np.max(np.abs(steps - dt)) > 1e-6 * dt:
        raise param_error("time", "uniformly sampled (constant step)",
                          f"<steps from {steps.min():.6g} to {steps.max():.6g} s>")
    return sig["voltage"], sig["current"], sig["speed"], dt


def _check_options(dt, cutoff, filter_order, voltage_hold, speed_kind):
    """The filter order and cutoff (default fs / 50); the choices of the two signal kinds."""
    fs = 1.0 / dt
    order = check_int(filter_order, "filter_order", low=1)
    if cutoff is None:
        cutoff = fs / 50.0
    cutoff = check_scalar(cutoff, "cutoff", low=0.0, high=fs / 2.0, low_open=True,
                          high_open=True)
    if voltage_hold not in ("zoh", "sampled"):
        raise param_error("voltage_hold", "one of 'zoh', 'sampled'", voltage_hold)
    if speed_kind not in ("sampled", "interval_mean"):
        raise param_error("speed_kind", "one of 'sampled', 'interval_mean'", speed_kind)
    if speed_kind == "interval_mean" and order < 2:
        raise param_error("filter_order", "at least 2 with speed_kind='interval_mean'", order)
    return order, cutoff


def _filtered_columns(dt, cutoff, order, voltage_hold, speed_kind, v, i, w):
    """Every column and regressand of the two equations through the same filter F.

    Keys ``v, i, di/dt, omega, domega/dt, sign(omega), 1`` (each shape (N,)).
    """
    n = v.shape[0]
    # measured signals: samples of continuous signals (first-order hold)
    (b, a), (bd, _) = state_variable_filter(dt, cutoff, order, "foh")
    if speed_kind == "sampled":
        # one pass of F over [i, ω, sign ω, 1]; one pass of sF over [i, ω]
        low = _filter_columns(b, a, np.column_stack([i, w, np.sign(w), np.ones(n)]))
        der = _filter_columns(bd, a, np.column_stack([i, w]))
        i_f, wf, sf, one = (low[:, j] for j in range(4))
        dif, dwf = der[:, 0], der[:, 1]
    else:
        # the angle at the sample instants is exact: θ_k = θ_0 + dt Σ ω̄_j;
        # ω_f = sF θ and (dω/dt)_f = s²F θ
        angle = np.empty(n)
        angle[0] = 0.0
        np.cumsum(w[1:] * dt, out=angle[1:])
        low = _filter_columns(b, a, np.column_stack([i, np.sign(w), np.ones(n)]))
        der = _filter_columns(bd, a, np.column_stack([i, angle]))
        b2, a2 = _second_derivative_filter(dt, cutoff, order)
        i_f, sf, one = (low[:, j] for j in range(3))
        dif, wf = der[:, 0], der[:, 1]
        dwf = _filter_columns(b2, a2, angle[:, None])[:, 0]
    if voltage_hold == "zoh":
        (bv, av), _ = state_variable_filter(dt, cutoff, order, "zoh")
    else:
        bv, av = b, a
    vf = _filter_columns(bv, av, v[:, None])[:, 0]
    return {"v": vf, "i": i_f, "di/dt": dif, "omega": wf, "domega/dt": dwf,
            "sign(omega)": sf, "1": one}
