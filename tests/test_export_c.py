"""Tests of pgcomm.export.c: the generated C law against the Python ModelLaw.

Each case exports a model, compiles the C files with a small harness
(``cc -std=c99 -O2 -Wall -Wextra -Werror -pedantic ... -lm``), feeds it random samples
through a binary file and compares currents, drive inputs and the model itself with
the Python implementation. Errors are relative to the largest |current| (or |Fy^l*|) of
the batch, so a sample with tiny currents is not judged by its own size.

Tolerances: double 1e-12, single 1e-5 (single: against Python evaluated at the
float-rounded inputs, which is what the C function receives). One exception, explained
in :func:`test_one_coil_set_damped_matches_extended_precision`: with one coil set the
law is always damped and its own rounding noise (Python's too) is ~1e-10.
"""

from __future__ import annotations

import re
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import _c_harness as c_harness
from pgcomm.commutation import ModelLaw, currents_to_drive_inputs
from pgcomm.export.c import CLawOptions, c_source, write_c
from pgcomm.models import MLP, CoilSetModel, CombinedModel, physics_from_ideal

POLE_PITCH = 0.03
Y_RANGE = (-0.1, 0.1)
N_SAMPLES = 5000
#: paper-like magnitudes of the network outputs per row [Fy, Fx, Tz]: gain (N/A, N/A, N·m/A), cogging (N, N, N·m)
GAIN_SCALE = np.array([1.5, 0.1, 0.01])
COG_SCALE = np.array([3.0, 0.5, 0.05])
#: F* ranges: |Fy| <= 100 N, |Fx| <= 5 N, |Tz| <= 1 N·m
F_RANGE = np.array([100.0, 5.0, 1.0])


# ---------------------------------------------------------------------------------------------
# models
# ---------------------------------------------------------------------------------------------


def _mlp(key, widths, scale, activation):
    """Random hidden layers (MLP.init) and random output layer scaled per output row."""
    k1, k2, k3 = jax.random.split(key, 3)
    net = MLP.init(k1, widths, activation)
    n = widths[-1]
    return MLP(net.hidden, jax.random.normal(k2, (n, 3)) * scale / np.sqrt(n),
               jax.random.normal(k3, (3,)) * scale, activation)


def make_model(L, gain_widths=(2,), cog_widths=(16,), activation="tanh", seed=0):
    """Paper-like PGNN: ideal physics (k ≈ 61 N/A, ζ ≈ -0.54, μ = 0.05) plus random networks."""
    key = jax.random.PRNGKey(seed)
    lever = np.linspace(-0.065, 0.075, L) if L > 1 else np.array([0.005])
    sets = []
    for l in range(L):
        key, kg1, kg2, kc = jax.random.split(key, 4)
        A, B = physics_from_ideal(POLE_PITCH, 61.0 + 0.5 * l, -0.54 - 0.01 * l, 0.05, lever[l])
        gain = None if gain_widths is None else (_mlp(kg1, gain_widths, GAIN_SCALE, activation),
                                                  _mlp(kg2, gain_widths, GAIN_SCALE, activation))
        cog = None if cog_widths is None else _mlp(kc, cog_widths, COG_SCALE, activation)
        sets.append(CoilSetModel(jnp.asarray(A), jnp.asarray(B), gain, cog, POLE_PITCH, 0.01 * l, 0.1 + 0.01 * l,
                                 *Y_RANGE))
    return CombinedModel.from_coil_sets(sets)


# ---------------------------------------------------------------------------------------------
# compiling and running the harness
# ---------------------------------------------------------------------------------------------

def compile_law(cc, model, directory: Path, precision="double", name="law", **kwargs) -> Path:
    """Export ``model``, compile it with the law harness (tests/_c_harness.py), return the executable."""
    options = {k: kwargs.pop(k) for k in list(kwargs) if k in CLawOptions.__dataclass_fields__}
    write_c(model, directory, CLawOptions(name, precision, **options), **kwargs)
    return c_harness.compile_law(cc, directory, name)


