"""Figures of a linear motor's runs, data, calibration, identification and logs (:mod:`pgcomm.plots`)."""

from __future__ import annotations

import numpy as np

from pgcomm.excitation import problem_runs
from pgcomm.metrics import lowpass
from pgcomm.plots.figure import plt

#: One colour per comparison row, stable across figures.
ROW_COLORS = {"original": "#9e9e9e", "classical": "#d62728", "physics": "#ff7f0e", "pgnn": "#1f77b4",
              "pgnn_direction": "#17becf", "spline": "#2ca02c", "pgnn_sensorless": "#9467bd", "cogging_table": "#8c564b",
              "cogging_table_sensorless": "#bcbd22", "harmonic_cogging": "#e377c2", "oracle": "#000000"}
_DIR_LABEL = ("$F_y - F_y^*$ [N]", "$F_x - F_x^*$ [N]", "$T_z - T_z^*$ [N m]")


def plot_run(result, lowpass_hz: float = 50.0, title: str = ""):
    """One closed-loop run: reference, filtered commutation error in y, x, z, tracking error, currents."""
    t = result.t
    err = lowpass(result.commutation_error, result.sample_time, lowpass_hz)
    fig, ax = plt.subplots(6, 1, figsize=(10, 11), sharex=True)
    ax[0].plot(t, result.r * 1e3, label="$r$")
    ax[0].plot(t, result.y * 1e3, "--", label="$y$")
    ax[0].set_ylabel("position [mm]")
    ax[0].legend(loc="upper right")
    for q in range(3):
        ax[q + 1].plot(t, err[:, q], lw=0.8)
        ax[q + 1].set_ylabel(_DIR_LABEL[q])
    ax[4].plot(t, result.e * 1e6, lw=0.8)
    ax[4].set_ylabel("tracking error [µm]")
    cur = result.currents
    for l in range(cur.shape[1]):
        ax[5].plot(t, cur[:, l, 0], lw=0.6, label=f"$i_a^{l + 1}$")
    ax[5].set_ylabel("current [A]")
    ax[5].set_xlabel("time [s]")
    ax[5].legend(loc="upper right", ncol=cur.shape[1])
    ax[1].set_title(f"commutation error, {lowpass_hz:g} Hz low-pass" + (f" — {title}" if title else ""))
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def plot_comparison(runs: dict, lowpass_hz: float = 50.0, title: str = ""):
    """The paper's Figs. 10 and 11 (slow and fast reference): reference, filtered commutation error
    y, x, z and tracking error, every row of ``runs`` (name -> SimResult) overlaid."""
    first = next(iter(runs.values()))
    # filter at full rate, draw at most ~5000 points per line (the figure cannot show more)
    k = _stride(first.t.shape[0])
    t = first.t[::k]
    fig, ax = plt.subplots(5, 1, figsize=(10, 10), sharex=True)
    ax[0].plot(t, first.r[::k] * 1e3, color="k")
    ax[0].set_ylabel("$y^*$ [mm]")
    for name, res in runs.items():
        err = lowpass(res.commutation_error, res.sample_time, lowpass_hz)[::k]
        draw_error_lines(ax, t, err, res.e[::k], ROW_COLORS.get(name), name)
    ax[1].legend(loc="upper right", ncol=min(4, len(runs)), fontsize=8)
    finish_error_axes(fig, ax, title)
    return fig


