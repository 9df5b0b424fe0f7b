"""Command-line interface: ``mbgen scenes | generate | check | simulate | demo | bench | stress | golden``.

Exit codes
----------
0  success
1  a check failed (errors above tolerance, golden files out of date)
2  usage error (bad arguments)
3  bad model or scene (unknown scene, missing file, malformed model, bad option)
4  the C compiler failed
5  numerical failure (singular mass matrix, non-finite result, integrator failure)
6  check inconclusive: some output was compared on no sample (every sample failed in
   every back end: a zero mass, a NaN parameter, a singular mass matrix everywhere)
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path


from dataclasses import replace

from .._version import __version__
from ..derive import Method
from ..errors import (BuildError, CacheError, CheckFailed, CheckInconclusive, MbgenError,
                      ModelError, NonFiniteResultError, SceneError, SingularMassMatrixError,
                      UnknownNameError, UsageError)

EXIT_OK, EXIT_CHECK, EXIT_USAGE, EXIT_MODEL, EXIT_BUILD, EXIT_NUMERIC = 0, 1, 2, 3, 4, 5
EXIT_INCONCLUSIVE = 6


def _options(pairs) -> dict:
    """``-O KEY=VALUE`` pairs as ``{key: text}``; the scene converts and checks the values."""
    out = {}
    for pair in pairs or ():
        if "=" not in pair:
            raise SceneError(f"option {pair!r} must look like KEY=VALUE (e.g. -O n=4)")
        k, v = pair.split("=", 1)
        k = k.strip()
        if not k.isidentifier():
            raise SceneError(f"option {pair!r}: {k!r} is not an option name (e.g. -O n=4)")
        if k in out:
            raise SceneError(f"option {k!r} is given twice (-O {k}={out[k]} and -O {pair})")
        out[k] = v.strip()
    return out


def _scene(args):
    from ..model.scene import load_scene

    scene = load_scene(args.scene, force=getattr(args, "force", False), **_options(args.option))
    derivation = getattr(args, "derivation", None)
    return replace(scene, method=Method(derivation)) if derivation else scene


# ------------------------------------------------------- numbers by name, paths
def _assignments(pairs, flag: str) -> dict[str, float]:
    """``["c=0.5", ...]`` of ``flag`` (-p, -r, -x) -> ``{"c": 0.5}``."""
    out = {}
    for pair in pairs or ():
        name, eq, value = pair.partition("=")
        name = name.strip()
        if not eq or not name:
            raise UsageError(f"{flag} {pair!r} must look like NAME=VALUE (e.g. {flag} c=0.5)")
        try:
            out[name] = float(value)
        except ValueError:
            raise UsageError(f"{flag} {pair!r}: {value.strip()!r} is not a number") from None
    return out


def _with_numbers(scene, args):
    """``scene`` with ``-p NAME=VALUE`` (parameters, fixed ones included) and ``-x NAME=VALUE``
    (initial state) applied; parameter names are checked here ("did you mean")."""
    from ..run.named import check_names

    params = _assignments(getattr(args, "parameter", None), "-p")
    states = _assignments(getattr(args, "state", None), "-x")
    if params:
        check_names(params, sorted({*scene.parameters, *scene.fixed}), "parameters",
                    scene.name)
        scene = replace(scene, parameters={**scene.parameters,
                                           **{k: v for k, v in params.items()
                                              if k not in scene.fixed}},
                        fixed={k: params.get(k, v) for k, v in scene.fixed.items()})
    if states:
        from ..model.scene import model_names

        known = (model_names(scene.model) or {}).get("states")
        if known is not None:
            check_names(states, known, "states", scene.name)
        scene = replace(scene, initial_state={**scene.initial_state, **states})
    return scene


def _initial_state(scene, model):
    """The scene's initial state for ``model``; ``-x`` names are checked ("did you mean")."""
    from ..run.named import check_names

    check_names(scene.initial_state, model.state_names, "states", scene.name)
    return scene.x0(model.layout)


def _inputs(args, model):
    """``-r NAME=VALUE`` as the model's input vector (others 0)."""
    from ..run.named import inputs

    return inputs(model, _assignments(getattr(args, "input", None), "-r"))


