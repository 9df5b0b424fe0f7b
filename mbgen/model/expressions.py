"""Expression strings, parsed without ``eval``.

``sympy.sympify("...")`` evaluates its argument as Python, so a string handed
to a model (``m.spring(..., stiffness="__import__('os')...")``) would run as
code.  mbgen never passes user text to ``sympify``: every value a user gives
goes through :func:`expression`, which

* passes sympy expressions and real numbers through (``sympify(strict=True)``,
  which refuses strings and unknown objects instead of parsing their ``str``);
* parses a string with :mod:`ast` (parsing builds a tree, it runs nothing) and
  converts the tree node by node against a whitelist:

  ==================  ======================================================
  numbers             ``2``, ``0.5``, ``1e-3`` (integers and floats only)
  names               the model's own symbols (constants, coordinates,
                      speeds, inputs, ``t``) and ``pi``, ``E``
  operators           ``+ - * / **``, unary ``-`` and ``+``, parentheses
  calls               ``sin cos tan asin acos atan atan2 sinh cosh tanh exp
                      log sqrt Abs`` (``abs``) with positional arguments
  ==================  ======================================================

  Anything else -- attributes, subscripts, keywords, strings, lambdas,
  comprehensions, an unknown name or function -- is a
  :class:`~mbgen.errors.ModelError` naming what was refused.  Sizes are bounded
  (:data:`MAX_LENGTH` characters, :data:`MAX_DIGITS` digits for exact numbers,
  so ``10**10**10`` is refused instead of computed).

Strings cannot express derivatives; give ``q'`` as a sympy expression
(``q.diff(t)``).
"""

from __future__ import annotations

import ast
import math
from collections.abc import Mapping

import sympy as sm

from ..errors import ModelError
from ..names import did_you_mean
from ..symbolic.graph import walk_unique

__all__ = ["expression", "parse", "FUNCTIONS", "MAX_LENGTH", "MAX_DIGITS"]

#: Functions a string may call, by the name it uses.
FUNCTIONS = {name: getattr(sm, name) for name in (
    "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "exp",
    "log", "sqrt", "Abs")}
FUNCTIONS["abs"] = sm.Abs

#: Constants a string may name (a model symbol of the same name wins).
CONSTANTS = {"pi": sm.pi, "E": sm.E}

#: Longest expression string accepted.
MAX_LENGTH = 10_000
#: Most decimal digits of an exact (integer or rational) number a string may produce.
MAX_DIGITS = 400
#: Deepest nesting of the parsed tree (Python's parser recurses too).
MAX_DEPTH = 100

_BINARY = {ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b,
           ast.Mult: lambda a, b: a * b, ast.Div: lambda a, b: a / b}


def expression(value, symbols: Mapping[str, sm.Basic] | None, what: str) -> sm.Expr:
    """``value`` as a sympy expression, without evaluating any user text.

    Parameters
    ----------
    value : sympy expression, real number, or str
        A string is parsed by :func:`parse` against ``symbols``.
    symbols : mapping str -> sympy object, or None
        The names a string may use (None: strings are refused, with a message
        saying to pass a sympy expression).
    what : str
        What the value is (``"stiffness of 'k1'"``), for error messages.

    Raises
    ------
    ModelError
        A string that is not in the whitelisted grammar, or a value that is
        neither a number nor a sympy object.
    """
    if isinstance(value, str):
        if symbols is None:
            raise ModelError(f"{what} is the string {_short(value)}; pass a sympy expression "
                             f"built from the model's symbols instead")
        return parse(value, symbols, what)
    if isinstance(value, (bytes, bytearray)):
        raise ModelError(f"{what} must be a number or sympy expression, got bytes")
    try:
        expr = sm.sympify(value, strict=True)
    except (sm.SympifyError, TypeError, ValueError):
        raise ModelError(f"{what} must be a number or sympy expression, got "
                         f"{type(value).__name__} {_short(repr(value))}") from None
    if isinstance(expr, sm.Basic) and _has_nonfinite(expr):
        raise ModelError(f"{what} is not finite ({_short(str(value))}); give a finite number "
                         f"or expression")
    return expr


def _has_nonfinite(expr) -> bool:
    """True when ``expr`` contains inf, -inf, zoo or nan (one visit per distinct node)."""
    for node in walk_unique([expr]):
        if node in _NONFINITE or (isinstance(node, sm.Float) and not math.isfinite(float(node))):
            return True
    return False