def _stride(n: int) -> int:
    """Every how many samples a line of ``n`` samples is drawn: about 5000 points (a figure cannot show more)."""
    return max(1, n // 5000)


def _filtered_every(x, sample_time: float, lowpass_hz: float, k: int) -> np.ndarray:
    """``lowpass(x)[::k]`` of ``x`` ``(N, m)``, filtered column by column (one filtered column in memory at a time)."""
    return np.stack([lowpass(x[:, q], sample_time, lowpass_hz)[::k] for q in range(x.shape[1])], axis=-1)


def draw_error_lines(ax, t, err_filtered, e, color, label) -> None:
    """One run on the 5-panel comparison axes: filtered ``F - F*`` (N, 3) in panels 1-3 and
    the tracking error ``e`` (N,) in m (or ``None``) in panel 4, in µm."""
    for q in range(3):
        ax[q + 1].plot(t, err_filtered[:, q], lw=0.7, color=color, label=label)
    if e is not None:
        ax[4].plot(t, e * 1e6, lw=0.8, color=color, label=label)


def finish_error_axes(fig, ax, title: str = "") -> None:
    """Labels, grid and layout of the 5-panel comparison axes."""
    for q in range(3):
        ax[q + 1].set_ylabel(_DIR_LABEL[q])
    ax[4].set_ylabel("$y^* - y$ [µm]")
    ax[4].set_xlabel("time [s]")
    if title:
        ax[0].set_title(title)
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()


def plot_reference(reference, title: str = "data-generation reference"):
    """The paper's Fig. 8 (reference for the data sets): the reference position (mm) and velocity (m/s)."""
    fig, ax = plt.subplots(2, 1, figsize=(10, 4.5), sharex=True)
    ax[0].plot(reference.t, reference.r * 1e3)
    ax[0].set_ylabel("$y^*$ [mm]")
    ax[0].set_title(title)
    ax[1].plot(reference.t, reference.v)
    ax[1].set_ylabel("$\\dot y^*$ [m/s]")
    ax[1].set_xlabel("time [s]")
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def plot_calibration(k_initial, zeta_initial, k_cal, zeta_cal, k_true=None, zeta_true=None):
    """The paper's Table 1 as a figure: initial, calibrated and (twin) true ``k̂^l`` (N/A), ``ζ̂^l`` (rad) per
    coil set."""
    n = len(k_cal)
    x = np.arange(1, n + 1)
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    for a, init, cal, true, lab in ((ax[0], k_initial, k_cal, k_true, "$\\hat k^l$ [N/A]"),
                                    (ax[1], zeta_initial, zeta_cal, zeta_true, "$\\hat\\zeta^l$ [rad]")):
        a.plot(x, np.broadcast_to(init, (n,)), "s", color="#9e9e9e", label="initial")
        a.plot(x, cal, "o", color="#d62728", label="calibrated")
        if true is not None:
            a.plot(x, true, "x", color="#2ca02c", ms=10, label="true")
        a.set_xticks(x)
        a.set_xlabel("coil set $l$")
        a.set_ylabel(lab)
        a.grid(alpha=0.3)
    ax[0].legend()
    fig.suptitle("Algorithm 1: data-based calibration")
    fig.tight_layout()
    return fig


def plot_cogging(y, cog_model, cog_true=None, title="identified cogging force", label="PGNN"):
    """The paper's Fig. 9 (identified cogging force): ``(1/L) Σ_l F̂_cog^l(y)`` in y, x, z, against the
    truth when known.

    Args:
        y: (N,) m; cog_model: (N, 3) (N, N, N·m); cog_true: (N, 3) or None; label: the model's legend entry.
    """
    fig, ax = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    labels = ("$F_{cog,y}$ [N]", "$F_{cog,x}$ [N]", "$T_{cog,z}$ [N m]")
    for q in range(3):
        ax[q].plot(y * 1e3, cog_model[:, q], color="#1f77b4", label=label)
        if cog_true is not None:
            ax[q].plot(y * 1e3, cog_true[:, q], "--", color="#2ca02c", label="truth")
        ax[q].set_ylabel(labels[q])
        ax[q].grid(alpha=0.3)
    ax[0].legend()
    ax[0].set_title(title)
    ax[2].set_xlabel("position $y$ [mm]")
    fig.tight_layout()
    return fig


def plot_gain_columns(y, gain_model, gain_true=None, coil_set: int = 0, label: str = "model"):
    """Gain-matrix columns ``K̂^l(y)`` (3 x 2 panels) of one coil set against the truth when known.

    Args:
        y: (N,) m; gain_model, gain_true: (N, 3, 2) (N/A; N·m/A in the Tz row); label: the model's legend
            entry and title word (e.g. ``"PGNN"``).
    """
    fig, ax = plt.subplots(3, 2, figsize=(11, 7), sharex=True)
    rows = ("$F_y$", "$F_x$", "$T_z$")
    units = ("[N/A]", "[N/A]", "[N m/A]")
    for q in range(3):
        for j in range(2):
            a = ax[q, j]
            a.plot(y * 1e3, gain_model[:, q, j], color="#1f77b4", lw=0.9, label=label)
            if gain_true is not None:
                a.plot(y * 1e3, gain_true[:, q, j], "--", color="#2ca02c", lw=0.9, label="truth")
            a.set_title(f"{rows[q]} per $i_{'ab'[j]}^{coil_set + 1}$", fontsize=9)
            a.set_ylabel(f"{rows[q]} per A {units[q]}", fontsize=8)
            a.grid(alpha=0.3)
    ax[0, 0].legend(fontsize=8)
    for j in range(2):
        ax[2, j].set_xlabel("position $y$ [mm]")
    fig.suptitle(f"gain of coil set {coil_set + 1}: {label}" + (" against the truth" if gain_true is not None else ""))
    fig.tight_layout()
    return fig


def plot_mse_bars(table: dict, title: str = "commutation-error MSE (filtered)"):
    """Bar chart of ``table[row][dir]`` (log scale), one group per direction."""
    rows = list(table)
    dirs = ("y", "x", "z")
    fig, ax = plt.subplots(1, 3, figsize=(12, 3.8))
    for q, d in enumerate(dirs):
        vals = [table[r][d] for r in rows]
        ax[q].bar(range(len(rows)), vals, color=[ROW_COLORS.get(r, "k") for r in rows])
        ax[q].set_xticks(range(len(rows)))
        ax[q].set_xticklabels(rows, rotation=40, ha="right", fontsize=8)
        ax[q].set_yscale("log")
        ax[q].set_title(f"{d}  [{'N²m²' if d == 'z' else 'N²'}]")
        ax[q].grid(alpha=0.3, axis="y")
    fig.suptitle(title)
    fig.tight_layout()
    return fig


# --------------------------------------------------------------------- rig logs (pgcomm evaluate)

_MODEL_LABEL = ("$F_y - \\hat F_y$ [N]", "$F_x - \\hat F_x$ [N]", "$T_z - \\hat T_z$ [N m]")


def _colors(n):
    cycle = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    return [cycle[i % len(cycle)] for i in range(n)]


def plot_logs(evaluations, title: str = ""):
    """All logs overlaid: position, filtered commutation error in y, x, z, tracking error.

    The layout of :func:`plot_comparison`, one line per log (legend: its name,
    :attr:`pgcomm.evaluation.LogEvaluation.label`); the first panel shows ``r`` where logged, else the logged position
    ``y`` (dashed). Logs without a desired force have no commutation-error line (said in the panel
    when none has one). Returns a Matplotlib figure.
    """
    fig, ax = plt.subplots(5, 1, figsize=(10, 10), sharex=True)
    for ev, c in zip(evaluations, _colors(len(evaluations))):
        k = _stride(ev.t.shape[0])  # filtered at full rate, drawn at ~5000 points per line (as plot_comparison)
        t = ev.t[::k]
        e = None if ev.e is None else ev.e[::k]
        if ev.r is not None:
            ax[0].plot(t, ev.r[::k] * 1e3, lw=0.9, color=c, label=ev.label)
        else:
            ax[0].plot(t, ev.y[::k] * 1e3, "--", lw=0.9, color=c, label=f"{ev.label} (y)")
        if ev.reconstructed is not None:  # y only, on the reconstruction's windows
            rc = ev.reconstructed
            if rc.error is not None:
                ax[1].plot(rc.t, rc.error, lw=0.7, color=c, label=f"{ev.label} (reconstructed)")
            if e is not None:
                ax[4].plot(t, e * 1e6, lw=0.8, color=c, label=ev.label)
            continue
        if ev.commutation_error is None:  # no desired force logged: tracking only
            if e is not None:
                ax[4].plot(t, e * 1e6, lw=0.8, color=c, label=ev.label)
            continue
        draw_error_lines(ax, t, _filtered_every(ev.commutation_error, ev.sample_time, ev.lowpass_hz, k), e, c,
                         ev.label)
    if any(ev.force_reconstructed for ev in evaluations):
        for q in (2, 3):
            ax[q].text(0.5, 0.9, "force reconstructed from the motion: x, z not observable (n/a)",
                       transform=ax[q].transAxes, ha="center", va="top", fontsize=8)
    if evaluations and all(ev.commutation_mse["y"]["filtered"] is None for ev in evaluations):
        ax[1].text(0.5, 0.5, "no desired force F* logged: commutation error not available (see the model error)",
                   transform=ax[1].transAxes, ha="center", va="center")
    ax[0].set_ylabel("$y^*$ [mm]")
    if not any(ev.e is not None for ev in evaluations):
        ax[4].text(0.5, 0.5, "no reference r logged: tracking error not available", transform=ax[4].transAxes,
                   ha="center", va="center")
    ax[0].legend(loc="upper right", ncol=min(4, len(evaluations)), fontsize=8)
    lp = evaluations[0].lowpass_hz if evaluations else 50.0
    n_rec = sum(ev.force_reconstructed for ev in evaluations)
    title1 = ("commutation error, Fy reconstructed from the motion, zero-phase filtered windows"
              if evaluations and n_rec == len(evaluations) else
              f"commutation error, {lp:g} Hz low-pass" + (" (reconstructed: filtered windows)" if n_rec else ""))
    ax[1].set_title(title1, fontsize=10)
    finish_error_axes(fig, ax, title)
    return fig


def plot_model_error(evaluations, title: str = "model error F - F̂(y, i)"):
    """Filtered model error ``F − F̂(y, i)`` in y, x, z, one line per log with a model fit."""
    evs = [ev for ev in evaluations if ev.model_error is not None or ev.window_model_error is not None]
    fig, ax = plt.subplots(3, 1, figsize=(10, 7), sharex=True)
    for ev, c in zip(evs, _colors(len(evs))):
        if ev.window_model_error is not None:  # reconstructed force: y on its windows only
            ax[0].plot(ev.reconstructed.t, ev.window_model_error, lw=0.7, color=c, label=f"{ev.label} (reconstructed)")
            continue
        k = _stride(ev.t.shape[0])
        err = _filtered_every(ev.model_error, ev.sample_time, ev.lowpass_hz, k)
        for q in range(3):
            ax[q].plot(ev.t[::k], err[:, q], lw=0.7, color=c, label=ev.label)
    for q in range(3):
        ax[q].set_ylabel(_MODEL_LABEL[q])
        ax[q].grid(alpha=0.3)
    ax[2].set_xlabel("time [s]")
    if evs:
        ax[0].legend(loc="upper right", ncol=min(4, len(evs)), fontsize=8)
    lp = evs[0].lowpass_hz if evs else 50.0
    ax[0].set_title(f"{title}, {lp:g} Hz low-pass", fontsize=10)
    fig.tight_layout()
    return fig


# ------------------------------------------------------------------- excitation (pgcomm check)

def plot_coverage(report):
    """Coverage figure of an :class:`pgcomm.excitation.ExcitationReport`: per coil set, samples per position bin stacked by ``Δ`` sign; bins with problems shaded.

    Returns a Matplotlib figure (one row of axes per coil set; positions in mm).
    """
    n = len(report.coil_sets)
    fig, axes = plt.subplots(n, 1, figsize=(10, 2.4 * n + 0.6), sharex=True, squeeze=False)
    lo, hi = report.y_range
    colors = {"Δ < 0": "#1f77b4", "Δ ≈ 0": "#7f7f7f", "Δ > 0": "#ff7f0e", "no current": "#d9d9d9"}
    for ax, cs in zip(axes[:, 0], report.coil_sets):
        status = "ok" if cs.ok else f"{len(cs.problems)} problem(s)"
        ax.set_title(f"coil set {cs.coil_set + 1}: {status}", fontsize=10, loc="left",
                     color="k" if cs.ok else "#d62728")
        ax.set_ylabel("samples")
        ax.grid(alpha=0.3, axis="y")
        if cs.bins is None:
            ax.text(0.5, 0.5, "no log with this coil set active", transform=ax.transAxes, ha="center",
                    va="center", color="#d62728")
            continue
        b = cs.bins
        left, width = b.edges[:-1] * 1e3, np.diff(b.edges) * 1e3
        bottom = np.zeros(len(left))
        for (label, c), v in zip(colors.items(), (b.delta_negative, b.delta_zero, b.delta_positive, b.no_current)):
            ax.bar(left, v, width=width, bottom=bottom, align="edge", color=c, edgecolor="white", lw=0.3,
                   label=label)
            bottom = bottom + v
        ax.set_ylim(0, 1.25 * max(float(bottom.max()), 1.0))  # headroom for the problem labels
        for first, last, kind in problem_runs(b.problem):
            ax.axvspan(b.edges[first] * 1e3, b.edges[last + 1] * 1e3, color="#d62728", alpha=0.15, lw=0)
            ax.text((b.edges[first] + b.edges[last + 1]) * 0.5e3, 0.96, kind, transform=ax.get_xaxis_transform(),
                    ha="center", va="top", fontsize=8, color="#d62728")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    if not handles:  # no coil set had data
        handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in colors.values()]
        labels = list(colors)
    axes[-1, 0].set_xlabel("position $y$ [mm]")
    axes[-1, 0].set_xlim(lo * 1e3, hi * 1e3)
    fig.suptitle(f"excitation: samples per position bin ({report.n_bins} bins) by sign of Δ; "
                 "shaded bins lack excitation", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 0.965), ncol=4, fontsize=8, frameon=False)
    return fig
