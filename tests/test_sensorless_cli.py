"""Identification without a force sensor through the command line.

Logs of the twin's data sets (``pgcomm calibrate --save-data``) with their force columns dropped
are what a rig without a force sensor records. ``identify`` on them (automatically without a
force sensor), ``check`` and ``evaluate`` run end to end through :func:`pgcomm.cli.main`, kept
small (two reference speeds, two random starts, ten iterations) so that the module runs in
well under a minute and a half.
"""

from __future__ import annotations

import json

import jax.numpy as jnp
import numpy as np
import pytest

from pgcomm.cli import main
from pgcomm.errors import DataError
from pgcomm.setup import build_setup
from pgcomm.settings import ExperimentConfig
from pgcomm.io.logs import Log, read_log, write_log
from pgcomm.io.model import load_model
from pgcomm.motor import ideal_gain

SMALL = ("[reference]\nvelocities = [0.075, 0.15]\ndwell = 0.2\n"
         "[identification]\nstarts = 2\nmax_iterations = 10\n")


def run(argv, capsys):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """``{"config", "with_force": [paths], "without": [paths]}``: the twin's data sets ``Z_i^l`` as logs."""
    d = tmp_path_factory.mktemp("sl")
    cfg = d / "exp.toml"
    cfg.write_text(SMALL)
    assert main(["calibrate", "--config", str(cfg), "--save-data", "--out", str(d / "cal"), "--quiet"]) == 0
    with_force = sorted((d / "cal" / "data").glob("*.csv"))
    (d / "nf").mkdir()
    without = []
    for p in with_force:
        log = read_log(p)
        cols = {k: v for k, v in log.columns.items() if k not in ("Fy", "Fx", "Tz")}
        write_log(d / "nf" / p.name, Log(cols, log.sample_time))
        without.append(d / "nf" / p.name)
    return {"dir": d, "config": cfg, "with_force": with_force, "without": without}


@pytest.fixture(scope="module")
def identified(logs):
    """``pgcomm identify --data`` on the force-less logs (no option: the mode is chosen from the logs)."""
    import contextlib
    import io

    out = logs["dir"] / "id"
    err, std = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(std):
        code = main(["identify", "--data", *map(str, logs["without"]), "--config", str(logs["config"]),
                     "--out", str(out)])
    assert code == 0, err.getvalue()
    return out, std.getvalue(), err.getvalue()


def test_identify_without_force_sensor_records_it(identified):
    out, stdout, stderr = identified
    assert "the logs have no force columns (Fy, Fx, Tz): identifying without a force sensor" in stderr
    model, doc = load_model(out / "model.json")
    meta = doc["metadata"]
    assert doc["identification"] == "no_force_sensor" and meta["force_sensor"] is False
    mass = ExperimentConfig().mechanics.mass  # the built-in twin's mass is known: no motor file needed
    assert meta["mechanics"]["mass"] == mass and meta["feedforward"]["mass"] == mass
    res = json.loads((out / "results.json").read_text())
    assert res["force_sensor"] is False and res["feedforward"] == meta["feedforward"]
    for c in res["identification"]["coil_sets"]:
        assert c["force_sensor"] is False and c["mechanics"]["mass"] == mass and c["cost_pgnn"] < c["cost_physics"]
    ff = meta["feedforward"]
    assert f"feedforward: m = {mass:.4g} kg, f_v = {ff['viscous']:.4g} N s/m, f_c = {ff['coulomb']:.4g} N" in stdout
    # friction opposes the motion; the twin's direction force (same column s(ẏ)) is part of f_c
    mech = ExperimentConfig().mechanics
    assert 0 < ff["viscous"] < 2 * mech.viscous and 0 < ff["coulomb"] < 2 * mech.coulomb
    table, knots = meta["mechanics"]["coulomb_table"], meta["mechanics"]["coulomb_knots"]
    assert len(table) == len(knots) > 2 and min(table) > 0  # F_c(y) along the stroke


def test_identified_y_gain_matches_the_plant_and_xz_are_classical(identified):
    out, _, _ = identified
    model, _ = load_model(out / "model.json")
    setup = build_setup(ExperimentConfig())
    lo, hi = model.training_range
    y = jnp.asarray(np.linspace(lo + 0.005, hi - 0.005, 801))
    g_model = np.asarray(model.gain(y))  # (N, L, 3, 2)
    g_true = np.asarray(setup.plant.gain(y))
    g_nominal = np.asarray(ideal_gain(y, setup.motor))  # the drive's k = 67, zeta = -0.52
    for l in range(3):
        scale = np.sqrt(np.mean(g_true[:, l, 0] ** 2))  # N/A: the y row's size
        err = np.sqrt(np.mean((g_model[:, l, 0] - g_true[:, l, 0]) ** 2))
        err_nominal = np.sqrt(np.mean((g_nominal[:, l, 0] - g_true[:, l, 0]) ** 2))
        # identified from the motion within 3 % of the gain's size (measured ~1 %), far better than the drive's
        # nominal guess (~10 %)
        assert err < 0.03 * scale and err < 0.3 * err_nominal, (l, err / scale, err_nominal / scale)
        # x and z rows: the classical model with the motor's nominal k, zeta, mu and lever arm
        np.testing.assert_allclose(g_model[:, l, 1:], g_nominal[:, l, 1:], rtol=1e-9, atol=1e-9 * scale)


