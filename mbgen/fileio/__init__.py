"""Writing files so that a reader never sees half of one, and folders of generated files so
that a reader never sees half of a generation and nothing the user changed is lost.

:mod:`~mbgen.fileio.files`: single files, written aside and renamed (:func:`write_atomic`,
:func:`atomic_path`), and the plain names and fingerprints the rest is made of;
:mod:`~mbgen.fileio.lock`: the lock of an output folder (one generation at a time, never
through a link); :mod:`~mbgen.fileio.generations`: a whole generation of files
(:func:`write_generated`: lock, recover, plan, write aside, swap).

How to add a way of writing
---------------------------
1. A function in the module of its kind (a single file: ``files``; a set of files that
   must appear together: ``generations``), writing aside and renaming, never in place.
2. Re-export it here if callers outside ``fileio`` use it; callers import from
   ``mbgen.fileio``.
3. ``tests/test_fileio.py`` kills a writer (SIGKILL, in a child process) at every step and
   checks what a reader and the next run see; add the new function's kills there.
"""

from .files import atomic_path, digest, keep_mode, plain_name, write_atomic, write_files
from .generations import MANIFEST, Generation, write_generated
from .lock import LOCK_WAIT, generation_lock

__all__ = ["MANIFEST", "LOCK_WAIT", "Generation", "keep_mode", "atomic_path", "write_atomic",
           "write_files", "plain_name", "digest", "write_generated", "generation_lock"]
