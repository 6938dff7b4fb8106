"""The rotary law as C99 (:mod:`pgcomm.export.rotary_law`) against pgcomm's law and its own Python mirror.

The model is a synthetic band-limited one (cogging, drag and ripple with known Fourier coefficients), so the
linear interpolation's error has a closed-form bound: ``(2π/N)²/8 · max|f''|`` with ``max|f''| ≤ Σ h² |A_h|``
per map, propagated through ``(u − c + d s)/g``. The compiled header must agree with the mirror to rounding
(1e-12 of the current scale in double; in single, float32's steps of the angle coordinate and the entries),
return the same codes, and give finite currents within the limit for every input, NaN, ±inf and ±1e308
included, on a model whose ripple would divide by zero without the clamp.
"""

from __future__ import annotations

import json
import math
import subprocess

import numpy as np
import pytest

from pgcomm.cli import main
from pgcomm.export.rotary_law import build_rotary_law, rotary_law_header, rotary_law_values
from pgcomm.rotary.law import MIN_GAIN, iq_command
from pgcomm.rotary.model import Fourier, RotaryModel

LIMIT = 4.0  # A


def model(ripple_scale=1.0):
    """A 12N14P-like model: cogging at 84, 168 and the low orders with a constant torque (order 0: a load or a
    current offset, as identify returns it) (A), drag with Coulomb (A), ripple (-)."""
    cog = Fourier(np.array([0, 1, 12, 84, 168]),
                  np.array([[0.3, 0.0], [0.02, -0.01], [0.05, 0.03], [0.4, -0.2], [0.06, 0.05]]))
    drag = Fourier(np.array([0, 1, 14]), np.array([[0.15, 0.0], [0.03, 0.02], [0.01, -0.02]]))
    rip = Fourier(np.array([1, 14, 42]), ripple_scale * np.array([[0.01, 0.005], [0.02, -0.01], [0.008, 0.004]]))
    return RotaryModel(7, cog, rip, drag, info={"current_limit": LIMIT})


def curvature(f: Fourier) -> float:
    """An upper bound of |f''| over the circle."""
    return float(np.sum(f.orders.astype(float) ** 2 * np.hypot(f.coef[:, 0], f.coef[:, 1])))


def law_bound(m: RotaryModel, n: int, u: float) -> float:
    """Upper bound of |C law − pgcomm's law| (A) at demand |u| from the maps' interpolation bounds."""
    h2 = (2 * math.pi / n) ** 2 / 8
    ec, ed, eg = (h2 * curvature(f) for f in (m.cogging, m.direction, m.ripple))
    num = abs(u) + np.max(np.abs(m.cogging.coef).sum()) + np.abs(m.direction.coef).sum()  # |u − c + d s| bound
    return (ec + ed) / MIN_GAIN + num * eg / MIN_GAIN**2


def test_the_tables_give_the_law_within_the_interpolation_bound():
    m = model()
    for n in (256, 1024):
        tabs = build_rotary_law(m, n, current_limit=LIMIT)
        assert tabs.errors["law"]["max"] <= law_bound(m, n, 0.5 * LIMIT)
        th = np.random.default_rng(1).uniform(-50, 50, 20000)
        u = np.random.default_rng(2).uniform(-0.5 * LIMIT, 0.5 * LIMIT, th.size)
        s = np.sign(np.random.default_rng(3).uniform(-1, 1, th.size))
        _, c = rotary_law_values(tabs, th, u, s)
        assert np.max(np.abs(c - iq_command(m, u, th, s, LIMIT))) <= law_bound(m, n, 0.5 * LIMIT)
    # the bound is not loose by orders of magnitude: four times the entries, about a sixteenth of the error
    e256 = build_rotary_law(m, 256, current_limit=LIMIT).errors["law"]["max"]
    e1024 = build_rotary_law(m, 1024, current_limit=LIMIT).errors["law"]["max"]
    assert 8 <= e256 / e1024 <= 32


def _compile(tmp_path, cc, tabs, name="law"):
    (tmp_path / f"{name}.h").write_text(rotary_law_header(tabs, name, "test"))
    T = "double" if tabs.precision == "double" else "float"
    (tmp_path / "main.c").write_text(rf"""
#include <stdio.h>
#include <stdlib.h>
#include "{name}.h"
int main(void)
{{
    char a[64], b[64], c[64];
    while (scanf("%63s %63s %63s", a, b, c) == 3) {{
        {T} q;
        int r = {name}_iq(({T})strtod(a, NULL), ({T})strtod(b, NULL), ({T})strtod(c, NULL), &q);
        printf("%d %.17g\n", r, (double)q);
    }}
    return 0;
}}
""")
    exe = tmp_path / "main"
    proc = subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic", "-o", str(exe),
                           str(tmp_path / "main.c"), "-lm"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return exe


def _run(exe, th, u, s):
    text = "\n".join(f"{float(a)!r} {float(b)!r} {float(c)!r}" for a, b, c in zip(th, u, s))
    out = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True).stdout
    return np.array([[float(v) for v in line.split()] for line in out.splitlines()])


