"""How :func:`pgcomm.rotary.identify.identify` reads a drive's logs: the current's timing against the encoder's, and
whether the logged angle is a PLL's estimate; each read off the fit of the slot/pole basis
(:mod:`pgcomm.rotary.regression`) repeated under each reading.

**The current's timing.** The kernel takes ``i_q[j]`` as the current held over ``[t_j, t_{j+1}]``. A drive that
samples its current at another point of its cycle than the encoder, or a logger that writes the column a cycle
late, shifts it by whole samples, and one sample turns each harmonic by ``h ω T_s``: enough to put the cogging tens
of per cent off and the ripple more, with a standard error that may still call the map resolved. The fit of the slot/pole basis is
repeated with the current shifted by :data:`CURRENT_DELAYS` samples and the delay whose residual is smallest is
taken when it fits clearly better than the log as written (:func:`_current_delay`); the results report it.

**Between logged samples.** A drive that controls at its log rate holds each logged current over the next sample.
Most drives control faster than they log (ODrive at 8 kHz, moteus at 15-40 kHz, their logs at about 1 kHz): the log
then holds snapshots of a current that moves between them, and the current that acted over a sample is not the one
logged at its start: read as held, such logs put the maps tens of per cent off. Read as the smooth curve through the snapshots (the cubic through the four around each interval, as the
angle's path), ``1/(2K)`` of a sample late at ``K`` control cycles per logged sample (the cycles' currents are held),
they fit as well as a drive's that controls at its log rate. The fit is repeated with the current smooth at each of
:data:`CONTROL_LAGS`, refined by a parabola, and taken by the same likelihood ratio (results: ``held``, ``lag``).

**A filtered report.** Drives report the q-current through a low-pass (ODrive's ``Iq_measured``; on a real ODrive
logged by a host, a first-order lag of about 80-100 ms): the logged current is ``i_m = i / (1 + τ s)``, and read as
the current that acted it puts every map late by ``τ`` at every speed (the maps turned by ``h ω τ``, shrunk by
``1/√(1 + (h ω τ)²)``). The current that acted is ``i = i_m + τ di_m/dt``; the basis fit is repeated with the current so
read at each ``τ`` of :data:`REPORT_FILTERS` (in units of the log's median step, so that no time is assumed),
refined by a parabola, and ``τ`` taken by the same likelihood ratio (:func:`_report_filter`; results
``current_filter``).

**The angle's estimate.** Open drives log the angle their PLL estimates from the encoder (ODrive's ``pos_estimate``,
a type-2 loop of 1000 rad/s by default), not the encoder's count: its acceleration is the rotor's through
``(k_p s + k_i)/(s² + k_p s + k_i)``, which at 1000 rad/s halves a cogging harmonic at 3 samples per period. Read
as the rotor's, such a log puts the cogging beyond 5 % while its standard error still calls it resolved, and the
ripple far off. A raw encoder angle sits on the encoder's lattice; where no logged angle does, the basis fit is
repeated with the angle corrected for a PLL (:func:`pll_corrected`) of each natural frequency in
:data:`PLL_FREQUENCIES` and dampings :data:`PLL_DAMPINGS`, and the best is taken when it fits clearly better
than the angle as logged by a likelihood ratio (:func:`_angle_pll`); the results report it, and
:data:`PLL_UNCERTAINTY` of the maps' move from the angle as logged counts against "resolved" (``pll_bias``).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import minimize

from pgcomm.errors import ExcitationError
from pgcomm.rotary import quantisation
from pgcomm.rotary.motor import RotaryMotor
from pgcomm.rotary.regression import FILTER_TAPS, MIN_SAMPLES_PER_PERIOD, Orders, _Layout, _basis_cost, _basis_costs, \
    _angle_parts, _evidence, _hann, _log_time, _prepare, resolved_orders
from pgcomm.settings import RotaryIdentifyOptions

#: Delays (samples) of the logged q-current behind the current that acted over each sample that
#: :func:`identify` tries (:func:`_current_delay`): drives sample the current and the encoder at different
#: points of their cycle, and loggers write a column a cycle late.
CURRENT_DELAYS = (-2, -1, 0, 1, 2)
#: Lags (samples) of the held control cycles behind the smooth curve through the logged snapshots that
#: :func:`_current_delay` tries for a drive that controls faster than it logs: ``1/(2K)`` at ``K`` control cycles per
#: logged sample (K = ∞, 16, 8, 4, 2, 1; an ODrive at 8 kHz and a moteus at 15-40 kHz logged at 1 kHz), and one a
#: little early (a current sampled later in the drive's cycle than the angle); refined between them by a parabola.
CONTROL_LAGS = (-1.0 / 32.0, 0.0, 1.0 / 32.0, 1.0 / 16.0, 1.0 / 8.0, 1.0 / 4.0, 1.0 / 2.0)
#: Time constants (in median log steps) of a first-order report filter on the logged current that :func:`_report_filter`
#: tries: none to 192 steps (190 ms at 1 kHz, 440 ms at a host's 2.3 ms; a drive's 80-120 ms report logged at 1 kHz
#: is 80-120 steps), geometric, refined between them by a parabola.
REPORT_FILTERS = (0.0, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 24.0, 32.0, 48.0, 64.0, 96.0, 128.0, 192.0)
#: How much better (``n_eff ln(cost_as_logged / cost)``, a likelihood ratio, :func:`_evidence`) another reading of
#: the logs (a shifted current, a PLL's angle) must fit than the logs as written to be taken: the χ²₁ quantile at
#: 0.1 %.
READING_EVIDENCE = 10.83
#: Natural frequencies (rad/s) of a drive's angle-estimating PLL tried when no logged angle sits on an encoder's
#: lattice (:func:`_angle_pll`): ODrive's encoder bandwidth defaults to 1000 rad/s.
PLL_FREQUENCIES = tuple(float(x) for x in np.geomspace(50.0, 5000.0, 13))
#: How much worse than the angle as logged the slowest PLL of :data:`PLL_FREQUENCIES` must fit for the PLL's reading
#: to be searched again under a report filter (:func:`_pll_under_filter`): where it is less, the logs are too slow
#: for a PLL's lag to show.
PLL_SECOND_START = 10.0
#: The report filters (shares of the one read first) under which :func:`_pll_under_filter` searches the PLL again: a
#: filter read under a PLL too fast has taken the PLL's lag and reads long (a twin's 17.3 ms at 25-28 ms).
SECOND_START_FILTERS = (1.0, 0.8, 0.64)
#: Dampings tried at the best natural frequency (1: ODrive's ``k_i = k_p² / 4``).
PLL_DAMPINGS = (1.0, 0.707)
#: The dampings the joint refinement (:func:`_refined`) may reach: a discrete PLL reads as a continuous one of higher
#: damping (ODrive's at its largest ``k_p T_c`` of 0.5: ``ζ = 1.41``).
PLL_DAMPING_RANGE = (0.5, 2.0)
#: The share of a PLL reading's move of the maps (from the angle as logged) taken as uncertain in the verdict: a drive's
#: discrete PLL differs from the continuous model the reading inverts by about ``k_p dt`` (ODrive's), so the reading
#: leaves a part of the as-logged error, a few tenths of it.
PLL_UNCERTAINTY = 0.4


def current_noise(iq, order: int = 4) -> float:
    """The logged current's white noise (A, standard deviation; ``iq`` ``(N,)`` A), from the median absolute
    ``order``-th difference (its variance is ``C(2k, k) σ²`` for white noise: 70 σ² at the fourth; it passes a
    sinusoid at f with gain ``(2 sin(π f T_s))^k``, 0.19 at the fourth and a 107 Hz dither sampled at 1 kHz). On
    dithered running logs the fourth difference reads somewhat above the noise (the dither's remainder, on the safe
    side for a threshold), the sixth closer to it; both also count the current the speed loop commands from a coarse
    encoder's noise, which can be several times the noise (:func:`current_noise_beside_angle` leaves it out)."""
    iq = np.asarray(iq, float)
    k = int(order)
    dk = np.abs(np.diff(iq, k)) if iq.size > k else np.zeros(0)
    return float(np.median(dk)) / (0.6745 * math.sqrt(math.comb(2 * k, k))) if dk.size else 0.0


