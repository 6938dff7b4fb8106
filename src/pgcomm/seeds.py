"""Named random streams: one helper turns the user's ``--seed`` and a stream's name into a seed.

Every random draw of a run (sensor noise of a data set, random starts of a network, the noise of
an evaluation run) takes its seed from :func:`stream_seed` with a name that says what it is for,
e.g. ``stream_seed(seed, "data", l, i)`` for experiment ``Z_i^l`` or ``stream_seed(seed, "starts", l)``
for coil set ``l``'s random starts. The names are hashed into a :class:`numpy.random.SeedSequence`'s
spawn key, so two streams with different names are statistically independent, however the integers
in their names compare: the noise of the first data set and the random starts of coil set 1 no
longer share a seed (as the old offsets ``seed + 2 l + i`` and ``seed + l`` did).

The result is an integer in ``[0, 2**32 - 1]``: the seed type of :func:`jax.random.PRNGKey` and of
NumPy, so the functions that draw (:func:`pgcomm.simulate.simulate_many`,
:func:`pgcomm.identify.identify`) keep taking plain integers. Streams nest:
``stream_seed(stream_seed(s, "a"), "b")`` is a stream of its own, for a step that hands a seed on.
"""

from __future__ import annotations

import zlib

import numpy as np

__all__ = ["stream_seed", "MAX_SEED"]

#: Largest seed (unsigned 32-bit, the seed type of JAX's ``PRNGKey`` and NumPy).
MAX_SEED = 2**32 - 1


def _word(name) -> int:
    """One spawn-key word per name part: strings and integers never map to the same word."""
    if isinstance(name, (bool, np.bool_)):
        raise TypeError(f"stream name part {name!r}: use a string or a non-negative integer")
    if isinstance(name, str):
        return 2 * zlib.crc32(name.encode("utf-8")) + 1
    n = int(name)
    if n < 0 or n != name:
        raise ValueError(f"stream name part {name!r}: integers must be non-negative whole numbers")
    return 2 * n


def stream_seed(seed: int, *name) -> int:
    """The seed of the random stream ``name`` under the run's ``seed``.

    Args:
        seed: the run's seed (``--seed``), an integer in ``[0, 2**32 - 1]``.
        name: the stream's name, one or more parts (strings, or non-negative integers such as a
            coil-set index or a pass number), e.g. ``("data", 0, 1)``.

    Returns:
        an integer in ``[0, 2**32 - 1]``, the same on every platform for the same arguments.

    Raises:
        ValueError: a seed outside ``[0, 2**32 - 1]`` or a negative integer in the name;
        TypeError: no name (a stream must say what it is for) or a boolean in it.
    """
    if not name:
        raise TypeError("stream_seed needs a stream name, e.g. stream_seed(seed, 'data', l, i)")
    s = int(seed)
    if s != seed or not 0 <= s <= MAX_SEED:
        raise ValueError(f"seed = {seed!r}: expected an integer from 0 to 2**32 - 1")
    ss = np.random.SeedSequence(s, spawn_key=tuple(_word(p) for p in name))
    return int(ss.generate_state(1, np.uint32)[0])
