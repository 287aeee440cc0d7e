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

A frame gets its image, local terms, per-light terms and shadow mask from
one pass (:class:`.termshade.TermShading`; :mod:`.terms_kernel`, and
:mod:`.terms_gouraud` for Gouraud models): each point's equation (a Phong
pixel's, a flat face's, a Gouraud vertex's) evaluated once with its parts
stored apart, the same numbers the variant passes give (measured equal, bit
for bit, on the test scenes); the frame is rendered band by band like a
plain one. The variant passes (:func:`_variant_terms`) are the definition
those are tested against.

Every variant is the frame's kernel inputs with other material rows, mesh
colours or lights (:func:`variant_inputs`): the packed geometry, the BVH, the
height maps and texels are the frame's, so a term costs one shading pass, no
repacking.
"""

from __future__ import annotations

import copy
import dataclasses

import numpy as np

from ..common.layout import LIGHT_SHADOWS, LIGHT_SIZE, MAT_KA, MAT_KD, MAT_KE, MAT_KS, MAT_REFLECTIVITY, TEXMAP_KD
from ..scene.lights import PointLight
from .inputs import colours, lighting, prepare
from .shade import SampleShading
from .termshade import TermShading

__all__ = ["TERM_OPTIONS", "check_terms", "shade_terms", "compose_terms", "variant_inputs", "with_materials"]

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
    repacking and no new BVH. For the material explorer
    (:mod:`raycast_shade.apps.explore`), whose frames carry the varied scene;
    the terms vary the frame's kernel inputs instead (:func:`variant_inputs`).
    Its ``models`` still hold the original materials.

    Parameters
    ----------
    materials : (G, MAT_SIZE) float64
        The packed material rows (:meth:`raycast_shade.Material.packed`).
    colors : float, optional
        Every vertex and face colour set to this value (0: no kd from the
        mesh; 1: a white kd with the kd maps dropped too). ``None`` keeps them.
    """
    geo = scene.geometry
    twin = copy.copy(geo)  # SceneGeometry.__copy__: the same arrays and BVH memo
    twin.materials = np.ascontiguousarray(materials, np.float64)
    twin.reflective = bool(np.any(twin.materials[:, MAT_REFLECTIVITY] > 0))
    if colors is not None and geo.textured:
        twin.vertex_colors = np.full_like(geo.vertex_colors, colors)
        twin.face_colors = np.full_like(geo.face_colors, colors)
        if colors != 0:
            twin.tex_index = geo.tex_index.copy()
            twin.tex_index[:, TEXMAP_KD] = -1
    return scene.replace(geometry=twin, **changes)


def variant_inputs(inputs, origin, materials=None, colors=None, lights=None):
    """The frame's kernel inputs with other material rows, colours or lights, on a black background.

    Everything else (geometry, BVH, height maps, texels, camera row) is the frame's own,
    shared, not repacked. The compile-time flags are those :func:`.inputs.prepare` would
    give the varied scene, so the kernels are the variants they would be.

    Parameters
    ----------
    inputs : FrameInputs
        The frame's (:func:`.inputs.prepare`).
    origin : (3,) float64
        The scene's re-centring origin (lights pack themselves relative to it).
    materials : (G, MAT_SIZE) float64, optional
        Other material rows.
    colors : float, optional
        Every vertex and face colour set to this value (0: no kd from the mesh; 1: a
        white kd, with the kd maps dropped too). ``None`` keeps them.
    lights : sequence of Light, optional
        Other lights (``()``: none). ``None`` keeps the frame's.

    Returns
    -------
    FrameInputs
    """
    changes = dict(background=np.zeros(3))
    mats = inputs.materials if materials is None else np.ascontiguousarray(materials, np.float64)
    changes["materials"] = mats
    if colors is not None and inputs.tex_on:
        T = inputs.colours
        tex_index = T.tex_index
        if colors != 0:
            tex_index = tex_index.copy()
            tex_index[:, TEXMAP_KD] = -1
        changes["colours"] = colours(np.full_like(T.vertex_colors, colors), np.full_like(T.face_colors, colors),
                                     T.color_mode, tex_index, T.tex_texels, T.tex_info)
    L = inputs.lighting
    rows, handle = L.lights, L.handle
    if lights is not None:
        rows = np.zeros((len(lights), LIGHT_SIZE))
        for i, light in enumerate(lights):
            rows[i] = light.pack(origin)
        # prepare() passes the BVH only when a light casts shadows (it moves the shadow-ray origin).
        handle = handle if rows[:, LIGHT_SHADOWS].any() else np.uintp(0)
    changes["lighting"] = lighting(L.ambient, rows, mats, L.dmin, handle, L.unit)  # the flags, as prepare()'s
    return dataclasses.replace(inputs, **changes)


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


