"""Where in a pixel its anti-aliasing rays go: the sample pattern, defined once.

``render(..., samples=N)`` traces ``N`` rays per pixel through the points
``(x + 0.5 + dx_i, y + 0.5 + dy_i)`` of :func:`sample_offsets` and averages
them with equal weights: a box filter over the pixel square.

The pattern is the ``N``-point Hammersley set ``(i / N, phi_2(i))``
(``phi_2`` the base-2 radical inverse) shifted by half a pixel modulo the
pixel, so that sample 0 is the pixel centre: the frame's id, depth and normal
buffers are that sample, exactly the ``samples=1`` buffers. The set is
deterministic (no seed), stratified like ``N`` rooks (one sample in each
``1/N``-wide column), and for ``N`` a power of two a ``(0, m, 2)``-net: one
sample in every dyadic box of area ``1/N``. The shift (exact in binary) keeps
those properties, but puts the samples' centroid ``1/(2N)`` pixel up and
left of the centre for even ``N`` (the price of keeping the centre itself).
"""

from __future__ import annotations

import numpy as np

from .validate import as_int

__all__ = ["MAX_SAMPLES", "check_samples", "sample_offsets"]

MAX_SAMPLES = 1024  # rays per pixel: a bound on the work of one frame, far past visible convergence


def check_samples(value, name: str = "samples") -> int:
    """``value`` as a number of rays per pixel: an integer (NumPy's too) in ``[1, MAX_SAMPLES]``.

    Raises
    ------
    TypeError, ValueError
        Naming ``name``.
    """
    return as_int(value, name, minimum=1, maximum=MAX_SAMPLES)


def _radical_inverse2(i: np.ndarray) -> np.ndarray:
    """Base-2 radical inverse (van der Corput) of non-negative integers, exactly."""
    i = i.astype(np.uint64)
    out = np.zeros(i.shape, np.float64)
    scale = 0.5
    while np.any(i):
        out += scale * (i & np.uint64(1))
        i = i >> np.uint64(1)
        scale *= 0.5
    return out


def sample_offsets(n: int) -> np.ndarray:
    """The ``n`` sub-pixel offsets of the anti-aliasing pattern.

    Parameters
    ----------
    n : int
        Rays per pixel, ``1 <= n <= MAX_SAMPLES``.

    Returns
    -------
    (n, 2) float64
        ``(dx, dy)`` in pixels (``y`` down), each in ``[-0.5, 0.5)``; row 0
        is ``(0, 0)``, the pixel centre.
    """
    n = check_samples(n, "n")
    i = np.arange(n)
    x = np.mod(i / n + 0.5, 1.0)
    y = np.mod(_radical_inverse2(i) + 0.5, 1.0)
    return np.stack([x - 0.5, y - 0.5], axis=1)
