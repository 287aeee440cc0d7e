"""The hit buffer: what visibility hands to shading.

Both the ray caster and the reference rasterizer emit this buffer, so every
shading kernel serves both, and any difference between their images comes
from visibility alone. A fragment shader needs only the primitive and its
barycentrics (tinyrenderer's contract); ``t`` feeds the depth buffer.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["HitBuffer"]


@dataclass(frozen=True, eq=False)
class HitBuffer:
    """Per-pixel visibility.

    The hit point is ``(1 - u - v) p0 + u p1 + v p2`` for the triangle's
    vertices ``p0, p1, p2`` (Embree's convention, the lecture's ``mu1, mu2``).

    Attributes
    ----------
    prim : (H, W) int32
        Triangle index within its model, ``-1`` where nothing was hit.
    geom : (H, W) int32
        Model index in the scene, ``-1`` where nothing was hit.
    u, v : (H, W) float32
        Barycentrics of vertices 1 and 2; zero where nothing was hit.
    t : (H, W) float32
        Distance from the camera along the unit ray (orthographic: from the
        image plane); ``inf`` where nothing was hit.
    """

    prim: np.ndarray
    geom: np.ndarray
    u: np.ndarray
    v: np.ndarray
    t: np.ndarray

    @classmethod
    def empty(cls, height: int, width: int) -> "HitBuffer":
        """A buffer of misses, ready for a caster or rasterizer to fill."""
        return cls(
            prim=np.full((height, width), -1, np.int32),
            geom=np.full((height, width), -1, np.int32),
            u=np.zeros((height, width), np.float32),
            v=np.zeros((height, width), np.float32),
            t=np.full((height, width), np.inf, np.float32),
        )

    @property
    def shape(self):
        return self.prim.shape

    @property
    def mask(self) -> np.ndarray:
        """(H, W) bool, True where a triangle was hit."""
        return self.prim >= 0
