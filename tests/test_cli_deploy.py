"""``pgcomm check``, ``pgcomm evaluate``, ``pgcomm inspect`` end to end, and their bad input.

Every bad input gives one line ``pgcomm: error: ...`` naming the file/column/value, exit
code 2, no traceback and no output directory; ``check`` exits with 1 when the data do not
excite the model (a finding: the report is still written).
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from pgcomm.cli import main
from pgcomm.io.logs import write_log
from test_excitation import EDGES, MOTOR, synthetic_log, synthetic_logs, truth_model


def run(argv, capsys):
    """``(exit code, stdout, stderr)`` of ``pgcomm argv`` run in this process."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as e:  # check's exit code 1, argparse's 2
        code = e.code
    out, err = capsys.readouterr()
    return code, out, err


def write_logs(directory, logs, suffix=".csv"):
    """Write ``logs`` under their source names into ``directory``; returns the glob matching them."""
    directory.mkdir(parents=True, exist_ok=True)
    for lg in logs:
        write_log(directory / (lg.source.rsplit(".", 1)[0] + suffix), lg)
    return str(directory / f"*{suffix}")


def expect_error(argv, capsys, match, out=None):
    """Exit code 2, one stderr line matching ``match``, nothing on stdout, ``out`` not created (``--quiet``)."""
    code, stdout, err = run([*argv, "--quiet"], capsys)
    assert code == 2, (stdout, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pgcomm: error: "), err
    assert match in lines[0], lines[0]
    assert "Traceback" not in err and stdout == ""
    if out is not None:
        assert not out.exists()
        assert not list(out.parent.glob(f".{out.name}.*")), "staging directory left behind"
    return lines[0]


# ------------------------------------------------------------------------------------------- check


def test_check_passes_on_two_deltas(tmp_path, capsys):
    pattern = write_logs(tmp_path / "logs", synthetic_logs())
    out = tmp_path / "chk"
    code, stdout, err = run(["check", "--data", pattern, "--out", out], capsys)
    assert code == 0, err
    assert "the data excite the model of every coil set" in stdout
    res = json.loads((out / "results.json").read_text())
    assert [c["ok"] for c in res["check"]["coil_sets"]] == [True] * 3
    assert res["check"]["coil_sets"][0]["problems"] == []
    assert res["check"]["coil_sets"][0]["bins"]["samples"][0] > 0
    assert (out / "coverage.png").stat().st_size > 10_000
    assert sorted(p.name for p in out.iterdir()) == ["coverage.png", "results.json"]


def test_check_reads_host_stamped_logs_on_a_uniform_grid_and_says_so(tmp_path, capsys):
    """Logs stamped by a host's clock (each step 0.5-1.5 times the sample time): read on a uniform grid of their median
    step, every column interpolated, and the note says it; the data still excite every coil set."""
    from dataclasses import replace as dc_replace

    rng = np.random.default_rng(3)
    logs = []
    for lg in synthetic_logs():
        n = lg.columns["t"].size
        t = np.concatenate([[0.0], np.cumsum(lg.sample_time * rng.uniform(0.5, 1.5, n - 1))])
        logs.append(dc_replace(lg, columns={**lg.columns, "t": t}))
    pattern = write_logs(tmp_path / "logs", logs)
    code, stdout, err = run(["check", "--data", pattern, "--out", tmp_path / "chk"], capsys)
    assert code == 0, err
    assert err.count("resampled to a uniform grid") == len(logs), err
    assert "the data excite the model of every coil set" in stdout


def test_check_single_delta_exits_1_and_names_the_coil_set(tmp_path, capsys):
    logs = synthetic_logs()[:2] + synthetic_logs()[3:]  # coil set 2 only at Delta = +pi/4
    pattern = write_logs(tmp_path / "logs", logs)
    out = tmp_path / "chk"
    code, stdout, err = run(["check", "--data", pattern, "--out", out, "--quiet"], capsys)
    assert code == 1
    assert err.strip() == ("pgcomm: check: the data do not persistently excite the model of coil set(s) 2 "
                           "(1 problem(s))")
    res = json.loads((out / "results.json").read_text())  # the finding is written, not discarded
    cs = res["check"]["coil_sets"]
    assert [c["ok"] for c in cs] == [True, False, True] and res["check"]["ok"] is False
    assert cs[1]["problems"][0].startswith("coil set 2: a single current direction (one ratio ia:ib, Delta = +0.785")
    assert (out / "coverage.png").exists()
    code, stdout, _ = run(["check", "--data", pattern], capsys)  # the readable table
    assert code == 1
    assert "coil set 2: a single current direction" in stdout and "1 PROBLEM(S)" in stdout


def test_check_names_the_position_gap(tmp_path, capsys):
    gap = (EDGES[12], EDGES[14])
    logs = [synthetic_log(l, d, gap=gap if l == 2 else None) for l in range(3) for d in (-np.pi / 4, np.pi / 4)]
    pattern = write_logs(tmp_path / "logs", logs, ".parquet")
    code, stdout, err = run(["check", "--data", pattern], capsys)
    assert code == 1
    assert "  coil set 3: no samples for y in [0.020, 0.040] m" in stdout.splitlines()
    assert "coil set(s) 3" in err


def test_check_converts_drive_inputs_with_the_motor(tmp_path, capsys):
    from pgcomm.io.config import write_motor

    pattern = write_logs(tmp_path / "logs", synthetic_logs(drive_inputs=True))
    write_motor(tmp_path / "motor.toml", MOTOR)
    code, stdout, err = run(["check", "--data", pattern, "--motor", tmp_path / "motor.toml", "--bins", 10,
                             "--range", -0.1, 0.1], capsys)
    assert code == 0, err
    assert "excitation over y in [-0.1, 0.1] m, 10 bins" in stdout


def test_check_exit_code_of_the_console_script(tmp_path):
    pattern = write_logs(tmp_path / "logs", [synthetic_log(0, np.pi / 4)])
    # what the console script does (pyproject: pgcomm = "pgcomm.cli:main")
    script = "import sys; from pgcomm.cli import main; sys.exit(main())"
    p = subprocess.run([sys.executable, "-c", script, "check", "--data", pattern, "--quiet"], capture_output=True,
                       text=True)
    assert p.returncode == 1, p.stderr
    assert "coil set(s) 1, 2, 3" in p.stderr and "Traceback" not in p.stderr


def test_check_bad_input(tmp_path, capsys):
    out = tmp_path / "chk"
    expect_error(["check", "--data", tmp_path / "nothing" / "*.csv", "--out", out], capsys,
                 f"{tmp_path}/nothing/*.csv: no file matches", out)
    expect_error(["check", "--out", out], capsys, "--data: give at least one log file", out)
    pattern = write_logs(tmp_path / "logs", synthetic_logs())
    expect_error(["check", "--data", pattern, "--bins", 0, "--out", out], capsys, "--bins 0", out)
    expect_error(["check", "--data", pattern, "--range", 0.1, -0.1, "--out", out], capsys, "--range 0.1 -0.1", out)
    bad = synthetic_log(0, np.pi / 4, name="bad.csv")
    bad.columns["Fy"][7] = np.nan
    (tmp_path / "bad").mkdir()
    write_log(tmp_path / "bad" / "bad.csv", bad)
    expect_error(["check", "--data", tmp_path / "bad" / "bad.csv", "--out", out], capsys,
                 f"{tmp_path}/bad/bad.csv row 8 column 'Fy': nan is not a finite number", out)


# ---------------------------------------------------------------------------------------- evaluate


def test_evaluate_writes_results_and_figure(tmp_path, capsys):
    logs = [synthetic_log(0, -np.pi / 4), synthetic_log(1, np.pi / 4, reference=False, n=3001)]
    pattern = write_logs(tmp_path / "logs", logs)
    out = tmp_path / "ev"
    code, stdout, err = run(["evaluate", "--data", pattern, "--out", out, "--quiet"], capsys)
    assert code == 0, err
    assert err.strip() == (f"pgcomm: note: {tmp_path}/logs/Zp_coilset2.csv: no column r (reference): "
                           "tracking error skipped")
    res = json.loads((out / "results.json").read_text())
    ev = res["evaluation"]["logs"]
    assert [e["file"] for e in ev] == [f"{tmp_path}/logs/Zm_coilset1.csv", f"{tmp_path}/logs/Zp_coilset2.csv"]
    assert [e["samples"] for e in ev] == [6001, 3001]
    err0 = logs[0].force()[:, 0] - logs[0]["Fy_star"]
    assert ev[0]["commutation_mse"]["y"]["unfiltered"] == pytest.approx(np.mean(err0 ** 2), rel=1e-12)
    assert 0 < ev[0]["commutation_mse"]["y"]["filtered"] < ev[0]["commutation_mse"]["y"]["unfiltered"]
    assert ev[0]["tracking_mse"] > 0 and ev[1]["tracking_mse"] is None
    assert res["evaluation"]["lowpass_hz"] == 50.0 and res["runtime_s"] > 0
    assert sorted(p.name for p in out.iterdir()) == ["evaluation.png", "results.json"]


def test_evaluate_refuses_logs_without_desired_force(tmp_path, capsys):
    logs = [synthetic_log(0, -np.pi / 4), synthetic_log(1, np.pi / 4, star=False)]
    pattern = write_logs(tmp_path / "logs", logs)
    out = tmp_path / "ev"
    line = expect_error(["evaluate", "--data", pattern, "--out", out], capsys,
                        f"{tmp_path}/logs/Zp_coilset2.csv: column(s) Fy_star, Fx_star, Tz_star missing", out)
    assert "F - F*" in line


def test_evaluate_bad_input(tmp_path, capsys):
    out = tmp_path / "ev"
    expect_error(["evaluate", "--data", tmp_path / "*.mat", "--out", out], capsys, "*.mat: no file matches", out)
    pattern = write_logs(tmp_path / "logs", [synthetic_log(0, np.pi / 4)])
    expect_error(["evaluate", "--data", pattern, "--out", out, "--lowpass-hz", -5], capsys, "--lowpass-hz -5", out)
    expect_error(["evaluate", "--data", pattern, "--out", out, "--lowpass-hz", 600], capsys, "Nyquist", out)
    expect_error(["evaluate", "--data", pattern, "--out", out, "--model", tmp_path / "missing.json"], capsys,
                 "missing.json", out)


# ------------------------------------------------------------------------------------ with a model


@pytest.fixture
def model_file(tmp_path):
    """The truth model (physics only, training range [-0.1, 0.1] m) saved with identify-like metadata."""
    from pgcomm.io.model import save_model

    meta = {"seed": 7, "plant": "twin", "data": "logs",
            "identification": {"coil_sets": [{"name": f"coil set {l + 1}", "cost_physics": 2.5 + l,
                                              "cost_pgnn": 1.25 + l, "cost_physics_validation": 2.75 + l,
                                              "cost_pgnn_validation": 1.5 + l, "iterations": 12} for l in range(3)],
                               "seconds_total": 3.0}}
    json_path, _ = save_model(tmp_path / "model", truth_model(), meta)
    return json_path


def test_evaluate_with_model_reports_model_error_and_range(tmp_path, capsys, model_file):
    from pgcomm.models import CombinedModel
    from pgcomm.io.model import save_model

    logs = [synthetic_log(0, -np.pi / 4, force_offset=(0.5, 0.0, 0.0)), synthetic_log(2, np.pi / 4)]
    pattern = write_logs(tmp_path / "logs", logs)
    out = tmp_path / "ev"
    code, stdout, err = run(["evaluate", "--data", pattern, "--model", model_file, "--out", out, "--quiet"], capsys)
    assert code == 0, err
    assert err == ""  # inside the training range: no warning
    ev = json.loads((out / "results.json").read_text())["evaluation"]
    assert ev["model"] == str(model_file)
    assert ev["logs"][0]["model_mse"]["y"]["unfiltered"] == pytest.approx(0.25, rel=1e-9)
    assert ev["logs"][1]["model_mse"]["y"]["unfiltered"] == pytest.approx(0.0, abs=1e-20)
    assert ev["logs"][0]["model_currents"] == "logged" and ev["warnings"] == []
    assert sorted(p.name for p in out.iterdir()) == ["evaluation.png", "model_error.png", "results.json"]
    # a model trained on less of the stroke: one stderr warning per log, also in results.json
    m = truth_model()
    narrow, _ = save_model(tmp_path / "narrow", CombinedModel.from_coil_sets(
        [m.coil_set(l).with_range(-0.08, 0.1) for l in range(3)]))
    code, stdout, err = run(["evaluate", "--data", pattern, "--model", narrow, "--out", out, "--overwrite",
                             "--quiet"], capsys)
    assert code == 0, err
    lines = err.strip().splitlines()
    assert len(lines) == 2 and all(ln.startswith("pgcomm: warning: ") for ln in lines)
    assert "lie outside the training range [-0.08, 0.1] m" in lines[0] and "Zm_coilset1.csv" in lines[0]
    ev = json.loads((out / "results.json").read_text())["evaluation"]
    assert ev["logs"][0]["range_warning"] in lines[0] and len(ev["warnings"]) == 2



def test_evaluate_with_model_names_logs_by_folder_and_takes_logs_without_desired_force(tmp_path, capsys, model_file):
    """Two log.csv from different folders keep apart (results.json, table); with --model the one without
    Fy_star, Fx_star, Tz_star gets its model error and a note instead of a refusal."""
    from pgcomm.io.logs import write_log

    for folder, log in (("day1", synthetic_log(0, -np.pi / 4, force_offset=(0.5, 0.0, 0.0))),
                        ("day2", synthetic_log(2, np.pi / 4, force_offset=(0.5, 0.0, 0.0), star=False))):
        (tmp_path / folder).mkdir()
        write_log(tmp_path / folder / "log.csv", log)
    out = tmp_path / "ev"
    code, stdout, err = run(["evaluate", "--data", tmp_path / "day1" / "log.csv", tmp_path / "day2" / "log.csv",
                             "--model", model_file, "--out", out], capsys)
    assert code == 0, err
    assert (f"pgcomm: note: {tmp_path}/day2/log.csv: no desired force (Fy_star, Fx_star, Tz_star missing): "
            "commutation error F - F* skipped") in err
    ev = json.loads((out / "results.json").read_text())["evaluation"]
    assert [lg["name"] for lg in ev["logs"]] == ["day1/log", "day2/log"]
    assert ev["logs"][1]["commutation_mse"]["y"] == {"filtered": None, "unfiltered": None}
    for lg in ev["logs"]:
        assert lg["model_mse"]["y"]["unfiltered"] == pytest.approx(0.25, rel=1e-9)
    rows = [ln for ln in stdout.splitlines() if ln.startswith(("day1/log ", "day2/log "))]
    assert len(rows) == 4  # commutation and model error, each log once
    assert sorted(p.name for p in out.iterdir()) == ["evaluation.png", "model_error.png", "results.json"]


def test_inspect_text_and_json(capsys, model_file):
    code, stdout, err = run(["inspect", "--model", model_file], capsys)
    assert code == 0, err
    assert "coil sets L:    3" in stdout and "pole pitch:     0.03 m" in stdout
    assert "training range: [-0.1, 0.1] m (all coil sets)" in stdout
    assert "seed:           7" in stdout and "plant:          twin" in stdout
    assert "model.json (" in stdout and "model.npz (" in stdout
    code, stdout, err = run(["inspect", "--model", model_file.with_suffix(""), "--json"], capsys)
    assert code == 0, err
    info = json.loads(stdout)
    assert info["structure"]["parameters_per_coil_set"] == {"physics": 12, "gain_networks": 0,
                                                             "cogging_network": 0, "harmonics": 0,
                                                             "direction": 0, "total": 12}
    assert info["structure"]["parameters_total"] == 36 and info["structure"]["coil_sets"] == 3
    assert [c["cost_pgnn"] for c in info["costs"]] == [1.25, 2.25, 3.25]
    assert info["seed"] == 7 and info["version"] == "0.1.0" and info["date"]
    assert info["files"]["model.json"] == model_file.stat().st_size
    assert info["metadata"] == {"plant": "twin", "data": "logs"}


def test_inspect_counts_pgnn_parameters(tmp_path, capsys):
    """The paper's PGNN: per coil set 12 (A, B) + 2 x 13 (gain nets, 2 tanh units) + 83 (cogging, 16 units)."""
    import jax

    from pgcomm.models import CoilSetModel, CombinedModel
    from pgcomm.io.model import save_model

    m = truth_model()
    keys = jax.random.split(jax.random.PRNGKey(0), 3)
    pgnn = CombinedModel.from_coil_sets([CoilSetModel.init(keys[l], CoilSetModel.physics(m.A[l], m.B[l], m.pole_pitch,
                                                                                         0.0, 0.1, -0.1, 0.1))
                                         for l in range(3)])
    path, _ = save_model(tmp_path / "pgnn.json", pgnn)
    code, stdout, err = run(["inspect", "--model", path, "--json"], capsys)
    s = json.loads(stdout)["structure"]
    assert (s["gain_widths"], s["cog_widths"], s["activation"]) == ([2], [16], "tanh")
    assert s["parameters_per_coil_set"] == {"physics": 12, "gain_networks": 26, "cogging_network": 83,
                                            "harmonics": 0, "direction": 0, "total": 121}
    assert s["parameters_total"] == 363


def test_inspect_refuses_damaged_model_files(tmp_path, capsys, model_file):
    bad = tmp_path / "bad.json"
    bad.write_text(model_file.read_text()[:100])  # truncated JSON
    expect_error(["inspect", "--model", bad], capsys, f"{bad}: not a valid JSON model file")
    npz = model_file.with_suffix(".npz")
    npz.write_bytes(b"\x93NUMPY garbage" * 10)  # not an archive
    expect_error(["inspect", "--model", model_file], capsys, f"{npz}: cannot read arrays")
    expect_error(["inspect", "--model", tmp_path / "nope.json"], capsys,
                 f"{tmp_path / 'nope.json'}: model file not found")


def test_inspect_refuses_truncated_array_archive(capsys, model_file):
    npz = model_file.with_suffix(".npz")
    npz.write_bytes(npz.read_bytes()[:200])  # a partly copied file
    expect_error(["inspect", "--model", model_file], capsys, f"{npz}: cannot read arrays")
