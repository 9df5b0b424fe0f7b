"""The embedding example: ``example.c`` next to a scene's generated C.

It sets the scene's free parameters and initial state, runs the first C
integrator the scene asks for, and prints the trajectory as CSV.  The options
(``EXAMPLE_OPTIONS``) are also what :func:`example_integration` passes to
:meth:`mbgen.run.compiled.CompiledModel.integrate`, so the two can be compared.
"""

from __future__ import annotations

import numpy as np

from ..._version import __version__
from ...pipeline import PipelineResult
from ..templating import environment
from ...model.scene import Scene

#: Rows of the example's trajectory.
N_OUT = 21
#: Tolerances of the adaptive integrators; RK4 takes 1000 steps over the span.
RTOL, ATOL, RK4_STEPS = 1e-8, 1e-10, 1000


def _c(value: float) -> str:
    return repr(float(value))


def example_settings(scene: Scene, result: PipelineResult):
    """``(method, t, x0, p, r, options)`` of the example, or None without an integrator."""
    if not result.kernel.integrators:
        return None
    method = result.kernel.integrators[0].value
    L = result.layout
    t0, t1 = (float(v) for v in scene.t_span)
    t = t0 + (t1 - t0) * np.arange(N_OUT) / (N_OUT - 1)  # the example's own formula
    h = (scene.t_span[1] - scene.t_span[0]) / RK4_STEPS if method == "rk4" else None
    options = dict(rtol=RTOL, atol=ATOL, h=h)
    return method, t, scene.x0(L), scene.p(L), np.zeros(L.n_r), options


def render_example(scene: Scene, result: PipelineResult) -> str | None:
    """The text of ``example.c`` for ``scene`` (None when it asks for no integrator)."""
    settings = example_settings(scene, result)
    if settings is None:
        return None
    method, t, x0, p, r, options = settings
    L = result.layout
    prefix = result.rendered.prefix
    args = ["x0"] + (["p"] if L.n_p else []) + (["r"] if L.n_r else [])
    return environment().get_template("example/example.c.j2").render(
        version=__version__, scene=scene.name,
        description=scene.description, prefix=prefix, upper=prefix.upper(),
        integrator=method, t0=_c(t[0]), t1=_c(t[-1]), n_out=N_OUT,
        state_names=list(L.state_names), x0=[_c(v) for v in x0],
        parameter_names=list(L.parameter_names), parameters=[_c(v) for v in p],
        input_names=list(L.input_names), inputs=[_c(v) for v in r],
        rtol=_c(options["rtol"]), atol=_c(options["atol"]), h0=_c(options["h"] or 0.0),
        call_args=args, projects=_projects(result))


def _projects(result: PipelineResult) -> bool:
    """Whether the integrators project onto configuration constraints (an options field)."""
    c = result.kernel.equations.constraints
    return c is not None and c.m_h > 0


def example_integration(scene: Scene, result: PipelineResult):
    """The example's trajectory computed through Python (``CompiledModel.integrate``)."""
    method, t, x0, p, r, options = example_settings(scene, result)
    return result.compiled.integrate(method, t, x0, p, r, **options)
