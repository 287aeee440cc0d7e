"""Blinn (1978) bump mapping: height maps, UV mappings and tangent frames.

A height map ``B(u, v)`` perturbs the normal as if the surface were displaced
by ``B`` along it, without moving the surface::

    N' = N + (Bu (N x Pv) - Bv (N x Pu)) / |N|

with ``Pu, Pv`` the surface derivatives (per triangle, from positions and
UVs) and ``Bu, Bv`` the height derivatives. Silhouettes are unchanged, the
lecture's stated limitation: only the normal moves, never the surface.

The perturbation needs a normal per pixel, so it applies in Phong shading
(and to mirror reflections, which are shaded per point); flat and Gouraud
shading evaluate the model at face centres or vertices and ignore bump maps.

Every height map is a grid sampled bilinearly (procedural ones are baked at a
chosen resolution), so the kernels have one code path.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass

import numpy as np

from ..common.choices import WRAPS
from ..common.layout import (BUMP_CLAMP, BUMP_COLS, BUMP_OFFSET, BUMP_ROWS, BUMP_SCALE, BUMP_SIZE, BUMP_TILE_U,
                             BUMP_TILE_V)
from ..common.validate import as_array, as_choice, as_int, as_scalar, as_vec3, check_memory
from .tangents import face_edges

__all__ = ["HeightMap", "spherical_uvs", "cylindrical_uvs", "planar_uvs", "tangent_frames", "WRAPS"]

# Baking a procedural map holds about eight float64 grids per texel at once (u, v, the
# pattern's temporaries, the sum) plus the float32 heights.
_BAKE_BYTES_PER_TEXEL = 8 * 8 + 4


def _check_bake(n: int) -> None:
    check_memory(float(n) * n * _BAKE_BYTES_PER_TEXEL, f"heightmap.resolution: {n} x {n} texels",
                 "baking the height map")



@dataclass(frozen=True, eq=False)
class HeightMap:
    """Heights on the unit UV square, sampled bilinearly.

    Parameters
    ----------
    heights : (h, w) array_like of float
        Row 0 is ``v = 0``; column 0 is ``u = 0``. Texel centres sit at
        ``((j + 0.5) / w, (i + 0.5) / h)``.
    scale : float
        World units of displacement per unit of height (may be negative:
        dimples instead of bumps).
    wrap : {"repeat", "clamp"}
        Outside [0, 1): tile, or hold the edge texel.
    tiling : (2,) float
        Repeats of the map across the UV square in u and v.
    """

    heights: np.ndarray
    scale: float = 0.02
    wrap: str = "repeat"
    tiling: tuple = (1.0, 1.0)

    def __post_init__(self):
        set_ = object.__setattr__
        h = as_array(self.heights, "heightmap.heights", dtype=np.float32, ndim=2, copy=True)
        if h.shape[0] < 2 or h.shape[1] < 2:
            raise ValueError(f"heightmap.heights: need at least 2x2 texels, got {h.shape}")
        h.setflags(write=False)
        set_(self, "heights", h)
        # Bounded: beyond, Blinn's perturbation overflows float64 and the kernels fall back to the plain normal.
        set_(self, "scale", as_scalar(self.scale, "heightmap.scale", minimum=-1e30, maximum=1e30))
        set_(self, "wrap", as_choice(self.wrap, "heightmap.wrap", WRAPS))
        t = as_array(self.tiling, "heightmap.tiling", dtype=np.float64, shape=(2,))
        if np.any(t <= 0):
            raise ValueError(f"heightmap.tiling: must be > 0, got {t.tolist()}")
        set_(self, "tiling", (float(t[0]), float(t[1])))

    # -- constructors ---------------------------------------------------------------
    @classmethod
    def from_image(cls, path, **kwargs) -> "HeightMap":
        """Heights from an image file: grey levels, or the Rec. 709 luminance
        of colour, scaled to [0, 1]. The image's top row is ``v = 1``."""
        import imageio.v3 as iio

        path = os.fspath(path)
        if not os.path.exists(path):
            raise ValueError(f"heightmap: image not found: {path}")
        try:
            with warnings.catch_warnings():
                # An unreadable file makes imageio try every plugin, legacy ones with a DeprecationWarning.
                warnings.simplefilter("ignore", DeprecationWarning)
                img = np.asarray(iio.imread(path))
        except Exception as exc:
            raise ValueError(f"heightmap: cannot read image {path}: {exc}") from None
        top = np.iinfo(img.dtype).max if img.dtype.kind in "ui" else 1.0
        img = img.astype(np.float64) / top
        if img.ndim == 3:
            img = img[..., :3] @ np.array([0.2126, 0.7152, 0.0722]) if img.shape[2] >= 3 else img[..., 0]
        return cls(img[::-1].copy(), **kwargs)

    @classmethod
    def from_function(cls, fn, resolution: int = 512, **kwargs) -> "HeightMap":
        """Bake ``fn(u, v) -> height`` (vectorised) at texel centres."""
        if not callable(fn):
            raise TypeError(f"fn: expected a function of (u, v), got {type(fn).__name__}")
        n = as_int(resolution, "heightmap.resolution", minimum=2)
        _check_bake(n)
        c = (np.arange(n) + 0.5) / n
        uu, vv = np.meshgrid(c, c)
        return cls(np.asarray(fn(uu, vv), np.float64), **kwargs)

    @classmethod
    def dimples(cls, count: int = 8, radius: float = 0.35, resolution: int = 512, **kwargs) -> "HeightMap":
        """``count x count`` round dimples (smooth cosine cups), heights in [-1, 0]."""
        count = as_int(count, "heightmap.count", minimum=1)
        radius = as_scalar(radius, "heightmap.radius", minimum=0.0, exclusive=True, maximum=0.5)

        def fn(u, v):
            fu = (u * count) % 1.0 - 0.5
            fv = (v * count) % 1.0 - 0.5
            r = np.hypot(fu, fv) / radius
            return np.where(r < 1.0, -0.5 * (1.0 + np.cos(np.pi * np.minimum(r, 1.0))), 0.0)

        return cls.from_function(fn, resolution, **kwargs)

    @classmethod
    def wrinkles(cls, frequency: int = 6, octaves: int = 4, seed: int = 0, resolution: int = 512, **kwargs) -> "HeightMap":
        """Tileable value noise summed over octaves (a "wrinkled" surface), in [0, 1]."""
        frequency = as_int(frequency, "heightmap.frequency", minimum=1)
        octaves = as_int(octaves, "heightmap.octaves", minimum=1)  # the lattice check below bounds it
        n = as_int(resolution, "heightmap.resolution", minimum=2)
        _check_bake(n)
        seed = as_int(seed, "heightmap.seed", minimum=0)
        # The last octave's lattice has (frequency * 2**(octaves - 1))**2 float64 cells.
        # (Capped exponents: the figure stays a float, and anything near the caps is refused.)
        check_memory(min(float(frequency), 1e100) ** 2 * 4.0 ** min(octaves - 1, 400) * 8,
                     f"heightmap.frequency, heightmap.octaves: {frequency}, {octaves}", "the noise lattice")
        rng = np.random.default_rng(seed)
        c = (np.arange(n) + 0.5) / n
        total = np.zeros((n, n))
        amp, norm = 1.0, 0.0
        for o in range(octaves):
            f = frequency * 2**o
            lattice = rng.random((f, f))
            x = c * f
            i0 = np.floor(x).astype(int)
            t = x - i0
            t = t * t * (3 - 2 * t)  # smoothstep: C1 across lattice cells
            a, b = i0 % f, (i0 + 1) % f  # wraps: the map tiles seamlessly
            row = lattice[a][:, a] * (1 - t)[None, :] + lattice[a][:, b] * t[None, :]
            row2 = lattice[b][:, a] * (1 - t)[None, :] + lattice[b][:, b] * t[None, :]
            total += amp * (row * (1 - t)[:, None] + row2 * t[:, None])
            norm += amp
            amp *= 0.5
        return cls(total / norm, **kwargs)

    def packed_info(self, offset: int) -> np.ndarray:
        """(BUMP_SIZE,) = (7,) float64 kernel row: texel offset, rows, cols, clamp flag, tile u, tile v,
        scale (slots named in :mod:`raycast_shade.common.layout`)."""
        h, w = self.heights.shape
        row = np.empty(BUMP_SIZE)
        row[BUMP_OFFSET] = offset
        row[BUMP_ROWS] = h
        row[BUMP_COLS] = w
        row[BUMP_CLAMP] = 1.0 if self.wrap == "clamp" else 0.0
        row[BUMP_TILE_U] = self.tiling[0]
        row[BUMP_TILE_V] = self.tiling[1]
        row[BUMP_SCALE] = self.scale
        return row


