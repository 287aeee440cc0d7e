"""Wireframe, vertex and normal overlays, drawn exactly from the hit buffer.

Method: analytic, per pixel, from the projected triangle that the pixel's
ray hit (no barycentric derivatives, so no error at triangle borders or
under perspective). An edge ``(p, q)`` projects to a straight line in the
image: the points whose ray lies in the plane through the edge and the eye
(perspective; the plane through the edge along the view direction,
orthographic). With that plane's normal ``n``, the line is ``f(x, y) = c +
sx (n . R) + sy (n . U) = 0`` in the normalised screen coordinates ``sx, sy``
of :func:`raycast_shade.visibility.rays.pixel_ray` (``R``, ``U`` the camera's
half-extent vectors; ``c = n . forward``, or ``n . (eye - p)``
orthographic), so ``f`` is affine in pixel coordinates and ``|f| / |grad f|``
is the exact distance, in pixels, from the pixel centre to the projected
edge line; it holds for vertices behind the eye too. A pixel centre inside
a triangle is nearest the boundary on the line of its nearest edge (the
triangle is convex), so:

* wireframe: a pixel is on an edge when that distance is below ``width / 2``;
* vertices: a pixel is on a dot when its centre is within ``radius`` pixels
  of the nearest projected corner of its own triangle;
* normals: short segments from each visible vertex along its shading normal,
  ``length`` world units, projected with the camera and drawn ``width``
  pixels wide.

Only what the hit buffer shows is drawn: hidden edges and vertices are not,
and a silhouette edge gets the half of its line that lies on its triangle.
The plain-NumPy twin is :mod:`raycast_shade.study.overlay_reference`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..common.parallel import KERNEL, in_parts, share
from ..common.layout import CAM_EYE, CAM_FORWARD, CAM_HEIGHT, CAM_ORTHO, CAM_RIGHT, CAM_UP, CAM_WIDTH
from ..common.validate import as_array, as_bool, as_rgb, as_scalar
from ..visibility.rays import camera_frame
from .display import ImageArray

__all__ = ["distances", "overlay", "normal_glyphs"]


@njit(cache=True)
def _screen(cam, px, py, pz):
    """Pixel coordinates (x, y) of re-centred point ``p``, and its depth along the view axis."""
    ex = px - cam[CAM_EYE + 0]
    ey = py - cam[CAM_EYE + 1]
    ez = pz - cam[CAM_EYE + 2]
    z = ex * cam[CAM_FORWARD + 0] + ey * cam[CAM_FORWARD + 1] + ez * cam[CAM_FORWARD + 2]
    r2 = cam[CAM_RIGHT + 0] * cam[CAM_RIGHT + 0] + cam[CAM_RIGHT + 1] * cam[CAM_RIGHT + 1] + cam[CAM_RIGHT + 2] * cam[CAM_RIGHT + 2]
    u2 = cam[CAM_UP + 0] * cam[CAM_UP + 0] + cam[CAM_UP + 1] * cam[CAM_UP + 1] + cam[CAM_UP + 2] * cam[CAM_UP + 2]
    sx = (ex * cam[CAM_RIGHT + 0] + ey * cam[CAM_RIGHT + 1] + ez * cam[CAM_RIGHT + 2]) / r2
    sy = (ex * cam[CAM_UP + 0] + ey * cam[CAM_UP + 1] + ez * cam[CAM_UP + 2]) / u2
    if cam[CAM_ORTHO] == 0.0:
        if not z > 0.0:
            return np.inf, np.inf, z
        sx /= z
        sy /= z
    return 0.5 * (sx + 1.0) * cam[CAM_WIDTH], 0.5 * (1.0 - sy) * cam[CAM_HEIGHT], z


@njit(cache=True)
def _edge_distance(cam, vertices, i, j, sx, sy):
    """Distance in pixels from screen point (sx, sy) to the projected line of edge (i, j)."""
    if cam[CAM_ORTHO] != 0.0:  # plane through the edge along the view direction
        ax = vertices[j, 0] - vertices[i, 0]
        ay = vertices[j, 1] - vertices[i, 1]
        az = vertices[j, 2] - vertices[i, 2]
        bx, by, bz = cam[CAM_FORWARD + 0], cam[CAM_FORWARD + 1], cam[CAM_FORWARD + 2]
    else:  # plane through the edge and the eye
        ax = vertices[i, 0] - cam[CAM_EYE + 0]
        ay = vertices[i, 1] - cam[CAM_EYE + 1]
        az = vertices[i, 2] - cam[CAM_EYE + 2]
        bx = vertices[j, 0] - cam[CAM_EYE + 0]
        by = vertices[j, 1] - cam[CAM_EYE + 1]
        bz = vertices[j, 2] - cam[CAM_EYE + 2]
    nx = ay * bz - az * by
    ny = az * bx - ax * bz
    nz = ax * by - ay * bx
    if cam[CAM_ORTHO] != 0.0:
        c = nx * (cam[CAM_EYE + 0] - vertices[i, 0]) + ny * (cam[CAM_EYE + 1] - vertices[i, 1]) + nz * (cam[CAM_EYE + 2] - vertices[i, 2])
    else:
        c = nx * cam[CAM_FORWARD + 0] + ny * cam[CAM_FORWARD + 1] + nz * cam[CAM_FORWARD + 2]
    a = nx * cam[CAM_RIGHT + 0] + ny * cam[CAM_RIGHT + 1] + nz * cam[CAM_RIGHT + 2]
    b = nx * cam[CAM_UP + 0] + ny * cam[CAM_UP + 1] + nz * cam[CAM_UP + 2]
    gx = 2.0 * a / cam[CAM_WIDTH]  # d f / d pixel x
    gy = -2.0 * b / cam[CAM_HEIGHT]  # d f / d pixel y (rows go down)
    g = math.sqrt(gx * gx + gy * gy)
    if not g > 0.0:
        return np.inf  # the edge is seen end-on: its line is a point
    return abs(c + sx * a + sy * b) / g


def _distances_kernel(prim, geom, face_offsets, faces, vertices, cam):
    """(H, W) distances in pixels to the nearest edge line and corner of each pixel's triangle
    (``inf`` on the background)."""
    h, w = prim.shape
    edge = np.full((h, w), np.inf)
    corner = np.full((h, w), np.inf)
    _distances_parts(prim, geom, face_offsets, faces, vertices, cam, edge, corner)
    return edge, corner


@in_parts
@njit(**KERNEL)
def _distances_parts(prim, geom, face_offsets, faces, vertices, cam, edge, corner, part):
    """:func:`_distances_kernel` for this part's rows."""
    y0, y1 = share(prim.shape[0], part)
    w = prim.shape[1]
    for y in range(y0, y1):
        sy = 1.0 - 2.0 * (y + 0.5) / cam[CAM_HEIGHT]
        for x in range(w):
            if prim[y, x] < 0:
                continue
            sx = 2.0 * (x + 0.5) / cam[CAM_WIDTH] - 1.0
            f = face_offsets[geom[y, x]] + prim[y, x]
            best_e = np.inf
            best_c = np.inf
            for k in range(3):
                i = faces[f, k]
                d = _edge_distance(cam, vertices, i, faces[f, (k + 1) % 3], sx, sy)
                best_e = min(best_e, d)
                qx, qy, _ = _screen(cam, vertices[i, 0], vertices[i, 1], vertices[i, 2])
                if np.isfinite(qx):
                    best_c = min(best_c, math.sqrt((qx - x - 0.5) ** 2 + (qy - y - 0.5) ** 2))
            edge[y, x] = best_e
            corner[y, x] = best_c
    return edge, corner


