"""Inputs that would take the machine down, and damaged files: refused before anything is allocated, with one line
naming the file and the dataset, variable or column, exit 2 and nothing written; and the readers that stream a
large file give what reading it whole gives.

Small versions of the large inputs: an HDF5 file declaring a dataset far larger than the file, a CSV header over
the column cap, a .mat whose dimensions lie, and the memory budget lowered to make an ordinary log too large.
"""

from __future__ import annotations

import struct

import h5py
import numpy as np
import pytest
import scipy.io as sio

import pgcomm.io.tables as tables
from pgcomm.errors import DataError
from pgcomm.io.logs import Log, read_log, write_log

from test_bad_input import _check_refused

N = 400
TS = 1e-3


def _columns(n=N):
    t = np.arange(n) * TS
    rng = np.random.default_rng(3)
    return {"t": t, "y": 0.05 * np.sin(2 * np.pi * t), "Fy": rng.standard_normal(n), "Fx": rng.standard_normal(n),
            "Tz": rng.standard_normal(n), "Fy_star": rng.standard_normal(n), "Fx_star": rng.standard_normal(n),
            "Tz_star": rng.standard_normal(n), "ia_1": rng.standard_normal(n), "ib_1": rng.standard_normal(n)}


def _evaluate(tmp_path, capsys, data, pattern):
    """``pgcomm evaluate --data data``: refused with one line matching ``pattern``, no output, no staging folder."""
    _check_refused(["evaluate", "--data", data], tmp_path / "out", capsys, pattern, tmp_path)


# --------------------------------------------------------------------------- HDF5: declared sizes


@pytest.mark.parametrize("layout", ["chunked", "contiguous"])
def test_hdf5_declaring_more_than_the_file_holds_is_refused_before_reading(tmp_path, capsys, layout):
    """A dataset declaring 8 GB in a file of kilobytes (chunks or space never written: HDF5 would hand back its fill
    value, and the reader would allocate the declared size)."""
    p = tmp_path / "lying.h5"
    cols = _columns()
    with h5py.File(p, "w") as f:
        for k, v in cols.items():
            f[k] = v
        del f["Fx"]
        f.create_dataset("Fx", shape=(10**9,), dtype="f8", chunks=(4096,) if layout == "chunked" else None)
    assert p.stat().st_size < 100_000
    _evaluate(tmp_path, capsys, p, r"lying\.h5: dataset 'Fx' declares 1000000000 values \(7\.45 GiB\) but the file "
                                   r"stores 0 B of it")


def test_hdf5_compressed_past_deflates_limit_is_refused_and_within_it_read(tmp_path, capsys):
    """Deflate expands a stored byte at most 1032-fold: a constant column (the best case) compressed with gzip reads
    back; a chunk written and the rest of a huge dataset left unwritten is refused."""
    p = tmp_path / "zip.h5"
    cols = _columns(50_000)
    cols["Fx"] = np.zeros(50_000)
    with h5py.File(p, "w") as f:
        for k, v in cols.items():
            f.create_dataset(k, data=v, compression="gzip", compression_opts=9, shuffle=True)
        assert f["Fx"].nbytes / f["Fx"].id.get_storage_size() > 100  # compressed, and still read
    log = read_log(p)
    np.testing.assert_array_equal(log["Fx"], 0.0)
    np.testing.assert_allclose(log["Fy"], cols["Fy"], rtol=1e-15, atol=0)
    q = tmp_path / "partly.h5"
    with h5py.File(q, "w") as f:
        for k, v in _columns().items():
            f[k] = v
        del f["y"]
        d = f.create_dataset("y", shape=(10**8,), dtype="f8", chunks=(4096,), compression="gzip")
        d[:4096] = np.random.default_rng(0).standard_normal(4096)
    _evaluate(tmp_path, capsys, q, r"partly\.h5: dataset 'y' declares 100000000 values \(763 MiB\) but the file "
                                   r"stores .* of it \(compressed data expands at most 1032-fold\)")


# --------------------------------------------------------------------------- the memory budget


@pytest.mark.parametrize("suffix", [".h5", ".parquet", ".mat"])
def test_a_table_beyond_the_memory_budget_is_refused_naming_the_file(tmp_path, capsys, monkeypatch, suffix):
    """The columns a read would allocate (rows declared by HDF5's datasets, Parquet's footer, MATLAB's dimensions)
    against a quarter of the machine's memory; here the budget is lowered below an ordinary log's 32 kB."""
    p = tmp_path / f"log{suffix}"
    cols = _columns()
    if suffix == ".h5":
        with h5py.File(p, "w") as f:
            for k, v in cols.items():
                f[k] = v
    elif suffix == ".mat":
        sio.savemat(p, cols)
    else:
        write_log(p, Log(cols, TS))
    assert read_log(p).n_samples == N
    monkeypatch.setattr(tables, "memory_budget", lambda: 8 * N * 5)  # five columns' worth
    with pytest.raises(DataError, match=rf"^{p}: .*declare 4000 values \(31\.2 KiB as float64\), more than a table "
                                        r"may take on this machine \(15\.6 KiB"):
        read_log(p)
    _evaluate(tmp_path, capsys, p, rf"log\{suffix}: .* more than a table may take on this machine")


def test_memory_budget_is_a_quarter_of_the_machine():
    import os

    total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    assert 0 < tables.memory_budget() <= total // 4


# --------------------------------------------------------------------------- CSV: the header's cap


