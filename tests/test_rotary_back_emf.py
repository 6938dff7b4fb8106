"""The logged q-voltage: the twin's winding (pgcomm.rotary.winding) and the ripple it measures (pgcomm.rotary.back_emf)."""

from __future__ import annotations

import functools
import math
from dataclasses import replace

import numpy as np
import pytest

from pgcomm.rotary.back_emf import agreement, fit_voltage, has_d_voltage, has_voltage, offset_text, voltage_text
from pgcomm.rotary.experiment import running_references
from pgcomm.settings import RotarySettings
from pgcomm.rotary.identify import identify
from pgcomm.settings import RotaryIdentifyOptions
from pgcomm.rotary.model import Fourier
from pgcomm.rotary.regression import Orders
from pgcomm.rotary.twin import LawParams, default_gains, simulate
from pgcomm.rotary.winding import BACK_EMF_FACTOR, BackEmf, Winding, d_voltage, deadtime_q, logged_dq, phase_saturation_dq, \
    q_voltage
from pgcomm.rotary.zoo import draw_rotary


@functools.lru_cache(maxsize=2)
def _identified(index: int):
    """Zoo motor ``index`` with its winding, its logs (:func:`_logs`) and their identification: one per motor for the
    module's tests of the q- and d-voltages."""
    t = draw_rotary(0, index)
    logs = _logs(t)
    return t, logs, identify(logs, t.motor)


def _logs(truth, settings=RotarySettings(), seed=1):
    a = truth.inertia / truth.k0
    refs = running_references(truth.motor, a, settings, Orders.for_motor(truth.motor))
    return [simulate(truth, r, LawParams.classical(truth.motor.pole_pairs), default_gains(a), seed=seed + k)
            for k, r in enumerate(refs)]


def test_the_twins_back_emf_is_its_torque_constant_seen_from_the_winding():
    """With no resistance, inductance, dead time or noise the logged q-voltage is the back-EMF alone, and the power it
    exchanges with the current, (3/2) v_q i_q, is the air-gap torque's power less the cogging's, T_em ω − T_cog ω:
    the twin's torque (from its scan) and its voltage (from the winding) are two formulations of one field."""
    t = draw_rotary(0, 2)
    t = replace(t, torque_noise=0.0, winding=Winding(0.0, 0.0, 0.0, 1.0, 0.0, 0.0))
    log = _logs(t, RotarySettings(revolutions=0.5))[0]
    th, om, iq = log["theta_true"], log["omega_true"], log["iq_true"]
    power_v = 1.0 / BACK_EMF_FACTOR * log["vq_1"] * iq
    power_t = (log["torque"] - t.cogging(th)) * om
    # the torque's scale times the speed's: what a relative error of 1e-12 in either would leave
    tol = 1e-12 * float(np.max(np.abs(t.k0 * iq))) * float(np.max(np.abs(om)))
    assert np.max(np.abs(power_v - power_t)) <= tol


def test_the_dead_time_is_a_voltage_against_the_current_of_four_over_pi_v_dt():
    """Far above the zero crossing, each phase loses V_dt against its current's sign; its q component averages to
    −(4/π) V_dt sign(i_q) over the electrical period (the mean of Σ|sin| over three phases is 6/π), and far below it
    the error is a resistance: −V_dt (2/3) Σ p_k² i_q / i_ε = −V_dt i_q / i_ε."""
    th_e = np.linspace(0, 2 * math.pi, 6000, endpoint=False)
    for iq in (5.0, -5.0):
        v = deadtime_q(np.full(th_e.size, iq), th_e, 0.2, 1e-6)
        assert abs(float(np.mean(v)) + 4.0 / math.pi * 0.2 * math.copysign(1.0, iq)) < 1e-4 * 0.2
    small = deadtime_q(np.full(th_e.size, 1e-4), th_e, 0.2, 1.0)
    # tanh(x) = x - x³/3: the cubic term at x = 1e-4 is 1e-8 of the linear one
    np.testing.assert_allclose(small, -0.2 * 1e-4, rtol=1e-7)


#: The synthetic logs' drive offset error (rad, electrical): the magnets' q axis ahead of the drive's.
SYNTHETIC_DELTA = 0.2


