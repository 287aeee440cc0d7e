"""Repair of camera pixels whose ray slipped through a shared vertex.

A ray that slips through a vertex leaves one of two marks in the image: a
miss between two hits (left and right, or above and below), or a hit
farther than both of them by more than ``_JUMP`` of their depth (it saw the
far side, or the floor behind). Only such pixels are re-tested: four rays
through points ``1e-3`` pixel from the centre find the nearer surface (its
candidate triangle), then the pixel's own ray is tested exactly against the
triangles around it (:func:`.watertight.refine`); a second round at ``1e-2``
pixel takes what the first left. The exact hit is kept when nearer than the
pixel's own by more than ``watertight.MARGIN``; a miss that finds no exact
hit takes the nearest jittered one (moved by at most a hundredth of a
pixel). The camera kernel counts them row by row while it casts (each row
once it and its neighbours are cast, :func:`row_suspicious`; the rows at its
block boundaries are finished serially, :func:`finish_counts`), so a frame
with no such pixel pays no pass of its own. A band (or frame) with a few -- fewer than
:data:`.cast.SERIAL_BELOW` jittered rays, four a pixel, as the noisy sphere's 13-18 silhouette
gaps -- is repaired by one serial kernel (:func:`_repair_serial`: the gather, both rounds' casts
and exact re-tests), with no parallel launch and no NumPy step; more take, per round, one cast of
their jittered rays and one exact re-test over NumPy arrays. The same hits either way, bit for bit.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from ..common.inline import inline_jit

from ..common.parallel import KERNEL, SERIAL, in_parts, share
from ..common.layout import CAM_EYE, CAM_FORWARD, CAM_HEIGHT, CAM_ORTHO, CAM_RIGHT, CAM_UP, CAM_WIDTH
from . import embree
from .alpha import masked_geometries
from .hits import HitBuffer
from .watertight import MARGIN, _refine_kernel, refine, vertex_fans

__all__ = ["fill_holes", "rays_at", "row_suspicious", "finish_counts"]


_JITTER = (1e-3, 1e-2)  # pixels: the re-cast rays' distance from the pixel centre, per round
_JUMP = 1e-3  # a hit farther than both neighbours by this fraction of their depth is re-tested


_refine_compiled = _refine_kernel.kernel  # called from compiled code, whole (SERIAL): a few rays


# LLVM-inlined per pixel (Numba's own inlining copied its IR into each caller)
@inline_jit(cache=True, forceinline=True, _nrt=False)
def _suspicious(prim, t, jump, y, x):
    """A miss between two hits, or a hit farther than both of them by ``jump`` of
    their depth: the two marks a ray leaves when it slips through a vertex."""
    h, w = prim.shape
    far = 1.0 + jump
    if 0 < x < w - 1 and prim[y, x - 1] >= 0 and prim[y, x + 1] >= 0:
        if prim[y, x] < 0 or (t[y, x] > far * t[y, x - 1] and t[y, x] > far * t[y, x + 1]):
            return True
    if 0 < y < h - 1 and prim[y - 1, x] >= 0 and prim[y + 1, x] >= 0:
        if prim[y, x] < 0 or (t[y, x] > far * t[y - 1, x] and t[y, x] > far * t[y + 1, x]):
            return True
    return False


@inline_jit(cache=True, forceinline=True, _nrt=False)  # LLVM-inlined into the camera kernel
def row_suspicious(prim, t, far, y):
    """How many pixels of row ``y`` :func:`_suspicious` flags (``far = 1 + jump``): the same
    test, written without branches over the row's interior so that it vectorises. The camera
    kernel runs it on each row as soon as the row and its neighbours are cast."""
    h, w = prim.shape
    vert = 0 < y < h - 1
    up = y - 1 if vert else y
    dn = y + 1 if vert else y
    n = 0
    for x in range(1, w - 1):
        miss = prim[y, x] < 0
        tx = t[y, x]
        side = (prim[y, x - 1] >= 0) & (prim[y, x + 1] >= 0) & (miss | ((tx > far * t[y, x - 1])
                                                                       & (tx > far * t[y, x + 1])))
        over = (prim[up, x] >= 0) & (prim[dn, x] >= 0) & (miss | ((tx > far * t[up, x]) & (tx > far * t[dn, x])))
        n += side | (vert & over)
    if vert:  # the first and last columns have no left or right neighbour: the vertical test alone
        for x in range(0, w, max(1, w - 1)):
            if prim[up, x] >= 0 and prim[dn, x] >= 0:
                tx = t[y, x]
                if prim[y, x] < 0 or (tx > far * t[up, x] and tx > far * t[dn, x]):
                    n += 1
    return n


@njit(cache=True, no_cfunc_wrapper=True)  # serial: a few rows per band
def finish_counts(prim, t, far, counts, lo, hi):
    """Count the rows ``lo .. hi`` the camera kernel left undecided (``counts[q] < 0``: rows
    at its block boundaries), in place; see :func:`row_suspicious`."""
    for q in range(lo, hi):
        if counts[q] < 0:
            counts[q] = row_suspicious(prim, t, far, q)


def _suspicious_rows_kernel(prim, t, jump):
    """(H,) int64: how many pixels of each row :func:`_suspicious` flags. Nearly
    every frame has none, so the caster asks this parallel count first (about
    2 ms at 1080p); the rows tell :func:`_gather_kernel` where to look."""
    rows = np.zeros(prim.shape[0], np.int64)
    _suspicious_rows_parts(prim, t, jump, rows)
    return rows


@in_parts
@njit(**KERNEL)
def _suspicious_rows_parts(prim, t, jump, rows, part):
    """:func:`_suspicious_rows_kernel` for this part's rows, into ``rows``."""
    h, w = prim.shape
    y0, y1 = share(h, part)
    for y in range(y0, y1):
        row = 0
        for x in range(w):
            if _suspicious(prim, t, jump, y, x):
                row += 1
        rows[y] = row


