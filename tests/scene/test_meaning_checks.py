"""Input that means nothing is refused by name, before any work; input that is legal but surely not
meant gets a warning naming the consequence (issue 45). Each check beside its valid neighbours,
which stay silent."""

from __future__ import annotations

import tracemalloc
import warnings

import imageio.v3 as iio
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.common import validate
from raycast_shade.scene.lens import fold, valid_fraction
from raycast_shade.scene.material import MAX_NORMAL_SCALE
from raycast_shade.scene.texture import DECODE_BYTES_PER_TEXEL, TEXTURE_BYTES_PER_TEXEL
from tests.conftest import down_camera

FLAT = (0.5, 0.5, 1.0)


def silent(make):
    """``make()`` with every warning an error: a valid neighbour says nothing."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return make()


def normal_png(tmp_path, pixels, name="n.png"):
    path = tmp_path / name
    iio.imwrite(path, np.asarray(pixels, np.uint8))
    return path


def bumpy_pixels():
    """A proper 8-bit normal map: flat with a ring of tilted texels, blue well above 128."""
    px = np.full((8, 8, 3), (128, 128, 255), np.uint8)
    px[2:6, 2] = (90, 128, 240)
    px[2:6, 5] = (166, 128, 240)
    return px


# -- normal maps ---------------------------------------------------------------------------------------
def test_a_normal_map_loaded_as_srgb_is_refused(tmp_path):
    """from_image decodes sRGB by default: the flat texel 128 becomes 0.216 and bends every normal."""
    path = normal_png(tmp_path, bumpy_pixels())
    with pytest.raises(ValueError, match=r"m\.normal_map: .*decoded from sRGB.*srgb=False"):
        rs.Material(name="m", normal_map=rs.Texture.from_image(path))
    silent(lambda: rs.Material(name="m", normal_map=rs.Texture.from_image(path, srgb=False)))


def test_normal_map_texels_above_one_are_refused():
    with pytest.raises(ValueError, match=r"m\.normal_map: texels must lie in \[0, 1\].*max 1\.5"):
        rs.Material(name="m", normal_map=rs.Texture(np.full((2, 2, 3), (0.5, 1.5, 1.0))))
    silent(lambda: rs.Material(normal_map=rs.Texture(np.full((2, 2, 3), (0.0, 1.0, 1.0)))))  # the bounds


def test_a_grey_normal_map_warns(tmp_path):
    """A one-channel PNG (a height map, say) replicates its grey into r, g and b."""
    path = normal_png(tmp_path, np.linspace(0, 255, 64).reshape(8, 8), "grey.png")
    with pytest.warns(rs.NormalMapWarning, match=r"m\.normal_map: every texel .* is grey"):
        rs.Material(name="m", normal_map=rs.Texture.from_image(path, srgb=False))


def test_an_all_zero_normal_map_warns_that_its_normals_point_inwards():
    with pytest.warns(rs.NormalMapWarning, match=r"m\.normal_map: .*grey.*into the surface"):
        rs.Material(name="m", normal_map=rs.Texture(np.zeros((4, 4, 3))))


@pytest.mark.parametrize("blue", [0.0, 0.3, 0.5])
def test_a_normal_map_without_an_outward_texel_warns(blue):
    """An RG map saved with b = 0 (z to be reconstructed), or any map whose z = 2b - 1 <= 0 everywhere."""
    rng = np.random.default_rng(1)
    texels = np.c_[rng.uniform(0, 1, (16, 2)), np.full(16, blue)].reshape(4, 4, 3)
    with pytest.warns(rs.NormalMapWarning, match=r"m\.normal_map: no texel .* blue > 0\.5"):
        rs.Material(name="m", normal_map=rs.Texture(texels))


@pytest.mark.parametrize("texels", [np.full((1, 1, 3), FLAT), bumpy_pixels() / 255.0,
                                    np.random.default_rng(3).uniform(0, 1, (5, 7, 3))])
def test_proper_normal_maps_are_silent(texels):
    """Flat, bumpy, and random texels some of which point out (normals past the horizon are legal)."""
    silent(lambda: rs.Material(normal_map=rs.Texture(texels), normal_scale=0.7))


# -- scales without their maps ------------------------------------------------------------------------
@pytest.mark.parametrize("field, value, needs", [("normal_scale", 2.0, "normal_map"), ("normal_scale", 0.0, "normal_map"),
                                                 ("ao_strength", 0.5, "ao_map")])
def test_a_scale_without_its_map_is_refused(field, value, needs):
    with pytest.raises(ValueError, match=rf"m\.{field}: .* without an? {needs}"):
        rs.Material(name="m", **{field: value})


def test_scales_with_their_maps_are_silent():
    nmap, ao = rs.Texture(np.full((2, 2, 3), FLAT)), rs.Texture(np.full((2, 2, 3), 0.7))
    silent(lambda: rs.Material(normal_map=nmap, normal_scale=0.0, ao_map=ao, ao_strength=0.0))
    silent(lambda: rs.Material(normal_map=nmap, normal_scale=-MAX_NORMAL_SCALE))
    silent(lambda: rs.Material(normal_scale=1.0, ao_strength=1.0))  # the defaults, without maps


# -- normal_scale's bound and its limit ---------------------------------------------------------------
@pytest.mark.parametrize("scale", [1e300, -1e151, 1.0000001e150])
def test_normal_scale_beyond_its_bound_is_refused(scale):
    """Beyond 1e150 the kernels' float64 length of the bent normal overflows and the normal stayed
    unbent: a different picture from the limit the formula tends to."""
    with pytest.raises(ValueError, match=r"m\.normal_scale: \|s\| must be <= 1e\+150"):
        rs.Material(name="m", normal_map=rs.Texture(np.full((2, 2, 3), FLAT)), normal_scale=scale)


LIGHT = np.array([0.3, -0.45, -1.0])


@settings(max_examples=12, deadline=None, derandomize=True)
@given(r=st.floats(0.05, 0.95), g=st.floats(0.05, 0.95), b=st.floats(0.55, 1.0),
       exponent=st.floats(8.0, 150.0), sign=st.sampled_from([1.0, -1.0]))
def test_large_normal_scales_render_the_limit(r, g, b, exponent, sign):
    """n' = normalize(T (2r-1) s + B (2g-1) s + N (2b-1)) tends to normalize(T (2r-1) + B (2g-1)) as
    s grows: up to the bound (1e150) the plane's normals are that limit (T = +x, B = +y)."""
    if np.hypot(2 * r - 1, 2 * g - 1) < 0.1:
        return  # a small tangential part: the limit is reached at larger scales than drawn
    scale = sign * 10.0 ** exponent
    tex = rs.Texture(np.full((2, 2, 3), (r, g, b), np.float32), name="nmap")
    material = rs.Material(kd=0.7, ka=0.0, normal_map=tex, normal_scale=scale)
    scene = rs.Scene([rs.Model(rs.shapes.plane(2.0), material)], lights=[rs.DirectionalLight(LIGHT)],
                     camera=down_camera(width=12, height=9), ambient=0.0)
    frame = rs.render(scene)
    x, y = (2 * np.float64(np.float32(c)) - 1 for c in (r, g))
    limit = sign * np.array([x, y, 0.0]) / np.hypot(x, y)
    assert frame.mask.sum() > 50
    np.testing.assert_allclose(frame.normal[frame.mask], np.broadcast_to(limit, (frame.mask.sum(), 3)), atol=1e-6)


