"""Logs as drives and hosts record them: non-uniform stamps, counts, a filtered current report, and the parts of the
model a log does not determine (pinned, with the experiment that would determine them). The truth is a rotor with a
known cogging (tests/_rotor.py), noise-free, so each tolerance is the kernel's own error at the logs' step."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import re

import numpy as np
import pytest

import _rotor
from pgcomm.errors import DataError, ExcitationError
from pgcomm.io.logs import ROTARY_REQUIRED, column_mapping, read_log, with_encoder_counts
from pgcomm.rotary.identify import identify, resolution_verdict
from pgcomm.settings import RotaryIdentifyOptions
from pgcomm.rotary.motor import RotaryMotor
from pgcomm.rotary.model import cogging_orders
from pgcomm.rotary.regression import DETERMINED_SHARE

MOTOR = RotaryMotor(pole_pairs=3, slots=9, sample_time=1e-3, k_t=0.1, current_limit=5.0)
GRID = np.linspace(0.0, 2.0 * np.pi, 720, endpoint=False)
#: Every reading fixed (none of them is under test here) except where a test detects one.
FIXED = RotaryIdentifyOptions(current_delay=0, current_lag=0.0, angle_pll=None, time_lines=(), current_noise=None,
                              extra_orders=False)


def cogging_error(model) -> float:
    """RMS of the identified cogging's difference from the truth (offsets removed), share of the truth's RMS."""
    c, tru = model.cogging(GRID), _rotor.cogging(GRID)
    return float(np.sqrt(np.mean((c - c.mean() - tru + tru.mean()) ** 2)) / tru.std())


def two_directions(jitter: float) -> list:
    return [_rotor.run(4.0, speed=20.0, jitter=jitter, seed=1), _rotor.run(4.0, speed=-15.0, jitter=jitter, seed=2)]


@pytest.fixture(scope="module")
def uniform_logs():
    return two_directions(0.0)


@pytest.fixture(scope="module")
def jittered_logs():
    return two_directions(0.5)


def test_non_uniform_stamps_against_the_uniform_fit(uniform_logs, jittered_logs):
    """Steps of 0.5-1.5 times the median, integrated over the real intervals, give the cogging as a uniform log does:
    both within the kernel's error at this step (the cubic path at 6 samples per period of the highest order)."""
    uniform = identify(uniform_logs, MOTOR, replace(FIXED, current_filter=0.0))
    jittered = identify(jittered_logs, MOTOR, replace(FIXED, current_filter=0.0))
    e_u, e_j = cogging_error(uniform.model), cogging_error(jittered.model)
    assert e_u < 2e-3 and e_j < 2e-3, (e_u, e_j)
    assert jittered.model.inertia_ratio == pytest.approx(_rotor.INERTIA_RATIO, rel=1e-2)
    # the same stamps replaced by a uniform grid: the time the regression integrates over is wrong
    as_uniform = [{**lg, "t": np.arange(lg["t"].size) * np.median(np.diff(lg["t"]))} for lg in jittered_logs]
    try:
        wrong = cogging_error(identify(as_uniform, MOTOR, replace(FIXED, current_filter=0.0)).model)
    except ExcitationError:
        wrong = np.inf  # refused as implausible: also a sign that the real intervals matter
    assert wrong > 10 * max(e_j, 1e-3)


def test_a_filtered_report_is_found_and_read_back(jittered_logs):
    """A current reported through a 20 ms first-order lag (20 median steps) is found to within a few per cent, and the
    cogging comes out as from the current that acted."""
    tau = 0.02
    logs = [_rotor.report_filtered(lg, tau) for lg in jittered_logs]
    res = identify(logs, MOTOR, replace(FIXED, current_filter="detect"))
    found = res.current_filter
    assert found["tau_s"] == pytest.approx(tau, rel=0.05)
    assert found["evidence"] > 10.83
    # against the same logs read back with the true τ (the second formulation: what the read-back's discretisation
    # leaves), the detection adds only the misestimate of τ turning each order h by h ω Δτ (ω up to 20 rad/s)
    known = cogging_error(identify(logs, MOTOR, replace(FIXED, current_filter=tau)).model)
    dtau = abs(found["tau_s"] - tau)
    a = np.array(_rotor.AMPLITUDES)
    turned = float(np.sqrt(np.sum((a * np.array(_rotor.ORDERS) * 20.0 * dtau) ** 2) / np.sum(a ** 2)))
    assert cogging_error(res.model) < known + 1.5 * turned + 1e-3, (found["tau_s"], known, turned)
    # as logged, the table is late by τ: far off
    try:
        plain = cogging_error(identify(logs, MOTOR, replace(FIXED, current_filter=0.0)).model)
    except ExcitationError:
        plain = np.inf  # refused as implausible
    assert plain > 5 * cogging_error(res.model) and plain > 5 * known


