"""The C text every generated law shares: the precision's spelling of numbers, identifiers, and the finite test.

Free of JAX, so the exports that need no model (the angle tables, the rotary law, the options of ``pgcomm export``)
load without it; :mod:`pgcomm.export.c`, :mod:`pgcomm.export.lut`, :mod:`pgcomm.export.angle_lut` and
:mod:`pgcomm.export.rotary_law` write their C with it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

__all__ = ["PRECISIONS", "CNumbers", "DOUBLE", "SINGLE", "macro_literal", "check_c_name", "ieee_finite"]

#: Accepted ``precision`` values.
PRECISIONS = ("double", "single")

_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


@dataclass(frozen=True)
class CNumbers:
    """Precision-specific spelling: C type, literal formatter, math function names."""

    ctype: str
    single: bool

    def lit(self, x) -> str:
        """A C literal that round-trips ``x`` in this precision."""
        x = float(x)
        if not math.isfinite(x):
            raise ValueError(f"cannot export a non-finite number ({x}) to C")
        if self.single:
            s = "%.9g" % float(np.float32(x))
        else:
            s = "%.17g" % x
        if "." not in s and "e" not in s and "n" not in s:
            s += ".0"  # "1f" is not a C literal; "1.0f" is
        return s + ("f" if self.single else "")

    def fn(self, name: str) -> str:
        """``sin`` -> ``sinf`` in single precision."""
        return name + "f" if self.single else name


DOUBLE = CNumbers("double", False)
SINGLE = CNumbers("float", True)


def macro_literal(literal: str) -> str:
    """A literal for a ``#define``: parenthesised when negative, so the macro is one operand anywhere."""
    return f"({literal})" if literal.startswith("-") else literal


def check_c_name(name: str) -> str:
    """``name`` if it is a usable C identifier prefix, else ``ValueError``.

    Names starting with an underscore are reserved in C and refused too.
    """
    if not isinstance(name, str) or not _IDENT.match(name) or name.startswith("_"):
        raise ValueError(f"name {name!r} is not a C identifier "
                         "(letters, digits, '_', not starting with a digit or '_')")
    return name


def ieee_finite(text: str, name: str, single: bool) -> str:
    """Generated C ``text`` with every ``isfinite(x)`` replaced by ``NAME_finite(x)``, a test on the IEEE-754 bits.

    ``-ffast-math`` (and ``-Ofast``, ``-ffinite-math-only``) lets a compiler assume that no value is NaN or inf, and
    GCC and Clang then fold ``isfinite`` to 1: the guards vanish, a NaN angle becomes a wild table index
    (a segfault) and a NaN demand NaN currents. An integer test of the exponent bits (all ones: NaN or inf),
    read through ``memcpy``, is not a floating-point operation and survives those flags. The test function
    (``static inline``, for ``float`` when ``single``, else ``double``) is inserted after ``#include <math.h>``
    with ``<stdint.h>`` and ``<string.h>``; ``text`` must include ``<math.h>`` when it uses ``isfinite``.
    """
    if "isfinite(" not in text:
        return text
    fn = f"{name}_finite"
    if single:
        body = (f"static inline int {fn}(float x)\n{{\n    uint32_t b;\n    memcpy(&b, &x, sizeof b);\n"
                "    return (b & UINT32_C(0x7f800000)) != UINT32_C(0x7f800000);\n}\n\n")
    else:
        body = (f"static inline int {fn}(double x)\n{{\n    uint64_t b;\n    memcpy(&b, &x, sizeof b);\n"
                "    return (b & UINT64_C(0x7ff0000000000000)) != UINT64_C(0x7ff0000000000000);\n}\n\n")
    helper = ("#include <stdint.h>\n#include <string.h>\n\n"
              "/* 1 unless x is NaN or inf: a test of the IEEE-754 exponent bits, which -ffast-math cannot fold\n"
              "   away, as it may fold the classification macros of math.h */\n" + body)
    anchor = "#include <math.h>\n\n"
    if anchor not in text:
        raise ValueError("generated C without #include <math.h>: cannot place the finite test")
    text = text.replace(anchor, anchor + helper, 1)
    head, _, tail = text.partition(helper)
    return head + helper + tail.replace("isfinite(", f"{fn}(")