def test_generated_data_without_force_sensor(logs, capsys, tmp_path):
    """Without ``--data``, ``--no-force-sensor`` drops the force of the data generated on the plant."""
    code, stdout, err = run(["identify", "--no-force-sensor", "--config", logs["config"], "--out", tmp_path / "g"],
                            capsys)
    assert code == 0, err
    res = json.loads((tmp_path / "g" / "results.json").read_text())
    assert res["force_sensor"] is False and res["data"] == "twin"
    assert all(c["mechanics"]["windows"] * c["mechanics"]["filter"]["stride"] > 0.5 * 2 * 9000
               for c in res["identification"]["coil_sets"])  # two data sets of ~9400 samples each
    assert "feedforward: m = 30 kg" in stdout


def test_mixed_logs_need_the_option(logs, capsys, tmp_path):
    code, _, err = run(["identify", "--data", *logs["without"][:-1], logs["with_force"][-1], "--out", tmp_path / "m"],
                       capsys)
    assert code == 2 and "5 of 6 logs have no force columns" in err and "--no-force-sensor" in err
    assert not (tmp_path / "m").exists()


def test_force_sensor_data_refuse_forceless_logs(logs):
    from pgcomm.data import coil_set_data_from_logs

    log = read_log(logs["without"][0])
    with pytest.raises(DataError, match=r"no force columns Fy, Fx, Tz .*--no-force-sensor"):
        coil_set_data_from_logs([log], build_setup(ExperimentConfig()).motor)


def test_check_on_forceless_logs(logs, capsys, tmp_path):
    code, stdout, err = run(["check", "--data", *logs["without"], "--out", tmp_path / "c"], capsys)
    assert code == 0, err
    assert "the data excite the model of every coil set" in stdout
    assert "6 of 6 log(s) have no force columns" in stdout
    res = json.loads((tmp_path / "c" / "results.json").read_text())
    assert len(res["logs_without_force"]) == 6 and res["check"]


def test_evaluate_reconstructs_the_force(logs, identified, capsys, tmp_path):
    model = identified[0] / "model.json"
    code, stdout, err = run(["evaluate", "--data", logs["without"][0], logs["with_force"][0], "--model", model,
                             "--out", tmp_path / "e"], capsys)
    assert code == 0, err
    assert "reconstructing Fy from the motion" in err and "(rec.)" in stdout
    ev = json.loads((tmp_path / "e" / "results.json").read_text())["evaluation"]
    assert ev["force_reconstructed"] is True
    rec, meas = ev["logs"]
    assert rec["force_reconstructed"] is True and meas["force_reconstructed"] is False
    recon = rec["reconstruction"]
    # windows cover most of the log (standstill and reversals left out), one every `stride` samples
    assert recon["mechanics"]["mass"] == 30.0 and recon["windows"] * recon["filter"]["stride"] > 0.5 * rec["samples"]
    assert any("reconstructed from the motion" in n for n in rec["notes"])
    for d in ("x", "z"):
        assert rec["commutation_mse"][d]["filtered"] is None and rec["model_mse"][d]["filtered"] is None
    assert rec["commutation_mse"]["y"]["unfiltered"] is None
    # Delta = -pi/4 drives: a commutation error of the size the force sensor sees (same log), and the
    # identified model explains the reconstructed force far better than the demand does
    y_rec, y_meas = rec["commutation_mse"]["y"]["filtered"], meas["commutation_mse"]["y"]["filtered"]
    assert 0.5 * y_meas < y_rec < 2.0 * y_meas
    assert rec["model_mse"]["y"]["filtered"] < 0.05 * y_rec
    assert (tmp_path / "e" / "evaluation.png").stat().st_size > 10_000
    assert (tmp_path / "e" / "model_error.png").stat().st_size > 10_000


def test_calibrate_without_force_sensor(tmp_path, capsys):
    """Algorithm 1 from the motion on the default twin: the calibration bar (0.5 %, 5 mrad) holds
    without force data too; results.json says how it was calibrated."""
    out = tmp_path / "out"
    code, _, err = run(["calibrate", "--out", str(out), "--quiet", "--no-force-sensor"], capsys)
    assert code == 0, err
    res = json.loads((out / "results.json").read_text())
    cal = res["calibration"]
    assert res["force_sensor"] is False and cal["method"] == "sensorless" and cal["mass"] == 30.0
    k_true, z_true = np.asarray(cal["true"]["k"]), np.asarray(cal["true"]["zeta"])
    assert np.all(np.abs(np.asarray(cal["calibrated"]["k"]) / k_true - 1) < 0.005)
    assert np.all(np.abs(np.asarray(cal["calibrated"]["zeta"]) - z_true) < 0.005)