def run_harness(exe: Path, L: int, y, f, k_hat, zeta_hat) -> dict:
    """Run the compiled harness on samples; returns its outputs as arrays."""
    return c_harness.run_law(exe, L, y, f, k_hat, zeta_hat)


def samples(L, n=N_SAMPLES, seed=7, y_range=Y_RANGE):
    """Random positions (m), forces (N, N, N·m) and drive parameters (N/A, rad)."""
    rng = np.random.default_rng(seed)
    y = rng.uniform(*y_range, n)
    f = rng.uniform(-1.0, 1.0, (n, 3)) * F_RANGE
    k_hat = rng.uniform(55.0, 70.0, (n, L))
    zeta_hat = rng.uniform(-np.pi, np.pi, (n, L))
    return y, f, k_hat, zeta_hat


@jax.jit
def _python_law(law, y, f, k_hat, zeta_hat):
    i = law.currents(y, f)
    fy, delta = jax.vmap(lambda y1, i1, k1, z1: currents_to_drive_inputs(y1, i1, k1, z1, law.model.pole_pitch))(
        y, i, k_hat, zeta_hat)
    return i, fy, delta, law.model.gain(y), law.model.cogging(y)


def python_reference(model, y, f, k_hat, zeta_hat, current_limit=None) -> dict:
    law = ModelLaw(model, metric="phase", current_limit=current_limit)
    i, fy, delta, gain, cog = _python_law(law, *(jnp.asarray(a) for a in (y, f, k_hat, zeta_hat)))
    return {"currents": np.asarray(i), "fy": np.asarray(fy), "delta": np.asarray(delta),
            "gain": np.asarray(gain), "cogging": np.asarray(cog)}


def to_float32(*arrays):
    """Arrays rounded to float32 and back (the inputs a single-precision C law actually sees)."""
    return tuple(np.asarray(a, dtype=np.float32).astype(float) for a in arrays)


def relative_errors(c: dict, p: dict) -> dict:
    """Errors relative to the batch maxima (see the module docstring).

    The drive inputs follow one convention on both sides (signed ``Fy^l*``, ``Δ ∈ (-π/2, π/2]``), so
    ``fy`` and ``delta`` are compared as they are: a sample folded differently would show as an ``fy``
    error of twice its size.
    """
    fy_max = np.max(np.abs(p["fy"]))
    dang = np.abs((c["delta"] - p["delta"] + np.pi) % (2 * np.pi) - np.pi)
    # the angle is judged through the force vector it rotates (|fy| · |Δ error|), and only where fy is
    # not tiny (there the angle is ill-defined: Δ of a zero force is arbitrary)
    not_tiny = np.abs(p["fy"]) > 1e-6 * fy_max
    return {
        "currents": np.max(np.abs(c["currents"] - p["currents"])) / np.max(np.abs(p["currents"])),
        "fy": np.max(np.abs(c["fy"] - p["fy"])) / fy_max,
        "delta": np.max((np.abs(p["fy"]) * dang)[not_tiny]) / fy_max,
        "gain": np.max(np.abs(c["gain"] - p["gain"])) / np.max(np.abs(p["gain"])),
        # a model without cogging network has zero cogging: then the error is absolute (and 0)
        "cogging": np.max(np.abs(c["cogging"] - p["cogging"])) / max(np.max(np.abs(p["cogging"])), 1.0),
    }


# ---------------------------------------------------------------------------------------------
# agreement with the Python law: a table of cases x both precisions
# ---------------------------------------------------------------------------------------------

#: name -> (L, gain widths, cog widths, activation, current limit (A))
CASES = {
    "L2": (2, (2,), (16,), "tanh", None),
    "L3_paper": (3, (2,), (16,), "tanh", None),
    "L3_two_hidden_layers": (3, (3, 4), (8, 5), "tanh", None),
    "L3_current_limit": (3, (2,), (16,), "tanh", 1.5),
    "L4_physics_only": (4, None, None, "tanh", None),
    "L2_cogging_only": (2, None, (6,), "tanh", None),
}
TOL = {"double": 1e-12, "single": 1e-5}


