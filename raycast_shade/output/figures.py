"""Figures for the lecture hall and the notebook: montages, differences, scanlines.

Each function returns a :class:`matplotlib.figure.Figure` made without
pyplot (no global figure list, no backend to choose): Jupyter shows it as
the cell's value, and ``fig.savefig("x.png")`` writes it. Matplotlib is an
optional dependency, imported on first use: ``pip install
'raycast_shade[notebook]'``.

* :func:`montage`: images side by side, tone-mapped as ``Frame.save`` does;
* :func:`difference`: a heatmap of ``a - b`` with a colour bar;
* :func:`profile`: one image row as a plot of each channel, where
  Gouraud's kinks (the Mach bands) show at the triangle edges.

Differences and profiles are of the *linear* images (the renderer's units),
not of the 8-bit ones.
"""

from __future__ import annotations

import numpy as np

from ..common.extras import require
from ..common.validate import as_array, as_int, as_name, as_scalar
from .tonemap import to_uint8

__all__ = ["montage", "difference", "profile", "LUMINANCE"]

# Rec. 709 / sRGB luminance weights of linear R, G, B.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def _figure(what: str, **kwargs):
    return require("matplotlib.figure", "matplotlib", what, "notebook").Figure(**kwargs)


def _linear(x, name: str) -> np.ndarray:
    """(H, W, 3) float64 linear image of a Frame or an array ((H, W) is grey)."""
    a = as_array(getattr(x, "image", x), name, dtype=np.float64, finite=False)  # strings, None, booleans refused
    if a.ndim == 2:
        a = np.repeat(a[..., None], 3, axis=2)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"{name}: expected a Frame, an (H, W, 3) or an (H, W) image, got shape {a.shape}")
    return a


