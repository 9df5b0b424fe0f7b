r"""Large C functions as a sequence of parts: a compiler's cost stays linear in the model.

A generated function is straight-line code: loads of ``x``, ``p``, ``r``, then
the temporaries ``const double v_k = ...;`` in dependency order, then the blocks
(``M``, ``F``, the output) that read them.  gcc's register allocation and
scheduling grow much faster than linearly with the length of one function: the
16-link arm's Jacobian (45k operations, 690 KB of C in one function) took 32 s at
-O1 and its 32-link one did not finish in 300 s; cut into parts of
:data:`PART_CHARS` it takes 5.6 s at -O1 and 8.7 s at -O2, and runs 1.8x faster
at -O2 than the one function at -O1 (15.5 vs 27.5 µs, both measured on a loaded
2-core machine).

:func:`split_view` cuts each run of temporaries (``temps``, ``post_temps``) of a
C function view whose printed temporaries exceed :data:`SPLIT_CHARS` into parts
of about :data:`PART_CHARS` characters, in their order.  Part ``k`` is a
``static`` function of ``(t, x, p, r, <local arrays read>, W)``; a temporary read
outside the part that defines it is stored in the work array ``W`` (a local of
the public function: its size is in the stack bound) and loaded back where it is
read, by another part (``const double v_k = W[i];``) or by the public function's
own statements after the part ran.  Values are computed once, in the same order
and by the same expressions, so the results are bit for bit those of the single
function (and of the generated Python, which is not split).

Shapes: a view's ``parts`` is a list of dicts ``{name, section, prototype, call,
status, loads, imports, temps}`` where ``loads`` are ``(ident, array, index)``,
``imports`` ``(ident, W index)`` and ``temps`` ``(ident, expr, check, W index or
None)``; ``main_loads`` replaces ``loads`` in the public function and
``main_imports[section]`` lists ``(ident, W index)`` to load after that section's
parts; ``work`` is ``W``'s length.

Functions with constraint solves (``velocity`` blocks) are not split.
"""

from __future__ import annotations

import re

#: A function whose printed temporaries exceed this many characters is split.
SPLIT_CHARS = 100_000
#: About this many characters of printed temporaries per part.
PART_CHARS = 40_000

_IDENT = re.compile(r"[A-Za-z_]\w*")

#: The runs of temporaries that are split, in the order the function computes them.
SECTIONS = ("temps", "post_temps")


def _names(text: str) -> set[str]:
    return set(_IDENT.findall(text))


def _chunks(temps: list, size: int) -> list[list]:
    out, cur, n = [], [], 0
    for t in temps:
        cur.append(t)
        n += len(t[1]) + 24
        if n >= size:
            out.append(cur)
            cur, n = [], 0
    if cur:
        out.append(cur)
    return out


def _main_statements(view: dict, section: str) -> list[str]:
    """What the public function itself prints after ``section``'s parts ran (every
    non-empty section is split, so these are block entries only)."""
    blocks = view["pre"] + view["post"] if section == "temps" else view["post"]
    return [e for b in blocks for _, e in b["assignments"]]


def split_view(view: dict, time_name: str, arrays: tuple[str, ...],
               split_chars: float | None = None, part_chars: int | None = None) -> dict:
    """Add ``parts`` to a C function ``view`` whose temporaries are too long for one function.

    ``arrays`` are the local arrays the temporaries may read (``F`` after the solve);
    returns ``view`` itself, with ``parts == []`` where nothing is split.  The sizes
    default to :data:`SPLIT_CHARS` and :data:`PART_CHARS`, read at the call.
    """
    split_chars = SPLIT_CHARS if split_chars is None else split_chars
    part_chars = PART_CHARS if part_chars is None else part_chars
    view.update(parts=[], split=(), work=0, main_imports={s: [] for s in SECTIONS},
                main_loads=view["loads"], main_uses_time=view["uses_time"])
    size = sum(len(e) for s in SECTIONS for _, e, _ in view[s])
    if size <= split_chars or view["velocity"]:
        return view
    view["split"] = tuple(s for s in SECTIONS if view[s])
    loads = {ident: (ident, arr, idx) for ident, arr, idx in view["loads"]}
    parts, owner = _cut(view, part_chars)
    work: dict[str, int] = {}

    def export(sym):
        return work.setdefault(sym, len(work))

    for k, part in enumerate(parts):
        read = set()
        for _, e, _ in part["temps"]:
            read |= _names(e)
        part["reads"] = read
        for sym in sorted(read, key=_order):
            if sym in owner and owner[sym] < k:
                export(sym)
    main_read = set()
    for section in view["split"]:
        names = set()
        for e in _main_statements(view, section):
            names |= _names(e)
        imports = [s for s in names if s in owner and parts[owner[s]]["section"] == section]
        view["main_imports"][section] = [(s, export(s)) for s in sorted(imports, key=_order)]
        main_read |= names
    view["main_loads"] = [loads[s] for s in loads if s in main_read]
    view["main_uses_time"] = time_name in main_read
    for k, part in enumerate(parts):
        _fill_part(part, f"{view['name']}_part{k}", view["args"], time_name, arrays, loads,
                   owner, work)
    view["parts"] = parts
    view["work"] = len(work)
    return view


def _cut(view: dict, part_chars: int) -> tuple[list[dict], dict[str, int]]:
    """``(parts, owner)``: the parts (``section``, ``temps``) the split sections of ``view``
    are cut into, in order, and the index of the part that computes each temporary."""
    parts, owner = [], {}
    for section in view["split"]:
        for chunk in _chunks(view[section], part_chars):
            k = len(parts)
            parts.append(dict(section=section, temps=chunk))
            for sym, _, _ in chunk:
                owner[sym] = k
    return parts, owner


def _fill_part(part: dict, name: str, args, time_name: str, arrays, loads: dict, owner: dict,
               work: dict) -> None:
    """Name, prototype, call and the loads, imports and stores of one part."""
    read = part.pop("reads")
    own = {s for s, _, _ in part["temps"]}
    passed = [a for a in arrays if a in read]
    needed = {loads[s][1] for s in read if s in loads}
    if time_name in read:
        needed.add("t")
    imports = [(s, work[s]) for s in sorted(read, key=_order) if s in owner and s not in own]
    status = any(c for _, _, c in part["temps"])
    params = ["double t" if a == "t" else f"const double *{a}" for a in args]
    params += [f"const double *{a}" for a in passed] + ["double *W"]
    part.update(
        name=name,
        status=status,
        prototype=f"static {'int' if status else 'void'} {name}({', '.join(params)})",
        call=f"{name}({', '.join(list(args) + passed + ['W'])})",
        unused=[a for a in args if a not in needed]
        + ([] if imports or any(s in work for s in own) else ["W"]),
        uses_time=time_name in read,
        loads=[loads[s] for s in loads if s in read],
        imports=imports,
        temps=[(s, e, c, work.get(s)) for s, e, c in part["temps"]],
    )


def _order(ident: str) -> tuple:
    """Identifiers in a stable order: by name length, then name (``v2`` before ``v10``)."""
    return (len(ident), ident)


__all__ = ["split_view", "SPLIT_CHARS", "PART_CHARS", "SECTIONS"]
