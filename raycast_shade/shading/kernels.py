"""Shading kernels: flat, Gouraud and Phong over a hit buffer.

Every mode evaluates the lecture's reflectance equation, per channel::

    I = Ia ka + sum_i vis_i att_i(d) Ii (kd max(n.s, 0) + Ks max(r.v, 0)^t)

with ``r = 2 (n.s) n - s`` (or Blinn-Phong ``(n.h)^t``), no specular term
where ``n.s <= 0``, ``att`` one of ``1``, ``1/d^2``, ``1/(d + k)``, and
``vis`` 0 or 1 from a shadow ray for lights that cast shadows. The viewer's
distance never enters: only the direction ``v`` to the eye does.

What differs is *where* the equation is evaluated:

flat
    once per triangle, at its centre, with its true (geometric) normal;
Gouraud
    at each vertex with its averaged normal; colours interpolated with the
    barycentrics;
Phong
    at each pixel, at the true 3D hit point, with the normal interpolated
    (``a = n1 + mu1 (n2 - n1) + mu2 (n3 - n1)``), renormalised, and perturbed
    by the material's bump map if it has one.

Shadows follow the same rule: a shadow ray leaves the point where the model
is evaluated (face centre, vertex, or pixel), so Gouraud's shadows are as
coarse as its highlights.

Orientation (two-sided lighting): the geometric normal ``ng`` is turned to
the viewer; a shading normal seen from the back is negated with it, and one
that still points into the far hemisphere (coarse silhouettes, inconsistent
data) is reflected across the tangent plane into the viewer's hemisphere,
which is continuous where plain negation would jump. An interpolated normal
that cancels (``|a| < 1e-6``) falls back to ``ng``. Gouraud lights a vertex
from whichever side the viewer sees its triangle (both sides are shaded).

Shadow rays start at the shading point pushed off the surface along ``ng``
by a few hundred float32 ulps of its coordinates (Wachter and Binder, Ray
Tracing Gems ch. 6), and near zero by a fixed fraction of the scene's size
(their absolute constants, in units of the scene), so the offset scales with
the scene; point-light rays stop just short of the light. Mirror rays start
from the same kind of offset point. In Phong mode the start point is first lifted onto the
vertices' tangent planes (Hanika, Ray Tracing Gems II ch. 4) so that coarse
meshes with smooth normals do not shadow themselves at the terminator.

Kernels are private, parallel, and work in float64; their plain-NumPy twins
live in :mod:`raycast_shade.reference`.

Speed notes. The kernels take the packed tuples of :func:`kernel_inputs` but
unpack them once, outside the pixel loop, and hand plain arrays to the inlined
helpers: unpacking a tuple of arrays inside the loop makes Numba take and drop
a reference on every array for every pixel (atomic operations on counters
that both threads share), which cost more than the shading arithmetic
(measured on a 1080p Phong frame of an 81,920-triangle sphere on 2 cores:
36 ms with the unpacking in the loop, 19 ms without, repeated squaring
included).
Integer shininess, the usual case, is raised by repeated squaring rather than
``pow``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..common.choices import SHADINGS
from ..visibility import embree
from ..visibility.accel import embree_accel
from ..common.schedule import BLOCK_ROWS, spread_step
from ..visibility.hits import check_hits

__all__ = ["SHADINGS", "METHODS", "shade", "shading_normals", "kernel_inputs", "resolve_methods"]

METHODS = {"flat": 0, "gouraud": 1, "phong": 2}
_CANCEL = 1e-6  # |interpolated normal| below this counts as cancelled
_SHADOW_TFAR = 1.0 - 1e-5  # point-light shadow rays stop just short of the light
_SCRATCH = 24  # float32 slots: one RTCRay (12) plus alignment slack

# No nnan/ninf: misses and degenerate cases must compare as written.
_FLT32_MAX = float(np.finfo(np.float32).max)  # radiance saturates here instead of becoming inf
_jit = dict(cache=True, error_model="numpy", fastmath={"nsz", "arcp", "contract", "afn", "reassoc"})


# ----------------------------------------------------------------------------------
# shadow rays


@njit(inline="always", **_jit)
def _scratch():
    """A per-task RTCRay buffer: (float view, uint view, aligned offset, address)."""
    buf = np.empty(_SCRATCH, np.float32)
    base = buf.ctypes.data
    off = ((16 - base % 16) % 16) // 4
    return buf, buf.view(np.uint32), off, base + off * 4


@njit(inline="always", **_jit)
def _nudge(p, n, unit):
    """Move coordinate ``p`` by 256 float32 ulps along normal component ``n``.

    Near zero, where ulps vanish but the triangles around the point still
    carry the float32 error of their (larger) vertex coordinates, the move is
    ``unit / 65536`` instead: Wachter and Binder's constants (1/32, 1/65536)
    measured in ``unit``, the scene's size (bounding-box diagonal), rather
    than in absolute units, so that a scene at scale 1e5 is as safe as one
    at scale 1."""
    if abs(p) < unit * (1.0 / 32.0):
        return p + n * (unit * (1.0 / 65536.0))
    _, e = math.frexp(p)
    return p + n * math.ldexp(256.0, e - 24)


@njit(inline="always", **_jit)
def _occluded(handle, S, px, py, pz, gx, gy, gz, sx, sy, sz, lx, ly, lz, is_point, unit):
    """True if the scene blocks the way from p towards the light.

    ``S`` is the scratch from :func:`_scratch`, unpacked only here: shadow
    rays are the rare path, and the unpacking costs reference counting."""
    buf, ib, off, addr = S
    side = 1.0 if gx * sx + gy * sy + gz * sz >= 0.0 else -1.0
    ox = _nudge(px, side * gx, unit)
    oy = _nudge(py, side * gy, unit)
    oz = _nudge(pz, side * gz, unit)
    if is_point:
        dx = lx - ox
        dy = ly - oy
        dz = lz - oz
        tfar = _SHADOW_TFAR
    else:
        dx = sx
        dy = sy
        dz = sz
        tfar = np.inf
    buf[off + 0] = ox
    buf[off + 1] = oy
    buf[off + 2] = oz
    buf[off + 3] = 0.0
    buf[off + 4] = dx
    buf[off + 5] = dy
    buf[off + 6] = dz
    buf[off + 7] = 0.0
    buf[off + 8] = tfar
    ib[off + 9] = 0xFFFFFFFF
    ib[off + 10] = 0
    ib[off + 11] = 0
    embree.occluded1(handle, addr, 0)
    return buf[off + 8] < 0.0  # Embree sets tfar to -inf on a hit


# ----------------------------------------------------------------------------------
# the reflectance equation


@njit(inline="always", **_jit)
def _power(c, t):
    """``c ** t`` for ``0 <= c <= 1``: repeated squaring when ``t`` is a whole
    number up to 4096 (a few multiplications, within a few ulps of ``pow``,
    which costs several times more), ``pow`` otherwise."""
    n = int(t)
    if n != t or n > 4096:
        return c ** t
    r = 1.0
    while n > 0:
        if n & 1:
            r *= c
        c *= c
        n >>= 1
    return r


def _illuminate_py(px, py, pz, nx, ny, nz, vx, vy, vz, mats, mi, ambient, lights, dmin, handle, unit, S,
                   ox, oy, oz, gx, gy, gz, spec_on, att_on):
    """RGB reflected towards unit ``v`` at point ``p`` with unit normal ``n``.

    ``mats[mi]`` is the material row (indexed, not sliced: a slice per pixel
    would cost an atomic reference count shared by all threads).
    ``ambient`` (3,), ``lights`` (L, 10), ``dmin``, ``handle`` and ``unit`` are
    the unpacked ``L`` of :func:`kernel_inputs`; ``S`` is the shadow-ray
    scratch; shadow rays start at ``o`` pushed off along ``g``. ``spec_on``
    and ``att_on`` are compile-time constants (see :func:`_make_kernels`): a
    scene with no specular material or no attenuating light compiles without
    that arithmetic.
    """
    r = ambient[0] * mats[mi, 0]
    g = ambient[1] * mats[mi, 1]
    b = ambient[2] * mats[mi, 2]
    shin = mats[mi, 9]
    blinn = mats[mi, 10] != 0.0
    has_spec = mats[mi, 6] > 0.0 or mats[mi, 7] > 0.0 or mats[mi, 8] > 0.0
    for i in range(lights.shape[0]):
        is_point = lights[i, 0] == 0.0
        if not is_point:
            sx = lights[i, 1]
            sy = lights[i, 2]
            sz = lights[i, 3]
            att = 1.0
        else:
            dx = lights[i, 1] - px
            dy = lights[i, 2] - py
            dz = lights[i, 3] - pz
            d = np.sqrt(dx * dx + dy * dy + dz * dz)
            if d == 0.0:
                continue  # light on the surface point: no direction, no light
            sx = dx / d
            sy = dy / d
            sz = dz / d
            att = 1.0
            if att_on:
                if lights[i, 7] == 1.0:
                    dd = max(d, dmin)
                    att = 1.0 / (dd * dd)
                elif lights[i, 7] == 2.0:
                    att = 1.0 / (d + lights[i, 8])
        ndots = nx * sx + ny * sy + nz * sz
        if ndots <= 0.0:
            continue
        if ndots > 1.0:
            ndots = 1.0
        if lights[i, 9] != 0.0 and handle != 0:
            if _occluded(handle, S, ox, oy, oz, gx, gy, gz, sx, sy, sz,
                         lights[i, 1], lights[i, 2], lights[i, 3], is_point, unit):
                continue
        spec = 0.0
        if spec_on and has_spec:
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
                spec = _power(min(c, 1.0), shin)
        r += att * lights[i, 4] * (mats[mi, 3] * ndots + mats[mi, 6] * spec)
        g += att * lights[i, 5] * (mats[mi, 4] * ndots + mats[mi, 7] * spec)
        b += att * lights[i, 6] * (mats[mi, 5] * ndots + mats[mi, 8] * spec)
    return r, g, b


# Inlined into the hot loops (each kernel inlines it once, which keeps compile
# time in check); the called variant serves rare fallback branches.
_illuminate = njit(inline="always", **_jit)(_illuminate_py)
_illuminate_call = njit(**_jit)(_illuminate_py)


# ----------------------------------------------------------------------------------
# geometry at a hit


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


@njit(inline="always", **_jit)
def _terminator_point(verts, normals, i0, i1, i2, b1, b2, px, py, pz, sgn):
    """Hanika's shadow-ray origin: p lifted onto the vertices' tangent planes
    (only upwards), so a flat facet under a smooth normal does not shadow
    itself near the terminator."""
    b0 = 1.0 - b1 - b2
    qx = px
    qy = py
    qz = pz
    for k in range(3):
        i = i0 if k == 0 else (i1 if k == 1 else i2)
        w = b0 if k == 0 else (b1 if k == 1 else b2)
        nx = sgn * normals[i, 0]
        ny = sgn * normals[i, 1]
        nz = sgn * normals[i, 2]
        d = (px - verts[i, 0]) * nx + (py - verts[i, 1]) * ny + (pz - verts[i, 2]) * nz
        if d < 0.0:
            qx -= w * d * nx
            qy -= w * d * ny
            qz -= w * d * nz
    return qx, qy, qz


@njit(inline="always", **_jit)
def _bilinear(tex, base, rows, cols, clamp, x, y):
    """Bilinear sample at texel coordinates (x, y) (texel centres at integers)."""
    j0 = math.floor(x)
    i0 = math.floor(y)
    tx = x - j0
    ty = y - i0
    j0 = int(j0)
    i0 = int(i0)
    j1 = j0 + 1
    i1 = i0 + 1
    if clamp:
        j0 = min(max(j0, 0), cols - 1)
        j1 = min(max(j1, 0), cols - 1)
        i0 = min(max(i0, 0), rows - 1)
        i1 = min(max(i1, 0), rows - 1)
    else:
        j0 %= cols
        j1 %= cols
        i0 %= rows
        i1 %= rows
    a = tex[base + i0 * cols + j0] * (1.0 - tx) + tex[base + i0 * cols + j1] * tx
    b = tex[base + i1 * cols + j0] * (1.0 - tx) + tex[base + i1 * cols + j1] * tx
    return a * (1.0 - ty) + b * ty


@njit(inline="always", **_jit)
def _bump(nx, ny, nz, f, gm, i0, i1, i2, b1, b2, uvs, tangents, bump_index, texels, info, fx, fy, fz):
    """Blinn's perturbed normal N' = N + (Bu (N x Pv) - Bv (N x Pu)) / |N|,
    with N = n |Pu x Pv| along the (oriented) shading normal n.

    The surface is displaced along its front (winding) normal ``f``, not
    along ``Pu x Pv``: where the UV map is left-handed (``(Pu x Pv).f < 0``,
    e.g. the spherical mapping seen from outside), the perturbation changes
    sign, so a negative height is a dent on every mesh. The arrays are the
    unpacked ``B`` of :func:`kernel_inputs`."""
    k = bump_index[gm]
    if k < 0:
        return nx, ny, nz
    b0 = 1.0 - b1 - b2
    tu = b0 * uvs[i0, 0] + b1 * uvs[i1, 0] + b2 * uvs[i2, 0]
    tv = b0 * uvs[i0, 1] + b1 * uvs[i1, 1] + b2 * uvs[i2, 1]
    base = int(info[k, 0])
    rows = int(info[k, 1])
    cols = int(info[k, 2])
    clamp = info[k, 3] != 0.0
    su = info[k, 4]
    sv = info[k, 5]
    scale = info[k, 6]
    x = tu * su * cols - 0.5
    y = tv * sv * rows - 0.5
    # Central differences one texel wide: exact for heights linear in u, v.
    bu = (_bilinear(texels, base, rows, cols, clamp, x + 0.5, y)
          - _bilinear(texels, base, rows, cols, clamp, x - 0.5, y)) * cols * su * scale
    bv = (_bilinear(texels, base, rows, cols, clamp, x, y + 0.5)
          - _bilinear(texels, base, rows, cols, clamp, x, y - 0.5)) * rows * sv * scale
    pux = tangents[f, 0]
    puy = tangents[f, 1]
    puz = tangents[f, 2]
    pvx = tangents[f, 3]
    pvy = tangents[f, 4]
    pvz = tangents[f, 5]
    cx = puy * pvz - puz * pvy
    cy = puz * pvx - pux * pvz
    cz = pux * pvy - puy * pvx
    area = np.sqrt(cx * cx + cy * cy + cz * cz)  # |N| = |Pu x Pv|
    if cx * fx + cy * fy + cz * fz < 0.0:  # left-handed UVs: Pu x Pv points inwards
        bu = -bu
        bv = -bv
    # (N x Pv) / |N| = n x Pv, likewise for Pu
    ax = area * nx + bu * (ny * pvz - nz * pvy) - bv * (ny * puz - nz * puy)
    ay = area * ny + bu * (nz * pvx - nx * pvz) - bv * (nz * pux - nx * puz)
    az = area * nz + bu * (nx * pvy - ny * pvx) - bv * (nx * puy - ny * pux)
    al = np.sqrt(ax * ax + ay * ay + az * az)
    if not (al > 0.0 and al < np.inf):
        return nx, ny, nz
    return ax / al, ay / al, az / al


@njit(inline="always", **_jit)
def _surface(verts, normals, faces, fnormals, uvs, tangents, bump_index, texels, info, cam, f, gm, b1, b2,
             use_dir, dx, dy, dz):
    """Everything about a hit that shading needs.

    The arrays are the unpacked ``G`` and ``B`` of :func:`kernel_inputs`.
    The view vector is towards the eye, or ``-d`` for a secondary ray.
    Returns p, v, oriented geometric normal g, its sign, and the oriented
    (and bumped) shading normal n.
    """
    i0 = faces[f, 0]
    i1 = faces[f, 1]
    i2 = faces[f, 2]
    px, py, pz = _hit_point(verts, i0, i1, i2, b1, b2)
    if use_dir:
        vx = -dx
        vy = -dy
        vz = -dz
    else:
        vx, vy, vz = _view(cam, px, py, pz)
    gx, gy, gz, sgn = _facing(fnormals, f, vx, vy, vz)
    nx, ny, nz = _shading_normal(normals, i0, i1, i2, b1, b2, gx, gy, gz, sgn)
    nx, ny, nz = _bump(nx, ny, nz, f, gm, i0, i1, i2, b1, b2, uvs, tangents, bump_index, texels, info,
                       sgn * gx, sgn * gy, sgn * gz)
    return px, py, pz, vx, vy, vz, gx, gy, gz, sgn, nx, ny, nz


@njit(inline="always", **_jit)
def _shade_surface(verts, normals, faces, fnormals, uvs, tangents, bump_index, texels, info,
                   ambient, lights, dmin, handle, unit, S, materials, cam, f, gm, b1, b2, use_dir, dx, dy, dz,
                   spec_on, att_on):
    """Phong shading of one hit: colour, plus the point and normals for mirrors.

    The arrays and scalars before ``S`` are the unpacked ``G``, ``B`` and
    ``L`` of :func:`kernel_inputs`."""
    px, py, pz, vx, vy, vz, gx, gy, gz, sgn, nx, ny, nz = _surface(
        verts, normals, faces, fnormals, uvs, tangents, bump_index, texels, info, cam, f, gm, b1, b2,
        use_dir, dx, dy, dz)
    ox = px
    oy = py
    oz = pz
    if handle != 0:  # shadow rays will be traced: start them past the terminator
        ox, oy, oz = _terminator_point(verts, normals, faces[f, 0], faces[f, 1], faces[f, 2], b1, b2, px, py, pz, sgn)
    r, g, b = _illuminate(px, py, pz, nx, ny, nz, vx, vy, vz, materials, gm, ambient, lights, dmin, handle, unit, S,
                          ox, oy, oz, gx, gy, gz, spec_on, att_on)
    return r, g, b, px, py, pz, vx, vy, vz, gx, gy, gz, nx, ny, nz


# ----------------------------------------------------------------------------------
# kernels


@njit(parallel=True, **_jit)
def _visible_kernel(prim, geom, faces, face_off, modes, face_flags, vertex_flags):
    """Mark the faces of flat-shaded models and the vertices of Gouraud-shaded
    ones that some pixel sees: only those get shaded."""
    h, w = prim.shape
    for y in prange(h):
        for x in range(w):
            p = prim[y, x]
            if p >= 0:
                g = geom[y, x]
                f = face_off[g] + p
                # Racy, but every writer stores the same 1.
                if modes[g] == 0:
                    face_flags[f] = 1
                elif modes[g] == 1:
                    vertex_flags[faces[f, 0]] = 1
                    vertex_flags[faces[f, 1]] = 1
                    vertex_flags[faces[f, 2]] = 1


_CHUNK = 1024


@njit(inline="always", **_jit)
def _corner_shade(vcol, normals, verts, i, side, gx, gy, gz, materials, m, cam, ambient, lights, dmin, handle, unit,
                  S, spec_on, att_on):
    """A vertex's Gouraud shade for a face seen from ``side``.

    The precomputed shade serves when the vertex normal (negated on the back
    side) lies in the face's viewer hemisphere, as on consistent data. A
    vertex without a normal borrows the face's; one whose normal points to
    the far side of this face (opposite normals, a wrongly wound face) is
    reflected across the face's plane, Phong's rule at the vertex, instead
    of being lit from behind. Both are rare, so they are shaded on the spot.
    """
    sg = 1.0 - 2.0 * side
    nx = sg * normals[i, 0]
    ny = sg * normals[i, 1]
    nz = sg * normals[i, 2]
    c = nx * gx + ny * gy + nz * gz
    if nx == 0.0 and ny == 0.0 and nz == 0.0:
        nx, ny, nz = gx, gy, gz
    elif c < 0.0:
        nx -= 2.0 * c * gx
        ny -= 2.0 * c * gy
        nz -= 2.0 * c * gz
    else:
        return vcol[i, side, 0], vcol[i, side, 1], vcol[i, side, 2]
    px = verts[i, 0]
    py = verts[i, 1]
    pz = verts[i, 2]
    vx, vy, vz = _view(cam, px, py, pz)
    return _illuminate_call(px, py, pz, nx, ny, nz, vx, vy, vz, materials, m, ambient, lights, dmin, handle, unit,
                            S, px, py, pz, gx, gy, gz, spec_on, att_on)


@njit(parallel=True, **_jit)
def _lookup_flat_kernel(prim, geom, face_off, fcol, background, modes, image):
    """Flat: each pixel of the models whose method is 0 takes its face's shade."""
    h, w = prim.shape
    for y in prange(h):
        for x in range(w):
            p = prim[y, x]
            if p < 0:
                for c in range(3):
                    image[y, x, c] = background[c]
                continue
            g = geom[y, x]
            if modes[g] != 0:
                continue
            f = face_off[g] + p
            for c in range(3):
                image[y, x, c] = min(fcol[f, c], _FLT32_MAX)


