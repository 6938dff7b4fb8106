"""What every report page shares: the style sheet and figures embedded as base64 PNG (a report opens anywhere)."""

from __future__ import annotations

import base64
import html
from pathlib import Path

__all__ = ["CSS", "figure_html"]

#: The reports' style sheet (:mod:`pgcomm.report.linear` and :mod:`pgcomm.report.rotary`).
CSS = """body { font-family: sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }
table { border-collapse: collapse; margin: 1em 0; }
th, td { border: 1px solid #bbb; padding: 4px 8px; text-align: right; }
th { font-size: 90%; }
td.desc { text-align: left; font-size: 90%; color: #555; min-width: 16em; }
tr.rec { background: #e8f5e9; }
figure { margin: 1.5em 0; } img { max-width: 100%; }
figcaption { font-size: 90%; color: #555; }
"""


def figure_html(path: Path, caption: str) -> str:
    """A PNG embedded as base64 in a ``<figure>`` with its caption (the report opens anywhere)."""
    return _img(Path(path), caption)


def _img(path: Path, caption: str) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return (f'<figure><img src="data:image/png;base64,{data}" alt="{html.escape(caption)}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")
