"""``adaptid.io``: the one reader and writer of data tables (CSV, Parquet, ``.npz``).

Used by ``adaptid fit``, ``adaptid fleet`` and :func:`adaptid.fleet.identify`'s
command line. Every problem becomes a :class:`~adaptid._exceptions.DataFileError`
(a ValueError) with a one-line message that names the file, the column and the first row at fault.
Rows are numbered from 1 in the order of the data (the header of a CSV file
is not a row). Nothing is dropped silently: missing values (empty fields,
``NA``, ``nan``) are reported, and only skipped when the user asks for it.
"""

from __future__ import annotations

import csv
import gzip
import os
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ._exceptions import DataFileError

__all__ = ["Table", "read_table", "read_frame", "write_table", "check_writable", "SUFFIXES"]

SUFFIXES = {
    ".csv": "csv", ".txt": "csv", ".tsv": "csv", ".csv.gz": "csv", ".tsv.gz": "csv",
    ".parquet": "parquet", ".pq": "parquet",
    ".npz": "npz",
}
_MAX_LISTED = 12


def _kind_of(path: Path) -> str:
    name = path.name.lower()
    for suffix in sorted(SUFFIXES, key=len, reverse=True):
        if name.endswith(suffix):
            return SUFFIXES[suffix]
    got = "".join(path.suffixes[-2:]) or "no extension"
    raise DataFileError(f"{path}: unknown file type ({got}); expected one of "
                   f"{', '.join(sorted(SUFFIXES))}")


def _first_line(msg) -> str:
    text = str(msg).strip().splitlines()
    return text[0] if text else type(msg).__name__


def _list(names, limit=_MAX_LISTED) -> str:
    names = list(names)
    shown = ", ".join(repr(n) for n in names[:limit])
    return shown + (f", … ({len(names)} in all)" if len(names) > limit else "")


@dataclass
class Table:
    """Named columns read from one file (values converted on request).

    Attributes
    ----------
    path : pathlib.Path
    kind : {"csv", "parquet", "npz"}
    names : list of str
        Column names in file order (a 2-D ``.npz`` array ``X`` of m columns
        gives ``X[0]`` … ``X[m-1]``).
    groups : dict
        ``.npz`` only: a 2-D array's name → its column names, so that
        ``--phi X`` selects all of them.
    """

    path: Path
    kind: str
    names: list
    _get: dict = field(repr=False)
    groups: dict = field(default_factory=dict)

    def _count(self, name) -> int:
        """How often ``name`` is in the header (a counter built once: wide files)."""
        counts = self.__dict__.get("_counts")
        if counts is None or counts[0] != len(self.names):
            from collections import Counter

            counts = (len(self.names), Counter(self.names))
            self.__dict__["_counts"] = counts
        return counts[1].get(name, 0)

    def to_pandas(self):
        """The table as a pandas DataFrame (columns as stored: no conversion).

        A table read with ``columns=`` holds only the columns read.

        Raises DataFileError for duplicate column names (ambiguous).
        """
        import pandas as pd

        dup = sorted({n for n in self.names if self.names.count(n) > 1})
        if dup:
            raise DataFileError(f"{self.path}: column {dup[0]!r} appears "
                                f"{self.names.count(dup[0])} times; rename the duplicates")
        return pd.DataFrame({n: self._get[n]() for n in self.names if n in self._get})

    # ------------------------------------------------------------ selection
    def expand(self, names, option: str) -> list:
        """Column names for an option's list (a 2-D ``.npz`` array expands)."""
        out = []
        for name in names:
            if name in self.groups:
                out.extend(self.groups[name])
            else:
                out.append(name)
        return out

    def column(self, name: str, option: str) -> np.ndarray:
        """Column ``name`` as float64, shape (N,); NaN marks a missing value.

        Raises DataFileError naming the column (and the option that asked for it)
        if it is missing, ambiguous, non-numeric or holds an infinite value.
        """
        count = self._count(name)
        if count == 0:
            raise DataFileError(f"{self.path}: no column {name!r} (asked for by {option}); "
                           f"the columns are {_list(self.names)}")
        if count > 1:
            raise DataFileError(f"{self.path}: column {name!r} (asked for by {option}) appears "
                           f"{count} times; rename the duplicates")
        values = self._get[name]()
        x = _to_float(values, f"{self.path}: column {name!r}")
        bad = np.isinf(x)
        if bad.any():
            i = int(np.argmax(bad))
            raise DataFileError(f"{self.path}: column {name!r}, row {i + 1}: infinite value (a number "
                           "outside the float64 range, such as 1e400, or 'inf'); "
                           f"{int(bad.sum())} such row(s)")
        return x

    def datetimes(self, name: str):
        """Column ``name`` as ``datetime64[ns]`` if it holds date-times, else None.

        (:meth:`column` gives date-times as float epoch seconds, rounded to
        about 0.2 µs; this keeps the stamps exact for axes and output files.)
        """
        import pandas as pd

        if self._count(name) != 1 or name not in self._get:
            return None
        values = self._get[name]()
        if not pd.api.types.is_datetime64_any_dtype(getattr(values, "dtype", None)):
            return None
        s = values if isinstance(values, pd.Series) else pd.Series(values)
        if getattr(s.dtype, "tz", None) is not None:
            s = s.dt.tz_convert("UTC").dt.tz_localize(None)
        return s.to_numpy(dtype="datetime64[ns]")

    def columns(self, names, option: str) -> np.ndarray:
        """Several columns as one float64 array, shape (N, len(names))."""
        cols = [self.column(n, option) for n in names]
        lengths = {len(c) for c in cols}
        if len(lengths) > 1:
            desc = ", ".join(f"{n!r} ({len(c)})" for n, c in zip(names, cols))
            raise DataFileError(f"{self.path}: columns of different lengths: {desc}")
        if not cols:
            return np.empty((0, 0))
        return np.ascontiguousarray(np.column_stack(cols), dtype=np.float64)


