r"""The step API: advance a state held in a caller-owned memory struct.

For a control loop or a co-simulation master that owns the clock.  Rendered
into ``<prefix>.h`` / ``<prefix>.c`` by ``templates/step/step.h.j2`` and
``templates/step/step.c.j2`` when :class:`~mbgen.codegen.targets.Targets` has ``step``.

Per method ``m`` (:func:`step_methods`: ``rk4`` always; ``dopri5`` unless the scene
asks for ``rosenbrock`` only; ``rosenbrock`` when the scene asks for it)::

    typedef struct { double t; double x[N_X]; double h; ...; } <prefix>_<m>_memory;
    int <prefix>_<m>_init(<prefix>_<m>_memory *mem, double t0, const double *x0,
                          double rtol, double atol);
    int <prefix>_<m>_step(<prefix>_<m>_memory *mem, double h[, const double *p]
                          [, const double *r]);

``step`` advances ``mem->x`` from ``mem->t`` to ``mem->t + h`` with the
inputs ``r`` held constant over the step (they may change from one call to
the next).  ``rk4`` takes one classic Runge--Kutta step of size ``h``.  The
adaptive methods take as many error-controlled steps as needed, the last one
cut to land on ``t + h``, and keep in ``mem`` what the next call needs: the
step size (``mem->h``; the controller's proposal, not the cut step), and
``f(t, x)`` with the ``p``, ``r`` it was computed for (reused when the next
call passes the same values, so an unchanged input costs no extra RHS call).
The memory's size is ``sizeof(<prefix>_<m>_memory)``, a compile-time
constant: every work array (for Rosenbrock the ``N_X x N_X`` Jacobian and
iteration matrix) lives in it, so the functions' stack use is small and
stated in the header.  No allocation, no globals: one memory per simulated
system, any number in parallel.

With the same tolerances, ``dopri5_step(mem, T)`` from ``t = t0`` takes exactly
the steps of ``<prefix>_dopri5`` over ``[t0, t0 + T]`` (and gives the same bits);
likewise for Rosenbrock.  On failure the status is returned and ``mem->t``,
``mem->x`` keep the last accepted state.  A trial stage that fails (the right-hand side
at a stage state gives ``NONFINITE`` or ``NOT_POSITIVE_DEFINITE``, the iteration matrix
is singular) rejects the attempt like an error estimate over 1: the step shrinks by the
least factor and is tried again, as in the whole-trajectory integrators (a long step
may probe states the flow never reaches: a foot deep in the ground, a pendulum past
its singular pose).  Only when the step falls below the resolution of ``t`` is that
stage's status returned (not ``STEP_TOO_SMALL``, which would hide the cause).

Arguments: ``mem``, ``x0``, ``p`` or ``r`` ``NULL``, non-finite ``t0``, ``x0`` or
tolerances, and an ``h`` that is not a positive finite number (or makes ``t + h``
overflow) return ``BAD_ARGUMENT``.  A step that cannot advance time -- ``h`` below
the resolution of ``t``, so that ``t + h == t`` (``t = 1e16``, ``h = 1``) -- returns
``STEP_TOO_SMALL``, the status the adaptive methods give when their own step falls
below the resolution of ``t``: ``h`` is a valid number, but time would not move, so
the call is refused rather than answering OK with ``t`` unchanged.  Neither touches
``mem``.

Configuration constraints: after every accepted step the dependent coordinates
are projected back onto ``f_h(q, t) = 0`` by the integrators' projection
(Newton, ``PROJECTION_FAILED`` when it does not converge), and the largest
residual met before projecting is kept in ``mem->max_residual``; as in the
whole-trajectory integrators, the adaptive methods evaluate the next step's
first stage at the projected state.  The dependent speeds are not states (the
RHS computes them), so the state stays consistent step after step.  The
projection needs the integrators rendered (a scene with an integrator output).

Input bounds (``Scene(saturate=True)``, off by default; :func:`saturation`): the header
states each input's bounds as ``const double <prefix>_input_lower[N_R]``, ``_upper[N_R]``
(an unbounded side is ``HUGE_VAL``; the comment above them names each input), and every
step call first clamps the inputs ``r`` into ``mem->r_in`` with
``<prefix>_saturate_inputs`` (``v < lower``: ``lower``; ``v > upper``: ``upper``; any other
value, NaN included, passes unchanged) and adds the number it clamped to the statistic
``mem->n_saturated`` (cleared by init); the right-hand side reads only the clamped
values.  So a step with an input beyond its bound is bit for bit the step with the input
at the bound.  The adaptive methods compare the clamped inputs to reuse ``f``: an input
that moves while it stays clamped costs no RHS call.  Why inputs only: a bound on an input
(a motor's torque) is a property of the actuator, which clamps before the dynamics; a
bound on a speed or coordinate is a property of the state, and clamping a state between
steps is no physics (it injects or removes energy, breaks the error control and
first-same-as-last reuse, and makes the answer depend on the step size), so those stay data
(``Model.bounds("speeds")``) for the caller to check a trajectory against.

The step functions call the runtime routines (:mod:`mbgen.codegen.targets.runtime`) the
whole-trajectory integrators call -- the error norm, the first step, Rosenbrock's LU --
so with both targets on each is defined once.  Stack bounds
(:meth:`Step.stack_bounds`): a step's own scalars (its arrays are in the memory struct)
over the RHS, the projection, the first step, an implicit method's Jacobian, ``df/dt``
and LU.
"""

