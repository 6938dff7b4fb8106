"""Tests of pgcomm.trajectory: jerk-limited profiles, sequences, file references."""

from __future__ import annotations

import math

import h5py
import numpy as np
import pytest
import scipy.io

from pgcomm.errors import ConfigError, DataError
from pgcomm.io.references import read_reference
from pgcomm.trajectory import (
    INITIAL_DWELL,
    Reference,
    data_generation_reference,
    point_to_point,
    sequence,
    single_velocity_reference,
    third_order_profile,
)

#: Relative slack on the limits (the brief: within 1e-9 relative).
LIMIT_RTOL = 1e-9

# (q0, q1, v_max, a_max, j_max, which limits are reached: "va", "a", "v", "")
CASES = {
    "paper_fast_all_limits": (-0.1, 0.1, 0.15, 1.0, 1000.0, "va"),
    "paper_slow_all_limits": (-0.1, 0.1, 0.025, 1.0, 1000.0, "va"),
    "negative_direction": (0.1, -0.1, 0.075, 1.0, 1000.0, "va"),
    "no_cruise_a_reached": (0.0, 0.01, 0.5, 1.0, 100.0, "a"),
    "no_const_acc_v_reached": (0.0, 0.5, 0.05, 1.0, 10.0, "v"),  # v*j < a^2
    "neither_limit": (0.0, 1e-4, 0.5, 1.0, 100.0, ""),
    "neither_limit_negative": (2e-4, 1e-4, 0.5, 1.0, 100.0, ""),
}


def _limits_ok(x, limit):
    return np.max(np.abs(x)) <= limit * (1.0 + LIMIT_RTOL)


@pytest.mark.parametrize("name", list(CASES))
def test_continuous_profile_respects_limits_and_ends_at_target(name):
    q0, q1, vm, am, jm, reached = CASES[name]
    prof = third_order_profile(q0, q1, vm, am, jm)
    big_t = prof.duration
    # Fine grid plus the switching times, where |a| and |v| peak.
    t = np.union1d(np.linspace(0.0, big_t, 100_001), prof.switching_times)
    r, v, a, j = prof.evaluate(t)
    assert _limits_ok(v, vm) and _limits_ok(a, am) and _limits_ok(j, jm)
    # The limits that should be reached are reached, the others are not.
    assert math.isclose(np.max(np.abs(v)), vm, rel_tol=1e-9) == ("v" in reached)
    assert math.isclose(np.max(np.abs(a)), am, rel_tol=1e-9) == ("a" in reached)
    assert (prof.t_v > 0) == ("v" in reached)
    assert np.max(np.abs(v)) == pytest.approx(prof.v_peak, rel=1e-9)
    assert np.max(np.abs(a)) == pytest.approx(prof.a_peak, rel=1e-9)
    assert (prof.t_a > 0) == ("a" in reached)
    # Monotone towards the target, never overshooting.
    s = np.sign(q1 - q0)
    assert np.all(s * v >= 0.0)
    assert np.all(s * np.diff(r) >= -1e-15)
    # Exact landing with zero velocity and acceleration.
    rT, vT, aT, jT = prof.evaluate(np.array([big_t, big_t + 1.0]))
    assert np.all(rT == q1) and np.all(vT == 0.0) and np.all(aT == 0.0) and np.all(jT == 0.0)
    r0, v0, a0, _ = prof.evaluate(np.array([-1.0, 0.0]))
    assert np.all(r0 == q0) and np.all(v0 == 0.0) and np.all(a0 == 0.0)


