"""Shadow rays as packets: the same rays as one by one, so the same images bit for bit.

A Phong frame whose lights cast shadows traces them as ``rtcOccluded16`` packets
(:mod:`raycast_shade.shading.shadows`): the batched kernel 16 of its lanes per packet and light
(:mod:`raycast_shade.shading.phong_fast`), the packet kernel of textured or bump-mapped frames each
4x4 tile's rays per light (:mod:`raycast_shade.shading.phong`). The oracle is the
single-ray kernel the packets replace (``rtcOccluded1`` per point, still what Gouraud, flat,
terms and mirrors use): every scene below renders bit for bit as it does, and each scene has
shadows to lose (its image differs from the one without shadows), so no comparison is vacuous.
"""

from __future__ import annotations

import dataclasses
import math
import os
import pathlib
import subprocess
import sys
import textwrap
import unittest.mock as mock

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from numba import njit

import raycast_shade as rs
from raycast_shade.shading import shade as shade_mod
from raycast_shade.shading import shadows
from raycast_shade.shading.jit import HELPER, variant
from raycast_shade.shading.phong import _PHONG, _PHONG_PACKETS
from raycast_shade.visibility import embree, secondary
from raycast_shade.visibility.accel import embree_accel


def _single_ray_image(scene, monkeypatch, **kwargs):
    """The frame rendered by the one-ray-at-a-time Phong kernel."""
    with monkeypatch.context() as m:
        m.setattr(shade_mod, "_fast_applies", lambda modes, k: False)
        m.setattr(shade_mod, "_PHONG_PACKETS", _PHONG)
        return rs.render(scene, **kwargs).image


def _tile_image(scene, monkeypatch, **kwargs):
    """The frame rendered by the packet kernel of 4x4 tiles (the batched kernel refused)."""
    with monkeypatch.context() as m:
        m.setattr(shade_mod, "_fast_applies", lambda modes, k: False)
        return rs.render(scene, **kwargs).image


def _without_shadows(scene):
    return scene.replace(lights=[dataclasses.replace(light, shadows=False) for light in scene.lights])


def _checker(n=8):
    c = (np.indices((n, n)).sum(0) % 2).astype(np.float64)
    return rs.Texture(np.stack([0.2 + 0.7 * c, 0.5 + 0.0 * c, 0.9 - 0.6 * c], axis=-1), name="checker")


def _scene(kind, width=67, height=53):
    """Spheres over a floor, lit by every kind of light (some casting shadows, one not)."""
    ball = rs.shapes.icosphere(3, radius=0.6)
    small = rs.shapes.icosphere(2, radius=0.25, center=(0.8, -0.2, 0.5))
    floor = rs.shapes.plane(6.0, subdivisions=3, center=(0.0, -0.7, 0.0), normal="+y")
    lights = [rs.PointLight((1.5, 3.0, 2.0), intensity=12.0, attenuation="inverse_square", shadows=True),
              rs.DirectionalLight((-0.4, -1.0, -0.3), intensity=0.4, shadows=True),
              rs.SpotLight((-1.0, 2.5, 1.0), direction=(0.4, -1.0, -0.3), intensity=6.0, inner_angle=15.0,
                           outer_angle=25.0, shadows=True),
              rs.PointLight((0.0, 1.0, 4.0), intensity=0.5)]  # casts none: never traced
    plain = rs.Material(kd=(0.8, 0.3, 0.2), ks=0.4, shininess=30.0)
    if kind == "textured":  # the tex_on variant: the coefficients kept between the two passes
        plain = rs.Material(kd_map=_checker(), ks=0.4, shininess=30.0)
    models = [rs.Model(ball, plain), rs.Model(small, rs.Material(kd=0.5, ks=0.0)),
              rs.Model(floor, rs.Material(kd=0.7, ks=0.2, shininess=10.0))]
    cam = rs.Camera(eye=(0.5, 1.5, 3.5), target=(0.0, -0.3, 0.0), width=width, height=height)
    if kind == "ortho":
        cam = rs.Camera(eye=(0.5, 1.5, 3.5), target=(0.0, -0.3, 0.0), width=width, height=height,
                        projection="orthographic", ortho_height=3.0)
    return rs.Scene(models, lights=lights, camera=cam, ambient=0.1)


