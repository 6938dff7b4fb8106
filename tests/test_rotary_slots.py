"""The slot count from running logs (:mod:`pgcomm.rotary.slots`), for motors whose description leaves it out.

Against the twin's truth on zoo motors with the quick running logs (a few seconds each): the cogging fundamental
``LCM(Q, 2p)`` and the slot count are the truth's (9N6P, 12N8P, 12N14P: the last has 84 slots beside 12 with
the same fundamental, which only the slot sidebands tell apart); a motor without cogging gets no invented
fundamental. Through the CLI, a motor TOML without ``slots`` gives the same compensation table as with them
(same orders, same fit: equal to the CSV's rounding), and ``reproduce``, which builds a twin, asks for them.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pgcomm.errors import ExcitationError
from pgcomm.rotary.experiment import quick_settings, running_log, running_references
from pgcomm.rotary.regression import Orders
from pgcomm.rotary.model import Fourier
from pgcomm.rotary.slots import HELD_OUT_OVERRULE, detect_slots
from pgcomm.rotary.twin import LawParams, default_gains
from pgcomm.rotary.zoo import draw_rotary

from _drive_pll import pll_and_late, rewrite_logs, with_sensor_pickup


def _logs(truth):
    m = truth.motor
    a = truth.inertia / truth.k0
    refs = running_references(m, a, quick_settings(), Orders.for_motor(m))
    return [running_log(truth, r, LawParams.classical(m.pole_pairs), default_gains(a), k) for k, r in enumerate(refs)]


@pytest.mark.parametrize("index, held", [(0, False), (1, False), (3, False), (0, True)])
def test_the_logs_give_the_cogging_fundamental_and_the_slots(index, held):
    """The zoo's drives control several times per logged sample: their logs, read as the smooth curve through the
    snapshots ``1/(2K)`` of a sample late (what the identification's reading finds), give the truth's count; read as
    held from sample to sample, they show orders the motor does not have (9N6P: 18 slots counted for 9). A drive that
    controls at its log rate (``held``), read held, gives it too."""
    truth = draw_rotary(0, index)
    if held:
        truth = replace(truth, control_per_log=1)
    m = truth.motor
    logs = _logs(truth)
    lag = None if held else 0.5 / truth.control_per_log
    q, info = detect_slots(logs, m.pole_pairs, m.sample_time, current_lag=lag)
    assert info["cogging_fundamental"] == m.cogging_fundamental
    assert q == m.slots, info
    assert m.cogging_fundamental in info["orders_seen"]
    assert m.slots in info["slots_with_that_fundamental"]
    if index == 0 and not held:
        assert detect_slots(logs, m.pole_pairs, m.sample_time)[0] != m.slots  # the failure the reading is for


def test_no_cogging_no_invented_fundamental():
    truth = replace(draw_rotary(0, 0), cogging=Fourier.zeros([]))
    with pytest.raises(ExcitationError, match="no cogging fundamental .* set slots in the motor TOML"):
        detect_slots(_logs(truth), truth.motor.pole_pairs, truth.motor.sample_time)


def test_identify_without_slots_gives_the_same_table(tmp_path):
    import json

    from pgcomm.cli import main
    from pgcomm.export.angle_table import read_angle_table

    assert main(["zoo", "--kind", "rotary", "--motors", "1", "--logs", "--out", str(tmp_path / "z"), "--quiet"]) == 0
    folder = tmp_path / "z" / "motor_01"
    text = (folder / "motor.toml").read_text()
    (folder / "noslots.toml").write_text("".join(l for l in text.splitlines(True) if not l.startswith("slots")))
    logs = str(folder / "logs" / "*.csv")
    for name, motor in (("with", "motor.toml"), ("without", "noslots.toml")):
        assert main(["identify", "--motor", str(folder / motor), "--data", logs, "--out", str(tmp_path / name),
                     "--quiet"]) == 0
    a = read_angle_table(tmp_path / "with" / "compensation.csv").iq
    b = read_angle_table(tmp_path / "without" / "compensation.csv").iq
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-9 * np.max(np.abs(a)))
    res = json.loads((tmp_path / "without" / "results.json").read_text())
    assert res["motor"]["slots"] == 9 and res["slots_detected"]["cogging_fundamental"] == 18
    # the zoo's drive logs snapshots: counted again on the current read smooth, 1/(2K) of a sample late
    from pgcomm.io.rotary_zoo import read_truth

    k = read_truth(folder / "truth.json").control_per_log
    assert k > 1 and res["slots_detected"]["counted_after_reading"] is True
    assert res["slots_detected"]["read_with"]["current_lag"] == pytest.approx(1 / (2 * k), abs=1 / 64)
    page = (tmp_path / "without" / "report.html").read_text()
    assert "Slot count not in the motor description" in page
    assert "the current read as the smooth curve through its snapshots" in page  # what the count was taken on


def test_slots_are_counted_on_the_logs_as_read(tmp_path):
    """A drive's log with the angle its PLL estimates (ODrive's, 1000 rad/s) and the q-current a sample late: counted
    as written, the cogging's orders fade and 18 slots came out for the 9N6P motor's 9; identify reads the logs first
    (the PLL, the delay) and counts again on them, so the slot count and the table are those of the motor TOML that
    gives the slots, within a millionth of the table's peak (the same readings, the same fit)."""
    import json

    from pgcomm.cli import main
    from pgcomm.export.angle_table import read_angle_table

    assert main(["zoo", "--kind", "rotary", "--motors", "1", "--logs", "--out", str(tmp_path / "z"), "--quiet"]) == 0
    folder = tmp_path / "z" / "motor_01"
    text = (folder / "motor.toml").read_text()
    (folder / "noslots.toml").write_text("".join(l for l in text.splitlines(True) if not l.startswith("slots")))
    made = [str(p) for p in rewrite_logs(sorted((folder / "logs").glob("*.csv")), tmp_path, "drive",
                                          lambda c: np.column_stack(pll_and_late(c)), fmt="%.12g")]
    for name, motor in (("with", "motor.toml"), ("without", "noslots.toml")):
        assert main(["identify", "--motor", str(folder / motor), "--data", *made, "--out", str(tmp_path / name),
                     "--quiet"]) == 0
    res = json.loads((tmp_path / "without" / "results.json").read_text())
    assert res["motor"]["slots"] == 9 and res["slots_detected"]["counted_after_reading"] is True
    a = read_angle_table(tmp_path / "with" / "compensation.csv").iq
    b = read_angle_table(tmp_path / "without" / "compensation.csv").iq
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-6 * np.max(np.abs(a)))


