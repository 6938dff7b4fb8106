"""A rotary motor identified from its drive's logs: what ``pgcomm identify --motor rotary.toml`` computes, as one call.

The Python API of the command line's rotary identification::

    from pgcomm import identify_rotary_logs, read_logs
    from pgcomm.io.config import load_rotary_motor
    from pgcomm.io.logs import ROTARY_REQUIRED

    motor = load_rotary_motor("motor.toml")
    logs = read_logs(["logs/*.csv"], required=ROTARY_REQUIRED, gaps=True, stamps=True)
    found = identify_rotary_logs(logs, motor)           # RotaryIdentifyOptions() : every reading detected
    found.model.table(3600)                              # the compensation table (A) over one revolution
    found.identification.standard_error["cogging"]       # its standard error and verdict
    found.to_dict()                                      # what results.json holds

:func:`identify_from_logs` takes logs already read (:class:`pgcomm.io.logs.Log`: the columns ``t``, ``theta``,
``iq_1`` and, where every log has them, ``vq_1``, ``vd_1``, ``vbus``, ``id_1``, ``torque``), the motor description, one
:class:`pgcomm.settings.RotaryIdentifyOptions`, and optionally a logged standstill sweep and the drive's own static
maps to compare with. It counts the slots where the description lacks them (:mod:`pgcomm.rotary.slots`), identifies
the maps (:func:`pgcomm.rotary.identify.identify`), fits the feedforward read the same way
(:func:`~pgcomm.rotary.identify.fit_mechanics`), puts the model in SI where a torque constant is known (the logged
q-voltage's back-EMF before the motor description's ``k_t``), and compares the sweep's and the static maps' tables
with the model's. The result (:class:`LogsIdentification`) is data; the files are the caller's to write
(``pgcomm identify`` writes ``model.json``, ``compensation.csv``, ``results.json``, the figure of
:func:`pgcomm.plots.plot_rotary_maps` and the report of :mod:`pgcomm.report.rotary`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from pgcomm import __version__
from pgcomm.errors import DataError
from pgcomm.progress import Progress
from pgcomm.rotary.power_ups import offsets_text
from pgcomm.rotary.back_emf import offset_text, voltage_text
from pgcomm.rotary.experiment import AGREEMENT_FACTOR
from pgcomm.rotary.identify import RotaryIdentification, drive_text, fit_mechanics, identify, map_text, orders_text, over_the_angle_text, \
    share_text
from pgcomm.rotary.model import RotaryModel
from pgcomm.rotary.motor import RotaryMotor
from pgcomm.rotary.readings import delay_text, filter_text, pll_text
from pgcomm.rotary.host_clock import host_clock_text
from pgcomm.rotary.slots import count_slots, held_out_text, over_the_angle_count_text
from pgcomm.rotary.standstill import SweepTable, table_from_sweep
from pgcomm.rotary.static_map import combine, compare, text
from pgcomm.rotary.time_lines import lines_text
from pgcomm.settings import RotaryIdentifyOptions

__all__ = ["identify_from_logs", "LogsIdentification", "TABLE_ENTRIES"]

#: Entries of the compensation table over one revolution (ODrive's size; the exports resample).
TABLE_ENTRIES = 3600


@dataclass(frozen=True)
class LogsIdentification:
    """What :func:`identify_from_logs` found; :meth:`to_dict` is ``results.json`` (keys in ``docs/results.md``).

    Attributes:
        motor: the description, with the slot count read from the logs where it had none.
        model: the identified :class:`~pgcomm.rotary.model.RotaryModel` (current units), its ``info`` naming the
            motor, its current limit and the logs.
        identification: :class:`~pgcomm.rotary.identify.RotaryIdentification` (standard errors, verdicts, reading).
        mechanics: the feedforward ``{"inertia_ratio", "viscous", "coulomb"}`` (current units), ``None`` with a torque
            sensor.
        logs: the logs' sources; samples: their samples in all; torque_sensor: identified from a torque column.
        table: ``(TABLE_ENTRIES,)`` the compensation table (A, forward and reverse averaged).
        table_summary: its entries, RMS and peak (A), forward minus reverse (A RMS), and in N·m where a torque
            constant is known.
        in_si: the model in SI (torque constant, cogging RMS, friction, inertia) or ``None``.
        slots_detected: how the slot count was read from the logs, or ``None``.
        static_maps: per static map, its comparison (:func:`pgcomm.rotary.static_map.compare`) and, under
            ``combined``, how it was combined with the identified table (:func:`pgcomm.rotary.static_map.combine`:
            the map's weight, both errors, the file).
        sweep: the logged standstill sweep's table (:class:`~pgcomm.rotary.standstill.SweepTable`) or ``None``;
            sweep_comparison: its agreement with the model's table, or ``None``.
        k_t_ratios: the back-EMF's torque constant over the description's ``k_t`` (``"back_emf"``) and along the
            magnets' axis (``"aligned"``), where both are known.
        runtime_s: seconds from ``started`` to the result.
        combined_tables: per static map, ``(file name, (n,) A, (n,) A)``: the identified table and the map as one
            table (:func:`pgcomm.rotary.static_map.combine`), and the map aligned with it, on the map's ``n`` angles
            ``2π j / n``.
    """

    motor: RotaryMotor
    model: RotaryModel
    identification: RotaryIdentification
    mechanics: dict | None
    logs: list
    samples: int
    torque_sensor: bool
    table: np.ndarray
    table_summary: dict
    in_si: dict | None
    slots_detected: dict | None
    static_maps: list
    sweep: SweepTable | None
    sweep_comparison: dict | None
    k_t_ratios: dict
    runtime_s: float
    combined_tables: list = field(default_factory=list)

    @property
    def how(self) -> str:
        """How the maps were identified, in words."""
        return "with the torque sensor" if self.torque_sensor else "without a torque sensor (from the motion)"

    def to_dict(self) -> dict:
        """``results.json`` of ``pgcomm identify`` on a rotary motor (a new dict; the result is not changed)."""
        ident = self.identification.to_dict()
        voltage = ident.get("back_emf") or {}
        if "back_emf" in self.k_t_ratios:
            voltage["ratio_to_motor_k_t"] = self.k_t_ratios["back_emf"]
        if "aligned" in self.k_t_ratios:
            voltage["offset_error"]["ratio_to_motor_k_t"] = self.k_t_ratios["aligned"]
        out = {"command": "identify", "kind": "rotary", "version": __version__, "motor": self.motor.to_dict(),
               "logs": list(self.logs), "samples": self.samples, "torque_sensor": self.torque_sensor,
               "identification": ident, "mechanics_fit": None if self.mechanics is None else dict(self.mechanics),
               **({"slots_detected": self.slots_detected} if self.slots_detected is not None else {}),
               "table": dict(self.table_summary), "runtime_s": self.runtime_s}
        if self.in_si is not None:
            out["in_SI"] = dict(self.in_si)
        if self.static_maps:
            out["static_maps"] = [dict(m) for m in self.static_maps]
        if self.sweep_comparison is not None:
            out["standstill_sweep"] = dict(self.sweep_comparison)
        return out


def identify_from_logs(logs, motor: RotaryMotor, options: RotaryIdentifyOptions | None = None, *, sweep_logs=(),
                       static_maps=(), progress: Progress | None = None, started: float | None = None
                       ) -> LogsIdentification:
    """Identify a rotary motor from its drive's running logs (module docstring).

    Args:
        logs: the running logs, :class:`pgcomm.io.logs.Log` s read with ``required=ROTARY_REQUIRED`` (``theta`` and
            ``iq_1`` each); a log with dropped samples is identified as the stretches between them.
        motor: :class:`~pgcomm.rotary.motor.RotaryMotor`; without ``slots`` the count is read from the logs.
        options: :class:`~pgcomm.settings.RotaryIdentifyOptions` (``torque_sensor``: every log has ``torque``, N·m).
        sweep_logs: a logged slow position sweep in both directions (``theta``, ``iq_1``), in pieces one after the
            other: the drives' own calibration, whose table is compared with the model's against both noises.
        static_maps: the drive's own static maps (:class:`pgcomm.rotary.static_map.StaticMap`) to compare with.
        progress: :class:`pgcomm.progress.Progress` for the stages and what each found (default: silent).
        started: ``time.perf_counter()`` at the start of the run, for ``runtime_s`` (default: this call's start).

    Returns:
        :class:`LogsIdentification`.

    Raises:
        DataError, ExcitationError: as :func:`pgcomm.rotary.identify.identify`; a sweep that does not cover the
            revolution (:func:`pgcomm.rotary.standstill.table_from_sweep`).
    """
    started = time.perf_counter() if started is None else started
    options = options or RotaryIdentifyOptions()
    progress = progress or Progress(enabled=False)
    torque_sensor = options.torque_sensor
    data = _segments(logs, torque_sensor, progress)
    slots_detected = None
    if motor.slots is None:
        with progress.stage("slot count from the logs (not in the motor description): every cogging order the logs "
                            "carry"):
            q, slots_detected = count_slots(data, motor, current_delay=options.current_delay,
                                            angle_pll=options.angle_pll, current_lag=options.current_lag,
                                            time_lines=options.time_lines)
            motor = replace(motor, slots=q)
            others = [x for x in slots_detected["slots_with_that_fundamental"] if x != q]
            progress.info(f"cogging fundamental {slots_detected['cogging_fundamental']} per revolution (orders seen, "
                          f"strongest first: {', '.join(map(str, slots_detected['orders_seen'][:8]))}): slots = {q}, "
                          f"{motor.name}" + (f" (also {', '.join(map(str, others))} slots have that fundamental; "
                                             "set slots in the motor TOML if you know it)" if others else "")
                          + (f"; {held_out_text(slots_detected)}" if slots_detected.get("held_out") else "")
                          + (f"; {over_the_angle_count_text(slots_detected)}"
                             if over_the_angle_count_text(slots_detected) else ""))
    how = "with the torque sensor" if torque_sensor else "without a torque sensor (from the motion)"
    with progress.stage(f"identification {how}: cogging, ripple, direction map over the revolution"):
        res = identify(data, motor, options)
        # the feedforward read as the identification read the logs, its report filter taken out too
        mech = None if torque_sensor else fit_mechanics(data, motor, options.with_reading(res.reading()))
        _tell(res, motor, progress)
    model = replace(res.model, info={**res.model.info, "motor": motor.name, "current_limit": motor.current_limit,
                                     "logs": [lg.source for lg in logs]})
    static = []
    # the maps' independent values: the cogging's highest order resolved, a sine and a cosine each
    independent = 2 * int(np.max(model.cogging.orders, initial=1))
    combined_tables = []
    model_error = ((res.standard_error or {}).get("cogging") or {}).get("rms_error")
    for m in static_maps:
        found = compare(m, model, independent)
        progress.info(text(found))
        if model_error is not None:
            both = combine(m, model, found, model_error)
            name = f"combined_{Path(m.source).stem}.csv"
            if any(name == used for used, *_ in combined_tables):  # two maps of one name in different folders
                name = f"combined_{Path(m.source).stem}_{len(combined_tables) + 1}.csv"
            combined_tables.append((name, both.pop("iq"), both.pop("map_aligned")))
            found["combined"] = {**both, "file": name}
            progress.info(f"{name}: the identified table and {Path(m.source).name} as one table, the map weighing "
                          f"{100 * both['weight_static']:.0f} % (its error {both['static_rms_error_A']:.3g} A RMS "
                          f"against the table's {both['model_rms_error_A']:.3g} A)")
        static.append(found)
    sweep = sweep_comparison = None
    if sweep_logs:
        with progress.stage(f"the drives' table from the standstill sweep ({len(sweep_logs)} log(s))"):
            sweep, sweep_comparison = _sweep_table(sweep_logs, model, res.standard_error)
            progress.info(f"sweep table: {sweep.theta.size} bins, coverage {100 * sweep.coverage:.0f} %, noise "
                          f"{sweep_comparison['noise_A']:.3g} A; model minus sweep "
                          f"{sweep_comparison['rms_model_minus_sweep_A']:.3g} A RMS against "
                          f"{sweep_comparison['expected_rms_difference_A']:.3g} A from the two noises")
    n = TABLE_ENTRIES
    table = model.table(n)
    fwd_rev = model.table(n, +1) - model.table(n, -1)
    summary = {"entries": n, "rms_A": float(np.sqrt(np.mean(table**2))), "peak_A": float(np.max(np.abs(table))),
               "forward_minus_reverse_rms_A": float(np.sqrt(np.mean(fwd_rev**2)))}
    runtime = time.perf_counter() - started
    voltage = res.back_emf or {}
    k_si, k_from, ratios = None, None, {}
    if voltage.get("consistent"):
        # the back-EMF's torque constant is the one the drive's frame sees, k_t cos δ with the drive's electrical offset
        # off by δ (pgcomm.rotary.back_emf); a datasheet's k_t knows neither δ nor this motor's tolerance
        k_si, k_from = voltage["k0_amplitude_invariant"], "the logged q-voltage's back-EMF (amplitude-invariant)"
        if motor.k_t:
            ratios["back_emf"] = k_si / float(motor.k_t)
            if voltage.get("offset_error"):
                ratios["aligned"] = voltage["offset_error"]["k_t_aligned"] / float(motor.k_t)
    elif motor.k_t:
        k_si, k_from = float(motor.k_t), "the motor description's k_t"
    in_si = None
    if k_si is not None:
        summary["rms_Nm"] = summary["rms_A"] * k_si
        summary["torque_constant_from"] = k_from
        in_si = _in_si(model, k_si, k_from)
    return LogsIdentification(motor=motor, model=model, identification=res, mechanics=mech,
                              logs=[lg.source for lg in logs], samples=sum(lg.n_samples for lg in logs),
                              torque_sensor=torque_sensor, table=table, table_summary=summary, in_si=in_si,
                              slots_detected=slots_detected, static_maps=static, sweep=sweep,
                              sweep_comparison=sweep_comparison, k_t_ratios=ratios, runtime_s=runtime,
                              combined_tables=combined_tables)


def _segments(logs, torque_sensor: bool, progress: Progress) -> list[dict]:
    """The columns the identification reads, per stretch of each log between dropped samples (no filter window may
    difference across a gap): the q-voltage (with the d-voltage and the supply) only where every log has it (the
    back-EMF fit takes every log's voltage or none), the d-current where every log has it (held at zero, it is the
    current's noise alone, and its command carries it into the d-voltage)."""
    extra = ("vq_1",) if all("vq_1" in lg.columns for lg in logs) and not torque_sensor else ()
    with_vq = sum("vq_1" in lg.columns for lg in logs)
    if 0 < with_vq < len(logs) and not torque_sensor:
        progress.info(f"q-voltage vq_1 in {with_vq} of {len(logs)} logs: not read (the back-EMF fit takes every log's "
                      "voltage or none)")
    for name in ("vd_1", "vbus"):
        if extra and all(name in lg.columns for lg in logs):
            extra += (name,)
    if all("id_1" in lg.columns for lg in logs):
        extra += ("id_1",)
    return [{"name": lg.source if len(lg.gaps) == 0 else f"{lg.source} rows {a + 1}-{b}",
             **{k: lg.columns[k][a:b] for k in ("t", "theta", "iq_1", *extra, *(("torque",) if torque_sensor else ()))}}
            for lg in logs for a, b in lg.segments()]


def _tell(res: RotaryIdentification, motor: RotaryMotor, progress: Progress) -> None:
    """What the identification found, a line each: the logs' reading, the drive's own orders, the back-EMF, the
    sign of ``J/k0``, the encoder's correction, each map's standard error and verdict."""
    for line in (filter_text(res.current_filter), drive_text(res.drive_orders, motor.pole_pairs),
                 pll_text(res.angle_pll or {}), delay_text(res.current_delay or {}), lines_text(res.time_lines),
                 voltage_text(res.back_emf), offset_text(res.back_emf), host_clock_text(res.host_clock),
                 offsets_text(res.index_offsets or []), orders_text(res.orders_not_resolved),
                 over_the_angle_text(res.orders_over_the_angle)):
        if line:
            progress.info(line)
    if (res.model.inertia_ratio or 0.0) < 0.0:
        progress.info(f"J/k0 = {res.model.inertia_ratio:.4g} A·s²/rad is negative: a positive q-current turns the "
                      "rotor against the logged angle's direction (the drive's sign convention); the maps and "
                      "tables are in the drive's own signs, as its compensation needs them")
    quant = res.quantisation
    if quant and quant["logs_on_lattice"]:
        progress.info(f"encoder: {quant['logs_on_lattice']} of {quant['logs']} logged angle(s) on a "
                      f"{'/'.join(map(str, quant['counts_per_revolution']))}-count lattice; its rounding noise "
                      f"({share_text(quant['noise_share'])} of the acceleration the maps do not explain) is taken "
                      "out of the normal equations, so that it does not pull J/k0 down"
                      + ("; capped: the logs hardly carry the rotor's acceleration above the encoder's noise, "
                         "log accelerations or a dither" if quant["correction_capped"] else ""))
    for name in ("cogging", "ripple", "direction") if res.standard_error else ():
        progress.info(map_text(name, res.standard_error[name]))


def _sweep_table(logs, model: RotaryModel, standard_error: dict | None) -> tuple[SweepTable, dict]:
    """The drives' table from a logged sweep (its pieces one after the other, each piece's angle as logged) and its
    agreement with ``model``'s table: the comparison of :mod:`pgcomm.rotary.experiment`, with the model's standard
    error in place of the truth.

    Returns:
        ``(SweepTable, dict)``: the dict is ``results.json``'s ``standstill_sweep``.
    """
    theta = np.concatenate([lg.columns["theta"] for lg in logs])
    iq = np.concatenate([lg.columns["iq_1"] for lg in logs])
    try:
        sweep = table_from_sweep(theta, iq, logs[0].sample_time)
    except DataError as e:
        raise DataError(f"--sweep {', '.join(lg.source for lg in logs)}: {str(e).removeprefix('sweep log: ')}") from None
    ok = np.isfinite(sweep.table)
    mod = 0.5 * (model.iq_comp(sweep.theta, 1.0) + model.iq_comp(sweep.theta, -1.0))
    diff = float(np.sqrt(np.mean((mod[ok] - sweep.table[ok]) ** 2)))
    se = (standard_error or {}).get("cogging", {}).get("rms_error", 0.0)
    expected = float(np.hypot(sweep.noise, se))
    fr = np.isfinite(sweep.forward) & np.isfinite(sweep.reverse)
    return sweep, {
        "logs": [lg.source for lg in logs], "points": int(sweep.theta.size), "coverage": sweep.coverage,
        "seconds": sweep.seconds, "noise_A": sweep.noise, "table_rms_A": float(np.sqrt(np.mean(sweep.table[ok] ** 2))),
        "rms_model_minus_sweep_A": diff, "model_standard_error_A": float(se),
        "expected_rms_difference_A": expected, "agreement_factor": AGREEMENT_FACTOR,
        "within_noise": bool(diff <= AGREEMENT_FACTOR * expected),
        "rms_forward_minus_reverse_A": float(np.sqrt(np.mean((sweep.forward[fr] - sweep.reverse[fr]) ** 2))),
        "table_written": bool(ok.all())}


def _in_si(model: RotaryModel, k: float, source: str) -> dict:
    """The model's scale in SI with the torque constant ``k`` (N·m/A): cogging RMS (N·m), Coulomb friction (N·m),
    viscous friction (N·m·s/rad) and the moment of inertia of rotor and load (kg·m²), from the current-unit model."""
    si = model.in_newton_metres(k)
    th = 2 * np.pi * np.arange(4096) / 4096
    direction = model.direction
    coulomb = float(sum(c[0] for h, c in zip(direction.orders, direction.coef) if h == 0))
    return {"torque_constant_Nm_per_A": k, "torque_constant_from": source,
            "cogging_rms_Nm": float(np.sqrt(np.mean(si["cogging"](th) ** 2))), "coulomb_Nm": coulomb * k,
            "viscous_Nm_s_per_rad": si["viscous"], "inertia_kg_m2": si["inertia"]}
