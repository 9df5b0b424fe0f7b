"""The model stage: what a user writes, checked as it is written.

* :mod:`~mbgen.model.builder` -- :class:`Model`, built method by method in the
  SOPHIA style (coordinates, speeds, constants, inputs, frames by simple
  rotations, points, particles and rigid bodies, loads, joints, constraints),
  and the time symbol :data:`t`;
* :mod:`~mbgen.model.elements` -- the frozen records a ``Model`` holds
  (``FrameDef``, ``Particle``, ``Force``, ``LineElement``, ``Constraint``, ...);
* :mod:`~mbgen.model.limits` -- the size guard (``MAX_SPEEDS``, ``MAX_BODIES``,
  ``allow_large_models``);
* :mod:`~mbgen.model.expressions` -- values given as text, parsed without ``eval``;
* :mod:`~mbgen.model.kinematics` -- the SOPHIA-named vector helpers;
* :mod:`~mbgen.model.scene` -- :class:`Scene` (a model plus its numbers and
  outputs) and :func:`load_scene` for built-in scenes and scene files;
* :mod:`~mbgen.model.summary` -- a model's notebook summary;
* :mod:`~mbgen.model.urdf` -- :func:`~mbgen.model.urdf.from_urdf`, a robot's URDF file as a
  ``Model`` (Pinocchio's conventions), read and checked by :mod:`~mbgen.model.urdf_xml`, its
  joints' mimics, dynamics and limits as :mod:`~mbgen.model.urdf_joints` says;
* :mod:`~mbgen.model.mjcf` -- :func:`~mbgen.model.mjcf.from_mjcf` and
  :func:`~mbgen.model.mjcf.from_mujoco`, a MuJoCo model (compiled by MuJoCo, the
  ``mujoco`` extra) as a ``Model`` (MuJoCo's ``qpos``/``qvel`` conventions); what MuJoCo
  would read is checked first by :mod:`~mbgen.model.mjcf_xml` (pipes, numbers, sizes);
  what else the compiled model says (options, flags, actuators) is honoured, refused or
  dropped with one warning by :mod:`~mbgen.model.mjcf_physics`;
* :mod:`~mbgen.model.files` -- a path read only if it is a regular file (else named for
  what it is: a folder, a pipe, a device);
* :mod:`~mbgen.model.free_base` -- a floating base must move mass whichever way it moves
  (its articulated-body inertia), checked by both robot readers.
* :mod:`~mbgen.model.ground` -- a compliant ground (``Model.ground``) as ordinary loads;
  :mod:`~mbgen.model.hold` -- a joint PD hold so a robot can stand on it;
  :mod:`~mbgen.model.robots` -- ``example-robot-data``'s robots by name (``solo12``).

Nothing here derives, generates or runs anything: this package imports only
the layers below it (``symbolic``, ``names``, ``abi``, ``summary``, ``errors``).

How to add a model element
--------------------------
(a new kind of load, mass or constraint; e.g. a torsional spring)

1. ``model/elements.py``: a frozen record holding what the user gave.
2. ``model/builder.py``: a :class:`Model` method that checks its arguments
   (``_check_point``, ``_check_frame``, ``_scalar``, a name through ``_claim``)
   and appends the record (a load goes to ``Model.loads``).
3. ``derive/prepare.py``: turn the record into plain symbols and tree terms on
   :class:`~mbgen.derivation.prepare.Prepared` (an unknown load is refused there with
   a ``ModelError``); then let every derivation method use it:
   ``derive/kane.py`` (generalized forces), ``derive/recursion.py``
   (``NewtonEuler._collect_loads``: body wrenches), and ``derive/common.py``
   (``energies``) when it has a potential.
   An element made of the loads above (``Model.ground``: forces and torques whose
   vectors hold the law) stops here: every derivation already takes them.
4. Tests: add it to ``loaded()`` in ``tests/derivation/test_derive.py``, which fails when
   a derivation method misses it (every method must agree with Kane), and
   check its physics against a derivation by hand in ``tests/scenes/test_physics.py``.
"""

from . import kinematics
from .builder import Model, t
from .scene import Scene, load_scene

__all__ = ["Model", "Scene", "kinematics", "load_scene", "t"]
