"""Shared test setup.

Importing :mod:`pgcomm` enables JAX x64 (float64 everywhere); the assertion makes
a silent float32 fallback fail loudly instead of loosening every tolerance.

JAX's dtype promotion is made strict, so an accidental mix of dtypes in the package
raises instead of silently promoting.
"""

from __future__ import annotations

import os

# The tests run the command line in-process (pgcomm.cli.main), so they set what the `pgcomm` program sets before
# NumPy loads (pgcomm.cli): one BLAS thread, as in the fleet's workers, so that in-process and worker results are
# summed in the same order.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")

import jax  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import pgcomm.models  # noqa: F401, E402  (a computing module: enables x64 at import)

assert jax.config.jax_enable_x64, "pgcomm's computing modules must enable JAX x64 at import"
jax.config.update("jax_numpy_dtype_promotion", "strict")


@pytest.fixture
def rng():
    """A seeded NumPy generator (explicit seeds only)."""
    return np.random.default_rng(20240611)


@pytest.fixture(scope="session")
def cc():
    """Path of the system C compiler; the tests that compile exported C are skipped only if there is none."""
    import shutil

    for name in ("cc", "gcc", "clang"):
        path = shutil.which(name)
        if path:
            return path
    pytest.skip("no C compiler (cc, gcc, clang) on PATH")
