"""A PLY file's header, and an ASCII PLY's rows, checked against each other before trimesh reads it.

trimesh reads an ASCII PLY's values as one stream: a face line cut short (``3 1``) borrows the next
row's values or comes out as a face the file does not have, rows beyond the header's counts are
passed over, and a malformed header stops it with an IndexError. Each of these is named here with the
file and line, before any reader runs.
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

    Raises
    ------
    ValueError
        Naming the file and line.

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
            for k, (line, tokens) in enumerate(rows):  # line by line, to name the first bad one
                _row(name, line, ename, k, tokens, props, nv)
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


def _row(name: str, line: int, ename: str, k: int, tokens: list, props: list, nv: int) -> None:
    """One ASCII row checked against its element's properties."""
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
    if at != len(tokens):
        raise ValueError(f"{name}:{line}: {ename} {k}: {len(tokens)} values where its properties take {at}")
