"""Ray casting into a hit buffer.

Two casters fill the same :class:`HitBuffer` with the camera's rays:

``"embree"`` (default)
    One parallel Numba kernel generates the camera rays in 4x4-pixel tiles,
    traces each tile as a 16-ray packet with ``rtcIntersect16``, flagged
    coherent so that the primary rays share BVH traversal, unpacks the
    hits and counts the pixels that show a vertex slip's marks (below) while
    their rows are in cache. Nothing crosses
    into Python per ray or per chunk.
``"embreex"``
    Rays from a Numba kernel, then embreex's ``EmbreeScene.run`` over chunks
    in two Python threads (its loop releases the GIL): the baseline in the
    benchmarks, for camera rays only.

What works without the direct binding (:func:`.embree.unavailable_reason`):
camera rays, through embreex, and nothing else. :func:`cast_rays`, shadow
rays and mirror rays exist only on the direct binding. So ``caster="auto"``
(:func:`resolve_caster`) is ``"embree"`` when the binding loads; otherwise it
falls back to ``"embreex"`` for a frame that traces no other ray (no light
casting shadows, no mirror bounce: :func:`secondary_rays`), and refuses any
other frame with one ``RuntimeError`` naming what needs the binding and why it
is unavailable, before any kernel runs. ``caster="embree"`` without the
binding, and :func:`cast_rays` without it, raise the same way.

Holes and leaks. Embree's robust mode is watertight across shared edges but
not at shared vertices: a ray that passes (to float32 rounding) through a
vertex meets edge functions smaller than their rounding error on every spoke
of the fan, and can slip between all its triangles, returning what lies
behind (the far side of a closed mesh, a floor) or nothing (measured: 55 of
12,288 perspective rays aimed at the vertices of a grid missed; 0.9% of rays
aimed at the vertices of icosphere(5) from outside hit its far side). The
repair re-tests the suspect rays' *own* hit exactly, in float64, with a test
that is watertight at vertices (:mod:`.watertight`), against the triangles
around a candidate found by a nearby ray:

* camera rays (both casters, :mod:`.holes`): the pixels that show a slip's
  marks -- a miss between hits, or a hit farther than both neighbours (left
  and right, or above and below) by more than 1e-3 of their depth -- take
  candidates from four rays 1e-3 pixel from the centre (then 1e-2 pixel),
  and the exact hit where it is nearer; a miss with no exact hit takes the
  nearest jittered hit. Every other pixel is the plain cast's; genuine gaps
  and holes stay open (their nearby rays find nothing nearer).
* :func:`cast_rays` (``watertight=True``, the default), and
  :func:`cast_recentred` for callers holding re-centred rays (the
  single-sided probe; mirror bounces go as packets, without this repair): every ray is re-cast once, nudged sideways by 2e-6 of the
  scene's scale and stopped just short of its first hit; where that finds a
  nearer surface, the exact re-test decides (see :func:`cast_rays`).
"""

from __future__ import annotations

import threading

import numpy as np
from numba import njit
from ..common.inline import inline_jit

from ..common.choices import CASTERS
from ..common.parallel import KERNEL, in_parts, share
from . import embree
from .accel import embree_accel, embreex_scene
from ..common.schedule import BLOCK_ROWS, spread_step
from ..common.validate import as_array
from .hits import HitBuffer, convex_hits, convex_rows, convex_uv, image_buffer
from ..common.layout import CAM_ORTHO
from . import holes
from .holes import empty_hits, fill_holes, rays_at, row_suspicious
from .watertight import nudged_rays, refine
from .rays import camera_frame, generate_rays, offset_pair, subpixel_camera
from .tiles import LANES, RAY, TILE_H, TILE_W, edge_hits, fixed_slots, row_terms, tile_columns, tile_hits, tile_rays
from .tiles import tile_valid

__all__ = ["cast_camera", "cast_rays", "cast_recentred", "resolve_caster", "secondary_rays", "CASTERS"]


_RAY = RAY  # float32 slots in one RTCRayHit (96 bytes, room for instPrimID)
_TILE_W, _TILE_H, _LANES = TILE_W, TILE_H, LANES  # a 16-ray packet is a 4x4 tile (see .tiles)


