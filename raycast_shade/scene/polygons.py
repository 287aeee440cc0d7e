"""OBJ and OFF polygons with more than three vertices triangulated in their own plane.

trimesh splits every polygon into a fan from its first vertex: right for a
convex polygon, but a concave one (an L, a keyhole ring around a hole) comes
out as triangles that spill over its outline and cover area it does not
have. :func:`ear_clip_obj` rewrites only the non-convex polygons of an OBJ's
text as the triangles of ear clipping (mapbox-earcut) in the polygon's plane,
before trimesh reads it; convex ones stay as written, so trimesh's fan gives
them the triangles it always did. Degenerate polygons (no area, a vertex
repeated next to itself, bent out of their plane, crossing themselves) are
named in one warning with the file and line of each. OFF faces are read by the library
(:func:`~raycast_shade.scene.fileparse.load_off`) and made triangles by :func:`triangulate_polygons`
the same way: convex ones as trimesh would split them, non-convex ones ear-clipped.
"""

from __future__ import annotations

import re
import warnings

import numpy as np

from ..common.warnings import DroppedOnLoadWarning

__all__ = ["ear_clip_obj", "triangulate_polygons", "vertex_lines", "PLANAR_TOLERANCE"]

# A polygon bent out of its (Newell) plane by more than this fraction of its size is warned of: its
# triangles then depend on how it is split. Subdivision-surface quads bend by far less.
PLANAR_TOLERANCE = 1e-2
# Relative slack for "convex" (a turn this small against the size is straight) and for the area check.
_TURN_EPS = 1e-9
_AREA_RTOL = 1e-6
# A face line with four vertex references or more (the quick test: most files have triangles only).
_POLYGON = re.compile(rb"(?m)^[ \t]*f(?:[ \t]+[^ \t\r\n#]+){4}")


def vertex_lines(data: bytes) -> tuple:
    """``(values per vertex line (V,) int64, whether some face line has four references or more)``.

    One pass of NumPy over the bytes where every key starts its line and no vertex or face line has a
    comment (the common case), else regular expressions; the OBJ read once for :func:`ear_clip_obj`
    and the colour check.
    """
    if len(data) < 2:
        return np.zeros(0, np.int64), False
    a = np.frombuffer(data, np.uint8)
    newline = np.flatnonzero(a == 10)
    starts = np.r_[0, newline + 1]
    starts = starts[starts < len(a) - 1]
    space = a <= 32
    first = np.flatnonzero(~space & np.r_[True, space[:-1]])  # where each token starts
    tokens = np.bincount(np.searchsorted(newline, first), minlength=len(newline) + 1)
    line = np.searchsorted(newline, starts)
    after = (a[starts + 1] == 32) | (a[starts + 1] == 9)
    vline, fline = (a[starts] == ord("v")) & after, (a[starts] == ord("f")) & after
    hashes = np.searchsorted(newline, np.flatnonzero(a == ord("#")))
    indented = np.any(space[starts] & ~((a[starts] == 10) | (a[starts] == 13)))
    if indented or np.isin(hashes, line[vline | fline]).any():
        bodies = _V_LINE.findall(data)
        return _tokens_per_line(b"\n".join(bodies), len(bodies)), _POLYGON.search(data) is not None
    return tokens[line[vline]] - 1, bool(np.any(tokens[line[fline]] > 4))


