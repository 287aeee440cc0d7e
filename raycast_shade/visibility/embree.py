"""Embree 4, as shipped inside the embreex wheel, called without copies.

embreex's Python API has two costs we cannot afford: its ``TriangleMesh``
copies vertices and indices element by element through Python objects (3-4x
the BVH build itself), and its ``run`` loop is serial and allocates the output
arrays per call. The shared library it bundles is a plain Embree 4, so we use
it directly:

* scene building: ``rtcSetSharedGeometryBuffer`` points Embree at our own
  NumPy arrays (held by :class:`EmbreeAccel` for as long as its scene
  exists), so building costs the BVH build alone;
* traversal: ``rtcIntersect1`` / ``rtcIntersect8`` / ``rtcIntersect16`` / ``rtcOccluded1`` /
  ``rtcOccluded16`` are
  declared as external symbols for Numba, so ray generation, traversal and
  hit unpacking run in one parallel kernel, with no Python per ray or chunk.
  Symbols (not addresses) keep ``cache=True`` valid across processes.
* kernels call them through :func:`intersect1_ray`, :func:`intersect8_packet`,
  :func:`intersect16_packet`, :func:`occluded1_ray` and :func:`occluded16_packet`, which take the
  scratch *arrays*, not their
  addresses: an address is a bare integer, and once a kernel has taken it
  Numba is free to free the array (it drops each array after its last use
  in the IR). Passed as arguments, the arrays are held by the caller until
  Embree has returned, whatever the caller's liveness, parallel or not.
* camera packets pass ``RTCIntersectArguments`` with
  ``RTC_RAY_QUERY_FLAG_COHERENT``: without it (a NULL argument means
  "incoherent") Embree never takes its coherent packet path, and primary
  rays cost about twice as much (measured: 90 ms against 47 ms for a 1080p
  frame of an 81,920-triangle sphere on 2 cores; the hits are bit-identical).

Struct layouts (Embree 4 ``rtcore_ray.h``), as 4-byte slots, named once here
(``RAY_*`` and ``HIT_*``) and written and read through :func:`write_ray`,
:func:`reset_hit` and :func:`read_hit` (the camera's packet kernel writes and reads the same
named slots lane by lane, :mod:`.cast`, so that its loops over a packet's lanes vectorise):
``RTCRayHit`` = org xyz, tnear, dir xyz, time, tfar, mask, id, flags |
Ng xyz, u, v, primID, geomID, instID[1], (instPrimID[1]); 16-byte aligned.
The packet forms ``RTCRayHit8`` / ``RTCRayHit16`` have the same fields, each an array of 8 / 16
(32- / 64-byte aligned): slot ``s`` of lane ``k`` is at ``s * lanes + k``. ``RTCRay`` (what
``rtcOccluded1`` reads) is the first 12 slots, and ``RTCRay16`` (``rtcOccluded16``'s, 64-byte aligned) the
first 12 slots of ``RTCRayHit16``: :data:`RAY16_SLOTS` in all, a multiple of 16 (768 bytes), so packets laid
one after another stay aligned. ``tests/visibility/test_embree_binding.py`` checks these
slots against the header's field order and against what the bundled library writes. Camera rays go as 16-ray packets of 4x4 pixels: on this AVX-512 build
(Embree 4.4, native 16-wide) they trace 1.08-1.31x faster than 4x2 packets of 8 (measured on
pre-generated packets: 21.4 against 28.0 ms for a 1080p frame of an 81,920-triangle sphere,
38.0 against 45.1 ms at 1.31 M triangles; 8x2 and 16x1 tiles are slower than 4x4).
``RTCIntersectArguments`` and ``RTCOccludedArguments`` (``rtcore_scene.h``) = flags, feature_mask, then
three pointers (context, filter, intersect or occluded): one layout. These layouts and the ``rtcIntersect*(scene, ray, args)``
signatures are Embree 4's (Embree 3 takes a context first), so the binding
reads the library's version and is unavailable, with that reason, for any
other major version (:func:`unavailable_reason`).

What needs this binding: the ``"embree"`` caster, :func:`~raycast_shade.cast_rays`,
shadow rays and mirror rays. Only camera rays have a second route, embreex's
own API (:mod:`raycast_shade.visibility.cast`).
"""

