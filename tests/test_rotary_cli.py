"""``pgcomm identify`` on a rotary motor's drive logs, against the rotary twin's truth.

The logs are the rotary zoo's running logs (``pgcomm zoo --kind rotary --logs``: what a drive records,
``t, theta, velocity, iq_1, id_1``). Zoo motor 1 (9N6P) has the lowest cogging orders, so its logs are
short (5 s). Tolerances: the cogging within the target of 5 % of the truth's RMS; the real drive's
log shape (its own column names, the angle in revolutions and wrapped, velocity in rpm, vq and vbus
beside) gives the same model as the canonical columns to within what the unit conversions round
(the CSV's 12 significant digits, relative 1e-9 of the table's scale).
"""

from __future__ import annotations

import json
import math
import re
import shlex

import numpy as np
import pytest

from pgcomm.cli import main
from pgcomm.export.angle_table import read_angle_table
from pgcomm.rotary.model import RotaryModel
from pgcomm.io.rotary_zoo import read_truth

from _drive_pll import pll_and_late, rewrite_logs


@pytest.fixture(scope="module")
def zoo(tmp_path_factory):
    root = tmp_path_factory.mktemp("rzoo")
    assert main(["zoo", "--kind", "rotary", "--motors", "1", "--logs", "--out", str(root / "z"), "--quiet"]) == 0
    return root / "z" / "motor_01"


def _identify(tmp, motor, data, extra=()):
    out = tmp / "id"
    assert main(["identify", "--motor", str(motor), "--data", *map(str, data), "--out", str(out), "--quiet",
                 *extra]) == 0
    return out


def test_identify_rotary_logs_recovers_the_cogging(tmp_path, zoo):
    out = _identify(tmp_path, zoo / "motor.toml", sorted((zoo / "logs").glob("*.csv")))
    truth = read_truth(zoo / "truth.json")
    model = RotaryModel.from_dict(json.loads((out / "model.json").read_text()))
    th = 2 * math.pi * np.arange(4096) / 4096
    tm = truth.model()
    err = np.sqrt(np.mean((model.cogging(th) - tm.cogging(th)) ** 2)) / np.sqrt(np.mean(tm.cogging(th) ** 2))
    assert err <= 0.05
    res = json.loads((out / "results.json").read_text())
    assert res["kind"] == "rotary" and res["torque_sensor"] is False
    se = res["identification"]["standard_error"]
    assert se["cogging"]["resolved"] and 0 < se["cogging"]["relative"] <= 0.05
    # the compensation table is the model's, carries the motor's limit, and exports without --current-limit
    table = read_angle_table(out / "compensation.csv")
    np.testing.assert_allclose(table.iq, model.table(table.n), rtol=0, atol=1e-12 * np.max(np.abs(table.iq)))
    assert table.current_limit == pytest.approx(truth.motor.current_limit)
    assert main(["export", "--format", "c-angle", "--table", str(out / "compensation.csv"), "--out",
                 str(tmp_path / "c"), "--quiet"]) == 0
    assert (out / "identify_rotary.png").stat().st_size > 10_000
    # the report shows the run's own numbers (a rig's logs: no truth column) and embeds the figure
    page = (out / "report.html").read_text()
    assert f"{res['table']['entries']} entries" in page and "data:image/png;base64," in page
    text = re.sub(r"data:image/[a-z]+;base64,[A-Za-z0-9+/=]+", "", page)  # base64 spells any word now and then
    assert f"{100 * se['cogging']['relative']:.1f} %" in page and "truth" not in text
    # the encoder's step is read from the logged angle (a CSV round trip keeps its lattice) and reported
    quant = res["identification"]["quantisation"]
    assert quant["counts_per_revolution"] == [truth.encoder_counts] and quant["logs_on_lattice"] == quant["logs"]
    assert f"lattice of {truth.encoder_counts} counts per revolution" in page
    # the Python API is the command: the same logs read and identified in this process give the same results.json
    from pgcomm import identify_rotary_logs, load_rotary_motor, read_logs
    from pgcomm.io.logs import ROTARY_REQUIRED

    logs = read_logs(sorted(map(str, (zoo / "logs").glob("*.csv"))), required=ROTARY_REQUIRED, gaps=True, stamps=True)
    found = identify_rotary_logs(logs, load_rotary_motor(zoo / "motor.toml"))
    api = found.to_dict()

    def same(a, b, where="results"):
        # the same keys throughout; numbers within rounding of their own size (timings apart)
        if isinstance(a, dict):
            assert list(a) == list(b), where
            for k in a:
                if k not in ("runtime_s", "seconds"):
                    same(a[k], b[k], f"{where}.{k}")
        elif isinstance(a, list):
            assert len(a) == len(b), where
            for i, (x, y) in enumerate(zip(a, b)):
                same(x, y, f"{where}[{i}]")
        elif isinstance(a, float) and isinstance(b, float):
            assert (a != a and b != b) or math.isclose(a, b, rel_tol=1e-9), where
        else:
            assert a == b, where

    same(json.loads(json.dumps(api)), res)
    np.testing.assert_allclose(found.table, table.iq, rtol=0, atol=1e-12 * np.max(np.abs(table.iq)))


