"""Tables from files: the one reader of CSV, Parquet, MATLAB .mat (v5 and v7.3) and HDF5 columns.

Logs (:mod:`pgcomm.io.logs`), force maps (:mod:`pgcomm.io.forcemap`) and lookup tables
(:func:`pgcomm.export.lut.read_lut`) read their columns here and add their own checks.
Every problem raises :class:`~pgcomm.errors.DataError` with one line naming the file, and
the row and column where there is one.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pgcomm.errors import DataError
from pgcomm.io.config import closest_hint, list_names

#: File suffixes :func:`read_table` reads.
SUFFIXES = (".csv", ".parquet", ".mat", ".h5", ".hdf5")


@dataclass(frozen=True)
class Table:
    """Columns read from a file.

    Attributes:
        columns: ``{name: (N,) float64}`` of the wanted columns, in file order.
        found: every column (variable, dataset) name the file holds, for messages.
        sample_time: sample time (s) stored in the file's metadata (Parquet written by pgcomm), else ``None``.
        kind: what a column is called in this format: ``"column"``, ``"variable"`` or ``"dataset"``.
    """

    columns: dict
    found: list
    sample_time: float | None
    kind: str


def read_table(path, wanted=None, group: str | None = None, source: str | None = None, what: str = "table",
               csv_suffixes=(".csv",)) -> Table:
    """Read the wanted numeric columns of a CSV, Parquet, ``.mat`` or HDF5 file (chosen by suffix).

    Args:
        path: the file.
        wanted: predicate on a column name: ``True`` = read it (and, in CSV and Parquet, it must
            be numeric in every row); other numeric columns are kept where the format reads
            them anyway, non-numeric ones are dropped. Default: every column.
        group: ``.mat`` struct or HDF5 group holding the columns (default: the top level, or
            its only struct/group when the top level has none of the wanted columns).
        source: name for messages (default ``str(path)``); what: ``"log"``, ``"reference"`` ...
            for the messages about unsupported suffixes and directories.
        csv_suffixes: suffixes read as CSV (references also take ``.txt``).

    Returns:
        :class:`Table`.
    """
    wanted = wanted or (lambda name: True)
    src = source or str(path)
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix in csv_suffixes:
        suffix = ".csv"
    if suffix not in SUFFIXES:
        raise DataError(f"{src}: unsupported {what} format '{suffix}' (supported: {', '.join(SUFFIXES)})")
    if not p.exists():
        raise DataError(f"{src}: file not found")
    if p.is_dir():
        raise DataError(f"{src}: is a directory, expected a {what} file")
    file_ts = None
    if suffix == ".csv":
        raw = read_csv_columns(p, src, strict=wanted)
        found = list(raw)
    elif suffix == ".parquet":
        raw, file_ts = _read_parquet(p, src, wanted)
        found = list(raw)
    elif suffix == ".mat":
        import h5py

        if h5py.is_hdf5(p):  # MATLAB v7.3 files are HDF5
            raw, found = _read_hdf5(p, src, wanted, group, "variable")
        else:
            raw, found = _read_mat_v5(p, src, wanted, group)
    else:
        raw, found = _read_hdf5(p, src, wanted, group, "dataset")
    kind = "variable" if suffix == ".mat" else "dataset" if suffix in (".h5", ".hdf5") else "column"
    return Table(raw, found, file_ts, kind)




def read_csv_header(path, src: str | None = None) -> list[str]:
    """Column names of a CSV file's header line (stripped; BOM removed).

    Raises:
        DataError: file missing, not UTF-8, empty, an unnamed or duplicate column.
    """
    src = src or str(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            header = next(csv.reader(f), None)
    except FileNotFoundError:
        raise DataError(f"{src}: file not found") from None
    except IsADirectoryError:
        raise DataError(f"{src}: is a directory, expected a CSV file") from None
    except UnicodeDecodeError as e:
        raise DataError(f"{src}: not UTF-8 text ({e.reason} at byte {e.start})") from None
    except csv.Error as e:
        raise DataError(f"{src}: header line is not valid CSV ({e})") from None
    except OSError as e:
        raise DataError(f"{src}: cannot read ({e.strerror})") from None
    if not header:
        raise DataError(f"{src}: empty file (expected a header line with column names)")
    header = [h.strip() for h in header]
    for j, h in enumerate(header):
        if not h:
            raise DataError(f"{src}: header column {j + 1} has no name")
    dup = sorted({h for h in header if header.count(h) > 1})
    if dup:
        raise DataError(f"{src}: column '{dup[0]}' appears {header.count(dup[0])} times in the header")
    return header


def _read_csv_python(path, src: str, header: list[str], strict) -> dict:
    """Slow exact CSV parser used when pyarrow refuses a file: it finds the offending cell."""
    n = len(header)
    cells: list[list] = [[] for _ in header]
    lenient = {j for j, h in enumerate(header) if not strict(h)}
    with open(path, newline="", encoding="utf-8-sig") as f:
        reader = csv.reader(f)
        next(reader)
        row = 0
        for fields in reader:
            if not fields:
                continue  # blank line (pyarrow skips them too)
            row += 1
            line = reader.line_num
            if len(fields) != n:
                raise DataError(f"{src} row {row} has {len(fields)} fields, expected {n} as in the header (line {line})")
            for j, cell in enumerate(fields):
                if j in lenient:
                    cells[j].append(cell)
                    continue
                s = cell.strip()
                if not s:
                    raise DataError(f"{src} row {row} column '{header[j]}' is empty, expected a number (line {line})")
                try:
                    cells[j].append(float(s))
                except ValueError:
                    raise DataError(f"{src} row {row} column '{header[j]}': {cell!r} is not a number (line {line})") from None
    out = {}
    for j, h in enumerate(header):
        if j in lenient:
            try:
                out[h] = np.array([float(c) for c in cells[j]], dtype=np.float64)
            except ValueError:
                continue  # a non-numeric column that is not a log column: ignored
        else:
            out[h] = np.array(cells[j], dtype=np.float64)
    return out


def read_csv_columns(path, source: str | None = None, strict=None) -> dict[str, np.ndarray]:
    """Read a CSV file with a header into ``{name: float64 array}`` (file order).

    Args:
        path: CSV file.
        source: name for messages (default ``str(path)``).
        strict: predicate on a column name: ``True`` = the column must be
            numeric in every row (else :class:`DataError` naming row and column);
            other columns are kept if numeric and dropped otherwise. Default:
            every column is strict.

    Returns:
        dict of 1-D float64 arrays of equal length (possibly 0).
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv

    src = source or str(path)
    strict = strict or (lambda name: True)
    header = read_csv_header(path, src)
    types = {h: pa.float64() for h in header if strict(h)}
    try:
        table = pacsv.read_csv(
            path,
            read_options=pacsv.ReadOptions(column_names=header, skip_rows=1),
            convert_options=pacsv.ConvertOptions(
                column_types=types, null_values=[""], strings_can_be_null=False, quoted_strings_can_be_null=True
            ),
        )
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
        return _read_csv_python(path, src, header, strict)
    out = {}
    for name, col in zip(header, table.columns):
        if name not in types:
            if not (pa.types.is_floating(col.type) or pa.types.is_integer(col.type) or pa.types.is_null(col.type)):
                continue  # non-numeric extra column: ignored
            if col.null_count or pa.types.is_null(col.type):
                continue
            out[name] = col.to_numpy().astype(np.float64, copy=False)
            continue
        if col.null_count:
            row = int(np.flatnonzero(col.is_null().to_numpy())[0]) + 1
            raise DataError(f"{src} row {row} column '{name}' is empty, expected a number")
        out[name] = col.to_numpy()  # one copy at most (concatenating chunks)
    return out


