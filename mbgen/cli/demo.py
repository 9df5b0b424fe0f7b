"""``mbgen demo``: the main job on the pendulum on a rotating disc -- derive, CSE,
render, compile, check against lambdify, simulate, and time the right-hand sides of
compiled C, generated Python and lambdify side by side.

The generated code (with ``example.c``, the C program that runs the generated
integrator, as ``mbgen generate`` writes it) and the trajectory go into the folder as
one generation (:func:`mbgen.fileio.write_generated`): a file of the user's in the way
is not replaced without ``--overwrite``."""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from ..codegen.targets.example import build_command, render_example
from ..errors import EXIT_CHECK, EXIT_OK
from ..fileio import write_generated
from ..model.scene import load_scene
from ..pipeline import run as run_pipeline
from ..runtime.lambdified import LambdifiedModel
from ..runtime.python import python_model
from ..runtime.simulate import simulate, simulate_in_c
from ..verify.check import check
from ._common import check_output_folder, progress


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("-o", "--output", default="mbgen-demo", metavar="DIR",
                   help="folder for the generated code and trajectory (default mbgen-demo)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace files in the folder that mbgen did not write or that were "
                        "changed since it wrote them")


def _per_call_us(f, t, x, calls: int = 2000, repeats: int = 5) -> float:
    """Median over ``repeats`` of the mean time of ``calls`` calls, in microseconds."""
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(calls):
            f(t, x)
        samples.append((time.perf_counter() - start) / calls * 1e6)
    return statistics.median(samples)


#: Both simulations of the headline: the same method (Dormand-Prince 5(4): scipy's RK45 and the
#: generated dopri5) at the same tolerances, so the time ratio is the back end's alone.
RTOL, ATOL = 1e-10, 1e-12


def run(args) -> int:
    check_output_folder(args.output, "-o")
    scene = load_scene("disc_pendulum")
    print(f"mbgen demo: {scene.description}")
    progress("derive, CSE, render, compile")
    result = run_pipeline(scene, warm=False)    # the demo shows every stage's time
    model = result.compiled
    folder = Path(args.output)
    progress("check against lambdify")
    report = check(scene, result=result, samples=50)
    progress("simulate")
    x0, p = scene.x0(model.layout), scene.p(model.layout)
    traj = simulate(model, x0, scene.t_span, method="RK45", rtol=RTOL, atol=ATOL,
                    progress=False)
    csv_path = folder / "trajectory.csv"
    example = render_example(scene, result.kernel)
    done = write_generated(folder, {**result.rendered.files, "example.c": example,
                                    csv_path.name: traj.to_csv()}, overwrite=args.overwrite)
    in_c = simulate_in_c(model, x0, scene.t_span, method="dopri5", rtol=RTOL, atol=ATOL)
    gap = float(abs(in_c.x[-1] - traj.x[-1]).max())
    progress("time the right-hand sides side by side")
    lam = LambdifiedModel(result.baked, model.outputs, layout=result.layout)
    py = python_model(result.rendered)
    speeds = {name: _per_call_us(m.bind(p), 0.0, x0) for name, m in
              (("compiled C", model), ("generated Python", py), ("lambdify", lam))}

    k = result.kernel
    rows = [("derivation", result.equations.derivation),
            ("derive", f"{result.timings['derive'] * 1e3:.1f} ms"),
            ("CSE", f"{result.timings['cse'] * 1e3:.1f} ms"),
            ("render", f"{result.timings['render'] * 1e3:.1f} ms"),
            ("compile (cffi)", f"{result.timings['compile'] * 1e3:.1f} ms"
             + (" (cache hit: source unchanged)" if result.compile_cached else "")),
            ("operations before -> after CSE", f"{k.ops_before} -> {k.ops_after}"),
            ("max rel error C vs lambdify", f"{report.max_rel:.2e} ({report.samples} states)"),
            (f"simulate t = 0..20: solve_ivp RK45, rtol {RTOL:g}",
             f"{traj.wall_time * 1e3:.1f} ms, {traj.nfev} RHS calls"),
            (f"simulate t = 0..20: C dopri5, rtol {RTOL:g}",
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
    print(f"C program: {folder / 'example.c'}; build and run it with: cd {folder} && "
          f"{build_command(result.rendered.prefix)}")
    for line in done.remarks():
        print(line)
    if not report.ok:
        print(report.format())
        return EXIT_CHECK
    return EXIT_OK
