r"""A synthetic fleet of DC motors, some with a fault: data for :mod:`adaptid.fleet`."""

from __future__ import annotations

import numpy as np

from .._validation import check_choice, check_int, check_scalar, param_error

__all__ = ["fleet"]


# nominal values of the simulated motors (a small permanent-magnet DC motor)
_NOMINAL = {"R": 1.0, "L": 5e-3, "Ke": 0.05, "V_b": 0.5}
_J = 1e-4       # rotor and load inertia, kg m^2
_B = 1e-3       # viscous friction, N m s
_PHI = ("i", "di_dt", "omega", "sign_i")
_FAULT_PARAMS = ("R", "L", "Ke", "V_b")


def fleet(n_devices=100, n_samples=1000, seed=0, *, fault_fraction=0.1, fault_param="R",
          fault_size=0.3, spread=0.2, noise_std=0.05, dt=1e-3, return_truth=False):
    r"""A synthetic fleet of current-controlled DC motors, some with a fault.

    Every device is a permanent-magnet DC motor whose current follows a
    random step reference (a current-controlled drive under a varying load);
    its armature voltage obeys the electrical equation, discretised with a
    backward difference of the current,

    .. math::

        v_k = R\,i_k + L\,\frac{i_k - i_{k-1}}{T} + K_e\,\omega_k
              + V_b\,\operatorname{sign}(i_k) + e_k,
        \qquad e_k \sim N(0, \sigma_v^2),

    which is a linear regression :math:`y_k = \theta^T\varphi_k + e_k` with
    ``y = v``, :math:`\varphi_k = [i_k,\ (i_k - i_{k-1})/T,\ \omega_k,\
    \operatorname{sign}(i_k)]` (columns ``i, di_dt, omega, sign_i``) and
    :math:`\theta = [R, L, K_e, V_b]` (n = 4), exact up to the noise. The
    speed follows the mechanical equation :math:`J\dot\omega = K_e i - B\omega
    - \tau_L` (explicit Euler at the sample time T, load torque
    :math:`\tau_L` a random step signal), so :math:`\omega` is smooth and
    correlated with the current, as on a real drive.

    Parameters
    ----------
    n_devices : int
        Number of devices G ≥ 1.
    n_samples : int
        Samples per device N ≥ 10.
    seed : int
        Seed of the random generator (``numpy.random.default_rng``); the
        same seed gives the same fleet.
    fault_fraction : float
        Fraction of faulty devices, in [0, 1] (rounded to a whole number of
        devices).
    fault_param : {"R", "L", "Ke", "V_b"}
        The parameter the fault changes.
    fault_size : float
        Relative change of that parameter (0.3: +30 %), > −1.
    spread : float
        Relative spread of the parameters across devices: each parameter is
        its nominal value times a uniform factor in [1 − spread, 1 + spread],
        spread in [0, 1).
    noise_std : float
        Standard deviation :math:`\sigma_v` of the voltage noise, V, ≥ 0.
    dt : float
        Sample time T, s, > 0.
    return_truth : bool
        Also return the ground truth.

    Returns
    -------
    df : pandas.DataFrame, shape (G·N, 7)
        Long format, sorted by device then time: ``device`` (int64, 0 … G−1),
        ``time`` (float64, k·T), ``v``, ``i``, ``di_dt``, ``omega``,
        ``sign_i`` (float64).
    truth : pandas.DataFrame, only with ``return_truth=True``
        The ground truth, indexed by device: the true
        parameters before any fault (``R``, ``L``, ``Ke``, ``V_b``),
        ``fault`` (bool), ``fault_param``, ``fault_sample`` (0-based index
        of the first sample with the changed parameter, −1 if none),
        ``fault_time`` (its time, NaN if none) and ``value_after`` (the
        faulty parameter's value after the fault, NaN if none).
        (Kept out of ``df.attrs``, which pandas copies on every operation
        and must serialise as JSON when writing Parquet.)
        ``df.attrs["regression"]`` is ``{"y": "v", "phi": ["i", "di_dt", "omega", "sign_i"]}``.

    Notes
    -----
    The fault time of a faulty device is uniform in the middle of its
    record, samples [0.3 N, 0.7 N]. The current is
    :math:`i_k = I_0 + \Delta_k + r_k`: a device-specific mean
    :math:`I_0 \in [1.5, 3]` A, a random step reference
    :math:`\Delta_k \in [-1, 1]` A held for 20–80 samples, and a small
    ripple :math:`r_k \sim N(0, 0.01^2)`, so :math:`i_k > 0` and
    :math:`\operatorname{sign}(i_k) = 1` (the brush drop acts as an offset).
    Vectorised over devices; the only loop is the Euler recursion of the
    speed over the N samples.

    Examples
    --------
    >>> from adaptid.datasets import fleet
    >>> df = fleet(n_devices=5, n_samples=200, seed=1)
    >>> df.shape, list(df.columns)
    ((1000, 7), ['device', 'time', 'v', 'i', 'di_dt', 'omega', 'sign_i'])
    >>> df, truth = fleet(n_devices=5, n_samples=200, seed=1, return_truth=True)
    >>> int(truth["fault"].sum())
    0
    """
    import pandas as pd

    G, N, fault_fraction, fault_param, fault_size, spread, noise_std, dt = _check_arguments(
        n_devices, n_samples, seed, fault_fraction, fault_param, fault_size, spread, noise_std,
        dt)
    rng = np.random.default_rng(seed)
    # the random draws, in this order: parameters, currents, load torques, faults, noise
    par = {k: v * rng.uniform(1.0 - spread, 1.0 + spread, G) for k, v in _NOMINAL.items()}

    # one float block (columns time, v, i, di_dt, omega, sign_i), filled in place
    # and handed to pandas without a copy
    block = np.empty((6, G * N))
    t_, v, i, di_dt, omega, sign_i = (row.reshape(G, N) for row in block)
    _currents(rng, dt, i, di_dt, sign_i)
    _speeds(rng, dt, par["Ke"], i, omega)
    faulty, k_fault, after = _faults(rng, G, N, fault_fraction, par[fault_param], fault_size)
    regressor = {"R": i, "L": di_dt, "Ke": omega, "V_b": sign_i}
    _voltages(rng, noise_std, par, regressor, v, faulty, k_fault, after, fault_param)
    t_[:] = np.arange(N) * dt

    df = pd.DataFrame(block.T, columns=["time", "v", "i", "di_dt", "omega", "sign_i"],
                      copy=False)
    df.insert(0, "device", np.repeat(np.arange(G, dtype=np.int64), N))
    df.attrs["regression"] = {"y": "v", "phi": list(_PHI)}
    if not return_truth:
        return df
    truth = pd.DataFrame({
        **par,
        "fault": faulty,
        "fault_param": np.where(faulty, fault_param, ""),
        "fault_sample": k_fault,
        "fault_time": np.where(faulty, k_fault * dt, np.nan),
        "value_after": after,
    }, index=pd.Index(np.arange(G, dtype=np.int64), name="device"))
    return df, truth


