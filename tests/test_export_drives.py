"""The drives' own tables (SINAMICS, AKD, Moog MSD, Beckhoff AX8000, Novanta Summit, IONI; moteus, ODrive):
each file read back by pgcomm's reader, each index -> position, unit and sign checked against a value computed by
hand from the manual's definitions, every drive's table within the limit and finite for any position, and bad
input refused with one line.

The compensations are single harmonics with amplitudes of order A0, so the hand values are closed forms;
tolerances are float32 rounding (2^-24 of the table's scale) unless a test says otherwise.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from pgcomm.cli import main
from pgcomm.errors import ConfigError, DataError
from pgcomm.export import akd, beckhoff, ioni, moog, sinamics, summit
from pgcomm.export.compensation import Compensation, from_angle_table, from_rotary_model
from pgcomm.export.drive_common import round_trip
from pgcomm.export.moteus import build_moteus, moteus_apply, read_moteus
from pgcomm.export.odrive import build_odrive, odrive_apply
from pgcomm.rotary.model import Fourier, RotaryModel

A0 = 0.2     # A: cogging amplitude (as a current)
D0 = 0.05    # A: drag
KT = 0.5     # N m/A
F32 = 2.0**-24


def rotary(orders=(16,), amps=(A0,), drag=D0, ripple=None, p=7, k_t=KT, limit=None):
    """A rotary model with cogging c = Σ a cos(hθ), drag d = D0 (order 0) and optional ripple (order, depth)."""
    cog = Fourier(np.array(orders), np.stack([np.array(amps, float), np.zeros(len(orders))], axis=1))
    rip = Fourier.zeros([]) if ripple is None else Fourier(np.array([ripple[0]]), np.array([[ripple[1], 0.0]]))
    dr = Fourier(np.array([0]), np.array([[drag, 0.0]])) if drag else Fourier.zeros([])
    model = RotaryModel(p, cog, rip, dr, k_t=k_t, info={"motor": "test", "current_limit": limit})
    return model, from_rotary_model(model, limit, "test", "model.json")


def linear(profile, span=(-0.1, 0.1), pitch=0.03, limit=None, k_f=50.0, directional=False):
    """A linear compensation ``profile(y)`` (N), ``+ s·3 N`` per direction when ``directional``."""
    def fn(y, s):
        return profile(np.asarray(y, float)) + (0.0 if s is None else 3.0 * float(np.sign(s)))

    return Compensation("linear", "N", fn, span, limit, "test", "lin.json", (), directional,
                        pole_pitch=pitch, force_constant=k_f)


def theta(i, n):
    return 2.0 * math.pi * i / n


# ------------------------------------------------------------------ SINAMICS S120


def test_sinamics_rotary_entries_units_sign_and_two_tables(tmp_path):
    """p5260[i] = k_t (−c + d s)(2π i/4096) N m: order 16 has 256 entries per period, so entry 128 is half a
    cogging period: cos = −1."""
    _, comp = rotary()
    tab = sinamics.write_sinamics(sinamics.build_sinamics(comp, KT, directions=2, hysteresis=3.0), tmp_path / "s.txt")
    back = sinamics.read_sinamics(tmp_path / "s.txt")
    assert back["p5253"] == 1.0 and back["p5250.1"] == 1.0 and back["p5256"] == 3.0
    fwd, rev = back["p5260"], back["p5261"]
    tol = KT * (A0 + D0) * F32 * 2
    assert fwd[0] == pytest.approx(KT * (-A0 + D0), abs=tol)
    assert fwd[128] == pytest.approx(KT * (A0 + D0), abs=tol)
    assert fwd[64] == pytest.approx(KT * D0, abs=tol)      # a quarter period: cos = 0
    assert rev[0] == pytest.approx(KT * (-A0 - D0), abs=tol)
    np.testing.assert_array_equal(fwd, tab.tables["forward"])  # the reader gets the float32 the drive holds
    # the drive's model: forward table when moving forward, half-way between entries the mean of both
    x = theta(128.5, 4096)
    assert sinamics.sinamics_apply(tab, x, +1) == pytest.approx(0.5 * (fwd[128] + fwd[129]), abs=tol)
    assert sinamics.sinamics_apply(tab, x + 6 * math.pi, -1) == pytest.approx(0.5 * (rev[128] + rev[129]), abs=tol)


def test_sinamics_direction_hysteresis_keeps_the_table_inside_the_band():
    band = 2.0
    prev = np.array([1.0, 1.0, -1.0, -1.0])
    v = np.array([0.5, -1.5, 0.9, 1.1])
    np.testing.assert_array_equal(sinamics.select_direction(v, prev, band), [1.0, -1.0, -1.0, 1.0])


def test_sinamics_period_fraction_averages_the_copies(tmp_path):
    """p5253 = 1/2: the table covers half a revolution and holds the mean of the two halves: an odd order
    (1) averages out, an even one (16) stays."""
    _, comp = rotary(orders=(1, 16), amps=(0.3, A0), drag=0.0)
    tab = sinamics.build_sinamics(comp, KT, factor=0.5)
    i = np.arange(4096)
    want = -KT * A0 * np.cos(16 * math.pi * i / 4096)
    np.testing.assert_allclose(tab.tables["both"], want, rtol=0, atol=KT * 0.5 * 1e-9 + KT * A0 * F32 * 2)


def test_sinamics_linear_entries_sit_at_the_measuring_systems_position():
    """Entry i at i·P/4096 of the measuring system's position (taken into the window that starts one spacing
    before the stroke); the default period P = stroke·4096/4094 keeps the table's wrap beyond the stroke, so the
    drive's interpolation reproduces a ramp over the whole stroke."""
    comp = linear(lambda y: 10.0 * y)  # N: a ramp makes every position's value its own
    tab = sinamics.build_sinamics(comp)
    P = 0.2 * 4096 / 4094
    assert tab.factor == pytest.approx(P / 0.03, rel=1e-12) and tab.unit == "N"
    v = tab.tables["both"]
    for i, y in ((0, 0.0), (100, 100 * P / 4096), (1024, P / 4), (3072, -P / 4), (4000, -96 * P / 4096)):
        assert v[i] == pytest.approx(10.0 * y, abs=2.0 * F32 + 1e-12), i
    y = np.linspace(-0.1, 0.1, 20001)
    np.testing.assert_allclose(sinamics.sinamics_apply(tab, y), 10.0 * y, atol=2.0 * F32 + 1e-12)


