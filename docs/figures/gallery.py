"""Pictures for docs/gallery.md: the teaching tools on one coarse scene.

* ``docs/images/gallery_montage.png``: flat | Gouraud | Phong (``rs.figures.montage``);
* ``docs/images/gallery_difference.png``: Gouraud minus Phong, luminance (``rs.figures.difference``);
* ``docs/images/gallery_profile.png``: one Gouraud scanline through the sphere, whose
  kinks at the triangle edges are the Mach bands (``rs.figures.profile``);
* ``docs/images/gallery_wireframe.png``: the Gouraud frame with its visible triangle
  edges, vertices and normals drawn from the hit buffer (``frame.overlay``).

Needs matplotlib (``pip install 'raycast_shade[notebook]'``). Usage::

    python -m docs.figures.gallery [--quick]
"""

from __future__ import annotations

import sys
from pathlib import Path

import raycast_shade as rs

from benchmarks.outputs import images_dir

IMAGES = Path(images_dir(False))
WIDTH, HEIGHT = 360, 240
ROW = 118  # through the sphere, below its highlight


def scene(width: int = WIDTH, height: int = HEIGHT) -> rs.Scene:
    """A coarse sphere and torus on a floor, one warm key light and a cool fill."""
    models = [
        rs.Model(rs.shapes.uv_sphere(8, 12, radius=0.8, center=(-0.95, 0.8, 0.0)),
                 rs.Material(kd=(0.85, 0.25, 0.15), ka=(0.85, 0.25, 0.15), ks=0.6, shininess=40)),
        rs.Model(rs.shapes.torus(0.6, 0.25, 16, 8, center=(1.0, 0.75, 0.0)),
                 rs.Material(kd=(0.2, 0.45, 0.9), ka=(0.2, 0.45, 0.9), ks=0.7, shininess=30)),
        rs.Model(rs.shapes.plane(8.0, subdivisions=4, normal="+y"), rs.Material(kd=0.45, ka=0.45, ks=0.2, shininess=20)),
    ]
    lights = [rs.PointLight((2.0, 4.0, 3.0), intensity=22.0, color=(1.0, 0.93, 0.8), attenuation="inverse_square"),
              rs.DirectionalLight((1.0, -0.4, -0.5), intensity=0.35, color=(0.4, 0.55, 1.0))]
    camera = rs.Camera(eye=(0.0, 1.9, 4.6), target=(0.0, 0.7, 0.0), fov=38.0, width=width, height=height)
    return rs.Scene(models, lights=lights, camera=camera, ambient=0.06)


def main(argv=None) -> int:
    """Draw the pictures; ``--quick`` writes them into the git-ignored ``out/quick/images/``."""
    global IMAGES
    argv = sys.argv[1:] if argv is None else list(argv)
    IMAGES = Path(images_dir("--quick" in argv))
    IMAGES.mkdir(parents=True, exist_ok=True)
    s = scene()
    frames = {m: rs.render(s, m) for m in rs.SHADINGS}
    print({m: repr(f) for m, f in frames.items()})
    fig = rs.figures.montage(frames.values(), ["flat", "Gouraud", "Phong"], panel_width=3.6)
    fig.savefig(IMAGES / "gallery_montage.png", dpi=110)
    fig = rs.figures.difference(frames["gouraud"], frames["phong"],
                                title="Gouraud - Phong: lost and polygonal highlights")
    fig.savefig(IMAGES / "gallery_difference.png", dpi=100)
    fig = rs.figures.profile(frames["gouraud"], ROW, columns=(40, 200),
                             title=f"Gouraud, row {ROW}: straight between edges, kinked at them (Mach bands)")
    fig.savefig(IMAGES / "gallery_profile.png", dpi=100)
    g = frames["gouraud"]
    img = g.overlay(wireframe=True, width=1.0, color=(0.9, 0.9, 0.9))
    img = g.overlay(wireframe=False, vertices=True, radius=2.0, color=(1.0, 0.85, 0.1), image=img)
    img = g.overlay(wireframe=False, normals=True, length=0.18, color=(0.2, 1.0, 0.4), image=img)
    rs.figures.montage([g.image, img], ["Gouraud", "edges, vertices, normals"], panel_width=4.2).savefig(
        IMAGES / "gallery_wireframe.png", dpi=100)
    return 0


if __name__ == "__main__":
    main()
