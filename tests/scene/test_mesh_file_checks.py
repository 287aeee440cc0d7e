"""Mesh files refused by name before any work (issue 45): OBJ lines, extensions that lie,
face indices out of range, glTF's top level and required extensions, nested archives.

Each refusal is a ValueError naming the file and, for text formats, the line (glTF: the
JSON path); valid unusual input (relative OBJ indices, an upper-case extension, continued
lines) still loads. The command line's side: tests/apps/test_cli_contract.py.
"""

from __future__ import annotations

import json
import struct
import warnings
import zipfile

import numpy as np
import pytest

import raycast_shade as rs

QUAD = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"  # lines 1-4
PLY_HEAD = ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
            "element face {n}\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n")


def glb(js: dict, binary: bytes = b"") -> bytes:
    """A binary glTF of ``js`` and a BIN chunk."""
    j = json.dumps(js).encode()
    j += b" " * (-len(j) % 4)
    binary += b"\0" * (-len(binary) % 4)
    body = struct.pack("<II", len(j), 0x4E4F534A) + j
    if binary:
        body += struct.pack("<II", len(binary), 0x004E4942) + binary
    return b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body


def triangles_glb(primitives: list, required=None) -> bytes:
    """One mesh whose primitives share three vertices, each with its own uint16 indices."""
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32).tobytes()
    data, views, accessors, prims = bytearray(pos), [], [], []
    views.append({"buffer": 0, "byteOffset": 0, "byteLength": len(pos)})
    accessors.append({"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                      "min": [0, 0, 0], "max": [1, 1, 0]})
    for indices in primitives:
        raw = np.array(indices, np.uint16).tobytes()
        views.append({"buffer": 0, "byteOffset": len(data), "byteLength": len(raw)})
        data += raw + b"\0" * (-len(raw) % 4)
        accessors.append({"bufferView": len(views) - 1, "componentType": 5123, "count": len(indices),
                          "type": "SCALAR"})
        prims.append({"attributes": {"POSITION": 0}, "indices": len(accessors) - 1})
    js = {"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
          "meshes": [{"primitives": prims}], "buffers": [{"byteLength": len(data)}],
          "bufferViews": views, "accessors": accessors}
    if required:
        js["extensionsRequired"] = js["extensionsUsed"] = required
    return glb(js, bytes(data))


def load_all(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return rs.load_models(path)


def refused(path, *fragments):
    """Both loaders refuse ``path`` with a ValueError naming the file and every fragment."""
    for load in (rs.load_models, rs.Mesh.load):
        with pytest.raises(ValueError) as info:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                load(path)
        message = str(info.value)
        assert path.name in message, message
        for fragment in fragments:
            assert fragment in message, message
    return message


# -- OBJ lines -------------------------------------------------------------------------------------

@pytest.mark.parametrize("tail, fragments", [
    ("f 1 2 3\nf 2 4", ["bad.obj:6:", "a face needs at least 3 vertices, got 2", "cut short"]),  # cut in a face line
    ("f 1/1 2/2 3", ["bad.obj:5:", "not written alike"]),  # cut inside a vertex reference
    ("f 0 1 2\n", ["bad.obj:5:", "vertex index 0", "start at 1"]),
    ("f 1 2 9\n", ["bad.obj:5:", "vertex index 9, but the file has 4"]),
    ("f 1 2 -5\n", ["bad.obj:5:", "relative vertex index -5, but only 4 come before it"]),
    ("f 1 2 x\n", ["bad.obj:5:", "'x' is not a vertex index"]),
    ("v 0 1\nf 1 2 3\n", ["bad.obj:5:", "a vertex needs 3 coordinates", "got 2"]),
    ("vt 0 0\nf 1/1 2/1 3/2\n", ["bad.obj:6:", "texture coordinate (vt) index 2, but the file has 1"]),
], ids=["truncated_face", "truncated_reference", "index_0", "out_of_range", "relative_out_of_range",
        "not_an_integer", "truncated_vertex", "vt_out_of_range"])
def test_bad_obj_lines_are_refused_naming_the_file_and_line(tmp_path, tail, fragments):
    (tmp_path / "bad.obj").write_text(QUAD + tail)
    refused(tmp_path / "bad.obj", *fragments)


def test_relative_obj_indices_count_back_from_the_face_not_the_file(tmp_path):
    """-1 is the last vertex written before the face: the second triangle is the second three vertices
    (trimesh alone resolved both faces to the first three)."""
    (tmp_path / "rel.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf -3/-1 -2/-1 -1/-1\n"
                                      "v 5 5 5\nv 6 5 5\nv 5 6 5\nf -3/-1 -2/-1 -1/-1\n")
    for mesh in (load_all(tmp_path / "rel.obj")[0].mesh, rs.Mesh.load(tmp_path / "rel.obj")):
        tris = {tuple(map(tuple, mesh.vertices[f])) for f in mesh.faces}
        assert tris == {((0, 0, 0), (1, 0, 0), (0, 1, 0)), ((5, 5, 5), (6, 5, 5), (5, 6, 5))}


def test_valid_unusual_obj_files_still_load(tmp_path):
    """An upper-case extension, a continued face line, v//vn references without vn lines (the reader
    ignores them), Windows line ends."""
    (tmp_path / "QUAD.OBJ").write_text(QUAD + "f 1 2 3\nf 2 4 3\n")
    (tmp_path / "cont.obj").write_text(QUAD + "f 1 2 \\\n 3\nf 2 4 3\n")
    (tmp_path / "novn.obj").write_text(QUAD + "f 1//1 2//2 3//3\n")
    (tmp_path / "crlf.obj").write_bytes((QUAD + "f 1 2 3\nf 2 4 3\n").replace("\n", "\r\n").encode())
    counts = {name: len(load_all(tmp_path / name)[0].mesh.faces)
              for name in ("QUAD.OBJ", "cont.obj", "novn.obj", "crlf.obj")}
    assert counts == {"QUAD.OBJ": 2, "cont.obj": 2, "novn.obj": 1, "crlf.obj": 2}


def test_a_large_valid_obj_takes_the_fast_check(tmp_path):
    import trimesh

    from raycast_shade.scene.filecheck import _obj_plainly_valid

    trimesh.creation.icosphere(subdivisions=3).export(tmp_path / "ico.obj")
    data = (tmp_path / "ico.obj").read_bytes()
    assert _obj_plainly_valid(data)
    assert not _obj_plainly_valid(data + b"f 1 2 0\n")
    assert len(load_all(tmp_path / "ico.obj")[0].mesh.faces) == 1280


# -- extensions that lie -----------------------------------------------------------------------------

@pytest.mark.parametrize("name, fragments", [
    ("lie.glb", ["not a binary glTF (.glb) file", "does not start with the bytes 'glTF'", "looks like an OBJ file",
                 "rename it lie.obj"]),
    ("lie.stl", ["not an STL file", "looks like an OBJ file"]),
    ("lie.ply", ["not a PLY file", "looks like an OBJ file"]),
    ("lie.txt", ["the extension .txt names no mesh format", "looks like an OBJ file", "rename it lie.obj"]),
    ("lie", ["without an extension", "looks like an OBJ file", "rename it lie.obj"]),
])
def test_an_obj_under_another_name_is_refused_saying_what_it_looks_like(tmp_path, name, fragments):
    (tmp_path / name).write_text(QUAD + "f 1 2 3\n")
    refused(tmp_path / name, *fragments)


def test_a_glb_named_obj_and_a_ply_named_glb_are_refused(tmp_path):
    (tmp_path / "model.obj").write_bytes(triangles_glb([[0, 1, 2]]))
    refused(tmp_path / "model.obj", "not an OBJ file", "binary glTF", "rename it model.glb")
    (tmp_path / "mesh.glb").write_text(PLY_HEAD.format(n=1) + "3 0 1 2\n")
    refused(tmp_path / "mesh.glb", "looks like a PLY file", "rename it mesh.ply")


# -- face indices out of range -------------------------------------------------------------------------

def test_ply_face_indices_out_of_range_name_the_line(tmp_path):
    """Three faces, a reversed pair first: the reversed-duplicate search used to run on the bad index first."""
    (tmp_path / "oor.ply").write_text(PLY_HEAD.format(n=3) + "3 0 1 2\n3 2 1 0\n3 0 1 7\n")
    refused(tmp_path / "oor.ply", "oor.ply:15:", "face 2 indexes vertex 7, but the file has 3 vertices")


def test_gltf_indices_out_of_range_name_the_json_path(tmp_path):
    (tmp_path / "oor.glb").write_bytes(triangles_glb([[0, 1, 2], [0, 2, 1, 0, 1, 5]]))
    refused(tmp_path / "oor.glb", "meshes[0].primitives[1].indices", "entry 5 is vertex 5",
            "POSITION has 3 vertices")


# -- glTF JSON ---------------------------------------------------------------------------------------

def test_a_json_list_named_gltf_is_refused(tmp_path):
    (tmp_path / "list.gltf").write_text("[1, 2, 3]")
    refused(tmp_path / "list.gltf", "a glTF file is a JSON object", "got a JSON list")


@pytest.mark.parametrize("extension", ["EXT_meshopt_compression", "KHR_materials_transmission", "XYZ_unknown"])
def test_a_required_extension_the_loader_lacks_is_refused_by_name(tmp_path, extension):
    (tmp_path / "req.glb").write_bytes(triangles_glb([[0, 1, 2]], required=["KHR_materials_emissive_strength",
                                                                             extension]))
    refused(tmp_path / "req.glb", "extensionsRequired[1]", f"requires {extension}",
            "this loader does not implement")


def test_a_required_extension_the_loader_reads_is_taken(tmp_path):
    (tmp_path / "ok.glb").write_bytes(triangles_glb([[0, 1, 2]], required=["KHR_materials_emissive_strength"]))
    assert len(load_all(tmp_path / "ok.glb")[0].mesh.faces) == 1


# -- archives ------------------------------------------------------------------------------------------

def test_a_zip_inside_a_zip_is_refused_naming_it(tmp_path):
    with zipfile.ZipFile(tmp_path / "inner.zip", "w") as z:
        z.writestr("a.obj", QUAD + "f 1 2 3\n")
    with zipfile.ZipFile(tmp_path / "outer.zip", "w") as z:
        z.write(tmp_path / "inner.zip", "inner.zip")
    refused(tmp_path / "outer.zip", "holds the archive 'inner.zip'", "unpack it")
    assert len(load_all(tmp_path / "inner.zip")[0].mesh.faces) == 1  # one level is read as before
