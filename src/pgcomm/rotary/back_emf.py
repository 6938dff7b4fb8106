"""The torque-constant ripple from the logged q-voltage: the back-EMF is the torque constant seen from the winding.

The power the magnets exchange with the winding is ``(3/2) e_q i_q = T_em ω`` (:mod:`pgcomm.rotary.winding`), so the
q-axis back-EMF carries the same relative ripple as the torque constant::

    v_q = R i_q + L di_q/dt + κ (1 + r(θ)) ω + v_0 + Σ_m d_m g_m(i_q, pθ) + noise

``κ`` the back-EMF constant (V·s/rad; ``(2/3) k0`` in the amplitude-invariant frame), ``r`` the ripple of
:mod:`pgcomm.rotary.regression`'s model, ``v_0`` a voltage offset, and ``g_m`` the inverter's dead time that the
drive's compensation leaves: each phase loses a voltage that is an odd, saturating function of its own current,
``tanh(i_ph/c_m)`` over a few widths ``c_m`` (the zero crossing's width is the PWM ripple, which the logs do not
show), projected on the drive's q axis. It carries the sixth electrical harmonic but does not scale with the speed,
so logs at two speeds tell it from the back-EMF's own harmonics at ``6p``. The model is linear in
``(R, L, κ, κ r_h, v_0, d_m)``: instrumental-variable least squares at every sample (the current's columns
instrumented by samples on either side, whose noise the voltage and the regressors do not carry, :func:`_log_rows`),
``ω`` and ``di_q/dt`` from central differences of the logged angle and current, and ``r_h = (κ r_h)/κ`` (``κ`` is
resolved far better than its ripple: the delta method's covariance). The covariance is the sandwich over time blocks
(one second, as the current's regression has them, shorter where the logs are short: :data:`BLOCKS_PER_UNKNOWN`).

**Why it matters.** The current's regression sees the ripple only through q-current that varies at a given angle
(``r(θ) i_q``): a dither or accelerations, which a free light rotor carries only briefly. The back-EMF shows the
ripple at every sample of a constant-speed run, and the faster the run, the larger it is; it needs no acceleration
and no alias guard (the relation holds at each sample instant). At the running logs' speeds, which the currents'
alias guard bounds, it is the weaker measurement and serves as a check; at a few times those speeds it is resolved
better, but it can then miss by more than its noise (the speed between two samples is no longer the speed at the
sample), which is one more reason the model does not take it (figures: ``bench/rotary_back_emf.py``, the validation
page of the documentation).

**What it is used for** (:func:`agreement`). ``identify`` reports the voltage's ripple beside the currents' and
whether the two agree within their errors (the RMS of the difference over the revolution within
:data:`AGREEMENT_FACTOR` times what both errors give together), the back-EMF constant (``k0`` in N·m/A, given the
drive's Park convention, without a torque sensor or a datasheet) and the resistance. They disagree where the
voltage's model does not hold: an interior-magnet motor (reluctance torque ``(L_d − L_q) i_d i_q`` and an inductance
that varies with the angle), a logged voltage that is not the one applied (before a limiter, or averaged over
another interval than the angle's), a dead time that depends on more than the current. The model stays the currents':
both estimates read the same logged current (the voltage through ``R i_q + L di_q/dt`` and the loop's ``−K_p n``, the
mechanics through the torque), so their errors are not independent, and a Kalman update of the currents' fit with the
voltage's ripple, which treats them as independent, makes the standard errors overconfident (it shrinks them without
shrinking the actual error). A joint fit that models that shared noise is the way to use both.

**The d-voltage** (:func:`_offset_error`). The magnets' q axis is ``δ`` (electrical) ahead of the drive's, so the
back-EMF has ``cos δ`` of itself on the drive's q axis (``κ = (2/3) k_t cos δ``) and ``−sin δ`` on its d axis; where
the logs have the d-voltage ``vd_1``, its ratio to the q-voltage's back-EMF gives ``δ``, the offset that aligns the
drive with the magnets and the torque constant along them (its figures on the zoo: ``bench/rotary_back_emf.py --fast
none``).

**Assumptions the user's logs must meet.** ``vq_1`` is the drive's q-voltage command in its own frame (V), written in
the same record as the current: it takes the current's timing against the angle (:mod:`pgcomm.rotary.readings`).
A search of its own over shifts would mislead: the command carries ``−K_p`` times the logged current's noise, so a
shift that lets the neighbouring currents explain that noise fits better than the true timing and puts ``k0`` off.
``i_d`` is held at zero; a surface-magnet motor. ``vd_1`` is the d-voltage command of the same record.
"""