@inline_jit(cache=True, forceinline=True, _nrt=False)
def _convex_tile(uf, vf, o, w, nx, ny):
    """A tile's barycentrics onto their triangles (:func:`.hits.convex_uv`), while in cache: the
    ``nx`` x ``ny`` pixels from flat index ``o`` of the (R W,) arrays, rows ``w`` apart."""
    for j in range(ny):
        for i in range(nx):
            q = o + j * w + i
            a, b = uf[q], vf[q]
            if not (a >= 0.0 and b >= 0.0 and np.float64(a) + np.float64(b) <= 1.0):  # a few a frame
                uf[q], vf[q] = convex_uv(a, b)


@in_parts
@njit(**KERNEL)
def _cast_camera_parts(scene, cam, prim, geom, u, v, t, y0, top, lo, hi, counts, jump, part):
    """Cast rows ``top ..`` of the (R, W) window into its hit arrays, and count the suspicious
    pixels (:func:`.holes.row_suspicious`, depth jumps past ``jump``) of its rows ``lo .. hi``.

    Window row ``r`` is image row ``y0 + r``; rows ``0 .. top`` are already cast (a band's
    neighbours, read by the test), and the tiles are laid from row ``top`` (so a band whose
    ``y0 + top`` is a multiple of ``_TILE_H`` traces the very packets the whole frame does; the
    whole frame is ``y0 = top = lo = 0``, ``hi = R``). Each block of tile rows counts a row of
    ``lo .. hi`` into ``counts`` (R,) int64 as soon as the row and both its neighbours are cast
    by the block (or are rows before ``top``, or outside the window), while the rows are in
    cache; the rows on either side of a block boundary keep ``-1``, for
    :func:`.holes.finish_counts`. Rows outside ``lo .. hi`` keep what ``counts`` held. The
    caller sets rows ``lo .. hi`` to ``-1`` first (:func:`_cast_camera_kernel`): no part may undo
    another's count."""
    n, w = prim.shape
    if not (0 <= top <= n and 0 <= lo <= hi <= n <= counts.shape[0]):  # no bounds checks below
        raise ValueError("_cast_camera_parts: rows top, lo .. hi beyond the window or its counts")
    ntx = (w + _TILE_W - 1) // _TILE_W
    nty = (n - top + _TILE_H - 1) // _TILE_H
    nblk = nty  # blocks of one tile row when there are too few for several a thread; else of about
    if nty >= 4 * BLOCK_ROWS:  # BLOCK_ROWS, a multiple of 4 of them: prange gives each of 1, 2 or 4 threads
        nblk = (nty + 4 * BLOCK_ROWS - 1) // (4 * BLOCK_ROWS) * 4  # as many (480 rows: 16, not 15 split 8/7)
    step = spread_step(nblk)
    ortho = cam[CAM_ORTHO] != 0.0
    far = 1.0 + jump
    ct = tile_columns(cam, ntx, ortho)
    pf, gf, uf, vf, tf = prim.reshape(n * w), geom.reshape(n * w), u.reshape(n * w), v.reshape(n * w), t.reshape(n * w)
    for it in range(*share(nblk, part)):  # this part's blocks of rows, in a balanced order
        blk = (it * step) % nblk
        # Per-block scratch: a 16-wide RTCRayHit16 (64-byte aligned) and its valid mask.
        # Addresses are taken only to align; Embree gets the arrays (see embree.intersect16_packet).
        buf = np.empty(_LANES * _RAY + 16, np.float32)
        off = ((64 - buf.ctypes.data % 64) % 64) // 4
        vbuf = np.empty(2 * _LANES, np.int32)
        voff = ((64 - vbuf.ctypes.data % 64) % 64) // 4
        # RTCIntersectArguments (8-byte aligned): the coherent flag lets
        # Embree trace the tile's rays as one frustum.
        abuf = np.empty(embree.ARGS_SLOTS + 2, np.uint32)
        abuf[:] = 0  # (np.zeros would build two more of Numba's overloads at a cold start)
        aoff = ((8 - abuf.ctypes.data % 8) % 8) // 4
        abuf[aoff] = embree.RAY_QUERY_FLAG_COHERENT
        abuf[aoff + 1] = embree.FEATURE_FLAG_ALL
        # Views taken once a block, not per tile (each view costs a reference count).
        pk, vv, args = buf[off:off + _LANES * _RAY], vbuf[voff:voff + _LANES], abuf[aoff:]
        pu = pk.view(np.uint32)
        fixed_slots(pk, pu, cam, ortho)
        rt = np.empty(3 * _LANES, np.float64)
        shape = -1  # the valid mask's tile shape, 4 nx + ny (rewritten only when it changes)
        ty0, ty1 = blk * nty // nblk, (blk + 1) * nty // nblk  # the block's tile rows (sizes differ by <= 1)
        r0 = top + ty0 * _TILE_H  # the block's first window row
        for ty in range(ty0, ty1):
            r = top + ty * _TILE_H
            ny = min(_TILE_H, n - r)
            row_terms(rt, cam, y0 + r)
            for tx in range(ntx):
                x0 = tx * _TILE_W
                nx = min(_TILE_W, w - x0)
                if _TILE_W * nx + ny != shape:
                    shape = _TILE_W * nx + ny
                    tile_valid(vv, nx, ny)
                tile_rays(pk, pu, vv, ct, tx, rt, ortho)
                embree.intersect16_packet(vv, scene, pk, args)
                if shape == _TILE_W * _TILE_W + _TILE_H:
                    tile_hits(pk, pu, r * w + x0, w, pf, gf, uf, vf, tf)
                else:
                    edge_hits(pk, pu, x0, r, nx, ny, prim, geom, u, v, t)
                _convex_tile(uf, vf, r * w + x0, w, nx, ny)
            # The vertex-slip test of the rows whose neighbours are now cast (rows r0 .. c are).
            c = r + ny
            for q in range(max(lo, r - 1), min(hi, c)):
                if (q - 1 < top or q - 1 >= r0) and (q + 1 < c or q + 1 >= n) and (q >= r0 or q < top):
                    counts[q] = row_suspicious(prim, t, far, q)


