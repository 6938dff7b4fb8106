"""Self-contained HTML report of ``pgcomm reproduce``: our numbers beside the paper's, with the figures.

Every number and every fact of the set-up in the report is read from the typed
:class:`~pgcomm.reproduce.ReproduceResult` (its ``to_dict()`` is what ``results.json`` holds,
its ``setup.config`` the settings it ran with); figures are embedded as base64 PNG so the
file opens anywhere. The report is written for an engineer: every number carries its unit,
the paper's tables and figures are named by their number and what they show (never by a
LaTeX label), and every figure has a caption of its own (:func:`figure_captions`).
"""

from __future__ import annotations

import html
from pathlib import Path
import jax.numpy as jnp
import numpy as np

from pgcomm.io.atomic import atomic_write_text
from pgcomm.report.page import CSS, figure_html
from pgcomm.reproduce import PAPER, ReproduceResult

#: The paper's tables and figures the report refers to, by number and content.
PAPER_TABLE_CALIBRATION = "the paper's Table 1 (initial and calibrated k̂, ζ̂)"
PAPER_TABLE_PERFORMANCE = "the paper's Table 2 (commutation performance)"
PAPER_TABLE_CALIBRATION_SHORT = "the paper's Table 1"
PAPER_FIG_REFERENCE = "the paper's Fig. 8 (reference for the data sets)"
PAPER_FIG_COGGING = "the paper's Fig. 9 (identified cogging force)"
PAPER_FIG_SLOW = "the paper's Fig. 10 (slow reference, 0.025 m/s)"
PAPER_FIG_FAST = "the paper's Fig. 11 (fast reference, 0.15 m/s)"


def row_descriptions(result: ReproduceResult) -> dict:
    """One line per row of the table, with the set-up's own values (initial ``k̂``, ``ζ̂``, harmonics)."""
    cfg = result.setup.config
    k0 = ", ".join(f"{k:.4g}" for k in result.calibration.k_initial)
    z0 = ", ".join(f"{z:.4g}" for z in result.calibration.zeta_initial)
    return {
        "original": f"classical commutation with the uncalibrated k̂ = {k0} N/A, ζ̂ = {z0} rad",
        "classical": "classical commutation, calibrated by Algorithm 1",
        "physics": "physics-only model A cos + B sin, inverted the same way as the PGNN",
        "pgnn": "PGNN commutation: the identified physics-guided neural network inverted for the minimum-energy "
                "currents (the paper's proposal)",
        "pgnn_direction": (f"PGNN with the direction term C s(dy/dt), s = tanh(v/{cfg.identification.direction_velocity:g}"
                           f" m/s), law fed the {cfg.identification.law_velocity} velocity"
                           + (", 5th/7th harmonics" if cfg.identification.direction_harmonics else "")),
        "spline": ("physics-guided spline model (fundamental with coefficients tabulated along the stroke, cogging and "
                   "direction tables; knots by cross-validation), inverted; feedforward from its own identification "
                   "of mass, viscous friction and Coulomb friction along the stroke (not tuned in closed loop)"),
        "pgnn_sensorless": ("PGNN identified without a force sensor (y row from m d2y/dt2 with friction; x, z rows "
                            "classical), calibration without force data"),
        "cogging_table": "classical + drive anti-cogging table (force offset vs position)",
        "cogging_table_sensorless": ("classical (calibrated without force data) + anti-cogging table from the "
                                     "position controller's effort at slow constant velocity, both directions "
                                     "averaged"),
        "harmonic_cogging": f"classical + offset of up to {cfg.evaluation.harmonics} pole-pitch harmonics",
        "oracle": "exact inverse of the plant with its true position and velocity (the floor)",
    }


def _fmt(x, digits: int = 3, unit: str = "") -> str:
    if x is None:
        return "–"
    return f"{x:.{digits}g}" + (f" {unit}" if unit else "")


def _plant_direction_force(result: ReproduceResult) -> float:
    """Mean magnitude (N) of the plant's direction-dependent force in y over the reference's span (0 on a force map)."""
    y = jnp.linspace(*result.setup.config.reference.span, 501)
    return float(np.mean(np.abs(np.asarray(result.setup.plant.direction_force(y, jnp.ones_like(y)))[:, 0])))


