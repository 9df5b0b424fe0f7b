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