@in_parts
@njit(**KERNEL)
def cast_rays_kernel(scene, origins, directions, tnear, tfar, prim, geom, u, v, t, part):
    n = origins.shape[0]
    chunk = 256
    nchunks = (n + chunk - 1) // chunk
    nchunk = nchunks
    step = spread_step(nchunk)
    for it in range(*share(nchunk, part)):  # this part's chunks, in a balanced order
        c = (it * step) % nchunk
        buf = np.empty(_RAY + 4, np.float32)
        off = ((16 - buf.ctypes.data % 16) % 16) // 4  # RTCRayHit is 16-byte aligned
        ib = buf.view(np.uint32)
        for i in range(c * chunk, min(n, (c + 1) * chunk)):
            embree.write_ray(buf, ib, off, np.int64(1), (origins[i, 0], origins[i, 1], origins[i, 2]),
                             (directions[i, 0], directions[i, 1], directions[i, 2]), tnear[i], tfar[i])
            embree.reset_hit(ib, off, np.int64(1))
            embree.intersect1_ray(scene, buf[off:])
            geom[i], prim[i], hu, hv, t[i] = embree.read_hit(buf, ib, off, np.int64(1))
            u[i], v[i] = convex_uv(hu, hv)  # onto the triangle (Embree's may stray an ulp)


cast_rays_serial = cast_rays_kernel.serial  # a handful of rays: no threads to wake (the same build)


def _cast_camera_kernel(scene, cam, prim, geom, u, v, t, y0, top, lo, hi, counts, jump) -> None:
    """:func:`_cast_camera_parts` over every part, rows ``lo .. hi`` of ``counts`` undecided
    (``-1``) until a block counts them."""
    n = prim.shape[0]
    if not (0 <= top <= n and 0 <= lo <= hi <= n <= counts.shape[0]):
        raise ValueError("_cast_camera_kernel: rows top, lo .. hi beyond the window or its counts")
    counts[lo:hi] = -1
    _cast_camera_parts(scene, cam, prim, geom, u, v, t, y0, top, lo, hi, counts, jump)
