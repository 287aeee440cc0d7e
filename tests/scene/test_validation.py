"""Every bad input is refused with a ValueError or TypeError naming its field,
before any kernel runs (Embree silently ignores non-finite triangles and
out-of-range indices, so nothing of the kind may reach it)."""

from __future__ import annotations

import re

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.visibility.accel import embree_accel, embreex_scene, has_embree_accel

TRI_V = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
TRI_F = [[0, 1, 2]]


def fresh_scene(**kw):
    kw.setdefault("camera", rs.Camera(eye=(0.0, 0.0, 3.0), width=8, height=6))
    return rs.Scene([rs.Mesh(TRI_V, TRI_F)], lights=[rs.PointLight((0, 0, 2))], **kw)


# -- meshes ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("vertices, faces, exc, match", [
    ([[0, 0, 0], [1, np.nan, 0], [0, 1, 0]], TRI_F, ValueError, r"mesh\.vertices: non-finite value at index \(1, 1\)"),
    ([[0, 0, 0], [1, np.inf, 0], [0, 1, 0]], TRI_F, ValueError, r"mesh\.vertices: non-finite"),
    (TRI_V, [[0, 1, 3]], ValueError, r"mesh\.faces: face 0 indexes vertex 3, but there are only 3 vertices"),
    (TRI_V, [[0, 1, 2], [0, -1, 2]], ValueError, r"mesh\.faces: negative vertex index in face 1"),
    ([[0, 0], [1, 0], [0, 1]], TRI_F, ValueError, r"mesh\.vertices: expected shape \(N, 3\), got \(3, 2\)"),
    (TRI_V, [[0, 1, 2, 0]], ValueError, r"mesh\.faces: expected shape \(N, 3\), got \(1, 4\)"),
    (TRI_V, [0, 1, 2], ValueError, r"mesh\.faces: expected shape \(N, 3\), got \(3,\)"),
    (np.zeros((2, 3, 3)), TRI_F, ValueError, r"mesh\.vertices: expected shape"),
    ([["a", "b", "c"]] * 3, TRI_F, TypeError, r"mesh\.vertices: expected numbers"),
    (TRI_V, [["0", "1", "2"]], TypeError, r"mesh\.faces: expected numbers"),
    ([[0, 0, 0], [1, 0], [0, 1, 0]], TRI_F, TypeError, r"mesh\.vertices: cannot be converted"),
    (TRI_V, [[0, 1], [0, 1, 2]], TypeError, r"mesh\.faces: cannot be converted"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, object()]], TRI_F, TypeError, r"mesh\.vertices"),
    (None, TRI_F, TypeError, r"mesh\.vertices: expected an array, got None"),
    (TRI_V, None, TypeError, r"mesh\.faces: expected an array, got None"),
    (TRI_V, [[0, 1, 2.5]], TypeError, r"mesh\.faces: expected integers"),
    (TRI_V, [[True, False, True]], TypeError, r"mesh\.faces: expected integers, got booleans"),
    (np.zeros((0, 3)), np.zeros((0, 3), int), ValueError, r"mesh\.vertices: the mesh has no vertices"),
    (TRI_V, np.zeros((0, 3), int), ValueError, r"mesh\.faces: the mesh has no faces"),
    ([], [], ValueError, r"mesh\.vertices"),
])
def test_bad_mesh_arrays(vertices, faces, exc, match):
    with pytest.raises(exc, match=match):
        rs.Mesh(vertices, faces)


def test_mesh_messages_use_its_name():
    with pytest.raises(ValueError, match=r"bunny\.faces: face 0 indexes vertex 9"):
        rs.Mesh(TRI_V, [[0, 1, 9]], name="bunny")


