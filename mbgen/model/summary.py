"""The notebook summary (``_repr_html_``) of a :class:`~mbgen.model.builder.Model`.

A small table of sizes and names (coordinates, speeds, constants, inputs,
frames, points, masses, loads by kind, constraints), never expressions; long
name lists are shortened and every name is escaped (:mod:`mbgen.summary`).
"""

from __future__ import annotations

import html

from ..summary import names, table


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
        rows.append(("constraints",
                     f"{len(m.constraints_)}: {names(c.name for c in m.constraints_)}"))
    if m.kinematic_equations_:
        rows.append(("kinematic equations", f"{len(m.kinematic_equations_)} given"))
    return table(f"Model {m.name!r}", rows)


__all__ = ["model_html"]
