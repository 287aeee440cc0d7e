"""The packed rows the kernels read, each defined once.

Kernels take flat float64 rows rather than objects; these named slots are the
only place their layout is written down. Numba freezes module-level integers
as compile-time constants, so ``cam[CAM_ORTHO]`` compiles exactly as
``cam[12]`` did. ``tests/common/test_layout.py`` checks every packer against
these sizes and slots.

Camera row, ``(CAM_SIZE,) = (16,)`` float64 (:func:`raycast_shade.visibility.rays.camera_frame`):
    eye (3, re-centred), right * half width (3), up * half height (3),
    forward (3), orthographic flag, width, height, unused.
Light rows, ``(L, LIGHT_SIZE) = (L, 24)`` float64 (each light's ``pack``; :meth:`raycast_shade.Scene.packed_lights`):
    kind (0 point, 1 directional, 2 spot, 3 area), position (an area light's centre) or
    unit direction towards the light (3), radiance ``Ii * color`` (3), attenuation code
    (:data:`ATT_CODE`), heuristic ``k``, casts shadows (0/1); spot lights
    only (zero otherwise): unit axis the spot shines along (3), cosines of the
    inner and outer cone half-angles, Warn exponent ``n``; area lights only: the
    emitter's two half-edge vectors (a rectangle) or radius-scaled axes (a disc) (3 + 3),
    its shape (:data:`AREA_RECTANGLE`, :data:`AREA_DISC`); every light: its sample count
    (1 but for an area light's N point samples).
Material rows, ``(G, MAT_SIZE) = (G, 19)`` float64 (:meth:`raycast_shade.Material.packed`):
    ka (3), kd (3), ks (3), shininess, reflectance model code (:data:`MODEL_PHONG`,
    :data:`MODEL_BLINN`, :data:`MODEL_GGX`; the slot is also named ``MAT_BLINN``: 1 is Blinn),
    reflectivity, ambient-follows-colours flag (1: the mesh's colours scale ka too), ke (3,
    emission), occlusion strength, metallic and roughness (the GGX model's; 0 otherwise).
Height-map rows, ``(B, BUMP_SIZE) = (B, 7)`` float64 (:meth:`raycast_shade.HeightMap.packed_info`):
    texel offset, rows, cols, clamp flag, tiling u, tiling v, height scale.
Texture rows, ``(K, TEX_SIZE) = (K, 8)`` float64 (:meth:`raycast_shade.Texture.packed_info`):
    texel offset of level 0 (RGB float32 triples, levels stored one after
    another, each ``max(1, w >> k) x max(1, h >> k)``), width, height, mip
    levels, clamp flag, tiling u, tiling v, mip-map flag (0: level 0 only).

Components of a 3-vector slot are ``SLOT + 0``, ``SLOT + 1``, ``SLOT + 2``.

Codes the kernels switch on: the light kinds (``LIGHT_KIND`` values, one branch each in
:func:`raycast_shade.shading.illumination._light_at`), the reflectance models (``MAT_MODEL``
values, :data:`raycast_shade.shading.reflectance.MODELS`) and the shading methods (one per
model, :data:`raycast_shade.shading.shade.METHODS`).
"""

from __future__ import annotations

# camera row
CAM_EYE = 0  # 0:3
CAM_RIGHT = 3  # 3:6, scaled by the half width of the image plane
CAM_UP = 6  # 6:9, scaled by the half height
CAM_FORWARD = 9  # 9:12, unit
CAM_ORTHO = 12
CAM_WIDTH = 13
CAM_HEIGHT = 14
CAM_SIZE = 16