# ------------------------------------------------------------------ Kollmorgen AKD


def test_akd_rotary_and_linear_entries(tmp_path):
    """8192 entries over one turn: order 32 has 256 per period (entry 128: cos = −1); linear: RANGELOW/HIGH in
    mm and entry i at RANGELOW + i (HIGH − LOW)/8192, the offset in A = N / force constant."""
    _, comp = rotary(orders=(32,), drag=0.0)
    tab = akd.write_akd(akd.build_akd(comp), tmp_path / "a.txt")
    back = akd.read_akd(tmp_path / "a.txt")
    assert back["values"][0] == pytest.approx(-A0, abs=A0 * F32) and back["values"][128] == pytest.approx(A0, abs=A0 * F32)
    text = (tmp_path / "a.txt").read_text()
    assert "COGCOMP.RANGELOW 0\nCOGCOMP.RANGEHIGH 0\n" in text and text.rstrip().endswith("COGCOMP.EN 1")
    assert tab.round_trip.max <= tab.round_trip.bound
    comp = linear(lambda y: 10.0 * y, k_f=50.0)
    tab = akd.write_akd(akd.build_akd(comp), tmp_path / "l.txt")
    back = akd.read_akd(tmp_path / "l.txt")
    assert back["low"] == pytest.approx(-100.0) and back["high"] == pytest.approx(100.0)
    y = -0.1 + 0.2 * 4096 / 8192
    assert back["values"][4096] == pytest.approx(10.0 * y / 50.0, abs=1e-9)
    assert akd.akd_apply(tab, 0.1 + 1e-9) == 0.0  # outside the range: no compensation (assumed)


# ------------------------------------------------------------------ Moog MSD


def test_moog_small_table_index_from_the_32_bit_position(tmp_path):
    """index = (inpos / 2^32)·250: order 25 has 10 entries per period; inpos = 2^31 is index 125 (θ = π)."""
    _, comp = rotary(orders=(25,), drag=0.0)
    tab = moog.write_moog(moog.build_moog(comp, 250, fade_out=(100.0, 300.0)), tmp_path / "m.txt")
    back = moog.read_moog(tmp_path / "m.txt")
    v = back["values"]
    assert v.size == 250 and v[0] == pytest.approx(-A0, abs=A0 * F32) and v[5] == pytest.approx(A0, abs=A0 * F32)
    inpos = 2**31
    th = 2.0 * math.pi * inpos / 2**32
    assert moog.moog_apply(tab, th) == pytest.approx(v[int(inpos / 2**32 * 250)], abs=A0 * 1e-6)
    assert back["fade"] == (100.0, 300.0)
    # the fade-out: full up to 100 rpm, half at 200, none from 300
    assert [float(moog.moog_apply(tab, 0.0, s)) for s in (50, 200, -200, 400)] == pytest.approx(
        [v[0], 0.5 * v[0], 0.5 * v[0], 0.0], abs=1e-9)


def test_moog_linear_uses_the_large_table_through_posstart_posdelta(tmp_path):
    comp = linear(lambda y: 10.0 * y, k_f=40.0)
    tab = moog.write_moog(moog.build_moog(comp), tmp_path / "m.txt")
    back = moog.read_moog(tmp_path / "m.txt")
    assert back["start"] == pytest.approx(-0.1) and back["delta"] == pytest.approx(0.2 / 3999)
    i = 1234
    assert back["values"][i] == pytest.approx(10.0 * (-0.1 + i * 0.2 / 3999) / 40.0, abs=1e-8)
    assert tab.size == 4000


