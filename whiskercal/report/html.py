"""A self-contained HTML page: inline CSS, figures as base64 PNG data URIs, no external resources."""

from __future__ import annotations

import base64
import html
import math
from dataclasses import dataclass
from typing import Any, Sequence

STYLE = """
body { font-family: sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }
h1 { border-bottom: 2px solid #444; } h2 { margin-top: 2em; border-bottom: 1px solid #aaa; }
table { border-collapse: collapse; margin: 0.5em 0 1em; font-size: 0.9em; }
th, td { border: 1px solid #bbb; padding: 3px 8px; text-align: right; }
th { background: #eee; } td.text { text-align: left; }
figure { margin: 1em 0; } figcaption { font-size: 0.85em; color: #555; }
img { max-width: 100%; border: 1px solid #ddd; }
.note { color: #555; font-size: 0.9em; } .fail { color: #b00; }
"""


@dataclass(frozen=True)
class Section:
    """One titled part of the report; ``body`` is trusted HTML built by this module's helpers."""

    title: str
    body: str


def esc(value: Any) -> str:
    """Text escaped for HTML."""
    return html.escape(str(value))


def fmt(value: Any, digits: int = 4) -> str:
    """A number in a few significant digits; other values as text."""
    if isinstance(value, bool) or value is None:
        return esc(value)
    if isinstance(value, (int, float)):
        if isinstance(value, float) and not math.isfinite(value):
            return "–"
        return esc(f"{value:.{digits}g}")
    return esc(value)


def figure(png: bytes, caption: str) -> str:
    """An <img> with the PNG inline as a data URI, and its caption."""
    data = base64.b64encode(png).decode("ascii")
    return (f'<figure><img src="data:image/png;base64,{data}" alt="{esc(caption)}">'
            f"<figcaption>{esc(caption)}</figcaption></figure>")


def table(rows: Sequence[dict], columns: Sequence[str]) -> str:
    """An HTML table of ``rows`` (dicts) showing ``columns``, headed by the column names."""
    head = "".join(f"<th>{esc(column)}</th>" for column in columns)
    body = []
    for row in rows:
        cells = []
        for column in columns:
            value = row.get(column)
            css = ' class="text"' if isinstance(value, str) else ""
            cells.append(f"<td{css}>{fmt(value)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><tr>{head}</tr>{''.join(body)}</table>"


def key_values(pairs: dict) -> str:
    """A two-column table of names and values."""
    return table([{"name": k, "value": v if isinstance(v, (int, float)) else str(v)}
                  for k, v in pairs.items()], ["name", "value"])


def paragraph(text: str, css: str = "note") -> str:
    """A paragraph of escaped text."""
    return f'<p class="{css}">{esc(text)}</p>'


def render(title: str, sections: Sequence[Section]) -> str:
    """The whole page."""
    parts = [f"<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
             f"<title>{esc(title)}</title><style>{STYLE}</style></head><body>",
             f"<h1>{esc(title)}</h1>"]
    parts.append("<ul>" + "".join(f'<li><a href="#s{k}">{esc(s.title)}</a></li>'
                                  for k, s in enumerate(sections)) + "</ul>")
    for k, section in enumerate(sections):
        parts.append(f'<section id="s{k}"><h2>{esc(section.title)}</h2>{section.body}</section>')
    parts.append("</body></html>")
    return "\n".join(parts)
