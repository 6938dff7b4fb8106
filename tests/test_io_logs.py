"""Logs: CSV/Parquet/.mat/HDF5 reading and writing, column mapping, validation."""

import h5py
import numpy as np
import pytest
import scipy.io as sio

from pgcomm.errors import ConfigError, DataError
from pgcomm.io.logs import Log, column_mapping, load_column_mapping, read_log, read_logs, write_log

N = 50
TS = 1e-3


def _columns(n=N, seed=0):
    """A log with coil set 1 as currents and coil set 2 as drive inputs (plus both for 2)."""
    rng = np.random.default_rng(seed)
    cols = {
        "t": np.arange(n) * TS,
        "y": rng.uniform(-0.1, 0.1, n),
        "Fy": rng.standard_normal(n) * 10.0 ** rng.integers(-200, 200, n),  # wide exponent range
        "Fx": rng.standard_normal(n),
        "Tz": rng.standard_normal(n) * 1e-3,
        "ia_1": rng.standard_normal(n),
        "ib_1": rng.standard_normal(n),
        "Fy_ref_2": rng.standard_normal(n) * 100,
        "delta_2": rng.uniform(-np.pi, np.pi, n),
        "ia_2": rng.standard_normal(n),
        "ib_2": rng.standard_normal(n),
        "r": np.linspace(0, 0.1, n),
        "experiment": np.repeat([1.0, 2.0], n // 2),
    }
    cols["Fx"][3] = -0.0
    cols["Fx"][4] = 5e-324  # subnormal
    return cols


def _bitwise_equal(a, b):
    return a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


def _write_csv(path, cols):
    names = list(cols)
    lines = [",".join(names)] + [",".join(repr(float(cols[k][i])) for k in names) for i in range(len(cols[names[0]]))]
    path.write_text("\n".join(lines) + "\n")
    return path


# ----------------------------------------------------------------------------- round trips


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_round_trip_bit_identical(tmp_path, suffix):
    log = Log(_columns(), TS, "sim")
    path = tmp_path / f"log{suffix}"
    write_log(path, log)
    back = read_log(path)
    assert list(back.columns) == list(log.columns)
    for k in log.columns:
        assert _bitwise_equal(back.columns[k], log.columns[k]), k
    assert back.sample_time == pytest.approx(TS, rel=1e-12)
    if suffix == ".parquet":
        assert back.sample_time == TS  # kept exactly in the metadata
    assert back.source == str(path)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


def test_write_adds_t_and_refuses_unknown_suffix(tmp_path):
    cols = _columns()
    del cols["t"]
    write_log(tmp_path / "log.csv", Log(cols, 2e-3))
    assert (tmp_path / "log.csv").read_text().startswith("t,y,Fy,")
    back = read_log(tmp_path / "log.csv")
    np.testing.assert_allclose(back["t"], np.arange(N) * 2e-3, rtol=1e-15)
    with pytest.raises(ConfigError, match=r"log.xlsx: cannot write logs as '.xlsx' \(supported: .csv, .parquet\)"):
        write_log(tmp_path / "log.xlsx", back)


def test_log_helpers():
    log = Log(_columns(), TS)
    assert log.n_coil_sets == 2 and len(log) == N
    cur = log.currents()
    assert cur.shape == (N, 2, 2)
    np.testing.assert_array_equal(cur[:, 1, 0], log["ia_2"])
    np.testing.assert_array_equal(cur[:, 0, 1], log["ib_1"])
    assert log.drive_inputs() is None  # coil set 1 has no drive inputs
    assert log.force().shape == (N, 3) and log.desired_force() is None
    cols = _columns()
    del cols["ia_1"], cols["ib_1"], cols["ia_2"], cols["ib_2"]
    cols["Fy_ref_1"], cols["delta_1"] = cols["Fy_ref_2"] * 2, cols["delta_2"] / 2
    fy, delta = Log(cols, TS).drive_inputs()
    assert fy.shape == delta.shape == (N, 2)
    np.testing.assert_array_equal(delta[:, 0], cols["delta_1"])
    with pytest.raises(DataError, match=r"x: column 'Fx' has 3 rows but 't' has 50"):
        Log({"t": np.zeros(N), "Fx": np.zeros(3)}, TS, "x")


def test_mat_v5_variables_and_struct(tmp_path):
    cols = _columns()
    sio.savemat(tmp_path / "vars.mat", {k: v[:, None] for k, v in cols.items()} | {"note": "hello", "M": np.eye(3)})
    log = read_log(tmp_path / "vars.mat")
    assert set(log.columns) == set(cols)
    for k in cols:
        np.testing.assert_array_equal(log[k], cols[k])
    sio.savemat(tmp_path / "struct.mat", {"data": cols, "other": 1.0})
    np.testing.assert_array_equal(read_log(tmp_path / "struct.mat")["Tz"], cols["Tz"])  # the only struct
    sio.savemat(tmp_path / "two.mat", {"a": cols, "b": {"x": 1.0}})
    np.testing.assert_array_equal(read_log(tmp_path / "two.mat", columns={"options": {"group": "a"}})["y"], cols["y"])


def test_mat_v73_and_hdf5(tmp_path):
    cols = _columns()
    # MATLAB v7.3: HDF5 with a 512-byte user block, column vectors stored transposed (1 x N)
    with h5py.File(tmp_path / "v73.mat", "w", userblock_size=512) as f:
        for k, v in cols.items():
            f[k] = v[None, :]
    log = read_log(tmp_path / "v73.mat")
    for k in cols:
        np.testing.assert_array_equal(log[k], cols[k])
    with h5py.File(tmp_path / "log.h5", "w") as f:
        g = f.create_group("run1/data")
        for k, v in cols.items():
            g[k] = v
        f["junk"] = np.zeros((3, 3))
    log = read_log(tmp_path / "log.h5", columns={"options": {"group": "run1/data"}})
    for k in cols:
        np.testing.assert_array_equal(log[k], cols[k])
    with pytest.raises(DataError, match=r"log.h5: group 'run2' \(options.group\) missing; found junk, run1 \(closest match: 'run1'\)"):
        read_log(tmp_path / "log.h5", columns={"options": {"group": "run2"}})


# ----------------------------------------------------------------------------- column mapping


MAPPING = """
[columns]
t = "time_ms"
y = "pos_mm"
Fy = "force_y"
Fx = "force_x"
Tz = "torque"
ia_1 = "Ia1"
ib_1 = "Ib1"
Fy_ref_2 = "F2"
delta_2 = "d2"
[units]
t = "ms"
y = "mm"
Fy = "mN"
Tz = "mN*m"
ia_1 = "mA"
delta_2 = "deg"
"""


def test_mapping_converts_units(tmp_path):
    (tmp_path / "map.toml").write_text(MAPPING)
    n = 20
    user = {
        "time_ms": np.arange(n) * 0.5,
        "pos_mm": np.linspace(-50, 50, n),
        "force_y": np.full(n, 1500.0),
        "force_x": np.full(n, 2.0),
        "torque": np.full(n, 30.0),
        "Ia1": np.full(n, 250.0),
        "Ib1": np.full(n, -1.0),
        "F2": np.full(n, 3.0),
        "d2": np.full(n, 90.0),
        "comment": np.zeros(n),
    }
    for path in (_write_csv(tmp_path / "user.csv", user), tmp_path / "user.mat"):
        if path.suffix == ".mat":
            sio.savemat(path, user)
        log = read_log(path, columns=tmp_path / "map.toml")
        np.testing.assert_allclose(log["t"], np.arange(n) * 5e-4, rtol=1e-14)
        assert log.sample_time == pytest.approx(5e-4)
        np.testing.assert_allclose(log["y"], np.linspace(-0.05, 0.05, n), rtol=1e-14, atol=1e-17)
        np.testing.assert_allclose(log["Fy"], 1.5)
        np.testing.assert_array_equal(log["Fx"], 2.0)
        np.testing.assert_allclose(log["Tz"], 0.03)
        np.testing.assert_allclose(log["ia_1"], 0.25)
        np.testing.assert_allclose(log["delta_2"], np.pi / 2)
        assert "pos_mm" not in log.columns
        assert log.n_coil_sets == 2


def test_mapping_csv_with_text_column_and_sample_time_option(tmp_path):
    p = tmp_path / "u.csv"
    p.write_text("when,pos,Fy,Fx,Tz,ia_1,ib_1\n" + "".join(f"2024-01-01 10:00:0{i},{i},1,2,3,4,5\n" for i in range(5)))
    log = read_log(p, columns={"columns": {"y": "pos"}, "options": {"sample_time": 0.002}})
    np.testing.assert_array_equal(log["t"], np.arange(5) * 0.002)
    assert list(log.columns)[:2] == ["t", "y"] and "when" not in log.columns
    log = read_log(p, sample_time=0.004, columns={"columns": {"y": "pos"}, "options": {"sample_time": 0.002}})
    assert log.sample_time == 0.004  # the argument wins over the mapping


def test_mapping_unknown_unit(tmp_path):
    (tmp_path / "map.toml").write_text('[units]\ny = "inch"\n')
    with pytest.raises(DataError, match=r"map.toml: \[units\] y = 'inch' is not a known length unit \(known: m, mm, um, µm, μm, nm\)"):
        load_column_mapping(tmp_path / "map.toml")


def test_mapping_unknown_name_and_keys():
    with pytest.raises(ConfigError, match=r"m.toml: \[columns\] 'Fyy' is not a log column \(closest match: 'Fy'\)"):
        column_mapping({"columns": {"Fyy": "a"}}, "m.toml")
    with pytest.raises(ConfigError, match=r"\[columns\] 'ia1' is not a log column \(closest match: 'ia_1'\)"):
        column_mapping({"columns": {"ia1": "a"}}, "m.toml")
    with pytest.raises(ConfigError, match=r"m.toml: unknown table \[unit\] \(closest valid table: 'units'\)"):
        column_mapping({"unit": {}}, "m.toml")
    with pytest.raises(ConfigError, match=r"unknown key 'sampletime' in table \[options\] \(closest valid key: 'sample_time'\)"):
        column_mapping({"options": {"sampletime": 1e-3}}, "m.toml")
    with pytest.raises(ConfigError, match=r"\[columns\] y and r are both mapped to 'pos'"):
        column_mapping({"columns": {"y": "pos", "r": "pos"}}, "m.toml")
    with pytest.raises(ConfigError, match=r"\[units\] experiment = 'm': column 'experiment' has no unit"):
        column_mapping({"units": {"experiment": "m"}}, "m.toml")


def test_mapped_column_missing(tmp_path):
    p = _write_csv(tmp_path / "log.csv", _columns())
    with pytest.raises(DataError, match=r"log.csv: column 'Fyy' \(mapped to Fy in column mapping\) missing; found t, y, .* \(closest match: 'Fy'\)$"):
        read_log(p, columns={"columns": {"Fy": "Fyy"}})


# ----------------------------------------------------------------------------- bad input


def test_missing_column_closest_match(tmp_path):
    cols = _columns()
    cols["Fz"] = cols.pop("Fy")
    p = _write_csv(tmp_path / "log.csv", cols)
    with pytest.raises(DataError, match=r"log.csv: column 'Fy' missing \(a log has all of the force columns Fy, Fx, Tz, "
                                        r"or none of them without a force sensor\); found t, y, Fx, Tz, .* "
                                        r"\(closest match: 'Fz'\)$"):
        read_log(p)


def test_force_columns_all_or_none(tmp_path):
    """A log without Fy, Fx, Tz is a log of a rig without a force sensor; some of them is an error."""
    cols = _columns()
    for c in ("Fy", "Fx", "Tz"):
        del cols[c]
    log = read_log(_write_csv(tmp_path / "noforce.csv", cols))
    assert not log.has_force
    with pytest.raises(DataError, match=r"noforce.csv: no measured force \(column\(s\) Fy, Fx, Tz missing\)"):
        log.force()
    cols = _columns()
    del cols["Fx"], cols["Tz"]
    with pytest.raises(DataError, match=r"fyonly.csv: columns 'Fx', 'Tz' missing \(a log has all of the force columns"):
        read_log(_write_csv(tmp_path / "fyonly.csv", cols))
    assert read_log(_write_csv(tmp_path / "all.csv", _columns())).has_force


def test_non_numeric_cell_names_row(tmp_path):
    cols = _columns()
    p = _write_csv(tmp_path / "log.csv", cols)
    lines = p.read_text().splitlines()
    fields = lines[17].split(",")
    fields[1] = "abc"  # column y of data row 17
    lines[17] = ",".join(fields)
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"log.csv row 17 column 'y': 'abc' is not a number \(line 18\)$"):
        read_log(p)