@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(normals=[[0, 0, 1]] * 2), ValueError, r"mesh\.normals: expected shape \(3, 3\)"),
    (dict(normals=[[0, 0, np.nan]] * 3), ValueError, r"mesh\.normals: non-finite"),
    (dict(uvs=[[0, 0, 0]] * 3), ValueError, r"mesh\.uvs: expected shape \(3, 2\)"),
    (dict(uvs=[["u", "v"]] * 3), TypeError, r"mesh\.uvs: expected numbers"),
    (dict(weighting="mean"), ValueError, r"mesh\.weighting: expected one of"),
    (dict(weighting=2), TypeError, r"mesh\.weighting"),
    (dict(crease_angle=0.0), ValueError, r"mesh\.crease_angle: must be > 0"),
    (dict(crease_angle=-10.0), ValueError, r"mesh\.crease_angle"),
    (dict(crease_angle=200.0), ValueError, r"mesh\.crease_angle: must be <= 180"),
    (dict(crease_angle=np.nan), ValueError, r"mesh\.crease_angle: must be finite"),
    (dict(crease_angle="30"), TypeError, r"mesh\.crease_angle: expected a number"),
])
def test_bad_mesh_options(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        rs.Mesh(TRI_V, TRI_F, **kwargs)


def test_missing_mesh_file(tmp_path):
    with pytest.raises(ValueError, match="mesh file not found"):
        rs.Mesh.load(tmp_path / "nope.obj")


# -- camera ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(width=0), ValueError, r"camera\.width: must be >= 1, got 0"),
    (dict(width=-4), ValueError, r"camera\.width: must be >= 1"),
    (dict(height=0), ValueError, r"camera\.height: must be >= 1"),
    (dict(height=-1), ValueError, r"camera\.height"),
    (dict(width=32.5), TypeError, r"camera\.width: expected an integer"),
    (dict(height=True), TypeError, r"camera\.height: expected an integer"),
    (dict(target=(0.0, 0.0, 3.0)), ValueError, r"camera\.eye: eye and target coincide"),
    (dict(up=(0.0, 0.0, 5.0)), ValueError, r"camera\.up: parallel to the view direction"),
    (dict(up=(0.0, 0.0, -1.0)), ValueError, r"camera\.up: parallel"),
    (dict(up=(0.0, 0.0, 0.0)), ValueError, r"camera\.up: must not be the zero vector"),
    (dict(eye=(0.0, np.nan, 3.0)), ValueError, r"camera\.eye: non-finite"),
    (dict(target=(0.0, 0.0)), ValueError, r"camera\.target: expected shape \(3\)"),
    (dict(fov=0.0), ValueError, r"camera\.fov: must be > 0"),
    (dict(fov=180.0), ValueError, r"camera\.fov: must be < 180"),
    (dict(fov=-30.0), ValueError, r"camera\.fov"),
    (dict(projection="fisheye"), ValueError, r"camera\.projection: expected one of"),
    (dict(ortho_height=0.0), ValueError, r"camera\.ortho_height: must be > 0"),
])
def test_bad_camera(kwargs, exc, match):
    kwargs = {"eye": (0.0, 0.0, 3.0), **kwargs}
    with pytest.raises(exc, match=match):
        rs.Camera(**kwargs)


def test_degenerate_camera_far_from_origin():
    """Coincidence is judged relative to the coordinates' magnitude."""
    with pytest.raises(ValueError, match=r"camera\.eye"):
        rs.Camera(eye=(1e6, 0.0, 0.0), target=(1e6 + 1e-8, 0.0, 0.0))
    rs.Camera(eye=(1e6, 0.0, 0.0), target=(1e6 + 1.0, 0.0, 0.0), up=(0, 0, 1))  # fine


