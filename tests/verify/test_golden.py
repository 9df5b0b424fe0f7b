"""generated/ holds exactly what the generator produces today.

Regenerate with ``mbgen golden --update`` (run from the repository root).
"""

from pathlib import Path

import pytest

from heavy import scene_params
from mbgen.model.scene import builtin_names
from mbgen.verify import golden

ROOT = Path(__file__).resolve().parents[2] / "generated"


def test_every_builtin_scene_has_a_folder():
    assert sorted(p.name for p in ROOT.iterdir() if p.is_dir()) == builtin_names()


@pytest.mark.parametrize("name", scene_params(heavy=True))
def test_generated_tree_matches_generator(name, tmp_path):
    fresh = tmp_path / "generated"
    golden.update(fresh, [name])
    assert not golden.differences(fresh, [name]), "update() must produce a tree with no differences"
    diffs = golden.differences(ROOT, [name])
    assert not diffs, ("generated/ is out of date; run 'mbgen golden --update':\n"
                       + "\n".join(diffs)[:5000])