def _points(vertices) -> np.ndarray:
    """(V, 3) float64 vertices, at least one, checked (the UV mappings' input)."""
    p = as_array(vertices, "vertices", dtype=np.float64, shape=(None, 3))
    if len(p) == 0:
        raise ValueError("vertices: no vertices")
    return p


def spherical_uvs(vertices, center=(0.0, 0.0, 0.0)) -> np.ndarray:
    """(V, 2) ``(atan2(x, z) / 2pi + 1/2, acos(y / r) / pi)`` about ``center``."""
    p = _points(vertices) - as_vec3(center, "center")
    r = np.maximum(np.linalg.norm(p, axis=1), 1e-300)
    return np.stack([np.arctan2(p[:, 0], p[:, 2]) / (2 * np.pi) + 0.5, np.arccos(np.clip(p[:, 1] / r, -1, 1)) / np.pi], 1)


def cylindrical_uvs(vertices, axis: int = 1, height: float | None = None) -> np.ndarray:
    """(V, 2) angle around ``axis`` and normalised height along it."""
    p = _points(vertices)
    axis = as_int(axis, "axis", minimum=0, maximum=2)
    a, b = [(1, 2), (2, 0), (0, 1)][axis]
    h = p[:, axis]
    if height is not None:
        height = as_scalar(height, "height", minimum=0.0, exclusive=True)
    span = height if height is not None else max(h.max() - h.min(), 1e-300)
    return np.stack([np.arctan2(p[:, a], p[:, b]) / (2 * np.pi) + 0.5, (h - h.min()) / span], 1)