# -- alpha cutoffs -------------------------------------------------------------------------------------
@pytest.mark.parametrize("alpha, cutoff", [(1.0, 2.0), (0.9, 1.0), (0.0, 0.5), (0.4, 0.5)])
def test_a_cutoff_above_every_alpha_warns_that_the_model_vanishes(alpha, cutoff):
    amap = rs.Texture(np.full((3, 3, 3), alpha), name="a")
    with pytest.warns(rs.AllMaskedWarning, match=r"m\.alpha_cutoff = .* exceeds every texel of alpha_map 'a'"):
        rs.Material(name="m", alpha_map=amap, alpha_cutoff=cutoff)


@pytest.mark.parametrize("cutoff", [0.0, 0.5, 0.9, 1.0])
def test_a_cutoff_some_alpha_reaches_is_silent(cutoff):
    """Texel 0.9 at the largest: a cutoff equal to it keeps those points (rays pass where alpha < cutoff)."""
    amap = rs.Texture(np.array([[0.1, 0.9], [0.5, 0.2]]).repeat(3).reshape(2, 2, 3))
    if cutoff == 1.0:
        amap = rs.Texture(np.ones((2, 2, 3)))
    silent(lambda: rs.Material(alpha_map=amap, alpha_cutoff=cutoff))


# -- tangents ------------------------------------------------------------------------------------------
def test_zero_tangents_are_refused():
    plane = rs.shapes.plane(2.0)
    t = np.tile([1.0, 0.0, 0.0, 1.0], (len(plane.vertices), 1))
    t[2, :3] = 0.0
    with pytest.raises(ValueError, match=r"p\.tangents: 1 tangent\(s\) of length <= 1e-12 \(zero\), first at vertex 2"):
        rs.Mesh(plane.vertices, plane.faces, uvs=plane.uvs, tangents=t, name="p")


def test_tangents_along_the_given_normals_are_refused():
    plane = rs.shapes.plane(2.0)
    t = np.c_[-3.0 * np.asarray(plane.normals), np.ones(len(plane.vertices))]
    with pytest.raises(ValueError, match=r"p\.tangents: 4 tangent\(s\) along the vertex normal, first at vertex 0"):
        rs.Mesh(plane.vertices, plane.faces, normals=plane.normals, uvs=plane.uvs, tangents=t, name="p")