# ------------------------------------------------------------------ Beckhoff AX8000


def test_beckhoff_harmonic_order_phase_amplitude(tmp_path):
    """c = A0 cos 14θ + 0.1 sin 28θ: the compensation −c is r cos(nθ + phi) with (n, phi, r) = (14, 180°,
    k_t A0) and (28, 90°, 0.1 k_t) under the assumed formula."""
    _, comp = rotary(orders=(14,), drag=0.0)
    model = RotaryModel(7, Fourier(np.array([14, 28]), np.array([[A0, 0.0], [0.0, 0.1]])), Fourier.zeros([]),
                        Fourier.zeros([]), k_t=KT)
    comp = from_rotary_model(model, None, "test", "m.json")
    tab = beckhoff.write_beckhoff(beckhoff.build_beckhoff(comp, KT), tmp_path / "b.txt")
    back = beckhoff.read_beckhoff(tmp_path / "b.txt")
    got = dict(zip(back["n"].tolist(), zip(back["phi"], back["r"])))
    assert set(got) == {14, 28}
    assert got[14][0] == pytest.approx(180.0, abs=1e-4) and got[14][1] == pytest.approx(KT * A0, rel=1e-6)
    assert got[28][0] == pytest.approx(90.0, abs=1e-4) and got[28][1] == pytest.approx(KT * 0.1, rel=1e-6)
    text = (tmp_path / "b.txt").read_text()
    assert "0x32CB:01 = 3\n" in text and "0x32CB:24 = 0\n" in text  # 10 sets, unused ones zero
    x = np.linspace(0, 2 * math.pi, 97)
    np.testing.assert_allclose(beckhoff.beckhoff_apply(tab, x), KT * comp.values(x), atol=KT * 0.3 * 1e-6)


def test_beckhoff_keeps_at_most_ten_orders_up_to_200_and_stays_within_the_limit():
    orders = tuple(range(10, 250, 20))  # 12 orders, two beyond 200
    _, comp = rotary(orders=orders, amps=tuple(0.05 for _ in orders), drag=0.0, limit=0.3)
    tab = beckhoff.build_beckhoff(comp, KT)
    assert tab.orders.size == 10 and tab.orders.max() <= 200
    assert np.sum(tab.r) <= KT * 0.3 * (1 + 1e-6)
    assert tab.dropped > 0


# ------------------------------------------------------------------ Novanta Summit


def test_summit_table_over_the_electrical_angle(tmp_path):
    """p = 7, N = 64: entry k at θe = 2π(k + ½)/64; order 14 = 2 per electrical revolution stays, order 3 (not a
    multiple of p) averages out over the 7 copies."""
    _, comp = rotary(orders=(14, 3), amps=(A0, 0.1), drag=0.0, p=7)
    tab = summit.write_summit(summit.build_summit(comp, 64), tmp_path / "s.txt")
    back = summit.read_summit(tmp_path / "s.txt")
    k = np.arange(64)
    np.testing.assert_allclose(back, -A0 * np.cos(2 * 2 * math.pi * (k + 0.5) / 64), atol=A0 * F32 * 2 + 1e-12)
    text = (tmp_path / "s.txt").read_text()
    assert text.splitlines()[-1] == "0x2306 = 1" and "0x2307 = 63\n" in text
    # the drive at a mechanical angle whose electrical angle is entry 5's centre
    th = 2 * math.pi * (5.5 / 64 + 3) / 7
    assert summit.summit_apply(tab, th) == pytest.approx(back[5], abs=1e-9)


# ------------------------------------------------------------------ Granite Devices IONI


def test_ioni_two_sinusoids_from_the_model(tmp_path):
    """c = A0 cos 14θ, p = 7, ripple r = ε cos 42θ: −c/(1+r) has −A0 (1 + ε²/2) cos 14θ + orders 28, 56, ...:
    TRF1 N = 2, phase −90° (−cos = sin(· − 90°)), TRA1 = A0 (1 + ε²/2); 1/(1+r) − 1 = −ε cos 6θe + O(ε²) →
    TRF2 N = 6, phase −90°, TRA2 = ε (1 + O(ε²))."""
    eps = 0.01
    _, comp = rotary(orders=(14,), drag=0.0, ripple=(42, eps), p=7)
    tab = ioni.write_ioni(ioni.build_ioni(comp), tmp_path / "i.txt")
    back = ioni.read_ioni(tmp_path / "i.txt")
    c, r = back["cogging"], back["ripple"]
    assert (c.n, r.n) == (2, 6)
    assert c.amplitude == pytest.approx(A0 * (1 + eps**2 / 2), rel=eps**4) and math.degrees(c.phase) == pytest.approx(-90.0, abs=1e-4)
    assert r.amplitude == pytest.approx(eps, rel=3 * eps**2) and math.degrees(r.phase) == pytest.approx(-90.0, abs=1e-3)
    assert "TRF1: sine, N = 2 per electrical revolution" in (tmp_path / "i.txt").read_text()


