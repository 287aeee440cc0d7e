"""The input contract of the scene's classes and files: every bad input refused
(naming its field) and every valid one taken. One section per class of issue 17:

4. silently accepted or altered; 5. aliasing; 6. refused though valid;
7. unclear errors and allocations beyond memory.

The rest of the contract: render's arguments (``tests/render/test_input_contract.py``),
hit buffers given to ``shade`` (``tests/shading/``), tone options and output paths
(``tests/output/``), the command line (``tests/apps/test_cli_contract.py``).
"""

from __future__ import annotations

import math
import os
import re
import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import raycast_shade as rs
from raycast_shade.common import validate
from raycast_shade.scene.camera import FRAME_BYTES_PER_PIXEL
from raycast_shade.scene.mesh import ZeroNormalWarning
from raycast_shade.scene.scenefile import SceneFileError, scene_from_dict

from tests.conftest import TRI_F, TRI_V, small_scene

EPS32 = float(np.finfo(np.float32).eps)
FAST = settings(max_examples=60, deadline=None)


def scene_dict(obj=None, light=None, camera=None, material=None, **top):
    """A minimal scene-file table; the arguments update its parts."""
    o = dict(obj or {})
    if o.setdefault("shape", "icosphere") == "icosphere":
        o.setdefault("subdivisions", 1)
    if material is not None:
        o["material"] = material
    cam = {"eye": [0.0, 0.0, 4.0], "width": 16, "height": 12}
    cam.update(camera or {})
    lt = {"type": "point", "position": [2.0, 3.0, 4.0]}
    lt.update(light or {})
    return {"camera": cam, "object": [o], "light": [lt], **top}


def write_ply(path, vertices, faces):
    lines = ["ply", "format ascii 1.0", f"element vertex {len(vertices)}", "property float x", "property float y",
             "property float z", f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    lines += [" ".join(str(c) for c in v) for v in vertices]
    lines += ["3 " + " ".join(str(i) for i in f) for f in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


# =====================================================================================================
# 4. Silently accepted, silently altered
# =====================================================================================================
SQUARE_V = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 2, 0]]
SQUARE_F = [[0, 1, 2], [0, 2, 3], [1, 4, 2]]


@pytest.mark.parametrize("ext", ["ply", "obj"])
@pytest.mark.parametrize("bad, n_vertices, n_faces", [
    ({4: "nan"}, 1, 1),            # one NaN vertex used by one face
    ({2: "nan"}, 1, 3),            # a vertex shared by all three faces
    ({0: "inf", 3: "-inf"}, 2, 2),  # infinities count too
    ({4: "nan", 2: "nan"}, 2, 3),
])
def test_a_mesh_file_with_non_finite_vertices_is_refused_with_the_counts(tmp_path, ext, bad, n_vertices, n_faces):
    """trimesh drops faces on NaN vertices while it loads; the mesh came back smaller without
    a word. Now the file is refused, naming it and both counts."""
    verts = [list(v) for v in SQUARE_V]
    for i, value in bad.items():
        verts[i][1] = value
    path = tmp_path / f"bad.{ext}"
    if ext == "ply":
        write_ply(path, verts, SQUARE_F)
    else:
        path.write_text("".join(f"v {' '.join(map(str, v))}\n" for v in verts)
                        + "".join(f"f {' '.join(str(i + 1) for i in f)}\n" for f in SQUARE_F))
    with pytest.raises(ValueError, match=rf"mesh file .*bad\.{ext}: {n_vertices} vertex\(es\) with non-finite "
                                         rf"coordinates \(NaN or inf\), used by {n_faces} face\(s\)"):
        rs.Mesh.load(path)


def test_a_finite_mesh_file_loads_as_trimesh_would(tmp_path):
    """The NaN check loads unprocessed and then processes: the same triangles as trimesh.load."""
    import trimesh

    path = write_ply(tmp_path / "ok.ply", SQUARE_V + [[0, 0, 0]], SQUARE_F + [[5, 1, 2]])  # a duplicate vertex
    tm = trimesh.load(path)
    mesh = rs.Mesh.load(path, merge=True)  # merging is now asked for (issue 13: kept as written by default)
    np.testing.assert_array_equal(mesh.vertices, tm.vertices)
    np.testing.assert_array_equal(mesh.faces, tm.faces)
    assert len(mesh.vertices) == 5  # merged, as before


