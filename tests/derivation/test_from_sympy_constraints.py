"""from_sympy with constraints: dependent coordinates and speeds, auxiliary speeds, multipliers.

Every model is checked against sympy itself at seeded random *consistent* states
(dependent coordinates completed by ``CompiledModel.consistent``, dependent
speeds solved from the model's own velocity constraints): the compiled C
right-hand side against sympy's ``mass_matrix_full x' = forcing_full`` solved
numerically (what its ``rhs()`` computes; ``rhs()`` itself on the rolling disc),
and the multipliers (``constraint_forces``) against sympy's ``lam`` or the
contact forces of its auxiliary equations.
"""

from functools import cache

import numpy as np
import pytest
import sympy as sm
from sympy.physics import mechanics as me

import mbgen
from checks import assert_close
from mbgen import LambdifiedModel, ModelError
from mbgen.derivation.from_sympy import from_sympy

t = me.dynamicsymbols._t
OUTPUTS = ("rhs", "constraint_forces", "holonomic", "holonomic_jacobian")


# --------------------------------------------------------------------------- models
@cache
def rolling_disc():
    """sympy's test_kane2.test_aux_dep: a disc rolling on the ground.

    Yaw q0, lean q1, spin q2; q3 (height of the centre, along A.z) is dependent
    through a configuration constraint; u0..u2 are body rates, u3..u5 the centre's
    velocity in A (dependent through three velocity constraints: the contact point
    has zero velocity); auxiliary speeds ua0..ua2 at the contact bring the contact
    force Fx, Fy, Fz (in A) into evidence.
    """
    r, m, g, I, J = sm.symbols("r m g I J")
    Fx, Fy, Fz = sm.symbols("Fx Fy Fz")
    q = me.dynamicsymbols("q:4")
    qd = [qi.diff(t) for qi in q]
    u = me.dynamicsymbols("u:6")
    ua = me.dynamicsymbols("ua:3")
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [q[0], N.z])
    B = A.orientnew("B", "Axis", [q[1], A.x])
    C = B.orientnew("C", "Axis", [q[2], B.y])
    C.set_ang_vel(N, u[0] * B.x + u[1] * B.y + u[2] * B.z)
    C.set_ang_acc(N, C.ang_vel_in(N).diff(t, B) + me.cross(B.ang_vel_in(N), C.ang_vel_in(N)))
    P = me.Point("P")
    P.set_vel(N, ua[0] * A.x + ua[1] * A.y + ua[2] * A.z)
    O = P.locatenew("O", q[3] * A.z + r * sm.sin(q[1]) * A.y)
    O.set_vel(N, u[3] * A.x + u[4] * A.y + u[5] * A.z)
    O.set_acc(N, O.vel(N).diff(t, A) + me.cross(A.ang_vel_in(N), O.vel(N)))
    w_qd = qd[0] * A.z + qd[1] * B.x + qd[2] * B.y
    v_qd = O.pos_from(P).diff(t, A) + me.cross(A.ang_vel_in(N), O.pos_from(P))
    kd = [me.dot(w_qd - C.ang_vel_in(N), e) for e in B] + [me.dot(v_qd - O.vel(N), A.z)]
    f_c = [me.dot(-r * B.z, A.z) - q[3]]
    f_v = [me.dot(O.vel(N) - (P.vel(N) + me.cross(C.ang_vel_in(N), O.pos_from(P))), e).expand()
           for e in A]
    disc = me.RigidBody("disc", O, C, m, (me.inertia(B, I, J, I), O))
    km = me.KanesMethod(N, q_ind=q[:3], u_ind=u[:3], kd_eqs=kd, q_dependent=q[3:],
                        configuration_constraints=f_c, u_dependent=u[3:],
                        velocity_constraints=f_v, u_auxiliary=ua)
    km.kanes_equations([disc], [(O, m * g * A.z), (P, Fx * A.x + Fy * A.y + Fz * A.z)])
    return km, f_v


