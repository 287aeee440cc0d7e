"""Plain-NumPy twins of the scene, visibility and output kernels.

Each function here computes what one Numba kernel of the library computes,
vectorised and without Numba, so that the tests can hold the kernel to it
(:mod:`.reference` holds the shading twins). They live in the study tools
rather than beside their kernels so that the library modules carry only
what renders.

- :func:`face_normals_numpy`: :func:`raycast_shade.scene.normals.face_normals`;
- :func:`corner_weights_numpy`: the corner weights of ``scene.normals._faces_kernel``;
- :func:`generate_rays_numpy`: :func:`raycast_shade.visibility.rays.generate_rays`;
- :func:`to_screen_space_numpy`: :func:`raycast_shade.visibility.interpolation.to_screen_space`;
- :func:`suspicious_numpy`: the per-pixel test of ``visibility.holes`` (a ray that slipped
  through a vertex), which its row count and gather kernels apply; :func:`isolated_misses_numpy`,
  its misses alone (the benchmarks count them in a frame);
- :func:`to_uint8_numpy`: :func:`raycast_shade.output.tonemap.to_uint8`.
"""

from __future__ import annotations

import numpy as np

from ..common.layout import CAM_EYE, CAM_FORWARD, CAM_RIGHT, CAM_UP

from ..visibility.hits import HitBuffer, check_hits
from ..visibility.interpolation import vertex_depths
from ..visibility.rays import camera_frame

__all__ = ["face_normals_numpy", "corner_weights_numpy", "generate_rays_numpy", "to_screen_space_numpy",
           "suspicious_numpy", "isolated_misses_numpy", "to_uint8_numpy"]


# -- scene: normals --------------------------------------------------------------------------------
def face_normals_numpy(vertices: np.ndarray, faces: np.ndarray):
    """Plain-NumPy twin of :func:`~raycast_shade.scene.normals.face_normals`.

    Parameters
    ----------
    vertices : (V, 3) float64
    faces : (F, 3) int

    Returns
    -------
    normals : (F, 3) float64
        Unit normals; exactly zero for zero-area faces.
    areas : (F,) float64
    """
    v0 = vertices[faces[:, 0]]
    cross = np.cross(vertices[faces[:, 1]] - v0, vertices[faces[:, 2]] - v0)
    length = np.linalg.norm(cross, axis=1)
    # Relative threshold: a face is degenerate when its cross product is tiny
    # compared with its edge lengths (float64 rounding of collinear points).
    scale = np.maximum(
        np.einsum("ij,ij->i", vertices[faces[:, 1]] - v0, vertices[faces[:, 1]] - v0),
        np.einsum("ij,ij->i", vertices[faces[:, 2]] - v0, vertices[faces[:, 2]] - v0),
    )
    ok = length > 1e-14 * scale
    normals = np.zeros_like(cross)
    normals[ok] = cross[ok] / length[ok, None]
    areas = np.where(ok, 0.5 * length, 0.0)
    return normals, areas


def corner_weights_numpy(vertices, faces, fnormals, areas, weighting: str) -> np.ndarray:
    """Weight of each face corner in its vertex's average normal.

    Plain-NumPy twin of the weights ``scene.normals._faces_kernel`` returns.

    Parameters
    ----------
    vertices : (V, 3) float64
    faces : (F, 3) int
    fnormals : (F, 3) float64
        From :func:`face_normals_numpy`; zero rows mark degenerate faces.
    areas : (F,) float64
    weighting : {"uniform", "area", "angle"}

    Returns
    -------
    (F, 3) float64
        Zero on degenerate faces.
    """
    valid = np.any(fnormals != 0.0, axis=1)
    if weighting == "uniform":
        w = np.repeat(valid.astype(np.float64)[:, None], 3, axis=1)
    elif weighting == "area":
        w = np.repeat(areas[:, None], 3, axis=1)
    else:  # angle at each corner, robust form atan2(|a x b|, a.b)
        p = vertices[faces]
        w = np.empty(faces.shape, np.float64)
        for k in range(3):
            a = p[:, (k + 1) % 3] - p[:, k]
            b = p[:, (k + 2) % 3] - p[:, k]
            w[:, k] = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))
        w[~valid] = 0.0
    return w


# -- visibility: camera rays and screen-space weights ------------------------------------------------
def generate_rays_numpy(camera, origin=np.zeros(3)):
    """Plain-NumPy twin of :func:`~raycast_shade.visibility.rays.generate_rays`, in float64.

    Parameters
    ----------
    camera : Camera
    origin : (3,) float64
        Scene re-centring offset, subtracted from the eye.

    Returns
    -------
    origins, directions : (H*W, 3) float64
        Row-major, one ray per pixel centre; unit directions.
    """
    cam = camera_frame(camera, origin)
    w, h = camera.width, camera.height
    ys, xs = np.mgrid[0:h, 0:w]
    sx = (2.0 * (xs + 0.5) / w - 1.0).reshape(-1, 1)
    sy = (1.0 - 2.0 * (ys + 0.5) / h).reshape(-1, 1)
    eye, right = cam[CAM_EYE:CAM_EYE + 3], cam[CAM_RIGHT:CAM_RIGHT + 3]
    up, fwd = cam[CAM_UP:CAM_UP + 3], cam[CAM_FORWARD:CAM_FORWARD + 3]
    if camera.orthographic:
        origins = eye + sx * right + sy * up
        directions = np.broadcast_to(fwd, origins.shape).copy()
    else:
        directions = fwd + sx * right + sy * up
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        origins = np.broadcast_to(eye, directions.shape).copy()
    return origins, directions


