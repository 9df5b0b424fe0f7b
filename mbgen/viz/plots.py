"""Pictures of a simulation: states against time, energy drift, constraint residual.

:func:`plot_simulation` draws what ``mbgen simulate --plot FILE`` writes: one PNG with

* the states against time, coordinates and speeds in two panels (each curve
  labelled by its state name);
* when inputs are given (``inputs=``; ``mbgen simulate`` passes the model's, with
  ``-r``'s values or tables): the inputs against time, each as the run saw it (a
  table's rows joined by straight lines and held outside them, a number held);
* when the scene conserves energy (``Scene.conserves_energy``) and the
  equations know ``T`` and ``V``: the relative energy drift
  ``(E(t) - E(0)) / max_t (|T| + |V|)`` with ``E = T + V``;
* when the model has configuration constraints: the residual
  ``max_i |f_h,i(q, t)|`` along the trajectory (the C integrators project the
  dependent coordinates back after every step, solve_ivp does not).

The energy and the residual are evaluated by a small model compiled for them
(``Output.ENERGY`` or ``Output.HOLONOMIC``; cached by content hash like every
compiled model), so the caller's model needs neither.  States are matched by
name.

matplotlib is imported here, lazily: generation and checking do not need it
(it comes with ``pip install 'mbgen[plot]'``, and with the ``bench`` and ``test``
extras; :func:`require_matplotlib`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..abi import Output
from ..errors import MbgenError, MissingExtraError
from ..fileio import atomic_path
from ..pipeline import compile

#: The extra that installs matplotlib (``bench`` and ``test`` have it too).
EXTRA = "plot"


def require_matplotlib():
    """Import matplotlib or raise :class:`MissingExtraError` naming the extra."""
    try:
        import matplotlib
    except ImportError:
        raise MissingExtraError("pictures need matplotlib, which is not installed; install it "
                                f"with pip install 'mbgen[{EXTRA}]' "
                                "(or pip install matplotlib)") from None
    return matplotlib


def figure(width: float, height: float):
    """A matplotlib ``Figure`` with an Agg canvas (no display, no global pyplot state)."""
    require_matplotlib()
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save_png(fig, path, dpi: int = 100) -> Path:
    """Write ``fig`` to ``path`` as PNG, atomically."""
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=dpi)
    return path


def trajectory_arrays(result, names=None) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """``(t, x, names)`` with ``x`` of shape ``(k, n_x)`` from any mbgen or scipy result.

    Accepts objects with ``t`` and either ``x`` (``(k, n_x)``, mbgen's
    ``Trajectory`` and ``Integration``) or ``y`` (``(n_x, k)``, scipy's
    ``OdeResult``); ``names`` default to the result's ``names`` or
    ``state_names``.
    """
    t = np.asarray(result.t, dtype=float)
    x = getattr(result, "x", None)
    if x is None or np.ndim(x) != 2 or np.shape(x)[0] != t.size:
        y = getattr(result, "y", None)
        if y is None:
            raise MbgenError(f"cannot plot {type(result).__name__}: it has no states x (k, n_x) "
                             f"or y (n_x, k)")
        x = np.asarray(y, dtype=float).T
    x = np.asarray(x, dtype=float)
    names = names or getattr(result, "names", None) or getattr(result, "state_names", None)
    names = tuple(names) if names else tuple(f"x{i}" for i in range(x.shape[1]))
    if len(names) != x.shape[1]:
        raise MbgenError(f"{len(names)} state names for {x.shape[1]} states")
    return t, x, names


def _constrained(model) -> bool:
    holonomic = [c for c in getattr(model, "constraints_", ()) if c.kind == "holonomic"]
    eq_constraints = getattr(model, "constraints", None)
    return bool(holonomic) or bool(getattr(eq_constraints, "m_h", 0))


def diagnostics(scene, t, x, names, parameters: Mapping[str, float] | None = None, *,
                driven: bool = False) -> dict:
    """Energy drift and constraint residual of a trajectory of ``scene`` (what applies).

    Returns a dict with ``"energy_drift"`` (shape ``(k,)``, relative to
    ``max |T| + |V|``) when the scene conserves energy, its equations have
    energies and no input is ``driven`` (nonzero inputs do work), and ``"residual"``
    (``max_i |f_h,i|``, shape ``(k,)``) when it has configuration constraints;
    ``"notes"`` says what was left out and why.
    """
    out: dict = {"notes": []}
    wanted = []
    if not scene.conserves_energy:
        out["notes"].append("no energy drift: the scene does not conserve energy")
    elif driven:
        out["notes"].append("no energy drift: the inputs do work")
    else:
        wanted.append(Output.ENERGY)
    if _constrained(scene.model):
        wanted.append(Output.HOLONOMIC)
    for output in wanted:
        try:
            model = compile(scene, (output,))
        except MbgenError as exc:  # e.g. equations without energies
            out["notes"].append(f"no {output.value}: {exc}")
            continue
        p = _parameters(scene, model, parameters)
        idx = [names.index(n) for n in model.state_names]
        xs = x[:, idx]
        if output is Output.ENERGY:
            TV = np.array([model.energy(float(ti), xi, p) for ti, xi in zip(t, xs)])
            E = TV.sum(axis=1)
            scale = float(np.abs(TV).sum(axis=1).max()) or 1.0
            out["energy_drift"] = (E - E[0]) / scale
        else:
            out["residual"] = np.array([np.max(np.abs(model.holonomic(float(ti), xi, p)))
                                        for ti, xi in zip(t, xs)])
    return out


def _parameters(scene, model, overrides) -> np.ndarray:
    values = {**scene.parameters, **scene.fixed, **dict(overrides or {})}
    return np.array([float(values[n]) for n in model.parameter_names])


def plot_simulation(result, path, *, scene=None, names=None,
                    parameters: Mapping[str, float] | None = None, title: str | None = None,
                    inputs: Mapping[str, object] | None = None) -> Path:
    """Write a PNG of a simulation: states against time, energy drift, constraint residual.

    Parameters
    ----------
    result
        A trajectory: :class:`mbgen.runtime.integration.Trajectory`, an ``Integration``
        from ``CompiledModel.integrate``, scipy's ``solve_ivp`` result, or any
        object with ``t`` and ``x`` (``(k, n_x)``) or ``y`` (``(n_x, k)``).
    path : str or Path
        The PNG to write (atomically).
    scene : Scene, optional
        Its energy and constraints add the drift and residual panels (see the
        module docstring); without it only the states are drawn.
    names : sequence of str, optional
        State names (default: the result's).
    parameters : mapping, optional
        Parameter values by name that the simulation used instead of the
        scene's (for the energy and residual).
    title : str, optional
        Figure title (default: the scene's name and the result's method).
    inputs : mapping, optional
        The inputs that drove the run, by name: a number (held) or a ``(times,
        values)`` pair (piecewise linear, held outside ``times``, as an
        :class:`~mbgen.runtime.named.InputTable`).  Drawn in a panel of their own.

    Returns
    -------
    Path
        ``path``.
    """
    require_matplotlib()
    t, x, names = trajectory_arrays(result, names)
    driven = any(np.any(np.asarray(v[1] if isinstance(v, tuple) else v, dtype=float) != 0)
                 for v in (inputs or {}).values())
    extra = (diagnostics(scene, t, x, names, parameters, driven=driven) if scene is not None
             else {"notes": []})
    n_q = _n_coordinates(scene, names)
    panels = [("coordinates", list(range(n_q)))] if n_q else []
    panels.append(("speeds" if n_q else "states", list(range(n_q, len(names)))))
    panels = [(label, cols) for label, cols in panels if cols]
    n_rows = len(panels) + bool(inputs) + ("energy_drift" in extra) + ("residual" in extra)
    fig = figure(9.0, 2.6 * n_rows + 0.6)
    axes = fig.subplots(n_rows, 1, sharex=True, squeeze=False)[:, 0]
    row = 0
    for label, cols in panels:
        ax = axes[row]
        for i in cols:
            ax.plot(t, x[:, i], label=names[i], linewidth=1.2)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.35)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False,
                  ncol=1 if len(cols) <= 12 else 2)
        row += 1
    if inputs:
        ax = axes[row]
        for name, signal in inputs.items():
            ax.plot(*input_curve(signal, t[0], t[-1]), label=name, linewidth=1.2)
        ax.set_ylabel("inputs")
        ax.grid(True, alpha=0.35)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False,
                  ncol=1 if len(inputs) <= 12 else 2)
        row += 1
    if "energy_drift" in extra:
        ax = axes[row]
        drift = extra["energy_drift"]
        ax.plot(t, drift, color="C3", linewidth=1.2,
                label=f"largest |drift|\n{np.max(np.abs(drift)):.2e}")
        ax.set_ylabel("energy drift\n(E - E0) / max(|T|+|V|)")
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
        ax.grid(True, alpha=0.35)
        row += 1
    if "residual" in extra:
        ax = axes[row]
        res = extra["residual"]
        positive = res[res > 0]
        label = f"largest residual\n{np.max(res):.2e}"
        if positive.size:
            ax.semilogy(t, np.where(res > 0, res, np.nan), color="C4", linewidth=1.2,
                        label=label)
        else:
            ax.plot(t, res, color="C4", linewidth=1.2, label=label)
        ax.set_ylabel("constraint residual\nmax |f_h(q, t)|")
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
        ax.grid(True, alpha=0.35)
        row += 1
    axes[-1].set_xlabel("t")
    method = getattr(result, "method", "")
    head = title or " ".join(s for s in (getattr(scene, "name", ""), str(method or "")) if s)
    if extra["notes"]:
        head += "\n" + "; ".join(extra["notes"])
    if head:
        fig.suptitle(head, fontsize=10)
    return save_png(fig, path)


def input_curve(signal, t0: float, t1: float) -> tuple[np.ndarray, np.ndarray]:
    """``(times, values)`` to draw of an input over ``[t0, t1]``: a number held, or a
    ``(times, values)`` table's rows inside the span joined by straight lines, the table
    interpolated (or held) at both ends of the span."""
    if not isinstance(signal, tuple):
        return np.array([t0, t1]), np.full(2, float(signal))
    times, values = (np.asarray(a, dtype=float) for a in signal)
    inside = times[(times > t0) & (times < t1)]
    at = np.concatenate([[t0], inside, [t1]])
    return at, np.interp(at, times, values)


def _n_coordinates(scene, names) -> int:
    """Number of coordinates among ``names`` (the first ones), from the scene's model."""
    if scene is None:
        return 0
    model = scene.model
    coords = getattr(model, "coordinates_", None)
    if coords is not None:
        return len(coords)
    layout = getattr(model, "layout", None)
    return layout.n_q if layout is not None else 0
