"""Robots by name (:mod:`mbgen.model.robots`): every row of ``ROBOTS`` is a file where
example-robot-data is installed, a scene name finds it (``mbgen simulate solo12``), the
benchmark reads the same table, and a missing install or an unknown name says what to do."""

import pytest

import mbgen
from mbgen.errors import SceneError
from mbgen.model import robots, scene
from mbgen.model.robots import ROBOTS, robot_path


def test_every_robot_is_found_and_is_the_benchmarks():
    pytest.importorskip("pinocchio", reason="example-robot-data comes with the pin wheel")
    from mbgen.bench import robot_peers

    assert robot_peers.ROBOTS is ROBOTS
    for name in ROBOTS:
        path = robot_path(name)
        assert path is not None and path.is_file() and path.suffix == ".urdf", name
        assert robot_peers.robot_file(name) == (path, ROBOTS[name][1])


def test_a_robot_name_is_a_scene():
    pytest.importorskip("pinocchio", reason="example-robot-data comes with the pin wheel")
    s = mbgen.load_scene("solo12", floating="true")
    assert s.model.name == "solo" and s.source == str(robot_path("solo12").resolve())
    assert "12 joints, floating base" in s.description
    assert {"ground", "hold", "drop", "floating"} <= set(scene.scene_options("solo12"))


def test_a_missing_robot_or_an_unknown_name_says_what_to_do(monkeypatch):
    monkeypatch.setattr(robots, "data_folders", lambda: [])
    with pytest.raises(SceneError, match="pip install example-robot-data"):
        mbgen.load_scene("solo12")
    with pytest.raises(SceneError, match="example-robot-data's \\(panda, ur5, solo12, g1\\)"):
        mbgen.load_scene("solo13")
