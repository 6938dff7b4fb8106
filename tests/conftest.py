"""Shared test setup.

Importing :mod:`pgcomm` enables JAX x64 (float64 everywhere); the assertion makes
a silent float32 fallback fail loudly instead of loosening every tolerance.

JAX's dtype promotion is made strict, so an accidental mix of dtypes in the package
raises instead of silently promoting.
"""

from __future__ import annotations

import jax
import numpy as np
import pytest

import pgcomm.models  # noqa: F401  (a computing module: enables x64 at import)

assert jax.config.jax_enable_x64, "pgcomm's computing modules must enable JAX x64 at import"
jax.config.update("jax_numpy_dtype_promotion", "strict")


@pytest.fixture
def rng():
    """A seeded NumPy generator (explicit seeds only)."""
    return np.random.default_rng(20240611)
