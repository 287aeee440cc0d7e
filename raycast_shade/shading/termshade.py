"""The image and its terms in one shading pass: :class:`TermShading`, ``render(terms=True)``'s shader.

Every method gets its image, local terms, per-light terms, background term and shadow mask
from one pass: each point's equation is evaluated once, its parts stored beside its colour
(Phong per pixel and flat per visible face, :mod:`.terms_kernel`; Gouraud per visible vertex,
the parts interpolated as the colour is, :mod:`.terms_gouraud`), where the variant passes of
:mod:`.terms` shade the frame once per term, per light and per shadow probe. The image is the
plain frame's, bit for bit; the terms are the variant passes' numbers (measured equal, bit for
bit, on the test scenes).

Like :class:`~raycast_shade.shading.shade.SampleShading`, whose ``shade(hits, out, y0)`` it
shares, it shades a whole frame's hit buffer or the frame band by band
(:func:`~raycast_shade.visibility.bands.cast_bands`): the term images are the frame's
full-size arrays, written at the band's rows, and each visible face's flat colour and terms
(each visible vertex's Gouraud colours and terms) are computed once, by the first band that
sees it. Only the mirror part needs the whole frame's hits (:func:`mirror_terms`).

Those face and vertex records are mesh-sized (some 130 MB for Gouraud at 1.31 M triangles):
they stay with the scene's geometry when the frame is done, and its next terms frame writes
into them (:func:`_spares`) rather than into fresh pages; only the entries of the faces and
vertices a frame sees are written and read, so a frame never shows another's numbers.
"""

from __future__ import annotations

import mmap
import weakref

import numpy as np

from ..common.layout import MAT_KE, MAT_REFLECTIVITY, METHOD_FLAT, METHOD_GOURAUD, METHOD_PHONG
from ..common.schedule import BLOCK_ROWS
from .jit import variant
from .mirrors import trace_mirrors
from .inputs import lean_lighting
from .phong_fast import _NO_NORMALS, _PHONG_FAST_TERMS
from .phong_fast import applies as _fast_applies
from .shade import Seen, resolve_methods
from .gouraud import prefetch_distance
from .terms_gouraud import _GOURAUD_TERMS, _VERTEX_TERMS, VERT_COL, VERT_Y0, scratch_slots
from .flat import _FLAT_TERMS, _lookup_flat_terms
from .terms_kernel import _PHONG_TERMS, TERM_BACKGROUND, TERM_EMISSIVE, TERM_SLOTS, TERMS_EACH, TERMS_SHADOW

__all__ = ["TermShading", "mirror_terms"]


# Zero arrays from this size on get pages of their own (_untouched_zeros): measured, a 1080p
# frame's three (25 MB) spent 3-7 ms clearing reused heap memory, while at 640x480 (3.7 MB each)
# mapping them apart cost more (the heap they left gave 2,400 page faults elsewhere a frame).
_MAPPED_FROM = 16 << 20


def _untouched_zeros(shape, dtype=np.float32) -> np.ndarray:
    """A writable zero array on fresh anonymous pages: nothing is written until someone writes
    it (a term no kernel writes costs no page faults and no memory bandwidth). ``np.zeros``
    does not promise that: its ``calloc`` clears memory it takes back from the heap, which
    after a few large frames is 25 MB of writes per (1080, 1920, 3) float32 array. Arrays
    under :data:`_MAPPED_FROM` bytes are ``np.zeros``.

    Parameters
    ----------
    shape : tuple of int
    dtype : numpy dtype

    Returns
    -------
    shape dtype
        Zeros, writable, owning its mapping (freed with the array); where the OS offers
        transparent huge pages (``mmap.MADV_HUGEPAGE``), the mapping asks for them.
    """
    nbytes = int(np.prod(shape)) * np.dtype(dtype).itemsize
    if nbytes < _MAPPED_FROM:  # clearing it costs little, and its heap memory serves the next frame
        return np.zeros(shape, dtype)
    private = getattr(mmap, "MAP_PRIVATE", None)  # POSIX: private, not shared-memory pages
    buf = mmap.mmap(-1, nbytes) if private is None else mmap.mmap(-1, nbytes, flags=private | mmap.MAP_ANONYMOUS)
    huge = getattr(mmap, "MADV_HUGEPAGE", None)
    if huge is not None:
        # Huge pages, as NumPy asks for its own large arrays: a read of the untouched zeros
        # (the image adds the emissive and background terms) maps one zero page per 2 MiB,
        # not per 4 KiB, and a mirror writing `reflected` faults 512 times less. Measured at
        # 1080p (82k triangles): terms 87-89 -> 80-82 ms, with a mirror 227-254 -> 208-209 ms.
        buf.madvise(huge)
    return np.frombuffer(buf, dtype).reshape(shape)


