"""rs.diagnose on images from an independent shader: slips outside the catalogue, post-processing, and the
catalogue's own slips.

Run ``python -m benchmarks.diagnose_outside [--quick]``. The student images
are made by :func:`student_image`, a NumPy shader written here from the
lecture's equations (not our renderer: it shares only the hit buffer, the
ray cast of the scene's camera), on four scenes like those of issue 46: a
torus lit by a point light and a directional one (Phong shading asked), a
cube of 8 shared vertices (Gouraud), a low-poly sphere at 173x131 (Phong),
and a prism off the origin (flat). Each image is quantised to 8 bits after
Gaussian noise of :data:`NOISE` levels.

Every trial is classed by what a verdict would mean:

* *right*: a verdict ("matches" or "best explained by") whose class holds
  the truth; for a slip outside the catalogue, a "matches" where the slip
  changes the independent image by at most :data:`INVISIBLE` levels at every
  pixel; for the photograph, "not a render of this scene";
* *honest*: "cannot tell" (or "not a render" for anything but a render of
  the scene's correct shading with post-processing);
* *wrong*: any other verdict: a confident wrong answer.

Writes ``benchmarks/results/outside_slips.csv`` (one row per trial) and
``outside_slips.md`` (the table), and puts the table into
``docs/diagnose.md`` between its markers; ``--quick`` runs one scene (the prism) and a
few slips and writes under the git-ignored quick folder only.
"""

from __future__ import annotations

import argparse
import collections
import io
import os
import re

import numpy as np

from benchmarks.outputs import ROOT, results_file, write_csv

NOISE = 0.75  # levels of Gaussian noise before 8-bit rounding
INVISIBLE = 2.0  # levels: a slip this small at every pixel is no slip on this scene
BEGIN, END = "<!-- outside-slips:begin -->", "<!-- outside-slips:end -->"
HEADER = ("| slip | kind | truth | images | right | honest | wrong |", "| --- | --- | --- | --- | --- | --- | --- |")
ROW = re.compile(r"^\| [\w.+-]+ \| (new|outside|catalogue|post|photo|all) \| [\w.+ ()-]+ \| \d+ \| \d+ \| \d+ \| \d+ \|$")


def outputs(quick: bool) -> list:
    """Every file :func:`main` writes in this mode."""
    out = [results_file("outside_slips.csv", quick), results_file("outside_slips.md", quick)]
    return out if quick else out + [os.path.join(ROOT, "docs", "diagnose.md")]


# -- the scenes -----------------------------------------------------------------------------------------
def _prism(center):
    """A triangular prism (6 vertices, 8 faces) around ``center``."""
    import raycast_shade as rs

    tri = np.array([[0.0, 0.6], [-0.55, -0.35], [0.55, -0.35]])
    verts = np.array([[x, y, z] for z in (-0.7, 0.7) for x, y in tri]) + np.asarray(center)
    faces = np.array([[0, 2, 1], [3, 4, 5], [0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4], [2, 0, 3], [2, 3, 5]])
    return rs.Mesh(verts, faces, crease_angle=30.0)