from __future__ import annotations

import math

import numpy as np

from pgcomm.errors import DataError
from pgcomm.rotary.model import harmonic_columns
from pgcomm.rotary.readings import _shifted, current_noise
from pgcomm.rotary.regression import _log_arrays
from pgcomm.rotary.winding import BACK_EMF_FACTOR, phase_saturation_dq

__all__ = ["VOLTAGE_COLUMNS", "D_VOLTAGE_COLUMNS", "has_voltage", "has_d_voltage", "fit_voltage", "agreement",
           "AGREEMENT_FACTOR", "voltage_text", "offset_text", "OFFSET_EVIDENCE"]

#: Column names of the logged q-voltage (V), in the order looked for.
VOLTAGE_COLUMNS = ("vq_1", "vq")
#: ... and of the d-voltage.
D_VOLTAGE_COLUMNS = ("vd_1", "vd")
#: ... and of the supply (V).
SUPPLY_COLUMNS = ("vbus",)
#: Samples whose voltage vector (``hypot(v_q, v_d)``, or ``|v_q|`` without a d-voltage) exceeds this share of the
#: space-vector limit ``v_bus/√3`` (amplitude-invariant frame) are left out: at the limit the logged command is not the
#: voltage applied (a limiter after it, or over-modulation), and the current no longer follows it.
MODULATION_LIMIT = 0.95
#: The voltage's ripple agrees with the currents' when their RMS difference over the revolution is at most this many
#: times what their errors give together (as a sweep's table and the model's, :mod:`pgcomm.rotary.experiment`). An RMS
#: test, not a χ² of the coefficients: the currents' covariance is overconfident in some directions of the
#: coefficients (on logs without a dither, far beyond the χ² quantile against the truth) while its RMS holds, and the
#: verdicts are RMS too.
AGREEMENT_FACTOR = 1.5
#: The back-EMF constant must exceed this many of its standard errors for the voltage's ripple to be read: a ripple
#: of a few per cent is not read off a constant known to 10 %.
MIN_BACK_EMF_EVIDENCE = 10.0
#: Widths of the dead time's zero crossing tried (shares of the logs' RMS q-current): the crossing's width is the PWM
#: current ripple, which the logs do not show.
DEADTIME_WIDTHS = (0.01, 0.03, 0.1, 0.3)
#: Rows whose logged current (or its neighbours' mean) is within this many of the current's noise of zero are left out.
ZERO_CROSSING_NOISES = 3.0
#: Length of the time blocks of the sandwich covariance (s), at most; shorter where the logs would give fewer than
#: :data:`BLOCKS_PER_UNKNOWN` blocks per unknown (a sandwich of fewer blocks than unknowns is singular, and one of a few
#: per unknown underestimates: 6 s of logs in 1 s blocks called 3-sigma differences 50-sigma). The voltage's residual
#: is nearly white (the current loop's noise), so blocks of tens of samples hold its correlation.
BLOCK_SECONDS = 1.0
BLOCKS_PER_UNKNOWN = 10


def has_voltage(logs) -> bool:
    """Whether every log has a q-voltage column (:data:`VOLTAGE_COLUMNS`)."""
    logs = list(logs)
    return bool(logs) and all(any(a in log for a in VOLTAGE_COLUMNS) for log in logs)


