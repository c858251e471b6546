"""The ``adaptid fleet`` command's work, independent of the CLI framework.

The CLI registers :func:`fleet_command` (parsing of arguments only) and
prints with :func:`summary_text` / :func:`write_result`. A single data file
(CSV, Parquet, ``.npz``) is read by :mod:`adaptid.io`, the reader of
``adaptid fit``; a folder or glob of Parquet files goes to Dask. The fleet
itself (layer 8) is imported only when the command runs.
"""

from __future__ import annotations

import glob as _glob
import importlib
import os

from .._validation import param_error
from ..io import SUFFIXES, check_writable, read_frame, write_table

__all__ = ["fleet_command", "resolve_model", "summary_text", "write_result", "check_outputs"]


def _split_names(value):
    if value is None:
        return None
    if isinstance(value, str):
        value = [value]
    out = []
    for v in value:
        out.extend(s.strip() for s in str(v).split(",") if s.strip())
    return out


def resolve_model(spec):
    """A model callable from ``"package.module:attribute"`` (or a callable, returned as is)."""
    if spec is None or callable(spec):
        return spec
    if not isinstance(spec, str) or ":" not in spec:
        raise param_error("model", "'package.module:callable'", spec)
    mod, _, attr = spec.partition(":")
    try:
        obj = importlib.import_module(mod)
        for part in attr.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as err:
        raise param_error("model", "an importable 'package.module:callable'", spec) from err
    if not callable(obj):
        raise param_error("model", "a callable", spec, exc=TypeError)
    return obj


def fleet_command(data, group, y=None, phi=None, model=None, method="rls", time=None,
                  scheduler=None, tracks=None, *, forgetting=None, window=None,
                  process_cov=None, noise_var=None, P0=None, step=None, eps=None, alpha=0.05,
                  nan_policy="raise", change_test="supF", multiple="bh", npartitions=None,
                  quiet=False, structure=None):
    """Run :func:`adaptid.fleet.identify` for the command line.

    Parameters
    ----------
    data : str
        Parquet file, directory or glob (or a CSV file, read with pandas).
    group, y, time : str
        Column names (``y`` not needed with ``model``).
    phi : str or list of str
        Regressor columns; comma-separated names are split.
    model : str, optional
        ``"package.module:callable"`` returning a Regression per group.
    method : {"rls", "window", "kalman", "lms", "nlms"}
    scheduler : str, optional
        ``None`` (in-process), ``"local"`` (start a LocalCluster) or a
        scheduler address.
    tracks : str, optional
        Directory for the per-sample estimates (Parquet).
    forgetting, window, process_cov, noise_var, P0, step, eps : optional
        Estimator options; ``None`` leaves the estimator's default.
    alpha, nan_policy, change_test, multiple, npartitions
        As in :func:`adaptid.fleet.identify`.
    quiet : bool
        No progress bar.
    structure : adaptid.cli._problem.Structure, optional
        A model option (``--arx``, ``--oe``, …; see :mod:`adaptid.cli._fleetmodel`):
        ``method="batch"`` fits the model object per device and a recursive
        method runs the streaming object of ARMA/ARMAX/OE/BJ per device
        (both by :func:`adaptid.fleet.fit_models`); ARX/FIR/AR with a
        recursive method run :func:`adaptid.fleet.identify` on the model's
        regressors.

    Returns
    -------
    pandas.DataFrame
        One row per device (see :func:`adaptid.fleet.identify`).
    """
    from adaptid.fleet import identify  # layer 8, on demand
    options = {k: v for k, v in dict(forgetting=forgetting, window=window,
                                     process_cov=process_cov, noise_var=noise_var,
                                     P0=P0, step=step, eps=eps).items() if v is not None}
    if is_single_file(data):
        source = read_frame(data)
        _check_empty_labels(source, group, data)
    else:
        source = data
    if structure is not None:
        from ._fleetmodel import ModelRegressors, device_model, uses_fit_models

        if uses_fit_models(structure, method):   # a model object per device, on Dask
            from adaptid.fleet import fit_models

            return fit_models(source, device_model(structure, method, options, nan_policy),
                              group=group, y=structure.y, u=structure.u, time=time,
                              client=scheduler or None, tracks=tracks, alpha=alpha,
                              change_test=change_test, multiple=multiple,
                              npartitions=npartitions, progress=not quiet)
        model, y = ModelRegressors(structure.kind, structure.orders, structure.y, structure.u), None
    return identify(source, group=group, y=y, phi=_split_names(phi),
                    model=resolve_model(model), method=method, time=time,
                    client=scheduler or None, tracks=tracks, nan_policy=nan_policy,
                    alpha=alpha, change_test=change_test, multiple=multiple,
                    npartitions=npartitions,
                    progress=not quiet, **options)


