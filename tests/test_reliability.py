"""No silent wrong table, no destroyed folder, no input that takes the machine down: one class per section.

Each case is refused with exit code 2 and one line ``pgcomm: error: ...`` whose words name the option, file
or key, before anything is written (``--out`` and the working folder untouched), or gives a correct result.
The refusals come before any identification or simulation, so the tables run in-process in seconds; the
generated C is compiled with ``-ffast-math`` (which folds ``isnan``/``isfinite`` away) and fuzzed.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest

import _c_harness as c_harness
from pgcomm.cli import main
from pgcomm.io.model import save_model

from test_cli_export import _model as _lut_model
from test_safe_law import LIMIT, _fuzz_inputs, _pgnn, _phases, _spline


def _run(argv) -> int:
    return main([str(a) for a in argv])


def _refused(capsys, argv, pattern, out=None):
    """Run ``pgcomm argv``: exit 2, one line matching ``pattern``, no traceback, ``out`` (if given) not created."""
    code = _run(argv)
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2, err
    assert lines and lines[0].startswith("pgcomm: error: ") and "Traceback" not in err, err
    assert re.search(pattern, lines[0]), lines[0]
    if out is not None:
        assert not Path(out).exists(), "--out written"
        assert not list(Path(out).parent.glob(f".{Path(out).name}.*")), "staging folder left"
    return lines[0]


# --------------------------------------------------------------------------- --out: never the working folder

#: every command with --out, with the least it needs to reach the --out check
OUT_COMMANDS = {
    "simulate": [], "plan": [], "calibrate": [], "identify": [], "reproduce": ["--quick"],
    "evaluate": ["--data", "log.csv"], "export": ["--format", "c", "--model", "m.json"],
    "zoo": ["--motors", "1"], "fleet": ["--data", "fleet"], "check": ["--data", "log.csv"],
}


@pytest.mark.parametrize("out", ["", ".", "..", "./", "../.."])
@pytest.mark.parametrize("command", sorted(OUT_COMMANDS))
def test_out_is_never_the_working_folder_or_a_parent(tmp_path, monkeypatch, capsys, command, out):
    here = tmp_path / "a" / "b" / "work"
    here.mkdir(parents=True)
    monkeypatch.chdir(here)
    before = [(p, p.stat().st_ino, p.stat().st_mode) for p in (here, *here.parents[:3])]
    _refused(capsys, [command, *OUT_COMMANDS[command], "--out", out, "--quiet"], r"^pgcomm: error: --out '[./]*'")
    assert [(p, p.stat().st_ino, p.stat().st_mode) for p in (here, *here.parents[:3])] == before
    assert list(here.iterdir()) == [] and Path.cwd() == here


def test_a_symbolic_link_to_the_working_folder_is_refused_too(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "link").symlink_to(tmp_path)
    _refused(capsys, ["zoo", "--motors", "1", "--out", "link", "--quiet"], r"--out 'link': is the current folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link"]


def test_overwrite_never_deletes_the_runs_own_inputs(tmp_path, capsys):
    out = tmp_path / "out"
    (out / "model").mkdir(parents=True)
    save_model(out / "model" / "m", _lut_model(L=1), {"current_limit": 5.0})
    _refused(capsys, ["export", "--format", "c", "--model", out / "model" / "m.json", "--out", out, "--overwrite",
                      "--quiet"], r"--out .*out --overwrite would delete '.*m\.json', which this run reads")
    assert (out / "model" / "m.json").is_file()


# --------------------------------------------------------------------------- fleet and seeds

def test_zoo_and_fleet_seeds_are_refused_in_one_line(tmp_path, capsys):
    for argv in (["zoo", "--motors", "1", "--seed", "-1"], ["fleet", "--data", tmp_path, "--seed", "-1"],
                 ["zoo", "--motors", "1", "--seed", str(2**32)], ["fleet", "--data", tmp_path, "--seed", "x"]):
        _refused(capsys, [*argv, "--out", tmp_path / "o"], r"argument --seed: ", tmp_path / "o")


def test_fleet_refuses_no_workers(tmp_path, capsys):
    _refused(capsys, ["fleet", "--data", tmp_path, "--workers", "0", "--out", tmp_path / "o"],
             r"--workers 0: need at least one worker", tmp_path / "o")


def test_fleet_out_is_new_empty_or_a_fleet_workspace(tmp_path, capsys):
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    _refused(capsys, ["fleet", "--data", tmp_path, "--out", other], r"--out .*other: folder exists, is not empty "
             r"\(1 entries: notes\.txt\) and is not the workspace of an earlier fleet run")
    assert sorted(p.name for p in other.iterdir()) == ["notes.txt"]


class _FakeCluster:
    """Stands in for distributed's LocalCluster/Client: records the workers asked for, starts nothing."""

    made: list = []

    def __init__(self, *a, n_workers=None, **k):
        _FakeCluster.made.append(n_workers)

    def close(self):
        pass


