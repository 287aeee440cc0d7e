"""Warnings for silent pitfalls: the image renders, but probably not as meant.

Every class derives from :class:`ShadingWarning`, so one filter silences the
family::

    warnings.filterwarnings("ignore", category=rs.ShadingWarning)

and one class silences one pitfall, e.g. for a single call that shows it on
purpose (a lecture showing that only Phong shading shows bump maps)::

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rs.BumpIgnoredWarning)
        frame = rs.render(scene, "gouraud")

Each message names the remedy.
"""

from __future__ import annotations

__all__ = [
    "ShadingWarning", "BumpIgnoredWarning", "ColourRangeWarning", "CreaseWarning", "DroppedOnLoadWarning",
    "LightInsideWarning", "NoLightsWarning", "ZeroNormalWarning", "EmptyViewWarning", "SingleSidedWarning",
    "AllMaskedWarning", "NormalMapWarning", "LensFoldWarning",
]


class ShadingWarning(UserWarning):
    """Base of raycast_shade's warnings about likely mistakes in a scene."""


class NoLightsWarning(ShadingWarning):
    """A scene rendered without lights shows the ambient term alone."""


class LightInsideWarning(ShadingWarning):
    """A point light inside a closed mesh lights only its inside."""


class BumpIgnoredWarning(ShadingWarning):
    """A bump-mapped model shaded flat or Gouraud: the bumps do not show."""


class ColourRangeWarning(ShadingWarning):
    """Material coefficients that look like 0-255 colour values."""


class CreaseWarning(ShadingWarning):
    """Computed vertex normals averaged across sharp edges."""


class DroppedOnLoadWarning(ShadingWarning):
    """Part of a mesh file (geometry, normals, UVs) was not kept."""


class ZeroNormalWarning(ShadingWarning):
    """Given vertex normals include zero vectors: the shading falls back to the
    face normal there (see docs/failure-cases.md, section 3)."""


class EmptyViewWarning(ShadingWarning):
    """The camera sees none of the scene: every model lies outside its view."""


class SingleSidedWarning(ShadingWarning):
    """The camera sees back faces of a model whose material is single-sided (glTF's
    ``doubleSided: false``): drawn and lit from the side seen, where a culling renderer would
    show what lies behind."""


class AllMaskedWarning(ShadingWarning):
    """A material's ``alpha_cutoff`` exceeds every texel of its ``alpha_map``: rays pass through the
    whole model, which is neither drawn nor casts a shadow."""


class NormalMapWarning(ShadingWarning):
    """A normal map no tangent-space normal map could be: grey everywhere (a one-channel image or a
    height map), or without a texel whose normal points out of the surface."""


class LensFoldWarning(ShadingWarning):
    """A camera's lens distortion folds inside the frame: the radial map stops increasing, and the
    pixels beyond the fold's image have no ray inside the fold (they stay empty, or see past it)."""