@njit(parallel=True, **_jit)
def _normals_kernel(prim, geom, u, v, G, B, face_off, cam, modes, nbuf):
    """The unit normal each pixel is shaded with, turned to the viewer."""
    verts, normals, faces, fnormals = G
    uvs, tangents, bump_index, texels, info = B
    h, w = prim.shape
    nblk = (h + BLOCK_ROWS - 1) // BLOCK_ROWS
    step = spread_step(nblk)
    for it in prange(nblk):  # blocks of rows in a balanced order (see _schedule)
        blk = (it * step) % nblk
        for y in range(blk * BLOCK_ROWS, min(h, (blk + 1) * BLOCK_ROWS)):
            for x in range(w):
                p = prim[y, x]
                if p < 0:
                    for c in range(3):
                        nbuf[y, x, c] = 0.0
                    continue
                gm = geom[y, x]
                f = face_off[gm] + p
                _, _, _, _, _, _, gx, gy, gz, _, nx, ny, nz = _surface(
                    verts, normals, faces, fnormals, uvs, tangents, bump_index, texels, info, cam, f, gm,
                    np.float64(u[y, x]), np.float64(v[y, x]), False, 0.0, 0.0, 0.0)
                if modes[gm] == 0:
                    nx, ny, nz = gx, gy, gz
                nbuf[y, x, 0] = nx
                nbuf[y, x, 1] = ny
                nbuf[y, x, 2] = nz


