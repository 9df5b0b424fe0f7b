"""Benchmarks: what mbgen costs and how fast its code runs, against sympy and Pinocchio.

Nothing here is imported by the library; ``mbgen bench WHAT`` (:mod:`mbgen.cli.bench`) runs
them.  :mod:`~mbgen.bench.arm` (the spatial arm, mbgen vs sympy vs Pinocchio; its Pinocchio
side in :mod:`~mbgen.bench.arm_pinocchio`), :mod:`~mbgen.bench.constraints` (the Whipple
bicycle and the four-bar), :mod:`~mbgen.bench.robot` (one robot file: mbgen vs Pinocchio vs
MuJoCo; its peers in :mod:`~mbgen.bench.robot_peers`), :mod:`~mbgen.bench.interop` (an
IPOPT NLP with mbgen's CasADi external vs CasADi's SX; JAX vs C batch vs MJX throughput),
:mod:`~mbgen.bench.scaling` (the
n-link pendulum, mbgen vs sympy), :mod:`~mbgen.bench.stages` (every pipeline stage of a
scene under a budget) and :mod:`~mbgen.bench.targets` (batch RHS, ensembles, FMU round trip:
``python -m mbgen.bench.targets``) and :mod:`~mbgen.bench.crossing` (a call of the arm's RHS
from Python, through the C entry and through cffi, against ``pin.aba``: ``python -m
mbgen.bench.crossing``).  :mod:`~mbgen.bench.timing` times calls from Python and in a C
loop; :mod:`~mbgen.bench.children` runs a side in a child process under a time budget and a
memory cap.

How to add a benchmark
----------------------
1. ``mbgen/bench/<name>.py``: the measurement (rows of numbers; mbgen's generation
   through :func:`mbgen.pipeline.run` with ``timer=``
   :func:`~mbgen.bench.timing.pipeline_timer`, not a sequence of stages of its own; only
   :mod:`~mbgen.bench.stages` has one, to time each output's CSE alone), a ``format_*``
   table and the writers (CSV with :func:`mbgen.fileio.write_atomic`, PNG with
   :func:`mbgen.viz.plots.figure` and :func:`~mbgen.viz.plots.save_png`).  A side that
   may run away runs in a child process: ``children.run_json_child(["-m",
   "mbgen.bench.<name>", ...])`` and ``if __name__ == "__main__":`` at the module's end
   (``tests/bench/test_scaling.py::test_child_process_entry_points_exist`` fails when the module
   or its ``__main__`` block is missing).
2. Its runner ``bench_<name>(args)`` and row in ``BENCHMARKS`` of
   ``mbgen/cli/bench.py``, any new option in its ``configure``, and its name in the
   ``bench`` help line of ``COMMANDS`` in ``mbgen/cli/__init__.py``
   (``tests/cli/test_cli.py::test_every_benchmark_is_named_in_the_help`` fails otherwise).
3. ``tests/bench/test_<name>.py`` (named after its module): a
   small run whose columns are all filled; nothing timed is asserted.
"""
