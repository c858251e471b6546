r"""Loader of the EMPS benchmark data (Janot, Gautier & Brunot 2019)."""

from __future__ import annotations

import numpy as np

from .._validation import check_choice, param_error
from ..models._iddata import IDData
from ._resources import data_file

__all__ = ["EMPSData", "load_emps"]

_FILES = {"estimation": "DATA_EMPS.mat", "validation": "DATA_EMPS_PULSES.mat"}


class EMPSData(IDData):
    r"""One record of the EMPS benchmark (see :func:`load_emps`): an :class:`adaptid.IDData`.

    As identification data its output is the position ``qm`` and its input
    the controller output ``vir`` (``dt`` = ``Ts``, ``time`` = ``t``).

    Attributes
    ----------
    kind : str
        ``"estimation"`` or ``"validation"``.
    t : ndarray, shape (N,)
        Time, s (0 … 24.84 s; stored with a jitter of about 2e-8 s).
    qm : ndarray, shape (N,)
        Measured motor position, given on the load side, m.
    qg : ndarray, shape (N,)
        Reference position (closed-loop set point), m.
    vir : ndarray, shape (N,)
        Controller output (motor voltage), V.
    gtau : float
        Drive gain, N/V; the motor force is ``gtau * vir``.
    kp : float
        Proportional gain of the position loop, 1/s.
    kv : float
        Velocity gain of the loop, V/(m/s).
    Ts : float
        Nominal sampling interval, 1e-3 s.
    pulses_N : ndarray, shape (N,), or None
        Force pulses applied during the validation run, N (stored as uint8
        in the file, returned as float64); ``None`` for the estimation set.
    """

    def __init__(self, *, kind, t, qm, qg, vir, gtau, kp, kv, Ts, pulses_N=None):
        super().__init__(qm, vir, dt=Ts, time=t, y_names="qm", u_names="vir")
        self.kind, self.qm, self.qg, self.vir = kind, qm, qg, vir
        self.gtau, self.kp, self.kv, self.Ts, self.pulses_N = gtau, kp, kv, Ts, pulses_N

    @property
    def force(self) -> np.ndarray:
        """Motor force ``gtau * vir``, N, shape (N,)."""
        return self.gtau * self.vir

    def __repr__(self) -> str:
        return (f"EMPSData(kind={self.kind!r}, N={self.t.size}, Ts={self.Ts}, "
                f"gtau={self.gtau:.6g}, kp={self.kp:.6g}, kv={self.kv:.6g})")


def load_emps(kind="estimation"):
    r"""Load the measured EMPS data (electro-mechanical positioning system).

    Parameters
    ----------
    kind : {"estimation", "validation"}
        ``"estimation"`` is ``DATA_EMPS.mat`` (bang-bang acceleration
        trajectory); ``"validation"`` is ``DATA_EMPS_PULSES.mat``, the
        cross-test run with force pulses applied.

    Returns
    -------
    EMPSData
        An :class:`adaptid.IDData` (output ``qm``, input ``vir``) with ``t``, ``qm``, ``qg``, ``vir`` (each shape (24841,)), the scalars
        ``gtau``, ``kp``, ``kv``, ``Ts = 1e-3`` and, for the validation set,
        ``pulses_N``.

    Raises
    ------
    TypeError
        If ``kind`` is not a string.
    ValueError
        If ``kind`` is not one of the choices.

    Notes
    -----
    A prismatic joint driven by a DC motor, in closed loop under a PD
    position controller, sampled at 1 kHz. The inverse dynamic model is

    .. math::

        \tau = g_\tau v_{ir} = M \ddot q + F_v \dot q
               + F_c \operatorname{sign}(\dot q) + \text{offset},

    identified by the IDIM-LS procedure of the benchmark (see
    ``examples/emps.py``). The packaged files are the benchmark's own
    (sha256 in ``adaptid/datasets/data/README.md``).

    References
    ----------
    .. [1] A. Janot, M. Gautier, M. Brunot, "Data Set and Reference Models
       of EMPS", 2019 Workshop on Nonlinear System Identification
       Benchmarks, Eindhoven, NL, April 10–12, 2019.

    Examples
    --------
    >>> from adaptid.datasets import load_emps
    >>> d = load_emps()
    >>> d.qm.shape, d.Ts
    ((24841,), 0.001)
    """
    if not isinstance(kind, str):
        raise param_error("kind", "a str", kind, exc=TypeError)
    kind = check_choice(kind, "kind", tuple(_FILES))
    from scipy.io import loadmat

    with data_file(_FILES[kind]).open("rb") as fh:
        mat = loadmat(fh)

    def vec(key):
        return np.ascontiguousarray(mat[key], dtype=np.float64).ravel()

    def scalar(key):
        return float(np.asarray(mat[key]).squeeze())

    return EMPSData(
        kind=kind, t=vec("t"), qm=vec("qm"), qg=vec("qg"), vir=vec("vir"),
        gtau=scalar("gtau"), kp=scalar("kp"), kv=scalar("kv"), Ts=1e-3,
        pulses_N=vec("pulses_N") if "pulses_N" in mat else None,
    )
