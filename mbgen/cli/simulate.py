"""``mbgen simulate SCENE``: integrate with the compiled RHS (a solve_ivp method or a
generated C integrator) and write the trajectory as CSV, optionally a PNG.

``--integrator`` names the method (``--method`` is its old spelling); ``--rtol`` and
``--atol`` default to mbgen's one default tolerance
(:data:`mbgen.integrators.DEFAULT_RTOL`, ``DEFAULT_ATOL``).  ``-r NAME=FILE.csv`` drives
an input by a table of time and values (:func:`mbgen.runtime.named.read_input_csv`: linear
between rows; the C integrators interpolate it with no Python in the loop), and the plot
shows the inputs in a panel of their own.  On a terminal the pipeline's stages are
printed on stderr as they start (``  .. derive``, ``  .. CSE``, ...)."""

from __future__ import annotations

import argparse

from ..abi import Output
from ..errors import EXIT_OK
from ..fileio import plain_name
from ..integrators import DEFAULT_ATOL, DEFAULT_RTOL
from ..pipeline import compile
from ..runtime.simulate import C_METHODS, IMPLICIT, choose_method, holonomic_outputs, simulate
from ..viz.plots import plot_simulation
from ._common import (
    MAX_POINTS,
    add_integrator_argument,
    add_number_arguments,
    add_scene_arguments,
    check_count,
    check_file,
    end_time,
    initial_state,
    input_signals,
    nonnegative_float,
    note,
    positive_int,
    progress,
    resolve_inputs,
    scene_from,
    stage_lines,
    with_numbers,
)


def configure(p: argparse.ArgumentParser) -> None:
    add_scene_arguments(p)
    p.add_argument("--t-end", type=float, help="final time (default: the scene's)")
    add_integrator_argument(
        p, "a solve_ivp method (RK45, DOP853, Radau, BDF, LSODA, RK23; the implicit ones get "
           "the compiled Jacobian) or a generated C integrator (dopri5, rosenbrock, rk4: fixed "
           "step (t_end - t0)/10000); default auto: the scene's C integrator, else DOP853, "
           "switching to Radau when stiffness-bound")
    p.add_argument("--rtol", type=nonnegative_float, default=DEFAULT_RTOL,
                   help="relative tolerance of the integrator")
    p.add_argument("--atol", type=nonnegative_float, default=DEFAULT_ATOL,
                   help="absolute tolerance of the integrator")
    p.add_argument("--points", type=int, default=201, help="output times (default 201)")
    p.add_argument("--csv", metavar="PATH", help="trajectory file (default SCENE.csv)")
    p.add_argument("--plot", metavar="FILE",
                   help="also write a PNG: states against time, the inputs, energy drift when "
                        "the scene conserves energy, constraint residual when it has "
                        "constraints")
    add_number_arguments(p, tables=True)
    p.add_argument("--quiet", action="store_true",
                   help="no progress bar and no stage lines (these appear only when stderr "
                        "is a terminal)")
    p.add_argument("--max-steps", type=positive_int, default=None, metavar="N",
                   help="step limit (default: 1,000,000 for solve_ivp, the C integrator's own)")


def run(args) -> int:
    method = args.integrator
    if method is not None:  # an unknown method is refused before any work
        choose_method(_NoModel, method if method.lower() not in C_METHODS else None)
    scene = with_numbers(scene_from(args), args)
    t_end = end_time(scene, args.t_end)
    csv = check_file(args.csv or plain_name(f"{scene.name}.csv", "default CSV name"), "--csv")
    check_count(args.points, "--points", 2, MAX_POINTS, "output times")
    signals = input_signals(args)
    outputs = tuple(scene.outputs)
    if method is not None and method.lower() in C_METHODS:
        outputs += (Output(method.lower()),)
    elif method is None or method.lower() in {m.lower() for m in IMPLICIT} \
            or method.lower() == "auto":
        outputs += (Output.JACOBIAN,)  # for the implicit methods (and the stiffness check)
    outputs += holonomic_outputs(scene)   # consistent initial state (constrained scenes)
    stage = stage_lines(args)
    model = compile(scene, outputs, stage=stage)
    x0 = initial_state(scene, model)
    r = resolve_inputs(signals, model)
    if stage is not None:
        progress("simulate")
    traj = simulate(model, x0, (scene.t_span[0], t_end), r=r, method=method, rtol=args.rtol,
                    atol=args.atol, n_out=args.points, progress=not args.quiet, say=note,
                    max_steps=args.max_steps)
    path = traj.write_csv(csv)
    why = f" ({traj.message})" if traj.message and traj.message != "as asked" else ""
    print(f"{scene.name}: {traj.method}{why}, rtol={args.rtol:g} atol={args.atol:g}, "
          f"t = {scene.t_span[0]:g} .. {t_end:g}, {traj.nfev} RHS calls"
          + (f", {traj.njev} Jacobians" if traj.njev else "") + f", {traj.wall_time:.3f} s")
    print("final state: " + ", ".join(f"{k} = {v:.10g}" for k, v in traj.final.items()))
    _print_constraint_start(model, x0, traj)
    print(f"trajectory: {path} ({len(traj.t)} rows)")
    if args.plot:
        drive = {**dict.fromkeys(model.input_names, 0.0), **signals}
        print(f"plot: {plot_simulation(traj, args.plot, scene=scene, inputs=drive)}")
    return EXIT_OK


def _print_constraint_start(model, x0, traj) -> None:
    """Constrained models: the completed dependent coordinates and the largest residual."""
    dependent = getattr(model, "dependent_coordinates", ())
    if not dependent:
        return
    moved = [f"{n} {x0[model.state_names.index(n)]:.6g} "
             f"-> {traj.x[0][model.state_names.index(n)]:.10g}"
             for n in dependent]
    print("consistent start (dependent coordinates solved from the constraints): "
          + ", ".join(moved))
    print(f"largest constraint residual |f_h|: {traj.max_residual:.3g}"
          + ("" if traj.method.startswith("C ") else " (solve_ivp does not project)"))


class _NoModel:
    """Stands in for a model when only a method name is checked."""

    outputs, backend, name = (), "none", ""
    c_integrators = ()