def scenes() -> dict:
    """name -> (Scene, method asked for)."""
    import raycast_shade as rs

    torus = rs.Scene([rs.Model(rs.shapes.torus(major_segments=32, minor_segments=16),
                               rs.Material(kd=(0.2, 0.6, 0.3), ks=0.5, shininess=30))],
                     lights=[rs.PointLight((2, 2, 3), intensity=14, attenuation="inverse_square"),
                             rs.DirectionalLight((-1, -0.6, -0.4), intensity=0.7, color=(1.0, 0.85, 0.6))],
                     camera=rs.Camera(eye=(0, 2.2, 3), width=128, height=96), ambient=0.06)
    cube = rs.Scene([rs.Model(rs.shapes.cube(1.2, center=(0.3, 0.1, 0.0), crease_angle=None),
                              rs.Material(kd=(0.85, 0.55, 0.2), ks=0.4, shininess=20))],
                    lights=[rs.PointLight((1.5, 2.5, 2.0), intensity=4, attenuation="heuristic", k=1.0)],
                    camera=rs.Camera(eye=(2.4, 2.0, 3.2), target=(0.3, 0.1, 0), width=96, height=72), ambient=0.08)
    sphere = rs.Scene([rs.Model(rs.shapes.icosphere(1), rs.Material(kd=(0.3, 0.45, 0.85), ks=0.6, shininess=25))],
                      lights=[rs.PointLight((-2, 3, 4), intensity=24, attenuation="inverse_square")],
                      camera=rs.Camera(eye=(0, 0, 3.2), width=173, height=131), ambient=0.1)
    prism = rs.Scene([rs.Model(_prism((0.4, 0.0, 0.0)), rs.Material(kd=(0.7, 0.7, 0.3), ks=0.3, shininess=10))],
                     lights=[rs.PointLight((1.0, 2.0, 2.5), intensity=1.0),
                             rs.DirectionalLight((1, -1, -1), intensity=0.4, color=(0.5, 0.7, 1.0))],
                     camera=rs.Camera(eye=(1.8, 1.2, 3.0), target=(0.4, 0, 0), width=96, height=72), ambient=0.07)
    return {"torus": (torus, "phong"), "cube8": (cube, "gouraud"), "sphere173": (sphere, "phong"),
            "prism": (prism, "flat")}


# -- the independent shader -----------------------------------------------------------------------------
def _camera_basis(cam):
    f = np.asarray(cam.target, float) - cam.eye
    f /= np.linalg.norm(f)
    r = np.cross(f, cam.up)
    r /= np.linalg.norm(r)
    return r, np.cross(r, f), -f  # camera x, y, z in world coordinates


def _lights(scene, space, reverse, centre):
    """(position or None, unit direction towards the light or None, rgb, law, k) per light, as the student
    reads them: in world, object (``centre``) or camera space; directional lights reversed with ``reverse``."""
    cam = scene.camera
    basis = np.stack(_camera_basis(cam))
    out = []
    for light in scene.lights:
        rgb = light.intensity * np.asarray(light.color, float)
        if hasattr(light, "position"):
            pos = np.asarray(light.position, float)
            if space == "object":
                pos = pos + centre
            elif space == "camera":
                pos = cam.eye + pos @ basis
            out.append((pos, None, rgb, light.attenuation, light.k))
        else:
            d = np.asarray(light.direction, float)
            d = d @ basis if space == "camera" else d
            d = d / np.linalg.norm(d)
            out.append((None, d if reverse else -d, rgb, "none", 1.0))
    return out


def _shade(p, n, eye, mat, lights, ambient, o):
    """The lecture's equation at points ``p`` (N, 3) with unit normals ``n``; ``o`` holds the slips."""
    v = eye - p
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    col = np.zeros_like(p) if o.get("no_ambient") else np.broadcast_to(ambient * np.asarray(mat.ka), p.shape).copy()
    blinn = (mat.specular == "blinn") != bool(o.get("swap"))
    tint = o.get("tint")
    for pos, direction, rgb, law, k in lights:
        if pos is None:
            s, att = np.broadcast_to(direction, p.shape), 1.0
        else:
            L = pos - p
            d = np.linalg.norm(L, axis=1, keepdims=True)
            s = L / d
            att = {"none": 1.0, "inverse_square": 1.0 / d ** 2, "heuristic": 1.0 / (d + k)}[law]
        ns = np.sum(n * s, axis=1, keepdims=True)
        diff = ns if o.get("unclamped") else np.maximum(ns, 0.0)
        if o.get("half_raw"):  # Blinn's h = s + v, never divided by its length
            c = np.sum(n * (s + v), axis=1, keepdims=True)
        elif blinn:
            h = s + v
            c = np.sum(n * h / np.linalg.norm(h, axis=1, keepdims=True), axis=1, keepdims=True)
        else:
            r = 2.0 * ns * n - s
            c = np.sum((-r if o.get("r_sign") else r) * v, axis=1, keepdims=True)
        spec = np.where((ns > 0) & (c > 0), np.clip(c, 0, None) ** mat.shininess, 0.0)
        ks = np.asarray(mat.ks) * np.ones(3)
        if tint is not None:
            ks = ks * (np.asarray(mat.kd) if isinstance(tint, str) else np.asarray(tint))
        term = (0.0 if o.get("no_diffuse") else np.asarray(mat.kd) * diff) + \
            (0.0 if o.get("no_specular") else ks * spec)
        col = col + att * rgb * term
    return col


