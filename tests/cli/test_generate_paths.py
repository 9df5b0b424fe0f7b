"""Where ``generate``, ``demo`` and ``golden`` write.

``generate`` writes to ``mbgen-out/SCENE`` by default, never the golden tree; a
regeneration removes only the files it wrote and overwrites none it did not write;
a file the user changed since mbgen wrote it is neither overwritten (a named error)
nor removed (kept, and said so); ``demo`` writes through the same function; the
header's bytes do not depend on the caller's folder; ``golden`` refuses to run outside
a source checkout and removes stale files.
"""

import json

from mbgen.cli import EXIT_OK, EXIT_USAGE, main
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.verify import golden
from models import scene_file


def test_generate_defaults_to_mbgen_out_and_never_the_golden_tree(tmp_path, monkeypatch, capsys):
    """Issue 11: generate defaulted to generated/SCENE and overwrote the golden files."""
    monkeypatch.chdir(tmp_path)
    assert main(["generate", "disc_pendulum"]) == EXIT_OK
    assert (tmp_path / "mbgen-out" / "disc_pendulum" / "disc_pendulum.h").is_file()
    assert not (tmp_path / "generated").exists()


def test_regeneration_removes_only_what_it_wrote(tmp_path, capsys):
    """Issue 11: a stale example.c was left behind by a regeneration."""
    out = tmp_path / "out"
    assert main(["generate", "disc_pendulum", "-o", str(out)]) == EXIT_OK
    assert (out / "example.c").is_file()
    (out / "notes.txt").write_text("mine")
    assert main(["generate", "disc_pendulum", "-o", str(out), "--outputs", "rhs"]) == EXIT_OK
    assert not (out / "example.c").exists()
    assert (out / "notes.txt").read_text() == "mine"
    assert "removed" in capsys.readouterr().out


def test_generate_does_not_overwrite_files_it_did_not_write(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "disc_pendulum.c").write_text("/* my own code */\n")
    assert main(["generate", "disc_pendulum", "-o", str(out)]) == EXIT_USAGE  # issue 19: was 3
    assert "--overwrite" in capsys.readouterr().err
    assert (out / "disc_pendulum.c").read_text() == "/* my own code */\n"
    assert not (out / "disc_pendulum.h").exists()
    assert main(["generate", "disc_pendulum", "-o", str(out), "--overwrite"]) == EXIT_OK
    assert "my own code" not in (out / "disc_pendulum.c").read_text()


def test_regeneration_keeps_an_edited_file_it_no_longer_generates(tmp_path, capsys):
    """Issue 18: a regeneration with fewer outputs deleted an edited example.c."""
    out = tmp_path / "out"
    assert main(["generate", "disc_pendulum", "-o", str(out)]) == EXIT_OK
    (out / "example.c").write_text("/* my edits */\n")
    capsys.readouterr()
    assert main(["generate", "disc_pendulum", "-o", str(out), "--outputs", "rhs"]) == EXIT_OK
    assert (out / "example.c").read_text() == "/* my edits */\n"
    assert f"{out / 'example.c'}  (kept: changed since mbgen wrote it; no longer generated)" \
        in capsys.readouterr().out.splitlines()
    assert "example.c" not in json.loads((out / ".mbgen-manifest.json").read_text())["files"]


def test_regeneration_refuses_to_overwrite_an_edited_file(tmp_path, capsys):
    """Issue 18: a regeneration overwrote a generated file the user had edited."""
    out = tmp_path / "out"
    assert main(["generate", "disc_pendulum", "-o", str(out)]) == EXIT_OK
    (out / "disc_pendulum.c").write_text("/* tuned by hand */\n")
    header = (out / "disc_pendulum.h").read_text()
    capsys.readouterr()
    assert main(["generate", "disc_pendulum", "-o", str(out), "--outputs", "rhs,jacobian"]) \
        == EXIT_USAGE
    err = capsys.readouterr().err
    assert "disc_pendulum.c (changed since mbgen wrote it)" in err and "--overwrite" in err
    assert (out / "disc_pendulum.c").read_text() == "/* tuned by hand */\n"
    assert (out / "disc_pendulum.h").read_text() == header          # nothing else changed
    assert main(["generate", "disc_pendulum", "-o", str(out), "--outputs", "rhs,jacobian",
                 "--overwrite"]) == EXIT_OK
    assert "tuned by hand" not in (out / "disc_pendulum.c").read_text()


