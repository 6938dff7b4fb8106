"""The slot count from running logs (:mod:`pgcomm.rotary.slots`), for motors whose description leaves it out.

Against the twin's truth on zoo motors with the quick running logs (a few seconds each): the cogging fundamental
``LCM(Q, 2p)`` and the slot count are the truth's (9N6P, 12N8P, 12N14P: the last has 84 slots beside 12 with
the same fundamental, which only the slot sidebands tell apart); a motor without cogging gets no invented
fundamental. Through the CLI, a motor TOML without ``slots`` gives the same compensation table as with them
(same orders, same fit: equal to the CSV's rounding), and ``reproduce``, which builds a twin, asks for them.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pgcomm.errors import ExcitationError
from pgcomm.rotary.experiment import quick_settings, running_log, running_references
from pgcomm.rotary.regression import Orders
from pgcomm.rotary.model import Fourier
from pgcomm.rotary.slots import detect_slots
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
