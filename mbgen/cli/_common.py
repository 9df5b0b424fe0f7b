"""What the subcommands share: argument groups and types, numbers by name, path checks.

A subcommand module (:mod:`mbgen.cli`) builds its arguments from
:func:`add_scene_arguments` (``SCENE``, ``-O``, ``--force``, ``--derivation``) and
:func:`add_number_arguments` (``-p``, ``-x``, ``-r`` by name), then turns them into a
scene with :func:`scene_from` and :func:`with_numbers`.  Output paths and counts are refused
before any work (:func:`check_folder`, :func:`check_file`, :func:`check_count`: at most
:data:`MAX_POINTS` output times); :func:`progress` prints a stage on stderr.  Exit codes are :mod:`mbgen.errors`'s ``EXIT_*``.
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import replace
from pathlib import Path

from ..derive import Method
from ..errors import SceneError, UsageError
from ..model.scene import load_scene, model_names
from ..run.named import check_names, inputs
from ..studies.ensemble import MAX_POINTS


# ------------------------------------------------------------------ argument groups
def add_scene_arguments(p: argparse.ArgumentParser, method_flag: bool = False) -> None:
    """``SCENE``, ``-O KEY=VALUE``, ``--force`` and ``--derivation`` (also ``--method``
    when ``method_flag``)."""
    p.add_argument("scene", metavar="SCENE",
                   help="built-in scene name (see 'mbgen scenes') or path to a scene .py file")
    p.add_argument("-O", "--option", action="append", metavar="KEY=VALUE",
                   help="scene option, e.g. -O n=8 (repeatable)")
    p.add_argument("--force", action="store_true",
                   help="build a model past the size guard (more than 200 speeds)")
    flags = ("--derivation", "--method") if method_flag else ("--derivation",)
    p.add_argument(*flags, dest="derivation", choices=[m.value for m in Method],
                   help="derivation method (default: the scene's, else kane)")


def add_number_arguments(p: argparse.ArgumentParser, parameters: bool = True,
                         states: bool = True, inputs: bool = True) -> None:
    """``-p``, ``-x`` and ``-r NAME=VALUE`` (each repeatable), those asked for."""
    if parameters:
        p.add_argument("-p", "--parameter", action="append", metavar="NAME=VALUE",
                       help="a parameter's value (repeatable; others: the scene's)")
    if states:
        p.add_argument("-x", "--state", action="append", metavar="NAME=VALUE",
                       help="an initial state's value (repeatable; others: the scene's "
                            "initial state, else 0)")
    if inputs:
        p.add_argument("-r", "--input", action="append", metavar="NAME=VALUE",
                       help="a constant input's value (repeatable; others 0)")


# ------------------------------------------------------------------ argument types
def nonnegative_float(text: str) -> float:
    """argparse type: a finite number >= 0 (tolerances, budgets)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value >= 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r}: give a finite number >= 0")
    return value


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0 (rates)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r}: give a finite number greater than 0")
    return value


def positive_int(text: str) -> int:
    """argparse type: a whole number >= 1 (step limits, counts)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: give a whole number of at least 1")
    return value


# ------------------------------------------------------------------ scenes and numbers
def options(pairs) -> dict:
    """``-O KEY=VALUE`` pairs as ``{key: text}``; the scene converts and checks the values."""
    out = {}
    for pair in pairs or ():
        if "=" not in pair:
            raise SceneError(f"option {pair!r} must look like KEY=VALUE (e.g. -O n=4)")
        k, v = pair.split("=", 1)
        k = k.strip()
        if not k.isidentifier():
            raise SceneError(f"option {pair!r}: {k!r} is not an option name (e.g. -O n=4)")
        if k in out:
            raise SceneError(f"option {k!r} is given twice (-O {k}={out[k]} and -O {pair})")
        out[k] = v.strip()
    return out


def scene_from(args):
    """The scene of :func:`add_scene_arguments`' arguments (its ``--derivation`` applied)."""
    scene = load_scene(args.scene, force=getattr(args, "force", False), **options(args.option))
    derivation = getattr(args, "derivation", None)
    return replace(scene, method=Method(derivation)) if derivation else scene


