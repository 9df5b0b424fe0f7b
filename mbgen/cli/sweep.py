"""``mbgen sweep SCENE``: a parameter study or Monte Carlo ensemble on Dask (or serial),
written as one table row per member; exit 5 when a member failed.

``--integrator`` names the C integrator (``--method`` is its old spelling).
Counts (``--points``, ``-n``, ``--chunk``, ``--workers``) and a scheduler's address
(``--address``, also spelled ``--scheduler``) are checked before any work: a mistake is
one ``mbgen: error:`` line and exit code 2.
"""

from __future__ import annotations

import argparse

from ..errors import EXIT_NUMERIC, EXIT_OK
from ..integrators import DEFAULT_ATOL, DEFAULT_RTOL
from ..studies.ensemble import MAX_MEMBERS, MAX_POINTS, ensemble, parse_grid, parse_samples
from ._common import (add_integrator_argument, add_scene_arguments, check_count, check_file,
                      nonnegative_float, scene_from)


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
    add_integrator_argument(p, "the C integrator: dopri5, rosenbrock or rk4 (default: the "
                               "scene's)")
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
    scene = scene_from(args)
    check_file(args.csv or f"{scene.name}_sweep.csv", "--csv")
    result = ensemble(scene, grid=parse_grid(args.grid), samples=parse_samples(args.samples),
                      n=args.n, seed=args.seed, method=args.integrator, t_end=args.t_end,
                      n_out=args.points, rtol=args.rtol, atol=args.atol, address=args.address,
                      n_workers=args.workers, chunk=args.chunk,
                      serial=args.serial, progress=not args.quiet)
    path = result.write_csv(args.csv or f"{scene.name}_sweep.csv")
    print(result.summary())
    print(f"table: {path} ({len(result.table)} members)")
    return EXIT_OK if result.n_failed == 0 else EXIT_NUMERIC
