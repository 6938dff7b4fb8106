"""The front door: the public names of ``pgcomm``, no process-wide settings at import, and the three
protocols (one argument order: ``force(y, currents, v)``) satisfied by every plant, model and law."""

from __future__ import annotations

import subprocess
import sys

import jax.numpy as jnp
import numpy as np

import pgcomm


def test_every_public_name_resolves_and_import_loads_no_jax():
    for name in pgcomm.__all__:
        assert getattr(pgcomm, name) is not None, name
    code = ("import os, sys, pgcomm; assert 'jax' not in sys.modules and 'numpy' not in sys.modules; "
            "assert 'OPENBLAS_NUM_THREADS' not in os.environ and 'JAX_PLATFORMS' not in os.environ")
    env = {k: v for k, v in __import__("os").environ.items() if k not in ("OPENBLAS_NUM_THREADS", "JAX_PLATFORMS")}
    subprocess.run([sys.executable, "-c", code], check=True, env=env)


def test_plants_models_and_laws_follow_the_protocols(rng):
    from pgcomm import ClassicalLaw, ForceModel, Law, ModelLaw, Plant, TwinParams
    from pgcomm.commutation import oracle_law
    from pgcomm.zoo import draw_motor

    twin = TwinParams()
    zoo = draw_motor(3, 1)
    plants = [twin.plant(), zoo.plant(), zoo.forcemap()]
    y = jnp.asarray(rng.uniform(-0.05, 0.05, 7))
    v = jnp.asarray(rng.normal(0, 0.1, 7))
    for plant in plants:
        assert isinstance(plant, Plant) and isinstance(plant, ForceModel), type(plant)
        i = jnp.asarray(rng.normal(size=(7, plant.gain(y).shape[-3], 2)))
        # one argument order: position, currents, velocity; without v the static force
        f = np.asarray(plant.force(y, i, v))
        static = np.asarray(jnp.einsum("slqj,slj->sq", plant.gain(y), i) + plant.cogging(y))
        scale = np.abs(static).max()
        np.testing.assert_allclose(np.asarray(plant.force(y, i)), static, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(f - static, np.asarray(plant.direction_force(y, v)), rtol=0, atol=1e-12 * scale)
    motor = twin.motor()
    for law in (ClassicalLaw.from_motor(motor), oracle_law(twin.plant()), ModelLaw(twin.plant())):
        assert isinstance(law, Law)
