"""glTF geometry trimesh reads wrong or not at all (issue 44): every primitive mode, KHR_mesh_quantization,
sparse accessors, KHR_draco_mesh_compression, morph targets at their default weights, and the extension
policy. Every file is small and written here; expectations are closed form or the arrays written."""

from __future__ import annotations

import base64
import json
import sys
import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import raycast_shade as rs
from raycast_shade.apps.cli import main
from raycast_shade.scene.gltfgeometry import (GLTF_EXTENSIONS, dequantise, extension_policy_table, fan_faces,
                                              strip_faces)

_CT = {np.dtype("int8"): 5120, np.dtype("uint8"): 5121, np.dtype("int16"): 5122, np.dtype("uint16"): 5123,
       np.dtype("uint32"): 5125, np.dtype("float32"): 5126}
_TYPE = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}


class Gltf:
    """A glTF written here: arrays become accessors (each on a 4-byte aligned bufferView of one data URI)."""

    def __init__(self):
        self.blob, self.views, self.accessors = b"", [], []
        self.js = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}]}

    def view(self, data: bytes) -> int:
        self.views.append({"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)})
        self.blob += data + b"\0" * (-len(data) % 4)
        return len(self.views) - 1

    def add(self, array, dtype="float32", normalized=False, **extra) -> int:
        a = np.asarray(array, dtype)
        a2 = a.reshape(len(a), -1)
        acc = {"bufferView": self.view(a.tobytes()), "componentType": _CT[a.dtype], "count": len(a2),
               "type": _TYPE[a2.shape[1]], **extra}
        if normalized:
            acc["normalized"] = True
        if a.dtype == np.float32 and a2.shape[1] == 3:
            acc["min"], acc["max"] = a2.min(0).tolist(), a2.max(0).tolist()
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def write(self, path, meshes, **top):
        js = dict(self.js, meshes=meshes, accessors=self.accessors, bufferViews=self.views, **top)
        js["buffers"] = [{"uri": "data:application/octet-stream;base64," + base64.b64encode(self.blob).decode(),
                          "byteLength": len(self.blob)}]
        path.write_text(json.dumps(js))
        return path


HEX = np.array([[0, 0, 0]] + [[np.cos(a), np.sin(a), 0] for a in np.arange(6) * np.pi / 3], np.float32)


def _normals_z(mesh):
    v, f = mesh.vertices, mesh.faces
    return np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])[:, 2]


# --- primitive modes ---------------------------------------------------------------------------------------

def test_strip_and_fan_follow_the_specs_formulas():
    idx = np.array([10, 11, 12, 13, 14])
    assert strip_faces(idx).tolist() == [[10, 11, 12], [12, 11, 13], [12, 13, 14]]
    assert fan_faces(idx).tolist() == [[11, 12, 10], [12, 13, 10], [13, 14, 10]]
    assert strip_faces(idx[:2]).shape == fan_faces(idx[:2]).shape == (0, 3)


