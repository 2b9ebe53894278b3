"""Benchmark harness: tension-distribution problems x backends x settings on fixed scenarios.

``python -m benchmarks`` runs the default suite and writes the report into
``benchmarks/results/``; ``python -m benchmarks --help`` lists the commands
(``run``, ``report``, ``list``, ``study``). Modules: :mod:`benchmarks.scenarios` (test
sets), :mod:`benchmarks.plan` (the matrix), :mod:`benchmarks.runner` (one cell),
:mod:`benchmarks.isolation` (forked workers with a hard time limit),
:mod:`benchmarks.distributed` (process pools and Dask clusters),
:mod:`benchmarks.store` (the results table), :mod:`benchmarks.harness` (a run, composed
of those), :mod:`benchmarks.metrics` (pure metrics), :mod:`benchmarks.report` (Markdown
and plots), :mod:`benchmarks.studies` and :mod:`benchmarks.study_points` (parameter
studies of the reference robot) and :mod:`benchmarks.cli` (the command line).
"""
