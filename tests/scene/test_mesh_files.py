"""Meshes from files: every format the issue names, the file's own normals, and scenes."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh

import raycast_shade as rs
from raycast_shade.scene.normals import face_normals
from raycast_shade.scene.scenefile import load_scene
from raycast_shade.scene.texture import srgb_to_linear


def _triangles(vertices, faces):
    """Each face as a sorted tuple of rounded corner positions: independent of vertex order."""
    corners = np.round(np.asarray(vertices)[np.asarray(faces)], 5)
    return sorted(tuple(sorted(map(tuple, tri))) for tri in corners)


@pytest.mark.parametrize("ext", ["obj", "ply", "stl", "off", "glb"])
def test_every_named_format_loads_the_same_triangles(tmp_path, ext):
    src = trimesh.creation.icosphere(subdivisions=2)
    path = tmp_path / f"ico.{ext}"
    src.export(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # e.g. trimesh's deprecated Scene.dump(concatenate=True)
        mesh = rs.Mesh.load(path)
    assert mesh.name == f"ico.{ext}"
    assert len(mesh.faces) == len(src.faces) == 320
    assert len(mesh.vertices) == 162  # STL stores a triangle soup: trimesh welds it on load
    assert _triangles(mesh.vertices, mesh.faces) == _triangles(src.vertices, src.faces)
    # Wound as in the source: every face normal points out of the sphere.
    fn, _ = face_normals(mesh.vertices, mesh.faces)
    centres = mesh.vertices[mesh.faces].mean(axis=1)
    assert (np.einsum("ij,ij->i", fn, centres) > 0).all()


# A square made of two triangles, with normals the faces do not have (tilted towards +x).
SQUARE_OBJ = """\
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vn 0.6 0 0.8
vn 0.6 0 0.8
vn 0.6 0 0.8
vn 0.6 0 0.8
f 1//1 2//2 3//3
f 1//1 3//3 4//4
"""


def test_normals_stored_in_an_obj_are_kept(tmp_path):
    (tmp_path / "sq.obj").write_text(SQUARE_OBJ)
    mesh = rs.Mesh.load(tmp_path / "sq.obj")
    assert mesh.normals is not None
    np.testing.assert_allclose(mesh.normals, np.tile([0.6, 0.0, 0.8], (4, 1)), atol=1e-12)
    np.testing.assert_allclose(mesh.prepared.normals, mesh.normals, atol=1e-12)  # not recomputed to +z
    assert rs.Mesh.load(tmp_path / "sq.obj", use_normals=False).normals is None
    bare = SQUARE_OBJ.replace("//1", "").replace("//2", "").replace("//3", "").replace("//4", "")
    (tmp_path / "bare.obj").write_text("\n".join(line for line in bare.splitlines() if not line.startswith("vn")))
    assert rs.Mesh.load(tmp_path / "bare.obj").normals is None
    forced = rs.Mesh.load(tmp_path / "bare.obj", use_normals=True)  # trimesh's own average
    np.testing.assert_allclose(forced.normals, np.tile([0.0, 0.0, 1.0], (4, 1)), atol=1e-12)


@pytest.mark.parametrize("ext", ["ply", "glb"])
def test_normals_stored_in_ply_and_gltf_are_kept(tmp_path, ext):
    src = trimesh.creation.icosphere(subdivisions=1)
    rng = np.random.default_rng(0)
    custom = src.vertices + 0.3 * rng.normal(size=src.vertices.shape)  # not what any average gives
    custom /= np.linalg.norm(custom, axis=1, keepdims=True)
    src.vertex_normals = custom
    path = tmp_path / f"n.{ext}"
    src.export(path, include_normals=True) if ext == "glb" else src.export(path, vertex_normal=True)
    mesh = rs.Mesh.load(path)
    assert mesh.normals is not None
    # Match vertices by position (a format may reorder them), then compare the normals.
    order = np.lexsort(np.round(mesh.vertices, 5).T)
    ref = np.lexsort(np.round(src.vertices, 5).T)
    np.testing.assert_allclose(mesh.vertices[order], src.vertices[ref], atol=1e-6)
    np.testing.assert_allclose(mesh.normals[order], custom[ref], atol=1e-6)


def test_a_scene_file_is_flattened_with_its_transforms(tmp_path):
    """Two instances of one sphere: one moved, one mirrored in x. Vertices follow
    the node transforms, normals the inverse transpose, and the mirrored faces
    are turned over so that they still face out."""
    ball = trimesh.creation.icosphere(subdivisions=1)
    ball.vertex_normals = ball.vertices / np.linalg.norm(ball.vertices, axis=1, keepdims=True)
    scene = trimesh.Scene()
    move = trimesh.transformations.translation_matrix([3.0, 0.0, 0.0])
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0]) @ trimesh.transformations.translation_matrix([3.0, 0.0, 0.0])
    scene.add_geometry(ball, node_name="moved", geom_name="ball", transform=move)
    scene.add_geometry(ball, node_name="mirrored", geom_name="ball", transform=mirror)
    path = tmp_path / "two.glb"
    scene.export(path, include_normals=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mesh = rs.Mesh.load(path)
    assert len(mesh.faces) == 2 * len(ball.faces)
    centres_x = sorted(np.round([mesh.vertices[mesh.faces[:80]].mean(axis=(0, 1))[0],
                                 mesh.vertices[mesh.faces[80:]].mean(axis=(0, 1))[0]], 6))
    assert centres_x == [-3.0, 3.0]
    # Exact sphere normals: unit, radial about each instance's centre.
    assert mesh.normals is not None
    centre = np.where(mesh.vertices[:, :1] > 0, [3.0, 0.0, 0.0], [-3.0, 0.0, 0.0])
    radial = mesh.vertices - centre
    np.testing.assert_allclose(mesh.normals, radial / np.linalg.norm(radial, axis=1, keepdims=True), atol=1e-6)
    # Faces wound outwards in both instances, and consistently.
    fn, _ = face_normals(mesh.vertices, mesh.faces)
    out = mesh.vertices[mesh.faces].mean(axis=1) - centre[mesh.faces[:, 0]]
    assert (np.einsum("ij,ij->i", fn, out) > 0).all()
    assert rs.winding_conflicts(mesh.vertices, mesh.faces) == 0


def test_a_file_without_triangles_is_refused(tmp_path):
    (tmp_path / "points.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(ValueError, match="holds no triangles"):
        rs.Mesh.load(tmp_path / "points.obj")
    (tmp_path / "junk.ply").write_bytes(b"this is not a ply file")
    with pytest.raises(ValueError, match="junk.ply"):
        rs.Mesh.load(tmp_path / "junk.ply")
    with pytest.raises(TypeError, match="trimesh.Trimesh or trimesh.Scene"):
        rs.Mesh.from_trimesh(np.zeros((3, 3)))


# -- vertices as written, colours and materials (issue 13) ---------------------------------------

def _cube_obj(tmp_path, mtl=""):
    """A unit cube whose six faces each have four vertices of their own (24 `v` lines)."""
    cube = trimesh.creation.box()
    lines = [mtl] if mtl else []
    faces = []
    for k, (axis, sign) in enumerate([(a, s) for a in range(3) for s in (-1, 1)]):
        corners = [c for c in np.array(np.meshgrid([-.5, .5], [-.5, .5], [-.5, .5])).reshape(3, -1).T
                   if c[axis] == sign * 0.5]
        centre = np.mean(corners, axis=0)
        a = np.eye(3)[(axis + 1) % 3]
        corners.sort(key=lambda c: np.arctan2(np.dot(np.cross(a, c - centre), np.eye(3)[axis] * sign),
                                              np.dot(a, c - centre)))
        lines += [f"v {c[0]} {c[1]} {c[2]}" for c in corners]
        faces.append(f"f {4 * k + 1} {4 * k + 2} {4 * k + 3} {4 * k + 4}")
    del cube
    path = tmp_path / "cube.obj"
    path.write_text("\n".join(lines + faces) + "\n")
    return path


def test_split_vertices_are_kept_as_written(tmp_path):
    """Today's bug: trimesh's default processing welded the 24 vertices into 8, and the
    averaged normals rounded the cube off. Kept as written, every face is flat."""
    path = _cube_obj(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rs.CreaseWarning)
        mesh = rs.Mesh.load(path)
        assert len(mesh.vertices) == 24 and len(mesh.faces) == 12
        prep = mesh.prepared
        fn, _ = face_normals(prep.vertices, prep.faces)
        for k in range(3):
            np.testing.assert_allclose(prep.normals[prep.faces[:, k]], fn, atol=1e-12)  # hard edges
        assert len(rs.Mesh.load(path, merge=True).vertices) == 8


MTL = """\
newmtl red
Kd 0.8 0.1 0.1
Ka 0.5 0.5 0.5
Ks 0.25 0.25 0.25
Ns 50
d 0.5
illum 2
newmtl wood
Kd 1 1 1
Ks 0 0 0
map_Kd wood.png
map_Bump bump.png
"""


def test_obj_mtl_materials_and_textures(tmp_path):
    """Two materials: two models. Kd, Ka, Ks, Ns exact (not trimesh's 8-bit copies), map_Kd
    decoded from sRGB; 'd 0.5' and 'map_Bump' have no counterpart and are named."""
    import imageio.v3 as iio

    img = np.random.default_rng(0).integers(0, 256, (4, 6, 3), dtype=np.uint8)
    iio.imwrite(tmp_path / "wood.png", img)
    (tmp_path / "two.mtl").write_text(MTL)
    (tmp_path / "two.obj").write_text(
        "mtllib two.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 3 0 0\nv 3 1 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nusemtl red\nf 1 2 3\nf 1 3 4\nusemtl wood\nf 5/1 6/2 7/3\n")
    with pytest.warns(rs.DroppedOnLoadWarning) as record:
        models = rs.load_models(tmp_path / "two.obj")
    message = " ".join(str(w.message) for w in record)
    assert "d 0.5" in message and "map_bump bump.png" in message
    by_name = {m.material.name: m for m in models}
    assert set(by_name) == {"red", "wood"}
    red = by_name["red"].material
    np.testing.assert_array_equal(red.kd, [0.8, 0.1, 0.1])
    np.testing.assert_array_equal(red.ka, [0.5, 0.5, 0.5])
    np.testing.assert_array_equal(red.ks, [0.25, 0.25, 0.25])
    assert red.shininess == 50 and red.kd_map is None
    wood = by_name["wood"]
    assert wood.material.kd_map is not None and wood.mesh.uvs is not None
    np.testing.assert_allclose(wood.material.kd_map.texels, srgb_to_linear(img[::-1] / 255),
                               rtol=1e-6)
    assert wood.material.kd_map.decoded_from_srgb  # colours: refused where data is meant
    assert len(by_name["red"].mesh.vertices) == 4
    # Mesh.load keeps the geometry and names what it drops.
    with pytest.warns(rs.DroppedOnLoadWarning, match=r"material\(s\) .*red.*load_models"):
        rs.Mesh.load(tmp_path / "two.obj")
    # Renders with both materials.
    scene = rs.Scene(models, lights=[rs.DirectionalLight((0, 0, -1))],
                     camera=rs.Camera(eye=(1.5, 0.5, 3), width=32, height=16))
    assert rs.render(scene).image.max() > 0


def test_gltf_base_colour_texture_vertex_colours_and_pbr_mapping(tmp_path):
    """kd = baseColor ((1 - m) + m alpha), ks = 0.04 (1 - m) + baseColor m (1 - alpha), ka = baseColor,
    Blinn t = 2/alpha^2 - 2 with alpha = roughness^2; COLOR_0 (linear in glTF, so not sRGB-decoded) becomes the vertex
    colours times kd's factor; the texture is decoded from sRGB; the emission becomes ke."""
    from PIL import Image

    box = trimesh.creation.box()
    rng = np.random.default_rng(2)
    img = rng.integers(0, 256, (4, 4, 3), dtype=np.uint8)
    mat = trimesh.visual.material.PBRMaterial(baseColorFactor=[255, 128, 51, 255], baseColorTexture=Image.fromarray(img),
                                              metallicFactor=0.25, roughnessFactor=0.5, emissiveFactor=[0.1, 0, 0])
    colours = rng.integers(0, 256, (len(box.vertices), 4), dtype=np.uint8)
    colours[:, 3] = 255
    box.visual = trimesh.visual.TextureVisuals(uv=rng.random((len(box.vertices), 2)), material=mat)
    box.visual.vertex_attributes["color"] = colours
    box.export(tmp_path / "box.glb")
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)  # emission is mapped now, not dropped
        (model,) = rs.load_models(tmp_path / "box.glb")
    m = model.material
    np.testing.assert_allclose(m.ke, [0.1, 0.0, 0.0])
    base = np.array([255, 128, 51]) / 255
    alpha = 0.5 ** 2
    np.testing.assert_allclose(m.kd, base * (0.75 + 0.25 * alpha))
    np.testing.assert_allclose(m.ks, 0.04 * 0.75 + base * 0.25 * (1 - alpha))
    # COLOR_0 makes the ambient follow the colours (ka_colors): the point's ka is ka x colour, the colour
    # being COLOR_0 x kd's factor, so ka = 1 / that factor gives an ambient of base colour x COLOR_0.
    assert m.ka_colors
    np.testing.assert_allclose(m.ka, 1.0 / (0.75 + 0.25 * alpha))
    assert m.specular == "blinn" and m.shininess == pytest.approx(2 / 0.25 ** 2 - 2)
    np.testing.assert_allclose(m.kd_map.texels, srgb_to_linear(img[::-1] / 255), rtol=1e-6)
    assert m.ks_map is m.kd_map  # the metallic part of ks is the base colour
    mesh = model.mesh
    assert mesh.color_mode == "vertex" and mesh.uvs is not None
    order = [int(np.flatnonzero(np.all(np.isclose(box.vertices, v), axis=1))[0]) for v in mesh.vertices]
    np.testing.assert_allclose(mesh.colors, colours[order, :3] / 255 * m.kd, rtol=1e-6)


