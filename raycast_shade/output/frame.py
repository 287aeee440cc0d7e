"""A rendered frame: the linear image, the buffers behind it, and timings."""

from __future__ import annotations

import copy
import threading
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..common.validate import as_scalar
from ..visibility.hits import HitBuffer
from .imagefile import LINEAR_EXTS, check_image_path, write_image
from .pngbands import write_png_bands
from .tonemap import to_uint8

__all__ = ["Frame", "NoTerms", "TermsMissingError"]


class _HitsSlot:
    """The ``hits`` field: a :class:`HitBuffer`, or a function that makes it on first use.

    A frame rendered band by band (:func:`raycast_shade.render`) never held its whole
    hit buffer (20 bytes a pixel); it keeps the recipe, the same cast again, and runs it
    once, the first time ``frame.hits`` (or something built on it) is read. The cast is
    deterministic, so the buffer is the one the frame was shaded from, bit for bit."""

    def __set_name__(self, owner, name):
        self.slot = "_" + name

    def __get__(self, obj, objtype=None):
        if obj is None:  # no default: the dataclass field stays required
            raise AttributeError(self.slot[1:])
        value = getattr(obj, self.slot)  # a private instance attribute (the class has none of that name)
        if callable(value):
            with obj._hits_lock:
                value = getattr(obj, self.slot)
                if callable(value):
                    value = value()
                    object.__setattr__(obj, self.slot, value)  # the frame is frozen: set once, under the lock
        return value

    def __set__(self, obj, value):
        object.__setattr__(obj, self.slot, value)
        object.__setattr__(obj, "_hits_lock", threading.Lock())

    def pending(self, obj):
        """The recipe of ``obj``'s hit buffer while it has not run, else None."""
        value = getattr(obj, self.slot)
        return value if callable(value) else None


_HITS = _HitsSlot()  # Frame.hits (a module name: the class attribute answers only for an instance)


class TermsMissingError(KeyError):
    """A term read from a frame rendered without its terms (a KeyError, so ``in`` and ``get`` behave)."""

    def __str__(self) -> str:  # KeyError would print the message in quotes
        return str(self.args[0])


TERMS_HOW = ("this frame was rendered without its terms; render it with rs.render(scene, ..., terms=True) "
             "(ambient, diffuse, specular, reflected, shadow, ...) or terms='per_light' (one image per light too)")


class NoTerms(dict):
    """``frame.terms`` of a frame rendered without them: empty (``== {}``, false), but
    reading a term raises :class:`TermsMissingError` saying how to get them, and the
    notebook shows that sentence rather than ``{}``."""

    def __missing__(self, key):
        raise TermsMissingError(f"frame.terms[{key!r}]: {TERMS_HOW}")

    def __setitem__(self, key, value):
        raise TypeError("frame.terms: a frame's terms are read-only")

    def __repr__(self) -> str:
        return f"NoTerms({{}}: {TERMS_HOW})"


class _TermsSlot:
    """The ``terms`` field: the dict of term images, or :class:`NoTerms` when there are none.

    A frame rendered without ``terms=True`` has none; a plain ``{}`` would let a later
    ``terms["diffuse"]`` fail with a bare ``KeyError: 'diffuse'``."""

    def __set_name__(self, owner, name):
        self.slot = "_" + name

    def __get__(self, obj, objtype=None):
        if obj is None:
            return None  # the dataclass default: no terms
        value = getattr(obj, self.slot, None)
        return value if value else NoTerms()

    def __set__(self, obj, value):
        object.__setattr__(obj, self.slot, value)