@njit(inline="always", **_jit)
def _mirror_ray(px, py, pz, vx, vy, vz, gx, gy, gz, nx, ny, nz, unit):
    """Reflect the incoming direction d = -v about n: r = d - 2 (d.n) n,
    kept above the geometric surface, from an origin pushed off along g."""
    dn = -(vx * nx + vy * ny + vz * nz)
    rx = -vx - 2.0 * dn * nx
    ry = -vy - 2.0 * dn * ny
    rz = -vz - 2.0 * dn * nz
    c = rx * gx + ry * gy + rz * gz
    if c < 0.0:  # a bent shading normal sent it below the surface
        rx -= 2.0 * c * gx
        ry -= 2.0 * c * gy
        rz -= 2.0 * c * gz
    return _nudge(px, gx, unit), _nudge(py, gy, unit), _nudge(pz, gz, unit), rx, ry, rz


@njit(parallel=True, **_jit)
def _mirror_rows_kernel(prim, geom, materials, counts):
    """``counts[y]``: how many pixels of row ``y`` see a reflective surface."""
    h, w = prim.shape
    for y in prange(h):
        c = 0
        for x in range(w):
            if prim[y, x] >= 0 and materials[geom[y, x], 11] > 0.0:
                c += 1
        counts[y] = c


@njit(parallel=True, **_jit)
def _reflect_primary_kernel(prim, geom, u, v, G, B, face_off, materials, cam, unit, starts, pixel, origins, dirs):
    """Mirror rays from every pixel whose surface reflects, packed: row ``y``'s
    rays go from ``starts[y]`` on (see :func:`_mirror_rows_kernel`), with
    their flat pixel index in ``pixel``. Packed arrays hold the mirror pixels
    only, not the whole image (at 1080p, 96 MB of mostly untouched memory
    that cost more in page faults than the mirror rays themselves)."""
    verts, normals, faces, fnormals = G
    uvs, tangents, bump_index, texels, info = B
    h, w = prim.shape
    nblk = (h + BLOCK_ROWS - 1) // BLOCK_ROWS
    step = spread_step(nblk)
    for it in prange(nblk):  # blocks of rows in a balanced order (see _schedule)
        blk = (it * step) % nblk
        for y in range(blk * BLOCK_ROWS, min(h, (blk + 1) * BLOCK_ROWS)):
            j = starts[y]
            for x in range(w):
                p = prim[y, x]
                if p < 0:
                    continue
                gm = geom[y, x]
                if materials[gm, 11] <= 0.0:
                    continue
                f = face_off[gm] + p
                px, py, pz, vx, vy, vz, gx, gy, gz, _, nx, ny, nz = _surface(
                    verts, normals, faces, fnormals, uvs, tangents, bump_index, texels, info, cam, f, gm,
                    np.float64(u[y, x]), np.float64(v[y, x]), False, 0.0, 0.0, 0.0)
                ox, oy, oz, rx, ry, rz = _mirror_ray(px, py, pz, vx, vy, vz, gx, gy, gz, nx, ny, nz, unit)
                pixel[j] = y * w + x
                origins[j, 0] = ox
                origins[j, 1] = oy
                origins[j, 2] = oz
                dirs[j, 0] = rx
                dirs[j, 1] = ry
                dirs[j, 2] = rz
                j += 1