# ------------------------------------------------------------------ moteus and ODrive against their firmware


def test_moteus_firmware_rule_at_hand_angles():
    """ISR_DoPositionCommon: left = min(1023, int(1024 f)), linear toward (left + 1) % 1024."""
    _, comp = rotary(orders=(3,), drag=0.0)
    mt = build_moteus(comp)
    e = mt.entries.astype(float) * mt.scale
    assert moteus_apply(mt, theta(512.25, 1024)) == pytest.approx(0.75 * e[512] + 0.25 * e[513], abs=1e-12)
    assert moteus_apply(mt, 2 * math.pi - theta(0.5, 1024)) == pytest.approx(0.5 * (e[1023] + e[0]), abs=1e-12)
    assert moteus_apply(mt, theta(7, 1024) - 4 * math.pi) == pytest.approx(e[7], abs=1e-12)


def test_moteus_rounds_and_a_given_scale_that_overflows_int8_is_refused():
    _, comp = rotary(orders=(16,), drag=0.0)
    mt = build_moteus(comp, scale=0.004)
    assert mt.scale == pytest.approx(0.004, rel=1e-7) and mt.quantisation <= 0.5 * mt.scale * (1 + 1e-6)
    assert abs(int(mt.entries[0])) == round(A0 / 0.004)  # 50: rounded, not truncated
    with pytest.raises(ConfigError, match="beyond int8"):
        build_moteus(comp, scale=0.001)


def test_odrive_truncation_toward_zero_for_negative_positions():
    _, comp = rotary(orders=(5,), drag=0.0)
    om = build_odrive(comp, KT)
    cur = om.current
    assert odrive_apply(om, theta(10.5, 3600)) == cur[10]
    assert odrive_apply(om, -theta(0.5, 3600)) == cur[0]       # (int)(−0.5) = 0
    assert odrive_apply(om, -theta(1.5, 3600)) == cur[3599]    # (int)(−1.5) = −1 -> mod 3600


# ------------------------------------------------------------------ safety for every input


def _all_drives(comp, k_t):
    """Every drive's applied value (in A of q current, or N for linear torque units) as a function of x."""
    out = {}
    if comp.rotary:
        s = sinamics.build_sinamics(comp, k_t, 2 if comp.directional else 1)
        out["sinamics"] = (lambda x, s=s: sinamics.sinamics_apply(s, x, np.sign(np.sin(3 * np.where(np.isfinite(x), x, 0.0)))) / k_t)
        b = beckhoff.build_beckhoff(comp, k_t)
        out["beckhoff"] = lambda x, b=b: beckhoff.beckhoff_apply(b, x) / k_t
        sm = summit.build_summit(comp, 128)
        out["summit"] = lambda x, sm=sm: summit.summit_apply(sm, x)
        io = ioni.build_ioni(comp)
        out["ioni"] = lambda x, io=io: ioni.ioni_apply(io, x, 0.0)
        mt = build_moteus(comp)
        out["moteus"] = lambda x, mt=mt: moteus_apply(mt, x)
        om = build_odrive(comp, k_t)
        out["odrive"] = lambda x, om=om: odrive_apply(om, x)
        k = 1.0
    else:
        s = sinamics.build_sinamics(comp)
        out["sinamics"] = lambda x, s=s: sinamics.sinamics_apply(s, x)
        b = beckhoff.build_beckhoff(comp)
        out["beckhoff"] = lambda x, b=b: beckhoff.beckhoff_apply(b, x)
        k = 1.0 / comp.force_constant
    a = akd.build_akd(comp)
    out["akd"] = lambda x, a=a: akd.akd_apply(a, x) / k
    m = moog.build_moog(comp)
    out["moog"] = lambda x, m=m: moog.moog_apply(m, x, 0.0) / k
    return out


@pytest.mark.parametrize("kind", ["rotary", "linear"])
def test_every_drive_table_is_finite_and_within_the_limit_for_any_position(kind):
    """Positions over ±10 times the range, wrapped and unwrapped, and NaN/±inf: the value every drive adds is
    finite and within the limit (a compensation twice the limit is clipped)."""
    rng = np.random.default_rng(0)
    if kind == "rotary":
        limit = 0.25
        _, comp = rotary(orders=(14, 28, 3), amps=(0.4, 0.1, 0.05), drag=0.1, ripple=(42, 0.02), limit=limit)
        span = 2 * math.pi
        x = np.concatenate([rng.uniform(-10 * span, 10 * span, 4000), np.mod(rng.uniform(-10, 10, 500), span)])
    else:
        limit = 40.0
        comp = linear(lambda y: 80.0 * np.sin(2 * math.pi * y / 0.03) + 30 * y, limit=limit, directional=True)
        span = comp.length
        x = rng.uniform(-10 * span, 10 * span, 4000)
    x = np.concatenate([x, [np.nan, np.inf, -np.inf, 0.0, span, -span]])
    for name, f in _all_drives(comp, KT).items():
        v = f(x)
        assert np.all(np.isfinite(v)), name
        assert np.max(np.abs(v)) <= limit * (1 + 1e-6), (name, np.max(np.abs(v)))
        assert np.all(v[-6:-3] == 0.0), name  # non-finite position: nothing added


