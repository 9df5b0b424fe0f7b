"""Writing files so that a reader never sees half of one, and folders of generated files so
that a reader never sees half of a generation and nothing the user changed is lost.

Single files (:func:`write_atomic`, :func:`atomic_path`): written to a temporary beside
the file, then renamed over it; an interrupted write leaves the old file (or nothing).  New
files get 0666 minus the umask, replaced ones keep their mode (:func:`keep_mode`).

Generations (:func:`write_generated`, what ``mbgen generate`` and ``mbgen demo`` write)
follow git's and pip's habits -- a lock, write aside, rename:

1. **Lock** ``<parent>/.<name>.lock`` with ``fcntl.flock`` (:func:`generation_lock`); the
   kernel releases it when its process ends, however it ends.  A second generation into
   the folder waits up to :data:`LOCK_WAIT` s, then raises ``OutputBusyError``.  Without
   ``fcntl`` (Windows) the file is created with ``O_CREAT | O_EXCL``; a killed run leaves
   it there, and the refusal names it for the user to delete.
2. **Recover** (:func:`_recover`) what a killed run left: ``.<name>.new-XXXXXXXX`` (a
   generation written aside, or after the swap the one it replaced) and
   ``.<name>.old-XXXXXXXX`` (the replaced one of the two-rename swap, put back when the
   folder is missing).  Each is deleted entry by entry, only where nothing is lost
   (:func:`_discard`); what is found only there stays, and the run says so.
3. **Plan** (:func:`_plan`) by the manifest :data:`MANIFEST`, the SHA-256 of each file
   mbgen wrote.  A file that already holds its new text stays as it is (same inode and
   time: ``make`` rebuilds nothing); one mbgen wrote and nobody changed is replaced, or
   removed when no longer generated.  One the user changed, one mbgen did not write, or
   one an older mbgen listed by name only (it cannot tell) is never overwritten
   (``OutputConflictError`` unless ``overwrite``) and never removed (kept, and said so).
4. **Write aside** (:func:`_fill`) into a fresh ``.<name>.new-XXXXXXXX``: the manifest, the
   new files, and every other entry of the old folder by hard link (folders and links
   recreated).  An entry that cannot be carried (a named pipe, a refused hard link) stops
   the generation before anything in the folder changed.
5. **Swap** (:func:`_swap`): Linux ``renameat2(RENAME_EXCHANGE)`` exchanges the folders in
   one step; elsewhere two renames leave the name briefly absent -- it shows the old
   generation, nothing, or the new one, never a mixture.  The old one goes as in step 2.

A process killed anywhere (SIGKILL included) leaves the old generation or the new one whole
(a reader that opens files by path across the swap may read one before, one after).  A
shell whose working folder is the output folder is left in the replaced one (``cd .``
enters the new one).  The parent folder must be writable.  Nothing is flushed to disk
(``fsync``), as git by default: a power cut is not covered.
"""

from __future__ import annotations

import ctypes
import errno
import hashlib
import json
import os
import re
import secrets
import shutil
import stat
import sys
import time
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Iterator, Mapping

try:
    import fcntl
except ImportError:                                        # Windows
    fcntl = None

from .errors import OutputBusyError, OutputConflictError, OutputPathError, SceneError

#: File listing what mbgen wrote into an output folder, with each file's content hash
#: (JSON: ``{"files": {name: "sha256:<hex>"}}``; an older mbgen wrote ``{"files": [names]}``).
MANIFEST = ".mbgen-manifest.json"

#: Seconds a generation waits for another one writing the same folder before it refuses.
LOCK_WAIT = 30.0

_PLAIN = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,127}\Z")


# ------------------------------------------------------------------ single files
def keep_mode(path: Path, new: Path) -> None:
    """Give ``new`` the mode of the file at ``path`` that it replaces, if any.  A new file keeps
    the 0666 minus umask it was created with: the umask is never set to be read (``os.umask``
    is process-wide, and another thread may be creating files meanwhile)."""
    with suppress(FileNotFoundError):
        os.chmod(new, stat.S_IMODE(os.stat(path).st_mode))


