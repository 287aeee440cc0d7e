"""Everything the shading kernels read, packed once per frame: :class:`FrameInputs`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..common.layout import ATT_NONE, COLOR_FACE, LIGHT_ATT, LIGHT_DIRECTIONAL, LIGHT_KIND, LIGHT_SHADOWS, MAT_KS
from ..visibility.accel import embree_accel
from ..visibility.rays import camera_frame

__all__ = ["FrameInputs", "prepare", "kernel_inputs", "bump_tuple"]


def bump_tuple(geo, bump_index, nmap_index) -> tuple:
    """``B``: the bump and normal maps of ``geo`` with the given per-model rows (-1: none)."""
    return (geo.uvs, geo.tangents, bump_index, geo.bump_texels, geo.bump_info, nmap_index, geo.nmap_texels,
            geo.nmap_info, geo.nmap_scale, geo.vertex_tangents)


_FACES32 = "shading.faces_int32"


def _faces32(geo):
    """The faces as int32 for the kernels: every pixel reads a random face's row, and at
    1.31 M faces half the bytes cut Phong shading by 12-21% (the same images; Embree's
    indices are 32-bit too, so no scene has more vertices)."""
    return np.ascontiguousarray(geo.faces, np.int32)


@dataclass(frozen=True, eq=False)
class FrameInputs:
    """The kernels' arguments for one frame (a scene seen by a camera), built by :func:`prepare`.

    The four tuples travel into the kernels whole (the helpers unpack them, see
    :mod:`.records`); the row layouts are those of :mod:`raycast_shade.common.layout`.
    ``inputs["G"]`` and the other keys of the dict this replaced still read the fields
    (``G`` geometry, ``B`` bumps, ``L`` lighting, ``T`` colours; the rest by name).

    Attributes
    ----------
    geometry : tuple
        ``G`` = (verts (V,3) f8, normals (V,3) f8, faces (F,3) i4, face normals (F,3) f8).
    bumps : tuple
        ``B`` = (uvs (V,2) f8, tangents (F,6) f8, bump_index (G,) i4, texels (T,) f4,
        info (B, BUMP_SIZE) f8, normal-map index (G,) i4, its texels (N,) f4, info (K, TEX_SIZE) f8,
        scale (G,) f8, vertex tangents (V,4) f8) (:func:`bump_tuple`).
    lighting : tuple
        ``L`` = (ambient (3,) f8, lights (L, LIGHT_SIZE) f8 (each light's ``pack``), dmin f8,
        scene handle uintp or 0 when no light casts shadows, unit f8 = the scene's size for
        ray offsets).
    colours : tuple
        ``T`` = (vertex colours (V,3) f8, face colours (F,3) f8, colour mode (G,) i1, map rows
        (G,3) i4 (ka, kd, ks; -1 none), texels (N,) f4, info (K, TEX_SIZE) f8, Gouraud modulate
        flag (G,) u1: a map or face colours) (:class:`SceneGeometry`).
    face_off : (G + 1,) int64
    materials : (G, MAT_SIZE) float64
    cam : (CAM_SIZE,) float64
    background : (3,) float64
    spec_on, att_on, tex_on : bool
        Whether any material has a specular term, any light attenuates, any model has
        colours or maps: the key of a kernel variant (:func:`~raycast_shade.shading.jit.variant`).
    """

    geometry: tuple
    bumps: tuple
    lighting: tuple
    colours: tuple
    face_off: np.ndarray
    materials: np.ndarray
    cam: np.ndarray
    background: np.ndarray
    spec_on: bool
    att_on: bool
    tex_on: bool

    _KEYS = {"G": "geometry", "B": "bumps", "L": "lighting", "T": "colours"}

    def __getitem__(self, key):
        return getattr(self, self._KEYS.get(key, key))


def prepare(scene, camera) -> FrameInputs:
    """Pack a frame's kernel inputs once: the geometry, the height maps, the lights (each packs
    itself), the colours and maps, the material rows and the camera row.

    Parameters
    ----------
    scene : Scene
    camera : Camera

    Returns
    -------
    FrameInputs
        Shared by the shading kernels and the mirror bounces of the frame. Builds the Embree
        BVH when a light casts shadows (the kernels trace shadow rays through it).
    """
    geo = scene.geometry
    lights = scene.packed_lights()
    handle = embree_accel(geo).handle if lights[:, LIGHT_SHADOWS].any() else 0
    return FrameInputs(
        geometry=(geo.vertices, geo.normals, geo.memo(_FACES32, _faces32), geo.face_normals),
        bumps=bump_tuple(geo, geo.bump_index, geo.nmap_index),
        lighting=(np.array(scene.ambient, np.float64), lights, 1e-6 * geo.scale, np.uintp(handle), float(geo.scale)),
        colours=(geo.vertex_colors, geo.face_colors, geo.color_mode, geo.tex_index, geo.tex_texels, geo.tex_info,
                 ((geo.tex_index >= 0).any(axis=1) | (geo.color_mode == COLOR_FACE)).astype(np.uint8)),
        face_off=geo.face_offsets, materials=geo.materials, cam=camera_frame(camera, geo.origin),
        background=np.array(scene.background, np.float64),
        # Compile-time variants: drop the arithmetic a scene does not need.
        spec_on=bool(np.any(geo.materials[:, MAT_KS:MAT_KS + 3] > 0)),
        att_on=bool(np.any((lights[:, LIGHT_KIND] != LIGHT_DIRECTIONAL) & (lights[:, LIGHT_ATT] != ATT_NONE))),
        tex_on=geo.textured,
    )


kernel_inputs = prepare  # the name the shading modules and tests have used