@settings(max_examples=40, deadline=None)
@given(st.integers(3, 40), st.booleans())
def test_a_zigzag_strip_and_a_convex_fan_face_one_way(n, flip):
    """A strip over two rows (0 at the bottom, 1 above it, 2 right of 0, ...: its first triangle is
    clockwise seen from +z) and a fan around a convex polygon written counter-clockwise: the spec's
    winding keeps every triangle of each facing the way its first one does."""
    i = np.arange(n)
    strip = np.c_[i // 2, i % 2, np.zeros(n)]
    if flip:
        strip[:, 1] = 1 - strip[:, 1]  # starting on the top row: counter-clockwise
    f = strip_faces(i)
    z = np.cross(strip[f[:, 1]] - strip[f[:, 0]], strip[f[:, 2]] - strip[f[:, 0]])[:, 2]
    assert np.all(z > 0) if flip else np.all(z < 0)
    ang = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = np.c_[np.cos(ang), np.sin(ang), np.zeros(n)]
    f = fan_faces(i)
    z = np.cross(ring[f[:, 1]] - ring[f[:, 0]], ring[f[:, 2]] - ring[f[:, 0]])[:, 2]
    assert len(f) == n - 2 and np.all(z > 0)


def _modes_file(tmp_path, modes, name="modes.gltf"):
    g = Gltf()
    pos = g.add(HEX)
    ring = [0, 1, 2, 3, 4, 5, 6, 1]
    idx = {0: list(range(7)), 1: [1, 2, 2, 3], 2: [1, 2, 3], 3: [1, 2, 3], 4: [0, 1, 2, 0, 2, 3],
           5: [2, 3, 1, 4, 6, 5], 6: ring}
    meshes = [{"primitives": [{"attributes": {"POSITION": pos}, "indices": g.add(idx[m], "uint16"), "mode": m}
                              for m in modes]}]
    return g.write(tmp_path / name, meshes)


@pytest.mark.parametrize("mode, faces", [(4, 2), (5, 4), (6, 6)])
def test_triangle_modes_load_facing_the_viewer(tmp_path, mode, faces):
    models = rs.load_models(_modes_file(tmp_path, [mode]))
    mesh = models[0].mesh
    assert len(mesh.faces) == faces and np.all(_normals_z(mesh) > 0)
    if mode > 4:  # the full hexagon: area 3 sqrt(3) / 2
        assert np.isclose(np.abs(_normals_z(mesh)).sum() / 2, 3 * np.sqrt(3) / 2, rtol=1e-6)


def test_a_strip_without_indices_draws_its_vertices_in_order(tmp_path):
    g = Gltf()
    pos = g.add(np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0]]))
    path = g.write(tmp_path / "s.gltf", [{"primitives": [{"attributes": {"POSITION": pos}, "mode": 5}]}])
    mesh = rs.Mesh.load(path)
    assert mesh.faces.tolist() == [[0, 1, 2], [2, 1, 3]] and np.all(_normals_z(mesh) < 0)


def test_points_and_lines_beside_triangles_are_skipped_by_name(tmp_path):
    path = _modes_file(tmp_path, [4, 1, 0, 6])
    with pytest.warns(rs.DroppedOnLoadWarning) as rec:
        models = rs.load_models(path)
    text = " ".join(str(w.message) for w in rec)
    assert "meshes[0].primitives[1]: mode 1 (LINES)" in text and "meshes[0].primitives[2]: mode 0 (POINTS)" in text
    assert sorted(len(m.mesh.faces) for m in models) == [2, 6]


@pytest.mark.parametrize("modes, fragment", [([1], "meshes[0].primitives[0]: mode 1 (LINES)"),
                                             ([0, 2, 3], "meshes[0].primitives[2]: mode 3 (LINE_STRIP)")])
def test_a_file_of_points_and_lines_only_is_refused_alike_everywhere(tmp_path, capsys, modes, fragment):
    path = _modes_file(tmp_path, modes)
    messages = []
    for load in (rs.load_models, rs.Mesh.load):
        with pytest.raises(ValueError) as exc:
            load(path)
        messages.append(str(exc.value))
    assert messages[0] == messages[1] and fragment in messages[0] and "holds no triangles" in messages[0]
    code = main(["render", str(path), "-o", str(tmp_path / "x.png")])
    out, err = capsys.readouterr()
    assert code == 2 and fragment in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "x.png").exists()


# --- KHR_mesh_quantization and sparse accessors --------------------------------------------------------------

def test_dequantise_follows_the_spec():
    assert dequantise(np.array([[-128, -127, 0, 127]], np.int8), True).tolist() == [[-1, -1, 0, 1]]
    assert np.allclose(dequantise(np.array([[0, 255, 51]], np.uint8), True), [[0, 1, 0.2]])
    assert np.allclose(dequantise(np.array([[-32767, 16384]], np.int16), True), [[-1, 16384 / 32767]])
    assert dequantise(np.array([[0, 65535]], np.uint16), True).tolist() == [[0, 1]]
    assert dequantise(np.array([[3, -7]], np.int16), False).tolist() == [[3, -7]]


