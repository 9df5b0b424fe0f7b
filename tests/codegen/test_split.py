"""Long functions cut into parts (mbgen.codegen.split): same numbers, strict C and C++, stack.

The thresholds are lowered so that small models are split: every part kind (time read in
a part, inputs, parameters, a solve's ``F`` read after it, a value handed on through ``W``
to a later part and to the function itself) appears, and the split code's results are
bit for bit those of the one-function code and of the generated Python.
"""

import dataclasses

import numpy as np
import pytest
import sympy as sm

import mbgen
from checks import CC, assert_compiles_strictly
from cstack import call_graph, deepest, stack_usage
from mbgen.build.extension import load
from mbgen.codegen import split
from mbgen.codegen.outputs import Form
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.runtime.compiled import CompiledModel

OUTPUTS = ("rhs", "jacobian", "mass_matrix", "forcing")


def scenes():
    """The arm driven by a torque ``a sin(w t)`` (time and parameters read in parts; by
    Newton-Euler, whose articulated-body pivots are checked in parts), the cart (inputs)."""
    arm = load_scene("spatial_arm", n=3)
    a, w = arm.model.constants("a w")
    arm.model.torque(arm.model.frame("L2"), a * sm.sin(w * mbgen.t) * arm.model.frame("L1").z)
    driven = dataclasses.replace(arm, name="driven_arm", method=mbgen.Method.NEWTON_EULER,
                                 parameters={**arm.parameters, "a": 2.0, "w": 3.0})
    return {"driven": driven, "cart": load_scene("n_link_cart", n=3)}


def build_pair(name):
    """``(scene, one-function code, split code)``."""
    scene = scenes()[name]
    kw = {"form": Form.RECURSIVE} if name == "driven" else {}
    whole = run(scene, OUTPUTS, build=False, **kw).rendered
    mp = pytest.MonkeyPatch()
    mp.setattr(split, "SPLIT_CHARS", 60)
    mp.setattr(split, "PART_CHARS", 60)
    try:
        cut = run(scene, OUTPUTS, build=False, **kw).rendered
    finally:
        mp.undo()
    return scene, whole, cut


@pytest.fixture(scope="module", params=["driven", "cart"])
def pair(request):
    return build_pair(request.param)


def compiled(rendered):
    return CompiledModel(rendered, load(rendered))


def test_the_long_functions_are_split_and_say_so(pair):
    _, whole, cut = pair
    assert "_part0(" not in whole.source
    assert "static void" in cut.source or "static int" in cut.source
    assert cut.source.count("_part") > 4 and "parts sharing W[" in cut.source
    if cut.layout.n_r:
        assert "const double *r" in cut.source.split("parts sharing W[")[0]
    else:   # the driven arm: time read in a part, a pivot checked in a part
        assert "= t;\n" in cut.source and "    return status;" in cut.source


def test_split_code_gives_the_same_numbers_bit_for_bit(pair):
    scene, whole, cut = pair
    a, b = compiled(whole), compiled(cut)
    py = mbgen.python_model(cut)
    rng = np.random.default_rng(5)
    for _ in range(3):
        x = rng.uniform(-1, 1, a.n_x)
        r = rng.uniform(-1, 1, a.n_r) if a.n_r else None
        t = float(rng.uniform(0, 2))
        for name in OUTPUTS:
            ours = getattr(b, name)(t, x, None, r)
            np.testing.assert_array_equal(ours, getattr(a, name)(t, x, None, r))
            np.testing.assert_allclose(ours, getattr(py, name)(t, x, None, r), rtol=1e-13,
                                       atol=1e-13)


def test_split_code_compiles_strictly_as_c_and_cxx(pair, tmp_path):
    _, _, cut = pair
    assert_compiles_strictly(cut.files, cut.prefix, tmp_path)


@pytest.mark.parametrize("opt", ["-O0", "-O2"])
def test_the_stack_bound_covers_the_parts(pair, opt, tmp_path):
    _, _, cut = pair
    usage = stack_usage(CC, tmp_path, cut.files, opt)
    graph = call_graph(cut.source)
    graph = {f: {c for c in cs if c in usage} for f, cs in graph.items()}
    for fn, bound in dict(cut.stack_bounds).items():
        assert deepest(fn, usage, graph) <= bound, (fn, deepest(fn, usage, graph), bound)


