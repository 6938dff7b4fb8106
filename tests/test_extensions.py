"""The model-class extensions beyond the paper: the direction term ``C s(ẏ)`` and the 5th/7th harmonic columns.

Checked against truth: Proposition 1 with the extra columns against ``numpy.linalg.lstsq``;
the projected Jacobian against finite differences; a noise-free plant whose truth lies in the
extended class (a random PGNN with ``H`` and ``C``) recovered; the velocity differentiator
exact on quadratic motion; model files with the extensions round-trip and schema /1 files
still load; the C export with a velocity argument against the Python law.
"""

from __future__ import annotations

import dataclasses
import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from pgcomm import data as pdata
from pgcomm import identify as idf
from pgcomm.commutation import ModelLaw, drive_currents
from pgcomm.identify.layout import _Layout, _physics_columns
from pgcomm.identify.projection import _prepare, _projected_residual
from pgcomm.io.model import load_model, model_paths, save_model
from pgcomm.models import CoilSetModel, CombinedModel, physics_from_ideal

D_M = 0.03
K_HAT, ZETA_HAT = 67.0, -0.52
TS = 1e-3
V_EPS = 1e-3


def _sweep(n, speeds=(0.05, 0.15, 0.3), stroke=0.1):
    """Cosine-profile moves between ``±stroke`` (m) at the given peak speeds (m/s), sampled at 1 ms."""
    ys, pos = [], -stroke
    while sum(a.size for a in ys) < n:
        for v in speeds:
            duration = np.pi / 2 * 2 * stroke / v
            t = np.arange(0.0, duration, TS)
            ys.append(pos - 2 * pos * (1 - np.cos(np.pi * t / duration)) / 2)
            pos = -pos
    return np.concatenate(ys)[:n]


def _truth(seed=3):
    """A PGNN of the extended class: ideal physics, random small networks, harmonics and a direction term."""
    key = jax.random.PRNGKey(seed)
    a, b = physics_from_ideal(D_M, 61.3, -0.54, 0.05, 0.005)
    m = CoilSetModel.init(key, CoilSetModel.physics(a, b, D_M, 0.0, 0.1), (2,), (3,), harmonics=True, direction=True,
                          direction_velocity=V_EPS)
    rng = np.random.default_rng(seed)
    scale = np.array([1.0, 0.1, 0.01])
    gain_out = [(jnp.asarray(rng.normal(size=(2, 3)) * scale), jnp.asarray(rng.normal(size=3) * scale)) for _ in range(2)]
    cog_out = (jnp.asarray(rng.normal(size=(3, 3)) * 3 * scale), jnp.asarray(rng.normal(size=3) * scale))
    H = jnp.asarray(rng.normal(size=(4, 3, 2)) * 0.4 * scale[None, :, None])
    C = jnp.asarray(np.array([3.0, 0.1, 0.2]))
    return m.with_outputs(a, b, gain_out, cog_out, H, C)


def _data(model, n_per=3000, noise=0.0, seed=0):
    """Both data sets (``Δ = ±π/4``) of ``model`` as the plant; velocity from the positions."""
    rng = np.random.default_rng(seed)
    ys, fys, dls, exps = [], [], [], []
    for e, delta in enumerate((np.pi / 4, -np.pi / 4)):
        t = np.arange(n_per) * TS
        fys.append((40.0 + 20.0 * np.sin(2 * np.pi * t / 1.3 + e)) * np.sign(np.sin(2 * np.pi * t / 0.7 + 0.3 + e)))
        ys.append(_sweep(n_per))
        dls.append(np.full(n_per, delta))
        exps.append(np.full(n_per, e))
    y, fy, delta, exp = (np.concatenate(a) for a in (ys, fys, dls, exps))
    vel = pdata.velocity_from_positions(y, TS, exp)
    cur = np.asarray(drive_currents(y, fy[:, None], delta[:, None], K_HAT, ZETA_HAT, D_M))[:, 0]
    force = np.asarray(model.force(y, cur, vel)) + noise * rng.normal(size=(y.size, 3))
    return pdata.CoilSetData(y, cur, force, exp, "coil set 1", vel)


@pytest.fixture(scope="module")
def truth():
    return _truth()


@pytest.fixture(scope="module")
def data(truth):
    return _data(truth)


