"""Shading a hit buffer: flat, Gouraud and Phong, one method per model.

Every method evaluates the reflectance equation (:mod:`.illumination`); what
differs is *where*: once per triangle (:mod:`.flat`), at each vertex
(:mod:`.gouraud`) or at each pixel (:mod:`.phong`). Shadows follow the same
rule: a shadow ray leaves the point where the model is evaluated (face
centre, vertex, or pixel), so Gouraud's shadows are as coarse as its
highlights.

Kernels are private, parallel, and work in float64; their plain-NumPy twins
live in :mod:`raycast_shade.study.reference`.

Anti-aliasing shades several hit buffers of one frame (one per sample
position) with :class:`SampleShading`: each face's flat colour and each
vertex's Gouraud colours are computed once per frame, the first time a
sample sees them, and reused by every later sample; only the per-pixel
kernels run per sample. :func:`accumulate` and :func:`sample_mean` form the
box-filtered mean, a group of :data:`GROUP` samples per pass over the float64
accumulator.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.parallel import KERNEL, in_parts, share
from ..common.choices import SHADINGS
from ..common.layout import MAT_REFLECTIVITY, METHOD_FLAT, METHOD_GOURAUD, METHOD_PHONG
from ..visibility.hits import check_hits
from .flat import _FLAT, _lookup_flat_kernel
from .gouraud import _INTERPOLATE, _VERTICES, prefetch_distance
from .gouraud_sides import _face_sides_kernel, _near_face, face_planes
from .inputs import lean_lighting, prepare
from .jit import JIT, variant
from .mirror_rays import NO_RAYS
from .phong import _PHONG, _PHONG_PACKETS
from .phong_fast import _NO_NORMALS, _PHONG_FAST, _PHONG_FAST_SHADOWS, applies as _fast_applies

__all__ = ["SHADINGS", "METHODS", "shade", "shade_hits", "resolve_methods", "SampleShading", "accumulate",
           "sample_mean", "GROUP"]

METHODS = {"flat": METHOD_FLAT, "gouraud": METHOD_GOURAUD, "phong": METHOD_PHONG}  # name: code (layout.py)


def resolve_methods(scene, shading) -> np.ndarray:
    """Per-model method codes from a name or one name per model.

    Parameters
    ----------
    shading : str or sequence of str
        ``"flat"``, ``"gouraud"`` or ``"phong"`` for every model, or one of
        those per model (in ``scene.models`` order).

    Returns
    -------
    (G,) int8
        :data:`METHODS` codes: 0 flat, 1 Gouraud, 2 Phong.
    """
    n = len(scene.models)
    if isinstance(shading, str):
        names = [shading] * n
    else:
        try:
            names = list(shading)
        except TypeError:
            raise ValueError(
                f"shading: expected one of {list(SHADINGS) + ['auto']} or one per model, got {shading!r}"
            ) from None
        if len(names) != n:
            raise ValueError(f"shading: expected {n} methods (one per model), got {len(names)}")
    codes = np.empty(n, np.int8)
    for i, name in enumerate(names):
        if not isinstance(name, str) or name.lower() not in METHODS:
            where = "shading" if isinstance(shading, str) else f"shading[{i}]"
            raise ValueError(f"{where}: expected one of {list(SHADINGS)}, got {name!r}")
        codes[i] = METHODS[name.lower()]
    return codes


def shade(scene, camera, hits, shading="phong") -> np.ndarray:
    """Shade a hit buffer.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    hits : HitBuffer
    shading : {"flat", "gouraud", "phong"} or sequence of them
        One method for all models, or one per model.

    Returns
    -------
    image : (H, W, 3) float32
        Linear RGB; ``scene.background`` where nothing was hit.

    Raises
    ------
    TypeError, ValueError
        For a hit buffer that does not fit the scene
        (:func:`~raycast_shade.visibility.hits.check_hits`), before any kernel runs.
    """
    _check_inputs(scene, camera, hits)
    return shade_hits(scene, camera, hits, shading)


def _check_inputs(scene, camera, hits) -> None:
    """Types, and a hit buffer whose indices fit the scene. Any shape of buffer is
    fine (the camera supplies the eye, not pixel positions); its indices are not."""
    from ..scene.camera import Camera
    from ..scene.scene import Scene

    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    if not isinstance(camera, Camera):
        raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
    check_hits(hits, scene.geometry)


@in_parts
@njit(nogil=True, **JIT)
def _visible_kernel(prim, geom, u, v, faces, face_off, modes, flags, part):
    """Mark what some pixel sees, into ``flags`` = ``(flat, gouraud, sides)``: the faces of
    flat-shaded models and those of Gouraud-shaded ones (F,) uint8; only those get shaded,
    Gouraud's vertices from the sides their faces need (:mod:`.gouraud_sides`).
    A Gouraud pixel whose weights stray from its triangle (:func:`.gouraud_sides._near_face`) may see
    it from either side: both sides of its corners ``sides[i, side]`` (V, 2) uint8."""
    flat, gouraud, sides = flags
    h, w = prim.shape
    for y in range(*share(h, part)):  # this part's share (common.parallel)
        for x in range(w):
            p = prim[y, x]
            if p >= 0:
                g = geom[y, x]
                f = face_off[g] + p
                # Racy, but every writer stores the same 1.
                if modes[g] == METHOD_FLAT:
                    flat[f] = 1
                elif modes[g] == METHOD_GOURAUD:
                    gouraud[f] = 1
                    if not _near_face(np.float64(u[y, x]), np.float64(v[y, x])):
                        for k in range(3):
                            sides[faces[f, k], 0] = 1
                            sides[faces[f, k], 1] = 1


def _unseen(seen, done) -> np.ndarray:
    """``seen & ~done`` of two uint8 flag arrays (0 or 1), written over ``seen`` in one pass: a
    band of a 1.31 M-triangle frame made four face-sized temporaries with ``seen & (1 - done)``."""
    np.greater(seen, done, out=seen.view(np.bool_))
    return seen


class Seen:
    """What one frame's hit buffers (its bands, its samples) have seen so far: the faces of
    flat-shaded models, the faces of Gouraud-shaded ones with their states (see
    :mod:`~raycast_shade.shading.gouraud_sides`) and the vertex sides those
    need; each is shaded once, by the first buffer that sees it.

    Attributes
    ----------
    face_done : (F,) uint8
        Flat faces seen (F = 1 without flat models, as every array here without its method).
    gouraud_done : (F,) uint8
        Gouraud faces seen.
    state : (F,) uint8
        The Gouraud faces' states, valid where ``gouraud_done``.
    vertex_done : (V, 2) uint8
        Vertex sides seen (front, back).
    """

    def __init__(self, geo, modes):
        nf, nv = len(geo.faces), len(geo.vertices)
        flat, gouraud = bool(np.any(modes == METHOD_FLAT)), bool(np.any(modes == METHOD_GOURAUD))
        self.gouraud = gouraud
        self.face_done = np.zeros(nf if flat else 1, np.uint8)
        self.gouraud_done = np.zeros(nf if gouraud else 1, np.uint8)
        self.state = np.zeros(nf if gouraud else 1, np.uint8)
        self.vertex_done = np.zeros((nv if gouraud else 1, 2), np.uint8)

    def new(self, hits, geo, k, modes) -> tuple:
        """The flat faces (F,) and vertex sides (V, 2) that ``hits`` sees and no earlier buffer
        saw (uint8 0 or 1), counted as seen from now on; the new Gouraud faces' states set."""
        flat, gouraud, sides = (np.zeros_like(a) for a in (self.face_done, self.gouraud_done, self.vertex_done))
        _visible_kernel(hits.prim, hits.geom, hits.u, hits.v, geo.faces, k["face_off"], modes, (flat, gouraud, sides))
        flat = _unseen(flat, self.face_done)
        self.face_done |= flat
        gouraud = _unseen(gouraud, self.gouraud_done)
        if self.gouraud and gouraud.any():
            _face_sides_kernel(gouraud, k["G"], k["cam"], face_planes(geo), self.state, sides)
            self.gouraud_done |= gouraud
        sides = _unseen(sides, self.vertex_done)
        self.vertex_done |= sides
        return flat, sides


