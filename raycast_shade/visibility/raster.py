"""The reference z-buffer rasterizer: the same hit buffer as the ray caster.

The lecture's interpolation shading runs on a scan converter: project the
vertices, fill each triangle's pixels, keep the nearest. This module is that
scan converter, written so that its :class:`~raycast_shade.visibility.hits.HitBuffer`
can be compared with Embree's pixel for pixel and shaded by the very same
kernels (``render(..., backend="raster")``).

Pipeline (Numba kernels in :mod:`.scan`, no write races)
--------------------------------------------------------
1. **Vertices** to camera space ``(x, y, z)`` (``z`` along the view axis) and
   to pixel coordinates; pixel ``(x, y)`` (``y`` down) has its centre at
   ``(x + 0.5, y + 0.5)``, exactly as in :func:`raycast_shade.visibility.rays.pixel_ray`.
2. **Set-up and binning**, in chunks of faces: each face's bounding box of
   pixel centres, clipped to the screen. Most faces of a dense mesh hold no
   pixel centre and stop here; a face whose box holds exactly one is tested
   against it at once. The rest are binned into bands of ``BAND_HEIGHT``
   rows, keeping face order within a band.
3. **Scan conversion and resolve** (:mod:`.raster_band`), a few bands per part
   (``launch``'s parts handed out one at a time): the band owns its rows and its
   own z-buffer, so no two threads write the same pixel. Per face and row, the
   span of candidate pixels is solved from the three edge functions and widened
   by a pixel; each candidate is then tested exactly and depth-tested. The faces
   turned to the eye are drawn first; the others then skip the tiles whose
   z-buffer is surely nearer (ties go to the lower face index either way, so
   the order changes no pixel). Once the band's faces are done, each pixel's ray
   is intersected with its winning face's plane to give the barycentrics and
   the distance.

Meshes under ``50,000`` faces run stages 1-2 serially (a parallel region
would cost more than the work).

Conventions
-----------
Coverage
    Edge functions ``(a - p) x (b - p)`` in float64 on the projected
    vertices, evaluated directly at each pixel centre ``p`` (the row's terms
    hoisted). This form is exactly antisymmetric in ``a, b`` (products
    commute, differences change sign exactly), so two faces sharing an edge
    compute bit-identical values of opposite sign, with no rounding in
    between; a pixel centre exactly on an edge goes to the face for which it
    is a *top* or *left* edge. A watertight mesh therefore has no cracks and
    no pixel covered twice by one surface layer. Both windings are drawn
    (two-sided, as the ray caster); zero-area faces are not.
Near plane
    Perspective: faces are clipped in camera space against ``z = near``
    (default ``NEAR_FRACTION`` of the scene's bounding-box diagonal). A clip
    point is computed from its edge's lexicographically smaller end, so
    neighbours clip a shared edge to the same point, and the clipped polygon
    (a triangle or a quad) is fanned into triangles. Orthographic: the same
    clip at ``z = 0``, the image plane the rays start from.
Depth
    A float64 z-buffer of ``-1/z`` (perspective; orthographic: ``z``), which
    is affine in screen space on a planar face: the plane through the three
    projected vertices (for a clipped face, the face's own plane in camera
    space), clamped to the face's range. On one pixel's ray ``1/z`` falls as
    the distance ``t`` grows, so the test orders fragments exactly as a test
    on the true distance does, without the precision loss of a normalised
    window-space depth. Ties go to the lower face index.
Barycentrics and ``t``
    ``u, v`` are the *perspective-correct* barycentrics of vertices 1 and 2
    of the 3D point seen through the pixel centre, and ``t`` its distance
    from the eye along the unit ray (orthographic: from the image plane along
    the view direction): Embree's ``u, v, t``, computed in float64 from the
    ray-plane intersection and clamped to the triangle.

:func:`coverage_count` runs the same scan conversion without the depth test
and counts, per pixel, the faces that cover it (for watertightness checks).
"""

from __future__ import annotations

import time

import numpy as np

from ..common.parallel import launch
from ..scene.camera import Camera
from .alpha import masked_geometries
from .hits import HitBuffer, image_buffer
from .rays import offset_pair, subpixel_camera
from .raster_band import _raster_kernel
from .scan import _CHUNK, _bin_fill_par, _bin_fill_ser, _project_par, _project_ser, _setup_par, _setup_ser

