"""The default derivation: the cheaper of Kane and Newton–Euler, and why, wherever it shows.

Seams checked here:

* every built-in scene, with no method named, costs at most 10 % more operations
  (after CSE) than the cheaper of Kane and Newton–Euler, each run on its own: the
  default is the one with fewer operations (L D L^T solve included), a tie Kane;
  the scene's own method, where it names one, is that cheaper one too;
* a 16-link spatial arm gets Newton–Euler without Kane's derivation ever running
  (it would take minutes), as do other long chains of joints; a long chain in
  absolute coordinates gets Kane without Newton–Euler; a model whose joints
  Newton–Euler cannot infer gets Kane;
* ``method=``, the scene's ``method`` and ``--derivation`` override the choice;
* a process remembers a comparison: regenerating derives only the method kept; the memo
  is an object a run is handed (``comparisons=``);
* the choice hands its prepared model and Newton–Euler outward pass to the derivation:
  ``prepare`` and the outward pass run once per compile, compared or not;
* the generated header, the Python module, the notebook summaries of
  ``Equations`` and ``CompiledModel`` say which method and why.
"""

from dataclasses import replace
from functools import cache

import pytest

import mbgen
from heavy import scene_params
from mbgen import Output
from mbgen.cli import main
from mbgen.codegen.optimize import optimize
from mbgen.derivation import CHAIN, COMPARE_SPEEDS, METHODS, Method, choose_method, derive
from mbgen.derivation import prepare as prepare_module
from mbgen.derivation.recursion import NewtonEuler
from mbgen.model.scene import load_scene
from mbgen.pipeline import Comparisons, equations_of, operations, run
from mbgen.scenes import n_link_cart, spatial_arm, stiff_chain
from mbgen.symbolic.equations import METHOD_TITLES
from models import ambiguous_slider


def unnamed(name, **options):
    """The built-in scene with its own method removed: what the default chooses."""
    return replace(load_scene(name, **options), method=None)


@cache
def each_method(name):
    """``{method: Kernel}`` of the scene's right-hand side (its own method removed) with each
    method, derived for the scene's outputs and sliced as the scene says: what the default
    compares."""
    return {m: optimize(run(unnamed(name), build=False, method=m).baked, (Output.RHS,))
            for m in Method}


def no_kane(monkeypatch):
    def refuse(prep, wants):
        raise AssertionError("Kane's method was derived")
    monkeypatch.setitem(METHODS, Method.KANE, refuse)


# ------------------------------------------------------------------ the 10 % rule
@pytest.mark.parametrize("name", scene_params(heavy=True))
def test_default_costs_at_most_ten_percent_more_than_the_cheaper(name):
    default = run(unnamed(name), build=False)
    chosen = Method(default.equations.method)
    other, = set(Method) - {chosen}
    by = {chosen: default, other: run(unnamed(name), build=False, method=other)}
    ops = {m: r.kernel.ops_after for m, r in by.items()}   # the scene's outputs
    assert ops[chosen] <= 1.1 * min(ops.values()), (chosen, ops)
    cost = {m: operations(k) for m, k in each_method(name).items()}   # its rhs decides
    assert cost[chosen] < cost[other] or cost[chosen] == cost[other] and chosen is Method.KANE
    own = load_scene(name).method       # a scene that names its method names the cheaper
    assert own is None or ops[Method(own)] <= 1.1 * min(ops.values())


def test_the_choice_is_reported_with_both_counts():
    by = each_method("car_trailer")
    kane, ne = (operations(by[m]) for m in (Method.KANE, Method.NEWTON_EULER))
    eq = run(unnamed("car_trailer"), build=False).equations
    assert ne < kane and eq.method == "newton_euler"
    assert eq.derivation == (f"Newton-Euler (chosen: a right-hand side of {ne} operations "
                             f"with the L D L^T solve, against Kane's {kane})")
    eq = run(unnamed("disc_pendulum"), build=False).equations
    assert eq.derivation.startswith("Kane's method (chosen: ") and "Newton-Euler's" in eq.derivation


def test_a_tie_goes_to_kane():
    eq = run(unnamed("torque_free"), build=False).equations
    by = each_method("torque_free")
    assert operations(by[Method.KANE]) == operations(by[Method.NEWTON_EULER])
    assert eq.method == "kane" and "a tie goes to Kane" in eq.method_reason