class _FakeClient:
    def close(self):
        pass


def test_a_fleet_with_a_failed_motor_exits_2_with_the_count(tmp_path, capsys, monkeypatch):
    """The CLI's side: the fleet table is written by ``run_fleet``, then the failures are one line and exit 2; the
    embedded cluster gets one worker per motor, at most the cores. (The real cluster: tests/test_fleet.py.)"""
    import distributed

    import pgcomm.fleet as fleet
    from pgcomm.cli.fleet import machine_cores
    from pgcomm.fleet.cluster import FleetRun

    for name in ("m1", "m2", "m3"):
        (tmp_path / "data" / name).mkdir(parents=True)
        (tmp_path / "data" / name / "motor.toml").write_text("")

    def run_fleet(client, data, out, **k):
        (Path(out) / "fleet.json").write_text("{}")
        run = FleetRun(motors=["m1", "m2", "m3"], skipped=[], submitted=["m1", "m2", "m3"])
        run.records = {"m1": {"status": "ok"}, "m2": {"status": "failed", "error": "logs/a.csv: column 'y' missing"},
                       "m3": {"status": "failed", "error": "motor.toml: key 'k' missing"}}
        return run

    monkeypatch.setattr(distributed, "LocalCluster", _FakeCluster)
    monkeypatch.setattr(distributed, "Client", lambda *a, **k: _FakeClient())
    monkeypatch.setattr(fleet, "run_fleet", run_fleet)
    _FakeCluster.made.clear()
    line = _refused(capsys, ["fleet", "--data", tmp_path / "data", "--out", tmp_path / "out", "--quiet"],
                    r"^pgcomm: error: fleet: 2 of 3 motor\(s\) failed \(m2: logs/a\.csv: column 'y' missing, \.\.\.\)")
    assert "failed/" in line and (tmp_path / "out" / "fleet.json").is_file()
    assert _FakeCluster.made == [min(3, machine_cores())]
    # more workers than cores: as many as the cores, and said
    _FakeCluster.made.clear()
    assert _run(["fleet", "--data", tmp_path / "data", "--out", tmp_path / "out", "--workers", "1000", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert _FakeCluster.made == [machine_cores()]
    assert err[0] == (f"pgcomm: --workers 1000: this machine has {machine_cores()} core(s); running "
                      f"{machine_cores()} worker process(es) (for more, start a Dask cluster and give --scheduler "
                      "ADDRESS)")


# --------------------------------------------------------------------------- implausible model files

def _linear_model_file(tmp_path, family, **header):
    """A model file of ``family`` (pgnn or spline) with ``header`` fields replaced in its JSON."""
    model = _lut_model(L=1) if family == "pgnn" else _spline(np.random.default_rng(0))
    json_path, _ = save_model(tmp_path / family, model, {"current_limit": LIMIT})
    doc = json.loads(json_path.read_text())
    doc.update(header)
    json_path.write_text(json.dumps(doc))
    return json_path


@pytest.fixture(scope="module")
def log_csv(tmp_path_factory):
    from pgcomm.io.logs import Log, write_log

    n = 400
    t = np.arange(n) * 1e-3
    y = 0.02 * np.sin(2 * np.pi * t)
    path = tmp_path_factory.mktemp("log") / "log.csv"
    write_log(path, Log({"t": t, "y": y, "Fy": np.zeros(n), "Fx": np.zeros(n), "Tz": np.zeros(n),
                         "ia_1": np.ones(n), "ib_1": np.ones(n)}, 1e-3))
    return path


@pytest.mark.parametrize("family", ["pgnn", "spline"])
@pytest.mark.parametrize("pole_pitch", [1e-300, 3.0, -0.03])
@pytest.mark.parametrize("command", ["inspect", "export", "evaluate"])
def test_an_implausible_pole_pitch_is_refused_by_every_command(tmp_path, capsys, log_csv, family, pole_pitch,
                                                               command):
    path = _linear_model_file(tmp_path, family, pole_pitch=pole_pitch)
    out = tmp_path / "out"
    argv = {"inspect": ["inspect", "--model", path],
            "export": ["export", "--format", "c", "--model", path, "--out", out],
            "evaluate": ["evaluate", "--data", log_csv, "--model", path, "--out", out]}[command]
    _refused(capsys, [*argv, "--quiet"], rf"{re.escape(str(path))}: .*pole_pitch", out)


@pytest.mark.parametrize("header, key", [
    ({"metadata": {"current_limit": 1e30}}, "metadata current_limit"),
    ({"metadata": {"current_limit": 5.0, "drive": {"k_hat": [67000.0], "zeta_hat": [0.0]}}}, r"k_hat\[0\]"),
    ({"metadata": {"current_limit": 5.0, "drive": {"k_hat": [67.0], "zeta_hat": [30.0]}}}, r"zeta_hat\[0\]"),
    ({"training_range": {"y_min": [0.1], "y_max": [-0.1]}}, "training_range"),
])
def test_implausible_model_metadata_is_refused(tmp_path, capsys, header, key):
    path = _linear_model_file(tmp_path, "pgnn", **header)
    _refused(capsys, ["export", "--format", "c", "--model", path, "--out", tmp_path / "o", "--quiet"],
             rf"{re.escape(str(path))}: .*{key}", tmp_path / "o")


def _rotary_doc():
    from pgcomm.rotary.model import Fourier, RotaryModel

    m = RotaryModel(7, Fourier(np.array([0, 42, 84]), np.array([[0.01, 0.0], [0.05, 0.02], [0.01, -0.01]])),
                    Fourier(np.array([1, 14, 42]), np.array([[0.01, 0.0], [0.02, 0.01], [0.0, 0.005]])),
                    Fourier(np.array([0, 1, 14]), np.array([[0.2, 0.0], [0.01, 0.0], [0.0, 0.01]])),
                    viscous=1e-3, inertia_ratio=2e-4, k_t=0.1, info={"current_limit": 17.5, "motor": "12N14P"})
    return m.to_dict()


@pytest.mark.parametrize("edit, key", [
    (lambda d: d["cogging"]["cos"].__setitem__(0, 1e6), r"cogging RMS 1e\+06 A exceeds the current limit 17\.5 A"),
    (lambda d: d["direction"]["sin"].__setitem__(2, -300.0), r"direction RMS .* exceeds the current limit"),
    (lambda d: d["ripple"]["cos"].__setitem__(0, 5.0), r"ripple: the torque constant varies by \+5\d\d %"),
    (lambda d: d.__setitem__("pole_pairs", 0), r"pole_pairs = 0 is implausible"),
    (lambda d: d["cogging"]["orders"].__setitem__(1, -42), r"cogging\.orders\[1\] = -42"),
    (lambda d: d["ripple"]["orders"].__setitem__(0, 0), r"ripple\.orders\[0\] = 0: .*no order 0"),
    (lambda d: d["cogging"]["orders"].__setitem__(1, 4.5), r"cogging\.orders\[1\] = 4\.5"),
    (lambda d: d["cogging"]["sin"].pop(), r"cogging: 3 orders, 3 cos and 2 sin"),
    (lambda d: d.__setitem__("k_t", 1e9), r"k_t = 1000000000"),
    (lambda d: d.__setitem__("inertia_ratio", -1.0), r"inertia_ratio = -1\.0"),
    (lambda d: d["info"].__setitem__("current_limit", 1e30), r"info\.current_limit = 1e\+30"),
])
def test_an_absurd_rotary_model_file_is_refused(tmp_path, capsys, edit, key):
    good = tmp_path / "good.json"
    good.write_text(json.dumps(_rotary_doc()))
    assert _run(["export", "--format", "c-rotary", "--model", good, "--out", tmp_path / "ok", "--quiet"]) == 0
    doc = _rotary_doc()
    edit(doc)
    bad = tmp_path / "model.json"
    bad.write_text(json.dumps(doc))
    _refused(capsys, ["export", "--format", "c-rotary", "--model", bad, "--out", tmp_path / "o", "--quiet"],
             rf"{re.escape(str(bad))}: {key}", tmp_path / "o")


# --------------------------------------------------------------------------- tables beyond the limit

def _table(tmp_path, entry5=None, limit=None, name="t.csv"):
    from pgcomm.export.angle_table import make_table, write_angle_table

    n = 64
    th = 2 * np.pi * np.arange(n) / n
    iq = 0.3 * np.sin(14 * th) + 0.1 * np.cos(42 * th)
    if entry5 is not None:
        iq[5] = entry5
    return write_angle_table(tmp_path / name, make_table(iq, current_limit=limit))


TABLE_FORMATS = {"moteus": [], "odrive": ["--torque-constant", "0.1"], "c-angle": []}


@pytest.mark.parametrize("fmt", sorted(TABLE_FORMATS))
def test_table_beyond_the_limit_is_refused_not_clipped(tmp_path, capsys, fmt):
    base = ["export", "--format", fmt, *TABLE_FORMATS[fmt], "--quiet"]
    huge = _table(tmp_path, entry5=1e30, limit=17.5)
    pattern = r"t\.csv: entry 5 \(theta = 2\*pi\*5/64 rad\) is iq = 1e\+30 A, beyond the current limit 17\.5 A"
    _refused(capsys, [*base, "--table", huge, "--out", tmp_path / "o"], pattern, tmp_path / "o")
    _refused(capsys, [*base, "--table", huge, "--current-limit", "none", "--out", tmp_path / "o"],
             r"iq = 1e\+30 A, beyond 10000 A, the largest plausible current", tmp_path / "o")
    # over a given limit, and without any limit recorded (as c-angle always refused)
    plain = _table(tmp_path, name="plain.csv")
    _refused(capsys, [*base, "--table", plain, "--current-limit", "0.2", "--out", tmp_path / "o"],
             r"plain\.csv: entry \d+ .* beyond the current limit 0\.2 A \(--current-limit\)", tmp_path / "o")
    _refused(capsys, [*base, "--table", plain, "--out", tmp_path / "o"],
             r"plain\.csv: the table records no current limit; give --current-limit A", tmp_path / "o")
    # within the limit: exported
    assert _run([*base, "--table", plain, "--current-limit", "0.5", "--out", tmp_path / "ok"]) == 0


# --------------------------------------------------------------------------- coarse lookup tables

def _identified(tmp_path):
    """The synthetic PGNN with the identification record ``pgcomm identify`` writes: Fy residual 0.25 N² over
    20 000 samples, so its standard error of Fy is 0.5 sqrt(p / 60 000) N (p its parameters)."""
    from pgcomm.export.lut import _parameters_per_coil_set

    model = _lut_model(L=1)
    ident = {"coil_sets": [{"cost_y": 0.25, "n_train": 20000}]}
    json_path, _ = save_model(tmp_path / "m", model, {"current_limit": 7.5, "fy_abs_max": 60.0,
                                                       "identification": ident})
    se = 0.5 * np.sqrt(_parameters_per_coil_set(model) / 60000)
    return json_path, se


def test_a_coarse_lookup_table_is_refused_with_the_spacing_that_would_do(tmp_path, capsys):
    path, se = _identified(tmp_path)
    line = _refused(capsys, ["export", "--format", "lut", "--model", path, "--resolution", "0.02", "--out",
                             tmp_path / "o", "--quiet"],
                    r"^pgcomm: error: --resolution 0\.02 m: the table of .*m\.json errs by up to [\d.]+ N in Fy .*"
                    r"more than the model's own standard error of Fy, [\d.]+ N .*use --resolution ([\d.e-]+) or finer",
                    tmp_path / "o")
    assert f"{se:.3g} N" in line
    h = float(re.search(r"use --resolution ([\d.e-]+) or finer", line).group(1))
    # the spacing named holds the bound ...
    assert _run(["export", "--format", "lut", "--model", path, "--resolution", repr(h), "--out", tmp_path / "ok",
                 "--quiet"]) == 0
    r = json.loads((tmp_path / "ok" / "results.json").read_text())
    assert r["error"]["y"]["abs"] <= se and r["error_bound"]["fy_N"] == pytest.approx(se, rel=1e-12)
    # ... and is near the coarsest that does: linear interpolation errs as h², so 1.4 h errs ~2x as much
    _refused(capsys, ["export", "--format", "lut", "--model", path, "--resolution", repr(1.4 * h), "--out",
                      tmp_path / "o2", "--quiet"], r"more than the model's own standard error", tmp_path / "o2")


def test_a_spacing_longer_than_the_range_is_refused_and_a_rounded_one_said(tmp_path, capsys):
    path, _ = _identified(tmp_path)
    _refused(capsys, ["export", "--format", "lut", "--model", path, "--resolution", "0.5", "--out", tmp_path / "o"],
             r"--resolution 0\.5 m: longer than the training range \[-0\.05, 0\.05\] m", tmp_path / "o")


def test_a_model_without_a_standard_error_is_held_to_the_float_rounding(tmp_path, capsys):
    json_path, _ = save_model(tmp_path / "m", _lut_model(L=1), {"current_limit": 7.5})
    _refused(capsys, ["export", "--format", "lut", "--model", json_path, "--resolution", "1e-3", "--out",
                      tmp_path / "o", "--quiet"],
             r"more than the float32 rounding of the table at f_max, .* \(the model file records no identification\)",
             tmp_path / "o")


# --------------------------------------------------------------------------- one conflict rule

#: every export option a format does not read, with a value: refused naming both
EXPORT_VALUES = {"torque_constant": "0.1", "entries": "64", "precision": "single", "resolution": "1e-3",
                 "drive_k": "60", "drive_zeta": "0.1", "f_max": "50", "force_constant": "100", "pole_pairs": "7",
                 "directions": "2", "hysteresis": "1", "period": "1", "harmonics": "5", "scale": "0.01",
                 "fade_out": "100,200"}


def _export_conflicts():
    from pgcomm.cli.export import FORMAT_OPTIONS

    fmts = ("c", "lut", "moteus", "odrive", "c-angle", "c-rotary", "sinamics", "akd", "moog", "beckhoff", "summit",
            "ioni")
    return [(fmt, dest) for dest, used in FORMAT_OPTIONS.items() for fmt in fmts if fmt not in used]


@pytest.mark.parametrize("fmt, dest", _export_conflicts())
def test_an_option_the_format_ignores_is_refused(tmp_path, capsys, fmt, dest):
    opt = "--" + dest.replace("_", "-")
    _refused(capsys, ["export", "--format", fmt, "--model", "m.json", opt, EXPORT_VALUES[dest], "--out",
                      tmp_path / "o"], rf"^pgcomm: error: {opt} conflicts with --format {fmt}: --format {fmt} "
                                       rf"ignores it \({opt} is for --format ", tmp_path / "o")


def test_precision_double_is_refused_with_lut_too(tmp_path, capsys):
    _refused(capsys, ["export", "--format", "lut", "--model", "m.json", "--precision", "double", "--out",
                      tmp_path / "o"], r"--precision conflicts with --format lut", tmp_path / "o")


@pytest.mark.parametrize("command, mode, key", [
    (["reproduce", "--quick"], "--quick", "[identification] starts = 4"),
    (["reproduce", "--quick"], "--quick", "[reference] velocities = [0.1, 0.2]"),
    (["reproduce", "--quick"], "--quick", "[controller] ff_iterations = 5"),
    (["identify", "--family", "spline"], "--family spline", "[identification] starts = 4"),
    (["identify", "--family", "spline"], "--family spline", "[identification] gain_widths = [4]"),
])
def test_a_setting_the_mode_overrides_is_refused(tmp_path, capsys, command, mode, key):
    section, setting = key.split(" ", 1)
    cfg = tmp_path / "exp.toml"
    cfg.write_text(f"{section}\n{setting}\n")
    name = setting.split(" ")[0]
    _refused(capsys, [*command, "--config", cfg, "--out", tmp_path / "o", "--quiet"],
             rf"^pgcomm: error: .*exp\.toml {re.escape(section)} {name} conflicts with {mode}: {mode} ", tmp_path / "o")


def test_settings_the_mode_reads_are_not_conflicts(tmp_path):
    from pgcomm.cli._common import refuse_conflicts, settings_given

    cfg = tmp_path / "exp.toml"
    cfg.write_text("[identification]\ndirection_velocity = 0.002\n[reference]\nstroke = 0.1\n")
    from pgcomm.cli.identify import PGNN_ONLY
    from pgcomm.reproduce import QUICK_OVERRIDES

    assert settings_given(cfg, PGNN_ONLY) == [] and settings_given(cfg, QUICK_OVERRIDES) == []
    refuse_conflicts("--quick", [], "overrides")  # nothing given: nothing refused


# --------------------------------------------------------------------------- generated C under -ffast-math

FAST = ["-ffast-math"]


@pytest.mark.parametrize("kind, precision", [("pgnn", "double"), ("pgnn", "single"), ("spline", "double")])
def test_c_law_under_fast_math_stays_finite_and_limited(cc, tmp_path, rng, kind, precision):
    from pgcomm.export.c import CLawOptions, write_c

    model = _pgnn() if kind == "pgnn" else _spline(rng)
    L = model.n_coil_sets
    write_c(model, tmp_path, CLawOptions("law", precision, LIMIT))
    assert "isfinite" not in (tmp_path / "law.c").read_text() + (tmp_path / "law.h").read_text()
    exe = c_harness.compile_law(cc, tmp_path, "law", flags=FAST)
    y, f, v = _fuzz_inputs(rng, 3000)
    y[:40], f[40:80, 0], f[80:120, 2] = 1e300, 1e300, -1e300  # huge finite inputs
    y[120:160], f[160:200, 1] = np.nan, -np.inf
    out = c_harness.run_law(exe, L, y, f, 60.0 * np.ones((y.size, L)), np.zeros((y.size, L)), v=v)
    i_c = out["currents"]
    assert np.all(np.isfinite(i_c)) and np.max(np.abs(_phases(i_c))) <= LIMIT * (1 + 1e-6)
    assert np.all(out["ret"][120:200, 0] == 2) and np.all(i_c[120:200] == 0.0)


def test_lut_under_fast_math_stays_finite_and_limited(cc, tmp_path, rng):
    from pgcomm.export.lut import build_lut, lut_header

    model = _pgnn()
    lut = build_lut(model, 2e-3, current_limit=LIMIT)
    (tmp_path / "tab.h").write_text(lut_header(lut, "tab"))
    exe = c_harness.compile_lut(cc, tmp_path, "tab", flags=FAST)
    y, f, _ = _fuzz_inputs(rng, 3000)
    y[:40], f[40:80, 0] = 3e38, 1e300
    y[80:120] = np.nan
    ret, i_c = c_harness.run_lut(exe, model.n_coil_sets, y, f)
    assert np.all(np.isfinite(i_c)) and np.max(np.abs(_phases(i_c))) <= LIMIT * (1 + 1e-6)
    assert np.all(ret[80:120] == 2) and np.all(i_c[80:120] == 0.0)


ANGLE_HARNESS = r"""
#include <stdio.h>
#include <stdlib.h>
#include "lut.h"
int main(void)
{
    char a[64], b[64], c[64];
    while (scanf("%63s %63s %63s", a, b, c) == 3) {
        T q;
        int r = CALL;
        printf("%d %.17g\n", r, (double)q);
    }
    return 0;
}
"""


@pytest.mark.parametrize("what", ["c-angle", "c-rotary"])
@pytest.mark.parametrize("precision", ["double", "single"])
def test_angle_lookups_under_fast_math_stay_finite_and_limited(cc, tmp_path, what, precision):
    from pgcomm.export.angle_lut import angle_lut_header, build_angle_lut
    from pgcomm.export.angle_table import make_table
    from pgcomm.export.rotary_law import build_rotary_law, rotary_law_header
    from pgcomm.io.rotary_model import rotary_model_from_dict

    limit = 0.5
    if what == "c-angle":
        th = 2 * np.pi * np.arange(256) / 256
        lut = build_angle_lut(make_table(0.3 * np.sin(14 * th)), 512, precision, current_limit=limit)
        text, call = angle_lut_header(lut, "lut", "test"), "lut_iq((T)strtod(a, NULL), (T)strtod(b, NULL), &q)"
    else:
        model = rotary_model_from_dict(_rotary_doc(), "model.json")
        tabs = build_rotary_law(model, 256, precision, limit, "model.json")
        text = rotary_law_header(tabs, "lut", "test")
        call = "lut_iq((T)strtod(a, NULL), (T)strtod(b, NULL), (T)strtod(c, NULL), &q)"
    assert "isfinite" not in text
    (tmp_path / "lut.h").write_text(text)
    T = "double" if precision == "double" else "float"
    (tmp_path / "main.c").write_text(ANGLE_HARNESS.replace("CALL", call).replace("T q", f"{T} q")
                                     .replace("(T)", f"({T})"))
    exe = tmp_path / "main"
    proc = subprocess.run([cc, *c_harness.CFLAGS, *FAST, "-o", str(exe), str(tmp_path / "main.c"), "-lm"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    rng = np.random.default_rng(3)
    n = 600
    a, b, s = rng.uniform(-20, 20, n), rng.uniform(-3, 3, n), rng.choice([-1.0, 0.0, 1.0], n)
    a[:50], a[50:100], a[100:120] = np.nan, np.inf, 1e300
    b[120:170], b[170:190], s[190:220] = np.nan, 1e300, np.nan
    text_in = "\n".join(f"{float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in zip(a, b, s))
    res = subprocess.run([str(exe)], input=text_in, capture_output=True, text=True, check=True).stdout
    out = np.array([[float(v) for v in line.split()] for line in res.splitlines()])
    assert out.shape == (n, 2)
    assert np.all(np.isfinite(out[:, 1])) and np.max(np.abs(out[:, 1])) <= limit * (1 + 1e-6)
    nonfinite = np.r_[0:100, 120:170] if what == "c-angle" else np.r_[0:100, 120:170, 190:220]
    assert np.all(out[nonfinite, 0] == 2) and np.all(out[nonfinite, 1] == 0.0)
