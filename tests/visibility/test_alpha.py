"""Alpha masks (Material.alpha_cutoff, glTF MASK / BLEND): rays pass through masked texels.

The oracle is the same scene with the masked cells' triangles removed: a checker-alpha grid must
render exactly as the grid without its clear cells, for camera, shadow and mirror rays.
"""

from __future__ import annotations

import ast
import base64
import io
import json
import pathlib
import warnings

import numpy as np
import pytest
from PIL import Image

import raycast_shade as rs
from raycast_shade.visibility import alpha, embree
from raycast_shade.visibility.accel import embree_accel

VISIBILITY = pathlib.Path(rs.__file__).parent / "visibility"
N = 4  # cells a side


def _grid(z=0.0, flip=False):
    """An N x N grid of cells over [-1, 1]^2 at height z, two triangles a cell, UVs on the unit square;
    the cell (row i, column j) holds faces 2 (i N + j) and 2 (i N + j) + 1."""
    xs = np.linspace(-1.0, 1.0, N + 1)
    v = np.array([(x, y, z) for y in xs for x in xs])
    faces = []
    for i in range(N):
        for j in range(N):
            a = i * (N + 1) + j
            tri = [(a, a + 1, a + N + 2), (a, a + N + 2, a + N + 1)]
            faces += [t[::-1] for t in tri] if flip else tri
    return v, np.array(faces), (v[:, :2] + 1.0) / 2.0


def _checker():
    """(N, N) coverage: 1 where (i + j) is even, row i at v = (i + 0.5) / N."""
    return (np.indices((N, N)).sum(0) % 2 == 0).astype(np.float64)


def _masked_and_cut(z=0.0, flip=False, **material):
    """The masked grid model, and the same grid with the clear cells' triangles removed."""
    v, f, uv = _grid(z, flip)
    cov = _checker()
    amap = rs.Texture(np.repeat(cov[..., None], 3, axis=2), wrap="clamp", name="checker_alpha")
    masked = rs.Model(rs.Mesh(v, f, uvs=uv, name="grid"),
                      rs.Material(alpha_map=amap, alpha_cutoff=0.5, name="leaf", **material))
    keep = np.repeat(cov.ravel() >= 0.5, 2)
    cut = rs.Model(rs.Mesh(v, f[keep], uvs=uv, name="grid"), rs.Material(name="leaf", **material))
    return masked, cut


def _plane(z, size=3.0, **material):
    v = np.array([(-size, -size, z), (size, -size, z), (size, size, z), (-size, size, z)])
    return rs.Model(rs.Mesh(v, np.array([(0, 1, 2), (0, 2, 3)]), name=f"plane{z:g}"), rs.Material(**material))


def _pair(others, lights, camera, **material):
    masked, cut = _masked_and_cut(**material)
    return (rs.Scene([masked, *others], lights=lights, camera=camera, ambient=0.2),
            rs.Scene([cut, *others], lights=lights, camera=camera, ambient=0.2))


def test_camera_rays_see_through_the_clear_texels_exactly():
    """Orthographic view whose pixel edges fall on the cell edges: bit-identical to the cut grid,
    in every shading method; the floor behind shows through half the grid."""
    cam = rs.Camera(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), projection="orthographic", ortho_height=3.0,
                    width=48, height=48)
    a, b = _pair([_plane(-1.0, kd=(0.1, 0.3, 0.9))], [rs.DirectionalLight((0.3, 0.2, -1.0))], cam,
                 kd=(0.9, 0.2, 0.2))
    for shading in ("flat", "gouraud", "phong"):
        fa, fb = rs.render(a, shading), rs.render(b, shading)
        np.testing.assert_array_equal(fa.image, fb.image)
        np.testing.assert_array_equal(fa.depth, fb.depth)
    hits = rs.cast_camera(a, cam)
    on_grid = (hits.geom == 0).sum()
    on_floor_inside = ((hits.geom == 1) & (np.abs(np.arange(48) - 23.5) < 16)[:, None]
                       & (np.abs(np.arange(48) - 23.5) < 16)[None, :]).sum()
    assert on_grid == on_floor_inside == 32 * 32 // 2