#: Lags (samples, each side) of the logged angle's sixth difference that :func:`current_noise_beside_angle` predicts
#: the q-current's sixth difference from.
ANGLE_LAGS = 8


def current_noise_beside_angle(iq, theta, order: int = 6, lags: int = ANGLE_LAGS) -> float:
    """The logged current's white noise (A, standard deviation; ``iq``, ``theta`` ``(N,)`` A and rad): the
    ``order``-th difference of the q-current less what the same difference of the logged angle predicts through a
    two-sided filter of ``2 lags + 1`` taps (least squares), scaled as :func:`current_noise` scales it. The speed loop
    turns the encoder's noise into real current, a linear filter of the logged angle, which the difference alone counts
    as noise (several times the real noise with a 16-bit encoder); the measurement's noise is not in the angle. Falls
    back to
    :func:`current_noise` where the log is too short for the filter."""
    iq, theta = np.asarray(iq, float), np.asarray(theta, float)
    k, m = int(order), int(lags)
    d, e = np.diff(iq, k), np.diff(theta, k)
    n = d.size - 2 * m
    if n < 20 * (2 * m + 1):
        return current_noise(iq, order=k)
    X = np.column_stack([e[m + s:m + s + n] for s in range(-m, m + 1)])
    y = d[m:m + n]
    # columns scaled to unit RMS: the angle's differences are a few encoder counts, tiny against a current
    scale = np.sqrt(np.mean(X**2, axis=0))
    scale[scale == 0] = 1.0
    beta = np.linalg.lstsq(X / scale, y, rcond=None)[0]
    r = y - (X / scale) @ beta
    return float(np.median(np.abs(r))) / (0.6745 * math.sqrt(math.comb(2 * k, k)))


def _shifted(x: np.ndarray, delay: int) -> np.ndarray:
    """``x[j + delay]`` (the edges repeat the first or last sample): the current that acted over sample ``j`` when
    the log writes it ``delay`` samples late."""
    d = int(delay)
    if d == 0 or x.size == 0:
        return x
    out = np.empty_like(x)
    if d > 0:
        out[:-d] = x[d:]
        out[-d:] = x[-1]
    else:
        out[-d:] = x[:d]
        out[:-d] = x[0]
    return out


def _with_delay(prepared, delay: int, lag: float | None = None) -> list:
    """``prepared`` with the current shifted by ``delay`` samples and read held between samples (``lag`` ``None``), or
    as the smooth curve through them ``lag`` samples late (:class:`pgcomm.rotary.regression._Prepared`)."""
    return [replace(p, iq=_shifted(p.iq, delay), lag=None if lag is None else float(lag)) for p in prepared]


def unfiltered(iq: np.ndarray, t, tau: float) -> np.ndarray:
    """The current that acted, from a report of it through a first-order low-pass of time constant ``tau`` (s):
    ``i = i_m + τ di_m/dt`` (module docstring, "A filtered report").

    Args:
        iq: ``(N,)`` the logged current (A).
        t: ``(N,)`` time stamps (s), or the sample time (s) of a uniform log.
        tau: ``τ`` (s), ``0`` for the current as logged.

    Returns:
        ``(N,)`` A (``iq`` itself where ``tau`` is 0).
    """
    if tau == 0.0 or iq.size < 2:
        return iq
    if iq.size < 4:
        return iq + tau * np.gradient(iq, t)
    # the derivative of the interpolating cubic spline: fourth-order accurate, where a central difference's
    # sin(ωh)/(ωh) loses 6 % of a 100 Hz dither at 1 kHz, and τ/h times that comes back into the current
    tt = np.arange(iq.size) * float(t) if np.ndim(t) == 0 else np.asarray(t, float)
    return iq + tau * CubicSpline(tt, iq)(tt, 1)


def _with_report(prepared, tau: float) -> list:
    """``prepared`` with the current read through a report filter of ``tau`` (s) (:func:`unfiltered`)."""
    if tau == 0.0:
        return prepared
    return [replace(p, iq=unfiltered(p.iq, p.ts if p.t is None else p.t, tau)) for p in prepared]


def _reading_cost(prepared, layout: "_Layout", taps: int, tau: float, pll, delay: int, lag,
                  relative: bool = False) -> tuple[float, float]:
    """The basis fit's ``(cost, rows)`` (:func:`pgcomm.rotary.regression._basis_cost`) with the logs read one way: the
    current through a report filter of ``tau`` (s), the angle through a PLL ``pll`` (``(ω_n, ζ)`` or ``None``), the
    current ``delay`` samples late and held (``lag`` ``None``) or smooth ``lag`` samples late; with ``relative``,
    the share of the current the fit leaves unexplained (:func:`pgcomm.rotary.regression._unexplained`), as
    readings under different report filters are compared."""
    read = _with_delay(_with_pll(_with_report(prepared, tau), pll, taps), delay, lag)
    return _basis_cost(read, layout, taps, relative)


