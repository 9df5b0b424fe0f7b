"""Robots by name: the URDF files of ``example-robot-data`` that a scene name may stand for.

``mbgen simulate solo12 --floating`` reads ``solo12`` as the file :data:`ROBOTS` names under
``example-robot-data``'s ``robots`` folder (the ``example-robot-data`` wheel, which
Pinocchio's ``pin`` wheel brings along, installs it under ``cmeel.prefix/share``); a scene
of that name, built in or a file, would come first.  ``mbgen bench robot`` reads the
same table (:mod:`mbgen.bench.robot_peers`).

How to add a robot
------------------
1. A row in :data:`ROBOTS`: its name, its path under ``robots/``, and whether it is
   usually simulated on a floating base (the benchmark's default).
2. ``tests/model/test_robots.py`` finds each row's file where the data is
   installed.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

#: Robot name -> (path under example-robot-data's ``robots`` folder, floating base).
ROBOTS = {"panda": ("panda_description/urdf/panda.urdf", False),
          "ur5": ("ur_description/urdf/ur5_robot.urdf", False),
          "solo12": ("solo_description/robots/solo12.urdf", True),
          "g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", True)}

_DATA = Path("share") / "example-robot-data" / "robots"


def data_folders() -> list[Path]:
    """Where ``example-robot-data``'s ``robots`` folder may be: under ``cmeel.prefix`` of
    each ``site-packages`` on the path, above the ``pinocchio`` package (found, not
    imported) and under the interpreter's prefix."""
    roots = [Path(p) / "cmeel.prefix" for p in sys.path if p]
    spec = importlib.util.find_spec("pinocchio")
    if spec is not None and spec.origin:
        roots += list(Path(spec.origin).resolve().parents)
    roots.append(Path(sys.prefix))
    return [root / _DATA for root in dict.fromkeys(roots)]


def robot_path(name: str) -> Path | None:
    """The URDF file of robot ``name`` (a key of :data:`ROBOTS`), None where
    ``example-robot-data`` is not installed."""
    relative = ROBOTS[name][0]
    return next((folder / relative for folder in data_folders()
                 if (folder / relative).is_file()), None)


__all__ = ["ROBOTS", "data_folders", "robot_path"]
