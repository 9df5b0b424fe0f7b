r"""Integrators rendered into the generated C: the methods as data (this module) and their
C-template views (:mod:`mbgen.codegen.integrators`), one template each.

Asking for :attr:`~mbgen.abi.Output.DOPRI5`, ``RK4`` or ``ROSENBROCK``
adds, next to the model's functions, C integrators that run a whole trajectory
with no Python per step (see ``templates/integrators/<name>.c.j2``)::

    int <prefix>_dopri5(const double *x0[, const double *p][, const double *r],
                        int n_out, const double *t_out, double *x_out,
                        const <prefix>_options *opt, <prefix>_stats *stats);

``t_out[0]`` is the initial time and must be followed by strictly increasing
times; ``x_out`` is row-major ``n_out x n_x`` with row 0 = ``x0``; inputs ``r``
are held constant.  The methods are described here by their coefficients, as
class attributes like scipy's ``RungeKutta`` classes, and printed into the C
with full precision (``repr(float)``):

:class:`Dopri5`
    Dormand--Prince 5(4), the coefficients of ``scipy.integrate.RK45`` (a test
    compares them entry by entry), with scipy's error control and initial step
    selection, so both take nearly the same steps.  Dense output: scipy's
    4th-order continuous extension ``P``.
:class:`RK4`
    The classic fixed-step 4th-order method; every output interval is split
    into ``ceil(dt / h0)`` equal steps.
:class:`Rosenbrock` (:data:`ROSENBROCK` = :class:`Rodas4`, :class:`Rodas3` also given)
    Linearly implicit (stiff) methods with the compiled Jacobian, in the
    formulation of KPP (Sandu et al. 1997): with ``G = I/(h gamma) - J``,

    .. math::

        G K_s = f\Big(t + \alpha_s h,\; y + \sum_{j<s} a_{sj} K_j\Big)
                + \sum_{j<s} \frac{c_{sj}}{h} K_j + h \gamma_s f_t,
        \qquad y_{n+1} = y + \sum_s m_s K_s,\qquad
        \mathrm{err} = \sum_s e_s K_s .

    A stage whose argument equals the previous stage's reuses its ``f``.

Error control (DOPRI5 and Rosenbrock) follows ``scipy.integrate.RK45``:
``err = RMS(err_i / (atol + rtol max(|y_i|, |y_new_i|)))``; a step is
accepted when ``err < 1``; the next step is ``h * min(10, 0.9 err^k)``
(``max(0.2, 0.9 err^k)`` after a rejection, and no growth right after one)
with ``k = -1 / (q + 1)``, ``q`` the order of the *embedded* (error
estimating) solution, because the estimate is that solution's local error,
``O(h^(q+1))``: ``k = -1/5`` for DOPRI5, ``-1/4`` for Rodas4, ``-1/3`` for
Rodas3.  ``h0 = 0`` selects the first step as ``scipy``'s
``select_initial_step`` (one extra RHS call); ``h_max = 0`` leaves steps
unbounded; ``max_steps`` bounds the attempted steps (0 = 1000000).

Rosenbrock dense output is the cubic Hermite interpolant through ``y, f`` at
both ends of a step (``f`` at the new point is the next step's first stage,
so it costs nothing extra); it is 3rd-order accurate between steps.
"""

from __future__ import annotations

import numpy as np

from ..abi import Output

#: Default step limit when ``options.max_steps`` is 0.
DEFAULT_MAX_STEPS = 1000000


class Method:
    """What the rest of mbgen reads about an integrator, instead of testing its name.

    Attributes
    ----------
    output : Output
        The generated function ``<prefix>_<output>`` and the ``Output`` that asks for it.
    label : str
        The method's name in messages (``"the Rosenbrock integrator of ..."``).
    adaptive : bool
        Error-controlled steps (``rtol``, ``atol``); else a fixed step ``h`` is required.
    implicit : bool
        Linearly implicit: it solves with ``I/(h gamma) - J`` (stiff problems), takes a
        caller-owned ``<prefix>_<output>_work`` and needs the Jacobian.
    needs : tuple of Output
        Outputs the generated integrator calls (``TIME_DERIVATIVE`` is added when the
        equations depend on ``t`` explicitly and the method is implicit).
    """

    output: Output = NotImplemented
    label: str = NotImplemented
    adaptive: bool = True
    implicit: bool = False
    needs: tuple = (Output.RHS,)


class ExplicitRungeKutta(Method):
    """Butcher tableau of an explicit Runge--Kutta method (scipy's attribute names)."""

    name: str = NotImplemented
    order: int = NotImplemented
    n_stages: int = NotImplemented
    C: np.ndarray = NotImplemented
    A: np.ndarray = NotImplemented
    B: np.ndarray = NotImplemented


