"""Points of the visible surface with their tracks: COLMAP's ``points3D`` for a rendered view set.

Gaussian-splatting trainers start from the sparse points of a COLMAP model. A rendered set
knows its surface exactly, so :func:`surface_points` samples it instead of triangulating:

* Per view, a deterministic subsample of the pixels whose centre ray hits the scene
  (``per_view`` of them, evenly spaced in row-major order): each hit is a point, its colour
  the view's image at that pixel.
* Each point's track: every view it projects into (inside the image, in front of the camera,
  lens included) with nothing in front of it (a ray from that view's eye to the point meets no
  surface before ``1 - 1e-4`` of the way). Its observation there is its projection: exact, so
  the reprojection error a reader computes is the rounding of the text (about 1e-9 px).

Points from different views are not merged (two views seeing one patch give two nearby
points), which is what a trainer's initialisation wants: density where the views look.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..common.validate import as_int

__all__ = ["SurfacePoints", "surface_points", "OCCLUSION_MARGIN"]

OCCLUSION_MARGIN = 1e-4  # of the eye-to-point distance: a surface nearer than this hides the point


class SurfacePoints(NamedTuple):
    """Sampled surface points and where each view sees them.

    Attributes
    ----------
    xyz : (N, 3) float64
        World coordinates.
    rgb : (N, 3) uint8
        Colour of the pixel each point was sampled at.
    observations : list of (ids, uv)
        Per view: ``ids`` (M,) int64, the points it sees in increasing order, and ``uv``
        (M, 2) float64 their OpenCV pixel coordinates (centre of pixel ``(i, j)`` at ``(i, j)``).
    """

    xyz: np.ndarray
    rgb: np.ndarray
    observations: list

    @property
    def track_lengths(self) -> np.ndarray:
        """(N,) int64: how many views see each point."""
        n = np.zeros(len(self.xyz), np.int64)
        for ids, _ in self.observations:
            np.add.at(n, ids, 1)
        return n


def _view_rays(camera) -> tuple:
    """(H*W, 3) float64 unit world directions of the pixel centres and (H*W,) bool: has a ray."""
    from ..visibility.distortion import ray_directions
    from ..visibility.rays import generate_rays

    if camera.distorted:
        return ray_directions(camera)
    d = generate_rays(camera, dtype=np.float64)[1]
    return d, np.ones(len(d), bool)


def _sample_view(geometry, camera, per_view: int) -> tuple:
    """``(xyz (M, 3), flat pixel indices (M,))`` of view ``camera``'s evenly spaced hits."""
    from ..visibility.cast import cast_camera

    hits = cast_camera(geometry, camera)
    hit = np.flatnonzero(hits.prim.ravel() >= 0)
    if not hit.size or per_view == 0:
        return np.empty((0, 3)), hit[:0]
    step = -(-hit.size // per_view)  # ceil: at most per_view
    pick = hit[step // 2::step]
    d, _ = _view_rays(camera)
    t = hits.t.ravel()[pick].astype(np.float64)
    return camera.eye + t[:, None] * d[pick], pick


def _seen(geometry, camera, xyz) -> tuple:
    """``(mask (N,), uv (N, 2))``: the points ``camera`` sees, and their OpenCV pixel coordinates."""
    from ..scene.projection import project_points
    from ..visibility.cast import cast_rays

    uv, _ = project_points(camera, xyz)
    w, h = camera.width, camera.height
    inside = np.isfinite(uv).all(axis=1)
    inside[inside] = ((uv[inside] >= -0.5) & (uv[inside] < [w - 0.5, h - 0.5])).all(axis=1)
    idx = np.flatnonzero(inside)
    if idx.size:
        eye = np.broadcast_to(camera.eye, (idx.size, 3))
        hits = cast_rays(geometry, eye, xyz[idx] - camera.eye, 0.0, 1.0 - OCCLUSION_MARGIN)
        inside[idx[hits.prim >= 0]] = False  # a surface before the point
    return inside, uv


def surface_points(geometry, cameras, images, per_view: int = 1000) -> SurfacePoints:
    """Sample the surface the views see, with each point's track (see the module docstring).

    Parameters
    ----------
    geometry : Scene or SceneGeometry
    cameras : sequence of Camera
        Perspective.
    images : sequence of (H, W, 3) uint8
        Each view's rendered image (the points' colours).
    per_view : int
        Points sampled per view (at most; fewer where fewer pixels hit). 0: none.

    Returns
    -------
    SurfacePoints
    """
    from ..scene.scene import as_geometry

    geometry = as_geometry(geometry)
    per_view = as_int(per_view, "per_view", minimum=0)
    if len(images) != len(cameras):
        raise ValueError(f"images: expected one per camera ({len(cameras)}), got {len(images)}")
    xyz, rgb, counts = [], [], []
    for k, (cam, image) in enumerate(zip(cameras, images)):
        image = np.asarray(image)
        if image.shape != (cam.height, cam.width, 3) or image.dtype != np.uint8:
            raise ValueError(f"images[{k}]: expected ({cam.height}, {cam.width}, 3) uint8, got {image.dtype} "
                             f"{image.shape}")
        p, pick = _sample_view(geometry, cam, per_view)
        xyz.append(p)
        rgb.append(image.reshape(-1, 3)[pick])
        counts.append(len(p))
    xyz = np.concatenate(xyz) if xyz else np.empty((0, 3))
    rgb = np.concatenate(rgb) if rgb else np.empty((0, 3), np.uint8)
    source = np.repeat(np.arange(len(cameras)), counts)
    observations = []
    for k, cam in enumerate(cameras):
        seen, uv = _seen(geometry, cam, xyz)
        seen |= source == k  # sampled there: its own view sees it (its projection is that pixel)
        ids = np.flatnonzero(seen)
        observations.append((ids.astype(np.int64), uv[ids]))
    return SurfacePoints(xyz, rgb.astype(np.uint8), observations)
