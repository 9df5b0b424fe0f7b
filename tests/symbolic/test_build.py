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
        calls.append(out)
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
    distributed: list = []
    monkeypatch.setattr(build, "_distributed", _counted(build._distributed, distributed))
    path = write(tmp_path, urdf(ARM_PARTS))
    run(mbgen.from_urdf(path), ("rhs", "jacobian"), build=False, warm=False)
    assert len(calls) > 50
    assert sum(out is not None for out in distributed) > 10   # Floats times sums, built here


def _counted(fn, outs):
    def counted(*args):
        outs.append(fn(*args))
        return outs[-1]
    return counted


def test_a_float_times_a_sum_is_distributed_as_sympy_does():
    """A number times one sum: sympy distributes it (``0.5*(x + y)`` is ``0.5*x + 0.5*y``);
    :func:`build.product` builds the same sum, its terms' numbers multiplied as sympy
    multiplies them.  A Rational times a sum takes sympy's two-argument path (each term
    through ``_keep_coeff``)."""
    x, y, z = sm.symbols("x y z")
    h = sm.Float("0.1")
    cases = [(sm.Float(0.5), x + y), (x + y, sm.Float(-1.5)), (h, 3 * h * x + 7 * h * y),
             (sm.Float(0.5), x + 2 * y + 1), (h, 2.0 * x + y * z + sm.Float(0.25)),
             (sm.Float(1.0), x + y), (h, x + sm.Rational(1, 3)), (h * x, y + z),
             (sm.Float(-0.3), sm.cos(x) * y - sm.sin(x) * z), (2, x + y),
             (sm.Rational(1, 2), x + y), (x + y, 3), (sm.Rational(-1, 3), x + 2 * y + 1),
             (-1, x - y), (2, sm.Float(0.5) * x + y), (2, 3 * x - z)]
    with build.interned():
        for a, b in cases:
            a, b = sm.sympify(a), sm.sympify(b)
            out, ref = build.product(a, b), sm.Mul(a, b)
            assert type(out) is type(ref) and out == ref and out.args == ref.args, (a, b, out)
            assert all(o.args == r.args for o, r in zip(out.args, ref.args)), (a, b, out)


def test_what_combines_is_sympys():
    """Like factors, like terms, numbers that meet and a number times a sum give sympy's
    nodes (built by sympy, or distributed as it distributes)."""
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
    equal graphs then stops at once), in a later block too; outside, the functions are
    sympy's constructors."""
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
    assert build.product(x, y) == sm.Mul(x, y) and not build._active()
    with build.interned():   # a later block: the same nodes (up to TABLE_MAX of them)
        assert build.product(y, x) is a


@pytest.mark.parametrize("name", ["spatial_arm", "bicycle", "whipple", "urdf"])
def test_baking_rebuilds_what_sympy_builds(monkeypatch, tmp_path, name):
    """``rebuilt`` (each node that baking numbers into a derivation changes) against
    ``node.func(*args)``, or the kept sum of ``build.kept_product``; and outside ``interned``
    (``xreplace_dag`` elsewhere) it is sympy's own."""
    calls: list = []
    fast = build.rebuilt

    def check(node, args, keep_sums=False):
        out = fast(node, args, keep_sums)
        ref = build.kept_product(args) if keep_sums and node.is_Mul else node.func(*args)
        assert type(out) is type(ref) and out == ref and out.args == ref.args, (node, args)
        calls.append(build._active())
        return out

    monkeypatch.setattr(build, "rebuilt", check)
    if name == "urdf":    # a robot's Float offsets and inertias
        from tests.support.urdf_models import ARM_PARTS, urdf, write

        scene = mbgen.from_urdf(write(tmp_path, urdf(ARM_PARTS)))
    else:
        scene = load_scene(name, **({"n": 5} if name == "spatial_arm" else {}))
    outputs = ("rhs",) if name == "whipple" else ("rhs", "jacobian")   # whipple's: 10 s
    run(scene, outputs, build=False, warm=False)
    assert sum(calls) > 50
    x, c = sm.symbols("x c")
    out = fast(x * c + c, [x * 2, sm.Integer(2)])
    assert out == sm.Add(2 * x, 2) and not build._active()
