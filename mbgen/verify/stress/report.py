"""The stress report: one :class:`Case` per row, one :class:`StressReport` per scene, and
the number formatting the cells share."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import UsageError
from ...fileio import write_atomic

#: Width of :meth:`StressReport.format`.
LINE_WIDTH = 120


#: Why a case failed (:attr:`Case.cause`): the model or the generated code missed the
#: bound; a run stopped at the suite's step or evaluation budget before the bound could
#: be judged; or the suite itself could not run the case.
MODEL, BUDGET, HARNESS = "model", "budget", "harness"


@dataclass(frozen=True)
class Case:
    """One row of the report.

    Attributes
    ----------
    kind : str
        ``"fp"``, ``"extreme"``, ``"singular"``, ``"stiff"`` or ``"long_run"``.
    name : str
        What was varied, e.g. ``"k=1e6 RK45"`` or ``"m3 x1e-6"``.
    figure : str
        What was measured.
    bound : str
        What it had to meet.
    ok : bool
        Whether it met the bound.
    reason : str
        Why, in words (``"within bound"``, ``"budget: ..."``,
        ``"not positive definite: SingularMassMatrixError"``, ...); never parsed.
    data : mapping str -> float
        The measured numbers (steps, errors, condition numbers, ...); their names are
        not those of :attr:`StressReport.FIELDS` (the CSV has one column per name).
    seconds : float
        Wall time of the case (reported, never judged).
    stopped : str
        The budget a run of the case stopped at, e.g. ``"RK45: 20000 steps"``; empty
        when every run finished.  An explicit method may stop (the case is then ok).
    cause : str
        Who a failure is on: :data:`MODEL` (the default), :data:`BUDGET` or
        :data:`HARNESS`; set by the case that judged it, read only when not ok.
    """

    kind: str
    name: str
    figure: str
    bound: str
    ok: bool
    reason: str
    data: Mapping[str, float] = field(default_factory=dict)
    seconds: float = 0.0
    stopped: str = ""
    cause: str = MODEL

    def __post_init__(self):
        if self.cause not in (MODEL, BUDGET, HARNESS):
            raise ValueError(f"cause must be {MODEL!r}, {BUDGET!r} or {HARNESS!r}, "
                             f"got {self.cause!r}")
        clash = sorted(set(self.data) & set(StressReport.FIELDS))
        if clash:
            raise ValueError(f"case {self.name!r}: data names {clash} are report columns")

    @property
    def failure(self) -> str | None:
        """None when ok; else :attr:`cause`: ``"budget"`` (the suite's step or evaluation
        budget ran out where the bound asks for completion), ``"harness"`` (the suite
        could not run the case) or ``"model"`` (the model or generated code did not meet
        the bound)."""
        return None if self.ok else self.cause

    @property
    def verdict(self) -> str:
        if self.ok:
            return "ok, budget" if self.stopped else "ok"
        return f"FAIL {self.failure}"


@dataclass(frozen=True)
class StressReport:
    """The cases run on one scene.

    Attributes
    ----------
    scene : str
    size : str
        ``"ci"`` or ``"full"``.
    cases : tuple of Case
    notes : tuple of str
        What was skipped and why (e.g. C integrators not compiled in).
    seconds : float
        Total wall time, compilation included.
    """

    scene: str
    size: str
    cases: tuple[Case, ...]
    notes: tuple[str, ...] = ()
    seconds: float = 0.0

    @property
    def ok(self) -> bool:
        """True when every case met its bound."""
        return all(c.ok for c in self.cases)

    @property
    def kinds(self) -> set[str]:
        """The case kinds present."""
        return {c.kind for c in self.cases}

    @property
    def failures(self) -> tuple[Case, ...]:
        return tuple(c for c in self.cases if not c.ok)

    def find(self, kind: str, name: str | None = None) -> list[Case]:
        """Cases of ``kind`` whose name contains ``name`` (all of that kind when None)."""
        return [c for c in self.cases if c.kind == kind and (name is None or name in c.name)]

    def format(self, width: int = LINE_WIDTH) -> str:
        """A terminal table of at most ``width`` columns; cells wrap at spaces, never cut.

        Each case is a row ``case | figure | bound | verdict`` (cells wrapped
        onto more lines where long) and an indented ``reason:`` line.  The
        verdict says ``ok``, ``ok, budget`` (an explicit method that was
        allowed to stop at its budget), ``FAIL model``, ``FAIL budget`` (the
        suite's step or evaluation budget ran out where the bound asks for
        completion: a harness limit, not a wrong result -- raise the budget or
        look at the cost) or ``FAIL harness`` (the suite itself crashed).
        """
        import textwrap

        head = ("case", "figure", "bound", "verdict")
        rows = [(f"{c.kind}: {c.name}", c.figure, c.bound, c.verdict) for c in self.cases]
        gaps = 2 * (len(head) - 1)
        verdict_w = max(len(r[3]) for r in rows + [head])
        natural = [max(len(r[i]) for r in rows + [head]) for i in range(3)]
        longest_word = [max(len(w) for r in rows + [head] for w in r[i].split() or [""])
                        for i in range(3)]
        room = max(width - gaps - verdict_w, 30)
        shares = _shares(natural, longest_word, room)
        widths = shares + [verdict_w]

        def wrap(cell: str, w: int) -> list[str]:
            return textwrap.wrap(cell, w, break_long_words=False, break_on_hyphens=False) or [""]

        def block(row) -> list[str]:
            cells = [wrap(cell, w) for cell, w in zip(row, widths)]
            lines = []
            for k in range(max(len(c) for c in cells)):
                parts = [(c[k] if k < len(c) else "").ljust(w) for c, w in zip(cells, widths)]
                lines.append("  ".join(parts).rstrip())
            return lines

        n_fail = len(self.failures)
        out = [f"stress {self.scene} ({self.size}): {len(self.cases)} cases, "
               f"{n_fail} failed, {self.seconds:.1f} s"]
        out += block(head)
        out.append("  ".join("-" * w for w in widths))
        for c, row in zip(self.cases, rows):
            out += block(row)
            out += textwrap.wrap(f"reason: {c.reason}", width, initial_indent="    ",
                                 subsequent_indent="      ", break_long_words=False,
                                 break_on_hyphens=False)
        out += [line for n in self.notes for line in textwrap.wrap(
            f"note: {n}", width, subsequent_indent="  ", break_long_words=False)]
        out += textwrap.wrap(self.verdict_line(), width, subsequent_indent="  ",
                             break_long_words=False, break_on_hyphens=False)
        return "\n".join(out)

    def verdict_line(self) -> str:
        """``PASSED``, or ``FAILED:`` with model, budget and harness failures counted apart."""
        if self.ok:
            return "PASSED"
        parts = []
        for kind, what in (("model", "model failure(s)"),
                           ("budget", "harness budget failure(s) (a run stopped at the "
                                      "suite's step or evaluation budget: not a model "
                                      "failure)"),
                           ("harness", "harness crash(es)")):
            cases = [c for c in self.failures if c.failure == kind]
            if cases:
                parts.append(f"{len(cases)} {what}: " + ", ".join(f"{c.kind}: {c.name}"
                                                                  for c in cases))
        return "FAILED: " + "; ".join(parts)

    # ------------------------------------------------------------ files
    FIELDS = ("kind", "name", "figure", "bound", "ok", "failure", "reason", "seconds",
              "stopped")

    def records(self) -> list[dict]:
        """One dict per case: the :attr:`FIELDS` and the measured ``data``."""
        return [{"kind": c.kind, "name": c.name, "figure": c.figure, "bound": c.bound,
                 "ok": c.ok, "failure": c.failure or "", "reason": c.reason,
                 "seconds": c.seconds, "stopped": c.stopped,
                 "data": {k: float(v) for k, v in c.data.items()}}
                for c in self.cases]

    def to_json(self) -> str:
        """The whole report as JSON (non-finite numbers as the strings ``"nan"``, ``"inf"``)."""
        import json

        def clean(v):
            if isinstance(v, float) and not np.isfinite(v):
                return str(v)
            if isinstance(v, dict):
                return {k: clean(x) for k, x in v.items()}
            return v

        doc = {"scene": self.scene, "size": self.size, "ok": self.ok, "seconds": self.seconds,
               "notes": list(self.notes), "verdict": self.verdict_line(),
               "cases": [clean(r) for r in self.records()]}
        return json.dumps(doc, indent=1) + "\n"

    def to_csv(self) -> str:
        """One row per case: :attr:`FIELDS`, then one column per measured quantity (each
        name once: a case's data never reuses a field's name)."""
        import csv
        import io

        keys = sorted({k for c in self.cases for k in c.data})
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(list(self.FIELDS) + keys)
        for r in self.records():
            w.writerow([r[f] for f in self.FIELDS] +
                       [repr(r["data"][k]) if k in r["data"] else "" for k in keys])
        return buf.getvalue()

    def write(self, path) -> Path:
        """Write :meth:`to_csv` (``.csv``) or :meth:`to_json` (``.json``) atomically."""
        path = report_path(path)
        write_atomic(path, self.to_csv() if path.suffix.lower() == ".csv" else self.to_json())
        return path


def report_path(path) -> Path:
    """``path`` as a :class:`~pathlib.Path` when it names a report file :meth:`StressReport.write`
    can write (``.csv`` or ``.json``); else a :class:`~mbgen.errors.UsageError` naming them,
    which ``mbgen stress -o`` raises before the suite runs."""
    path = Path(path)
    if path.suffix.lower() not in (".csv", ".json"):
        raise UsageError(f"stress report {str(path)!r}: use a file name ending in .csv or "
                         f".json")
    return path


def _shares(natural: list[int], least: list[int], room: int) -> list[int]:
    """Column widths that fit ``room``: natural widths when they fit, else shrink the widest
    column that is still wider than its longest word (a word is never split)."""
    widths = list(natural)
    while sum(widths) > room:
        shrinkable = [i for i, w in enumerate(widths) if w > least[i]]
        if not shrinkable:
            break
        i = max(shrinkable, key=lambda j: widths[j])
        widths[i] -= 1
    return widths


def fmt_sci(v: float) -> str:
    """Compact notation: 1e6, 2.5e-3, 0, -1, 2.5."""
    if v == 0 or 0.1 <= abs(v) < 1e3:
        return f"{v:g}"
    mant, exp = f"{v:.1e}".split("e")
    mant = mant.rstrip("0").rstrip(".")
    return f"{mant}e{int(exp)}"


def fmt_g(v: float) -> str:
    """Two significant digits (``inf`` and ``nan`` as they are)."""
    return f"{v:.2g}" if np.isfinite(v) else str(v)
