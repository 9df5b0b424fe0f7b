"""``mbgen bench WHAT``: the benchmarks, chosen by WHAT.

``WHAT`` names a benchmark of :data:`BENCHMARKS` -- ``arm`` (the spatial arm: mbgen
vs sympy vs Pinocchio, :mod:`mbgen.bench.arm`), ``constraints`` (the Whipple bicycle
and the four-bar, :mod:`mbgen.bench.constraints`), ``scaling`` (the n-link pendulum,
mbgen vs sympy, :mod:`mbgen.bench.scaling`) -- or else it is a scene, whose
work-precision report (:mod:`mbgen.studies.workprecision`) is written.  ``--stages``
times each pipeline stage of WHAT as a scene instead (:mod:`mbgen.bench.stages`),
where the row allows it.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ..bench import arm, constraints, scaling, stages
from ..errors import EXIT_OK
from ..fileio import write_atomic
from ..model.scene import load_scene
from ..studies.workprecision import DEFAULT_RTOLS, work_precision
from ._common import (add_number_arguments, check_count, check_folder, nonnegative_float,
                      options, progress, with_numbers)

#: Most timed repeats per point (``--repeats``): a median of more says nothing new.
MAX_REPEATS = 1000


def configure(p: argparse.ArgumentParser) -> None:
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
    p.add_argument("--time-budget", type=nonnegative_float, default=10.0,
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
    p.add_argument("--budget", type=nonnegative_float, default=300.0,
                   help="arm: seconds mbgen may take for one n (default 300; stops larger n); "
                        "--stages: seconds one stage may take")
    p.add_argument("--sympy-budget", type=nonnegative_float, default=120.0,
                   help="arm: seconds sympy's KanesMethod may take for one n (default 120; 0: skip)")
    p.add_argument("--memory-gb", type=nonnegative_float, default=12.0,
                   help="arm, --stages: address-space cap of each timed child process "
                        "(default 12)")
    p.add_argument("--no-pinocchio", action="store_true", help="arm: leave Pinocchio out")
    p.add_argument("--no-cxx", action="store_true",
                   help="arm: time Pinocchio from Python only (no C++ loop)")
    p.add_argument("--derivation", default="kane", metavar="METHOD",
                   help="arm: mbgen's derivation method (default kane)")
    add_number_arguments(p, inputs=False)


# ------------------------------------------------------------------ the four modes
def bench_arm(args) -> int:
    """``bench arm``: the spatial arm, mbgen vs sympy vs Pinocchio (``arm_scaling.csv``, .png)."""
    ns = tuple(int(v) for v in args.ns.split(","))
    rows = arm.arm_scaling(ns, repeats=args.repeats or 7, budget_s=args.budget,
                           sympy_budget_s=args.sympy_budget, memory_gb=args.memory_gb,
                           pinocchio=not args.no_pinocchio, cxx=not args.no_cxx,
                           method=args.derivation, progress=progress)
    print(arm.format_arm(rows))
    folder = Path(args.output or Path("bench") / "arm")
    folder.mkdir(parents=True, exist_ok=True)
    csv_path = arm.write_csv(rows, folder / "arm_scaling.csv")
    png_path = arm.plot(rows, folder / "arm_scaling.png")
    print(f"\nwrote {csv_path} and {png_path}")
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


def bench_scaling(args) -> int:
    """``bench scaling``: the n-link pendulum, mbgen vs sympy (``scaling.csv``, .png)."""
    repeats = 3 if args.repeats is None else args.repeats
    ns = tuple(int(v) for v in args.ns.split(","))
    rows = scaling.scaling(ns, sympy_max_n=args.sympy_max_n, repeats=repeats,
                           progress=progress)
    print(scaling.format_scaling(rows))
    folder = Path(args.output or Path("bench") / "scaling")
    csv_path = scaling.write_scaling_csv(rows, folder / "scaling.csv")
    png_path = scaling.plot_scaling(rows, folder / "scaling.png")
    print(f"\nwrote {csv_path} and {png_path}")
    return EXIT_OK


def bench_work_precision(args) -> int:
    """``bench SCENE``: error against run time of every integrator and back end."""
    repeats = 3 if args.repeats is None else args.repeats
    if args.output:
        check_folder(args.output, "-o")
    scene = with_numbers(load_scene(args.what, **options(args.option)), args)
    rtols = tuple(float(v) for v in args.rtols.split(",")) if args.rtols else DEFAULT_RTOLS
    report = work_precision(
        scene, rtols=rtols, repeats=repeats,
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
              "scaling": Benchmark(bench_scaling, takes_stages=True)}
#: Any other WHAT: a scene.
SCENE = Benchmark(bench_work_precision, takes_stages=True)


def run(args) -> int:
    if args.repeats is not None:  # 10**12 would run for ever
        check_count(args.repeats, "--repeats", 1, MAX_REPEATS, "timed repeats per point")
    chosen = BENCHMARKS.get(args.what, SCENE)
    return (bench_stages if args.stages and chosen.takes_stages else chosen.run)(args)
