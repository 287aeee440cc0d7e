"""Figure for docs/gradients.md: ``rs.fit`` recovering a sphere's Phong parameters.

``python -m docs.figures.gradients [--quick]`` writes ``gradients_fit.png`` into ``docs/images/``:
a target rendered with ``kd = (0.8, 0.3, 0.2)``, ``ks = 0.5``, ``t = 40`` and a light at
``(2, 3, 4)``, fitted from a grey, dull start lit from elsewhere; the renders at a few
iterations, the target, and the loss per iteration (log scale).
"""

from __future__ import annotations

import os
import sys

import numpy as np

import raycast_shade as rs

from benchmarks.outputs import images_dir

TRUTH = dict(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40.0, position=(2.0, 3.0, 4.0))
START = dict(kd=(0.4, 0.4, 0.4), ks=0.1, shininess=10.0, position=(-1.0, 1.0, 5.0))
PARAMS = ("kd", "ks", "shininess", "light_position")


def scene(kd, ks, shininess, position, width=96, height=72):
    return rs.Scene([rs.Model(rs.shapes.icosphere(3), rs.Material(kd=kd, ks=ks, shininess=shininess))],
                    lights=[rs.PointLight(position, intensity=20.0, attenuation="inverse_square")],
                    camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=width, height=height), ambient=0.1)


def fit():
    """The target image and ``rs.fit``'s result (with its images)."""
    target = rs.render(scene(**TRUTH), "phong").image
    return target, rs.fit(scene(**START), target, PARAMS, keep_images=True)


def draw(target, result, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(result.losses) - 1
    steps = [0, min(3, n), min(10, n), n]
    fig = plt.figure(figsize=(10.0, 4.2), dpi=100)
    grid = fig.add_gridspec(2, 5, height_ratios=[1.0, 0.9], hspace=0.45)
    for k, (label, image) in enumerate([(f"iteration {s}", result.images[s]) for s in steps] + [("target", target)]):
        ax = fig.add_subplot(grid[0, k])
        ax.imshow(rs.to_uint8(image))
        ax.set_title(label, fontsize=9)
        ax.axis("off")
    ax = fig.add_subplot(grid[1, :])
    ax.semilogy(range(len(result.losses)), result.losses, marker=".", color="#c0392b")
    ax.set_xlabel("L-BFGS-B iteration")
    ax.set_ylabel("mean squared error")
    v = result.values
    ax.set_title(f"fitted kd = {np.round(v['kd'][0], 4)}, ks = {np.round(v['ks'][0], 4)}, "
                 f"t = {v['shininess'][0]:.3f}, light = {np.round(v['light_position'][0], 3)}", fontsize=9)
    fig.savefig(path)
    plt.close(fig)


def main(argv=None):
    """Draw the figure; ``--quick`` writes it into the git-ignored ``out/quick/images/``."""
    argv = sys.argv[1:] if argv is None else list(argv)
    out = images_dir("--quick" in argv)
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, "gradients_fit.png")
    draw(*fit(), path)
    print("wrote", path)
    return 0


if __name__ == "__main__":
    main()
