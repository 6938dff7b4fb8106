"""The rig loop: ``pgcomm plan`` → (the rig: ``pgcomm simulate --plan`` on the twin) →
``pgcomm calibrate --data`` → the next round's motor TOML, round after round; and the noise figures
(standard errors) the convergence rule rests on."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from pgcomm.calibration import CalibrationOptions, convergence, fit_coefficients
from pgcomm.cli import main
from pgcomm.experiment import data_generation_reference, run_calibration
from pgcomm.setup import build_setup
from pgcomm.settings import CalibrationConfig, ExperimentConfig
from pgcomm.io.config import load_motor
from pgcomm.io.plan import read_plan
from pgcomm.io.references import read_reference


def _cli(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def rounds(tmp_path_factory):
    """Two rounds on the twin, every step through the command line and files."""
    root = tmp_path_factory.mktemp("rig")
    motor = None
    out = []
    for r in (1, 2):
        plan, logs, cal = root / f"plan{r}", root / f"logs{r}", root / f"cal{r}"
        argv = ["plan", "--out", str(plan), "--quiet"] + (["--motor", str(motor)] if motor else [])
        assert main(argv) == 0
        assert main(["simulate", "--plan", str(plan), "--out", str(logs), "--seed", str(10 * r), "--quiet"]) == 0
        assert main(["calibrate", "--data", str(logs / "*.csv"), "--motor", str(plan / "motor.toml"),
                     "--out", str(cal), "--quiet"]) == 0
        out.append((plan, logs, cal, json.loads((cal / "results.json").read_text())["calibration"]))
        motor = cal / "motor.toml"
    return out


def test_plan_files_play_back_the_data_generation_reference(rounds):
    """The plan's files: 2 L experiments, one reference (the in-process one), Δ = ∓π/4, the drive at k0, ζ0."""
    plan_dir = rounds[0][0]
    plan = read_plan(plan_dir)
    setup = build_setup(ExperimentConfig())
    ref = data_generation_reference(setup)
    L = setup.motor.n_coil_sets
    assert [e.name for e in plan.experiments] == [f"Z{i}_coilset{l}" for l in range(1, L + 1) for i in (1, 2)]
    np.testing.assert_allclose([e.delta for e in plan.experiments], [-math.pi / 4, math.pi / 4] * L, rtol=1e-15)
    # positions are written in shortest round-trip form: equal to the in-process reference to the last bit
    np.testing.assert_allclose(plan.reference.r, ref.r, rtol=0, atol=1e-15 * np.abs(ref.r).max())
    np.testing.assert_allclose(plan.motor.k, setup.motor.k, rtol=1e-15)
    ref_file = read_reference(plan_dir / "references" / "Z2_coilset3.csv")
    assert ref_file.sample_time == pytest.approx(setup.motor.sample_time, rel=1e-9)
    doc = json.loads((plan_dir / "plan.json").read_text())
    assert doc["total_duration_s"] == pytest.approx(2 * L * ref.r.shape[0] * ref.sample_time, rel=1e-9)
    text = (plan_dir / "plan.md").read_text()
    assert "no feedforward" in text and "zero force command" in text and "pgcomm calibrate --data" in text


def test_logs_of_the_plan_pass_check_and_keep_delta_constant(rounds, capsys):
    """``pgcomm check`` passes on the plan's logs; ``delta_l`` of the commanded coil set stays at the plan's Δ
    while the force command changes sign (one drive-input convention: the sign in ``Fy_ref_l``)."""
    plan_dir, logs = rounds[0][0], rounds[0][1]
    code, out, err = _cli(["check", "--data", str(logs / "*.csv"), "--motor", str(plan_dir / "motor.toml")], capsys)
    assert code == 0, out + err
    from pgcomm.io.logs import read_log

    log = read_log(logs / "Z1_coilset2.csv")
    fy, d = log["Fy_ref_2"], log["delta_2"]
    moving = np.abs(fy) > 1e-3 * np.abs(fy).max()
    assert (fy[moving] > 0).any() and (fy[moving] < 0).any()
    np.testing.assert_allclose(d[moving], -math.pi / 4, rtol=0, atol=1e-9)


