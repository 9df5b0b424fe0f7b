"""Runtime models: the compiled C, the generated Python and the lambdified reference.

All three expose the same interface, so they can be compared and swapped:

``rhs(t, x, p=None, r=None)``
    ``dxdt``, shape ``(n_x,)``; works directly as ``solve_ivp(model.rhs, ...)``
    (bind parameters with ``args=(p,)`` or :meth:`ModelBase.bind`).
``mass_matrix``, ``forcing``, ``energy``
    The other outputs, when they were generated.

Every call returns a **new** array, validates ``t``, ``x``, ``p`` and ``r`` (a
wrong length is an :class:`~mbgen.errors.ArgumentError`, also a ``ValueError``; a
non-real dtype or a complex or string ``t`` an :class:`~mbgen.errors.ArgumentTypeError`,
also a ``TypeError``; non-contiguous, read-only and byte-swapped input is accepted) and raises :class:`~mbgen.errors.SingularMassMatrixError` or
:class:`~mbgen.errors.NonFiniteResultError` instead of returning NaNs.
"""

from __future__ import annotations

import numbers
import time
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np

from ..errors import (ArgumentError, ArgumentTypeError, IntegrationError, MbgenError,
                      NonFiniteResultError, SingularConstraintError, SingularMassMatrixError)
