"""The scripts that draw the pictures of the docs (``docs/images/``): ``python -m docs.figures``.

Each module of this package draws the figures of one page and has ``main(argv)``;
``--quick`` writes the same names into the git-ignored ``out/quick/images/`` and
``out/quick/results/`` (:mod:`benchmarks.outputs`), so that a check of the
scripts changes no tracked file. :mod:`docs.figures.__main__` lists them all.
"""
