"""Verification: is the generated code right?  Each check compares it with an independent
source and returns a report with a verdict.

:mod:`~mbgen.verify.check`
    Compiled C vs generated Python vs lambdified sympy of the unsliced equations, on
    seeded random states (``mbgen check``).
:mod:`~mbgen.verify.stress`
    The numerical stress suite: stiffness, extreme parameters, singular configurations,
    long runs and floating point against a 50-digit reference (``mbgen stress``).
:mod:`~mbgen.verify.golden`
    The checked-in ``generated/`` tree against the generator (``mbgen golden``), and the
    embedding example's trajectory computed through Python.
:mod:`~mbgen.verify.audit`
    What a scene's slice leaves out and what each cut saves (``mbgen generate --explain``).

These modules run the pipeline (:mod:`mbgen.pipeline`) and read its results; nothing
below imports them.

How to add a check
------------------
1. ``verify/<check>.py``: a function from a scene (or a pipeline result) to a report
   with a verdict, raising :class:`~mbgen.errors.CheckFailed` (or returning a failing
   report) with the reason; module docstring states the bound it checks and why it
   holds.
2. Its command in :mod:`mbgen.cli` (owned by the CLI; the exit code follows the verdict).
3. ``tests/verify/test_<check>.py``: a good model passes and an injected fault fails, as
   ``tests/verify/test_check.py`` (``test_disagreeing_on_failure_fails``) and
   ``tests/verify/test_stress.py``
   (``test_high_precision_comparison_detects_an_injected_error``) do;
   ``tests/verify/test_golden.py`` fails when ``generated/`` and the generator differ.
"""
