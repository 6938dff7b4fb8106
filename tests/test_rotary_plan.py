"""``pgcomm plan`` on a rotary motor: the speeds against the alias guard, the dither against its closed form, the
drives' scripts against the log reader, and the next round's durations against the identification's standard errors.

Closed forms the tests check (:mod:`pgcomm.rotary.plan`):

* the alias guard ``ω_max = 2π / (T_s · 3 · h_max)``, ``h_max`` from the slot/pole arithmetic (``3 LCM(Q, 2p)``,
  ``12p``, ``Q``), computed here without :class:`pgcomm.rotary.regression.Orders`;
* the dither's speed swing on a free rotor, ``Δω(τ) = Σ a_k sin(2π f_k τ) / ((J/k0) 2π f_k)``, against the dither
  of the written reference file integrated by the trapezoid rule: the rule's error on ``cos(2π f τ)`` over a step
  ``T_s`` is at most ``(2π f T_s)² / 12`` of the integral's scale per unit, so the tolerance is
  ``Σ a_k (2π f_k T_s)² / 12 / ((J/k0) 2π f_k)`` times the number of periods plus a step's worth of amplitude
  (the reference starts its cruise on the sample grid, not at the ramp's exact end).
"""

from __future__ import annotations

import ast
import csv
import json
import math
import py_compile
import re
import sys
import types
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pgcomm.cli import main
from pgcomm.io.config import rotary_motor_to_toml
from pgcomm.io.logs import ROTARY_REQUIRED, load_column_mapping, read_log
from pgcomm.io.rotary_plan import script_text
from pgcomm.rotary.motor import RotaryMotor
from pgcomm.rotary.plan import (DRIVE_COLUMNS, FirstRound, RotaryPlanSettings, dither_frequencies, first_plan,
                                refined_plan, swing_bound)

#: Motors of the tables: a light 9N6P, the shared ODrive's 12N14P (its k_t and inertia), a 36N42P, and a 12N14P
#: without slots, inertia or limit; at a drive's 1 ms and a USB host's 2.3 ms.
MOTORS = {
    "9N6P": RotaryMotor(pole_pairs=3, slots=9, sample_time=1e-3, k_t=0.97, inertia=4.2e-3, current_limit=17.5),
    "12N14P": RotaryMotor(pole_pairs=7, slots=12, sample_time=2.3e-3, k_t=0.0551, inertia=2.5e-4, current_limit=10.0),
    "36N42P": RotaryMotor(pole_pairs=21, slots=36, sample_time=1e-3, k_t=0.3, inertia=1e-4, current_limit=20.0),
    "heavy": RotaryMotor(pole_pairs=4, slots=12, sample_time=1e-3, k_t=0.1, inertia=0.5, current_limit=5.0),
    "unknown": RotaryMotor(pole_pairs=7, sample_time=1e-3),
}


def _highest(motor: RotaryMotor) -> int:
    """The highest modelled order from the slot/pole arithmetic (1024 without the slots: the slot count's search)."""
    if motor.slots is None:
        return 1024
    q, p = motor.slots, motor.pole_pairs
    return max(3 * math.lcm(q, 2 * p), 12 * p, 6 * p, q)


@pytest.mark.parametrize("name", MOTORS)
def test_speeds_respect_the_alias_guard_in_both_directions(name):
    motor = MOTORS[name]
    plan = first_plan(motor)
    st = plan.settings
    v_lim = 2 * math.pi / (motor.sample_time * 3 * _highest(motor))
    assert plan.speed_limit == pytest.approx(v_lim, rel=1e-12)
    speeds = sorted({abs(r.speed) for r in plan.runs})
    assert len(speeds) == st.speeds
    for w in speeds:  # both directions at every speed
        assert sorted(np.sign(r.speed) for r in plan.runs if abs(r.speed) == w) == [-1.0, 1.0]
    # the fastest at top_share of the guard's limit (a host's clock), within the guard's margin with the dither's
    # largest swing; where top_share is no bound, at that margin
    assert speeds[0] / speeds[-1] == pytest.approx(st.lowest_share, rel=1e-12)
    assert speeds[-1] == pytest.approx(st.top_share * v_lim, rel=1e-12)
    assert speeds[-1] * (1 + st.swing) <= st.guard_margin * v_lim
    free = first_plan(motor, replace(st, top_share=1.0))
    assert max(abs(r.speed) for r in free.runs) * (1 + st.swing) == pytest.approx(st.guard_margin * v_lim, rel=1e-12)
    for r in plan.runs:
        ref = r.reference(plan.sample_time)
        assert np.max(np.abs(ref["speed"])) <= abs(r.speed) * (1 + 1e-12)
        top = np.max(np.abs(ref["speed"])) + swing_bound(r, plan.inertia_ratio)
        assert top <= st.guard_margin * v_lim * (1 + 1e-12)