@pytest.mark.parametrize("kind", ["plain", "textured", "ortho"])
def test_packets_render_the_single_ray_image_bit_for_bit(kind, monkeypatch):
    """Odd sizes (partial tiles at the right and bottom), three shadowing lights of every kind,
    one that casts none, textured and orthographic variants: the frame (the batched kernel's,
    untextured) and the 4x4-tile kernel's."""
    scene = _scene(kind)
    got = rs.render(scene).image
    want = _single_ray_image(scene, monkeypatch)
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(_tile_image(scene, monkeypatch), want)
    lost = np.any(got != rs.render(_without_shadows(scene)).image, axis=-1)
    assert lost.mean() > 0.05, lost.mean()  # shadows there to lose: the comparison is not vacuous


def test_the_packet_kernel_is_the_one_that_runs():
    """A textured frame with a shadowing light runs the packet kernel; one without, the plain
    kernel (untextured frames run the batched kernel: tests/shading/test_phong_fast.py)."""
    from raycast_shade.shading.inputs import prepare

    scene = _scene("textured", 16, 12)
    k = prepare(scene, scene.camera)
    packets = variant(_PHONG_PACKETS, k)
    calls = []

    def spy(*args):
        calls.append(True)
        return packets(*args)

    assert k["L"].handle != 0
    with mock.patch.dict(_PHONG_PACKETS, {key: spy if fn is packets else fn for key, fn in _PHONG_PACKETS.items()}):
        rs.render(scene)
        assert calls, "the packet kernel did not run for a shadowed frame"
        calls.clear()
        rs.render(_without_shadows(scene))
        assert not calls, "the packet kernel ran for a frame without shadows"


def test_a_banded_frame_with_packets_is_the_single_ray_frame(monkeypatch):
    """Large enough for the banded path (2**19 pixels): each band, whatever its first row, tiles its
    own rows (the packets group pixels differently from the whole frame; the answers are the same).
    The frame is the batched kernel's; the 4x4-tile kernel's the same."""
    scene = _scene("plain", 1024, 512)
    rows = []
    band_shade = shade_mod.SampleShading.shade

    def shade(self, hits, out=None, y0=0, normal=None, rays=None):
        rows.append(y0)
        return band_shade(self, hits, out, y0, normal, rays)

    with monkeypatch.context() as m:
        m.setattr(shade_mod.SampleShading, "shade", shade)
        got = rs.render(scene).image
    assert len(rows) >= 4 and rows[0] == 0  # shaded band by band
    np.testing.assert_array_equal(got, _single_ray_image(scene, monkeypatch))
    np.testing.assert_array_equal(_tile_image(scene, monkeypatch), got)


def _masked_grid_and_floor():
    """A 4 x 4 grid at y = 0.3 whose alpha map clears every other cell (a checkerboard), over a floor
    at y = -0.7: the two models of the alpha-mask tests."""
    n = 4
    xs = np.linspace(-1.0, 1.0, n + 1)
    v = np.array([(x, 0.3, z) for z in xs for x in xs])
    faces = []
    for i in range(n):
        for j in range(n):
            a = i * (n + 1) + j
            faces += [(a, a + n + 2, a + 1), (a, a + n + 1, a + n + 2)]
    uv = (v[:, [0, 2]] + 1.0) / 2.0
    cov = (np.indices((n, n)).sum(0) % 2 == 0).astype(np.float64)
    amap = rs.Texture(np.repeat(cov[..., None], 3, axis=2), wrap="clamp", name="alpha")
    grid = rs.Model(rs.Mesh(v, np.array(faces), uvs=uv), rs.Material(kd=0.6, alpha_map=amap, alpha_cutoff=0.5))
    floor = rs.Model(rs.shapes.plane(4.0, center=(0.0, -0.7, 0.0), normal="+y"), rs.Material(kd=0.8))
    return grid, floor