def _synthetic(noise: float, seed: int = 0):
    """Constant speeds of 20 and 40 rad/s in both directions with a current dither, the q-voltage of a known winding
    and ripple (the twin's own formula, a dead time of a width in the fit's family)."""
    rng = np.random.default_rng(seed)
    ts, p = 1e-3, 4
    ripple = Fourier(np.array([1, 3, 8, 24]), rng.normal(0, 0.01, (4, 2)))
    n = 4000
    t = ts * np.arange(n)
    iq = 1.0 + 3.0 * np.sin(2 * math.pi * 61 * t) + 0.5 * np.sin(2 * math.pi * 83 * t)
    # the dead time's width one of the fit's (a tenth of the RMS current), so that the fit's model is the generator's
    w = Winding(0.4, 4e-4, 0.1, 0.1 * math.sqrt(float(np.mean(iq**2))), 0.0, noise)
    logs = []
    for speed in (20.0, -20.0, 40.0, -40.0):
        th = 0.3 + speed * t
        om = np.full(n, speed)
        emf = BackEmf(0.3 / math.cos(SYNTHETIC_DELTA), SYNTHETIC_DELTA, ripple, p)
        vq = q_voltage(w, emf, th, om, iq, ts, rng.standard_normal(n))
        vd = d_voltage(w, emf, th, om, iq, rng.standard_normal(n))
        logs.append({"t": t, "theta": th, "iq_1": iq, "vq_1": vq, "vd_1": vd})
    return logs, ripple, w, p, ts


def test_fit_voltage_is_exact_without_noise_and_within_its_covariance_with_it():
    """Noise off, the ripple, the back-EMF constant and the resistance come back to rounding (the model is the
    generator's, a constant speed makes the central differences exact). With noise, over twenty seeds the
    ripple's error over its reported covariance is χ² with 8 degrees of freedom: its mean within 4 standard
    deviations of 8 (a sandwich that underestimated the noise twofold would give a mean near 32)."""
    logs, ripple, w, p, ts = _synthetic(0.0)
    rms = Fourier.rms(ripple)
    f = fit_voltage(logs, ripple.orders, p, ts)
    truth = np.concatenate([ripple.coef[:, 0], ripple.coef[:, 1]])
    assert np.max(np.abs(f["ripple"] - truth)) < 1e-8 * rms
    assert abs(f["back_emf_constant"] - BACK_EMF_FACTOR * 0.3) < 1e-9 * 0.3
    assert abs(f["resistance"] - w.resistance) < 1e-6 * w.resistance
    off = f["offset_error"]
    assert abs(off["delta"] - SYNTHETIC_DELTA) < 1e-8
    assert abs(off["k_t_aligned"] - 0.3 / math.cos(SYNTHETIC_DELTA)) < 1e-8 * 0.3
    assert abs(off["inductance"] - w.inductance) < 1e-6 * w.inductance
    chi = []
    for seed in range(20):
        logs, ripple, w, p, ts = _synthetic(0.05, seed=seed)
        f = fit_voltage(logs, ripple.orders, p, ts)
        d = f["ripple"] - np.concatenate([ripple.coef[:, 0], ripple.coef[:, 1]])
        chi.append(float(d @ np.linalg.solve(f["cov"], d)))
    k = 2 * ripple.orders.size
    assert abs(np.mean(chi) - k) < 4 * math.sqrt(2 * k / len(chi)), chi


def test_the_voltage_takes_the_currents_timing():
    """Current and voltage written one sample late in the same record (zoo motor 0): identify reads the current's
    delay, and the voltage's back-EMF constant and ripple come out as from the record in time, within a third of
    their standard errors (the same samples, one fewer at the end)."""
    t = draw_rotary(0, 0)
    logs = _logs(t, RotarySettings(revolutions=1.0))

    def late(x):
        return np.concatenate([x[:1], x[:-1]])

    shifted = [dict(log, iq_1=late(log["iq_1"]), vq_1=late(log["vq_1"])) for log in logs]
    a, b = identify(logs, t.motor), identify(shifted, t.motor)
    assert b.current_delay["samples"] == 1
    va, vb = a.back_emf, b.back_emf
    assert vb["voltage_delay"] == 1
    assert abs(vb["back_emf_constant"] - va["back_emf_constant"]) < va["back_emf_constant_se"] / 3
    ra, rb = Fourier.from_dict(va["ripple"]), Fourier.from_dict(vb["ripple"])
    th = np.linspace(0, 2 * math.pi, 1024, endpoint=False)
    assert float(np.sqrt(np.mean((ra(th) - rb(th)) ** 2))) < va["ripple_rms_error"] / 3


