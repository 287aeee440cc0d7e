"""raycast_shade's benchmark suite: ``python -m benchmarks [--quick]``.

Each benchmark is a module here with ``run(quick: bool)`` or ``main(argv)``;
:mod:`benchmarks.__main__` runs them in turn, writes CSVs under
``benchmarks/results/`` and regenerates ``docs/benchmarks.md``. Quick runs
write into git-ignored ``quick/`` folders instead (:mod:`benchmarks.outputs`).
"""