from __future__ import annotations

import ctypes
import functools
import glob
import os

import numpy as np
from numba import types

from ..common.inline import inline_jit

__all__ = ["available", "unavailable_reason", "library_path", "embree_version", "EmbreeAccel", "intersect1",
           "intersect8", "intersect16", "occluded1", "occluded16", "intersect1_ray", "intersect8_packet",
           "intersect16_packet", "occluded1_ray", "occluded16_packet", "write_ray", "reset_hit", "read_hit",
           "INVALID_ID", "RAY_SLOTS", "RAYHIT_SLOTS", "RAY16_SLOTS"]

INVALID_ID = 0xFFFFFFFF  # RTC_INVALID_GEOMETRY_ID: geomID / primID of a miss

# RTCRay (rtcore_ray.h): 4-byte slots, float32 unless marked uint32.
RAY_ORG = 0  # 0:3, origin xyz
RAY_TNEAR = 3
RAY_DIR = 4  # 4:7, direction xyz (need not be unit)
RAY_TIME = 7
RAY_TFAR = 8  # in: end of the segment; out: the hit's distance (rtcOccluded1: -inf when blocked)
RAY_MASK = 9  # uint32
RAY_ID = 10  # uint32
RAY_FLAGS = 11  # uint32
RAY_SLOTS = 12  # sizeof(RTCRay) / 4
RAY16_SLOTS = 16 * RAY_SLOTS  # sizeof(RTCRay16) / 4: slot s of lane k at s * 16 + k
# RTCHit, following the ray in RTCRayHit.
HIT_NG = 12  # 12:15, unnormalised geometric normal xyz
HIT_U = 15
HIT_V = 16
HIT_PRIM_ID = 17  # uint32
HIT_GEOM_ID = 18  # uint32
HIT_INST_ID = 19  # uint32, instID[RTC_MAX_INSTANCE_LEVEL_COUNT = 1]
HIT_INST_PRIM_ID = 20  # uint32, instPrimID[1] (builds with instance arrays)
RAYHIT_SLOTS = 24  # one RTCRayHit with instPrimID, rounded up to its 16-byte alignment (96 bytes)

# Embree 4 enum values (rtcore_device.h, rtcore_buffer.h, rtcore_geometry.h, rtcore_scene.h)
_RTC_BUFFER_TYPE_INDEX = 0
_RTC_BUFFER_TYPE_VERTEX = 1
_RTC_FORMAT_UINT3 = 0x5003
_RTC_FORMAT_FLOAT3 = 0x9003
_RTC_GEOMETRY_TYPE_TRIANGLE = 0
_RTC_SCENE_FLAG_ROBUST = 1 << 2
_RTC_BUILD_QUALITY_HIGH = 2
_RTC_DEVICE_PROPERTY_VERSION = 0
_LAYOUT_MAJOR = 4  # the Embree major version whose struct layouts and signatures the kernels hard-code
# Embree intersects in float32 and multiplies coordinates together (edge cross products), so
# beyond about 1e19 from the scene's centre those products overflow and triangles are missed
# without a word (measured: a triangle of size 1e18 renders, 1e19 does not). Geometry and ray
# origins, re-centred, must stay within this bound.
MAX_COORDINATE = 1e18
# The same products underflow below about 1e-19: a scene that small is missed entirely.
MIN_EXTENT = 1e-18
# RTCIntersectArguments (rtcore_scene.h): flags, feature_mask, then three
# pointers (context, filter, intersect), all zero = Embree's defaults; RTCOccludedArguments
# is the same with an occluded function in the last pointer.
# 16 uint32 slots cover it, with room for the optional minWidth float.
ARGS_SLOTS = 16
RAY_QUERY_FLAG_COHERENT = 1 << 16
FEATURE_FLAG_ALL = 0xFFFFFFFF
_ERRORS = {
    0: "none",
    1: "unknown error",
    2: "invalid argument",
    3: "invalid operation",
    4: "out of memory",
    5: "unsupported CPU",
    6: "cancelled",
}