def _make_kernels(spec_on: bool, att_on: bool):
    """The kernels that evaluate the reflectance equation, compiled for one
    scene variant: ``spec_on`` (some material has a specular term) and
    ``att_on`` (some light attenuates) are closure constants, so a variant
    without them carries none of that arithmetic. Each variant is cached on
    disk separately; only the variants a program uses are ever compiled.

    Returns
    -------
    dict of str to dispatcher
        ``phong``, ``faces``, ``vertices``, ``gouraud``, ``points``.
    """

    @njit(parallel=True, **_jit)
    def _shade_phong_kernel(prim, geom, u, v, G, B, L, face_off, materials, cam, background, modes, image):
        """Phong: shade every pixel of the models whose method is 2."""
        verts, normals, faces, fnormals = G
        uvs, tangents, bump_index, texels, info = B
        ambient, lights, dmin, handle, unit = L
        h, w = prim.shape
        nblk = (h + BLOCK_ROWS - 1) // BLOCK_ROWS
        step = spread_step(nblk)
        for it in prange(nblk):  # blocks of rows in a balanced order (see _schedule)
            blk = (it * step) % nblk
            for y in range(blk * BLOCK_ROWS, min(h, (blk + 1) * BLOCK_ROWS)):
                S = _scratch()
                for x in range(w):
                    p = prim[y, x]
                    if p < 0:
                        for c in range(3):
                            image[y, x, c] = background[c]
                        continue
                    gm = geom[y, x]
                    if modes[gm] != 2:
                        continue
                    f = face_off[gm] + p
                    r, g, b, _, _, _, _, _, _, _, _, _, _, _, _ = _shade_surface(
                        verts, normals, faces, fnormals, uvs, tangents, bump_index, texels, info,
                        ambient, lights, dmin, handle, unit, S, materials, cam, f, gm,
                        np.float64(u[y, x]), np.float64(v[y, x]), False, 0.0, 0.0, 0.0, spec_on, att_on)
                    image[y, x, 0] = min(r, _FLT32_MAX)
                    image[y, x, 1] = min(g, _FLT32_MAX)
                    image[y, x, 2] = min(b, _FLT32_MAX)


    @njit(parallel=True, **_jit)
    def _shade_faces_kernel(face_flags, verts, faces, fnormals, face_model, materials, cam, L, out):
        """Flat shading: one shade per visible face, at its centre."""
        ambient, lights, dmin, handle, unit = L
        n = faces.shape[0]
        nchunk = (n + _CHUNK - 1) // _CHUNK
        step = spread_step(nchunk)
        for it in prange(nchunk):  # chunks in a balanced order (see _schedule)
            c = (it * step) % nchunk
            S = _scratch()
            for f in range(c * _CHUNK, min(n, (c + 1) * _CHUNK)):
                if face_flags[f] == 0:
                    continue
                third = 1.0 / 3.0
                px, py, pz = _hit_point(verts, faces[f, 0], faces[f, 1], faces[f, 2], third, third)
                vx, vy, vz = _view(cam, px, py, pz)
                gx, gy, gz, sgn = _facing(fnormals, f, vx, vy, vz)
                r, g, b = _illuminate(px, py, pz, gx, gy, gz, vx, vy, vz, materials, face_model[f],
                                      ambient, lights, dmin, handle, unit, S, px, py, pz, gx, gy, gz,
                                      spec_on, att_on)
                out[f, 0] = r
                out[f, 1] = g
                out[f, 2] = b


    @njit(parallel=True, **_jit)
    def _shade_vertices_kernel(vertex_flags, verts, normals, vertex_model, materials, cam, L, out):
        """Gouraud: the shade of each visible vertex, lit from the front (normal)
        and from the back (negated normal)."""
        ambient, lights, dmin, handle, unit = L
        n = verts.shape[0]
        nchunk = (n + _CHUNK - 1) // _CHUNK
        step = spread_step(nchunk)
        for it in prange(nchunk):  # chunks in a balanced order (see _schedule)
            c = (it * step) % nchunk
            S = _scratch()
            for i in range(c * _CHUNK, min(n, (c + 1) * _CHUNK)):
                if vertex_flags[i] == 0:
                    continue
                px = verts[i, 0]
                py = verts[i, 1]
                pz = verts[i, 2]
                vx, vy, vz = _view(cam, px, py, pz)
                m = vertex_model[i]
                for side in range(2):
                    sg = 1.0 - 2.0 * side
                    nx = sg * normals[i, 0]
                    ny = sg * normals[i, 1]
                    nz = sg * normals[i, 2]
                    r, g, b = _illuminate(px, py, pz, nx, ny, nz, vx, vy, vz, materials, m,
                                          ambient, lights, dmin, handle, unit, S, px, py, pz, nx, ny, nz,
                                          spec_on, att_on)
                    out[i, side, 0] = r
                    out[i, side, 1] = g
                    out[i, side, 2] = b


    @njit(parallel=True, **_jit)
    def _interp_gouraud_kernel(prim, geom, u, v, verts, normals, faces, fnormals, face_off, materials, cam, L,
                               background, modes, vcol, image):
        """Gouraud: interpolate vertex shades over the models whose method is 1."""
        ambient, lights, dmin, handle, unit = L
        h, w = prim.shape
        nblk = (h + BLOCK_ROWS - 1) // BLOCK_ROWS
        step = spread_step(nblk)
        for it in prange(nblk):  # blocks of rows in a balanced order (see _schedule)
            blk = (it * step) % nblk
            for y in range(blk * BLOCK_ROWS, min(h, (blk + 1) * BLOCK_ROWS)):
                S = _scratch()
                for x in range(w):
                    p = prim[y, x]
                    if p < 0:
                        for c in range(3):
                            image[y, x, c] = background[c]
                        continue
                    g = geom[y, x]
                    if modes[g] != 1:
                        continue
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
                    r0, g0, c0 = _corner_shade(vcol, normals, verts, i0, side, gx, gy, gz, materials, g, cam,
                                                 ambient, lights, dmin, handle, unit, S, spec_on, att_on)
                    r1, g1, c1 = _corner_shade(vcol, normals, verts, i1, side, gx, gy, gz, materials, g, cam,
                                                 ambient, lights, dmin, handle, unit, S, spec_on, att_on)
                    r2, g2, c2 = _corner_shade(vcol, normals, verts, i2, side, gx, gy, gz, materials, g, cam,
                                                 ambient, lights, dmin, handle, unit, S, spec_on, att_on)
                    image[y, x, 0] = min(b0 * r0 + b1 * r1 + b2 * r2, _FLT32_MAX)
                    image[y, x, 1] = min(b0 * g0 + b1 * g1 + b2 * g2, _FLT32_MAX)
                    image[y, x, 2] = min(b0 * c0 + b1 * c1 + b2 * c2, _FLT32_MAX)


    @njit(parallel=True, **_jit)
    def _shade_points_kernel(prim, geom, u, v, dirs, G, B, L, face_off, materials, cam, background, last,
                             colour, origins, next_dirs, active):
        """Phong-shade secondary hits seen along ``dirs``; emit the next mirror rays.

        A reflective surface keeps ``1 - rho`` of its local shade and passes
        ``rho`` on, except at the last bounce, where it shows its local shade.
        """
        verts, normals, faces, fnormals = G
        uvs, tangents, bump_index, texels, info = B
        ambient, lights, dmin, handle, unit = L
        n = prim.shape[0]
        nchunk = (n + _CHUNK - 1) // _CHUNK
        step = spread_step(nchunk)
        for it in prange(nchunk):  # chunks in a balanced order (see _schedule)
            c = (it * step) % nchunk
            S = _scratch()
            for i in range(c * _CHUNK, min(n, (c + 1) * _CHUNK)):
                active[i] = False
                p = prim[i]
                if p < 0:
                    for k in range(3):
                        colour[i, k] = background[k]
                    continue
                gm = geom[i]
                f = face_off[gm] + p
                r, g, b, px, py, pz, vx, vy, vz, gx, gy, gz, nx, ny, nz = _shade_surface(
                    verts, normals, faces, fnormals, uvs, tangents, bump_index, texels, info,
                    ambient, lights, dmin, handle, unit, S, materials, cam, f, gm,
                    np.float64(u[i]), np.float64(v[i]), True, dirs[i, 0], dirs[i, 1], dirs[i, 2], spec_on, att_on)
                rho = materials[gm, 11]
                keep = 1.0
                if rho > 0.0 and not last:
                    keep = 1.0 - rho
                    ox, oy, oz, rx, ry, rz = _mirror_ray(px, py, pz, vx, vy, vz, gx, gy, gz, nx, ny, nz, unit)
                    origins[i, 0] = ox
                    origins[i, 1] = oy
                    origins[i, 2] = oz
                    next_dirs[i, 0] = rx
                    next_dirs[i, 1] = ry
                    next_dirs[i, 2] = rz
                    active[i] = True
                colour[i, 0] = keep * r
                colour[i, 1] = keep * g
                colour[i, 2] = keep * b


    return dict(phong=_shade_phong_kernel, faces=_shade_faces_kernel, vertices=_shade_vertices_kernel,
                gouraud=_interp_gouraud_kernel, points=_shade_points_kernel)