SERIAL_BELOW = 1024  # rays: fewer are cast serially by _cast_points (chosen by measurement, docs/performance.md)


def secondary_rays(scene, max_depth: int) -> tuple[str, ...]:
    """What a frame of ``scene`` traces besides its camera rays, named for an error.

    Parameters
    ----------
    scene : Scene
    max_depth : int
        Mirror bounces (``render(max_depth=...)``).

    Returns
    -------
    tuple of str
        ``"shadow rays (scene.lights[i])"`` for each light that casts
        shadows, and ``"mirror rays (scene.models[g])"`` for each reflective
        model when ``max_depth > 0``; empty when the frame needs camera rays
        alone. Each needs the direct binding.
    """
    needs = [f"shadow rays (scene.lights[{i}])" for i, light in enumerate(scene.lights) if light.shadows]
    if max_depth > 0:
        needs += [f"mirror rays (scene.models[{g}])" for g, m in enumerate(scene.models) if m.material.reflectivity > 0]
    return tuple(needs)


def resolve_caster(caster: str, needs: tuple[str, ...] = ()) -> str:
    """The camera-ray caster that will run: ``"embree"`` or ``"embreex"``.

    Parameters
    ----------
    caster : {"auto", "embree", "embreex"}
    needs : tuple of str
        What else the frame traces (:func:`secondary_rays`); each needs the
        direct binding whatever the caster.

    Raises
    ------
    ValueError
        For an unknown caster.
    RuntimeError
        When the direct binding is unavailable and ``caster`` is
        ``"embree"`` or ``needs`` is not empty; the message names both what
        needs it and why it is unavailable.
    """
    if not isinstance(caster, str) or (caster not in CASTERS and caster != "auto"):
        raise ValueError(f"caster: expected one of {list(CASTERS)} or 'auto', got {caster!r}")
    if embree.available():
        return "embree" if caster == "auto" else caster
    why = embree.unavailable_reason()
    if needs:
        shown = ", ".join(needs[:3]) + (f" and {len(needs) - 3} more" if len(needs) > 3 else "")
        raise RuntimeError(f"{shown} need the direct Embree binding (embreex's API casts camera rays only), "
                           f"which is unavailable: {why}")
    if caster == "embree":
        raise RuntimeError(f"caster 'embree' is unavailable: {why}")
    return "embreex"


def cast_camera(geometry, camera, caster: str = "auto", threads: int = 2, *, offset=None, out=None) -> HitBuffer:
    """Cast one ray through every pixel centre (or the same point off each centre).

    Parameters
    ----------
    geometry : SceneGeometry or Scene
    camera : Camera
    caster : {"auto", "embree", "embreex"}
        See :func:`resolve_caster`: ``"auto"`` is ``"embreex"`` when the
        direct binding is unavailable.
    threads : int
        Python threads for the ``"embreex"`` caster.
    offset : (dx, dy), optional
        Sub-pixel offset in pixels (``y`` down): the rays pass through
        ``(x + 0.5 + dx, y + 0.5 + dy)``, as anti-aliasing needs
        (:func:`~raycast_shade.visibility.rays.subpixel_camera`). ``None`` or
        ``(0, 0)``: the pixel centres.
    out : HitBuffer, optional
        (H, W) int32/int32/float32/float32/float32 C-contiguous arrays to fill
        in place (every pixel is written) instead of fresh ones: the samples
        of an anti-aliased frame reuse one buffer.

    Returns
    -------
    HitBuffer
        (H, W) arrays (``out`` when given).

    Raises
    ------
    TypeError, ValueError
        For an ``out`` that does not fit the image, before any kernel runs.
    RuntimeError
        ``caster="embree"`` without the direct binding (the reason is in the
        message), before any kernel runs.
    """
    from ..scene.camera import Camera
    from ..scene.scene import as_geometry

    geometry = as_geometry(geometry)
    if not isinstance(camera, Camera):
        raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
    if offset is not None:
        camera = subpixel_camera(camera, *offset_pair(offset))
    caster = resolve_caster(caster)
    h, w = camera.height, camera.width
    out = None if out is None else image_buffer(out, h, w)
    check_camera_reach(geometry, camera)
    if camera.distorted:  # exact rays through the distorted pixel centres
        return _cast_distorted(geometry, camera, out)
    cam = camera_frame(camera, geometry.origin)
    if caster == "embree":
        hits = image_buffer(out, h, w)  # the kernel writes every pixel
        counts = np.empty(h, np.int64)
        _cast_camera_kernel(embree_accel(geometry).handle, cam, *hits, 0, 0, 0, h, counts, holes._JUMP)
        _fill_holes(geometry, cam, hits, caster, counts=counts)
        return hits
    origins, directions = generate_rays(camera, geometry.origin)
    res = run_embreex(embreex_scene(geometry), origins, directions, threads)
    miss = res["geomID"] < 0
    hits = HitBuffer(
        prim=np.where(miss, -1, res["primID"]).astype(np.int32).reshape(h, w),
        geom=np.where(miss, -1, res["geomID"]).astype(np.int32).reshape(h, w),
        u=np.where(miss, 0.0, res["u"]).astype(np.float32).reshape(h, w),
        v=np.where(miss, 0.0, res["v"]).astype(np.float32).reshape(h, w),
        t=np.where(miss, np.inf, res["tfar"]).astype(np.float32).reshape(h, w),
    )
    if out is not None:
        for dst, src in zip(out, hits):
            dst[...] = src
        hits = out
    _fill_holes(geometry, cam, hits, caster)
    return hits


