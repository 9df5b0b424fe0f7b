"""The work-precision diagram: log-log error against run time, one curve per configuration
(:func:`plot_report`, behind :meth:`~mbgen.studies.workprecision.report.WorkPrecisionReport.plot`).

Readable with many curves (3 integrator families x 3 back ends x with/without
Jacobian is 27 curves):

* one panel per method family -- solve_ivp's explicit methods, solve_ivp's
  implicit methods, the generated C integrators -- on shared axes;
* in every panel, the **Pareto front** of all ok points of the whole report
  (no other point is both faster and more accurate) as a thick grey line, so
  a family is compared with the best of every family;
* every ok point is labelled with its tolerance exponent (``6`` for rtol
  1e-6; ``rk4`` points with the row their fixed step is laid on);
* points that did not produce a solution are drawn in a strip at the top of
  their panel, one mark per configuration and outcome, labelled with the
  configuration and its tolerances: ``x`` failed (integrator or model error;
  at the run time of its probe when known, else at the budget), ``>``
  stopped at the time budget (drawn at the budget); the panel titles count
  them, the figure title also counts the skipped points (tighter tolerances
  after an over-budget one).

Colour: method; line style: back end; filled marker: with Jacobian.  The
dotted horizontal line is the reference floor (the disagreement of the two
reference solves).
"""

from __future__ import annotations

import math
from pathlib import Path

from ...viz.plots import figure, require_matplotlib, save_png
from .points import C_METHODS, FAILED, IMPLICIT_METHODS, OVER_BUDGET, SKIPPED, SOLVE_IVP_METHODS

#: Panels: (title, methods).
FAMILIES = (("solve_ivp explicit", tuple(m for m in SOLVE_IVP_METHODS
                                         if m not in IMPLICIT_METHODS)),
            ("solve_ivp implicit", IMPLICIT_METHODS),
            ("generated C integrators", C_METHODS))


def pareto_front(points) -> list:
    """Ok points not dominated by another (faster *and* at most as large an error), by time."""
    ok = sorted((p for p in points if p.ok and p.err_max > 0 and p.time_s > 0),
                key=lambda p: (p.time_s, p.err_max))
    front, best = [], math.inf
    for p in ok:
        if p.err_max < best:
            front.append(p)
            best = p.err_max
    return front


def tolerance_label(p) -> str:
    """``"6"`` for rtol 1e-6 (the exponent), ``"2.5e-6"`` when not a power of ten."""
    exponent = -math.log10(p.rtol)
    return f"{exponent:.0f}" if abs(exponent - round(exponent)) < 1e-9 else f"{p.rtol:.1e}"


def plot_report(report, path) -> Path:
    """Write the work-precision diagram of ``report`` as PNG (atomically); see the module.

    Parameters
    ----------
    report : WorkPrecisionReport
    path : str or Path

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    MissingExtraError
        matplotlib is not installed (the message names ``pip install 'mbgen[plot]'``).
    """
    require_matplotlib()
    from matplotlib.transforms import blended_transform_factory

    families = [(title, methods) for title, methods in FAMILIES
                if any(p.method in methods for p in report.points)] or [FAMILIES[0]]
    fig = figure(5.2 * len(families) + 2.4, 6.6)
    axes = fig.subplots(1, len(families), sharex=True, sharey=True, squeeze=False)[0]
    colours = {m: f"C{i}" for i, m in enumerate(SOLVE_IVP_METHODS + C_METHODS)}
    styles = {"c": "-", "python": "--", "lambdify": ":"}
    front = pareto_front(report.points)
    handles, extras = {}, {}
    for ax, (title, methods) in zip(axes, families):
        strip = blended_transform_factory(ax.transData, ax.transAxes)
        n_bad = n_marks = 0
        for config in report.configurations():
            if config.method not in methods:
                continue
            curve = report.curve(config)
            ok = [p for p in curve if p.ok and p.err_max > 0]
            colour = colours[config.method]
            if ok:
                line, = ax.plot([p.time_s for p in ok], [p.err_max for p in ok],
                                styles[config.backend], color=colour,
                                marker="o" if config.jac else "s",
                                markerfacecolor=None if config.jac else "none", markersize=5,
                                linewidth=1.2, label=config.label)
                handles[config.label] = line
                for p in ok:
                    ax.annotate(tolerance_label(p), (p.time_s, p.err_max), xytext=(3, 2),
                                textcoords="offset points", fontsize=6, color=colour)
            for status, marker in ((OVER_BUDGET, ">"), (FAILED, "x")):
                bad = [p for p in curve if p.status == status]
                if not bad:
                    continue
                # one mark per configuration and outcome, staggered down the strip
                x = report.time_budget if status == OVER_BUDGET else \
                    min(p.probe_s or report.time_budget for p in bad)
                y = 0.97 - 0.035 * (n_marks % 8)
                n_marks += 1
                n_bad += len(bad)
                ax.plot([x], [y], marker=marker, color=colour, markersize=7,
                        linestyle="", transform=strip, clip_on=False)
                ax.annotate(f"{config.label}: {','.join(tolerance_label(p) for p in bad)}",
                            (x, y), xycoords=strip, xytext=(-6, -3), ha="right",
                            textcoords="offset points", fontsize=6, color=colour)
        if front:
            pf, = ax.plot([p.time_s for p in front], [p.err_max for p in front], color="0.5",
                          linewidth=5, alpha=0.3, zorder=0, solid_capstyle="round",
                          label="Pareto front (all panels)")
            extras[pf.get_label()] = pf
        if report.reference.disagreement > 0:
            floor = ax.axhline(report.reference.disagreement, color="0.4",
                               linestyle=(0, (1, 3)),
                               label=f"reference floor {report.reference.disagreement:.1e}")
            extras[floor.get_label()] = floor
        ax.set_title(f"{title}" + (f"  ({n_bad} not ok, top strip)" if n_bad else ""),
                     fontsize=10)
        drawn = [p for p in report.points if p.method in methods and p.ok and p.err_max > 0]
        if not drawn and not front:   # nothing to scale the axes by: show the budget's decade
            ax.set_xlim(report.time_budget / 1e3, report.time_budget * 10)
            ax.set_ylim(1e-12, 1.0)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="major", alpha=0.4)
        ax.set_xlabel(f"run time, s (median of {report.repeats})")
    axes[0].set_ylabel("max abs error over the output times")
    from matplotlib.lines import Line2D

    handles.update(extras)
    handles["failed"] = Line2D([], [], marker="x", color="0.2", linestyle="",
                               label="x  failed (top strip, at its run time)")
    handles["over"] = Line2D([], [], marker=">", color="0.2", linestyle="",
                             label=f">  over the {report.time_budget:g} s budget (top strip)")
    counts = {s: sum(p.status == s for p in report.points) for s in (FAILED, OVER_BUDGET,
                                                                      SKIPPED)}
    fig.suptitle(f"{report.scene}: work-precision ({report.reference.source} reference); "
                 f"labels: -log10(rtol); {len(report.points)} points, "
                 f"{counts[FAILED]} failed, {counts[OVER_BUDGET]} over budget, "
                 f"{counts[SKIPPED]} skipped", fontsize=10)
    fig.legend(handles=list(handles.values()), loc="outside right upper", fontsize=7,
               frameon=False)
    return save_png(fig, path, dpi=110)