def _check_empty_labels(frame, group, data):
    """A CSV's empty device id is read as the text '' (not as a missing value):
    refused as :func:`adaptid.fleet.identify` refuses a missing label."""
    from ._errors import CLIError
    if not isinstance(group, str) or group not in frame.columns:
        return  # identify names the missing column
    col = frame[group]
    if col.dtype.kind != "O" and str(col.dtype) not in ("string", "str"):
        return
    blank = col.astype(str).str.strip().eq("") & col.notna()
    if blank.any():
        row = int(blank.to_numpy().argmax())
        raise CLIError(f"--group {group}: an empty device id in {data} (data row {row + 1}); "
                       "every row needs a label")


def summary_text(result, *, max_rows=10) -> str:
    """A short human-readable summary: counts, flagged devices, parameter spread."""
    n = len(result)
    flagged = result.index[result["change"].to_numpy(dtype=bool)] if "change" in result \
        else result.index[:0]   # a batch model fit per device: no change test
    theta_cols = [c for c in result.columns
                  if f"stderr_{c}" in result.columns]
    lines = [f"{n} devices identified, "
             + (f"{len(flagged)} with a change flag, " if "change" in result else "")
             + f"{int(result['n_skipped'].sum())} samples skipped"]
    if theta_cols:
        desc = result[theta_cols].describe().loc[["mean", "std", "min", "max"]]
        lines.append(desc.to_string(float_format=lambda v: f"{v:.6g}"))
    if len(flagged):
        cols = [c for c in ("change_at", "change_stat", "change_pvalue", "rms") if c in result]
        show = result.loc[flagged[:max_rows], cols]
        lines.append("flagged:")
        lines.append(show.to_string(float_format=lambda v: f"{v:.6g}"))
        if len(flagged) > max_rows:
            lines.append(f"... and {len(flagged) - max_rows} more")
    return "\n".join(lines)


def is_single_file(data) -> bool:
    """True for one CSV / Parquet / ``.npz`` file (read by :mod:`adaptid.io`)."""
    if not isinstance(data, (str, os.PathLike)):
        return False
    p = os.fspath(data)
    if os.path.isdir(p) or _glob.has_magic(p):
        return False
    return p.lower().endswith(tuple(SUFFIXES))


def input_files(data) -> list:
    """The existing files named by ``data`` (a file, a folder's files or a glob's)."""
    p = os.fspath(data)
    if os.path.isdir(p):
        return [os.path.join(r, f) for r, _, fs in os.walk(p) for f in fs]
    return [q for q in (_glob.glob(p) if _glob.has_magic(p) else [p]) if os.path.exists(q)]


def check_outputs(data, output=None, tracks=None) -> None:
    """Before any computation: outputs writable, of a known type, and not an input."""
    from ._errors import CLIError
    p = os.fspath(data)
    if _glob.has_magic(p) and not _glob.glob(p, recursive=True):
        raise CLIError(f"no files match {p}")
    inputs = input_files(data)
    if output is not None:
        check_writable(output, what="--out")
        low = os.fspath(output).lower()
        if not low.endswith((".csv", ".parquet", ".pq", ".json")):
            raise CLIError(f"--out {output}: the name must end in .csv, .parquet or .json")
        for q in inputs:
            if os.path.exists(output) and os.path.samefile(output, q):
                raise CLIError(f"--out {output} is the input file {q}; choose another name")
    if tracks is not None:
        t = os.fspath(tracks)
        if os.path.exists(t) and not os.path.isdir(t):
            raise CLIError(f"--tracks {t}: exists and is not a folder")
        roots = inputs + ([os.fspath(data)] if os.path.isdir(os.fspath(data)) else [])
        for q in roots:
            if os.path.exists(t) and os.path.samefile(t, q):
                raise CLIError(f"--tracks {t} is the input {q}; choose another folder")
        if os.path.isdir(os.fspath(data)):
            root = os.path.realpath(os.fspath(data))
            if os.path.commonpath([root, os.path.realpath(t)]) == root:
                raise CLIError(f"--tracks {t} is inside the input folder {os.fspath(data)}: "
                               "the next run would read the tracks as data; choose a folder "
                               "outside it")


def write_result(result, path) -> None:
    """Write the per-device table to ``path`` (.csv, .parquet or .json by extension), atomically."""
    p = os.fspath(path)
    if not p.lower().endswith((".csv", ".parquet", ".pq", ".json")):
        raise param_error("output", "a path ending in .csv, .parquet or .json", p)
    write_table(result, p)