def ear_clip_obj(data: bytes, name: str, vertices: tuple | None = None):
    """The OBJ's text with every non-convex polygon written as its ear-clipped triangles.

    Parameters
    ----------
    data : bytes
        The file's content, checked by :func:`~raycast_shade.scene.filecheck.check_obj` (positive indices
        within the file's counts).
    name : str
        The file's name, for the warning.
    vertices : tuple, optional
        :func:`vertex_lines` of ``data``, when the caller has it.

    Returns
    -------
    bytes or None
        The rewritten text, or None when no polygon needs it (every face a triangle or convex).

    Warns
    -----
    DroppedOnLoadWarning
        One for the file, naming the line of each degenerate polygon: no area (collinear or coincident
        vertices), a vertex repeated next to itself, bent out of its plane by more than
        :data:`PLANAR_TOLERANCE` of its size, or crossing itself (the triangles then cannot match its
        outline's area). Such a polygon is still triangulated (ear clipping where it is not convex).
    """
    if not (vertex_lines(data) if vertices is None else vertices)[1]:
        return None
    read = _read_fast(data) if b"\\\n" not in data and b"\\\r\n" not in data else None
    positions, spans, counts, flat = read if read is not None else _read(data)
    if positions is None or not np.any(counts > 3):
        return None
    offsets = np.concatenate([[0], np.cumsum(counts)[:-1]])
    notes, rewrite = [], {}
    for k in np.unique(counts[counts > 3]):
        group = np.flatnonzero(counts == k)
        idx = flat[offsets[group][:, None] + np.arange(k)] - 1
        if idx.min() < 0 or idx.max() >= len(positions):
            return None  # not checked as expected: trimesh's to refuse
        pts = positions[idx]
        normal, convex, degenerate = _classify(pts, idx)
        for j in np.flatnonzero(~convex | (degenerate != "")):
            start, end = spans[group[j]]
            why = degenerate[j]
            if not convex[j]:
                tris, area_note = _ear_clip(pts[j], normal[j])
                why = "; ".join(w for w in (why, area_note) if w)
                if tris is not None:
                    tokens = data[start:end].split(b"#", 1)[0].replace(b"\\", b" ").split()[1:]
                    rewrite[start] = (end, b"\n".join(b"f " + b" ".join(tokens[c] for c in t) for t in tris))
            if why:
                notes.append((start, why))
    if notes:
        notes.sort()
        lines = [data.count(b"\n", 0, at) + 1 for at, _ in notes[:8]]
        shown = "; ".join(f"line {n} ({why})" for n, (_, why) in zip(lines, notes))
        more = f"; and {len(notes) - 8} more" if len(notes) > 8 else ""
        warnings.warn(f"{name}: {len(notes)} degenerate polygon(s), triangulated as written: {shown}{more}",
                      DroppedOnLoadWarning, stacklevel=5)
    if not rewrite:
        return None
    parts, at = [], 0
    for start in sorted(rewrite):
        end, text = rewrite[start]
        parts += [data[at:start], text]
        at = end
    return b"".join(parts + [data[at:]])


# Vertex and face lines (their bodies), where no line is continued with a backslash.
_V_LINE = re.compile(rb"(?m)^[ \t]*v[ \t]+([^\r\n#]*)")
_F_LINE = re.compile(rb"(?m)^[ \t]*f[ \t]+([^\r\n#]*)")


def _tokens_per_line(joined: bytes, n: int) -> np.ndarray:
    """How many whitespace-separated tokens each of the ``n`` newline-joined lines has, (n,) int64."""
    a = np.frombuffer(joined, np.uint8)
    space = (a <= 32)  # space, tab, CR, LF (the lines hold no other control bytes that matter here)
    first = np.flatnonzero(~space[1:] & space[:-1]) + 1
    if len(a) and not space[0]:
        first = np.r_[0, first]
    line = np.searchsorted(np.flatnonzero(a == 10), first)
    return np.bincount(line, minlength=n)[:n].astype(np.int64)


def _numbers(joined: bytes, dtype):
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # older numpy: a token that is not a number ends the parse short
            return np.fromstring(joined, dtype=dtype, sep=" ")
    except ValueError:  # numpy 2.4: that token is an error
        return None


def _read_fast(data: bytes):
    """:func:`_read` at C speed (regular expressions and NumPy over the whole text); None where in doubt."""
    bodies = _V_LINE.findall(data)
    joined = b"\n".join(bodies)
    counts = _tokens_per_line(joined, len(bodies))
    values = _numbers(joined, np.float64)
    if values is None or len(values) != counts.sum() or (len(counts) and counts.min() < 3):
        return None
    positions = values[np.concatenate([[0], np.cumsum(counts)[:-1]])[:, None] + np.arange(3)] if len(counts) \
        else np.zeros((0, 3))
    bodies = _F_LINE.findall(data)
    joined = b"\n".join(bodies)
    counts = _tokens_per_line(joined, len(bodies))
    flat = _numbers(re.sub(rb"/[^ \t\r\n]*", b"", joined), np.int64)
    if flat is None or len(flat) != counts.sum():
        return None
    a = np.frombuffer(data, np.uint8)
    starts = np.r_[0, np.flatnonzero(a[:-1] == 10) + 1]
    starts = starts[starts < len(a) - 1]
    starts = starts[(a[starts] == ord("f")) & ((a[starts + 1] == 32) | (a[starts + 1] == 9))]
    if len(starts) != len(bodies):  # an indented face line: the match objects place them
        starts = np.array([m.start() for m in _F_LINE.finditer(data)], np.int64)
    return positions, _Spans(data, starts), counts, flat


