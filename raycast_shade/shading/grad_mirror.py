"""Reverse-mode gradients through one mirror bounce (:mod:`.mirrors`), over the frame's hits.

A reflective pixel (``rho = reflectivity > 0``) is ``(1 - rho) local + rho R``, ``R`` the colour its
mirror ray meets: the Phong-shaded point there, seen along the ray (the one evaluator,
:func:`~raycast_shade.shading.illumination._reflected`), or the background on a miss. So::

    dL/d(local)   = (1 - rho) dL/dI           (the method's own VJP, with dL/dI scaled)
    dL/d(R)       = rho dL/dI                 (:func:`~.grad_terms._reflected_vjp` at the bounce point)
    dL/d(rho)     = dL/dI . (R - local)

For the materials and lights the mirror ray and its hit are held (they depend on the geometry
only). Each ray is the forward's own (:func:`~.mirror_rays._mirror_ray` of :func:`~.phong._surface`),
traced alone (one lane of a closest-hit packet); shadow rays at the bounce are traced again, as the
forward traces them, and a blocked light stays blocked. One bounce only: a ray that meets another
reflective surface is reported (``nested``), and the caller refuses the frame (unless rendered with
``max_depth=1``).

The geometry and the vertex normals (:func:`mirror_scatter`): the ray leaves the mirror's hit ``p``
along ``r = -v + 2 (v.n) n`` (``n`` the mirror's interpolated normal, its weights moving with the hit)
and meets the bounce's held triangle at ``q``. Back from ``_reflected_vjp``'s ``dL/dn_q, dL/dq,
dL/dv_q`` at ``q``: the bounce's normal onto its barycentrics, the ray-triangle VJP
(:func:`~.grad_geometry.ray_hit_vjp`, the camera rays' closed form applied to the mirror ray), the
view ``-r``, the reflection (``dL/dv = -g + 2 n (n.g)``, ``dL/dn = 2 ((n.g) v + (v.n) g)``), the
mirror's normal onto its barycentrics, and the mirror pixel's own hit
(:func:`~.grad_geometry.pixel_hit_vjp`). Held: both triangles, the origin's push off the surface,
the flip of a reflection sent below the mirror's plane (a fixed reflection), a miss.

Determinism: the pixels are summed in :data:`~.grad_frame.PARTS`'s fixed parts of rows, each
into its own accumulator row, added in part order by the caller; the geometry's scatter is serial in
row-major order.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.layout import MAT_REFLECTIVITY
from ..common.parallel import launch, share
from ..visibility.secondary import closest_hit, closest_packet, ray_scratch, set_closest_rays, trace_closest
from .grad_geometry import _add_cam, _view_vjp, pixel_hit_vjp, ray_hit_vjp
from .grad_normal import _normal_vjp
from .grad_terms import GM_REFLECTIVITY, GM_SIZE, _reflected_vjp
from .illumination import _illuminate
from .jit import HELPER, JIT
from .mirror_rays import _mirror_ray
from .mirrors import MIRROR_FLAGS
from .phong import _shading_point, _surface
from .records import At, dot
from .surface import _triangle
from .texture import _row_coefficients

__all__ = ["mirror_scatter", "mirror_vjp"]

_LANES = 16  # a closest-hit packet's lanes (visibility.secondary): one used


@njit(nogil=True, **JIT)
def _bounce_kernel(hits, G, B, L, face_off, mats, cam, trace, background, gimg, local, lay, acc, out, part):
    """Reflective pixels of this part's rows: ``acc[k]`` += the bounce's parameter gradients
    (``rho dL/dI`` at the point the mirror ray meets) and ``dL/drho``; ``out = (nested, points,
    bounce, gq)``: ``nested[y, x]`` set where the ray meets another reflective surface,
    ``points[y, x]`` (H, W, 11; or (0, 0, 11) for none) the bounce's point, shading normal, view,
    model (-1: a miss) and face; for the geometry (else (0, 0, 4) and (0, 0, 9)) ``bounce[y, x]`` (H, W, 4)
    the bounce's face, model and barycentrics (face -1: none) and ``gq[y, x]`` (H, W, 9) its
    ``dL/dn``, ``dL/dp``, ``dL/dv`` (:func:`_reflected_vjp`'s)."""
    nested, points, bounce, gq = out
    want = points.shape[0] != 0
    want_g = bounce.shape[0] != 0
    prim, geom, u, v = hits
    handle, unit = trace
    k = part[0]
    spec_on, att_on = L.spec_on, L.att_on
    S = ray_scratch()
    Q = closest_packet(np.uint32(MIRROR_FLAGS))
    org = np.zeros((3, _LANES))
    dr = np.zeros((3, _LANES))
    act = np.zeros(_LANES, np.bool_)
    act[0] = True
    h, w = prim.shape
    for y in range(*share(h, part)):
        for x in range(w):
            p = prim[y, x]
            if p < 0:
                continue
            gm = geom[y, x]
            rho = mats[gm, MAT_REFLECTIVITY]
            if rho <= 0.0:
                continue
            gI = (np.float64(gimg[y, x, 0]), np.float64(gimg[y, x, 1]), np.float64(gimg[y, x, 2]))
            at = At(face_off[gm] + p, gm, np.float64(u[y, x]), np.float64(v[y, x]))
            o, r = _mirror_ray(_surface(G, B, cam, at, np.bool_(False), (0.0, 0.0, 0.0)), unit)
            for c in range(3):
                org[c, 0] = o[c]
                dr[c, 0] = r[c]
            set_closest_rays(Q, org, dr, act, 1)
            trace_closest(handle, Q)
            gb, pb, ub, vb, _ = closest_hit(Q, 0)
            if want:
                points[y, x, 9] = -1.0
                points[y, x, 10] = -1.0
            if pb < 0:
                rgb = (background[0], background[1], background[2])
            else:
                if mats[gb, MAT_REFLECTIVITY] > 0.0:
                    nested[y, x] = True
                bt = At(face_off[gb] + pb, gb, np.float64(ub), np.float64(vb))
                coef = _row_coefficients(mats, gb)
                hp = _shading_point(G, B, L, cam, bt, np.bool_(True), r)
                rgb = _illuminate(hp, coef, mats, gb, L, S, spec_on, att_on)
                if want:
                    for c in range(3):
                        points[y, x, c] = hp.p[c]
                        points[y, x, 3 + c] = hp.n[c]
                        points[y, x, 6 + c] = hp.v[c]
                    points[y, x, 9] = gb
                    points[y, x, 10] = face_off[gb] + pb
                gr = _reflected_vjp(hp, coef, mats, gb, L, S, (rho * gI[0], rho * gI[1], rho * gI[2]), acc, k, lay)
                if want_g:
                    bounce[y, x, 0] = face_off[gb] + pb
                    bounce[y, x, 1] = gb
                    bounce[y, x, 2] = np.float64(ub)
                    bounce[y, x, 3] = np.float64(vb)
                    for j in range(3):
                        for c in range(3):
                            gq[y, x, 3 * j + c] = gr[j][c]
            acc[k, gm * GM_SIZE + GM_REFLECTIVITY] += (gI[0] * (rgb[0] - local[y, x, 0]) + gI[1] * (rgb[1] - local[y, x, 1])
                                                      + gI[2] * (rgb[2] - local[y, x, 2]))


@njit(**HELPER)
def _spread_normal(G, tri, b1, b2, ga, gnormals):
    """``gnormals[tri[k]] += b_k dL/da`` (none if ``gnormals`` is empty) and ``dL/d(b1, b2)`` of the
    interpolated normal ``a = sum b_k n_k``."""
    normals = G.normals
    b = (1.0 - b1 - b2, b1, b2)
    if gnormals.shape[0] != 0:
        for k in range(3):
            for c in range(3):
                gnormals[tri[k], c] += b[k] * ga[c]
    i0, i1, i2 = tri
    gb1 = gb2 = 0.0
    for c in range(3):
        gb1 += ga[c] * (normals[i1, c] - normals[i0, c])
        gb2 += ga[c] * (normals[i2, c] - normals[i0, c])
    return gb1, gb2


@njit(**JIT)
def mirror_scatter(hits, G, B, face_off, cam, unit, bounce, gq, gverts, gcam, gnormals):
    """Serially, in row-major order, each reflective pixel whose mirror ray met a surface: back from
    the bounce's ``dL/dn``, ``dL/dp``, ``dL/dv`` (``gq``) through its hit on the bounce's (held)
    triangle (:func:`~.grad_geometry.ray_hit_vjp`: that triangle's vertices, the ray's origin and
    direction), the view ``-r``, the reflection ``r = -v + 2 (v.n) n`` about the mirror's interpolated
    normal and the origin at the mirror's hit, to the mirror pixel's own hit
    (:func:`~.grad_geometry.pixel_hit_vjp`: the mirror's vertices and the camera). The vertex normals'
    share of both interpolated normals goes into ``gnormals`` ((0, 3) for none)."""
    prim, geom, u, v = hits
    verts, normals, faces, _ = G
    zero = (0.0, 0.0, 0.0)
    h, w = prim.shape
    for y in range(h):
        for x in range(w):
            fq = np.int64(bounce[y, x, 0])
            if prim[y, x] < 0 or fq < 0:
                continue
            gm = geom[y, x]
            b1 = np.float64(u[y, x])
            b2 = np.float64(v[y, x])
            hm = _surface(G, B, cam, At(face_off[gm] + prim[y, x], gm, b1, b2), np.bool_(False), zero)
            o, r = _mirror_ray(hm, unit)
            # the bounce: its shading normal (the ray's view), its hit on its triangle
            b1q = bounce[y, x, 2]
            b2q = bounce[y, x, 3]
            triq = _triangle(faces, fq)
            hq = _surface(G, B, cam, At(fq, np.int64(bounce[y, x, 1]), b1q, b2q), np.bool_(True), r)
            ga = _normal_vjp(normals, triq, b1q, b2q, hq.g, hq.sgn, (gq[y, x, 0], gq[y, x, 1], gq[y, x, 2]))
            gb1q, gb2q = _spread_normal(G, triq, b1q, b2q, ga, gnormals)
            j0, j1, j2 = triq
            go, gd = ray_hit_vjp(o, r, (verts[j0, 0], verts[j0, 1], verts[j0, 2]),
                                 (verts[j1, 0], verts[j1, 1], verts[j1, 2]), (verts[j2, 0], verts[j2, 1], verts[j2, 2]),
                                 b1q, b2q, (gq[y, x, 3], gq[y, x, 4], gq[y, x, 5]), gb1q, gb2q, gverts, triq)
            gr = (gd[0] - gq[y, x, 6], gd[1] - gq[y, x, 7], gd[2] - gq[y, x, 8])  # the bounce's view is -r
            # the reflection r0 = -v + 2 (v.n) n, kept above the mirror's plane (reflect_into, g held)
            vm, nm, g = hm.v, hm.n, hm.g
            vn = dot(vm, nm)
            r0 = (-vm[0] + 2.0 * vn * nm[0], -vm[1] + 2.0 * vn * nm[1], -vm[2] + 2.0 * vn * nm[2])
            if dot(r0, g) < 0.0:
                k = 2.0 * dot(gr, g)
                gr = (gr[0] - k * g[0], gr[1] - k * g[1], gr[2] - k * g[2])
            ng = dot(nm, gr)
            gv = (-gr[0] + 2.0 * ng * nm[0], -gr[1] + 2.0 * ng * nm[1], -gr[2] + 2.0 * ng * nm[2])
            gn = (2.0 * (ng * vm[0] + vn * gr[0]), 2.0 * (ng * vm[1] + vn * gr[1]), 2.0 * (ng * vm[2] + vn * gr[2]))
            # the mirror pixel: its normal's barycentrics, its view, its hit (the origin: the hit point,
            # its push along the face's normal held)
            tri = _triangle(faces, face_off[gm] + prim[y, x])
            ga = _normal_vjp(normals, tri, b1, b2, hm.g, hm.sgn, gn)
            gb1, gb2 = _spread_normal(G, tri, b1, b2, ga, gnormals)
            gpv, geye, gw = _view_vjp(cam, hm.p, gv)
            _add_cam(gcam, geye, gw)
            i0, i1, i2 = tri
            pixel_hit_vjp(cam, x, y, (verts[i0, 0], verts[i0, 1], verts[i0, 2]),
                          (verts[i1, 0], verts[i1, 1], verts[i1, 2]), (verts[i2, 0], verts[i2, 1], verts[i2, 2]),
                          b1, b2, (go[0] + gpv[0], go[1] + gpv[1], go[2] + gpv[2]), gb1, gb2, gverts, tri, gcam)


def mirror_vjp(hits, inputs, gimg, local, lay, size, handle, unit, parts, want_points: bool = False,
               want: tuple = (False, False)):
    """The mirror bounce's part of a frame's gradient.

    Parameters
    ----------
    hits : HitBuffer
        The frame's hits (H, W).
    inputs : FrameInputs
        The frame's packed inputs (no colours or maps: their coefficients are the rows').
    gimg : (H, W, 3) float64
        ``dL/dI`` of the final image.
    local : (H, W, 3) float
        The frame's local shade (the image before the mirrors are blended in).
    lay, size : tuple, int
        The accumulator's ``(ambient offset, first light's offset)`` and row length
        (:func:`~.grad_terms.layout`).
    handle, unit : int, float
        The scene's Embree handle and its scale (the rays' offsets).
    parts : int
        The fixed number of parts.
    want_points : bool
        Also return each reflective pixel's bounce (for checks by a reference shader).
    want : (bool, bool)
        ``(geometry, normals)``: also the bounces' ``dL/dvertices`` and ``dL/dcamera`` (through both
        hits and the reflection), and ``dL/dnormals`` (both interpolated normals).

    Returns
    -------
    gimg_local : (H, W, 3) float64
        ``dL/d(local)``: ``(1 - rho) dL/dI`` on reflective pixels, ``dL/dI`` elsewhere.
    params : (size,) float64
        The bounces' gradients and ``dL/drho`` (slot ``GM_REFLECTIVITY`` of each model).
    nested : (H, W) bool
        Where a mirror ray meets another reflective surface (not differentiated).
    points : (H, W, 11) float64 or None
        With ``want_points``: the bounce's shading point, unit shading normal and view vector
        (re-centred coordinates), its model and its packed face (-1 for a miss; 0 rows elsewhere).
    extra : tuple
        ``(gverts (V, 3), gcam (6,), gnormals (V, 3))``, each None unless asked for by ``want``.
    """
    mats = inputs.materials
    rho = np.where(hits.prim >= 0, mats[np.maximum(hits.geom, 0), MAT_REFLECTIVITY], 0.0)
    acc = np.zeros((parts, size))
    nested = np.zeros(hits.prim.shape, np.bool_)
    points = np.zeros(hits.prim.shape + (11,) if want_points else (0, 0, 11))
    moved = want[0] or want[1]
    bounce = np.full(hits.prim.shape + (4,) if moved else (0, 0, 4), -1.0)
    gq = np.zeros(hits.prim.shape + (9,) if moved else (0, 0, 9))
    hit = (hits.prim, hits.geom, hits.u, hits.v)
    launch(_bounce_kernel, hit, inputs.geometry, inputs.bumps, inputs.lighting,
           inputs.face_off, mats, inputs.cam, (np.int64(handle), np.float64(unit)),
           np.asarray(inputs.background, np.float64), gimg, np.asarray(local, np.float64), lay, acc,
           (nested, points, bounce, gq), parts=parts, dynamic=True)
    total = acc[0].copy()
    for r in range(1, parts):
        total += acc[r]
    extra = (None, None, None)
    if moved:
        nv = inputs.geometry.verts.shape[0]
        gverts, gcam = np.zeros((nv, 3)), np.zeros(6)
        gnormals = np.zeros((nv if want[1] else 0, 3))
        mirror_scatter(hit, inputs.geometry, inputs.bumps, inputs.face_off, inputs.cam, np.float64(unit), bounce, gq,
                       gverts, gcam, gnormals)
        extra = (gverts if want[0] else None, gcam if want[0] else None, gnormals if want[1] else None)
    return gimg * (1.0 - rho)[..., None], total, nested, (points if want_points else None), extra
