"""Mesh files refused by name before any reader runs on them (issue 45).

trimesh reads what it is given as best it can: an OBJ face cut short is
skipped, an index 0 becomes the last vertex, a file whose extension lies
gets the reader of its extension, a required glTF extension no one decodes
is passed over. Each of these would render something other than the file,
without a word. The checks here run where the file is read, before trimesh
(and before any kernel or output file), and name the file and the line
(text formats) or the JSON path (glTF):

* :func:`check_mesh_file`: the content against the extension (the first
  bytes only), archives inside archives, glTF's top level and
  ``extensionsRequired``;
* :func:`check_obj`: every ``v`` and ``f`` line of an OBJ;
* :func:`check_face_indices`: every face index of what trimesh read against
  its vertex count, placed in the file (PLY line, glTF accessor) when one is
  out of range.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import struct
import warnings
import zipfile

import numpy as np

from .gltfgeometry import APPLIED_GLTF_EXTENSIONS

__all__ = ["check_mesh_file", "check_obj", "check_face_indices", "naming_file", "SUPPORTED_GLTF_EXTENSIONS"]

# Extensions whose data the loader reads (trimesh or raycast_shade itself): a file may require these. The
# policy for every other one (warned when used, refused when required) is gltfgeometry.GLTF_EXTENSIONS.
SUPPORTED_GLTF_EXTENSIONS = APPLIED_GLTF_EXTENSIONS
_ARCHIVES = (".zip", ".tar", ".tar.gz", ".tgz", ".tar.bz2", ".tbz2", ".tar.xz", ".txz", ".7z", ".rar", ".gz", ".bz2")
_LABELS = {"obj": "an OBJ file", "ply": "a PLY file", "off": "an OFF file", "stl": "an STL file",
           "glb": "a binary glTF (.glb) file", "gltf": "a glTF JSON (.gltf) file", "zip": "a zip archive"}
_HEAD = 4096  # bytes read to tell formats apart


def _sniff(head: bytes, size: int):
    """The format the first bytes of a file show (a key of ``_LABELS``), or None."""
    if head[:4] == b"glTF":
        return "glb"
    if head[:4] == b"PK\x03\x04":
        return "zip"
    text = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    if text[:3] == b"ply" and text[3:4] in (b"\n", b"\r"):
        return "ply"
    if text[:1] == b"{":
        return "gltf"
    first = text.split(None, 1)[0] if text.split() else b""
    if first.endswith(b"OFF") and len(first) <= 6:  # OFF, COFF, NOFF, STOFF, 4OFF, ...
        return "off"
    if text[:5].lower() == b"solid" or (size >= 84 and size == 84 + 50 * struct.unpack("<I", head[80:84])[0]):
        return "stl"
    keys = {line.split(None, 1)[0] for line in text.splitlines() if line.strip()}
    if keys & {b"v", b"vn", b"vt", b"f", b"mtllib", b"usemtl"}:
        return "obj"
    return None


def _looks(kind) -> str:
    return f"its content looks like {_LABELS[kind]}" if kind else "its content is not a mesh format recognised here"


def _renamed(name: str, kind) -> str:
    return f": rename it {os.path.splitext(name)[0]}.{kind}" if kind in ("obj", "ply", "off", "stl", "glb", "gltf") else ""


def check_mesh_file(path: str):
    """Refuse a mesh file whose content is not what its extension says, before any reader runs.

    Only the first bytes are read (for glTF, its JSON). The extension is
    matched in any case (``.OBJ`` is an OBJ).

    Parameters
    ----------
    path : str

    Returns
    -------
    dict or None
        The glTF JSON of a ``.gltf``/``.glb`` file (read once, for the loader's own use); None for other formats.

    Raises
    ------
    ValueError
        Naming the file: missing, a folder, empty, an extension no reader
        takes or one its content belies (with what the content looks like),
        an archive inside a zip archive, a glTF whose top level is not a JSON
        object or that requires an extension the loader does not implement.
    """
    name = os.path.basename(path)
    if not os.path.exists(path):
        raise ValueError(f"mesh file not found: {path}")
    if os.path.isdir(path):
        raise ValueError(f"{path}: a folder, not a mesh file")
    size = os.path.getsize(path)
    with open(path, "rb") as fh:
        head = fh.read(_HEAD)
    if not head:
        raise ValueError(f"{name}: the file is empty")
    kind = _sniff(head, size)
    lower = name.lower()
    ext = os.path.splitext(lower)[1].lstrip(".")
    known = any(lower.endswith("." + f) for f in _trimesh_formats())
    if not known:
        what = f"the extension .{ext} names" if ext else "without an extension, the name gives"
        raise ValueError(f"{name}: {what} no mesh format read here (.obj, .ply, .stl, .off, .glb, .gltf, "
                         f".zip); {_looks(kind)}{_renamed(name, kind)}")
    expected = ext if ext in ("obj", "ply", "off", "stl", "glb", "gltf", "zip") else None
    # These formats always show their signature (trimesh reads an STL as binary when its length matches the
    # header's count, else as "solid" text); any other content is refused. The strong signatures (glTF magic,
    # PK, "ply", a JSON object, OFF) belie an .obj or .off too; an OBJ guess only fills the message.
    strict = expected in ("glb", "ply", "stl", "zip") and kind != expected
    belied = expected and kind in ("glb", "zip", "ply", "gltf", "off") and kind != expected
    if strict or belied:
        magic = {"glb": "the bytes 'glTF'", "ply": "the line 'ply'", "zip": "the bytes 'PK'",
                 "stl": "'solid' and is not a binary STL of its length"}.get(expected)
        start = f" (it does not start with {magic})" if magic and strict else ""
        raise ValueError(f"{name}: not {_LABELS[expected]}{start}; {_looks(kind)}{_renamed(name, kind)}")
    if expected == "gltf" and kind != "gltf":
        got = "a JSON list ([...])" if head.lstrip(b"\xef\xbb\xbf \t\r\n")[:1] == b"[" else _looks(kind)
        raise ValueError(f"{name}: a glTF file is a JSON object ({{...}}) at the top level; got {got}")
    if kind == "zip" or (ext == "zip" and zipfile.is_zipfile(path)):
        _check_zip(path, name)
    if expected == "ply":
        from .plycheck import check_ply

        check_ply(path)
    if expected in ("glb", "gltf"):
        from .gltfcheck import check_gltf_structure

        js = _gltf_json(path, name, expected)
        check_gltf_structure(js, name, path)  # types and references, by JSON path, before trimesh trusts them
        return js
    return None


@contextlib.contextmanager
def naming_file(path):
    """Every failure of reading the mesh file ``path`` in this block as a ValueError naming the file.

    The backstop behind the checks: a reader's IndexError, KeyError, AttributeError, RecursionError (any
    failure but a TypeError, which is the caller's arguments') becomes ``ValueError("cannot read mesh
    file PATH: KeyError: 'x'")``, and a ValueError that does not name the file is prefixed with it.
    """
    name = os.path.basename(os.fspath(path))
    try:
        yield
    except TypeError:
        raise
    except ValueError as exc:
        if name in str(exc):
            raise
        raise ValueError(f"{name}: {exc}") from None
    except (ArithmeticError, AttributeError, LookupError, OSError, RuntimeError, struct.error) as exc:
        raise ValueError(f"cannot read mesh file {os.fspath(path)}: {type(exc).__name__}: {exc}") from None


def _trimesh_formats() -> set:
    """Every extension trimesh has a reader for, installed or not (a missing one names its pip package)."""
    from trimesh.exchange import load

    return set(load.mesh_loaders) | set(load.compressed_loaders) | set(load.path_formats())


def _check_zip(path: str, name: str) -> None:
    """Refuse an archive inside a zip archive: trimesh reads one level and would pass the inner one over."""
    try:
        with zipfile.ZipFile(path) as z:
            names = z.namelist()
    except (OSError, zipfile.BadZipFile) as exc:
        raise ValueError(f"{name}: not a readable zip archive ({exc})") from None
    inner = [n for n in names if n.lower().endswith(_ARCHIVES) and "__macosx" not in n.lower()]
    if inner:
        raise ValueError(f"{name}: holds the archive {inner[0]!r} (an archive inside an archive is not read): "
                         "unpack it and load the mesh files inside")


def _gltf_json(path: str, name: str, kind: str) -> dict:
    """The JSON of a glTF file, checked: an object at the top level, every required extension implemented."""
    try:
        with open(path, "rb") as fh:
            if kind == "glb":
                head = fh.read(20)
                length, chunk = struct.unpack("<II", head[12:20]) if len(head) == 20 else (0, 0)
                if chunk != 0x4E4F534A:  # "JSON"
                    raise ValueError("the first chunk is not JSON")
                js = json.loads(fh.read(length).decode("utf-8"))
            else:
                js = json.loads(fh.read().decode("utf-8-sig"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise ValueError(f"{name}: not valid glTF JSON ({exc})") from None
    if not isinstance(js, dict):
        raise ValueError(f"{name}: a glTF file is a JSON object ({{...}}) at the top level; got a JSON "
                         f"{type(js).__name__}")
    required = js.get("extensionsRequired", [])
    if not isinstance(required, list) or not all(isinstance(e, str) for e in required):
        raise ValueError(f"{name}: extensionsRequired: expected a list of extension names, got {required!r}")
    for i, ext in enumerate(required):
        if ext not in SUPPORTED_GLTF_EXTENSIONS:
            raise ValueError(f"{name}: extensionsRequired[{i}]: the file requires {ext}, which this loader does not "
                             f"implement (it reads {', '.join(sorted(SUPPORTED_GLTF_EXTENSIONS))}): the file cannot "
                             "be drawn as written (decompress or re-export it without the extension)")
    return js


def check_obj(data: bytes, name: str):
    """Check every ``v`` and ``f`` line of an OBJ; make relative (negative) indices absolute.

    A face needs three vertices or more, each written alike (``v``,
    ``v/vt``, ``v//vn`` or ``v/vt/vn``: a line cut short breaks the
    pattern); indices are integers, 1-based (0 is none), positive ones at
    most the file's count, negative ones (relative: -1 is the last vertex
    so far) reaching no further back than the first. A vertex needs three
    coordinates.

    Parameters
    ----------
    data : bytes
        The file's content.
    name : str
        For the messages.

    Returns
    -------
    bytes or None
        The content with every negative index made absolute (trimesh counts
        them back from the file's last vertex, not the face's), or None when
        there is none.

    Raises
    ------
    ValueError
        Naming the file, the line and what is wrong.
    """
    if _obj_plainly_valid(data):
        return None
    lines = data.split(b"\n")
    counts = {b"v": 0, b"vt": 0, b"vn": 0}
    faces = []  # (first line, last line, references, counts so far): checked once the totals are known
    i = 0
    while i < len(lines):
        first, raw = i, lines[i]
        while raw.rstrip(b"\r").endswith(b"\\") and i + 1 < len(lines):  # a continued line, as trimesh joins it
            i += 1
            raw = raw.rstrip(b"\r")[:-1] + lines[i]
        i += 1
        parts = raw.split(b"#", 1)[0].split()
        key = parts[0] if parts else None
        if key in counts:
            counts[key] += 1
            if key == b"v" and len(parts) < 4:
                raise ValueError(f"{name}:{first + 1}: a vertex needs 3 coordinates (x y z), got {len(parts) - 1}: "
                                 f"{_show(raw)} (is the file cut short?)")
        elif key == b"f":
            faces.append((first, i - 1, raw, parts[1:], (counts[b"v"], counts[b"vt"], counts[b"vn"])))
    totals = (counts[b"v"], counts[b"vt"], counts[b"vn"])
    relative = False
    for first, _, raw, refs, so_far in faces:
        relative |= _check_face(name, first + 1, raw, refs, so_far, totals)
    if not relative:
        return None
    for first, last, _, refs, so_far in faces:  # absolute from here on, as the spec reads them
        lines[first:last + 1] = [b"f " + b" ".join(b"/".join(_absolute(p, so_far[k], totals[k])
                                                           for k, p in enumerate(r.split(b"/"))) for r in refs)
                                 ] + [b""] * (last - first)
    return b"\n".join(lines)


def _absolute(token: bytes, so_far: int, total: int) -> bytes:
    """An OBJ index token made absolute (1-based); as written if it is not relative, or if the file has
    nothing of its kind (the reader then ignores the reference)."""
    return b"%d" % (so_far + int(token) + 1) if token.startswith(b"-") and total else token


def _obj_plainly_valid(data: bytes) -> bool:
    """Whether every vertex line has three coordinates and every face line is written alike, with positive
    indices within the file's counts: the common case, checked at C speed (any doubt: line by line)."""
    data = b"\n" + data
    # Indented keys, continued lines: the line-by-line check reads them.
    if re.search(rb"\n[ \t]+[^ \t\r\n]", data) or b"\\\n" in data or b"\\\r\n" in data:
        return False
    vertices = re.findall(rb"\nv[ \t]([^\n]*)", data)
    if min((len(b.split()) for b in vertices), default=3) < 3 or b"#" in b"".join(vertices):
        return False
    bodies = re.findall(rb"\nf[ \t]([^\n]*)", data)
    if not bodies:
        return True
    if b"#" in b"".join(bodies):
        return False
    refs = np.array([len(b.split()) for b in bodies])
    slashes = np.array([b.count(b"/") for b in bodies])
    doubles = np.array([b.count(b"//") for b in bodies])
    k, d = int(slashes[0] // max(refs[0], 1)), int(doubles[0] // max(refs[0], 1))
    if refs.min() < 3 or k > 2 or d > 1 or np.any(slashes != k * refs) or np.any(doubles != d * refs):
        return False
    slots = [0] if k == 0 else [0, 1] if k == 1 else [0, 2] if d else [0, 1, 2]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # older numpy: a token that is not an integer ends the parse short
            values = np.fromstring(b" ".join(bodies).replace(b"/", b" "), dtype=np.int64, sep=" ")
    except ValueError:  # numpy 2.4: that token is an error
        return False
    if len(values) != int(refs.sum()) * len(slots):
        return False
    totals = [data.count(b"\n%s " % key) + data.count(b"\n%s\t" % key) for key in (b"v", b"vt", b"vn")]
    table = values.reshape(-1, len(slots))
    return bool(table.min() >= 1 and all(table[:, c].max() <= totals[t] or (t and not totals[t])
                                         for c, t in enumerate(slots)))


def _show(raw: bytes) -> str:
    text = raw.decode("utf-8", errors="replace").strip()
    return repr(text if len(text) <= 60 else text[:57] + "...")


def _check_face(name: str, line: int, raw: bytes, refs: list, so_far: tuple, totals: tuple) -> bool:
    """One ``f`` line's vertex references checked; whether it has a negative (relative) index."""
    where = f"{name}:{line}: {_show(raw)}"
    if len(refs) < 3:
        raise ValueError(f"{where}: a face needs at least 3 vertices, got {len(refs)} (is the file cut short?)")
    forms = {tuple(bool(p) for p in r.split(b"/")) for r in refs}
    if len(forms) != 1 or len(next(iter(forms))) > 3 or not next(iter(forms))[0]:
        raise ValueError(f"{where}: the vertices are not written alike (v, v/vt, v//vn or v/vt/vn on every "
                         "vertex of a face; is the line cut short?)")
    relative = False
    for r in refs:
        for k, p in enumerate(r.split(b"/")):
            if not p:
                continue
            if k and not totals[k]:
                continue  # the file has no vt (vn) at all: the reader ignores references to them
            what = ("vertex", "texture coordinate (vt)", "normal (vn)")[k]
            try:
                idx = int(p)
            except ValueError:
                raise ValueError(f"{where}: {p.decode(errors='replace')!r} is not a {what} index (an integer)") \
                    from None
            if idx == 0:
                raise ValueError(f"{where}: {what} index 0: OBJ indices start at 1 (negative ones count back from "
                                 "the last one so far)")
            if idx > totals[k]:
                raise ValueError(f"{where}: {what} index {idx}, but the file has {totals[k]}")
            if idx < 0:
                relative = True
                if -idx > so_far[k]:
                    raise ValueError(f"{where}: relative {what} index {idx}, but only {so_far[k]} come before it")
    return relative


def check_face_indices(path: str, meshes) -> None:
    """Refuse any face index of what trimesh read that is outside its vertices, naming where it is in the file.

    Runs before anything else looks at the faces (the reversed-duplicate
    search, the normals): an index out of range there is an IndexError.

    Raises
    ------
    ValueError
        Naming the file and the PLY line or the glTF accessor (``meshes[0].primitives[1].indices``) where
        the file says so, else the mesh and the face.
    """
    for m in meshes:
        faces = np.asarray(getattr(m, "faces", np.zeros((0, 3), np.int64)))
        nv = len(getattr(m, "vertices", ()))
        if faces.size and (faces.min() < 0 or faces.max() >= nv):
            raise ValueError(locate_bad_index(path) or _generic(path, m, faces, nv))


def _generic(path: str, m, faces: np.ndarray, nv: int) -> str:
    k = int(np.argmax(((faces < 0) | (faces >= nv)).any(axis=1)))
    bad = int(faces[k][(faces[k] < 0) | (faces[k] >= nv)][0])
    mesh = getattr(m, "metadata", {}).get("name") or ""
    return (f"{os.path.basename(path)}: {'mesh ' + repr(mesh) + ': ' if mesh else ''}face {k} indexes vertex {bad}, "
            f"but there are only {nv} vertices")


def locate_bad_index(path: str):
    """Where a PLY (ASCII) or glTF file indexes a vertex it does not have, as a message; None if not found."""
    ext = os.path.splitext(path)[1].lower()
    try:
        if ext == ".ply":
            return _ply_bad_index(path)
        if ext in (".gltf", ".glb"):
            return _gltf_bad_index(path)
    except (OSError, ValueError, KeyError, IndexError, TypeError, struct.error):
        return None  # the generic message then
    return None


def _ply_bad_index(path: str):
    name = os.path.basename(path)
    with open(path, "rb") as fh:
        data = fh.read()
    end = data.index(b"end_header")
    header = data[:end].decode("latin-1").splitlines()
    if not any(line.split()[:2] == ["format", "ascii"] for line in header):
        return None
    elements = []  # [name, count, [property names; a list is ("list", name)]]
    for line in header:
        t = line.split()
        if t[:1] == ["element"]:
            elements.append([t[1], int(t[2]), []])
        elif t[:1] == ["property"] and elements:
            elements[-1][2].append(("list", t[-1]) if t[1] == "list" else ("scalar", t[-1]))
    nv = next(c for n, c, _ in elements if n == "vertex")
    rows = data[end:].split(b"\n")[1:]
    first = len(header) + 2  # the line after end_header
    row = 0
    for ename, count, props in elements:
        if ename != "face":
            row += count
            continue
        for k in range(count):
            tokens, at = rows[row + k].split(), 0
            for kind, prop in props:
                n = int(tokens[at]) if kind == "list" else 0
                values = tokens[at + 1:at + 1 + n] if kind == "list" else []
                at += 1 + n
                if prop in ("vertex_indices", "vertex_index"):
                    bad = [int(v) for v in values if not 0 <= int(v) < nv]
                    if bad:
                        return (f"{name}:{first + row + k}: face {k} indexes vertex {bad[0]}, but the file has "
                                f"{nv} vertices (PLY indices start at 0)")
        return None
    return None


def _gltf_bad_index(path: str):
    from .gltfgeometry import _Reader

    name = os.path.basename(path)
    js = _gltf_json(path, name, "glb" if path.lower().endswith(".glb") else "gltf")
    reader = None
    for i, mesh in enumerate(js.get("meshes", [])):
        for j, prim in enumerate(mesh.get("primitives", [])):
            if "indices" not in prim or "POSITION" not in prim.get("attributes", {}):
                continue
            nv = int(js["accessors"][prim["attributes"]["POSITION"]]["count"])
            acc = js["accessors"][prim["indices"]]
            if acc.get("componentType") not in (5121, 5123, 5125) or "bufferView" not in acc:
                continue  # the unsigned index types the spec allows, as stored
            reader = _Reader(path, js) if reader is None else reader
            where = f"meshes[{i}].primitives[{j}].indices"
            idx = reader.raw(prim["indices"], where)[0].reshape(-1)
            bad = np.flatnonzero(idx >= nv)
            if bad.size:
                return (f"{name}: {where}: entry {int(bad[0])} is vertex {int(idx[bad[0]])}, but the primitive's "
                        f"POSITION has {nv} vertices")
    return None
