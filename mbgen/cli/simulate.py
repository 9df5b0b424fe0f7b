"""``mbgen simulate SCENE``: integrate with the compiled RHS (a solve_ivp method or a
generated C integrator) and write the trajectory as CSV, optionally a PNG.

``--integrator`` names the method (``--method`` is its old spelling); ``--rtol`` and
``--atol`` default to mbgen's one default tolerance
(:data:`mbgen.integrators.DEFAULT_RTOL`, ``DEFAULT_ATOL``).  ``-r NAME=FILE.csv`` drives
an input by a table of time and values (:func:`mbgen.runtime.named.read_input_csv`: linear
between rows; the C integrators interpolate it with no Python in the loop), and the plot
shows the inputs in a panel of their own.  ``--saturate`` clamps the inputs (held values
or tables) to the model's input bounds (a URDF joint's ``<limit effort>``,
``Model.bound``) before the right-hand side reads them, as the generated step API does
(:func:`mbgen.runtime.simulate.saturated`); the default follows the scene's ``saturate``,
``--no-saturate`` turns it off.  ``--floating``, ``--ground LINKS`` and ``--hold KP,KD``
set a URDF robot's scene options (a floating base, a compliant ground under those links,
its joints held at the start's posture: :mod:`mbgen.model.ground`, :mod:`mbgen.model.hold`),
and a scene on a ground is integrated by an implicit method (``stiff=True`` of
:func:`mbgen.runtime.simulate.simulate`).  On a terminal the pipeline's stages are
printed on stderr as they start (``  .. derive``, ``  .. CSE``, ...)."""

from __future__ import annotations

import argparse
from dataclasses import replace

