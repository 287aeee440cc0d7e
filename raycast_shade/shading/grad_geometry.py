"""Reverse-mode gradients of a shaded frame with respect to the geometry: vertex positions and the
camera pose, through the interior of each triangle (the pixel's triangle held fixed).

A pixel's ray ``o + t d`` meets triangle ``(P0, P1, P2)`` where ``o + t d = P0 + b1 e1 + b2 e2``
(``e1 = P1 - P0``, ``e2 = P2 - P0``): with ``M = [-d, e1, e2]`` the hit is ``x = (t, b1, b2) =
M^-1 (o - P0)``, Möller and Trumbore's closed form. Its vector-Jacobian product, for ``g = dL/dx``
and ``lam = M^-T g`` (Cramer's rule with cross products), is::

    dL/dP_k = -b_k lam        (b_0 = 1 - b1 - b2)
    dL/do   = lam             dL/dd = t lam

The shading reads the hit point ``p = o + t d`` (so ``g_t = dL/dp . d``, and ``dL/dp`` goes to ``o``
and ``d`` directly), the barycentrics (Phong's interpolated normal, Gouraud's weights) and the unit
view vector ``v = (eye - p)/|eye - p|`` (orthographic: ``-forward``).

**The camera pose** is the eye (``camera_eye``, world coordinates) and a small rotation
``camera_rotation = w`` applied on the left to the camera's axes about the eye: every world vector of
the camera (right, up, forward, and so each pixel's ray direction) becomes ``b + w x b``. Its
gradient is ``sum b x dL/db`` over those vectors (:func:`rotate_camera` applies a finite ``w``).

Held fixed (not differentiated): the vertex *normals* (a separate parameter, ``normals``: when the
mesh's normals were averaged from its positions, the chain through that averaging is not included),
the geometric normal's use in orienting the shading normal (a sign, and Phong's reflection of a
normal that points away, rare), shadow visibility and the shadow rays' origins, Gouraud's clamping
of weights onto the triangle. Flat shading's face normal is differentiated: it is
``(e1 x e2)/|e1 x e2|``, turned to the viewer.

Every pass here is serial in row-major (vertex, face) order: the sums are bit for bit the same on
any number of threads.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.layout import CAM_EYE, CAM_FORWARD, CAM_ORTHO, METHOD_GOURAUD, METHOD_PHONG
from ..visibility.rays import pixel_ray
from ..visibility.secondary import ray_scratch
from .gouraud import _corner_shade
from .grad_walk import chunk_items, chunks, pixel_dI, triangle_points
from .illumination import _illuminate_call
from .jit import HELPER, JIT
from .records import Hit, dot
from .surface import _facing, _hit_point, _triangle, _view
from .texture import _row_coefficients

__all__ = ["pixel_hit_vjp", "ray_hit_vjp", "rotate_vectors"]


@njit(**HELPER)
def cross(a, b):
    """``a x b`` of two 3-tuples."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(**HELPER)
def _add_cam(gcam, geye, gw):
    """``gcam[0:3] += dL/deye``, ``gcam[3:6] += dL/dw``."""
    for c in range(3):
        gcam[c] += geye[c]
        gcam[3 + c] += gw[c]


@njit(**HELPER)
def _view_vjp(cam, p, gv):
    """Back through :func:`~raycast_shade.shading.surface._view`: ``(dL/dp, dL/deye, dL/dw)`` for
    ``dL/dv``; orthographic ``v = -forward`` turns with the camera only."""
    if cam[CAM_ORTHO] != 0.0:
        v = (-cam[CAM_FORWARD + 0], -cam[CAM_FORWARD + 1], -cam[CAM_FORWARD + 2])
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), cross(v, gv)
    r = (cam[CAM_EYE + 0] - p[0], cam[CAM_EYE + 1] - p[1], cam[CAM_EYE + 2] - p[2])
    ln = np.sqrt(dot(r, r))
    if ln == 0.0:
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    v = (r[0] / ln, r[1] / ln, r[2] / ln)
    q = dot(gv, v)
    gr = ((gv[0] - q * v[0]) / ln, (gv[1] - q * v[1]) / ln, (gv[2] - q * v[2]) / ln)
    return (-gr[0], -gr[1], -gr[2]), gr, (0.0, 0.0, 0.0)


