r"""The Whipple bicycle with its rolling stated as constraints: four bodies, two wheel contacts.

The model is stated the way a vehicle engineer draws it, with nothing solved by
hand: a rear frame (with the rider) that carries the rear wheel, a front frame
(fork and handlebar) steering about the head axis, and two knife-edge wheels.
The ground contact is three constraints, none of them embedded in the
coordinates:

* the front wheel touches the ground: its lowest point has height zero
  (:meth:`~mbgen.Model.holonomic`, dependent coordinate: the pitch ``pitch``);
* neither wheel slips: the material point of each wheel at its contact has no
  horizontal velocity (:meth:`~mbgen.Model.no_slip` along n1 and n2, twice).

Frames (z up, gravity ``-g n3``)::

    Y  = N turned by yaw about n3           heading
    L  = Y turned by roll about y1          lean (its z axis lies in the rear wheel plane)
    R  = L turned by pitch about l2         rear frame; r3 is the steer (head) axis
    RW = R turned by theta_r about r2       rear wheel
    F  = R turned by steer about r3         front frame
    FW = F turned by theta_f about f2       front wheel

Points: the rear contact ``P = x n1 + y n2``, the rear hub ``CR = P + rR l3``, the
front hub ``CF = CR + d1 r1 + d2 r3 + d3 f1``, the front contact ``CF - rF k`` with
``k`` the unit vector in the front wheel plane nearest to n3, ``k = (n3 - (f2 . n3)
f2) / sqrt(1 - (f2 . n3)^2)``.  The three offsets come from the benchmark's
geometry (wheelbase ``w``, trail ``c``, head angle ``lam``; rear frame pitched by
``-lam`` so that its z axis is the head axis)::

    d1 = cos(lam) (w + c) - rR sin(lam)      hub to head axis, along r1
    d2 = (rF - rR) cos(lam) - w sin(lam)     along the head axis
    d3 = rF sin(lam) - c cos(lam)            head axis to front hub (fork offset), along f1

Coordinates ``x, y, yaw, roll, pitch, steer, theta_r, theta_f`` with ``q' = u``;
eight speeds of which ``vx, vy`` (rear contact), ``w_yaw, w_f`` (front contact) and
``w_pitch`` (the contact's height) are dependent: three degrees of freedom, the
roll rate ``w_roll``, the steer rate ``w_steer`` and the rear wheel rate ``w_r``.

Numbers: the benchmark bicycle of Meijaard, Papadopoulos, Ruina and Schwab
(Proc. R. Soc. A 463, 2007, table 1), its inertias turned from their z-down axes to
these z-up rear and front frames.  Published facts the tests reproduce: the
upright straight run is self-stable between the weave speed ``v_w = 4.292 m/s``
and the capsize speed ``v_c = 6.024 m/s``.  The constraint forces do no work,
nothing dissipates: ``T + V`` is conserved.

The default run goes straight at 4.6 m/s (inside the stable range) with a roll
rate of 0.5 rad/s: the weave dies out and the bicycle rights itself.
"""

from __future__ import annotations

import math

import mpmath
import sympy as sm

from .. import Model, Output, Scene

#: Meijaard et al. (2007), table 1 (z down, x forward; inertias about the mass centres).
BENCHMARK = dict(w=1.02, c=0.08, lam=math.pi / 10, g=9.81, rR=0.3, mR=2.0, IRxx=0.0603,
                 IRyy=0.12, xB=0.3, zB=-0.9, mB=85.0, IBxx=9.2, IByy=11.0, IBzz=2.8, IBxz=2.4,
                 xH=0.9, zH=-0.7, mH=4.0, IHxx=0.05892, IHyy=0.06, IHzz=0.00708,
                 IHxz=-0.00756, rF=0.35, mF=3.0, IFxx=0.1405, IFyy=0.28)
#: Published weave and capsize speeds of the benchmark (m/s).
WEAVE_SPEED, CAPSIZE_SPEED = 4.292, 6.024


def _frame_data(b: dict) -> dict:
    """The benchmark's numbers in this model's z-up rear and front frames (nominal pose).

    Computed in 40-digit arithmetic (mpmath) from the doubles of :data:`BENCHMARK` and
    rounded once to doubles, so the constants, and the code generated with them baked
    in, are the same bits on every machine: a BLAS matrix product (numpy's ``@``) sums in
    an order and with fused multiply-adds that depend on the CPU's kernel, which changed
    the Whipple bicycle's CSE (7196 against 7186 operations) from machine to machine.
    """
    with mpmath.workprec(133):                                    # 40 decimal digits
        v = {k: mpmath.mpf(x) for k, x in b.items()}
        lam, w, c, rR, rF = v["lam"], v["w"], v["c"], v["rR"], v["rF"]
        cl, sl = mpmath.cos(lam), mpmath.sin(lam)
        x_axis = mpmath.matrix([cl, 0, sl])                       # r1 in n at pitch -lam
        z_axis = mpmath.matrix([-sl, 0, cl])                      # r3: the head axis
        C = mpmath.matrix([[cl, 0, -sl], [0, 1, 0], [sl, 0, cl]])
        flip = mpmath.diag([1, -1, -1])                           # z down -> z up

        def inertia(xx, yy, zz, xz):
            return C.T * (flip * mpmath.matrix([[xx, 0, xz], [0, yy, 0], [xz, 0, zz]])
                          * flip) * C

        def offset(x, z, origin):
            r = mpmath.matrix([x, 0, -z]) - origin
            return (r.T * x_axis)[0], (r.T * z_axis)[0]

        hub_r, hub_f = mpmath.matrix([0, 0, rR]), mpmath.matrix([w, 0, rF])
        out = dict(d1=cl * (w + c) - rR * sl, d2=(rF - rR) * cl - w * sl,
                   d3=rF * sl - c * cl, rR=rR, rF=rF, g=v["g"],
                   mB=v["mB"], mH=v["mH"], mR=v["mR"], mF=v["mF"],
                   IRxx=v["IRxx"], IRyy=v["IRyy"], IFxx=v["IFxx"], IFyy=v["IFyy"])
        out["xB"], out["zB"] = offset(v["xB"], v["zB"], hub_r)
        out["xH"], out["zH"] = offset(v["xH"], v["zH"], hub_f)
        IB = inertia(v["IBxx"], v["IByy"], v["IBzz"], v["IBxz"])
        IH = inertia(v["IHxx"], v["IHyy"], v["IHzz"], v["IHxz"])
        out.update(IBxx=IB[0, 0], IByy=IB[1, 1], IBzz=IB[2, 2], IBxz=IB[0, 2],
                   IHxx=IH[0, 0], IHyy=IH[1, 1], IHzz=IH[2, 2], IHxz=IH[0, 2])
        return {k: float(x) for k, x in out.items()}