def test_alpha_masked_occluders_let_packet_rays_through_their_clear_texels(monkeypatch):
    """The occlusion filter of a masked model sees packets too (Embree calls it with N lanes)."""
    grid, floor = _masked_grid_and_floor()
    cam = rs.Camera(eye=(0.0, 3.0, 2.5), target=(0.0, -0.7, 0.0), width=64, height=48)
    scene = rs.Scene([grid, floor], lights=[rs.PointLight((0.1, 3.0, 0.2), intensity=8.0, shadows=True)],
                     camera=cam, ambient=0.1)
    got = rs.render(scene).image
    np.testing.assert_array_equal(got, _single_ray_image(scene, monkeypatch))
    np.testing.assert_array_equal(_tile_image(scene, monkeypatch), got)
    on_floor = rs.cast_camera(scene, cam).geom == 1
    lum = got.mean(axis=-1)[on_floor]
    assert (lum < 0.2).mean() > 0.05 and (lum > 0.3).mean() > 0.2  # shadows of covered cells, light through holes


# Under glibc's free-poisoning (every free overwrites the block with 0xA5): a packet, valid mask or
# RTCOccludedArguments freed before Embree read it would turn into garbage rays or pointers.
_POISONED = textwrap.dedent("""
    import ctypes, sys
    import numpy as np
    libc = ctypes.CDLL(None)
    libc.malloc.restype = ctypes.c_void_p
    libc.malloc.argtypes = [ctypes.c_size_t]
    libc.free.argtypes = [ctypes.c_void_p]
    p = libc.malloc(96)
    ctypes.memset(p, 0, 96)
    libc.free(p)
    if ctypes.string_at(p + 32, 48) != b"\\xa5" * 48:
        print("NOPOISON")
        sys.exit(0)
    import raycast_shade as rs
    sys.path.insert(0, sys.argv[2])
    from test_shadow_packets import _scene
    np.save(sys.argv[1], np.stack([rs.render(_scene(kind)).image for kind in ("plain", "textured")]))
    print("OK")
""")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc tunables")
def test_the_packet_kernel_keeps_its_embree_buffers_alive_when_frees_are_poisoned(tmp_path):
    env = dict(os.environ, GLIBC_TUNABLES="glibc.malloc.tcache_count=0:glibc.malloc.perturb=165")
    out = tmp_path / "image.npy"
    proc = subprocess.run([sys.executable, "-c", _POISONED, str(out), str(pathlib.Path(__file__).parent)],
                          env=env, capture_output=True, text=True, timeout=900)
    if "NOPOISON" in proc.stdout:
        pytest.skip("this libc does not poison freed memory")
    assert proc.returncode == 0 and "OK" in proc.stdout, proc.stderr[-3000:]
    np.testing.assert_array_equal(np.load(out), np.stack([rs.render(_scene(kind)).image
                                                          for kind in ("plain", "textured")]))


# -- the packets against single rays, ray for ray -------------------------------------------------------


@njit(cache=False)
def _trace_both(handle, origins, directions, tfar, active):
    """Each group of 16 rays as one packet (:func:`.secondary.trace_occlusion`, inactive lanes off) and one
    by one (``rtcOccluded1``): (vis per lane, blocked per ray, the packet's tfar slots after the call)."""
    n = origins.shape[0] // shadows.LANES
    buf, ib, off, valid, voff, args, aoff, vis, points = shadows._packets(1)
    packet = np.empty((n, shadows.LANES), np.int8)
    after = np.empty((n, shadows.LANES), np.float32)
    single = np.zeros(origins.shape[0], np.bool_)
    S1 = secondary.ray_scratch()
    for t in range(n):
        shadows.clear_packets(valid, voff, vis, points)
        for k in range(shadows.LANES):
            r = t * shadows.LANES + k
            buf[off + embree.RAY_TFAR * shadows.LANES + k] = 7.0  # an inactive lane keeps it
            if active[r]:
                secondary.set_occlusion_ray((buf, ib, off, valid, voff), 0, k,
                                            (origins[r, 0], origins[r, 1], origins[r, 2]),
                                            (directions[r, 0], directions[r, 1], directions[r, 2]), tfar[r])
        secondary.trace_occlusion(handle, buf, off, valid, voff, args, aoff, vis)
        for k in range(shadows.LANES):
            packet[t, k] = vis[0, k]
            after[t, k] = buf[off + embree.RAY_TFAR * shadows.LANES + k]
            r = t * shadows.LANES + k
            single[r] = secondary.occluded(handle, S1, (origins[r, 0], origins[r, 1], origins[r, 2]),
                                           (directions[r, 0], directions[r, 1], directions[r, 2]), tfar[r])
    return packet, single, after