def _inputs(seed, n=4000):
    rng = np.random.default_rng(seed)
    th = rng.uniform(-30, 30, n)
    u = rng.uniform(-1.5 * LIMIT, 1.5 * LIMIT, n)
    s = rng.choice([-2.0, -1.0, 0.0, 1.0, 3.5], n)
    bad = [np.nan, np.inf, -np.inf, 1e308, -1e308]
    extra_th = np.array(bad + [0.0] * 5 + [1e300, 0.3])
    extra_u = np.array([0.0] * 5 + bad + [0.1, 1e300])
    extra_s = np.zeros(12)
    extra_s[[0, 1]] = [np.nan, np.inf]
    return np.concatenate([th, extra_th]), np.concatenate([u, extra_u]), np.concatenate([s, extra_s])


@pytest.mark.parametrize("precision", ["double", "single"])
def test_compiled_law_matches_its_mirror_and_is_safe(tmp_path, cc, precision):
    tabs = build_rotary_law(model(), 512, precision, current_limit=LIMIT)
    exe = _compile(tmp_path, cc, tabs)
    th, u, s = _inputs(7)
    if precision == "single":
        with np.errstate(over="ignore"):  # 1e308 is inf in float, as the C's cast makes it
            th, u, s = (x.astype(np.float32).astype(float) for x in (th, u, s))
    res = _run(exe, th, u, s)
    code, val = rotary_law_values(tabs, th, u, s)
    finite = np.all(np.isfinite(np.stack([th, u, s])), axis=0) & (np.abs(th) < 1e6) & (np.abs(u) < 1e6)
    np.testing.assert_array_equal(res[finite, 0], code[finite])
    assert np.all(np.isfinite(res[:, 1])) and np.all(np.abs(res[:, 1]) <= LIMIT)
    assert np.all(res[~np.isfinite(th) | ~np.isfinite(u) | ~np.isfinite(s), 1] == 0)
    assert np.all(res[~np.isfinite(th) | ~np.isfinite(u) | ~np.isfinite(s), 0] == 2)
    if precision == "double":
        tol = 1e-12 * LIMIT
    else:
        # float32: the angle coordinate x = theta*N/(2 pi) carries |x|*2^-23, times the largest entry step
        # per unit of x, through the division by g >= MIN_GAIN; the entries and the arithmetic 2^-23 relative
        steps = [np.max(np.abs(np.diff(np.append(v, v[0])))) for v in (tabs.cogging, tabs.direction, tabs.gain)]
        x_err = 30 * 512 / (2 * np.pi) * 2**-22 + 512 * 2**-22
        tol = x_err * (steps[0] + steps[1] + steps[2] * 1.5 * LIMIT / MIN_GAIN) / MIN_GAIN + 16 * 2**-24 * 3 * LIMIT
    np.testing.assert_allclose(res[finite, 1], val[finite], rtol=0, atol=tol)


def test_a_wild_ripple_is_clamped_not_divided_by_zero(tmp_path, cc):
    m = model(ripple_scale=60.0)  # 1 + r crosses zero: the law divides by MIN_GAIN there
    th = 2 * np.pi * np.arange(4096) / 4096
    assert np.min(m.gain(th)) < 0
    tabs = build_rotary_law(m, 1024, current_limit=LIMIT)
    assert np.min(tabs.gain) >= MIN_GAIN
    exe = _compile(tmp_path, cc, tabs)
    t, u, s = _inputs(11)
    res = _run(exe, t, u, s)
    assert np.all(np.isfinite(res[:, 1])) and np.all(np.abs(res[:, 1]) <= LIMIT)
    _, mirror = rotary_law_values(tabs, th, 0.5, 1.0)
    assert np.all(np.isfinite(mirror))


def test_cli_exports_an_identified_model_and_refuses_bad_input(tmp_path, capsys):
    path = tmp_path / "model.json"
    path.write_text(json.dumps(model().to_dict()))
    assert main(["export", "--format", "c-rotary", "--model", str(path), "--out", str(tmp_path / "c")]) == 0
    h = (tmp_path / "c" / "pgcomm_rotary_law.h").read_text()
    res = json.loads((tmp_path / "c" / "results.json").read_text())
    assert res["c_rotary"]["entries"] == 4096  # 16 per period of order 168, a power of two
    assert "#define PGCOMM_ROTARY_LAW_N 4096" in h and "4 A on |iq| (from the model file)" in h
    assert res["c_rotary"]["errors"]["law"]["max"] <= law_bound(model(), 4096, 0.5 * LIMIT)
    capsys.readouterr()
    bare = model().to_dict()
    bare["info"] = {}
    (tmp_path / "bare.json").write_text(json.dumps(bare))
    (tmp_path / "linear.json").write_text(json.dumps({"schema": "pgcomm.model", "version": 1}))
    for args, match in ((["--model", str(tmp_path / "bare.json")], "records no current limit"),
                        (["--model", str(tmp_path / "linear.json")], "not a rotary model"),
                        (["--model", str(path), "--entries", "4"], "--entries 4"),
                        ([], "give --model MODEL.json")):
        out = tmp_path / "bad"
        assert main(["export", "--format", "c-rotary", *args, "--out", str(out)]) != 0
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and match in err[0], err
        assert not out.exists()