_VARIANTS = {(s, a): _make_kernels(s, a) for s in (False, True) for a in (False, True)}


def _kernels(k):
    """The kernels of a frame's variant (see :func:`_make_kernels`)."""
    return _VARIANTS[(k["spec_on"], k["att_on"])]


# ----------------------------------------------------------------------------------
# public wrappers


def kernel_inputs(scene, camera):
    """Everything the kernels read, packed once per frame.

    Returns
    -------
    dict
        ``G`` = (verts (V,3) f8, normals (V,3) f8, faces (F,3) i8, fnormals (F,3) f8);
        ``B`` = (uvs (V,2) f8, tangents (F,6) f8, bump_index (G,) i4, texels (T,) f4, info (B,7) f8);
        ``L`` = (ambient (3,) f8, lights (L,10) f8, dmin f8, scene handle uintp or 0
        when no light casts shadows, unit f8 = the scene's size for ray offsets), where
        a row of ``lights`` is kind (0 point, 1 directional), position or direction
        to the light (3), radiance (3), attenuation code (0 none, 1 1/d^2,
        2 1/(d+k)), k, casts shadows (0/1);
        ``face_off`` (G+1,) i8, ``materials`` (G,12) f8, ``cam`` (16,) f8, ``background`` (3,) f8;
        ``spec_on``, ``att_on`` bool: whether any material has a specular term and any
        light attenuates (the kernels compile a variant for each combination).
    """
    from ..visibility.rays import camera_frame

    geo = scene.geometry
    lkind, lvec, lrad, latt, lk, lshadow = scene.packed_lights()
    handle = embree_accel(geo).handle if lshadow.any() else 0
    # One array for the lights: the kernels index it per pixel and light, and
    # every separate array would be one more argument to thread through.
    lights = np.column_stack([lkind, lvec, lrad, latt, lk, lshadow]).astype(np.float64).reshape(-1, 10)
    return dict(
        G=(geo.vertices, geo.normals, geo.faces, geo.face_normals),
        B=(geo.uvs, geo.tangents, geo.bump_index, geo.bump_texels, geo.bump_info),
        L=(np.array(scene.ambient, np.float64), lights, 1e-6 * geo.scale, np.uintp(handle), float(geo.scale)),
        face_off=geo.face_offsets, materials=geo.materials, cam=camera_frame(camera, geo.origin),
        background=np.array(scene.background, np.float64),
        # Compile-time variants: drop the arithmetic a scene does not need.
        spec_on=bool(np.any(geo.materials[:, 6:9] > 0)),
        att_on=bool(np.any((lkind == 0) & (latt != 0))),
    )