@pytest.mark.parametrize("name", list(CASES))
def test_sampled_profile_respects_limits_and_ends_exactly(name):
    q0, q1, vm, am, jm, _ = CASES[name]
    ts = 1e-3
    ref = point_to_point(q0, q1, vm, am, jm, ts)
    big_t = third_order_profile(q0, q1, vm, am, jm).duration
    assert _limits_ok(ref.v, vm) and _limits_ok(ref.a, am) and _limits_ok(ref.j, jm)
    assert ref.r[0] == q0 and ref.r[-1] == q1
    assert ref.v[0] == 0.0 and ref.a[0] == 0.0
    assert ref.v[-1] == 0.0 and ref.a[-1] == 0.0 and ref.j[-1] == 0.0
    # The last sample is the first one at or after the end of the move.
    assert ref.t[-1] >= big_t - 1e-9 * ts and ref.t[-2] < big_t
    np.testing.assert_array_equal(ref.t, np.arange(len(ref)) * ts)
    assert ref.sample_time == ts


@pytest.mark.parametrize("v_max", [0.025, 0.075, 0.15])
def test_total_time_matches_closed_form_when_all_limits_reached(v_max):
    d, am, jm = 0.2, 1.0, 1000.0
    prof = third_order_profile(-0.1, 0.1, v_max, am, jm)
    assert math.isclose(prof.duration, d / v_max + v_max / am + am / jm, rel_tol=1e-12)
    assert prof.v_peak == pytest.approx(v_max, rel=1e-12)
    assert prof.t_v > 0.0 and prof.t_a > 0.0