def test_quantized_attributes_load_as_the_floats_they_stand_for(tmp_path):
    """Positions as normalised shorts under a node scale, normals as normalised bytes, UVs as normalised
    unsigned shorts, a second UV set as unnormalised bytes: the floats a renderer would see."""
    rng = np.random.default_rng(4)
    q = rng.integers(-32767, 32768, (30, 3)).astype(np.int16)
    n = rng.normal(size=(30, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    nq = np.round(n * 127).astype(np.int8)
    uq = rng.integers(0, 65536, (30, 2)).astype(np.uint16)
    g = Gltf()
    attrs = {"POSITION": g.add(q, "int16", True), "NORMAL": g.add(nq, "int8", True),
             "TEXCOORD_0": g.add(uq, "uint16", True)}
    prim = {"attributes": attrs, "indices": g.add(np.arange(30), "uint16"), "material": 0}  # UVs need one
    g.js["nodes"] = [{"mesh": 0, "scale": [2.0, 3.0, 4.0]}]
    path = g.write(tmp_path / "q.gltf", [{"primitives": [prim]}], extensionsUsed=["KHR_mesh_quantization"],
                   extensionsRequired=["KHR_mesh_quantization"], materials=[{"name": "m"}])
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)  # applied: nothing to warn
        (model,) = rs.load_models(path)
    mesh = model.mesh
    assert np.allclose(mesh.vertices, np.maximum(q / 32767, -1) * [2, 3, 4], atol=1e-6)
    want = nq / 127 / [2, 3, 4]  # normals under a scale: the inverse transpose
    assert np.allclose(mesh.normals, want / np.linalg.norm(want, axis=1, keepdims=True), atol=1e-6)
    assert np.allclose(mesh.uvs, np.c_[uq[:, 0] / 65535, 1 - uq[:, 1] / 65535], atol=1e-6)


def test_quantized_tangents_of_a_normal_map_are_the_files(tmp_path):
    """TANGENT as normalised bytes (the spec allows them under KHR_mesh_quantization): read as the file's
    tangents, not replaced by tangents computed from the UVs (which would point along +u: +x here)."""
    import io

    from PIL import Image

    g = Gltf()
    quad = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
    attrs = {"POSITION": g.add(quad), "NORMAL": g.add(np.tile([0, 0, 1], (4, 1))),
             "TEXCOORD_0": g.add([[0, 1], [1, 1], [1, 0], [0, 0]]),
             "TANGENT": g.add(np.tile([0, 127, 0, 127], (4, 1)), "int8", True)}
    png = io.BytesIO()
    Image.fromarray(np.full((2, 2, 3), (128, 128, 255), np.uint8)).save(png, format="PNG")  # flat
    prim = {"attributes": attrs, "indices": g.add([0, 1, 2, 0, 2, 3], "uint16"), "material": 0}
    path = g.write(tmp_path / "t.gltf", [{"primitives": [prim]}], materials=[{"normalTexture": {"index": 0}}],
                   textures=[{"source": 0}],
                   images=[{"uri": "data:image/png;base64," + base64.b64encode(png.getvalue()).decode()}],
                   extensionsUsed=["KHR_mesh_quantization"], extensionsRequired=["KHR_mesh_quantization"])
    (model,) = rs.load_models(path)
    assert model.mesh.tangents is not None and np.allclose(model.mesh.tangents, [0, 1, 0, 1])


def test_a_sparse_accessor_overrides_its_rows(tmp_path):
    g = Gltf()
    base = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], np.float32)
    pos = g.add(base)
    rows, values = np.array([3], np.uint16), np.array([[1, 1, 2]], np.float32)
    g.accessors[pos]["sparse"] = {"count": 1, "indices": {"bufferView": g.view(rows.tobytes()), "componentType": 5123},
                                  "values": {"bufferView": g.view(values.tobytes())}}
    path = g.write(tmp_path / "sp.gltf", [{"primitives": [{"attributes": {"POSITION": pos},
                                                           "indices": g.add([0, 1, 2, 2, 1, 3], "uint16")}]}])
    assert rs.Mesh.load(path).vertices.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 2]]


# --- KHR_draco_mesh_compression ---------------------------------------------------------------------------------

def _draco_file(tmp_path, vertices, faces):
    import DracoPy  # the draco extra is in the test extra

    blob = DracoPy.encode(vertices, faces, quantization_bits=16)
    ids = {a["attribute_type"]: a["unique_id"] for a in DracoPy.decode(blob).attributes}
    g = Gltf()
    view = g.view(blob)
    pos = len(g.accessors)
    g.accessors += [{"componentType": 5126, "count": len(vertices), "type": "VEC3",
                     "min": vertices.min(0).tolist(), "max": vertices.max(0).tolist()},
                    {"componentType": 5125, "count": faces.size, "type": "SCALAR"}]
    prim = {"attributes": {"POSITION": pos}, "indices": pos + 1,
            "extensions": {"KHR_draco_mesh_compression": {"bufferView": view, "attributes": {"POSITION": ids[0]}}}}
    return g.write(tmp_path / "draco.gltf", [{"primitives": [prim]}],
                   extensionsUsed=["KHR_draco_mesh_compression"], extensionsRequired=["KHR_draco_mesh_compression"])


