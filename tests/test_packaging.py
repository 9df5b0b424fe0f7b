"""The wheel ships the templates, and an installed mbgen renders from them."""

import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_wheel_contains_templates_and_scenes(tmp_path):
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                    "-q", "-w", str(tmp_path), str(ROOT)], check=True, capture_output=True)
    wheel, = tmp_path.glob("mbgen-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    templates = sorted((ROOT / "templates").rglob("*.j2"))
    assert len(templates) > 20  # grouped by target in subfolders
    for template in templates:
        assert f"mbgen/_templates/{template.relative_to(ROOT / 'templates').as_posix()}" in names
    for module in (ROOT / "mbgen").rglob("*.py"):  # every stage folder is a listed package
        assert module.relative_to(ROOT).as_posix() in names
    assert "mbgen/scenes/disc_pendulum.py" in names
    assert "mbgen/derivation/kane.py" in names
    assert "mbgen/py.typed" in names  # PEP 561 marker (package-data)
    assert "mbgen/build/crossing.c" in names  # compiled into every model's extension