@pytest.mark.parametrize("kind", ["vertex", "face"])
def test_ply_colours_are_decoded_from_srgb(tmp_path, kind):
    box = trimesh.creation.box()
    n = len(box.vertices) if kind == "vertex" else len(box.faces)
    colours = np.random.default_rng(4).integers(0, 256, (n, 4), dtype=np.uint8)
    colours[:, 3] = 255
    if kind == "vertex":
        box.visual.vertex_colors = colours
    else:
        box.visual.face_colors = colours
    box.export(tmp_path / "c.ply")
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        mesh = rs.Mesh.load(tmp_path / "c.ply")
        (model,) = rs.load_models(tmp_path / "c.ply")
    assert mesh.color_mode == kind == model.mesh.color_mode
    np.testing.assert_allclose(mesh.colors, srgb_to_linear(colours[:, :3] / 255), rtol=1e-12)
    assert len(mesh.vertices) == 8  # as written


def test_a_scene_file_takes_the_file_materials_and_overrides_them(tmp_path):
    (tmp_path / "two.mtl").write_text("newmtl red\nKd 0.8 0.1 0.1\nKs 0.5 0.5 0.5\nNs 20\n")
    (tmp_path / "two.obj").write_text("mtllib two.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl red\nf 1 2 3\n")
    base = '[camera]\neye = [0.5, 0.5, 3]\ntarget = [0.5, 0.5, 0]\n[[object]]\nmesh = "two.obj"\n'
    (tmp_path / "a.toml").write_text(base)
    scene, _ = load_scene(tmp_path / "a.toml")
    m = scene.models[0].material
    np.testing.assert_array_equal(m.kd, [0.8, 0.1, 0.1])
    assert m.shininess == 20 and m.ks.tolist() == [0.5] * 3
    (tmp_path / "b.toml").write_text(base + "[object.material]\nkd = 0.3\n")
    scene, _ = load_scene(tmp_path / "b.toml")
    m = scene.models[0].material
    assert m.kd.tolist() == [0.3] * 3 and m.shininess == 20 and m.ks.tolist() == [0.5] * 3
    (tmp_path / "c.toml").write_text(base + 'materials = "none"\n')
    with pytest.warns(rs.DroppedOnLoadWarning, match="red"):
        scene, _ = load_scene(tmp_path / "c.toml")
    assert scene.models[0].material.kd.tolist() == [0.8] * 3


