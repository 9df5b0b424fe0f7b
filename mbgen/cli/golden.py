"""``mbgen golden``: compare the checked-in golden tree ``generated/`` with what the
generator writes now (exit 1 on a difference), or ``--update`` it.  A developer's
command: it refuses to run outside a source checkout.

The one-line summary comes first, then one line per file that differs (``changed``,
``missing``, ``unexpected``); ``-v`` adds each changed file's unified diff."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import EXIT_CHECK, EXIT_OK, OutputPathError
from ..verify import golden


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("--root", default=None,
                   help="folder (default: generated/ of the source checkout; the command "
                        "refuses to run outside one)")
    p.add_argument("--update", action="store_true", help="rewrite the files")
    p.add_argument("--scenes", metavar="LIST",
                   help="only these scenes, e.g. --scenes bicycle,spatial_arm (default: all)")
    p.add_argument("-v", "--verbose", action="store_true",
                   help="also print the unified diff of every changed file")


def run(args) -> int:
    names = args.scenes.split(",") if args.scenes else None
    golden.repository_root()  # a developer's command: refuse outside a source checkout
    root = Path(args.root) if args.root else golden.default_root()
    if root.exists() and not root.is_dir():
        raise OutputPathError(f"--root {str(root)!r} is a file; give the folder of the golden "
                              f"tree")
    if args.update:
        changed = golden.update(root, names)
        print(f"{len(changed)} file(s) rewritten under {root}")
        for p in changed:
            print(f"  {p}")
        return EXIT_OK
    diffs = golden.compare(root, names)
    if not diffs:
        print(f"{root}: up to date")
        return EXIT_OK
    more = "" if args.verbose else " (-v shows the diffs)"
    print(f"{root}: {len(diffs)} file(s) differ from the generator; run mbgen golden --update"
          f"{more}")
    for d in diffs:
        print(f"  {d.kind}: {d.path}")
    if args.verbose:
        for d in diffs:
            if d.diff:
                print()
                print(d.diff, end="" if d.diff.endswith("\n") else "\n")
    return EXIT_CHECK