class Dopri5(ExplicitRungeKutta):
    """Dormand--Prince 5(4): exactly the coefficients of ``scipy.integrate.RK45``.

    ``E`` has ``n_stages + 1`` entries (the last multiplies ``f(t + h, y_new)``,
    first-same-as-last) and ``P`` is scipy's quartic continuous extension:
    ``y(t + s h) = y + h K^T P [s, s^2, s^3, s^4]``.
    """

    name = "dopri5"
    output = Output.DOPRI5
    label = "DOPRI5"
    order = 5
    error_estimator_order = 4
    n_stages = 6
    SAFETY = 0.9
    MIN_FACTOR = 0.2
    MAX_FACTOR = 10.0
    C = np.array([0, 1/5, 3/10, 4/5, 8/9, 1])
    A = np.array([
        [0, 0, 0, 0, 0],
        [1/5, 0, 0, 0, 0],
        [3/40, 9/40, 0, 0, 0],
        [44/45, -56/15, 32/9, 0, 0],
        [19372/6561, -25360/2187, 64448/6561, -212/729, 0],
        [9017/3168, -355/33, 46732/5247, 49/176, -5103/18656]
    ])
    B = np.array([35/384, 0, 500/1113, 125/192, -2187/6784, 11/84])
    E = np.array([-71/57600, 0, 71/16695, -71/1920, 17253/339200, -22/525,
                  1/40])
    P = np.array([
        [1, -8048581381/2820520608, 8663915743/2820520608,
         -12715105075/11282082432],
        [0, 0, 0, 0],
        [0, 131558114200/32700410799, -68118460800/10900136933,
         87487479700/32700410799],
        [0, -1754552775/470086768, 14199869525/1410260304,
         -10690763975/1880347072],
        [0, 127303824393/49829197408, -318862633887/49829197408,
         701980252875 / 199316789632],
        [0, -282668133/205662961, 2019193451/616988883, -1453857185/822651844],
        [0, 40617522/29380423, -110615467/29380423, 69997945/29380423]])


class RK4(ExplicitRungeKutta):
    """The classic 4th-order Runge--Kutta method (fixed step)."""

    name = "rk4"
    output = Output.RK4
    label = "RK4"
    adaptive = False
    order = 4
    n_stages = 4
    C = np.array([0, 1/2, 1/2, 1])
    A = np.array([
        [0, 0, 0],
        [1/2, 0, 0],
        [0, 1/2, 0],
        [0, 0, 1],
    ])
    B = np.array([1/6, 1/3, 1/3, 1/6])


class Rosenbrock(Method):
    """A Rosenbrock method in the KPP form (see the module docstring).

    Attributes
    ----------
    gamma : float
        Diagonal coefficient: every stage solves with ``I/(h gamma) - J``.
    alpha : array (s,)
        Stage times ``t + alpha_s h``.
    gamma_t : array (s,)
        Coefficients ``gamma_s`` of ``h f_t`` (non-autonomous problems).
    A, C : arrays (s, s)
        Strictly lower triangular stage couplings ``a_sj`` and ``c_sj``.
    M, E : arrays (s,)
        Solution and error weights.
    order, error_estimator_order : int
        Orders of the solution and of the embedded solution ``y + (M - E) K``.
    """

    name: str = NotImplemented
    output = Output.ROSENBROCK
    label = "Rosenbrock"
    implicit = True
    needs = (Output.RHS, Output.JACOBIAN)
    reference: str = ""
    order: int = NotImplemented
    error_estimator_order: int = NotImplemented
    gamma: float = NotImplemented
    alpha: np.ndarray = NotImplemented
    gamma_t: np.ndarray = NotImplemented
    A: np.ndarray = NotImplemented
    C: np.ndarray = NotImplemented
    M: np.ndarray = NotImplemented
    E: np.ndarray = NotImplemented
    SAFETY = 0.9
    MIN_FACTOR = 0.2
    MAX_FACTOR = 10.0

    @classmethod
    def n_stages(cls) -> int:
        return len(cls.alpha)

    @classmethod
    def new_f(cls) -> list[bool]:
        """Whether stage ``s`` needs a new ``f`` (its argument differs from stage ``s-1``'s)."""
        flags = [True]
        for s in range(1, cls.n_stages()):
            same = cls.alpha[s] == cls.alpha[s - 1] and all(
                cls.A[s, j] == (cls.A[s - 1, j] if j < s - 1 else 0.0) for j in range(s))
            flags.append(not same)
        return flags

    @classmethod
    def step(cls, f, jac, dfdt, t: float, y, h: float):
        """One step with the tableau (reference implementation): ``(y_new, err)``.

        ``f(t, y)``, ``jac(t, y)`` and ``dfdt(t, y)`` (or ``None`` for an
        autonomous problem) return arrays.  Used to verify the coefficients.
        """
        y = np.asarray(y, dtype=float)
        G = np.eye(y.size) / (h * cls.gamma) - np.atleast_2d(jac(t, y))
        ft = None if dfdt is None else np.asarray(dfdt(t, y), dtype=float)
        K = []
        fs = None
        for s, new in enumerate(cls.new_f()):
            if new:
                ys = y + sum((cls.A[s, j] * K[j] for j in range(s)), np.zeros_like(y))
                fs = np.asarray(f(t + cls.alpha[s] * h, ys), dtype=float)
            rhs = fs + sum((cls.C[s, j] / h * K[j] for j in range(s)), np.zeros_like(y))
            if ft is not None:
                rhs = rhs + h * cls.gamma_t[s] * ft
            K.append(np.linalg.solve(G, rhs))
        y_new = y + sum(m * k for m, k in zip(cls.M, K))
        err = sum(e * k for e, k in zip(cls.E, K))
        return y_new, err

    @classmethod
    def fixed_steps(cls, f, jac, dfdt, t_span, y0, n: int, embedded: bool = False):
        """``n`` equal steps over ``t_span``; the embedded solution when ``embedded``."""
        t0, t1 = t_span
        h = (t1 - t0) / n
        y = np.asarray(y0, dtype=float)
        for i in range(n):
            y_new, err = cls.step(f, jac, dfdt, t0 + i * h, y, h)
            y = y_new - err if embedded else y_new
        return y


