r"""Straight-line ``L D L^T`` solvers for the mass matrix's sparsity pattern.

``M`` is symmetric positive definite, so ``M = L D L^T`` with unit lower
triangular ``L`` and diagonal ``D > 0``.  Unlike Cholesky this needs no square root.

Singular is singular: a pivot is compared with the scale of its column, not with 0.
A matrix that is singular in exact arithmetic (a rank-one ``M``; the four-bar whose
crank has zero length) leaves a pivot of rounding noise, of either sign, and dividing
by it gives accelerations of 1e16.  The factorisation's own backward error is
within ``(n + 1) eps M_jj`` on the diagonal (Higham, *Accuracy and Stability of
Numerical Algorithms*, Thm. 10.3: ``|L| |D| |L^T|`` has the diagonal ``M_jj`` when
``D > 0``) and the computed entries of ``M`` carry a few ulps more, so ::

    d_j <= tol_j = PIVOT_ULPS * n * eps * M_jj     (eps = DBL_EPSILON = 2^-52)

(or NaN) is "not positive definite": the pivot is indistinguishable from rounding
(a pivot that small would leave at most a digit or two of ``u'``).  As LAPACK's
pivoted Cholesky (``dpstrf``, tolerance ``n eps max_j A_jj``) the test is relative,
but per column: it is invariant under a change of units of any coordinate
(``M -> D M D``), so a diagonal ``M`` with entries 1e-20 and 1 is still solved.
A matrix computed as a sum that may cancel checks its pivots against the
magnitude of the summands as well: the reduced mass matrix ``T^T M T`` of a
constrained model (``templates/model/constraints.c.j2``, ``kkt_factor``).

For ``n_u <= UNROLL_MAX`` the factorisation and the solve are emitted as
straight-line code that touches only the structural nonzeros of ``L`` (the
nonzeros of ``M`` plus fill-in); a diagonal ``M`` becomes ``n_u`` checks and
divisions.  Larger systems use the dense loops in the templates.

Storage: ``M`` row-major ``n x n``; the factor overwrites the lower triangle
(``L`` strictly below the diagonal, ``D`` on it).  The solve overwrites ``b``.

Algorithm (column ``j``, with ``w_k = L_jk d_k``)::

    d_j  = M_jj - sum_k L_jk w_k                  (singular unless d_j > tol_j)
    L_ij = (M_ij - sum_k L_ik w_k) / d_j          (i > j)
    solve: b_i -= sum_k L_ik b_k (k < i);  b_i /= d_i;  b_i -= sum_k L_ki b_k (k > i)
"""

from __future__ import annotations

from dataclasses import dataclass

#: Largest ``n_u`` whose solver is unrolled into straight-line code.
UNROLL_MAX = 12
#: A pivot ``d_j <= PIVOT_ULPS * n * eps * M_jj`` is singular (the module docstring).
PIVOT_ULPS = 16
#: The one pivot rule of every LU factorisation in the generated code (the constraint block
#: ``A_r``, the projection's Jacobian, Rosenbrock's ``I / (h gamma) - J``: the runtime routine
#: ``lu``): partial pivoting, and a pivot ``|u_kk| <= LU_PIVOT * max_ij |A_ij|`` is singular.
#: A general matrix has no diagonal to scale by, so the rule is relative to its largest entry;
#: ``1e-13`` is stricter than rounding (``n eps`` for the sizes met here) because a solve with
#: a smaller pivot keeps fewer than 3 of its 16 digits.  The generated Python and the
#: lambdified reference (``CONSTRAINT_PIVOT``) state the same number.
LU_PIVOT = 1e-13


def pivot_factor(n: int) -> str:
    """``"<PIVOT_ULPS n> * DBL_EPSILON"``: the factor of ``M_jj`` in the pivot threshold, the same
    text in C (``<float.h>``) and in the generated Python (which defines ``DBL_EPSILON``)."""
    return f"{PIVOT_ULPS * n} * DBL_EPSILON"


def fill_pattern(n: int, pattern: frozenset) -> frozenset:
    """Structural nonzeros ``(i, j)``, ``i > j``, of ``L`` for the lower pattern of ``M``."""
    L: set = set()
    for j in range(n):
        for i in range(j + 1, n):
            if (i, j) in pattern or any((i, k) in L and (j, k) in L for k in range(j)):
                L.add((i, j))
    return frozenset(L)