@pytest.mark.parametrize("precision", ["double", "single"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_c_law_matches_python(cc, tmp_path, case, precision):
    L, gw, cw, act, limit = CASES[case]
    model = make_model(L, gw, cw, act, seed=len(case))
    exe = compile_law(cc, model, tmp_path, precision, current_limit=limit)
    y, f, k_hat, zeta_hat = samples(L)
    c = run_harness(exe, L, y, f, k_hat, zeta_hat)
    if precision == "single":
        y, f, k_hat, zeta_hat = to_float32(y, f, k_hat, zeta_hat)
    p = python_reference(model, y, f, k_hat, zeta_hat, limit)
    err = relative_errors(c, p)
    assert all(e <= TOL[precision] for e in err.values()), err
    assert np.all(c["ret"] == 0)  # every sample inside the training range
    assert np.all((c["delta"] > -np.pi / 2) & (c["delta"] <= np.pi / 2))
    assert np.any(c["fy"] < 0) and np.any(c["fy"] > 0)  # the sign is in the force, not in Δ
    if limit is not None:
        # the limit is active on part of the batch, and respected
        phases = np.concatenate([c["currents"], -c["currents"].sum(-1, keepdims=True)], -1)
        peak = np.max(np.abs(phases), axis=(-2, -1))
        assert np.mean(peak > 0.999 * limit) > 0.2
        assert np.max(peak) <= limit * (1 + 1e-6)


@pytest.mark.parametrize("activation", ["sigmoid", "relu", "softplus", "gelu", "linear"])
def test_c_activations_match_python(cc, tmp_path, activation):
    model = make_model(2, (3,), (4, 3), activation, seed=3)
    exe = compile_law(cc, model, tmp_path)
    y, f, k_hat, zeta_hat = samples(2, n=1000)
    err = relative_errors(run_harness(exe, 2, y, f, k_hat, zeta_hat), python_reference(model, y, f, k_hat, zeta_hat))
    assert all(e <= 1e-12 for e in err.values()), err


# ---------------------------------------------------------------------------------------------
# one coil set: always damped
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("precision", ["double", "single"])
def test_one_coil_set_meets_fy_and_fx_like_python(cc, tmp_path, precision):
    """L = 1: two currents for three rows; the law meets ``Fy`` and ``Fx`` exactly (Tz follows).

    Checked against Python and against the ``2 x 2`` solve of the ``Fy``, ``Fx`` rows of the
    model's gain (a second formulation); the gain is well conditioned there, so double
    precision agrees to ~1e-12 and single precision as usual.
    """
    model = make_model(1, seed=11)
    exe = compile_law(cc, model, tmp_path, precision)
    y, f, k_hat, zeta_hat = samples(1)
    c = run_harness(exe, 1, y, f, k_hat, zeta_hat)
    if precision == "single":
        y, f, k_hat, zeta_hat = to_float32(y, f, k_hat, zeta_hat)
    p = python_reference(model, y, f, k_hat, zeta_hat)
    err = relative_errors(c, p)
    assert np.all(c["ret"] == 0)
    tol = 1e-5 if precision == "single" else 1e-11
    assert all(e <= tol for e in err.values()), err
    gain = np.asarray(p["gain"], float)[:, 0]                    # (N, 3, 2)
    direct = np.linalg.solve(gain[:, :2, :], (f - p["cogging"])[:, :2, None])[..., 0]
    scale = np.abs(direct).max()
    np.testing.assert_allclose(np.asarray(c["currents"], float)[:, 0, :], direct, rtol=0, atol=10 * tol * scale)


# ---------------------------------------------------------------------------------------------
# range flag, drive constants, the source itself
# ---------------------------------------------------------------------------------------------


def test_outside_training_range_holds_the_range_end_and_returns_one(cc, tmp_path):
    model = make_model(3, seed=5)
    exe = compile_law(cc, model, tmp_path)
    y = np.array([-0.12, -0.1, 0.0, 0.1, 0.1 + 1e-9, 0.3, -2.0])
    _, f, k_hat, zeta_hat = samples(3, n=y.size)
    f[:] = f[0]  # one demand: beyond the range the currents must be those at its end
    c = run_harness(exe, 3, y, f, k_hat, zeta_hat)
    assert c["ret"][:, 0].tolist() == [1, 0, 0, 0, 1, 1, 1]
    assert np.array_equal(c["ret"][:, 0], c["ret"][:, 1])
    p = python_reference(model, y, f, k_hat, zeta_hat)
    assert relative_errors(c, p)["currents"] <= 1e-12
    scale = np.abs(c["currents"]).max()
    for far, end in ((0, 1), (6, 1), (4, 3), (5, 3)):
        np.testing.assert_allclose(c["currents"][far], c["currents"][end], rtol=0, atol=1e-12 * scale)


@pytest.mark.parametrize("precision", ["double", "single"])
def test_non_finite_input_gives_zero_and_code_two(cc, tmp_path, precision):
    """Return codes: 0 inside, 1 held at the range's end, 2 non-finite input (zero currents and drive inputs)."""
    model = make_model(2, seed=6)
    exe = compile_law(cc, model, tmp_path, precision, current_limit=5.0)
    # the last position is finite in double but its commutation phase 2 pi y / d_m overflows (and a float
    # law receives it as inf)
    y = np.array([0.0, 0.5, np.nan, np.inf, 0.0, 0.0, 0.0, 0.0, -np.inf, 1.7e308])
    f = np.tile([40.0, 1.0, 0.2], (y.size, 1))
    f[4, 0], f[5, 1], f[6, 2] = np.nan, np.inf, -np.inf
    k_hat = np.full((y.size, 2), 61.0)
    zeta_hat = np.full((y.size, 2), -0.5)
    k_hat[7, 1] = np.nan  # the drive's constants: only the drive inputs are refused
    c = run_harness(exe, 2, y, f, k_hat, zeta_hat)
    huge = 1 if precision == "double" else 2
    assert c["ret"][:, 0].tolist() == [0, 1, 2, 2, 2, 2, 2, 0, 2, huge]
    assert c["ret"][:, 1].tolist() == [0, 1, 2, 2, 2, 2, 2, 2, 2, 2]
    assert np.all(np.isfinite(c["currents"])) and np.all(np.isfinite(c["fy"])) and np.all(np.isfinite(c["delta"]))
    bad = c["ret"][:, 0] == 2
    assert np.all(c["currents"][bad] == 0.0) and np.all(np.abs(c["currents"][~bad]) > 0)
    bad_drive = c["ret"][:, 1] == 2
    assert np.all(c["fy"][bad_drive] == 0.0) and np.all(c["delta"][bad_drive] == 0.0)
    np.testing.assert_array_equal(c["currents"][7], c["currents"][0])  # k_hat is not an input of the law


def test_drive_constants_and_metadata_are_embedded(tmp_path):
    model = make_model(2, seed=2)
    meta = {"source": "runs/model.json", "created": "2024-06-11T10:00:00", "pgcomm_version": "0.1.0"}
    paths = write_c(model, tmp_path / "out", CLawOptions("motor_a", current_limit=10.0), metadata=meta,
                    drive=((60.0, 61.0), -0.5))
    assert [p.name for p in paths] == ["motor_a.h", "motor_a.c"]
    header, source = (p.read_text() for p in paths)
    for text in ("runs/model.json", "2024-06-11T10:00:00", "pgcomm 0.1.0", "L = 2", "d_m = 0.03 m",
                 "[-0.1, 0.1] m", "10 A peak phase current", "Commutation_Model_Currents"):
        assert text in header and text in source, text
    assert "extern const double motor_a_drive_k_hat[MOTOR_A_L];" in header
    assert re.search(r"const double motor_a_drive_zeta_hat\[MOTOR_A_L\] = \{-0\.5, -0\.5\};", source)
    assert "#define MOTOR_A_CURRENT_LIMIT 10.0" in source


def _file_scope_statements(source: str) -> list[str]:
    """Declarations at file scope (function bodies and initializers skipped), comments removed."""
    text = re.sub(r"/\*.*?\*/", " ", source, flags=re.S)
    text = "\n".join(line for line in text.splitlines() if not line.lstrip().startswith("#"))
    out, cur, depth = [], "", 0
    for ch in text:
        if depth:
            depth += {"{": 1, "}": -1}.get(ch, 0)
            if depth == 0 and "(" in cur and "=" not in cur:  # end of a function body
                out.append(cur.strip())
                cur = ""
            continue
        if ch == "{":
            depth = 1
            continue
        if ch == ";":
            out.append(cur.strip())
            cur = ""
            continue
        cur += ch
    return [s for s in out if s]


@pytest.mark.parametrize("precision", ["double", "single"])
def test_source_is_self_contained_and_has_no_mutable_state(precision):
    model = make_model(3, (3, 2), (16,), seed=4)
    header, source = c_source(model, CLawOptions("pgcomm_law", precision, 5.0), drive=(61.0, -0.5))
    both = header + source
    for word in ("malloc", "calloc", "realloc", "free(", "alloca", "printf"):
        assert word not in both, word
    includes = re.findall(r"#include\s*[<\"]([^>\"]+)[>\"]", both)
    # stdint.h and string.h: memcpy of the IEEE-754 bits, the non-finite test that survives -ffast-math
    assert set(includes) <= {"math.h", "stddef.h", "stdint.h", "string.h", "pgcomm_law.h"}, includes
    statements = _file_scope_statements(source) + _file_scope_statements(header)
    assert statements
    for s in statements:
        is_function = "(" in s and "=" not in s
        assert is_function or s.startswith("typedef") or re.search(r"\bconst\b", s.split("=")[0]), s
    assert "extern" not in source  # definitions only in the source
    assert both.isascii()
    if precision == "single":
        assert re.search(r"\btanhf\(", source) and re.search(r"\bsinf\(", source)
        assert re.search(r"\batan2f\(", source) and re.search(r"\bhypotf\(", source)
        code = re.sub(r"/\*.*?\*/", " ", source, flags=re.S)
        assert not re.search(r"\btanh\(|\bsin\(|\bcos\(|\batan2\(|\bhypot\(", code)
        arrays = re.findall(r"static const float \w+(?:\[\d+\])+ = (\{.*?\});", source, flags=re.S)
        numbers = re.findall(r"[-+]?\d[\d.e+-]*f?", " ".join(arrays))
        assert numbers and all(x.endswith("f") for x in numbers)


def test_double_weights_round_trip_exactly():
    model = make_model(2, (2,), (5,), seed=9)
    _, source = c_source(model, CLawOptions("w"))

    def numbers(cname):
        body = re.search(rf"static const double {cname}(?:\[\d+\])+ = (\{{.*?\}});", source, flags=re.S).group(1)
        return np.array([float(x) for x in re.findall(r"[-+]?\d[\d.eE+-]*", body)])

    assert np.array_equal(numbers("w_A"), np.asarray(model.A).ravel())
    assert np.array_equal(numbers("w_cog_wo"), np.asarray(model.cog_nets.W_out).ravel())
    assert np.array_equal(numbers("w_gain_w1"), np.asarray(model.gain_nets.hidden[0][0]).ravel())


@pytest.mark.parametrize("bad", ["1law", "_law", "law-x", "", "la w"])
def test_bad_name_is_refused(bad):
    with pytest.raises(ValueError, match="C identifier"):
        CLawOptions(bad)


def test_bad_arguments_are_refused(tmp_path):
    model = make_model(2, None, (4,))
    with pytest.raises(ValueError, match="precision"):
        CLawOptions(precision="half")
    with pytest.raises(ValueError, match="current_limit"):
        CLawOptions(current_limit=-1.0)
    bad = CombinedModel(model.A.at[0, 0, 0].set(jnp.nan), model.B, None, model.cog_nets, model.y_center,
                        model.y_scale, model.pole_pitch, model.y_min, model.y_max)
    with pytest.raises(ValueError, match="non-finite"):
        write_c(bad, tmp_path / "x")
    assert not (tmp_path / "x").exists()  # refused before anything was written