def test_a_pivot_checked_in_a_part_stops_the_function():
    """The driven arm's articulated-body pivot fails (a negative mass) inside a part: the
    function returns the part's status, as the one-function code does."""
    scene, whole, cut = build_pair("driven")
    a, b = compiled(whole), compiled(cut)
    p = np.array([{"m3": -50.0}.get(n, scene.parameters.get(n, 0.0))
                  for n in cut.layout.parameter_names])
    x = np.full(a.n_x, 0.3)
    for model in (a, b):
        with pytest.raises(mbgen.SingularMassMatrixError):
            model.rhs(0.0, x, p)


def _view(temps, pre, post_temps=(), post=()):
    """A plain C function view of :func:`mbgen.codegen.targets.model.function_views`' shape."""
    def blocks(rows):
        return [dict(name=name, local=name != "J", size=len(es), mirror=[],
                     assignments=list(enumerate(es))) for name, es in rows]
    return dict(name="m_jacobian", args=["t", "x"], loads=[("q1", "x", 0), ("u1", "x", 1)],
                uses_time=False, velocity=[], temps=list(temps), post_temps=list(post_temps),
                pre=blocks(pre), post=blocks(post))


def test_block_entries_are_stored_by_the_parts():
    """The 32-link arm's Jacobian kept its block entries (``DT``: 2 n^2 sums of products,
    225 KB of C) in the public function, which fell to -O1: now the parts store them, through
    the array as an argument, reading what earlier parts computed from ``W``."""
    temps = [("v0", "q1*q1", False), ("v1", "v0*u1", False)]
    view = _view(temps, [("M", ["v0"]), ("F", ["v1"]), ("J", ["0.0", "1.0"])],
                 post=[("DT", ["-v0*v1", "-v1*F[0]", "v0 + v1"])])
    split.split_view(view, "t", ("F",), split_chars=5, part_chars=12)
    stores = [s for p in view["parts"] for s in p["stores"]]
    assert stores == [("M[0]", "v0"), ("F[0]", "v1"), ("J[0]", "0.0"), ("J[1]", "1.0"),
                      ("DT[0]", "-v0*v1"), ("DT[1]", "-v1*F[0]"), ("DT[2]", "v0 + v1")]
    assert all(b["assignments"] == [] for b in view["pre"] + view["post"])
    assert view["split"] == ("temps", "post_temps")
    assert view["main_loads"] == [] and view["main_imports"] == {"temps": [], "post_temps": []}
    post = [p for p in view["parts"] if p["section"] == "post_temps"]
    assert post and all("double *DT" in p["prototype"] for p in post)
    reads_f = [p for p in post if "F[0]" in str(p["stores"])]
    assert reads_f and "const double *F" in reads_f[0]["prototype"]
    assert {s for p in post for s, _ in p["imports"]} == {"v0", "v1"}   # through W
    first = view["parts"][0]
    assert first["temps"][0][:2] == ("v0", "q1*q1") and "double *M" not in first["prototype"]


def test_long_blocks_alone_split_a_function():
    """Short temporaries but long block entries: the function is split all the same (the size
    that decides counts both), and small functions are left whole."""
    many = [f"v0*v0*{k}.0" for k in range(50)]
    view = _view([("v0", "q1*u1", False)], [("J", many)])
    split.split_view(view, "t", (), split_chars=400, part_chars=200)
    assert len(view["parts"]) > 2 and view["pre"][0]["assignments"] == []
    small = _view([("v0", "q1*u1", False)], [("J", many[:3])])
    split.split_view(small, "t", (), split_chars=400, part_chars=200)
    assert small["parts"] == [] and len(small["pre"][0]["assignments"]) == 3


def test_short_statements_count_what_they_print():
    """The 32-link arm's RHS: 3,275 short temporaries, under the split's size by their
    expressions alone but 168 KB of C as one function, which fell to -O1 (gcc 2.0 s).  The
    size that decides counts each statement as printed, so it is cut into parts that keep
    -O2 (gcc 1.2 s)."""
    temps = [(f"v{k}", "q1*u1", False) for k in range(40)]
    expressions = sum(len(e) for _, e, _ in temps)
    view = _view(temps, [("J", ["v0"])])
    split.split_view(view, "t", (), split_chars=expressions + 10, part_chars=400)
    assert len(view["parts"]) > 1
