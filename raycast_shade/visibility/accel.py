"""Acceleration structures of a scene's geometry, built once and kept with it.

Both live in :meth:`SceneGeometry.memo <raycast_shade.scene.scene.SceneGeometry.memo>`,
so they are built once per geometry, under its lock (two threads rendering a new
scene at once share one build), and are freed with the geometry, never while a
kernel holds their handle.
"""

from __future__ import annotations

import numpy as np

from .alpha import filter_address, mask_data, masked_geometries
from .embree import EmbreeAccel, check_range

__all__ = ["embree_accel", "embreex_scene", "has_embree_accel"]

_EMBREE = "embree"
_EMBREEX = "embreex"


def _build_embree(geo) -> EmbreeAccel:
    check_range(geo.reach, "scene vertices", scene=True)
    v4 = np.zeros((len(geo.vertices), 4), np.float32)
    v4[:, :3] = geo.vertices
    faces = np.ascontiguousarray(geo.local_faces, dtype=np.uint32)
    masks = {}
    for g in masked_geometries(geo):
        alpha_map, cutoff = geo.alpha_masks[g]
        v0, f0, f1 = geo.vertex_offsets[g], geo.face_offsets[g], geo.face_offsets[g + 1]
        masks[g] = mask_data(alpha_map, cutoff, geo.uvs[v0:geo.vertex_offsets[g + 1]], geo.local_faces[f0:f1])
    return EmbreeAccel(v4, faces, geo.vertex_offsets, geo.face_offsets, masks,
                       filter_address() if masks else 0)


def _build_embreex(geo):
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    check_range(geo.reach, "scene vertices", scene=True)
    masked = masked_geometries(geo)
    if masked:
        raise RuntimeError(f"alpha masks (scene.models{list(masked)}) need the direct Embree binding "
                           "(embreex's API takes no filter functions)")
    scene = rtcore_scene.EmbreeScene()
    v32 = geo.vertices.astype(np.float32)
    for g in range(geo.n_models):
        v0, v1 = geo.vertex_offsets[g], geo.vertex_offsets[g + 1]
        f0, f1 = geo.face_offsets[g], geo.face_offsets[g + 1]
        TriangleMesh(scene, v32[v0:v1], geo.local_faces[f0:f1].astype(np.int32))
    return scene


def embree_accel(geometry) -> EmbreeAccel:
    """The geometry's Embree scene over shared buffers (built on first use, then reused).

    Parameters
    ----------
    geometry : SceneGeometry

    Returns
    -------
    EmbreeAccel
        ``.handle`` is the ``RTCScene`` the kernels take; it stays valid while
        ``geometry`` is alive.
    """
    return geometry.memo(_EMBREE, _build_embree)


def embreex_scene(geometry):
    """The same geometry through embreex's own API (the baseline caster)."""
    return geometry.memo(_EMBREEX, _build_embreex)


def has_embree_accel(geometry) -> bool:
    """True once :func:`embree_accel` has built the geometry's BVH."""
    return geometry.memoized(_EMBREE)