def _check_arguments(n_devices, n_samples, seed, fault_fraction, fault_param, fault_size, spread,
                     noise_std, dt):
    """The validated arguments of :func:`fleet` (G, N, then the options in order)."""
    G = check_int(n_devices, "n_devices", low=1)
    N = check_int(n_samples, "n_samples", low=10)
    fault_fraction = check_scalar(fault_fraction, "fault_fraction", low=0.0, high=1.0)
    fault_param = check_choice(fault_param, "fault_param", _FAULT_PARAMS)
    fault_size = check_scalar(fault_size, "fault_size", low=-1.0, low_open=True)
    spread = check_scalar(spread, "spread", low=0.0, high=1.0, high_open=True)
    noise_std = check_scalar(noise_std, "noise_std", low=0.0)
    dt = check_scalar(dt, "dt", low=0.0, low_open=True)
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise param_error("seed", "an integer", seed, exc=TypeError)
    return G, N, fault_fraction, fault_param, fault_size, spread, noise_std, dt


def _currents(rng, dt, i, di_dt, sign_i):
    """Fill the (G, N) current, its backward difference and its sign, in place.

    Current: device mean + random steps held 20..80 samples + ripple (all > 0).
    """
    G, N = i.shape
    I0 = rng.uniform(1.5, 3.0, G)
    i[:] = _step_signal(rng, G, N, low=-1.0, high=1.0)
    i += I0[:, None]
    i += 0.01 * rng.standard_normal((G, N))
    di_dt[:, 0] = 0.0
    np.subtract(i[:, 1:], i[:, :-1], out=di_dt[:, 1:])
    di_dt[:, 1:] /= dt
    np.sign(i, out=sign_i)


