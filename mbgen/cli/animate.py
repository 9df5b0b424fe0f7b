"""``mbgen animate SCENE``: a 3-D animation of the scene's points and bodies (``.html``
with play controls, or ``.gif``)."""

from __future__ import annotations

import argparse

from ..errors import EXIT_OK, UsageError
from ..viz.animate import FORMATS, animate_scene
from ._common import (
    add_scene_arguments,
    check_count,
    check_file,
    end_time,
    positive_float,
    scene_from,
)


def configure(p: argparse.ArgumentParser) -> None:
    add_scene_arguments(p)
    p.add_argument("-o", "--output", metavar="FILE",
                   help="FILE.html or FILE.gif (default SCENE.html)")
    p.add_argument("--frames", type=int, default=100, help="frames over t_span (default 100)")
    p.add_argument("--t-end", type=float, help="final time (default: the scene's)")
    p.add_argument("--fps", type=positive_float, default=20.0, help="playback frames per second")


def run(args) -> int:
    if args.output:  # mistakes in the arguments, before any work (exit 2)
        if not args.output.lower().endswith(tuple(FORMATS)):
            raise UsageError(f"-o {args.output!r}: name an animation file ending in "
                             f"{' or '.join(FORMATS)}")
        check_file(args.output, "-o")
    check_count(args.frames, "--frames", 2, what="frames")
    scene = scene_from(args)
    path = animate_scene(scene, args.output or f"{scene.name}.html", frames=args.frames,
                         t_end=end_time(scene, args.t_end), fps=args.fps)
    print(f"{scene.name}: {args.frames} frames -> {path}")
    return EXIT_OK