def test_rounds_reach_the_in_process_algorithm_1(rounds):
    """Two rounds through files reach in-process Algorithm 1 (two passes) within the rounds' own noise.

    Both are estimates at the same fixed point with independent noise, so their difference has about
    √2 times one round's standard error; 5 × √2 × SE (SE from the file round's residuals) as the bar.
    """
    cal = rounds[-1][3]
    setup = build_setup(ExperimentConfig(calibration=CalibrationConfig(iterations=2, tol=0.0)))
    ref = data_generation_reference(setup)
    inproc, _ = run_calibration(setup, ref, seed=777)
    k, z = np.asarray(cal["calibrated"]["k"]), np.asarray(cal["calibrated"]["zeta"])
    k_se, z_se = np.asarray(cal["standard_error"]["k"]), np.asarray(cal["standard_error"]["zeta"])
    assert np.all(k_se > 0) and np.all(z_se > 0)
    assert np.all(np.abs(k - inproc.k) <= 5 * math.sqrt(2) * k_se), (k - inproc.k) / k_se
    assert np.all(np.abs(z - inproc.zeta) <= 5 * math.sqrt(2) * z_se), (z - inproc.zeta) / z_se
    # the first round moved far beyond its noise; the next round's motor TOML holds the new values
    first = rounds[0][3]
    assert not first["convergence"]["converged"]
    nxt = load_motor(rounds[0][2] / "motor.toml")
    np.testing.assert_allclose(nxt.k, first["calibrated"]["k"], rtol=1e-15)
    assert nxt.travel == load_motor(rounds[0][0] / "motor.toml").travel


def test_standard_error_matches_the_closed_form_and_the_spread_over_noise(rng):
    """The residual-based covariance of (ĉ1, ĉ2): against σ²/Σ F*² (eq. Ci, white noise) and, for the
    ``offset`` method, against the spread of ĉ over independent noise draws."""
    n, ts, sigma = 20000, 1e-3, 2.0
    t = np.arange(n) * ts
    y = 0.1 * np.sin(2 * np.pi * 0.25 * t)
    fs1 = 40 * np.sin(2 * np.pi * 0.5 * t) + 30 * np.sign(np.cos(2 * np.pi * 0.25 * t))
    fs2 = 1.1 * fs1
    c_true = (0.7, 0.6)
    draws, se = [], []
    for _ in range(40):
        fy1 = c_true[0] * fs1 + sigma * rng.normal(size=n)
        fy2 = c_true[1] * fs2 + sigma * rng.normal(size=n)
        c1, c2, cov = fit_coefficients((fy1, fs1, y), (fy2, fs2, y), CalibrationOptions(method="offset", n_bins=10),
                                       sample_time=ts, pole_pitch=0.03, return_cov=True)
        draws.append((c1, c2))
        se.append(np.sqrt(np.diag(cov)))
    draws, se = np.asarray(draws), np.asarray(se)
    # 40 draws: the sample standard deviation is within ±35 % of the truth with > 99 % probability
    np.testing.assert_allclose(draws.std(axis=0, ddof=1), se.mean(axis=0), rtol=0.35)
    p1, p2, cov = fit_coefficients((fy1, fs1, y), (fy2, fs2, y), CalibrationOptions(method="paper"), sample_time=ts,
                                   return_cov=True)
    closed = sigma**2 / np.array([fs1 @ fs1, fs2 @ fs2])
    # the variance from 40 blocks of residuals: relative error about sqrt(2/40) = 0.22; 3x that as the bar
    np.testing.assert_allclose(np.diag(cov), closed, rtol=0.67)


def test_convergence_rule():
    """A step within max(tol, 3 √2 SE) converges; one beyond it does not; tol is the floor."""
    from pgcomm.calibration import CalibrationResult, CalibrationStep

    def result(k_new, z_new, k_se, z_se):
        steps = [CalibrationStep(0, 1.0, 1.0, k_new, z_new, k_se, z_se)]
        return CalibrationResult(np.array([k_new]), np.array([z_new]), np.array([60.0]), np.array([-0.5]), 1,
                                 [steps])

    se_k = 0.06  # N/A: 1e-3 relative at k = 60
    assert convergence(result(60.0 * (1 + 4e-3), -0.5, se_k, 1e-4))["converged"]
    assert not convergence(result(60.0 * (1 + 4.5e-3), -0.5, se_k, 1e-4))["converged"]
    assert not convergence(result(60.0, -0.5 + 5e-4, se_k, 1e-4))["converged"]
    assert convergence(result(60.0, -0.5 + 5e-4, se_k, 1e-4), tol=6e-4)["converged"]


