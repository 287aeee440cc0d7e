"""Per-pixel buffers for vision data sets, computed by name from the hit buffer.

``render(scene, buffers=("zdepth", "position", ...))`` puts each asked-for
buffer on ``frame.buffers``; nothing else is computed or held. All come from
the hit buffer, band by band as the banded path casts it (:class:`FrameBuffers`;
the whole frame as one band otherwise), in one Numba pass over the band's
pixels (parallel over rows, float64 arithmetic per pixel, written float32
straight into the full-frame outputs: no full-frame temporaries); the shading
normals are the shading kernels' own (:func:`raycast_shade.shading_normals`,
as ``frame.normal``), written into the ``normal`` buffer by the Phong kernel as
it shades each pixel (by the normals kernel when a model is flat- or
Gouraud-shaded). ``render(buffers_out=...)`` has them written into the caller's
arrays instead of new ones (:func:`check_buffers_out`).

``position`` is the float64 intersection of the pixel's own ray (the ray the
camera casts, lens distortion included) with the hit triangle's plane,
rounded once to float32: it reprojects onto its pixel centre to float32
rounding at any angle, where interpolating Embree's float32 barycentrics
would land up to half a pixel off at grazing angles. ``zdepth`` is
``t (d . forward)`` for the cast's ``t`` and the unit ray ``d``.

Names, shapes and meanings, from the one registry of buffers
(:data:`~raycast_shade.common.bufferspec.REGISTRY`; background: 0, ids -1;
camera axes are OpenCV's, ``x`` right, ``y`` down, ``z`` forward; see
``docs/vision.md``):

{table}

``id`` asks for ``model_id`` and ``triangle_id``. Every buffer but
``coverage`` is the pixel centre's (sample 0), whatever the number of
samples, so masks and ids stay exact.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.parallel import in_parts, share
from ..common.bufferspec import ALIASES, BUFFER_NAMES, BUFFERS, KERNEL_BUFFERS, registry_table
from ..common.layout import CAM_ORTHO
from ..scene.framememory import BUFFER_BYTES
from ..common.prefetch import beyond_caches
from ..visibility.rays import camera_frame
from .pixelrays import _RAY_BUFFERS, _pinhole_zdepth_row, _ray_row, _ray_row_ahead, _row_rays, _zdepth_row

__all__ = ["BUFFER_NAMES", "ALIASES", "BUFFER_BYTES", "buffer_bytes", "check_buffers", "check_buffers_out",
           "compute_buffers", "FrameBuffers"]


__doc__ = __doc__.replace("{table}", registry_table())


def check_buffers(names, field: str = "buffers") -> tuple:
    """The buffer names asked for, aliases expanded, duplicates dropped, in order.

    Parameters
    ----------
    names : str or sequence of str
        Names of :data:`BUFFER_NAMES` or :data:`ALIASES`; one string may list
        several, comma-separated.

    Raises
    ------
    TypeError, ValueError
        Naming ``field`` and listing the valid names.
    """
    from ..common.validate import as_names

    keys = as_names(names, field, BUFFER_NAMES + tuple(ALIASES), item="buffer")
    return tuple(dict.fromkeys(n for key in keys for n in ALIASES.get(key, (key,))))


def buffer_bytes(names) -> int:
    """Bytes per pixel of the named buffers (:data:`BUFFER_BYTES`, aliases expanded)."""
    return sum(BUFFER_BYTES[n] for n in check_buffers(names))


# error_model="numpy": the inlined ray-row helpers divide without a zero test (output.pixelrays)
@in_parts
@njit(nogil=True, cache=True, error_model="numpy")
def _buffers_kernel(view, hits, geometry, extra, outputs, part):
    """Every asked-for buffer of one pixel in one pass; an output of size 0 is not asked for.

    The arguments are five tuples, unpacked once here (never inside the pixel loop):
    ``view = (cam, fwd, R, dirs, y0)``, ``hits = (prim, geom, u, v, t)``,
    ``geometry = (vertices, faces, face_normals, face_offsets, origin, ahead)``,
    ``extra = (shading_n, lut)`` and ``outputs = (depth, zdepth, position, normal,
    normal_cam, face_n, face_n_cam, bary, model_id, triangle_id, mask, semantic_id)``
    (:data:`~raycast_shade.common.bufferspec.KERNEL_BUFFERS`' order).

    Parameters
    ----------
    cam : (16,) float64
        :func:`~raycast_shade.visibility.rays.camera_frame` re-centred on ``origin``.
    fwd : (3,) float64
        The camera's unit optical axis.
    R : (3, 3) float64
        World-to-camera rotation (rows: camera x, y, z in world axes).
    dirs : (H*W, 3) or (0, 3) float64
        Distorted unit ray directions of the whole frame, or empty for a pinhole camera.
    y0 : int
        The image row of the hits' first row (0 for a whole frame; a band's first row).
    prim, geom : (h, W) int32
        The hits of image rows ``y0`` to ``y0 + h``; every output has their rows too.
    u, v, t : (h, W) float32
    vertices : (V, 3) float64
    faces : (F, 3) int64
    face_normals : (F, 3) float64
    face_offsets : (G + 1,) int64
    origin : (3,) float64
    ahead : bool
        Prefetch each row's triangles a few pixels ahead (a mesh beyond the caches).
    shading_n : (h, W, 3) or (0, 0, 3) float32
    lut : (G,) int32
        Semantic class of each model.
    depth, zdepth : (h, W) or (0, 0) float32
    position, normal, normal_cam, face_n, face_n_cam, bary : (h, W, 3) or (0, 0, 3) float32
    model_id, semantic_id, triangle_id : (h, W) or (0, 0) int32
    mask : (h, W) or (0, 0) bool
    """
    cam, fwd, R, dirs, y0 = view
    prim, geom, u, v, t = hits
    shading_n, lut = extra
    depth, zdepth, position, normal, normal_cam, face_n, face_n_cam, bary, model_id, triangle_id, mask, \
        semantic_id = outputs
    h, w = prim.shape
    hit_rays = position.shape[0] != 0 or face_n.shape[0] != 0 or face_n_cam.shape[0] != 0
    rays = zdepth.shape[0] != 0 and not hit_rays  # the z-depth alone: from a row of rays
    one_origin = cam[CAM_ORTHO] == 0.0  # a perspective camera's rays (lens-distorted too) share the eye
    # The rotation as scalars: read from R inside a loop, each would be reloaded per pixel (an
    # output might alias it), and the loops would not vectorise.
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = (R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2],
                                                   R[2, 0], R[2, 1], R[2, 2])
    # One simple loop per asked output and row (the asked set is decided per row, not per
    # pixel): the ids, mask, depth, the row's rays and a z-depth asked alone vectorise; the
    # buffers that need a hit's triangle share its ray (one square root a pixel, vectorised).
    for y in range(*share(h, part)):  # this part's share (common.parallel)
        if depth.shape[0] != 0:
            for x in range(w):
                depth[y, x] = t[y, x] if prim[y, x] >= 0 else np.float32(0.0)
        if mask.shape[0] != 0:
            for x in range(w):
                mask[y, x] = prim[y, x] >= 0
        if model_id.shape[0] != 0:
            for x in range(w):
                model_id[y, x] = geom[y, x]
        if triangle_id.shape[0] != 0:
            for x in range(w):
                triangle_id[y, x] = prim[y, x]
        if semantic_id.shape[0] != 0:
            for x in range(w):
                semantic_id[y, x] = lut[geom[y, x]] if prim[y, x] >= 0 else np.int32(-1)
        if bary.shape[0] != 0:
            out = bary[y].reshape(-1)  # flat rows (a stride known when compiled, 3): the loops vectorise
            for x in range(w):
                hit = prim[y, x] >= 0
                a = np.float64(u[y, x]) if hit else 0.0
                b = np.float64(v[y, x]) if hit else 0.0
                out[3 * x] = 1.0 - a - b if hit else 0.0
                out[3 * x + 1] = a
                out[3 * x + 2] = b
        if normal.shape[0] != 0:
            for x in range(w):
                for k in range(3):
                    normal[y, x, k] = shading_n[y, x, k]
        if normal_cam.shape[0] != 0:
            sn, out = shading_n[y].reshape(-1), normal_cam[y].reshape(-1)
            for x in range(w):
                n0 = np.float64(sn[3 * x])
                n1 = np.float64(sn[3 * x + 1])
                n2 = np.float64(sn[3 * x + 2])
                out[3 * x] = n0 * r00 + n1 * r01 + n2 * r02
                out[3 * x + 1] = n0 * r10 + n1 * r11 + n2 * r12
                out[3 * x + 2] = n0 * r20 + n1 * r21 + n2 * r22
        if rays and dirs.shape[0] == 0 and cam[CAM_ORTHO] == 0.0:  # a pinhole's z-depth alone: no scratch
            _pinhole_zdepth_row(y, cam, fwd, y0, prim, t, zdepth)
        elif hit_rays or rays:  # the row's rays, branch-free (it vectorises), shared by these buffers
            ray = np.empty((6, w), np.float64)
            _row_rays(cam, dirs, w, y0 + y, ray)
            if hit_rays and geometry[5]:
                _ray_row_ahead(y, fwd, R, ray, prim, geom, t, geometry, (zdepth, position, face_n, face_n_cam), one_origin)
            elif hit_rays:
                _ray_row(y, fwd, R, ray, prim, geom, t, geometry, (zdepth, position, face_n, face_n_cam), one_origin)
            else:
                _zdepth_row(y, fwd, ray, prim, t, zdepth)


class FrameBuffers:
    """The named buffers of one frame, filled band by band (or in one band: the whole frame).

    Every full-frame output is allocated once, up front (or is the caller's, ``out``);
    :meth:`band` runs the buffer kernel on one band's hits, writing straight into the band's
    rows: no full-frame temporaries, and each output's pages are touched while the band's hits
    are in cache. The shading normals (``normal``, ``normal_camera``) are written by the Phong
    kernel as it shades (:meth:`normal_target`) when every model is Phong-shaded, and by the
    shading-normal kernel otherwise. A pixel's values do not depend on the band it is in, so
    any banding gives the whole frame's buffers, bit for bit.

    Parameters
    ----------
    scene : Scene
    camera : Camera
        The camera the hits are cast (or rasterized) with.
    names : sequence of str
        Checked names (:func:`check_buffers`).
    shading : str or sequence of str
        The frame's methods (for the shading normals).
    shape : (int, int), optional
        The frame's (H, W); the camera's image by default.
    out : dict of str to ndarray, optional
        Arrays to write some of the buffers into instead of new ones, checked by
        :func:`check_buffers_out` (their old contents are overwritten).
    """

    def __init__(self, scene, camera, names, shading="phong", shape=None, out=None):
        from ..common.layout import METHOD_PHONG
        from ..scene.projection import extrinsics
        from ..shading.normals import normal_inputs
        from ..shading.shade import resolve_methods

        self.names = check_buffers(names)
        h, w = (camera.height, camera.width) if shape is None else shape
        geo = scene.geometry
        c = np.ascontiguousarray
        ahead = beyond_caches(geo.vertices, geo.faces, geo.face_normals)  # no vertex normals read
        self.geometry = (geo.vertices, geo.faces, geo.face_normals, geo.face_offsets, c(geo.origin, np.float64), ahead)
        R, _ = extrinsics(camera)
        dirs = np.empty((0, 3), np.float64)
        if camera.distorted and any(n in self.names for n in _RAY_BUFFERS):
            from ..visibility.distortion import ray_directions

            dirs = c(ray_directions(camera)[0], np.float64)
        self.view = (camera_frame(camera, geo.origin), c(R[2], np.float64), c(R, np.float64), dirs)  # R[2]: forward
        self.lut = np.zeros(max(len(geo.face_offsets) - 1, 1), np.int32)
        if "semantic_id" in self.names:
            from .labels import semantic_classes

            self.lut = c(semantic_classes(scene)[1], np.int32)
        out = {} if out is None else out
        self.out = {name: out[name] for name in self.names if name in out}
        # New outputs are separate arrays, faulted in by the kernels as they write each band: one
        # block for all measured no faster (the OS zeroes the same pages) and would keep every
        # buffer's memory alive while any one of them is; paging a band in before its kernels
        # measured slower (the zeroed pages leave the cache before the kernel writes them).
        self.full = {b.name: self.out[b.name] if b.name in self.out else np.empty(b.shape(h, w), b.dtype)
                     for b in KERNEL_BUFFERS if b.name in self.names}
        self.empty = {b.name: np.empty(b.shape(0, 0), b.dtype) for b in KERNEL_BUFFERS}
        self.normals = None  # the shading normals' inputs, when a normal buffer is asked for
        self.phong = False  # whether the Phong kernel writes every pixel's shading normal
        if "normal" in self.names or "normal_camera" in self.names:
            self.normals = normal_inputs(scene, camera, shading)
            self.phong = bool(np.all(resolve_methods(scene, shading) == METHOD_PHONG))
        self._scratch = np.empty((0, 0, 3), np.float32)  # one band's normals when only normal_camera is asked

    def normal_target(self, y0: int, m: int, w: int):
        """Where the shading kernel writes the shading normals of rows ``y0 .. y0 + m`` as it
        shades them: the ``normal`` buffer's rows (or a band's scratch for ``normal_camera``
        alone); None when no normal buffer is asked for or some model is not Phong-shaded
        (then :meth:`band` computes them). Pass ``shaded=True`` to :meth:`band` after."""
        if not self.phong:
            return None
        return self._normals(y0, m, w)

    def _normals(self, y0, m, w):
        if "normal" in self.full:
            return self.full["normal"][y0:y0 + m]
        if self._scratch.shape[0] < m or self._scratch.shape[1] != w:
            self._scratch = np.empty((m, w, 3), np.float32)
        return self._scratch[:m]

    def band(self, hits, y0: int = 0, shaded: bool = False) -> None:
        """Fill the rows ``y0 .. y0 + R`` of every output from the band's (R, W) hits;
        ``shaded``: the shading kernel has written the band's shading normals into
        :meth:`normal_target`."""
        from ..shading.normals import normals_into

        m, w = hits.prim.shape
        rows = slice(y0, y0 + m)
        outputs = {name: a[rows] for name, a in self.full.items()}
        outputs.pop("normal", None)  # the shading normals themselves: written by the shading or normals kernel
        shading_n = self.empty["normal"]
        if self.normals is not None:
            shading_n = self._normals(y0, m, w)
            if not (shaded and self.phong):
                normals_into(self.normals, hits, shading_n)
        if not outputs:
            return
        c = np.ascontiguousarray
        _buffers_kernel(self.view + (int(y0),),
                        (c(hits.prim, np.int32), c(hits.geom, np.int32), c(hits.u, np.float32),
                         c(hits.v, np.float32), c(hits.t, np.float32)),
                        self.geometry, (shading_n, self.lut),
                        tuple(outputs.get(b.name, self.empty[b.name]) for b in KERNEL_BUFFERS))

    def result(self, mask=None, coverage=None) -> dict:
        """The buffers in the order asked. ``coverage``: the samples' hit fraction, or None for
        one sample (then ``mask``, the (H, W) bool hit mask, as float32)."""
        res = {}
        for name in self.names:
            if BUFFERS[name].writer == "samples":  # the coverage
                value = mask if coverage is None else coverage
                if name in self.out:
                    if self.out[name] is not value:
                        np.copyto(self.out[name], value)
                    res[name] = self.out[name]
                else:
                    res[name] = np.asarray(value, np.float32) if coverage is not None else mask.astype(np.float32)
            else:
                res[name] = self.full[name]
        return res


def check_buffers_out(buffers_out, names, shape, others=(), field: str = "buffers_out") -> dict:
    """Caller-provided arrays for some of the asked buffers, checked before any kernel runs.

    Parameters
    ----------
    buffers_out : mapping of str to ndarray, or None
        Buffer name (:data:`BUFFER_NAMES`, no alias) to the array to write it into: a
        writeable C-contiguous array of the buffer's dtype and shape (e.g. an earlier
        frame's ``frame.buffers``, whose arrays then change).
    names : tuple of str
        The checked names asked for (:func:`check_buffers`); every key must be one of them.
    shape : (int, int)
        The frame's (H, W).
    others : sequence of ndarray
        Arrays the frame writes too (``render(out=...)``): none of the given may overlap them.

    Returns
    -------
    dict of str to ndarray

    Raises
    ------
    TypeError, ValueError
        Naming ``field`` and the buffer: not a mapping or not an array; a name not asked for;
        a wrong shape or dtype; read-only, not C-contiguous, or sharing memory with another
        output.
    """
    if buffers_out is None:
        return {}
    if not hasattr(buffers_out, "items"):
        raise TypeError(f"{field}: expected a mapping of buffer names to arrays, got {type(buffers_out).__name__}")
    out = {}
    h, w = shape
    for name, a in buffers_out.items():
        if not isinstance(name, str):
            raise TypeError(f"{field}: expected buffer names (str) as keys, got {type(name).__name__}")
        if name not in names:
            raise ValueError(f"{field}[{name!r}]: not among the buffers asked for ({', '.join(names) or 'none'}); "
                             "ask for it in buffers= or leave it out")
        if not isinstance(a, np.ndarray):
            raise TypeError(f"{field}[{name!r}]: expected a numpy array, got {type(a).__name__}")
        spec = BUFFERS[name]
        want = spec.shape(h, w)
        if a.shape != want or a.dtype != np.dtype(spec.dtype):
            raise ValueError(f"{field}[{name!r}]: expected a {want} {spec.dtype} array, got {a.shape} {a.dtype}")
        if not a.flags.c_contiguous or not a.flags.writeable:
            raise ValueError(f"{field}[{name!r}]: expected a writeable C-contiguous array")
        for other_name, b in list(out.items()) + [("out", o) for o in others if o is not None]:
            if np.may_share_memory(a, b):
                raise ValueError(f"{field}[{name!r}]: shares memory with "
                                 f"{other_name if other_name == 'out' else f'{field}[{other_name!r}]'}; "
                                 "each output needs its own array")
        out[name] = a
    return out


def compute_buffers(scene, camera, hits, names, shading="phong", coverage=None) -> dict:
    """The named buffers of one frame.

    Parameters
    ----------
    scene : Scene
    camera : Camera
        The camera ``hits`` was made with.
    hits : HitBuffer
        ``(H, W)`` arrays from a caster or the rasterizer.
    names : sequence of str
        Checked names (:func:`check_buffers`).
    shading : str or sequence of str
        The frame's methods (for the shading normals).
    coverage : (H, W) float32, optional
        The anti-aliasing samples' hit fraction; ``None``: one sample, the mask.

    Returns
    -------
    dict of str to ndarray
        In the order asked; shapes and dtypes as in the module table. Only
        the asked-for arrays (and the shading normals, if only a
        ``normal_camera`` is asked for) are allocated.
    """
    fb = FrameBuffers(scene, camera, names, shading, shape=hits.prim.shape)
    fb.band(hits, 0)
    counted = any(BUFFERS[n].writer == "samples" for n in fb.names)
    return fb.result(hits.prim >= 0 if counted else None, coverage)
