"""A drive's static map as data: the reader's refusals, and the index offset between power-ups found on a rolled map
(the truth: the roll) and removed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pgcomm.errors import DataError
from pgcomm.rotary.model import Fourier, RotaryModel
from pgcomm.io.static_map import is_static_map, read_static_map
from pgcomm.rotary.static_map import compare, index_offset

COUNTS = 8192


def a_map(n=512):
    th = 2 * math.pi * np.arange(n) / n
    return th, 0.9 * np.cos(7 * th + 0.4) + 0.5 * np.cos(28 * th + 1.0) + 0.3 * np.sin(14 * th) + 0.1 * np.cos(84 * th)


@pytest.mark.parametrize("shift", [0, 1, 37, 256, 400])
def test_index_offset_of_a_rolled_map_is_the_roll(shift):
    _, m = a_map()
    rng = np.random.default_rng(shift)
    other = np.roll(m, -shift) + 0.02 * rng.standard_normal(m.size) + 0.3  # another power-up: moved, noisy, offset
    found = index_offset(m, other, independent=2 * 84)
    assert found["taken"] == (shift != 0)
    assert found["shift"] == shift
    assert found["correlation"] > 0.99
    assert found["rad"] == pytest.approx(2 * math.pi * (shift if shift <= 256 else shift - 512) / 512)


def test_compare_removes_half_a_revolution(tmp_path):
    th, m = a_map()
    model = RotaryModel(7, cogging=Fourier(np.array([7, 14, 28, 84]),
                                           np.array([[0.9 * math.cos(0.4), -0.9 * math.sin(0.4)], [0.0, 0.3],
                                                     [0.5 * math.cos(1.0), -0.5 * math.sin(1.0)], [0.1, 0.0]])),
                        ripple=Fourier.zeros([]), direction=Fourier.zeros([]), viscous=0.0, inertia_ratio=1e-3)
    # the model's compensation is what holds the rotor: the map's own sign, whatever the model's convention
    sign = np.sign(np.corrcoef(model.iq_comp(th, 1.0), m)[0, 1])
    counts = np.arange(512) * 16
    p = tmp_path / "map.csv"
    np.savetxt(p, np.column_stack([counts, sign * np.roll(m, -256)]), delimiter=",", header="count,Iq_A",
               comments="", fmt="%.10g")
    assert is_static_map(p)
    found = compare(read_static_map(p, COUNTS), model, independent=168)
    assert found["index_offset"]["taken"] and abs(found["index_offset"]["rad"]) == pytest.approx(math.pi)
    assert found["correlation"] > 0.9999 and found["rms_difference_share"] < 1e-3


def write(tmp_path, rows, header="count,Iq_A"):
    p = tmp_path / "m.csv"
    p.write_text(header + "\n" + "\n".join(",".join(map(str, r)) for r in rows) + "\n")
    return p


def test_a_hole_is_refused_with_its_row(tmp_path):
    rows = [(16 * k, 0.1) for k in range(64) if k not in (20, 21)]
    with pytest.raises(DataError, match=r"m.csv row 21: a hole in the map"):
        read_static_map(write(tmp_path, rows), COUNTS)


def test_counts_need_encoder_counts_and_one_revolution(tmp_path):
    rows = [(16 * k, 0.1) for k in range(64)]
    with pytest.raises(DataError, match="encoder_counts"):
        read_static_map(write(tmp_path, rows), None)
    with pytest.raises(DataError, match="more than one revolution"):
        read_static_map(write(tmp_path, rows), 512)
    with pytest.raises(DataError, match="no position column"):
        read_static_map(write(tmp_path, rows, header="pos,Iq_A"), COUNTS)


@pytest.mark.parametrize("ratio", [0.1, 1.0, 10.0])
def test_combined_table_weighs_the_map_by_its_error(ratio):
    """A model off the truth by a known table error ``σ_m`` (RMS) and a static map of the truth with white noise of
    ``σ_s = ratio σ_m``, half a revolution away and offset: the map's error is read back within four of its sampling
    standard deviations (the noise's sample variance and its cross term with the model's error over ``n`` points),
    the map's weight is ``σ_m² / (σ_m² + σ_s²)`` within what that error allows, and the combined table is closer to the
    truth than either where both count (``ratio`` 1: ``1/√2`` of either, within the same sampling)."""
    from pgcomm.rotary.static_map import StaticMap, combine

    n = 512
    # order 3 beside the multiples of 7: a map of period 2π/7 alone would match itself at shifts 512/7 apart
    orders = np.array([3, 7, 14, 28, 84])
    coef = np.array([[0.2, 0.1], [0.9 * math.cos(0.4), -0.9 * math.sin(0.4)], [0.0, 0.3],
                     [0.5 * math.cos(1.0), -0.5 * math.sin(1.0)], [0.1, 0.0]])

    def model(c):
        return RotaryModel(7, cogging=Fourier(orders, c), ripple=Fourier.zeros([]), direction=Fourier.zeros([]),
                           viscous=0.0, inertia_ratio=1e-3)

    truth = model(coef)
    ident = model(coef + 0.02 * np.random.default_rng(1).standard_normal(coef.shape))
    ref = truth.table(n)
    sigma_m = float(np.sqrt(np.mean((ident.table(n) - ref) ** 2)))
    sigma_s = ratio * sigma_m
    noise = np.random.default_rng(2).standard_normal(n)
    noise = sigma_s * (noise - noise.mean()) / noise.std()
    th = 2 * math.pi * np.arange(n) / n
    static = StaticMap(th, np.roll(ref + noise, -256) + 0.3, 1, "map.csv")
    found = compare(static, ident, independent=2 * 84)
    assert found["index_offset"]["shift"] == 256
    both = combine(static, ident, found, sigma_m)
    ours = ident.table(n)
    np.testing.assert_allclose(both["map_aligned"], ref + noise - (ref + noise).mean() + ours.mean(), rtol=0,
                               atol=1e-12 * np.max(np.abs(ref)))
    tol_var = 4 * (sigma_s**2 * math.sqrt(2 / n) + 2 * sigma_m * sigma_s / math.sqrt(n))
    assert abs(both["static_rms_error_A"] ** 2 - sigma_s**2) <= tol_var
    w = sigma_m**2 / (sigma_m**2 + sigma_s**2)
    dw = tol_var * sigma_m**2 / (sigma_m**2 + max(sigma_s**2 - tol_var, 0.0)) ** 2  # |dw/dσ_s²| at its smallest
    assert abs(both["weight_static"] - w) <= dw
    err = float(np.sqrt(np.mean((both["iq"] - ref) ** 2)))
    best = sigma_m * sigma_s / math.sqrt(sigma_m**2 + sigma_s**2)
    assert err <= best + math.sqrt(tol_var)
    if ratio == 1.0:
        assert err < 0.8 * min(sigma_m, sigma_s)