def _triangles(mesh_vertices, faces):
    return sorted(tuple(sorted(map(tuple, np.round(mesh_vertices[f], 3).tolist()))) for f in faces)


def test_a_draco_mesh_loads_as_the_mesh_encoded(tmp_path):
    rng = np.random.default_rng(1)
    v = rng.uniform(-1, 1, (40, 3))
    f = np.array([[i, (i + 1) % 40, (i + 7) % 40] for i in range(40)], np.uint32)
    path = _draco_file(tmp_path, v, f)
    for mesh in (rs.Mesh.load(path), rs.load_models(path)[0].mesh):
        assert len(mesh.faces) == 40  # Draco gives each corner a vertex of its own
        assert np.abs(mesh.vertices).max() > 0.5  # never the all-zero placeholder
        assert _triangles(mesh.vertices, mesh.faces) == _triangles(v, f)  # 16 bits over [-1, 1]: 3e-5 steps


def test_a_draco_mesh_without_dracopy_is_refused_with_the_install_hint(tmp_path, monkeypatch, capsys):
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float64)
    path = _draco_file(tmp_path, v, np.array([[0, 1, 2]], np.uint32))
    monkeypatch.setitem(sys.modules, "DracoPy", None)  # import DracoPy now raises ImportError
    messages = []
    for load in (rs.load_models, rs.Mesh.load):
        with pytest.raises(ValueError) as exc:
            load(path)
        messages.append(str(exc.value))
    assert messages[0] == messages[1]
    assert "meshes[0].primitives[0] is Draco-compressed" in messages[0] and "raycast_shade[draco]" in messages[0]
    code = main(["render", str(path), "-o", str(tmp_path / "x.png")])
    _, err = capsys.readouterr()
    assert code == 2 and len(err.strip().splitlines()) == 1 and not (tmp_path / "x.png").exists()


# --- morph targets -------------------------------------------------------------------------------------------

def _morph_file(tmp_path, mesh_weights=None, node_weights=None, nodes=None, normals=True):
    """A unit-wide triangle 0.5 tall (apex at y = 0.5); target 0 lifts the apex by 1, target 1 by 2 and
    tilts its normal towards +x."""
    g = Gltf()
    attrs = {"POSITION": g.add([[0, 0, 0], [1, 0, 0], [0.5, 0.5, 0]])}
    t0 = {"POSITION": g.add([[0, 0, 0], [0, 0, 0], [0, 1, 0]])}
    t1 = {"POSITION": g.add([[0, 0, 0], [0, 0, 0], [0, 2, 0]])}
    if normals:
        attrs["NORMAL"] = g.add(np.tile([0, 0, 1], (3, 1)))
        t1["NORMAL"] = g.add([[0, 0, 0], [0, 0, 0], [1, 0, 0]])
    mesh = {"primitives": [{"attributes": attrs, "targets": [t0, t1]}]}
    if mesh_weights is not None:
        mesh["weights"] = mesh_weights
    g.js["nodes"] = nodes or [{"mesh": 0, **({"weights": node_weights} if node_weights is not None else {})}]
    g.js["scenes"] = [{"nodes": list(range(len(g.js["nodes"])))}]
    return g.write(tmp_path / "morph.gltf", [mesh])


@pytest.mark.parametrize("mesh_weights, node_weights, height", [(None, None, 0.5), ([1.0, 0.0], None, 1.5),
                                                                 ([1.0, 0.25], None, 2.0), ([1.0, 0.0], [0.0, 0.5], 1.5),
                                                                 ([0.0, 0.0], [-0.1, 0.0], 0.4)])
def test_morph_targets_stand_at_their_default_weights(tmp_path, mesh_weights, node_weights, height):
    path = _morph_file(tmp_path, mesh_weights, node_weights)
    for mesh in (rs.Mesh.load(path), rs.load_models(path)[0].mesh):
        assert np.isclose(np.ptp(mesh.vertices[:, 1]), height, atol=1e-6)


