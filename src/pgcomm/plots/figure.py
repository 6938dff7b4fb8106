"""What every figure shares: Matplotlib on the non-interactive Agg backend (no display needed), and saving.

This module is the one place that imports Matplotlib (:mod:`pgcomm.plots`).
"""

from __future__ import annotations

import io

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)

from pgcomm.io.atomic import atomic_path  # noqa: E402

__all__ = ["plt", "save", "png_bytes"]


def save(fig, path) -> None:
    """Save ``fig`` as PNG at ``path`` (atomically) and close it.

    Every figure lays itself out (``tight_layout``) where it is drawn, so the page is saved as laid out:
    ``bbox_inches="tight"`` would draw each figure twice (once to measure it), which doubled the time a run
    spends on its figures.
    """
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


def png_bytes(fig, dpi: int = 90) -> bytes:
    """``fig`` as PNG bytes (for a page that embeds it), and close it."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    return buf.getvalue()
