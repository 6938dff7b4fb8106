"""Tables from files: the one reader of CSV, Parquet, MATLAB .mat (v5 and v7.3) and HDF5 columns.

Logs (:mod:`pgcomm.io.logs`), force maps (:mod:`pgcomm.io.forcemap`) and lookup tables
(:func:`pgcomm.export.lut.read_lut`) read their columns here and add their own checks.
Every problem raises :class:`~pgcomm.errors.DataError` with one line naming the file, and
the row and column where there is one.

Limits (checked before anything is allocated, so a damaged or hostile file is refused in
milliseconds instead of taking the machine's memory):

* a CSV header of at most :data:`MAX_COLUMNS` columns in at most :data:`MAX_HEADER_BYTES` bytes;
* an HDF5 dataset (or MATLAB variable) whose declared size the file cannot hold is refused: an
  uncompressed one must store all its bytes, a compressed one at least ``1/MAX_EXPANSION`` of them
  (deflate, the compression of HDF5 and MATLAB files, cannot expand a byte more than 1032-fold);
* the columns a read would allocate (as float64) must fit in :func:`memory_budget`, a quarter of
  the machine's memory: Parquet's and HDF5's declared row counts and MATLAB's declared dimensions
  are checked against it.
"""

from __future__ import annotations

import csv
import os
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pgcomm.errors import DataError
from pgcomm.io.config import closest_hint, list_names

#: File suffixes :func:`read_table` reads.
SUFFIXES = (".csv", ".parquet", ".mat", ".h5", ".hdf5")

#: Most columns a CSV header may name: a motor's log has tens, a drive's full telemetry hundreds; pyarrow
#: spends about a quarter of a millisecond per column and block of rows, so 4096 columns take a second.
MAX_COLUMNS = 4096

#: Most characters a CSV header may take: 4096 names of 256 characters.
MAX_HEADER_BYTES = 2**20

#: The most one stored byte of a compressed dataset may expand to when read: deflate (zlib, gzip), the
#: compression HDF5 and MATLAB files use, cannot exceed 1032:1 (a 258-byte match coded in 2 bits).
MAX_EXPANSION = 1032

#: HDF5 filters whose expansion :data:`MAX_EXPANSION` bounds (deflate, shuffle, fletcher32, lzf); others
#: (szip, n-bit, scale-offset, plug-ins) are bounded by :func:`memory_budget` alone.
_BOUNDED_FILTERS = {1, 2, 3, 32000}


def memory_budget() -> int:
    """Bytes the columns of one table may take in memory (float64): a quarter of the machine's memory.

    The machine's memory is the physical memory, or the container's limit (cgroup) where that is
    smaller. A log's later steps need a few times its columns, so a table beyond this would not
    be processed anyway; the limit refuses it before anything is allocated.

    Returns:
        bytes (int).
    """
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        total = 16 * 2**30
    for limit in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            with open(limit) as f:
                text = f.read().strip()
        except OSError:
            continue
        if text.isdigit() and 0 < int(text) < total:
            total = int(text)
    return total // 4


def _size(nbytes: float) -> str:
    """``nbytes`` in B, KiB, MiB, GiB or TiB (3 digits)."""
    for unit in ("B", "KiB", "MiB", "GiB"):
        if abs(nbytes) < 1024:
            return f"{nbytes:.3g} {unit}"
        nbytes /= 1024
    return f"{nbytes:.3g} TiB"


