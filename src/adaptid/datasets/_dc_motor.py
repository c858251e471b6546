r"""A simulated permanent-magnet DC motor driving a load: the ``adaptid demo`` data set."""

from __future__ import annotations

import math

import numpy as np

from .._kernels.layers._simulators import DC_MOTOR_PARAMETER_ORDER, simulate_dc_motor
from .._validation import check_scalar, param_error

__all__ = ["dc_motor", "MOTOR_PARAMETERS"]

#: Nominal parameters of the simulated motor (SI units). ``R0`` is the winding
#: resistance at the ambient temperature ``T_amb``; ``J0, B0`` hold before the
#: load is coupled and ``J1, B1`` after.
MOTOR_PARAMETERS = {
    "R0": 1.0,            # Ω, winding resistance at T_amb
    "alpha": 3.93e-3,     # 1/K, temperature coefficient of copper
    "T_amb": 25.0,        # °C
    "L": 8.0e-3,          # H   (electrical time constant L/R0 = 8 ms = 8 samples)
    "Ke": 0.05,           # V·s/rad (= Kt in N·m/A)
    "J0": 2.0e-4,         # kg·m², rotor + coupling
    "J1": 6.0e-4,         # kg·m², with the load coupled
    "B0": 1.0e-4,         # N·m·s/rad
    "B1": 3.0e-4,         # N·m·s/rad, with the load's viscous brake
    "tau_c": 8.0e-3,      # N·m, Coulomb friction
    "tau_0": 2.0e-3,      # N·m, constant load torque (offset)
    "C_th": 10.0,         # J/K, thermal capacity of the winding
    "R_th": 4.0,          # K/W, winding-to-ambient thermal resistance (τ_th = 40 s)
    "V_bus": 12.0,        # V, H-bridge supply
    "duty_bits": 12,      # PWM duty resolution (sign + 11 bits over ±V_bus)
    "i_range": 25.0,      # A, current sensor full scale (±)
    "adc_bits": 12,       # current ADC resolution
    "i_noise": 0.015,     # A, RMS analogue noise of the current sensor
    "encoder_counts": 16384,  # counts per revolution (4096 lines, ×4 decoding)
}

def _param_vector(prm):
    """The simulator's parameter vector (order of the kernel's list; K_t = K_e in SI units)."""
    named = {**prm, "Kt": prm["Ke"]}
    return np.array([named[k] for k in DC_MOTOR_PARAMETER_ORDER])


def _excitation(rng, n, dt, prm):
    """Averaged PWM voltage: random multilevel steps plus a small multisine."""
    t = np.arange(n) * dt
    # random levels held 50..350 ms; duty in [-0.5, 1] avoiding |d| < 0.15 so
    # that the motor never stalls in static friction
    n_seg = int(np.ceil(n * dt / 0.05)) + 2
    hold = rng.uniform(0.05, 0.35, n_seg)
    level = rng.uniform(-0.5, 1.0, n_seg)
    small = np.abs(level) < 0.15
    level[small] = np.where(level[small] < 0, -0.15, 0.15) + 0.3 * level[small]
    edges = np.concatenate(([0.0], np.cumsum(hold)))
    seg = np.searchsorted(edges, t, side="right") - 1
    duty = level[np.minimum(seg, n_seg - 1)]
    # multisine of 8 log-spaced frequencies 3..150 Hz, random phases, to excite
    # the electrical dynamics (amplitude 4 % of the bus)
    freqs = np.geomspace(3.0, 150.0, 8)
    phases = rng.uniform(0.0, 2.0 * np.pi, freqs.size)
    ms = np.sin(2.0 * np.pi * freqs[None, :] * t[:, None] + phases[None, :]).sum(axis=1)
    duty = duty + 0.04 * ms / np.sqrt(freqs.size / 2.0)
    # the motor starts at rest with the bridge off for the first 100 ms
    duty[t < 0.1] = 0.0
    duty = np.clip(duty, -1.0, 1.0)
    q = 2.0 ** (prm["duty_bits"] - 1)
    duty = np.round(duty * q) / q
    return duty * prm["V_bus"]


