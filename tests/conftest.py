"""Shared test setup.

Importing :mod:`pgcomm` enables JAX x64 (float64 everywhere); the assertion makes
a silent float32 fallback fail loudly instead of loosening every tolerance.

JAX's ``jax_numpy_dtype_promotion="strict"`` was tried and is NOT enabled: the
package's own code does not pass with it (``pgcomm/twin.py``,
``TwinPlant.gain_phases`` builds ``ct + 1j * st``, a float64 x Python complex
promotion that strict mode rejects), so the default "standard" promotion is kept.
"""

from __future__ import annotations

import jax
import numpy as np
import pytest

import pgcomm  # noqa: F401  (enables x64 at import)

assert jax.config.jax_enable_x64, "pgcomm must enable JAX x64 at import"


@pytest.fixture
def rng():
    """A seeded NumPy generator (explicit seeds only)."""
    return np.random.default_rng(20240611)
