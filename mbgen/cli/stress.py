"""``mbgen stress SCENE``: the stability suite -- stiff, extreme, near-singular, long
runs, floating point against 50-digit mpmath; exit 1 when a case of the model fails, 6
(inconclusive) when the only failures are the harness's (a run stopped at the suite's
budget, or the suite itself crashed): nothing was learned about the model there.

The progress lines on stderr count the cases (``[i/n]``, ``n`` growing as cases decide
follow-ups); the verdict line counts model failures apart from harness budget failures
(a run stopped at the suite's step or evaluation budget) and harness crashes
(:mod:`mbgen.verify.stress`)."""

from __future__ import annotations

import argparse

from ..errors import EXIT_CHECK, EXIT_INCONCLUSIVE, EXIT_OK
from ..verify.stress import report_path, stress
from ._common import add_scene_arguments, check_file, progress, scene_from


def configure(p: argparse.ArgumentParser) -> None:
    add_scene_arguments(p)
    p.add_argument("--full", action="store_true",
                   help="the whole grid (stiffness 1e4..1e8, ratios 1e-6..1e6, long runs over "
                        "10 t_span; minutes) (default: the CI size, seconds)")
    p.add_argument("-o", "--output", metavar="FILE",
                   help="also write the report, every measured number, as FILE.csv or "
                        "FILE.json (default: printed only)")


def run(args) -> int:
    if args.output:  # a path that cannot be written is refused before the suite runs
        report_path(check_file(args.output, "-o"))
    report = stress(scene_from(args), size="full" if args.full else "ci", progress=progress)
    # the file first: a pipe closed early (``| head``) stops the printing, not the file
    written = report.write(args.output) if args.output else None
    print(report.format())
    if written is not None:
        print(f"wrote {written}")
    if report.ok:
        return EXIT_OK
    model = any(c.failure == "model" for c in report.failures)
    return EXIT_CHECK if model else EXIT_INCONCLUSIVE
