"""Named random streams (pgcomm.seeds) and the identification options object (IdentifyOptions)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pgcomm.seeds import MAX_SEED, stream_seed
from pgcomm.settings import IdentificationConfig


def test_stream_seed_is_a_pure_function_of_seed_and_name():
    assert stream_seed(0, "data", 0, 1) == stream_seed(0, "data", 0, 1)
    # SeedSequence's output is specified by its algorithm, not by the platform: pin one value so a
    # change of the derivation (which changes every noise draw) cannot pass unnoticed
    ss = np.random.SeedSequence(0, spawn_key=(2 * __import__("zlib").crc32(b"data") + 1, 0, 2))
    assert stream_seed(0, "data", 0, 1) == int(ss.generate_state(1, np.uint32)[0])


def test_streams_with_different_names_do_not_collide():
    # the old offsets gave seed + 2l + i for the data of coil set l and seed + l for its starts:
    # data (0, 1) and starts of coil set 1 shared one seed
    seeds = {stream_seed(s, *name) for s in range(4)
             for name in [("data", l, i) for l in range(3) for i in range(2)]
             + [("starts", l) for l in range(3)] + [("feedforward", it, j) for it in range(3) for j in range(4)]
             + [("evaluation", r) for r in ("long", "slow", "fast")]}
    assert len(seeds) == 4 * (6 + 3 + 12 + 3)
    assert stream_seed(0, "1") != stream_seed(0, 1)  # strings and integers are different words
    assert all(0 <= s <= MAX_SEED for s in seeds)


def test_stream_draws_are_uncorrelated():
    # neighbouring names must give independent noise: correlation of 10^5 normal draws ~ N(0, 1/sqrt(n))
    n = 100_000
    a = np.random.default_rng(stream_seed(7, "data", 0, 0)).normal(size=n)
    b = np.random.default_rng(stream_seed(7, "data", 0, 1)).normal(size=n)
    assert abs(np.corrcoef(a, b)[0, 1]) < 5 / np.sqrt(n)


@pytest.mark.parametrize("seed, name, err", [(-1, ("x",), ValueError), (2**32, ("x",), ValueError),
                                              (1.5, ("x",), ValueError), (0, (), TypeError),
                                              (0, ("x", -2), ValueError), (0, (True,), TypeError)])
def test_stream_seed_refuses_bad_arguments(seed, name, err):
    with pytest.raises(err):
        stream_seed(seed, *name)


def test_identification_config_passes_every_shared_setting_by_name():
    from pgcomm.identify import IdentifyOptions

    cfg = IdentificationConfig(gain_widths=(3,), cog_widths=(5, 4), gain_width_candidates=(2, 6), activation="tanh",
                               regularisation=0.3, starts=5, max_iterations=17, validation_fraction=0.1,
                               ridge_output=1e-3, tol=1e-7, decrease_tol=2e-5, screen_iterations=33, direction_velocity=2e-3)
    o = cfg.options()
    shared = {f.name for f in dataclasses.fields(IdentifyOptions)} & {f.name for f in dataclasses.fields(cfg)}
    assert shared >= {"gain_widths", "cog_widths", "starts", "max_iterations", "regularisation", "tol", "decrease_tol",
                      "screen_iterations"}
    for name in shared:
        assert getattr(o, name) == getattr(cfg, name), name
    assert cfg.options(direction=True, starts=1).direction and cfg.options(starts=1).starts == 1


@pytest.mark.parametrize("changes", [dict(gain_widths=None, cog_widths=None), dict(starts=0), dict(gain_widths=()),
                                     dict(regularisation=-1.0), dict(method="qr"), dict(validation_fraction=0.7)])
def test_identify_options_refuse_bad_values(changes):
    from pgcomm.identify import IdentifyOptions

    with pytest.raises(ValueError):
        IdentifyOptions(**changes)


def test_identify_fits_the_physics_model_once(monkeypatch):
    from pgcomm.data import CoilSetData
    from pgcomm.identify import IdentifyOptions, lm, projection

    calls = []
    real = projection.fit_physics

    def counting(data, pole_pitch):
        calls.append(data.n)
        return real(data, pole_pitch)

    monkeypatch.setattr(lm, "fit_physics", counting)
    monkeypatch.setattr(projection, "fit_physics", counting)
    rng = np.random.default_rng(0)
    n, d_m = 4000, 0.03
    y = np.linspace(-0.05, 0.05, n)
    cur = rng.normal(size=(n, 2))
    eta = 2 * np.pi * y / d_m
    fy = 60 * (np.sin(eta) * cur[:, 0] + np.sin(eta + 2 * np.pi / 3) * cur[:, 1])
    force = np.stack([fy, 0 * fy, 0 * fy], axis=1) + 0.1 * rng.normal(size=(n, 3))
    data = CoilSetData(y, cur, force, (np.arange(n) >= n // 2).astype(int))
    lm.identify(data, d_m, IdentifyOptions(gain_widths=(2,), cog_widths=(2,), starts=1, max_iterations=2),
                check_data=False)
    assert len(calls) == 1