def test_a_filter_is_not_read_as_a_late_current():
    """A 17 ms report filter on a current that a 100 Hz dither dominates lags it by 2.3 ms, as a current two samples
    late would: with the delay, the current's form and the filter all detected, the filter is still found (the
    search starts from both, :func:`pgcomm.rotary.readings.read_logs`), the current is read on time, and the cogging
    comes out as with the true τ and timing given (the second formulation), up to what the misestimate of τ turns."""
    tau = 0.017
    logs = [_rotor.run(3.0, speed=s, dither=1.0, dither_hz=100.0, jitter=0.3, seed=k, report_filter=tau)
            for k, s in ((3, 20.0), (4, -15.0))]
    res = identify(logs, MOTOR, replace(FIXED, current_delay="detect", current_lag="detect", current_filter="detect"))
    found = res.current_filter
    assert found["tau_s"] == pytest.approx(tau, rel=0.05)
    assert res.current_delay["samples"] == 0
    known = cogging_error(identify(logs, MOTOR, replace(FIXED, current_filter=tau)).model)
    a = np.array(_rotor.AMPLITUDES)
    turned = float(np.sqrt(np.sum((a * np.array(_rotor.ORDERS) * 20.0 * abs(found["tau_s"] - tau)) ** 2)
                           / np.sum(a ** 2)))
    assert cogging_error(res.model) < known + 1.5 * turned + 2e-3, (found["tau_s"], known, turned)


def test_degrees_read_as_radians_name_the_unit(uniform_logs):
    """An angle logged in degrees and read as radians turns 57 times as fast: every window is beyond the alias guard,
    and the refusal says how fast the logs turn and which unit to declare."""
    deg = [{**lg, "theta": np.degrees(lg["theta"])} for lg in uniform_logs]
    with pytest.raises(ExcitationError, match=r"too fast .* turn at up to 1\d{3} rad/s .* declare it in the "
                                              r"--columns map's \[units\] \(theta = \"deg\""):
        identify(deg, MOTOR, replace(FIXED, current_filter=0.0))


def test_one_direction_without_dither_pins_ripple_and_direction():
    """A speed-loop log at one speed, one direction, no dither determines the cogging only: the ripple is pinned at
    zero and the direction map folded into the cogging, each verdict naming the experiment that would determine it."""
    log = _rotor.run(6.0, speed=20.0, dither=0.0, seed=3)
    res = identify([log], MOTOR, replace(FIXED, current_filter=0.0))
    assert set(res.pinned) == {"ripple", "direction"}
    assert res.model.ripple.orders.size == 0 and res.model.direction.orders.size == 0
    se = res.standard_error
    assert "dither" in resolution_verdict(se["ripple"]) and "both directions" in resolution_verdict(se["direction"])
    # noise-free, what is left is the ridge's pull on columns that one pass makes nearly collinear (J/k0's θ̈ is a
    # function of the angle too): the verdict reports it, and the error stays within it
    c = se["cogging"]
    assert cogging_error(res.model) < 2 * np.hypot(c["relative"], c["ridge_bias"]) + 2e-3, c


def test_both_directions_with_a_dither_pin_nothing(uniform_logs):
    res = identify(uniform_logs, MOTOR, replace(FIXED, current_filter=0.0))
    assert res.pinned == []
    assert min(res.information_share.values()) > DETERMINED_SHARE


# --------------------------------------------------------------------------- the reader


def write(tmp_path, name, t, theta, iq):
    p = tmp_path / name
    np.savetxt(p, np.column_stack([t, theta, iq]), delimiter=",", header="time_s,pos,iq", comments="", fmt="%.9g")
    return p


MAP = {"columns": {"t": "time_s", "theta": "pos", "iq_1": "iq"}, "units": {"theta": "counts"},
       "options": {"encoder_counts": 8192}}


REAL_LOGS = sorted((Path(__file__).resolve().parents[2] / "shared" / "real" / "odrive_cogging" / "logs").glob("*.csv"))