@pytest.mark.parametrize("zero_rows", [[0], [1, 2], [0, 1, 2]])
def test_zero_vertex_normals_are_counted_in_a_warning(zero_rows):
    normals = np.tile([0.0, 0.0, 1.0], (3, 1))
    normals[zero_rows] = 0.0
    with pytest.warns(ZeroNormalWarning, match=rf"tri\.normals: {len(zero_rows)} of 3 vertex normal\(s\) are zero; "
                                               "the face normal is used"):
        rs.Mesh(TRI_V, TRI_F, normals=normals, name="tri")


def test_non_zero_normals_give_no_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rs.Mesh(TRI_V, TRI_F, normals=np.tile([0.0, 0.0, 1e-300], (3, 1)))
        rs.shapes.uv_sphere(6, 8)  # exact normals, poles included


BOOL_CASES = [
    (lambda b: rs.Material(ks=b), "material.ks"),
    (lambda b: rs.Material(kd=b), "material.kd"),
    (lambda b: rs.Material(ka=b), "material.ka"),
    (lambda b: rs.PointLight(b), "point_light.position"),
    (lambda b: rs.PointLight((0, 0, 1), color=b), "point_light.color"),
    (lambda b: rs.DirectionalLight(b), "directional_light.direction"),
    (lambda b: rs.DirectionalLight((0, 0, -1), color=b), "directional_light.color"),
    (lambda b: rs.Camera(eye=b), "camera.eye"),
    (lambda b: rs.Camera(eye=(0, 0, 3), target=b), "camera.target"),
    (lambda b: rs.Camera(eye=(0, 0, 3), up=b), "camera.up"),
    (lambda b: rs.Scene([rs.Mesh(TRI_V, TRI_F)], ambient=b), "scene.ambient"),
    (lambda b: rs.Scene([rs.Mesh(TRI_V, TRI_F)], background=b), "scene.background"),
    (lambda b: rs.Mesh([b, [1.0, 0, 0], [0, 1.0, 0]], TRI_F), "mesh.vertices"),
    (lambda b: rs.Mesh(TRI_V, TRI_F, normals=[b] * 3), "mesh.normals"),
    (lambda b: rs.Mesh(TRI_V, TRI_F, uvs=[[list(b)[0], list(b)[2]]] * 3), "mesh.uvs"),
    (lambda b: rs.shapes.icosphere(1, center=b), "center"),
]


@pytest.mark.parametrize("make, field", BOOL_CASES)
@pytest.mark.parametrize("value", [
    [True, False, True], (True, True, True), np.array([True, False, True]), [True, 0.5, 1.0], [0.0, 0.0, np.True_],
    [1, 0, False],
])
def test_booleans_are_not_numbers_for_any_array_field(make, field, value):
    """NumPy takes [True, False, True] for [1, 0, 1] and [True, 0.5, 1] for floats; a boolean
    in a coordinate, colour or index is a mistake, named."""
    with pytest.raises(TypeError, match=rf"{field}: expected numbers, got booleans"):
        make(value)


@pytest.mark.parametrize("faces", [[[True, False, True]], [[0, 1, True]], np.ones((1, 3), bool), [(0, np.True_, 2)]])
def test_boolean_face_indices_are_refused(faces):
    with pytest.raises(TypeError, match=r"mesh\.faces: expected integers, got booleans"):
        rs.Mesh(TRI_V, faces)


@pytest.mark.parametrize("make, field", [
    (lambda b: rs.Material(kd=b), "material.kd"),
    (lambda b: rs.Material(shininess=b), "material.shininess"),
    (lambda b: rs.Material(reflectivity=b), "material.reflectivity"),
    (lambda b: rs.PointLight((0, 0, 1), intensity=b), "point_light.intensity"),
    (lambda b: rs.PointLight((0, 0, 1), k=b), "point_light.k"),
    (lambda b: rs.Camera(eye=(0, 0, 3), fov=b), "camera.fov"),
    (lambda b: rs.Camera(eye=(0, 0, 3), width=b), "camera.width"),
    (lambda b: rs.shapes.icosphere(b), "subdivisions"),
    (lambda b: rs.shapes.uv_sphere(b), "rings"),
    (lambda b: rs.shapes.torus(major_segments=b), "major_segments"),
    (lambda b: rs.shapes.plane(subdivisions=b), "subdivisions"),
    (lambda b: rs.shapes.cylinder(segments=b), "segments"),
    (lambda b: rs.shapes.cube(size=b), "size"),
    (lambda b: rs.HeightMap.dimples(count=b, resolution=8), "heightmap.count"),
    (lambda b: rs.HeightMap.wrinkles(seed=b, resolution=8), "heightmap.seed"),
    (lambda b: rs.HeightMap(np.zeros((2, 2)), scale=b), "heightmap.scale"),
])
@pytest.mark.parametrize("value", [True, False, np.True_])
def test_a_boolean_is_not_a_scalar_or_a_count(make, field, value):
    with pytest.raises(TypeError, match=rf"{field}: expected (a number|an integer|numbers), got (bool|a boolean)"):
        make(value)


