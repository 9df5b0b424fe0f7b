"""Targets: what is rendered, each a small config object over its own template folder.

A target (:class:`~mbgen.codegen.targets.base.Target`) names its folder
``templates/<name>/``, lists the templates it renders from there and where each
goes (a file, or a section of the model's ``.h`` / ``.c``), says when it is wanted
and gives its template context.  :func:`mbgen.codegen.render.render` loops over them;
the model's templates include the sections the active targets list, never a template
they know by name.

``model`` (:data:`MODEL`, :mod:`~mbgen.codegen.targets.model`)
    ``<prefix>.h``, ``<prefix>.c``, ``<prefix>.py``: the requested outputs.  Always.
``integrators`` (:data:`INTEGRATORS`, :mod:`~mbgen.codegen.targets.integrators`)
    Whole-trajectory C integrators, one template per method; when the scene asks for
    an integrator output.
``step`` (:data:`STEP`, :mod:`~mbgen.codegen.targets.step`)
    The step API: a fixed-step and an adaptive ``<prefix>_<method>_step`` that advance
    a state held in a caller-owned memory struct; with ``Targets(step=True)``.
``batch`` (:data:`BATCH`, :mod:`~mbgen.codegen.targets.batch`)
    Loops over ``k`` items compiled into the Python extension only.  Always.
``fmu`` (:data:`FMU`, :mod:`~mbgen.codegen.targets.fmu`)
    An FMI 2.0 FMU's model description and glue; rendered from a scene after the
    pipeline (:func:`mbgen.export.export_fmu`), needs ``step``.
``example`` (:data:`EXAMPLE`, :mod:`~mbgen.codegen.targets.example`)
    ``example.c``, a main() running the scene's first integrator; rendered from a scene
    after the pipeline (``mbgen generate``, ``generated/``).

The header's index macros, content hash and stack bounds are the model target's
(:mod:`mbgen.codegen.header`, ``templates/model/header_extra.h.j2``).

How to add a target
-------------------
1. ``templates/<name>/``: its templates (a section of ``<prefix>.c`` is included by
   ``model/model.c.j2`` with the model's context, so it can call the model's functions).
2. ``codegen/targets/<name>.py``: a :class:`~mbgen.codegen.targets.base.Target`
   subclass (``name``, ``files``, and ``wanted``, ``context``, ``declarations``,
   ``status_codes`` as needed) and its instance.
3. This module: the instance in :data:`TARGETS`, and in :data:`SECTIONS` (in file order)
   when it adds to the model's files; a field of :class:`Targets` when the user
   switches it on (read by its ``wanted``).
4. ``tests/codegen/test_targets.py`` fails when a listed template is missing
   (``test_every_target_has_its_templates``); ``tests/codegen/test_golden.py`` shows the
   rendered text of the built-in scenes.
"""

from __future__ import annotations

from dataclasses import dataclass

from .base import Target
from .batch import BATCH
from .example import EXAMPLE
from .fmu import FMU
from .integrators import INTEGRATORS
from .model import MODEL
from .step import STEP


@dataclass(frozen=True)
class Targets:
    """What to render besides the requested outputs.

    Attributes
    ----------
    step : bool
        Emit the step API into ``<prefix>.h`` / ``<prefix>.c``.
    """

    step: bool = False


#: The targets that add sections to the model's files, in the order of their sections.
SECTIONS: tuple[Target, ...] = (INTEGRATORS, STEP)
#: Every target.
TARGETS: tuple[Target, ...] = (MODEL, *SECTIONS, BATCH, FMU, EXAMPLE)

__all__ = ["Targets", "Target", "TARGETS", "SECTIONS", "MODEL", "INTEGRATORS", "STEP", "BATCH",
           "FMU", "EXAMPLE"]