@pytest.mark.skipif(not REAL_LOGS, reason="the shared real logs are not beside the checkout")
def test_an_encoder_glitch_is_refused_and_real_logs_are_not(tmp_path):
    """A jump of 0.3 rad that stays, where the speed predicts a hundredth of that, is refused with its row; none of
    the real rig's 26 logs (host stamps, PLL angle, stalls, a shaking rotor, 0-77 rad/s) is, as recorded."""
    for path in REAL_LOGS:
        read_log(path, columns=MAP_ODRIVE, required=ROTARY_REQUIRED, stamps=True, gaps=True)
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 2000))
    counts = np.round(8192 * (2.0 * t + 0.01 * np.sin(40 * t)))  # 2 rev/s: 0.013 rad per step
    counts[1200:] += 400  # 0.31 rad
    with pytest.raises(DataError, match=r"c\.csv row 1201: .* jumps by 0\.3.* predicts 0\.01.*encoder glitch"):
        read_log(write(tmp_path, "c.csv", t, counts, np.zeros_like(t)), columns=MAP, required=ROTARY_REQUIRED,
                 stamps=True)


MAP_ODRIVE = {"columns": {"t": "time_s", "theta": "pos_estimate_counts", "iq_1": "Iq_measured_A"},
              "units": {"theta": "counts"}, "options": {"encoder_counts": 8192}}


def test_counts_and_host_stamps_are_read_as_recorded(tmp_path):
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(1.4e-3, 6e-3, 500))
    counts = 8192 * 0.1 * t  # 0.1 rev/s
    log = read_log(write(tmp_path, "a.csv", t, counts, np.zeros_like(t)), columns=MAP, required=ROTARY_REQUIRED,
                   stamps=True)
    assert not log.uniform
    # written with 9 significant digits: t to 1e-8 s, the counts to 1e-9 of their value
    np.testing.assert_allclose(log["t"], t, rtol=0, atol=2e-8)
    np.testing.assert_allclose(log["theta"], 2 * np.pi * 0.1 * t, rtol=1e-8, atol=2 * np.pi * 0.1 * 2e-8)
    assert log.sample_time == pytest.approx(np.median(np.diff(t)), abs=4e-8)
    # a gap longer than GAP_STEPS median steps splits the log
    t2 = t.copy()
    t2[300:] += 0.5
    log2 = read_log(write(tmp_path, "b.csv", t2, 8192 * 0.1 * t2, np.zeros_like(t)), columns=MAP,
                    required=ROTARY_REQUIRED, stamps=True)
    assert log2.gaps == (299,) and any("split" in n for n in log2.notes)


@pytest.mark.parametrize("bad, word", [(0.0, "repeats"), (-1e-3, "goes back")])
def test_stamps_that_repeat_or_go_back_are_refused_with_the_row(tmp_path, bad, word):
    t = np.arange(100) * 2e-3
    t[50] = t[49] + bad
    p = write(tmp_path, "c.csv", t, np.arange(100.0), np.zeros(100))
    with pytest.raises(DataError, match=rf"c.csv row 51 column 'time_s' \(t\): .*{word}"):
        read_log(p, columns=MAP, required=ROTARY_REQUIRED, stamps=True)


def test_counts_need_the_encoder_counts(tmp_path):
    p = write(tmp_path, "d.csv", np.arange(10) * 1e-3, np.arange(10.0), np.zeros(10))
    no_counts = {**MAP, "options": {}}
    with pytest.raises(Exception, match="encoder_counts"):
        read_log(p, columns=no_counts, required=ROTARY_REQUIRED, stamps=True)
    mapping = with_encoder_counts(column_mapping(no_counts), MOTOR.__class__(pole_pairs=3, sample_time=1e-3,
                                                                              encoder_counts=4096))
    assert read_log(p, columns=mapping, required=ROTARY_REQUIRED, stamps=True)["theta"][1] == pytest.approx(
        2 * np.pi / 4096)


def test_counts_declared_as_radians_name_the_unit(tmp_path):
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(1.4e-3, 6e-3, 2000))
    counts = 8192 * 1.0 * t + 40 * np.sin(50 * t)  # 1 rev/s in counts, with a cogging wobble
    p = write(tmp_path, "e.csv", t, counts, np.zeros_like(t))
    as_rad = {**MAP, "units": {}}
    with pytest.raises(DataError, match=r"e.csv row \d+: .*theta.*declare it \(\[units\] theta = \"counts\""):
        read_log(p, columns=as_rad, required=ROTARY_REQUIRED, stamps=True)


