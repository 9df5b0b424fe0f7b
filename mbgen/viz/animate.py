"""A 3-D animation of a scene's points and bodies (``mbgen animate SCENE -o FILE``).

:func:`animate_scene` compiles the scene with ``Output.POSITIONS`` for every
point of its model (the Newtonian components of each point's position, shape
``(k, 3)``), simulates it (the scene's C integrator when it has one, else
solve_ivp's DOP853), and draws each frame:

* every point as a dot, with a segment from the point it was placed from
  (``model.point(name, parent, offset)``: the tree of offsets, which for a
  chain of links is the links themselves);
* particles and the mass centres of rigid bodies as larger dots, labelled;
* the path of every particle and mass centre so far, faint;
* every rigid body's axes at its mass centre (x red, y green, z blue), from
  the direction cosines ``N.dcm(B)`` of its frame along the run.

The axes are equal (a metre is a metre in every direction) and fixed over the
whole animation.  ``.html`` writes a self-contained page (matplotlib's
``to_jshtml``: the frames as PNG in the page, with play controls; any browser
shows it, none is needed to write it); ``.gif`` writes an animated GIF with
Pillow (a matplotlib dependency).

matplotlib is imported lazily (``pip install 'mbgen[plot]'``).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import sympy as sm

from ..abi import Output
from ..errors import MbgenError, SceneError
from ..fileio import atomic_path
from ..model.builder import Model
from ..model.builder import t as time_symbol
from ..pipeline import run
from ..runtime.simulate import simulate, simulate_in_c
from .plots import figure, require_matplotlib

#: File suffixes :func:`animate_scene` writes.
FORMATS = (".html", ".gif")


def animate_scene(scene, path, *, frames: int = 100, t_end: float | None = None,
                  fps: float = 20.0) -> Path:
    """Simulate ``scene`` and write an animation of its points and bodies to ``path``.

    Parameters
    ----------
    scene : Scene
        A scene whose model is an :class:`mbgen.Model` (its points are drawn).
    path : str or Path
        ``.html`` (interactive, self-contained) or ``.gif``; written atomically.
    frames : int
        Number of frames, equally spaced over the scene's ``t_span``.
    t_end : float, optional
        Final time (default: the scene's).
    fps : float
        Frames per second of playback.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    SceneError
        The scene's model is not a :class:`~mbgen.Model` (equations carry no
        geometry), has no points but its origin, or the suffix is not
        :data:`FORMATS`; ``frames < 2``.
    """
    require_matplotlib()   # before the simulation, not after
    path = Path(path)
    if path.suffix.lower() not in FORMATS:
        raise SceneError(f"animation file {str(path)!r}: use a name ending in "
                         f"{' or '.join(FORMATS)} (e.g. -o {path.stem or 'scene'}.html)")
    if int(frames) < 2:
        raise SceneError(f"an animation needs at least 2 frames; got {frames}")
    model = scene.model
    if not isinstance(model, Model):
        raise SceneError(f"scene {scene.name!r} holds equations, not a Model: it has no points "
                         f"to draw (animate a scene built with mbgen.Model)")
    names = [p.name for p in model.points if p is not model.origin]
    if not names and not model.bodies:
        raise SceneError(f"scene {scene.name!r} has no points besides the origin and no rigid "
                         f"bodies to draw; place points with model.point()")
    t, positions, states = _simulate_positions(scene, names, int(frames), t_end)
    triads = _body_axes(scene, model, t, states)
    _write(scene, model, names, t, positions, triads, path, fps)
    return path


def _simulate_positions(scene, names, frames, t_end):
    """Times ``(k,)``, positions ``(k, n_points, 3)`` of the named points, and the states
    ``{name: (k,)}``."""
    integrators = [o for o in scene.outputs if Output(o).is_integrator]
    method = Output(integrators[0]) if integrators else None
    outputs = ((Output.POSITIONS,) if names else ()) + ((method,) if method else (Output.RHS,))
    result = run(replace(scene, points=tuple(names)), outputs)
    model = result.compiled
    order = [pk.name for pk in result.baked.points]
    x0 = scene.x0(model.layout)
    if model.dependent_coordinates:
        x0 = model.consistent(x0)
    span = (scene.t_span[0], scene.t_span[1] if t_end is None else float(t_end))
    p = scene.p(model.layout)
    if method is not None and method is not Output.RK4:
        traj = simulate_in_c(model, x0, span, method=method.value, rtol=1e-8, atol=1e-10,
                             n_out=frames, p=p)
    else:
        traj = simulate(model, x0, span, p=p, rtol=1e-8, atol=1e-10, n_out=frames)
    states = dict(zip(model.state_names, traj.x.T))
    if not names:
        return traj.t, np.zeros((traj.t.size, 0, 3)), states
    pos = np.array([model.positions(float(ti), xi, p) for ti, xi in zip(traj.t, traj.x)])
    return traj.t, pos[:, [order.index(n) for n in names], :], states


def _body_axes(scene, model, t, states) -> list:
    """Per rigid body ``(name, centre point, R)`` with ``R`` of shape ``(k, 3, 3)``: the body's
    unit vectors (columns) in Newtonian components, ``N.dcm(B)`` evaluated along the run.

    The direction cosines of a frame depend only on the coordinates, constants and time
    (small expressions of the model's rotation chain, not derived quantities).
    """
    values = {**scene.parameters, **scene.fixed}
    coords = list(model.coordinates_)
    consts = [c for c in model.constants_ if str(c) in values]
    out = []
    for body in model.bodies:
        R = model.N.dcm(body.frame)
        fn = sm.lambdify([coords, consts, time_symbol], R, modules="numpy")
        args = [float(values[str(c)]) for c in consts]
        q = np.array([states[str(c.func)] for c in coords]) if coords else np.zeros((0, t.size))
        mats = np.array([np.asarray(fn(list(q[:, k]), args, float(t[k])), dtype=float)
                         for k in range(t.size)])
        out.append((body.name, body.center, mats))
    return out


def _write(scene, model, names, t, positions, triads, path: Path, fps: float) -> None:
    require_matplotlib()
    from matplotlib.animation import FuncAnimation

    index = {n: i for i, n in enumerate(names)}
    origin = np.zeros(3)

    def where(k, point):
        return origin if point is model.origin else positions[k, index[point.name]]

    segments = [(d.parent, d.point) for d in model.points.values()
                if d.parent is not None and d.point.name in index]
    masses = [(pt.name, pt.point) for pt in model.particles] + \
             [(b.name, b.center) for b in model.bodies]
    masses = [(label, pt) for label, pt in masses if pt is model.origin or pt.name in index]

    extent = np.concatenate([positions.reshape(-1, 3), np.zeros((1, 3))])
    size = float((extent.max(axis=0) - extent.min(axis=0)).max())
    axis_length = 0.25 * size if size > 0 else 1.0
    tips = [np.array([where(k, centre) for k in range(len(t))])[:, :, None] +
            axis_length * R for _, centre, R in triads]      # (k, 3 components, 3 axes)

    fig = figure(6.4, 6.0)
    ax = fig.add_subplot(projection="3d")
    every = np.concatenate([positions.reshape(-1, 3), origin[None]] +
                           [tip.transpose(0, 2, 1).reshape(-1, 3) for tip in tips])
    lo, hi = every.min(axis=0), every.max(axis=0)
    centre, half = (lo + hi) / 2, max(float((hi - lo).max()) / 2, 1e-9) * 1.1
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))
    n_frame = model.N.name if model.N is not None else "N"
    ax.set_xlabel(f"{n_frame}.x")
    ax.set_ylabel(f"{n_frame}.y")
    ax.set_zlabel(f"{n_frame}.z")
    lines = [ax.plot([], [], [], color="0.35", linewidth=1.5)[0] for _ in segments]
    dots = ax.plot([], [], [], linestyle="", marker="o", markersize=3, color="0.2")[0]
    heavy = ax.plot([], [], [], linestyle="", marker="o", markersize=9, color="C0")[0]
    trails = [ax.plot([], [], [], color="C0", alpha=0.3, linewidth=0.8)[0] for _ in masses]
    labels = [ax.text(0, 0, 0, label, fontsize=8) for label, _ in masses]
    axes_lines = [[ax.plot([], [], [], color=c, linewidth=2)[0] for c in ("C3", "C2", "C0")]
                  for _ in triads]
    title = ax.set_title("")

    def draw(k):
        for line, (a, b) in zip(lines, segments):
            ab = np.array([where(k, a), where(k, b)])
            line.set_data_3d(ab[:, 0], ab[:, 1], ab[:, 2])
        pts = positions[k]
        dots.set_data_3d(pts[:, 0], pts[:, 1], pts[:, 2])
        if masses:
            m = np.array([where(k, pt) for _, pt in masses])
            heavy.set_data_3d(m[:, 0], m[:, 1], m[:, 2])
            for trail, label, (_, pt) in zip(trails, labels, masses):
                path_so_far = np.array([where(j, pt) for j in range(k + 1)])
                trail.set_data_3d(path_so_far[:, 0], path_so_far[:, 1], path_so_far[:, 2])
                label.set_position_3d(path_so_far[-1])
        for body_lines, tip, (_, centre, _) in zip(axes_lines, tips, triads):
            c = where(k, centre)
            for j, line in enumerate(body_lines):
                line.set_data_3d([c[0], tip[k, 0, j]], [c[1], tip[k, 1, j]],
                                 [c[2], tip[k, 2, j]])
        title.set_text(f"{scene.name}   t = {t[k]:.3f}")
        return [*lines, dots, heavy, *trails, *labels, *sum(axes_lines, []), title]

    anim = FuncAnimation(fig, draw, frames=len(t), interval=1000.0 / fps, blit=False)
    with atomic_path(path) as tmp:
        if path.suffix.lower() == ".html":
            fig.set_dpi(80)   # the frames are embedded as PNG: keep the page small
            page = anim.to_jshtml(fps=fps, default_mode="loop")
            tmp.write_text(f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>"
                           f"{scene.name}</title></head><body>\n{page}\n</body></html>\n",
                           encoding="utf-8")
        else:
            _save_gif(fig, draw, len(t), fps, tmp)


def _save_gif(fig, draw, n: int, fps: float, target: Path) -> None:
    """Draw every frame on the Agg canvas and write them as one looping GIF (Pillow)."""
    try:
        from PIL import Image
    except ImportError:
        raise MbgenError("writing a GIF needs Pillow (a matplotlib dependency); install it "
                         "with pip install pillow, or write .html") from None
    images = []
    for k in range(n):
        draw(k)
        fig.canvas.draw()
        rgba = np.asarray(fig.canvas.buffer_rgba())
        images.append(Image.fromarray(rgba[..., :3].copy()).quantize(colors=128))
    images[0].save(target, format="GIF", save_all=True, append_images=images[1:],
                   duration=int(round(1000.0 / fps)), loop=0)
