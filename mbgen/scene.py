"""Scenes: a model plus what to do with it.

A scene file is a Python file with a function ``scene(**options) -> Scene``.
Built-in scenes live in :mod:`mbgen.scenes`; a user's own file works the same
way (``mbgen check path/to/my_scene.py``)::

    from mbgen import Model, Scene

    def scene(n: int = 3) -> Scene:
        m = Model("my_model")
        ...
        return Scene(name="my_model", model=m, parameters={"g": 9.81},
                     initial_state={"q1": 0.1, "u1": 0.0}, t_span=(0.0, 10.0))
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import pkgutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from .equations import Equations
from .errors import SceneError
from .model import Model
from .optimize import Output


@dataclass(frozen=True)
class Scene:
    """A model, its numbers, and what to generate.

    Attributes
    ----------
    name : str
        Scene name (also the folder name under ``generated/``).
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
        C prefix of the generated code (default: the model name); give two
        slices of one model different prefixes to link them into one program.
    options : mapping
        The options the scene was built with.
    source : str
        File the scene came from.
    method : Method or None
        Derivation method (None: Kane's method; ``Method.NEWTON_EULER`` for
        joint reactions and the articulated-body recursion of long chains).
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

    def x0(self, layout) -> np.ndarray:
        """Initial state as an array in ``layout`` order; unknown names are an error."""
        unknown = set(self.initial_state) - set(layout.state_names)
        if unknown:
            raise SceneError(f"scene {self.name!r}: initial_state names {sorted(unknown)} are not "
                             f"states; states are {list(layout.state_names)}")
        return np.array([float(self.initial_state.get(n, 0.0)) for n in layout.state_names])

    def p(self, layout) -> np.ndarray:
        """Parameter values in ``layout`` order; every parameter needs a value."""
        values = {**self.parameters, **self.fixed}
        missing = [n for n in layout.parameter_names if n not in values]
        if missing:
            raise SceneError(f"scene {self.name!r} gives no value for parameter(s) {missing}")
        return np.array([float(values[n]) for n in layout.parameter_names])


def builtin_names() -> list[str]:
    """Names of the built-in scenes (modules of :mod:`mbgen.scenes`)."""
    from . import scenes

    return sorted(m.name for m in pkgutil.iter_modules(scenes.__path__) if not m.name.startswith("_"))


def _module_for(name_or_path: str):
    path = Path(name_or_path)
    if name_or_path in builtin_names():
        return importlib.import_module(f"mbgen.scenes.{name_or_path}"), f"mbgen/scenes/{name_or_path}.py"
    if path.suffix == ".py":
        if not path.is_file():
            raise SceneError(f"scene file {str(path)!r} does not exist")
        spec = importlib.util.spec_from_file_location(f"mbgen_user_scene_{path.stem}", path)
        module = importlib.util.module_from_spec(spec)
        try:
            spec.loader.exec_module(module)
        except Exception as exc:
            raise SceneError(f"scene file {str(path)!r} failed to import: "
                             f"{type(exc).__name__}: {exc}") from exc
        return module, str(path)
    raise SceneError(f"no scene {name_or_path!r}: built-in scenes are "
                     f"{', '.join(builtin_names())}; or give the path of a .py scene file")


def scene_options(name_or_path: str) -> dict[str, Any]:
    """Options of a scene and their defaults (from the signature of its ``scene``)."""
    module, _ = _module_for(name_or_path)
    fn = _scene_function(module, name_or_path)
    return {k: v.default for k, v in inspect.signature(fn).parameters.items()
            if v.default is not inspect.Parameter.empty}


def _scene_function(module, name):
    fn = getattr(module, "scene", None)
    if not callable(fn):
        raise SceneError(f"scene {name!r} defines no function scene(**options) -> Scene")
    return fn


def load_scene(name_or_path: str, **options) -> Scene:
    """Build a built-in scene by name, or a scene file by path.

    Options are passed to the scene's ``scene(**options)``; string values (from
    the command line) are converted to the type of the option's default.

    Raises
    ------
    SceneError
        Unknown scene, missing file, unknown option, or a file that fails.
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
            try:
                value = type(default)(value) if not isinstance(default, bool) else \
                    value.lower() in ("1", "true", "yes")
            except ValueError:
                raise SceneError(f"option {key}={value!r} of scene {name_or_path!r} must be "
                                 f"{type(default).__name__}") from None
        typed[key] = value
    try:
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


def _with(scn: Scene, **changes) -> Scene:
    from dataclasses import replace

    return replace(scn, **changes)
