"""Colour textures: images on the UV square that scale a material's ka, kd or ks.

A :class:`Texture` holds linear RGB texels (images stored in sRGB are decoded
with the exact sRGB transfer function first: shading is linear arithmetic, and
averaging encoded values would darken every filtered texel) and its mip-map
pyramid, each level a 2x2 box filter of the one below, computed in linear
space once, when the scene is packed. The kernels sample it bilinearly at the
hit's UV, trilinearly between the two levels the pixel's footprint falls
between (:mod:`raycast_shade.shading.texture`).

Conventions are those of :class:`~raycast_shade.HeightMap`: row 0 of
``texels`` is ``v = 0``, column 0 is ``u = 0``, texel centres sit at
``((j + 0.5) / w, (i + 0.5) / h)``; an image file's top row is ``v = 1``
(as OBJ and glTF UVs assume).
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..common.choices import WRAPS
from ..common.layout import (TEX_CLAMP, TEX_HEIGHT, TEX_LEVELS, TEX_MIPMAP, TEX_OFFSET, TEX_SIZE, TEX_TILE_U,
                             TEX_TILE_V, TEX_WIDTH)
from ..common.validate import as_array, as_bool, as_choice, as_int, as_name, check_memory
from ..common.warnings import DroppedOnLoadWarning

__all__ = ["Texture", "TEXTURE_FILTERS", "srgb_to_linear", "TEXTURE_BYTES_PER_TEXEL", "DECODE_BYTES_PER_TEXEL"]

# "mipmap": trilinear between the levels the pixel footprint falls between; "bilinear": level 0 only.
TEXTURE_FILTERS = ("mipmap", "bilinear")
# Peak bytes a texel needs while a texture is made, as the camera's FRAME_BYTES_PER_PIXEL bounds a frame
# (tests/scene/test_meaning_checks.py measures them): a Texture or a checker (the parity grid, the
# float64 colours, the float32 texels) and its mip pyramid (float64 levels: 72) ...
TEXTURE_BYTES_PER_TEXEL = 80
# ... and an image decoded (a 16-bit RGBA file's pixels 8, float64 copies, the sRGB decode's temporaries,
# the flipped copy and the float32 texels: 127 beyond the pixels).
DECODE_BYTES_PER_TEXEL = 136


def _check_size(h: int, w: int, what: str, per_texel: int) -> None:
    """Refuse (ValueError, with the figure) a texture larger than the memory limit, before allocating it."""
    check_memory(float(h) * float(w) * per_texel, f"{what}: {w} x {h} texels", "a texture")


def srgb_to_linear(c) -> np.ndarray:
    """The exact sRGB EOTF (IEC 61966-2-1): ``c / 12.92`` up to 0.04045,
    ``((c + 0.055) / 1.055) ** 2.4`` above; ``c`` in [0, 1], any shape."""
    c = np.asarray(c, np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((np.maximum(c, 0.04045) + 0.055) / 1.055) ** 2.4)


def _halve(a: np.ndarray, axis: int) -> np.ndarray:
    """Box-filter ``a`` to half its length along ``axis``: pairs averaged; an odd
    length folds its last sample into the last output (a 3-wide box there)."""
    n = a.shape[axis]
    if n == 1:
        return a
    m = n // 2
    even = np.take(a, np.arange(0, 2 * m, 2), axis=axis)
    odd = np.take(a, np.arange(1, 2 * m, 2), axis=axis)
    out = 0.5 * (even + odd)
    if n % 2:
        last = [slice(None)] * a.ndim
        last[axis] = slice(m - 1, m)
        tail = np.take(a, [n - 1], axis=axis)
        out[tuple(last)] = (2.0 * out[tuple(last)] + tail) / 3.0
    return out


# PIL modes whose pixels are palette indices or another colour space: decoded through PIL's own
# conversion (np.asarray would hand back the indices: a palette PNG read as near-black grey).
_PIL_CONVERT = {"P": "RGBA", "PA": "RGBA", "CMYK": "RGB", "YCbCr": "RGB", "LAB": "RGB", "HSV": "RGB", "RGBX": "RGB",
                "RGBa": "RGBA", "La": "LA"}
# PIL modes holding 16-bit values in a wider integer array ("I" is int32 storage of 16-bit PNGs).
_PIL_16BIT = ("I;16", "I;16B", "I;16L", "I;16N", "I")


def _pil_pixels(image):
    """Pixels of a PIL image as a NumPy array whose dtype says its range: palette and other
    colour spaces converted to RGB(A) by PIL; 16-bit modes as uint16; "1" as bool; "F" as float."""
    mode = image.mode
    if mode in _PIL_CONVERT:
        if mode == "P" and "transparency" not in image.info:
            return np.asarray(image.convert("RGB"))
        return np.asarray(image.convert(_PIL_CONVERT[mode]))
    a = np.asarray(image)
    if mode in _PIL_16BIT:
        if a.size and (a.min() < 0 or a.max() > 65535):
            raise ValueError(f"a mode {mode!r} image with values outside 0..65535 (min {a.min()}, max {a.max()})")
        return a.astype(np.uint16)
    return a


def _image_floats(img, name: str, alpha: str = "warn") -> np.ndarray:
    """(h, w, 3) float64 from image pixels by the rule of :meth:`Texture.from_array`:
    grey replicated, alpha dropped (with a warning unless opaque or ``alpha="ignore"``)."""
    if hasattr(img, "mode") and hasattr(img, "convert"):  # a PIL image: decode by its mode
        try:
            img = _pil_pixels(img)
        except ValueError as exc:
            raise ValueError(f"{name}: {exc}") from None
    img = np.asarray(img)
    if img.dtype == np.bool_:
        img = img.astype(np.uint8) * 255
    if img.dtype in (np.uint8, np.uint16):
        x = img.astype(np.float64) / np.iinfo(img.dtype).max
    elif img.dtype.kind in "ui":
        # Other integer types carry no range of their own: 0..255 is taken as 8-bit, anything else refused.
        lo, hi = (int(img.min()), int(img.max())) if img.size else (0, 0)
        if lo < 0 or hi > 255:
            raise ValueError(f"{name}: {img.dtype} pixels must lie in 0..255 (8-bit values), got {lo}..{hi}; "
                             "pass uint8 or uint16 arrays (their range is their type's), or floats in [0, 1]")
        x = img.astype(np.float64) / 255.0
    elif img.dtype.kind == "f":
        x = img.astype(np.float64)
        if not np.all(np.isfinite(x)):
            raise ValueError(f"{name}: image pixels must be finite, got NaN or inf")
    else:
        raise TypeError(f"{name}: expected image pixels (integers or floats), got dtype {img.dtype}")
    if x.ndim == 2:
        x = x[..., None]
    if x.ndim != 3 or x.shape[2] not in (1, 2, 3, 4):
        raise ValueError(f"{name}: expected an (h, w), (h, w, 3) or (h, w, 4) image, got shape {img.shape}")
    if x.shape[2] in (2, 4):
        if alpha == "warn" and np.any(x[..., -1] < 1.0):
            warnings.warn(f"{name}: dropped the alpha channel (transparency is not modelled; the colour is used "
                          "as if opaque)", DroppedOnLoadWarning, stacklevel=4)
        x = x[..., :-1]
    if x.shape[2] == 1:
        x = np.repeat(x, 3, axis=2)
    return x


@dataclass(frozen=True, eq=False)
class Texture:
    """Linear RGB texels on the unit UV square.

    A material's ``kd_map`` (``ka_map``, ``ks_map``) multiplies its ``kd``
    (``ka``, ``ks``) at each point by the texel there, as OBJ's ``map_Kd`` and
    glTF's ``baseColorTexture`` scale ``Kd`` and ``baseColorFactor``.

    Parameters
    ----------
    texels : (h, w, 3) array_like of float
        Linear values ``>= 0``; row 0 is ``v = 0``. (h, w) is grey. A
        texture needing more than
        :func:`~raycast_shade.common.validate.memory_limit` at
        ``TEXTURE_BYTES_PER_TEXEL`` (80) bytes a texel is refused with the
        figure, before it is copied (:meth:`from_array` and
        :meth:`from_image` at ``DECODE_BYTES_PER_TEXEL``, 136, before decoding).
    wrap : {"repeat", "clamp"}
        Outside [0, 1): tile, or hold the edge texel.
    filter : {"mipmap", "bilinear"}
        ``"mipmap"``: trilinear, the level chosen by each pixel's footprint
        (no shimmer where the texture is minified); ``"bilinear"``: the full
        resolution everywhere (sharp, aliases in the distance).
    tiling : (2,) float
        Repeats across the UV square in u and v.
    name : str
    decoded_from_srgb : bool
        The texels are colours decoded from sRGB (set by :meth:`from_array` and
        :meth:`from_image` with ``srgb=True``): a :class:`~raycast_shade.Material`
        refuses such a texture where data is meant (a normal map, glTF's
        metallic-roughness map). A field, so that ``dataclasses.replace`` keeps it.
    """

    texels: np.ndarray
    wrap: str = "repeat"
    filter: str = "mipmap"
    tiling: tuple = (1.0, 1.0)
    name: str = "texture"
    decoded_from_srgb: bool = False

    def __post_init__(self):
        set_ = object.__setattr__
        set_(self, "name", as_name(self.name, f"{type(self).__name__}.name"))  # first: every message uses it
        t = np.asarray(self.texels)
        if t.ndim in (2, 3):  # before the float32 copy and the pyramid
            _check_size(t.shape[0], t.shape[1], f"{self.name}.texels", TEXTURE_BYTES_PER_TEXEL)
        if t.ndim == 2:
            t = np.repeat(t[..., None], 3, axis=2)
        t = as_array(t, f"{self.name}.texels", dtype=np.float32, shape=(None, None, 3), copy=True)
        if t.shape[0] < 1 or t.shape[1] < 1:
            raise ValueError(f"{self.name}.texels: need at least one texel, got shape {t.shape}")
        if t.min() < 0:
            raise ValueError(f"{self.name}.texels: must be >= 0 (reflectance scales), got min {float(t.min())}")
        t.setflags(write=False)
        set_(self, "texels", t)
        set_(self, "wrap", as_choice(self.wrap, f"{self.name}.wrap", WRAPS))
        set_(self, "filter", as_choice(self.filter, f"{self.name}.filter", TEXTURE_FILTERS))
        tiling = as_array(self.tiling, f"{self.name}.tiling", dtype=np.float64, shape=(2,))
        if np.any(tiling <= 0):
            raise ValueError(f"{self.name}.tiling: must be > 0, got {tiling.tolist()}")
        set_(self, "tiling", (float(tiling[0]), float(tiling[1])))
        set_(self, "decoded_from_srgb", as_bool(self.decoded_from_srgb, f"{self.name}.decoded_from_srgb"))

    @property
    def _decoded_srgb(self) -> bool:  # the name Material's checks read
        return self.decoded_from_srgb

    # -- constructors ---------------------------------------------------------------
    @classmethod
    def from_array(cls, image, srgb: bool = True, alpha: str = "warn", **kwargs) -> "Texture":
        """From image pixels as an image file holds them: top row first (``v = 1``).

        The pixels' range follows their type: ``uint8`` over 255, ``uint16``
        over 65535, ``bool`` as 0 or 1; other integer types must hold 8-bit
        values 0..255 (anything else is refused: cast to ``uint16`` for 16-bit
        data); floats are used as they are and, with ``srgb=True``, must lie in
        [0, 1] (the sRGB encoding's range; refused otherwise, never clipped).
        A PIL image is decoded by its mode (palette images through their
        palette, 16-bit modes over 65535).

        Parameters
        ----------
        image : (h, w), (h, w, 3) or (h, w, 4) array_like, or PIL.Image.Image
        srgb : bool
            Decode from sRGB to linear (8- and 16-bit colour images are
            almost always sRGB); ``False`` for data already linear (then
            floats may exceed 1, and must be ``>= 0``).
        alpha : {"warn", "ignore"}
            An alpha channel is dropped; ``"warn"`` says so in a
            :class:`DroppedOnLoadWarning` unless it is opaque (``"ignore"``:
            the source says the alpha means nothing, as glTF's ``OPAQUE``).
        """
        name = kwargs.get("name", "texture")
        srgb = as_bool(srgb, f"{name}.srgb")
        alpha = as_choice(alpha, f"{name}.alpha", ("warn", "ignore"))
        shape = image.size[::-1] if hasattr(image, "mode") and hasattr(image, "size") else np.shape(image)
        if len(shape) >= 2:  # before the float64 decoding
            _check_size(shape[0], shape[1], f"{name}.image", DECODE_BYTES_PER_TEXEL)
        x = _image_floats(image, f"{name}.image", alpha)  # the argument named, as every check does
        if srgb:
            lo, hi = (float(x.min()), float(x.max())) if x.size else (0.0, 0.0)
            if lo < 0.0 or hi > 1.0:
                raise ValueError(f"{name}.image: sRGB-encoded pixels must lie in [0, 1], got {lo:g}..{hi:g} (pass "
                                 "srgb=False for linear values, which may exceed 1)")
            x = srgb_to_linear(x)
        if "decoded_from_srgb" in kwargs:
            raise TypeError(f"{name}.decoded_from_srgb: from_array sets it from srgb=; leave it out")
        return cls(np.ascontiguousarray(x[::-1]), decoded_from_srgb=srgb, **kwargs)

    @classmethod
    def from_image(cls, path, srgb: bool = True, **kwargs) -> "Texture":
        """Read an image file (PNG, JPEG, ...); see :meth:`from_array`."""
        import imageio.v3 as iio

        path = os.fspath(path)
        kwargs.setdefault("name", os.path.basename(path))
        if not os.path.exists(path):
            raise ValueError(f"{kwargs['name']}: image not found: {path}")
        try:  # the size from the header, before the pixels are read
            shape = iio.improps(path).shape
        except Exception:  # unreadable: imread below says why
            shape = ()
        if len(shape) >= 2:
            _check_size(shape[0], shape[1], f"{kwargs['name']}.image", DECODE_BYTES_PER_TEXEL)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", DeprecationWarning)  # imageio's legacy plugins on junk files
                img = np.asarray(iio.imread(path))
        except Exception as exc:
            raise ValueError(f"{kwargs['name']}: cannot read image {path}: {exc}") from None
        return cls.from_array(img, srgb=srgb, **kwargs)

    @classmethod
    def checker(cls, squares: int = 8, texels_per_square: int = 8, colors=((1.0, 1.0, 1.0), (0.0, 0.0, 0.0)),
                **kwargs) -> "Texture":
        """A ``squares x squares`` checkerboard of two linear colours; square (0, 0)
        (at ``u, v = 0``) has ``colors[0]``."""
        squares = as_int(squares, "texture.squares", minimum=1)
        k = as_int(texels_per_square, "texture.texels_per_square", minimum=1)
        c = as_array(colors, "texture.colors", dtype=np.float64, shape=(2, 3))
        n = squares * k
        _check_size(n, n, f"texture.squares x texture.texels_per_square: {squares} x {k} a side",
                    TEXTURE_BYTES_PER_TEXEL)
        parity = ((np.arange(n) // k) % 2).astype(np.uint8)
        odd = parity[:, None] ^ parity[None, :]  # one byte a texel, not an int64 sum and its remainder
        return cls(c[odd], **kwargs)

    # -- derived --------------------------------------------------------------------
    @property
    def shape(self) -> tuple:
        """(h, w) of level 0."""
        return self.texels.shape[:2]

    @cached_property
    def pyramid(self) -> tuple:
        """The mip levels, level 0 first, each (h_k, w_k, 3) float32 with
        ``h_k = max(1, h >> k)``, down to 1 x 1; only level 0 for ``"bilinear"``."""
        levels = [self.texels]
        if self.filter == "bilinear":
            return tuple(levels)
        cur = self.texels.astype(np.float64)
        while cur.shape[0] > 1 or cur.shape[1] > 1:
            cur = _halve(_halve(cur, 0), 1)
            lvl = cur.astype(np.float32)
            lvl.setflags(write=False)
            levels.append(lvl)
        return tuple(levels)

    @property
    def size(self) -> int:
        """Floats in the packed pyramid."""
        return sum(lvl.size for lvl in self.pyramid)

    def packed_texels(self) -> np.ndarray:
        """(size,) float32: every level's RGB triples, row-major, level 0 first."""
        return np.concatenate([lvl.ravel() for lvl in self.pyramid])

    def packed_info(self, offset: int) -> np.ndarray:
        """(TEX_SIZE,) = (8,) float64 kernel row: texel offset, width, height, levels, clamp flag,
        tile u, tile v, mip-map flag (slots named in :mod:`raycast_shade.common.layout`)."""
        h, w = self.shape
        row = np.empty(TEX_SIZE)
        row[TEX_OFFSET] = offset
        row[TEX_WIDTH] = w
        row[TEX_HEIGHT] = h
        row[TEX_LEVELS] = len(self.pyramid)
        row[TEX_CLAMP] = 1.0 if self.wrap == "clamp" else 0.0
        row[TEX_TILE_U] = self.tiling[0]
        row[TEX_TILE_V] = self.tiling[1]
        row[TEX_MIPMAP] = 1.0 if self.filter == "mipmap" else 0.0
        return row

    def __repr__(self) -> str:
        h, w = self.shape
        return f"Texture(name={self.name!r}, {w}x{h}, wrap={self.wrap!r}, filter={self.filter!r})"
