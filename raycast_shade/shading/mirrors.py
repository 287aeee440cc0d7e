"""Mirror reflections: rays from reflective pixels, Phong-shaded at every bounce.

A reflective pixel becomes ``(1 - rho) local + rho reflected``. Mirror rays
start from the hit pushed off the surface as shadow rays do
(:func:`~raycast_shade.shading.shadows._nudge`).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..common.layout import MAT_REFLECTIVITY
from ..common.schedule import BLOCK_ROWS, spread_step
from ..visibility.accel import embree_accel
from .inputs import prepare
from .jit import CHUNK, FLT32_MAX, HELPER, JIT, compile_variants, variant
from .phong import _shade_surface, _surface
from .records import At, reflect_into
from .shadows import _nudge, _scratch
from .texture import _point_coefficients, _row_coefficients

__all__ = ["trace_mirrors", "MAX_MIRROR_DEPTH"]

# Bounces per primary ray. A camera inside a closed perfect mirror bounces every ray that many
# times; the bound keeps such a frame finite (64 bounces of a 1080p frame: seconds, not forever).
MAX_MIRROR_DEPTH = 64
# A reflected ray whose weight (the product of the reflectivities it met) is under float32's
# resolution changes its pixel by less than one part in 2**24 of its colour: it stops.
_MIN_WEIGHT = 2.0 ** -24


@njit(**HELPER)
def _mirror_ray(hp, unit):
    """The mirror ray of shading point ``hp`` (:class:`~raycast_shade.shading.records.Hit`):
    the incoming direction ``d = -v`` reflected about ``n``, ``r = d - 2 (d.n) n``, kept above
    the geometric surface, from an origin pushed off along ``g``. Returns ``(origin, r)``."""
    vx, vy, vz = hp.v
    nx, ny, nz = hp.n
    dn = -(vx * nx + vy * ny + vz * nz)
    r = (-vx - 2.0 * dn * nx, -vy - 2.0 * dn * ny, -vz - 2.0 * dn * nz)
    r = reflect_into(r, hp.g)  # a bent shading normal sent it below the surface
    p, g = hp.p, hp.g
    return (_nudge(p[0], g[0], unit), _nudge(p[1], g[1], unit), _nudge(p[2], g[2], unit)), r


# The two blends run over the mirror pixels in place, in plain IEEE arithmetic (no fast-math:
# the NumPy expressions they replace, bit for bit, without their gathers and float64 temporaries).
@njit(parallel=True, cache=True)
def _keep_kernel(flat, idx, rho):
    """``flat[idx[j]] *= float32(1 - rho[j])``: a mirror pixel keeps ``1 - rho`` of its local shade."""
    for j in prange(len(idx)):
        keep = np.float32(1.0 - rho[j])
        for c in range(3):
            flat[idx[j], c] = flat[idx[j], c] * keep


@njit(parallel=True, cache=True)
def _add_kernel(flat, idx, weight, colour):
    """``flat[idx[j]] = float32(min(flat[idx[j]] + weight[j] colour[j], FLT32_MAX))`` in float64."""
    for j in prange(len(idx)):
        for c in range(3):
            flat[idx[j], c] = min(np.float64(flat[idx[j], c]) + weight[j] * colour[j, c], FLT32_MAX)


@njit(parallel=True, **JIT)
def _mirror_rows_kernel(prim, geom, materials, counts):
    """``counts[y]``: how many pixels of row ``y`` see a reflective surface."""
    h, w = prim.shape
    for y in prange(h):
        c = 0
        for x in range(w):
            if prim[y, x] >= 0 and materials[geom[y, x], MAT_REFLECTIVITY] > 0.0:
                c += 1
        counts[y] = c


@njit(parallel=True, **JIT)
def _reflect_primary_kernel(prim, geom, u, v, G, B, face_off, materials, cam, unit, starts, pixel, origins, dirs):
    """Mirror rays from every pixel whose surface reflects, packed: row ``y``'s
    rays go from ``starts[y]`` on (see :func:`_mirror_rows_kernel`), with
    their flat pixel index in ``pixel``. Packed arrays hold the mirror pixels
    only, not the whole image (at 1080p, 96 MB of mostly untouched memory
    that cost more in page faults than the mirror rays themselves)."""
    h, w = prim.shape
    nblk = (h + BLOCK_ROWS - 1) // BLOCK_ROWS
    step = spread_step(nblk)
    for it in prange(nblk):  # blocks of rows in a balanced order (see common.schedule)
        blk = (it * step) % nblk
        for y in range(blk * BLOCK_ROWS, min(h, (blk + 1) * BLOCK_ROWS)):
            j = starts[y]
            for x in range(w):
                p = prim[y, x]
                if p < 0:
                    continue
                gm = geom[y, x]
                if materials[gm, MAT_REFLECTIVITY] <= 0.0:
                    continue
                at = At(face_off[gm] + p, gm, np.float64(u[y, x]), np.float64(v[y, x]))
                o, r = _mirror_ray(_surface(G, B, cam, at, False, (0.0, 0.0, 0.0)), unit)
                pixel[j] = y * w + x
                for k in range(3):
                    origins[j, k] = o[k]
                    dirs[j, k] = r[k]
                j += 1


def _make_bounce(spec_on: bool, att_on: bool, tex_on: bool = False):
    """The secondary-hit kernel for one variant (see :mod:`.jit`; ``tex_on``: textured
    coefficients, sampled at level 0: a bounced ray has no pixel footprint here)."""

    @njit(parallel=True, **JIT)
    def _shade_points_kernel(rays, G, B, L, T, face_off, materials, cam, background, last, out):
        """Phong-shade secondary hits seen along their rays; emit the next mirror rays.

        ``rays`` = the hits ``(prim, geom, u, v)`` and their directions ``dirs``, (N,) and
        (N, 3); ``out`` = ``(colour, origins, next_dirs, active)``. A reflective surface keeps
        ``1 - rho`` of its local shade and passes ``rho`` on, except at the last bounce, where
        it shows its local shade.
        """
        prim, geom, u, v, dirs = rays
        colour, origins, next_dirs, active = out
        uvs = B[0]
        unit = L[4]
        n = prim.shape[0]
        nchunk = (n + CHUNK - 1) // CHUNK
        step = spread_step(nchunk)
        for it in prange(nchunk):  # chunks in a balanced order (see common.schedule)
            c = (it * step) % nchunk
            S = _scratch()
            for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
                active[i] = False
                p = prim[i]
                if p < 0:
                    for k in range(3):
                        colour[i, k] = background[k]
                    continue
                gm = geom[i]
                at = At(face_off[gm] + p, gm, np.float64(u[i]), np.float64(v[i]))
                if tex_on:
                    coef = _point_coefficients(G, uvs, at, cam, 0, 0, False, materials, T)
                else:
                    coef = _row_coefficients(materials, gm)
                rgb, hp = _shade_surface(G, B, L, S, materials, cam, at, True, (dirs[i, 0], dirs[i, 1], dirs[i, 2]),
                                         coef, spec_on, att_on)
                rho = materials[gm, MAT_REFLECTIVITY]
                keep = 1.0
                if rho > 0.0 and not last:
                    keep = 1.0 - rho
                    o, r = _mirror_ray(hp, unit)
                    for k in range(3):
                        origins[i, k] = o[k]
                        next_dirs[i, k] = r[k]
                    active[i] = True
                colour[i, 0] = keep * rgb[0]
                colour[i, 1] = keep * rgb[1]
                colour[i, 2] = keep * rgb[2]

    return _shade_points_kernel


_BOUNCE = compile_variants(_make_bounce)  # the family's registry (see .jit)


def trace_mirrors(scene, camera, hits, image, max_depth: int = 3, inputs=None) -> np.ndarray:
    """Blend mirror reflections into a shaded image.

    Each reflective pixel becomes ``(1 - rho) local + rho reflected``, the
    reflected colour traced recursively (Phong-shaded at every bounce, seen
    along the bouncing ray) to ``max_depth`` bounces; the last bounce shows
    its local shade. ``max_depth=0`` is the same image as no mirror at all.

    Parameters
    ----------
    image : (H, W, 3) float32
        Local shading of ``hits``; updated in place and returned.
    inputs : FrameInputs, optional
        The frame's packed inputs (:func:`~raycast_shade.shading.inputs.prepare`), when the
        caller has them already; packed here otherwise.
    """
    geo = scene.geometry
    if max_depth <= 0 or not geo.reflective:
        return image
    from ..visibility.cast import cast_rays_kernel

    k = prepare(scene, camera) if inputs is None else inputs
    points_kernel = variant(_BOUNCE, k)
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
    rho = geo.materials[hits.geom.reshape(-1)[idx], MAT_REFLECTIVITY]
    _keep_kernel(flat, idx, rho)
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
        points_kernel((prim, gm, u, v, dirs), k["G"], k["B"], k["L"], k["T"], k["face_off"], k["materials"], k["cam"],
                      k["background"], depth == max_depth, (colour, next_o, next_d, more))
        _add_kernel(flat, idx, weight, colour)
        weight = weight[more] * geo.materials[gm[more], MAT_REFLECTIVITY]
        idx, origins, dirs = idx[more], next_o[more], next_d[more]
        # A ray that can no longer change a float32 pixel of its own colour's size stops here.
        keep = weight >= _MIN_WEIGHT
        if not keep.all():
            weight, idx, origins, dirs = weight[keep], idx[keep], origins[keep], dirs[keep]
    return image
