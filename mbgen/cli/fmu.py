"""``mbgen fmu SCENE``: write an FMI 2.0 FMU (model exchange and co-simulation).

An alias of ``mbgen generate SCENE --target fmu`` that writes ``<prefix>.fmu`` alone
into ``-o`` (default: the current folder; no manifest, no other file), through the same
row of :data:`mbgen.codegen.targets.TARGETS` (:func:`mbgen.generate`).

An FMU's inputs are the importer's (causality input): it sets them at every step or
communication point, so an input table belongs to the importer (FMPy:
``simulate_fmu(..., input=...)``, linear between rows as ``mbgen simulate -r
F=table.csv``).  ``-r`` is refused with that fix rather than baked in as a signal
the importer would silently override."""

from __future__ import annotations

import argparse

from ..errors import EXIT_OK, UsageError
from ..export import generate
from ._common import add_scene_arguments, check_folder, scene_from


def configure(p: argparse.ArgumentParser) -> None:
    add_scene_arguments(p)
    p.add_argument("-o", "--output", default=".", metavar="DIR",
                   help="folder for SCENE.fmu (default: the current folder)")
    p.add_argument("-r", "--input", action="append", metavar="NAME=...",
                   help="refused: an FMU's inputs come from the importer (feed a table "
                        "there, e.g. FMPy's simulate_fmu(..., input=...))")


def run(args) -> int:
    if args.input:
        raise UsageError(f"-r {args.input[0]!r}: an FMU takes its inputs from the importer "
                         f"(causality input, start 0), which sets them at every communication "
                         f"point; give the values or the table to the importer (FMPy: "
                         f"simulate_fmu(path, input=...)), or use 'mbgen simulate -r "
                         f"NAME=FILE.csv' to run the table here")
    check_folder(args.output, "-o")
    for path, what in generate(scene_from(args), ["fmu"], args.output).archives:
        print(f"{path}  ({what})")
    return EXIT_OK