def test_tangents_along_computed_normals_are_refused_when_the_frame_is_prepared():
    plane = rs.shapes.plane(2.0)
    normal = plane.prepared.normals[0]
    mesh = rs.Mesh(plane.vertices, plane.faces, uvs=plane.uvs, name="p",
                   tangents=np.tile(np.r_[normal, 1.0], (len(plane.vertices), 1)))
    scene = rs.Scene([rs.Model(mesh, rs.Material(normal_map=rs.Texture(np.full((2, 2, 3), FLAT))))],
                     lights=[rs.DirectionalLight(LIGHT)], camera=down_camera())
    with pytest.raises(ValueError, match=r"scene\.models\[0\] \(p\)\.tangents: .* along the vertex normal"):
        scene.geometry


def test_tangents_across_the_normal_are_silent():
    plane = rs.shapes.plane(2.0)
    t = np.tile([0.6, 0.8, 1e-3, -1.0], (len(plane.vertices), 1))  # not orthogonal, not unit: made so
    mesh = silent(lambda: rs.Mesh(plane.vertices, plane.faces, normals=plane.normals, uvs=plane.uvs, tangents=t))
    scene = rs.Scene([rs.Model(mesh, rs.Material(normal_map=rs.Texture(np.full((2, 2, 3), FLAT))))],
                     lights=[rs.DirectionalLight(LIGHT)], camera=down_camera())
    assert silent(lambda: scene.geometry).has_normal_map


def test_a_files_zero_tangents_are_computed_from_the_uvs(tmp_path):
    from tests.scene.test_gltf_normal_maps import _quad

    _quad(tmp_path / "z.gltf", tangents=np.tile([0.0, 0.0, 0.0, 1.0], (4, 1)))
    with pytest.warns(rs.DroppedOnLoadWarning, match=r"TANGENT \(zero or along the normal"):
        (model,) = rs.load_models(tmp_path / "z.gltf")
    assert model.mesh.tangents is None


# -- spot lights ---------------------------------------------------------------------------------------
def test_a_spot_cone_of_angle_zero_is_refused():
    with pytest.raises(ValueError, match=r"lamp\.outer_angle: must be > 0, got inner_angle 0 and outer_angle 0"):
        rs.SpotLight((0, 0, 2), inner_angle=0, outer_angle=0, name="lamp")
    silent(lambda: rs.SpotLight((0, 0, 2), inner_angle=0, outer_angle=1e-3))
    silent(lambda: rs.SpotLight((0, 0, 2), inner_angle=10, outer_angle=10))


# -- texture sizes -------------------------------------------------------------------------------------
def test_a_huge_checker_is_refused_with_the_figure():
    """4096 squares of 8 texels a side: 32768^2 texels, which ended in MemoryError."""
    with pytest.raises(ValueError, match=r"texture\.squares x texture\.texels_per_square: 4096 x 8 a side: 32768 x "
                                         r"32768 texels need about 85\.9 GB for a texture; the limit is"):
        rs.Texture.checker(squares=4096)


def test_a_large_image_is_refused_from_its_header(tmp_path, monkeypatch):
    """As a 12000 x 12000 PNG on a real machine: the size is read from the header and refused before
    the pixels are decoded (imread is never called)."""
    path = normal_png(tmp_path, np.zeros((60, 50, 3)), "big.png")
    monkeypatch.setattr(validate, "memory_limit", lambda: 50 * 60 * DECODE_BYTES_PER_TEXEL - 1)

    def no_read(*a, **k):
        raise AssertionError("the pixels were read")

    monkeypatch.setattr(iio, "imread", no_read)
    with pytest.raises(ValueError, match=r"big\.png\.image: 50 x 60 texels need about 408000 bytes for a texture"):
        rs.Texture.from_image(path)


def test_the_texture_limit_is_exact(monkeypatch):
    monkeypatch.setattr(validate, "memory_limit", lambda: 100 * TEXTURE_BYTES_PER_TEXEL)
    rs.Texture(np.zeros((10, 10, 3)))
    with pytest.raises(ValueError, match=r"t\.texels: 11 x 10 texels need about 8800 bytes for a texture; the "
                                         r"limit is 8000 bytes"):
        rs.Texture(np.zeros((10, 11, 3)), name="t")
    with pytest.raises(ValueError, match=r"texture\.image: 10 x 10 texels"):
        rs.Texture.from_array(np.zeros((10, 10, 3), np.uint8))  # decoding needs more a texel