def resolve_methods(scene, shading) -> np.ndarray:
    """Per-model method codes from a name or one name per model.

    Parameters
    ----------
    shading : str or sequence of str
        ``"flat"``, ``"gouraud"`` or ``"phong"`` for every model, or one of
        those per model (in ``scene.models`` order).

    Returns
    -------
    (G,) int8
        0 flat, 1 Gouraud, 2 Phong.
    """
    n = len(scene.models)
    if isinstance(shading, str):
        names = [shading] * n
    else:
        try:
            names = list(shading)
        except TypeError:
            raise ValueError(
                f"shading: expected one of {list(SHADINGS) + ['auto']} or one per model, got {shading!r}"
            ) from None
        if len(names) != n:
            raise ValueError(f"shading: expected {n} methods (one per model), got {len(names)}")
    codes = np.empty(n, np.int8)
    for i, name in enumerate(names):
        if not isinstance(name, str) or name.lower() not in METHODS:
            where = "shading" if isinstance(shading, str) else f"shading[{i}]"
            raise ValueError(f"{where}: expected one of {list(SHADINGS)}, got {name!r}")
        codes[i] = METHODS[name.lower()]
    return codes


def shade(scene, camera, hits, shading="phong") -> np.ndarray:
    """Shade a hit buffer.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    hits : HitBuffer
    shading : {"flat", "gouraud", "phong"} or sequence of them
        One method for all models, or one per model.

    Returns
    -------
    image : (H, W, 3) float32
        Linear RGB; ``scene.background`` where nothing was hit.

    Raises
    ------
    TypeError, ValueError
        For a hit buffer that does not fit the scene
        (:func:`~raycast_shade.hits.check_hits`), before any kernel runs.
    """
    _check_inputs(scene, camera, hits)
    return shade_hits(scene, camera, hits, shading)