def test_profile_is_symmetric_in_time_and_direction():
    q0, q1, vm, am, jm, _ = CASES["no_cruise_a_reached"]
    prof = third_order_profile(q0, q1, vm, am, jm)
    big_t = prof.duration
    t = np.linspace(0.0, big_t, 20_001)
    r, v, a, _ = prof.evaluate(t)
    rb, vb, ab, _ = prof.evaluate(big_t - t)
    np.testing.assert_allclose(vb, v, rtol=0, atol=1e-12 * vm)
    np.testing.assert_allclose(ab, -a, rtol=0, atol=1e-9 * am)
    np.testing.assert_allclose(r - q0, q1 - rb, rtol=0, atol=1e-15)
    assert prof.evaluate(big_t / 2)[0] == pytest.approx((q0 + q1) / 2, abs=1e-15)
    # The reverse move is the point reflection of the forward one.
    rev = third_order_profile(q1, q0, vm, am, jm)
    assert rev.duration == big_t
    rr, vr, ar, _ = rev.evaluate(t)
    np.testing.assert_allclose(rr, q0 + q1 - r, rtol=0, atol=1e-15)
    np.testing.assert_allclose(vr, -v, rtol=0, atol=1e-15)
    np.testing.assert_allclose(ar, -a, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", list(CASES))
def test_position_velocity_acceleration_continuous_at_switching_times(name):
    q0, q1, vm, am, jm, _ = CASES[name]
    prof = third_order_profile(q0, q1, vm, am, jm)
    knots = np.append(prof.switching_times, prof.duration / 2)
    eps = 1e-10 * prof.duration
    left = prof.evaluate(knots - eps)
    right = prof.evaluate(knots + eps)
    # A jump would be O(1) of the limit; a smooth profile moves O(eps * rate).
    for lo, hi, rate in zip(left[:3], right[:3], (vm, am, jm)):
        np.testing.assert_allclose(lo, hi, rtol=0, atol=4 * eps * rate)
    # The jerk is right-continuous: at a switching time it already has the
    # value of the segment that starts there (0 from the end on).
    np.testing.assert_array_equal(prof.evaluate(knots)[3], right[3])
    # ... also when rounding puts a sample a hair before the switching time.
    np.testing.assert_array_equal(prof.evaluate(knots - 1e-14 * prof.duration)[3], right[3])


def test_sampled_jerk_pulses_on_grid_aligned_switching_times():
    # Paper slow move: switching times 0, 1, 25, 26, 8000, 8001, 8025, 8026 ms,
    # all on the 1 ms grid; each 1 ms jerk pulse is exactly one sample long.
    ref = point_to_point(-0.1, 0.1, 0.025, 1.0, 1000.0, 1e-3)
    assert len(ref) == 8027
    nz = np.flatnonzero(ref.j)
    np.testing.assert_array_equal(nz, [0, 25, 8000, 8025])
    np.testing.assert_array_equal(ref.j[nz], [1000.0, -1000.0, -1000.0, 1000.0])


def test_analytic_profile_equals_numerically_integrated_jerk():
    q0, q1, vm, am, jm = 0.0, 0.01, 0.05, 1.0, 100.0  # all three limits reached
    prof = third_order_profile(q0, q1, vm, am, jm)
    assert prof.t_v > 0 and prof.t_a > 0
    dt = 1e-5
    t = np.arange(0.0, prof.duration + 10 * dt, dt)
    r, v, a, j = prof.evaluate(t)

    def cumtrapz(y):
        return np.concatenate([[0.0], np.cumsum((y[1:] + y[:-1]) * dt / 2)])

    # j is piecewise constant: each of its 8 jumps costs at most jm*dt in a.
    np.testing.assert_allclose(cumtrapz(j), a, rtol=0, atol=8 * jm * dt)
    # a and v are continuous and piecewise polynomial: trapezoid error ~ T*dt^2*jm.
    np.testing.assert_allclose(cumtrapz(a), v, rtol=0, atol=prof.duration * dt**2 * jm)
    np.testing.assert_allclose(q0 + cumtrapz(v), r, rtol=0, atol=prof.duration * dt**2 * am)


@pytest.mark.parametrize("d", [1e-9, 1e-6, 1e-4, 2e-3, 5e-3, 0.02])
def test_short_moves_stay_within_limits_and_land_on_target(d):
    vm, am, jm = 0.15, 1.0, 1000.0
    for q0, q1 in ((0.0, d), (0.05, 0.05 - d)):
        prof = third_order_profile(q0, q1, vm, am, jm)
        assert prof.t_v == 0.0  # all these are too short to reach v_max
        assert prof.v_peak < vm
        if d < 2 * am**3 / jm**2:
            assert prof.t_a == 0.0 and prof.a_peak < am
        ref = point_to_point(q0, q1, vm, am, jm, 1e-4)
        assert ref.r[-1] == q1 and ref.v[-1] == 0.0 and ref.a[-1] == 0.0
        assert _limits_ok(ref.v, vm) and _limits_ok(ref.a, am) and _limits_ok(ref.j, jm)
        r, v, a, _ = prof.evaluate(np.linspace(0, prof.duration, 5001))
        assert _limits_ok(v, vm) and _limits_ok(a, am)
        assert np.min(r) >= min(q0, q1) - 1e-18 and np.max(r) <= max(q0, q1) + 1e-18


def test_zero_distance_move_is_one_sample_at_rest():
    ref = point_to_point(0.03, 0.03, 0.1, 1.0, 1000.0, 1e-3)
    assert len(ref) == 1
    assert ref.r[0] == 0.03 and ref.v[0] == 0.0 and ref.a[0] == 0.0 and ref.j[0] == 0.0
    assert third_order_profile(0.03, 0.03, 0.1, 1.0, 1000.0).duration == 0.0


def test_sampled_velocity_equals_numerical_derivative_of_position():
    ts, jm = 1e-3, 1000.0
    ref = point_to_point(-0.1, 0.1, 0.15, 1.0, jm, ts)
    # Central difference error of r' is at most ts^2/6 * max|r'''| = ts^2*j_max/6
    # (1.7e-4 m/s here). A one-sample lag would give a_max*ts = 1e-3 m/s.
    tol = ts**2 * jm / 6 * (1 + 1e-6) + 1e-12
    v_num = (ref.r[2:] - ref.r[:-2]) / (2 * ts)
    np.testing.assert_allclose(v_num, ref.v[1:-1], rtol=0, atol=tol)
    a_num = (ref.v[2:] - ref.v[:-2]) / (2 * ts)
    # a is piecewise quadratic with |a''| = 0 between jumps of j; at a jump the
    # central difference of v errs by at most j_max*ts/4.
    np.testing.assert_allclose(a_num, ref.a[1:-1], rtol=0, atol=jm * ts / 4 + 1e-12)


def test_data_generation_reference_matches_paper():
    ts = 1e-3
    ref = data_generation_reference(sample_time=ts)
    assert ref.r.min() == -0.1 and ref.r.max() == 0.1
    assert ref.r[0] == -0.1 and ref.r[-1] == -0.1
    # Initial dwell at rest.
    n0 = round(INITIAL_DWELL / ts)
    assert np.all(ref.r[: n0 + 1] == -0.1) and np.all(ref.v[: n0 + 1] == 0.0)
    assert ref.v[n0 + 1] > 0.0
    # Split into moves at rest: six moves, peak speeds 0.025, 0.025, 0.075, ...
    moving = ref.v != 0.0
    starts = np.flatnonzero(np.diff(moving.astype(int)) == 1) + 1
    ends = np.flatnonzero(np.diff(moving.astype(int)) == -1) + 1
    assert len(starts) == len(ends) == 6
    peaks = [np.max(np.abs(ref.v[s:e])) for s, e in zip(starts, ends)]
    np.testing.assert_allclose(peaks, [0.025, 0.025, 0.075, 0.075, 0.15, 0.15], rtol=1e-12)
    directions = [np.sign(ref.v[s]) for s in starts]
    assert directions == [1, -1, 1, -1, 1, -1]
    # Dwell of 0.5 s between moves (at least; the last move sample may land early).
    gaps = (starts[1:] - ends[:-1]) * ts
    assert np.all(gaps >= 0.5 - 1e-9) and np.all(gaps <= 0.5 + 2 * ts)
    assert _limits_ok(ref.a, 1.0) and _limits_ok(ref.j, 1000.0)
    assert np.max(np.abs(ref.a)) == pytest.approx(1.0, rel=1e-12)
    # Stitching moves and dwells keeps v the derivative of r (bound as above).
    v_num = (ref.r[2:] - ref.r[:-2]) / (2 * ts)
    np.testing.assert_allclose(v_num, ref.v[1:-1], rtol=0, atol=ts**2 * 1000.0 / 6 * (1 + 1e-6) + 1e-12)


def test_single_velocity_reference_is_one_back_and_forth():
    ref = single_velocity_reference(0.025)
    assert ref.r.min() == -0.1 and ref.r.max() == 0.1
    assert np.max(np.abs(ref.v)) == pytest.approx(0.025, rel=1e-12)
    assert np.count_nonzero(np.diff((ref.v != 0).astype(int)) == 1) == 2
    total = 2 * third_order_profile(-0.1, 0.1, 0.025, 1.0, 1000.0).duration + 2 * 0.5 + INITIAL_DWELL
    assert ref.duration == pytest.approx(total, abs=3e-3)


def test_sequence_start_dwell_list_and_continuity():
    ts = 1e-3
    moves = [(0.05, 0.1, 1.0, 1000.0), (0.02, 0.05, 0.5, 100.0)]
    ref = sequence(moves, ts, dwell=[0.2, 0.0], start=0.01)
    assert ref.r[0] == 0.01 and ref.r[-1] == 0.02
    first = point_to_point(0.01, 0.05, 0.1, 1.0, 1000.0, ts)
    n1 = len(first)
    np.testing.assert_array_equal(ref.r[:n1], first.r)
    np.testing.assert_array_equal(ref.v[:n1], first.v)
    assert np.all(ref.r[n1 - 1 : n1 + 200] == 0.05)  # 0.2 s dwell, 200 samples
    assert ref.v[n1 + 199] == 0.0 and ref.v[n1 + 200] < 0.0
    # The second move starts at sample n1 + 199 with its (negative) jerk.
    assert ref.j[n1 + 199] == -100.0 and ref.j[n1 + 198] == 0.0
    second = point_to_point(0.05, 0.02, 0.05, 0.5, 100.0, ts)
    assert len(ref) == n1 + 200 + len(second) - 1
    np.testing.assert_allclose(np.diff(ref.t), ts, rtol=1e-9)
    # Default start is 0.
    assert sequence([(0.01, 0.1, 1.0, 1000.0)], ts).r[0] == 0.0


def test_reference_concat_continues_time_and_checks_sample_time():
    a = point_to_point(0.0, 0.01, 0.1, 1.0, 1000.0, 1e-3)
    b = point_to_point(0.01, 0.0, 0.1, 1.0, 1000.0, 1e-3)
    c = a.concat(b)
    assert len(c) == len(a) + len(b)
    np.testing.assert_allclose(np.diff(c.t), 1e-3, rtol=1e-9)
    np.testing.assert_array_equal(c.r, np.concatenate([a.r, b.r]))
    with pytest.raises(DataError, match="sample times"):
        a.concat(point_to_point(0.0, 0.01, 0.1, 1.0, 1000.0, 2e-3))
    with pytest.raises(DataError, match=r"Reference\.v has 2 samples"):
        Reference(t=[0, 1, 2], r=[0, 0, 0], v=[0, 0], a=[0, 0, 0], j=[0, 0, 0], sample_time=1.0)
    with pytest.raises(ValueError):
        a.r[0] = 1.0  # read-only arrays


# ---------------------------------------------------------------------------
# Files
# ---------------------------------------------------------------------------


@pytest.fixture
def ref_small():
    return point_to_point(-0.01, 0.01, 0.05, 1.0, 100.0, 1e-3)


def _assert_round_trip(got: Reference, ref: Reference):
    np.testing.assert_array_equal(got.r, ref.r)
    assert got.sample_time == pytest.approx(ref.sample_time, rel=1e-12)
    np.testing.assert_allclose(got.t, ref.t, rtol=0, atol=1e-12)
    # Finite-difference velocity: ts^2*j_max/6 in the interior (see above);
    # one-sided at the ends, where the profile is at rest with |r''| <= jm*ts.
    ts, jm = ref.sample_time, 100.0
    np.testing.assert_allclose(got.v[1:-1], ref.v[1:-1], rtol=0, atol=ts**2 * jm / 6 + 1e-12)
    np.testing.assert_allclose(got.v[[0, -1]], ref.v[[0, -1]], rtol=0, atol=jm * ts**2)


def _write_csv(path, header, rows):
    with open(path, "w") as fh:
        fh.write(",".join(header) + "\n")
        for row in rows:
            fh.write(",".join(str(x) for x in row) + "\n")


def test_read_reference_csv_round_trip_with_and_without_time(tmp_path, ref_small):
    p = tmp_path / "ref.csv"
    _write_csv(p, ["t", "r", "extra"], [(repr(float(t)), repr(float(r)), 1) for t, r in zip(ref_small.t, ref_small.r)])
    _assert_round_trip(read_reference(p), ref_small)
    q = tmp_path / "r_only.csv"
    _write_csv(q, ["r"], [(repr(float(r)),) for r in ref_small.r])
    _assert_round_trip(read_reference(q, sample_time=1e-3), ref_small)
    with pytest.raises(DataError, match=r"r_only\.csv.*--reference-sample-time"):
        read_reference(q)


def test_read_reference_mat_v5_round_trip(tmp_path, ref_small):
    p = tmp_path / "ref.mat"
    scipy.io.savemat(p, {"r": ref_small.r, "t": ref_small.t[:, None]})
    _assert_round_trip(read_reference(p), ref_small)
    q = tmp_path / "ts.mat"
    scipy.io.savemat(q, {"y_ref": ref_small.r[:, None], "Ts": 1e-3})
    _assert_round_trip(read_reference(q, variable="y_ref"), ref_small)
    s = tmp_path / "bare.mat"
    scipy.io.savemat(s, {"r": ref_small.r})
    _assert_round_trip(read_reference(s, sample_time=1e-3), ref_small)
    with pytest.raises(DataError, match=r"bare\.mat.*--reference-sample-time"):
        read_reference(s)


def test_read_reference_mat_v73_hdf5_round_trip(tmp_path, ref_small):
    p = tmp_path / "ref73.mat"
    # MATLAB -v7.3 files: HDF5 with a 512-byte user block and (1, N) vectors.
    with h5py.File(p, "w", userblock_size=512) as f:
        f["r"] = ref_small.r[None, :]
        f["Ts"] = np.array([[1e-3]])
    with open(p, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, written by a test".ljust(128, b" "))
    _assert_round_trip(read_reference(p), ref_small)
    h = tmp_path / "ref.h5"
    with h5py.File(h, "w") as f:
        f["r"] = ref_small.r
        f["t"] = ref_small.t
    _assert_round_trip(read_reference(h), ref_small)
    with pytest.raises(DataError, match=r"ref\.h5: no dataset 'pos'.*datasets found: r, t"):
        read_reference(h, variable="pos")


def test_read_reference_rejects_non_numeric_cell_with_row(tmp_path):
    p = tmp_path / "bad.csv"
    _write_csv(p, ["t", "r"], [(0.0, 0.0), (0.001, "abc"), (0.002, 0.0)])
    with pytest.raises(DataError, match=r"bad\.csv row 2 column 'r': 'abc' is not a number \(line 3\)"):
        read_reference(p)


@pytest.mark.parametrize("cell", ["nan", "inf", "-inf"])
def test_read_reference_rejects_non_finite_r_with_row(tmp_path, cell):
    p = tmp_path / "nan.csv"
    _write_csv(p, ["r"], [(0.0,), (0.0,), (cell,)])
    with pytest.raises(DataError, match=r"nan\.csv: 'r' holds -?(nan|inf) at row 3, expected finite numbers"):
        read_reference(p, sample_time=1e-3)


def test_read_reference_rejects_non_finite_in_mat_with_row(tmp_path):
    p = tmp_path / "nan.mat"
    scipy.io.savemat(p, {"r": np.array([0.0, 1.0, np.nan, 2.0])})
    with pytest.raises(DataError, match=r"nan\.mat: 'r' holds nan at row 3"):
        read_reference(p, sample_time=1e-3)


def test_read_reference_missing_column_names_columns_found(tmp_path):
    p = tmp_path / "cols.csv"
    _write_csv(p, ["time", "y", "Fy"], [(0.0, 0.0, 0.0), (0.001, 0.0, 0.0)])
    with pytest.raises(DataError, match=r"cols\.csv: no column 'r' .*columns found: time, y, Fy"):
        read_reference(p, sample_time=1e-3)
    m = tmp_path / "vars.mat"
    scipy.io.savemat(m, {"y": np.zeros(3), "Fy": np.zeros(3)})
    with pytest.raises(DataError, match=r"vars\.mat: no variable 'r' .*variables found: y, Fy"):
        read_reference(m, sample_time=1e-3)


def test_read_reference_non_uniform_time_names_row(tmp_path):
    p = tmp_path / "jitter.csv"
    t = [0.0, 0.001, 0.002, 0.0031, 0.004]
    _write_csv(p, ["t", "r"], [(x, 0.0) for x in t])
    with pytest.raises(DataError, match=r"jitter\.csv: 't' is not uniformly sampled: the step changes at row 4"):
        read_reference(p)
    # 1e-7 relative jitter is accepted.
    ok = tmp_path / "ok.csv"
    _write_csv(ok, ["t", "r"], [(repr(k * 1e-3 * (1 + 1e-7 * (k % 2))), 0.0) for k in range(5)])
    assert read_reference(ok).sample_time == pytest.approx(1e-3, rel=1e-6)
    # 1e-5 relative is not (the tolerance is relative to the step, not absolute).
    bad = tmp_path / "bad.csv"
    _write_csv(bad, ["t", "r"], [(repr(k * 1e-3 * (1 + 1e-5 * (k == 3))), 0.0) for k in range(5)])
    with pytest.raises(DataError, match=r"bad\.csv: 't' is not uniformly sampled: the step changes at row 4"):
        read_reference(bad)


def test_read_reference_other_file_errors(tmp_path):
    with pytest.raises(DataError, match=r"missing\.csv: reference file not found"):
        read_reference(tmp_path / "missing.csv", sample_time=1e-3)
    x = tmp_path / "ref.xlsx"
    x.write_bytes(b"")
    with pytest.raises(DataError, match=r"ref\.xlsx: unsupported reference file type '\.xlsx'"):
        read_reference(x)
    short = tmp_path / "short.csv"
    _write_csv(short, ["r"], [(0.0,)])
    with pytest.raises(DataError, match=r"short\.csv: 'r' has 1 sample\(s\)"):
        read_reference(short, sample_time=1e-3)
    ragged = tmp_path / "ragged.csv"
    _write_csv(ragged, ["t", "r"], [(0.0, 0.0), (0.001,)])
    with pytest.raises(DataError, match=r"ragged\.csv row 2 has 1 fields, expected 2 as in the header \(line 3\)"):
        read_reference(ragged)
    clash = tmp_path / "clash.csv"
    _write_csv(clash, ["t", "r"], [(0.0, 0.0), (0.002, 0.0)])
    with pytest.raises(DataError, match=r"clash\.csv: the file's sample time 0\.002 s disagrees"):
        read_reference(clash, sample_time=1e-3)
    junk = tmp_path / "junk.mat"
    junk.write_bytes(b"not a mat file at all")
    with pytest.raises(DataError, match=r"junk\.mat: not a readable MATLAB \.mat file"):
        read_reference(junk)


# ---------------------------------------------------------------------------
# Bad numbers
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"v_max": 0.0}, r"v_max must be a finite number > 0 \(m/s\), got 0\.0"),
        ({"a_max": -1.0}, r"a_max must be a finite number > 0 \(m/s\^2\), got -1\.0"),
        ({"j_max": float("nan")}, r"j_max must be a finite number > 0 \(m/s\^3\), got nan"),
        ({"sample_time": 0.0}, r"sample_time must be a finite number > 0 \(s\)"),
        ({"q1": float("inf")}, r"q1 must be a finite number \(m\), got inf"),
        ({"v_max": "fast"}, r"v_max must be a number \(m/s\), got 'fast'"),
    ],
)
def test_point_to_point_rejects_bad_numbers(kwargs, match):
    args = {"q0": 0.0, "q1": 0.1, "v_max": 0.1, "a_max": 1.0, "j_max": 1000.0, "sample_time": 1e-3}
    args.update(kwargs)
    with pytest.raises(ConfigError, match=match):
        point_to_point(**args)


def test_sequence_rejects_bad_moves_and_dwell():
    with pytest.raises(ConfigError, match="no moves"):
        sequence([], 1e-3)
    with pytest.raises(ConfigError, match=r"move 1 is \(0\.1, 0\.1\)"):
        sequence([(0.1, 0.1, 1.0, 10.0), (0.1, 0.1)], 1e-3)
    with pytest.raises(ConfigError, match=r"move 0: v_max must be a finite number > 0"):
        sequence([(0.1, -0.1, 1.0, 10.0)], 1e-3)
    with pytest.raises(ConfigError, match=r"dwell\[0\] must be a finite time >= 0"):
        sequence([(0.1, 0.1, 1.0, 10.0)], 1e-3, dwell=-1.0)
    with pytest.raises(ConfigError, match="1 dwell times for 2 moves"):
        sequence([(0.1, 0.1, 1.0, 10.0)] * 2, 1e-3, dwell=[0.1])
    with pytest.raises(ConfigError, match="samples"):
        point_to_point(0.0, 1.0, 0.1, 1.0, 10.0, 1e-12)
    with pytest.raises(ConfigError, match=r"sample_time must be a finite number > 0"):
        read_reference("whatever.csv", sample_time=-1.0)
