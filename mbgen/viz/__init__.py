"""Pictures: PNG plots of a simulation (:mod:`~mbgen.viz.plots`) and 3-D animations of a
scene (:mod:`~mbgen.viz.animate`).

matplotlib is an optional extra (``pip install 'mbgen[plot]'``): it is imported inside
the functions that draw, after :func:`~mbgen.viz.plots.require_matplotlib` (which
raises :class:`~mbgen.errors.MissingExtraError` naming the extra), never at a module's
top, so generating, checking and simulating do not need it.

How to add a picture
--------------------
1. A function in ``mbgen/viz/plots.py`` (or a new ``mbgen/viz/<name>.py``) that draws
   on :func:`~mbgen.viz.plots.figure` and writes with :func:`~mbgen.viz.plots.save_png`
   (atomically), importing matplotlib only inside it
   (``tests/viz/test_pictures.py::test_generate_check_and_simulate_do_not_import_matplotlib``
   fails when ``import mbgen`` pulls matplotlib in).
2. Where users reach it: its name in ``mbgen/__init__.py`` (and ``__all__``), and/or an
   option in the ``configure`` of the command that draws it (e.g. ``--plot`` in
   ``mbgen/cli/simulate.py``).
3. A test in ``tests/viz/test_pictures.py`` that writes it into ``tmp_path`` and checks the
   file (the PNG signature, what each panel shows).
"""
