"""Replays each misuse class of the hardening issue: one quick test per class, each
failing on the code before its fix (the thorough tests sit in the area's own test files).
"""

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

from mbgen.build.fmu import write_fmu
from mbgen.cli import EXIT_MODEL, EXIT_OK, main

ROOT = Path(__file__).resolve().parent.parent


# --- 1. A regeneration never deletes or overwrites what the user changed or put there
def test_regeneration_keeps_the_users_edits(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["generate", "disc_pendulum", "-o", str(out)]) == EXIT_OK
    (out / "example.c").write_text("/* my example */\n")
    assert main(["generate", "disc_pendulum", "-o", str(out), "--outputs", "rhs"]) == EXIT_OK
    assert (out / "example.c").read_text() == "/* my example */\n"        # not deleted
    (out / "disc_pendulum.c").write_text("/* my tuning */\n")
    assert main(["generate", "disc_pendulum", "-o", str(out)]) == EXIT_MODEL
    assert (out / "disc_pendulum.c").read_text() == "/* my tuning */\n"   # not overwritten
    assert "--overwrite" in capsys.readouterr().err


# --- 2. A generation is whole or absent
KILLED_GENERATE = textwrap.dedent("""
    import io, os, signal, sys
    from mbgen.cli import main

    real_open, opened = io.open, []

    def open_(file, mode="r", *args, **kwargs):
        if "w" in mode and "disc_pendulum" in os.path.basename(os.fspath(file)):
            opened.append(file)
            if len(opened) == 2:                       # the first file is written
                os.kill(os.getpid(), signal.SIGKILL)
        return real_open(file, mode, *args, **kwargs)

    io.open = open_
    main(["generate", "disc_pendulum", "-o", sys.argv[1], "--outputs", "rhs,jacobian"])
""")


def test_a_generation_killed_between_files_leaves_the_old_one_whole(tmp_path):
    out = tmp_path / "out"
    assert main(["generate", "disc_pendulum", "-o", str(out), "--outputs", "rhs"]) == EXIT_OK
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    proc = subprocess.run([sys.executable, "-c", KILLED_GENERATE, str(out)], cwd=tmp_path,
                          capture_output=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert proc.returncode == -signal.SIGKILL
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before      # the old set, whole


# --- 5. Scene files are Python and run when loaded
def test_the_docs_say_scene_files_run_as_code():
    readme = (ROOT / "README.md").read_text()
    safety = readme.split("## Safety")[1].split("\n## ")[0]
    assert "Scene files are Python" in safety and "trust" in safety
    for text in (readme.split("## Scenes")[1].split("\n## ")[0],
                 (ROOT / "docs" / "modelling.md").read_text()):
        assert "runs when it is loaded" in text


# --- The .fmu follows the umask like every other output
def test_the_fmu_follows_the_umask(tmp_path):
    old = os.umask(0o022)
    try:
        path = write_fmu(tmp_path, "m", {"modelDescription.xml": "<x/>"}, b"")
    finally:
        os.umask(old)
    assert os.stat(path).st_mode & 0o777 == 0o644                       # not mkstemp's 0600
