"""Safe laws: ModelLaw never asks for more than the current limit, never returns NaN or inf, and holds
the position at the end of the model's training range (fuzzed over ±10x the range, demands up to 10x the motor's
capacity, NaN/inf inputs); the exported C laws (PGNN and spline model, double and single precision, and the
lookup-table C) compiled with the system compiler and fuzzed alike: every current finite and within the limit on
every phase, return codes 0 inside / 1 held at the range's end / 2 non-finite input with zero currents, and the
currents those of the Python laws (skipped without a C compiler)."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import _c_harness as c_harness
from pgcomm.commutation import ModelLaw
from pgcomm.models import CoilSetModel, CombinedModel, physics_from_ideal
from pgcomm.motor import star_to_phases
from pgcomm.spline_model import SplineModel

D_M, LIMIT, K = 0.03, 10.0, 60.0


def _pgnn(seed=0):
    models = []
    for l, (z, d) in enumerate(((-0.54, -0.065), (-0.55, 0.005), (-0.55, 0.075))):
        a, b = physics_from_ideal(D_M, K, z, 0.05, d)
        m = CoilSetModel.init(jax.random.PRNGKey(seed + l), CoilSetModel.physics(a, b, D_M, 0.0, 0.1, -0.1, 0.1))
        # output layers large enough that the networks dominate far outside the range
        m = m.with_outputs(a, b, [(jnp.full((2, 3), 5.0), jnp.zeros(3))] * 2, (jnp.full((16, 3), 3.0), jnp.zeros(3)))
        models.append(m)
    return CombinedModel.from_coil_sets(models)


def _spline(rng):
    mg, mc, md = 9, 40, 12
    a, b = physics_from_ideal(D_M, K, -0.54, 0.05, 0.0)
    table = np.stack([np.stack([a, b])] * mg)[:, None] * (1 + 0.05 * rng.normal(size=(mg, 3, 1, 1, 1)))
    return SplineModel(jnp.asarray(table.transpose(0, 1, 2, 3, 4)), jnp.asarray(0.01 * rng.normal(size=(3, 4, 3, 2))),
                       jnp.asarray(rng.normal(size=(mc, 3))), jnp.asarray(rng.normal(size=(md, 3))),
                       jnp.linspace(-0.1, 0.1, mg), jnp.linspace(-0.1, 0.1, mc), jnp.linspace(-0.1, 0.1, md),
                       D_M, (-0.1,) * 3, (0.1,) * 3)


def _fuzz_inputs(rng, n=20000):
    y = rng.uniform(-1.0, 1.0, n)                                  # ±10x the 0.1 m range
    f = rng.uniform(-1, 1, (n, 3)) * np.array([10 * 3 * K * LIMIT, 100.0, 10.0])
    v = rng.normal(0, 1.0, n)
    bad = rng.random(n) < 0.05
    y[bad & (rng.random(n) < 0.3)] = np.nan
    f[bad & (rng.random(n) < 0.3), 0] = np.inf
    v[bad & (rng.random(n) < 0.3)] = -np.inf
    return y, f, v


@pytest.mark.parametrize("kind", ["pgnn", "spline"])
def test_model_law_is_safe_for_every_input(kind, rng):
    model = _pgnn() if kind == "pgnn" else _spline(rng)
    law = ModelLaw(model, current_limit=LIMIT)
    y, f, v = _fuzz_inputs(rng)
    i = np.asarray(jax.jit(law.currents)(jnp.asarray(y), jnp.asarray(f), jnp.asarray(v)))
    assert np.all(np.isfinite(i))
    phases = np.asarray(star_to_phases(jnp.asarray(i)))
    assert np.max(np.abs(phases)) <= LIMIT * (1 + 1e-12)
    bad = ~(np.isfinite(y) & np.all(np.isfinite(f), axis=1) & np.isfinite(v))
    assert np.all(i[bad] == 0.0)


def test_model_law_holds_the_range_end(rng):
    """Past the training range the law gives the currents of the range's end for the same demand."""
    law = ModelLaw(_pgnn(), current_limit=None)
    f = jnp.asarray([[300.0, 0.0, 0.0]] * 3)
    far = law.currents(jnp.asarray([0.1, 0.117, 0.5]), f)
    np.testing.assert_array_equal(np.asarray(far[1]), np.asarray(far[0]))
    np.testing.assert_array_equal(np.asarray(far[2]), np.asarray(far[0]))
    lo = law.currents(jnp.asarray([-0.1, -3.0]), f[:2])
    np.testing.assert_array_equal(np.asarray(lo[1]), np.asarray(lo[0]))


# ---------------------------------------------------------------------------------------------
# the exported C laws (PGNN, spline, lookup table) fuzzed the same way, against the Python laws
# ---------------------------------------------------------------------------------------------


