"""The compiled back end: the generated C, built into a plain library and opened with cffi.

:class:`CompiledModel` has the :class:`~mbgen.runtime.base.ModelBase` interface.  Each
generated function gets one entry (``_make_call``) whose common case (a float ``t``,
a contiguous float64 ``x``, default or float64 ``p`` and ``r``) is checked in C and goes
straight to the generated function (:mod:`mbgen.runtime.crossing`); anything else takes the
validating path or the batch loop (:mod:`mbgen.runtime.batch`) in Python.
:meth:`CompiledModel.integrate` runs a generated C integrator over the output times
and returns a :class:`~mbgen.runtime.integration.Trajectory`.
"""

from __future__ import annotations

import html
import re
import time

import numpy as np

from .. import summary
from ..abi import INTEGRATORS, Output, status_message
from ..errors import ArgumentError, ConstraintError, IntegrationError, MbgenError
from ..integrators import DEFAULT_ATOL, DEFAULT_RTOL
from ..integrators import method as integrator
from ..symbolic.layout import Layout
from . import crossing, named
from .arguments import F64, real_number, step_count, times
from .base import GeneratedModel, on_loop_bound
from .batch import evaluate, is_batch, options
from .batch import integrate as batch_integrate
from .integration import SUCCESS, Trajectory

#: The rendered code's values that ``CompiledModel``'s older signature repeated, each with
#: how a repeated value is compared (a mapping as a dict, a sequence as a tuple).
_AS_RENDERED = {"layout": lambda value: value, "defaults": dict, "outputs": tuple}


