"""The rasterizer's perspective resolve equals its one-pixel-at-a-time form, bit for bit.

:func:`raycast_shade.visibility.raster_band._resolve_perspective` computes the winners' ``u, v, t``
in passes: the face terms per pixel, then the same operations over runs of pixels with selects for
branches (vectorised), then the pixels where a branch would differ (``d.n`` zero, ``u + v`` over 1,
a float32 pair off the triangle) redone one at a time. The reference below is the one-pixel loop
written out in Python floats (IEEE double, the same operations in the same order), run on bands
whose winners are made up: runs of random faces, misses, faces that do not hold the pixel (so
``u, v`` are clamped and ``u + v`` exceeds 1) and a face in a plane through the eye, seen edge-on
in the row whose ray has ``dy = 0`` (so ``d.n = 0``). Every branch is asserted to occur.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from raycast_shade.visibility.hits import convex_uv
from raycast_shade.visibility.raster_band import RUN, _columns, _resolve_rows, resolve_scratch


def _reference(fid, rlo, faces, cs, face_model, face_off, screen, shear, shape):
    """The one-pixel loop: ``(prim, geom, u, v, t)`` of the band's rows, and how often each branch
    was taken (``dn0``: ``d.n == 0``; ``over``: ``u + v > 1`` after the clamp; ``off``: the float32
    pair not inside the triangle as it is; ``off_only``: that alone)."""
    _, W, H, hw, hh = screen
    ox, oy = shear
    prim = np.full(shape, 7, np.int32)
    geom = np.full(shape, 7, np.int32)
    u = np.full(shape, 7.0, np.float32)
    v = np.full(shape, 7.0, np.float32)
    t = np.full(shape, 7.0, np.float32)
    taken = dict(dn0=0, over=0, off=0, off_only=0)
    for r in range(fid.shape[0]):
        y = rlo + r
        dy = (1.0 - 2.0 * (y + 0.5) / H) * hh
        dy2 = (dy + oy) * (dy + oy)
        for x in range(fid.shape[1]):
            f = int(fid[r, x])
            if f < 0:
                prim[y, x], geom[y, x], u[y, x], v[y, x], t[y, x] = -1, -1, 0.0, 0.0, np.inf
                continue
            i0, i1, i2 = (int(i) for i in faces[f])
            p0x, p0y, p0z = (float(c) for c in cs[i0])
            e1x, e1y, e1z = (float(cs[i1, k]) - c for k, c in enumerate((p0x, p0y, p0z)))
            e2x, e2y, e2z = (float(cs[i2, k]) - c for k, c in enumerate((p0x, p0y, p0z)))
            nx = e1y * e2z - e1z * e2y
            ny = e1z * e2x - e1x * e2z
            nz = e1x * e2y - e1y * e2x
            c1x = e2y * p0z - e2z * p0y
            c1y = e2z * p0x - e2x * p0z
            c1z = e2x * p0y - e2y * p0x
            c2x = p0y * e1z - p0z * e1y
            c2y = p0z * e1x - p0x * e1z
            c2z = p0x * e1y - p0y * e1x
            qn = p0x * nx + p0y * ny + p0z * nz
            dx = (2.0 * (x + 0.5) / W - 1.0) * hw
            dz = 1.0
            dn = dx * nx + dy * ny + dz * nz
            if dn != 0.0:
                inv = 1.0 / dn
                b1 = (dx * c1x + dy * c1y + dz * c1z) * inv
                b2 = (dx * c2x + dy * c2y + dz * c2z) * inv
                s = qn * inv
            else:
                taken["dn0"] += 1
                b1 = b2 = 1.0 / 3.0
                s = (float(cs[i0, 2]) + float(cs[i1, 2]) + float(cs[i2, 2])) / 3.0
            b1 = 0.0 if b1 < 0.0 else b1
            b2 = 0.0 if b2 < 0.0 else b2
            sb = b1 + b2
            if sb > 1.0:
                taken["over"] += 1
                b1 /= sb
                b2 /= sb
            s *= math.sqrt((dx + ox) * (dx + ox) + dy2 + 1.0)
            a, c = float(np.float32(b1)), float(np.float32(b2))
            if not (a >= 0.0 and c >= 0.0 and a + c <= 1.0):
                taken["off"] += 1
                taken["off_only"] += sb <= 1.0 and dn != 0.0  # only the float32 rounding is off
            g = int(face_model[f])
            prim[y, x], geom[y, x] = f - int(face_off[g]), g
            u[y, x], v[y, x] = convex_uv(np.float32(b1), np.float32(b2))
            t[y, x] = s
    return (prim, geom, u, v, t), taken


def _band(rng, rows, width, nfaces):
    """Winners in runs: misses, and faces repeated over runs of 1 to 12 pixels."""
    fid = np.empty((rows, width), np.int32)
    for r in range(rows):
        x = 0
        while x < width:
            n = int(rng.integers(1, 13))
            fid[r, x:x + n] = -1 if rng.random() < 0.25 else int(rng.integers(0, nfaces))
            x += n
    return fid


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("shear", [(0.0, 0.0), (0.13, -0.07)])
def test_perspective_resolve_equals_the_one_pixel_loop(seed, shear):
    rng = np.random.default_rng(seed)
    W, H = RUN + 89, 41  # two runs of columns a row, the second partial; the middle row has dy = 0
    hw, hh = 0.6, 0.45
    # Camera space (z along the view axis): a cloud in front of the eye, and one face in the plane
    # y = 0 through the eye (its normal has no x or z part: d.n = 0 where dy = 0).
    cs = np.concatenate([rng.normal(0.0, 0.5, (60, 3)) + (0.0, 0.0, 3.0),
                         [[-1.0, 0.0, 2.0], [1.0, 0.0, 2.5], [0.2, 0.0, 4.0]]])
    faces = np.concatenate([rng.integers(0, 60, (50, 3)), [[60, 61, 62]]]).astype(np.int64)
    screen = (False, float(W), float(H), hw, hh)
    rows, rlo = 8, 16  # the band holds row 20, the middle one
    fid = _band(rng, rows, W, len(faces))
    fid[4, : W // 2] = 50  # the edge-on face along the row with dy = 0
    # Faces whose edge 1 -> 2 crosses a pixel's ray: u + v within rounding of 1 there, where the
    # float32 pair alone can leave the triangle.
    dxs, _ = _columns(float(W), hw, 0.0)
    more_v, more_f = [], []
    for k in range(200):
        r, x = int(rng.integers(0, rows)), int(rng.integers(0, W))
        q = rng.uniform(2.0, 5.0) * np.array([dxs[x], (1.0 - 2.0 * (rlo + r + 0.5) / H) * hh, 1.0])
        w = rng.normal(size=3)
        n = len(cs) + 3 * k
        more_v += [q + rng.normal(0.0, 0.5, 3), q + rng.uniform(0.1, 1.0) * w, q - rng.uniform(0.1, 1.0) * w]
        more_f.append([n, n + 1, n + 2])
        fid[r, x] = len(faces) + k
    cs = np.concatenate([cs, more_v])
    faces = np.concatenate([faces, np.array(more_f, np.int64)])
    face_model = (np.arange(len(faces)) >= 20).astype(np.int32)  # two models: prim is local to its model
    face_off = np.array([0, 20], np.int64)
    shape = (H, W)
    hits = tuple(np.full(shape, 9, dt) for dt in (np.int32, np.int32, np.float32, np.float32, np.float32))
    zbuf = np.where(fid >= 0, 1.0, np.inf)
    band = (fid.copy(), zbuf, *_columns(float(W), hw, shear[0]), *resolve_scratch())
    _resolve_rows(band, rlo, faces, cs, face_model, face_off, screen, shear, hits)
    want, taken = _reference(fid, rlo, faces, cs, face_model, face_off, screen, shear, shape)
    assert min(taken.values()) > 0, taken  # every branch occurs
    rows_of_band = slice(rlo, rlo + rows)
    for name, got, exp in zip(("prim", "geom", "u", "v", "t"), hits, want):
        assert np.array_equal(got[rows_of_band].view(np.uint32), exp[rows_of_band].view(np.uint32)), name
        assert np.all(got[:rlo] == 9) and np.all(got[rlo + rows:] == 9), name  # no row outside the band
    # the band's z-buffer is left empty for the next band
    assert np.all(band[0] == -1) and np.all(band[1] == np.inf)
