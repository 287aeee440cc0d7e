"""Flat shading under the lecture's convention and under the APIs' provoking vertex."""

from __future__ import annotations

import numpy as np

from ..visibility.interpolation import provoking_vertex
from .shade import shade

__all__ = ["shade_flat", "FLAT_CONVENTIONS"]

FLAT_CONVENTIONS = ("centre", "first", "last")


def shade_flat(scene, camera, hits, convention: str = "centre") -> np.ndarray:
    """Flat shading under either convention.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    hits : HitBuffer
    convention : {"centre", "first", "last"}
        ``"centre"``: the lecture's, one shade per polygon at its centre with
        its true normal (``shade(..., "flat")``). ``"last"`` / ``"first"``:
        OpenGL's / Direct3D's provoking vertex, the Gouraud shade of that
        vertex (its averaged normal) over the whole triangle.

    Returns
    -------
    (H, W, 3) float32
        Linear RGB, as :func:`raycast_shade.shading.shade`.
    """
    if convention not in FLAT_CONVENTIONS:
        raise ValueError(f"convention: expected one of {list(FLAT_CONVENTIONS)}, got {convention!r}")
    if convention == "centre":
        return shade(scene, camera, hits, "flat")
    return shade(scene, camera, provoking_vertex(hits, convention), "gouraud")
