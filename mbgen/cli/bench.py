"""``mbgen bench WHAT``: the benchmarks, chosen by WHAT.

``WHAT`` names a benchmark of :data:`BENCHMARKS` -- ``arm`` (the spatial arm: mbgen
vs sympy vs Pinocchio, :mod:`mbgen.bench.arm`), ``constraints`` (the Whipple bicycle
and the four-bar, :mod:`mbgen.bench.constraints`), ``scaling`` (the n-link pendulum,
mbgen vs sympy, :mod:`mbgen.bench.scaling`) -- or else it is a scene, whose
work-precision report (:mod:`mbgen.studies.workprecision`) is written.  ``--stages``
times each pipeline stage of WHAT as a scene instead (:mod:`mbgen.bench.stages`),
where the row allows it.  ``--help`` lists the options by the mode they belong to.

The plots need matplotlib (``pip install 'mbgen[plot]'``).  Without it a mode that
plots says so before it starts, writes its CSV and names the command that installs
what draws the plot; it never stops with a traceback after the sweep.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..bench import arm, constraints, interop, robot, scaling, stages
from ..errors import EXIT_OK, MissingExtraError, UsageError
from ..fileio import write_atomic
from ..model.scene import load_scene
from ..studies.workprecision import (
    BACKENDS,
    C_METHODS,
    DEFAULT_RTOLS,
    DEFAULT_TIME_BUDGET_S,
    REFERENCE_BUDGET_FACTOR,
    REFERENCE_BUDGET_MIN_S,
    SOLVE_IVP_METHODS,
    work_precision,
)
from ..viz.plots import EXTRA, require_matplotlib
from ._common import (
    OldSpelling,
    add_number_arguments,
    check_count,
    check_folder,
    nonnegative_float,
    note,
    options,
    progress,
    with_numbers,
)

#: Most timed repeats per point (``--repeats``): a median of more says nothing new.
MAX_REPEATS = 1000
#: Link counts of ``bench scaling`` and ``bench arm`` unless ``--ns``.
DEFAULT_NS = (2, 4, 8, 16, 32)


def _numbers(kind: type, what: str) -> Callable[[str], tuple]:
    """argparse type: a comma-separated list of ``kind`` (``1e-3,1e-6``; ``2,4,8``)."""
    def parse(text: str) -> tuple:
        try:
            values = tuple(kind(v) for v in text.split(","))
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of "
                                             f"{what}") from None
        return values
    return parse


def configure(p: argparse.ArgumentParser) -> None:
    p.description = ("WHAT chooses the benchmark: a scene, 'scaling', 'arm', "
                     "'constraints', 'robot' or 'interop'; each mode is a group of options "
                     "below, with what it "
                     "measures and the files it writes.  The plots need matplotlib (pip "
                     f"install 'mbgen[{EXTRA}]'); without it the CSV is written, and a note "
                     "says so before the sweep starts.")
    p.add_argument("what", metavar="WHAT",
                   help="a scene (name or .py file), 'scaling', 'arm', 'constraints', "
                        "'robot' or 'interop'")
    p.add_argument("file", nargs="?", metavar="FILE",
                   help="robot: a .urdf or MJCF .xml file, or panda, ur5, solo12, g1 "
                        "(example-robot-data)")
    shared = p.add_argument_group("every mode but SCENE --stages")
    shared.add_argument("-o", "--output", metavar="DIR",
                        help="folder of the files written (default: bench/WHAT, e.g. "
                             "bench/disc_pendulum or bench/scaling)")
    shared.add_argument("--repeats", type=int, default=None, metavar="N",
                        help="timed repeats per point, medians reported (default: 3; arm "
                             "and constraints: 7; at most 1000)")

    scene = p.add_argument_group(
        "mbgen bench SCENE", "Work-precision report of a scene: error against run time of "
                             "every integrator and back end (work_precision.csv and .png).")
    scene.add_argument("-O", "--option", action="append", metavar="KEY=VALUE",
                       help="scene option, e.g. -O stiffness=1e6 (repeatable; --stages too; "
                            "default: the scene's)")
    add_number_arguments(scene, inputs=False)
    scene.add_argument("--rtols", type=_numbers(float, "numbers"), default=DEFAULT_RTOLS,
                       metavar="LIST", help="relative tolerances (default: "
                                            f"{','.join(f'{r:g}' for r in DEFAULT_RTOLS)})")
    scene.add_argument("--integrators", metavar="LIST",
                       help=f"integrators, of {','.join(SOLVE_IVP_METHODS + C_METHODS)} "
                            f"(default: all)")
    scene.add_argument("--methods", dest="integrators", metavar="LIST", action=OldSpelling,
                       new="--integrators", meaning="the integration methods",
                       help="old spelling of --integrators (still accepted, with a note)")
    scene.add_argument("--backends", default=",".join(BACKENDS), metavar="LIST",
                       help="RHS back ends for solve_ivp")
    scene.add_argument("--time-budget", type=nonnegative_float, default=DEFAULT_TIME_BUDGET_S,
                       metavar="S",
                       help=f"seconds one solve may take (default: {DEFAULT_TIME_BUDGET_S:g}); "
                            f"a reference solve may take {REFERENCE_BUDGET_FACTOR:g} times "
                            f"it, at least {REFERENCE_BUDGET_MIN_S:g} s")

    staged = p.add_argument_group(
        "mbgen bench SCENE --stages", "Every pipeline stage's time and peak memory, each "
                                      "under --budget (printed, no files).")
    staged.add_argument("--stages", action="store_true",
                        help="time every pipeline stage of SCENE (derive, bake, CSE per "
                             "output, render, compile) instead of the work-precision report")
    staged.add_argument("--outputs", metavar="LIST",
                        help="the outputs to generate (default: the scene's)")

    sizes = p.add_argument_group(
        "mbgen bench scaling", "n-link pendulum on a cart, mbgen vs sympy's KanesMethod "
                               "(scaling.csv and .png); --ns is arm's too.")
    sizes.add_argument("--ns", type=_numbers(int, "whole numbers"), default=DEFAULT_NS,
                       metavar="LIST",
                       help=f"link counts (default: {','.join(map(str, DEFAULT_NS))})")
    sizes.add_argument("--sympy-max-n", type=int, default=32, metavar="N",
                       help="largest n run through sympy's KanesMethod")

    arm_only = p.add_argument_group(
        "mbgen bench arm", "Spatial arm, mbgen vs sympy vs Pinocchio, the RHS timed inside "
                           "C (arm_scaling.csv and .png).")
    arm_only.add_argument("--no-pinocchio", action="store_true", help="leave Pinocchio out")
    arm_only.add_argument("--no-cxx", action="store_true",
                          help="time Pinocchio from Python only, no C++ loop")
    arm_only.add_argument("--derivation", default="newton_euler", metavar="METHOD",
                          help="mbgen's derivation method (default: newton_euler, the "
                               "spatial arm scene's own)")
    arm_only.add_argument("--no-casadi", action="store_true",
                          help="leave CasADi out (it runs where casadi is installed)")

    robot_only = p.add_argument_group(
        "mbgen bench robot FILE", "One robot: mbgen's RHS vs Pinocchio's aba vs MuJoCo's "
                                  "mj_forward, in C/C++ loops and from Python; generation "
                                  "stages; agreement (printed, no files).  --no-pinocchio, "
                                  "--no-cxx and --budget apply too.")
    robot_only.add_argument("--floating", action="store_true",
                            help="a floating base on a URDF file's root (named robots: "
                                 "their own)")
    robot_only.add_argument("--jacobian", action="store_true",
                            help="robot: generate the Jacobian too (generation time of "
                                 "rhs+jacobian) and time it in C against Pinocchio's "
                                 "computeABADerivatives (tangent space for a floating base); "
                                 "arm: the Jacobian's stages, ops and C loop against "
                                 "computeABADerivatives (and CasADi's)")
    robot_only.add_argument("--no-mujoco", action="store_true", help="leave MuJoCo out")

    inter = p.add_argument_group(
        "mbgen bench interop", "mbgen's dynamics in CasADi and JAX against the peers' own "
                               "(the casadi and jax extras; printed, no files): an IPOPT "
                               "multiple-shooting NLP (arm and UR5) with mbgen's external vs "
                               "CasADi's SX; UR5's RHS over batches, JAX vs C vs MJX.")
    inter.add_argument("--arm-n", type=int, default=7, metavar="N",
                       help="links of the actuated arm in the NLP (default 7)")
    inter.add_argument("--intervals", type=int, default=interop.N_INTERVALS, metavar="N",
                       help=f"shooting intervals (default {interop.N_INTERVALS})")
    inter.add_argument("--batches", type=_numbers(int, "whole numbers"),
                       default=(1000, 10000), metavar="LIST",
                       help="batch sizes of the throughput table (default 1000,10000)")

    children = p.add_argument_group(
        "mbgen bench constraints", "Whipple bicycle and four-bar (constraints.txt and "
                                   ".json).  Its child processes, arm's and --stages' run "
                                   "under these limits.")
    children.add_argument("--budget", type=nonnegative_float, default=300.0, metavar="S",
                          help="seconds mbgen may take for one side (constraints), one n "
                               "(arm; stops larger n) or one stage (--stages)")
    children.add_argument("--sympy-budget", type=nonnegative_float, default=120.0,
                          metavar="S",
                          help="constraints, arm: seconds sympy's KanesMethod may take (0: "
                               "leave sympy out)")
    children.add_argument("--memory-gb", type=nonnegative_float, default=12.0, metavar="GB",
                          help="address-space cap of each timed child process")


# ------------------------------------------------------------------ plots
def _can_plot() -> bool:
    """Whether matplotlib imports; when not, say so now, before any sweep runs."""
    try:
        require_matplotlib()
    except MissingExtraError:
        note(f"matplotlib is not installed: the CSV is written, the plot is not (pip install "
             f"'mbgen[{EXTRA}]' draws it)")
        return False
    return True


def _wrote(csv_path: Path, png_path: Path | None) -> None:
    """The closing line: the files written, and how to get the plot when it was not drawn."""
    if png_path is not None:
        print(f"\nwrote {csv_path} and {png_path}")
    else:
        print(f"\nwrote {csv_path}; no plot: matplotlib is not installed "
              f"(pip install 'mbgen[{EXTRA}]', then run this again)")


# ------------------------------------------------------------------ the modes
def bench_arm(args) -> int:
    """``bench arm``: the spatial arm, mbgen vs sympy vs Pinocchio (``arm_scaling.csv``, .png)."""
    plot = _can_plot()
    rows = arm.arm_scaling(args.ns, repeats=args.repeats or 7, budget_s=args.budget,
                           sympy_budget_s=args.sympy_budget, memory_gb=args.memory_gb,
                           pinocchio=not args.no_pinocchio, cxx=not args.no_cxx,
                           method=args.derivation, jacobian=args.jacobian,
                           casadi=not args.no_casadi, progress=progress)
    print(arm.format_arm(rows))
    folder = Path(args.output or Path("bench") / "arm")
    folder.mkdir(parents=True, exist_ok=True)
    csv_path = arm.write_csv(rows, folder / "arm_scaling.csv")
    _wrote(csv_path, arm.plot(rows, folder / "arm_scaling.png") if plot else None)
    return EXIT_OK


def bench_constraints(args) -> int:
    """``bench constraints``: the Whipple bicycle and the four-bar (``constraints.txt``, .json)."""
    bench = constraints.constraint_bench(repeats=args.repeats or 7, budget_s=args.budget,
                                         sympy_budget_s=args.sympy_budget,
                                         memory_gb=args.memory_gb, progress=progress)
    text = constraints.format_bench(bench)
    print(text)
    folder = Path(args.output or Path("bench") / "constraints")
    path = folder / "constraints.txt"
    write_atomic(path, text + "\n")
    write_atomic(folder / "constraints.json", bench.to_json())
    print(f"\nwrote {path} and {folder / 'constraints.json'}")
    return EXIT_OK


def bench_interop(args) -> int:
    """``bench interop``: CasADi NLP and JAX throughput against the peers (printed)."""
    check_count(args.arm_n, "--arm-n", 1, 32, "links of the arm")
    check_count(args.intervals, "--intervals", 2, 1000, "shooting intervals")
    for k in args.batches:
        check_count(k, "--batches", 1, 10**6, "states in one batch")
    folder = Path(args.output or Path("bench") / "interop")
    report = interop.interop_bench(folder, arm_n=args.arm_n, N=args.intervals,
                                   batches=args.batches, repeats=args.repeats or 5,
                                   progress=progress)
    print(interop.format_interop(report))
    return EXIT_OK


def bench_robot(args) -> int:
    """``bench robot FILE``: one robot against Pinocchio and MuJoCo (printed)."""
    if not args.file:
        raise UsageError("mbgen bench robot FILE: give a .urdf or MJCF .xml file, or one of "
                         + ", ".join(robot.peers.ROBOTS))
    report = robot.robot_bench(args.file, floating=True if args.floating else None,
                               jacobian=args.jacobian, repeats=args.repeats or 7,
                               budget_s=args.budget, memory_gb=args.memory_gb,
                               pinocchio=not args.no_pinocchio, cxx=not args.no_cxx,
                               mujoco=not args.no_mujoco, progress=progress)
    print(robot.format_robot(report))
    return EXIT_OK


def bench_scaling(args) -> int:
    """``bench scaling``: the n-link pendulum, mbgen vs sympy (``scaling.csv``, .png)."""
    repeats = 3 if args.repeats is None else args.repeats
    plot = _can_plot()
    rows = scaling.scaling(args.ns, sympy_max_n=args.sympy_max_n, repeats=repeats,
                           progress=progress)
    print(scaling.format_scaling(rows))
    folder = Path(args.output or Path("bench") / "scaling")
    csv_path = scaling.write_scaling_csv(rows, folder / "scaling.csv")
    _wrote(csv_path, scaling.plot_scaling(rows, folder / "scaling.png") if plot else None)
    return EXIT_OK


def bench_work_precision(args) -> int:
    """``bench SCENE``: error against run time of every integrator and back end."""
    repeats = 3 if args.repeats is None else args.repeats
    if args.output:
        check_folder(args.output, "-o")
    scene = with_numbers(load_scene(args.what, **options(args.option)), args)
    plot = _can_plot()
    report = work_precision(
        scene, rtols=args.rtols, repeats=repeats,
        methods=args.integrators.split(",") if args.integrators else None,
        backends=tuple(args.backends.split(",")), time_budget=args.time_budget, progress=True)
    print(report.table())
    print()
    print(report.summary())
    folder = Path(args.output or Path("bench") / scene.name)
    folder.mkdir(parents=True, exist_ok=True)
    csv_path = report.write_csv(folder / "work_precision.csv")
    _wrote(csv_path, report.plot(folder / "work_precision.png") if plot else None)
    return EXIT_OK


def bench_stages(args) -> int:
    """``bench SCENE --stages``: every pipeline stage's time, each under ``--budget``."""
    outputs = tuple(args.outputs.split(",")) if args.outputs else ()
    rows = stages.stage_times(args.what, options(args.option), outputs, budget_s=args.budget,
                              memory_gb=args.memory_gb, progress=progress)
    print(stages.format_stages(args.what, rows))
    return EXIT_OK


@dataclass(frozen=True)
class Benchmark:
    """One mode of ``mbgen bench``: what runs, and whether ``--stages`` replaces it by the
    stage times of WHAT read as a scene."""

    run: Callable[[argparse.Namespace], int]
    takes_stages: bool


#: The benchmarks ``mbgen bench WHAT`` runs by name (``--stages`` is ignored by arm and
#: constraints; with scaling it reads 'scaling' as a scene, as it always has).
BENCHMARKS = {"arm": Benchmark(bench_arm, takes_stages=False),
              "constraints": Benchmark(bench_constraints, takes_stages=False),
              "interop": Benchmark(bench_interop, takes_stages=False),
              "robot": Benchmark(bench_robot, takes_stages=False),
              "scaling": Benchmark(bench_scaling, takes_stages=True)}
#: Any other WHAT: a scene.
SCENE = Benchmark(bench_work_precision, takes_stages=True)


def run(args) -> int:
    if args.repeats is not None:  # 10**12 would run for ever
        check_count(args.repeats, "--repeats", 1, MAX_REPEATS, "timed repeats per point")
    chosen = BENCHMARKS.get(args.what, SCENE)
    return (bench_stages if args.stages and chosen.takes_stages else chosen.run)(args)