def test_a_log_that_never_moves_is_refused_by_the_cli(tmp_path):
    import subprocess
    import sys

    t = np.arange(3000) * 2e-3
    p = write(tmp_path, "still.csv", t, np.full(t.size, 100.0), 0.3 + 0.01 * np.sin(t))
    (tmp_path / "map.toml").write_text('[columns]\nt = "time_s"\ntheta = "pos"\niq_1 = "iq"\n[units]\n'
                                       'theta = "counts"\n[options]\nencoder_counts = 8192\n')
    (tmp_path / "motor.toml").write_text('kind = "rotary"\npole_pairs = 7\nslots = 12\nsample_time = 0.002\n'
                                         'k_t = 0.05\ncurrent_limit = 10.0\n')
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-m", "pgcomm", "identify", "--motor", str(tmp_path / "motor.toml"),
                          "--columns", str(tmp_path / "map.toml"), "--data", str(p), "--out", str(out), "--quiet"],
                         capture_output=True, text=True)
    assert run.returncode == 2
    assert run.stderr.count("\n") == 1 and "no usable window" in run.stderr and "Traceback" not in run.stderr
    assert not out.exists()


def test_a_pinned_ripple_leaves_the_cogging_of_logs_that_determine_it(uniform_logs):
    """``pin``: the ripple pinned on logs that would determine it (the path a fit whose ripple is not a motor's takes)
    leaves the cogging as the full fit has it, this rotor having no ripple."""
    full = identify(uniform_logs, MOTOR, replace(FIXED, current_filter=0.0))
    pinned = identify(uniform_logs, MOTOR, replace(FIXED, current_filter=0.0, pin=("ripple",)))
    assert pinned.pinned == ["ripple"] and pinned.model.ripple.orders.size == 0
    assert "not determined by these logs" in resolution_verdict(pinned.standard_error["ripple"])
    assert cogging_error(pinned.model) < max(2 * cogging_error(full.model), 2e-3)


def test_the_kept_angle_parts_give_the_fit_of_parts_built_afresh():
    """Second formulation: an identification that searches the logs' reading (its delay, lag, filter and a PLL: tens
    of passes over the same logs, the angle's columns kept between them, :func:`pgcomm.rotary.regression.angle_parts_kept`)
    gives the maps of the same identification with every pass building them afresh (no budget), within 1e-9 of the
    maps' own scale; another thread keeps parts of its own."""
    import threading

    from pgcomm.rotary import regression

    logs = [_rotor.run(2.0, speed=20.0, seed=1), _rotor.run(2.0, speed=-15.0, seed=2)]
    kept = identify(logs, MOTOR)
    parts = regression._angle_parts()
    budget, parts.budget = parts.budget, 0
    try:
        fresh = identify(logs, MOTOR)
    finally:
        parts.budget = budget
    assert fresh.reading() == kept.reading()
    for name in ("cogging", "ripple", "direction"):
        a, b = getattr(kept.model, name), getattr(fresh.model, name)
        assert np.array_equal(a.orders, b.orders)
        np.testing.assert_allclose(a.coef, b.coef, rtol=0, atol=1e-9 * max(np.abs(b.coef).max(), 1e-300))
    other = []
    thread = threading.Thread(target=lambda: other.append(regression._angle_parts()))
    thread.start()
    thread.join()
    assert other[0] is not parts


def test_logs_of_two_power_ups_are_put_in_one_frame(uniform_logs):
    """Two log files whose encoder index moved between them (the second's angles read 0.4 rad more): the second is
    found 0.4 rad off against the first, modulo the map's own period (its orders are multiples of 6: a shift of 60° is
    no shift), within the refinement's resolution (a fiftieth of a bin), re-aligned, and the cogging is the truth's
    within the kernel's error as from the logs in one frame; the same two files in one frame are left as they are."""
    from pgcomm.rotary.power_ups import _bins

    named = [{**lg, "name": f"run_{k}.csv"} for k, lg in enumerate(uniform_logs)]
    moved = [named[0], {**named[1], "theta": named[1]["theta"] + 0.4}]
    options = replace(FIXED, current_filter=0.0)
    res = identify(moved, MOTOR, options)
    (found,) = res.index_offsets
    period = 2 * np.pi / np.gcd.reduce(_rotor.ORDERS)
    miss = (found["rad"] + 0.4 + period / 2) % period - period / 2
    step = 2 * np.pi / _bins(res.highest_order)
    assert found["log"] == "run_1.csv" and found["taken"]
    assert abs(miss) <= step / 25, (found["rad"], step)
    assert cogging_error(res.model) < 2e-3
    # as it was: the two frames' cogging averaged
    wrong = identify([{k: v for k, v in lg.items() if k != "name"} for lg in moved], MOTOR, options)
    assert wrong.index_offsets is None and cogging_error(wrong.model) > 0.1
    same = identify(named, MOTOR, options)
    assert same.index_offsets is None and cogging_error(same.model) < 2e-3


