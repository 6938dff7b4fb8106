"""The cogging's orders that a log's time sampling does not resolve, read over the angle.

A robot joint's drive polled by a host every few milliseconds turns, in its own speed loop, too fast for the
regression's alias guard (:mod:`pgcomm.rotary.regression`: three samples per period of every order in a filter
window): the basis is cut to the orders the samples resolve in time (:func:`pgcomm.rotary.regression.resolved_orders`).
The orders above are still in the logs. At a steady speed, every angle-periodic quantity is sampled at angles that
fall on a different phase of each order in each revolution (the oscilloscope's *equivalent-time* sampling, and why a
drive's binning of the current over the angle works at any speed): over a few revolutions, a least-squares fit of the
logged samples against ``cos hθ, sin hθ`` resolves order ``h`` whatever the sample rate, provided the samples do not
lock to the order's period.

**The model at one speed.** Over a stretch of steady speed ``ω`` (a *segment*), the torque balance of
:mod:`pgcomm.rotary.regression`, ``(J/k0) θ̈ = (1 + r) i_q + c(θ) − …``, at order ``h`` reads, per complex Fourier
coefficient (``x(θ) = Re Σ X_h e^{ihθ}``)::

    table_h = −c_h = I_h − (J/k0) A_h

``I_h`` is the current that acted and ``A_h`` the rotor's acceleration, both as functions of the angle (the ripple's
``r I`` at the segment's mean current is folded in, as the running logs fold it). The two are read from the log:

* the **current**: the logged q-current's coefficient ``Y_h`` over the angle is the acted current through the drive's
  report, ``Y_h = G_h I_h``; ``G_h = e^{−ihω λ T_s} / (1 + ihω τ)`` with the report filter ``τ`` and the current's lag
  ``λ`` (samples) that the identification found (:mod:`pgcomm.rotary.readings`; a current held over the sample lags by
  half a sample);
* the **acceleration**: time as a function of the angle, ``t(θ) = D(θ) + Re Σ Z_h e^{ihθ}`` (``D`` a slow polynomial:
  the speed's drift over the segment), gives ``ω(θ) = 1/t'(θ)`` and ``θ̈ = ω dω/dθ = −t''/t'³``, taken on a grid of
  the revolution (to first order in the speed's ripple ``A_h = ω³ h² Z_h``, which sets the standard errors; a
  speed loop's ripple of 8 % at the fundamental puts a third of its second multiple's inertia torque in the second
  order terms). Orders within their noise are set to zero first (:func:`_shrunk`). A drive's PLL estimate of the angle (``ω_n, ζ``) holds ``P_h = (2ζω_n s + ω_n²) / (s² + 2ζω_n s
  + ω_n²)`` of its ripple at ``s = ihω``: ``Z_h`` is divided by it.

``J/k0`` is the time-domain fit's. The host's stamp noise and the encoder's rounding are noise in ``t(θ)``, which the
fit averages over the segment's samples; ``h²`` amplifies it, so the highest orders come with the largest standard
errors. At a given acceleration the ripple in time falls as ``1/ω³`` while the stamp noise stays: the inertia
torque's standard error grows as the cube of the speed (a joint's 12N14P at order 84: 4 % at 5 rad/s, 11 % at 8 rad/s
over 10 s), and slower logs read it better.

**Standard errors.** The residuals of a segment are correlated in time (a filtered report, a speed loop): each fit's
covariance is the cluster-robust sandwich over one-second blocks (``(XᵀX)⁻¹ Σ_b X_bᵀ r_b r_bᵀ X_b (XᵀX)⁻¹``), and the
coefficient's covariance adds ``Var(J/k0) |A_h|²`` along ``A_h``. Segments combine by inverse covariance.

**The check on the orders both read.** The same estimate at the orders the time-domain fit resolves (the cogging's
largest there) is compared with that fit's: :func:`agreement` is the RMS of the difference over those orders against the
RMS of the time-domain map there. Where the two disagree, the model over the angle does not hold on these logs (a
speed that is not steady enough, a loop the first order does not describe) and the orders above stay out.
"""

from __future__ import annotations

import math

import numpy as np


#: A segment is a stretch whose speed (averaged over :data:`SPEED_WINDOW_S`) stays within this share of its median.
STEADY_SHARE = 0.2
#: The averaging window of the speed that segments the logs (s).
SPEED_WINDOW_S = 0.1
#: A segment turns at least this many revolutions: fewer do not spread the samples over each order's phases.
MIN_REVOLUTIONS = 2.0
#: The robust covariance's blocks (s).
BLOCK_SECONDS = 1.0


