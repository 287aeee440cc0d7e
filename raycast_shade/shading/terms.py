"""The reflectance equation's terms as images: ``render(..., terms=True)``.

The equation is linear in the material coefficients and in the lights, and
every method interpolates linearly (Gouraud) or not at all, so each term is
the same hit buffer shaded by the unchanged kernels with a variant of the
scene:

=====================  ==============================================================
term                   variant shaded
=====================  ==============================================================
``ambient``            no lights, ``ke = 0`` (``Ia ka`` only)
``diffuse``            ``ka = ks = ke = 0``
``specular``           ``ka = kd = ke = 0``
``emissive``           no lights, ``ka = 0`` (``ke`` only; zeros without emission)
``diffuse_per_light``  one light at a time, ``ka = ks = ke = 0`` (``terms="per_light"``)
``specular_per_light`` one light at a time, ``ka = kd = ke = 0``
``reflected``          the mirror trace (:func:`.mirrors.trace_mirrors`) over a black image
=====================  ==============================================================

so that, per pixel and channel, to float32 rounding::

    image = keep * (ambient + diffuse + specular + emissive) + reflected + background

with ``keep = 1 - rho`` on mirror pixels (1 elsewhere) and ``background`` the
scene's background where no surface is seen. The local terms are the
unmirrored shade: a mirror pixel shows ``keep`` of them plus ``rho`` times
what the mirror ray sees, which is ``reflected``.

The shadow mask ``shadow`` (L, H, W) is, per light, the fraction of that
light's Lambert term ``n.s`` that its shadow rays let through, where the
method evaluates the equation: the pixel's point (Phong) or the face centre
(flat), 1 or 0; the vertices (Gouraud), interpolated, so a fraction
``sum w_k vis_k (n.s)_k / sum w_k (n.s)_k`` in [0, 1]. It is 1 where the light
does not reach the point anyway (the surface faces away: no ray is traced),
for lights that cast no shadows, and on the background. Mirror bounces
have shadows of their own, which the mask does not show.

A mesh's vertex or face colours stand in for kd, and colour maps multiply
their coefficient: the ``ambient`` and ``specular`` variants therefore also
zero the mesh colours (a zero kd row alone would leave them in), and the
shadow probe sets them to 1 and drops the kd map (their hue would skew the
probe's ratio).

Material variants share the scene's packed geometry and Embree BVH (only the
material rows and mesh colours differ), so a term costs one shading pass, no
repacking.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..common.layout import MAT_KA, MAT_KD, MAT_KE, MAT_KS, MAT_REFLECTIVITY, TEXMAP_KD
from ..scene.lights import PointLight
from .mirrors import trace_mirrors
from .shade import shade_hits

__all__ = ["TERM_OPTIONS", "check_terms", "shade_terms", "compose_terms", "with_materials"]

TERM_OPTIONS = ("per_light",)


def check_terms(terms):
    """``render``'s ``terms`` argument, checked.

    Parameters
    ----------
    terms : bool, str or sequence of str
        ``False`` (none), ``True`` (the summed terms and the shadow mask), or
        options from :data:`TERM_OPTIONS` (``"per_light"``: also each light's
        diffuse and specular term), which imply ``True``.

    Returns
    -------
    tuple of str or None
        ``None`` for no terms, else the options.
    """
    if isinstance(terms, (bool, np.bool_)):
        return () if terms else None
    names = (terms,) if isinstance(terms, str) else terms
    try:
        names = tuple(names)
    except TypeError:
        raise TypeError(f"terms: expected True, False or options from {list(TERM_OPTIONS)}, "
                        f"got {type(terms).__name__}") from None
    out = []
    for name in names:
        if not isinstance(name, str) or name.lower() not in TERM_OPTIONS:
            raise ValueError(f"terms: expected True, False or options from {list(TERM_OPTIONS)}, got {name!r}")
        out.append(name.lower())
    return tuple(out)


def with_materials(scene, materials, colors=None, **changes):
    """``scene.replace(**changes)`` whose packed geometry has other material rows.

    The copy of the packed geometry shares every array but ``materials``,
    and the memo of acceleration structures, so shading it needs no
    repacking and no new BVH. For shading variants of a scene only: its
    ``models`` still hold the original materials.

    Parameters
    ----------
    materials : (G, MAT_SIZE) float64
        The packed material rows (:meth:`raycast_shade.Material.packed`).
    colors : float, optional
        Every vertex and face colour set to this value (0: no kd from the
        mesh; 1: a white kd with the kd maps dropped too). ``None`` keeps them.
    """
    geo = scene.geometry
    twin = object.__new__(type(geo))
    twin.__dict__.update(geo.__dict__)  # not copy.copy: its pickling hooks would drop the shared BVH memo
    twin.materials = np.ascontiguousarray(materials, np.float64)
    twin.reflective = bool(np.any(twin.materials[:, MAT_REFLECTIVITY] > 0))
    if colors is not None and geo.textured:
        twin.vertex_colors = np.full_like(geo.vertex_colors, colors)
        twin.face_colors = np.full_like(geo.face_colors, colors)
        if colors != 0:
            twin.tex_index = geo.tex_index.copy()
            twin.tex_index[:, TEXMAP_KD] = -1
    new = scene.replace(**changes)
    new.__dict__["geometry"] = twin
    return new


def _rows(materials, keep):
    """Material rows with the coefficient slots not in ``keep`` zeroed."""
    out = materials.copy()
    for slot in (MAT_KA, MAT_KD, MAT_KS, MAT_KE):
        if slot not in keep:
            out[:, slot:slot + 3] = 0.0
    return out


def _shadow_probe(light):
    """Two unit white lights where ``light`` is, one tracing shadow rays into
    the red channel, one not into green: their ratio is the shadow fraction."""
    if isinstance(light, PointLight):
        common = dict(intensity=1.0, attenuation="none")
    else:
        common = dict(intensity=1.0)
    return (dataclasses.replace(light, color=(1.0, 0.0, 0.0), shadows=True, **common),
            dataclasses.replace(light, color=(0.0, 1.0, 0.0), shadows=False, **common))


def shade_terms(scene, camera, hits, shading, max_depth: int = 0, per_light: bool = False) -> dict:
    """Each term of the reflectance equation shaded over a hit buffer.

    Parameters
    ----------
    scene, camera, hits, shading
        As :func:`.shade.shade_hits` (one method, or one per model).
    max_depth : int
        Mirror bounces, as ``render``'s.
    per_light : bool
        Also each light's diffuse and specular term.

    Returns
    -------
    dict of str to ndarray
        ``ambient``, ``diffuse``, ``specular``, ``emissive``, ``reflected``, ``background``
        (H, W, 3) float32; ``keep`` (H, W) float32; ``shadow`` (L, H, W)
        float32; with ``per_light``, ``diffuse_per_light`` and
        ``specular_per_light`` (L, H, W, 3) float32. See the module docstring
        for what they mean and how they add up.
    """
    geo = scene.geometry
    mats = geo.materials
    h, w = hits.shape
    black = dict(background=0.0)
    out = {
        "ambient": shade_hits(with_materials(scene, _rows(mats, (MAT_KA,)), lights=(), **black), camera, hits,
                              shading),
        "diffuse": shade_hits(with_materials(scene, _rows(mats, (MAT_KD,)), **black), camera, hits, shading),
        "specular": shade_hits(with_materials(scene, _rows(mats, (MAT_KS,)), 0.0, **black), camera, hits, shading),
    }
    if np.any(mats[:, MAT_KE:MAT_KE + 3] > 0):
        out["emissive"] = shade_hits(with_materials(scene, _rows(mats, (MAT_KE,)), lights=(), **black), camera,
                                     hits, shading)
    else:  # no emission anywhere: no shading pass
        out["emissive"] = np.zeros((h, w, 3), np.float32)
    if per_light:
        for name, slot, colors in (("diffuse", MAT_KD, None), ("specular", MAT_KS, 0.0)):
            rows = _rows(mats, (slot,))
            out[f"{name}_per_light"] = np.stack(
                [shade_hits(with_materials(scene, rows, colors, lights=(light,), **black), camera, hits, shading)
                 for light in scene.lights]) if scene.lights else np.zeros((0, h, w, 3), np.float32)
    seen = hits.prim >= 0
    out["background"] = np.where(seen[..., None], np.float32(0.0),
                                 np.asarray(scene.background, np.float32)).astype(np.float32)
    keep = np.ones((h, w), np.float32)
    reflected = np.zeros((h, w, 3), np.float32)
    if geo.reflective and max_depth > 0:
        rho = np.where(seen, mats[np.maximum(hits.geom, 0), MAT_REFLECTIVITY], 0.0)
        keep = np.where(rho > 0, (1.0 - rho).astype(np.float32), np.float32(1.0))
        trace_mirrors(scene, camera, hits, reflected, max_depth)  # over black: rho * what the mirror sees
    out["keep"], out["reflected"] = keep, reflected
    out["shadow"] = _shadow_mask(scene, camera, hits, shading)
    return out


def _shadow_mask(scene, camera, hits, shading) -> np.ndarray:
    """(L, H, W) float32, see the module docstring."""
    mask = np.ones((len(scene.lights),) + hits.shape, np.float32)
    probe = _rows(scene.geometry.materials, ())
    probe[:, MAT_KD:MAT_KD + 3] = 1.0
    for i, light in enumerate(scene.lights):
        if not light.shadows:
            continue
        img = shade_hits(with_materials(scene, probe, 1.0, lights=_shadow_probe(light), background=0.0), camera,
                         hits, shading)
        through, reached = img[..., 0].astype(np.float64), img[..., 1].astype(np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            mask[i] = np.where(reached > 0.0, np.minimum(through / reached, 1.0), 1.0)
    return mask


def compose_terms(terms: dict) -> np.ndarray:
    """(H, W, 3) float32 ``keep * (ambient + diffuse + specular + emissive) + reflected + background``:
    the image the terms add up to."""
    local = terms["ambient"].astype(np.float64) + terms["diffuse"] + terms["specular"]
    if "emissive" in terms:
        local = local + terms["emissive"]
    total = terms["keep"][..., None] * local + terms["reflected"] + terms["background"]
    return total.astype(np.float32)
