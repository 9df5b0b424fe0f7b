"""Folders of generated files, so that a reader never sees half of a generation and nothing
the user changed is lost.

A generation (:func:`write_generated`, what ``mbgen generate`` and ``mbgen demo`` write)
follows git's and pip's habits -- a lock, write aside, rename:

1. **Lock** the folder (:func:`~mbgen.fileio.lock.generation_lock`): one generation at a
   time, and the lock file is never a link.
2. **Recover** (:func:`_recover`) what a killed run left: ``.<name>.new-XXXXXXXX`` (a
   generation written aside, or after the swap the one it replaced),
   ``.<name>.old-XXXXXXXX`` (the replaced one of the two-rename swap, put back when the
   folder is missing) and, inside the folder, ``.mbgen-new-XXXXXXXX`` (a content swap's,
   step 5).  Each is deleted entry by entry, only where nothing is lost (:func:`_discard`):
   a file whose bytes are the live generation's, or whose SHA-256 one of the manifests
   there records, is mbgen's own and reproducible; what is found only there stays, and the
   run says so.  (A name too long for these 14 more bytes is shortened in them:
   :func:`~mbgen.fileio.lock.sibling_stem`.)
3. **Plan** (:func:`_plan`) by the manifest :data:`MANIFEST`, the SHA-256 of each file
   mbgen wrote (and those of a killed run's manifests, step 2).  A file that already holds
   its new text stays as it is (same inode and time: ``make`` rebuilds nothing); one mbgen
   wrote and nobody changed is replaced, or removed when no longer generated.  One the
   user changed, one mbgen did not write, or one an older mbgen listed by name only (it
   cannot tell) is never overwritten (``OutputConflictError`` unless ``overwrite``) and
   never removed (kept, and said so).
4. **Write aside** (:func:`_fill`) into a fresh ``.<name>.new-XXXXXXXX``: the manifest, the
   new files, and every other entry of the old folder by hard link (folders and links
   recreated).  An entry that cannot be carried (a named pipe, a refused hard link) stops
   the generation before anything in the folder changed.
5. **Swap** (:func:`_swap`): Linux ``renameat2(RENAME_EXCHANGE)`` exchanges the folders in
   one step; elsewhere two renames leave the name briefly absent -- it shows the old
   generation, nothing, or the new one, never a mixture.  The old one goes as in step 2,
   its manifest last (while it is there, it vouches for what is left).  A folder that
   cannot be renamed -- a mount point (a Docker volume, a tmpfs): ``EBUSY`` -- has its
   contents swapped instead (:func:`_swap_contents`): the new files are written into a
   folder inside it, then renamed over the old ones one by one, the manifest last.

A process killed anywhere (SIGKILL included) leaves the old generation or the new one whole
(a reader that opens files by path across the swap may read one before, one after), and the
next run leaves nothing of it behind.  In a folder that cannot be renamed each file is
replaced whole, but a reader (or a killed run) may see files of both generations; the next
run finishes the job.  A shell whose working folder is the output folder is left in the
replaced one (``cd .`` enters the new one).  The parent folder must be writable.  Nothing
is flushed to disk (``fsync``), as git by default: a power cut is not covered.
"""

from __future__ import annotations

import ctypes
import errno
import json
import os
import re
import secrets
import shutil
import stat
import sys
from collections.abc import Mapping
from contextlib import suppress
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

from ..errors import OutputConflictError, OutputPathError
from .files import digest, fingerprint, is_plain, keep_mode, plain_name
from .lock import LOCK_WAIT, generation_lock, output_folder, sibling_stem

#: File listing what mbgen wrote into an output folder, with each file's content hash
#: (JSON: ``{"files": {name: "sha256:<hex>"}}``; an older mbgen wrote ``{"files": [names]}``).
MANIFEST = ".mbgen-manifest.json"

