"""``mbgen generate SCENE``: write the generated C header, C source and Python (and
``example.c``) into a folder; ``--explain`` prints what was left out and why.

``--target LIST`` names what to write, rows of :data:`mbgen.codegen.targets.TARGETS`:
``c`` (``<prefix>.h``, ``.c``), ``python`` (``<prefix>.py``), ``step`` (the step API,
``<prefix>_<method>_memory``, ``_init``, ``_step``, in the ``.h``/``.c``), ``batch``
(``<prefix>_batch.c``: the Python extension's loops over ``k`` items; a C caller gains
nothing over its own loop around ``<prefix>_rhs``), ``example`` (``example.c``) and
``fmu`` (``<prefix>.fmu``, as ``mbgen fmu``).  The default is ``c,python,example`` and
what the scene's ``targets`` switch on; ``--step`` adds ``step``.  ``-r NAME=VALUE`` or
``-r NAME=FILE.csv`` sets the inputs ``example.c`` runs with (held, or a table against
time).  The library front is :func:`mbgen.generate`.

The folder gets one whole generation or keeps the one it had, and nothing the user
changed or put there is lost (:func:`mbgen.fileio.write_generated`: a lock, the new
files written into a sibling folder and swapped in, a manifest of content hashes).  The
checked-in golden tree ``generated/`` is refused (``mbgen golden --update`` writes it).
A scene file is Python and runs when it is loaded: trust it as you trust code."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..abi import Output
from ..codegen.targets import CHOSEN, DEFAULT
from ..errors import EXIT_OK, ModelError, UsageError
from ..export import DEFAULT_OUTPUT, generate
from ..fileio import plain_name
from ..verify.audit import audit
from ._common import (
    add_number_arguments,
    add_scene_arguments,
    check_output_folder,
    input_signals,
    resolve_inputs,
    scene_from,
    stage_lines,
)


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
    p.add_argument("--target", metavar="LIST",
                   help=f"comma-separated targets to write, of {','.join(CHOSEN)} (default "
                        f"{','.join(DEFAULT)} -- example.c when the outputs have an integrator "
                        f"-- and the scene's targets)")
    p.add_argument("--step", action="store_true",
                   help="add the step API (<prefix>_dopri5_step, _rk4_step, ... with their "
                        "memory structs) to the .h and .c, as --target ...,step; default: "
                        "the scene's targets")
    p.add_argument("--explain", action="store_true",
                   help="print the audit: what was left out of the generated code and why")
    p.add_argument("--no-slice", action="store_true",
                   help="ignore the scene's fixed parameters and input selection")
    add_number_arguments(p, parameters=False, states=False, tables=True)
    p.add_argument("-q", "--quiet", action="store_true",
                   help="no stage lines on stderr (they appear only when stderr is a terminal)")


def run(args) -> int:
    scene = scene_from(args)
    targets = args.target.split(",") if args.target else None
    if args.step:
        targets = [*(targets or DEFAULT), "step"]
    try:
        outputs = Output.parse(args.outputs.split(",")) if args.outputs else None
    except ModelError as exc:  # a mistake in the argument, not in the model
        raise UsageError(f"--outputs: {exc}") from None
    folder = Path(args.output) if args.output else \
        DEFAULT_OUTPUT / plain_name(scene.name, "scene name")
    check_output_folder(folder, "-o")  # before any work
    signals = input_signals(args)
    done = generate(scene, targets, folder, outputs=outputs, sliced=not args.no_slice,
                    overwrite=args.overwrite, stage=stage_lines(args),
                    inputs=(lambda layout: resolve_inputs(signals, layout, scene.name))
                    if signals else None)
    for path in done.files:
        print(f"{path}  ({'written' if path in done.written else 'unchanged'})")
    for path, what in done.archives:
        print(f"{path}  ({what})")
    if done.generation is not None:
        for path in done.generation.removed:
            print(f"{path}  (removed: no longer generated)")
        for line in done.generation.remarks():
            print(line)
    k = done.result.kernel
    print(f"operations: {k.ops_before} before CSE, {k.ops_after} after "
          f"({', '.join(f.output.value for f in k.functions)})")
    if done.result.rendered.step_methods:
        print(f"step API: {', '.join(done.result.rendered.step_methods)}")
    if args.explain:
        print()
        print(audit(scene).format())
    return EXIT_OK