def test_regenerating_derives_only_the_method_kept(monkeypatch):
    first = run(unnamed("car_trailer"), build=False)
    no_kane(monkeypatch)                  # the process remembers the comparison
    again = run(unnamed("car_trailer"), build=False)
    assert again.rendered.files == first.rendered.files
    assert again.equations.derivation == first.equations.derivation
    other = run(unnamed("car_trailer"), [Output.RHS], build=False, method="newton_euler")
    assert other.equations.method_reason == "named: method="
    more = run(unnamed("car_trailer"), [Output.RHS, Output.JACOBIAN, Output.ENERGY],
               build=False)        # other outputs of the same slice: the same choice
    assert more.equations.derivation == first.equations.derivation
    with pytest.raises(AssertionError, match="Kane's method was derived"):  # another slice:
        run(unnamed("car_trailer"), [Output.RHS], build=False, fixed={})  # compared afresh


def test_the_memo_is_the_comparisons_a_run_is_handed(monkeypatch):
    memo = Comparisons()
    first = run(unnamed("car_trailer"), build=False, comparisons=memo)
    assert len(memo) == 1
    no_kane(monkeypatch)
    again = run(unnamed("car_trailer"), build=False, comparisons=memo)
    assert again.equations.derivation == first.equations.derivation
    for afresh in (None, Comparisons()):    # None: nothing remembered, nothing looked up
        with pytest.raises(AssertionError, match="Kane's method was derived"):
            run(unnamed("car_trailer"), build=False, comparisons=afresh)


def test_comparisons_keep_at_most_their_size():
    memo = Comparisons(size=2)
    for k in range(3):
        memo.remember(("slice", k), Method.KANE, "why")
    assert len(memo) == 2 and memo.get(("slice", 0)) is None
    assert memo.get(("slice", 2)) == (Method.KANE, "why")
    memo.clear()
    assert len(memo) == 0


# ------------------------------------------------------------------ each runs once
@pytest.fixture
def counted(monkeypatch):
    """How often ``prepare`` and the Newton-Euler outward pass (a ``NewtonEuler``) run."""
    counts = {"prepare": 0, "outward": 0}
    real_prepare, real_init = prepare_module.prepare, NewtonEuler.__init__

    def prepare(model):
        counts["prepare"] += 1
        return real_prepare(model)

    def init(self, *args, **kw):
        counts["outward"] += 1
        real_init(self, *args, **kw)

    monkeypatch.setattr(prepare_module, "prepare", prepare)
    monkeypatch.setattr(NewtonEuler, "__init__", init)
    return counts


@pytest.mark.parametrize("how", ["structure", "compared", "named", "derive"])
def test_prepare_and_the_outward_pass_run_once(counted, how):
    """Before, the choice ran both and the derivation both again (twice more while
    comparing): 2 and 2 on a long chain, 3 and 2 on a small model."""
    reactions = [Output.RHS, Output.REACTIONS]     # Kane's reactions use the outward pass too
    if how == "structure":
        eq = run(unnamed("spatial_arm", n=CHAIN), build=False).equations
        assert eq.method == "newton_euler" and "Kane's method not derived" in eq.method_reason
    elif how == "compared":
        eq = run(unnamed("car_trailer"), reactions, build=False,
                 comparisons=Comparisons()).equations
        assert "against Kane's" in eq.method_reason
    elif how == "named":
        run(unnamed("car_trailer"), reactions, build=False, method=Method.KANE)
    else:
        assert derive(n_link_cart.build_model(2), reactions=True).method == "kane"
    assert counted == {"prepare": 1, "outward": 1}


def test_every_derivation_forks_the_outward_pass_it_is_handed():
    """The choice's outward pass, forked: the derivations' programs grow apart from it."""
    choice = choose_method(spatial_arm.build_model(3))
    ne = choice.prepared.outward
    before = list(ne.P.assignments)
    for method in Method:
        derive(choice.prepared, method, reactions=True)
    assert ne.P.assignments == before
    assert derive(choice.prepared, Method.NEWTON_EULER) == derive(spatial_arm.build_model(3),
                                                                  Method.NEWTON_EULER)


# ------------------------------------------------------------------ decided by structure
class Derived(Exception):
    """Raised by a stand-in for ``bake``: the pipeline stops once it has derived."""


def test_a_sixteen_link_arm_gets_newton_euler_without_deriving_kane(monkeypatch):
    no_kane(monkeypatch)

    def stop(equations, *args):
        raise Derived(equations)

    monkeypatch.setattr(mbgen.pipeline, "bake", stop)  # what follows derive is the slow test's
    scene = unnamed("spatial_arm", n=16)
    with pytest.raises(Derived) as derived:
        run(scene, build=False)
    eq, = derived.value.args
    assert eq.method == "newton_euler"
    assert eq.derivation == (
        "Newton-Euler (chosen: a tree of joints that own their speeds, with a chain of 16 "
        "bodies; Kane's method not derived)")
    assert derive(scene.model, energy=False).method == "newton_euler"   # derive's default too