@cache
def four_bar(method, dependent=True):
    """Crank (q1), coupler (q2) and rocker (q3) on PinJoints, the loop to the ground pivot
    at ``l1 N.x`` closed by two configuration constraints; gravity ``-g N.y`` and a torque
    ``T(t)`` on the crank.  ``dependent``: set the System's q_dep/u_dep to q2, q3."""
    lagrange = method is me.LagrangesMethod
    q = me.dynamicsymbols("q1:4")
    u = [qi.diff(t) for qi in q] if lagrange else me.dynamicsymbols("u1:4")
    l1, l2, l3, l4, rho, g = sm.symbols("l1:5 rho g")
    T = me.dynamicsymbols("T")
    ground = me.RigidBody("ground")
    links = [me.RigidBody(f"link{i}", mass=rho * l) for i, l in zip((2, 3, 4), (l2, l3, l4))]
    for body, l in zip(links, (l2, l3, l4)):
        body.inertia = (me.inertia(body.frame, 0, 0, rho * l ** 3 / 12), body.masscenter)
    crank, coupler, rocker = links
    system = me.System.from_newtonian(ground)
    system.add_joints(
        me.PinJoint("J1", ground, crank, q[0], u[0], child_point=-l2 / 2 * crank.x,
                    joint_axis=ground.z),
        me.PinJoint("J2", crank, coupler, q[1], u[1], parent_point=l2 / 2 * crank.x,
                    child_point=-l3 / 2 * coupler.x, joint_axis=crank.z),
        me.PinJoint("J3", coupler, rocker, q[2], u[2], parent_point=l3 / 2 * coupler.x,
                    child_point=-l4 / 2 * rocker.x, joint_axis=coupler.z))
    end = rocker.masscenter.locatenew("E", l4 / 2 * rocker.x)
    loop = end.pos_from(ground.masscenter) - l1 * ground.x
    system.add_holonomic_constraints(loop.dot(ground.x), loop.dot(ground.y))
    if dependent:
        system.q_ind, system.q_dep = [q[0]], [q[1], q[2]]
        system.u_ind, system.u_dep = [u[0]], [u[1], u[2]]
    system.apply_uniform_gravity(-g * ground.y)
    system.add_loads(me.Torque(crank.frame, T * ground.z))
    system.form_eoms(method)
    return system


FOUR_BAR = {"l1": 4.0, "l2": 1.0, "l3": 3.5, "l4": 3.0}  # a crank-rocker (Grashof)


def four_bar_guess(q1):
    """An assembled four-bar (upper branch) at crank angle ``q1``: the coupler's end on
    both circles, then the relative angles."""
    l1, l2, l3, l4 = FOUR_BAR.values()
    B, D = np.array([l2 * np.cos(q1), l2 * np.sin(q1)]), np.array([l1, 0.0])
    d = np.linalg.norm(D - B)
    a = (l3 ** 2 - l4 ** 2 + d ** 2) / (2 * d)
    e = (D - B) / d
    C = B + a * e + np.sqrt(l3 ** 2 - a ** 2) * np.array([-e[1], e[0]])
    th3, th4 = np.arctan2(*(C - B)[::-1]), np.arctan2(*(D - C)[::-1])
    return np.array([q1, th3 - q1, th4 - th3])


def cartesian_pendulum():
    """A bob at (x, y) on a rod of length l: x^2 + y^2 - l^2 = 0; gravity -g, force F(t) along x."""
    x, y = me.dynamicsymbols("x y")
    m, g, l = sm.symbols("m g l")
    F = me.dynamicsymbols("F")
    N = me.ReferenceFrame("N")
    P = me.Point("P")
    P.set_vel(N, x.diff(t) * N.x + y.diff(t) * N.y)
    bob = me.Particle("bob", P, m)
    bob.potential_energy = m * g * y
    lm = me.LagrangesMethod(me.Lagrangian(N, bob), [x, y], forcelist=[(P, F * N.x)], frame=N,
                            hol_coneqs=[x ** 2 + y ** 2 - l ** 2])
    lm.form_lagranges_equations()
    return lm