def _cast_distorted(geometry, camera, out=None) -> HitBuffer:
    """A distorted camera's hits: :func:`cast_rays` along :func:`.distortion.ray_directions`;
    pixels without a ray (beyond a fold of the lens model) are misses."""
    from .distortion import ray_directions

    d, ok = ray_directions(camera)
    d[~ok] = camera.basis[2]  # any valid direction: the ray gets no length
    flat = cast_rays(geometry, np.broadcast_to(camera.eye, d.shape), d, 0.0, np.where(ok, np.inf, 0.0))
    hits = image_buffer(out, camera.height, camera.width)
    for dst, src, empty in zip(hits, flat, (-1, -1, 0.0, 0.0, np.inf)):
        dst[...] = np.where(ok, src, empty).reshape(camera.height, camera.width)
    return hits


def check_camera_reach(geometry, camera) -> None:
    """ValueError naming ``camera.eye`` when its rays start beyond Embree's float32 range."""
    reach = float(np.abs(camera.eye - geometry.origin).max())
    if camera.orthographic:  # rays start anywhere on the view rectangle around the eye
        reach += 0.5 * camera.ortho_height * float(np.hypot(camera.width / camera.height, 1.0))
    embree.check_range(reach, "camera.eye")


def _cast_points(geometry, cam, xs, ys, caster) -> HitBuffer:
    """The caster's hits for rays through image points (not pixel centres)."""
    o, d = rays_at(cam, xs, ys)
    n = len(xs)
    if caster == "embree":
        hits = empty_hits(n)
        kernel = cast_rays_serial if n < SERIAL_BELOW else cast_rays_kernel  # same bits (rays are independent)
        kernel(embree_accel(geometry).handle, o, d, np.zeros(n), np.full(n, np.inf), *hits)
        return hits
    res = run_embreex(embreex_scene(geometry), o.astype(np.float32), d.astype(np.float32), 1)
    geom = res["geomID"].astype(np.int32)
    return HitBuffer(prim=np.where(geom < 0, -1, res["primID"]).astype(np.int32), geom=geom,
                     u=res["u"].astype(np.float32), v=res["v"].astype(np.float32),
                     t=np.where(geom < 0, np.inf, res["tfar"]).astype(np.float32))


