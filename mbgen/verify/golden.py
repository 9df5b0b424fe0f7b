"""The checked-in generated code of the built-in scenes (``generated/<scene>/``).

``mbgen golden`` compares the tree with freshly generated code and
``mbgen golden --update`` rewrites it; ``tests/verify/test_golden.py`` fails on any
difference, so the checked-in files always match the generator.

It is a developer's command: the tree is the one of the source checkout mbgen
runs from (:func:`repository_root`, found from the package's own location, not
from the current folder), and without a checkout it refuses.  The update
removes files in a scene's folder that the generator no longer produces (the
folders hold generated files only).  :func:`compare` lists the differences, a
:class:`Difference` per file (its unified diff in ``diff``): ``mbgen golden`` prints
the one-line summary first, then one line per file, and the diffs with ``-v``.
"""

from __future__ import annotations

import difflib
from pathlib import Path
from typing import NamedTuple

from ..codegen.targets.example import example_settings, render_example
from ..errors import UsageError
from ..fileio import write_files
from ..model.scene import builtin_names, load_scene
from ..pipeline import run

#: Scene options used for the checked-in code (kept small).
GOLDEN_OPTIONS: dict[str, dict] = {"n_link_cart": {"n": 3}}


def repository_root() -> Path:
    """The source checkout mbgen is imported from (holding ``pyproject.toml`` and ``generated/``).

    Raises
    ------
    UsageError
        mbgen is installed, not run from a checkout: the golden tree is not there.
    """
    root = Path(__file__).resolve().parents[2]
    project = root / "pyproject.toml"
    if project.is_file() and (root / "generated").is_dir() and \
            'name = "mbgen"' in project.read_text(encoding="utf-8", errors="replace"):
        return root
    raise UsageError("'mbgen golden' is a developer command for a source checkout of mbgen "
                     f"(this mbgen runs from {root}, which has no pyproject.toml and "
                     f"generated/); to write generated code, use 'mbgen generate SCENE -o DIR'")


def default_root() -> Path:
    """The checked-in tree: ``<repository>/generated``."""
    return repository_root() / "generated"


def scene_files(name: str) -> dict[str, str]:
    """``{file name: text}`` generated for built-in scene ``name`` (with ``example.c``)."""
    scene = load_scene(name, **GOLDEN_OPTIONS.get(name, {}))
    result = run(scene, build=False)
    files = dict(result.rendered.files)
    example = render_example(scene, result.kernel)
    if example is not None:
        files["example.c"] = example
    return files


def example_integration(scene, result, r=None):
    """The trajectory of ``example.c`` computed through Python (``CompiledModel.integrate``).

    ``result`` is the scene's pipeline result, built; the settings are the example's
    (:func:`mbgen.codegen.targets.example.example_settings`, with the inputs ``r`` it
    was rendered with), so the two can be compared.
    """
    method, t, x0, p, r, options = example_settings(scene, result.kernel, r)
    return result.compiled.integrate(method, t, x0, p, r, **options)


def expected(names=None) -> dict[str, dict[str, str]]:
    """Generated files of every built-in scene (or of ``names``)."""
    return {n: scene_files(n) for n in (names or builtin_names())}


def update(root: Path, names=None) -> list[Path]:
    """Rewrite ``root/<scene>/`` for every scene; returns the files that changed or were removed.

    Files in a scene's folder that the generator no longer produces are removed.
    """
    changed = []
    for name, files in expected(names).items():
        folder = Path(root) / name
        changed += write_files(folder, files)
        for stale in sorted(folder.iterdir()):
            if stale.name not in files and stale.is_file() and not stale.is_symlink():
                stale.unlink()
                changed.append(stale)
    return changed


class Difference(NamedTuple):
    """A file of the golden tree that differs from the generator's."""

    path: Path
    #: ``"changed"``, ``"missing"`` (generated, not in the tree) or ``"unexpected"``
    #: (in the tree, no longer generated)
    kind: str
    #: the unified diff of a changed file (empty otherwise)
    diff: str = ""

    def __str__(self) -> str:
        return self.diff or f"{self.kind}: {self.path}"


def compare(root: Path, names=None) -> list[Difference]:
    """Every file of ``root`` that differs from what the generator writes now."""
    root = Path(root)
    out = []
    for name, files in expected(names).items():
        folder = root / name
        for fname, text in sorted(files.items()):
            path = folder / fname
            if not path.exists():
                out.append(Difference(path, "missing"))
                continue
            old = path.read_text(encoding="utf-8")
            if old != text:
                out.append(Difference(path, "changed", "".join(difflib.unified_diff(
                    old.splitlines(True), text.splitlines(True), str(path), f"{path} (generated)",
                    n=1))))
        if folder.exists():
            out += [Difference(folder / e, "unexpected")
                    for e in sorted(p.name for p in folder.iterdir() if p.name not in files)]
    return out


def differences(root: Path, names=None) -> list[str]:
    """Unified diffs (or 'missing'/'unexpected' lines) between ``root`` and the generator."""
    return [str(d) for d in compare(root, names)]
