"""Draw ``docs/images/architecture.png``: the pipeline around the hit buffer, and the layer order.

The top row is one frame's path (:func:`raycast_shade.render`): the scene, its
camera rays, visibility by Embree or by the reference rasterizer, the hit
buffer both fill, the shading kernels, the frame and its file; notes under
the frame give the anti-aliasing path and the optional stages. Each box is
coloured by the stage package that owns it; the strip below is the layer
order tests/project/test_architecture.py enforces (a module imports only from its own
package and the ones to its left). See docs/architecture.md.

Usage::

    python -m docs.figures.architecture [--quick]
"""

from __future__ import annotations

import os
import sys

from benchmarks.outputs import image_file

# One colour per package (pale fill, strong edge), shared by the boxes and the layer strip.
COLOURS = {
    "common": ("#eeeeee", "#777777"),
    "scene": ("#dcebf7", "#2f6fa7"),
    "visibility": ("#fde6cf", "#c0650f"),
    "shading": ("#dff2dc", "#2e8540"),
    "output": ("#ece1f3", "#7547a0"),
    "study": ("#f7dcdc", "#b03a3a"),
    "render.py": ("#fff3c4", "#a07c00"),
    "apps": ("#d9f1f1", "#247b7b"),
    "__init__": ("#e6e6e6", "#444444"),
}
LAYERS = ("common", "scene", "visibility", "shading", "output", "study", "render.py", "apps", "__init__")


def _box(ax, x, y, w, h, package, title, body="", where="", *, title_size=11, lw=1.6):
    """A rounded box: bold title, body lines, and the owning module(s) in grey at the bottom."""
    from matplotlib.patches import FancyBboxPatch

    fill, edge = COLOURS[package]
    ax.add_patch(FancyBboxPatch((x, y), w, h, boxstyle="round,pad=0.02,rounding_size=0.9",
                                facecolor=fill, edgecolor=edge, linewidth=lw, zorder=2))
    ax.text(x + w / 2, y + h - 1.3, title, ha="center", va="top", fontsize=title_size, fontweight="bold",
            color="#1a1a1a", zorder=3)
    if body:
        ax.text(x + w / 2, y + h / 2 - 0.6, body, ha="center", va="center", fontsize=8.6, color="#1a1a1a",
                linespacing=1.35, zorder=3)
    if where:
        ax.text(x + w / 2, y + 1.0, where, ha="center", va="bottom", fontsize=7.6, color=edge, style="italic",
                linespacing=1.25, zorder=3)


def _arrow(ax, start, end, *, style="-|>", colour="#333333", lw=1.6, ls="-", rad=0.0, label="", label_xy=None,
           label_colour=None):
    from matplotlib.patches import FancyArrowPatch

    ax.add_patch(FancyArrowPatch(start, end, arrowstyle=style, mutation_scale=14, color=colour, linewidth=lw,
                                 linestyle=ls, connectionstyle=f"arc3,rad={rad}", zorder=1, shrinkA=0, shrinkB=0))
    if label:
        lx, ly = label_xy if label_xy else ((start[0] + end[0]) / 2, (start[1] + end[1]) / 2 + 1.0)
        ax.text(lx, ly, label, ha="center", va="bottom", fontsize=7.8, color=label_colour or colour,
                style="italic", zorder=3)


