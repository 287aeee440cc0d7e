"""Figure for docs/gradients.md: the vertex-normal gradient under flat, Gouraud and Phong shading.

``python -m docs.figures.normal_gradients [--quick]`` writes ``normal_gradients.png`` into
``docs/images/``: a 64x48 icosphere (162 vertices) with a highlight under one point light, the
loss its mean brightness; per method the render, each pixel's ``|dL/dn|`` of its triangle's three
vertex normals (interpolated with its barycentrics, log scale, black: exactly 0) and every vertex
normal's ``|dL/dn|`` sorted. Flat's gradient is exactly 0 (it shades with the face normal); the
notebook ``notebooks/flat_vs_gouraud_gradient.ipynb`` draws the same, step by step.
"""

from __future__ import annotations

import os
import sys

import numpy as np

import raycast_shade as rs

from benchmarks.outputs import images_dir

METHODS = ("flat", "gouraud", "phong")


def gradients():
    """The scene, its frames and each method's ``dL/dN`` (V, 3) for the mean brightness."""
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(kd=(0.8, 0.4, 0.3), ks=0.4, shininess=30.0))],
                     lights=[rs.PointLight((2.0, 2.5, 4.0), intensity=25.0, attenuation="inverse_square")],
                     camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=64, height=48), ambient=0.1)
    frames = {m: rs.render(scene, m) for m in METHODS}
    dL_dI = np.full(frames["flat"].image.shape, 1.0 / frames["flat"].image.size)
    return scene, frames, {m: rs.grad(scene, dL_dI, "normals", shading=m, frame=frames[m])["normals"]
                           for m in METHODS}


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    scene, frames, grads = gradients()
    assert not np.any(grads["flat"]) and np.any(grads["gouraud"]) and np.any(grads["phong"])
    geo, hits = scene.geometry, frames["phong"].hits
    mask = hits.prim >= 0
    tri = geo.faces[geo.face_offsets[hits.geom[mask]] + hits.prim[mask]]
    bary = np.stack([1.0 - hits.u[mask] - hits.v[mask], hits.u[mask], hits.v[mask]], axis=1)
    size = {m: np.linalg.norm(g, axis=1) for m, g in grads.items()}
    top = max(s.max() for s in size.values())
    cmap = plt.get_cmap("viridis").with_extremes(under="black", bad="black")
    fig, axes = plt.subplots(3, 3, figsize=(11, 8), gridspec_kw=dict(height_ratios=[1, 1, 0.8]))
    for col, m in enumerate(METHODS):
        axes[0, col].imshow(rs.to_uint8(frames[m].image)); axes[0, col].set_title(m); axes[0, col].axis("off")
        picture = np.zeros(mask.shape)
        picture[mask] = np.sum(bary * size[m][tri], axis=1)
        axes[1, col].imshow(picture, cmap=cmap, norm=LogNorm(vmin=1e-4 * top, vmax=top)); axes[1, col].axis("off")
        axes[1, col].set_title(f"|dL/dn| over the pixels ({m})", fontsize=9)
        if np.any(size[m] > 0):
            axes[2, col].bar(np.arange(len(size[m])), np.sort(size[m])[::-1], color="C0", width=1.0)
            axes[2, col].set_yscale("log"); axes[2, col].set_ylim(1e-6 * top, 2 * top)
        else:  # nothing to draw on a log scale
            axes[2, col].text(0.5, 0.5, f"all {len(size[m])} exactly 0", ha="center", transform=axes[2, col].transAxes)
        axes[2, col].set_xlabel("vertex (sorted)"); axes[2, col].set_title(f"max {size[m].max():.2g}", fontsize=9)
    axes[2, 0].set_ylabel("|dL/dn|")
    fig.suptitle("dL/d(vertex normal), L = mean brightness: flat's is exactly zero")
    plt.tight_layout()
    out = images_dir("--quick" in argv)
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, "normal_gradients.png")
    fig.savefig(path, dpi=72)
    print("wrote", path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
