"""The built-in scenes: one module per scene, each written as a user writes a scene file.

A scene module defines ``scene(**options) -> Scene`` (a model, its parameter
values, initial state, outputs; see :mod:`mbgen.model.scene`) and imports only
the public ``mbgen`` names, as a user's own file would.  Built-in scenes are
found by module name (:func:`mbgen.model.scene.builtin_names`, ``mbgen scenes``);
their generated code is checked in under ``generated/<scene>/``.

How to add a built-in scene
---------------------------
1. ``mbgen/scenes/<name>.py``: a module docstring saying what the model is (and
   where its equations come from), and ``def scene(...) -> Scene`` whose options
   all have defaults.
2. ``mbgen golden --update`` (from the repository root) writes
   ``generated/<name>/``; commit it.  ``tests/verify/test_golden.py``
   (``test_every_builtin_scene_has_a_folder``) fails until it exists.
3. The tests that loop over every built-in scene then include it
   (``tests/verify/test_golden.py``, ``tests/codegen/test_codegen.py``,
   ``tests/build/test_embedding.py``, ``tests/runtime/test_jacobian.py``,
   ``tests/scenes/test_physics.py``, ``tests/derivation/test_newton_euler.py``); a scene
   too slow for the default run goes into ``HEAVY`` in ``tests/support/heavy.py``
   (marked slow, never skipped).
4. List it in ``docs/tutorials/scenes.md`` (``mbgen scenes`` and the site's gallery show
   it by themselves).
"""
