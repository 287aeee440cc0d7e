"""Reverse-mode gradients of a shaded frame over its fixed hit buffer: the kernels and their driver.

Given ``gimg = dL/dI`` for the linear image ``I`` (``frame.image``, float32 of the float64 the
kernels compute) and the hit buffer it was shaded from, :func:`frame_vjp` returns ``dL/d`` every
material, ambient and light parameter (one vector, the slots of
:func:`~raycast_shade.shading.grad_terms.layout`) and, on request, ``dL/d`` the packed vertex
normals, and (:mod:`.grad_geometry`) the vertex positions and camera pose. Each pixel's triangle is
held: the gradient is exact wherever the image is differentiable in the parameters; the edges,
where a pixel's triangle changes, are :mod:`.grad_edges`'.

Each method is differentiated where it evaluates the equation:

- Phong, per pixel: :func:`~raycast_shade.shading.grad_terms._reflected_vjp` at the pixel's
  shading point (the forward pass's :func:`~raycast_shade.shading.phong._shading_point`), then
  back through the renormalised interpolation of the vertex normals;
- Gouraud: each pixel's ``dL/dI`` spread onto its corners' shades with the forward pass's
  weights, then one VJP per vertex side (its normal enters the vertex shade directly);
- flat: each face's pixels summed onto the face, one VJP per face at its centre with its true
  normal, so a vertex normal's flat gradient is exactly 0.

Determinism: the per-pixel, per-vertex and per-face passes run in :data:`PARTS` fixed parts (not
one per thread), each summing into its own accumulator row, and the rows are added in part
order; the scatters onto vertices and faces run serially in row-major order. The result is
bit for bit the same run to run and on any number of threads.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.layout import (LIGHT_AREA, LIGHT_KIND, LIGHT_SAMPLES, MAT_MODEL, MAT_REFLECTIVITY, METHOD_FLAT,
                             METHOD_GOURAUD, METHOD_PHONG, MODEL_GGX)
from ..common.parallel import launch, share
from ..visibility.secondary import ray_scratch
from .grad_bump import perturb_partials
from .grad_geometry import faces_scatter, pixels_scatter, points_scatter, vertex_shades_kernel
from .grad_normal import _normal_vjp
from .grad_terms import _plain_vjp, _reflected_vjp, _rich, layout
from .grad_walk import (chunk_items, chunks, corner_gather, corner_normal_grad, face_grad, gouraud_pixel, pixel_at,
                        pixel_grad, vertex_grad)
from .jit import HELPER, JIT
from .phong import _shading_point
from .surface import _triangle
from .texture import _row_coefficients

__all__ = ["PARTS", "frame_vjp", "unsupported"]

PARTS = 16  # fixed parts of every parallel pass: the sums' order does not depend on the thread count


def unsupported(inputs, material_names, light_names, maps_asked: bool = False, geometry_asked: bool = False,
                mirrors_ok: bool = False) -> list:
    """What the gradient kernels do not differentiate in a frame's packed inputs, as messages
    naming the material or light (empty: everything is supported). ``maps_asked``: a colour, texel,
    height or normal-map family is asked for (:mod:`.grad_maps`, :mod:`.grad_bump`);
    ``geometry_asked``: the vertices or the camera pose are; ``mirrors_ok``: the caller adds the
    mirror bounce (:mod:`.grad_mirror`) and refuses the families it holds. On a scene with colours,
    maps, bump or normal maps the other families are :mod:`.grad_textured`'s and :mod:`.grad_bump`'s,
    which take neither GGX materials, mirrors nor area lights yet."""
    out = []
    mats = inputs.materials
    B = inputs.bumps
    bumped = bool(np.any(B.bump_index >= 0) or np.any(B.nmap_index >= 0))
    mapped = maps_asked or inputs.tex_on or bumped
    for m, name in enumerate(material_names):
        if mats[m, MAT_MODEL] == MODEL_GGX and mapped:
            out.append(f"material {name!r}: specular='ggx' has no gradients on a scene with colours, maps, bump or "
                       "normal maps, nor colour or texel gradients, yet (on other scenes its material's, lights' and "
                       "geometry's gradients are done)")
        if mats[m, MAT_REFLECTIVITY] > 0 and (mapped or not mirrors_ok):
            out.append(f"material {name!r}: reflectivity > 0 (mirror bounces): " + (
                "no gradients on a scene with colours, maps, bump or normal maps, nor colour or texel gradients, yet"
                if mapped else "not differentiated here (rs.grad differentiates one bounce; rs.fit not yet)"))
    if bumped and geometry_asked:
        out.append("bump and normal maps: the geometry (vertices, camera_eye, camera_rotation) has no "
                   "gradients on such a scene yet (every other parameter has)")
    if inputs.tex_on or bumped or maps_asked:
        lights = inputs.lighting.lights
        for i, name in enumerate(light_names):
            if lights[i, LIGHT_KIND] == LIGHT_AREA or lights[i, LIGHT_SAMPLES] > 1:
                out.append(f"light {name!r}: area lights have no gradients on a scene with colours, maps, bump or "
                           "normal maps, nor with colour or texel gradients, yet (on other scenes they have)")
    return out


@njit(**HELPER)
def _point_grads(gvg, i, gr):
    """``gvg[i] += (dL/dp, dL/dv)`` of :func:`_reflected_vjp`'s answer ``gr`` (none if ``gvg`` is
    empty)."""
    if gvg.shape[0] != 0:
        for c in range(3):
            gvg[i, c] += gr[1][c]
            gvg[i, 3 + c] += gr[2][c]


def _make_phong(rich: bool):
    """The Phong pixels' kernel (``rich``: :func:`~.grad_terms._make_reflected_vjp`'s)."""
    @njit(nogil=True, **JIT)
    def _phong_vjp_kernel(hits, G, B, L, face_off, materials, cam, modes, gimg, lay, acc, gpx, part):
        """Phong pixels: ``acc[k]`` (part ``k``) += ``dL/dparameters``; ``gpx`` (H, W, 9) the pixel's
        ``dL/da`` of its interpolated normal, ``dL/dp`` of its point and ``dL/dv`` of its view vector
        (for the normals and the geometry), or a (0, 0, 9) array for none."""
        want_n = gpx.shape[0] != 0
        k = part[0]
        h, w = hits[0].shape
        for y in range(*share(h, part)):
            S = ray_scratch()
            for x in range(w):
                shaded, at, gI = pixel_grad(hits, face_off, modes, METHOD_PHONG, gimg, y, x)
                if not shaded:
                    continue
                gm = at.gm
                hp = _shading_point(G, B, L, cam, at, np.bool_(False), (0.0, 0.0, 0.0))
                coef = _row_coefficients(materials, gm)
                if rich:  # a closure constant: the plain build compiles neither GGX nor light samples
                    gn, gp, gv = _reflected_vjp(hp, coef, materials, gm, L, S, gI, acc, k, lay)
                else:
                    gn, gp, gv = _plain_vjp(hp, coef, materials, gm, L, S, gI, acc, k, lay)
                if want_n:
                    ga = _normal_vjp(G.normals, _triangle(G.faces, at.f), at.b1, at.b2, hp.g, hp.sgn, gn)
                    for c in range(3):
                        gpx[y, x, c] = ga[c]
                        gpx[y, x, 3 + c] = gp[c]
                        gpx[y, x, 6 + c] = gv[c]

    return _phong_vjp_kernel


@njit(**JIT)
def _phong_normals_scatter(prim, geom, u, v, faces, face_off, modes, gpx, gnormals):
    """Serially, in row-major order: each Phong pixel's ``dL/da`` onto its corners' normals."""
    h, w = prim.shape
    for y in range(h):
        for x in range(w):
            shaded, at = pixel_at((prim, geom, u, v), face_off, modes, METHOD_PHONG, y, x)
            if not shaded:
                continue
            b = (1.0 - at.b1 - at.b2, at.b1, at.b2)
            for corner in range(3):
                i = faces[at.f, corner]
                for c in range(3):
                    gnormals[i, c] += b[corner] * gpx[y, x, c]


@njit(**JIT)
def _flat_gather(prim, geom, face_off, modes, gimg, gface):
    """Serially, in row-major order: each flat pixel's ``dL/dI`` summed onto its face."""
    h, w = prim.shape
    for y in range(h):
        for x in range(w):
            p = prim[y, x]
            if p < 0 or modes[geom[y, x]] != METHOD_FLAT:
                continue
            f = face_off[geom[y, x]] + p
            for c in range(3):
                gface[f, c] += gimg[y, x, c]


