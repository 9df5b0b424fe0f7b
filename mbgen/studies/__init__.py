"""Studies: many runs of one scene, summarised in one report.

:mod:`~mbgen.studies.ensemble`
    Parameter studies and Monte Carlo runs, serially or on Dask (``mbgen.ensemble``,
    ``mbgen sweep``).
:mod:`~mbgen.studies.workprecision`
    Error against run time of every integrator and back end (``mbgen workprecision``).
:mod:`~mbgen.studies.cluster`
    Chunks of a study on Dask: each chunk's result or its failure, bounded retries, a
    scheduler's address tried first.

A study runs the pipeline and the compiled model (it stands above :mod:`mbgen.verify`
and :mod:`mbgen.viz`, whose figures it may draw); failed runs are rows of its result,
never exceptions that stop it.

How to add a study
------------------
1. ``studies/<study>.py`` (a package when it has several parts): a function from a
   scene and its options to a result (a table or a report) that records every failed
   run with its reason.
2. Its name in :mod:`mbgen` (``mbgen/__init__.py``) when it is public, and its command
   in :mod:`mbgen.cli`.
3. ``tests/studies/test_<study>.py``: results equal to single runs and failures recorded, as
   ``tests/studies/test_ensemble.py`` (``test_dask_gives_the_serial_results_bit_for_bit``,
   ``test_failed_members_are_recorded_not_fatal``) and ``tests/studies/test_workprecision.py``
   (``test_every_point_ran``, ``test_failures_are_recorded_not_raised``).
"""