def test_empty_cell(tmp_path):
    p = tmp_path / "log.csv"
    p.write_text("t,y,Fy,Fx,Tz,ia_1,ib_1\n0,0,0,0,0,0,0\n0.001,0,,0,0,0,0\n")
    with pytest.raises(DataError, match=r"log.csv row 2 column 'Fy' is empty, expected a number"):
        read_log(p)


def test_mixed_sample_times(tmp_path):
    cols = _columns()
    cols["t"] = np.concatenate([np.arange(30) * 1e-3, 0.029 + np.arange(1, 21) * 2e-3])
    p = _write_csv(tmp_path / "log.csv", cols)
    with pytest.raises(DataError, match=r"log.csv row 31 column 't': time step changes from 0.001 s to 0.002 s \(t must be uniformly sampled"):
        read_log(p)


def test_time_stored_as_float32_is_taken_as_its_uniform_grid(tmp_path):
    """A 1 kHz time column stored as float32 (300 s: its values are up to 15 µs, 1.5 % of a step, off the grid)
    is uniform up to its own rounding: read as the exact grid, with a note; the sample time is the grid's to
    1e-9 of itself. A sample 10 % of a step off (a jittering sampler) is still refused."""
    n = 300_001
    t32 = (np.arange(n) * 1e-3).astype(np.float32).astype(float)
    assert np.max(np.abs(t32 - np.arange(n) * 1e-3)) > 0.01e-3  # the rounding this test is about
    cols = {"t": t32, "theta": np.linspace(0.0, 1.0, n), "iq_1": np.zeros(n)}
    p = tmp_path / "f32.parquet"
    write_log(p, Log(cols, 1e-3))
    lg = read_log(p, required=("theta",))
    assert lg.sample_time == pytest.approx(1e-3, rel=1e-9)
    np.testing.assert_allclose(lg.columns["t"], np.arange(n) * lg.sample_time, rtol=0, atol=1e-12)
    assert any("off a uniform grid" in note for note in lg.notes)
    t = np.arange(200) * 1e-3
    t[100] += 0.1e-3
    p = _write_csv(tmp_path / "jitter.csv", {"t": t, "theta": np.zeros(200), "iq_1": np.zeros(200)})
    with pytest.raises(DataError, match=r"jitter.csv row 101 column 't': time step changes from 0.001 s to 0.0011 s"):
        read_log(p, required=("theta",))