def _make_flat(rich: bool):
    """The flat faces' kernel (``rich`` as for :func:`_make_phong`)."""

    @njit(nogil=True, **JIT)
    def _flat_vjp_kernel(gface, G, face_model, materials, cam, L, lay, acc, gfg, part):
        """Flat faces (the forward pass's point: the centre, its true normal): ``acc[k]`` += the
        parameters' gradients; ``gfg`` (F, 9) the face's ``dL/dn``, ``dL/dp``, ``dL/dv`` for the
        geometry (each face in one part), or a (0, 9) array for none."""
        k = part[0]
        nf = G.faces.shape[0]
        for ch in range(*chunks(nf, part)):
            S = ray_scratch()
            for f in range(*chunk_items(nf, ch)):
                shaded, hp, gI = face_grad(G, cam, gface, f)
                if not shaded:
                    continue
                m = face_model[f]
                coef = _row_coefficients(materials, m)
                if rich:  # a closure constant (see _make_phong)
                    gr = _reflected_vjp(hp, coef, materials, m, L, S, gI, acc, k, lay)
                else:
                    gr = _plain_vjp(hp, coef, materials, m, L, S, gI, acc, k, lay)
                if gfg.shape[0] != 0:
                    for j in range(3):
                        for c in range(3):
                            gfg[f, 3 * j + c] = gr[j][c]

    return _flat_vjp_kernel