def shade_terms(scene, camera, hits, shading, max_depth: int = 0, per_light: bool = False, inputs=None) -> dict:
    """Each term of the reflectance equation shaded over a hit buffer.

    Parameters
    ----------
    scene, camera, hits, shading
        As :func:`.shade.shade_hits` (one method, or one per model).
    max_depth : int
        Mirror bounces, as ``render``'s.
    per_light : bool
        Also each light's diffuse and specular term.
    inputs : FrameInputs, optional
        The frame's kernel inputs (:func:`.inputs.prepare`); packed here when not given.
        Every term shades a variant of them (:func:`variant_inputs`): nothing is repacked.

    Returns
    -------
    dict of str to ndarray
        ``ambient``, ``diffuse``, ``specular``, ``emissive``, ``reflected``, ``background``
        (H, W, 3) float32; ``keep`` (H, W) float32; ``shadow`` (L, H, W)
        float32; with ``per_light``, ``diffuse_per_light`` and
        ``specular_per_light`` (L, H, W, 3) float32. See the module docstring
        for what they mean and how they add up.
    """
    k = prepare(scene, camera) if inputs is None else inputs
    shader = TermShading(scene, camera, shading, k, per_light)  # the image's own pass writes the terms
    shader.shade(hits)
    return shader.terms(hits, max_depth)


def _variant_terms(scene, shaded, mats, h, w, per_light) -> dict:
    """The local terms, per-light terms and shadow mask, one shading pass of a variant each:
    the definition the one-pass terms (:class:`.termshade.TermShading`) are tested against
    (``shaded(**variant)`` shades a variant of the frame's inputs, :func:`variant_inputs`)."""
    out = {
        "ambient": shaded(materials=_rows(mats, (MAT_KA,)), lights=()),
        "diffuse": shaded(materials=_rows(mats, (MAT_KD,))),
        "specular": shaded(materials=_rows(mats, (MAT_KS,)), colors=0.0),
    }
    if np.any(mats[:, MAT_KE:MAT_KE + 3] > 0):
        out["emissive"] = shaded(materials=_rows(mats, (MAT_KE,)), lights=())
    else:  # no emission anywhere: no shading pass
        out["emissive"] = np.zeros((h, w, 3), np.float32)
    if per_light:
        for name, slot, colors in (("diffuse", MAT_KD, None), ("specular", MAT_KS, 0.0)):
            rows = _rows(mats, (slot,))
            out[f"{name}_per_light"] = np.stack(
                [shaded(materials=rows, colors=colors, lights=(light,)) for light in scene.lights]
            ) if scene.lights else np.zeros((0, h, w, 3), np.float32)
    out["shadow"] = _shadow_mask(scene, shaded, (h, w), mats)
    return out


def _shadow_mask(scene, shaded, shape, mats) -> np.ndarray:
    """(L, H, W) float32, see the module docstring; ``shaded(**variant)`` shades a variant."""
    mask = np.ones((len(scene.lights),) + shape, np.float32)
    probe = _rows(mats, ())
    probe[:, MAT_KD:MAT_KD + 3] = 1.0
    for i, light in enumerate(scene.lights):
        if not light.shadows:
            continue
        img = shaded(materials=probe, colors=1.0, lights=_shadow_probe(light))
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