def gain_sentence(result: ReproduceResult, results: dict | None = None) -> str:
    """What the gain figure shows of the PGNN's driving-force gain against the truth, and why, from this run.

    The explanation (the PGNN takes the motor's direction-dependent force into its gain) is given
    only when this run supports it: the plant has such a force, the PGNN's gain is more than 2 %
    off, and the PGNN with the direction term, identified from the same data, is less than half as
    far off. Otherwise the numbers are stated alone.
    """
    me = (results or result.to_dict())["model_error"]
    r_p = me["pgnn"]["gain_ratio_y"]
    text = (f"The PGNN's driving-force gain |K̂_y| is on average {_off(r_p)} over the stroke "
            f"(mean of |K̂_y(y)| / |K_y(y)| over positions and coil sets)")
    others = [f"{label} {_off(me[name]['gain_ratio_y'])}" for name, label in
              (("pgnn_direction", "the PGNN with the direction term"), ("spline", "the spline model")) if name in me]
    if others:
        text += "; identified from the same data, " + " and ".join(others)
    text += "."
    f_dir = _plant_direction_force(result)
    r_d = me.get("pgnn_direction", {}).get("gain_ratio_y")
    if f_dir > 0 and abs(r_p - 1.0) > 0.02 and r_d is not None and abs(r_d - 1.0) < 0.5 * abs(r_p - 1.0):
        text += (f" Why: the motor has a direction-dependent force (mean {f_dir:.3g} N in y, e.g. from the cable "
                 "slab or magnet hysteresis) and the PGNN has no term for it. In the data sets the current follows "
                 "the direction of motion (the drive pushes against friction), so the PGNN explains that force as "
                 "extra gain; given a term C·sign(dy/dt) for it, its gain returns to the truth. The PGNN law therefore "
                 "compensates the direction force only in proportion to the current.")
    z_p = me["pgnn"]["gain_rms_relative"]["z"]
    z_d = me.get("pgnn_direction", {}).get("gain_rms_relative", {}).get("z")
    if z_p and z_d is not None:
        z_ref = me["pgnn"]["gain_rms"]["z"] / z_p  # RMS of the true Tz row (N m/A)
        text += (f" The Tz row's true gain has an RMS of {z_ref:.2g} N m/A: the PGNN misses it by {100 * z_p:.0f} % "
                 f"of that, the PGNN with the direction term by {100 * z_d:.0f} %")
        text += (", so the torque row takes up the motor's direction-dependent torque in the same way."
                 if f_dir > 0 and z_d < 0.5 * z_p else ".")
    return text


def _off(ratio: float) -> str:
    """``ratio`` of a model's gain to the truth's in words: ``"10.9 % above the truth"``, ``"within 0.05 % of the
    truth"``."""
    d = 100.0 * (ratio - 1.0)
    if abs(d) < 0.05:
        return "within 0.05 % of the truth"
    return f"{abs(d):.1f} % {'above' if d > 0 else 'below'} the truth"


def figure_captions(result: ReproduceResult, results: dict | None = None) -> dict:
    """One caption per figure file of ``pgcomm reproduce`` (file name -> caption), each describing its own figure.

    Units are those of the figure's axes; the paper's figure or table it corresponds to is named
    by number and content.
    """
    cfg = result.setup.config
    lp = cfg.evaluation.lowpass_hz
    velocities = cfg.reference.velocities
    truth = "the plant's truth" if result.setup.plant_name == "twin" else f"the force map {result.setup.plant_name}"
    caps = {
        "reference.png": (f"Data-generation reference: position y* (mm) and velocity (m/s) against time (s), moves at "
                          + ", ".join(f"{v:g}" for v in sorted(velocities)) + " m/s. The data sets for calibration and "
                          f"identification and the long evaluation run on it; compare {PAPER_FIG_REFERENCE}."),
        "mse.png": (f"Commutation-error MSE per row on the long reference after the {lp:g} Hz low-pass (log scale): "
                    "Fy − Fy* and Fx − Fx* in N², Tz − Tz* in N²m²."),
        "cogging.png": (f"Cogging force identified by the PGNN (mean over the coil sets) against {truth}: Fy and Fx in "
                        f"N, Tz in N m, over the position y (mm); compare {PAPER_FIG_COGGING}."),
        "gain_coilset1.png": ("Gain of coil set 1, PGNN against " + truth + ": force per ampere of phase current "
                              "ia and ib (Fy, Fx in N/A, Tz in N m/A) over the position y (mm). "
                              + gain_sentence(result, results)),
        "calibration.png": (f"Calibration (Algorithm 1): initial, calibrated and true k̂ (N/A) and ζ̂ (rad) per coil set; "
                            f"the values of {PAPER_TABLE_CALIBRATION} as a figure."),
        "cogging_spline.png": (f"Cogging force of the spline model (knot spacing chosen by cross-validation) against "
                               f"{truth}: Fy and Fx in N, Tz in N m, over the position y (mm)."),
        "gain_spline_coilset1.png": ("Gain of coil set 1, spline model against " + truth + ": force per ampere of "
                                     "phase current ia and ib (Fy, Fx in N/A, Tz in N m/A) over the position y (mm)."),
    }
    panels = (f"top to bottom: reference y* (mm), the {lp:g} Hz-filtered commutation error Fy − Fy* (N), Fx − Fx* (N), "
              "Tz − Tz* (N m) and the tracking error y* − y (µm) against time (s), every row")
    caps["compare_slow.png"] = (f"Slow reference, moves at {min(velocities):g} m/s; {panels}; compare "
                                f"{PAPER_FIG_SLOW}.")
    caps["compare_fast.png"] = (f"Fast reference, moves at {max(velocities):g} m/s; {panels}; compare "
                                f"{PAPER_FIG_FAST}.")
    caps["compare_user.png"] = f"The reference given with --reference; {panels}."
    return caps


