"""Figure for docs/gradients.md: the gradient image of a point light's x-position at a hard shadow.

``python -m docs.figures.gradients_shadow_edges [--quick]`` writes ``gradients_shadow_edges.png``
into ``docs/images/``: a triangle (flat) over a Phong plane, a point light casting shadows, a camera
looking down, then ``dI/d(light x)`` per pixel (summed over RGB) three ways: ``rs.grad``'s interior
term alone (each pixel's light visibility held), interior plus edges (``edges=True``, 16 samples
per pixel of outline; the interior at the pixel centres), and central finite differences of the
16x16-ray anti-aliased image (step 0.01). A pixel's gradient is ``rs.grad`` of the loss
``I[y, x]``: one call per pixel (the figure is 48x36).
"""

from __future__ import annotations

import os
import sys

import numpy as np

import raycast_shade as rs

from benchmarks.outputs import images_dir

from .gradient_panels import anti_aliased, four_panels, per_pixel

W, H, K, STEP = 48, 36, 16, 0.01
SHADING = ("phong", "flat")
LIGHT = np.array([1.2, 0.9, 3.0])


def scene(dx=0.0):
    tri = np.array([[-0.6, -0.4, 0.8], [0.3, -0.5, 0.9], [-0.2, 0.45, 0.7]])
    plane = rs.Mesh(np.array([[-3.0, -3.0, 0.0], [3.0, -3.0, 0.0], [3.0, 3.0, 0.0], [-3.0, 3.0, 0.0]]),
                    [[0, 1, 2], [0, 2, 3]])
    light = rs.PointLight(tuple(LIGHT + (dx, 0.0, 0.0)), intensity=12.0, attenuation="inverse_square", shadows=True)
    return rs.Scene([rs.Model(plane, rs.Material(ka=0.2, kd=(0.8, 0.7, 0.6), ks=0.0)),
                     rs.Model(rs.Mesh(tri, [[0, 1, 2]]), rs.Material(ka=0.2, kd=(0.3, 0.5, 0.8), ks=0.0))],
                    lights=[light], ambient=0.2, background=(0.1, 0.1, 0.1),
                    camera=rs.Camera(eye=(0.1, -0.2, 3.0), target=(0.0, 0.0, 0.0), width=W, height=H))


def gradient_images():
    """``dI/d(light x)`` (H, W), summed over RGB: the interior alone, interior + edges, differences."""
    s = scene()
    frame = rs.render(s, SHADING)
    inner = per_pixel(lambda g: rs.grad(s, g, "light_position", shading=SHADING,
                                        frame=frame)["light_position"][0, 0], H, W)
    total = per_pixel(lambda g: rs.grad(s, g, "light_position", shading=SHADING, frame=frame, edges=True,
                                        edge_density=16.0)["light_position"][0, 0], H, W)
    fd = (anti_aliased(scene(STEP), SHADING, K) - anti_aliased(scene(-STEP), SHADING, K)).sum(axis=2) / (2.0 * STEP)
    return anti_aliased(s, SHADING, K), inner, total, fd


def draw(image, inner, total, fd, path):
    err = np.abs(total - fd).sum() / np.abs(fd).sum()
    err_in = np.abs(inner - fd).sum() / np.abs(fd).sum()
    four_panels(image, "the image (16x16 rays a pixel)",
                [("rs.grad:\ninterior only", inner), ("rs.grad: interior\n+ edges (the outline)", total),
                 ("finite differences\n(16x16 rays a pixel)", fd)], "dI/d(light x) (RGB summed)",
                f"d image / d (light x): sum|rs.grad - FD| / sum|FD| = {err:.3f} with edges, "
                f"{err_in:.3f} interior only", path, title_y=1.0)


def main(argv=None):
    """Draw the figure; ``--quick`` writes it into the git-ignored ``out/quick/images/``."""
    argv = sys.argv[1:] if argv is None else list(argv)
    out = images_dir("--quick" in argv)
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, "gradients_shadow_edges.png")
    draw(*gradient_images(), path)
    print("wrote", path)
    return 0


if __name__ == "__main__":
    main()
