"""Expression strings: parsed to the model's symbols, never evaluated, bounded.

Every entry that takes a value refuses code (and objects whose ``str`` is code)
before anything runs; huge or deeply nested text is refused after bounded work (counted); the
parser reads text with Python's precedence.
"""

import pytest
import sympy as sm

from mbgen import Model
from mbgen.errors import ModelError
from mbgen.model import expressions
from mbgen.model.kinematics import vec


def _entry_points(m, code):
    """Every model method that takes a value, called with the string ``code``."""
    q, = m.coordinates("q")
    u, = m.speeds("u")
    k, = m.constants("k")
    N = m.newtonian()
    P = m.point("P", m.origin, q * N.x)
    return {
        "rotate angle": lambda: m.rotate(N, "B", 3, code),
        "particle mass": lambda: m.particle("bob", P, code),
        "body mass": lambda: m.body("rod", N, code, (1, 1, 1), P),
        "body inertia tuple": lambda: m.body("rod", N, 1.0, (code, 1, 1), P),
        "body inertia matrix": lambda: m.body("rod", N, 1.0,
                                              [[code, 0, 0], [0, 1, 0], [0, 0, 1]], P),
        "spring stiffness": lambda: m.spring("s", P, m.origin, code),
        "spring length": lambda: m.spring("s", P, m.origin, 1.0, natural_length=code),
        "damper damping": lambda: m.damper("d", P, m.origin, code),
        "prescribed": lambda: m.prescribed("theta", code),
        "kinematics": lambda: m.kinematics({q: code}),
        "kinematic_equations": lambda: m.kinematic_equations([code]),
        "vec": lambda: vec(N, [code, 0, 0]),
    }


ENTRY_POINTS = list(_entry_points(Model("probe"), "0"))


@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_expression_strings_are_never_evaluated(entry, tmp_path):
    """Issue 9.2: sympify(str) evaluated user text; the code ran before any error."""
    target = tmp_path / "PWNED"
    code = f"__import__('builtins').open({str(target)!r}, 'w').write('x')"
    with pytest.raises(ModelError, match="pass a sympy expression|not an allowed function"):
        _entry_points(Model("m"), code)[entry]()
    assert not target.exists()


@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_objects_whose_str_is_code_are_not_parsed(entry, tmp_path):
    """sympify(non-strict) falls back to parsing str(obj); strict sympify does not."""
    target = tmp_path / "PWNED"

    class Sneaky:
        def __str__(self):
            return f"__import__('builtins').open({str(target)!r}, 'w')"

    with pytest.raises(ModelError):
        _entry_points(Model("m"), Sneaky())[entry]()
    assert not target.exists()


def test_expression_strings_parse_to_the_models_symbols():
    m = Model("m")
    q, = m.coordinates("q")
    m.speeds("u")
    k, l = m.constants("k l")
    N = m.newtonian()
    B = m.rotate(N, "B", 3, "2*q + sin(k)/3")
    assert m.frames[B].angle == 2 * q + sm.sin(k) / 3
    P = m.point("P", m.origin, q * N.x)
    s = m.spring("s", P, m.origin, "k*l**2", natural_length="sqrt(l) - pi")
    assert s.stiffness == k * l ** 2 and s.natural_length == sm.sqrt(l) - sm.pi
    with pytest.raises(ModelError, match="did you mean 'k'"):
        m.damper("d", P, m.origin, "kk")


@pytest.mark.parametrize("text, bound", [
    ("10**10**10", "more than 400 digits"), ("9**9**9**9", "more than 400 digits"),
    ("sin(" * 150 + "k" + ")" * 150, "deeper than 100 levels"),
    ("-" * 500 + "k", "deeper than 100 levels"),
    ("1" * 20_000, "more than 10000"), ("k" + "+k" * 6000, "more than 10000")])
def test_expression_strings_are_bounded(text, bound, monkeypatch):
    """Refused by the named bound after converting at most ``MAX_DEPTH + 2`` nodes: the
    work is counted, not timed (a wall-clock limit failed on loaded machines)."""
    converted = []
    convert = expressions._Converter.convert
    monkeypatch.setattr(expressions._Converter, "convert",
                        lambda self, node, depth: converted.append(depth) or
                        convert(self, node, depth))
    m = Model("m")
    m.constants("k")
    with pytest.raises(ModelError, match=bound):
        m.prescribed("theta", text)
    assert len(converted) <= expressions.MAX_DEPTH + 2


def test_expression_parser_agrees_with_python_precedence():
    """Seeded random expressions of the whitelisted grammar: the ast-based parser gives
    sympy's own reading of the same text (precedence, -2**2, right-associative **, a/b/c)."""
    import random

    from mbgen.model.expressions import parse

    rng = random.Random(20261124)
    k, l = sm.symbols("k l")
    table = {"k": k, "l": l}
    atoms = ["k", "l", "2", "3", "0.5", "pi"]
    funcs = ["sin", "cos", "exp", "sqrt", "atan2"]

    def gen(depth):
        if depth == 0 or rng.random() < 0.25:
            return rng.choice(atoms)
        kind = rng.random()
        if kind < 0.55:
            op = rng.choice(["+", "-", "*", "/", "**"])
            right = rng.choice(["2", "3", "-1", "0.5"]) if op == "**" else gen(depth - 1)
            return f"{gen(depth - 1)} {op} {right}"
        if kind < 0.7:
            return f"-{gen(depth - 1)}"
        if kind < 0.85:
            return f"({gen(depth - 1)})"
        f = rng.choice(funcs)
        return f"{f}({gen(depth - 1)}, {gen(depth - 1)})" if f == "atan2" else \
            f"{f}({gen(depth - 1)})"

    checked = 0
    for _ in range(300):
        text = gen(4)
        try:
            expected = sm.sympify(text, locals=dict(table))  # our own generated text: safe
        except (ZeroDivisionError, ValueError, TypeError):
            continue
        if expected.has(sm.zoo, sm.oo, sm.nan):
            continue
        assert sm.simplify(parse(text, table) - expected) == 0, text
        checked += 1
    assert checked > 250