__all__ = ["rasterize", "coverage_count", "choose_backend", "covered_pixels", "NEAR_FRACTION", "BAND_HEIGHT",
           "AUTO_FACES_PER_PIXEL"]

NEAR_FRACTION = 1e-5  # default near plane, as a fraction of the scene's bounding-box diagonal
# Rows of the z-buffer owned by one parallel task: a face is set up once per band it touches, so
# taller bands set up fewer (16 rows: single-thread hit buffer of the 82k-face sphere 7% faster
# than 8 at 1920x1080 and 640x480; the band's z-buffer, 16 x W x 12 bytes, stays in L2).
BAND_HEIGHT = 16
_BANDS_A_PART = 2  # bands a part of the scan runs (one call each: a few keep the calls' cost small)
_SERIAL_BELOW = 50_000  # faces: fewer run the geometry stages serially
_MAX_SIDE = 1 << 24  # image sides beyond this are refused (float64 pixel arithmetic stays exact)
# backend="auto" rasterizes while faces <= alpha * image pixels + beta * covered pixels, with
# (alpha, beta) = AUTO_FACES_PER_PIXEL: the fit of the crossovers `benchmarks/bench_raster.py
# --crossover` measures (benchmarks/results/raster_crossover.csv; tests/visibility/test_raster_auto.py
# holds the two equal).
AUTO_FACES_PER_PIXEL = (0.13, 0.071)


def check_raster_camera(camera) -> None:
    """TypeError/ValueError naming the field for a camera the rasterizer cannot draw: not a
    :class:`~raycast_shade.scene.camera.Camera`, a distorted lens, or a side over 2**24 pixels
    (``render(backend="raster")`` checks it in its plan, before any kernel)."""
    if not isinstance(camera, Camera):
        raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
    if camera.distorted:  # straight edges stay straight only through a pinhole
        raise ValueError("camera.distortion: the rasterizer draws pinhole cameras only; use backend='raycast'")
    if camera.width > _MAX_SIDE or camera.height > _MAX_SIDE:
        raise ValueError(f"camera.width, camera.height: at most {_MAX_SIDE} pixels, got {camera.width}x{camera.height}")


def _check(geometry, camera, near):
    from ..scene.scene import Scene, SceneGeometry

    if isinstance(geometry, Scene):
        geometry = geometry.geometry
    if not isinstance(geometry, SceneGeometry):
        raise TypeError(f"geometry: expected a SceneGeometry (scene.geometry), got {type(geometry).__name__}")
    check_raster_camera(camera)
    if near is None:
        near = NEAR_FRACTION * geometry.scale
    else:
        if isinstance(near, bool) or not isinstance(near, (int, float, np.integer, np.floating)):
            raise TypeError(f"near: expected a number, got {type(near).__name__}")
        near = float(near)
        if not (np.isfinite(near) and near > 0.0):
            raise ValueError(f"near: must be a finite number > 0, got {near}")
    if camera.orthographic:
        near = 0.0  # rays start on the image plane through the eye
    return geometry, near


