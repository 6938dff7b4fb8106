"""The rotary twin's real-drive habits (:mod:`pgcomm.rotary.twin`, "A real drive's habits"), each on the twin's own
output against a closed form or a second formulation: the current report's filter, the current sensors' torque at the
electrical orders, ODrive's PLL, the host's stamps, the index's move between power-ups, a stall; the zoo's switch."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from pgcomm.rotary.model import Fourier
from pgcomm.rotary.twin import Gains, LawParams, Reference, RotaryTruth, Start, breakaway_current, deadtime_residual, \
    power_up_offset, simulate
from pgcomm.rotary.zoo import draw_rotary


def _quiet(t: RotaryTruth, **changes) -> RotaryTruth:
    """``t`` without noises and winding, its drive at its log rate: the columns are the twin's arithmetic alone."""
    return replace(t, current_noise=0.0, torque_noise=0.0, winding=None, control_per_log=1, **changes)


#: No feedback: with :func:`_open_loop`'s reference the drive holds the current it is given.
NO_FEEDBACK = Gains(0.0, 0.0, 0.0, 0.0, 0.0)


def _open_loop(n: int, current) -> Reference:
    """A speed-mode reference at rest with the demand ``current`` (A, ``(n,)``): under :data:`NO_FEEDBACK` the drive
    holds the current it is given (the classical law passes the demand through)."""
    z = np.zeros(n)
    return Reference(z, z, z, "speed", np.asarray(current, float))


def test_the_logged_current_is_the_drives_first_order_filter_of_what_it_measures():
    """``report_filter = τ``: the logged q-current is ``y_k = y_{k-1} + (1 - a)(i_k - y_{k-1})``, ``a = e^{-T_c/τ}``,
    from zero. On a step of ``I`` at sample ``k0`` (drive at its log rate): ``I (1 - a^{k-k0+1})``, to rounding. On a
    sinusoid at a drive that controls 4 times per logged sample: the steady state ``|H| sin(ωt + ∠H)`` of
    ``H = (1 - a)/(1 - a e^{-jωT_c})``, within the cubic spline's error on the control samples (``5/384 (ω T_s)^4``
    of the amplitude) once the start's transient (``a^k``) is gone, away from the run's last samples (the spline's
    end). Without the filter the log is the current."""
    t = _quiet(draw_rotary(0, 0), report_filter=0.02)
    ts = t.motor.sample_time
    amp = 0.25 * t.motor.current_limit
    n, k0 = 400, 50
    step = amp * (np.arange(n) >= k0)
    log = simulate(t, _open_loop(n, step), LawParams.classical(t.motor.pole_pairs), NO_FEEDBACK)
    a = math.exp(-ts / t.report_filter)
    k = np.arange(n)
    closed = np.where(k >= k0, amp * (1.0 - a ** (k - k0 + 1.0)), 0.0)
    np.testing.assert_allclose(log["iq_drive"], step, rtol=0, atol=1e-12 * amp)
    np.testing.assert_allclose(log["iq_1"], closed, rtol=0, atol=1e-12 * amp)
    plain = simulate(replace(t, report_filter=0.0), _open_loop(n, step), LawParams.classical(t.motor.pole_pairs),
                     NO_FEEDBACK)
    np.testing.assert_array_equal(plain["iq_1"], plain["iq_drive"])

    kk = 4
    t4 = replace(t, control_per_log=kk, report_filter=0.03)
    w = 2 * math.pi * 5.0
    n = 1000
    tt = ts * np.arange(n)
    log = simulate(t4, _open_loop(n, amp * np.sin(w * tt)), LawParams.classical(t.motor.pole_pairs), NO_FEEDBACK)
    tc = ts / kk
    a = math.exp(-tc / t4.report_filter)
    h = (1 - a) / (1 - a * np.exp(-1j * w * tc))
    # a^k below 1e-11 there; the spline's error bound holds away from its end conditions
    steady = (tt >= 0.8) & (tt <= tt[-10])
    expect = amp * abs(h) * np.sin(w * tt + np.angle(h))
    tol = (5.0 / 384.0) * (w * ts) ** 4 * amp + 1e-9 * amp
    assert np.max(np.abs(log["iq_1"] - expect)[steady]) <= tol
    assert abs(h) < 0.9  # the filter is visible at this frequency: the check could fail


