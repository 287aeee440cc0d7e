"""A PLY file's header, and its rows (ASCII or binary), checked against each other before trimesh reads it.

trimesh reads an ASCII PLY's values as one stream: a face line cut short (``3 1``) borrows the next
row's values or comes out as a face the file does not have, rows beyond the header's counts are
passed over, and a malformed header stops it with an IndexError. Each of these is named here with the
file and line, before any reader runs. A binary body is walked element by element: a face whose list
count is wrong (under 3, or running past the end of the file) or that indexes a vertex the file does
not have is named by its number, checked at NumPy speed where every row of an element has the same
list lengths (the common case: all triangles), else row by row.
"""

from __future__ import annotations

import os
import warnings

import numpy as np

from ..common.warnings import DroppedOnLoadWarning

__all__ = ["check_ply"]

_TYPES = {"char", "uchar", "short", "ushort", "int", "uint", "float", "double", "int8", "uint8", "int16",
          "uint16", "int32", "uint32", "float32", "float64"}
_FORMATS = ("ascii", "binary_little_endian", "binary_big_endian")
_INDICES = ("vertex_indices", "vertex_index")


def check_ply(path: str) -> None:
    """Refuse a PLY whose header is malformed or whose ASCII rows do not match it.

    The header: ``format`` one of ascii/binary_little_endian/binary_big_endian, each ``element`` a name
    and a count >= 0, each ``property`` a known type (lists: two), ``end_header``. An ASCII body: one
    row per line, each with the values its element's properties give (a list: its count, then that
    many), numbers throughout, face indices in ``[0, vertices)``, as many rows as the header declares.

    A binary body: each face's list count at least 3, its indices in ``[0, vertices)``, every row within
    the file.

    Raises
    ------
    ValueError
        Naming the file and line (binary: the face's number).

    Warns
    -----
    DroppedOnLoadWarning
        Lines after the rows the header declares (no reader reads them).
    """
    name = os.path.basename(path)
    with open(path, "rb") as fh:
        data = fh.read()
    lines = data.split(b"\n")
    elements, fmt, end = _header(lines, name)
    if fmt != "ascii":
        _check_binary(data, len(b"\n".join(lines[:end + 1])) + 1, lines[:end], "<" if "little" in fmt else ">", name)
        return
    body = [(i + 1, ln.split()) for i, ln in enumerate(lines[end + 1:], end + 1)]
    body = [(n, t) for n, t in body if t and t[0] != b"comment"]
    nv = next((count for ename, count, _ in elements if ename == "vertex"), 0)
    at = 0
    for ename, count, props in elements:
        rows = body[at:at + count]
        if len(rows) < count:
            where = f"{name}:{rows[-1][0] if rows else len(lines)}"
            raise ValueError(f"{where}: the header declares {count} {ename} row(s), the file has {len(rows)} "
                             "(is it cut short?)")
        if not _table_ok(rows, ename, props, nv):
            trailing = [(line, extra) for k, (line, tokens) in enumerate(rows)  # line by line: the first bad one
                        if (extra := _row(name, line, ename, k, tokens, props, nv))]
            if trailing:  # values after the declared ones: readers take the leading columns (trimesh's corpus has such files)
                warnings.warn(f"{name}:{trailing[0][0]}: {len(trailing)} {ename} row(s) carry values after the ones its "
                              f"header declares ({trailing[0][1]} on this line); ignored", DroppedOnLoadWarning,
                              stacklevel=4)
        at += count
    if at < len(body):
        warnings.warn(f"{name}:{body[at][0]}: {len(body) - at} line(s) after the rows the header declares "
                      "(ignored: no element holds them)", DroppedOnLoadWarning, stacklevel=4)


