"""The Khronos glTF samples that exercise geometry trimesh reads wrong: per file loaded / right / warned / refused.

``python benchmarks/corpus_check.py geometry FOLDER [--out CSV]``, FOLDER a copy of the samples' ``2.0``
folder (KhronosGroup/glTF-Sample-Models). Two kinds of check, neither using the loader's own code:

* **closed form** for the samples whose shape their README states: MeshPrimitiveModes (three hexagons of
  area 3 sqrt(3) / 2 facing +z: triangles, strip, fan; points and lines skipped with a warning),
  SimpleMorph (at its weights 0.5, 0.5 the apex stands at y = 1.5), AnimatedMorphCube and
  AnimatedMorphSphere (weights 0: the base shape, 2 units across), SimpleSparseAccessor (the sparse rows
  lift the peaks to y = 4), TriangleWithoutIndices (one triangle);
* **against the plain variant** for every ``glTF-Draco``, ``glTF-Quantized``, ``glTF-Meshopt`` and
  ``glTF-pbrSpecularGlossiness`` variant present: the same bounding box (to 1% of its diagonal) and
  surface area (to 1%) as the sample's ``glTF`` variant; a spec-gloss variant whose materials give a
  ``diffuseTexture`` also has a model with a ``kd_map`` (the diffuse image was read, not a factor alone). ``EXT_meshopt_compression`` is not applied: those are expected refused.

Whether the colours look right is not judged here: the contact sheet (``docs/figures/samples.py``) shows
each file beside its reference screenshot for the eye.

A file is **right** when it loads and its check holds, or when it is refused where a refusal is expected.
"""

from __future__ import annotations

import csv
import os
import sys
import warnings

import numpy as np

HEX_AREA = 3 * np.sqrt(3) / 2  # the file writes sqrt(3)/2 as 0.866: its hexagons are 3e-5 smaller


def _area(models) -> float:
    total = 0.0
    for m in models:
        v, f = m.mesh.vertices, m.mesh.faces
        total += 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum()
    return float(total)


def _bbox(models) -> np.ndarray:
    v = np.concatenate([m.mesh.vertices for m in models])
    return np.array([v.min(0), v.max(0)])


def _modes(models) -> str:
    areas = sorted(_area([m]) for m in models)
    facing = all((np.cross(m.mesh.vertices[m.mesh.faces[:, 1]] - m.mesh.vertices[m.mesh.faces[:, 0]],
                           m.mesh.vertices[m.mesh.faces[:, 2]] - m.mesh.vertices[m.mesh.faces[:, 0]])[:, 2] > 0).all()
                 for m in models)
    ok = len(models) == 3 and np.allclose(areas, HEX_AREA, rtol=1e-4) and facing
    return "" if ok else f"{len(models)} models, areas {np.round(areas, 4).tolist()}, all facing +z: {facing}"


def _height(want: float):
    def check(models) -> str:
        h = float(np.ptp(np.concatenate([m.mesh.vertices[:, 1] for m in models])))
        return "" if abs(h - want) <= 1e-4 * max(1.0, want) else f"height {h:.4f}, expected {want}"
    return check


def _extent(want: float):
    def check(models) -> str:
        box = _bbox(models)
        size = float((box[1] - box[0]).max())
        return "" if abs(size - want) <= 1e-3 * want else f"extent {size:.4f}, expected {want}"
    return check


def _faces(want: int):
    def check(models) -> str:
        n = sum(len(m.mesh.faces) for m in models)
        return "" if n == want else f"{n} faces, expected {want}"
    return check


CLOSED_FORM = {
    "MeshPrimitiveModes/glTF/MeshPrimitiveModes.gltf": _modes,
    "MeshPrimitiveModes/glTF-Embedded/MeshPrimitiveModes.gltf": _modes,
    "SimpleMorph/glTF/SimpleMorph.gltf": _height(1.5),
    "SimpleMorph/glTF-Embedded/SimpleMorph.gltf": _height(1.5),
    "AnimatedMorphCube/glTF/AnimatedMorphCube.gltf": _extent(2.0),
    "AnimatedMorphCube/glTF-Binary/AnimatedMorphCube.glb": _extent(2.0),
    "AnimatedMorphSphere/glTF/AnimatedMorphSphere.gltf": _extent(2.0),
    "AnimatedMorphSphere/glTF-Binary/AnimatedMorphSphere.glb": _extent(2.0),
    "SimpleSparseAccessor/glTF/SimpleSparseAccessor.gltf": _height(4.0),
    "SimpleSparseAccessor/glTF-Embedded/SimpleSparseAccessor.gltf": _height(4.0),
    "TriangleWithoutIndices/glTF/TriangleWithoutIndices.gltf": _faces(1),
    "TriangleWithoutIndices/glTF-Embedded/TriangleWithoutIndices.gltf": _faces(1),
}
VARIANTS = ("glTF-Draco", "glTF-Quantized", "glTF-Meshopt", "glTF-pbrSpecularGlossiness")
REFUSED = ("glTF-Meshopt",)  # EXT_meshopt_compression is required there and not applied


def _load(path):
    import raycast_shade as rs

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            models, error = rs.load_models(path), ""
        except ValueError as exc:
            models, error = None, str(exc)
    return models, error, [str(w.message) for w in caught]