@dataclass(frozen=True)
class Statement:
    """One step: ``target = value``, or a check ``target > value`` of a pivot."""

    kind: str      # "let" (new local), "set" (array element), "check"
    target: str
    value: str = ""


def _m(n, i, j, name="M"):
    return f"{name}[{i * n + j}]"


def factor_program(n: int, pattern: frozenset) -> list[Statement]:
    """Unrolled in-place ``L D L^T`` factorisation of ``M`` (pattern: lower nonzeros, i > j)."""
    L = fill_pattern(n, pattern)
    out: list[Statement] = []
    for j in range(n):
        ks = [k for k in range(j) if (j, k) in L]
        out.append(Statement("let", f"tol{j}", f"{pivot_factor(n)} * {_m(n, j, j)}"))
        for k in ks:
            out.append(Statement("let", f"w{j}_{k}", f"{_m(n, j, k)}*{_m(n, k, k)}"))
        if ks:
            out.append(Statement("set", _m(n, j, j), " - ".join(
                [_m(n, j, j)] + [f"{_m(n, j, k)}*w{j}_{k}" for k in ks])))
        out.append(Statement("check", _m(n, j, j), f"tol{j}"))
        for i in range(j + 1, n):
            if (i, j) not in L:
                continue
            terms = [f"{_m(n, i, k)}*w{j}_{k}" for k in ks if (i, k) in L]
            num = " - ".join([_m(n, i, j)] + terms)
            out.append(Statement("set", _m(n, i, j),
                                 f"({num})/{_m(n, j, j)}" if terms else f"{num}/{_m(n, j, j)}"))
    return out


def solve_program(n: int, pattern: frozenset, b: str = "b", offset: str = "") -> list[Statement]:
    """Unrolled solve of ``L D L^T y = b`` in place (``b[offset + i]``)."""
    L = fill_pattern(n, pattern)

    def bi(i):
        return f"{b}[{offset}{i}]" if offset else f"{b}[{i}]"

    out: list[Statement] = []
    for i in range(n):
        ks = [k for k in range(i) if (i, k) in L]
        if ks:
            out.append(Statement("set", bi(i), " - ".join(
                [bi(i)] + [f"{_m(n, i, k)}*{bi(k)}" for k in ks])))
    for i in range(n):
        out.append(Statement("set", bi(i), f"{bi(i)}/{_m(n, i, i)}"))
    for i in reversed(range(n)):
        ks = [k for k in range(i + 1, n) if (k, i) in L]
        if ks:
            out.append(Statement("set", bi(i), " - ".join(
                [bi(i)] + [f"{_m(n, k, i)}*{bi(k)}" for k in ks])))
    return out


def solve_ops(n: int, pattern: frozenset) -> int:
    """Floating-point operations of factoring ``M`` and solving once (the unrolled programs).

    Used to weigh ``M u' = F`` against a recursion; loops (``n > UNROLL_MAX``)
    are counted as their dense equivalent.
    """
    if n > UNROLL_MAX:
        pattern = frozenset((i, j) for i in range(n) for j in range(i))
    ops = 0
    for st in factor_program(n, pattern) + solve_program(n, pattern):
        if st.kind != "check" and not st.target.startswith("tol"):
            ops += st.value.count("*") + st.value.count(" - ") + st.value.count("/")
    return ops


def c_lines(program: list[Statement], fail: str) -> list[str]:
    """C statements; a failed check returns ``fail``."""
    out = []
    for s in program:
        if s.kind == "let":
            out.append(f"const double {s.target} = {s.value};")
        elif s.kind == "set":
            out.append(f"{s.target} = {s.value};")
        else:
            out.append(f"if (!({s.target} > {s.value})) return {fail};")
    return out


def py_lines(program: list[Statement], fail: str) -> list[str]:
    """Python statements; a failed check raises ``fail`` (an exception expression)."""
    out = []
    for s in program:
        if s.kind in ("let", "set"):
            out.append(f"{s.target} = {s.value}")
        else:
            out.append(f"if not {s.target} > {s.value}:")
            out.append(f"    raise {fail}")
    return out