def _check_inputs(scene, camera, hits) -> None:
    """Types, and a hit buffer whose indices fit the scene. Any shape of buffer is
    fine (the camera supplies the eye, not pixel positions); its indices are not."""
    from ..scene.camera import Camera
    from ..scene.scene import Scene

    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    if not isinstance(camera, Camera):
        raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
    check_hits(hits, scene.geometry)


def shade_hits(scene, camera, hits, shading="phong") -> np.ndarray:
    """:func:`shade` without the hit-buffer check, for buffers made by this package's casters and
    rasterizer (valid by construction; a hand-made buffer with bad indices would crash a kernel)."""
    modes = resolve_methods(scene, shading)
    k = kernel_inputs(scene, camera)
    kern = _kernels(k)
    geo = scene.geometry
    h, w = hits.shape
    image = np.empty((h, w, 3), np.float32)
    flat, gouraud = bool(np.any(modes == 0)), bool(np.any(modes == 1))
    if flat or gouraud:
        face_flags = np.zeros(len(geo.faces) if flat else 1, np.uint8)
        vertex_flags = np.zeros(len(geo.vertices) if gouraud else 1, np.uint8)
        _visible_kernel(hits.prim, hits.geom, geo.faces, k["face_off"], modes, face_flags, vertex_flags)
    # Each pixel kernel writes only the pixels of its own method's models
    # (and the background), so a mixed frame runs just the kernels it needs.
    if flat:
        fcol = np.zeros((len(geo.faces), 3), np.float64)
        kern["faces"](face_flags, geo.vertices, geo.faces, geo.face_normals, geo.face_model, k["materials"],
                      k["cam"], k["L"], fcol)
        _lookup_flat_kernel(hits.prim, hits.geom, k["face_off"], fcol, k["background"], modes, image)
    if gouraud:
        vcol = np.zeros((len(geo.vertices), 2, 3), np.float64)
        kern["vertices"](vertex_flags, geo.vertices, geo.normals, geo.vertex_model, k["materials"], k["cam"],
                         k["L"], vcol)
        kern["gouraud"](hits.prim, hits.geom, hits.u, hits.v, geo.vertices, geo.normals, geo.faces,
                        geo.face_normals, k["face_off"], k["materials"], k["cam"], k["L"], k["background"], modes,
                        vcol, image)
    if np.any(modes == 2):
        kern["phong"](hits.prim, hits.geom, hits.u, hits.v, k["G"], k["B"], k["L"], k["face_off"], k["materials"],
                      k["cam"], k["background"], modes, image)
    return image