_NONE = np.zeros((1, 1, 3), np.float32)  # a term slot no kernel writes or reads (never indexed)
_NONE64 = np.zeros((1, 1, 3), np.float64)


def _arrays(shape, nlights, per_light, emit_on, bg_on, dtype=np.float32) -> tuple:
    """The arrays of a terms record ``R`` (:mod:`.terms_kernel`) of ``shape`` = (rows, columns)
    that get written, fresh (``np.empty``: every point of them that is read is written): the
    ambient, diffuse and specular images, the emissive one with ``emit_on``, the background one
    with ``bg_on``, the per-light terms and the shadow mask."""
    h, w = shape
    local = tuple(np.empty((h, w, 3), dtype) for on in (True, True, True, emit_on, bg_on) if on)
    return local + (np.empty((2, nlights if per_light else 0, h, w, 3), dtype), np.empty((nlights, h, w), dtype))


def _assemble(arrays, slots, emit_on, bg_on, background) -> tuple:
    """The terms record ``R`` of :func:`_arrays`' ``arrays``: the term slots not written (no
    emission, a black background) ``slots``' zeros whose pages nobody touches."""
    written = iter(arrays)
    local = tuple(next(written) if on else slots[k] for k, on in enumerate((True, True, True, emit_on, bg_on)))
    return local + (next(written), next(written), bool(emit_on), bool(bg_on), background)


def _record(shape, slots, nlights, per_light, background, emit_on, bg_on, dtype=np.float32):
    """A fresh terms record ``R`` (:mod:`.terms_kernel`) of ``shape`` = (rows, columns)
    (:func:`_arrays`, :func:`_assemble`)."""
    return _assemble(_arrays(shape, nlights, per_light, emit_on, bg_on, dtype), slots, emit_on, bg_on, background)


_SPARES = "shading.terms_spares"  # the geometry's memo key of the spare face and vertex records


def _spares(geo) -> dict:
    """The geometry's spare face and vertex records (kind -> (shape key, array tuple)): kept with
    the geometry, so a scene's next terms frame writes into memory the last one faulted in.
    Measured: at 1.31 M triangles and 1080p a Gouraud terms frame took some 130 MB of fresh
    mesh-sized pages per frame (page faults and the kernel's zeroing, in the kernels' time)."""
    return geo.memo(_SPARES, lambda _: {})


def _take(spares, key, build) -> tuple:
    """The spare array tuple of shape ``key`` (no other frame holds it: ``dict.pop`` is atomic),
    or ``build()``. One spare per kind (``key[0]``: flat or Gouraud) whatever its shape, so a
    scene rendered with changing lights holds one set of records, not one per light count."""
    kept = spares.pop(key[0], None)
    return kept[1] if kept is not None and kept[0] == key else build()


def _give(spares, key, arrays) -> None:
    """``arrays`` back to the spares once their frame's shader is gone (replacing a spare of
    another shape: the newest frame's is the likeliest to fit the next one)."""
    spares[key[0]] = (key, arrays)