def check_budget(src: str, values: int, what: str) -> None:
    """Refuse a read that would allocate ``values`` float64 numbers beyond :func:`memory_budget`.

    Args:
        src: the file, for the message; values: numbers the read would hold (rows × columns);
        what: what declares them (e.g. ``"15 datasets of 268435456 rows"``).

    Raises:
        DataError: naming the file, what declares the size, the size and the budget.
    """
    budget = memory_budget()
    if 8 * values > budget:
        raise DataError(f"{src}: {what} declare {values:.4g} values ({_size(8.0 * values)} as float64), more than "
                        f"a table may take on this machine ({_size(budget)}, a quarter of its memory); "
                        "split the log into shorter files")


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
        import h5py  # start-up cost: h5py loads only when this runs

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

    The header is read with a cap (:data:`MAX_HEADER_BYTES`, :data:`MAX_COLUMNS`) before anything
    else reads the file: a file whose first line is megabytes long is refused at once.

    Raises:
        DataError: file missing, not UTF-8, empty, an unnamed or duplicate column, a header beyond
            the caps.
    """
    src = src or str(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            header = next(csv.reader(_capped_lines(f, src)), None)
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
    if len(header) > MAX_COLUMNS:
        raise DataError(f"{src}: header line names {len(header)} columns, at most {MAX_COLUMNS} are read "
                        "(a log has one column per signal); keep the columns pgcomm reads")
    header = [h.strip() for h in header]
    for j, h in enumerate(header):
        if not h:
            raise DataError(f"{src}: header column {j + 1} has no name")
    counts = Counter(header)
    dup = next((h for h in header if counts[h] > 1), None)
    if dup is not None:
        raise DataError(f"{src}: column '{dup}' appears {counts[dup]} times in the header")
    return header


def _capped_lines(f, src: str):
    """The lines of text file ``f`` for :func:`csv.reader`, at most :data:`MAX_HEADER_BYTES` characters in all
    (a quoted name may span lines); beyond that a :class:`DataError`."""
    left = MAX_HEADER_BYTES
    while True:
        line = f.readline(left + 1)
        if not line:
            return
        left -= len(line)
        if left < 0:
            raise DataError(f"{src}: header line longer than {_size(MAX_HEADER_BYTES)} (at most {MAX_COLUMNS} "
                            "column names are read); is this a CSV log with a header line?")
        yield line


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

    The file is parsed block by block (pyarrow's streaming reader) straight into one float64 array
    per column, so reading takes the columns' own memory plus one block, not twice the columns.

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
    import pyarrow as pa  # start-up cost: PyArrow loads only when this runs
    import pyarrow.csv as pacsv  # start-up cost: PyArrow loads only when this runs

    src = source or str(path)
    strict = strict or (lambda name: True)
    header = read_csv_header(path, src)
    nulls = dict(null_values=[""], strings_can_be_null=False, quoted_strings_can_be_null=True)

    def reader(types, include=None):
        return pacsv.open_csv(path, read_options=pacsv.ReadOptions(column_names=header, skip_rows=1,
                                                                   block_size=_CSV_BLOCK),
                              convert_options=pacsv.ConvertOptions(column_types=types, include_columns=include,
                                                                   **nulls))

    strict_types = {h: pa.float64() for h in header if strict(h)}

    def read():
        # the first block tells which extra columns are numbers; a streaming reader keeps the types it infers
        # there, so every kept column is then read as float64 (an extra column of "1" then "1.5" stays numeric)
        with reader(strict_types) as probe:
            schema = probe.schema
        kept = [f.name for f in schema if f.name in strict_types or pa.types.is_floating(f.type)
                or pa.types.is_integer(f.type) or pa.types.is_null(f.type)]
        with reader({h: pa.float64() for h in kept}, kept) as stream:
            return _stream_columns(stream, kept, set(strict_types), _count_lines(path), src)

    try:
        out = read()
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
        return _read_csv_python(path, src, header, strict)
    finally:
        pa.default_memory_pool().release_unused()  # the parser's buffers (~60 MB): its allocator keeps them otherwise
    return out


def _stream_columns(stream, kept: list[str], strict: set, rows: int, src: str) -> dict[str, np.ndarray]:
    """The batches of a pyarrow CSV stream written into one float64 array per kept column.

    Args:
        rows: an upper bound on the rows (:func:`_count_lines`): each array is allocated once.
        strict: columns whose empty cells are an error; an extra column with one is dropped.
    """
    out = {name: np.empty(rows) for name in kept}
    dropped: set[str] = set()
    n = 0
    for batch in stream:
        m = batch.num_rows
        for name, col in zip(batch.schema.names, batch.columns):
            if name in dropped:
                continue
            if col.null_count:
                if name not in strict:
                    dropped.add(name)  # an extra column with empty cells: ignored
                    continue
                row = n + int(np.flatnonzero(col.is_null().to_numpy(zero_copy_only=False))[0]) + 1
                raise DataError(f"{src} row {row} column '{name}' is empty, expected a number")
            out[name][n:n + m] = col.to_numpy()
        n += m
    return {name: a[:n] if n < a.shape[0] else a for name, a in out.items() if name not in dropped}


#: Bytes of CSV text pyarrow parses per block: pyarrow's default. The parser holds tens of blocks' worth of
#: buffers (~40 MB at 1 MiB, ~280 MB at 8 MiB) beside the arrays, and larger blocks are not faster.
_CSV_BLOCK = 2**20


def _count_lines(path) -> int:
    """Lines of a text file (a last line without a newline counts): an upper bound on its CSV rows + 1."""
    count, last = 0, b"\n"
    with open(path, "rb") as f:
        while chunk := f.read(2**24):
            count += chunk.count(b"\n")
            last = chunk[-1:]
    return count + (last != b"\n")


def _arrow_column(col, name: str, src: str, strict: bool):
    """A pyarrow column as float64, or ``None`` for an ignored non-numeric extra column."""
    import pyarrow as pa  # start-up cost: PyArrow loads only when this runs
    import pyarrow.compute as pc  # start-up cost: PyArrow loads only when this runs

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
    import pyarrow as pa  # start-up cost: PyArrow loads only when this runs
    import pyarrow.parquet as pq  # start-up cost: PyArrow loads only when this runs

    try:
        pf = pq.ParquetFile(path)
        meta = pf.metadata
    except FileNotFoundError:
        raise DataError(f"{src}: file not found") from None
    except (pa.ArrowInvalid, OSError) as e:
        raise DataError(f"{src}: not a readable Parquet file ({' '.join(str(e).split())})") from None
    # rows are declared in the footer: a run-length-coded column can declare billions in a few bytes
    check_budget(src, meta.num_rows * meta.num_columns, f"its {meta.num_columns} columns of {meta.num_rows} rows")
    try:
        table = pf.read()
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


#: Bytes per element of MATLAB's numeric classes (``scipy.io.whosmat``), for the declared-size check.
_MAT_BYTES = {"double": 8, "single": 4, "int8": 1, "uint8": 1, "int16": 2, "uint16": 2, "int32": 4, "uint32": 4,
              "int64": 8, "uint64": 8, "logical": 1}


def _read_mat_v5(path, src: str, wanted, group: str | None) -> tuple[dict, list[str]]:
    import scipy.io as sio  # start-up cost: SciPy loads only when this runs

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
        return _mat_struct(_loadmat(path, src, [group])[group], group, src, wanted)
    top = _pick(names, wanted)
    if not top and len(structs) == 1:
        return _mat_struct(_loadmat(path, src, structs)[structs[0]], structs[0], src, wanted)
    _check_mat_sizes(path, src, [v for v in info if v[0] in top])
    data = _loadmat(path, src, top) if top else {}
    return {n: _vector(data[n], n, src) for n in top}, names


def _check_mat_sizes(path, src: str, info) -> None:
    """Refuse variables whose declared dimensions the file cannot hold, or the memory cannot (before loading).

    Args:
        info: ``[(name, shape, class), ...]`` of :func:`scipy.io.whosmat` for the variables to load.
    """
    file_size = Path(path).stat().st_size
    total = 0
    for name, shape, cls in info:
        values = int(np.prod(shape, dtype=np.float64)) if len(shape) else 1
        total += values
        if cls in _MAT_BYTES and values * _MAT_BYTES[cls] > MAX_EXPANSION * file_size:
            raise DataError(f"{src}: variable '{name}' declares {' x '.join(str(d) for d in shape)} values "
                            f"({_size(values * _MAT_BYTES[cls])}) but the file has {_size(file_size)} (compressed data "
                            f"expands at most {MAX_EXPANSION}-fold): its dimensions are damaged")
    check_budget(src, total, f"the {len(info)} variable(s) read ({', '.join(repr(n) for n, _, _ in info[:3])}"
                             f"{', ...' if len(info) > 3 else ''})")


def _loadmat(path, src: str, names: list[str]) -> dict:
    """:func:`scipy.io.loadmat` of the variables ``names``; a damaged variable (cut short, dimensions that do not
    match its data) is a :class:`DataError` naming it."""
    import scipy.io as sio  # start-up cost: SciPy loads only when this runs

    try:
        return sio.loadmat(str(path), variable_names=names, simplify_cells=True)
    except Exception as e:  # scipy raises OSError, ValueError, zlib.error ... on damaged data
        first = e
    bad = names[0]
    if len(names) > 1:  # which one: load them one by one (only on this error path)
        for name in names:
            try:
                sio.loadmat(str(path), variable_names=[name], simplify_cells=True)
            except Exception as e:
                bad, first = name, e
                break
    raise DataError(f"{src}: variable '{bad}' cannot be read ({type(first).__name__}: {' '.join(str(first).split())}); "
                    "the file is damaged: cut short, or its declared dimensions do not match its data") from None


def _mat_struct(s, group: str, src: str, wanted) -> tuple[dict, list[str]]:
    if not isinstance(s, dict):
        raise DataError(f"{src}: '{group}' is a struct array; expected a scalar struct with one field per column")
    fields = list(s)
    return {n: _vector(s[n], f"{group}.{n}", src, "field") for n in _pick(fields, wanted)}, [f"{group}.{n}" for n in fields]


_HDF5_SKIP = ("#refs#", "#subsystem#")


def _read_hdf5(path, src: str, wanted, group: str | None, what: str) -> tuple[dict, list[str]]:
    import h5py  # start-up cost: h5py loads only when this runs

    try:
        f = h5py.File(path, "r")
    except FileNotFoundError:
        raise DataError(f"{src}: file not found") from None
    except OSError as e:
        raise DataError(f"{src}: not a readable HDF5 file ({' '.join(str(e).split())})") from None
    file_size = Path(path).stat().st_size
    with f:
        if group is not None:
            if group not in f:
                found = [k for k in f.keys() if k not in _HDF5_SKIP]
                raise DataError(f"{src}: group '{group}' (options.group) missing; found {list_names(found)}{closest_hint(group, found)}")
            base = f[group]
            if isinstance(base, h5py.Dataset):
                if base.dtype.names is None:
                    raise DataError(f"{src}: '{group}' (options.group) is a dataset without named fields, expected a group")
                names = list(base.dtype.names)
                picked = _pick(names, wanted)
                _check_dataset(base, group, src, "dataset", file_size)
                check_budget(src, base.size * len(picked), f"{len(picked)} fields of {base.size} rows in '{group}'")
                arr = _read_dataset(base, group, src, "dataset")
                return {n: _vector(arr[n], f"{group}.{n}", src, "field") for n in picked}, names
        else:
            base = f
            datasets = [k for k, v in f.items() if isinstance(v, h5py.Dataset)]
            groups = [k for k, v in f.items() if isinstance(v, h5py.Group) and k not in _HDF5_SKIP]
            if not _pick(datasets, wanted) and len(groups) == 1:
                base = f[groups[0]]  # the only struct / group holds the columns
        names = [k for k, v in base.items() if isinstance(v, h5py.Dataset) and k not in _HDF5_SKIP]
        prefix = "" if base.name == "/" else base.name.lstrip("/") + "/"
        picked = _pick(names, wanted)
        # every declared size against the file and the memory before the first byte is read
        for n in picked:
            _check_dataset(base[n], prefix + n, src, what, file_size)
        if picked:
            rows = max(base[n].size for n in picked)
            check_budget(src, sum(base[n].size for n in picked),
                         f"the {len(picked)} {what}(s) read (up to {rows} values each)")
        out = {n: _vector(_read_dataset(base[n], prefix + n, src, what), prefix + n, src, what) for n in picked}
        if not names:
            names = [k for k in base.keys() if k not in _HDF5_SKIP]
        return out, [prefix + n for n in names]


def _check_dataset(ds, name: str, src: str, what: str, file_size: int) -> None:
    """Refuse an HDF5 dataset whose declared size the file does not hold (before reading it).

    An unfiltered dataset must store every declared byte (chunks never written read as the fill
    value: a column of made-up numbers); a compressed one (deflate, lzf, shuffle) at least
    ``1/MAX_EXPANSION`` of them. Compact, external and virtual layouts and other filters are left to
    :func:`check_budget`.
    """
    import h5py  # start-up cost: h5py loads only when this runs

    declared = int(ds.size) * int(ds.dtype.itemsize)
    if declared == 0:
        return
    dcpl = ds.id.get_create_plist()
    layout = dcpl.get_layout()
    if layout not in (h5py.h5d.CONTIGUOUS, h5py.h5d.CHUNKED) or dcpl.get_external_count():
        return
    filters = {dcpl.get_filter(i)[0] for i in range(dcpl.get_nfilters())}
    if filters and not filters <= _BOUNDED_FILTERS:
        return
    stored = min(int(ds.id.get_storage_size()), file_size)
    factor = MAX_EXPANSION if filters else 1
    if declared > factor * stored:
        how = f" (compressed data expands at most {MAX_EXPANSION}-fold)" if filters else ""
        raise DataError(f"{src}: {what} '{name}' declares {ds.size} values ({_size(declared)}) but the file stores "
                        f"{_size(stored)} of it{how}: the file is damaged (a {what} created larger than written, "
                        "or cut short)")


def _read_dataset(ds, name: str, src: str, what: str):
    """``ds[()]``; a read error of HDF5 (a damaged chunk, a missing filter) as a :class:`DataError` naming it."""
    try:
        return ds[()]
    except (OSError, ValueError) as e:
        raise DataError(f"{src}: {what} '{name}' cannot be read ({' '.join(str(e).split())})") from None