def draw(path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(16, 8.2), dpi=110)
    ax = fig.add_axes([0, 0, 1, 1])
    ax.set_xlim(0, 160)
    ax.set_ylim(0, 82)
    ax.axis("off")

    ax.text(80, 80.5, "raycast_shade: one frame, render(scene, shading)", ha="center", va="top", fontsize=14,
            fontweight="bold")
    ax.text(80, 77.0, "boxes are coloured by the stage package that owns them; solid arrows carry data, "
            "dashed arrows are the extra rays shading casts", ha="center", va="top", fontsize=9, color="#555555")

    # -- the pipeline row ------------------------------------------------------------------------
    _box(ax, 2, 32, 19, 30, "scene", "scene",
         "meshes, normals\n(crease angle)\nmaterials ka kd Ks t\ntextures, colours\nlights, spots, camera\n"
         "height maps\nmesh & TOML files",
         "scene/")
    _box(ax, 25, 47, 15, 15, "visibility", "camera rays", "one per pixel\ncentre, or N\nsub-pixel samples", "visibility/rays.py",
         title_size=10)
    _box(ax, 44, 47, 21, 15, "visibility", "Embree cast", "8-ray coherent packets\nBVH kept per geometry\n"
         "exact vertex re-tests", "visibility/cast, embree, accel,\nholes, watertight", title_size=10.5)
    _box(ax, 44, 28, 21, 15, "visibility", "reference rasterizer", "z-buffer, top-left rule\n"
         "perspective-correct", "visibility/raster, scan", title_size=10.5)

    # The hit buffer: the one record between visibility and shading.
    fill, edge = COLOURS["visibility"]
    from matplotlib.patches import FancyBboxPatch

    hx, hy, hw, hh = 70, 27, 24, 37
    ax.add_patch(FancyBboxPatch((hx, hy), hw, hh, boxstyle="round,pad=0.02,rounding_size=1.2", facecolor="white",
                                edgecolor=edge, linewidth=3.2, zorder=2))
    ax.text(hx + hw / 2, hy + hh - 1.4, "HIT BUFFER", ha="center", va="top", fontsize=13, fontweight="bold",
            color=edge, zorder=3)
    ax.text(hx + hw / 2, hy + hh - 5.2, "(H, W) per pixel", ha="center", va="top", fontsize=8.4, color="#555555",
            zorder=3)
    fields = [("prim", "triangle id  int32"), ("geom", "model id  int32"), ("u, v", "barycentrics  float32"),
              ("t", "ray distance  float32")]
    for i, (name, what) in enumerate(fields):
        y = hy + hh - 10.5 - 5.2 * i
        ax.add_patch(FancyBboxPatch((hx + 2, y - 3.6), hw - 4, 4.2, boxstyle="round,pad=0.02,rounding_size=0.5",
                                    facecolor=fill, edgecolor=edge, linewidth=0.8, zorder=3))
        ax.text(hx + 3.6, y - 1.5, name, ha="left", va="center", fontsize=10, fontweight="bold",
                family="monospace", zorder=4)
        ax.text(hx + hw - 3.0, y - 1.5, what, ha="right", va="center", fontsize=8.2, zorder=4)
    ax.text(hx + hw / 2, hy + 1.0, "visibility/hits.py  (HitBuffer)\n-1 / inf where nothing is hit", ha="center",
            va="bottom", fontsize=7.6, color=edge, style="italic", linespacing=1.25, zorder=3)

    _box(ax, 99, 27, 25, 37, "shading", "shading",
         "flat  |  Gouraud  |  Phong\nkernels over the hit buffer\n\nLambert, Phong / Blinn\nattenuation, spot cones\n"
         "textures, mesh colours\n\nBlinn bump maps\nshadow rays\nmirror reflections",
         "shading/", title_size=12)
    _box(ax, 129, 40, 13.5, 22, "output", "frame", "linear image\nmask, depth\nnormal, prim\nbuffers, terms\ntimings",
         "output/frame.py", title_size=10.5)
    _box(ax, 146, 40, 12, 22, "output", "file", "tone map\nsRGB 8-bit\nPNG, PFM, NPY\nbuffers: npz,\nEXR, depth PNG",
         "output/tonemap,\nimagefile, bufferfile", title_size=10.5)

    # Data flow.
    _arrow(ax, (21, 54.5), (25, 54.5))
    _arrow(ax, (40, 54.5), (44, 54.5), label="rays", label_xy=(42, 55.3))
    _arrow(ax, (21, 38), (44, 35.5), label="triangles, camera", label_xy=(32, 37.8))
    _arrow(ax, (65, 54.5), (70, 50.5))
    _arrow(ax, (65, 35.5), (70, 39.5))
    _arrow(ax, (94, 45.5), (99, 45.5))
    _arrow(ax, (124, 51), (129, 51))
    _arrow(ax, (142.5, 51), (146, 51))
    # Shading casts rays of its own: shadow rays and mirror bounces go back through Embree.
    _arrow(ax, (111, 64.4), (54.5, 62.4), ls=(0, (4, 3)), colour=COLOURS["shading"][1], rad=0.28,
           label="shadow rays, mirror rays (Embree)", label_xy=(83, 71.6))
    # The scene's packed arrays (materials, lights, normals) feed the kernels directly.
    blue = COLOURS["scene"][1]
    ax.plot([11.5, 11.5, 111.5], [32, 19, 19], color=blue, linewidth=1.3, zorder=1, solid_joinstyle="round")
    _arrow(ax, (111.5, 19), (111.5, 27), colour=blue, lw=1.3)
    ax.text(40, 19.5, "normals, materials, lights, height maps (packed rows)", ha="center", va="bottom",
            fontsize=7.8, color=blue, style="italic")
    # Screen-space weights: an optional remap of the hit buffer.
    ax.text(82, 25.6, "optional remap: screen-space weights\n(visibility/interpolation.py)", ha="center",
            va="top", fontsize=7.6, color=COLOURS["visibility"][1], style="italic")

    # Anti-aliasing and the optional stages, which the row above does not show.
    ax.text(143.5, 37.5, "samples=N: cast and shade once per\nsub-pixel camera (common/samples.py),\n"
            "face and vertex shades shared\n(SampleShading), then averaged", ha="center", va="top", fontsize=7.6,
            color=COLOURS["shading"][1], style="italic", linespacing=1.25)
    ax.text(143.5, 27.0, "optional, after the image:\nbuffers=(...)  (output/buffers.py)\n"
            "terms=True  (shading/terms.py)", ha="center", va="top", fontsize=7.6,
            color=COLOURS["output"][1], style="italic", linespacing=1.25)

    # -- the layer strip -------------------------------------------------------------------------
    ax.text(3, 12.6, "Layer order (lowest first): a module imports only from its own package and from those to "
            "its left", ha="left", va="bottom", fontsize=10, fontweight="bold")
    x0, w, gap = 3.0, 15.6, 1.8
    extras = {"common": "choices, layout,\nvalidate, samples,\nthreads, warnings",
              "scene": "meshes, textures,\nlights, camera,\nprojection, files",
              "visibility": "rays, Embree, raster,\nwatertight re-tests,\nhit buffer",
              "shading": "flat, Gouraud, Phong,\nsurfaces, textures,\nterms",
              "output": "frame, buffers,\ntone map, files,\nfigures, overlays",
              "study": "exact images, twins,\nmetrics, auto,\nexplain",
              "render.py": "render():\nthe composition", "apps": "cli, demo, animate,\nbatch, views,\nexplore",
              "__init__": "the public API"}
    for i, name in enumerate(LAYERS):
        fill, edge = COLOURS[name]
        x = x0 + i * (w + gap)
        ax.add_patch(FancyBboxPatch((x, 2.0), w, 8.6, boxstyle="round,pad=0.02,rounding_size=0.7", facecolor=fill,
                                    edgecolor=edge, linewidth=1.4, zorder=2))
        label = name if name in ("render.py", "__init__") else name + "/"
        ax.text(x + w / 2, 9.2, label, ha="center", va="top", fontsize=10, fontweight="bold", family="monospace",
                zorder=3)
        if name in extras:
            ax.text(x + w / 2, 2.7, extras[name], ha="center", va="bottom", fontsize=7.4, color=edge,
                    linespacing=1.2, zorder=3)
        if i:
            ax.text(x - gap / 2, 6.3, "<", ha="center", va="center", fontsize=12, fontweight="bold", color="#555555")

    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    """Draw the figure; ``--quick`` writes it into the git-ignored ``out/quick/images/``."""
    argv = sys.argv[1:] if argv is None else list(argv)
    path = draw(image_file("architecture.png", "--quick" in argv))
    print(f"wrote {os.path.relpath(path)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
