"""Load and render every mesh file under a folder; check each pixel's colour against trimesh's own lookup.

``python benchmarks/corpus_check.py FOLDER --out DIR [--size 256] [--gltf-variants glTF,glTF-Binary]``;
``python -m benchmarks.corpus_check [--quick]`` (as ``python -m benchmarks`` runs it) checks a few small
files it writes itself;
``python benchmarks/corpus_check.py summary NAME BEFORE.csv AFTER.csv [...]`` prints the tables of
``docs/files.md``; ``python benchmarks/corpus_check.py sheet DIR`` redraws ``DIR/sheet.png``;
``python benchmarks/corpus_check.py geometry FOLDER`` checks the Khronos samples of glTF geometry
(modes, morph targets, sparse, Draco, quantized; :mod:`benchmarks.corpus_geometry`).

For each mesh file (OBJ, glTF/GLB, PLY, OFF, STL, archives, and whatever else
trimesh reads) it loads the models with :func:`raycast_shade.load_models`
(recording every warning), frames them with ``Camera.fit`` (a headlight and a
key light, Phong), renders, and, for files with a texture or colours, compares
the colour source under each hit pixel with trimesh's own at the same surface
point: the hit buffer's triangle id and barycentrics give the point; our side
is the loaded model's texture (NumPy bilinear, level 0, with its wrap and
tiling, at the mesh's UVs) times its factor, or its mesh colours; trimesh's
side interpolates trimesh's UVs at the same corners, folds them by the file's
glTF sampler (trimesh's lookup only repeats) and samples trimesh's material
image with ``trimesh.visual.color.uv_to_interpolated_color``, times the
file's factor, or takes trimesh's vertex or face colours. The error is the
largest channel difference in sRGB-encoded units (0..1); per file the median
over hit pixels.

Writes into ``DIR``: ``corpus.csv`` (one row per file: loads, models, faces,
colour source, median error, warnings, verdict), ``sheet.png`` (a contact
sheet of every render, labelled), and one ``renders/NAME.png`` each. With
``--screenshots``, also ``side_by_side.png``: our render next to each glTF
sample's ``screenshot/screenshot.png``.

Verdicts: ``right`` (renders something, and the colour error is <= 0.01 or
the file has no colour source), ``wrong (warned)`` when a warning names
what differs, ``wrong (silent)`` otherwise; ``fails`` when it does not load.

The code under test is whatever ``raycast_shade`` imports: run it with
``PYTHONPATH`` pointing at another checkout to count "before". Renders small
images at low priority: the corpora hold 2048 x 2048 textures.
"""

from __future__ import annotations

import argparse
import csv
import os
import signal
import sys
import time
import warnings

import numpy as np

MESH_EXTS = (".obj", ".glb", ".gltf", ".ply", ".off", ".stl", ".zip", ".3mf", ".dae", ".zae", ".xaml", ".3dxml",
             ".bz2", ".tar.gz", ".ctm", ".msh", ".binvox", ".step", ".brep", ".xyz")
THRESHOLD = 0.01


def _files(folder: str, variants) -> list:
    out = []
    for root, dirs, files in os.walk(folder):
        dirs.sort()
        parts = os.path.relpath(root, folder).split(os.sep)
        if variants and any(p.startswith("glTF") for p in parts) and not any(p in variants for p in parts):
            continue
        for f in sorted(files):
            low = f.lower()
            if low.endswith(MESH_EXTS) and not low.endswith((".bin",)):
                out.append(os.path.join(root, f))
    return out


def _srgb(c):
    """The sRGB encoding (IEC 61966-2-1) of linear values, clipped to [0, 1]."""
    c = np.clip(np.asarray(c, np.float64), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.maximum(c, 0.0031308) ** (1 / 2.4) - 0.055)


def _sample(tex, uv):
    """Our texture's level 0 at (n, 2) UVs: bilinear, the texture's wrap and tiling (linear RGB)."""
    t = tex.texels.astype(np.float64)
    h, w = t.shape[:2]
    x = uv[:, 0] * tex.tiling[0] * w - 0.5
    y = uv[:, 1] * tex.tiling[1] * h - 0.5
    x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]

    def at(i, j):
        if tex.wrap == "clamp":
            return t[np.clip(i, 0, h - 1), np.clip(j, 0, w - 1)]
        return t[i % h, j % w]
    return ((1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1))
            + fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1)))