@pytest.mark.slow
def test_a_sixteen_link_arm_generates_by_newton_euler_alone(monkeypatch):
    no_kane(monkeypatch)
    result = run(unnamed("spatial_arm", n=16), build=False)
    assert result.equations.method == "newton_euler"
    assert "Derivation: Newton-Euler (chosen: a tree of joints" in result.rendered.header


def test_long_chains_of_joints_and_large_models_are_decided_without_comparing():
    assert choose_method(spatial_arm.build_model(CHAIN)).method is Method.NEWTON_EULER
    assert choose_method(spatial_arm.build_model(CHAIN - 1)).method is None   # compared
    # sliders each on the ground: joints own their speeds, but no chain
    assert choose_method(stiff_chain.build_model(COMPARE_SPEEDS)).method is None
    wide = choose_method(stiff_chain.build_model(COMPARE_SPEEDS + 1))
    assert wide.method is Method.NEWTON_EULER and "25 speeds" in wide.reason
    # absolute link angles: every link's velocity carries every angle before it
    cart = choose_method(n_link_cart.build_model(COMPARE_SPEEDS))
    assert cart.method is Method.KANE and "Newton-Euler not derived" in cart.reason
    assert choose_method(n_link_cart.build_model(3)).method is None


def test_a_model_newton_euler_cannot_read_gets_kane():
    m = ambiguous_slider("ambiguous")    # the slider's parent is ambiguous to Newton-Euler
    choice = choose_method(m)
    assert choice.method is Method.KANE and "cannot infer" in choice.reason
    result = run(m, build=False)
    assert result.equations.method == "kane" and "state it with" in result.equations.method_reason


# ------------------------------------------------------------------ overrides
def test_a_named_method_overrides_the_choice(monkeypatch, tmp_path, capsys):
    scene = unnamed("spatial_arm", n=CHAIN)
    eq = equations_of(scene, Method.KANE, energy=False)
    assert eq.method == "kane" and eq.derivation == "Kane's method (named: method=)"
    small = unnamed("car_trailer")
    for how in (Method.KANE, "kane"):
        assert run(small, build=False, method=how).equations.method == "kane"
    named = load_scene("car_trailer")            # the scene names Newton-Euler
    assert named.method is Method.NEWTON_EULER
    eq = run(named, build=False).equations
    assert eq.derivation == "Newton-Euler (named by the scene or --derivation)"
    assert run(named, build=False, method="kane").equations.derivation == \
        "Kane's method (named: method=)"
    no_kane(monkeypatch)   # a named method is derived alone
    assert run(named, build=False).equations.method == "newton_euler"
    monkeypatch.undo()
    assert main(["generate", "car_trailer", "--derivation", "kane", "-o",
                 str(tmp_path / "g")]) == 0
    assert " * Derivation: Kane's method (named by the scene or --derivation)\n" in \
        (tmp_path / "g" / "car_trailer.h").read_text()
    capsys.readouterr()


def test_derive_alone_takes_kane_where_the_structure_leaves_it_open():
    eq = derive(n_link_cart.build_model(2), energy=False)
    assert eq.method == "kane" and "mbgen.compile keeps the cheaper" in eq.method_reason
    with pytest.raises(mbgen.ModelError, match="unknown derivation method 'lagrange'; choose "
                                               "from kane, newton_euler"):
        derive(n_link_cart.build_model(2), "lagrange")


def test_every_method_has_a_title():
    assert set(METHOD_TITLES) == {m.value for m in Method}


# ------------------------------------------------------------------ where it shows
def test_header_module_and_summaries_say_which_and_why():
    scene = unnamed("car_trailer")
    compiled = mbgen.compile(scene)
    eq = run(scene, build=False).equations
    line = f"Derivation: {eq.derivation}\n"
    assert eq.derivation.startswith("Newton-Euler (chosen: ")
    assert f" * {line}" in compiled.rendered.header
    assert line in compiled.rendered.python
    assert f"<td style=\"text-align:left\">{eq.derivation.replace(chr(39), '&#x27;')}</td>" in \
        compiled._repr_html_()
    assert "Newton-Euler (chosen: " in eq._repr_html_()
    assert "Kane&#x27;s method (named: method=)" in derive(
        n_link_cart.build_model(1), Method.KANE)._repr_html_()