def comparison_sentences(result: ReproduceResult) -> list[str]:
    """One sentence per comparison of our rows with the paper's, built from ``result`` alone.

    Only facts of this run are stated: its plant (the built-in twin, or a force map), its
    start values, its settings and its numbers, each with its unit; statements about how the
    twin was sized appear only when the plant is the twin.
    """
    results = result.to_dict()
    cm, tm = result.commutation_mse, result.tracking_mse
    cfg = result.setup.config
    mech, cal = cfg.mechanics, result.calibration
    twin = result.setup.plant_name == "twin"
    plant = "the built-in twin" if twin else f"the force map {result.setup.plant_name}"
    k0 = ", ".join(f"{k:.4g}" for k in cal.k_initial)
    k_excess = 100.0 * (float(sum(cal.k_initial)) / float(sum(cal.k)) - 1.0)
    noise = results["sensor_noise"]["long"]
    noise_expected = results["sensor_noise"]["expected"]
    oracle_true = results["sensor_noise"]["oracle_true_force"]
    lp = cfg.evaluation.lowpass_hz
    p = PAPER["commutation_mse"]
    s = []
    r_cy, p_cy = cm["classical"]["y"]["filtered"], p["classical"]["y"][0]
    sized = (" The twin's parasitic effects were sized from the paper's evidence (its classical error and the "
             "identification cost of its remark on a direction term), so this ratio is not an independent outcome."
             if twin else "")
    s.append(f"Plant: {plant}. Classical commutation, driving direction y: {r_cy:.3g} N² against the paper's "
             f"{p_cy:.3g} N² (ratio {r_cy / p_cy:.2f}).{sized}")
    r_oy, p_oy = cm["original"]["y"]["filtered"], p["original"]["y"][0]
    s.append(f"Original, y: {r_oy:.3g} N² against the paper's {p_oy:.3g} N²; the uncalibrated k̂ = {k0} N/A is "
             f"{abs(k_excess):.0f} % {'above' if k_excess >= 0 else 'below'} the calibrated values, so this error "
             "grows with the squared driving force, which depends on the friction and mass of the translator "
             f"(this run: {mech.mass:.4g} kg, {mech.coulomb:.4g} N Coulomb friction, {mech.viscous:.4g} N s/m viscous "
             "friction).")
    r_py, p_py = cm["pgnn"]["y"]["filtered"], p["pgnn"]["y"][0]
    r_or = cm["oracle"]["y"]["filtered"]
    s.append(f"PGNN, y: {r_py:.3g} N² against the paper's {p_py:.3g} N², {r_cy / r_py:.1f} times less than classical "
             f"(paper: {p_cy / p_py:.1f} times). The oracle (the plant's exact inverse with its true position and "
             f"velocity) reaches {r_or:.3g} N²: its true force meets the demand (MSE {oracle_true['y']:.2g} N²), "
             f"and {noise['y']:.3g} N² is the force sensor's own noise on this reference ({cfg.sensors.force_noise[0]:.3g} "
             f"N rms after the {lp:g} Hz low-pass; {noise_expected['y']:.3g} N² expected), the floor of any error "
             "measured with this sensor. What lies between the PGNN and the oracle is outside the PGNN's model class "
             "(velocity-dependent forces, higher harmonics, variation along the stroke finer than its networks) or "
             "not identified from the data.")
    s.append(gain_sentence(result, results))
    share = result.reducible_share()
    below = [row for row in result.rows if row != "oracle" and share[row]["y"] is not None and share[row]["y"] > 1.0]
    if below:
        s.append(f"Rows below the oracle in y: {', '.join(below)}. The oracle is the floor up to noise; a row "
                 "below it by more than the noise spread points to a defect in the simulation or the oracle.")
    for d, unit, q, nu in (("x", "N²", 1, "N"), ("z", "N²m²", 2, "N m")):
        s.append(f"{d}: classical {cm['classical'][d]['filtered']:.3g} {unit} (paper {p['classical'][d][0]:.3g} "
                 f"{unit}), PGNN {cm['pgnn'][d]['filtered']:.3g} {unit} (paper {p['pgnn'][d][0]:.3g} {unit}), oracle "
                 f"{cm['oracle'][d]['filtered']:.3g} {unit} (the filtered sensor noise on this reference: "
                 f"{noise[d]:.3g} {unit}); the unfiltered values hold all of the force-sensor noise (this run: "
                 f"{cfg.sensors.force_noise[q]:.3g} {nu} rms, {cfg.sensors.force_noise[q] ** 2:.3g} {unit}).")
    r_ct, p_ct = tm["classical"], PAPER["tracking_mse"]["classical"]
    r_pt, p_pt = tm["pgnn"], PAPER["tracking_mse"]["pgnn"]
    s.append(f"Tracking error: classical {r_ct:.3g} m² (paper {p_ct:.3g} m²), PGNN {r_pt:.3g} m² (paper "
             f"{p_pt:.3g} m²): {r_ct / r_pt:.1f} times less than classical (paper: {p_ct / p_pt:.1f} times), with a "
             f"{cfg.controller.bandwidth_hz:g} Hz position loop and the feedforward identified per row.")
    tab = cm["cogging_table"]["y"]["filtered"]
    s.append(f"Drive-style rows: the anti-cogging table reaches {tab:.3g} N² in y (a force offset against "
             "position: it cannot follow errors that scale with the current, and has no x/z action); the harmonic "
             f"fit reaches {cm['harmonic_cogging']['y']['filtered']:.3g} N² (it holds only forces periodic in the "
             "pole pitch).")
    if result.sensorless is not None and "pgnn_sensorless" in cm:
        sl = results["sensorless"]
        r_sy = cm["pgnn_sensorless"]["y"]["filtered"]
        share_p = sl["share_of_pgnn_reduction_y"]
        fr = "; ".join(f"{c['name']}: Coulomb {c['mechanics']['coulomb']:.3g} N, viscous "
                       f"{c['mechanics']['viscous']:.3g} N s/m" for c in sl["coil_sets"])
        mass = sl.get("mass_source") or f"{sl['mass']:g} kg"
        s.append(f"Without a force sensor, y: {r_sy:.3g} N² (classical {r_cy:.3g} N², force-sensor PGNN {r_py:.3g} "
                 f"N²): it removes {_pct(share_p)} of what the force-sensor PGNN removes. Its Coulomb column also "
                 "holds any direction-dependent force of the motor (the two cannot be told apart from the motion), "
                 f"so that force stays in its error. Identified friction ({fr}) against the simulated translator's "
                 f"{mech.coulomb:.4g} N Coulomb and {mech.viscous:.4g} N s/m viscous friction; offered as the "
                 f"feedforward's parameters. Moving mass: {mass}.")
        if "cogging_table_sensorless" in cm:
            wo = sl["y_mse_without_direction_force"]
            s.append(f"The drives' sensorless anti-cogging table reaches "
                     f"{cm['cogging_table_sensorless']['y']['filtered']:.3g} N² in y. A different quantity, known "
                     "only because the plant is simulated, shows what the rows without a force sensor could reach: "
                     f"the {lp:g} Hz-filtered MSE of the true driving force (not the sensor's reading, so without its "
                     "noise) minus the demand minus the plant's own direction-dependent force: classical "
                     f"{wo['classical']:.3g} N², PGNN without force sensor {wo['pgnn_sensorless']:.3g} N², sensorless "
                     f"table {wo['cogging_table_sensorless']:.3g} N². These are not comparable with the table above "
                     f"(measured force, {noise['y']:.3g} N² of sensor noise in every row): a value below the "
                     f"oracle's {r_or:.3g} N² does not beat the floor. Rows that compensate the direction force "
                     "(pgnn through its gain, pgnn_direction, spline, oracle) are not comparable on it either.")
    return s


