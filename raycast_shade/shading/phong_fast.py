"""Phong shading that vectorises: the common scene's pixels in batches of :data:`LANES` lanes.

The general Phong kernel (:mod:`.phong`) shades one pixel at a time: gathers, three square
roots, several divisions and a branch per light and per test, a scalar float64 loop that LLVM
does not vectorise. For the common scene — no textures or mesh colours, no bump or normal map
on a Phong model — this kernel does the same arithmetic in passes:

1. the Phong pixels (of any rows of the task's block) are queued, their face and barycentrics
   into lane ``k`` of a small scratch array, structure of arrays, until :data:`LANES` are; then a
   gather (:func:`_gather`) reads the lanes' vertex indices in one pass and sums each lane's point
   and interpolated normal (the sums of :mod:`.surface`, in their order) and copies its face
   normal in another, passes whose iterations are independent so that the lanes' cache misses
   overlap (on a large mesh the rows are also prefetched: the faces as they are queued, the
   vertices a pass before they are read; flat views of the mesh, unsigned indices: no
   multiplications by row lengths, no wrap-around tests); the material row fills the lanes once
   per batch of one model, whose lane 0 then tells the models and powers the batch needs;
2. branch-free passes over the lanes (selects, not ``continue``): the point, the view vector,
   the oriented normal; then per light its direction, distance and attenuation, ``n . s``, the
   specular cosine and the whole-number power by repeated squaring (one pass per bit, a bit
   applied to the lanes that have it), and the sum; these are the loops LLVM vectorises;
3. a pass sums and saturates the colours (vectorised), a scatter writes them (and, when asked,
   the shading normals); the ``terms_on`` build (``render(terms=True)``) also sums each light's
   diffuse and specular parts in the accumulate pass and writes the terms in a pass of its own.

Shadows (a variant of its own, :data:`_PHONG_FAST_SHADOWS`, for frames with a scene handle): the
pixels are queued by 4x4 tiles, each lane's shadow origin is lifted past the terminator once per
batch (:func:`_origins`), and per light that casts shadows, after ``n . s``, a branch-free pass
writes every lane's shadow ray (:func:`~raycast_shade.shading.shadows._shadow_ray`, the ray the
general kernel traces) into four ``RTCRay16`` packets, the lanes the light reaches active; one
``rtcOccluded16`` per packet, and the lanes found blocked lose the light before the sum.

Every lane does the float64 operations of :func:`.phong._shade_surface` in the same order, so
the image is the general kernel's bit for bit (``tests/shading/test_phong_fast.py``). The
passes are split where the scalar kernel's operations lie in different basic blocks: the
shading flags allow fused multiply-adds (``contract``), which LLVM forms only within a block,
so a product that the scalar kernel computes in one block and adds in another (the rescaled
normal before its reflection into the viewer's hemisphere; the light direction before the
half vector) goes through the scratch array between two passes here too. Lanes whose
shininess is not a whole number up to 4096 (``pow``), and spot lights' cone factors, are
computed per lane by the scalar helpers. The scratch is indexed at constant offsets with
constant trip counts, so LLVM sees that its fields never overlap and needs no run-time
alias checks.

:data:`HANDLES` declares the light kinds, attenuation laws and reflectance models the passes
implement; :func:`applies` (the dispatch of :class:`~raycast_shade.shading.shade.SampleShading`)
takes this kernel only for frames of declared codes without textures, colours, bump or normal maps.
Every other frame, a new light kind or model included, goes to :func:`.illumination._reflected`.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from ..common.inline import inline_jit

from ..common.parallel import in_parts, share
from ..common.layout import (ATT_HEURISTIC, ATT_INVERSE_SQUARE, ATT_NONE, CAM_EYE, CAM_FORWARD, CAM_ORTHO,
                             LIGHT_ATT, LIGHT_DIRECTIONAL, LIGHT_K, LIGHT_KIND, LIGHT_POINT, LIGHT_RADIANCE,
                             LIGHT_SHADOWS, LIGHT_SPOT, LIGHT_VEC, MAT_KA, MAT_KD, MAT_KE, MAT_KS, MAT_MODEL,
                             MAT_SHININESS, METHOD_PHONG, MODEL_BLINN, MODEL_PHONG)
from ..common.prefetch import PREFETCH_BYTES, prefetch
from ..common.schedule import BLOCK_ROWS, spread_step
from ..visibility.secondary import set_occlusion_lane, trace_occlusion
from .illumination import _spot_factor
from .jit import CALLED, HELPER, JIT
from .lanes import (_A, _ATT, _B1, _B2, _CB, _CC, _CP, _D, _FIELDS, _FN, _G, _HASSPEC, _KA, _KD, _KE, _KS, _LIT,
                    _MODEL, _N, _ND, _O, _P, _PW, _R, _S, _SG, _SHN, _SHT, _TD, _TS, _V, LANES, _pick)
from .mirror_rays import hand_over_lanes
from .pixelstore import saturate, store_background
from .shadows import LANES as PACKET_LANES, _packets, _shadow_ray, _strip_background
from .terms_kernel import _miss, _scatter_terms

__all__ = ["LANES", "applies", "HANDLES"]

_TILE = 4  # a shadowed frame's pixels are queued by tiles of 4x4 (BLOCK_ROWS is a multiple of it)
_NO_NORMALS = np.empty((0, 0, 3), np.float32)  # the kernel's normal output when none is asked for


# What the passes implement (layout codes): _direction's kinds and laws, _cosines' and _specular's lobes.
HANDLES = dict(light_kinds=frozenset({LIGHT_POINT, LIGHT_DIRECTIONAL, LIGHT_SPOT}),
               attenuations=frozenset({ATT_NONE, ATT_INVERSE_SQUARE, ATT_HEURISTIC}),
               models=frozenset({MODEL_PHONG, MODEL_BLINN}))


def applies(modes, k) -> bool:
    """Whether this kernel shades the frame's Phong pixels bit for bit as the general one.

    Parameters
    ----------
    modes : (G,) int8
        Per-model method codes.
    k : FrameInputs

    Returns
    -------
    bool
        True for a frame without textures or mesh colours, no bump or normal map on a Phong model,
        whose lights, laws and Phong models' reflectance models are all in :data:`HANDLES`.
    """
    phong = np.asarray(modes) == METHOD_PHONG
    B, lights = k.bumps, k.lighting.lights
    if k.tex_on or bool(np.any(B.bump_index[phong] >= 0)) or bool(np.any(B.nmap_index[phong] >= 0)):
        return False
    kinds = lights[:, LIGHT_KIND]
    laws = lights[kinds != LIGHT_DIRECTIONAL, LIGHT_ATT]  # a light at infinity reads no law
    return (all(float(c) in HANDLES["light_kinds"] for c in kinds)
            and all(float(c) in HANDLES["attenuations"] for c in laws)
            and all(float(c) in HANDLES["models"] for c in k.materials[phong, MAT_MODEL]))


@inline_jit(**CALLED)  # returns views: NRT on (a helper without it would hand out unowned references)
def _flat_mesh(G):
    """The mesh record ``G``'s (m, 3) arrays as flat views, row ``i`` at ``3 i`` (an address
    computation, not a multiplication by a run-time row length): what :func:`_gather` reads."""
    return G.verts.reshape(-1), G.normals.reshape(-1), G.faces.reshape(-1), G.face_normals.reshape(-1)


@inline_jit(**HELPER)
def _gather(S, XY, n, F, ahead):
    """The queued lanes' points, interpolated (not yet renormalised) normals and face normals:
    lane ``k``'s hit on face ``XY[3 * LANES + k]`` at ``(_B1, _B2)`` (surface._hit_point,
    surface._shading_normal's sums). Two passes whose iterations are independent, so that the
    lanes' cache misses overlap: the faces' vertex indices (``ahead``: then their rows
    prefetched), then the sums. ``F``: the mesh's flat views (:func:`_flat_mesh`); the vertices'
    offsets (``3 i``) stay in ``XY`` fields 4-6 (for :func:`_origins`)."""
    verts, normals, faces, fnormals = F
    for k in range(n):
        f3 = 3 * XY[3 * LANES + k]
        for c in range(3):
            i3 = 3 * np.int64(faces[np.uint64(f3 + c)])  # unsigned indices: no wrap-around test per read
            XY[(4 + c) * LANES + k] = i3
            if ahead:
                prefetch(verts, i3)
                prefetch(normals, i3)
    for k in range(n):
        f3 = 3 * XY[3 * LANES + k]
        i0, i1, i2 = XY[4 * LANES + k], XY[5 * LANES + k], XY[6 * LANES + k]
        b1, b2 = S[_B1 * LANES + k], S[_B2 * LANES + k]
        b0 = 1.0 - b1 - b2
        for c in range(3):
            S[(_P + c) * LANES + k] = b0 * verts[np.uint64(i0 + c)] + b1 * verts[np.uint64(i1 + c)] + b2 * verts[np.uint64(i2 + c)]
        for c in range(3):
            S[(_A + c) * LANES + k] = b0 * normals[np.uint64(i0 + c)] + b1 * normals[np.uint64(i1 + c)] + b2 * normals[np.uint64(i2 + c)]
        for c in range(3):
            S[(_FN + c) * LANES + k] = fnormals[np.uint64(f3 + c)]


@inline_jit(**HELPER)
def _material(S, lo, hi, materials, gm):
    """Fill lanes ``lo`` to ``hi - 1`` with model ``gm``'s material row: its coefficients, its whole
    shininess (0 where ``pow`` serves, as illumination._power decides), the shininess itself,
    its reflectance model and whether it has a specular term."""
    t = materials[gm, MAT_SHININESS]
    n = int(t)
    use_pow = n != t or n > 4096
    has = materials[gm, MAT_KS + 0] > 0.0 or materials[gm, MAT_KS + 1] > 0.0 or materials[gm, MAT_KS + 2] > 0.0
    for c in range(3):
        for field, slot in ((_KA, MAT_KA), (_KD, MAT_KD), (_KS, MAT_KS), (_KE, MAT_KE)):
            value = materials[gm, slot + c]
            for k in range(lo, hi):
                S[(field + c) * LANES + k] = value
    rest = (0.0 if use_pow else float(n), t, materials[gm, MAT_MODEL], 1.0 if has else 0.0)
    for j in range(4):
        value = rest[j]
        for k in range(lo, hi):
            S[(_SHN + j) * LANES + k] = value


@inline_jit(**HELPER)
def _geometry(S, cam, ambient):
    """Per lane: the point, the view vector, the geometric normal turned to it, the rescaled
    interpolated normal (``_A``; the geometric normal where it cancels) and the ambient term."""
    bx = -cam[CAM_FORWARD + 0]
    by = -cam[CAM_FORWARD + 1]
    bz = -cam[CAM_FORWARD + 2]
    ortho = cam[CAM_ORTHO] != 0.0
    ex = cam[CAM_EYE + 0]
    ey = cam[CAM_EYE + 1]
    ez = cam[CAM_EYE + 2]
    for k in range(LANES):
        px = S[(_P + 0) * LANES + k]
        py = S[(_P + 1) * LANES + k]
        pz = S[(_P + 2) * LANES + k]
        dx = ex - px
        dy = ey - py
        dz = ez - pz
        length = np.sqrt(dx * dx + dy * dy + dz * dz)
        back = ortho | (length == 0.0)
        vx = _pick(back, bx, dx / length)
        vy = _pick(back, by, dy / length)
        vz = _pick(back, bz, dz / length)
        gx = S[(_FN + 0) * LANES + k]
        gy = S[(_FN + 1) * LANES + k]
        gz = S[(_FN + 2) * LANES + k]
        degenerate = (gx == 0.0) & (gy == 0.0) & (gz == 0.0)
        flip = (gx * vx + gy * vy + gz * vz < 0.0) & (not degenerate)
        sgn = _pick(flip, -1.0, 1.0)
        gx = _pick(degenerate, vx, _pick(flip, -gx, gx))
        gy = _pick(degenerate, vy, _pick(flip, -gy, gy))
        gz = _pick(degenerate, vz, _pick(flip, -gz, gz))
        ax = S[(_A + 0) * LANES + k]
        ay = S[(_A + 1) * LANES + k]
        az = S[(_A + 2) * LANES + k]
        al = np.sqrt(ax * ax + ay * ay + az * az)
        keep = al >= 1e-6
        s = sgn / al
        S[_SG * LANES + k] = sgn
        S[(_A + 0) * LANES + k] = _pick(keep, ax * s, gx)
        S[(_A + 1) * LANES + k] = _pick(keep, ay * s, gy)
        S[(_A + 2) * LANES + k] = _pick(keep, az * s, gz)
        S[(_V + 0) * LANES + k] = vx
        S[(_V + 1) * LANES + k] = vy
        S[(_V + 2) * LANES + k] = vz
        S[(_G + 0) * LANES + k] = gx
        S[(_G + 1) * LANES + k] = gy
        S[(_G + 2) * LANES + k] = gz
        for c in range(3):
            S[(_R + c) * LANES + k] = ambient[c] * S[(_KA + c) * LANES + k]
    for k in range(LANES):  # into the viewer's hemisphere (records.reflect_into): a pass of its own, see above
        ax = S[(_A + 0) * LANES + k]
        ay = S[(_A + 1) * LANES + k]
        az = S[(_A + 2) * LANES + k]
        gx = S[(_G + 0) * LANES + k]
        gy = S[(_G + 1) * LANES + k]
        gz = S[(_G + 2) * LANES + k]
        c = ax * gx + ay * gy + az * gz
        below = c < 0.0
        S[(_N + 0) * LANES + k] = _pick(below, ax - 2.0 * c * gx, ax)
        S[(_N + 1) * LANES + k] = _pick(below, ay - 2.0 * c * gy, ay)
        S[(_N + 2) * LANES + k] = _pick(below, az - 2.0 * c * gz, az)


@inline_jit(**HELPER)
def _direction(S, lights, i, dmin, att_on):
    """Light ``i``'s unit direction, distance and attenuation (times a spot's cone) per lane
    (illumination._light_at)."""
    lx = lights[i, LIGHT_VEC + 0]
    ly = lights[i, LIGHT_VEC + 1]
    lz = lights[i, LIGHT_VEC + 2]
    if lights[i, LIGHT_KIND] == LIGHT_DIRECTIONAL:
        for k in range(LANES):
            S[(_S + 0) * LANES + k] = lx
            S[(_S + 1) * LANES + k] = ly
            S[(_S + 2) * LANES + k] = lz
            S[_D * LANES + k] = np.inf
            S[_ATT * LANES + k] = 1.0
        return
    for k in range(LANES):
        dx = lx - S[(_P + 0) * LANES + k]
        dy = ly - S[(_P + 1) * LANES + k]
        dz = lz - S[(_P + 2) * LANES + k]
        d = np.sqrt(dx * dx + dy * dy + dz * dz)
        S[(_S + 0) * LANES + k] = dx / d
        S[(_S + 1) * LANES + k] = dy / d
        S[(_S + 2) * LANES + k] = dz / d
        S[_D * LANES + k] = d
    law = lights[i, LIGHT_ATT]
    if att_on and law == ATT_INVERSE_SQUARE:
        for k in range(LANES):
            dd = max(S[_D * LANES + k], dmin)
            S[_ATT * LANES + k] = 1.0 / (dd * dd)
    elif att_on and law == ATT_HEURISTIC:
        kk = lights[i, LIGHT_K]
        for k in range(LANES):
            S[_ATT * LANES + k] = 1.0 / (S[_D * LANES + k] + kk)
    else:
        for k in range(LANES):
            S[_ATT * LANES + k] = 1.0
    if lights[i, LIGHT_KIND] == LIGHT_SPOT:  # Warn's cone: per lane by the scalar helper (a branch and a power)
        for k in range(LANES):
            cone = _spot_factor(lights, i, (S[(_S + 0) * LANES + k], S[(_S + 1) * LANES + k],
                                            S[(_S + 2) * LANES + k]))
            S[_ATT * LANES + k] = S[_ATT * LANES + k] * cone
            if cone == 0.0:
                S[_D * LANES + k] = 0.0  # outside the cone: unlit, as a light on the point


@inline_jit(**HELPER)
def _cosines(S, spec_on, phong, blinn):
    """Per lane: ``n . s`` (clamped to 1), whether the light counts (``_LIT``), and the specular
    cosines of the models the batch uses (reflectance: Phong's ``_CP``, Blinn-Phong's ``_CB``)."""
    for k in range(LANES):
        ndots = (S[(_N + 0) * LANES + k] * S[(_S + 0) * LANES + k] + S[(_N + 1) * LANES + k] * S[(_S + 1) * LANES + k]
                 + S[(_N + 2) * LANES + k] * S[(_S + 2) * LANES + k])
        lit = (S[_D * LANES + k] != 0.0) & (not ndots <= 0.0)
        S[_LIT * LANES + k] = _pick(lit, 1.0, 0.0)
        S[_ND * LANES + k] = _pick(ndots > 1.0, 1.0, ndots)
    if spec_on and phong:
        for k in range(LANES):
            nd = S[_ND * LANES + k]
            rx = 2.0 * nd * S[(_N + 0) * LANES + k] - S[(_S + 0) * LANES + k]
            ry = 2.0 * nd * S[(_N + 1) * LANES + k] - S[(_S + 1) * LANES + k]
            rz = 2.0 * nd * S[(_N + 2) * LANES + k] - S[(_S + 2) * LANES + k]
            S[_CP * LANES + k] = rx * S[(_V + 0) * LANES + k] + ry * S[(_V + 1) * LANES + k] + rz * S[(_V + 2) * LANES + k]
    if spec_on and blinn:
        for k in range(LANES):
            hx = S[(_S + 0) * LANES + k] + S[(_V + 0) * LANES + k]
            hy = S[(_S + 1) * LANES + k] + S[(_V + 1) * LANES + k]
            hz = S[(_S + 2) * LANES + k] + S[(_V + 2) * LANES + k]
            hl = np.sqrt(hx * hx + hy * hy + hz * hz)
            c = (S[(_N + 0) * LANES + k] * hx + S[(_N + 1) * LANES + k] * hy + S[(_N + 2) * LANES + k] * hz) / hl
            S[_CB * LANES + k] = _pick(hl > 0.0, c, 0.0)


@inline_jit(**HELPER)
def _origins(S, XY, F):
    """Per lane the shadow rays' origin ``_O``: the point lifted past the terminator as
    surface._terminator_point lifts it (phong._shading_point with shadow rays), the same operations
    in order, over every lane without branches (a select per vertex: on a noisy mesh the branches
    mispredict), from the gather's vertex offsets (``XY``) into the flat arrays ``F``; the lanes past
    the queued ones are not traced."""
    verts, normals, _, _ = F
    for k in range(LANES):
        b1 = S[_B1 * LANES + k]
        b2 = S[_B2 * LANES + k]
        b0 = 1.0 - b1 - b2
        px = S[(_P + 0) * LANES + k]
        py = S[(_P + 1) * LANES + k]
        pz = S[(_P + 2) * LANES + k]
        sgn = S[_SG * LANES + k]
        qx = px
        qy = py
        qz = pz
        for j in range(3):
            i = XY[(4 + j) * LANES + k]  # the vertex's offset: unsigned reads, no wrap-around test
            i0, i1, i2 = np.uint64(i), np.uint64(i + 1), np.uint64(i + 2)
            w = b0 if j == 0 else (b1 if j == 1 else b2)
            nx = sgn * normals[i0]
            ny = sgn * normals[i1]
            nz = sgn * normals[i2]
            d = (px - verts[i0]) * nx + (py - verts[i1]) * ny + (pz - verts[i2]) * nz
            below = d < 0.0
            qx = _pick(below, qx - w * d * nx, qx)
            qy = _pick(below, qy - w * d * ny, qy)
            qz = _pick(below, qz - w * d * nz, qz)
        S[(_O + 0) * LANES + k] = qx
        S[(_O + 1) * LANES + k] = qy
        S[(_O + 2) * LANES + k] = qz


@inline_jit(**HELPER)
def _shadow_pass(S, n, lights, i, handle, unit, Q):
    """Light ``i``'s shadow rays from the queued lanes it lights (``_LIT`` 1: in its cone, not on
    the point, ``n . s > 0``: the rays the general kernel traces) as ``rtcOccluded16`` packets, 16
    lanes each; the occluded lanes' ``_LIT`` becomes 0. ``Q``: the task's packet scratch
    (:func:`.shadows._packets` of one packet per 16 lanes, its fixed slots set there).

    Every lane's ray is :func:`~raycast_shade.shading.shadows._shadow_ray`'s, written into its
    packet (:func:`~raycast_shade.visibility.secondary.set_occlusion_lane`) in a pass without
    branches (vectorised); a lane outside the mask is not traced, and a stale answer in ``vis``
    (an earlier light's or batch's) can only zero a lane that is 0 already or is not written."""
    buf, ib, off, valid, voff, args, aoff, vis, points = Q
    target = (lights[i, LIGHT_VEC + 0], lights[i, LIGHT_VEC + 1], lights[i, LIGHT_VEC + 2])
    ub = np.uint64(off)  # unsigned: no wrap-around test per write, so the stores vectorise
    for j in range(LANES // PACKET_LANES):
        for q in range(PACKET_LANES):
            k = j * PACKET_LANES + q
            org, d, tfar = _shadow_ray(
                (S[(_O + 0) * LANES + k], S[(_O + 1) * LANES + k], S[(_O + 2) * LANES + k]),
                (S[(_G + 0) * LANES + k], S[(_G + 1) * LANES + k], S[(_G + 2) * LANES + k]),
                (S[(_S + 0) * LANES + k], S[(_S + 1) * LANES + k], S[(_S + 2) * LANES + k]),
                target, S[_D * LANES + k] < np.inf, unit)
            set_occlusion_lane(buf, ub, j, q, org, d, tfar)
            valid[voff + k] = -1 if (k < n) & (S[_LIT * LANES + k] == 1.0) else 0
    trace_occlusion(handle, buf, off, valid, voff, args, aoff, vis)
    for j in range(LANES // PACKET_LANES):
        for q in range(PACKET_LANES):
            k = j * PACKET_LANES + q
            S[_LIT * LANES + k] = _pick(vis[j, q] == 1, 0.0, S[_LIT * LANES + k])


@inline_jit(**HELPER)
def _specular(S, nbits, any_pow):
    """Per lane the specular factor ``max(c, 0)^t`` into ``_PW`` (0 without a specular term):
    repeated squaring, one pass per bit of the largest whole shininess (illumination._power)."""
    for k in range(LANES):
        c = _pick(S[_MODEL * LANES + k] == MODEL_BLINN, S[_CB * LANES + k], S[_CP * LANES + k])
        S[_CC * LANES + k] = min(c, 1.0)
        S[_PW * LANES + k] = 1.0
        S[_LIT * LANES + k] = S[_LIT * LANES + k] + _pick((S[_HASSPEC * LANES + k] != 0.0) & (c > 0.0), 2.0, 0.0)
    for j in range(nbits):
        for k in range(LANES):
            c = S[_CC * LANES + k]
            on = ((int(S[_SHN * LANES + k]) >> j) & 1) != 0
            S[_PW * LANES + k] = _pick(on, S[_PW * LANES + k] * c, S[_PW * LANES + k])
            S[_CC * LANES + k] = c * c
    if any_pow:
        for k in range(LANES):
            t = S[_SHT * LANES + k]
            n = int(t)
            if (n != t or n > 4096) and S[_LIT * LANES + k] >= 2.0:
                c = S[_CB * LANES + k] if S[_MODEL * LANES + k] == MODEL_BLINN else S[_CP * LANES + k]
                S[_PW * LANES + k] = min(c, 1.0) ** t


@inline_jit(**HELPER)
def _add_terms(S, k, c, ar, nd, spec, lit):
    """Lane ``k``'s channel ``c``: ``_TD += ar (kd n.s)``, ``_TS += ar (Ks spec)`` where ``lit``."""
    td = S[(_TD + c) * LANES + k]
    ts = S[(_TS + c) * LANES + k]
    S[(_TD + c) * LANES + k] = td + ar * (S[(_KD + c) * LANES + k] * nd) if lit else td
    S[(_TS + c) * LANES + k] = ts + ar * (S[(_KS + c) * LANES + k] * spec) if lit else ts