def knife_edge(nonholonomic=None, holonomic=()):
    """A blade on the plane (x, y, heading theta) that cannot slide sideways:
    -sin(theta) x' + cos(theta) y' = 0; pushed by P(t) along its heading, turned by T(t)."""
    x, y, th = me.dynamicsymbols("x y theta")
    m, I = sm.symbols("m I")
    P_, T = me.dynamicsymbols("P T")
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Axis", [th, N.z])
    G = me.Point("G")
    G.set_vel(N, x.diff(t) * N.x + y.diff(t) * N.y)
    blade = me.RigidBody("blade", G, B, m, (me.inertia(B, 0, 0, I), G))
    if nonholonomic is None:
        nonholonomic = [-sm.sin(th) * x.diff(t) + sm.cos(th) * y.diff(t)]
    lm = me.LagrangesMethod(me.Lagrangian(N, blade), [x, y, th],
                            forcelist=[(G, P_ * B.x), (B, T * N.z)], frame=N,
                            nonhol_coneqs=nonholonomic, hol_coneqs=list(holonomic))
    lm.form_lagranges_equations()
    return lm


# --------------------------------------------------------------------------- sympy's side
def plain(exprs, coordinates, speeds, accelerations=()):
    """sympy expressions with q(t), u(t) (or q'(t)) and u'(t) as plain symbols named like
    mbgen's."""
    rep = {f: sm.Symbol(f"{f.expr.func}_acc") for f in accelerations}
    for f in [*speeds, *coordinates]:
        rep[f] = sm.Symbol(f"{f.expr.func}_dot" if isinstance(f, sm.Derivative) else str(f.func))
    return sm.Matrix(exprs).xreplace(rep), rep


class SympySide:
    """sympy's own numbers: the full state's derivative (and multipliers) at (t, q, u, p, r).

    ``mass_matrix_full [x'; lam] = forcing_full`` solved numerically: what sympy's
    ``rhs()`` computes (``KanesMethod`` and ``LagrangesMethod`` alike), without its
    symbolic LU (seconds on the four-bar).

    ``velocity``: the velocity constraints as stated to sympy (``q'`` allowed), which
    give the dependent speeds.
    """

    def __init__(self, obj, eq, velocity, vanishing=()):
        L = eq.layout
        self.lagrange = isinstance(obj, me.LagrangesMethod)
        q, u = list(obj.q), list(obj.u)
        zero = {v: 0 for v in vanishing} | {v.diff(t): 0 for v in vanishing}
        lhs, rhs = obj.mass_matrix_full, obj.forcing_full
        if not self.lagrange:
            velocity = [me.msubs(v, obj.kindiffdict()) for v in velocity]
        self.u_names = [str(s) for s in plain(u, q, u)[0]]
        velocity = me.msubs(sm.Matrix(velocity), zero)
        lhs, rhs = me.msubs(lhs, zero), me.msubs(rhs, zero)
        inputs = [me.dynamicsymbols(n) for n in L.input_names]
        args = [L.time, list(L.coordinates), list(L.parameters), list(L.inputs)]
        (lhs, rhs, velocity), rep = zip(*(plain(e, q, u) for e in (lhs, rhs, velocity)))
        rep = rep[0] | {f: sm.Symbol(str(f.func)) for f in inputs}
        lhs, rhs, velocity = (e.xreplace(rep) for e in (lhs, rhs, velocity))
        speeds = [sm.Symbol(n) for n in self.u_names]
        self._lhs = sm.lambdify(args + [speeds], lhs)
        self._rhs = sm.lambdify(args + [speeds], rhs)
        K = velocity.jacobian(speeds)
        self._K = sm.lambdify(args, K)
        self._k = sm.lambdify(args, velocity.xreplace({s: 0 for s in speeds}))
        self.n_q, self.n_u = len(q), len(u)

    def speeds(self, t_, q, p, r, independent: dict) -> np.ndarray:
        """Every speed (sympy's order): the independent ones given by name, the others solved
        from the velocity constraints."""
        K = np.array(self._K(t_, q, p, r), dtype=float)
        k = np.array(self._k(t_, q, p, r), dtype=float).ravel()
        known = [i for i, n in enumerate(self.u_names) if n in independent]
        free = [i for i in range(len(self.u_names)) if i not in known]
        u = np.zeros(len(self.u_names))
        u[known] = [independent[self.u_names[i]] for i in known]
        u[free] = np.linalg.solve(K[:, free], -(K[:, known] @ u[known] + k))
        return u

    def solve(self, t_, q, u, p, r):
        """``(x', multipliers)`` with ``x = [q, u]`` in sympy's order (multipliers: Lagrange)."""
        lhs = np.array(self._lhs(t_, q, p, r, u), dtype=float)
        rhs = np.array(self._rhs(t_, q, p, r, u), dtype=float).ravel()
        sol = np.linalg.solve(lhs, rhs)
        n = self.n_q + self.n_u
        return sol[:n], sol[n:]


