"""The files of a MuJoCo model, read and checked before MuJoCo reads them (:func:`scan_mjcf`).

MuJoCo's compiler trusts its input: it waits forever on a named pipe, warns and goes on at a
NaN, normalises ``axis="1e200 0 0"`` to (0, 0, 0) (its square overflows: the joint turns
about another axis) and grows without bound on 300 bytes whose nested ``<replicate>``
counts ask for 10^9 bodies.  :func:`scan_mjcf` reads the file and everything it brings in
once, with expat, and refuses each of these by name (file, line, element, attribute)
before :func:`mbgen.model.mjcf.compile_mjcf` hands the path to MuJoCo.
"""

from __future__ import annotations

import os
import stat
from xml.parsers import expat

import numpy as np

from ..errors import MjcfError
from .files import kind_of, read_regular_file
from .limits import MAX_BODIES, check_count

#: Largest file read (the main file and each it brings in).
MAX_FILE_BYTES = 100 * 1024 * 1024
#: Largest magnitude of a number in a file or a compiled model: a vector's squared length
#: (MuJoCo's normalisation of an axis or a quaternion) and products of a few such numbers
#: stay finite.  ``axis="1e200 0 0"`` would become (0, 0, 0) in MuJoCo: a different joint.
MAX_MAGNITUDE = 1e100
#: Most elements MuJoCo may make of a file, each ``<replicate>`` copy counted and each body
#: of a ``<composite>`` or ``<flexcomp>``: ten thousand times a model mbgen can derive,
#: far below what exhausts MuJoCo's compiler (10^9 bodies from 300 bytes).
MAX_ELEMENTS = 100_000
#: Deepest chain of ``<include>``-d or ``<attach>``-ed files.
MAX_DEPTH = 32

#: Attributes that hold names, not numbers (a body may be called ``inf``), digits stripped
#: (``body1``, ``geom2``); ``file...`` and ``...dir`` attributes are paths.
_NAMES = frozenset("name class childclass prefix suffix model body joint geom site tendon "
                   "actuator target objname refname material texture mesh hfield skin plugin "
                   "instance flex cranksite slidersite jointinparent key camera light "
                   "sensor".split())
#: Limits where MuJoCo reads an infinite bound as none: ``inf`` is allowed there.
_UNBOUNDED = frozenset("range ctrlrange forcerange actrange actuatorfrcrange "
                       "lengthrange".split())
#: Elements that stand for many, and the attribute whose numbers multiply: a
#: ``<replicate>`` its content, a ``<composite>`` or ``<flexcomp>`` the bodies it makes.
_COPIES = {"replicate": "count"}
_MAKES_BODIES = {"composite": "count", "flexcomp": "count"}


def _what_is(path) -> str | None:
    """``None`` for a regular file (links followed), ``"missing"`` if nothing is there, else
    what the path is (``"a named pipe (FIFO)"``, ...).  ``stat`` opens nothing."""
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return "missing"
    return None if stat.S_ISREG(mode) else kind_of(mode)


def _read_file(path: str, label: str) -> bytes | None:
    """The bytes of the regular file ``path``, ``None`` if there is none; anything else (a
    pipe, even one swapped in meanwhile) refused, never waited on (:mod:`.files`)."""
    if _what_is(path) == "missing":
        return None
    return read_regular_file(path, label, MjcfError, MAX_FILE_BYTES,
                             "; a model file is far smaller")


def _copies(value: str | None) -> int:
    """The product of the counts in ``value`` (``"10 10 1"``), at least 1 each: an upper
    bound of what MuJoCo makes, whatever it makes of a count it refuses."""
    n = 1
    for token in (value or "").split():
        try:
            n *= max(1, int(float(token)))
        except (ValueError, OverflowError):
            pass
    return n


def _check_numbers(attr: str, value: str, where) -> None:
    """Refuse a non-finite number, or one beyond :data:`MAX_MAGNITUDE`, in a numeric
    attribute (one whose every token reads as a number; names and paths are skipped)."""
    if attr.rstrip("0123456789") in _NAMES or attr.startswith("file") or attr.endswith("dir"):
        return
    try:
        x = np.array(value.split(), dtype=float)
    except ValueError:
        return
    unbounded = attr in _UNBOUNDED
    bad = np.isnan(x) if unbounded else ~np.isfinite(x)
    if bad.any():
        problem = f"holds {value.split()[int(np.argmax(bad))]!r}, not a finite number"
    elif not unbounded and (np.abs(x) > MAX_MAGNITUDE).any():
        problem = (f"holds {x[np.abs(x) > MAX_MAGNITUDE][0]:g}, beyond {MAX_MAGNITUDE:g}: "
                   f"its square overflows, and MuJoCo turns such an axis or quaternion "
                   f"into zero (the joint would turn about another axis)")
    else:
        return
    shown = value if len(value) <= 60 else value[:57] + "..."
    raise MjcfError(f"{where()} {attr}=\"{shown}\" {problem}; give finite numbers of "
                    f"ordinary size (a direction as e.g. '1 0 0')")


