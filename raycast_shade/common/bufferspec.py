"""The per-pixel buffers ``render(buffers=...)`` makes, each defined once.

:data:`REGISTRY` holds every buffer's name, dtype, channels, who writes it
and its documentation line. Everything else reads it: the name check and
the buffer kernel's output tuple (:mod:`raycast_shade.output.buffers`, whose
module table is built from it), the memory count
(:mod:`raycast_shade.scene.framememory`) and the byte sizes the writers store.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["BufferSpec", "REGISTRY", "BUFFERS", "BUFFER_NAMES", "ALIASES", "KERNEL_BUFFERS", "registry_table"]


@dataclass(frozen=True)
class BufferSpec:
    """One buffer.

    Attributes
    ----------
    name : str
    dtype : str
        NumPy dtype name of the stored array.
    channels : int
        0 for an (H, W) image, 3 for (H, W, 3).
    writer : {"kernel", "samples"}
        ``"kernel"``: the buffer kernel writes it, band by band, in
        :data:`REGISTRY` order; ``"samples"``: ``render`` counts it from the
        anti-aliasing samples' hits (with one sample, the mask).
    doc : str
        What a pixel holds (background: 0, ids -1; OpenCV camera axes).
    """

    name: str
    dtype: str
    channels: int
    writer: str
    doc: str

    @property
    def bytes(self) -> int:
        """Bytes per pixel."""
        return np.dtype(self.dtype).itemsize * max(self.channels, 1)

    def shape(self, h: int, w: int) -> tuple:
        """The array's shape for ``h`` x ``w`` pixels."""
        return (h, w) if self.channels == 0 else (h, w, self.channels)


REGISTRY = (
    BufferSpec("depth", "float32", 0, "kernel",
               "distance from the eye along the ray (``frame.depth``; orthographic: from the image plane)"),
    BufferSpec("zdepth", "float32", 0, "kernel", "view-space ``z``: depth along the optical axis"),
    BufferSpec("position", "float32", 3, "kernel", "world position of the surface point"),
    BufferSpec("normal", "float32", 3, "kernel", "shading normal, world axes, turned to the viewer"),
    BufferSpec("normal_camera", "float32", 3, "kernel", "the same in camera axes"),
    BufferSpec("face_normal", "float32", 3, "kernel", "geometric (triangle) normal, world, turned to the viewer"),
    BufferSpec("face_normal_camera", "float32", 3, "kernel", "the same in camera axes"),
    BufferSpec("barycentric", "float32", 3, "kernel", "weights of the triangle's vertices 0, 1, 2"),
    BufferSpec("model_id", "int32", 0, "kernel", "model index in the scene (the instance mask)"),
    BufferSpec("triangle_id", "int32", 0, "kernel", "triangle index within its model (the mesh's face order)"),
    BufferSpec("mask", "bool", 0, "kernel", "pixels that see a surface"),
    BufferSpec("coverage", "float32", 0, "samples",
               "fraction of the pixel's anti-aliasing samples that hit a surface (``render(samples=N)``; "
               "with one sample, ``mask``)"),
    BufferSpec("semantic_id", "int32", 0, "kernel",
               "index of the model's name among the scene's distinct model names "
               "(:func:`~raycast_shade.output.labels.semantic_classes`)"),
)
BUFFERS = {spec.name: spec for spec in REGISTRY}
BUFFER_NAMES = tuple(BUFFERS)
#: The buffer kernel's outputs, in the order of its ``outputs`` tuple.
KERNEL_BUFFERS = tuple(spec for spec in REGISTRY if spec.writer == "kernel")
ALIASES = {"id": ("model_id", "triangle_id")}


def registry_table() -> str:
    """A reStructuredText table of :data:`REGISTRY` (name, shape and dtype, meaning), as
    :mod:`raycast_shade.output.buffers`' docstring shows it."""
    import textwrap

    rule = "=" * 22 + "  " + "=" * 15 + "  " + "=" * 56
    rows = [rule]
    for spec in REGISTRY:
        shape = ("(H, W)" if spec.channels == 0 else f"(H, W, {spec.channels})") + " " + (
            "f32" if spec.channels and spec.dtype == "float32" else spec.dtype)
        lines = textwrap.wrap(spec.doc, 56, break_on_hyphens=False, break_long_words=False) or [""]
        rows.append(f"{'``' + spec.name + '``':<22}  {shape:<15}  {lines[0]}")
        rows += [" " * 41 + line for line in lines[1:]]
    return "\n".join(rows + [rule])