def test_shadow_rays_pass_through_the_clear_texels():
    """A light above the grid: the floor under clear cells is lit, under covered cells shadowed;
    the image equals the cut grid's (a perspective view from the side, shadows on)."""
    cam = rs.Camera(eye=(2.0, -3.0, 4.0), target=(0, 0, -0.5), width=96, height=96)
    light = [rs.PointLight((0.2, 0.3, 3.0), intensity=1.5, shadows=True)]
    a, b = _pair([_plane(-1.0, kd=0.8)], light, cam, kd=(0.9, 0.2, 0.2))
    fa, fb = rs.render(a), rs.render(b)
    differ = np.any(fa.image != fb.image, axis=-1)
    assert differ.mean() < 0.005, differ.sum()  # cell edges only, where float rounding picks a side
    floor = (rs.cast_camera(a, cam).geom == 1)
    lum = fa.image.mean(axis=-1)[floor]
    assert (lum < 0.3).mean() > 0.05 and (lum > 0.5).mean() > 0.3  # shadows of covered cells and lit holes


def test_mirror_rays_pass_through_the_clear_texels():
    """The camera sees only a mirror floor; the grid and a blue ceiling are behind it, seen in the mirror:
    blue through the clear cells, as with the cut grid."""
    cam = rs.Camera(eye=(0.0, 0.0, 4.0), target=(0, 0, -1.0), up=(0, 1, 0), fov=40.0, width=96, height=96)
    mirror = _plane(-1.0, kd=0.0, ka=0.0, reflectivity=1.0)
    ceiling = _plane(7.0, size=20.0, kd=(0.1, 0.2, 0.9), ka=(0.1, 0.2, 0.9))
    masked, cut = _masked_and_cut(z=5.0, kd=(0.9, 0.2, 0.2), ka=(0.9, 0.2, 0.2))
    lights = [rs.DirectionalLight((0.0, 0.0, 1.0))]
    a = rs.Scene([masked, mirror, ceiling], lights=lights, camera=cam, ambient=0.3)
    b = rs.Scene([cut, mirror, ceiling], lights=lights, camera=cam, ambient=0.3)
    hits = rs.cast_camera(a, cam)
    assert np.all(hits.geom == 1)  # nothing but the mirror, directly
    fa, fb = rs.render(a, max_depth=1), rs.render(b, max_depth=1)
    differ = np.any(fa.image != fb.image, axis=-1)
    assert differ.mean() < 0.005, differ.sum()
    red = (fa.image[..., 0] > 2 * fa.image[..., 2])
    blue = (fa.image[..., 2] > 2 * fa.image[..., 0])
    assert 0.02 < red.mean() and blue.mean() > 0.3
    # explain's own bounce cast agrees: inside the grid's reflection, a blue pixel's bounce hits the
    # ceiling (through a clear cell), a red one the grid.
    rows, cols = np.nonzero(red)
    box = np.zeros_like(red)
    box[rows.min() + 4:rows.max() - 3, cols.min() + 4:cols.max() - 3] = True
    for sel, model in ((blue & box, 2), (red & box, 0)):
        y, x = np.argwhere(sel)[len(np.argwhere(sel)) // 2]
        assert rs.explain(fa, int(x), int(y)).bounces[0].model == model


def test_cast_rays_and_explain_hit_what_lies_behind_a_clear_texel():
    """The one-ray paths (cast_rays, as explain's) take the filters too: a ray through the centre of a clear
    cell hits the floor, one through a covered cell the grid."""
    masked, _ = _masked_and_cut()
    scene = rs.Scene([masked, _plane(-1.0)], lights=[rs.DirectionalLight((0, 0, -1))],
                     camera=rs.Camera(eye=(0, 0, 5), width=8, height=8))
    # Cell (row 0, column 1) is clear ((0 + 1) odd), (0, 0) covered; row i spans y in [-1 + i/2, -1 + (i+1)/2].
    o = np.array([[-0.25, -0.75, 3.0], [-0.75, -0.75, 3.0]])
    d = np.array([[0, 0, -1.0], [0, 0, -1.0]])
    hits = rs.cast_rays(scene.geometry, o, d)
    np.testing.assert_array_equal(hits.geom, [1, 0])
    np.testing.assert_allclose(hits.t, [4.0, 3.0], rtol=1e-6)


@pytest.mark.parametrize("seed", range(3))
def test_the_filter_samples_the_alpha_map_as_numpy_bilinear_does(seed):
    """alpha_at against a plain NumPy bilinear lookup (texel centres at (j + 0.5) / w), repeat and clamp, tiled."""
    rng = np.random.default_rng(seed)
    h, w = rng.integers(1, 7, 2)
    cov = rng.random((h, w))
    uvs = rng.uniform(-1.5, 2.5, (3, 2))
    for wrap in ("repeat", "clamp"):
        tex = rs.Texture(np.repeat(cov[..., None], 3, 2), wrap=wrap, tiling=(1.5, 0.75))
        data = alpha.mask_data(tex, 0.5, uvs, np.array([[0, 1, 2]]))
        for _ in range(20):
            b1, b2 = rng.dirichlet((1, 1, 1))[1:]
            u, v = (1 - b1 - b2) * uvs[0] + b1 * uvs[1] + b2 * uvs[2]
            x, y = u.astype(np.float32) * 1.5 * w - 0.5, v.astype(np.float32) * 0.75 * h - 0.5
            j0, i0 = int(np.floor(x)), int(np.floor(y))
            tx, ty = x - j0, y - i0
            fix = (lambda k, n: min(max(k, 0), n - 1)) if wrap == "clamp" else (lambda k, n: k % n)
            want = sum(wt * cov[fix(i, h), fix(j, w)] for i, j, wt in (
                (i0, j0, (1 - tx) * (1 - ty)), (i0, j0 + 1, tx * (1 - ty)), (i0 + 1, j0, (1 - tx) * ty),
                (i0 + 1, j0 + 1, tx * ty)))
            got = alpha.alpha_at(data, 0, np.float32(b1), np.float32(b2))
            assert got == pytest.approx(want, abs=2e-5)


# -- only masked geometries get a filter ---------------------------------------------------------------

class _Spy:
    def __init__(self, monkeypatch):
        lib, _ = embree._open()
        self.calls = []
        for name in ("rtcSetGeometryUserData", "rtcSetGeometryIntersectFilterFunction",
                     "rtcSetGeometryOccludedFilterFunction"):
            real = getattr(lib, name)

            def spy(geom, ptr, real=real, name=name):
                self.calls.append((name, ptr.value))
                return real(geom, ptr)

            monkeypatch.setattr(lib, name, spy)


def test_opaque_scenes_install_no_filter(monkeypatch):
    """No masked material, no filter function: Embree is set up as before masks existed."""
    spy = _Spy(monkeypatch)
    _, cut = _masked_and_cut()
    scene = rs.Scene([cut, _plane(-1.0)], camera=rs.Camera(eye=(0, 0, 5), width=8, height=8))
    acc = embree_accel(scene.geometry)
    assert spy.calls == [] and acc.mask_data == {}


def test_an_opaque_gltf_with_an_rgba_texture_is_not_masked(tmp_path):
    img = np.zeros((2, 2, 4), np.uint8)
    img[..., 3] = 10
    _gltf_quad(tmp_path / "o.gltf", img, {})
    (model,) = rs.load_models(tmp_path / "o.gltf")
    assert model.material.alpha_cutoff is None and model.material.alpha_map is None


def test_masked_geometries_get_both_filters_and_user_data_the_accelerator_holds(monkeypatch):
    spy = _Spy(monkeypatch)
    masked, _ = _masked_and_cut()
    scene = rs.Scene([_plane(-1.0), masked], camera=rs.Camera(eye=(0, 0, 5), width=8, height=8))
    acc = embree_accel(scene.geometry)
    assert set(acc.mask_data) == {1}
    data = acc.mask_data[1]
    assert data.flags.owndata and data.dtype == np.float32
    address = alpha.filter_address()
    assert spy.calls == [("rtcSetGeometryUserData", data.ctypes.data),
                         ("rtcSetGeometryIntersectFilterFunction", address),
                         ("rtcSetGeometryOccludedFilterFunction", address)]


def test_the_only_user_pointer_embree_gets_is_an_array_the_accelerator_holds():
    """AST check of embree.py: every rtcSetGeometryUserData call passes
    ``ctypes.c_void_p(self.mask_data[...].ctypes.data)``, an array held by the EmbreeAccel (checked owning
    its memory in its constructor), so the pointer lives as long as the scene."""
    tree = ast.parse((VISIBILITY / "embree.py").read_text(encoding="utf-8"))
    calls = [n for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute)
             and n.func.attr == "rtcSetGeometryUserData"]
    assert len(calls) == 1
    arg = ast.unparse(calls[0].args[1])
    assert arg == "ctypes.c_void_p(self.mask_data[g].ctypes.data)", arg
    others = [p for p in VISIBILITY.glob("*.py") if p.name != "embree.py"
              and "rtcSetGeometryUserData" in p.read_text(encoding="utf-8")]
    assert not others


