"""The canonical form of a value: the same digest for the same content, in any process.

The warm cache (:mod:`mbgen.build.warm`) names what a model rendered to after what the user
gave: a :class:`~mbgen.Model` (or a scene, or ``Equations``) and the options of the run.
Python's ``hash`` changes from process to process and ``pickle`` writes object identity, so
:func:`digest` writes a value's content as text and hashes that:

* ``None``, ``bool``, ``int``, ``str``, ``bytes``: tagged by type (``1``, ``True`` and
  ``"1"`` differ); a ``float`` by its exact bits (``float.hex``); an ``Enum`` member by
  its class and name;
* ``tuple``, ``list``, ``dict`` in their order (a dict's insertion order is the order a
  model was built in); a ``set`` sorted;
* a dataclass by its class and every field; an object of a class of mbgen's (a
  :class:`~mbgen.Model`) by its class and its attributes (``vars``), so that an element a
  later version adds to the model is part of the key without a line here;
* a sympy expression as a graph (:meth:`_Writer.expression`): every distinct node is
  written once, as its head and its children's numbers, and numbered in the order first
  met (the number of an equal node met again is reused: a shared subexpression costs one
  line, however often it is used).  An atom is its ``srepr`` (a symbol with its
  assumptions, a ``Float`` with its digits and precision); an applied undefined function
  (``q1(t)``) its name and assumptions; any other node its class;
* a frame or point of :mod:`sympy.physics.vector` by its name (how the model made it is in
  the model's own records: ``FrameDef``, ``PointDef``), a vector by its components in each
  frame (sorted by frame name), a dyadic by its terms;
* a NumPy array by its dtype, shape and bytes.

Anything else -- a function, a file handle, an object of another library's class, a cycle
-- raises :class:`Uncacheable`: such a model is not kept in the warm cache (it derives, as
it did before), since two different values must never share a digest.
"""

from __future__ import annotations

import dataclasses
import enum
import hashlib
import sys
from collections.abc import Iterable


class Uncacheable(Exception):
    """A value whose content :func:`digest` cannot state; its message names the value."""


def digest(value) -> str:
    """SHA-256 (hex) of the canonical form of ``value``; :class:`Uncacheable` if it has none."""
    return _Writer().digest(value)


def text(value) -> str:
    """The canonical form of ``value`` as text (what :func:`digest` hashes; for tests)."""
    writer = _Writer()
    top = writer.value(value)
    return "\n".join(writer.lines + [top])


