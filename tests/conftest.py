"""Small helpers shared by the core renderer's tests."""

from __future__ import annotations

import numpy as np

import raycast_shade as rs
from raycast_shade.study.twins import generate_rays_numpy

# Tolerance for "equal up to float32 rounding" of quantities computed through
# float32 hit buffers (barycentrics, t) into a float32 image (eps = 1.2e-7).
RTOL32 = 2e-6


def camera_rays(camera):
    """World-space rays of every pixel centre, float64.

    Returns
    -------
    origins, directions : (H, W, 3) float64
        Unit directions.
    """
    o, d = generate_rays_numpy(camera)
    shape = (camera.height, camera.width, 3)
    return o.reshape(shape), d.reshape(shape)


def plane_hits(camera, z0=0.0):
    """Exact intersection of every camera ray with the plane ``z = z0``.

    Returns
    -------
    points : (H, W, 3) float64
    t : (H, W) float64
        Distance along the unit ray (NaN where the ray is parallel).
    """
    o, d = camera_rays(camera)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (z0 - o[..., 2]) / d[..., 2]
    return o + t[..., None] * d, t


def lit_scene(mesh, material=None, lights=(), camera=None, ambient=0.0):
    """A one-model scene."""
    return rs.Scene([rs.Model(mesh, material or rs.Material())], lights=list(lights), camera=camera, ambient=ambient)


def down_camera(eye=(0.0, 0.0, 3.0), target=(0.0, 0.0, 0.0), width=81, height=61, projection="perspective", **kw):
    """A small camera looking at the xy plane from above (+z)."""
    return rs.Camera(eye=eye, target=target, up=(0.0, 1.0, 0.0), width=width, height=height,
                     projection=projection, **kw)


def render_all(scene, **kw):
    """The scene rendered in every shading mode: ``{mode: Frame}``."""
    return {m: rs.render(scene, m, **kw) for m in rs.SHADINGS}


def assert_sane(frame):
    """The invariants every frame keeps, whatever the scene: finite, non-negative
    image; unit normals on hit pixels and zero normals elsewhere."""
    img = frame.image
    assert np.isfinite(img).all()
    assert img.min() >= 0.0
    n = frame.normal
    assert np.isfinite(n).all()
    np.testing.assert_allclose(np.linalg.norm(n[frame.mask], axis=-1), 1.0, atol=1e-5)
    assert (n[~frame.mask] == 0).all()


def hit_buffer(u, v, prim=0):
    """A hit buffer of one model whose pixels hit face ``prim`` at barycentrics ``(u, v)`` (H, W), t = 1."""
    u = np.asarray(u, np.float32)
    v = np.asarray(v, np.float32)
    return rs.HitBuffer(prim=np.full(u.shape, prim, np.int32), geom=np.zeros(u.shape, np.int32), u=u, v=v,
                        t=np.ones(u.shape, np.float32))


# One triangle in z = 0 (the input-contract tests' smallest mesh).
TRI_V = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
TRI_F = [[0, 1, 2]]


def small_scene(**kw):
    """The triangle under a point light, seen by an 8 x 6 camera (``kw`` go to :class:`Scene`)."""
    kw.setdefault("camera", rs.Camera(eye=(0.0, 0.0, 3.0), width=8, height=6))
    return rs.Scene([rs.Mesh(TRI_V, TRI_F)], lights=[rs.PointLight((0, 0, 2))], **kw)


def pytest_xdist_auto_num_workers(config):
    """``-n auto`` (pyproject's addopts): one worker per usable core, at most 4 — each worker compiles
    the kernels it needs (about 1.5 GB at peak), so more workers would cost memory, not time."""
    import os

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, min(cores, 4))
