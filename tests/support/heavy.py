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
light enough for every every-scene case but the few that generate, compile and
lambdify *every* output at once (``every_output=True``: the back ends on every
output, the Jacobians against lambdified symbolic ones, the sliced code against
the full code), about 70 s together of the default run's 10 minutes.  Its
golden files, determinism, generated C's warnings, energy, derivation choice,
constrained back ends (rhs and constraint forces) and sympy oracle stay default.
"""

import pytest

from mbgen.model.scene import builtin_names

#: scene name -> why it is heavy
HEAVY = {
    "bicycle": "every-scene cases: about 6 minutes together (large Jacobian, gcc -O2)",
}


#: scene name -> why it is heavy for the cases that generate every output at once
HEAVY_EVERY_OUTPUT = {
    "whipple": "every output generated, compiled and lambdified: about 70 s over three cases",
}


def scene_params(names=None, every_output: bool = False) -> list:
    """``names`` (default: every built-in scene) as pytest params, heavy ones marked slow
    (with ``every_output``, those of :data:`HEAVY_EVERY_OUTPUT` too)."""
    heavy = set(HEAVY) | (set(HEAVY_EVERY_OUTPUT) if every_output else set())
    return [pytest.param(n, marks=pytest.mark.slow, id=n) if n in heavy else n
            for n in (builtin_names() if names is None else names)]