def test_agreement_is_the_rms_difference_against_what_both_errors_give():
    """On a basis of orders 1 and 2 (the mean square of [a1, a2, b1, b2] is half its squared norm): two estimates
    3 % apart in one coefficient differ by 3/√2 % RMS; with covariances of 0.01² each per coefficient the errors give
    √(2 · 4 · 0.01² / 2) = 2 % RMS, so they agree at 1.5x; 6 % apart they do not; an extra mean square of the
    currents' counts."""
    from pgcomm.rotary.regression import _map_gram

    gram = _map_gram(np.array([1, 2]))
    np.testing.assert_allclose(gram, 0.5 * np.eye(4), atol=1e-12)
    c = np.eye(4) * 0.01**2
    a = agreement(np.zeros(4), c, np.array([0.03, 0, 0, 0]), c, gram)
    assert abs(a["rms_difference"] - 0.03 / math.sqrt(2)) < 1e-12
    assert abs(a["expected_rms_difference"] - 0.02) < 1e-12 and a["consistent"]
    assert not agreement(np.zeros(4), c, np.array([0.06, 0, 0, 0]), c, gram)["consistent"]
    assert agreement(np.zeros(4), c, np.array([0.06, 0, 0, 0]), c, gram, extra_ms=0.03**2)["consistent"]


@pytest.mark.parametrize("index", [0, 3])
def test_identify_checks_the_ripple_against_the_voltage_and_reads_k0(index):
    """On zoo motors with the twin's winding: the back-EMF constant gives k0 (the truth's k_t cos δ) within four of
    its standard errors, the resistance within 10 %, and the voltage's ripple agrees with the currents'. A voltage
    whose ripple is not the torque's (an extra 5 % of order 2p in the back-EMF, as a saliency would add) is
    called inconsistent. The model is the currents' either way, to the digit."""
    t, logs, res = _identified(index)
    assert has_voltage(logs)
    bare = identify(logs, t.motor, RotaryIdentifyOptions(back_emf=False))
    v = res.back_emf
    assert bare.back_emf is None
    se = v["back_emf_constant_se"] / BACK_EMF_FACTOR
    assert abs(v["k0_amplitude_invariant"] - t.k0) < 4 * se
    assert abs(v["resistance"] / t.winding.resistance - 1.0) < 0.1
    assert v["consistent"], v
    assert "agrees" in voltage_text(v)
    np.testing.assert_array_equal(res.model.ripple.coef, bare.model.ripple.coef)
    p = t.motor.pole_pairs
    kappa = BACK_EMF_FACTOR * t.k0
    bad = [dict(log, vq_1=log["vq_1"] + 0.05 * kappa * log["omega_true"] * np.cos(2 * p * log["theta_true"]))
           for log in logs]
    # the currents as they were: read as the first identification read them
    w = identify(bad, t.motor, RotaryIdentifyOptions().with_reading(res.reading())).back_emf
    assert not w["consistent"], w
    assert "differs from the currents" in voltage_text(w)


def test_the_zoo_draws_the_same_motor_beside_its_winding():
    """The winding comes from a stream of its own and the voltage's noise is drawn after the currents': the logged
    currents of a twin with a winding are those of the same twin without one (so every figure of the currents'
    identification stays as it was)."""
    t = draw_rotary(0, 0)
    assert t.winding is not None and t.winding.resistance > 0
    a = _logs(replace(t, winding=None), RotarySettings(revolutions=0.3))[0]
    b = _logs(t, RotarySettings(revolutions=0.3))[0]
    np.testing.assert_array_equal(a["iq_1"], b["iq_1"])
    assert "vq_1" not in a and "vq_1" in b


def test_a_voltage_without_back_emf_is_said_so_not_read():
    """A vq_1 column of noise alone (a drive that logs another quantity there) gives no ripple, no non-finite number,
    and a line that says the constant is not determined and why that may be."""
    t = draw_rotary(0, 0)
    logs = _logs(t, RotarySettings(revolutions=1.0))
    rng = np.random.default_rng(3)
    noise = [dict(log, vq_1=0.01 * rng.standard_normal(log["t"].size)) for log in logs]
    v = identify(noise, t.motor).back_emf
    assert v["consistent"] is None and math.isfinite(v["back_emf_constant"])
    assert "does not determine the back-EMF constant" in voltage_text(v)