def test_packets_answer_as_single_rays_and_leave_inactive_lanes_alone():
    """Random rays from around a sphere (many blocked, many not; finite and infinite tfar): each
    active lane's answer is ``rtcOccluded1``'s, and an inactive lane is neither answered nor written."""
    scene = _scene("plain", 8, 8)
    geo = scene.geometry
    handle = np.uintp(embree_accel(geo).handle)
    rng = np.random.default_rng(27)
    n = 16 * 200
    origins = rng.uniform(-2.0, 2.0, (n, 3))
    directions = rng.standard_normal((n, 3))
    tfar = np.where(rng.random(n) < 0.5, np.inf, rng.uniform(0.1, 3.0, n))
    active = rng.random(n) < 0.8
    packet, single, after = _trace_both(handle, origins, directions, tfar, active)
    packet, after = packet.ravel(), after.ravel()
    assert 0.2 < single[active].mean() < 0.8  # both answers well represented
    np.testing.assert_array_equal(packet[active], single[active].astype(np.int8))
    assert np.all(packet[~active] == -1) and np.all(after[~active] == 7.0)
    assert np.all((after[active] == -np.inf) == single[active])


# -- the offset's exponent, read off the bits ------------------------------------------------------------


@njit(**HELPER)
def _nudge_libm(p, n, unit):
    """The offset as it was written with frexp and ldexp (the same compile flags as the kernels)."""
    if abs(p) < unit * (1.0 / 32.0):
        return p + n * (unit * (1.0 / 65536.0))
    _, e = math.frexp(p)
    return p + n * math.ldexp(256.0, e - 24)


@njit(cache=False)
def _both(p, n, unit):
    return shadows._nudge(p, n, unit), _nudge_libm(p, n, unit)


@settings(max_examples=400, deadline=None)
@given(p=st.floats(allow_nan=True, allow_infinity=True, width=64),
       n=st.floats(-1.0, 1.0), unit=st.sampled_from([1e-18, 1e-3, 1.0, 1e5, 1e18]))
def test_the_nudge_equals_frexp_and_ldexp_everywhere(p, n, unit):
    a, b = _both(p, n, unit)
    assert a == b or (math.isnan(a) and math.isnan(b)), (p, n, unit, a, b)


@pytest.mark.parametrize("kind, shadowed", [("plain", True), ("textured", True), ("plain", False)])
def test_every_phong_kernel_writes_the_normal_buffer_as_frame_normal(kind, shadowed):
    """The ``normal`` buffer is written by whichever Phong kernel shades the frame (the batched
    kernel with or without shadow rays, the tile packets of a textured frame): bit for bit the
    normals pass of ``frame.normal``."""
    scene = _scene(kind) if shadowed else _without_shadows(_scene(kind))
    frame = rs.render(scene, buffers=("normal", "normal_camera"))
    assert np.array_equal(frame.buffers["normal"].view(np.uint32), frame.normal.view(np.uint32))
    assert np.any(frame.buffers["normal"] != 0.0)


def test_light_falls_through_the_clear_texels_of_an_alpha_masked_occluder():
    """Seen from straight above, with the light straight above, the floor seen through the masked
    grid's holes is lit exactly as without shadows: the shadow rays pass the same holes. Were the
    mask applied to camera rays only, the grid would shadow all of that floor (none of it lit)."""
    grid, floor = _masked_grid_and_floor()
    cam = rs.Camera(eye=(0.0, 6.0, 0.01), target=(0.0, -0.7, 0.0), width=80, height=80)
    scene = rs.Scene([grid, floor], lights=[rs.DirectionalLight((0.0, -1.0, 0.0), intensity=0.9, shadows=True)],
                     camera=cam, ambient=0.1)
    under = np.zeros((80, 80), bool)
    under[25:55, 25:55] = True  # inside the grid's footprint on screen
    through = (rs.cast_camera(scene, cam).geom == 1) & under  # the floor seen through the holes
    lit = np.all(rs.render(scene).image == rs.render(_without_shadows(scene)).image, axis=-1)
    assert through.sum() > 200
    assert (lit & through).sum() > 0.7 * through.sum()  # measured: 398 of 450 (the rest by the cells' edges)