def _report_filter(prepared, layout: "_Layout", taps: int) -> dict:
    """The time constant of a first-order filter on the logged current (module docstring, "A filtered report"):
    the basis fit with the current read at each of :data:`REPORT_FILTERS` median steps and at the vertex of the
    parabola through the best and its neighbours; a filter only where its likelihood ratio (:func:`_evidence`) over the
    current as logged exceeds :data:`READING_EVIDENCE`. The fits are compared by the share of the current each leaves
    unexplained (:func:`pgcomm.rotary.regression._unexplained`): read back, a filtered current grows, and in amperes
    the current as logged would win by being small.

    Returns:
        ``{"tau_s": float (0: as logged), "evidence": float, "cost_by_tau": {τ (s): share unexplained}}``.
    """
    ts = float(np.median([p.ts for p in prepared]))
    taus = [f * ts for f in REPORT_FILTERS]
    found = _basis_costs([_with_report(prepared, tau) for tau in taus], layout, taps, relative=True)
    costs = {tau: c for tau, (c, _) in zip(taus, found)}
    rows = found[0][1]
    tau = _vertex(sorted(costs.items()), 0.0, taus[-1])
    if tau is not None and tau not in costs:
        costs[tau] = _basis_cost(_with_report(prepared, tau), layout, taps, relative=True)[0]
    best = min(costs, key=costs.get)
    evidence = _evidence(costs[0.0], costs[best], rows, taps)
    return {"tau_s": float(best) if evidence > READING_EVIDENCE else 0.0, "evidence": float(evidence),
            "cost_by_tau": {f"{k:.6g}": float(v) for k, v in sorted(costs.items())}}


def read_logs(prepared, orders: Orders, taps: int, encoder_step, current_delay, angle_pll, current_lag="detect",
              current_filter="detect") -> tuple[dict, dict, dict]:
    """How to read the logs: the angle's PLL, the current's timing (:func:`_reading`) and a report filter on the current
    (:func:`_report_filter`), each detected or as given.

    A filter and a delay mimic each other at the frequency that carries most of the current: a 17 ms filter on a
    100 Hz dither lags it by 2.3 ms, so a reading of the current two samples late, with a ``J/k0`` that takes the
    filter's attenuation, fits the dither nearly as well, and the other orders pay for it. So both are searched from
    two starts, each alternating (the filter under the reading found, then the reading under the filter, until the
    filter stays):

    * the reading first, the filter under it (a drive whose current is a sample late is not read as filtered);
    * the filter first, on the current as logged (held between samples, or smooth through them: the better), then
      the reading under it (a filtered report is not read as late);

    and the start whose basis fit (:func:`pgcomm.rotary.regression._basis_cost`, relative as the filter's readings
    are compared) is the lower wins.

    Args:
        prepared: the logs (:func:`pgcomm.rotary.regression._prepare`); orders, taps: the basis and filter taps;
        encoder_step, current_delay, angle_pll, current_lag: as :func:`_reading`; current_filter: ``"detect"`` or
            ``τ`` (s, 0: none).

    Returns:
        ``(angle_pll, current_delay, current_filter)``: the results' entries; ``current_filter`` as
        :func:`_report_filter` (``evidence``, ``cost_by_tau`` ``None`` where given).
    """
    given = not isinstance(current_filter, str)
    report = {"tau_s": float(current_filter or 0.0) if given else 0.0, "evidence": None, "cost_by_tau": None}
    layout = _Layout.of(orders)

    def read(tau):
        return _reading(_with_report(prepared, tau), orders, taps, encoder_step, current_delay, angle_pll,
                        current_lag)

    def pll_of(estimate):
        w = estimate["natural_frequency_rad_s"]
        return None if w is None else (w, estimate["damping"])

    def alternate(estimate, timing, report):
        for _ in range(2):
            found = _report_filter(_with_delay(_with_pll(prepared, pll_of(estimate), taps), timing["samples"],
                                               lag_of(timing)), layout, taps)
            moved = found["tau_s"] != report["tau_s"]
            report = found
            if not moved:
                break
            estimate, timing = read(report["tau_s"])
        return estimate, timing, report

    def cost(run):
        estimate, timing, found = run
        return _reading_cost(prepared, layout, taps, found["tau_s"], pll_of(estimate), timing["samples"],
                             lag_of(timing), relative=True)[0]

    detect_lag = isinstance(current_lag, str)

    def pll_refined(estimate, timing, report):
        # the PLL's frequency and damping refined last, with the current's lag (and a filter read): _refined
        if not (estimate.get("searched") and estimate["natural_frequency_rad_s"] is not None):
            return estimate, timing, report
        report, timing, estimate = _refined(prepared, layout, taps, report, timing, estimate,
                                            refine_lag=detect_lag and not timing["held"], refine_damping=True,
                                            refine_tau=not given and report["tau_s"] > 0.0)
        return estimate, timing, report

    estimate, timing = read(report["tau_s"])
    if given:
        return pll_refined(estimate, timing, report)
    runs = [alternate(estimate, timing, report)]
    # the filter first, under the current held between samples and smooth through them (a drive that controls
    # faster than it logs: read held, the filter's read-back current fits worse than the report itself)
    firsts = [_report_filter(_with_delay(prepared, 0, lag), layout, taps) for lag in (None, 0.0)]
    first = min(firsts, key=lambda f: min(f["cost_by_tau"].values()))
    if first["tau_s"] != runs[0][2]["tau_s"]:
        runs.append(alternate(*read(first["tau_s"]), first))
    estimate, timing, report = runs[int(np.argmin([cost(r) for r in runs]))] if len(runs) > 1 else runs[0]
    if report["tau_s"] > 0.0:
        report, timing, estimate = _refined(prepared, layout, taps, report, timing, estimate,
                                            refine_lag=detect_lag and not timing["held"])
        if estimate.get("searched") and detect_lag:
            found = _pll_under_filter(prepared, layout, taps, report, timing, estimate)
            if found is not None:
                estimate, timing, report = found
    return pll_refined(estimate, timing, report)