def _new_temp(path: Path) -> Path:
    """A new empty ``.<name>.<random>.tmp`` beside ``path``, 0666 minus the umask."""
    while True:
        tmp = path.parent / f".{path.name}.{secrets.token_hex(4)}.tmp"
        with suppress(FileExistsError):                  # odds 2**-32: draw again
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            return tmp


@contextmanager
def atomic_path(path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it replaces ``path``, else it is removed."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _new_temp(path)
    try:
        yield tmp
        keep_mode(path, tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_atomic(path, text: str) -> bool:
    """Write ``text`` to ``path`` atomically; skip (return False) when unchanged."""
    path = Path(path)
    if path.exists() and path.read_text(encoding="utf-8") == text:
        return False
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8", newline="\n")
    return True


def write_files(folder, files: Mapping[str, str]) -> list[Path]:
    """Write every ``{name: text}`` into ``folder`` atomically; return the paths that changed."""
    folder = Path(folder)
    return [folder / n for n, text in sorted(files.items()) if write_atomic(folder / n, text)]


def plain_name(name: str, what: str = "file name") -> str:
    """``name`` if it is a plain file name (no folder part, no ``..``), else a SceneError."""
    if not isinstance(name, str) or not _PLAIN.match(name) or ".." in name:
        raise SceneError(f"{what} {name!r} is not a plain file name (letters, digits, '_', '.', "
                         f"'-'; no folders, at most 128 characters)")
    return name


def digest(data: bytes) -> str:
    """SHA-256 of ``data`` in hex; the manifest records ``"sha256:" + digest(bytes)``."""
    return hashlib.sha256(data).hexdigest()


def _fingerprint(path: Path) -> str | None:
    """``sha256:<hex>`` of a regular file, ``link:<target>`` of a symbolic link, else None."""
    st = os.lstat(path)
    if stat.S_ISLNK(st.st_mode):
        return "link:" + os.readlink(path)
    if stat.S_ISREG(st.st_mode):
        return "sha256:" + digest(path.read_bytes())
    return None


# ------------------------------------------------------------------ generations
@dataclass(frozen=True)
class Generation:
    """What :func:`write_generated` did (paths in the folder as the caller named it): files
    written with new text, files removed (mbgen's, unchanged, no longer generated), files
    no longer generated but kept ``{path: why}``, and notes on a killed run's leftovers."""

    changed: list[Path]
    removed: list[Path]
    kept: dict[Path, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def remarks(self) -> list[str]:
        """Lines for the user beside the per-file lines: the kept files, then the notes."""
        return [f"{path}  (kept: {why}; no longer generated)"
                for path, why in self.kept.items()] + self.notes


@dataclass
class _Plan:
    write: list[str]              # generated names that get new text
    removed: list[str]            # mbgen's unchanged files no longer generated
    kept: dict[str, str]          # {name: why} no longer generated, not removed
    expendable: dict[str, str]    # {name: fingerprint} of old entries the new folder drops
    carry: list[str]              # old entries the new folder takes over (by hard link)
    manifest: bytes
    unchanged: bool               # the folder already holds this generation


def write_generated(folder, files: Mapping[str, str], *, overwrite: bool = False,
                    wait: float = LOCK_WAIT) -> Generation:
    """Write the generated ``{name: text}`` into ``folder`` as one whole generation (lock,
    plan, write aside, swap: see the module docstring).

    Parameters
    ----------
    folder : path
        Output folder; created (with its parents) when missing.
    files : {str: str}
        Plain file names (:func:`plain_name`: nothing is written outside ``folder``) and
        their texts, written as UTF-8 with ``\\n`` line ends.
    overwrite : bool
        Replace files of the user's that are in the way (``--overwrite``); files no
        longer generated are never removed unless mbgen wrote them and nobody changed them.
    wait : float
        Seconds to wait for another generation into the same folder.

    Raises
    ------
    OutputConflictError
        A file mbgen did not write, or changed since mbgen wrote it, would be replaced.
    OutputBusyError
        Another generation held the folder for longer than ``wait``.
    OutputPathError
        ``folder`` is a file, the manifest is damaged, an entry cannot be carried into the
        new generation, or writing failed (a name that is not plain: ``SceneError``).
    """
    shown = Path(folder)
    data = {plain_name(name): text.encode("utf-8") for name, text in files.items()}
    target = _target(shown)
    with generation_lock(target, wait):
        notes = _recover(target)
        plan = _plan(target, data, overwrite)
        if not plan.unchanged:
            cwd = None
            with suppress(OSError):
                cwd = os.getcwd()
            aside = _fill(target, data, plan)
            try:
                old = _swap(aside, target)
            except OSError as exc:
                shutil.rmtree(aside, ignore_errors=True)
                raise OutputPathError(f"cannot put the new generation in place of "
                                      f"{str(shown)!r}: {exc.strerror or exc}") from None
            if cwd is not None and (cwd + os.sep).startswith(str(target) + os.sep):
                os.chdir(cwd)
            if old is not None:
                notes += _left_note(old, _discard(old, target, plan.expendable))
    return Generation(changed=[shown / n for n in plan.write],
                      removed=[shown / n for n in plan.removed],
                      kept={shown / n: why for n, why in plan.kept.items()}, notes=notes)


def _target(folder: Path) -> Path:
    """The real path of the output folder (symbolic links resolved), checked."""
    if folder.exists() and not folder.is_dir():
        raise OutputPathError(f"output folder {str(folder)!r} is a file; give a folder with -o")
    try:
        target = folder.resolve()
    except FileNotFoundError:       # the working folder is gone: a generation replaced it?
        raise OutputPathError("the current folder no longer exists (did a generation replace "
                              "it?); run 'cd .' to enter the folder now at its path") from None
    if not target.name:
        raise OutputPathError(f"cannot generate into {str(folder)!r}: choose a folder below it")
    return target


@contextmanager
def generation_lock(folder, wait: float = LOCK_WAIT) -> Iterator[None]:
    """Hold the lock ``<parent>/.<name>.lock`` of the output folder ``folder`` (removed on
    release); wait up to ``wait`` seconds for another holder, then raise OutputBusyError."""
    target = _target(Path(folder))
    lock = target.parent / f".{target.name}.lock"
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd = _acquire(lock, time.monotonic() + wait, target)
    except OSError as exc:
        raise OutputPathError(f"cannot write beside {str(target)!r} (its lock {lock.name}): "
                              f"{exc.strerror or exc}; choose a folder whose parent you can "
                              f"write") from None
    try:
        yield
    finally:                       # flock: unlink first, so a waiter that opened it retries
        if fcntl is None:
            os.close(fd)
        with suppress(FileNotFoundError):
            os.unlink(lock)
        if fcntl is not None:
            os.close(fd)


def _acquire(lock: Path, deadline: float, target: Path) -> int:
    while True:
        if fcntl is None:
            with suppress(FileExistsError):
                return os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666)
        else:
            fd = os.open(lock, os.O_CREAT | os.O_RDWR, 0o666)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                held = os.fstat(fd).st_ino == os.stat(lock).st_ino   # not a removed one
            except (BlockingIOError, FileNotFoundError):
                held = False
            if held:
                return fd
            os.close(fd)
        if time.monotonic() >= deadline:
            stale = "" if fcntl else f"; if no mbgen is running, delete {lock}"
            raise OutputBusyError(f"another mbgen generation is writing {target} (it holds "
                                  f"{lock.name}); wait for it to finish and run again{stale}")
        time.sleep(0.05)


def _manifest(folder: Path) -> dict[str, str | None]:
    """``{name: fingerprint}`` of the folder's manifest; None: an older mbgen's name-only entry."""
    path = folder / MANIFEST
    if not path.is_file():
        return {}
    try:
        files = json.loads(path.read_text(encoding="utf-8"))["files"]
        records = dict.fromkeys(files) if isinstance(files, list) else dict(files)
    except (ValueError, KeyError, TypeError, OSError):
        raise OutputPathError(f"{path} is damaged; remove it (and the files mbgen generated "
                              f"there) and generate again") from None
    return {n: (d if isinstance(d, str) and d.startswith("sha256:") else None)
            for n, d in records.items() if isinstance(n, str) and _PLAIN.match(n) and ".." not in n}


def _plan(folder: Path, data: Mapping[str, bytes], overwrite: bool) -> _Plan:
    """Decide, file by file, what the new generation writes, keeps, removes and carries."""
    previous = _manifest(folder) if folder.is_dir() else {}
    entries = set(os.listdir(folder)) if folder.is_dir() else set()
    write, expendable, conflicts, folders = [], {}, [], []
    for name in sorted(data):
        if name not in entries:
            write.append(name)
            continue
        now = _fingerprint(folder / name)
        if now == "sha256:" + digest(data[name]):
            continue                                   # already this text: carried as it is
        if now is None:
            folders.append(name)
        elif now == previous.get(name) or overwrite:
            write.append(name)
            expendable[name] = now
        else:
            conflicts.append(f"{name} ({_whose(name, previous)})")
    if folders:
        raise OutputConflictError(f"{folder} holds {', '.join(folders)} where mbgen writes a "
                                  f"file; move it away or choose another output folder (-o)")
    if conflicts:
        raise OutputConflictError(f"{folder} holds files mbgen would replace: "
                                  f"{', '.join(conflicts)}; pass --overwrite to replace them, "
                                  f"or choose another output folder (-o)")
    removed, kept = [], {}
    for name in sorted((set(previous) - set(data)) & entries):
        now = _fingerprint(folder / name)
        if previous[name] is not None and now == previous[name]:
            removed.append(name)
            expendable[name] = now
        else:
            kept[name] = _whose(name, previous)
    manifest = (json.dumps({"files": {n: "sha256:" + digest(b) for n, b in sorted(data.items())}},
                           indent=1) + "\n").encode()
    carry = sorted(entries - set(write) - set(removed) - {MANIFEST})
    unchanged = bool(entries) and not write and not removed and \
        (folder / MANIFEST).is_file() and (folder / MANIFEST).read_bytes() == manifest
    return _Plan(write, removed, kept, expendable, carry, manifest, unchanged)


def _whose(name: str, previous: Mapping[str, str | None]) -> str:
    return ("mbgen did not write it" if name not in previous else "changed since mbgen wrote it"
            if previous[name] else "cannot tell whether it was changed: an older mbgen wrote it")


def _fill(target: Path, data: Mapping[str, bytes], plan: _Plan) -> Path:
    """Write the new generation into a fresh folder beside ``target``; returns its path."""
    aside = target.parent / f".{target.name}.new-{secrets.token_hex(4)}"
    os.mkdir(aside)                     # FileExistsError at odds of 2**-32: run again
    try:
        (aside / MANIFEST).write_bytes(plan.manifest)     # first: it vouches for what follows
        keep_mode(target / MANIFEST, aside / MANIFEST)
        for name in plan.write:
            (aside / name).write_bytes(data[name])
            keep_mode(target / name, aside / name)
        for name in plan.carry:
            _carry(target / name, aside / name, target)
        if target.is_dir():
            os.chmod(aside, stat.S_IMODE(os.stat(target).st_mode))
    except BaseException as exc:
        shutil.rmtree(aside, ignore_errors=True)
        if isinstance(exc, OSError):
            raise OutputPathError(f"cannot write into {str(target)!r}: {exc.strerror or exc}") \
            from None
        raise
    return aside


def _carry(src: Path, dst: Path, target: Path) -> None:
    """Recreate ``src`` at ``dst``: a file by hard link, a folder and a link anew."""
    try:
        st = os.lstat(src)
        if stat.S_ISDIR(st.st_mode):
            os.mkdir(dst, 0o700)
            for entry in sorted(os.listdir(src)):
                _carry(src / entry, dst / entry, target)
            return os.chmod(dst, stat.S_IMODE(st.st_mode))
        if stat.S_ISLNK(st.st_mode):
            return os.symlink(os.readlink(src), dst)
        if stat.S_ISREG(st.st_mode):
            return os.link(src, dst)
        reason = "it is not a file, folder or link"
    except OSError as exc:
        reason = exc.strerror or str(exc)
    raise OutputPathError(f"{src} cannot be carried into the new generation ({reason}); nothing "
                          f"was written: move it out of {target} or choose another folder (-o)")


@cache
def _renameat2():
    """glibc's ``renameat2`` (2.28+; the exchange needs Linux 3.15+), else None."""
    return getattr(ctypes.CDLL(None, use_errno=True), "renameat2", None) \
        if sys.platform == "linux" else None


def _exchange(a: Path, b: Path) -> bool:
    """Exchange the folders ``a`` and ``b`` atomically; False where the system cannot."""
    fn, at_fdcwd, rename_exchange = _renameat2(), -100, ctypes.c_uint(2)
    if fn is None:
        return False
    if fn(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _swap(aside: Path, target: Path) -> Path | None:
    """Put ``aside`` in ``target``'s place; returns where the old folder is now (or None)."""
    if not os.path.lexists(target):
        os.rename(aside, target)
        return None
    if _exchange(aside, target):
        return aside
    old = aside.with_name(aside.name.replace(".new-", ".old-"))
    os.rename(target, old)
    os.rename(aside, target)             # between the two, the folder is absent
    return old


def _recover(target: Path) -> list[str]:
    """Restore or remove what a killed generation left beside ``target`` (under the lock)."""
    pattern = re.compile(rf"\.{re.escape(target.name)}\.(new|old)-[0-9a-f]{{8}}\Z")
    left = [p for p in sorted(target.parent.iterdir())
            if pattern.match(p.name) and p.is_dir() and not p.is_symlink()]
    notes = []
    olds = [p for p in left if ".old-" in p.name]
    if olds and not os.path.lexists(target):
        old = max(olds, key=lambda p: p.stat().st_mtime)
        os.rename(old, target)
        left.remove(old)
        notes.append(f"{target}: restored from {old.name}, where a generation stopped between "
                     f"its two renames had left it")
    for path in left:
        try:
            records = _manifest(path)
        except OutputPathError:         # killed while writing it: vouches for nothing
            records = {}
        notes += _left_note(path, _discard(path, target, records)) or [
            f"{path}  (removed: left by a generation that was stopped)"]
    return notes


def _left_note(path: Path, files: list[str]) -> list[str]:
    return [f"{path}  (kept: it holds {', '.join(files)}, found nowhere else; move what you "
            f"need out of it, then delete it)"] if files else []


def _discard(old: Path, live: Path, expendable: Mapping[str, str | None],
             rel: str = "") -> list[str]:
    """Delete the folder ``old`` entry by entry, each only when nothing is lost: the same
    entry is in ``live`` (:func:`_same`), it is the manifest, or ``expendable`` records its
    fingerprint (a file mbgen wrote and nobody changed, or one replaced on purpose).
    Returns the entries left (relative paths); ``old`` is removed when none is."""
    left = []
    folder = old / rel
    for name in sorted(os.listdir(folder)):
        path, key = folder / name, rel + name
        try:
            if path.is_dir() and not path.is_symlink():
                os.chmod(path, stat.S_IMODE(os.lstat(path).st_mode) | stat.S_IRWXU)
                left += _discard(old, live, expendable, key + "/")
            elif key == MANIFEST or _same(path, live / key) or \
                    (expendable.get(key) or "-") == _fingerprint(path):
                os.unlink(path)
            else:
                left.append(key)
        except OSError:
            left.append(key)
    if not left:
        try:
            os.rmdir(folder)
        except OSError:
            left.append(rel or ".")
    return left


def _same(path: Path, twin: Path) -> bool:
    """``twin`` holds what ``path`` holds: the same inode, the same bytes or the same link."""
    try:
        a, b = os.lstat(path), os.lstat(twin)
    except OSError:
        return False
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino) or \
        (_fingerprint(path) or "-") == _fingerprint(twin)


__all__ = ["MANIFEST", "LOCK_WAIT", "Generation", "keep_mode", "atomic_path", "write_atomic",
           "write_files", "plain_name", "digest", "write_generated", "generation_lock"]