@njit(cache=True)
def _segment_kernel(mask, x0, y0, x1, y1, half):
    """Set ``mask`` where the pixel centre lies within ``half`` pixels of segment (x0, y0)-(x1, y1)."""
    h, w = mask.shape
    dx = x1 - x0
    dy = y1 - y0
    ll = dx * dx + dy * dy
    for y in range(max(0, int(math.floor(min(y0, y1) - half))), min(h, int(math.ceil(max(y0, y1) + half)) + 1)):
        for x in range(max(0, int(math.floor(min(x0, x1) - half))), min(w, int(math.ceil(max(x0, x1) + half)) + 1)):
            cx = x + 0.5 - x0
            cy = y + 0.5 - y0
            s = 0.0 if ll == 0.0 else min(1.0, max(0.0, (cx * dx + cy * dy) / ll))
            if (cx - s * dx) ** 2 + (cy - s * dy) ** 2 < half * half:
                mask[y, x] = True


@njit(cache=True)
def _glyphs_kernel(vertices, normals, cam, t, length, half, tolerance, mask):
    """Draw each visible vertex's normal as a segment ``length`` long into ``mask``."""
    h, w = t.shape
    for v in range(vertices.shape[0]):
        n2 = normals[v, 0] ** 2 + normals[v, 1] ** 2 + normals[v, 2] ** 2
        if n2 == 0.0:
            continue
        x0, y0, z0 = _screen(cam, vertices[v, 0], vertices[v, 1], vertices[v, 2])
        if not (np.isfinite(x0) and 0.0 <= x0 < w and 0.0 <= y0 < h):
            continue
        # Visible when nothing nearer covers the vertex's pixel (t is along the unit ray,
        # or from the image plane orthographic).
        if cam[CAM_ORTHO] != 0.0:
            dist = z0
        else:
            dist = math.sqrt((vertices[v, 0] - cam[CAM_EYE + 0]) ** 2 + (vertices[v, 1] - cam[CAM_EYE + 1]) ** 2
                             + (vertices[v, 2] - cam[CAM_EYE + 2]) ** 2)
        if t[int(y0), int(x0)] < dist - tolerance:
            continue
        s = length / math.sqrt(n2)
        x1, y1, _ = _screen(cam, vertices[v, 0] + s * normals[v, 0], vertices[v, 1] + s * normals[v, 1],
                            vertices[v, 2] + s * normals[v, 2])
        if np.isfinite(x1):
            _segment_kernel(mask, x0, y0, x1, y1, half)


