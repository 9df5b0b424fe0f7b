"""The canonical form behind the warm cache's key: the same digest for the same content in
any process, another for any change, and no digest for what it cannot state."""

import os
import subprocess
import sys
from pathlib import Path

import pytest
import sympy as sm
from sympy.physics import vector as spv

from mbgen import Model, Output
from mbgen.build.canonical import Uncacheable, digest, text
from models import pendulum

SUPPORT = Path(__file__).resolve().parents[1] / "support"


def swinging(mass="m", axis=3, length=1, g=9.81, name="swing") -> Model:
    """A pendulum whose every part a test may change."""
    m = Model(name)
    q, = m.coordinates("q")
    m.speeds("u")
    l, mm = m.constants("l m", defaults=(1.0, 2.0))
    N = m.newtonian()
    B = m.rotate(N, "B", axis, q)
    P = m.point("P", m.origin, -length * l * B.y)
    m.particle("bob", P, sm.sympify(mass, locals={"m": mm}))
    m.gravity(-g * N.y)
    return m


def test_same_content_same_digest_in_another_process():
    code = "from models import pendulum\nfrom mbgen.build.canonical import digest\n" \
           "print(digest(pendulum()))"
    other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           env={**os.environ, "PYTHONHASHSEED": "123",
                                "PYTHONPATH": str(SUPPORT)})
    assert other.returncode == 0, other.stderr
    assert other.stdout.strip().splitlines()[-1] == digest(pendulum())
    assert digest(swinging()) == digest(swinging())          # two models built alike


@pytest.mark.parametrize("changed", [dict(mass="2*m"), dict(axis=1), dict(length=2),
                                     dict(g=9.80665), dict(name="swing2")])
def test_a_changed_model_changes_the_digest(changed):
    assert digest(swinging(**changed)) != digest(swinging())


def test_a_default_or_a_bound_changes_the_digest():
    a, b = swinging(), swinging()
    b.defaults_["l"] = 1.5
    assert digest(a) != digest(b)
    c = swinging()
    c.bound(c.coordinates_[0], -1.0, 1.0)
    assert digest(a) != digest(c)


def test_values_of_different_types_or_bits_differ():
    values = [1, 1.0, True, "1", b"1", None, (1,), [1], {1: 1}, {1}, Output.RHS, "rhs",
              0.1, 0.1 + 2 ** -56, sm.Integer(1), sm.Float(1.0), sm.Float("0.1", 30),
              sm.Symbol("x"), sm.Symbol("x", positive=True), spv.dynamicsymbols("x"),
              sm.Function("x", real=True)(sm.Symbol("t"))]
    assert len({digest(v) for v in values}) == len(values)


def test_dict_order_and_vector_terms():
    assert digest({"a": 1, "b": 2}) != digest({"b": 2, "a": 1})      # a model's build order
    N = spv.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [sm.Symbol("q"), N.z])
    assert digest(N.x + A.y) == digest(A.y + N.x)                    # one vector either way
    assert digest(N.x + A.y) != digest(N.x + A.x)


def test_a_shared_graph_costs_its_size():
    e = sm.Symbol("x")
    for i in range(200):        # a tree of 2**200 nodes, a graph of about 600
        e = sm.Add(e, sm.Mul(e, sm.Symbol(f"a{i}"), evaluate=False), evaluate=False)
    assert len(text(e).splitlines()) < 1000   # written as a tree it would never end


@pytest.mark.parametrize("value", [lambda: 1, print, object(), open],
                         ids=["lambda", "builtin", "object", "open"])
def test_what_has_no_canonical_form_is_uncacheable(value):
    with pytest.raises(Uncacheable):
        digest({"scene": value})


def test_a_cycle_is_uncacheable():
    a = []
    a.append(a)
    with pytest.raises(Uncacheable, match="holds itself"):
        digest(a)
