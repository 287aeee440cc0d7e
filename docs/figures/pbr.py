"""Contact sheet of docs/pbr.md: glTF materials shaded with the lecture's model and with glTF's own BRDF.

``python -m docs.figures.pbr SAMPLES [--quick]`` writes ``pbr_sheet.png`` into ``docs/images/``: for
DamagedHelmet, BoomBox and the metal-rough spheres, our render with ``reflectance="phong"`` (the
default mapping onto ka, kd, ks, t), with ``reflectance="pbr"`` (``Material(specular="ggx")``), and
the Khronos reference screenshot, side by side. ``SAMPLES`` is a copy of the Khronos
glTF-Sample-Models ``2.0`` folder (not shipped: the files are large). Our renders use
:func:`raycast_shade.load_models`' framing and lights (a headlight and a key light, ambient 0.2,
as ``raycast-shade render FILE``); the screenshots are lit by an environment map (image-based
lighting), which no point light reproduces.

MetalRoughSpheres' geometry buffer (11 MB) is not in every copy of the samples; when it is absent the
sheet renders the same grid built here from the sample's two textures' values: 7 x 7 cells, metallic
1 (top) to 0 (bottom), roughness 0 (left) to 1 (right), each a grey sphere (sRGB 204, 204, 204) and a
gold one (sRGB 204, 177, 29) behind it.
"""

from __future__ import annotations

import os
import sys
import warnings

import numpy as np

import raycast_shade as rs

from benchmarks.outputs import images_dir

TILE = 200
FILES = {"DamagedHelmet": ("DamagedHelmet/glTF/DamagedHelmet.gltf", (-0.8, -0.25, -1.0)),  # as the screenshots
         "BoomBox": ("BoomBox/glTF-pbrSpecularGlossiness/BoomBox.gltf", (-0.7, -0.45, -1.0))}
SHOTS = {"DamagedHelmet": "DamagedHelmet/screenshot/screenshot.png", "BoomBox": "BoomBox/screenshot/screenshot.jpg",
         "MetalRoughSpheres": "MetalRoughSpheres/screenshot/screenshot.png"}
GREY, GOLD = (204, 204, 204), (204, 177, 29)  # the spheres' base colours, sRGB (Spheres_BaseColor.png)


def _linear(srgb):
    c = np.asarray(srgb, np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _lit(models, direction, size):
    """``model_scene``'s framing and lights for models already loaded."""
    cam = rs.Camera.fit(models, direction, margin=0.05, width=size, height=size)
    r, u, f = cam.basis
    lights = [rs.DirectionalLight(f, intensity=0.5), rs.DirectionalLight(f + 0.8 * r - 0.9 * u, intensity=0.7)]
    return rs.Scene(models, lights=lights, camera=cam, ambient=0.2)


def spheres(reflectance: str):
    """The metal-rough grid: ``reflectance="pbr"`` as GGX materials, ``"phong"`` through the loader's own
    mapping (``from_pbr``) of the same factors, so both columns show what a glTF file would give."""
    from raycast_shade.scene.filematerial import FileContext, from_pbr

    class Pbr:  # a trimesh PBRMaterial's fields, as from_pbr reads them
        def __init__(self, rgb, m, r):
            self.baseColorFactor, self.metallicFactor, self.roughnessFactor = (*rgb, 1.0), m, r
            self.name = f"m{m:.2f}r{r:.2f}"

    ctx = FileContext(None, reflectance=reflectance)
    models = []
    for i in range(7):
        for j in range(7):
            m, r = 1.0 - i / 6.0, j / 6.0
            x, y = 1.1 * j, -1.1 * i
            for rgb, dx, dz in ((GOLD, -0.22, -0.5), (GREY, 0.1, 0.0)):
                kw = from_pbr(Pbr(_linear(rgb), m, r), "sphere", [], ctx)
                mesh = rs.shapes.icosphere(2, radius=0.4, center=(x + dx, y + (0.22 if dz else 0.0), dz))
                models.append(rs.Model(mesh, rs.Material(**kw)))
    return models


def _render(name, samples, reflectance):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Phong mapping's notes (approximated maps) are docs/textures.md's
        if name == "MetalRoughSpheres":
            models, direction = spheres(reflectance), (0.0, 0.0, -1.0)
        else:
            path, direction = FILES[name]
            models = rs.load_models(os.path.join(samples, path), reflectance=reflectance)
        return np.asarray(rs.render(_lit(models, direction, TILE), shading="phong").to_uint8())


def _shot(samples, name):
    from PIL import Image

    ref = Image.open(os.path.join(samples, SHOTS[name])).convert("RGB")
    ref.thumbnail((TILE, TILE))
    pad = Image.new("RGB", (TILE, TILE), (255, 255, 255))
    pad.paste(ref, ((TILE - ref.width) // 2, (TILE - ref.height) // 2))
    return np.asarray(pad)


def main(argv=None):
    """Draw the sheet; ``--quick`` writes it into the git-ignored ``out/quick/images/``."""
    from PIL import Image, ImageDraw

    argv = sys.argv[1:] if argv is None else list(argv)
    paths = [a for a in argv if not a.startswith("-")] or [os.environ.get("KHRONOS_SAMPLES", "")]
    if not os.path.isdir(paths[0]):  # the runner (python -m docs.figures) passes none: say why nothing is drawn
        print("docs.figures.pbr: skipped, it needs the Khronos samples: python -m docs.figures.pbr SAMPLES [--quick] "
              "or KHRONOS_SAMPLES=SAMPLES (SAMPLES: glTF-Sample-Models' 2.0 folder)", file=sys.stderr)
        return 2
    out = images_dir("--quick" in argv)
    os.makedirs(out, exist_ok=True)
    names = ["DamagedHelmet", "BoomBox", "MetalRoughSpheres"]
    head, gap = 16, 6
    sheet = Image.new("RGB", (3 * TILE + 2 * gap, head + len(names) * (TILE + head)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    for k, title in enumerate(["ours: reflectance='phong'", "ours: reflectance='pbr' (GGX)",
                               "Khronos screenshot (IBL)"]):
        draw.text((k * (TILE + gap) + 4, 2), title, fill=(0, 0, 0))
    for row, name in enumerate(names):
        y = head + row * (TILE + head)
        draw.text((4, y + 1), name, fill=(0, 0, 0))
        tiles = [_render(name, paths[0], "phong"), _render(name, paths[0], "pbr"), _shot(paths[0], name)]
        for k, t in enumerate(tiles):
            sheet.paste(Image.fromarray(t), (k * (TILE + gap), y + head - 2))
        print(name, "done", flush=True)
    path = os.path.join(out, "pbr_sheet.png")
    sheet.save(path, optimize=True)
    print("wrote", path, os.path.getsize(path), "bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
