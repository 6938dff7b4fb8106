"""Frozen dataclasses that are JAX pytrees (arrays are leaves, ``static`` fields are metadata)."""

from __future__ import annotations

import dataclasses

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax


def static_field(**kwargs):
    """A dataclass field that is pytree metadata (hashable, not traced)."""
    return dataclasses.field(metadata={"static": True}, **kwargs)


def pytree_dataclass(cls):
    """Decorate ``cls`` as a frozen dataclass registered as a pytree.

    Fields declared with :func:`static_field` become metadata; all others are
    children, so a jitted function taking such an object recompiles only when
    the static fields or the array shapes change, not when values change.
    """
    cls = dataclasses.dataclass(frozen=True)(cls)
    fields = dataclasses.fields(cls)
    meta = [f.name for f in fields if f.metadata.get("static", False)]
    data = [f.name for f in fields if not f.metadata.get("static", False)]
    return jax.tree_util.register_dataclass(cls, data_fields=data, meta_fields=meta)