# Serial: it reads only the rows that have a flag, a parallel launch would cost more.
@njit(cache=True, no_cfunc_wrapper=True)
def _gather_kernel(prim, t, jump, rows, ys, xs):
    """The flagged pixels' ``ys``, ``xs`` (n,) int64 in row-major order, as ``np.nonzero``
    of the mask of :func:`_suspicious` gives them."""
    k = 0
    for y in range(prim.shape[0]):
        if rows[y] == 0:
            continue
        for x in range(prim.shape[1]):
            if _suspicious(prim, t, jump, y, x):
                ys[k] = y
                xs[k] = x
                k += 1


def rays_at(cam, xs, ys):
    """Float64 rays through the image points (xs + 0.5, ys + 0.5), as
    :func:`.rays.pixel_ray` does for pixel centres."""
    eye, right = cam[CAM_EYE:CAM_EYE + 3], cam[CAM_RIGHT:CAM_RIGHT + 3]
    up, fwd = cam[CAM_UP:CAM_UP + 3], cam[CAM_FORWARD:CAM_FORWARD + 3]
    sx = (2.0 * (xs + 0.5) / cam[CAM_WIDTH] - 1.0)[:, None]
    sy = (1.0 - 2.0 * (ys + 0.5) / cam[CAM_HEIGHT])[:, None]
    if cam[CAM_ORTHO] != 0.0:
        o = eye + sx * right + sy * up
        d = np.broadcast_to(fwd, o.shape)
    else:
        d = fwd + sx * right + sy * up
        d = d / np.linalg.norm(d, axis=1, keepdims=True)
        o = np.broadcast_to(eye, d.shape)
    return np.ascontiguousarray(o), np.ascontiguousarray(d)


@njit(cache=True, inline="always")
def _ray_at(cam, x, y, o, d):
    """:func:`rays_at`'s ray through the image point (x + 0.5, y + 0.5) into ``o``, ``d`` (3,)
    float64, operation for operation (the norm summed left to right, as NumPy's is), so the
    same bits."""
    sx = 2.0 * (x + 0.5) / cam[CAM_WIDTH] - 1.0
    sy = 1.0 - 2.0 * (y + 0.5) / cam[CAM_HEIGHT]
    for c in range(3):
        if cam[CAM_ORTHO] != 0.0:
            o[c] = cam[CAM_EYE + c] + sx * cam[CAM_RIGHT + c] + sy * cam[CAM_UP + c]
            d[c] = cam[CAM_FORWARD + c]
        else:
            o[c] = cam[CAM_EYE + c]
            d[c] = cam[CAM_FORWARD + c] + sx * cam[CAM_RIGHT + c] + sy * cam[CAM_UP + c]
    if cam[CAM_ORTHO] == 0.0:
        norm = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        for c in range(3):
            d[c] = d[c] / norm