def test_real_drive_log_shape_gives_the_same_model(tmp_path, zoo):
    """The drive's own names and units: time, position in revolutions wrapped to [0, 1), speed in rpm, Iq, plus
    vq and vbus that identification does not need; against the same columns in pgcomm's names and units (no
    d-current in either: where the logs have one, the current's noise is read from it)."""
    from pgcomm.io.logs import read_log

    logs = sorted((zoo / "logs").glob("*.csv"))
    mapped, native = [], []
    for k, path in enumerate(logs):
        lg = read_log(path, required=("theta",))
        c = lg.columns
        p = tmp_path / f"native{k}.csv"
        with open(p, "w") as f:
            f.write("t,theta,velocity,iq_1,vq_1\n")
            np.savetxt(f, np.column_stack([c["t"], c["theta"], c["velocity"], c["iq_1"], 0.1 * c["iq_1"]]),
                       delimiter=",", fmt="%.15g")
        native.append(p)
        rev = np.mod(c["theta"] / (2 * math.pi), 1.0)
        rows = np.column_stack([c["t"], rev, c["velocity"] * 60 / (2 * math.pi), c["iq_1"],
                                0.1 * c["iq_1"], np.full(rev.size, 24.0)])
        p = tmp_path / f"drive{k}.csv"
        with open(p, "w") as f:
            f.write("time_s,pos_rev,speed_rpm,Iq,Vq,Vbus\n")
            np.savetxt(f, rows, delimiter=",", fmt="%.15g")
        mapped.append(p)
    (tmp_path / "map.toml").write_text(
        '[columns]\nt = "time_s"\ntheta = "pos_rev"\nvelocity = "speed_rpm"\niq_1 = "Iq"\nvq_1 = "Vq"\n'
        'vbus = "Vbus"\n[units]\ntheta = "rev"\nvelocity = "rpm"\n')
    a = _identify(tmp_path / "a", zoo / "motor.toml", native)
    b = _identify(tmp_path / "b", zoo / "motor.toml", mapped, ["--columns", str(tmp_path / "map.toml")])
    ta, tb = read_angle_table(a / "compensation.csv").iq, read_angle_table(b / "compensation.csv").iq
    np.testing.assert_allclose(tb, ta, rtol=0, atol=1e-6 * np.max(np.abs(ta)))