def _to_float(values, where: str) -> np.ndarray:
    """A pandas Series or ndarray → float64, rejecting non-numeric entries."""
    import pandas as pd

    s = values if isinstance(values, pd.Series) else pd.Series(values)
    dt = s.dtype
    if pd.api.types.is_bool_dtype(dt):
        return s.to_numpy(dtype=np.float64, na_value=np.nan)
    if pd.api.types.is_numeric_dtype(dt) and not pd.api.types.is_complex_dtype(dt):
        return s.to_numpy(dtype=np.float64, na_value=np.nan)
    if pd.api.types.is_datetime64_any_dtype(dt):
        ns = s.to_numpy(dtype="datetime64[ns]").astype(np.int64).astype(np.float64)
        ns[s.isna().to_numpy()] = np.nan
        return ns * 1e-9  # seconds since the epoch
    if pd.api.types.is_complex_dtype(dt):
        raise DataFileError(f"{where} holds complex numbers; adaptid identifies real parameters")
    # object / string: parse, and name the first entry that is not a number
    present = s.notna().to_numpy()
    first = np.flatnonzero(present)
    if first.size and isinstance(s.iloc[first[0]], (bytes, bytearray)):
        for i in first:
            try:
                s.iloc[i].decode("utf-8")
            except UnicodeDecodeError:
                raise DataFileError(f"{where}, row {i + 1}: not UTF-8 text ({bytes(s.iloc[i])[:20]!r}); "
                               "save the file as UTF-8") from None
        s = s.map(lambda b: b.decode("utf-8") if isinstance(b, (bytes, bytearray)) else b)
    x = pd.to_numeric(s.astype("string"), errors="coerce").to_numpy(dtype=np.float64,
                                                                    na_value=np.nan)
    bad = present & np.isnan(x)
    if bad.any():
        i = int(np.argmax(bad))
        text = str(s.iloc[i])
        if len(text) > 30:
            text = text[:30] + "…"
        raise DataFileError(f"{where}, row {i + 1}: {text!r} is not a number "
                       f"({int(bad.sum())} non-numeric value(s) in the column)")
    return x


