"""Everything the shading kernels read, packed once per frame: :class:`FrameInputs`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..common.layout import (ATT_NONE, COLOR_FACE, LIGHT_ATT, LIGHT_DIRECTIONAL, LIGHT_KIND, LIGHT_SHADOWS, MAT_KS,
                             MAT_MODEL)
from ..visibility.accel import embree_accel
from ..visibility.rays import camera_frame
from .illumination import LEAN
from .records import Bumps, Colours, Geometry, Lighting

__all__ = ["FrameInputs", "prepare", "kernel_inputs", "bump_tuple", "lighting", "colours", "extensions",
           "lean_lighting"]


def extensions(lights, materials, nmap_index, tex_on: bool):
    """A frame's extensions marker ``ext``: None when it needs nothing the lean build leaves out
    (:data:`~raycast_shade.shading.illumination.LEAN`: only point lights and lights at infinity, Phong
    and Blinn-Phong, no normal map, no texture), else True. The one place it is derived; it goes into
    ``L.ext`` and ``B.ext``, and the kernels compile one build for each value.

    Parameters
    ----------
    lights : (L, LIGHT_SIZE) float64
    materials : (G, MAT_SIZE) float64
    nmap_index : (G,) int
        Each model's normal-map row (-1: none).
    tex_on : bool
        Whether any model has colours or maps (a textured frame takes the full build: its lookups
        dwarf what the lean build saves, and one build fewer is compiled).
    """
    kinds = {int(k) for k in lights[:, LIGHT_KIND]}
    models = {int(m) for m in materials[:, MAT_MODEL]}
    lean = (kinds <= LEAN["light_kinds"] and models <= LEAN["models"] and not bool(np.any(nmap_index >= 0))
            and not tex_on)
    return None if lean else True


def lean_lighting(L) -> Lighting:
    """``L`` with the lean marker (``ext`` None), for a kernel that reads no marker (the batched Phong
    kernel, whose passes implement its spot lights themselves): every frame it takes shares one build."""
    return L if L.ext is None else L._replace(ext=None)


def bump_tuple(geo, bump_index, nmap_index, ext) -> Bumps:
    """``B``: the bump and normal maps of ``geo`` with the given per-model rows (-1: none), and the
    frame's extensions marker ``ext`` (:func:`extensions`)."""
    return Bumps(geo.uvs, geo.tangents, bump_index, geo.bump_texels, geo.bump_info, nmap_index, geo.nmap_texels,
                 geo.nmap_info, geo.nmap_scale, geo.vertex_tangents, ext)


def lighting(ambient, lights, materials, dmin, handle, unit, ext) -> Lighting:
    """``L`` for light rows ``lights`` (L, LIGHT_SIZE) and material rows ``materials`` (G, MAT_SIZE): the one
    place a frame's flags are derived. ``spec_on``: some material has a specular term; ``att_on``: some
    light attenuates (a light at infinity never does); ``ext`` the frame's extensions marker
    (:func:`extensions`)."""
    spec_on = bool(np.any(materials[:, MAT_KS:MAT_KS + 3] > 0))
    att_on = bool(np.any((lights[:, LIGHT_KIND] != LIGHT_DIRECTIONAL) & (lights[:, LIGHT_ATT] != ATT_NONE)))
    return Lighting(np.asarray(ambient, np.float64), lights, float(dmin), np.uintp(handle), float(unit),
                    spec_on, att_on, np.zeros((1, 1), np.int8), ext)


def colours(vertex_colors, face_colors, color_mode, tex_index, tex_texels, tex_info) -> Colours:
    """``T``, with Gouraud's modulate flag derived from the maps and colour modes: a model with any map,
    or with face colours, interpolates its diffuse and specular vertex light apart."""
    modulate = ((tex_index >= 0).any(axis=1) | (color_mode == COLOR_FACE)).astype(np.uint8)
    return Colours(vertex_colors, face_colors, color_mode, tex_index, tex_texels, tex_info, modulate)


_FACES32 = "shading.faces_int32"


def _faces32(geo):
    """The faces as int32 for the kernels: every pixel reads a random face's row, and at
    1.31 M faces half the bytes cut Phong shading by 12-21% (the same images; Embree's
    indices are 32-bit too, so no scene has more vertices)."""
    return np.ascontiguousarray(geo.faces, np.int32)


@dataclass(frozen=True, eq=False)
class FrameInputs:
    """The kernels' arguments for one frame (a scene seen by a camera), built by :func:`prepare`.

    The four named tuples travel into the kernels whole (the helpers read their fields by name,
    see :mod:`.records`); the row layouts are those of :mod:`raycast_shade.common.layout`.
    ``inputs["G"]`` and the other keys of the dict this replaced still read the fields
    (``G`` geometry, ``B`` bumps, ``L`` lighting, ``T`` colours; the rest by name).

    Attributes
    ----------
    geometry : Geometry
        ``G`` (:class:`~raycast_shade.shading.records.Geometry`).
    bumps : Bumps
        ``B`` (:class:`~raycast_shade.shading.records.Bumps`, :func:`bump_tuple`).
    lighting : Lighting
        ``L`` (:class:`~raycast_shade.shading.records.Lighting`, :func:`lighting`): the ambient
        term, the lights' rows (each light's ``pack``), the scene handle (0 when no light casts
        shadows) and the frame's flags ``spec_on`` and ``att_on``.
    colours : Colours
        ``T`` (:class:`~raycast_shade.shading.records.Colours`, :func:`colours`).
    face_off : (G + 1,) int64
    materials : (G, MAT_SIZE) float64
    cam : (CAM_SIZE,) float64
    background : (3,) float64
    tex_on : bool
        Whether any model has colours or maps: the key of a kernel variant
        (:func:`~raycast_shade.shading.jit.variant`).
    """

    geometry: Geometry
    bumps: Bumps
    lighting: Lighting
    colours: Colours
    face_off: np.ndarray
    materials: np.ndarray
    cam: np.ndarray
    background: np.ndarray
    tex_on: bool

    _KEYS = {"G": "geometry", "B": "bumps", "L": "lighting", "T": "colours"}

    def __getitem__(self, key):
        return getattr(self, self._KEYS.get(key, key))

    @property
    def spec_on(self) -> bool:
        """Some material has a specular term (``L.spec_on``, derived in :func:`lighting`)."""
        return self.lighting.spec_on

    @property
    def att_on(self) -> bool:
        """Some light attenuates (``L.att_on``, derived in :func:`lighting`)."""
        return self.lighting.att_on


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
    ext = extensions(lights, geo.materials, geo.nmap_index, geo.textured)
    return FrameInputs(
        geometry=Geometry(geo.vertices, geo.normals, geo.memo(_FACES32, _faces32), geo.face_normals),
        bumps=bump_tuple(geo, geo.bump_index, geo.nmap_index, ext),
        lighting=lighting(scene.ambient, lights, geo.materials, 1e-6 * geo.scale, handle, geo.scale, ext),
        colours=colours(geo.vertex_colors, geo.face_colors, geo.color_mode, geo.tex_index, geo.tex_texels,
                        geo.tex_info),
        face_off=geo.face_offsets, materials=geo.materials, cam=camera_frame(camera, geo.origin),
        background=np.array(scene.background, np.float64),
        tex_on=geo.textured,  # the one compile-time variant: textured coefficient lookups
    )


kernel_inputs = prepare  # the name the shading modules and tests have used
