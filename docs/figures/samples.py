"""Contact sheet of docs/files.md: the Khronos samples of each file class beside their reference screenshots.

``python -m docs.figures.samples SAMPLES [--verdicts CSV] [--quick]`` writes ``files_classes.png`` into ``docs/images/``:
for each sample of :data:`SAMPLES` that ``SAMPLES`` (a copy of glTF-Sample-Models' ``2.0`` folder, not
shipped) holds, our render (``load_models``' framing and lights, Phong, as ``raycast-shade render FILE``)
and the sample's ``screenshot/screenshot.*`` (a PBR viewer with an environment light; a GIF's first
frame), labelled with the class and the verdict of ``benchmarks/corpus_geometry.py`` (``ok``: loaded and
its automatic check holds; ``W``: warned; ``X``: the check fails; ``fail``: refused; read from that
script's ``--out CSV`` with ``--verdicts``, else checked here). Samples the copy
lacks are listed on stderr and left out. Whether the colours look right is for the eye: the screenshots
are lit by an environment map, which no point light reproduces.
"""

from __future__ import annotations

import os
import sys
import warnings

import numpy as np

from benchmarks.outputs import images_dir

TILE = 160
FRONT = (0.0, 0.0, -1.0)  # flat samples facing +z
# (class, file under 2.0/, view direction); the screenshot is the sample's screenshot/screenshot.*
SAMPLES = [
    ("primitive modes", "MeshPrimitiveModes/glTF-Embedded/MeshPrimitiveModes.gltf", FRONT),
    ("primitive modes", "TriangleWithoutIndices/glTF/TriangleWithoutIndices.gltf", FRONT),
    ("sparse accessor", "SimpleSparseAccessor/glTF/SimpleSparseAccessor.gltf", FRONT),
    ("morph", "SimpleMorph/glTF/SimpleMorph.gltf", FRONT),
    ("morph", "AnimatedMorphCube/glTF/AnimatedMorphCube.gltf", (-0.6, -0.5, -1.0)),
    ("morph", "AnimatedMorphSphere/glTF/AnimatedMorphSphere.gltf", (-0.4, -0.35, -1.0)),
    ("spec-gloss", "Box/glTF-pbrSpecularGlossiness/Box.gltf", (-0.6, -0.5, -1.0)),
    ("spec-gloss", "Duck/glTF-pbrSpecularGlossiness/Duck.gltf", (-1.0, -0.3, -0.4)),  # as the screenshot
    ("spec-gloss", "Avocado/glTF-pbrSpecularGlossiness/Avocado.gltf", (0.3, 0.2, -1.0)),
    ("spec-gloss", "BoomBox/glTF-pbrSpecularGlossiness/BoomBox.gltf", (-0.7, -0.45, -1.0)),
    ("spec-gloss", "2CylinderEngine/glTF-pbrSpecularGlossiness/2CylinderEngine.gltf", (0.6, -0.4, 1.0)),
    ("texture transform", "TextureTransformTest/glTF/TextureTransformTest.gltf", FRONT),
    ("texture transform", "TextureTransformMultiTest/glTF/TextureTransformMultiTest.gltf", FRONT),
    ("Draco", "Box/glTF-Draco/Box.gltf", (-0.6, -0.5, -1.0)),
    ("Draco", "Duck/glTF-Draco/Duck.gltf", (-1.0, -0.3, -0.4)),
    ("quantized", "Duck/glTF-Quantized/Duck.gltf", (-1.0, -0.3, -0.4)),
]


def _render(path, direction):
    import raycast_shade as rs
    from raycast_shade.scene.meshfile import model_scene

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the loader's notes are the verdict's (benchmarks/corpus_geometry.py)
        scene = model_scene(path, width=TILE, height=TILE, direction=direction)
        return np.asarray(rs.render(scene, shading="phong").to_uint8())