class _Spans:
    """``(start, end)`` of the i-th face line, its end found when asked (only flagged polygons ask)."""

    def __init__(self, data: bytes, starts: np.ndarray):
        self.data, self.starts = data, starts

    def __getitem__(self, i):
        start = int(self.starts[i])
        end = self.data.find(b"\n", start)
        return start, len(self.data) if end < 0 else end


def _read(data: bytes):
    """``(positions (V, 3) float64 or None, face line spans [(start, end)], references per face (F,),
    vertex indices of every face one after another)``, continued lines (a trailing backslash) joined as
    trimesh joins them."""
    lines = data.split(b"\n")
    rows, spans, counts, flat = [], [], [], []
    i, at = 0, 0
    while i < len(lines):
        start, raw = at, lines[i]
        at += len(lines[i]) + 1
        while raw.rstrip(b"\r").endswith(b"\\") and i + 1 < len(lines):
            i += 1
            at += len(lines[i]) + 1
            raw = raw.rstrip(b"\r")[:-1] + lines[i]
        i += 1
        parts = raw.split(b"#", 1)[0].split()
        if parts[:1] == [b"v"]:
            rows.append(parts[1:4])
        elif parts[:1] == [b"f"]:
            spans.append((start, min(at - 1, len(data))))
            counts.append(len(parts) - 1)
            flat += [int(t.split(b"/", 1)[0]) for t in parts[1:]]
    try:
        positions = np.array(rows, np.float64).reshape(-1, 3)
    except ValueError:
        positions = None  # a coordinate that is not a number: trimesh's to refuse
    return positions, spans, np.array(counts, np.int64), np.array(flat, np.int64)


def _classify(pts: np.ndarray, idx: np.ndarray):
    """For (P, k, 3) polygons: (Newell normals (P, 3), convex (P,) bool, what is degenerate (P,) str)."""
    centred = pts - pts.mean(axis=1, keepdims=True)  # Newell's sums on centred points: no cancellation
    nxt = np.roll(centred, -1, axis=1)
    normal = np.cross(centred, nxt).sum(axis=1)  # twice the vector area
    edges = nxt - centred
    size = np.sqrt((centred ** 2).sum(axis=2).max(axis=1)) * 2
    length = np.linalg.norm(normal, axis=1)
    flat = length <= 1e-12 * np.maximum(size, np.finfo(float).tiny) ** 2
    unit = normal / np.where(flat, 1.0, length)[:, None]
    turns = np.einsum("pkc,pc->pk", np.cross(np.roll(edges, 1, axis=1), edges), unit)
    convex = flat | (turns >= -_TURN_EPS * size[:, None] ** 2).all(axis=1)
    bent = np.abs(np.einsum("pkc,pc->pk", centred, unit)).max(axis=1) > PLANAR_TOLERANCE * size
    repeated = (idx == np.roll(idx, -1, axis=1)).any(axis=1) | ((edges ** 2).sum(axis=2) == 0).any(axis=1)
    why = np.full(len(pts), "", dtype=object)
    for mask, text in ((bent & ~flat, "not planar"), (repeated, "a vertex repeated next to itself"),
                       (flat, "no area")):
        why[mask] = [f"{w}; {text}" if w else text for w in why[mask]]
    return normal, convex, why


