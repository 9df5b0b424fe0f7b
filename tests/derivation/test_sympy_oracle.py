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
runs under ``-m slow``, and its closed-form straight run is its oracle by default.)

Every built-in scene meets an oracle that the default command runs: the test collects
the named tests as ``pytest`` does by default (``-m "not slow"``), so an oracle marked slow,
directly or through a parameter, no longer counts.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

from mbgen.model.elements import Force, Gravity, LineElement, Torque
from mbgen.model.scene import builtin_names, load_scene
from mbgen.pipeline import run

T = me.dynamicsymbols._t

SCENES = ["bead_wire", "bent_pipe", "bicycle", "car_trailer", "disc_pendulum", "n_link_cart",
          "paraboloid", "spatial_arm", "spherical_rod", "spring_pendulum", "stiff_chain",
          "torque_free"]
SLOW = {"bicycle"}  # 75 s in sympy; SLOW_ORACLES names its oracle in the default command


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
        loads += sympy_loads(load, masses, N)
    kane = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    kane.kanes_equations(bodies, loads)
    return kane, kane.mass_matrix_full, kane.forcing_full


def sympy_loads(load, masses, N) -> list:
    """One mbgen load as ``KanesMethod`` loads (``(point or frame, vector)`` pairs); gravity
    acts on the ``masses`` (``(point, mass)`` pairs)."""
    if isinstance(load, Force):
        out = [(load.point, load.vector)]
        if load.reaction is not None:
            out.append((load.reaction, -load.vector))
        return out
    if isinstance(load, Torque):
        out = [(load.frame, load.vector)]
        if load.reaction is not None:
            out.append((load.reaction, -load.vector))
        return out
    if isinstance(load, Gravity):
        return [(point, mass * load.vector) for point, mass in masses]
    if isinstance(load, LineElement):
        r = load.a.pos_from(load.b)
        L = sm.sqrt(r.dot(r))
        Ldot = r.dt(N).dot(r) / L
        if load.natural_length == 0 and load.damping == 0:
            f = -load.stiffness * r
        else:
            f = -(load.stiffness * (L - load.natural_length) + load.damping * Ldot) / L * r
        return [(load.a, f), (load.b, -f)]
    raise TypeError(f"unknown load {load!r}")  # pragma: no cover


#: Constrained built-in scenes and the independent oracles each is held to (``file::test``
#: under tests/); this file's oracle takes unconstrained models only.  "(slow)" marks an
#: oracle that runs under ``-m slow`` only; every other one must run in the default command.
CONSTRAINED_ORACLES = {
    "four_bar": ("scenes/test_constrained_scenes.py::"
                 "test_four_bar_position_analysis_is_what_consistent_finds",
                 "derivation/test_constraints.py::"
                 "test_four_bar_consistent_state_projection_and_energy"),  # energy conserved
    "slider_crank": ("scenes/test_constrained_scenes.py::"
                     "test_slider_crank_power_balance_with_the_driving_torque",),
    "rolling_disc": ("scenes/test_constrained_scenes.py::"
                     "test_rolling_disc_scene_reproduces_the_published_equations",),
    "paraboloid_normal": ("scenes/test_constrained_scenes.py::"
                          "test_paraboloid_normal_force_is_the_closed_form_along_a_run",),
    "bead_wire_force": ("scenes/test_constrained_scenes.py::"
                        "test_bead_wire_force_is_two_m_omega_rho_dot",),
    "whipple": ("scenes/test_constrained_scenes.py::"
                "test_whipple_reproduces_the_benchmark_eigenvalues",
                "scenes/test_constrained_scenes.py::"
                "test_sympy_kanes_method_states_the_same_bicycle (slow)"),
}
#: Scenes of :data:`SCENES` whose comparison here is slow, and the oracle that runs in the
#: default command instead.
SLOW_ORACLES = {
    "bicycle": ("scenes/test_vehicles.py::test_bicycle_straight_run_matches_closed_form",),
}


def default_command_collects(paths) -> set[str]:
    """The test ids (``file::test[param]`` under tests/) that the default command runs from
    ``paths``: ``pytest --collect-only`` with the project's own options (``-m "not slow"``)."""
    tests = Path(__file__).resolve().parents[1]
    out = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-n", "0",
                          "-p", "no:cacheprovider", *sorted({f"tests/{p}" for p in paths})],
                         cwd=tests.parent, capture_output=True, text=True, check=True).stdout
    return {line.removeprefix("tests/") for line in out.splitlines() if "::" in line}


def test_every_builtin_scene_is_compared_in_the_default_command():
    """Each built-in scene meets an oracle outside mbgen that the default command runs (not
    marked slow, directly or through a parameter): here, or one named above."""
    assert not set(SCENES) & set(CONSTRAINED_ORACLES)
    assert set(SCENES) | set(CONSTRAINED_ORACLES) == set(builtin_names())
    assert set(SLOW_ORACLES) == SLOW
    for name in CONSTRAINED_ORACLES:
        assert load_scene(name).model.constraints_, f"{name} is unconstrained: compare it here"
    here = "derivation/test_sympy_oracle.py::test_rhs_matches_sympy_kanes_method"
    oracles = {name: SLOW_ORACLES.get(name, (f"{here}[{name}]",)) for name in SCENES}
    oracles.update(CONSTRAINED_ORACLES)
    tests = Path(__file__).resolve().parents[1]
    for name, named in oracles.items():
        for oracle in named:
            path, test = oracle.removesuffix(" (slow)").split("::")
            assert f"def {test.split('[')[0]}(" in (tests / path).read_text(), \
                f"{name}: no test {oracle!r}"
    by_default = {o for named in oracles.values() for o in named if not o.endswith(" (slow)")}
    collected = default_command_collects(o.split("::")[0] for o in by_default)
    for name, named in oracles.items():
        default = [o for o in named if not o.endswith(" (slow)")]
        assert default, f"{name}: every oracle is slow; name one the default command runs"
        missing = [o for o in default if o not in collected]
        assert not missing, f"{name}: not run by the default command (marked slow?): {missing}"


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