def shade_hits(scene, camera, hits, shading="phong") -> np.ndarray:
    """:func:`shade` without the hit-buffer check, for buffers made by this package's casters and
    rasterizer (valid by construction; a hand-made buffer with bad indices would crash a kernel)."""
    return SampleShading(scene, camera, shading).shade(hits)


class SampleShading:
    """Shade the hit buffers of one frame's anti-aliasing samples, sharing the
    per-face (flat) and per-vertex (Gouraud) work between them.

    Parameters
    ----------
    scene : Scene
    camera : Camera
        The frame's camera (the sub-pixel cameras of the samples have the same
        eye and axes, so they shade alike).
    shading : str or sequence of str
        As for :func:`shade`.
    inputs : FrameInputs, optional
        The frame's packed inputs (:func:`~raycast_shade.shading.inputs.prepare`) when the
        caller has them already (``render`` prepares them once for shading and mirrors).

    Notes
    -----
    :meth:`shade` of one buffer gives the image :func:`shade_hits` gives,
    bit for bit: a face's or vertex's colour does not depend on which pixel
    or sample asked for it.
    """

    def __init__(self, scene, camera, shading="phong", inputs=None):
        self.modes = resolve_methods(scene, shading)
        self.k = prepare(scene, camera) if inputs is None else inputs
        self.geo = scene.geometry
        self.flat = bool(np.any(self.modes == METHOD_FLAT))
        self.gouraud = bool(np.any(self.modes == METHOD_GOURAUD))
        self.phong = bool(np.any(self.modes == METHOD_PHONG))
        self.fast_phong = self.phong and _fast_applies(self.modes, self.k)  # the batched kernel (phong_fast)
        # The Phong kernels hand every reflective pixel's mirror ray over (shade's ``rays``) when only
        # Phong models reflect: flat faces and Gouraud vertices have no per-pixel shading point.
        reflective = self.k["materials"][:, MAT_REFLECTIVITY] > 0.0
        self.hands_over = bool(reflective.any()) and bool(np.all(self.modes[reflective] == METHOD_PHONG))
        self.seen = Seen(self.geo, self.modes)
        self.fcol = np.zeros((len(self.geo.faces), 3), np.float64) if self.flat else None
        self.vcol = np.zeros((len(self.geo.vertices), 2, 3), np.float64) if self.gouraud else None
        # Specular vertex light apart from the diffuse: the textured "modulate" path only.
        self.vspec = np.zeros((len(self.geo.vertices) if self.k["tex_on"] and self.gouraud else 1, 2, 3), np.float64)
        self.ahead = prefetch_distance(self.k.geometry.faces, self.vcol) if self.gouraud else 0

    def _share(self, hits):
        """Shade the faces and vertex sides ``hits`` sees that no earlier sample saw."""
        k, geo = self.k, self.geo
        faces, sides = self.seen.new(hits, geo, k, self.modes)
        if self.flat and faces.any():
            variant(_FLAT, k)(faces, k["G"], geo.face_model, k["materials"], k["cam"], k["L"], k["T"], geo.uvs,
                              self.fcol)
        if self.gouraud and sides.any():
            variant(_VERTICES, k)(sides, k["G"], geo.vertex_model, k["materials"], k["cam"], k["L"], k["T"],
                                  self.vcol, self.vspec)

    WRITES_NORMALS = True  # the Phong kernels write the normal buffer as they shade (shade's ``normal``)

    def shade(self, hits, out=None, y0=0, normal=None, rays=None) -> np.ndarray:
        """(H, W, 3) float32 linear image of one sample's hit buffer (valid by construction),
        written to ``out`` when given (one buffer serves every sample: no fresh pages each time).
        ``normal``: an (H, W, 3) float32 array the Phong kernel writes the shading normal of its
        pixels into as it shades them (zero on the background; other methods' pixels untouched).

        ``y0``: the image row of the buffer's first row, for a band of the frame
        (:func:`~raycast_shade.visibility.bands.cast_bands`): the bands of a frame share the
        per-face and per-vertex work as its samples do, each face and vertex shaded once.
        ``rays``: (H, W, 3) float32 and float64 arrays (:func:`.mirror_rays.hand_over_buffers`) the
        Phong kernel writes each reflective pixel's first mirror ray into, for
        :func:`.mirrors.trace_mirrors` (only when :attr:`hands_over`: every reflective model is Phong)."""
        k, geo, modes = self.k, self.geo, self.modes
        h, w = hits.shape
        if rays is not None and not (self.hands_over and rays[0].shape == rays[1].shape == (h, w, 3)):
            raise ValueError(f"rays: two ({h}, {w}, 3) arrays, for a frame whose reflective models are all Phong")
        image = np.empty((h, w, 3), np.float32) if out is None else out
        if self.flat or self.gouraud:
            self._share(hits)
        # Each pixel kernel writes only the pixels of its own method's models
        # (and the background), so a mixed frame runs just the kernels it needs.
        if self.flat:
            _lookup_flat_kernel(hits.prim, hits.geom, k["face_off"], self.fcol, k["background"], modes, image)
        if self.gouraud:
            variant(_INTERPOLATE, k)((hits.prim, hits.geom, hits.u, hits.v), k["G"], k["B"], k["face_off"],
                                     k["materials"], k["cam"], k["L"], k["T"], k["background"], modes,
                                     (self.vcol, self.vspec, int(y0), self.seen.state, self.ahead), image)
        normals = _NO_NORMALS if normal is None else normal
        outs = (image, normals, NO_RAYS if rays is None else rays)
        if self.fast_phong:  # shadow rays (a scene handle) go as packets of 16 of its lanes
            fast = _PHONG_FAST_SHADOWS if k.lighting.handle != 0 else _PHONG_FAST
            fast(hits.prim, hits.geom, hits.u, hits.v, k["G"], lean_lighting(k["L"]), k["face_off"],
                                            k["materials"], k["cam"], k["background"], modes, outs)
        elif self.phong:  # textures or maps; shadow rays (a scene handle) go as packets of 4x4 pixels
            variant(_PHONG_PACKETS if k.lighting.handle != 0 else _PHONG, k)(
                (hits.prim, hits.geom, hits.u, hits.v), k["G"], k["B"], k["L"], k["T"], k["face_off"], k["materials"],
                k["cam"], k["background"], modes, outs, y0)
        return image


