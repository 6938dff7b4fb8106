"""Rotary model, orders, law and motor TOML: closed forms, explicit tolerances."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pgcomm.errors import ConfigError
from pgcomm.rotary.law import MIN_GAIN, iq_command, iq_for_torque
from pgcomm.rotary.model import Fourier, RotaryModel, cogging_orders, harmonic_columns, ripple_orders
from pgcomm.rotary.motor import RotaryMotor


def _model(rng):
    return RotaryModel(7, Fourier(np.array([84, 12, 1]), rng.normal(0, 0.1, (3, 2))),
                       Fourier(np.array([1, 42]), rng.normal(0, 0.01, (2, 2))),
                       Fourier(np.array([0, 14]), np.array([[0.05, 0.0], [0.01, -0.02]])), viscous=1e-3,
                       inertia_ratio=2e-3, k_t=0.1)


def test_orders_follow_the_slot_pole_combination():
    o = cogging_orders(12, 7)  # 12N14P: LCM(12, 14) = 84
    assert {84, 168, 252, 12, 14, 1, 2} <= set(o.tolist())
    assert o.max() == 252 and np.all(np.diff(o) > 0)
    assert {1, 14, 42, 84, 12} <= set(ripple_orders(12, 7).tolist())
    assert RotaryMotor(21, 36).cogging_fundamental == 252
    assert RotaryMotor(7, 12).electrical_period == pytest.approx(2 * math.pi / 7, rel=1e-15)


def test_fourier_closed_forms(rng):
    th = np.linspace(0, 2 * math.pi, 4096, endpoint=False)
    cols = harmonic_columns(th, [0, 3])
    np.testing.assert_allclose(cols[:, 1], np.cos(3 * th), atol=1e-12)
    np.testing.assert_allclose(cols[:, 3], np.sin(3 * th), atol=1e-12)
    f = Fourier(np.array([0, 5, 84]), rng.normal(size=(3, 2)))
    # Parseval against the sampled RMS (exact for orders below half the sample count)
    assert f.rms() == pytest.approx(np.sqrt(np.mean(f(th) ** 2)), rel=1e-10)
    # periodic over one revolution, multi-turn angles included
    scale = np.abs(f.coef).sum()
    np.testing.assert_allclose(f(th + 2 * math.pi * 1000), f(th), atol=1e-9 * scale)
    assert Fourier.from_dict(f.to_dict()).coef.tolist() == f.coef.tolist()


def test_harmonic_columns_by_recurrence_match_the_closed_form(rng):
    """The integer orders' columns come from the angle-addition recurrence: unsorted orders with a repeat and
    order 0, up to 756 (36N42P's third cogging multiple), on multi-turn angles, against cos/sin of ``h θ`` in
    extended precision on the same reduced angle. Each step of the recurrence adds about one rounding, and a step's
    own phase ``d θ`` is rounded as the closed form's ``h θ`` is: the error is bounded by the number of orders
    times a few ulp plus the spacing of floats at ``2π h_max``; a non-integer order is taken by the closed form."""
    orders = np.array([252, 0, 1, 756, 36, 42, 504, 2, 36, 84, 168, 3, 14, 700])
    theta = rng.uniform(-1e3, 1e3, 5000)
    cols = harmonic_columns(theta, orders)
    red = np.mod(theta, 2 * math.pi).astype(np.longdouble)
    ph = red[:, None] * orders[None, :].astype(np.longdouble)
    tol = 8 * orders.size * np.finfo(float).eps + np.spacing(2 * math.pi * orders.max())
    np.testing.assert_allclose(cols[:, : orders.size], np.cos(ph).astype(float), rtol=0, atol=tol)
    np.testing.assert_allclose(cols[:, orders.size:], np.sin(ph).astype(float), rtol=0, atol=tol)
    assert np.all(cols[:, orders.size + 1] == 0.0)  # the sine of order 0
    half = harmonic_columns(theta, [0.5, 3])
    np.testing.assert_allclose(half[:, 0], np.cos(0.5 * np.mod(theta, 2 * math.pi)), rtol=0, atol=1e-15)
    assert harmonic_columns(theta, []).shape == (theta.size, 0)


def test_twin_harmonics_by_repeated_squaring_match_the_closed_form(rng):
    """The twin's plant and law read their maps through ``e^{i h θ}`` built from the binary digits of ``h``
    (pgcomm.rotary.twin._harmonics): against cos/sin of ``h θ`` in extended precision, on multi-turn angles, for the
    zoo's orders up to 756 and an order 0 (the padding). Each squaring doubles the phase's error, as the rounding
    of ``h θ`` scales with ``h``: the bound is a few ulp times the highest order; and a negative or fractional order
    is refused, not read as its bits."""
    from pgcomm.rotary.twin import _harmonics, _order_bits

    orders = np.array([0, 1, 2, 36, 42, 84, 252, 504, 756, 0])
    bits = _order_bits(orders)
    assert bits.shape == (orders.size, 10)
    np.testing.assert_array_equal(bits @ 2.0 ** np.arange(10), orders)
    tol = 16 * orders.max() * np.finfo(float).eps
    for theta in rng.uniform(-1e3, 1e3, 20):
        c, s = (np.asarray(v) for v in _harmonics(bits, theta))
        red = np.longdouble(np.mod(theta, 2 * math.pi))
        np.testing.assert_allclose(c, np.cos(red * orders).astype(float), rtol=0, atol=tol)
        np.testing.assert_allclose(s, np.sin(red * orders).astype(float), rtol=0, atol=tol)
    for bad in ([1, -2], [0.5]):
        with pytest.raises(ValueError, match="non-negative integers"):
            _order_bits(np.array(bad))


def test_table_is_the_compensating_current(rng):
    m = _model(rng)
    n = 1024
    th = 2 * math.pi * np.arange(n) / n
    fwd, rev, avg = m.table(n, +1), m.table(n, -1), m.table(n)
    np.testing.assert_allclose(fwd, (-m.cogging(th) + m.direction(th)) / m.gain(th), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(rev, (-m.cogging(th) - m.direction(th)) / m.gain(th), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(avg, 0.5 * (fwd + rev), rtol=1e-12, atol=1e-14)
    # at zero demand the compensated motor produces no torque: gain * iq + c - d s = 0
    np.testing.assert_allclose(m.gain(th) * fwd + m.cogging(th) - m.direction(th), 0.0, atol=1e-12)
    assert RotaryModel.from_dict(m.to_dict()).table(64).tolist() == m.table(64).tolist()
    with pytest.raises(ValueError):
        m.table(0)


def test_law_inverts_the_model_and_is_safe(rng):
    m = _model(rng)
    th = rng.uniform(-50, 50, 500)
    u = rng.uniform(-3, 3, 500)
    s = np.sign(rng.normal(size=500))
    iq = iq_command(m, u, th, s)
    delivered = m.gain(th) * iq + m.cogging(th) - m.direction(th) * s
    np.testing.assert_allclose(delivered, u, atol=1e-12 * 3)
    np.testing.assert_allclose(iq_for_torque(m, 0.1 * u, th, s), iq, rtol=1e-12, atol=1e-14)
    bad = iq_command(m, np.array([np.nan, 1.0, np.inf, 1.0]), np.array([0.0, np.nan, 0.0, np.inf]))
    assert np.all(bad == 0.0)
    assert np.max(np.abs(iq_command(m, 100.0 * u, th, s, current_limit=2.0))) <= 2.0
    wild = RotaryModel(7, Fourier.zeros([]), Fourier(np.array([1]), np.array([[-5.0, 0.0]])), Fourier.zeros([]))
    assert np.all(np.isfinite(iq_command(wild, 1.0, np.linspace(0, 7, 100))))
    assert np.max(np.abs(iq_command(wild, 1.0, np.linspace(0, 7, 100)))) <= 1.0 / MIN_GAIN + 1e-12
    no_kt = RotaryModel.zero(7)
    with pytest.raises(ValueError, match="k_t"):
        iq_for_torque(no_kt, 1.0, 0.0)


def _write(tmp_path, text):
    p = tmp_path / "motor.toml"
    p.write_text(text)
    return p


def test_rotary_motor_toml(tmp_path):
    from pgcomm.io.config import load_motor, load_rotary_motor, motor_kind, rotary_motor_to_toml

    m = RotaryMotor(7, 12, 1e-3, k_t=0.1, inertia=2e-4, current_limit=20.0, encoder_counts=65536)
    p = _write(tmp_path, rotary_motor_to_toml(m))
    assert motor_kind(p) == "rotary"
    assert load_rotary_motor(p) == m
    with pytest.raises(ConfigError, match="rotary"):
        load_motor(p)  # linear commands refuse it with one line
    cases = {
        'kind = "rotory"\n': "closest match: 'rotary'",
        'kind = "rotary"\nslots = 12\nsample_time = 0.001\n': "key 'pole_pairs' missing",
        'kind = "rotary"\npole_pairs = 7.5\nslots = 12\nsample_time = 0.001\n': "pole_pairs = 7.5 is a float",
        'kind = "rotary"\npole_pairs = 7\nslots = 13\nsample_time = 0.001\n': "multiple of 3",
        'kind = "rotary"\npole_pairs = 7\nslots = 12\nsample_time = 1\n': "did you give ms",
        'kind = "rotary"\npole_pairs = 7\nslots = 12\nsample_time = 0.001\nk_t = -1\n': "k_t = -1",
        'kind = "rotary"\npole_pairs = 7\nslots = 12\nsample_time = 0.001\ninertai = 1\n': "closest valid key: 'inertia'",
        # each value in its range, the combination beyond what identification screens in reasonable time
        'kind = "rotary"\npole_pairs = 200\nslots = 600\nsample_time = 0.001\n':
            r"slots = 600 with pole_pairs = 200 put the cogging fundamental at LCM\(Q, 2p\) = 1200 per revolution and "
            r"the model's orders up to 3600, beyond the 2048 pgcomm identifies",
        'kind = "rotary"\npole_pairs = 180\nsample_time = 0.001\n':
            r"pole_pairs = 180 puts the torque ripple at order 12p = 2160 .* \(at most pole_pairs = 170\)",
    }
    for text, msg in cases.items():
        with pytest.raises(ConfigError, match=msg) as e:
            load_rotary_motor(_write(tmp_path, text))
        assert "\n" not in str(e.value)
    # the largest combination a torque motor may have within the bound: accepted (3 LCM(54, 48) = 1296)
    assert load_rotary_motor(_write(tmp_path, 'kind = "rotary"\npole_pairs = 24\nslots = 54\nsample_time = 0.001\n'))


def test_hold_angle_is_the_middle_of_the_hold(rng):
    """A current held over ``T`` at constant speed acts on the hold's mean of ``cos(hθ(t))``; the value at
    :func:`hold_angle` differs from that mean by at most ``(hωT)²/24`` (closed form: ``1 − sinc``), the
    value at the sampled angle by about ``hωT/2`` (first order)."""
    from pgcomm.rotary.law import hold_angle

    h, w, T = 54, 7.0, 1e-3  # 54 periods per revolution at 7 rad/s, held 1 ms: ~17 samples per period
    th = rng.uniform(0, 2 * math.pi, 200)
    t = np.linspace(0.0, T, 4001)
    mean = np.trapezoid(np.cos(h * (th[:, None] + w * t)), t, axis=1) / T
    x = h * w * T
    err_mid = np.abs(np.cos(h * hold_angle(th, w, T)) - mean)
    err_start = np.abs(np.cos(h * th) - mean)
    assert np.max(err_mid) <= x**2 / 24 * (1 + 1e-6) + 1e-9
    assert np.max(err_start) >= 0.9 * x / 2
    assert np.isnan(hold_angle(np.nan, w, T)) and hold_angle(1.0, -w, T) == pytest.approx(1.0 - w * T / 2)


def test_twin_evaluates_the_law_at_the_middle_of_the_hold():
    """The oracle (the truth inverted) in the speed loop: read at the middle of the held sample, it leaves far
    less speed ripple than read at the sampled angle (the half-sample lag is what the advance removes)."""
    from pgcomm.rotary.experiment import quick_settings, tracking_references
    from pgcomm.rotary.regression import Orders
    from pgcomm.rotary.twin import LawParams, default_gains, simulate
    from pgcomm.rotary.zoo import draw_rotary

    from dataclasses import replace

    t = replace(draw_rotary(0, 0), control_per_log=1)  # the hold is the log's sample
    a = t.inertia / t.k0
    ref = tracking_references(t.motor, Orders.for_motor(t.motor), quick_settings())["speed"]
    mse = {}
    for adv in (0.0, 0.5):
        law = LawParams(t.model(), None, a, t.viscous / t.k0, 0.0, advance=adv)
        log = simulate(t, ref, law, default_gains(a), seed=3)
        cruise = np.abs(ref.omega) >= 0.999 * np.max(np.abs(ref.omega))
        mse[adv] = float(np.mean((ref.omega - log["omega_true"])[cruise] ** 2))
    # at the evaluation speed the highest cogging order has 16 samples per period: the lag leaves
    # 2 sin(pi/32) ~ 20 % of it, i.e. ~4 % of its power; the advance removes that to second order
    assert mse[0.5] < 0.5 * mse[0.0]


def test_twin_sub_steps_converge_at_second_order():
    """The twin's sub-steps take the angle's torques (cogging, ripple, drag) at each sub-step's middle: the rotor's
    path converges as ``dt²``, halving the sub-step quarters its error (the torques taken at the sub-step's start
    converge as ``dt``, halving halves it). Speed loop at the evaluation speed, noises off, and an encoder of 2⁴⁰
    counts, so that the loop reads the same angle at every sub-step count. The error is each run's largest angle
    difference from a run of 256 sub-steps; the test compares the errors at 4 and 8 sub-steps."""
    from dataclasses import replace

    from pgcomm.rotary.experiment import quick_settings, tracking_references
    from pgcomm.rotary.regression import Orders
    from pgcomm.rotary.twin import LawParams, default_gains, simulate
    from pgcomm.rotary.zoo import draw_rotary

    t = replace(draw_rotary(1, 7), control_per_log=1, current_noise=0.0, torque_noise=0.0, encoder_counts=2**40)
    a = t.inertia / t.k0
    ref = tracking_references(t.motor, Orders.for_motor(t.motor), quick_settings())["speed"]
    law = LawParams.classical(t.motor.pole_pairs)
    run = {n: simulate(t, ref, law, default_gains(a), seed=0, n_sub=n)["theta_true"] for n in (4, 8, 256)}
    err = {n: float(np.max(np.abs(run[n] - run[256]))) for n in (4, 8)}
    assert err[8] > 0.0
    # second order: 4 (3.2 leaves room for the 256-step run's own error and the higher orders); first order gives 2
    assert err[4] / err[8] > 3.2


def test_a_twin_from_an_identified_model_gives_that_model_back():
    """truth_from_model is the inverse of RotaryTruth.model: the zoo truth's own model, with its k0 and offset error,
    gives a twin whose model is the same (to 1e-12 of each map's scale), with the truth's k_t, J, friction; and a
    model without a torque constant or J/k0 is refused in one line."""
    from dataclasses import replace

    from pgcomm.rotary.zoo import draw_rotary, truth_from_model

    t = draw_rotary(1, 3)
    m = t.model()
    back = truth_from_model(m, t.motor, current_noise=t.current_noise, encoder_counts=t.encoder_counts,
                            offset_error=t.offset_error)
    b = back.model()
    for name in ("cogging", "ripple", "direction"):
        x, y = getattr(m, name), getattr(b, name)
        np.testing.assert_array_equal(x.orders, y.orders)
        assert np.max(np.abs(x.coef - y.coef)) <= 1e-12 * float(np.max(np.abs(x.coef)))
    for a, c in ((back.k_t, t.k_t), (back.inertia, t.inertia), (back.coulomb, t.coulomb), (back.viscous, t.viscous)):
        assert abs(a - c) <= 1e-12 * abs(c)
    assert back.current_noise == t.current_noise and back.encoder_counts == t.encoder_counts
    with pytest.raises(ConfigError, match="torque constant"):
        truth_from_model(replace(m, k_t=None), t.motor, current_noise=0.01)
    with pytest.raises(ConfigError, match="J/k0"):
        truth_from_model(replace(m, inertia_ratio=None), t.motor, current_noise=0.01)


def test_a_drive_faster_than_its_log_is_its_fast_twin_sampled():
    """A drive that controls ``K = 4`` times per logged sample (``RotaryTruth.control_per_log``): every column of its
    log is the log of the same drive run with control and log at ``T_s/K`` (the references interpolated the same way,
    a cubic spline through the logged samples), taken every ``K``-th sample. The noises are off, so the two
    formulations differ by float rounding only (tolerance 1e-9 of each column's scale). With the noises on, they are
    drawn per logged sample: the same numbers at every ``K``."""
    from dataclasses import replace

    from scipy.interpolate import CubicSpline

    from pgcomm.rotary.experiment import quick_settings, tracking_references
    from pgcomm.rotary.regression import Orders
    from pgcomm.rotary.twin import SUBSTEPS, LawParams, Reference, default_gains, simulate
    from pgcomm.rotary.zoo import draw_rotary

    k = 4
    noisy = replace(draw_rotary(0, 0), control_per_log=1)
    t = replace(noisy, current_noise=0.0, torque_noise=0.0, winding=replace(noisy.winding, voltage_noise=0.0))
    a = t.inertia / t.k0
    ref = tracking_references(t.motor, Orders.for_motor(t.motor), quick_settings())["position"]
    ts = t.motor.sample_time
    n = ref.n
    fine_t = np.minimum(ts / k * np.arange(n * k), ts * (n - 1))
    up = [CubicSpline(ts * np.arange(n), v)(fine_t) for v in (ref.theta, ref.omega, ref.alpha, np.zeros(n))]
    fine = Reference(up[0], up[1], up[2], ref.mode, up[3])
    law = LawParams(t.model(), None, a, t.viscous / t.k0, 0.0)  # the oracle: the law's path is exercised too
    log = simulate(replace(t, control_per_log=k), ref, law, default_gains(a), seed=1)
    fast = simulate(replace(t, motor=replace(t.motor, sample_time=ts / k)), fine, law, default_gains(a), seed=1,
                    n_sub=max(2, -(-SUBSTEPS // k)))
    for key in ("theta", "velocity", "iq_1", "theta_true", "omega_true", "torque", "demand", "vq_1", "vd_1"):
        scale = float(np.max(np.abs(fast[key])))
        np.testing.assert_allclose(log[key], fast[key][::k], rtol=0, atol=1e-9 * scale, err_msg=key)
    # the noises: per logged sample, the same numbers for every K
    one, four = (simulate(replace(noisy, control_per_log=c), ref, law, default_gains(a), seed=1) for c in (1, k))
    scale = noisy.current_noise
    np.testing.assert_allclose(one["iq_1"] - one["iq_true"], four["iq_1"] - four["iq_true"], rtol=0, atol=1e-9 * scale)
    assert float(np.std(four["iq_1"] - four["iq_true"])) == pytest.approx(scale, rel=0.1)


def test_control_per_log_is_a_positive_integer_and_round_trips():
    import json
    from dataclasses import replace

    from pgcomm.rotary.twin import RotaryTruth
    from pgcomm.rotary.zoo import draw_rotary

    t = replace(draw_rotary(0, 1), control_per_log=1)
    assert "control_per_log" not in t.to_dict()  # truth files of a drive at its log rate are as before
    d8 = replace(t, control_per_log=8).to_dict()
    back = RotaryTruth.from_dict(json.loads(json.dumps(d8)))
    assert back.control_per_log == 8 and json.dumps(back.to_dict()) == json.dumps(d8)
    for bad in (0, -2, 2.5, True):
        with pytest.raises(ValueError, match="control_per_log"):
            replace(t, control_per_log=bad)


def test_a_preview_drive_controls_as_fast_as_the_logs_read():
    """truth_from_identification: a current read smooth ``lag`` samples late makes the preview's drive control
    ``1/(2 lag)`` times per logged sample (at most PREVIEW_MAX_CONTROL_PER_LOG); a held one, once."""
    from pgcomm.rotary.zoo import PREVIEW_MAX_CONTROL_PER_LOG, draw_rotary, truth_from_identification

    t = draw_rotary(0, 2)
    m = t.model()
    base = {"current_noise_A": t.current_noise}
    for timing, k in (({"held": True, "lag": 0.0}, 1), ({"held": False, "lag": 0.25}, 2),
                      ({"held": False, "lag": 0.0631}, 8), ({"held": False, "lag": 0.004}, PREVIEW_MAX_CONTROL_PER_LOG),
                      ({"held": False, "lag": -0.01}, PREVIEW_MAX_CONTROL_PER_LOG), (None, 1)):
        info = dict(base, **({"current_delay": timing} if timing else {}))
        assert truth_from_identification(m, info, t.motor).control_per_log == k


def test_the_zoos_drives_control_at_plausible_rates():
    """Every zoo drive controls at a rate within :data:`~pgcomm.rotary.zoo.CONTROL_RATE_HZ` (to the rounding of whole
    control cycles per logged sample), from a stream of its own: the motor's other draws are those of a drive at its
    log rate, and the truth file keeps the rate. A user's motor description gets one too, and at a log rate above the
    drive's range its drive logs every cycle."""
    from dataclasses import replace

    from pgcomm.rotary.twin import RotaryTruth
    from pgcomm.rotary.zoo import CONTROL_RATE_HZ, default_truth, draw_rotary

    lo, hi = CONTROL_RATE_HZ
    ks = []
    for seed in range(3):
        for i in range(10):
            t = draw_rotary(seed, i)
            ts = t.motor.sample_time
            assert lo * ts - 0.5 <= t.control_per_log <= hi * ts + 0.5
            ks.append(t.control_per_log)
            assert RotaryTruth.from_dict(t.to_dict()).control_per_log == t.control_per_log
    assert len(set(ks)) >= 5  # drawn, not one rate for all
    import numpy as np

    from pgcomm.rotary.zoo import COMBINATIONS, draw_truth

    t = draw_rotary(0, 2)
    alone = draw_truth(np.random.default_rng([0, 2, 0x70]), *COMBINATIONS[2])  # the motor's own stream alone
    assert t.k_t == alone.k_t and t.inertia == alone.inertia
    np.testing.assert_array_equal(t.cogging.coef, alone.cogging.coef)
    m = t.motor
    assert lo * m.sample_time - 0.5 <= default_truth(m).control_per_log <= hi * m.sample_time + 0.5
    assert default_truth(replace(m, sample_time=1 / (2 * hi))).control_per_log == 1


def test_a_motor_description_gives_its_drives_control_rate(tmp_path):
    """``control_rate`` (Hz) in a rotary motor TOML: read, written back, and the twin's drive of that description
    controls ``round(control_rate · sample_time)`` times per logged sample (the preview too, at most its cap); a rate
    below the log rate, or one given in kHz, is refused in one line naming the file and the key."""
    from dataclasses import replace

    from pgcomm.errors import ConfigError
    from pgcomm.io.config import load_rotary_motor, rotary_motor_to_toml
    from pgcomm.rotary.zoo import PREVIEW_MAX_CONTROL_PER_LOG, default_truth, draw_rotary, truth_from_identification

    t = draw_rotary(0, 0)
    m = replace(t.motor, control_rate=6000.0)
    path = tmp_path / "m.toml"
    path.write_text(rotary_motor_to_toml(m))
    back = load_rotary_motor(path)
    assert back == m and back.control_per_log == 6
    assert default_truth(back, seed=3).control_per_log == 6
    assert replace(back, sample_time=5e-4).control_per_log == 3
    info = {"current_noise_A": t.current_noise, "current_delay": {"held": False, "lag": 0.25}}
    assert truth_from_identification(t.model(), info, back).control_per_log == 6  # the description over the lag
    fast = replace(back, control_rate=40000.0)
    assert truth_from_identification(t.model(), info, fast).control_per_log == PREVIEW_MAX_CONTROL_PER_LOG
    assert truth_from_identification(t.model(), info, t.motor).control_per_log == 2  # no rate given: the lag's
    for value, match in (("500.0", "below the log rate"), ("8.0", "did you give kHz")):
        path.write_text(rotary_motor_to_toml(t.motor) + f"control_rate = {value}\n")
        with pytest.raises(ConfigError, match=match) as e:
            load_rotary_motor(path)
        assert str(path) in str(e.value) and "control_rate" in str(e.value) and "\n" not in str(e.value)