@inline_jit(**HELPER)
def _accumulate(S, lights, i, terms):
    """Add light ``i``'s ``att Ii (kd n.s + Ks spec)`` to the lanes it lights; ``terms`` (a constant of
    the kernel): also ``att Ii (kd n.s)`` to ``_TD`` and ``att Ii (Ks spec)`` to ``_TS``, as the evaluator."""
    r0 = lights[i, LIGHT_RADIANCE + 0]
    r1 = lights[i, LIGHT_RADIANCE + 1]
    r2 = lights[i, LIGHT_RADIANCE + 2]
    for k in range(LANES):
        flags = S[_LIT * LANES + k]
        lit = (flags == 1.0) | (flags == 3.0)
        spec = _pick(flags >= 2.0, S[_PW * LANES + k], 0.0)  # 2 is set only by _specular (spec_on)
        att = S[_ATT * LANES + k]
        nd = S[_ND * LANES + k]
        r = S[(_R + 0) * LANES + k]
        g = S[(_R + 1) * LANES + k]
        b = S[(_R + 2) * LANES + k]
        nr = r + att * r0 * (S[(_KD + 0) * LANES + k] * nd + S[(_KS + 0) * LANES + k] * spec)
        ng = g + att * r1 * (S[(_KD + 1) * LANES + k] * nd + S[(_KS + 1) * LANES + k] * spec)
        nb = b + att * r2 * (S[(_KD + 2) * LANES + k] * nd + S[(_KS + 2) * LANES + k] * spec)
        S[(_R + 0) * LANES + k] = _pick(lit, nr, r)
        S[(_R + 1) * LANES + k] = _pick(lit, ng, g)
        S[(_R + 2) * LANES + k] = _pick(lit, nb, b)
        if terms:
            _add_terms(S, k, 0, att * r0, nd, spec, lit)
            _add_terms(S, k, 1, att * r1, nd, spec, lit)
            _add_terms(S, k, 2, att * r2, nd, spec, lit)