def test_the_twins_d_voltage_is_the_magnets_back_emf_seen_in_the_drives_frame():
    """A second formulation of the twin's back-EMF: the phases' back-EMFs of a field whose q axis is δ ahead of the
    drive's, ``e_k = E (−sin(η + δ − 2πk/3))`` with ``E = (2/3) k_t (1 + ρ) ω``, Park-transformed into the drive's frame
    ``η = p θ + offset`` (amplitude-invariant), are the twin's logged v_d and v_q with no resistance, inductance, dead
    time or noise; to 1e-12 of E."""
    t = draw_rotary(0, 1)
    t = replace(t, winding=Winding(0.0, 0.0, 0.0, 1.0, 0.0, 0.0))
    log = _logs(t, RotarySettings(revolutions=0.3))[0]
    th, om = log["theta_true"], log["omega_true"]
    eta = t.motor.pole_pairs * th + t.motor.commutation_offset
    big_e = BACK_EMF_FACTOR * t.k_t * (1.0 + t.ripple(th)) * om
    vd, vq = np.zeros_like(th), np.zeros_like(th)
    for k in range(3):
        e_k = big_e * -np.sin(eta + t.offset_error - 2 * math.pi * k / 3)
        vd += 2.0 / 3.0 * e_k * np.cos(eta - 2 * math.pi * k / 3)
        vq -= 2.0 / 3.0 * e_k * np.sin(eta - 2 * math.pi * k / 3)
    tol = 1e-12 * float(np.max(np.abs(big_e)))
    assert np.max(np.abs(log["vd_1"] - vd)) <= tol
    assert np.max(np.abs(log["vq_1"] - vq)) <= tol


def test_the_dead_times_voltage_is_a_hexagons_vertex():
    """Far above the zero crossing every phase's error is ±V_dt, so the dead time's vector in the drive's frame is
    (2/3) V_dt Σ ±a^k: a vertex of the hexagon, of length (4/3) V_dt at every electrical angle; its d part turns sign
    across each sector (mean zero over the period)."""
    th_e = np.linspace(0, 2 * math.pi, 6000, endpoint=False) + 1e-3
    d, q = phase_saturation_dq(np.full(th_e.size, 5.0), th_e, [1e-9])
    np.testing.assert_allclose(np.hypot(d[:, 0], q[:, 0]), 4.0 / 3.0, rtol=1e-12)
    assert abs(float(np.mean(d))) < 1e-3 and float(np.ptp(d)) > 1.0


@pytest.mark.parametrize("index", [0, 3])
def test_identify_reads_the_drives_offset_error_from_the_d_voltage(index):
    """On zoo motors with the twin's winding, the d-voltage gives the offset error δ (the magnets' q axis ahead of the
    drive's) and the torque constant along the magnets' axis within four of their standard errors. Set the drive's
    offset to the one it reports (the twin's drive frame turned by δ̂, the magnets where they were), the logs give an
    offset error within four standard errors of zero, k0 = k_t, and the line says the offset is on the axis."""
    t, logs, res = _identified(index)
    assert has_d_voltage(logs)
    off = res.back_emf["offset_error"]
    assert abs(off["delta"] - t.offset_error) < 4 * off["delta_se"], (off, t.offset_error)
    assert abs(off["k_t_aligned"] - t.k_t) < 4 * off["k_t_aligned_se"]
    assert "ahead of the drive's" in offset_text({"offset_error": off})
    turned = replace(t, offset_error=t.offset_error - (off["corrected_offset"] - t.motor.commutation_offset),
                     motor=replace(t.motor, commutation_offset=off["corrected_offset"]))
    v = identify(_logs(turned, seed=7), turned.motor).back_emf
    again = v["offset_error"]
    assert abs(again["delta"]) < 4 * again["delta_se"], again
    assert abs(v["k0_amplitude_invariant"] - t.k_t) < 4 * v["back_emf_constant_se"] / BACK_EMF_FACTOR
    assert "on the magnets' axis" in offset_text(v)