#: The constants of :func:`build_model` for the benchmark bicycle.
PARAMETERS = _frame_data(BENCHMARK)


def build_model() -> Model:
    """The Whipple bicycle; constants as in :data:`PARAMETERS`."""
    m = Model("whipple")
    x, y, yaw, roll, pitch, steer, theta_r, theta_f = m.coordinates(
        "x y yaw roll pitch steer theta_r theta_f")
    vx, vy, w_yaw, w_roll, w_pitch, w_steer, w_r, w_f = m.speeds(
        "vx vy w_yaw w_roll w_pitch w_steer w_r w_f")
    (d1, d2, d3, rR, rF, g, mB, mH, mR, mF, IRxx, IRyy, IFxx, IFyy, xB, zB, xH, zH,
     IBxx, IByy, IBzz, IBxz, IHxx, IHyy, IHzz, IHxz) = m.constants(
        "d1 d2 d3 rR rF g mB mH mR mF IRxx IRyy IFxx IFyy xB zB xH zH "
        "IBxx IByy IBzz IBxz IHxx IHyy IHzz IHxz")
    N = m.newtonian()
    Y = m.rotate(N, "Y", 3, yaw)
    L = m.rotate(Y, "L", 1, roll)
    R = m.rotate(L, "R", 2, pitch)
    RW = m.rotate(R, "RW", 2, theta_r)
    F = m.rotate(R, "F", 3, steer)
    FW = m.rotate(F, "FW", 2, theta_f)

    P = m.point("P", m.origin, x * N.x + y * N.y)                # rear contact
    CR = m.point("CR", P, rR * L.z)                              # rear hub
    CF = m.point("CF", CR, d1 * R.x + d2 * R.z + d3 * F.x)       # front hub
    tilt = F.y.dot(N.z)
    k = (N.z - tilt * F.y) / sm.sqrt(1 - tilt**2)
    Q = m.point("Q", CF, -rF * k)                                # front contact
    GB = m.point("GB", CR, xB * R.x + zB * R.z)
    GH = m.point("GH", CF, xH * F.x + zH * F.z)

    m.body("rear_frame", R, mB, sm.Matrix([[IBxx, 0, IBxz], [0, IByy, 0], [IBxz, 0, IBzz]]),
           GB)
    m.body("front_frame", F, mH, sm.Matrix([[IHxx, 0, IHxz], [0, IHyy, 0], [IHxz, 0, IHzz]]),
           GH)
    m.body("rear_wheel", RW, mR, (IRxx, IRyy, IRxx), CR)
    front_wheel = m.body("front_wheel", FW, mF, (IFxx, IFyy, IFxx), CF)
    rear_wheel = m.bodies[-2]
    m.gravity(-g * N.z)

    m.holonomic(Q.pos_from(m.origin).dot(N.z), pitch, names=["front_height"])
    m.no_slip(P, rear_wheel, [vx, vy], axes=(1, 2), name="rear")
    m.no_slip(Q, front_wheel, [w_yaw, w_f], axes=(1, 2), name="front")
    return m


def upright_state(speed: float, roll_rate: float = 0.0) -> dict:
    """Upright and straight at ``speed`` (m/s) along n1; pitch is the nominal ``-lam``."""
    return {"pitch": -BENCHMARK["lam"], "w_r": speed / BENCHMARK["rR"], "w_roll": roll_rate}


def scene(speed: float = 4.6, roll_rate: float = 0.5) -> Scene:
    """Straight run at ``speed`` m/s, pushed with a roll rate of ``roll_rate`` rad/s."""
    return Scene(
        name="whipple",
        model=build_model(),
        outputs=(Output.RHS, Output.ENERGY, Output.CONSTRAINT_FORCES, Output.DOPRI5),
        parameters={"g": PARAMETERS["g"]},
        fixed={k: v for k, v in PARAMETERS.items() if k != "g"},
        initial_state=upright_state(speed, roll_rate),
        t_span=(0.0, 5.0),
        description="Whipple bicycle (benchmark), rolling contacts stated with no_slip "
                    "and the front contact's height",
        conserves_energy=True,
    )
