"""Reverse-mode gradients of a frame with respect to mesh colours and colour-map texels.

The reflectance equation is linear in a point's own coefficients::

    I = Ia ka + sum_i vis_i att_i Ii (kd (n.s) + ks c^t) + ke

so ``dL/dkd`` at a point is ``gI * sum_i vis_i att_i Ii (n.s)`` (per channel), ``dL/dka`` is
``gI * Ia`` and ``dL/dks`` is ``gI * sum_i vis_i att_i Ii c^t``: exactly what
:func:`~raycast_shade.shading.grad_terms._reflected_vjp` adds to a model's ``kd``, ``ka`` and ``ks``
slots. :func:`_point_partials` reads them from a scratch row, evaluated where the forward method
evaluates the equation (Phong: each pixel; flat: each face's centre, its pixels' ``dL/dI`` summed;
Gouraud: each vertex side, its pixels' ``dL/dI`` spread with the forward weights, and the corners
the forward pass shades on the spot where it does). :func:`map_partials` returns them per pixel
(Phong), per face (flat) and per vertex (Gouraud); the driver (:func:`raycast_shade.grad`) chains
them to the parameters:

- a vertex colour replaces kd (times the kd map's sample; ``ka`` times it with the material's
  ``ka_colors``, and the ka map's sample and the occlusion: :func:`_factors`): Phong
  ``kd = b0 c0 + b1 c1 + b2 c2`` (the hit's barycentrics), flat the mean of the three (the face's
  centre), Gouraud each vertex's own;
- a face colour replaces kd on its face; Gouraud's modulate path (a model with a map or face
  colours) is differentiated per pixel: ``dL/dkd = gI D`` with the corners' diffuse light ``D``
  interpolated (each corner's from its own point, shares ``w_k gI``), likewise ks;
- a kd or ks map multiplies the row's kd or ks by its sample at the point's UV: the four texels
  around it get the bilinear weights (wrapped or clamped as the forward sampler does); a mip-mapped
  map's two levels their trilinear weights, each level's gradient then taken down the pyramid by the
  transpose of its box filter (the level of detail, a function of the geometry, held)
  (:mod:`.grad_texels`);
- a ka map's sample multiplies the row's ka, the colour (``ka_colors``) and the occlusion; an emission
  map's the row's ke (``dL/dke = dL/dI``); an occlusion map's red channel ``ao`` enters ka as
  ``1 + s (ao - 1)`` (:func:`_sample_gradient`).

The passes over pixels, faces and vertices run in :data:`~raycast_shade.shading.grad_frame.PARTS`
fixed parts, each point written to its own output row; the scatters onto vertices, faces and
texels run in NumPy (``np.bincount``, in index order): bit-identical on any number of threads.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.layout import (COLOR_FACE, COLOR_NONE, COLOR_VERTEX, MAT_AO_STRENGTH, MAT_KA, MAT_KA_COLORS, MAT_KD,
                             MAT_KE, MAT_KS, METHOD_FLAT, METHOD_GOURAUD, METHOD_PHONG, TEX_MIPMAP, TEXMAP_AO, TEXMAP_KA,
                             TEXMAP_KD, TEXMAP_KE, TEXMAP_KS)
from ..common.parallel import launch, share
from ..visibility.secondary import ray_scratch
from .grad_frame import _flat_gather
from .grad_texels import add_rows, face_rho, pixel_rho, texel_gradient
from .grad_terms import GM_KA, GM_KD, GM_KS, GM_SIZE, _plain_vjp, layout
from .grad_walk import (chunk_items, chunks, corner_gather, corner_hit, face_grad, gouraud_pixel, pixel_at,
                        pixel_grad, vertex_grad)
from .jit import HELPER, JIT
from .phong import _shading_point
from .records import At
from .surface import _triangle
from .texture import _coefficients, _face_footprint, _point_coefficients, _row_coefficients

__all__ = ["MAPS", "map_partials", "maps_gradients"]

PARTS = 16  # as grad_frame.PARTS: the parts do not depend on the thread count
MAPS = ("vertex_colors", "face_colors", "kd_map", "ks_map", "ka_map", "ke_map", "ao_map")
"""The names :func:`maps_gradients` answers."""
_MAP_SLOT = {"kd_map": (TEXMAP_KD, MAT_KD, 3), "ks_map": (TEXMAP_KS, MAT_KS, 6), "ka_map": (TEXMAP_KA, MAT_KA, 0),
             "ke_map": (TEXMAP_KE, MAT_KE, -1), "ao_map": (TEXMAP_AO, MAT_KA, 0)}


@njit(**HELPER)
def _point_partials(hp, mats, mi, L, S, gI, scratch, lay, out, r):
    """``out[r] += dL/d(ka, kd, ks)`` (9) of the point's own coefficients at ``hp`` for
    ``gI = dL/dI``, via a zeroed scratch row ``scratch`` (1, R)."""
    mb = mi * GM_SIZE
    for j in range(scratch.shape[1]):
        scratch[0, j] = 0.0
    _plain_vjp(hp, _row_coefficients(mats, mi), mats, mi, L, S, gI, scratch, 0, lay)  # no GGX, no area lights here (refused)
    for c in range(3):
        out[r, c] += scratch[0, mb + GM_KA + c]
        out[r, 3 + c] += scratch[0, mb + GM_KD + c]
        out[r, 6 + c] += scratch[0, mb + GM_KS + c]


@njit(nogil=True, **JIT)
def _pixel_partials_kernel(hits, G, B, L, face_off, materials, cam, modes, points, gimg, lay, size, out, part):
    """The points that are pixels (of the models ``points`` flags: Phong's, and Gouraud's on the
    modulate path): ``out[y * W + x]`` = the pixel's ``dL/d(ka, kd, ks)`` (rows of other pixels 0).
    Phong: at the pixel's shading point. Gouraud's modulate path (a model with a map or face colours:
    ``Ia ka + D kd + S ks`` with the corners' diffuse and specular light ``D``, ``S`` interpolated):
    each corner's, its ``dL/dI`` share ``w_k gI`` (the weights sum to 1)."""
    h, w = hits[0].shape
    scratch = np.zeros((1, size))
    for y in range(*share(h, part)):
        S = ray_scratch()
        for x in range(w):
            shaded, at, gI = pixel_grad(hits, face_off, points, 1, gimg, y, x)
            if not shaded:
                continue
            gm = at.gm
            if modes[gm] == METHOD_PHONG:
                hp = _shading_point(G, B, L, cam, at, np.bool_(False), (0.0, 0.0, 0.0))
                _point_partials(hp, materials, gm, L, S, gI, scratch, lay, out, y * w + x)
                continue
            tri, gn, side, wts = gouraud_pixel(G, cam, at)
            for corner in range(3):
                hp, _ = corner_hit(G, cam, tri[corner], side, gn)
                wk = wts[corner]
                _point_partials(hp, materials, gm, L, S, (wk * gI[0], wk * gI[1], wk * gI[2]), scratch, lay, out,
                                y * w + x)


@njit(nogil=True, **JIT)
def _flat_partials_kernel(gface, G, face_model, materials, cam, L, lay, size, out, part):
    """Flat faces (the centre, the true normal, as the forward pass): ``out[f]`` = ``dL/d(ka, kd, ks)``
    of the face's coefficients, ``gface`` (F, 3) its pixels' summed ``dL/dI``."""
    nf = G.faces.shape[0]
    scratch = np.zeros((1, size))
    for ch in range(*chunks(nf, part)):
        S = ray_scratch()
        for f in range(*chunk_items(nf, ch)):
            shaded, hp, gI = face_grad(G, cam, gface, f)
            if shaded:
                _point_partials(hp, materials, face_model[f], L, S, gI, scratch, lay, out, f)


@njit(**JIT)
def _gouraud_gather_partials(hits, G, L, face_off, materials, cam, modes, modulate, gimg, lay, size, gvert, out):
    """Serially, in row-major order: each Gouraud pixel's (not on the modulate path) ``dL/dI`` onto its
    corners' stored shades ``gvert`` (V, 2, 3) with the forward weights and sides; a corner the forward
    pass shades on the spot adds its ``dL/d(ka, kd, ks)`` into ``out[i]`` here."""
    S = ray_scratch()
    scratch = np.zeros((1, size))
    h, w = hits[0].shape
    for y in range(h):
        for x in range(w):
            shaded, at = pixel_at(hits, face_off, modes, METHOD_GOURAUD, y, x)
            if not shaded or modulate[at.gm] != 0:
                continue
            gm = at.gm
            tri, gn, side, wts = gouraud_pixel(G, cam, at)
            for corner in range(3):
                i = tri[corner]
                spot, hp, gI = corner_gather(G, cam, gimg, y, x, i, wts[corner], side, gn, gvert)
                if spot:
                    _point_partials(hp, materials, gm, L, S, gI, scratch, lay, out, i)


@njit(nogil=True, **JIT)
def _gouraud_partials_kernel(gvert, G, vertex_model, materials, cam, L, lay, size, out, part):
    """Gouraud vertices (lit with their own normal from each side a face needs): ``out[i]`` +=
    ``dL/d(ka, kd, ks)`` of the vertex's coefficients (each vertex in one part)."""
    n = G.verts.shape[0]
    scratch = np.zeros((1, size))
    for ch in range(*chunks(n, part)):
        S = ray_scratch()
        for i in range(*chunk_items(n, ch)):
            for side in range(2):
                shaded, hp, gI = vertex_grad(G, cam, gvert, i, side)
                if shaded:
                    _point_partials(hp, materials, vertex_model[i], L, S, gI, scratch, lay, out, i)


@njit(nogil=True, **JIT)
def _factors_kernel(hits, G, uvs, cam, face_off, unit_mats, Tn, need, fac, part):
    """Pixels of the models ``need`` flags: ``fac[y * W + x]`` = (the kd map's filtered sample, the ka
    map's times the occlusion), :func:`~raycast_shade.shading.texture._point_coefficients` with unit
    ka and kd rows and no colours (``unit_mats``, ``Tn``): what multiplies the mesh colour there."""
    h, w = hits[0].shape
    for y in range(*share(h, part)):
        for x in range(w):
            shaded, at = pixel_at(hits, face_off, need, 1, y, x)
            if not shaded:
                continue
            coef = _point_coefficients(G, uvs, at, cam, x, y, True, unit_mats, Tn)
            for c in range(3):
                fac[y * w + x, c] = coef[3 + c]
                fac[y * w + x, 3 + c] = coef[c]


@njit(**JIT)
def _face_factors(faces, uvs, face_model, unit_mats, Tn, need, fac):
    """:func:`_factors_kernel` for flat faces (their centres and footprints, as the forward pass)."""
    third = 1.0 / 3.0
    for f in range(faces.shape[0]):
        m = face_model[f]
        if need[m] == 0:
            continue
        tri = _triangle(faces, f)
        coef = _coefficients(unit_mats, Tn, At(f, m, third, third), tri, uvs, _face_footprint(uvs, tri))
        for c in range(3):
            fac[f, c] = coef[3 + c]
            fac[f, 3 + c] = coef[c]


def _unit_samples(hits, inputs, geo, partials, need, keep):
    """:func:`_factors_kernel` with unit ``ka``, ``kd`` rows, no colours, and only the map slots
    ``keep`` (the others dropped) for the models ``need`` flags: ``{"pixels": (H * W, 6), "flat": (F, 6)}``
    (the kd and ka coefficients; ones elsewhere)."""
    T = inputs.colours
    out = {"pixels": np.ones((hits.prim.size, 6)), "flat": np.ones((inputs.geometry.faces.shape[0], 6))}
    if not need.any():
        return out
    unit = inputs.materials.copy()
    unit[:, MAT_KA:MAT_KA + 3] = 1.0
    unit[:, MAT_KD:MAT_KD + 3] = 1.0
    unit[:, MAT_KA_COLORS] = 0.0
    tindex = np.full_like(T.tex_index, -1)
    tindex[:, list(keep)] = T.tex_index[:, list(keep)]
    Tn = T._replace(color_mode=np.zeros_like(T.color_mode), tex_index=tindex)
    G = inputs.geometry
    need = need.astype(np.int8)  # int8 as the modes: the kernel's pixel_at takes the pixels of the 1s
    if "pixels" in partials:
        launch(_factors_kernel, (hits.prim, hits.geom, hits.u, hits.v), G, inputs.bumps.uvs, inputs.cam,
               inputs.face_off, unit, Tn, need, out["pixels"], parts=PARTS, dynamic=True)
    if "flat" in partials:
        _face_factors(G.faces, inputs.bumps.uvs, geo.face_model, unit, Tn, need, out["flat"])
    return out


def _factors(hits, inputs, geo, partials, names=()):
    """What multiplies each point's mesh colour and the ka, ke and occlusion maps' samples
    (:func:`_factors_kernel`): ``{"pixels": (H * W, 12), "flat": (F, 12)}``, columns the kd map's
    sample, the ka map's times the occlusion, the ka map's alone, the occlusion alone (ones where a
    model has no such map; the last six only when ``names`` asks for ka or occlusion texels)."""
    T = inputs.colours
    slots = [TEXMAP_KA, TEXMAP_KD, TEXMAP_KS, TEXMAP_KE, TEXMAP_AO]
    out = _unit_samples(hits, inputs, geo, partials, (T.color_mode != COLOR_NONE) & (T.tex_index >= 0).any(axis=1),
                        slots)
    alone = [_unit_samples(hits, inputs, geo, partials,
                           (T.tex_index[:, slot] >= 0) & any(n in names for n in ("ka_map", "ao_map")), (slot,))
             for slot in (TEXMAP_KA, TEXMAP_AO)]
    return {key: np.hstack([out[key], alone[0][key][:, 3:6], alone[1][key][:, 3:6]]) for key in out}


def map_partials(hits, inputs, modes, gimg, geo) -> dict:
    """``dL/d(ka, kd, ks)`` of the points where each method evaluates the equation.

    Parameters
    ----------
    hits : HitBuffer
        The frame's hit buffer (H, W); each pixel's triangle held.
    inputs : FrameInputs
        The frame's packed inputs.
    modes : (G,) int8
        Each model's method code.
    gimg : (H, W, 3) float64
        ``dL/dI`` for the linear image.
    geo : SceneGeometry
        The scene's packed geometry (its ``face_model`` and ``vertex_model``).

    Returns
    -------
    dict
        ``"pixels"``: (H * W, 9) per pixel (row-major; Phong's and Gouraud's modulate path's, zero
        elsewhere), ``"flat"``: (F, 9) per
        face, ``"gouraud"``: (V, 9) per vertex (models off the modulate path); the columns ``dL/dka``, ``dL/dkd``, ``dL/dks`` (RGB).
        A method no model uses is absent.
    """
    G, B, L = inputs.geometry, inputs.bumps, inputs.lighting
    mats, cam, face_off = inputs.materials, inputs.cam, inputs.face_off
    amb, lb, size = layout(mats.shape[0], L.lights.shape[0])
    lay = (np.int64(amb), np.int64(lb))
    size = np.int64(size)
    hit = (hits.prim, hits.geom, hits.u, hits.v)
    nv, nf = G.verts.shape[0], G.faces.shape[0]
    out = {}
    modulate = inputs.colours.modulate
    if np.any(modes == METHOD_PHONG) or np.any((modes == METHOD_GOURAUD) & (modulate != 0)):
        out["pixels"] = np.zeros((hits.prim.size, 9))
        points = ((modes == METHOD_PHONG) | ((modes == METHOD_GOURAUD) & (modulate != 0))).astype(np.int8)
        launch(_pixel_partials_kernel, hit, G, B, L, face_off, mats, cam, modes, points, gimg, lay, size,
               out["pixels"], parts=PARTS, dynamic=True)
    if np.any(modes == METHOD_FLAT):
        gface = np.zeros((nf, 3))
        _flat_gather(hits.prim, hits.geom, face_off, modes, gimg, gface)
        out["flat"] = np.zeros((nf, 9))
        launch(_flat_partials_kernel, gface, G, geo.face_model, mats, cam, L, lay, size, out["flat"], parts=PARTS,
               dynamic=True)
    if np.any(modes == METHOD_GOURAUD):
        gvert = np.zeros((nv, 2, 3))
        out["gouraud"] = np.zeros((nv, 9))
        _gouraud_gather_partials(hit, G, L, face_off, mats, cam, modes, modulate, gimg, lay, size, gvert,
                                 out["gouraud"])
        launch(_gouraud_partials_kernel, gvert, G, geo.vertex_model, mats, cam, L, lay, size, out["gouraud"],
               parts=PARTS, dynamic=True)
    return out


def _points(hits, inputs, modes, geo, partials, factors):
    """Every point the methods evaluated, as flat arrays: ``(model, face, barycentrics (N, 3), vertex
    or -1, dL/d(ka, kd, ks) (N, 9), the faces (F, 3), the pixel (row-major index) or -1)``: Phong's
    pixels (row-major), flat's faces (their centres), Gouraud's vertices, in that order (the scatters'
    fixed order)."""
    faces = inputs.geometry.faces
    model, face, bary, vert, part, pix, fac = [], [], [], [], [], [], []
    modulate = inputs.colours.modulate
    if "pixels" in partials:
        prim, geom = hits.prim.ravel(), hits.geom.ravel()
        sel = np.flatnonzero(prim >= 0)
        mode = modes[geom[sel]]
        sel = sel[(mode == METHOD_PHONG) | ((mode == METHOD_GOURAUD) & (modulate[geom[sel]] != 0))]
        b1 = hits.u.ravel()[sel].astype(np.float64)
        b2 = hits.v.ravel()[sel].astype(np.float64)
        model.append(geom[sel].astype(np.int64))
        face.append(inputs.face_off[geom[sel]] + prim[sel])
        bary.append(np.stack([1.0 - b1 - b2, b1, b2], axis=1))  # as texture._coefficients
        vert.append(np.full(sel.size, -1))
        part.append(partials["pixels"][sel])
        pix.append(sel)
        fac.append(factors["pixels"][sel])
    if "flat" in partials:
        sel = np.flatnonzero(modes[geo.face_model] == METHOD_FLAT)
        third = 1.0 / 3.0
        model.append(geo.face_model[sel].astype(np.int64))
        face.append(sel)
        bary.append(np.tile([1.0 - third - third, third, third], (sel.size, 1)))
        vert.append(np.full(sel.size, -1))
        part.append(partials["flat"][sel])
        pix.append(np.full(sel.size, -1))
        fac.append(factors["flat"][sel])
    if "gouraud" in partials:
        sel = np.flatnonzero((modes[geo.vertex_model] == METHOD_GOURAUD) & (modulate[geo.vertex_model] == 0))
        model.append(geo.vertex_model[sel].astype(np.int64))
        face.append(np.full(sel.size, -1))
        bary.append(np.zeros((sel.size, 3)))
        vert.append(sel)
        part.append(partials["gouraud"][sel])
        pix.append(np.full(sel.size, -1))
        fac.append(np.ones((sel.size, 12)))  # off the modulate path: no maps
    cat = (lambda a, shape: np.concatenate(a) if a else np.zeros(shape))
    return (cat(model, 0).astype(np.int64), cat(face, 0).astype(np.int64), cat(bary, (0, 3)),
            cat(vert, 0).astype(np.int64), cat(part, (0, 9)), faces, cat(pix, 0).astype(np.int64), cat(fac, (0, 12)))


def _colour_gradient(mats, model, part, fac):
    """``dL/d colour`` at each point: kd is the colour times the kd map's sample ``fac[:, :3]``, ka the
    row's ka times it with the row's ``ka_colors`` (times the ka map's sample and the occlusion,
    ``fac[:, 3:]``)."""
    kac = (mats[model, MAT_KA_COLORS] != 0.0)[:, None]
    return part[:, 3:6] * fac[:, 0:3] + np.where(kac, mats[model, MAT_KA:MAT_KA + 3] * fac[:, 3:6] * part[:, 0:3], 0.0)


def _point_colour(T, model, face, bary, faces):
    """The mesh colour at each point on a face (Phong's pixels, flat's centres), or NaN."""
    out = np.full((model.size, 3), np.nan)
    vx = T.color_mode[model] == COLOR_VERTEX
    out[vx] = np.einsum("nk,nkc->nc", bary[vx], T.vertex_colors[faces[face[vx]]])
    fx = T.color_mode[model] == COLOR_FACE
    out[fx] = T.face_colors[face[fx]]
    return out


def maps_gradients(hits, inputs, modes, gimg, geo, names) -> dict:
    """``dL/d`` the mesh colours and colour-map texels named in ``names`` (a subset of :data:`MAPS`).

    The scene's refusals (:func:`raycast_shade.gradients.grad`) come first.

    Returns
    -------
    dict
        ``"vertex_colors"`` (V, 3) and ``"face_colors"`` (F, 3), rows of the packed
        ``geo.vertex_colors``/``geo.face_colors`` (zero rows for models without);
        ``"kd_map"``, ``"ks_map"``, ``"ka_map"``, ``"ke_map"``, ``"ao_map"``: a tuple, per model, of
        its map's (h, w, 3) texel gradient (rows as its ``Texture.texels``: row 0 is ``v = 0``; the
        occlusion map's red channel only: the forward pass reads no other), None for a model without
        one.
    """
    partials = map_partials(hits, inputs, modes, gimg, geo)
    model, face, bary, vert, part, faces, pix, fac = _points(hits, inputs, modes, geo, partials,
                                                            _factors(hits, inputs, geo, partials, names))
    mats, T = inputs.materials, inputs.colours
    gpt = _point_gradients(hits, inputs, modes, gimg, face, pix) if "ke_map" in names else None
    cmode = T.color_mode
    out, rhos = {}, {}
    if "vertex_colors" in names:
        g = np.zeros((inputs.geometry.verts.shape[0], 3))
        sel = np.flatnonzero(cmode[model] == COLOR_VERTEX)
        gc = _colour_gradient(mats, model[sel], part[sel], fac[sel])
        at_vertex = vert[sel] >= 0  # Gouraud's vertices: their own colour
        add_rows(g, vert[sel[at_vertex]], gc[at_vertex])
        on_face = sel[~at_vertex]  # Phong's pixels, flat's faces: by the barycentrics
        tri, bary_f, gc = faces[face[on_face]], bary[on_face], gc[~at_vertex]
        for corner in range(3):
            add_rows(g, tri[:, corner], bary_f[:, corner, None] * gc)
        out["vertex_colors"] = g
    if "face_colors" in names:
        g = np.zeros((faces.shape[0], 3))
        sel = (cmode[model] == COLOR_FACE) & (face >= 0)
        add_rows(g, face[sel], _colour_gradient(mats, model[sel], part[sel], fac[sel]))
        out["face_colors"] = g
    for name in ("kd_map", "ks_map", "ka_map", "ke_map", "ao_map"):
        if name not in names:
            continue
        slot = _MAP_SLOT[name][0]
        maps = []
        for m in range(mats.shape[0]):
            k = T.tex_index[m, slot]
            if k < 0:
                maps.append(None)
                continue
            sel = (model == m) & (face >= 0)
            tri = faces[face[sel]]
            uvs = inputs.bumps.uvs
            uv = np.einsum("nk,nkc->nc", bary[sel], uvs[tri])
            rho = np.zeros(uv.shape[0])
            if T.tex_info[k, TEX_MIPMAP] != 0.0:
                if slot not in rhos:
                    rhos[slot] = pixel_rho(hits, inputs, slot)
                rho = rhos[slot][np.maximum(pix[sel], 0)]
                at_face = pix[sel] < 0
                rho[at_face] = face_rho(T.tex_info, k, uvs, tri[at_face])
            g = _sample_gradient(name, mats, T, m, sel, model, face, bary, faces, part, fac,
                                 None if gpt is None else gpt[sel])
            maps.append(texel_gradient(T.tex_info, k, uv, g, rho))
        out[name] = tuple(maps)
    return out


def _point_gradients(hits, inputs, modes, gimg, face, pix):
    """``dL/dI`` at each point of :func:`_points` on a face (a pixel's own; a flat face's, its pixels'
    summed), zero at Gouraud's vertices: what an emitted ``ke`` at the point is multiplied by."""
    out = np.zeros((face.size, 3))
    at_pixel = pix >= 0
    out[at_pixel] = gimg.reshape(-1, 3)[pix[at_pixel]]
    at_face = (pix < 0) & (face >= 0)
    if np.any(at_face):
        gface = np.zeros((inputs.geometry.faces.shape[0], 3))
        _flat_gather(hits.prim, hits.geom, inputs.face_off, modes, gimg, gface)
        out[at_face] = gface[face[at_face]]
    return out


def _sample_gradient(name, mats, T, m, sel, model, face, bary, faces, part, fac, gpt):
    """``dL/d`` the map ``name``'s filtered sample (N, 3) at model ``m``'s points ``sel``: the point's
    coefficient's gradient times what the sample multiplies there (:mod:`~raycast_shade.shading.texture`'s
    ``_coefficients``): kd the row's kd (or the mesh colour, which replaces it), ks the row's ks, ke the
    row's ke (``dL/dke = dL/dI``), ka the row's ka times the colour (``ka_colors``) and the occlusion
    ``1 + s (ao - 1)``; the occlusion map's red channel ``s`` times the sum over RGB of ``dL/dka`` times
    ka over the occlusion (its green and blue channels get 0)."""
    n = int(np.count_nonzero(sel))
    if name == "ke_map":
        return mats[m, MAT_KE:MAT_KE + 3] * gpt
    if name in ("kd_map", "ks_map"):
        _, row, col = _MAP_SLOT[name]
        base = np.broadcast_to(mats[m, row:row + 3], (n, 3))  # what the sample multiplies
        if name == "kd_map" and T.color_mode[m] != COLOR_NONE:  # the colour, in place of the row's kd
            base = _point_colour(T, model[sel], face[sel], bary[sel], faces)
        return base * part[sel, col:col + 3]
    ka = np.broadcast_to(mats[m, MAT_KA:MAT_KA + 3], (n, 3))
    if T.color_mode[m] != COLOR_NONE and mats[m, MAT_KA_COLORS] != 0.0:
        ka = ka * _point_colour(T, model[sel], face[sel], bary[sel], faces)
    ka_sample, occ = fac[sel, 6:9], fac[sel, 9:12]
    if name == "ka_map":
        return ka * occ * part[sel, 0:3]
    g = np.zeros((n, 3))
    g[:, 0] = mats[m, MAT_AO_STRENGTH] * np.sum(ka * ka_sample * part[sel, 0:3], axis=1)
    return g
