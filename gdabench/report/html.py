"""The report as one self-contained HTML file: styles inline, images as data URIs.

Nothing is loaded from elsewhere (no scripts, fonts, stylesheets or linked images), so the file
can be mailed, archived or opened offline and always shows the same thing.
"""

from __future__ import annotations

import base64
from html import escape

from .content import Figure, Report, Table

STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto; max-width: 1200px;
       padding: 0 1em; color: #222; line-height: 1.45; }
h1 { font-size: 1.6em; } h2 { border-bottom: 1px solid #ddd; padding-bottom: .2em; margin-top: 2em; }
table { border-collapse: collapse; margin: 1em 0; font-size: .92em; }
th, td { border: 1px solid #ccc; padding: .3em .6em; text-align: right; vertical-align: top; }
th { background: #f3f3f3; } td:first-child, th:first-child { text-align: left; }
table.facts td { text-align: left; } table.facts td:first-child { font-weight: 600; white-space: nowrap; }
.notes { background: #fff7e0; border-left: 4px solid #f0b400; padding: .5em 1em; }
figure { margin: 1.5em 0; } figure img { max-width: 100%; border: 1px solid #eee; }
figcaption { font-size: .9em; color: #555; } dt { font-weight: 600; margin-top: .5em; }
code { background: #f5f5f5; padding: 0 .2em; } p.caption { font-size: .9em; color: #555; margin-top: -.5em; }
"""


def data_uri(data: bytes, mime: str) -> str:
    return f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"


def _table(headers: list[str], rows: list[list[str]], css: str = "") -> str:
    head = "".join(f"<th>{escape(h)}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{escape(c)}</td>" for c in row) + "</tr>" for row in rows)
    cls = f' class="{css}"' if css else ""
    return (
        f"<table{cls}><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
        if headers
        else f"<table{cls}><tbody>{body}</tbody></table>"
    )


def _figure(fig: Figure) -> str:
    return (
        f'<figure><img alt="{escape(fig.title)}" src="{data_uri(fig.data, fig.mime)}">'
        f"<figcaption><b>{escape(fig.title)}.</b> {escape(fig.caption)}</figcaption></figure>"
    )


def _captioned(table: Table) -> str:
    caption = f" {escape(table.caption)}" if table.caption else ""
    return (
        f"<h3>{escape(table.title)}</h3>"
        + _table(table.headers, table.rows)
        + (f'<p class="caption">{caption.strip()}</p>' if caption else "")
    )


def render_html(report: Report) -> str:
    """The whole report page."""
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{escape(report.title)}</title><style>{STYLE}</style></head><body>",
        f"<h1>{escape(report.title)}</h1>",
    ]
    if report.notes:
        parts.append('<div class="notes"><ul>' + "".join(f"<li>{escape(n)}</li>" for n in report.notes) + "</ul></div>")
    parts.append("<h2>Run</h2>" + _table([], [[k, v] for k, v in report.facts], "facts"))
    parts.append("<h2>Summary per designer</h2>" + _table(report.headers, report.rows))
    for section in report.sections:
        parts.append(f"<h2>{escape(section.title)}</h2>")
        if section.intro:
            parts.append(f"<p>{escape(section.intro)}</p>")
        parts.extend(f"<p>{escape(text)}</p>" for text in section.paragraphs)
        parts.extend(_captioned(t) for t in section.tables)
        parts.extend(_figure(f) for f in section.figures)
    if report.definitions:
        parts.append("<h2>How the numbers are computed</h2><dl>")
        parts.extend(f"<dt>{escape(term)}</dt><dd>{escape(text)}</dd>" for term, text in report.definitions)
        parts.append("</dl>")
    if report.tables:
        parts.append("<h2>Tables next to this file</h2><ul>")
        parts.extend(f"<li><code>{escape(name)}</code>: {escape(what)}</li>" for name, what in report.tables)
        parts.append("</ul>")
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"