def test_boolean_heights_and_tiling_are_refused():
    with pytest.raises(TypeError, match=r"heightmap.heights: expected numbers, got booleans"):
        rs.HeightMap(np.ones((3, 3), bool))
    with pytest.raises(TypeError, match=r"heightmap.tiling: expected numbers, got booleans"):
        rs.HeightMap(np.zeros((2, 2)), tiling=(True, 2.0))


@given(data=st.data(), n=st.integers(1, 4))
@FAST
def test_any_boolean_anywhere_in_a_vector_is_refused(data, n):
    """Property: a length-3 value with at least one bool, the rest numbers, is refused in every
    vector field."""
    pos = data.draw(st.lists(st.integers(0, 2), min_size=1, max_size=n, unique=True))
    value = [data.draw(st.floats(-10, 10)) for _ in range(3)]
    for i in pos:
        value[i] = data.draw(st.booleans())
    make, field = data.draw(st.sampled_from(BOOL_CASES[:12]))
    with pytest.raises(TypeError, match=field):
        make(value)


TOML_BOOL_CASES = [
    (dict(material={"kd": [True, False, True]}), "object[0].material.kd"),
    (dict(material={"ks": True}), "object[0].material.ks"),
    (dict(material={"shininess": True}), "object[0].material.shininess"),
    (dict(obj={"subdivisions": True}), "subdivisions"),
    (dict(obj={"radius": True}), "radius"),
    (dict(obj={"center": [True, 0, 0]}), "object[0].center"),
    (dict(obj={"scale": True}), "object[0].scale"),
    (dict(obj={"rotate": [0, True, 0]}), "object[0].rotate"),
    (dict(obj={"translate": [0, 0, True]}), "object[0].translate"),
    (dict(obj={"crease_angle": True}), "object[0].crease_angle"),
    (dict(obj={"shape": "cylinder", "segments": True}), "segments"),
    (dict(obj={"shape": "torus", "major_segments": True}), "major_segments"),
    (dict(light={"position": [True, 0, 0]}), "light[0].position"),
    (dict(light={"intensity": True}), "light[0].intensity"),
    (dict(light={"color": [1, 1, False]}), "light[0].color"),
    (dict(camera={"eye": [0, True, 4]}), "camera.eye"),
    (dict(camera={"fov": True}), "camera.fov"),
    (dict(camera={"width": True}), "camera.width"),
    (dict(ambient=True), "ambient"),
    (dict(background=[True, True, True]), "background"),
    (dict(material={"bump": {"pattern": "dimples", "count": True, "resolution": 8}}), "count"),
    (dict(material={"bump": {"pattern": "dimples", "tiling": [True, 1], "resolution": 8}}), "tiling"),
]


@pytest.mark.parametrize("parts, key", TOML_BOOL_CASES)
def test_scene_file_booleans_are_refused_naming_the_key(parts, key):
    """TOML `kd = [true, false, true]` and `subdivisions = true` were coordinates and counts."""
    with pytest.raises(SceneFileError, match=r"<scene>: .*" + re.escape(key) + r".*"
                                              r"expected (numbers|a number|an integer), got (booleans|bool|a boolean)"):
        scene_from_dict(scene_dict(**parts))