def shading_normals(scene, camera, hits, shading="phong") -> np.ndarray:
    """The normal each pixel is shaded with.

    Parameters
    ----------
    shading : {"flat", "gouraud", "phong"} or sequence of them (one per model)

    Returns
    -------
    (H, W, 3) float32
        Unit normals turned to the viewer (flat: the face normal; otherwise
        the interpolated, renormalised vertex normal, bumped in Phong mode);
        zero on the background.

    Raises
    ------
    TypeError, ValueError
        As :func:`shade`, before any kernel runs.
    """
    _check_inputs(scene, camera, hits)
    modes = resolve_methods(scene, shading)
    geo = scene.geometry
    from ..visibility.rays import camera_frame

    # Bumps only apply where the normal is per pixel.
    bump_index = np.where(modes == 2, geo.bump_index, -1).astype(np.int32)
    B = (geo.uvs, geo.tangents, bump_index, geo.bump_texels, geo.bump_info)
    nbuf = np.empty(hits.shape + (3,), np.float32)
    _normals_kernel(hits.prim, hits.geom, hits.u, hits.v, (geo.vertices, geo.normals, geo.faces, geo.face_normals),
                    B, geo.face_offsets, camera_frame(camera, geo.origin), modes, nbuf)
    return nbuf


def trace_mirrors(scene, camera, hits, image, max_depth: int = 3) -> np.ndarray:
    """Blend mirror reflections into a shaded image.

    Each reflective pixel becomes ``(1 - rho) local + rho reflected``, the
    reflected colour traced recursively (Phong-shaded at every bounce, seen
    along the bouncing ray) to ``max_depth`` bounces; the last bounce shows
    its local shade. ``max_depth=0`` is the same image as no mirror at all.

    Parameters
    ----------
    image : (H, W, 3) float32
        Local shading of ``hits``; updated in place and returned.
    """
    geo = scene.geometry
    if max_depth <= 0 or not geo.reflective:
        return image
    from ..visibility.cast import cast_rays_kernel

    k = kernel_inputs(scene, camera)
    points_kernel = _kernels(k)["points"]
    h, w = hits.shape
    counts = np.empty(h, np.int64)
    _mirror_rows_kernel(hits.prim, hits.geom, k["materials"], counts)
    starts = np.zeros(h + 1, np.int64)
    np.cumsum(counts, out=starts[1:])
    m = int(starts[-1])
    idx = np.empty(m, np.int64)
    origins = np.empty((m, 3))
    dirs = np.empty((m, 3))
    _reflect_primary_kernel(hits.prim, hits.geom, hits.u, hits.v, k["G"], k["B"], k["face_off"], k["materials"],
                            k["cam"], float(geo.scale), starts, idx, origins, dirs)
    flat = image.reshape(-1, 3)
    rho = geo.materials[hits.geom.reshape(-1)[idx], 11]
    flat[idx] *= (1.0 - rho)[:, None].astype(np.float32)
    weight = rho
    accel = embree_accel(geo).handle
    for depth in range(1, max_depth + 1):
        m = len(idx)
        if m == 0:
            break
        prim = np.empty(m, np.int32)
        gm = np.empty(m, np.int32)
        u = np.empty(m, np.float32)
        v = np.empty(m, np.float32)
        t = np.empty(m, np.float32)
        cast_rays_kernel(accel, origins, dirs, np.zeros(m), np.full(m, np.inf), prim, gm, u, v, t)
        colour = np.empty((m, 3))
        next_o = np.empty((m, 3))
        next_d = np.empty((m, 3))
        more = np.empty(m, np.bool_)
        points_kernel(prim, gm, u, v, dirs, k["G"], k["B"], k["L"], k["face_off"], k["materials"], k["cam"],
                      k["background"], depth == max_depth, colour, next_o, next_d, more)
        flat[idx] = np.minimum(flat[idx] + weight[:, None] * colour, _FLT32_MAX).astype(np.float32)
        weight = weight[more] * geo.materials[gm[more], 11]
        idx, origins, dirs = idx[more], next_o[more], next_d[more]
    return image
