"""Self-contained HTML report of a rotary run (``pgcomm reproduce`` or ``pgcomm identify`` on a rotary motor).

Every number is read from the run's ``results.json`` dict (keys in ``docs/results.md``); the figures are
embedded as base64 PNG with the style of the linear report (:mod:`pgcomm.report.linear`). Units: angles in
rad, speeds in rad/s, currents in A; the maps in current units (cogging and direction term as an
equivalent q-current, the ripple relative).
"""

from __future__ import annotations

import html
from pathlib import Path

from pgcomm.io.atomic import atomic_write_text
from pgcomm.report.page import CSS, figure_html
from pgcomm.rotary.identify import orders_text, over_the_angle_text, resolution_verdict, share_text
from pgcomm.rotary.back_emf import offset_text, voltage_text
from pgcomm.rotary.readings import delay_text, filter_text, pll_text
from pgcomm.rotary.power_ups import offsets_text
from pgcomm.rotary.time_lines import lines_text
from pgcomm.rotary.slots import held_out_text, over_the_angle_count_text

__all__ = ["write_rotary_report", "ROW_DESCRIPTIONS"]

#: One line per row of ``reproduce``'s table.
ROW_DESCRIPTIONS = {
    "classical": "no compensation (i_q = demand), with the feedforward a drive user tunes",
    "standstill_table": "the drives' method: a standstill sweep's table added to the demand",
    "model": "the law of the model identified from running logs without a torque sensor",
    "oracle": "the true map inverted, true feedforward: the floor",
}


def _g(x, digits: int = 3, unit: str = "") -> str:
    if x is None:
        return "–"
    return f"{x:.{digits}g}" + (f" {unit}" if unit else "")


def _pct(x) -> str:
    return "–" if x is None else f"{100 * x:.1f} %"