@njit(**HELPER)
def ray_hit_vjp(o, d, P0, P1, P2, b1, b2, gp, gb1, gb2, gverts, tri):
    """Back through the hit of any ray ``o + t d`` (a mirror ray: :mod:`.grad_mirror`) on triangle
    ``(P0, P1, P2)`` at barycentrics ``(b1, b2)`` (a camera ray: :func:`pixel_hit_vjp`, which calls it):
    ``dL/dP_k`` into ``gverts[tri[k]]``; returns ``(dL/do, dL/dd)``. ``t = (p - o).d / d.d``; a ray
    parallel to the triangle adds nothing."""
    p = (P0[0] + b1 * (P1[0] - P0[0]) + b2 * (P2[0] - P0[0]), P0[1] + b1 * (P1[1] - P0[1]) + b2 * (P2[1] - P0[1]),
         P0[2] + b1 * (P1[2] - P0[2]) + b2 * (P2[2] - P0[2]))
    t = ((p[0] - o[0]) * d[0] + (p[1] - o[1]) * d[1] + (p[2] - o[2]) * d[2]) / dot(d, d)
    c0 = (-d[0], -d[1], -d[2])
    c1 = (P1[0] - P0[0], P1[1] - P0[1], P1[2] - P0[2])
    c2 = (P2[0] - P0[0], P2[1] - P0[1], P2[2] - P0[2])
    k12 = cross(c1, c2)
    det = dot(c0, k12)
    if det == 0.0:
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    k20 = cross(c2, c0)
    k01 = cross(c0, c1)
    gt = dot(gp, d)
    lam = ((gt * k12[0] + gb1 * k20[0] + gb2 * k01[0]) / det, (gt * k12[1] + gb1 * k20[1] + gb2 * k01[1]) / det,
           (gt * k12[2] + gb1 * k20[2] + gb2 * k01[2]) / det)
    b = (1.0 - b1 - b2, b1, b2)
    for k in range(3):
        i = tri[k]
        for c in range(3):
            gverts[i, c] -= b[k] * lam[c]
    go = (gp[0] + lam[0], gp[1] + lam[1], gp[2] + lam[2])
    return go, (t * go[0], t * go[1], t * go[2])


@njit(**HELPER)
def pixel_hit_vjp(cam, x, y, P0, P1, P2, b1, b2, gp, gb1, gb2, gverts, tri, gcam):
    """Back through the hit of pixel ``(x, y)``'s ray (through its centre, :func:`pixel_ray`) on
    triangle ``(P0, P1, P2)`` at barycentrics ``(b1, b2)``: given ``dL/dp`` of the hit point and
    ``dL/db1``, ``dL/db2``, add ``dL/dP_k`` into ``gverts[tri[k]]`` and the camera's into ``gcam``
    (eye, rotation). A ray parallel to the triangle (``det = 0``) adds nothing."""
    ox, oy, oz, dx, dy, dz = pixel_ray(cam, np.float64(x), np.float64(y))
    d = (dx, dy, dz)
    go, gd = ray_hit_vjp((ox, oy, oz), d, P0, P1, P2, b1, b2, gp, gb1, gb2, gverts, tri)
    gw = cross(d, gd)
    if cam[CAM_ORTHO] != 0.0:  # the origin turns about the eye with the camera too
        w2 = cross((ox - cam[CAM_EYE + 0], oy - cam[CAM_EYE + 1], oz - cam[CAM_EYE + 2]), go)
        gw = (gw[0] + w2[0], gw[1] + w2[1], gw[2] + w2[2])
    _add_cam(gcam, go, gw)


