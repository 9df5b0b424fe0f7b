"""``mbgen scenes``: list the built-in scenes, their descriptions and options."""

from __future__ import annotations

import argparse

from ..errors import EXIT_OK
from ..model.scene import builtin_names, load_scene, scene_options


def configure(p: argparse.ArgumentParser) -> None:
    """No arguments."""


def run(args) -> int:
    for name in builtin_names():
        opts = scene_options(name)
        scn = load_scene(name)
        extra = f"  [options: {', '.join(f'{k}={v}' for k, v in opts.items())}]" if opts else ""
        print(f"{name:<15} {scn.description}{extra}")
    return EXIT_OK