def test_logs_too_fast_for_the_basis_keep_the_orders_they_resolve():
    """A log at a speed of its own, where the full basis's alias guard would refuse every window (order 54, three
    multiples of the fundamental 18, at 60 rad/s and 1 ms has under 2 samples per period), is identified with the
    orders it resolves: up to ``⌊2π / (3 ω T_s)⌋`` (34 at the commanded speed; the speed loop's ripple lowers it by
    its share), the truth's orders 6, 12, 18 among them, and the orders left out are named."""
    ts, speed = MOTOR.sample_time, 60.0
    log = _rotor.run(4.0, speed=speed, dither=0.0, seed=5)
    res = identify([log], MOTOR, replace(FIXED, current_filter=0.0))
    cut = res.orders_not_resolved
    top = int(np.floor(2 * np.pi / (3 * speed * ts)))
    ripple = np.quantile(np.abs(np.diff(log["theta"])), 0.9) / (speed * ts) - 1.0
    assert top * (1 - 2 * ripple) - 1 <= cut["highest_order"] <= top, (cut, ripple)
    assert res.highest_order <= cut["highest_order"] and min(cut["orders"]) > cut["highest_order"]
    assert 54 in cut["orders"]
    # the cogging's orders cut are read over the angle, and only they sit above the cut in its map
    over = res.orders_over_the_angle
    above = res.model.cogging.orders[res.model.cogging.orders > cut["highest_order"]]
    assert sorted(above.tolist()) == sorted(over["orders"]) and 54 in over["orders"] and over["segments"] >= 1
    c = res.standard_error["cogging"]
    assert cogging_error(res.model) < 2 * np.hypot(c["relative"], c["ridge_bias"]) + 2e-3, c
    # the basis given: nothing is cut, and the guard refuses the windows
    with pytest.raises(ExcitationError, match="no usable window"):
        identify([log], MOTOR, replace(FIXED, current_filter=0.0, orders=(cogging_orders(9, 3), [], [])))
    # a fundamental the logs cannot resolve (27 slots: order 54) is refused with the speed that would resolve it:
    # 2π / (3 · 54 · T_s) = 38.8 rad/s at the median step, less the share the speed loop's ripple adds to the fastest
    with pytest.raises(ExcitationError, match=r"fundamental \(order 54 per revolution\).*log at most") as refused:
        identify([log], replace(MOTOR, slots=27), replace(FIXED, current_filter=0.0))
    need = float(re.search(r"log at most ([\d.]+) rad/s", str(refused.value)).group(1))
    nominal = 2 * np.pi / (3 * 54 * ts)
    assert nominal / (1 + 2 * ripple) <= need <= nominal * 1.001, (need, nominal, ripple)


def test_the_report_gives_a_pinned_maps_verdict_as_a_sentence(tmp_path):
    """A one-direction log without a dither pins the direction map and the ripple; the report's verdict column says
    "no: not determined by these logs" for each (not "nonot")."""
    from pgcomm.report.rotary import write_rotary_report
    from pgcomm.rotary.from_logs import identify_from_logs

    log = _rotor.run(6.0, speed=20.0, dither=0.0, seed=3)
    path = tmp_path / "one_way.csv"
    np.savetxt(path, np.c_[log["t"], log["theta"], log["iq_1"]], delimiter=",", header="t,theta,iq_1", comments="",
               fmt="%.15g")
    found = identify_from_logs([read_log(path, required=ROTARY_REQUIRED, stamps=True)], MOTOR,
                               replace(FIXED, current_filter=0.0))
    assert set(found.identification.pinned) == {"ripple", "direction"}
    page = write_rotary_report(tmp_path / "report.html", found.to_dict(), {}).read_text()
    assert page.count("no: not determined by these logs") == 2 and "nonot" not in page
