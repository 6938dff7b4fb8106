"""Every bad input, one table per class: exit code 2, one line ``pgcomm: error: ...`` naming
the file / key / value, no traceback, ``--out`` untouched and no staging folder left.

The cases fail in validation, before any simulation or identification, so the whole table runs
in-process (``pgcomm.cli.main``) in seconds. Two subprocess tests check SIGINT / SIGTERM.
"""

from __future__ import annotations

import dataclasses
import io
import json
import os
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest

from pgcomm.cli import main
from pgcomm.forcemap import ForceMapPlant
from pgcomm.io.config import write_motor
from pgcomm.io.forcemap import write_forcemap
from pgcomm.io.logs import Log, write_log
from pgcomm.io.model import save_model
from pgcomm.twin import TwinParams

from test_io_model import _model

SRC = Path(__file__).resolve().parents[1] / "src"


# --------------------------------------------------------------------------- fixtures: files


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Bad (and good) input files shared by the tables: name -> path."""
    d = tmp_path_factory.mktemp("bad")
    f = {}
    tw = TwinParams().without("direction")
    y = np.linspace(-0.13, 0.13, 261)
    fm = ForceMapPlant.from_plant(tw.plant(), y)
    gain, cog = np.asarray(fm.gain_table), np.asarray(fm.cog_table)
    write_forcemap(d / "map.csv", y, gain, cog)
    write_forcemap(d / "map_mm.csv", y * 1000.0, gain, cog)
    write_forcemap(d / "map_mNA.csv", y, gain * 1000.0, cog)
    write_forcemap(d / "map2.csv", y, gain[:, :2], cog)
    write_motor(d / "motor.toml", tw.motor())
    write_motor(d / "motor_nomass.toml", dataclasses.replace(tw.motor(), mass=None))
    text = (d / "motor.toml").read_text()
    text = text.replace("[67.0, 67.0, 67.0]", "[67.0, 67.0]").replace("[-0.52, -0.52, -0.52]", "[-0.52, -0.52]")
    (d / "motor2.toml").write_text(text[: text.rfind("[[coil_set]]")])
    f.update({k: d / f"{k}.csv" for k in ("map", "map_mm", "map_mNA", "map2")})
    f["motor"], f["motor2"] = d / "motor.toml", d / "motor2.toml"
    f["motor_nomass"] = d / "motor_nomass.toml"
    rotary = Path(__file__).resolve().parents[1] / "bench" / "real_odrive" / "motor.toml"
    (d / "rotary.toml").write_text(rotary.read_text())
    f["rotary"] = d / "rotary.toml"

    # model files: a good one, and each kind of damage
    save_model(d / "model", _model(), {"seed": 0})
    good = json.loads((d / "model.json").read_text())
    f["model"] = d / "model.json"

    def model(name, npz=None, **changes):
        doc = {**good, "arrays": f"{name}.npz", **changes}
        (d / f"{name}.json").write_text(json.dumps(doc))
        (d / f"{name}.npz").write_bytes(npz if npz is not None else (d / "model.npz").read_bytes())
        f[name] = d / f"{name}.json"

    model("m_dotdot", arrays="../x.npz")
    model("m_abs", arrays=str(d / "model.npz"))
    model("m_meta", metadata="hello")
    model("m_range", training_range={"y_min": [-1e6] * 3, "y_max": [1e6] * 3})
    src = np.load(d / "model.npz")

    def npz(edit):
        b = io.BytesIO()
        with zipfile.ZipFile(b, "w") as z:
            for k in src.files:
                a = io.BytesIO()
                np.save(a, src[k])
                z.writestr(k + ".npy", edit(k, a.getvalue()))
            if edit("extra", None) is not None:
                z.writestr("evil.txt", "not an array")
        return b.getvalue()

    header = "{'descr': '<f8', 'fortran_order': False, 'shape': (100000000000,), }"
    header = (header + " " * (118 - len(header)) + "\n").encode()
    huge = b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header + b"\0" * 64
    model("m_notnpy", npz(lambda k, v: b"" if k == "extra" else v))
    model("m_huge", npz(lambda k, v: None if k == "extra" else (huge if k == "A" else v)))
    (d / "m_deep.json").write_text("[" * 200_000 + "]" * 200_000)
    f["m_deep"] = d / "m_deep.json"

    # logs and references in the wrong units
    n = 400
    t = np.arange(n) * 1e-3
    yy = 0.05 * np.sin(2 * np.pi * t)
    cols = {"t": t, "y": yy, "Fy": np.zeros(n), "Fx": np.zeros(n), "Tz": np.zeros(n),
            "ia_1": np.ones(n), "ib_1": np.ones(n)}
    write_log(d / "log_ms.csv", Log({**cols, "t": t * 1000.0}, 1.0))
    write_log(d / "log_mm.csv", Log({**cols, "y": yy * 1000.0}, 1e-3))
    f["log_ms"], f["log_mm"] = d / "log_ms.csv", d / "log_mm.csv"
    (d / "ref_not.csv").write_text("r\n" + "\n".join(repr(float(v)) for v in yy) + "\n")
    (d / "ref_mm.csv").write_text("t,r\n" + "\n".join(f"{float(a)!r},{1000 * float(v)!r}" for a, v in zip(t, yy)) + "\n")
    f["ref_not"], f["ref_mm"] = d / "ref_not.csv", d / "ref_mm.csv"
    # identification without a force sensor: a one-coil-set rig, its logs without force
    from pgcomm.motor import Motor

    rig = Motor(pole_pitch=0.03, lever_arms=(0.0,), k=67.0, zeta=-0.52, current_limit=10.0, mass=30.0)
    write_motor(d / "rig.toml", rig)
    write_motor(d / "rig_nomass.toml", Motor(pole_pitch=0.03, lever_arms=(0.0,), k=67.0, zeta=-0.52))
    f["rig"], f["rig_nomass"] = d / "rig.toml", d / "rig_nomass.toml"
    ts = 1e-3

    def rig_log(name, y, amp=2.0, extra=None):
        eta = 2 * np.pi * y / 0.03 - 0.52
        cols = {"t": np.arange(y.shape[0]) * ts, "y": y, "ia_1": amp * np.sin(eta),
                "ib_1": amp * np.sin(eta + 2 * np.pi / 3), "Fy_star": np.full(y.shape[0], 100.0 * amp), **(extra or {})}
        write_log(d / f"{name}.csv", Log(cols, ts))
        f[name] = d / f"{name}.csv"

    tt = np.arange(4000) * ts
    moving = -0.1 + 0.05 * tt + 0.5 * 0.2 * np.minimum(tt, 1.0) ** 2  # accelerates for 1 s, then coasts
    rig_log("sl_short", 0.05 * np.arange(6) * ts)                       # 6 samples: no filter window fits
    rig_log("sl_constv", -0.1 + 0.05 * tt)                              # constant velocity: no acceleration
    rig_log("sl_sat", moving, amp=10.0 / np.sin(np.pi / 3))             # peak phase current at the 10 A limit
    rig_log("sl_fyonly", moving, extra={"Fy": np.zeros(tt.shape[0])})   # Fy without Fx, Tz
    rig_log("sl_ok", moving)
    (d / "file").write_text("a file, not a folder")
    f["file"] = d / "file"
    f["dir"] = d
    return f


def _config(tmp_path, text):
    p = tmp_path / "exp.toml"
    p.write_text(text)
    return p


def _check_refused(argv, out, capsys, pattern, tmp_path):
    """Run ``pgcomm argv --out out``: exit 2, one matching line, no traceback, out untouched, no staging."""
    before = sorted(p.name for p in out.iterdir()) if out is not None and out.is_dir() else None
    t0 = time.perf_counter()
    code = main([str(a) for a in argv] + (["--out", str(out)] if out is not None else []) + ["--quiet"])
    seconds = time.perf_counter() - t0
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert code == 2, captured.err
    assert len(lines) == 1 and lines[0].startswith("pgcomm: error: "), captured.err
    assert "Traceback" not in captured.err
    import re

    assert re.search(pattern, lines[0]), lines[0]
    if out is not None:
        after = sorted(p.name for p in out.iterdir()) if out.is_dir() else None
        assert after == before, "--out changed"
        parent = out.parent if out.parent.exists() else tmp_path
        assert not list(parent.glob(f".{out.name}.*")), "staging folder left"
    assert seconds < 30, f"refused after {seconds:.0f} s"


# --------------------------------------------------------------------------- class 1: settings (silent wrong results)

CONFIG_CASES = [
    ("calibrate", "[calibration]\nn_bins = 0\n", r"exp\.toml \[calibration\]: n_bins = 0 .*expected 1"),
    ("calibrate", "[calibration]\niterations = 0\n", r"\[calibration\]: iterations = 0 .*at least one pass"),
    ("simulate", "[evaluation]\nlowpass_hz = 0\n", r"\[evaluation\]: lowpass_hz = 0 Hz"),
    ("simulate", "[evaluation]\nlowpass_hz = 600\n", r"lowpass_hz = 600 Hz: .*Nyquist frequency 500 Hz"),
    ("simulate", "current_limit = 0\n", r"exp\.toml: current_limit = 0 A .*positive"),
    ("simulate", "current_limit = -1\n", r"current_limit = -1 A"),
    ("simulate", "[controller]\nbandwidth_hz = 0\n", r"\[controller\]: bandwidth_hz = 0 Hz"),
    ("simulate", "[controller]\nbandwidth_hz = 400\n", r"bandwidth_hz = 400 Hz: .*unstable"),
    ("simulate", "[sensors]\nforce_noise = [-0.8, 0.45, 0.9]\n", r"\[sensors\]: force_noise\[0\] = -0\.8"),
    ("simulate", "[mechanics]\nmass = 0\n", r"\[mechanics\]: mass = 0 kg"),
    ("simulate", "[mechanics]\nsubsteps = 0\n", r"\[mechanics\]: substeps = 0 .*1 to 1000"),
    ("simulate", "[mechanics]\nsubsteps = 1000000000\n", r"substeps = 1e\+09 .*1 to 1000"),
    ("identify", "[identification]\nregularisation = -0.1\n", r"\[identification\]: regularisation = -0\.1"),
    ("identify", "[identification]\nmax_iterations = 0\n", r"max_iterations = 0 "),
    ("identify", "[identification]\nstarts = 0\n", r"\[identification\]: starts = 0 .*1 to 256"),
    ("identify", "[identification]\ngain_widths = []\n", r"gain_widths = \[\]: give at least one"),
    ("identify", "[identification]\nvalidation_fraction = 1.0\n", r"validation_fraction = 1 .*expected 0"),
    ("identify", "[identification]\nvalidation_fraction = -0.1\n", r"validation_fraction = -0\.1"),
    ("reproduce", "[reference]\nstroke = 100\n", r"stroke = 100 m .*mm"),
    ("identify", "[rotary]\ncurrent_lag = 2\n", r"exp\.toml \[rotary\]: current_lag = 2\.0: \"held\", or a lag"),
    ("identify", "[rotary]\nangle_pll = [1000, -1]\n", r"\[rotary\]: angle_pll = \[1000\.0, -1\.0\]: .*both positive"),
    ("identify", "[rotary]\ncurrent_filter = \"off\"\n",
     r"\[rotary\]: current_filter = 'off': expected 'detect' or 'none', or a time constant in s"),
    ("identify", "[rotary]\ncurrent_delay = 0.5\n", r"\[rotary\]: current_delay = 0\.5 .*an integer or a string"),
    ("identify", "[rotary]\npin = [\"cogging\"]\n", r"\[rotary\]: pin = \['cogging'\]: maps to pin are"),
    ("identify", "[rotary]\ncurent_filter = 0.1\n",
     r"unknown key 'curent_filter' in table \[rotary\] \(closest valid key: 'current_filter'\)"),
    ("identify", "[rotary_experiment]\nspeed_shares = []\n", r"\[rotary_experiment\]: speed_shares = \[\]: give at least"),
    ("identify", "[rotary_experiment.standstill]\npoints = 4\n", r"\[rotary_experiment\.standstill\]: points = 4 "),
]


@pytest.mark.parametrize("command,text,pattern", CONFIG_CASES, ids=[c[1].strip().replace("\n", " ") for c in CONFIG_CASES])
def test_config_values_refused(tmp_path, capsys, command, text, pattern):
    _check_refused([command, "--config", _config(tmp_path, text)], tmp_path / "out", capsys, pattern, tmp_path)


# --------------------------------------------------------------------------- class 2: input files (units, model files)

FILE_CASES = [
    (["calibrate", "--plant", "map_mm", "--motor", "motor"], r"map_mm\.csv column 'y': .*looks like mm"),
    (["calibrate", "--plant", "map_mNA", "--motor", "motor"], r"map_mNA\.csv column 'Fy_1\w': .*N/A"),
    (["export", "--format", "c", "--model", "m_dotdot"], r"m_dotdot\.json: \"arrays\": '\.\./x\.npz' must be the plain name"),
    (["simulate", "--model", "m_dotdot"], r"m_dotdot\.json: \"arrays\""),
    (["export", "--format", "c", "--model", "m_abs"], r"m_abs\.json: \"arrays\": '/.*no absolute path"),
    (["export", "--format", "c", "--model", "m_notnpy"], r"m_notnpy\.npz: member 'evil\.txt' is not a \.npy array"),
    (["export", "--format", "lut", "--model", "m_huge"], r"m_huge\.npz: array 'A' has shape \(100000000000,\)"),
    (["export", "--format", "c", "--model", "m_deep"], r"m_deep\.json: JSON nested too deeply"),
    (["simulate", "--model", "m_deep"], r"m_deep\.json: JSON nested too deeply"),
    (["inspect", "--model", "m_meta"], r"m_meta\.json: \"metadata\" must be a JSON object"),
    (["simulate", "--model", "model", "--plant", "map2", "--motor", "motor2"],
     r"model\.json: the model has 3 coil set\(s\) but the plant .*map2\.csv\) has 2"),
    (["evaluate", "--data", "log_ms"], r"log_ms\.csv column 't': sample time 1 s .*looks like milliseconds"),
    (["evaluate", "--data", "log_mm"], r"log_mm\.csv column 'y': .*looks like mm"),
    (["evaluate", "--data", "log_mm", "--motor", "rotary"],
     r"rotary\.toml: kind = \"rotary\": this command takes a linear motor .*'pgcomm identify', 'plan' or 'reproduce'"),
    (["simulate", "--reference", "ref_mm"], r"ref_mm\.csv: 'r' reaches 50.*looks like mm"),
    (["simulate", "--reference", "ref_not"], r"ref_not\.csv: no 't' column .*--reference-sample-time"),
]


# identification without a force sensor: logs too short, without acceleration, saturated, partial force
# columns, no mass; refused before any identification
SENSORLESS_CASES = [
    (["identify", "--plant", "map", "--motor", "motor_nomass", "--no-force-sensor", "--family", "spline"],
     r"--family spline needs force measurements \(Fy, Fx, Tz\); without a force sensor use --family pgnn"),
    (["identify", "--data", "sl_ok", "--motor", "rig", "--family", "spline"], r"--family spline needs force measurements"),
    (["identify", "--data", "sl_ok", "--motor", "rig_nomass"],
     r"--motor .*rig_nomass\.toml: key 'mass' missing"),
    (["identify", "--data", "sl_short", "--motor", "rig"],
     r"coil set 1 \(.*sl_short\.csv\): no window of \d+ samples .*too short or too slow"),
    (["identify", "--data", "sl_constv", "--motor", "rig"],
     r"coil set 1 \(.*sl_constv\.csv\): no acceleration above 0\.2 m/s\^2 in Z_1"),
    (["identify", "--data", "sl_sat", "--motor", "rig"],
     r"sl_sat\.csv\): currents at the drive's limit 10 A in 100\.0 % of the samples"),
    (["identify", "--data", "sl_fyonly", "--motor", "rig"],
     r"sl_fyonly\.csv: columns 'Fx', 'Tz' missing \(a log has all of the force columns Fy, Fx, Tz, or none"),
    (["evaluate", "--data", "sl_ok"], r"sl_ok\.csv: no force columns Fy, Fx, Tz: .*needs --model"),
    (["evaluate", "--data", "sl_ok", "--model", "model"], r"--model .*model\.json: no identified mechanics"),
    (["check", "--data", "sl_fyonly", "--motor", "rig"], r"sl_fyonly\.csv: columns 'Fx', 'Tz' missing"),
]


# a run that simulates its plant knows the translator's mass; every other input is checked
# before the first computation (here: the first data generation is replaced by a stop)


class _Stop(Exception):
    pass


@pytest.fixture
def stop_at_first_simulation(monkeypatch):
    """``pgcomm.experiment.generate`` records the set-up it is given and stops the command (exit 2)."""
    from pgcomm import experiment
    from pgcomm.errors import DataError

    seen = []

    def generate(setup, *a, **k):
        seen.append(setup)
        raise DataError("stopped at the first simulation")

    monkeypatch.setattr(experiment, "generate", generate)
    return seen


@pytest.mark.parametrize("command", [["reproduce", "--quick"], ["identify", "--no-force-sensor"]])
def test_simulated_runs_give_a_motor_without_mass_the_simulated_translators(tmp_path, capsys, files,
                                                                            stop_at_first_simulation, command):
    # a mass that is not the default 30 kg: the value comes from these settings, and is said
    config = _config(tmp_path, "[mechanics]\nmass = 24.5\n")
    out = tmp_path / "out"
    code = main([*command, "--plant", str(files["map"]), "--motor", str(files["motor_nomass"]), "--config", str(config),
                 "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.strip().splitlines()[-1] == "pgcomm: error: stopped at the first simulation", err
    assert [s.motor.mass for s in stop_at_first_simulation] == [24.5]
    assert "24.5 kg from the simulated mechanics ([mechanics] mass; the motor description has none)" in err
    assert not out.exists()


def test_simulated_mass_names_a_motor_mass_that_differs():
    from pgcomm.setup import build_setup
    from pgcomm.settings import ExperimentConfig
    from pgcomm.setup import simulated_mass

    setup = build_setup(ExperimentConfig())
    same, source = simulated_mass(setup)
    assert same is setup and source == "30 kg from the simulated mechanics ([mechanics] mass)"
    other = dataclasses.replace(setup, motor=dataclasses.replace(setup.motor, mass=28.0), plant_name="map.csv")
    assert simulated_mass(other)[1] == "28 kg from the motor description; the simulated translator has 30 kg"


def test_reproduce_refuses_a_stroke_too_short_for_the_sensorless_table_before_any_work(tmp_path, capsys,
                                                                                       stop_at_first_simulation):
    # the drives' sensorless table needs settled constant-speed samples in both directions: found out minutes
    # into the run before, now before the first simulation
    _check_refused(["reproduce", "--quick", "--config", _config(tmp_path, "[reference]\nstroke = 0.004\n")],
                   tmp_path / "out", capsys, r"sensorless cogging table: the stroke \[-0\.004, 0\.004\] m at "
                   r"[\d.]+ m/s leaves no positions passed in both directions", tmp_path)
    assert stop_at_first_simulation == []


ROTARY_MOTOR = 'kind = "rotary"\npole_pairs = 7\nslots = 12\nsample_time = 0.001\ncurrent_limit = 20.0\n'

ROTARY_REPRODUCE_CASES = [
    ([], "[rotary_experiment]\nspeed_shares = []\n", r"exp\.toml \[rotary_experiment\]: speed_shares = \[\]: give at least"),
    ([], "[rotary_experiment]\nrevolution = 2\n",
     r"exp\.toml: unknown key 'revolution' in table \[rotary_experiment\] \(closest valid key: 'revolutions'\)"),
    ([], "[rotary_experiment.standstill]\npoints = 4\n", r"exp\.toml \[rotary_experiment\.standstill\]: points = 4 "),
    (["--quick"], "[rotary_experiment.standstill]\npoints = 7200\n",
     r"exp\.toml \[rotary_experiment\] \[standstill\] points conflicts with --quick: --quick overrides it"),
]


@pytest.mark.parametrize("extra,text,pattern", ROTARY_REPRODUCE_CASES,
                         ids=[c[1].strip().replace("\n", " ") for c in ROTARY_REPRODUCE_CASES])
def test_rotary_reproduce_config_refused(tmp_path, capsys, extra, text, pattern):
    """``reproduce`` on a rotary motor reads ``--config``'s ``[rotary_experiment]`` as the linear one reads its tables:
    a bad value, a misspelt key or a key ``--quick`` overrides is one line naming the file, table and key."""
    motor = tmp_path / "rotary.toml"
    motor.write_text(ROTARY_MOTOR)
    _check_refused(["reproduce", "--motor", motor, *extra, "--config", _config(tmp_path, text)], tmp_path / "out",
                   capsys, pattern, tmp_path)


@pytest.mark.parametrize("argv,pattern", SENSORLESS_CASES, ids=[" ".join(c[0][:3]) + f" {i}"
                                                                for i, c in enumerate(SENSORLESS_CASES)])
def test_sensorless_bad_input_refused(tmp_path, capsys, files, argv, pattern):
    argv = [str(files.get(a, a)) if not a.startswith("-") else a for a in argv]
    out = None if argv[0] == "check" else tmp_path / "out"
    _check_refused(argv, out, capsys, pattern, tmp_path)


@pytest.mark.parametrize("argv,pattern", FILE_CASES, ids=[" ".join(c[0][:3]) for c in FILE_CASES])
def test_bad_files_refused(tmp_path, capsys, files, argv, pattern):
    argv = [str(files.get(a, a)) if not a.startswith("-") else a for a in argv]
    out = None if argv[0] == "inspect" else tmp_path / "out"
    _check_refused(argv, out, capsys, pattern, tmp_path)


# --------------------------------------------------------------------------- class 3: sizes and options

def test_sizes_and_options_refused(tmp_path, capsys, files):
    cases = [
        (["export", "--format", "lut", "--model", files["model"], "--resolution", "1e-9", "--current-limit", "10"],
         r"--resolution 1e-09 m over the training range .* at most 200000 .*use --resolution"),
        (["export", "--format", "lut", "--model", files["m_range"], "--current-limit", "10"],
         r"training range \[-1e\+06, 1e\+06\] m .*rows"),
        (["check", "--data", files["log_mm"], "--bins", "100000000"], r"--bins 100000000: expected 1 to 10000"),
        (["simulate", "--seed", "1000000000000000000000"], r"--seed: 1000000000000000000000 is outside 0 to 2\*\*32-1"),
        (["simulate", "--seed", "-1"], r"--seed: -1 is outside"),
        (["simulate", "--bogus"], r"unrecognized arguments: --bogus"),
        (["simulate", "--law", "nonsense"], r"--law: invalid choice: 'nonsense'"),
    ]
    for argv, pattern in cases:
        out = None if argv[0] == "check" else tmp_path / "out"
        _check_refused(argv, out, capsys, pattern, tmp_path)
    code = main([])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "required: COMMAND" in err[0]


# --------------------------------------------------------------------------- class 4: --out

def test_out_refused(tmp_path, capsys, files):
    full = tmp_path / "full"
    full.mkdir()
    (full / "log.parquet").write_text("stale")
    cases = [
        (files["file"] / "x", r"--out .*file/x: '.*file' exists and is a file"),
        (files["file"], r"exists and is a file"),
        (full, r"--out .*full: folder exists and is not empty \(1 entries: log\.parquet\); pass --overwrite"),
    ]
    for out, pattern in cases:
        _check_refused(["simulate"], out, capsys, pattern, tmp_path)  # refused before any work
    assert (full / "log.parquet").read_text() == "stale"
    # /proc takes no new folders, even from root: refused before any work
    _check_refused(["simulate"], Path("/proc/pgcomm-test/x"), capsys, r"not writable|cannot create", tmp_path)


def test_out_overwrite_replaces_the_whole_folder_and_creates_parents(tmp_path):
    from pgcomm.cli._output import staged_output

    out = tmp_path / "a" / "b" / "out"
    with staged_output(out) as tmp:
        (tmp / "log.parquet").write_text("1")
    assert sorted(p.name for p in out.iterdir()) == ["log.parquet"]
    with pytest.raises(Exception, match="not empty"):
        with staged_output(out) as tmp:
            pass
    with staged_output(out, overwrite=True) as tmp:
        (tmp / "log.csv").write_text("2")
    assert sorted(p.name for p in out.iterdir()) == ["log.csv"]  # no stale log.parquet beside the new run
    with pytest.raises(RuntimeError):
        with staged_output(out, overwrite=True) as tmp:
            (tmp / "x").write_text("3")
            raise RuntimeError("failed")
    assert sorted(p.name for p in out.iterdir()) == ["log.csv"]
    assert sorted(p.name for p in out.parent.iterdir()) == ["out"]  # no staging or old folder left


def test_calibrate_save_data_writes_the_data_sets(tmp_path, capsys):
    cfg = _config(tmp_path, "[reference]\nvelocities = [0.15]\ndwell = 0.05\n")
    code = main(["calibrate", "--config", str(cfg), "--save-data", "--out", str(tmp_path / "cal"), "--quiet"])
    assert code == 0, capsys.readouterr().err
    names = sorted(p.name for p in (tmp_path / "cal" / "data").iterdir())
    assert names == [f"Z{i}_coilset{l}.csv" for i in (1, 2) for l in (1, 2, 3)]


def test_identify_without_validation_set():
    """``validation_fraction=0`` trains on everything; validation costs are NaN (documented)."""
    from pgcomm.data import CoilSetData
    from pgcomm.identify import IdentifyOptions, identify

    rng = np.random.default_rng(0)
    n = 3000
    y = np.linspace(-0.1, 0.1, n)
    cur = rng.normal(size=(n, 2))
    eta = 2 * np.pi * y / 0.03
    force = np.stack([60 * (np.sin(eta) * cur[:, 0] + np.sin(eta + 2 * np.pi / 3) * cur[:, 1]),
                      np.zeros(n), np.zeros(n)], axis=1) + rng.normal(size=(n, 3)) * 0.1
    exp = (np.arange(n) >= n // 2).astype(int)
    r = identify(CoilSetData(y, cur, force, exp), 0.03,
                 IdentifyOptions(validation_fraction=0.0, starts=1, max_iterations=2), check_data=False)
    assert r.n_validation == 0 and r.n_train == n
    assert np.isnan(r.cost_pgnn_validation) and np.isnan(r.cost_physics_validation)
    assert np.isfinite(r.cost_pgnn)


# --------------------------------------------------------------------------- interrupts (subprocess)

@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupt_leaves_no_output(tmp_path, sig, code):
    out = tmp_path / "D"
    env = dict(os.environ, PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.Popen([sys.executable, "-m", "pgcomm", "reproduce", "--quick", "--out", str(out), "--quiet"],
                         env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    time.sleep(4.0)
    p.send_signal(sig)
    _, err = p.communicate(timeout=120)
    assert p.returncode == code, err
    assert "Traceback" not in err
    assert not out.exists()
    assert not list(tmp_path.glob(".D.*"))


def test_an_interrupt_is_not_raised_inside_a_finaliser():
    """An interrupt handler's exception raised in a garbage collector's callback (JAX's ``_xla_gc_callback``) or a
    ``__del__``, or in a function they call, is printed by Python with a traceback and dropped. Both handlers, the
    signal's and the retry's after an import, defer it there (the retry re-arms its timer) and raise it elsewhere."""
    import pgcomm.cli as cli

    def __del__():  # noqa: N807  (a frame of the finaliser's name)
        return inner()

    def inner():
        return sys._getframe()

    deep, plain = __del__(), sys._getframe()
    assert cli._in_finaliser(deep) and not cli._in_finaliser(plain)
    saved = (list(cli._PENDING), signal.getsignal(signal.SIGALRM), signal.getsignal(signal.SIGINT),
             signal.getsignal(signal.SIGTERM))
    try:
        cli._PENDING[:] = [int(signal.SIGTERM)]
        assert cli._retry_interrupt(signal.SIGALRM, deep) is None
        assert signal.getitimer(signal.ITIMER_REAL)[0] > 0  # re-armed
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        with pytest.raises(cli.Interrupted):
            cli._retry_interrupt(signal.SIGALRM, plain)
        cli._PENDING[:] = []
        assert cli._on_signal(int(signal.SIGINT), deep) is None and cli._PENDING == [int(signal.SIGINT)]
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        cli._PENDING[:] = saved[0]
        for s, h in zip((signal.SIGALRM, signal.SIGINT, signal.SIGTERM), saved[1:]):
            signal.signal(s, h)
