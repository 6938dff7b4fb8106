"""Log evaluation: commutation-error and tracking MSE, model error, training-range warning, figures."""

from __future__ import annotations

import numpy as np
import pytest

from pgcomm.errors import DataError
from pgcomm.plots import plot_logs, plot_model_error
from pgcomm.evaluation import (
    evaluate_log,
    evaluate_logs,
    evaluation_results,
    format_table,
    log_names,
)
from pgcomm.metrics import lowpass
from test_excitation import MOTOR, TS, synthetic_log, truth_model

OFFSET = (0.5, -0.2, 0.01)  # N, N, N·m: a constant force the truth model does not know


def test_commutation_and_tracking_mse_against_direct_formulas():
    log = synthetic_log(0, -np.pi / 4)
    ev = evaluate_log(log)
    err = log.force() - np.stack([log["Fy_star"], log["Fx_star"], log["Tz_star"]], -1)
    # first-order ZOH low-pass written out: x_f[k] = a x_f[k-1] + (1 - a) x[k-1]
    a = np.exp(-2 * np.pi * 50.0 * TS)
    filt = np.zeros_like(err)
    for k in range(1, len(err)):
        filt[k] = a * filt[k - 1] + (1 - a) * err[k - 1]
    for q, d in enumerate("yxz"):
        assert ev.commutation_mse[d]["unfiltered"] == pytest.approx(np.mean(err[:, q] ** 2), rel=1e-12)
        assert ev.commutation_mse[d]["filtered"] == pytest.approx(np.mean(filt[:, q] ** 2), rel=1e-9)
    assert ev.tracking_mse == pytest.approx(np.mean((log["r"] - log["y"]) ** 2), rel=1e-12)
    assert ev.samples == 6001 and ev.label == "Zm_coilset1" and ev.notes == ()
    assert ev.model_mse is None and "model_mse" not in ev.to_dict()


def test_missing_desired_force_names_file_and_columns():
    log = synthetic_log(0, np.pi / 4, star=False, name="rig/run3.csv")
    with pytest.raises(DataError, match=r"^rig/run3.csv: column\(s\) Fy_star, Fx_star, Tz_star missing: "):
        evaluate_log(log)
    partial = synthetic_log(0, np.pi / 4, name="run4.csv")
    del partial.columns["Tz_star"]
    with pytest.raises(DataError, match=r"^run4.csv: column\(s\) Tz_star missing"):
        evaluate_logs([synthetic_log(0, -np.pi / 4), partial])


def test_without_reference_tracking_is_skipped_and_said():
    ev = evaluate_log(synthetic_log(1, np.pi / 4, reference=False))
    assert ev.tracking_mse is None and ev.e is None
    assert ev.notes == ("no column r (reference): tracking error skipped",)
    res = evaluation_results([ev])
    assert res["logs"][0]["tracking_mse"] is None
    assert res["notes"] == ["Zp_coilset2.csv: no column r (reference): tracking error skipped"]
    assert "-" in format_table([ev]).splitlines()[1]


def test_model_error_is_the_unmodelled_force():
    # forces = truth model + a constant offset: the model error is exactly that offset
    logs = [synthetic_log(l, d, force_offset=OFFSET) for l in (0, 2) for d in (-np.pi / 4, np.pi / 4)]
    evs = evaluate_logs(logs, model=truth_model(), motor=MOTOR)
    for ev in evs:
        np.testing.assert_allclose(ev.model_error, np.broadcast_to(OFFSET, ev.model_error.shape), rtol=0, atol=1e-12)
        for q, d in enumerate("yxz"):
            assert ev.model_mse[d]["unfiltered"] == pytest.approx(OFFSET[q] ** 2, rel=1e-9)
            filt = lowpass(np.full(ev.samples, OFFSET[q]), TS)
            assert ev.model_mse[d]["filtered"] == pytest.approx(np.mean(filt ** 2), rel=1e-9)
        assert ev.currents == "logged" and ev.range_warning is None


def test_drive_input_logs_use_the_drive_to_get_currents():
    ev_i = evaluate_log(synthetic_log(1, np.pi / 4, force_offset=OFFSET), model=truth_model(), motor=MOTOR)
    ev_d = evaluate_log(synthetic_log(1, np.pi / 4, force_offset=OFFSET, drive_inputs=True), model=truth_model(),
                        motor=MOTOR)
    assert ev_d.currents == "from drive inputs"
    np.testing.assert_allclose(ev_d.model_error, ev_i.model_error, rtol=0, atol=1e-9)


def test_positions_outside_the_training_range_are_warned():
    model = truth_model()
    narrow = type(model).from_coil_sets([model.coil_set(l).with_range(-0.05, 0.08) for l in range(3)])
    log = synthetic_log(0, np.pi / 4)
    ev = evaluate_log(log, model=narrow, motor=MOTOR)
    n_out = int(np.sum((log["y"] < -0.05) | (log["y"] > 0.08)))
    assert ev.range_warning.startswith(f"{n_out} of 6001 positions")
    assert "outside the training range [-0.05, 0.08] m" in ev.range_warning
    res = evaluation_results([ev], model="m.json")
    assert res["model"] == "m.json" and res["logs"][0]["range_warning"] == ev.range_warning
    assert res["warnings"] == [f"Zp_coilset1.csv: {ev.range_warning}"]


