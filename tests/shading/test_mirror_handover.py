"""Mirror rays handed over by the Phong kernels (issue 27).

For a frame whose reflective models are all Phong-shaded, the shading kernel that holds each
pixel's point, view vector and normals writes its first mirror ray
(:mod:`raycast_shade.shading.mirror_rays`), and the mirror kernel reads it instead of gathering
the pixel's face and vertices again. The rays, and so the images, must be those the mirror kernel
makes itself (``mirrors._start_lane``, ``_start_group``), bit for bit, for every Phong kernel
(batched, general, with shadow packets), banded or not, and the other frames keep their own start.
"""

from __future__ import annotations

import importlib
from dataclasses import replace

import numpy as np
import pytest
from numba import njit

import raycast_shade as rs
from raycast_shade.common.layout import MAT_REFLECTIVITY
from raycast_shade.shading import mirror_rays
from raycast_shade.shading.inputs import prepare
from raycast_shade.shading.jit import JIT
from raycast_shade.shading.lanes import _A, _FIELDS, _FN, _G, _N, _P, _V, LANES
from raycast_shade.shading.mirror_rays import NO_RAYS, _mirror_ray, hand_over_buffers, lane_rays
from raycast_shade.shading.phong import _surface
from raycast_shade.shading.records import At, Hit
from raycast_shade.shading.shade import SampleShading

from tests.shading.test_mirror import LIGHTS, PERFECT, SPHERE_MAT, mirror_mesh
from tests.shading.test_mirror_packets import _hall

render_module = importlib.import_module("raycast_shade.render")


def _variants():
    """Scenes for each Phong kernel: the hall (a textured ball: the general kernel; its light casts
    shadows: the packet kernel), untextured (the batched kernel, with and without shadow packets),
    and a bump-mapped mirror (the general kernel; the bumped normal bends the ray)."""
    hall = _hall()
    plain_ball = [m if m.material.kd_map is None else rs.Model(m.mesh, replace(m.material, kd_map=None))
                  for m in hall.models]
    unshadowed = [replace(light, shadows=False) for light in hall.lights]
    sphere = rs.shapes.icosphere(2, radius=0.5, center=(0.3, 0.2, 1.0))
    bumpy = replace(PERFECT, bump=rs.HeightMap.wrinkles(resolution=128, scale=0.05))
    bumped = rs.Scene([rs.Model(mirror_mesh(), bumpy), rs.Model(sphere, SPHERE_MAT)], lights=LIGHTS,
                      camera=rs.Camera(eye=(0.9, 1.2, 4.0), target=(0.0, 0.0, 0.4), width=61, height=45),
                      ambient=0.1)
    return {"general_packets": hall, "general": hall.replace(lights=unshadowed),
            "batched_shadows": hall.replace(models=plain_ball),
            "batched": hall.replace(models=plain_ball, lights=unshadowed), "bumped": bumped}


_SCENES = _variants()


def _both(scene, depth, shading="phong", monkeypatch=None):
    """``render(scene, shading, max_depth=depth)``'s image with the rays handed over and without
    (the mirror kernel starting its lanes itself), and whether the frame handed them over."""
    handed = []
    real = render_module._handed_rays

    def spy(*args):
        rays = real(*args)
        handed.append(rays is not None)
        return rays

    monkeypatch.setattr(render_module, "_handed_rays", spy)
    given = rs.render(scene, shading, max_depth=depth).image
    monkeypatch.setattr(render_module, "_handed_rays", lambda *args: None)
    own = rs.render(scene, shading, max_depth=depth).image
    return given, own, any(handed)


@pytest.mark.parametrize("depth", [1, 4])
@pytest.mark.parametrize("name", sorted(_SCENES))
def test_the_handed_over_rays_give_the_mirror_kernels_own_image(name, depth, monkeypatch):
    given, own, handed = _both(_SCENES[name], depth, monkeypatch=monkeypatch)
    assert handed
    assert np.array_equal(given.view(np.uint32), own.view(np.uint32))
    plain = rs.render(_SCENES[name], max_depth=0).image
    assert not np.array_equal(given, plain)  # not vacuous: the bounces changed the image