def check_range(extent: float, name: str, *, scene: bool = False) -> None:
    """Raise ``ValueError`` naming ``name`` when ``extent`` (re-centred, world units) is out of Embree's
    float32 range: too far always, and with ``scene`` also too small (a scene's half-size)."""
    if scene and 0.0 < extent < MIN_EXTENT:
        raise ValueError(
            f"{name}: the scene spans only {extent:.3g} from its centre; Embree's float32 ray-triangle test "
            f"underflows below about 1e-19 and misses every triangle, so the limit is {MIN_EXTENT:.0e}: "
            "scale the scene (vertices, camera and lights) up")
    if not extent <= MAX_COORDINATE:
        raise ValueError(
            f"{name}: reaches {extent:.3g} from the scene's centre; Embree's float32 ray-triangle test overflows "
            f"beyond about 1e19 and misses every triangle there, so the limit is {MAX_COORDINATE:.0e}: "
            "scale the scene (vertices, camera and lights) down")


def _candidate_paths():
    try:
        import embreex
    except ImportError:  # pragma: no cover - embreex is a hard dependency
        return []
    pkg = os.path.dirname(os.path.abspath(embreex.__file__))
    site = os.path.dirname(pkg)
    patterns = []
    for d in (os.path.join(site, "embreex.libs"), pkg, os.path.join(pkg, ".dylibs"), os.path.join(site, "embreex.libs", "lib")):
        patterns += [os.path.join(d, "libembree4*.so*"), os.path.join(d, "libembree4*.dylib"), os.path.join(d, "embree4*.dll")]
    found = []
    for pat in patterns:
        found += sorted(glob.glob(pat))
    return found


@functools.lru_cache(maxsize=1)
def _open():
    """Load the bundled Embree once per process; returns (ctypes lib, path) or (None, reason)."""
    paths = _candidate_paths()
    if not paths:
        return None, "embreex's bundled libembree4 was not found"
    path = paths[0]
    try:
        # Import embreex's extension first so that the very same copy of the
        # library (same handle, same TBB) is the one we bind to.
        import embreex.rtcore_scene  # noqa: F401

        lib = ctypes.CDLL(path)
        from llvmlite import binding as llvm

        llvm.load_library_permanently(path)
    except Exception as exc:  # pragma: no cover - depends on the platform
        return None, f"cannot load {path}: {exc}"
    vp = ctypes.c_void_p
    lib.rtcNewDevice.restype = vp
    lib.rtcNewDevice.argtypes = [ctypes.c_char_p]
    lib.rtcGetDeviceError.restype = ctypes.c_int
    lib.rtcGetDeviceError.argtypes = [vp]
    lib.rtcGetDeviceProperty.restype = ctypes.c_ssize_t
    lib.rtcGetDeviceProperty.argtypes = [vp, ctypes.c_int]
    lib.rtcNewScene.restype = vp
    lib.rtcNewScene.argtypes = [vp]
    lib.rtcSetSceneFlags.argtypes = [vp, ctypes.c_int]
    lib.rtcSetSceneBuildQuality.argtypes = [vp, ctypes.c_int]
    lib.rtcNewGeometry.restype = vp
    lib.rtcNewGeometry.argtypes = [vp, ctypes.c_int]
    lib.rtcSetSharedGeometryBuffer.argtypes = [
        vp, ctypes.c_int, ctypes.c_uint, ctypes.c_int, vp, ctypes.c_size_t, ctypes.c_size_t, ctypes.c_size_t,
    ]
    lib.rtcCommitGeometry.argtypes = [vp]
    lib.rtcAttachGeometryByID.argtypes = [vp, vp, ctypes.c_uint]
    lib.rtcReleaseGeometry.argtypes = [vp]
    lib.rtcCommitScene.argtypes = [vp]
    lib.rtcReleaseScene.argtypes = [vp]
    lib.rtcReleaseDevice.argtypes = [vp]
    # Filter functions (alpha masks, :mod:`.alpha`): installed on masked geometries only.
    lib.rtcSetGeometryUserData.argtypes = [vp, vp]
    lib.rtcSetGeometryIntersectFilterFunction.argtypes = [vp, vp]
    lib.rtcSetGeometryOccludedFilterFunction.argtypes = [vp, vp]
    return lib, path