def _header(lines: list, name: str):
    """``([(element, count, [(kind, type, name)])], format, index of the end_header line)``."""
    elements, fmt = [], None
    for i, raw in enumerate(lines):
        t = raw.decode("latin-1").split()
        where = f"{name}:{i + 1}"
        if not t or t[0] in ("ply", "comment", "obj_info"):
            continue
        if t[0] == "end_header":
            if fmt is None:
                raise ValueError(f"{where}: end_header before any 'format' line")
            return elements, fmt, i
        if t[0] == "format":
            if len(t) < 2 or t[1] not in _FORMATS:
                raise ValueError(f"{where}: format must be one of {', '.join(_FORMATS)}, got {' '.join(t[1:])!r}")
            fmt = t[1]
        elif t[0] == "element":
            if len(t) != 3 or not t[2].isdigit():
                raise ValueError(f"{where}: expected 'element NAME COUNT' (COUNT an integer >= 0), got "
                                 f"{' '.join(t)!r}")
            elements.append((t[1], int(t[2]), []))
        elif t[0] == "property":
            kinds = t[2:4] if len(t) == 5 and t[1] == "list" else t[1:2] if len(t) == 3 else None
            if not elements or not kinds or not set(kinds) <= _TYPES:
                raise ValueError(f"{where}: expected 'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME' "
                                 f"after an element (types: {', '.join(sorted(_TYPES))}), got {' '.join(t)!r}")
            elements[-1][2].append(("list" if len(kinds) == 2 else "scalar", kinds[-1], t[-1]))
        else:
            raise ValueError(f"{where}: {t[0]!r} is not a PLY header keyword (element, property, format, comment; "
                             "is end_header missing?)")
    raise ValueError(f"{name}: no end_header line (is the file cut short?)")


def _table_ok(rows: list, ename: str, props: list, nv: int) -> bool:
    """Whether an element's rows are all valid, checked as one table (rows of one length, at most one
    list, of one count throughout: the common case); False leaves it to the line-by-line check."""
    lists = [i for i, (kind, _, _) in enumerate(props) if kind == "list"]
    if not rows or len(lists) > 1:
        return not rows
    try:
        nums = np.array([t for _, t in rows]).astype(np.float64)
    except ValueError:  # ragged rows, or a value that is not a number
        return False
    extra = nums.shape[1] - len(props)  # a list's values beyond its count column
    if nums.ndim != 2 or extra < 0 or (not lists and extra) or (lists and np.any(nums[:, lists[0]] != extra)):
        return False
    at = 0
    for kind, typ, prop in props:
        cols = nums[:, at + 1:at + 1 + extra] if kind == "list" else nums[:, at:at + 1]
        at += 1 + extra if kind == "list" else 1
        if typ not in ("float", "double", "float32", "float64") and (not np.isfinite(cols).all()
                                                                       or np.any(cols != np.round(cols))):
            return False
        if ename == "face" and prop in _INDICES and cols.size and (cols.min() < 0 or cols.max() >= nv):
            return False
    return True


def _row(name: str, line: int, ename: str, k: int, tokens: list, props: list, nv: int) -> int:
    """One ASCII row checked against its element's properties; returns how many values follow the
    declared ones (0 for an exact row)."""
    at = 0
    for kind, typ, prop in props:
        want = f"{ename} {k}: {prop}"
        if at >= len(tokens):
            raise ValueError(f"{name}:{line}: {want}: missing (the row has {len(tokens)} value(s); is it cut short?)")
        if kind == "list":
            try:
                n = int(tokens[at])
            except ValueError:
                raise ValueError(f"{name}:{line}: {want}: the list's count {tokens[at].decode(errors='replace')!r} "
                                 "is not an integer") from None
            values = tokens[at + 1:at + 1 + n]
            if n < 0 or len(values) < n:
                raise ValueError(f"{name}:{line}: {want}: the list says {n} value(s), the row has {len(values)} "
                                 "(is it cut short?)")
            at += 1 + n
        else:
            values = tokens[at:at + 1]
            at += 1
        try:
            nums = np.array([float(v) for v in values], np.float64)
        except ValueError:
            raise ValueError(f"{name}:{line}: {want}: {b' '.join(values).decode(errors='replace')!r} is not a "
                             "number") from None
        if typ not in ("float", "double", "float32", "float64") and len(nums) and (
                not np.isfinite(nums).all() or np.any(nums != np.round(nums))):
            raise ValueError(f"{name}:{line}: {want}: {typ} values must be integers")
        if ename == "face" and prop in _INDICES and len(nums) and (nums.min() < 0 or nums.max() >= nv):
            bad = int(nums[(nums < 0) | (nums >= nv)][0])
            raise ValueError(f"{name}:{line}: face {k} indexes vertex {bad}, but the file has {nv} vertices "
                             "(PLY indices start at 0)")
    return len(tokens) - at  # values after the declared ones (the caller warns)


_BINARY = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4", "uint": "u4", "float": "f4",
           "double": "f8", "int8": "i1", "uint8": "u1", "int16": "i2", "uint16": "u2", "int32": "i4", "uint32": "u4",
           "float32": "f4", "float64": "f8"}


