"""Printers: sympy expression -> C99 or Python source text.

Printers print expressions; templates own files.  Behaviour is customised the
sympy way, by overriding single ``_print_X`` methods:

* symbols print as the sanitised identifiers of the layout (or temporaries);
* small integer powers become multiplications (``x*x*x`` rather than
  ``pow(x, 3)``), ``x**-1`` a division, half-integer powers ``sqrt`` times
  multiplications (``x**(-3/2)`` is ``1.0/(sqrt(x)*x)``);
* floats keep 17 significant digits, so no value is rounded on the way;
* a non-finite constant (``inf``, ``nan``, ``zoo``) is never printed: it raises
  :class:`NonFiniteConstantError` (a bare ``inf`` does not compile, and a NaN
  baked into code would poison every result silently).

Which powers print as products is decided by one function, :func:`power_form`;
the C and Python printers, :func:`math_functions` and the CSE pass that hoists
repeated bases (:mod:`mbgen.codegen.cse`) all ask it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import sympy as sm
from sympy.core.exprtools import decompose_power
from sympy.core.sorting import default_sort_key
from sympy.printing.c import C99CodePrinter
from sympy.printing.precedence import PRECEDENCE, precedence
from sympy.printing.pycode import PythonCodePrinter

from ..errors import NonFiniteConstantError
from ..symbolic.graph import walk_unique

#: Largest integer power printed as repeated multiplication.
MAX_UNROLLED_POWER = 8


def power_form(exp) -> tuple[str, int] | None:
    """How ``base**exp`` prints; the single rule for unrolled powers.

    Returns
    -------
    ("product", k)
        ``exp = +-k`` with ``1 <= k <= MAX_UNROLLED_POWER``: ``b*b*...*b`` (k
        factors), divided into 1 when negative.
    ("sqrt", k)
        ``exp = +-(k + 1/2)`` with ``k <= MAX_UNROLLED_POWER``: ``sqrt(b)*b*...*b``
        (k factors after the root), divided into 1 when negative.
    None
        Anything else: a general ``pow(b, exp)``.
    """
    if exp.is_Integer and 1 <= abs(int(exp)) <= MAX_UNROLLED_POWER:
        return "product", abs(int(exp))
    if exp.is_Rational and exp.q == 2 and abs(exp.p) <= 2 * MAX_UNROLLED_POWER + 1:
        return "sqrt", abs(int(exp.p)) // 2
    return None


def printed_base_count(exp) -> int:
    """How many times a power with exponent ``exp`` prints its base (1 for ``pow``)."""
    form = power_form(exp)
    if form is None:
        return 1
    kind, k = form
    return k if kind == "product" else 1 + k


def _refuse_nonfinite(expr):
    raise NonFiniteConstantError(
        f"the generated code would contain the non-finite constant {expr}; a parameter, fixed "
        f"value or number in the model is inf or nan (or a division by zero was folded): "
        f"give finite values")


class _PowerMixin:
    """Shared rewriting of powers and symbols for both printers."""

    def doprint(self, expr, assign_to=None):
        """sympy's ``doprint``, by :class:`_Fast` where ``expr`` is an expression alone."""
        if assign_to is not None or not isinstance(expr, sm.Expr):
            return super().doprint(expr, assign_to)
        self._not_supported, self._number_symbols = set(), set()
        fast = self.__dict__.get("_fast")
        if fast is None:   # one per printer: its numbers' texts serve every expression
            fast = self._fast = _Fast(self)
        text = fast.text(expr)
        if self._not_supported or self._number_symbols or "\n" in text:
            return super().doprint(expr, assign_to)
        return text

    def _handle_UnevaluatedExpr(self, expr):
        """sympy's printers rebuild every expression with ``replace`` to strip ``re`` around an
        ``UnevaluatedExpr`` (a quarter of the 32-link arm's render); only an expression that
        holds an ``re`` is handed to it."""
        if any(isinstance(node, sm.re) for node in walk_unique([expr])):
            return super()._handle_UnevaluatedExpr(expr)
        return expr

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
        form = power_form(exp)
        if form is not None and form[0] == "product":
            b = self.parenthesize(base, prec)
            k = form[1]
            prod = b if k == 1 else "(" + "*".join([b] * k) + ")"
            return prod if exp > 0 else f"({self._one}/{prod})"
        if form is not None:
            k = form[1]  # x**(n/2) = sqrt(x) * x**k
            root = f"{self._sqrt}({self._print(base)})"
            b = self.parenthesize(base, prec)
            prod = "*".join([root] + [b] * k)
            prod = prod if k == 0 else f"({prod})"
            return prod if exp > 0 else f"({self._one}/{prod})"
        return self._print_general_pow(expr)

    def _print_Float(self, expr):
        value = float(expr)
        if not math.isfinite(value):
            _refuse_nonfinite(expr)
        return repr(value)

    def _print_Infinity(self, expr):
        _refuse_nonfinite(expr)

    _print_NegativeInfinity = _print_ComplexInfinity = _print_NaN = _print_Infinity


