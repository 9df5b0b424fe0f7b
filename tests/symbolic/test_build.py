"""``mbgen.symbolic.build``: sums and products built without sympy's evaluation are the nodes
sympy builds.  Each derivation below runs with every call checked against ``sympy.Mul`` and
``sympy.Add``: the same class, equal, with the same arguments in the same order."""

import pytest
import sympy as sm

import mbgen
import mbgen.derivation.tree as tree
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.symbolic import build


def _checked(fast, slow, calls):
    def check(*args):
        out, ref = fast(*args), slow(*args)
        assert type(out) is type(ref) and out == ref and out.args == ref.args, (args, out, ref)
        calls.append(out is not ref)
        return out
    return check


@pytest.mark.parametrize("name, options, method", [
    ("spatial_arm", {"n": 4}, mbgen.Method.NEWTON_EULER),
    ("spatial_arm", {"n": 3}, mbgen.Method.KANE),
    ("bicycle", {}, None),
    ("four_bar", {}, None),
    ("car_trailer", {}, None),
    ("rolling_disc", {}, None),
    ("n_link_cart", {"n": 3}, None),
])
def test_every_product_and_sum_is_sympys(monkeypatch, name, options, method):
    calls: list = []
    monkeypatch.setattr(tree, "product", _checked(build.product, sm.Mul, calls))
    monkeypatch.setattr(tree, "total", _checked(build.total, lambda t: sm.Add(*t), calls))
    scene = load_scene(name, **options)
    run(scene, ("rhs",), build=False, warm=False,
                       **({"method": method} if method else {}))
    assert len(calls) > 50


def test_a_urdf_robot_with_float_offsets(monkeypatch, tmp_path):
    """A robot read from URDF: its offsets and inertias are Floats."""
    from tests.support.urdf_models import ARM_PARTS, urdf, write

    calls: list = []
    monkeypatch.setattr(tree, "product", _checked(build.product, sm.Mul, calls))
    monkeypatch.setattr(tree, "total", _checked(build.total, lambda t: sm.Add(*t), calls))
    path = write(tmp_path, urdf(ARM_PARTS))
    run(mbgen.from_urdf(path), ("rhs", "jacobian"), build=False, warm=False)
    assert len(calls) > 50


def test_what_combines_goes_to_sympy():
    """Like factors, like terms, numbers that meet and a number times a sum are sympy's."""
    with build.interned():
        _combine_cases()


def _combine_cases():
    x, y, z = sm.symbols("x y z")
    q = sm.Symbol("q")
    cases_mul = [(x, x), (x * y, x), (x ** 2, x), (sm.exp(x), sm.exp(y)), (2, x + y),
                 (sm.Rational(1, 2), 2 * x), (x * y, z), (sm.cos(q), sm.sin(q)), (3, x * y),
                 (sm.Float(0.5), x), (x ** -1, y), (sm.sqrt(2), x)]
    for a, b in cases_mul:
        a, b = sm.sympify(a), sm.sympify(b)
        out, ref = build.product(a, b), sm.Mul(a, b)
        assert out == ref and out.args == ref.args, (a, b)
    cases_add = [(x, x), (x, 2 * x), (1, x, 2), (x + y, -y), (x + y, z), (sm.sqrt(2), x),
                 (x * y, 3 * x * y), (sm.Float(1.5), x), (x + 1, y + 2), (x, y, z)]
    for terms in cases_add:
        terms = [sm.sympify(t) for t in terms]
        out, ref = build.total(terms), sm.Add(*terms)
        assert out == ref and out.args == ref.args, terms


def test_equal_nodes_are_one_object_and_outside_they_are_sympys():
    """Inside ``interned`` an equal product or sum built twice is one object (comparing two
    equal graphs then stops at once); outside, the functions are sympy's constructors."""
    x, y, z = sm.symbols("x y z")
    with build.interned():
        a, b = build.product(x, y), build.product(y, x)
        assert a is b and build.total([a, z]) is build.total([z, a])
        with build.interned():   # nested: the same table
            assert build.product(x, y) is a
        deep = [x, y]
        for _ in range(40):      # a graph whose tree has 2**40 nodes, built twice
            deep = [build.total([build.product(deep[0], z), deep[1]]) for _k in range(2)]
            assert deep[0] is deep[1]
    assert build.product(x, y) == sm.Mul(x, y)
    assert not hasattr(build._local, "table") or build._local.table is None