def assignments(pairs, flag: str) -> dict[str, float]:
    """``["c=0.5", ...]`` of ``flag`` (-p, -r, -x) -> ``{"c": 0.5}``."""
    out = {}
    for pair in pairs or ():
        name, eq, value = pair.partition("=")
        name = name.strip()
        if not eq or not name:
            raise UsageError(f"{flag} {pair!r} must look like NAME=VALUE (e.g. {flag} c=0.5)")
        try:
            out[name] = float(value)
        except ValueError:
            raise UsageError(f"{flag} {pair!r}: {value.strip()!r} is not a number") from None
    return out


def with_numbers(scene, args):
    """``scene`` with ``-p NAME=VALUE`` (parameters, fixed ones included) and ``-x NAME=VALUE``
    (initial state) applied; parameter names are checked here ("did you mean")."""
    params = assignments(getattr(args, "parameter", None), "-p")
    states = assignments(getattr(args, "state", None), "-x")
    if params:
        check_names(params, sorted({*scene.parameters, *scene.fixed}), "parameters",
                    scene.name)
        scene = replace(scene, parameters={**scene.parameters,
                                           **{k: v for k, v in params.items()
                                              if k not in scene.fixed}},
                        fixed={k: params.get(k, v) for k, v in scene.fixed.items()})
    if states:
        known = (model_names(scene.model) or {}).get("states")
        if known is not None:
            check_names(states, known, "states", scene.name)
        scene = replace(scene, initial_state={**scene.initial_state, **states})
    return scene


def initial_state(scene, model):
    """The scene's initial state for ``model``; ``-x`` names are checked ("did you mean")."""
    check_names(scene.initial_state, model.state_names, "states", scene.name)
    return scene.x0(model.layout)


def input_values(args, model):
    """``-r NAME=VALUE`` as the model's input vector (others 0)."""
    return inputs(model, assignments(getattr(args, "input", None), "-r"))


# ------------------------------------------------------------------ paths, progress
def _nearest_existing(path: Path) -> Path:
    path = path.absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def check_folder(path, flag: str) -> Path:
    """Refuse (before any work) an output folder that is a file or cannot be created."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise UsageError(f"{flag} {str(path)!r} is a file, not a folder; give a folder (it is "
                         f"created when missing)")
    base = _nearest_existing(path)
    if not base.is_dir():
        raise UsageError(f"{flag} {str(path)!r}: {str(base)!r} is a file, so the folder cannot "
                         f"be created; choose another path")
    if not os.access(base, os.W_OK | os.X_OK):
        raise UsageError(f"{flag} {str(path)!r}: the folder {str(base)!r} is not writable; "
                         f"choose a folder you can write")
    return path


def check_file(path, flag: str) -> Path:
    """Refuse (before any work) an output file that is a folder or cannot be written."""
    path = Path(path)
    if path.is_dir():
        raise UsageError(f"{flag} {str(path)!r} is a folder; give a file path (e.g. "
                         f"{str(path / 'trajectory.csv')!r})")
    if path.exists() and not os.access(path, os.W_OK):
        raise UsageError(f"{flag} {str(path)!r} is not writable; choose another file")
    base = _nearest_existing(path.parent)
    if not base.is_dir():
        raise UsageError(f"{flag} {str(path)!r}: {str(base)!r} is a file, not a folder; choose "
                         f"a path in a folder")
    if not os.access(base, os.W_OK | os.X_OK):
        raise UsageError(f"{flag} {str(path)!r}: the folder {str(base)!r} is not writable; "
                         f"choose a folder you can write")
    return path


def check_count(value: int, flag: str, low: int = 1, high: int | None = None,
                what: str = "") -> int:
    """Refuse (before any work) a count below ``low`` or above ``high`` (``--points 10**12``
    would allocate terabytes or run for ever)."""
    if value < low:
        raise UsageError(f"{flag} {value}: {what or 'it'} must be at least {low}")
    if high is not None and value > high:
        raise UsageError(f"{flag} {value:,}: {what or 'it'} must be at most {high:,}; ask "
                         f"for fewer")
    return value


def progress(msg: str) -> None:
    """A stage of a long command, on stderr: ``  .. msg``."""
    print(f"  .. {msg}", file=sys.stderr, flush=True)
