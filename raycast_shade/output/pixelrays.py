"""The buffers that need each pixel's ray (z-depth, position, face normals), one image row at a time.

The row's rays are made as the casters make them (:func:`_row_rays`, branch-free: it vectorises).
A row's position and face normals then take passes over the row: its triangles (branch-free), a
gather of each pixel's triangle (its plane, reused from the pixel before when it is the same
triangle, as are the numerator ``(p0 - o) . n`` of rays from one origin; its face normal; a
miss reads triangle 0) into float64 rows, and the arithmetic,
branch-free, misses chosen to 0 at the store, which vectorises (8 pixels a step with AVX-512).
Two things keep those loops vector loops: each (W, 3) output row is stored through a flat view
(``3 x + k``: a stride known when compiled; through ``[y, x, k]`` the stride is the array's, known
only at run time, and LLVM leaves the loop scalar), and a zero denominator divides to inf or nan
(``error_model="numpy"``, chosen away after) instead of raising. Every value is the one the
scalar loop computed, operation for operation (no fused or reordered arithmetic): the buffers are
bit-identical.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.layout import CAM_EYE, CAM_FORWARD, CAM_HEIGHT, CAM_ORTHO, CAM_RIGHT, CAM_UP, CAM_WIDTH
from ..common.prefetch import prefetch

# A zero denominator divides to inf or nan (chosen away after), not a raised error: a branch per pixel
# the loops do not vectorise past. The buffer kernel that inlines these helpers is compiled alike.
_ROW = dict(cache=True, inline="always", error_model="numpy")


@njit(**_ROW)
def _row_rays(cam, dirs, w, yy, ray):
    """The rays of image row ``yy`` as the casters make them, into ``ray`` (6, W) float64: origins
    x, y, z, then unit directions (``dirs``: the lens-distorted directions, row-major, or empty
    for a pinhole). :func:`~raycast_shade.visibility.rays.pixel_ray`'s arithmetic, operation for
    operation, with the camera read into scalars first: each loop is branch-free, so it vectorises."""
    e0, e1, e2 = cam[CAM_EYE + 0], cam[CAM_EYE + 1], cam[CAM_EYE + 2]
    r0, r1, r2 = cam[CAM_RIGHT + 0], cam[CAM_RIGHT + 1], cam[CAM_RIGHT + 2]
    u0, u1, u2 = cam[CAM_UP + 0], cam[CAM_UP + 1], cam[CAM_UP + 2]
    f0, f1, f2 = cam[CAM_FORWARD + 0], cam[CAM_FORWARD + 1], cam[CAM_FORWARD + 2]
    cw = cam[CAM_WIDTH]
    sy = 1.0 - 2.0 * (yy + 0.5) / cam[CAM_HEIGHT]
    if dirs.shape[0] != 0:
        i0 = yy * w
        for x in range(w):
            ray[0, x] = e0
            ray[1, x] = e1
            ray[2, x] = e2
            ray[3, x] = dirs[i0 + x, 0]
            ray[4, x] = dirs[i0 + x, 1]
            ray[5, x] = dirs[i0 + x, 2]
    elif cam[CAM_ORTHO] != 0.0:
        for x in range(w):
            sx = 2.0 * (x + 0.5) / cw - 1.0
            ray[0, x] = e0 + sx * r0 + sy * u0
            ray[1, x] = e1 + sx * r1 + sy * u1
            ray[2, x] = e2 + sx * r2 + sy * u2
            ray[3, x] = f0
            ray[4, x] = f1
            ray[5, x] = f2
    else:
        for x in range(w):
            sx = 2.0 * (x + 0.5) / cw - 1.0
            dx = f0 + sx * r0 + sy * u0
            dy = f1 + sx * r1 + sy * u1
            dz = f2 + sx * r2 + sy * u2
            inv = 1.0 / np.sqrt(dx * dx + dy * dy + dz * dz)
            ray[0, x] = e0
            ray[1, x] = e1
            ray[2, x] = e2
            ray[3, x] = dx * inv
            ray[4, x] = dy * inv
            ray[5, x] = dz * inv


@njit(**_ROW)
def _zdepth_row(y, fwd, ray, prim, t, zdepth):
    """Row ``y``'s z-depth from its rays (:func:`_row_rays`), branch-free: it vectorises (the
    z-depth alone; with position or face normals it comes with their rays, :func:`_ray_row`)."""
    g0, g1, g2 = fwd[0], fwd[1], fwd[2]
    for x in range(prim.shape[1]):
        z = np.float64(t[y, x]) * (ray[3, x] * g0 + ray[4, x] * g1 + ray[5, x] * g2)
        zdepth[y, x] = z if prim[y, x] >= 0 else 0.0


@njit(**_ROW)
def _pinhole_zdepth_row(y, cam, fwd, y0, prim, t, zdepth):
    """Row ``y``'s z-depth for a pinhole perspective camera, each ray made where it is used:
    :func:`_row_rays` then :func:`_zdepth_row`, operation for operation, without the scratch row
    (branch-free: it vectorises)."""
    r0, r1, r2 = cam[CAM_RIGHT + 0], cam[CAM_RIGHT + 1], cam[CAM_RIGHT + 2]
    u0, u1, u2 = cam[CAM_UP + 0], cam[CAM_UP + 1], cam[CAM_UP + 2]
    f0, f1, f2 = cam[CAM_FORWARD + 0], cam[CAM_FORWARD + 1], cam[CAM_FORWARD + 2]
    g0, g1, g2 = fwd[0], fwd[1], fwd[2]
    cw = cam[CAM_WIDTH]
    sy = 1.0 - 2.0 * (y0 + y + 0.5) / cam[CAM_HEIGHT]
    for x in range(prim.shape[1]):
        sx = 2.0 * (x + 0.5) / cw - 1.0
        dx = f0 + sx * r0 + sy * u0
        dy = f1 + sx * r1 + sy * u1
        dz = f2 + sx * r2 + sy * u2
        inv = 1.0 / np.sqrt(dx * dx + dy * dy + dz * dz)
        z = np.float64(t[y, x]) * ((dx * inv) * g0 + (dy * inv) * g1 + (dz * inv) * g2)
        zdepth[y, x] = z if prim[y, x] >= 0 else 0.0


@njit(**_ROW)
def _triangle_plane(vertices, faces, f):
    """Triangle ``f``'s first vertex ``p0`` and its unnormalised normal ``n = e1 x e2``, float64."""
    i0 = faces[f, 0]
    i1 = faces[f, 1]
    i2 = faces[f, 2]
    p0x, p0y, p0z = vertices[i0, 0], vertices[i0, 1], vertices[i0, 2]
    e1x, e1y, e1z = vertices[i1, 0] - p0x, vertices[i1, 1] - p0y, vertices[i1, 2] - p0z
    e2x, e2y, e2z = vertices[i2, 0] - p0x, vertices[i2, 1] - p0y, vertices[i2, 2] - p0z
    return p0x, p0y, p0z, e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x


