"""What a mesh file refers to and declares, read from the file itself.

trimesh reads the geometry and most materials, but passes over what a
careful loader must report: an MTL or an image that is missing, a ``usemtl``
that no MTL defines, a glTF sampler's wrap modes, an OFF file's colours.
These small parsers read exactly those parts, with the file and line (or
JSON field) of each, so :mod:`raycast_shade.scene.meshfile` can map, warn or
refuse naming them.
"""

from __future__ import annotations

import io
import json
import math
import os
import re
import struct
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..common.warnings import DroppedOnLoadWarning

__all__ = ["load_obj", "load_off", "MtlMaterial", "parse_mtl", "obj_references", "gltf_header", "off_colors", "ply_texture_files",
           "GL_WRAPS", "obj_mtl_files",
           "off_mesh_colors"]

# glTF sampler wrap codes (the OpenGL enums the spec uses).
GL_WRAPS = {10497: "repeat", 33071: "clamp", 33648: "mirror"}


@dataclass
class MtlMaterial:
    """One ``newmtl`` block: each key (lower case) -> (tokens, line number)."""

    name: str
    path: str
    line: int
    fields: dict = field(default_factory=dict)

    def where(self, key: str) -> str:
        """``file:line`` of ``key`` (of the ``newmtl`` without a key)."""
        line = self.fields[key][1] if key in self.fields else self.line
        return f"{os.path.basename(self.path)}:{line}"


def _lines(path: str):
    with open(path, "rb") as fh:
        data = fh.read()
    text = data.decode("utf-8", errors="replace")
    for i, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if line:
            yield i, line


def parse_mtl(path: str) -> dict:
    """The materials of an MTL file by name, each a :class:`MtlMaterial`.

    A key before the first ``newmtl`` is ignored. A ``newmtl`` without a name
    starts a material named ``""`` (warned, naming the file and line): its
    keys are its own, not the material before it.

    Warns
    -----
    DroppedOnLoadWarning
        For a ``newmtl`` without a name.
    """
    out, cur = {}, None
    for i, line in _lines(path):
        parts = line.split(None, 1)
        key, rest = parts[0].lower(), (parts[1] if len(parts) > 1 else "")
        tokens = rest.split()
        if key == "newmtl":
            if not tokens:
                warnings.warn(f"{os.path.basename(path)}:{i}: newmtl without a name: read as the material named '' "
                              "(no usemtl can name it)", DroppedOnLoadWarning, stacklevel=4)
            cur = MtlMaterial(" ".join(tokens), path, i)
            out[cur.name] = cur
        elif cur is not None:
            cur.fields[key] = (tokens, i)
    return out


def mtl_color(mat: MtlMaterial, key: str):
    """``Kd``/``Ka``/``Ks`` as (3,) float64: one or three finite numbers ``>= 0``.

    Raises
    ------
    ValueError
        Naming the file, line and key, for anything else (``Kd abc``, ``Kd -0.5``,
        ``Kd spectral ...`` and ``Kd xyz ...``, which are not RGB).
    """
    tokens, _ = mat.fields[key]
    where = f"{mat.where(key)}: {key.capitalize()} {' '.join(tokens)}".rstrip()
    try:
        nums = [float(t) for t in tokens]
    except ValueError:
        raise ValueError(f"{where}: expected 1 or 3 numbers (r g b)") from None
    if len(nums) not in (1, 3):
        raise ValueError(f"{where}: expected 1 or 3 numbers (r g b), got {len(nums)}")
    if not all(math.isfinite(n) for n in nums):
        raise ValueError(f"{where}: the values must be finite")
    if min(nums) < 0:
        raise ValueError(f"{where}: reflectances must be >= 0")
    return np.array(nums * 3 if len(nums) == 1 else nums, np.float64)