def _plain(folder: str, rel: str):
    """The sample's plain ``glTF`` variant beside variant ``rel`` (the first mesh file in it), or None."""
    sample = rel.split(os.sep)[0]
    plain = os.path.join(folder, sample, "glTF")
    names = sorted(n for n in os.listdir(plain) if n.endswith((".gltf", ".glb"))) if os.path.isdir(plain) else []
    return os.path.join(plain, names[0]) if names else None


def _diffuse_maps(path, models) -> str:
    """Why the diffuse images look unread: the file's spec-gloss materials give a ``diffuseTexture`` and no
    model has a ``kd_map`` (a coarse check: the images were read, not which model took which)."""
    import json

    if not path.endswith(".gltf"):
        return ""
    with open(path, encoding="utf-8") as fh:
        js = json.load(fh)
    textured = sum("diffuseTexture" in ((m.get("extensions") or {}).get("KHR_materials_pbrSpecularGlossiness") or {})
                   for m in js.get("materials") or [])
    mapped = sum(m.material.kd_map is not None for m in models)
    return f"{textured} material(s) with a diffuseTexture, no model with a kd_map" if textured and not mapped else ""


def _against_plain(models, reference) -> str:
    ref, _, _ = _load(reference)
    if ref is None:
        return "the plain variant does not load"
    box, want = _bbox(models), _bbox(ref)
    diag = float(np.linalg.norm(want[1] - want[0]))
    moved = float(np.abs(box - want).max())
    area, ref_area = _area(models), _area(ref)
    if moved > 0.01 * diag or abs(area - ref_area) > 0.01 * ref_area:
        return f"bbox off by {moved:.4g} (diagonal {diag:.4g}), area {area:.4g} vs {ref_area:.4g}"
    return ""


def files(folder: str) -> list:
    """``(relative path, kind)`` of every file this check covers that ``folder`` holds."""
    out = [(rel, "closed form") for rel in CLOSED_FORM if os.path.exists(os.path.join(folder, rel))]
    for sample in sorted(os.listdir(folder)) if os.path.isdir(folder) else []:
        for variant in VARIANTS:
            d = os.path.join(folder, sample, variant)
            if os.path.isdir(d):
                out += [(os.path.join(sample, variant, n), "vs plain") for n in sorted(os.listdir(d))
                        if n.endswith((".gltf", ".glb"))]
    return out


def check(folder: str, rel: str, kind: str) -> dict:
    """One row: ``file``, ``loaded``, ``right``, ``warned``, ``refused`` (the message), ``why`` (what differs)."""
    path = os.path.join(folder, rel)
    models, error, notes = _load(path)
    expect_refusal = any(f"{os.sep}{v}{os.sep}" in path for v in REFUSED)
    if models is None:
        why = "" if expect_refusal else "refused"
    elif kind == "closed form":
        why = CLOSED_FORM[rel](models)
    else:
        reference = _plain(folder, rel)
        why = _against_plain(models, reference) if reference else "no plain glTF variant to compare with"
        why = why or (_diffuse_maps(path, models) if "pbrSpecularGlossiness" in rel else "")
        why = why or ("loaded, but a refusal was expected" if expect_refusal else "")
    return {"file": rel, "loaded": models is not None, "right": not why, "warned": bool(notes),
            "refused": error.replace(folder + os.sep, ""), "why": why,
            "warnings": " | ".join(n.replace(folder + os.sep, "") for n in notes)}


def _class(rel: str) -> str:
    """The file class a sample exercises, from its name and variant."""
    for key, name in (("pbrSpecularGlossiness", "spec-gloss"), ("Draco", "Draco"), ("Quantized", "quantized"),
                      ("Meshopt", "meshopt"), ("Morph", "morph"), ("Sparse", "sparse accessor")):
        if key in rel:
            return name
    return "primitive modes"


def main(argv) -> int:
    """``geometry FOLDER [--out CSV] [--markdown]``: print one line per file and the counts (and with
    ``--markdown`` the table of docs/files.md); 1 unless all are right."""
    if not argv or argv[0].startswith("-"):
        print("usage: corpus_check.py geometry FOLDER [--out CSV] [--markdown]", file=sys.stderr)
        return 2
    folder = os.path.abspath(argv[0])
    out = argv[argv.index("--out") + 1] if "--out" in argv else None
    rows = [check(folder, rel, kind) for rel, kind in files(folder)]
    for r in rows:
        state = "right" if r["right"] else "WRONG"
        print(f"{state:<6} loaded={'yes' if r['loaded'] else 'no ':<3} warned={'yes' if r['warned'] else 'no ':<3} "
              f"{r['file']}  {r['why'] or r['refused'][:100]}")
    print(f"{len(rows)} files: loaded {sum(r['loaded'] for r in rows)}, right {sum(r['right'] for r in rows)}, "
          f"warned {sum(r['warned'] for r in rows)}, refused {sum(not r['loaded'] for r in rows)}")
    if "--markdown" in argv:  # the table of docs/files.md
        print("\n| file | class | loaded | right (automatic check) | warned | refused |\n|---|---|---|---|---|---|")
        for r in rows:
            yes = {True: "yes", False: "no"}
            print(f"| {r['file']} | {_class(r['file'])} | {yes[r['loaded']]} | {yes[r['right']]}"
                  f"{' (' + r['why'] + ')' if r['why'] else ''} | {yes[r['warned']]} | {r['refused'] or '-'} |")
    if out:
        with open(out, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]) if rows else ["file"])
            w.writeheader()
            w.writerows(rows)
    return 0 if all(r["right"] for r in rows) else 1