# ------------------------------------------------------------------ the read-back check


def test_round_trip_refuses_a_file_beyond_the_drives_quantisation():
    meant = np.array([0.1, -0.2, 0.3])
    assert round_trip(meant + 1e-9, meant, 2e-9, "f", "A").max == pytest.approx(1e-9)
    with pytest.raises(DataError, match="entry 1 differs from the table by .* more than the drive's quantisation"):
        round_trip(meant + np.array([0, 1e-6, 0]), meant, 1e-8, "f", "A")


def test_a_writer_that_loses_digits_is_refused_and_nothing_is_written(tmp_path, monkeypatch, capsys):
    """A file written with 3 significant digits is caught by the read-back: exit 2, one line, no output."""
    path = tmp_path / "rot.json"
    path.write_text(json.dumps(rotary(limit=2.0)[0].to_dict()))
    monkeypatch.setattr(sinamics, "fmt32", lambda v: "%.3g" % v)
    argv = ["export", "--format", "sinamics", "--model", str(path), "--out", str(tmp_path / "o")]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "more than the drive's quantisation" in err
    assert not (tmp_path / "o").exists()


# ------------------------------------------------------------------ the command line


@pytest.fixture
def files(tmp_path):
    model, _ = rotary(limit=2.0)
    rot = tmp_path / "rot.json"
    rot.write_text(json.dumps(model.to_dict()))
    from pgcomm.export.angle_table import make_table, write_angle_table

    tab = write_angle_table(tmp_path / "t.csv", make_table(model.table(256), "model", current_limit=2.0))
    lin = tmp_path / "lin.json"
    lin.write_text(json.dumps({"schema": "pgcomm.model/2"}))  # a linear model file's header
    # a cogging of RMS 0.25 A within a 0.3 A limit whose peak, 0.35 A, is beyond it
    big, _ = rotary(amps=(0.35,), drag=0.0, limit=0.3)
    over = tmp_path / "over.json"
    over.write_text(json.dumps(big.to_dict()))
    return {"rot": rot, "tab": tab, "lin": lin, "over": over}


@pytest.mark.parametrize("fmt, extra", [("sinamics", ["--directions", "2"]), ("akd", []), ("moog", []),
                                        ("beckhoff", []), ("summit", ["--entries", "512"]), ("ioni", [])])
def test_cli_each_drive_from_a_rotary_model(tmp_path, files, capsys, fmt, extra):
    out = tmp_path / fmt
    assert main(["export", "--format", fmt, "--model", str(files["rot"]), "--out", str(out)] + extra) == 0
    res = json.loads((out / "results.json").read_text())
    rt = res[fmt]["round_trip"]
    assert rt["max"] <= rt["bound"] and res["kind"] == "rotary"
    text = (out / f"pgcomm_{fmt}.txt").read_text()
    assert "What the documentation fixes:" in text and "What pgcomm assumed" in text and "Sources:" in text
    assert "http" in text
    printed = capsys.readouterr().out
    assert "read back:" in printed and "assumes:" in printed and "load:" in printed


@pytest.mark.parametrize("args, match", [
    (["--format", "moog", "--model", "{rot}", "--entries", "8192"], "holds a table of 250 .* or 4000"),
    (["--format", "beckhoff", "--model", "{rot}", "--harmonics", "11"], "holds 1 to 10 coefficient sets"),
    (["--format", "summit", "--model", "{rot}", "--entries", "70000"], "8 to 65536"),
    (["--format", "moteus", "--model", "{rot}", "--scale", "0.0001"], "beyond int8"),
    (["--format", "moteus", "--model", "{lin}"], "is a linear model; --format moteus"),
    (["--format", "odrive", "--model", "{lin}", "--torque-constant", "1"], "is a linear model; --format odrive"),
    (["--format", "summit", "--model", "{lin}", "--entries", "64"], "is a linear model; --format summit"),
    (["--format", "ioni", "--model", "{lin}"], "is a linear model; --format ioni"),
    (["--format", "summit", "--table", "{tab}", "--entries", "64"], "give --pole-pairs"),
    (["--format", "sinamics", "--table", "{tab}", "--torque-constant", "1", "--directions", "2"], "no direction term"),
    (["--format", "sinamics", "--table", "{tab}"], "give --torque-constant"),
    (["--format", "akd", "--model", "{rot}", "--harmonics", "3"], "--harmonics is for --format beckhoff"),
    (["--format", "akd", "--model", "{over}"], r"over.json: the compensation reaches -0.35 A at 0 rad, beyond the limit "
                                              "0.3 A"),
])
def test_cli_bad_input_one_line_exit_2_nothing_written(tmp_path, files, capsys, args, match):
    argv = ["export"] + [a.format(**files) for a in args] + ["--out", str(tmp_path / "out")]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("pgcomm: error:") and "Traceback" not in err, err
    assert __import__("re").search(match, err), err
    assert not (tmp_path / "out").exists()


