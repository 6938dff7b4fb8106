"""``pgcomm inspect``: what a model file holds (structure, training range, costs, provenance)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from pgcomm.cli._common import add_common_options
from pgcomm.io.results import to_jsonable

# Imports inside the functions below: JAX, SciPy and Matplotlib load only when the command runs; every
# command's parser is built by `import pgcomm.cli`, which loads none of them (`--help` and a bad option answer at once).

HELP = ("What a model file holds: structure (L, widths, activation, parameters), pole pitch, "
        "training range, costs per coil set, seed, version, date, file sizes.")


def configure(p) -> None:
    """Options of ``pgcomm inspect``."""
    p.add_argument("--model", required=True, type=Path, metavar="M", help="model file written by pgcomm identify")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    add_common_options(p, out=False, plant=False)  # --quiet, which cli.main expects of every command


def run(args, out, progress) -> None:
    """Print the summary of ``--model`` (text, or JSON with ``--json``)."""
    from pgcomm.io.model import load_model

    model, document = load_model(args.model)
    info = model_summary(model, document, args.model)
    if args.json:
        print(json.dumps(to_jsonable(info), indent=2, ensure_ascii=False))
    else:
        print(format_summary(info))



def _n_params(tree) -> int:
    import jax

    return int(sum(np.size(x) for x in jax.tree_util.tree_leaves(tree)))


def _widths(net) -> list[int] | None:
    """Hidden widths of a stacked :class:`~pgcomm.models.MLP` (leading coil-set dims ignored)."""
    return None if net is None else [int(b.shape[-1]) for _, b in net.hidden]


def model_summary(model, document: dict, path) -> dict:
    """JSON-ready description of a combined model and its file's document (:func:`pgcomm.io.model.load_model`).

    Keys: ``file``, ``files`` (name -> bytes: the JSON and its ``.npz``), ``structure``
    (``coil_sets``, ``gain_widths``, ``cog_widths``, ``activation``, ``parameters_per_coil_set``
    split into ``physics`` (``A, B``: 12), ``gain_networks``, ``cogging_network`` and ``total``;
    ``parameters_total``), ``pole_pitch`` (m), ``training_range`` (m, covered by every coil
    set) and ``training_range_per_coil_set``, ``costs`` (per coil set, from the metadata's
    ``identification``), ``seed``, ``version`` (package that wrote the file), ``date``,
    ``schema`` and the remaining ``metadata``.
    """
    if getattr(model, "gain_table", None) is not None:
        return spline_summary(model, document, path)
    L = model.n_coil_sets
    per_gain = _n_params(model.gain_nets) // L if model.gain_nets is not None else 0
    per_cog = _n_params(model.cog_nets) // L if model.cog_nets is not None else 0
    n_phy = int(np.size(model.A) + np.size(model.B)) // L
    net = model.gain_nets if model.gain_nets is not None else model.cog_nets
    n_harm = int(np.size(model.H)) // L if model.H is not None else 0
    n_dir = int(np.size(model.C)) // L if model.C is not None else 0
    per_cs = {"physics": n_phy, "gain_networks": per_gain, "cogging_network": per_cog,
              "harmonics": n_harm, "direction": n_dir, "total": n_phy + per_gain + per_cog + n_harm + n_dir}
    extensions = {"harmonics": model.H is not None,
                  "direction": None if model.C is None else {
                      "velocity": float(model.direction_velocity),
                      "C": [[float(x) for x in row] for row in np.asarray(model.C)]},
                  "identification": document.get("identification", "force_sensor")}
    ranges = None
    if model.y_min is not None and model.y_max is not None:
        ranges = [[float(a), float(b)] for a, b in zip(model.y_min, model.y_max)]
    meta = document.get("metadata") or {}
    ident = meta.get("identification") or {}
    keys = ("cost_physics", "cost_pgnn", "cost_physics_validation", "cost_pgnn_validation", "iterations", "seconds",
            "n_train", "n_validation", "stop_reason")
    costs = [{"coil_set": l + 1, **{k: c[k] for k in keys if k in c}}
             for l, c in enumerate(ident.get("coil_sets") or []) if isinstance(c, dict)]
    return {
        "file": str(path),
        "files": _file_sizes(path, document.get("arrays")),
        "schema": document.get("schema"),
        "structure": {"coil_sets": L, "gain_widths": _widths(model.gain_nets), "cog_widths": _widths(model.cog_nets),
                      "activation": None if net is None else net.activation,
                      "parameters_per_coil_set": per_cs, "parameters_total": L * per_cs["total"]},
        "extensions": extensions,
        "pole_pitch": float(model.pole_pitch),
        "training_range": None if model.training_range is None else list(model.training_range),
        "training_range_per_coil_set": ranges,
        "costs": costs,
        "seed": meta.get("seed"),
        "version": document.get("package_version"),
        "date": document.get("created"),
        "metadata": {k: v for k, v in meta.items() if k not in ("identification", "seed")},
    }


def _grid(knots) -> dict:
    """``{"knots", "lo", "hi", "spacing"}`` (m) of a uniform knot vector."""
    k = np.asarray(knots, float)
    return {"knots": int(k.size), "lo": float(k[0]), "hi": float(k[-1]),
            "spacing": float((k[-1] - k[0]) / (k.size - 1))}


def spline_summary(model, document: dict, path) -> dict:
    """JSON-ready description of a spline model file (schema ``pgcomm-model/3``).

    Keys: ``file``, ``files``, ``schema``, ``family`` (``"spline"``), ``structure`` (``coil_sets``,
    ``grids``: per table ``gain``, ``cogging``, ``direction`` its knots, ends and spacing (m),
    ``parameters`` per table and ``parameters_total``), ``pole_pitch`` (m), ``training_range``
    (m), ``direction_velocity`` (m/s, or ``None``), ``mechanics`` (mass kg, viscous N s/m, Coulomb
    table knots and spacing m, mean/min/max N; or ``None``), ``identification``, ``version``,
    ``date`` and ``metadata``.
    """
    grids = {"gain": _grid(model.gain_knots), "cogging": _grid(model.cog_knots)}
    params = {"gain": int(np.size(model.gain_table)), "harmonics": int(np.size(model.H)),
              "cogging": int(np.size(model.cog_table)), "direction": 0}
    if model.dir_table is not None:
        grids["direction"] = _grid(model.dir_knots)
        params["direction"] = int(np.size(model.dir_table))
    mech = document.get("mechanics")
    mech_info = None
    if isinstance(mech, dict):
        table = np.asarray(mech.get("coulomb_table") or [0.0], float)
        mech_info = {"mass": mech.get("mass"), "viscous": mech.get("viscous"),
                     "direction_velocity": mech.get("direction_velocity"),
                     "coulomb": {**_grid(mech["coulomb_knots"]), "mean": float(table.mean()),
                                 "min": float(table.min()), "max": float(table.max())}
                     if mech.get("coulomb_knots") else None}
    meta = document.get("metadata") or {}
    return {
        "file": str(path),
        "files": _file_sizes(path, document.get("arrays")),
        "schema": document.get("schema"),
        "family": "spline",
        "structure": {"coil_sets": model.n_coil_sets, "grids": grids, "parameters": params,
                      "parameters_total": int(model.n_parameters)},
        "pole_pitch": float(model.pole_pitch),
        "training_range": None if model.training_range is None else list(model.training_range),
        "direction_velocity": float(model.direction_velocity) if model.dir_table is not None else None,
        "mechanics": mech_info,
        "identification": document.get("identification", "force_sensor"),
        "version": document.get("package_version"),
        "date": document.get("created"),
        "metadata": meta,
    }


def format_spline_summary(info: dict) -> str:
    """Readable text of :func:`spline_summary`."""
    s = info["structure"]
    lines = [f"model {info['file']}",
             f"  files:          {', '.join(f'{k} ({_bytes(v)})' for k, v in info['files'].items()) or '-'}",
             f"  schema:         {_or_dash(info['schema'])}",
             "  family:         spline (physics-guided tables on uniform knots)",
             f"  coil sets L:    {s['coil_sets']}"]
    for name, g in s["grids"].items():
        lines.append(f"  {name + ' knots:':15s} {g['knots']} on [{g['lo']:.4g}, {g['hi']:.4g}] m, "
                     f"spacing {1e3 * g['spacing']:.4g} mm")
    p = s["parameters"]
    lines.append(f"  parameters:     {s['parameters_total']} (gain {p['gain']}, harmonics {p['harmonics']}, "
                 f"cogging {p['cogging']}, direction {p['direction']})")
    lines.append(f"  pole pitch:     {info['pole_pitch']:.6g} m")
    dv = info["direction_velocity"]
    lines.append("  direction term: " + ("off" if dv is None else
                                          f"C(y) s(v), s = tanh(v / {dv:g} m/s); the law needs a velocity"))
    tr = info["training_range"]
    lines.append("  training range: " + ("unknown" if tr is None else f"[{tr[0]:.4g}, {tr[1]:.4g}] m (all coil sets)"))
    m = info["mechanics"]
    if m is None:
        lines.append("  mechanics:      not stored (no feedforward in the file)")
    else:
        c = m["coulomb"]
        lines.append(f"  mechanics:      m = {m['mass']:.4g} kg, f_v = {m['viscous']:.4g} N s/m"
                     + ("" if c is None else f", Coulomb table D(r) {c['knots']} knots every "
                        f"{1e3 * c['spacing']:.4g} mm, {c['min']:.3g} .. {c['max']:.3g} N (mean {c['mean']:.3g} N)"))
        lines.append("  feedforward:    u_ff[k] = (g[k] + g[k+1]) / 2, g = m a_r + f_v v_r + D(r) sign(v_r)")
    lines += [f"  identified:     {info['identification'].replace('_', ' ')}",
              f"  version:        {_or_dash(info['version'])}",
              f"  date:           {_or_dash(info['date'])}"]
    for k, v in info["metadata"].items():
        if isinstance(v, (str, int, float, bool)) or v is None:
            lines.append(f"  {k + ':':15s} {v}")
    return "\n".join(lines)


def _file_sizes(path, arrays_name) -> dict:
    """Bytes of the model's JSON and of the array file it names (name -> bytes)."""
    from pgcomm.io.model import model_paths

    js, npz = model_paths(path)
    files = [js, js.with_name(str(arrays_name)) if arrays_name else npz]
    return {f.name: f.stat().st_size for f in files if f.is_file()}