from ..abi import Output
from ..errors import EXIT_OK, UsageError
from ..fileio import plain_name
from ..integrators import DEFAULT_ATOL, DEFAULT_RTOL
from ..model.builder import Model
from ..model.ground import DROP, drop_state, free_height
from ..model.hold import reference_name
from ..model.robots import ROBOTS
from ..model.scene import scene_options
from ..pipeline import compile
from ..runtime.simulate import (
    C_METHODS,
    IMPLICIT,
    beyond_bounds,
    choose_method,
    holonomic_outputs,
    simulate,
)
from ..viz.plots import plot_simulation
from ._common import (
    MAX_POINTS,
    add_integrator_argument,
    add_number_arguments,
    add_scene_arguments,
    assignments,
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
    add_ground_arguments(p)
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
    p.add_argument("--saturate", action=argparse.BooleanOptionalAction, default=None,
                   help="clamp the inputs to the model's input bounds (a URDF joint's <limit "
                        "effort>) before the right-hand side reads them; default: the "
                        "scene's saturate")


def run(args) -> int:
    method = args.integrator
    if method is not None:  # an unknown method is refused before any work
        choose_method(_NoModel, method if method.lower() not in C_METHODS else None)
    scene = _on_the_ground(with_numbers(scene_from(_ground_options(args)), args), args)
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
    stiff = getattr(scene.model, "ground_", None) is not None   # a compliant ground
    if stiff and (method is None or method.lower() == "auto"):
        outputs += (Output.JACOBIAN, Output.ROSENBROCK)
    stage = stage_lines(args)
    model = compile(scene, outputs, stage=stage)
    x0 = initial_state(scene, model)
    r = resolve_inputs(signals, model)
    if stage is not None:
        progress("simulate")
    bounds = _saturation(scene, model, args.saturate)
    traj = simulate(model, x0, (scene.t_span[0], t_end), r=r, method=method, rtol=args.rtol,
                    atol=args.atol, n_out=args.points, progress=not args.quiet, say=note,
                    max_steps=args.max_steps, saturate=bounds, stiff=stiff)
    path = traj.write_csv(csv)
    why = f" ({traj.message})" if traj.message and traj.message != "as asked" else ""
    print(f"{scene.name}: {traj.method}{why}, rtol={args.rtol:g} atol={args.atol:g}, "
          f"t = {scene.t_span[0]:g} .. {t_end:g}, {traj.nfev} RHS calls"
          + (f", {traj.njev} Jacobians" if traj.njev else "") + f", {traj.wall_time:.3f} s")
    print("final state: " + ", ".join(f"{k} = {v:.10g}" for k, v in traj.final.items()))
    _print_constraint_start(model, x0, traj)
    if bounds is not None:
        _print_speeds_beyond(scene, traj)
    print(f"trajectory: {path} ({len(traj.t)} rows)")
    if args.plot:
        drive = {**dict.fromkeys(model.input_names, 0.0), **signals}
        print(f"plot: {plot_simulation(traj, args.plot, scene=scene, inputs=drive)}")
    return EXIT_OK


def _saturation(scene, model, asked: bool | None) -> dict | None:
    """The input bounds to clamp to (``--saturate``; None: the scene's ``saturate``), those
    of the compiled model's inputs, said in a line; None when not saturating."""
    if not (scene.saturate if asked is None else asked):
        return None
    bounds = scene.input_bounds()
    if not bounds:
        raise UsageError(f"--saturate: no input of scene {scene.name!r} has bounds; bound one "
                         f"with Model.bound(input, lower, upper) (a URDF joint's <limit "
                         f"effort> does it), or leave --saturate out")
    bounds = {n: b for n, b in bounds.items() if n in model.input_names}
    print("inputs clamped to their bounds: "
          + ", ".join(f"{n} in [{lo:g}, {hi:g}]" for n, (lo, hi) in bounds.items()))
    return bounds


def _print_speeds_beyond(scene, traj) -> None:
    """Saturating: the speeds that left their bounds (reported, never clamped)."""
    bounds = scene.model.bounds("speeds") if hasattr(scene.model, "bounds") else {}
    beyond = beyond_bounds(traj, bounds)
    if beyond:
        print("speeds beyond their bounds (reported, not clamped): "
              + ", ".join(f"{n} from t = {t:.6g} (reaches {v:.6g}; bounds [{bounds[n][0]:g}, "
                          f"{bounds[n][1]:g}])" for n, (t, v) in beyond.items()))


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


# ------------------------------------------------------------------ a ground to stand on
#: The options of a robot's scene the ground flags set: flag attribute -> scene option.
GROUND_OPTIONS = {"floating": "floating", "ground": "ground", "hold": "hold"}


def add_ground_arguments(p: argparse.ArgumentParser) -> None:
    """``--floating``, ``--ground LINKS`` and ``--hold KP,KD``: a robot's scene options
    (``-O floating=true`` ...; :func:`~mbgen.model.scene.urdf_scene`,
    :func:`~mbgen.model.scene.mjcf_scene`) spelled as flags."""
    p.add_argument("--floating", action="store_true",
                   help="a URDF robot on a floating base (its scene option floating=true)")
    p.add_argument("--ground", metavar="LINK,LINK,...",
                   help="a robot on a compliant ground touched at these links' origins "
                        "(fixed links too, e.g. FL_FOOT,FR_FOOT,HL_FOOT,HR_FOOT; an MJCF "
                        "file's sphere geoms and sites): "
                        "parameters k_ground, c_ground, mu, v_slip; the lowest contact "
                        "starts 0.3 m up (-O drop=...) and auto integrates with the C "
                        "rosenbrock; default: no ground")
    p.add_argument("--hold", metavar="KP,KD",
                   help="hold every joint of a robot at its initial posture with a PD "
                        "torque -KP (q - q_ref) - KD u (parameters kp_hold, kd_hold, "
                        "q_<joint>_ref); default: no hold")


def _ground_options(args):
    """``args`` with the ground flags added to its ``-O`` options, once checked that the
    scene takes them (a URDF robot's)."""
    given = {option: getattr(args, flag) for flag, option in GROUND_OPTIONS.items()
             if getattr(args, flag, None)}
    if not given:
        return args
    known = scene_options(args.scene)
    missing = [f"--{flag}" for flag, option in GROUND_OPTIONS.items()
               if option in given and option not in known]
    if missing:
        raise UsageError(f"{', '.join(missing)} set the options of a robot's scene "
                         f"(a .urdf file, or one of {', '.join(ROBOTS)}; an MJCF .xml file "
                         f"takes --ground and --hold); scene "
                         f"{args.scene!r} has none: a Model of your own calls "
                         f"model.ground() and hold_posture() itself")
    text = {k: "true" if v is True else str(v) for k, v in given.items()}
    return argparse.Namespace(**{**vars(args),
                                 "option": list(args.option or []) +
                                 [f"{k}={v}" for k, v in text.items()]})


def _on_the_ground(scene, args):
    """A robot's scene after ``-x``: a floating base lifted again so that its lowest contact
    starts ``drop`` above the ground (unless ``-x`` placed it: ``root_z``), and each held
    joint's reference ``q_<joint>_ref`` its initial value (unless ``-p`` gave it)."""
    model, states = scene.model, assignments(getattr(args, "state", None), "-x")
    if not states or not isinstance(model, Model):
        return scene
    start, lift = dict(scene.initial_state), free_height(model)
    if model.ground_ is not None and lift is not None and lift not in states:
        start = drop_state(model, start, float(scene.options.get("drop", DROP)))
    given = assignments(getattr(args, "parameter", None), "-p")
    refs = {reference_name(q): float(start.get(q, 0.0))
            for q in (str(c.func) for c in model.coordinates_)
            if reference_name(q) in scene.parameters and reference_name(q) not in given}
    return replace(scene, initial_state=start, parameters={**scene.parameters, **refs})