from __future__ import annotations

import math

from ...abi import INTEGRATOR_STATUS_CODES, Output
from ...errors import ModelError
from ...integrators import METHODS, method
from ..header import SMALL, frame
from ..integrators import method_view, projection, require
from .base import HEADER, SOURCE, Target
from .integrators import project_bound
from .runtime import routine_bounds

#: Default attempted-step limit per call (``mem->max_steps = 0``).
DEFAULT_MAX_STEPS = 1000000


def step_methods(kernel) -> tuple[str, ...]:
    """The step functions rendered for ``kernel``, fixed-step first, then the adaptive ones.

    Every fixed-step method; an adaptive one when the scene asks for its integrator;
    the explicit adaptive ones also when it asks for no implicit one.
    """
    wanted = set(kernel.integrators)
    stiff = any(METHODS[o].implicit for o in wanted)
    chosen = [o for o, T in METHODS.items()
              if not T.adaptive or o in wanted or not (T.implicit or stiff)]
    return tuple(o.value for o in sorted(chosen, key=lambda o: (METHODS[o].adaptive,
                                                                METHODS[o].implicit)))


def adaptive_method(kernel) -> str:
    """The adaptive step method an FMU's co-simulation uses: the implicit one of a stiff scene."""
    return [m for m in step_methods(kernel) if method(m).adaptive][-1]


def c_bound(value: float) -> str:
    """A bound as a C double expression: ``repr`` of a finite one, ``(+/-)HUGE_VAL``."""
    if math.isinf(value):
        return "HUGE_VAL" if value > 0 else "-HUGE_VAL"
    return repr(float(value))


def saturation(kernel) -> list[dict] | None:
    """``[{name, index, lower, upper}]`` per input of ``kernel.layout`` (C expressions; an
    input without bounds gets ``-HUGE_VAL``, ``HUGE_VAL``), or None when the inputs are not
    saturated (``kernel.input_bounds`` empty, or no inputs)."""
    names = kernel.layout.input_names
    if not kernel.input_bounds or not names:
        return None
    bounds = {n: (lo, hi) for n, lo, hi in kernel.input_bounds}
    return [dict(name=n, index=i, lower=c_bound(bounds.get(n, (-math.inf, math.inf))[0]),
                 upper=c_bound(bounds.get(n, (-math.inf, math.inf))[1]))
            for i, n in enumerate(names)]


