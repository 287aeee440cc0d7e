"""The per-view file options of a view set (:class:`ViewFiles`), checked: what each view writes.

:func:`raycast_shade.apps.views.render_views` takes them whole, ``files=ViewFiles(...)`` (its flat
keywords ``buffers=``, ``formats=``, ... are deprecated); see its docstring for the files themselves.
"""

from __future__ import annotations

import dataclasses

from ..common.validate import as_bool, as_names, as_scalar
from ..output.buffers import check_buffers
from ..output.imagefile import check_image_path

__all__ = ["ViewFiles", "FORMATS", "PNG_FORMATS", "COMPRESSIONS", "view_files", "format_buffers", "png_format_bytes"]

# Per view: buffer files (npz, exr), and one PNG of a buffer each (PNG_FORMATS, their file suffixes).
PNG_FORMATS = {"depth_png": "_depth.png", "distance_png": "_distance.png", "mask_png": "_mask.png",
               "semantic_png": "_semantic.png", "instance_png": "_instance.png"}
FORMATS = ("npz", "exr", *PNG_FORMATS)
COMPRESSIONS = ("auto", "none", "zip")  # npz deflate level 1 and EXR ZIP, or neither; auto: zip with ISA-L
_STEM = "view_{:05d}"
# The buffer each PNG format is made from.
_PNG_SOURCE = {"depth_png": "zdepth", "distance_png": "depth", "mask_png": "model_id", "semantic_png": "model_id",
               "instance_png": "model_id"}


def view_files(index: int, formats, image) -> dict:
    """File names (no folder) of view ``index``, by kind (``image``, ``npz``, ``exr``, the PNG formats,
    and ``record``, the view's record, written last)."""
    stem = _STEM.format(index)
    files = {} if image is None else {"image": stem + image}
    for f in formats:
        files[f] = stem + PNG_FORMATS.get(f, "." + f)
    files["record"] = stem + ".json"
    return files


def format_buffers(formats) -> tuple:
    """The buffers the PNG formats in ``formats`` are made from (``model_id`` is rendered always)."""
    return tuple(dict.fromkeys(_PNG_SOURCE[f] for f in formats if f in PNG_FORMATS))


def png_format_bytes(kind: str, buffers: dict, depth_scale: float, labels) -> bytes:
    """The bytes of view PNG ``kind`` from the view's ``buffers``.

    ``depth_png``: uint16 z-depth times ``depth_scale`` (0: none); ``distance_png``: the same of the
    distance along the ray; ``mask_png``: 255 where a surface is hit, else 0; ``semantic_png``,
    ``instance_png``: label PNGs (:mod:`raycast_shade.output.labelfiles`), ``labels`` being
    ``{kind: (lookup, bits)}`` for them.
    """
    import numpy as np

    from ..output.bufferfile import depth_png_bytes
    from ..output.imagefile import png_bytes
    from ..output.labelfiles import label_png_bytes

    source = buffers[_PNG_SOURCE[kind]]
    if kind in ("depth_png", "distance_png"):
        return depth_png_bytes(source, scale=depth_scale, fast=True)
    if kind == "mask_png":
        return png_bytes(np.where(source >= 0, np.uint8(255), np.uint8(0)), fast=True)
    return label_png_bytes(source, *labels[kind.split("_")[0]])


def _check_outputs(names, formats, image) -> None:
    if not formats and image is None:
        raise ValueError("formats: nothing to write (no buffer format and image=None)")
    if formats and not names and not set(formats) & set(PNG_FORMATS):
        raise ValueError("buffers: no buffers asked for, but formats names buffer files")
    if "exr" in formats:
        import OpenEXR  # noqa: F401 - fail now, not on the first view


_DEFAULT_BUFFERS = ("zdepth", "normal", "id", "mask")
_DEFAULT_FORMATS = ("npz",)


@dataclasses.dataclass(frozen=True)
class ViewFiles:
    """What each view of a set writes: :func:`~raycast_shade.apps.views.render_views`' file options in one.

    Parameters
    ----------
    buffers : sequence of str
        Buffer names (:mod:`raycast_shade.output.buffers`).
    formats : sequence of {"npz", "exr", "depth_png", "distance_png", "mask_png", "semantic_png", "instance_png"}
        Files per view besides the image: the buffers (npz, exr), 16-bit z-depth and distance
        along the ray (``depth_png``, ``distance_png``: units of ``1 / depth_scale``, 0: none),
        the 8-bit foreground mask (``mask_png``: 255 on a surface, 0 on the background), and
        the label PNGs (``semantic_png``, ``instance_png``: 0 the background, 8- or 16-bit,
        :mod:`raycast_shade.output.labelfiles`).
    image : {".png", ".pfm", ".npy", ...} or None
        Extension of the per-view image file, or None for none.
    depth_scale : float
        Units per world unit of the depth and distance PNGs (1000: millimetres for a scene in metres).
    float_image : bool
        Also store the linear float32 image in the npz and EXR files.
    compression : {"auto", "none", "zip"}
        npz and EXR files compressed or stored (see :func:`~raycast_shade.apps.views.render_views`).

    Raises
    ------
    TypeError, ValueError
        Naming the field, when the instance is made.
    """

    buffers: tuple = _DEFAULT_BUFFERS
    formats: tuple = _DEFAULT_FORMATS
    image: str | None = ".png"
    depth_scale: float = 1000.0
    float_image: bool = False
    compression: str = "auto"

    def __post_init__(self):
        from ..common.validate import as_choice

        check_buffers(self.buffers)  # None: no buffers, as render(buffers=None)
        buffers = () if self.buffers is None else (self.buffers,) if isinstance(self.buffers, str) \
            else tuple(self.buffers)
        formats = as_names(self.formats, "formats", FORMATS)
        image = self.image
        if image is not None:
            if not isinstance(image, str):
                raise TypeError(f"image: expected an extension such as '.png', or None; got {type(image).__name__}")
            check_image_path("view" + image, "image")
            image = image.lower()
        _check_outputs(check_buffers(buffers), formats, image)
        float_image = as_bool(self.float_image, "float_image")
        depth_scale = float(as_scalar(self.depth_scale, "depth_scale", minimum=0.0, exclusive=True))
        compression = as_choice(self.compression, "compression", COMPRESSIONS)
        for name, value in (("buffers", buffers), ("formats", formats), ("image", image), ("depth_scale", depth_scale),
                            ("float_image", float_image), ("compression", compression)):
            object.__setattr__(self, name, value)
