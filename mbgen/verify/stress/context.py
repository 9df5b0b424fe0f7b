"""What every case shares: the case grid of a size (:class:`Size`, :data:`SIZES`) and the
:class:`Context` made by :func:`make_context`: the scene compiled once, its 50-digit
reference and its nominal point.

The scene is compiled from its equations with every parameter free (a scene's
``fixed`` parameters and input selection are ignored, inputs are zero), with
``rhs, mass_matrix, jacobian, parameter_jacobian, time_derivative, energy`` and
the C integrators ``dopri5`` and ``rosenbrock``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ...abi import Output
from ...model.scene import Scene, builtin_names, load_scene
from ...pipeline import equations_of, run
from .reference import HighPrecision


@dataclass(frozen=True)
class Size:
    """Case grid of one size (``ci`` or ``full``).

    The budgets count work, never seconds, so a case stops at the same place on any
    machine, however loaded: a scipy run stops after ``step_budget`` accepted steps (a
    multiple of it where a case says so: ten for the implicit stiff runs) or
    ``eval_budget`` calls of the right-hand side and the Jacobian, whichever comes
    first (Radau makes about seven calls a step, so the implicit runs meet the second);
    a C integrator stops at its step limit.
    """

    stiffness: tuple[float, ...]
    stiff_horizon: float          # fraction of the scene's t_span for stiff runs
    step_budget: int              # accepted steps of a scipy explicit run
    eval_budget: int              # RHS and Jacobian evaluations of one scipy run
    ratios: tuple[float, ...]     # mass and length scalings
    speeds: tuple[float, ...]
    gravity: tuple[float, ...]
    offsets: tuple[float, ...]    # distances to a singular configuration
    long_factor: float            # long runs over long_factor * t_span
    random_states: int
    scan_points: int
    first_and_last: bool          # scale the first mass-like parameter too


#: The case grid of each size, by name.
SIZES = {
    "ci": Size(stiffness=(1e4, 1e6, 1e8), stiff_horizon=0.25, step_budget=20_000,
               eval_budget=400_000, ratios=(1e-6, 1e6), speeds=(1e3, 1e6), gravity=(1e-6, 1e6),
               offsets=(1e-2, 1e-6, 1e-12, 0.0), long_factor=1.0, random_states=3,
               scan_points=16, first_and_last=False),
    "full": Size(stiffness=(1e4, 1e5, 1e6, 1e7, 1e8), stiff_horizon=1.0, step_budget=200_000,
                 eval_budget=4_000_000, ratios=(1e-6, 1e-3, 1e3, 1e6),
                 speeds=(1e3, 1e4, 1e5, 1e6), gravity=(1e-6, 1e-3, 1e3, 1e6),
                 offsets=(1e-1, 1e-2, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-14, 0.0),
                 long_factor=10.0, random_states=20, scan_points=64, first_and_last=True),
}


@dataclass
class Context:
    """Everything the cases share: the scene, the compiled model, the reference, the size."""

    scene: Scene
    source: str | None            # built-in name or scene file, for reloading with options
    result: object                # PipelineResult
    model: object                 # CompiledModel
    hp: HighPrecision
    equations: object             # the unoptimised equations behind hp
    size: Size
    size_name: str
    values: dict[str, float]      # nominal parameter values by name
    x0: np.ndarray
    t0: float
    span: tuple[float, float]
    outputs: tuple
    cache: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)

    @property
    def p0(self) -> np.ndarray:
        return self.p_of(self.values)

    def p_of(self, values: Mapping[str, float]) -> np.ndarray:
        """Parameter array in the compiled model's order."""
        return np.array([float(values[n]) for n in self.model.parameter_names])

    def named(self, x, values: Mapping[str, float]) -> dict[str, float]:
        """States (by the model's names), parameters and zero inputs as one name -> value dict."""
        out = dict(values)
        out.update(zip(self.model.state_names, np.asarray(x, dtype=float).tolist()))
        return out


def _source_of(scene: Scene, given: str | None) -> str | None:
    if given:
        return given
    if scene.name in builtin_names():
        return scene.name
    if scene.source and scene.source.endswith(".py"):
        return scene.source
    return None


def _wanted_outputs(equations) -> list[Output]:
    outs = [Output.RHS, Output.MASS_MATRIX, Output.JACOBIAN, Output.TIME_DERIVATIVE]
    if equations.kinetic_energy is not None:
        outs.append(Output.ENERGY)
    if equations.layout.n_p:
        outs.append(Output.PARAMETER_JACOBIAN)
    return outs


def _compile(equations):
    """Compile with every output the cases use, the C integrators included."""
    return run(equations, _wanted_outputs(equations) + [Output.DOPRI5, Output.ROSENBROCK])


def make_context(scene: Scene | str, size: str = "ci", notes: list[str] | None = None) -> Context:
    """Load (if named) and compile ``scene`` for the suite; see
    :func:`mbgen.verify.stress.stress`."""
    if size not in SIZES:
        raise ValueError(f"size must be one of {sorted(SIZES)}, got {size!r}")
    notes = [] if notes is None else notes
    given = scene if isinstance(scene, str) else None
    scn = load_scene(scene) if isinstance(scene, str) else scene
    equations = equations_of(scn)
    result = _compile(equations)
    model = result.compiled
    reference_eq = result.baked
    values = {**{k: float(v) for k, v in scn.parameters.items()},
              **{k: float(v) for k, v in getattr(scn, "fixed", {}).items()}}
    x0 = scn.x0(model.layout)
    return Context(scene=scn, source=_source_of(scn, given), result=result, model=model,
                   hp=HighPrecision(reference_eq), equations=reference_eq, size=SIZES[size],
                   size_name=size,
                   values=values, x0=x0, t0=float(scn.t_span[0]),
                   span=(float(scn.t_span[0]), float(scn.t_span[1])),
                   outputs=tuple(model.outputs), notes=notes)
