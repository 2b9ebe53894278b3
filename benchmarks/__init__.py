"""Benchmark harness: tension-distribution problems x backends x settings on fixed scenarios.

``python -m benchmarks`` runs the default suite and writes the report into
``benchmarks/results/``; ``python -m benchmarks --help`` lists the commands.
Modules: :mod:`benchmarks.scenarios` (test sets), :mod:`benchmarks.metrics` (pure
metrics), :mod:`benchmarks.harness` (runner and results store) and
:mod:`benchmarks.report` (Markdown and plots).
"""