class _Writer:
    """Writes one value: ``lines`` holds the sympy nodes (``#i`` is line ``i``)."""

    def __init__(self):
        self.lines: list[str] = []
        self._numbers: dict[str, int] = {}          # node text -> its number
        self._met: dict[int, str] = {}              # id(node) -> its token, this walk
        self._alive: list = []                      # keeps the ids of _met valid
        self._open: set[int] = set()                # containers being written (cycles)
        self._sympy = sys.modules.get("sympy")
        self._vector = sys.modules.get("sympy.physics.vector")

    def digest(self, value) -> str:
        top = self.value(value)
        h = hashlib.sha256()
        for line in self.lines:
            h.update(line.encode("utf-8", "surrogatepass") + b"\n")
        h.update(b"=" + top.encode("utf-8", "surrogatepass"))
        return h.hexdigest()

    # ------------------------------------------------------------------ values
    def value(self, v) -> str:
        """The token of ``v``."""
        if v is None or isinstance(v, (bool, int, str, bytes)) and not isinstance(v, enum.Enum):
            return f"{type(v).__name__}:{v!r}"
        if isinstance(v, float):
            return f"float:{float(v).hex()}"
        if isinstance(v, complex):
            return f"complex:{v.real.hex()},{v.imag.hex()}"
        if isinstance(v, enum.Enum):
            return f"enum:{_qualified(type(v))}.{v.name}"
        if self._sympy is not None and isinstance(v, self._sympy.Basic):
            return self.expression(v)
        kind = self._kind(v)
        if kind is not None:
            return kind
        return self._container(v)

    def _kind(self, v) -> str | None:
        """The token of a sympy.physics.vector object, a matrix or an array, else None."""
        spv = self._vector
        if spv is not None:
            if isinstance(v, spv.ReferenceFrame):
                return f"frame:{v.name!r}"
            if isinstance(v, spv.Point):
                return f"point:{v.name!r}"
            if isinstance(v, spv.Vector):
                terms = sorted(v.args, key=lambda term: term[1].name)   # written in order
                return "vector(" + ",".join(f"{frame.name!r}:{self.value(tuple(matrix))}"
                                            for matrix, frame in terms) + ")"
            if isinstance(v, spv.Dyadic):      # terms (coefficient, unit vector, unit vector)
                return "dyadic" + self.value(tuple(tuple(term) for term in v.args))
        if self._sympy is not None and isinstance(v, self._sympy.MatrixBase):
            return f"matrix{v.shape}" + self.value(tuple(v))
        numpy = sys.modules.get("numpy")
        if numpy is not None and isinstance(v, numpy.ndarray):
            if v.dtype.hasobject:
                return f"array{v.shape}" + self.value(v.tolist())
            return f"array:{v.dtype.str}{v.shape}:{hashlib.sha256(v.tobytes()).hexdigest()}"
        if numpy is not None and isinstance(v, numpy.generic):
            return self.value(v.item())
        return None

    def _container(self, v) -> str:
        if id(v) in self._open:
            raise Uncacheable(f"a {type(v).__name__} that holds itself")
        self._open.add(id(v))
        try:
            if isinstance(v, (tuple, list)):
                return f"{type(v).__name__}(" + ",".join(map(self.value, v)) + ")"
            if isinstance(v, dict):
                return "dict(" + ",".join(f"{self.value(k)}:{self.value(x)}"
                                          for k, x in v.items()) + ")"
            if isinstance(v, (set, frozenset)):     # each alone: no order to number by
                return "set(" + ",".join(sorted(map(digest, v))) + ")"
            if dataclasses.is_dataclass(v) and not isinstance(v, type):
                return self._fields(_qualified(type(v)), ((f.name, getattr(v, f.name))
                                                          for f in dataclasses.fields(v)))
            if _ours(type(v)) and hasattr(v, "__dict__") and not callable(v):
                return self._fields(_qualified(type(v)), vars(v).items())
        finally:
            self._open.discard(id(v))
        raise Uncacheable(f"a {_qualified(type(v))} ({_short(v)}) has no canonical form")

    def _fields(self, head: str, items: Iterable[tuple[str, object]]) -> str:
        return head + "{" + ",".join(f"{name}={self.value(x)}" for name, x in items) + "}"

    # ------------------------------------------------------------------ sympy
    def expression(self, root) -> str:
        """The token (``#i``) of a sympy expression, its nodes written as a graph: an
        explicit stack, each node once (a deep or widely shared expression costs its size)."""
        basic, met = self._sympy.Basic, self._met
        stack = [root]
        while stack:
            node = stack[-1]
            if id(node) in met:
                stack.pop()
                continue
            args = node.args
            waiting = [a for a in args if isinstance(a, basic) and id(a) not in met]
            if waiting:
                stack.extend(waiting)
                continue
            stack.pop()
            line = self._node(node, args)
            number = self._numbers.get(line)
            if number is None:
                number = self._numbers[line] = len(self.lines)
                self.lines.append(line)
            met[id(node)] = f"#{number}"
            self._alive.append(node)
        return met[id(root)]

    def _node(self, node, args) -> str:
        """One node: an atom's ``srepr``, else its head and its children's tokens."""
        sympy = self._sympy
        if not args:
            return sympy.srepr(node)
        if isinstance(node, sympy.core.function.AppliedUndef):
            assumed = sorted(node.func.default_assumptions.items())
            head = f"Function({node.func.__name__!r},{assumed})"
        else:
            head = _qualified(type(node))
        children = (self._met[id(a)] if isinstance(a, sympy.Basic) else self.value(a)
                    for a in args)
        return f"{head}({','.join(children)})"


def _qualified(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def _ours(cls: type) -> bool:
    """A class of mbgen's (whose attributes are its content), not a library's."""
    return cls.__module__ == "mbgen" or cls.__module__.startswith("mbgen.")


def _short(v) -> str:
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


__all__ = ["Uncacheable", "digest", "text"]