INT_FIELDS = [
    (lambda x: rs.shapes.icosphere(x), "subdivisions"),
    (lambda x: rs.shapes.uv_sphere(x, 8), "rings"),
    (lambda x: rs.shapes.uv_sphere(4, x), "segments"),
    (lambda x: rs.shapes.torus(major_segments=x), "major_segments"),
    (lambda x: rs.shapes.torus(minor_segments=x), "minor_segments"),
    (lambda x: rs.shapes.plane(subdivisions=x), "subdivisions"),
    (lambda x: rs.shapes.cylinder(segments=x), "segments"),
    (lambda x: rs.Camera(eye=(0, 0, 3), width=x), "camera.width"),
    (lambda x: rs.Camera(eye=(0, 0, 3), height=x), "camera.height"),
    (lambda x: rs.HeightMap.dimples(count=x, resolution=8), "heightmap.count"),
    (lambda x: rs.HeightMap.dimples(resolution=x), "heightmap.resolution"),
    (lambda x: rs.HeightMap.wrinkles(octaves=x, resolution=8), "heightmap.octaves"),
    (lambda x: rs.HeightMap.wrinkles(frequency=x, resolution=8), "heightmap.frequency"),
    (lambda x: rs.render(small_scene(), max_depth=x), "max_depth"),
]


@pytest.mark.parametrize("make, field", INT_FIELDS)
@pytest.mark.parametrize("value", [2.7, 3.5, np.float64(6.5), np.float32(2.25), 1e12, 3.0])
def test_floats_are_never_truncated_into_integer_fields(make, field, value):
    """`subdivisions = 2.7` was built as 2; every integer field now refuses a float, integral
    or not (1e12 is not a count either)."""
    with pytest.raises(TypeError, match=rf"{field}: expected an integer, got (float|float64|float32)"):
        make(value)


@given(x=st.floats(-1e6, 1e6, allow_nan=False).filter(lambda x: x != int(x)), i=st.integers(0, len(INT_FIELDS) - 1))
@FAST
def test_non_integral_floats_are_refused_everywhere(x, i):
    make, field = INT_FIELDS[i]
    with pytest.raises(TypeError, match=field):
        make(x)


@pytest.mark.parametrize("obj, key", [
    ({"subdivisions": 2.7}, "subdivisions"),
    ({"shape": "cylinder", "segments": 6.5}, "segments"),
    ({"shape": "uv_sphere", "rings": 4.0}, "rings"),
    ({"shape": "plane", "subdivisions": 1.5}, "subdivisions"),
    ({"shape": "torus", "minor_segments": 8.25}, "minor_segments"),
])
def test_scene_file_floats_for_integers_are_refused(obj, key):
    with pytest.raises(SceneFileError, match=rf"object\[0\].*{key}: expected an integer, got float"):
        scene_from_dict(scene_dict(obj=obj))