@pytest.mark.parametrize("argv, needle", [
    (["calibrate", "--data", "x.csv", "--plant", "map.csv"], "--plant does not go with --data"),
    (["simulate", "--plan", "p", "--law", "oracle"], "--law does not go with --plan"),
    (["simulate", "--plan", "nowhere"], "no plan.json"),
])
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, argv, needle):
    out = tmp_path / "out"
    code, _, err = _cli(argv + ["--out", str(out)], capsys)
    assert code == 2 and needle in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists()


def test_plan_for_a_rig_needs_the_travel_or_a_stroke(tmp_path, capsys):
    """A motor TOML without travel and no [reference] stroke: one line naming both ways out; with a stroke
    the plan spans it; without a force sensor the motor must give the mass."""
    from pgcomm.io.config import write_motor
    from pgcomm.twin import TwinParams

    motor = tmp_path / "motor.toml"
    write_motor(motor, replace(TwinParams().motor(), mass=None))
    code, _, err = _cli(["plan", "--motor", str(motor), "--out", str(tmp_path / "p")], capsys)
    assert code == 2 and "travel" in err and "stroke" in err and not (tmp_path / "p").exists()
    cfg = tmp_path / "c.toml"
    cfg.write_text("[reference]\nstroke = 0.05\ncenter = 0.01\n")
    code, _, err = _cli(["plan", "--motor", str(motor), "--config", str(cfg), "--out", str(tmp_path / "p"),
                         "--quiet"], capsys)
    assert code == 0, err
    r = read_plan(tmp_path / "p").reference.r
    np.testing.assert_allclose([r.min(), r.max()], [-0.04, 0.06], rtol=0, atol=1e-12)
    code, _, err = _cli(["plan", "--motor", str(motor), "--config", str(cfg), "--no-force-sensor",
                         "--out", str(tmp_path / "q")], capsys)
    assert code == 2 and "mass" in err and not (tmp_path / "q").exists()


def test_logs_carry_their_round_and_another_rounds_motor_is_refused(rounds, capsys, tmp_path):
    """Each log of ``simulate --plan`` carries its plan (id, k̂, ζ̂, pole pitch, sample time). Round 1's logs with
    round 2's motor TOML: refused naming the log and the k̂ it was recorded at (calibrated against the wrong drive
    values it gave k = 55.5 N/A where 61 is right); with their own plan's TOML they calibrated above."""
    import re

    from pgcomm.io.plan import plan_id

    plan1, logs1 = rounds[0][0], rounds[0][1]
    plan2 = rounds[1][0]
    side = json.loads((logs1 / "Z1_coilset1.csv.plan.json").read_text())
    assert side["plan_id"] == json.loads((plan1 / "plan.json").read_text())["id"] == plan_id(read_plan(plan1))
    assert side["plan_id"] != plan_id(read_plan(plan2))
    m1 = load_motor(plan1 / "motor.toml")
    assert (side["k_hat_N_per_A"], side["zeta_hat_rad"]) == (list(m1.k), list(m1.zeta))
    assert (side["experiment"], side["coil_set"]) == ("Z1_coilset1", 1)
    k2 = load_motor(plan2 / "motor.toml").k[0]
    assert abs(k2 - m1.k[0]) > 0.05 * m1.k[0]
    out = tmp_path / "cal"
    code, _, err = _cli(["calibrate", "--data", str(logs1 / "*.csv"), "--motor", str(plan2 / "motor.toml"),
                         "--out", str(out), "--quiet"], capsys)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert re.search(rf"Z1_coilset1\.csv: recorded under plan {side['plan_id']} \(Z1_coilset1\.csv\.plan\.json\) with "
                     rf"k̂1 = {m1.k[0]:.6g} N/A, but --motor \S+plan2/motor\.toml has k̂1 = {k2:.6g} N/A: logs of "
                     "another round", lines[0]), lines[0]
    assert not out.exists()


