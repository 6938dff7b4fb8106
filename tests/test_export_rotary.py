"""Rotary drive exports (moteus, ODrive 0.5.x, C lookup by angle) read back against the input table.

Bounds are derived from the table: the int8 step ``scale/2`` (moteus), the zero-order hold over a
bin of ``2π/3600`` rad times the table's largest slope (ODrive), float32 rounding (single C).
The table is a band-limited Fourier series (as a model on the circle gives) with amplitude A0.
"""

from __future__ import annotations

import json
import math
import subprocess

import numpy as np
import pytest

from pgcomm.cli import main
from pgcomm.errors import DataError
from pgcomm.export.angle_lut import angle_lut_header, angle_lut_values, build_angle_lut
from pgcomm.export.angle_table import (
    bin_means,
    make_table,
    periodic_interpolant,
    read_angle_table,
    resample_periodic,
    write_angle_table,
)
from pgcomm.export.moteus import ENTRIES as M_ENTRIES
from pgcomm.export.moteus import build_moteus, moteus_current, read_moteus, write_moteus
from pgcomm.export.odrive import ENTRIES as O_ENTRIES
from pgcomm.export.odrive import build_odrive, odrive_current, read_odrive, write_odrive

A0 = 0.4  # A: the table's scale
ORDERS = ((1, 0.05, 0.3), (14, 0.25, 1.1), (28, 0.1, -0.4), (42, 0.06, 2.0))  # (order, amplitude/A0... in A, phase)


def f(theta):
    """The continuous compensation current (A) the tables sample."""
    th = np.asarray(theta, dtype=float)
    return 0.02 + sum(a * np.cos(h * th + p) for h, a, p in ORDERS)


def f_slope_max():
    """An upper bound of |f'| (A/rad)."""
    return sum(h * a for h, a, _ in ORDERS)


def table(n=256, source="model"):
    return make_table(f(2 * np.pi * np.arange(n) / n), source, ["synthetic Fourier table"])


# --------------------------------------------------------------------------- the table


def test_table_file_round_trip(tmp_path):
    t = table(300)
    write_angle_table(tmp_path / "t.csv", t)
    back = read_angle_table(tmp_path / "t.csv")
    np.testing.assert_array_equal(back.iq, t.iq)
    assert back.n == 300 and "synthetic Fourier table" in back.comments
    assert back.current_limit is None


