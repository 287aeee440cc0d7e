"""The reflectance equation's terms by their definition: one shading pass of a variant each.

The equation is linear in the material coefficients and in the lights, and
every method interpolates linearly (Gouraud) or not at all, so each term of
:mod:`raycast_shade.shading.terms` is the same hit buffer shaded by the
unchanged kernels with a variant of the frame's kernel inputs
(:func:`variant_inputs`): no lights and ``ke = 0`` (ambient), ``ka = ks =
ke = 0`` (diffuse), ``ka = kd = ke = 0`` (specular), no lights and ``ka =
0`` (emissive), one light at a time (per-light terms), and for each
shadow-casting light a probe of two unit lights (the shadow mask,
:func:`shadow_probe`).

``render`` does not shade these variants: the image's own pass writes the
terms (:class:`raycast_shade.shading.termshade.TermShading`), and the tests
hold it to :func:`variant_terms` (measured equal, bit for bit, on the test
scenes). The passes live here, with the other oracles, so that the library
carries only what renders.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..common.layout import LIGHT_SHADOWS, LIGHT_SIZE, MAT_KA, MAT_KD, MAT_KE, MAT_KS, TEXMAP_KD
from ..scene.lights import PointLight
from ..shading.inputs import colours, extensions, lighting, prepare
from ..shading.shade import SampleShading

__all__ = ["variant_inputs", "coefficient_rows", "shadow_probe", "shadow_mask", "variant_terms"]


def variant_inputs(inputs, origin, materials=None, colors=None, lights=None):
    """The frame's kernel inputs with other material rows, colours or lights, on a black background.

    Everything else (geometry, BVH, height maps, texels, camera row) is the frame's own,
    shared, not repacked. The frame's flags and variant are those
    :func:`raycast_shade.shading.inputs.prepare` would give the varied scene (derived by
    :func:`raycast_shade.shading.inputs.lighting`), so the kernels run as they would.

    Parameters
    ----------
    inputs : FrameInputs
        The frame's (:func:`raycast_shade.shading.inputs.prepare`).
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
    # the flags and the extensions marker, as prepare()'s (other lights or materials may need the full build)
    ext = extensions(rows, mats, inputs.bumps.nmap_index, inputs.tex_on)
    changes["lighting"] = lighting(L.ambient, rows, mats, L.dmin, handle, L.unit, ext)
    if ext is not inputs.bumps.ext:  # (else the frame's record, shared)
        changes["bumps"] = inputs.bumps._replace(ext=ext)
    return dataclasses.replace(inputs, **changes)


def coefficient_rows(materials, keep):
    """Material rows with the coefficient slots not in ``keep`` zeroed.

    Parameters
    ----------
    materials : (G, MAT_SIZE) float64
    keep : sequence of int
        The slots kept, of ``MAT_KA``, ``MAT_KD``, ``MAT_KS`` and ``MAT_KE``.

    Returns
    -------
    (G, MAT_SIZE) float64
        A copy.
    """
    out = materials.copy()
    for slot in (MAT_KA, MAT_KD, MAT_KS, MAT_KE):
        if slot not in keep:
            out[:, slot:slot + 3] = 0.0
    return out


def shadow_probe(light):
    """Two unit white lights where ``light`` is: their ratio is the shadow fraction.

    Parameters
    ----------
    light : Light

    Returns
    -------
    tuple of Light
        One tracing shadow rays into the red channel, one not into green, both unattenuated.
    """
    if isinstance(light, PointLight):
        common = dict(intensity=1.0, attenuation="none")
    else:
        common = dict(intensity=1.0)
    return (dataclasses.replace(light, color=(1.0, 0.0, 0.0), shadows=True, **common),
            dataclasses.replace(light, color=(0.0, 1.0, 0.0), shadows=False, **common))


def shadow_mask(scene, shaded, shape, materials) -> np.ndarray:
    """The shadow mask, one probe pass (:func:`shadow_probe`) per shadow-casting light.

    Parameters
    ----------
    scene : Scene
    shaded : callable
        ``shaded(**variant)``: the (H, W, 3) image of the frame's inputs varied by
        :func:`variant_inputs`'s keywords.
    shape : tuple of int
        ``(H, W)``.
    materials : (G, MAT_SIZE) float64
        The frame's material rows.

    Returns
    -------
    (L, H, W) float32
        See :mod:`raycast_shade.shading.terms`: 1 where a light is not blocked, casts no
        shadows or does not reach the point.
    """
    mask = np.ones((len(scene.lights),) + tuple(shape), np.float32)
    probe = coefficient_rows(materials, ())
    probe[:, MAT_KD:MAT_KD + 3] = 1.0
    for i, light in enumerate(scene.lights):
        if not light.shadows:
            continue
        # White kd, mesh colours 1, kd maps dropped: a hue would skew the probe's ratio.
        img = shaded(materials=probe, colors=1.0, lights=shadow_probe(light))
        through, reached = img[..., 0].astype(np.float64), img[..., 1].astype(np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            mask[i] = np.where(reached > 0.0, np.minimum(through / reached, 1.0), 1.0)
    return mask


def variant_terms(scene, camera, shading, hits, inputs=None, per_light: bool = False) -> dict:
    """The local terms, per-light terms and shadow mask, one shading pass of a variant each.

    Parameters
    ----------
    scene, camera, hits, shading
        As :func:`raycast_shade.shading.terms.shade_terms`.
    inputs : FrameInputs, optional
        The frame's kernel inputs (:func:`raycast_shade.shading.inputs.prepare`); packed here
        when not given. Every pass shades a variant of them (:func:`variant_inputs`).
    per_light : bool
        Also each light's diffuse and specular term.

    Returns
    -------
    dict of str to ndarray
        ``ambient``, ``diffuse``, ``specular``, ``emissive`` (H, W, 3) float32, ``shadow``
        (L, H, W) float32 and, with ``per_light``, ``diffuse_per_light`` and
        ``specular_per_light`` (L, H, W, 3) float32: the terms
        :func:`~raycast_shade.shading.terms.shade_terms` gives, without the mirror part,
        ``keep`` and ``background``.
    """
    k = prepare(scene, camera) if inputs is None else inputs
    mats = k.materials
    h, w = hits.shape

    def shaded(**variant):
        return SampleShading(scene, camera, shading, variant_inputs(k, scene.geometry.origin, **variant)).shade(hits)

    out = {
        "ambient": shaded(materials=coefficient_rows(mats, (MAT_KA,)), lights=()),
        "diffuse": shaded(materials=coefficient_rows(mats, (MAT_KD,))),
        # Mesh colours stand in for kd: a zero kd row alone would leave them in.
        "specular": shaded(materials=coefficient_rows(mats, (MAT_KS,)), colors=0.0),
    }
    if np.any(mats[:, MAT_KE:MAT_KE + 3] > 0):
        out["emissive"] = shaded(materials=coefficient_rows(mats, (MAT_KE,)), lights=())
    else:  # no emission anywhere: no shading pass
        out["emissive"] = np.zeros((h, w, 3), np.float32)
    if per_light:
        for name, slot, colors in (("diffuse", MAT_KD, None), ("specular", MAT_KS, 0.0)):
            rows = coefficient_rows(mats, (slot,))
            out[f"{name}_per_light"] = np.stack(
                [shaded(materials=rows, colors=colors, lights=(light,)) for light in scene.lights]
            ) if scene.lights else np.zeros((0, h, w, 3), np.float32)
    out["shadow"] = shadow_mask(scene, shaded, (h, w), mats)
    return out
