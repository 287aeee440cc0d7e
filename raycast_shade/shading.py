"""Shading kernels: flat, Gouraud and Phong over a hit buffer.

Every mode evaluates the lecture's reflectance equation, per channel::

    I = Ia ka + sum_i att_i(d) Ii (kd max(n.s, 0) + Ks max(r.v, 0)^t)

with ``r = 2 (n.s) n - s`` (or Blinn-Phong ``(n.h)^t``), no specular term
where ``n.s <= 0``, and ``att`` one of ``1``, ``1/d^2``, ``1/(d + k)``. The
viewer's distance never enters: only the direction ``v`` to the eye does.

What differs is *where* the equation is evaluated:

flat
    once per triangle, at its centre, with its true (geometric) normal;
Gouraud
    at each vertex with its averaged normal; colours interpolated with the
    barycentrics;
Phong
    at each pixel, at the true 3D hit point, with the normal interpolated
    (``a = n1 + mu1 (n2 - n1) + mu2 (n3 - n1)``) and renormalised.

Orientation (two-sided lighting): the geometric normal ``ng`` is turned to
the viewer; a shading normal seen from the back is negated with it, and one
that still points into the far hemisphere (coarse silhouettes, inconsistent
data) is reflected across the tangent plane into the viewer's hemisphere,
which is continuous where plain negation would jump. An interpolated normal
that cancels (``|a| < 1e-6``) falls back to ``ng``. Gouraud lights a vertex
from whichever side the viewer sees its triangle (both sides are shaded).

Kernels are private, parallel over rows, and work in float64; their plain-
NumPy twins live in :mod:`raycast_shade.reference`.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["SHADINGS", "shade"]

SHADINGS = ("flat", "gouraud", "phong")
_CANCEL = 1e-6  # |interpolated normal| below this counts as cancelled

_jit = dict(cache=True, error_model="numpy", fastmath={"nsz", "arcp", "contract", "afn", "reassoc"})


def _illuminate_py(px, py, pz, nx, ny, nz, vx, vy, vz, mats, mi, ambient, lkind, lvec, lrad, latt, lk, dmin):
    """RGB reflected towards unit ``v`` at point ``p`` with unit normal ``n``,
    for material row ``mats[mi]`` (indexed, not sliced: a slice per pixel
    would cost an atomic reference count shared by all threads)."""
    r = ambient[0] * mats[mi, 0]
    g = ambient[1] * mats[mi, 1]
    b = ambient[2] * mats[mi, 2]
    shin = mats[mi, 9]
    blinn = mats[mi, 10] != 0.0
    has_spec = mats[mi, 6] > 0.0 or mats[mi, 7] > 0.0 or mats[mi, 8] > 0.0
    for i in range(lkind.shape[0]):
        if lkind[i] == 1:
            sx = lvec[i, 0]
            sy = lvec[i, 1]
            sz = lvec[i, 2]
            att = 1.0
        else:
            dx = lvec[i, 0] - px
            dy = lvec[i, 1] - py
            dz = lvec[i, 2] - pz
            d = np.sqrt(dx * dx + dy * dy + dz * dz)
            if d == 0.0:
                continue  # light on the surface point: no direction, no light
            sx = dx / d
            sy = dy / d
            sz = dz / d
            if latt[i] == 1:
                dd = max(d, dmin)
                att = 1.0 / (dd * dd)
            elif latt[i] == 2:
                att = 1.0 / (d + lk[i])
            else:
                att = 1.0
        ndots = nx * sx + ny * sy + nz * sz
        if ndots <= 0.0:
            continue
        if ndots > 1.0:
            ndots = 1.0
        spec = 0.0
        if has_spec:
            if blinn:
                hx = sx + vx
                hy = sy + vy
                hz = sz + vz
                hl = np.sqrt(hx * hx + hy * hy + hz * hz)
                c = (nx * hx + ny * hy + nz * hz) / hl if hl > 0.0 else 0.0
            else:
                rx = 2.0 * ndots * nx - sx
                ry = 2.0 * ndots * ny - sy
                rz = 2.0 * ndots * nz - sz
                c = rx * vx + ry * vy + rz * vz
            if c > 0.0:
                spec = min(c, 1.0) ** shin
        r += att * lrad[i, 0] * (mats[mi, 3] * ndots + mats[mi, 6] * spec)
        g += att * lrad[i, 1] * (mats[mi, 4] * ndots + mats[mi, 7] * spec)
        b += att * lrad[i, 2] * (mats[mi, 5] * ndots + mats[mi, 8] * spec)
    return r, g, b


# Inlined into the hot loops (each kernel inlines it exactly once, which keeps
# compile time in check); the called variant serves rare fallback branches.
_illuminate = njit(inline="always", **_jit)(_illuminate_py)
_illuminate_call = njit(**_jit)(_illuminate_py)


@njit(inline="always", **_jit)
def _view(cam, px, py, pz):
    """Unit vector from a point to the eye (orthographic: against the view)."""
    if cam[12] != 0.0:
        return -cam[9], -cam[10], -cam[11]
    vx = cam[0] - px
    vy = cam[1] - py
    vz = cam[2] - pz
    vl = np.sqrt(vx * vx + vy * vy + vz * vz)
    if vl == 0.0:
        return -cam[9], -cam[10], -cam[11]
    return vx / vl, vy / vl, vz / vl


@njit(inline="always", **_jit)
def _facing(fnormals, f, vx, vy, vz):
    """Geometric normal turned to the viewer, and the sign that turned it."""
    gx = fnormals[f, 0]
    gy = fnormals[f, 1]
    gz = fnormals[f, 2]
    if gx == 0.0 and gy == 0.0 and gz == 0.0:  # degenerate face: face the viewer
        return vx, vy, vz, 1.0
    if gx * vx + gy * vy + gz * vz < 0.0:
        return -gx, -gy, -gz, -1.0
    return gx, gy, gz, 1.0


@njit(inline="always", **_jit)
def _shading_normal(normals, i0, i1, i2, b1, b2, gx, gy, gz, sgn):
    """Interpolated, renormalised normal, oriented into the viewer's hemisphere."""
    b0 = 1.0 - b1 - b2
    ax = b0 * normals[i0, 0] + b1 * normals[i1, 0] + b2 * normals[i2, 0]
    ay = b0 * normals[i0, 1] + b1 * normals[i1, 1] + b2 * normals[i2, 1]
    az = b0 * normals[i0, 2] + b1 * normals[i1, 2] + b2 * normals[i2, 2]
    al = np.sqrt(ax * ax + ay * ay + az * az)
    if not al >= _CANCEL:
        return gx, gy, gz
    s = sgn / al
    nx = ax * s
    ny = ay * s
    nz = az * s
    c = nx * gx + ny * gy + nz * gz
    if c < 0.0:
        nx -= 2.0 * c * gx
        ny -= 2.0 * c * gy
        nz -= 2.0 * c * gz
    return nx, ny, nz