def _rows(logs, orders, pole_pairs: int, offset: float, sample_time: float, current_delay: int, d_axis: bool = False):
    """Stacked rows of every log (:func:`_log_rows`) and each row's time block, as long as :data:`BLOCK_SECONDS` and
    :data:`BLOCKS_PER_UNKNOWN` allow: ``(X, Z, y, block, d, over)``."""
    X, Z, y, t, d, over = _log_rows(logs, orders, pole_pairs, offset, sample_time, current_delay, d_axis)
    total = sum(float(np.ptp(tk)) for tk in t if tk.size)
    length = min(BLOCK_SECONDS, total / (BLOCKS_PER_UNKNOWN * X.shape[1])) if total > 0 else BLOCK_SECONDS
    blocks, start = [np.zeros(0, int)], 0
    for tk in t:
        if not tk.size:
            continue
        b = np.floor((tk - tk[0]) / length).astype(int)
        blocks.append(start + b)
        start += int(b.max()) + 1
    return X, Z, y, np.concatenate(blocks), d, over


def _column(log, name: str, columns) -> np.ndarray:
    """A log's column (the first of ``columns`` it has), checked finite."""
    key = next(a for a in columns if a in log)
    v = np.asarray(log[key], float)
    bad = np.flatnonzero(~np.isfinite(v))
    if bad.size:
        raise DataError(f"{name}: column '{key}' has a non-finite value at row {bad[0] + 1}")
    return v