@functools.lru_cache(maxsize=1)
def _device():
    lib, why = _open()
    if lib is None:
        raise RuntimeError(why)
    dev = lib.rtcNewDevice(b"verbose=0")
    if not dev:
        raise RuntimeError("Embree: rtcNewDevice failed")
    return dev


def _read_version(lib, dev) -> int:
    """``RTC_DEVICE_PROPERTY_VERSION``: major * 10000 + minor * 100 + patch."""
    return int(lib.rtcGetDeviceProperty(dev, _RTC_DEVICE_PROPERTY_VERSION))


def _format_version(v: int) -> str:
    return f"{v // 10000}.{(v // 100) % 100}.{v % 100}"


@functools.lru_cache(maxsize=1)
def _load():
    """The binding, once per process: (ctypes lib, path) when the kernels can use
    it, else (None, reason) -- the library is missing, does not load, or is not
    the Embree major version whose structs the kernels hard-code."""
    lib, path = _open()
    if lib is None:
        return None, path
    try:
        dev = _device()
    except RuntimeError as exc:  # pragma: no cover - depends on the machine
        return None, f"{path}: {exc}"
    version = _read_version(lib, dev)
    if version // 10000 != _LAYOUT_MAJOR:
        return None, (f"Embree {_format_version(version)} found in {path}; the kernels hard-code Embree "
                      f"{_LAYOUT_MAJOR}'s struct layouts (RTCRayHit, RTCRayHit8, RTCIntersectArguments) "
                      "and rtcIntersect signatures")
    return lib, path


def available() -> bool:
    """True when the direct Embree path can be used in this process."""
    return _load()[0] is not None


def unavailable_reason() -> str | None:
    """Why the direct Embree path cannot be used (None when it can)."""
    lib, why = _load()
    return None if lib is not None else why


def library_path() -> str | None:
    lib, path = _load()
    return path if lib is not None else None


def embree_version() -> str:
    """The loaded library's version, e.g. ``"4.3.3"``."""
    lib, why = _open()
    if lib is None:
        raise RuntimeError(why)
    return _format_version(_read_version(lib, _device()))


def _check(lib, dev, what: str):
    err = lib.rtcGetDeviceError(dev)
    if err:
        raise RuntimeError(f"Embree: {what} failed: {_ERRORS.get(err, err)}")


