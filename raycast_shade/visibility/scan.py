"""The rasterizer's scan-conversion kernels (the driver is :mod:`.raster`).

Vertex projection, per-face set-up and binning into bands, near-plane
clipping and the edge-function scan of one triangle in one band (the band's
kernel and the resolve are in :mod:`.raster_band`); the conventions (fill
rule, clipping, depth keys) are written down in :mod:`.raster`'s docstring.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..common.parallel import KERNEL, in_parts, share


_CHUNK = 4096  # faces per set-up and binning task

# ----------------------------------------------------------------------------------
# small inlined helpers


@njit(cache=True, inline="always")
def _to_screen(xc, yc, zc, ortho, W, H, hw, hh):
    """Camera space to pixel coordinates (centre of pixel (x, y) at x+.5, y+.5)."""
    if ortho:
        sx = xc / hw
        sy = yc / hh
    else:
        sx = xc / (zc * hw)
        sy = yc / (zc * hh)
    return 0.5 * W * (1.0 + sx), 0.5 * H * (1.0 - sy)


@njit(cache=True, inline="always")
def _pixel_range(lo, hi, n):
    """Indices ``i`` in ``[0, n)`` whose centre ``i + 0.5`` lies in ``[lo, hi]``
    (empty when the first exceeds the second)."""
    a = math.ceil(lo - 0.5)
    b = math.floor(hi - 0.5)
    if not a >= 0.0:
        a = 0.0
    if not b <= n - 1.0:
        b = n - 1.0
    if a > b:
        return 1, 0
    return int(a), int(b)


@njit(cache=True, inline="always")
def _top_left(dx, dy):
    """Top or left edge, for an edge direction of a triangle whose inside is
    where the edge function is positive (pixel coordinates, y down)."""
    return dy < 0.0 or (dy == 0.0 and dx > 0.0)


@njit(cache=True, inline="always")
def _edges(x0, y0, x1, y1, x2, y2):
    """Edge set-up of a triangle in pixel coordinates.

    The triangle is reordered (vertices 1 and 2 swapped if need be) so that
    its inside is where every edge function ``(a - p) x (b - p)`` is
    positive; ``tl`` says whether an edge is a top or left edge. ``ok`` is
    False for a zero-area triangle.

    Returns
    -------
    ok, then ``ax, ay, bx, by, tl`` for the edges ``0 -> 1``, ``1 -> 2``,
    ``2 -> 0`` of the reordered triangle.
    """
    area = (x0 - x2) * (y1 - y2) - (y0 - y2) * (x1 - x2)  # edge 0 -> 1 at vertex 2
    ok = area > 0.0 or area < 0.0
    if area < 0.0:
        x1, y1, x2, y2 = x2, y2, x1, y1
    return (ok, x0, y0, x1, y1, _top_left(x1 - x0, y1 - y0), x1, y1, x2, y2, _top_left(x2 - x1, y2 - y1),
            x2, y2, x0, y0, _top_left(x0 - x2, y0 - y2))


@njit(cache=True, inline="always")
def _inside(ax, ay, bx, by, tl, X, Y):
    """Pixel centre ``(X, Y)`` on the inner side of the edge ``a -> b``, or on
    the edge itself if it is a top or left edge.

    The edge function ``(a - p) x (b - p)`` is exactly antisymmetric in
    ``a, b`` (products commute, differences change sign exactly), so the two
    triangles of a shared edge compute bit-identical values of opposite
    sign, and a pixel centre on the edge goes to exactly one of them."""
    e = (ax - X) * (by - Y) - (ay - Y) * (bx - X)
    return e > 0.0 or (e == 0.0 and tl)


_EPS = 2.0 ** -52  # float64 unit roundoff, twice over: the bounds below are generous by design


@njit(cache=True)
def _edge_setup(ax, ay, bx, by, Ya, Yb, px, qx):
    """One edge's row spans over the rows ``Ya..Yb`` (pixel-centre ``Y``), once per triangle.

    The edge function ``(ax - X)(by - Y) - (ay - Y)(bx - X)`` is linear in ``X`` with slope
    ``ay - by``, and its root is linear in ``Y``: ``root(Y) = root(Ya) + (Y - Ya) dr``,
    ``dr = (ax - bx) / (ay - by)``. :func:`_inside`'s float64 value errs by at most
    ``d = 16 eps (px max|by - Y| + max|ay - Y| qx)`` over the box (``px, qx`` bound
    ``|ax - X|, |bx - X|``; the true bound is about 4 eps), the root by ``rerr`` (the formula's
    rounding, and the steps' over up to 2**10 rows); so at least ``m = 2 d / |slope| + 2 rerr``
    past the root the exact test's sign is certain (see :func:`_edge_row`).

    Returns ``(kind, root, dr, m)``: kind 1 bounds X below, -1 above; 0 is a horizontal edge
    whose value ``c = (ay - Y)(ax - bx)`` is the same at every X of a row (``m`` is then ``d``)."""
    r = max(abs(by - Ya), abs(by - Yb))
    s = max(abs(ay - Ya), abs(ay - Yb))
    d = 16.0 * _EPS * (px * r + s * qx)
    slope = ay - by
    if slope == 0.0:
        return 0, 0.0, 0.0, d
    root = ((ay - Ya) * bx - ax * (by - Ya)) / slope
    dr = (ax - bx) / slope
    rerr = 16.0 * _EPS * ((s * abs(bx) + abs(ax) * r) / abs(slope) + abs(root) + 1024.0 * abs(dr) * (Yb - Ya + 1.0))
    return (1 if slope > 0.0 else -1), root, dr, 2.0 * d / abs(slope) + 2.0 * rerr + 1e-9


@njit(cache=True, inline="always")
def _edge_row(edge, ax, ay, bx, k, Y, span):
    """Narrow a row's span by one edge set up by :func:`_edge_setup` (``k`` rows below ``Ya``):
    ``span`` = ``(lo, hi, ilo, ihi)``, the X where the edge function may be positive
    (``lo..hi``) and where its float64 value surely is (``ilo..ihi``); ``lo > hi`` for a row
    the edge excludes."""
    kind, root, dr, m = edge
    lo, hi, ilo, ihi = span
    if kind == 0:
        c = (ay - Y) * (ax - bx)
        if c < -2.0 * m - 4.0 * _EPS * abs(c):
            return 1.0, 0.0, 1.0, 0.0
        if not c > 2.0 * m + 4.0 * _EPS * abs(c):
            ilo = np.inf  # undecided: every candidate of the row is tested exactly
        return lo, hi, ilo, ihi
    x = root + k * dr
    if kind > 0:
        return max(lo, x - m), hi, max(ilo, x + m), ihi
    return lo, min(hi, x + m), ilo, min(ihi, x - m)


@njit(cache=True)
def _clip(faces, vx, cs, f, near, ortho, W, H, hw, hh, px, py, pq):
    """Face ``f`` clipped to ``z > near``, in pixel coordinates.

    Writes the polygon's vertices to ``px, py`` and their depth keys to
    ``pq``, and returns their number: 0 (all behind), 3 or 4. Unclipped
    vertices are copied from the projected vertex array, so a vertex has the
    same bits in every triangle; a clip point is computed from its edge's
    lexicographically smaller end point, so both triangles of an edge get
    the same point.
    """
    n = 0
    for k in range(3):
        a = faces[f, k]
        b = faces[f, (k + 1) % 3]
        ina = vx[a, 2] > near
        inb = vx[b, 2] > near
        if ina:
            px[n] = vx[a, 0]
            py[n] = vx[a, 1]
            pq[n] = vx[a, 3]
            n += 1
        if ina != inb:
            lo = a
            hi = b
            if cs[b, 0] < cs[a, 0] or (cs[b, 0] == cs[a, 0] and (cs[b, 1] < cs[a, 1] or (
                    cs[b, 1] == cs[a, 1] and cs[b, 2] < cs[a, 2]))):
                lo = b
                hi = a
            s = (near - cs[lo, 2]) / (cs[hi, 2] - cs[lo, 2])
            xc = cs[lo, 0] + s * (cs[hi, 0] - cs[lo, 0])
            yc = cs[lo, 1] + s * (cs[hi, 1] - cs[lo, 1])
            X, Y = _to_screen(xc, yc, near, ortho, W, H, hw, hh)
            px[n] = X
            py[n] = Y
            pq[n] = near if ortho else -1.0 / near
            n += 1
    return n


@njit(cache=True)
def _plane3d(faces, cs, f, ortho, W, H, hw, hh):
    """Depth key of face ``f``'s plane as ``(A, B, C)``, key = ``A X + B Y + C``
    in pixel coordinates (perspective ``-1/z``, orthographic ``z``), from its
    camera-space vertices; ``ok`` False for a plane seen edge-on."""
    i0 = faces[f, 0]
    i1 = faces[f, 1]
    i2 = faces[f, 2]
    e1x = cs[i1, 0] - cs[i0, 0]
    e1y = cs[i1, 1] - cs[i0, 1]
    e1z = cs[i1, 2] - cs[i0, 2]
    e2x = cs[i2, 0] - cs[i0, 0]
    e2y = cs[i2, 1] - cs[i0, 1]
    e2z = cs[i2, 2] - cs[i0, 2]
    nx = e1y * e2z - e1z * e2y
    ny = e1z * e2x - e1x * e2z
    nz = e1x * e2y - e1y * e2x
    pn = cs[i0, 0] * nx + cs[i0, 1] * ny + cs[i0, 2] * nz
    if ortho:
        # z = (P0.n - ox nx - oy ny) / nz with o = (sx hw, sy hh, 0)
        if nz == 0.0:
            return 0.0, 0.0, 0.0, False
        return -(2.0 * hw * nx / W) / nz, (2.0 * hh * ny / H) / nz, (pn + hw * nx - hh * ny) / nz, True
    # -1/z = -(d.n) / (P0.n) with d = (sx hw, sy hh, 1)
    if pn == 0.0:
        return 0.0, 0.0, 0.0, False
    return -(2.0 * hw * nx / W) / pn, (2.0 * hh * ny / H) / pn, -(nz - hw * nx + hh * ny) / pn, True


# ----------------------------------------------------------------------------------
# scan conversion of one triangle in one band


@njit(cache=True, _nrt=False)
def _scan_triangle(corners, rlo, rhi, W, f, plane, fid, zbuf, count, count_mode):
    """Fill the pixels of rows ``rlo..rhi`` whose centres the triangle covers.

    ``corners`` = ``((x0, y0, q0), (x1, y1, q1), (x2, y2, q2))``: pixel coordinates
    and depth keys. Depth mode: the fragment's key ``zA X + zB Y + zC`` (``plane`` =
    ``(given, zA, zB, zC)``: the plane through the three ``(x, y, q)`` unless
    ``given``), clamped to the vertices' range, replaces the band's z-buffer entry
    (row ``y - rlo``) where smaller, and ``f`` goes to ``fid``. Count mode:
    ``count[y, x]`` is incremented. The arrays come one by one, not in a tuple, and the
    function counts no references: a tuple built per call, and its references counted (atomic
    increments and decrements), took a tenth of the band kernel's time.
    """
    (x0, y0, q0), (x1, y1, q1), (x2, y2, q2) = corners
    given, zA, zB, zC = plane
    ya, yb = _pixel_range(min(y0, y1, y2), max(y0, y1, y2), rhi + 1)
    ya = max(ya, rlo)
    if ya > yb:
        return
    xa, xb = _pixel_range(min(x0, x1, x2), max(x0, x1, x2), W)
    if xa > xb:
        return
    ok, ax0, ay0, bx0, by0, tl0, ax1, ay1, bx1, by1, tl1, ax2, ay2, bx2, by2, tl2 = _edges(x0, y0, x1, y1, x2, y2)
    if not ok:
        return
    kmin = min(q0, q1, q2)
    kmax = max(q0, q1, q2)
    ready = given or count_mode  # the depth plane is set up at the first covered pixel
    # A box under 4 columns wide tests its few candidates exactly, without the edges' set-up (three
    # divisions and bounds each): cheaper for the small faces of a dense mesh (640x480, 82k faces:
    # the hit buffer about 5% faster than with the set-up from 2 columns on); the pixels are the same.
    wide = xb - xa >= 3
    if wide:
        # Each edge's row roots and margins (_edge_setup), bounded over the triangle's box.
        Xa = xa + 0.5
        Xb = xb + 0.5
        Ya = ya + 0.5
        Yb = yb + 0.5
        ed0 = _edge_setup(ax0, ay0, bx0, by0, Ya, Yb, max(abs(ax0 - Xa), abs(ax0 - Xb)),
                          max(abs(bx0 - Xa), abs(bx0 - Xb)))
        ed1 = _edge_setup(ax1, ay1, bx1, by1, Ya, Yb, max(abs(ax1 - Xa), abs(ax1 - Xb)),
                          max(abs(bx1 - Xa), abs(bx1 - Xb)))
        ed2 = _edge_setup(ax2, ay2, bx2, by2, Ya, Yb, max(abs(ax2 - Xa), abs(ax2 - Xb)),
                          max(abs(bx2 - Xa), abs(bx2 - Xb)))
    else:
        ed0 = ed1 = ed2 = (0, 0.0, 0.0, 0.0)
    for y in range(ya, yb + 1):
        Y = y + 0.5
        xs = xa
        xe = xb
        xi = xb + 1  # pixels xi .. xj are inside for certain; the others are tested exactly
        xj = xb
        if wide:
            # The row's span from the three edges' roots, with margins past which the exact
            # test's answer is certain: the candidates outside it would fail the exact test,
            # those in its interior pass it, so only the pixels near an edge are tested. The
            # pixels drawn are the exact test's, bit for bit.
            k = float(y - ya)
            span = _edge_row(ed0, ax0, ay0, bx0, k, Y, (-np.inf, np.inf, -np.inf, np.inf))
            span = _edge_row(ed1, ax1, ay1, bx1, k, Y, span)
            lo, hi, ilo, ihi = _edge_row(ed2, ax2, ay2, bx2, k, Y, span)
            if lo > hi:
                continue
            lo = min(max(lo, -2.0), W + 2.0)
            hi = min(max(hi, -2.0), W + 2.0)
            xs = max(int(math.ceil(lo - 0.5)), xa)
            xe = min(int(math.floor(hi - 0.5)), xb)
            ilo = min(max(ilo, -2.0), W + 2.0)
            ihi = min(max(ihi, -2.0), W + 2.0)
            xi = max(int(math.ceil(ilo - 0.5)), xs)
            xj = min(int(math.floor(ihi - 0.5)), xe)
        rowz = zB * Y + zC
        for x in range(xs, xe + 1):
            X = x + 0.5
            if (xi <= x <= xj) or (_inside(ax0, ay0, bx0, by0, tl0, X, Y) and _inside(ax1, ay1, bx1, by1, tl1, X, Y)
                                   and _inside(ax2, ay2, bx2, by2, tl2, X, Y)):
                if count_mode:
                    count[y, x] += 1
                else:
                    if not ready:
                        det = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
                        if det == 0.0:
                            return
                        zA = ((q1 - q0) * (y2 - y0) - (q2 - q0) * (y1 - y0)) / det
                        zB = ((q2 - q0) * (x1 - x0) - (q1 - q0) * (x2 - x0)) / det
                        zC = q0 - zA * x0 - zB * y0
                        rowz = zB * Y + zC
                        ready = True
                    z = zA * X + rowz
                    if z < kmin:
                        z = kmin
                    elif z > kmax:
                        z = kmax
                    # Nearest first, then the lower face index: the order the faces come in
                    # does not matter (raster_band draws them in two passes).
                    zb = zbuf[y - rlo, x]
                    if z < zb or (z == zb and f < fid[y - rlo, x]):
                        zbuf[y - rlo, x] = z
                        fid[y - rlo, x] = f


# ----------------------------------------------------------------------------------
# kernels


@in_parts
@njit(**KERNEL)
def _project_par(verts, view, near, ortho, W, H, hw, hh, cs, vx, part):
    """Camera-space coordinates ``cs`` of every vertex, and ``vx`` = pixel
    coordinates, camera depth and depth key (NaN but the depth for a
    perspective vertex at or behind the near plane)."""
    for i in range(*share(verts.shape[0], part)):  # this part's share (common.parallel)
        dx = verts[i, 0] - view[0, 0]
        dy = verts[i, 1] - view[0, 1]
        dz = verts[i, 2] - view[0, 2]
        xc = dx * view[1, 0] + dy * view[1, 1] + dz * view[1, 2]
        yc = dx * view[2, 0] + dy * view[2, 1] + dz * view[2, 2]
        zc = dx * view[3, 0] + dy * view[3, 1] + dz * view[3, 2]
        cs[i, 0] = xc
        cs[i, 1] = yc
        cs[i, 2] = zc
        vx[i, 2] = zc
        if ortho or zc > near:
            X, Y = _to_screen(xc, yc, zc, ortho, W, H, hw, hh)
            vx[i, 0] = X
            vx[i, 1] = Y
            vx[i, 3] = zc if ortho else -1.0 / zc
        else:
            vx[i, 0] = np.nan
            vx[i, 1] = np.nan
            vx[i, 3] = np.nan


@in_parts
@njit(**KERNEL)
def _setup_par(faces, vx, cs, near, ortho, W, H, hw, hh, band_h, ylo, yhi, counts, first, part):
    """Rows ``ylo[f]..yhi[f]`` of pixel centres in face ``f``'s (clipped)
    bounding box, or ``ylo[f] = -1`` when it holds no pixel centre;
    ``counts[c, b]``, the faces of chunk ``c`` that touch band ``b``; and
    ``first[f]``, 1 for a face the scan draws in its first pass (facing the
    eye, by its screen winding, or clipped), 0 for one it draws after them
    (see :mod:`.raster_band`; which pass changes no pixel, only the cost)."""
    nf = faces.shape[0]
    for c in range(*share(counts.shape[0], part)):  # this part's share (common.parallel)
        px = np.empty(4)
        py = np.empty(4)
        pq = np.empty(4)
        for f in range(c * _CHUNK, min(nf, (c + 1) * _CHUNK)):
            i0 = faces[f, 0]
            i1 = faces[f, 1]
            i2 = faces[f, 2]
            ylo[f] = -1
            yhi[f] = -1
            first[f] = 1
            if vx[i0, 2] > near and vx[i1, 2] > near and vx[i2, 2] > near:
                x0 = vx[i0, 0]
                y0 = vx[i0, 1]
                x1 = vx[i1, 0]
                y1 = vx[i1, 1]
                x2 = vx[i2, 0]
                y2 = vx[i2, 1]
                # Counter-clockwise faces (the usual outward winding) turn clockwise with y down:
                # they face the eye, and on a closed mesh hide the others; drawn first.
                if (x0 - x2) * (y1 - y2) - (y0 - y2) * (x1 - x2) > 0.0:
                    first[f] = 0
                xa, xb = _pixel_range(min(x0, x1, x2), max(x0, x1, x2), W)
                if xa > xb:
                    continue
                ya, yb = _pixel_range(min(y0, y1, y2), max(y0, y1, y2), H)
                if ya > yb:
                    continue
                if xa == xb and ya == yb:
                    # One candidate pixel centre, the common case in a dense
                    # mesh: test it now, exactly as the scan would.
                    ok, ax0, ay0, bx0, by0, tl0, ax1, ay1, bx1, by1, tl1, ax2, ay2, bx2, by2, tl2 = _edges(
                        x0, y0, x1, y1, x2, y2)
                    X = xa + 0.5
                    Y = ya + 0.5
                    if not (ok and _inside(ax0, ay0, bx0, by0, tl0, X, Y) and _inside(ax1, ay1, bx1, by1, tl1, X, Y)
                            and _inside(ax2, ay2, bx2, by2, tl2, X, Y)):
                        continue
            else:
                n = _clip(faces, vx, cs, f, near, ortho, W, H, hw, hh, px, py, pq)
                if n == 0:
                    continue
                x_lo = px[0]
                x_hi = px[0]
                y_lo = py[0]
                y_hi = py[0]
                for k in range(1, n):
                    x_lo = min(x_lo, px[k])
                    x_hi = max(x_hi, px[k])
                    y_lo = min(y_lo, py[k])
                    y_hi = max(y_hi, py[k])
                xa, xb = _pixel_range(x_lo, x_hi, W)
                ya, yb = _pixel_range(y_lo, y_hi, H)
                if xa > xb or ya > yb:
                    continue
            ylo[f] = ya
            yhi[f] = yb
            for b in range(ya // band_h, yb // band_h + 1):
                counts[c, b] += 1


@in_parts
@njit(**KERNEL)
def _bin_fill_par(ylo, yhi, band_h, pos, out, part):
    """Write each face into its bands' lists, at the slots ``pos`` reserved
    for its chunk, keeping face order within a band."""
    nf = ylo.shape[0]
    for c in range(*share(pos.shape[0], part)):  # this part's share (common.parallel)
        for f in range(c * _CHUNK, min(nf, (c + 1) * _CHUNK)):
            if ylo[f] >= 0:
                for b in range(ylo[f] // band_h, yhi[f] // band_h + 1):
                    out[pos[c, b]] = f
                    pos[c, b] += 1


# The geometry stages of a small mesh run serially (raster.py): the same builds, their
# whole loops in the calling thread (no threads to wake).
_project_ser = _project_par.serial  # a small mesh: the whole loop in the calling thread
_setup_ser = _setup_par.serial
_bin_fill_ser = _bin_fill_par.serial
