"""The pipeline around the kernels: casters, re-centring, BVH reuse, frames and
their files, tone mapping, arbitrary rays, and a property test over random scenes."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.visibility.accel import embree_accel, embreex_scene, has_embree_accel
from raycast_shade.study.reference import hit_points

from tests.conftest import camera_rays


def _models(offset):
    offset = np.asarray(offset, float)
    sphere = rs.shapes.icosphere(3, radius=0.8)
    cube = rs.shapes.cube(center=(1.5, 0.0, 0.0))
    torus = rs.shapes.torus(0.6, 0.2, 24, 12, center=(-1.5, 0.0, 0.0))
    return [
        rs.Model(rs.Mesh(sphere.vertices + offset, sphere.faces, normals=sphere.normals),
                 rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=30)),
        rs.Model(rs.Mesh(cube.vertices + offset, cube.faces, crease_angle=30.0), rs.Material(kd=0.6, ks=0.3)),
        rs.Model(rs.Mesh(torus.vertices + offset, torus.faces, normals=torus.normals),
                 rs.Material(kd=0.5, ks=0.8, shininess=60, specular="blinn")),
    ]


def scene_at(offset, width=120, height=90):
    """Three models, three kinds of light and a camera, all shifted by ``offset``."""
    offset = np.asarray(offset, float)
    lights = [rs.PointLight(np.array([2.0, 3.0, 4.0]) + offset, 20.0, attenuation="inverse_square"),
              rs.PointLight(np.array([-2.0, 1.0, 2.0]) + offset, 3.0, color=(1, 0.6, 0.3), attenuation="heuristic", k=0.5),
              rs.DirectionalLight((1.0, -1.0, -1.0), 0.3)]
    cam = rs.Camera(eye=np.array([0.3, 1.0, 4.0]) + offset, target=offset, width=width, height=height)
    return rs.Scene(_models(offset), lights=lights, camera=cam)


BASE = scene_at(np.zeros(3))


def test_the_two_casters_agree():
    """The packet-traced direct Embree caster and embreex's own API see the
    same triangles at the same barycentrics and distances (allowing a handful
    of pixels exactly on shared edges, where either triangle is right)."""
    a = rs.cast_camera(BASE.geometry, BASE.camera, caster="embree")
    b = rs.cast_camera(BASE.geometry, BASE.camera, caster="embreex")
    assert a.mask.mean() > 0.15
    differ = (a.prim != b.prim) | (a.geom != b.geom)
    assert differ.sum() <= 0.002 * differ.size  # measured: 0
    np.testing.assert_array_equal(a.mask, b.mask)
    same = ~differ & a.mask
    np.testing.assert_allclose(a.u[same], b.u[same], atol=1e-6)
    np.testing.assert_allclose(a.v[same], b.v[same], atol=1e-6)
    np.testing.assert_allclose(a.t[same], b.t[same], rtol=1e-6)
    assert np.isinf(a.t[~a.mask]).all() and np.isinf(b.t[~b.mask]).all()
    assert (a.u[~a.mask] == 0).all() and (a.geom[~a.mask] == -1).all()
    # Through render, too.
    fa = rs.render(BASE, "phong", caster="embree")
    fb = rs.render(BASE, "phong", caster="embreex")
    np.testing.assert_allclose(fa.image[~differ], fb.image[~differ], atol=1e-5)


def test_hit_buffer_distance_is_the_ray_distance():
    """t is the distance along the unit camera ray: o + t d is the hit point."""
    frame = rs.render(BASE, "flat")
    o, d = camera_rays(BASE.camera)
    from_t = (o + frame.hits.t[..., None].astype(np.float64) * d)[frame.mask]
    from_bary = hit_points(BASE, frame.hits)[frame.mask]
    assert np.linalg.norm(from_t - from_bary, axis=1).max() < 1e-4
    assert np.isnan(hit_points(BASE, frame.hits)[~frame.mask]).all()


@pytest.mark.parametrize("shift", [1e3, 1e5])
def test_translated_scene_renders_the_same(shift):
    """Re-centring in float64 before Embree's float32: a scene 1e5 away renders
    like one at the origin. Stated tolerance: at most 0.2% of the pixels may
    see another triangle, and all others agree to 1e-5 (measured: no pixel
    changes triangle, image difference <= 6e-8 at 1e5)."""
    moved = scene_at(shift * np.array([1.0, -0.7, 0.4]))
    np.testing.assert_allclose(moved.geometry.origin, shift * np.array([1.0, -0.7, 0.4]) + BASE.geometry.origin,
                               rtol=1e-12)
    for shading in rs.SHADINGS:
        f0 = rs.render(BASE, shading)
        f1 = rs.render(moved, shading)
        same = (f0.hits.prim == f1.hits.prim) & (f0.hits.geom == f1.hits.geom)
        assert same.mean() >= 0.998
        np.testing.assert_allclose(f1.image[same], f0.image[same], atol=1e-5)
        np.testing.assert_allclose(f1.hits.t[same & f0.mask], f0.hits.t[same & f0.mask], rtol=1e-5)
        assert f0.image.max() > 0.5


def test_replace_camera_reuses_the_bvh():
    scene = scene_at(np.zeros(3), 48, 36)
    first = rs.render(scene, "phong")
    assert "build" in first.timings
    accel = embree_accel(scene.geometry)
    cam2 = rs.Camera(eye=(-1.0, 2.0, 3.5), width=40, height=30)
    moved = scene.replace(camera=cam2)
    assert moved.geometry is scene.geometry and embree_accel(moved.geometry) is accel
    second = rs.render(moved, "phong")
    assert "build" not in second.timings
    assert embree_accel(moved.geometry) is accel
    # ... and renders exactly what a fresh scene with that camera renders.
    fresh = scene_at(np.zeros(3), 48, 36).replace(camera=cam2)
    np.testing.assert_array_equal(second.image, rs.render(fresh, "phong").image)
    # New lights keep the BVH too; new models do not.
    relit = scene.replace(lights=[rs.DirectionalLight((0, 0, -1))])
    assert embree_accel(relit.geometry) is accel
    remodelled = scene.replace(models=[rs.shapes.cube()])
    assert remodelled.geometry is not scene.geometry
    assert len(remodelled.geometry.faces) == 12
    # A camera passed to render() overrides the scene's, also without a rebuild.
    third = rs.render(scene, "phong", camera=cam2)
    np.testing.assert_array_equal(third.image, second.image)


def test_frame_buffers():
    scene = scene_at(np.zeros(3), 64, 48)
    frame = rs.render(scene, "gouraud")
    np.testing.assert_array_equal(frame.mask, frame.hits.prim >= 0)
    np.testing.assert_array_equal(frame.mask, frame.hits.geom >= 0)
    assert 0.1 < frame.mask.mean() < 0.9
    assert (frame.image[~frame.mask] == 0).all()
    assert (frame.depth[~frame.mask] == 0).all() and (frame.depth[frame.mask] > 0).all()
    np.testing.assert_array_equal(frame.prim_id, frame.hits.prim)
    np.testing.assert_array_equal(frame.model_id, frame.hits.geom)
    assert set(np.unique(frame.model_id)) == {-1, 0, 1, 2}
    assert frame.image.dtype == np.float32 and frame.image.shape == (48, 64, 3)
    assert (frame.normal[~frame.mask] == 0).all()
    assert {"cast", "shade", "total"} <= set(frame.timings)


def test_frame_save_png_pfm_npy(tmp_path):
    import imageio.v3 as iio

    frame = rs.render(scene_at(np.zeros(3), 40, 30), "phong")
    assert frame.image.max() > 1.0  # over-exposed highlights survive in the lossless formats
    frame.save(tmp_path / "f.png")
    frame.save(tmp_path / "f.pfm")
    frame.save(tmp_path / "f.npy")
    png = iio.imread(tmp_path / "f.png")
    assert png.shape == (30, 40, 3) and png.dtype == np.uint8
    np.testing.assert_array_equal(png, frame.to_uint8())
    pfm = rs.read_pfm(tmp_path / "f.pfm")
    assert pfm.dtype == np.float32
    np.testing.assert_array_equal(pfm, frame.image)
    np.testing.assert_array_equal(np.load(tmp_path / "f.npy"), frame.image)
    # Exposure reaches the PNG.
    frame.save(tmp_path / "dark.png", exposure=0.25)
    assert iio.imread(tmp_path / "dark.png").astype(int).sum() < png.astype(int).sum()


@pytest.mark.parametrize("ext", [".bmp", ".tif", ".tiff", ".gif", ".webp", ".jpg", ".jpeg"])
def test_frame_save_eight_bit_formats(tmp_path, ext):
    import imageio.v3 as iio
    from PIL import Image

    frame = rs.render(scene_at(np.zeros(3), 40, 30), "phong")
    path = tmp_path / f"f{ext}"
    frame.save(path)
    fmt = {".bmp": "BMP", ".tif": "TIFF", ".tiff": "TIFF", ".gif": "GIF", ".webp": "WEBP", ".jpg": "JPEG",
           ".jpeg": "JPEG"}[ext]
    with Image.open(path) as im:
        assert im.format == fmt and im.size == (40, 30)
    if ext in (".bmp", ".tif", ".tiff"):  # lossless 8-bit RGB
        np.testing.assert_array_equal(iio.imread(path), frame.to_uint8())


@pytest.mark.parametrize("name, fragment", [
    ("f.exr", ".exr is not written; use .pfm or .npy"),
    ("f.hdr", ".hdr is not written"),
    ("f.xyz", "unknown image format '.xyz'"),
    ("f", "has no extension"),
])
def test_frame_save_refuses_formats_it_would_get_wrong(tmp_path, name, fragment):
    """imageio writes an 8-bit TIFF for extensions it has no writer for: out.exr would be a TIFF."""
    frame = rs.render(scene_at(np.zeros(3), 8, 6), "flat")
    with pytest.raises(ValueError, match="path: .*" + re.escape(fragment)):
        frame.save(tmp_path / name)
    assert list(tmp_path.iterdir()) == []


def test_pfm_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(7)
    for h, w in [(1, 1), (3, 5), (17, 4)]:
        img = rng.normal(scale=1e3, size=(h, w, 3)).astype(np.float32)
        img.flat[0] = np.float32(1e-40)  # a subnormal
        img.flat[-1] = np.float32(3e38)
        rs.write_pfm(tmp_path / "x.pfm", img)
        back = rs.read_pfm(tmp_path / "x.pfm")
        np.testing.assert_array_equal(back, img)
        assert back.shape == (h, w, 3)
    # Rows are stored bottom first, as the format requires.
    img = np.zeros((2, 1, 3), np.float32)
    img[0] = 1.0
    rs.write_pfm(tmp_path / "y.pfm", img)
    raw = (tmp_path / "y.pfm").read_bytes()
    data = np.frombuffer(raw[-24:], "<f4")
    np.testing.assert_array_equal(data, [0, 0, 0, 1, 1, 1])


@pytest.mark.parametrize("tonemap", ["clamp", "reinhard", "exponential"])
@pytest.mark.parametrize("gamma", ["srgb", 2.2, 1.0])
def test_to_uint8_is_monotone_and_anchored(tonemap, gamma):
    x = np.linspace(0.0, 6.0, 20001)
    img = np.repeat(x[None, :, None], 3, axis=2)
    out = rs.to_uint8(img, tonemap=tonemap, gamma=gamma)[0, :, 0].astype(int)
    assert out[0] == 0
    assert (np.diff(out) >= 0).all()
    assert out[-1] > 200
    if tonemap == "clamp":
        assert out[np.searchsorted(x, 1.0)] == 255 and (out[x >= 1.0] == 255).all()


def test_to_uint8_values():
    img = np.array([[[0.0, 1.0, 0.25], [-1.0, 7.0, np.float32(0.0031308)]]], np.float32)
    out = rs.to_uint8(img)
    assert out[0, 0, 0] == 0 and out[0, 0, 1] == 255 and out[0, 1, 0] == 0 and out[0, 1, 1] == 255
    # sRGB of 0.25 is 1.055 * 0.25^(1/2.4) - 0.055 = 0.5371.
    assert out[0, 0, 2] == round(255 * (1.055 * 0.25 ** (1 / 2.4) - 0.055))
    assert out[0, 1, 2] == round(255 * 12.92 * 0.0031308)
    assert rs.to_uint8(img, gamma=1.0)[0, 0, 2] == 64  # linear: 0.25 * 255 = 63.75
    assert rs.to_uint8(np.full((1, 1, 3), 1.0), tonemap="reinhard", gamma=1.0)[0, 0, 0] == 128  # 1 / (1 + 1)


@pytest.mark.parametrize("tonemap", ["clamp", "reinhard", "exponential"])
def test_to_uint8_edges_under_every_curve(tonemap):
    """Negatives (also below -1, where x / (1 + x) is large and positive) and NaN give 0; +inf gives
    255, the curves' limit (reinhard's inf / inf would be NaN); the NumPy twin agrees."""
    from raycast_shade.study.twins import to_uint8_numpy

    img = np.array([[[-0.5, -1.0, -3.0], [-np.inf, np.nan, np.inf], [-0.0, 0.0, 2.0]]], np.float32)
    out = rs.to_uint8(img, tonemap=tonemap)
    assert out[0, 0].tolist() == [0, 0, 0] and out[0, 1].tolist() == [0, 0, 255] and out[0, 2, :2].tolist() == [0, 0]
    np.testing.assert_array_equal(out, to_uint8_numpy(img, tonemap=tonemap))


# -- arbitrary rays ----------------------------------------------------------------------------------
@pytest.mark.parametrize("shift", [0.0, 1e5])
def test_cast_rays_known_distances(shift):
    """A cube of side 2 centred at c: its faces are at c +- 1."""
    c = np.array([1.0, 2.0, 3.0]) + shift
    cube = rs.shapes.cube(size=2.0, center=c)
    geo = rs.Scene([cube]).geometry
    origins = np.array([c + (0.2, 0.1, 10.0),   # straight down onto the top face z = c + 1: t = 9
                        c + (0.2, 0.1, 10.0),   # same, direction of length 2: t = 4.5
                        c + (-5.0, 0.3, -0.4),  # along +x onto the face x = c - 1: t = 4
                        c + (0.0, 0.0, 10.0),   # a miss, pointing away
                        c + (3.0, 4.0, 5.0)])   # oblique, towards the centre
    directions = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -2.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0],
                           [-3.0, -4.0, -5.0]])
    prim, geom, u, v, t = rs.cast_rays(geo, origins, directions)
    # Oblique ray: it enters through the face z = c + 1 at parameter (5 - 1) / 5 of the direction.
    expected = np.array([9.0, 4.5, 4.0, np.inf, 0.8])
    np.testing.assert_allclose(t, expected, rtol=2e-6)
    np.testing.assert_array_equal(prim[3], -1)
    np.testing.assert_array_equal(geom, [0, 0, 0, -1, 0])
    # The barycentrics give back the hit point.
    hits = rs.HitBuffer(prim=prim[None], geom=geom[None], u=u[None], v=v[None], t=t[None])
    scene = rs.Scene([cube])
    points = hit_points(scene, hits)[0]
    ok = geom >= 0
    np.testing.assert_allclose(points[ok], origins[ok] + t[ok, None] * directions[ok], atol=1e-5)
    # tnear / tfar clip the ray: beyond the top face the next hit is the bottom face (t = 11).
    prim2, _, _, _, t2 = rs.cast_rays(geo, origins[:1], directions[:1], tnear=9.5)
    np.testing.assert_allclose(t2, [11.0], rtol=2e-6)
    prim3, _, _, _, t3 = rs.cast_rays(geo, origins[:1], directions[:1], tfar=8.0)
    assert prim3[0] == -1 and np.isinf(t3[0])
    # No rays, no work.
    empty = rs.cast_rays(geo, np.zeros((0, 3)), np.zeros((0, 3)))
    assert all(len(a) == 0 for a in empty)


# -- property test -------------------------------------------------------------------------------------
finite = dict(allow_nan=False, allow_infinity=False)
vec3 = st.tuples(*[st.floats(-3.0, 3.0, **finite)] * 3)


@st.composite
def random_scene(draw):
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    nv = draw(st.integers(3, 20))
    nf = draw(st.integers(1, 30))
    verts = rng.uniform(-1, 1, (nv, 3))
    if draw(st.booleans()):  # integer lattice: coplanar and degenerate faces galore
        verts = np.round(verts * 2) / 2
    faces = rng.integers(0, nv, (nf, 3))
    if draw(st.booleans()):
        normals = rng.normal(size=(nv, 3))
        normals[rng.random(nv) < 0.2] = 0.0
        mesh = rs.Mesh(verts, faces, normals=normals)
    else:
        crease = draw(st.one_of(st.none(), st.floats(1.0, 180.0)))
        mesh = rs.Mesh(verts, faces, weighting=draw(st.sampled_from(["uniform", "area", "angle"])), crease_angle=crease)
    material = rs.Material(kd=tuple(rng.uniform(0, 1, 3)), ka=draw(st.floats(0, 1)), ks=tuple(rng.uniform(0, 2, 3)),
                           shininess=draw(st.floats(0.01, 1000.0)), specular=draw(st.sampled_from(["phong", "blinn"])))
    lights = []
    for _ in range(draw(st.integers(0, 3))):
        kind = draw(st.sampled_from(["point", "vertex", "directional"]))
        if kind == "directional":
            d = draw(vec3)
            assume(np.linalg.norm(d) > 1e-3)
            lights.append(rs.DirectionalLight(d, intensity=draw(st.floats(0, 10)), color=tuple(rng.uniform(0, 1, 3))))
        else:
            pos = verts[rng.integers(nv)] if kind == "vertex" else np.array(draw(vec3))  # "vertex": on the surface
            att = draw(st.sampled_from(["none", "inverse_square", "heuristic"]))
            lights.append(rs.PointLight(pos, intensity=draw(st.floats(0, 10)), attenuation=att,
                                        k=draw(st.floats(1e-3, 5.0))))
    eye = np.array(draw(vec3))
    eye = eye / max(np.linalg.norm(eye), 1e-3) * draw(st.floats(0.5, 6.0))
    target = np.array(draw(vec3)) * 0.2
    up = np.array(draw(vec3))
    forward = target - eye
    assume(np.linalg.norm(forward) > 1e-3 and np.linalg.norm(up) > 1e-3)
    assume(np.linalg.norm(np.cross(forward / np.linalg.norm(forward), up / np.linalg.norm(up))) > 1e-3)
    camera = rs.Camera(eye=eye, target=target, up=up, fov=draw(st.floats(10.0, 120.0)),
                       width=draw(st.integers(1, 20)), height=draw(st.integers(1, 16)),
                       projection=draw(st.sampled_from(["perspective", "orthographic"])),
                       ortho_height=draw(st.floats(0.5, 4.0)))
    return rs.Scene([rs.Model(mesh, material)], lights=lights, camera=camera, ambient=draw(st.floats(0, 1)))


@pytest.mark.filterwarnings("ignore::raycast_shade.WindingWarning")  # random faces: expected, and tested elsewhere
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(scene=random_scene())
def test_random_scenes_never_produce_nan_inf_or_negative(scene):
    for shading in rs.SHADINGS:
        frame = rs.render(scene, shading)
        event(f"pixels hit: {'some' if frame.mask.any() else 'none'}")
        img = frame.image
        assert img.shape == (scene.camera.height, scene.camera.width, 3)
        assert np.isfinite(img).all()
        assert img.min() >= 0.0
        np.testing.assert_array_equal(frame.mask, frame.hits.prim >= 0)
        np.testing.assert_array_equal(frame.hits.geom >= 0, frame.hits.prim >= 0)
        assert (img[~frame.mask] == 0).all()
        n = frame.normal
        assert np.isfinite(n).all()
        np.testing.assert_allclose(np.linalg.norm(n[frame.mask], axis=-1), 1.0, atol=1e-5)


@pytest.mark.parametrize("n", [1, 2, 3, 7, 68, 135, 270, 1000])
def test_balanced_row_order_is_a_permutation_that_spreads_each_share(n):
    """The kernels visit row blocks as (t * step) mod n: every block exactly
    once, and each thread's contiguous share of t (halves and quarters here)
    takes blocks from all over the image, not one region of it."""
    from raycast_shade.common.schedule import spread_step

    step = spread_step(n)
    order = (np.arange(n) * step) % n
    assert sorted(order) == list(range(n))
    for parts in (2, 4):
        for share in np.array_split(order, parts):
            if len(share) < 8:
                continue
            # Of a share, the blocks in each half of the image: close to even.
            top = (share < n / 2).sum()
            assert abs(top - len(share) / 2) <= 0.1 * len(share) + 1


@pytest.mark.parametrize("tonemap", ["clamp", "reinhard", "exponential"])
@pytest.mark.parametrize("gamma", ["srgb", 2.2, 1.0])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_to_uint8_kernel_matches_numpy_twin(tonemap, gamma, dtype):
    from raycast_shade.study.twins import to_uint8_numpy

    rng = np.random.default_rng(7)
    x = np.concatenate([rng.uniform(-0.5, 3.0, 30000), rng.uniform(0.0, 0.01, 10000),
                        [0.0, -0.0, 0.0031308, 1.0, 1e30]])
    # Values whose code sits exactly on a rounding boundary of the linear curve.
    x = np.concatenate([x, (np.arange(256) + 0.5) / 255.0])
    img = x.astype(dtype).reshape(1, -1, 1)
    exposure = 1.7 if tonemap != "clamp" else 1.0
    got = rs.to_uint8(img, exposure=exposure, tonemap=tonemap, gamma=gamma)
    assert got.dtype == np.uint8 and got.shape == img.shape
    np.testing.assert_array_equal(got, to_uint8_numpy(img, exposure=exposure, tonemap=tonemap, gamma=gamma))


def test_to_uint8_takes_strided_and_integer_input():
    img = np.linspace(0.0, 1.0, 60, dtype=np.float64).reshape(4, 5, 3)
    np.testing.assert_array_equal(rs.to_uint8(img[:, ::2]), rs.to_uint8(np.ascontiguousarray(img[:, ::2])))
    assert rs.to_uint8(np.ones((2, 2, 3), np.int64)).min() == 255
    assert rs.to_uint8(np.zeros((0, 4, 3), np.float32)).shape == (0, 4, 3)
