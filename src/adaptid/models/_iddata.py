r"""The measured record of an identification experiment: outputs, inputs, time, names."""

from __future__ import annotations

import numpy as np

from .._validation import as_float_array, check_choice, check_scalar, param_error
from .._lazy import pyplot
from ._experiments import ExperimentsMixin, _merged

__all__ = ["IDData", "as_signals", "u_with_iddata_error"]


def _names_of(obj):
    """Column names of a pandas Series / DataFrame (None for arrays)."""
    if hasattr(obj, "columns"):
        return tuple(str(c) for c in obj.columns)
    name = getattr(obj, "name", None)
    if hasattr(obj, "to_numpy") and name is not None:
        return (str(name),)
    return None


def _index_of(obj):
    """A pandas object's index as time, unless it is the default 0..N-1 range.

    Returns ``(values, freq_seconds)``: the stamps as an ndarray (``datetime64``
    for a ``DatetimeIndex``, in UTC if it has a time zone; ``timedelta64`` for a
    ``TimedeltaIndex``; numbers otherwise) and the step of the index's own
    fixed frequency in seconds (None without one; ``"rows"`` for a
    ``RangeIndex``, which numbers rows, as a sliced default index does, and
    gives no sample time).
    """
    idx = getattr(obj, "index", None)
    if idx is None or not hasattr(obj, "to_numpy"):
        return None, None
    if type(idx).__name__ == "RangeIndex":
        if idx.start == 0 and idx.step == 1:
            return None, None
        return idx.to_numpy(), "rows"
    if getattr(idx, "tz", None) is not None:      # aware stamps: compare them in UTC
        idx = idx.tz_convert("UTC").tz_localize(None)
    freq = None
    if getattr(idx, "freq", None) is not None:
        try:
            import pandas as pd

            freq = pd.to_timedelta(idx.freq).total_seconds()
        except (ValueError, TypeError):           # calendar steps (months, business days)
            freq = None
    return idx.to_numpy(), freq


def _has_time(obj):
    """Whether a pandas object's index is a time axis (not the rows' numbers)."""
    values, freq = _index_of(obj)
    return values is not None and freq != "rows"


def _elapsed_seconds(time):
    """Seconds since the first stamp, as floats (numbers are taken as seconds)."""
    if time.dtype.kind in "Mm":
        return (time - time[0]).astype("timedelta64[ns]").astype(np.int64) * 1e-9
    t = time.astype(np.float64)
    return t - t[0]


#: A time axis is regular when every stamp lies within this fraction of a
#: step of the grid t0 + k·dt (the EMPS stamps, rounded in their file, stray
#: by 3.2e-5 of a step; a missing or doubled sample strays by a whole step).
_GRID_RTOL = 1e-4
#: A dt given for an irregular axis (gaps, jitter) is its nominal step: it
#: contradicts the axis when it is off the median step by more than this.
_NOMINAL_RTOL = 1e-2


def _where(source):
    return "time" if source == "time" else f"the time axis (index of {source})"


def _sample_time(dt, time, source, freq):
    """dt from the arguments and the time axis: given, inferred, or 1.0 without time."""
    if dt is not None:
        dt = check_scalar(dt, "dt", low=0.0, low_open=True)
    if time is None or len(time) < 2:
        if dt is None and freq is not None:
            return freq
        return 1.0 if dt is None else dt
    el = _elapsed_seconds(time)
    steps = np.diff(el)
    if not np.all(steps > 0):
        k = int(np.argmax(~(steps > 0))) + 1
        raise param_error("time" if source == "time" else f"the time axis (index of {source})",
                          "strictly increasing", f"<a step <= 0 at sample {k}>")
    span = 0.0 if time.dtype.kind in "Mm" else float(np.abs(time.astype(np.float64)).max())
    k = np.arange(len(el))

    def off_grid(h):       # stamps off t0 + k·h by more than _GRID_RTOL of a step (+ rounding)
        return float(np.max(np.abs(el - h * k))) > _GRID_RTOL * h + 8 * np.finfo(float).eps * span

    step = freq if freq is not None else float(el[-1]) / (len(el) - 1)
    lo, hi = float(steps.min()), float(steps.max())
    if not off_grid(step):                          # a regular axis: dt must be its step
        if dt is None:
            return step
        if off_grid(dt):
            raise ValueError(f"dt={dt:.9g} s contradicts {_where(source)}, whose step is "
                             f"{step:.9g} s ({len(el) - 1} steps over {float(el[-1]):.9g} s); "
                             "give that step as dt or leave dt out")
        return dt
    median = float(np.median(steps))
    if dt is None:
        raise ValueError(f"dt must be given for an irregular time axis: {_where(source)} has "
                         f"steps from {lo:.9g} to {hi:.9g} s (median {median:.9g} s); pass "
                         "the nominal sample time as dt, e.g. IDData(y, u, dt) (the stamps are "
                         "kept), or resample")
    if abs(dt - median) > _NOMINAL_RTOL * dt:
        raise ValueError(f"dt={dt:.9g} s contradicts {_where(source)}, an irregular axis whose "
                         f"median step is {median:.9g} s (steps from {lo:.9g} to {hi:.9g} s); "
                         "give its nominal step as dt")
    return dt


