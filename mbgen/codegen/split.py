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

:func:`split_view` cuts each section of a C function view whose printed statements
exceed :data:`SPLIT_CHARS` into parts of about :data:`PART_CHARS` characters, in their
order.  A section's statements are its temporaries (``temps``, ``post_temps``) and then the
entries of the blocks that follow them (:data:`BLOCKS`: ``pre`` after ``temps``, ``post``
after ``post_temps``).  Part ``k`` is a ``static`` function of
``(t, x, p, r, <local arrays read>, <arrays written>, W)``; a temporary read outside the
part that defines it is stored in the work array ``W`` (a local of the public function: its
size is in the stack bound) and loaded back by the part that reads it
(``const double v_k = W[i];``); block entries are stored through the array, passed as an
argument (``DT[17] = -v1*v2;``).  The public function keeps only the calls, the block
mirrors, the solves and the checks.  Values are computed once, in the same order and by the
same expressions, so the results are bit for bit those of the single function (and of the
generated Python, which is not split).

Why the block entries too: they used to stay in the public function, which read what they
needed from ``W``.  The Jacobian's right-hand sides of the column solve (``DT``,
``2 n^2`` sums of products) made that function 348 KB of C on the 32-link arm and 171 KB on
the G1 humanoid (floating), past :data:`mbgen.build.extension.LARGE_FUNCTION_CHARS`, so
the whole module fell to -O1.  With the entries in parts (the longest function 86 KB and
77 KB) it keeps -O2: the arm's Jacobian at n = 32 ran in 28.2 µs against 60.2 µs, and gcc
took 15.4 s and 352 MB against 27.8 s and 652 MB (paired runs on a loaded 2-core machine,
the module's own flags).  Measured and left: storing each entry right after the last
temporary it reads (fewer ``W`` round trips: 27.1 vs 27.0 µs, gcc 487 MB), and parts of
80,000 characters (29.0 vs 27.9 µs, gcc 21 s and 411 MB).

Shapes: a view's ``parts`` is a list of dicts ``{name, section, prototype, call,
status, loads, imports, temps, stores}`` where ``loads`` are ``(ident, array, index)``,
``imports`` ``(ident, W index)``, ``temps`` ``(ident, expr, check, W index or None)`` and
``stores`` ``(target, expr)`` (``target`` as ``"DT[17]"``); the split blocks'
``assignments`` are emptied, ``main_loads`` (empty) replaces ``loads`` in the public
function and ``main_imports[section]`` (empty: nothing is read after the parts) is kept for
the template; ``work`` is ``W``'s length.

Functions with constraint solves (``velocity`` blocks) are not split.
"""

from __future__ import annotations

import re

#: A function whose printed temporaries and block entries exceed this many characters is split.
SPLIT_CHARS = 100_000
#: About this many characters of printed statements per part.
PART_CHARS = 40_000
#: Characters of a statement beyond its expression (``    const double v123 = ...;``).
STATEMENT_CHARS = 24

_IDENT = re.compile(r"[A-Za-z_]\w*")

#: The runs of temporaries that are split, in the order the function computes them.
SECTIONS = ("temps", "post_temps")


def _names(text: str) -> set[str]:
    return set(_IDENT.findall(text))


#: The blocks whose entries each section's parts store, after its temporaries.
BLOCKS = {"temps": "pre", "post_temps": "post"}


def _chunks(statements: list, size: int) -> list[list]:
    out, cur, n = [], [], 0
    for t in statements:
        cur.append(t)
        n += len(t[1]) + STATEMENT_CHARS
        if n >= size:
            out.append(cur)
            cur, n = [], 0
    if cur:
        out.append(cur)
    return out


def _stores(view: dict, section: str) -> list[tuple]:
    """``(target, expr, None)`` for each block entry of ``section``, in the order the one
    function prints them (``("M[3]", "v12", None)``; None tells a store from a temporary)."""
    return [(f"{b['name']}[{i}]", e, None) for b in view[BLOCKS[section]]
            for i, e in b["assignments"]]


def _size(view: dict) -> int:
    """Characters of the printed temporaries and block entries of ``view``, each with its
    statement's own (:data:`STATEMENT_CHARS`): what the one function would print."""
    return sum(len(e) + STATEMENT_CHARS for s in SECTIONS
               for _, e, _ in view[s] + _stores(view, s))


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
    if _size(view) <= split_chars or view["velocity"]:
        return view
    view["split"] = tuple(s for s in SECTIONS if view[s] or _stores(view, s))
    loads = {ident: (ident, arr, idx) for ident, arr, idx in view["loads"]}
    parts, owner = _cut(view, part_chars)
    for section in view["split"]:      # the parts store every entry: none is left to print
        for b in view[BLOCKS[section]]:
            b["assignments"] = []
    view.update(main_loads=[], main_uses_time=False)
    work: dict[str, int] = {}
    for k, part in enumerate(parts):
        read = set()
        for e in [e for _, e, _ in part["temps"]] + [e for _, e in part["stores"]]:
            read |= _names(e)
        part["reads"] = read
        for sym in sorted(read, key=_order):
            if sym in owner and owner[sym] < k:
                work.setdefault(sym, len(work))
    written = {b["name"] for b in view["pre"] + view["post"]}
    for k, part in enumerate(parts):
        _fill_part(part, f"{view['name']}_part{k}", view["args"], time_name, arrays, written,
                   loads, owner, work)
    view["parts"] = parts
    view["work"] = len(work)
    return view


def _cut(view: dict, part_chars: int) -> tuple[list[dict], dict[str, int]]:
    """``(parts, owner)``: the parts (``section``, ``temps``, ``stores``) the split sections
    of ``view`` are cut into, in order, and the index of the part that computes each
    temporary.  A section's statements are its temporaries, then its blocks' entries
    (:func:`_stores`), in the one function's order."""
    parts, owner = [], {}
    for section in view["split"]:
        temps = view[section]
        for chunk in _chunks(temps + _stores(view, section), part_chars):
            k = len(parts)
            parts.append(dict(section=section, temps=[t for t in chunk if t[2] is not None],
                              stores=[(s, e) for s, e, c in chunk if c is None]))
            for sym, _, c in chunk:
                if c is not None:
                    owner[sym] = k
    return parts, owner


def _fill_part(part: dict, name: str, args, time_name: str, arrays, written: set,
               loads: dict, owner: dict, work: dict) -> None:
    """Name, prototype, call and the loads, imports and stores of one part."""
    read = part.pop("reads")
    own = {s for s, _, _ in part["temps"]}
    out = sorted({target.split("[")[0] for target, _ in part["stores"]} & written)
    passed = [a for a in arrays if a in read and a not in out]
    needed = {loads[s][1] for s in read if s in loads}
    if time_name in read:
        needed.add("t")
    imports = [(s, work[s]) for s in sorted(read, key=_order) if s in owner and s not in own]
    status = any(c for _, _, c in part["temps"])
    params = ["double t" if a == "t" else f"const double *{a}" for a in args]
    params += [f"const double *{a}" for a in passed] + [f"double *{a}" for a in out]
    params.append("double *W")
    part.update(
        name=name,
        status=status,
        prototype=f"static {'int' if status else 'void'} {name}({', '.join(params)})",
        call=f"{name}({', '.join(list(args) + passed + out + ['W'])})",
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


__all__ = ["split_view", "SPLIT_CHARS", "PART_CHARS", "SECTIONS", "BLOCKS"]
