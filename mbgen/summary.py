"""Notebook summaries (``_repr_html_``) of a Model, Equations and a CompiledModel.

A notebook cell that ends in one of these objects shows a small table: sizes,
the symbols in array order, operation counts, the outputs; never the matrices
(``M`` of a 32-link model is pages of text).  Long symbol lists are shortened
to their first and last entries.  Every name is HTML-escaped.

The summary of ``Equations`` is :func:`mbgen.symbolic.equations.equations_html`.
"""

from __future__ import annotations

import html
import re
from typing import Iterable, Sequence

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


def model_html(m) -> str:
    """Summary of an :class:`mbgen.Model`."""
    loads = {}
    for ld in m.loads:
        loads[type(ld).__name__] = loads.get(type(ld).__name__, 0) + 1
    rows = [("coordinates", f"{len(m.coordinates_)}: {names(s.func for s in m.coordinates_)}"),
            ("speeds", f"{len(m.speeds_)}: {names(s.func for s in m.speeds_)}"),
            ("constants", f"{len(m.constants_)}: {names(m.constants_)}"),
            ("inputs", f"{len(m.inputs_)}: {names(s.func for s in m.inputs_)}"),
            ("frames", f"{len(m.frames)}: {names(f.name for f in m.frames)}"),
            ("points", f"{len(m.points)}: {names(p.name for p in m.points)}"),
            ("particles", f"{len(m.particles)}: {names(p.name for p in m.particles)}"),
            ("rigid bodies", f"{len(m.bodies)}: {names(b.name for b in m.bodies)}"),
            ("loads", html.escape(", ".join(f"{n} x{k}" for n, k in loads.items()) or "none"))]
    if m.constraints_:
        rows.append(("constraints", f"{len(m.constraints_)}: {names(c.name for c in m.constraints_)}"))
    if m.kinematic_equations_:
        rows.append(("kinematic equations", f"{len(m.kinematic_equations_)} given"))
    return table(f"Model {m.name!r}", rows)


def compiled_html(model) -> str:
    """Summary of a :class:`mbgen.CompiledModel` (ABI sizes, outputs, operation counts)."""
    rendered = model.rendered
    ops = re.search(r"Operations: (\d+) after CSE \((\d+) before\)", rendered.header)
    rows = [("states x", f"{model.n_x}: {names(model.state_names)}"),
            ("parameters p", f"{model.n_p}: {names(model.parameter_names)}"),
            ("inputs r", f"{model.n_r}: {names(model.input_names)}"),
            ("outputs", names(o.value for o in model.outputs))]
    if ops:
        rows.append(("operations", f"{ops.group(1)} after CSE ({ops.group(2)} before)"))
    if model.default_parameters is not None and model.n_p:
        rows.append(("default p", names(f"{n}={v:g}" for n, v in
                                        zip(model.parameter_names, model.default_parameters))))
    if model.reaction_names:
        rows.append(("joints", names(model.reaction_names)))
    if model.constraint_names:
        rows.append(("constraints", names(model.constraint_names)))
    rows.append(("content hash", html.escape(rendered.content_hash[:16] or "-")))
    return table(f"CompiledModel {model.name!r} (C)", rows)