def test_current_limit_travels_with_the_table(tmp_path, capsys):
    """A table made with the motor's current limit records it; c-angle then uses it without --current-limit,
    --current-limit still overrides, and a malformed limit line is refused with one line naming the file."""
    t = make_table(f(2 * np.pi * np.arange(128) / 128), "model", ["synthetic"], current_limit=17.5)
    path = write_angle_table(tmp_path / "t.csv", t)
    assert read_angle_table(path).current_limit == 17.5
    assert main(["export", "--format", "c-angle", "--table", str(path), "--name", "cog", "--out", str(tmp_path / "c"),
                 "--quiet"]) == 0
    res = json.loads((tmp_path / "c" / "results.json").read_text())
    assert res["current_limit"] == 17.5 and "current_limit" in res["current_limit_source"]
    assert "17.5 A on the q-current command" in (tmp_path / "c" / "cog.h").read_text()
    assert main(["export", "--format", "c-angle", "--table", str(path), "--current-limit", "3", "--name", "cog",
                 "--out", str(tmp_path / "c3"), "--quiet"]) == 0
    assert json.loads((tmp_path / "c3" / "results.json").read_text())["current_limit"] == 3.0
    bad = tmp_path / "bad.csv"
    bad.write_text(path.read_text().replace("# current_limit: 17.5 A", "# current_limit: lots"))
    capsys.readouterr()
    assert main(["export", "--format", "c-angle", "--table", str(bad), "--out", str(tmp_path / "cb")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "bad.csv line" in err and "current limit" in err
    assert not (tmp_path / "cb").exists()
    with pytest.raises(DataError, match="positive current"):
        make_table(np.zeros(16), "t", current_limit=-1.0)


@pytest.mark.parametrize("n, m", [(256, 1024), (256, 3600), (255, 97), (1024, 1024)])
def test_periodic_resampling_is_exact_for_a_band_limited_table(n, m):
    g = resample_periodic(table(n).iq, m)
    np.testing.assert_allclose(g, f(2 * np.pi * np.arange(m) / m), rtol=0, atol=1e-13 * A0 * 10)


def _bad_table(tmp_path, angles, iq=None, extra=""):
    iq = np.zeros(len(angles)) if iq is None else iq
    p = tmp_path / "bad.csv"
    p.write_text("# comment\nangle,iq\n" + extra + "".join(f"{float(a)!r},{float(v)!r}\n" for a, v in zip(angles, iq)))
    return p


def test_bad_tables_are_refused_with_one_line(tmp_path):
    n = 64
    ang = 2 * np.pi * np.arange(n) / n
    cases = [
        (ang + 0.01, "line 3: the first angle is 0.01 rad; a table starts at encoder angle 0"),
        (np.where(np.arange(n) == 10, ang + 0.02, ang), r"line 13: angle .* expected 2\*pi\*10/64 .* not uniformly spaced"),
        (2 * np.pi * np.arange(n) / (n + 1), r"not one revolution \(spacing .* needs"),
        (np.append(ang, 2 * np.pi), "repeats angle 0 one revolution later"),
        (np.degrees(ang), "looks like degrees"),
        (ang[:5], "5 rows; a table over one revolution needs 8"),
        (ang[[0, 1, 2, 3, 4, 6, 5, *range(7, n)]], r"line 9: angle 0.49\d+ rad does not follow 0.58"),
    ]
    for angles, match in cases:
        with pytest.raises(DataError, match=match) as e:
            read_angle_table(_bad_table(tmp_path, angles))
        assert "\n" not in str(e.value) and "bad.csv" in str(e.value)
    iq = np.zeros(n)
    iq[7] = np.nan
    with pytest.raises(DataError, match=r"bad.csv line 10 column 'iq': nan is not a finite number"):
        read_angle_table(_bad_table(tmp_path, ang, iq))
    (tmp_path / "cols.csv").write_text("theta,iq\n0,1\n")
    with pytest.raises(DataError, match=r"cols.csv line 1: no column 'angle' \(rad\)"):
        read_angle_table(tmp_path / "cols.csv")


# --------------------------------------------------------------------------- moteus


def test_moteus_lines_parse_back_within_the_int8_bound(tmp_path):
    t = table(1024)  # the drive's own size: no resampling, the entries are the table
    mt = build_moteus(t)
    write_moteus(mt, tmp_path / "m.cfg")
    lines = (tmp_path / "m.cfg").read_text().splitlines()
    assert lines[0].startswith("conf set motor.cogging_dq_scale ") and len(lines) == 1 + M_ENTRIES
    assert all(l.startswith("conf set motor.cogging_dq_comp.") for l in lines[1:])
    scale, q = read_moteus(tmp_path / "m.cfg")
    # the printed scale is the float32 the firmware holds, and the one the entries were quantised against
    assert np.float32(scale) == np.float32(mt.scale) and scale == pytest.approx(np.max(np.abs(t.iq)) / 127, rel=1e-7)
    assert np.max(np.abs(q)) == 127 and q.dtype == np.int8
    # each entry within half a step of the table, the sign that of the current to add
    np.testing.assert_array_less(np.abs(q * scale - t.iq), 0.5 * scale * (1 + 1e-6))
    big = np.abs(t.iq) > scale
    assert np.all(np.sign(q[big]) == np.sign(t.iq[big]))
    # between entries the drive interpolates linearly: within the int8 bound of the unquantised interpolation
    pts = 16 * M_ENTRIES
    drive = moteus_current(q, scale, pts)
    exact = moteus_current(t.iq, 1.0, pts)
    assert np.max(np.abs(drive - exact)) <= 0.5 * scale * (1 + 1e-6)
    assert mt.quantisation <= 0.5 * scale * (1 + 1e-6)
    assert mt.total.max <= mt.interpolation.max + 0.5 * scale * (1 + 1e-6)
    # the interpolation error of a band-limited table: below (h_max*2pi/1024)^2/8 of each order's amplitude
    assert mt.interpolation.max <= sum(a * (h * 2 * np.pi / M_ENTRIES) ** 2 / 8 for h, a, _ in ORDERS) * 1.01


def test_moteus_resamples_other_sizes_and_reads_a_dump(tmp_path):
    mt = build_moteus(table(300))
    np.testing.assert_allclose(mt.resampled, f(2 * np.pi * np.arange(M_ENTRIES) / M_ENTRIES), atol=1e-13)
    # moteus_tool --dump-config prints "name value" lines among others
    dump = ["servo.max_current_A 30"] + [f"motor.cogging_dq_comp.{i} {v}" for i, v in enumerate(mt.entries)]
    (tmp_path / "dump.cfg").write_text("\n".join(dump + [f"motor.cogging_dq_scale {mt.scale!r}"]) + "\n")
    scale, q = read_moteus(tmp_path / "dump.cfg")
    np.testing.assert_array_equal(q, mt.entries)
    (tmp_path / "short.cfg").write_text("\n".join(dump[:-1] + [f"motor.cogging_dq_scale {mt.scale!r}"]))
    with pytest.raises(DataError, match=r"motor.cogging_dq_comp.1023 missing \(1023 of 1024"):
        read_moteus(tmp_path / "short.cfg")


def test_moteus_limit_and_zero_table():
    mt = build_moteus(table(256), current_limit=0.2)
    assert mt.clipped > 0 and np.max(np.abs(mt.entries * mt.scale)) <= 0.2 * (1 + 1e-6)
    z = build_moteus(make_table(np.zeros(64)))
    assert z.scale == 0.0 and not np.any(z.entries)  # scale 0 is moteus' "off"


# --------------------------------------------------------------------------- ODrive


def test_odrive_map_parses_back_and_holds_within_one_bin(tmp_path):
    kt = 0.083
    om = build_odrive(table(256), kt)
    write_odrive(om, tmp_path / "o.json", ["test"])
    doc = json.loads((tmp_path / "o.json").read_text())
    assert doc["loadable_by_stock_firmware"] is False and len(doc["cogging_map"]) == O_ENTRIES
    m, k = read_odrive(tmp_path / "o.json")
    assert k == kt
    np.testing.assert_array_equal(m, om.torque)
    # entries are the bin means (N m), to float32 rounding
    np.testing.assert_allclose(m / kt, bin_means(table(256).iq, O_ENTRIES), rtol=0, atol=2 * 2**-24 * A0 * 2)
    # zero-order hold: within the slope bound over one bin (two bins for negative positions)
    w = 2 * np.pi / O_ENTRIES
    assert om.positive.max <= f_slope_max() * w
    assert om.negative.max <= 2 * f_slope_max() * w
    assert om.negative.max > om.positive.max  # the firmware's truncation toward zero costs a bin
    pts = 8 * O_ENTRIES
    held = odrive_current(m / kt, pts)
    np.testing.assert_allclose(held, periodic_interpolant(table(256).iq, pts), atol=f_slope_max() * w)


def test_odrive_refuses_a_bad_torque_constant():
    with pytest.raises(ValueError, match="torque constant"):
        build_odrive(table(64), 0.0)


# --------------------------------------------------------------------------- C lookup


@pytest.mark.parametrize("precision", ["double", "single"])
def test_c_lookup_compiles_and_matches(tmp_path, cc, precision):
    lut = build_angle_lut(table(256), 512, precision, current_limit=0.5)
    (tmp_path / "lut.h").write_text(angle_lut_header(lut, "lut", "test"))
    T = "double" if precision == "double" else "float"
    (tmp_path / "main.c").write_text(rf"""
#include <stdio.h>
#include <stdlib.h>
#include "lut.h"
int main(void)
{{
    char a[64], b[64];
    while (scanf("%63s %63s", a, b) == 2) {{
        {T} c, q;
        int r1 = lut_comp(({T})strtod(a, NULL), &c);
        int r2 = lut_iq(({T})strtod(a, NULL), ({T})strtod(b, NULL), &q);
        printf("%d %.17g %d %.17g\n", r1, (double)c, r2, (double)q);
    }}
    return 0;
}}
""")
    exe = tmp_path / "main"
    proc = subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic", "-o", str(exe),
                           str(tmp_path / "main.c"), "-lm"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    rng = np.random.default_rng(5)
    th = np.concatenate([rng.uniform(-20, 20, 3000), 2 * np.pi * np.arange(512) / 512, [np.nan, np.inf, -np.inf, 0.0]])
    iq = np.concatenate([rng.uniform(-0.3, 0.3, 3000), np.zeros(512), [0.0, 0.0, 0.0, np.nan]])
    iq[:20] = 3.0  # beyond the limit
    if precision == "single":
        th, iq = th.astype(np.float32).astype(float), iq.astype(np.float32).astype(float)
    text = "\n".join(f"{float(a)!r} {float(b)!r}" for a, b in zip(th, iq))
    out = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True).stdout
    res = np.array([[float(v) for v in line.split()] for line in out.splitlines()])
    c_code, c_val = angle_lut_values(lut, th)
    q_code, q_val = angle_lut_values(lut, th, iq)
    np.testing.assert_array_equal(res[:, 0], c_code)
    np.testing.assert_array_equal(res[:, 2], q_code)
    assert list(res[-4:, 0]) == [2, 2, 2, 0] and list(res[-4:, 2]) == [2, 2, 2, 2]
    assert np.all(res[-4:-1, 1] == 0) and np.all(res[-4:, 3] == 0)  # zero current for non-finite input
    assert np.all(res[:20, 2] == 1) and np.all(res[:20, 3] == np.float32(0.5))
    if precision == "double":
        tol = 1e-12 * A0
    else:
        # float32: the angle coordinate u = theta*N/(2 pi) carries |u|*2^-23; times the largest entry step
        step = np.max(np.abs(np.diff(np.append(lut.values, lut.values[0]))))
        tol = (20 * 512 / (2 * np.pi) * 2**-22 + 2**-22 * 512) * step + 4 * 2**-24 * (A0 + 0.5)
    np.testing.assert_allclose(res[:, 1], c_val, rtol=0, atol=tol)
    np.testing.assert_allclose(res[:, 3], q_val, rtol=0, atol=tol)
    # at its own entries the lookup is the table, and the table the function (band-limited: exact)
    np.testing.assert_allclose(res[3000:3512, 1], f(2 * np.pi * np.arange(512) / 512), atol=tol + 1e-12)


# --------------------------------------------------------------------------- the command line


@pytest.fixture
def table_csv(tmp_path):
    return write_angle_table(tmp_path / "table.csv", table(256))


def test_cli_exports(tmp_path, table_csv, capsys):
    assert main(["export", "--format", "moteus", "--table", str(table_csv), "--current-limit", "2", "--out",
                 str(tmp_path / "m")]) == 0
    scale, q = read_moteus(tmp_path / "m" / "pgcomm_moteus.cfg")
    res = json.loads((tmp_path / "m" / "results.json").read_text())
    assert res["moteus"]["scale_A_per_lsb"] == pytest.approx(scale, rel=1e-7)
    assert res["moteus"]["quantisation_max_A"] <= 0.5 * scale * (1 + 1e-6)
    assert main(["export", "--format", "odrive", "--table", str(table_csv), "--torque-constant", "0.05",
                 "--current-limit", "none", "--out", str(tmp_path / "o"), "--quiet"]) == 0
    m, k = read_odrive(tmp_path / "o" / "pgcomm_odrive.json")
    assert k == 0.05 and m.shape == (3600,)
    assert main(["export", "--format", "c-angle", "--table", str(table_csv), "--current-limit", "2",
                 "--entries", "128", "--name", "cog", "--out", str(tmp_path / "c"), "--quiet"]) == 0
    h = (tmp_path / "c" / "cog.h").read_text()
    assert "#define COG_N 128" in h and "2 A on the q-current command" in h and "table.csv" in h
    out = capsys.readouterr().out
    assert "int8 quantisation max" in out and "assumes:" in out


@pytest.mark.parametrize("args, match", [
    (["--format", "moteus"], "give --table TABLE.csv"),
    (["--format", "moteus", "--table", "{t}", "--model", "m.json"], "give --table TABLE.csv or --model MODEL.json, not both"),
    (["--format", "c", "--table", "{t}"], "give --model MODEL.json"),
    (["--format", "odrive", "--table", "{t}"], "needs --torque-constant"),
    (["--format", "odrive", "--table", "{t}", "--torque-constant", "-1"], "--torque-constant -1"),
    (["--format", "c-angle", "--table", "{t}"], "records no current limit"),
    (["--format", "moteus", "--table", "{t}", "--entries", "64"], "--entries is for --format c-angle"),
    (["--format", "moteus", "--table", "{bad}"], r"bad.csv line 13: angle .* not uniformly spaced"),
    (["--format", "moteus", "--table", "{half}"], "not one revolution"),
])
def test_cli_bad_input_one_line_no_output(tmp_path, table_csv, capsys, args, match):
    n = 64
    ang = 2 * np.pi * np.arange(n) / n
    bad = _bad_table(tmp_path, np.where(np.arange(n) == 10, ang + 0.02, ang))
    half = tmp_path / "half.csv"
    half.write_text("angle,iq\n" + "".join(f"{float(a)!r},0\n" for a in np.pi * np.arange(n) / n))
    argv = ["export"] + [a.format(t=table_csv, bad=bad, half=half) for a in args] + ["--out", str(tmp_path / "out")]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("pgcomm: error:"), err
    assert __import__("re").search(match, err), err
    assert "Traceback" not in err
    assert not (tmp_path / "out").exists()