_POISONED = """
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
import gc
import raycast_shade as rs
sys.path.insert(0, sys.argv[2])
from test_alpha import _masked_and_cut, _plane
masked, _ = _masked_and_cut()
cam = rs.Camera(eye=(0, 0, 5), projection="orthographic", ortho_height=3.0, width=48, height=48)
scene = rs.Scene([masked, _plane(-1.0)], lights=[rs.PointLight((0, 0, 3), shadows=True)], camera=cam)
geo = scene.geometry
from raycast_shade.visibility.accel import embree_accel
embree_accel(geo)
for _ in range(3):
    junk = [np.full(1000 * k, 7.0, np.float32) for k in range(1, 50)]  # reuse freed blocks
    del junk
    gc.collect()
np.save(sys.argv[1], rs.render(scene).image)
print("OK")
"""


def test_the_filters_user_data_stays_alive_when_frees_are_poisoned(tmp_path):
    """Under glibc's free-poisoning, with the scene built and memory churned, the masked render (camera
    and shadow rays through the filters) is the ordinary run's: the user data was never freed."""
    import os
    import subprocess
    import sys

    if not sys.platform.startswith("linux"):
        pytest.skip("glibc's malloc tunables")
    env = dict(os.environ, GLIBC_TUNABLES="glibc.malloc.tcache_count=0:glibc.malloc.perturb=165")
    out = tmp_path / "img.npy"
    proc = subprocess.run([sys.executable, "-c", _POISONED, str(out), str(pathlib.Path(__file__).parent)],
                          env=env, capture_output=True, text=True, timeout=900)
    if "NOPOISON" in proc.stdout:
        pytest.skip("this libc does not poison freed memory")
    assert proc.returncode == 0 and "OK" in proc.stdout, proc.stderr[-3000:]
    masked, _ = _masked_and_cut()
    cam = rs.Camera(eye=(0, 0, 5), projection="orthographic", ortho_height=3.0, width=48, height=48)
    scene = rs.Scene([masked, _plane(-1.0)], lights=[rs.PointLight((0, 0, 3), shadows=True)], camera=cam)
    np.testing.assert_array_equal(np.load(out), rs.render(scene).image)