_NO_NORMALS = np.empty((0, 0, 3), np.float32)  # the Phong kernel's normal output when none is asked for
GROUP = 4  # samples added to the accumulator per pass (images alive at a time); _group_sum takes 4


@njit(inline="always")
def _group_sum(acc, imgs, k, first, y, x, c):
    """``acc[y, x, c] + imgs[0][y, x, c] + ... + imgs[k - 1][y, x, c]`` in float64, left to
    right (``first``: without ``acc``): the sum of adding the samples one at a time. The
    tuple is indexed by constants (a run-time index into a tuple is a branch per read)."""
    s = np.float64(imgs[0][y, x, c]) if first else acc[y, x, c] + imgs[0][y, x, c]
    if k > 1:
        s += imgs[1][y, x, c]
    if k > 2:
        s += imgs[2][y, x, c]
    if k > 3:
        s += imgs[3][y, x, c]
    return s


@njit(inline="always")
def _group_hits(prims, k, y, x):
    hit = 1 if prims[0][y, x] >= 0 else 0
    if k > 1 and prims[1][y, x] >= 0:
        hit += 1
    if k > 2 and prims[2][y, x] >= 0:
        hit += 1
    if k > 3 and prims[3][y, x] >= 0:
        hit += 1
    return hit


@in_parts
@njit(**KERNEL)
def _accumulate_kernel(imgs, prims, k, acc, counting, count, first, part):
    h, w = acc.shape[0], acc.shape[1]
    for y in range(*share(h, part)):  # this part's share (common.parallel)
        for x in range(w):
            for c in range(3):
                acc[y, x, c] = _group_sum(acc, imgs, k, first, y, x, c)  # first: no read of acc
            if counting:
                hit = _group_hits(prims, k, y, x)
                count[y, x] = hit if first else count[y, x] + hit