def _pll_under_filter(prepared, layout: "_Layout", taps: int, report: dict, timing: dict, estimate: dict):
    """A second start for :func:`_refined` where a report filter was read and the PLL searched: the PLL's grid under
    the filter found and shorter ones (:data:`SECOND_START_FILTERS`), with the current held and smooth at each of
    :data:`CONTROL_LAGS`, then the joint refinement from the best. Read first without the filter, the PLL can
    settle at the grid's fast end (no PLL), the filter then takes the PLL's lag and the current reads held (a twin's
    896 rad/s PLL and 17.3 ms filter as 3560 rad/s and 25 ms, seven times the true reading's residual). The second
    reading is taken only where it fits better than the first by the likelihood ratio every reading must pass
    (:data:`READING_EVIDENCE`); it is tried only where the PLL's reading matters, the slowest PLL of the grid fitting
    :data:`PLL_SECOND_START` times worse than the angle as logged (on logs too slow for a PLL's lag to show, 1.7
    times on the ODrive's, it would cost time and change nothing).

    Returns:
        ``(estimate, timing, report)`` of the second reading, or ``None`` where the first stands.
    """
    by_freq = estimate.get("cost_by_frequency") or {}
    if not by_freq or max(by_freq.values()) < PLL_SECOND_START * estimate["cost_as_logged"]:
        return None
    d = timing["samples"]

    def cost(tau, estimate, lag):
        pll = (None if estimate["natural_frequency_rad_s"] is None
               else (estimate["natural_frequency_rad_s"], estimate["damping"]))
        return _reading_cost(prepared, layout, taps, tau, pll, d, lag, relative=True)

    first, rows = cost(report["tau_s"], estimate, lag_of(timing))
    grid = [(cost(tau, {"natural_frequency_rad_s": w, "damping": 1.0}, lag)[0], tau, w, lag)
            for tau in (report["tau_s"] * f for f in SECOND_START_FILTERS)
            for lag in (None, *CONTROL_LAGS) for w in PLL_FREQUENCIES]
    _, tau, w, lag = min(grid, key=lambda g: g[0])
    start_timing = {**timing, **_timing(d, lag)}
    start = {**estimate, "natural_frequency_rad_s": float(w), "damping": 1.0}
    report2, timing2, estimate2 = _refined(prepared, layout, taps, {**report, "tau_s": float(tau)}, start_timing,
                                           start, refine_lag=lag is not None)
    second = cost(report2["tau_s"], estimate2, lag_of(timing2))[0]
    if _evidence(first, second, rows, taps) <= READING_EVIDENCE:
        return None
    # its "cost" is _refined's, in amperes as the PLL's other costs
    estimate2 = {**estimate2, "second_start": True}
    return estimate2, timing2, report2


def _refined(prepared, layout: "_Layout", taps: int, report: dict, timing: dict, estimate: dict, refine_lag: bool,
             refine_damping: bool = False, refine_tau: bool = True):
    """The filter's ``τ`` (``refine_tau``), the smooth current's lag (``refine_lag``) and a searched PLL's natural
    frequency (and its damping, ``refine_damping``) refined together, by Nelder–Mead on the basis fit's cost from the
    grids' values. They trade off (a filter lags the current as a lag does, and a PLL's lag on the angle turns the
    current against the acceleration as both do), so each refined under the others' grid values stops on the
    valley's side: read one after the other, a 17.3 ms filter and an 896 rad/s PLL on a twin's logs were read as
    19 ms and 1580 rad/s with a third of a sample's lag; refined together, 15.6 ms and 902 rad/s, at a seventh of
    the fit's mean squared residual. The natural frequency stays within the searched :data:`PLL_FREQUENCIES`, the
    damping within :data:`PLL_DAMPING_RANGE`, the filter within the longest of :data:`REPORT_FILTERS` (or its start).

    The damping is refined last, from the reading the others settled on, with or without a filter (free from the
    start, it let a reading that began at the grid's fast end stay there at the lowest damping): a drive's PLL runs
    at its control period ``T_c``, and ODrive's (predict, then correct by ``k_p T_c`` of the error,
    :mod:`pgcomm.rotary.twin`) lags its count by ``(1 − k_p T_c)`` times the continuous loop's lag at low
    frequencies, which is the continuous loop of ``ω_n/√(1 − k_p T_c)`` and ``ζ/√(1 − k_p T_c)``. At ODrive's 8 kHz
    and ``ω_n`` = 896 rad/s that is ``ζ`` = 1.13, between the grid's dampings: read at ``ζ`` = 1, the filter took the
    rest (17.3 ms read 15.6 ms; 17.2 ms with the damping). Without a filter, a PLL at ``k_p T_c`` = 0.5 read
    2510 rad/s at ``ζ`` = 1 for the equivalent 2110 rad/s at 1.41; 2060 at 1.37 with it.

    Returns:
        ``(report, timing, estimate)``, each as given or with the refined values (``"refined": True``).
    """
    d, lag0, tau0 = timing["samples"], lag_of(timing), report["tau_s"]
    # a PLL given, or searched and not taken, stays as it is; a searched and taken one is refined
    fixed = (None if estimate["natural_frequency_rad_s"] is None
             else (estimate["natural_frequency_rad_s"], estimate["damping"]))
    w0 = fixed[0] if fixed is not None and estimate.get("searched") else None
    zeta = estimate["damping"]
    z_lo, z_hi = PLL_DAMPING_RANGE

    # within the filters searched (REPORT_FILTERS): compared by the share unexplained (_report_filter), the read-back
    # tends to τ di/dt as τ grows, a share that no longer depends on τ, and the simplex could walk off along it
    # (on zoo motor 2:0 with a real drive's habits, to 1e9 s)
    tau_max = max(REPORT_FILTERS) * float(np.median([p.ts for p in prepared]))

    def unpack(x):
        # relative steps in τ and ω_n: the cost's scale in each is the value itself
        tau = min(tau0 * math.exp(x[0]), max(tau_max, tau0)) if refine_tau else tau0
        lag = float(np.clip(x[int(refine_tau)], -0.5, 0.5)) if refine_lag else lag0
        # within the natural frequencies searched: beyond them the reading is the angle as logged's
        if w0 is None:
            return tau, lag, fixed
        z = float(np.clip(zeta * math.exp(x[-1]), z_lo, z_hi)) if refine_damping else zeta
        w = w0 * math.exp(x[-2] if refine_damping else x[-1])
        return tau, lag, (float(np.clip(w, PLL_FREQUENCIES[0], PLL_FREQUENCIES[-1])), z)

    def f(x):
        tau, lag, pll = unpack(x)
        # relative where τ moves: the read-back current's scale moves with it (_report_filter)
        return _reading_cost(prepared, layout, taps, tau, pll, d, lag, relative=refine_tau)[0]

    x0 = np.array(([0.0] if refine_tau else []) + ([lag0] if refine_lag else []) + ([0.0] if w0 is not None else [])
                  + ([0.0] if w0 is not None and refine_damping else []))
    if x0.size == 0:
        return report, timing, estimate
    step = np.diag(np.full(x0.size, 0.1))
    res = minimize(f, x0, method="Nelder-Mead",
                   options={"initial_simplex": np.vstack([x0, x0 + step]), "xatol": 2e-3, "fatol": 0.0,
                            "maxfev": 80 * x0.size})
    if not res.fun < f(x0):
        return report, timing, estimate
    tau, lag, pll = unpack(res.x)
    if refine_tau:
        costs = dict(report["cost_by_tau"] or {})
        costs[f"{tau:.6g}"] = float(res.fun)
        report = {**report, "tau_s": tau, "cost_by_tau": dict(sorted(costs.items(), key=lambda kv: float(kv[0]))),
                  "refined": True}
    if refine_lag:
        timing = {**timing, "lag": lag}
    if w0 is not None:
        # the PLL's costs are in amperes: refined with τ, the fit's own again
        cost = float(res.fun) if not refine_tau else _reading_cost(prepared, layout, taps, tau, pll, d, lag)[0]
        by_freq = dict(estimate.get("cost_by_frequency") or {})
        by_freq[f"{pll[0]:.4g}"] = cost
        estimate = {**estimate, "natural_frequency_rad_s": float(pll[0]), "damping": float(pll[1]),
                    "cost": cost,
                    "cost_by_frequency": by_freq, "refined": True}
    return report, timing, estimate