def test_model_with_other_coil_sets_is_refused():
    log = synthetic_log(0, np.pi / 4)
    for j in (2, 3):
        del log.columns[f"ia_{j}"], log.columns[f"ib_{j}"]
    with pytest.raises(DataError, match=r"Zp_coilset1.csv: 1 coil sets in the log, the model has 3"):
        evaluate_log(log, model=truth_model(), motor=MOTOR)


def test_results_keys_and_figures_with_logs_of_different_lengths():
    import matplotlib.pyplot as plt

    logs = [synthetic_log(0, -np.pi / 4), synthetic_log(1, np.pi / 4, n=3001, reference=False)]
    evs = evaluate_logs(logs, lowpass_hz=20.0, model=truth_model(), motor=MOTOR)
    res = evaluation_results(evs, 20.0)
    assert res["lowpass_hz"] == 20.0
    assert [r["samples"] for r in res["logs"]] == [6001, 3001]
    assert set(res["logs"][0]["commutation_mse"]["x"]) == {"filtered", "unfiltered"}
    assert res["logs"][1]["model_mse"]["z"]["unfiltered"] == pytest.approx(0.0, abs=1e-20)
    fig = plot_logs(evs)
    axes = fig.get_axes()
    assert len(axes) == 5
    assert [ln.get_label() for ln in axes[1].get_lines()] == ["Zm_coilset1", "Zp_coilset2"]
    assert len(axes[4].get_lines()) == 1  # the second log has no r: no tracking line
    assert len(axes[1].get_lines()[1].get_xdata()) == 3001
    plt.close(fig)
    fig = plot_model_error(evs)
    assert len(fig.get_axes()) == 3 and len(fig.get_axes()[0].get_lines()) == 2
    plt.close(fig)
    table = format_table(evs)
    assert "model error" in table and table.count("Zm_coilset1") == 2


def test_log_without_currents_needs_a_motor_for_the_model():
    log = synthetic_log(0, np.pi / 4, drive_inputs=True)
    with pytest.raises(DataError, match="no currents ia_l, ib_l"):
        evaluate_log(log, model=truth_model())


# ------------------------------------------------------------------ names of logs and logs without F*


@pytest.mark.parametrize("files, names", [
    (["a/log.csv", "b/log.csv"], ["a/log", "b/log"]),
    (["x/a/log.csv", "y/a/log.csv", "y/b/run.csv"], ["x/a/log", "y/a/log", "run"]),
    (["rig/run1.csv", "rig/run2.parquet"], ["run1", "run2"]),
    (["rig/log.csv", "rig/log.parquet"], ["log.csv", "log.parquet"]),
    (["a/log.csv", "a/log.csv"], ["log", "log (2)"]),
])
def test_log_names_are_the_shortest_distinct_path_ends(files, names):
    assert log_names(files) == names


def test_logs_of_the_same_file_name_in_different_folders_keep_apart():
    import matplotlib.pyplot as plt

    logs = [synthetic_log(0, -np.pi / 4, name="day1/log.csv"), synthetic_log(1, np.pi / 4, name="day2/log.csv")]
    evs = evaluate_logs(logs)
    assert [ev.label for ev in evs] == ["day1/log", "day2/log"]
    res = evaluation_results(evs)
    assert [lg["name"] for lg in res["logs"]] == ["day1/log", "day2/log"]
    assert [lg["file"] for lg in res["logs"]] == ["day1/log.csv", "day2/log.csv"]
    fig = plot_logs(evs)
    assert [ln.get_label() for ln in fig.get_axes()[1].get_lines()] == ["day1/log", "day2/log"]
    plt.close(fig)
    rows = format_table(evs).splitlines()[1:]
    assert rows[0].startswith("day1/log ") and rows[1].startswith("day2/log ")


def test_long_names_are_not_cut_in_the_table():
    # two names that differ only beyond 24 characters from their start
    logs = [synthetic_log(0, -np.pi / 4, name=f"rig/a_very_long_experiment_name_{k}.csv") for k in (1, 2)]
    rows = format_table(evaluate_logs(logs)).splitlines()[1:]
    assert rows[0].split()[0] == "a_very_long_experiment_name_1"
    assert rows[1].split()[0] == "a_very_long_experiment_name_2"