def _check_binary(data: bytes, at: int, header: list, endian: str, name: str) -> None:
    """Every element's rows of a binary body walked from byte ``at``; faces checked (see :func:`check_ply`).
    ``header``: the header's lines (checked by :func:`_header`), read again for the lists' count types."""
    elements = []  # [name, count, [(kind, value dtype, count dtype or None, property)]]
    for raw in header:
        t = raw.decode("latin-1").split()
        if t[:1] == ["element"]:
            elements.append((t[1], int(t[2]), []))
        elif t[:1] == ["property"]:
            value = np.dtype(endian + _BINARY[t[-2]])
            counter = np.dtype(endian + _BINARY[t[2]]) if t[1] == "list" else None
            elements[-1][2].append(("list" if counter is not None else "scalar", value, counter, t[-1]))
    nv = next((count for ename, count, _ in elements if ename == "vertex"), 0)
    for ename, count, layout in elements:
        at = _rows(data, at, ename, count, layout, nv, name)


def _rows(data: bytes, at: int, ename: str, count: int, layout: list, nv: int, name: str) -> int:
    """The end of an element's ``count`` rows starting at byte ``at``; its faces checked."""
    if not count:
        return at
    first, sizes = at, []  # row 0's list lengths: the guess every row shares
    for kind, dt, ct, _ in layout:
        if kind == "list":
            if first + ct.itemsize > len(data):
                break
            sizes.append(int(np.frombuffer(data, ct, 1, first)[0]))
            first += ct.itemsize + sizes[-1] * dt.itemsize
        else:
            first += dt.itemsize
    stride = first - at
    if len(sizes) == sum(kind == "list" for kind, *_ in layout) and stride > 0 and at + count * stride <= len(data):
        rows = np.lib.stride_tricks.as_strided(np.frombuffer(data, np.uint8, count * stride, at), (count, stride),
                                               (stride, 1))
        off, same, columns = 0, True, {}
        for (kind, dt, ct, prop), n in zip(layout, _list_sizes(layout, sizes)):
            if kind == "list":
                same &= bool(np.all(rows[:, off:off + ct.itemsize].copy().view(ct).reshape(-1) == n))
                off += ct.itemsize
                columns[prop] = (off, n, dt)
                off += n * dt.itemsize
            else:
                off += dt.itemsize
        if same:
            if ename == "face":
                for prop in _INDICES:
                    if prop in columns:
                        o, n, dt = columns[prop]
                        _face_indices(rows[:, o:o + n * dt.itemsize].copy().view(dt).reshape(count, n), 0, nv, name)
            return at + count * stride
    for k in range(count):  # lists of different lengths (or a count that runs off the file): row by row
        for kind, dt, ct, prop in layout:
            n = 1
            if kind == "list":
                if at + ct.itemsize > len(data):
                    raise ValueError(f"{name}: {ename} {k}: the file ends inside it (cut short, or a wrong list count "
                                     "before it)")
                n = int(np.frombuffer(data, ct, 1, at)[0])
                at += ct.itemsize
            if at + n * dt.itemsize > len(data):
                raise ValueError(f"{name}: {ename} {k}: {prop}: the list says {n} value(s), and the file ends before "
                                 "them (cut short, or a wrong count)")
            if ename == "face" and prop in _INDICES:
                if n < 3:
                    raise ValueError(f"{name}: face {k}: {prop}: a list of {n} index(es) (a face needs 3 or more; a "
                                     "wrong count?)")
                _face_indices(np.frombuffer(data, dt, n, at).reshape(1, n), k, nv, name)
            at += n * dt.itemsize
    return at


def _list_sizes(layout: list, sizes: list) -> list:
    """Per property, its list length (row 0's) or 1 for a scalar."""
    it = iter(sizes)
    return [next(it) if kind == "list" else 1 for kind, *_ in layout]


def _face_indices(idx: np.ndarray, first: int, nv: int, name: str) -> None:
    """Refuse a face (row ``first + r`` of ``idx``, (F, n)) with fewer than 3 indices or one outside ``[0, nv)``."""
    if idx.shape[1] < 3:
        raise ValueError(f"{name}: face {first}: a list of {idx.shape[1]} index(es) (a face needs 3 or more; a wrong "
                         "count?)")
    bad = (idx < 0) | (idx >= nv)
    if bad.any():
        r = int(np.argmax(bad.any(axis=1)))
        raise ValueError(f"{name}: face {first + r} indexes vertex {int(idx[r][bad[r]][0])}, but the file has {nv} "
                         "vertices (PLY indices start at 0)")
