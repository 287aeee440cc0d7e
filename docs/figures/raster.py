"""Figures and agreement figures for docs/raster.md.

* ``docs/images/raster_side_by_side.png``: ray cast | rasterized | their
  difference (of the linear images, on a log scale, since the 8-bit images
  are identical almost everywhere), for flat, Gouraud and Phong shading;
* ``docs/images/raster_interpolation.png``: Gouraud shading of one large
  triangle at a grazing angle, perspective-correct | screen-space | difference;
* ``benchmarks/results/raster_agreement.csv`` and a Markdown table on stdout:
  per shading mode and interpolation, the fraction of commonly covered pixels
  whose 8-bit colours agree within 1/255, and the fraction of the image that
  only one method covers, over several meshes, views and both projections.

Usage::

    python -m docs.figures.raster [--quick]
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np

import raycast_shade as rs
from raycast_shade.shading.shade import shade
from raycast_shade.visibility.interpolation import to_screen_space
from raycast_shade.visibility.raster import rasterize

from benchmarks.outputs import images_dir, results_dir

LOG_RANGE = (-8.0, -4.0)  # the difference panel's colour scale, log10 of linear intensity
WIDTH, HEIGHT = 320, 240


def _mat(kd=(0.8, 0.4, 0.2), ks=0.6, shininess=40.0):
    return rs.Material(kd=kd, ks=ks, shininess=shininess, ka=0.5)


def _lights():
    return [rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, color=(1.0, 0.9, 0.8), attenuation="inverse_square"),
            rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.4)]


def views():
    """(name, scene, eye, target, ortho_height): the test suite's scenes."""
    sc = lambda models, lights=None: rs.Scene(models, lights=_lights() if lights is None else lights, ambient=0.05)  # noqa: E731
    yield "icosphere", sc([rs.Model(rs.shapes.icosphere(3), _mat())]), (0.3, 0.5, 3.2), (0, 0, 0), 2.6
    yield "torus", sc([rs.Model(rs.shapes.torus(), _mat())]), (0.5, 2.0, 2.5), (0, 0, 0), 3.0
    yield "cube (creased)", sc([rs.Model(rs.shapes.cube(), _mat((0.3, 0.7, 0.9)))]), (1.6, 1.2, 2.0), (0, 0, 0), 2.2
    yield ("grazing plane", sc([rs.Model(rs.shapes.plane(size=4.0, subdivisions=12, normal="+y"), _mat())],
                               [rs.PointLight((0.5, 1.0, 0.0), intensity=3.0)]), (0.0, 0.25, 3.0), (0.0, 0.0, -1.0), 1.2)
    yield "three models", multi_scene(), (0.4, 1.2, 3.0), (0, 0, 0), 3.0


def multi_scene():
    return rs.Scene([
        rs.Model(rs.shapes.icosphere(2, radius=0.6, center=(-0.8, 0.0, 0.0)), _mat()),
        rs.Model(rs.shapes.torus(0.5, 0.2, center=(0.7, 0.0, 0.0)), _mat((0.2, 0.6, 0.9), 0.4, 20.0)),
        rs.Model(rs.shapes.cube(0.7, center=(0.0, 0.1, -0.9)), _mat((0.9, 0.9, 0.3), 0.0)),
    ], lights=_lights(), ambient=0.05)


def images(scene, camera, hits, mode, interpolation):
    if interpolation == "screen":
        hits = to_screen_space(hits, scene.geometry, camera)
    return rs.to_uint8(shade(scene, camera, hits, mode))


def agreement():
    """Rows of (mode, interpolation, scene, projection, covered, within, only)."""
    rows = []
    for name, scene, eye, target, oh in views():
        for projection in ("perspective", "orthographic"):
            camera = rs.Camera(eye=eye, target=target, width=WIDTH, height=HEIGHT, projection=projection,
                               ortho_height=oh)
            raster = rasterize(scene.geometry, camera)
            cast = rs.cast_camera(scene.geometry, camera)
            both = raster.mask & cast.mask
            only = int((raster.mask ^ cast.mask).sum())
            for interpolation in ("perspective", "screen"):
                for mode in ("flat", "gouraud", "phong"):
                    a = images(scene, camera, raster, mode, interpolation).astype(int)
                    b = images(scene, camera, cast, mode, interpolation).astype(int)
                    d = np.abs(a - b).max(axis=2)[both]
                    rows.append(dict(mode=mode, interpolation=interpolation, scene=name, projection=projection,
                                     pixels=WIDTH * HEIGHT, covered_both=int(both.sum()),
                                     within_1=int((d <= 1).sum()), only_one=only, max_diff=int(d.max())))
    return rows


def summarise(rows):
    print("| shading | interpolation | within 1/255 (all views) | worst view | only one covers (all) | worst view |")
    print("|---|---|---|---|---|---|")
    for interpolation in ("perspective", "screen"):
        for mode in ("flat", "gouraud", "phong"):
            sel = [r for r in rows if r["mode"] == mode and r["interpolation"] == interpolation]
            within = sum(r["within_1"] for r in sel) / sum(r["covered_both"] for r in sel)
            worst = min(r["within_1"] / r["covered_both"] for r in sel)
            only = sum(r["only_one"] for r in sel) / sum(r["pixels"] for r in sel)
            worst_only = max(r["only_one"] / r["pixels"] for r in sel)
            print(f"| {mode} | {interpolation} | {100 * within:.4f} % | {100 * worst:.4f} % | {100 * only:.4f} % "
                  f"| {100 * worst_only:.4f} % |")


