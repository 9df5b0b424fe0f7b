"""Built-in scenes too heavy for the default test run on today's symbolic core.

The tests that loop over every built-in scene take their parameters from
:func:`scene_params`: a heavy scene is still a case of every such test, marked
``slow`` (deselected by default, run with ``pytest -m slow``), never skipped.

``bicycle``: its rolling constraints nest deeply.  Before the symbolic core
became linear in the expression graph its ``jacobian`` output took minutes and
gigabytes; now the code is generated in about 10 s, but its ten every-scene
cases still take about 6 minutes together (three generations for the golden
diff, ``gcc -O2`` on a 250 kB Jacobian for the example, unsliced pipelines).
Its own physics tests (``tests/scenes/test_vehicles.py``) run by default.

``whipple`` (the benchmark bicycle, 7,000 operations in its right-hand side):
light enough for every every-scene case but the heavy ones (``heavy=True``):
those that generate, compile and lambdify *every* output at once (the back ends
on every output, the Jacobians against lambdified symbolic ones, the sliced code
against the full code), the golden diff (its bytes are compared with
``generated/whipple`` by ``tests/codegen/test_determinism.py`` once by default, a second
machine variant ``slow``)
the example program, the derivation choice's 10 % rule (both derivations compiled) and
the plain C/C++ embedding compile, about 98 s together of a default run near 9 minutes.
Its determinism, generated C's warnings (C), energy, Newton–Euler against Kane,
constrained back ends (rhs and constraint forces) and sympy oracle stay default.
"""

import pytest

from mbgen.model.scene import builtin_names

#: scene name -> why it is heavy
HEAVY = {
    "bicycle": "every-scene cases: about 6 minutes together (large Jacobian, gcc -O2)",
}


#: scene name -> why it is heavy for the heavy every-scene cases (``scene_params(heavy=True)``)
HEAVY_CASES = {
    "whipple": "every output at once, the golden diff, the example, the 10 % rule, the plain "
               "C/C++ compile: about 98 s over seven cases",
}


def scene_params(names=None, heavy: bool = False) -> list:
    """``names`` (default: every built-in scene) as pytest params, heavy ones marked slow
    (in a heavy case, those of :data:`HEAVY_CASES` too)."""
    heavy = set(HEAVY) | (set(HEAVY_CASES) if heavy else set())
    return [pytest.param(n, marks=pytest.mark.slow, id=n) if n in heavy else n
            for n in (builtin_names() if names is None else names)]