class _Fast:
    """sympy's printing of sums, products and powers, without its detours: the same text.

    ``printer.doprint`` of one temporary went through ``replace`` over the expression, a
    ``precedence`` lookup along the class's MRO per node, ``could_extract_minus_sign``
    (which builds ``-expr``) and ``_keep_coeff`` (a new product) per product: most of the
    32-link arm's render.  This walks the expression once with the rules of sympy 1.14's
    ``StrPrinter._print_Add``, ``CodePrinter._print_Mul``, :mod:`sympy.printing.precedence`
    and :meth:`_PowerMixin._print_Pow`, in the sorted order with sympy's own sorting of
    terms and factors; anything else (a function, a general power) is printed by the
    printer itself.  Tested against sympy's printing, character for character, on the
    4-link arm's RHS and Jacobian and the 3-link cart (``tests/codegen/test_printing.py``).
    """

    def __init__(self, printer):
        self.p = printer
        self.sorted = printer.order not in ("old", "none")
        self.numbers: dict = {}

    def prec(self, e) -> int:
        if e.is_Symbol:
            return PRECEDENCE["Atom"]
        if e.is_Add:
            return PRECEDENCE["Add"]
        if e.is_Pow:
            return PRECEDENCE["Pow"]
        if e.is_Mul and not any(a.is_Function for a in e.args):
            c = e.args[0]
            return PRECEDENCE["Add"] if c.is_Number and _negative(c) else PRECEDENCE["Mul"]
        return precedence(e)

    def paren(self, e, level) -> str:
        return f"({self.text(e)})" if self.prec(e) <= level else self.text(e)

    def text(self, e) -> str:
        if e.is_Symbol:
            return self.p._print_Symbol(e)
        if e.is_Number:
            hit = self.numbers.get(e)
            if hit is None:
                hit = self.numbers[e] = self.p._print(e)
            return hit
        if e.is_Add:
            return self.add(e)
        if e.is_Mul and e.is_commutative:
            return self.mul(e)
        if e.is_Pow and power_form(e.exp) is not None:
            return self.pow(e.base, e.exp)
        return self.p._print(e)

    def add(self, e) -> str:
        words = []
        for term in ordered_terms(e) if self.sorted else e.args:
            t = self.text(term)
            sign = "+"
            if t.startswith("-") and not term.is_Add:
                sign, t = "-", t[1:]
            words += [sign, f"({t})" if self.prec(term) < PRECEDENCE["Add"] or term.is_Add
                      else t]
        sign = words.pop(0)
        return ("" if sign == "+" else sign) + " ".join(words)

    def mul(self, e) -> str:
        prec = self.prec(e)
        args = list(e.args)
        sign = "-" if args[0].is_Number and _negative(args[0]) else ""
        if sign:   # what sympy's _keep_coeff(-c, rest) holds, without building it
            c = -args[0]
            args = args[1:] if c is sm.S.One else [c] + args[1:]
        if self.sorted:     # as_ordered_factors() of that product: sorted by sort_key
            args.sort(key=default_sort_key)
        a, b, paren = [], [], []
        for item in args:
            if item.is_Pow and item.exp.is_Rational and item.exp.p < 0:
                if item.exp != -1:
                    b.append(sm.Pow(item.base, -item.exp, evaluate=False))
                else:
                    if len(item.args[0].args) != 1 and isinstance(item.base, sm.Mul):
                        paren.append(item)
                    b.append(item.base)
            else:
                a.append(item)
        a = a or [sm.S.One]
        if len(a) == 1 and sign == "-":
            a_str = [self.paren(a[0], 0.5 * (PRECEDENCE["Pow"] + PRECEDENCE["Mul"]))]
        else:
            a_str = [self.paren(x, prec) for x in a]
        b_str = [self.paren(x, prec) for x in b]
        for item in paren:
            if item.base in b:
                b_str[b.index(item.base)] = f"({b_str[b.index(item.base)]})"
        if not b:
            return sign + "*".join(a_str)
        if len(b) == 1:
            return sign + "*".join(a_str) + "/" + b_str[0]
        return sign + "*".join(a_str) + "/(" + "*".join(b_str) + ")"

    def pow(self, base, exp) -> str:
        kind, k = power_form(exp)
        one = self.p._one
        b = self.paren(base, PRECEDENCE["Pow"])
        if kind == "product":
            prod = b if k == 1 else "(" + "*".join([b] * k) + ")"
        else:
            prod = "*".join([f"{self.p._sqrt}({self.text(base)})"] + [b] * k)
            prod = prod if k == 0 else f"({prod})"
        return prod if exp > 0 else f"({one}/{prod})"


