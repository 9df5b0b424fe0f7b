"""Built-in scenes too heavy for the default test run on today's symbolic core.

The tests that loop over every built-in scene take their parameters from
:func:`scene_params`: a heavy scene is still a case of every such test, marked
``slow`` (deselected by default, run with ``pytest -m slow``), never skipped.

``bicycle``: its rolling constraints nest deeply; on the tree-walking
conversion to symengine (issue 8) its ``jacobian`` output takes minutes and
gigabytes.  Remove it from :data:`HEAVY` once the symbolic core is linear in
the expression graph.
"""

import pytest

from mbgen.scene import builtin_names

#: scene name -> why it is heavy
HEAVY = {
    "bicycle": "Jacobian of the rolling constraints: minutes on the tree-walking core (issue 8)",
}


def scene_params(names=None) -> list:
    """``names`` (default: every built-in scene) as pytest params, heavy ones marked slow."""
    return [pytest.param(n, marks=pytest.mark.slow, id=n) if n in HEAVY else n
            for n in (builtin_names() if names is None else names)]
