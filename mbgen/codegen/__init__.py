"""Code generation: ``Equations -> Kernel -> Rendered``, the stage between the derivation
and the build.

:mod:`~mbgen.codegen.slicing` bakes a scene's fixed parameters in;
:mod:`~mbgen.codegen.outputs` turns each requested output into expressions and
:mod:`~mbgen.codegen.optimize` (with :mod:`~mbgen.codegen.cse`) into a ``Kernel``: the
functions after common-subexpression elimination.  :func:`mbgen.codegen.render.render`
prints a kernel with :mod:`~mbgen.codegen.printing` into the Jinja templates of
``templates/`` (:mod:`~mbgen.codegen.templating`), one folder per target
(:mod:`mbgen.codegen.targets`): the model's C and Python, the integrators (views of
:mod:`mbgen.integrators` in :mod:`~mbgen.codegen.integrators`), the step API, the batch
loops, the FMU and the embedding example.  :mod:`~mbgen.codegen.split` cuts a long C
function into parts that share a work array (a compiler's time stays linear in the model),
:mod:`~mbgen.codegen.solver` unrolls the mass matrix's ``L D L^T`` solve,
:mod:`~mbgen.codegen.tree_solve` factors it over a tree's structural nonzeros,
:mod:`~mbgen.codegen.pairs` writes a chain's pair products of the Jacobian as loops,
:mod:`~mbgen.codegen.header` states the header's index macros, content hash and the units of
the stack bounds (each target states its own; the C helpers are runtime routines emitted
once, :mod:`mbgen.codegen.targets.runtime`), :mod:`~mbgen.codegen.escape` escapes user text
where it lands.

Nothing here compiles or runs the code (:mod:`mbgen.build`, :mod:`mbgen.runtime`) or derives
equations (:mod:`mbgen.derivation`); the pipeline (:mod:`mbgen.pipeline`) calls the stages.

How to add a rendered part
--------------------------
1. A target (a new file set, or a section of the model's files): see "How to add a
   target" in :mod:`mbgen.codegen.targets` (its template folder ``templates/<name>/``,
   its config object in ``codegen/targets/<name>.py``, its row in ``TARGETS``).
2. An integrator: see "How to add an integrator" in :mod:`mbgen.integrators` (its method
   class and ``METHODS`` row there; here nothing but ``templates/integrators/<name>.c.j2``
   and ``templates/step/<name>.c.j2``, ``.h.j2``, chosen by the output's name; its view is
   chosen by ``implicit`` in :func:`mbgen.codegen.integrators.method_view`, its stack bound
   by ``adaptive`` / ``implicit`` in the integrators and step targets' ``stack_bounds``).
3. An output: its row in :mod:`mbgen.codegen.outputs` (the expressions) -- the templates
   print every output the same way.
4. ``tests/codegen/test_targets.py`` fails when a target's or an integrator's template
   is missing (``test_every_target_has_its_templates``,
   ``test_every_integrator_has_its_templates``); ``tests/verify/test_golden.py`` shows
   the new text of the built-in scenes (``mbgen golden --update`` after checking the
   diff); ``tests/codegen/test_codegen.py`` compiles it strictly.
"""