def _placeholder(mat) -> bool:
    """trimesh's 2 x 2 grey (100) image for UVs without a material."""
    image = getattr(mat, "image", None)
    if image is None or getattr(mat, "kwargs", None):
        return False
    a = np.asarray(image.convert("RGBA"))
    return a.shape[:2] == (2, 2) and bool(np.all(a.reshape(-1, 4) == (100, 100, 100, 255)))


def _fold(c, mode):
    if mode == "clamp":
        return np.clip(c, 0.0, 1.0)
    if mode == "mirror":
        p = np.mod(c, 2.0)
        return np.where(p < 1.0, p, 2.0 - p)
    return np.mod(c, 1.0)


def _items(tm):
    """(geometry, transform) per model, in load_models' order."""
    import trimesh

    if isinstance(tm, trimesh.Scene):
        out = []
        for node in tm.graph.nodes_geometry:
            transform, gname = tm.graph[node]
            g = tm.geometry.get(gname)
            if isinstance(g, trimesh.Trimesh) and len(g.faces):
                out.append((g, np.asarray(transform, np.float64)))
        return out
    return [(tm, np.eye(4))]


def _gltf_wraps(path, mat):
    """The glTF sampler's (wrapS, wrapT) of a trimesh PBR material's base texture, by the spec."""
    import json
    import struct

    names = {10497: "repeat", 33071: "clamp", 33648: "mirror"}
    try:
        if path.lower().endswith(".glb"):
            with open(path, "rb") as fh:
                head = fh.read(20)
                js = json.loads(fh.read(struct.unpack("<I", head[12:16])[0]))
        elif path.lower().endswith(".gltf"):
            with open(path) as fh:
                js = json.load(fh)
        else:
            return "repeat", "repeat"
        cands = [m for m in js.get("materials", []) if m.get("name") == getattr(mat, "name", None)] or \
            js.get("materials", [])
        info = (cands[0].get("pbrMetallicRoughness") or {}).get("baseColorTexture") if cands else None
        tex = js["textures"][info["index"]]
        smp = js["samplers"][tex["sampler"]] if "sampler" in tex else {}
        return names.get(smp.get("wrapS", 10497), "repeat"), names.get(smp.get("wrapT", 10497), "repeat")
    except (KeyError, IndexError, TypeError, ValueError, OSError):
        return "repeat", "repeat"