# -- refusals and validation ---------------------------------------------------------------------------

def test_the_rasterizer_and_embreex_refuse_masks_before_any_kernel():
    masked, _ = _masked_and_cut()
    scene = rs.Scene([masked], camera=rs.Camera(eye=(0, 0, 5), width=8, height=8))
    with pytest.raises(ValueError, match=r"rasterize: scene.models\[0\] are alpha-masked .*backend='raycast'"):
        rs.render(scene, backend="raster")
    with pytest.raises(RuntimeError, match=r"alpha masks \(scene.models\[0\]\) need the direct Embree binding"):
        rs.cast_camera(scene, scene.camera, caster="embreex")


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(alpha_cutoff=0.5), ValueError, r"leaf.alpha_cutoff: given without an alpha_map"),
    (dict(alpha_map="tex"), TypeError, r"leaf.alpha_map: expected a Texture"),
    (dict(alpha_map=rs.Texture(np.ones((2, 2, 3)))), ValueError, r"leaf.alpha_map: given without alpha_cutoff"),
    (dict(alpha_map=rs.Texture(np.ones((2, 2, 3))), alpha_cutoff=-0.1), ValueError, r"leaf.alpha_cutoff"),
    (dict(alpha_map=rs.Texture(np.ones((2, 2, 3))), alpha_cutoff="half"), TypeError, r"leaf.alpha_cutoff"),
])
def test_material_alpha_fields_are_validated_naming_the_field(kwargs, error, match):
    with pytest.raises(error, match=match):
        rs.Material(name="leaf", **kwargs)


def test_a_mask_on_a_mesh_without_uvs_is_refused_naming_the_model():
    v, f, _ = _grid()
    mat = rs.Material(alpha_map=rs.Texture(np.ones((2, 2, 3))), alpha_cutoff=0.5, name="leaf")
    scene = rs.Scene([rs.Model(rs.Mesh(v, f, name="bare"), mat)], camera=rs.Camera(eye=(0, 0, 5)))
    with pytest.raises(ValueError, match=r"scene.models\[0\] \(bare\): material 'leaf' has an alpha_map"):
        scene.geometry


# -- glTF ------------------------------------------------------------------------------------------

