"""Figure for docs/gradients.md: the gradient image of a triangle's x-translation, interior plus edges.

``python -m docs.figures.gradients_edges [--quick]`` writes ``gradients_edges.png`` into
``docs/images/``: a Phong-lit triangle over a background (point light, anti-aliased), then
``dI/dx`` per pixel (summed over RGB) three ways: ``rs.grad``'s interior term alone (the triangle
held in every pixel), interior plus the edge term (``edges=True``, 16 samples per pixel of edge;
the interior at the pixel centres), and central finite differences of the 16x16-ray anti-aliased image
(step 0.01 world units, 0.2 pixel). A pixel's gradient is ``rs.grad`` of the loss ``I[y, x]``: one
call per pixel (the figure is 48x36).
"""

from __future__ import annotations

import os
import sys

import numpy as np

import raycast_shade as rs

from benchmarks.outputs import images_dir

from .gradient_panels import anti_aliased, four_panels, per_pixel

W, H, K, STEP = 48, 36, 16, 0.01


def scene(shift=0.0):
    v = np.array([[-1.0, -0.8, 0.0], [1.2, -0.5, 0.2], [-0.1, 1.0, -0.1]]) + np.array([shift, 0.0, 0.0])
    material = rs.Material(ka=0.2, kd=(0.8, 0.5, 0.3), ks=0.4, shininess=8.0)
    return rs.Scene([rs.Model(rs.Mesh(v, [[0, 1, 2]]), material)],
                    lights=[rs.PointLight((1.0, 1.5, 2.0), intensity=6.0, attenuation="inverse_square")],
                    camera=rs.Camera(eye=(0.2, 0.1, 4.0), target=(0.0, 0.0, 0.0), width=W, height=H),
                    ambient=0.2, background=(0.15, 0.2, 0.3))


def gradient_images():
    """``dI/dx`` (H, W), summed over RGB: the interior alone, interior + edges, finite differences."""
    s = scene()
    frame = rs.render(s, "phong")
    inner = per_pixel(lambda g: rs.grad(s, g, "vertices", frame=frame)["vertices"][:, 0].sum(), H, W)
    total = per_pixel(lambda g: rs.grad(s, g, "vertices", frame=frame, edges=True,
                                        edge_density=16.0)["vertices"][:, 0].sum(), H, W)
    fd = (anti_aliased(scene(STEP), "phong", K) - anti_aliased(scene(-STEP), "phong", K)).sum(axis=2) / (2.0 * STEP)
    return frame.image, inner, total, fd


def draw(image, inner, total, fd, path):
    err = np.abs(total.sum() - fd.sum()) / np.abs(fd).sum()
    four_panels(image, "the image (one ray a pixel)",
                [("rs.grad:\ninterior only", inner), ("rs.grad:\ninterior + edges", total),
                 ("finite differences\n(16x16 rays a pixel)", fd)], "dI/dx (RGB summed)",
                f"d image / d (x-translation): sum over pixels {total.sum():.2f} (rs.grad) against "
                f"{fd.sum():.2f} (differences); |difference| / sum|FD| = {err:.3f}", path)


def main(argv=None):
    """Draw the figure; ``--quick`` writes it into the git-ignored ``out/quick/images/``."""
    argv = sys.argv[1:] if argv is None else list(argv)
    out = images_dir("--quick" in argv)
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, "gradients_edges.png")
    draw(*gradient_images(), path)
    print("wrote", path)
    return 0


if __name__ == "__main__":
    main()