@inline_jit(**HELPER)
def _shade_batch(S, XY, n, mixed, F, L, cam, Q, spec_on, att_on, shadows_on, terms):
    """Shade the lanes (``n`` of them queued, the rest an earlier batch's or zeros); with
    ``shadows_on`` (a scene handle), the lights that cast shadows trace them (:func:`_shadow_pass`);
    ``terms``: sum the diffuse and specular terms too (:func:`_accumulate`). The models and powers
    the batch needs: from each queued lane if it is ``mixed``, else from lane 0 (all hold one row)."""
    ambient, lights, dmin, handle, unit = L.ambient, L.lights, L.dmin, L.handle, L.unit
    m = n if mixed else 1
    nblinn = 0
    npow = 0
    top = 0.0
    for k in range(m):
        nblinn += 1 if S[_MODEL * LANES + k] == MODEL_BLINN else 0
        npow += 1 if S[_SHN * LANES + k] == 0.0 else 0  # shininess > 0: 0 marks the lanes of pow
        top = max(top, S[_SHN * LANES + k])
    nbits = 0
    while (int(top) >> nbits) > 0:
        nbits += 1
    _geometry(S, cam, ambient)
    if terms:
        for k in range(6 * LANES):
            S[_TD * LANES + k] = 0.0  # _TD and _TS: six fields from _TD on
    if shadows_on:
        _origins(S, XY, F)
    for i in range(lights.shape[0]):
        _direction(S, lights, i, dmin, att_on)
        _cosines(S, spec_on, nblinn < m, nblinn > 0)
        if shadows_on and lights[i, LIGHT_SHADOWS] != 0.0:
            _shadow_pass(S, n, lights, i, handle, unit, Q)
        if spec_on:
            _specular(S, nbits, npow > 0)
        _accumulate(S, lights, i, terms)


