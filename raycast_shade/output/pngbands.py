"""An 8-bit PNG of a linear image, tone-mapped and deflated band by band.

:meth:`~raycast_shade.output.frame.Frame.save` writes its PNGs here. The
whole-image route (:func:`~raycast_shade.output.imagefile.write_image`) holds
the 8-bit image and its filtered rows at once beside the linear one: 2 x 100 MB
at 7680 x 4320, the peak of an 8K frame's life (0.92 GB resident with the
82k-triangle icosphere, against 0.71 GB for the render; 0.70 GB saved here). Here a band of
:data:`BAND_ROWS` rows is tone-mapped
(:func:`~raycast_shade.output.quantize.to_uint8_table`, a per-value map: a band's
bytes are the whole image's), filtered "Sub" into one reused row buffer and fed
to one zlib stream, so the extra memory is two bands (about 12 MB at 8K) and the
compressed file. The filter and the container are :mod:`.imagefile`'s (its
:func:`~raycast_shade.output.imagefile.sub_filtered` and
:func:`~raycast_shade.output.imagefile.png_file`, which takes bands): the file is
byte for byte :func:`~raycast_shade.output.imagefile.png_bytes`' of the 8-bit image
(``tests/output/test_pngbands.py``).
"""

from __future__ import annotations

import os

import numpy as np

from .imagefile import png_file, sub_filtered, write_bytes
from .quantize import to_uint8_table

__all__ = ["png_bands", "write_png_bands", "BAND_ROWS"]

BAND_ROWS = 256  # 5.9 MB of 8-bit rows at 7680 pixels a row: two such buffers live at once


def png_bands(image, *, rows: int = BAND_ROWS, **tone) -> bytes:
    """The 8-bit RGB PNG file of a linear image, encoded ``rows`` rows at a time.

    Parameters
    ----------
    image : (H, W, 3) float
        Linear RGB (as :func:`~raycast_shade.output.tonemap.to_uint8` takes it).
    rows : int
        Rows a band (positive); changes the memory only, never a byte of the file.
    **tone
        ``exposure``, ``tonemap``, ``gamma`` of :func:`~raycast_shade.output.tonemap.to_uint8`.

    Returns
    -------
    bytes
        The PNG file: byte for byte ``png_bytes(to_uint8(image, **tone))``.

    Raises
    ------
    TypeError, ValueError
        Naming ``image`` (not an (H, W, 3) array with pixels) or ``rows``; the tone options'
        errors are :func:`~raycast_shade.output.tonemap.to_uint8`'s, from the first band.
    """
    from ..common.validate import as_int

    rows = as_int(rows, "rows", minimum=1)
    if not isinstance(image, np.ndarray):
        raise TypeError(f"image: expected a NumPy array, got {type(image).__name__}")
    if image.ndim != 3 or image.shape[2] != 3 or 0 in image.shape:
        raise ValueError(f"image: expected a non-empty (H, W, 3) array, got shape {image.shape}")
    h, w = image.shape[:2]
    buffer = np.empty((min(rows, h), 3 * w + 1), np.uint8)  # one band's raw rows, reused

    def bands():
        for y in range(0, h, rows):
            yield sub_filtered(to_uint8_table(image[y:y + rows], **tone).reshape(-1, 3 * w), 3, out=buffer)

    return png_file(bands(), w, h, bits=8, channels=3)


def write_png_bands(path, image, *, atomic: bool = False, **tone) -> str:
    """Write :func:`png_bands` of ``image`` to ``path`` (encoded first: no truncated file).

    Parameters
    ----------
    path : str or path-like
        Ending in ``.png``.
    image : (H, W, 3) float
        Linear RGB.
    atomic : bool
        As :func:`~raycast_shade.output.imagefile.write_bytes`.
    **tone
        ``exposure``, ``tonemap``, ``gamma``.

    Returns
    -------
    str
        ``path``.
    """
    if not isinstance(path, (str, os.PathLike)) or not os.fspath(path).lower().endswith(".png"):
        raise ValueError(f"path: a PNG file's name ends in .png, got {path!r:.60}")
    return write_bytes(path, png_bands(image, **tone), atomic=atomic)