_NO_COUNT = np.zeros((1, 1), np.int32)  # a stand-in when no coverage is counted: never indexed
_NO_IMAGE = np.zeros((1, 1, 3), np.float32)  # pads a group to GROUP images: never indexed


def _padded(images, prims):
    """``images`` and ``prims`` as GROUP-tuples (one kernel type for every group size), and the size."""
    k = len(images)
    if not 1 <= k <= GROUP or len(prims) != k:
        raise ValueError(f"expected 1 to {GROUP} images and as many prims, got {k} and {len(prims)}")
    return (tuple(images) + (_NO_IMAGE,) * (GROUP - k), tuple(prims) + (_NO_COUNT,) * (GROUP - k), k)


def accumulate(acc, count, images, prims, first: bool = False) -> None:
    """Add up to :data:`GROUP` samples in one pass: ``acc += images[0] + images[1] + ...``
    ((H, W, 3) float64 += float32, left to right) and ``count += (prims[0] >= 0) + ...``
    ((H, W) int32; skipped when ``count`` is None), in place; ``first`` sets them instead
    (the accumulator is not read).

    A group per pass reads and writes the float64 accumulator once per group, not once
    per sample; the sums are those of adding the samples one at a time, bit for bit."""
    imgs, prs, k = _padded(images, prims)
    counting = count is not None
    _accumulate_kernel(imgs, prs, k, acc, counting, count if counting else _NO_COUNT, first)


