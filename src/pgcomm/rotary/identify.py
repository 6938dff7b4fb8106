"""Identification of a rotary motor from running logs, with or without a torque sensor.

**Without a torque sensor** (the drive's own logs: ``t``, ``theta``, ``iq``). The model of
:mod:`pgcomm.rotary.model` divided by ``k0``::

    (J/k0) θ̈ = (1 + r(θ)) i_q + c(θ) − d(θ) s(ω) − b ω

is linear in ``J/k0``, the Fourier coefficients of ``r``, ``c``, ``d`` and ``b``; the ``1`` in
front of ``i_q`` fixes the scale (only ratios are observable). Least squares on::

    i_q,f = (J/k0) θ̈_f − Σ r_h (i_q φ_h)_f − Σ c_h φ_h,f + Σ d_h (s φ_h)_f + b ω_f

**Where the parts are.** The regression (the filter, the kernel, the alias guard, the encoder's noise, the ridge, the
orders outside the basis) is :mod:`pgcomm.rotary.regression`; how the logs are read (the current's timing, a PLL's
angle) :mod:`pgcomm.rotary.readings`; time-periodic disturbances :mod:`pgcomm.rotary.time_lines`. This module
puts them together (:func:`identify`), gives each map its standard error and its verdict, and fits the
feedforward (:func:`fit_mechanics`).

**With a torque sensor** (column ``torque``, N·m: the air-gap torque): ``T = k0 (1 + r) i_q +
T_cog(θ)`` sample by sample, no filter; gives ``k0`` (N·m/A), the ripple and the cogging in N·m
(returned in current units with ``k_t = k0``).
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, replace

import numpy as np

from pgcomm.errors import DataError, ExcitationError
from pgcomm.rotary.model import Fourier, RotaryModel, drive_orders, harmonic_columns
from pgcomm.rotary.motor import RotaryMotor
from pgcomm.rotary.back_emf import agreement, fit_voltage, has_voltage
from pgcomm.rotary.winding import BACK_EMF_FACTOR
from pgcomm.rotary.power_ups import index_offsets, tested
from pgcomm.rotary.readings import PLL_UNCERTAINTY, read_logs, _with_delay, _with_pll, _with_report, \
    _shifted, apply_reading, current_noise_beside_angle, lag_of, orders_of, unfiltered
from pgcomm.rotary.over_the_angle import agreement as angle_agreement, read_over_the_angle
from pgcomm.rotary.regression import _basis_cost, _unit_hint, _chunks, _fit, _full, _Layout, _line_columns, _log_arrays, \
    _map_error_quantile, _map_gram, _map_standard_error, _prepare, _quantisation_correction, _require_current, _significant_extra_orders, \
    angle_parts_kept, DETERMINED_SHARE, EXTRA_ORDER_ALPHA, FILTER_TAPS, information_shares, MIN_SAMPLES_PER_PERIOD, Orders, RIDGE_GRID, \
    resolved_orders
from pgcomm.rotary.time_lines import _time_lines
from pgcomm.rotary.host_clock import unresolved_timing_noise, weigh
from pgcomm.settings import RotaryIdentifyOptions
from pgcomm.rotary.law import MIN_GAIN

__all__ = ["identify", "fit_mechanics", "orders_of", "Reading", "check_plausible", "resolution_verdict", "share_text", "orders_text",
           "RESOLVED_SHARE", "RESOLVED_CONFIDENCE", "RotaryIdentification"]


@dataclass(frozen=True)
class Reading:
    """How :func:`identify` read a drive's logs (:meth:`RotaryIdentification.reading`), for
    :meth:`pgcomm.settings.RotaryIdentifyOptions.with_reading`.

    Attributes:
        current_delay: samples by which the logged q-current lags the current that acted.
        current_lag: the smooth current's lag between samples (samples), or ``None``: held.
        angle_pll: ``(ω_n rad/s, ζ)`` of the drive's PLL whose estimate the logged angle is, or ``None``.
        time_lines: frequencies (Hz) of the time-periodic disturbances fitted.
        current_filter: time constant (s) of the drive's first-order report filter taken out of the logged current;
            ``0.0``: the current read as logged.
    """

    current_delay: int
    current_lag: float | None
    angle_pll: tuple[float, float] | None
    time_lines: tuple[float, ...]
    current_filter: float = 0.0


#: The fields of :class:`RotaryIdentification` an identification from running logs fills, in ``results.json``'s order.
_RUNNING_KEYS = ("windows", "windows_used", "windows_refused_alias", "windows_refused_slow", "speed_limit_rad_s",
                 "min_samples_per_period", "highest_order", "filter_taps", "unknowns", "ridge", "ridge_chosen_by",
                 "validation_curve", "orders_added", "orders_screened", "cost_A2", "inertia_ratio", "standard_error",
                 "quantisation", "current_delay", "angle_pll", "current_filter", "information_share", "drive_orders",
                 "pinned", "time_lines", "back_emf", "current_noise_A", "current_noise_from",
                 "current_noise_correction", "host_clock", "seconds")
#: ... and those written only when set: the alias guard's note, and what a rotary experiment's rounds of logs add.
_OPTIONAL_KEYS = ("note", "orders_not_resolved", "orders_over_the_angle", "index_offsets", "rounds", "first_round_standard_error", "log_budget_s", "speed_shares",
                  "set_aside_s")
#: ... and an identification with a torque sensor.
_TORQUE_KEYS = ("k0", "cost_Nm2", "seconds")


@dataclass(frozen=True)
class RotaryIdentification:
    """Result of :func:`identify`: the model, each map's standard error and verdict, and how the logs were read.

    A result is data: :meth:`to_dict` (``results.json``'s ``identification``, keys in ``docs/results.md``) computes
    nothing and returns a copy. The sections that are reports of their own (``standard_error`` per map,
    ``current_delay``, ``angle_pll``, ``current_filter``, ``time_lines``, ``back_emf``, ``quantisation``, the current's
    noise) are JSON-ready dicts as their modules write them (:mod:`pgcomm.rotary.readings`,
    :mod:`pgcomm.rotary.time_lines`, :mod:`pgcomm.rotary.back_emf`); :func:`map_text` and the ``*_text`` functions
    read them.

    Attributes:
        model: :class:`RotaryModel` (current units).
        seconds: the identification's wall time (s).
        torque_sensor: identified from a ``torque`` column; then ``k0`` (N·m/A) and ``cost_Nm2`` (N²·m²) are set and
            the running-log fields are ``None``.
        windows, windows_used, windows_refused_alias, windows_refused_slow: filter windows in all, used, refused by
            the alias guard (faster than ``speed_limit_rad_s``), refused as too slow.
        min_samples_per_period, highest_order, filter_taps, unknowns: the alias guard, the highest modelled order, the
            filter's taps, the fit's unknowns.
        ridge, ridge_chosen_by, validation_curve: the relative ridge weight, how it was chosen, held-out cost per
            candidate (A²).
        orders_added, orders_screened: orders outside the basis the logs added (per map), whether they were screened.
        cost_A2, inertia_ratio: the fit's cost (A²) and ``J/k0`` (A·s²/rad).
        standard_error: per map (``cogging``, ``ripple``, ``direction``) its standard error and verdict
            (:func:`resolution_verdict`).
        quantisation, current_delay, angle_pll, current_filter, time_lines, back_emf: the encoder's correction and the
            logs' reading (:mod:`pgcomm.rotary.readings`, :mod:`pgcomm.rotary.time_lines`), the q-voltage's check
            (:mod:`pgcomm.rotary.back_emf`; ``None`` without a voltage).
        information_share, pinned, drive_orders: each map's information beyond the angle's, the maps pinned, the
            cogging at the drive's own orders.
        current_noise_A, current_noise_from, current_noise_correction: the logged current's noise (A), where it was
            read, the fit's correction for it.
        host_clock: the logged angle's timing noise (µs) and whether the rows were weighted for it
            (:func:`pgcomm.rotary.host_clock.weigh`).
        note: the alias guard's refusals in words, where it refused windows.
        orders_not_resolved: where the logs turn too fast for the motor's basis, the orders left out of it and the
            speeds (:func:`pgcomm.rotary.regression.resolved_orders`; :func:`orders_text`).
        orders_over_the_angle: where orders were cut, the cogging's cut orders read over the angle
            (:func:`_cut_orders_over_the_angle`).
        index_offsets: the encoder index's offsets found between the logs' power-ups and removed before the fit
            (:func:`pgcomm.rotary.power_ups.index_offsets`: per log file, the offset in rad and the binned maps'
            correlation before and after), where one was.
        rounds, first_round_standard_error, log_budget_s: set by a rotary experiment that logs in rounds
            (:func:`pgcomm.rotary.experiment.record_running_logs`); speed_shares: the speeds the identified rounds ran
            at (shares of the alias guard's limit); set_aside_s: a first round recorded and set aside (s, where the
            logs carried a host's clock, :func:`pgcomm.rotary.experiment.slower_for_the_host_clock`).
    """

    model: RotaryModel
    seconds: float
    torque_sensor: bool = False
    k0: float | None = None
    cost_Nm2: float | None = None
    windows: int | None = None
    windows_used: int | None = None
    windows_refused_alias: int | None = None
    windows_refused_slow: int | None = None
    speed_limit_rad_s: float | None = None
    min_samples_per_period: float | None = None
    highest_order: int | None = None
    filter_taps: int | None = None
    unknowns: int | None = None
    ridge: float | None = None
    ridge_chosen_by: str | None = None
    validation_curve: dict | None = None
    orders_added: dict | None = None
    orders_screened: bool | None = None
    cost_A2: float | None = None
    inertia_ratio: float | None = None
    standard_error: dict | None = None
    quantisation: dict | None = None
    current_delay: dict | None = None
    angle_pll: dict | None = None
    current_filter: dict | None = None
    information_share: dict | None = None
    drive_orders: dict | None = None
    pinned: list | None = None
    time_lines: dict | None = None
    back_emf: dict | None = None
    current_noise_A: float | None = None
    current_noise_from: str | None = None
    current_noise_correction: dict | None = None
    host_clock: dict | None = None
    note: str | None = None
    orders_not_resolved: dict | None = None
    orders_over_the_angle: dict | None = None
    index_offsets: list | None = None
    rounds: int | None = None
    first_round_standard_error: dict | None = None
    log_budget_s: float | None = None
    speed_shares: list | None = None
    set_aside_s: float | None = None

    def to_dict(self) -> dict:
        """``results.json``'s ``identification``: the fields as JSON-ready data (a deep copy; the torque sensor's
        fields alone for an identification with one)."""
        if self.torque_sensor:
            keys = _TORQUE_KEYS
        else:
            keys = _RUNNING_KEYS + tuple(k for k in _OPTIONAL_KEYS if getattr(self, k) is not None)
        return copy.deepcopy({k: getattr(self, k) for k in keys})

    def reading(self) -> Reading:
        """How the logs were read (:class:`Reading`), to read more logs of the same drive the same way without
        searching again: ``identify(logs, motor, options.with_reading(result.reading()))``. The search tries tens of
        readings, each a fit of all the logs: most of an identification's time."""
        if self.torque_sensor:
            raise ValueError("an identification with a torque sensor reads no current's timing and no angle's PLL")
        timing, pll = self.current_delay, self.angle_pll
        w = pll["natural_frequency_rad_s"]
        return Reading(current_delay=int(timing["samples"]),
                       current_lag=None if timing["held"] else float(timing["lag"]),
                       angle_pll=None if w is None else (float(w), float(pll["damping"])),
                       time_lines=tuple(float(f) for f in self.time_lines["hz"]),
                       current_filter=float(self.current_filter["tau_s"]))


def _guard(options: RotaryIdentifyOptions) -> tuple[float, int]:
    """The alias guard's samples per period and the filter's taps of ``options`` (the regression's defaults)."""
    return (MIN_SAMPLES_PER_PERIOD if options.min_samples_per_period is None else options.min_samples_per_period,
            FILTER_TAPS if options.taps is None else options.taps)


def _as_logged(value, logged):
    """An option's value, or ``logged`` (the log as written) where it is left at ``"detect"``."""
    return logged if isinstance(value, str) else value


def _design(logs, motor: RotaryMotor, orders: Orders, min_samples: float, taps: int, encoder_step="detect",
            current_delay: int = 0, angle_pll=None, lines=(), current_lag=None, current_filter: float = 0.0):
    """All filtered rows of all logs at once (for the few columns of :func:`fit_mechanics`)."""
    prepared, counts, v_limit, ts = _prepare(logs, motor, orders, min_samples, taps, encoder_step)
    prepared = _with_report(prepared, current_filter)
    parts = list(_chunks(_with_delay(_with_pll(prepared, angle_pll, taps), current_delay, current_lag), orders, taps,
                         lines=lines))
    return {k: np.concatenate([c[k] for c in parts]) for k in parts[0]}, counts, v_limit, ts


def identify(logs, motor: RotaryMotor, options: RotaryIdentifyOptions | None = None) -> RotaryIdentification:
    """Identify cogging, torque-constant ripple, the direction-dependent torque and friction.

    Args:
        logs: sequence of dict-like logs with columns ``t`` (s), ``theta`` (rad, multi-turn),
            ``iq_1`` (or ``iq``, A), and ``torque`` (N·m) for a torque sensor; each ``(N_i,)``.
        motor: :class:`RotaryMotor` (pole pairs and slots set the orders; ``sample_time`` is used
            when a log has no ``t``).
        options: :class:`pgcomm.settings.RotaryIdentifyOptions` (default: every reading of the logs detected):
            the orders (default :meth:`Orders.for_motor`), a torque sensor, the alias guard
            (:mod:`pgcomm.rotary.regression`), the filter's taps, a fixed ridge, orders outside the basis
            (:mod:`pgcomm.rotary.regression`, "Orders the basis does not have"), the encoder's step for the
            quantisation correction (:mod:`pgcomm.rotary.quantisation`), the current's delay and form between samples
            (:mod:`pgcomm.rotary.readings`, "The current's timing"), a drive PLL's angle (:mod:`pgcomm.rotary.readings`,
            "The angle's estimate"), time-periodic disturbances (:mod:`pgcomm.rotary.time_lines`), the q-voltage's
            back-EMF (:mod:`pgcomm.rotary.back_emf`; results key ``back_emf``; the model is the currents' either way),
            the current's noise (:mod:`pgcomm.rotary.regression`, "The current's noise": from the logged d-current
            where every log has one, else from the q-current's own less what the logged angle predicts of it; the
            verdict counts what the correction may leave), a report filter (:mod:`pgcomm.rotary.readings`, "A filtered
            report") and maps to pin. A fit whose ripple is not a motor's (:func:`check_plausible`) is repeated with
            the ripple pinned, and says so.

    Returns:
        :class:`RotaryIdentification`; ``model.k_t`` is ``k0`` with a torque sensor, else the
        motor's ``k_t`` (or ``None``).

    Raises:
        DataError: missing/non-finite columns, non-uniform ``t``.
        ExcitationError: no usable window (all too fast for the alias guard or at standstill).
    """
    options = options or RotaryIdentifyOptions()
    # the reading search and the fits pass over the same logs tens of times: the angle's columns are built once
    with angle_parts_kept():
        return _identify(logs, motor, options)


def _lost_windows(counts: dict, logs, taps: int) -> str:
    """A clause on where the logs' filter windows went (``counts`` of :func:`pgcomm.rotary.regression._prepare`): too
    fast for the alias guard, near standstill or reversing (a rotor that stalls on its cogging, a position loop that
    steps), and the samples of logs too short for one window (``taps + 4`` samples: a log split at its gaps, a host
    loop that pauses, :data:`pgcomm.io.logs.GAP_STEPS`)."""
    parts = [f"of {counts['windows']} windows, {counts['alias']} too fast for the alias guard and {counts['slow']} "
             "near standstill or reversing (a rotor that stalls or steps: log at a steadier speed)"]
    sizes = [int(np.size(log["theta"])) for log in logs]
    short = [n for n in sizes if n < taps + 4]
    if short:
        parts.append(f"{len(short)} of {len(sizes)} logs or pieces between gaps ({sum(short)} of {sum(sizes)} samples) "
                     f"are shorter than one window ({taps + 4} samples) and give none")
    return "; " + "; ".join(parts)


def _identify(logs, motor: RotaryMotor, options: RotaryIdentifyOptions) -> RotaryIdentification:
    """:func:`identify` with its options given."""
    min_samples_per_period, taps = _guard(options)
    ridge, extra_orders, encoder_step = options.ridge, options.extra_orders, options.encoder_step
    current_delay, angle_pll, time_lines = options.current_delay, options.angle_pll, options.time_lines
    back_emf, current_lag, current_noise = options.back_emf, options.current_lag, options.current_noise
    current_filter, pin = options.current_filter, options.pin
    t0 = time.perf_counter()
    orders = orders_of(options, motor)
    if options.torque_sensor:
        return check_plausible(_identify_torque(logs, motor, orders, t0))
    cut, basis = None, orders
    if options.orders is None:
        # logs that turn too fast for the basis's highest order (a joint's own speed loop, a slow host): the basis cut
        # to the orders they resolve, rather than most of their windows refused
        orders, cut = resolved_orders(logs, motor, orders, min_samples_per_period)
    # logs of several power-ups: the offsets their binned maps suggest, tested once the logs are read
    offsets = index_offsets(logs, orders.highest)
    prepared, counts, v_limit, ts = _prepare(logs, motor, orders, min_samples_per_period, taps, encoder_step)
    n_windows = sum(p.starts.size for p in prepared)
    # a map the logs do not determine is pinned (the ripple at zero, a one-direction log's direction map folded into
    # the cogging) before anything is read off the basis fit: its columns would take the cogging's part
    all_orders = orders

    def pinning(prepared):
        shares = information_shares(prepared, all_orders, taps)
        pinned = {name: share for name, share in shares.items() if share < DETERMINED_SHARE or name in pin}
        return shares, pinned, replace(all_orders, **{name: np.zeros(0, int) for name in pinned})

    shares, pinned, orders = pinning(prepared)
    # a host's clock makes the angle's noise grow with the speed: the rows weighted for it before the logs are read, so
    # that the reading's search, the fit, its validation and its standard errors all see the same weighted rows
    prepared, host = weigh(prepared, orders, taps)
    estimate, timing, report = read_logs(prepared, orders, taps, encoder_step, current_delay, angle_pll, current_lag,
                                         current_filter)

    def angle(estimate):
        return None if estimate["natural_frequency_rad_s"] is None else (estimate["natural_frequency_rad_s"],
                                                                         estimate["damping"])

    if offsets:
        # each recording's offset tested by the fit under the reading found (pgcomm.rotary.power_ups); where one is
        # taken the logs are read again in one frame
        layout0 = _Layout.of(orders)

        def read_cost(prep):
            # under the reading found last (the names are read when called)
            read = _with_delay(_with_pll(_with_report(prep, report["tau_s"]), angle(estimate), taps),
                               timing["samples"], lag_of(timing))
            return _basis_cost(read, layout0, taps)

        prepared, offsets = tested(prepared, logs, offsets, read_cost, orders.highest, taps)
        if any(o["taken"] for o in offsets):
            # two recordings misaligned hold two currents at an angle: what the logs determine, and the rows' weights
            # for a host's clock (from the basis fit's residuals), are decided again in one frame
            prepared = [replace(p, weight=None, timing_noise=None) for p in prepared]
            shares, pinned, orders = pinning(prepared)
            prepared, host = weigh(prepared, orders, taps)
            layout0 = _Layout.of(orders)
        # read in one frame, then each offset taken tested once more under that reading (read across two frames,
        # the filter and the current's timing took part of the misalignment: 179.3° for a 180° move on the ODrive's)
        for _ in range(2):
            if not any(o["taken"] for o in offsets):
                break
            estimate, timing, report = read_logs(prepared, orders, taps, encoder_step, current_delay, angle_pll,
                                                 current_lag, current_filter)
            kept = [o for o in offsets if o["taken"]]
            prepared, again = tested(prepared, logs, [{**o, "binned_rad": 0.0} for o in kept], read_cost,
                                     orders.highest, taps)
            for o, a in zip(kept, again):
                o["rad"] += a["rad"]
            if not any(a["taken"] for a in again):
                break
    prepared = _with_report(prepared, report["tau_s"])
    pll = angle(estimate)
    as_logged = _with_delay(prepared, timing["samples"], lag_of(timing))
    prepared = _with_delay(_with_pll(prepared, pll, taps), timing["samples"], lag_of(timing))
    if isinstance(time_lines, str):
        lines_info = _time_lines(prepared, orders, taps)
    else:
        lines_info = {"hz": [float(f) for f in time_lines or ()], "searched": False}
    lines = tuple(lines_info["hz"])
    added = {"cogging": np.zeros(0, int), "ripple": np.zeros(0, int)}
    screen = None
    if extra_orders:
        full = Orders(_full(orders.cogging), _full(orders.ripple) if orders.ripple.size else orders.ripple,
                      orders.direction)
        n_extra = full.cogging.size + full.ripple.size - orders.cogging.size - orders.ripple.size
        lay_full = _Layout.of(full, lines, len(prepared))
        if n_extra and n_windows >= 2 * int(lay_full.keep.sum()):
            # not corrected for the current's noise: over every order to the basis's highest its probes would cost
            # about as much again as the fit, and the screening only decides which orders enter the corrected fit
            screen = _significant_extra_orders(_fit(prepared, lay_full, taps, ridge), lay_full, orders,
                                               EXTRA_ORDER_ALPHA)
            added = {k: screen[k] for k in ("cogging", "ripple")}
    final = Orders(np.union1d(orders.cogging, added["cogging"]), np.union1d(orders.ripple, added["ripple"]),
                   orders.direction)
    layout = _Layout.of(final, lines, len(prepared))
    n_unknowns = int(layout.keep.sum())
    if n_windows < 2 * n_unknowns:
        raise ExcitationError(f"{n_windows} usable windows for {n_unknowns} unknowns: record longer running logs "
                              f"(speeds up to {v_limit:.3g} rad/s, both directions)" + _lost_windows(counts, logs, taps))
    noise_info = _noise_info(logs, ts, report["tau_s"])
    correction = _current_noise_setting(current_noise, noise_info)
    fit = _fit(prepared, layout, taps, ridge, current_noise=correction["noise_A"],
               current_noise_uncertainty=correction["uncertainty"])
    unresolved = None if host is None or host.get("bias_corrected") else unresolved_timing_noise(prepared, taps)
    if unresolved is not None:
        # a clock's noise the angle reads but does not resolve (one speed): the fit with it taken out, and what that
        # fit's own correction may leave, is as likely as the fit without it
        alt = _fit([replace(p, timing_noise=n) for p, n in zip(prepared, unresolved)], layout, taps, fit["ridge"],
                   current_noise=correction["noise_A"])
        move = alt["beta"] + alt["quantisation_shift"] - fit["beta"]
        host = {**host, "unresolved_in_verdict": bool(abs(move[0]) > abs(fit["quantisation_shift"][0]))}
        if host["unresolved_in_verdict"]:
            fit["quantisation_shift"] = move
    beta = np.zeros(layout.keep.size)
    beta[layout.keep] = fit["beta"]
    cov = np.zeros((layout.keep.size, layout.keep.size))
    cov[np.ix_(layout.keep, layout.keep)] = fit["cov"]
    bias = np.zeros(layout.keep.size)
    bias[layout.keep] = fit["bias"]
    shift = np.zeros(layout.keep.size)
    shift[layout.keep] = fit["quantisation_shift"]
    c_shift = np.zeros(layout.keep.size)
    c_shift[layout.keep] = fit["current_shift"]
    reading = np.zeros(layout.keep.size)
    if pll is not None:
        # what a PLL's reading may leave: a share of the maps' move from the angle as logged (pgcomm.rotary.readings)
        reading[layout.keep] = PLL_UNCERTAINTY * (_fit(as_logged, layout, taps, fit["ridge"],
                                                       current_noise=correction["noise_A"])["beta"] - fit["beta"])
    o_r, o_c, o_d = layout.o_r, layout.o_c, layout.o_d
    # read before the cut orders read over the angle are appended to the vector
    viscous, reading_kept = float(beta[-1]), reading[layout.keep]
    over = None
    if cut is not None and not any(o["taken"] for o in offsets):
        beta, cov, bias, shift, c_shift, reading, o_c, final, over = _cut_orders_over_the_angle(
            logs, basis, final, o_c, beta, cov, [bias, shift, c_shift, reading], ts, report["tau_s"], timing, pll)
        lost = cut.get("fundamental_over_the_angle")
        if lost is not None and (over is None or lost not in over["kept"]):
            need = cut["speed_to_resolve_fundamental_rad_s"]
            raise ExcitationError(
                f"the logs turn too fast for their sampling to resolve the cogging's fundamental (order {lost} per "
                f"revolution) in time (nine in ten filter windows at speed turn at up to {cut['speed_rad_s']:.4g} "
                "rad/s), and read over the angle it is not determined either ("
                + ("no steady stretch" if over is None else
                   "it is within its noise there" if over["agreement"] <= MAX_DISAGREEMENT else
                   f"that reading is {100 * over['agreement']:.0f} % of the map away from the time-domain fit where "
                   "both read") + f"); log at most {need:.3g} rad/s or poll the drive faster"
                + _unit_hint(cut["speed_rad_s"], need))
    if lines:
        # per log a cosine and a sine of each line (A): the amplitude of each line in each log
        cs = beta[layout.o_t].reshape(len(prepared), 2, len(lines))
        lines_info["amplitude_A"] = [float(a) for a in np.median(np.hypot(cs[:, 0], cs[:, 1]), axis=0)]
    model = RotaryModel(
        motor.pole_pairs,
        cogging=Fourier.from_vector(final.cogging, beta[o_c]),
        ripple=Fourier.from_vector(final.ripple, beta[o_r]),
        direction=Fourier.from_vector(final.direction, beta[o_d]),
        viscous=viscous, inertia_ratio=float(beta[0]), k_t=motor.k_t,
        info={"method": "running logs, no torque sensor"})
    drive = _drive_share(model.cogging, motor.pole_pairs)
    blind = None
    if screen is not None:
        blind = {k: float(np.median(v)) for k, v in screen["blind_rms"].items() if np.size(v)}
    standard_error = _standard_errors(model, cov, bias, o_r, o_c, o_d, final, fit["blocks"], blind, shift, reading,
                                      c_shift)
    for name, share in pinned.items():
        standard_error[name] = _pinned_entry(name, share)
    lost = (cut or {}).get("fundamental_over_the_angle")
    if lost is not None:
        # the time-domain fit leaves the largest torque out: its J/k0, readings and standard errors do not bound what
        # the fundamental read over the angle may be off by (a joint's 24N22P at 3 rad/s: J/k0 at a seventh, the
        # table correlating 0.54 with a standard error of 4.8 %); longer logs of the same kind do not change that
        standard_error["cogging"] = {**standard_error["cogging"], "resolved": False,
                                     "log_time_factor_to_resolve": float("inf"), "fundamental_over_the_angle": lost,
                                     "speed_to_resolve_fundamental_rad_s": cut["speed_to_resolve_fundamental_rad_s"]}
    voltage_info = None
    if back_emf and has_voltage(logs):
        # the parts of the currents' error that its covariance does not hold, as the verdict counts them
        fixed = [fit["bias"], fit["quantisation_shift"], reading_kept, fit["current_shift"]]
        voltage_info = _voltage_check(fit, fixed, (blind or {}).get("ripple"), logs, motor, final, layout, ts,
                                      timing["samples"], pll)
    result = RotaryIdentification(
        model, windows=counts["windows"], windows_used=int(n_windows), windows_refused_alias=counts["alias"],
        windows_refused_slow=counts["slow"], speed_limit_rad_s=v_limit,
        min_samples_per_period=float(min_samples_per_period), highest_order=orders.highest, filter_taps=int(taps),
        unknowns=n_unknowns, ridge=fit["ridge"],
        ridge_chosen_by="validation on held-out time blocks" if ridge is None else "given",
        validation_curve={f"{l:.0e}": c for l, c in zip(RIDGE_GRID, fit["curve"])},
        orders_added={k: v.tolist() for k, v in added.items()}, orders_screened=screen is not None,
        cost_A2=fit["cost"], inertia_ratio=float(beta[0]), standard_error=standard_error,
        quantisation=_quantisation_info(prepared, fit), current_delay=timing, angle_pll=estimate,
        current_filter=report, information_share=shares, drive_orders=drive, pinned=sorted(pinned),
        time_lines=lines_info, back_emf=voltage_info, current_noise_A=noise_info["current_noise_A"],
        current_noise_from=noise_info["current_noise_from"],
        current_noise_correction={**correction, **fit["current_noise"]}, host_clock=host,
        note=(f"{counts['alias']} of {counts['windows']} windows refused: faster than {v_limit:.3g} rad/s, where order "
              f"{orders.highest} has fewer than {min_samples_per_period:g} samples per period")
        if counts["alias"] else None,
        index_offsets=[o for o in offsets if o["taken"]] or None, orders_not_resolved=cut,
        orders_over_the_angle=over, seconds=time.perf_counter() - t0)
    try:
        return check_plausible(result)
    except ExcitationError as e:
        if "ripple" in pinned:
            raise
        # the logs carry some information on the ripple, but not enough for a motor's: the cogging is what they
        # determine, the ripple is pinned as where they carry none
        again = identify(logs, motor, replace(options, pin=(*pin, "ripple")))
        ripple = {**again.standard_error["ripple"], "implausible_fit": str(e)}
        return replace(again, standard_error={**again.standard_error, "ripple": ripple})


#: Where the cogging read over the angle differs from the time-domain fit's, at the orders both read, by more than this
#: share of that map's RMS, the two are not readings of one map (their correlation may be as low as 0.87) and the cut
#: orders stay out.
MAX_DISAGREEMENT = 0.5


def _cut_orders_over_the_angle(logs, basis: Orders, final: Orders, o_c, beta, cov, zeros, ts: float, tau: float,
                               timing: dict, pll):
    """The cogging's orders the basis was cut of (:func:`pgcomm.rotary.regression.resolved_orders`) read over the angle
    (:mod:`pgcomm.rotary.over_the_angle`) and appended to the fit's vector: ``(beta, cov, *zeros, o_c, final, info)``
    extended; ``zeros`` are the vectors of the error the covariance does not hold (the ridge's bias, the quantisation
    shift, the current noise's shift, the PLL reading's), extended by the shrinkage's pull in the first and zeros in
    the others. ``J/k0``'s variance for the inertia torque adds the square of its quantisation shift.

    **Checked where both read.** At the cogging's orders the time-domain fit resolves, the reading over the angle
    is compared with it: where the two differ by more than their standard errors say, the cut orders' covariance is
    scaled by that excess ``κ = max(1, Σ|ΔX|² / Σ tr(Cov_t + Cov_a))``, so that logs on which the model over the angle
    does not hold give the cut orders a standard error as large as that disagreement.

    **Shrunk to what the logs show.** Each cut order's coefficient ``X`` is multiplied by ``f = max(0, 1 − tr(κ
    Cov)/|X|²)`` (the posterior mean under a zero-mean prior of the variance the estimate itself shows): an order
    within its noise (the highest multiples, whose ``h²`` amplifies the clock's noise) adds nothing, and is left out
    of the verdict as the alias guard's cut left it. A kept order's covariance is ``f κ Cov``, and ``(f − 1) X`` its
    pull towards zero, counted like the ridge's (:func:`_standard_errors`).

    ``info``: ``None`` where no cogging order was cut or no log holds a steady segment, else ``{"orders"`` (added),
    ``"kept"`` (of those, the ones not shrunk to zero), ``"agreement"`` (:func:`pgcomm.rotary.over_the_angle.agreement`
    at the resolved orders), ``"inflation"`` (``κ``), ``"segments", "seconds", "speeds_rad_s"}``."""
    cut_cog = np.setdiff1d(basis.cogging[basis.cogging > 0], final.cogging)
    if not cut_cog.size:
        return (beta, cov, *zeros, o_c, final, None)
    every = np.union1d(np.union1d(basis.cogging, basis.ripple), np.union1d(basis.direction, final.cogging))
    every = every[every > 0]
    # J/k0's noise and what the encoder's and the clock's corrections may leave of it (the verdict's quantisation
    # bias): at one speed it is the inertia torque of the speed's ripple that the current does not carry
    var_j = float(cov[0, 0]) + float(zeros[1][0]) ** 2
    shifted = [{**log, "iq_1": _shifted(np.asarray(log["iq_1"] if "iq_1" in log else log["iq"], float),
                                        int(timing["samples"]))} for log in logs]
    angle = read_over_the_angle(shifted, every, ts, float(beta[0]), var_j, tau=tau, lag=lag_of(timing), pll=pll)
    if angle is None:
        return (beta, cov, *zeros, o_c, final, None)
    n = final.cogging.size
    flip = np.diag([-1.0, 1.0])  # (a, b) of the model's cogging −c  <->  (Re X, Im X) of the table's X = −a + i b
    both = [j for j, h in enumerate(final.cogging) if h > 0]
    x_t = np.array([-beta[o_c[j]] + 1j * beta[o_c[n + j]] for j in both])
    at = final.cogging[both]
    idx = np.searchsorted(angle["orders"], at)
    diff = np.abs(x_t - angle["table"][idx]) ** 2
    spread = sum(np.trace(flip @ cov[np.ix_([o_c[j], o_c[n + j]], [o_c[j], o_c[n + j]])] @ flip) for j in both)
    spread += sum(np.trace(angle["cov"][i]) for i in idx)
    kappa = float(max(1.0, diff.sum() / spread)) if spread > 0 else 1.0
    gap = angle_agreement(x_t, angle, at)
    info = {"orders": [int(h) for h in cut_cog], "kept": [], "agreement": gap, "inflation": kappa,
            "segments": int(angle["segments"]), "seconds": float(angle["seconds"]),
            "speeds_rad_s": [float(w) for w in angle["speeds_rad_s"]]}
    if gap > MAX_DISAGREEMENT:
        # the two readings are not of one map: the model over the angle does not hold on these logs
        return (beta, cov, *zeros, o_c, final, info)
    k = beta.size
    m = cut_cog.size
    add_beta, add_cov, pull = np.zeros(2 * m), np.zeros((2 * m, 2 * m)), np.zeros(2 * m)
    kept = info["kept"]
    for j, h in enumerate(cut_cog):
        i = int(np.searchsorted(angle["orders"], h))
        x, c = angle["table"][i], kappa * angle["cov"][i]
        f = max(0.0, 1.0 - float(np.trace(c)) / abs(x) ** 2) if abs(x) > 0 else 0.0
        if f > 0:
            kept.append(int(h))
        ab = flip @ np.array([x.real, x.imag])
        add_beta[[j, m + j]] = f * ab
        # an order within its noise is left out, as the alias guard's cut left it: its noise (h² amplifies the
        # clock's at the highest multiples) is no part of the map's error
        pull[[j, m + j]] = (f - 1.0) * ab if f > 0 else 0.0
        add_cov[np.ix_([j, m + j], [j, m + j])] = f * (flip @ c @ flip)
    beta = np.concatenate([beta, add_beta])
    big = np.zeros((k + 2 * m, k + 2 * m))
    big[:k, :k], big[k:, k:] = cov, add_cov
    extended = [np.concatenate([zeros[0], pull])] + [np.concatenate([z, np.zeros(2 * m)]) for z in zeros[1:]]
    orders = np.concatenate([final.cogging, cut_cog])
    perm = np.argsort(orders, kind="stable")
    a_idx = np.concatenate([o_c[:n], k + np.arange(m)])[perm]
    b_idx = np.concatenate([o_c[n:], k + m + np.arange(m)])[perm]
    return (beta, big, *extended, np.concatenate([a_idx, b_idx]), replace(final, cogging=orders[perm]), info)


def _voltage_check(fit: dict, fixed, blind, logs, motor: RotaryMotor, final: Orders, layout: _Layout, ts: float,
                   delay: int, pll) -> dict:
    """The ripple, the back-EMF constant and the resistance that the logged q-voltage measures
    (:func:`pgcomm.rotary.back_emf.fit_voltage`), and whether its ripple agrees with the currents' fit
    (:func:`pgcomm.rotary.back_emf.agreement`): what the results say about it. The model stays the currents' (the
    module docstring of :mod:`pgcomm.rotary.back_emf` says why). ``fixed``: vectors over the kept columns of the
    currents' error that its covariance does not hold (the ridge's bias, the encoder correction's and a PLL reading's
    uncertain share), added to it as ``b bᵀ``; ``blind``: the RMS of an order outside the basis the logs could hide
    (relative, or ``None``)."""
    read = [apply_reading(log, 0, pll, ts) for log in logs]
    fv = fit_voltage(read, final.ripple, motor.pole_pairs, ts, delay, motor.commutation_offset)
    if fv["ripple"] is None:
        return {"used_logs": len(logs), "back_emf_constant": fv["back_emf_constant"],
                "back_emf_constant_se": fv["back_emf_constant_se"], "rows": fv["rows"], "consistent": None,
                "rows_at_voltage_limit": fv["rows_at_voltage_limit"], "offset_error": None}
    kept = np.flatnonzero(layout.keep)
    where = {int(c): j for j, c in enumerate(kept)}
    nr = final.ripple.size
    pos = [j for j, h in enumerate(final.ripple) if h > 0]
    idx = np.array([where[int(layout.o_r[j])] for j in pos] + [where[int(layout.o_r[nr + j])] for j in pos], int)
    # the ridge's pull, what the encoder correction and a PLL's reading may leave: each as a direction of error of its
    # own size (b bᵀ), beside the noise; and an order outside the basis the logs could hide (blind, RMS)
    cov_c = fit["cov"][np.ix_(idx, idx)] + sum(np.outer(b[idx], b[idx]) for b in fixed)
    gram = _map_gram(fv["orders"])
    check = agreement(fit["beta"][idx], cov_c, fv["ripple"], fv["cov"], gram, extra_ms=(blind or 0.0) ** 2)
    rms = float(np.sqrt(max(float(fv["ripple"] @ gram @ fv["ripple"]), 0.0)))
    return {"used_logs": len(logs), "back_emf_constant": fv["back_emf_constant"],
            "back_emf_constant_se": fv["back_emf_constant_se"],
            "k0_amplitude_invariant": 1.0 / BACK_EMF_FACTOR * fv["back_emf_constant"],
            "resistance": fv["resistance"], "inductance": fv["inductance"], "voltage_delay": fv["voltage_delay"],
            "residual_rms_V": fv["residual_rms_V"], "rows": fv["rows"], "blocks": fv["blocks"],
            "rows_at_voltage_limit": fv["rows_at_voltage_limit"],
            "ripple": Fourier.from_vector(fv["orders"], fv["ripple"]).to_dict(), "ripple_rms": rms,
            "ripple_rms_error": _map_standard_error(fv["cov"], gram), **check, "offset_error": fv["offset_error"]}


def _noise_info(logs, ts: float, report_filter: float = 0.0) -> dict:
    """The logged current's white noise (A), what a twin of this motor logs (``pgcomm reproduce --truth model.json``):
    from the logged d-current where every log has one (held at zero, it is the noise alone: the median absolute
    deviation), else from the q-current's sixth difference less the current the speed loop commands from the encoder's
    noise, which the logged angle predicts (:func:`pgcomm.rotary.readings.current_noise_beside_angle`: with a coarse
    encoder the difference alone would read that commanded current as noise, several times the real one). Through a
    report filter of ``report_filter`` (s) the currents are read back first (:func:`pgcomm.rotary.readings.unfiltered`):
    the noise the fit sees is the read-back current's, not the smoothed report's."""
    def back(x, log):
        return unfiltered(x, np.asarray(log["t"], float) if "t" in log else ts, report_filter)

    if logs and all("id_1" in log for log in logs):
        d = [back(np.asarray(log["id_1"], float), log) for log in logs]
        noise = float(np.median([np.median(np.abs(x - np.median(x))) / 0.6745 for x in d if x.size]))
        # a drive that writes its d-current command (zeros) rather than the measurement shows no noise there
        if noise > 0:
            return {"current_noise_A": noise, "current_noise_from": "the logged d-current (held at zero)"}
    arrays = [_log_arrays(log, i, ts) for i, log in enumerate(logs)]
    noise = float(np.median([current_noise_beside_angle(back(a[2], log), a[1]) for a, log in zip(arrays, logs)]))
    return {"current_noise_A": noise, "current_noise_from": "the q-current's sixth difference less what the logged "
            "angle predicts of it (the current the loop commands from the encoder's noise)"}


#: The share of the current-noise correction taken as uncertain in the verdict when the noise is read from the logged
#: d-current (or given): the d- and q-current's noises are the same phase sensors' through the drive's transform, equal
#: on average over the electrical angle, but a drive with two phase sensors makes them differ with the angle.
CURRENT_NOISE_UNCERTAINTY = 0.25


def _current_noise_setting(current_noise, noise_info: dict) -> dict:
    """The current's noise the fit corrects for (``noise_A``, A) and the share of that correction the verdict counts
    as uncertain (``uncertainty``), from :func:`identify`'s ``current_noise`` and :func:`_noise_info`: the logged
    d-current's noise as it is, a quarter of the correction uncertain (:data:`CURRENT_NOISE_UNCERTAINTY`); the
    q-current's own, less what the angle predicts (:func:`_noise_info`), half of it uncertain (it read up to 1.11 times
    the twin's noise, 1.23 times its variance)."""
    if current_noise is None:
        return {"noise_A": 0.0, "uncertainty": 0.0, "from": "off"}
    if not isinstance(current_noise, str):
        return {"noise_A": float(current_noise), "uncertainty": CURRENT_NOISE_UNCERTAINTY, "from": "given"}
    sigma = float(noise_info["current_noise_A"])
    if noise_info["current_noise_from"].startswith("the logged d-current"):
        return {"noise_A": sigma, "uncertainty": CURRENT_NOISE_UNCERTAINTY, "from": "the logged d-current"}
    return {"noise_A": sigma, "uncertainty": 2 * CURRENT_NOISE_UNCERTAINTY,
            "from": "the q-current's own, less what the logged angle predicts"}


def _quantisation_info(prepared, fit: dict) -> dict:
    """What the results say about the encoder's quantisation correction."""
    steps = [p.step for p in prepared if p.step is not None]
    return {"encoder_step_rad": float(np.median(steps)) if steps else None,
            "counts_per_revolution": sorted({round(2 * math.pi / q) for q in steps}),
            "logs_on_lattice": sum(p.step is not None for p in prepared), "logs": len(prepared),
            "noise_share": fit["noise_share"], "correction_capped": fit["noise_factor"] < 1.0,
            "inertia_ratio_shift": float(fit["quantisation_shift"][0])}


def check_plausible(result: RotaryIdentification) -> RotaryIdentification:
    """Refuse a model that is not a motor: a torque constant that falls below :data:`pgcomm.rotary.law.MIN_GAIN`
    of its mean somewhere on the revolution (``|r(θ)| > 1 − MIN_GAIN``; a real ripple is a few per cent). Such a
    fit comes from logs that do not determine the maps (e.g. a dither that reverses the speed, so that the few
    windows left carry nearly the same current at every angle), and its law would fight the feedback where the
    law clamps the gain.

    Returns:
        ``result`` unchanged.

    Raises:
        ExcitationError: the ripple's peak, where, and how many windows the fit had.
    """
    th = 2 * math.pi * np.arange(4096) / 4096
    r = result.model.ripple(th)
    j = int(np.argmax(np.abs(r)))
    if not np.isfinite(r[j]) or abs(r[j]) > 1.0 - MIN_GAIN:
        used = result.windows_used
        raise ExcitationError(
            f"the identified torque constant varies by {100 * r[j]:+.0f} % of its mean at {th[j]:.3f} rad (a motor's "
            f"ripple is a few per cent; the law refuses below {100 * MIN_GAIN:.0f} %): the logs do not determine the "
            "model" + (f" ({used} of {result.windows} filter windows used)" if used is not None else "")
            + "; log at steady speeds in both directions with a q-current dither that keeps the speed's sign")
    return result


#: Relative standard error (of a map's RMS) at which :func:`identify` calls a map resolved.
RESOLVED_SHARE = 0.05
#: ... with this probability: a map is called resolved when the noise part of its error stays within
#: :data:`RESOLVED_SHARE` with this probability (its expected size within the target would be missed half the time).
RESOLVED_CONFIDENCE = 0.9


def _standard_errors(model: RotaryModel, cov, bias, o_r, o_c, o_d, orders: Orders, blocks: int,
                     blind: dict | None = None, shift=None, reading=None, current=None) -> dict:
    """How well the logs determine each map: expected RMS error over the revolution, relative to the
    map's identified RMS, and the running-log time that would bring it to :data:`RESOLVED_SHARE`.

    ``relative`` is the noise part (its expected RMS), ``relative_at_confidence`` the size it stays below with
    probability :data:`RESOLVED_CONFIDENCE` (:func:`_map_error_quantile`); both fall as the square root of the
    log time at the same excitation, which gives the time needed. ``ridge_bias`` is the RMS over the revolution
    of the ridge's pull towards zero (``(A⁻¹N − I) β̂``), relative too: small when the data set the map, large
    when logs that do not excite it leave the map to the ridge (then longer logs of the same kind do not help,
    and the noise part alone would call a map resolved that the data never determined).

    ``outside_order_limit`` (``blind``: per map, the RMS in the map's units, from the screening) is the RMS over
    the revolution of the largest order outside the slot/pole basis that the screening would not have added (the
    median over the candidate orders, :func:`_significant_extra_orders`), relative too: the part of a real map
    the logs could still hide. It falls with the noise, as the square root of the log time. A map is resolved
    when ``sqrt(relative_at_confidence² + outside_order_limit² + ridge_bias² + quantisation_bias²)`` is within
    :data:`RESOLVED_SHARE`: without the limit, an order outside the basis of a few per cent of the map's RMS, below
    what the logs could see, would leave a map called resolved beyond 5 %.

    ``quantisation_bias`` (``shift``: the fit's shift were the encoder-noise correction
    :data:`QUANTISATION_UNCERTAINTY` smaller, or, where the correction was capped, as large as the noise model asks,
    :func:`_fit`) is the RMS of that shift over the revolution, relative: what the correction may leave. It does not
    fall with longer logs of the same kind. Capped, the logs hardly hold the rotor's acceleration above the encoder's
    and the clock's noise: at one speed the acceleration is a function of the angle, and ``J/k0`` trades with every
    map along it (a speed loop's inertia torque of the cogging's speed ripple, as large as the cogging on a joint).
    A clock's noise the angle reads but does not resolve from the encoder's floor (one speed,
    :func:`pgcomm.rotary.host_clock.unresolved_timing_noise`) is not taken out; the fit with it taken out (and what
    that fit's own correction may leave) takes the shift's place where it moves ``J/k0`` more.

    ``pll_bias`` (``reading``: :data:`PLL_UNCERTAINTY` times the fit's move from the angle as logged to the angle read
    through a drive's PLL, :func:`_angle_pll`; zero when the angle is the encoder's) is the RMS of that over the
    revolution, relative: what the PLL's reading may leave. It counts like the quantisation bias.

    ``current_noise_bias`` (``current``: the fit's shift were the current-noise correction its uncertain share
    smaller, :func:`_current_noise_setting`) is the RMS of that shift over the revolution, relative. It counts like the
    quantisation bias.
    """
    out = {"blocks": int(blocks), "resolved_share": RESOLVED_SHARE, "confidence": RESOLVED_CONFIDENCE}
    th = 2 * math.pi * np.arange(4096) / 4096
    for name, cols, fn, map_orders in (("cogging", o_c, model.cogging, orders.cogging),
                                       ("ripple", o_r, model.ripple, orders.ripple),
                                       ("direction", o_d, model.direction, orders.direction)):
        gram, c = _map_gram(map_orders), cov[np.ix_(cols, cols)]
        se = _map_standard_error(c, gram)
        se_q = _map_error_quantile(c, gram, RESOLVED_CONFIDENCE)
        b = bias[cols]
        b_rms = float(np.sqrt(max(float(b @ gram @ b), 0.0)))
        rms = float(np.sqrt(np.mean(fn(th) ** 2)))
        rel = se / rms if rms > 0 else float("inf")
        b_rel = b_rms / rms if rms > 0 else float("inf")
        rel_q = se_q / rms if rms > 0 else float("inf")
        sh = np.zeros(len(cols)) if shift is None else shift[cols]
        q_rel = float(np.sqrt(max(float(sh @ gram @ sh), 0.0))) / rms if rms > 0 else float("inf")
        rd = np.zeros(len(cols)) if reading is None else reading[cols]
        p_rel = float(np.sqrt(max(float(rd @ gram @ rd), 0.0))) / rms if rms > 0 else float("inf")
        cs = np.zeros(len(cols)) if current is None else current[cols]
        c_rel = float(np.sqrt(max(float(cs @ gram @ cs), 0.0))) / rms if rms > 0 else float("inf")
        lim = (blind or {}).get(name)
        lim_rel = (float(lim) / rms if rms > 0 else float("inf")) if lim is not None else None
        noise = math.hypot(rel_q, lim_rel or 0.0)
        fixed = math.hypot(b_rel, q_rel, p_rel, c_rel)
        out[name] = {"rms_error": se, "rms": rms, "relative": rel, "relative_at_confidence": rel_q,
                     "outside_order_limit": lim_rel, "ridge_bias": b_rel, "quantisation_bias": q_rel,
                     "pll_bias": p_rel, "current_noise_bias": c_rel,
                     "resolved": bool(math.hypot(noise, fixed) <= RESOLVED_SHARE),
                     "log_time_factor_to_resolve": _time_factor(noise, fixed)}
    # the ripple is seen only through q-current that varies at a given angle: its need falls with the square of that
    # variation, which constant-speed logs hardly carry (a short stretch of accelerations resolves more of it than a
    # long one of constant speeds)
    out["ripple"]["excitation_hint"] = ("more q-current variation at each angle (a dither that keeps the speed's sign, "
                                        "or accelerations) resolves it sooner than longer logs of the same kind")
    return out


def _time_factor(noise: float, fixed: float) -> float:
    """How many times the log so far brings the noise part (falling as the square root of the log time) within
    what :data:`RESOLVED_SHARE` leaves beside the parts longer logs do not change (``fixed``); ``inf`` if none."""
    room = RESOLVED_SHARE**2 - fixed**2
    if room <= 0.0:
        return float("inf")
    return float(max(1.0, noise**2 / room))


def _drive_share(cogging: Fourier, pole_pairs: int) -> dict:
    """How much of the identified cogging sits at the drive's own orders (:func:`pgcomm.rotary.model.drive_orders`):
    ``{"share": RMS at those orders / RMS of the map (order 0 left out), "amplitude_A": {order: amplitude}}``, the
    largest first."""
    amp = np.hypot(cogging.coef[:, 0], cogging.coef[:, 1])
    moving = cogging.orders > 0
    at = np.isin(cogging.orders, drive_orders(pole_pairs)) & moving
    total = float(np.sum(amp[moving] ** 2))
    top = np.argsort(-amp * at)[:int(at.sum())]
    return {"share": float(np.sqrt(np.sum(amp[at] ** 2) / total)) if total > 0 else 0.0,
            "amplitude_A": {str(int(cogging.orders[j])): float(amp[j]) for j in top}}


def drive_text(found: dict | None, pole_pairs: int) -> str | None:
    """One line on :func:`_drive_share`'s result, or ``None`` where it holds little (under a tenth of the RMS)."""
    if not found or found["share"] < 0.1:
        return None
    top = ", ".join(f"{o}: {a:.3g} A" for o, a in list(found["amplitude_A"].items())[:4])
    return (f"the drive's own orders (p = {pole_pairs}: p, 2p, 3p, 4p, 6p) hold "
            f"{100 * found['share']:.0f} % of the cogging table's RMS ({top}): where a drive's current measurement "
            "and inverter add torque (a motor's pole tolerances add some at 2p and its multiples too); the table "
            "compensates both on this drive")


#: The experiment that determines a map the logs leave undetermined (:func:`_pinned_entry`).
_DETERMINING_EXPERIMENT = {
    "ripple": "running logs with more than one q-current at each angle: a dither that keeps the speed's sign, or "
              "accelerations, or two speeds",
    "direction": "running logs in both directions",
}


def _pinned_entry(name: str, share: float) -> dict:
    """A map's ``standard_error`` entry where the logs do not determine it
    (:func:`pgcomm.rotary.regression.information_shares`): pinned (the ripple at zero; the direction map folded into
    the cogging, which then holds the logs' direction's sum of both), with the experiment that would determine it."""
    how = "pinned at zero" if name == "ripple" else "folded into the cogging (the logs' one direction)"
    return {"resolved": False, "determined": False, "pinned": how, "information_share": float(share),
            "experiment": _DETERMINING_EXPERIMENT[name], "rms_error": None, "rms": 0.0, "relative": None,
            "relative_at_confidence": None, "log_time_factor_to_resolve": None}


def resolution_verdict(entry: dict, log_seconds: float | None = None) -> str:
    """One phrase for a map's entry of ``standard_error`` (:func:`_standard_errors`): ``"resolved"``, or
    why not and what would help (and the entry's ``excitation_hint``, the ripple's: more q-current variation):
    longer logs of the same kind when the noise part is too large (with
    ``log_seconds``, the seconds of running log so far, also the total it would take; with the noise part at
    :data:`RESOLVED_CONFIDENCE` and the outside-order limit it weighs, when the entry has them), a different
    excitation when the ridge sets the map or the encoder's rounding could move it by more than the share, the
    encoder's count when a PLL's reading could, the d-current when the correction for the current's noise could (then
    longer logs of the same kind do not help)."""
    if entry["resolved"]:
        return "resolved"
    if entry.get("fundamental_over_the_angle"):
        return (f"not resolved: its fundamental (order {entry['fundamental_over_the_angle']}) is read over the angle "
                "only, with J/k0 from a time-domain fit that cannot hold it; there the inertia torque of the speed's "
                "ripple can outweigh the current, and at one speed J/k0 trades with the maps: log at most "
                f"{entry['speed_to_resolve_fundamental_rad_s']:.3g} rad/s, or poll the drive faster")
    if entry.get("determined") is False:
        why = ("its fit was not a motor's" if entry.get("implausible_fit") else
               f"{100 * entry['information_share']:.2g} % of its information beyond the angle's")
        return (f"not determined by these logs ({why}): {entry['pinned']}; to determine it, record "
                f"{entry['experiment']}")
    ridge, quant = entry.get("ridge_bias", 0.0), entry.get("quantisation_bias", 0.0)
    if math.hypot(ridge, quant) >= RESOLVED_SHARE and ridge >= quant:
        return (f"not resolved: the ridge sets {100 * entry['ridge_bias']:.0f} % of it (the logs do not excite it; "
                "log with more q-current variation, e.g. a dither or accelerations)")
    pll = entry.get("pll_bias", 0.0)
    if math.hypot(ridge, quant, pll) >= RESOLVED_SHARE and pll >= quant and pll >= ridge:
        return (f"not resolved: the drive PLL's reading of the angle could move it by {100 * pll:.0f} % (log the "
                "encoder's count if the drive has it)")
    cur = entry.get("current_noise_bias", 0.0)
    if math.hypot(ridge, quant, pll, cur) >= RESOLVED_SHARE and cur >= max(quant, pll, ridge):
        return (f"not resolved: the correction for the logged current's noise could move it by {100 * cur:.0f} % (log "
                "the d-current beside the q-current: its noise is then read, not bounded)")
    if math.hypot(ridge, quant) >= RESOLVED_SHARE:
        return (f"not resolved: the encoder's rounding could move it by {100 * entry['quantisation_bias']:.0f} % (the "
                "logs hardly carry the rotor's acceleration above it, or above a host's stamp noise, and at one speed "
                "J/k0 trades with the maps along the speed ripple; log a speed change, accelerations or a dither, or "
                "use a finer encoder)")
    if not math.isfinite(entry["log_time_factor_to_resolve"]):
        # the parts longer logs do not change reach the share together, none of them alone
        fixed = {"the ridge": ridge, "the encoder's rounding": quant, "the PLL's reading": pll,
                 "the current's noise correction": cur}
        listed = ", ".join(f"{k} {100 * v:.1f} %" for k, v in fixed.items() if v >= 0.1 * RESOLVED_SHARE)
        return (f"not resolved: what longer logs of the same kind do not change reaches "
                f"{100 * math.hypot(*fixed.values()):.1f} % of it together ({listed}); a dither or accelerations "
                "(more acceleration above the encoder's rounding, more q-current variation at each angle) shrink it")
    # rounded up to a tenth: a factor just above 1 would otherwise read "1.0x", as if no more log were needed
    factor = max(1.1, math.ceil(10 * entry["log_time_factor_to_resolve"]) / 10)
    total = "" if log_seconds is None else f" ({factor * log_seconds:.0f} s)"
    # what the verdict weighs, so a standard error below 5 % next to "not resolved" reads as intended
    parts = []
    if entry.get("relative_at_confidence") is not None:
        parts.append(f"noise up to {100 * entry['relative_at_confidence']:.1f} % at {100 * RESOLVED_CONFIDENCE:.0f} %")
    if entry.get("outside_order_limit") is not None:
        parts.append(f"an unseen order outside the basis up to {100 * entry['outside_order_limit']:.1f} %")
    if entry.get("quantisation_bias", 0.0) >= 0.1 * RESOLVED_SHARE:
        parts.append(f"the encoder's rounding up to {100 * entry['quantisation_bias']:.1f} %")
    if entry.get("current_noise_bias", 0.0) >= 0.1 * RESOLVED_SHARE:
        parts.append(f"the current's noise up to {100 * entry['current_noise_bias']:.1f} %")
    if entry.get("pll_bias", 0.0) >= 0.1 * RESOLVED_SHARE:
        parts.append(f"the PLL's reading up to {100 * entry['pll_bias']:.1f} %")
    why = f" ({', '.join(parts)})" if parts else ""
    hint = f"; {entry['excitation_hint']}" if entry.get("excitation_hint") else ""
    return (f"not resolved{why}: about {factor:.1f}x the running log so far{total}, at the same excitation, "
            f"would resolve it{hint}")


def share_text(x: float) -> str:
    """A share as per cent with two significant digits, or "under 0.1 %"."""
    return "under 0.1 %" if x < 1e-3 else f"{100 * x:.2g} %"


def over_the_angle_text(found: dict | None) -> str:
    """One sentence on the cut orders read over the angle (``identification.orders_over_the_angle``); ``""`` where
    none were."""
    if not found:
        return ""
    kept = ", ".join(map(str, found["kept"])) or "none"
    shown = ", ".join(map(str, found["orders"][:8])) + (", ..." if len(found["orders"]) > 8 else "")
    return (f"the cogging's orders above the alias guard's ({shown}) read over the "
            f"angle from {found['segments']} steady stretch(es), {found['seconds']:.3g} s: kept {kept} (the others are "
            f"within their noise); where both read, that reading is {100 * found['agreement']:.1f} % of the map from the "
            f"time-domain fit's" + (f", {found['inflation']:.3g} times what their noise explains: the cut orders' "
                                    "standard errors scaled by it" if found["inflation"] > 1 else ""))


def orders_text(cut: dict | None) -> str:
    """One sentence on the orders left out of the basis because the logs turn too fast to resolve them
    (``identification.orders_not_resolved``); ``""`` where none were."""
    if not cut:
        return ""
    shown = ", ".join(map(str, cut["orders"][:8])) + (", ..." if len(cut["orders"]) > 8 else "")
    return (f"orders above {cut['highest_order']} per revolution not resolved in time by these logs and left out of "
            f"the time-domain fit ({shown}): nine in ten filter windows at speed turn at up to {cut['speed_rad_s']:.3g} rad/s (their "
            f"fastest step over the median step); logs at most {cut['speed_to_resolve_rad_s']:.3g} rad/s (or a host "
            "that polls faster) would resolve them")


def map_text(name: str, entry: dict, log_seconds: float | None = None) -> str:
    """One line on a map's entry of ``standard_error``: its standard error and :func:`resolution_verdict`, or
    only the verdict for a map the logs do not determine."""
    if entry.get("determined") is False:
        return f"{name}: {resolution_verdict(entry, log_seconds)}"
    return f"{name}: standard error {100 * entry['relative']:.1f} % of its RMS, {resolution_verdict(entry, log_seconds)}"


def fit_mechanics(logs, motor: RotaryMotor, options: RotaryIdentifyOptions | None = None) -> dict:
    """The feedforward a drive user tunes: ``i_q ≈ (J/k0) θ̈ + b ω + d0 sign(ω)`` fitted on the same
    windows as :func:`identify`, without any position dependence, with the same correction for the encoder's
    quantisation (:mod:`pgcomm.rotary.quantisation`; ``encoder_step`` as in :func:`identify`), the logs read as
    ``options`` say: the current shifted by ``current_delay`` samples and read held (``current_lag`` ``None``) or
    smooth with that lag between samples after the report filter ``current_filter`` (s) is taken out, the angle read
    through ``angle_pll`` and the time-periodic disturbances ``time_lines`` (Hz) fitted beside. It searches nothing: a
    reading left at ``"detect"`` is read as logged (no delay, held, the encoder's angle, no lines, no filter); give
    the one :func:`identify` found (``options.with_reading(result.reading())`` and its ``current_filter``): a mains
    pickup left unfitted moves the Coulomb term by tens of per cent and can turn the viscous term's sign.

    Returns:
        ``{"inertia_ratio": A·s²/rad, "viscous": A·s/rad, "coulomb": A}``.
    """
    options = options or RotaryIdentifyOptions()
    orders = orders_of(options, motor)
    min_samples_per_period, taps = _guard(options)
    if options.orders is None:
        # the windows of identify's own basis: the full basis's guard would keep only a joint's ramp from standstill
        orders, _ = resolved_orders(logs, motor, orders, min_samples_per_period)
    encoder_step = options.encoder_step
    current_delay, current_lag = _as_logged(options.current_delay, 0), _as_logged(options.current_lag, None)
    angle_pll, current_filter = _as_logged(options.angle_pll, None), _as_logged(options.current_filter, 0.0)
    time_lines = _as_logged(options.time_lines, ())
    lines = tuple(float(f) for f in time_lines or ())
    d, _, _, _ = _design(logs, motor, orders, min_samples_per_period, taps, encoder_step, current_delay, angle_pll,
                         lines, current_lag, current_filter)
    # the Coulomb column is the order-0 direction column (cos 0 · s)
    j0 = int(np.flatnonzero(orders.direction == 0)[0]) if np.any(orders.direction == 0) else None
    s_col = d["dir"][:, j0] if j0 is not None else np.sign(d["visc"])
    X = np.column_stack([d["acc"], d["visc"], s_col] + ([_line_columns(d, int(d["log"].max()) + 1)] if lines else []))
    G, _, _ = _quantisation_correction((X.T @ X)[None], np.array([float(np.sum(d["acc_noise"]))]))
    beta = np.linalg.lstsq(G[0], X.T @ d["y"], rcond=None)[0]
    return {"inertia_ratio": float(beta[0]), "viscous": float(beta[1]), "coulomb": float(beta[2])}


def _identify_torque(logs, motor, orders, t0) -> RotaryIdentification:
    _require_current(logs, motor.sample_time)
    ys, xs = [], []
    for i, log in enumerate(logs):
        name, th, iq, torque, _ = _log_arrays(log, i, motor.sample_time)
        if torque is None:
            raise DataError(f"{name}: column 'torque' missing (identification with a torque sensor)")
        if not np.all(np.isfinite(torque)):
            raise DataError(f"{name}: column 'torque' has a non-finite value at row "
                            f"{np.flatnonzero(~np.isfinite(torque))[0] + 1}")
        phi_r = harmonic_columns(th, orders.ripple)
        phi_c = harmonic_columns(th, orders.cogging)
        xs.append(np.column_stack([iq, iq[:, None] * phi_r, phi_c]))
        ys.append(torque)
    X, y = np.concatenate(xs), np.concatenate(ys)
    keep = np.any(X != 0, axis=0)
    if np.ptp(X[:, 0]) == 0:
        raise ExcitationError("torque-sensor identification needs a varying q-current")
    beta = np.zeros(X.shape[1])
    beta[keep] = np.linalg.lstsq(X[:, keep], y, rcond=None)[0]
    k0 = float(beta[0])
    nr = 2 * orders.ripple.size
    model = RotaryModel(motor.pole_pairs, Fourier.from_vector(orders.cogging, beta[1 + nr:] / k0),
                        Fourier.from_vector(orders.ripple, beta[1:1 + nr] / k0), Fourier.zeros([0]), k_t=k0,
                        info={"method": "torque sensor"})
    return RotaryIdentification(model, seconds=time.perf_counter() - t0, torque_sensor=True, k0=k0,
                                cost_Nm2=float(np.mean((y - X @ beta) ** 2)))