def student_linear(scene, hits, method, **o) -> np.ndarray:
    """(H, W, 3) linear RGB as the student's shader computes it (background 0), one model.

    Slips (keywords): ``no_ambient``, ``no_diffuse``, ``no_specular``, ``unclamped``, ``r_sign``, ``swap``
    (Blinn for Phong), ``half_raw``, ``tint`` (``"kd"`` or an RGB multiplying the highlight), ``space``
    (``"world"``, ``"object"``, ``"camera"``), ``reverse`` (directional lights), ``face_normals``,
    ``at_vertex`` (flat shading lit at the face's first vertex, not its centre).
    """
    geo = scene.geometry
    (model,) = scene.models
    mat = model.material
    mask = hits.prim >= 0
    face = hits.prim[mask].astype(np.int64)  # one model: the primitive is the face
    tri = geo.faces[face]
    world = geo.vertices + geo.origin
    u, v = hits.u[mask].astype(np.float64), hits.v[mask].astype(np.float64)
    b = np.stack([1.0 - u - v, u, v], axis=1)
    corners = world[tri]
    g = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    eye = np.asarray(scene.camera.eye, float)
    centre = np.mean(model.mesh.bounds, axis=0)
    lights = _lights(scene, o.get("space", "world"), o.get("reverse", False), centre)

    def shade(p, n):
        return _shade(p, n, eye, mat, lights, scene.ambient, o)

    normals = geo.normals[tri] if not o.get("face_normals") else np.repeat(g[:, None], 3, axis=1)
    if method == "flat":
        p = corners[:, 0] if o.get("at_vertex") else corners.mean(axis=1)
        col = shade(p, g)
    elif method == "gouraud":
        col = sum(b[:, k, None] * shade(corners[:, k], normals[:, k]) for k in range(3))
    else:
        n = np.einsum("nk,nkc->nc", b, normals)
        col = shade(np.einsum("nk,nkc->nc", b, corners), n / np.linalg.norm(n, axis=1, keepdims=True))
    out = np.zeros(hits.shape + (3,))
    out[mask] = col
    return out


def _srgb(x):
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def student_image(scene, hits, method, rng, *, encoding="srgb", background=None, flip=False, bgr=False,
                  post=None, **slips) -> np.ndarray:
    """(H, W, 3) uint8: :func:`student_linear`, encoded, noised by :data:`NOISE` levels, rounded, then
    written as the student's program does (``flip``, ``bgr``, a ``background`` display value, ``post``:
    ``"jpeg75"``, ``"resize"`` (to half and back, bilinear) or None)."""
    x = np.clip(student_linear(scene, hits, method, **slips), 0.0, 1.0)
    x = {"srgb": _srgb, "linear": lambda y: y, "gamma22": lambda y: y ** (1 / 2.2),
         "double": lambda y: _srgb(_srgb(y))}[encoding](x)
    if background is not None:
        x[hits.prim < 0] = background
    img = np.clip(np.rint(x * 255.0 + rng.normal(0.0, NOISE, x.shape)), 0, 255).astype(np.uint8)
    img = img[::-1] if flip else img
    img = img[..., ::-1] if bgr else img
    return _post(np.ascontiguousarray(img), post)


