r"""Loader of measured sets from DaISy (KU Leuven ESAT/SISTA)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import check_choice, param_error
from ..models._iddata import IDData
from ._resources import data_file

__all__ = ["DaisyData", "load_daisy", "DAISY_NAMES"]


@dataclass(frozen=True)
class _Spec:
    file: str
    daisy_id: str
    columns: tuple
    u_cols: tuple
    y_cols: tuple
    time_col: int | None
    Ts: float | None
    description: str


_SPECS = {
    "dryer": _Spec(
        "dryer.dat", "96-006", ("u", "y"), (0,), (1,), None, 0.08,
        "Laboratory setup acting like a hair dryer (Feedback Process Trainer "
        "PT326). Air is fanned through a tube and heated at the inlet; the "
        "outlet air temperature is measured by a thermocouple. "
        "u: voltage over the heating device (binary random signal, 3.41 / "
        "6.41 V, switching with probability 0.2); y: outlet air temperature "
        "(thermocouple voltage). 1000 samples. DaISy gives no sampling time; "
        "Ts = 0.08 s is that of the same experiment in MATLAB's System "
        "Identification Toolbox (dryer2). Contributor: W. Favoreel, KU Leuven. "
        "References: L. Ljung, System Identification: Theory for the User, "
        "2nd ed., 1999, p. 525; L. Ljung, System Identification Toolbox "
        "user's guide, 1991."),
    "robot_arm": _Spec(
        "robot_arm.dat", "96-009", ("u", "y"), (0,), (1,), None, None,
        "Flexible robot arm mounted on an electrical motor. u: measured "
        "reaction torque of the structure (periodic sine sweep); y: "
        "acceleration of the flexible arm. 1024 samples; no sampling time "
        "given. Contributor: W. Favoreel, KU Leuven; data from H. Van Brussel "
        "and J. Swevers (KU Leuven, PMA)."),
    "CD_player_arm": _Spec(
        "CD_player_arm.dat", "96-007", ("u1", "u2", "y1", "y2"), (0, 1),
        (2, 3), None, None,
        "Mechanical construction of a CD player arm. u1, u2: forces of the "
        "mechanical actuators; y1, y2: tracking accuracy of the arm. Measured "
        "in closed loop and converted to open-loop-equivalent data; the "
        "inputs are highly coloured. 2048 samples; no sampling time given. "
        "Contributor: W. Favoreel, KU Leuven; data from R. de Callafon "
        "(TU Delft). Reference: P. Van den Hof, R. Schrama, Automatica 29(6) "
        "1523-1527, 1993."),
    "exchanger": _Spec(
        "exchanger.dat", "97-002", ("time", "q", "th"), (1,), (2,), 0, 1.0,
        "Liquid-saturated steam heat exchanger: water is heated by "
        "pressurised saturated steam through a copper tube. q: liquid flow "
        "rate (input); th: outlet liquid temperature (output). Ts = 1 s, "
        "4000 samples. The process is non-minimum phase and nonlinear. "
        "Contributor: S. Bittanti, Politecnico di Milano. References: "
        "S. Bittanti, L. Piroddi, J. Franklin Inst., 1996; L. Piroddi, "
        "PhD thesis, 1995."),
}

#: Names accepted by :func:`load_daisy`.
DAISY_NAMES = tuple(_SPECS)


class DaisyData(IDData):
    r"""One DaISy data set (see :func:`load_daisy`): an :class:`adaptid.IDData`.

    The record's signals, names (the file's column names) and sample time
    (``dt`` = ``Ts``, 1.0 when DaISy gives none) are those of
    :class:`~adaptid.IDData`, so it goes straight into ``fit``,
    :func:`adaptid.models.compare` and the other workflow functions.

    Attributes
    ----------
    name : str
        The name passed to :func:`load_daisy`.
    daisy_id : str
        DaISy catalogue number, e.g. ``"96-006"``.
    u : ndarray, shape (N,) or (N, m)
        Input(s); 2-D only for several inputs (``CD_player_arm``: m = 2).
    y : ndarray, shape (N,) or (N, p)
        Output(s); 2-D only for several outputs (``CD_player_arm``: p = 2).
    Ts : float or None
        Sampling interval in seconds where known (dryer 0.08, exchanger 1),
        else ``None``.
    time : ndarray, shape (N,), or None
        The file's own time column (``exchanger``: 1 … 4000), else ``None``.
    data : ndarray, shape (N, ncols)
        The file's columns as read.
    columns : tuple of str
        Names of the columns of ``data``.
    description : str
        The DaISy description (contributor, signals, references).
    """

    def __init__(self, *, name, daisy_id, u, y, Ts, time, data, columns, description,
                 u_names, y_names):
        super().__init__(y, u, dt=1.0 if Ts is None else Ts, time=time, y_names=y_names,
                         u_names=u_names)
        self.name, self.daisy_id, self.Ts = name, daisy_id, Ts
        self.data, self.columns, self.description = data, columns, description

    def __repr__(self) -> str:
        return (f"DaisyData(name={self.name!r}, daisy_id={self.daisy_id!r}, "
                f"u.shape={self.u.shape}, y.shape={self.y.shape}, Ts={self.Ts})")


def load_daisy(name):
    r"""Load a measured input–output set from DaISy.

    Parameters
    ----------
    name : {"dryer", "robot_arm", "CD_player_arm", "exchanger"}
        Which set:

        * ``"dryer"`` [96-006] — laboratory hair dryer, 1000 samples, SISO,
          Ts = 0.08 s;
        * ``"robot_arm"`` [96-009] — flexible robot arm, 1024 samples, SISO;
        * ``"CD_player_arm"`` [96-007] — CD player arm, 2048 samples,
          2 inputs, 2 outputs;
        * ``"exchanger"`` [97-002] — heat exchanger, 4000 samples, SISO,
          Ts = 1 s (the file's first column, the time step, is ``time``).

    Returns
    -------
    DaisyData
        An :class:`adaptid.IDData` (``dt`` = ``Ts``; names from the file's
        columns) with ``u``, ``y`` (1-D for one signal, (N, 2) for the CD player),
        ``Ts``, ``time``, the raw ``data`` and the ``description``.

    Raises
    ------
    TypeError
        If ``name`` is not a string.
    ValueError
        If ``name`` is not one of the choices.

    Notes
    -----
    The files are the unmodified DaISy ASCII files (sha256 in
    ``adaptid/datasets/data/README.md``); no sampling time is given by
    DaISy for the dryer, robot arm and CD player: the dryer's 0.08 s comes
    from the identical MATLAB ``dryer2`` record.

    References
    ----------
    .. [1] B. De Moor (ed.), DaISy: Database for the Identification of
       Systems, Department of Electrical Engineering, ESAT/SISTA,
       KU Leuven, Belgium.

    Examples
    --------
    >>> from adaptid.datasets import load_daisy
    >>> d = load_daisy("dryer")
    >>> d.u.shape, d.y.shape, d.Ts, d.dt
    ((1000,), (1000,), 0.08, 0.08)
    """
    if not isinstance(name, str):
        raise param_error("name", "a str", name, exc=TypeError)
    name = check_choice(name, "name", DAISY_NAMES)
    spec = _SPECS[name]
    with data_file(spec.file).open("r") as fh:
        raw = np.loadtxt(fh, dtype=np.float64, ndmin=2)

    def pick(cols):
        out = raw[:, list(cols)]
        return np.ascontiguousarray(out[:, 0] if len(cols) == 1 else out)

    return DaisyData(
        name=name, daisy_id=spec.daisy_id, u=pick(spec.u_cols), y=pick(spec.y_cols),
        Ts=spec.Ts,
        time=None if spec.time_col is None else np.ascontiguousarray(raw[:, spec.time_col]),
        data=raw, columns=spec.columns, description=spec.description,
        u_names=tuple(spec.columns[i] for i in spec.u_cols),
        y_names=tuple(spec.columns[i] for i in spec.y_cols),
    )
