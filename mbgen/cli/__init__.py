"""Command-line interface: ``mbgen COMMAND ...``, one module per command.

:data:`COMMANDS` lists the commands (``scenes generate linearize check simulate animate
demo bench stress fmu sweep golden``): each names its module in this package and its
one-line help.  A command's module has ``configure(parser)``, which adds its arguments
to its sub-parser, and ``run(args) -> int``, which does the work and returns the exit
code.  :func:`main` imports only the module of the command asked for (``mbgen --help``
imports none), so a module imports what it needs at its top.  What the commands share
-- the scene and number arguments, argument types, path checks, progress lines -- is in
:mod:`mbgen.cli._common`.

Exit codes
----------
0  success
1  a check failed (errors above tolerance, golden files out of date)
2  usage error: a mistake in what was asked, in every command alike -- a bad argument,
   an unknown method, parameter, state or input name, an output path that is a file or
   cannot be written, the golden tree as an output folder, a file of the user's in the
   way of a generation (``--overwrite``), an unreadable input table
3  bad model or scene: what the scene states (unknown scene name, a scene file that
   does not exist or fails, a malformed model, a bad ``-O`` option)
4  the C compiler failed
5  numerical failure (singular mass matrix, non-finite result, integrator failure)
6  check inconclusive: some output was compared on no sample (every sample failed in
   every back end: a zero mass, a NaN parameter, a singular mass matrix everywhere), or
   differed only within the reference's own rounding (an ill-conditioned state)

An :class:`~mbgen.errors.MbgenError` that ends a command exits with its class's
``exit_code`` (the table in :mod:`mbgen.errors`).  Every option's help states its
default (:class:`HelpFormatter`); ``--derivation`` and
``--integrator`` mean one thing in every command (the old ``--method`` still works,
with a note saying which of the two it is there).

How to add a command
--------------------
1. ``mbgen/cli/<name>.py`` with ``configure(parser)`` (its arguments; the shared
   groups of :mod:`mbgen.cli._common`) and ``run(args) -> int`` (an ``EXIT_*`` code of
   :mod:`mbgen.errors`; raise an :class:`~mbgen.errors.MbgenError` for a failure).
2. Its row in :data:`COMMANDS` (the order is the order of ``mbgen --help``).
   ``tests/cli/test_cli.py::test_every_command_module_has_configure_and_run`` fails when
   the row names a module that is missing or lacks either function.
3. Its tests in ``tests/cli/test_cli.py`` (or ``tests/<area>/test_<subject>.py``): at
   least one run through :func:`main`; ``test_help_everywhere`` already runs its
   ``--help``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

from .._version import __version__
from ..errors import (
    EXIT_BUILD,
    EXIT_CHECK,
    EXIT_INCONCLUSIVE,
    EXIT_MODEL,
    EXIT_NUMERIC,
    EXIT_OK,
    EXIT_USAGE,
    MbgenError,
)


class Command(NamedTuple):
    """A row of :data:`COMMANDS`: the module in this package, and the line of ``--help``."""

    module: str
    help: str


#: Every command, in the order of ``mbgen --help``.
COMMANDS = {
    "scenes": Command("scenes", "list the built-in scenes"),
    "generate": Command("generate", "write the generated C header, C source and Python "
                                    "(--target c,python,step,batch,example,fmu)"),
    "linearize": Command("linearize", "A, B and eigenvalues at the scene's initial state"),
    "check": Command("check", "compare compiled C, generated Python and lambdify"),
    "simulate": Command("simulate", "integrate with the compiled RHS and write a CSV"),
    "animate": Command("animate", "3-D animation of the scene's points and bodies "
                                  "(.html with play controls, or .gif)"),
    "demo": Command("demo", "the main job on the pendulum on a rotating disc"),
    "bench": Command(
        "bench", "benchmarks: 'mbgen bench SCENE' (work-precision: error against run time "
                 "of every integrator and back end), 'mbgen bench scaling' (n-link "
                 "pendulum, mbgen vs sympy), 'mbgen bench robot' (a URDF or MJCF "
                 "robot FILE: mbgen vs Pinocchio vs MuJoCo), 'mbgen bench arm' (spatial "
                 "arm: mbgen vs "
                 "sympy vs Pinocchio, RHS timed inside C), 'mbgen bench constraints' "
                 "(Whipple bicycle: mbgen vs sympy's KanesMethod; four-bar residual "
                 "against run time) or 'mbgen bench interop' (an IPOPT NLP with mbgen's "
                 "CasADi external vs CasADi's SX; JAX vs C batch vs MJX throughput)"),
    "stress": Command("stress", "stability suite: stiff, extreme, near-singular, long runs, "
                                "floating point vs 50-digit mpmath"),
    "fmu": Command("fmu", "write an FMI 2.0 FMU (model exchange and co-simulation); "
                          "alias of 'generate --target fmu -o .'"),
    "sweep": Command("sweep", "parameter study / Monte Carlo ensemble on Dask (exit 5 "
                              "when a member failed; the table is written anyway)"),
    "golden": Command("golden", "compare (or --update) generated/ with the generator"),
}

#: How ``mbgen: <heading>: <message>`` begins for an error's exit code (else "error").
HEADINGS = {EXIT_CHECK: "check failed", EXIT_INCONCLUSIVE: "check inconclusive",
            EXIT_BUILD: "compiler error", EXIT_NUMERIC: "numerical error"}


class HelpFormatter(argparse.HelpFormatter):
    """Every option's help ends with its default, unless the text states it already
    (a flag, or an option whose default is "none", shows none)."""

    def _get_help_string(self, action):
        text = action.help or ""
        if (not action.option_strings or action.default in (None, False, argparse.SUPPRESS)
                or "default" in text):
            return text
        return f"{text} (default: %(default)s)"


def command_module(name: str):
    """The module of command ``name`` (imported now)."""
    return importlib.import_module(f"{__name__}.{COMMANDS[name].module}")


def parser(commands: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The ``mbgen`` parser; only ``commands`` (default: all) get their arguments.

    Every command is a choice (with its help line) either way; the others are
    left without arguments, so their modules are not imported.
    """
    top = argparse.ArgumentParser(
        prog="mbgen", description="Multibody models to fast, verified C and Python.",
        formatter_class=HelpFormatter,
        epilog="Exit codes: 0 ok, 1 check failed, 2 usage, 3 bad model/scene, 4 compiler "
               "failed, 5 numerical failure, 6 check inconclusive (nothing compared, or "
               "nothing resolved).")
    top.add_argument("--version", action="version", version=f"mbgen {__version__}")
    sub = top.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, command in COMMANDS.items():
        p = sub.add_parser(name, help=command.help, formatter_class=HelpFormatter)
        if commands is None or name in commands:
            module = command_module(name)
            module.configure(p)
            p.set_defaults(run=module.run)
    return top


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``mbgen`` with ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    # the command is the first word that is not an option (``mbgen`` itself has no option
    # that takes a value); none (``mbgen --help``): no command module is imported
    chosen = [word for word in argv if not word.startswith("-")][:1]
    args = parser(chosen).parse_args(argv)
    try:
        return args.run(args)
    except BrokenPipeError:  # output piped into e.g. `head`: stop quietly
        sys.stderr.close()
        return EXIT_OK
    except MbgenError as exc:
        print(f"mbgen: {HEADINGS.get(exc.exit_code, 'error')}: {exc}", file=sys.stderr)
        return exc.exit_code
    except OSError as exc:  # a path that cannot be written (or read): the caller's to fix
        print(f"mbgen: error: {_os_error(exc)}", file=sys.stderr)
        return EXIT_USAGE


def _os_error(exc: OSError) -> str:
    """What went wrong with a file or folder, and the fix."""
    name = exc.filename or ""
    env = os.environ.get("MBGEN_CACHE_DIR")  # build.cache_dir(), without creating it
    cache = Path(env) if env else Path(os.environ.get("XDG_CACHE_HOME",
                                                      Path.home() / ".cache")) / "mbgen"
    where = f" {str(name)!r}" if name else ""
    if name and (Path(name).absolute() == cache.absolute()
                 or cache.absolute() in Path(name).absolute().parents):
        return (f"cannot use the compile cache folder {str(cache)!r} ({exc.strerror}); set "
                f"MBGEN_CACHE_DIR to a writable folder")
    return f"cannot write{where}: {exc.strerror or exc}; choose a writable path"


__all__ = ["COMMANDS", "Command", "HelpFormatter", "EXIT_BUILD", "EXIT_CHECK", "EXIT_INCONCLUSIVE",
           "EXIT_MODEL", "EXIT_NUMERIC", "EXIT_OK", "EXIT_USAGE", "command_module", "main",
           "parser"]
