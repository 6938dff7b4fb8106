"""The rotary model file: ``model.json`` of ``pgcomm identify`` on a rotary motor, read and checked.

A rotary model is in current units (:mod:`pgcomm.rotary.model`) and its file is plain JSON: reading it needs neither
JAX nor SciPy, so the drives' tables export from it without them (:mod:`pgcomm.export.drive_export`). The linear
model files are :mod:`pgcomm.io.model`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from pgcomm.defaults import MAX_JSON_BYTES
from pgcomm.errors import DataError
from pgcomm.io.config import ROTARY_PLAUSIBLE
from pgcomm.rotary.law import MIN_GAIN
from pgcomm.rotary.model import Fourier, RotaryModel

__all__ = ["ROTARY_SCHEMA", "MAX_ROTARY_ORDERS", "rotary_model_from_dict", "load_rotary_model"]

#: Schema of a rotary model file (``model.json`` of ``pgcomm identify`` on a rotary motor).
ROTARY_SCHEMA = "pgcomm.rotary_model"
#: Most orders one map of a rotary model file may hold (bounds what a file can make us allocate; an identified
#: map has tens to a few hundred).
MAX_ROTARY_ORDERS = 100_000
#: Points per revolution on which a rotary model's ripple is checked (as identification checks it).
_RIPPLE_GRID = 4096


def rotary_model_from_dict(doc, path):
    """A :class:`pgcomm.rotary.model.RotaryModel` from a rotary model file's JSON ``doc``, checked for plausibility.

    A rotary model is in current units (module :mod:`pgcomm.rotary.model`). Refused with one line naming the
    file and the key: another schema; ``pole_pairs`` outside the motor TOML's range
    (:data:`pgcomm.io.config.ROTARY_PLAUSIBLE`); a map (``cogging``, ``ripple``, ``direction``) whose orders are not
    distinct non-negative integers (the ripple has no order 0: it is relative to the mean) or whose coefficients are
    not finite; a cogging or drag whose RMS exceeds the motor's current limit (the model's ``info.current_limit``,
    else the largest plausible limit): no drive could apply its compensation; a ripple whose torque constant falls
    below :data:`pgcomm.rotary.law.MIN_GAIN` of its mean somewhere (identification refuses the same);
    a ``k_t`` outside the motor TOML's range, a non-positive ``inertia_ratio`` or a non-finite ``viscous``.

    Args:
        doc: the parsed JSON; path: the file (named in errors).

    Raises:
        DataError: the problem, on one line.
    """
    if not isinstance(doc, dict) or doc.get("schema") != ROTARY_SCHEMA:
        what = doc.get("schema") if isinstance(doc, dict) else None
        raise DataError(f"{path}: not a rotary model (schema {what!r}, expected {ROTARY_SCHEMA!r}: the model.json of "
                        "pgcomm identify on a rotary motor)")

    def number(key, value, lo=None, hi=None, unit="", optional=False):
        if value is None and optional:
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise DataError(f"{path}: {key} = {value!r} is not a finite number{(' in ' + unit) if unit else ''}")
        if (lo is not None and not value >= lo) or (hi is not None and not value <= hi):
            raise DataError(f"{path}: {key} = {value!r}{(' ' + unit) if unit else ''} is implausible (expected "
                            f"{lo:g} to {hi:g}{(' ' + unit) if unit else ''})")
        return float(value)

    pp = doc.get("pole_pairs")
    lo, hi, _ = ROTARY_PLAUSIBLE["pole_pairs"]
    if isinstance(pp, bool) or not isinstance(pp, int) or not lo <= pp <= hi:
        raise DataError(f"{path}: pole_pairs = {pp!r} is implausible (expected an integer from {lo} to {hi})")
    info = doc.get("info", {})
    if not isinstance(info, dict):
        raise DataError(f"{path}: info must be a JSON object, found {type(info).__name__}")
    lo, hi, unit = ROTARY_PLAUSIBLE["current_limit"]
    limit = number("info.current_limit", info.get("current_limit"), 0.0, hi, unit, optional=True)
    if limit is not None and limit <= 0:
        raise DataError(f"{path}: info.current_limit = {limit!r} A: expected a positive current")

    maps = {}
    for key, unit in (("cogging", "A"), ("ripple", "-"), ("direction", "A")):
        m = doc.get(key)
        if not isinstance(m, dict) or not all(isinstance(m.get(f), list) for f in ("orders", "cos", "sin")):
            raise DataError(f"{path}: {key} must be an object with lists orders, cos, sin")
        orders, cos, sin = m["orders"], m["cos"], m["sin"]
        if not (len(orders) == len(cos) == len(sin)) or len(orders) > MAX_ROTARY_ORDERS:
            raise DataError(f"{path}: {key}: {len(orders)} orders, {len(cos)} cos and {len(sin)} sin coefficients; "
                            f"expected as many of each (at most {MAX_ROTARY_ORDERS})")
        for i, h in enumerate(orders):
            if isinstance(h, bool) or not isinstance(h, int) or h < (1 if key == "ripple" else 0):
                least = "1 (the ripple is relative to the mean torque constant: no order 0)" if key == "ripple" else "0"
                raise DataError(f"{path}: {key}.orders[{i}] = {h!r}: expected an integer harmonic per revolution of "
                                f"at least {least}")
        if len(set(orders)) != len(orders):
            raise DataError(f"{path}: {key}.orders repeats an order")
        for f, vals in (("cos", cos), ("sin", sin)):
            for i, v in enumerate(vals):
                number(f"{key}.{f}[{i}]", v, unit=unit)
        maps[key] = Fourier(np.asarray(orders, int), np.stack([np.asarray(cos, float), np.asarray(sin, float)],
                                                               axis=1).reshape(len(orders), 2))
    bound = limit if limit is not None else ROTARY_PLAUSIBLE["current_limit"][1]
    for key in ("cogging", "direction"):
        rms = maps[key].rms()
        if rms > bound:
            raise DataError(f"{path}: {key} RMS {rms:.4g} A exceeds the current limit {bound:g} A "
                            f"({'info.current_limit' if limit is not None else 'the largest plausible'}): no drive "
                            "can apply its compensation; not a model of a motor")
    rip = maps["ripple"]
    th = 2.0 * math.pi * np.arange(_RIPPLE_GRID) / _RIPPLE_GRID
    r = np.zeros(1)
    if np.sum(np.hypot(rip.coef[:, 0], rip.coef[:, 1])) > 1.0 - MIN_GAIN:  # only then can the peak be too large
        step = 1000  # orders per block: bounds the harmonic rows' memory
        r = sum(Fourier(rip.orders[i:i + step], rip.coef[i:i + step])(th) for i in range(0, rip.orders.size, step))
    j = int(np.argmax(np.abs(r)))
    if abs(r[j]) > 1.0 - MIN_GAIN:
        raise DataError(f"{path}: ripple: the torque constant varies by {100 * r[j]:+.0f} % of its mean at "
                        f"{th[j]:.3f} rad; a motor's ripple is a few per cent and the law refuses below "
                        f"{100 * MIN_GAIN:.0f} % (identification refuses the same)")
    viscous = number("viscous", doc.get("viscous", 0.0), unit="A s/rad")
    ratio = doc.get("inertia_ratio")
    if ratio is not None:
        ratio = number("inertia_ratio", ratio, unit="A s^2/rad")
        if not ratio > 0:
            raise DataError(f"{path}: inertia_ratio = {ratio!r} A s^2/rad: expected a positive J/k0")
    lo, hi, unit = ROTARY_PLAUSIBLE["k_t"]
    k_t = number("k_t", doc.get("k_t"), lo, hi, unit, optional=True)
    return RotaryModel(pp, maps["cogging"], maps["ripple"], maps["direction"], viscous, ratio, k_t, info)


def load_rotary_model(path):
    """Read a rotary model file (:func:`rotary_model_from_dict`; the JSON at most :data:`MAX_JSON_BYTES`).

    Raises:
        DataError: missing, unreadable or implausible file (one line naming the file and key).
    """
    path = Path(path)
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        raise DataError(f"{path}: file not found") from None
    except OSError as e:
        raise DataError(f"{path}: cannot read ({e.strerror})") from None
    if size > MAX_JSON_BYTES:
        raise DataError(f"{path}: {size} bytes is far more than a rotary model needs; not a model file")
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError) as e:
        raise DataError(f"{path}: not a JSON model file ({' '.join(str(e).split())[:200]})") from None
    return rotary_model_from_dict(doc, path)
