"""Scenes: a model plus what to do with it.

A scene file is a Python file with a function ``scene(**options) -> Scene``.
Built-in scenes live in :mod:`mbgen.scenes`; a user's own file works the same
way (``mbgen check path/to/my_scene.py``), and so does a robot's URDF file
(``mbgen check robot.urdf``, :func:`urdf_scene`; option ``-O floating=true``) and a
MuJoCo model (``mbgen check robot.xml``, :func:`mjcf_scene`)::

    from mbgen import Model, Scene

    def scene(n: int = 3) -> Scene:
        m = Model("my_model")
        ...
        return Scene(name="my_model", model=m, parameters={"g": 9.81},
                     initial_state={"q1": 0.1, "u1": 0.0}, t_span=(0.0, 10.0))

A scene is validated once, when it is made (every command loads scenes through
here): its name follows the name rule (:mod:`mbgen.names`); every name in
``parameters``, ``fixed``, ``initial_state``, ``inputs`` and ``points`` exists in
the model (else a :class:`~mbgen.errors.SceneError` with "did you mean");
every number is a finite real and ``t_span`` a finite, increasing pair.
Options given as text (``-O n=4`` on the command line) are converted to the
type of the option's default, finite and integral where the default is.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import inspect
import math
import numbers
import os
import pkgutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from .. import scenes
from ..abi import Output
from ..errors import ModelError, SceneError
from ..names import check_name, did_you_mean
from ..symbolic.equations import Equations
from .builder import Model
from .files import require_regular_file
from .ground import DROP, drop_state, free_height
from .hold import hold_gains, hold_posture
from .limits import allow_large_models, check_size
from .mjcf import compile_mjcf, file_model_name, from_mujoco, scene_values
from .robots import ROBOTS, robot_path
from .urdf import build_model, read_urdf

#: The name of equations imported without one (``from_sympy(obj)``); a scene holding
#: them names the generated code after itself (its ``prefix`` is the scene's name).
UNNAMED = "sympy_model"


@dataclass(frozen=True)
class Scene:
    """A model, its numbers, and what to generate.

    Attributes
    ----------
    name : str
        Scene name, following the name rule of :mod:`mbgen.names` (it names
        output folders and files: ``mbgen-out/<name>/``, ``<name>.csv``).
    model : Model or Equations
        What to derive (a ``Model``) or already derived equations (e.g. from
        :func:`mbgen.from_sympy`).
    parameters : mapping str -> float
        Default value of every parameter.
    initial_state : mapping str -> float
        Initial value of every state (missing states start at 0).
    t_span : (float, float)
        Default simulation interval.
    outputs : tuple of Output
        What the generated code computes (default: the right-hand side).
    description : str
        One line for ``mbgen scenes`` and generated headers.
    closed_form : callable or None
        ``closed_form(t, x0, p) -> x(t)`` with ``t`` of shape (k,) and the
        result of shape (k, n_x): an exact solution to check simulations against.
    conserves_energy : bool
        True when T + V is constant along solutions (no inputs, no dissipation,
        no prescribed motion).
    fixed : mapping str -> float
        Parameters baked into the generated code as constants (folded away);
        the other parameters stay free (run-time values, defaults from
        ``parameters``).
    inputs : tuple of str or None
        Inputs given at run time; the model's other inputs are zero and leave
        the generated code.  ``None``: every input.
    points : tuple of str
        Points whose positions/velocities ``Output.POSITIONS``/``VELOCITIES`` report.
    prefix : str or None
        C prefix of the generated code (default: the model name; for equations
        imported without a name, ``from_sympy(obj)``, the scene's name); give two
        slices of one model different prefixes to link them into one program.
    options : mapping
        The options the scene was built with.
    source : str
        File the scene came from (an absolute path for a scene file; generated
        files record only its name, see :func:`source_label`).
    method : Method or None
        Derivation method (None: Kane's method; ``Method.NEWTON_EULER`` for
        joint reactions and the articulated-body recursion of long chains).
    targets : Targets or None
        What to render besides the outputs, as for :func:`mbgen.compile`:
        ``mbgen.Targets(step=True)`` puts the step API into the generated
        ``.h``/``.c`` (``mbgen generate`` writes it; ``--step`` asks for it
        without the scene).  None: the outputs only.
    saturate : bool
        Clamp every input to its bounds (the model's ``Model.bound`` records of inputs,
        e.g. a URDF joint's ``<limit effort>``: :meth:`input_bounds`) before the
        right-hand side reads it, in the generated step API (its header states the
        bounds as ``<prefix>_input_lower`` / ``_upper``; ``mem->n_saturated`` counts the
        clamped inputs) and the FMU (``fmi2SetReal`` stores an input clamped); ``mbgen
        simulate`` follows it (``--saturate`` / ``--no-saturate`` overrides), as does
        :func:`mbgen.simulate` given ``saturate=scene.input_bounds()``.  Default False:
        the generated code is what it is without bounds.  Speed and coordinate bounds are
        never applied (clamping a state inside an integrator is not physics): they stay
        data, ``model.bounds("speeds")``, to check a trajectory against.
    """

    name: str
    model: Model | Equations
    parameters: Mapping[str, float] = field(default_factory=dict)
    initial_state: Mapping[str, float] = field(default_factory=dict)
    t_span: tuple[float, float] = (0.0, 10.0)
    outputs: tuple = (Output.RHS,)
    description: str = ""
    closed_form: Callable | None = None
    conserves_energy: bool = False
    fixed: Mapping[str, float] = field(default_factory=dict)
    inputs: tuple[str, ...] | None = None
    points: tuple[str, ...] = ()
    prefix: str | None = None
    options: Mapping[str, Any] = field(default_factory=dict)
    source: str = ""
    method: Any = None
    targets: Any = None
    saturate: bool = False

    def __post_init__(self):
        try:
            check_name(self.name, "scene")
            if self.prefix is not None:
                check_name(self.prefix, "C prefix")
        except ModelError as exc:
            raise SceneError(str(exc)) from None
        for what in ("parameters", "fixed", "initial_state"):
            values = getattr(self, what)
            if not isinstance(values, Mapping):
                raise SceneError(f"scene {self.name!r}: {what} must be a mapping name -> number, "
                                 f"got {type(values).__name__}")
            for key, value in values.items():
                finite_number(value, f"scene {self.name!r}: {what}[{key!r}]")
        span = self.t_span
        if not isinstance(span, (tuple, list)) or len(span) != 2:
            raise SceneError(f"scene {self.name!r}: t_span must be (t0, t_end), got {span!r}")
        t0 = finite_number(span[0], f"scene {self.name!r}: t_span[0]")
        t1 = finite_number(span[1], f"scene {self.name!r}: t_span[1]")
        check_span(t0, t1, f"scene {self.name!r}: t_span")
        _check_symbol_names(self)
        _check_targets(self)
        _check_saturate(self)
        if isinstance(self.model, Equations):  # a Model checks its size as it is built
            L = self.model.layout
            check_size(L.n_u + L.n_d, f"scene {self.name!r}")
            if self.prefix is None and self.model.name == UNNAMED:
                object.__setattr__(self, "prefix", self.name)

    def x0(self, layout) -> np.ndarray:
        """Initial state as an array in ``layout`` order; unknown names are an error."""
        unknown = set(self.initial_state) - set(layout.state_names)
        if unknown:
            raise SceneError(f"scene {self.name!r}: initial_state names {sorted(unknown)} are not "
                             f"states; states are {list(layout.state_names)}")
        return np.array([float(self.initial_state.get(n, 0.0)) for n in layout.state_names])

    def input_bounds(self) -> dict[str, tuple[float, float]]:
        """``{input: (lower, upper)}`` of the model's bounded inputs that the scene keeps
        (``Model.bounds("inputs")``; an unbounded side is an infinity; equations imported
        without a model have none): what ``saturate`` clamps to."""
        if not isinstance(self.model, Model):
            return {}
        kept = self.inputs
        return {n: b for n, b in self.model.bounds("inputs").items()
                if kept is None or n in kept}

    def p(self, layout) -> np.ndarray:
        """Parameter values in ``layout`` order; every parameter needs a value."""
        values = {**self.parameters, **self.fixed}
        missing = [n for n in layout.parameter_names if n not in values]
        if missing:
            raise SceneError(f"scene {self.name!r} gives no value for parameter(s) {missing}")
        return np.array([float(values[n]) for n in layout.parameter_names])


def finite_number(value, what: str) -> float:
    """``value`` as a float if it is a finite real number, else a :class:`SceneError`."""
    if isinstance(value, (bool, str, bytes)) or not isinstance(value, (numbers.Real, np.floating,
                                                                      np.integer)):
        try:  # sympy numbers
            import sympy as sm

            if isinstance(value, sm.Basic) and value.is_number and value.is_real:
                value = float(value)
            else:
                raise TypeError
        except (TypeError, ValueError):
            raise SceneError(f"{what} must be a real number, got {type(value).__name__} "
                             f"{_shown(value)}") from None
    try:
        number = float(value)
    except (OverflowError, ValueError):
        number = math.inf
    if not math.isfinite(number):
        raise SceneError(f"{what} is {_shown(value)}; it must be a finite number")
    return number


def check_span(t0: float, t_end: float, what: str = "time span") -> None:
    """Refuse a span that is not finite or does not increase (``t_end > t0``)."""
    for v in (t0, t_end):
        if not math.isfinite(v):
            raise SceneError(f"{what}: {t0!r} .. {t_end!r} is not finite; give a finite end time")
    if not t_end > t0:
        raise SceneError(f"{what}: the end time {t_end!r} must be after the start {t0!r}")


def _shown(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:50] + "..."


def model_names(model) -> dict[str, list[str]] | None:
    """Names a scene may refer to, by kind (None: an object we cannot inspect)."""
    if isinstance(model, Model):
        return dict(parameters=[str(c) for c in model.constants_],
                    states=[str(s.func) for s in model.coordinates_ + model.speeds_],
                    inputs=[str(s.func) for s in model.inputs_],
                    points=[p.name for p in model.points if p is not model.origin])
    if isinstance(model, Equations):
        L = model.layout
        return dict(parameters=list(L.parameter_names),
                    states=list(L.state_names) + [str(u) for u in L.dependent_speeds],
                    inputs=list(L.input_names), points=[pk.name for pk in model.points])
    return None


def _check_symbol_names(scn: Scene) -> None:
    """Every name the scene gives must exist in its model (once, where the scene is made)."""
    known = model_names(scn.model)
    if known is None:
        raise SceneError(f"scene {scn.name!r}: model must be an mbgen Model or Equations, got "
                         f"{type(scn.model).__name__}")
    checks = [("parameters", scn.parameters, "parameters", "a constant"),
              ("fixed", scn.fixed, "parameters", "a constant"),
              ("initial_state", scn.initial_state, "states", "a coordinate or speed"),
              ("inputs", scn.inputs or (), "inputs", "an input"),
              ("points", scn.points, "points", "a point")]
    for field_name, given, kind, noun in checks:
        if isinstance(given, str):
            raise SceneError(f"scene {scn.name!r}: {field_name} must be a tuple of names, not "
                             f"the string {given!r}")
        for name in given:
            if name not in known[kind]:
                listed = ", ".join(known[kind][:12]) + (" ..." if len(known[kind]) > 12 else "")
                raise SceneError(
                    f"scene {scn.name!r}: {field_name} names {str(name)!r}, which is not "
                    f"{noun} of model {getattr(scn.model, 'name', '?')!r}"
                    f"{did_you_mean(name, known[kind])} ({kind}: {listed or 'none'})")


def _check_targets(scn: Scene) -> None:
    """``targets`` is None or a :class:`mbgen.Targets` (a dataclass of switches)."""
    targets = scn.targets
    if targets is None:
        return
    if not dataclasses.is_dataclass(targets) or isinstance(targets, type) or not all(
            isinstance(getattr(targets, f.name), bool) for f in dataclasses.fields(targets)):
        raise SceneError(f"scene {scn.name!r}: targets must be mbgen.Targets(...), e.g. "
                         f"targets=mbgen.Targets(step=True); got {_shown(targets)}")


def _check_saturate(scn: Scene) -> None:
    """``saturate`` is a bool, and True only where the scene keeps a bounded input."""
    if not isinstance(scn.saturate, bool):
        raise SceneError(f"scene {scn.name!r}: saturate must be True or False; got "
                         f"{_shown(scn.saturate)}")
    if scn.saturate and not scn.input_bounds():
        raise SceneError(f"scene {scn.name!r}: saturate=True, but no input it keeps has "
                         f"bounds; bound one with Model.bound(input, lower, upper) (a URDF "
                         f"joint's <limit effort> does it), or leave saturate off")


def source_label(scn: Scene) -> str:
    """The scene's name and file as generated files record them: ``scene 'x' (x.py)``.

    Only the file's name is recorded, never the path as typed, so the
    generated bytes do not depend on the folder mbgen was run from.
    """
    if not scn.source:
        return f"scene {scn.name!r}"
    source = scn.source if scn.source.startswith("mbgen/scenes/") else Path(scn.source).name
    return f"scene {scn.name!r} ({source})"


def builtin_names() -> list[str]:
    """Names of the built-in scenes (modules of :mod:`mbgen.scenes`)."""
    return sorted(m.name for m in pkgutil.iter_modules(scenes.__path__)
                  if not m.name.startswith("_"))


def _require_file(path: Path, what: str) -> None:
    """``SceneError`` unless ``path`` is a regular file: missing, or what it is instead
    (a folder, a pipe, a device), never read."""
    if not os.path.lexists(path):
        raise SceneError(f"{what} {str(path)!r} does not exist")
    require_regular_file(path, what, SceneError)


def _module_for(name_or_path: str):
    path = Path(name_or_path)
    if name_or_path in builtin_names():
        return (importlib.import_module(f"mbgen.scenes.{name_or_path}"),
                f"mbgen/scenes/{name_or_path}.py")
    if path.suffix == ".py":
        _require_file(path, "scene file")
        spec = importlib.util.spec_from_file_location(f"mbgen_user_scene_{path.stem}", path)
        module = importlib.util.module_from_spec(spec)
        try:
            spec.loader.exec_module(module)
        except Exception as exc:
            raise SceneError(f"scene file {str(path)!r} failed to import: "
                             f"{type(exc).__name__}: {exc}") from exc
        return module, str(path.resolve())
    if name_or_path in ROBOTS and not os.path.lexists(path):   # example-robot-data's
        path = _robot_file(name_or_path)
    if path.suffix.lower() == ".urdf":
        _require_file(path, "URDF file")

        def scene(floating: bool = False, saturate: bool = False, ground: str = "",
                  hold: str = "", drop: float = DROP) -> Scene:
            return urdf_scene(path, floating=floating, saturate=saturate, ground=ground,
                              hold=hold, drop=drop)
        return SimpleNamespace(scene=scene), str(path.resolve())
    if path.suffix.lower() == ".xml":
        _require_file(path, "MJCF file")

        def mjcf(ground: str = "", hold: str = "", drop: float = DROP) -> Scene:
            return mjcf_scene(path, ground=ground, hold=hold, drop=drop)
        return SimpleNamespace(scene=mjcf), str(path.resolve())
    raise SceneError(f"no scene {name_or_path!r}: built-in scenes are "
                     f"{', '.join(builtin_names())}; or give the path of a .py scene file "
                     f"or a .urdf or MJCF (.xml) robot, or name one of example-robot-data's "
                     f"({', '.join(ROBOTS)})")


def _robot_file(name: str) -> Path:
    """The URDF file of a robot of :data:`mbgen.model.robots.ROBOTS`, or a SceneError."""
    found = robot_path(name)
    if found is None:
        raise SceneError(f"scene {name!r} is example-robot-data's robot, which is not "
                         f"installed: pip install example-robot-data (or give a .urdf path)")
    return found


def urdf_scene(path, *, floating: bool = False, saturate: bool = False, ground=(),
               hold=None, drop: float = DROP) -> Scene:
    """The scene of a URDF robot (``mbgen check robot.urdf``; options ``floating`` and
    ``saturate``: the joint torques clamped to ``<limit effort>``, :class:`Scene`; and
    ``ground``, ``hold``, ``drop`` below).

    The model is :func:`mbgen.from_urdf`'s; ``g = 9.81``; it starts at rest with
    every joint at zero (and the identity quaternion for a floating base) and runs
    for a second.  Its outputs are the right-hand side and the C ``dopri5`` integrator
    (``mbgen simulate robot.urdf --integrator dopri5`` needs no Jacobian).

    ``ground`` (link names, ``"A,B"`` on the command line: ``--ground``) puts the robot on
    a compliant ground (:mod:`mbgen.model.ground`) touched at those links; ``hold``
    (``(kp, kd)`` or ``"KP,KD"``: ``--hold``) holds the joints at the initial posture
    (:mod:`mbgen.model.hold`).  With a ground the scene is stiff: its outputs are the
    right-hand side, the Jacobian and the C ``rosenbrock`` integrator, its points the
    contacts (for ``Output.POSITIONS``); a floating base starts with its lowest contact
    ``drop`` (m) above the ground, and it runs for 3 s.
    """
    robot = read_urdf(path)
    model = build_model(robot, floating=floating, ground=ground or None)
    joints = len(model.coordinates_) - (7 if floating else 0)
    state, outputs, span, points, what = _standing(
        model, {"root_qw": 1.0} if floating else {}, hold, drop)
    return Scene(name=model.name, model=model, parameters=dict(model.defaults_),
                 initial_state=state, t_span=span, points=points,
                 outputs=outputs, source=str(Path(path).resolve()),
                 saturate=saturate,
                 description=f"URDF robot {robot.name!r}: {joints} joints"
                             f"{', floating base' if floating else ''}, gravity{what}")


def _standing(model, state: dict, hold, drop: float):
    """``(initial state, outputs, t_span, points, words)`` of a robot's scene: its joints
    held (``hold``), and on its ground (if it has one) a floating base lifted so that the
    lowest contact starts ``drop`` up, outputs for a stiff model, 3 s, the contacts."""
    words = ""
    if hold:
        hold_posture(model, *hold_gains(hold))
        words = ", holding its posture"
    if model.ground_ is None:
        return state, (Output.RHS, Output.DOPRI5), (0.0, 1.0), (), words
    if free_height(model) is not None:
        state = drop_state(model, state, drop)
    points = tuple(p.name for p in model.ground_.points)
    return (state, (Output.RHS, Output.JACOBIAN, Output.ROSENBROCK), (0.0, 3.0), points,
            f", on a ground under {', '.join(points)}{words}")


def mjcf_scene(path, *, ground=(), hold=None, drop: float = DROP) -> Scene:
    """The scene of a MuJoCo model file (``mbgen check robot.xml``; :func:`mbgen.from_mjcf`).

    Named after the file (``cartpole.xml``: ``cartpole``); ``g`` is ``|opt.gravity|`` (0
    under ``<flag gravity="disable"/>``); it starts at MuJoCo's ``qpos0`` at rest and runs
    for a second; outputs as :func:`urdf_scene`'s, and so are ``ground`` (sphere geoms and
    sites), ``hold`` and ``drop``.
    """
    mj = compile_mjcf(path)
    model = from_mujoco(mj, name=file_model_name(path), ground=ground or None)
    parameters, initial = scene_values(mj)
    state, outputs, span, points, what = _standing(model, initial, hold, drop)
    return Scene(name=model.name, model=model,
                 parameters={**model.defaults_, **parameters}, initial_state=state,
                 t_span=span, outputs=outputs, points=points,
                 source=str(Path(path).resolve()),
                 description=f"MuJoCo model {model.name!r}: {mj.njnt} joints, {mj.nv} "
                             f"speeds{what}")


def scene_options(name_or_path: str) -> dict[str, Any]:
    """Options of a scene and their defaults (from the signature of its ``scene``)."""
    module, _ = _module_for(name_or_path)
    fn = _scene_function(module, name_or_path)
    return {k: v.default for k, v in inspect.signature(fn).parameters.items()
            if v.default is not inspect.Parameter.empty}


def scene_module(name_or_path: str):
    """The module of a built-in scene (or a scene file), for the helpers it defines
    besides ``scene()`` (e.g. ``scene_module("four_bar").dead_angle``)."""
    return _module_for(name_or_path)[0]


def _scene_function(module, name):
    fn = getattr(module, "scene", None)
    if not callable(fn):
        raise SceneError(f"scene {name!r} defines no function scene(**options) -> Scene")
    return fn


def load_scene(name_or_path: str, *, force: bool = False, **options) -> Scene:
    """Build a built-in scene by name, or a scene file by path.

    A scene file is Python and runs when it is loaded, with the caller's rights (mbgen
    does not sandbox it): trust a scene file as you trust code.

    Options are passed to the scene's ``scene(**options)``; string values (from
    the command line) are converted to the type of the option's default: a
    float option must be finite, an int option integral, a bool option one
    of ``1 0 true false yes no``.  ``force=True`` builds models beyond the
    size guard (:data:`mbgen.model.limits.MAX_SPEEDS`).

    Raises
    ------
    SceneError
        Unknown scene, missing file, unknown option or a bad option value, a
        file that fails, or a scene that fails validation (see the module
        docstring).
    ModelSizeError
        The scene's model is far too large (unless ``force``).
    """
    module, source = _module_for(name_or_path)
    fn = _scene_function(module, name_or_path)
    params = inspect.signature(fn).parameters
    typed = {}
    for key, value in options.items():
        if key not in params:
            raise SceneError(f"scene {name_or_path!r} has no option {key!r}; options: "
                             f"{', '.join(params) or 'none'}")
        default = params[key].default
        if isinstance(value, str) and default is not inspect.Parameter.empty and \
                not isinstance(default, str):
            value = _option_value(key, value, default, name_or_path)
        typed[key] = value
    try:
        if force:
            with allow_large_models():
                scn = fn(**typed)
        else:
            scn = fn(**typed)
    except SceneError:
        raise
    except Exception as exc:
        if type(exc).__module__.startswith("mbgen"):
            raise
        raise SceneError(f"scene {name_or_path!r} failed: {type(exc).__name__}: {exc}") from exc
    if not isinstance(scn, Scene):
        raise SceneError(f"scene {name_or_path!r}: scene() returned {type(scn).__name__}, "
                         f"not a Scene")
    merged = {k: v.default for k, v in params.items() if v.default is not inspect.Parameter.empty}
    merged.update(typed)
    return _with(scn, options=merged, source=scn.source or source)


_BOOLS = {"1": True, "true": True, "yes": True, "on": True,
          "0": False, "false": False, "no": False, "off": False}


def _option_value(key: str, text: str, default, scene: str):
    """Convert the option text ``text`` to the type of ``default`` (finite, integral, ...)."""
    what = f"option {key}={text!r} of scene {scene!r}"
    if isinstance(default, bool):
        try:
            return _BOOLS[text.strip().lower()]
        except KeyError:
            raise SceneError(f"{what} must be true or false (1/0, yes/no)") from None
    if isinstance(default, int):
        try:
            return int(text.strip(), 10)
        except ValueError:
            raise SceneError(f"{what} must be an integer (e.g. {key}={default})") from None
    if isinstance(default, float):
        try:
            number = float(text)
        except ValueError:
            raise SceneError(f"{what} must be a number (e.g. {key}={default!r})") from None
        if not math.isfinite(number):
            raise SceneError(f"{what} is not a finite number (inf, nan and overflowing values "
                             f"such as 1e400 are refused)")
        return number
    try:
        return type(default)(text)
    except (TypeError, ValueError):
        raise SceneError(f"{what} must be {type(default).__name__}") from None


def _with(scn: Scene, **changes) -> Scene:
    return dataclasses.replace(scn, **changes)