def _default_names(prefix, count, given, what):
    if given is None:
        return (prefix,) if count == 1 else tuple(f"{prefix}{i + 1}" for i in range(count))
    names = (given,) if isinstance(given, str) else tuple(str(g) for g in given)
    if len(names) != count:
        raise param_error(what, f"{count} name(s)", f"<{len(names)} names>")
    return names


class IDData(ExperimentsMixin):
    r"""The measured record of an identification experiment (MATLAB's ``iddata``).

    Parameters
    ----------
    y : array_like, shape (N,), (N, 1) or (N, p); or pandas Series / DataFrame
        Outputs. A pandas object gives the names and, unless it is the
        default range 0..N−1, its index gives ``time``. One output may come
        as a column (N, 1); :attr:`y` is then 1-D, as for shape (N,).
        NaN marks a missing sample (a gap, in ``u`` too): the fits leave
        out the rows that touch it or split the record there (see their
        ``nan_policy``); infinity is refused.
    u : array_like, shape (N,) or (N, m); pandas; or None
        Inputs (None: a time series without input). If ``y`` has no time
        index, a pandas ``u``'s index gives ``time``.
    dt : float, optional
        Sample time in seconds, > 0; may be given by position, as in
        MATLAB's ``iddata(y, u, Ts)``. Default: the step of the time axis,
        or 1.0 when there is no time axis at all (see Notes).
    time : array_like, shape (N,), optional
        Time stamps: numbers (seconds), ``datetime64`` or ``timedelta64``;
        default the index of pandas inputs, else ``dt · k``.
    y_names, u_names : str or sequence of str, optional
        Signal names (default ``"y"``, ``"u"`` for one signal, ``"y1"``,
        ``"y2"``, … for several).

    Raises
    ------
    ValueError
        If the time axis is irregular and ``dt`` is not given, if ``dt``
        contradicts the time axis (see Notes), or if the time axis does not
        increase. The message names ``dt`` and the time axis.

    Attributes
    ----------
    y : ndarray, shape (N,) or (N, p)
        Outputs (1-D for one output).
    u : ndarray, shape (N,) or (N, m), or None
        Inputs (1-D for one input).
    outputs, inputs : ndarray, shape (N, p), (N, m)
        Always 2-D (m may be 0).
    dt : float
        Sample time in seconds (given, from the time axis, or 1.0).
    time : ndarray, shape (N,), or None
        The time stamps given or taken from a pandas index (None if none).
    t : ndarray, shape (N,)
        The time axis: ``time`` or ``dt · (k0 + k)``.
    y_names, u_names : tuple of str
    y_trend, u_trend : ndarray, shape (N, p), (N, m)
        What :meth:`detrend` removed (zeros for raw data): the measured
        signal is ``outputs + y_trend``; :meth:`retrend` adds it back to a
        model output.

    Notes
    -----
    Several experiments of the same signals are one record by
    :meth:`merge`; they stay apart (:attr:`n_experiments`,
    :meth:`experiment`), and no model forms a regressor across the boundary
    between two of them.

    The sample time comes from the first of these that exists:

    1. ``dt`` as given;
    2. the time axis, which is ``time`` if given, else the index of a pandas
       ``y`` (or ``u``) unless it is a ``RangeIndex`` (row numbers, such as
       the default 0..N−1 or a slice of it, give no sample time): the
       index's own fixed frequency (``pd.to_timedelta(index.freq)``) for a
       ``DatetimeIndex`` or ``TimedeltaIndex`` that has one, else the mean
       step :math:`(t_{N-1} - t_0)/(N - 1)` in seconds (numbers are taken
       as seconds);
    3. 1.0, when there is no time axis at all (as MATLAB's ``iddata``).

    A time axis is regular when every stamp lies on the grid
    :math:`t_0 + k\,h` to within 1e-4 of a step (plus the rounding of float
    stamps, 8 ε·max|t|), h its step; this tolerates stamps rounded in a file,
    as EMPS's are. A ``dt`` given with a regular axis must put the stamps on
    its own grid to the same tolerance, which pins it to the step to a
    relative 1e-4/(N − 1). An irregular axis (gaps, jitter) cannot give a
    sample time: ``dt`` must then be given, as the nominal step, and is
    taken if it is within 1 % of the median step (the stamps are kept in
    :attr:`time`). Otherwise ``dt`` contradicts the axis. Both errors are a
    ``ValueError`` naming ``dt`` and the time axis; resample an irregular
    record to make it regular (``df.resample("80ms").mean().interpolate()``).
    Time-zone aware stamps are kept in UTC. Models fitted from an ``IDData``
    (or from pandas inputs, which become one) take its ``dt``, and so does
    their ``to_control()``.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid import IDData
    >>> d = IDData(np.arange(10.0), np.ones(10), 0.5, y_names="temp", u_names="power")
    >>> est, val = d.split(0.6)
    >>> len(est), len(val), float(val.t[0])
    (6, 4, 3.0)
    >>> dd = d.detrend("linear")
    >>> bool(np.allclose(dd.y, 0.0)) and bool(np.allclose(dd.retrend(dd.y), d.y))
    True

    The sample time of a pandas record comes from its index, here 80 ms:

    >>> import pandas as pd
    >>> idx = pd.date_range("2026-01-01", periods=6, freq="80ms")
    >>> df = pd.DataFrame({"y": np.arange(6.0), "u": np.ones(6)}, index=idx)
    >>> IDData(df["y"], df["u"]).dt
    0.08
    """

    def __init__(self, y, u=None, dt=None, *, time=None, y_names=None, u_names=None):
        y_names = y_names if y_names is not None else _names_of(y)
        u_names = u_names if u_names is not None or u is None else _names_of(u)
        source, freq = "time", None
        if time is None:
            time, freq = _index_of(y)
            source = "y"
            if time is None and u is not None:
                time, freq = _index_of(u)
                source = "u"
        Y = as_float_array(getattr(y, "to_numpy", lambda: y)(), "y", ndim=(1, 2), allow_nan=True)
        Y = Y.reshape(Y.shape[0], -1)
        N = Y.shape[0]
        if u is None:
            U = np.zeros((N, 0))
        else:
            U = as_float_array(getattr(u, "to_numpy", lambda: u)(), "u", ndim=(1, 2),
                               allow_nan=True)
            U = U.reshape(U.shape[0], -1)
            if U.shape[0] != N:
                raise param_error("u", f"with N={N} rows (as y)", f"<{U.shape[0]} rows>")
        if N < 1 or Y.shape[1] < 1:
            raise param_error("y", "at least one sample of at least one output", f"<shape {Y.shape}>")
        if time is not None:
            time = np.asarray(time)
            if time.shape != (N,):
                raise param_error("time", f"of shape ({N},)", f"<shape {time.shape}>")
            if time.dtype.kind not in "iufMm":
                raise param_error("time", "numbers, datetime64 or timedelta64 values",
                                  f"<dtype {time.dtype}>", exc=TypeError)
            if time.dtype.kind == "f" and not np.all(np.isfinite(time)):
                raise param_error("time", "finite", "<NaN or infinite stamps>")
        rows = freq == "rows"      # a RangeIndex: kept as the stamps, but no sample time
        self.dt = _sample_time(dt, None if rows else time, source, None if rows else freq)
        self.time = time
        self._k0 = 0
        self.outputs = np.ascontiguousarray(Y)
        self.inputs = np.ascontiguousarray(U)
        self.y_names = _default_names("y", Y.shape[1], y_names, "y_names")
        self.u_names = _default_names("u", U.shape[1], u_names, "u_names")
        self.y_trend = np.zeros_like(self.outputs)
        self.u_trend = np.zeros_like(self.inputs)
        self._parts = None

    # ------------------------------------------------------------ access
    @property
    def y(self):
        """Outputs, shape (N,) for one output, else (N, p)."""
        return self.outputs[:, 0] if self.outputs.shape[1] == 1 else self.outputs

    @property
    def u(self):
        """Inputs, shape (N,) for one input, (N, m) for several, None without inputs."""
        m = self.inputs.shape[1]
        if m == 0:
            return None
        return self.inputs[:, 0] if m == 1 else self.inputs

    @property
    def n_outputs(self) -> int:
        """Number of outputs p."""
        return self.outputs.shape[1]

    @property
    def n_inputs(self) -> int:
        """Number of inputs m (0 for a time series)."""
        return self.inputs.shape[1]

    @property
    def t(self) -> np.ndarray:
        """The time axis: the stamps given, else ``dt · k`` (k counted from the original start).

        A merged record's is each experiment's time axis in turn."""
        if self._parts is not None:
            return np.concatenate([p.t for p in self._parts])
        if self.time is not None:
            return self.time
        return self.dt * (self._k0 + np.arange(len(self)))

    def __len__(self) -> int:
        return self.outputs.shape[0]

    def _copy_with(self, rows=None, *, outputs=None, inputs=None, y_trend=None, u_trend=None,
                   dt=None, k0=None):
        if self._parts is not None:        # merged: the same change, experiment by experiment
            if rows is not None or dt is not None or k0 is not None:
                raise ValueError("a merged IDData is sliced experiment by experiment: use "
                                 "data.experiment(k)[...] and merge the parts")
            b = self.bounds
            given = {"outputs": outputs, "inputs": inputs, "y_trend": y_trend, "u_trend": u_trend}
            return _merged([p._copy_with(**{n: None if v is None else v[b[e]: b[e + 1]]
                                            for n, v in given.items()})
                            for e, p in enumerate(self._parts)])
        new = object.__new__(IDData)
        new._parts = None
        sel = slice(None) if rows is None else rows
        new.outputs = np.ascontiguousarray(self.outputs[sel] if outputs is None else outputs)
        new.inputs = np.ascontiguousarray(self.inputs[sel] if inputs is None else inputs)
        new.y_trend = self.y_trend[sel] if y_trend is None else y_trend
        new.u_trend = self.u_trend[sel] if u_trend is None else u_trend
        new.time = None if self.time is None else self.time[sel]
        new.dt = self.dt if dt is None else dt
        new._k0 = self._k0 if k0 is None else k0
        new.y_names, new.u_names = self.y_names, self.u_names
        return new

    def __getitem__(self, key):
        """Samples by slice, e.g. ``data[:300]`` (a step multiplies ``dt``)."""
        if not isinstance(key, slice):
            raise param_error("key", "a slice of samples (e.g. data[100:400])", key, exc=TypeError)
        if self._parts is not None:
            raise param_error("key", "no slice of a merged record (slice one experiment: "
                              "data.experiment(k)[...])", key, exc=TypeError)
        start, stop, step = key.indices(len(self))
        if step < 1:
            raise param_error("slice step", "a positive integer", step)
        if len(range(start, stop, step)) == 0:
            raise param_error("key", "a slice selecting at least one sample", key)
        sel = slice(start, stop, step)
        if step == 1:
            return self._copy_with(sel, k0=self._k0 + start)
        new = self._copy_with(sel, dt=self.dt * step)
        new.time = self.t[sel]          # keep the original time stamps
        return new

    def split(self, fraction):
        r"""First ``round(fraction · N)`` samples for estimation, the rest for validation.

        Parameters
        ----------
        fraction : float
            In (0, 1); both parts must keep at least one sample.

        Returns
        -------
        (IDData, IDData)
            For a merged record, each experiment is split so, and the first
            parts are merged, and the second parts.
        """
        if self._parts is not None:
            halves = [p.split(fraction) for p in self._parts]
            return _merged([h[0] for h in halves]), _merged([h[1] for h in halves])
        fraction = check_scalar(fraction, "fraction", low=0.0, high=1.0, low_open=True,
                                high_open=True)
        n1 = int(round(fraction * len(self)))
        if not 1 <= n1 < len(self):
            raise param_error("fraction", f"leaving samples in both parts of N={len(self)}",
                              fraction)
        return self[:n1], self[n1:]

    # ----------------------------------------------------------- trends
    def detrend(self, kind="constant"):
        r"""Remove each signal's mean or least-squares line; keep what was removed.

        ``"constant"`` removes the mean, ``"linear"`` the straight line
        fitted by least squares over the samples (as
        :func:`scipy.signal.detrend` and MATLAB's ``detrend``). The removed
        parts accumulate in ``y_trend`` / ``u_trend`` so that
        :meth:`retrend` can add the output's back to a model output.

        Parameters
        ----------
        kind : {"constant", "linear"}

        Returns
        -------
        IDData
            A merged record is detrended experiment by experiment. NaN
            samples (gaps) are left out of the fit and stay NaN.
        """
        kind = check_choice(kind, "kind", ("constant", "linear"))
        if self._parts is not None:
            return _merged([p.detrend(kind) for p in self._parts])
        N = len(self)
        X = np.ones((N, 1))
        if kind == "linear":
            X = np.column_stack([X, np.arange(N) / max(N - 1, 1)])

        def fitted(S):
            out = np.zeros_like(S)
            for j in range(S.shape[1]):
                ok = ~np.isnan(S[:, j])
                if ok.any():
                    coef = np.linalg.lstsq(X[ok], S[ok, j], rcond=None)[0]   # QR/SVD, 1-2 columns
                    out[:, j] = X @ coef
            return out

        ty, tu = fitted(self.outputs), fitted(self.inputs)
        return self._copy_with(outputs=self.outputs - ty, inputs=self.inputs - tu,
                               y_trend=self.y_trend + ty, u_trend=self.u_trend + tu)

    def retrend(self, y_model):
        """Add the removed output trend back to a model output over these samples.

        Parameters
        ----------
        y_model : array_like, shape (N,) or (N, p)

        Returns
        -------
        ndarray, shape like ``y_model``
        """
        arr = as_float_array(y_model, "y_model", ndim=(1, 2))
        if arr.shape[0] != len(self):
            raise param_error("y_model", f"of length N={len(self)}", f"<shape {arr.shape}>")
        tr = self.y_trend[:, 0] if arr.ndim == 1 else self.y_trend
        return arr + tr

    # ----------------------------------------------------------- output
    def to_frame(self):
        """The record as a pandas DataFrame: outputs then inputs, indexed by time."""
        try:
            import pandas as pd
        except ImportError as err:  # pragma: no cover - depends on the extra
            raise ImportError("to_frame needs pandas: pip install 'adaptid[pandas]'") from err
        if self._parts is not None:     # the experiments stacked, under an "experiment" level
            return pd.concat([p.to_frame() for p in self._parts],
                             keys=range(len(self._parts)), names=["experiment"])
        cols = {n: self.outputs[:, i] for i, n in enumerate(self.y_names)}
        cols.update({n: self.inputs[:, i] for i, n in enumerate(self.u_names)})
        return pd.DataFrame(cols, index=pd.Index(self.t, name="time"))

    def plot(self, fig=None):
        """One panel per signal (outputs, then inputs as stairs) against time; returns the figure.

        Requires matplotlib (``pip install 'adaptid[plot]'``).
        """
        plt = pyplot()
        n = self.n_outputs + self.n_inputs
        if fig is None:
            fig = plt.figure(figsize=(7, 1.8 * n + 0.6))
        axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
        for e, part in enumerate(self.experiments):     # one line per experiment
            t = part.t
            label = f"experiment {e}" if self._parts is not None else None
            for i, name in enumerate(self.y_names):
                axes[i].plot(t, part.outputs[:, i], lw=0.9, label=label)
                axes[i].set_ylabel(name)
            for j, name in enumerate(self.u_names):
                ax = axes[self.n_outputs + j]
                ax.step(t, part.inputs[:, j], where="post", lw=0.9)
                ax.set_ylabel(name)
        if self._parts is not None:
            axes[0].legend(fontsize="small")
        axes[-1].set_xlabel("time" if self.time is not None else "time (s)")
        return fig

    def __repr__(self) -> str:
        trend = "" if not (self.y_trend.any() or self.u_trend.any()) else ", detrended"
        if self._parts is not None:
            trend += f", experiments={self.n_experiments} (N={[len(p) for p in self._parts]})"
        gaps = int((np.isnan(self.outputs).any(axis=1) | np.isnan(self.inputs).any(axis=1)).sum())
        if gaps:
            trend += f", {gaps} sample(s) with NaN"
        return (f"IDData(N={len(self)}, outputs={list(self.y_names)}, inputs={list(self.u_names)}, "
                f"dt={self.dt:g}{trend})")


