"""The symbolic core is linear in the expression graph, not in its expanded tree.

The reproducer: ``x <- x*cos(x + i) + x`` nested ``n`` times shares every
level twice, so its tree has about ``2**n`` nodes while its graph has ``3 n``.
Every pass (conversion to and from symengine, baking, differentiation, CSE,
counting, printing, the lambdified reference) must cost what the graph costs.
At ``n = 30`` a tree walk would not finish; the passes below take a second.
"""

import math
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import sympy as sm

import mbgen
from mbgen.symbolic.equations import Equations
from mbgen.symbolic.graph import (
    count_ops_dag,
    count_ops_tree,
    postorder_unique,
    split_shared,
    to_symengine,
    to_sympy,
    xreplace_dag,
)
from mbgen.symbolic.layout import Layout

N = 30


def nested(n, q, c):
    x = sm.sin(c * q)
    for i in range(n):
        x = x * sm.cos(x + i) + x
    return x


def nested_value(n, q, c):
    x = math.sin(c * q)
    for i in range(n):
        x = x * math.cos(x + i) + x
    return x


def equations(n=N):
    q, u, c = sm.symbols("q u c")
    L = Layout((q,), (u,), (c,))
    return Equations("nested", L, sm.ImmutableMatrix([[1]]),
                     sm.ImmutableMatrix([nested(n, q, c)]), sm.ImmutableMatrix([u]),
                     defaults={"c": 0.7})


def test_passes_are_linear_in_the_graph():
    q, c = sm.symbols("q c")
    x = nested(N, q, c)
    # (never let pytest print these expressions: their text is as large as the tree)
    nodes, tree, graph = len(postorder_unique([x])), count_ops_tree([x]), count_ops_dag([x])
    assert nodes < 10 * N
    assert tree > 2 ** N             # the tree is huge ...
    assert graph < 2 * N ** 2        # ... the graph is not (sympy flattens nested sums)
    same = to_sympy(to_symengine([x]))[0] == x
    assert same
    same = xreplace_dag([x], {c: sm.Integer(2)})[0] == nested(N, q, sm.Integer(2))
    assert same
    reps, reduced = split_shared(x)
    assert len(reps) <= 2 * N + 2
    assert count_ops_dag([e for _, e in reps] + [reduced]) <= graph


def test_reproducer_through_optimize_render_and_build_in_seconds():
    """Run in a child process with a deadline: an exponential pass would never return."""
    code = textwrap.dedent(f"""
        import sys, time
        sys.path.insert(0, {str(__import__('pathlib').Path(__file__).parent)!r})
        from test_graph import equations
        import mbgen
        from mbgen.codegen.slicing import bake
        from mbgen.codegen.optimize import optimize
        from mbgen.codegen.render import render
        t0 = time.perf_counter()
        eq = equations()
        k = optimize(bake(eq, {{}}), ("rhs", "jacobian", "parameter_jacobian"))
        r = render(k)
        print(k.ops_after, len(r.source), time.perf_counter() - t0)
    """)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    ops_after = int(proc.stdout.split()[0])
    assert ops_after < 2 * N ** 2


def test_reproducer_values_and_jacobian():
    model = mbgen.compile(equations(), ("rhs", "jacobian"))
    ref = mbgen.LambdifiedModel(equations(), ("rhs", "jacobian"))
    rng = np.random.default_rng(3)
    for _ in range(5):
        x = rng.uniform(-1, 1, 2)
        expected = nested_value(N, x[0], 0.7)
        np.testing.assert_allclose(model.rhs(0.0, x)[1], expected, rtol=1e-10, atol=1e-13)
        np.testing.assert_allclose(ref.rhs(0.0, x)[1], expected, rtol=1e-10, atol=1e-13)
        h = 1e-6
        fd = (nested_value(N, x[0] + h, 0.7) - nested_value(N, x[0] - h, 0.7)) / (2 * h)
        J = model.jacobian(0.0, x)
        np.testing.assert_allclose(J, ref.jacobian(0.0, x), rtol=1e-10, atol=1e-12)
        assert J[1, 0] == pytest.approx(fd, rel=1e-5, abs=1e-7)
    baked = mbgen.compile(equations(), ("rhs",), fixed={"c": 0.7}, name="nested_baked")
    assert baked.n_p == 0
    x = np.array([0.3, 0.1])
    np.testing.assert_allclose(baked.rhs(0.0, x), model.rhs(0.0, x), rtol=1e-13)


def test_fewer_collections_raises_the_threshold_and_restores_it():
    """Inside, the collector's first threshold is at least GC_THRESHOLD; the user's own
    thresholds come back on the way out, after nesting and after an exception; a pipeline
    run derives inside it."""
    import gc

    from mbgen.abi import Output
    from mbgen.pipeline import StageTimer, run
    from mbgen.scenes.spatial_arm import scene
    from mbgen.symbolic.graph import GC_THRESHOLD, fewer_collections

    before = gc.get_threshold()
    gc.set_threshold(1234, 9, 8)
    try:
        with fewer_collections():
            assert gc.get_threshold() == (GC_THRESHOLD, 9, 8)
            with fewer_collections():
                assert gc.get_threshold()[0] == GC_THRESHOLD
            assert gc.get_threshold()[0] == GC_THRESHOLD
        assert gc.get_threshold() == (1234, 9, 8)
        with pytest.raises(ZeroDivisionError):
            with fewer_collections():
                raise ZeroDivisionError
        assert gc.get_threshold() == (1234, 9, 8)
        seen = []
        run(scene(2), (Output.RHS,), build=False,
            timer=StageTimer(started=lambda stage: seen.append((stage, gc.get_threshold()[0]))))
        assert seen and all(t == GC_THRESHOLD for _, t in seen), seen
        assert gc.get_threshold() == (1234, 9, 8)
    finally:
        gc.set_threshold(*before)


def test_reachable_shares_what_each_definition_reads(monkeypatch):
    """With ``reads`` shared, a second call over the same definitions walks none again, and
    both calls answer as separate ones do."""
    from mbgen.symbolic import graph

    a, b, c, d, x = sm.symbols("a b c d x")
    defs = {a: x + 1, b: a * x, c: sm.sin(b) + a, d: c * c}
    walked = []
    real = graph.free_symbols

    def counting(exprs):
        walked.append(len(list(exprs)))
        return real(exprs)

    separate = (graph.reachable([d], defs), graph.reachable([b + x], defs))
    monkeypatch.setattr(graph, "free_symbols", counting)
    reads: dict = {}
    assert graph.reachable([d], defs, reads) == separate[0] == {a, b, c, d}
    first = len(walked)
    assert graph.reachable([b + x], defs, reads) == separate[1] == {a, b}
    assert len(walked) - first == 1     # the roots only: a and b were walked by the first call
