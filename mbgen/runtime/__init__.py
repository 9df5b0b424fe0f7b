"""Running generated models from Python: three back ends behind one interface.

Back ends (each a :class:`~mbgen.runtime.base.ModelBase`)
    :mod:`~mbgen.runtime.compiled` (:class:`CompiledModel`: the generated C through cffi,
    the fast one), :mod:`~mbgen.runtime.python` (:class:`PythonModel`: the generated
    Python, no compiler) and :mod:`~mbgen.runtime.lambdified` (:class:`LambdifiedModel`:
    ``sympy.lambdify`` of the unoptimised equations, the reference).
The one interface (:mod:`~mbgen.runtime.base`)
    ``model.<output>(t, x, p=None, r=None)`` for every generated output (``rhs``,
    ``mass_matrix``, ``jacobian``, ...: one row of :data:`~mbgen.runtime.base.ACCESSORS`
    each), with ``x`` of shape ``(n_x,)``, ``p`` ``(n_p,)`` (default: the model's),
    ``r`` ``(n_r,)`` (default: zeros), as arrays or mappings by name
    (:mod:`~mbgen.runtime.named`); ``bind(p, r)`` for ``solve_ivp``; ``consistent(x)`` for
    constrained models.  A back end implements only ``_evaluate(output, t, x, p, r)``.
Around them
    :mod:`~mbgen.runtime.arguments` (argument checks), :mod:`~mbgen.runtime.batch` (``k``
    items in one C call), :mod:`~mbgen.runtime.stepper` (the C step API),
    :mod:`~mbgen.runtime.simulate` (integration, choosing the method),
    :mod:`~mbgen.runtime.linearize` (``A, B`` at an operating point) and
    :mod:`~mbgen.runtime.integration` (:class:`Trajectory`, the one result type of
    ``CompiledModel.integrate`` and ``simulate``).

How to add a back end
---------------------
1. ``run/<name>.py``: a :class:`~mbgen.runtime.base.ModelBase` subclass with its own
   ``backend`` label, an ``__init__`` that calls ``ModelBase.__init__(name, layout,
   defaults, outputs)`` (and sets ``reaction_names``, ``constraint_names``,
   ``dependent_coordinates`` when it has them), and ``_evaluate(output, t, x, p, r)``:
   check the arguments with ``self._x``, ``self._p``, ``self._r``, ``self._t``, report a
   failed evaluation with ``self._fail(status, ...)``.  Set ``batch_loop = True`` if
   ``_evaluate`` takes ``(k, n_x)`` batches in one call, and ``c_integrators`` if it
   runs generated C integrators.
2. ``run/__init__.py`` (``__all__`` below) and ``mbgen/__init__.py``: export the class.
3. ``verify/check.py``: compare it with the reference in ``check`` (the ``models`` of
   each output).
4. ``tests/runtime/test_base.py`` fails when a back end in ``mbgen.runtime`` is not a public
   ``mbgen`` name, has no ``_evaluate`` or reuses another's ``backend`` label.
"""

from .base import ACCESSORS, ModelBase
from .batch import BatchIntegration
from .compiled import CompiledModel
from .integration import Integration, Trajectory
from .lambdified import LambdifiedModel
from .python import PythonModel, python_model

__all__ = ["ModelBase", "ACCESSORS", "CompiledModel", "PythonModel", "python_model",
           "LambdifiedModel", "Trajectory", "Integration", "BatchIntegration"]
