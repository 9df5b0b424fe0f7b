"""Writing a generation into a folder (:func:`mbgen.fileio.write_generated`).

What the user changed or put there is never deleted or overwritten (the manifest
records a SHA-256 per file); a generation is whole or absent: it is written into a
sibling folder and swapped in under a lock, so a process killed with SIGKILL between
files leaves the old generation whole, two processes at once give one whole set (or
a refusal), and the next run cleans what a killed run left.  The kills and races use
real child processes.
"""

import json
import os
import signal
import stat
import subprocess
import sys
import textwrap

import pytest

from mbgen import fileio
from mbgen.errors import OutputBusyError, OutputConflictError, SceneError

#: A child process that writes generation ``tag`` (``n`` files, each naming its tag) into
#: ``folder`` with the options of its JSON argument: it kills itself (SIGKILL) when it
#: opens for writing its ``kill_at``-th generated file, when ``fileio``'s function
#: ``kill_in`` is called, or (``kill_in`` = ``rename:K``) at its ``K``-th ``os.rename``;
#: it creates the file ``announce`` before it starts, and after its third file waits for
#: the file ``await`` to exist and then for ``slow`` seconds before each further file;
#: ``exchange: false`` takes the two-rename path of systems without ``renameat2``.
CHILD = textwrap.dedent("""
    import io, json, os, re, signal, sys, time
    from mbgen import fileio
    from mbgen.errors import MbgenError

    o = json.loads(sys.argv[1])
    files = {f"f{i:02d}.c": f"/* generation {o['tag']}, file {i} */\\n" * 50
             for i in range(o["n"])}
    opened = 0
    real_open, real_rename, renames = io.open, os.rename, []

    def killed(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGKILL)

    def watched_open(file, mode="r", *args, **kwargs):
        global opened
        if any(c in mode for c in "wax") and re.search(r"f\\d\\d\\.c", os.fspath(file)):
            opened += 1
            if opened == o["kill_at"]:
                killed()
            if opened > 3 and o["await"]:
                give_up = time.monotonic() + 120          # the other never came
                while not os.path.exists(o["await"]) and time.monotonic() < give_up:
                    time.sleep(0.01)
                time.sleep(o["slow"])
        return real_open(file, mode, *args, **kwargs)

    def counted_rename(*args, **kwargs):
        renames.append(args)
        if o["kill_in"] == f"rename:{len(renames)}":
            killed()
        return real_rename(*args, **kwargs)

    io.open, os.rename = watched_open, counted_rename
    if o["kill_in"] and not o["kill_in"].startswith("rename:"):
        setattr(fileio, o["kill_in"], killed)
    if not o["exchange"]:
        fileio._exchange = lambda a, b: False
    if o["announce"]:
        open(o["announce"], "w").close()
    try:
        fileio.write_generated(o["folder"], files)
    except MbgenError as exc:
        print(type(exc).__name__, exc)
        sys.exit(3)
""")