def _geometry(frame):
    # By its fields, not isinstance: frame.py imports this module (Frame.overlay).
    if not all(hasattr(frame, field) for field in ("image", "hits", "scene", "camera")):
        raise TypeError(f"frame: expected a Frame from raycast_shade.render, got {type(frame).__name__}")
    if frame.scene is None or frame.camera is None:
        raise ValueError("frame: overlays need the frame's scene and camera (a Frame from raycast_shade.render)")
    if frame.camera.distorted:  # the overlays project edges and corners through a pinhole
        raise ValueError("frame: overlays draw a pinhole projection, but the frame's camera has lens distortion; "
                         "render it with distortion=None to draw overlays")
    return frame.scene.geometry


def distances(frame):
    """Per-pixel distances, in pixels, to the frame's projected triangle edges and corners.

    Parameters
    ----------
    frame : Frame

    Returns
    -------
    edge : (H, W) float64
        Distance from the pixel centre to the nearest edge line of the
        triangle the pixel shows; ``inf`` on the background.
    corner : (H, W) float64
        Distance to the nearest projected corner of that triangle; ``inf``
        on the background (and for corners behind the eye).
    """
    geo = _geometry(frame)
    cam = camera_frame(frame.camera, geo.origin)
    return _distances_kernel(frame.hits.prim, frame.hits.geom, geo.face_offsets, geo.faces, geo.vertices, cam)