def to_screen_space_numpy(hits, geometry, camera) -> HitBuffer:
    """Plain-NumPy twin of :func:`~raycast_shade.visibility.interpolation.to_screen_space`.

    Parameters
    ----------
    hits : HitBuffer
        (H, W) buffers, validated against ``geometry`` as the kernel's are.
    geometry : SceneGeometry
    camera : Camera

    Returns
    -------
    HitBuffer
        Screen-space (affine) ``u, v``; ``prim``, ``geom``, ``t`` shared with ``hits``.
    """
    geometry = check_hits(hits, geometry, camera)
    u = hits.u.astype(np.float64)
    v = hits.v.astype(np.float64)
    if not camera.orthographic:
        hit = hits.prim >= 0
        f = geometry.face_offsets[hits.geom[hit]] + hits.prim[hit]
        w = vertex_depths(geometry, camera)[geometry.faces[f]]  # (N, 3)
        lam = np.stack([1.0 - u[hit] - v[hit], u[hit], v[hit]], axis=1)
        a = lam * w
        den = a.sum(axis=1)
        ok = np.all(w > 0.0, axis=1) & (den > 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            u[hit] = np.where(ok, a[:, 1] / den, u[hit])
            v[hit] = np.where(ok, a[:, 2] / den, v[hit])
    return HitBuffer(prim=hits.prim, geom=hits.geom, u=u.astype(np.float32), v=v.astype(np.float32), t=hits.t)


# -- visibility: the marks of a ray that slipped through a vertex -------------------------------------
def suspicious_numpy(prim: np.ndarray, t: np.ndarray, jump: float) -> np.ndarray:
    """Plain-NumPy twin of the per-pixel test of :mod:`raycast_shade.visibility.holes`.

    A pixel is flagged when its left and right (or upper and lower) neighbours are hits and it
    is a miss, or a hit farther than both of them by ``jump`` of their depth.

    Parameters
    ----------
    prim : (H, W) int32
        Triangle index, < 0 on a miss.
    t : (H, W) float32
        Ray distance.
    jump : float
        The depth jump, a fraction of the neighbours' depth.

    Returns
    -------
    (H, W) bool
    """
    hit = prim >= 0
    t = t.astype(np.float64)  # the kernel compares float64 products of the float32 depths
    far = 1.0 + jump
    out = np.zeros(prim.shape, np.bool_)
    mid = (slice(None), slice(1, -1))
    side = hit[:, :-2] & hit[:, 2:] & (~hit[mid] | ((t[mid] > far * t[:, :-2]) & (t[mid] > far * t[:, 2:])))
    out[mid] |= side
    mid = (slice(1, -1), slice(None))
    over = hit[:-2] & hit[2:] & (~hit[mid] | ((t[mid] > far * t[:-2]) & (t[mid] > far * t[2:])))
    out[mid] |= over
    return out


def isolated_misses_numpy(prim: np.ndarray) -> np.ndarray:
    """The misses between two hits, left and right or above and below: the misses
    :func:`suspicious_numpy` flags, whatever the depths.

    Parameters
    ----------
    prim : (H, W) int32
        Triangle index, < 0 on a miss.

    Returns
    -------
    (H, W) bool
    """
    hit = np.pad(prim >= 0, 1, constant_values=False)
    return ~hit[1:-1, 1:-1] & ((hit[1:-1, :-2] & hit[1:-1, 2:]) | (hit[:-2, 1:-1] & hit[2:, 1:-1]))


# -- output: tone mapping ------------------------------------------------------------------------------
def to_uint8_numpy(image, exposure: float = 1.0, tonemap: str = "clamp", gamma="srgb") -> np.ndarray:
    """Plain-NumPy twin of :func:`~raycast_shade.output.tonemap.to_uint8`.

    Parameters
    ----------
    image : (...) float array
        Linear radiance, any shape.
    exposure : float
    tonemap : {"clamp", "reinhard", "exponential"}
    gamma : "srgb" or float > 0

    Returns
    -------
    uint8 array, the shape of ``image``
    """
    x = np.asarray(image, np.float64) * exposure
    x = np.where(x > 0.0, x, 0.0)  # negatives and NaN give 0 under every curve
    with np.errstate(invalid="ignore"):
        if tonemap == "reinhard":
            x = np.where(np.isinf(x), 1.0, x / (1.0 + x))
        elif tonemap == "exponential":
            x = -np.expm1(-x)
    x = np.clip(x, 0.0, 1.0)
    if isinstance(gamma, str):
        if gamma != "srgb":
            raise ValueError(f"gamma: expected 'srgb' or a number, got {gamma!r}")
        x = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    else:
        if not (np.isfinite(gamma) and gamma > 0):
            raise ValueError(f"gamma: must be > 0, got {gamma}")
        x = np.power(x, 1.0 / float(gamma))
    return np.rint(x * 255.0).astype(np.uint8)