# -- materials and lights ------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(kd=-0.1), ValueError, r"material\.kd: must be >= 0"),
    (dict(ka=(0.1, -1.0, 0.2)), ValueError, r"material\.ka: must be >= 0"),
    (dict(ks=-1), ValueError, r"material\.ks: must be >= 0"),
    (dict(kd=(0.1, 0.2)), ValueError, r"material\.kd: expected a scalar or 3 values"),
    (dict(kd="red"), TypeError, r"material\.kd: expected numbers"),
    (dict(kd=np.nan), ValueError, r"material\.kd: must be finite"),
    (dict(shininess=0.0), ValueError, r"material\.shininess: must be > 0"),
    (dict(shininess=-5.0), ValueError, r"material\.shininess: must be > 0"),
    (dict(shininess=np.inf), ValueError, r"material\.shininess: must be finite"),
    (dict(shininess="high"), TypeError, r"material\.shininess: expected a number"),
    (dict(specular="cook-torrance"), ValueError, r"material\.specular: expected one of"),
])
def test_bad_material(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        rs.Material(**kwargs)


@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(intensity=-1.0), ValueError, r"point_light\.intensity: must be >= 0"),
    (dict(color=(1.0, -0.5, 1.0)), ValueError, r"point_light\.color: must be >= 0"),
    (dict(attenuation="inverse_cube"), ValueError, r"point_light\.attenuation: expected one of"),
    (dict(attenuation="heuristic", k=0.0), ValueError, r"point_light\.k: heuristic attenuation needs k > 0"),
    (dict(attenuation="heuristic", k=-2.0), ValueError, r"point_light\.k: heuristic attenuation needs k > 0"),
    (dict(k=np.nan), ValueError, r"point_light\.k: must be finite"),
    (dict(position=(0.0, np.inf, 0.0)), ValueError, r"point_light\.position: non-finite"),
    (dict(position=(0.0, 1.0)), ValueError, r"point_light\.position: expected shape"),
])
def test_bad_point_light(kwargs, exc, match):
    kwargs = {"position": (0.0, 0.0, 1.0), **kwargs}
    with pytest.raises(exc, match=match):
        rs.PointLight(**kwargs)


@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(direction=(0.0, 0.0, 0.0)), ValueError, r"directional_light\.direction: must not be the zero vector"),
    (dict(direction=(0.0, np.nan, 1.0)), ValueError, r"directional_light\.direction: non-finite"),
    (dict(intensity=-0.5), ValueError, r"directional_light\.intensity: must be >= 0"),
    (dict(color=-1.0), ValueError, r"directional_light\.color: must be >= 0"),
])
def test_bad_directional_light(kwargs, exc, match):
    kwargs = {"direction": (0.0, 0.0, -1.0), **kwargs}
    with pytest.raises(exc, match=match):
        rs.DirectionalLight(**kwargs)


# -- scenes ------------------------------------------------------------------------------------------
def test_bad_scene_fields():
    mesh = rs.Mesh(TRI_V, TRI_F)
    with pytest.raises(ValueError, match=r"scene\.models: a scene needs at least one model"):
        rs.Scene([])
    with pytest.raises(TypeError, match=r"scene\.models\[1\]: expected a Model"):
        rs.Scene([mesh, "teapot"])
    with pytest.raises(TypeError, match=r"model\.mesh: expected a Mesh"):
        rs.Model(np.zeros((3, 3)))
    with pytest.raises(TypeError, match=r"model\.material: expected a Material"):
        rs.Model(mesh, {"kd": 0.5})
    with pytest.raises(TypeError, match=r"scene\.lights\[0\]: expected a PointLight or DirectionalLight"):
        rs.Scene([mesh], lights=[(0, 0, 1)])
    with pytest.raises(TypeError, match=r"scene\.lights"):
        rs.Scene([mesh], lights=5)
    with pytest.raises(TypeError, match=r"scene\.camera: expected a Camera"):
        rs.Scene([mesh], camera=(0, 0, 3))
    with pytest.raises(ValueError, match=r"scene\.ambient: must be >= 0"):
        rs.Scene([mesh], ambient=-0.1)
    with pytest.raises(ValueError, match=r"scene\.ambient: expected a scalar or 3 values"):
        rs.Scene([mesh], ambient=(0.1, 0.1))


