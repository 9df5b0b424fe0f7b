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
"""

import pytest

from mbgen.model.scene import builtin_names

#: scene name -> why it is heavy
HEAVY = {
    "bicycle": "every-scene cases: about 6 minutes together (large Jacobian, gcc -O2)",
}


def scene_params(names=None) -> list:
    """``names`` (default: every built-in scene) as pytest params, heavy ones marked slow."""
    return [pytest.param(n, marks=pytest.mark.slow, id=n) if n in HEAVY else n
            for n in (builtin_names() if names is None else names)]