def test_logs_with_dropped_samples_are_used_between_the_gaps(tmp_path, zoo, capsys):
    """Each zoo log with 5 rows dropped in its middle: identify says so and uses the stretches between the gaps
    (no filter window across one), and the compensation table moves from the intact logs' by less than its own
    standard error (RMS over the table; the gapped logs are 0.4 % shorter)."""

    logs = sorted((zoo / "logs").glob("*.csv"))

    def rows(c):
        keep = np.ones(c["t"].size, bool)
        keep[c["t"].size // 2:c["t"].size // 2 + 5] = False
        return np.column_stack([c["t"], c["theta"], c["iq_1"]])[keep]

    gapped = rewrite_logs(logs, tmp_path, "gapped", rows)
    a = _identify(tmp_path / "a", zoo / "motor.toml", logs)
    capsys.readouterr()
    out = tmp_path / "b"
    assert main(["identify", "--motor", str(zoo / "motor.toml"), "--data", *map(str, gapped), "--out", str(out)]) == 0
    assert "5 dropped sample(s) in 1 gap(s)" in capsys.readouterr().err
    ta, tb = read_angle_table(a / "compensation.csv").iq, read_angle_table(out / "compensation.csv").iq
    se = json.loads((a / "results.json").read_text())["identification"]["standard_error"]["cogging"]["rms_error"]
    assert np.sqrt(np.mean((tb - ta) ** 2)) <= se


def test_a_current_logged_a_sample_late_is_found_and_shifted(tmp_path, zoo, capsys):
    """Each zoo log with its q-current written one sample late (a logger that writes the column a cycle later than
    the angle): identify says so, reports the delay, and the compensation table is the intact logs' within a
    fifth of its standard error (only the first and last sample of each log differ). As logged, the same delay
    is reported as none. The zoo's drive controls faster than it logs, so both are read as the smooth curve through
    the snapshots, with the same lag."""

    logs = sorted((zoo / "logs").glob("*.csv"))
    late = rewrite_logs(logs, tmp_path, "late",
                        lambda c: np.column_stack([c["t"], c["theta"], np.concatenate([[c["iq_1"][0]], c["iq_1"][:-1]])]))
    capsys.readouterr()
    a = tmp_path / "a"
    assert main(["identify", "--motor", str(zoo / "motor.toml"), "--data", *map(str, logs), "--out", str(a)]) == 0
    assert "the logged q-current is a snapshot of a current that moves between" in capsys.readouterr().err
    plain = json.loads((a / "results.json").read_text())["identification"]["current_delay"]
    assert plain["samples"] == 0 and not plain["held"]
    out = tmp_path / "b"
    assert main(["identify", "--motor", str(zoo / "motor.toml"), "--data", *map(str, late), "--out", str(out)]) == 0
    assert "written 1 sample(s) late against the angle: used shifted by 1" in capsys.readouterr().err
    res = json.loads((out / "results.json").read_text())["identification"]
    assert res["current_delay"]["samples"] == 1 and res["current_delay"]["detected"]
    k = read_truth(zoo / "truth.json").control_per_log
    for timing in (plain, res["current_delay"]):
        assert timing["lag"] == pytest.approx(1 / (2 * k), abs=1 / 64)  # the held cycles' lag, within the grid's step
    assert "1 sample(s) late" in (out / "report.html").read_text()
    ta, tb = read_angle_table(a / "compensation.csv").iq, read_angle_table(out / "compensation.csv").iq
    se = json.loads((a / "results.json").read_text())["identification"]["standard_error"]["cogging"]["rms_error"]
    assert np.sqrt(np.mean((tb - ta) ** 2)) <= 0.2 * se


def test_a_drive_pll_angle_and_a_late_current_through_the_column_mapping(tmp_path, zoo, capsys):
    """The shape of an open drive's log: the angle its PLL estimates (ODrive's, 1000 rad/s at 16 kHz) and the
    q-current a sample late, under the drive's own column names: identify says how it read both, reports them,
    writes the report, and its table is within 5 % of the truth's RMS."""

    made = rewrite_logs(sorted((zoo / "logs").glob("*.csv")), tmp_path, "drive",
                        lambda c: np.column_stack(pll_and_late(c)), header="time_s,pos_rad,Iq", fmt="%.9g")
    (tmp_path / "map.toml").write_text('[columns]\nt = "time_s"\ntheta = "pos_rad"\niq_1 = "Iq"\n')
    capsys.readouterr()
    out = tmp_path / "id"
    assert main(["identify", "--motor", str(zoo / "motor.toml"), "--data", *map(str, made), "--columns",
                 str(tmp_path / "map.toml"), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "read as a drive's PLL estimate of natural frequency" in err
    assert "1 sample(s) late against the angle" in err and "smooth curve through the samples" in err
    ident = json.loads((out / "results.json").read_text())["identification"]
    assert ident["angle_pll"]["natural_frequency_rad_s"] == pytest.approx(1000.0, rel=0.3)
    assert ident["current_delay"]["samples"] == 1
    assert "PLL estimate" in (out / "report.html").read_text()
    truth = read_truth(zoo / "truth.json").model()
    table = read_angle_table(out / "compensation.csv")
    ref = truth.table(table.n)
    assert np.sqrt(np.mean((table.iq - ref) ** 2)) <= 0.05 * np.sqrt(np.mean(ref**2))
    # the same readings given on the command line: nothing searched, the same table
    given = tmp_path / "given"
    w, z = ident["angle_pll"]["natural_frequency_rad_s"], ident["angle_pll"]["damping"]
    timing = ident["current_delay"]
    lag = "held" if timing["held"] else repr(timing["lag"])
    tau = ident["current_filter"]["tau_s"]
    assert main(["identify", "--motor", str(zoo / "motor.toml"), "--data", *map(str, made), "--columns",
                 str(tmp_path / "map.toml"), "--out", str(given), "--quiet", "--current-delay", "1",
                 "--current-lag", lag, "--angle-pll", f"{w!r},{z!r}",
                 "--current-filter", repr(tau) if tau > 0 else "none"]) == 0
    again = json.loads((given / "results.json").read_text())["identification"]
    assert again["angle_pll"]["searched"] is False and again["current_delay"]["detected"] is False
    assert again["current_filter"]["cost_by_tau"] is None
    np.testing.assert_allclose(read_angle_table(given / "compensation.csv").iq, table.iq, rtol=0,
                               atol=1e-9 * np.max(np.abs(table.iq)))


def test_a_mains_pickup_in_the_logged_current_is_found_said_and_fitted(tmp_path, zoo, capsys):
    """Each zoo log with a 50 Hz line of 1 % of the current limit added to its q-current (a phase of its own per
    log): identify says it found a time-periodic disturbance at 50 Hz, reports it (results and report), and its table
    is the intact logs' within twice their standard error; with ``--time-lines none`` it is not, by more than five."""
    from pgcomm.io.config import load_rotary_motor

    logs = sorted((zoo / "logs").glob("*.csv"))
    amp = 0.01 * load_rotary_motor(zoo / "motor.toml").current_limit
    rng = np.random.default_rng(5)
    hum = rewrite_logs(logs, tmp_path, "hum", lambda c: np.column_stack(
        [c["t"], c["theta"], c["iq_1"] + amp * np.sin(2 * np.pi * 50.0 * c["t"] + rng.uniform(0, 2 * np.pi))]))
    a = _identify(tmp_path / "a", zoo / "motor.toml", logs)
    capsys.readouterr()
    out = tmp_path / "b"
    assert main(["identify", "--motor", str(zoo / "motor.toml"), "--data", *map(str, hum), "--out", str(out)]) == 0
    assert re.search(r"a time-periodic disturbance, 0\.\d+ A of q-current at 50\.0\d Hz", capsys.readouterr().err)
    lines = json.loads((out / "results.json").read_text())["identification"]["time_lines"]
    assert len(lines["hz"]) == 1 and lines["hz"][0] == pytest.approx(50.0, abs=0.05)
    assert lines["amplitude_A"][0] == pytest.approx(amp, rel=0.1)
    assert "A of q-current at 50.0" in (out / "report.html").read_text()
    se = json.loads((a / "results.json").read_text())["identification"]["standard_error"]["cogging"]["rms_error"]
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    ta = read_angle_table(a / "compensation.csv").iq
    assert rms(read_angle_table(out / "compensation.csv").iq - ta) <= 2 * se
    blind = tmp_path / "c"
    assert main(["identify", "--motor", str(zoo / "motor.toml"), "--data", *map(str, hum), "--out", str(blind),
                 "--quiet", "--time-lines", "none"]) == 0
    assert rms(read_angle_table(blind / "compensation.csv").iq - ta) > 5 * se


def test_a_current_counted_against_the_angle_gives_the_negated_table(tmp_path, zoo, capsys):
    """A drive whose positive q-current turns the rotor against its angle's direction (each zoo log with iq_1
    negated): identify says J/k0 is negative and returns the table the drive needs, the negated table of the logs
    as written, within a ten-thousandth of its peak (the same fit with every current's sign turned)."""

    logs = sorted((zoo / "logs").glob("*.csv"))
    neg = rewrite_logs(logs, tmp_path, "neg", lambda c: np.column_stack([c["t"], c["theta"], -c["iq_1"]]))
    a = _identify(tmp_path / "a", zoo / "motor.toml", logs)
    capsys.readouterr()
    out = tmp_path / "b"
    assert main(["identify", "--motor", str(zoo / "motor.toml"), "--data", *map(str, neg), "--out", str(out)]) == 0
    assert "is negative: a positive q-current turns the rotor against" in capsys.readouterr().err
    ta, tb = read_angle_table(a / "compensation.csv").iq, read_angle_table(out / "compensation.csv").iq
    np.testing.assert_allclose(tb, -ta, rtol=0, atol=1e-4 * np.max(np.abs(ta)))


@pytest.mark.parametrize("case, match", [
    ("no data", "--data: a rotary motor"),
    ("linear log", "column 'theta' missing; found t, y"),
    ("no iq", "no column 'iq_1'|no q-axis current|coil set"),
    ("nan", "nan.csv row 50 column 'theta': nan is not a finite number"),
    ("family", "--family spline"),
    ("sweep one way", "sweep.csv: the angle moves one way only"),
    ("glitch", r"glitch\.csv row 1001: 'theta' jumps by 0\.3.* encoder glitch"),
    ("sweep in degrees", r"deg\.csv: the angle travels 5[78] revolutions forward .* declare it in the --columns map"),
    ("delay", "--current-delay 0.5: an integer number of samples"),
    ("lag", "--current-lag 2: \"held\", or a lag in samples between -0.5 and 0.5"),
    ("pll", "--angle-pll 1000,-1: a natural frequency in rad/s and optionally a damping, both positive"),
    ("lines", "--time-lines 50,x: frequencies in Hz, positive"),
    ("noise", "--current-noise -0.1: the logged current's noise in A"),
    ("filter", "--current-filter -1: the report filter's time constant in s"),
    ("no current", r"zero\.csv: column 'iq_1' is 0 A in every row: the current carries no excitation"),
])
def test_bad_input_one_line_no_output(tmp_path, zoo, capsys, case, match):
    log = sorted((zoo / "logs").glob("*.csv"))[0]
    text = log.read_text().splitlines()
    args = ["identify", "--motor", str(zoo / "motor.toml"), "--out", str(tmp_path / "out"), "--quiet"]
    if case == "linear log":
        p = tmp_path / "lin.csv"
        p.write_text("\n".join([text[0].replace("theta", "y")] + text[1:]) + "\n")
        args += ["--data", str(p)]
    elif case == "no iq":
        p = tmp_path / "noiq.csv"
        p.write_text("\n".join(",".join(r.split(",")[:3]) for r in text) + "\n")
        args += ["--data", str(p)]
    elif case == "nan":
        p = tmp_path / "nan.csv"
        cells = text[50].split(",")
        cells[1] = "nan"
        p.write_text("\n".join(text[:50] + [",".join(cells)] + text[51:]) + "\n")
        args += ["--data", str(p)]
    elif case == "family":
        args += ["--data", str(log), "--family", "spline"]
    elif case == "sweep one way":
        sweep = (zoo / "sweep" / "sweep.csv").read_text().splitlines()
        p = tmp_path / "sweep.csv"
        p.write_text("\n".join(sweep[: len(sweep) // 2]) + "\n")  # the forward pass only
        args += ["--data", str(log), "--sweep", str(p)]
    elif case == "glitch":  # the encoder slips by 0.3 rad at row 1001 and stays there
        head = text[0].split(",")
        j = head.index("theta")
        p = tmp_path / "glitch.csv"
        p.write_text("\n".join([text[0]] + [",".join(f"{float(c) + (0.3 if k >= 1000 else 0.0):.12g}" if i == j else c
                                                      for i, c in enumerate(r.split(",")))
                                             for k, r in enumerate(text[1:])]) + "\n")
        args += ["--data", str(p)]
    elif case == "sweep in degrees":
        sweep = (zoo / "sweep" / "sweep.csv").read_text().splitlines()
        head = sweep[0].split(",")
        j = head.index("theta")
        p = tmp_path / "deg.csv"
        p.write_text("\n".join([sweep[0]] + [",".join(f"{float(c) * 180 / np.pi:.9g}" if i == j else c
                                                      for i, c in enumerate(r.split(","))) for r in sweep[1:]]) + "\n")
        args += ["--data", str(log), "--sweep", str(p)]
    elif case == "delay":
        args += ["--data", str(log), "--current-delay", "0.5"]
    elif case == "lag":
        args += ["--data", str(log), "--current-lag", "2"]
    elif case == "pll":
        args += ["--data", str(log), "--angle-pll", "1000,-1"]
    elif case == "lines":
        args += ["--data", str(log), "--time-lines", "50,x"]
    elif case == "noise":
        args += ["--data", str(log), "--current-noise", "-0.1"]
    elif case == "filter":
        args += ["--data", str(log), "--current-filter", "-1"]
    elif case == "no current":  # a drive that logged a disabled channel: the fit's matrices were not positive definite
        head = text[0].split(",")
        j = head.index("iq_1")
        p = tmp_path / "zero.csv"
        p.write_text("\n".join([text[0]] + [",".join(c if i != j else "0" for i, c in enumerate(r.split(",")))
                                             for r in text[1:]]) + "\n")
        args += ["--data", str(p)]
    capsys.readouterr()
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("pgcomm: error:"), err
    assert __import__("re").search(match, err), err
    assert "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_sweep_log_gives_the_drives_table_and_agrees_with_the_model(tmp_path, zoo):
    """``--sweep``: the drives' table from the zoo's logged slow sweep (a revolution each way) is within 3x
    its own noise estimate of the truth, the running-log model's table agrees with it within the two noises
    (the same factor as the twin's comparison), and the table exports like the model's. A drive's static map given
    beside it (the truth's table with white noise of a tenth of its RMS, the index half a revolution away): its
    error is read back within what its sampling and the model's own error allow, and the combined table is the
    model's and the map's, index removed, each weighed by its error."""
    from pgcomm.rotary.experiment import AGREEMENT_FACTOR

    n = 512
    ref = read_truth(zoo / "truth.json").model().table(n)
    sigma_s = 0.1 * float(np.sqrt(np.mean(ref**2)))
    noise = np.random.default_rng(4).standard_normal(n)
    noise = sigma_s * (noise - noise.mean()) / noise.std()
    np.savetxt(tmp_path / "map.csv", np.column_stack([2 * np.pi * np.arange(n) / n, np.roll(ref + noise, -n // 2)]),
               delimiter=",", header="angle,iq", comments="", fmt="%.17g")
    out = _identify(tmp_path, zoo / "motor.toml", sorted((zoo / "logs").glob("*.csv")),
                    ["--sweep", str(zoo / "sweep" / "sweep.csv"), "--sweep", str(tmp_path / "map.csv")])
    res = json.loads((out / "results.json").read_text())
    (found,) = res["static_maps"]
    both = found["combined"]
    assert found["index_offset"]["shift"] == n // 2 and both["file"] == "combined_map.csv"
    ours = RotaryModel.from_dict(json.loads((out / "model.json").read_text())).table(n)
    e_m = float(np.sqrt(np.mean((ours - ref) ** 2)))
    se = both["model_rms_error_A"]
    tol = 4 * (sigma_s**2 * math.sqrt(2 / n) + 2 * sigma_s * e_m / math.sqrt(n)) + abs(e_m**2 - se**2)
    assert abs(both["static_rms_error_A"] ** 2 - sigma_s**2) <= tol
    w = both["weight_static"]
    assert w == pytest.approx(se**2 / (se**2 + both["static_rms_error_A"] ** 2), rel=1e-12)
    centred = lambda x: x - x.mean()  # noqa: E731
    combined = read_angle_table(out / "combined_map.csv")
    np.testing.assert_allclose(combined.iq, ours + w * (centred(ref + noise) - centred(ours)), rtol=0,
                               atol=1e-9 * np.max(np.abs(ref)))
    sw = res["standstill_sweep"]
    assert sw["coverage"] == 1.0 and sw["table_written"] and sw["within_noise"]
    assert sw["rms_model_minus_sweep_A"] <= AGREEMENT_FACTOR * sw["expected_rms_difference_A"]
    table = read_angle_table(out / "standstill_table.csv")
    assert table.n == sw["points"] and table.current_limit == pytest.approx(read_truth(zoo / "truth.json").motor
                                                                            .current_limit)
    tm = read_truth(zoo / "truth.json").model()
    truth = tm.table(table.n)  # entry j at 2πj/n, both directions averaged: the drives' convention
    err = float(np.sqrt(np.mean((table.iq - truth) ** 2)))
    assert err <= 3 * sw["noise_A"], (err, sw["noise_A"])
    assert "Against the drives' standstill sweep" in (out / "report.html").read_text()
    assert main(["export", "--format", "moteus", "--table", str(out / "standstill_table.csv"), "--out",
                 str(tmp_path / "m"), "--quiet"]) == 0


def test_sweep_table_noise_estimate_predicts_its_error():
    """:func:`table_from_sweep` on twin sweeps of two speeds: the RMS error against the truth is within a
    factor 2 of the table's own noise estimate (its white-noise part), and a faster sweep is noisier."""
    from pgcomm.rotary.standstill import sweep_reference, table_from_sweep
    from pgcomm.rotary.twin import LawParams, default_gains, simulate
    from pgcomm.rotary.zoo import draw_rotary

    t = draw_rotary(0, 3)
    tm = t.model()
    noise = []
    for secs in (20.0, 60.0):
        log = simulate(t, sweep_reference(t.motor.sample_time, secs), LawParams.classical(t.motor.pole_pairs),
                       default_gains(t.inertia / t.k0), seed=5)
        sw = table_from_sweep(log["theta"], log["iq_1"], t.motor.sample_time)
        assert sw.coverage == 1.0
        err = float(np.sqrt(np.mean((sw.table - tm.table(sw.theta.size)) ** 2)))
        assert 0.5 <= err / sw.noise <= 2.0, (secs, err, sw.noise)
        noise.append(sw.noise / np.sqrt(np.mean(tm.table(sw.theta.size) ** 2)))
    assert noise[0] > noise[1]


def test_sweep_table_of_a_staircase_of_holds_matches_the_hold_averages():
    """A sweep logged as a staircase of holds (the drives' other way): binned by angle at the staircase's own
    resolution it covers the whole revolution and is within the hold-average table's own error of the truth
    (twice its RMS error at most: the bins also take the settling samples the hold averages leave out)."""
    from pgcomm.rotary.standstill import run_standstill, staircase, table_from_sweep
    from pgcomm.settings import StandstillPlan
    from pgcomm.rotary.twin import LawParams, default_gains, simulate
    from pgcomm.rotary.zoo import draw_rotary

    t = draw_rotary(0, 0)
    plan = StandstillPlan(points=360, settle=30, average=20)
    gains = default_gains(t.inertia / t.k0)
    ref, _ = staircase(plan, t.motor.sample_time)
    log = simulate(t, ref, LawParams.classical(t.motor.pole_pairs), gains, seed=2, n_sub=5)
    holds = run_standstill(t, gains, plan, seed=2)
    sw = table_from_sweep(log["theta"], log["iq_1"], t.motor.sample_time, points=plan.points)
    truth = t.model().table(plan.points)
    rms = lambda x: float(np.sqrt(np.mean(x**2)))  # noqa: E731
    assert sw.coverage == 1.0
    assert rms(sw.table - truth) <= 2 * rms(holds.table - truth)


def test_without_a_datasheet_k_t_the_back_emf_gives_the_table_in_newton_metres(tmp_path, zoo, capsys):
    """The zoo's motor TOML without its k_t: identify reads the logged q-voltage (zoo logs have vq_1), prints the
    back-EMF's torque constant and gives the table in N·m with it, within four of its standard errors of the table
    in N·m at the twin's true k0 (k_t cos δ); the same logs without vq_1 give no N·m."""
    text = (zoo / "motor.toml").read_text()
    assert "k_t" in text
    (tmp_path / "motor.toml").write_text("\n".join(l for l in text.splitlines() if not l.startswith("k_t")) + "\n")
    logs = sorted((zoo / "logs").glob("*.csv"))
    out = _identify(tmp_path / "a", tmp_path / "motor.toml", logs)
    res = json.loads((out / "results.json").read_text())
    v, table = res["identification"]["back_emf"], res["table"]
    assert v["consistent"] and "back-EMF" in table["torque_constant_from"]
    k0 = read_truth(zoo / "truth.json").k0
    se_nm = table["rms_A"] * 1.5 * v["back_emf_constant_se"]
    assert abs(table["rms_Nm"] - table["rms_A"] * k0) < 4 * se_nm
    # the mechanics in SI with it: J = (J/k0) k0, the moment of inertia a loop is tuned with, from drive logs alone;
    # within 2 %: J/k0's error from these logs (docs/validation.md) and k0's (4 standard errors)
    si, truth = res["in_SI"], read_truth(zoo / "truth.json")
    model = RotaryModel.from_dict(json.loads((out / "model.json").read_text()))
    assert abs(si["inertia_kg_m2"] - model.inertia_ratio * si["torque_constant_Nm_per_A"]) < 1e-12 * truth.inertia
    assert abs(si["inertia_kg_m2"] / truth.inertia - 1.0) < 0.02
    assert abs(si["cogging_rms_Nm"] / truth.cogging.rms() - 1.0) < 0.05
    assert f"{si['inertia_kg_m2']:.4g} kg·m²" in (out / "report.html").read_text(encoding="utf-8")
    # with the datasheet's k_t as well, the back-EMF's is taken and their ratio is the drive frame's cos δ
    res_k = json.loads((_identify(tmp_path / "k", zoo / "motor.toml", logs) / "results.json").read_text())
    ratio = res_k["identification"]["back_emf"]["ratio_to_motor_k_t"]
    k_t = float(re.search(r"^k_t = ([0-9.]+)", text, re.M).group(1))
    assert abs(ratio - truth.k_t * math.cos(truth.offset_error) / k_t) < 4 * 1.5 * v["back_emf_constant_se"] / k_t
    assert "back-EMF" in res_k["table"]["torque_constant_from"]
    # the zoo's logs have the d-voltage too: the drive's offset error within four of its standard errors of the twin's,
    # the torque constant along the magnets' axis against the TOML's, and the report's paragraph
    off = res_k["identification"]["back_emf"]["offset_error"]
    assert abs(off["delta"] - truth.offset_error) < 4 * off["delta_se"]
    assert abs(off["ratio_to_motor_k_t"] - truth.k_t / k_t) < 4 * off["k_t_aligned_se"] / k_t
    assert "Drive offset: the d-voltage" in (tmp_path / "k" / "id" / "report.html").read_text(encoding="utf-8")
    bare = []
    for p in logs:
        rows = p.read_text().splitlines()
        cols = rows[0].split(",")
        keep = [j for j, c in enumerate(cols) if c != "vq_1"]
        (tmp_path / p.name).write_text("\n".join(",".join(r.split(",")[j] for j in keep) for r in rows) + "\n")
        bare.append(tmp_path / p.name)
    res_b = json.loads((_identify(tmp_path / "b", tmp_path / "motor.toml", bare) / "results.json").read_text())
    assert res_b["identification"]["back_emf"] is None and "rms_Nm" not in res_b["table"]


def test_a_voltage_in_some_logs_only_is_said_and_not_read(tmp_path, zoo, capsys):
    """The first zoo log without its vq_1 column, the others with it: identify says that the voltage is in 3 of 4
    logs and reads none of it (results back_emf null)."""
    logs = sorted((zoo / "logs").glob("*.csv"))
    rows = logs[0].read_text().splitlines()
    cols = rows[0].split(",")
    keep = [j for j, c in enumerate(cols) if c != "vq_1"]
    (tmp_path / logs[0].name).write_text("\n".join(",".join(r.split(",")[j] for j in keep) for r in rows) + "\n")
    data = [tmp_path / logs[0].name, *logs[1:]]
    out = tmp_path / "id"
    assert main(["identify", "--motor", str(zoo / "motor.toml"), "--data", *map(str, data), "--out", str(out)]) == 0
    said = capsys.readouterr()
    assert f"vq_1 in {len(logs) - 1} of {len(logs)} logs: not read" in said.out + said.err
    assert json.loads((out / "results.json").read_text())["identification"]["back_emf"] is None


def test_reproduce_on_your_motor_as_identified(tmp_path, zoo, capsys):
    """reproduce --truth model.json (identify's, with its results.json beside): the twin is the motor as the logs gave
    it, J = (J/k0) k0 within 2 % of the zoo truth's (J/k0's error from these logs and k0's, as the N·m test above),
    the current noise from the logged d-current within 10 % of the twin's (a median absolute deviation of ~5000
    samples: 1.6 % standard error), the encoder's counts as read; the experiment's rows all there. Without the
    results.json it says what is missing."""
    rid = tmp_path / "id"
    capsys.readouterr()
    assert main(["identify", "--motor", str(zoo / "motor.toml"), "--data", *map(str, sorted((zoo / "logs").glob("*.csv"))),
                 "--out", str(rid)]) == 0
    # identify's last line says how to preview: that command, as printed, runs
    hint = [l for l in capsys.readouterr().out.splitlines() if l.startswith("preview the law")]
    assert len(hint) == 1
    args = shlex.split(hint[0].split(": ", 1)[1])
    assert args[:2] == ["pgcomm", "reproduce"] and args[args.index("--truth") + 1] == f"{rid}/model.json"
    out = tmp_path / "rep"
    args[args.index("--out") + 1] = str(out)
    assert main([*args[1:], "--quiet"]) == 0
    res = json.loads((out / "results.json").read_text())
    truth = read_truth(zoo / "truth.json")
    assert res["truth_source"].startswith("your motor as identified")
    j = float(re.search(r"J ([0-9.e+-]+) kg", res["truth_source"]).group(1))
    assert abs(j / truth.inertia - 1.0) < 0.02
    noise = float(re.search(r"current noise ([0-9.e+-]+) A", res["truth_source"]).group(1))
    assert abs(noise / truth.current_noise - 1.0) < 0.1
    ident = json.loads((rid / "results.json").read_text())["identification"]
    assert ident["current_noise_from"].startswith("the logged d-current")
    assert f"{truth.encoder_counts}-count encoder" in res["truth_source"]
    assert {"standstill_table", "model", "oracle"} <= set(res["tracking_mse"])
    alone = tmp_path / "alone"
    alone.mkdir()
    (alone / "model.json").write_text((rid / "model.json").read_text())
    capsys.readouterr()
    assert main(["reproduce", "--motor", str(zoo / "motor.toml"), "--truth", str(alone / "model.json"), "--quick",
                 "--out", str(tmp_path / "no")]) == 2
    err = capsys.readouterr().err
    assert "results.json" in err and "Traceback" not in err and not (tmp_path / "no").exists()


def test_logs_of_a_drive_faster_than_its_log_through_the_cli(tmp_path, zoo, capsys):
    """The zoo motor's running logs from a drive that controls 8 times per logged sample: identify says it read the
    current as snapshots of a moving one (about 8 cycles per logged sample), reports the lag (within a 64th of
    1/16) in results.json and report.html, and its table is within 5 % of the truth's RMS; with
    ``--current-lag held`` it is not."""
    from dataclasses import replace

    from pgcomm.io.rotary_zoo import write_running_logs

    truth = replace(read_truth(zoo / "truth.json"), control_per_log=8)
    logs = [tmp_path / "logs" / name for name in write_running_logs(truth, tmp_path / "logs", seed=0)]
    capsys.readouterr()
    out = tmp_path / "id"
    assert main(["identify", "--motor", str(zoo / "motor.toml"), "--data", *map(str, logs), "--out", str(out)]) == 0
    assert "a snapshot of a current that moves between logged samples" in capsys.readouterr().err
    timing = json.loads((out / "results.json").read_text())["identification"]["current_delay"]
    assert timing["held"] is False and timing["lag"] == pytest.approx(1 / 16, abs=1 / 64)
    assert "about 8 control cycles per logged sample" in (out / "report.html").read_text()
    ref = truth.model().table(3600)
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    assert rms(read_angle_table(out / "compensation.csv").iq - ref) <= 0.05 * rms(ref)
    # held and nothing else: a report filter of a fraction of a sample, searched by default, mimics the snapshot's lag
    held = _identify(tmp_path / "held", zoo / "motor.toml", logs, ["--current-lag", "held", "--current-filter", "none"])
    assert rms(read_angle_table(held / "compensation.csv").iq - ref) > 0.05 * rms(ref)


def test_zoo_drives_faster_than_their_logs(tmp_path, capsys):
    """``pgcomm zoo --kind rotary --control-per-log 8`` writes truths whose drives control 8 times per logged sample
    (their motor.toml as without); a count outside 1..64, or on linear motors, is refused in one line, no output."""
    out = tmp_path / "z"
    assert main(["zoo", "--kind", "rotary", "--motors", "1", "--control-per-log", "8", "--out", str(out),
                 "--quiet"]) == 0
    assert read_truth(out / "motor_01" / "truth.json").control_per_log == 8
    plain = tmp_path / "p"
    assert main(["zoo", "--kind", "rotary", "--motors", "1", "--out", str(plain), "--quiet"]) == 0
    assert (plain / "motor_01" / "motor.toml").read_text() == (out / "motor_01" / "motor.toml").read_text()
    for args, match in ((["--kind", "rotary", "--control-per-log", "0"], "--control-per-log 0: expected 1 to 64"),
                        (["--control-per-log", "8"], "--control-per-log: a rotary drive's control rate")):
        capsys.readouterr()
        bad = tmp_path / "bad"
        assert main(["zoo", "--motors", "1", *args, "--out", str(bad)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and match in err[0] and "Traceback" not in err[0]
        assert not bad.exists()


def test_the_rotary_table_of_the_settings_reads_as_the_options_on_the_command_line(tmp_path):
    """``--config``'s ``[rotary]`` table and the reading options on the command line make the same
    :class:`~pgcomm.settings.RotaryIdentifyOptions` (TOML's ``"held"``/``"none"`` as the options' ``held``/``none``);
    an option on the command line takes the table's place, and what neither gives is detected."""
    from dataclasses import replace

    from pgcomm.cli import build_parser
    from pgcomm.cli._identify_rotary import _rotary_options
    from pgcomm.settings import RotaryIdentifyOptions

    parser = build_parser()
    base = ["identify", "--motor", "m.toml", "--data", "x.csv", "--out", str(tmp_path / "o")]
    cfg = tmp_path / "exp.toml"
    cfg.write_text("[rotary]\ncurrent_delay = 1\ncurrent_lag = \"held\"\nangle_pll = [1000.0, 0.7]\n"
                   "time_lines = [50.0]\ncurrent_noise = 0.01\ncurrent_filter = \"none\"\n")
    from_file = _rotary_options(parser.parse_args([*base, "--config", str(cfg)]))
    from_flags = _rotary_options(parser.parse_args([*base, "--current-delay", "1", "--current-lag", "held",
                                                    "--angle-pll", "1000,0.7", "--time-lines", "50",
                                                    "--current-noise", "0.01", "--current-filter", "none"]))
    assert from_file == from_flags == RotaryIdentifyOptions(current_delay=1, current_lag=None, angle_pll=(1000.0, 0.7),
                                                            time_lines=(50.0,), current_noise=0.01,
                                                            current_filter=0.0)
    both = _rotary_options(parser.parse_args([*base, "--config", str(cfg), "--current-filter", "0.08"]))
    assert both == replace(from_file, current_filter=0.08)
    assert _rotary_options(parser.parse_args(base)) == RotaryIdentifyOptions()


def test_the_rotary_experiment_table_of_the_settings_sizes_reproduce(tmp_path):
    """``reproduce --motor rotary.toml --config FILE``: the experiment's sizes are the file's ``[rotary_experiment]``
    (:class:`~pgcomm.settings.RotarySettings`); ``--quick`` shortens what the file leaves to the defaults, and
    ``--log-budget`` / ``--until-resolved`` take their keys' place."""
    from dataclasses import replace

    from pgcomm.cli import build_parser
    from pgcomm.cli._reproduce_rotary import _rotary_settings
    from pgcomm.rotary.experiment import quick_settings
    from pgcomm.settings import RotarySettings, StandstillPlan

    parser = build_parser()
    base = ["reproduce", "--motor", "m.toml", "--out", str(tmp_path / "o")]
    cfg = tmp_path / "exp.toml"
    cfg.write_text("[rotary]\ncurrent_filter = 0.08\n[rotary_experiment]\nrevolutions = 1.5\nspeed_shares = [0.2, 0.4]\n"
                   "log_budget_share = 2.0\nstop_when_resolved = true\n[rotary_experiment.standstill]\npoints = 1440\n")
    from_file = RotarySettings(revolutions=1.5, speed_shares=(0.2, 0.4), log_budget_share=2.0, stop_when_resolved=True,
                               standstill=StandstillPlan(points=1440))
    ts = 1e-3
    assert _rotary_settings(parser.parse_args([*base, "--config", str(cfg)]), ts) == from_file
    assert _rotary_settings(parser.parse_args(base), ts) == RotarySettings()
    assert _rotary_settings(parser.parse_args([*base, "--quick"]), ts) == quick_settings()
    quick_cfg = tmp_path / "quick.toml"
    quick_cfg.write_text("[rotary_experiment]\nspeed_shares = [0.2, 0.4]\n")
    assert (_rotary_settings(parser.parse_args([*base, "--quick", "--config", str(quick_cfg)]), ts)
            == replace(quick_settings(), speed_shares=(0.2, 0.4)))
    # 40 s of rig time over the sweep's 2 * 1440 * (30 + 20) samples of 1 ms
    budget = _rotary_settings(parser.parse_args([*base, "--config", str(cfg), "--log-budget", "40"]), ts)
    assert budget == replace(from_file, log_budget_share=pytest.approx(40 / (2 * 1440 * 50 * ts), rel=1e-12))