def test_a_banded_frame_hands_over_band_by_band(monkeypatch):
    """A frame of 2^19 pixels is cast, shaded and mirrored in bands of rows (one band's buffers,
    reused by every band): the same image as the mirror kernel's own start."""
    scene = _SCENES["batched"]
    scene = scene.replace(camera=replace(scene.camera, width=1024, height=512))
    given, own, handed = _both(scene, 2, monkeypatch=monkeypatch)
    assert handed
    assert np.array_equal(given.view(np.uint32), own.view(np.uint32))


def test_samples_share_one_buffer(monkeypatch):
    """Anti-aliasing: every sample's rays go through the frame's one buffer, each sample's mirror
    kernel reading its own: the same image as the mirror kernel's own start."""
    scene = _SCENES["batched_shadows"]
    real = render_module._handed_rays
    given = rs.render(scene, samples=4, max_depth=2).image
    monkeypatch.setattr(render_module, "_handed_rays", lambda *args: None)
    own = rs.render(scene, samples=4, max_depth=2).image
    monkeypatch.setattr(render_module, "_handed_rays", real)
    assert SampleShading(scene, scene.camera).hands_over
    assert np.array_equal(given.view(np.uint32), own.view(np.uint32))


def test_flat_and_gouraud_mirrors_start_their_own_lanes(monkeypatch):
    """Flat faces and Gouraud vertices have no per-pixel shading point: a frame with such a mirror
    hands nothing over (a Phong mirror beside it neither), and its image is unchanged."""
    hall = _SCENES["batched"]
    for shading in ("flat", "gouraud", ("flat", "phong", "phong")):
        shader = SampleShading(hall, hall.camera, shading)
        assert not shader.hands_over, shading
        given, own, handed = _both(hall, 2, shading, monkeypatch)
        assert not handed
        assert np.array_equal(given.view(np.uint32), own.view(np.uint32))
    dull_ball = hall.replace(models=[*hall.models[:2], rs.Model(hall.models[2].mesh,
                                                                replace(hall.models[2].material, reflectivity=0.0))])
    assert SampleShading(dull_ball, hall.camera, ("phong", "phong", "flat")).hands_over  # a flat model, not a mirror
    no_mirror = hall.replace(models=[rs.Model(m.mesh, replace(m.material, reflectivity=0.0)) for m in hall.models])
    assert not SampleShading(no_mirror, no_mirror.camera).hands_over


@pytest.mark.parametrize("name", ["batched", "batched_shadows", "general", "general_packets", "bumped"])
def test_each_reflective_pixel_gets_its_scalar_mirror_ray_and_no_other_pixel_is_written(name):
    """The rays a Phong kernel writes are ``_mirror_ray(_surface(...))`` of the pixel's hit (the
    origin rounded to float32, as Embree takes it); the other pixels of the buffers stay as they were;
    the batched kernel's rays are the general kernel's, bit for bit."""
    scene = _SCENES[name]
    cam = scene.camera
    hits = rs.cast_camera(scene.geometry, cam)
    shader = SampleShading(scene, cam)
    org = np.full(hits.shape + (3,), np.nan, np.float32)
    dr = np.full(hits.shape + (3,), np.nan, np.float64)
    shader.shade(hits, rays=(org, dr))
    k = prepare(scene, cam)
    rho = k["materials"][:, MAT_REFLECTIVITY][np.maximum(hits.geom, 0)]
    mirror = (hits.prim >= 0) & (rho > 0.0)
    assert mirror.sum() > 50 and (~mirror).sum() > 50
    assert np.isnan(org[~mirror]).all() and np.isnan(dr[~mirror]).all()
    ys, xs = np.nonzero(mirror)
    want_o, want_d = _scalar_rays(hits, k, ys, xs)
    assert np.array_equal(org[ys, xs].view(np.uint32), want_o.astype(np.float32).view(np.uint32))
    # The kernels' flags allow reassociation, so a direction's last bits depend on the code around
    # it: a separately compiled reference agrees to an ulp or two (the images agree bit for bit:
    # the tests above, and tests/render/test_bit_identity.py), the kernels with each other exactly.
    assert np.allclose(dr[ys, xs], want_d, rtol=0.0, atol=4e-16)
    if shader.fast_phong:
        general = SampleShading(scene, cam)
        general.fast_phong = False
        org2, dr2 = np.full_like(org, np.nan), np.full_like(dr, np.nan)
        general.shade(hits, rays=(org2, dr2))
        assert np.array_equal(org.view(np.uint32), org2.view(np.uint32))
        assert np.array_equal(dr.view(np.uint64), dr2.view(np.uint64))


