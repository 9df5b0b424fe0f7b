"""``mbgen generate SCENE``: write the generated C header, C source and Python (and
``example.c``) into a folder; ``--explain`` prints what was left out and why.

``--step`` adds the step API (``<prefix>_<method>_memory``, ``_init``, ``_step``) to the
``.h``/``.c``, as a scene's ``targets=mbgen.Targets(step=True)`` does.  The batch loops
(``<prefix>_<output>_batch``) are not offered: they exist to save the Python extension
one crossing into C per item, which a C caller never pays, so a C program loops over
``<prefix>_rhs`` itself at the same speed.  ``-r NAME=VALUE`` or ``-r NAME=FILE.csv``
sets the inputs ``example.c`` runs with (held, or a table against time).

The folder gets one whole generation or keeps the one it had, and nothing the user
changed or put there is lost (:func:`mbgen.fileio.write_generated`: a lock, the new
files written into a sibling folder and swapped in, a manifest of content hashes).  The
checked-in golden tree ``generated/`` is refused (``mbgen golden --update`` writes it).
A scene file is Python and runs when it is loaded: trust it as you trust code."""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

from ..abi import Output
from ..codegen.targets import Targets
from ..codegen.targets.example import render_example
from ..errors import EXIT_OK, ModelError, UsageError
from ..fileio import plain_name, write_generated
from ..pipeline import run as run_pipeline
from ..verify.audit import audit
from ._common import (add_number_arguments, add_scene_arguments, check_output_folder,
                      input_signals, resolve_inputs, scene_from, stage_lines)

#: Where ``mbgen generate SCENE`` writes without ``-o``: ``./mbgen-out/SCENE/`` (never the
#: checked-in golden tree ``generated/``, which only ``mbgen golden --update`` writes).
DEFAULT_OUTPUT = Path("mbgen-out")


def configure(p: argparse.ArgumentParser) -> None:
    add_scene_arguments(p, method_flag=True)
    p.add_argument("-o", "--output", metavar="DIR",
                   help="output folder (default mbgen-out/SCENE; not the golden tree "
                        "generated/); a regeneration removes the files it wrote before, no "
                        "longer produces and nobody changed since")
    p.add_argument("--overwrite", action="store_true",
                   help="replace files in the output folder that mbgen did not write or that "
                        "were changed since it wrote them")
    p.add_argument("--outputs", metavar="LIST",
                   help="comma-separated outputs (e.g. rhs,jacobian,dopri5); default: the scene's")
    p.add_argument("--step", action="store_true",
                   help="add the step API (<prefix>_dopri5_step, _rk4_step, ... with their "
                        "memory structs) to the .h and .c; default: the scene's targets")
    p.add_argument("--explain", action="store_true",
                   help="print the audit: what was left out of the generated code and why")
    p.add_argument("--no-slice", action="store_true",
                   help="ignore the scene's fixed parameters and input selection")
    add_number_arguments(p, parameters=False, states=False, tables=True)
    p.add_argument("-q", "--quiet", action="store_true",
                   help="no stage lines on stderr (they appear only when stderr is a terminal)")


def run(args) -> int:
    scene = scene_from(args)
    if args.step:
        scene = replace(scene, targets=replace(scene.targets or Targets(), step=True))
    try:
        outputs = Output.parse(args.outputs.split(",")) if args.outputs else None
    except ModelError as exc:  # a mistake in the argument, not in the model
        raise UsageError(f"--outputs: {exc}") from None
    folder = Path(args.output) if args.output else \
        DEFAULT_OUTPUT / plain_name(scene.name, "scene name")
    check_output_folder(folder, "-o")  # before any work
    signals = input_signals(args)
    result = run_pipeline(scene, outputs, build=False, sliced=not args.no_slice,
                          stage=stage_lines(args))
    files = dict(result.rendered.files)
    r = resolve_inputs(signals, result.kernel.layout, scene.name) if signals else None
    example = render_example(scene, result.kernel, r)
    if example is not None:
        files["example.c"] = example
    elif r is not None:
        raise UsageError("-r sets the inputs of example.c, which this generation does not "
                         "have (no integrator among its outputs); add one, e.g. --outputs "
                         "rhs,dopri5")
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
    if result.rendered.step_methods:
        print(f"step API: {', '.join(result.rendered.step_methods)}")
    if args.explain:
        print()
        print(audit(scene).format())
    return EXIT_OK
