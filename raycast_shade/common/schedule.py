"""A balanced order for the static parallel loops over image rows.

Numba hands each thread of a ``prange`` one contiguous share of the
iterations. Over image rows that is unbalanced whenever the expensive part
of a scene sits in one half of the picture: a floor below an empty sky, a
mirror at the top (measured: the mirror rays of the surfaces benchmark ran
1.07x faster on two threads than on one; Phong shading of that scene 1.46x).
Numba's ``parallel_chunksize`` did not change that with the OpenMP layer
used here. So the kernels walk blocks of rows in a permuted order,
``t -> (t * step) mod n`` with ``step`` coprime to ``n`` and close to
``n / phi`` (the golden ratio): any run of consecutive ``t``, hence each
thread's share, covers the whole image evenly, while the rows inside a block
stay consecutive for the caches.
"""

from __future__ import annotations

import math

from .inline import inline_jit

__all__ = ["spread_step", "BLOCK_ROWS"]

BLOCK_ROWS = 8  # image rows (or ray chunks' worth of work) visited together


@inline_jit()  # called by kernels only: IR for them, no wrappers (common/inline.py)
def spread_step(n):
    """A step coprime with ``n`` near ``n / phi``; 1 for ``n <= 2``.

    ``t -> (t * step) % n`` is then a permutation of ``0 .. n - 1``."""
    if n <= 2:
        return 1
    s = max(1, int(n * 0.6180339887498949))
    while math.gcd(s, n) != 1:
        s += 1
    return s