def _log_rows(logs, orders, pole_pairs: int, offset: float, sample_time: float, current_delay: int,
              d_axis: bool = False):
    """Rows of every log: ``X`` with columns ``[ω, ω cos hθ…, ω sin hθ…, i_q, di_q/dt, 1, dead time…]``, ``Z`` the
    instruments (the current's columns from its neighbours), the target ``y = v_q`` (V) and each log's kept times (s);
    with ``d_axis``, the d-voltage's rows on the same samples, ``(X_d, Z_d, y_d)``: columns ``[−p ω i_q, the dead time's
    d part…, i_d]`` (``i_d`` where every log has ``id_1``) and ``y_d = v_d`` (V), else ``None``. Where a log has the
    supply ``vbus``, samples at the inverter's voltage limit are left out (:data:`MODULATION_LIMIT`); ``over`` counts
    the rows so lost. Returns ``(X, Z, y, [t_k], d, over)``."""
    xs, zs, ys, ts_out, dx, dz, dy = [], [], [], [], [], [], []
    over = 0
    read = [_log_arrays(log, i, sample_time) for i, log in enumerate(logs)]
    i_rms = math.sqrt(float(np.mean(np.concatenate([r[2] for r in read]) ** 2)))
    widths = [w * max(i_rms, 1e-12) for w in DEADTIME_WIDTHS]
    with_id = d_axis and all("id_1" in log for log in logs)
    for log, (name, th, iq, _, ts) in zip(logs, read):
        vq = _column(log, name, VOLTAGE_COLUMNS)
        vd = _column(log, name, D_VOLTAGE_COLUMNS) if any(a in log for a in D_VOLTAGE_COLUMNS) else None
        if th.size < 5:
            continue
        # the voltages are written in the current's record: the current's timing
        iq, vq = _shifted(iq, current_delay), _shifted(vq, current_delay)
        vd = None if vd is None else _shifted(vd, current_delay)
        # rows 2 .. n-3: the instruments reach two samples either side
        c = slice(2, th.size - 2)
        w = (th[3:-1] - th[1:-3]) / (2 * ts)
        di = (iq[3:-1] - iq[1:-3]) / (2 * ts)
        thc, iqc = th[c], iq[c]
        th_e = pole_pairs * thc + offset
        emf = np.column_stack([w, w[:, None] * harmonic_columns(thc, orders)])
        # the dead time's d and q parts, at the sample's current and at its instrument (the d part for the d-voltage)
        dt_d, dt_q = phase_saturation_dq(iqc, th_e, widths)
        X = np.column_stack([emf, iqc, di, np.ones_like(w), dt_q])
        # instruments for the current's columns, from samples whose noise neither the voltage nor the regressor carries.
        # The logged voltage carries -K_p times the logged current's own noise (the loop acts on the measured current),
        # so least squares on the current of the same sample pulls R, and k0 with it, by about K_p σ²/var(i_q); the
        # current's central difference carries the noise of samples j ± 1, which attenuates L where the current hardly
        # changes (constant speeds: the cogging current's L ω c'(θ) then reads as back-EMF ripple at the cogging
        # orders), so its instrument is the difference of samples j ± 2
        nb = 0.5 * (iq[3:-1] + iq[1:-3])
        di2 = (iq[4:] - iq[:-4]) / (4 * ts)
        zt_d, zt_q = phase_saturation_dq(nb, th_e, widths)
        Z = np.column_stack([emf, nb, di2, np.ones_like(w), zt_q])
        # rows whose current is within a few of its noise of zero are left out: there the dead time turns with the
        # noise, tanh(i/c) of the neighbours' mean no longer follows the sample's (a weak instrument, which a slow
        # sweep's small currents would make of the whole fit), and the back-EMF they carry is what the other rows carry
        noise = current_noise(iq)
        keep = (np.abs(iqc) > ZERO_CROSSING_NOISES * noise) & (np.abs(nb) > ZERO_CROSSING_NOISES * noise)
        if any(a in log for a in SUPPLY_COLUMNS):
            # at the inverter's voltage limit the command is not the voltage applied (a limiter after it, or
            # over-modulation): those samples, and their neighbours whose differences reach them, are left out
            vbus = _shifted(_column(log, name, SUPPLY_COLUMNS), current_delay)
            amp = np.hypot(vq, 0.0 if vd is None else vd)
            hit = amp > MODULATION_LIMIT * np.abs(vbus) / math.sqrt(3.0)
            near = np.convolve(hit.astype(float), np.ones(5), mode="same") > 0
            over += int(np.count_nonzero(keep & near[c]))
            keep &= ~near[c]
        xs.append(X[keep])
        zs.append(Z[keep])
        ys.append(vq[c][keep])
        ts_out.append((ts * np.arange(2, th.size - 2))[keep])
        if d_axis:
            # the d-current is held at zero: its logged noise is what the loop's gain puts into the command (-K_p n_d),
            # a regressor of its own that no other column carries
            extra = [_shifted(_column(log, name, ("id_1",)), current_delay)[c][:, None]] if with_id else []
            dx.append(np.column_stack([-pole_pairs * w * iqc, dt_d, *extra])[keep])
            dz.append(np.column_stack([-pole_pairs * w * nb, zt_d, *extra])[keep])
            dy.append(vd[c][keep])
    k = 1 + 2 * len(orders) + 3 + len(DEADTIME_WIDTHS)
    kd = 1 + len(DEADTIME_WIDTHS) + with_id
    if not xs:
        d = (np.zeros((0, kd)), np.zeros((0, kd)), np.zeros(0)) if d_axis else None
        return np.zeros((0, k)), np.zeros((0, k)), np.zeros(0), ts_out, d, over
    d = (np.concatenate(dx), np.concatenate(dz), np.concatenate(dy)) if d_axis else None
    return np.concatenate(xs), np.concatenate(zs), np.concatenate(ys), ts_out, d, over


def _solve(X, Z, y, block):
    """Instrumental-variable least squares ``β = (ZᵀX)⁻¹ Zᵀy`` with column scaling, and its sandwich covariance
    ``(ZᵀX)⁻¹ (Σ_b Z_bᵀ e_b e_bᵀ Z_b) (XᵀZ)⁻¹`` over the blocks. Returns ``(beta, cov, cost)``."""
    scale = np.sqrt(np.mean(X * X, axis=0))
    scale[scale == 0] = 1.0
    Xs, Zs = X / scale, Z / scale
    a_inv = np.linalg.pinv(Zs.T @ Xs)
    beta_s = a_inv @ (Zs.T @ y)
    e = y - Xs @ beta_s
    lab, inv = np.unique(block, return_inverse=True)
    scores = np.zeros((lab.size, X.shape[1]))
    np.add.at(scores, inv, Zs * e[:, None])
    # small-sample factor B/(B-1) of the block sandwich
    corr = lab.size / max(lab.size - 1, 1)
    cov = corr * (a_inv @ (scores.T @ scores) @ a_inv.T) / np.outer(scale, scale)
    return beta_s / scale, cov, float(e @ e) / y.size