@dataclass(frozen=True, eq=False, repr=False)
class Frame:
    """The result of :func:`raycast_shade.render`.

    Attributes
    ----------
    image : (H, W, 3) float32
        Linear RGB, finite and non-negative; zero on the background.
    hits : HitBuffer
        Primitive, model, barycentrics and distance per pixel. A frame that
        asked for no buffer may hold a function instead (no arguments,
        returning the buffer): it runs on first access (the frame was shaded
        band by band and kept no full-frame buffer; the cast again gives the
        same bits).
    shading : str or tuple of str
        The method of every model, or one per model (``shading="auto"``
        resolves to the latter).
    timings : dict of str to float
        Seconds per stage: ``build`` (packing and BVH, first frame of a scene
        only), ``cast`` (or ``raster``), ``shade``, ``total``; ``mirror``,
        ``buffers``, ``terms`` when they ran, and ``average`` (the box filter's
        passes) with ``samples > 1``.
    decisions : tuple of Decision
        With ``shading="auto"``: each model's method and the reason.
    tone : dict
        Default ``exposure``, ``tonemap``, ``gamma`` of :meth:`to_uint8` and
        :meth:`save` (keywords given there win): a scene file's, from
        :func:`raycast_shade.render_file`; empty from :func:`raycast_shade.render`.
    buffers : dict of str to ndarray
        The buffers asked for with ``render(..., buffers=(...))``, by name
        (:mod:`raycast_shade.output.buffers`); empty otherwise.
    terms : dict of str to ndarray
        With ``render(..., terms=True)``: the reflectance equation's terms as
        images, ``ambient``, ``diffuse``, ``specular``, ``reflected``, the
        shadow mask, ... (:mod:`raycast_shade.shading.terms`). Without them, an
        empty :class:`NoTerms` whose every term raises :class:`TermsMissingError`
        (a KeyError) saying how to get them (:attr:`has_terms` asks).
    max_depth : int or None
        The mirror bounces the frame was rendered with (``None``: unknown).
    explainer : callable or None
        ``explainer(frame, x, y)`` behind :meth:`explain`: :func:`raycast_shade.explain`,
        set by :func:`raycast_shade.render`. It lives in the study layer, above this
        one, so it is handed in rather than imported.
    hit_mask : (H, W) bool or None
        ``hits.prim >= 0``, kept by a frame whose hit buffer is made on first
        use, so that :attr:`mask` needs no cast.
    inputs : FrameInputs or None
        The kernel inputs the frame was shaded with
        (:func:`~raycast_shade.shading.inputs.prepare`), which :meth:`explain`
        reads instead of packing them again; ``None``: not kept.
    """

    image: np.ndarray
    hits: HitBuffer = _HITS
    shading: str
    scene: object = None
    camera: object = None
    timings: dict = field(default_factory=dict)
    decisions: tuple = ()
    tone: dict = field(default_factory=dict)
    buffers: dict = field(default_factory=dict)
    terms: dict = _TermsSlot()
    max_depth: int | None = None
    explainer: object = None
    hit_mask: np.ndarray | None = None
    inputs: object = None

    @property
    def method(self) -> np.ndarray:
        """(H, W) int8: the method that shaded each pixel: 0 flat, 1 Gouraud,
        2 Phong; -1 on the background."""
        from ..shading.shade import resolve_methods

        codes = resolve_methods(self.scene, self.shading)
        return np.where(self.hits.geom >= 0, codes[np.maximum(self.hits.geom, 0)], -1).astype(np.int8)

    @cached_property
    def normal(self) -> np.ndarray:
        """(H, W, 3) float32 unit normal each pixel was shaded with, turned to
        the viewer (world axes); zero on the background. Computed on first
        access: most frames never need it, and it is 12 bytes a pixel. A frame
        rendered with the ``normal`` buffer returns that array (the same values,
        not computed twice)."""
        from ..shading.normals import shading_normals

        if "normal" in self.buffers:
            return self.buffers["normal"]
        return shading_normals(self.scene, self.camera, self.hits, self.shading)

    @property
    def mask(self) -> np.ndarray:
        """(H, W) bool: pixels that see a surface."""
        if self.hit_mask is not None:
            return self.hit_mask.copy()  # a fresh array, as the computed one is
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

    def hit(self, x: int, y: int) -> HitBuffer:
        """Pixel ``(x, y)``'s hit as (1, 1) arrays, the hit buffer's bit for bit. A frame whose
        buffer is still a recipe (shaded band by band) casts that pixel's rays alone
        (:func:`~raycast_shade.visibility.pixel.cast_pixel`), not the frame.
        ``x``, ``y`` are not checked here (:meth:`explain` checks them)."""
        recipe = _HITS.pending(self)
        if recipe is not None and hasattr(recipe, "pixel"):
            return recipe.pixel(x, y)
        return HitBuffer(*(a[y:y + 1, x:x + 1] for a in self.hits))

    def explain(self, x: int, y: int):
        """The reflectance equation at pixel ``(x, y)`` with its numbers filled in
        (an :class:`~raycast_shade.insight.explain.Explanation`; ``print`` it); see
        :func:`raycast_shade.explain`."""
        if self.explainer is None:
            raise ValueError("explain: this frame was not made by raycast_shade.render; "
                             "call raycast_shade.explain(frame, x, y)")
        return self.explainer(self, x, y)

    def with_tone(self, tone: dict) -> "Frame":
        """This frame with other default tone options (:attr:`tone`); everything else,
        the hit buffer included (made or still a recipe), is shared, not copied or cast."""
        new = copy.copy(self)  # shallow: the same arrays, hit buffer (or its recipe) and lock
        object.__setattr__(new, "tone", dict(tone))
        return new

    def to_uint8(self, **kwargs) -> np.ndarray:
        """8-bit sRGB image; see :func:`raycast_shade.output.tonemap.to_uint8`."""
        return to_uint8(self.image, **{**self.tone, **kwargs})

    def __repr__(self) -> str:
        """One line: size, shading and timings in ms (the image itself is left out)."""
        h, w = self.image.shape[:2]
        shading = self.shading if isinstance(self.shading, str) else "/".join(self.shading)
        times = ", ".join(f"{k} {v * 1e3:.1f}" for k, v in self.timings.items())
        return f"Frame({w}x{h}, shading={shading!r}" + (f", ms: {times})" if times else ")")

    @property
    def has_terms(self) -> bool:
        """Whether the frame holds its terms (``render(..., terms=True)``)."""
        return bool(getattr(self, "_terms", None))

    def show(self, scale: int | None = None, width: int | None = None, **tone):
        """The picture a notebook shows: the 8-bit image (:meth:`to_uint8` with ``tone``)
        upscaled by an integer factor, nearest neighbour, so each pixel stays a square.

        Parameters
        ----------
        scale : int, optional
            Display pixels per image pixel, each way (1 to 64).
        width : int, optional
            Display width in pixels: the largest integer scale that fits.
            By default the picture is at least 480 pixels wide, at most 1024
            (:func:`raycast_shade.output.display.display_scale`).
        **tone
            ``exposure``, ``tonemap``, ``gamma`` (over :attr:`tone`).

        Returns
        -------
        raycast_shade.output.display.Picture
            Shows itself in a notebook; ``.rgb`` (H, W, 3) uint8, ``.pixels`` the upscaled one.
        """
        from .display import Picture, display_scale

        return Picture(self.to_uint8(**tone), display_scale(self.image.shape, scale, width))

    def _repr_png_(self) -> bytes:
        """PNG bytes for Jupyter and IPython: :meth:`show` at its default scale (the image
        :meth:`save` writes, each pixel repeated as a square up to a legible width)."""
        return self.show()._repr_png_()

    def overlay(self, wireframe: bool = True, vertices: bool = False, normals: bool = False, width: float = 1.0,
                color=(1.0, 1.0, 1.0), **kwargs) -> np.ndarray:
        """(H, W, 3) float32: the image with its triangle edges, vertices or normals drawn
        over it, exactly from the hit buffer; see :func:`raycast_shade.output.overlays.overlay`
        (``radius``, ``length``, ``image``)."""
        from .overlays import overlay

        return overlay(self, wireframe=wireframe, vertices=vertices, normals=normals, width=width, color=color,
                       **kwargs)

    def save(self, path, **kwargs) -> None:
        """Write the image: ``.pfm`` (float32) or ``.npy`` losslessly; PNG, JPEG,
        BMP, TIFF, GIF or WebP in 8 bits after :meth:`to_uint8` with ``kwargs``
        (over :attr:`tone`).

        Parameters
        ----------
        path : str or path-like
        **kwargs
            ``exposure``, ``tonemap``, ``gamma``, 8-bit formats only: the
            lossless formats store the linear image as is, so tone options
            with them are refused rather than silently ignored.

        Raises
        ------
        TypeError
            For an unknown keyword (a typo such as ``exposur``).
        ValueError
            For an invalid tone option, tone options with ``.pfm``/``.npy``,
            or an unknown extension (see :mod:`raycast_shade.output.imagefile`).
        """
        _check_tone(path, kwargs)
        # The frame's own tone options (a scene file's [render]) apply where tone applies: 8-bit files.
        ext = check_image_path(path)
        if ext == ".png" and isinstance(self.image, np.ndarray) and self.image.ndim == 3:
            # Band by band: no 8-bit copy of the whole image beside it (200 MB at 8K); the same bytes.
            write_png_bands(path, self.image, **{**self.tone, **kwargs})
        else:
            write_image(path, self.image, **(kwargs if ext in LINEAR_EXTS else {**self.tone, **kwargs}))