def test_velocity_is_exact_on_quadratic_motion():
    """A Savitzky–Golay differentiator of order 2 is exact on quadratic motion, also at the segment ends."""
    t = np.arange(400) * TS
    y = 0.01 + 0.2 * t - 0.7 * t**2
    seg = (t > 0.2).astype(int)
    y[seg == 1] = 0.05 - 0.1 * t[seg == 1] + 0.3 * t[seg == 1] ** 2
    v = pdata.velocity_from_positions(y, TS, seg)
    v_true = np.where(seg == 0, 0.2 - 1.4 * t, -0.1 + 0.6 * t)
    np.testing.assert_allclose(v, v_true, rtol=0, atol=1e-9 * np.abs(v_true).max())


def test_proposition1_with_extra_columns_matches_lstsq(truth, data):
    layout = _Layout.of(truth)
    assert layout.n_known == 4 + 8 + 1
    rng = np.random.default_rng(1)
    lam12 = 0.05 + 0.2 * rng.random(12)
    star = idf.theta_phy(*idf.fit_physics(data, D_M)) + rng.normal(size=12)
    m = np.asarray(idf.regressor(truth, data.y, data.currents, data.velocity))
    n, p = m.shape
    ref = []
    for q in range(3):
        w = np.zeros(p)
        w[:4] = lam12[_physics_columns(q)]  # Λ only on A, B: the extensions are not regularised
        target = np.zeros(p)
        target[:4] = star[_physics_columns(q)]
        a = np.vstack([m, np.sqrt(n) * np.diag(w)])
        b = np.concatenate([data.force[:, q], np.sqrt(n) * w * target])
        ref.append(np.linalg.lstsq(a, b, rcond=None)[0])
    ref = np.stack(ref, axis=1)
    res = idf.proposition1(truth, data, lam12, star, damping=0.0)
    np.testing.assert_allclose(res.theta_L, ref, rtol=0, atol=1e-8 * np.abs(ref).max())
    # the LIP rewrite reproduces the model's force with the direction term
    f_lip = m @ np.asarray(idf.theta_L_of(truth))
    scale = np.abs(data.force).max()
    np.testing.assert_allclose(f_lip, np.asarray(truth.force(data.y, data.currents, data.velocity)), rtol=0,
                               atol=1e-12 * scale)


def test_jacobian_with_direction_term_matches_finite_differences(truth, data):
    sub = data.take(slice(None, None, 4))
    a, b = idf.fit_physics(sub, D_M)
    model = CoilSetModel.init(jax.random.PRNGKey(7), CoilSetModel.physics(a, b, D_M, 0.0, 0.1), (2,), (3,),
                              harmonics=True, direction=True, direction_velocity=V_EPS)
    star = idf.theta_phy(a, b)
    f, jtj, jtr, _ = idf.projected_normal_equations(model, sub, theta_phy_star=star)
    flat = np.asarray(idf.hidden_vector(model))
    r0 = idf.projected_residual(model, sub, theta_phy_star=star)
    layout, chunks, k = _prepare(model, sub, idf.DEFAULT_LAMBDA, star, 0.0, idf.DEFAULT_DAMPING, None, "auto")
    jac = np.empty((r0.size, flat.size))
    for i in range(flat.size):
        e = np.zeros_like(flat)
        e[i] = 1e-6 * max(1.0, abs(flat[i]))
        rp, rm = (np.asarray(_projected_residual(layout, flat + s * e, chunks, k)) for s in (1, -1))
        jac[:, i] = (rp - rm) / (2 * e[i])
    assert f == pytest.approx(0.5 * r0 @ r0, rel=1e-10)
    np.testing.assert_allclose(jtj, jac.T @ jac, rtol=0, atol=1e-5 * np.abs(jac.T @ jac).max())
    np.testing.assert_allclose(jtr, jac.T @ r0, rtol=0, atol=1e-5 * np.abs(jac.T @ r0).max())