# =====================================================================================================
# 5. Aliasing: frozen classes own their arrays
# =====================================================================================================
def test_a_mesh_owns_copies_of_every_array():
    buf = np.array(TRI_V)
    faces = np.array(TRI_F)
    normals = np.tile([0.0, 0.0, 1.0], (3, 1))
    uvs = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    mesh = rs.Mesh(buf[:], faces[:], normals=normals[:], uvs=uvs[:])
    buf *= 0.5
    faces[0] = [2, 1, 0]
    normals *= -1
    uvs += 1
    np.testing.assert_array_equal(mesh.vertices, TRI_V)
    np.testing.assert_array_equal(mesh.faces, TRI_F)
    np.testing.assert_array_equal(mesh.normals, np.tile([0.0, 0.0, 1.0], (3, 1)))
    np.testing.assert_array_equal(mesh.uvs, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    for a, mine in ((mesh.vertices, buf), (mesh.faces, faces), (mesh.normals, normals), (mesh.uvs, uvs)):
        assert not a.flags.writeable
        assert not np.shares_memory(a, mine)
    assert buf.flags.writeable and faces.flags.writeable  # the caller's arrays are left alone
    with pytest.raises(ValueError, match="read-only"):
        mesh.vertices[0, 0] = 9.0


def test_config_classes_own_copies_of_their_vectors():
    v = np.array([0.5, 0.25, 0.125])
    eye, target, up = np.array([0.0, 0.0, 3.0]), np.zeros(3), np.array([0.0, 1.0, 0.0])
    heights = np.linspace(0, 1, 9, dtype=np.float32).reshape(3, 3)
    cam = rs.Camera(eye=eye, target=target, up=up)
    pl = rs.PointLight(v, color=v)
    dl = rs.DirectionalLight(-v, color=v)
    mat = rs.Material(kd=v, ka=v, ks=v)
    hm = rs.HeightMap(heights)
    scene = rs.Scene([rs.Mesh(TRI_V, TRI_F)], ambient=v, background=v)
    keep = [a.copy() for a in (cam.eye, cam.up, pl.position, pl.color, dl.direction, mat.kd, hm.heights,
                              scene.ambient)]
    for a in (v, eye, target, up, heights):
        a *= 3
    got = [cam.eye, cam.up, pl.position, pl.color, dl.direction, mat.kd, hm.heights, scene.ambient]
    for before, after in zip(keep, got):
        np.testing.assert_array_equal(before, after)
        assert not after.flags.writeable


# =====================================================================================================
# 6. Refused though valid: NumPy scalars, 0-d arrays, extreme but finite vectors
# =====================================================================================================


@pytest.mark.parametrize("make", [
    lambda: rs.Material(kd=np.array(0.5)), lambda: rs.Material(kd=np.float32(0.5)), lambda: rs.Material(ks=np.int64(1)),
    lambda: rs.Material(kd=np.array([0.5, 0.5, 0.5], np.float32)), lambda: rs.Material(shininess=np.int64(32)),
    lambda: rs.Material(shininess=np.array(8.0)), lambda: rs.Material(reflectivity=np.float16(0.5)),
    lambda: rs.PointLight(np.array([0, 0, 1], np.int32), intensity=np.float32(2), k=np.array(1.0)),
    lambda: rs.Camera(eye=(0, 0, 3), width=np.int64(64), height=np.uint16(48), fov=np.float32(40)),
    lambda: rs.Camera(eye=(0, 0, 3), width=np.array(32), height=np.array(24)),
    lambda: rs.shapes.icosphere(np.int64(2), radius=np.float32(1.5)),
    lambda: rs.shapes.uv_sphere(np.int32(6), np.int64(8)),
    lambda: rs.shapes.torus(np.float32(1.0), np.float64(0.3), np.int64(8), np.int8(6)),
    lambda: rs.shapes.plane(np.int64(2), subdivisions=np.uint8(3), center=np.array([0, 0, 1], np.int64)),
    lambda: rs.shapes.cylinder(segments=np.int64(7)),
    lambda: rs.HeightMap.dimples(count=np.int64(4), resolution=np.int32(16), scale=np.float32(0.1)),
    lambda: rs.HeightMap.wrinkles(frequency=np.int64(2), octaves=np.int8(2), seed=np.uint32(5), resolution=8),
    lambda: rs.Mesh(TRI_V, np.array(TRI_F, np.uint8), crease_angle=np.float32(30)),
])
def test_numpy_scalars_and_0d_arrays_are_taken(make):
    make()


def test_0d_arrays_equal_their_scalars():
    np.testing.assert_array_equal(rs.Material(kd=np.array(0.5)).kd, [0.5, 0.5, 0.5])
    assert rs.Material(shininess=np.array(8.0)).shininess == 8.0
    assert rs.Camera(eye=(0, 0, 3), width=np.array(32)).width == 32


@pytest.mark.parametrize("direction, expected", [
    ((1e-200, 1e-200, 0.0), (math.sqrt(0.5), math.sqrt(0.5), 0.0)),
    ((1e308, 1e308, 0.0), (math.sqrt(0.5), math.sqrt(0.5), 0.0)),
    ((-1e308, 0.0, 1e308), (-math.sqrt(0.5), 0.0, math.sqrt(0.5))),
    ((5e-324, 0.0, 0.0), (1.0, 0.0, 0.0)),  # the smallest subnormal
    ((0.0, -1.7976931348623157e308, 0.0), (0.0, -1.0, 0.0)),
    ((1e-300, 2e-300, -2e-300), (1 / 3, 2 / 3, -2 / 3)),
])
def test_extreme_light_directions_stay_directions(direction, expected):
    """(1e308, 1e308, 0) was normalised to zero (the norm overflowed) and the light vanished;
    (1e-200, 1e-200, 0) divided by an underflowed norm."""
    d = rs.DirectionalLight(direction).direction
    np.testing.assert_allclose(d, expected, rtol=1e-15, atol=1e-16)
    assert abs(np.linalg.norm(d) - 1.0) < 4e-16


magnitudes = st.floats(-300, 300).map(lambda e: 10.0 ** e)
unit_ish = st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda t: max(map(abs, t)) > 1e-3)


