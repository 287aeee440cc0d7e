"""Embree 4, as shipped inside the embreex wheel, called without copies.

embreex's Python API has two costs we cannot afford: its ``TriangleMesh``
copies vertices and indices element by element through Python objects (3-4x
the BVH build itself), and its ``run`` loop is serial and allocates the output
arrays per call. The shared library it bundles is a plain Embree 4, so we use
it directly:

* scene building: ``rtcSetSharedGeometryBuffer`` points Embree at our own
  NumPy arrays (kept alive by :class:`EmbreeAccel`), so building costs the BVH
  build alone;
* traversal: ``rtcIntersect1`` / ``rtcIntersect8`` / ``rtcOccluded1`` are
  declared as external symbols for Numba, so ray generation, traversal and
  hit unpacking run in one parallel kernel, with no Python per ray or chunk.
  Symbols (not addresses) keep ``cache=True`` valid across processes.
* camera packets pass ``RTCIntersectArguments`` with
  ``RTC_RAY_QUERY_FLAG_COHERENT``: without it (a NULL argument means
  "incoherent") Embree never takes its coherent packet path, and primary
  rays cost about twice as much (measured: 90 ms against 47 ms for a 1080p
  frame of an 81,920-triangle sphere on 2 cores; the hits are bit-identical).

Struct layouts (Embree 4 ``rtcore_ray.h``), as float32 slots:
``RTCRayHit`` = org xyz, tnear, dir xyz, time, tfar, mask, id, flags |
Ng xyz, u, v, primID, geomID, instID[1], (instPrimID[1]); 16-byte aligned.
The packet form ``RTCRayHit8`` has the same fields, each an array of 8.
"""

from __future__ import annotations

import ctypes
import functools
import glob
import os

import numpy as np
from numba import types

__all__ = ["available", "library_path", "EmbreeAccel", "intersect1", "intersect8", "occluded1", "INVALID_ID"]

INVALID_ID = 0xFFFFFFFF

# Embree 4 enum values (rtcore_device.h, rtcore_buffer.h, rtcore_geometry.h, rtcore_scene.h)
_RTC_BUFFER_TYPE_INDEX = 0
_RTC_BUFFER_TYPE_VERTEX = 1
_RTC_FORMAT_UINT3 = 0x5003
_RTC_FORMAT_FLOAT3 = 0x9003
_RTC_GEOMETRY_TYPE_TRIANGLE = 0
_RTC_SCENE_FLAG_ROBUST = 1 << 2
_RTC_BUILD_QUALITY_HIGH = 2
_RTC_DEVICE_PROPERTY_VERSION = 0
# Embree intersects in float32 and multiplies coordinates together (edge cross products), so
# beyond about 1e19 from the scene's centre those products overflow and triangles are missed
# without a word (measured: a triangle of size 1e18 renders, 1e19 does not). Geometry and ray
# origins, re-centred, must stay within this bound.
MAX_COORDINATE = 1e18
# The same products underflow below about 1e-19: a scene that small is missed entirely.
MIN_EXTENT = 1e-18
# RTCIntersectArguments (rtcore_scene.h): flags, feature_mask, then three
# pointers (context, filter, intersect), all zero = Embree's defaults.
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
def _load():
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
    return lib, path


def available() -> bool:
    """True when the direct Embree path can be used in this process."""
    return _load()[0] is not None


def library_path() -> str | None:
    lib, path = _load()
    return path if lib is not None else None


@functools.lru_cache(maxsize=1)
def _device():
    lib, why = _load()
    if lib is None:
        raise RuntimeError(why)
    dev = lib.rtcNewDevice(b"verbose=0")
    if not dev:
        raise RuntimeError("Embree: rtcNewDevice failed")
    return dev


def embree_version() -> str:
    lib, _ = _load()
    v = lib.rtcGetDeviceProperty(_device(), _RTC_DEVICE_PROPERTY_VERSION)
    return f"{v // 10000}.{(v // 100) % 100}.{v % 100}"


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

    Attributes
    ----------
    handle : int
        The ``RTCScene`` pointer, passed to the Numba kernels.
    build_seconds : float
        Wall time of ``rtcCommitScene`` (the BVH build).
    """

    def __init__(self, vertices, faces, vertex_offsets, face_offsets):
        import time

        lib, why = _load()
        if lib is None:
            raise RuntimeError(why)
        if vertices.dtype != np.float32 or vertices.ndim != 2 or vertices.shape[1] != 4 or not vertices.flags.c_contiguous:
            raise TypeError("vertices: expected C-contiguous (V, 4) float32")
        if faces.dtype != np.uint32 or faces.ndim != 2 or faces.shape[1] != 3 or not faces.flags.c_contiguous:
            raise TypeError("faces: expected C-contiguous (F, 3) uint32")
        self._lib = lib
        self._arrays = (vertices, faces)  # Embree holds raw pointers into these
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
# 64-bit ABI Numba supports.
intersect1 = types.ExternalFunction("rtcIntersect1", types.void(types.uintp, types.uintp, types.uintp))
intersect8 = types.ExternalFunction(
    "rtcIntersect8", types.void(types.uintp, types.uintp, types.uintp, types.uintp)
)
occluded1 = types.ExternalFunction("rtcOccluded1", types.void(types.uintp, types.uintp, types.uintp))

# Make the symbols resolvable before any kernel that calls them is compiled
# or loaded from the cache.
_load()