def consistent_states(cm, eq, count=4, seed=0, parameters=None, guess=None):
    """Seeded random consistent ``(t, x, p, r)``: independent entries random, dependent
    coordinates completed by ``CompiledModel.consistent`` (from ``guess(x)`` if given)."""
    L = eq.layout
    dependent = [L.coordinates.index(q) for q in eq.constraints.dependent_coordinates]
    rng = np.random.default_rng(seed)
    for _ in range(count):
        p = rng.uniform(0.5, 2.0, L.n_p)
        for k, v in (parameters or {}).items():
            p[L.parameter_names.index(k)] = v
        x = rng.uniform(-1, 1, L.n_x)
        if guess is not None:
            x[:L.n_q] = guess(x)
            x[dependent] += 0.05  # off the manifold: Newton has work to do
        x = cm.consistent(x, p)
        assert np.max(np.abs(cm.holonomic(0.0, x, p))) < 1e-10 if eq.constraints.m_h else True
        yield rng.uniform(0, 1), x, p, rng.uniform(-1, 1, L.n_r)


def check_against_sympy(obj, eq, velocity, vanishing=(), multipliers=None, **options):
    """Compiled C (and the lambdified reference) against sympy at consistent states.

    ``multipliers(t, q, u, u', p)`` gives the expected ``constraint_forces``;
    default for a LagrangesMethod: sympy's ``lam``.
    """
    L = eq.layout
    cm = mbgen.compile(eq, OUTPUTS if eq.constraints.m_h else OUTPUTS[:2])
    reference = LambdifiedModel(eq, ("rhs", "constraint_forces"))
    side = SympySide(obj, eq, velocity, vanishing)
    names = list(L.state_names)
    for t_, x, p, r in consistent_states(cm, eq, **options):
        q = x[:L.n_q]
        u = side.speeds(t_, q, p, r, dict(zip(names[L.n_q:], x[L.n_q:])))
        xdot, lam = side.solve(t_, q, u, p, r)
        position = [L.n_q + side.u_names.index(n) for n in names[L.n_q:]]
        expected = np.concatenate([xdot[:L.n_q], xdot[position]])
        got = cm.rhs(t_, x, p, r)
        assert_close(got, expected)
        assert_close(reference.rhs(t_, x, p, r), expected)
        if side.lagrange:
            assert_close(cm.constraint_forces(t_, x, p, r), lam)
        elif multipliers is not None:
            assert_close(cm.constraint_forces(t_, x, p, r),
                         multipliers(t_, q, u, xdot[L.n_q:], p))
        assert_close(reference.constraint_forces(t_, x, p, r), cm.constraint_forces(t_, x, p, r))
    return cm