@njit(inline="always", **_jit)
def _hit_point(verts, i0, i1, i2, b1, b2):
    b0 = 1.0 - b1 - b2
    px = b0 * verts[i0, 0] + b1 * verts[i1, 0] + b2 * verts[i2, 0]
    py = b0 * verts[i0, 1] + b1 * verts[i1, 1] + b2 * verts[i2, 1]
    pz = b0 * verts[i0, 2] + b1 * verts[i1, 2] + b2 * verts[i2, 2]
    return px, py, pz


@njit(parallel=True, **_jit)
def _shade_phong_kernel(prim, geom, u, v, verts, normals, faces, fnormals, face_off, materials, cam,
                        ambient, lkind, lvec, lrad, latt, lk, dmin, image):
    h, w = prim.shape
    for y in prange(h):
        for x in range(w):
            p = prim[y, x]
            if p < 0:
                for c in range(3):
                    image[y, x, c] = 0.0
                continue
            g = geom[y, x]
            f = face_off[g] + p
            i0 = faces[f, 0]
            i1 = faces[f, 1]
            i2 = faces[f, 2]
            b1 = np.float64(u[y, x])
            b2 = np.float64(v[y, x])
            px, py, pz = _hit_point(verts, i0, i1, i2, b1, b2)
            vx, vy, vz = _view(cam, px, py, pz)
            gx, gy, gz, sgn = _facing(fnormals, f, vx, vy, vz)
            nx, ny, nz = _shading_normal(normals, i0, i1, i2, b1, b2, gx, gy, gz, sgn)
            r, gg, b = _illuminate(px, py, pz, nx, ny, nz, vx, vy, vz, materials, g, ambient,
                                   lkind, lvec, lrad, latt, lk, dmin)
            image[y, x, 0] = r
            image[y, x, 1] = gg
            image[y, x, 2] = b