def colour_errors(path, models, frame):
    """(kind, errors (n,)) over the hit pixels whose model has a colour source; kind '' when none has."""
    import trimesh
    from trimesh.visual.color import uv_to_interpolated_color

    from raycast_shade.scene.mesh import read_trimesh
    from raycast_shade.scene.texture import srgb_to_linear

    try:
        from raycast_shade.scene.normals import reversed_duplicates
    except ImportError:  # the code before reversed duplicates were dropped
        def reversed_duplicates(faces, vertices=None):
            return np.zeros(len(faces), bool)

    tm, srgb = read_trimesh(path, False)
    items = _items(tm)
    # trimesh's own reading, images and all (raycast_shade reads the MTL's images itself).
    own = _items(trimesh.load(path, process=False)) if path.lower().endswith(".obj") else items
    if len(own) == len(items):
        items = [(o if len(o.vertices) == len(g.vertices) else g, t) for (o, _), (g, t) in zip(own, items)]
    if len(items) != len(models):
        return "?", np.zeros(0)
    hits = frame.hits
    mask = hits.prim >= 0
    geom, prim = hits.geom[mask], hits.prim[mask]
    bu, bv = hits.u[mask].astype(np.float64), hits.v[mask].astype(np.float64)
    bw = np.stack([1 - bu - bv, bu, bv], 1)
    gltf = path.lower().endswith((".glb", ".gltf"))
    errors, kinds = [], set()
    for gi, (model, (g, transform)) in enumerate(zip(models, items)):
        sel = geom == gi
        if not sel.any():
            continue
        mat, mesh = model.material, model.mesh
        tri = mesh.faces[prim[sel]]  # trimesh vertex ids (vertices are kept as written)
        vis = g.visual
        tmat = getattr(vis, "material", None)
        use_ka = gltf and mat.ka_map is not None
        tex = mat.ka_map if use_ka else mat.kd_map
        factor = mat.ka if use_ka else mat.kd
        if tex is not None and mesh.uvs is not None and _placeholder(tmat):
            # trimesh's stand-in for "no material": the file means the default colour, kd 0.8.
            kinds.add("texture")
            ours = factor * _sample(tex, np.einsum("nk,nkj->nj", bw[sel], mesh.uvs[tri]))
            ref = np.full_like(ours, 0.8)
        elif tex is not None and mesh.uvs is not None:
            image = getattr(tmat, "baseColorTexture", None) if gltf else getattr(tmat, "image", None)
            tuv = getattr(vis, "uv", None)
            if image is None or tuv is None:
                continue
            kinds.add("texture")
            ours = factor * _sample(tex, np.einsum("nk,nkj->nj", bw[sel], mesh.uvs[tri]))
            uv = np.einsum("nk,nkj->nj", bw[sel], np.asarray(tuv, np.float64)[tri])
            ws, wt = _gltf_wraps(path, tmat) if gltf else ("repeat", "repeat")
            # trimesh's v is 1 - t: the folds are symmetric under it.
            uv = np.stack([_fold(uv[:, 0], ws), _fold(uv[:, 1], wt)], 1)
            # trimesh puts texel centres at u (w - 1); ours (the OpenGL rule) at (j + 0.5) / w: the same point
            # in trimesh's coordinates is u' = (u w - 1/2) / (w - 1) (and likewise for 1 - v).
            w, h = image.size
            if w > 1 and h > 1:
                uv = np.stack([(uv[:, 0] * w - 0.5) / (w - 1), 1.0 - ((1.0 - uv[:, 1]) * h - 0.5) / (h - 1)], 1)
                # trimesh's lookup wraps: a clamped axis must stay on its edge texel.
                for axis, mode in ((0, ws), (1, wt)):
                    if mode == "clamp":
                        uv[:, axis] = np.clip(uv[:, axis], 0.0, 1.0)
            ref8 = uv_to_interpolated_color(uv, image)[:, :3] / 255.0
            if gltf:
                base = np.asarray(tmat.baseColorFactor if tmat.baseColorFactor is not None else [255] * 4)
                base = base[:3] / 255.0 if base.dtype.kind in "ui" else base[:3]
                ref = srgb_to_linear(ref8) * base
            else:
                kd = np.asarray((getattr(tmat, "kwargs", {}) or {}).get("kd", [1.0, 1.0, 1.0]), np.float64)
                ref = srgb_to_linear(ref8) * (kd if kd.size == 3 else np.repeat(kd[:1], 3))
        elif mesh.colors is not None and getattr(vis, "kind", None) is None and not gltf:
            kinds.add("colours (trimesh has none)")  # e.g. OFF colours, which trimesh's reader drops
            continue
        elif mesh.colors is not None:
            kinds.add("colours")
            if mesh.color_mode == "face":
                faces_inst = np.asarray(g.faces, np.int64)
                if np.linalg.det(transform[:3, :3]) < 0:
                    faces_inst = faces_inst[:, ::-1]
                keep = np.flatnonzero(~reversed_duplicates(faces_inst, np.asarray(g.vertices)))
                ours = mesh.colors[prim[sel]]
                fc = np.asarray(g.visual.face_colors)[keep[prim[sel]], :3] / 255.0
                ref = srgb_to_linear(fc) if srgb else fc
            else:
                ours = np.einsum("nk,nkj->nj", bw[sel], mesh.colors[tri])
                raw = np.asarray(vis.vertex_colors if isinstance(vis, trimesh.visual.ColorVisuals)
                                 else vis.vertex_attributes["color"])[:, :3]
                vc = raw / 255.0 if raw.dtype.kind in "ui" else raw.astype(np.float64)
                vc = srgb_to_linear(vc) if srgb else vc
                base = getattr(tmat, "baseColorFactor", None) if gltf else None
                base = 1.0 if base is None else np.asarray(base)[:3] / (255.0 if np.asarray(base).dtype.kind in "ui"
                                                                         else 1.0)
                ref = np.einsum("nk,nkj->nj", bw[sel], vc[tri]) * base
        else:
            continue
        errors.append(np.abs(_srgb(ours) - _srgb(ref)).max(axis=1))
    if not kinds:
        return "", np.zeros(0)
    return "+".join(sorted(kinds)), np.concatenate(errors) if errors else np.zeros(0)