class EmbreeAccel:
    """An Embree scene over shared buffers: one geometry per model.

    Parameters
    ----------
    vertices : (V, 4) float32
        Re-centred positions, padded to 16 bytes per vertex (Embree reads
        vertices with 16-byte loads). Kept alive and never copied.
    faces : (F, 3) uint32
        Indices local to each model's vertex range.
    vertex_offsets, face_offsets : (G + 1,) int64
        Ranges of each model in ``vertices`` and ``faces``; model ``g``
        becomes Embree geometry ``g``.
    masks : dict of int to (N,) float32, optional
        Alpha-masked models: geometry ``g`` gets the intersection and
        occlusion filter at ``filter_address`` with the address of
        ``masks[g]`` (:func:`.alpha.mask_data`) as its user pointer; every
        other geometry gets no filter at all.
    filter_address : int, optional
        The ``RTCFilterFunctionN`` (:func:`.alpha.filter_address`); needed with ``masks``.

    Attributes
    ----------
    handle : int
        The ``RTCScene`` pointer, passed to the Numba kernels.
    build_seconds : float
        Wall time of ``rtcCommitScene`` (the BVH build).
    mask_data : dict of int to (N,) float32
        The user data Embree points into, held as long as this object (and so its scene).
    """

    def __init__(self, vertices, faces, vertex_offsets, face_offsets, masks=None, filter_address=0):
        import time

        lib, why = _load()
        if lib is None:
            raise RuntimeError(f"the direct Embree binding is unavailable: {why}")
        if vertices.dtype != np.float32 or vertices.ndim != 2 or vertices.shape[1] != 4 or not vertices.flags.c_contiguous:
            raise TypeError("vertices: expected C-contiguous (V, 4) float32")
        if faces.dtype != np.uint32 or faces.ndim != 2 or faces.shape[1] != 3 or not faces.flags.c_contiguous:
            raise TypeError("faces: expected C-contiguous (F, 3) uint32")
        self._lib = lib
        # Embree keeps raw pointers into these for the scene's lifetime: held
        # here before any pointer is taken, dropped only after __del__ has
        # released the scene.
        self._arrays = (vertices, faces)
        self.mask_data = dict(masks or {})
        for g, data in self.mask_data.items():
            if data.dtype != np.float32 or data.ndim != 1 or not data.flags.c_contiguous or not data.flags.owndata:
                raise TypeError(f"masks[{g}]: expected a 1-D C-contiguous float32 array owning its memory")
        if self.mask_data and not filter_address:
            raise ValueError("filter_address: needed with masks")
        dev = _device()
        scene = lib.rtcNewScene(dev)
        _check(lib, dev, "rtcNewScene")
        self.handle = int(scene)
        lib.rtcSetSceneFlags(scene, _RTC_SCENE_FLAG_ROBUST)
        vptr = vertices.ctypes.data
        fptr = faces.ctypes.data
        for g in range(len(vertex_offsets) - 1):
            v0, v1 = int(vertex_offsets[g]), int(vertex_offsets[g + 1])
            f0, f1 = int(face_offsets[g]), int(face_offsets[g + 1])
            geom = lib.rtcNewGeometry(dev, _RTC_GEOMETRY_TYPE_TRIANGLE)
            lib.rtcSetSharedGeometryBuffer(
                geom, _RTC_BUFFER_TYPE_VERTEX, 0, _RTC_FORMAT_FLOAT3, vptr, v0 * 16, 16, v1 - v0
            )
            lib.rtcSetSharedGeometryBuffer(geom, _RTC_BUFFER_TYPE_INDEX, 0, _RTC_FORMAT_UINT3, fptr, f0 * 12, 12, f1 - f0)
            if g in self.mask_data:  # the CPU invokes geometry filters whatever the queries' arguments
                lib.rtcSetGeometryUserData(geom, ctypes.c_void_p(self.mask_data[g].ctypes.data))
                lib.rtcSetGeometryIntersectFilterFunction(geom, ctypes.c_void_p(filter_address))
                lib.rtcSetGeometryOccludedFilterFunction(geom, ctypes.c_void_p(filter_address))
            lib.rtcCommitGeometry(geom)
            lib.rtcAttachGeometryByID(scene, geom, g)
            lib.rtcReleaseGeometry(geom)
            _check(lib, dev, f"building geometry {g}")
        t0 = time.perf_counter()
        lib.rtcCommitScene(scene)
        self.build_seconds = time.perf_counter() - t0
        _check(lib, dev, "rtcCommitScene")

    def __del__(self):
        handle = getattr(self, "handle", 0)
        if handle:
            self._lib.rtcReleaseScene(ctypes.c_void_p(handle))
            self.handle = 0