def test_csv_header_over_the_column_cap_is_refused(tmp_path, capsys):
    p = tmp_path / "wide.csv"
    names = ["t", "y", "Fy", "Fx", "Tz", "ia_1", "ib_1"] + [f"s{j}" for j in range(tables.MAX_COLUMNS)]
    p.write_text(",".join(names) + "\n" + ",".join(["0"] * len(names)) + "\n")
    _evaluate(tmp_path, capsys, p, rf"wide\.csv: header line names {len(names)} columns, at most 4096 are read")


def test_csv_header_line_over_the_byte_cap_is_refused(tmp_path, capsys):
    p = tmp_path / "oneline.csv"
    p.write_text("t," + "x" * tables.MAX_HEADER_BYTES)  # no newline: a reader without a cap reads it all
    _evaluate(tmp_path, capsys, p, r"oneline\.csv: header line longer than 1 MiB")


def test_duplicate_column_in_a_wide_header_is_named(tmp_path):
    p = tmp_path / "dup.csv"
    names = [f"s{j}" for j in range(4000)] + ["s17"]
    p.write_text(",".join(names) + "\n")
    with pytest.raises(DataError, match=r"dup\.csv: column 's17' appears 2 times in the header"):
        tables.read_csv_header(p)


# --------------------------------------------------------------------------- CSV: streamed block by block


def test_csv_read_block_by_block_equals_the_exact_parser(tmp_path, monkeypatch):
    """Small blocks (many of them) against the plain Python parser: the same columns and numbers; an extra column of
    integers in the first block and fractions later stays numeric; one with text or an empty cell is dropped."""
    monkeypatch.setattr(tables, "_CSV_BLOCK", 4096)
    rng = np.random.default_rng(7)
    n = 3000
    a, b = rng.standard_normal(n) * 10.0 ** rng.integers(-30, 30, n), rng.uniform(-1, 1, n)
    count = np.arange(n, dtype=float)
    count[-1] = 2.5
    lines = ["t,a,b,count,label,gappy"]
    for i in range(n):
        label, gap = "x" if i % 7 else "y", "" if i == n - 5 else 1
        lines.append(f"{i * TS!r},{float(a[i])!r},{float(b[i])!r},{count[i]:g},{label},{gap}")
    p = tmp_path / "long.csv"
    p.write_text("\n".join(lines))  # no newline after the last row
    strict = {"t", "a", "b"}.__contains__
    got = tables.read_csv_columns(p, strict=strict)
    ref = tables._read_csv_python(p, str(p), tables.read_csv_header(p), strict)
    assert list(got) == ["t", "a", "b", "count"] and list(ref) == ["t", "a", "b", "count"]
    for k in got:
        assert got[k].shape == (n,)
        np.testing.assert_allclose(got[k], ref[k], rtol=1e-15, atol=0)
    np.testing.assert_allclose(got["count"], count, rtol=0, atol=0)


def test_csv_empty_cell_in_a_late_block_names_its_row(tmp_path, monkeypatch):
    monkeypatch.setattr(tables, "_CSV_BLOCK", 1024)
    p = tmp_path / "hole.csv"
    rows = [f"{i * TS!r},{i}" for i in range(2000)]
    rows[1733] = f"{1733 * TS!r},"
    p.write_text("t,y\n" + "\n".join(rows) + "\n")
    with pytest.raises(DataError, match=r"hole\.csv row 1734 column 'y' is empty, expected a number"):
        tables.read_csv_columns(p)


# --------------------------------------------------------------------------- MATLAB .mat: damaged files


@pytest.fixture
def mat_files(tmp_path):
    """A good .mat log (uncompressed and compressed) and damaged copies: cut in half, a dimension that lies
    (5000 rows declared for 400 stored), and one declaring 10¹⁰ values."""
    cols = _columns()
    files = {}
    for name, compress in (("plain", False), ("zipped", True)):
        p = tmp_path / f"{name}.mat"
        sio.savemat(p, cols, do_compression=compress)
        raw = p.read_bytes()
        (tmp_path / f"cut_{name}.mat").write_bytes(raw[: len(raw) // 2])
        files[f"cut_{name}"] = tmp_path / f"cut_{name}.mat"
    raw = bytearray((tmp_path / "plain.mat").read_bytes())
    dims = struct.pack("<II", 5, 8) + struct.pack("<ii", 1, N)  # miINT32, 8 bytes: the first variable's 1 x N
    i = raw.find(dims)
    assert i > 0
    for name, shape in (("lying", (1, 5000)), ("huge", (100_000, 100_000))):
        out = bytearray(raw)
        out[i + 8:i + 16] = struct.pack("<ii", *shape)
        (tmp_path / f"{name}.mat").write_bytes(bytes(out))
        files[name] = tmp_path / f"{name}.mat"
    return files


@pytest.mark.parametrize("case,pattern", [
    ("cut_plain", r"cut_plain\.mat: variable '\w+' cannot be read \(OSError: .*\); the file is damaged: cut short"),
    ("cut_zipped", r"cut_zipped\.mat: variable '\w+' cannot be read \(\w+: .*\); the file is damaged: cut short"),
    ("lying", r"lying\.mat: variable 't' cannot be read \(ValueError: cannot reshape .*\); the file is damaged: cut "
              r"short, or its declared dimensions do not match its data"),
    ("huge", r"huge\.mat: variable 't' declares 100000 x 100000 values \(74\.5 GiB\) but the file has .* its "
             r"dimensions are damaged"),
])
def test_damaged_mat_files_are_one_line(tmp_path, capsys, mat_files, case, pattern):
    _evaluate(tmp_path, capsys, mat_files[case], pattern)
