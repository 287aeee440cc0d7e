"""Reverse-mode gradients through Phong's perturbed shading normal: bump and normal maps.

Only Phong bends the normal (flat shades with the face's true normal, Gouraud with the vertex
normals: both ignore the maps, so their gradients need nothing here). The Phong shading point's
normal is :func:`~raycast_shade.shading.phong._surface`'s chain

    n0 = _shading_normal(...)          the interpolated, renormalised, oriented normal
    n1 = _bump(n0, ...)                Blinn: normalize(A n0 + bu (n0 x Pv) - bv (n0 x Pu))
    n  = _normal_map(n1, ...)          reflect_into(sgn normalize(T' x + B' y + N z), g)

and :func:`_perturbed_vjp` goes back along it from ``dL/dn`` to ``dL/dn0`` (then
:func:`~raycast_shade.shading.grad_normal._normal_vjp` to the vertex normals), recording on the way
the height map's and the normal map's partials. It runs in a pass of its own
(:func:`perturb_partials`), over the bumped models' Phong pixels only, called by the drivers when
such a model is there: the per-pixel gradient kernels of every other scene do not compile it.

- **bump**: ``bu = (h(x + 1/2, y) - h(x - 1/2, y)) cols su scale`` (a one-texel central difference
  of the bilinear height, as :func:`~raycast_shade.shading.bump._bump` computes it; ``bv`` likewise
  in ``y``), negated where the UV map is left-handed. The image is linear in ``bu``, ``bv`` before
  the normalisation, and they are linear in the texels: the four bilinear samples get
  ``+-dL/dbu cols su scale`` (``dL/dbv rows sv scale``), each spread onto its four texels;
- **normal map**: ``x = (2r - 1) s``, ``y = (2g - 1) s``, ``z = 2b - 1`` (``s`` the material's
  ``normal_scale``): ``dL/dr = 2 s dL/da . T'``, ``dL/dg = 2 s dL/da . B'``, ``dL/db = 2 dL/da . N``
  onto level 0's four texels (the forward pass samples level 0, bilinearly).

Kinks of the forward map where the gradient is one-sided or 0: the reflections into the viewer's
hemisphere (``reflect_into``: continuous, a kink where the bent normal grazes the face's plane), the
texel grid's bilinear cell edges (the sample is continuous, its slope jumps at texel centres; for
bump maps at the half-texel offsets), the clamps of ``n.s`` at 0 and of the lobe's cosine, and the
degenerate cases the forward pass falls back from (a zero perturbed normal, a tangent parallel to
the normal: the unperturbed normal is used, and so is its gradient).
"""

from __future__ import annotations

import contextvars
import functools

import numpy as np
from numba import njit

from ..common.layout import BUMP_CLAMP, BUMP_COLS, BUMP_ROWS, METHOD_PHONG
from ..common.parallel import launch, share
from ..visibility.secondary import ray_scratch
from .bump import _bump, _bump_slopes
from .grad_normal import _normal_vjp
from .grad_terms import _plain_vjp, layout
from .grad_texels import grid_scatter, texel_scatter
from .grad_walk import pixel_grad
from .jit import HELPER, JIT
from .normalmap import _nmap_sample
from .phong import _shading_point
from .records import dot
from .surface import _shading_normal, _triangle
from .texture import _point_coefficients

__all__ = ["BUMP_COLUMNS", "BUMPS", "bump_gradients", "perturb_partials"]

PARTS = 16  # as grad_frame.PARTS
BUMPS = ("bump_map", "normal_map")
"""The names :func:`bump_gradients` answers."""
BUMP_COLUMNS = 10
"""Per pixel: the height map's ``(x, y, dL/dbu', dL/dbv')`` (texel coordinates, coefficients of the
four one-texel samples), the normal map's ``(u, v, dL/dr, dL/dg, dL/db)``, and 1 where recorded."""


@njit(**HELPER)
def cross(a, b):
    """``a x b``."""
    return a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]