# Pointers travel as uintp: the same register class as a C pointer on every
# 64-bit ABI Numba supports. Kernels do not call these with addresses of their
# own: they go through the array wrappers below.
intersect1 = types.ExternalFunction("rtcIntersect1", types.void(types.uintp, types.uintp, types.uintp))
intersect8 = types.ExternalFunction(
    "rtcIntersect8", types.void(types.uintp, types.uintp, types.uintp, types.uintp)
)
intersect16 = types.ExternalFunction(
    "rtcIntersect16", types.void(types.uintp, types.uintp, types.uintp, types.uintp)
)
occluded1 = types.ExternalFunction("rtcOccluded1", types.void(types.uintp, types.uintp, types.uintp))
occluded16 = types.ExternalFunction(
    "rtcOccluded16", types.void(types.uintp, types.uintp, types.uintp, types.uintp)
)


# The wrappers below and the struct helpers: inlined by LLVM into the kernels, they neither take
# references on the arrays nor allocate (a Python call runs a twin with wrappers: common/inline.py).
_INLINE = dict(cache=True, forceinline=True, _nrt=False)


@inline_jit(**_INLINE)
def intersect1_ray(scene, rayhit):
    """``rtcIntersect1(scene, rayhit, NULL)``.

    Parameters
    ----------
    scene : uintp
        ``EmbreeAccel.handle``.
    rayhit : (>= 24,) float32 or uint32
        Starts at a 16-byte aligned ``RTCRayHit`` (e.g. ``buf[off:]``); its
        hit fields are written in place.

    The array, not its address, crosses this call, so the caller holds it
    until Embree returns (see the module docstring)."""
    intersect1(scene, rayhit.ctypes.data, 0)


@inline_jit(**_INLINE)
def intersect8_packet(valid, scene, rayhit, args):
    """``rtcIntersect8(valid, scene, rayhit, args)``.

    Parameters
    ----------
    valid : (>= 8,) int32
        Starts at a 32-byte boundary: -1 for an active ray, 0 for an inactive one.
    scene : uintp
    rayhit : (>= 192,) float32 or uint32
        Starts at a 32-byte aligned ``RTCRayHit8``; hit fields written in place.
    args : (>= ARGS_SLOTS,) uint32
        Starts at an 8-byte aligned ``RTCIntersectArguments``.

    Each array stays alive for the whole call (held by the caller)."""
    intersect8(valid.ctypes.data, scene, rayhit.ctypes.data, args.ctypes.data)


@inline_jit(**_INLINE)
def intersect16_packet(valid, scene, rayhit, args):
    """``rtcIntersect16(valid, scene, rayhit, args)``.

    Parameters
    ----------
    valid : (>= 16,) int32
        Starts at a 64-byte boundary: -1 for an active ray, 0 for an inactive one.
    scene : uintp
    rayhit : (>= 384,) float32 or uint32
        Starts at a 64-byte aligned ``RTCRayHit16``; hit fields written in place.
    args : (>= ARGS_SLOTS,) uint32
        Starts at an 8-byte aligned ``RTCIntersectArguments``.

    Each array stays alive for the whole call (held by the caller)."""
    intersect16(valid.ctypes.data, scene, rayhit.ctypes.data, args.ctypes.data)


@inline_jit(**_INLINE)
def occluded1_ray(scene, ray):
    """``rtcOccluded1(scene, ray, NULL)``: sets ``tfar`` (slot :data:`RAY_TFAR`) to ``-inf`` when blocked.

    Parameters
    ----------
    scene : uintp
    ray : (>= 12,) float32 or uint32
        Starts at a 16-byte aligned ``RTCRay``; held by the caller for the call."""
    occluded1(scene, ray.ctypes.data, 0)