_TONE_OPTIONS = ("exposure", "tonemap", "gamma")


def _check_tone(path, tone: dict) -> None:
    """Names and values of ``tone`` (see :meth:`Frame.save`), before any file is touched."""
    import difflib

    for key in tone:
        if key not in _TONE_OPTIONS:
            hint = difflib.get_close_matches(key, _TONE_OPTIONS, n=1)
            tail = f" (did you mean {hint[0]!r}?)" if hint else f"; expected {', '.join(_TONE_OPTIONS)}"
            raise TypeError(f"save: unexpected keyword argument {key!r}{tail}")
    # Checked for every format. Types here (to_uint8 would take True for 1 and fail on "2"
    # inside NumPy); ranges and choices by to_uint8 itself, on one pixel.
    if "exposure" in tone:
        as_scalar(tone["exposure"], "exposure", minimum=0.0, exclusive=True)
    if "gamma" in tone and not isinstance(tone["gamma"], str):
        as_scalar(tone["gamma"], "gamma", minimum=0.0, exclusive=True)
    if "tonemap" in tone and not isinstance(tone["tonemap"], str):
        raise TypeError(f"tonemap: expected a string, got {type(tone['tonemap']).__name__}")
    to_uint8(np.zeros((1, 1, 3), np.float32), **tone)
    ext = check_image_path(path)
    if tone and ext in LINEAR_EXTS:
        raise ValueError(f"{', '.join(tone)}: tone options do not apply to {ext}, which stores the linear "
                         "float32 image as is; leave them out, or write an 8-bit format such as .png")
