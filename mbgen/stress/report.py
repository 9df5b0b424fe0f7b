"""The stress report: one :class:`Case` per row, one :class:`StressReport` per scene, and
the number formatting the cells share."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np


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
        Why (the named outcome: ``"within bound"``, ``"budget: ..."``,
        ``"not positive definite: SingularMassMatrixError"``, ...).
    data : mapping str -> float
        The measured numbers (steps, errors, condition numbers, ...).
    seconds : float
        Wall time of the case.
    """

    kind: str
    name: str
    figure: str
    bound: str
    ok: bool
    reason: str
    data: Mapping[str, float] = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def verdict(self) -> str:
        return "ok" if self.ok else "FAIL"


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

    def format(self, width: int = 64) -> str:
        """A terminal table: case, figure, bound, verdict, reason (long cells are cut)."""
        rows = [(f"{c.kind}: {c.name}", c.figure, c.bound, c.verdict, c.reason)
                for c in self.cases]
        head = ("case", "figure", "bound", "verdict", "reason")
        cut = [tuple(_cut(cell, width) for cell in row) for row in rows]
        widths = [max(len(r[i]) for r in cut + [head]) for i in range(5)]
        widths[-1] = len(head[-1])  # the reason is last: no padding
        line = "  ".join("-" * w for w in widths[:-1]) + "  " + "-" * 6

        def fmt(row):
            return "  ".join(cell.ljust(w) for cell, w in zip(row[:-1], widths[:-1])) + \
                "  " + row[-1]

        n_fail = len(self.failures)
        out = [f"stress {self.scene} ({self.size}): {len(self.cases)} cases, "
               f"{n_fail} failed, {self.seconds:.1f} s", fmt(head), line]
        out += [fmt(r) for r in cut]
        out += [f"note: {n}" for n in self.notes]
        out.append("PASSED" if self.ok else "FAILED: " + ", ".join(
            f"{c.kind}: {c.name}" for c in self.failures))
        return "\n".join(out)


def _cut(text: str, width: int) -> str:
    return text if len(text) <= width else text[:width - 1] + "~"


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
