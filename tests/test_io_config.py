"""TOML configs: generic dataclass loader, motor config, atomic writing."""

from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import pytest

from pgcomm.errors import ConfigError
from pgcomm.io.atomic import atomic_open, atomic_write_text
from pgcomm.io.config import closest_match, load_dataclass, load_motor, load_toml, motor_to_toml, write_motor
from pgcomm.motor import Motor


def _toml(tmp_path, text, name="motor.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


# ----------------------------------------------------------------------------- load_toml / atomic


def test_load_toml_syntax_error_names_file_and_line(tmp_path):
    p = _toml(tmp_path, "a = 1\nb = [1, 2\nc = 3\n", "bad.toml")
    with pytest.raises(ConfigError, match=r"bad.toml: TOML syntax error: .*line 3"):
        load_toml(p)
    with pytest.raises(ConfigError, match=r"missing.toml: file not found"):
        load_toml(tmp_path / "missing.toml")


def test_atomic_write_leaves_old_file_on_error(tmp_path):
    p = tmp_path / "out.txt"
    atomic_write_text(p, "old\n")
    with pytest.raises(RuntimeError):
        with atomic_open(p) as f:
            f.write("half")
            raise RuntimeError("crash while writing")
    assert p.read_text() == "old\n"
    assert [q.name for q in tmp_path.iterdir()] == ["out.txt"]


def test_atomic_write_missing_directory(tmp_path):
    with pytest.raises(ConfigError, match=r"out.txt: cannot write, directory '.*nodir' does not exist"):
        atomic_write_text(tmp_path / "nodir" / "out.txt", "x")


def test_closest_match():
    assert closest_match("Fy", ["Fz", "temp"]) == "Fz"
    assert closest_match("pole_pich", ["pole_pitch", "sample_time"]) == "pole_pitch"
    assert closest_match("zzz", ["pole_pitch"]) is None


# ----------------------------------------------------------------------------- load_dataclass


@dataclass(frozen=True)
class Feedback:
    kp: float
    ki: float = 0.0
    cutoff_hz: float = field(default=200.0, metadata={"range": (1.0, 1e4), "unit": "Hz", "hint": "cutoff in Hz"})


@dataclass(frozen=True)
class Move:
    distance: float
    velocity: float = 1.0


@dataclass(frozen=True)
class Experiment:
    name: str
    feedback: Feedback
    seeds: tuple[int, ...] = (0,)
    gains: tuple[float, float] = (1.0, 2.0)
    mode: Literal["twin", "forcemap"] = "twin"
    forcemap: Path | None = None
    moves: tuple[Move, ...] = ()
    enabled: bool = True
    repeats: int = 1
    extra: dict[str, float] = field(default_factory=dict)

    def __post_init__(self):
        if self.repeats < 1:
            raise ValueError(f"repeats = {self.repeats} must be at least 1")


def test_load_dataclass_nested_and_conversions():
    table = {
        "name": "run",
        "feedback": {"kp": 3, "ki": 0.5},  # int accepted for float
        "seeds": [1, 2, 3],
        "gains": [1, 2.5],
        "mode": "forcemap",
        "forcemap": "maps/fm.csv",
        "moves": [{"distance": 0.1}, {"distance": -0.1, "velocity": 2}],
        "extra": {"a": 1},
    }
    exp = load_dataclass(Experiment, table, "exp.toml")
    assert exp.feedback == Feedback(kp=3.0, ki=0.5)
    assert isinstance(exp.feedback.kp, float)
    assert exp.seeds == (1, 2, 3) and exp.gains == (1.0, 2.5)
    assert exp.forcemap == Path("maps/fm.csv")
    assert exp.moves == (Move(0.1), Move(-0.1, 2.0))
    assert exp.extra == {"a": 1.0} and exp.enabled is True


def test_load_dataclass_unknown_key_closest():
    with pytest.raises(ConfigError, match=r"^exp.toml: unknown key 'feedbak' in the top-level table \(closest valid key: 'feedback'\)"):
        load_dataclass(Experiment, {"name": "x", "feedbak": {}}, "exp.toml")
    with pytest.raises(ConfigError, match=r"^exp.toml: unknown key 'kd' in table \[feedback\] \(closest valid key: 'kp'\); valid keys: kp, ki, cutoff_hz$"):
        load_dataclass(Experiment, {"name": "x", "feedback": {"kp": 1.0, "kd": 2.0}}, "exp.toml")
    with pytest.raises(ConfigError, match=r"unknown key 'velocty' in table \[moves\[1\]\] \(closest valid key: 'velocity'\)"):
        load_dataclass(Experiment, {"name": "x", "feedback": {"kp": 1}, "moves": [{"distance": 1}, {"distance": 1, "velocty": 1}]}, "exp.toml")


def test_load_dataclass_where_with_table():
    with pytest.raises(ConfigError, match=r"^exp.toml: key 'kp' missing in table \[controller.feedback\] \(expected a number\)$"):
        load_dataclass(Feedback, {}, "exp.toml [controller.feedback]")


def test_load_dataclass_missing_key():
    with pytest.raises(ConfigError, match=r"exp.toml: key 'feedback' missing in the top-level table \(expected a table\)"):
        load_dataclass(Experiment, {"name": "x"}, "exp.toml")


@pytest.mark.parametrize(
    "patch, message",
    [
        ({"feedback": {"kp": "3"}}, r"exp.toml \[feedback\]: kp = '3' is a string, expected a number"),
        ({"feedback": {"kp": True}}, r"kp = True is a boolean, expected a number"),
        ({"repeats": 2.0}, r"exp.toml: repeats = 2 is a float, expected an integer"),
        ({"seeds": [1, "a"]}, r"seeds\[1\] = 'a' is a string, expected an integer"),
        ({"gains": [1.0]}, r"gains has 1 entries, expected 2"),
        ({"mode": "twn"}, r"mode = 'twn' is not one of 'twin', 'forcemap' \(closest match: 'twin'\)"),
        ({"enabled": 1}, r"enabled = 1 is an integer, expected true or false"),
        ({"feedback": 3}, r"feedback = 3 is an integer, expected a table"),
        ({"feedback": {"kp": 1, "cutoff_hz": 0.5}}, r"\[feedback\]: cutoff_hz = 0.5 Hz is out of range \(expected 1–10000 Hz; cutoff in Hz\)"),
        ({"repeats": 0}, r"^exp.toml: repeats = 0 must be at least 1$"),
    ],
)
def test_load_dataclass_type_errors(patch, message):
    table = {"name": "x", "feedback": {"kp": 1.0}, **patch}
    with pytest.raises(ConfigError, match=message):
        load_dataclass(Experiment, table, "exp.toml")


# ----------------------------------------------------------------------------- motor


MOTOR = """
pole_pitch = 0.03
sample_time = 0.001
current_limit = 10.0

[nominal]
k = [61.0, 62.0, 60.0]
zeta = -0.52
mu = 0.04

[[coil_set]]
lever_arm = -0.065
[[coil_set]]
lever_arm = 0.005
[[coil_set]]
lever_arm = 0.075
"""


def test_load_motor(tmp_path):
    m = load_motor(_toml(tmp_path, MOTOR))
    assert m == Motor(
        pole_pitch=0.03, lever_arms=(-0.065, 0.005, 0.075), k=(61.0, 62.0, 60.0), zeta=-0.52, mu=0.04,
        sample_time=0.001, current_limit=10.0,
    )


def test_motor_optional_keys(tmp_path):
    text = MOTOR.replace("current_limit = 10.0\n", "").replace("mu = 0.04\n", "").replace("k = [61.0, 62.0, 60.0]", "k = 67")
    m = load_motor(_toml(tmp_path, text))
    assert m.current_limit is None and m.mu == Motor().mu and m.k == (67.0, 67.0, 67.0)
    assert m.mass is None  # only identification without a force sensor needs it
    m = load_motor(_toml(tmp_path, MOTOR.replace("current_limit = 10.0\n", "current_limit = 10.0\nmass = 12.5\n"),
                         "mass.toml"))
    assert m.mass == 12.5


def test_motor_round_trip(tmp_path):
    motor = Motor(k=(61.34, 61.62, 60.07), zeta=(-0.54, -0.55, -0.55), current_limit=None, sample_time=1.0 / 3000.0)
    p = tmp_path / "out" / "motor.toml"
    p.parent.mkdir()
    write_motor(p, motor)
    assert load_motor(p) == motor  # bit-exact floats
    write_motor(p, Motor(mass=1.0 / 3.0))
    assert load_motor(p) == Motor(mass=1.0 / 3.0)
    assert load_motor(_toml(tmp_path, motor_to_toml(Motor()), "default.toml")) == Motor()


@pytest.mark.parametrize(
    "old, new, message",
    [
        ("pole_pitch = 0.03", "pole_pitch = 30", r"^.*motor.toml: pole_pitch = 30 m is implausible \(expected 0.001–0.5 m; did you give mm\?\)$"),
        ("sample_time = 0.001", "sample_time = 1", r"motor.toml: sample_time = 1 s is implausible \(expected 1e-06–0.1 s; did you give ms\?\)"),
        ("zeta = -0.52", "zeta = -30", r"motor.toml \[nominal\]: zeta = -30 rad is implausible \(expected -6.28319–6.28319 rad; did you give degrees\?\)"),
        ("k = [61.0, 62.0, 60.0]", "k = [61.0, 62.0e5, 60.0]", r"\[nominal\]: k\[1\] = 6.2e\+06 N/A is implausible \(expected 0.01–10000 N/A\)"),
        ("lever_arm = 0.075", "lever_arm = 75", r"motor.toml \[\[coil_set\]\] 3: lever_arm = 75 m is implausible \(expected -2–2 m; did you give mm\?\)"),
        ("current_limit = 10.0", "current_limit = 0", r"current_limit = 0 A is implausible \(expected 0 < value ≤ 10000 A\)"),
        ("current_limit = 10.0", "current_limit = 10000", None),
        ("mu = 0.04", "mu = 40", r"\[nominal\]: mu = 40 is implausible \(expected -10–10\)"),
        ("current_limit = 10.0", "mass = 30000", r"^.*motor.toml: mass = 30000 kg is implausible \(expected 0.001–10000 kg; did you give g\?\)$"),
        ("current_limit = 10.0", "mass = 0", r"motor.toml: mass = 0 kg is implausible"),
        ("current_limit = 10.0", "mass = '30 kg'", r"motor.toml: mass = '30 kg' is a string, expected a number in kg"),
        ("current_limit = 10.0", "mas = 30", r"unknown key 'mas' in the top-level table \(closest valid key: 'mass'\)"),
        ("mu = 0.04", "mu = nan", r"\[nominal\]: mu = nan is not finite"),
        ("k = [61.0, 62.0, 60.0]", "k = [61.0, 62.0]", r"motor.toml \[nominal\]: k has 2 entries but there are 3 \[\[coil_set\]\] tables"),
        ("pole_pitch = 0.03", "pole_pitch = '30 mm'", r"motor.toml: pole_pitch = '30 mm' is a string, expected a number in m"),
        ("pole_pitch = 0.03", "pole_pich = 0.03", r"motor.toml: unknown key 'pole_pich' in the top-level table \(closest valid key: 'pole_pitch'\)"),
        ("mu = 0.04", "muu = 0.04", r"unknown key 'muu' in table \[nominal\] \(closest valid key: 'mu'\)"),
        ("lever_arm = 0.005", "lever = 0.005", r"unknown key 'lever' in \[\[coil_set\]\] 2 \(closest valid key: 'lever_arm'\)"),
        ("sample_time = 0.001", "", r"motor.toml: key 'sample_time' missing \(expected a number in s\)"),
        ("zeta = -0.52", "", r"motor.toml \[nominal\]: key 'zeta' missing"),
    ],
)
def test_motor_bad_values(tmp_path, old, new, message):
    assert old in MOTOR
    p = _toml(tmp_path, MOTOR.replace(old, new, 1))
    if message is None:
        load_motor(p)
        return
    with pytest.raises(ConfigError, match=message):
        load_motor(p)


def test_motor_structure_errors(tmp_path):
    no_sets = MOTOR.split("[[coil_set]]")[0]
    with pytest.raises(ConfigError, match=r"motor.toml: no \[\[coil_set\]\] tables"):
        load_motor(_toml(tmp_path, no_sets))
    no_nominal = MOTOR.replace("[nominal]\nk = [61.0, 62.0, 60.0]\nzeta = -0.52\nmu = 0.04\n", "")
    with pytest.raises(ConfigError, match=r"motor.toml: table \[nominal\] missing"):
        load_motor(_toml(tmp_path, no_nominal, "x.toml").rename(tmp_path / "motor.toml"))


# ----------------------------------------------------------------------------- the rotary tables of the settings


def test_rotary_tables_load_as_the_options_built_in_python(tmp_path):
    """``[rotary]`` and ``[rotary_experiment]`` of an experiment TOML load, by the settings' one loader, into the same
    frozen objects as built in Python; TOML's words for ``None`` (``"none"``, ``"held"``) read as the Python values."""
    from pgcomm.io.config import load_experiment
    from pgcomm.settings import RotaryIdentifyOptions, RotarySettings, StandstillPlan

    p = _toml(tmp_path, "[rotary]\norders = [[0, 18], [6, 12], [0, 1]]\nangle_pll = [1000]\ncurrent_lag = \"held\"\n"
              "current_noise = \"none\"\ncurrent_filter = \"none\"\ntime_lines = [50, 100.0]\ncurrent_delay = 1\n"
              "encoder_step = \"none\"\npin = [\"ripple\"]\n"
              "[rotary_experiment]\nrevolutions = 1.5\ndither_hz = [61, 83]\n[rotary_experiment.standstill]\n"
              "points = 720\n", "exp.toml")
    config = load_experiment(p)
    assert config.rotary == RotaryIdentifyOptions(
        orders=((0, 18), (6, 12), (0, 1)), angle_pll=(1000.0, 1.0), current_lag=None, current_noise=None,
        current_filter=0.0, time_lines=(50.0, 100.0), current_delay=1, encoder_step=None, pin=("ripple",))
    assert config.rotary_experiment == RotarySettings(revolutions=1.5, dither_hz=(61.0, 83.0),
                                                      standstill=StandstillPlan(points=720))
    # left out, every reading is detected
    assert load_experiment(_toml(tmp_path, "", "empty.toml")).rotary == RotaryIdentifyOptions()
    assert RotaryIdentifyOptions().current_filter == "detect"


def test_rotary_options_take_the_orders_and_the_reading_of_an_identification():
    """An :class:`~pgcomm.rotary.regression.Orders` is held as integer tuples and read back unchanged; a reading
    fixes the current's delay and lag, the PLL and the lines, and nothing else."""
    import numpy as np

    from pgcomm.rotary.identify import Reading, orders_of
    from pgcomm.rotary.motor import RotaryMotor
    from pgcomm.rotary.regression import Orders
    from pgcomm.settings import RotaryIdentifyOptions

    motor = RotaryMotor(pole_pairs=3, slots=9, sample_time=1e-3)
    orders = Orders.for_motor(motor)
    opts = RotaryIdentifyOptions(orders=orders, current_filter=0.05)
    back = orders_of(opts, motor)
    for name in ("cogging", "ripple", "direction"):
        assert np.array_equal(getattr(back, name), getattr(orders, name))
    assert np.array_equal(orders_of(RotaryIdentifyOptions(), motor).cogging, orders.cogging)
    read = Reading(current_delay=1, current_lag=0.0625, angle_pll=(800.0, 0.7), time_lines=(50.0,),
                   current_filter=0.02)
    fixed = opts.with_reading(read)
    assert (fixed.current_delay, fixed.current_lag, fixed.angle_pll, fixed.time_lines) == (1, 0.0625, (800.0, 0.7),
                                                                                          (50.0,))
    assert fixed.current_filter == 0.02 and fixed.current_noise == "detect" and fixed.orders == opts.orders