def _arrow_column(col, name: str, src: str, strict: bool):
    """A pyarrow column as float64, or ``None`` for an ignored non-numeric extra column."""
    import pyarrow as pa
    import pyarrow.compute as pc

    t = col.type
    if pa.types.is_dictionary(t):
        col = col.dictionary_decode() if hasattr(col, "dictionary_decode") else pc.cast(col, t.value_type)
        t = col.type
    numeric = pa.types.is_floating(t) or pa.types.is_integer(t) or pa.types.is_boolean(t) or pa.types.is_decimal(t)
    if not numeric:
        if not strict:
            return None
        if pa.types.is_string(t) or pa.types.is_large_string(t):
            for i, v in enumerate(col.to_pylist()):
                try:
                    float(v)
                except (TypeError, ValueError):
                    if v is None:
                        raise DataError(f"{src} row {i + 1} column '{name}' is empty, expected a number") from None
                    raise DataError(f"{src} row {i + 1} column '{name}': {v!r} is not a number") from None
            return np.array([float(v) for v in col.to_pylist()], dtype=np.float64)
        raise DataError(f"{src}: column '{name}' has type {t}, expected numbers")
    if col.null_count:
        if not strict:
            return None
        row = int(np.flatnonzero(col.is_null().to_numpy(zero_copy_only=False))[0]) + 1
        raise DataError(f"{src} row {row} column '{name}' is empty, expected a number")
    if not pa.types.is_float64(t):
        col = pc.cast(col, pa.float64())
    return col.to_numpy()


