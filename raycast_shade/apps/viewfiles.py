"""The per-view file options of a view set (:class:`ViewFiles`), checked: what each view writes.

:func:`raycast_shade.apps.views.render_views` takes them whole, ``files=ViewFiles(...)`` (its flat
keywords ``buffers=``, ``formats=``, ... are deprecated); see its docstring for the files themselves.
"""

from __future__ import annotations

import dataclasses

from ..common.validate import as_bool, as_names, as_scalar
from ..output.buffers import check_buffers
from ..output.imagefile import check_image_path

__all__ = ["ViewFiles", "FORMATS", "COMPRESSIONS"]

FORMATS = ("npz", "exr", "depth_png")
COMPRESSIONS = ("auto", "none", "zip")  # npz deflate level 1 and EXR ZIP, or neither; auto: zip with ISA-L


def _check_outputs(names, formats, image) -> None:
    if not formats and image is None:
        raise ValueError("formats: nothing to write (no buffer format and image=None)")
    if formats and not names and "depth_png" not in formats:
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
    formats : sequence of {"npz", "exr", "depth_png"}
        Buffer files per view (see the module docstring).
    image : {".png", ".pfm", ".npy", ...} or None
        Extension of the per-view image file, or None for none.
    depth_scale : float
        Units per world unit of the depth PNG (1000: millimetres).
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
