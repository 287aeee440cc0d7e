"""Per-pixel buffers for vision data sets, computed by name from the hit buffer.

``render(scene, buffers=("zdepth", "position", ...))`` puts each asked-for
buffer on ``frame.buffers``; nothing else is computed or held. All come from
the hit buffer after the cast (NumPy, float64 arithmetic, stored float32),
except the shading normals, which are the shading kernels' own
(:func:`raycast_shade.shading_normals`, as ``frame.normal``).

Names, shapes and meanings (background: 0, ids -1; camera axes are OpenCV's,
``x`` right, ``y`` down, ``z`` forward; see ``docs/vision.md``):

=====================  ===============  ===============================================
``depth``              (H, W) float32   distance from the eye along the ray (``frame.depth``;
                                        orthographic: from the image plane)
``zdepth``             (H, W) float32   view-space ``z``: depth along the optical axis
``position``           (H, W, 3) f32    world position of the surface point
``normal``             (H, W, 3) f32    shading normal, world axes, turned to the viewer
``normal_camera``      (H, W, 3) f32    the same in camera axes
``face_normal``        (H, W, 3) f32    geometric (triangle) normal, world, turned to the viewer
``face_normal_camera`` (H, W, 3) f32    the same in camera axes
``barycentric``        (H, W, 3) f32    weights of the triangle's vertices 0, 1, 2
``model_id``           (H, W) int32     model index in the scene (the instance mask)
``semantic_id``        (H, W) int32     index of the model's name among the scene's distinct
                                        model names (:func:`~raycast_shade.output.labels.semantic_classes`)
``triangle_id``        (H, W) int32     triangle index within its model (the mesh's face order)
``mask``               (H, W) bool      pixels that see a surface
``coverage``           (H, W) float32   fraction of the pixel's anti-aliasing samples that hit a
                                        surface (``render(samples=N)``; with one sample, ``mask``)
=====================  ===============  ===============================================

``id`` asks for ``model_id`` and ``triangle_id``. Every buffer but
``coverage`` is the pixel centre's (sample 0), whatever the number of
samples, so masks and ids stay exact.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BUFFER_NAMES", "ALIASES", "check_buffers", "compute_buffers"]

BUFFER_NAMES = ("depth", "zdepth", "position", "normal", "normal_camera", "face_normal", "face_normal_camera",
                "barycentric", "model_id", "triangle_id", "mask", "coverage", "semantic_id")
ALIASES = {"id": ("model_id", "triangle_id")}


def check_buffers(names, field: str = "buffers") -> tuple:
    """The buffer names asked for, aliases expanded, duplicates dropped, in order.

    Parameters
    ----------
    names : str or sequence of str
        Names of :data:`BUFFER_NAMES` or :data:`ALIASES`; one string may list
        several, comma-separated.

    Raises
    ------
    TypeError, ValueError
        Naming ``field`` and listing the valid names.
    """
    if names is None:
        return ()
    if isinstance(names, str):
        names = [n for n in names.split(",") if n.strip()]
    elif not hasattr(names, "__iter__"):
        raise TypeError(f"{field}: expected a sequence of buffer names, got {type(names).__name__}")
    out = []
    for name in names:
        if not isinstance(name, str):
            raise TypeError(f"{field}: expected buffer names (str), got {type(name).__name__}")
        key = name.strip().lower()
        if key not in BUFFER_NAMES and key not in ALIASES:
            raise ValueError(f"{field}: unknown buffer {name!r}; expected some of "
                             f"{', '.join(BUFFER_NAMES + tuple(ALIASES))}")
        out.extend(ALIASES.get(key, (key,)))
    return tuple(dict.fromkeys(out))


def _unit_rays(camera):
    """(H, W, 3) float64 unit ray directions (world axes), as the casters make them."""
    from ..visibility.rays import generate_rays

    if camera.distorted:
        from ..visibility.distortion import ray_directions

        return ray_directions(camera)[0].reshape(camera.height, camera.width, 3)
    _, d = generate_rays(camera, dtype=np.float64)
    return d.reshape(camera.height, camera.width, 3)


def compute_buffers(scene, camera, hits, names, shading="phong", coverage=None) -> dict:
    """The named buffers of one frame.

    Parameters
    ----------
    scene : Scene
    camera : Camera
        The camera ``hits`` was made with.
    hits : HitBuffer
        ``(H, W)`` arrays from a caster or the rasterizer.
    names : sequence of str
        Checked names (:func:`check_buffers`).
    shading : str or sequence of str
        The frame's methods (for the shading normals).
    coverage : (H, W) float32, optional
        The anti-aliasing samples' hit fraction; ``None``: one sample, the mask.

    Returns
    -------
    dict of str to ndarray
        In the order asked; shapes and dtypes as in the module table.
    """
    names = check_buffers(names)
    mask = hits.prim >= 0
    out = {}
    need_rays = any(n in names for n in ("zdepth", "face_normal", "face_normal_camera"))
    rays = _unit_rays(camera) if need_rays else None
    geo = scene.geometry if any(n in names for n in ("position", "face_normal", "face_normal_camera")) else None
    from ..scene.projection import extrinsics

    R, _ = extrinsics(camera)
    face = None
    if geo is not None:
        face = np.where(mask, geo.face_offsets[np.maximum(hits.geom, 0)] + hits.prim, 0)
    shading_n = None
    geometric_n = None
    for name in names:
        if name == "depth":
            buf = np.where(mask, hits.t, np.float32(0.0))
        elif name == "zdepth":
            # z = t (d . forward) for a unit ray d (orthographic: d = forward, z = t).
            cosine = rays @ camera.basis[2]
            buf = np.where(mask, hits.t * cosine, 0.0)
        elif name == "position":
            tri = geo.vertices[geo.faces[face]]  # (H, W, 3 vertices, 3)
            u = hits.u.astype(np.float64)[..., None]
            v = hits.v.astype(np.float64)[..., None]
            p = (1.0 - u - v) * tri[..., 0, :] + u * tri[..., 1, :] + v * tri[..., 2, :] + geo.origin
            buf = np.where(mask[..., None], p, 0.0)
        elif name in ("normal", "normal_camera"):
            if shading_n is None:
                from ..shading.normals import shading_normals

                shading_n = shading_normals(scene, camera, hits, shading).astype(np.float64)
            buf = shading_n if name == "normal" else shading_n @ R.T
        elif name in ("face_normal", "face_normal_camera"):
            if geometric_n is None:
                n = geo.face_normals[face]
                back = np.einsum("...i,...i->...", n, rays) > 0.0  # turn to the viewer, as shading does
                geometric_n = np.where(mask[..., None], np.where(back[..., None], -n, n), 0.0)
            buf = geometric_n if name == "face_normal" else geometric_n @ R.T
        elif name == "barycentric":
            u = hits.u.astype(np.float64)
            v = hits.v.astype(np.float64)
            buf = np.where(mask[..., None], np.stack([1.0 - u - v, u, v], axis=-1), 0.0)
        elif name == "model_id":
            buf = hits.geom.copy()
        elif name == "semantic_id":
            from .labels import semantic_classes

            lut = semantic_classes(scene)[1]
            buf = np.where(mask, lut[np.maximum(hits.geom, 0)], np.int32(-1)).astype(np.int32)
        elif name == "triangle_id":
            buf = hits.prim.copy()
        elif name == "coverage":
            buf = mask.astype(np.float32) if coverage is None else np.array(coverage, np.float32)
        else:  # mask
            buf = mask.copy()
        if buf.dtype.kind == "f":
            buf = np.ascontiguousarray(buf, dtype=np.float32)
        out[name] = buf
    return out