@pytest.mark.parametrize("name", ["9N6P", "12N14P", "36N42P", "heavy"])
def test_the_dither_keeps_the_speed_sign(tmp_path, name):
    """The written reference's dither, integrated over (J/k0), against the closed form; the swing within the share."""
    motor = MOTORS[name]
    path = tmp_path / "motor.toml"
    path.write_text(rotary_motor_to_toml(motor))
    assert main(["plan", "--motor", str(path), "--drive", "generic", "--out", str(tmp_path / "p"), "--quiet"]) == 0
    doc = json.loads((tmp_path / "p" / "plan.json").read_text())
    a = motor.inertia / motor.k_t
    assert doc["inertia_ratio_A_s2_per_rad"] == pytest.approx(a, rel=1e-12)
    ts, st = doc["sample_time_s"], RotaryPlanSettings()
    n_f = len(doc["runs"][0]["dither_hz"])
    for run in doc["runs"]:
        amp, f = np.array(run["dither_amplitude_A"]), np.array(run["dither_hz"])
        w = run["speed_rad_s"]
        assert np.all(amp > 0)
        # each amplitude within both caps, the binding one reached
        cap_swing = st.swing * abs(w) * a * 2 * np.pi * f / n_f
        cap_current = st.dither_share * motor.current_limit / n_f
        assert np.all(amp <= np.minimum(cap_swing, cap_current) * (1 + 1e-12))
        np.testing.assert_allclose(amp, np.minimum(cap_swing, cap_current), rtol=1e-12)
        bound = float(np.sum(amp / (a * 2 * np.pi * f)))
        assert bound == pytest.approx(run["swing_bound_rad_s"], rel=1e-12)
        assert bound <= st.swing * abs(w) * (1 + 1e-12)
        ref = np.loadtxt(tmp_path / "p" / run["reference"], delimiter=",", skiprows=1)
        t, dither = ref[:, 0], ref[:, 2]
        on = (t - run["ramp_s"] >= 0) & (t - run["ramp_s"] < run["cruise_s"])
        assert np.all(dither[~on] == 0) and np.all(dither[on] != 0)
        tau = t[on] - run["ramp_s"]
        dw = np.concatenate([[0.0], np.cumsum(0.5 * (dither[on][1:] + dither[on][:-1]) * np.diff(t[on]))]) / a
        closed = np.sum(amp[:, None] * np.sin(2 * np.pi * f[:, None] * tau) / (a * 2 * np.pi * f[:, None]), axis=0)
        periods = tau[-1] * f
        tol = float(np.sum(amp / (a * 2 * np.pi * f) * ((2 * np.pi * f * ts) ** 2 / 12 * periods + 2 * np.pi * f * ts)))
        np.testing.assert_allclose(dw, closed, rtol=0, atol=tol)
        # the speed keeps its sign, and stays within the guard's margin
        assert np.min(abs(w) + np.sign(w) * closed) >= (1 - st.swing) * abs(w) * (1 - 1e-9)
        assert abs(w) + np.max(np.abs(closed)) <= doc["speed_limit_rad_s"] * st.guard_margin * (1 + 1e-9)
    if name == "heavy":  # the current limit binds: the swing stays below its share
        assert any(r["swing_bound_rad_s"] < 0.99 * st.swing * abs(r["speed_rad_s"]) for r in doc["runs"])


