"""The fleet's outputs: ``fleet.parquet`` / ``fleet.csv`` (the rows) and ``fleet.html`` (the distributions of
the QA quantities with the outliers marked).
"""

from __future__ import annotations

import base64
import html
from pathlib import Path

import numpy as np

from pgcomm.defaults import DEFAULT_OUTLIER_Z
from pgcomm.fleet.motor import COLUMNS, QA_QUANTITIES
from pgcomm.fleet.qa import flag_outliers
from pgcomm.io.atomic import atomic_path, atomic_write_text

_LABELS = {"k": "k (N/A)", "zeta": "zeta (rad)", "cogging_pp": "cogging amplitude, peak-to-peak in y (N)",
           "improvement": "improvement cost_physics / cost_pgnn (-)"}


def write_fleet_html(path, rows, threshold: float = DEFAULT_OUTLIER_Z) -> Path:
    """``fleet.html``: histograms of :data:`QA_QUANTITIES` (PNG embedded), outliers marked, a table of them, failures.

    Returns:
        ``path``.
    """
    # start-up cost: Matplotlib loads when the page is drawn, not in every fleet worker that imports pgcomm.fleet
    from pgcomm.plots import plot_quantity_histogram, png_bytes

    flags = flag_outliers(rows, threshold)
    ok = [r for r in rows if r.get("status") == "ok"]
    failed = [r for r in rows if r.get("status") != "ok"]
    esc = html.escape
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>pgcomm fleet</title></head><body>",
             f"<h1>pgcomm fleet: {len({r['motor'] for r in rows})} motors</h1>",
             f"<p>{len({r['motor'] for r in ok})} ok ({len(ok)} coil sets), {len(failed)} failed. Outliers: robust "
             f"z-score |z| &gt; {threshold:g} (median and MAD &middot; 1.4826 across the fleet).</p>"]
    for q in QA_QUANTITIES:
        x = np.array([np.nan if r.get(q) is None else r[q] for r in ok], dtype=float)
        x = x[np.isfinite(x)]
        out = [f["value"] for f in flags if f["quantity"] == q]
        fig = plot_quantity_histogram(x, out, _LABELS[q], f"{q}: {x.size} values, {len(out)} outlier(s) (red)")
        parts.append(f"<h2>{esc(_LABELS[q])}</h2><img src='data:image/png;base64,"
                     f"{base64.b64encode(png_bytes(fig)).decode()}'>")
    parts.append("<h2>Outliers: which motor is unlike the others, and in what</h2>")
    if flags:
        parts.append("<table border='1' cellpadding='3'><tr><th>motor</th><th>coil set</th><th>quantity</th>"
                     "<th>value</th><th>fleet median</th><th>robust z</th></tr>")
        for f in flags:
            parts.append(f"<tr><td>{esc(f['motor'])}</td><td>{f['coil_set']}</td><td>{esc(f['quantity'])}</td>"
                         f"<td>{f['value']:.6g}</td><td>{f['median']:.6g}</td><td>{f['z']:+.2f}</td></tr>")
        parts.append("</table>")
    else:
        parts.append("<p>none</p>")
    parts.append("<h2>Failed motors</h2>")
    if failed:
        parts.append("<table border='1' cellpadding='3'><tr><th>motor</th><th>error</th></tr>")
        parts += [f"<tr><td>{esc(r['motor'])}</td><td>{esc(r['error'] or '')}</td></tr>" for r in failed]
        parts.append("</table>")
    else:
        parts.append("<p>none</p>")
    parts.append("</body></html>\n")
    atomic_write_text(path, "\n".join(parts))
    return Path(path)


def write_fleet_table(out_dir, rows, threshold: float = DEFAULT_OUTLIER_Z) -> list[Path]:
    """Write ``fleet.parquet``, ``fleet.csv`` (columns :data:`COLUMNS`) and ``fleet.html`` atomically.

    Returns:
        the three paths.
    """
    import pyarrow as pa  # start-up cost: PyArrow loads only when this runs
    import pyarrow.csv as pacsv  # start-up cost: PyArrow loads only when this runs
    import pyarrow.parquet as pq  # start-up cost: PyArrow loads only when this runs

    out_dir = Path(out_dir)
    types = {"motor": pa.string(), "coil_set": pa.int64(), "status": pa.string(), "error": pa.string()}
    table = pa.table({c: pa.array([r.get(c) for r in rows], type=types.get(c, pa.float64())) for c in COLUMNS})
    with atomic_path(out_dir / "fleet.parquet") as tmp:
        pq.write_table(table, str(tmp))
    with atomic_path(out_dir / "fleet.csv") as tmp:
        pacsv.write_csv(table, str(tmp))
    html_path = write_fleet_html(out_dir / "fleet.html", rows, threshold)
    return [out_dir / "fleet.parquet", out_dir / "fleet.csv", html_path]