@inline_jit(**HELPER)
def _flush(S, XY, n, mixed, filled, materials, F, L, cam, outs, Q, spec_on, att_on, shadows_on, terms):
    """Fill the material fields (once for a batch of one model that the lanes already hold),
    shade the batch and write it (``outs = (image, normal)``; with ``terms``, the kernel writes the
    terms, :func:`_scatter_terms`); returns the model whose row now fills every lane (-1: none)."""
    if mixed:
        for k in range(n):
            _material(S, k, k + 1, materials, XY[2 * LANES + k])
        filled = -1
    elif XY[2 * LANES] != filled:
        filled = XY[2 * LANES]
        _material(S, 0, LANES, materials, filled)
    _shade_batch(S, XY, n, mixed, F, L, cam, Q, spec_on, att_on, shadows_on, terms)
    _scatter(S, XY, n, outs)
    return filled


@inline_jit(**HELPER)
def _scatter(S, XY, n, outs):
    """Write the first ``n`` lanes' colours (plus emission, :func:`.pixelstore.saturate`d in place
    in ``_R`` by a pass over every lane, vectorised) and, when asked for, their shading normals."""
    image, normal = outs
    for c in range(3):
        for k in range(LANES):
            S[(_R + c) * LANES + k] = saturate(S[(_R + c) * LANES + k] + S[(_KE + c) * LANES + k])
    for k in range(n):
        y, x = np.uint64(XY[k]), np.uint64(XY[LANES + k])  # unsigned: no wrap-around test per store
        for c in range(3):
            image[y, x, c] = S[(_R + c) * LANES + k]
    if normal.shape[0] != 0:
        for k in range(n):
            y, x = np.uint64(XY[k]), np.uint64(XY[LANES + k])
            for c in range(3):
                normal[y, x, c] = S[(_N + c) * LANES + k]