#: A content swap's folder inside the output folder (step 5).
_INSIDE = re.compile(r"\.mbgen-new-[0-9a-f]{8}\Z")


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
    expendable: dict[str, set[str]]  # {name: fingerprints} of old entries the new one drops
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
    target = output_folder(shown)
    with generation_lock(target, wait):
        notes, known = _recover(target)
        plan = _plan(target, data, overwrite, known)
        if not plan.unchanged and os.path.ismount(target):   # cannot be renamed
            _swap_contents(target, data, plan)
        elif not plan.unchanged:
            notes += _swap_folder(target, shown, data, plan)
    return Generation(changed=[shown / n for n in plan.write],
                      removed=[shown / n for n in plan.removed],
                      kept={shown / n: why for n, why in plan.kept.items()}, notes=notes)


def _swap_folder(target: Path, shown: Path, data: Mapping[str, bytes], plan: _Plan) -> list[str]:
    """Steps 4 and 5 for a folder that can be renamed (else :func:`_swap_contents`); the
    notes on what of the old generation stays."""
    cwd = None
    with suppress(OSError):
        cwd = os.getcwd()
    aside = _fill(target, data, plan)
    try:
        old = _swap(aside, target)
    except OSError as exc:
        shutil.rmtree(aside, ignore_errors=True)
        if exc.errno == errno.EBUSY:            # a mount point ismount did not see (a bind)
            _swap_contents(target, data, plan)
            return []
        raise OutputPathError(f"cannot put the new generation in place of "
                              f"{str(shown)!r}: {exc.strerror or exc}") from None
    if cwd is not None and (cwd + os.sep).startswith(str(target) + os.sep):
        os.chdir(cwd)
    return [] if old is None else _left_note(old, _discard(old, target, plan.expendable))


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
            for n, d in records.items() if is_plain(n)}


def _plan(folder: Path, data: Mapping[str, bytes], overwrite: bool,
          known: Mapping[str, set[str]]) -> _Plan:
    """Decide, file by file, what the new generation writes, keeps, removes and carries.

    ``previous`` holds, per name, the fingerprints mbgen wrote there: the manifest's, and
    those a killed run's manifests record (``known``, from :func:`_recover`) where the file
    holds one of them -- its bytes are mbgen's, whichever run wrote them."""
    entries = set(os.listdir(folder)) if folder.is_dir() else set()
    previous = {name: {fp} if fp else set()
                for name, fp in (_manifest(folder) if folder.is_dir() else {}).items()}
    for name in known.keys() & entries:
        if fingerprint(folder / name) in known[name]:
            previous.setdefault(name, set()).update(known[name])
    write, expendable, conflicts, folders = [], {}, [], []
    for name in sorted(data):
        if name not in entries:
            write.append(name)
            continue
        now = fingerprint(folder / name)
        if now == "sha256:" + digest(data[name]):
            continue                                   # already this text: carried as it is
        if now is None:
            folders.append(name)
        elif now in previous.get(name, ()) or overwrite:
            write.append(name)
            expendable[name] = {now}
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
        now = fingerprint(folder / name)
        if now in previous[name]:
            removed.append(name)
            expendable[name] = {now}
        else:
            kept[name] = _whose(name, previous)
    manifest = (json.dumps({"files": {n: "sha256:" + digest(b) for n, b in sorted(data.items())}},
                           indent=1) + "\n").encode()
    carry = sorted(entries - set(write) - set(removed) - {MANIFEST})
    unchanged = bool(entries) and not write and not removed and \
        (folder / MANIFEST).is_file() and (folder / MANIFEST).read_bytes() == manifest
    return _Plan(write, removed, kept, expendable, carry, manifest, unchanged)


def _whose(name: str, previous: Mapping[str, set[str]]) -> str:
    return ("mbgen did not write it" if name not in previous else "changed since mbgen wrote it"
            if previous[name] else "cannot tell whether it was changed: an older mbgen wrote it")


def _fill(target: Path, data: Mapping[str, bytes], plan: _Plan) -> Path:
    """Write the new generation into a fresh folder beside ``target``; returns its path."""
    aside = target.parent / f".{sibling_stem(target)}.new-{secrets.token_hex(4)}"
    try:
        os.mkdir(aside)                 # FileExistsError at odds of 2**-32: run again
    except OSError as exc:
        raise OutputPathError(f"cannot write beside {str(target)!r}: {exc.strerror or exc}; "
                              f"choose a folder whose parent you can write") from None
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
    old = aside.with_name(aside.name[:-13] + ".old-" + aside.name[-8:])    # .new-XXXXXXXX
    os.rename(target, old)
    os.rename(aside, target)             # between the two, the folder is absent
    return old


