"""Physics oracle: every built-in scene's compiled RHS against sympy's ``KanesMethod``.

The scene's model is handed, load by load, to :mod:`sympy.physics.mechanics`
(particles, rigid bodies with their inertia dyadics, forces and torques with their
reactions, gravity on every mass, springs and dampers as the force
``-(k (L - L0) + c L') e`` on ``a`` and its opposite on ``b``), ``KanesMethod`` forms
``M_full x' = F_full`` on its own, and ``x' = M_full^-1 F_full`` is compared with the
compiled (unsliced) right-hand side at seeded random states.  sympy shares nothing
with mbgen's derivations but the model's frames and points.

(The bicycle's rolling constraints enter through its kinematic equations -- minimal
speeds -- so it is unconstrained in this sense; sympy takes over a minute on it, so it
runs under ``-m slow``.)
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

from mbgen.model.elements import Force, Gravity, LineElement, Torque
from mbgen.pipeline import run
from mbgen.model.scene import builtin_names, load_scene

T = me.dynamicsymbols._t

SCENES = ["bead_wire", "bent_pipe", "bicycle", "car_trailer", "disc_pendulum", "n_link_cart", "paraboloid",
          "spatial_arm", "spherical_rod", "spring_pendulum", "stiff_chain", "torque_free"]
SLOW = {"bicycle"}  # 75 s in sympy


def kanes_method(model):
    """``(KanesMethod, M_full, F_full)`` of an unconstrained mbgen model, by sympy alone."""
    N, O = model.N, model.origin
    O.set_vel(N, 0)
    for point in model.points:  # every velocity from the origin (one path, no ambiguity)
        if point is not O:
            point.set_vel(N, point.pos_from(O).dt(N))
    q, u = list(model.coordinates_), list(model.speeds_)
    kd = [sm.sympify(e) for e in model.kinematic_equations_]
    used = set().union(*(e.atoms(sm.Derivative) for e in kd)) if kd else set()
    used_u = set().union(*(e.atoms(sm.Function) for e in kd)) if kd else set()
    free_q = [qi for qi in q if qi.diff(T) not in used]
    free_u = [ui for ui in u if ui not in used_u]
    kd += [qi.diff(T) - ui for qi, ui in zip(free_q, free_u)]
    bodies, loads, masses = [], [], []
    for p in model.particles:
        bodies.append(me.Particle(p.name, p.point, p.mass))
        masses.append((p.point, p.mass))
    for b in model.bodies:
        F = b.frame
        e = (F.x, F.y, F.z)
        dyadic = sum((b.inertia[i, j] * (e[i] | e[j]) for i in range(3) for j in range(3)),
                     sm.S.Zero * (F.x | F.x))
        bodies.append(me.RigidBody(b.name, b.center, F, b.mass, (dyadic, b.center)))
        masses.append((b.center, b.mass))
    for load in model.loads:
        if isinstance(load, Force):
            loads.append((load.point, load.vector))
            if load.reaction is not None:
                loads.append((load.reaction, -load.vector))
        elif isinstance(load, Torque):
            loads.append((load.frame, load.vector))
            if load.reaction is not None:
                loads.append((load.reaction, -load.vector))
        elif isinstance(load, Gravity):
            loads += [(point, mass * load.vector) for point, mass in masses]
        elif isinstance(load, LineElement):
            r = load.a.pos_from(load.b)
            L = sm.sqrt(r.dot(r))
            Ldot = r.dt(N).dot(r) / L
            if load.natural_length == 0 and load.damping == 0:
                f = -load.stiffness * r
            else:
                f = -(load.stiffness * (L - load.natural_length) + load.damping * Ldot) / L * r
            loads += [(load.a, f), (load.b, -f)]
        else:  # pragma: no cover
            raise TypeError(f"unknown load {load!r}")
    kane = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    kane.kanes_equations(bodies, loads)
    return kane, kane.mass_matrix_full, kane.forcing_full


#: Constrained built-in scenes and the independent oracle each is held to (tests of
#: tests/scenes/test_constrained_scenes.py and tests/derive/test_constraints.py); this
#: file's oracle takes unconstrained models only.
CONSTRAINED_ORACLES = {
    "four_bar": "test_four_bar_position_analysis_is_what_consistent_finds, "
                "test_four_bar_consistent_state_projection_and_energy (energy conserved)",
    "slider_crank": "test_slider_crank_power_balance_with_the_driving_torque",
    "rolling_disc": "test_rolling_disc_scene_reproduces_the_published_equations",
    "paraboloid_normal": "test_paraboloid_normal_force_is_the_closed_form_along_a_run",
    "bead_wire_force": "test_bead_wire_force_is_two_m_omega_rho_dot",
    "whipple": "test_whipple_reproduces_the_benchmark_eigenvalues, "
               "test_sympy_kanes_method_states_the_same_bicycle (slow)",
}


def test_every_builtin_scene_is_compared():
    """Each built-in scene meets an oracle outside mbgen: here, or the one named above."""
    assert not set(SCENES) & set(CONSTRAINED_ORACLES)
    assert set(SCENES) | set(CONSTRAINED_ORACLES) == set(builtin_names())
    for name in CONSTRAINED_ORACLES:
        assert load_scene(name).model.constraints_, f"{name} is unconstrained: compare it here"
    import pathlib
    text = "".join((pathlib.Path(__file__).resolve().parents[1] / f).read_text()
                   for f in ("scenes/test_constrained_scenes.py", "derive/test_constraints.py"))
    for name, tests in CONSTRAINED_ORACLES.items():
        for test in tests.split(", "):
            assert f"def {test.split(' ')[0]}(" in text, f"{name}: no test {test!r}"


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW else n
                                  for n in SCENES])
def test_rhs_matches_sympy_kanes_method(name):
    scene = load_scene(name)
    model = scene.model
    assert not model.constraints_
    result = run(scene, ("rhs",), sliced=False)
    c = result.compiled
    L = result.layout
    values = {**scene.parameters, **scene.fixed}
    p = np.array([values[n] for n in L.parameter_names], dtype=float)

    kane, M, F = kanes_method(model)
    states = list(kane.q) + list(kane.u)
    assert [str(s.func) for s in states] == list(L.state_names)
    consts = {s for s in model.constants_}
    params = [next(s for s in consts if str(s) == n) for n in L.parameter_names]
    inputs = [next(s for s in model.inputs_ if str(s.func) == n) for n in L.input_names]
    args = (T, states, params, inputs)
    M_fn = sm.lambdify(args, M, modules="numpy", cse=True)
    F_fn = sm.lambdify(args, F, modules="numpy", cse=True)

    rng = np.random.default_rng(5)
    compared = 0
    for k in range(4):
        x = rng.uniform(-0.8, 0.8, c.n_x)
        r = rng.uniform(-1, 1, c.n_r)
        t = 0.3 * (k + 1)
        want = np.linalg.solve(np.asarray(M_fn(t, x, p, r), dtype=float),
                               np.asarray(F_fn(t, x, p, r), dtype=float).ravel())
        got = c.rhs(t, x, p, r)
        np.testing.assert_allclose(got, want, rtol=1e-8, atol=1e-10 * max(1.0, np.abs(want).max()))
        compared += 1
    assert compared == 4
