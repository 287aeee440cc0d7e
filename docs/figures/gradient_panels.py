"""What the per-pixel gradient figures share: the anti-aliased reference, the per-pixel gradient
image and the four-panel drawing (the image | interior only | interior + edges | differences).

Used by ``gradients_edges`` and ``gradients_shadow_edges``.
"""

from __future__ import annotations

import numpy as np

import raycast_shade as rs


def anti_aliased(scene, shading, k):
    """The image of ``scene`` with ``k`` x ``k`` rays a pixel, averaged in float64, (H, W, 3)."""
    w, h = scene.camera.width, scene.camera.height
    big = scene.replace(camera=scene.camera.replace(width=w * k, height=h * k))
    return rs.render(big, shading).image.astype(np.float64).reshape(h, k, w, k, 3).mean(axis=(1, 3))


def per_pixel(gradient, height, width):
    """``gradient(g_img)`` for the loss ``I[y, x]`` (g_img one-hot over the pixel's RGB) at every pixel.

    Parameters
    ----------
    gradient : callable
        Takes ``g_img : (H, W, 3) float64`` and returns one float.

    Returns
    -------
    (H, W) float64
    """
    out = np.zeros((height, width))
    for y in range(height):
        for x in range(width):
            g_img = np.zeros((height, width, 3))
            g_img[y, x] = 1.0
            out[y, x] = gradient(g_img)
    return out


def four_panels(image, image_title, panels, colour_label, suptitle, path, title_y=None):
    """The image, then three gradient images on one symmetric colour scale (99.5th percentile of the last).

    Parameters
    ----------
    image : (H, W, 3) float
    panels : list of (str, (H, W) float64)
        Three titled gradient images; the last (the finite differences) sets the scale.
    title_y : float, optional
        The title's height in figure units (matplotlib's default when None).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    top = float(np.percentile(np.abs(panels[-1][1]), 99.5))
    fig, axes = plt.subplots(1, 4, figsize=(11.0, 2.9), dpi=100)
    axes[0].imshow(rs.to_uint8(np.asarray(image, dtype=np.float32)))
    axes[0].set_title(image_title, fontsize=9)
    for ax, (label, g) in zip(axes[1:], panels):
        im = ax.imshow(g, cmap="RdBu_r", vmin=-top, vmax=top)
        ax.set_title(label, fontsize=9)
    for ax in axes:
        ax.axis("off")
    fig.colorbar(im, ax=axes[1:].tolist(), shrink=0.8, label=colour_label)
    fig.suptitle(suptitle, fontsize=9, **({} if title_y is None else {"y": title_y}))
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)
