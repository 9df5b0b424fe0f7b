"""``mbgen check SCENE``: compare compiled C, generated Python and lambdify on random
states; exit 1 when an error is above tolerance, 6 when nothing was compared or the
reference could not resolve a difference (an ill-conditioned state)."""

from __future__ import annotations

import argparse
import sys

from ..errors import EXIT_CHECK, EXIT_INCONCLUSIVE, EXIT_OK, EXIT_USAGE
from ..verify.check import check
from ._common import (
    add_number_arguments,
    add_scene_arguments,
    nonnegative_float,
    scene_from,
    with_numbers,
)


def configure(p: argparse.ArgumentParser) -> None:
    add_scene_arguments(p, method_flag=True)
    p.add_argument("--samples", type=int, default=20, help="random states (default 20, >= 1)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--rtol", type=nonnegative_float, default=1e-9,
                   help="relative tolerance (default 1e-9)")
    p.add_argument("--atol", type=nonnegative_float, default=1e-12,
                   help="absolute tolerance (default 1e-12)")
    add_number_arguments(p, states=False, inputs=False)


def run(args) -> int:
    if args.samples < 1:
        print(f"mbgen: error: --samples must be at least 1 (got {args.samples}): a check of "
              f"no sample proves nothing", file=sys.stderr)
        return EXIT_USAGE
    report = check(with_numbers(scene_from(args), args), samples=args.samples, seed=args.seed,
                   rtol=args.rtol,
                   atol=args.atol)
    print(report.format())
    if report.ok:
        return EXIT_OK
    if report.inconclusive:
        print(f"mbgen: check inconclusive: {report.name}: {report.reason}", file=sys.stderr)
        return EXIT_INCONCLUSIVE
    print(f"mbgen: check failed: {report.name}: see the report", file=sys.stderr)
    return EXIT_CHECK