def fit_voltage(logs, orders, pole_pairs: int, sample_time: float, current_delay: int = 0, offset: float = 0.0,
                d_axis: bool | None = None) -> dict:
    """The ripple (relative) and the winding's constants from the logged q-voltage, and the drive's offset error from
    the d-voltage where the logs have it (module docstring).

    Args:
        logs: dict-like logs with ``theta`` (rad, multi-turn), ``iq_1`` (A), ``vq_1`` (V) and ``t`` (s), optionally
            ``vd_1`` (V) and ``id_1`` (A), each ``(N_i,)``.
        orders: ``(n,)`` the ripple's orders (per revolution, > 0).
        pole_pairs: ``p`` (the dead time's sixth electrical harmonic is order ``6p``).
        sample_time: ``T_s`` (s) where a log has no ``t``.
        current_delay: samples by which the logged current is late (:mod:`pgcomm.rotary.readings`).
        offset: the drive's electrical offset (rad): its frame is ``p θ + offset`` (where the phase currents cross
            zero, for the dead time).
        d_axis: read the d-voltage (default: where every log has one, :func:`has_d_voltage`).

    Returns:
        dict: ``orders``; ``ripple`` ``(2n,)`` ``[a…, b…]`` (-) and ``cov`` ``(2n, 2n)``; ``back_emf_constant``
        (V·s/rad) and its standard error; ``resistance`` (Ω), ``inductance`` (H), ``offset_V``, ``deadtime_V`` (the
        coefficients of the dead time's columns, one per :data:`DEADTIME_WIDTHS`); ``voltage_delay`` (samples),
        ``rows``, ``blocks``, ``residual_rms_V``; ``offset_error`` (:func:`_offset_error`'s dict, or ``None`` without a
        d-voltage). Where the back-EMF constant is within :data:`MIN_BACK_EMF_EVIDENCE` standard errors of zero (not
        determined), ``ripple``, ``cov`` and ``offset_error`` are ``None`` and only the constant, its error, the delay
        and the rows are given.
    """
    orders = np.asarray(orders, int)
    orders = orders[orders > 0]
    n = orders.size
    if d_axis is None:
        d_axis = has_d_voltage(logs)
    X, Z, y, block, d_rows, over = _rows(logs, orders, pole_pairs, offset, sample_time, current_delay, d_axis)
    rows = y.size
    if rows < 2 * X.shape[1]:
        # hardly a row away from the current's zero crossing: nothing to read
        return {"orders": orders, "ripple": None, "cov": None, "back_emf_constant": None,
                "back_emf_constant_se": None, "voltage_delay": int(current_delay), "rows": int(rows),
                "rows_at_voltage_limit": over, "offset_error": None}
    beta, cov, cost = _solve(X, Z, y, block)
    kappa = beta[0]
    if not abs(kappa) > MIN_BACK_EMF_EVIDENCE * math.sqrt(max(cov[0, 0], 0.0)):
        # the constant is not determined: a column that is not the voltage, or logs that hardly turn (logs of a
        # turning motor, even at constant speeds alone, determine it far better than to a tenth)
        return {"orders": orders, "ripple": None, "cov": None, "back_emf_constant": float(kappa),
                "back_emf_constant_se": float(math.sqrt(max(cov[0, 0], 0.0))), "voltage_delay": int(current_delay),
                "rows": int(rows), "rows_at_voltage_limit": over, "offset_error": None}
    c = beta[1:1 + 2 * n]
    # delta method: r = c / κ
    J = np.zeros((2 * n, beta.size))
    J[:, 0] = -c / kappa ** 2
    J[:, 1:1 + 2 * n] = np.eye(2 * n) / kappa
    r = c / kappa
    k = 1 + 2 * n
    se_kappa = float(math.sqrt(max(cov[0, 0], 0.0)))
    out = {"orders": orders, "ripple": r, "cov": J @ cov @ J.T,
           "back_emf_constant": float(kappa), "back_emf_constant_se": se_kappa,
           "resistance": float(beta[k]), "inductance": float(beta[k + 1]), "offset_V": float(beta[k + 2]),
           "deadtime_V": [float(v) for v in beta[k + 3:]], "voltage_delay": int(current_delay),
           "rows": int(rows), "rows_at_voltage_limit": over, "blocks": int(np.unique(block).size),
           "residual_rms_V": math.sqrt(cost),
           "offset_error": None}
    if d_rows is not None:
        out["offset_error"] = _offset_error(y, X[:, k:], X[:, :k] @ beta[:k], Z[:, k:], Z @ beta, pole_pairs * X[:, 0],
                                            *d_rows, block, float(kappa), se_kappa, offset)
    return out