# --------------------------------------------------------------------------- KanesMethod
def test_rolling_disc_dependent_and_auxiliary_speeds():
    km, f_v = rolling_disc()
    eq = from_sympy(km, name="rolling_disc")
    L, c = eq.layout, eq.constraints
    assert L.state_names == ("q0", "q1", "q2", "q3", "u0", "u1", "u2")
    assert tuple(map(str, L.dependent_speeds)) == ("u3", "u4", "u5")
    assert tuple(map(str, c.dependent_coordinates)) == ("q3",)
    # f_v[2] (along A.z) is -d/dt of the configuration constraint: it comes first
    assert c.names == ("configuration_0", "velocity_0", "velocity_1")
    assert L.parameter_names == ("I", "J", "g", "m", "r") and L.inputs == ()  # no ua, no Fx

    # the contact force from sympy's auxiliary equations, solved for Fx, Fy, Fz
    Fs = sm.symbols("Fx Fy Fz")
    zero = {a: 0 for a in km._uaux} | {a.diff(t): 0 for a in km._uaux}
    aux = me.msubs(km.auxiliary_eqs, km.kindiffdict(), zero)
    aux, _ = plain(aux, list(km.q), list(km.u), [ui.diff(t) for ui in km.u])
    A_aux, b_aux = sm.linear_eq_to_matrix(list(aux), Fs)
    syms = [sm.Symbol(str(s.func)) for s in km.q]
    speeds = [sm.Symbol(str(s.func)) for s in km.u]
    accs = [sm.Symbol(f"{s.func}_acc") for s in km.u]
    contact = sm.lambdify([syms, speeds, accs, list(L.parameters)], [A_aux, b_aux])

    def multipliers(t_, q, u, ud, p):
        Aa, ba = contact(q, u, ud, p)
        Fx, Fy, Fz = np.linalg.solve(np.array(Aa, float), np.array(ba, float).ravel())
        return [Fz, Fx, Fy]  # the rows' order: configuration_0 (A.z), velocity_0, velocity_1

    cm = check_against_sympy(km, eq, f_v, vanishing=km._uaux, multipliers=multipliers)

    # and KanesMethod.rhs() itself, symbolic LU and all
    side = SympySide(km, eq, f_v, km._uaux)
    rhs, _ = plain(me.msubs(km.rhs(), zero), list(km.q), list(km.u))
    rhs = sm.lambdify([syms, speeds, list(L.parameters)], rhs)
    for t_, x, p, r in consistent_states(cm, eq, count=2, seed=1):
        u = side.speeds(t_, x[:4], p, r, dict(zip(L.state_names[4:], x[4:])))
        assert_close(cm.rhs(t_, x, p, r), np.ravel(rhs(x[:4], u, p))[:7])


def test_rolling_disc_jacobians_match_reference():
    """Implicit-differentiation Jacobian of the imported constraints: C == lambdify."""
    km, _ = rolling_disc()
    eq = from_sympy(km, name="rolling_disc")
    cm = mbgen.compile(eq, ("rhs", "jacobian", "holonomic", "holonomic_jacobian"))
    reference = LambdifiedModel(eq, ("jacobian",))
    for t_, x, p, r in consistent_states(cm, eq, count=2):
        assert_close(cm.jacobian(t_, x, p, r), reference.jacobian(t_, x, p, r), 1e-8)


def test_four_bar_kane():
    system = four_bar(me.KanesMethod)
    eq = from_sympy(system, name="four_bar")
    L, c = eq.layout, eq.constraints
    assert L.state_names == ("q1", "q2", "q3", "u1")
    assert tuple(map(str, L.dependent_speeds)) == ("u2", "u3")
    assert tuple(map(str, c.dependent_coordinates)) == ("q2", "q3")
    assert c.names == ("configuration_0", "configuration_1") and c.m_h == 2
    assert L.input_names == ("T",)
    check_against_sympy(system.eom_method, eq, list(system.velocity_constraints),
                        parameters=FOUR_BAR, guess=lambda x: four_bar_guess(x[0]))


def test_four_bar_lagrange_matches_sympy_and_kane():
    system = four_bar(me.LagrangesMethod)
    eq = from_sympy(system, name="four_bar")
    L, c = eq.layout, eq.constraints
    assert L.state_names == ("q1", "q2", "q3", "q1_dot")  # the System's q_dep and u_dep
    assert c.names == ("lam1", "lam2")
    cm = check_against_sympy(system.eom_method, eq, list(system.eom_method.coneqs),
                             parameters=FOUR_BAR, guess=lambda x: four_bar_guess(x[0]))
    kane = mbgen.compile(from_sympy(four_bar(me.KanesMethod)), OUTPUTS)
    for t_, x, p, r in consistent_states(cm, eq, parameters=FOUR_BAR,
                                         guess=lambda x: four_bar_guess(x[0])):
        assert_close(cm.rhs(t_, x, p, r), kane.rhs(t_, x, p, r))  # u = q' on PinJoints


@pytest.mark.parametrize("dependent, speeds", [
    (None, ("q1_dot",)),          # chosen: from the last coordinate backwards
    (["q3", "q1"], ("q2_dot",)),  # named, in any order
])
def test_four_bar_lagrange_dependent_choice(dependent, speeds):
    lm = four_bar(me.LagrangesMethod, dependent=False).eom_method
    eq = from_sympy(lm, dependent=dependent)
    assert tuple(map(str, eq.layout.speeds)) == speeds
    check_against_sympy(lm, eq, list(lm.coneqs), parameters=FOUR_BAR,
                        guess=lambda x: four_bar_guess(x[0]))