def test_a_table_file_exports_like_its_model(tmp_path, files):
    """The same compensation through a table file and through the model: the same AKD entries (the table's
    trigonometric interpolant is the band-limited model)."""
    model, _ = rotary(limit=2.0)
    from pgcomm.export.angle_table import read_angle_table

    a = akd.build_akd(from_angle_table(read_angle_table(files["tab"])))
    b = akd.build_akd(from_rotary_model(model))
    np.testing.assert_allclose(a.values, b.values, atol=(A0 + D0) * 1e-6)


# ------------------------------------------------------------------ linear models end to end


@pytest.fixture(scope="module")
def linear_model(tmp_path_factory):
    """A paper-like PGNN (3 coil sets, d_m = 0.03 m) with a direction force C_y = 4 N, saved with its limit."""
    import dataclasses

    import jax.numpy as jnp
    from test_export_lut import paper_model

    from pgcomm.io.model import save_model

    m = paper_model(0)
    m = dataclasses.replace(m, C=jnp.tile(jnp.array([4.0, 0.0, 0.0]), (3, 1)))
    path = tmp_path_factory.mktemp("lin") / "lin"
    save_model(path, m, {"current_limit": 10.0})
    return m, path.with_suffix(".json")


def test_linear_compensation_is_the_anti_cogging_offset_negated_plus_the_direction_force(linear_model):
    """Second formulation: the lookup table's anti-cogging offset (subtracted from the demand) is the forward/
    reverse average of the compensation (added) with the opposite sign; the per-direction ones differ by ∓C/g."""
    from pgcomm.export.compensation import from_linear_model
    from pgcomm.export.lut import build_cogging_table, drive_gain

    m, _ = linear_model
    comp = from_linear_model(m, None, None)
    cog = build_cogging_table(m, 0.002)
    y = np.asarray(cog.y)
    np.testing.assert_allclose(comp.values(y), -np.asarray(cog.values), rtol=1e-12, atol=1e-12)
    g = drive_gain(m, y)
    np.testing.assert_allclose(comp.values(y, +1) - comp.values(y, -1), -2 * 4.0 / g, rtol=1e-9)
    assert comp.force_constant == pytest.approx(sum(k**2 for k in m_k(m)) / max(m_k(m)), rel=1e-12)


def m_k(m):
    from pgcomm.export.lut import classical_parameters

    return classical_parameters(m)[0].tolist()


def test_cli_linear_model_into_sinamics_two_tables_and_moog(tmp_path, linear_model, capsys):
    m, path = linear_model
    out = tmp_path / "s"
    assert main(["export", "--format", "sinamics", "--model", str(path), "--directions", "2", "--hysteresis", "0.6",
                 "--out", str(out), "--quiet"]) == 0
    back = sinamics.read_sinamics(out / "pgcomm_sinamics.txt")
    res = json.loads((out / "results.json").read_text())["sinamics"]
    assert res["tables"] == 2 and res["unit"] == "N" and back["p5256"] == pytest.approx(0.6)
    # the two direction tables differ by the direction force through the drive's gain (about 2 x 4 N)
    d = back["p5260"] - back["p5261"]
    assert np.all(d < 0) and np.median(-d) == pytest.approx(8.0, rel=0.3)
    # every entry within the force the drive's commutation makes at 10 A
    assert np.max(np.abs(back["p5260"])) <= res["limit"] * (1 + 1e-6)
    out = tmp_path / "m"
    assert main(["export", "--format", "moog", "--model", str(path), "--force-constant", "150",
                 "--out", str(out), "--quiet"]) == 0
    mo = moog.read_moog(out / "pgcomm_moog.txt")
    assert mo["start"] == pytest.approx(m.training_range[0]) and mo["values"].size == 4000
    assert "A = N / 150 N/A (--force-constant)" in (out / "pgcomm_moog.txt").read_text()


# ------------------------------------------------------------------ the twins apply each table as its drive does


def _twin_added(law, th, u=0.0, d=1.0, w=0.0):
    """The rotary twin's q current for demand ``u`` at angles ``th`` (its step, in NumPy): the law's maps, the table
    of direction state ``d`` and the fade-out at speed ``w`` (rad/s)."""
    from pgcomm.export.drive_common import periodic_linear

    m = law.model
    g = 1.0 + m.ripple(th)
    iq = (u - m.cogging(th)) / g
    if law.table is not None:
        t = law.table_reverse if (d < 0 and law.table_reverse is not None) else law.table
        f = 1.0 if law.fade is None else np.clip((law.fade[1] - abs(w)) / (law.fade[1] - law.fade[0]), 0, 1)
        iq = iq + f * periodic_linear(t, np.mod(th, 2 * np.pi) / (2 * np.pi) * t.size)
    return iq