@pytest.mark.parametrize("ts", [1e-4, 1e-3, 2.3e-3, 5e-3, 2e-2])
def test_dither_frequencies_stay_off_the_mains_harmonics(ts):
    st = RotaryPlanSettings()
    f = np.array(dither_frequencies(ts, st))
    assert 1 <= f.size <= st.dither_count and np.all(np.diff(f) > 0)
    assert f.max() <= min(110.0, 1 / (8 * ts)) and f.max() < 2 * f.min()  # an octave: no harmonic of another
    for mains in (50.0, 60.0):
        k = np.maximum(np.round(f / mains), 1)
        assert np.all(np.abs(f - k * mains) >= st.mains_margin_hz)


def test_a_motor_without_inertia_gets_a_first_round_without_dither_and_says_so(tmp_path):
    path = tmp_path / "motor.toml"
    path.write_text(rotary_motor_to_toml(MOTORS["unknown"]))
    assert main(["plan", "--motor", str(path), "--drive", "generic", "--out", str(tmp_path / "p"), "--quiet"]) == 0
    doc = json.loads((tmp_path / "p" / "plan.json").read_text())
    assert doc["inertia_ratio_A_s2_per_rad"] is None and doc["highest_order"] == 1024
    assert all(a == 0 for r in doc["runs"] for a in r["dither_amplitude_A"])
    text = (tmp_path / "p" / "plan.md").read_text()
    assert "No dither: J/k0 is not known" in text and "no slot count" in text
    assert "a default, not a standard error" in text


# --------------------------------------------------------------------------- the refined round, closed form


def _first(seconds=40.0, ts=1e-3, factors=(1.0, 4.0, 1.0), ratio=4.5e-3, slots=None):
    se = {m: {"relative": 0.03 * math.sqrt(f), "resolved": f <= 1.0, "log_time_factor_to_resolve": f}
          for m, f in zip(("cogging", "ripple", "direction"), factors)}
    return FirstRound(seconds, ts, ratio, slots, se, {m: "verdict" for m in se})


def test_the_next_round_is_what_the_standard_errors_ask_for():
    motor = MOTORS["9N6P"]
    first = _first(factors=(1.3, 4.0, 1.0))
    plan = refined_plan(motor, first)
    # (F - 1) x the first round's log time, F the largest finite factor (the ripple's)
    assert plan.need["factor"] == 4.0 and plan.need["driver"] == "ripple"
    assert plan.need["seconds"] == pytest.approx(3.0 * first.seconds, rel=1e-12)
    assert plan.duration == pytest.approx(plan.need["seconds"], rel=1e-9)
    # the dither from the TOML's inertia / k_t where it has them (a note where the logs disagree), else the identified
    assert plan.inertia_ratio == motor.inertia / motor.k_t and not any("J/k0 =" in n for n in plan.notes)
    far = refined_plan(motor, replace(first, inertia_ratio=0.25 * motor.inertia / motor.k_t))
    assert far.inertia_ratio == motor.inertia / motor.k_t and any("the dither is sized from the TOML's" in n
                                                                  for n in far.notes)
    assert refined_plan(replace(motor, inertia=None), first).inertia_ratio == first.inertia_ratio
    base = first_plan(motor)
    ratios = [r.cruise / b.cruise for r, b in zip(plan.runs, base.runs)]  # a first round's proportions
    np.testing.assert_allclose(ratios, ratios[0], rtol=1e-12)
    # a slower host: the speeds follow the period the first round's logs show
    slow = refined_plan(motor, replace(first, sample_time=2e-3))
    assert slow.speed_limit == pytest.approx(base.speed_limit / 2, rel=1e-12)
    assert slow.motor.sample_time == 2e-3