class _Scan:
    """One pass over a model file and every file it brings in, before MuJoCo reads any.

    * every file read is a regular one: the main file and each ``<include>`` (a named pipe
      would leave MuJoCo, and this scan, waiting forever; a device feeds it without end),
      and no asset (a ``file`` of a mesh, texture, model, ...) where MuJoCo may look for it
      is a pipe, device or socket;
    * every number is finite and within :data:`MAX_MAGNITUDE` (MuJoCo reads a NaN with a
      warning, and normalises ``axis="1e200 0 0"`` to zero); the error names the file,
      line, element and attribute;
    * what MuJoCo would make: each element counts as often as the ``<replicate>`` counts
      above it multiply, a ``<composite>`` or ``<flexcomp>`` as the product of its
      ``count``, an ``<attach>`` as its model file; more than :data:`MAX_ELEMENTS`
      elements is an :class:`MjcfError`, more than
      :data:`~mbgen.model.limits.MAX_BODIES` bodies a
      :class:`~mbgen.errors.ModelSizeError` (unless forced).

    Linear in the size of the files: each is read once (MuJoCo refuses a second
    ``<include>`` of one; an ``<attach>``-ed model file is counted once, memoised).
    """

    def __init__(self, path, depth: int = 0, memo: dict | None = None):
        self.path = os.path.abspath(os.fspath(path))
        self.main_dir = os.path.dirname(self.path)
        self.depth = depth
        self.memo = {} if memo is None else memo   # model file: (elements, bodies), None while read
        self.read: set[str] = set()
        self.dirs = {""}                            # <compiler meshdir, texturedir, assetdir>
        self.assets: list[tuple[str, str, str]] = []        # (file, folder of its XML, where)
        self.models: dict[str, tuple[str, str]] = {}        # <model name> -> (file, folder)
        self.attached: list[tuple[str, int, str]] = []      # (model name, copies, where)
        self.elements = self.bodies = self.nesting = 0

    def run(self) -> None:
        if self.document(self.path, 1, "MJCF file") is None:
            raise MjcfError(f"MJCF file {self.path!r} does not exist")
        for value, folder, where in self.assets:
            self.check_asset(value, folder, where)
        for name, copies, where in self.attached:
            self.attach(name, copies, where)

    def add(self, elements: int, bodies: int, where: str) -> None:
        self.elements += elements
        self.bodies += bodies
        if self.elements > MAX_ELEMENTS:
            raise MjcfError(f"{where}: {os.path.basename(self.path)!r} would make at least "
                            f"{self.elements} elements (each <replicate> copy counted), more "
                            f"than {MAX_ELEMENTS}: MuJoCo's compiler would run out of memory "
                            f"or time, and mbgen derives at most {MAX_BODIES} bodies; lower "
                            f"the counts")

    def document(self, path: str, copies: int, label: str):
        """Read one XML file (``copies`` times over); ``None`` if it does not exist."""
        real = os.path.realpath(path)
        if real in self.read:           # MuJoCo refuses a second include of a file
            return True
        self.read.add(real)
        data = _read_file(path, label)
        if data is None:
            return None
        folder = os.path.dirname(os.path.abspath(path))
        parser = expat.ParserCreate()
        stack = [copies]

        def refuse(*_args):
            raise MjcfError(f"{label} {path!r} has a <!DOCTYPE> or <!ENTITY> declaration: "
                            f"MJCF has none, and entities can expand without bound; remove it")

        def start(tag: str, attrs: dict) -> None:
            def where() -> str:
                name = f" name={attrs['name']!r}" if "name" in attrs else ""
                return f"{path!r}, line {parser.CurrentLineNumber}: <{tag}{name}>"
            n = stack[-1]
            made = n * _copies(attrs.get(_MAKES_BODIES[tag])) if tag in _MAKES_BODIES else 0
            self.add(n + made, (n if tag == "body" else 0) + made, where())
            for attr, value in attrs.items():
                _check_numbers(attr, value, where)
                if attr.startswith("file") and tag != "include":
                    self.assets.append((value, folder, where()))
            if tag in _HANDLERS:
                _HANDLERS[tag](self, attrs, n, folder, where)
            stack.append(n * _copies(attrs.get(_COPIES[tag])) if tag in _COPIES else n)

        parser.StartElementHandler = start
        parser.EndElementHandler = lambda _tag: stack.pop()
        parser.StartDoctypeDeclHandler = parser.EntityDeclHandler = refuse
        try:
            parser.Parse(data, True)
        except expat.ExpatError as exc:
            raise MjcfError(f"{label} {path!r} is not well-formed XML: {exc}") from None
        return True

    def include(self, attrs: dict, copies: int, folder: str, where) -> None:
        """``<include file>``: where MuJoCo finds it (the main file's folder first, then the
        including file's), read in place; a missing one is left to MuJoCo to name."""
        file = attrs.get("file", "")
        for candidate in dict.fromkeys((os.path.join(self.main_dir, file),
                                        os.path.join(folder, file))):
            if file and _what_is(candidate) != "missing":
                self.nesting += 1
                if self.nesting > MAX_DEPTH:
                    raise MjcfError(f"{where()}: includes nest more than {MAX_DEPTH} deep; "
                                    f"flatten them")
                self.document(candidate, copies, f"MJCF file (included by {where()})")
                self.nesting -= 1
                return

    def compiler(self, attrs: dict, *_args) -> None:
        self.dirs |= {attrs[a] for a in ("meshdir", "texturedir", "assetdir") if a in attrs}

    def model_asset(self, attrs: dict, _copies, folder: str, _where) -> None:
        self.models[attrs.get("name", "")] = (attrs.get("file", ""), folder)

    def attach_element(self, attrs: dict, copies: int, _folder, where) -> None:
        self.attached.append((attrs.get("model", ""), copies, where()))

    def candidates(self, value: str, folder: str) -> list[str]:
        """Every path MuJoCo may read for ``file=value``: from the main file's folder or the
        naming file's, through a ``<compiler>`` folder or not, the path or its last part."""
        names = [n for n in dict.fromkeys((value, os.path.basename(value))) if n]
        return list(dict.fromkeys(os.path.join(base, d, n) for base in (self.main_dir, folder)
                                  for d in sorted(self.dirs) for n in names))

    def check_asset(self, value: str, folder: str, where: str) -> None:
        for candidate in self.candidates(value, folder):
            try:
                what = _what_is(candidate)
            except OSError:             # a name too long, a loop of links: not a pipe
                continue
            if what not in (None, "missing", "a folder"):
                raise MjcfError(f"{where}: {value!r} ({candidate!r}) is {what}, not a "
                                f"file: MuJoCo would wait on it or read without end; give the "
                                f"path of a file")

    def attach(self, name: str, copies: int, where: str) -> None:
        """``<attach model>``: the model file's own count, once per copy (memoised)."""
        value, folder = self.models.get(name, ("", ""))
        found = next((c for c in self.candidates(value, folder) if _what_is(c) is None), None)
        if found is None:
            return                      # MuJoCo names what is missing
        key = os.path.realpath(found)
        if key not in self.memo:
            if self.depth >= MAX_DEPTH:
                raise MjcfError(f"{where}: model files attach each other more than "
                                f"{MAX_DEPTH} deep; flatten the chain")
            self.memo[key] = None
            sub = _Scan(found, self.depth + 1, self.memo)
            sub.run()
            self.memo[key] = (sub.elements, sub.bodies)
        if self.memo[key] is None:
            raise MjcfError(f"{where}: the model file {found!r} attaches itself (through "
                            f"others): a cycle; break it")
        elements, bodies = self.memo[key]
        self.add(copies * elements, copies * bodies, where)


_HANDLERS = {"include": _Scan.include, "compiler": _Scan.compiler,
             "model": _Scan.model_asset, "attach": _Scan.attach_element}


def scan_mjcf(path) -> None:
    """Read the model file at ``path`` and everything it brings in; refuse (:class:`_Scan`)
    what MuJoCo must not be handed: :class:`MjcfError`, or
    :class:`~mbgen.errors.ModelSizeError` for more bodies than mbgen derives (unless
    forced)."""
    scan = _Scan(path)
    scan.run()
    check_count(os.path.basename(scan.path), scan.bodies, "bodies", MAX_BODIES)


__all__ = ["MAX_DEPTH", "MAX_ELEMENTS", "MAX_FILE_BYTES", "MAX_MAGNITUDE", "scan_mjcf"]