def test_dropped_samples_are_gaps_when_asked_and_refused_otherwise(tmp_path):
    """A 1 kHz rotary log with samples dropped in two places (3, then 1), its angle wrapped to one revolution and
    turning at about 40 rad/s: refused by default (the same line as any change of the sample time); with
    ``gaps=True`` read with its gaps (the rows after which samples are missing), ``t`` on its 1 ms grid, the angle
    unwrapped across the gaps (the motion over a gap is that of its time), and a note."""
    n = 3000
    keep = np.setdiff1d(np.arange(n), [1000, 1001, 1002, 2000])
    t = keep * 1e-3
    w = 40.0 + 5.0 * np.sin(2 * np.pi * t)
    theta = 40.0 * t - 5.0 / (2 * np.pi) * np.cos(2 * np.pi * t)
    cols = {"t": t, "theta": np.mod(theta, 2 * np.pi), "velocity": w, "iq_1": np.zeros(t.size)}
    p = _write_csv(tmp_path / "gaps.csv", cols)
    with pytest.raises(DataError, match=r"gaps.csv row 1001 column 't': time step changes from 0.001 s to 0.004 s"):
        read_log(p, required=("theta",))
    lg = read_log(p, required=("theta",), gaps=True)
    assert lg.gaps == (999, 1996) and lg.segments() == [(0, 1000), (1000, 1997), (1997, t.size)]
    assert lg.sample_time == pytest.approx(1e-3, rel=1e-9)
    np.testing.assert_allclose(lg.columns["t"], keep * lg.sample_time, rtol=0, atol=1e-12)
    np.testing.assert_allclose(lg.columns["theta"], theta - theta[0] + lg.columns["theta"][0], rtol=0, atol=1e-9)
    assert any("4 dropped sample(s) in 2 gap(s), the first after row 1000" in note for note in lg.notes)
    # the stretches between the gaps are uniform
    for a, b in lg.segments():
        assert np.allclose(np.diff(lg.columns["t"][a:b]), lg.sample_time, rtol=1e-9, atol=0)


