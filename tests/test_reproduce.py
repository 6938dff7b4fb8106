"""``pgcomm reproduce --quick`` end to end on the twin: keys, rows, report, and the paper's bars that hold
already on the short run."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from pgcomm.cli import main
from pgcomm.io.results import get_key
from pgcomm.reproduce import ROWS


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("rep") / "out"
    assert main(["reproduce", "--quick", "--out", str(out), "--quiet"]) == 0
    return json.loads((out / "results.json").read_text()), out


def test_design_keys_present(quick):
    res, _ = quick
    for key in ("calibration.initial.k", "calibration.initial.zeta", "calibration.calibrated.k",
                "calibration.calibrated.zeta", "calibration.true.k", "calibration.true.zeta",
                "identification.seconds_total", "runtime_s"):
        get_key(res, key)
    for row in ROWS:
        assert get_key(res, f"tracking_mse.{row}") > 0
        for d in ("y", "x", "z"):
            for kind in ("filtered", "unfiltered"):
                assert get_key(res, f"commutation_mse.{row}.{d}.{kind}") > 0
    for l in range(3):
        for key in ("cost_physics", "cost_pgnn", "cost_physics_validation", "cost_pgnn_validation", "seconds"):
            assert np.isfinite(get_key(res, f"identification.coil_sets[{l}].{key}"))


def test_pgnn_cost_below_physics(quick):
    """Proposition 1: the PGNN's cost is strictly below the physics-only cost, train and validation."""
    res, _ = quick
    for c in res["identification"]["coil_sets"]:
        assert c["cost_pgnn"] < c["cost_physics"]
        assert c["cost_pgnn_validation"] < c["cost_physics_validation"]


def test_rows_ordering(quick):
    """The oracle is at or below classical in every direction; the PGNN beats the drive's cogging table and the
    harmonic cogging model in y.

    The paper's 10x (classical / PGNN in y) is a figure for a full-size identification
    (``bench/bench_quick.py --full`` prints the short run's rows against a full run's): the short run stops its
    PGNN at 25 LM iterations per start, where the y error still moves with the machine's floating-point path
    (seed 0: ~3.0 N^2 on one x86-64 machine, 3.74 N^2 on an AVX-512 AMD EPYC, i.e. 12x and 9.7x), so this test
    checks the ordering the short run shows on any machine.
    """
    res, _ = quick
    cm = res["commutation_mse"]
    for d in ("y", "x", "z"):
        assert cm["oracle"][d]["filtered"] < cm["classical"][d]["filtered"]
    assert cm["pgnn"]["y"]["filtered"] < cm["cogging_table"]["y"]["filtered"]
    assert cm["pgnn"]["y"]["filtered"] < cm["harmonic_cogging"]["y"]["filtered"]


def test_report_matches_results(quick):
    """The report embeds every figure and shows the numbers of results.json."""
    res, out = quick
    html = (out / "report.html").read_text()
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert html.count("data:image/png;base64,") == len(pngs) >= 6
    for row in ROWS:
        cm = res["commutation_mse"][row]
        cell = f"{cm['y']['filtered']:.3g} ({cm['y']['unfiltered']:.3g})"
        assert re.search(rf"<th>{row}</th>.*?{re.escape(cell)}", html), (row, cell)
    assert f"{res['tracking_mse']['pgnn']:.3g}" in html
    assert (out / "model.json").exists() and (out / "model.npz").exists()


def _text(html: str) -> str:
    """The report without its embedded images, HTML entities resolved."""
    import html as html_lib

    return html_lib.unescape(re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "", html))


def test_report_speaks_plain_words_with_units(quick):
    """No LaTeX label of the paper (Table Commutation_Performance, eq. Identification_CostFunction,
    Fig. Data_Generation, ...), a unit in every numeric column's header, one caption per figure and none twice."""
    _, out = quick
    html = _text((out / "report.html").read_text())
    labels = re.findall(r"\b[A-Z][A-Za-z]*(?:_[A-Z][A-Za-z0-9]*)+\b", html)
    assert labels == [], labels
    for table in re.findall(r"<table>(.*?)</table>", html, flags=re.S):
        header = re.search(r"<tr>(.*?)</tr>", table, flags=re.S).group(1)
        for th in re.findall(r"<th>(.*?)</th>", header, flags=re.S):
            assert th in ("row", "law", "coil set") or re.search(r"\[[^\]]+\]$", th), th
    captions = re.findall(r"<figcaption>(.*?)</figcaption>", html, flags=re.S)
    assert len(captions) == len(set(captions)) == len(list(out.glob("*.png")))
    for word in ("the paper's Table 1", "the paper's Table 2", "the paper's Fig. 8", "the paper's Fig. 9"):
        assert word in html, word


def test_report_explains_the_pgnn_gain_offset(quick):
    """On the twin the force-sensor PGNN's Fy gain sits well above the truth because it takes the motor's
    direction-dependent force into its gain: the PGNN with the direction term, from the same data, is back
    at the truth (less than half the offset; measured: 11 % against 0.1 %). The report says so, with the
    numbers of results.json."""
    res, out = quick
    me = res["model_error"]
    r_p, r_d = me["pgnn"]["gain_ratio_y"], me["pgnn_direction"]["gain_ratio_y"]
    assert r_p > 1.02 and abs(r_d - 1) < 0.5 * abs(r_p - 1), (r_p, r_d)
    assert abs(me["spline"]["gain_ratio_y"] - 1) < 0.5 * abs(r_p - 1)
    html = _text((out / "report.html").read_text())
    cap = re.search(r"<figcaption>(Gain of coil set 1, PGNN.*?)</figcaption>", html, flags=re.S).group(1)
    assert f"{100 * (r_p - 1):.1f} % above the truth" in cap
    assert "direction-dependent force" in cap and "extra gain" in cap