@njit(**HELPER)
def _bump_vjp(n, B, at, tri, front, gout):
    """Back through :func:`~raycast_shade.shading.bump._bump` at ``n``: ``(dL/dn, (x, y, cu, cv))``
    for ``gout = dL/dn'``; ``cu`` multiplies the samples ``h(x + 1/2, y) - h(x - 1/2, y)``, ``cv``
    those in ``y`` (zeros, and ``gout`` itself, where the forward pass left ``n`` as it was)."""
    none = (0.0, 0.0, 0.0, 0.0)
    k = B.bump_index[at.gm]
    if k < 0:
        return gout, none
    x, y, bu, bv, ku, kv, pu, pv, area = _bump_slopes(B, k, at, tri, front)  # the forward's own lookup
    nxpv = cross(n, pv)
    nxpu = cross(n, pu)
    a = (area * n[0] + bu * nxpv[0] - bv * nxpu[0], area * n[1] + bu * nxpv[1] - bv * nxpu[1],
         area * n[2] + bu * nxpv[2] - bv * nxpu[2])
    al = np.sqrt(dot(a, a))
    if not (al > 0.0 and al < np.inf):
        return gout, none
    u = (a[0] / al, a[1] / al, a[2] / al)
    q = dot(u, gout)
    ga = ((gout[0] - q * u[0]) / al, (gout[1] - q * u[1]) / al, (gout[2] - q * u[2]) / al)
    # a = A n + bu (n x Pv) - bv (n x Pu): g . (n x P) = n . (P x g)
    pvg = cross(pv, ga)
    pug = cross(pu, ga)
    gn = (area * ga[0] + bu * pvg[0] - bv * pug[0], area * ga[1] + bu * pvg[1] - bv * pug[1],
          area * ga[2] + bu * pvg[2] - bv * pug[2])
    return gn, (x, y, ku * dot(ga, nxpv), -kv * dot(ga, nxpu))


@njit(**HELPER)
def _nmap_vjp(n, B, normals, at, tri, g, sgn, gout):
    """Back through :func:`~raycast_shade.shading.normalmap._normal_map` at ``n``: ``(dL/dn,
    (u, v, dL/dr, dL/dg, dL/db))`` for ``gout`` = ``dL/d`` its answer (``gout`` itself and zeros where
    the model has no normal map or the forward pass fell back to ``n``)."""
    k = B.nmap_index[at.gm]
    none = (0.0, 0.0, 0.0, 0.0, 0.0)
    if k < 0:
        return gout, none
    scale = B.nmap_scale[at.gm]
    tu, tv, x, y, z, t, w = _nmap_sample(B, k, at, tri)  # the forward's own lookup
    nn = (sgn * n[0], sgn * n[1], sgn * n[2])
    c = dot(t, nn)
    t1 = (t[0] - c * nn[0], t[1] - c * nn[1], t[2] - c * nn[2])
    tl = np.sqrt(dot(t1, t1))
    if not (tl > 1e-12 and tl < np.inf):
        return gout, none
    th = (t1[0] / tl, t1[1] / tl, t1[2] / tl)
    nxt = cross(nn, th)
    bt = (w * nxt[0], w * nxt[1], w * nxt[2])
    a = (th[0] * x + bt[0] * y + nn[0] * z, th[1] * x + bt[1] * y + nn[1] * z, th[2] * x + bt[2] * y + nn[2] * z)
    al = np.sqrt(dot(a, a))
    if not (al > 0.0 and al < np.inf):
        return gout, none
    m = (sgn * a[0] / al, sgn * a[1] / al, sgn * a[2] / al)
    gm_ = gout
    if dot(m, g) < 0.0:  # reflected across the face's plane: the Householder map is its own transpose
        q = 2.0 * dot(gout, g)
        gm_ = (gout[0] - q * g[0], gout[1] - q * g[1], gout[2] - q * g[2])
    u = (a[0] / al, a[1] / al, a[2] / al)
    q = dot(u, gm_)
    ga = (sgn * (gm_[0] - q * u[0]) / al, sgn * (gm_[1] - q * u[1]) / al, sgn * (gm_[2] - q * u[2]) / al)
    tex = (2.0 * scale * dot(ga, th), 2.0 * scale * dot(ga, bt), 2.0 * dot(ga, nn))
    # a = T' x + w (N x T') y + N z, T' = T1/|T1|, T1 = T - (T.N) N
    gth = (x * ga[0] + w * y * (ga[1] * nn[2] - ga[2] * nn[1]),  # g . (N x T') = T' . (g x N)
           x * ga[1] + w * y * (ga[2] * nn[0] - ga[0] * nn[2]),
           x * ga[2] + w * y * (ga[0] * nn[1] - ga[1] * nn[0]))
    txg = cross(th, ga)  # g . (N x T') = N . (T' x g)
    gN = (z * ga[0] + w * y * txg[0], z * ga[1] + w * y * txg[1], z * ga[2] + w * y * txg[2])
    q = dot(th, gth)
    gt1 = ((gth[0] - q * th[0]) / tl, (gth[1] - q * th[1]) / tl, (gth[2] - q * th[2]) / tl)
    q = dot(nn, gt1)
    gN = (gN[0] - c * gt1[0] - q * t[0], gN[1] - c * gt1[1] - q * t[1], gN[2] - c * gt1[2] - q * t[2])
    return (sgn * gN[0], sgn * gN[1], sgn * gN[2]), (tu, tv) + tex