def _run(geometry, camera, near, count_mode, hits=None, stages=None):
    """The pipeline. Returns the hit buffer (``hits``, filled in place, when given),
    or the coverage counts in count mode. ``stages``, a dict, receives each stage's
    wall time in seconds (``project``, ``setup``, ``bin``, ``scan``: scan and resolve)."""
    clock = time.perf_counter
    t0 = clock()
    W, H = camera.width, camera.height
    ortho = camera.orthographic
    right, up, fwd = camera.basis
    hw, hh = camera.half_extents()
    view = np.ascontiguousarray(np.stack([camera.eye - geometry.origin, right, up, fwd]), dtype=np.float64)
    ox, oy = camera.principal_offset()
    if camera.fx is not None:
        # A principal point off the centre: orthographic, a shifted eye;
        # perspective, camera space sheared to x - ox z, y - oy z, which
        # keeps z (the depth keys), planes and barycentrics; the resolve
        # scales t by the unsheared ray length.
        if ortho:
            view[0] += ox * right + oy * up
        else:
            view[1] -= ox * fwd
            view[2] -= oy * fwd
        ox, oy = (0.0, 0.0) if ortho else (ox, oy)
    verts = np.ascontiguousarray(geometry.vertices, dtype=np.float64)
    faces = np.ascontiguousarray(geometry.faces, dtype=np.int64)
    nv, nf = len(verts), len(faces)
    # Small meshes: the geometry stages run serially (a parallel region costs
    # more than their work); the per-pixel stage is always parallel.
    small = nf < _SERIAL_BELOW
    Wf, Hf = float(W), float(H)
    cs = np.empty((nv, 3))
    vx = np.empty((nv, 4))
    (_project_ser if small else _project_par)(verts, view, near, ortho, Wf, Hf, hw, hh, cs, vx)
    t1 = clock()
    band_h = BAND_HEIGHT
    nbands = (H + band_h - 1) // band_h
    nchunks = (nf + _CHUNK - 1) // _CHUNK
    ylo = np.empty(nf, np.int32)
    yhi = np.empty(nf, np.int32)
    counts = np.zeros((nchunks, nbands), np.int64)
    first = np.empty(nf, np.int8)
    (_setup_ser if small else _setup_par)(faces, vx, cs, near, ortho, Wf, Hf, hw, hh, band_h, ylo, yhi, counts,
                                          first)
    t2 = clock()
    band_start = np.zeros(nbands + 1, np.int64)
    np.cumsum(counts.sum(axis=0), out=band_start[1:])
    pos = np.ascontiguousarray(band_start[:-1][None, :] + np.cumsum(counts, axis=0) - counts)
    band_tris = np.empty(int(band_start[-1]), np.int32)
    (_bin_fill_ser if small else _bin_fill_par)(ylo, yhi, band_h, pos, band_tris)
    t3 = clock()
    if count_mode:
        count = np.zeros((H, W), np.int32)
        out = [np.empty((1, 1), dt) for dt in (np.int32, np.int32, np.float32, np.float32, np.float32)]
    else:
        count = np.empty((1, 1), np.int32)
        out = list(image_buffer(hits, H, W))  # the resolve writes every pixel
    face_model = np.ascontiguousarray(geometry.face_model, dtype=np.int32)
    face_off = np.ascontiguousarray(geometry.face_offsets, dtype=np.int64)
    # Bands differ in cost: hand them out a few at a time (a part each), to the threads as they finish.
    launch(_raster_kernel.kernel, faces, vx, cs, near, (ortho, Wf, Hf, hw, hh), (float(ox), float(oy)),
           (band_h, band_start, band_tris, first), count_mode, face_model, face_off, count, tuple(out),
           parts=max(1, (len(band_start) - 1 + _BANDS_A_PART - 1) // _BANDS_A_PART), dynamic=True)
    if stages is not None:
        stages.update(project=t1 - t0, setup=t2 - t1, bin=t3 - t2, scan=clock() - t3)
    if count_mode:
        return count
    return HitBuffer(prim=out[0], geom=out[1], u=out[2], v=out[3], t=out[4])


def rasterize(geometry, camera, *, near=None, offset=None, out=None) -> HitBuffer:
    """Visibility by z-buffer scan conversion: the ray caster's hit buffer.

    Parameters
    ----------
    geometry : SceneGeometry
        ``scene.geometry`` (a :class:`~raycast_shade.Scene` is accepted
        too).
    camera : Camera
    near : float, optional
        Perspective near-plane distance in world units, ``> 0``; default
        ``NEAR_FRACTION * geometry.scale``. Ignored for orthographic cameras,
        which clip at the image plane.
    offset : (dx, dy), optional
        Sub-pixel offset in pixels (``y`` down): pixel ``(x, y)`` samples the
        image point ``(x + 0.5 + dx, y + 0.5 + dy)`` (coverage, depth and
        barycentrics alike), the ray caster's ``cast_camera(..., offset=)``.
        ``None`` or ``(0, 0)``: the pixel centres.
    out : HitBuffer, optional
        A buffer to fill in place instead of fresh arrays, as
        ``cast_camera(..., out=)`` takes.

    Returns
    -------
    HitBuffer
        ``prim`` (local to its model), ``geom``, perspective-correct ``u, v``
        and distance ``t``, with the ray caster's conventions (``out`` when
        given).

    Raises
    ------
    TypeError, ValueError
        For a bad argument (the message names it).
    ValueError
        For a scene with alpha-masked models (``Material.alpha_cutoff``): the
        z-buffer fill keeps no fragment behind the nearest, so it cannot let
        the masked texels through; the ray caster honours them.
    """
    geometry, near = _check(geometry, camera, near)
    masked = masked_geometries(geometry)
    if masked:
        raise ValueError(f"rasterize: scene.models{list(masked)} are alpha-masked (Material.alpha_cutoff), which "
                         "the rasterizer does not honour; use backend='raycast'")
    if offset is not None:
        camera = subpixel_camera(camera, *offset_pair(offset))
    if out is not None:
        out = image_buffer(out, camera.height, camera.width)
    return _run(geometry, camera, near, False, out)


def coverage_count(geometry, camera, *, near=None) -> np.ndarray:
    """How many triangles cover each pixel centre (no depth test).

    Same scan conversion, clipping and fill rule as :func:`rasterize`. On a
    closed, watertight mesh every count is even (a ray enters as often as it
    leaves); on an open sheet seen from one side it is 0 or 1. An odd count
    or a 2 on a sheet would be a crack or a pixel drawn twice.

    Parameters
    ----------
    geometry : SceneGeometry
    camera : Camera
    near : float, optional
        As in :func:`rasterize`.

    Returns
    -------
    (H, W) int32
    """
    geometry, near = _check(geometry, camera, near)
    return _run(geometry, camera, near, True)


def _bounds(geometry):
    v = geometry.vertices
    if len(v) == 0:
        return np.zeros(3), np.zeros(3)
    return v.min(axis=0), v.max(axis=0)


def covered_pixels(geometry, camera) -> int:
    """The pixels the scene's bounding box covers on screen: ``backend="auto"``'s estimate of the
    pixels a frame shades, from the 8 corners of the re-centred vertices' box (kept with the
    geometry); none when the whole box lies at or behind the eye plane, the whole image when part
    of it does (a bound: its screen box is unbounded).

    Parameters
    ----------
    geometry : SceneGeometry
    camera : Camera

    Returns
    -------
    int
        In ``0 .. width * height``.
    """
    lo, hi = geometry.memo("raster_bounds", _bounds)
    W, H = camera.width, camera.height
    right, up, fwd = camera.basis
    hw, hh = camera.half_extents()
    ox, oy = camera.principal_offset()
    corners = np.array([[(lo, hi)[i >> k & 1][k] for k in range(3)] for i in range(8)]) - (camera.eye - geometry.origin)
    x, y, z = corners @ right, corners @ up, corners @ fwd
    if camera.orthographic:
        sx, sy = (x - ox) / hw, (y - oy) / hh
    else:
        if not np.any(z > 0.0):
            return 0
        if not np.all(z > 0.0):
            return W * H
        sx, sy = (x / z - ox) / hw, (y / z - oy) / hh
    # Pixel coordinates of the corners (y down), their box clipped to the image.
    px0, px1 = np.clip(0.5 * W * (1.0 + np.array([sx.min(), sx.max()])), 0.0, W)
    py0, py1 = np.clip(0.5 * H * (1.0 - np.array([sy.max(), sy.min()])), 0.0, H)
    return int(round((px1 - px0) * (py1 - py0)))


def choose_backend(geometry, camera) -> tuple[str, str]:
    """``render(backend="auto")``'s choice: the rasterizer where it is measured to be faster.

    The rasterizer's cost grows with the faces (each is projected, set up and binned), the ray
    caster's with the pixels (a descent each, dearer on a hit); the rasterizer is chosen when
    ``faces <= alpha * width * height + beta * covered_pixels(geometry, camera)``, ``(alpha, beta)
    = AUTO_FACES_PER_PIXEL`` (the measured crossover), and it can draw the frame
    (a pinhole camera, sides up to 2**24, no alpha-masked model); Embree otherwise. Deterministic:
    a function of the scene and the camera only (not of what has been built or cached).

    Parameters
    ----------
    geometry : SceneGeometry
    camera : Camera

    Returns
    -------
    backend : {"raster", "raycast"}
    reason : str
        Why, for ``frame.decisions``-style reports.
    """
    if camera.distorted:
        return "raycast", "a distorted lens: the rasterizer draws pinhole cameras only"
    if camera.width > _MAX_SIDE or camera.height > _MAX_SIDE:
        return "raycast", f"a side over {_MAX_SIDE} pixels"
    if masked_geometries(geometry):
        return "raycast", "alpha-masked models: the rasterizer does not honour them"
    faces = len(geometry.faces)
    covered = covered_pixels(geometry, camera)
    alpha, beta = AUTO_FACES_PER_PIXEL
    limit = alpha * camera.width * camera.height + beta * covered
    why = f"{alpha} x {camera.width * camera.height} image pixels + {beta} x {covered} covered pixels"
    if faces <= limit:
        return "raster", f"{faces} faces <= {why}"
    return "raycast", f"{faces} faces > {why}"
