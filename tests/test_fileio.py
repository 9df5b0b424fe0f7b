"""Writing a generation into a folder (:func:`mbgen.fileio.write_generated`).

What the user changed or put there is never deleted or overwritten (the manifest
records a SHA-256 per file); a generation is whole or absent: it is written into a
sibling folder and swapped in under a lock, so a process killed with SIGKILL between
files leaves the old generation whole, two processes at once give one whole set (or
a refusal), and the next run cleans what a killed run left, whatever step it was killed
at.  The lock is a plain file of the user's, never a link; a folder that cannot be renamed
(a mount point) gets its contents swapped; long legal names work.  The kills and races use
real child processes.
"""

import json
import os
import shutil
import signal
import stat
import subprocess
import sys
import textwrap

import pytest

from mbgen import fileio
from mbgen.errors import OutputBusyError, OutputConflictError, OutputPathError, SceneError

#: A child process that writes generation ``tag`` (``n`` files, each naming its tag) into
#: ``folder`` with the options of its JSON argument: it kills itself (SIGKILL) when it
#: opens for writing its ``kill_at``-th generated file, when the function ``kill_in`` of
#: ``fileio.generations`` is called, or (``kill_in`` = ``<f>:K``, e.g. ``rename:2``) at
#: its ``K``-th call of ``os.<f>``; it creates the file ``announce`` before it starts, and
#: after its third file waits for the file ``await`` to exist and then for ``slow`` seconds
#: before each further file; ``exchange: false`` takes the two-rename path of systems
#: without ``renameat2``, ``mount: true`` the content swap of a folder that cannot be
#: renamed.
CHILD = textwrap.dedent("""
    import io, json, os, re, signal, sys, time
    from mbgen import fileio
    from mbgen.fileio import generations
    from mbgen.errors import MbgenError

    o = json.loads(sys.argv[1])
    files = {f"f{i:02d}.c": f"/* generation {o['tag']}, file {i} */\\n" * 50
             for i in range(o["n"])}
    opened = 0
    real_open, calls = io.open, []

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

    def counted(name, real):
        def call(*args, **kwargs):
            calls.append(args)
            if o["kill_in"] == f"{name}:{len(calls)}":
                killed()
            return real(*args, **kwargs)
        return call

    io.open = watched_open
    if ":" in o["kill_in"]:
        name = o["kill_in"].split(":")[0]
        setattr(os, name, counted(name, getattr(os, name)))
    elif o["kill_in"]:
        setattr(generations, o["kill_in"], killed)
    if not o["exchange"]:
        generations._exchange = lambda a, b: False
    if o["mount"]:
        os.path.ismount = lambda path: True
    if o["announce"]:
        open(o["announce"], "w").close()
    try:
        fileio.write_generated(o["folder"], files)
    except MbgenError as exc:
        print(type(exc).__name__, exc)
        sys.exit(3)
""")


def child(folder, tag, n=6, kill_at=0, kill_in="", exchange=True, announce="", wait_for="",
          slow=0.0, mount=False):
    """Start the child writer (:data:`CHILD`); returns the Popen."""
    options = dict(folder=str(folder), tag=tag, n=n, kill_at=kill_at, kill_in=kill_in,
                   exchange=exchange, announce=str(announce), slow=slow, mount=mount)
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


@pytest.mark.parametrize("kill_in, survivor", [("_swap", "one"), ("_discard", "two"),
                                              ("unlink:2", "two")])
def test_a_kill_around_the_swap_leaves_one_whole_generation(tmp_path, kill_in, survivor):
    """``unlink:2``: killed while removing the replaced generation, its manifest gone
    already (issue 28: the next run kept that folder, for files only mbgen had written)."""
    out = tmp_path / "out"
    write(out, "one")
    (out / "notes.txt").write_text("mine\n")
    assert child(out, "two", kill_in=kill_in).wait() == -signal.SIGKILL
    assert generations(out) == {survivor}
    assert siblings(out)                                        # the killed run's folder
    done = write(out, "three")
    assert generations(out) == {"three"} and siblings(out) == []
    assert any("removed" in line for line in done.remarks())
    assert not any("kept" in line for line in done.remarks()), done.remarks()
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
    monkeypatch.setattr(fileio.lock, "fcntl", None)
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