def _camera(models, size):
    import raycast_shade as rs

    if hasattr(rs.Camera, "fit"):
        return rs.Camera.fit(models, (-0.4, -0.35, -1.0), margin=0.05, width=size, height=size)
    # The code before Camera.fit: the bounding sphere seen from the same direction.
    pts = np.concatenate([m.mesh.vertices for m in models])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo)) or 1.0
    d = np.array([-0.4, -0.35, -1.0])
    d /= np.linalg.norm(d)
    dist = radius / np.sin(np.radians(22.5)) * 1.05
    return rs.Camera(eye=centre - dist * d, target=centre, width=size, height=size)


def _scene(models, size):
    import raycast_shade as rs

    cam = _camera(models, size)
    r, u, f = cam.basis
    key = f + 0.8 * r - 0.9 * u
    return rs.Scene(models, lights=[rs.DirectionalLight(f, intensity=0.5), rs.DirectionalLight(key, intensity=0.7)],
                    camera=cam, ambient=0.2)


def _verdict(ok: bool, warnings_text) -> str:
    """A file whose referenced files are missing cannot look as meant: wrong, and warned when it says so."""
    missing = any("missing referenced file" in t for t in warnings_text)
    if ok and not missing:
        return "right"
    return "wrong (warned)" if warnings_text else "wrong (silent)"


class _Timeout(Exception):
    pass


def check_file(path, size: int, seconds: int = 240) -> dict:
    """Load, render and check one file; a dict for the CSV (plus ``image``)."""
    import raycast_shade as rs

    row = {"file": path, "loads": False, "models": 0, "faces": 0, "source": "", "median_error": "",
           "p90_error": "", "warnings": 0, "warning_text": "", "verdict": "fails", "error": "", "seconds": 0.0,
           "image": None}
    t0 = time.perf_counter()

    def alarm(*_):
        raise _Timeout(f"over {seconds} s")
    old = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(seconds)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            models = rs.load_models(path)
            row.update(loads=True, models=len(models), faces=int(sum(len(m.mesh.faces) for m in models)))
            frame = rs.render(_scene(models, size), shading="phong")
        texts = [str(w.message) for w in caught if issubclass(w.category, UserWarning)
                 and not issubclass(w.category, (DeprecationWarning,))]
        row["warnings"] = len(texts)
        row["warning_text"] = " | ".join(texts)[:2000]
        row["image"] = frame.to_uint8() if hasattr(frame, "to_uint8") else rs.to_uint8(frame.image)
        kind, err = colour_errors(path, models, frame)
        row["source"] = kind
        if err.size:
            row["median_error"] = float(np.median(err))
            row["p90_error"] = float(np.percentile(err, 90))
        visible = bool(frame.mask.any())
        ok = visible and (not err.size or np.median(err) <= THRESHOLD)  # no oracle: judged on the sheet
        row["verdict"] = _verdict(ok, texts)
    except _Timeout as exc:
        row["error"] = str(exc)
    except Exception as exc:  # every failure is a row of the table
        row["error"] = f"{type(exc).__name__}: {' '.join(str(exc).split())}"[:300]
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    row["seconds"] = round(time.perf_counter() - t0, 2)
    return row


def _label(img, text, width):
    from PIL import Image, ImageDraw

    tile = Image.new("RGB", (width, width + 24), (255, 255, 255))
    if img is not None:
        tile.paste(Image.fromarray(img).resize((width, width)), (0, 0))
    d = ImageDraw.Draw(tile)
    for k, line in enumerate([text[:34], text[34:68]]):
        d.text((3, width + 1 + 11 * k), line, fill=(0, 0, 0))
    return tile


