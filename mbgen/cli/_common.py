"""What the subcommands share: argument groups and types, numbers by name, path checks.

A subcommand module (:mod:`mbgen.cli`) builds its arguments from
:func:`add_scene_arguments` (``SCENE``, ``-O``, ``--force``, ``--derivation``),
:func:`add_integrator_argument` (``--integrator``) and :func:`add_number_arguments`
(``-p``, ``-x``, ``-r`` by name; ``-r NAME=FILE.csv`` a table of the input against time,
:func:`mbgen.runtime.named.read_input_csv`), then turns them into a scene with
:func:`scene_from` and :func:`with_numbers`.  A scene path that is a folder or a pipe is named
for what it is (:func:`~mbgen.model.scene.load_scene`).  Output paths and counts are refused before
any work (:func:`check_folder`, :func:`check_output_folder`, :func:`check_file`,
:func:`check_count`: at most :data:`MAX_POINTS` output times); :func:`progress` prints a
stage on stderr, :func:`stage_lines` the pipeline's stages when stderr is a terminal.
Exit codes are :mod:`mbgen.errors`'s ``EXIT_*``.

Conventions every command keeps: ``--derivation`` is the derivation method (Kane,
Newton--Euler) and ``--integrator`` the integration method; ``--method``, which meant
either, still works where it did, with a note on stderr naming what it means there
(:class:`OldSpelling`).  Every option has help text that states its default
(:class:`mbgen.cli.HelpFormatter`).  A user's mistake in what they asked for (an argument, an
output path, a file in the way) exits 2; one in what the scene states exits 3.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from dataclasses import replace
from pathlib import Path

from ..derivation import Method
from ..errors import OutputPathError, SceneError, UsageError
from ..model.scene import load_scene, model_names
from ..names import did_you_mean
from ..runtime.named import InputTable, check_names, merge_inputs, read_input_csv, vector
from ..studies.ensemble import MAX_POINTS as MAX_POINTS  # the commands' limit (docstring)
from ..symbolic.equations import METHOD_TITLES
from ..verify import golden


# ------------------------------------------------------------------ help and spellings
def note(message: str) -> None:
    """``mbgen: note: message`` on stderr."""
    print(f"mbgen: note: {message}", file=sys.stderr, flush=True)


class OldSpelling(argparse.Action):
    """An option's old spelling (``--method``): stores into the new option's ``dest`` and
    says on stderr which option it stands for here."""

    def __init__(self, option_strings, dest, new: str = "", meaning: str = "", **kwargs):
        self.new, self.meaning = new, meaning
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        note(f"{option_string} is the old spelling of {self.new} here ({self.meaning}); "
             f"use {self.new}")
        setattr(namespace, self.dest, values)


# ------------------------------------------------------------------ argument groups
def add_scene_arguments(p: argparse.ArgumentParser, method_flag: bool = False) -> None:
    """``SCENE``, ``-O KEY=VALUE``, ``--force`` and ``--derivation`` (also the old spelling
    ``--method`` when ``method_flag``: generate, check and linearize had it)."""
    p.add_argument("scene", metavar="SCENE",
                   help="built-in scene name (see 'mbgen scenes') or path to a scene .py file")
    p.add_argument("-O", "--option", action="append", metavar="KEY=VALUE",
                   help="scene option, e.g. -O n=8 (repeatable)")
    p.add_argument("--force", action="store_true",
                   help="build a model past the size guard (more than 200 speeds)")
    choices = [m.value for m in Method]
    p.add_argument("--derivation", choices=choices,
                   help="derivation method (default: the scene's, else the cheaper of the two "
                        "for the model: docs/modelling.md, 'Which derivation')")
    if method_flag:
        p.add_argument("--method", dest="derivation", choices=choices, action=OldSpelling,
                       new="--derivation", meaning="the derivation method",
                       help="old spelling of --derivation (still accepted, with a note)")


def add_integrator_argument(p: argparse.ArgumentParser, help: str) -> None:
    """``--integrator NAME`` (``help`` says which), and its old spelling ``--method``."""
    p.add_argument("--integrator", default=None, metavar="NAME", help=help)
    p.add_argument("--method", dest="integrator", metavar="NAME", action=OldSpelling,
                   new="--integrator", meaning="the integration method",
                   help="old spelling of --integrator (still accepted, with a note)")


def add_number_arguments(p: argparse.ArgumentParser, parameters: bool = True,
                         states: bool = True, inputs: bool = True,
                         tables: bool = False) -> None:
    """``-p``, ``-x`` and ``-r NAME=VALUE`` (each repeatable), those asked for; with
    ``tables``, ``-r NAME=FILE.csv`` too (an input against time)."""
    if parameters:
        p.add_argument("-p", "--parameter", action="append", metavar="NAME=VALUE",
                       help="a parameter's value (repeatable; others: the scene's)")
    if states:
        p.add_argument("-x", "--state", action="append", metavar="NAME=VALUE",
                       help="an initial state's value (repeatable; others: the scene's "
                            "initial state, else 0)")
    if inputs and tables:
        p.add_argument("-r", "--input", action="append", metavar="NAME=VALUE|NAME=FILE.csv",
                       help="an input's value (repeatable; others 0): a number, held "
                            "constant, or a CSV table of time and values (header t,NAME; "
                            "linear between rows, held outside them)")
    elif inputs:
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


#: What a scene path names, by its suffix (as :func:`~mbgen.model.scene.load_scene` reads it).
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


def end_time(scene, t_end: float | None, flag: str = "--t-end") -> float:
    """``t_end`` (default: the scene's), refused unless finite and after the scene's start."""
    t0 = float(scene.t_span[0])
    t1 = float(scene.t_span[1]) if t_end is None else float(t_end)
    if not math.isfinite(t1) or not t1 > t0:
        raise UsageError(f"{flag} {t1!r}: give a finite end time after the scene's start "
                         f"{t0!r}")
    return t1


def initial_state(scene, model):
    """The scene's initial state for ``model``; ``-x`` names are checked ("did you mean")."""
    check_names(scene.initial_state, model.state_names, "states", scene.name)
    return scene.x0(model.layout)


def input_values(args, model):
    """``-r NAME=VALUE`` as the model's input vector (others 0); with a ``-r NAME=FILE.csv``
    among them, an :class:`~mbgen.runtime.named.InputTable` in the model's input order.
    ``model``: a compiled model, or a kernel's ``Layout`` (generate's example.c)."""
    return resolve_inputs(input_signals(args), model)


def resolve_inputs(given: dict, model, name: str = ""):
    """:func:`input_signals`' ``given`` for ``model`` (see :func:`input_values`); ``name``
    names a ``Layout``'s model in messages."""
    name = name or getattr(model, "name", "")
    check_names(given, model.input_names, "inputs", name)
    merged = merge_inputs(given)
    if isinstance(merged, InputTable):
        return merged.for_model(model)
    return vector(merged, model.input_names, "inputs", fill=0.0, model=name)


def input_signals(args) -> dict:
    """``-r`` as ``{name: number}``, or ``{name: (times, values)}`` for ``NAME=FILE.csv``:
    the file's column NAME, or its only input column."""
    out = {}
    for pair in getattr(args, "input", None) or ():
        name, eq, value = pair.partition("=")
        name, value = name.strip(), value.strip()
        if not eq or not name:
            raise UsageError(f"-r {pair!r} must look like NAME=VALUE or NAME=FILE.csv (e.g. "
                             f"-r F=0.5, -r F=force.csv)")
        try:
            out[name] = float(value)
            continue
        except ValueError:
            pass
        if not value.lower().endswith(".csv") and not Path(value).is_file():
            raise UsageError(f"-r {pair!r}: {value!r} is neither a number nor a CSV file (a "
                             f"table with the header t,{name})")
        table = read_input_csv(value)
        columns = table.values
        if name not in columns and len(columns) != 1:
            raise UsageError(f"-r {pair!r}: {value} has the columns {', '.join(columns)}, "
                             f"none named {name!r}{did_you_mean(name, columns)} (name the "
                             f"column {name}, or give a table with one input column)")
        out[name] = (table.times, columns.get(name, next(iter(columns.values()))))
    return out


def constant_inputs(args, model):
    """``-r NAME=VALUE`` as the model's input vector; a table is refused (for commands that
    work at one operating point: linearize)."""
    value = input_values(args, model)
    if isinstance(value, InputTable):
        raise UsageError("-r takes a number here (the inputs at the operating point), not "
                         "a table; tables drive 'mbgen simulate' and generate's example.c")
    return value


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


def check_output_folder(path, flag: str) -> Path:
    """:func:`check_folder`, and refuse the checked-in golden tree (``generated/`` of the
    source checkout mbgen runs from), which only ``mbgen golden --update`` writes."""
    path = check_folder(path, flag)
    try:
        tree = golden.default_root().resolve()
    except UsageError:  # an installed mbgen: no golden tree to protect
        return path
    where = path.resolve()
    if where == tree or tree in where.parents:
        raise OutputPathError(f"{flag} {str(path)!r} is inside the golden tree {str(tree)!r}, "
                              f"which 'mbgen golden --update' alone writes (the tests compare "
                              f"it with the generator); choose another folder (the default "
                              f"is mbgen-out/SCENE)")
    return path


def progress(msg: str) -> None:
    """A stage of a long command, on stderr: ``  .. msg``."""
    print(f"  .. {msg}", file=sys.stderr, flush=True)


#: How :func:`stage_lines` names the pipeline's stages (:func:`mbgen.pipeline.run`).
STAGES = {"derive": "derive", "bake": "bake the scene's slice", "cse": "CSE",
          "render": "render", "compile": "compile (C compiler)",
          "warm": "load (unchanged since a run before: nothing derived)"}


def stage_lines(args):
    """A ``stage=`` callback for :func:`mbgen.pipeline.run` that prints ``  .. derive``,
    ``  .. CSE``, ... on stderr; None (quiet) unless stderr is a terminal, or with
    ``--quiet``: a log or a pipe gets only the results, as git prints progress."""
    if getattr(args, "quiet", False) or not sys.stderr.isatty():
        return None
    def line(name: str) -> None:
        base, _, method = name.partition("/")   # derive/kane: while both are compared
        title = f" ({METHOD_TITLES.get(method, method)})" if method else ""
        progress(STAGES.get(base, base) + title)
    return line