# light rows
LIGHT_KIND = 0
LIGHT_VEC = 1  # 1:4
LIGHT_RADIANCE = 4  # 4:7
LIGHT_ATT = 7
LIGHT_K = 8
LIGHT_SHADOWS = 9
LIGHT_AXIS = 10  # 10:13, spot lights: unit direction from the light into its cone
LIGHT_COS_INNER = 13  # spot lights: full intensity inside this cone
LIGHT_COS_OUTER = 14  # spot lights: none outside this one
LIGHT_EXPONENT = 15  # spot lights: Warn's n in cos^n
LIGHT_EDGE_U = 16  # 16:19, area lights: half-edge vector (rectangle) or radius along the first axis (disc)
LIGHT_EDGE_V = 19  # 19:22, area lights: the other half-edge vector, or radius along the second axis
LIGHT_SHAPE = 22  # area lights: AREA_RECTANGLE or AREA_DISC
LIGHT_SAMPLES = 23  # point samples the light is evaluated at: 1, or an area light's N
LIGHT_SIZE = 24
LIGHT_POINT = 0  # LIGHT_KIND values
LIGHT_DIRECTIONAL = 1
LIGHT_SPOT = 2
LIGHT_AREA = 3
AREA_RECTANGLE = 0  # LIGHT_SHAPE values
AREA_DISC = 1
LIGHT_KINDS = {"point": 0, "directional": 1, "spot": 2, "area": 3}  # LIGHT_KIND values, every one
ATT_CODE = {"none": 0, "inverse_square": 1, "heuristic": 2}  # LIGHT_ATT values
ATT_NONE = 0
ATT_INVERSE_SQUARE = 1
ATT_HEURISTIC = 2

# material rows
MAT_KA = 0  # 0:3
MAT_KD = 3  # 3:6
MAT_KS = 6  # 6:9
MAT_SHININESS = 9
MAT_MODEL = 10  # reflectance model code: MODEL_PHONG, MODEL_BLINN or MODEL_GGX
MAT_BLINN = MAT_MODEL  # the same slot under its first name: 1.0 for Blinn-Phong
MAT_REFLECTIVITY = 11
MAT_KA_COLORS = 12  # 1.0: the mesh's colours scale ka as they replace kd (Material.ka_colors)
MAT_KE = 13  # 13:16, emission: added to the point's intensity, whatever the lights
MAT_AO_STRENGTH = 16  # occlusion map strength s: ka scaled by 1 + s (ao - 1)
MAT_METALLIC = 17  # GGX: glTF's metallicFactor (the point's is this times its ks blue: the map's B)
MAT_ROUGHNESS = 18  # GGX: glTF's roughnessFactor (the point's is this times its ks green: the map's G)
MAT_SIZE = 19

MODEL_PHONG = 0  # MAT_MODEL values: Phong's (r.v)^t
MODEL_BLINN = 1  # Blinn-Phong's (n.h)^t
MODEL_GGX = 2  # glTF 2.0 metallic-roughness: Lambert + GGX, Smith height-correlated, Schlick
MODEL_CODE = {"phong": MODEL_PHONG, "blinn": MODEL_BLINN, "ggx": MODEL_GGX}  # every MAT_MODEL value

# shading methods, one per model
METHOD_FLAT = 0
METHOD_GOURAUD = 1
METHOD_PHONG = 2

# height-map rows
BUMP_OFFSET = 0
BUMP_ROWS = 1
BUMP_COLS = 2
BUMP_CLAMP = 3
BUMP_TILE_U = 4
BUMP_TILE_V = 5
BUMP_SCALE = 6
BUMP_SIZE = 7

# texture rows
TEX_OFFSET = 0
TEX_WIDTH = 1
TEX_HEIGHT = 2
TEX_LEVELS = 3
TEX_CLAMP = 4
TEX_TILE_U = 5
TEX_TILE_V = 6
TEX_MIPMAP = 7
TEX_SIZE = 8
# Per-model colour sources (SceneGeometry.color_mode)
COLOR_NONE = 0
COLOR_VERTEX = 1
COLOR_FACE = 2
# Per-model texture slots (SceneGeometry.tex_index columns): which coefficient a map scales
TEXMAP_KA = 0
TEXMAP_KD = 1
TEXMAP_KS = 2  # GGX: the metallicRoughness map (its G scales roughness, its B metallic)
TEXMAP_KE = 3
TEXMAP_AO = 4  # occlusion: its red channel scales ka
TEXMAP_COUNT = 5  # tex_index columns

__all__ = [name for name in dir() if name.isupper()]