def _nearest_existing(path: Path) -> Path:
    path = path.absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def _check_folder(path, flag: str) -> Path:
    """Refuse (before any work) an output folder that is a file or cannot be created."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise UsageError(f"{flag} {str(path)!r} is a file, not a folder; give a folder (it is "
                         f"created when missing)")
    base = _nearest_existing(path)
    if not base.is_dir():
        raise UsageError(f"{flag} {str(path)!r}: {str(base)!r} is a file, so the folder cannot "
                         f"be created; choose another path")
    if not os.access(base, os.W_OK | os.X_OK):
        raise UsageError(f"{flag} {str(path)!r}: the folder {str(base)!r} is not writable; "
                         f"choose a folder you can write")
    return path


def _check_file(path, flag: str) -> Path:
    """Refuse (before any work) an output file that is a folder or cannot be written."""
    path = Path(path)
    if path.is_dir():
        raise UsageError(f"{flag} {str(path)!r} is a folder; give a file path (e.g. "
                         f"{str(path / 'trajectory.csv')!r})")
    if path.exists() and not os.access(path, os.W_OK):
        raise UsageError(f"{flag} {str(path)!r} is not writable; choose another file")
    base = _nearest_existing(path.parent)
    if not base.is_dir():
        raise UsageError(f"{flag} {str(path)!r}: {str(base)!r} is a file, not a folder; choose "
                         f"a path in a folder")
    if not os.access(base, os.W_OK | os.X_OK):
        raise UsageError(f"{flag} {str(path)!r}: the folder {str(base)!r} is not writable; "
                         f"choose a folder you can write")
    return path


def _os_error(exc: OSError) -> str:
    """What went wrong with a file or folder, and the fix."""
    name = exc.filename or ""
    env = os.environ.get("MBGEN_CACHE_DIR")  # build.cache_dir(), without creating it
    cache = Path(env) if env else Path(os.environ.get("XDG_CACHE_HOME",
                                                      Path.home() / ".cache")) / "mbgen"
    where = f" {str(name)!r}" if name else ""
    if name and (Path(name).absolute() == cache.absolute()
                 or cache.absolute() in Path(name).absolute().parents):
        return (f"cannot use the compile cache folder {str(cache)!r} ({exc.strerror}); set "
                f"MBGEN_CACHE_DIR to a writable folder")
    return f"cannot write{where}: {exc.strerror or exc}; choose a writable path"


def _progress(msg: str) -> None:
    print(f"  .. {msg}", file=sys.stderr, flush=True)


# ------------------------------------------------------------------ commands
def cmd_scenes(args) -> int:
    from ..model.scene import builtin_names, load_scene, scene_options

    for name in builtin_names():
        opts = scene_options(name)
        scn = load_scene(name)
        extra = f"  [options: {', '.join(f'{k}={v}' for k, v in opts.items())}]" if opts else ""
        print(f"{name:<15} {scn.description}{extra}")
    return EXIT_OK


#: Where ``mbgen generate SCENE`` writes without ``-o``: ``./mbgen-out/SCENE/`` (never the
#: checked-in golden tree ``generated/``, which only ``mbgen golden --update`` writes).
DEFAULT_OUTPUT = Path("mbgen-out")


def cmd_generate(args) -> int:
    from ..codegen.targets.example import render_example
    from ..fileio import plain_name, write_generated
    from ..pipeline import run

    scene = _scene(args)
    outputs = args.outputs.split(",") if args.outputs else None
    folder = Path(args.output) if args.output else \
        DEFAULT_OUTPUT / plain_name(scene.name, "scene name")
    if folder.exists() and not folder.is_dir():  # before any work
        raise SceneError(f"output folder {str(folder)!r} is a file; give a folder with -o")
    result = run(scene, outputs, build=False, sliced=not args.no_slice)
    files = dict(result.rendered.files)
    example = render_example(scene, result.kernel)
    if example is not None:
        files["example.c"] = example
    changed, removed = write_generated(folder, files, overwrite=args.overwrite)
    for name in sorted(files):
        state = "written" if folder / name in changed else "unchanged"
        print(f"{folder / name}  ({state})")
    for path in removed:
        print(f"{path}  (removed: no longer generated)")
    k = result.kernel
    print(f"operations: {k.ops_before} before CSE, {k.ops_after} after "
          f"({', '.join(f.output.value for f in k.functions)})")
    if args.explain:
        from ..verify.audit import audit

        print()
        print(audit(scene).format())
    return EXIT_OK


def cmd_linearize(args) -> int:
    import numpy as np

    from ..fileio import write_atomic
    from ..run.linearize import linearize
    from ..abi import Output
    from ..pipeline import compile

    if args.output:
        _check_folder(args.output, "-o")
    scene = _with_numbers(_scene(args), args)
    outputs = [Output.RHS, Output.JACOBIAN]
    model_eq = scene.model
    constrained = bool(getattr(model_eq, "constraints_", None) or
                       getattr(model_eq, "constraints", None))
    if constrained:
        outputs += [Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN]
    model = compile(scene, outputs + ([Output.INPUT_JACOBIAN] if _has_inputs(scene) else []))
    x = _initial_state(scene, model)
    r = _inputs(args, model)
    if model.dependent_coordinates:
        x = model.consistent(x, r=r)
    lin = linearize(model, x, scene.p(model.layout), r)
    print(f"{scene.name}: operating point " + ", ".join(
        f"{n} = {v:.6g}" for n, v in zip(model.state_names, x)))
    print(lin.format())
    if args.output:
        folder = Path(args.output)
        for name, matrix, cols in (("A", lin.A, lin.states), ("B", lin.B, lin.inputs)):
            text = ",".join(cols) + "\n" + "".join(
                ",".join(repr(float(v)) for v in row) + "\n" for row in np.atleast_2d(matrix))
            write_atomic(folder / f"{name}.csv", text)
        print(f"wrote {folder / 'A.csv'} and {folder / 'B.csv'} (rows and columns: "
              f"{', '.join(lin.states)})")
    return EXIT_OK


def _has_inputs(scene) -> bool:
    model = scene.model
    inputs = getattr(model, "inputs_", None)
    if inputs is None:
        inputs = model.layout.inputs
    return bool(inputs) and scene.inputs != ()


def cmd_check(args) -> int:
    from ..verify.check import check

    if args.samples < 1:
        print(f"mbgen: error: --samples must be at least 1 (got {args.samples}): a check of "
              f"no sample proves nothing", file=sys.stderr)
        return EXIT_USAGE
    report = check(_with_numbers(_scene(args), args), samples=args.samples, seed=args.seed,
                   rtol=args.rtol,
                   atol=args.atol)
    print(report.format())
    if report.ok:
        return EXIT_OK
    if report.inconclusive:
        print(f"mbgen: check inconclusive: {report.name}: nothing was compared for some "
              f"outputs (every sample failed in every back end); see the report",
              file=sys.stderr)
        return EXIT_INCONCLUSIVE
    print(f"mbgen: check failed: {report.name}: see the report", file=sys.stderr)
    return EXIT_CHECK


def cmd_simulate(args) -> int:
    from ..fileio import plain_name
    from ..abi import Output
    from ..pipeline import compile
    from ..model.scene import check_span
    from ..run.simulate import C_METHODS, IMPLICIT, choose_method, holonomic_outputs, simulate

    method = args.method
    if method is not None:  # an unknown method is refused before any work
        choose_method(_NoModel, method if method.lower() not in C_METHODS else None)
    scene = _with_numbers(_scene(args), args)
    check_span(scene.t_span[0], scene.t_span[1] if args.t_end is None else args.t_end, "--t-end")
    csv = _check_file(args.csv or plain_name(f"{scene.name}.csv", "default CSV name"), "--csv")
    if args.points < 2:
        raise UsageError(f"--points {args.points}: give at least 2 output times")
    outputs = tuple(scene.outputs)
    if method is not None and method.lower() in C_METHODS:
        outputs += (Output(method.lower()),)
    elif method is None or method.lower() in {m.lower() for m in IMPLICIT} \
            or method.lower() == "auto":
        outputs += (Output.JACOBIAN,)  # for the implicit methods (and the stiffness check)
    outputs += holonomic_outputs(scene)   # consistent initial state (constrained scenes)
    model = compile(scene, outputs)
    x0 = _initial_state(scene, model)
    r = _inputs(args, model)
    t_end = args.t_end if args.t_end is not None else scene.t_span[1]

    def note(msg: str) -> None:
        print(f"mbgen: note: {msg}", file=sys.stderr, flush=True)

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
        from ..viz.plots import plot_simulation

        print(f"plot: {plot_simulation(traj, args.plot, scene=scene)}")
    return EXIT_OK


def cmd_animate(args) -> int:
    from ..viz.animate import animate_scene

    scene = _scene(args)
    path = animate_scene(scene, args.output or f"{scene.name}.html", frames=args.frames,
                         t_end=args.t_end, fps=args.fps)
    print(f"{scene.name}: {args.frames} frames -> {path}")
    return EXIT_OK


def _print_constraint_start(model, x0, traj) -> None:
    """Constrained models: the completed dependent coordinates and the largest residual."""
    dependent = getattr(model, "dependent_coordinates", ())
    if not dependent:
        return
    moved = [f"{n} {x0[model.state_names.index(n)]:.6g} -> {traj.x[0][model.state_names.index(n)]:.10g}"
             for n in dependent]
    print("consistent start (dependent coordinates solved from the constraints): "
          + ", ".join(moved))
    print(f"largest constraint residual |f_h|: {traj.max_residual:.3g}"
          + ("" if traj.method.startswith("C ") else " (solve_ivp does not project)"))


class _NoModel:
    """Stands in for a model when only a method name is checked."""

    outputs, backend, name = (), "none", ""


def _per_call_us(f, t, x, calls: int = 2000, repeats: int = 5) -> float:
    """Median over ``repeats`` of the mean time of ``calls`` calls, in microseconds."""
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(calls):
            f(t, x)
        samples.append((time.perf_counter() - start) / calls * 1e6)
    return statistics.median(samples)


def cmd_demo(args) -> int:
    from ..verify.check import check
    from ..fileio import write_files
    from ..pipeline import python_model, run
    from ..run.lambdified import LambdifiedModel
    from ..model.scene import load_scene
    from ..run.simulate import simulate, simulate_in_c

    _check_folder(args.output, "-o")
    scene = load_scene("disc_pendulum")
    print(f"mbgen demo: {scene.description}")
    _progress("derive, CSE, render, compile")
    result = run(scene)
    model = result.compiled
    folder = Path(args.output)
    write_files(folder, result.rendered.files)
    _progress("check against lambdify")
    report = check(scene, result=result, samples=50)
    _progress("simulate")
    x0, p = scene.x0(model.layout), scene.p(model.layout)
    traj = simulate(model, x0, scene.t_span, method="DOP853", rtol=1e-10, atol=1e-12,
                    progress=False)
    csv_path = traj.write_csv(folder / "trajectory.csv")
    in_c = simulate_in_c(model, x0, scene.t_span, method="dopri5", rtol=1e-10, atol=1e-12)
    gap = float(abs(in_c.x[-1] - traj.x[-1]).max())
    _progress("time the right-hand sides side by side")
    lam = LambdifiedModel(result.baked, model.outputs, layout=result.layout)
    py = python_model(result.rendered)
    speeds = {name: _per_call_us(m.bind(p), 0.0, x0) for name, m in
              (("compiled C", model), ("generated Python", py), ("lambdify", lam))}

    k = result.kernel
    rows = [("derive (Kane)", f"{result.timings['derive'] * 1e3:.1f} ms"),
            ("CSE", f"{result.timings['cse'] * 1e3:.1f} ms"),
            ("render", f"{result.timings['render'] * 1e3:.1f} ms"),
            ("compile (cffi)", f"{result.timings['compile'] * 1e3:.1f} ms"
             + (" (cache hit: source unchanged)" if result.compile_cached else "")),
            ("operations before -> after CSE", f"{k.ops_before} -> {k.ops_after}"),
            ("max rel error C vs lambdify", f"{report.max_rel:.2e} ({report.samples} states)"),
            ("simulate t = 0..20: solve_ivp DOP853, rtol 1e-10",
             f"{traj.wall_time * 1e3:.1f} ms, {traj.nfev} RHS calls"),
            ("simulate t = 0..20: C dopri5, rtol 1e-10",
             f"{in_c.wall_time * 1e3:.2f} ms, {in_c.nfev} RHS calls "
             f"({traj.wall_time / in_c.wall_time:.0f}x faster; final states differ by {gap:.1e})"),
            ("RHS call: compiled C", f"{speeds['compiled C']:.2f} us"),
            ("RHS call: generated Python", f"{speeds['generated Python']:.2f} us"),
            ("RHS call: lambdify", f"{speeds['lambdify']:.2f} us"),
            ("C speed-up over lambdify", f"{speeds['lambdify'] / speeds['compiled C']:.1f}x")]
    width = max(len(a) for a, _ in rows)
    print("\n".join(f"  {a:<{width}}  {b}" for a, b in rows))
    print("final state: " + ", ".join(f"{n} = {v:.8f}" for n, v in traj.final.items()))
    print(f"generated code: {folder}/ ; trajectory: {csv_path}")
    if not report.ok:
        print(report.format())
        return EXIT_CHECK
    return EXIT_OK


def cmd_bench(args) -> int:
    if args.what == "arm":
        return _bench_arm(args)
    if args.what == "constraints":
        return _bench_constraints(args)
    if args.stages:
        from ..bench.stages import format_stages, stage_times

        outputs = tuple(args.outputs.split(",")) if args.outputs else ()
        rows = stage_times(args.what, _options(args.option), outputs, budget_s=args.budget,
                           memory_gb=args.memory_gb, progress=_progress)
        print(format_stages(args.what, rows))
        return EXIT_OK
    if args.repeats is None:
        args.repeats = 3
    if args.what == "scaling":
        from ..bench.scaling import format_scaling, scaling

        ns = tuple(int(v) for v in args.ns.split(","))
        rows = scaling(ns, sympy_max_n=args.sympy_max_n, repeats=args.repeats,
                       progress=_progress)
        print(format_scaling(rows))
        from ..bench.scaling import plot_scaling, write_scaling_csv

        folder = Path(args.output or Path("bench") / "scaling")
        csv_path = write_scaling_csv(rows, folder / "scaling.csv")
        png_path = plot_scaling(rows, folder / "scaling.png")
        print(f"\nwrote {csv_path} and {png_path}")
        return EXIT_OK
    from ..model.scene import load_scene
    from ..studies.workprecision import DEFAULT_RTOLS, work_precision

    if args.output:
        _check_folder(args.output, "-o")
    scene = _with_numbers(load_scene(args.what, **_options(args.option)), args)
    rtols = tuple(float(v) for v in args.rtols.split(",")) if args.rtols else DEFAULT_RTOLS
    report = work_precision(
        scene, rtols=rtols, repeats=args.repeats,
        methods=args.methods.split(",") if args.methods else None,
        backends=tuple(args.backends.split(",")), time_budget=args.time_budget, progress=True)
    print(report.table())
    print()
    print(report.summary())
    folder = Path(args.output or Path("bench") / scene.name)
    folder.mkdir(parents=True, exist_ok=True)
    csv_path = report.write_csv(folder / "work_precision.csv")
    png_path = report.plot(folder / "work_precision.png")
    print(f"\nwrote {csv_path} and {png_path}")
    return EXIT_OK


def _bench_constraints(args) -> int:
    from ..bench.constraints import constraint_bench, format_bench
    from ..fileio import write_atomic

    bench = constraint_bench(repeats=args.repeats or 7, budget_s=args.budget,
                             sympy_budget_s=args.sympy_budget, memory_gb=args.memory_gb,
                             progress=_progress)
    text = format_bench(bench)
    print(text)
    folder = Path(args.output or Path("bench") / "constraints")
    path = folder / "constraints.txt"
    write_atomic(path, text + "\n")
    write_atomic(folder / "constraints.json", bench.to_json())
    print(f"\nwrote {path} and {folder / 'constraints.json'}")
    return EXIT_OK


def _bench_arm(args) -> int:
    from ..bench.arm import BenchmarkError, arm_scaling, format_arm, plot, write_csv

    ns = tuple(int(v) for v in args.ns.split(","))
    try:
        rows = arm_scaling(ns, repeats=args.repeats or 7, budget_s=args.budget,
                           sympy_budget_s=args.sympy_budget, memory_gb=args.memory_gb,
                           pinocchio=not args.no_pinocchio, cxx=not args.no_cxx,
                           method=args.derivation, progress=_progress)
    except BenchmarkError as exc:  # a missing optional dependency or a driver that failed
        print(f"mbgen: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    print(format_arm(rows))
    folder = Path(args.output or Path("bench") / "arm")
    folder.mkdir(parents=True, exist_ok=True)
    csv_path = write_csv(rows, folder / "arm_scaling.csv")
    png_path = plot(rows, folder / "arm_scaling.png")
    print(f"\nwrote {csv_path} and {png_path}")
    return EXIT_OK


def cmd_stress(args) -> int:
    from ..verify.stress import stress

    report = stress(_scene(args), size="full" if args.full else "ci", progress=_progress)
    print(report.format())
    if args.output:
        print(f"wrote {report.write(args.output)}")
    return EXIT_OK if report.ok else EXIT_CHECK


def cmd_golden(args) -> int:
    from ..verify import golden

    names = args.scenes.split(",") if args.scenes else None
    golden.repository_root()  # a developer's command: refuse outside a source checkout
    root = Path(args.root) if args.root else golden.default_root()
    if root.exists() and not root.is_dir():
        raise SceneError(f"--root {str(root)!r} is a file; give the folder of the golden tree")
    if args.update:
        changed = golden.update(root, names)
        print(f"{len(changed)} file(s) rewritten under {root}")
        for p in changed:
            print(f"  {p}")
        return EXIT_OK
    diffs = golden.differences(root, names)
    for d in diffs:
        print(d)
    print(f"{root}: {'up to date' if not diffs else f'{len(diffs)} difference(s); run mbgen golden --update'}")
    return EXIT_OK if not diffs else EXIT_CHECK


def cmd_fmu(args) -> int:
    from ..export import export_fmu

    _check_folder(args.output, "-o")
    path = export_fmu(_scene(args), args.output)
    print(f"{path}  (FMI 2.0, model exchange and co-simulation)")
    return EXIT_OK


def cmd_sweep(args) -> int:
    from ..studies.ensemble import ensemble, parse_grid, parse_samples

    scene = _scene(args)
    _check_file(args.csv or f"{scene.name}_sweep.csv", "--csv")
    result = ensemble(scene, grid=parse_grid(args.grid), samples=parse_samples(args.samples),
                      n=args.n, seed=args.seed, method=args.method, t_end=args.t_end,
                      n_out=args.points, rtol=args.rtol, atol=args.atol, address=args.address,
                      n_workers=args.workers, chunk=args.chunk,
                      serial=args.serial, progress=not args.quiet)
    path = result.write_csv(args.csv or f"{scene.name}_sweep.csv")
    print(result.summary())
    print(f"table: {path} ({len(result.table)} members)")
    return EXIT_OK if result.n_failed == 0 else EXIT_NUMERIC


# ------------------------------------------------------------------- parser
def _nonnegative_float(text: str) -> float:
    """argparse type: a finite number >= 0 (tolerances, budgets)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value >= 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r}: give a finite number >= 0")
    return value