def _offset_error(v_q, X_q, emf_fit, Z_q, vq_fit, w_e, X_d, Z_d, y_d, block, kappa: float, kappa_se: float,
                  offset: float) -> dict:
    """The drive's offset error from the back-EMF's d component (module docstring, "The d-voltage").

    The magnets' q axis is ``δ`` (electrical) ahead of the drive's (:func:`pgcomm.rotary.winding.d_voltage`), so at
    every instant the back-EMF on the drive's d axis is ``−tan δ`` times that on its q axis,
    ``e_q = v_q − R i_q − L di_q/dt − v_0 − Σ d_m g_m^q``::

        v_d = −tan δ · v_q + tan δ (R i_q + L di_q/dt + Σ d_m g_m^q) − L p ω i_q + v_0' + Σ_m d'_m g_m^d + g i_d
              − τ p ω v_q + noise

    Regressed on the logged q-voltage, which carries the speed of the sample instant as the d-voltage does, the ratio
    holds however the speed varies between samples: against a central difference of the angle (or a q-voltage less
    terms fitted against one), the speed's dither and cogging ripple, which the difference attenuates, would bias
    ``κ_d`` by many of its standard errors, even with a higher-order difference. The q terms' coefficients are free (the q fit's ``L`` takes up part of that speed error), so are the frame's
    cross-coupling, an offset, the dead time's d part and the logged d-current (its noise, which the loop's gain puts
    into the command). The last term is a drive that applies its command ``τ`` after the sample instant in the frame of
    the sample's angle (:func:`pgcomm.rotary.winding.logged_dq`): the logged voltages are turned by ``p ω τ``, and
    without the term ``δ`` would read ``δ + p ω τ`` (a PWM period and a half at 20 kHz is 6° electrical at
    2000 rad/s). Even in the speed where the back-EMF is odd, it costs ``δ`` little with logs in both directions.
    Instruments: the q fit's back-EMF (``emf_fit``, of θ and ω alone: neither voltage's noise) for ``v_q``, the q fit's
    for its current columns, ``p ω`` times the q fit's value from its instruments (``vq_fit``) for ``p ω v_q``; the
    sandwich over the q fit's blocks.

    Args:
        v_q: ``(N,)`` (V); X_q, Z_q: ``(N, m)`` the q fit's columns other than the back-EMF's, and their instruments;
        emf_fit: ``(N,)`` the q fit's back-EMF (V); vq_fit: ``(N,)`` the q fit's value from its instruments (V);
        w_e: ``(N,)`` the electrical speed ``p ω`` (rad/s); X_d, Z_d: ``(N, m')`` the d axis's own columns and instruments;
        y_d: ``(N,)`` ``v_d`` (V); block: ``(N,)`` time blocks; kappa, kappa_se: the q-axis back-EMF constant
        (V·s/rad) and its error; offset: the drive's electrical offset (rad).

    Returns:
        dict: ``delta`` ``δ`` (rad, electrical; the magnets' frame minus the drive's) and ``delta_se``;
        ``corrected_offset`` (rad, ``offset + δ``: the drive's q axis on the magnets'); ``k_t_aligned`` (N·m/A,
        amplitude-invariant: the torque constant along the magnets' axis, ``k0 / cos δ``) and its error;
        ``torque_per_ampere_gain`` ``1/cos δ``; ``inductance`` (H, from the cross-coupling); ``voltage_lag_s`` ``τ``
        (s) and its error; ``rows``, ``residual_rms_V``.
    """
    X = np.column_stack([v_q, X_q, X_d, w_e * v_q])
    beta, cov, cost = _solve(X, np.column_stack([emf_fit, Z_q, Z_d, w_e * vq_fit]), y_d, block)
    tan_d, var_t = float(beta[0]), max(float(cov[0, 0]), 0.0)
    delta = -math.atan(tan_d)
    cos_d = math.cos(delta)
    k0 = kappa / BACK_EMF_FACTOR
    # k_t = k0 / cos δ = k0 sqrt(1 + tan²δ): its variance from k0's and tan δ's (independent: the d- and q-axis noises)
    kt = k0 / cos_d
    kt_var = (kappa_se / BACK_EMF_FACTOR / cos_d) ** 2 + (k0 * tan_d * cos_d) ** 2 * var_t
    return {"delta": delta, "delta_se": math.sqrt(var_t) / (1.0 + tan_d * tan_d),
            "corrected_offset": float(offset) + delta, "k_t_aligned": kt, "k_t_aligned_se": math.sqrt(kt_var),
            "torque_per_ampere_gain": 1.0 / cos_d, "inductance": float(beta[1 + X_q.shape[1]]),
            "voltage_lag_s": -float(beta[-1]), "voltage_lag_s_se": math.sqrt(max(float(cov[-1, -1]), 0.0)),
            "rows": int(y_d.size), "residual_rms_V": math.sqrt(cost)}