def test_dependent_as_functions_or_derivatives():
    lm = four_bar(me.LagrangesMethod, dependent=False).eom_method
    q1, q2, q3 = lm.q
    named = from_sympy(lm, dependent=["q3", "q1"])
    for dependent in ([q3, q1], [q3.diff(t), "q1_dot"], [q3, q1.diff(t)]):
        assert from_sympy(lm, dependent=dependent) == named


def test_kane_without_dependent_speeds_keeps_auxiliary_speeds_out():
    q, u, ua = me.dynamicsymbols("q u ua")
    m, k = sm.symbols("m k")
    N = me.ReferenceFrame("N")
    P, C = me.Point("P"), me.Point("C")
    P.set_vel(N, u * N.x)
    C.set_vel(N, u * N.x + ua * N.y)  # the auxiliary speed shows the support's force R
    R = me.dynamicsymbols("R")
    km = me.KanesMethod(N, [q], [u], kd_eqs=[q.diff() - u], u_auxiliary=[ua])
    km.kanes_equations([me.Particle("Pa", P, m)], [(P, -k * q * N.x), (C, R * N.y)])
    eq = from_sympy(km)
    s = {n: sm.Symbol(n) for n in ("q", "u", "m", "k")}
    assert eq.constraints is None and eq.layout.inputs == ()
    assert (eq.mass_matrix, eq.forcing) == (sm.ImmutableMatrix([[s["m"]]]),
                                            sm.ImmutableMatrix([[-s["k"] * s["q"]]]))


def test_dependent_speed_in_plain_velocity_constraint():
    """x' = u_x rolls with the spin: u_x + r u_theta = 0, u_x dependent."""
    x, th, ux, uth = me.dynamicsymbols("x theta u_x u_theta")
    m, r, I = sm.symbols("m r I")
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Axis", [th, N.z])
    B.set_ang_vel(N, uth * N.z)
    P = me.Point("P")
    P.set_vel(N, ux * N.x)
    wheel = me.RigidBody("wheel", P, B, m, (me.inertia(B, 0, 0, I), P))
    km = me.KanesMethod(N, [x, th], [uth], kd_eqs=[x.diff() - ux, th.diff() - uth],
                        u_dependent=[ux], velocity_constraints=[ux + r * uth])
    km.kanes_equations([wheel], [(B, me.dynamicsymbols("T") * N.z)])
    eq = from_sympy(km)
    s = {n: sm.Symbol(n) for n in ("u_theta", "u_x", "r", "m", "I", "T")}
    assert eq.layout.speeds == (s["u_theta"],) and eq.layout.dependent_speeds == (s["u_x"],)
    assert eq.constraints.velocity_matrix == sm.ImmutableMatrix([[s["r"], 1]])
    assert eq.constraints.velocity_bias == sm.ImmutableMatrix([[0]])
    assert eq.mass_matrix == sm.ImmutableMatrix([[s["I"], 0], [0, s["m"]]])
    cm = mbgen.compile(eq, ("rhs", "constraint_forces"))
    I_, m_, r_, T_ = 0.7, 1.3, 0.4, 0.9  # closed form: (I + m r^2) u_theta' = T
    p = [dict(I=I_, m=m_, r=r_)[n] for n in cm.parameter_names]
    x0 = [0.1, 0.2, 0.5]
    assert_close(cm.rhs(0.0, x0, p, [T_]), [-r_ * 0.5, 0.5, T_ / (I_ + m_ * r_ ** 2)])
    # the multiplier is the ground's force on the wheel along x: m x'' = lambda
    assert_close(cm.constraint_forces(0.0, x0, p, [T_]), [-m_ * r_ * T_ / (I_ + m_ * r_ ** 2)])