def test_morphed_normals_are_renormalised_and_computed_where_the_file_has_none(tmp_path):
    mesh = rs.Mesh.load(_morph_file(tmp_path, [0.0, 0.75]))
    assert np.allclose(mesh.normals[2], np.array([0.75, 0, 1]) / 1.25) and np.allclose(mesh.normals[0], [0, 0, 1])
    bare = rs.Mesh.load(_morph_file(tmp_path, [1.0, 0.0], normals=False))
    assert bare.normals is None and np.isclose(bare.vertices[2, 1], 1.5)  # computed from the morphed shape


def test_a_mesh_drawn_by_two_nodes_at_other_weights_stands_at_both(tmp_path):
    nodes = [{"mesh": 0, "weights": [1.0, 0.0]}, {"mesh": 0, "translation": [5, 0, 0]}]
    path = _morph_file(tmp_path, [0.0, 0.0], nodes=nodes)
    heights = sorted(round(float(np.ptp(m.mesh.vertices[:, 1])), 6) for m in rs.load_models(path))
    assert heights == [0.5, 1.5]


@pytest.mark.parametrize("weights", [[1.0], [1.0, True], [1.0, float("nan")], "1 0"])
def test_morph_weights_that_are_not_one_number_per_target_are_refused_by_field(tmp_path, weights):
    with pytest.raises(ValueError, match=r"morph\.gltf: nodes\[0\]\.weights: expected 2 finite numbers"):
        rs.Mesh.load(_morph_file(tmp_path, None, weights))


# --- extension policy -------------------------------------------------------------------------------------------

def test_an_optional_extension_not_applied_is_warned_by_name(tmp_path):
    path = _modes_file(tmp_path, [4])
    js = json.loads(path.read_text())
    js["extensionsUsed"] = ["KHR_materials_clearcoat", "KHR_materials_sheen", "EXT_made_up"]
    path.write_text(json.dumps(js))
    for load in (rs.load_models, rs.Mesh.load):
        with pytest.warns(rs.DroppedOnLoadWarning) as rec:
            load(path)
        text = " ".join(str(w.message) for w in rec)
        assert all(e in text for e in ("KHR_materials_clearcoat", "KHR_materials_sheen", "EXT_made_up"))


def test_a_required_extension_not_applied_is_refused(tmp_path):
    path = _modes_file(tmp_path, [4])
    js = json.loads(path.read_text())
    js["extensionsUsed"] = js["extensionsRequired"] = ["KHR_materials_transmission"]
    path.write_text(json.dumps(js))
    with pytest.raises(ValueError, match="extensionsRequired\\[0\\]: the file requires KHR_materials_transmission"):
        rs.load_models(path)


def test_inspect_shows_the_extensions(tmp_path, capsys):
    path = _modes_file(tmp_path, [4])
    js = json.loads(path.read_text())
    js["extensionsUsed"] = ["KHR_mesh_quantization", "KHR_materials_clearcoat"]
    js["extensionsRequired"] = ["KHR_mesh_quantization"]
    path.write_text(json.dumps(js))
    assert main(["inspect", str(path)]) == 0
    out = capsys.readouterr().out
    assert "extensionsUsed: KHR_mesh_quantization (applied), KHR_materials_clearcoat (not applied)" in out
    assert "extensionsRequired: KHR_mesh_quantization" in out


def test_the_docs_table_is_the_codes_own():
    from pathlib import Path

    text = (Path(__file__).parents[2] / "docs" / "files.md").read_text()
    begin, end = "<!-- gltf-extensions:begin -->", "<!-- gltf-extensions:end -->"
    assert text.split(begin, 1)[1].split(end, 1)[0].strip() == extension_policy_table(), (
        "regenerate: python -c 'from raycast_shade.scene.gltfgeometry import extension_policy_table as t; print(t())'")
    assert all(f"`{name}`" in text for name in GLTF_EXTENSIONS)


def test_a_draco_primitive_missing_an_attribute_is_refused_by_name(tmp_path):
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float64)
    path = _draco_file(tmp_path, v, np.array([[0, 1, 2]], np.uint32))
    js = json.loads(path.read_text())
    js["accessors"].append({"componentType": 5126, "count": 3, "type": "VEC3"})  # in neither buffer
    js["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = len(js["accessors"]) - 1
    path.write_text(json.dumps(js))
    with pytest.raises(ValueError, match=r"meshes\[0\]\.primitives\[0\]\.attributes\.NORMAL: no data"):
        rs.Mesh.load(path)