def child(folder, tag, n=6, kill_at=0, kill_in="", exchange=True, announce="", wait_for="",
          slow=0.0):
    """Start the child writer (:data:`CHILD`); returns the Popen."""
    options = dict(folder=str(folder), tag=tag, n=n, kill_at=kill_at, kill_in=kill_in,
                   exchange=exchange, announce=str(announce), slow=slow)
    options["await"] = str(wait_for)
    return subprocess.Popen([sys.executable, "-c", CHILD, json.dumps(options)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def generations(folder):
    """The set of generation tags of the generated files in ``folder``."""
    tags = set()
    for path in folder.glob("f*.c"):
        tags.add(path.read_text().split(",")[0].split()[-1])
    return tags


def write(folder, tag, n=6):
    files = {f"f{i:02d}.c": f"/* generation {tag}, file {i} */\n" * 50 for i in range(n)}
    return fileio.write_generated(folder, files)


def siblings(folder):
    """What a generation left beside ``folder`` (locks, temporary folders)."""
    return sorted(p.name for p in folder.parent.iterdir() if p.name.startswith(f".{folder.name}."))


# ------------------------------------------------------------------ what the user changed
def test_the_manifest_records_a_hash_per_file(tmp_path):
    out = tmp_path / "out"
    fileio.write_generated(out, {"a.c": "int a;\n"})
    record = json.loads((out / fileio.MANIFEST).read_text())["files"]
    assert record == {"a.c": "sha256:" + fileio.digest(b"int a;\n")}


def test_an_edited_file_is_neither_overwritten_nor_deleted(tmp_path):
    out = tmp_path / "out"
    fileio.write_generated(out, {"a.c": "int a;\n", "b.c": "int b;\n"})
    (out / "a.c").write_text("int a; /* mine */\n")
    (out / "b.c").write_text("int b; /* mine */\n")
    with pytest.raises(OutputConflictError, match=r"a\.c \(changed since mbgen wrote it\).*"
                                                  r"--overwrite.*\(-o\)"):
        fileio.write_generated(out, {"a.c": "int a2;\n"})
    assert (out / "a.c").read_text() == "int a; /* mine */\n"
    done = fileio.write_generated(out, {"c.c": "int c;\n"})       # a.c, b.c no longer generated
    assert list(done.kept) == [out / "a.c", out / "b.c"] and done.removed == []
    assert (out / "b.c").read_text() == "int b; /* mine */\n"
    assert any("kept" in line and "b.c" in line for line in done.remarks())


def test_overwrite_replaces_an_edited_file(tmp_path):
    out = tmp_path / "out"
    fileio.write_generated(out, {"a.c": "int a;\n"})
    (out / "a.c").write_text("mine\n")
    done = fileio.write_generated(out, {"a.c": "int a2;\n"}, overwrite=True)
    assert (out / "a.c").read_text() == "int a2;\n" and done.changed == [out / "a.c"]


def test_a_name_only_manifest_is_read_and_its_files_are_not_trusted(tmp_path):
    """An older mbgen wrote ``{"files": [names]}``: mbgen cannot tell whether those files
    were changed, so it replaces them only when their text is already the new one."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.c").write_text("int a;\n")
    (out / "b.c").write_text("int b;\n")
    (out / fileio.MANIFEST).write_text(json.dumps({"files": ["a.c", "b.c"]}))
    with pytest.raises(OutputConflictError, match=r"b\.c \(cannot tell"):
        fileio.write_generated(out, {"a.c": "int a;\n", "b.c": "int b2;\n"})
    done = fileio.write_generated(out, {"a.c": "int a;\n"})
    assert done.changed == [] and list(done.kept) == [out / "b.c"]
    assert json.loads((out / fileio.MANIFEST).read_text())["files"] == {
        "a.c": "sha256:" + fileio.digest(b"int a;\n")}


def test_unchanged_files_keep_their_inode_and_time(tmp_path):
    out = tmp_path / "out"
    fileio.write_generated(out, {"a.c": "int a;\n", "b.c": "int b;\n"})
    before = os.stat(out / "a.c")
    done = fileio.write_generated(out, {"a.c": "int a;\n", "b.c": "int b2;\n"})
    after = os.stat(out / "a.c")
    assert done.changed == [out / "b.c"]
    assert (after.st_ino, after.st_mtime_ns) == (before.st_ino, before.st_mtime_ns)


def test_the_users_files_subfolders_and_links_are_carried(tmp_path):
    out = tmp_path / "out"
    fileio.write_generated(out, {"a.c": "int a;\n"})
    os.chmod(out, 0o750)
    (out / "notes.txt").write_text("mine\n")
    (out / "build" / "obj").mkdir(parents=True)
    (out / "build" / "obj" / "a.o").write_bytes(b"\x7fELF")
    (out / "link").symlink_to("notes.txt")
    (out / "dangling").symlink_to("nowhere")
    ino = os.stat(out / "notes.txt").st_ino
    fileio.write_generated(out, {"a.c": "int a2;\n"})
    assert (out / "notes.txt").read_text() == "mine\n" and os.stat(out / "notes.txt").st_ino == ino
    assert (out / "build" / "obj" / "a.o").read_bytes() == b"\x7fELF"
    assert os.readlink(out / "link") == "notes.txt" and os.readlink(out / "dangling") == "nowhere"
    assert os.stat(out).st_mode & 0o777 == 0o750
    assert siblings(out) == []


def test_new_files_follow_the_umask_and_replaced_ones_keep_their_mode(tmp_path):
    out = tmp_path / "out"
    old = os.umask(0o027)
    try:
        fileio.write_generated(out, {"a.c": "int a;\n"})
        assert os.stat(out / "a.c").st_mode & 0o777 == 0o640
        assert os.stat(out).st_mode & 0o777 == 0o750
        os.chmod(out / "a.c", 0o600)
        fileio.write_generated(out, {"a.c": "int a2;\n"})
        assert os.stat(out / "a.c").st_mode & 0o777 == 0o600
    finally:
        os.umask(old)


def test_an_entry_that_cannot_be_carried_is_refused_before_any_change(tmp_path):
    out = tmp_path / "out"
    fileio.write_generated(out, {"a.c": "int a;\n"})
    os.mkfifo(out / "pipe")
    with pytest.raises(SceneError, match="pipe.*cannot be carried"):
        fileio.write_generated(out, {"a.c": "int a2;\n"})
    assert (out / "a.c").read_text() == "int a;\n" and siblings(out) == []


def test_a_generation_changes_the_callers_working_folder_to_the_new_one(tmp_path, monkeypatch):
    out = tmp_path / "out"
    fileio.write_generated(out, {"a.c": "int a;\n"})
    monkeypatch.chdir(out)
    fileio.write_generated(".", {"a.c": "int a2;\n"})
    assert open("a.c").read() == "int a2;\n" and os.getcwd() == str(out)


def test_a_working_folder_that_a_generation_replaced_is_named(tmp_path, monkeypatch):
    """A shell left in the replaced folder runs mbgen again: the error says ``cd .``."""
    gone = tmp_path / "gone"
    gone.mkdir()
    monkeypatch.chdir(gone)
    gone.rmdir()
    with pytest.raises(SceneError, match=r"no longer exists.*'cd \.'"):
        fileio.write_generated(".", {"a.c": "int a;\n"})


# ------------------------------------------------------------------ whole or absent
def test_a_generation_killed_between_files_leaves_the_old_one_whole(tmp_path):
    out = tmp_path / "out"
    assert child(out, "one").wait() == 0
    (out / "notes.txt").write_text("mine\n")
    proc = child(out, "two", kill_at=3)
    assert proc.wait() == -signal.SIGKILL
    assert generations(out) == {"one"} and len(list(out.glob("f*.c"))) == 6
    assert (out / "notes.txt").read_text() == "mine\n"
    # the next run removes what the killed one left, and writes a whole set
    write(out, "three")
    assert generations(out) == {"three"} and siblings(out) == []
    assert (out / "notes.txt").read_text() == "mine\n"


@pytest.mark.parametrize("kill_in", ["_swap", "_discard"])
def test_a_kill_around_the_swap_leaves_one_whole_generation(tmp_path, kill_in):
    out = tmp_path / "out"
    write(out, "one")
    (out / "notes.txt").write_text("mine\n")
    assert child(out, "two", kill_in=kill_in).wait() == -signal.SIGKILL
    assert generations(out) == ({"two"} if kill_in == "_discard" else {"one"})
    assert siblings(out)                                        # the killed run's folder
    done = write(out, "three")
    assert generations(out) == {"three"} and siblings(out) == []
    assert any("removed" in line for line in done.remarks())
    assert (out / "notes.txt").read_text() == "mine\n"


def test_a_kill_between_the_two_renames_is_restored(tmp_path):
    """Without ``renameat2`` the swap is two renames; a kill between them leaves no
    folder, and the next run puts the old generation back before it writes."""
    out = tmp_path / "out"
    write(out, "one")
    (out / "notes.txt").write_text("mine\n")
    proc = child(out, "two", kill_in="rename:2", exchange=False)
    assert proc.wait() == -signal.SIGKILL
    assert not out.exists()
    done = write(out, "three")
    assert any("restored" in line for line in done.remarks())
    assert generations(out) == {"three"} and siblings(out) == []
    assert (out / "notes.txt").read_text() == "mine\n"


def test_a_file_found_only_in_a_stale_folder_is_kept(tmp_path):
    out = tmp_path / "out"
    write(out, "one")
    assert child(out, "two", kill_in="_discard").wait() == -signal.SIGKILL
    stale, = (tmp_path / n for n in siblings(out) if ".new-" in n)
    (stale / "only-here.txt").write_text("mine\n")
    done = write(out, "three")
    assert (stale / "only-here.txt").read_text() == "mine\n"
    assert [p.name for p in stale.iterdir()] == ["only-here.txt"]
    assert any("only-here.txt" in line for line in done.remarks())


def test_two_generations_at_once_give_one_whole_set(tmp_path):
    """The first writer, three files in, waits until the second is about to write, then
    goes on slowly: without a lock the second overwrites the first three files only."""
    out = tmp_path / "out"
    write(out, "zero")
    ready = tmp_path / "second-is-writing"
    first = child(out, "one", n=8, wait_for=ready, slow=0.3)
    second = child(out, "two", n=8, announce=ready)
    codes = [first.wait(), second.wait()]
    assert codes in ([0, 0], [0, 3]), [first.stdout.read(), second.stdout.read()]
    assert len(generations(out)) == 1 and len(list(out.glob("f*.c"))) == 8
    assert siblings(out) == []


def test_a_busy_folder_is_refused_after_a_bounded_wait(tmp_path):
    out = tmp_path / "out"
    write(out, "one")
    with fileio.generation_lock(out):
        with pytest.raises(OutputBusyError, match="another mbgen"):
            fileio.write_generated(out, {"f00.c": "x\n"}, wait=0.1)
    assert generations(out) == {"one"}
    write(out, "two")                                           # the lock is free again
    assert generations(out) == {"two"} and siblings(out) == []


def test_without_fcntl_the_lock_is_an_exclusive_file(tmp_path, monkeypatch):
    """Where there is no ``fcntl`` (Windows) the lock is a file created exclusively; a lock
    left by a killed run is named in the refusal, for the user to delete."""
    monkeypatch.setattr(fileio, "fcntl", None)
    out = tmp_path / "out"
    write(out, "one")
    assert siblings(out) == []
    (tmp_path / ".out.lock").write_text("")
    with pytest.raises(OutputBusyError, match=r"delete .*\.out\.lock"):
        fileio.write_generated(out, {"f00.c": "x\n"}, wait=0)
    (tmp_path / ".out.lock").unlink()
    write(out, "two")
    assert generations(out) == {"two"} and siblings(out) == []


def test_new_files_get_the_umask_without_setting_it(tmp_path, monkeypatch):
    """The umask is process-wide: setting it to read it would give another thread's new files
    the wrong mode.  New files get 0666 minus the umask from the kernel; replaced files keep
    their mode."""
    old = os.umask(0o027)
    try:
        monkeypatch.setattr(os, "umask", lambda *a: pytest.fail("os.umask was called"))
        fileio.write_atomic(tmp_path / "a.txt", "a\n")
        fileio.write_generated(tmp_path / "out", {"b.c": "int b;\n"})
    finally:
        monkeypatch.undo()
        os.umask(old)
    assert stat.S_IMODE(os.stat(tmp_path / "a.txt").st_mode) == 0o640
    assert stat.S_IMODE(os.stat(tmp_path / "out" / "b.c").st_mode) == 0o640
    os.chmod(tmp_path / "a.txt", 0o600)
    fileio.write_atomic(tmp_path / "a.txt", "changed\n")
    assert stat.S_IMODE(os.stat(tmp_path / "a.txt").st_mode) == 0o600