def _shot(samples, rel):
    """The sample's screenshot fitted into a tile (white padding), or None when the copy has none."""
    from PIL import Image

    folder = os.path.join(samples, rel.split("/")[0], "screenshot")
    names = sorted(n for n in os.listdir(folder) if n.startswith("screenshot.")) if os.path.isdir(folder) else []
    if not names:
        return None
    ref = Image.open(os.path.join(folder, names[0])).convert("RGB")  # a GIF: its first frame
    ref.thumbnail((TILE, TILE))
    pad = Image.new("RGB", (TILE, TILE), (255, 255, 255))
    pad.paste(ref, ((TILE - ref.width) // 2, (TILE - ref.height) // 2))
    return np.asarray(pad)


def _verdict(samples, rel, table) -> str:
    """The label of ``rel``'s row of ``benchmarks/corpus_geometry.py`` (from ``table``, its CSV by file, when
    given; else checked here); ``-`` for a file that check does not cover."""
    from benchmarks.corpus_geometry import CLOSED_FORM, check

    if table is not None:
        row = table.get(rel)
    else:
        kind = "vs plain" if rel.split("/")[1] != "glTF" and "Embedded" not in rel else "closed form"
        row = None if kind == "closed form" and rel not in CLOSED_FORM else check(samples, rel, kind)
    if row is None:
        return "-"
    yes = lambda v: v in (True, "True")  # noqa: E731 (the CSV's text, or the row's bool)
    if not yes(row["loaded"]):
        return "fail"
    return ("ok" if yes(row["right"]) else "X") + (" W" if yes(row["warned"]) else "")


def main(argv=None):
    """Draw the sheet; ``--quick`` writes it into the git-ignored ``out/quick/images/``."""
    from PIL import Image, ImageDraw

    argv = sys.argv[1:] if argv is None else list(argv)
    paths = [a for k, a in enumerate(argv) if not a.startswith("-") and argv[k - 1:k] != ["--verdicts"]] or [os.environ.get("KHRONOS_SAMPLES", "")]
    if not os.path.isdir(paths[0]):  # the runner (python -m docs.figures) passes none: say why nothing is drawn
        print("docs.figures.samples: skipped, it needs the Khronos samples: python -m docs.figures.samples SAMPLES "
              "[--quick] or KHRONOS_SAMPLES=SAMPLES (SAMPLES: glTF-Sample-Models' 2.0 folder)", file=sys.stderr)
        return 2
    samples = paths[0]
    table = None
    if "--verdicts" in argv:  # the CSV of `corpus_check.py geometry SAMPLES --out CSV`: not checked again
        import csv

        with open(argv[argv.index("--verdicts") + 1], newline="") as fh:
            table = {r["file"].replace(os.sep, "/"): r for r in csv.DictReader(fh)}
    present = [s for s in SAMPLES if os.path.exists(os.path.join(samples, s[1]))]
    for cls, rel, _ in SAMPLES:
        if (cls, rel, _) not in present:
            print(f"docs.figures.samples: {rel} ({cls}) is not in {samples}: left out", file=sys.stderr)
    out = images_dir("--quick" in argv)
    os.makedirs(out, exist_ok=True)
    per_row, head, gap = 2, 14, 8
    rows = (len(present) + per_row - 1) // per_row
    width = per_row * 2 * TILE + (per_row - 1) * gap
    sheet = Image.new("RGB", (width, head + rows * (TILE + head)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    draw.text((4, 1), "each pair: ours (Phong, two lights) | the sample's screenshot (PBR, environment light)",
              fill=(0, 0, 0))
    for k, (cls, rel, direction) in enumerate(present):
        x, y = (k % per_row) * (2 * TILE + gap), head + (k // per_row) * (TILE + head)
        label = f"{cls}: {rel.split('/')[0]} {rel.split('/')[1].replace('glTF-', '')} [{_verdict(samples, rel, table)}]"
        draw.text((x + 2, y + 1), label, fill=(0, 0, 0))
        sheet.paste(Image.fromarray(_render(os.path.join(samples, rel), direction)), (x, y + head - 2))
        shot = _shot(samples, rel)
        if shot is None:
            draw.text((x + TILE + 8, y + TILE // 2), "no screenshot in this copy", fill=(120, 120, 120))
        else:
            sheet.paste(Image.fromarray(shot), (x + TILE, y + head - 2))
        print(rel, "done", flush=True)
    path = os.path.join(out, "files_classes.png")
    sheet.save(path, optimize=True)
    print("wrote", path, os.path.getsize(path), "bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
