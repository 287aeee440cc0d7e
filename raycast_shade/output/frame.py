"""A rendered frame: the linear image, the buffers behind it, and timings."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..visibility.hits import HitBuffer
from .imagefile import write_image
from .tonemap import to_uint8

__all__ = ["Frame"]


@dataclass(frozen=True, eq=False)
class Frame:
    """The result of :func:`raycast_shade.render`.

    Attributes
    ----------
    image : (H, W, 3) float32
        Linear RGB, finite and non-negative; zero on the background.
    hits : HitBuffer
        Primitive, model, barycentrics and distance per pixel.
    shading : str or tuple of str
        The method of every model, or one per model (``shading="auto"``
        resolves to the latter).
    timings : dict of str to float
        Seconds per stage: ``build`` (packing and BVH, first frame of a scene
        only), ``cast``, ``shade``, ``total``.
    decisions : tuple of Decision
        With ``shading="auto"``: each model's method and the reason.
    tone : dict
        Default ``exposure``, ``tonemap``, ``gamma`` of :meth:`to_uint8` and
        :meth:`save` (keywords given there win): a scene file's, from
        :func:`raycast_shade.render_file`; empty from :func:`raycast_shade.render`.
    buffers : dict of str to ndarray
        The buffers asked for with ``render(..., buffers=(...))``, by name
        (:mod:`raycast_shade.output.buffers`); empty otherwise.
    """

    image: np.ndarray
    hits: HitBuffer
    shading: str
    scene: object = None
    camera: object = None
    timings: dict = field(default_factory=dict)
    decisions: tuple = ()
    tone: dict = field(default_factory=dict)
    buffers: dict = field(default_factory=dict)

    @property
    def method(self) -> np.ndarray:
        """(H, W) int8: the method that shaded each pixel: 0 flat, 1 Gouraud,
        2 Phong; -1 on the background."""
        from ..shading.kernels import resolve_methods

        codes = resolve_methods(self.scene, self.shading)
        return np.where(self.hits.geom >= 0, codes[np.maximum(self.hits.geom, 0)], -1).astype(np.int8)

    @cached_property
    def normal(self) -> np.ndarray:
        """(H, W, 3) float32 unit normal each pixel was shaded with, turned to
        the viewer (world axes); zero on the background. Computed on first
        access: most frames never need it, and it is 12 bytes a pixel."""
        from ..shading.kernels import shading_normals

        return shading_normals(self.scene, self.camera, self.hits, self.shading)

    @property
    def mask(self) -> np.ndarray:
        """(H, W) bool: pixels that see a surface."""
        return self.hits.prim >= 0

    @property
    def depth(self) -> np.ndarray:
        """(H, W) float32 ray distance; 0 where nothing was hit (see ``mask``)."""
        return np.where(self.mask, self.hits.t, np.float32(0.0))

    @property
    def prim_id(self) -> np.ndarray:
        """(H, W) int32 triangle index within its model; -1 on the background."""
        return self.hits.prim

    @property
    def model_id(self) -> np.ndarray:
        """(H, W) int32 model index; -1 on the background."""
        return self.hits.geom

    def to_uint8(self, **kwargs) -> np.ndarray:
        """8-bit sRGB image; see :func:`raycast_shade.tonemap.to_uint8`."""
        return to_uint8(self.image, **{**self.tone, **kwargs})

    def save(self, path, **kwargs) -> None:
        """Write the image: ``.pfm`` (float32) or ``.npy`` losslessly; PNG, JPEG,
        BMP, TIFF, GIF or WebP in 8 bits after :meth:`to_uint8` with ``kwargs``
        (over :attr:`tone`).

        Raises
        ------
        ValueError
            For any other extension (see :mod:`raycast_shade.imagefile`).
        """
        write_image(path, self.image, **{**self.tone, **kwargs})
