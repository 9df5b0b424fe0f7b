"""The integrators target: whole-trajectory C integrators in the model's files.

Rendered when the scene asks for an integrator output (``Output.DOPRI5``, ``RK4``,
``ROSENBROCK``): ``templates/integrators/integrators.h.j2`` (options, statistics, work
structs, prototypes) into ``<prefix>.h`` and ``integrators.c.j2`` (what every method
shares, then one template per method, ``<output>.c.j2``) into ``<prefix>.c``.  The
views of the methods are :mod:`mbgen.codegen.integrators`.
"""

from __future__ import annotations

from ...abi import INTEGRATOR_STATUS_CODES
from ..integrators import integrator_context
from .base import HEADER, SOURCE, Target


class Integrators(Target):
    """The C integrators the kernel asks for, a section of the model's files."""

    name = "integrators"
    files = (("integrators.h.j2", HEADER), ("integrators.c.j2", SOURCE))
    status_codes = INTEGRATOR_STATUS_CODES

    def wanted(self, kernel, targets) -> bool:
        return bool(kernel.integrators)

    def context(self, kernel, views: list[dict], prefix: str) -> dict:
        return integrator_context(kernel)


#: The integrators target.
INTEGRATORS = Integrators()

__all__ = ["INTEGRATORS", "Integrators"]