class Rodas3(Rosenbrock):
    """Rodas3: 4 stages, order 3(2), stiffly accurate, L-stable.

    Coefficients of ``Rodas3`` in KPP's ``Rosenbrock`` integrator, after
    Sandu, Verwer, Blom, Spee, Carmichael, Potra (1997), "Benchmarking stiff
    ODE solvers for atmospheric chemistry problems II: Rosenbrock solvers",
    Atmos. Environ. 31, 3459-3472.
    """

    name = "rodas3"
    reference = "Sandu et al. (1997), Atmos. Environ. 31:3459; KPP ros_Rodas3"
    order = 3
    error_estimator_order = 2
    gamma = 0.5
    alpha = np.array([0.0, 0.0, 1.0, 1.0])
    gamma_t = np.array([0.5, 1.5, 0.0, 0.0])
    A = np.array([
        [0.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0],
        [2.0, 0.0, 0.0, 0.0],
        [2.0, 0.0, 1.0, 0.0],
    ])
    C = np.array([
        [0.0, 0.0, 0.0, 0.0],
        [4.0, 0.0, 0.0, 0.0],
        [1.0, -1.0, 0.0, 0.0],
        [1.0, -1.0, -8/3, 0.0],
    ])
    M = np.array([2.0, 0.0, 1.0, 1.0])
    E = np.array([0.0, 0.0, 0.0, 1.0])


class Rodas4(Rosenbrock):
    """Rodas4: 6 stages, order 4(3), stiffly accurate, L-stable.

    Coefficients of Hairer & Wanner's ``RODAS`` (``rodas.f``, ``METH = 1``,
    subroutine ``ROCOE``; Hairer, Wanner, Solving ODEs II, sec. IV.7), in the
    same transformed variables as KPP's ``ros_Rodas4``: ``a_6j = a_5j`` for
    ``j < 5``, ``a_65 = 1``, ``M = [a_51 .. a_54, 1, 1]``, ``E = e_6``.
    """

    name = "rodas4"
    reference = "Hairer & Wanner, Solving ODEs II, IV.7 (rodas.f ROCOE, METH=1); KPP ros_Rodas4"
    order = 4
    error_estimator_order = 3
    gamma = 0.25
    alpha = np.array([0.0, 0.386, 0.21, 0.63, 1.0, 1.0])
    gamma_t = np.array([0.25, -0.1043, 0.1035, -0.0362, 0.0, 0.0])
    _a5 = [0.1221224509226641e+01, 0.6019134481288629e+01, 0.1253708332932087e+02,
           -0.6878860361058950e+00]
    A = np.array([
        [0.0] * 6,
        [0.1544e+01, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.9466785280815826e+00, 0.2557011698983284e+00, 0.0, 0.0, 0.0, 0.0],
        [0.3314825187068521e+01, 0.2896124015972201e+01, 0.9986419139977817e+00, 0.0, 0.0,
         0.0],
        _a5 + [0.0, 0.0],
        _a5 + [1.0, 0.0],
    ])
    C = np.array([
        [0.0] * 6,
        [-0.56688e+01, 0.0, 0.0, 0.0, 0.0, 0.0],
        [-0.2430093356833875e+01, -0.2063599157091915e+00, 0.0, 0.0, 0.0, 0.0],
        [-0.1073529058151375e+00, -0.9594562251023355e+01, -0.2047028614809616e+02, 0.0,
         0.0, 0.0],
        [0.7496443313967647e+01, -0.1024680431464352e+02, -0.3399990352819905e+02,
         0.1170890893206160e+02, 0.0, 0.0],
        [0.8083246795921522e+01, -0.7981132988064893e+01, -0.3152159432874371e+02,
         0.1631930543123136e+02, -0.6058818238834054e+01, 0.0],
    ])
    M = np.array(_a5 + [1.0, 1.0])
    E = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
    del _a5


#: The Rosenbrock method rendered as ``<prefix>_rosenbrock``.
ROSENBROCK = Rodas4


__all__ = ["Method", "ExplicitRungeKutta", "Dopri5", "RK4", "Rosenbrock", "Rodas3", "Rodas4",
           "ROSENBROCK", "DEFAULT_MAX_STEPS"]