def _speed(t: np.ndarray, th: np.ndarray) -> np.ndarray:
    """``(N,)`` the speed (rad/s) averaged over :data:`SPEED_WINDOW_S` around each sample."""
    h = 0.5 * SPEED_WINDOW_S
    lo, hi = np.maximum(t - h, t[0]), np.minimum(t + h, t[-1])
    span = np.maximum(hi - lo, 1e-12)
    return (np.interp(hi, t, th) - np.interp(lo, t, th)) / span


def segments(t: np.ndarray, th: np.ndarray) -> list[slice]:
    """The stretches of steady speed in one log (module docstring): contiguous samples of one sign whose averaged
    speed stays within :data:`STEADY_SHARE` of the stretch's median, turning at least :data:`MIN_REVOLUTIONS`.

    Args:
        t: ``(N,)`` increasing time stamps (s); th: ``(N,)`` the angle (rad, multi-turn).

    Returns:
        slices into the log.
    """
    if t.size < 8:
        return []
    w = _speed(t, th)
    out = []
    sign = np.sign(w)
    start = 0
    n = t.size
    while start < n:
        s = sign[start]
        stop = start
        while stop < n and sign[stop] == s:
            stop += 1
        if s != 0:
            med = float(np.median(w[start:stop]))
            ok = np.abs(w[start:stop] - med) <= STEADY_SHARE * abs(med)
            # contiguous runs of steady samples within the run of one sign
            edges = np.flatnonzero(np.diff(np.concatenate([[0], ok.astype(int), [0]])))
            for a, b in zip(edges[::2], edges[1::2]):
                if abs(th[start + b - 1] - th[start + a]) >= MIN_REVOLUTIONS * 2 * math.pi and b - a >= 64:
                    out.append(slice(start + a, start + b))
        start = stop
    return out


def _design(th: np.ndarray, orders: np.ndarray, degree: int) -> np.ndarray:
    """``(N, degree + 1 + 2 m)``: Legendre polynomials of the angle over the segment, then ``cos hθ``, ``sin hθ``."""
    u = 2.0 * (th - th.min()) / max(float(np.ptp(th)), 1e-12) - 1.0
    poly = np.polynomial.legendre.legvander(u, degree)
    ph = np.outer(th, orders)
    return np.hstack([poly, np.cos(ph), np.sin(ph)])


def _robust_fit(x: np.ndarray, y: np.ndarray, t: np.ndarray):
    """Least squares ``y ≈ x β`` and its cluster-robust covariance over :data:`BLOCK_SECONDS` blocks."""
    q, r = np.linalg.qr(x)
    beta = np.linalg.solve(r, q.T @ y)
    res = y - x @ beta
    blocks = np.floor((t - t[0]) / BLOCK_SECONDS).astype(int)
    # per block, Qᵀ r (the score in the orthogonal basis): the sandwich's meat in it is their outer products' sum
    score = np.zeros((blocks.max() + 1, q.shape[1]))
    np.add.at(score, blocks, q * res[:, None])
    b = int(score.shape[0])
    meat = score.T @ score * (b / max(b - 1, 1))
    rinv = np.linalg.inv(r)
    return beta, rinv @ meat @ rinv.T


def _complex_block(beta: np.ndarray, cov: np.ndarray, start: int, m: int, j: int):
    """Order ``j``'s coefficient ``X = a − i b`` of ``a cos + b sin`` and the ``2×2`` covariance of ``(Re X, Im X)``."""
    ia, ib = start + j, start + m + j
    c = cov[np.ix_([ia, ib], [ia, ib])] * np.array([[1.0, -1.0], [-1.0, 1.0]])
    return beta[ia] - 1j * beta[ib], c


def _shrunk(z: complex, cov: np.ndarray) -> complex:
    """``z`` times ``max(0, 1 − tr(cov)/|z|²)``: the posterior mean of a coefficient under a zero-mean prior whose
    variance is read from the estimate itself (zero where ``z`` is within its noise)."""
    size = abs(z) ** 2
    return z * max(0.0, 1.0 - float(np.trace(cov)) / size) if size > 0 else z


def _as_real(z: complex) -> np.ndarray:
    return np.array([z.real, z.imag])


def _rotated(cov: np.ndarray, g: complex) -> np.ndarray:
    """The covariance of ``(Re, Im)`` of ``g X`` given that of ``X``."""
    m = np.array([[g.real, -g.imag], [g.imag, g.real]])
    return m @ cov @ m.T


def _source(log) -> str | None:
    """The file a piece of a log came from (the reader names pieces between gaps ``"<file> rows a-b"``)."""
    name = log.get("name") if isinstance(log, dict) else None
    return None if name is None else str(name).split(" rows ")[0]


