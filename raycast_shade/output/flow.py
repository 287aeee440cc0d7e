"""Optical flow and scene flow between two views, exact from each pixel's 3D point.

View A is a scene and a camera; view B another camera, and/or the same
scene with models moved (:func:`move_model`: a rigid or affine transform of
one model, same triangles). For each pixel of A that sees a surface, the
point is recomputed exactly (the pixel's ray against its hit triangle, in
float64), carried to B by the same barycentrics on the same triangle of B's
scene, and projected by B's camera (lens distortion included,
:func:`~raycast_shade.scene.projection.project_points`):

* ``flow`` = B's OpenCV pixel coordinates of the point minus A's pixel
  ``(i, j)`` (OpenCV's pixel centres): the forward flow; swap the views for
  the backward flow;
* ``scene_flow`` = the point in B minus the point in A (world units);
* ``occluded``: the point lands inside B's image but a surface of B's scene
  lies in front of it (a ray from B's eye to the point, cast watertight,
  meets a surface before ``1 - 1e-4`` of the way);
* ``outside``: the point lands outside B's image (or behind its camera).

Conventions follow the buffers (``docs/vision.md``): ``flow[..., 0]`` along
``x`` (columns, right), ``flow[..., 1]`` along ``y`` (rows, down), in pixels.
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["move_model", "pixel_rays", "surface_points", "optical_flow", "OCCLUSION_MARGIN"]

OCCLUSION_MARGIN = 1e-4  # an occluder nearer than this fraction of the distance to the point is not seen


def move_model(scene, index: int, matrix):
    """The scene with model ``index`` moved by a (4, 4) affine transform (same triangles, same order).

    Parameters
    ----------
    scene : Scene
    index : int
        The model.
    matrix : (4, 4) float
        ``x' = M[:3, :3] x + M[:3, 3]``; last row ``[0, 0, 0, 1]``, the 3x3
        part invertible. Given normals are moved by its inverse transpose.

    Returns
    -------
    Scene
    """
    from ..common.validate import as_array, as_instance, as_int
    from ..scene.scene import Scene

    as_instance(scene, "scene", Scene)
    index = as_int(index, "index", minimum=0, maximum=len(scene.models) - 1)
    M = as_array(matrix, "matrix", dtype=np.float64, shape=(4, 4))
    if not np.array_equal(M[3], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"matrix: last row must be [0, 0, 0, 1], got {M[3].tolist()}")
    A = M[:3, :3]
    if not abs(np.linalg.det(A)) > 1e-12:
        raise ValueError("matrix: its 3x3 part is singular")
    model = scene.models[index]
    mesh = model.mesh
    normals = None if mesh.normals is None else mesh.normals @ np.linalg.inv(A)  # rows: (A^-T n)^T
    # A new Mesh of the same fields (dataclasses.replace trips over the colour mode a mesh without
    # colours stores as None).
    moved = type(mesh)(mesh.vertices @ A.T + M[:3, 3], mesh.faces, normals=normals, uvs=mesh.uvs,
                       weighting=mesh.weighting, crease_angle=mesh.crease_angle, name=mesh.name, colors=mesh.colors,
                       color_mode=mesh.color_mode or "auto",
                       tangents=None if mesh.tangents is None else  # tangents move with A, w with its handedness
                       np.c_[mesh.tangents[:, :3] @ A.T, mesh.tangents[:, 3] * np.sign(np.linalg.det(A))])
    models = list(scene.models)
    models[index] = dataclasses.replace(model, mesh=moved)
    return scene.replace(models=models)


def pixel_rays(camera):
    """World-space rays of every pixel centre, as the caster casts them, row-major.

    Returns
    -------
    origins, directions : (H*W, 3) float64
        Unit directions.
    ok : (H*W,) bool
        Pixels that have a ray (False only beyond a fold of a lens model).
    """
    from ..visibility.distortion import ray_directions
    from ..visibility.rays import generate_rays

    if camera.distorted:
        d, ok = ray_directions(camera)
        return np.broadcast_to(camera.eye, d.shape).copy(), d, ok
    o, d = generate_rays(camera, dtype=np.float64)
    return o, d, np.ones(len(d), bool)


def _corners(geo, model, prim):
    face = geo.faces[geo.face_offsets[model] + prim]
    return [geo.vertices[face[:, k]] + geo.origin for k in range(3)]


def _check_own_hits(hits, bary, sel, tol=1e-3, share=0.01):
    """A given buffer's pixels must hit the triangles it names, where it says: each pixel's ray,
    intersected again with its triangle in float64, lands within ``tol`` of the buffer's ``(u, v)``
    (float32 rounding and grazing triangles stay far below it). A buffer of another scene or camera
    with the same sizes passes :func:`check_hits` but fails here on most pixels; more than ``share``
    of them is refused."""
    if not len(sel):
        return
    uv = np.stack([hits.u.ravel()[sel], hits.v.ravel()[sel]], axis=-1).astype(np.float64)
    off = ~(np.abs(bary - uv).max(axis=-1) <= tol)  # NaN (a ray parallel to its triangle) counts as off
    if off.mean() > share:
        k = int(sel[np.argmax(off)])
        raise ValueError(f"hits: not this scene's and camera's hit buffer: at {int(off.sum())} of {len(sel)} hit "
                         f"pixels (the first at x={k % hits.prim.shape[1]}, y={k // hits.prim.shape[1]}) the pixel's "
                         "ray does not meet its triangle where the buffer says (pass the frame of this scene and "
                         "camera, or hits=None)")


def surface_points(scene, camera, hits):
    """Each pixel's exact surface point: its ray against its hit triangle, in float64.

    Parameters
    ----------
    scene : Scene
    camera : Camera
        The camera ``hits`` was cast with.
    hits : HitBuffer
        (H, W).

    Returns
    -------
    points : (N, 3) float64
        World points of the ``N`` pixels with a hit.
    bary : (N, 2) float64
        Their barycentrics ``(u, v)`` on the triangle (vertices 1 and 2).
    index : (N,) int64
        Flat pixel indices (row-major).
    """
    o, d, _ = pixel_rays(camera)
    sel = np.flatnonzero(hits.prim.ravel() >= 0)
    o, d = o[sel], d[sel]
    p0, p1, p2 = _corners(scene.geometry, hits.geom.ravel()[sel], hits.prim.ravel()[sel])
    e1, e2 = p1 - p0, p2 - p0
    pv = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    tv = o - p0
    u = np.einsum("ij,ij->i", tv, pv) / det
    qv = np.cross(tv, e1)
    v = np.einsum("ij,ij->i", d, qv) / det
    t = np.einsum("ij,ij->i", e2, qv) / det
    return o + t[:, None] * d, np.stack([u, v], axis=-1), sel


def _check_same_triangles(a, b):
    if len(a.models) != len(b.models):
        raise ValueError(f"scene_b: expected the same models as scene ({len(a.models)}), got {len(b.models)}")
    for g, (ma, mb) in enumerate(zip(a.models, b.models)):
        if len(ma.mesh.faces) != len(mb.mesh.faces) or not np.array_equal(ma.mesh.faces, mb.mesh.faces):
            raise ValueError(f"scene_b.models[{g}]: other triangles than scene.models[{g}] "
                             "(flow follows each triangle; move models with move_model)")


def _occluded(scene_b, camera_b, points):
    """True where a surface of ``scene_b`` lies between ``camera_b`` and the point."""
    from ..visibility.cast import cast_rays

    if camera_b.orthographic:
        fwd = camera_b.basis[2]
        depth = (points - camera_b.eye) @ fwd
        origins = points - depth[:, None] * fwd
    else:
        origins = np.broadcast_to(camera_b.eye, points.shape)
    directions = points - origins
    n = len(points)
    if n == 0:
        return np.zeros(0, bool)
    hits = cast_rays(scene_b.geometry, origins, directions, 0.0, 1.0 - OCCLUSION_MARGIN)
    return hits.geom >= 0


def optical_flow(scene, camera, scene_b=None, camera_b=None, *, hits=None) -> dict:
    """Forward optical flow, scene flow and occlusion from view A to view B.

    Parameters
    ----------
    scene, camera : Scene, Camera
        View A.
    scene_b : Scene, optional
        B's scene: the same models with the same triangles, moved or deformed
        (:func:`move_model`); default ``scene``.
    camera_b : Camera, optional
        B's camera; default ``camera``. At least one of ``scene_b`` and
        ``camera_b`` is given.
    hits : HitBuffer, optional
        A's hit buffer (``frame.hits``), cast if not given; checked against
        ``scene`` and ``camera`` (:func:`~raycast_shade.visibility.hits.check_hits`).

    Returns
    -------
    dict
        ``flow`` (H, W, 2) float64 (pixels; 0 where ``mask`` is False; float32
        rounds a 30-pixel flow by 2e-6 px), ``scene_flow`` (H, W, 3) float64, ``mask`` (H, W) bool (A sees a
        surface whose point is in front of B), ``occluded`` and ``outside``
        (H, W) bool (see the module docstring).

    Raises
    ------
    TypeError, ValueError
        Naming the argument, before any ray is cast.
    """
    from ..scene.camera import Camera
    from ..scene.projection import project_points
    from ..scene.scene import Scene
    from ..visibility.cast import cast_camera
    from ..visibility.hits import check_hits

    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    if not isinstance(camera, Camera):
        raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
    if scene_b is None and camera_b is None:
        raise ValueError("scene_b, camera_b: give B's scene, B's camera or both (A to A is no motion)")
    scene_b = scene if scene_b is None else scene_b
    camera_b = camera if camera_b is None else camera_b
    if not isinstance(scene_b, Scene):
        raise TypeError(f"scene_b: expected a Scene, got {type(scene_b).__name__}")
    if not isinstance(camera_b, Camera):
        raise TypeError(f"camera_b: expected a Camera, got {type(camera_b).__name__}")
    if scene_b is not scene:
        _check_same_triangles(scene, scene_b)
    h, w = camera.height, camera.width
    given = hits
    if hits is None:
        hits = cast_camera(scene.geometry, camera)
    else:  # A's own buffer: the camera's size, model and triangle indices of this scene (another's reads garbage)
        check_hits(hits, scene, camera)
    pa, bary, sel = surface_points(scene, camera, hits)
    if given is not None:
        _check_own_hits(hits, bary, sel)
    if scene_b is scene:
        pb = pa
    else:
        q0, q1, q2 = _corners(scene_b.geometry, hits.geom.ravel()[sel], hits.prim.ravel()[sel])
        u, v = bary[:, :1], bary[:, 1:]
        pb = (1.0 - u - v) * q0 + u * q1 + v * q2
    uv, z = project_points(camera_b, pb)
    front = np.isfinite(uv).all(axis=1) & (z > 0)  # orthographic too: its rays start at the eye plane
    inside = front & (uv[:, 0] > -0.5) & (uv[:, 0] < camera_b.width - 0.5) & (uv[:, 1] > -0.5) \
        & (uv[:, 1] < camera_b.height - 0.5)
    occluded = np.zeros(len(sel), bool)
    occluded[inside] = _occluded(scene_b, camera_b, pb[inside])
    jj, ii = np.divmod(sel, w)
    flow = np.zeros((h * w, 2))
    flow[sel[front]] = uv[front] - np.stack([ii, jj], axis=-1)[front]
    scene_flow = np.zeros((h * w, 3))
    scene_flow[sel] = pb - pa
    out = {}
    for name, sub in (("mask", front), ("occluded", occluded), ("outside", ~inside)):
        full = np.zeros(h * w, bool)
        full[sel] = sub
        out[name] = full.reshape(h, w)
    return {"flow": flow.reshape(h, w, 2), "scene_flow": scene_flow.reshape(h, w, 3), **out}