@njit(**HELPER)
def _perturbed_vjp(G, B, at, hp, gout):
    """``dL/dn0`` of :func:`~raycast_shade.shading.surface._shading_normal`'s answer from ``gout = dL/dn`` of
    the Phong point ``hp``'s (bumped, normal-mapped) normal, with the maps' partials
    ``((x, y, cu, cv), (u, v, dr, dg, db))`` (see :func:`_bump_vjp`, :func:`_nmap_vjp`)."""
    tri = _triangle(G.faces, at.f)
    n0 = _shading_normal(G.normals, tri, at.b1, at.b2, hp.g, hp.sgn)
    front = (hp.sgn * hp.g[0], hp.sgn * hp.g[1], hp.sgn * hp.g[2])
    n1 = _bump(n0, B, at, tri, front)
    g1, nm = _nmap_vjp(n1, B, G.normals, at, tri, hp.g, hp.sgn, gout)
    g0, bp = _bump_vjp(n0, B, at, tri, front, g1)
    return g0, bp, nm


@njit(nogil=True, **JIT)
def _perturb_kernel(hits, G, B, L, T, face_off, materials, cam, modes, gimg, lay, out, gpx, part):
    """Phong pixels of models with a bump or normal map: ``out[y * W + x]`` = the maps' partials
    (:data:`BUMP_COLUMNS`) at the pixel's shading point, its coefficients the forward pass's; and
    ``gpx[y, x]`` = ``dL/da`` of its interpolated normal through the bent one (``gpx`` (H, W, 3),
    or (0, 0, 3) for none)."""
    h, w = hits[0].shape
    _, _, size = lay
    scratch = np.zeros((1, size))  # the parameters' slots: not read (the driver's own pass has them)
    for y in range(*share(h, part)):
        S = ray_scratch()
        for x in range(w):
            shaded, at, gI = pixel_grad(hits, face_off, modes, METHOD_PHONG, gimg, y, x)
            if not shaded or (B.bump_index[at.gm] < 0 and B.nmap_index[at.gm] < 0):
                continue
            gm = at.gm
            coef = _point_coefficients(G, B.uvs, at, cam, x, y, True, materials, T)
            hp = _shading_point(G, B, L, cam, at, np.bool_(False), (0.0, 0.0, 0.0))
            gn, _, _ = _plain_vjp(hp, coef, materials, gm, L, S, gI, scratch, 0, (lay[0], lay[1]))
            g0, bp, nm = _perturbed_vjp(G, B, at, hp, gn)
            if gpx.shape[0] != 0:
                ga = _normal_vjp(G.normals, _triangle(G.faces, at.f), at.b1, at.b2, hp.g, hp.sgn, g0)
                for c in range(3):
                    gpx[y, x, c] = ga[c]
            r = y * w + x
            for c in range(4):
                out[r, c] = bp[c]
            for c in range(5):
                out[r, 4 + c] = nm[c]
            out[r, 9] = 1.0


# The bent normal's pass, shared within one rs.grad call (:func:`one_bent_pass`): the height and normal
# maps' texels and the vertex normals read the same pass. None outside such a call.
_SHARED: contextvars.ContextVar = contextvars.ContextVar("raycast_shade_bent_pass", default=None)