def _phases(i):
    """``(N, L, 3)`` phase currents ia, ib, ic = -ia - ib (A)."""
    return np.concatenate([i, -i.sum(-1, keepdims=True)], axis=-1)


#: agreement of the C law with the Python law, as a share of the current limit (the scale every current
#: is bounded by, whatever the demand): double precision to rounding of currents up to ~100 x the limit
#: before the limit scales them; single precision to float rounding (~1e-7) amplified by the solve
C_TOL = {"double": 1e-10, "single": 1e-5}


@pytest.mark.parametrize("kind, precision", [("pgnn", "double"), ("pgnn", "single"), ("spline", "double")])
def test_c_law_is_safe_and_agrees_with_model_law(cc, tmp_path, rng, kind, precision):
    """Fuzz: y over ±10x the range, F* up to 10x the motor's capacity, NaN/inf; every current finite and
    within the limit on every phase; codes 0 inside, 1 held at the end, 2 non-finite (zero currents); the
    currents those of ModelLaw; the drive inputs in the convention and giving the currents back."""
    from pgcomm.commutation import drive_currents
    from pgcomm.export.c import CLawOptions, write_c

    model = _pgnn() if kind == "pgnn" else _spline(rng)
    L = model.n_coil_sets
    write_c(model, tmp_path, CLawOptions("law", precision, LIMIT))
    exe = c_harness.compile_law(cc, tmp_path, "law")
    y, f, v = _fuzz_inputs(rng, 8000)
    k_hat = K * rng.uniform(0.9, 1.1, (y.size, L))
    zeta_hat = rng.uniform(-np.pi, np.pi, (y.size, L))
    out = c_harness.run_law(exe, L, y, f, k_hat, zeta_hat, v=v)
    ret, i_c, ret_d = out["ret"][:, 0], out["currents"], out["ret"][:, 1]
    fy, delta = out["fy"], out["delta"]

    # what the C function received (float in single precision), and the codes it must return
    cast = (lambda a: np.asarray(a, np.float32).astype(float)) if precision == "single" else np.asarray
    yc, fc, vc, kc, zc = cast(y), cast(f), cast(v), cast(k_hat), cast(zeta_hat)
    lo, hi = (float(cast(b)) for b in model.training_range)
    uses_v = kind == "spline"  # the spline model has a direction term; the PGNN's law ignores v
    bad = ~(np.isfinite(yc) & np.all(np.isfinite(fc), axis=1) & (np.isfinite(vc) if uses_v else True))
    assert 0.02 < bad.mean() < 0.1
    want = np.where(bad, 2, np.where((yc >= lo) & (yc <= hi), 0, 1))
    assert np.array_equal(ret, want) and np.mean(want == 1) > 0.5
    assert np.array_equal(ret_d, want)

    assert np.all(np.isfinite(i_c)) and np.all(np.isfinite(fy)) and np.all(np.isfinite(delta))
    assert np.max(np.abs(_phases(i_c))) <= LIMIT * (1 + 1e-6)
    assert np.mean(np.max(np.abs(_phases(i_c)), axis=(1, 2)) > 0.999 * LIMIT) > 0.5  # the limit is working
    assert np.all(i_c[bad] == 0.0) and np.all(fy[bad] == 0.0) and np.all(delta[bad] == 0.0)

    law = ModelLaw(model, current_limit=LIMIT)
    i_py = np.asarray(jax.jit(law.currents)(jnp.asarray(yc), jnp.asarray(fc), jnp.asarray(vc) if uses_v else None))
    err = np.max(np.abs(i_c - i_py))
    assert err <= C_TOL[precision] * LIMIT, f"C vs ModelLaw: {err:.3g} A"

    # drive inputs: Fy* signed, Δ in (-π/2, π/2], and the drive makes the law's currents from them
    assert np.all((delta > -np.pi / 2) & (delta <= np.pi / 2))
    ok = ~bad  # (with a NaN position the drive has no phase: those give fy = delta = 0, checked above)
    back = np.asarray(drive_currents(jnp.asarray(yc[ok]), jnp.asarray(fy[ok]), jnp.asarray(delta[ok]),
                                     jnp.asarray(kc[ok]), jnp.asarray(zc[ok]), model.pole_pitch))
    err = np.max(np.abs(back - i_c[ok]))
    assert err <= C_TOL[precision] * LIMIT, f"drive inputs -> currents: {err:.3g} A"