def _ear_clip(pts: np.ndarray, normal: np.ndarray):
    """Ear-clipped triangles of one (k, 3) polygon in its plane, wound as the polygon ((T, 3) corner
    indices, or None), and a note if their area is not the outline's (the polygon crosses itself)."""
    from mapbox_earcut import triangulate_float64

    n = normal / np.linalg.norm(normal)
    u = np.cross(n, np.eye(3)[int(np.argmin(np.abs(n)))])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    flat = np.c_[(pts - pts[0]) @ u, (pts - pts[0]) @ v]  # (u, v, n) right-handed: the outline winds positive
    tris = np.asarray(triangulate_float64(flat, np.array([len(flat)], np.uint32)), np.int64).reshape(-1, 3)
    if not len(tris):
        return None, "ear clipping found no triangles: kept as a fan"
    a, b, c = flat[tris[:, 0]], flat[tris[:, 1]], flat[tris[:, 2]]
    signed = ((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]) / 2
    if signed.sum() < 0:
        tris, signed = tris[:, ::-1], -signed
    x, y = flat[:, 0], flat[:, 1]
    outline = abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))) / 2  # the shoelace area
    covered = float(np.abs(signed).sum())
    note = ""
    if abs(covered - outline) > _AREA_RTOL * max(outline, covered):
        note = f"crosses itself: its triangles cover {covered:.6g}, its outline {outline:.6g}"
    return tris, note


def triangulate_polygons(positions: np.ndarray, flat: np.ndarray, counts: np.ndarray, name: str,
                         lines: np.ndarray) -> np.ndarray:
    """Polygons as triangles in trimesh's order for OFF files, non-convex ones ear-clipped in their plane.

    Parameters
    ----------
    positions : (V, 3) float64
    flat : (sum(counts),) int64
        Every polygon's vertex indices (0-based, checked) one polygon after another.
    counts : (P,) int64
        Vertices per polygon, each at least 3.
    name : str
        The file's name, for the warning.
    lines : (P,) int64
        Each polygon's line in the file, for the warning.

    Returns
    -------
    (sum(counts - 2), 3) int64
        The order trimesh's ``triangulate_quads`` gives (the OFF colours' mapping relies on it):
        the triangles, then every quad's first triangle, then every quad's second, then each larger
        polygon's ``k - 2`` triangles in the file's order. A convex polygon keeps trimesh's split
        (a quad ``(0, 1, 2), (2, 3, 0)``, a larger one the fan ``(0, i, i + 1)``); a non-convex one
        is ear-clipped (as many triangles, in the same places).

    Warns
    -----
    DroppedOnLoadWarning
        One for the file, naming the line of each degenerate polygon (as :func:`ear_clip_obj`).
    """
    offsets = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    parts, larger, notes = {}, [], []
    for k in (int(c) for c in np.unique(counts)):
        group = np.flatnonzero(counts == k)
        idx = flat[offsets[group][:, None] + np.arange(k)]
        if k == 3:
            parts[3] = idx
            continue
        local = (np.array([[0, 1, 2], [2, 3, 0]]) if k == 4 else
                 np.stack([np.zeros(k - 2, np.int64), np.arange(1, k - 1), np.arange(2, k)], axis=1))
        local = np.repeat(local[None], len(group), axis=0)
        normal, convex, why = _classify(positions[idx], idx)
        for j in np.flatnonzero(~convex | (why != "")):
            note = why[j]
            if not convex[j]:
                tris, crossing = _ear_clip(positions[idx[j]], normal[j])
                if tris is not None and len(tris) == k - 2:
                    local[j] = tris
                note = "; ".join(w for w in (note, crossing) if w)
            if note:
                notes.append((int(lines[group[j]]), note))
        tris = idx[np.arange(len(group))[:, None, None], local]  # (P, k - 2, 3) vertex indices
        if k == 4:
            parts[4] = tris
        else:
            larger += list(zip(group.tolist(), tris))
    if notes:
        notes.sort()
        shown = "; ".join(f"line {n} ({why})" for n, why in notes[:8])
        more = f"; and {len(notes) - 8} more" if len(notes) > 8 else ""
        warnings.warn(f"{name}: {len(notes)} degenerate polygon(s), triangulated as written: {shown}{more}",
                      DroppedOnLoadWarning, stacklevel=5)
    out = [parts.get(3, np.zeros((0, 3), np.int64))]
    if 4 in parts:
        out += [parts[4][:, 0], parts[4][:, 1]]
    out += [t for _, t in sorted(larger, key=lambda gt: gt[0])]
    return np.concatenate(out).astype(np.int64) if out else np.zeros((0, 3), np.int64)