def montage(frames_or_images, labels=None, *, columns: int | None = None, panel_width: float = 4.0, **tone):
    """Images side by side, each with its label as a title.

    Parameters
    ----------
    frames_or_images : sequence of Frame or (H, W, 3) float
        Linear images; frames contribute ``frame.image``.
    labels : sequence of str, optional
        One per image; by default a frame's shading method.
    columns : int, optional
        Panels per row; all in one row by default.
    panel_width : float
        Inches per panel.
    **tone
        ``exposure``, ``tonemap``, ``gamma`` of :func:`~raycast_shade.output.tonemap.to_uint8`.

    Returns
    -------
    matplotlib.figure.Figure
        One axes per image, in order.
    """
    if isinstance(frames_or_images, (str, np.ndarray)) or not hasattr(frames_or_images, "__iter__"):
        raise TypeError(f"frames_or_images: expected a sequence of frames or images, "
                        f"got {type(frames_or_images).__name__}")
    items = list(frames_or_images)
    if not items:
        raise ValueError("frames_or_images: expected at least one image")
    images = [_linear(x, f"frames_or_images[{i}]") for i, x in enumerate(items)]
    if labels is None:
        labels = [x.shading if isinstance(getattr(x, "shading", None), str) else "" for x in items]
    if isinstance(labels, (str, np.ndarray)) or not hasattr(labels, "__iter__"):
        raise TypeError(f"labels: expected a sequence of strings, got {type(labels).__name__}")
    labels = [as_name(label, f"labels[{i}]") for i, label in enumerate(labels)]
    if len(labels) != len(images):
        raise ValueError(f"labels: expected {len(images)}, got {len(labels)}")
    columns = len(images) if columns is None else as_int(columns, "columns", minimum=1, maximum=len(images))
    panel_width = as_scalar(panel_width, "panel_width", minimum=0.0, exclusive=True, maximum=1000.0)
    rows = -(-len(images) // columns)
    h, w = images[0].shape[:2]
    fig = _figure("montage", figsize=(panel_width * columns, panel_width * rows * h / w + 0.4 * rows),
                  layout="constrained")
    for i, (img, label) in enumerate(zip(images, labels)):
        ax = fig.add_subplot(rows, columns, i + 1)
        ax.imshow(to_uint8(img, **tone), interpolation="nearest")
        ax.set_title(label)
        ax.set_axis_off()
    return fig


def difference(a, b, *, signed: bool = True, title: str | None = None, width: float = 6.0):
    """Heatmap of the per-pixel luminance difference ``Y(a) - Y(b)``, with a colour bar.

    ``Y`` is the Rec. 709 luminance of the linear image (:data:`LUMINANCE`),
    one number per pixel that weighs the channels as the eye does, in the
    renderer's linear units.

    Parameters
    ----------
    a, b : Frame or (H, W, 3) float
        Same shape.
    signed : bool
        ``True``: ``Y(a) - Y(b)`` on a diverging map symmetric about 0 (red:
        ``a`` brighter, blue: ``b`` brighter). ``False``: ``|Y(a) - Y(b)|``
        from 0 up.
    title : str, optional
    width : float
        Figure width in inches.

    Returns
    -------
    matplotlib.figure.Figure
        Two axes: the heatmap, and its colour bar.
    """
    la, lb = _linear(a, "a"), _linear(b, "b")
    width = as_scalar(width, "width", minimum=0.0, exclusive=True, maximum=1000.0)  # inches
    if title is not None:
        title = as_name(title, "title")
    if la.shape != lb.shape:
        raise ValueError(f"b: expected the shape of a, {la.shape}, got {lb.shape}")
    d = la @ LUMINANCE - lb @ LUMINANCE
    h, w = d.shape
    fig = _figure("difference", figsize=(width, width * h / w * 0.85 + 0.5), layout="constrained")
    ax = fig.add_subplot()
    if signed:
        m = float(np.max(np.abs(d))) or 1.0
        im = ax.imshow(d, cmap="RdBu_r", vmin=-m, vmax=m, interpolation="nearest")
        label = "luminance difference a - b (linear)"
    else:
        d = np.abs(d)
        im = ax.imshow(d, cmap="magma", vmin=0.0, vmax=float(d.max()) or 1.0, interpolation="nearest")
        label = "|luminance difference| (linear)"
    fig.colorbar(im, ax=ax, label=label, shrink=0.9)
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    return fig


def profile(frame, row: int, *, columns=None, edges: bool = True, title: str | None = None):
    """One image row as a plot of its R, G and B channels (linear).

    Gouraud shading is linear across each triangle, so the profile is a
    polyline whose kinks sit on the triangle edges: the eye exaggerates each
    kink into a light or dark band (Mach bands). Phong's profile is smooth.

    Parameters
    ----------
    frame : Frame or (H, W, 3) float
    row : int
        Image row, 0 at the top.
    columns : slice or (start, stop), optional
        The part of the row to plot; all of it by default.
    edges : bool
        With a Frame: faint vertical lines where the row crosses from one
        triangle to another.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
        One axes whose ``lines`` are the three channels (red, green, blue).
    """
    img = _linear(frame, "frame")
    if title is not None:
        title = as_name(title, "title")
    h, w = img.shape[:2]
    row = as_int(row, "row", minimum=0, maximum=h - 1)
    cols = slice(*columns) if isinstance(columns, tuple) else (columns or slice(None))
    x = np.arange(w)[cols]
    line = img[row, cols]
    fig = _figure("profile", figsize=(7.0, 3.2), layout="constrained")
    ax = fig.add_subplot()
    for c, (name, colour) in enumerate((("R", "tab:red"), ("G", "tab:green"), ("B", "tab:blue"))):
        ax.plot(x, line[:, c], color=colour, label=name, lw=1.2)
    hits = getattr(frame, "hits", None)
    if edges and hits is not None:
        tri = (hits.geom[row, cols].astype(np.int64) << 32) | (hits.prim[row, cols].astype(np.int64) & 0xFFFFFFFF)
        change = x[1:][tri[1:] != tri[:-1]] - 0.5
        if len(change):
            ax.vlines(change, 0.0, 1.0, transform=ax.get_xaxis_transform(), colors="0.7", lw=0.6, zorder=0,
                      label="triangle edge")
    ax.set_xlabel("column (pixels)")
    ax.set_ylabel("linear intensity")
    ax.set_xlim(x[0] - 0.5, x[-1] + 0.5)
    ax.set_ylim(bottom=0.0)
    ax.legend(loc="upper right", fontsize="small")
    ax.set_title(title if title is not None else f"row {row}")
    return fig