def filter_text(found: dict | None) -> str | None:
    """One line on the current's report filter as :func:`_report_filter` found it, or ``None`` where not searched."""
    if not found:
        return None
    given = found.get("evidence") is None
    if found["tau_s"] == 0.0:
        return "the logged q-current is the current that acted" + (" (as given)" if given else
                                                                    " (no report filter fits better)")
    why = "as given" if given else f"likelihood ratio {found['evidence']:.3g} over the current as logged"
    return (f"the logged q-current is a filtered report: a first-order lag of {found['tau_s'] * 1e3:.3g} ms, read back "
            f"as i = i_logged + tau di/dt ({why})")


def _vertex(points, lo: float, hi: float) -> float | None:
    """The vertex of the parabola through the lowest of ``points`` (``(x, cost)``, ``x`` increasing) and its two
    neighbours, clipped to ``[lo, hi]``; ``None`` at an end of the grid or where the three are not convex."""
    j = min(range(len(points)), key=lambda i: points[i][1])
    if j == 0 or j == len(points) - 1:
        return None
    (x0, y0), (x1, y1), (x2, y2) = points[j - 1:j + 2]
    if not all(math.isfinite(y) for y in (y0, y1, y2)):
        return None
    den = (x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0)
    if den >= 0:
        return None
    x = x1 - 0.5 * ((x1 - x0) ** 2 * (y1 - y2) - (x1 - x2) ** 2 * (y1 - y0)) / den
    return float(min(max(x, lo), hi))


def _lag_search(prepared, layout: "_Layout", taps: int, delay: int) -> tuple[dict, float]:
    """The smooth reading's fit at ``delay`` for each of :data:`CONTROL_LAGS` and at the vertex of the parabola
    through the best and its neighbours (the cost is quadratic in the lag near its minimum: a timing error turns every
    harmonic of the current).

    Returns:
        ``({lag: A²}, rows)``.
    """
    found = _basis_costs([_with_delay(prepared, delay, f) for f in CONTROL_LAGS], layout, taps)
    costs = {f: c for f, (c, _) in zip(CONTROL_LAGS, found)}
    rows = found[-1][1]
    f = _vertex(sorted(costs.items()), -0.5, 0.5)
    if f is not None and f not in costs:
        costs[f], rows = _basis_cost(_with_delay(prepared, delay, f), layout, taps)
    return costs, rows


def _current_delay(prepared, layout: "_Layout", taps: int, delays=CURRENT_DELAYS, lag="detect") -> dict:
    """The delay (samples) of the logged q-current behind the current that acted, and whether it is held or smooth
    between logged samples (module docstring, "The current's timing"): the ridge-validated fit of ``layout`` with the
    current shifted by each of :data:`CURRENT_DELAYS` and held, then read smooth at the best of those delays and the
    one before, each with the lags of :data:`CONTROL_LAGS`; its mean squared residual from the normal
    equations. A reading other than the log as written (delay 0, held) only where its likelihood ratio
    (:func:`_evidence`) exceeds :data:`READING_EVIDENCE`.

    Args:
        delays: the delays tried (samples; 0, or else the first, is the log as written).
        lag: ``"detect"`` tries both forms; ``None`` held only; a number (samples) smooth with that lag only.

    Returns:
        ``{"samples": int, "held": bool, "lag": float (samples, smooth only), "cost_by_delay": {delay: A²} (held),
        "cost_by_form": {"held": A², "smooth": A²} (each form's best), "evidence": float}``.
    """
    costs, rows = {}, 0.0
    as_written = 0 if 0 in delays else delays[0]
    detect = isinstance(lag, str)
    if detect or lag is None:
        found = _basis_costs([_with_delay(prepared, d) for d in delays], layout, taps)
        costs.update({(d, None): c for d, (c, _) in zip(delays, found)})
        rows = found[-1][1]
    if detect or lag is not None:
        near = delays
        if costs:
            best_held = min(costs, key=costs.get)[0]
            # the held reading of a smooth current fits as well one sample later or not: try the smooth at both
            near = [d for d in delays if best_held - 1 <= d <= best_held]
        for d in near:
            if detect:
                found, rows = _lag_search(prepared, layout, taps, d)
                costs.update({(d, f): c for f, c in found.items()})
            else:
                costs[d, float(lag)], rows = _basis_cost(_with_delay(prepared, d, lag), layout, taps)
    base = (as_written, None if detect or lag is None else float(lag))
    best = min(costs, key=costs.get)
    evidence = _evidence(costs[base], costs[best], rows, taps)
    chosen = best if evidence > READING_EVIDENCE else base
    by_form = {name: min((v for k, v in costs.items() if (k[1] is None) == held), default=None)
               for name, held in (("held", True), ("smooth", False))}
    return {**_timing(chosen[0], chosen[1]),
            "cost_by_delay": {int(k[0]): v for k, v in costs.items() if k[1] is None} or None, "cost_by_form": by_form,
            "evidence": float(evidence)}


def _timing(delay: int, lag: float | None) -> dict:
    """The results' entries of a reading of the current: ``samples``, ``held`` and ``lag`` (0 where held)."""
    return {"samples": int(delay), "held": lag is None, "lag": 0.0 if lag is None else float(lag)}


