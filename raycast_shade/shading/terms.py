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
plain one. The variant passes, one shading pass of the frame's kernel
inputs with other material rows, mesh colours or lights each, are the
definition those are tested against; they live with the other oracles
(:mod:`raycast_shade.study.variant_terms`).
"""

from __future__ import annotations

import copy

import numpy as np

from ..common.layout import MAT_REFLECTIVITY, TEXMAP_KD
from .inputs import prepare
from .termshade import TermShading

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
    repacking and no new BVH. For the material explorer
    (:mod:`raycast_shade.apps.explore`), whose frames carry the varied scene;
    the terms' definition varies the frame's kernel inputs instead
    (:func:`raycast_shade.study.variant_terms.variant_inputs`).
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
        The image's own pass writes the terms: nothing is repacked.

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


def compose_terms(terms: dict) -> np.ndarray:
    """(H, W, 3) float32 ``keep * (ambient + diffuse + specular + emissive) + reflected + background``:
    the image the terms add up to."""
    local = terms["ambient"].astype(np.float64) + terms["diffuse"] + terms["specular"]
    if "emissive" in terms:
        local = local + terms["emissive"]
    total = terms["keep"][..., None] * local + terms["reflected"] + terms["background"]
    return total.astype(np.float32)