def _speeds(rng, dt, Ke, i, omega):
    """Fill the (G, N) speed in place: J dω/dt = Ke i − B ω − τ_L (explicit Euler).

    Starts from the steady state; τ_L is a random step signal. Time-major
    copies, so that each step works on contiguous rows.
    """
    G, N = i.shape
    tau_L = _step_signal(rng, G, N, low=0.0, high=0.05)
    iT = np.ascontiguousarray(i.T)
    tT = np.ascontiguousarray(tau_L.T)
    wT = np.empty((N, G))
    w = np.maximum((Ke * iT[0] - tT[0]) / _B, 0.0)
    c = dt / _J
    for k in range(N):
        wT[k] = w
        w = w + c * (Ke * iT[k] - _B * w - tT[k])
    omega[:] = wT.T


def _faults(rng, G, N, fault_fraction, nominal, fault_size):
    """Which devices are faulty, their first faulty sample (−1 if none), the value after.

    ``nominal`` (G,) is the faulty parameter's value of each device before the fault.
    """
    n_fault = int(round(fault_fraction * G))
    faulty = np.zeros(G, dtype=bool)
    faulty[rng.choice(G, size=n_fault, replace=False)] = True
    k_fault = np.full(G, -1, dtype=np.int64)
    k_fault[faulty] = rng.integers(int(0.3 * N), int(0.7 * N) + 1, size=n_fault)
    after = np.where(faulty, nominal * (1.0 + fault_size), np.nan)
    return faulty, k_fault, after


def _voltages(rng, noise_std, par, regressor, v, faulty, k_fault, after, fault_param):
    """Fill the (G, N) voltage in place: noise + θᵀφ, with the changed parameter after a fault."""
    G, N = v.shape
    v[:] = noise_std * rng.standard_normal((G, N))
    for name, col in regressor.items():
        v += par[name][:, None] * col
    for g in np.flatnonzero(faulty):  # only the faulty devices (a fraction)
        k0 = k_fault[g]
        v[g, k0:] += (after[g] - par[fault_param][g]) * regressor[fault_param][g, k0:]


def _step_signal(rng, G, N, *, low, high, min_hold=20, max_hold=80):
    """(G, N) piecewise-constant random levels in [low, high], held min..max_hold samples."""
    n_seg = N // min_hold + 2
    holds = rng.integers(min_hold, max_hold + 1, size=(G, n_seg))
    starts = np.cumsum(holds, axis=1) - holds            # start sample of each level
    levels = rng.uniform(low, high, size=(G, n_seg))
    # index of the level active at sample k (number of starts <= k, minus one),
    # for all devices in one searchsorted: device g's starts are shifted by g·M
    M = int(starts[:, -1].max()) + N + 1
    shift = (np.arange(G, dtype=np.int64) * M)[:, None]
    flat = (starts + shift).ravel()
    idx = np.searchsorted(flat, (np.arange(N)[None, :] + shift).ravel(), side="right") - 1
    return levels.ravel()[idx].reshape(G, N)
