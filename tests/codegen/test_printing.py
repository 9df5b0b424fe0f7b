"""The printers: no infinite or NaN constant reaches generated code, and one power rule
(``printing.power_form``) decides for both printers and the CSE.
"""

import pytest
import sympy as sm

from mbgen.codegen.printing import (
    CPrinter,
    NonFiniteConstantError,
    PyPrinter,
    power_form,
    printed_base_count,
)


@pytest.mark.parametrize("printer", [CPrinter, PyPrinter])
@pytest.mark.parametrize("value", [sm.oo, -sm.oo, sm.zoo, sm.nan, sm.Float("inf"),
                                   sm.Float("1e400")])
def test_printers_never_emit_inf_or_nan(printer, value):
    x = sm.Symbol("x")
    with pytest.raises(NonFiniteConstantError, match="non-finite"):
        printer({x: "x"}).doprint(x + value if value is not sm.nan else value)


def test_power_rule_is_one_function():
    """printing.power_form decides; both printers and the CSE hoisting follow it."""
    from mbgen.codegen.cse import _repeats_base

    x = sm.Symbol("x")
    for exp in [sm.Integer(k) for k in range(-12, 13) if k] + \
               [sm.Rational(k, 2) for k in range(-21, 22, 2)] + [sm.Rational(1, 3), sm.Float(2.5)]:
        power = sm.Pow(x, exp, evaluate=False)
        for printer in (CPrinter({x: "x"}), PyPrinter({x: "x"})):
            text = printer.doprint(power)
            assert text.count("x") == printed_base_count(exp), (exp, text)
            assert ("pow(" in text) == (power_form(exp) is None), (exp, text)
        assert _repeats_base(exp) == (printed_base_count(exp) >= 2)


def _reference(printer, expr):
    """What sympy's own ``doprint`` prints (the printer's mixin rules for symbols, numbers and
    powers, sympy's for sums and products): the text before the fast path."""
    return super(type(printer).__mro__[1], printer).doprint(expr)


def _expressions():
    """Every temporary and output entry of the 4-link arm's RHS and Jacobian (by Kane's
    method, with its divisions) and of the 3-link cart's RHS (inputs, sums of products)."""
    import mbgen
    from mbgen.model.scene import load_scene
    from mbgen.pipeline import run

    out = []
    for name, options, outputs, method in (
            ("spatial_arm", {"n": 4}, ("rhs", "jacobian"), mbgen.Method.KANE),
            ("n_link_cart", {"n": 3}, ("rhs",), None)):
        kernel = run(load_scene(name, **options), outputs, build=False,
                     **({"method": method} if method else {})).kernel
        for fn in kernel.functions:
            out += [e for _, e in fn.temporaries + fn.post_temporaries]
            out += [e for b in fn.pre + fn.post for _, e in b.entries]
    x, y, z = sm.symbols("x y z")
    out += [-x, -2 * x, -sm.Float(0.5) * x * y, -(x + y), -3 * (x + y) * z, x / y, -x / (y * z),
            x ** -3 * y, -1 / (x * y), sm.sqrt(x) / y ** 3, x * y ** sm.Rational(-3, 2),
            sm.sin(x) * -2, -sm.cos(x + y), x - y - 2 * z, 1 / (x + y), sm.Float(1.0) * x]
    return out


@pytest.mark.parametrize("sort", [True, False])
@pytest.mark.parametrize("kind", [CPrinter, PyPrinter])
def test_fast_printing_is_sympys_text(kind, sort):
    """The printers' fast path (``printing._Fast``) prints what sympy's printing printed,
    character for character, in the sorted and the stored order of terms."""
    exprs = _expressions()
    names = {s: str(s) for e in exprs for s in e.free_symbols}
    printer = kind(names, sort)
    assert len(exprs) > 500
    for e in exprs:
        assert printer.doprint(e) == _reference(printer, e), e


def test_ordered_terms_is_sympys_order():
    """``printing.ordered_terms`` orders every sum's terms as ``as_ordered_terms`` does: the
    arm's and the cart's sums, and sums it hands to sympy (numbers that are not a Number,
    ``number + number*x``, a numeric factor)."""
    from mbgen.codegen.printing import ordered_terms
    from mbgen.symbolic.graph import walk_unique

    x, y, z = sm.symbols("x y z")
    odd = [sm.pi + x, sm.sqrt(2) * x + y, 2 - 3 * x, x * y + sm.Float(0.5) * x + y ** 2 - 4,
           sm.sin(1) * x + z, x ** sm.Rational(3, 2) * y + x - z ** -2, sm.exp(2 * y) + x,
           sm.Mul(2, x + y, evaluate=False) + x * z + 3, -x - y - z + x * y * z]
    sums = [e for e in walk_unique(_expressions() + odd) if e.is_Add]
    assert len(sums) > 200
    for e in sums:
        assert ordered_terms(e) == e.as_ordered_terms(), e