def test_maps_more_logs_do_not_resolve_are_named_and_the_cap_is_said():
    motor = MOTORS["9N6P"]
    plan = refined_plan(motor, _first(factors=(math.inf, 2.0, 1.0)))
    assert plan.need["driver"] == "ripple" and plan.need["not_by_time"] == ["cogging"]
    assert any("Not resolved by more of the same logs: the cogging" in n for n in plan.notes)
    capped = refined_plan(motor, _first(seconds=1000.0, factors=(1.0, 9.0, 1.0)))
    assert capped.need["capped"] and capped.need["seconds"] == pytest.approx(3600.0 - 1000.0, rel=1e-12)
    # the ripple's noise part at the cap: 0.03 x 3 x sqrt(1000 / 3600)
    assert any(f"near {100 * 0.09 * math.sqrt(1000 / 3600):.1f} %" in n for n in capped.notes)
    done = refined_plan(motor, _first(factors=(1.0, 1.0, 1.0)))
    assert done.runs == () and done.duration == 0.0


def test_a_first_round_without_dither_is_followed_by_one_with(tmp_path):
    """No J/k0 in the TOML: the ripple was not excited; the next round carries a dither from the identified J/k0."""
    motor = MOTORS["unknown"]
    plan = refined_plan(motor, _first(factors=(1.0, math.inf, 1.0), slots=12))
    assert plan.motor.slots == 12 and plan.highest_order == _highest(replace(motor, slots=12))
    assert plan.runs and all(a > 0 for r in plan.runs for a in r.dither_amplitude)
    base = first_plan(replace(motor, slots=12))
    assert all(r.cruise >= b.cruise * (1 - 1e-12) for r, b in zip(plan.runs, base.runs))
    assert any("had no dither" in n for n in plan.notes)


def test_a_map_the_first_round_did_not_determine_gets_the_experiment_that_does(tmp_path):
    """The identification pins a map the logs do not determine (no factor); the next round has what determines it."""
    from pgcomm.io.rotary_plan import write_rotary_plan

    motor = MOTORS["9N6P"]
    first = _first(factors=(1.0, 1.0, 1.0))
    pinned = {"resolved": False, "determined": False, "relative": None, "log_time_factor_to_resolve": None}
    first = replace(first, standard_error={**first.standard_error, "ripple": pinned},
                    verdicts={**first.verdicts, "ripple": "not determined by these logs"})
    plan = refined_plan(motor, first)
    assert plan.need["undetermined"] == ["ripple"] and plan.need["seconds"] == 0.0
    base = first_plan(motor)
    assert [r.cruise for r in plan.runs] == pytest.approx([r.cruise for r in base.runs], rel=1e-12)
    assert all(a > 0 for r in plan.runs for a in r.dither_amplitude)
    assert {np.sign(r.speed) for r in plan.runs} == {-1.0, 1.0}
    write_rotary_plan(tmp_path, plan, "generic", {"identify": "pgcomm identify", "plan": "pgcomm plan"})
    text = (tmp_path / "plan.md").read_text()
    assert "| ripple | not determined |" in text and "Not determined by the first round's logs: the ripple" in text


# --------------------------------------------------------------------------- the drives' scripts against the reader


def _plan(tmp_path, drive, motor=MOTORS["12N14P"]):
    path = tmp_path / "motor.toml"
    path.write_text(rotary_motor_to_toml(motor))
    out = tmp_path / f"plan_{drive}"
    assert main(["plan", "--motor", str(path), "--drive", drive, "--out", str(out), "--quiet"]) == 0
    return out


def _script_columns(path: Path) -> tuple:
    """The script's ``COLUMNS``, read from its syntax tree (it is not imported)."""
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "COLUMNS" for t in node.targets):
            return ast.literal_eval(node.value)
    raise AssertionError(f"{path}: no COLUMNS")