def _post(img, post):
    from PIL import Image

    if post == "jpeg75":
        buf = io.BytesIO()
        Image.fromarray(img).save(buf, format="JPEG", quality=75)
        return np.asarray(Image.open(io.BytesIO(buf.getvalue())).convert("RGB"))
    if post == "resize":
        h, w = img.shape[:2]
        small = Image.fromarray(img).resize((w // 2, h // 2), Image.BILINEAR)
        return np.asarray(small.resize((w, h), Image.BILINEAR))
    return img


def photograph(shape, rng) -> np.ndarray:
    """A photograph-like image: smooth random shapes and texture (uint8), nothing of any scene."""
    from PIL import Image

    h, w = shape
    coarse = rng.uniform(0, 255, (max(h // 12, 2), max(w // 12, 2), 3)).astype(np.uint8)
    img = np.asarray(Image.fromarray(coarse).resize((w, h), Image.BICUBIC), float)
    return np.clip(img + rng.normal(0, 6, img.shape), 0, 255).astype(np.uint8)


# -- the trials -----------------------------------------------------------------------------------------
OUTSIDE = {  # slip -> (keywords, truth: a catalogue name (kind "new": added for issue 46), or "" (kind "outside"))
    "highlight-times-kd": (dict(tint="kd"), "specular-times-kd"),
    "highlight-tinted": (dict(tint=(1.0, 0.2, 0.8)), ""),  # magenta: no scene's kd
    "directional-reversed": (dict(reverse=True), "light-reversed"),
    "light-object-space": (dict(space="object"), "light-object-space"),
    "light-camera-space": (dict(space="camera"), "light-in-camera-space"),
    "flat-at-vertex": (dict(at_vertex=True), ""),
    "half-unnormalised": (dict(half_raw=True), ""),
}
POST = {"grey-background": dict(background=0.5), "jpeg75": dict(post="jpeg75"), "resize": dict(post="resize"),
        "gamma22": dict(encoding="gamma22")}
CATALOGUE = {"correct": {}, "no-ambient": dict(no_ambient=True), "no-diffuse": dict(no_diffuse=True),
             "no-specular": dict(no_specular=True), "no-srgb": dict(encoding="linear"),
             "srgb-twice": dict(encoding="double"), "flipped": dict(flip=True), "bgr": dict(bgr=True),
             "n.s-unclamped": dict(unclamped=True), "r-sign": dict(r_sign=True), "halfway-swapped": dict(swap=True),
             "face-normals": dict(face_normals=True)}
QUICK = ("correct", "no-ambient", "highlight-times-kd", "directional-reversed", "light-object-space",
         "grey-background", "jpeg75", "photo")


def _applicable(slip, truth, diag, scene, method):
    names = {c.name for c in diag.candidates}
    if truth and truth not in names and slip != "photo":
        return False
    if slip in ("face-normals", "halfway-swapped", "r-sign") and method == "flat":
        return False
    if slip == "flat-at-vertex":
        return method == "flat"
    if slip == "directional-reversed":
        return any(not hasattr(light, "position") for light in scene.lights)
    return True


def _plan(quick):
    """(slip, kind, keywords, truth) for every trial type."""
    out = [(s, "new" if t else "outside", k, t) for s, (k, t) in OUTSIDE.items()]
    out += [(s, "post", k, "correct") for s, k in POST.items()]
    out += [(s, "catalogue", k, s) for s, k in CATALOGUE.items()]
    out.append(("photo", "photo", {}, "not-a-render"))
    return [p for p in out if not quick or p[0] in QUICK]


def _outcome(d, kind, truth, invisible):
    if truth == "not-a-render":
        return "right" if d.status == "not-a-render" else ("honest" if d.status == "cannot-tell" else "wrong")
    if d.status == "cannot-tell" or (d.status == "not-a-render" and kind != "post"):
        return "honest"
    if d.status == "not-a-render":
        return "wrong"
    if truth == "correct":
        return "right" if d.matches else "wrong"
    if not truth:
        return "right" if d.matches and invisible else "wrong"
    return "right" if truth in d.group else "wrong"


def run(quick: bool = False, trials: int = 2, seed: int = 46) -> list:
    """Every trial as a dict row."""
    from raycast_shade.apps.diagnose import Diagnoser

    rng = np.random.default_rng(seed)
    rows = []
    chosen = {"prism": scenes()["prism"]} if quick else scenes()
    for sname, (scene, method) in chosen.items():
        diag = Diagnoser(scene, method)
        hits = diag.frame.hits
        ok_lin = np.clip(student_linear(scene, hits, method), 0, 1)
        for slip, kind, kw, truth in _plan(quick):
            if not _applicable(slip, truth if kind != "post" else "", diag, scene, method):
                continue
            slips = {k: v for k, v in kw.items() if k not in ("encoding", "background", "flip", "bgr", "post")}
            invisible = bool(np.abs(_srgb(np.clip(student_linear(scene, hits, method, **slips), 0, 1))
                                    - _srgb(ok_lin)).max() * 255 <= INVISIBLE) if kind == "outside" else False
            for trial in range(1 if quick else trials):
                img = photograph(hits.shape, rng) if kind == "photo" else \
                    student_image(scene, hits, method, rng, **kw)
                d = diag(img)
                rows.append(dict(scene=sname, method=method, size=f"{hits.shape[1]}x{hits.shape[0]}", slip=slip,
                                 kind=kind, truth=truth or "(none)", trial=trial, status=d.status,
                                 best=d.best.name, group="|".join(d.group), invisible=int(invisible),
                                 outcome=_outcome(d, kind, truth, invisible),
                                 rms=round(d.scores[d.best.name], 3), q99=round(d.facts.get("q99", 0.0), 2)))
    return rows


def table(rows) -> str:
    """The markdown table: one row per slip (all scenes), then one per kind, then the total."""
    lines = list(HEADER)

    def line(name, kind, truth, sub):
        c = collections.Counter(r["outcome"] for r in sub)
        return f"| {name} | {kind} | {truth} | {len(sub)} | {c['right']} | {c['honest']} | {c['wrong']} |"

    slips = list(dict.fromkeys((r["slip"], r["kind"], r["truth"]) for r in rows))
    for slip, kind, truth in slips:
        lines.append(line(slip, kind, truth, [r for r in rows if r["slip"] == slip and r["kind"] == kind]))
    for kind in dict.fromkeys(r["kind"] for r in rows):
        lines.append(line("all", kind, "-", [r for r in rows if r["kind"] == kind]))
    lines.append(line("all", "all", "-", rows))
    return "\n".join(lines)


def put_table(doc: str, text: str) -> str:
    """``doc`` with the text between the markers replaced by ``text``."""
    a, b = doc.index(BEGIN) + len(BEGIN), doc.index(END)
    return doc[:a] + "\n" + text + "\n" + doc[b:]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.diagnose_outside", description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="one scene, a few slips, one trial; quick folder only")
    args = p.parse_args(argv)
    rows = run(args.quick)
    text = table(rows)
    csv_path, md_path = outputs(args.quick)[:2]
    write_csv(csv_path, rows)
    with open(md_path, "w", encoding="utf-8") as fh:
        fh.write(text + "\n")
    if not args.quick:
        doc_file = outputs(False)[2]
        with open(doc_file, encoding="utf-8") as fh:
            doc = fh.read()
        with open(doc_file, "w", encoding="utf-8") as fh:
            fh.write(put_table(doc, text))
    print(text)
    for r in rows:
        if r["outcome"] == "wrong":
            print("WRONG", r)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