def test_a_single_light_is_accepted_like_a_single_model():
    light = rs.PointLight((0, 0, 2))
    scene = rs.Scene(rs.Mesh(TRI_V, TRI_F), lights=light)
    assert scene.lights == (light,)
    assert len(scene.models) == 1


# -- render and friends: refused before anything is packed, built or cast -----------------------------------
@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(shading="smooth"), ValueError, r"shading: expected one of \['flat', 'gouraud', 'phong', 'auto'\], got 'smooth'"),
    (dict(shading=None), ValueError, r"shading: expected one of"),
    (dict(shading=3), ValueError, r"shading: expected one of"),
    (dict(backend="gpu"), ValueError, r"backend: expected one of"),
    (dict(interpolation="cubic"), ValueError, r"interpolation: expected one of"),
    (dict(caster="optix"), ValueError, r"caster: expected one of"),
    (dict(caster=None), ValueError, r"caster: expected one of"),
    (dict(camera="front"), TypeError, r"camera: expected a Camera"),
])
def test_bad_render_arguments_fail_before_any_work(kwargs, exc, match):
    scene = fresh_scene()
    with pytest.raises(exc, match=match):
        rs.render(scene, **kwargs)
    assert not scene.has_geometry  # nothing packed, no BVH built, no kernel run


def test_render_without_camera():
    scene = fresh_scene(camera=None)
    with pytest.raises(ValueError, match=r"camera: the scene has no camera"):
        rs.render(scene)
    assert not scene.has_geometry


def test_render_needs_a_scene():
    with pytest.raises(TypeError, match=r"scene: expected a Scene, got Mesh"):
        rs.render(rs.Mesh(TRI_V, TRI_F))


def test_bad_names_in_lower_level_functions():
    scene = fresh_scene()
    hits = rs.HitBuffer.empty(6, 8)
    with pytest.raises(ValueError, match=r"shading: expected one of"):
        rs.shade(scene, scene.camera, hits, "toon")
    with pytest.raises(ValueError, match=r"shading: expected one of"):
        rs.shading_normals(scene, scene.camera, hits, "toon")
    with pytest.raises(ValueError, match=r"caster: expected one of"):
        rs.cast_camera(scene.geometry, scene.camera, caster="cuda")
    with pytest.raises(ValueError, match=r"shape: expected one of"):
        rs.shapes.make("teapot")
    with pytest.raises(ValueError, match=r"shape 'plane'"):
        rs.shapes.make("plane", radius=2.0)


@pytest.mark.parametrize("kwargs, match", [
    (dict(tonemap="aces"), r"tonemap: expected one of"),
    (dict(exposure=0.0), r"exposure: must be a finite number > 0"),
    (dict(exposure=np.nan), r"exposure"),
    (dict(gamma="linear"), r"gamma: expected 'srgb' or a number"),
    (dict(gamma=-2.2), r"gamma: must be > 0"),
])
def test_bad_tonemap_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        rs.to_uint8(np.zeros((2, 2, 3)), **kwargs)


def test_bad_pfm(tmp_path):
    with pytest.raises(ValueError, match=r"image: expected \(H, W, 3\)"):
        rs.write_pfm(tmp_path / "x.pfm", np.zeros((4, 4)))
    (tmp_path / "y.pfm").write_bytes(b"P6\n1 1\n255\n\x00\x00\x00")
    with pytest.raises(ValueError, match="not a colour PFM"):
        rs.read_pfm(tmp_path / "y.pfm")


@pytest.mark.parametrize("make, field", [
    (lambda: rs.shapes.plane(size=-1.0), "size"),
    (lambda: rs.shapes.plane(size=float("nan")), "size"),
    (lambda: rs.shapes.cube(size=0.0), "size"),
    (lambda: rs.shapes.icosphere(2, radius=float("inf")), "radius"),
    (lambda: rs.shapes.uv_sphere(radius=-2.0), "radius"),
    (lambda: rs.shapes.cylinder(height=0.0), "height"),
    (lambda: rs.shapes.cylinder(radius=-0.5), "radius"),
    (lambda: rs.shapes.cylinder(segments=2), "segments"),
])
def test_bad_procedural_shape_sizes(make, field):
    """A shape of negative, zero or non-finite size is an error naming the field,
    not a mirrored or empty mesh."""
    with pytest.raises(ValueError, match=field):
        make()