# ------------------------------------------------------------------ readers
def read_table(path, columns=None) -> Table:
    """Read a CSV (``.csv``, ``.tsv``, ``.txt``, optionally ``.gz``), Parquet or ``.npz`` file.

    ``columns`` (optional): the names that will be used. A CSV or Parquet file
    then converts only those (the header still lists every name, for the
    error messages), so a file of 10⁶ columns costs what its used columns
    cost; names absent from the header are reported when asked for.
    """
    path = Path(os.fspath(path))
    kind = _kind_of(path)
    if not path.exists():
        raise DataFileError(f"{path}: no such file")
    if path.is_dir():
        raise DataFileError(f"{path}: is a directory, not a data file")
    try:
        with open(path, "rb") as fh:
            head = fh.read(8192)
    except OSError as err:
        raise DataFileError(f"{path}: cannot be read ({err.strerror or err})") from None
    if not head:
        raise DataFileError(f"{path}: the file is empty")
    if kind == "npz":
        return _read_npz(path, head)
    wanted = None if columns is None else list(dict.fromkeys(str(c) for c in columns))
    return (_read_csv if kind == "csv" else _read_parquet)(path, head, wanted)


def read_frame(path):
    """Read a CSV, Parquet or ``.npz`` file (as :func:`read_table`) into a pandas DataFrame."""
    return read_table(path).to_pandas()


