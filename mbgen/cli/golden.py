"""``mbgen golden``: compare the checked-in golden tree ``generated/`` with what the
generator writes now (exit 1 on a difference), or ``--update`` it.  A developer's
command: it refuses to run outside a source checkout."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import EXIT_CHECK, EXIT_OK, SceneError
from ..verify import golden


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("--root", default=None,
                   help="folder (default: generated/ of the source checkout; the command "
                        "refuses to run outside one)")
    p.add_argument("--update", action="store_true", help="rewrite the files")
    p.add_argument("--scenes", metavar="LIST",
                   help="only these scenes, e.g. --scenes bicycle,spatial_arm (default: all)")


def run(args) -> int:
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
