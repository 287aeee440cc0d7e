"""Reverse-mode gradients through one mirror bounce (:mod:`.mirrors`), over the frame's hits.

A reflective pixel (``rho = reflectivity > 0``) is ``(1 - rho) local + rho R``, ``R`` the colour its
mirror ray meets: the Phong-shaded point there, seen along the ray (the one evaluator,
:func:`~raycast_shade.shading.illumination._reflected`), or the background on a miss. So::

    dL/d(local)   = (1 - rho) dL/dI           (the method's own VJP, with dL/dI scaled)
    dL/d(R)       = rho dL/dI                 (:func:`~.grad_terms._reflected_vjp` at the bounce point)
    dL/d(rho)     = dL/dI . (R - local)

The mirror ray (origin and direction) and its hit are held: the bounce is differentiated with respect
to the materials and lights the reflection shows, not to the mirror's normal or geometry (the caller
refuses those families on a scene with mirrors), nor to where the bounce lands. Each ray is the
forward's own (:func:`~.mirror_rays._mirror_ray` of :func:`~.phong._surface`), traced alone
(one lane of a closest-hit packet); shadow rays at the bounce are traced again, as the forward
traces them, and a blocked light stays blocked. One bounce only: a ray that meets another reflective
surface is reported (``nested``), and the caller refuses the frame.

Determinism: the pixels are summed in :data:`~.grad_frame.PARTS`'s fixed parts of rows, each
into its own accumulator row, added in part order by the caller.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.layout import MAT_REFLECTIVITY
from ..common.parallel import launch, share
from ..visibility.secondary import closest_hit, closest_packet, ray_scratch, set_closest_rays, trace_closest
from .grad_terms import GM_REFLECTIVITY, GM_SIZE, _reflected_vjp
from .illumination import _illuminate
from .jit import JIT
from .mirror_rays import _mirror_ray
from .mirrors import MIRROR_FLAGS
from .phong import _shading_point, _surface
from .records import At
from .texture import _row_coefficients

__all__ = ["mirror_vjp"]

_LANES = 16  # a closest-hit packet's lanes (visibility.secondary): one used


@njit(nogil=True, **JIT)
def _bounce_kernel(hits, G, B, L, face_off, mats, cam, trace, background, gimg, local, lay, acc, out, part):
    """Reflective pixels of this part's rows: ``acc[k]`` += the bounce's parameter gradients
    (``rho dL/dI`` at the point the mirror ray meets) and ``dL/drho``; ``out = (nested, points)``:
    ``nested[y, x]`` set where the ray meets another reflective surface, ``points[y, x]`` (H, W, 10;
    or (0, 0, 10) for none) the bounce's point, shading normal, view and model (-1: a miss)."""
    nested, points = out
    want = points.shape[0] != 0
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
                _reflected_vjp(hp, coef, mats, gb, L, S, (rho * gI[0], rho * gI[1], rho * gI[2]), acc, k, lay)
            acc[k, gm * GM_SIZE + GM_REFLECTIVITY] += (gI[0] * (rgb[0] - local[y, x, 0]) + gI[1] * (rgb[1] - local[y, x, 1])
                                                      + gI[2] * (rgb[2] - local[y, x, 2]))


def mirror_vjp(hits, inputs, gimg, local, lay, size, handle, unit, parts, want_points: bool = False):
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

    Returns
    -------
    gimg_local : (H, W, 3) float64
        ``dL/d(local)``: ``(1 - rho) dL/dI`` on reflective pixels, ``dL/dI`` elsewhere.
    params : (size,) float64
        The bounces' gradients and ``dL/drho`` (slot ``GM_REFLECTIVITY`` of each model).
    nested : (H, W) bool
        Where a mirror ray meets another reflective surface (not differentiated).
    points : (H, W, 10) float64 or None
        With ``want_points``: the bounce's shading point, unit shading normal and view vector
        (re-centred coordinates) and its model (-1 for a miss; 0 rows elsewhere).
    """
    mats = inputs.materials
    rho = np.where(hits.prim >= 0, mats[np.maximum(hits.geom, 0), MAT_REFLECTIVITY], 0.0)
    acc = np.zeros((parts, size))
    nested = np.zeros(hits.prim.shape, np.bool_)
    points = np.zeros(hits.prim.shape + (10,) if want_points else (0, 0, 10))
    launch(_bounce_kernel, (hits.prim, hits.geom, hits.u, hits.v), inputs.geometry, inputs.bumps, inputs.lighting,
           inputs.face_off, mats, inputs.cam, (np.int64(handle), np.float64(unit)),
           np.asarray(inputs.background, np.float64), gimg, np.asarray(local, np.float64), lay, acc, (nested, points),
           parts=parts, dynamic=True)
    total = acc[0].copy()
    for r in range(1, parts):
        total += acc[r]
    return gimg * (1.0 - rho)[..., None], total, nested, (points if want_points else None)