def _peak(make):
    tracemalloc.start()
    try:
        out = make()
        return out, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_the_texture_figures_bound_the_measured_peaks():
    """The figures are the peaks per texel, measured: decoding a 16-bit RGBA image (its pixels
    counted), a checker, a Texture's copy and its pyramid."""
    n = 256 * 256
    rgba = np.random.default_rng(0).integers(0, 65535, (256, 256, 4), dtype=np.uint16)
    _, decode = _peak(lambda: rs.Texture.from_array(rgba, alpha="ignore"))
    assert 0.7 * DECODE_BYTES_PER_TEXEL * n < decode + rgba.nbytes <= DECODE_BYTES_PER_TEXEL * n
    tex, checker = _peak(lambda: rs.Texture.checker(squares=32, texels_per_square=8))
    assert 0.7 * TEXTURE_BYTES_PER_TEXEL * n < checker <= TEXTURE_BYTES_PER_TEXEL * n
    _, pyramid = _peak(lambda: tex.pyramid)
    assert pyramid <= TEXTURE_BYTES_PER_TEXEL * n


# -- lens folds ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("model, k", [("opencv", (-50.0, 0.0, 0.0, 0.0)), ("fisheye", (-40.0, 0.0, 0.0, 0.0)),
                                      ("opencv", (-0.2, 0.0, 0.0, 0.0, 0.0))])
def test_a_lens_folding_inside_the_frame_warns_with_the_valid_share(model, k):
    fov = 45.0 if k[0] < -1 else 100.0  # the mild lens folds only in a wide view
    with pytest.warns(rs.LensFoldWarning, match=rf"camera\.distortion: the {model} model .* folds at .* about "
                                                r"[0-9.]+% of the frame lies inside the fold"):
        rs.Camera(eye=(0, 0, 3), fov=fov, distortion=k, distortion_model=model)


@pytest.mark.parametrize("model, k", [("opencv", (-0.2, 0.0, 0.0, 0.0)), ("opencv", (0.3, -0.05, 1e-3, 0.0)),
                                      ("fisheye", (-0.05, 0.01, 0.0, 0.0)), ("opencv", (-50.0, 0.0, 0.0, 0.0))])
def test_mild_lenses_are_silent(model, k):
    """A folding model whose fold lies outside the frame (k1 = -50 on a view 0.04 across its diagonal) says nothing."""
    fov = 3.0 if k[0] == -50.0 else 45.0
    silent(lambda: rs.Camera(eye=(0, 0, 3), fov=fov, distortion=k, distortion_model=model))


@pytest.mark.parametrize("model, k", [("opencv", (-0.5, 0.0, 0.0, 0.0)), ("fisheye", (-0.3, 0.01, 0.0, 0.0)),
                                      ("fisheye", (-40.0, 0.0, 0.0, 0.0))])
def test_the_valid_share_is_the_kernels(model, k):
    """The share the warning gives is that of the pixels the ray casting gives a ray (a fisheye
    leaves every pixel beyond the fold empty)."""
    from raycast_shade.visibility.distortion import ray_directions

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rs.LensFoldWarning)
        cam = rs.Camera(eye=(0, 0, 3), fov=70, width=160, height=120, distortion=k, distortion_model=model)
    _, ok = ray_directions(cam)
    assert abs(valid_fraction(cam, fold(model, k)[1]) - ok.mean()) < 0.01


@settings(max_examples=40, deadline=None, derandomize=True)
@given(model=st.sampled_from(["opencv", "fisheye"]), k1=st.floats(-60.0, -0.05), k2=st.floats(-1.0, 1.0),
       k3=st.floats(-0.5, 0.5))
def test_no_pixel_beyond_the_fold_has_a_ray_inside_it(model, k1, k2, k3):
    """The certainty the warning rests on: every distorted radius up to the fold's has its ray inside
    the fold, and none beyond it has (the kernel gives it none, or one from past the fold)."""
    from raycast_shade.visibility.distortion import undistort

    k = (k1, k2, 0.0, 0.0, k3) if model == "opencv" else (k1, k2, k3, 0.0)
    found = fold(model, k)
    if found is None:
        return
    r_star, f_star = found
    cam = rs.Camera.__new__(rs.Camera)  # only the lens is read
    object.__setattr__(cam, "distortion", k)
    object.__setattr__(cam, "distortion_model", model)
    rd = np.r_[np.linspace(0.0, 0.98, 50), np.linspace(1.000001, 4.0, 50)] * f_star
    d, ok = undistort(cam, rd, np.zeros_like(rd))
    r = np.arccos(np.clip(d[:, 2], -1, 1)) if model == "fisheye" else np.hypot(d[:, 0], d[:, 1]) / d[:, 2]
    inside = np.arange(len(rd)) < 50
    assert np.all(ok[inside]) and np.all(r[inside] < r_star)
    assert np.all(~ok[~inside] | (r[~inside] >= r_star * (1 - 1e-9)))