def _pct(x) -> str:
    return "–" if x is None else f"{100 * x:.0f} %"


def write_report(path: Path, result: ReproduceResult, figures: dict, *, version: str = "",
                 runtime_s: float = float("nan")) -> None:
    """Write ``report.html``.

    Args:
        path: output file.
        result: the experiment's :class:`~pgcomm.reproduce.ReproduceResult`.
        figures: caption -> PNG path, in display order.
        version: package version for the header; runtime_s: wall time of the command (s).
    """
    results = result.to_dict()
    cm, tm = result.commutation_mse, result.tracking_mse
    share = result.reducible_share()
    descriptions = row_descriptions(result)
    lp = result.setup.config.evaluation.lowpass_hz
    rows_html = []
    rec = results["recommended"]
    for row in result.tracking_order():
        cells = "".join(f"<td>{_fmt(cm[row][d]['filtered'])} ({_fmt(cm[row][d]['unfiltered'])})</td>"
                        for d in ("y", "x", "z"))
        sh = share.get(row, {})
        mark = " class='rec'" if row == rec["row"] else ""
        other = "".join(f"<td>{_fmt(result.metrics[rn][row]['tracking_mse'])}</td>"
                        for rn in result.metrics if rn != "long")
        rows_html.append(f"<tr{mark}><th>{row}</th><td class='desc'>{html.escape(descriptions[row])}</td>"
                         f"<td>{_fmt(tm[row])}</td><td>{_pct(sh.get('tracking'))}</td>{other}{cells}"
                         f"<td>{_pct(sh.get('y'))}</td></tr>")
    other_heads = "".join(f"<th>tracking MSE, {html.escape(rn)} reference [m²]</th>"
                          for rn in result.metrics if rn != "long")
    nbytes = rec["table_bytes"]
    stores = "nothing" if not nbytes else f"{int(nbytes)} bytes of tables or weights (float32)"
    rec_html = (f"<p><b>Recommended: {html.escape(rec['row'])}</b> — {html.escape(rec['reason'])}. "
                f"Deploying it stores {stores}; its C law's time per call is measured by "
                "<code>bench/bench_export.py</code>.</p>")
    paper_rows = []
    for row, vals in PAPER["commutation_mse"].items():
        cells = "".join(f"<td>{_fmt(vals[d][0])} ({_fmt(vals[d][1])})</td>" for d in ("y", "x", "z"))
        paper_rows.append(f"<tr><th>{row}</th>{cells}<td>{_fmt(PAPER['tracking_mse'].get(row))}</td></tr>")
    cal = results["calibration"]
    cal_rows = []
    for l in range(len(cal["calibrated"]["k"])):
        tk = cal["true"]["k"][l] if cal["true"]["k"] is not None else None
        tz = cal["true"]["zeta"][l] if cal["true"]["zeta"] is not None else None
        pk = PAPER["calibrated"]["k"][l] if l < 3 else None
        pz = PAPER["calibrated"]["zeta"][l] if l < 3 else None
        cal_rows.append(f"<tr><th>{l + 1}</th><td>{_fmt(cal['initial']['k'][l])}</td>"
                        f"<td>{cal['calibrated']['k'][l]:.4g}</td><td>{_fmt(tk, 4)}</td><td>{_fmt(pk, 4)}</td>"
                        f"<td>{_fmt(cal['initial']['zeta'][l])}</td><td>{cal['calibrated']['zeta'][l]:.4f}</td>"
                        f"<td>{_fmt(tz, 4)}</td><td>{_fmt(pz)}</td></tr>")
    ident = results["identification"]
    id_rows = "".join(
        f"<tr><th>{c['name']}</th><td>{_fmt(c['cost_physics'])}</td><td>{_fmt(c['cost_pgnn'])}</td>"
        f"<td>{_fmt(c['cost_physics_validation'])}</td><td>{_fmt(c['cost_pgnn_validation'])}</td>"
        f"<td>{_fmt(c.get('cost_y_pgnn'))}</td><td>{_fmt(c.get('cost_y_pgnn_direction'))}</td>"
        f"<td>{c['seconds']:.1f}</td></tr>" for c in ident["coil_sets"])
    sentences = "".join(f"<li>{html.escape(t)}</li>" for t in comparison_sentences(result))
    figs = "".join(figure_html(Path(p), cap) for cap, p in figures.items())
    plant = "the built-in twin" if results.get("plant") == "twin" else f"the force map {results.get('plant')}"
    doc = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>pgcomm reproduce — {html.escape(plant)}</title>
