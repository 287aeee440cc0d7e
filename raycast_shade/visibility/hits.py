"""The hit buffer: what visibility hands to shading.

Both the ray caster and the reference rasterizer emit this buffer, so every
shading kernel serves both, and any difference between their images comes
from visibility alone. A fragment shader needs only the primitive and its
barycentrics (tinyrenderer's contract); ``t`` feeds the depth buffer.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit
from ..common.inline import inline_jit

from ..common.parallel import KERNEL, in_parts, launch, parts, share
from ..common.validate import as_int

__all__ = ["HitBuffer", "check_hits", "image_buffer", "convex_uv", "convex_hits", "convex_rows"]

_INLINE = dict(cache=True, forceinline=True, _nrt=False)  # LLVM-inlined into the kernels, compiled once


@dataclass(frozen=True, eq=False)
class HitBuffer:
    """Per-pixel (or per-ray) visibility.

    The hit point is ``(1 - u - v) p0 + u p1 + v p2`` for the triangle's
    vertices ``p0, p1, p2`` (Embree's convention, the lecture's ``mu1, mu2``).
    The five arrays share one shape: ``(H, W)`` from a camera (the casters,
    the rasterizer; what shading takes) or ``(N,)`` from
    :func:`~raycast_shade.cast_rays`. A buffer unpacks as
    ``prim, geom, u, v, t = hits``.

    Attributes
    ----------
    prim : (H, W) or (N,) int32
        Triangle index within its model, ``-1`` where nothing was hit.
    geom : (H, W) or (N,) int32
        Model index in the scene, ``-1`` where nothing was hit.
    u, v : (H, W) or (N,) float32
        Barycentrics of vertices 1 and 2; zero where nothing was hit.
    t : (H, W) or (N,) float32
        Distance from the camera along the unit ray (orthographic: from the
        image plane; :func:`~raycast_shade.cast_rays`: in units of each
        ray's direction); ``inf`` where nothing was hit.
    """

    prim: np.ndarray
    geom: np.ndarray
    u: np.ndarray
    v: np.ndarray
    t: np.ndarray

    def __post_init__(self):
        # A hand-made buffer in the other byte order (read from a big-endian file) is valid; Numba's
        # kernels take native arrays only, so it is swapped here once, values unchanged.
        for name in ("prim", "geom", "u", "v", "t"):
            arr = getattr(self, name)
            if isinstance(arr, np.ndarray) and not arr.dtype.isnative:
                object.__setattr__(self, name, arr.astype(arr.dtype.newbyteorder("=")))

    @classmethod
    def empty(cls, height: int, width: int) -> "HitBuffer":
        """A buffer of misses, ready for a caster or rasterizer to fill."""
        height, width = as_int(height, "height", minimum=0), as_int(width, "width", minimum=0)
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
        """bool of :attr:`shape`, True where a triangle was hit."""
        return self.prim >= 0

    def __iter__(self):
        """``prim, geom, u, v, t``: unpacks like the tuple ``cast_rays`` once returned."""
        return iter((self.prim, self.geom, self.u, self.v, self.t))


_DTYPES = (np.int32, np.int32, np.float32, np.float32, np.float32)  # prim, geom, u, v, t


def image_buffer(out, height: int, width: int) -> HitBuffer:
    """``out`` checked for a caster or rasterizer to fill in place (every pixel is
    written), or a fresh (H, W) buffer when ``out`` is None.

    Reusing one buffer across the samples of an anti-aliased frame spares
    each sample the page faults of ~40 MB of fresh arrays at 1080p.

    Raises
    ------
    TypeError, ValueError
        For an ``out`` that is not a HitBuffer of C-contiguous (H, W) arrays
        of the caster's dtypes.
    """
    if out is None:
        return HitBuffer(*(np.empty((height, width), dt) for dt in _DTYPES))
    if not isinstance(out, HitBuffer):
        raise TypeError(f"out: expected a HitBuffer, got {type(out).__name__}")
    for name, arr, dt in zip(("prim", "geom", "u", "v", "t"), out, _DTYPES):
        if (not isinstance(arr, np.ndarray) or arr.shape != (height, width) or arr.dtype != dt
                or not arr.flags.c_contiguous or not arr.flags.writeable):
            raise ValueError(f"out.{name}: expected a writeable C-contiguous ({height}, {width}) "
                             f"{np.dtype(dt).name} array, got {getattr(arr, 'shape', type(arr).__name__)} "
                             f"{getattr(arr, 'dtype', '')}")
    return out


# Barycentrics may leave the triangle by rounding only: Embree's (and the rasterizer's
# float64 ones stored in float32) stay within a few float32 ulps of it.
BARYCENTRIC_SLACK = 8 * float(np.finfo(np.float32).eps)  # 9.5e-7


def _count_bad_kernel(prim, geom, u, v, nfaces, slack):
    """Hit pixels with a model index out of range, a triangle index beyond the
    model's face count, non-finite barycentrics, and barycentrics outside the
    triangle (``u < 0``, ``v < 0`` or ``u + v > 1`` by more than ``slack``): four counts."""
    n = parts()
    counts = np.zeros((n, 4), np.int64)
    launch(_count_bad_parts.kernel, prim, geom, u, v, nfaces, slack, counts, parts=n)
    return tuple(int(c) for c in counts.sum(axis=0))


@in_parts
@njit(**KERNEL)
def _count_bad_parts(prim, geom, u, v, nfaces, slack, counts, part):
    """:func:`_count_bad_kernel`'s four counts of this part's rows, into ``counts[part[0]]``."""
    h, w = prim.shape
    bad_geom = 0
    bad_prim = 0
    bad_uv = 0
    outside = 0
    y0, y1 = share(h, part)
    for y in range(y0, y1):
        for x in range(w):
            p = prim[y, x]
            if p < 0:
                continue
            g = geom[y, x]
            if g < 0 or g >= nfaces.shape[0]:
                bad_geom += 1
            elif p >= nfaces[g]:
                bad_prim += 1
            a = np.float64(u[y, x])
            b = np.float64(v[y, x])
            if not (np.isfinite(a) and np.isfinite(b)):
                bad_uv += 1
            elif a < -slack or b < -slack or a + b > 1.0 + slack:
                outside += 1
    k = part[0]
    counts[k, 0], counts[k, 1], counts[k, 2], counts[k, 3] = bad_geom, bad_prim, bad_uv, outside


def check_hits(hits, geometry, camera=None):
    """Validate a hit buffer against a scene before any shading kernel reads it.

    A prim or geom index out of range would make a kernel read outside its
    arrays (a crash, or garbage); barycentrics outside the triangle would
    extrapolate its normals and UVs. The casters never produce either, but a
    hand-made buffer can. One parallel pass: about 0.8 ms at 1080p.

    Parameters
    ----------
    hits : HitBuffer
    geometry : SceneGeometry or Scene
    camera : Camera, optional
        When given, the buffer must have its image size.

    Returns
    -------
    SceneGeometry

    Raises
    ------
    TypeError, ValueError
        Naming the offending field.
    """
    from ..scene.camera import Camera
    from ..scene.scene import as_geometry

    if not isinstance(hits, HitBuffer):
        raise TypeError(f"hits: expected a HitBuffer, got {type(hits).__name__}")
    geometry = as_geometry(geometry)
    if camera is not None and not isinstance(camera, Camera):
        raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
    shape = getattr(hits.prim, "shape", None)
    for name, kinds in (("prim", "i"), ("geom", "i"), ("u", "f"), ("v", "f"), ("t", "f")):
        arr = getattr(hits, name)
        if not isinstance(arr, np.ndarray) or arr.ndim != 2 or arr.shape != shape:
            raise ValueError(f"hits.{name}: expected a 2-D array of shape {shape}, got "
                             f"{getattr(arr, 'shape', type(arr).__name__)}")
        if arr.dtype.kind not in kinds:
            raise TypeError(f"hits.{name}: expected {'integers' if kinds == 'i' else 'floats'}, got {arr.dtype}")
    if camera is not None and shape != (camera.height, camera.width):
        raise ValueError(f"hits: shape {shape} does not match the camera's {camera.height}x{camera.width} image")
    nfaces = np.diff(geometry.face_offsets).astype(np.int64)
    bad_geom, bad_prim, bad_uv, outside = _count_bad_kernel(hits.prim, hits.geom, hits.u, hits.v, nfaces,
                                                            BARYCENTRIC_SLACK)
    if bad_geom:
        raise ValueError(f"hits.geom: {bad_geom} hit pixel(s) name a model outside 0..{geometry.n_models - 1}")
    if bad_prim:
        raise ValueError(f"hits.prim: {bad_prim} hit pixel(s) name a triangle beyond their model's face count")
    if bad_uv:
        raise ValueError(f"hits.u, hits.v: {bad_uv} hit pixel(s) have non-finite barycentrics")
    if outside:
        raise ValueError(f"hits.u, hits.v: {outside} hit pixel(s) lie outside their triangle (u < 0, v < 0 or "
                         f"u + v > 1 by more than {BARYCENTRIC_SLACK:.2g})")
    return geometry


# -- barycentrics onto the triangle ----------------------------------------------------------------


@inline_jit(**_INLINE)
def convex_uv(u, v):
    """``(u, v)`` as float32 with ``u >= 0``, ``v >= 0`` and ``1 - u - v >= 0`` in float64.

    Embree's ``u, v`` (float32, its reciprocal one ulp off) and the watertight re-test's
    (float64 rounded to float32) can leave the triangle by a float32 ulp at its edges and
    vertices: a weight of -6e-8 on a vertex colour of 0 and 1 elsewhere made Phong pixels with
    ``ka_colors`` -6e-8. Shading forms ``w = 1 - u - v`` in float64: ``1 - u`` is exact, so
    ``u + v <= 1`` exactly gives ``w >= 0`` after rounding, and every interpolated value lies
    between its vertex values. A pair already inside is returned as it is, bit for bit; a NaN
    becomes 0 (a vertex: the caller's hit is not made up, only its weights)."""
    a = np.float64(u)
    b = np.float64(v)
    if a >= 0.0 and b >= 0.0 and a + b <= 1.0:
        return np.float32(u), np.float32(v)
    a = min(a, 1.0) if a > 0.0 else 0.0  # NaN and negatives to 0, inf to 1
    b = min(b, 1.0) if b > 0.0 else 0.0
    s = a + b
    if s > 1.0:
        a /= s
        b /= s
    fa = np.float32(min(a, 1.0))
    fb = np.float32(b)
    rest = 1.0 - np.float64(fa)  # exact
    if np.float64(fb) > rest:  # rounded up past the edge: the float32 at or below it
        fb = np.float32(rest)
        if np.float64(fb) > rest:
            fb = np.nextafter(fb, np.float32(0.0))
    return fa, fb


def convex_hits(u, v) -> None:
    """Every ``(u[i], v[i])`` onto its triangle, in place: :func:`convex_uv`'s answer, bit for bit,
    in NumPy (the few pixels of a repair, or the embreex caster's frame: no kernel to compile).
    Pairs already inside, and the misses' zeros, are not touched.

    Parameters
    ----------
    u, v : (N,) or (H, W) float32, writeable
    """
    a, b = u.astype(np.float64), v.astype(np.float64)
    out = ~((a >= 0.0) & (b >= 0.0) & (a + b <= 1.0))
    if not out.any():
        return
    a, b = a[out], b[out]
    with np.errstate(invalid="ignore"):
        a = np.where(a > 0.0, np.minimum(a, 1.0), 0.0)  # NaN and negatives to 0, inf to 1
        b = np.where(b > 0.0, np.minimum(b, 1.0), 0.0)
    s = a + b
    over = s > 1.0
    a[over] /= s[over]
    b[over] /= s[over]
    fa, fb = np.minimum(a, 1.0).astype(np.float32), b.astype(np.float32)
    rest = 1.0 - fa.astype(np.float64)  # exact
    up = fb.astype(np.float64) > rest
    fb[up] = rest[up].astype(np.float32)
    up = fb.astype(np.float64) > rest
    fb[up] = np.nextafter(fb[up], np.float32(0.0))
    u[out], v[out] = fa, fb


def convex_rows(hits: HitBuffer, rows) -> None:
    """:func:`convex_hits` on the given rows of an (H, W) buffer: ``(lo, hi)`` or an index array."""
    if isinstance(rows, tuple):
        lo, hi = rows
        if hi > lo:
            convex_hits(hits.u[lo:hi], hits.v[lo:hi])
        return
    rows = np.asarray(rows, np.int64)
    if len(rows):
        u, v = hits.u[rows], hits.v[rows]
        convex_hits(u, v)
        hits.u[rows], hits.v[rows] = u, v
