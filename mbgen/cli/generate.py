"""``mbgen generate SCENE``: write the generated C header, C source and Python (and
``example.c``) into a folder; ``--explain`` prints what was left out and why.

The folder gets one whole generation or keeps the one it had, and nothing the user
changed or put there is lost (:func:`mbgen.fileio.write_generated`: a lock, the new
files written into a sibling folder and swapped in, a manifest of content hashes).
A scene file is Python and runs when it is loaded: trust it as you trust code."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..codegen.targets.example import render_example
from ..errors import EXIT_OK, SceneError
from ..fileio import plain_name, write_generated
from ..pipeline import run as run_pipeline
from ..verify.audit import audit
from ._common import add_scene_arguments, scene_from

#: Where ``mbgen generate SCENE`` writes without ``-o``: ``./mbgen-out/SCENE/`` (never the
#: checked-in golden tree ``generated/``, which only ``mbgen golden --update`` writes).
DEFAULT_OUTPUT = Path("mbgen-out")


def configure(p: argparse.ArgumentParser) -> None:
    add_scene_arguments(p, method_flag=True)
    p.add_argument("-o", "--output", metavar="DIR",
                   help="output folder (default mbgen-out/SCENE); a regeneration removes the "
                        "files it wrote before, no longer produces and nobody changed since")
    p.add_argument("--overwrite", action="store_true",
                   help="replace files in the output folder that mbgen did not write or that "
                        "were changed since it wrote them")
    p.add_argument("--outputs", metavar="LIST",
                   help="comma-separated outputs (e.g. rhs,jacobian,dopri5); default: the scene's")
    p.add_argument("--explain", action="store_true",
                   help="print the audit: what was left out of the generated code and why")
    p.add_argument("--no-slice", action="store_true",
                   help="ignore the scene's fixed parameters and input selection")


def run(args) -> int:
    scene = scene_from(args)
    outputs = args.outputs.split(",") if args.outputs else None
    folder = Path(args.output) if args.output else \
        DEFAULT_OUTPUT / plain_name(scene.name, "scene name")
    if folder.exists() and not folder.is_dir():  # before any work
        raise SceneError(f"output folder {str(folder)!r} is a file; give a folder with -o")
    result = run_pipeline(scene, outputs, build=False, sliced=not args.no_slice)
    files = dict(result.rendered.files)
    example = render_example(scene, result.kernel)
    if example is not None:
        files["example.c"] = example
    done = write_generated(folder, files, overwrite=args.overwrite)
    for name in sorted(files):
        state = "written" if folder / name in done.changed else "unchanged"
        print(f"{folder / name}  ({state})")
    for path in done.removed:
        print(f"{path}  (removed: no longer generated)")
    for line in done.remarks():
        print(line)
    k = result.kernel
    print(f"operations: {k.ops_before} before CSE, {k.ops_after} after "
          f"({', '.join(f.output.value for f in k.functions)})")
    if args.explain:
        print()
        print(audit(scene).format())
    return EXIT_OK
