"""A model on a compliant ground is stiff, and simulate says so: ``stiff=True`` makes auto
take the generated C ``rosenbrock`` where compiled (and the inputs stay in C), else scipy's
``Radau``, never DOP853 first; a named method is still obeyed.  A point mass dropped on
the ground through Radau rests sunk by ``m g / k``.  Solo-12 (slow): dropped from 0.3 m on
its four feet with the joints held, it ends standing and at rest, its energy falling at
every output time; the run time is printed."""

import time

import numpy as np
import pytest

import mbgen
from mbgen import Model, Output
from mbgen.runtime.simulate import choose_method, simulate


class Fake:
    """Stands in for a compiled model: what choose_method reads."""

    name = "fake"

    def __init__(self, *outputs):
        self.outputs = outputs
        self.c_integrators = tuple(o for o in outputs if o.is_integrator)


@pytest.mark.parametrize("outputs, r, chosen", [
    ((Output.RHS, Output.JACOBIAN, Output.DOPRI5, Output.ROSENBROCK), None, "rosenbrock"),
    ((Output.RHS, Output.DOPRI5), None, "Radau"),
    ((Output.RHS, Output.JACOBIAN, Output.ROSENBROCK), lambda t, x: [0.0], "Radau"),
])
def test_stiff_auto_takes_an_implicit_method(outputs, r, chosen):
    method, why = choose_method(Fake(*outputs), None, r, stiff=True)
    assert method == chosen and why.startswith("stiff: ")
    assert choose_method(Fake(*outputs), "auto", r, stiff=True)[0] == chosen
    assert choose_method(Fake(*outputs), "RK45", r, stiff=True) == ("RK45", "as asked")
    if r is None and Output.DOPRI5 in outputs:
        assert choose_method(Fake(*outputs), None, r)[0] == "dopri5"   # not stiff: as before


def test_a_point_mass_rests_on_the_ground_through_radau():
    m = Model("drop")
    z, = m.coordinates("z")
    m.speeds("w")
    N = m.newtonian()
    m.particle("p", m.point("P", m.origin, z * N.z), 2.0)
    m.gravity(-9.81 * N.z)
    m.ground(["P"], k=2e4, c=50.0)
    c = mbgen.compile(m, (Output.RHS, Output.JACOBIAN))
    traj = simulate(c, [0.2, 0.0], (0.0, 3.0), stiff=True, rtol=1e-8, atol=1e-10)
    assert traj.method == "Radau" and "compiled Jacobian" in traj.message and traj.njev > 0
    assert traj.x[-1] == pytest.approx([-2.0 * 9.81 / 2e4, 0.0], abs=1e-7)


FEET = "FL_FOOT,FR_FOOT,HL_FOOT,HR_FOOT"


@pytest.mark.slow
def test_solo12_dropped_on_its_feet_ends_standing():
    """``mbgen simulate solo12 --floating --ground FL_FOOT,... --hold 50,0.5`` in Python:
    dropped with its feet 0.3 m up, it ends standing (the base above 0.3 m: its straight
    legs are 0.32 m long; every foot on the ground, sunk less than 2 mm), at rest (every
    speed below 2e-3), its energy -- kinetic, gravity, the ground's and the hold's springs
    -- falling at every output time (to 1e-6 of what the drop loses)."""
    pytest.importorskip("pinocchio", reason="example-robot-data comes with the pin wheel")
    from mbgen.model.hold import reference_name

    scene = mbgen.load_scene("solo12", floating="true", ground=FEET, hold="50,0.5")
    start = time.perf_counter()
    c = mbgen.compile(scene, scene.outputs + (Output.ENERGY, Output.POSITIONS))
    built = time.perf_counter() - start
    traj = simulate(c, scene.x0(c.layout), scene.t_span, n_out=601, stiff=True,
                    progress=False)
    print(f"\nsolo12 drop: compile {built:.1f} s, {traj.method}, {traj.nfev} RHS calls, "
          f"{traj.njev} Jacobians, {traj.wall_time:.3f} s for {scene.t_span[1]:g} s")
    assert traj.method == "C rosenbrock"
    p, names = c.parameter_defaults, c.state_names
    joints = [n for n in names[:c.layout.n_q] if reference_name(n) in p]
    feet = np.array([c.positions(0.0, x)[:, 2] for x in traj.x])   # (601, 4) heights
    assert feet[0] == pytest.approx([0.3] * 4)
    energy = []
    for x, h in zip(traj.x, np.minimum(feet, 0.0)):
        state = dict(zip(names, x))
        bent = np.array([state[q] - p[reference_name(q)] for q in joints])
        energy.append(c.energy(0.0, x).sum() + 0.5 * p["k_ground"] * h @ h
                      + 0.5 * p["kp_hold"] * bent @ bent)
    energy = np.array(energy)
    assert np.diff(energy).max() <= 1e-6 * (energy[0] - energy[-1])
    assert traj.x[-1, names.index("root_z")] > 0.3
    assert np.all((-2e-3 < feet[-1]) & (feet[-1] < 0))
    assert np.abs(traj.x[-1, c.layout.n_q:]).max() < 2e-3
