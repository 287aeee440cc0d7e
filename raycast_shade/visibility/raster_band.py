"""The rasterizer's band kernel: the z-buffer of a band of rows, and the resolve of its winners.

The driver is :mod:`.raster`; the per-triangle scan, clipping and depth planes are in :mod:`.scan`.

Two passes, and a coarse depth test in between
---------------------------------------------
The depth test keeps, per pixel, the nearest fragment and among equally near ones the lower
face index (:func:`.scan._scan_triangle`): a lexicographic minimum, so the order the faces
are drawn in changes no pixel. The kernel uses that freedom. It first draws the faces that
face the eye (by their screen winding, set in :func:`.scan._setup_par`) and the clipped ones;
then, per tile of ``TILE`` columns of the band, it takes the largest depth key left in the
z-buffer (``inf`` where a pixel is still empty). A remaining face whose nearest vertex key is
beyond the largest key of every tile its box touches cannot win a pixel there (its keys are
clamped to its vertices' range, so each fragment is strictly behind the pixel's entry) and is
skipped whole. On a closed mesh that is most of the faces turned away: the pixels drawn, the
winners and the hit buffer are those of a single pass, bit for bit, at about half the scan.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..common.parallel import KERNEL, in_parts, share
from .hits import convex_uv
from .scan import _clip, _pixel_range, _plane3d, _scan_triangle

TILE = 16  # columns of a tile of the coarse depth test (a band's rows high)


@njit(cache=True, _nrt=False)
def _tile_max(zbuf, tmax, col):
    """``tmax[j]``: the largest entry of the band's z-buffer in columns ``j TILE .. (j + 1) TILE - 1``.
    ``col`` (``W``,) is scratch: first each column's largest over the rows, a select per entry that
    LLVM vectorises (no reduction), then each tile's over its columns (entries are never NaN)."""
    rows, w = zbuf.shape
    for x in range(w):
        col[x] = zbuf[0, x]
    for r in range(1, rows):
        for x in range(w):
            z = zbuf[r, x]
            col[x] = z if z > col[x] else col[x]
    for j in range(tmax.shape[0]):
        m = -np.inf
        for x in range(j * TILE, min(w, (j + 1) * TILE)):
            if col[x] > m:
                m = col[x]
        tmax[j] = m


