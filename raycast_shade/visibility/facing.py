"""Back faces of single-sided models in view: the one thing glTF's ``doubleSided: false`` asks
that the lecture's renderer does not do.

Every surface is lit from the side it is seen from and back faces are drawn (two-sided
lighting, :mod:`raycast_shade.shading.surface`). A file that marks a material single-sided
expects a culling renderer to show what lies behind its back faces instead; where the camera
sees such back faces, :func:`warn_single_sided` says so, naming the model and the share of
what is seen of it, so the difference is never silent. The share is measured on a coarse grid
of camera rays (at most 64 x 48, one ray through each cell's centre), cast through the frame's
own BVH: about 3,000 rays, and only for scenes with a single-sided model.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..common.layout import CAM_EYE, CAM_FORWARD, CAM_ORTHO, CAM_RIGHT, CAM_UP
from ..common.warnings import SingleSidedWarning
from .cast import cast_recentred
from .rays import camera_frame

__all__ = ["back_face_shares", "warn_single_sided", "GRID", "MIN_SHARE"]

GRID = (64, 48)  # columns, rows of the probe grid (fewer on a smaller image)
MIN_SHARE = 0.005  # below this share of a model's probes, back faces are a grazing edge: no warning


def back_face_shares(scene, camera) -> dict:
    """Per single-sided model, the share of its probe hits that land on a back face.

    Parameters
    ----------
    scene : Scene
    camera : Camera

    Returns
    -------
    dict of int to float
        Model index -> back-face hits / hits on that model, for the models whose material has
        ``double_sided=False`` and that the grid sees at all.
    """
    single = [g for g, m in enumerate(scene.models) if not m.material.double_sided]
    if not single:
        return {}
    geo = scene.geometry
    cam = camera_frame(camera, geo.origin)
    nx, ny = min(camera.width, GRID[0]), min(camera.height, GRID[1])
    sx = 2.0 * (np.arange(nx) + 0.5) / nx - 1.0  # the cell centres, as pixel_ray's screen coordinates
    sy = 1.0 - 2.0 * (np.arange(ny) + 0.5) / ny
    sx, sy = (a.ravel() for a in np.meshgrid(sx, sy))
    right, up = cam[CAM_RIGHT:CAM_RIGHT + 3], cam[CAM_UP:CAM_UP + 3]
    eye, fwd = cam[CAM_EYE:CAM_EYE + 3], cam[CAM_FORWARD:CAM_FORWARD + 3]
    spread = sx[:, None] * right + sy[:, None] * up
    if cam[CAM_ORTHO] != 0.0:
        origins, directions = eye + spread, np.broadcast_to(fwd, spread.shape)
    else:
        origins, directions = np.broadcast_to(eye, spread.shape), fwd + spread
        directions = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    n = len(sx)
    hits = cast_recentred(geo, np.ascontiguousarray(origins, np.float64), np.ascontiguousarray(directions, np.float64),
                          np.zeros(n), np.full(n, np.inf))
    seen = hits.prim >= 0
    faces = geo.face_offsets[np.maximum(hits.geom, 0)] + np.maximum(hits.prim, 0)
    back = seen & (np.einsum("ij,ij->i", directions, geo.face_normals[faces]) > 0.0)
    out = {}
    for g in single:
        mine = seen & (hits.geom == g)
        if mine.any():
            out[g] = float(back[mine].sum()) / float(mine.sum())
    return out


def warn_single_sided(scene, camera, stacklevel: int = 3) -> dict:
    """Warn (:class:`~raycast_shade.SingleSidedWarning`) for each single-sided model whose back
    faces make at least :data:`MIN_SHARE` of what the camera sees of it; returns
    :func:`back_face_shares`."""
    shares = back_face_shares(scene, camera)
    for g, share in shares.items():
        if share >= MIN_SHARE:
            model = scene.models[g]
            warnings.warn(
                f"scene.models[{g}] ({model.name}): its material {model.material.name!r} is single-sided "
                f"(glTF doubleSided: false) and about {100.0 * share:.1f}% of what the camera sees of it is "
                "back faces, drawn and lit from the side seen where a culling renderer shows what lies "
                "behind them: set the material's double_sided=True to silence this",
                SingleSidedWarning, stacklevel=stacklevel)
    return shares