# --------------------------------------------------------------------------- LagrangesMethod
def test_cartesian_pendulum_multiplier_is_the_rod_tension():
    lm = cartesian_pendulum()
    eq = from_sympy(lm, name="cartesian_pendulum")
    L = eq.layout
    assert L.state_names == ("x", "y", "x_dot") and tuple(map(str, L.dependent_speeds)) == (
        "y_dot",)

    def guess(x):  # the bob on the unit circle below the pivot
        return [0.3 * x[0], -np.sqrt(1 - 0.09 * x[0] ** 2)]

    cm = check_against_sympy(lm, eq, list(lm.coneqs), guess=guess)
    # closed form: the rod pulls the bob inwards with T = (m (v^2 - g y) + F x) / l; the force
    # lambda * d(x^2 + y^2)/d(x, y) = 2 lambda (x, y) makes lambda = -T / (2 l)
    for t_, x, p, r in consistent_states(cm, eq, guess=guess):
        g, l, m = (p[L.parameter_names.index(n)] for n in ("g", "l", "m"))
        xx, yy, xd = x
        yd = -xx * xd / yy
        tension = (m * (xd ** 2 + yd ** 2 - g * yy) + r[0] * xx) / l
        assert_close(cm.constraint_forces(t_, x, p, r), [-tension / (2 * l)])


def test_knife_edge_nonholonomic():
    lm = knife_edge()
    eq = from_sympy(lm, name="knife_edge")
    assert eq.layout.state_names == ("x", "y", "theta", "x_dot", "theta_dot")
    assert eq.constraints.m_h == 0 and eq.constraints.names == ("lam1",)
    check_against_sympy(lm, eq, list(lm.coneqs))
    with pytest.raises(ModelError, match=r"do not determine the speeds of \['theta'\].*"
                                         r"dependent=\['y'\] would"):
        from_sympy(lm, dependent=["theta"])


def test_pydy_system():
    from pydy.system import System as PydySystem

    km, _ = rolling_disc()
    constants = {sm.Symbol(n): v for n, v in dict(r=0.3, m=2.0, g=9.81, I=0.1, J=0.2).items()}
    eq = from_sympy(PydySystem(km, constants=constants), name="disc")
    assert eq.source == "PyDy System (KanesMethod)"
    assert dict(eq.defaults) == {"r": 0.3, "m": 2.0, "g": 9.81, "I": 0.1, "J": 0.2}
    assert eq.constraints.names == from_sympy(km).constraints.names


# --------------------------------------------------------------------------- bad input
def test_refuses_velocity_constraints_without_the_configuration_derivative():
    km, f_v = rolling_disc()
    bad = me.KanesMethod(km._inertial, q_ind=km.q[:3], u_ind=km.u[:3],
                         kd_eqs=[k - v for k, v in km.kindiffdict().items()],
                         q_dependent=km.q[3:], configuration_constraints=km._f_h,
                         u_dependent=km.u[3:], velocity_constraints=[f_v[0], f_v[1],
                                                                     f_v[2] + f_v[0]],
                         u_auxiliary=km._uaux)
    bad.kanes_equations(km.bodies, km.loads)
    with pytest.raises(ModelError, match=r"time derivative of configuration_constraints\[0\]"):
        from_sympy(bad)


def three_masses(velocity, dependent):
    """Three masses on x (speeds u1, u2, u3), pushed by F(t), with given velocity constraints."""
    q = me.dynamicsymbols("q1:4")
    u = me.dynamicsymbols("u1:4")
    m = sm.symbols("m")
    N = me.ReferenceFrame("N")
    particles = []
    for i in range(3):
        P = me.Point(f"P{i}")
        P.set_vel(N, u[i] * N.x)
        particles.append(me.Particle(f"p{i}", P, m))
    independent = [ui for ui in u if ui not in dependent]
    km = me.KanesMethod(N, [q[0], q[2]], independent,
                        kd_eqs=[qi.diff() - ui for qi, ui in zip(q, u)],
                        q_dependent=q[1:2], configuration_constraints=[q[1] - q[0]],
                        u_dependent=dependent, velocity_constraints=velocity(q, u))
    km.kanes_equations(particles, [(particles[0].point, me.dynamicsymbols("F") * N.x)])
    return km