def planar_uvs(vertices, axis: int = 2) -> np.ndarray:
    """(V, 2) projection along ``axis``, normalised to the bounding square."""
    p = _points(vertices)
    axis = as_int(axis, "axis", minimum=0, maximum=2)
    a, b = [(1, 2), (2, 0), (0, 1)][axis]
    lo = p.min(axis=0)
    span = max((p.max(axis=0) - lo)[[a, b]].max(), 1e-300)
    return np.stack([(p[:, a] - lo[a]) / span, (p[:, b] - lo[b]) / span], 1)


def tangent_frames(vertices, faces, uvs, face_normals) -> np.ndarray:
    """Per-face surface derivatives ``Pu = dP/du`` and ``Pv = dP/dv``.

    Triangles with a degenerate UV map (zero area in UV space) get an
    arbitrary orthogonal frame in their plane, scaled like their edges, so
    that bumps on them stay finite instead of NaN.

    Returns
    -------
    (F, 6) float64
        ``Pu`` then ``Pv``.
    """
    vertices = _points(vertices)
    faces = as_array(faces, "faces", dtype=np.int64, shape=(None, 3))
    if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise ValueError(f"faces: vertex index {int(faces.max() if faces.min() >= 0 else faces.min())} "
                         f"outside [0, {len(vertices)})")
    uvs = as_array(uvs, "uvs", dtype=np.float64, shape=(len(vertices), 2))
    face_normals = as_array(face_normals, "face_normals", dtype=np.float64, shape=(len(faces), 3))
    e1, e2, d1, d2, det = face_edges(vertices, faces, uvs)
    edge = np.maximum(np.linalg.norm(e1, axis=1), np.linalg.norm(e2, axis=1))
    uv_edge = np.maximum(np.linalg.norm(d1, axis=1), np.linalg.norm(d2, axis=1))
    ok = np.abs(det) > 1e-12 * np.maximum(uv_edge**2, 1e-300)
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    pu = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * inv[:, None]
    pv = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * inv[:, None]
    bad = ~ok | ~np.all(np.isfinite(pu), axis=1) | ~np.all(np.isfinite(pv), axis=1)
    if np.any(bad):
        n = face_normals[bad]
        # Any unit vector orthogonal to n, then n x that; a face with no
        # normal at all gets the world axes.
        helper = np.where(np.abs(n[:, 0:1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
        t = np.cross(n, helper)
        tl = np.linalg.norm(t, axis=1, keepdims=True)
        t = np.where(tl > 0, t / np.where(tl > 0, tl, 1), np.array([[1.0, 0, 0]]))
        b = np.cross(n, t)
        b = np.where(np.linalg.norm(b, axis=1, keepdims=True) > 0, b, np.array([[0, 1.0, 0]]))
        s = np.where(edge[bad] > 0, edge[bad], 1.0)[:, None]
        pu[bad] = t * s
        pv[bad] = b * s
    return np.concatenate([pu, pv], axis=1)
