"""``mbgen sweep SCENE``: a parameter study or Monte Carlo ensemble on Dask (or serial),
written as one table row per member; exit 5 when a member failed.

``--integrator`` names the C integrator (``--method`` is its old spelling; ``rk4`` steps
``(t_end - t0)/10000`` as ``mbgen simulate``'s does).  Varied names must be states or
parameters of the scene's model ("did you mean" otherwise).
Counts (``--points``, ``-n``, ``--chunk``, ``--workers``) and a scheduler's address
(``--address``, also spelled ``--scheduler``) are checked before any work: a mistake is
one ``mbgen: error:`` line and exit code 2.
"""

from __future__ import annotations

import argparse

from ..errors import EXIT_NUMERIC, EXIT_OK, SceneError, UsageError
from ..integrators import DEFAULT_ATOL, DEFAULT_RTOL
from ..model.scene import model_names
from ..runtime.named import check_names
from ..runtime.simulate import C_METHODS, RK4_STEPS
from ..studies.ensemble import MAX_MEMBERS, MAX_POINTS, ensemble, parse_grid, parse_samples
from ._common import (
    add_integrator_argument,
    add_scene_arguments,
    check_count,
    check_file,
    end_time,
    nonnegative_float,
    scene_from,
)

#: The distributions ``--samples`` names (those :func:`mbgen.studies.ensemble.ensemble` draws
#: from by name).
DISTRIBUTIONS = ("uniform", "normal")


def configure(p: argparse.ArgumentParser) -> None:
    add_scene_arguments(p)
    p.add_argument("--grid", action="append", metavar="NAME=V1,V2,...|NAME=LO:HI:N",
                   help="a parameter or initial state on a grid (repeatable; the grids' "
                        "product is swept)")
    p.add_argument("--samples", action="append", metavar="NAME=uniform:LO:HI|normal:MU:SIGMA",
                   help="a parameter or initial state drawn at random (repeatable)")
    p.add_argument("-n", type=int, default=None,
                   help="members drawn per grid point (default 1; 100 without --grid)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    add_integrator_argument(p, "the C integrator: dopri5, rosenbrock or rk4 (fixed step "
                               "(t_end - t0)/10000, as simulate's) (default: the scene's)")
    p.add_argument("--t-end", type=float, help="final time (default: the scene's)")
    p.add_argument("--points", type=int, default=2,
                   help="output times, t0..t_end (default 2: initial and final state)")
    p.add_argument("--rtol", type=nonnegative_float, default=DEFAULT_RTOL,
                   help="relative tolerance of the integrator")
    p.add_argument("--atol", type=nonnegative_float, default=DEFAULT_ATOL,
                   help="absolute tolerance of the integrator")
    p.add_argument("--address", "--scheduler", dest="address", metavar="ADDRESS",
                   help="a running Dask scheduler, tcp://HOST:PORT (default: a LocalCluster)")
    p.add_argument("--workers", type=int, default=2,
                   help="LocalCluster worker processes (default 2)")
    p.add_argument("--chunk", type=int, default=None, help="members per task (default: auto)")
    p.add_argument("--serial", action="store_true", help="no Dask: run in this process")
    p.add_argument("--csv", metavar="PATH", help="result table (default SCENE_sweep.csv)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args) -> int:
    check_count(args.points, "--points", 1, MAX_POINTS, "output times")
    if args.n is not None:
        check_count(args.n, "-n", 1, MAX_MEMBERS, "members per grid point")
    if args.chunk is not None:
        check_count(args.chunk, "--chunk", 1, what="members per task")
    check_count(args.workers, "--workers", 1, what="worker processes")
    method = args.integrator.lower() if args.integrator else None
    if method is not None and method not in C_METHODS:
        raise UsageError(f"--integrator {args.integrator!r}: a sweep runs a generated C "
                         f"integrator; choose {', '.join(C_METHODS)}")
    try:
        grid, samples = parse_grid(args.grid), parse_samples(args.samples)
    except SceneError as exc:  # how the command line was written: a usage error
        raise UsageError(str(exc)) from None
    for name, (kind, *_) in samples.items():
        if kind not in DISTRIBUTIONS:
            raise UsageError(f"--samples {name}={kind}:...: unknown distribution {kind!r}; use "
                             f"{' or '.join(DISTRIBUTIONS)} (NAME=uniform:LO:HI, "
                             f"NAME=normal:MEAN:SIGMA)")
    scene = scene_from(args)
    t_end = end_time(scene, args.t_end)
    known = model_names(scene.model)   # a scene holds a Model or Equations: never None
    check_names([*grid, *samples], known["states"] + known["parameters"],
                "states and parameters", scene.name)
    check_file(args.csv or f"{scene.name}_sweep.csv", "--csv")
    h = (t_end - scene.t_span[0]) / RK4_STEPS if method == "rk4" else None
    result = ensemble(scene, grid=grid, samples=samples, n=args.n, seed=args.seed,
                      method=method, t_end=t_end, n_out=args.points, rtol=args.rtol,
                      atol=args.atol, h=h, address=args.address, n_workers=args.workers,
                      chunk=args.chunk, serial=args.serial, progress=not args.quiet)
    path = result.write_csv(args.csv or f"{scene.name}_sweep.csv")
    print(result.summary())
    print(f"table: {path} ({len(result.table)} members)")
    return EXIT_OK if result.n_failed == 0 else EXIT_NUMERIC