def dc_motor(seed=0, *, duration=60.0, dt=1e-3, noise=True):
    r"""Simulated record of a permanent-magnet DC motor that gets a load mid-run.

    A physically faithful simulation of a small brushed PM DC motor fed by an
    H-bridge (averaged PWM voltage), with the true parameter trajectories.
    The data set of ``adaptid demo``; deterministic for a given seed.

    Parameters
    ----------
    seed : int, default 0
        Seed of the :func:`numpy.random.default_rng` generator that draws the
        excitation, the sensor noise and the encoder's initial angle.
    duration : float, default 60.0
        Length of the record, s.
    dt : float, default 1e-3
        Sample time, s (sensors sampled and PWM duty updated every ``dt``).
    noise : bool, default True
        ``False`` returns the exact motor current and speed at the sample
        instants (no sensor noise, quantisation or encoder differencing).

    Returns
    -------
    data : pandas.DataFrame, shape (N, 4)
        Columns ``time`` (s), ``voltage`` (V; the averaged PWM voltage applied
        over ``[t_k, t_{k+1})``), ``current`` (A) and ``speed`` (rad/s),
        N = round(duration / dt).
    truth : pandas.DataFrame, shape (N, 9)
        Columns ``time, R, L, Ke, Kt, J, B, tau_c, tau_0``: the true
        parameters at each sample (Ω, H, V·s/rad, N·m/A, kg·m², N·m·s/rad,
        N·m, N·m). Both frames carry ``attrs = {"load_time", "dt", "seed"}``
        (s, s, int).

    Raises
    ------
    ValueError
        If ``duration`` or ``dt`` is not positive and finite, or the record
        would have fewer than 10 samples.
    ImportError
        If pandas is not installed (``pip install 'adaptid[pandas]'``).

    Notes
    -----
    **Motor.** Current :math:`i`, speed :math:`\omega`, winding temperature
    :math:`T`:

    .. math::

        v &= R(T)\,i + L\,\frac{di}{dt} + K_e\,\omega, \\
        K_t\,i &= J\,\frac{d\omega}{dt} + B\,\omega
                 + \tau_c\,\mathrm{sign}(\omega) + \tau_0, \\
        C_{th}\,\frac{dT}{dt} &= R(T)\,i^2 - \frac{T - T_{amb}}{R_{th}}, \qquad
        R(T) = R_0\,(1 + \alpha\,(T - T_{amb})).

    :math:`K_t = K_e` in SI units: for a permanent-magnet machine both are the
    same flux linkage constant (power balance :math:`K_t i \omega = K_e \omega i`).
    Nominal values in :data:`MOTOR_PARAMETERS`: :math:`R_0 = 1\ \Omega`,
    :math:`L = 8` mH (L/R = 8 samples at 1 kHz), :math:`K_e = 0.05` V·s/rad,
    :math:`J = 2\cdot10^{-4} \to 6\cdot10^{-4}` kg·m²,
    :math:`B = 10^{-4} \to 3\cdot10^{-4}` N·m·s/rad, :math:`\tau_c = 8` mN·m,
    :math:`\tau_0 = 2` mN·m. The Joule losses heat the winding (first-order
    thermal model, time constant 40 s): R rises by roughly 10–20 % over the
    default 60 s record. :math:`K_e` is held constant (magnet temperature is
    not modelled). At ω = 0 a static-friction (Karnopp) test holds the rotor
    while :math:`|K_t i - \tau_0| \le \tau_c`.

    **Load.** At ``load_time = duration / 2`` a load (flywheel plus a viscous
    brake) is engaged through a synchronising clutch: J and B step to their
    loaded values; the speed is continuous (the load is spun up to the motor
    speed before engagement).

    **Integration.** The voltage is held over each sample interval (ZOH);
    the three ODEs plus the shaft angle are integrated with classical RK4 on
    sub-steps of at most 50 µs (20 per sample at 1 kHz) in one compiled
    kernel. The friction direction is frozen within a sub-step; a speed
    reversal is located (linear guess plus one secant step), the step is
    stopped exactly at ω = 0 and finished in the new direction (or stuck),
    so the discontinuous friction does not degrade the accuracy.

    **Excitation.** PWM duty (12-bit, ±12 V bus) = random levels in
    [−0.5, 1] (``|duty| ≥ 0.15``, so the motor never stalls in static friction)
    held 50–350 ms, plus a multisine of 8 log-spaced tones 3–150 Hz with
    4 % amplitude each scaled, to excite the electrical dynamics. The speed
    is mostly positive but reverses every few seconds, which makes Coulomb
    friction and the offset τ₀ separately identifiable. The first 100 ms
    the bridge is off (motor at rest).

    **Sensors** (``noise=True``). Current: Hall sensor with 15 mA RMS white
    noise, quantised by a 12-bit ADC over ±25 A (12.2 mA steps), sampled at
    :math:`t_k`. Speed: a 4096-line quadrature encoder (16384 counts/rev,
    random initial angle) differenced over the last sample,
    :math:`\hat\omega_k = 2\pi(c_k - c_{k-1})/(16384\,dt)` — the mean speed
    over :math:`[t_{k-1}, t_k]` in steps of 0.38 rad/s, i.e. the true
    speed delayed by half a sample, as a drive's firmware reports it.

    Examples
    --------
    >>> from adaptid.datasets import dc_motor
    >>> data, truth = dc_motor(seed=0)
    >>> list(data.columns)
    ['time', 'voltage', 'current', 'speed']
    >>> bool(truth["R"].iloc[-1] > 1.05 * truth["R"].iloc[0])
    True
    """
    try:
        import pandas as pd
    except ImportError as err:  # pragma: no cover - exercised without pandas
        raise ImportError("dc_motor needs pandas: pip install 'adaptid[pandas]'") from err
    seed, duration, dt, n = _check_arguments(seed, duration, dt)
    noise = bool(noise)
    prm = MOTOR_PARAMETERS
    rng = np.random.default_rng(seed)
    voltage = _excitation(rng, n, dt, prm)
    k_load = int(round(duration / 2.0 / dt))
    states = _motor_states(voltage, dt, k_load, prm)
    # sensors: always draw the random numbers, so that the excitation does
    # not depend on `noise`
    angle0 = rng.uniform(0.0, 2.0 * np.pi)
    e_i = rng.standard_normal(n)
    if noise:
        current, speed = _sensors(states, angle0, e_i, dt, prm)
    else:
        current, speed = states[:, 0].copy(), states[:, 1].copy()

    time = np.arange(n) * dt
    attrs = {"load_time": float(k_load * dt), "dt": dt, "seed": seed}
    data = pd.DataFrame({"time": time, "voltage": voltage, "current": current,
                         "speed": speed})
    truth = _truth(time, states[:, 2], k_load, prm)
    data.attrs.update(attrs)
    truth.attrs.update(attrs)
    return data, truth


