"""What every back end shares: argument checks, parameter defaults, the outputs, binding.

:class:`ModelBase` is the interface of the three back ends (:mod:`mbgen.runtime.compiled`,
:mod:`mbgen.runtime.python`, :mod:`mbgen.runtime.lambdified`).  A back end implements
``_evaluate(output, t, x, p, r)``; the output accessors (``rhs``, ``mass_matrix``, ...,
one per expression output, their docstrings from the outputs' rows of
:data:`mbgen.abi.OUTPUT_INFO`), :meth:`ModelBase.consistent` and :meth:`ModelBase.bind`
are built on it.

Every call returns a **new** array, validates ``t``, ``x``, ``p`` and ``r`` (a
wrong length is an :class:`~mbgen.errors.ArgumentError`, also a ``ValueError``; a
non-real dtype or a complex or string ``t`` an :class:`~mbgen.errors.ArgumentTypeError`,
also a ``TypeError``; non-contiguous, read-only and byte-swapped input is accepted) and
raises :class:`~mbgen.errors.SingularMassMatrixError` or
:class:`~mbgen.errors.NonFiniteResultError` instead of returning NaNs.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np

from ..abi import OUTPUT_INFO, Output, OutputInfo
from ..errors import (
    ArgumentError,
    ConstraintError,
    MbgenError,
    NonFiniteResultError,
    SingularConstraintError,
    SingularMassMatrixError,
)
from ..symbolic.layout import Layout
from . import named
from .arguments import F64, real_number, real_vector, step_count, tolerance

#: Rounding allowance of a constraint residual, in units of the double epsilon (see
#: :func:`on_loop_bound`): the few roundings of a sum, a sine and a product in each term.
ROUNDING = 8.0


def on_loop_bound(J, q, tol: float) -> np.ndarray:
    """Largest residual of each configuration constraint ``f_h(q) = 0`` still taken as zero
    at coordinates ``q`` (``(..., n_q)``), from ``J = df_h/dq`` there (``(..., m, n_q)``)::

        bound_i = tol * s_i + ROUNDING * eps * sum_j |J_ij| |q_j|,   s_i = sum_j |J_ij|

    A residual is in its constraint's own units -- a length for a loop closed by coincident
    points -- and ``q`` is not: an angle's size says nothing of the mechanism's.  The row
    sum ``s_i`` is: the change of ``f_i`` when every coordinate moves by one unit, for an
    angle the lever arms (the links' lengths at this configuration), for a length 1.  So
    ``tol`` is relative to the mechanism's size.  The second term is the floor that
    rounding allows: ``q_j`` is known to ``eps |q_j|`` (and so is ``sin q_j`` or ``q_1 +
    q_2``), which moves ``f_i`` by ``|J_ij| eps |q_j|`` -- a dependent angle of 1e13 rad
    on links of length 2 cannot close the loop better than about 1e-2, and no start with
    a residual of 3.2 is taken for closed.  (The former ``tol (1 + max|q|)`` took that
    one: an angle's size was read as a length.)  A row that does not move at all here (a
    locked configuration) is held to the largest row's scale; a NaN anywhere refuses.
    """
    A = np.abs(np.asarray(J, dtype=float))
    s = A.sum(axis=-1)
    s = np.where(s > 0, s, s.max(axis=-1, keepdims=True))
    q = np.abs(np.asarray(q, dtype=float))
    return tol * s + ROUNDING * np.finfo(float).eps * (A @ q[..., None])[..., 0]


def accessor_doc(info: OutputInfo) -> str:
    """The accessor's docstring from the output's row: what it computes, the note, its shape."""
    note = f"{info.note}.\n\n" if info.note else ""
    return f"{info.doc}.\n\n{note}Returns\n-------\nndarray, shape {info.shape_text}\n"


def _accessor(output: Output) -> Callable[..., np.ndarray]:
    """The method ``model.<output>(t, x, p=None, r=None)``: ``_evaluate`` of ``output``."""
    def accessor(self, t, x, p=None, r=None) -> np.ndarray:
        return self._evaluate(output, t, x, p, r)

    accessor.__name__ = output.value
    accessor.__qualname__ = f"ModelBase.{output.value}"
    accessor.__doc__ = accessor_doc(OUTPUT_INFO[output])
    return accessor


class ModelBase:
    """Shared validation, parameter defaults and binding.

    Attributes
    ----------
    name : str
    layout : Layout
    state_names, parameter_names, input_names : tuple of str
    default_parameters : ndarray, shape (n_p,), or None when not every default is known
    outputs : tuple of Output
    """

    backend = "base"
    #: ``_evaluate`` takes a ``(k, n_x)`` batch of states in one call (the C batch loop).
    batch_loop = False

    def __init__(self, name: str, layout: Layout, defaults: Mapping[str, float] | None,
                 outputs: Sequence[Output]):
        self.name = name
        self.layout = layout
        self.state_names = layout.state_names
        self.parameter_names = layout.parameter_names
        self.input_names = layout.input_names
        self.n_x, self.n_p, self.n_r = layout.n_x, layout.n_p, layout.n_r
        defaults = dict(defaults or {})
        values = [defaults.get(n) for n in self.parameter_names]
        self.default_parameters = (np.array(values, dtype=float)
                                   if all(v is not None for v in values) else None)
        self.parameter_defaults = {n: float(v) for n, v in zip(self.parameter_names, values)
                                   if v is not None}
        self.outputs = tuple(outputs)
        self.reaction_names: tuple[str, ...] = ()
        self.reaction_frames: tuple[str, ...] = ()
        self.constraint_names: tuple[str, ...] = ()
        self.dependent_coordinates: tuple[str, ...] = ()
        self._zeros_r = np.zeros(self.n_r)

    # -------------------------------------------------------------- validation
    @staticmethod
    def _vector(value, n: int, what: str, names) -> np.ndarray:
        if (type(value) is np.ndarray and value.dtype is F64 and value.shape == (n,)
                and value.flags.c_contiguous):
            return value
        return real_vector(value, n, what, names)

    def _x(self, x) -> np.ndarray:
        if isinstance(x, Mapping):  # by name (mbgen.runtime.named)
            x = named.states(self, x)
        return self._vector(x, self.n_x, "state x", self.state_names)

    def _p(self, p) -> np.ndarray:
        if p is None:
            if self.default_parameters is None and self.n_p:
                raise ArgumentError(f"model {self.name!r} has no default for every parameter "
                                    f"{list(self.parameter_names)}; pass p")
            return self.default_parameters if self.n_p else np.zeros(0)
        if isinstance(p, Mapping):  # by name (mbgen.runtime.named)
            p = named.parameters(self, p)
        return self._vector(p, self.n_p, "parameters p", self.parameter_names)

    def _r(self, r) -> np.ndarray:
        if r is None:
            return self._zeros_r
        if isinstance(r, Mapping):  # by name (mbgen.runtime.named)
            r = named.inputs(self, r)
        return self._vector(r, self.n_r, "inputs r", self.input_names)

    @staticmethod
    def _t(t) -> float:
        return real_number(t, "time t")

    def _fail(self, status: int, what: str, t, x) -> None:
        where = f"at t={t!r}, x={dict(zip(self.state_names, np.asarray(x).tolist()))}"
        if status == 1:
            raise SingularMassMatrixError(
                f"{self.name}.{what}: the mass matrix is not positive definite {where}; "
                f"check parameters (masses, inertias > 0) and avoid singular configurations")
        if status == 2:
            raise NonFiniteResultError(f"{self.name}.{what}: result is NaN or infinite {where}")
        if status == 7:
            raise SingularConstraintError(
                f"{self.name}.{what}: the constraint Jacobian of the dependent speeds is singular "
                f"{where}: a locked or singular configuration (a four-bar at its dead point, ...); "
                f"choose other dependent speeds or avoid the configuration")
        if status == 9:
            raise SingularConstraintError(
                f"{self.name}.{what}: the contacts' Delassus matrix J M^-1 J^T is singular "
                f"{where}: the contact forces are undetermined (two contacts on one point, a "
                f"leg stretched straight); drop a contact or avoid the configuration")
        raise MbgenError(f"{self.name}.{what}: error status {status} {where}")  # pragma: no cover

    @property
    def c_integrators(self) -> tuple[Output, ...]:
        """The generated C integrators :meth:`CompiledModel.integrate` can run here (only a
        compiled model has any)."""
        return ()

    # ------------------------------------------------------------------ outputs
    # One accessor per expression output, named here so that IDEs and type checkers see it;
    # what it computes and its shape are the output's row (tests/runtime/test_base.py
    # checks that every output has its line).
    rhs = _accessor(Output.RHS)
    mass_matrix = _accessor(Output.MASS_MATRIX)
    forcing = _accessor(Output.FORCING)
    energy = _accessor(Output.ENERGY)
    jacobian = _accessor(Output.JACOBIAN)
    parameter_jacobian = _accessor(Output.PARAMETER_JACOBIAN)
    time_derivative = _accessor(Output.TIME_DERIVATIVE)
    positions = _accessor(Output.POSITIONS)
    velocities = _accessor(Output.VELOCITIES)
    reactions = _accessor(Output.REACTIONS)
    input_jacobian = _accessor(Output.INPUT_JACOBIAN)
    constraint_forces = _accessor(Output.CONSTRAINT_FORCES)
    holonomic = _accessor(Output.HOLONOMIC)
    holonomic_jacobian = _accessor(Output.HOLONOMIC_JACOBIAN)
    contact_jacobian = _accessor(Output.CONTACT_JACOBIAN)
    tangent_jacobian = _accessor(Output.TANGENT_JACOBIAN)

    def _evaluate(self, output: Output, t, x, p, r) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def _require(self, output: Output) -> None:
        if output not in self.outputs:
            raise MbgenError(f"output {output.value!r} was not generated for {self.name!r}; "
                             f"compile with outputs including Output.{output.name}")

    def consistent(self, x, p=None, r=None, t: float = 0.0, *, tol: float = 1e-12,
                   max_iterations: int = 50) -> np.ndarray:
        """Complete ``x`` to a consistent state: solve the configuration constraints for
        the dependent coordinates (Newton), keeping every other entry of ``x``.

        Speeds need nothing: only the independent speeds are states; the
        dependent ones always come from the velocity constraints.

        The result's residual is at most :func:`on_loop_bound` ``(J, q, tol)`` per
        constraint: ``tol`` times the constraint's own scale (the row sums of
        ``J = df_h/dq``: lengths for a loop of links) plus the floor rounding allows at
        ``q``, both taken at the given ``x`` (fixed before the first step: near a dead
        point Newton's steps are huge, and a tolerance that grew with the iterate once
        accepted a state far off the loop).

        Raises
        ------
        ArgumentError
            ``tol`` is not a finite number >= 0.
        ConstraintError
            Newton did not converge within ``max_iterations`` (the message gives the
            residual), or the constraint Jacobian of the dependent coordinates is
            singular.
        """
        x = self._x(x).copy()
        tol = tolerance(tol, "tol")
        max_iterations = step_count(max_iterations, "max_iterations")
        if not self.dependent_coordinates:
            return x
        for o in (Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN):
            self._require(o)
        idx = [self.state_names.index(n) for n in self.dependent_coordinates]
        n_q = self.layout.n_q
        bound = on_loop_bound(self._evaluate(Output.HOLONOMIC_JACOBIAN, t, x, p, r),
                              x[:n_q], tol)
        res = allowed = np.inf
        for iteration in range(max_iterations + 1):
            f = self._evaluate(Output.HOLONOMIC, t, x, p, r)
            if np.all(np.abs(f) <= bound):        # the residual of the very state returned
                return x
            worst = int(np.argmax(np.abs(f) - bound))  # a NaN's row, if any
            res, allowed = float(np.max(np.abs(f))), float(bound[worst])
            if iteration == max_iterations or not np.isfinite(res):
                break
            J = self._evaluate(Output.HOLONOMIC_JACOBIAN, t, x, p, r)[:, idx]
            try:
                x[idx] -= np.linalg.solve(J, f)
            except np.linalg.LinAlgError:
                raise ConstraintError(
                    f"{self.name}: the configuration constraints cannot be solved for "
                    f"{list(self.dependent_coordinates)} at {dict(zip(self.state_names, x))}: "
                    f"their Jacobian is singular (a locked configuration); start elsewhere"
                ) from None
        raise ConstraintError(
            f"{self.name}: Newton on the configuration constraints did not converge for "
            f"{list(self.dependent_coordinates)} (residual {res:.3g} > {allowed:.3g} after "
            f"{iteration} iterations); give initial values of the dependent coordinates "
            f"closer to a solution")

    def bind(self, p=None, r=None, output: Output = Output.RHS, *,
             vectorized: bool = False) -> Callable:
        """``f(t, x)`` with parameters and inputs fixed (for ``solve_ivp(f, ...)``).

        ``vectorized=True``: ``f(t, y)`` takes and returns solve_ivp's ``(n_x, k)``
        columns (``solve_ivp(f, ..., vectorized=True)``), evaluated by the batch
        loop in C (compiled models) as ``rhs(t, y.T).T``.

        ``p``, ``r``: arrays or mappings by name (:mod:`mbgen.runtime.named`); ``r`` may
        also be a function ``r(t, x)`` (or an :class:`~mbgen.runtime.named.InputTable`),
        called at every evaluation.
        """
        output = Output(output)
        self._require(output)
        if callable(r) and not vectorized:
            return named.driven(self, output, self._p(p).copy(), r)
        p_arr, r_arr = self._p(p).copy(), self._r(r).copy()

        if vectorized:
            def f(t, y):
                y = np.asarray(y)
                if y.ndim == 1:
                    return self._evaluate(output, t, y, p_arr, r_arr)
                if not self.batch_loop:  # one call per column
                    return np.stack([self._evaluate(output, t, col, p_arr, r_arr)
                                     for col in y.T], axis=-1)
                return self._evaluate(output, t, y.T, p_arr, r_arr).T
            return f

        def f(t, x):
            return self._evaluate(output, t, x, p_arr, r_arr)

        return f

    def __repr__(self) -> str:
        return (f"<{type(self).__name__} {self.name!r}: x={list(self.state_names)}, "
                f"p={list(self.parameter_names)}, outputs={[o.value for o in self.outputs]}>")


#: The docstring of every accessor ``model.<output>(t, x, p=None, r=None)``, by output.
ACCESSORS: dict[Output, str] = {o: accessor_doc(info) for o, info in OUTPUT_INFO.items()}


class GeneratedModel(ModelBase):
    """A back end over rendered code (the C extension or the generated Python module).

    ``rendered`` (:class:`~mbgen.abi.Rendered`) names the joints, constraints and
    dependent coordinates; ``module`` is what was loaded from it.
    """

    def __init__(self, rendered, module, layout: Layout, defaults, outputs):
        super().__init__(rendered.prefix, layout, defaults, outputs)
        self.rendered = rendered
        self.module = module
        self.reaction_names = tuple(n for n, _ in rendered.joints)
        self.reaction_frames = tuple(f for _, f in rendered.joints)
        self.constraint_names = rendered.constraints
        self.dependent_coordinates = rendered.dependent


__all__ = ["ModelBase", "ACCESSORS", "GeneratedModel"]
