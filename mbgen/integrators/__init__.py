"""The integrators mbgen can render into generated C, as data: tableaux and properties.

``METHODS`` maps each integrator :class:`~mbgen.abi.Output` to its method class
(:mod:`mbgen.integrators.tableaux`).  Every stage reads a method's properties
here instead of testing its name:

``adaptive``
    error-controlled steps (``rtol``, ``atol``), else a fixed step ``h``;
``implicit``
    solves with ``I/(h gamma) - J``: needs the Jacobian and a caller-owned work struct;
``needs``
    the outputs its generated C calls.

:data:`DEFAULT_RTOL` and :data:`DEFAULT_ATOL` are the one default tolerance of every
adaptive integration mbgen runs or writes: ``CompiledModel.integrate``, the step API's
:class:`~mbgen.runtime.stepper.Stepper`, ``mbgen simulate`` and ``mbgen sweep``, the
generated ``example.c`` and an FMU's co-simulation (``DefaultExperiment tolerance``;
``atol = DEFAULT_ATOL / DEFAULT_RTOL * rtol`` for the importer's ``rtol``).

This package holds no code generation (:mod:`mbgen.codegen.integrators` turns a method
into template context) and imports only :mod:`mbgen.abi`, so the run stage, the
studies and the code generator can all read it.

How to add an integrator
------------------------
1. ``abi.py``: an :class:`~mbgen.abi.Output` member named for the C function
   (``<prefix>_<name>``), and the member in ``abi.INTEGRATORS``.
2. ``integrators/tableaux.py``: a :class:`~mbgen.integrators.tableaux.Method` subclass
   stating its coefficients and ``output``, ``label``, ``adaptive``, ``implicit``,
   ``needs``; one row in :data:`METHODS` below.
3. Its C: ``templates/integrators/<name>.c.j2`` (the whole trajectory) and
   ``templates/step/<name>.c.j2``, ``<name>.h.j2`` (the step API; an adaptive one extends
   ``step/_adaptive.c.j2``).  :mod:`mbgen.codegen.integrators` gives it the view its
   properties call for (an explicit Runge--Kutta tableau, or a Rosenbrock method); the
   stack bound, the work struct, the step API's choice of methods and the studies read
   the same properties.
4. ``tests/codegen/test_targets.py`` (``test_every_integrator_has_its_templates``) fails
   when a member of ``INTEGRATORS`` has no row here or no template, and the golden tree
   (``tests/verify/test_golden.py``) shows the rendered C.
"""

from ..abi import INTEGRATORS, Output
from ..errors import ArgumentError
from .tableaux import (
    DEFAULT_MAX_STEPS,
    RK4,
    ROSENBROCK,
    Dopri5,
    ExplicitRungeKutta,
    Method,
    Rodas3,
    Rodas4,
    Rosenbrock,
)

#: The default tolerances (error per step <= atol + rtol |x|) of every adaptive integration:
#: integrate, Stepper, simulate and sweep on the command line, example.c, an FMU.
DEFAULT_RTOL, DEFAULT_ATOL = 1e-6, 1e-9

#: Output -> method class of every integrator that can be rendered.
METHODS: dict = {Output.DOPRI5: Dopri5, Output.RK4: RK4, Output.ROSENBROCK: ROSENBROCK}


def method(name) -> type:
    """The method class of an integrator given as an :class:`Output` or its name.

    Raises :class:`~mbgen.errors.ArgumentError` naming the choices for anything else.
    """
    try:
        output = name if isinstance(name, Output) else Output(str(name).lower())
    except ValueError:
        output = None
    if output not in METHODS:
        raise ArgumentError(f"{name!r:.60} is not an integrator; choose from "
                            f"{', '.join(repr(o.value) for o in INTEGRATORS)}")
    return METHODS[output]


__all__ = ["METHODS", "method", "Method", "ExplicitRungeKutta", "Rosenbrock", "Dopri5", "RK4",
           "Rodas3", "Rodas4", "ROSENBROCK", "DEFAULT_MAX_STEPS", "DEFAULT_RTOL",
           "DEFAULT_ATOL"]