@njit(parallel=True, **_jit)
def _visible_kernel(prim, geom, faces, face_off, face_flags, vertex_flags):
    """Mark the faces (and their vertices) that some pixel sees."""
    h, w = prim.shape
    for y in prange(h):
        for x in range(w):
            p = prim[y, x]
            if p >= 0:
                f = face_off[geom[y, x]] + p
                # Racy, but every writer stores the same 1.
                face_flags[f] = 1
                vertex_flags[faces[f, 0]] = 1
                vertex_flags[faces[f, 1]] = 1
                vertex_flags[faces[f, 2]] = 1


@njit(parallel=True, **_jit)
def _shade_faces_kernel(face_flags, verts, faces, fnormals, face_model, materials, cam,
                        ambient, lkind, lvec, lrad, latt, lk, dmin, out):
    """Flat shading: one shade per visible face, at its centre."""
    for f in prange(faces.shape[0]):
        if face_flags[f] == 0:
            continue
        i0 = faces[f, 0]
        i1 = faces[f, 1]
        i2 = faces[f, 2]
        third = 1.0 / 3.0
        px, py, pz = _hit_point(verts, i0, i1, i2, third, third)
        vx, vy, vz = _view(cam, px, py, pz)
        gx, gy, gz, sgn = _facing(fnormals, f, vx, vy, vz)
        r, g, b = _illuminate(px, py, pz, gx, gy, gz, vx, vy, vz, materials, face_model[f], ambient,
                              lkind, lvec, lrad, latt, lk, dmin)
        out[f, 0] = r
        out[f, 1] = g
        out[f, 2] = b


@njit(parallel=True, **_jit)
def _shade_vertices_kernel(vertex_flags, verts, normals, vertex_model, materials, cam,
                           ambient, lkind, lvec, lrad, latt, lk, dmin, out):
    """Gouraud: the shade of each visible vertex, lit from the front (normal)
    and from the back (negated normal)."""
    for i in prange(verts.shape[0]):
        if vertex_flags[i] == 0:
            continue
        px = verts[i, 0]
        py = verts[i, 1]
        pz = verts[i, 2]
        vx, vy, vz = _view(cam, px, py, pz)
        m = vertex_model[i]
        for side in range(2):
            sg = 1.0 - 2.0 * side
            r, g, b = _illuminate(px, py, pz, sg * normals[i, 0], sg * normals[i, 1], sg * normals[i, 2],
                                  vx, vy, vz, materials, m, ambient, lkind, lvec, lrad, latt, lk, dmin)
            out[i, side, 0] = r
            out[i, side, 1] = g
            out[i, side, 2] = b