def _fill_holes(geometry, cam, hits, caster, rows=None, y0=0, counts=None):
    """Re-test the pixels whose ray may have slipped through a vertex (:mod:`.holes`); in place.
    ``rows``, ``y0``: a band of the image; ``counts``: the camera kernel's (see
    :func:`.holes.fill_holes`)."""
    scene = embree_accel(geometry).handle if caster == "embree" else None  # the serial repair: few rays
    fill_holes(geometry, cam, hits, lambda xs, ys: _cast_points(geometry, cam, xs, ys, caster), rows, y0, counts,
               scene, SERIAL_BELOW)
    # The repaired pixels' barycentrics (float64 rounded to float32, or a jittered ray's) onto their
    # triangles: the rows the repair counted (the camera kernel's own hits are already), else every row.
    lo, hi = (0, hits.prim.shape[0]) if rows is None else rows
    if counts is None:
        convex_rows(hits, (lo, hi))
    else:
        convex_rows(hits, lo + np.flatnonzero(counts[lo:hi] > 0))


def run_embreex(embreex_scene, origins, directions, threads: int = 2):
    """embreex ``run(output=1)`` over contiguous chunks in Python threads.

    Parameters
    ----------
    origins, directions : (N, 3) float32, C-contiguous

    Returns
    -------
    dict of (N,) arrays: ``u``, ``v``, ``tfar``, ``primID``, ``geomID``
    """
    n = len(origins)
    threads = max(1, min(int(threads), n))
    bounds = np.linspace(0, n, threads + 1).astype(int)
    parts = [None] * threads

    def work(i):
        a, b = bounds[i], bounds[i + 1]
        parts[i] = embreex_scene.run(origins[a:b], directions[a:b], output=1)

    if threads == 1:
        work(0)
    else:
        pool = [threading.Thread(target=work, args=(i,)) for i in range(threads)]
        for th in pool:
            th.start()
        for th in pool:
            th.join()
    keys = ("u", "v", "tfar", "primID", "geomID")
    return {k: np.concatenate([p[k] for p in parts]) for k in keys}


def _ray_bound(value, name: str, n: int) -> np.ndarray:
    """``tnear``/``tfar`` as (n,) float64: a scalar or one value per ray; NaN refused, inf allowed."""
    arr = as_array(value, name, dtype=np.float64, finite=False)
    if np.ndim(value) == 0:
        arr = arr.reshape(())
    if np.isnan(arr).any():
        raise ValueError(f"{name}: NaN")
    if arr.ndim > 1 or (arr.ndim == 1 and len(arr) != n):
        raise ValueError(f"{name}: expected a number or {n} values, got shape {arr.shape}")
    return np.broadcast_to(arr, (n,)).copy()


