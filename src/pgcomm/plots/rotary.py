"""Figures of a rotary motor (:mod:`pgcomm.plots`): its maps as identified from running logs, and a rotary
``reproduce``'s identification and tracking. Angles in rad (mechanical), currents in A, the ripple in %.
"""

from __future__ import annotations

import numpy as np

from pgcomm.plots.figure import plt
from pgcomm.rotary.model import Fourier

__all__ = ["plot_rotary_maps", "plot_rotary_run"]


def plot_rotary_maps(model, identification, motor_name: str, n: int = 3600, sweep=None, static=()):
    """The identified maps over one revolution, each with its standard error as a band where known; the
    table of a logged standstill sweep (``sweep``, :class:`pgcomm.rotary.standstill.SweepTable`) and the drive's own
    static maps with their combination (``static``) beside the model's, and the ripple the logged q-voltage measures
    beside the currents' (:mod:`pgcomm.rotary.back_emf`).

    Args:
        model: :class:`pgcomm.rotary.model.RotaryModel` (current units).
        identification: :class:`pgcomm.rotary.identify.RotaryIdentification` (its standard errors and back-EMF).
        motor_name: for the title; n: points over the revolution.
        static: ``(name, combined (m,) A, map aligned (m,) A)`` per static map, on ``2π j / m``
            (:func:`pgcomm.rotary.static_map.combine`).

    Returns:
        the figure: cogging (A), ripple (%), direction term (A) over ``(n,)`` angles.
    """
    th = 2 * np.pi * np.arange(n) / n
    se = identification.standard_error or {}
    panels = (("cogging", "compensating q current", "A", 1.0, model.table(n)),
              ("ripple", "torque-constant ripple", "%", 100.0, model.ripple(th)),
              ("direction", "direction-dependent torque", "A", 1.0, model.direction(th)))
    fig, ax = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    voltage = identification.back_emf or {}
    for a, (key, label, unit, scale, values) in zip(ax, panels):
        a.plot(th, scale * values, lw=0.7, label="identified" + (" (forward and reverse averaged)"
                                                                 if key == "cogging" else ""))
        if key in se and se[key].get("determined") is False:
            a.set_title(f"{label}: not determined by these logs ({se[key]['pinned']})", fontsize=9)
        elif key in se:
            band = scale * se[key]["rms_error"]
            a.fill_between(th, scale * values - band, scale * values + band, alpha=0.25, lw=0,
                           label=f"± standard error ({100 * se[key]['relative']:.1f} % of its RMS)")
        if key == "ripple" and voltage.get("ripple"):
            rel = voltage["ripple_rms_error"] / voltage["ripple_rms"] if voltage["ripple_rms"] > 0 else float("inf")
            a.plot(th, scale * Fourier.from_dict(voltage["ripple"])(th), "k--", lw=0.6, alpha=0.7,
                   label=f"from the q-voltage's back-EMF (standard error {100 * rel:.0f} % of its RMS; "
                         f"{'agrees' if voltage['consistent'] else 'disagrees'})")
        if key == "cogging":
            a.plot(th, model.table(n, +1), lw=0.5, alpha=0.7, label="forward")
            a.plot(th, model.table(n, -1), lw=0.5, alpha=0.7, label="reverse")
            if sweep is not None:
                a.plot(sweep.theta, sweep.table, "k", lw=0.4, alpha=0.6,
                       label=f"standstill sweep ({sweep.seconds:.0f} s of rig time)")
            for name, combined, aligned in static:
                grid = 2 * np.pi * np.arange(np.size(aligned)) / np.size(aligned)
                a.plot(grid, aligned, "k--", lw=0.4, alpha=0.6, label=f"drive's static map {name} (index aligned)")
                a.plot(grid, combined, lw=0.6, alpha=0.8, label=f"{name} and the identified table as one")
        a.set_ylabel(f"{label} [{unit}]", fontsize=8)
        a.legend(fontsize=7, loc="upper right")
    ax[-1].set_xlabel("mechanical angle θ [rad]")
    fig.suptitle(f"rotary {motor_name}: maps identified from running logs")
    fig.tight_layout()
    return fig


def plot_rotary_run(table, model, truth_model, tracking_mse: dict, motor_name: str):
    """A rotary ``reproduce``: the standstill table, the identified model's and the truth's compensation; the
    identified and true ripple; each row's tracking MSE over classical commutation's.

    Args:
        table: ``(n,)`` the standstill sweep's table (A) at ``θ_j = 2π j / n``.
        model, truth_model: :class:`pgcomm.rotary.model.RotaryModel` identified and true.
        tracking_mse: ``{row: {"position": rad², "speed": (rad/s)²}}`` with a ``classical`` row.
        motor_name: for the title.

    Returns:
        the figure (three panels).
    """
    n = table.size
    th = 2 * np.pi * np.arange(n) / n
    fig, ax = plt.subplots(3, 1, figsize=(10, 9))
    ax[0].plot(th, table, lw=0.6, label="standstill table (drives' method)")
    ax[0].plot(th, model.table(n), lw=0.8, label="model from running logs")
    ax[0].plot(th, truth_model.table(n), "k--", lw=0.6, label="truth")
    ax[0].set_ylabel("compensating $i_q$ [A]")
    ax[0].legend(fontsize=8)
    ax[1].plot(th, 100 * model.ripple(th), label="identified")
    ax[1].plot(th, 100 * truth_model.ripple(th), "k--", label="truth")
    ax[1].set_ylabel("torque-constant ripple [%]")
    ax[1].set_xlabel("mechanical angle θ [rad]")
    ax[1].legend(fontsize=8)
    rows = list(tracking_mse)
    x = np.arange(len(rows))
    for k, loop in enumerate(("position", "speed")):
        vals = [tracking_mse[r][loop] / tracking_mse["classical"][loop] for r in rows]
        ax[2].bar(x + 0.4 * k, vals, 0.4, label=f"{loop} loop")
    ax[2].set_xticks(x + 0.2, rows)
    ax[2].set_yscale("log")
    ax[2].set_ylabel("tracking MSE / classical")
    ax[2].legend(fontsize=8)
    fig.suptitle(f"rotary {motor_name}: identification and tracking")
    fig.tight_layout()
    return fig
