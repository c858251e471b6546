r"""Compiled simulators of the generated data sets (:mod:`adaptid.datasets`).

``simulate_dc_motor`` integrates the permanent-magnet DC motor of
:func:`adaptid.datasets.dc_motor` (model, friction and integration scheme
documented there): current i, speed ω, winding temperature T and shaft
angle, with the voltage held over each sample interval (ZOH), classical RK4
on ``n_sub`` sub-steps per sample, the friction direction frozen within a
sub-step and a speed reversal located and stopped at exactly ω = 0.

State ``x = [i, ω, T, angle]``; parameter vector ``p`` in the order of
:data:`DC_MOTOR_PARAMETER_ORDER`. As every kernel, nothing here validates:
:mod:`adaptid.datasets._dc_motor` checks the arguments and allocates.
"""

import numpy as np

from ..._config import NJIT, njit

__all__ = ["DC_MOTOR_PARAMETER_ORDER", "simulate_dc_motor"]

#: NJIT without FMA contraction (``fastmath={"contract"}``): a data set must be
#: the same bits on every machine for a given seed, and contraction changes
#: the last bits of the simulated states (by up to ~1e-13 A on this motor).
_NJIT_EXACT = {**NJIT, "fastmath": False}

#: Names of the entries of the parameter vector ``p``, in order (SI units;
#: ``J0, B0`` act before sample ``k_load``, ``J1, B1`` from it on).
DC_MOTOR_PARAMETER_ORDER = ("R0", "alpha", "T_amb", "L", "Ke", "Kt", "J0", "J1", "B0", "B1",
                            "tau_c", "tau_0", "C_th", "R_th")
# index of each parameter in p
_R0, _ALPHA, _TAMB, _L, _KE, _KT, _J0, _J1, _B0, _B1, _TC, _T0, _CTH, _RTH = range(14)


@njit(**_NJIT_EXACT)
def _deriv(x, v, mode, p, J, B):
    """Right-hand side with the friction direction ``mode`` ∈ {-1, 0, 1} frozen.

    ``mode = 0`` is the stuck state (ω held at zero by static friction).
    """
    i, w, T = x[0], x[1], x[2]
    R = p[_R0] * (1.0 + p[_ALPHA] * (T - p[_TAMB]))
    di = (v - R * i - p[_KE] * w) / p[_L]
    if mode == 0:
        dw = 0.0
    else:
        dw = (p[_KT] * i - B * w - p[_TC] * mode - p[_T0]) / J
    dT = (R * i * i - (T - p[_TAMB]) / p[_RTH]) / p[_CTH]
    return di, dw, dT, w


@njit(**_NJIT_EXACT)
def _rk4(x, h, v, mode, p, J, B, out, tmp):
    """One classical Runge–Kutta step of length h with frozen friction mode."""
    k1 = _deriv(x, v, mode, p, J, B)
    for j in range(4):
        tmp[j] = x[j] + 0.5 * h * k1[j]
    k2 = _deriv(tmp, v, mode, p, J, B)
    for j in range(4):
        tmp[j] = x[j] + 0.5 * h * k2[j]
    k3 = _deriv(tmp, v, mode, p, J, B)
    for j in range(4):
        tmp[j] = x[j] + h * k3[j]
    k4 = _deriv(tmp, v, mode, p, J, B)
    for j in range(4):
        out[j] = x[j] + h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])


@njit(**_NJIT_EXACT)
def _mode_of(x, p):
    """Direction of motion; at ω = 0 the static-friction (Karnopp) test."""
    w = x[1]
    if w > 0.0:
        return 1
    if w < 0.0:
        return -1
    drive = p[_KT] * x[0] - p[_T0]
    if abs(drive) <= p[_TC]:
        return 0
    return 1 if drive > 0.0 else -1


@njit(**_NJIT_EXACT)
def _substep(x, h, v, p, J, B, new, mid, tmp):
    """Advance x by h into ``new``, landing exactly on ω = 0 at a reversal."""
    mode = _mode_of(x, p)
    _rk4(x, h, v, mode, p, J, B, new, tmp)
    if mode != 0 and new[1] * mode < 0.0:
        # ω crossed zero inside the step: locate the crossing (linear guess,
        # then one secant refinement on the smooth single-mode solution),
        # stop there, snap ω to 0 and finish the step in the new mode.
        w0, w1 = x[1], new[1]
        s = w0 / (w0 - w1)
        _rk4(x, s * h, v, mode, p, J, B, mid, tmp)
        wm = mid[1]
        if wm != 0.0 and w1 != wm:
            s2 = s - wm * (1.0 - s) / (w1 - wm)
            if 0.0 < s2 < 1.0:
                s = s2
                _rk4(x, s * h, v, mode, p, J, B, mid, tmp)
        mid[1] = 0.0
        mode2 = _mode_of(mid, p)
        _rk4(mid, (1.0 - s) * h, v, mode2, p, J, B, new, tmp)
        if mode2 != 0 and new[1] * mode2 < 0.0:  # cannot happen for h ≪ J/B
            new[1] = 0.0


@njit(**_NJIT_EXACT)
def simulate_dc_motor(v, dt, n_sub, k_load, p, x0, states):
    """Integrate the motor over every ZOH interval; ``states[k]`` is x(t_k).

    ``v[k]`` is held over [t_k, t_{k+1}); the load (J1, B1) acts from sample
    ``k_load`` on.
    """
    n = v.shape[0]
    x = x0.copy()
    new = np.empty(4)
    mid = np.empty(4)
    tmp = np.empty(4)
    h = dt / n_sub
    for k in range(n):
        for j in range(4):
            states[k, j] = x[j]
        if k >= k_load:
            J, B = p[_J1], p[_B1]
        else:
            J, B = p[_J0], p[_B0]
        for _ in range(n_sub):
            _substep(x, h, v[k], p, J, B, new, mid, tmp)
            for j in range(4):
                x[j] = new[j]