def _make_gouraud_gather(rich: bool):
    """The Gouraud pixels' gather (``rich`` as for :func:`_make_phong`)."""

    @njit(**JIT)
    def _gouraud_gather(hits, G, L, face_off, materials, cam, modes, gimg, lay, acc, gvert, gnormals, gvg):
        """Serially, in row-major order: each Gouraud pixel's ``dL/dI`` onto its corners' stored shades
        ``gvert`` (V, 2, 3) with the forward pass's weights and sides; a corner the forward pass shades on
        the spot (a zero normal, or one reflected into the face's hemisphere) is differentiated here,
        into ``acc[0]``, ``gnormals`` and ``gvg`` (V, 6: ``dL/dp``, ``dL/dv`` at the vertex; (0, 6) for
        none)."""
        S = ray_scratch()
        h, w = hits[0].shape
        for y in range(h):
            for x in range(w):
                shaded, at = pixel_at(hits, face_off, modes, METHOD_GOURAUD, y, x)
                if not shaded:
                    continue
                gm = at.gm
                tri, gn, side, wts = gouraud_pixel(G, cam, at)
                for corner in range(3):
                    i = tri[corner]
                    spot, hp, gI = corner_gather(G, cam, gimg, y, x, i, wts[corner], side, gn, gvert)
                    if not spot:
                        continue
                    # shaded on the spot: a zero normal (lit with the face's, no normal gradient) or one
                    # reflected across the face's plane
                    coef = _row_coefficients(materials, gm)
                    if rich:  # a closure constant (see _make_phong)
                        gr = _reflected_vjp(hp, coef, materials, gm, L, S, gI, acc, 0, lay)
                    else:
                        gr = _plain_vjp(hp, coef, materials, gm, L, S, gI, acc, 0, lay)
                    _point_grads(gvg, i, gr)
                    corner_normal_grad(G, i, side, gn, gr[0], gnormals)

    return _gouraud_gather


def _make_gouraud(rich: bool):
    """The Gouraud vertices' kernel (``rich`` as for :func:`_make_phong`)."""

    @njit(nogil=True, **JIT)
    def _gouraud_vjp_kernel(gvert, G, vertex_model, materials, cam, L, lay, acc, gnormals, gvg, part):
        """Gouraud vertices (the forward pass's point: the vertex, lit with its own normal from the side
        a face needs): ``acc[k]`` += the parameters' gradients, ``gnormals[i]`` += the normal's (each
        vertex in one part only)."""
        k = part[0]
        n = G.verts.shape[0]
        for ch in range(*chunks(n, part)):
            S = ray_scratch()
            for i in range(*chunk_items(n, ch)):
                for side in range(2):
                    shaded, hp, gI = vertex_grad(G, cam, gvert, i, side)
                    if not shaded:
                        continue
                    m = vertex_model[i]
                    coef = _row_coefficients(materials, m)
                    if rich:  # a closure constant (see _make_phong)
                        gr = _reflected_vjp(hp, coef, materials, m, L, S, gI, acc, k, lay)
                    else:
                        gr = _plain_vjp(hp, coef, materials, m, L, S, gI, acc, k, lay)
                    _point_grads(gvg, i, gr)
                    sg = 1.0 - 2.0 * side
                    for c in range(3):
                        gnormals[i, c] += sg * gr[0][c]

    return _gouraud_vjp_kernel


# Each family's two builds, compiled on first use: a scene without GGX materials or area lights
# never compiles the rich ones (``_rich``).
_PHONG = {r: _make_phong(r) for r in (False, True)}
_FLAT = {r: _make_flat(r) for r in (False, True)}
_GOURAUD_GATHER = {r: _make_gouraud_gather(r) for r in (False, True)}
_GOURAUD = {r: _make_gouraud(r) for r in (False, True)}
# The plain builds under the kernels' own names (other modules' notes refer to them).
_phong_vjp_kernel, _flat_vjp_kernel = _PHONG[False], _FLAT[False]
_gouraud_gather, _gouraud_vjp_kernel = _GOURAUD_GATHER[False], _GOURAUD[False]