def mtl_number(mat: MtlMaterial, key: str) -> float:
    """A one-number key (``Ns``, ``d``, ``Tr``, ``illum``, ``Ni``) as a finite float."""
    tokens, _ = mat.fields[key]
    where = f"{mat.where(key)}: {key.capitalize()} {' '.join(tokens)}".rstrip()
    try:
        value = float(tokens[0])
    except (ValueError, IndexError):
        raise ValueError(f"{where}: expected a number") from None
    if not math.isfinite(value):
        raise ValueError(f"{where}: the value must be finite")
    return value


def obj_references(path: str) -> tuple:
    """``(mtllibs, usemtls)`` of an OBJ file: lists of ``(name, line)``.

    Without a ``mtllib`` the ``usemtl`` names are none (many exporters write them as group names in files
    that have no materials: nothing to look them up in, nothing to warn of).
    """
    mtllibs, usemtls = [], []
    with open(path, "rb") as fh:
        for i, raw in enumerate(fh, 1):
            if raw[:1] not in (b"m", b"u", b"M", b"U"):
                continue  # the quick path over v/vt/f lines
            line = raw.decode("utf-8", errors="replace").split("#", 1)[0].strip()
            parts = line.split(None, 1)
            if not parts:
                continue
            key, rest = parts[0], (parts[1] if len(parts) > 1 else "")
            if key.lower() == "mtllib":
                mtllibs.append((rest.strip(), i))  # one name with spaces, or several: resolved by the caller
            elif key.lower() == "usemtl" and rest.strip():
                usemtls.append((rest.strip(), i))
    return mtllibs, (usemtls if mtllibs else [])


def obj_mtl_files(path: str) -> list:
    """The MTL files an OBJ names that exist, in order (a ``mtllib`` line may name several)."""
    base = os.path.dirname(os.path.abspath(path))
    out = []
    for names, _ in obj_references(path)[0]:
        full = os.path.join(base, names)
        for f in [full] if os.path.isfile(full) else [os.path.join(base, n) for n in names.split()]:
            if os.path.isfile(f) and f not in out:
                out.append(f)
    return out


def gltf_header(path: str):
    """The JSON of a ``.gltf`` or a ``.glb`` file (its first chunk), or None if unreadable."""
    try:
        if path.lower().endswith(".glb"):
            with open(path, "rb") as fh:
                head = fh.read(20)
                if len(head) < 20 or head[:4] != b"glTF":
                    return None
                length, kind = struct.unpack("<II", head[12:20])
                if kind != 0x4E4F534A:  # "JSON"
                    return None
                return json.loads(fh.read(length).decode("utf-8"))
        with open(path, "rb") as fh:
            return json.loads(fh.read().decode("utf-8"))
    except (OSError, ValueError):
        return None


