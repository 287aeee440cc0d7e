"""Embree's ray and hit structs, named once in visibility/embree.py: the slot constants
against the field order of Embree 4's ``rtcore_ray.h`` (rebuilt here as ctypes structs, so
the offsets are the C compiler's rules, not ours), and ``write_ray`` / ``reset_hit`` /
``read_hit`` against what the bundled library actually reads and writes."""

from __future__ import annotations

import ctypes
import pathlib

import numpy as np
import pytest
from numba import njit

import raycast_shade as rs
from raycast_shade.visibility import embree
from raycast_shade.visibility.accel import embree_accel

ROOT = pathlib.Path(embree.__file__).parents[2]

# rtcore_ray.h (Embree 4), field by field; RTC_MAX_INSTANCE_LEVEL_COUNT = 1, and the
# instPrimID array that builds with instance arrays add.
_RAY_FIELDS = [("org_x", "f"), ("org_y", "f"), ("org_z", "f"), ("tnear", "f"),
               ("dir_x", "f"), ("dir_y", "f"), ("dir_z", "f"), ("time", "f"),
               ("tfar", "f"), ("mask", "u"), ("id", "u"), ("flags", "u")]
_HIT_FIELDS = [("Ng_x", "f"), ("Ng_y", "f"), ("Ng_z", "f"), ("u", "f"), ("v", "f"),
               ("primID", "u"), ("geomID", "u"), ("instID", "u"), ("instPrimID", "u")]
_SLOT = {"org_x": embree.RAY_ORG, "org_y": embree.RAY_ORG + 1, "org_z": embree.RAY_ORG + 2,
         "tnear": embree.RAY_TNEAR, "dir_x": embree.RAY_DIR, "dir_y": embree.RAY_DIR + 1,
         "dir_z": embree.RAY_DIR + 2, "time": embree.RAY_TIME, "tfar": embree.RAY_TFAR,
         "mask": embree.RAY_MASK, "id": embree.RAY_ID, "flags": embree.RAY_FLAGS,
         "Ng_x": embree.HIT_NG, "Ng_y": embree.HIT_NG + 1, "Ng_z": embree.HIT_NG + 2,
         "u": embree.HIT_U, "v": embree.HIT_V, "primID": embree.HIT_PRIM_ID, "geomID": embree.HIT_GEOM_ID,
         "instID": embree.HIT_INST_ID, "instPrimID": embree.HIT_INST_PRIM_ID}


def _struct(name, fields, lanes, align):
    """The C struct with each field an array of ``lanes`` (1: a scalar), padded to ``align``."""
    def ctype(kind):
        base = ctypes.c_float if kind == "f" else ctypes.c_uint32
        return base if lanes == 1 else base * lanes

    body = [(n, ctype(k)) for n, k in fields]
    size = ctypes.sizeof(type("_", (ctypes.Structure,), {"_fields_": body}))
    pad = (-size) % align
    if pad:
        body.append(("_pad", ctypes.c_uint8 * pad))  # RTC_ALIGN(align)
    return type(name, (ctypes.Structure,), {"_fields_": body})


@pytest.mark.parametrize("lanes, align", [(1, 16), (8, 32), (16, 64)])
def test_the_slot_constants_are_the_header_offsets(lanes, align):
    """Field ``f`` of RTCRayHit / RTCRayHit8 / RTCRayHit16 lies at byte ``4 * slot(f) * lanes``,
    and one RTCRayHit (the stride the casters use) is RAYHIT_SLOTS floats."""
    ray = _struct("RTCRay", _RAY_FIELDS, lanes, align)
    hit = _struct("RTCHit", _HIT_FIELDS, lanes, align)
    rayhit = type("RTCRayHit", (ctypes.Structure,), {"_fields_": [("ray", ray), ("hit", hit)]})
    for name, _ in _RAY_FIELDS:
        assert getattr(rayhit, "ray").offset + getattr(ray, name).offset == 4 * _SLOT[name] * lanes, name
    for name, _ in _HIT_FIELDS:
        assert rayhit.hit.offset + getattr(hit, name).offset == 4 * _SLOT[name] * lanes, name
    assert ctypes.sizeof(ray) == 4 * embree.RAY_SLOTS * lanes
    if lanes == 1:
        assert ctypes.sizeof(rayhit) == 4 * embree.RAYHIT_SLOTS
    else:  # the packet stride the casters use covers the packet struct
        assert ctypes.sizeof(rayhit) <= 4 * embree.RAYHIT_SLOTS * lanes


def _aligned(n, dtype, align):
    raw = np.zeros(n + align, dtype)
    off = ((align - raw.ctypes.data % align) % align) // raw.itemsize
    return raw[off:off + n]