def _make_ray_row(ahead: bool):
    """:func:`_ray_row` without (``ahead`` False) or with prefetching, ``ahead`` a closure constant
    folded at compile time: the plain loop is compiled as if prefetching did not exist (a loop
    invariant test of it, or a loop over chunks, measured 20% slower at 82k triangles)."""

    @njit(**_ROW)
    def ray_row(y, fwd, R, ray, prim, geom, t, geometry, outputs, one_origin):
        """Row ``y``'s buffers that need each pixel's ray (``ray``, the row's rays from :func:`_row_rays`):
        z-depth, position, face normals; with ``ahead``, prefetching (:func:`_prefetch_ahead`).
        ``one_origin``: every ray of the row starts at ``ray[:3, 0]`` (a perspective camera)."""
        vertices, faces, face_normals, face_offsets, origin, _ = geometry
        zdepth, position, face_n, face_n_cam = outputs
        w = prim.shape[1]
        want_p = position.shape[0] != 0
        want_f = face_n.shape[0] != 0 or face_n_cam.shape[0] != 0
        if zdepth.shape[0] != 0:
            _zdepth_row(y, fwd, ray, prim, t, zdepth)
        face = np.empty(w, np.int64)  # the row's triangles (0 for a miss)
        for x in range(w):
            hit = prim[y, x] >= 0
            face[x] = face_offsets[geom[y, x] if hit else 0] + prim[y, x] if hit else 0
        if want_p:
            # Each pixel's triangle normal n and numerator (p0 - o) . n, gathered: neighbouring
            # pixels mostly hit the same triangle, and rays from one origin (a perspective
            # camera) share the numerator too, so it is computed once per run of pixels on a
            # triangle; an orthographic row's origins differ, so per pixel. Either way the same
            # operations on the same operands: the same bits.
            plane = np.empty((4, w), np.float64)
            last = -1
            p0x = p0y = p0z = nx = ny = nz = num = 0.0
            for x in range(w):
                if ahead:
                    _prefetch_ahead(face, x, faces, face_normals, vertices, want_p, want_f)
                fresh = face[x] != last
                if fresh:
                    last = face[x]
                    p0x, p0y, p0z, nx, ny, nz = _triangle_plane(vertices, faces, last)
                if fresh or not one_origin:
                    num = (p0x - ray[0, x]) * nx + (p0y - ray[1, x]) * ny + (p0z - ray[2, x]) * nz
                plane[0, x], plane[1, x], plane[2, x], plane[3, x] = nx, ny, nz, num
            _position_row(y, ray, prim, t, plane, origin, position)
        if want_f:
            if ahead and not want_p:  # the gather's rows a pass ahead (with position: its gather asked)
                for x in range(w):
                    prefetch(face_normals, face[x])
            _face_normal_row(y, R, ray, prim, face, face_normals, (face_n, face_n_cam))

    return ray_row