def _identification_html(r: dict) -> str:
    ident = r["identification"]
    se = ident.get("standard_error") or {}
    rows = []
    has_truth = "errors" in ident  # the twin's runs know the truth; a rig's logs do not
    for name, unit in (("cogging", "A"), ("ripple", "(relative)"), ("direction", "A")):
        if name not in se:
            continue
        e = se[name]
        truth = ident.get("errors", {}).get({"cogging": "cogging_rel", "ripple": "ripple_rel",
                                               "direction": "direction_rel"}[name])
        said = resolution_verdict(e)
        verdict = ("yes" if e["resolved"] else "no" + said.removeprefix("not resolved")
                   if said.startswith("not resolved") else "no: " + said)
        rows.append(f"<tr><th>{name}</th><td>{_g(e['rms'])} {unit}</td><td>{_g(e['rms_error'])} {unit}</td>"
                    f"<td>{_pct(e['relative'])}</td><td>{html.escape(verdict)}</td>"
                    + (f"<td>{_pct(truth)}</td>" if has_truth else "") + "</tr>")
    refused = ident.get("windows_refused_alias", 0)
    limit = ident.get("speed_limit_rad_s")
    parts = [f"<p>{ident.get('windows_used', 0)} filter windows used of {ident.get('windows', 0)}; "
             f"{refused} refused as too fast for the encoder-sampled cogging (above {_g(limit)} rad/s the highest "
             f"order, {ident.get('highest_order', '–')} per revolution, has fewer than "
             f"{_g(ident.get('min_samples_per_period'))} samples per period), {ident.get('windows_refused_slow', 0)} "
             "near standstill or reversing. Ridge "
             f"{_g(ident.get('ridge'))} ({html.escape(str(ident.get('ridge_chosen_by', '–')))}); J/k0 "
             f"{_g(ident.get('inertia_ratio'), 4)} A·s²/rad."
             + (f" {ident['rounds']} round(s) of running logs." if "rounds" in ident else "") + "</p>"]
    for label, text in (("Angle", pll_text(ident.get("angle_pll"))), ("Timing", delay_text(ident.get("current_delay"))),
                        ("Rig", lines_text(ident.get("time_lines"))), ("Voltage", voltage_text(ident.get("back_emf"))),
                        ("Drive offset", offset_text(ident.get("back_emf"))),
                        ("Current report", filter_text(ident.get("current_filter"))),
                        ("Power-ups", offsets_text(ident.get("index_offsets") or [])),
                        ("Alias guard", orders_text(ident.get("orders_not_resolved"))),
                        ("Over the angle", over_the_angle_text(ident.get("orders_over_the_angle")))):
        if text:
            parts.append(f"<p>{label}: {html.escape(text)}.</p>")
    quant = ident.get("quantisation") or {}
    if quant.get("logs_on_lattice"):
        parts.append(f"<p>The logged angle sits on an encoder's lattice of "
                     f"{html.escape('/'.join(map(str, quant['counts_per_revolution'])))} counts per revolution "
                     f"({quant['logs_on_lattice']} of {quant['logs']} logs). Its quantisation noise, "
                     f"{share_text(quant['noise_share'])} of the acceleration "
                     "the maps and friction do not explain, is taken "
                     "out of the normal equations (errors in variables), so that it does not pull J/k0 down and the "
                     "maps with it" + ("; the correction was capped: the logs hardly carry the rotor's acceleration "
                                       "above the encoder's noise (log accelerations or a dither)"
                                       if quant.get("correction_capped") else "") + ".</p>")
    det = r.get("slots_detected")
    if det:
        others = [q for q in det.get("slots_with_that_fundamental", []) if q != det["slots"]]
        read = det.get("read_with") or {}
        how = []  # what the count was taken on, where the logs were not read as written
        if read.get("angle_pll_rad_s"):
            how.append(f"the angle read through a PLL of {read['angle_pll_rad_s']:.4g} rad/s")
        if read.get("current_delay"):
            how.append(f"the current shifted by {read['current_delay']} sample(s)")
        if read.get("current_lag") is not None:
            how.append(f"the current read as the smooth curve through its snapshots, {read['current_lag']:.3g} sample "
                       "late")
        held = det.get("chosen_by") == "held-out blocks"
        parts.append("<p>Slot count not in the motor description: " + ("the held-out time blocks of the logs" if held
                                                                       else "the logs")
                     + (f" ({html.escape(', '.join(how))})" if how else "")
                     + (" are predicted best with" if held else " show") + " a cogging fundamental of"
                     + f" {det['cogging_fundamental']} per revolution (orders seen, "
                     f"strongest first: {html.escape(', '.join(map(str, det.get('orders_seen', [])[:8])))}), taken as "
                     f"{det['slots']} slots" + (f"; {html.escape(', '.join(map(str, others)))} slots have the same "
                                                "fundamental (set <code>slots</code> in the motor TOML if you know it)"
                                                if others else "")
                     + (f"; {html.escape(held_out_text(det))}" if det.get("held_out") else "")
                     + (f"; {html.escape(over_the_angle_count_text(det))}" if over_the_angle_count_text(det) else "")
                     + ".</p>")
    added = ident.get("orders_added") or {}
    if ident.get("orders_screened"):
        found = "; ".join(f"{k} {', '.join(map(str, v))}" for k, v in added.items() if v)
        parts.append("<p>Orders outside the slot/pole basis that the logs resolve (added to the model): "
                     + (html.escape(found) if found else "none") + ".</p>")
    elif "orders_screened" in ident:
        parts.append("<p>Orders outside the slot/pole basis were not screened: the logs have fewer than twice as "
                     "many windows as the full basis has unknowns.</p>")
    if rows:
        parts.append("<p>Standard error: the expected RMS error over the revolution from the noise (one-second "
                     "time blocks), relative to the map's RMS; a map is resolved when its error from the noise "
                     f"stays within {_pct(se.get('resolved_share'))} with probability "
                     f"{_pct(se.get('confidence'))}, together with the largest order outside the slot/pole basis "
                     "the screening would not have seen and the regularisation's bias.</p>"
                     "<table><tr><th>map</th><th>RMS</th><th>standard error</th><th>relative</th><th>resolved</th>"
                     + ("<th>error against the twin's truth</th>" if has_truth else "") + "</tr>" + "".join(rows)
                     + "</table>")
    return "".join(parts)


def _tracking_html(r: dict) -> str:
    tr, cm, sh = r["tracking_mse"], r["commutation_mse"], r["reducible_share"]
    body = "".join(
        f"<tr><th>{row}</th><td class=desc>{html.escape(ROW_DESCRIPTIONS.get(row, ''))}</td>"
        f"<td>{_g(v['position'])}</td><td>{_pct(sh[row]['position'])}</td><td>{_g(v['speed'])}</td>"
        f"<td>{_pct(sh[row]['speed'])}</td><td>{_g(cm[row]['position'])}</td></tr>" for row, v in tr.items())
    q = r["tracking_ratio_model_over_standstill"]
    a, t = r["standstill"]["agreement"], r["timing"]
    return (f"<p>Tracking error of the model's law over the standstill table's: position loop "
            f"<b>{q['position']:.2f}</b>, speed loop <b>{q['speed']:.2f}</b> (target ≤ 0.5).</p>"
            "<table><tr><th>row</th><th>law</th><th>position loop, MSE of θ* − θ [rad²]</th>"
            "<th>share of reducible</th><th>speed loop, MSE of ω* − ω at cruise [(rad/s)²]</th>"
            "<th>share of reducible</th><th>torque disturbance, position loop [A²]</th></tr>" + body + "</table>"
            f"<p>Running-log table against the standstill sweep: {_g(a['rms_model_minus_sweep_A'])} A RMS apart; the "
            f"sweep's own error against the truth {_g(a['rms_sweep_minus_truth_A'])} A "
            f"({'within' if a.get('within_noise') else 'not within'} the sweep's noise). Rig time: running logs "
            f"{t['running_logs_s']:.0f} s, standstill sweep {t['standstill_s']:.0f} s.</p>")