def format_summary(info: dict) -> str:
    """Readable text of :func:`model_summary`."""
    if info.get("family") == "spline":
        return format_spline_summary(info)
    s = info["structure"]
    pc = s["parameters_per_coil_set"]
    lines = [f"model {info['file']}",
             f"  files:          {', '.join(f'{k} ({_bytes(v)})' for k, v in info['files'].items()) or '-'}",
             f"  schema:         {_or_dash(info['schema'])}",
             f"  coil sets L:    {s['coil_sets']}",
             f"  gain networks:  {_fmt_widths(s['gain_widths'])}   cogging network: {_fmt_widths(s['cog_widths'])}"
             f"   activation: {s['activation'] or '-'}",
             f"  parameters:     {pc['total']} per coil set (A, B {pc['physics']}, gain networks "
             f"{pc['gain_networks']}, cogging {pc['cogging_network']}); {s['parameters_total']} in total",
             f"  pole pitch:     {info['pole_pitch']:.6g} m"]
    ext = info.get("extensions") or {}
    d = ext.get("direction")
    lines.append(f"  harmonics:      {'5th and 7th (' + str(pc.get('harmonics', 0)) + ' parameters per coil set)' if ext.get('harmonics') else 'off'}")
    lines.append("  direction term: " + ("off" if d is None else
                                          f"C s(v), s = tanh(v / {d['velocity']:g} m/s); C_y per coil set "
                                          + ", ".join(f"{c[0]:.4g}" for c in d["C"]) + " N; the law needs a velocity"))
    lines.append(f"  identified:     {'without a force sensor (y row; x/z classical)' if ext.get('identification') == 'no_force_sensor' else 'with a force sensor'}")
    tr = info["training_range"]
    lines.append("  training range: " + ("unknown" if tr is None else f"[{tr[0]:.4g}, {tr[1]:.4g}] m (all coil sets)"))
    for l, r in enumerate(info["training_range_per_coil_set"] or []):
        lines.append(f"                  coil set {l + 1}: [{r[0]:.4g}, {r[1]:.4g}] m")
    if info["costs"]:
        lines.append(f"  {'coil set':>8s} {'V physics':>11s} {'V PGNN':>11s} {'V phys val':>11s} {'V PGNN val':>11s}")
        for c in info["costs"]:
            cells = [_num(c.get(k)) for k in ("cost_physics", "cost_pgnn", "cost_physics_validation",
                                              "cost_pgnn_validation")]
            lines.append(f"  {c['coil_set']:8d} {cells[0]:>11s} {cells[1]:>11s} {cells[2]:>11s} {cells[3]:>11s}")
    else:
        lines.append("  costs:          not recorded")
    lines += [f"  seed:           {_or_dash(info['seed'])}",
              f"  version:        {_or_dash(info['version'])}",
              f"  date:           {_or_dash(info['date'])}"]
    for k, v in info["metadata"].items():
        if isinstance(v, (str, int, float, bool)) or v is None:
            lines.append(f"  {k + ':':15s} {v}")
    ff = info["metadata"].get("feedforward")
    if isinstance(ff, dict) and all(isinstance(ff.get(k), (int, float)) for k in ("mass", "viscous", "coulomb")):
        lines.append(f"  feedforward:    m = {ff['mass']:.4g} kg, f_v = {ff['viscous']:.4g} N s/m, "
                     f"f_c = {ff['coulomb']:.4g} N (mechanics identified without a force sensor)")
    return "\n".join(lines)


def _fmt_widths(w) -> str:
    return "none" if w is None else "x".join(map(str, w))


def _num(v) -> str:
    return "-" if v is None else f"{v:.5g}"


def _or_dash(v) -> str:
    return "-" if v is None else str(v)


def _bytes(n: int) -> str:
    return f"{n} B" if n < 1024 else f"{n / 1024:.1f} KiB" if n < 1024**2 else f"{n / 1024**2:.1f} MiB"