def test_refuses_redundant_or_undetermined_kane_constraints():
    u1, u2, u3 = me.dynamicsymbols("u1:4")
    assert from_sympy(three_masses(lambda q, u: [u[1] - u[0], u[2] - u[0]], [u2, u3]))
    # sympy's LU cannot see that sin^2 + cos^2 - 1 is zero: the rows are the same
    same = sm.sin(me.dynamicsymbols("q1")) ** 2 + sm.cos(me.dynamicsymbols("q1")) ** 2
    with pytest.raises(ModelError, match=r"redundant or do not determine its dependent speeds "
                                         r"\[u2, u3\]"):
        from_sympy(three_masses(lambda q, u: [u[1] - u[0], u[1] - u[0] + (same - 1) * u[2]],
                                [u2, u3]))


def test_refuses_dependent_coordinate_outside_the_configuration_constraints():
    u1, u2, u3 = me.dynamicsymbols("u1:4")
    km = three_masses(lambda q, u: [u[1] - u[0], u[2] - u[0]], [u2, u3])
    km._qdep = sm.Matrix([me.dynamicsymbols("q3")])  # as if q_dependent=[q3] had been given
    with pytest.raises(ModelError, match=r"dependent coordinate q3 appears in no "
                                         r"configuration constraint"):
        from_sympy(km)


def test_refuses_bad_lagrange_constraints():
    with pytest.raises(ModelError, match=r"not linear in the speeds"):
        x, th = me.dynamicsymbols("x theta")
        from_sympy(knife_edge([x.diff(t) ** 2 - th.diff(t)]))
    x, y, th = me.dynamicsymbols("x y theta")
    twice = [-sm.sin(th) * x.diff(t) + sm.cos(th) * y.diff(t)] * 2
    with pytest.raises(ModelError, match=r"redundant"):
        from_sympy(knife_edge(twice))
    three = [x.diff(t), y.diff(t), th.diff(t)]
    with pytest.raises(ModelError, match=r"at least one speed must stay independent"):
        from_sympy(knife_edge(three))


def test_refuses_bad_dependent_argument():
    lm = knife_edge()
    with pytest.raises(ModelError, match=r"names 2 coordinates, .* 1 constraints.*"
                                         r"dependent=\['y'\] would"):
        from_sympy(lm, dependent=["x", "y"])
    with pytest.raises(ModelError, match=r"names z, which is not a coordinate"):
        from_sympy(lm, dependent=["z"])
    with pytest.raises(ModelError, match=r"names y twice"):
        from_sympy(cartesian_pendulum(), dependent=["y", "y_dot"])
    with pytest.raises(ModelError, match=r"dependent= is for a LagrangesMethod.*u_dependent"):
        from_sympy(rolling_disc()[0], dependent=["q3"])
    x = me.dynamicsymbols("x")
    with pytest.raises(ModelError, match=r"configuration constraints do not determine any 1 "
                                         r"of dependent=\['y', 'theta'\].*dependent=\['x', "
                                         r"'y'\] would"):
        from_sympy(knife_edge(holonomic=[x - 2]), dependent=["y", "theta"])


def test_four_bar_trajectory_matches_sympy():
    """The C integrator (projecting onto the loop closure) against solve_ivp on sympy's own
    equations over every speed, from the same consistent state."""
    from scipy.integrate import solve_ivp

    system = four_bar(me.KanesMethod)
    eq = from_sympy(system, name="four_bar")
    L = eq.layout
    cm = mbgen.compile(eq, OUTPUTS + ("dopri5",))
    side = SympySide(system.eom_method, eq, list(system.velocity_constraints))
    p = np.array([dict(FOUR_BAR, g=9.81, rho=1.0)[n] for n in L.parameter_names])
    r = np.array([0.5])
    x0 = cm.consistent(np.r_[four_bar_guess(0.3), 1.0], p)
    times = np.linspace(0.0, 1.0, 5)
    ours = cm.integrate("dopri5", times, x0, p, r, rtol=1e-10, atol=1e-10)
    assert ours.max_residual < 1e-8
    u0 = side.speeds(0.0, x0[:3], p, r, {"u1": x0[3]})
    theirs = solve_ivp(lambda t_, y: side.solve(t_, y[:3], y[3:], p, r)[0], times[[0, -1]],
                       np.r_[x0[:3], u0], t_eval=times, rtol=1e-11, atol=1e-11)
    assert theirs.success
    assert_close(ours.x, theirs.y[:4].T, 1e-7)