def test_rotary_twin_laws_apply_each_table_as_its_drive():
    from pgcomm.export.drive_twin import RPM, rotary_law

    _, comp = rotary(orders=(14, 28, 3), amps=(0.2, 0.05, 0.03), drag=0.05, ripple=(42, 0.02), p=7, limit=1.0)
    th = np.random.default_rng(1).uniform(-20, 20, 3000)
    s2 = sinamics.build_sinamics(comp, 1.0, 2, hysteresis=30.0)
    mg = moog.build_moog(comp, 250, fade_out=(100.0, 300.0))
    cases = [
        (build_moteus(comp), lambda x: moteus_apply(build_moteus(comp), x), {}),
        (s2, lambda x: sinamics.sinamics_apply(s2, x, -1), {"d": -1.0}),
        (akd.build_akd(comp), lambda x: akd.akd_apply(akd.build_akd(comp), x), {}),
        (mg, lambda x: moog.moog_apply(mg, x, 200.0), {"w": 200.0 * RPM}),
        (beckhoff.build_beckhoff(comp, 1.0), lambda x: beckhoff.beckhoff_apply(beckhoff.build_beckhoff(comp, 1.0), x), {}),
        (summit.build_summit(comp, 96), lambda x: summit.summit_apply(summit.build_summit(comp, 96), x), {}),
    ]
    for tab, apply, kw in cases:
        law = rotary_law(tab, pole_pairs=7)
        np.testing.assert_allclose(_twin_added(law, th, **kw), apply(th), atol=1e-9, err_msg=type(tab).__name__)
    assert rotary_law(s2, pole_pairs=7).hysteresis == pytest.approx(30.0 * RPM)
    io = ioni.build_ioni(comp)
    law = rotary_law(io, pole_pairs=7)
    u = 1.3
    # the drive adds TRA1 sin after scaling; the twin's law divides the sinusoid by its gain too: a product of the
    # two amplitudes
    bound = io.cogging.amplitude * io.ripple.amplitude * 1.05 + 1e-9
    np.testing.assert_allclose(_twin_added(law, th, u), ioni.ioni_apply(io, th, u), atol=bound)
    om = build_odrive(comp, 1.0)
    law = rotary_law(om, pole_pairs=7)
    x = 2 * np.pi * (np.arange(3600) + 0.5) / 3600  # bin centres: away from the eighth-bin ramps
    np.testing.assert_allclose(_twin_added(law, x), odrive_apply(om, x), atol=1e-12)


def test_linear_drive_laws_read_the_tables_as_the_drives():
    import jax.numpy as jnp

    from pgcomm.commutation import ClassicalLaw
    from pgcomm.export.drive_twin import M_PER_MIN, linear_law

    base = ClassicalLaw(jnp.array([60.0]), jnp.array([0.0]), jnp.asarray(0.0), jnp.array([0.0]), 0.03)
    comp = linear(lambda y: 40.0 * np.sin(2 * math.pi * y / 0.03) + 25 * y, directional=True)
    y = np.random.default_rng(2).uniform(-0.3, 0.3, 4000)
    s2 = sinamics.build_sinamics(comp, directions=2, hysteresis=6.0)
    law = linear_law(s2, base)
    for d in (1.0, -1.0):
        np.testing.assert_allclose(np.asarray(law.offset(jnp.asarray(y), 0.0, d)), sinamics.sinamics_apply(s2, y, d),
                                   atol=1e-9)
    assert float(law.direction_state(1.0, -0.04)) == 1.0 and float(law.direction_state(1.0, -0.06)) == -1.0
    assert float(law.band) == pytest.approx(6.0 * M_PER_MIN)
    for tab, apply in ((akd.build_akd(comp), akd.akd_apply), (moog.build_moog(comp), moog.moog_apply)):
        law = linear_law(tab, base, newton_per_unit=comp.force_constant)
        np.testing.assert_allclose(np.asarray(law.offset(jnp.asarray(y), 0.0, 1.0)), apply(tab, y) * comp.force_constant,
                                   atol=1e-9, err_msg=type(tab).__name__)
    b = beckhoff.build_beckhoff(comp)
    np.testing.assert_allclose(np.asarray(linear_law(b, base).offset(jnp.asarray(y))), beckhoff.beckhoff_apply(b, y),
                               atol=1e-9)


