"""Rotary twin -> identification / standstill sweep against the twin's truth, and the CLI.

Tolerances: the target (5 % RMS of the truth over the revolution) for the cogging; the
ripple of a short (quick-sized) run is held to 10 %, the direction map to 15 %. The zoo motor 0
(9N6P) has the lowest cogging orders (up to 54 per revolution), so its running logs are short. Its drive,
as the zoo draws it, controls 8 times per logged sample (``motor0_fast``); most tests here run it at its log rate
(``motor0``: the current held between samples), where the readings of the angle and the current were built, and
the tests of the snapshot current run it as drawn.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace

import numpy as np
import pytest

from pgcomm.errors import ExcitationError
from pgcomm.rotary.experiment import identification_errors, quick_settings, running_references
from pgcomm.rotary.identify import identify, resolution_verdict
from pgcomm.settings import RotaryIdentifyOptions
from pgcomm.rotary.regression import Orders, max_speed
from pgcomm.rotary.standstill import run_standstill
from pgcomm.settings import StandstillPlan
from pgcomm.rotary.twin import LawParams, Reference, default_gains, simulate
from pgcomm.rotary.zoo import draw_rotary
from _drive_pll import odrive_pll, with_sensor_pickup


@pytest.fixture(scope="module")
def motor0():
    """Zoo motor 0 with a drive that controls at its log rate (``control_per_log = 1``), and its quick running logs."""
    from dataclasses import replace

    t = replace(draw_rotary(0, 0), control_per_log=1)
    a = t.inertia / t.k0
    orders = Orders.for_motor(t.motor)
    refs = running_references(t.motor, a, quick_settings(), orders)
    logs = [simulate(t, r, LawParams.classical(t.motor.pole_pairs), default_gains(a), seed=k)
            for k, r in enumerate(refs)]
    return t, logs


@pytest.fixture(scope="module")
def motor0_fast():
    """Zoo motor 0 as the zoo draws it, its drive controlling several times per logged sample, and its quick running
    logs (as ``motor0``'s)."""
    t = draw_rotary(0, 0)
    assert t.control_per_log > 1
    a = t.inertia / t.k0
    refs = running_references(t.motor, a, quick_settings(), Orders.for_motor(t.motor))
    return t, [simulate(t, r, LawParams.classical(t.motor.pole_pairs), default_gains(a), seed=k)
               for k, r in enumerate(refs)]


def _within_the_bars(model, t):
    """The module's bars (its docstring) for a quick run of zoo motor 0 without a torque sensor."""
    e = identification_errors(model, t)
    assert e["cogging_rel"] <= 0.05
    assert e["ripple_rel"] <= 0.10
    assert e["direction_rel"] <= 0.15
    assert e["inertia_ratio_rel"] <= 0.01


def test_identification_without_torque_sensor_matches_the_truth(motor0):
    t, logs = motor0
    res = identify(logs, t.motor)
    _within_the_bars(res.model, t)
    assert res.ridge_chosen_by.startswith("validation")
    assert res.windows_used > 0


def test_a_current_offset_is_the_cogging_maps_constant_and_moves_nothing_else(motor0):
    """A current sensor's offset ``i0`` (1 % of the limit) in every log: the torque is ``k0 (1 + r)(i_q − i0)``, so
    the cogging map's constant comes out as ``−i0`` and its angle-dependent part moves by ``−i0 r(θ)``; the
    ripple, the direction map and ``J/k0`` are those of the offset-free fit within a fifth of their standard
    errors (the same windows, the same noise: only the offset differs). Before the constant was in the model,
    the offset went into the ripple (153 % of its RMS)."""
    t, logs = motor0
    i0 = 0.01 * t.motor.current_limit
    plain = identify(logs, t.motor)
    shifted = identify([dict(lg, iq_1=lg["iq_1"] + i0) for lg in logs], t.motor)
    c = shifted.model.cogging
    c0 = float(c.coef[c.orders == 0, 0].sum())
    se = shifted.standard_error
    assert c0 == pytest.approx(-i0 + float(plain.model.cogging.coef[plain.model.cogging.orders == 0, 0].sum()),
                               abs=0.2 * se["cogging"]["rms_error"] + 1e-3 * i0)
    th = 2 * np.pi * np.arange(4096) / 4096
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    expected = plain.model.cogging(th) - i0 * plain.model.ripple(th) - i0
    assert rms(shifted.model.cogging(th) - expected) <= 0.2 * se["cogging"]["rms_error"] + 1e-3 * i0
    assert rms(shifted.model.ripple(th) - plain.model.ripple(th)) <= 0.2 * se["ripple"]["rms_error"]
    assert rms(shifted.model.direction(th) - plain.model.direction(th)) <= 0.2 * se["direction"]["rms_error"]
    assert shifted.model.inertia_ratio == pytest.approx(plain.model.inertia_ratio, rel=1e-3)


@pytest.mark.parametrize("delay", [-1, 1, 2])
def test_a_current_shifted_against_the_angle_is_found(motor0, delay):
    """The logged q-current shifted by ``delay`` samples against the angle (``iq_logged[j + delay]`` acted over
    sample ``j``): the fit detects the delay and returns the model of the logs as written within a tenth of its
    standard errors (the repeated edge samples are the only difference); fitted as logged, the cogging is off by
    more than 3 standard errors. The twin's own logs are in time."""
    from pgcomm.rotary.readings import CURRENT_DELAYS, delay_text

    t, logs = motor0
    plain = identify(logs, t.motor)
    assert plain.current_delay["samples"] == 0
    assert set(plain.current_delay["cost_by_delay"]) == set(CURRENT_DELAYS)
    assert delay_text(plain.current_delay).startswith("the logged q-current is in time with the angle")

    def shift(x):
        out = np.empty_like(x)
        if delay > 0:
            out[delay:], out[:delay] = x[:-delay], x[0]
        else:
            out[:delay], out[delay:] = x[-delay:], x[-1]
        return out

    moved = [dict(lg, iq_1=shift(np.asarray(lg["iq_1"]))) for lg in logs]
    found = identify(moved, t.motor)
    assert found.current_delay["samples"] == delay
    assert f"used shifted by {delay}" in delay_text(found.current_delay)
    th = 2 * np.pi * np.arange(4096) / 4096
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    se = plain.standard_error
    assert rms(found.model.cogging(th) - plain.model.cogging(th)) <= 0.1 * se["cogging"]["rms_error"]
    assert rms(found.model.ripple(th) - plain.model.ripple(th)) <= 0.1 * se["ripple"]["rms_error"]
    as_logged = identify(moved, t.motor, RotaryIdentifyOptions(current_delay=0, current_lag=None))
    assert as_logged.current_delay == {"samples": 0, "held": True, "lag": 0.0, "cost_by_delay": None,
                                               "evidence": None, "detected": False}
    assert rms(as_logged.model.cogging(th) - plain.model.cogging(th)) > 3 * se["cogging"]["rms_error"]
    if delay == 1:
        # the delay given and its form left to detect: the same reading as detected, said as given
        given = identify(moved, t.motor, RotaryIdentifyOptions(current_delay=delay))
        assert given.current_delay["detected"] and given.current_delay["held"] == found.current_delay["held"]
        assert delay_text(given.current_delay) == f"the logged q-current is used shifted by {delay} sample(s) against " \
                                                  "the angle, as given"
        assert rms(given.model.cogging(th) - found.model.cogging(th)) <= 0.01 * se["cogging"]["rms_error"]


def test_a_drive_that_controls_faster_than_it_logs_is_read_smooth(motor0_fast):
    """The running logs of zoo 9N6P on its drive, which controls ``K`` = 8 times per logged sample (an ODrive's 8 kHz
    loop logged at 1 kHz): each logged current is a snapshot of one that moves between samples. Detected, it reads as
    the smooth curve through the snapshots, ``1/(2K)`` of a sample late (the cycles' currents are held), within the lag's
    resolution (a 64th), and the maps and ``J/k0`` hold the bars of the drive that controls at its log rate
    (:func:`test_identification_without_torque_sensor_matches_the_truth`). Read as held, the cogging is off by more than
    ten of the smooth reading's standard errors and ``J/k0`` by more than 3 %."""
    from pgcomm.rotary.readings import delay_text

    t, logs = motor0_fast
    res = identify(logs, t.motor)
    timing = res.current_delay
    assert timing["detected"] and not timing["held"] and timing["samples"] == 0
    k = t.control_per_log
    assert timing["lag"] == pytest.approx(1 / (2 * k), abs=1 / 64)
    assert f"about {k} control cycles per logged sample" in delay_text(timing)
    _within_the_bars(res.model, t)
    # held and nothing else: a report filter of a fraction of a sample, searched by default, mimics the snapshot's lag
    held = identify(logs, t.motor, RotaryIdentifyOptions(current_lag=None, current_filter=0.0))
    e_held = identification_errors(held.model, t)
    assert held.current_delay["held"]
    assert e_held["cogging_rel"] > 10 * res.standard_error["cogging"]["relative"]
    assert e_held["inertia_ratio_rel"] > 0.03


def test_an_odrive_log_pll_angle_and_snapshot_current(motor0_fast):
    """What an ODrive logs at 1 kHz from its 8 kHz loop: the angle its PLL estimates (1000 rad/s, run at 8 kHz) and a
    snapshot of the current every eighth cycle. A smooth current a little late and a PLL's lag on the angle trade one
    for the other; read together (the PLL's search with the smooth current's lag fitted at each frequency), the maps
    and ``J/k0`` hold the bars of the drive that controls at its log rate
    (:func:`test_identification_without_torque_sensor_matches_the_truth`); read with the current held, the cogging
    is off by more than ten of the joint reading's standard errors and no PLL is found."""
    from scipy.interpolate import CubicSpline

    t, fast = motor0_fast
    logs = []
    for c in fast:
        fine = c["t"][0] + (c["t"][1] - c["t"][0]) / 8 * np.arange(c["t"].size * 8)
        logs.append({"t": c["t"], "theta": odrive_pll(fine, CubicSpline(c["t"], c["theta"])(fine), 1000.0, 8),
                     "iq_1": c["iq_1"]})
    res = identify(logs, t.motor)
    assert res.angle_pll["natural_frequency_rad_s"] == pytest.approx(1000.0, rel=0.3)
    assert not res.current_delay["held"] and res.current_delay["samples"] == 0
    _within_the_bars(res.model, t)
    # held and nothing else: a report filter of a fraction of a sample, searched by default, mimics the snapshot's lag
    held = identify(logs, t.motor, RotaryIdentifyOptions(current_lag=None, current_filter=0.0))
    assert held.angle_pll["natural_frequency_rad_s"] is None
    assert identification_errors(held.model, t)["cogging_rel"] > 10 * res.standard_error["cogging"]["relative"]


def test_identification_with_torque_sensor(motor0):
    t, logs = motor0
    res = identify(logs, t.motor, RotaryIdentifyOptions(torque_sensor=True))
    assert res.model.k_t == pytest.approx(t.k0, rel=2e-3)
    e = identification_errors(res.model, t)
    assert e["cogging_rel"] <= 0.05
    assert e["ripple_rel"] <= 0.10


def test_the_reading_found_reads_the_logs_again_without_a_search(motor0_fast, motor0):
    """:meth:`RotaryIdentification.reading` hands the reading the search chose (a drive that controls 8x faster
    than it logs: the current smooth and late) to a second identification of the same logs: it searches nothing,
    reads them the same way and gives the same maps (within rounding of the maps' own scale); an identification
    with a torque sensor has no reading to give."""
    t, logs = motor0_fast
    res = identify(logs, t.motor)
    read = res.reading()
    assert read.current_lag is not None and read.current_lag == res.current_delay["lag"]
    again = identify(logs, t.motor, RotaryIdentifyOptions().with_reading(read))
    assert not again.angle_pll["searched"] and not again.time_lines["searched"]
    assert again.current_filter["cost_by_tau"] is None  # the report filter given, not searched
    assert again.current_delay["detected"] is False
    assert again.reading() == read
    for name in ("cogging", "ripple", "direction"):
        a, b = getattr(res.model, name), getattr(again.model, name)
        assert np.array_equal(a.orders, b.orders)
        np.testing.assert_allclose(b.coef, a.coef, rtol=0, atol=1e-9 * np.abs(a.coef).max())
    t0, logs0 = motor0
    with pytest.raises(ValueError, match="torque sensor"):
        identify(logs0, t0.motor, RotaryIdentifyOptions(torque_sensor=True)).reading()


def test_alias_guard_refuses_fast_windows(motor0):
    t, logs = motor0
    orders = Orders.for_motor(t.motor)
    v = 3.0 * max_speed(orders, t.motor.sample_time)  # every window far too fast
    n = 3000
    ref = Reference(v * 1e-3 * np.arange(n), np.full(n, v), np.zeros(n), "speed")
    a = t.inertia / t.k0
    fast = simulate(t, ref, LawParams.classical(t.motor.pole_pairs), default_gains(a))
    with pytest.raises(ExcitationError, match="too fast"):
        identify([fast], t.motor)
    res = identify(list(logs) + [fast], t.motor)
    assert res.windows_refused_alias > 0 and "refused" in res.note


def test_standstill_sweep_holds_the_cogging(motor0):
    t, _ = motor0
    plan = StandstillPlan(points=360, settle=30, average=20)
    sweep = run_standstill(t, default_gains(t.inertia / t.k0), plan)
    truth = t.model().table(plan.points)
    err = np.sqrt(np.mean((sweep.table - truth) ** 2))
    assert err <= 0.1 * np.sqrt(np.mean(truth**2))
    assert sweep.seconds == pytest.approx(2 * 360 * 50 * t.motor.sample_time, rel=1e-12)


def test_cli_zoo_and_reproduce_rotary(tmp_path):
    from pgcomm.cli import main
    from pgcomm.io.results import read_results

    assert main(["zoo", "--kind", "rotary", "--motors", "1", "--out", str(tmp_path / "zoo"), "--quiet"]) == 0
    motor = tmp_path / "zoo" / "motor_1" / "motor.toml"
    if not motor.exists():
        motor = next((tmp_path / "zoo").glob("motor_*/motor.toml"))
    # --log-budget: the running logs' rig time in seconds, whole rounds within it (a round is 5 s on this motor)
    assert main(["reproduce", "--motor", str(motor), "--quick", "--log-budget", "20", "--out", str(tmp_path / "rep"),
                 "--quiet"]) == 0
    r = read_results(tmp_path / "rep" / "results.json")
    assert r["kind"] == "rotary"
    assert r["identification"]["log_budget_s"] == pytest.approx(20.0, rel=1e-12)
    assert r["timing"]["running_logs_s"] <= 20.0 and r["identification"]["rounds"] >= 2
    assert set(r["tracking_mse"]) == {"classical", "standstill_table", "model", "oracle"}
    # the law beats no compensation and does not lose to the floor by more than noise
    assert r["tracking_mse"]["model"]["position"] < 0.1 * r["tracking_mse"]["classical"]["position"]
    assert r["timing"]["running_logs_s"] < r["timing"]["standstill_s"]
    page = (tmp_path / "rep" / "report.html").read_text()
    q = r["tracking_ratio_model_over_standstill"]
    assert f"position loop <b>{q['position']:.2f}</b>" in page and "standstill_table" in page
    for f in ("model.json", "table.csv", "rotary.png", "report.html"):
        assert (tmp_path / "rep" / f).is_file()
    # the model file carries the motor's current limit, so the whole law exports to C without --current-limit
    assert main(["export", "--format", "c-rotary", "--model", str(tmp_path / "rep" / "model.json"), "--out",
                 str(tmp_path / "claw"), "--quiet"]) == 0
    assert read_results(tmp_path / "claw" / "results.json")["current_limit"] == pytest.approx(r["motor"]["current_limit"])
    assert main(["reproduce", "--motor", str(motor), "--plant", "x.csv", "--out", str(tmp_path / "bad")]) == 2
    assert not (tmp_path / "bad").exists()
    for bad in (["--log-budget", "-5"], ["--log-budget", "nan"]):
        assert main(["reproduce", "--motor", str(motor), *bad, "--out", str(tmp_path / "bad")]) == 2
        assert not (tmp_path / "bad").exists()


def test_log_budget_options_are_refused_for_a_linear_motor(tmp_path, capsys):
    """--log-budget and --until-resolved size the rotary experiment's running logs; on the linear twin they would be
    silently ignored, so they are refused in one line naming the option."""
    from pgcomm.cli import main

    for flag in (["--log-budget", "60"], ["--until-resolved"]):
        capsys.readouterr()
        assert main(["reproduce", "--quick", *flag, "--out", str(tmp_path / "lin")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and flag[0] in err[0] and "rotary" in err[0]
        assert not (tmp_path / "lin").exists()


def test_log_budget_is_a_share_of_this_motors_sweep():
    """``--log-budget`` seconds become the settings' share of the sweep's rig time on the motor's own sample time."""
    import argparse

    from pgcomm.cli._reproduce_rotary import _rotary_settings

    s = quick_settings()
    for ts in (1e-3, 2.5e-4):
        got = _rotary_settings(argparse.Namespace(config=None, quick=True, log_budget=42.0, until_resolved=True), ts)
        assert got.log_budget_share * got.standstill.duration(ts) == pytest.approx(42.0, rel=1e-12)
        assert got.stop_when_resolved
    kept = _rotary_settings(argparse.Namespace(config=None, quick=True, log_budget=None, until_resolved=False), 1e-3)
    assert kept.log_budget_share == s.log_budget_share and not kept.stop_when_resolved


def test_standard_errors_predict_the_error_over_noise_seeds():
    """The time-block sandwich standard errors predict the RMS error over the revolution: with ten times the
    zoo's current noise (so that noise, not the basis, makes the error), the mean square error over four noise
    seeds is within a factor 2 of the mean square predicted error, for the cogging and for the ripple."""
    from dataclasses import replace

    t = draw_rotary(0, 0)
    t = replace(t, current_noise=10 * t.current_noise)
    a = t.inertia / t.k0
    orders = Orders.for_motor(t.motor)
    refs = running_references(t.motor, a, quick_settings(), orders)
    err, pred = [], []
    for seed in range(4):
        logs = [simulate(t, r, LawParams.classical(t.motor.pole_pairs), default_gains(a), seed=100 * seed + 1 + k)
                for k, r in enumerate(refs)]
        # a negligible ridge: the standard error has no bias part
        res = identify(logs, t.motor, RotaryIdentifyOptions(ridge=1e-10))
        e, se = identification_errors(res.model, t), res.standard_error
        err.append([e["cogging_rms_A"], e["ripple_rms"]])
        pred.append([se["cogging"]["rms_error"], se["ripple"]["rms_error"]])
        assert se["ripple"]["log_time_factor_to_resolve"] >= 1.0
    ratio = np.mean(np.square(err), axis=0) / np.mean(np.square(pred), axis=0)
    assert np.all((ratio >= 0.5) & (ratio <= 2.0)), ratio


def test_chunked_rows_and_normal_equations_match_a_dense_ridge_solve(motor0):
    """Second formulation: rows built in chunks of any size are the same rows, and the ridge solution from
    the accumulated normal equations is the one a QR solve of the stacked rows (augmented by the ridge) gives
    (without the encoder's quantisation correction, which tests/test_rotary_quantisation.py checks)."""
    from pgcomm.rotary import regression as ri

    t, logs = motor0
    orders = Orders.for_motor(t.motor)
    prepared, _, _, _ = ri._prepare(logs, t.motor, orders, ri.MIN_SAMPLES_PER_PERIOD, ri.FILTER_TAPS, None)
    big = list(ri._chunks(prepared, orders, ri.FILTER_TAPS))
    small = list(ri._chunks(prepared, orders, ri.FILTER_TAPS, chunk=37))
    rows = {}
    for k in big[0]:
        a, b = np.concatenate([c[k] for c in big]), np.concatenate([c[k] for c in small])
        assert a.shape == b.shape
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * max(1.0, float(np.max(np.abs(a)))))
        rows[k] = a
    lay = ri._Layout.of(orders)
    X, y = lay.rows(rows), rows["y"]
    lam_rel = 1e-6
    fit = ri._fit(prepared, lay, ri.FILTER_TAPS, ridge=lam_rel)
    scale = np.sqrt(np.mean(X**2, axis=0))
    Xs = X / scale
    lam = lam_rel * np.trace(Xs.T @ Xs) / Xs.shape[1]
    pen = lay.pen[lay.keep].astype(float)
    aug = np.vstack([Xs, np.diag(np.sqrt(lam * pen))])
    beta = np.linalg.lstsq(aug, np.concatenate([y, np.zeros(X.shape[1])]), rcond=None)[0] / scale
    # fitted currents agree to a small part of the logged current's RMS
    rms_y = float(np.sqrt(np.mean(y**2)))
    assert float(np.sqrt(np.mean((X @ (fit["beta"] - beta)) ** 2))) <= 1e-8 * rms_y
    assert fit["rows"] == y.size and fit["cost"] == pytest.approx(float(np.mean((y - X @ beta) ** 2)), rel=1e-6)


@pytest.mark.parametrize("lag", [None, 1.0 / 16.0])
def test_current_noise_equations_are_the_sum_over_logged_samples(motor0, lag):
    """Second formulation of the current-noise correction's expectation (regression, "The current's noise"): the
    probes' sums equal the sum over every logged sample ``j`` of the rows built with a current that is 1 at ``j``
    alone (brute force on the middle 0.4 s of a log), for the current held between samples and read smooth."""
    from dataclasses import replace

    from pgcomm.rotary import regression as ri

    t, logs = motor0
    orders = Orders.for_motor(t.motor)
    n_log = logs[0]["t"].size
    mid = n_log // 2
    short = [{k: np.asarray(v)[mid - 200:mid + 200] for k, v in logs[0].items()
              if np.ndim(v) == 1 and len(v) == n_log}]
    prepared, _, _, _ = ri._prepare(short, t.motor, orders, ri.MIN_SAMPLES_PER_PERIOD, ri.FILTER_TAPS, None)
    prepared = [replace(p, lag=lag) for p in prepared]
    assert prepared[0].starts.size > 100
    lay = ri._Layout.of(orders)
    Gn, bn, yyn = ri._current_noise_equations(prepared, lay, ri.FILTER_TAPS)
    n = prepared[0].iq.size
    k = int(lay.keep.sum())
    G, b, yy = np.zeros((k, k)), np.zeros(k), 0.0
    for j in range(n):
        e = np.zeros(n)
        e[j] = 1.0
        for ch in ri._chunks([replace(prepared[0], iq=e)], orders, ri.FILTER_TAPS):
            # only the target and the ripple's columns read the current
            X = lay.rows({**ch, **{c: 0.0 * ch[c] for c in ("acc", "cog", "dir", "visc")}})
            G += X.T @ X
            b += X.T @ ch["y"]
            yy += float(ch["y"] @ ch["y"])
    assert np.max(np.abs(G)) > 0
    np.testing.assert_allclose(Gn.sum(axis=0), G, rtol=0, atol=1e-12 * np.max(np.abs(G)))
    np.testing.assert_allclose(bn.sum(axis=0), b, rtol=0, atol=1e-12 * np.max(np.abs(b)))
    assert yyn.sum() == pytest.approx(yy, rel=1e-12)


def test_ridge_bias_is_the_shift_of_a_refit_on_the_fitted_currents(motor0):
    """Second formulation of the ridge's bias ``(A⁻¹N − I) β̂``: the ridge solution (a dense QR solve of the rows
    augmented by the ridge) of currents that are exactly ``X β̂`` lands at ``β̂ + bias``. A strong ridge leaves a
    map that only its noise part would call resolved unresolved; a negligible one adds no bias."""
    from pgcomm.rotary import regression as ri
    from pgcomm.rotary.identify import RESOLVED_SHARE

    t, logs = motor0
    orders = Orders.for_motor(t.motor)
    prepared, _, _, _ = ri._prepare(logs, t.motor, orders, ri.MIN_SAMPLES_PER_PERIOD, ri.FILTER_TAPS)
    rows = list(ri._chunks(prepared, orders, ri.FILTER_TAPS))
    lay = ri._Layout.of(orders)
    X = lay.rows({k: np.concatenate([c[k] for c in rows]) for k in rows[0]})
    lam_rel = 1e-2
    fit = ri._fit(prepared, lay, ri.FILTER_TAPS, ridge=lam_rel)
    scale = np.sqrt(np.mean(X**2, axis=0))
    Xs = X / scale
    lam = lam_rel * np.trace(Xs.T @ Xs) / Xs.shape[1]
    aug = np.vstack([Xs, np.diag(np.sqrt(lam * lay.pen[lay.keep].astype(float)))])
    y_fit = X @ fit["beta"]
    shifted = np.linalg.lstsq(aug, np.concatenate([y_fit, np.zeros(X.shape[1])]), rcond=None)[0] / scale
    # compared through the currents they explain, against the fitted current's RMS
    rms_y = float(np.sqrt(np.mean(y_fit**2)))
    assert float(np.sqrt(np.mean((X @ (shifted - fit["beta"] - fit["bias"])) ** 2))) <= 1e-8 * rms_y
    assert float(np.sqrt(np.mean((X @ fit["bias"]) ** 2))) > 1e-4 * rms_y  # the check above is not vacuous

    strong = identify(logs, t.motor, RotaryIdentifyOptions(ridge=1.0)).standard_error
    weak = identify(logs, t.motor, RotaryIdentifyOptions(ridge=1e-10)).standard_error
    for name in ("cogging", "ripple"):
        assert weak[name]["ridge_bias"] < 1e-6
        assert strong[name]["ridge_bias"] > RESOLVED_SHARE and not strong[name]["resolved"]


def _strip_outside(t):
    """Zoo motor ``t`` without the cogging and ripple orders outside its slot/pole basis."""
    from dataclasses import replace

    from pgcomm.rotary.model import Fourier

    o = Orders.for_motor(t.motor)

    def strip(f, basis):
        m = np.isin(f.orders, basis)
        return Fourier(f.orders[m], f.coef[m])

    return replace(t, cogging=strip(t.cogging, o.cogging), ripple=strip(t.ripple, o.ripple))


def test_screening_adds_the_order_outside_the_basis_and_no_noise_order():
    """Zoo motor 3 (12N14P) cogs at order 43 besides its slot/pole basis (the zoo's stand-in for a
    manufacturing defect): identification adds that order and only it, and the cogging error falls to
    half the basis-only fit's or less; the same motor without its outside orders gets no order added over
    three noise seeds (the screening lets in a noise-only order with chance at most 1 % per map). Three
    revolutions per segment: about 26 s of logs in all."""
    from dataclasses import replace

    t = draw_rotary(0, 3)
    a = t.inertia / t.k0
    orders = Orders.for_motor(t.motor)
    outside = np.setdiff1d(t.cogging.orders, orders.cogging)
    refs = running_references(t.motor, a, replace(quick_settings(), revolutions=3.0), orders)
    assert 15.0 < sum(r.n for r in refs) * t.motor.sample_time < 30.0
    law, gains = LawParams.classical(t.motor.pole_pairs), default_gains(a)
    logs = [simulate(t, r, law, gains, seed=k) for k, r in enumerate(refs)]
    res = identify(logs, t.motor)
    # the same drive's logs, read as the first identification read them (the reading is not what is tested here)
    read = res.reading()
    base = identify(logs, t.motor, RotaryIdentifyOptions(extra_orders=False).with_reading(read))
    assert res.orders_screened and not base.orders_screened
    assert res.orders_added["cogging"] == outside.tolist()
    assert np.array_equal(base.model.cogging.orders, orders.cogging)
    e_base, e = identification_errors(base.model, t), identification_errors(res.model, t)
    assert e["cogging_rel"] <= 0.5 * e_base["cogging_rel"]
    clean = _strip_outside(t)
    for seed in range(3):
        logs = [simulate(clean, r, law, gains, seed=100 * seed + 7 + k) for k, r in enumerate(refs)]
        added = identify(logs, t.motor, RotaryIdentifyOptions().with_reading(read)).orders_added
        assert added == {"cogging": [], "ripple": []}, (seed, added)


def test_a_fit_whose_torque_constant_leaves_the_laws_range_is_refused(motor0):
    """A ripple whose peak passes 1 - MIN_GAIN (the gain the law refuses to divide by) is not a motor: the
    identification says so in one line (where, by how much, how many windows) instead of handing it to a law;
    a ripple just inside passes, and so does the zoo motor's own fit."""
    from pgcomm.rotary.identify import RotaryIdentification, check_plausible
    from pgcomm.rotary.law import MIN_GAIN
    from pgcomm.rotary.model import Fourier, RotaryModel

    def fit(amplitude):
        model = RotaryModel(4, Fourier.zeros([]), Fourier(np.array([3]), np.array([[0.0, amplitude]])),
                            Fourier.zeros([]))
        return RotaryIdentification(model, seconds=0.0, windows_used=383, windows=4622)

    inside = fit(0.99 * (1 - MIN_GAIN))
    assert check_plausible(inside) is inside
    with pytest.raises(ExcitationError, match=r"varies by [+-]51 % of its mean at (\d\.\d{3}) rad.*383 of 4622") as e:
        check_plausible(fit(-1.02 * (1 - MIN_GAIN)))
    assert "\n" not in str(e.value)
    at = float(re.search(r"at (\d\.\d{3}) rad", str(e.value)).group(1))
    assert abs(np.sin(3 * at)) > 0.999  # the angle named is a peak of the ripple
    t, logs = motor0
    identify(logs, t.motor)  # does not raise


def test_map_error_quantile_against_monte_carlo():
    """The RMS error a map stays below with a given probability (Satterthwaite on the map's error covariance)
    against the empirical quantile of 200 000 draws: exact when the weights are equal (within the draws' own
    spread), close when they differ by two orders of magnitude."""
    from pgcomm.rotary import regression as ri
    from pgcomm.rotary.model import harmonic_columns

    rng = np.random.default_rng(7)
    orders = np.array([0, 3, 7, 12])
    n = harmonic_columns(np.zeros(1), orders).shape[1]
    gram = ri._map_gram(orders)
    a = rng.normal(size=(n, n)) * np.logspace(-1, 0, n)
    live = np.diag(gram) > 0  # order 0 has a cosine column only (its sine column is zero)
    equal = np.zeros((n, n))
    equal[np.ix_(live, live)] = 0.01 * np.linalg.inv(gram[np.ix_(live, live)])
    for cov, tol in ((equal, 0.01), (a @ a.T, 0.025)):
        draws = rng.multivariate_normal(np.zeros(n), cov, size=200_000)
        rms = np.sqrt(np.einsum("ki,ij,kj->k", draws, gram, draws))
        for level in (0.5, 0.9):
            q = ri._map_error_quantile(cov, gram, level)
            assert q == pytest.approx(float(np.quantile(rms, level)), rel=tol)
        assert ri._map_standard_error(cov, gram) == pytest.approx(float(np.sqrt(np.mean(rms**2))), rel=0.01)


def test_resolution_verdict_says_what_would_help():
    """Resolved; not resolved for noise (the factor rounded up, so a factor just above 1 never reads 1.0x); not
    resolved because the ridge sets the map (then it names the excitation, not the log time); the encoder's rounding,
    a PLL's reading and the current's noise, named among the parts or as the reason."""
    from pgcomm.rotary.identify import RESOLVED_SHARE, resolution_verdict

    assert resolution_verdict({"resolved": True, "ridge_bias": 0.0, "log_time_factor_to_resolve": 1.0}) == "resolved"
    noise = resolution_verdict({"resolved": False, "ridge_bias": 0.0, "log_time_factor_to_resolve": 1.02})
    assert "1.1x the running log so far" in noise and "ridge" not in noise
    assert "2.4x the running log so far (24 s)" in resolution_verdict(
        {"resolved": False, "ridge_bias": 0.0, "log_time_factor_to_resolve": 2.31}, log_seconds=10.0)
    parts = resolution_verdict({"resolved": False, "ridge_bias": 0.0, "log_time_factor_to_resolve": 1.6,
                                "relative_at_confidence": 0.052, "outside_order_limit": 0.038})
    assert "noise up to 5.2 % at 90 %" in parts and "outside the basis up to 3.8 %" in parts and "1.6x" in parts
    hinted = resolution_verdict({"resolved": False, "ridge_bias": 0.0, "log_time_factor_to_resolve": 30.0,
                                 "excitation_hint": "more q-current variation"})
    assert hinted.endswith("would resolve it; more q-current variation") and "30.0x" in hinted
    ridge = resolution_verdict({"resolved": False, "ridge_bias": 2 * RESOLVED_SHARE, "log_time_factor_to_resolve": 1.0})
    assert "ridge sets 10 %" in ridge and "dither" in ridge
    # the encoder's rounding: named among the parts when it weighs, and the verdict when it alone reaches the share
    part = resolution_verdict({"resolved": False, "ridge_bias": 0.0, "quantisation_bias": 0.026,
                               "log_time_factor_to_resolve": 1.2, "relative_at_confidence": 0.045})
    assert "the encoder's rounding up to 2.6 %" in part and "1.2x" in part
    enc = resolution_verdict({"resolved": False, "ridge_bias": 0.01, "quantisation_bias": 0.76,
                              "log_time_factor_to_resolve": float("inf"), "excitation_hint": "more q-current"})
    assert "encoder's rounding could move it by 76 %" in enc and "accelerations" in enc and "x the running" not in enc
    # parts that reach the share only together (none alone, the largest the encoder's): named with their sum, no
    # log time (an infinite factor: _time_factor of these parts)
    from pgcomm.rotary.identify import _time_factor

    together = {"resolved": False, "ridge_bias": 0.02, "quantisation_bias": 0.04, "pll_bias": 0.02,
                "current_noise_bias": 0.02, "relative_at_confidence": 0.01}
    together["log_time_factor_to_resolve"] = _time_factor(0.01, math.hypot(0.02, 0.04, 0.02, 0.02))
    assert together["log_time_factor_to_resolve"] == float("inf")
    both = resolution_verdict(together, log_seconds=10.0)
    assert f"reaches {100 * math.hypot(0.02, 0.04, 0.02, 0.02):.1f} % of it together" in both, both
    assert "the encoder's rounding 4.0 %" in both and "the ridge 2.0 %" in both and "x the running" not in both
    # a drive PLL's reading of the angle: likewise
    part = resolution_verdict({"resolved": False, "ridge_bias": 0.0, "pll_bias": 0.034,
                               "log_time_factor_to_resolve": 1.3, "relative_at_confidence": 0.035})
    assert "the PLL's reading up to 3.4 %" in part and "1.3x" in part
    pll = resolution_verdict({"resolved": False, "ridge_bias": 0.01, "quantisation_bias": 0.02, "pll_bias": 0.079,
                              "log_time_factor_to_resolve": float("inf")})
    assert "PLL's reading of the angle could move it by 8 %" in pll and "encoder's count" in pll
    # the correction for the current's noise: likewise
    part = resolution_verdict({"resolved": False, "ridge_bias": 0.0, "current_noise_bias": 0.021,
                               "log_time_factor_to_resolve": 1.4, "relative_at_confidence": 0.04})
    assert "the current's noise up to 2.1 %" in part and "1.4x" in part
    cur = resolution_verdict({"resolved": False, "ridge_bias": 0.01, "quantisation_bias": 0.02, "pll_bias": 0.0,
                              "current_noise_bias": 0.061, "log_time_factor_to_resolve": float("inf")})
    assert "current's noise could move it by 6 %" in cur and "d-current" in cur and "x the running" not in cur


def test_the_log_time_factor_leaves_room_for_what_longer_logs_do_not_change():
    """The noise part falls as the square root of the log time; the ridge's pull and the encoder's rounding do not,
    so the factor brings the noise within what the share leaves beside them: ``noise² / (share² − fixed²)``."""
    from pgcomm.rotary.identify import RESOLVED_SHARE, _time_factor

    assert _time_factor(0.5 * RESOLVED_SHARE, 0.0) == 1.0
    assert _time_factor(2 * RESOLVED_SHARE, 0.0) == pytest.approx(4.0)
    assert _time_factor(RESOLVED_SHARE, 0.6 * RESOLVED_SHARE) == pytest.approx(1 / 0.64)
    assert _time_factor(0.1 * RESOLVED_SHARE, RESOLVED_SHARE) == float("inf")


def test_interval_weights_are_the_path_integrals():
    """``A_k = ∫₀¹ x φ(θ(t_k + x T)) dx`` and ``B_k = ∫₀¹ (1 − x) φ(...) dx`` on a path that is quadratic in
    time (a constant acceleration: the cubic through the samples is then exact), with the highest order
    turning 2π/3 per sample (the alias guard's 3 samples per period) at the start and 30 % more at the end,
    against a 20 000-point midpoint rule. Tolerance: the four-point Gauss–Legendre remainder on [0, 1],
    ``(4!)⁴ / (9 (8!)³) · max|f⁽⁸⁾|`` with ``f = x cos(a + c x)``, ``|f⁽⁸⁾| ≤ c⁸ + 8 c⁷`` (``c`` the largest
    phase turned in an interval), for columns of scale 1; the midpoint rule adds ``c² / (24 · 20000²)``."""
    from pgcomm.rotary.regression import _extended, _interval_weights, _path_angles

    ts, n = 1e-3, 40
    orders = np.array([1, 7, 30, 120])
    omega = 2 * np.pi / (3 * ts * orders.max())  # 3 samples per period of order 120
    alpha = 0.3 * omega / (n * ts)  # the speed changes by 30 % over the stretch
    path = lambda t: 0.4 + omega * t + 0.5 * alpha * t**2  # noqa: E731
    theta = path(ts * np.arange(n))
    lo, hi = 5, 25
    c = orders.max() * (omega + alpha * n * ts) * ts
    tol = 24.0**4 / (9 * 40320.0**3) * (c**8 + 8 * c**7) + c**2 / (24 * 20000.0**2)
    A, B = _interval_weights(_path_angles(_extended(theta, lo, hi), hi - lo - 1), orders)
    m = 20000
    x = (np.arange(m) + 0.5) / m
    for j, k in enumerate(range(lo, hi - 1)):
        th = path(ts * (k + x))
        ph = np.mod(th, 2 * np.pi)[:, None] * orders[None, :]
        phi = np.concatenate([np.cos(ph), np.sin(ph)], axis=1)
        np.testing.assert_allclose(A[j], (x[:, None] * phi).mean(axis=0), atol=tol, rtol=0)
        np.testing.assert_allclose(B[j], ((1 - x)[:, None] * phi).mean(axis=0), atol=tol, rtol=0)
    # the ends of a log: the sample before the first is extrapolated linearly, off by α T² (the second
    # difference), which the cubic weighs by at most |x(x-1)(x-2)/6| ≤ 0.065 on [0, 1]; order 1 turns it 1:1
    A0, _ = _interval_weights(_path_angles(_extended(theta, 0, 10), 9), orders[:1])
    th = path(ts * x)
    np.testing.assert_allclose(A0[0], [(x * np.cos(th)).mean(), (x * np.sin(th)).mean()],
                               atol=0.065 * alpha * ts**2 + tol, rtol=0)


def test_noise_free_identification_at_three_samples_per_period():
    """With the current and encoder noise off, zoo motor 4 (18N16P, cogging up to order 432, logs at up to the
    alias guard's 3 samples per period) gives its cogging within 0.5 % of the truth's RMS (measured 0.11 %:
    what is left is the order outside the basis and the friction's smooth sign; sample-by-sample kernels
    that take the torque as quadratic in time err by tens of percent here)."""
    from dataclasses import replace

    t = draw_rotary(0, 4)
    t = replace(t, current_noise=0.0, encoder_counts=2**30)
    a = t.inertia / t.k0
    orders = Orders.for_motor(t.motor)
    refs = running_references(t.motor, a, quick_settings(), orders)
    logs = [simulate(t, r, LawParams.classical(t.motor.pole_pairs), default_gains(a), seed=k)
            for k, r in enumerate(refs)]
    # the logs read as the twin writes them (the drive's snapshot current: smooth, 1/(2K) of a sample late; the
    # encoder's own angle): what is tested is the regression's kernel, not the reading's search
    read = RotaryIdentifyOptions(current_delay=0, current_lag=0.5 / t.control_per_log, angle_pll=None,
                                 time_lines=(), current_filter=0.0)
    res = identify(logs, t.motor, read)
    assert res.min_samples_per_period == 3.0
    assert res.windows_refused_alias < 0.2 * res.windows
    assert identification_errors(res.model, t)["cogging_rel"] <= 0.005


def test_outside_order_limit_is_what_the_screening_sees():
    """``outside_order_limit`` is the RMS of the largest outside order the screening would miss: zoo motor 3 without
    its outside orders reports a limit for the cogging; the same motor with order 43 planted at twice that RMS gets
    order 43 added (its ``T²`` is then about four times the threshold, missed with chance well below 1e-3), and the
    limit sits between the noise part's tenth and ten times it (it falls with the noise: both are set by the
    same covariance)."""
    from dataclasses import replace

    from pgcomm.rotary.model import Fourier

    t = _strip_outside(draw_rotary(0, 3))
    a = t.inertia / t.k0
    orders = Orders.for_motor(t.motor)
    refs = running_references(t.motor, a, replace(quick_settings(), revolutions=3.0), orders)
    law, gains = LawParams.classical(t.motor.pole_pairs), default_gains(a)
    logs = [simulate(t, r, law, gains, seed=11 + k) for k, r in enumerate(refs)]
    first = identify(logs, t.motor)
    se = first.standard_error["cogging"]
    lim = se["outside_order_limit"]
    assert 0.1 * se["relative"] < lim < 10 * se["relative"]
    rms_abs = 2.0 * lim * se["rms"] * t.k0  # N·m; the map is in current units
    planted = Fourier(np.concatenate([t.cogging.orders, [43]]),
                      np.concatenate([t.cogging.coef, [[rms_abs * np.sqrt(2.0), 0.0]]]))
    t2 = replace(t, cogging=planted)
    logs = [simulate(t2, r, law, gains, seed=11 + k) for k, r in enumerate(refs)]
    # the same drive's logs, read as the first were (what is tested is the screening)
    assert 43 in identify(logs, t2.motor, RotaryIdentifyOptions().with_reading(first.reading())).orders_added["cogging"]


def test_rounds_of_running_logs_do_not_retrace_the_same_path(motor0):
    """The twin has no process noise, so two logs of one reference from one angle retrace one path with one
    encoder quantisation error in every sample (more rounds would not average it); ``running_log`` starts each
    log at an angle drawn from its seed, and the quantisation errors of two rounds are then uncorrelated
    (|correlation| within 4/sqrt(N) of zero, N samples)."""
    from pgcomm.rotary.experiment import running_log

    t, _ = motor0
    a = t.inertia / t.k0
    ref = running_references(t.motor, a, quick_settings(), Orders.for_motor(t.motor))[0]
    law, gains = LawParams.classical(t.motor.pole_pairs), default_gains(a)
    same = [simulate(t, ref, law, gains, seed=s) for s in (1, 2)]
    e_same = [g["theta"] - g["theta_true"] for g in same]
    assert np.corrcoef(e_same[0], e_same[1])[0, 1] > 0.99  # the twin's determinism: why rounds need their own start
    runs = [running_log(t, ref, law, gains, s) for s in (1, 2)]
    e = [g["theta"] - g["theta_true"] for g in runs]
    assert abs(runs[0]["theta"][0] - runs[1]["theta"][0]) > 1e3 * 2 * np.pi / t.encoder_counts
    c = np.corrcoef(e[0], e[1])[0, 1]
    assert abs(c) < 4 / np.sqrt(e[0].size)


def test_reproduce_fills_the_log_budget_unless_told_to_stop_when_resolved():
    """By default the rotary experiment records rounds for the whole budget (half the sweep's time); with
    ``stop_when_resolved`` it stops earlier, with both maps resolved (zoo motor 0, quick settings: its maps
    resolve within the budget). The early stop is :func:`record_running_logs` alone (what ``run`` calls first):
    every round holds each reference once, and its time is the rounds' own."""
    import math
    from dataclasses import replace

    from pgcomm.rotary.experiment import record_running_logs, run

    t = draw_rotary(0, 0)
    s = quick_settings()
    full = run(t, s, seed=3)
    ident = full["identification"]
    refs = running_references(t.motor, t.inertia / t.k0, s, Orders.for_motor(t.motor))
    round_s = sum(r.n for r in refs) * t.motor.sample_time
    assert ident["rounds"] == max(1, math.floor(ident["log_budget_s"] / round_s))
    assert full["timing"]["running_logs_s"] == pytest.approx(ident["rounds"] * round_s, rel=1e-12)
    assert "first_round_standard_error" in ident
    early = record_running_logs(t, replace(s, stop_when_resolved=True), seed=3)
    assert early.rounds < ident["rounds"]
    assert len(early.logs) == early.rounds * len(refs)
    assert early.seconds == pytest.approx(sum(g["t"].size for g in early.logs) * t.motor.sample_time, rel=1e-12)
    assert early.identification.rounds == early.rounds
    se = early.identification.standard_error
    assert se["cogging"]["resolved"] and se["ripple"]["resolved"]


def test_the_log_mix_a_drive_user_has_gives_the_cogging_and_an_honest_ripple_verdict():
    """The logs a drive user has: constant speeds, accelerations, a slow sweep, no dither
    (:func:`pgcomm.rotary.experiment.drive_log_mix`, zoo motor 0). From the constant-speed runs alone the cogging
    is within the target's 5 % and resolved, and the ripple, which only q-current varying at a given angle shows,
    is called not resolved while its error is above 5 %, with the hint that a dither or accelerations would help.
    (Not on every motor: with a coarse encoder, constant speeds bias the maps beyond their standard error, see
    docs/validation.md, "Logs without a dither".)
    The accelerating runs carry that current: adding them (half as long again) cuts the ripple's standard error
    by more than the factor sqrt(1.5) that the extra time alone would give, here at least twofold. The slow sweep
    passed with them in ``--data`` keeps the cogging within 5 % and adds no order outside the basis that the
    running logs did not."""
    from pgcomm.rotary.experiment import drive_log_mix

    t = draw_rotary(0, 0)
    logs = drive_log_mix(t, seed=3)
    const = identify(logs["const"], t.motor)
    e, se = identification_errors(const.model, t), const.standard_error
    assert e["cogging_rel"] <= 0.05 and se["cogging"]["resolved"]
    assert e["ripple_rel"] > 0.05 and not se["ripple"]["resolved"]
    assert "dither" in resolution_verdict(se["ripple"]) and "excitation_hint" not in se["cogging"]
    # more logs of the same drive, read as the first were (what is tested is what they add, not the reading)
    read = RotaryIdentifyOptions().with_reading(const.reading())
    accel = identify(logs["const"] + logs["accel"], t.motor, read)
    assert accel.standard_error["ripple"]["relative"] <= 0.5 * se["ripple"]["relative"]
    every = identify(logs["const"] + logs["accel"] + logs["sweep"], t.motor, read)
    assert identification_errors(every.model, t)["cogging_rel"] <= 0.05
    for k, v in every.orders_added.items():
        assert set(v) <= set(accel.orders_added[k]), (k, v)


def test_pll_correction_inverts_a_drive_pll():
    """A rotor at 20 rad/s with a speed ripple at 40 and 300 Hz (the cogging's range at 1 kHz) seen through a PLL
    of 1000 rad/s, ζ = 1, in closed form (a type-2 loop follows the ramp exactly; each tone is scaled and turned
    by ``H(jω)``), logged at 1 kHz: corrected, the estimate is the angle within 1 % of the PLL's error away from
    the log's first and last 50 ms (the correction's odd extension). A straight line is left as it is. ODrive's
    discrete PLL (16 kHz here) is the closed form's within its ``k_p dt`` (the velocity's feed-forward is scaled by
    ``1 - k_p dt``), so that, too, the correction takes out to within that share."""
    from pgcomm.rotary.readings import pll_corrected

    ts, bw = 1e-3, 1000.0
    kp, ki = 2 * bw, bw**2
    t = ts * np.arange(2000)
    tones = ((40.0, 2e-3), (300.0, 4e-4))
    truth = 20.0 * t + sum(a * np.sin(2 * np.pi * f * t) for f, a in tones)
    h = {f: (kp * s + ki) / (s * s + kp * s + ki) for f, _ in tones for s in [2j * np.pi * f]}
    logged = 20.0 * t + sum(a * abs(h[f]) * np.sin(2 * np.pi * f * t + np.angle(h[f])) for f, a in tones)
    inner = slice(50, t.size - 50)
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    err = rms(logged[inner] - truth[inner])
    assert err > 1e-4
    assert rms(pll_corrected(logged, ts, bw, 1.0)[inner] - truth[inner]) <= 0.01 * err
    line = 3.0 + 20.0 * t[:500]
    np.testing.assert_allclose(pll_corrected(line, ts, bw, 1.0), line, rtol=0, atol=1e-9 * np.max(np.abs(line)))
    every = 16
    fine = np.arange(0, 2.0, ts / every)
    odrive = odrive_pll(fine, 20.0 * fine + sum(a * np.sin(2 * np.pi * f * fine) for f, a in tones), bw, every)
    share = kp * ts / every
    assert rms(odrive[inner] - logged[inner]) <= 1.5 * share * err
    assert rms(pll_corrected(odrive, ts, bw, 1.0)[inner] - truth[inner]) <= 1.5 * share * err


def test_pll_correction_on_a_hosts_time_stamps():
    """The same closed form as :func:`test_pll_correction_inverts_a_drive_pll` on a rotor at 0.5 rad/s, sampled at
    a host's instants (log-normal steps of σ 0.14 around 1 ms, the zoo's jitter): given the stamps, the correction
    takes the PLL's error out to within 2 % of it; read as uniform, the angle's uneven steps become an acceleration
    the correction amplifies, and it leaves more of the error than it takes."""
    from pgcomm.rotary.readings import pll_corrected

    rng = np.random.default_rng(7)
    ts, bw, speed = 1e-3, 576.0, 0.5
    kp, ki = 2 * bw, bw**2
    t = np.concatenate([[0.0], np.cumsum(ts * np.exp(0.14 * rng.standard_normal(3999)))])
    tones = ((11.0, 2e-4), (60.0, 2e-5))
    truth = speed * t + sum(a * np.sin(2 * np.pi * f * t) for f, a in tones)
    h = {f: (kp * s + ki) / (s * s + kp * s + ki) for f, _ in tones for s in [2j * np.pi * f]}
    logged = speed * t + sum(a * abs(h[f]) * np.sin(2 * np.pi * f * t + np.angle(h[f])) for f, a in tones)
    inner = slice(100, t.size - 100)
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    err = rms(logged[inner] - truth[inner])
    step = float(np.median(np.diff(t)))
    assert rms(pll_corrected(logged, step, bw, 1.0, t=t)[inner] - truth[inner]) <= 0.02 * err
    assert rms(pll_corrected(logged, step, bw, 1.0)[inner] - truth[inner]) > err


@pytest.mark.parametrize("bw, damping", [(500.0, 1.0), (1581.0, 0.5), (232.0, 0.707)])
def test_pll_noise_gain_is_what_the_correction_does_to_a_white_angle_noise(bw, damping):
    """A white angle noise (a host's clock) through the PLL's correction and a row's filtered second difference: its
    variance against the same noise's without the correction is the closed form's ratio, within the Monte Carlo
    estimate's own scatter (the two variances share the noise: 0.1 % over three seeds at 400 000 samples; 1 %
    asserted). The ratio is below one near a lightly damped
    PLL's resonance (the correction is the PLL's inverse) and above it for a slow PLL: both are exercised."""
    from pgcomm.rotary.readings import pll_corrected, pll_noise_gain
    from pgcomm.rotary.regression import FILTER_TAPS, _hann

    ts, n = 1e-3, 400_000
    noise = np.random.default_rng(11).standard_normal(n)
    row = np.convolve(_hann(FILTER_TAPS), [1.0, -2.0, 1.0])
    inner = slice(1000, n - 1000)
    plain = np.var(np.convolve(noise, row, "same")[inner])
    corrected = np.var(np.convolve(pll_corrected(noise, ts, bw, damping), row, "same")[inner])
    gain = pll_noise_gain(ts, bw, damping, FILTER_TAPS)
    assert abs(gain - 1.0) > 0.2
    assert corrected / plain == pytest.approx(gain, rel=0.01)

def test_an_angle_logged_through_a_drive_pll_is_read_as_one(motor0):
    """The twin's logs with the angle replaced by ODrive's PLL estimate of it (1000 rad/s at 16 kHz on the rotor's
    path, cubic between the samples): no log is on an encoder's lattice, so identify tries PLLs, finds the
    continuous loop that the discrete one matches (``k_p T_c`` = 0.125: 1069 rad/s at ``ζ`` = 1.069) within 10 % and
    5 %, and takes its lag out; the cogging then comes out at most a third as far from
    the truth as read as logged, and within 5 %. The encoder's own angle is never searched (it sits on the
    lattice), and an angle off the lattice without a PLL (noise of 0.4 counts) is read as logged."""
    from scipy.interpolate import CubicSpline

    from pgcomm.rotary.readings import pll_text

    t, logs = motor0
    ts, every = t.motor.sample_time, 16
    moved = []
    for lg in logs:
        tt = np.asarray(lg["t"])
        fine = tt[0] + ts / every * np.arange(tt.size * every)
        moved.append(dict(lg, theta=odrive_pll(fine, CubicSpline(tt, lg["theta_true"])(fine), 1000.0, every)))
    found = identify(moved, t.motor)
    est = found.angle_pll
    g = 2 * 1000.0 * ts / every
    assert est["searched"] and est["natural_frequency_rad_s"] == pytest.approx(1000.0 / math.sqrt(1 - g), rel=0.1)
    assert est["damping"] == pytest.approx(1 / math.sqrt(1 - g), rel=0.05)
    assert "PLL estimate of natural frequency" in pll_text(est)
    as_logged = identify(moved, t.motor, RotaryIdentifyOptions(angle_pll=None))
    e_found = identification_errors(found.model, t)["cogging_rel"]
    e_logged = identification_errors(as_logged.model, t)["cogging_rel"]
    assert e_found <= min(e_logged / 3, 0.05)
    # what the reading may leave counts in the verdict: 0.4 of the maps' move from the angle as logged, against the
    # same move between two identifications with the same orders, ridge and current delay (only the angle differs)
    from pgcomm.rotary.readings import PLL_UNCERTAINTY, lag_of

    th = 2 * np.pi * np.arange(4096) / 4096
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    same = RotaryIdentifyOptions(extra_orders=False, ridge=found.ridge,
                                 current_delay=found.current_delay["samples"],
                                 current_lag=lag_of(found.current_delay),
                                 time_lines=found.time_lines["hz"])
    read = identify(moved, t.motor, replace(same, angle_pll=(est["natural_frequency_rad_s"], est["damping"])))
    raw = identify(moved, t.motor, replace(same, angle_pll=None))
    move = rms(raw.model.cogging(th) - read.model.cogging(th)) / rms(read.model.cogging(th))
    # both fits solve the same normal equations but the angle: float64 rounding of the solves, far below 1e-6
    assert read.standard_error["cogging"]["pll_bias"] == pytest.approx(PLL_UNCERTAINTY * move, rel=1e-6)
    assert read.standard_error["cogging"]["pll_bias"] > 0.01
    plain = identify(logs, t.motor)
    assert plain.standard_error["cogging"]["pll_bias"] == 0.0
    assert plain.angle_pll == {"natural_frequency_rad_s": None, "damping": None, "searched": False}
    q = 2 * np.pi / t.encoder_counts
    rng = np.random.default_rng(3)
    noisy = identify([dict(lg, theta=lg["theta"] + 0.4 * q * rng.standard_normal(len(lg["theta"]))) for lg in logs],
                     t.motor)
    assert noisy.angle_pll["searched"] and noisy.angle_pll["natural_frequency_rad_s"] is None


def test_a_current_sensors_mains_pickup_is_found_and_fitted_beside_the_maps(motor0):
    """A 50 Hz pickup of 1 % of the current limit in the current sensor (the motor gets the demand less it, the log
    shows the demand): identify finds one line, within a tenth of the longest log's frequency resolution of 50 Hz and
    its amplitude within 10 %, and the maps come out as from the same references without the pickup (cogging and
    ripple within twice their standard errors, RMS over the revolution); fitted without the line the cogging moves by
    more than five. The logs without a pickup (which carry the running logs' dither at three frequencies) give no
    line."""
    t, logs = motor0
    refs = running_references(t.motor, t.inertia / t.k0, quick_settings(), Orders.for_motor(t.motor))
    amp = 0.01 * t.motor.current_limit
    picked = with_sensor_pickup(t, refs, amp, 50.0)
    clean = identify(logs, t.motor)
    assert clean.time_lines["searched"] and clean.time_lines["hz"] == []
    found = identify(picked, t.motor)
    lines = found.time_lines
    longest = max(lg["t"].size for lg in logs) * t.motor.sample_time
    assert len(lines["hz"]) == 1 and abs(lines["hz"][0] - 50.0) <= 0.1 / longest
    assert lines["amplitude_A"][0] == pytest.approx(amp, rel=0.10)
    th = 2 * np.pi * np.arange(4096) / 4096
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    se = clean.standard_error
    assert rms(found.model.cogging(th) - clean.model.cogging(th)) <= 2 * se["cogging"]["rms_error"]
    assert rms(found.model.ripple(th) - clean.model.ripple(th)) <= 2 * se["ripple"]["rms_error"]
    blind = identify(picked, t.motor, RotaryIdentifyOptions(time_lines=()))
    assert blind.time_lines == {"hz": [], "searched": False}
    assert rms(blind.model.cogging(th) - clean.model.cogging(th)) > 5 * se["cogging"]["rms_error"]


def test_a_line_in_the_logged_current_leaves_the_feedforward_as_without_it(motor0):
    """``fit_mechanics`` is linear in the logged current, which is not in its columns, and a line's columns are in
    them: a 50 Hz line added to the logged current of each log (its own phase) leaves the feedforward as on the logs
    without it, both fitted with the line, to float rounding (relative 1e-7 of each figure's scale); fitted without
    it, the Coulomb term moves by ten thousand times that (0.9 % here). (``identify``'s ripple columns hold the logged
    current, ``r(θ) i_q``, so there the line's ripple sidebands stay: the maps are checked against the clean logs'
    with a physical pickup above.)"""
    from pgcomm.rotary.identify import fit_mechanics

    t, logs = motor0
    rng = np.random.default_rng(3)
    amp = 0.01 * t.motor.current_limit
    hum = [dict(lg, iq_1=lg["iq_1"] + amp * np.sin(2 * np.pi * 50.0 * lg["t"] + rng.uniform(0, 2 * np.pi)))
           for lg in logs]
    fifty = RotaryIdentifyOptions(time_lines=(50.0,))
    a, b = fit_mechanics(logs, t.motor, fifty), fit_mechanics(hum, t.motor, fifty)
    for k in a:
        assert b[k] == pytest.approx(a[k], rel=1e-7, abs=1e-7 * abs(a["coulomb"]))
    assert abs(fit_mechanics(hum, t.motor)["coulomb"] - a["coulomb"]) > 1e-3 * abs(a["coulomb"])


def test_the_currents_own_line_is_read_beside_its_strong_neighbours(motor0, monkeypatch):
    """The logged current's line at a candidate's frequency (the share test's denominator) is fitted jointly with the
    current's strong lines nearby: a current of a 0.1 A line at 100 Hz and a 1 A line three natural bins of the
    shortest log above it (a dither), with white noise of 1 mA, reads 0.1 A in every log to within the noise's share
    (1 mA over the windows' count, times a margin of 5, plus a hundredth for the neighbour's frequency, estimated on
    the periodogram's parabola); fitted alone, the neighbour leaks in and at least one log reads it off by more than
    a fifth (what made pickups beside a dither look like the current's own)."""
    from pgcomm.rotary import regression as ri
    from pgcomm.rotary import time_lines as tl

    t, logs = motor0
    orders = Orders.for_motor(t.motor)
    rng = np.random.default_rng(5)
    shortest = min(lg["t"][-1] - lg["t"][0] for lg in logs)
    neighbour = 100.0 + 3.0 / shortest
    fake = [dict(lg, iq_1=0.1 * np.sin(2 * np.pi * 100.0 * lg["t"] + rng.uniform(0, 2 * np.pi))
                 + 1.0 * np.sin(2 * np.pi * neighbour * lg["t"] + rng.uniform(0, 2 * np.pi))
                 + 1e-3 * rng.standard_normal(lg["t"].size)) for lg in logs]
    prepared, _, _, _ = ri._prepare(fake, t.motor, orders, ri.MIN_SAMPLES_PER_PERIOD, ri.FILTER_TAPS)
    windows = min(p.starts.size for p in prepared)
    joint = tl._current_lines(prepared, 100.0, ri.FILTER_TAPS)
    assert np.all(np.abs(joint - 0.1) <= 5 * 1e-3 / np.sqrt(windows) + 0.01 * 0.1), joint
    monkeypatch.setattr(tl, "MAX_CURRENT_NEIGHBOURS", 0)
    alone = tl._current_lines(prepared, 100.0, ri.FILTER_TAPS)
    assert np.max(np.abs(alone - 0.1)) > 0.2 * 0.1, alone


def test_current_noise_beside_the_angle_leaves_the_loops_current_out():
    """Zoo seed 1's 18N16P on a 16-bit encoder: the speed loop turns the encoder's noise into real current, which the
    q-current's sixth difference alone counts as noise (more than twice the twin's); less what the logged angle
    predicts of it, the estimate is within 15 % of the twin's noise (0.97-1.11 times it over zoo seeds 0 and 1), and
    a log whose angle carries no encoder noise reads the same as the difference alone."""
    from pgcomm.rotary.experiment import _tuned_drive, running_log
    from pgcomm.settings import RotarySettings
    from pgcomm.rotary.readings import current_noise, current_noise_beside_angle

    truth = draw_rotary(1, 4)
    assert truth.motor.encoder_counts == 65536
    orders, a_nom, gains, classical = _tuned_drive(truth)
    ref = running_references(truth.motor, a_nom, RotarySettings(), orders)[0]
    log = running_log(truth, ref, classical, gains, 11)
    plain = current_noise(log["iq_1"], order=6)
    beside = current_noise_beside_angle(log["iq_1"], log["theta"])
    assert plain > 2.0 * truth.current_noise
    assert abs(beside / truth.current_noise - 1.0) < 0.15
    # white noise beside an angle that predicts nothing of it: the filter takes (almost) nothing out
    rng = np.random.default_rng(3)
    white = 0.1 * rng.standard_normal(20000)
    smooth = 0.01 * np.arange(20000) + 1e-3 * np.sin(0.003 * np.arange(20000))
    assert current_noise_beside_angle(white, smooth) == pytest.approx(current_noise(white, order=6), rel=0.02)


def _continuous_pll(t) -> tuple[float, float]:
    """The continuous PLL ``(ω_n, ζ)`` the twin's discrete one (ODrive's: predict, correct by ``g = k_p T_c``)
    matches at low frequencies: its angle lags the count by ``(1 − g)`` times the continuous loop's
    ``s²/(k_p s + k_i)``, which is the continuous loop of ``k_p/(1 − g)``, ``k_i/(1 − g)``."""
    g = 2 * t.pll_bandwidth * t.motor.sample_time / t.control_per_log
    return t.pll_bandwidth / math.sqrt(1 - g), 1 / math.sqrt(1 - g)


def _quick_round(t):
    """``(orders, logs)``: one round of the quick settings' running logs on twin ``t``, driven as the experiment
    drives it (classical commutation at the nominal ``J/k0``'s gains; the experiment's first noise streams)."""
    from pgcomm.rotary.experiment import _tuned_drive, running_log
    from pgcomm.seeds import stream_seed

    orders, a_nom, gains, classical = _tuned_drive(t)
    return orders, [running_log(t, ref, classical, gains, stream_seed(0, "rotary running log", 0, i))
                    for i, ref in enumerate(running_references(t.motor, a_nom, quick_settings(), orders))]


def test_a_report_filter_under_a_dither_is_read_by_the_share_of_the_current_unexplained():
    """Zoo motor 2:4 with a real drive's habits (a 60.5 ms report filter, a host's clock, a PLL's angle, corrected
    here at the twin's own PLL) and its 100 Hz dither: read back, the current's moving part grows with ``τ``, and in
    amperes the fit is best at a filter a quarter of the twin's or less. Compared by the share of the current each
    reading leaves unexplained (:func:`pgcomm.rotary.regression._unexplained`), the filter is read within 10 % of
    the twin's."""
    from pgcomm.rotary.identify import _guard
    from pgcomm.rotary.readings import REPORT_FILTERS, _report_filter, _with_delay, _with_pll, _with_report
    from pgcomm.rotary.regression import _Layout, _basis_costs, _prepare, angle_parts_kept

    t = draw_rotary(2, 4, real_drive=True)
    assert t.report_filter > 0.05 and t.pll_bandwidth > 0 and t.host_jitter > 0
    orders, logs = _quick_round(t)
    options = RotaryIdentifyOptions()
    min_samples, taps = _guard(options)
    with angle_parts_kept():
        prepared = _prepare(logs, t.motor, orders, min_samples, taps, options.encoder_step)[0]
        prepared = _with_delay(_with_pll(prepared, (t.pll_bandwidth, 1.0), taps), 0, 0.5 / t.control_per_log)
        layout = _Layout.of(orders)
        ts = float(np.median([p.ts for p in prepared]))
        taus = [f * ts for f in REPORT_FILTERS]
        amperes = [c for c, _ in _basis_costs([_with_report(prepared, tau) for tau in taus], layout, taps)]
        found = _report_filter(prepared, layout, taps)
    assert taus[int(np.argmin(amperes))] <= 0.25 * t.report_filter
    assert found["tau_s"] == pytest.approx(t.report_filter, rel=0.1)


def test_a_pll_and_a_report_filter_are_refined_together():
    """A drive PLL's angle and a filtered current report (ODrive logs both) each lag the current against the
    acceleration: started where a reading of one after the other settles (the PLL 1.7 times too fast, the current's
    lag a third of a sample), the joint refinement reaches the optimum a refinement from the twin's own reading
    reaches (a second formulation; within five times the refinement's step tolerance, 2e-3 in ``ln τ``, ``ln ω_n``
    and the lag), its PLL within 10 % of the continuous loop the drive's discrete one matches (:func:`_continuous_pll`,
    ``ζ`` = 1.13 at the twin's ``k_p T_c`` = 0.22), and the filter within 5 % of the twin's."""
    from pgcomm.rotary.experiment import _tuned_drive, quick_settings, running_log, running_references
    from pgcomm.rotary.identify import _guard
    from pgcomm.rotary.readings import _refined, _with_delay, _with_pll, _with_report
    from pgcomm.rotary.regression import _Layout, _basis_cost, _prepare, angle_parts_kept

    off = dict(host_jitter=0.0, host_gaps=0.0, stamp_noise=0.0, sensor_offset=(0.0, 0.0), sensor_gain=(0.0, 0.0),
               deadtime_error=0.0, deadtime_width=0.0)
    t = replace(draw_rotary(0, 0, real_drive=True), **off)
    assert t.pll_bandwidth > 0 and t.report_filter > 0
    orders, a_nom, gains, classical = _tuned_drive(t)
    logs = [running_log(t, ref, classical, gains, seed=k)
            for k, ref in enumerate(running_references(t.motor, a_nom, quick_settings(), orders))]
    options = RotaryIdentifyOptions()
    min_samples, taps = _guard(options)
    with angle_parts_kept():
        prepared = _prepare(logs, t.motor, orders, min_samples, taps, options.encoder_step)[0]
        layout = _Layout.of(orders)
        start_tau, start_w, start_lag = 1.3 * t.report_filter, 1.7 * t.pll_bandwidth, 0.33
        report = {"tau_s": start_tau, "evidence": None, "cost_by_tau": None}
        timing = {"samples": 0, "held": False, "lag": start_lag}
        estimate = {"natural_frequency_rad_s": start_w, "damping": 1.0, "searched": True}
        report, timing, estimate = _refined(prepared, layout, taps, report, timing, estimate, refine_lag=True,
                                            refine_damping=True)
        best = _refined(prepared, layout, taps, {"tau_s": t.report_filter, "evidence": None, "cost_by_tau": None},
                        {"samples": 0, "held": False, "lag": 0.5 / t.control_per_log},
                        {"natural_frequency_rad_s": t.pll_bandwidth, "damping": 1.0, "searched": True},
                        refine_lag=True, refine_damping=True)

        def cost(tau, pll, lag):
            return _basis_cost(_with_delay(_with_pll(_with_report(prepared, tau), pll, taps), 0, lag), layout, taps)[0]

        tol = 5 * 2e-3
        assert report["tau_s"] == pytest.approx(best[0]["tau_s"], rel=tol)
        assert estimate["natural_frequency_rad_s"] == pytest.approx(best[2]["natural_frequency_rad_s"], rel=tol)
        assert estimate["damping"] == pytest.approx(best[2]["damping"], rel=tol)
        assert timing["lag"] == pytest.approx(best[1]["lag"], abs=tol)
        w_c, z_c = _continuous_pll(t)
        assert estimate["natural_frequency_rad_s"] == pytest.approx(w_c, rel=0.1)
        assert estimate["damping"] == pytest.approx(z_c, rel=0.1)
        assert report["tau_s"] == pytest.approx(t.report_filter, rel=0.05)
        assert estimate["refined"] and report["refined"]
        pll = (estimate["natural_frequency_rad_s"], estimate["damping"])
        assert cost(report["tau_s"], pll, timing["lag"]) < cost(start_tau, (start_w, 1.0), start_lag)


def test_a_pll_and_a_report_filter_read_from_the_logs():
    """The whole reading (:func:`pgcomm.rotary.readings.read_logs`) on a twin's first round of running logs with a
    drive PLL and a filtered report only, where reading the PLL before the filter settles at the grid's fast end with
    the current held (3560 rad/s, 25 ms): the PLL within 10 % of the twin's, the current smooth within a sixteenth of
    a sample of its lag, the filter within 2 % of where a refinement from the twin's own reading ends (the valley
    along which the filter and the lag trade is flat) and within 5 % of the twin's. A PLL given rather than searched
    is held through the joint refinement (a second formulation: the angle corrected for it first)."""
    from pgcomm.rotary.identify import _guard
    from pgcomm.rotary.readings import _refined, _with_pll, read_logs
    from pgcomm.rotary.regression import _Layout, _prepare, angle_parts_kept

    off = dict(host_jitter=0.0, host_gaps=0.0, stamp_noise=0.0, sensor_offset=(0.0, 0.0), sensor_gain=(0.0, 0.0),
               deadtime_error=0.0, deadtime_width=0.0)
    t = replace(draw_rotary(0, 0, real_drive=True), **off)
    orders, logs = _quick_round(t)
    options = RotaryIdentifyOptions()
    min_samples, taps = _guard(options)
    with angle_parts_kept():
        prepared = _prepare(logs, t.motor, orders, min_samples, taps, options.encoder_step)[0]
        estimate, timing, report = read_logs(prepared, orders, taps, options.encoder_step, "detect", "detect")
        layout = _Layout.of(orders)
        floor = _refined(prepared, layout, taps, {"tau_s": t.report_filter, "evidence": None, "cost_by_tau": None},
                         {"samples": 0, "held": False, "lag": 0.5 / t.control_per_log},
                         {"natural_frequency_rad_s": t.pll_bandwidth, "damping": 1.0, "searched": True},
                         refine_lag=True, refine_damping=True)[0]
        # a PLL given (not searched) is held in the joint refinement: the same refinement as on the angle corrected
        # for it beforehand
        pll = (t.pll_bandwidth, 1.0)
        start = ({"tau_s": 1.3 * t.report_filter, "evidence": None, "cost_by_tau": None},
                 {"samples": 0, "held": False, "lag": 0.2})
        given = _refined(prepared, layout, taps, *start, {"natural_frequency_rad_s": pll[0], "damping": pll[1],
                                                          "searched": False}, refine_lag=True)
        corrected = _refined(_with_pll(prepared, pll, taps), layout, taps, *start,
                             {"natural_frequency_rad_s": None, "damping": None, "searched": False}, refine_lag=True)
    assert given[0]["tau_s"] == pytest.approx(corrected[0]["tau_s"], rel=1e-6)
    assert given[1]["lag"] == pytest.approx(corrected[1]["lag"], abs=1e-6)
    assert given[2]["natural_frequency_rad_s"] == pll[0]
    w_c, z_c = _continuous_pll(t)
    assert estimate["natural_frequency_rad_s"] == pytest.approx(w_c, rel=0.1)
    assert estimate["damping"] == pytest.approx(z_c, rel=0.1)
    assert report["tau_s"] == pytest.approx(floor["tau_s"], rel=0.02)
    assert report["tau_s"] == pytest.approx(t.report_filter, rel=0.05)
    # the drive controls 8 times per logged sample: a snapshot half a control cycle late
    assert t.control_per_log == 8 and not timing["held"] and timing["samples"] == 0
    assert abs(timing["lag"] - 1.0 / 16.0) <= 1.0 / 16.0


def test_the_report_filters_sentence_says_whether_it_was_read_or_given():
    """The sentence on the current's report filter, for a filter read from the logs (with its likelihood ratio), one
    given (``--current-filter``: no ratio to give) and none."""
    from pgcomm.rotary.readings import filter_text

    assert filter_text({"tau_s": 0.088, "evidence": 446.0, "cost_by_tau": {}}).endswith(
        "a first-order lag of 88 ms, read back as i = i_logged + tau di/dt (likelihood ratio 446 over the current as "
        "logged)")
    assert filter_text({"tau_s": 0.08, "evidence": None, "cost_by_tau": None}).endswith(
        "a first-order lag of 80 ms, read back as i = i_logged + tau di/dt (as given)")
    assert filter_text({"tau_s": 0.0, "evidence": None, "cost_by_tau": None}) == \
        "the logged q-current is the current that acted (as given)"
    assert filter_text({"tau_s": 0.0, "evidence": 3.0, "cost_by_tau": {}}).endswith("(no report filter fits better)")
    assert filter_text(None) is None


def test_too_few_windows_says_where_the_windows_went(motor0):
    """Logs too short for the model: the refusal counts the windows (``n - span + 1`` starts every ``taps // 2``
    samples per log, ``span = taps + 2``), those the guards refused, and the pieces too short for one window (a log
    split at its gaps)."""
    from pgcomm.rotary.regression import FILTER_TAPS

    t, logs = motor0
    keys = ("t", "theta", "iq_1")
    # from the middle of each log, at its speed
    cut = [{k: np.asarray(lg[k])[np.size(lg["theta"]) // 2:][:24] for k in keys} for lg in logs]
    cut.append({k: np.asarray(logs[0][k])[-5:] for k in keys})
    span, stride = FILTER_TAPS + 2, FILTER_TAPS // 2
    windows = sum(len(range(0, lg["theta"].size - span + 1, stride)) for lg in cut if lg["theta"].size >= span + 2)
    said = (rf"usable windows for \d+ unknowns: .*; of {windows} windows, \d+ too fast for the alias guard and \d+ near "
            rf"standstill or reversing .*; 1 of {len(cut)} logs or pieces between gaps \(5 of {24 * len(logs) + 5} "
            rf"samples\) are shorter than one window \({FILTER_TAPS + 4} samples\)")
    with pytest.raises(ExcitationError, match=said):
        identify(cut, t.motor)
