"""The report as a short markdown summary that links the image files written next to it.

Meant for READMEs and pull requests: the table and the headline plots render on any git host.
"""

from __future__ import annotations

from .content import Report


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def table(headers: list[str], rows: list[list[str]]) -> str:
    """A GitHub-flavoured markdown table: names (the first two columns) left, numbers right."""
    align = ["---" if i < 2 else "--:" for i in range(len(headers))]
    lines = ["| " + " | ".join(_cell(h) for h in headers) + " |", "|" + "|".join(align) + "|"]
    lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def render_markdown(report: Report) -> str:
    """Title, notes, run facts, the per-designer table, the figures and the definitions."""
    out = [f"# {report.title}", ""]
    if report.notes:
        out += [f"> **Note:** {n}" for n in report.notes] + [""]
    out += [f"- **{k}:** {_cell(v)}" for k, v in report.facts] + [""]
    out += ["## Summary per designer", "", table(report.headers, report.rows), ""]
    for section in report.sections:
        out += [f"## {section.title}", ""]
        if section.intro:
            out += [section.intro, ""]
        for text in section.paragraphs:
            out += [text, ""]
        for t in section.tables:
            out += [f"**{t.title}**", "", table(t.headers, t.rows), ""] + ([f"*{t.caption}*", ""] if t.caption else [])
        for fig in section.figures:
            out += [f"![{fig.title}]({fig.filename})", "", f"*{fig.title}.* {fig.caption}", ""]
    if report.definitions:
        out += ["## How the numbers are computed", ""]
        out += [f"- **{term}:** {text}" for term, text in report.definitions] + [""]
    if report.tables:
        out += ["## Tables", ""] + [f"- [`{name}`]({name}): {what}" for name, what in report.tables] + [""]
    return "\n".join(out)