def has_d_voltage(logs) -> bool:
    """Whether every log has a d-voltage column (:data:`D_VOLTAGE_COLUMNS`)."""
    logs = list(logs)
    return bool(logs) and all(any(a in log for a in D_VOLTAGE_COLUMNS) for log in logs)


def agreement(r_c: np.ndarray, cov_c: np.ndarray, r_v: np.ndarray, cov_v: np.ndarray, gram: np.ndarray,
              extra_ms: float = 0.0, factor: float = AGREEMENT_FACTOR) -> dict:
    """Whether the voltage's ripple agrees with the currents' within what their errors give together.

    Args:
        r_c, r_v: ``(k,)`` the currents' and the voltage's ripple coefficients (same orders, ``[a…, b…]``, relative).
        cov_c, cov_v: ``(k, k)`` their covariances.
        gram: ``(k, k)`` the mean square over the revolution of a coefficient vector is ``dᵀ gram d``.
        extra_ms: mean square (relative²) of the currents' error that its covariance does not hold (an order outside
            the basis the logs could hide).
        factor: the RMS difference may be this many times the expected one.

    Returns:
        dict: ``rms_difference`` and ``expected_rms_difference`` (relative, over the revolution: the square root of
        ``tr(gram (C_c + C_v)) + extra_ms``), ``factor``, ``consistent`` (``rms_difference ≤ factor × expected``).
    """
    d = np.asarray(r_v) - np.asarray(r_c)
    rms = math.sqrt(max(float(d @ gram @ d), 0.0))
    expected = math.sqrt(max(float(np.trace(gram @ (np.asarray(cov_c) + np.asarray(cov_v)))) + extra_ms, 0.0))
    return {"consistent": bool(rms <= factor * expected), "rms_difference": rms, "expected_rms_difference": expected,
            "factor": factor}