def one_bent_pass(fn):
    """``fn`` (:func:`raycast_shade.grad`) with one bent-normal pass per call: within it,
    :func:`perturb_partials` runs once for a hit buffer and ``dL/dI`` and hands its answers to every
    later caller of the same call (the texels' gradients first, then the vertex normals'); kept only
    for the call's duration."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        token = _SHARED.set({})
        try:
            return fn(*args, **kwargs)
        finally:
            _SHARED.reset(token)

    return wrapper


def perturb_partials(hits, inputs, modes, gimg, gpx=None) -> np.ndarray:
    """(H * W, :data:`BUMP_COLUMNS`) per pixel (row-major) of the bump- and normal-mapped Phong
    models: the maps' partials at its shading point (zero rows elsewhere). ``gpx`` (H, W, 9), if
    given: those pixels' ``dL/da`` (its first three columns) written through the bent normal, in
    place of the unbent chain's (the caller's Phong pass wrote the others): a pass of its own, so
    the per-pixel kernels of every other scene compile without it. Within :func:`one_bent_pass`,
    run once per ``(hits, inputs, modes, gimg)`` (the same objects): later calls read the first's."""
    shared = _SHARED.get()
    key = (id(hits), id(inputs), id(modes), id(gimg))
    if shared is not None and key in shared:
        _, out, ga = shared[key]
    else:
        L = inputs.lighting
        amb, lb, size = layout(inputs.materials.shape[0], L.lights.shape[0])
        out = np.zeros((hits.prim.size, BUMP_COLUMNS))
        ga = np.zeros(hits.prim.shape + (3,) if gpx is not None or shared is not None else (0, 0, 3))
        launch(_perturb_kernel, (hits.prim, hits.geom, hits.u, hits.v), inputs.geometry, inputs.bumps, L,
               inputs.colours, inputs.face_off, inputs.materials, inputs.cam, modes, gimg,
               (np.int64(amb), np.int64(lb), np.int64(size)), out, ga, parts=PARTS, dynamic=True)
        if shared is not None:  # the objects kept with it: their ids stay theirs for the call
            shared[key] = ((hits, inputs, modes, gimg), out, ga)
    if gpx is not None:
        rec = (out[:, 9] != 0.0).reshape(hits.prim.shape)
        gpx[rec, :3] = ga[rec]
    return out


def bump_gradients(hits, inputs, modes, gimg, names) -> dict:
    """``dL/d`` the height maps' and normal maps' texels named in ``names`` (``"bump_map"``,
    ``"normal_map"``): per model a tuple entry, the (rows, cols) heights' gradient (rows as the
    :class:`~raycast_shade.HeightMap`'s ``heights``) or the (h, w, 3) normal map texels' (level 0,
    rows as its ``Texture.texels``), None for a model without one. Summed over the Phong pixels in
    row-major order (deterministic); flat and Gouraud ignore the maps (0)."""
    B = inputs.bumps
    part = perturb_partials(hits, inputs, modes, gimg)
    geom = hits.geom.ravel()
    rec = part[:, 9] != 0.0
    out = {}
    if "bump_map" in names:
        maps = []
        for m in range(B.bump_index.shape[0]):
            k = B.bump_index[m]
            if k < 0:
                maps.append(None)
                continue
            info = B.bump_info[k]
            sel = rec & (geom == m)
            x, y, cu, cv = (part[sel, c] for c in range(4))
            xs = np.concatenate([x + 0.5, x - 0.5, x, x])
            ys = np.concatenate([y, y, y + 0.5, y - 0.5])
            g = np.concatenate([cu, -cu, cv, -cv])[:, None]
            grid = grid_scatter(int(info[BUMP_ROWS]), int(info[BUMP_COLS]), info[BUMP_CLAMP] != 0.0, xs, ys, g)
            maps.append(grid[:, :, 0])
        out["bump_map"] = tuple(maps)
    if "normal_map" in names:
        maps = []
        for m in range(B.nmap_index.shape[0]):
            k = B.nmap_index[m]
            if k < 0:
                maps.append(None)
                continue
            sel = rec & (geom == m)
            maps.append(texel_scatter(B.nmap_info, k, part[sel, 4:6], part[sel, 6:9]))
        out["normal_map"] = tuple(maps)
    return out