def step_context(kernel, prefix: str) -> dict:
    """Template context (key ``step``) for ``step/step.h.j2`` / ``step/step.c.j2``."""
    L = kernel.layout
    names = step_methods(kernel)
    non_autonomous = require(kernel, [Output(m) for m in names], "step", "df/dt")
    project = projection(kernel)
    if project and not kernel.integrators:
        raise ModelError(f"the step API of {kernel.equations.name!r} projects onto its "
                         f"configuration constraints with the integrators' projection; add an "
                         f"integrator output (e.g. Output.DOPRI5)")
    params = "".join(f", const double *{a}" for a, n in (("p", L.n_p), ("r", L.n_r)) if n)
    args = "".join(f", {a}" for a, n in (("p", L.n_p), ("r", L.n_r)) if n)
    null_args = "".join(f" || !{a}" for a, n in (("p", L.n_p), ("r", L.n_r)) if n)
    methods = []
    for m in names:
        view = method_view(Output(m))
        view.update(
            template=f"step/{m}.c.j2",
            memory_template=f"step/{m}.h.j2",
            memory=f"{prefix}_{m}_memory",
            init=f"int {prefix}_{m}_init({prefix}_{m}_memory *mem, double t0, const double *x0, "
                 f"double rtol, double atol)",
            step=f"int {prefix}_{m}_step({prefix}_{m}_memory *mem, double h{params})")
        methods.append(view)
    return dict(step=dict(
        methods=methods,
        names=list(names),
        adaptive=any(m["adaptive"] for m in methods),
        params=params,
        args=args,
        null_args=null_args,
        n_p=L.n_p,
        n_r=L.n_r,
        n=max(L.n_x, 1),
        max_steps=DEFAULT_MAX_STEPS,
        non_autonomous=non_autonomous,
        project=project,
        saturate=saturation(kernel),
    ))


class Step(Target):
    """The step API, a section of the model's files when ``Targets(step=True)``."""

    name = "step"
    files = (("step.h.j2", HEADER), ("step.c.j2", SOURCE))
    status_codes = INTEGRATOR_STATUS_CODES
    requires = ("initial_step", "lu")
    needs = ("c",)

    def wanted(self, kernel, targets) -> bool:
        return targets.step

    def context(self, kernel, views, prefix: str) -> dict:
        return step_context(kernel, prefix)

    def stack_bounds(self, kernel, ctx: dict, known: dict) -> dict[str, int]:
        """``<prefix>_<m>_init``, ``<prefix>_<m>_step`` of every step method; with
        configuration constraints ``<prefix>_project_state``; with saturated inputs
        ``<prefix>_saturate_inputs`` (a leaf)."""
        prefix = ctx["prefix"]
        routines = routine_bounds(kernel, ctx, known)
        project = project_bound(kernel, prefix, known, routines)
        project_state = frame(14, 2) + project if project else 0
        rhs = max(known.get(f"{prefix}_rhs", 0), project)
        bounds = {f"{prefix}_project_state": project_state} if project else {}
        if ctx["step"]["saturate"]:
            bounds[f"{prefix}_saturate_inputs"] = SMALL
        for m in ctx["step"]["names"]:
            T = method(m)
            calls = [rhs, SMALL, project_state]
            if T.adaptive:
                calls.append(routines["initial_step"])
            if T.implicit:
                calls += [known.get(f"{prefix}_{need.value}", 0) for need in T.needs]
                calls += [known.get(f"{prefix}_time_derivative", 0), routines["lu"]]
            bounds[f"{prefix}_{m}_init"] = frame(2) + SMALL
            bounds[f"{prefix}_{m}_step"] = frame(24, 6) + max(calls)
        return bounds


#: The step target.
STEP = Step()

__all__ = ["STEP", "Step", "step_methods", "adaptive_method", "step_context", "saturation",
           "c_bound", "DEFAULT_MAX_STEPS"]