def test_demo_does_not_overwrite_a_users_file(tmp_path, capsys):
    """Issue 18: ``mbgen demo -o DIR`` overwrote a user's file of the same name."""
    out = tmp_path / "demo"
    out.mkdir()
    (out / "trajectory.csv").write_text("my measurements\n")
    assert main(["demo", "-o", str(out)]) == EXIT_USAGE
    err = capsys.readouterr().err
    assert "trajectory.csv (mbgen did not write it)" in err and "--overwrite" in err
    assert (out / "trajectory.csv").read_text() == "my measurements\n"
    assert sorted(p.name for p in out.iterdir()) == ["trajectory.csv"]
    assert main(["demo", "-o", str(out), "--overwrite"]) == EXIT_OK
    assert (out / "trajectory.csv").read_text().startswith("t,")
    # issue 19: the demo writes example.c as generate does, and says how to build it
    assert (out / "example.c").read_text() == golden.scene_files("disc_pendulum")["example.c"]
    assert f"C program: {out / 'example.c'}; build and run it with: cd {out} && cc -std=c99" \
        in capsys.readouterr().out
    assert set(json.loads((out / ".mbgen-manifest.json").read_text())["files"]) == {
        "disc_pendulum.c", "disc_pendulum.h", "disc_pendulum.py", "example.c", "trajectory.csv"}


def test_generate_into_a_file_is_an_error(tmp_path, capsys):
    target = tmp_path / "file"
    target.write_text("x")
    assert main(["generate", "disc_pendulum", "-o", str(target)]) == EXIT_USAGE  # issue 19: was 3
    assert "is a file" in capsys.readouterr().err


def test_header_bytes_do_not_depend_on_the_callers_folder(tmp_path, monkeypatch):
    """Issue 11: the header recorded the scene path as typed."""
    (tmp_path / "scenes").mkdir()
    path = scene_file(tmp_path / "scenes")
    monkeypatch.chdir(tmp_path)
    a = run(load_scene("scenes/pend.py"), build=False).rendered.files
    monkeypatch.chdir(tmp_path / "scenes")
    b = run(load_scene("pend.py"), build=False).rendered.files
    c = run(load_scene(str(path)), build=False).rendered.files
    assert a == b == c
    assert "(pend.py)" in a["pend.h"] and str(tmp_path) not in a["pend.h"]


def test_golden_refuses_outside_a_checkout(tmp_path, monkeypatch, capsys):
    fake = tmp_path / "site-packages" / "mbgen" / "golden.py"
    monkeypatch.setattr(golden, "__file__", str(fake))
    assert main(["golden", "--scenes", "disc_pendulum"]) == EXIT_USAGE
    assert "source checkout" in capsys.readouterr().err
    assert not (tmp_path / "site-packages" / "generated").exists()


def test_golden_update_removes_stale_files(tmp_path):
    root = tmp_path / "generated"
    golden.update(root, ["disc_pendulum"])
    (root / "disc_pendulum" / "old.c").write_text("int stale;\n")
    assert any("unexpected" in d for d in golden.differences(root, ["disc_pendulum"]))
    golden.update(root, ["disc_pendulum"])
    assert not golden.differences(root, ["disc_pendulum"])


def test_generate_refuses_a_lock_that_is_a_link(tmp_path, capsys):
    """Issue 28: whoever could write the parent folder made mbgen create a file anywhere."""
    (tmp_path / ".out.lock").symlink_to(tmp_path / "victim")
    assert main(["generate", "disc_pendulum", "-o", str(tmp_path / "out")]) == EXIT_USAGE
    err = capsys.readouterr().err
    assert "symbolic link" in err and "Traceback" not in err and len(err.splitlines()) == 1
    assert not (tmp_path / "victim").exists() and not (tmp_path / "out").exists()
