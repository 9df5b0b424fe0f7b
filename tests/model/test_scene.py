"""Scene fields checked where a scene is made: ``targets`` (what is rendered besides the
outputs) is an ``mbgen.Targets``, and the pipeline renders what it asks for."""

import pytest

import mbgen
from mbgen import Scene, Targets
from mbgen.errors import SceneError
from models import pendulum

PARAMETERS = {"l": 1.0, "g": 9.81, "m": 1.0}


def test_targets_ask_for_the_step_api():
    scene = Scene("pend", pendulum("pend"), parameters=PARAMETERS, targets=Targets(step=True),
                  outputs=("rhs", "dopri5"))
    result = mbgen.pipeline.run(scene, build=False)
    assert result.rendered.step_methods == ("rk4", "dopri5")
    assert "pend_dopri5_memory" in result.rendered.files["pend.h"]
    plain = mbgen.pipeline.run(Scene("pend", pendulum("pend"), parameters=PARAMETERS), build=False)
    assert plain.rendered.step_methods == ()


@pytest.mark.parametrize("targets", ["step", {"step": True}, Targets, ("step",)])
def test_targets_must_be_a_targets(targets):
    with pytest.raises(SceneError, match=r"targets must be mbgen.Targets\(\.\.\.\), e.g. "
                                         r"targets=mbgen.Targets\(step=True\)"):
        Scene("pend", pendulum("pend"), parameters=PARAMETERS, targets=targets)


@pytest.mark.parametrize("suffix", [".py", ".urdf", ".xml"])
def test_a_scene_path_that_is_a_folder_is_named_for_what_it_is(tmp_path, suffix):
    """load_scene (what `mbgen bench SCENE` and the library call) says what the path is,
    as the CLI does: not "does not exist" (issue 28, item 5)."""
    folder = tmp_path / f"robot{suffix}"
    folder.mkdir()
    with pytest.raises(SceneError, match=r"is a folder, not a file"):
        mbgen.load_scene(str(folder))
    with pytest.raises(SceneError, match="does not exist"):
        mbgen.load_scene(str(tmp_path / f"missing{suffix}"))