def side_by_side(path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scene = multi_scene()
    camera = rs.Camera(eye=(0.4, 1.2, 3.0), width=WIDTH, height=HEIGHT)
    raster = rasterize(scene.geometry, camera)
    cast = rs.cast_camera(scene.geometry, camera)
    fig, axes = plt.subplots(3, 3, figsize=(3 * WIDTH / 100, 3 * HEIGHT / 100 + 0.9), dpi=100)
    for row, (mode, interpolation) in enumerate((("flat", "perspective"), ("gouraud", "screen"),
                                                 ("phong", "perspective"))):
        a = images(scene, camera, cast, mode, interpolation)
        b = images(scene, camera, raster, mode, interpolation)
        n = int((np.abs(a.astype(int) - b.astype(int)).max(axis=2) > 1).sum())
        # The 8-bit images agree to the last bit almost everywhere, so show the
        # difference of the linear images, amplified: Embree's float32 noise.
        ha, hb = cast, raster
        if interpolation == "screen":
            ha, hb = to_screen_space(cast, scene.geometry, camera), to_screen_space(raster, scene.geometry, camera)
        lin = np.abs(shade(scene, camera, ha, mode) - shade(scene, camera, hb, mode)).max(axis=2)
        with np.errstate(divide="ignore"):
            logd = np.where(lin > 0, np.log10(np.maximum(lin, 1e-30)), np.nan)
        for col, (img, title) in enumerate(((a, f"ray cast ({mode}, {interpolation})"),
                                            (b, f"rasterized ({mode}, {interpolation})"),
                                            (logd, f"log10 |linear difference|, max {lin.max():.1e}\n"
                                                   f"8-bit: {n} px differ by more than 1/255"))):
            ax = axes[row, col]
            if col < 2:
                ax.imshow(img, interpolation="nearest")
            else:
                ax.set_facecolor("black")
                im = ax.imshow(img, interpolation="nearest", cmap="magma", vmin=LOG_RANGE[0], vmax=LOG_RANGE[1])
                ax.imshow(np.zeros(img.shape + (4,)), interpolation="nearest")  # keeps the axes' extent
                fig.colorbar(im, ax=ax, fraction=0.035, pad=0.02).ax.tick_params(labelsize=6)
            ax.set_title(title, fontsize=8)
            ax.set_xticks([])
            ax.set_yticks([])
    fig.suptitle("The same hit buffer from Embree and from the z-buffer rasterizer, shaded by the same kernels",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def interpolation_figure(path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    verts = np.array([[-1.5, 0.0, 0.5], [1.5, 0.0, 0.5], [0.0, 0.0, -12.0]])
    normals = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])
    mesh = rs.Mesh(verts, np.array([[0, 1, 2]]), normals=normals)
    scene = rs.Scene([rs.Model(mesh, rs.Material(kd=0.9, ka=0.0))],
                     lights=[rs.DirectionalLight((0.0, -1.0, 0.0))], ambient=0.0)
    camera = rs.Camera(eye=(0.0, 0.6, 2.0), target=(0.0, 0.0, -3.0), width=WIDTH, height=HEIGHT, fov=50.0)
    hits = rasterize(scene.geometry, camera)
    a = images(scene, camera, hits, "gouraud", "perspective")
    b = images(scene, camera, hits, "gouraud", "screen")
    diff = np.clip(np.abs(a.astype(int) - b.astype(int)) * 2, 0, 255).astype(np.uint8)
    fig, axes = plt.subplots(1, 3, figsize=(3 * WIDTH / 100, HEIGHT / 100 + 0.6), dpi=100)
    for ax, img, title in zip(axes, (a, b, diff), ("Gouraud, perspective-correct (3D)",
                                                    "Gouraud, screen-space (2D, scanline)", "|difference| x 2")):
        ax.imshow(img, interpolation="nearest")
        ax.set_title(title, fontsize=8)
        ax.axis("off")
    fig.suptitle("One triangle at a grazing angle: shades 0.9, 0.9 at the near corners, 0 at the far one",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(argv=None):
    """Draw the figures and write the agreement CSV; ``--quick`` writes into the git-ignored quick/ folders."""
    argv = sys.argv[1:] if argv is None else list(argv)
    quick = "--quick" in argv
    out = Path(images_dir(quick))
    out.mkdir(parents=True, exist_ok=True)
    side_by_side(out / "raster_side_by_side.png")
    interpolation_figure(out / "raster_interpolation.png")
    rows = agreement()
    res = Path(results_dir(quick))
    res.mkdir(parents=True, exist_ok=True)
    with open(res / "raster_agreement.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    summarise(rows)
    print(f"wrote {out / 'raster_side_by_side.png'}, {out / 'raster_interpolation.png'}, "
          f"{res / 'raster_agreement.csv'}")


if __name__ == "__main__":
    main()
