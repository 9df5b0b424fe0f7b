r"""A split model's source as several translation units, compiled at once on several cores.

gcc compiles one translation unit on one core.  A large function is already cut into
``static`` parts (:mod:`mbgen.codegen.split`), each of which gcc optimises on its own, so
the parts can just as well live in other translation units and be compiled in parallel;
the library is then linked from their objects.  The code is the same code: every part is
the same function with the same flags, called once from the same place, so the results are
those of the one unit bit for bit (no flag lets gcc reassociate or contract floating point,
and a call across units only forgoes inlining a function of some 40,000 characters).

:func:`units` cuts the rendered source ``<prefix>.c`` into up to :data:`UNITS_PER_JOB`
``* jobs`` texts, which a pool of ``jobs`` compilers works through
(:func:`run_compilers`):

* the first is the source with each moved part's body replaced by its declaration;
* the others hold the parts, in order, in contiguous groups of about equal size, after the
  source's ``#include`` lines (the parts read the header's status codes and ``math.h``).

A part keeps its name (``<prefix>_<function>_part<k>``, prefixed like every symbol of the
model) but loses ``static``: it is declared with hidden visibility where the compiler has
it, so the library exports what it exported before.  Measured on the 32-link arm's RHS
(four parts, ``-O2 -march=native``, 2 cores): the compile stage (build and load, a new
process) took 1.35-1.38 s as one unit and 0.84-0.96 s with two jobs.

Shapes: ``units(source, jobs) -> list[str]``; one text where the source has no parts or
``jobs`` is 1.
"""

from __future__ import annotations

import os
import re
import subprocess
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from ..errors import BuildError
from .cache import disk_full, mentions_full_disk

#: A part as :file:`templates/model/model.c.j2` prints it: its comment, its ``static``
#: prototype (group 1: the prototype without ``static``), its body up to the first ``}`` in
#: column 0.
PART = re.compile(r"\n/\* Part \d+ of \d+ of \w+ \([^)]*\)\. \*/\n"
                  r"static ((?:int|void) \w+_part\d+\([^)]*\))\n\{\n.*?\n\}\n", re.S)

#: What a part is declared with in every unit: not ``static``, and not exported.
HIDDEN = ("#if defined(__GNUC__)\n#define MBGEN_PART __attribute__((visibility(\"hidden\")))\n"
          "#else\n#define MBGEN_PART\n#endif\n")


#: Units per compiler process: parts of one size differ several-fold in compile time (the
#: 32-link arm's first part, with the sines and cosines, takes 0.59 s where the others take
#: 0.21 s), so a pool of ``jobs`` processes works through smaller units.
UNITS_PER_JOB = 4


def build_jobs() -> int:
    """How many compiler processes build one library: ``$MBGEN_BUILD_JOBS`` where set, else
    the cores this process may run on.

    Raises
    ------
    BuildError
        ``$MBGEN_BUILD_JOBS`` is not a whole number of at least 1.
    """
    given = os.environ.get("MBGEN_BUILD_JOBS", "").strip()
    if given:
        if not given.isdigit() or int(given) < 1:
            raise BuildError(f"MBGEN_BUILD_JOBS={given!r}: give a whole number of compiler "
                             f"processes (1 or more), or unset it to use every core")
        return int(given)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):   # not on Linux
        return max(1, os.cpu_count() or 1)


def units(source: str, jobs: int) -> list[str]:
    """``source`` as :data:`UNITS_PER_JOB` ``* jobs`` translation units at most: the rest,
    then the parts in contiguous groups (module docstring); ``[source]`` where there is
    nothing to share."""
    parts = list(PART.finditer(source))
    if jobs < 2 or not parts:
        return [source]
    rest = len(source) - sum(m.end() - m.start() for m in parts)
    groups = _groups([rest] + [m.end() - m.start() for m in parts], jobs * UNITS_PER_JOB)
    if len(groups) < 2:
        return [source]
    moved = {k - 1 for group in groups[1:] for k in group}
    first, at = [HIDDEN], 0
    for k, m in enumerate(parts):   # a moved part leaves its declaration behind
        first += [source[at:m.start()],
                  f"\nMBGEN_PART {m.group(1)};\n" if k in moved else m.group(0)]
        at = m.end()
    first.append(source[at:])
    includes = "".join(line + "\n" for line in source.splitlines()
                       if line.startswith("#include"))
    return ["".join(first)] + [
        HIDDEN + includes + "".join(parts[k - 1].group(0).replace("\nstatic ", "\nMBGEN_PART ", 1)
                                    for k in group)
        for group in groups[1:]]


def _groups(sizes: list[int], count: int) -> list[list[int]]:
    """Indices ``0..len(sizes)-1`` in at most ``count`` contiguous groups of about
    ``sum(sizes) / count`` each (greedy, in order); index 0 is the first unit."""
    target = sum(sizes) / count
    groups: list[list[int]] = [[]]
    load = 0
    for k, size in enumerate(sizes):
        if groups[-1] and load + size / 2 > target and len(groups) < count:
            groups.append([])
            load = 0
        groups[-1].append(k)
        load += size
    return groups


def run_compilers(commands: list[list[str]], folder: Path, name: str, what: str,
                  jobs: int | None = None, meanwhile: Callable[[], object] | None = None
                  ) -> str:
    """Run ``commands`` in ``folder``, ``jobs`` at a time (all at once by default), each
    read through a pipe: the process's working directory and descriptors are never
    touched, so threads may build at once.  ``meanwhile()`` runs in this thread while they
    do (Python work that would otherwise wait for them: cffi's parse of the declarations,
    0.065 s of the 2-link arm's 0.13 s load, as long as its gcc run).  Their joined output,
    or a :class:`BuildError` naming ``what`` is built (a
    :func:`~mbgen.build.cache.disk_full` one when the output says the disk is full)."""
    label = what if " " in what else f"model {what!r}"

    def one(cmd: list[str]) -> tuple[int, str]:
        try:
            proc = subprocess.Popen(cmd, cwd=folder, stdout=subprocess.PIPE,
                                    stderr=subprocess.STDOUT, text=True, errors="replace")
        except OSError as exc:
            raise BuildError(f"compiling {label} failed: cannot run {cmd[0]!r} ({exc}); "
                             f"install a C compiler or set CC") from None
        output = proc.communicate()[0]
        return proc.returncode, output

    with ThreadPoolExecutor(max_workers=jobs or len(commands)) as pool:
        running = [pool.submit(one, cmd) for cmd in commands]
        if meanwhile is not None:
            meanwhile()
        results = [r.result() for r in running]
    output = "\n".join(o.strip() for _, o in results if o.strip())
    full = mentions_full_disk(output)
    if full:
        raise disk_full(folder.parent, name, full)
    failed = [rc for rc, _ in results if rc != 0]
    if failed:
        raise BuildError(f"compiling {label} failed: the compiler exited with "
                         f"status {failed[0]}\n--- compiler output ---\n{output}")
    return output


__all__ = ["units", "build_jobs", "run_compilers", "PART"]