def _sidecar_log(folder, name, motor, plan="aaaaaaaaaaaa", **changes):
    """A log (its columns do not matter here) with a plan sidecar of ``motor``'s drive values, edited by ``changes``."""
    from pgcomm.io.logs import Log
    from pgcomm.io.plan import write_log_identity

    path = folder / name
    ident = {"schema": "pgcomm-log-plan/1", "plan_id": plan, "experiment": "Z1_coilset1", "coil_set": 1,
             "delta_rad": -math.pi / 4, "k_hat_N_per_A": list(motor.k), "zeta_hat_rad": list(motor.zeta),
             "pole_pitch_m": motor.pole_pitch, "sample_time_s": motor.sample_time} | changes
    write_log_identity(path, ident)
    return Log({"t": np.arange(3) * motor.sample_time}, motor.sample_time, source=str(path))


@pytest.mark.parametrize("changes, needle", [
    ({"pole_pitch_m": 0.024}, r"with pole pitch 0\.024 m, but M has 0\.03 m: logs of another motor"),
    ({"sample_time_s": 2e-3}, r"with sample time 0\.002 s, but M has 0\.001 s: logs of another motor"),
    ({"k_hat_N_per_A": [67.0, 61.0, 67.0]}, r"with k̂2 = 61 N/A, but M has k̂2 = 67 N/A: logs of another round"),
    ({"zeta_hat_rad": [-0.52, -0.52, -0.5]}, r"with ζ̂3 = -0\.5 rad, but M has ζ̂3 = -0\.52 rad"),
    ({"k_hat_N_per_A": [67.0] * 2, "zeta_hat_rad": [-0.52] * 2}, r"with 2 coil set\(s\), but M has 3"),
])
def test_a_log_recorded_at_other_drive_values_is_refused_naming_the_value(tmp_path, changes, needle):
    from pgcomm.errors import DataError
    from pgcomm.io.plan import check_log_plans
    from pgcomm.twin import TwinParams

    motor = TwinParams().motor()
    good = _sidecar_log(tmp_path, "a.csv", motor)
    bad = _sidecar_log(tmp_path, "b.csv", motor, **changes)
    assert check_log_plans([good], motor, "M") == []
    with pytest.raises(DataError, match=rf"^{tmp_path}/b\.csv: recorded under plan aaaaaaaaaaaa \(b\.csv\.plan\.json\) "
                                        + needle):
        check_log_plans([good, bad], motor, "M")


def test_logs_of_two_plans_are_refused_and_logs_without_a_plan_get_a_note(tmp_path):
    from pgcomm.errors import DataError
    from pgcomm.io.logs import Log
    from pgcomm.io.plan import check_log_plans
    from pgcomm.twin import TwinParams

    motor = TwinParams().motor()
    one, two = _sidecar_log(tmp_path, "a.csv", motor), _sidecar_log(tmp_path, "b.csv", motor, plan="bbbbbbbbbbbb")
    with pytest.raises(DataError, match=r"b\.csv: recorded under plan bbbbbbbbbbbb .*, but \S+a\.csv under plan "
                                        r"aaaaaaaaaaaa: give the logs of one round at a time"):
        check_log_plans([one, two], motor, "M")
    own = [Log({"t": np.arange(3) * ts}, ts, source=str(tmp_path / f"own{i}.csv")) for i, ts in enumerate((1e-3, 5e-4))]
    notes = check_log_plans([one, *own], motor, "M")
    assert notes[0].startswith("2 log(s) without a plan sidecar")
    assert "taken as recorded at the drive values of M" in notes[0]
    assert len(notes) == 2 and "own1.csv: sample time 0.0005 s, M has 0.001 s" in notes[1]
    (tmp_path / "bad.csv.plan.json").write_text("{not json")
    with pytest.raises(DataError, match=r"bad\.csv\.plan\.json: not a readable plan sidecar"):
        check_log_plans([Log({"t": np.arange(3) * 1e-3}, 1e-3, source=str(tmp_path / "bad.csv"))], motor, "M")