def _si_html(r: dict) -> str:
    """The model's scale in SI (``in_SI`` of ``identify``'s results), or nothing."""
    si = r.get("in_SI")
    if not si or si.get("inertia_kg_m2") is None:
        return ""
    return (f"<h2>In SI</h2><p>With k0 = {_g(si['torque_constant_Nm_per_A'], 4)} N·m/A "
            f"({html.escape(si['torque_constant_from'])}): cogging {_g(si['cogging_rms_Nm'])} N·m RMS, Coulomb "
            f"friction {_g(si['coulomb_Nm'])} N·m, viscous friction {_g(si['viscous_Nm_s_per_rad'])} N·m·s/rad, "
            f"moment of inertia of rotor and load {_g(si['inertia_kg_m2'], 4)} kg·m² (J/k0 times k0).</p>")


def _sweep_html(r: dict) -> str:
    """``identify --sweep``: the drives' table from the logged sweep against the model's."""
    sw = r.get("standstill_sweep")
    if not sw:
        return ""
    ratio = sw["rms_model_minus_sweep_A"] / sw["expected_rms_difference_A"] if sw["expected_rms_difference_A"] else \
        float("nan")
    return ("<h2>Against the drives' standstill sweep</h2>"
            f"<p>The logged sweep ({html.escape(', '.join(sw['logs']))}, {sw['seconds']:.0f} s of rig time) gives a "
            f"table of {sw['points']} bins ({_pct(sw['coverage'])} of the revolution in both directions), "
            f"{_g(sw['table_rms_A'])} A RMS with a noise of {_g(sw['noise_A'])} A. The model's table differs from it "
            f"by {_g(sw['rms_model_minus_sweep_A'])} A RMS, <b>{ratio:.2f}×</b> what the two noises give together "
            f"({_g(sw['expected_rms_difference_A'])} A, the sweep's and the model's standard error): "
            f"<b>{'within' if sw['within_noise'] else 'not within'}</b> the noise (factor "
            f"{_g(sw['agreement_factor'])}). Forward and reverse passes differ by "
            f"{_g(sw['rms_forward_minus_reverse_A'])} A RMS (friction and the direction-dependent torque)."
            + (" <code>standstill_table.csv</code> holds the sweep's table in the export's format."
               if sw.get("table_written") else "") + "</p>")


def write_rotary_report(path, results: dict, figures: dict, *, version: str = "") -> Path:
    """Write ``report.html`` for a rotary ``reproduce`` or ``identify`` run (atomically).

    Args:
        path: the file to write.
        results: the run's results dict (``results.json``; ``command`` says which).
        figures: caption -> PNG path, embedded in this order.
        version: pgcomm's version for the header.

    Returns:
        ``path``.
    """
    motor = results.get("motor", {})
    name = motor.get("name") or f"{motor.get('slots', '?')}N{2 * int(motor.get('pole_pairs', 0))}P"
    command = results.get("command", "reproduce")
    if command == "reproduce":
        title = f"Rotary motor {name} on the twin: running-log identification against the drives' standstill table"
        sections = ("<h2>Tracking, best law against the drives' method</h2>" + _tracking_html(results)
                    + "<h2>Identification from running logs (no torque sensor)</h2>" + _identification_html(results))
    else:
        t = results.get("table", {})
        title = f"Rotary motor {name}: maps identified from {len(results.get('logs', []))} drive log(s)"
        sections = ("<h2>Identification</h2>" + _identification_html(results)
                    + f"<h2>Compensation table</h2><p>{t.get('entries', '–')} entries over one revolution, "
                    f"{_g(t.get('rms_A'))} A RMS, {_g(t.get('peak_A'))} A peak; forward and reverse differ by "
                    f"{_g(t.get('forward_minus_reverse_rms_A'))} A RMS (the table holds their mean). "
                    "<code>compensation.csv</code> goes to <code>pgcomm export --format moteus|odrive|c-angle</code>; "
                    "the whole law, with the direction term and the ripple that a drive's table cannot hold, to "
                    "<code>pgcomm export --format c-rotary --model model.json</code>."
                    "</p>" + _si_html(results) + _sweep_html(results))
    figs = "".join(figure_html(Path(p), cap) for cap, p in figures.items())
    runtime = results.get("runtime_s")
    doc = (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>pgcomm {html.escape(command)} — "
           f"{html.escape(name)}</title>\n<style>\n{CSS}</style></head><body>\n<h1>{html.escape(title)}</h1>\n"
           f"<p>Generated by <code>pgcomm {html.escape(command)}</code> (version {html.escape(str(version))})"
           + (f" in {runtime:.0f} s" if runtime is not None else "")
           + ". All numbers are those of <code>results.json</code>.</p>\n" + sections + figs + "\n</body></html>\n")
    atomic_write_text(path, doc)
    return Path(path)
