"""Printers: sympy expression -> C99 or Python source text.

Printers print expressions; templates own files.  Behaviour is customised the
sympy way, by overriding single ``_print_X`` methods:

* symbols print as the sanitised identifiers of the layout (or temporaries);
* small integer powers become multiplications (``x*x*x`` rather than
  ``pow(x, 3)``), ``x**-1`` a division, half-integer powers ``sqrt`` times
  multiplications (``x**(-3/2)`` is ``1.0/(sqrt(x)*x)``);
* floats keep 17 significant digits, so no value is rounded on the way.
"""

from __future__ import annotations

from typing import Mapping

import sympy as sm
from sympy.printing.c import C99CodePrinter
from sympy.printing.precedence import precedence
from sympy.printing.pycode import PythonCodePrinter

#: Largest integer power printed as repeated multiplication.
MAX_UNROLLED_POWER = 8


class _PowerMixin:
    """Shared rewriting of powers and symbols for both printers."""

    _names: Mapping[sm.Symbol, str]
    _one: str
    _sqrt: str

    def _print_Symbol(self, expr):
        try:
            return self._names[expr]
        except KeyError:
            raise KeyError(f"no name for symbol {expr} in the printer's table") from None

    def _print_Pow(self, expr, rational=False):
        base, exp = expr.base, expr.exp
        prec = precedence(expr)
        if exp.is_Integer and 1 <= abs(int(exp)) <= MAX_UNROLLED_POWER:
            b = self.parenthesize(base, prec)
            k = abs(int(exp))
            prod = b if k == 1 else "(" + "*".join([b] * k) + ")"
            return prod if exp > 0 else f"({self._one}/{prod})"
        if exp.is_Rational and exp.q == 2 and abs(exp.p) <= 2 * MAX_UNROLLED_POWER + 1:
            k = abs(int(exp.p)) // 2  # x**(n/2) = sqrt(x) * x**k
            root = f"{self._sqrt}({self._print(base)})"
            b = self.parenthesize(base, prec)
            prod = "*".join([root] + [b] * k)
            prod = prod if k == 0 else f"({prod})"
            return prod if exp > 0 else f"({self._one}/{prod})"
        return self._print_general_pow(expr)


class CPrinter(_PowerMixin, C99CodePrinter):
    """C99 printer with mbgen's symbol table and power rewriting."""

    _one = "1.0"
    _sqrt = "sqrt"

    def __init__(self, names: Mapping[sm.Symbol, str]):
        super().__init__({"precision": 17, "math_macros": {}})
        self._names = names

    def _print_general_pow(self, expr):
        return f"pow({self._print(expr.base)}, {self._print(expr.exp)})"

    def _print_Integer(self, expr):
        return f"{int(expr)}.0" if abs(int(expr)) < 2**53 else super()._print_Integer(expr)

    def _print_Float(self, expr):
        return repr(float(expr))


class PyPrinter(_PowerMixin, PythonCodePrinter):
    """Python printer (``math`` module) with mbgen's symbol table and power rewriting."""

    _one = "1.0"
    _sqrt = "math.sqrt"

    def __init__(self, names: Mapping[sm.Symbol, str]):
        super().__init__({"fully_qualified_modules": True, "standard": "python3"})
        self._names = names

    def _print_general_pow(self, expr):
        return f"math.pow({self._print(expr.base)}, {self._print(expr.exp)})"

    def _print_Rational(self, expr):
        return f"{expr.p}.0/{expr.q}.0"

    def _print_Float(self, expr):
        return repr(float(expr))


def math_functions(exprs) -> set[str]:
    """Names of the sympy functions used in ``exprs`` (for includes and audits)."""
    from .symbolic import walk_unique

    out = set()
    for node in walk_unique(exprs):
        if isinstance(node, sm.Function):
            out.add(type(node).__name__)
        elif isinstance(node, sm.Pow) and not (node.exp.is_Integer
                                               and abs(int(node.exp)) <= MAX_UNROLLED_POWER):
            half = node.exp.is_Rational and node.exp.q == 2 and \
                abs(node.exp.p) <= 2 * MAX_UNROLLED_POWER + 1
            out.add("sqrt" if half else "pow")
    return out
