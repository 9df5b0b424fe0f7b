"""``mbgen simulate ROBOT.urdf --ground LINKS --hold KP,KD`` (and ``--floating``): the
flags set the robot scene's options, auto integrates with the C rosenbrock, ``-x`` moves
the held posture with the start, and the flags are refused, before any work, where the
scene is no robot's.

The robot: an arm turning about y at 0.3 m above the ground, a tip 0.4 m out on a link
fixed to it (the ground's point).
"""

import numpy as np
import pytest
from scipy.optimize import brentq

from mbgen.cli import EXIT_MODEL, EXIT_USAGE, main
from urdf_models import LIMIT, inertial, joint, link, urdf, write

ARM = [link("base", inertial(2.0)), link("arm", inertial(1.0, "0 0 -0.2")),
       link("tip", inertial(0.1)),
       joint("pivot", "revolute", "base", "arm", "0 0 0.3", axis="0 1 0", extra=LIMIT),
       joint("weld", "fixed", "arm", "tip", "0 0 -0.4")]


def test_an_arm_held_up_and_held_into_the_ground(tmp_path, monkeypatch, capsys):
    """Started at 1 rad: held there (the reference follows ``-x``) it sags to where the
    spring carries gravity's moment, ``20 (1 - q) = (1.0 * 0.2 + 0.1 * 0.4) g sin q``; held
    at 0.3 rad (``-p q_pivot_ref=0.3``, no friction) it comes down and rests on its tip,
    sunk less than 5 mm."""
    path = write(tmp_path, urdf(ARM, "arm"))
    monkeypatch.chdir(tmp_path)
    finals = []
    for extra in ([], ["-p", "q_pivot_ref=0.3", "-p", "mu=0"]):
        assert main(["simulate", path, "--ground", "tip", "--hold", "20,1", "--t-end", "6",
                     "-x", "q_pivot=1", "--quiet", "--points", "11", *extra]) == 0
        out = capsys.readouterr().out
        assert "C rosenbrock (stiff: the model's generated C integrator 'rosenbrock')" in out
        finals.append(np.loadtxt(tmp_path / "arm.csv", delimiter=",", skiprows=1)[-1, 1:])
    (q_up, u_up), (q_down, u_down) = finals
    sag = brentq(lambda q: 20 * (1 - q) - 0.24 * 9.81 * np.sin(q), 0.5, 1.0)
    assert abs(q_up - sag) < 1e-6 and abs(u_up) < 1e-6
    tip = 0.3 - 0.4 * np.cos(q_down)
    assert -5e-3 < tip < 0 and abs(u_down) < 1e-6


@pytest.mark.parametrize("argv, code, message", [
    (["simulate", "disc_pendulum", "--ground", "P"], EXIT_USAGE,
     "--ground set the options of a robot's scene"),
    (["simulate", "ROBOT", "--floating", "--ground", "toe"], EXIT_MODEL,
     "has no link 'toe' for the ground"),
    (["simulate", "ROBOT", "--hold", "20"], EXIT_MODEL, "give the gains as KP,KD"),
])
def test_the_flags_are_checked_first(argv, code, message, tmp_path, monkeypatch, capsys):
    path = write(tmp_path, urdf(ARM, "arm"))
    monkeypatch.chdir(tmp_path)
    assert main([path if a == "ROBOT" else a for a in argv]) == code
    assert message in capsys.readouterr().err
