"""The pieces of every notebook summary (``_repr_html_``): a table, a list of names.

A notebook cell that ends in a Model, Equations or a compiled model shows a small
table: sizes, the symbols in array order, operation counts, the outputs; never
the matrices (``M`` of a 32-link model is pages of text).  Each summary lives
beside its class (:mod:`mbgen.model.summary`, :func:`mbgen.symbolic.equations.equations_html`,
:func:`mbgen.runtime.compiled.compiled_html`) and is built from :func:`table` and
:func:`names` here: long symbol lists are shortened to their first and last
entries, and every name is HTML-escaped.
"""

from __future__ import annotations

import html
from collections.abc import Iterable, Sequence

#: Symbol lists longer than this show their first and last few names.
MAX_NAMES = 12


def names(items: Iterable) -> str:
    """``a, b, c`` (escaped); long lists as ``a, b, ..., y, z (40)``."""
    items = [str(i) for i in items]
    if not items:
        return "<i>none</i>"
    if len(items) > MAX_NAMES:
        shown = items[:MAX_NAMES // 2] + ["..."] + items[-3:]
        return html.escape(", ".join(shown)) + f" ({len(items)})"
    return html.escape(", ".join(items))


def table(title: str, rows: Sequence[tuple[str, str]]) -> str:
    """An HTML table: a caption and ``(label, cell html)`` rows (labels are escaped)."""
    body = "".join(f"<tr><th style=\"text-align:left\">{html.escape(k)}</th>"
                   f"<td style=\"text-align:left\">{v}</td></tr>" for k, v in rows)
    return (f"<table><caption style=\"text-align:left\"><b>{html.escape(title)}</b></caption>"
            f"{body}</table>")


__all__ = ["MAX_NAMES", "names", "table"]
