"""A rotor with a known cogging, integrated in closed form steps, sampled where a host would stamp it.

``J/k0 θ̈ = i(t) + c(θ) − b ω`` with a proportional speed loop and a smooth dither in ``i`` (so the current is
smooth between samples), RK4 sub-steps between the sample instants (which may be jittered), noise-free: the
regression's kernel is then the only approximation, and the identified cogging can be held to the truth.
"""

from __future__ import annotations

import math

import numpy as np

#: The truth: ``J/k0`` (A·s²/rad), viscous ``b`` (A·s/rad), cogging orders, amplitudes (A) and phases (rad).
INERTIA_RATIO = 2e-4
VISCOUS = 1e-3
ORDERS = (6, 12, 18)
AMPLITUDES = (0.20, 0.08, 0.03)
PHASES = (0.3, 1.1, 2.0)


def cogging(theta: np.ndarray) -> np.ndarray:
    """The true cogging ``c(θ)`` (A) at ``theta`` (rad), the model's sign (:mod:`pgcomm.rotary.regression`)."""
    th = np.asarray(theta, float)
    return sum(a * np.cos(o * th + p) for o, a, p in zip(ORDERS, AMPLITUDES, PHASES))


def run(seconds: float, sample_time: float = 1e-3, speed: float = 20.0, dither: float = 0.3, jitter: float = 0.0,
        seed: int = 0, sub: int = 2, dither_hz: float = 3.1, report_filter: float = 0.0) -> dict:
    """One log ``{"t", "theta", "iq_1"}``: the speed loop at ``speed`` rad/s (its sign the direction), a
    ``dither_hz`` dither of ``dither`` A, sample steps drawn uniformly in ``sample_time · [1 − jitter, 1 + jitter]``.
    With ``report_filter = τ`` (s) the logged current is the report ``y`` of a first-order low-pass,
    ``τ y' = i − y`` from ``y(0) = i(0)``, integrated with the rotor (a drive's filtered report of a smooth current)."""
    rng = np.random.default_rng(seed)
    kp = 0.05
    terms = list(zip(ORDERS, AMPLITUDES, PHASES))

    def current(t, w):
        return kp * (speed - w) + VISCOUS * w + dither * math.sin(2 * math.pi * dither_hz * t) + 0.05

    def acc(t, th, w):
        return (current(t, w) + sum(a * math.cos(o * th + p) for o, a, p in terms) - VISCOUS * w) / INERTIA_RATIO

    n = int(round(seconds / sample_time))
    steps = sample_time * (rng.uniform(1 - jitter, 1 + jitter, n - 1) if jitter > 0 else np.ones(n - 1))
    t = np.concatenate([[0.0], np.cumsum(steps)])
    th, w, rep = np.empty(n), np.empty(n), np.empty(n)
    x, v = 0.0, float(speed)
    y = current(0.0, v)
    th[0], w[0], rep[0] = x, v, y

    def dy(t, w, y):
        return (current(t, w) - y) / report_filter if report_filter > 0 else 0.0

    for k in range(n - 1):
        h, tk = steps[k] / sub, t[k]
        for _ in range(sub):
            # RK4 on (θ, ω, y) written out: θ' = ω, ω' = acc, y' = dy
            v1, a1, y1 = v, acc(tk, x, v), dy(tk, v, y)
            v2 = v + h / 2 * a1
            a2, y2 = acc(tk + h / 2, x + h / 2 * v1, v2), dy(tk + h / 2, v2, y + h / 2 * y1)
            v3 = v + h / 2 * a2
            a3, y3 = acc(tk + h / 2, x + h / 2 * v2, v3), dy(tk + h / 2, v3, y + h / 2 * y2)
            v4 = v + h * a3
            a4, y4 = acc(tk + h, x + h * v3, v4), dy(tk + h, v4, y + h * y3)
            x, v = x + h / 6 * (v1 + 2 * v2 + 2 * v3 + v4), v + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
            y = y + h / 6 * (y1 + 2 * y2 + 2 * y3 + y4)
            tk += h
        th[k + 1], w[k + 1], rep[k + 1] = x, v, y
    iq = rep if report_filter > 0 else np.array([current(a, b) for a, b in zip(t, w)])
    return {"t": t, "theta": th, "iq_1": iq}


def report_filtered(log: dict, tau: float) -> dict:
    """``log`` with its current through a first-order low-pass of time constant ``tau`` (s), exact for a current
    linear between samples (a drive's filtered report)."""
    t, i = log["t"], log["iq_1"]
    y = np.empty_like(i)
    y[0] = i[0]
    for k in range(i.size - 1):
        h = t[k + 1] - t[k]
        e = math.exp(-h / tau)
        slope = (i[k + 1] - i[k]) / h
        # y' = (i - y)/τ with i linear over the step: y follows i - τ slope, plus a decaying transient
        y[k + 1] = (i[k + 1] - tau * slope) + (y[k] - (i[k] - tau * slope)) * e
    return {**log, "iq_1": y}