def test_samples_at_the_inverters_voltage_limit_are_left_out():
    """A drive at its voltage limit logs a voltage vector clipped to vbus/√3 that the winding's model does not
    follow. With the supply logged, those samples (and the model's near them) are left out: the fit on the clipped logs
    is the fit on the unclipped ones (the same rows, to rounding), and the line counts them; without the supply the
    clipped samples pull the back-EMF constant by more than four of its standard errors."""
    logs, ripple, w, p, ts = _synthetic(0.05, seed=2)
    amp = np.concatenate([np.hypot(lg["vq_1"], lg["vd_1"]) for lg in logs])
    vbus = math.sqrt(3.0) * float(np.quantile(amp, 0.9))
    clipped, plain = [], []
    for lg in logs:
        a = np.hypot(lg["vq_1"], lg["vd_1"])
        s = np.minimum(1.0, vbus / math.sqrt(3.0) / a)
        clipped.append(dict(lg, vq_1=lg["vq_1"] * s, vd_1=lg["vd_1"] * s, vbus=np.full(a.size, vbus)))
        plain.append(dict(lg, vbus=np.full(a.size, vbus)))
    fc, fp = fit_voltage(clipped, ripple.orders, p, ts), fit_voltage(plain, ripple.orders, p, ts)
    assert fc["rows_at_voltage_limit"] == fp["rows_at_voltage_limit"] > 0
    kappa = BACK_EMF_FACTOR * 0.3
    assert abs(fc["back_emf_constant"] - fp["back_emf_constant"]) < 1e-9 * kappa
    assert abs(fc["back_emf_constant"] - kappa) < 4 * fc["back_emf_constant_se"]
    blind = fit_voltage([{k: v for k, v in lg.items() if k != "vbus"} for lg in clipped], ripple.orders, p, ts)
    assert blind["rows_at_voltage_limit"] == 0
    assert abs(blind["back_emf_constant"] - kappa) > 4 * blind["back_emf_constant_se"]
    info = {"used_logs": 4, "back_emf_constant": fc["back_emf_constant"], "k0_amplitude_invariant": 0.3,
            "resistance": fc["resistance"], "consistent": True, "ripple_rms": 0.01, "ripple_rms_error": 0.001,
            "rms_difference": 0.001, "expected_rms_difference": 0.001, "rows_at_voltage_limit": fc["rows_at_voltage_limit"]}
    assert "voltage limit" in voltage_text(info)


def test_a_drive_that_applies_its_voltage_late_does_not_move_the_offset():
    """A drive that applies its command τ = 75 µs after the sample, in the frame of the sample's angle, logs voltages
    turned by φ = p ω τ (up to 0.012 rad here): the back-EMF's d/q ratio reads δ + φ. The fit's term −τ p ω v_q takes
    it out: δ comes back within 2 φ_max² (the linearised rotation's remainder), where leaving it in would put δ off by
    the mean φ (≥ 0.006 rad here); τ comes back as τ (1 + tan²δ) to within 2 φ_max (the ratio of the turned voltages is
    tan(δ + φ))."""
    logs, ripple, w, p, ts = _synthetic(0.0)
    lag = 75e-6
    late = []
    for lg in logs:
        om = np.gradient(lg["theta"], ts)
        vd, vq = logged_dq(lg["vd_1"], lg["vq_1"], p, om, lag)
        late.append(dict(lg, vd_1=vd, vq_1=vq))
    phi_max = p * 40.0 * lag
    off = fit_voltage(late, ripple.orders, p, ts)["offset_error"]
    assert abs(off["delta"] - SYNTHETIC_DELTA) < 2 * phi_max ** 2
    expect = lag * (1.0 + math.tan(SYNTHETIC_DELTA) ** 2)
    assert abs(off["voltage_lag_s"] - expect) < 2 * phi_max * expect
    assert abs(fit_voltage(logs, ripple.orders, p, ts)["offset_error"]["voltage_lag_s"]) < 1e-9



def test_without_a_d_voltage_the_line_says_what_would_give_the_offset():
    """Logs with the q-voltage and no d-voltage (the maintainers' logs): no offset is read, and the line names the
    column that would give it; logs without any voltage say nothing about it."""
    t = draw_rotary(0, 0)
    logs = [{k: v for k, v in log.items() if k != "vd_1"} for log in _logs(t, RotarySettings(revolutions=1.0))]
    v = identify(logs, t.motor).back_emf
    assert v["consistent"] is not None and v["offset_error"] is None
    assert "vd_1" in offset_text(v)
    assert offset_text(None) is None