from .arguments import F64, real_number, real_vector, step_count, times
from ..symbolic.layout import Layout
from . import named
from .batch import batch_args, batch_times, evaluate, is_batch
from .batch import integrate as batch_integrate
from ..abi import Output, status_message

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
        if isinstance(x, Mapping):  # by name (mbgen.run.named)
            x = named.states(self, x)
        return self._vector(x, self.n_x, "state x", self.state_names)

    def _p(self, p) -> np.ndarray:
        if p is None:
            if self.default_parameters is None and self.n_p:
                raise ArgumentError(f"model {self.name!r} has no default for every parameter "
                                    f"{list(self.parameter_names)}; pass p")
            return self.default_parameters if self.n_p else np.zeros(0)
        if isinstance(p, Mapping):  # by name (mbgen.run.named)
            p = named.parameters(self, p)
        return self._vector(p, self.n_p, "parameters p", self.parameter_names)

    def _r(self, r) -> np.ndarray:
        if r is None:
            return self._zeros_r
        if isinstance(r, Mapping):  # by name (mbgen.run.named)
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
        raise MbgenError(f"{self.name}.{what}: error status {status} {where}")  # pragma: no cover

    # ------------------------------------------------------------------ outputs
    def _evaluate(self, output: Output, t, x, p, r) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def _require(self, output: Output) -> None:
        if output not in self.outputs:
            raise MbgenError(f"output {output.value!r} was not generated for {self.name!r}; "
                             f"compile with outputs including Output.{output.name}")

    def rhs(self, t, x, p=None, r=None) -> np.ndarray:
        """``dxdt = [G; M^-1 F]``, shape ``(n_x,)``."""
        return self._evaluate(Output.RHS, t, x, p, r)

    def mass_matrix(self, t, x, p=None, r=None) -> np.ndarray:
        """``M(q, t)``, shape ``(n_u, n_u)``."""
        return self._evaluate(Output.MASS_MATRIX, t, x, p, r)

    def forcing(self, t, x, p=None, r=None) -> np.ndarray:
        """``F(q, u, r, t)``, shape ``(n_u,)``."""
        return self._evaluate(Output.FORCING, t, x, p, r)

    def energy(self, t, x, p=None, r=None) -> np.ndarray:
        """``[T, V]``: kinetic and potential energy."""
        return self._evaluate(Output.ENERGY, t, x, p, r)

    def jacobian(self, t, x, p=None, r=None) -> np.ndarray:
        """``df/dx`` of the right-hand side, shape ``(n_x, n_x)`` (``jac=`` for solve_ivp)."""
        return self._evaluate(Output.JACOBIAN, t, x, p, r)

    def parameter_jacobian(self, t, x, p=None, r=None) -> np.ndarray:
        """``df/dp`` of the right-hand side, shape ``(n_x, n_p)``."""
        return self._evaluate(Output.PARAMETER_JACOBIAN, t, x, p, r)

    def time_derivative(self, t, x, p=None, r=None) -> np.ndarray:
        """``df/dt`` of the right-hand side (explicit time dependence), shape ``(n_x,)``."""
        return self._evaluate(Output.TIME_DERIVATIVE, t, x, p, r)

    def positions(self, t, x, p=None, r=None) -> np.ndarray:
        """Newtonian positions of the reported points, shape ``(k, 3)``."""
        return self._evaluate(Output.POSITIONS, t, x, p, r)

    def velocities(self, t, x, p=None, r=None) -> np.ndarray:
        """Newtonian velocities of the reported points, shape ``(k, 3)``."""
        return self._evaluate(Output.VELOCITIES, t, x, p, r)

    def input_jacobian(self, t, x, p=None, r=None) -> np.ndarray:
        """``df/dr`` of the right-hand side, shape ``(n_x, n_r)`` (``B`` of a linearisation)."""
        return self._evaluate(Output.INPUT_JACOBIAN, t, x, p, r)

    def constraint_forces(self, t, x, p=None, r=None) -> np.ndarray:
        """Constraint multipliers ``lambda`` of ``M u' = F + A^T lambda``, shape ``(m,)``.

        For a point constraint (``no_slip``, ``coincident``) the force on the body at
        the point along the frame axis; for a stated one the generalized force
        conjugate to it.  Order: the model's constraints.
        """
        return self._evaluate(Output.CONSTRAINT_FORCES, t, x, p, r)

    def holonomic(self, t, x, p=None, r=None) -> np.ndarray:
        """Residual ``f_h(q, t)`` of the configuration constraints, shape ``(m_h,)``."""
        return self._evaluate(Output.HOLONOMIC, t, x, p, r)

    def holonomic_jacobian(self, t, x, p=None, r=None) -> np.ndarray:
        """``df_h/dq``, shape ``(m_h, n_q)``."""
        return self._evaluate(Output.HOLONOMIC_JACOBIAN, t, x, p, r)

    def reactions(self, t, x, p=None, r=None) -> np.ndarray:
        """Joint reactions, shape ``(n_joints, 6)``: per joint (in :attr:`reaction_names`
        order, from the root) the force ``Fx, Fy, Fz`` and the moment ``Mx, My, Mz`` about the
        joint point that the parent exerts on the child, in the joint's frame
        (:attr:`reaction_frames`)."""
        return self._evaluate(Output.REACTIONS, t, x, p, r)

    def consistent(self, x, p=None, r=None, t: float = 0.0, *, tol: float = 1e-12,
                   max_iterations: int = 50) -> np.ndarray:
        """Complete ``x`` to a consistent state: solve the configuration constraints for
        the dependent coordinates (Newton), keeping every other entry of ``x``.

        Speeds need nothing: only the independent speeds are states; the
        dependent ones always come from the velocity constraints.

        Raises
        ------
        ConstraintError
            Newton did not converge (the message gives the residual), or the
            constraint Jacobian of the dependent coordinates is singular.
        """
        from ..errors import ConstraintError

        x = self._x(x).copy()
        tol = real_number(tol, "tol")
        if not tol >= 0:
            raise ArgumentError(f"tol must be a number >= 0; got {tol!r}")
        max_iterations = step_count(max_iterations, "max_iterations")
        if not self.dependent_coordinates:
            return x
        for o in (Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN):
            self._require(o)
        idx = [self.state_names.index(n) for n in self.dependent_coordinates]
        res = np.inf
        for _ in range(max_iterations):
            f = self._evaluate(Output.HOLONOMIC, t, x, p, r)
            res = float(np.max(np.abs(f)))
            if res <= tol * (1.0 + float(np.max(np.abs(x[idx])))):
                return x
            J = self._evaluate(Output.HOLONOMIC_JACOBIAN, t, x, p, r)[:, idx]
            try:
                x[idx] -= np.linalg.solve(J, f)
            except np.linalg.LinAlgError:
                raise ConstraintError(
                    f"{self.name}: the configuration constraints cannot be solved for "
                    f"{list(self.dependent_coordinates)} at {dict(zip(self.state_names, x))}: "
                    f"their Jacobian is singular (a locked configuration); start elsewhere"
                ) from None
            if not np.all(np.isfinite(x)):
                break
        raise ConstraintError(
            f"{self.name}: Newton on the configuration constraints did not converge for "
            f"{list(self.dependent_coordinates)} (residual {res:.3g} after {max_iterations} "
            f"iterations); give initial values of the dependent coordinates closer to a "
            f"solution")

    def bind(self, p=None, r=None, output: Output = Output.RHS, *,
             vectorized: bool = False) -> Callable:
        """``f(t, x)`` with parameters and inputs fixed (for ``solve_ivp(f, ...)``).

        ``vectorized=True``: ``f(t, y)`` takes and returns solve_ivp's ``(n_x, k)``
        columns (``solve_ivp(f, ..., vectorized=True)``), evaluated by the batch
        loop in C (compiled models) as ``rhs(t, y.T).T``.

        ``p``, ``r``: arrays or mappings by name (:mod:`mbgen.run.named`); ``r`` may
        also be a function ``r(t, x)`` (or an :class:`~mbgen.run.named.InputTable`),
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
                if self.backend != "c":  # no batch loop: one call per column
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


@dataclass(frozen=True)
class Integration:
    """A trajectory computed by a generated C integrator (:meth:`CompiledModel.integrate`).

    It reads like scipy's ``OdeResult``: ``t``, ``y`` (shape ``(n_x, k)``),
    ``success``, ``message``, ``status``, ``nfev``, ``njev``, ``nlu`` (also as
    ``result["y"]``), plus mbgen's own fields below (``x`` is ``y.T``, ``n_rhs``
    is ``nfev``, ...).

    Attributes
    ----------
    t : ndarray, shape (k,)
        The requested output times.
    x : ndarray, shape (k, n_x)
        The state at those times (row 0 is ``x0``); ``y`` is its transpose.
    method : str
        ``"dopri5"``, ``"rk4"`` or ``"rosenbrock"``.
    status : int
        The C status code (0: success; failures raise instead).
    n_steps, n_rejected, n_rhs, n_jac, n_lu : int
        Accepted and rejected steps, right-hand side and Jacobian calls, LU factorisations.
    wall_time : float
        Seconds spent in the C call (``time.perf_counter``).
    max_residual : float
        Constrained models: the largest configuration-constraint residual
        ``max|f_h|`` met after a step, before projection (NaN without
        configuration constraints).
    """

    t: np.ndarray
    x: np.ndarray
    method: str
    status: int
    n_steps: int
    n_rejected: int
    n_rhs: int
    n_jac: int
    n_lu: int
    wall_time: float
    max_residual: float = float("nan")

    # scipy.integrate.OdeResult's names -------------------------------------
    @property
    def y(self) -> np.ndarray:
        """States as columns, shape ``(n_x, k)`` (as ``solve_ivp``'s ``y``)."""
        return self.x.T

    @property
    def success(self) -> bool:
        return self.status == 0

    @property
    def message(self) -> str:
        return ("The solver successfully reached the end of the integration interval."
                if self.status == 0 else f"failed with status {self.status}")

    @property
    def nfev(self) -> int:
        return self.n_rhs

    @property
    def njev(self) -> int:
        return self.n_jac

    @property
    def nlu(self) -> int:
        return self.n_lu

    def __getitem__(self, key: str):
        try:
            return getattr(self, key)
        except AttributeError:
            raise KeyError(key) from None


class CompiledModel(ModelBase):
    """The generated C, compiled with cffi; see :func:`mbgen.compile`."""

    backend = "c"

    def __init__(self, rendered, module, layout: Layout, defaults, outputs):
        super().__init__(rendered.prefix, layout, defaults, outputs)
        self.rendered = rendered
        self.module = module
        self.reaction_names = tuple(n for n, _ in rendered.joints)
        self.reaction_frames = tuple(f for _, f in rendered.joints)
        self.constraint_names, self.dependent_coordinates = (rendered.constraints,
                                                             rendered.dependent)
        self.ffi, self.lib = module.ffi, module.lib
        self._calls = {Output(info.output): self._make_call(info) for info in rendered.functions}
        self._rhs = self._calls.get(Output.RHS) or (
            lambda t, x, p=None, r=None: self._evaluate(Output.RHS, t, x, p, r))

    def _make_call(self, info):
        """``call(t, x, p=None, r=None)`` for one generated function.

        The common case (a float ``t``, a contiguous float64 ``x`` of the right
        length, default or float64 ``p`` and ``r``) goes straight to C: the
        crossing from Python costs under a microsecond.  Anything else takes the
        validating path (named errors, conversions) or the batch loop.
        """
        ffi = self.ffi
        buf = ffi.from_buffer
        cfunc = getattr(self.lib, info.c_name)
        size, shape = info.out_size, info.out_shape
        has_p, has_r = "p" in info.args, "r" in info.args
        what = info.output
        check_x, check_p, check_r, as_t, fail = self._x, self._p, self._r, self._t, self._fail
        empty, ndarray, f64 = np.empty, np.ndarray, F64
        xshape, stride = (self.n_x,), (8,)
        reshape = len(shape) != 1


        model = self
        keep: list = []   # arrays behind the cached default buffers

        def default_buffer(array):
            keep.append(array)
            return buf("double[]", array)

        p_default = (default_buffer(self.default_parameters.copy())
                     if has_p and self.default_parameters is not None else None)
        r_default = default_buffer(self._zeros_r.copy()) if has_r else None

        def slow(t, x, p, r):
            x, p, r = named.arrays(model, x, p, r)  # mappings by name (a batch too)
            if not (type(x) is ndarray and x.ndim == 1) \
                    or p is not None and not (type(p) is ndarray and p.ndim == 1) \
                    or r is not None and not (type(r) is ndarray and r.ndim == 1):
                p_, r_ = (p if has_p else None), (r if has_r else None)  # others are ignored
                if is_batch(x, p_, r_):  # (k, n) arrays: one C loop over the k items
                    return evaluate(model, info, t, x, p_, r_)
            xa = check_x(x)
            out = empty(size)
            args = [as_t(t), buf("double[]", xa)]
            if has_p:
                args.append(buf("double[]", check_p(p)))
            if has_r:
                args.append(buf("double[]", check_r(r)))
            status = cfunc(*args, buf("double[]", out))
            if status:
                fail(status, what, t, xa)
            return out.reshape(shape) if reshape else out

        n_p, n_r = self.n_p, self.n_r
        last = [(None, None), (None, None)]   # the last p, r arrays and their buffers

        def vector(v, n, default, slot):
            if v is None and default is not None:
                return default
            if v.__class__ is ndarray and v.dtype is f64 and v.shape == (n,) and \
                    v.strides == stride:
                seen, b = last[slot]
                if v is not seen:   # a new array: a new buffer (the same array keeps its memory)
                    b = buf("double[]", v)
                    last[slot] = (v, b)
                return b
            return None

        def call(t, x, p=None, r=None):
            if not (t.__class__ is float and x.__class__ is ndarray and x.dtype is f64
                    and x.shape == xshape and x.strides == stride):
                return slow(t, x, p, r)
            pb = rb = None
            if has_p:
                pb = p_default if p is None else vector(p, n_p, None, 0)
                if pb is None:
                    return slow(t, x, p, r)
            if has_r:
                rb = r_default if r is None else vector(r, n_r, None, 1)
                if rb is None:
                    return slow(t, x, p, r)
            out = empty(size)
            if has_p and has_r:
                status = cfunc(t, buf("double[]", x), pb, rb, buf("double[]", out))
            elif has_p:
                status = cfunc(t, buf("double[]", x), pb, buf("double[]", out))
            elif has_r:
                status = cfunc(t, buf("double[]", x), rb, buf("double[]", out))
            else:
                status = cfunc(t, buf("double[]", x), buf("double[]", out))
            if status:
                fail(status, what, t, x)
            return out.reshape(shape) if reshape else out

        return call

    def _evaluate(self, output, t, x, p, r):
        try:
            call = self._calls[output]
        except KeyError:
            self._require(output)
            raise
        return call(t, x, p, r)

    def rhs(self, t, x, p=None, r=None) -> np.ndarray:
        """``dxdt = [G; u']``, shape ``(n_x,)`` (the fastest way in from Python)."""
        return self._rhs(t, x, p, r)

    def _input_table(self, table: "named.InputTable") -> "named.InputTable":
        """``table`` in this model's input order, if its C integrators take tables."""
        if not self.n_r:
            raise ValueError(f"{self.name!r} has no inputs; an InputTable has nothing to drive")
        if "n_table" not in dict(self.ffi.typeof(f"{self.rendered.prefix}_options").fields):
            raise MbgenError(f"the C integrators of {self.name!r} were generated without "
                             f"input tables (an older mbgen); regenerate the code")
        return table.for_model(self)

    #: Largest configuration-constraint residual ``max|f_h(x0)|`` (relative to
    #: ``1 + max|q|``) that :meth:`integrate` accepts at the start.
    START_RESIDUAL_TOL = 1e-8

    def _check_consistent_start(self, t0, x0, p, r) -> None:
        """Refuse an initial state off the configuration constraints (ConstraintError)."""
        from ..errors import ConstraintError

        res = float(np.max(np.abs(self.holonomic(float(t0), x0, p, r))))
        scale = 1.0 + float(np.max(np.abs(x0[:self.layout.n_q]))) if self.layout.n_q else 1.0
        if not res <= self.START_RESIDUAL_TOL * scale:
            raise ConstraintError(
                f"{self.name}: the initial state violates the configuration constraints "
                f"(residual {res:.3g}); complete its dependent coordinates "
                f"({', '.join(self.dependent_coordinates)}) with model.consistent(x0) first "
                f"(mbgen.run.simulate.simulate does this), or pass project=False to integrate "
                f"from it as given")

    def integrate(self, method, t_eval, x0, p=None, r=None, *, rtol: float = 1e-6,
                  atol: float = 1e-9, h: float | None = None, h_max: float = 0.0,
                  max_steps: int = 0, on_failure: str = "raise", project: bool = True):
        """Run a generated C integrator over ``t_eval`` (no Python per step).

        Parameters
        ----------
        method : Output or str
            ``"dopri5"`` (Dormand-Prince 5(4), as scipy's RK45), ``"rk4"`` (fixed
            step ``h``) or ``"rosenbrock"`` (stiff, Rodas4 with the compiled
            Jacobian); it must have been generated (``mbgen.compile(...,
            outputs={"dopri5"})``).
        t_eval : array_like, shape (k,)
            Output times, strictly increasing; ``t_eval[0]`` is the initial time.
        x0, p, r
            Initial state, parameters (default: the model's) and inputs (held constant),
            as arrays or mappings by name (:mod:`mbgen.run.named`).  ``r`` may also be an
            :class:`~mbgen.run.named.InputTable`: a piecewise-linear ``r(t)`` that the C
            integrator interpolates at every stage time.
            A 2-D ``x0`` ``(k, n_x)``, ``p`` ``(k, n_p)`` or ``r`` ``(k, n_r)`` is a
            batch (1-D ones are shared by every member): ``k`` trajectories in one C
            loop, returned as a :class:`~mbgen.run.batch.BatchIntegration`.
        rtol, atol : float
            Error tolerances of the adaptive methods (as solve_ivp).
        h : float, optional
            The step of ``rk4`` (required); the first step of the adaptive methods.
        h_max : float
            Largest step (0: unbounded).
        max_steps : int
            Limit on attempted steps (0: 1000000).
        on_failure : str
            Batches only: ``"raise"`` (the first failed member raises) or
            ``"record"`` (statuses and messages are returned per member).
        project : bool
            Models with configuration constraints: project the dependent
            coordinates back onto the constraints after every step (``False``
            only records the drift, ``Integration.max_residual``).

        Raises
        ------
        MbgenError
            The integrator was not generated.
        ArgumentError
            Bad ``t_eval``, ``x0``, tolerances, steps or step limit (ArgumentTypeError, also
            a ``TypeError``, for a wrong type: a complex or string number, ``None``).
        IntegrationError
            The C integrator failed (step too small, step limit, singular
            matrix, mass matrix not positive definite, non-finite result).
        """
        try:
            output = method if isinstance(method, Output) else Output(str(method).lower())
        except ValueError:
            output = None
        if output is None or not output.is_integrator:
            raise ArgumentError(f"{method!r:.60} is not an integrator; choose from 'dopri5', "
                                f"'rk4', 'rosenbrock'")
        self._require(output)
        t = times(t_eval)
        x0, p, r = named.arrays(self, x0, p, r)
        table = None
        if isinstance(r, named.InputTable):
            table, r = self._input_table(r), None
        xa = None if is_batch(x0, p, r) else self._x(x0)
        if xa is not None and not np.all(np.isfinite(xa)):
            raise ArgumentError(f"initial state x0 must be finite; got {xa.tolist()}")
        if output is Output.RK4:
            if h is None:
                raise ArgumentError("the rk4 integrator takes a fixed step: pass h > 0")
        rtol, atol = real_number(rtol, "rtol"), real_number(atol, "atol")
        h_max = real_number(h_max, "h_max")
        h0 = 0.0 if h is None else real_number(h, "h")
        for name, value in (("rtol", rtol), ("atol", atol), ("h", h0)):
            if not (np.isfinite(value) and value >= 0):
                raise ArgumentError(f"{name} must be a finite number >= 0; got {value!r}")
        if h is not None and not h0 > 0:
            raise ArgumentError(f"h must be > 0; got {h0!r}")
        if not h_max >= 0:
            raise ArgumentError(f"h_max must be >= 0 (0: unbounded); got {h_max!r}")
        max_steps = step_count(max_steps, limit=2**(8 * self.ffi.sizeof("long") - 1) - 1)

        if xa is None:
            if table is not None:
                raise ValueError("an InputTable drives one trajectory; integrate the batch "
                                 "members one by one, or give constant inputs r")
            return batch_integrate(self, output, t, x0, p, r, rtol=rtol, atol=atol, h0=h0,
                                   h_max=h_max, max_steps=max_steps, on_failure=on_failure)
        if project and self.dependent_coordinates and Output.HOLONOMIC in self.outputs:
            self._check_consistent_start(t[0], xa, p, r)
        ffi, prefix = self.ffi, self.rendered.prefix
        buf = ffi.from_buffer
        settings = {"rtol": rtol, "atol": atol, "h0": h0, "h_max": h_max,
                    "max_steps": int(max_steps)}
        projects = "no_projection" in dict(ffi.typeof(f"{prefix}_options").fields)
        if projects:
            settings["no_projection"] = 0 if project else 1
        if table is not None:
            settings.update(n_table=table.times.size, table_t=buf("double[]", table.times),
                            table_r=buf("double[]", table.values))
        opt = ffi.new(f"{prefix}_options *", settings)
        stats = ffi.new(f"{prefix}_stats *")
        x_out = np.empty((t.size, self.n_x))
        args = [buf("double[]", xa)]
        if self.n_p:
            args.append(buf("double[]", self._p(p)))
        if self.n_r:
            args.append(buf("double[]", self._r(r)))
        cfunc = getattr(self.lib, f"{prefix}_{output.value}")
        work = (ffi.new(f"{prefix}_rosenbrock_work *"),) if output is Output.ROSENBROCK else ()
        start = time.perf_counter()
        status = cfunc(*args, t.size, buf("double[]", t), buf("double[]", x_out), opt, stats,
                       *work)
        wall = time.perf_counter() - start
        if status:
            raise IntegrationError(
                f"{self.name}.integrate({output.value!r}) failed with status {status} "
                f"({status_message(prefix, status)}) at t_reached={stats.t_reached!r} after "
                f"{stats.n_steps} steps ({stats.n_rejected} rejected, {stats.n_rhs} RHS calls)",
                status, float(stats.t_reached))
        return Integration(t, x_out, output.value, int(status), int(stats.n_steps),
                           int(stats.n_rejected), int(stats.n_rhs), int(stats.n_jac),
                           int(stats.n_lu), wall,
                           float(stats.max_residual) if projects else float("nan"))

    def _repr_html_(self) -> str:
        """Notebook summary: ABI sizes and names, outputs, operation counts."""
        from ..summary import compiled_html

        return compiled_html(self)


class PythonModel(ModelBase):
    """The generated Python module (``<prefix>.py``) behind the same interface."""

    backend = "python"

    def __init__(self, rendered, module, layout: Layout, defaults, outputs):
        super().__init__(rendered.prefix, layout, defaults, outputs)
        self.rendered = rendered
        self.module = module
        self.reaction_names = tuple(n for n, _ in rendered.joints)
        self.reaction_frames = tuple(f for _, f in rendered.joints)
        self.constraint_names, self.dependent_coordinates = (rendered.constraints,
                                                             rendered.dependent)
        self._args = {Output(info.output): info.args for info in rendered.functions}

    def _evaluate(self, output, t, x, p, r):
        self._require(output)
        fn = getattr(self.module, output.value)
        takes = self._args[output]
        p_, r_ = (p if "p" in takes else None), (r if "r" in takes else None)
        if not all(v is None or type(v) is np.ndarray and v.ndim == 1 for v in (x, p_, r_)):
            if is_batch(x, p_, r_):  # as the C batch loop: item by item, the first failure raises
                return self._batch(output, fn, t, x, p_, r_)
        xa = self._x(x)
        args = [self._t(t), xa]
        if "p" in self._args[output]:
            args.append(self._p(p))
        if "r" in self._args[output]:
            args.append(self._r(r))
        return self._call(fn, output, args, t, xa)

    def _call(self, fn, output, args, t, xa):
        try:
            return fn(*args)
        except self.module.NotPositiveDefinite:
            self._fail(1, output.value, t, xa)
        except self.module.NonFinite:
            self._fail(2, output.value, t, xa)
        except getattr(self.module, "ConstraintSingular", ()):
            self._fail(7, output.value, t, xa)

    def _batch(self, output, fn, t, x, p, r):
        k, (xa, xs), (pa, ps), (ra, rs) = batch_args(self, x, p, r)
        ta, ts = batch_times(self, t, k)
        info = next(f for f in self.rendered.functions if Output(f.output) is output)
        out = np.empty((k,) + tuple(info.out_shape))
        for i in range(k):
            args = [float(ta[i * ts]), xa[i * (xs > 0)]]
            if "p" in self._args[output]:
                args.append(pa[i * (ps > 0)])
            if "r" in self._args[output]:
                args.append(ra[i * (rs > 0)])
            try:
                out[i] = self._call(fn, output, args, args[0], args[1])
            except MbgenError as exc:
                raise type(exc)(f"batch item {i} of {k}: {exc}") from None
        return out