@njit(cache=True)  # serial: a few pixels a band; one call instead of a dozen NumPy steps and launches
def _repair_serial(scene, cam, fans, hits, rows, y0, jump, jitters, margin):
    """:func:`fill_holes`'s repair of the flagged pixels of ``rows`` (their count per row, zero
    outside the band), step for step, in one serial call: the gather, then per jitter round
    each pixel's four jittered rays cast one by one (as :func:`.cast.cast_rays_serial` does),
    the exact re-test (:func:`.watertight.refine` without its alpha filters: the caller has
    none) and the same choice of hit. ``scene`` is the Embree handle; ``fans`` the
    :class:`.watertight.VertexFans` arrays; ``hits`` the window's (R, W) arrays, updated in place."""
    prim, geom, u, v, t = hits
    n = 0
    for q in range(rows.shape[0]):
        n += rows[q]
    ys, xs = np.empty(n, np.int64), np.empty(n, np.int64)
    _gather_kernel(prim, t, jump, rows, ys, xs)
    buf = np.empty(embree.RAYHIT_SLOTS + 4, np.float32)
    off = ((16 - buf.ctypes.data % 16) % 16) // 4  # RTCRayHit is 16-byte aligned
    ib = buf.view(np.uint32)
    ray = buf[off:]
    for jitter in jitters:
        if n == 0:
            return
        m = 4 * n
        o, d = np.empty((m, 3)), np.empty((m, 3))
        t0, limit = np.empty(n), np.empty(m)
        cg, cp = np.empty(m, np.int32), np.empty(m, np.int32)
        cu, cv, ct = np.empty(m, np.float32), np.empty(m, np.float32), np.empty(m, np.float32)
        cand = np.empty(m, np.bool_)
        jo, jd = np.empty(3), np.empty(3)
        for i in range(n):
            t0[i] = np.float64(t[ys[i], xs[i]])
            lim = t0[i] * (1.0 - margin) if np.isfinite(t0[i]) else np.inf
            _ray_at(cam, xs[i], ys[i] + y0, o[i], d[i])  # the pixel's own ray, re-tested exactly
            for k in range(4):  # the jitters' order of fill_holes: (+,+), (-,+), (+,-), (-,-)
                j = k * n + i
                if k:
                    for c in range(3):  # by element: a row assignment compiles Numba's shape-error path
                        o[j, c] = o[i, c]
                        d[j, c] = d[i, c]
                limit[j] = lim
                jx = jitter if k % 2 == 0 else -jitter
                jy = jitter if k < 2 else -jitter
                _ray_at(cam, xs[i] + jx, ys[i] + y0 + jy, jo, jd)
                embree.write_ray(buf, ib, off, np.int64(1), (jo[0], jo[1], jo[2]), (jd[0], jd[1], jd[2]), 0.0, np.inf)
                embree.reset_hit(ib, off, np.int64(1))
                embree.intersect1_ray(scene, ray)
                g, p, hu, hv, ht = embree.read_hit(buf, ib, off, np.int64(1))
                cand[j] = ht < limit[j]  # a surface in front of the pixel's hit: its fan is re-tested
                if cand[j]:
                    cg[j], cp[j], cu[j], cv[j], ct[j] = g, p, hu, hv, ht
                else:
                    cg[j], cp[j], cu[j], cv[j], ct[j] = -1, -1, 0.0, 0.0, np.inf
        fp, fg = np.empty(m, np.int32), np.empty(m, np.int32)
        fu, fv, ft = np.empty(m, np.float32), np.empty(m, np.float32), np.empty(m, np.float32)
        _refine_compiled(fans, (o, d, np.zeros(m), limit), (cg, cp), (fp, fg, fu, fv, ft), SERIAL)
        k = 0
        for i in range(n):
            eg, ep, eu, ev, et = -1, -1, np.float32(0.0), np.float32(0.0), np.float32(np.inf)
            mg, mp, mu, mv, mt = -1, -1, np.float32(0.0), np.float32(0.0), np.float32(np.inf)
            for r in range(4):  # in the jitters' order: ties keep the earlier one
                j = r * n + i
                if cand[j] and fg[j] >= 0 and ft[j] < et:
                    eg, ep, eu, ev, et = fg[j], fp[j], fu[j], fv[j], ft[j]
                if cand[j] and cg[j] >= 0 and ct[j] < mt:
                    mg, mp, mu, mv, mt = cg[j], cp[j], cu[j], cv[j], ct[j]
            y, x = ys[i], xs[i]
            if eg >= 0:  # the exact hit where there is one; else, for a miss only, the nearest jittered hit
                geom[y, x], prim[y, x], u[y, x], v[y, x], t[y, x] = eg, ep, eu, ev, et
            elif mg >= 0 and not np.isfinite(t0[i]):
                geom[y, x], prim[y, x], u[y, x], v[y, x], t[y, x] = mg, mp, mu, mv, mt
            else:  # left for the next round
                ys[k], xs[k] = y, x
                k += 1
        n = k


def empty_hits(n: int) -> HitBuffer:
    """(n,) misses."""
    return HitBuffer(prim=np.full(n, -1, np.int32), geom=np.full(n, -1, np.int32), u=np.zeros(n, np.float32),
                     v=np.zeros(n, np.float32), t=np.full(n, np.inf, np.float32))


def _keep_nearer(best: HitBuffer, new: HitBuffer, where) -> None:
    """``best[i] = new[i]`` where ``where[i]`` and ``new`` is nearer (in place)."""
    take = where & (new.geom >= 0) & (new.t < best.t)
    for arr, src in zip(best, new):
        arr[take] = src[take]