def parse(text: str, symbols: Mapping[str, sm.Basic], what: str = "expression") -> sm.Expr:
    """Parse ``text`` (``"k*(1 + 2*sin(q1))"``) into a sympy expression of ``symbols``.

    Nothing in ``text`` is executed: :func:`ast.parse` only builds a syntax
    tree, and each node is converted by hand (see the module docstring for
    the grammar).
    """
    if len(text) > MAX_LENGTH:
        raise ModelError(f"{what}: the expression string has {len(text)} characters, more than "
                         f"{MAX_LENGTH}; build long expressions with sympy")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, MemoryError, RecursionError) as exc:
        raise ModelError(f"{what}: {_short(text)} is not an expression "
                         f"({type(exc).__name__}: {getattr(exc, 'msg', exc)})") from None
    return _Converter(symbols, what, text).convert(tree.body, 0)


class _Converter:
    def __init__(self, symbols, what, text):
        self.symbols = dict(symbols)
        self.what = what
        self.text = text

    def refuse(self, why: str):
        raise ModelError(f"{self.what}: {_short(self.text)} {why}; expression strings may use "
                         f"numbers, the model's symbols, + - * / **, and the functions "
                         f"{', '.join(sorted(FUNCTIONS))} -- or pass a sympy expression")

    def convert(self, node, depth: int):
        if depth > MAX_DEPTH:
            self.refuse(f"nests deeper than {MAX_DEPTH} levels")
        if isinstance(node, ast.Constant):
            return self.constant(node.value)
        if isinstance(node, ast.Name):
            return self.name(node.id)
        if isinstance(node, ast.BinOp):
            return self.binary(node, depth)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            v = self.convert(node.operand, depth + 1)
            return -v if isinstance(node.op, ast.USub) else v
        if isinstance(node, ast.Call):
            return self.call(node, depth)
        self.refuse(f"contains {type(node).__name__!r}, which is not allowed")

    def constant(self, v):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.refuse(f"contains the literal {_short(repr(v))}")
        if isinstance(v, float) and not math.isfinite(v):
            self.refuse(f"contains the non-finite number {v!r}")
        return self.bounded(sm.Integer(v) if isinstance(v, int) else sm.Float(v))

    def name(self, name: str):
        if name in self.symbols:
            return self.symbols[name]
        if name in CONSTANTS:
            return CONSTANTS[name]
        hint = did_you_mean(name, list(self.symbols) + list(CONSTANTS))
        raise ModelError(f"{self.what}: {_short(self.text)} names {name!r}, which is not "
                         f"a symbol of the model (declare it first, e.g. "
                         f"model.constants({name!r})){hint}")

    def binary(self, node: ast.BinOp, depth: int):
        a = self.convert(node.left, depth + 1)
        b = self.convert(node.right, depth + 1)
        if isinstance(node.op, ast.Pow):
            return self.power(a, b)
        op = _BINARY.get(type(node.op))
        if op is None:
            self.refuse(f"uses the operator {type(node.op).__name__}")
        if isinstance(node.op, ast.Div) and b == 0:
            self.refuse("divides by zero")
        return self.bounded(op(a, b))

    def call(self, node: ast.Call, depth: int):
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            name = node.func.id if isinstance(node.func, ast.Name) else ast.unparse(node.func)
            self.refuse(f"calls {_short(name)}, which is not an allowed function")
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
            self.refuse(f"passes keyword or starred arguments to {node.func.id}")
        args = [self.convert(a, depth + 1) for a in node.args]
        try:
            value = FUNCTIONS[node.func.id](*args)
        except (TypeError, ValueError) as exc:
            self.refuse(f"calls {node.func.id} wrongly ({exc})")
        return self.bounded(value)

    def power(self, base, exp):
        if base.is_Number and exp.is_Number:
            if exp.is_Integer and (base.is_Integer or base.is_Rational):
                if max(_digits(base.p), _digits(base.q)) * abs(int(exp)) > MAX_DIGITS:
                    self.refuse(f"computes a number with more than {MAX_DIGITS} digits")
            elif abs(float(exp)) > 1e4:
                self.refuse(f"raises a number to the power {exp}")
        return self.bounded(base ** exp)

    def bounded(self, value):
        if isinstance(value, sm.Rational) and max(_digits(value.p),
                                                   _digits(value.q)) > MAX_DIGITS:
            self.refuse(f"computes a number with more than {MAX_DIGITS} digits")
        if value in _NONFINITE or (isinstance(value, sm.Float)
                                   and not math.isfinite(float(value))):
            self.refuse("computes a non-finite value (a division by zero, log(0), ...)")
        return value


_NONFINITE = (sm.zoo, sm.oo, -sm.oo, sm.nan)


def _digits(n) -> int:
    """Decimal digits of the integer ``n`` (an upper bound; no conversion to text)."""
    return int(abs(int(n)).bit_length() * 0.30103) + 1


def _short(text: str) -> str:
    text = text if isinstance(text, str) else repr(text)
    return repr(text) if len(text) <= 60 else repr(text[:50]) + f"... ({len(text)} characters)"
