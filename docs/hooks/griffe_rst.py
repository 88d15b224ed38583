"""Griffe extension for the API reference: gdabench's reST-flavoured docstrings shown as Markdown.

The docstrings are written for plain reading, with Sphinx roles (:class:`Name`), ``literals`` and
"example::" blocks, and attributes documented by ``#:`` comments above them, as Sphinx's autodoc
reads them.  mkdocstrings renders Markdown and knows no ``#:`` comments, so this extension:

* turns a role into inline code: ``:class:`~a.b.Name``` becomes ```Name```, ``:mod:`a.b``` ```a.b```;
* turns a trailing ``::`` into ``:`` (the indented block after it is a code block in Markdown too);
* gives an attribute without a docstring the text of the ``#:`` comment lines just above it.

The docstrings themselves stay as they are.
"""

from __future__ import annotations

import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:class|meth|func|mod|attr|data|exc|obj):`(~?)([^`]+)`")
LITERAL_MARKER = re.compile(r"(?<=\S)::$", re.MULTILINE)


def _markdown(text: str) -> str:
    text = ROLE.sub(lambda m: f"`{m.group(2).rsplit('.', 1)[-1] if m.group(1) else m.group(2)}`", text)
    return LITERAL_MARKER.sub(":", text)


def _comment_above(attr: griffe.Attribute) -> str | None:
    """The ``#:`` comment lines directly above the attribute's first line, joined."""
    if attr.lineno is None:
        return None
    try:
        lines = attr.module.lines
    except Exception:  # noqa: BLE001 - no source (compiled module): nothing to read
        return None
    found: list[str] = []
    index = attr.lineno - 2  # the line above, 0-based
    while index >= 0 and lines[index].strip().startswith("#:"):
        found.insert(0, lines[index].strip()[2:].strip())
        index -= 1
    return " ".join(found) or None


class RestToMarkdown(griffe.Extension):
    def on_attribute_instance(self, *, attr: griffe.Attribute, **kwargs: Any) -> None:
        if attr.docstring is None:
            comment = _comment_above(attr)
            if comment:
                attr.docstring = griffe.Docstring(_markdown(comment), lineno=attr.lineno, parent=attr)

    def on_instance(self, *, obj: Any, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = _markdown(obj.docstring.value)