def cast_rays(geometry, origins, directions, tnear=0.0, tfar=np.inf, watertight: bool = True) -> HitBuffer:
    """Trace arbitrary rays in the scene's world coordinates (direct Embree).

    Parameters
    ----------
    geometry : SceneGeometry or Scene
    origins, directions : (N, 3) float
        World coordinates; directions need not be unit (``t`` is in units of
        ``|direction|``).
    tnear, tfar : float or (N,) float
    watertight : bool
        Repair rays that slip through shared vertices (default). Embree's
        robust mode is watertight at edges, not at vertices: aimed at the
        vertices of a closed icosphere(5) from outside, 0.9% of rays pass
        through and return the far side (or nothing from inside). Every ray
        is cast a second time, nudged sideways by ``2e-6`` of the scene's
        scale (reach plus the origin's distance from its centre) and with
        ``tfar`` just short of the first hit; where the nudged ray meets a
        nearer surface, the original ray is re-tested exactly (float64,
        watertight at vertices: :mod:`.watertight`) against every triangle
        sharing a vertex with the one the nudged ray met, and its exact hit
        replaces Embree's when nearer by more than ``1e-4`` of Embree's
        distance (or Embree missed). Other rays keep Embree's hit bit for
        bit. Cost: a second, shorter traversal (about 1.7x the time of
        ``watertight=False`` at 1M rays; benchmarks/vertex_rays.py). Not
        repaired: a ray within about 1e-2 in cosine of tangent to the faces
        at the vertex, whose nudged twin can leave the mesh (measured: 2 of
        60,123 rays at icosphere(6)'s vertices from 100 radii), triangles
        smaller than about ``1e-5`` of the scale, and a slip onto a surface
        less than ``1e-4`` of the distance behind.

    Returns
    -------
    HitBuffer
        (N,) arrays: ``prim``, ``geom`` int32 (``-1`` on a miss), ``u``,
        ``v``, ``t`` float32 (``t`` is ``inf`` on a miss). It unpacks as
        ``prim, geom, u, v, t = cast_rays(...)``.

    Raises
    ------
    TypeError, ValueError
        Naming the argument, before Embree sees it: wrong shapes, non-finite
        origins or directions, zero directions, NaN or negative bounds,
        ``tfar < tnear``, origins beyond Embree's float32 range, a
        ``watertight`` that is not a bool.
    RuntimeError
        When the direct binding is unavailable (embreex has no route for
        these rays), naming the reason, before any kernel runs.
    """
    from ..scene.scene import as_geometry

    geometry = as_geometry(geometry)
    if not isinstance(watertight, (bool, np.bool_)):
        raise TypeError(f"watertight: expected a bool, got {type(watertight).__name__}")
    o = as_array(origins, "origins", dtype=np.float64, shape=(None, 3)) - geometry.origin
    d = as_array(directions, "directions", dtype=np.float64, shape=(None, 3))
    n = len(o)
    if len(d) != n:
        raise ValueError(f"directions: expected {n} rows like origins, got {len(d)}")
    if n and not (np.abs(d).max(axis=1) > 0).all():
        raise ValueError(f"directions: row {int(np.argmin(np.abs(d).max(axis=1)))} is the zero vector")
    tn, tf = (_ray_bound(value, name, n) for value, name in ((tnear, "tnear"), (tfar, "tfar")))
    if np.isinf(tn).any() or (tn < 0).any():
        raise ValueError("tnear: expected finite values >= 0")
    if (tf < tn).any():
        raise ValueError(f"tfar: row {int(np.argmax(tf < tn))} is below tnear")
    if n:
        embree.check_range(float(np.abs(o).max()), "origins")
    if not embree.available():
        raise RuntimeError(f"cast_rays needs the direct Embree binding, which is unavailable: "
                           f"{embree.unavailable_reason()}")
    return cast_recentred(geometry, np.ascontiguousarray(o), np.ascontiguousarray(d), tn, tf, bool(watertight))


def cast_recentred(geometry, origins, directions, tnear, tfar, watertight: bool = True) -> HitBuffer:
    """:func:`cast_rays` for callers holding checked, re-centred rays (mirror bounces).

    Parameters
    ----------
    geometry : SceneGeometry
    origins, directions : (N, 3) float64, C-contiguous
        Re-centred (world minus ``geometry.origin``), finite, directions not zero.
    tnear, tfar : (N,) float64
        ``0 <= tnear <= tfar``.
    watertight : bool
        The vertex repair of :func:`cast_rays` (default on).

    Returns
    -------
    HitBuffer
        (N,) arrays, as :func:`cast_rays`.
    """
    n = len(origins)
    hits = HitBuffer(prim=np.empty(n, np.int32), geom=np.empty(n, np.int32), u=np.empty(n, np.float32),
                     v=np.empty(n, np.float32), t=np.empty(n, np.float32))
    if n == 0:
        return hits
    accel = embree_accel(geometry).handle
    cast_rays_kernel(accel, origins, directions, tnear, tfar, *hits)
    if watertight:
        _retest_rays(geometry, accel, origins, directions, tnear, tfar, hits)
    return hits


def _retest_rays(geometry, accel, o, d, tn, tf, hits) -> None:
    """The vertex repair of :func:`cast_rays` (see its ``watertight``); updates ``hits`` in place."""
    no, limit = nudged_rays(geometry, o, d, tn, tf, hits)
    nudged = empty_hits(len(o))
    cast_rays_kernel(accel, no, d, tn, limit, *nudged)
    sel = np.flatnonzero(nudged.geom >= 0)
    if len(sel) == 0:
        return
    exact = refine(geometry, o[sel], d[sel], tn[sel], limit[sel], HitBuffer(*(a[sel] for a in nudged)))
    ok = exact.geom >= 0
    convex_hits(exact.u, exact.v)  # the exact test's float64 weights, rounded to float32: onto the triangle
    for arr, new in zip(hits, exact):
        arr[sel[ok]] = new[ok]
