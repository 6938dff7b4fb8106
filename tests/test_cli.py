"""End-to-end CLI tests: simulate, calibrate (twin and force map), reproduce --quick, and bad input."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from pgcomm.cli import main
from pgcomm.forcemap import ForceMapPlant
from pgcomm.io.forcemap import write_forcemap
from pgcomm.io.config import write_motor
from pgcomm.twin import DEFAULT_TWIN, true_fundamental


def test_the_command_line_loads_no_jax_scipy_or_matplotlib_before_a_command_runs():
    """``import pgcomm.cli`` (every command's parser) and ``pgcomm --help`` load none of the heavy libraries: their
    imports sit inside the commands, so a bad option is answered at once."""
    heavy = ("jax", "scipy", "matplotlib", "dask", "pyarrow", "h5py")
    code = ("import sys, pgcomm.cli; from pgcomm.cli import build_parser; build_parser().format_help(); "
            f"loaded = [m for m in {heavy!r} if m in sys.modules]; assert not loaded, loaded")
    subprocess.run([sys.executable, "-c", code], check=True)


def run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """``pgcomm calibrate`` on the default twin (sensor noise on)."""
    out = tmp_path_factory.mktemp("cal") / "out"
    assert main(["calibrate", "--out", str(out), "--quiet"]) == 0
    return json.loads((out / "results.json").read_text()), out


def test_calibrate_recovers_true_fundamental(calibrated):
    """Calibration bar: every coil set's k within 0.5 % and zeta within 5 mrad of the twin's true fundamental."""
    res, out = calibrated
    cal = res["calibration"]
    k_true, z_true = true_fundamental(DEFAULT_TWIN)
    np.testing.assert_allclose(cal["true"]["k"], k_true, rtol=1e-12)
    k = np.asarray(cal["calibrated"]["k"])
    z = np.asarray(cal["calibrated"]["zeta"])
    assert np.all(np.abs(k / k_true - 1) < 0.005), k / k_true - 1
    assert np.all(np.abs(z - z_true) < 0.005), z - z_true
    assert cal["initial"]["k"] == [67.0, 67.0, 67.0]
    assert (out / "calibration.png").stat().st_size > 10_000


def test_calibrate_on_forcemap_plant(tmp_path, capsys):
    """The same command runs unchanged on a force-map plant (here: the twin tabulated, without the
    direction-dependent force, which a static map cannot hold)."""
    tw = DEFAULT_TWIN.without("direction")
    plant = tw.plant()
    y = np.linspace(-0.13, 0.13, 2601)
    fm = ForceMapPlant.from_plant(plant, y)
    write_forcemap(tmp_path / "map.csv", y, np.asarray(fm.gain_table), np.asarray(fm.cog_table))
    write_motor(tmp_path / "motor.toml", tw.motor())
    out = tmp_path / "out"
    code, stdout, err = run(["calibrate", "--out", str(out), "--plant", str(tmp_path / "map.csv"), "--motor",
                             str(tmp_path / "motor.toml"), "--quiet"], capsys)
    assert code == 0, err
    res = json.loads((out / "results.json").read_text())
    assert res["calibration"]["true"]["k"] is None
    k_true, z_true = true_fundamental(tw)
    # the tabulated map is linearly interpolated at 0.1 mm: same truth to well within the bar
    np.testing.assert_allclose(res["calibration"]["calibrated"]["k"], k_true, rtol=0.005)
    np.testing.assert_allclose(res["calibration"]["calibrated"]["zeta"], z_true, atol=0.005)


def test_simulate_writes_log_plot_results(tmp_path, capsys):
    out = tmp_path / "sim"
    code, stdout, err = run(["simulate", "--out", str(out), "--law", "true", "--quiet", "--no-feedforward"], capsys)
    assert code == 0, err
    res = json.loads((out / "results.json").read_text())
    mse = res["commutation_mse"]["true"]["y"]
    assert mse["unfiltered"] > mse["filtered"] > 0
    header = (out / "log.csv").read_text().splitlines()[0].split(",")
    for col in ("t", "y", "Fy", "Fx", "Tz", "ia_1", "ib_1", "Fy_ref_3", "delta_3", "r"):
        assert col in header
    assert (out / "run.png").exists()


def _expect_error(argv, capsys, match, out=None):
    code, stdout, err = run(argv, capsys)
    assert code == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("pgcomm: error:"), err
    assert match in lines[0], lines[0]
    assert "Traceback" not in err
    if out is not None:
        assert not out.exists() or not any(out.iterdir())


def test_bad_config_key(tmp_path, capsys):
    cfg = tmp_path / "exp.toml"
    cfg.write_text("[controler]\nbandwidth_hz = 5.0\n")
    out = tmp_path / "o"
    _expect_error(["calibrate", "--out", str(out), "--config", str(cfg)], capsys, "controller", out)


def test_bad_motor_units(tmp_path, capsys):
    write_forcemap(tmp_path / "map.csv", np.linspace(-0.2, 0.2, 5), np.ones((5, 1, 3, 3)))
    (tmp_path / "motor.toml").write_text("pole_pitch = 30\nsample_time = 0.001\n[nominal]\nk = 67.0\nzeta = -0.52\n"
                                         "[[coil_set]]\nlever_arm = 0.0\n")
    out = tmp_path / "o"
    _expect_error(["calibrate", "--out", str(out), "--plant", str(tmp_path / "map.csv"), "--motor",
                   str(tmp_path / "motor.toml")], capsys, "pole_pitch", out)


def test_forcemap_missing_phase(tmp_path, capsys):
    write_forcemap(tmp_path / "map.csv", np.linspace(-0.2, 0.2, 5), np.ones((5, 1, 3, 3)))
    text = (tmp_path / "map.csv").read_text().splitlines()
    cols = text[0].split(",")
    drop = cols.index("Fy_1c")
    bad = [",".join(c for j, c in enumerate(line.split(",")) if j != drop) for line in text]
    (tmp_path / "bad.csv").write_text("\n".join(bad) + "\n")
    write_motor(tmp_path / "motor.toml", DEFAULT_TWIN.motor().with_nominal(k=67.0, zeta=-0.52))
    out = tmp_path / "o"
    _expect_error(["calibrate", "--out", str(out), "--plant", str(tmp_path / "bad.csv"), "--motor",
                   str(tmp_path / "motor.toml")], capsys, "Fy_1c", out)


def test_forcemap_too_short_for_stroke(tmp_path, capsys):
    """A map that does not cover the configured reference's stroke is refused before simulating."""
    y = np.linspace(-0.05, 0.05, 11)
    write_forcemap(tmp_path / "map.csv", y, np.ones((11, 3, 3, 3)))
    write_motor(tmp_path / "motor.toml", DEFAULT_TWIN.motor())
    (tmp_path / "cfg.toml").write_text("[reference]\nstroke = 0.1\n")
    out = tmp_path / "o"
    _expect_error(["calibrate", "--out", str(out), "--plant", str(tmp_path / "map.csv"), "--motor",
                   str(tmp_path / "motor.toml"), "--config", str(tmp_path / "cfg.toml")], capsys, "stroke", out)


def test_default_reference_spans_the_map(tmp_path):
    """Without [reference] stroke, the reference covers the map's range less the margin (any centre)."""
    from pgcomm.experiment import data_generation_reference
    from pgcomm.setup import build_setup
    from pgcomm.settings import ExperimentConfig
    from pgcomm.setup import reference_span

    y = np.linspace(0.2, 0.5, 31)  # a map not centred on 0
    write_forcemap(tmp_path / "map.csv", y, np.ones((31, 3, 3, 3)))
    write_motor(tmp_path / "motor.toml", DEFAULT_TWIN.motor())
    setup = build_setup(ExperimentConfig(), tmp_path / "map.csv", tmp_path / "motor.toml")
    lo, hi = reference_span(0.2, 0.5)
    assert setup.config.reference.span == pytest.approx((lo, hi), rel=0, abs=1e-12)
    r = data_generation_reference(setup).r
    assert r.min() == pytest.approx(lo, rel=0, abs=1e-12) and r.max() == pytest.approx(hi, rel=0, abs=1e-12)


def test_plant_without_motor(tmp_path, capsys):
    write_forcemap(tmp_path / "map.csv", np.linspace(-0.2, 0.2, 5), np.ones((5, 1, 3, 3)))
    _expect_error(["simulate", "--out", str(tmp_path / "o"), "--plant", str(tmp_path / "map.csv")], capsys,
                  "--motor")


def test_reference_file_missing_column(tmp_path, capsys):
    (tmp_path / "ref.csv").write_text("t,x\n0,0\n0.001,0\n")
    _expect_error(["simulate", "--out", str(tmp_path / "o"), "--reference", str(tmp_path / "ref.csv")], capsys,
                  "ref.csv")


def test_identify_writes_model_and_costs(tmp_path, capsys):
    """``pgcomm identify`` on the twin: model file, identification keys, PGNN cost below physics (Prop. 1)."""
    cfg = tmp_path / "exp.toml"
    cfg.write_text("[reference]\nvelocities = [0.075, 0.15]\ndwell = 0.2\n"
                   "[identification]\nstarts = 2\nmax_iterations = 10\n")
    out = tmp_path / "id"
    code, stdout, err = run(["identify", "--out", str(out), "--config", str(cfg), "--quiet"], capsys)
    assert code == 0, err
    res = json.loads((out / "results.json").read_text())
    sets = res["identification"]["coil_sets"]
    assert len(sets) == 3 and res["identification"]["seconds_total"] > 0
    for c in sets:
        assert c["cost_pgnn"] < c["cost_physics"] and c["cost_pgnn_validation"] < c["cost_physics_validation"]
    from pgcomm.io.model import load_model

    model, doc = load_model(out / "model.json")
    assert model.n_coil_sets == 3 and doc["metadata"]["fy_abs_max"] > 0
    # the motor's current limit travels with the model (the twin's 10 A) and every export applies it by default
    assert doc["metadata"]["current_limit"] == 10.0 and "drive" not in doc["metadata"]
    code, stdout, err = run(["export", "--model", str(out / "model.json"), "--format", "c", "--out",
                             str(tmp_path / "c"), "--quiet"], capsys)
    assert code == 0, err
    header = " ".join((tmp_path / "c" / "pgcomm_law.h").read_text().split())
    assert "Current limit: 10 A peak phase current (from the model file)" in header