def _check_arguments(seed, duration, dt):
    """Seed (a non-negative int), duration and dt (positive), and the number of samples."""
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise param_error("seed", "a non-negative integer", seed, exc=TypeError)
    if seed < 0:
        raise param_error("seed", "a non-negative integer", seed)
    duration = check_scalar(duration, "duration", low=0.0, low_open=True)
    dt = check_scalar(dt, "dt", low=0.0, low_open=True)
    n = int(round(duration / dt))
    if n < 10:
        raise param_error("duration", f"at least 10 samples of dt={dt:g} s", duration)
    return int(seed), duration, dt, n


def _motor_states(voltage, dt, k_load, prm):
    """(N, 4) states [i, ω, T, angle] at the sample instants, from rest at ambient temperature.

    RK4 sub-steps of at most 50 µs (compiled kernel of :mod:`adaptid._kernels.layers._simulators`).
    """
    n_sub = max(1, int(math.ceil(dt / 5e-5 - 1e-9)))
    x0 = np.array([0.0, 0.0, prm["T_amb"], 0.0])
    states = np.empty((voltage.shape[0], 4))
    simulate_dc_motor(voltage, dt, n_sub, k_load, _param_vector(prm), x0, states)
    return states


def _sensors(states, angle0, e_i, dt, prm):
    """Measured current (noisy, 12-bit ADC) and speed (encoder counts differenced over dt)."""
    lsb = 2.0 * prm["i_range"] / 2.0 ** prm["adc_bits"]
    current = np.clip(np.round((states[:, 0] + prm["i_noise"] * e_i) / lsb) * lsb,
                      -prm["i_range"], prm["i_range"] - lsb)
    step = 2.0 * np.pi / prm["encoder_counts"]
    counts = np.floor((states[:, 3] + angle0) / step)
    speed = np.empty(states.shape[0])
    speed[0] = 0.0
    speed[1:] = np.diff(counts) * (step / dt)
    return current, speed


def _truth(time, temperature, k_load, prm):
    """The true parameters at each sample (R follows the winding temperature)."""
    import pandas as pd

    n = time.shape[0]
    R = prm["R0"] * (1.0 + prm["alpha"] * (temperature - prm["T_amb"]))
    loaded = np.arange(n) >= k_load
    ones = np.ones(n)
    return pd.DataFrame({
        "time": time, "R": R, "L": prm["L"] * ones, "Ke": prm["Ke"] * ones,
        "Kt": prm["Ke"] * ones, "J": np.where(loaded, prm["J1"], prm["J0"]),
        "B": np.where(loaded, prm["B1"], prm["B0"]), "tau_c": prm["tau_c"] * ones,
        "tau_0": prm["tau_0"] * ones})