def pll_corrected(theta: np.ndarray, sample_time: float, natural_frequency: float, damping: float,
                  t: np.ndarray | None = None) -> np.ndarray:
    """The rotor's angle from a drive's estimate of it: the output of a type-2 phase-locked loop,
    ``θ̂ = (k_p s + k_i) / (s² + k_p s + k_i) θ`` with ``k_p = 2 ζ ω_n``, ``k_i = ω_n²`` (ODrive's encoder PLL:
    ``ζ = 1``, ``ω_n`` its bandwidth). Solved for ``θ``: ``θ = θ̂ + s² / (k_p s + k_i) θ̂``, applied in the
    frequency domain up to the log's Nyquist frequency (a second difference and a bilinear low-pass at the log's
    rate would take 0.4x of the correction at 3 samples per period, where the cogging's highest order sits): to
    ``θ̂`` less the line through its ends, extended oddly (continuous with its slope, so only a few samples at each
    end feel the extension).

    A host's time stamps are not uniform (steps of ±14 % and more): read as uniform, the angle's steps of ``ω dt``
    turn into an acceleration the correction's ``s²`` amplifies (on a rotor at 0.5 rad/s with a 576 rad/s PLL, a
    basis fit ten times worse than with no correction). With ``t``, the estimate is taken onto a uniform grid of
    ``sample_time`` through the cubic spline on the stamps, corrected there, and the correction brought back to the
    stamps by the same spline.

    Args:
        theta: ``(N,)`` the logged estimate (rad); sample_time: s (the median step where ``t`` is given);
        natural_frequency: ``ω_n`` (rad/s); damping: ``ζ``; t: ``(N,)`` increasing time stamps (s), or ``None``:
        uniform at ``sample_time``.

    Returns:
        ``(N,)`` rad.
    """
    th = np.asarray(theta, float)
    n = th.size
    if n < 3:
        return th.copy()
    if t is not None:
        t = np.asarray(t, float)
        h = float(sample_time)
        grid = t[0] + h * np.arange(int(math.floor((t[-1] - t[0]) / h)) + 1)
        if grid.size >= 3:
            on_grid = CubicSpline(t, th)(grid)
            correction = pll_corrected(on_grid, h, natural_frequency, damping) - on_grid
            # the grid ends at or before the last stamp: the spline extrapolates by less than a step
            return th + CubicSpline(grid, correction)(t)
    kp, ki = 2.0 * damping * natural_frequency, natural_frequency**2
    x = th - np.linspace(th[0], th[-1], n)
    ext = np.concatenate([x, -x[-2:0:-1]])
    s = 2j * np.pi * np.fft.rfftfreq(ext.size, float(sample_time))
    # the line's correction is zero: s² kills it
    return th + np.fft.irfft(np.fft.rfft(ext) * (s * s / (kp * s + ki)), ext.size)[:n]


def pll_noise_gain(sample_time: float, natural_frequency: float, damping: float, taps: int) -> float:
    """The factor by which :func:`pll_corrected` multiplies the variance a white angle noise puts in a row's filtered
    acceleration: ``∫ |W(f)|² |1 + H(f)|² df / ∫ |W(f)|² df``, ``W`` the row's weights on the angle (the second
    difference through the Hann filter of ``taps``, :mod:`pgcomm.rotary.regression`), ``H = s² / (k_p s + k_i)`` the
    correction.

    A host's clock puts a white noise ``ω δt`` in the logged angle (:mod:`pgcomm.rotary.host_clock`), and its variance
    in the acceleration is taken out of the fit. The correction amplifies it: above the PLL's bandwidth ``|H| ≈ ω /
    k_p``, so a slower PLL's reading carries more of it. Left at the angle-as-logged's variance, each slower reading
    would fit worse by the noise it adds, and the search would settle at the grid's fast end (a twin's 896 rad/s PLL
    read at 2100 rad/s, with the report filter taking the lag the PLL left).

    Args:
        sample_time: the log's (median) step (s); natural_frequency: ``ω_n`` (rad/s); damping: ``ζ``; taps: the
            acceleration filter's taps.

    Returns:
        the variance ratio (dimensionless): above 1 for a PLL slow against the log rate, below 1 for one whose
        bandwidth lies in the row's band, where the correction's ``|1 + H|`` dips below 1 (at 1 kHz and 6 taps:
        1.58 at 500 rad/s, 0.82 at 1077 rad/s, ζ = 1; 0.59 at 1581 rad/s, ζ = 0.5).
    """
    w = np.convolve(_hann(taps), [1.0, -2.0, 1.0])
    n = 1 << 14
    weights = np.abs(np.fft.fft(w, n)) ** 2
    s = 2j * np.pi * np.fft.fftfreq(n, float(sample_time))
    kp, ki = 2.0 * damping * natural_frequency, natural_frequency**2
    gain = np.abs(1.0 + s * s / (kp * s + ki)) ** 2
    return float(np.sum(weights * gain) / np.sum(weights))


def _with_pll(prepared, pll, taps: int) -> list:
    """``prepared`` with the angle corrected for a PLL ``pll`` (``(ω_n, ζ)`` or ``None``: as logged), and the host
    clock's noise in the acceleration (:attr:`pgcomm.rotary.regression._Prepared.timing_noise`) scaled by what the
    correction does to it (:func:`pll_noise_gain`)."""
    if pll is None:
        return prepared
    # the same corrected angle for the same reading: the search tries each PLL several times, and the fit's angle parts
    # are kept per angle array (pgcomm.rotary.regression.angle_parts_kept)
    cache = _angle_parts()
    out = []
    for p in prepared:
        theta = cache.derived(p.theta, ("pll", p.ts, *pll), lambda p=p: pll_corrected(p.theta, p.ts, *pll, t=p.t))
        noise = p.timing_noise
        if noise is not None:
            noise = cache.derived(noise, ("pll noise", p.ts, *pll, taps),
                                  lambda p=p: p.timing_noise * pll_noise_gain(p.ts, *pll, taps))
        out.append(replace(p, theta=theta, timing_noise=noise))
    return out


