"""The report of a work-precision run (:class:`WorkPrecisionReport`): the terminal table,
the CSV, the summary (fastest configuration per error level, dopri5 against RK45,
solve_ivp's own overhead, failures) and the figure (:mod:`mbgen.studies.workprecision.plot`).
"""

from __future__ import annotations

import csv
import io
import math
import statistics
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...fileio import write_atomic
from .plot import plot_report
from .points import BACKENDS, FAILED, OK, OVER_BUDGET, SKIPPED, Config, Point
from .reference import TrueSolution

#: Error levels of the summary (max abs error over the output grid).
ERROR_LEVELS = (1e-2, 1e-4, 1e-6, 1e-8, 1e-10)
#: Columns of :meth:`WorkPrecisionReport.to_csv`, one row per point.
CSV_COLUMNS = ("method", "backend", "jac", "rtol", "atol", "h", "err_final", "err_max", "time_s",
               "nfev", "njev", "nlu", "status", "message", "err_final_rel", "overhead",
               "err_residual")


@dataclass(frozen=True)
class WorkPrecisionReport:
    """The points of one work-precision run, and how to show them.

    Attributes
    ----------
    scene : str
    state_names : tuple of str
    t_eval : ndarray
        The output grid the errors are measured on.
    rtols : tuple of float
    atol_scale : float
        ``atol = rtol * atol_scale``.
    atol_note : str
        How ``atol_scale`` was chosen.
    reference : TrueSolution
    points : tuple of Point
        Configuration by configuration, tolerance by tolerance.
    repeats : int
    time_budget : float
    wall_time : float
        Seconds the whole run took (compile, pilot and reference included).
    """

    scene: str
    state_names: tuple[str, ...]
    t_eval: np.ndarray
    rtols: tuple[float, ...]
    atol_scale: float
    atol_note: str
    reference: TrueSolution
    points: tuple[Point, ...]
    repeats: int
    time_budget: float
    wall_time: float

    def configurations(self) -> list[Config]:
        """The curves, in the order they ran."""
        return list(dict.fromkeys(p.config for p in self.points))

    def curve(self, config: Config) -> list[Point]:
        return [p for p in self.points if p.config == config]

    # ------------------------------------------------------------ table
    def table(self) -> str:
        """Terminal table: error, time and RHS calls per configuration and tolerance."""
        t0, t1 = self.t_eval[0], self.t_eval[-1]
        head = (f"{self.scene}: n_x = {len(self.state_names)}, t in [{t0:g}, {t1:g}], "
                f"{self.t_eval.size} output times; {self.atol_note}\n{self.reference.describe()}")
        blocks = [
            ("max abs error over the output times", lambda p: f"{p.err_max:.1e}"),
            (f"run time, ms (median of {self.repeats})", lambda p: _ms(p.time_s)),
            ("RHS calls", lambda p: f"{p.nfev}"),
        ]
        body = [_matrix(title, self.configurations(), self.curve, self.rtols, cell)
                for title, cell in blocks]
        rk4 = [p for p in self.points if p.h is not None]
        foot = ["rk4: fixed step h per column: " + ", ".join(f"{p.h:.3g}" for p in rk4)] \
            if rk4 else []
        foot += [f"Cells: budget = stopped after {self.time_budget:g} s; skip = a looser "
                 f"tolerance went over budget; fail = integrator or model error (see the CSV).",
                 "BLAS threads pinned to 1 (threadpoolctl)."]
        return "\n\n".join([head, *body, "\n".join(foot)])

    # -------------------------------------------------------------- CSV
    def to_csv(self) -> str:
        """One row per point, columns :data:`CSV_COLUMNS`."""
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(CSV_COLUMNS)
        for p in self.points:
            writer.writerow([_csv_value(getattr(p, name)) for name in CSV_COLUMNS])
        return buf.getvalue()

    def write_csv(self, path) -> Path:
        """Write :meth:`to_csv` to ``path`` atomically."""
        path = Path(path)
        write_atomic(path, self.to_csv())
        return path

    # ------------------------------------------------------------- plot
    def plot(self, path) -> Path:
        """Write the work-precision diagram to ``path`` as PNG (see
        :func:`~mbgen.studies.workprecision.plot.plot_report`)."""
        return plot_report(self, path)

    # ---------------------------------------------------------- summary
    def fastest(self, level: float, c_integrators: bool | None = None) -> Point | None:
        """The cheapest ok point with ``err_max <= level``.

        ``c_integrators``: True to look only at the C integrators, False only
        at solve_ivp, None at both.
        """
        pool = [p for p in self.points if p.ok and p.err_max <= level and (
            c_integrators is None or p.config.is_c_integrator == c_integrators)]
        return min(pool, key=lambda p: p.time_s, default=None)

    def summary(self) -> str:
        """Reference, fastest configuration per error level, solve_ivp overhead, failures."""
        n_ok = sum(p.ok for p in self.points)
        counts = ", ".join(f"{sum(p.status == s for p in self.points)} {s}"
                           for s in (OK, FAILED, OVER_BUDGET, SKIPPED))
        lines = [f"Work-precision summary: {self.scene} ({len(self.points)} points: {counts}; "
                 f"time: median of {self.repeats} timed loops; whole run {self.wall_time:.1f} s)",
                 self.reference.describe(), *(f"  ({n})" for n in self.reference.notes),
                 self.atol_note, ""]
        lines += self._levels() if n_ok else ["No point succeeded."]
        lines += self._same_steps()
        lines += self._overheads()
        lines += self._failures()
        return "\n".join(lines)

    def _levels(self) -> list[str]:
        floor = self.reference.disagreement
        lines = ["Fastest configuration per error level (max abs error over the output times; "
                 "cheapest point reaching it):"]
        for level in ERROR_LEVELS:
            if level < floor:
                lines.append(f"  error <= {level:.0e}: below the reference floor {floor:.1e}, "
                             f"not measurable")
                continue
            best = self.fastest(level)
            if best is None:
                lines.append(f"  error <= {level:.0e}: no configuration reached it")
                continue
            lines.append(f"  error <= {level:.0e}: {_describe(best)}")
            ivp, c = self.fastest(level, False), self.fastest(level, True)
            for name, p in (("solve_ivp", ivp), ("C integrators", c)):
                if p is not None and p is not best:
                    lines.append(f"      best {name}: {_describe(p)}")
            if ivp is not None and c is not None:
                lines.append(f"      {_speedup(ivp.time_s / c.time_s)} at this error")
        return lines

    def _same_steps(self) -> list[str]:
        """dopri5 against RK45 on the C back end: same tableau and step control."""
        pairs = [(a, b) for a, b in zip(self.curve(Config("RK45", "c")),
                                        self.curve(Config("dopri5", "c"))) if a.ok and b.ok]
        if not pairs:
            return []
        ratios = [a.time_s / b.time_s for a, b in pairs]
        evals = [b.nfev / a.nfev for a, b in pairs]
        return ["", f"dopri5 [c] vs RK45 [c] (same Dormand-Prince tableau and step control) at "
                    f"equal rtol: {statistics.median(ratios):.1f}x faster (median over "
                    f"{len(pairs)} tolerances; range {min(ratios):.1f}-{max(ratios):.1f}x), "
                    f"RHS calls ratio {min(evals):.2f}-{max(evals):.2f}"]

    def _overheads(self) -> list[str]:
        """Median share of solve_ivp's wall time spent outside the callables, per configuration."""
        rows = list(dict.fromkeys((c.method, c.jac) for c in self.configurations()
                                  if not c.is_c_integrator))
        backends = [b for b in BACKENDS if any(p.backend == b for p in self.points)]
        if not rows:
            return []
        lines = ["", "solve_ivp's own overhead: share of wall time outside the RHS/Jacobian "
                     "callables (median over ok points):",
                 "  " + f"{'method':<12}" + "".join(f"{b:>10}" for b in backends)]
        for method, jac in rows:
            cells = []
            for backend in backends:
                shares = [p.overhead for p in self.curve(Config(method, backend, jac))
                          if p.ok and p.overhead is not None]
                cells.append(f"{statistics.median(shares):>10.0%}" if shares else f"{'-':>10}")
            lines.append("  " + f"{method + (' +jac' if jac else ''):<12}" + "".join(cells))
        return lines

    def _failures(self) -> list[str]:
        bad = [p for p in self.points if not p.ok]
        if not bad:
            return []
        return ["", f"Points not ok ({len(bad)}):"] + [
            f"  {p.config.label} {p.setting}: {p.status}: {p.message}" for p in bad]