@njit(**JIT)  # the shading kernels' flags: the same contractions as theirs
def _scalar_kernel(prim, geom, u, v, G, B, face_off, cam, unit, ys, xs, o, d):
    for i in range(ys.shape[0]):
        y, x = ys[i], xs[i]
        at = At(face_off[geom[y, x]] + prim[y, x], geom[y, x], np.float64(u[y, x]), np.float64(v[y, x]))
        org, r = _mirror_ray(_surface(G, B, cam, at, False, (0.0, 0.0, 0.0)), unit)
        for c in range(3):
            o[i, c] = org[c]
            d[i, c] = r[c]


def _scalar_rays(hits, k, ys, xs):
    o = np.empty((len(ys), 3))
    d = np.empty((len(ys), 3))
    _scalar_kernel(hits.prim, hits.geom, hits.u, hits.v, k["G"], k["B"], k["face_off"], k["cam"], k["L"].unit,
                   ys, xs, o, d)
    return o, d


@njit(**JIT)
def _lanes_both(S, n, unit, o, d):
    """``lane_rays`` over the scratch ``S`` (into ``S``), and ``_mirror_ray`` of each lane (into ``o``, ``d``)."""
    for k in range(n):
        pt = (S[(_P + 0) * LANES + k], S[(_P + 1) * LANES + k], S[(_P + 2) * LANES + k])
        hp = Hit(pt, (S[(_V + 0) * LANES + k], S[(_V + 1) * LANES + k], S[(_V + 2) * LANES + k]),
                 (S[(_G + 0) * LANES + k], S[(_G + 1) * LANES + k], S[(_G + 2) * LANES + k]), 1.0,
                 (S[(_N + 0) * LANES + k], S[(_N + 1) * LANES + k], S[(_N + 2) * LANES + k]), pt)
        org, r = _mirror_ray(hp, unit)
        for c in range(3):
            o[k, c] = org[c]
            d[k, c] = r[c]
    lane_rays(S, n, unit)