def joined(logs) -> list[dict]:
    """The pieces of each log between a host's gaps joined again (``t``, ``theta``, ``iq_1``): over the angle a gap
    is no edge (the samples need not be even in time), and a joint's log split at every pause of its host keeps
    no stretch of two revolutions. Consecutive pieces join where both have time stamps, the second starts after the
    first ends, and they come from one file (``name``, where given)."""
    out: list[dict] = []
    for log in logs:
        cur = {"t": log.get("t"), "theta": np.asarray(log["theta"], float),
               "iq_1": np.asarray(log["iq_1"] if "iq_1" in log else log["iq"], float), "name": _source(log)}
        prev = out[-1] if out else None
        if (prev is not None and prev["t"] is not None and cur["t"] is not None and np.size(cur["t"])
                and np.size(prev["t"]) and float(cur["t"][0]) > float(prev["t"][-1]) and prev["name"] == cur["name"]):
            for key in ("t", "theta", "iq_1"):
                prev[key] = np.concatenate([np.asarray(prev[key], float), np.asarray(cur[key], float)])
        else:
            out.append(cur)
    return out


def _segment_fits(logs, orders: np.ndarray, sample_time: float):
    """Per steady segment of every log (:func:`segments`): ``(t, ω, β_i, Cov_i, β_t, Cov_t, s0)``, the fits of the
    current (A) and of time (s) against the angle's polynomial drift and ``cos hθ, sin hθ`` of ``orders`` (their
    coefficients from column ``s0``: cosines, then sines), with robust covariances (:func:`_robust_fit`)."""
    for log in joined(logs):
        th_all = np.asarray(log["theta"], float)
        iq_all = np.asarray(log["iq_1"], float)
        t_all = (np.asarray(log["t"], float) if "t" in log and log["t"] is not None
                 else np.arange(th_all.size) * float(sample_time))
        for sl in segments(t_all, th_all):
            t, th, iq = t_all[sl], th_all[sl], iq_all[sl]
            revs = abs(th[-1] - th[0]) / (2 * math.pi)
            degree = int(min(12, 3 + revs // 2))
            x = _design(th, orders, degree)
            if x.shape[0] < 2 * x.shape[1]:
                continue
            w = (th[-1] - th[0]) / (t[-1] - t[0])
            by, cy = _robust_fit(x, iq, t)
            bt, ct = _robust_fit(x, t - t[0], t)
            yield t, w, by, cy, bt, ct, degree + 1


def order_evidence(logs, orders, sample_time: float) -> tuple[np.ndarray, int]:
    """How strongly the logs' steady segments show each of ``orders`` over the angle, whatever the reading and
    ``J/k0``: per order, the sum over segments of ``T² = Yᵀ C_Y⁻¹ Y + Zᵀ C_Z⁻¹ Z`` of the current's and time's
    coefficients (module docstring; the cogging moves one or the other, as the speed loop shares it), ``χ²`` with
    ``4 S`` degrees of freedom where the order is absent (``S`` segments).

    Args:
        logs: as for :func:`read_over_the_angle`; orders: ``(m,)`` int (every order that may hold content should be
            among them: they are fitted together); sample_time: s, where a log has no ``t``.

    Returns:
        ``(T2, segments)``: ``(m,)`` float and the number of segments (0: none, ``T2`` zeros).
    """
    orders = np.asarray(orders, int)
    m = orders.size
    t2, n = np.zeros(m), 0
    for _, _, by, cy, bt, ct, s0 in _segment_fits(logs, orders, sample_time):
        for j in range(m):
            for beta, cov in ((by, cy), (bt, ct)):
                x, c = _complex_block(beta, cov, s0, m, j)
                t2[j] += float(_as_real(x) @ np.linalg.pinv(c) @ _as_real(x))
        n += 1
    return t2, n


def read_over_the_angle(logs, orders, sample_time: float, inertia_ratio: float, inertia_ratio_var: float,
                        tau: float = 0.0, lag: float | None = None, pll=None) -> dict | None:
    """The table's coefficients at ``orders`` read over the angle (module docstring) from the logs' steady segments.

    Args:
        logs: the logs as :func:`pgcomm.rotary.identify.identify` takes them (``t`` s where not uniform, ``theta``
            rad, ``iq_1`` A; ``(N_i,)`` each), the current shifted by the delay the identification found
            (:func:`pgcomm.rotary.readings._shifted`).
        orders: ``(m,)`` int orders per revolution to read, fitted together: every order that may hold content
            should be among them, so that none leaks into another.
        sample_time: the drive's period (s) where a log has no ``t``.
        inertia_ratio: ``J/k0`` (A·s²/rad) of the time-domain fit; inertia_ratio_var: its variance.
        tau: the report filter (s); lag: the smooth current's lag (samples), ``None`` for a current held over the sample (half a sample);
        pll: ``(ω_n, ζ)`` of a drive's PLL angle, or ``None``.

    Returns:
        ``None`` where no log has a steady segment, else ``{"orders": (m,) int, "table": (m,) complex`` (the table's
        coefficient ``X_h`` of ``Re Σ X_h e^{ihθ}``, A), ``"cov": (m, 2, 2)`` (of ``Re X_h, Im X_h``, A²),
        ``"segments": int, "seconds": float, "speeds_rad_s": list``}.
    """
    orders = np.asarray(orders, int)
    m = orders.size
    lag_eff = 0.5 if lag is None else float(lag)
    acc_w = np.zeros((m, 2, 2))  # Σ cov⁻¹
    acc_b = np.zeros((m, 2))  # Σ cov⁻¹ x
    n_seg, seconds, speeds = 0, 0.0, []
    for t, w, by, cy, bt, ct, s0 in _segment_fits(logs, orders, sample_time):
        st = sample_time_of(t)
        zs, ys, vys, vzs, gains = [], [], [], [], []
        for j, h in enumerate(orders):
            s = 1j * h * w
            gain = np.exp(-s * lag_eff * st) / (1.0 + s * tau)
            y, vy = _complex_block(by, cy, s0, m, j)
            z, vz = _complex_block(bt, ct, s0, m, j)
            if pll is not None:
                wn, zeta = pll
                p = (2 * zeta * wn * s + wn**2) / (s * s + 2 * zeta * wn * s + wn**2)
                z, vz = z / p, _rotated(vz, 1.0 / p)
            zs.append(z), ys.append(y), vys.append(vy), vzs.append(vz), gains.append(gain)
        # orders whose ripple is within its noise go to zero before the exact (nonlinear) acceleration: there,
        # noise at a high order (h² amplifies it, a PLL's correction more) would move every other order
        accel = _acceleration(np.array([_shrunk(z, vz) for z, vz in zip(zs, vzs)]), orders, w)
        for j, h in enumerate(orders):
            table = ys[j] / gains[j] - inertia_ratio * accel[j]
            cov = (_rotated(vys[j], 1.0 / gains[j]) + inertia_ratio**2 * w**6 * h**4 * vzs[j]
                   + inertia_ratio_var * np.outer(_as_real(accel[j]), _as_real(accel[j])))
            inv = np.linalg.pinv(cov)
            acc_w[j] += inv
            acc_b[j] += inv @ _as_real(table)
        n_seg += 1
        seconds += float(t[-1] - t[0])
        speeds.append(float(w))
    if not n_seg:
        return None
    cov = np.array([np.linalg.pinv(a) for a in acc_w])
    est = np.einsum("jab,jb->ja", cov, acc_b)
    return {"orders": orders, "table": est[:, 0] + 1j * est[:, 1], "cov": cov, "segments": n_seg,
            "seconds": seconds, "speeds_rad_s": speeds}


def _acceleration(z: np.ndarray, orders: np.ndarray, w: float) -> np.ndarray:
    """The acceleration's coefficients ``A_h`` (rad/s²) at ``orders`` from time's periodic part over the angle
    ``Re Σ Z_h e^{ihθ}`` (s) at the mean speed ``w`` (rad/s): ``θ̈ = −t''/t'³`` on a grid of the revolution, exact
    where the speed's ripple is not small (``A_h = w³ h² Z_h`` to first order)."""
    n = 4 * int(orders.max(initial=1)) + 4
    th = 2 * math.pi * np.arange(n) / n
    e = np.exp(1j * np.outer(th, orders))
    d1 = 1.0 / w + np.real(e @ (1j * orders * z))
    d2 = np.real(e @ (-(orders**2) * z))
    a = -d2 / d1**3
    return 2.0 / n * (e.conj().T @ a)


def has_steady_segment(logs, sample_time: float) -> bool:
    """Whether a log holds a stretch of steady speed (:func:`segments`) to read orders over the angle.

    Args:
        logs: as for :func:`read_over_the_angle`; sample_time: s, where a log has no ``t``.
    """
    for log in joined(logs):
        th = np.asarray(log["theta"], float)
        t = np.asarray(log["t"], float) if log["t"] is not None else np.arange(th.size) * sample_time
        if segments(t, th):
            return True
    return False


def sample_time_of(t: np.ndarray) -> float:
    """The median step of a segment's stamps (s)."""
    return float(np.median(np.diff(t))) if t.size > 1 else 0.0


def agreement(time_table: np.ndarray, angle: dict, at: np.ndarray) -> float:
    """The RMS over the orders ``at`` of the difference between the time-domain fit's table coefficients
    (``time_table``: complex, one per order of ``at``) and :func:`read_over_the_angle`'s, over the RMS of the former
    (0: the same map; 1: as far apart as the map is large)."""
    idx = np.searchsorted(angle["orders"], at)
    diff = np.asarray(time_table) - angle["table"][idx]
    size = float(np.sum(np.abs(time_table) ** 2))
    return float(np.sqrt(np.sum(np.abs(diff) ** 2) / size)) if size > 0 else float("inf")