def _reduce(acc) -> np.ndarray:
    """The accumulator's rows added in row order (fixed: NumPy's pairwise sum would be too, but
    this states it)."""
    total = acc[0].copy()
    for r in range(1, acc.shape[0]):
        total += acc[r]
    return total


def frame_vjp(hits, inputs, modes, gimg, geo, want_normals: bool = False, want_geometry: bool = False):
    """``dL/dparameters`` (and ``dL/dnormals``, ``dL/dvertices``, ``dL/dcamera``) of a frame shaded
    from ``hits``.

    Parameters
    ----------
    hits : HitBuffer
        The frame's hit buffer (H, W); each pixel's triangle held fixed.
    inputs : FrameInputs
        The packed inputs the image was (or would be) shaded with; :func:`unsupported` must
        be empty for them.
    modes : (G,) int8
        Each model's method code.
    gimg : (H, W, 3) float64
        ``dL/dI`` for the linear image.
    geo : SceneGeometry
        The scene's packed geometry (its ``face_model`` and ``vertex_model``).
    want_normals : bool
        Also the gradient with respect to the packed vertex normals.
    want_geometry : bool
        Also the gradients with respect to the packed vertex positions and the camera pose
        (:mod:`.grad_geometry`, the interior: each pixel's triangle fixed).

    Returns
    -------
    params : (R,) float64
        The slots of :func:`~raycast_shade.shading.grad_terms.layout`.
    gnormals : (V, 3) float64 or None
    gverts : (V, 3) float64 or None
    gcam : (6,) float64 or None
        ``dL/deye`` and ``dL/dw`` of the camera's left-multiplied rotation ``w``.
    """
    G, B, L = inputs.geometry, inputs.bumps, inputs.lighting
    mats, cam, face_off = inputs.materials, inputs.cam, inputs.face_off
    amb, lb, size = layout(mats.shape[0], L.lights.shape[0])
    lay = (np.int64(amb), np.int64(lb))
    rich = _rich(mats, L.lights)
    acc = np.zeros((PARTS, size))
    serial = np.zeros((1, size))
    nv, nf = G.verts.shape[0], G.faces.shape[0]
    gnormals = np.zeros((nv, 3))
    gverts = np.zeros((nv, 3))
    gcam = np.zeros(6)
    hit = (hits.prim, hits.geom, hits.u, hits.v)
    gpx = np.zeros(gimg.shape[:2] + (9,) if want_normals or want_geometry else (0, 0, 9))
    if np.any(modes == METHOD_PHONG):
        launch(_PHONG[rich], hit, G, B, L, face_off, mats, cam, modes, gimg, lay, acc, gpx, parts=PARTS,
               dynamic=True)
        if want_normals and (np.any(B.bump_index >= 0) or np.any(B.nmap_index >= 0)):
            perturb_partials(hits, inputs, modes, gimg, gpx)  # bumped pixels' dL/da through the bent normal
        if want_normals:
            _phong_normals_scatter(*hit, G.faces, face_off, modes, gpx, gnormals)
    if np.any(modes == METHOD_FLAT):
        gface = np.zeros((nf, 3))
        gfg = np.zeros((nf if want_geometry else 0, 9))
        _flat_gather(hits.prim, hits.geom, face_off, modes, gimg, gface)
        launch(_FLAT[rich], gface, G, geo.face_model, mats, cam, L, lay, acc, gfg, parts=PARTS, dynamic=True)
        if want_geometry:
            faces_scatter(gfg, G, cam, gverts, gcam)
    vcol = np.zeros((0, 2, 3))
    if np.any(modes == METHOD_GOURAUD):
        gvert = np.zeros((nv, 2, 3))
        gvg = np.zeros((nv if want_geometry else 0, 6))
        _GOURAUD_GATHER[rich](hit, G, L, face_off, mats, cam, modes, gimg, lay, serial, gvert, gnormals, gvg)
        launch(_GOURAUD[rich], gvert, G, geo.vertex_model, mats, cam, L, lay, acc, gnormals, gvg, parts=PARTS,
               dynamic=True)
        if want_geometry:
            points_scatter(gvg, G.verts, cam, gverts, gcam)
            vcol = np.zeros((nv, 2, 3))
            launch(vertex_shades_kernel, G, geo.vertex_model, mats, cam, L, vcol, parts=PARTS, dynamic=True)
    if want_geometry and (np.any(modes == METHOD_PHONG) or np.any(modes == METHOD_GOURAUD)):
        pixels_scatter(hit, G, L, face_off, mats, cam, modes, gimg, gpx, vcol, gverts, gcam)
    params = serial[0] + _reduce(acc)
    return (params, gnormals if want_normals else None, gverts if want_geometry else None,
            gcam if want_geometry else None)