@njit(**_ROW)
def _position_row(y, ray, prim, t, plane, origin, position):
    """Row ``y``'s positions, branch-free (it vectorises): the ray ``o + s d`` meets the pixel's
    triangle plane (``plane``: (4, W), its normal ``n`` of :func:`_triangle_plane` and the
    numerator ``(p0 - o) . n``) at ``s = ((p0 - o) . n) / (d . n)`` in float64, exact to rounding
    at any angle (the cast's ``t`` is float32, and its barycentrics too); at ``t`` itself if the
    ray is parallel to the plane to float64 precision (or ``s`` is not a finite positive number);
    0 for a miss."""
    o0, o1, o2 = origin[0], origin[1], origin[2]
    out = position[y].reshape(-1)  # flat: a store stride known at compile time (3), so the loop vectorises
    for x in range(prim.shape[1]):
        ox, oy, oz, dx, dy, dz = ray[0, x], ray[1, x], ray[2, x], ray[3, x], ray[4, x], ray[5, x]
        den = dx * plane[0, x] + dy * plane[1, x] + dz * plane[2, x]
        q = plane[3, x] / den
        s = q if (den != 0.0) & np.isfinite(q) & (q > 0.0) else np.float64(t[y, x])
        hit = prim[y, x] >= 0
        out[3 * x] = (ox + s * dx) + o0 if hit else 0.0
        out[3 * x + 1] = (oy + s * dy) + o1 if hit else 0.0
        out[3 * x + 2] = (oz + s * dz) + o2 if hit else 0.0