def _positive_float(text: str) -> float:
    """argparse type: a finite number > 0 (rates)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r}: give a finite number greater than 0")
    return value


def _positive_int(text: str) -> int:
    """argparse type: a whole number >= 1 (step limits, counts)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: give a whole number of at least 1")
    return value


def parser() -> argparse.ArgumentParser:
    top = argparse.ArgumentParser(
        prog="mbgen", description="Multibody models to fast, verified C and Python.",
        epilog="Exit codes: 0 ok, 1 check failed, 2 usage, 3 bad model/scene, 4 compiler "
               "failed, 5 numerical failure, 6 check inconclusive (nothing compared).")
    top.add_argument("--version", action="version", version=f"mbgen {__version__}")
    sub = top.add_subparsers(dest="command", metavar="COMMAND", required=True)

    def scene_args(p, method_flag=False):
        p.add_argument("scene", metavar="SCENE",
                       help="built-in scene name (see 'mbgen scenes') or path to a scene .py file")
        p.add_argument("-O", "--option", action="append", metavar="KEY=VALUE",
                       help="scene option, e.g. -O n=8 (repeatable)")
        p.add_argument("--force", action="store_true",
                       help="build a model past the size guard (more than 200 speeds)")
        flags = ("--derivation", "--method") if method_flag else ("--derivation",)
        p.add_argument(*flags, dest="derivation", choices=[m.value for m in Method],
                       help="derivation method (default: the scene's, else kane)")

    def numbers_args(p, parameters=True, states=True, inputs=True):
        if parameters:
            p.add_argument("-p", "--parameter", action="append", metavar="NAME=VALUE",
                           help="a parameter's value (repeatable; others: the scene's)")
        if states:
            p.add_argument("-x", "--state", action="append", metavar="NAME=VALUE",
                           help="an initial state's value (repeatable; others: the scene's "
                                "initial state, else 0)")
        if inputs:
            p.add_argument("-r", "--input", action="append", metavar="NAME=VALUE",
                           help="a constant input's value (repeatable; others 0)")

    p = sub.add_parser("scenes", help="list the built-in scenes")
    p.set_defaults(func=cmd_scenes)

    p = sub.add_parser("generate", help="write the generated C header, C source and Python")
    scene_args(p, method_flag=True)
    p.add_argument("-o", "--output", metavar="DIR",
                   help="output folder (default mbgen-out/SCENE); a regeneration removes the "
                        "files it wrote before and no longer produces")
    p.add_argument("--overwrite", action="store_true",
                   help="replace files in the output folder that mbgen did not write")
    p.add_argument("--outputs", metavar="LIST",
                   help="comma-separated outputs (e.g. rhs,jacobian,dopri5); default: the scene's")
    p.add_argument("--explain", action="store_true",
                   help="print the audit: what was left out of the generated code and why")
    p.add_argument("--no-slice", action="store_true",
                   help="ignore the scene's fixed parameters and input selection")
    p.set_defaults(func=cmd_generate)

    p = sub.add_parser("linearize", help="A, B and eigenvalues at the scene's initial state")
    scene_args(p, method_flag=True)
    p.add_argument("-x", "--state", action="append", metavar="NAME=VALUE",
                   help="operating point: a state's value (repeatable; default the scene's "
                        "initial state, made consistent with its constraints)")
    numbers_args(p, states=False)
    p.add_argument("-o", "--output", metavar="DIR", help="write A.csv and B.csv into DIR")
    p.set_defaults(func=cmd_linearize)

    p = sub.add_parser("check", help="compare compiled C, generated Python and lambdify")
    scene_args(p, method_flag=True)
    p.add_argument("--samples", type=int, default=20, help="random states (default 20, >= 1)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--rtol", type=_nonnegative_float, default=1e-9, help="relative tolerance (default 1e-9)")
    p.add_argument("--atol", type=_nonnegative_float, default=1e-12, help="absolute tolerance (default 1e-12)")
    numbers_args(p, states=False, inputs=False)
    p.set_defaults(func=cmd_check)

    p = sub.add_parser("simulate", help="integrate with the compiled RHS and write a CSV")
    scene_args(p)
    p.add_argument("--t-end", type=float, help="final time (default: the scene's)")
    p.add_argument("--method", default=None,
                   help="a solve_ivp method (RK45, DOP853, Radau, BDF, LSODA, RK23; the implicit "
                        "ones get the compiled Jacobian) or a generated C integrator (dopri5, "
                        "rosenbrock, rk4: fixed step (t_end - t0)/10000); default auto: the "
                        "scene's C integrator, else DOP853, switching to Radau when "
                        "stiffness-bound")
    p.add_argument("--rtol", type=_nonnegative_float, default=1e-9)
    p.add_argument("--atol", type=_nonnegative_float, default=1e-12)
    p.add_argument("--points", type=int, default=201, help="output times (default 201)")
    p.add_argument("--csv", metavar="PATH", help="trajectory file (default SCENE.csv)")
    p.add_argument("--plot", metavar="FILE",
                   help="also write a PNG: states against time, energy drift when the scene "
                        "conserves energy, constraint residual when it has constraints")
    numbers_args(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--max-steps", type=_positive_int, default=None, metavar="N",
                   help="step limit (default: 1,000,000 for solve_ivp, the C integrator's own)")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("animate", help="3-D animation of the scene's points and bodies "
                                       "(.html with play controls, or .gif)")
    scene_args(p)
    p.add_argument("-o", "--output", metavar="FILE",
                   help="FILE.html or FILE.gif (default SCENE.html)")
    p.add_argument("--frames", type=int, default=100, help="frames over t_span (default 100)")
    p.add_argument("--t-end", type=float, help="final time (default: the scene's)")
    p.add_argument("--fps", type=_positive_float, default=20.0, help="playback frames per second")
    p.set_defaults(func=cmd_animate)

    p = sub.add_parser("demo", help="the main job on the pendulum on a rotating disc")
    p.add_argument("-o", "--output", default="mbgen-demo", metavar="DIR",
                   help="folder for the generated code and trajectory (default mbgen-demo)")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser(
        "bench", help="benchmarks: 'mbgen bench SCENE' (work-precision: error against run time "
                      "of every integrator and back end), 'mbgen bench scaling' (n-link "
                      "pendulum, mbgen vs sympy), 'mbgen bench arm' (spatial arm: mbgen vs "
                      "sympy vs Pinocchio, RHS timed inside C) or 'mbgen bench constraints' "
                      "(Whipple bicycle: mbgen vs sympy's KanesMethod; four-bar residual "
                      "against run time)")
    p.add_argument("what", metavar="SCENE|scaling|arm",
                   help="a scene (name or .py file) for the work-precision report, 'scaling' "
                        "or 'arm'")
    p.add_argument("-O", "--option", action="append", metavar="KEY=VALUE",
                   help="scene option, e.g. -O stiffness=1e6 (repeatable)")
    p.add_argument("-o", "--output", metavar="DIR",
                   help="folder for work_precision.csv and .png (default bench/SCENE); "
                        "scaling: scaling.csv and .png (default bench/scaling)")
    p.add_argument("--rtols", metavar="LIST", help="relative tolerances (default 1e-3,...,1e-10)")
    p.add_argument("--methods", metavar="LIST",
                   help="RK45,DOP853,Radau,BDF,LSODA,dopri5,rosenbrock,rk4 (default all)")
    p.add_argument("--backends", default="lambdify,python,c", metavar="LIST",
                   help="RHS back ends for solve_ivp (default lambdify,python,c)")
    p.add_argument("--time-budget", type=_nonnegative_float, default=10.0,
                   help="seconds one solve may take (default 10)")
    p.add_argument("--repeats", type=int, default=None,
                   help="timed repeats per point; medians are reported (default 3; arm: 7)")
    p.add_argument("--ns", default="2,4,8,16,32", help="scaling: link counts (default 2,4,8,16,32)")
    p.add_argument("--sympy-max-n", type=int, default=32,
                   help="scaling: largest n run through sympy's KanesMethod (default 32)")
    p.add_argument("--stages", action="store_true",
                   help="time every pipeline stage of SCENE (derive, bake, CSE per output, "
                        "render, compile), each under --budget, instead of the work-precision "
                        "report")
    p.add_argument("--outputs", metavar="LIST", help="--stages: outputs (default: the scene's)")
    p.add_argument("--budget", type=_nonnegative_float, default=300.0,
                   help="arm: seconds mbgen may take for one n (default 300; stops larger n); "
                        "--stages: seconds one stage may take")
    p.add_argument("--sympy-budget", type=_nonnegative_float, default=120.0,
                   help="arm: seconds sympy's KanesMethod may take for one n (default 120; 0: skip)")
    p.add_argument("--memory-gb", type=_nonnegative_float, default=12.0,
                   help="arm, --stages: address-space cap of each timed child process "
                        "(default 12)")
    p.add_argument("--no-pinocchio", action="store_true", help="arm: leave Pinocchio out")
    p.add_argument("--no-cxx", action="store_true",
                   help="arm: time Pinocchio from Python only (no C++ loop)")
    p.add_argument("--derivation", default="kane", metavar="METHOD",
                   help="arm: mbgen's derivation method (default kane)")
    numbers_args(p, inputs=False)
    p.set_defaults(func=cmd_bench)

    p = sub.add_parser("stress", help="stability suite: stiff, extreme, near-singular, long runs, "
                                      "floating point vs 50-digit mpmath")
    scene_args(p)
    p.add_argument("--full", action="store_true",
                   help="the whole grid (stiffness 1e4..1e8, ratios 1e-6..1e6, long runs); "
                        "default: the CI size")
    p.add_argument("-o", "--output", metavar="FILE",
                   help="also write the report as FILE.csv or FILE.json")
    p.set_defaults(func=cmd_stress)

    p = sub.add_parser("fmu", help="write an FMI 2.0 FMU (model exchange and co-simulation)")
    scene_args(p)
    p.add_argument("-o", "--output", default=".", metavar="DIR",
                   help="folder for SCENE.fmu (default: the current folder)")
    p.set_defaults(func=cmd_fmu)

    p = sub.add_parser("sweep", help="parameter study / Monte Carlo ensemble on Dask (exit 5 "
                                      "when a member failed; the table is written anyway)")
    scene_args(p)
    p.add_argument("--grid", action="append", metavar="NAME=V1,V2,...|NAME=LO:HI:N",
                   help="a parameter or initial state on a grid (repeatable; the grids' "
                        "product is swept)")
    p.add_argument("--samples", action="append", metavar="NAME=uniform:LO:HI|normal:MU:SIGMA",
                   help="a parameter or initial state drawn at random (repeatable)")
    p.add_argument("-n", type=int, default=None,
                   help="members drawn per grid point (default 1; 100 without --grid)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--method", help="dopri5, rosenbrock or rk4 (default: the scene's)")
    p.add_argument("--t-end", type=float, help="final time (default: the scene's)")
    p.add_argument("--points", type=int, default=2,
                   help="output times, t0..t_end (default 2: initial and final state)")
    p.add_argument("--rtol", type=_nonnegative_float, default=1e-6)
    p.add_argument("--atol", type=_nonnegative_float, default=1e-9)
    p.add_argument("--address", help="a running Dask scheduler (default: a LocalCluster)")
    p.add_argument("--workers", type=int, default=2, help="LocalCluster worker processes")
    p.add_argument("--chunk", type=int, default=None, help="members per task (default: auto)")
    p.add_argument("--serial", action="store_true", help="no Dask: run in this process")
    p.add_argument("--csv", metavar="PATH", help="result table (default SCENE_sweep.csv)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("golden", help="compare (or --update) generated/ with the generator")
    p.add_argument("--root", default=None,
                   help="folder (default: generated/ of the source checkout; the command "
                        "refuses to run outside one)")
    p.add_argument("--update", action="store_true", help="rewrite the files")
    p.add_argument("--scenes", metavar="LIST",
                   help="only these scenes, e.g. --scenes bicycle,spatial_arm (default: all)")
    p.set_defaults(func=cmd_golden)
    return top


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    try:
        return args.func(args)
    except BrokenPipeError:  # output piped into e.g. `head`: stop quietly
        sys.stderr.close()
        return EXIT_OK
    except CheckInconclusive as exc:
        print(f"mbgen: check inconclusive: {exc}", file=sys.stderr)
        return EXIT_INCONCLUSIVE
    except CheckFailed as exc:
        print(f"mbgen: check failed: {exc}", file=sys.stderr)
        return EXIT_CHECK
    except (UsageError, UnknownNameError) as exc:  # a mistake in the arguments
        print(f"mbgen: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as exc:  # a path that cannot be written (or read): the caller's to fix
        print(f"mbgen: error: {_os_error(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except (SceneError, ModelError) as exc:
        print(f"mbgen: error: {exc}", file=sys.stderr)
        return EXIT_MODEL
    except ImportError as exc:  # plots.MissingExtraError: an optional dependency is missing
        if not isinstance(exc, MbgenError):
            raise
        print(f"mbgen: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except CacheError as exc:  # $MBGEN_CACHE_DIR unusable: the caller's setting to fix
        print(f"mbgen: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except BuildError as exc:
        print(f"mbgen: compiler error: {exc}", file=sys.stderr)
        return EXIT_BUILD
    except (SingularMassMatrixError, NonFiniteResultError, MbgenError) as exc:
        print(f"mbgen: numerical error: {exc}", file=sys.stderr)
        return EXIT_NUMERIC


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
