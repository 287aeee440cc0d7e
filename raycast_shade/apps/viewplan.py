"""The plan of a view set and the records of its views: what makes a resume honest.

``plan.json`` (:func:`prepare_folder`) is written before any view: the
settings every view's files depend on and, per view, the hashes of its scene,
camera and lights (:func:`view_hashes`). Each view's record
(:func:`write_record`, ``view_{i:05d}.json``) is written after its files:
the view's key (:func:`view_key`) and each file's size and BLAKE2b digest. A
view is done (:func:`view_is_done`) only if its record holds the current key
and every file it lists is intact. :mod:`raycast_shade.apps.views` uses
these; see its docstring.
"""

from __future__ import annotations

import hashlib
import json
import os
import re

from ..output.imagefile import atomic_target
from .batch.plan import _digest

__all__ = ["PLAN_NAME", "PLAN_FORMAT", "FILE_HASH", "digest", "file_hasher", "view_hashes", "view_key", "view_is_done",
           "write_record", "plan_differences", "prepare_folder", "write_json"]

PLAN_NAME = "plan.json"
PLAN_FORMAT = "raycast_shade view set plan 1"
_OURS = re.compile(r"^view_\d{5}(\.|_depth\.png$)")  # files of some view set (any plan)


def digest(obj) -> str:
    """32 hex digits of BLAKE2b over ``obj``'s content (arrays, dataclasses, containers)."""
    h = hashlib.blake2b(digest_size=16)
    _digest(obj, h)
    return h.hexdigest()


FILE_HASH = "sha256"  # a record's key for each file's digest


def file_hasher():
    """The hash of a view's files in its record (SHA-256: what ``sha256sum`` prints), fresh.

    SHA-256 rather than BLAKE2b: on CPUs with SHA extensions it hashes in about a third of
    BLAKE2b's time (this project's machines: 1.7 against 0.63 GB/s), and anyone can check a file
    with ``sha256sum``. Records written with BLAKE2b (16 bytes, key ``"blake2b"``) are still
    checked with it (:func:`view_is_done`)."""
    return hashlib.sha256()


# The digests a record may hold, by its key: the current one and the one of older records.
_HASHERS = {FILE_HASH: file_hasher, "blake2b": lambda: hashlib.blake2b(digest_size=16)}


def _file_digest(path, algorithm: str = FILE_HASH) -> str:
    h = _HASHERS[algorithm]()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def view_hashes(job) -> dict:
    """What view ``job`` is rendered from, as hashes: its scene's models, camera, lights and colours."""
    return {"scene": job.key, "camera": digest(job.camera),
            "lights": digest((job.lights, job.ambient, job.background))}


def view_key(settings_hash: str, job) -> str:
    """One hash of everything a view's files depend on (settings and the view's own inputs)."""
    return digest((settings_hash, job.index, tuple(sorted(view_hashes(job).items()))))


def view_is_done(files: dict, key: str) -> bool:
    """True if the view's record holds ``key`` and every file it lists is there, byte for byte."""
    try:
        with open(files["record"]) as fh:
            record = json.load(fh)
        if record.get("key") != key:
            return False
        listed = record["files"]
        for kind, path in files.items():
            if kind == "record":
                continue
            entry = listed[os.path.basename(path)]
            algorithm = next((a for a in _HASHERS if a in entry), None)
            if algorithm is None:  # no digest this version knows
                return False
            size = os.path.getsize(path)
            if size == 0 or size != entry["bytes"] or _file_digest(path, algorithm) != entry[algorithm]:
                return False
        return True
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return False


def write_record(files: dict, key: str, job, objects, written: dict | None = None) -> None:
    """Write view ``job``'s record (last, atomically): ``key``, its camera, each file's size and
    digest, and its ``objects``.

    ``written`` maps a file's path to ``(bytes, digest)`` taken as it was written
    (:func:`raycast_shade.output.imagefile.write_hashed` with :func:`file_hasher`); the files it
    does not hold are read back and hashed here.
    """
    K, R, t = job.camera.to_opencv()
    written = dict(written or {})
    paths = [p for kind, p in files.items() if kind != "record"]
    missing = [p for p in paths if p not in written]
    if missing:
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(len(missing)) as pool:  # hashlib releases the GIL on large blocks
            for p, d in zip(missing, pool.map(_file_digest, missing)):
                written[p] = (os.path.getsize(p), d)
    entries = {os.path.basename(p): {"bytes": int(written[p][0]), FILE_HASH: written[p][1]} for p in paths}
    record = {"index": job.index, "key": key, "K": K.tolist(), "R": R.tolist(), "t": t.tolist(), "files": entries,
              "objects": objects}
    with atomic_target(files["record"]) as tmp, open(tmp, "w") as fh:
        json.dump(record, fh, indent=1)


def _plural(n: int, word: str) -> str:
    return f"{n} {word}" + ("" if n == 1 else "s")