def contact_sheet(rows, out, tile=128, cols=10):
    from PIL import Image

    n = len(rows)
    rows_n = (n + cols - 1) // cols
    sheet = Image.new("RGB", (cols * tile, rows_n * (tile + 24)), (255, 255, 255))
    for i, r in enumerate(rows):
        err = f" {r['median_error']:.3f}" if isinstance(r["median_error"], float) else ""
        mark = {"right": "ok", "wrong (warned)": "W", "wrong (silent)": "X", "fails": "fail"}[r["verdict"]]
        name = os.path.basename(r["file"])
        sheet.paste(_label(r["image"], f"{mark}{err} {name}", tile), ((i % cols) * tile, (i // cols) * (tile + 24)))
    sheet.save(out)


def _render_sample(path, direction, size):
    import raycast_shade as rs

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        models = rs.load_models(path)
        cam = rs.Camera.fit(models, direction, margin=0.05, width=size, height=size)
        r, u, f = cam.basis
        key = f + 0.8 * r - 0.9 * u
        lights = [rs.DirectionalLight(f, intensity=0.5), rs.DirectionalLight(key, intensity=0.7)]
        scene = rs.Scene(models, lights=lights, camera=cam, ambient=0.2)
        return rs.render(scene, shading="phong").to_uint8()


def side_by_side(folder, out, samples, tile=192):
    """Our render next to the sample's own screenshot, two pairs a row, for the named glTF samples
    (each from the direction its screenshot shows, roughly)."""
    import glob

    from PIL import Image, ImageDraw

    pairs = []
    for name, direction in samples.items():
        shots = sorted(glob.glob(os.path.join(folder, name, "screenshot", "screenshot.*")))
        files = sorted(glob.glob(os.path.join(folder, name, "glTF-Binary", "*.glb"))
                       + glob.glob(os.path.join(folder, name, "glTF", "*.gltf")))
        if not shots or not files:
            continue
        try:
            ours = Image.fromarray(_render_sample(files[0], direction, tile))
        except Exception:  # a sample that does not load has no pair (the table says why)
            continue
        ref = Image.open(shots[0]).convert("RGB")
        ref.thumbnail((tile, tile))
        pad = Image.new("RGB", (tile, tile), (255, 255, 255))
        pad.paste(ref, ((tile - ref.width) // 2, (tile - ref.height) // 2))
        pairs.append((name, ours, pad))
    cols = 2
    per = 2 * tile + 8
    sheet = Image.new("RGB", (cols * per, ((len(pairs) + cols - 1) // cols) * (tile + 16)), (255, 255, 255))
    d = ImageDraw.Draw(sheet)
    for i, (name, ours, ref) in enumerate(pairs):
        x, y = (i % cols) * per, (i // cols) * (tile + 16)
        sheet.paste(ours, (x, y + 14))
        sheet.paste(ref, (x + tile, y + 14))
        d.text((x + 2, y + 1), f"{name}: ours | reference screenshot", fill=(0, 0, 0))
    sheet.save(out)


FRONT = (-0.4, -0.35, -1.0)
# The samples of docs/files.md, each seen roughly from where its screenshot is taken. (Lantern,
# BarramundiFish, Corset, SciFiHelmet lack their textures in the corpus copy used here.)
SAMPLES = {"Duck": FRONT, "DamagedHelmet": (0.0, 0.0, -1.0), "Avocado": (0.0, -0.2, -1.0),
           "BoomBox": (0.3, -0.2, -1.0), "CesiumMilkTruck": (-1.0, -0.35, -0.6), "BoxTextured": FRONT,
           "BoxTexturedNonPowerOfTwo": FRONT, "TextureSettingsTest": (0.0, 0.0, -1.0),
           "TextureCoordinateTest": (0.0, 0.0, 1.0), "BoxVertexColors": FRONT, "WaterBottle": (0.0, 0.0, -1.0),
           "VC": FRONT, "NormalTangentTest": (0.0, 0.0, -1.0), "Suzanne": (0.0, -0.2, -1.0)}


def _read(path):
    """The CSV's rows, verdicts re-derived by :func:`_verdict` (a table written before the rule changed)."""
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        if r["verdict"] == "right":
            r["verdict"] = _verdict(True, [t for t in r["warning_text"].split(" | ") if t])
    return rows


def summary(pairs) -> str:
    """Markdown: per corpus, the verdict counts before and after, and the colour errors after.

    ``pairs``: ``[(corpus name, before.csv, after.csv), ...]``.
    """
    verdicts = ("right", "wrong (warned)", "wrong (silent)", "fails")
    out = ["| corpus | files | code | loads | " + " | ".join(verdicts) + " |",
           "|---|---|---|---|" + "---|" * len(verdicts)]
    for name, before, after in pairs:
        for label, path in (("before", before), ("after", after)):
            rows = _read(path)
            counts = [sum(r["verdict"] == v for r in rows) for v in verdicts]
            loads = sum(r["loads"] == "True" for r in rows)
            out.append(f"| {name} | {len(rows)} | {label} | {loads} | " + " | ".join(map(str, counts)) + " |")
    out += ["", "| file | colour source | median error before | median error after | p90 after | verdict after |",
            "|---|---|---|---|---|---|"]
    for name, before, after in pairs:
        old = {r["file"]: r for r in _read(before)}
        for r in _read(after):
            b = old.get(r["file"], {})
            if not (r["median_error"] or b.get("median_error")):
                continue

            def f(x):
                return f"{float(x):.4f}" if x else "-"
            out.append(f"| {name}/{r['file']} | {r['source'] or '-'} | {f(b.get('median_error'))} | "
                       f"{f(r['median_error'])} | {f(r['p90_error'])} | {r['verdict']} |")
    out += ["", "| file | before | after | what the after run says |", "|---|---|---|---|"]
    for name, before, after in pairs:
        old = {r["file"]: r for r in _read(before)}
        for r in _read(after):
            b = old.get(r["file"], {})
            if r["verdict"] == "right" and b.get("verdict") == "right":
                continue
            why = (r["error"] or r["warning_text"]).replace("|", "/")
            out.append(f"| {name}/{r['file']} | {b.get('verdict', '-')} | {r['verdict']} | {why[:160]} |")
    return "\n".join(out)


def _own_corpus(folder: str) -> None:
    """A few small files of the defect classes of issue 22, written here (the public corpora stay out
    of the repository): a palette PNG in a GLB, an OBJ with its MTL and map_Kd, a PLY with vertex
    colours, an OFF with face colours, a glTF with a mirrored-repeat sampler."""
    import base64
    import io
    import json

    import trimesh
    from PIL import Image

    rng = np.random.default_rng(0)
    # Blocks of 16 x 16 texels in 16 colours (a palette holds them exactly): trimesh interpolates 8-bit
    # sRGB values, we linear light, and the two differ only across the blocks' edges.
    i, j = np.mgrid[0:64, 0:64] // 16
    img = np.stack([i * 80, j * 80, (i + j) * 40], -1).astype(np.uint8)
    box = trimesh.creation.box()
    box.visual = trimesh.visual.TextureVisuals(uv=rng.random((8, 2)), material=trimesh.visual.material.PBRMaterial(
        baseColorTexture=Image.fromarray(img).convert("P"), metallicFactor=0.0))
    box.export(os.path.join(folder, "palette.glb"))
    Image.fromarray(img).save(os.path.join(folder, "wood.png"))
    with open(os.path.join(folder, "quad.mtl"), "w") as fh:
        fh.write("newmtl wood\nKd 1 1 1\nmap_Kd wood.png\n")
    with open(os.path.join(folder, "quad.obj"), "w") as fh:
        fh.write("mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                 "usemtl wood\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n")
    ico = trimesh.creation.icosphere(2)
    ico.visual.vertex_colors = rng.integers(0, 256, (len(ico.vertices), 4), dtype=np.uint8) | np.uint8(0)
    ico.visual.vertex_colors[:, 3] = 255
    ico.export(os.path.join(folder, "colours.ply"))
    with open(os.path.join(folder, "faces.off"), "w") as fh:
        fh.write("OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2 255 0 0\n3 0 2 3 0 128 255\n")
    buf = io.BytesIO()
    Image.fromarray(img).save(buf, format="PNG")
    pos = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    uv = np.array([[-1, -1], [2, -1], [2, 2], [-1, 2]], np.float32)
    blob = pos.tobytes() + uv.tobytes() + np.array([0, 1, 2, 0, 2, 3], np.uint16).tobytes()
    js = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
          "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
          "materials": [{"name": "m", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
                                                               "metallicFactor": 0.0}}],
          "textures": [{"source": 0, "sampler": 0}], "samplers": [{"wrapS": 33648, "wrapT": 33071}],
          "images": [{"uri": "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()}],
          "buffers": [{"uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
                       "byteLength": len(blob)}],
          "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                          {"buffer": 0, "byteOffset": 48, "byteLength": 32},
                          {"buffer": 0, "byteOffset": 80, "byteLength": 12}],
          "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0],
                         "max": [1, 1, 0]},
                        {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
                        {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}]}
    with open(os.path.join(folder, "sampler.gltf"), "w") as fh:
        json.dump(js, fh)


def outputs(quick: bool) -> list:
    """The CSV :func:`self_check` writes (see :mod:`benchmarks.outputs`)."""
    from benchmarks import outputs as where

    return [where.results_file("corpus_selftest.csv", quick)]


def self_check(quick: bool) -> int:
    """The check on :func:`_own_corpus` (what ``python -m benchmarks`` runs): its CSV to
    ``corpus_selftest.csv`` (quick mode: the git-ignored quick folder); 1 unless every file is right."""
    import tempfile

    fields = ["file", "loads", "models", "faces", "source", "median_error", "p90_error", "warnings", "verdict",
              "error"]
    with tempfile.TemporaryDirectory() as folder:
        _own_corpus(folder)
        rows = [check_file(p, 64 if quick else 128) for p in _files(folder, ())]
        path = outputs(quick)[0]
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=fields, extrasaction="ignore")
            w.writeheader()
            for r in rows:
                w.writerow(dict(r, file=os.path.basename(r["file"])))
    for r in rows:
        err = f"{r['median_error']:.4f}" if isinstance(r["median_error"], float) else "-"
        print(f"{r['verdict']:<15} {err:>7} {os.path.basename(r['file'])} {r['error']}")
    return 0 if all(r["verdict"] == "right" for r in rows) else 1


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if not [a for a in argv if not a.startswith("-")]:  # the suite's runner: main([]) or main(["--quick"])
        return self_check("--quick" in argv)
    if argv[:1] == ["sheet"]:  # sheet DIR: the contact sheet again from DIR's corpus.csv and renders/
        from PIL import Image

        rows = _read(os.path.join(argv[1], "corpus.csv"))
        for r in rows:
            png = os.path.join(argv[1], "renders", r["file"].replace(os.sep, "__") + ".png")
            r["image"] = np.asarray(Image.open(png).convert("RGB")) if os.path.exists(png) else None
            r["median_error"] = float(r["median_error"]) if r["median_error"] else ""
        contact_sheet(rows, os.path.join(argv[1], "sheet.png"))
        return 0
    if argv[:1] == ["geometry"]:  # geometry FOLDER [--out CSV]: the samples of benchmarks/corpus_geometry.py
        try:
            from benchmarks.corpus_geometry import main as geometry
        except ImportError:  # run as a script from another folder: this file's folder is on the path
            from corpus_geometry import main as geometry
        return geometry(argv[1:])
    if argv[:1] == ["summary"]:  # summary NAME BEFORE.csv AFTER.csv [NAME BEFORE AFTER ...]
        rest = argv[1:]
        print(summary([tuple(rest[i:i + 3]) for i in range(0, len(rest), 3)]))
        return 0
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("folder")
    p.add_argument("--out", required=True)
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--gltf-variants", default="glTF,glTF-Binary",
                   help="subfolders of glTF samples to take (default: glTF,glTF-Binary)")
    p.add_argument("--screenshots", action="store_true", help="write side_by_side.png (Khronos samples)")
    p.add_argument("--only-screenshots", action="store_true", help="write side_by_side.png only")
    args = p.parse_args(argv)
    os.makedirs(os.path.join(args.out, "renders"), exist_ok=True)
    if args.only_screenshots:
        side_by_side(args.folder, os.path.join(args.out, "side_by_side.png"), SAMPLES)
        return 0
    variants = tuple(v for v in args.gltf_variants.split(",") if v)
    rows = []
    for path in _files(args.folder, variants):
        row = check_file(path, args.size)
        rows.append(row)
        rel = os.path.relpath(path, args.folder)
        if row["image"] is not None:
            from PIL import Image

            Image.fromarray(row["image"]).save(os.path.join(args.out, "renders", rel.replace(os.sep, "__") + ".png"))
        err = f"{row['median_error']:.4f}" if isinstance(row["median_error"], float) else "-"
        print(f"{row['verdict']:<15} {err:>7} {row['seconds']:6.1f}s {rel} {row['error']}", flush=True)
    fields = ["file", "loads", "models", "faces", "source", "median_error", "p90_error", "warnings", "verdict",
              "seconds", "error", "warning_text"]
    with open(os.path.join(args.out, "corpus.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        root = os.path.abspath(args.folder) + os.sep
        for r in rows:  # paths relative to the folder: the table does not depend on where it lay
            w.writerow(dict(r, file=os.path.relpath(r["file"], args.folder), error=r["error"].replace(root, ""),
                            warning_text=r["warning_text"].replace(root, "")))
    contact_sheet(rows, os.path.join(args.out, "sheet.png"))
    if args.screenshots:
        side_by_side(args.folder, os.path.join(args.out, "side_by_side.png"), SAMPLES)
    counts = {v: sum(r["verdict"] == v for r in rows) for v in ("right", "wrong (warned)", "wrong (silent)", "fails")}
    print(f"{len(rows)} files: " + ", ".join(f"{k} {v}" for k, v in counts.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
