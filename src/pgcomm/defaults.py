"""Defaults and bounds shared by the library and the command line, in a module that imports nothing heavy.

The command line shows them in ``--help``; keeping them here (not in the modules that use them, which
import JAX, SciPy or Dask) keeps ``pgcomm --help`` and argument errors fast.
"""

#: Most motors :func:`pgcomm.zoo.write_zoo` writes in one call (with logs a motor takes 20-150 MB of CSV).
MAX_MOTORS = 1000
#: Robust z-score above which ``pgcomm fleet`` flags a value as an outlier (Iglewicz & Hoaglin's 3.5).
DEFAULT_OUTLIER_Z = 3.5
#: Default grid spacing (m) of the exported lookup tables: worst case 0.030 % of f_max on paper-like
#: models (d_m = 0.03 m), 134 kB for ±0.1 m.
DEFAULT_RESOLUTION = 8e-5
#: Largest model file header read (bytes): a real one is a few kB (metadata included).
MAX_JSON_BYTES = 16 * 2**20