def test_time_not_increasing(tmp_path):
    cols = _columns()
    cols["t"][10] = cols["t"][9]
    with pytest.raises(DataError, match=r"log.parquet row 11 column 't': t = 0.009.* s is not after t = 0.009.* s of row 10"):
        write_log(tmp_path / "log.parquet", Log(cols, TS))
        read_log(tmp_path / "log.parquet")


def test_nan_and_inf_name_row_and_column(tmp_path):
    cols = _columns()
    cols["Tz"][20] = np.nan
    cols["ib_1"][7] = np.inf
    write_log(tmp_path / "log.csv", Log(cols, TS))
    with pytest.raises(DataError, match=r"log.csv row 8 column 'ib_1': inf is not a finite number"):
        read_log(tmp_path / "log.csv")
    cols["ib_1"][7] = 0.0
    write_log(tmp_path / "log.parquet", Log(cols, TS))
    with pytest.raises(DataError, match=r"log.parquet row 21 column 'Tz': nan is not a finite number"):
        read_log(tmp_path / "log.parquet")


def test_coil_set_with_only_ia(tmp_path):
    cols = _columns()
    del cols["ib_2"], cols["Fy_ref_2"], cols["delta_2"]
    p = _write_csv(tmp_path / "log.csv", cols)
    with pytest.raises(DataError, match=r"log.csv: column 'ib_2' missing \(coil set 2 has ia_2 but no ib_2; give both currents ia_2, ib_2 or both drive inputs Fy_ref_2, delta_2\)"):
        read_log(p)