<style>
{CSS}</style></head><body>
<h1>Physics-guided commutation: the paper's experiment on {html.escape(plant)}</h1>
<p>Generated by <code>pgcomm reproduce</code> (version {html.escape(str(version))}) in
{runtime_s:.0f} s. All numbers below are those of <code>results.json</code>.</p>
<h2>Tracking error and commutation error, best tracking first</h2>
<p>Tracking error: the MSE of y* − y on the long (data-generation) reference (m²) and its share of the reducible
tracking error, (classical − row)/(classical − oracle) in %; the same MSE on the other references. Commutation
error: the MSE of F − F* on the long reference after the {lp:g} Hz low-pass (without it, in brackets): Fy and Fx
in N², Tz in N²m², as in {PAPER_TABLE_PERFORMANCE}; and the share of the reducible y error in %. Shares are shown
only where classical − oracle stands above the noise.</p>
{rec_html}
<table><tr><th>row</th><th>law</th><th>tracking MSE, long reference [m²]</th><th>share of reducible tracking
error [%]</th>{other_heads}
<th>Fy − Fy*, filtered (unfiltered) [N²]</th><th>Fx − Fx*, filtered (unfiltered) [N²]</th>
<th>Tz − Tz*, filtered (unfiltered) [N²m²]</th><th>share of reducible y error [%]</th></tr>{''.join(rows_html)}</table>
<h3>The paper's values: its Table 2 (commutation performance) and tracking errors</h3>
<table><tr><th>row</th><th>Fy − Fy*, filtered (unfiltered) [N²]</th><th>Fx − Fx*, filtered (unfiltered) [N²]</th>
<th>Tz − Tz*, filtered (unfiltered) [N²m²]</th><th>tracking MSE [m²]</th></tr>
{''.join(paper_rows)}</table>
<h3>How ours differ</h3><ul>{sentences}</ul>
<h2>Calibration (Algorithm 1), as in {PAPER_TABLE_CALIBRATION_SHORT}</h2>
<p>Motor constant k̂ (N/A) and commutation phase offset ζ̂ (rad) of each coil set: the drive's initial values,
Algorithm 1's, the plant's true fundamental where it is known, and the paper's.</p>
<table><tr><th>coil set</th><th>k̂ initial [N/A]</th><th>k̂ calibrated [N/A]</th><th>k true [N/A]</th>
<th>k̂ paper [N/A]</th><th>ζ̂ initial [rad]</th><th>ζ̂ calibrated [rad]</th><th>ζ true [rad]</th>
<th>ζ̂ paper [rad]</th></tr>{''.join(cal_rows)}</table>
<h2>Identification (Algorithm 2)</h2>
<p>Identification cost V per coil set: the mean over the samples of both data sets of
(Fy − F̂y)² + (Fx − F̂x)² + (Tz − T̂z)² (N², the torque in N m); for the PGNN on the
training data plus the regularisation that ties its physical part to the physics-only model. Validation: the
data term alone on the held-out samples. The y costs are the mean of (Fy − F̂y)² on the training data (N²), of
the PGNN and of the PGNN with the direction term.</p>
<table><tr><th>coil set</th><th>V physics-only, training [N²]</th><th>V PGNN, training [N²]</th>
<th>V physics-only, validation [N²]</th><th>V PGNN, validation [N²]</th><th>y cost PGNN [N²]</th>
<th>y cost PGNN with direction term [N²]</th><th>time [s]</th></tr>{id_rows}</table>
<p>Total identification time {ident['seconds_total']:.1f} s.</p>
<h2>Figures</h2>{figs}
</body></html>
"""
    atomic_write_text(path, doc)