def test_noise_free_extended_truth_is_recovered(truth, data):
    """Warm start near the truth's hidden layers: LM with Proposition 1 recovers C and H.

    Tolerances from the data's scale: the force RMS times 1e-4 for the direction term (N), and
    the same relative to the fundamental gain's size for the harmonic coefficients (N/A).
    """
    rng = np.random.default_rng(5)
    flat = np.asarray(idf.hidden_vector(truth))
    start = idf.with_hidden_vector(truth, flat * (1 + 0.02 * rng.normal(size=flat.size)))
    res = idf.identify(data, D_M, idf.IdentifyOptions(
        gain_widths=(2,), cog_widths=(3,), regularisation=0.0, starts=1, harmonics=True, direction=True,
        direction_velocity=V_EPS, tol=1e-12, max_iterations=200, validation_fraction=0.0, damping=0.0),
        start_from=start, check_data=False)
    f_rms = float(np.sqrt(np.mean(data.force[:, 0] ** 2)))
    assert res.cost_y < (1e-4 * f_rms) ** 2
    np.testing.assert_allclose(np.asarray(res.model.C), np.asarray(truth.C), rtol=0, atol=1e-4 * f_rms)
    k_scale = float(np.abs(np.asarray(truth.A)).max())
    np.testing.assert_allclose(np.asarray(res.model.H), np.asarray(truth.H), rtol=0, atol=1e-4 * k_scale)


def test_model_file_roundtrip_with_extensions_and_old_schema(tmp_path, truth):
    combined = CombinedModel.from_coil_sets([truth, truth])
    save_model(tmp_path / "m", combined, identification="force_sensor")
    loaded, doc = load_model(tmp_path / "m")
    assert doc["schema"] == "pgcomm-model/2" and doc["direction"] == {"velocity": V_EPS} and doc["harmonics"]
    y = jnp.linspace(-0.1, 0.1, 11)
    v = jnp.linspace(-0.01, 0.01, 11)
    np.testing.assert_array_equal(np.asarray(loaded.gain(y)), np.asarray(combined.gain(y)))
    np.testing.assert_array_equal(np.asarray(loaded.direction_force(y, v)), np.asarray(combined.direction_force(y, v)))
    # a schema /1 file (before the extensions) still loads as the paper's model
    plain = dataclasses.replace(combined, H=None, C=None)
    js, _ = save_model(tmp_path / "old", plain)
    doc = json.loads(js.read_text())
    for key in ("harmonics", "direction", "identification"):
        doc.pop(key)
    doc["schema"] = "pgcomm-model/1"
    model_paths(tmp_path / "old")[0].write_text(json.dumps(doc))
    old, doc_old = load_model(tmp_path / "old")
    assert old.H is None and old.C is None and doc_old["identification"] == "force_sensor"
    np.testing.assert_array_equal(np.asarray(old.gain(y)), np.asarray(plain.gain(y)))


def test_c_export_with_velocity_matches_python(cc, tmp_path, truth):
    import _c_harness as c_harness
    from test_export_c import samples

    from pgcomm.export.c import CLawOptions, write_c

    L = 2
    # a second coil set at another lever arm: with both at the same lever arm the Tz row is nearly
    # dependent and rounding is amplified far above 1e-12 of the currents (in Python as in C)
    a2, b2 = physics_from_ideal(D_M, 61.6, -0.55, 0.05, 0.075)
    model = CombinedModel.from_coil_sets([truth, dataclasses.replace(truth, A=jnp.asarray(a2), B=jnp.asarray(b2),
                                                                     C=truth.C * 0.5)])
    write_c(model, tmp_path, CLawOptions("law"))
    exe = c_harness.compile_law(cc, tmp_path, "law")
    y, f, k_hat, zeta_hat = samples(L, n=2000)
    v = np.random.default_rng(3).uniform(-0.005, 0.005, y.size)  # through the smooth sign's transition
    out = c_harness.run_law(exe, L, y, f, k_hat, zeta_hat, v=v)
    cur_c = out["currents"]
    law = ModelLaw(model, metric="phase")
    cur_py = np.asarray(jax.jit(law.currents)(jnp.asarray(y), jnp.asarray(f), jnp.asarray(v)))
    np.testing.assert_allclose(cur_c, cur_py, rtol=0, atol=1e-12 * np.abs(cur_py).max())
    # the velocity matters: without the direction force the currents differ
    cur_static = np.asarray(law.currents(jnp.asarray(y), jnp.asarray(f)))
    assert np.abs(cur_static - cur_py).max() > 1e-3 * np.abs(cur_py).max()