def _make_phong_fast(terms_on: bool = False, shadows_on: bool = False):
    """The batched Phong kernel for one variant (see :mod:`.jit`; untextured only). ``terms_on``:
    the kernel that also writes the frame's terms (``render(terms=True)``, never with shadows);
    ``shadows_on``: the frame's lights cast shadows (a scene handle in ``L``), traced from the lanes."""
    if terms_on and shadows_on:  # their scratch fields overlap (see _FIELDS)
        raise ValueError("terms_on and shadows_on: the batched kernel builds one or the other")

    @in_parts
    @njit(nogil=True, **JIT)
    def _shade_phong_fast_kernel(prim, geom, u, v, G, L, face_off, materials, cam, background, modes, outs, part):
        """As :func:`.phong._make_phong`'s kernel for a frame :func:`applies` to, bit for bit.
        ``outs = (image, normal)``: the (h, W, 3) float32 image, and the (h, W, 3) float32 array
        the shading normals of the Phong pixels go to (zero on the background), or
        ``_NO_NORMALS`` for none. The terms kernel's ``outs = (image, normal, R, y0)``: also each
        pixel's terms into the terms record ``R`` (:mod:`.terms_kernel`, without per-light terms)
        at image row ``y0 + y``, the numbers :func:`.terms_kernel._make_phong_terms` writes."""
        spec_on, att_on = L.spec_on, L.att_on  # run-time flags of the frame (records.Lighting)
        if terms_on:  # a closure constant: Numba prunes the other branch before typing
            image, normal, R, y0 = outs
        else:
            image, normal, rays = outs
        bg = (np.float32(background[0]), np.float32(background[1]), np.float32(background[2]))
        pix = (image, normal)  # once: a tuple of arrays built in the loops could keep reference counts there
        h, w = prim.shape
        faces, fnormals = G.faces, G.face_normals
        F = _flat_mesh(G)
        ahead = G.verts.nbytes + G.normals.nbytes + faces.nbytes + fnormals.nbytes > PREFETCH_BYTES
        many = modes.shape[0] > 1  # one model: every hit is model 0's (no model read per pixel)
        mixed_modes = (modes != METHOD_PHONG).any()  # other methods' pixels are other kernels'
        f0 = face_off[0]  # one model: its faces' offset
        # The pixels are queued row by row; with shadows, by 4x4 tiles (each row-major: a packet's 16
        # lanes neighbours both ways, coherent rays), after their strip's background (_strip_background).
        th = _TILE if shadows_on else 1
        tw = _TILE if shadows_on else w
        nblk = (h + BLOCK_ROWS - 1) // BLOCK_ROWS
        step = spread_step(nblk)
        for it in range(*share(nblk, part)):  # this part's blocks of rows, in a balanced order
            blk = (it * step) % nblk
            S = np.zeros(_FIELDS * LANES)
            XY = np.zeros(7 * LANES, np.int64)  # per lane: row, column, model, face, its three vertices
            Q = _packets(4 if shadows_on else 0)  # one shadow packet per 16 lanes (a stand-in without shadows)
            # Not the literals 0, False, -1: inference would also build the helpers for those (unused; 4-5 s)
            n, mixed, filled = np.int64(0), np.bool_(False), np.int64(-1)
            ye = min(h, (blk + 1) * BLOCK_ROWS)
            for ty in range(blk * BLOCK_ROWS, ye, th):  # rows (tiles of rows: see above)
                if shadows_on:
                    _strip_background((prim, geom, u, v), pix, bg, ty, min(ty + th, ye))
                for tx in range(0, w, tw):
                    for y in range(ty, min(ty + th, ye)):
                        for x in range(tx, min(tx + tw, w)):
                            p = prim[y, x]
                            if p < 0:
                                if not shadows_on:  # (a shadowed frame's strip wrote its background)
                                    store_background(pix, y, x, bg)
                                    if terms_on:
                                        _miss(image, R, y, y0 + y, x)
                                continue
                            # Unsigned lane indices. One model: its field stays 0, the batch unmixed.
                            f = f0 + p
                            if many:
                                gm = geom[y, x]
                                if mixed_modes and modes[gm] != METHOD_PHONG:
                                    continue
                                f = face_off[gm] + p
                                XY[np.uint64(2 * LANES + n)] = gm
                                mixed = mixed | ((n > 0) & (gm != XY[2 * LANES]))
                            if ahead:  # the face's row a batch before it is read (_gather)
                                prefetch(faces, f)
                                prefetch(fnormals, f)
                            S[np.uint64(_B1 * LANES + n)] = u[y, x]
                            S[np.uint64(_B2 * LANES + n)] = v[y, x]
                            XY[np.uint64(n)] = y
                            XY[np.uint64(LANES + n)] = x
                            XY[np.uint64(3 * LANES + n)] = f
                            n += 1
                            if n == LANES:
                                _gather(S, XY, n, F, ahead)
                                filled = _flush(S, XY, n, mixed, filled, materials, F, L, cam, pix, Q,
                                                spec_on, att_on, shadows_on, terms_on)
                                if terms_on:
                                    _scatter_terms(S, XY, n, R, y0, L.ambient)
                                else:
                                    hand_over_lanes(S, XY, n, materials, L.unit, rays)
                                n, mixed = np.int64(0), np.bool_(False)
            if n > 0:  # the lanes past n hold an earlier batch's pixels (or zeros): shaded, not written
                _gather(S, XY, n, F, ahead)
                _flush(S, XY, n, mixed, filled, materials, F, L, cam, pix, Q, spec_on, att_on, shadows_on, terms_on)
                if terms_on:
                    _scatter_terms(S, XY, n, R, y0, L.ambient)
                else:
                    hand_over_lanes(S, XY, n, materials, L.unit, rays)

    return _shade_phong_fast_kernel


_PHONG_FAST = _make_phong_fast()  # one build each: the frame's flags are run-time fields of L
_PHONG_FAST_TERMS = _make_phong_fast(terms_on=True)
_PHONG_FAST_SHADOWS = _make_phong_fast(shadows_on=True)