def _read_parquet(path, src: str, strict) -> tuple[dict, float | None]:
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        table = pq.read_table(path)
    except FileNotFoundError:
        raise DataError(f"{src}: file not found") from None
    except (pa.ArrowInvalid, OSError) as e:
        raise DataError(f"{src}: not a readable Parquet file ({' '.join(str(e).split())})") from None
    out = {}
    for name, col in zip(table.column_names, table.columns):
        if name in out:
            raise DataError(f"{src}: column '{name}' appears more than once")
        a = _arrow_column(col, name, src, strict(name))
        if a is not None:
            out[name] = a
    meta = table.schema.metadata or {}
    ts = meta.get(b"pgcomm.sample_time")
    try:
        ts = float(ts) if ts is not None else None
    except ValueError:
        ts = None
    return out, ts


def _vector(value, name: str, src: str, what: str = "variable") -> np.ndarray:
    a = np.asarray(value)
    if a.ndim == 0:
        a = a.reshape(1)  # a MATLAB scalar (e.g. a sample time Ts)
    if a.dtype.kind not in "biuf":
        raise DataError(f"{src}: {what} '{name}' is not numeric (type {a.dtype}), expected a vector of numbers")
    if a.ndim > 1:
        a = a.reshape(-1) if sum(s != 1 for s in a.shape) <= 1 else a
    if a.ndim != 1:
        raise DataError(f"{src}: {what} '{name}' has shape {a.shape}, expected a vector (N×1 or 1×N)")
    return a.astype(np.float64, copy=False)


def _pick(available: list[str], wanted) -> list[str]:
    return [n for n in available if wanted(n)]


def _read_mat_v5(path, src: str, wanted, group: str | None) -> tuple[dict, list[str]]:
    import scipy.io as sio

    try:
        info = sio.whosmat(str(path))
    except Exception as e:  # scipy raises assorted errors on non-.mat input
        raise DataError(f"{src}: not a readable MATLAB .mat file ({type(e).__name__}: {' '.join(str(e).split())})") from None
    names = [n for n, _, _ in info]
    structs = [n for n, _, cls in info if cls == "struct"]
    if group is not None:
        if group not in names:
            raise DataError(f"{src}: struct '{group}' (options.group) missing; found {list_names(names)}{closest_hint(group, names)}")
        if group not in structs:
            raise DataError(f"{src}: variable '{group}' (options.group) is not a struct")
        return _mat_struct(sio.loadmat(str(path), variable_names=[group], simplify_cells=True)[group], group, src, wanted)
    top = _pick(names, wanted)
    if not top and len(structs) == 1:
        return _mat_struct(sio.loadmat(str(path), variable_names=structs, simplify_cells=True)[structs[0]], structs[0], src, wanted)
    data = sio.loadmat(str(path), variable_names=top, simplify_cells=True) if top else {}
    return {n: _vector(data[n], n, src) for n in top}, names


def _mat_struct(s, group: str, src: str, wanted) -> tuple[dict, list[str]]:
    if not isinstance(s, dict):
        raise DataError(f"{src}: '{group}' is a struct array; expected a scalar struct with one field per column")
    fields = list(s)
    return {n: _vector(s[n], f"{group}.{n}", src, "field") for n in _pick(fields, wanted)}, [f"{group}.{n}" for n in fields]


_HDF5_SKIP = ("#refs#", "#subsystem#")


def _read_hdf5(path, src: str, wanted, group: str | None, what: str) -> tuple[dict, list[str]]:
    import h5py

    try:
        f = h5py.File(path, "r")
    except FileNotFoundError:
        raise DataError(f"{src}: file not found") from None
    except OSError as e:
        raise DataError(f"{src}: not a readable HDF5 file ({' '.join(str(e).split())})") from None
    with f:
        if group is not None:
            if group not in f:
                found = [k for k in f.keys() if k not in _HDF5_SKIP]
                raise DataError(f"{src}: group '{group}' (options.group) missing; found {list_names(found)}{closest_hint(group, found)}")
            base = f[group]
            if isinstance(base, h5py.Dataset):
                if base.dtype.names is None:
                    raise DataError(f"{src}: '{group}' (options.group) is a dataset without named fields, expected a group")
                arr = base[()]
                names = list(base.dtype.names)
                return {n: _vector(arr[n], f"{group}.{n}", src, "field") for n in _pick(names, wanted)}, names
        else:
            base = f
            datasets = [k for k, v in f.items() if isinstance(v, h5py.Dataset)]
            groups = [k for k, v in f.items() if isinstance(v, h5py.Group) and k not in _HDF5_SKIP]
            if not _pick(datasets, wanted) and len(groups) == 1:
                base = f[groups[0]]  # the only struct / group holds the columns
        names = [k for k, v in base.items() if isinstance(v, h5py.Dataset) and k not in _HDF5_SKIP]
        prefix = "" if base.name == "/" else base.name.lstrip("/") + "/"
        out = {n: _vector(base[n][()], prefix + n, src, what) for n in _pick(names, wanted)}
        if not names:
            names = [k for k in base.keys() if k not in _HDF5_SKIP]
        return out, [prefix + n for n in names]
