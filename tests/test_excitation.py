"""Excitation report (paper's Remark on persistently exciting data): per-bin criteria, messages, figure.

Synthetic logs (NumPy, no simulation): the drive of the twin's nominal motor makes the
currents of one coil set from ``(Fy*, Δ)`` while the position sweeps the stroke; the
measured force is the ideal model's with the twin's true ``k``, ``ζ``. The report is
checked against known answers (gaps, a single Δ, a single force magnitude, a missing coil
set) and against ``identify.check_excitation`` bin by bin.
Data sets generated on the twin are checked in ``test_log_roundtrip.py`` (which makes them anyway).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from pgcomm.errors import DataError
from pgcomm.excitation import excitation_report, group_logs
from pgcomm.plots import plot_coverage
from pgcomm.data import CoilSetData
from pgcomm.motor import Motor
from pgcomm.excitation import check_excitation
from pgcomm.io.logs import Log
from pgcomm.models import physics_from_ideal
from pgcomm.twin import TwinParams

MOTOR = TwinParams().motor()
TWIN_K, TWIN_ZETA = TwinParams().k, TwinParams().zeta
TS = 1e-3
EDGES = np.linspace(-0.1, 0.1, 21)  # the report's default bins over the stroke [-0.1, 0.1] m


def synthetic_log(coil_set: int, delta: float, *, n: int = 6001, fy=None, gap=None, star: bool = True,
                  reference: bool = True, drive_inputs: bool = False, name: str | None = None,
                  force_offset=(0.0, 0.0, 0.0)) -> Log:
    """One data set ``Z^l`` with coil set ``coil_set`` (0-based) active at phase offset ``delta`` (rad).

    The position sweeps ``[-0.1, 0.1]`` m three times (ends included for ``n = 6k + 1``);
    ``Fy*`` (N) varies in magnitude and sign unless ``fy`` gives it; ``gap=(a, b)`` drops the
    samples with ``a <= y < b`` (t stays uniform). The drive makes the currents with the
    motor's ``k̂``, ``ζ̂`` (eq. Commutation_Solution_With_PhaseOffset, written out here in
    NumPy); the measured force is the ideal model's (``A cos + B sin``, :func:`physics_from_ideal`)
    plus ``force_offset`` (N, N, N·m).
    """
    t = np.arange(n) * TS
    y = -0.1 + 0.2 * 0.5 * (1.0 - np.cos(2 * np.pi * 3 * np.arange(n) / (n - 1)))
    fy = 20.0 + 15.0 * np.sin(2 * np.pi * 7.3 * t / t[-1]) if fy is None else np.broadcast_to(fy, t.shape)
    if gap is not None:
        keep = ~((y >= gap[0]) & (y < gap[1]))
        y, fy, n = y[keep], fy[keep], int(keep.sum())
        t = np.arange(n) * TS
    L = MOTOR.n_coil_sets
    eta = 2 * np.pi * y / MOTOR.pole_pitch + MOTOR.zeta[coil_set] + delta
    i_l = np.stack([np.sin(eta), np.sin(eta + 2 * np.pi / 3)], -1) * (fy / MOTOR.k[coil_set])[:, None]
    theta = 2 * np.pi * y / MOTOR.pole_pitch
    A, B = physics_from_ideal(MOTOR.pole_pitch, TWIN_K[coil_set], TWIN_ZETA[coil_set], MOTOR.mu,
                              MOTOR.lever_arms[coil_set])
    gain = A * np.cos(theta)[:, None, None] + B * np.sin(theta)[:, None, None]
    f = np.einsum("nqj,nj->nq", gain, i_l) + np.asarray(force_offset)
    cols = {"t": t, "y": y, "Fy": f[:, 0], "Fx": f[:, 1], "Tz": f[:, 2]}
    zero = np.zeros(n)
    for j in range(L):
        on = j == coil_set
        if drive_inputs:
            cols[f"Fy_ref_{j + 1}"], cols[f"delta_{j + 1}"] = (fy, np.full(n, delta)) if on else (zero, zero)
        else:
            cols[f"ia_{j + 1}"], cols[f"ib_{j + 1}"] = (i_l[:, 0], i_l[:, 1]) if on else (zero, zero)
    if star:
        cols.update(Fy_star=np.asarray(fy, float).copy(), Fx_star=zero, Tz_star=zero)
    if reference:
        cols["r"] = y + 1e-6 * np.sin(2 * np.pi * 5 * t)
    tag = "m" if delta < 0 else "p"
    return Log(cols, TS, name or f"Z{tag}_coilset{coil_set + 1}.csv")


def truth_model():
    """The combined physics model that generated the synthetic forces (true k, ζ of the twin)."""
    from pgcomm.models import CoilSetModel, CombinedModel

    return CombinedModel.from_coil_sets([
        CoilSetModel.physics(*physics_from_ideal(MOTOR.pole_pitch, TWIN_K[l], TWIN_ZETA[l], MOTOR.mu,
                                                 MOTOR.lever_arms[l]), MOTOR.pole_pitch, y_min=-0.1, y_max=0.1)
        for l in range(MOTOR.n_coil_sets)])


def synthetic_logs(deltas=(-np.pi / 4, np.pi / 4), **kw) -> list[Log]:
    """Data sets ``Z_{1,2}^l`` for every coil set (one log per coil set and Δ)."""
    return [synthetic_log(l, d, **kw) for l in range(MOTOR.n_coil_sets) for d in deltas]


# ------------------------------------------------------------------------------------ known answers


def test_two_deltas_full_stroke_pass():
    rep = excitation_report(synthetic_logs(), MOTOR)
    assert rep.ok and rep.problems == []
    assert rep.y_range == pytest.approx((-0.1, 0.1), abs=1e-12)
    for cs in rep.coil_sets:
        assert cs.ok and cs.identify_check == ()
        b = cs.bins
        assert int(b.samples.sum()) == cs.samples == 12002
        # half the samples with current at -π/4, half at +π/4 (folded Δ against ζ̂)
        assert b.delta_negative.sum() == pytest.approx(b.delta_positive.sum(), rel=0.02)
        assert b.delta_zero.sum() == 0
        assert np.all(b.angle_spread > 1.4)  # π/2 between the two directions
    d = rep.to_dict()
    assert d["ok"] and [c["ok"] for c in d["coil_sets"]] == [True] * 3


def test_single_delta_is_flagged_per_coil_set():
    logs = synthetic_logs()[:2] + [synthetic_log(l, np.pi / 4) for l in (1, 2)]
    rep = excitation_report(logs, MOTOR)
    assert not rep.ok
    assert [cs.ok for cs in rep.coil_sets] == [True, False, False]
    (msg,) = rep.coil_sets[1].problems
    assert msg == ("coil set 2: a single current direction (one ratio ia:ib, Delta = +0.785 rad) for "
                   "y in [-0.100, 0.100] m; repeat the experiment with the opposite sign of Delta")
    assert rep.coil_sets[1].bins.delta_negative.sum() == 0
    assert rep.coil_sets[1].identify_check  # identification would refuse too


def test_negative_force_with_delta_is_the_same_direction():
    # Fy* < 0 at Δ = π/4 gives the current direction of Δ = π/4 - π: still ONE ratio ia:ib
    log = synthetic_log(0, np.pi / 4, fy=np.where(np.arange(6001) % 2 == 0, -25.0, 25.0))
    cs = excitation_report([log, *synthetic_logs()[2:]], MOTOR).coil_sets[0]
    assert cs.problems[0].startswith("coil set 1: a single current direction")
    assert np.nanmax(cs.bins.angle_spread) < 1e-9


def test_position_gap_is_named():
    gap = (EDGES[12], EDGES[14])  # [0.02, 0.04) m
    logs = [synthetic_log(l, d, gap=gap if l == 1 else None) for l in range(3) for d in (-np.pi / 4, np.pi / 4)]
    rep = excitation_report(logs, MOTOR)
    assert [cs.ok for cs in rep.coil_sets] == [True, False, True]
    assert rep.coil_sets[1].problems == ("coil set 2: no samples for y in [0.020, 0.040] m",)
    assert list(rep.coil_sets[1].bins.problem[12:14]) == ["gap", "gap"]
    assert rep.coil_sets[1].bins.samples[12:14].tolist() == [0, 0]


def test_sparse_bins_and_range_beyond_the_data():
    rep = excitation_report(synthetic_logs(), MOTOR, y_range=(-0.13, 0.1), n_bins=10)
    for cs in rep.coil_sets:
        assert cs.problems == (f"coil set {cs.coil_set + 1}: no samples for y in [-0.130, -0.107] m",)
        assert cs.identify_check == ()  # on its own range identification accepts the data
    rep = excitation_report(synthetic_logs(n=300), MOTOR)  # 600 samples per coil set in 20 bins: ends dense only
    assert "too few samples" in rep.coil_sets[0].problems[0] and "need 20" in rep.coil_sets[0].problems[0]


def test_single_force_magnitude_is_flagged():
    # two Δ with one |Fy*| each: the currents of a bin are two points, whose affine span is a line
    logs = [synthetic_log(l, d, fy=25.0) for l in range(3) for d in (-np.pi / 4, np.pi / 4)]
    rep = excitation_report(logs, MOTOR)
    for cs in rep.coil_sets:
        assert cs.problems == (f"coil set {cs.coil_set + 1}: a single force magnitude per current direction for "
                               "y in [-0.100, 0.100] m; move at several velocities and in both directions "
                               "(different Fy*)",)
        assert np.all(cs.bins.magnitude_spread < 1e-6)
        # identify.check_excitation refuses these data too (identification would fail on them)
        assert cs.identify_check == ("y ∈ [-0.1, 0.1] m: a single force magnitude",)
    # the same data with the force sign alternating excite the model: 4 points, not on one line
    fy = np.where(np.arange(6001) % 3 == 0, -25.0, 25.0)
    rep = excitation_report([synthetic_log(l, d, fy=fy) for l in range(3) for d in (-np.pi / 4, np.pi / 4)], MOTOR)
    assert rep.ok


def test_missing_coil_set_and_no_current():
    rep = excitation_report(synthetic_logs()[:4], MOTOR)
    assert rep.coil_sets[2].bins is None and rep.coil_sets[2].samples == 0
    assert rep.coil_sets[2].problems == ("coil set 3: no log with this coil set active (every coil set needs its own "
                                         "experiments Z_1, Z_2)",)
    assert rep.coil_sets[2].to_dict()["ok"] is False
    # current switched off over part of the stroke: samples there carry no current
    fy = 20.0 + 15.0 * np.sin(np.linspace(0, 40, 6001))
    y = -0.1 + 0.2 * 0.5 * (1.0 - np.cos(2 * np.pi * 3 * np.linspace(0, 1, 6001)))
    fy = np.where((y >= EDGES[0]) & (y < EDGES[2]), 0.0, fy)
    logs = [synthetic_log(0, d, fy=fy) for d in (-np.pi / 4, np.pi / 4)] + synthetic_logs()[2:]
    problems = excitation_report(logs, MOTOR).coil_sets[0].problems
    assert problems == ("coil set 1: no current for y in [-0.100, -0.080] m",)


def test_drive_input_logs_give_the_same_report():
    a = excitation_report(synthetic_logs(), MOTOR)
    b = excitation_report(synthetic_logs(drive_inputs=True), MOTOR)
    for ca, cb in zip(a.coil_sets, b.coil_sets):
        assert ca.problems == cb.problems
        np.testing.assert_array_equal(ca.bins.samples, cb.bins.samples)
        np.testing.assert_array_equal(ca.bins.delta_positive, cb.bins.delta_positive)


def test_logs_the_motor_does_not_describe_are_refused():
    two = MOTOR.__class__(pole_pitch=MOTOR.pole_pitch, lever_arms=MOTOR.lever_arms[:2], k=67.0, zeta=-0.52)
    with pytest.raises(DataError, match=r"Zm_coilset1.csv: 3 coil sets in the log, the motor has 2"):
        group_logs(synthetic_logs(), two)
    both = synthetic_logs()[0]
    both.columns["ia_2"] = both.columns["ia_1"].copy()
    with pytest.raises(DataError, match=r"Zm_coilset1.csv: coil sets 1, 2 all carry current"):
        excitation_report([both], MOTOR)


# ------------------------------------------------------------------ agreement with identify's check

_KIND = {"no data (gap)": "gap", "no current": "no current", "one ratio ia:ib (a single Δ)": "single direction",
         "a single force magnitude": "single magnitude"}


def _runs_of_check(messages):
    out = []
    for m in messages:
        lo, hi, kind = re.fullmatch(r"y ∈ \[(\S+), (\S+)\] m: (.+)", m).groups()
        out.append((float(lo), float(hi), _KIND[kind]))
    return out


def _runs_of_bins(bins):
    out, prev = [], None
    for b, kind in enumerate(bins.problem):
        if kind is not None and kind == prev:
            out[-1] = (out[-1][0], float(bins.edges[b + 1]), kind)
        elif kind is not None:
            out.append((float(bins.edges[b]), float(bins.edges[b + 1]), kind))
        prev = kind
    return out


@pytest.mark.parametrize("case", ["good", "single delta", "gap", "sparse", "single delta and magnitude"])
def test_bins_agree_with_identify_check_excitation(case):
    """Where both judge alike (all but the force-magnitude test), the bins are those of check_excitation."""
    kw = {"good": {}, "single delta": {"deltas": (np.pi / 4,)}, "gap": {"gap": (-0.013, 0.041)},
          "sparse": {"n": 200}, "single delta and magnitude": {"deltas": (-np.pi / 4,), "fy": 30.0}}[case]
    deltas = kw.pop("deltas", (-np.pi / 4, np.pi / 4))
    logs = [synthetic_log(0, d, **kw) for d in deltas]
    data = CoilSetData(np.concatenate([lg["y"] for lg in logs]),
                       np.concatenate([np.stack([lg["ia_1"], lg["ib_1"]], -1) for lg in logs]),
                       np.concatenate([lg.force() for lg in logs]))
    cs = excitation_report(logs + synthetic_logs()[2:], MOTOR, y_range=(data.y.min(), data.y.max())).coil_sets[0]
    ours = _runs_of_bins(cs.bins)
    theirs = _runs_of_check(check_excitation(data, MOTOR.pole_pitch))
    assert len(ours) == len(theirs) and (case == "good") == (not ours)
    for (a0, a1, ak), (b0, b1, bk) in zip(ours, theirs):
        assert ak == bk
        assert a0 == pytest.approx(b0, rel=1e-3) and a1 == pytest.approx(b1, rel=1e-3)


# ------------------------------------------------------------------------------------------ figure


def test_coverage_figure_has_a_panel_per_coil_set():
    import matplotlib.pyplot as plt

    gap = (EDGES[12], EDGES[14])
    logs = [synthetic_log(l, d, gap=gap if l == 1 else None) for l in range(2) for d in (-np.pi / 4, np.pi / 4)]
    fig = plot_coverage(excitation_report(logs, MOTOR))
    axes = fig.get_axes()
    assert len(axes) == 3
    assert axes[1].get_title(loc="left") == "coil set 2: 1 problem(s)"
    assert axes[2].get_title(loc="left") == "coil set 3: 1 problem(s)"
    assert any(t.get_text() == "gap" for t in axes[1].texts)
    plt.close(fig)


def test_two_exact_directions_in_equal_shares_are_two_directions():
    # Δ = ±π/4 exactly, equal sample counts, noise-free currents, one position per bin: the
    # doubled directions nearly cancel; the criterion must still see two directions in every bin.
    # (Zoo motor seed 1 #15 was refused when their mean was exactly 0j; this case does not reach
    # exact cancellation, so it guards the balanced case, not that one input.)
    edges = np.linspace(-0.1, 0.1, 21)
    centres = 0.5 * (edges[1:] + edges[:-1])
    per = 300
    y1 = np.concatenate([[-0.1], np.repeat(centres, per), [0.1]])
    m = y1.size
    fy1 = 20.0 + 15.0 * np.sin(2 * np.pi * 61.3 * np.arange(m) / m)  # ~3 periods per bin
    y, fy = np.tile(y1, 2), np.tile(fy1, 2)
    delta = np.repeat([np.pi / 4, -np.pi / 4], m)
    drive = Motor(pole_pitch=0.03, lever_arms=(0.0,), k=(60.0,), zeta=(-0.5,))
    data = CoilSetData.from_drive_inputs(y, fy, delta, np.zeros((2 * m, 3)), drive, 0, np.repeat([0, 1], m))
    assert check_excitation(data, 0.03) == []