@pytest.mark.parametrize("kind", ["pgnn", "spline"])
def test_c_lookup_table_is_safe_and_agrees_with_the_table_law(cc, tmp_path, rng, kind):
    """The same fuzz on the lookup-table C (float): ends held (code 1), non-finite -> zeros and code 2, the limit
    on every phase; the C table agrees with pgcomm.export.lut.lut_currents, and that with ModelLaw to the
    table's interpolation error."""
    from pgcomm.export.lut import build_lut, lut_currents, lut_header

    model = _pgnn() if kind == "pgnn" else _spline(rng)
    L = model.n_coil_sets
    h = 2.5e-4  # m
    lut = build_lut(model, h, current_limit=LIMIT)
    (tmp_path / "tab.h").write_text(lut_header(lut, "tab", limit_source="test"))
    uses_v = lut.direction is not None
    exe = c_harness.compile_lut(cc, tmp_path, "tab", velocity=uses_v)
    y, f, v = _fuzz_inputs(rng, 8000)
    ret, i_c = c_harness.run_lut(exe, L, y, f, v)

    f32 = lambda a: np.asarray(a, np.float32)  # noqa: E731  (what the float table function computes with)
    yc, fc, vc = f32(y), f32(f), f32(v)
    bad = ~(np.isfinite(yc) & np.all(np.isfinite(fc), axis=1) & (np.isfinite(vc) if uses_v else True))
    with np.errstate(invalid="ignore"):
        u = (yc - f32(lut.y[0])) * f32(1.0 / lut.dy)  # the table's float index, as the C computes it
    want = np.where(bad, 2, np.where((u >= 0) & (u <= lut.n - 1), 0, 1))
    assert np.array_equal(ret, want) and np.mean(want == 1) > 0.5

    assert np.all(np.isfinite(i_c)) and np.all(i_c[bad] == 0.0)
    assert np.max(np.abs(_phases(i_c))) <= LIMIT * (1 + 1e-6)
    assert np.mean(np.max(np.abs(_phases(i_c)), axis=(1, 2)) > 0.999 * LIMIT) > 0.5

    # C against the Python table law at the same (float-rounded) inputs, sample by sample within the float32
    # rounding of the table law, scaled as the limit scales the currents: (a) 16 unit roundoffs u (entries,
    # interpolation, differences, products, sums, the limit's factor) of sum_j |P_j(y)| (|F*_j| + |Fcog_j| + |C_j|);
    # (b) the float row index u = (y - Y0) / dy, off by up to (n - 1) u rows plus Y0's rounding, times the
    # largest change of the entries from one row to the next
    yd, fd, vd = (jnp.asarray(a.astype(float)) for a in (yc, fc, vc))
    i_tab = np.asarray(lut_currents(lut, yd, fd, vd if uses_v else None))
    ok = ~bad
    free = dataclasses.replace(lut, current_limit=None)
    peak = np.max(np.abs(_phases(np.asarray(lut_currents(free, yd[ok], fd[ok], vd[ok] if uses_v else None)))),
                  axis=(1, 2))
    scale = np.minimum(1.0, LIMIT / peak)
    offsets = np.abs(lut.cogging).max(axis=0) + (0.0 if lut.direction is None else np.abs(lut.direction).max(axis=0))
    sums = dataclasses.replace(free, P=np.abs(lut.P), cogging=np.zeros_like(lut.cogging), direction=None)
    size = np.max(np.asarray(lut_currents(sums, yd[ok], jnp.abs(fd[ok]) + offsets)), axis=(1, 2))
    rows = (lut.n - 1) * 2.0**-24 + abs(float(np.float32(lut.y[0])) - lut.y[0]) / lut.dy
    dP = np.abs(np.diff(lut.P, axis=0)).max(axis=0)                   # (L, 2, 3) per row
    doff = np.abs(np.diff(lut.cogging, axis=0)).max(axis=0)
    if lut.direction is not None and np.ndim(lut.direction) == 2:
        doff = doff + np.abs(np.diff(lut.direction, axis=0)).max(axis=0)
    f_all = np.abs(np.asarray(fd[ok])) + offsets                       # (n, 3)
    slope = np.max(np.einsum("laj,nj->nla", dP, f_all) + np.abs(lut.P).max(axis=0) @ doff, axis=(1, 2))
    bound = scale * (16 * 2.0**-24 * size + rows * slope)
    err = np.max(np.abs(i_c[ok] - i_tab[ok]), axis=(1, 2))
    j = int(np.argmax(err / bound))
    assert np.all(err <= bound), f"C table vs Python table law: {err[j]:.3g} A > {bound[j]:.3g} A"
    assert np.all(i_tab[bad] == 0.0)

    # at its grid points the table law is the exact law (ModelLaw), for every demand: double rounding amplified
    # by the damped solve (1/eps2 = 1e6 where Khat loses rank) of currents the limit scales to at most LIMIT
    yg = jnp.asarray(np.resize(lut.y, y.size))
    i_tab = np.asarray(lut_currents(lut, yg, fd, vd if uses_v else None))
    i_exact = np.asarray(jax.jit(ModelLaw(model, current_limit=LIMIT).currents)(yg, fd, vd if uses_v else None))
    err = np.max(np.abs(i_tab - i_exact))
    assert err <= 1e-8 * LIMIT, f"table law vs ModelLaw at the grid points: {err:.3g} A"