@njit(inline="always", **_jit)
def _corner_shade(vcol, normals, verts, i, side, gx, gy, gz, materials, m, cam, ambient, lkind, lvec, lrad, latt, lk, dmin):
    """A vertex's Gouraud shade; a vertex without a normal borrows the face's."""
    if normals[i, 0] == 0.0 and normals[i, 1] == 0.0 and normals[i, 2] == 0.0:
        px = verts[i, 0]
        py = verts[i, 1]
        pz = verts[i, 2]
        vx, vy, vz = _view(cam, px, py, pz)
        return _illuminate_call(px, py, pz, gx, gy, gz, vx, vy, vz, materials, m, ambient, lkind, lvec, lrad, latt, lk, dmin)
    return vcol[i, side, 0], vcol[i, side, 1], vcol[i, side, 2]


@njit(parallel=True, **_jit)
def _interp_gouraud_kernel(prim, geom, u, v, verts, normals, faces, fnormals, face_off, materials, cam,
                           ambient, lkind, lvec, lrad, latt, lk, dmin, vcol, image):
    h, w = prim.shape
    for y in prange(h):
        for x in range(w):
            p = prim[y, x]
            if p < 0:
                for c in range(3):
                    image[y, x, c] = 0.0
                continue
            g = geom[y, x]
            f = face_off[g] + p
            i0 = faces[f, 0]
            i1 = faces[f, 1]
            i2 = faces[f, 2]
            b1 = np.float64(u[y, x])
            b2 = np.float64(v[y, x])
            b0 = 1.0 - b1 - b2
            px, py, pz = _hit_point(verts, i0, i1, i2, b1, b2)
            vx, vy, vz = _view(cam, px, py, pz)
            gx, gy, gz, sgn = _facing(fnormals, f, vx, vy, vz)
            side = 0 if sgn > 0.0 else 1
            m = g
            r0, g0, c0 = _corner_shade(vcol, normals, verts, i0, side, gx, gy, gz, materials, m, cam, ambient, lkind, lvec, lrad, latt, lk, dmin)
            r1, g1, c1 = _corner_shade(vcol, normals, verts, i1, side, gx, gy, gz, materials, m, cam, ambient, lkind, lvec, lrad, latt, lk, dmin)
            r2, g2, c2 = _corner_shade(vcol, normals, verts, i2, side, gx, gy, gz, materials, m, cam, ambient, lkind, lvec, lrad, latt, lk, dmin)
            image[y, x, 0] = b0 * r0 + b1 * r1 + b2 * r2
            image[y, x, 1] = b0 * g0 + b1 * g1 + b2 * g2
            image[y, x, 2] = b0 * c0 + b1 * c1 + b2 * c2


@njit(parallel=True, **_jit)
def _lookup_flat_kernel(prim, geom, face_off, fcol, image):
    h, w = prim.shape
    for y in prange(h):
        for x in range(w):
            p = prim[y, x]
            if p < 0:
                for c in range(3):
                    image[y, x, c] = 0.0
                continue
            f = face_off[geom[y, x]] + p
            for c in range(3):
                image[y, x, c] = fcol[f, c]


@njit(parallel=True, **_jit)
def _normals_kernel(prim, geom, u, v, verts, normals, faces, fnormals, face_off, cam, flat, nbuf):
    """The unit normal each pixel is shaded with, turned to the viewer."""
    h, w = prim.shape
    for y in prange(h):
        for x in range(w):
            p = prim[y, x]
            if p < 0:
                for c in range(3):
                    nbuf[y, x, c] = 0.0
                continue
            f = face_off[geom[y, x]] + p
            i0 = faces[f, 0]
            i1 = faces[f, 1]
            i2 = faces[f, 2]
            b1 = np.float64(u[y, x])
            b2 = np.float64(v[y, x])
            px, py, pz = _hit_point(verts, i0, i1, i2, b1, b2)
            vx, vy, vz = _view(cam, px, py, pz)
            gx, gy, gz, sgn = _facing(fnormals, f, vx, vy, vz)
            if flat:
                nx, ny, nz = gx, gy, gz
            else:
                nx, ny, nz = _shading_normal(normals, i0, i1, i2, b1, b2, gx, gy, gz, sgn)
            nbuf[y, x, 0] = nx
            nbuf[y, x, 1] = ny
            nbuf[y, x, 2] = nz