@pytest.mark.parametrize("drive", ["moteus", "odrive", "generic"])
def test_the_logging_columns_match_the_reader(tmp_path, drive):
    out = _plan(tmp_path, drive)
    mapping = load_column_mapping(out / "columns.toml")
    if drive == "generic":
        assert not (out / "run_generic.py").exists()
        written = tuple(col for col, _ in DRIVE_COLUMNS["generic"].values())
    else:
        script = out / f"run_{drive}.py"
        assert script.read_text() == script_text(drive)
        text = (out / "plan.md").read_text()
        assert f"python run_{drive}.py" in text and f"pip install {drive}" in text and "{" not in text
        ast.parse(script.read_text())
        py_compile.compile(str(script), cfile=str(tmp_path / "x.pyc"), doraise=True)
        written = _script_columns(script)
    for name in ("t", "theta", "iq_1"):  # what the rotary identification needs
        assert mapping.columns[name] in written, (name, mapping.columns)
    assert set(mapping.columns.values()) <= set(written)
    # a log made with the script's columns reads through the reader, in SI units
    n, ts = 400, 1e-3
    rng = np.random.default_rng(3)
    rev = 0.3 * np.arange(n) * ts + 0.01 * np.sin(np.arange(n) / 7)
    values = {"t": np.arange(n) * ts, "theta": rev, "velocity": np.gradient(rev, ts),
              "iq_1": rng.normal(size=n), "id_1": rng.normal(size=n)}
    unit = {name: u for name, (_, u) in DRIVE_COLUMNS[drive].items()}
    inverse = {col: name for name, col in mapping.columns.items()}
    cols = {c: values[inverse[c]] if c in inverse else rng.normal(size=n) for c in written}
    log_path = tmp_path / "log.csv"
    with open(log_path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(written)
        w.writerows(zip(*([repr(float(x)) for x in cols[c]] for c in written)))
    log = read_log(log_path, required=ROTARY_REQUIRED, columns=mapping)
    scale = 2 * math.pi if unit["theta"] == "rev" else 1.0
    np.testing.assert_allclose(log["theta"], scale * rev, rtol=1e-14, atol=0)
    np.testing.assert_allclose(log["iq_1"], values["iq_1"], rtol=0, atol=0)
    assert log.is_rotary and log.sample_time == pytest.approx(ts, rel=1e-9)


class _Clockwork:
    """A stand-in rotor for the fake drives: it follows the commanded speed and reports a current from the
    feed-forward torque, so the test can check what the script sent and logged."""

    def __init__(self, k_t):
        import time

        self.k_t, self.pos, self.vel, self.torque = k_t, 0.0, 0.0, 0.0
        self.t, self.clock = time.perf_counter(), time.perf_counter
        self.sent = []

    def advance(self):
        now = self.clock()
        self.pos += self.vel * (now - self.t)
        self.t = now


def _fake_moteus(rotor):
    mod = types.ModuleType("moteus")

    class Register:
        MODE, POSITION, VELOCITY, TORQUE, Q_CURRENT, D_CURRENT, FAULT = 0, 1, 2, 3, 4, 5, 15

    class Mode:
        FAULT, POSITION, TIMEOUT = 1, 10, 11

    class QueryResolution:
        q_current = d_current = None

    class Controller:
        def __init__(self, id=1, query_resolution=None):
            assert query_resolution.q_current == mod.F32 and query_resolution.d_current == mod.F32

        async def set_stop(self):
            rotor.vel = 0.0

        async def set_position(self, position, velocity, feedforward_torque, query=False):
            assert math.isnan(position)
            rotor.advance()
            rotor.vel, rotor.torque = velocity, feedforward_torque
            rotor.sent.append((velocity, feedforward_torque))
            values = {Register.MODE: Mode.POSITION, Register.POSITION: rotor.pos, Register.VELOCITY: rotor.vel,
                      Register.TORQUE: feedforward_torque, Register.Q_CURRENT: feedforward_torque / rotor.k_t,
                      Register.D_CURRENT: 0.0, Register.FAULT: 0}
            return types.SimpleNamespace(values=values) if query else None

    mod.Register, mod.Mode, mod.QueryResolution, mod.Controller = Register, Mode, QueryResolution, Controller
    mod.F32 = 3
    return {"moteus": mod}


def _fake_odrive(rotor):
    mod, enums = types.ModuleType("odrive"), types.ModuleType("odrive.enums")
    enums.AXIS_STATE_IDLE, enums.AXIS_STATE_CLOSED_LOOP_CONTROL = 1, 8
    enums.CONTROL_MODE_VELOCITY_CONTROL, enums.INPUT_MODE_PASSTHROUGH = 2, 1

    class Controller:
        config = types.SimpleNamespace(vel_limit=100.0, control_mode=None, input_mode=None,
                                       anticogging=types.SimpleNamespace(anticogging_enabled=False))

        def __setattr__(self, key, value):
            rotor.advance()
            if key == "input_vel":
                rotor.vel = value
            elif key == "input_torque":
                rotor.torque = value
                rotor.sent.append((rotor.vel, value))

    class Encoder:
        @property
        def pos_estimate(self):
            rotor.advance()
            return rotor.pos

    class CurrentControl:
        Id_measured = 0.0

        @property
        def Iq_measured(self):
            return rotor.torque / rotor.k_t

    axis = types.SimpleNamespace(controller=Controller(), encoder=Encoder(), error=0, requested_state=None,
                                 motor=types.SimpleNamespace(config=types.SimpleNamespace(torque_constant=rotor.k_t),
                                                             current_control=CurrentControl()))
    mod.find_any = lambda: types.SimpleNamespace(axis0=axis)
    mod.enums = enums
    return {"odrive": mod, "odrive.enums": enums}


@pytest.mark.parametrize("drive", ["moteus", "odrive"])
def test_the_script_runs_on_a_stand_in_package_and_logs_the_mapped_columns(tmp_path, drive, monkeypatch):
    """The script against a stand-in for the drive's package (CI has no drive): the commands it sends are the
    reference's speed (rev/s) and dither torque (the dither's current times k_t), its log has its COLUMNS, its time
    stamps increase, and its angle and current are the rotor's in the column map's units."""
    out = _plan(tmp_path, drive)
    doc = json.loads((out / "plan.json").read_text())
    k_t = MOTORS["12N14P"].k_t
    rotor = _Clockwork(k_t)
    for name, mod in (_fake_moteus if drive == "moteus" else _fake_odrive)(rotor).items():
        monkeypatch.setitem(sys.modules, name, mod)
    namespace = {"__name__": "plan_script", "__file__": str(out / f"run_{drive}.py")}
    exec(compile((out / f"run_{drive}.py").read_text(), str(out / f"run_{drive}.py"), "exec"), namespace)
    monkeypatch.setitem(namespace, "SETTLE_S", 0.0)
    run = doc["runs"][-1]  # the fastest, in reverse: the dither is on from its ramp's end
    seconds = run["ramp_s"] + 0.05
    argv = ["--runs", run["name"], "--max-seconds", str(seconds), "--out", str(tmp_path / "logs")]
    assert namespace["main"](argv) == 0
    log_path = tmp_path / "logs" / f"{run['name']}.csv"
    with open(log_path, newline="") as f:
        rows = list(csv.reader(f))
    assert tuple(rows[0]) == namespace["COLUMNS"] and len(rows) > 10
    data = np.array(rows[1:], float)
    t = data[:, 0]
    assert np.all(np.diff(t) > 0)
    # the log as written, host stamps and all, through the reader with the plan's column map
    mapping = load_column_mapping(out / "columns.toml")
    log = read_log(log_path, required=ROTARY_REQUIRED, columns=mapping, gaps=True, stamps=True)
    np.testing.assert_array_equal(log["t"], t)
    np.testing.assert_allclose(log["theta"], 2 * math.pi * data[:, 1], rtol=1e-15, atol=0)
    assert log.is_rotary and "iq_1" in log and "id_1" in log
    ref = np.loadtxt(out / run["reference"], delimiter=",", skiprows=1)
    speeds = set(ref[:, 1] / (2 * math.pi))
    sent = np.array(rotor.sent)
    assert set(sent[:, 0]) <= speeds | {0.0}
    # every torque sent is a value of the reference's dither times k_t
    levels = np.unique(ref[:, 2])
    near = levels[np.clip(np.searchsorted(levels, sent[:, 1] / k_t), 0, levels.size - 1)]
    below = levels[np.clip(np.searchsorted(levels, sent[:, 1] / k_t) - 1, 0, levels.size - 1)]
    gap = np.minimum(np.abs(near - sent[:, 1] / k_t), np.abs(below - sent[:, 1] / k_t))
    assert np.all(gap <= 1e-12 * np.max(np.abs(levels)))
    assert np.any(sent[:, 1] != 0)  # the dither ran
    iq = data[:, namespace["COLUMNS"].index(mapping.columns["iq_1"])]
    dither = data[:, namespace["COLUMNS"].index("dither_A")]
    np.testing.assert_allclose(iq, dither, rtol=1e-12, atol=0)  # the stand-in's current is the dither's
    sidecar = json.loads((tmp_path / "logs" / f"{run['name']}.csv.plan.json").read_text())
    assert sidecar["plan_id"] == doc["plan_id"] and sidecar["run"] == run["name"] and sidecar["rows"] == len(rows) - 1
    assert sidecar["median_step_s"] == pytest.approx(float(np.median(np.diff(t))), rel=1e-9)


@pytest.mark.parametrize("drive", ["moteus", "odrive"])
def test_the_script_without_the_drives_package_says_so_in_one_line(tmp_path, drive, monkeypatch, capsys):
    out = _plan(tmp_path, drive)
    monkeypatch.setitem(sys.modules, drive, None)  # import raises ImportError
    namespace = {"__name__": "plan_script", "__file__": str(out / f"run_{drive}.py")}
    exec(compile((out / f"run_{drive}.py").read_text(), str(out / f"run_{drive}.py"), "exec"), namespace)
    with pytest.raises(SystemExit) as e:
        namespace["main"](["--out", str(tmp_path / "logs")])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and f"the {drive} package" in err and f"pip install {drive}" in err


def test_a_script_refuses_another_drives_plan(tmp_path, capsys):
    out = _plan(tmp_path, "odrive")
    (out / "run_moteus.py").write_text(script_text("moteus"))
    namespace = {"__name__": "plan_script", "__file__": str(out / "run_moteus.py")}
    exec(compile((out / "run_moteus.py").read_text(), str(out / "run_moteus.py"), "exec"), namespace)
    with pytest.raises(SystemExit) as e:
        namespace["main"]([])
    assert e.value.code == 2 and "a plan for odrive, not moteus" in capsys.readouterr().err


# --------------------------------------------------------------------------- plan --data on the rotary twin's logs


def test_plan_data_sizes_the_next_round_from_the_identification(tmp_path):
    """The zoo's 9N6P running logs (5 s): the next round's time is what ``pgcomm identify``'s standard errors ask for
    on the same logs, at the period the logs show, with the dither from the identified J/k0."""
    from pgcomm.io.rotary_zoo import write_rotary_motor, write_running_logs
    from pgcomm.rotary.zoo import draw_rotary

    truth = draw_rotary(0, 0)
    write_rotary_motor(truth, tmp_path / "m")
    write_running_logs(truth, tmp_path / "m" / "logs")
    logs = sorted(str(p) for p in (tmp_path / "m" / "logs").glob("*.csv"))
    assert main(["plan", "--motor", str(tmp_path / "m" / "motor.toml"), "--drive", "generic", "--data", *logs,
                 "--out", str(tmp_path / "p"), "--quiet"]) == 0
    assert main(["identify", "--motor", str(tmp_path / "m" / "motor.toml"), "--data", *logs, "--out",
                 str(tmp_path / "id"), "--quiet"]) == 0
    doc = json.loads((tmp_path / "p" / "plan.json").read_text())
    se = json.loads((tmp_path / "id" / "results.json").read_text())["identification"]["standard_error"]
    factors = {m: se[m]["log_time_factor_to_resolve"] for m in ("cogging", "ripple", "direction")}
    factor = max(f for f in factors.values() if math.isfinite(f))
    assert factor > 1.0  # these logs leave a map unresolved
    assert doc["need"]["factor"] == pytest.approx(factor, rel=1e-9)
    seconds = doc["first_round"]["seconds"]
    assert seconds == pytest.approx(sum(np.loadtxt(p, delimiter=",", skiprows=1, usecols=0).size for p in logs)
                                    * truth.motor.sample_time, rel=1e-9)
    assert doc["need"]["seconds"] == pytest.approx((factor - 1.0) * seconds, rel=1e-9)
    assert doc["total_duration_s"] >= doc["need"]["seconds"] * (1 - 1e-9)
    assert doc["inertia_ratio_A_s2_per_rad"] == pytest.approx(doc["first_round"]["inertia_ratio_A_s2_per_rad"])
    assert doc["inertia_ratio_A_s2_per_rad"] == pytest.approx(truth.inertia / truth.k0, rel=0.1)
    text = (tmp_path / "p" / "plan.md").read_text()
    assert f"{factor:.2f}x" in text and all(p in doc["commands"]["identify"] for p in logs)


def test_the_next_rounds_commands_take_the_first_rounds_logs_where_they_share_the_column_map(tmp_path):
    """``pgcomm identify`` reads one column map per call: the first round's logs join this round's only under the same
    map (the same drive's, or none for logs in the log format's own names and SI units)."""
    from types import SimpleNamespace

    from pgcomm.cli.plan import _rotary_commands
    from pgcomm.io.rotary_plan import columns_toml

    (tmp_path / "moteus.toml").write_text(columns_toml("moteus"))
    args = SimpleNamespace(out=tmp_path / "p", data=["first/*.csv"], columns=tmp_path / "moteus.toml")
    same = _rotary_commands(args, "moteus", runs=True)
    assert "'first/*.csv'" in same["identify"] and "p/logs/*.csv" in same["identify"] and "note" not in same
    other = _rotary_commands(args, "odrive", runs=True)
    assert "first/*.csv" not in other["identify"] and "another column map" in other["note"]
    plain = _rotary_commands(SimpleNamespace(out=tmp_path / "p", data=["first/*.csv"], columns=None), "generic", True)
    assert "'first/*.csv'" in plain["identify"] and "note" not in plain
    done = _rotary_commands(args, "moteus", runs=False)  # nothing to run: the first round's logs, with their map
    assert "p/logs" not in done["identify"] and f"--columns {tmp_path / 'moteus.toml'}" in done["identify"]


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("extra, match", [
    ([], r"--drive: a rotary motor's plan is written for its drive"),
    (["--drive", "odrive", "--swing", "1"], r"--swing 1: expected a share between 0 and 1"),
    (["--drive", "odrive", "--columns", "c.toml"], r"--columns: maps the columns of --data"),
    (["--drive", "odrive", "--no-force-sensor"], r"--no-force-sensor: a rotary plan never uses a force sensor"),
    (["--drive", "odrive", "--data", "LINEAR"], r"lin\.csv: a linear motor's log"),
    (["--drive", "odrive", "--data", "NOIQ"], r"noiq\.csv: (no columns for coil set 1|no q-axis current)"),
    (["--drive", "tmotor"], r"argument --drive: invalid choice: 'tmotor'"),
])
def test_bad_input_one_line_no_output(tmp_path, capsys, extra, match):
    path = tmp_path / "motor.toml"
    path.write_text(rotary_motor_to_toml(MOTORS["9N6P"]))
    t = np.arange(50) * 1e-3
    (tmp_path / "lin.csv").write_text("t,y,theta,iq_1\n" + "".join(f"{x},0,{x},0\n" for x in t))
    (tmp_path / "noiq.csv").write_text("t,theta\n" + "".join(f"{x},{x}\n" for x in t))
    extra = [{"LINEAR": str(tmp_path / "lin.csv"), "NOIQ": str(tmp_path / "noiq.csv")}.get(a, a) for a in extra]
    capsys.readouterr()
    assert main(["plan", "--motor", str(path), "--out", str(tmp_path / "out"), "--quiet", *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("pgcomm: error:") and "Traceback" not in err, err
    assert re.search(match, err), err
    assert not (tmp_path / "out").exists()


def test_linear_plan_refuses_the_rotary_options(tmp_path, capsys):
    from pgcomm.io.config import write_motor
    from pgcomm.twin import TwinParams

    write_motor(tmp_path / "motor.toml", TwinParams().motor())
    capsys.readouterr()
    assert main(["plan", "--motor", str(tmp_path / "motor.toml"), "--drive", "odrive", "--out",
                 str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--drive: only for a rotary motor's plan" in err and not (tmp_path / "out").exists()