def _describe(p: Point) -> str:
    return f"{p.config.label} {p.setting}: {_ms(p.time_s)} ms, error {p.err_max:.1e}"


def _speedup(ratio: float) -> str:
    """``ratio`` = solve_ivp time / C integrator time, in words."""
    if ratio >= 1:
        return f"C integrators {ratio:.1f}x faster than solve_ivp"
    return f"solve_ivp {1 / ratio:.1f}x faster than the C integrators"


def _ms(seconds: float) -> str:
    """Milliseconds with three significant figures and no exponent."""
    ms = seconds * 1e3
    return f"{ms:.3f}" if ms < 1 else f"{ms:.2f}" if ms < 10 else f"{ms:.1f}" if ms < 100 \
        else f"{ms:.0f}"


_SHORT_STATUS = {FAILED: "fail", OVER_BUDGET: "budget", SKIPPED: "skip"}


def _matrix(title: str, configs: Sequence[Config], curve: Callable[[Config], list[Point]],
            rtols: Sequence[float], cell: Callable[[Point], str]) -> str:
    """A block of the table: one row per configuration, one column per tolerance."""
    width = max(len("configuration"), *(len(c.label) for c in configs)) + 2
    header = f"{'configuration':<{width}}" + "".join(f"{f'rtol {r:.0e}':>11}" for r in rtols)
    lines = [title, header, "-" * len(header)]
    for config in configs:
        cells = [cell(p) if p.ok else _SHORT_STATUS[p.status] for p in curve(config)]
        lines.append(f"{config.label:<{width}}" + "".join(f"{c:>11}" for c in cells))
    return "\n".join(lines)


def _csv_value(value) -> str:
    if value is None:
        return ""
    if isinstance(value, (float, np.floating)):
        return "" if math.isnan(value) else repr(float(value))
    return str(value)