def _far_triangle(scale, eye_factor=1.0):
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]) * scale
    cam = rs.Camera(eye=(0.3 * scale, 0.3 * scale, eye_factor * scale), target=(0.3 * scale, 0.3 * scale, 0.0),
                    width=16, height=16)
    return rs.Scene([rs.Model(rs.Mesh(v, [[0, 1, 2]]))], lights=[rs.DirectionalLight((0, 0, -1))], camera=cam)


def test_coordinates_beyond_embrees_float32_range_are_refused():
    """Embree multiplies float32 coordinates together: a triangle of size 1e19 came back
    as an empty image without a word. The ray caster now refuses such scenes (and far
    cameras) before any kernel runs; at 1e18 it still agrees with the rasterizer, which
    computes in float64 and keeps working beyond."""
    ok = _far_triangle(1e18)
    mask = rs.render(ok).mask
    assert mask.sum() > 100
    np.testing.assert_array_equal(mask, rs.render(ok, backend="raster").mask)
    far = _far_triangle(1e19)
    with pytest.raises(ValueError, match=r"scene vertices: reaches 5e\+18 from the scene's centre.*scale the scene"):
        rs.render(far)
    with pytest.raises(ValueError, match=r"reaches [0-9.e+]+ from the scene's centre"):
        rs.render(far, caster="embreex")  # the fallback caster: the camera is checked first
    with pytest.raises(ValueError, match=r"scene vertices: reaches 5e\+18"):
        embreex_scene(far.geometry)
    assert rs.render(far, backend="raster").mask.sum() > 100
    with pytest.raises(ValueError, match=r"camera.eye: reaches 2e\+18"):
        rs.render(_far_triangle(1.0, eye_factor=2e18))
    # Orthographic rays start across the view rectangle: its half-diagonal counts too.
    ortho = _far_triangle(1.0, eye_factor=0.9e18)
    wide = ortho.camera.replace(projection="orthographic", ortho_height=0.3e18)  # half-diagonal 0.21e18
    with pytest.raises(ValueError, match=r"camera.eye: reaches 1.1\de\+18"):
        rs.render(ortho, camera=wide)
    assert np.isfinite(rs.render(ortho, camera=wide.replace(ortho_height=0.1e18)).image).all()  # within: accepted
    with pytest.raises(ValueError, match="scene vertices"):  # float32 overflow: inf vertices would vanish
        rs.render(_far_triangle(1e39))