def test_the_sensors_noise_goes_through_the_report_filter():
    """A filtered report carries the sensors' noise through the filter, as ODrive's ``Iq_measured`` and
    ``Id_measured`` do: white noise of std ``σ`` per control cycle through ``y_k = a y_{k-1} + (1 - a) x_k`` has the
    stationary variance ``σ² (1 - a)/(1 + a)``, and its lag-one correlation is ``a``. The logged d-current (held at
    zero) is that noise alone: its variance within its sampling error (``2 (1 + ρ²)/(1 - ρ²) / n`` relative for an
    AR(1) of correlation ``ρ = a^K`` between logged samples, 5 of them)."""
    kk, sigma = 4, 0.05
    t = replace(_quiet(draw_rotary(0, 0), report_filter=0.004), current_noise=sigma, control_per_log=kk)
    n = 20000
    log = simulate(t, _open_loop(n, np.zeros(n)), LawParams.classical(t.motor.pole_pairs), NO_FEEDBACK, seed=3)
    a = math.exp(-t.motor.sample_time / kk / t.report_filter)
    d = log["id_1"][200:]  # past the start's transient (a^(200 K) < 1e-80)
    expect = sigma ** 2 * (1 - a) / (1 + a)
    rho = a ** kk
    rel = 5 * math.sqrt(2 * (1 + rho ** 2) / (1 - rho ** 2) / d.size)
    assert abs(np.var(d) / expect - 1) < rel, (np.var(d), expect, rel)
    r1 = float(np.corrcoef(d[1:], d[:-1])[0, 1])
    assert abs(r1 - rho) < 5 / math.sqrt(d.size), (r1, rho)
    # white noise added after the filter would read sigma² (the twin without a filtered report)
    assert np.var(d) < 0.5 * sigma ** 2


def _three_phase_flow(theta_e, iq, offsets, gains, dt_error, dt_width, tan_delta):
    """A second formulation of the current that flows: the drive holds its measured phase currents at the command's
    (``i_k = i_q (-sin(θ_e - 2πk/3))``); the sensors of phases a and b read ``(1 + g) i + o``, phase c is what closes
    the star; the dead time takes ``dt_error tanh(i_k/dt_width)`` off each phase; the q- and d-currents by the
    three-phase amplitude-invariant Park sum; the true frame's q-current over ``cos δ``."""
    cmd = [iq * -np.sin(theta_e - 2 * np.pi * k / 3) for k in range(3)]
    a = (cmd[0] - offsets[0]) / (1 + gains[0])
    b = (cmd[1] - offsets[1]) / (1 + gains[1])
    flow = [a, b, -a - b]
    flow = [flow[k] - dt_error * np.tanh(cmd[k] / dt_width) for k in range(3)]
    i_q = (2 / 3) * sum(flow[k] * -np.sin(theta_e - 2 * np.pi * k / 3) for k in range(3))
    i_d = (2 / 3) * sum(flow[k] * np.cos(theta_e - 2 * np.pi * k / 3) for k in range(3))
    return i_q - i_d * tan_delta


def _order_amplitude(theta, values, order: int, n: int = 4096) -> float:
    """The amplitude of ``order`` (per revolution) in ``values`` over the last whole revolution of the increasing angle
    ``theta``: linearly interpolated on ``n`` angles, FFT."""
    end = theta[-1]
    grid = end - 2 * np.pi + 2 * np.pi * np.arange(n) / n
    x = np.fft.rfft(np.interp(grid, theta, values)) / n
    return float(2 * abs(x[order]))