def _gltf_quad(path, image, material_extra, factor=(1.0, 1.0, 1.0, 1.0)):
    """A .gltf quad [0, 1]^2 at z = 0 with UVs = positions, the image embedded as its base colour."""
    pos = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)  # glTF's v runs down the image
    idx = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    blob = pos.tobytes() + uv.tobytes() + idx.tobytes()
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG")
    js = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
        "materials": [dict({"name": "leafy", "pbrMetallicRoughness": {
            "baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "baseColorFactor": list(factor)}},
            **material_extra)],
        "textures": [{"source": 0}],
        "images": [{"uri": "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()}],
        "buffers": [{"uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
                     "byteLength": len(blob)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                        {"buffer": 0, "byteOffset": 48, "byteLength": 32},
                        {"buffer": 0, "byteOffset": 80, "byteLength": 12}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]},
                      {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
                      {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}],
    }
    path.write_text(json.dumps(js))


def _checker_rgba():
    img = np.full((N, N, 4), 255, np.uint8)
    img[..., 3] = np.where(np.indices((N, N)).sum(0) % 2 == 0, 255, 0)
    img[..., 3][0, 0] = 140  # 140/255 * 0.8 = 0.44: clear at cutoff 0.5 (factor times texture)
    return img


def _loaded_hits(path, tmp_path):
    (model,) = rs.load_models(path)
    scene = rs.Scene([model, rs.Model(rs.Mesh(np.array([(-1, -1, -1), (2, -1, -1), (2, 2, -1), (-1, 2, -1.)]),
                                              np.array([(0, 1, 2), (0, 2, 3)])), rs.Material())],
                     camera=rs.Camera(eye=(0.5, 0.5, 3), target=(0.5, 0.5, 0), up=(0, 1, 0),
                                      projection="orthographic", ortho_height=1.0, width=N * 8, height=N * 8))
    return model, rs.cast_camera(scene, scene.camera)


def _numpy_coverage(image_alpha, factor):
    """Coverage under each pixel centre of _loaded_hits' view, plain NumPy: the image flipped to row 0 at
    v = 0 (glTF's top row is v = 0 of its own convention, ours v = 1), bilinear, repeat."""
    a = image_alpha[::-1].astype(np.float64) / 255 * factor
    h, w = a.shape
    side = N * 8
    c = (np.arange(side) + 0.5) / side
    u, v = np.meshgrid(c, c[::-1])  # pixel row 0 at the top, y = 1
    x, y = u * w - 0.5, v * h - 0.5
    j0, i0 = np.floor(x).astype(int), np.floor(y).astype(int)
    tx, ty = x - j0, y - i0
    at = lambda i, j: a[i % h, j % w]  # noqa: E731
    return ((1 - tx) * (1 - ty) * at(i0, j0) + tx * (1 - ty) * at(i0, j0 + 1) + (1 - tx) * ty * at(i0 + 1, j0)
            + tx * ty * at(i0 + 1, j0 + 1))


def test_a_gltf_mask_lets_the_clear_texels_through(tmp_path):
    """MASK with alphaCutoff 0.5 and baseColorFactor alpha 0.8: the cells whose texture alpha x 0.8 is
    below 0.5 show the floor, exactly the image's clear texels (its top row at v = 1, y up)."""
    _gltf_quad(tmp_path / "m.gltf", _checker_rgba(), {"alphaMode": "MASK", "alphaCutoff": 0.5},
               factor=(1, 1, 1, 0.8))
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        model, hits = _loaded_hits(tmp_path / "m.gltf", tmp_path)
    assert model.material.alpha_cutoff == 0.5
    clear = _numpy_coverage(_checker_rgba()[..., 3], 0.8) < 0.5
    assert 0.3 < clear.mean() < 0.95  # both kinds of pixel (factor 0.8 narrows the covered cells)
    np.testing.assert_array_equal(hits.geom == 1, clear)


def test_gltf_blend_is_drawn_as_mask_at_half_and_warns_naming_the_material(tmp_path):
    _gltf_quad(tmp_path / "b.gltf", _checker_rgba(), {"alphaMode": "BLEND"})
    with pytest.warns(rs.DroppedOnLoadWarning, match=r"material 'leafy': alphaMode BLEND: approximated as MASK "
                                                     r"with cutoff 0.5"):
        model, hits = _loaded_hits(tmp_path / "b.gltf", tmp_path)
    assert model.material.alpha_cutoff == 0.5
    clear = _numpy_coverage(_checker_rgba()[..., 3], 1.0) < 0.5
    np.testing.assert_array_equal(hits.geom == 1, clear)


@pytest.mark.parametrize("mode, fate", [("MASK", "mapped"), ("BLEND", "approximated"), ("OPAQUE", "mapped")])
def test_inspect_says_what_alpha_became(tmp_path, mode, fate):
    from raycast_shade.apps.inspect import inspect_file

    _gltf_quad(tmp_path / "i.gltf", _checker_rgba(), {"alphaMode": mode, "alphaCutoff": 0.3})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = inspect_file(tmp_path / "i.gltf")
    rows = {r[0]: r for m in report["models"] for r in m["fields"]}
    assert rows["alphaMode"][2] == fate
    assert rows["alphaCutoff"][2] == "mapped"