@njit(nogil=True, **JIT)
def vertex_shades_kernel(G, vertex_model, materials, cam, L, vcol, part):
    """Gouraud's stored vertex shades, both sides of every vertex (``vcol`` (V, 2, 3)), by the
    forward evaluator: the barycentric gradient of a Gouraud pixel is ``gI . (S_k - S_0)``."""
    verts, normals, _, _ = G
    n = verts.shape[0]
    for ch in range(*chunks(n, part)):
        S = ray_scratch()
        for i in range(*chunk_items(n, ch)):
            p = (verts[i, 0], verts[i, 1], verts[i, 2])
            m = vertex_model[i]
            for side in range(2):
                sg = 1.0 - 2.0 * side
                nv = (sg * normals[i, 0], sg * normals[i, 1], sg * normals[i, 2])
                rgb = _illuminate_call(Hit(p, _view(cam, p), nv, 1.0, nv, p), _row_coefficients(materials, m),
                                       materials, m, L, S, L.spec_on, L.att_on)
                for c in range(3):
                    vcol[i, side, c] = rgb[c]


@njit(**JIT)
def pixels_scatter(hits, G, L, face_off, materials, cam, modes, gimg, gpx, vcol, gverts, gcam):
    """Serially, in row-major order: each Phong and Gouraud pixel's hit moved with its triangle and
    ray (flat pixels show a constant face: nothing). ``gpx`` (H, W, 9): a Phong pixel's ``dL/da`` of
    its interpolated normal, ``dL/dp`` and ``dL/dv`` (:func:`_reflected_vjp`'s); ``vcol`` the
    Gouraud vertex shades (V, 2, 3)."""
    prim, geom, u, v = hits
    verts, normals, faces, fnormals = G
    S = ray_scratch()
    h, w = prim.shape
    for y in range(h):
        for x in range(w):
            pr = prim[y, x]
            if pr < 0:
                continue
            gm = geom[y, x]
            f = face_off[gm] + pr
            tri = _triangle(faces, f)
            i0, i1, i2 = tri
            P0, P1, P2 = triangle_points(verts, tri)
            b1 = np.float64(u[y, x])
            b2 = np.float64(v[y, x])
            if modes[gm] == METHOD_PHONG:
                p = _hit_point(verts, tri, b1, b2)
                gv = (gpx[y, x, 6], gpx[y, x, 7], gpx[y, x, 8])
                gpv, geye, gw = _view_vjp(cam, p, gv)
                _add_cam(gcam, geye, gw)
                gp = (gpx[y, x, 3] + gpv[0], gpx[y, x, 4] + gpv[1], gpx[y, x, 5] + gpv[2])
                ga = (gpx[y, x, 0], gpx[y, x, 1], gpx[y, x, 2])
                gb1 = gb2 = 0.0
                for c in range(3):  # a = sum b_k n_k
                    gb1 += ga[c] * (normals[i1, c] - normals[i0, c])
                    gb2 += ga[c] * (normals[i2, c] - normals[i0, c])
                pixel_hit_vjp(cam, x, y, P0, P1, P2, b1, b2, gp, gb1, gb2, gverts, tri, gcam)
            elif modes[gm] == METHOD_GOURAUD:
                nonzero, gI = pixel_dI(gimg, y, x)
                if not nonzero:
                    continue
                view = _view(cam, _hit_point(verts, tri, b1, b2))
                g, sgn = _facing(fnormals, f, view)
                side = 0 if sgn > 0.0 else 1
                coef = _row_coefficients(materials, gm)
                s0 = _corner_shade(vcol, G, i0, side, g, materials, gm, cam, L, S, coef, L.spec_on, L.att_on)
                s1 = _corner_shade(vcol, G, i1, side, g, materials, gm, cam, L, S, coef, L.spec_on, L.att_on)
                s2 = _corner_shade(vcol, G, i2, side, g, materials, gm, cam, L, S, coef, L.spec_on, L.att_on)
                gb1 = gI[0] * (s1[0] - s0[0]) + gI[1] * (s1[1] - s0[1]) + gI[2] * (s1[2] - s0[2])
                gb2 = gI[0] * (s2[0] - s0[0]) + gI[1] * (s2[1] - s0[1]) + gI[2] * (s2[2] - s0[2])
                pixel_hit_vjp(cam, x, y, P0, P1, P2, b1, b2, (0.0, 0.0, 0.0), gb1, gb2, gverts, tri, gcam)