#: What every entry point (the models' ``fit`` / ``fit_recursive``, ``compare``,
#: ``resid``, ``select_order``) accepts as a record; the one error message.
RECORD = ("an IDData, arrays (y, u) (two arguments or one tuple), or pandas "
          "Series/DataFrames (one DataFrame: the output column first, the inputs after it)")


def _is_frame(obj):
    return hasattr(obj, "columns") and hasattr(obj, "iloc")


def u_with_iddata_error(u) -> TypeError:
    """The error for a second signal given beside an IDData (which holds u already);
    an estimator given there by position is told to go by keyword."""
    if hasattr(u, "update") and hasattr(u, "theta"):
        return TypeError(f"u must be None when the first argument is an IDData, got the "
                         f"estimator {type(u).__name__}: pass it by keyword, estimator=...")
    return param_error("u", "None when the first argument is an IDData (it holds the inputs)",
                       u if np.ndim(u) == 0 else f"<an array of shape {np.shape(u)}>",
                       exc=TypeError)


def _squeeze_column(arr):
    """An (N, 1) array (or DataFrame's values) as (N,), as :class:`IDData` and ``lstsq`` do."""
    if getattr(arr, "ndim", 0) == 2 and arr.shape[1] == 1:
        return arr[:, 0]
    return arr


