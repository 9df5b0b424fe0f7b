"""Build: rendered texts to binaries, with the C compiler.

:mod:`~mbgen.build.extension` compiles a :class:`~mbgen.abi.Rendered` into a plain shared
library, cached by content hash, and opens it with cffi's ABI mode (``load``); the one
Python extension, the crossing that calls a library's functions from Python, is compiled
once per cache; the compiler runs in child processes read through pipes, so that threads
may build at once, and a source cut into parts compiles as one translation unit per core
(:mod:`~mbgen.build.units`); the compiler's answers that the flags depend on are kept in the
cache (:mod:`~mbgen.build.probes`);
:mod:`~mbgen.build.cache` keeps the folder of compiled modules private and decides
which file may be loaded (owner, mode, SHA-256 record, checked on the open file that is
then loaded); :mod:`~mbgen.build.warm` is the cache's second index, the rendered code of
an unchanged model keyed by what the user gave (its canonical form,
:mod:`~mbgen.build.canonical`), so that a warm run derives nothing; :mod:`~mbgen.build.fmu`
compiles an FMU's sources into this platform's shared library and writes the ``.fmu`` zip.
Nothing here renders code (:mod:`mbgen.codegen`) or calls a model (:mod:`mbgen.runtime`).

How to add a build
------------------
1. ``build/<product>.py``: a function from texts (``{file name: text}``, or a
   ``Rendered``) to the product, calling :func:`mbgen.build.extension.compiler` and
   raising :class:`~mbgen.errors.BuildError` with the compiler's output on failure;
   its flags as a module constant (as ``CFLAGS``, ``FMU_CFLAGS``).
2. The caller one stage up: :mod:`mbgen.pipeline` for the extension, a root module such
   as :mod:`mbgen.export` for a product made from a scene.
3. ``tests/build/test_cflags.py`` (the extension's flags and cache key),
   ``tests/build/test_cache.py`` (a damaged, planted or half-built module is never
   loaded; a full disk is a named error), ``tests/build/test_threads.py`` (threads and
   processes building at once) and
   ``tests/test_export_fmu.py`` (the FMU builds and FMPy runs it) fail when a build
   breaks; add the new product's test beside them.
"""
