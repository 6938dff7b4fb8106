"""The host's clock in a logged angle: the speed-dependent noise read from the angle alone against a known timing
noise, and the rows weighted for it against the unweighted fit on a rotor of known cogging (tests/_rotor.py)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

import _rotor
import pgcomm.rotary.host_clock as host_clock_module
import pgcomm.rotary.identify as identify_module
from pgcomm.rotary.host_clock import DIFFERENCE_ORDER, angle_noise_bins, speed_noise_fit
from pgcomm.rotary.identify import identify
from test_real_logs import FIXED, MOTOR, cogging_error


def _overlap(order: int) -> float:
    return math.comb(4 * order, 2 * order) / math.comb(2 * order, order) ** 2


def _ramp_log(n: int, sigma_t: float, floor: float, seed: int):
    """An angle of known motion (a speed ramp from 2 to 30 rad/s and a 1 mrad, 80 Hz dither) on log-normally jittered
    stamps, read at instants that miss their stamps by a normal ``sigma_t`` (s), plus a white angle noise ``floor``
    (rad): ``var_θ(ω) = floor² + sigma_t² ω²``."""
    rng = np.random.default_rng(seed)
    t = np.concatenate([[0.0], np.cumsum(1e-3 * np.exp(0.2 * rng.standard_normal(n - 1)))])
    instant = t + sigma_t * rng.standard_normal(n)
    duration = t[-1]
    w0, w1 = 2.0, 30.0

    def angle(x):
        return w0 * x + 0.5 * (w1 - w0) / duration * x * x + 1e-3 * np.sin(2 * np.pi * 80.0 * x)

    return t, angle(instant) + floor * rng.standard_normal(n)


def test_timing_noise_is_read_from_the_angle_alone():
    """A 40 µs timing noise on jittered stamps, beside a 10 µrad white floor, under a dither the sixth difference must
    cancel: ``σ_t`` within four standard errors of the squared sixth differences' mean over the log's windows (the
    overlapping windows' correlation counted), ``b`` within four of its own reported standard errors."""
    n, sigma_t, floor = 20000, 40e-6, 1e-5
    t, theta = _ramp_log(n, sigma_t, floor, seed=3)
    fit = speed_noise_fit(angle_noise_bins(t, theta))
    # b rests mostly on the faster half of the windows: its relative SE is about sqrt(2 C / (n/2)), doubled for the
    # floor fitted beside it; σ_t's relative error is half of b's
    rel_b = 2.0 * math.sqrt(2.0 * _overlap(DIFFERENCE_ORDER) / (n / 2))
    assert fit["resolved"]
    assert fit["sigma_t_s"] == pytest.approx(sigma_t, rel=4 * rel_b / 2)
    assert abs(fit["timing_s2"] - sigma_t**2) <= 4 * fit["timing_se_s2"]
    assert fit["timing_se_s2"] <= 2 * rel_b * sigma_t**2  # the reported SE is no looser than the count says


def test_exact_stamps_give_no_timing_noise():
    """The same motion read at its stamps (non-uniform, exact): the timing noise is not resolved, or stays far below
    the floor at the fastest speed."""
    t, theta = _ramp_log(20000, 0.0, 1e-5, seed=4)
    fit = speed_noise_fit(angle_noise_bins(t, theta))
    assert not fit["resolved"] or fit["timing_s2"] * fit["speed95_rad_s"] ** 2 < 0.1 * fit["floor_rad2"]


def _host_stamped(sigma_t: float, seed: int) -> list:
    """Three logs of the known rotor (30, −5 and 5 rad/s, jittered steps) whose rows are stamped ``sigma_t`` (normal,
    clipped at 3σ) off the instants their angle and current are of, with a 10 mA current noise."""
    rng = np.random.default_rng(seed)
    logs = []
    for speed, s in ((30.0, 1), (-5.0, 2), (5.0, 3)):
        lg = _rotor.run(3.0, speed=speed, jitter=0.5, seed=s)
        miss = np.clip(rng.standard_normal(lg["t"].size), -3.0, 3.0) * sigma_t
        logs.append({**lg, "t": lg["t"] + miss, "iq_1": lg["iq_1"] + 0.01 * rng.standard_normal(lg["t"].size)})
    return logs


def test_weighted_rows_cut_the_cogging_error_of_host_stamped_logs(monkeypatch):
    """With a 40 µs stamp error the fast log's rows carry far more noise than the slow logs': weighted, the cogging
    comes within three of its standard errors of the truth and at least a quarter closer than unweighted; the timing
    noise found is the clipped normal's std (0.9866 σ) within a tenth."""
    sigma_t = 40e-6
    logs = _host_stamped(sigma_t, seed=5)
    options = replace(FIXED, current_filter=0.0)
    weighted = identify(logs, MOTOR, options)
    host = weighted.host_clock
    assert host["weighted"], host
    assert host["sigma_t_us"] == pytest.approx(0.9866 * sigma_t * 1e6, rel=0.1)
    e_w, se_w = cogging_error(weighted.model), weighted.standard_error["cogging"]["relative"]
    assert e_w < 3 * se_w, (e_w, se_w)
    monkeypatch.setattr(identify_module, "weigh", lambda prepared, orders, taps: (prepared, None))
    e_u = cogging_error(identify(logs, MOTOR, options).model)
    assert e_w < 0.75 * e_u, (e_w, e_u)


def test_exact_stamps_leave_every_row_at_weight_one():
    """Jittered but exact stamps: no timing noise is found and the fit is the unweighted one."""
    logs = [_rotor.run(2.0, speed=20.0, jitter=0.5, seed=1), _rotor.run(2.0, speed=-15.0, jitter=0.5, seed=2)]
    res = identify(logs, MOTOR, replace(FIXED, current_filter=0.0))
    assert not res.host_clock["weighted"], res.host_clock


def test_row_noise_is_the_variance_of_the_filtered_divided_differences():
    """The exact row variance (:func:`pgcomm.rotary.host_clock._row_noise`) against a Monte Carlo of the regression's
    own acceleration column (the divided differences over the real stamps, filtered) on angle errors of a variance
    that varies per sample: the mean square over 4000 draws within five of its standard errors (``√(2/4000)``)."""
    from pgcomm.rotary.host_clock import _row_noise
    from pgcomm.rotary.regression import _Prepared, _filt, _hann

    rng = np.random.default_rng(3)
    n, taps = 400, 9
    t = np.concatenate([[0.0], np.cumsum(1e-3 * rng.uniform(0.5, 1.5, n - 1))])
    variance = (1e-4 * (1.0 + rng.uniform(0.0, 3.0, n))) ** 2
    starts = np.arange(0, n - taps - 2, 7)
    p = _Prepared(0, np.zeros(n), np.zeros(n), np.ones(n), np.ones(n), starts, 1e-3, t=t)
    g = _hann(taps)
    exact = _row_noise(p, g, variance)[starts + (taps + 2) // 2]
    draws = 4000
    e = rng.standard_normal((draws, n)) * np.sqrt(variance)
    d = ((e[:, 2:] - e[:, 1:-1]) / np.diff(t)[1:] - (e[:, 1:-1] - e[:, :-2]) / np.diff(t)[:-1]) / (0.5 * (t[2:] - t[:-2]))
    rows = np.array([_filt(di, starts, g) for di in d])
    mc = np.mean(rows**2, axis=0)
    np.testing.assert_allclose(mc, exact, rtol=5 * math.sqrt(2 / draws))
    # the uniform formula on these stamps reads the noise low: a divided difference over a short step amplifies it
    from pgcomm.rotary.quantisation import acceleration_noise
    uniform = np.array([acceleration_noise(1.0, g, 1e-3) * variance[s + (taps + 2) // 2] for s in starts])
    assert np.mean(exact) > 1.5 * np.mean(uniform)


def test_the_timing_noise_is_taken_out_of_the_inertia(monkeypatch):
    """The 40 µs stamp error in the acceleration pulls ``J/k0`` towards zero (to about half on the test rotor's 30 rad/s
    log); taken out of the normal equations, ``J/k0`` comes within a third of that error of the truth."""
    logs = _host_stamped(40e-6, seed=5)
    options = replace(FIXED, current_filter=0.0)
    corrected = identify(logs, MOTOR, options)
    assert corrected.host_clock["bias_corrected"], corrected.host_clock
    monkeypatch.setattr(host_clock_module, "timing_noise", lambda prepared, fit, taps: (None, "left in"))
    plain = identify(logs, MOTOR, options)
    truth = _rotor.INERTIA_RATIO
    e_c = abs(corrected.model.inertia_ratio / truth - 1)
    e_p = abs(plain.model.inertia_ratio / truth - 1)
    assert e_p > 0.3, e_p  # the bias this test is about is there
    assert e_c < e_p / 3, (e_c, e_p)


def test_the_terminal_line_says_what_was_done_for_the_clock():
    """One line only where something was done for the clock, naming each thing done."""
    from pgcomm.rotary.host_clock import host_clock_text

    base = {"resolved": True, "sigma_t_us": 38.7, "sigma_t_se_us": 0.5, "spread": 3.0}
    assert host_clock_text({**base, "weighted": False, "bias_corrected": False}) is None
    assert host_clock_text({**base, "resolved": False, "weighted": True, "bias_corrected": True}) is None
    only_bias = host_clock_text({**base, "weighted": False, "bias_corrected": True})
    assert "38.7 µs" in only_bias and "J/k0" in only_bias and "weighted" not in only_bias
    both = host_clock_text({**base, "weighted": True, "bias_corrected": True})
    assert "J/k0" in both and "weighted" in both and "3 times" in both


def test_the_experiment_runs_slower_where_the_first_round_finds_a_host_clock():
    """The rotary experiment on a zoo motor with a real drive's habits (0:0, a host's clock of ~37 µs RMS): its first
    round's angle carries the clock, so that round is set aside and the logs identified are the references at
    ``host_clock_speed_shares`` (each log as long as its slower reference, the set-aside round in the rig time). Against
    the twin's truth, the cogging identified from one slower round is at least twice as close as from the set-aside
    faster one (21 % against 7 % when measured; the clock's timing noise and the readings it blurs cost in proportion
    to the speed)."""
    from pgcomm.rotary.experiment import _tuned_drive, identification_errors, quick_settings, record_running_logs, \
        running_log, running_references
    from pgcomm.rotary.regression import Orders
    from pgcomm.seeds import stream_seed
    from pgcomm.rotary.zoo import draw_rotary

    t = draw_rotary(0, 0, real_drive=True)
    s = replace(quick_settings(), revolutions=2.0, log_budget_share=1e-3)  # one round after the first
    rec = record_running_logs(t, s, seed=0)
    ident = rec.identification
    a = t.inertia / t.k0
    fast = running_references(t.motor, a, s, Orders.for_motor(t.motor))
    # each slower segment: revolutions times the ratio of the mean speeds (a round about as long)
    revs = s.revolutions * np.mean(s.host_clock_speed_shares) / np.mean(s.speed_shares)
    slow = running_references(t.motor, a, replace(s, speed_shares=s.host_clock_speed_shares, revolutions=float(revs)),
                              Orders.for_motor(t.motor))
    assert ident.host_clock["resolved"]
    assert ident.speed_shares == list(s.host_clock_speed_shares)
    assert rec.set_aside == pytest.approx(sum(r.n for r in fast) * t.motor.sample_time, rel=1e-12)
    assert ident.set_aside_s == rec.set_aside
    # each log spans its slower reference (the host's first and last rows within a few steps of the drive's first and
    # last cycle: its jitter and gaps) and runs at its speed: the angle it passes within a tenth of the reference's (a
    # speed loop holds the speed, not the angle), the faster references' at least twice as far in about the same time
    assert len(rec.logs) == len(slow)
    for g, r, q in zip(rec.logs, slow, fast):
        assert abs((g["t"][-1] - g["t"][0]) / t.motor.sample_time - (r.n - 1)) <= 5
        travel = abs(r.theta[-1] - r.theta[0])
        assert abs(abs(g["theta"][-1] - g["theta"][0]) / travel - 1.0) < 0.1
        assert abs(q.theta[-1] - q.theta[0]) > 2.0 * travel
    assert rec.seconds == pytest.approx(rec.set_aside + sum(r.n for r in slow) * t.motor.sample_time, rel=1e-12)
    _, _, gains, classical = _tuned_drive(t)
    first = [running_log(t, r, classical, gains, stream_seed(0, "rotary running log", 0, i)) for i, r in enumerate(fast)]
    err_fast = identification_errors(identify(first, t.motor).model, t)["cogging_rel"]
    err_slow = identification_errors(ident.model, t)["cogging_rel"]
    assert err_slow < 0.5 * err_fast, (err_slow, err_fast)


def test_only_a_resolved_clock_and_slower_shares_change_the_runs():
    """:func:`pgcomm.rotary.experiment.slower_for_the_host_clock`: no clock read, a clock not resolved, no slower
    shares given, or shares not slower: the runs stay as set. Otherwise each segment is ``revolutions`` times the ratio
    of the mean speeds (a round about as long), at least ``1 / len(shares)`` revolutions (every angle in each
    direction)."""
    from pgcomm.rotary.experiment import slower_for_the_host_clock
    from pgcomm.settings import RotarySettings

    s = RotarySettings(revolutions=2.0, speed_shares=(0.3, 0.5), host_clock_speed_shares=(0.1, 0.2))
    found = {"resolved": True, "sigma_t_us": 37.0}
    assert slower_for_the_host_clock(None, s) is None
    assert slower_for_the_host_clock({**found, "resolved": False}, s) is None
    assert slower_for_the_host_clock(found, replace(s, host_clock_speed_shares=())) is None
    assert slower_for_the_host_clock(found, replace(s, host_clock_speed_shares=(0.4, 0.6))) is None
    got = slower_for_the_host_clock(found, s)
    assert got.speed_shares == (0.1, 0.2) and got.revolutions == pytest.approx(2.0 * 0.15 / 0.4, rel=1e-12)
    assert slower_for_the_host_clock(found, replace(s, revolutions=0.5)).revolutions == pytest.approx(0.5, rel=1e-12)