def test_coil_set_hole_and_none(tmp_path):
    cols = _columns()
    for k in ("ia_1", "ib_1"):
        del cols[k]
    with pytest.raises(DataError, match=r"log.csv: no columns for coil set 1 but coil sets up to 2 are present"):
        read_log(_write_csv(tmp_path / "log.csv", cols))
    cols = {k: v for k, v in _columns().items() if k in ("t", "y", "Fy", "Fx", "Tz")}
    cols["Ia1"] = cols["y"]
    with pytest.raises(DataError, match=r"log2.csv: no columns for coil set 1 \(expected ia_1, ib_1 or Fy_ref_1, delta_1\); found .* \(closest match: 'Ia1'\)"):
        read_log(_write_csv(tmp_path / "log2.csv", cols))
    assert read_log(tmp_path / "log2.csv", min_coil_sets=0).n_coil_sets == 0


def test_mat_without_named_variables(tmp_path):
    sio.savemat(tmp_path / "log.mat", {"pos": np.zeros(5), "force": np.zeros(5), "M": np.eye(2)})
    with pytest.raises(DataError, match=r"log.mat: variable 'y' missing; found pos, force, M"):
        read_log(tmp_path / "log.mat")
    with pytest.raises(DataError, match=r"log.mat: variable 'position' \(mapped to y in m.toml\) missing; found pos, force, M \(closest match: 'pos'\)"):
        read_log(tmp_path / "log.mat", columns=column_mapping({"columns": {"y": "position"}}, "m.toml"))
    with pytest.raises(DataError, match=r"log.mat: variable 'M' has shape \(2, 2\), expected a vector"):
        read_log(tmp_path / "log.mat", columns={"columns": {"y": "M"}})


def test_no_time_needs_sample_time(tmp_path):
    cols = _columns()
    del cols["t"]
    p = _write_csv(tmp_path / "log.csv", cols)
    with pytest.raises(DataError, match=r"log.csv: no column 't' and no sample time given"):
        read_log(p)
    log = read_log(p, sample_time=0.002)
    assert list(log.columns)[0] == "t" and log.sample_time == 0.002
    np.testing.assert_array_equal(log["t"], np.arange(N) * 0.002)


def test_sample_time_contradicts_t(tmp_path):
    p = _write_csv(tmp_path / "log.csv", _columns())
    with pytest.raises(DataError, match=r"log.csv: sample time 0.002 s given but t has steps of 0.001 s"):
        read_log(p, sample_time=0.002)


def test_file_level_errors(tmp_path):
    with pytest.raises(DataError, match=r"none.csv: file not found"):
        read_log(tmp_path / "none.csv")
    (tmp_path / "log.txt").write_text("x")
    with pytest.raises(DataError, match=r"log.txt: unsupported log format '.txt' \(supported: .csv, .parquet, .mat, .h5, .hdf5\)"):
        read_log(tmp_path / "log.txt")
    (tmp_path / "short.csv").write_text("t,y,Fy,Fx,Tz,ia_1,ib_1\n0,0,0,0,0,0,0\n")
    with pytest.raises(DataError, match=r"short.csv: 1 data rows, a log needs at least 2"):
        read_log(tmp_path / "short.csv")
    (tmp_path / "fake.parquet").write_text("not parquet")
    with pytest.raises(DataError, match=r"fake.parquet: not a readable Parquet file"):
        read_log(tmp_path / "fake.parquet")