class CompiledModel(GeneratedModel):
    """The generated C, compiled with cffi; see :func:`mbgen.compile`."""

    backend = "c"
    batch_loop = True

    def __init__(self, rendered, module, layout: Layout | None = None, defaults=None,
                 outputs=None):
        """The compiled ``module`` of ``rendered`` (:func:`mbgen.build.extension.load`).

        Its layout, default parameters and outputs are the rendered code's.  The older
        form ``CompiledModel(rendered, module, rendered.layout, rendered.defaults,
        rendered.outputs)`` still works: each of the three given must equal the rendered
        code's (:class:`~mbgen.errors.ArgumentError` otherwise), since the C knows no other.
        """
        given = {"layout": layout, "defaults": defaults, "outputs": outputs}
        for what, same in _AS_RENDERED.items():
            if given[what] is not None and same(given[what]) != same(getattr(rendered, what)):
                raise ArgumentError(f"CompiledModel({what}=...) differs from the rendered "
                                    f"code's (rendered.{what}); leave it out")
        super().__init__(rendered, module, rendered.layout, rendered.defaults,
                         rendered.outputs)
        self.ffi, self.lib = module.ffi, module.lib
        #: The Python path of every function (what the C entries fall back to).
        self._python_calls: dict = {}
        self._calls = {Output(info.output): self._make_call(info) for info in rendered.functions}
        self._rhs = self._calls.get(Output.RHS) or (
            lambda t, x, p=None, r=None: self._evaluate(Output.RHS, t, x, p, r))

    @property
    def c_integrators(self) -> tuple[Output, ...]:
        """The generated C integrators :meth:`integrate` can run (its ``outputs``)."""
        return tuple(o for o in INTEGRATORS if o in self.outputs)

    def _make_call(self, info):  # noqa: C901 - the measured hot path (docstring), kept whole
        """``call(t, x, p=None, r=None)`` for one generated function.

        What is returned is the function's C entry (:mod:`mbgen.runtime.crossing`): the
        common case (a float ``t``, a contiguous float64 ``x`` of the right length,
        default or float64 ``p`` and ``r``) is checked in C and goes straight to the
        generated function, about 0.1 µs from Python at n = 2 where this Python closure
        takes about 1.2 µs.  The entry hands anything else, and every error status, to
        the closure made here (kept in ``_python_calls``): the same common case through
        cffi, else the validating path (named errors, conversions) or the batch loop, so
        every error is this closure's.  A module without the entry (none built by this
        mbgen) gets the closure itself.

        Every array is handed to C through a buffer taken at this call
        (``ffi.from_buffer``, with its type looked up once), never one cached
        from an earlier call: an array may have been reallocated in place since
        (``p.resize(..., refcheck=False)``), and its old memory freed.  Only the
        default ``p`` and ``r``, copies this closure owns, keep their buffers.
        """
        ffi = self.ffi
        buf, darr = ffi.from_buffer, ffi.typeof("double[]")
        cfunc = getattr(self.lib, info.c_name)
        size, shape = info.out_size, info.out_shape
        has_p, has_r = "p" in info.args, "r" in info.args
        what = info.output
        check_x, check_p, check_r, as_t, fail = self._x, self._p, self._r, self._t, self._fail
        empty, ndarray, f64 = np.empty, np.ndarray, F64
        xshape, pshape, rshape, stride = (self.n_x,), (self.n_p,), (self.n_r,), (8,)
        reshape = len(shape) != 1
        model = self
        # the closure's own default arrays (the C entry's too), behind their buffers
        p_array = (self.default_parameters.copy()
                   if has_p and self.default_parameters is not None else None)
        r_array = self._zeros_r.copy() if has_r else None
        p_default = buf(darr, p_array) if p_array is not None else None
        r_default = buf(darr, r_array) if r_array is not None else None

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
            args = [as_t(t), buf(darr, xa)]
            if has_p:
                args.append(buf(darr, check_p(p)))
            if has_r:
                args.append(buf(darr, check_r(r)))
            status = cfunc(*args, buf(darr, out))
            if status:
                fail(status, what, t, xa)
            return out.reshape(shape) if reshape else out

        def call(t, x, p=None, r=None):  # noqa: C901 - the hot path itself: no helper calls
            if not (t.__class__ is float and x.__class__ is ndarray and x.dtype is f64
                    and x.shape == xshape and x.strides == stride):
                return slow(t, x, p, r)
            if has_p:
                if p is None:
                    pb = p_default
                    if pb is None:
                        return slow(t, x, p, r)
                elif p.__class__ is ndarray and p.dtype is f64 and p.shape == pshape and \
                        p.strides == stride:
                    pb = buf(darr, p)
                else:
                    return slow(t, x, p, r)
            if has_r:
                if r is None:
                    rb = r_default
                elif r.__class__ is ndarray and r.dtype is f64 and r.shape == rshape and \
                        r.strides == stride:
                    rb = buf(darr, r)
                else:
                    return slow(t, x, p, r)
            out = empty(size)
            if has_p and has_r:
                status = cfunc(t, buf(darr, x), pb, rb, buf(darr, out))
            elif has_p:
                status = cfunc(t, buf(darr, x), pb, buf(darr, out))
            elif has_r:
                status = cfunc(t, buf(darr, x), rb, buf(darr, out))
            else:
                status = cfunc(t, buf(darr, x), buf(darr, out))
            if status:
                fail(status, what, t, x)
            return out.reshape(shape) if reshape else out

        self._python_calls[Output(what)] = call
        if crossing.available(self.module) and len(shape) in (1, 2):
            return crossing.c_entry(self.module, info, call, (self.n_x, self.n_p, self.n_r),
                                    p_array, r_array, release=crossing.releases_gil(
                                        self.rendered.header, info.c_name))
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

    def _input_table(self, table: named.InputTable) -> named.InputTable:
        """``table`` in this model's input order, if its C integrators take tables."""
        if not self.n_r:
            raise ValueError(f"{self.name!r} has no inputs; an InputTable has nothing to drive")
        if "n_table" not in dict(self.ffi.typeof(f"{self.rendered.prefix}_options").fields):
            raise MbgenError(f"the C integrators of {self.name!r} were generated without "
                             f"input tables (an older mbgen); regenerate the code")
        return table.for_model(self)

    #: Relative tolerance of the configuration-constraint residual that :meth:`integrate`
    #: accepts at the start: per constraint, this times its own scale plus the rounding
    #: floor at the start's coordinates (:func:`mbgen.runtime.base.on_loop_bound`).
    START_RESIDUAL_TOL = 1e-8

    def _check_consistent_start(self, t0, x0, p, r) -> None:
        """Refuse an initial state off the configuration constraints (ConstraintError); a
        batch (any of ``x0``, ``p``, ``r`` 2-D) names its first such member.

        The residual, in the constraint's own units, is compared with
        :func:`~mbgen.runtime.base.on_loop_bound` at the start: its scale comes from the
        constraint Jacobian's rows, not from the size of the coordinates (an angle of
        1e13 rad is no licence for a loop open by 3.2 length units).
        """
        f = np.atleast_2d(self.holonomic(float(t0), x0, p, r))
        J = self.holonomic_jacobian(float(t0), x0, p, r)
        q = np.atleast_2d(x0)[:, :self.layout.n_q]
        bound = on_loop_bound(J, q, self.START_RESIDUAL_TOL).reshape(f.shape)
        bad = np.flatnonzero(~np.all(np.abs(f) <= bound, axis=1))
        if bad.size:
            i = int(bad[0])
            member = f"batch member {i} of {len(f)}: " if is_batch(x0, p, r) else ""
            j = int(np.argmax(np.abs(f[i]) - bound[i]))  # the row most off (a NaN's, if any)
            raise ConstraintError(
                f"{self.name}: {member}the initial state violates the configuration "
                f"constraints (residual {abs(f[i, j]):.3g}, at most {bound[i, j]:.3g} "
                f"allowed); complete its dependent coordinates "
                f"({', '.join(self.dependent_coordinates)}) with model.consistent(x0) first "
                f"(mbgen.runtime.simulate.simulate does this), or pass project=False to integrate "
                f"from it as given")

    def _step_settings(self, spec, rtol, atol, h, h_max, max_steps) -> tuple:
        """``(rtol, atol, h0, h_max, max_steps)`` of :meth:`integrate` checked and converted
        (``h0``: 0 when ``h`` is None, which only the adaptive methods allow)."""
        if not spec.adaptive:
            if h is None:
                raise ArgumentError(f"the {spec.output.value} integrator takes a fixed step: "
                                    f"pass h > 0")
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
        return rtol, atol, h0, h_max, max_steps

    def integrate(self, method, t_eval, x0, p=None, r=None, *, rtol: float = DEFAULT_RTOL,
                  atol: float = DEFAULT_ATOL, h: float | None = None, h_max: float = 0.0,
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
            as arrays or mappings by name (:mod:`mbgen.runtime.named`).  ``r`` may also be an
            :class:`~mbgen.runtime.named.InputTable`: a piecewise-linear ``r(t)`` that the C
            integrator interpolates at every stage time.
            A 2-D ``x0`` ``(k, n_x)``, ``p`` ``(k, n_p)`` or ``r`` ``(k, n_r)`` is a
            batch (1-D ones are shared by every member): ``k`` trajectories in one C
            loop, returned as a :class:`~mbgen.runtime.batch.BatchIntegration`.
        rtol, atol : float
            Error tolerances of the adaptive methods (as solve_ivp; default
            :data:`mbgen.integrators.DEFAULT_RTOL`, ``DEFAULT_ATOL``: 1e-6, 1e-9).
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
            Models with configuration constraints: refuse a start off the constraints
            (:class:`~mbgen.errors.ConstraintError`; a batch names the member) and
            project the dependent coordinates back onto the constraints after every
            step (``False`` integrates from the start as given and only records the
            drift, ``Integration.max_residual``; a batch's ``stats["max_residual"]``).

        Returns
        -------
        Trajectory
            :class:`~mbgen.runtime.integration.Trajectory` (also named ``Integration``):
            ``t``, ``x`` ``(k, n_x)``, ``method`` (``"dopri5"``, ...), step and call
            counts; a :class:`~mbgen.runtime.batch.BatchIntegration` for a batch.

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
        spec = integrator(method)
        output = spec.output
        self._require(output)
        t = times(t_eval)
        x0, p, r = named.arrays(self, x0, p, r)
        table = None
        if isinstance(r, named.InputTable):
            table, r = self._input_table(r), None
        xa = None if is_batch(x0, p, r) else self._x(x0)
        if xa is not None and not np.all(np.isfinite(xa)):
            raise ArgumentError(f"initial state x0 must be finite; got {xa.tolist()}")
        rtol, atol, h0, h_max, max_steps = self._step_settings(spec, rtol, atol, h, h_max,
                                                               max_steps)

        checks_start = bool(project and self.dependent_coordinates
                            and {Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN} <= set(self.outputs))
        if xa is None:
            if table is not None:
                raise ValueError("an InputTable drives one trajectory; integrate the batch "
                                 "members one by one, or give constant inputs r")
            return batch_integrate(self, output, t, x0, p, r, rtol=rtol, atol=atol, h0=h0,
                                   h_max=h_max, max_steps=max_steps, on_failure=on_failure,
                                   project=project, check_start=self._check_consistent_start
                                   if checks_start else None)
        if checks_start:
            self._check_consistent_start(t[0], xa, p, r)
        ffi, prefix = self.ffi, self.rendered.prefix
        buf = ffi.from_buffer
        settings, projects = options(self, rtol=rtol, atol=atol, h0=h0, h_max=h_max,
                                     max_steps=max_steps, project=project)
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
        work = (ffi.new(f"{prefix}_{output.value}_work *"),) if spec.implicit else ()
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
        return Trajectory(t, x_out, tuple(self.state_names), int(stats.n_rhs), wall,
                          output.value, njev=int(stats.n_jac), nlu=int(stats.n_lu),
                          n_steps=int(stats.n_steps), message=SUCCESS,
                          max_residual=float(stats.max_residual) if projects else float("nan"),
                          status=int(status), n_rejected=int(stats.n_rejected))

    def _repr_html_(self) -> str:
        """Notebook summary: ABI sizes and names, outputs, operation counts."""
        return compiled_html(self)


def compiled_html(model: CompiledModel) -> str:
    """Summary of a :class:`CompiledModel` (derivation, ABI sizes, outputs, operation counts)."""
    rendered = model.rendered
    ops = re.search(r"Operations: (\d+) after CSE \((\d+) before\)", rendered.header)
    derivation = re.search(r"Derivation: (.+)", rendered.header)
    rows = [("derivation", html.escape(derivation.group(1)))] if derivation else []
    rows += [("states x", f"{model.n_x}: {summary.names(model.state_names)}"),
            ("parameters p", f"{model.n_p}: {summary.names(model.parameter_names)}"),
            ("inputs r", f"{model.n_r}: {summary.names(model.input_names)}"),
            ("outputs", summary.names(o.value for o in model.outputs))]
    if ops:
        rows.append(("operations", f"{ops.group(1)} after CSE ({ops.group(2)} before)"))
    if model.default_parameters is not None and model.n_p:
        rows.append(("default p", summary.names(
            f"{n}={v:g}" for n, v in zip(model.parameter_names, model.default_parameters))))
    if model.reaction_names:
        rows.append(("joints", summary.names(model.reaction_names)))
    if model.constraint_names:
        rows.append(("constraints", summary.names(model.constraint_names)))
    rows.append(("content hash", html.escape(rendered.content_hash[:16] or "-")))
    return summary.table(f"CompiledModel {model.name!r} (C)", rows)


__all__ = ["CompiledModel", "compiled_html"]
