"""Targets: what is rendered besides the model's functions, chosen by a small config value.

A target is a template set plus a :class:`Targets` field, never a branch inside
the model templates:

``step``
    The step API (:mod:`mbgen.codegen.targets.step`, ``templates/step.*.j2``): a
    fixed-step and an adaptive ``<prefix>_<method>_step`` that advance a state
    held in a caller-owned memory struct.
``fmu``
    An FMI 2.0 FMU (:mod:`mbgen.codegen.targets.fmu`); needs ``step``.

Always rendered (no option): the index macros, the content hash and the stack
bounds in the header (:mod:`mbgen.codegen.header`), and the batch loops that
only the Python extension compiles (:mod:`mbgen.codegen.targets.batch`).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Targets:
    """What to render besides the requested outputs.

    Attributes
    ----------
    step : bool
        Emit the step API into ``<prefix>.h`` / ``<prefix>.c``.
    """

    step: bool = False


__all__ = ["Targets"]