def test_slots_are_counted_with_a_time_periodic_disturbance_fitted(tmp_path):
    """A current sensor's 50 Hz pickup (1 % of the current limit) in the quick running logs of zoo motor 24N20P (seed
    0): counted with it, the pickup at two speeds spreads over orders and 120 slots come out for 24; identify finds
    the line with the first count's basis and counts again with it fitted, so the slot count and the table are those
    of the motor TOML that gives the slots, within a millionth of the table's peak (the same lines, the same fit)."""
    import json

    from pgcomm.cli import main
    from pgcomm.export.angle_table import read_angle_table
    from pgcomm.io.rotary_zoo import write_rotary_motor

    t = draw_rotary(0, 5)
    m = t.motor
    logs = with_sensor_pickup(t, running_references(m, t.inertia / t.k0, quick_settings(), Orders.for_motor(m)),
                              0.01 * m.current_limit, 50.0)
    assert detect_slots(logs, m.pole_pairs, m.sample_time)[0] != m.slots  # the failure the fix is for
    toml = write_rotary_motor(t, tmp_path / "m") / "motor.toml"
    text = toml.read_text()
    (tmp_path / "noslots.toml").write_text("".join(l for l in text.splitlines(True) if not l.startswith("slots")))
    made = []
    for k, lg in enumerate(logs):
        made.append(tmp_path / f"run{k}.csv")
        np.savetxt(made[-1], np.column_stack([lg["t"], lg["theta"], lg["iq_1"]]), delimiter=",", fmt="%.15g",
                   header="t,theta,iq_1", comments="")
    for name, motor in (("with", toml), ("without", tmp_path / "noslots.toml")):
        assert main(["identify", "--motor", str(motor), "--data", *map(str, made), "--out", str(tmp_path / name),
                     "--quiet"]) == 0
    res = json.loads((tmp_path / "without" / "results.json").read_text())
    assert res["motor"]["slots"] == m.slots and res["slots_detected"]["counted_with_time_lines"]
    a = read_angle_table(tmp_path / "with" / "compensation.csv").iq
    b = read_angle_table(tmp_path / "without" / "compensation.csv").iq
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-6 * np.max(np.abs(a)))