def off_colors(path: str):
    """An OFF file's colours: ``(vertex (V, k) or None, face (P, k) or None, polygon sizes (P,))``.

    Vertex colours follow the three coordinates on a vertex line, face colours
    the index list on a face line (k = 3 or 4 values: integers 0..255, or
    floats in [0, 1]); None when the file has none. Raises ValueError naming
    the line for colours that are neither.
    """
    lines = list(_lines(path))
    if not lines:
        return None, None, np.zeros(0, np.int64)
    none = None, None, np.zeros(0, np.int64)
    i = next((k for k, (_, line) in enumerate(lines) if "OFF" in line), None)
    if i is None:
        return none
    try:  # the structure is trimesh's to judge (and refuse); only the colours are read here
        line = lines[i][1]
        rest = line[line.index("OFF") + 3:].split()  # "OFF", "COFF", "NOFF" ..., counts here or on the next line
        i += 1
        if not rest:
            rest = lines[i][1].split()
            i += 1
        nv, nf = int(rest[0]), int(rest[1])
        if len(lines) < i + nv + nf:
            return none  # fewer rows than declared: load_off names that before any colour is read
        vrows = [(n, line.split()[3:]) for n, line in lines[i:i + nv]]
        frows = []
        for n, line in lines[i + nv:i + nv + nf]:
            t = line.split()
            k = int(t[0])
            frows.append((n, k, t[1 + k:]))
    except (IndexError, ValueError):
        return none
    sizes = np.array([k for _, k, _ in frows], np.int64)
    frows = [(n, r) for n, _, r in frows]

    def table(rows, what):
        counts = {len(r) for _, r in rows}
        if counts == {0} or not rows:
            return None
        if len(counts) != 1 or counts.pop() not in (3, 4):
            bad = next(n for n, r in rows if len(r) not in (3, 4))
            raise ValueError(f"{os.path.basename(path)}:{bad}: expected 3 or 4 {what} colour values (r g b [a]) "
                             "on every line, or none")
        try:
            a = np.array([[float(x) for x in r] for _, r in rows], np.float64)
        except ValueError:
            bad = next(n for n, r in rows if not all(_is_number(x) for x in r))
            raise ValueError(f"{os.path.basename(path)}:{bad}: {what} colour values must be numbers") from None
        if not np.isfinite(a).all() or a.min() < 0:
            bad = rows[int(np.argmax(~np.isfinite(a).all(axis=1) | (a < 0).any(axis=1)))][0]
            raise ValueError(f"{os.path.basename(path)}:{bad}: {what} colour values must be finite and >= 0")
        ints = all("." not in x and "e" not in x.lower() for _, r in rows for x in r)
        if ints or a.max() > 1.0:
            if a.max() > 255:
                bad = rows[int(np.argmax(a.max(axis=1)))][0]
                raise ValueError(f"{os.path.basename(path)}:{bad}: {what} colour values above 255")
            return a / 255.0
        return a

    return table(vrows, "vertex"), table(frows, "face"), sizes


def _is_number(x: str) -> bool:
    try:
        float(x)
        return True
    except ValueError:
        return False


def ply_texture_files(path: str) -> list:
    """The ``comment TextureFile name`` entries of a PLY header."""
    names = []
    with open(path, "rb") as fh:
        for raw in fh:
            line = raw.decode("latin-1").strip()
            if line == "end_header":
                break
            low = line.lower()
            if low.startswith("comment") and "texturefile" in low:
                names.append(line[low.index("texturefile") + len("texturefile"):].strip())
    return names


_MTL_KEY = "__raycast_shade_materials__.mtl"
# A comment after the values of a vertex, UV, normal, face or line statement (``f 1 2 3  # x``): group 1
# is the statement. Other keys keep theirs (a file name may hold a '#').
_DATA_COMMENT = re.compile(rb"(?m)^([ \t]*(?:v|vt|vn|vp|f|l|p)[ \t][^#\r\n]*?)[ \t]*#[^\r\n]*")


class _MtlOnly:
    """A trimesh resolver that hands over the OBJ's MTL files, joined, and nothing else: trimesh
    reads only the first ``mtllib`` (a missing first one loses every material, names and all),
    and the textures are read by raycast_shade itself (once, with their options)."""

    def __init__(self, mtl: bytes):
        self.mtl = mtl

    def get(self, name):
        if name == _MTL_KEY:
            return self.mtl
        raise OSError(f"{name}: read by raycast_shade, not by trimesh")

    __getitem__ = get


def _warn_partial_colors(counts: np.ndarray, name: str) -> None:
    """Warn, with the counts, when only some ``v`` lines carry a colour (x y z r g b: six values or more;
    ``counts`` the values on each): trimesh then drops them all."""
    coloured, total = int(np.count_nonzero(counts >= 6)), len(counts)
    if 0 < coloured < total:
        warnings.warn(f"{name}: {coloured} of {total} vertices (v lines) have a colour (x y z r g b), the other "
                      f"{total - coloured} none: dropped every vertex colour (give every vertex one, or none)",
                      DroppedOnLoadWarning, stacklevel=5)