def test_scenes_too_small_for_embrees_float32_range_are_refused():
    """The same products underflow below about 1e-19: a scene 1e-20 across came back
    empty. 1e-15 renders (the camera check is relative, so such a small camera is
    valid) and agrees with the rasterizer; 1e-20 is refused with the remedy."""
    small = _far_triangle(1e-15)
    mask = rs.render(small).mask
    assert mask.sum() > 100
    np.testing.assert_array_equal(mask, rs.render(small, backend="raster").mask)
    with pytest.raises(ValueError, match=r"scene vertices: the scene spans only 5e-21 .*scale the scene .* up"):
        rs.render(_far_triangle(1e-20))
    assert rs.render(_far_triangle(1e-20), backend="raster").mask.sum() > 100


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(origins=np.zeros((2, 2))), ValueError, r"origins: expected shape \(N, 3\)"),
    (dict(origins=[[0.0, 0.0, np.nan]] * 2), ValueError, "origins: non-finite"),
    (dict(directions=[[0.0, 0.0, -1.0]]), ValueError, "directions: expected 2 rows"),
    (dict(directions=[[0.0, 0.0, -1.0], [0.0, 0.0, 0.0]]), ValueError, "directions: row 1 is the zero vector"),
    (dict(directions=[["a", "b", "c"]] * 2), TypeError, "directions: expected numbers"),
    (dict(tnear=-1.0), ValueError, "tnear: expected finite values >= 0"),
    (dict(tnear=np.inf), ValueError, "tnear: expected finite values >= 0"),
    (dict(tnear=[0.0, 0.0, 0.0]), ValueError, r"tnear: expected a number or 2 values"),
    (dict(tfar=np.nan), ValueError, "tfar: NaN"),
    (dict(tnear=5.0, tfar=[9.0, 1.0]), ValueError, "tfar: row 1 is below tnear"),
    (dict(origins=[[0.0, 0.0, 2e18]] * 2), ValueError, r"origins: reaches 2e\+18"),
])
def test_cast_rays_validates_before_embree(kwargs, error, match):
    geo = rs.Scene([rs.Model(rs.shapes.icosphere(1))]).geometry
    args = dict(origins=[[0.0, 0.0, 5.0]] * 2, directions=[[0.0, 0.0, -1.0]] * 2)
    args.update(kwargs)
    with pytest.raises(error, match=match):
        rs.cast_rays(geo, **args)
    prim, *_ = rs.cast_rays(geo, [[0.0, 0.0, 5.0]] * 2, [[0.0, 0.0, -1.0]] * 2, tnear=[0.0, 1.0], tfar=np.inf)
    assert (prim >= 0).all()


def test_extreme_radiance_saturates_instead_of_overflowing():
    """Every radiometric input may be up to 1e30; products of them overflowed float32 to
    inf (intensity 1e30 times kd 1e30). The kernels now store at most float32's maximum, in
    every mode, backend and through mirrors; more than 1e30 is refused up front."""
    big = 1e30
    ico = rs.shapes.icosphere(2)
    floor = rs.shapes.plane(size=6.0, center=(0.0, -1.2, 0.0), normal="+y")
    mirror = rs.shapes.plane(size=3.0, center=(0.0, 0.0, -2.0), normal="+z")
    mat = rs.Material(kd=big, ks=big, ka=big)
    scene = rs.Scene([rs.Model(ico, mat), rs.Model(floor, mat),
                      rs.Model(mirror, rs.Material(kd=big, reflectivity=0.9))],
                     lights=[rs.PointLight((0.0, 1.0001, 0.0), intensity=big, attenuation="inverse_square"),
                             rs.DirectionalLight((0.0, -1.0, 0.0), intensity=big)],
                     camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=16, height=16), ambient=big, background=big)
    top = float(np.finfo(np.float32).max)
    for backend in ("raycast", "raster"):
        for shading in rs.SHADINGS:
            img = rs.render(scene, shading, backend=backend).image
            assert np.isfinite(img).all(), (backend, shading)
            assert img.max() == np.float32(top)  # saturated, not wrapped or NaN
            assert img.min() >= np.float32(big)  # ambient * ka alone is 1e60
    for make, field in ((lambda: rs.PointLight((0, 0, 1), intensity=1.1e30), "point_light.intensity"),
                        (lambda: rs.DirectionalLight((0, 0, 1), intensity=2e30), "directional_light.intensity"),
                        (lambda: rs.Material(ks=(0.0, 0.0, 1e31)), "material.ks"),
                        (lambda: rs.PointLight((0, 0, 1), color=(1e31, 0, 0)), "point_light.color"),
                        (lambda: rs.Scene([rs.Model(ico)], background=1e31), "scene.background")):
        with pytest.raises(ValueError, match=re.escape(field) + ": must be <= 1e"):
            make()