def test_current_sensors_make_torque_at_the_electrical_orders():
    """A rotor turning slowly on a constant q-current (open loop, a viscous load, no cogging, ripple or friction), its
    drive with current-sensor offsets: the torque error ``T - k0 i_q`` has the order ``p`` of amplitude
    ``k0 |o_αβ|``, ``o_α = o_a``, ``o_β = (o_a + 2 o_b)/√3`` (FFT over a revolution, within the linear interpolation's
    error), and nothing at ``2p``; a gain mismatch adds ``2p``. Sample by sample, the torque is that of a second
    formulation (three phases and the offset error ``δ`` included) to rounding. Without the habits the torque
    error is zero."""
    base = draw_rotary(0, 3)  # 12N14P, p = 7
    p = base.motor.pole_pairs
    amp = 0.2 * base.motor.current_limit
    n = 4000
    w_target = 2 * np.pi / 1.5  # a revolution in 1.5 s: ~1500 samples per revolution at 1 kHz
    t = _quiet(base, cogging=Fourier.zeros([]), ripple=Fourier.zeros([]), drag=Fourier.zeros([]), coulomb=0.0,
               offset_error=0.0, encoder_counts=2**20)
    t = replace(t, viscous=t.k0 * amp / w_target)
    o = (0.02 * amp, -0.015 * amp)
    law = LawParams.classical(p)
    offsets = replace(t, sensor_offset=o)
    log = simulate(offsets, _open_loop(n, np.full(n, amp)), law, NO_FEEDBACK)
    err = log["torque"] - t.k0 * amp
    o_ab = math.hypot(o[0], (o[0] + 2 * o[1]) / math.sqrt(3))
    th = log["theta"]
    assert th[-1] - th[n // 4] > 2 * np.pi  # a whole revolution at a settled speed
    per_rev = n / ((th[-1] - th[0]) / (2 * np.pi))
    tol = 0.5 * (2 * np.pi * p / per_rev) ** 2 + 1e-6  # linear interpolation of order p
    assert _order_amplitude(th, err, p) == pytest.approx(t.k0 * o_ab, rel=tol)
    assert _order_amplitude(th, err, 2 * p) <= tol * t.k0 * o_ab
    np.testing.assert_allclose(log["iq_1"], amp, rtol=0, atol=1e-12 * amp)  # the drive reports what it measures

    g = (0.03, -0.02)
    full = replace(offsets, sensor_gain=g, offset_error=0.2)
    log = simulate(full, _open_loop(n, np.full(n, amp)), law, NO_FEEDBACK)
    flow = _three_phase_flow(p * log["theta"], amp, o, g, 0.0, 1.0, math.tan(0.2))
    np.testing.assert_allclose(log["torque"], full.k0 * flow, rtol=0, atol=1e-9 * full.k0 * amp)
    np.testing.assert_allclose(log["iq_true"], flow, rtol=0, atol=1e-9 * amp)
    gain_only = simulate(replace(t, sensor_gain=g), _open_loop(n, np.full(n, amp)), law, NO_FEEDBACK)
    th = gain_only["theta"]
    expect = _order_amplitude(th, t.k0 * _three_phase_flow(p * th, amp, (0, 0), g, 0, 1, 0), 2 * p)
    assert expect > 0.005 * t.k0 * amp  # the mismatch's order 2p is there to be found
    assert _order_amplitude(th, gain_only["torque"] - t.k0 * amp, 2 * p) == pytest.approx(expect, rel=tol)
    plain = simulate(t, _open_loop(n, np.full(n, amp)), law, NO_FEEDBACK)
    np.testing.assert_allclose(plain["torque"], t.k0 * amp, rtol=0, atol=1e-12 * t.k0 * amp)


def _dead_time_twin(rev_per_s: float, amp_share: float = 0.2):
    """Zoo motor 0:3 (12N14P) without noise, cogging, ripple or friction, turning at ``rev_per_s`` on a constant
    q-current ``amp`` (open loop, a viscous load), with a dead time of 5 % of ``amp`` over a zero crossing 20 % of it
    wide, a current loop of 300 rad/s and a winding pole of 100 rad/s: ``(truth, amp)``."""
    base = draw_rotary(0, 3)
    amp = amp_share * base.motor.current_limit
    t = _quiet(base, cogging=Fourier.zeros([]), ripple=Fourier.zeros([]), drag=Fourier.zeros([]), coulomb=0.0,
               offset_error=0.0, encoder_counts=2**20)
    return replace(t, viscous=t.k0 * amp / (2 * np.pi * rev_per_s), deadtime_error=0.05 * amp,
                   deadtime_width=0.2 * amp, current_bandwidth=300.0, electrical_pole=100.0), amp


@pytest.mark.parametrize("rev_per_s", [0.5, 2.0])
def test_the_current_loop_leaves_the_dead_times_residual(rev_per_s):
    """The drive's sensors measure the current that flows, so the dead time moves both off the command, by what the
    current loop leaves of it: the error ``e`` the dead time would leave without a loop (the three-phase formulation
    at the logged angle) through ``H(s) = a s/((s + a)(s + ω_c))`` (:func:`deadtime_residual`). On a rotor turning at
    a constant speed, the residual's order ``6p`` is ``e``'s times ``|H(jω)|`` at its frequency ``ω = 6 p Ω``, and
    times ``sinc²(ω T_c / 2)`` for the error held over a control cycle and the residual's mean over it, within the
    next terms of both (``(ω T_c)⁴/320``) and the images of the hold (``a T_c / 2π`` of the held error); the orders
    by least squares on the last revolution's samples (orders ``6p`` to ``24p``, where ``e`` has them). The measured current is the one that flows (no sensor errors); the current loop
    takes out most of the dead time (the residual's peak under a third of ``e``'s)."""
    t, amp = _dead_time_twin(rev_per_s)
    p = t.motor.pole_pairs
    n = 4000
    log = simulate(t, _open_loop(n, np.full(n, amp)), LawParams.classical(p), NO_FEEDBACK)
    th = log["theta"]
    residual = log["iq_drive"] - amp
    e = _three_phase_flow(p * th, amp, (0, 0), (0, 0), t.deadtime_error, t.deadtime_width, 0.0) - amp
    tc = t.motor.sample_time
    w = 6 * p * (th[-1] - th[n // 2]) / (tc * (n - 1 - n // 2))
    expect = deadtime_residual(t, w) * np.sinc(w * tc / (2 * np.pi)) ** 2
    tol = (w * tc) ** 4 / 320 + t.electrical_pole * tc / (2 * np.pi)
    last = th >= th[-1] - 2 * np.pi
    x = p * th[last, None] * np.arange(6, 25, 6)[None, :]
    basis = np.hstack([np.ones((x.shape[0], 1)), np.cos(x), np.sin(x)])

    def amplitude(v):
        c = np.linalg.lstsq(basis, v[last], rcond=None)[0]
        return math.hypot(c[1], c[5])

    ratio = amplitude(residual) / amplitude(e)
    assert ratio == pytest.approx(expect, rel=tol)
    assert 0.1 < expect < 0.9  # the loop's residual at this frequency: neither nothing nor all of it
    np.testing.assert_allclose(log["iq_true"], log["iq_drive"], rtol=0, atol=1e-12 * amp)
    assert np.max(np.abs(residual)) < np.max(np.abs(e)) / 3


def test_the_truths_model_holds_the_drives_current_errors():
    """:meth:`RotaryTruth.model` with the sensors' errors is the torque seen from the drive's current:
    ``k0' ((1 + r') i_q + c')`` equals ``k0 (1 + ρ)(i_q + e(θ, i_q)) + T_cog`` (e by the three-phase formulation, no dead
    time) at random angles and currents, to rounding; ``model(drive=False)`` is the motor alone."""
    t = replace(draw_rotary(0, 3), sensor_offset=(0.3, -0.2), sensor_gain=(0.02, -0.03))
    rng = np.random.default_rng(5)
    th = rng.uniform(0, 2 * np.pi, 300)
    iq = rng.uniform(-10, 10, 300)
    m = t.model()
    p = t.motor.pole_pairs
    flow = _three_phase_flow(p * th, iq, t.sensor_offset, t.sensor_gain, 0.0, 1.0, math.tan(t.offset_error))
    truth = t.k0 * (1 + t.ripple(th)) * flow + t.cogging(th)
    scale = t.k0 * 10
    np.testing.assert_allclose(m.k_t * ((1 + m.ripple(th)) * iq + m.cogging(th)), truth, rtol=0, atol=1e-10 * scale)
    assert abs(m.ripple.mean()) <= 1e-14 and m.k_t != pytest.approx(t.k0, rel=1e-4)
    alone = t.model(drive=False)
    plain = replace(t, sensor_offset=(0, 0), sensor_gain=(0, 0)).model()
    np.testing.assert_allclose(alone.cogging.coef, plain.cogging.coef, rtol=1e-15, atol=0)
    assert alone.k_t == pytest.approx(plain.k_t, rel=1e-15)


def _odrive_pll(theta_enc, dt, bw):
    """ODrive's encoder PLL step by step from rest on the count: predict, correct (``k_p = 2 bw``, ``k_i = bw²``)."""
    kp, ki = 2 * bw, bw * bw
    pe, ve = theta_enc[0], 0.0
    pos, vel = np.empty(theta_enc.size), np.empty(theta_enc.size)
    for k, x in enumerate(theta_enc):
        pe += dt * ve
        e = x - pe
        pe += dt * kp * e
        ve += dt * ki * e
        pos[k], vel[k] = pe, ve
    return pos, vel


def test_the_drives_angle_is_its_pll_on_the_encoder():
    """``pll_bandwidth``: the logged angle and velocity are ODrive's PLL run on the encoder's count of the rotor's
    angle (a loop written out step by step), to rounding; off the encoder's lattice; the position loop on it still
    follows its reference."""
    t = _quiet(draw_rotary(0, 0))
    t = replace(t, motor=replace(t.motor, sample_time=2.5e-4), pll_bandwidth=1000.0, encoder_counts=2**14)
    ts = t.motor.sample_time
    n = 4000
    prof = np.minimum(1.0, np.arange(n) / 800.0) * 20.0  # rad/s
    ref = Reference(ts * np.cumsum(prof), prof, np.gradient(prof, ts), "position")
    a = t.inertia / t.k0
    from pgcomm.rotary.twin import default_gains

    log = simulate(t, ref, LawParams.classical(t.motor.pole_pairs), default_gains(a))
    q = 2 * np.pi / t.encoder_counts
    pos, vel = _odrive_pll(np.round(log["theta_true"] / q) * q, ts, t.pll_bandwidth)
    np.testing.assert_allclose(log["theta"], pos, rtol=0, atol=1e-9 * np.max(np.abs(pos)))
    np.testing.assert_allclose(log["velocity"], vel, rtol=0, atol=1e-9 * np.max(np.abs(vel)))
    off_lattice = np.abs(log["theta"] / q - np.round(log["theta"] / q)) > 1e-3
    assert np.mean(off_lattice[n // 10:]) > 0.9
    assert np.max(np.abs(log["theta_true"] - ref.theta)[n // 2:]) < 0.01  # still tracking: the loop is stable


def test_host_rows_are_the_drives_state_at_jittered_stamps():
    """A host's habits: stamps increase; the instants' steps lie in 0.6-2.6 median steps apart from the gaps, their
    median is the log's period (within 5 standard errors of a median), the gaps come at their rate (within 5 binomial
    standard deviations) and the stamps sit within the noise's clip of their instants. Each row is the drive's state at
    its last control cycle before the instant: the same drive logged every control cycle (the existing formulation,
    test_rotary_model.py) read there, to rounding; the rotor's angle is the one at the instant, within the linear
    interpolation's error ``max|α| T_c²/8`` of that fine log. Without the host's habits, ``host=True`` changes nothing."""
    from scipy.interpolate import CubicSpline

    from pgcomm.rotary.experiment import quick_settings, tracking_references
    from pgcomm.rotary.regression import Orders
    from pgcomm.rotary.twin import HOST_STEP_RANGE, STAMP_NOISE_CLIP, SUBSTEPS, default_gains

    kk = 4
    base = replace(_quiet(draw_rotary(0, 0)), control_per_log=kk)
    ts = base.motor.sample_time
    t = replace(base, host_jitter=0.15, host_gaps=0.01, stamp_noise=0.02 * ts)
    a = t.inertia / t.k0
    ref = tracking_references(t.motor, Orders.for_motor(t.motor), quick_settings())["position"]
    law, gains = LawParams.classical(t.motor.pole_pairs), default_gains(a)
    log = simulate(t, ref, law, gains, seed=2, host=True)
    stamps, inst = log["t"], log["t_instant"]
    assert np.all(np.diff(stamps) > 0)
    steps = np.diff(inst) / ts
    gaps = steps > HOST_STEP_RANGE[1] + 1e-9
    m = steps.size
    assert abs(gaps.sum() - m * t.host_gaps) <= 5 * math.sqrt(m * t.host_gaps)
    core = steps[~gaps]
    assert core.min() >= HOST_STEP_RANGE[0] - 1e-9
    se_median = 1.2533 * t.host_jitter / math.sqrt(core.size)
    assert np.median(core) == pytest.approx(1.0, abs=5 * se_median)
    noise = stamps - inst
    assert np.max(np.abs(noise)) <= STAMP_NOISE_CLIP * ts + 1e-15
    assert np.std(noise) == pytest.approx(t.stamp_noise, rel=0.1)

    n = ref.n
    fine_t = np.minimum(ts / kk * np.arange(n * kk), ts * (n - 1))
    up = [CubicSpline(ts * np.arange(n), v)(fine_t) for v in (ref.theta, ref.omega, ref.alpha, np.zeros(n))]
    fine = simulate(replace(base, motor=replace(base.motor, sample_time=ts / kk), control_per_log=1),
                    Reference(up[0], up[1], up[2], ref.mode, up[3]), law, gains, seed=2,
                    n_sub=max(2, -(-SUBSTEPS // kk)))
    tc = ts / kk
    idx = np.floor(inst / tc).astype(int)
    for key in ("theta", "velocity", "iq_1", "demand"):
        scale = float(np.max(np.abs(fine[key])))
        np.testing.assert_allclose(log[key], fine[key][idx], rtol=0, atol=1e-9 * scale, err_msg=key)
    alpha = np.max(np.abs(np.diff(fine["omega_true"]))) / tc
    lin = np.interp(inst, fine["t"], fine["theta_true"])
    # the linear interpolation's error bound, with the acceleration's change within a cycle (the cogging turns by at
    # most an eighth of its period per logged sample) on top of the cycles' largest mean
    assert np.max(np.abs(log["theta_true"] - lin)) <= alpha * tc**2 / 8 * 1.25 + 1e-12
    drive = simulate(base, ref, law, gains, seed=2)
    same = simulate(base, ref, law, gains, seed=2, host=True)
    for key in drive:
        np.testing.assert_array_equal(same[key], drive[key])


def test_a_host_log_written_as_csv_keeps_its_stamps(tmp_path):
    """The zoo's CSV writer keeps a host's stamps as they are (12 digits), non-uniform."""
    from pgcomm.io.rotary_zoo import write_drive_log

    t = replace(_quiet(draw_rotary(0, 1)), host_jitter=0.2, host_gaps=0.01)
    n = 1500
    log = simulate(t, _open_loop(n, np.full(n, 0.1)), LawParams.classical(t.motor.pole_pairs), NO_FEEDBACK, host=True)
    write_drive_log(tmp_path / "run.csv", log)
    back = np.genfromtxt(tmp_path / "run.csv", delimiter=",", names=True)
    np.testing.assert_allclose(back["t"], log["t"], rtol=1e-11, atol=0)
    steps = np.diff(back["t"])
    assert steps.max() / steps.min() > 2


def test_the_index_moves_the_drives_angle_between_power_ups():
    """``power_up_offsets``: the same speed-loop run recorded in two power-ups turns the rotor the same way (the
    commutation is calibrated again, so the current sensors' errors stay on the rotor), and its logged angle is the
    other power_up's rolled by the power-up's offset in whole counts; an offset of an electrical period is rounded to a
    count, and power_ups wrap."""
    t = replace(_quiet(draw_rotary(0, 3)), power_up_offsets=(0.0, math.pi, 2 * math.pi / 7), sensor_offset=(0.3, 0.1),
                encoder_counts=2**16)
    a = t.inertia / t.k0
    from pgcomm.rotary.twin import default_gains

    n = 2000
    ts = t.motor.sample_time
    om = np.minimum(1.0, np.arange(n) / 300.0) * 15.0
    ref = Reference(1.0 + ts * np.cumsum(om), om, np.gradient(om, ts), "speed")
    law = LawParams.classical(t.motor.pole_pairs)
    one, two = (simulate(t, ref, law, default_gains(a), start=Start(power_up=s, theta=1.0)) for s in (0, 1))
    q = 2 * np.pi / t.encoder_counts
    assert power_up_offset(t, 1) == pytest.approx(math.pi, abs=1e-12)
    scale = float(np.max(np.abs(one["theta_true"])))
    np.testing.assert_allclose(two["theta_true"], one["theta_true"], rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(two["torque"], one["torque"], rtol=0, atol=1e-12 * float(np.max(np.abs(one["torque"]))))
    np.testing.assert_allclose(two["theta"] - one["theta"], math.pi, rtol=0, atol=1e-12 * scale)
    third = power_up_offset(t, 2)
    assert third == pytest.approx(round((2 * np.pi / 7) / q) * q, abs=1e-12) and third != 2 * np.pi / 7
    assert power_up_offset(t, 4) == power_up_offset(t, 1) and power_up_offset(replace(t, power_up_offsets=()), 1) == 0.0


def test_breakaway_current_of_a_single_cogging_harmonic():
    """One cogging harmonic of amplitude ``C`` (N·m) and Coulomb friction ``T_c``, no ripple or drive errors: a rotor
    at rest turns from every angle above ``(C + T_c)/k0``, in either direction (bisection to 1e-9)."""
    t = replace(draw_rotary(0, 0), cogging=Fourier(np.array([18]), np.array([[0.3, 0.4]])), ripple=Fourier.zeros([]),
                drag=Fourier.zeros([]), coulomb=0.1)
    expect = (0.5 + 0.1) / t.k0
    assert breakaway_current(t) == pytest.approx(expect, rel=1e-9)
    assert breakaway_current(t, -1.0) == pytest.approx(expect, rel=1e-9)


def test_a_speed_loop_too_soft_for_the_cogging_stalls_halfway():
    """:func:`pgcomm.rotary.experiment.stall_log` on a zoo motor with a real drive's habits: the rotor turns through
    many cogging periods in the run's first half and stops in its second (the last quarter: speed below a tenth of
    the break-away speed, travel below half a cogging period); the same reference in the drive's tuned PI loop turns
    to the end."""
    from pgcomm.rotary.experiment import stall_log
    from pgcomm.rotary.twin import default_gains

    # the drive at its log rate, without the PLL it was drawn for a faster drive (a run of seconds in seconds)
    t = replace(draw_rotary(0, 3, real_drive=True), control_per_log=1, pll_bandwidth=0.0)
    assert t.drive_errors and t.host_logger
    log = stall_log(t, seed=1, seconds=8.0)
    th, om, tt = log["theta_true"], log["omega_true"], log["t"]
    period = 2 * np.pi / t.motor.cogging_fundamental
    half = tt <= 0.5 * tt[-1]
    last = tt >= 0.75 * tt[-1]
    w_b = log["stall_speed"]
    assert th[half][-1] - th[half][0] > 20 * period
    assert np.max(np.abs(om[last])) < 0.1 * abs(w_b)
    assert np.ptp(th[last]) < 0.5 * period
    ts = t.motor.sample_time
    n = int(round(8.0 / ts))
    w = w_b * np.linspace(1.5, 0.5, n)
    ref = Reference(th[0] + ts * np.cumsum(w), w, np.gradient(w, ts), "speed")
    moving = simulate(t, ref, LawParams.classical(t.motor.pole_pairs), default_gains(t.inertia / t.k0), seed=1)
    assert moving["theta_true"][-1] - moving["theta_true"][0] > 0.8 * (ref.theta[-1] - ref.theta[0])


def test_the_zoo_draws_the_habits_behind_one_switch():
    """``draw_rotary(..., real_drive=True)``: the same motor and drive as without it, with every habit drawn within
    :data:`~pgcomm.rotary.zoo.REAL_DRIVE_RANGES` (report filters up to the ODrive logs' 80-100 ms among them, PLLs on
    some drives and not others, indices that move by half a revolution); the truth file keeps them, and a truth file
    without them is a twin without them."""
    from pgcomm.rotary.zoo import REAL_DRIVE_RANGES as R

    taus, bws, halves = [], [], 0
    for seed in range(4):
        for i in range(25):
            plain, real = draw_rotary(seed, i), draw_rotary(seed, i, real_drive=True)
            assert not plain.habits()
            assert real.k_t == plain.k_t and real.control_per_log == plain.control_per_log
            np.testing.assert_array_equal(real.cogging.coef, plain.cogging.coef)
            i_lim = plain.motor.current_limit
            full = R["sensor_range"] * i_lim
            assert max(map(abs, real.sensor_offset)) <= 6 * R["sensor_offset"][1] * full
            assert max(map(abs, real.sensor_gain)) <= 6 * R["sensor_gain"][1]
            w = plain.winding
            assert real.deadtime_error == pytest.approx(w.deadtime_voltage / w.resistance, rel=1e-12)
            assert real.current_bandwidth == pytest.approx(w.loop_gain / w.inductance, rel=1e-12)
            assert real.report_filter == 0 or R["report_filter"][0] <= real.report_filter <= R["report_filter"][1]
            tc = plain.motor.sample_time / plain.control_per_log
            assert real.pll_bandwidth == 0 or R["pll_bandwidth"][0] <= real.pll_bandwidth <= 0.25 / tc + 1e-9
            assert real.host_logger and (not real.power_up_offsets or real.power_up_offsets[0] == 0.0)
            halves += any(abs(x - math.pi) < 1e-12 for x in real.power_up_offsets)
            taus.append(real.report_filter)
            bws.append(real.pll_bandwidth)
            assert json.dumps(RotaryTruth.from_dict(json.loads(json.dumps(real.to_dict()))).to_dict()) == \
                json.dumps(real.to_dict())
    taus, bws = np.array(taus), np.array(bws)
    assert np.any(taus == 0) and np.any(taus >= 0.08) and np.any((taus > 0) & (taus < 0.005))
    assert np.any(bws == 0) and np.any(bws > 0)
    assert halves > 0
    assert "report_filter" not in draw_rotary(0, 0).to_dict()


def test_habits_are_checked():
    t = draw_rotary(0, 0)
    for change, match in (({"sensor_offset": (1.0,)}, "sensor_offset"), ({"report_filter": -1.0}, "report_filter"),
                          ({"sensor_gain": (-1.0, 0.0)}, "sensor_gain"), ({"host_gaps": 2.0}, "host_gaps"),
                          ({"deadtime_error": 0.1}, "deadtime_width"),
                          ({"deadtime_error": 0.1, "deadtime_width": 0.1, "winding": None}, "current_bandwidth"),
                          ({"power_up_offsets": (0.0, float("nan"))}, "power_up_offsets")):
        with pytest.raises(ValueError, match=match):
            replace(t, **change)


def test_zoo_real_drive_on_the_command_line(tmp_path, capsys):
    """``pgcomm zoo --kind rotary --real-drive`` writes truths with the habits; the switches are a rotary drive's, and
    ``--stall`` writes a log (it needs ``--logs``): refused in one line, exit 2, nothing written."""
    from pgcomm.cli import main
    from pgcomm.io.rotary_zoo import read_truth

    from test_bad_input import _check_refused

    out = tmp_path / "z"
    assert main(["zoo", "--kind", "rotary", "--real-drive", "--motors", "2", "--seed", "3", "--out", str(out),
                 "--quiet"]) == 0
    for i in (1, 2):
        truth = read_truth(out / f"motor_{i:02d}" / "truth.json")
        assert truth.habits() and truth.to_dict() == draw_rotary(3, i - 1, real_drive=True).to_dict()
    _check_refused(["zoo", "--motors", "1", "--real-drive"], tmp_path / "o1", capsys,
                   r"--real-drive: a rotary drive's option \(--kind rotary\)", tmp_path)
    _check_refused(["zoo", "--motors", "1", "--kind", "rotary", "--stall"], tmp_path / "o2", capsys,
                   r"--stall writes a log: give it with --logs", tmp_path)