def load_obj(path: str):
    """``trimesh.load`` of an OBJ with every ``mtllib`` the file names (those that exist) as one.

    Its lines are checked first (:func:`~raycast_shade.scene.filecheck.check_obj`), and its non-convex
    polygons ear-clipped in their planes (:func:`~raycast_shade.scene.polygons.ear_clip_obj`); trimesh
    fans the rest from their first vertex, as it always did.
    """
    import trimesh

    from .filecheck import check_obj
    from .polygons import ear_clip_obj, vertex_lines

    with open(path, "rb") as fh:
        data = fh.read()
    name = os.path.basename(path)
    absolute = check_obj(data, name)
    data = data if absolute is None else absolute
    if b"#" in data:  # the spec allows a comment after a statement; trimesh reads it as an index
        stripped = _DATA_COMMENT.sub(rb"\1", data)
        absolute = absolute if stripped == data else stripped
        data = stripped
    vertices = vertex_lines(data)
    _warn_partial_colors(vertices[0], name)
    clipped = ear_clip_obj(data, name, vertices)  # only non-convex polygons: convex ones keep trimesh's fan
    absolute = absolute if clipped is None else clipped
    data = data if clipped is None else clipped
    files = obj_mtl_files(path)
    if not files and absolute is None:
        return trimesh.load(path, process=False)
    if not files:
        return trimesh.load(file_obj=io.BytesIO(data), file_type="obj", process=False, metadata={"file_name": name})
    parts = []
    for f in files:
        with open(f, "rb") as fh:
            parts.append(fh.read())
    mtl = b"\n".join(parts)
    lines = [ln for ln in data.split(b"\n") if not ln.lstrip().lower().startswith(b"mtllib")]
    text = b"mtllib " + _MTL_KEY.encode() + b"\n" + b"\n".join(lines)
    return trimesh.load(file_obj=io.BytesIO(text), file_type="obj", resolver=_MtlOnly(mtl), process=False,
                        metadata={"file_name": name})


def load_off(path: str):
    """An OFF file as a ``trimesh.Trimesh`` (not processed), its faces read and triangulated here.

    trimesh's reader fails on polygons of five vertices or more (``The 'out' kwarg is necessary``) and
    fans concave ones over area they do not have; here every polygon is checked (the file and line of
    what is wrong) and triangulated by :func:`~raycast_shade.scene.polygons.triangulate_polygons` (convex
    ones as trimesh split them, in its order, so the file's face colours land as before).

    Raises
    ------
    ValueError
        Naming the file and line: no ``OFF`` header or counts, a vertex line without three numbers, a face
        line whose count is not an integer >= 3 or that has fewer indices than its count, an index that is
        not an integer or outside ``[0, vertices)`` (naming the face's number), fewer lines than declared.
    """
    import trimesh

    from .polygons import triangulate_polygons

    name = os.path.basename(path)
    rows = list(_lines(path))
    head = next((k for k, (_, line) in enumerate(rows) if "OFF" in line.split()[0]), None) if rows else None
    if head is None:
        raise ValueError(f"{name}: no OFF header line (OFF, COFF, NOFF, ...)")
    line = rows[head][1]
    rest, at = line[line.index("OFF") + 3:].split(), head + 1  # counts after the keyword (even "OFF8 6 12")
    if not rest and at < len(rows):
        rest, at = rows[at][1].split(), at + 1
    try:
        nv, nf = int(rest[0]), int(rest[1])
        if nv < 0 or nf < 0:
            raise ValueError
    except (IndexError, ValueError):
        where = rows[at - 1][0]
        raise ValueError(f"{name}:{where}: expected the counts 'VERTICES FACES [EDGES]' (integers >= 0)") from None
    vrows, frows = rows[at:at + nv], rows[at + nv:at + nv + nf]
    if len(vrows) < nv or len(frows) < nf:
        kind, got, want = ("vertex", len(vrows), nv) if len(vrows) < nv else ("face", len(frows), nf)
        raise ValueError(f"{name}: the header declares {want} {kind} line(s), the file has {got} (is it cut short?)")
    try:
        vertices = np.array([line.split()[:3] for _, line in vrows], np.float64).reshape(nv, 3)
    except ValueError:
        bad = next(n for n, line in vrows if len(line.split()) < 3 or not all(_is_number(x) for x in line.split()[:3]))
        raise ValueError(f"{name}:{bad}: a vertex needs 3 coordinates (x y z), numbers") from None
    counts, flat, lines = np.zeros(nf, np.int64), [], np.array([n for n, _ in frows], np.int64)
    for j, (n, line) in enumerate(frows):
        t = line.split()
        k = int(t[0]) if t[0].isdigit() else -1
        if k < 3 or len(t) < 1 + k:
            raise ValueError(f"{name}:{n}: face {j}: {line.strip()!r}: expected a vertex count of 3 or more and that "
                             "many indices (is the line cut short?)")
        counts[j] = k
        flat += t[1:1 + k]
    try:
        flat = np.array(flat, np.int64)
    except ValueError:
        j = next(j for j, (_, line) in enumerate(frows) if not all(x.lstrip("-").isdigit()
                                                                   for x in line.split()[1:1 + counts[j]]))
        raise ValueError(f"{name}:{lines[j]}: face {j}: a vertex index is not an integer") from None
    if len(flat) and (flat.min() < 0 or flat.max() >= nv):
        at = int(np.argmax((flat < 0) | (flat >= nv)))
        j = int(np.searchsorted(np.cumsum(counts), at, side="right"))
        raise ValueError(f"{name}:{lines[j]}: face {j} indexes vertex {int(flat[at])}, but the file has {nv} vertices "
                         "(OFF indices start at 0)")
    faces = triangulate_polygons(vertices, flat, counts, name, lines) if nf else np.zeros((0, 3), np.int64)
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False,
                           metadata={"file_name": name, "file_path": os.path.abspath(path), "file_type": "off"})