@pytest.mark.slow
@pytest.mark.parametrize("way", ["exchange", "two renames", "contents"])
def test_a_kill_at_any_step_leaves_nothing_the_next_run_keeps(tmp_path, way):
    """Killed at the K-th call of each file operation (every K until the run finishes): the
    folder holds one whole generation (or, while two renames have it absent, the next run
    restores it; a folder swapped by contents may hold both), and the next run writes a
    whole one, keeps the user's files, and leaves no folder and no "kept" remark behind."""
    options = dict(exchange=way != "two renames", mount=way == "contents")
    killed = 0
    for name in ("open", "mkdir", "link", "symlink", "chmod", "rename", "replace", "unlink",
                 "rmdir"):
        for k in range(1, 40):
            out = tmp_path / f"{name}{k}" / "out"
            write(out, "one", n=4)
            (out / "notes.txt").write_text("mine\n")
            (out / "sub").mkdir()
            (out / "sub" / "x.txt").write_text("x\n")
            code = child(out, "two", n=3, kill_in=f"{name}:{k}", **options).wait()
            if code == 0:
                break
            assert code == -signal.SIGKILL
            killed += 1
            if way != "contents":
                assert generations(out) in ({"one"}, {"two"}) or not out.exists()
            done = write(out, "three", n=5)
            assert generations(out) == {"three"} and siblings(out) == [], (name, k)
            assert not [line for line in done.remarks() if "kept" in line], (name, k)
            assert (out / "notes.txt").read_text() == "mine\n"
            assert (out / "sub" / "x.txt").read_text() == "x\n"
            assert not list(out.glob(".mbgen-new-*")), (name, k)
    assert killed > 10


# ------------------------------------------------------------------ the lock
def test_the_lock_is_a_plain_file_of_the_users_never_a_link(tmp_path, monkeypatch):
    """Issue 28: the lock was opened with O_CREAT through a link, so whoever could write the
    parent folder made the user (root, say) create a file wherever the link pointed."""
    out, lock = tmp_path / "out", tmp_path / ".out.lock"
    with fileio.generation_lock(out):
        info = os.lstat(lock)
        assert stat.S_ISREG(info.st_mode) and info.st_uid == os.geteuid()
    (tmp_path / "theirs.txt").write_text("theirs\n")
    for pointee in ("victim", "theirs.txt"):                # dangling, and an existing file
        lock.symlink_to(tmp_path / pointee)
        with pytest.raises(OutputPathError, match=r"\.out\.lock.*symbolic link.*delete it"):
            fileio.write_generated(out, {"a.c": "int a;\n"})
        lock.unlink()
    assert not (tmp_path / "victim").exists()
    assert (tmp_path / "theirs.txt").read_text() == "theirs\n"
    os.mkfifo(lock)                                         # an open for reading would block
    with pytest.raises(OutputPathError, match=r"\.out\.lock.*not a regular file"):
        fileio.write_generated(out, {"a.c": "int a;\n"})
    lock.unlink()
    lock.write_text("")
    uid = os.geteuid()
    monkeypatch.setattr(os, "geteuid", lambda: uid + 1)     # now it is another user's file
    with pytest.raises(OutputPathError, match=rf"\.out\.lock.*belongs to uid {uid}"):
        fileio.write_generated(out, {"a.c": "int a;\n"})
    assert not out.exists()


def test_a_lock_on_a_file_its_last_holder_removed_is_not_held(tmp_path, monkeypatch):
    """The holder removes the lock file, then closes it.  A waiter that opened the file just
    before the removal then gets the flock of a file nobody else will open again: taking
    that for the lock lets a writer that opens the name anew run at the same time."""
    out, lock = tmp_path / "out", tmp_path / ".out.lock"
    real_open, opened = os.open, []

    def open_then_removed(path, flags, *args, **kwargs):
        fd = real_open(path, flags, *args, **kwargs)
        if os.fspath(path) == str(lock) and not opened:
            opened.append(fd)
            os.unlink(lock)                     # the last holder's release, just then,
            os.close(real_open(lock, os.O_CREAT | os.O_WRONLY, 0o666))   # and a new file
        return fd

    monkeypatch.setattr(os, "open", open_then_removed)
    with fileio.generation_lock(out, wait=5):
        monkeypatch.undo()
        assert opened, "the lock was not opened through os.open"
        with pytest.raises(OutputBusyError):
            with fileio.generation_lock(out, wait=0):
                pass


