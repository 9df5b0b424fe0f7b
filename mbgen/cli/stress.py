"""``mbgen stress SCENE``: the stability suite -- stiff, extreme, near-singular, long
runs, floating point against 50-digit mpmath; exit 1 when a case fails."""

from __future__ import annotations

import argparse

from ..errors import EXIT_CHECK, EXIT_OK
from ..verify.stress import stress
from ._common import add_scene_arguments, progress, scene_from


def configure(p: argparse.ArgumentParser) -> None:
    add_scene_arguments(p)
    p.add_argument("--full", action="store_true",
                   help="the whole grid (stiffness 1e4..1e8, ratios 1e-6..1e6, long runs); "
                        "default: the CI size")
    p.add_argument("-o", "--output", metavar="FILE",
                   help="also write the report as FILE.csv or FILE.json")


def run(args) -> int:
    report = stress(scene_from(args), size="full" if args.full else "ci", progress=progress)
    print(report.format())
    if args.output:
        print(f"wrote {report.write(args.output)}")
    return EXIT_OK if report.ok else EXIT_CHECK