def test_read_logs_globs(tmp_path):
    for name, seed in (("b.csv", 1), ("a.csv", 2), ("c.parquet", 3)):
        write_log(tmp_path / name, Log(_columns(seed=seed), TS))
    logs = read_logs([str(tmp_path / "*.csv"), str(tmp_path / "c.parquet"), str(tmp_path / "a.csv")])
    assert [l.source.rsplit("/", 1)[-1] for l in logs] == ["a.csv", "b.csv", "c.parquet"]
    np.testing.assert_array_equal(logs[0]["y"], _columns(seed=2)["y"])
    with pytest.raises(DataError, match=r"\*.hdf5: no file matches"):
        read_logs([str(tmp_path / "*.csv"), str(tmp_path / "*.hdf5")])
    with pytest.raises(DataError, match=r"d.csv: file not found"):
        read_logs([str(tmp_path / "d.csv")])


def test_large_csv_single_copy(tmp_path):
    """A few hundred thousand rows go through pyarrow (multi-threaded) and read back exactly."""
    n = 200_000
    cols = {"t": np.arange(n) * TS, "y": np.sin(np.arange(n) * 1e-3) * 0.1, "Fy": np.cos(np.arange(n) * 1e-2),
            "Fx": np.zeros(n), "Tz": np.ones(n), "ia_1": np.arange(n) / n, "ib_1": -np.arange(n) / n}
    write_log(tmp_path / "big.csv", Log(cols, TS))
    log = read_log(tmp_path / "big.csv")
    for k in cols:
        assert _bitwise_equal(log[k], cols[k]), k


def test_host_stamps_are_resampled_for_a_reader_that_needs_a_uniform_grid(tmp_path):
    """A linear log stamped by a host (steps 0.4-1.9 ms around 1 ms) whose columns are straight lines in time: with
    ``resample=True`` every column is on a uniform grid of the median step, equal to the line there (linear
    interpolation is exact on a line, to rounding) and a data set's label held, with a note; a step over ``GAP_STEPS`` median steps is refused
    with its row; without the flag the log is refused as before."""
    from pgcomm.io.logs import GAP_STEPS

    rng = np.random.default_rng(7)
    steps = 1e-3 * rng.uniform(0.4, 1.9, 2000)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    cols = {"t": t, "y": 0.01 + 0.02 * t, "Fy": -3.0 + 40.0 * t, "Fx": 0.5 * t, "Tz": np.zeros(t.size),
            "ia_1": 1.0 + 2.0 * t, "ib_1": -1.0 + 0.5 * t, "experiment": np.where(t < 1.0, 1.0, 2.0)}
    p = _write_csv(tmp_path / "host.csv", cols)
    with pytest.raises(DataError, match=r"host.csv row \d+ column 't': time step changes"):
        read_log(p)
    lg = read_log(p, resample=True)
    step = float(np.median(steps))
    assert lg.sample_time == pytest.approx(step, rel=1e-12)
    tg = lg.columns["t"]
    np.testing.assert_allclose(np.diff(tg), step, rtol=1e-9)
    assert tg[0] == t[0] and tg[-1] <= t[-1] < tg[-1] + step
    for name in ("y", "Fy", "Fx", "ia_1", "ib_1"):
        c0 = cols[name][0]
        slope = (cols[name][-1] - c0) / t[-1]
        np.testing.assert_allclose(lg.columns[name], c0 + slope * tg, rtol=0, atol=1e-12 * (abs(c0) + abs(slope)))
    # a label is held, not interpolated: the one in force at each grid point
    np.testing.assert_array_equal(lg.columns["experiment"], np.where(tg < t[np.searchsorted(t, 1.0)], 1.0, 2.0))
    assert any("resampled to a uniform grid" in note for note in lg.notes)
    t_gap = t.copy()
    t_gap[1001:] += (GAP_STEPS + 1) * step
    p = _write_csv(tmp_path / "gap.csv", {**cols, "t": t_gap})
    with pytest.raises(DataError, match=r"gap.csv row 1002 column .t.: a gap of .* ms after t = .* \(split the log there\)"):
        read_log(p, resample=True)