@njit(cache=False)
def _trace16(handle, org, dirs, valid):
    """16 rays as one RTCRayHit16 through the helpers; hits read back per lane."""
    buf = np.zeros(16 * embree.RAYHIT_SLOTS + 16, np.float32)
    off = ((64 - buf.ctypes.data % 64) % 64) // 4
    ib = buf.view(np.uint32)
    vbuf = np.zeros(32, np.int32)
    voff = ((64 - vbuf.ctypes.data % 64) % 64) // 4
    abuf = np.zeros(embree.ARGS_SLOTS + 2, np.uint32)
    aoff = ((8 - abuf.ctypes.data % 8) % 8) // 4
    abuf[aoff + 1] = embree.FEATURE_FLAG_ALL
    for k in range(16):
        vbuf[voff + k] = -1 if valid[k] else 0
        embree.write_ray(buf, ib, off + k, 16, (org[k, 0], org[k, 1], org[k, 2]),
                         (dirs[k, 0], dirs[k, 1], dirs[k, 2]), 0.0, np.inf)
        embree.reset_hit(ib, off + k, 16)
        ib[off + embree.HIT_INST_ID * 16 + k] = 7  # Embree overwrites it on a hit
    embree.intersect16_packet(vbuf[voff:], handle, buf[off:], abuf[aoff:])
    geom = np.empty(16, np.int32)
    prim = np.empty(16, np.int32)
    uv = np.empty((16, 2), np.float32)
    t = np.empty(16, np.float32)
    ng = np.empty((16, 3), np.float32)
    inst = np.empty(16, np.uint32)
    for k in range(16):
        geom[k], prim[k], uv[k, 0], uv[k, 1], t[k] = embree.read_hit(buf, ib, off + k, 16)
        for j in range(3):
            ng[k, j] = buf[off + (embree.HIT_NG + j) * 16 + k]
        inst[k] = ib[off + embree.HIT_INST_ID * 16 + k]
    return geom, prim, uv, t, ng, inst


@pytest.mark.skipif(not embree.available(), reason="needs the direct Embree binding")
def test_a_packet_written_by_the_helpers_hits_where_the_geometry_says():
    """Rays down onto a two-model scene: every valid lane's hit, read through the named slots,
    is the point the ray reaches (position from the barycentrics, distance, normal), the lanes
    that miss or are masked off read as misses, and Embree wrote the instance slot."""
    cube = rs.shapes.cube(size=2.0)
    plane = rs.shapes.plane(size=20.0, subdivisions=1, center=(0.0, 0.0, -3.0), normal="+z")
    scene = rs.Scene([cube, plane])
    geo = scene.geometry
    handle = embree_accel(geo).handle
    rng = np.random.default_rng(3)
    xy = rng.uniform(-2.5, 2.5, (16, 2))
    xy[5] = (30.0, 30.0)  # misses everything
    org = np.column_stack([xy, np.full(16, 5.0)]) - geo.origin
    dirs = np.tile([0.0, 0.0, -1.0], (16, 1)) + np.column_stack([rng.uniform(-0.05, 0.05, (16, 2)), np.zeros(16)])
    valid = np.ones(16, np.bool_)
    valid[9] = False
    geom, prim, uv, t, ng, inst = _trace16(handle, org, dirs, valid)
    assert geom[5] == -1 and prim[5] == -1 and np.isinf(t[5]) and uv[5].tolist() == [0.0, 0.0]
    assert geom[9] == -1 and np.isinf(t[9])
    offsets = np.asarray(geo.face_offsets)
    for k in range(16):
        if k in (5, 9):
            continue
        inside = abs(org[k, 0] + geo.origin[0] + 5 * dirs[k, 0]) <= 1.0 and \
            abs(org[k, 1] + geo.origin[1] + 5 * dirs[k, 1]) <= 1.0
        assert geom[k] == (0 if inside else 1), k
        assert inst[k] == embree.INVALID_ID  # no instance: Embree wrote the instID slot
        f = offsets[geom[k]] + prim[k]
        p0, p1, p2 = geo.vertices[geo.faces[f]]
        hit = (1 - uv[k, 0] - uv[k, 1]) * p0 + uv[k, 0] * p1 + uv[k, 1] * p2
        np.testing.assert_allclose(hit, org[k] + t[k] * dirs[k], atol=1e-5)
        expected_z = 1.0 if inside else -3.0
        assert abs(hit[2] + geo.origin[2] - expected_z) < 1e-5
        n = np.cross(p1 - p0, p2 - p0)
        cosine = abs(float(ng[k] @ n)) / (np.linalg.norm(ng[k]) * np.linalg.norm(n))
        assert cosine > 1 - 1e-6  # the Ng slots hold the triangle's normal


@pytest.mark.skipif(not embree.available(), reason="needs the direct Embree binding")
def test_an_occlusion_ray_written_by_the_helpers_reports_in_the_tfar_slot():
    """``rtcOccluded1`` sets the named tfar slot to -inf for a blocked ray and leaves a free one."""
    scene = rs.Scene([rs.shapes.cube(size=2.0)])
    handle = np.uintp(embree_accel(scene.geometry).handle)
    origin = -scene.geometry.origin
    for start, blocked in (((0.0, 0.0, 5.0), True), ((5.0, 5.0, 5.0), False)):
        ray = _aligned(embree.RAY_SLOTS, np.float32, 16)
        embree.write_ray(ray, ray.view(np.uint32), 0, 1, tuple(np.add(start, origin)), (0.0, 0.0, -1.0), 0.0, 100.0)
        embree.occluded1_ray(handle, ray)
        assert bool(ray[embree.RAY_TFAR] == -np.inf) is blocked
        assert ray[embree.RAY_TFAR] == (-np.inf if blocked else 100.0)


def test_no_caller_writes_embree_slots_by_number():
    """The camera kernels, cast_rays, the query for secondary rays, explain and the benchmark write
    rays only through write_ray (no ``0xFFFFFFFF`` mask or id literal, no ``# tfar`` slot comment)."""
    callers = [ROOT / "raycast_shade" / "visibility" / "cast.py", ROOT / "raycast_shade" / "visibility" / "secondary.py",
               ROOT / "raycast_shade" / "study" / "explain.py", ROOT / "benchmarks" / "bench_limits.py"]
    for path in callers:
        if not path.exists():
            continue
        text = path.read_text(encoding="utf-8")
        assert "embree.write_ray(" in text, path.name
        assert "0xFFFFFFFF" not in text and "# tfar" not in text and "# mask" not in text, path.name
