"""pgcomm fleet on a real Dask LocalCluster (2 worker processes), and the robust outlier score."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from pgcomm.cli import main
from pgcomm.fleet import flag_outliers, robust_z
from pgcomm.experiment import write_production_logs
from pgcomm.zoo import draw_motor, write_motor

# zoo seed 1: indices 9 and 10 are single-coil-set motors with short data sets of about the same
# length (one compiled identification serves both), index 4 gets a corrupt log.
GOOD = {"motor_01": 9, "motor_02": 10}
BAD = ("motor_03", 4)


def _small_motor(folder: Path, index: int) -> Path:
    """A zoo motor with a short reference (fastest speed only) and a light identification."""
    f = write_motor(draw_motor(1, index), folder)
    c = (f / "config.toml").read_text()
    c = re.sub(r"velocities = \[([^,]*), [^\]]*\]", lambda m: f"velocities = [{m.group(1)}]", c)
    c = re.sub(r"dwell = \S+", "dwell = 0.05", c)
    (f / "config.toml").write_text(c + "\n[identification]\nstarts = 2\nmax_iterations = 3\n")
    write_production_logs(f, seed=0)
    return f


@pytest.fixture(scope="module")
def fleet_dir(tmp_path_factory, release_memory):
    root = tmp_path_factory.mktemp("fleet")
    for name, i in GOOD.items():
        _small_motor(root / "data" / name, i)
    bad = _small_motor(root / "data" / BAD[0], BAD[1])
    log = bad / "logs" / "Z2_coilset1.csv"
    lines = log.read_text().split("\n")
    cells = lines[50].split(",")
    cells[3] = "abc"
    lines[50] = ",".join(cells)
    log.write_text("\n".join(lines))
    # the logs' simulations compiled programs in this process: released before the fleet's two worker
    # processes start (all three at once would hold ~2.5 GB)
    release_memory()
    return root


def test_fleet_on_local_cluster_resumes_and_matches_identify(fleet_dir, capsys, release_memory):
    data, out = fleet_dir / "data", fleet_dir / "out"
    # a fleet with a failed motor exits with code 2 and one line with the count, after writing its workspace
    assert main(["fleet", "--data", str(data), "--out", str(out), "--workers", "2", "--quiet"]) == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert line.startswith(f"pgcomm: error: fleet: 1 of 3 motor(s) failed ({BAD[0]}: "), line
    import pyarrow.parquet as pq

    table = pq.read_table(out / "fleet.parquet").to_pylist()
    by = {r["motor"]: r for r in table}
    assert set(by) == {*GOOD, BAD[0]}
    assert by[BAD[0]]["status"] == "failed"
    err = by[BAD[0]]["error"]
    assert "\n" not in err and "Z2_coilset1.csv" in err and "'Fy'" in err and "not a number" in err
    # the same line the CLI prints for that log
    assert main(["identify", "--data", str(data / BAD[0] / "logs" / "*.csv"), "--out", str(fleet_dir / "x"),
                 "--quiet"]) == 2
    assert capsys.readouterr().err.strip() == f"pgcomm: error: {err}"
    assert (out / "fleet.csv").read_text().count("\n") == 4
    html = (out / "fleet.html").read_text()
    assert "Outliers" in html and "data:image/png;base64," in html and BAD[0] in html

    # each good motor: the same numbers as pgcomm calibrate / identify run alone on its logs
    for name in GOOD:
        row = by[name]
        assert row["status"] == "ok" and row["coil_set"] == 1
        m = data / name
        opts = ["--plant", str(m / "plant.csv"), "--motor", str(m / "motor.toml"), "--config", str(m / "config.toml"),
                "--quiet"]
        alone = fleet_dir / f"alone_{name}"
        assert main(["identify", "--data", str(m / "logs" / "*.csv"), "--out", str(alone), *opts]) == 0
        ident = json.loads((alone / "results.json").read_text())["identification"]["coil_sets"][0]
        cal_dir = fleet_dir / f"cal_{name}"
        assert main(["calibrate", "--out", str(cal_dir), *opts]) == 0
        cal = json.loads((cal_dir / "results.json").read_text())["calibration"]["calibrated"]
        # tolerances from the data's scale: costs relative to the physics cost (N^2), k relative, zeta in rad
        scale = ident["cost_physics"]
        assert row["cost_physics"] == pytest.approx(ident["cost_physics"], rel=1e-9)
        assert abs(row["cost_pgnn"] - ident["cost_pgnn"]) <= 1e-6 * scale
        assert row["k"] == pytest.approx(cal["k"][0], rel=1e-9)
        assert abs(row["zeta"] - cal["zeta"][0]) <= 1e-9
        assert row["improvement"] == pytest.approx(ident["cost_physics"] / ident["cost_pgnn"], rel=1e-6)
        assert row["cogging_pp"] > 0 and row["seconds"] > 0
        for f in ("model.json", "model.npz", "results.json", "pgcomm_law.c", "pgcomm_law.h", "pgcomm_lut.csv",
                  "pgcomm_lut_cogging.csv"):
            assert (out / name / f).is_file(), f

    # a rerun does no work for the finished motors: only the failed one is submitted again
    release_memory()  # the in-process identify/calibrate runs' programs, before the workers start again
    stamps = {n: (out / n / "fleet_rows.json").stat().st_mtime_ns for n in GOOD}
    assert main(["fleet", "--data", str(data), "--out", str(out), "--workers", "2", "--quiet"]) == 2
    run = json.loads((out / "fleet.json").read_text())
    assert run["submitted"] == [BAD[0]] and sorted(run["skipped"]) == sorted(GOOD)
    assert {n: (out / n / "fleet_rows.json").stat().st_mtime_ns for n in GOOD} == stamps
    assert (out / "failed" / f"{BAD[0]}.json").is_file()


def test_robust_z_hand_computed():
    x = np.array([10.0, 11.0, 9.0, 10.5, 9.5, 30.0])
    # median 10.25; |x - med| = .25 .75 1.25 .25 .75 19.75 -> MAD = 0.75; scale = 1.4826 * 0.75 = 1.11195
    z = robust_z(x)
    np.testing.assert_allclose(z, (x - 10.25) / 1.11195, rtol=1e-12)
    assert z[-1] == pytest.approx(17.761590, rel=1e-6)  # 19.75 / 1.11195
    rows = [{"motor": f"m{i}", "coil_set": 1, "status": "ok", "k": v, "zeta": 0.1, "cogging_pp": 1.0,
             "improvement": 2.0} for i, v in enumerate(x)] + [{"motor": "bad", "status": "failed", "k": None}]
    flags = flag_outliers(rows, threshold=3.5)
    assert [(f["motor"], f["quantity"]) for f in flags] == [("m5", "k")]
    assert flags[0]["median"] == 10.25
    # all equal -> no outliers; MAD = 0 with one differing value -> mean absolute deviation fallback
    assert np.all(robust_z([2.0, 2.0, 2.0]) == 0)
    np.testing.assert_allclose(robust_z([1.0, 1.0, 1.0, 5.0]), [0, 0, 0, 4.0 / (1.2533 * 1.0)])