@given(d=unit_ish, scale=magnitudes)
@FAST
def test_directions_of_any_finite_magnitude(d, scale):
    """Property over magnitudes 1e-300..1e300: the light's direction is the unit vector of d."""
    d = np.array(d)
    got = rs.DirectionalLight(d * scale).direction
    np.testing.assert_allclose(got, d / np.linalg.norm(d), rtol=1e-12, atol=1e-12)


@given(d=unit_ish, e=st.integers(-900, 900))
@FAST
def test_direction_bits_are_those_of_the_plain_formula(d, e):
    """Pre-scaling by powers of two is exact: wherever d / |d| was computable, the same bits."""
    d = np.ldexp(np.array(d), e)
    with np.errstate(all="ignore"):
        plain = d / np.linalg.norm(d)
    nonzero = np.abs(d[d != 0])
    if nonzero.size and 1e-150 < nonzero.min() and nonzero.max() < 1e150:  # where the plain formula is exact
        np.testing.assert_array_equal(rs.DirectionalLight(d).direction, plain)


@given(up=unit_ish.filter(lambda t: abs(t[1]) > 0.1), scale=magnitudes)
@FAST
def test_camera_up_of_any_finite_magnitude(up, scale):
    """Camera(up=1e-200 * u) was refused as parallel to the view (its norm underflowed)."""
    up = np.array(up)
    ref = rs.Camera(eye=(0.2, 0.1, 3.0), up=up)
    cam = rs.Camera(eye=(0.2, 0.1, 3.0), up=up * scale)
    for a, b in zip(cam.basis, ref.basis):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("up", [(0.0, 1e-200, 0.0), (1e-300, 1e-300, 0.0), (0.0, 1e300, 1e299), (0.0, 5e-324, 0.0)])
def test_extreme_camera_up_vectors_render(up):
    cam = rs.Camera(eye=(0.0, 0.0, 3.0), up=up, width=8, height=6)
    ref = rs.Camera(eye=(0.0, 0.0, 3.0), up=validate.pow2_scaled(up), width=8, height=6)  # |up| about 1
    for a, b in zip(cam.basis, ref.basis):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(rs.render(small_scene(camera=cam)).image, rs.render(small_scene(camera=ref)).image)


