"""Targets: what is rendered, each a row of :data:`TARGETS` over its own template folder.

A target (:class:`~mbgen.codegen.targets.base.Target`) names its folder ``templates/<folder>/``,
lists the templates it renders from there and where each goes (a file, or a section of
the model's ``.h`` / ``.c``), says when it is wanted, gives its template context, the
stack bounds of its public C functions, the runtime routines its C calls
(:mod:`~mbgen.codegen.targets.runtime`) and what it writes into an output folder.  Two
loops read the rows and name none: :func:`mbgen.codegen.render.render` (``Kernel ->
Rendered``) and :func:`mbgen.export.generate` (a scene into a folder, ``mbgen generate
SCENE --target c,python,step,batch,example,fmu,casadi,jax``).  The model's templates
include the sections the active targets list, never a template they know by name.

``c`` (:data:`C`, :mod:`~mbgen.codegen.targets.model`)
    ``<prefix>.h``, ``<prefix>.c``: the requested outputs in C.  Always rendered.
``python`` (:data:`PYTHON`, :mod:`~mbgen.codegen.targets.model`)
    ``<prefix>.py``: the same functions in Python.  Always rendered.
``integrators`` (:data:`INTEGRATORS`, :mod:`~mbgen.codegen.targets.integrators`)
    Whole-trajectory C integrators, one template per method, in ``c``'s files; when the
    scene asks for an integrator output (not chosen by name).
``step`` (:data:`STEP`, :mod:`~mbgen.codegen.targets.step`)
    The step API in ``c``'s files: a fixed-step and an adaptive
    ``<prefix>_<method>_step`` that advance a state held in a caller-owned memory struct;
    with ``Targets(step=True)`` or ``--target step`` (``--step``).
``batch`` (:data:`BATCH`, :mod:`~mbgen.codegen.targets.batch`)
    Loops over ``k`` items compiled into the Python extension (always);
    ``<prefix>_batch.c`` when chosen.
``example`` (:data:`EXAMPLE`, :mod:`~mbgen.codegen.targets.example`)
    ``example.c``, a main() running the scene's first integrator; rendered from a scene
    after the pipeline.
``fmu`` (:data:`FMU`, :mod:`~mbgen.codegen.targets.fmu`)
    An FMI 2.0 FMU, ``<prefix>.fmu``: the model description and glue rendered from a scene
    after the pipeline, with the step API, compiled and zipped (``mbgen fmu``).
``casadi`` (:data:`CASADI`, :mod:`~mbgen.codegen.targets.casadi`)
    ``<prefix>_casadi.c``: the right-hand side and its analytic Jacobian behind CasADi's
    external-function interface, and ``<prefix>_casadi.py``, a loader; needs ``c``
    (:func:`mbgen.casadi_function` builds and loads the same).
``jax`` (:data:`JAX`, :mod:`~mbgen.codegen.targets.jax`)
    ``<prefix>_jax.py``: the outputs as pure ``jax.numpy`` functions
    (:func:`mbgen.jax_function` loads the same).

The header's index macros and content hash are :mod:`mbgen.codegen.header`'s, with the units
of the stack bounds every row states for its own functions.

How to add a target
-------------------
1. ``templates/<name>/``: its templates (a section of ``<prefix>.c`` is included by
   ``model/model.c.j2`` with the model's context, so it can call the model's functions;
   a runtime routine it calls is asked for with ``runtime("<routine>")`` first).
2. ``codegen/targets/<name>.py``: a :class:`~mbgen.codegen.targets.base.Target`
   subclass and its instance, the row: ``name``, ``files``; as needed ``wanted``,
   ``context``, ``declarations``, ``status_codes``, ``requires`` (its runtime routines),
   ``stack_bounds`` (of its public C functions), ``needs`` / ``uses`` (other targets),
   and ``export`` (its files in an output folder) or ``archive`` (a file it writes whole).
3. This module: the instance in :data:`TARGETS`, in file order.  A target the pipeline
   renders on request also gets a field of :class:`Targets` named after it (read by its
   ``wanted``; :func:`switches` sets it).  Nothing else: ``render``, ``mbgen.generate`` and
   ``mbgen generate --target`` read the rows.
4. ``tests/codegen/test_targets.py`` fails when a listed template is missing, a folder is
   nobody's, or a template calls a runtime routine its row does not list;
   ``tests/codegen/test_header.py`` checks stack bounds against ``gcc -fstack-usage``;
   ``tests/verify/test_golden.py`` shows the rendered text of the built-in scenes.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ...errors import UsageError
from ...names import did_you_mean
from .base import Job, Target
from .batch import BATCH
from .casadi import CASADI
from .example import EXAMPLE
from .fmu import FMU
from .integrators import INTEGRATORS
from .jax import JAX
from .model import PYTHON, C
from .step import STEP


@dataclass(frozen=True)
class Targets:
    """What the pipeline renders besides the requested outputs (a field per target that is
    switched on: :func:`switches`).

    Attributes
    ----------
    step : bool
        Emit the step API into ``<prefix>.h`` / ``<prefix>.c``.
    """

    step: bool = False


#: Every target, in file order (the model's sections in the order they follow it).
TARGETS: tuple[Target, ...] = (C, PYTHON, INTEGRATORS, STEP, BATCH, EXAMPLE, FMU, CASADI,
                                JAX)
#: The targets that add sections to the model's files, in the order of their sections.
SECTIONS: tuple[Target, ...] = tuple(t for t in TARGETS
                                     if any(w in ("header", "source") for _, w in t.files))
#: What ``mbgen generate`` and :func:`mbgen.generate` write unless told: the model in C and
#: in Python, and ``example.c`` when the scene has an integrator.
DEFAULT: tuple[str, ...] = ("c", "python", "example")
#: The targets chosen by name.
CHOSEN: tuple[str, ...] = tuple(t.name for t in TARGETS if t.chosen)


def target(name: str) -> Target:
    """The row named ``name``."""
    return {t.name: t for t in TARGETS}[name]


def select(names) -> tuple[Target, ...]:
    """The rows named (a sequence of names, or one comma-separated string) with the rows
    they need, in registry order.  An unknown name is a :class:`~mbgen.errors.UsageError`."""
    names = [n.strip() for n in (names.split(",") if isinstance(names, str) else names)]
    for n in names:
        if n not in CHOSEN:
            raise UsageError(f"unknown target {n!r}{did_you_mean(n, CHOSEN)}; the targets are "
                             f"{', '.join(CHOSEN)}")
    wanted = set(names)
    while True:
        more = {n for t in TARGETS if t.name in wanted for n in t.needs} - wanted
        if not more:
            return tuple(t for t in TARGETS if t.name in wanted)
        wanted |= more


def switches(rows, scene_targets: Targets | None = None) -> Targets:
    """The :class:`Targets` that renders ``rows`` (and the rows they use), with those the
    scene switches on."""
    names = {t.name for t in rows} | {n for t in rows for n in t.uses}
    on = {f.name: f.name in names or bool(scene_targets and getattr(scene_targets, f.name))
          for f in dataclasses.fields(Targets)}
    return Targets(**on)


__all__ = ["Targets", "Target", "Job", "TARGETS", "SECTIONS", "DEFAULT", "CHOSEN", "C", "PYTHON",
           "INTEGRATORS", "STEP", "BATCH", "EXAMPLE", "FMU", "CASADI", "JAX", "target", "select",
           "switches"]