# ------------------------------------------------------------------ folders that cannot move
def test_a_mount_point_gets_its_contents_swapped(tmp_path, monkeypatch):
    """A Docker volume or a tmpfs cannot be renamed: its files are replaced one by one, the
    user's stay (same inode), an edited one is still refused, and a killed content swap is
    finished by the next run."""
    out = tmp_path / "out"
    write(out, "one", n=4)
    (out / "notes.txt").write_text("mine\n")
    ino = os.stat(out / "notes.txt").st_ino
    real = os.path.ismount
    monkeypatch.setattr(os.path, "ismount", lambda p: os.fspath(p) == str(out) or real(p))
    done = write(out, "two", n=3)
    assert generations(out) == {"two"} and not (out / "f03.c").exists()
    assert done.removed == [out / "f03.c"] and os.stat(out / "notes.txt").st_ino == ino
    assert sorted(os.listdir(out)) == [fileio.MANIFEST, "f00.c", "f01.c", "f02.c", "notes.txt"]
    (out / "f00.c").write_text("/* mine */\n")
    with pytest.raises(OutputConflictError, match=r"f00\.c \(changed since"):
        write(out, "three", n=3)
    (out / "f00.c").write_text("/* generation two, file 0 */\n" * 50)
    assert child(out, "four", n=4, kill_in="replace:3", mount=True).wait() == -signal.SIGKILL
    assert len(generations(out)) == 2 and list(out.glob(".mbgen-new-*"))    # half and half
    done = write(out, "five", n=2)
    assert generations(out) == {"five"} and sorted(os.listdir(out)) == [
        fileio.MANIFEST, "f00.c", "f01.c", "notes.txt"]
    assert not [line for line in done.remarks() if "kept" in line], done.remarks()


TMPFS = textwrap.dedent("""
    import os, subprocess, sys
    from mbgen import fileio
    out = sys.argv[1]
    os.makedirs(out)
    subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "mbgen-test", out], check=True)
    assert os.path.ismount(out)
    fileio.write_generated(out, {"a.c": "int a;\\n", "b.c": "int b;\\n"})
    open(os.path.join(out, "notes.txt"), "w").write("mine")
    fileio.write_generated(out, {"a.c": "int a2;\\n"})
    print(sorted(os.listdir(out)), open(os.path.join(out, "a.c")).read().strip())
""")


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("unshare") is None, reason="needs unshare(1)")
def test_a_real_tmpfs_mount_point_is_generated_into(tmp_path):
    """Issue 28: "Device or resource busy" -- the swap renamed the mount point itself."""
    proc = subprocess.run(["unshare", "-m", sys.executable, "-c", TMPFS, str(tmp_path / "out")],
                          capture_output=True, text=True)
    if proc.returncode != 0 and "mount" in proc.stderr and "ismount" not in proc.stderr:
        pytest.skip(f"cannot mount a tmpfs here: {proc.stderr.strip()[-200:]}")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split("]")[0] == str(
        [fileio.MANIFEST, "a.c", "notes.txt"]).rstrip("]") and "int a2;" in proc.stdout


def test_long_legal_folder_names_are_generated_into(tmp_path):
    """Issue 28: a name of 242-255 bytes left no room for ``.<name>.new-XXXXXXXX`` beside it,
    and the refusal said to choose a folder whose parent one can write."""
    for out in (tmp_path / ("x" * 255), tmp_path / ("é" * 127)):
        write(out, "one")
        write(out, "two")
        assert generations(out) == {"two"}
        assert sorted(os.listdir(tmp_path)) == [out.name]
        shutil.rmtree(out)
    for name in ("y" * 256, f"{'y' * 256}/out"):
        with pytest.raises(OutputPathError, match=r"is 256 bytes long.*at most 255.*shorter"):
            write(tmp_path / name, "one")