class TermShading:
    """Shade one frame's hit buffer, whole or band by band, into its image and its terms.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    shading : str or sequence of str
        As for :func:`~raycast_shade.shading.shade.shade`.
    inputs : FrameInputs
        The frame's (:func:`~raycast_shade.shading.inputs.prepare`).
    per_light : bool
        Also each light's diffuse and specular term.

    Notes
    -----
    The term arrays are the frame's: (H, W, 3) float32 for ``ambient``, ``diffuse``,
    ``specular``, ``emissive`` and ``background``, (L, H, W) float32 for ``shadow``, (L, H, W, 3)
    for the per-light terms. :meth:`terms` hands them over with ``keep`` and ``reflected``.
    """

    def __init__(self, scene, camera, shading, inputs, per_light: bool = False):
        k = inputs
        self.k, self.scene, self.geo, self.camera = k, scene, scene.geometry, camera
        self.modes = resolve_methods(scene, shading)
        self.flat = bool(np.any(self.modes == METHOD_FLAT))
        self.gouraud = bool(np.any(self.modes == METHOD_GOURAUD))
        self.phong = bool(np.any(self.modes == METHOD_PHONG))
        h, w = camera.height, camera.width
        nl = k.lighting.lights.shape[0]
        emit_on = bool(np.any(k.materials[:, MAT_KE:MAT_KE + 3] > 0))
        bg_on = bool(np.any(k.background != 0))
        zeros = [_untouched_zeros((h, w, 3)) for _ in range(2)]  # untouched unless written
        slots = {TERM_EMISSIVE: zeros[0], TERM_BACKGROUND: zeros[1]}
        self.R = _record((h, w), slots, nl, per_light, k.background, emit_on, bg_on)
        self.per_light = per_light
        # The batched Phong kernel (phong_fast) where it applies; per-light terms: the general one
        self.fast_phong = (self.phong and not per_light and _fast_applies(self.modes, k)
                           and int(k.lighting.handle) == 0)  # its terms build traces no shadow rays
        # Each visible face's colour and terms (each visible vertex's colours and terms), computed
        # once by the first band that sees it, into mesh-sized arrays an earlier frame left
        # (_spares): only the entries of seen faces and vertices are written, and only those read.
        spares = _spares(self.geo)
        nf = len(self.geo.faces) if self.flat else 1
        nv = len(self.geo.vertices) if self.gouraud else 1
        self.seen = Seen(self.geo, self.modes)
        if self.flat:
            key = ("flat", nf, nl, per_light, emit_on)
            arrays = _take(spares, key, lambda: (np.empty((nf, 3)),) + _arrays((nf, 1), nl, per_light, emit_on, False))
            self.fcol = arrays[0]
            self.F = _assemble(arrays[1:], {TERM_EMISSIVE: _NONE, TERM_BACKGROUND: _NONE}, emit_on, False,
                               k.background)
            weakref.finalize(self, _give, spares, key, arrays)
        if self.gouraud:  # each visible vertex's colours and terms (float64, as its colours), once
            key = ("gouraud", nv, nl, per_light, emit_on, bool(k.tex_on))
            arrays = _take(spares, key, lambda: _arrays((2 * nv, 1), nl, per_light, emit_on, False, np.float64) + (
                np.empty((nl, 2 * nv, 1)), np.empty((nv, 2, 3)), np.empty((nv if k.tex_on else 1, 2, 3))))
            V = _assemble(arrays[:-3], {TERM_EMISSIVE: _NONE64, TERM_BACKGROUND: _NONE64}, emit_on, False,
                          k.background)
            self.V = V + arrays[-3:] + (0,)
            self.ahead = prefetch_distance(k.geometry.faces, self.V[VERT_COL])
            weakref.finalize(self, _give, spares, key, arrays)

    def _share(self, hits):
        """Shade the faces of flat models and the vertices of Gouraud ones that ``hits`` sees
        and no earlier band saw."""
        k, geo = self.k, self.geo
        faces, sides = self.seen.new(hits, geo, k, self.modes)
        if self.flat and faces.any():
            variant(_FLAT_TERMS, k)(faces, k.geometry, geo.face_model, k.materials, k.cam, k.lighting, k.colours,
                                    geo.uvs, (self.fcol, self.F))
        if self.gouraud and sides.any():
            variant(_VERTEX_TERMS, k)(sides, k.geometry, geo.vertex_model, k.materials, k.cam, k.lighting, k.colours,
                                      self.V)

    WRITES_NORMALS = False  # the terms' kernels do not write the normal buffer (the buffer kernel does)

    hands_over = False  # the terms' kernels hand no mirror rays over (SampleShading.hands_over)

    def shade(self, hits, out=None, y0=0, normal=None, rays=None) -> np.ndarray:
        """(h, W, 3) float32 image of a hit buffer whose first row is image row ``y0`` (the
        whole frame: 0), written to ``out`` when given; its terms go to the frame's term
        arrays at rows ``y0`` on. The image is :class:`~raycast_shade.shading.shade.SampleShading`'s,
        bit for bit. ``normal`` and ``rays`` must be None (see :attr:`WRITES_NORMALS`,
        :attr:`hands_over`)."""
        if normal is not None:
            raise ValueError("normal: TermShading does not write the shading normals (WRITES_NORMALS is False)")
        if rays is not None:
            raise ValueError("rays: TermShading hands no mirror rays over (hands_over is False)")
        k, modes = self.k, self.modes
        h, w = hits.shape
        image = np.empty((h, w, 3), np.float32) if out is None else out
        y0 = int(y0)
        if self.flat or self.gouraud:
            self._share(hits)
        if self.flat:
            _lookup_flat_terms(hits.prim, hits.geom, k.face_off, self.fcol, k.background, modes,
                               (image, y0, self.R, self.F))
        if self.gouraud:
            tasks = (h + BLOCK_ROWS - 1) // BLOCK_ROWS  # the pixel kernel's parallel tasks
            V = self.V[:VERT_Y0] + (y0, self.seen.state, self.ahead) + scratch_slots(self.V, tasks)
            variant(_GOURAUD_TERMS, k)((hits.prim, hits.geom, hits.u, hits.v), k.geometry, k.bumps, k.face_off,
                                       k.materials, k.cam, k.lighting, k.colours, modes, image, self.R, V)
        if self.fast_phong:
            _PHONG_FAST_TERMS(hits.prim, hits.geom, hits.u, hits.v, k.geometry, lean_lighting(k.lighting),
                                                   k.face_off, k.materials, k.cam, k.background, modes,
                                                   (image, _NO_NORMALS, self.R, y0))
        elif self.phong:
            variant(_PHONG_TERMS, k)((hits.prim, hits.geom, hits.u, hits.v), k.geometry, k.bumps, k.lighting,
                                     k.colours, k.face_off, k.materials, k.cam, modes, image, y0, self.R)
        return image

    def terms(self, hits=None, max_depth: int = 0) -> dict:
        """The frame's terms once every row is shaded (the keys of
        :func:`~raycast_shade.shading.terms.shade_terms`); ``hits``: the whole frame's, needed
        only for mirror bounces (``max_depth > 0`` on a scene with a mirror)."""
        each, shadow = self.R[TERMS_EACH], self.R[TERMS_SHADOW]
        out = dict(zip(TERM_SLOTS, self.R))
        if self.per_light:
            out["diffuse_per_light"], out["specular_per_light"] = each[0], each[1]
        out["keep"], out["reflected"] = mirror_terms(self.scene, self.camera, hits, max_depth, self.k)
        out["shadow"] = shadow  # last, as the montage and the docs list the terms
        return out


def mirror_terms(scene, camera, hits, max_depth, k):
    """``keep`` (H, W) float32 (``1 - rho`` on mirror pixels, else 1) and ``reflected``
    (H, W, 3) float32 (``rho`` times what the mirror rays see, traced over black; zeros whose
    pages nobody touches without mirrors)."""
    h, w = camera.height, camera.width
    keep = np.ones((h, w), np.float32)
    reflected = _untouched_zeros((h, w, 3))  # untouched pages until a mirror writes them
    if scene.geometry.reflective and max_depth > 0:
        seen = hits.prim >= 0
        rho = np.where(seen, k.materials[np.maximum(hits.geom, 0), MAT_REFLECTIVITY], 0.0)
        keep = np.where(rho > 0, (1.0 - rho).astype(np.float32), np.float32(1.0))
        trace_mirrors(scene, camera, hits, reflected, max_depth, k)
    return keep, reflected