def voltage_text(info: dict) -> str | None:
    """One line on what the voltage gave (``None`` without a voltage)."""
    if not info or not info.get("used_logs"):
        return None
    kappa = info["back_emf_constant"]
    if kappa is None:
        return "the q-voltage is not read: hardly a logged current clear of its zero crossing"
    if info.get("consistent") is None:
        se = info["back_emf_constant_se"]
        return (f"the q-voltage does not determine the back-EMF constant ({kappa:.3g} ± {se:.2g} V·s/rad): its ripple "
                "is not read. Either vq_1 is not the drive's q-voltage in V (map it in --columns, with its unit), or "
                "the logs hardly turn")
    k0 = info["k0_amplitude_invariant"]
    base = (f"the q-voltage's back-EMF constant {kappa:.4g} V·s/rad (k0 = {k0:.4g} N·m/A in the amplitude-invariant "
            f"frame), R {info['resistance']:.3g} Ω")
    if info.get("rows_at_voltage_limit"):
        base += (f" ({info['rows_at_voltage_limit']} samples at the inverter's voltage limit, above "
                 f"{MODULATION_LIMIT:g} vbus/√3, left out)")
    if info.get("voltage_delay"):
        base += f", voltage read {info['voltage_delay']:+d} samples late with the current"
    if info["consistent"]:
        rel = info["ripple_rms_error"] / info["ripple_rms"] if info["ripple_rms"] > 0 else float("inf")
        return base + (f"; its ripple ({100 * info['ripple_rms']:.2g} % of k0 RMS, standard error {100 * rel:.2g} % of "
                       f"that) agrees with the currents' (they differ by {100 * info['rms_difference']:.2g} % of k0 "
                       f"RMS, their errors give {100 * info['expected_rms_difference']:.2g} %)")
    rel = info["ripple_rms_error"] / info["ripple_rms"] if info["ripple_rms"] > 0 else float("inf")
    return base + (f"; its ripple differs from the currents' by {100 * info['rms_difference']:.2g} % of k0 RMS, more "
                   f"than {info['factor']:g}x the {100 * info['expected_rms_difference']:.2g} % their errors give: an "
                   "interior-magnet motor, a logged voltage that is not the applied one, or, where neither resolves "
                   f"the ripple (the voltage's standard error {100 * rel:.2g} % of its RMS), errors beyond what the "
                   "fits state (the model is the currents')")


#: An offset error within this many of its standard errors of zero is not called one.
OFFSET_EVIDENCE = 3.0


def offset_text(info: dict) -> str | None:
    """One line on the drive's offset error the d-voltage gives (``back_emf`` of
    :func:`pgcomm.rotary.identify.identify`), or ``None`` without a d-voltage read."""
    off = (info or {}).get("offset_error")
    if not off:
        if (info or {}).get("consistent") is not None:
            # the q-voltage was read: the d-voltage beside it would give the offset
            return ("log the drive's d-voltage beside its q-voltage (vd_1: ODrive's Vd_setpoint, moteus's "
                    "servo_control.d_V) and identify reads the drive's electrical offset error from it")
        return None
    d, se = math.degrees(off["delta"]), math.degrees(off["delta_se"])
    lag, lag_se = off.get("voltage_lag_s", 0.0), off.get("voltage_lag_s_se", 0.0)
    late = (f"; the logged voltage is applied {1e6 * lag:.0f} ± {1e6 * lag_se:.0f} µs after its sample in that sample's "
            "frame (read and taken out: it turns the logged voltages by p·ω·τ)" if abs(lag) > OFFSET_EVIDENCE * lag_se
            else "")
    if abs(d) <= OFFSET_EVIDENCE * se:
        return (f"the d-voltage's back-EMF puts the drive's electrical offset on the magnets' axis: {d:+.2f} ± "
                f"{se:.2f}° electrical (k_t along it {off['k_t_aligned']:.4g} N·m/A, amplitude-invariant)" + late)
    return (f"the d-voltage's back-EMF puts the magnets' q axis {d:+.2f} ± {se:.2f}° electrical ahead of the drive's: "
            f"an electrical offset of {off['corrected_offset']:.4f} rad (in the frame p·theta + offset of the logged "
            f"angle) aligns them and gives {off['torque_per_ampere_gain']:.4f}x the torque per ampere (k_t "
            f"{off['k_t_aligned']:.4g} N·m/A against k0 {off['k_t_aligned'] * math.cos(off['delta']):.4g}); the "
            "compensation in A identified before then scales by cos δ" + late)