def test_model_error_of_logs_without_desired_force():
    """With a model, a log without F* is evaluated: its model error is the unmodelled force, its commutation
    error is skipped (every entry None) and a note says why; a log with F* in the same call is unchanged."""
    import matplotlib.pyplot as plt

    with_star = synthetic_log(0, -np.pi / 4, force_offset=OFFSET)
    without = synthetic_log(1, np.pi / 4, force_offset=OFFSET, star=False)
    evs = evaluate_logs([with_star, without], model=truth_model(), motor=MOTOR)
    assert evs[0].commutation_mse == evaluate_log(with_star).commutation_mse
    ev = evs[1]
    assert ev.commutation_error is None
    assert all(ev.commutation_mse[d] == {"filtered": None, "unfiltered": None} for d in "yxz")
    for q, d in enumerate("yxz"):
        assert ev.model_mse[d]["unfiltered"] == pytest.approx(OFFSET[q] ** 2, rel=1e-9)
    assert ev.tracking_mse == pytest.approx(np.mean((without["r"] - without["y"]) ** 2), rel=1e-12)
    assert any("(Fy_star, Fx_star, Tz_star missing): commutation error F - F* skipped" in n for n in ev.notes)
    res = evaluation_results(evs)
    assert res["logs"][1]["commutation_mse"]["y"]["filtered"] is None
    assert any(n.startswith("Zp_coilset2.csv: no desired force") for n in res["notes"])
    table = format_table(evs)
    assert "n/a" in table.splitlines()[2] and "commutation error skipped" in table
    fig = plot_logs(evs)  # the log without F* has a tracking line but no commutation-error line
    axes = fig.get_axes()
    assert [ln.get_label() for ln in axes[1].get_lines()] == ["Zm_coilset1"]
    assert len(axes[4].get_lines()) == 2
    plt.close(fig)
    # without a model there is nothing to compute for such a log: refused before any work
    with pytest.raises(DataError, match=r"^Zp_coilset2.csv: column\(s\) Fy_star, Fx_star, Tz_star missing: .*--model"):
        evaluate_logs([with_star, without])


def test_inputs_a_model_needs_are_checked_before_any_log_is_evaluated(monkeypatch):
    import pgcomm.evaluation as evaluation

    calls = []
    monkeypatch.setattr(evaluation, "RunningMse", lambda *a, **k: calls.append(1))
    good = synthetic_log(0, -np.pi / 4)
    no_currents = synthetic_log(1, np.pi / 4, drive_inputs=True)
    with pytest.raises(DataError, match=r"^Zp_coilset2.csv: no currents ia_l, ib_l; converting drive inputs needs"):
        evaluate_logs([good, no_currents], model=truth_model())
    assert calls == []


def test_a_long_log_is_evaluated_block_by_block_as_whole(monkeypatch):
    """Blocks of 1024 rows (six, the last one short) against the whole-log formulas: the commutation error and its
    MSEs (the low-pass's state carried across blocks), and a PGNN with a direction term evaluated on the whole log
    at once (its velocity from the whole log), currents logged and converted from drive inputs."""
    import jax

    import pgcomm.evaluation as evaluation
    from pgcomm.data import log_currents, velocity_from_positions
    from pgcomm.metrics import commutation_mse
    from pgcomm.models import CoilSetModel, CombinedModel, physics_from_ideal

    rng = np.random.default_rng(5)
    sets = []
    for l in range(MOTOR.n_coil_sets):
        a, b = physics_from_ideal(MOTOR.pole_pitch, 61.0 + l, -0.54, 0.05, MOTOR.lever_arms[l])
        m = CoilSetModel.init(jax.random.PRNGKey(l), CoilSetModel.physics(a, b, MOTOR.pole_pitch, 0.0, 0.1, -0.1, 0.1),
                              (2,), (16,), "tanh", direction=True)
        leaves, tree = jax.tree_util.tree_flatten(m)
        sets.append(jax.tree_util.tree_unflatten(tree, [np.asarray(x) + rng.normal(size=np.shape(x)) for x in leaves]))
    model = CombinedModel.from_coil_sets(sets)
    assert model.has_direction
    monkeypatch.setattr(evaluation, "BLOCK_ROWS", 1024)
    for log in (synthetic_log(1, np.pi / 4, force_offset=OFFSET), synthetic_log(2, -np.pi / 4, drive_inputs=True)):
        ev = evaluate_log(log, lowpass_hz=20.0, model=model, motor=MOTOR)
        f, f_star = log.force(), log.desired_force()
        f_hat = np.asarray(model.force(log["y"], log_currents(log, MOTOR), velocity_from_positions(log["y"], TS)))
        scale = np.abs(f).max(axis=0)
        np.testing.assert_allclose(ev.commutation_error, f - f_star, rtol=0, atol=1e-14 * scale.max())
        np.testing.assert_allclose(ev.model_error / scale, (f - f_hat) / scale, rtol=0, atol=1e-12)
        for got, want in ((ev.commutation_mse, commutation_mse(f, f_star, TS, 20.0)),
                          (ev.model_mse, commutation_mse(f, f_hat, TS, 20.0))):
            for d in "yxz":
                for k in ("filtered", "unfiltered"):
                    assert got[d][k] == pytest.approx(want[d][k], rel=1e-10), (d, k)