def test_a_duplicate_vertex_in_a_ply_is_kept_unless_merging_is_asked(tmp_path):
    box = trimesh.creation.box()
    v = np.vstack([box.vertices, box.vertices[:1]])
    f = box.faces.copy()
    f[0, 0] = len(v) - 1  # one face uses the duplicate
    trimesh.Trimesh(v, f, process=False).export(tmp_path / "d.ply")
    assert len(rs.Mesh.load(tmp_path / "d.ply").vertices) == 9
    assert len(rs.Mesh.load(tmp_path / "d.ply", merge=True).vertices) == 8


@pytest.mark.parametrize("value", ["no", "false", 0, 1, [False]])
@pytest.mark.parametrize("call, name", [
    (lambda p, tm, v: rs.load_models(p, merge=v), "merge"),
    (lambda p, tm, v: rs.load_models(p, use_normals=v), "use_normals"),
    (lambda p, tm, v: rs.Mesh.load(p, merge=v), "merge"),
    (lambda p, tm, v: rs.Mesh.load(p, use_normals=v), "use_normals"),
    (lambda p, tm, v: rs.Mesh.from_trimesh(tm, use_normals=v), "use_normals"),
    (lambda p, tm, v: rs.Mesh.from_trimesh(tm, srgb_colors=v), "srgb_colors"),
])
def test_flags_of_the_loaders_must_be_bools_not_truthy_values(tmp_path, monkeypatch, call, name, value):
    path = tmp_path / "d.ply"
    trimesh.creation.box().export(path)
    tm = trimesh.load(path, process=False)
    real, reads = trimesh.load, []
    monkeypatch.setattr(trimesh, "load", lambda *a, **k: reads.append(a) or real(*a, **k))
    with pytest.raises(TypeError, match=f"{name}: expected True or False, got {type(value).__name__}"):
        call(path, tm, value)
    assert reads == []  # refused before the file is read
    flag = None if name == "use_normals" else np.False_  # None: the file decides; NumPy's bool is a bool
    out = call(path, tm, flag)
    assert len(out[0].mesh.faces if isinstance(out, list) else out.faces) == 12
