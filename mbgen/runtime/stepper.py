r"""The step API of a compiled model, driven from Python (for tests and prototyping).

The C side (``<prefix>_<method>_init`` / ``_step`` and the memory struct) is
rendered by :mod:`mbgen.codegen.targets.step`; see there for what a step does.

The numbers ``t0``, ``rtol``, ``atol`` and ``h`` are checked for their type here, as by
the rest of the runtime (:func:`mbgen.runtime.arguments.real_number`: a string, ``None`` or a
complex is an :class:`~mbgen.errors.ArgumentTypeError` naming the argument, never parsed
or passed on); their values (finite, positive) are the C functions' to check, so the C
checks are what a value error exercises (``IntegrationError``, ``BAD_ARGUMENT``).
"""

from __future__ import annotations

import numpy as np

from ..abi import status_name
from ..errors import IntegrationError, MbgenError
from ..integrators import DEFAULT_ATOL, DEFAULT_RTOL
from .arguments import real_number


class Stepper:
    """The step API of a compiled model, driven from Python (for tests and prototyping).

    ``Stepper(model, "dopri5", t0, x0, rtol=1e-6, atol=1e-9)``; then
    ``step(h, p=None, r=None)`` advances ``t``, ``x`` by ``h``.  The memory is one
    ``<prefix>_<method>_memory`` owned by this object.  A model generated from a scene with
    ``saturate=True`` clamps ``r`` to its input bounds in C (:attr:`n_saturated` counts).
    """

    def __init__(self, model, method: str, t0: float, x0, *, rtol: float = DEFAULT_RTOL,
                 atol: float = DEFAULT_ATOL):
        rendered = model.rendered
        if method not in rendered.step_methods:
            raise MbgenError(f"{model.name!r} has no {method!r} step function (step methods: "
                             f"{list(rendered.step_methods) or 'none'}); compile with "
                             f"targets=Targets(step=True)")
        t0, rtol, atol = (real_number(v, name) for v, name in ((t0, "t0"), (rtol, "rtol"),
                                                                (atol, "atol")))
        self.model, self.method = model, method
        ffi, lib = model.ffi, model.lib
        self.memory = ffi.new(f"{rendered.prefix}_{method}_memory *")
        self._step = getattr(lib, f"{rendered.prefix}_{method}_step")
        x0 = model._x(x0)
        status = getattr(lib, f"{rendered.prefix}_{method}_init")(
            self.memory, t0, ffi.from_buffer("double[]", x0), rtol, atol)
        self._check(status, "init")

    def _check(self, status: int, what: str) -> None:
        if status:
            raise IntegrationError(f"{self.model.name}_{self.method}_{what} failed with status "
                                   f"{status} ({status_name(status)}) at t = {self.t!r}",
                                   status, self.t)

    @property
    def t(self) -> float:
        return float(self.memory.t)

    @property
    def x(self):
        """The state, a new float64 array (a copy of the C memory's ``x``)."""
        return np.frombuffer(self.model.ffi.buffer(self.memory.x), np.float64,
                             self.model.n_x).copy()

    @property
    def max_residual(self) -> float:
        """Largest constraint residual met before projecting (NaN without projection)."""
        return float(getattr(self.memory, "max_residual", float("nan")))

    @property
    def n_saturated(self) -> int:
        """Inputs the steps clamped to their bounds since init, summed over the calls (0 when
        the model was not generated with ``Scene(saturate=True)``)."""
        return int(getattr(self.memory, "n_saturated", 0))

    @property
    def h(self) -> float:
        """The adaptive methods' next step size (0 before the first step)."""
        return float(getattr(self.memory, "h", 0.0))

    def step(self, h: float, p=None, r=None):
        """Advance by ``h`` with parameters ``p`` and inputs ``r`` (held over the step);
        returns ``x``."""
        buf = self.model.ffi.from_buffer
        args = [self.memory, real_number(h, "h")]
        if self.model.n_p:
            args.append(buf("double[]", self.model._p(p)))
        if self.model.n_r:
            args.append(buf("double[]", self.model._r(r)))
        self._check(self._step(*args), "step")
        return self.x


__all__ = ["Stepper"]