@inline_jit(**_INLINE)
def occluded16_packet(valid, scene, ray, args):
    """``rtcOccluded16(valid, scene, ray, args)``: sets each blocked active lane's ``tfar`` to ``-inf``.

    Parameters
    ----------
    valid : (>= 16,) int32
        Starts at a 64-byte boundary: -1 for an active ray, 0 for an inactive one
        (an inactive lane's ray is neither read nor written).
    scene : uintp
    ray : (>= 16 RAYHIT_SLOTS,) float32 or uint32
        Starts at a 64-byte aligned ``RTCRay16`` (:data:`RAY16_SLOTS`), followed by room for the rest
        of an ``RTCRayHit16``: on a CPU without 16-wide kernels Embree traces the lanes one by one
        and writes each back as an ``RTCRayHit``, rewriting the hit fields past the ``RTCRay16``.
    args : (>= ARGS_SLOTS,) uint32
        Starts at an 8-byte aligned ``RTCOccludedArguments``.

    Each array stays alive for the whole call (held by the caller)."""
    occluded16(valid.ctypes.data, scene, ray.ctypes.data, args.ctypes.data)


# Helpers over the structs, for kernels and plain Python alike (``.py_func``). A ray or hit
# lives in a float32 array and its uint32 view (the same memory); ``base`` is the slot of lane
# 0 of the struct plus the lane, ``lanes`` 1 for RTCRay / RTCRayHit and 8 or 16 for a packet.
# Inlined by LLVM into the kernels, they neither take references on the arrays nor allocate (_INLINE).


@inline_jit(**_INLINE)
def write_ray(f32, u32, base, lanes, org, direction, tnear, tfar):
    """Write one ray: origin, direction, segment ``[tnear, tfar]``, time 0, every mask bit, id and flags 0.

    Parameters
    ----------
    f32, u32 : (N,) float32, (N,) uint32
        Two views of one buffer holding the struct.
    base : int
        Slot of this ray's ``org_x`` (``start + lane`` in a packet).
    lanes : int
        1 for ``RTCRay`` / ``RTCRayHit``, 8 or 16 for ``RTCRayHit8`` / ``RTCRayHit16``.
    org, direction : 3-tuples of float
    tnear, tfar : float
    """
    f32[base + (RAY_ORG + 0) * lanes] = org[0]
    f32[base + (RAY_ORG + 1) * lanes] = org[1]
    f32[base + (RAY_ORG + 2) * lanes] = org[2]
    f32[base + RAY_TNEAR * lanes] = tnear
    f32[base + (RAY_DIR + 0) * lanes] = direction[0]
    f32[base + (RAY_DIR + 1) * lanes] = direction[1]
    f32[base + (RAY_DIR + 2) * lanes] = direction[2]
    f32[base + RAY_TIME * lanes] = 0.0
    f32[base + RAY_TFAR * lanes] = tfar
    u32[base + RAY_MASK * lanes] = INVALID_ID  # every mask bit: no geometry is masked out
    u32[base + RAY_ID * lanes] = 0
    u32[base + RAY_FLAGS * lanes] = 0


@inline_jit(**_INLINE)
def reset_hit(u32, base, lanes):
    """Mark the hit of an ``RTCRayHit`` (or one lane of a packet) as none before a query
    (Embree writes the hit fields only when it finds one)."""
    u32[base + HIT_PRIM_ID * lanes] = INVALID_ID
    u32[base + HIT_GEOM_ID * lanes] = INVALID_ID


@inline_jit(**_INLINE)
def read_hit(f32, u32, base, lanes):
    """The hit of an ``RTCRayHit`` (or one lane of a packet) as a hit buffer stores it.

    Returns
    -------
    geom, prim : int32
        Model and triangle, ``-1`` for a miss.
    u, v : float32
        Barycentrics of vertices 1 and 2 (0 for a miss).
    t : float32
        The hit's distance along the ray (``inf`` for a miss).
    """
    g = u32[base + HIT_GEOM_ID * lanes]
    if g == INVALID_ID:
        return np.int32(-1), np.int32(-1), np.float32(0.0), np.float32(0.0), np.float32(np.inf)
    return (np.int32(g), np.int32(u32[base + HIT_PRIM_ID * lanes]), f32[base + HIT_U * lanes],
            f32[base + HIT_V * lanes], f32[base + RAY_TFAR * lanes])


# Make the symbols resolvable before any kernel that calls them is compiled
# or loaded from the cache.
_open()