def test_report_says_what_the_sensorless_line_below_the_oracle_is(quick):
    """The oracle's filtered y error is the force sensor's noise (its true force meets the demand), and the line
    with the direction force taken out is of the true force (no noise): below the oracle is no paradox, and the
    report says it is a different quantity."""
    res, out = quick
    sn, oracle = res["sensor_noise"], res["commutation_mse"]["oracle"]["y"]["filtered"]
    a = np.exp(-2 * np.pi * 50.0 * 1e-3)
    assert sn["expected"]["y"] == pytest.approx(0.8 ** 2 * (1 - a) / (1 + a), rel=1e-12)
    # the oracle has the true state: its true force meets the demand (well below the noise), so its measured error
    # is the noise draw of this reference
    assert sn["oracle_true_force"]["y"] < 0.01 * sn["long"]["y"]
    n, t = sn["long"]["y"], sn["oracle_true_force"]["y"]
    assert abs(oracle - n - t) <= 2 * np.sqrt(n * t) + 1e-12 * n  # the cross term, by Cauchy-Schwarz
    wo = res["sensorless"]["y_mse_without_direction_force"]["pgnn_sensorless"]
    assert wo < oracle  # the case the report must explain
    html = _text((out / "report.html").read_text())
    sentence = re.search(r"<li>[^<]*PGNN without force sensor[^<]*</li>", html).group(0)
    assert f"{wo:.3g} N²" in sentence and "A different quantity" in sentence and "true driving force" in sentence
    assert f"{sn['long']['y']:.3g} N² of sensor noise" in sentence and "does not beat the floor" in sentence


def test_filtered_noise_mse_matches_filtered_white_noise():
    from pgcomm.metrics import lowpass
    from pgcomm.reproduce import filtered_noise_mse
    from pgcomm.sensors import Sensors

    sensors = Sensors(force_noise=(0.8, 0.45, 0.9))
    n, ts = 400_000, 1e-3
    rng = np.random.default_rng(3)
    got = filtered_noise_mse(sensors, ts, 50.0)
    a = np.exp(-2 * np.pi * 50.0 * ts)
    # the filtered series is correlated over ~(1 + a)/(1 - a) samples: its variance estimate's relative standard
    # error is sqrt(2 (1 + a) / ((1 - a) n)); 5 of them
    tol = 5 * np.sqrt(2 * (1 + a) / ((1 - a) * n))
    for q, d in enumerate("yxz"):
        x = lowpass(rng.normal(0.0, sensors.force_noise[q], n), ts, 50.0)
        assert np.mean(x[100:] ** 2) == pytest.approx(got[d], rel=tol)


def test_sensorless_rows(quick):
    """Without a force sensor on the twin: calibration within the calibration bars (0.5 %, 5 mrad); pgnn_sensorless removes
    >= 80 % of what the force-sensor PGNN removes in y; with the plant's direction-dependent force (which no
    sensorless law can tell from friction) taken out, it beats the drives' sensorless anti-cogging table."""
    res, _ = quick
    sl = res["sensorless"]
    err = sl["calibration"]["error"]
    assert np.all(np.abs(err["k_relative"]) < 0.005) and np.all(np.abs(err["zeta_rad"]) < 0.005)
    assert sl["share_of_pgnn_reduction_y"] >= 0.8
    wo = sl["y_mse_without_direction_force"]
    assert wo["pgnn_sensorless"] < wo["cogging_table_sensorless"]
    assert wo["pgnn_sensorless"] < 0.01 * wo["classical"]
    for c in sl["coil_sets"]:
        assert c["force_sensor"] is False
        me = c["mechanics"]  # the twin's translator: 12 N Coulomb minus its 3 N direction force, 80 N s/m
        assert me["viscous"] == pytest.approx(80.0, rel=0.05)
        assert 0 < me["coulomb"] < 12.0
    assert sl["cogging_table"]["samples"]["positive"] > 0


def test_spline_row_tracks_and_merges_the_mechanics(quick):
    """The spline row on the twin (quick run): its own identification recovers the simulated translator
    (mass 1 %, viscous 2 %, Coulomb table mean 2 %: the data are noise-light windows of ~5000 moving samples);
    it removes >= 97 % of the reducible y error and tracks at most half as badly as the drives' anti-cogging
    table on every reference; the recommended row is the realisable row with the least long-reference tracking."""
    res, _ = quick
    me, sim = res["mechanics"]["identified"], res["mechanics"]["simulated"]
    assert me["mass"] == pytest.approx(sim["mass"], rel=0.01)
    assert me["viscous"] == pytest.approx(sim["viscous"], rel=0.02)
    assert me["coulomb_mean"] == pytest.approx(sim["coulomb"], rel=0.02)
    assert res["reducible_share"]["spline"]["y"] >= 0.97
    for rname, ref in res["references"].items():
        assert ref["tracking_mse"]["spline"] <= 0.5 * ref["tracking_mse"]["cogging_table"], rname
    rec = res["recommended"]
    tm = res["tracking_mse"]
    assert rec["row"] != "oracle" and rec["tracking_mse"] == min(v for r, v in tm.items() if r != "oracle")
    assert res["tracking_order"] == sorted(tm, key=tm.get)
    assert rec["table_bytes"] > 0
    ident = res["identification"]["spline"]
    assert ident["parameters"] > 0 and all(c["y"] > 0 for c in ident["cost_validation"])
