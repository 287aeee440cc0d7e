"""The mirror's floor in ``benchmarks/bench_shadows.py`` (``rays_bounce16``): the bounce rays it traces
bare are the mirror kernel's, one per reflective pixel, and its ``rtcIntersect16`` packets answer as
single ``rtcIntersect1`` rays do."""

from __future__ import annotations

import numpy as np

import raycast_shade as rs
from benchmarks import bench_shadows
from raycast_shade.visibility import embree
from raycast_shade.visibility.cast import cast_camera

_LANES = 16


def _mirror_scene(backdrop: bool):
    """A mirror sphere (reflectivity 0.5), and optionally a wall behind the camera that the bounces meet."""
    sphere = rs.shapes.icosphere(3)
    mirror = rs.Material(kd=(0.8, 0.3, 0.2), reflectivity=0.5)
    models = [rs.Model(sphere, mirror)]
    if backdrop:
        models.append(rs.Model(rs.shapes.plane(size=40.0, center=(0.0, 0.0, 6.0), normal="-z"), rs.Material()))
    cam = rs.Camera(eye=(0.0, 0.0, 3.0), fov=40.0, width=48, height=36)
    return rs.Scene(models, lights=[rs.PointLight(position=(2.0, 3.0, 4.0))], camera=cam)


def _single_hits(handle, rays, valid):
    """Each active lane's ray alone (``rtcIntersect1``): its hit model, -1 for a miss."""
    out = np.full(valid.shape, -1, np.int32)
    buf = np.zeros(2 * embree.RAYHIT_SLOTS, np.float32)
    off = ((16 - buf.ctypes.data % 16) % 16) // 4
    ib = buf.view(np.uint32)
    for t, k in zip(*np.nonzero(valid)):
        for s in range(embree.RAY_SLOTS):
            buf[off + s] = rays[t, s * _LANES + k]
        embree.reset_hit(ib, off, 1)
        embree.intersect1_ray(handle, buf[off:])
        out[t, k] = embree.read_hit(buf, ib, off, 1)[0]
    return out


def test_one_bounce_ray_per_reflective_pixel():
    scene = _mirror_scene(backdrop=False)
    hits = cast_camera(scene.geometry, scene.camera)
    _, rays, valid = bench_shadows._bounce_rays(scene)
    assert int((valid != 0).sum()) == int((hits.prim >= 0).sum()) > 0


def test_bounces_off_a_lone_convex_mirror_all_miss():
    scene = _mirror_scene(backdrop=False)
    handle, rays, valid = bench_shadows._bounce_rays(scene)
    out = np.zeros(valid.shape, np.int32)
    bench_shadows._bounce_packets(handle, rays, valid, out)
    assert np.all(out[valid != 0] == -1)


def test_bounce_packets_answer_as_single_rays():
    scene = _mirror_scene(backdrop=True)
    handle, rays, valid = bench_shadows._bounce_rays(scene)
    out = np.full(valid.shape, -1, np.int32)
    bench_shadows._bounce_packets(handle, rays, valid, out)
    single = _single_hits(handle, rays, valid)
    assert np.array_equal(out, single)
    assert np.any(out[valid != 0] == 1)  # the wall is met


def test_only_reflective_pixels_bounce():
    scene = _mirror_scene(backdrop=False)
    wall = rs.Model(rs.shapes.plane(size=40.0, center=(0.0, 0.0, -3.0), normal="+z"), rs.Material(reflectivity=0.5))
    scene = scene.replace(models=[rs.Model(scene.models[0].mesh, rs.Material()), wall])
    hits = cast_camera(scene.geometry, scene.camera)
    n = int((bench_shadows._bounce_rays(scene)[2] != 0).sum())
    assert np.any(hits.geom == 0)  # the matte sphere is in view
    assert n == int(((hits.prim >= 0) & (hits.geom == 1)).sum()) > 0  # the wall's pixels bounce, the sphere's not