@njit(**JIT)
def points_scatter(gvg, verts, cam, gverts, gcam):
    """Serially: each Gouraud vertex's ``dL/dp`` and ``dL/dv`` (``gvg`` (V, 6)) at the vertex."""
    for i in range(gvg.shape[0]):
        gv = (gvg[i, 3], gvg[i, 4], gvg[i, 5])
        p = (verts[i, 0], verts[i, 1], verts[i, 2])
        gpv, geye, gw = _view_vjp(cam, p, gv)
        _add_cam(gcam, geye, gw)
        for c in range(3):
            gverts[i, c] += gvg[i, c] + gpv[c]


@njit(**JIT)
def faces_scatter(gfg, G, cam, gverts, gcam):
    """Serially: each flat face's ``dL/dn``, ``dL/dp``, ``dL/dv`` (``gfg`` (F, 9)) at its centre,
    through the centre ``(P0 + P1 + P2)/3``, its view and its unit normal ``(e1 x e2)/|e1 x e2|``
    (turned to the viewer)."""
    verts, _, faces, fnormals = G
    third = 1.0 / 3.0
    for f in range(gfg.shape[0]):
        gn = (gfg[f, 0], gfg[f, 1], gfg[f, 2])
        gpc = (gfg[f, 3], gfg[f, 4], gfg[f, 5])
        gv = (gfg[f, 6], gfg[f, 7], gfg[f, 8])
        if (gn[0] == 0.0 and gn[1] == 0.0 and gn[2] == 0.0 and gpc[0] == 0.0 and gpc[1] == 0.0 and gpc[2] == 0.0
                and gv[0] == 0.0 and gv[1] == 0.0 and gv[2] == 0.0):
            continue
        tri = _triangle(faces, f)
        i0, i1, i2 = tri
        p = _hit_point(verts, tri, third, third)
        gpv, geye, gw = _view_vjp(cam, p, gv)
        _add_cam(gcam, geye, gw)
        for k in range(3):
            for c in range(3):
                gverts[tri[k], c] += third * (gpc[c] + gpv[c])
        e1 = (verts[i1, 0] - verts[i0, 0], verts[i1, 1] - verts[i0, 1], verts[i1, 2] - verts[i0, 2])
        e2 = (verts[i2, 0] - verts[i0, 0], verts[i2, 1] - verts[i0, 1], verts[i2, 2] - verts[i0, 2])
        cr = cross(e1, e2)
        ln = np.sqrt(dot(cr, cr))
        if ln == 0.0 or (fnormals[f, 0] == 0.0 and fnormals[f, 1] == 0.0 and fnormals[f, 2] == 0.0):
            continue  # a degenerate face is lit with the view vector: no normal to move
        _, sgn = _facing(fnormals, f, _view(cam, p))
        un = (cr[0] / ln, cr[1] / ln, cr[2] / ln)
        gu = (sgn * gn[0], sgn * gn[1], sgn * gn[2])
        q = dot(gu, un)
        gc = ((gu[0] - q * un[0]) / ln, (gu[1] - q * un[1]) / ln, (gu[2] - q * un[2]) / ln)
        ge1 = cross(e2, gc)
        ge2 = cross(gc, e1)
        for c in range(3):
            gverts[i1, c] += ge1[c]
            gverts[i2, c] += ge2[c]
            gverts[i0, c] -= ge1[c] + ge2[c]


def rotate_vectors(w, vectors) -> np.ndarray:
    """``exp([w]x) b`` for each row ``b`` of ``vectors`` (N, 3): Rodrigues' rotation by the angle
    ``|w|`` about ``w``, the finite form of ``b + w x b``."""
    w = np.asarray(w, np.float64)
    vectors = np.asarray(vectors, np.float64)
    angle = float(np.linalg.norm(w))
    if angle == 0.0:
        return vectors.copy()
    k = w / angle
    c, s = np.cos(angle), np.sin(angle)
    return vectors * c + np.cross(k, vectors) * s + np.outer(vectors @ k, k) * (1.0 - c)
