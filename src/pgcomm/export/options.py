"""Options shared by ``pgcomm export``'s formats: the current limit, the drive's commutation, names.

Parsed here, beside the exports, so the command line (:mod:`pgcomm.cli.export`) and the drive tables
(:mod:`pgcomm.export.drive_export`) read them the same way; each refuses a bad value with one line naming the
option.
"""

from __future__ import annotations

import math
import numpy as np

from pgcomm.errors import ConfigError
from pgcomm.export.c_text import check_c_name
from pgcomm.io.config import _plausible

#: ``--name`` when not given; the drive tables default to ``pgcomm_<format>``.
DEFAULT_NAMES = {"c": "pgcomm_law", "lut": "pgcomm_lut", "c-angle": "pgcomm_angle_lut",
                 "c-rotary": "pgcomm_rotary_law"}

__all__ = ["DEFAULT_NAMES", "parse_current_limit", "parse_per_coil_set", "drive_commutation", "c_name",
           "entries_name_limit", "limit_text", "fmt_values"]


def parse_current_limit(text: str | None) -> tuple[float | None, bool]:
    """``--current-limit``: ``(limit in A or None, given)``; ``"none"`` turns the limit off.

    Raises:
        ConfigError: anything but a plausible positive current in A or ``none`` (one line naming the value).
    """
    if text is None:
        return None, False
    if text.strip().lower() == "none":
        return None, True
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and 0 < v <= 1e4):
        raise ConfigError(f"--current-limit {text}: expected a peak phase current in A (0 < A <= 10000, e.g. 10) "
                          "or none to export without a limit")
    return v, True


def parse_per_coil_set(text: str | None, option: str, key: str, n_coil_sets: int):
    """``--drive-k`` / ``--drive-zeta``: one value or ``n_coil_sets`` comma-separated values, as an ``(L,)`` array.

    ``key`` is ``"k"`` (N/A, positive) or ``"zeta"`` (rad); values outside the motor TOML's plausible
    range (:data:`pgcomm.io.config.PLAUSIBLE`, e.g. a ``zeta`` in degrees) are refused with a hint.
    """
    if text is None:
        return None
    parts = [t.strip() for t in text.split(",")]
    unit = "N/A" if key == "k" else "rad"
    try:
        values = [float(t) for t in parts]
    except ValueError:
        raise ConfigError(f"{option} {text}: expected numbers in {unit}, one or one per coil set "
                          f"({n_coil_sets}), comma-separated") from None
    if len(values) not in (1, n_coil_sets):
        raise ConfigError(f"{option} {text}: {len(values)} values for a model with {n_coil_sets} coil sets "
                          f"(give one value or {n_coil_sets})")
    for l, v in enumerate(values):
        _plausible(v, key, f"{option} {text}", f"coil set {l + 1}" if len(values) > 1 else "value")
    return np.broadcast_to(np.asarray(values, dtype=float), (n_coil_sets,)).copy()


def fmt_values(a) -> str:
    return ", ".join(f"{x:.6g}" for x in a)


def drive_commutation(args, model, metadata) -> dict:
    """The drive's ``k̂`` (N/A), ``ζ̂`` (rad) per coil set and where each came from (see the module docstring).

    Returns:
        ``{"k_hat": (L,), "zeta_hat": (L,), "source": str, "given": bool}``; ``given`` is true when the
        values are the user's or the model file's (not the fit to the model's fundamental).
    """
    from pgcomm.export.lut import classical_parameters  # start-up cost: loads JAX only when this runs
    from pgcomm.io.model import drive_of  # start-up cost: loads JAX only when this runs

    L = model.n_coil_sets
    k = parse_per_coil_set(args.drive_k, "--drive-k", "k", L)
    z = parse_per_coil_set(args.drive_zeta, "--drive-zeta", "zeta", L)
    recorded = drive_of(metadata, args.model, L)
    if recorded is not None:
        k0, z0, src0 = recorded[0], recorded[1], f"the model file: {recorded[2]}"
    else:
        k0, z0 = classical_parameters(model)
        src0 = "fitted to the model's fundamental (the model file records no drive commutation)"
    parts = []
    if k is not None and z is not None:
        parts = ["--drive-k, --drive-zeta"]
    elif k is not None:
        parts, z = [f"k_hat from --drive-k, zeta_hat {src0}"], z0
    elif z is not None:
        parts, k = [f"zeta_hat from --drive-zeta, k_hat {src0}"], k0
    else:
        k, z, parts = k0, z0, [src0]
    return {"k_hat": k, "zeta_hat": z, "source": parts[0],
            "given": recorded is not None or args.drive_k is not None or args.drive_zeta is not None}


def limit_text(limit, source) -> str:
    """``"17.5 A (source)"`` or ``"none (source)"``."""
    return f"{limit:g} A ({source})" if limit is not None else f"none ({source})"


def entries_name_limit(args) -> tuple[str, float | None, bool]:
    """``--entries`` checked, ``--name`` (default per format) checked as a C identifier, ``--current-limit`` parsed:
    ``(name, limit, limit_given)``."""
    if args.entries is not None and not 8 <= args.entries <= 1 << 20:
        raise ConfigError(f"--entries {args.entries}: expected a table size from 8 to {1 << 20}")
    return (c_name(args), *parse_current_limit(args.current_limit))


def c_name(args) -> str:
    """``--name`` (default per format), checked as a C identifier prefix."""
    name = args.name or DEFAULT_NAMES.get(args.format, f"pgcomm_{args.format.replace('-', '_')}")
    try:
        check_c_name(name)
    except ValueError as e:
        raise ConfigError(f"--name: {e}") from None
    return name
