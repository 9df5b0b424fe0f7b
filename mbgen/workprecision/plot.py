"""The work-precision diagram: log-log error against run time, one curve per configuration
(:func:`plot_report`, behind :meth:`~mbgen.workprecision.report.WorkPrecisionReport.plot`).
"""

from __future__ import annotations

from pathlib import Path

from ..fileio import atomic_path
from .points import C_METHODS, SOLVE_IVP_METHODS


def plot_report(report, path) -> Path:
    """Log-log error (max over the output grid) against run time, one curve per configuration.

    Written as PNG, atomically (temporary file in the same folder, then
    ``os.replace``).  Colour: method; line style: back end; filled marker:
    with Jacobian.  The dotted horizontal line is the reference floor.

    Parameters
    ----------
    report : WorkPrecisionReport
    path : str or Path
        Where to write the PNG.

    Returns
    -------
    Path
        ``path``.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 7.5), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    colours = {m: f"C{i}" for i, m in enumerate(SOLVE_IVP_METHODS + C_METHODS)}
    styles = {"c": "-", "python": "--", "lambdify": ":"}
    for config in report.configurations():
        ok = [p for p in report.curve(config) if p.ok and p.err_max > 0]
        if not ok:
            continue
        ax.plot([p.time_s for p in ok], [p.err_max for p in ok], styles[config.backend],
                color=colours[config.method], marker="o" if config.jac else "s",
                markerfacecolor=None if config.jac else "none", markersize=5,
                label=config.label)
    if report.reference.disagreement > 0:
        ax.axhline(report.reference.disagreement, color="0.4", linestyle=(0, (1, 3)),
                   label=f"reference floor {report.reference.disagreement:.1e}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(f"run time, s (median of {report.repeats})")
    ax.set_ylabel("max abs error over the output times")
    ax.set_title(f"{report.scene}: work-precision ({report.reference.source} reference)")
    ax.grid(True, which="major", alpha=0.4)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    return path