def test_extreme_light_directions_light_the_scene():
    """The huge direction no longer vanishes: the image equals the unit direction's."""
    mesh = rs.shapes.icosphere(1)
    cam = rs.Camera(eye=(0.0, 0.0, 4.0), width=12, height=10)
    images = [rs.render(rs.Scene([rs.Model(mesh)], lights=[rs.DirectionalLight(d)], camera=cam, ambient=0.0)).image
              for d in ((-1e308, -1e308, -1e308), (-1.0, -1.0, -1.0), (-1e-200, -1e-200, -1e-200))]
    assert images[1].max() > 0.1
    np.testing.assert_allclose(images[0], images[1], rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(images[2], images[1], rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("scale", [1e-200, 1e-100, 1e100, 1e300])
def test_mesh_normals_of_any_length_are_directions(scale):
    n = np.array([[0.0, 0.0, 1.0], [0.0, 0.6, 0.8], [0.6, 0.0, 0.8]])
    got = rs.Mesh(TRI_V, TRI_F, normals=n * scale).prepared.normals
    np.testing.assert_allclose(got, n, rtol=1e-14, atol=1e-15)


# =====================================================================================================
# 7. Unclear errors: memory estimates, wrong types in scene files, out-of-range indices
# =====================================================================================================
@pytest.mark.parametrize("w, h, figure", [(1_000_000, 1_000_000, "47 TB"), (100_000, 100_000, "470 GB"),
                                          (10 ** 10, 1, None), (2 ** 31, 2 ** 31, None)])
def test_a_frame_beyond_memory_is_refused_with_the_figure(w, h, figure):
    """A camera of 10^6 x 10^6 pixels ended in NumPy's MemoryError."""
    scene = small_scene()
    cam = rs.Camera(eye=(0, 0, 3), width=w, height=h)
    assert w * h * FRAME_BYTES_PER_PIXEL > validate.memory_limit()  # beyond any machine this suite runs on
    msg = rf"camera.width x camera.height: {w} x {h} pixels need about "
    msg += re.escape(figure) if figure else r"[0-9.e+]+ [TGM]B"
    with pytest.raises(ValueError, match=msg + r" for a frame; the limit is [0-9.]+ [TGM]B"):
        rs.render(scene, camera=cam)
    assert not scene.has_geometry


def test_the_frame_limit_is_exact(monkeypatch):
    """With the limit set to 10 x 10 frames' worth, 10 x 10 renders and 10 x 11 is refused."""
    assert FRAME_BYTES_PER_PIXEL == 47
    monkeypatch.setattr(validate, "memory_limit", lambda: 100 * FRAME_BYTES_PER_PIXEL)
    rs.render(small_scene(camera=rs.Camera(eye=(0, 0, 3), width=10, height=10)))
    with pytest.raises(ValueError, match=r"10 x 11 pixels need about 5170 bytes for a frame; the limit is 4700 bytes"):
        rs.render(small_scene(camera=rs.Camera(eye=(0, 0, 3), width=10, height=11)))


def test_the_memory_limit_is_half_the_physical_memory():
    total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    assert validate.memory_limit() == total // 2


@pytest.mark.parametrize("make, field", [
    (lambda: rs.shapes.cylinder(segments=10 ** 12), "segments: 1000000000000"),
    (lambda: rs.shapes.uv_sphere(100_000, 100_000), "rings x segments: 100000 x 100000"),
    (lambda: rs.shapes.torus(major_segments=10 ** 6, minor_segments=10 ** 6), "major_segments x minor_segments"),
    (lambda: rs.shapes.plane(subdivisions=10 ** 6), "subdivisions: 1000000 x 1000000"),
    (lambda: rs.HeightMap.dimples(resolution=100_000), "heightmap.resolution: 100000 x 100000 texels"),
    (lambda: rs.HeightMap.wrinkles(resolution=100_000), "heightmap.resolution: 100000 x 100000 texels"),
    (lambda: rs.HeightMap.from_function(lambda u, v: u, resolution=10 ** 6), "heightmap.resolution"),
    (lambda: rs.HeightMap.wrinkles(octaves=40, resolution=8), "heightmap.frequency, heightmap.octaves: 6, 40"),
    (lambda: rs.HeightMap.wrinkles(frequency=10 ** 7, resolution=8), "heightmap.frequency, heightmap.octaves"),
])
def test_shapes_and_height_maps_estimate_before_building(make, field):
    with pytest.raises(ValueError, match=re.escape(field) + r".* need about [0-9.e+]+ [TGM]B for .*; the limit is"):
        make()


def test_icosphere_subdivisions_are_bounded():
    with pytest.raises(ValueError, match=r"subdivisions: expected an integer in 0..9, got 10"):
        rs.shapes.icosphere(10)


@pytest.mark.parametrize("obj, key", [
    ({"shape": "cylinder", "segments": 10 ** 12}, "segments"),
    ({"shape": "uv_sphere", "rings": 10 ** 6, "segments": 10 ** 6}, "rings x segments"),
    ({"shape": "plane", "subdivisions": 10 ** 9}, "subdivisions"),
])
def test_scene_files_asking_for_huge_shapes_are_refused(obj, key):
    with pytest.raises(SceneFileError, match=rf"<scene>: object\[0\].*{key}.* need about"):
        scene_from_dict(scene_dict(obj=obj))


def test_scene_file_huge_height_map_is_refused():
    bump = {"pattern": "dimples", "resolution": 100_000}
    with pytest.raises(SceneFileError, match=r"object\[0\]\.material\.bump.*heightmap.resolution: 100000 x 100000"):
        scene_from_dict(scene_dict(obj={"shape": "plane"}, material={"bump": bump}))


@pytest.mark.parametrize("obj, key, kind", [
    ({"shape": "torus", "major_radius": "1"}, "major_radius", "a number, got str"),
    ({"shape": "torus", "minor_radius": [0.3]}, "minor_radius", "a number, got list"),
    ({"shape": "cylinder", "segments": 6.5}, "segments", "an integer, got float"),
    ({"shape": "cylinder", "radius": "0.5"}, "radius", "a number, got str"),
    ({"shape": "cylinder", "height": {"a": 1}}, "height", "a number, got dict"),
    ({"radius": "1"}, "radius", "a number, got str"),
    ({"subdivisions": "2"}, "subdivisions", "an integer, got str"),
    ({"shape": "uv_sphere", "rings": "8"}, "rings", "an integer, got str"),
    ({"shape": "plane", "size": "2"}, "size", "a number, got str"),
    ({"shape": "plane", "normal": 3}, "normal", "one of +x -x +y -y +z -z, got int"),
    ({"shape": "cube", "size": [1, 2]}, "size", "a number, got list"),
    ({"center": "origin"}, ".center", "numbers, got dtype <U6"),
])
def test_scene_file_wrong_types_name_the_key(obj, key, kind):
    """`major_radius = "1"` failed inside a comparison ('>' not supported between str and float)."""
    with pytest.raises(SceneFileError, match=rf"<scene>: object\[0\].*{re.escape(key)}: expected {re.escape(kind)}"):
        scene_from_dict(scene_dict(obj=obj))


@pytest.mark.parametrize("parts, key", [
    (dict(light={"name": 5}), "light[0].name: expected a string, got int"),
    (dict(material={"name": ["m"]}), "object[0].material.name: expected a string, got an array"),
    (dict(material={"bump": {"image": 5}}), "object[0].material.bump.image: expected a string, got int"),
    (dict(material={"bump": {"pattern": "wrinkles", "seed": -1, "resolution": 8}}), "heightmap.seed: must be >= 0"),
    (dict(material={"bump": {"pattern": "wrinkles", "seed": 1.5, "resolution": 8}}), "heightmap.seed: expected an integer"),
])
def test_scene_file_names_strings_and_seeds_are_checked(parts, key):
    with pytest.raises(SceneFileError, match=re.escape(key)):
        scene_from_dict(scene_dict(**parts))


@pytest.mark.parametrize("faces, match", [
    (np.array([[0, 1, 2 ** 64 - 1]], np.uint64), r"mesh.faces: value 18446744073709551615 is beyond the int64 range"),
    (np.array([[0, 1, 2 ** 63]], np.uint64), r"mesh.faces: value 9223372036854775808 is beyond the int64 range"),
    ([[0, 1, 2 ** 64 - 1]], r"mesh.faces: value 1.844674407370955\d+e\+19 is beyond the int64 range"),  # NumPy: float64
    ([[2 ** 64 - 1, 0, 1]], r"mesh.faces: value 1.844674407370955\d+e\+19 is beyond the int64 range"),
    ([[0, 1, 1e20]], r"mesh.faces: value 1e\+20 is beyond the int64 range"),
    ([[0, 1, -1e20]], r"mesh.faces: value -1e\+20 is beyond the int64 range"),
    ([[0, 1, 2.0 ** 63]], r"mesh.faces: value 9.2233720368547758e\+18 is beyond the int64 range"),
    ([[0, 1, 2 ** 70]], r"mesh.faces: an integer beyond the 64-bit range"),
    ([[0, 1, -2 ** 70]], r"mesh.faces: an integer beyond the 64-bit range"),
])
def test_face_indices_beyond_int64_are_named(faces, match):
    """2**64-1 wrapped to -1 ("negative vertex index") and 1e20 cast to an undefined integer."""
    with pytest.raises(ValueError, match=match):
        rs.Mesh(TRI_V, faces)


def test_large_but_representable_indices_get_the_range_message():
    with pytest.raises(ValueError, match=r"mesh.faces: face 0 indexes vertex 9223372036854775807, but there are only 3"):
        rs.Mesh(TRI_V, np.array([[0, 1, 2 ** 63 - 1]], np.uint64))
    with pytest.raises(ValueError, match=r"face 0 indexes vertex 100000000000000000, but there are only 3"):
        rs.Mesh(TRI_V, [[0, 1, 1e17]])


@pytest.mark.parametrize("make, match", [
    (lambda: rs.HeightMap([[0.0, 1e39], [0.0, 0.0]]), r"heightmap.heights: value 1e\+39 is beyond the float32 range"),
    (lambda: rs.Material(shininess=10 ** 400), r"material.shininess: must be finite, got an integer of 401 digits"),
    (lambda: rs.PointLight((0, 0, 1), intensity=-(10 ** 400)), r"point_light.intensity: must be finite"),
    (lambda: rs.Material(kd=10 ** 400), r"material.kd: must be finite"),
])
def test_values_beyond_float_range_are_named(make, match):
    with pytest.raises(ValueError, match=match):
        make()