def normal_glyphs(frame, length: float | None = None, width: float = 1.0) -> np.ndarray:
    """(H, W) bool: the vertex normals of the frame's scene as short segments.

    Parameters
    ----------
    frame : Frame
    length : float, optional
        World units; by default half the mean edge length of the scene's triangles.
    width : float
        Pixels.
    """
    geo = _geometry(frame)
    if length is None:
        e = geo.vertices[geo.faces]
        length = 0.5 * float(np.mean(np.linalg.norm(e[:, 1] - e[:, 0], axis=1)))
    length = as_scalar(length, "length", minimum=0.0, exclusive=True)
    width = as_scalar(width, "width", minimum=0.0, exclusive=True)
    cam = camera_frame(frame.camera, geo.origin)
    mask = np.zeros(frame.hits.shape, np.bool_)
    _glyphs_kernel(geo.vertices, geo.normals, cam, frame.hits.t, length, 0.5 * width, 1e-3 * geo.scale, mask)
    return mask


def overlay(frame, wireframe: bool = True, vertices: bool = False, normals: bool = False, width: float = 1.0,
            color=(1.0, 1.0, 1.0), radius: float | None = None, length: float | None = None,
            image=None) -> np.ndarray:
    """The frame's image with its mesh drawn over it.

    Parameters
    ----------
    frame : Frame
    wireframe : bool
        Pixels within ``width / 2`` pixels of a projected triangle edge.
    vertices : bool
        Pixels within ``radius`` pixels of a projected vertex.
    normals : bool
        Vertex normals as segments ``length`` world units long (see :func:`normal_glyphs`).
    width : float
        Line width in pixels, ``> 0``.
    color : float or (3,) float
        Linear RGB of the overlay.
    radius : float, optional
        Vertex dot radius in pixels; ``width`` by default.
    length : float, optional
        Normal glyph length in world units.
    image : (H, W, 3) float, optional
        The picture to draw on, linear: finite and ``>= 0``; ``frame.image``
        by default (pass an earlier overlay's result to layer colours).

    Returns
    -------
    (H, W, 3) float32 ImageArray
        A new linear image: an ndarray that a notebook shows as its picture
        (:class:`~raycast_shade.output.display.ImageArray`, tone-mapped with the
        frame's tone options, pixels upscaled as squares; ``.show(scale=...)``).

    Raises
    ------
    TypeError, ValueError
        Naming the argument: ``image`` (or ``frame.image``) not numbers, of
        another shape, NaN, infinite or negative; a bad ``width``, ``radius``,
        ``length`` or ``color``.
    """
    _geometry(frame)
    wireframe, vertices, normals = (as_bool(v, n) for v, n in ((wireframe, "wireframe"), (vertices, "vertices"),
                                                               (normals, "normals")))
    width = as_scalar(width, "width", minimum=0.0, exclusive=True)
    radius = width if radius is None else as_scalar(radius, "radius", minimum=0.0, exclusive=True)
    if length is not None:  # checked even when no normals are drawn: a bad value is never ignored
        as_scalar(length, "length", minimum=0.0, exclusive=True)
    rgb = as_rgb(color, "color").astype(np.float32)
    field = "frame.image" if image is None else "image"
    # A linear image: NaN or a negative value would pass through to the tone map unseen.
    out = as_array(frame.image if image is None else image, field, dtype=np.float32, copy=True)
    if out.shape != frame.image.shape:
        raise ValueError(f"{field}: expected shape {frame.image.shape}, got {out.shape}")
    if np.any(out < 0.0):
        bad = tuple(int(i) for i in np.argwhere(out < 0.0)[0])
        raise ValueError(f"{field}: a linear image, >= 0; got {float(out[bad]):g} at index {bad}")
    mask = np.zeros(frame.hits.shape, np.bool_)
    if wireframe or vertices:
        edge, corner = distances(frame)
        if wireframe:
            mask |= edge < 0.5 * width
        if vertices:
            mask |= corner < radius
    if normals:
        mask |= normal_glyphs(frame, length, width)
    out[mask] = rgb
    out = out.view(ImageArray)
    out.tone = dict(getattr(frame, "tone", {}) or {})
    return out