def _plan_problem(old) -> str | None:
    """Why ``old`` (a plan.json as read) is not a plan this version reads, in words; None if it is."""
    if not isinstance(old, dict):
        return f"{PLAN_NAME} holds a JSON {type(old).__name__}, not an object"
    if old.get("format") != PLAN_FORMAT:
        return f"{PLAN_NAME} has format {json.dumps(old.get('format'))}, not {json.dumps(PLAN_FORMAT)}"
    for key, kind in (("settings", dict), ("views", list)):
        if not isinstance(old.get(key), kind):
            return f"{PLAN_NAME}'s {key!r} is not a JSON {'object' if kind is dict else 'list'}"
    bad = next((i for i, v in enumerate(old["views"]) if not isinstance(v, dict)), None)
    if bad is not None:
        return f"{PLAN_NAME}'s views[{bad}] is not a JSON object"
    return None


def plan_differences(old: dict, new: dict) -> list:
    """What differs between two plans, in words (empty: the same plan); a plan.json that is not one
    (edited by hand, say) is one difference saying what is wrong with it."""
    problem = _plan_problem(old)
    if problem is not None:
        return [problem + " (edited by hand?)"]
    out = []
    a, b = old.get("settings", {}), new["settings"]
    for k in sorted(set(a) | set(b)):
        if a.get(k) != b.get(k):
            out.append(f"{k} {json.dumps(a.get(k))} -> {json.dumps(b.get(k))}")
    va, vb = old["views"], new["views"]
    if len(va) != len(vb):
        out.append(f"{_plural(len(va), 'view')} -> {len(vb)}")
    shared = list(zip(va, vb))
    for field, what in (("scene", "scene (meshes or materials)"), ("camera", "camera"),
                        ("lights", "lights or colours")):
        n = sum(x.get(field) != y[field] for x, y in shared)
        if n:
            out.append(f"the {what} of {n} of the {_plural(len(shared), 'shared view')} differs")
    sizes = [(f"{x.get('width')}x{x.get('height')}", f"{y['width']}x{y['height']}") for x, y in shared]
    changed = sorted({f"{p} -> {q}" for p, q in sizes if p != q})
    if changed:
        out.append("size " + ", ".join(changed))
    return out


def prepare_folder(out_dir: str, plan: dict, overwrite: bool, set_files) -> None:
    """Check ``out_dir`` against ``plan`` (refusing another plan unless ``overwrite``), then write the plan.

    ``set_files`` are the set-level names (the index, the exports). Under ``overwrite``, the other
    plan's files go, except those of views with the same hashes and file names (their records are
    checked again before they are skipped).
    """
    plan_path = os.path.join(out_dir, PLAN_NAME)
    set_files = set(set_files)
    ours = sorted(n for n in os.listdir(out_dir) if _OURS.match(n))
    ours += sorted(n for n in set_files if os.path.exists(os.path.join(out_dir, n)))
    old = None
    if os.path.isdir(plan_path):  # not replaceable by a file, overwrite or not
        raise ValueError(f"out_dir: {plan_path!r} is a folder; the view set writes its plan there")
    if os.path.exists(plan_path):
        try:
            with open(plan_path, encoding="utf-8") as fh:
                old = json.load(fh)
            differences = plan_differences(old, plan)
        except (OSError, ValueError) as exc:  # UnicodeDecodeError and JSONDecodeError are ValueErrors
            differences = [f"{PLAN_NAME} cannot be read as JSON ({exc})"]
    elif ours:
        differences = [f"{_plural(len(ours), 'view set file')} (e.g. {ours[0]}) but no {PLAN_NAME} "
                       "(deleted?); without it nothing tells which plan they were made for"]
    else:
        differences = []
    if not differences:
        return write_json(plan_path, plan)
    if not overwrite:
        raise ValueError(f"out_dir: {out_dir} holds another view set: {'; '.join(differences)}. "
                         "Pass overwrite=True (CLI: --overwrite) to replace it, or choose another folder")
    keep = set()
    if _plan_problem(old) is None and not plan_differences({**old, "views": []}, {**plan, "views": []}):
        # Same settings: views with the same inputs and files stay (their records are checked later).
        for x, y in zip(old.get("views", []), plan["views"]):
            if isinstance(x, dict) and all(x.get(k) == y[k] for k in ("scene", "camera", "lights", "files")):
                keep.update(y["files"].values())
    listed = _listed_files(old)
    for name in ours:
        # The other plan's own files (all view-set-like names when that plan cannot be read).
        if name not in keep and (listed is None or name in listed or name in set_files):
            os.unlink(os.path.join(out_dir, name))
    write_json(plan_path, plan)


def _listed_files(plan):
    """The view file names a plan lists, or None if it cannot be read as a plan."""
    try:
        return {n for v in plan["views"] for n in v["files"].values()}
    except (TypeError, KeyError, AttributeError):
        return None


def write_json(path, obj) -> None:
    with atomic_target(path) as tmp, open(tmp, "w") as fh:
        json.dump(obj, fh, indent=1)