@pytest.mark.parametrize("unit", [1.0, 3.7e-3, 1e-310, 1e300])
def test_the_vectorised_lane_rays_are_the_scalar_mirror_ray_bit_for_bit(unit):
    """``lane_rays`` (selects over every lane) against ``_mirror_ray`` lane by lane: random unit
    view vectors and normals (bent normals reflected back above the surface), points near zero,
    across powers of two, with subnormal steps (a tiny unit), inf and NaN (``_nudge``'s own cases):
    the origins bit for bit, the directions to an ulp."""
    rng = np.random.default_rng(int(unit * 1e3) % 2 ** 32 if unit < 1e10 else 7)
    S = np.zeros(_FIELDS * LANES)
    unitv = lambda a: a / np.linalg.norm(a, axis=0)  # noqa: E731
    for field, vec in ((_V, unitv(rng.normal(size=(3, LANES)))), (_G, unitv(rng.normal(size=(3, LANES)))),
                       (_N, unitv(rng.normal(size=(3, LANES))))):
        S[field * LANES:(field + 3) * LANES] = vec.reshape(-1)
    p = rng.normal(size=(3, LANES)) * 10.0 ** rng.integers(-8, 8, (3, LANES))
    p[:, :6] = [[0.0, 1e-320, -3e-310, np.inf, np.nan, 2.0 ** -1000]] * 3
    p[0, 6:10] = [unit / 32.0, np.nextafter(unit / 32.0, 0.0), -unit / 32.0, 1.5 * unit]
    S[_P * LANES:(_P + 3) * LANES] = p.reshape(-1)
    n = LANES - 3  # the lanes past n are computed but not fixed up (not read)
    o, d = np.empty((n, 3)), np.empty((n, 3))
    _lanes_both(S, n, unit, o, d)
    got_o = S[_A * LANES:(_A + 3) * LANES].reshape(3, LANES)[:, :n].T
    got_d = S[_FN * LANES:(_FN + 3) * LANES].reshape(3, LANES)[:, :n].T
    assert np.array_equal(got_o, o, equal_nan=True)  # the offsets, _nudge's cases included: exact
    assert np.allclose(got_d, d, rtol=0.0, atol=4e-16)  # (reassociation: see the test above)
    assert np.isfinite(o).sum() > 2 * n  # not vacuous


def test_a_wrong_rays_buffer_is_refused_and_the_stand_in_writes_nothing():
    scene = _SCENES["batched"]
    hits = rs.cast_camera(scene.geometry, scene.camera)
    shader = SampleShading(scene, scene.camera)
    with pytest.raises(ValueError, match="rays"):
        shader.shade(hits, rays=hand_over_buffers(hits.shape[0] - 1, hits.shape[1]))
    a = shader.shade(hits)
    b = shader.shade(hits, rays=hand_over_buffers(*hits.shape))
    assert np.array_equal(a.view(np.uint32), b.view(np.uint32))  # handing over leaves the image alone
    assert NO_RAYS[0].shape == (0, 0, 3) and NO_RAYS[1].dtype == np.float64
    assert mirror_rays.hand_over_buffers(4, 5)[0].shape == (4, 5, 3)


def _fma(a, b, c):
    """``a * b + c`` rounded once, exactly (rationals): the reference of the fused origin."""
    from fractions import Fraction

    return float(Fraction(a) * Fraction(b) + Fraction(c))


def test_the_origins_offset_is_rounded_once_whatever_the_optimiser_does():
    """``_offset``'s ``p + n * step`` near zero (the step ``unit / 65536`` is no power of two, so
    the product is inexact) is the fused multiply-add, explicitly (``_fused``), in the scalar
    helper and the vectorised lanes alike: before, each was contracted or not by where LLVM placed
    the multiply (linking the helpers' IR unoptimised changed it for one of them)."""
    rng = np.random.default_rng(5)
    unit = 3.7e-3
    S = np.zeros(_FIELDS * LANES)
    g = rng.normal(size=(3, LANES))
    g /= np.linalg.norm(g, axis=0)
    p = rng.uniform(-4.0, 4.0, size=(3, LANES)) * unit / 65536.0  # near zero (the step unit / 65536), the size of the move
    for field, vec in ((_V, g), (_G, g), (_N, g), (_P, p)):
        S[field * LANES:(field + 3) * LANES] = vec.reshape(-1)
    o, d = np.empty((LANES, 3)), np.empty((LANES, 3))
    _lanes_both(S, LANES, unit, o, d)
    step = unit * (1.0 / 65536.0)
    want = np.array([[_fma(g[c, k], step, p[c, k]) for c in range(3)] for k in range(LANES)])
    unfused = (p + g * step).T
    assert np.array_equal(o, want)  # the scalar helper's
    assert np.array_equal(S[_A * LANES:(_A + 3) * LANES].reshape(3, LANES).T, want)  # the lanes'
    assert np.count_nonzero(want != unfused) > 0  # the case tells fused from unfused
