"""``mbgen fmu SCENE``: write an FMI 2.0 FMU (model exchange and co-simulation)."""

from __future__ import annotations

import argparse

from ..export import export_fmu
from ..errors import EXIT_OK
from ._common import add_scene_arguments, check_folder, scene_from


def configure(p: argparse.ArgumentParser) -> None:
    add_scene_arguments(p)
    p.add_argument("-o", "--output", default=".", metavar="DIR",
                   help="folder for SCENE.fmu (default: the current folder)")


def run(args) -> int:
    check_folder(args.output, "-o")
    path = export_fmu(scene_from(args), args.output)
    print(f"{path}  (FMI 2.0, model exchange and co-simulation)")
    return EXIT_OK
