"""MJCF from other hands: dm_control's suite models against MuJoCo's ``mj_forward`` (issue 30).

The files as ``dm_control`` ships them (``dm_control/suite/<name>.xml``, which include
``./common/*.xml``), found with ``importlib.util.find_spec`` so that nothing of
``dm_control`` is imported (its suite modules load OpenGL).  Each is read by
:func:`mbgen.from_mjcf` as a new user would, warned about once (contacts, limits, the
clamping of ``ctrl``), compiled, and compared with ``mj_forward`` at random states,
``qfrc_applied`` and ``ctrl`` (within ``ctrlrange``): contacts, limits, equality constraints
and friction loss off, actuation on, the file's own flags kept (``finger.xml`` disables
gravity), to 1e-9 relative (:func:`test_mjcf.compare`).

``swimmer.xml`` is the file as shipped (the head alone: two slides and a hinge; the
``swimmer`` task adds its links in code, ``swimmer.get_model_and_assets``, which needs
dm_control's suite imported): refused for its fluid forces (``density``), and compared with
the density set to zero in the compiled model.

The files' joint armature is ``Model.armature`` on each joint's diagonal, so cheetah, hopper,
walker and humanoid keep the file's joint tree and are derived by Newton–Euler (the
articulated-body recursion, armature in its pivots), as the default choice has it.

Fast by default: finger (its gravity flag, two geared motors), humanoid (27 speeds, about
8 s to generate and compile; 62 s by Kane's method when its armature was rotor bodies) and
swimmer; the rest are ``slow`` (one to two seconds each).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

import mbgen
from mbgen.abi import Output
from mbgen.errors import MjcfError, ModelWarning
from mbgen.model.elements import Gravity
from mbgen.model.mjcf import scene_values
from mbgen.model.scene import Scene
from mbgen.pipeline import run
from mujoco_models import RTOL, compare

mujoco = pytest.importorskip("mujoco")


def suite_file(name: str) -> Path:
    spec = importlib.util.find_spec("dm_control")
    if spec is None or not spec.submodule_search_locations:
        pytest.skip("dm_control is in the test extra")
    return Path(next(iter(spec.submodule_search_locations))) / "suite" / f"{name}.xml"


#: name: (nq, nv, actuators read, gravity on, what the load warning names)
MODELS = {
    "acrobot": (2, 2, 1, True, ["ctrl to ctrlrange ('elbow')"]),
    "cartpole": (2, 2, 1, True, ["limits of 'slider'", "ctrl to ctrlrange ('slide')"]),
    "finger": (3, 3, 2, False, ["contacts", "limits of 'proximal', 'distal'",
                                "friction loss of 'hinge'"]),
    "cheetah": (9, 9, 6, True, ["contacts", "limits of 'bthigh'"]),
    "hopper": (7, 7, 4, True, ["contacts", "limits of 'waist'"]),
    "walker": (9, 9, 6, True, ["contacts", "limits of 'right_hip'"]),
    "humanoid": (28, 27, 21, True, ["contacts", "limits of 'abdomen_z'"]),
}
FAST = {"finger"}
#: The models whose joint tree the default choice derives by Newton–Euler.
NEWTON_EULER = {"cheetah", "hopper", "walker", "humanoid"}


@pytest.mark.parametrize("name", [
    pytest.param(name, marks=() if name in FAST else pytest.mark.slow) for name in MODELS])
def test_suite_model_matches_mj_forward_with_actuation_on(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)         # MuJoCo logs cheetah's deprecation warning to ./
    path = suite_file(name)
    nq, nv, nu, gravity, named = MODELS[name]
    with pytest.warns(ModelWarning) as caught:
        model = mbgen.from_mjcf(path)
    assert len(caught) == 1
    for part in named:
        assert part in str(caught[0].message), (part, str(caught[0].message))
    assert model.name == name                       # the file's name, not <mujoco model>
    mj = mujoco.MjModel.from_xml_path(str(path))
    assert (mj.nq, mj.nv, mj.nu) == (nq, nv, nu)
    parameters, initial = scene_values(mj)
    assert (parameters["g"] > 0) == gravity         # finger.xml: <flag gravity="disable"/>
    assert any(isinstance(load, Gravity) for load in model.loads) == gravity
    result = run(Scene(name=model.name, model=model, parameters=parameters,
                       initial_state=initial, t_span=(0.0, 1.0), outputs=(Output.RHS,)))
    compiled = result.compiled
    if name in NEWTON_EULER:
        assert result.equations.method == "newton_euler", result.equations.method_reason
    inputs = list(compiled.layout.input_names)
    assert len(inputs) == nv + nu and all(n.startswith("ctrl_") for n in inputs[nv:])
    assert compare(mj, [compiled], samples=6, seed=5) <= RTOL


class _Lambdified:
    def __init__(self, mj):
        self.model = mbgen.LambdifiedModel(mbgen.equations_of(mbgen.from_mujoco(mj)),
                                           outputs=(Output.RHS,))
        self.p = [scene_values(mj)[0]["g"]]

    def rhs(self, t, x, p, r):
        return self.model.rhs(t, x, self.p, r)


def test_swimmer_is_refused_for_its_fluid_forces_and_matches_without_them(tmp_path,
                                                                         monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = suite_file("swimmer")
    with pytest.raises(MjcfError, match=r"fluid forces \(option density"):
        mbgen.from_mjcf(path)
    mj = mujoco.MjModel.from_xml_path(str(path))
    mj.opt.density = 0.0
    compare(mj, [_Lambdified(mj)], samples=4)