def test_rotary_twin_switches_tables_with_hysteresis_and_fades_with_speed():
    """A constant +0.5 A forward table and −0.5 A reverse table: at a constant forward speed the drive adds the
    forward one; above the fade-out's end nothing."""
    from pgcomm.rotary.model import RotaryModel
    from pgcomm.rotary.twin import LawParams, Reference, default_gains, simulate
    from pgcomm.rotary.zoo import draw_rotary

    truth = draw_rotary(0, 0)
    n = 400
    w = 20.0
    ref = Reference(w * truth.motor.sample_time * np.arange(n), np.full(n, w), np.zeros(n), "speed")
    gains = default_gains(truth.inertia / truth.k0)
    zero = RotaryModel.zero(truth.motor.pole_pairs)
    fwd, rev = np.full(64, 0.5), np.full(64, -0.5)
    base = simulate(truth, ref, LawParams(zero), gains, seed=3)
    sw = simulate(truth, ref, LawParams(zero, fwd, table_reverse=rev, hysteresis=2.0), gains, seed=3)
    faded = simulate(truth, ref, LawParams(zero, fwd, table_reverse=rev, fade=(1.0, 5.0)), gains, seed=3)
    late = slice(n // 2, n)
    # the loop takes the table's current out of its own demand: the demand falls by what the table adds
    assert np.mean(base["demand"][late] - sw["demand"][late]) == pytest.approx(0.5, rel=0.05)
    assert np.mean(base["demand"][late] - faded["demand"][late]) == pytest.approx(0.0, abs=0.025)


def test_linear_closed_loop_carries_the_direction_table():
    """On the linear twin, a +5 N forward and −5 N reverse table: the loop's demand falls by 5 N while moving
    forward and rises by 5 N while moving back, against classical commutation on the same reference."""
    import jax.numpy as jnp

    from pgcomm import experiment
    from pgcomm.commutation import ClassicalLaw
    from pgcomm.export.drive_twin import DriveTableLaw
    from pgcomm.setup import build_setup
    from pgcomm.settings import ExperimentConfig

    setup = build_setup(ExperimentConfig())
    ref = experiment.single_velocity_reference(setup, 0.05)
    base = ClassicalLaw.from_motor(setup.motor)
    f = jnp.asarray
    law = DriveTableLaw(base, f(np.full(16, 5.0)), f(np.full(16, -5.0)), f(0.0), f(0.01), f(0.002), f(0.0), f(0.0))
    zero = DriveTableLaw(base, f(np.zeros(16)), f(np.zeros(16)), f(0.0), f(0.01), f(0.002), f(0.0), f(0.0))
    from pgcomm.control import Feedforward

    # one law type: one compiled loop for both runs (zero tables = classical commutation)
    c, t = experiment.run_laws(setup, [zero, law], ref, [Feedforward(), Feedforward()], seeds=[1, 1])
    v = np.asarray(ref.v)
    diff = t.f_star[:, 0] - c.f_star[:, 0]
    fwd, rev = v > 0.5 * v.max(), v < 0.5 * v.min()
    assert np.mean(diff[fwd]) == pytest.approx(-5.0, abs=0.5) and np.mean(diff[rev]) == pytest.approx(5.0, abs=0.5)


#: Each drive's reader on a file with a bad line 3 (a comment and a blank line before it count): the message names
#: the file, the line and what was wrong.
READER_CASES = [
    (akd.read_akd, "COGCOMP.CORRECTIONVALUE 0 abc", r"t\.txt line 3: 'abc' is not a number"),
    (akd.read_akd, "COGCOMP.RANGELOW 1e999", r"t\.txt line 3: 1e999 is not finite"),
    (beckhoff.read_beckhoff, "0x32CB:02 = x", r"t\.txt line 3: '0x32CB:02 = x' is not 'index:subindex = value'"),
    (beckhoff.read_beckhoff, "32CB:02 = 1", r"t\.txt line 3: '32CB:02 = 1' is not 'index:subindex = value'"),
    (ioni.read_ioni, "TRA1 = one A", r"t\.txt line 3: 'TRA1 = one A' is not a TRF/TRA setting of pgcomm"),
    (moog.read_moog, "P 380[0] = nan", r"t\.txt line 3: nan is not finite"),
    (moog.read_moog, "P380 = 1", r"t\.txt line 3: 'P380 = 1' is not 'P id\[index\] = value'"),
    (read_moteus, "conf set motor.cogging_dq_comp.0 1.x", r"t\.txt line 3: '1\.x' is not a number"),
    (sinamics.read_sinamics, "p5260[0] = -inf", r"t\.txt line 3: -inf is not finite"),
    (sinamics.read_sinamics, "p5260[0] := 1", r"t\.txt line 3: 'p5260\[0\] := 1' is not 'pNNNN\[i\] = value'"),
    (summit.read_summit, "0x2308 = 1,5", r"t\.txt line 3: '1,5' is not a number"),
    (summit.read_summit, "0x2309 = 1", r"t\.txt line 3: '0x2309 = 1' is not '0x230N = value'"),
]


@pytest.mark.parametrize("reader, line, match", READER_CASES,
                         ids=[f"{r.__module__.rsplit('.', 1)[-1]}: {line}" for r, line, _ in READER_CASES])
def test_every_drive_reader_names_the_file_and_line_of_a_bad_entry(tmp_path, reader, line, match):
    path = tmp_path / "t.txt"
    path.write_text(f"# a drive's file: comments and blank lines are skipped but counted\n\n{line}  # the bad one\n")
    with pytest.raises(DataError, match=match):
        reader(path)