def _angle_pll(prepared, layout: "_Layout", taps: int, smooth_delays: tuple = ()) -> dict:
    """Whether the logged angle reads as a drive's PLL estimate (module docstring, "The angle's estimate"): the
    basis fit with the angle corrected for each natural frequency of :data:`PLL_FREQUENCIES` at ``ζ = 1``, then
    each :data:`PLL_DAMPINGS` at the best frequency and its neighbours, against the angle as logged; a PLL only
    where its likelihood ratio (:func:`_evidence`) exceeds :data:`READING_EVIDENCE`.

    With ``smooth_delays``, each reading of the angle is scored with the current read smooth at the best of those
    delays and its best lag (:func:`_lag_search`): a PLL's lag on the angle and a smooth current's lag both turn the
    current against the acceleration, and along the valley they trade one for the other, so reading the two in turn
    stops on the valley's side, away from its floor. The valley crosses whole samples of delay (a current written a
    sample late, read at the held reading's delay, finds a slow PLL, two samples and a half-sample lag instead of the
    drive's PLL, one sample and its lag), so the delay before is tried too.

    Returns:
        ``{"natural_frequency_rad_s": float | None, "damping": float | None, "cost_as_logged": A², "cost": A²,
        "evidence": float, "cost_by_frequency": {"ω_n": A²}}`` (``None``: read as logged; the frequencies as
        strings of 4 digits, the results' keys).
    """
    def cost_of(prep):
        if not smooth_delays:
            return _basis_cost(prep, layout, taps)
        found = [_lag_search(prep, layout, taps, d) for d in smooth_delays]
        return min(min(costs.values()) for costs, _ in found), found[0][1]

    plain, rows = cost_of(prepared)
    grid = np.asarray(PLL_FREQUENCIES, float)
    costs = np.array([cost_of(_with_pll(prepared, (w, 1.0), taps))[0] for w in grid])
    by_freq = {f"{w:.4g}": float(c) for w, c in zip(grid, costs)}  # results keys are strings
    j = int(np.argmin(costs))
    best, best_cost = (float(grid[j]), 1.0), float(costs[j])
    if 0 < j < grid.size - 1:
        # the grid is 1.47x per step: the minimum of a parabola in ln ω_n through the best point and its neighbours
        x, y = np.log(grid[j - 1:j + 2]), np.log(costs[j - 1:j + 2])
        den = y[0] - 2 * y[1] + y[2]
        if den > 0:
            w = float(np.exp(x[1] + 0.5 * (y[0] - y[2]) / den * (x[1] - x[0])))
            c = cost_of(_with_pll(prepared, (w, 1.0), taps))[0]
            by_freq[f"{w:.4g}"] = c
            if c < best_cost:
                best, best_cost = (w, 1.0), c
    for z in PLL_DAMPINGS:
        if z == 1.0:
            continue
        for w in grid[max(0, j - 1):j + 2]:
            c = cost_of(_with_pll(prepared, (float(w), z), taps))[0]
            if c < best_cost:
                best, best_cost = (float(w), float(z)), c
    evidence = _evidence(plain, best_cost, rows, taps)
    # no gate on the residual's drop: a drive's true PLL can lower it as little as a fast PLL that is not there lowers
    # it on an angle with noise of its own (off any lattice), so a gate would refuse true readings and leave their maps
    # off while called resolved; a false reading's move is counted in the verdict instead (pll_bias)
    taken = evidence > READING_EVIDENCE
    return {"natural_frequency_rad_s": best[0] if taken else None, "damping": best[1] if taken else None,
            "cost_as_logged": plain, "cost": best_cost if taken else plain, "evidence": float(evidence),
            "cost_by_frequency": by_freq}


def _reading(prepared, orders: Orders, taps: int, encoder_step, current_delay, angle_pll,
             current_lag="detect") -> tuple[dict, dict]:
    """How to read the logs: the angle (a drive's PLL estimate or the rotor's, :func:`_angle_pll`) and the current's
    timing (its delay, and held or linear between samples: :func:`_current_delay`), each detected or as given. Each
    masks the other (a current a sample late hid ODrive's PLL: the PLL's reading fitted worse than the angle as
    logged), so where both are detected and the current is not read as written the angle is read again with that
    reading, and the current's timing again with the angle's.

    Returns:
        ``(angle_pll, current_delay)``: the results' entries.
    """
    layout = _Layout.of(orders)
    search_pll = False
    if isinstance(angle_pll, str):
        # a raw encoder angle sits on its lattice (read here even when the correction is turned off: the
        # rounding's noise in the acceleration, uncorrected, reads as a PLL's high-frequency gain)
        steps = [p.step if isinstance(encoder_step, str) else quantisation.encoder_step(p.theta) for p in prepared]
        search_pll = all(q is None for q in steps)
        pll = None
    else:
        pll = None if angle_pll is None else (float(angle_pll[0]), float(angle_pll[1]))
    estimate = {"natural_frequency_rad_s": None if pll is None else pll[0], "damping": None if pll is None else pll[1],
                "searched": False}
    detect_delay, detect_form = isinstance(current_delay, str), isinstance(current_lag, str)
    timing = {**_timing(0 if detect_delay else current_delay, None if detect_form else current_lag),
              "cost_by_delay": None, "evidence": None}
    delays = CURRENT_DELAYS if detect_delay else (timing["samples"],)

    def read_angle(timing):
        found = {**_angle_pll(_with_delay(prepared, timing["samples"], lag_of(timing)), layout, taps),
                 "searched": True}
        w = found["natural_frequency_rad_s"]
        return found, (None if w is None else (w, found["damping"]))

    def alternate(lag, estimate, pll, timing):
        if search_pll:
            estimate, pll = read_angle(timing)
        for _ in range(2):
            if detect_delay or detect_form:
                timing = _current_delay(_with_pll(prepared, pll, taps), layout, taps, delays, lag)
            if not (search_pll and (timing["samples"] != 0 or not timing["held"])):
                break
            before = pll
            estimate, pll = read_angle(timing)
            if pll == before:
                break
        return estimate, pll, timing

    if search_pll and detect_form:
        # a smooth current a little early mimics a PLL's lag on the angle (ODrive's at 1000 rad/s with a late current:
        # 50x the residual of the PLL's reading), so the angle and the current are read with the current held first;
        # where the current then reads smooth, the angle is read again with the smooth current's lag fitted for each
        # PLL (_angle_pll's smooth_delay), and the two readings are compared on their own fits
        runs = [alternate(None, estimate, pll, timing)]
        free = _current_delay(_with_pll(prepared, runs[0][1], taps), layout, taps, delays, "detect")
        if not free["held"]:
            d = free["samples"]
            found = {**_angle_pll(prepared, layout, taps, tuple(x for x in (d - 1, d) if x in delays)),
                     "searched": True}
            q = None if found["natural_frequency_rad_s"] is None else (found["natural_frequency_rad_s"],
                                                                       found["damping"])
            runs.append((found, q, _current_delay(_with_pll(prepared, q, taps), layout, taps, delays, "detect")))
        cost = [_basis_cost(_with_delay(_with_pll(prepared, q, taps), t["samples"], lag_of(t)), layout, taps)[0]
                for _, q, t in runs]
        estimate, pll, timing = runs[int(np.argmin(cost))]
    else:
        estimate, pll, timing = alternate(current_lag, estimate, pll, timing)
    timing["detected"] = detect_delay or detect_form
    return estimate, timing