def test_shade_refuses_hit_buffers_that_would_read_outside_the_scene():
    """rs.shade takes any HitBuffer; a triangle or model index out of range made the
    kernels read outside their arrays (a segmentation fault). Now a ValueError names
    the field first; a buffer of any shape with valid indices is still shaded."""
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(1))], lights=[rs.PointLight((2.0, 3.0, 4.0))],
                     camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=8, height=6))
    hits = rs.cast_camera(scene.geometry, scene.camera)
    n_faces = len(scene.geometry.faces)

    def buf(**kw):
        d = dict(prim=hits.prim, geom=hits.geom, u=hits.u, v=hits.v, t=hits.t)
        d.update(kw)
        return rs.HitBuffer(**d)

    hit = hits.mask
    cases = [
        (dict(prim=np.where(hit, n_faces, -1).astype(np.int32)), ValueError, "hits.prim: 12 hit pixel"),
        (dict(geom=np.where(hit, 1, -1).astype(np.int32)), ValueError, r"hits.geom: 12 hit pixel\(s\) name a model outside 0..0"),
        (dict(geom=np.full(hits.shape, -1, np.int32)), ValueError, "hits.geom"),
        (dict(u=np.where(hit, np.nan, 0).astype(np.float32)), ValueError, "hits.u, hits.v: 12 hit pixel"),
        (dict(prim=hits.prim.astype(np.float32)), TypeError, "hits.prim: expected integers"),
        (dict(v=np.zeros((2, 2), np.float32)), ValueError, r"hits.v: expected a 2-D array of shape \(6, 8\)"),
    ]
    assert hit.sum() == 12
    for kw, error, match in cases:
        with pytest.raises(error, match=match):
            rs.shade(scene, scene.camera, buf(**kw), "phong")
    with pytest.raises(TypeError, match="camera"):
        rs.shade(scene, "camera", hits, "phong")
    # A strip of hits unrelated to the camera's image size: shaded, as before.
    strip = rs.HitBuffer(prim=np.arange(5, dtype=np.int32)[None], geom=np.zeros((1, 5), np.int32),
                         u=np.full((1, 5), 0.3, np.float32), v=np.full((1, 5), 0.3, np.float32),
                         t=np.ones((1, 5), np.float32))
    assert np.isfinite(rs.shade(scene, scene.camera, strip, "gouraud")).all()


def test_public_casting_and_shading_functions_check_their_arguments():
    """AttributeErrors (a str for the geometry) and a segmentation fault
    (shading_normals with an out-of-range triangle index) became errors naming
    the argument; a Scene is accepted wherever its geometry is."""
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(1))], lights=[rs.PointLight((2.0, 3.0, 4.0))],
                     camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=8, height=6))
    with pytest.raises(TypeError, match="geometry: expected a SceneGeometry"):
        rs.cast_camera("geo", scene.camera)
    with pytest.raises(TypeError, match="camera: expected a Camera"):
        rs.cast_camera(scene.geometry, "camera")
    with pytest.raises(TypeError, match="geometry: expected a SceneGeometry"):
        rs.cast_rays(None, [[0.0, 0.0, 5.0]], [[0.0, 0.0, -1.0]])
    hits = rs.cast_camera(scene, scene.camera)  # the Scene stands for its geometry
    np.testing.assert_array_equal(hits.prim, rs.cast_camera(scene.geometry, scene.camera).prim)
    assert rs.cast_rays(scene, [[0.0, 0.0, 5.0]], [[0.0, 0.0, -1.0]]).prim[0] >= 0
    bad = rs.HitBuffer(prim=np.where(hits.mask, 10 ** 6, -1).astype(np.int32), geom=hits.geom, u=hits.u, v=hits.v,
                       t=hits.t)
    with pytest.raises(ValueError, match="hits.prim"):
        rs.shading_normals(scene, scene.camera, bad)
    with pytest.raises(TypeError, match="scene: expected a Scene"):
        rs.shading_normals(scene.geometry, scene.camera, hits)
    n = rs.shading_normals(scene, scene.camera, hits)
    np.testing.assert_allclose(np.linalg.norm(n[hits.mask], axis=1), 1.0, atol=1e-5)
