"""The embedding example: ``example.c`` next to a scene's generated C.

It sets the scene's free parameters and initial state, runs the first C
integrator the scene asks for, and prints the trajectory as CSV.  The inputs are
held at 0, or at the values given (``mbgen generate -r F=2``), or follow a table
(``mbgen generate -r F=force.csv``: the table's rows become two static arrays and
the integrator's options point at them, so the C interpolates them at every stage
time as :meth:`~mbgen.runtime.compiled.CompiledModel.integrate` does with an
:class:`~mbgen.runtime.named.InputTable`).  The tolerances are mbgen's defaults
(:data:`mbgen.integrators.DEFAULT_RTOL`, ``DEFAULT_ATOL``).  The options
(:func:`example_settings`) are also what
:func:`mbgen.verify.golden.example_integration` passes to
:meth:`mbgen.runtime.compiled.CompiledModel.integrate`, so the two can be compared.

Rendered after the pipeline from the scene's values and the kernel (not by
:func:`~mbgen.codegen.render.render`): :data:`EXAMPLE`'s :meth:`~Example.export`, for
``mbgen generate`` (``--target example``, on by default when the scene has an integrator),
:func:`mbgen.generate` and ``generated/``.
"""

from __future__ import annotations

import numpy as np

from ..._version import __version__
from ...integrators import DEFAULT_ATOL, DEFAULT_RTOL, METHODS
from ...model.scene import Scene
from ...names import model_prefix
from ..templating import environment
from .base import Job, Target

#: Rows of the example's trajectory.
N_OUT = 21
#: Tolerances of the adaptive integrators (mbgen's defaults); a fixed-step one takes 1000
#: steps over the span.
RTOL, ATOL, RK4_STEPS = DEFAULT_RTOL, DEFAULT_ATOL, 1000


def build_command(prefix: str) -> str:
    """The one-line shell command that builds and runs ``example.c`` (its first comment)."""
    return f"cc -std=c99 -O2 -o example example.c {prefix}.c -lm && ./example"


class Example(Target):
    """``example.c``: a main() that runs the scene's first integrator."""

    name = "example"
    files = (("example.c.j2", "example.c"),)
    needs = ("c",)
    takes_inputs = True

    def wanted(self, kernel, targets) -> bool:
        return False

    def unavailable(self, kernel) -> str | None:
        if kernel.integrators:
            return None
        return ("example.c runs the scene's first integrator, and the outputs have none; add "
                "one, e.g. --outputs rhs,dopri5")

    def export(self, job: Job) -> dict[str, str]:
        text = render_example(job.scene, job.kernel, job.inputs)
        return {} if text is None else {self.files[0][1]: text}


#: The example target.
EXAMPLE = Example()


def _c(value: float) -> str:
    return repr(float(value))


def example_settings(scene: Scene, kernel, r=None):
    """``(method, t, x0, p, r, options)`` of the example, or None without an integrator.

    ``r``: the inputs, an array ``(n_r,)`` in the kernel's input order or an
    :class:`~mbgen.runtime.named.InputTable` already in that order (default zeros).
    """
    if not kernel.integrators:
        return None
    output = kernel.integrators[0]
    L = kernel.layout
    t0, t1 = (float(v) for v in scene.t_span)
    t = t0 + (t1 - t0) * np.arange(N_OUT) / (N_OUT - 1)  # the example's own formula
    h = None if METHODS[output].adaptive else (scene.t_span[1] - scene.t_span[0]) / RK4_STEPS
    options = dict(rtol=RTOL, atol=ATOL, h=h)
    r = np.zeros(L.n_r) if r is None else r
    return output.value, t, scene.x0(L), scene.p(L), r, options


def render_example(scene: Scene, kernel, r=None) -> str | None:
    """The text of ``example.c`` for ``scene`` and its kernel (None without an integrator);
    ``r`` as for :func:`example_settings`."""
    settings = example_settings(scene, kernel, r)
    if settings is None:
        return None
    method, t, x0, p, r, options = settings
    table = getattr(r, "times", None)
    L = kernel.layout
    prefix = model_prefix(kernel.equations.name)
    args = ["x0"] + (["p"] if L.n_p else []) + (["r"] if L.n_r else [])
    [(template, _)] = EXAMPLE.templates(prefix)
    return environment().get_template(template).render(
        version=__version__, scene=scene.name,
        description=scene.description, prefix=prefix, upper=prefix.upper(),
        integrator=method, work=METHODS[kernel.integrators[0]].implicit,
        t0=_c(t[0]), t1=_c(t[-1]), n_out=N_OUT,
        state_names=list(L.state_names), x0=[_c(v) for v in x0],
        parameter_names=list(L.parameter_names), parameters=[_c(v) for v in p],
        input_names=list(L.input_names),
        inputs=[_c(v) for v in (np.zeros(L.n_r) if table is not None else r)],
        table_t=None if table is None else [_c(v) for v in table],
        table_r=None if table is None else [", ".join(_c(v) for v in row) for row in r.values],
        rtol=_c(options["rtol"]), atol=_c(options["atol"]), h0=_c(options["h"] or 0.0),
        call_args=args, projects=_projects(kernel), build=build_command(prefix))


def _projects(kernel) -> bool:
    """Whether the integrators project onto configuration constraints (an options field)."""
    c = kernel.equations.constraints
    return c is not None and c.m_h > 0


__all__ = ["EXAMPLE", "Example", "build_command", "example_settings", "render_example", "N_OUT",
           "RTOL", "ATOL", "RK4_STEPS"]