@njit(cache=True, _nrt=False, forceinline=True)  # inlined by LLVM: no references counted
def _behind(tmax, x0, x1, x2, kmin, W):
    """True when no fragment of a face with these vertex ``X`` and nearest key ``kmin`` can
    pass the depth test in the band: ``kmin`` exceeds every touched tile's largest key."""
    xa, xb = _pixel_range(min(x0, x1, x2), max(x0, x1, x2), W)
    if xa > xb:
        return True
    for j in range(xa // TILE, xb // TILE + 1):
        if not kmin > tmax[j]:
            return False
    return True


@in_parts
@njit(**KERNEL)
def _raster_kernel(faces, vx, cs, near, screen, shear, bins, count_mode, face_model, face_off, count, hits, part):
    """Scan-convert every band's faces into the band's own z-buffer, then
    resolve the band's rows into the hit buffer (depth mode), or count the
    covering faces (count mode). ``screen`` = ``(ortho, W, H, hw, hh)``,
    ``shear`` = ``(ox, oy)`` (see :func:`_resolve_rows`), ``bins`` =
    ``(band_h, band_start, band_tris, first)`` (band ``b``'s faces are
    ``band_tris[band_start[b]:band_start[b + 1]]``; ``first[f]`` is 1 for a face of the
    first pass), ``hits`` = the hit buffer's ``(prim, geom, u, v, t)``."""
    ortho, W, H, hw, hh = screen
    band_h, band_start, band_tris, first = bins
    nbands = band_start.shape[0] - 1
    iw = int(W)
    ih = int(H)
    tmax = np.full((iw + TILE - 1) // TILE, np.inf)
    col = np.empty(iw)
    px = np.empty(4)
    py = np.empty(4)
    pq = np.empty(4)
    # One band's z-buffer for the part's bands: the resolve empties each entry it reads.
    rows = 0 if count_mode else band_h
    fid_all = np.full((rows, iw), -1, np.int32)
    zbuf_all = np.full((rows, iw), np.inf)
    dxs, dx2 = _columns(W, hw, shear[0])
    terms, flags = resolve_scratch()
    blo, bhi = share(nbands, part)  # this part's bands (common.parallel)
    most = 0
    for b in range(blo, bhi):
        most = max(most, band_start[b + 1] - band_start[b])
    later = np.empty(most, np.int32)  # a band's faces of the second pass, set aside by the first
    for b in range(blo, bhi):
        rlo = b * band_h
        rhi = min(ih, rlo + band_h) - 1
        fid = fid_all[:rhi - rlo + 1]
        zbuf = zbuf_all[:rhi - rlo + 1]
        # Depth mode: faces of the first pass, then the others behind the coarse test; count
        # mode has no depth test: one pass, every face.
        nlater = 0
        for ps in range(1 if count_mode else 2):
            if ps == 1:
                _tile_max(zbuf, tmax, col)
            for k in range(band_start[b] if ps == 0 else 0, band_start[b + 1] if ps == 0 else nlater):
                if ps == 0:
                    f = band_tris[k]
                    if not count_mode and first[f] == 0:
                        later[nlater] = f
                        nlater += 1
                        continue
                else:
                    f = later[k]
                i0 = faces[f, 0]
                i1 = faces[f, 1]
                i2 = faces[f, 2]
                if vx[i0, 2] > near and vx[i1, 2] > near and vx[i2, 2] > near:
                    if ps == 1 and _behind(tmax, vx[i0, 0], vx[i1, 0], vx[i2, 0],
                                           min(vx[i0, 3], vx[i1, 3], vx[i2, 3]), W):
                        continue
                    _scan_triangle(((vx[i0, 0], vx[i0, 1], vx[i0, 3]), (vx[i1, 0], vx[i1, 1], vx[i1, 3]),
                                    (vx[i2, 0], vx[i2, 1], vx[i2, 3])), rlo, rhi, W, f, (False, 0.0, 0.0, 0.0),
                                   fid, zbuf, count, count_mode)
                    continue
                n = _clip(faces, vx, cs, f, near, ortho, W, H, hw, hh, px, py, pq)
                zA = 0.0
                zB = 0.0
                zC = 0.0
                if not count_mode:
                    # Clip points may lie far off screen: take the depth plane from
                    # the triangle itself, not from the clipped polygon.
                    zA, zB, zC, ok = _plane3d(faces, cs, f, ortho, W, H, hw, hh)
                    if not ok:
                        continue
                for j in range(1, n - 1):
                    _scan_triangle(((px[0], py[0], pq[0]), (px[j], py[j], pq[j]),
                                    (px[j + 1], py[j + 1], pq[j + 1])),
                                   rlo, rhi, W, f, (True, zA, zB, zC), fid, zbuf, count, count_mode)
        if not count_mode:
            _resolve_rows((fid, zbuf, dxs, dx2, terms, flags), rlo, faces, cs, face_model, face_off, screen, shear, hits)


@njit(cache=True)
def _columns(W, hw, ox):
    """Per column ``x``: the ray's ``dx = sx hw`` (``sx`` = ``2 (x + 0.5) / W - 1``) and
    ``(dx + ox)**2``, the resolve's per-pixel terms that depend on ``x`` alone (the same
    operations, so the same bits, as computing them at every pixel)."""
    iw = int(W)
    dxs = np.empty(iw)
    dx2 = np.empty(iw)
    for x in range(iw):
        sx = 2.0 * (x + 0.5) / W - 1.0
        dxs[x] = sx * hw
        dx2[x] = (dxs[x] + ox) * (dxs[x] + ox)
    return dxs, dx2


@njit(cache=True, _nrt=False, error_model="numpy")
def _resolve_rows(band, rlo, faces, cs, face_model, face_off, screen, shear, hits):
    """Barycentrics and distance of each pixel's ray on its winning face, for
    the rows ``rlo ..`` of a band, into ``hits`` = ``(prim, geom, u, v, t)``.
    ``band`` = ``(fid, zbuf, dxs, dx2, terms, flags)``: the band's winners and z-buffer (both
    reset to empty, for the next band), :func:`_columns` and :func:`resolve_scratch`.
    ``screen`` = ``(ortho, W, H, hw, hh)``; ``shear`` = ``(ox, oy)``: the perspective
    principal-point shear of camera space (zero without intrinsics), undone in the ray length
    that turns ``z`` into ``t``. A perspective camera's pixels go through
    :func:`_resolve_perspective`; an orthographic one's (every ray along ``+z``, from its pixel),
    one at a time, through the loop below."""
    if not screen[0]:
        _resolve_perspective(band, rlo, faces, cs, face_model, face_off, screen, shear, hits)
        return
    _, W, H, hw, hh = screen
    prim, geom, u, v, t = hits
    fid, zbuf, dxs, _, _, _ = band
    last = -1  # the face whose set-up below is current: neighbouring pixels mostly share their face
    p0x = p0y = p0z = nx = ny = nz = 0.0
    e1x = e1y = e1z = e2x = e2y = e2z = 0.0
    for r in range(fid.shape[0]):
        y = rlo + r
        sy = 1.0 - 2.0 * (y + 0.5) / H
        dyr = sy * hh  # the row's ray origin y
        for x in range(fid.shape[1]):
            f = fid[r, x]
            if f < 0:
                prim[y, x] = -1
                geom[y, x] = -1
                u[y, x] = 0.0
                v[y, x] = 0.0
                t[y, x] = np.inf
                continue
            fid[r, x] = -1
            zbuf[r, x] = np.inf
            if f != last:
                # The face's terms, the same operations in the same order whether set up here or
                # reused: the results do not depend on the order the pixels come in.
                last = f
                p0x, p0y, p0z, e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz = _face_frame(faces, cs, f)
            # Ray o + s d, d = (0, 0, 1), against P0 + b1 e1 + b2 e2, with q = P0 - o.
            qx = p0x - dxs[x]
            qy = p0y - dyr
            qz = p0z
            c1x = e2y * qz - e2z * qy
            c1y = e2z * qx - e2x * qz
            c1z = e2x * qy - e2y * qx
            c2x = qy * e1z - qz * e1y
            c2y = qz * e1x - qx * e1z
            c2z = qx * e1y - qy * e1x
            qn = qx * nx + qy * ny + qz * nz
            dx = 0.0
            dy = 0.0
            dz = 1.0
            dn = dx * nx + dy * ny + dz * nz
            b1, b2, s = _solve(dn, dx * c1x + dy * c1y + dz * c1z, dx * c2x + dy * c2y + dz * c2z, qn, faces, cs, f)
            g = face_model[f]
            geom[y, x] = g
            prim[y, x] = f - face_off[g]
            # float32 rounding can take b1 + b2 past 1 again: onto the triangle as the casters store theirs
            fu, fv = convex_uv(np.float32(b1), np.float32(b2))
            u[y, x] = fu
            v[y, x] = fv
            t[y, x] = s


RUN = 256  # columns the perspective resolve takes at a time: its scratch (10 terms each) stays in L1
_NTERMS = 10


@njit(cache=True)
def resolve_scratch():
    """The perspective resolve's scratch: ``terms`` (``_NTERMS``, ``RUN``) float64 (zeros: a
    column that holds no face's terms computes on zeros, never on stray denormals) and
    ``flags`` (2, ``RUN``) uint8 (hit, redo)."""
    return np.zeros((_NTERMS, RUN)), np.zeros((2, RUN), np.uint8)


@njit(cache=True, _nrt=False, error_model="numpy")
def _resolve_perspective(band, rlo, faces, cs, face_model, face_off, screen, shear, hits):
    """:func:`_resolve_rows` for a perspective camera, in three passes over each run of ``RUN``
    columns of a row, with the very operations of a one-pixel-at-a-time loop (so the same bits; that
    loop, in Python, is the reference of ``tests/visibility/test_raster_resolve.py``).

    1. Per pixel, in order: ``prim, geom`` (a miss's ``u, v, t`` too) and the winning face's ray
       terms (set up once per run of pixels that show it), copied into ``terms``.
    2. Per hit pixel, the same operations in every pixel, which LLVM vectorises: ``d.n`` and its
       reciprocal, ``u, v``, their clamp to zero, ``t``, the float32 ``u, v``. A pixel whose
       ``d.n`` is zero, whose ``u + v`` exceeds 1, or whose float32 pair leaves the triangle is
       flagged instead (a few pixels on edges: the one-pixel loop takes another branch there).
    3. The flagged pixels, one at a time, through that loop's branches.
    The error model is NumPy's: a division by zero is never reached (``d.n == 0`` is flagged
    and redone), and Python's check of each divisor would keep the pass from vectorising."""
    ortho, W, H, hw, hh = screen
    ox, oy = shear
    prim, geom, u, v, t = hits
    fid, zbuf, dxs, dx2, terms, flags = band
    iw = fid.shape[1]
    hit = flags[0]
    redo = flags[1]
    Tnx = terms[0]
    Tny = terms[1]
    Tnz = terms[2]
    Tc1x = terms[3]
    Tc1y = terms[4]
    Tc1z = terms[5]
    Tc2x = terms[6]
    Tc2y = terms[7]
    Tc2z = terms[8]
    Tqn = terms[9]
    last = -1  # the face whose set-up below is current: neighbouring pixels mostly share their face
    g = pf = 0
    nx = ny = nz = c1x = c1y = c1z = c2x = c2y = c2z = qn = 0.0
    for r in range(fid.shape[0]):
        y = rlo + r
        sy = 1.0 - 2.0 * (y + 0.5) / H
        dyr = sy * hh  # the row's ray dy
        dy2 = (dyr + oy) * (dyr + oy)
        for x0 in range(0, iw, RUN):
            n = min(RUN, iw - x0)
            fr = fid[r, x0:x0 + n]
            pr = prim[y, x0:x0 + n]
            gr = geom[y, x0:x0 + n]
            lo = n
            hi = -1
            i = 0
            while i < n:  # 1.
                k = np.uint64(i)  # an unsigned index: no wraparound of negative indices to compute
                f = fr[k]
                if f < 0:  # a run of misses, filled at once (vectorised)
                    j = i + 1
                    while j < n and fr[np.uint64(j)] < 0:
                        j += 1
                    _fill_miss(pr[i:j], gr[i:j], u[y, x0 + i:x0 + j], v[y, x0 + i:x0 + j], t[y, x0 + i:x0 + j],
                               hit[i:j])
                    i = j
                    continue
                if f != last:  # the face's terms, once per run of pixels that show it
                    last = f
                    nx, ny, nz, c1x, c1y, c1z, c2x, c2y, c2z, qn, pf, g = _face_terms(faces, cs, face_model,
                                                                                    face_off, f)
                pr[k] = pf
                gr[k] = g
                hit[k] = 1
                Tnx[k] = nx
                Tny[k] = ny
                Tnz[k] = nz
                Tc1x[k] = c1x
                Tc1y[k] = c1y
                Tc1z[k] = c1z
                Tc2x[k] = c2x
                Tc2y[k] = c2y
                Tc2z[k] = c2z
                Tqn[k] = qn
                if lo == n:
                    lo = i
                hi = i
                i += 1
            if hi < 0:
                continue
            # 2. on views from the first to the last hit (indices from 0: LLVM sees them >= 0)
            a = x0 + lo
            b = x0 + hi + 1
            if _uvt_run((Tnx[lo:hi + 1], Tny[lo:hi + 1], Tnz[lo:hi + 1], Tc1x[lo:hi + 1], Tc1y[lo:hi + 1],
                         Tc1z[lo:hi + 1], Tc2x[lo:hi + 1], Tc2y[lo:hi + 1], Tc2z[lo:hi + 1], Tqn[lo:hi + 1]),
                        (hit[lo:hi + 1], redo[lo:hi + 1]), (dxs[a:b], dx2[a:b]), (dyr, dy2),
                        (u[y, a:b], v[y, a:b], t[y, a:b])) > 0:
                _redo(terms, redo, lo, hi, x0, y, dxs, dx2, (dyr, dy2), faces, cs, face_off, hits)
    for r in range(fid.shape[0]):  # the band's z-buffer emptied for the next band
        for x in range(iw):
            fid[r, x] = -1
            zbuf[r, x] = np.inf


@njit(cache=True, _nrt=False, error_model="numpy")  # its divisions are guarded, as in the one-pixel loop
def _redo(terms, redo, lo, hi, x0, y, dxs, dx2, ray, faces, cs, face_off, hits):
    """Pass 3 of :func:`_resolve_perspective`: the pixels ``lo .. hi`` of a run of columns from
    ``x0`` that pass 2 flagged in ``redo``, through the one-pixel loop's branches (``ray`` =
    ``(dy, dy2)`` of the row ``y``)."""
    dyr, dy2 = ray
    prim, geom, u, v, t = hits
    for i in range(lo, hi + 1):
        if redo[i] != 0:
            x = x0 + i
            gx = geom[y, x]
            f = prim[y, x] + face_off[gx]
            dx = dxs[x]
            dy = dyr
            dz = 1.0
            dn = dx * terms[0, i] + dy * terms[1, i] + dz * terms[2, i]
            b1, b2, s = _solve(dn, dx * terms[3, i] + dy * terms[4, i] + dz * terms[5, i],
                               dx * terms[6, i] + dy * terms[7, i] + dz * terms[8, i], terms[9, i], faces, cs, f)
            s *= math.sqrt(dx2[x] + dy2 + 1.0)
            fu, fv = convex_uv(np.float32(b1), np.float32(b2))
            u[y, x] = fu
            v[y, x] = fv
            t[y, x] = s


@njit(cache=True, _nrt=False, forceinline=True, error_model="numpy")  # the division is guarded
def _solve(dn, n1, n2, qn, faces, cs, f):
    """A ray against face ``f`` from its projections ``dn = d.n``, ``n1 = d.(e2 x q)``, ``n2 = d.(q x e1)``
    and ``qn = q.n``: ``(b1, b2, s) = (n1, n2, qn) / dn``, clamped onto the triangle as the casters
    store theirs; an edge-on face (``dn = 0``, which cannot win a pixel in exact arithmetic) gives its
    centre at its vertices' mean depth in camera space ``cs``. Both resolves' arithmetic, in their order."""
    if dn != 0.0:
        inv = 1.0 / dn
        b1 = n1 * inv
        b2 = n2 * inv
        s = qn * inv
    else:
        b1 = 1.0 / 3.0
        b2 = 1.0 / 3.0
        s = (cs[faces[f, 0], 2] + cs[faces[f, 1], 2] + cs[faces[f, 2], 2]) / 3.0
    if b1 < 0.0:
        b1 = 0.0
    if b2 < 0.0:
        b2 = 0.0
    sb = b1 + b2
    if sb > 1.0:
        b1 /= sb
        b2 /= sb
    return b1, b2, s


@njit(cache=True, _nrt=False, forceinline=True)
def _face_frame(faces, cs, f):
    """Face ``f`` in camera space ``cs`` (V, 3) float64: its first vertex ``P0``, its edges
    ``e1 = P1 - P0``, ``e2 = P2 - P0`` and ``n = e1 x e2``, as 12 floats (both resolves' set-up)."""
    i0 = faces[f, 0]
    i1 = faces[f, 1]
    i2 = faces[f, 2]
    p0x = cs[i0, 0]
    p0y = cs[i0, 1]
    p0z = cs[i0, 2]
    e1x = cs[i1, 0] - p0x
    e1y = cs[i1, 1] - p0y
    e1z = cs[i1, 2] - p0z
    e2x = cs[i2, 0] - p0x
    e2y = cs[i2, 1] - p0y
    e2z = cs[i2, 2] - p0z
    return (p0x, p0y, p0z, e1x, e1y, e1z, e2x, e2y, e2z,
            e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x)


@njit(cache=True, _nrt=False, forceinline=True)
def _face_terms(faces, cs, face_model, face_off, f):
    """Face ``f``'s terms for a perspective ray ``s d`` (``q = P0 - o = P0``: the crosses with ``q``
    are the face's too): ``n = e1 x e2``, ``e2 x q``, ``q x e1``, ``q.n``, then ``prim`` (local to
    its model) and ``geom``; the one-pixel loop's operations, in its order."""
    p0x, p0y, p0z, e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz = _face_frame(faces, cs, f)
    g = face_model[f]
    return (nx, ny, nz, e2y * p0z - e2z * p0y, e2z * p0x - e2x * p0z, e2x * p0y - e2y * p0x,
            p0y * e1z - p0z * e1y, p0z * e1x - p0x * e1z, p0x * e1y - p0y * e1x, p0x * nx + p0y * ny + p0z * nz,
            f - face_off[g], g)


@njit(cache=True, _nrt=False, forceinline=True)
def _fill_miss(prim, geom, u, v, t, hit):
    """A run of pixels that no face covers: the hit buffer's miss."""
    for i in range(hit.shape[0]):
        prim[i] = -1
        geom[i] = -1
        u[i] = 0.0
        v[i] = 0.0
        t[i] = np.inf
        hit[i] = 0


@njit(cache=True, _nrt=False, error_model="numpy", forceinline=True)
def _uvt_run(terms, flags, cols, ray, out):
    """Pass 2 of :func:`_resolve_perspective` over one run of columns: the one-pixel loop's
    operations without its branches (selects instead), ``redo`` set where a branch would differ.
    ``terms`` = the ten face-term rows, ``flags`` = ``(hit, redo)``, ``cols`` = ``(dxs, dx2)``,
    ``ray`` = ``(dy, dy2)``, ``out`` = ``(u, v, t)``, all views of the run. Returns how many
    pixels are flagged."""
    nx, ny, nz, c1x, c1y, c1z, c2x, c2y, c2z, qn = terms
    hit, redo = flags
    dxs, dx2 = cols
    dy, dy2 = ray
    u, v, t = out
    nredo = 0
    for i in range(hit.shape[0]):
        dx = dxs[i]
        dz = 1.0
        dn = dx * nx[i] + dy * ny[i] + dz * nz[i]
        inv = 1.0 / dn
        b1 = (dx * c1x[i] + dy * c1y[i] + dz * c1z[i]) * inv
        b2 = (dx * c2x[i] + dy * c2y[i] + dz * c2z[i]) * inv
        s = qn[i] * inv
        b1 = 0.0 if b1 < 0.0 else b1
        b2 = 0.0 if b2 < 0.0 else b2
        sb = b1 + b2
        s *= math.sqrt(dx2[i] + dy2 + 1.0)
        fu = np.float32(b1)
        fv = np.float32(b2)
        a = np.float64(fu)
        c = np.float64(fv)
        # convex_uv's own test: a pair inside the triangle is stored as it is
        ok = (dn != 0.0) & (sb <= 1.0) & (a >= 0.0) & (c >= 0.0) & (a + c <= 1.0)
        h = hit[i]
        rd = 0 if ok else h
        redo[i] = rd
        nredo += rd
        u[i] = fu if h != 0 else np.float32(0.0)
        v[i] = fv if h != 0 else np.float32(0.0)
        t[i] = s if h != 0 else np.inf
    return nredo