def off_mesh_colors(off, nv: int, nf: int, name: str):
    """An OFF file's own colours (trimesh drops them) for its mesh of ``nv`` vertices and ``nf`` triangles.

    Parameters
    ----------
    off : tuple
        :func:`off_colors` of the file.
    nv, nf : int
    name : str
        For the warning.

    Returns
    -------
    colors : (nv, 3) or (nf, 3) float64 or None
        Linear (decoded from sRGB): per vertex, or per polygon spread over its triangles in trimesh's
        order (triangles first, then quads' first halves, then second halves, then larger polygons' fans).
    mode : "vertex", "face" or None

    Warns
    -----
    DroppedOnLoadWarning
        An alpha channel that is not opaque (transparency is not modelled).
    """
    from .texture import srgb_to_linear

    vc, fc, sizes = off
    if vc is not None and len(vc) == nv:
        c = vc
        mode = "vertex"
    elif fc is not None:
        order = _off_triangle_sources(sizes)
        if len(order) != nf:
            return None, None
        c, mode = fc[order], "face"
    else:
        return None, None
    if c.shape[1] == 4:
        if np.any(c[:, 3] < 1.0):
            warnings.warn(f"{name}: dropped the colours' alpha (transparency is not modelled)",
                          DroppedOnLoadWarning, stacklevel=4)
        c = c[:, :3]
    return srgb_to_linear(np.clip(c, 0.0, 1.0)), mode


def _off_triangle_sources(sizes: np.ndarray) -> np.ndarray:
    """For each triangle trimesh's ``triangulate_quads`` makes, the polygon it comes from."""
    idx = np.arange(len(sizes))
    if np.all(sizes == 3):
        return idx
    if np.all(sizes == 4):
        return np.concatenate([idx, idx])
    tri, quad, poly = idx[sizes == 3], idx[sizes == 4], idx[sizes > 4]
    fans = np.concatenate([np.full(sizes[p] - 2, p) for p in poly]) if len(poly) else np.zeros(0, np.int64)
    return np.concatenate([tri, quad, quad, fans]).astype(np.int64)
