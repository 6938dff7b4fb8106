"""Rotary drive logs: theta/velocity units, wrapped vs continuous angles, iq/id columns, bad input.

Tolerances: unit factors and whole-revolution offsets are exact up to float64 rounding of the
values involved (|theta| < 1e3 rad: 1e-12 rad absolute is ~1e4 ulp, loose enough for any x86-64).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pgcomm.errors import DataError
from pgcomm.io.angles import AMBIGUITY, unwrap_angle
from pgcomm.io.logs import ROTARY_REQUIRED, read_log

TS = 1e-3  # s: the drives' 1 kHz
ATOL = 1e-12  # rad


def _motion(n=4000, seed=3):
    """A multi-turn move (rad, rad/s) with speeds up to ~60 rad/s: several revolutions both ways."""
    t = np.arange(n) * TS
    omega = 60.0 * np.sin(2 * np.pi * t / (n * TS)) + 15.0 * np.sin(2 * np.pi * 3.1 * t)
    theta = 1.3 + np.concatenate(([0.0], np.cumsum(0.5 * (omega[1:] + omega[:-1]) * TS)))
    return t, theta, omega


def _write(path, names, cols, fmt="%.17g"):
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        for row in zip(*cols):
            f.write(",".join(fmt % v for v in row) + "\n")


@pytest.mark.parametrize("lo", [0.0, -math.pi])  # [0, 2π) and [-π, π)
@pytest.mark.parametrize("with_velocity", [True, False])
def test_wrapped_and_continuous_logs_give_the_same_angle(tmp_path, lo, with_velocity):
    t, theta, omega = _motion()
    iq = 0.3 * np.sin(theta * 12)
    wrapped = np.mod(theta - lo, 2 * np.pi) + lo
    names = ["t", "theta", "iq_1"] + (["velocity"] if with_velocity else [])
    extra = [omega] if with_velocity else []
    _write(tmp_path / "cont.csv", names, [t, theta, iq, *extra])
    _write(tmp_path / "wrap.csv", names, [t, wrapped, iq, *extra])
    a = read_log(tmp_path / "cont.csv", required=ROTARY_REQUIRED)
    b = read_log(tmp_path / "wrap.csv", required=ROTARY_REQUIRED)
    assert a.angle_wraps == 0 and not any("wrap" in n for n in a.notes)
    assert b.angle_wraps > 3 and any(f"{b.angle_wraps} wrap(s)" in n for n in b.notes)
    # the same motion up to the whole revolutions the wrapped file lost before its first sample
    offset = a["theta"][0] - b["theta"][0]
    assert abs(offset / (2 * np.pi) - round(offset / (2 * np.pi))) < 1e-12
    np.testing.assert_allclose(b["theta"] + offset, a["theta"], rtol=0, atol=ATOL * 100)
    assert a.is_rotary and b.dq_currents().shape == (t.size, 1, 2)


@pytest.mark.parametrize("unit, fac, vunit, vfac", [
    ("deg", 180 / np.pi, "deg/s", 180 / np.pi),
    ("rev", 1 / (2 * np.pi), "rev/s", 1 / (2 * np.pi)),
    ("rad", 1.0, "rpm", 60 / (2 * np.pi)),
    ("mrad", 1e3, "rad/s", 1.0),
])
@pytest.mark.parametrize("wrap", [False, True])
def test_angle_and_velocity_units(tmp_path, unit, fac, vunit, vfac, wrap):
    t, theta, omega = _motion(1500)
    col = theta * fac
    if wrap:
        col = np.mod(col, 2 * np.pi * fac)  # [0, 360) deg, [0, 1) rev ...
    _write(tmp_path / "log.csv", ["time", "pos", "vel", "Iq"], [t, col, omega * vfac, np.ones_like(t)])
    mapping = {"columns": {"t": "time", "theta": "pos", "velocity": "vel", "iq_1": "Iq"},
               "units": {"theta": unit, "velocity": vunit}}
    log = read_log(tmp_path / "log.csv", columns=mapping, required=ROTARY_REQUIRED)
    np.testing.assert_allclose(log["velocity"], omega, rtol=1e-14, atol=1e-12)
    off = theta[0] - log["theta"][0]
    np.testing.assert_allclose(log["theta"] + off, theta, rtol=0, atol=ATOL * 1e3 if unit == "mrad" else ATOL * 100)
    assert (log.angle_wraps > 0) == wrap


def test_real_drive_log_shape_through_a_column_mapping(tmp_path):
    """time, multi-turn position (rad), velocity, q current, q voltage, supply voltage at 1 kHz."""
    t, theta, omega = _motion(3000)
    iq = 0.8 + 0.1 * np.sin(14 * theta)
    vq = 0.05 * omega + 1.2 * iq
    vbus = 24.0 + 0.01 * np.cos(t)
    _write(tmp_path / "drive.csv", ["timestamp_s", "position_rad", "velocity_rad_s", "q_current_A", "q_voltage_V",
                                    "bus_voltage_V"], [t, theta, omega, iq, vq, vbus])
    (tmp_path / "map.toml").write_text(
        '# the drive\'s own names\n[columns]\nt = "timestamp_s"\ntheta = "position_rad"\nvelocity = "velocity_rad_s"\n'
        'iq_1 = "q_current_A"\n\n[units]\ntheta = "rad"\nvelocity = "rad/s"\n')
    log = read_log(tmp_path / "drive.csv", columns=tmp_path / "map.toml", required=ROTARY_REQUIRED)
    assert log.sample_time == pytest.approx(TS, rel=1e-9)
    np.testing.assert_array_equal(log["theta"], theta)
    np.testing.assert_array_equal(log["iq_1"], iq)
    # unmapped numeric columns are kept under their own names, never refused
    np.testing.assert_array_equal(log["q_voltage_V"], vq)
    np.testing.assert_array_equal(log["bus_voltage_V"], vbus)
    dq = log.dq_currents()
    np.testing.assert_array_equal(dq[:, 0, 0], iq)
    np.testing.assert_array_equal(dq[:, 0, 1], 0.0)
    assert any("no id_1" in n for n in log.notes) and log.angle_wraps == 0
    # the voltages mapped to their log names (with units)
    (tmp_path / "map2.toml").write_text(
        '[columns]\nt = "timestamp_s"\ntheta = "position_rad"\nvelocity = "velocity_rad_s"\niq_1 = "q_current_A"\n'
        'vq_1 = "q_voltage_V"\nvbus = "bus_voltage_V"\n[units]\nvq_1 = "mV"\n')
    log2 = read_log(tmp_path / "drive.csv", columns=tmp_path / "map2.toml", required=ROTARY_REQUIRED)
    np.testing.assert_allclose(log2["vq_1"], vq * 1e-3, rtol=1e-15)
    np.testing.assert_array_equal(log2["vbus"], vbus)


# --------------------------------------------------------------------------- bad input


def _one_line(excinfo):
    msg = str(excinfo.value)
    assert "\n" not in msg
    return msg


def test_id_without_iq_is_refused(tmp_path):
    t, theta, omega = _motion(50)
    _write(tmp_path / "log.csv", ["t", "theta", "id_1", "Iq1"], [t, theta, 0 * t, 0 * t])
    with pytest.raises(DataError) as e:
        read_log(tmp_path / "log.csv", required=ROTARY_REQUIRED)
    msg = _one_line(e)
    assert "log.csv" in msg and "'iq_1' missing" in msg and "id_1" in msg and "closest match: 'Iq1'" in msg


def test_ambiguous_jump_is_refused_naming_file_column_and_sample(tmp_path):
    t, theta, omega = _motion(400)
    bad = np.mod(theta, 2 * np.pi)
    bad[200:] += 3.0  # a glitch of ~half a revolution: neither a wrap nor motion
    _write(tmp_path / "glitch.csv", ["t", "pos", "velocity", "iq_1"], [t, bad, omega, 0 * t])
    cols = {"columns": {"theta": "pos"}}
    with pytest.raises(DataError) as e:
        read_log(tmp_path / "glitch.csv", columns=cols, required=ROTARY_REQUIRED)
    msg = _one_line(e)
    assert msg.startswith(f"{tmp_path / 'glitch.csv'} row 201: 'pos' (theta) jumps by")
    assert "ambiguous" in msg and "velocity" in msg
    # without a velocity column too
    _write(tmp_path / "glitch2.csv", ["t", "theta", "iq_1"], [t, bad, 0 * t])
    with pytest.raises(DataError, match=r"glitch2.csv row 201: 'theta' jumps by .* ambiguous"):
        read_log(tmp_path / "glitch2.csv", required=ROTARY_REQUIRED)


def test_velocity_in_the_wrong_unit_makes_wraps_ambiguous(tmp_path):
    t, theta, omega = _motion(3000)
    theta, omega = 4 * theta, 4 * omega  # up to 300 rad/s: an rpm read as rad/s is then off by > 1.5 rad per sample
    _write(tmp_path / "log.csv", ["t", "theta", "velocity", "iq_1"],
           [t, np.mod(theta, 2 * np.pi), omega * 60 / (2 * np.pi), 0 * t])
    with pytest.raises(DataError, match=r"log.csv row \d+: 'theta' jumps .*check the velocity's unit and sign"):
        read_log(tmp_path / "log.csv", required=ROTARY_REQUIRED)  # rpm read as rad/s


def test_fast_log_without_velocity_asks_for_it():
    theta = np.arange(50) * 2.0  # 2 rad per sample: beyond a quarter revolution
    with pytest.raises(DataError, match="add the velocity column"):
        unwrap_angle(theta, TS, None, "f.csv")
    th, n = unwrap_angle(theta, TS, np.full(50, 2.0 / TS), "f.csv")  # with it: continuous, no wrap
    assert n == 0 and th is not None
    np.testing.assert_array_equal(th, theta)


def test_jump_of_two_revolutions_is_not_a_wrap():
    theta = np.zeros(10)
    theta[5:] += 4 * np.pi
    with pytest.raises(DataError, match=r"row 6: .* 2 revolutions in one sample is not a wrap"):
        unwrap_angle(theta, TS, None, "f.csv")


def test_threshold_is_a_quarter_revolution():
    assert AMBIGUITY == pytest.approx(np.pi / 2)
    ok = np.array([0.0, 2 * np.pi - 0.1 - 2 * np.pi + 0.0, 0.0])  # steps -0.1, +0.1
    assert unwrap_angle(ok, TS)[1] == 0


def test_non_monotonic_time_is_refused(tmp_path):
    t, theta, omega = _motion(30)
    t[17] = t[15]
    _write(tmp_path / "log.csv", ["t", "theta", "iq_1"], [t, theta, 0 * t])
    with pytest.raises(DataError) as e:
        read_log(tmp_path / "log.csv", required=ROTARY_REQUIRED)
    msg = _one_line(e)
    assert "log.csv row 18" in msg and "'t'" in msg and "strictly increasing" in msg


def test_velocity_unit_must_match_the_kind_of_log(tmp_path):
    t, theta, omega = _motion(30)
    _write(tmp_path / "log.csv", ["t", "theta", "velocity", "iq_1"], [t, theta, omega, 0 * t])
    with pytest.raises(DataError, match=r"log.csv column 'velocity': unit 'm/s' is linear"):
        read_log(tmp_path / "log.csv", columns={"units": {"velocity": "m/s"}}, required=ROTARY_REQUIRED)
    with pytest.raises(DataError, match=r"'furlong' is not a known rotation unit \(known: rad, mrad, deg, rev, turn, counts\)"):
        read_log(tmp_path / "log.csv", columns={"units": {"theta": "furlong"}}, required=ROTARY_REQUIRED)


def test_linear_logs_still_need_y(tmp_path):
    t, theta, omega = _motion(30)
    _write(tmp_path / "log.csv", ["t", "theta", "iq_1"], [t, theta, 0 * t])
    with pytest.raises(DataError, match="'y' missing"):
        read_log(tmp_path / "log.csv")


def test_a_linear_log_keeps_an_extra_theta_column_as_it_is(tmp_path):
    t = np.arange(20) * TS
    wrapped = np.mod(np.arange(20) * 2.0, 2 * np.pi)  # would be ambiguous in a rotary log
    _write(tmp_path / "lin.csv", ["t", "y", "ia_1", "ib_1", "theta"], [t, 0 * t, 0 * t, 0 * t, wrapped])
    log = read_log(tmp_path / "lin.csv")
    np.testing.assert_array_equal(log["theta"], wrapped)
    assert log.angle_wraps == 0
