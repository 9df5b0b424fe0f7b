"""Runtime models: the compiled C, the generated Python and the lambdified reference.

All three expose the same interface, so they can be compared and swapped:

``rhs(t, x, p=None, r=None)``
    ``dxdt``, shape ``(n_x,)``; works directly as ``solve_ivp(model.rhs, ...)``
    (bind parameters with ``args=(p,)`` or :meth:`ModelBase.bind`).
``mass_matrix``, ``forcing``, ``energy``
    The other outputs, when they were generated.

Every call returns a **new** array, validates ``x``, ``p`` and ``r`` (a wrong
length is a ``ValueError``, a non-real dtype a ``TypeError``; non-contiguous
input is accepted) and raises :class:`~mbgen.errors.SingularMassMatrixError` or
:class:`~mbgen.errors.NonFiniteResultError` instead of returning NaNs.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np

from .errors import IntegrationError, MbgenError, NonFiniteResultError, SingularMassMatrixError
from .layout import Layout
from .optimize import Output
from .render import INTEGRATOR_STATUS_CODES, STATUS_CODES

F64 = np.dtype(np.float64)


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
        self.outputs = tuple(outputs)
        self._zeros_r = np.zeros(self.n_r)

    # -------------------------------------------------------------- validation
    @staticmethod
    def _vector(value, n: int, what: str, names) -> np.ndarray:
        if (type(value) is np.ndarray and value.dtype is F64 and value.shape == (n,)
                and value.flags.c_contiguous):
            return value
        try:
            a = np.asarray(value)
        except Exception as exc:  # ragged lists and the like
            raise ValueError(f"{what} must be a 1-D array of {n} numbers {list(names)}: {exc}") from None
        if a.dtype.kind not in "iuf":
            raise TypeError(f"{what} must hold real numbers (float64); got dtype {a.dtype}")
        if a.shape != (n,):
            raise ValueError(f"{what} must have shape ({n},) for {list(names)}; got shape {a.shape}")
        return np.ascontiguousarray(a, dtype=F64)

    def _x(self, x) -> np.ndarray:
        return self._vector(x, self.n_x, "state x", self.state_names)

    def _p(self, p) -> np.ndarray:
        if p is None:
            if self.default_parameters is None and self.n_p:
                raise ValueError(f"model {self.name!r} has no default for every parameter "
                                 f"{list(self.parameter_names)}; pass p")
            return self.default_parameters if self.n_p else np.zeros(0)
        return self._vector(p, self.n_p, "parameters p", self.parameter_names)

    def _r(self, r) -> np.ndarray:
        if r is None:
            return self._zeros_r
        return self._vector(r, self.n_r, "inputs r", self.input_names)

    @staticmethod
    def _t(t) -> float:
        try:
            return float(t)
        except (TypeError, ValueError):
            raise TypeError(f"time t must be a real number, got {t!r}") from None

    def _fail(self, status: int, what: str, t, x) -> None:
        where = f"at t={t!r}, x={dict(zip(self.state_names, np.asarray(x).tolist()))}"
        if status == 1:
            raise SingularMassMatrixError(
                f"{self.name}.{what}: the mass matrix is not positive definite {where}; "
                f"check parameters (masses, inertias > 0) and avoid singular configurations")
        if status == 2:
            raise NonFiniteResultError(f"{self.name}.{what}: result is NaN or infinite {where}")
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

    def bind(self, p=None, r=None, output: Output = Output.RHS, *,
             vectorized: bool = False) -> Callable:
        """``f(t, x)`` with parameters and inputs fixed (for ``solve_ivp(f, ...)``).

        ``vectorized=True``: ``f(t, y)`` takes and returns solve_ivp's ``(n_x, k)``
        columns (``solve_ivp(f, ..., vectorized=True)``), evaluated by the batch
        loop in C (compiled models) as ``rhs(t, y.T).T``.
        """
        output = Output(output)
        self._require(output)
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

    Attributes
    ----------
    t : ndarray, shape (k,)
        The requested output times.
    x : ndarray, shape (k, n_x)
        The state at those times (row 0 is ``x0``).
    method : str
        ``"dopri5"``, ``"rk4"`` or ``"rosenbrock"``.
    status : int
        The C status code (0: success; failures raise instead).
    n_steps, n_rejected, n_rhs, n_jac, n_lu : int
        Accepted and rejected steps, right-hand side and Jacobian calls, LU factorisations.
    wall_time : float
        Seconds spent in the C call (``time.perf_counter``).
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


class CompiledModel(ModelBase):
    """The generated C, compiled with cffi; see :func:`mbgen.compile`."""

    backend = "c"

    def __init__(self, rendered, module, layout: Layout, defaults, outputs):
        super().__init__(rendered.prefix, layout, defaults, outputs)
        self.rendered = rendered
        self.module = module
        self.ffi, self.lib = module.ffi, module.lib
        self._calls = {Output(info.output): self._make_call(info) for info in rendered.functions}

    def _make_call(self, info):
        ffi = self.ffi
        buf = ffi.from_buffer
        cfunc = getattr(self.lib, info.c_name)
        size, shape = info.out_size, info.out_shape
        has_p, has_r = "p" in info.args, "r" in info.args
        what = info.output
        check_x, check_p, check_r, as_t, fail = self._x, self._p, self._r, self._t, self._fail

        from .targets.batch import evaluate, is_batch

        model = self

        def call(t, x, p, r):
            if not (type(x) is np.ndarray and x.ndim == 1) \
                    or p is not None and not (type(p) is np.ndarray and p.ndim == 1) \
                    or r is not None and not (type(r) is np.ndarray and r.ndim == 1):
                if is_batch(x, p, r):  # (k, n) arrays: one C loop over the k items
                    return evaluate(model, info, t, x, p, r)
            xa = check_x(x)
            out = np.empty(size)
            if has_p and has_r:
                status = cfunc(as_t(t), buf("double[]", xa), buf("double[]", check_p(p)),
                               buf("double[]", check_r(r)), buf("double[]", out))
            elif has_p:
                status = cfunc(as_t(t), buf("double[]", xa), buf("double[]", check_p(p)),
                               buf("double[]", out))
            elif has_r:
                status = cfunc(as_t(t), buf("double[]", xa), buf("double[]", check_r(r)),
                               buf("double[]", out))
            else:
                status = cfunc(as_t(t), buf("double[]", xa), buf("double[]", out))
            if status:
                fail(status, what, t, xa)
            return out if len(shape) == 1 else out.reshape(shape)

        return call

    def _evaluate(self, output, t, x, p, r):
        try:
            call = self._calls[output]
        except KeyError:
            self._require(output)
            raise
        return call(t, x, p, r)

    def rhs(self, t, x, p=None, r=None) -> np.ndarray:  # fast path, no enum lookup
        return self._calls[Output.RHS](t, x, p, r) if Output.RHS in self._calls else \
            self._evaluate(Output.RHS, t, x, p, r)

    def integrate(self, method, t_eval, x0, p=None, r=None, *, rtol: float = 1e-6,
                  atol: float = 1e-9, h: float | None = None, h_max: float = 0.0,
                  max_steps: int = 0, on_failure: str = "raise"):
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
            Initial state, parameters (default: the model's) and inputs (held constant).
            A 2-D ``x0`` ``(k, n_x)``, ``p`` ``(k, n_p)`` or ``r`` ``(k, n_r)`` is a
            batch (1-D ones are shared by every member): ``k`` trajectories in one C
            loop, returned as a :class:`~mbgen.targets.batch.BatchIntegration`.
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

        Raises
        ------
        MbgenError
            The integrator was not generated.
        ValueError
            Bad ``t_eval``, ``x0``, tolerances or steps.
        IntegrationError
            The C integrator failed (step too small, step limit, singular
            matrix, mass matrix not positive definite, non-finite result).
        """
        try:
            output = method if isinstance(method, Output) else Output(str(method).lower())
        except ValueError:
            output = None
        if output is None or not output.is_integrator:
            raise MbgenError(f"{method!r} is not an integrator; choose from 'dopri5', 'rk4', "
                             f"'rosenbrock'")
        self._require(output)
        try:
            t = np.array(t_eval, dtype=F64)
        except (TypeError, ValueError):
            raise ValueError(f"t_eval must be a 1-D array of increasing times; got {t_eval!r}") \
                from None
        if t.ndim != 1 or t.size < 1:
            raise ValueError(f"t_eval must be a 1-D array of at least one time; got shape "
                             f"{t.shape}")
        if not np.all(np.isfinite(t)):
            raise ValueError("t_eval must hold finite times")
        if t.size > 2**31 - 1:
            raise ValueError("t_eval has too many times for the C integrator (int n_out)")
        if np.any(np.diff(t) <= 0):
            i = int(np.argmax(np.diff(t) <= 0))
            raise ValueError(f"t_eval must be strictly increasing; t_eval[{i + 1}] = {t[i + 1]!r} "
                             f"follows t_eval[{i}] = {t[i]!r}")
        from .targets import batch

        xa = None if batch.is_batch(x0, p, r) else self._x(x0)
        if xa is not None and not np.all(np.isfinite(xa)):
            raise ValueError(f"initial state x0 must be finite; got {xa.tolist()}")
        if output is Output.RK4:
            if h is None:
                raise ValueError("the rk4 integrator takes a fixed step: pass h > 0")
        rtol, atol, h_max = float(rtol), float(atol), float(h_max)
        h0 = 0.0 if h is None else float(h)
        for name, value in (("rtol", rtol), ("atol", atol), ("h", h0)):
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0; got {value!r}")
        if h is not None and not h0 > 0:
            raise ValueError(f"h must be > 0; got {h0!r}")
        if not h_max >= 0:
            raise ValueError(f"h_max must be >= 0 (0: unbounded); got {h_max!r}")
        if int(max_steps) != max_steps or max_steps < 0:
            raise ValueError(f"max_steps must be an integer >= 0 (0: default); got {max_steps!r}")

        if xa is None:
            return batch.integrate(self, output, t, x0, p, r, rtol=rtol, atol=atol, h0=h0,
                                   h_max=h_max, max_steps=max_steps, on_failure=on_failure)
        ffi, prefix = self.ffi, self.rendered.prefix
        buf = ffi.from_buffer
        opt = ffi.new(f"{prefix}_options *", {"rtol": rtol, "atol": atol, "h0": h0,
                                              "h_max": h_max, "max_steps": int(max_steps)})
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
            names = {v: (n, text) for n, v, text in STATUS_CODES + INTEGRATOR_STATUS_CODES}
            code, text = names.get(status, ("UNKNOWN", "unknown error"))
            raise IntegrationError(
                f"{self.name}.integrate({output.value!r}) failed with status {status} "
                f"({prefix.upper()}_{code}: {text}) at t_reached={stats.t_reached!r} after "
                f"{stats.n_steps} steps ({stats.n_rejected} rejected, {stats.n_rhs} RHS calls)",
                status, float(stats.t_reached))
        return Integration(t, x_out, output.value, int(status), int(stats.n_steps),
                           int(stats.n_rejected), int(stats.n_rhs), int(stats.n_jac),
                           int(stats.n_lu), wall)


class PythonModel(ModelBase):
    """The generated Python module (``<prefix>.py``) behind the same interface."""

    backend = "python"

    def __init__(self, rendered, module, layout: Layout, defaults, outputs):
        super().__init__(rendered.prefix, layout, defaults, outputs)
        self.rendered = rendered
        self.module = module
        self._args = {Output(info.output): info.args for info in rendered.functions}

    def _evaluate(self, output, t, x, p, r):
        self._require(output)
        fn = getattr(self.module, output.value)
        xa = self._x(x)
        args = [self._t(t), xa]
        if "p" in self._args[output]:
            args.append(self._p(p))
        if "r" in self._args[output]:
            args.append(self._r(r))
        try:
            return fn(*args)
        except self.module.NotPositiveDefinite:
            self._fail(1, output.value, t, xa)
        except self.module.NonFinite:
            self._fail(2, output.value, t, xa)