def _rows(hits: HitBuffer, sel) -> HitBuffer:
    return HitBuffer(*(a[sel] for a in hits))


def fill_holes(geometry, cam, hits, cast_points, rows=None, y0=0, counts=None, scene=None, serial_below=0):
    """Re-test the suspicious pixels (see the module docstring); updates ``hits`` in place.

    Each round casts the four jittered rays of every pixel in one call of
    ``cast_points`` and re-tests them in one :func:`.watertight.refine`: a
    frame with a few suspicious pixels pays two short launches per round, not
    eight. Rays are independent, so the hits are those of one call per jitter.

    Parameters
    ----------
    hits : HitBuffer of (R, W) arrays
        The image's rows ``y0 .. y0 + R``, as cast (the test reads each pixel's
        neighbours as cast, so no row may have been repaired yet).
    cast_points : callable
        ``cast_points(xs, ys)``: the hits of the rays through image points.
    rows : (lo, hi), optional
        Repair only the rows ``lo .. hi`` of ``hits`` (a band, whose rows
        outside it are only neighbours); all of them by default.
    y0 : int
        The image row of ``hits``'s row 0. A band's top and bottom rows are
        image borders only when they are the image's: ``hits`` then starts or
        ends there.
    counts : (R,) int64, optional
        The suspicious pixels of each row of ``rows`` as the camera kernel
        counted them while casting (``-1`` for a row it left: finished here);
        without it, a parallel pass counts them.
    scene : int, optional
        The Embree handle ``cast_points`` casts with (direct binding). With it, fewer
        than ``serial_below`` jittered rays (four a pixel) and no alpha-masked model,
        the whole repair runs as one serial kernel (:func:`_repair_serial`): the same
        hits, bit for bit, without a parallel launch or a NumPy step per round.
    serial_below : int
        See ``scene``.
    """
    if not _JITTER:
        return
    lo, hi = (0, hits.prim.shape[0]) if rows is None else rows
    if counts is None:
        rows = _suspicious_rows_kernel(hits.prim, hits.t, _JUMP)
    else:  # the camera kernel's counts: finish the rows it left, at its block boundaries
        finish_counts(hits.prim, hits.t, 1.0 + _JUMP, counts, lo, hi)
        rows = counts.copy()
    rows[:lo] = 0
    rows[hi:] = 0
    n = int(rows.sum())
    if n == 0:
        return
    if scene is not None and 4 * n < serial_below and not masked_geometries(geometry):
        f = vertex_fans(geometry)
        _repair_serial(scene, cam, (f.vertices, f.faces, f.points, f.face_model, f.face_offsets, f.start, f.around),
                       tuple(hits), rows, y0, _JUMP, np.array(_JITTER, np.float64), MARGIN)
        return
    ys, xs = np.empty(n, np.int64), np.empty(n, np.int64)
    _gather_kernel(hits.prim, hits.t, _JUMP, rows, ys, xs)
    for jitter in _JITTER:
        if len(ys) == 0:
            return
        n = len(ys)
        o, d = rays_at(cam, xs, ys + y0)  # the pixels' own rays, re-tested exactly
        t0 = hits.t[ys, xs].astype(np.float64)
        limit = np.where(np.isfinite(t0), t0 * (1.0 - MARGIN), np.inf)
        offsets = ((jitter, jitter), (-jitter, jitter), (jitter, -jitter), (-jitter, -jitter))
        near = cast_points(np.concatenate([xs + jx for jx, _ in offsets]),
                           np.concatenate([ys + y0 + jy for _, jy in offsets]))
        limit4 = np.tile(limit, 4)
        cand = near.t < limit4  # a surface in front of the pixel's hit: its fan is re-tested
        fills = (-1, -1, 0, 0, np.inf)
        near = HitBuffer(*(np.where(cand, a, fill).astype(a.dtype) for a, fill in zip(near, fills)))
        found = refine(geometry, np.tile(o, (4, 1)), np.tile(d, (4, 1)), np.zeros(4 * n), limit4, near)
        exact, moved = empty_hits(n), empty_hits(n)
        for k in range(4):  # in the jitters' order: ties keep the earlier one
            part = slice(k * n, (k + 1) * n)
            _keep_nearer(exact, _rows(found, part), cand[part])
            _keep_nearer(moved, _rows(near, part), cand[part])
        # The exact hit where there is one; else, for a miss only, the nearest jittered hit.
        ok = exact.geom >= 0
        fall = ~ok & (moved.geom >= 0) & ~np.isfinite(t0)
        for arr, a, b in zip(hits, exact, moved):
            arr[ys[ok], xs[ok]] = a[ok]
            arr[ys[fall], xs[fall]] = b[fall]
        left = ~(ok | fall)
        ys, xs = ys[left], xs[left]
