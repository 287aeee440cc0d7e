"""Everything the shading kernels read, packed once per frame."""

from __future__ import annotations

import numpy as np

from ..common.layout import ATT_NONE, COLOR_FACE, LIGHT_ATT, LIGHT_DIRECTIONAL, LIGHT_KIND, LIGHT_SHADOWS, MAT_KS
from ..visibility.accel import embree_accel
from ..visibility.rays import camera_frame

__all__ = ["kernel_inputs"]


_FACES32 = "shading.faces_int32"


def _faces32(geo):
    """The faces as int32 for the kernels: every pixel reads a random face's row, and at
    1.31 M faces half the bytes cut Phong shading by 12-21% (the same images; Embree's
    indices are 32-bit too, so no scene has more vertices)."""
    return np.ascontiguousarray(geo.faces, np.int32)


def kernel_inputs(scene, camera):
    """The kernels' arguments for one frame.

    Returns
    -------
    dict
        ``G`` = (verts (V,3) f8, normals (V,3) f8, faces (F,3) i4, fnormals (F,3) f8);
        ``B`` = (uvs (V,2) f8, tangents (F,6) f8, bump_index (G,) i4, texels (T,) f4,
        info (B, BUMP_SIZE) f8);
        ``L`` = (ambient (3,) f8, lights (L, LIGHT_SIZE) f8 (:meth:`Scene.packed_lights`),
        dmin f8, scene handle uintp or 0 when no light casts shadows, unit f8 = the
        scene's size for ray offsets);
        ``T`` = (vertex colours (V,3) f8, face colours (F,3) f8, colour mode (G,) i1,
        map rows (G,3) i4 (ka, kd, ks; -1 none), texels (N,) f4, info (K, TEX_SIZE) f8,
        Gouraud modulate flag (G,) u1: a map or face colours) (:class:`SceneGeometry`);
        ``face_off`` (G+1,) i8, ``materials`` (G, MAT_SIZE) f8, ``cam`` (CAM_SIZE,) f8,
        ``background`` (3,) f8;
        ``spec_on``, ``att_on`` bool: whether any material has a specular term and any
        light attenuates (the kernels compile a variant for each combination);
        ``tex_on`` bool: whether any model has colours or maps (a second table of
        variants, :func:`~raycast_shade.shading.texture.variant_for`).
        The row layouts are those of :mod:`raycast_shade.common.layout`.
    """
    geo = scene.geometry
    lights = scene.packed_lights()
    handle = embree_accel(geo).handle if lights[:, LIGHT_SHADOWS].any() else 0
    return dict(
        G=(geo.vertices, geo.normals, geo.memo(_FACES32, _faces32), geo.face_normals),
        B=(geo.uvs, geo.tangents, geo.bump_index, geo.bump_texels, geo.bump_info),
        L=(np.array(scene.ambient, np.float64), lights, 1e-6 * geo.scale, np.uintp(handle), float(geo.scale)),
        T=(geo.vertex_colors, geo.face_colors, geo.color_mode, geo.tex_index, geo.tex_texels, geo.tex_info,
           ((geo.tex_index >= 0).any(axis=1) | (geo.color_mode == COLOR_FACE)).astype(np.uint8)),
        tex_on=geo.textured,
        face_off=geo.face_offsets, materials=geo.materials, cam=camera_frame(camera, geo.origin),
        background=np.array(scene.background, np.float64),
        # Compile-time variants: drop the arithmetic a scene does not need.
        spec_on=bool(np.any(geo.materials[:, MAT_KS:MAT_KS + 3] > 0)),
        att_on=bool(np.any((lights[:, LIGHT_KIND] != LIGHT_DIRECTIONAL) & (lights[:, LIGHT_ATT] != ATT_NONE))),
    )