def write_table(frame, path, *, index=True) -> Path:
    """Write a pandas DataFrame to ``.csv``, ``.parquet`` or ``.json`` (by extension), atomically.

    The table is written to a temporary file in the destination folder and
    moved over ``path`` only when complete, so a failed write leaves an
    existing file unchanged. Raises DataFileError for an unknown extension
    or an unwritable place.
    """
    path = Path(os.fspath(path))
    low = path.name.lower()
    kind = ("csv" if low.endswith(".csv") else "parquet" if low.endswith((".parquet", ".pq"))
            else "json" if low.endswith(".json") else None)
    if kind is None:
        raise DataFileError(f"{path}: unknown output type; the name must end in .csv, "
                            ".parquet or .json")
    check_writable(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        if kind == "csv":
            frame.to_csv(tmp, index=index)
        elif kind == "parquet":
            frame.to_parquet(tmp, index=index)
        else:
            (frame.reset_index() if index else frame).to_json(tmp, orient="records", indent=1)
        os.replace(tmp, path)
    except OSError as err:
        raise DataFileError(f"{path}: cannot be written ({err.strerror or err})") from None
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def check_writable(path, *, what="output") -> Path:
    """Raise DataFileError unless a file can be created or replaced at ``path``."""
    path = Path(os.fspath(path))
    if path.is_dir():
        raise DataFileError(f"{path}: is a directory; the {what} must be a file name")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise DataFileError(f"{path}: the folder {parent} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise DataFileError(f"{path}: the folder {parent} is not writable")
    if path.exists() and not os.access(path, os.W_OK):
        raise DataFileError(f"{path}: the file is not writable")
    from .estimators._statefile import special_kind
    kind = special_kind(path)
    if kind is not None:  # a device, FIFO or socket would be replaced by a regular file
        raise DataFileError(f"{path}: is {kind}; the {what} must be a regular file or a new name")
    return path


def _delimiter(path: Path, head: bytes) -> str:
    if path.name.lower().endswith((".tsv", ".tsv.gz")):
        return "\t"
    first = head.split(b"\n", 1)[0]
    counts = {d: first.count(d.encode()) for d in (",", ";", "\t")}
    best = max(counts, key=counts.get)
    return best if counts[best] > 0 else ","


def _csv_header(path: Path, delim: str, gz: bool) -> list:
    """The header's names (the first record, as the csv module splits it)."""
    opener = gzip.open if gz else open
    try:
        with opener(path, "rt", newline="", encoding="utf-8", errors="replace") as fh:
            return next(csv.reader(fh, delimiter=delim), [])
    except (OSError, csv.Error, EOFError, zlib.error):
        return []


def _usable(names, wanted):
    """The wanted names that occur exactly once in ``names`` (others are reported later)."""
    from collections import Counter

    count = Counter(names)
    return [n for n in wanted if count.get(n) == 1]


def _read_csv(path: Path, head: bytes, wanted=None) -> Table:
    try:
        import pyarrow as pa
        import pyarrow.csv as pacsv
    except ImportError:  # pragma: no cover - the cli extra installs it
        raise DataFileError("reading CSV needs pyarrow: pip install 'adaptid[cli]'") from None
    gz = path.name.lower().endswith(".gz")
    if gz:
        try:
            with gzip.open(path, "rb") as fh:
                head = fh.read(8192)
        except (OSError, EOFError, zlib.error) as err:
            raise DataFileError(f"{path}: not a readable gzip file ({_first_line(err)})") from None
        if not head:
            raise DataFileError(f"{path}: the file is empty")
    if b"\x00" in head:
        raise DataFileError(f"{path}: binary data (NUL bytes), not CSV text")
    _check_utf8(path, head)
    delim = _delimiter(path, head)
    block = max(1 << 20, 2 * _header_length(path, gz) + 2)
    header = None
    convert = pacsv.ConvertOptions()
    if wanted is not None:
        header = [str(n) for n in _csv_header(path, delim, gz)]
        convert = pacsv.ConvertOptions(include_columns=_usable(header, wanted))
    try:
        table = pacsv.read_csv(path, parse_options=pacsv.ParseOptions(delimiter=delim),
                               read_options=pacsv.ReadOptions(block_size=block),
                               convert_options=convert)
    except UnicodeDecodeError as err:
        raise DataFileError(f"{path}: the header is not UTF-8 text ({err.reason} at byte "
                       f"{err.start}); save the file as UTF-8") from None
    except pa.ArrowInvalid as err:
        msg = _first_line(err)
        if "Empty CSV file" in msg:
            raise DataFileError(f"{path}: the file is empty") from None
        if "Expected" in msg and "columns" in msg:
            where = _ragged_row(path, delim, gz)
            raise DataFileError(f"{path}: ragged rows: {where or msg}") from None
        if "UTF8" in msg or "UTF-8" in msg:
            raise DataFileError(f"{path}: not UTF-8 text ({msg}); save the file as UTF-8") from None
        raise DataFileError(f"{path}: cannot be read as CSV ({msg})") from None
    except (OSError, EOFError, zlib.error, pa.ArrowException) as err:
        raise DataFileError(f"{path}: cannot be read as CSV ({_first_line(err)})") from None
    return _from_arrow(path, "csv", table, header)


_MAX_HEADER = 64 << 20


def _check_utf8(path: Path, head: bytes) -> None:
    """Refuse text that is not UTF-8 (another encoding, or binary data), naming the byte."""
    import codecs

    try:
        codecs.getincrementaldecoder("utf-8")().decode(head, final=False)
    except UnicodeDecodeError as err:
        line = head.count(b"\n", 0, err.start) + 1
        what = "the header" if line == 1 else f"line {line}"
        raise DataFileError(f"{path}: {what} is not UTF-8 text (byte 0x{head[err.start]:02x} at "
                            f"offset {err.start}): binary data or another encoding such as "
                            "latin-1; save the file as UTF-8") from None


def _header_length(path: Path, gz: bool) -> int:
    """Bytes of the first line (to size the reader's blocks for very wide headers)."""
    opener = gzip.open if gz else open
    n = 0
    try:
        with opener(path, "rb") as fh:
            while n < _MAX_HEADER:
                chunk = fh.read(1 << 20)
                if not chunk:
                    return n
                i = chunk.find(b"\n")
                if i >= 0:
                    return n + i
                n += len(chunk)
    except (OSError, EOFError, zlib.error) as err:
        raise DataFileError(f"{path}: cannot be read ({_first_line(err)})") from None
    raise DataFileError(f"{path}: the first line is longer than {_MAX_HEADER >> 20} MB; "
                        "not a CSV header")


def _ragged_row(path: Path, delim: str, gz: bool):
    """Describe the first data row whose field count differs from the header's."""
    opener = gzip.open if gz else open
    try:
        with opener(path, "rt", newline="", encoding="utf-8", errors="replace") as fh:
            rows = csv.reader(fh, delimiter=delim)
            header = next(rows, None)
            if header is None:
                return None
            k = 0
            for row in rows:
                if not row:
                    continue
                k += 1
                if len(row) != len(header):
                    return (f"row {k} (line {rows.line_num}) has {len(row)} field(s), the header "
                            f"has {len(header)}")
    except (OSError, csv.Error, EOFError):
        return None
    return None


def _read_parquet(path: Path, head: bytes, wanted=None) -> Table:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:  # pragma: no cover - the cli extra installs it
        raise DataFileError("reading Parquet needs pyarrow: pip install 'adaptid[cli]'") from None
    if not head.startswith(b"PAR1"):
        raise DataFileError(f"{path}: not a Parquet file (no PAR1 magic bytes)")
    header = None
    try:
        if wanted is not None:
            header = [str(n) for n in pq.read_schema(path).names]
            table = pq.read_table(path, columns=_usable(header, wanted))
        else:
            table = pq.read_table(path)
    except (OSError, pa.ArrowException, ValueError) as err:
        raise DataFileError(f"{path}: cannot be read as Parquet ({_first_line(err)})") from None
    return _from_arrow(path, "parquet", table, header)


def _from_arrow(path: Path, kind: str, table, header=None) -> Table:
    """A Table of the columns read; ``header``: every name of the file (a selection was read)."""
    read = [str(n) for n in table.column_names]
    names = read if header is None else header
    if not names:
        raise DataFileError(f"{path}: no columns")
    if table.num_rows == 0 and (header is None or read):
        raise DataFileError(f"{path}: no data rows (only a header with columns {_list(names)})")
    get = {}
    for i, name in enumerate(read):
        get.setdefault(name, (lambda i=i: table.column(i).to_pandas()))
    return Table(path=path, kind=kind, names=names, _get=get)


def _read_npz(path: Path, head: bytes) -> Table:
    if not head.startswith(b"PK"):
        raise DataFileError(f"{path}: not a .npz file (not a zip archive)")
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {k: npz[k] for k in npz.files}
    except ValueError as err:  # object arrays are refused without pickle
        raise DataFileError(f"{path}: refused ({_first_line(err)})") from None
    except RuntimeError as err:  # zipfile: an encrypted member
        raise DataFileError(f"{path}: not a readable .npz file ({_first_line(err)}); "
                            "adaptid reads unencrypted archives only") from None
    except (OSError, zipfile.BadZipFile, EOFError, KeyError, zlib.error) as err:
        raise DataFileError(f"{path}: not a readable .npz file ({_first_line(err)})") from None
    except Exception as err:  # noqa: BLE001 - untrusted bytes: a damaged .npy header
        raise DataFileError(f"{path}: not a readable .npz file (a damaged member: "
                            f"{type(err).__name__}: {_first_line(err)})") from None
    for key, arr in arrays.items():
        if not isinstance(arr, np.ndarray):
            raise DataFileError(f"{path}: member {key!r} is not a NumPy array (.npy); "
                                "write the file with numpy.savez")
    names, get, groups = [], {}, {}
    for key, arr in arrays.items():
        if arr.ndim == 1:
            names.append(key)
            get[key] = (lambda a=arr: a)
        elif arr.ndim == 2:
            cols = [f"{key}[{j}]" for j in range(arr.shape[1])]
            groups[key] = cols
            for j, c in enumerate(cols):
                names.append(c)
                get[c] = (lambda a=arr, j=j: a[:, j])
    if not names:
        raise DataFileError(f"{path}: no 1-D or 2-D arrays (columns) in the archive")
    if max(len(get[n]()) for n in names) == 0:
        raise DataFileError(f"{path}: no data rows (all arrays are empty)")
    return Table(path=path, kind="npz", names=names, _get=get, groups=groups)
