"""Every named choice, defined once.

Python, the command line, scene files and batch rendering all accept exactly
these names (case-insensitively, through :func:`raycast_shade.common.validate.as_choice`).
"""

from __future__ import annotations

__all__ = [
    "SHADINGS", "SHADING_CHOICES", "BACKENDS", "BACKEND_CHOICES", "INTERPOLATIONS", "CASTERS", "CASTER_CHOICES",
    "TONEMAPS",
    "ATTENUATIONS", "PROJECTIONS", "SPECULAR_MODELS", "REFLECTANCES", "WEIGHTINGS", "WRAPS", "LINEAR_EXTS", "EIGHT_BIT_EXTS",
    "IMAGE_EXTS", "ORBITS", "VIDEO_EXTS",
]

# Shading methods (the lecture's three), and "auto": the cheapest within an error budget.
SHADINGS = ("flat", "gouraud", "phong")
SHADING_CHOICES = SHADINGS + ("auto",)
# Visibility: Embree ray casting, or the reference z-buffer rasterizer.
BACKENDS = ("raycast", "raster")
# ... and "auto": the rasterizer where it is measured faster (visibility/raster.py's choose_backend).
BACKEND_CHOICES = BACKENDS + ("auto",)
# Barycentrics of the 3D hit (perspective-correct) or weights affine in screen space.
INTERPOLATIONS = ("perspective", "screen")
# Ray casters: Embree driven from Numba, or embreex's own API (the benchmark baseline).
CASTERS = ("embree", "embreex")
CASTER_CHOICES = ("auto",) + CASTERS
# Tone curves of 8-bit output.
TONEMAPS = ("clamp", "reinhard", "exponential")
# Point-light attenuation laws: 1, 1/d^2, 1/(d + k).
ATTENUATIONS = ("none", "inverse_square", "heuristic")
PROJECTIONS = ("perspective", "orthographic")
SPECULAR_MODELS = ("phong", "blinn", "ggx")
# How load_models maps a glTF material: onto Phong coefficients, or glTF's own BRDF (Material specular="ggx").
REFLECTANCES = ("phong", "pbr")
# Vertex-normal weightings of the adjacent face normals.
WEIGHTINGS = ("uniform", "area", "angle")
# Height-map addressing outside [0, 1).
WRAPS = ("repeat", "clamp")
# Image files: lossless float32, and 8-bit after tone mapping.
LINEAR_EXTS = (".pfm", ".npy")
EIGHT_BIT_EXTS = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".gif", ".webp")
IMAGE_EXTS = EIGHT_BIT_EXTS + LINEAR_EXTS
# Animations: what orbits, and the video containers (other outputs: GIF or a frame folder).
ORBITS = ("camera", "light")
VIDEO_EXTS = (".mp4", ".m4v", ".mov", ".mkv")