def kernel_inputs(scene, camera):
    """Everything the kernels read, packed once per frame.

    Returns
    -------
    dict
        ``verts (V,3) f8, normals (V,3) f8, faces (F,3) i8, fnormals (F,3) f8,
        face_off (G+1,) i8, materials (G,11) f8, cam (16,) f8, ambient (3,) f8,
        lkind (L,) i4, lvec (L,3) f8, lrad (L,3) f8, latt (L,) i4, lk (L,) f8,
        dmin float``.
    """
    from .rays import camera_frame

    geo = scene.geometry
    lkind, lvec, lrad, latt, lk = scene.packed_lights()
    return dict(
        verts=geo.vertices, normals=geo.normals, faces=geo.faces, fnormals=geo.face_normals,
        face_off=geo.face_offsets, materials=geo.materials, cam=camera_frame(camera, geo.origin),
        ambient=np.asarray(scene.ambient, np.float64), lkind=lkind, lvec=lvec, lrad=lrad, latt=latt, lk=lk,
        dmin=1e-6 * geo.scale,
    )


def shade(scene, camera, hits, shading: str = "phong") -> np.ndarray:
    """Shade a hit buffer.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    hits : HitBuffer
    shading : {"flat", "gouraud", "phong"}

    Returns
    -------
    image : (H, W, 3) float32
        Linear RGB; zero where nothing was hit.
    """
    if shading not in SHADINGS:
        raise ValueError(f"shading: expected one of {list(SHADINGS)}, got {shading!r}")
    k = kernel_inputs(scene, camera)
    geo = scene.geometry
    h, w = hits.shape
    image = np.empty((h, w, 3), np.float32)
    light = (k["ambient"], k["lkind"], k["lvec"], k["lrad"], k["latt"], k["lk"], k["dmin"])
    if shading == "phong":
        _shade_phong_kernel(hits.prim, hits.geom, hits.u, hits.v, k["verts"], k["normals"], k["faces"], k["fnormals"],
                            k["face_off"], k["materials"], k["cam"], *light, image)
        return image
    face_flags = np.zeros(len(geo.faces), np.uint8)
    vertex_flags = np.zeros(len(geo.vertices), np.uint8)
    _visible_kernel(hits.prim, hits.geom, k["faces"], k["face_off"], face_flags, vertex_flags)
    if shading == "flat":
        fcol = np.zeros((len(geo.faces), 3), np.float64)
        _shade_faces_kernel(face_flags, k["verts"], k["faces"], k["fnormals"], geo.face_model, k["materials"],
                            k["cam"], *light, fcol)
        _lookup_flat_kernel(hits.prim, hits.geom, k["face_off"], fcol, image)
        return image
    vcol = np.zeros((len(geo.vertices), 2, 3), np.float64)
    _shade_vertices_kernel(vertex_flags, k["verts"], k["normals"], geo.vertex_model, k["materials"], k["cam"],
                           *light, vcol)
    _interp_gouraud_kernel(hits.prim, hits.geom, hits.u, hits.v, k["verts"], k["normals"], k["faces"], k["fnormals"],
                           k["face_off"], k["materials"], k["cam"], *light, vcol, image)
    return image


def shading_normals(scene, camera, hits, shading: str = "phong") -> np.ndarray:
    """The normal each pixel is shaded with.

    Returns
    -------
    (H, W, 3) float32
        Unit normals turned to the viewer (flat: the face normal; otherwise
        the interpolated, renormalised vertex normal); zero on the background.
    """
    geo = scene.geometry
    from .rays import camera_frame

    nbuf = np.empty(hits.shape + (3,), np.float32)
    _normals_kernel(hits.prim, hits.geom, hits.u, hits.v, geo.vertices, geo.normals, geo.faces, geo.face_normals,
                    geo.face_offsets, camera_frame(camera, geo.origin), shading == "flat", nbuf)
    return nbuf