@in_parts
@njit(**KERNEL)
def _mean_kernel(acc, count, imgs, prims, k, first, n, out, counting, coverage, part):
    h, w = out.shape[0], out.shape[1]
    inv = 1.0 / n
    for y in range(*share(h, part)):  # this part's share (common.parallel)
        for x in range(w):
            for c in range(3):
                out[y, x, c] = _group_sum(acc, imgs, k, first, y, x, c) / n  # out may be images[0]: read first
            if counting:
                coverage[y, x] = ((0 if first else count[y, x]) + _group_hits(prims, k, y, x)) * inv


def sample_mean(acc, count, images, prims, n: int, first: bool = False, out=None, coverage: bool = True):
    """The box filter's result: the last group of samples (``images``, ``prims``, up to
    :data:`GROUP`) added to the earlier ones (``acc``, ``count``; not read when ``first``,
    i.e. ``n <= GROUP``), divided by ``n``, in one pass with no write back.

    Parameters
    ----------
    out : (H, W, 3) float32, optional
        Where the mean goes; may be ``images[0]`` itself.
    coverage : bool
        Count the coverage (``count`` holds the earlier samples' hits); False
        skips it (``count`` is not read) and returns None for it.

    Returns
    -------
    image : (H, W, 3) float32
        ``(acc + images[0] + ...) / n`` (``out`` when given).
    coverage : (H, W) float32 or None
        The fraction of the pixel's ``n`` samples that hit a surface.
    """
    imgs, prs, k = _padded(images, prims)
    out = np.empty(images[0].shape, np.float32) if out is None else out
    cov = np.empty(prims[0].shape, np.float32) if coverage else np.empty((1, 1), np.float32)
    _mean_kernel(acc, count if count is not None else _NO_COUNT, imgs, prs, k, first, float(n), out,
                 bool(coverage), cov)
    return out, (cov if coverage else None)