def detect_reading(logs, motor: RotaryMotor, options: RotaryIdentifyOptions | None = None) -> tuple[dict, dict]:
    """How :func:`~pgcomm.rotary.identify.identify` would read ``logs`` with ``options`` (the angle's PLL and the
    current's delay and form, module docstring; the orders, the alias guard, the filter's taps and the encoder's step as
    it takes them), without the identification: e.g. to read the logs before counting the slots from them (a late
    current or a PLL's angle hides the cogging's orders).

    Returns:
        ``(angle_pll, current_delay)``: the entries :func:`identify` reports
        (:class:`~pgcomm.rotary.identify.RotaryIdentification`).
    """
    options = options or RotaryIdentifyOptions()
    orders = orders_of(options, motor)
    samples = MIN_SAMPLES_PER_PERIOD if options.min_samples_per_period is None else options.min_samples_per_period
    taps = FILTER_TAPS if options.taps is None else options.taps
    try:
        prepared, _, _, _ = _prepare(logs, motor, orders, samples, taps, options.encoder_step)
    except ExcitationError:
        if options.orders is not None:
            raise
        # logs too fast for every order of the motor's basis: read on the orders they resolve, as identify fits them
        orders, _ = resolved_orders(logs, motor, orders, samples)
        prepared, _, _, _ = _prepare(logs, motor, orders, samples, taps, options.encoder_step)
    return _reading(prepared, orders, taps, options.encoder_step, options.current_delay, options.angle_pll,
                    options.current_lag)


def orders_of(options: RotaryIdentifyOptions, motor: RotaryMotor) -> Orders:
    """The maps' orders ``options`` give, or the motor's (:meth:`Orders.for_motor`) where they give none."""
    if options.orders is None:
        return Orders.for_motor(motor)
    return Orders(*(np.asarray(o, int) for o in options.orders))


def apply_reading(log: dict, current_delay: int, angle_pll, sample_time: float) -> dict:
    """``log`` (a dict with ``theta`` and ``iq_1``) as :func:`identify` reads it: the current shifted by
    ``current_delay`` samples (edges repeated), the angle corrected for ``angle_pll`` (``(ω_n, ζ)`` or ``None``,
    :func:`pll_corrected`; ``sample_time`` in s where the log has no ``t``). A new dict; the other columns as they
    are."""
    out = dict(log)
    key = "iq_1" if "iq_1" in log else "iq"
    out[key] = _shifted(np.asarray(log[key], float), int(current_delay))
    if angle_pll is not None:
        t = np.asarray(log["t"], float) if "t" in log else None
        ts = float(np.median(np.diff(t))) if t is not None and t.size > 1 else float(sample_time)
        out["theta"] = pll_corrected(np.asarray(log["theta"], float), ts, *angle_pll, t=_log_time(log))
    return out


def _times(ratio: float) -> str:
    """A factor for a sentence: ``"1.9x"``, ``"190x"``, ``"1.2e+08x"``."""
    return f"{ratio:.0f}x" if 10 <= ratio < 1e6 else f"{ratio:.2g}x"


def lag_of(timing: dict):
    """The ``current_lag`` that reads the logs as ``timing`` (``current_delay``) says: ``None`` held, else the
    smooth curve's lag (samples)."""
    return None if not timing or timing.get("held", True) else float(timing.get("lag", 0.0))


def delay_text(timing: dict) -> str | None:
    """One sentence on the logged current's timing (``current_delay`` of
    :func:`pgcomm.rotary.identify.identify`), or ``None`` when it was given rather than detected."""
    if not timing or not timing.get("detected"):
        return None
    costs = {int(k): v for k, v in (timing.get("cost_by_delay") or {}).items()}
    d = int(timing["samples"])
    if not timing.get("held", True):
        lag = float(timing.get("lag", 0.0))
        forms = timing.get("cost_by_form") or {}
        better = (f"; it fits {_times(forms['held'] / forms['smooth'])} better so than held from sample to sample"
                  if forms.get("held") and forms.get("smooth") else "")
        rate = f", about {1.0 / (2.0 * lag):.0f} control cycles per logged sample" if lag > 0.5 / 1000 else ""
        late = (f"; written {abs(d)} sample(s) {'late' if d > 0 else 'early'} against the angle: used shifted by {d}"
                if d else "")
        return (f"the logged q-current is a snapshot of a current that moves between logged samples (a drive that "
                f"controls faster than it logs{rate}): read as the smooth curve through the samples, {lag:.3g} sample "
                f"late{better}{late}")
    if d == 0:
        near = [costs[k] / costs[0] for k in (-1, 1) if k in costs and costs.get(0)]
        return ("the logged q-current is in time with the angle" + (
            f" (shifted by one sample it fits {_times(min(near))} worse)" if near else ""))
    if not (costs.get(0) and costs.get(d)):
        # the delay given, its form (held from sample to sample) detected: nothing to compare it with
        return f"the logged q-current is used shifted by {d} sample(s) against the angle, as given"
    return (f"the logged q-current is {abs(d)} sample(s) {'late' if d > 0 else 'early'} against the angle: used "
            f"shifted by {d} (it fits {_times(costs[0] / costs[d])} better so; the drive samples its current at another "
            "point of its cycle than the encoder, or the logger writes it late)")


def pll_text(estimate: dict) -> str | None:
    """One sentence on how the logged angle was read (``angle_pll`` of :func:`identify`), or ``None`` when
    nothing was searched or given."""
    if not estimate:
        return None
    w = estimate.get("natural_frequency_rad_s")
    if w is None and not estimate.get("searched"):
        return None
    if w is None:
        return ("the logged angle is not on an encoder's lattice, and it fits best as the rotor's angle (no drive "
                "PLL's lag found in it)")
    how = (f"it fits {_times(estimate['cost_as_logged'] / estimate['cost'])} better so"
           if estimate.get("searched") else "as given")
    return (f"the logged angle is read as a drive's PLL estimate of natural frequency {w:.0f} rad/s and damping "
            f"{estimate['damping']:.3g}, and its lag taken out ({how}; log the encoder's count if the drive has it)")