def ordered_terms(e) -> list:
    """``e.as_ordered_terms()`` (sympy's printing order of a sum's terms), without its detours.

    sympy splits each term into a coefficient (``complex(c)``, an ``evalf``) and a monomial
    over the sum's generators (a new product per term, ``as_coeff_Mul``) and sorts by the
    negated monomial, then the coefficient.  This does the same for a sum of real numbers and
    products of commutative, non-numeric factors, where each term's monomial is read from its
    arguments (like terms are combined, so two terms never tie on the monomial); anything
    else, and sympy's special case of ``number + number*x``, is handed to sympy itself.  The
    two are compared term for term in ``tests/codegen/test_printing.py``.
    """
    args = e.args
    if len(args) == 2 and any(a.is_Number or a.is_NumberSymbol for a in args):
        return e.as_ordered_terms()
    gens: set = set()
    rows = []
    for term in args:
        if term.is_Number:
            c, factors = term, ()
        elif term.is_Mul and term.args[0].is_Number:   # sympy's as_coeff_Mul, make_args
            c, factors = term.args[0], term.args[1:]
            if len(factors) == 1 and factors[0].is_Mul:
                factors = factors[0].args
        elif term.is_Mul:
            c, factors = sm.S.One, term.args
        else:
            c, factors = sm.S.One, (term,)
        if not (c.is_Rational or c.is_Float):
            return e.as_ordered_terms()
        cpart = {}
        for f in factors:
            if f.is_Order or f.is_number or not f.is_commutative:
                return e.as_ordered_terms()
            base, exp = decompose_power(f)
            cpart[base] = exp
            gens.add(base)
        rows.append((term, float(c), cpart))
    index = {g: k for k, g in enumerate(sorted(gens, key=default_sort_key))}
    keys = []
    for term, c, cpart in rows:
        monom = [0] * len(index)
        for base, exp in cpart.items():
            monom[index[base]] = -exp
        keys.append(((tuple(monom), (), ((False, 0.0), (c, 0.0))), term))
    keys.sort(key=lambda k: k[0])
    return [term for _, term in keys]


def _negative(number) -> bool:
    """``number < 0`` for a sympy number, without its assumptions (a new Float's first
    ``is_negative`` deduces every fact about it)."""
    return number.p < 0 if number.is_Rational else float(number) < 0


#: Kernels with more operations after CSE than this print the terms of a sum in the order
#: sympy stores them instead of re-sorting each sum (``sort=False``): sympy's sorting of
#: terms is most of rendering a mid-sized kernel (the 8-link arm's RHS, 1,806 operations:
#: 0.24 s sorted, 0.03 s stored; the 16-link arm's 0.32 / 0.06 s; ``mbgen bench arm``, one
#: run each).  Small kernels keep the
#: sorted order, where it costs little, and the golden files, figures and check margins
#: measured on them.  With every kernel in the stored order one check failed: four_bar's
#: energy drift near its dead point, C dopri5 at rtol 1e-10, 1.1e-6 against its bound of
#: 1e-6 (9.1e-7 sorted; DOP853 4.8e-7 / 3.9e-7): rounding, amplified near the singular
#: configuration.  Of the built-in scenes, bicycle, spatial_arm and whipple are above.
SORT_TERMS_MAX_OPS = 1_000


def _order(sort: bool) -> dict:
    """Printer settings: sympy's sorted order of terms, or the stored order (no sorting)."""
    return {} if sort else {"order": "none"}


class CPrinter(_PowerMixin, C99CodePrinter):
    """C99 printer with mbgen's symbol table and power rewriting."""

    _one = "1.0"
    _sqrt = "sqrt"

    def __init__(self, names: Mapping[sm.Symbol, str], sort: bool = True):
        super().__init__({"precision": 17, "math_macros": {}, **_order(sort)})
        self._names = names

    def _print_general_pow(self, expr):
        return f"pow({self._print(expr.base)}, {self._print(expr.exp)})"

    def _print_Integer(self, expr):
        return f"{int(expr)}.0" if abs(int(expr)) < 2**53 else super()._print_Integer(expr)



class PyPrinter(_PowerMixin, PythonCodePrinter):
    """Python printer (``math`` module) with mbgen's symbol table and power rewriting."""

    _one = "1.0"
    _sqrt = "math.sqrt"

    def __init__(self, names: Mapping[sm.Symbol, str], sort: bool = True):
        super().__init__({"fully_qualified_modules": True, "standard": "python3", **_order(sort)})
        self._names = names

    def _print_general_pow(self, expr):
        return f"math.pow({self._print(expr.base)}, {self._print(expr.exp)})"

    def _print_Rational(self, expr):
        return f"{expr.p}.0/{expr.q}.0"


def math_functions(exprs) -> set[str]:
    """Names of the sympy functions used in ``exprs`` (for includes and audits)."""
    out = set()
    for node in walk_unique(exprs):
        if isinstance(node, sm.Function):
            out.add(type(node).__name__)
        elif isinstance(node, sm.Pow):
            form = power_form(node.exp)
            if form is None:
                out.add("pow")
            elif form[0] == "sqrt":
                out.add("sqrt")
    return out