def _swap_contents(target: Path, data: Mapping[str, bytes], plan: _Plan) -> None:
    """Step 5 for a folder that cannot be renamed (a mount point): the new files and the
    manifest are written into ``target/.mbgen-new-XXXXXXXX`` (the manifest first: it vouches
    for them), then renamed over their names one by one, the files no longer generated are
    removed, the manifest goes last.  Each file is replaced whole; a run killed in between
    leaves files of both generations and that folder, whose manifest tells the next run
    (:func:`_recover`, :func:`_plan`) which of them are mbgen's."""
    inside = target / f".mbgen-new-{secrets.token_hex(4)}"
    try:
        os.mkdir(inside, 0o700)
        try:
            (inside / MANIFEST).write_bytes(plan.manifest)
            keep_mode(target / MANIFEST, inside / MANIFEST)
            for name in plan.write:
                (inside / name).write_bytes(data[name])
                keep_mode(target / name, inside / name)
        except BaseException:
            shutil.rmtree(inside, ignore_errors=True)
            raise
        for name in plan.write:
            os.replace(inside / name, target / name)
        for name in plan.removed:
            with suppress(FileNotFoundError):
                os.unlink(target / name)
        os.replace(inside / MANIFEST, target / MANIFEST)
        os.rmdir(inside)
    except OSError as exc:
        raise OutputPathError(f"cannot write into {str(target)!r}: {exc.strerror or exc}") \
            from None


def _recover(target: Path) -> tuple[list[str], dict[str, set[str]]]:
    """Restore or remove what a killed generation left (under the lock): the folders beside
    ``target`` and the content swap's inside it (see the module docstring, step 2).

    Returns the notes for the user and ``known``: ``{name: fingerprints}`` that the left
    folders' manifests record, gathered before any is removed.  A file found there whose
    fingerprint one of them records (or the live manifest does, or whose bytes the live
    file has) is mbgen's own and goes; a killed run's manifest is removed last, so it is
    there as long as anything it vouches for is."""
    pattern = re.compile(rf"\.{re.escape(sibling_stem(target))}\.(new|old)-[0-9a-f]{{8}}\Z")
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
    if target.is_dir():
        left += [p for p in sorted(target.iterdir())
                 if _INSIDE.match(p.name) and p.is_dir() and not p.is_symlink()]
    known: dict[str, set[str]] = {}
    for path in [target, *left]:
        try:
            records = _manifest(path) if path.is_dir() else {}
        except OutputPathError:         # killed while writing it: vouches for nothing
            records = {}
        for name, fp in records.items():
            if fp:
                known.setdefault(name, set()).add(fp)
    for path in left:
        notes += _left_note(path, _discard(path, target, known)) or [
            f"{path}  (removed: left by a generation that was stopped)"]
    return notes, known


def _left_note(path: Path, files: list[str]) -> list[str]:
    return [f"{path}  (kept: it holds {', '.join(files)}, found nowhere else; move what you "
            f"need out of it, then delete it)"] if files else []


def _discard(old: Path, live: Path, expendable: Mapping[str, set[str]],
             rel: str = "") -> list[str]:
    """Delete the folder ``old`` entry by entry, each only when nothing is lost: the same
    entry is in ``live`` (:func:`_same`), it is the manifest, or ``expendable`` records its
    fingerprint (a file mbgen wrote and nobody changed, or one replaced on purpose).
    The manifest goes last: a run killed meanwhile leaves it to vouch for the rest.
    Returns the entries left (relative paths); ``old`` is removed when none is."""
    left = []
    folder = old / rel
    for name in sorted(os.listdir(folder), key=lambda n: (rel + n == MANIFEST, n)):
        path, key = folder / name, rel + name
        try:
            if path.is_dir() and not path.is_symlink():
                os.chmod(path, stat.S_IMODE(os.lstat(path).st_mode) | stat.S_IRWXU)
                left += _discard(old, live, expendable, key + "/")
            elif key == MANIFEST or _same(path, live / key) or \
                    fingerprint(path) in expendable.get(key, ()):
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
        (fingerprint(path) or "-") == fingerprint(twin)