@njit(**_ROW)
def _face_normal_row(y, R, ray, prim, face, face_normals, outputs):
    """Row ``y``'s face normals (world, camera; either may be size 0): the gather of each pixel's
    triangle's normal (``face``: the row's triangles), then per output a branch-free loop (it
    vectorises): turned to the viewer as shading turns them (against the pixel's ray ``d`` of
    ``ray``), 0 for a miss."""
    face_n, face_n_cam = outputs
    w = prim.shape[1]
    g = np.empty((3, w), np.float64)
    for x in range(w):
        f = face[x]
        g[0, x] = face_normals[f, 0]
        g[1, x] = face_normals[f, 1]
        g[2, x] = face_normals[f, 2]
    if face_n.shape[0] != 0:
        _turned_row(y, R, ray, prim, g, face_n[y].reshape(-1))
    if face_n_cam.shape[0] != 0:
        _turned_row_camera(y, R, ray, prim, g, face_n_cam[y].reshape(-1))


def _make_turned_row(rotate: bool):
    """:func:`_turned_row` (world axes, ``rotate`` False) or :func:`_turned_row_camera` (``R n``),
    ``rotate`` a closure constant: the world normals are stored as gathered, not multiplied by an
    identity (``-0.0 + 0.0`` would lose a zero's sign)."""

    @njit(**_ROW)
    def turned_row(y, R, ray, prim, g, out):
        """Each normal ``n`` of ``g`` (3, W), turned against the pixel's ray and with ``rotate``
        rotated by ``R``, into the flat row ``out`` (3 W: a stride known at compile time, so the loop
        vectorises); 0 for a miss."""
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = (R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2],
                                                       R[2, 0], R[2, 1], R[2, 2])
        for x in range(prim.shape[1]):
            n0, n1, n2 = g[0, x], g[1, x], g[2, x]
            flip = n0 * ray[3, x] + n1 * ray[4, x] + n2 * ray[5, x] > 0.0  # turned to the viewer, as shading does
            n0, n1, n2 = (-n0 if flip else n0), (-n1 if flip else n1), (-n2 if flip else n2)
            if rotate:
                n0, n1, n2 = n0 * r00 + n1 * r01 + n2 * r02, n0 * r10 + n1 * r11 + n2 * r12, n0 * r20 + n1 * r21 + n2 * r22
            hit = prim[y, x] >= 0
            out[3 * x] = n0 if hit else 0.0
            out[3 * x + 1] = n1 if hit else 0.0
            out[3 * x + 2] = n2 if hit else 0.0

    return turned_row


_turned_row, _turned_row_camera = _make_turned_row(False), _make_turned_row(True)


@njit(**_ROW)
def _prefetch_ahead(face, x, faces, face_normals, vertices, want_p, want_f):
    """Prefetch the rows (faces, face normals) of the triangle of the pixel :data:`_AHEAD_FACES`
    ahead of ``x`` in the row whose triangles are ``face``, and the vertices of that of the pixel
    :data:`_AHEAD_VERTS` ahead (whose face row was prefetched before). The arrays come one by one: a
    tuple of them made per pixel would take and drop a reference on each."""
    w = face.shape[0]
    if x + _AHEAD_FACES < w:
        f = face[x + _AHEAD_FACES]
        if want_p:
            prefetch(faces, f)
        if want_f:
            prefetch(face_normals, f)
    if want_p and x + _AHEAD_VERTS < w:
        f = face[x + _AHEAD_VERTS]
        for c in range(3):
            prefetch(vertices, faces[f, c])


# Pixels ahead of the one being done whose triangles' rows (then vertices) are prefetched, on a mesh
# whose gathered arrays exceed PREFETCH_BYTES (the kernels' common threshold). Measured at 1.31 M triangles,
# 1080p, all 12 buffers: 48/24, 32/16 and 16/8 within noise of one another, each 20-27% faster.
_AHEAD_FACES, _AHEAD_VERTS = 48, 24
_RAY_BUFFERS = ("zdepth", "position", "face_normal", "face_normal_camera")  # those that need the pixel's ray

_ray_row, _ray_row_ahead = _make_ray_row(False), _make_ray_row(True)
