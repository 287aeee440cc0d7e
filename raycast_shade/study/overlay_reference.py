"""Plain-NumPy twin of :func:`raycast_shade.output.overlays.distances`, for tests.

The same analytic method (see :mod:`raycast_shade.output.overlays`), written
with whole-image arrays: each pixel's triangle's edges give planes through
the eye (or along the view direction), whose traces on the image are the
projected edge lines.
"""

from __future__ import annotations

import numpy as np

from ..common.layout import CAM_EYE, CAM_FORWARD, CAM_HEIGHT, CAM_ORTHO, CAM_RIGHT, CAM_UP, CAM_WIDTH
from ..visibility.rays import camera_frame

__all__ = ["distances_numpy"]


def distances_numpy(frame):
    """(edge, corner): (H, W) float64 distances in pixels, ``inf`` on the background.

    Parameters
    ----------
    frame : Frame
    """
    geo = frame.scene.geometry
    cam = camera_frame(frame.camera, geo.origin)
    eye, r, u, fwd = cam[CAM_EYE:CAM_EYE + 3], cam[CAM_RIGHT:CAM_RIGHT + 3], cam[CAM_UP:CAM_UP + 3], cam[CAM_FORWARD:CAM_FORWARD + 3]
    ortho = cam[CAM_ORTHO] != 0.0
    w, h = int(cam[CAM_WIDTH]), int(cam[CAM_HEIGHT])
    hit = frame.hits.prim >= 0
    ys, xs = np.nonzero(hit)
    faces = geo.faces[geo.face_offsets[frame.hits.geom[hit]] + frame.hits.prim[hit]]
    p = geo.vertices[faces]  # (N, 3 corners, 3)
    sx = 2.0 * (xs + 0.5) / w - 1.0
    sy = 1.0 - 2.0 * (ys + 0.5) / h
    edges, corners = [], []
    for k in range(3):
        a, b = p[:, k], p[:, (k + 1) % 3]
        if ortho:
            n = np.cross(b - a, fwd)
            c = np.einsum("ij,ij->i", n, eye - a)
        else:
            n = np.cross(a - eye, b - eye)
            c = n @ fwd
        na, nb = n @ r, n @ u
        g = np.hypot(2.0 * na / w, 2.0 * nb / h)
        with np.errstate(divide="ignore", invalid="ignore"):
            edges.append(np.where(g > 0, np.abs(c + sx * na + sy * nb) / g, np.inf))
        e = a - eye
        z = e @ fwd
        qx, qy = (e @ r) / (r @ r), (e @ u) / (u @ u)
        if not ortho:
            with np.errstate(divide="ignore", invalid="ignore"):
                qx, qy = np.where(z > 0, qx / z, np.inf), np.where(z > 0, qy / z, np.inf)
        px, py = 0.5 * (qx + 1.0) * w, 0.5 * (1.0 - qy) * h
        with np.errstate(invalid="ignore"):
            corners.append(np.where(np.isfinite(px), np.hypot(px - xs - 0.5, py - ys - 0.5), np.inf))
    edge = np.full((h, w), np.inf)
    corner = np.full((h, w), np.inf)
    edge[hit] = np.min(edges, axis=0)
    corner[hit] = np.min(corners, axis=0)
    return edge, corner