def as_signals(y, u=None, *, where="y"):
    """(y (N,), U-like or None, IDData or None) from ``fit(data)`` or ``fit(y, u)``.

    The one input convention of adaptid's models and workflow functions:

    * an :class:`IDData` (or anything with ``outputs``/``inputs``), alone,
      with one output;
    * arrays ``(y, u)``: two arguments, or one tuple ``(y, u)`` (``u`` may
      be None for a model without inputs);
    * pandas Series / DataFrames: ``y`` and ``u`` separately, or one
      DataFrame whose first column is the output and the others the inputs
      (as :func:`compare` reads one); a single-column DataFrame or a Series
      is an output alone.

    ``y`` of shape (N, 1) is squeezed to (N,), as :class:`IDData` and
    :func:`adaptid.lstsq` do. pandas objects become arrays, and an IDData
    (their names, and the ``dt`` of a time index) when they are named or
    indexed by time.
    """
    if isinstance(y, tuple) and u is None and any(np.ndim(v) > 0 for v in y):
        # a tuple of signals is the pair (y, u); a tuple of numbers stays a signal
        if len(y) != 2:
            raise param_error(where, RECORD, f"<a tuple of {len(y)} items>")
        y, u = y
    if _is_frame(y) and u is None and y.shape[1] >= 2:
        y, u = y.iloc[:, 0], y.iloc[:, 1:]
    if isinstance(y, IDData):
        if u is not None:
            raise u_with_iddata_error(u)
        if y.n_outputs != 1:
            raise param_error(where, "an IDData with one output", f"<{y.n_outputs} outputs>")
        return y.y, (y.u if y.n_inputs else None), y
    y_arr = _squeeze_column(getattr(y, "to_numpy", lambda: y)())
    u_arr = None if u is None else getattr(u, "to_numpy", lambda: u)()
    named = _names_of(y) is not None or (u is not None and _names_of(u) is not None)
    timed = _has_time(y) or (u is not None and _has_time(u))
    if named or timed:      # pandas: its names and the dt of its index go into the model
        return y_arr, u_arr, IDData(y, u)
    return y_arr, u_arr, None


def as_record(data, u=None, *, where="data"):
    """An :class:`IDData` from anything :func:`as_signals` accepts (the workflow functions).

    A bare array without ``u`` is refused (TypeError naming ``where``): a
    record is an IDData, a pair, or pandas data.
    """
    if isinstance(data, IDData) and u is None:
        return data
    pandas = _is_frame(data) or (hasattr(data, "to_numpy") and hasattr(data, "index"))
    if u is None and not (isinstance(data, tuple) or pandas):
        raise param_error(where, RECORD, data, exc=TypeError)
    y, u, rec = as_signals(data, u, where=where)
    return rec if rec is not None else IDData(y, u)