def test_reproduce_needs_the_slots(tmp_path, capsys):
    from pgcomm.cli import main

    (tmp_path / "m.toml").write_text('kind = "rotary"\npole_pairs = 3\nsample_time = 0.001\n')
    assert main(["reproduce", "--motor", str(tmp_path / "m.toml"), "--quick", "--out", str(tmp_path / "o")]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "key 'slots' missing" in err[0] and "Traceback" not in err[0]
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("slots, pole_pairs, built", [
    (9, 3, True), (12, 4, True), (12, 5, True), (12, 7, True), (18, 8, True), (24, 10, True), (24, 11, True),
    (36, 21, True), (9, 6, True), (36, 2, True), (27, 15, True),  # made: the zoo's, 9N12P, integer-slot, a joint's
    (12, 3, False), (6, 3, False), (24, 6, False),  # no three phases 120° apart: Q / (3 gcd(Q, p)) not whole
    (3, 7, False), (9, 7, False), (15, 11, False)])  # balanced, but under a quarter slot per pole and phase
def test_a_count_is_one_a_motor_can_be_wound_with(slots, pole_pairs, built):
    """Known motors (9N6P to 36N42P, 9N12P, the integer-slot 36N4P) can be wound; 12N6P, 6N6P and 24N12P cannot
    give three balanced phases, and 3N14P, 9N14P, 15N22P put a tooth across more than a pole pair (a quarter slot per
    pole and phase is the least fractional-slot motors are built with)."""
    from pgcomm.rotary.slots import winding_exists

    assert winding_exists(slots, pole_pairs) is built


def test_a_counts_held_out_mean_square_is_that_of_its_own_fit():
    """Each count's held-out mean square comes from columns of the every-order fit's normal equations; the second
    formulation builds the count's own layout and normal equations from the logs and validates its ridge: the two agree
    to rounding (the same rows and products, the Fourier columns' recurrence over another set of orders: ~1e-13 of a
    column, which the ridge's solve at the chosen weight amplifies by its condition number, well under 1e7 here)."""
    from pgcomm.rotary.model import cogging_orders, direction_orders, drive_orders, ripple_orders
    from pgcomm.rotary.motor import RotaryMotor
    from pgcomm.rotary.regression import FILTER_TAPS, MIN_SAMPLES_PER_PERIOD, _Layout, _normal_equations, _prepare, \
        _validated_ridge
    from pgcomm.rotary.slots import _held_out

    truth = draw_rotary(0, 1)
    m = truth.motor
    p, top = m.pole_pairs, 60
    logs = _logs(truth)
    ripple = ripple_orders(None, p)
    every = Orders(np.arange(1, top + 1), ripple[ripple <= top], direction_orders(p))
    prepared = _prepare(logs, RotaryMotor(pole_pairs=p, sample_time=m.sample_time), every, MIN_SAMPLES_PER_PERIOD,
                        FILTER_TAPS)[0]
    G, b, yy, n, _ = _normal_equations(prepared, _Layout.of(every), FILTER_TAPS)
    held = _held_out((G, b, yy, n), _Layout.of(every), p, top)
    assert held["same_as"][m.slots] == m.slots
    shared = {1, 2} | set(range(2 * p, top + 1, 2 * p)) | {int(h) for h in drive_orders(p) if h <= top}
    for q in (m.slots, 15, 21):
        own = Orders(np.array(sorted({int(h) for h in cogging_orders(q, p) if h <= top} | shared)), every.ripple,
                     every.direction)
        lay = _Layout.of(own)
        G2, b2, yy2, n2, _ = _normal_equations(prepared, lay, FILTER_TAPS)
        direct = min(_validated_ridge(G2, b2, yy2, n2, lay.pen[lay.keep].astype(float))[1])
        assert held["mse"][held["same_as"][q]] == pytest.approx(direct, rel=1e-6), q


REAL = Path(__file__).resolve().parents[2] / "shared" / "real" / "odrive_cogging"


#: The count of the real log as a script runs it (one JSON line: the count, the order examined, the held-out share).
REAL_COUNT = """
import json, sys
from pathlib import Path
from pgcomm.io.logs import ROTARY_REQUIRED, read_logs
from pgcomm.progress import Progress
from pgcomm.rotary.from_logs import _segments
from pgcomm.rotary.motor import RotaryMotor
from pgcomm.rotary.slots import count_slots

mapping = {"columns": {"t": "time_s", "theta": "pos_estimate_counts", "iq_1": "Iq_measured_A"},
           "units": {"theta": "counts"}, "options": {"encoder_counts": 8192}}
logs = read_logs([Path(sys.argv[1])], columns=mapping, required=ROTARY_REQUIRED, gaps=True, stamps=True)
q, info = count_slots(_segments(logs, False, Progress(enabled=False)), RotaryMotor(pole_pairs=7, sample_time=0.0023))
print(json.dumps({"slots": q, "info": info}, default=float))
"""


def _real_count(threads: str) -> dict:
    """The count of ``slow2__nocomp_0`` in a fresh process whose BLAS runs ``threads`` threads."""
    import json
    import os
    import subprocess
    import sys

    env = {**os.environ, "OPENBLAS_NUM_THREADS": threads, "OMP_NUM_THREADS": threads}
    run = subprocess.run([sys.executable, "-c", REAL_COUNT, str(REAL / "logs" / "slow2__nocomp_0.csv")], env=env,
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-2000:]
    return json.loads(run.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(not (REAL / "logs").is_dir(), reason="the shared real logs are not beside the checkout")
def test_a_real_motor_whose_fundamental_does_not_show_is_counted_by_its_held_out_blocks():
    """A real 12N14P outrunner on an ODrive (0.1 rev/s, host stamps, the angle a PLL's): the orders seen show no slot
    count's fundamental (84 does not pass; 7, 12, 28, 36 do), and the count was refused. The held-out time blocks
    give the datasheet's 12: its basis leaves a fraction of what the next count's and the poles' alone leave.

    The count is the same whatever the summation order of the fit's sums (a second formulation of them: the BLAS
    on one thread and on two). Ten seconds at 0.1 rev/s resolve orders to 626 in time, but 714 windows do not
    determine 1273 unknowns; fitted all the same, the count came out 12 on one thread and was refused on two. The
    count examines the orders its windows determine (at least two per unknown), and the next order would not be."""
    from pgcomm.rotary.regression import FILTER_TAPS, MIN_SAMPLES_PER_PERIOD, _Layout, steps_at_speed
    from pgcomm.rotary.slots import COUNT_WINDOWS_PER_UNKNOWN, _every_order

    one, two = _real_count("1"), _real_count("2")
    q, info = one["slots"], one["info"]
    assert q == 12 and info["chosen_by"] == "held-out blocks", info
    held = info["held_out"]
    assert held["unexplained"] < HELD_OUT_OVERRULE * min(held["next"]["unexplained"], held["poles_alone"])
    # the counts agree; the held-out share to a millionth (rounding moves a determined fit's by ~1e-12; the
    # undetermined fit's moved by tens of percent)
    assert two["slots"] == q and two["info"]["highest_order_examined"] == info["highest_order_examined"]
    assert two["info"]["held_out"]["unexplained"] == pytest.approx(held["unexplained"], rel=1e-6)
    from pgcomm.io.logs import ROTARY_REQUIRED, read_logs
    mapping = {"columns": {"t": "time_s", "theta": "pos_estimate_counts", "iq_1": "Iq_measured_A"},
               "units": {"theta": "counts"}, "options": {"encoder_counts": 8192}}
    logs = read_logs([REAL / "logs" / "slow2__nocomp_0.csv"], columns=mapping, required=ROTARY_REQUIRED, gaps=True,
                     stamps=True)
    steps = steps_at_speed(logs, 0.0023, FILTER_TAPS)

    def windows_per_unknown(h):
        kept = np.sum(steps <= 2 * np.pi / (MIN_SAMPLES_PER_PERIOD * h))
        return kept / _Layout.of(_every_order(h, 7), (), len(logs)).keep.sum()

    top = info["highest_order_examined"]
    assert top < 626
    assert windows_per_unknown(top) >= COUNT_WINDOWS_PER_UNKNOWN > windows_per_unknown(top + 1)


@pytest.mark.skipif(not (REAL / "logs").is_dir(), reason="the shared real logs are not beside the checkout")
def test_a_log_too_short_for_the_orders_it_resolves_is_refused_as_short():
    """The first 0.9 s of the real 0.1 rev/s log resolve orders far beyond 2p = 14 in time, but their windows determine
    no fit to order 14: the count is refused as too short (one line, the orders the windows determine), not as too
    fast. The order the bisection finds is a linear scan's (the highest order with two windows per unknown)."""
    from pgcomm.io.logs import ROTARY_REQUIRED, read_logs
    from pgcomm.progress import Progress
    from pgcomm.rotary.from_logs import _segments
    from pgcomm.rotary.regression import FILTER_TAPS, MIN_SAMPLES_PER_PERIOD, _Layout, steps_at_speed
    from pgcomm.rotary.slots import COUNT_WINDOWS_PER_UNKNOWN, _determined_order, _every_order, _highest_order

    mapping = {"columns": {"t": "time_s", "theta": "pos_estimate_counts", "iq_1": "Iq_measured_A"},
               "units": {"theta": "counts"}, "options": {"encoder_counts": 8192}}
    (log,) = _segments(read_logs([REAL / "logs" / "slow2__nocomp_0.csv"], columns=mapping, required=ROTARY_REQUIRED,
                                 gaps=True, stamps=True), False, Progress(enabled=False))
    n = log["theta"].size
    short = [{k: (v[:400] if isinstance(v, np.ndarray) and v.shape[:1] == (n,) else v) for k, v in log.items()}]
    resolved = _highest_order(short, 0.0023)
    assert resolved > 14
    steps = steps_at_speed(short, 0.0023, FILTER_TAPS)
    scan = max([h for h in range(1, resolved + 1)
                if np.sum(steps <= 2 * np.pi / (MIN_SAMPLES_PER_PERIOD * h))
                >= COUNT_WINDOWS_PER_UNKNOWN * _Layout.of(_every_order(h, 7), (), 1).keep.sum()], default=0)
    assert _determined_order(short, 7, 0.0023, resolved, 0) == scan < 14
    with pytest.raises(ExcitationError) as e:
        detect_slots(short, 7, 0.0023)
    msg = str(e.value)
    assert "too short" in msg and f"orders to {scan} " in msg and "\n" not in msg
