"""The fleet's figures (:mod:`pgcomm.plots`): one QA quantity's distribution over the fleet, outliers marked."""

from __future__ import annotations

import numpy as np

from pgcomm.plots.figure import plt

__all__ = ["plot_quantity_histogram"]


def plot_quantity_histogram(values, outliers, label: str, title: str):
    """A histogram of one QA quantity over the fleet's coil sets, each outlier's value a red line.

    Args:
        values: ``(N,)`` finite values; outliers: ``(K,)`` the outliers' values; label: the axis' label (with
            its unit); title: the figure's title.

    Returns:
        the figure.
    """
    x = np.asarray(values, dtype=float)
    fig, ax = plt.subplots(figsize=(6, 3))
    if x.size:
        ax.hist(x, bins=max(5, min(40, int(np.sqrt(x.size)) * 2)), color="0.6")
        for v in outliers:
            ax.axvline(v, color="C3", lw=1)
    ax.set_xlabel(label)
    ax.set_ylabel("coil sets")
    ax.set_title(title)
    fig.tight_layout()
    return fig
