"""Figures for the lecture hall and the notebook: montages, differences, scanlines.

Each function returns a :class:`matplotlib.figure.Figure` made without
pyplot (no global figure list, no backend to choose), of the subclass
:class:`~raycast_shade.output.lecturefigure.LectureFigure`: Jupyter shows it as
the cell's value, as a PNG, in any kernel and without ``%matplotlib inline``,
and ``fig.savefig("x.png")`` writes it. Matplotlib is an optional dependency,
imported on first use: ``pip install 'raycast_shade[notebook]'``.

* :func:`montage`: images side by side, tone-mapped as ``Frame.save`` does;
  given a dict (``montage(frame.terms)``), the reflectance equation's terms
  on one shared linear scale with a colour bar, and the shadow mask (and
  ``keep``) as fractions on a colour map of their own;
* :func:`difference`: a heatmap of ``a - b`` with a colour bar;
* :func:`profile`: one image row as a plot of each channel, where
  Gouraud's kinks (the Mach bands) show at the triangle edges.

Differences and profiles are of the *linear* images (the renderer's units),
not of the 8-bit ones. An 8-bit picture (``uint8``, such as ``to_uint8(img)``
or a PNG read back; ``uint16`` likewise) is decoded from sRGB to linear first,
and the figure says so in a note; any other integer array is refused, since
its scale cannot be known. The term images of :func:`terms` are linear by
definition: 8-bit ones are refused.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..common.extras import require
from ..common.validate import as_array, as_bool, as_int, as_name, as_scalar
from ..scene.texture import srgb_to_linear
from .tonemap import to_uint8

__all__ = ["montage", "terms", "difference", "profile", "LUMINANCE", "FRACTION_MAP"]

# Rec. 709 / sRGB luminance weights of linear R, G, B.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def _figure(what: str, **kwargs):
    require("matplotlib.figure", "matplotlib", what, "notebook")
    from .lecturefigure import LectureFigure

    return LectureFigure(**kwargs)


# The note a figure carries when it decoded 8-bit input.
DECODED_NOTE = "8-bit input decoded from sRGB to linear"


def _linear(x, name: str, decoded: list | None = None) -> np.ndarray:
    """(H, W, 3) float64 linear image of a Frame or an array ((H, W) is grey): radiance, so no NaN,
    infinite or negative pixel (each refused naming ``name`` and the pixel). A ``uint8`` or ``uint16``
    array is an sRGB-encoded picture: decoded, and ``name`` appended to ``decoded``; another integer
    array (``int64`` 0-255?) is refused, its scale unknown."""
    raw = getattr(x, "image", x)
    if isinstance(raw, np.ndarray) and raw.dtype in (np.uint8, np.uint16):
        if decoded is not None:
            decoded.append(name)
        raw = srgb_to_linear(raw / float(np.iinfo(raw.dtype).max))
    elif isinstance(raw, np.ndarray) and np.issubdtype(raw.dtype, np.integer):
        raise TypeError(f"{name}: {raw.dtype} pixels have no known scale; pass a linear float image, or an "
                        "8-bit picture as uint8 (decoded from sRGB, as to_uint8 and PNG files encode it)")
    a = as_array(raw, name, dtype=np.float64, finite=False)  # strings, None, booleans refused
    bad = ~np.isfinite(a) | (a < 0.0)
    if bad.any():
        at = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(f"{name}: pixel {at} is {a[at]}; a linear image is finite and not negative")
    if a.ndim == 2:
        a = np.repeat(a[..., None], 3, axis=2)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"{name}: expected a Frame, an (H, W, 3) or an (H, W) image, got shape {a.shape}")
    return a


def montage(frames_or_images, labels=None, *, columns: int | None = None, panel_width: float = 4.0, **tone):
    """Images side by side, each with its label as a title.

    Parameters
    ----------
    frames_or_images : sequence of Frame or (H, W, 3) float, or dict of str to ndarray
        Linear images; frames contribute ``frame.image``; (H, W, 3) ``uint8``
        pictures are decoded from sRGB (and shown as given, with a note). A dict (such as
        ``frame.terms``) is drawn by :func:`terms`: labelled by its keys, on
        a shared scale with colour bars.
    labels : sequence of str, optional
        One per image; by default a frame's shading method (a dict's keys).
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
    if isinstance(frames_or_images, Mapping):
        if labels is not None:
            raise ValueError("labels: a dict's keys are its labels; leave labels out")
        if tone:
            raise TypeError(f"{', '.join(tone)}: a dict of terms is drawn on a linear scale, not tone-mapped")
        return terms(frames_or_images, columns=columns, panel_width=panel_width)
    if isinstance(frames_or_images, (str, bytes, np.ndarray)) or not hasattr(frames_or_images, "__iter__"):
        raise TypeError(f"frames_or_images: expected a sequence of frames or images, or a dict, "
                        f"got {type(frames_or_images).__name__}")
    items = list(frames_or_images)
    if not items:
        raise ValueError("frames_or_images: expected at least one image")
    decoded: list = []
    images = [_linear(x, f"frames_or_images[{i}]", decoded) for i, x in enumerate(items)]
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
    if decoded:  # shown as they were (decoding then encoding is exact); the note says why they are not linear
        fig.supxlabel(f"{', '.join(decoded)}: {DECODED_NOTE}, shown as given", fontsize="small")
    return fig


def difference(a, b, *, signed: bool = True, title: str | None = None, width: float = 6.0):
    """Heatmap of the per-pixel luminance difference ``Y(a) - Y(b)``, with a colour bar.

    ``Y`` is the Rec. 709 luminance of the linear image (:data:`LUMINANCE`),
    one number per pixel that weighs the channels as the eye does, in the
    renderer's linear units.

    Parameters
    ----------
    a, b : Frame or (H, W, 3) float or (H, W, 3) uint8
        Same shape; ``uint8`` is decoded from sRGB first (the colour bar says so).
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
    decoded: list = []
    la, lb = _linear(a, "a", decoded), _linear(b, "b", decoded)
    signed = as_bool(signed, "signed")
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
    if decoded:
        label += f"\n{' and '.join(decoded)}: {DECODED_NOTE}"
    fig.colorbar(im, ax=ax, label=label, shrink=0.9)
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    return fig


def _columns(columns, width: int) -> slice:
    """``profile``'s ``columns`` as a slice selecting at least one of ``width`` columns, or an error naming it."""
    if columns is None:
        return slice(None)
    if isinstance(columns, slice):
        bounds = (columns.start, columns.stop, columns.step)
    elif isinstance(columns, tuple) and len(columns) == 2:
        bounds = (columns[0], columns[1], None)
    else:
        raise TypeError(f"columns: expected a slice or (start, stop), got {columns!r}")
    if any(b is not None and (isinstance(b, (bool, np.bool_)) or not isinstance(b, (int, np.integer)))
           for b in bounds):
        raise TypeError(f"columns: expected integer bounds, got {columns!r}")
    start, stop, step = bounds
    if step is not None and step < 1:
        raise ValueError(f"columns: the step must be >= 1, got {step}")
    if any(b is not None and not -width <= b <= width for b in (start, stop)):
        raise ValueError(f"columns: {columns!r} reaches beyond the image, {width} pixels wide")
    cols = slice(start, stop, step)
    if not len(range(width)[cols]):
        raise ValueError(f"columns: {columns!r} selects no column of the image, {width} pixels wide "
                         "(expected start < stop)")
    return cols


def profile(frame, row: int, *, columns=None, edges: bool = True, title: str | None = None):
    """One image row as a plot of its R, G and B channels (linear).

    Gouraud shading is linear across each triangle, so the profile is a
    polyline whose kinks sit on the triangle edges: the eye exaggerates each
    kink into a light or dark band (Mach bands). Phong's profile is smooth.

    Parameters
    ----------
    frame : Frame or (H, W, 3) float or (H, W, 3) uint8
        ``uint8`` is decoded from sRGB first (the axis label says so).
    row : int
        Image row, 0 at the top.
    columns : slice or (start, stop), optional
        The part of the row to plot; all of it by default. Integer bounds
        within the image's width (negative ones count from its end), at
        least one column, and a slice's step ``>= 1``.
    edges : bool
        With a Frame: faint vertical lines where the row crosses from one
        triangle to another.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
        One axes whose ``lines`` are the three channels (red, green, blue).
    """
    decoded: list = []
    img = _linear(frame, "frame", decoded)
    edges = as_bool(edges, "edges")
    if title is not None:
        title = as_name(title, "title")
    h, w = img.shape[:2]
    row = as_int(row, "row", minimum=0, maximum=h - 1)
    cols = _columns(columns, w)
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
    ax.set_ylabel("linear intensity" + (f"\n({DECODED_NOTE})" if decoded else ""))
    ax.set_xlim(x[0] - 0.5, x[-1] + 0.5)
    ax.set_ylim(bottom=0.0)
    ax.legend(loc="upper right", fontsize="small")
    ax.set_title(title if title is not None else f"row {row}")
    return fig


# The fractions (shadow mask, keep) use a colour map whose 1 is not white, so a lit
# region shows against the page: dark blue in shadow, yellow where fully lit.
FRACTION_MAP = "cividis"
_FRACTIONS = ("shadow", "keep")


def _term_panels(items) -> list:
    """(label, image, kind) per panel: kind "colour" (H, W, 3) or "fraction" (H, W)."""
    panels = []
    for name, value in items.items():
        if not isinstance(name, str):
            raise TypeError(f"terms: keys are the terms' names (str), got {type(name).__name__}")
        a = np.asarray(value)
        if a.dtype in (np.uint8, np.uint16):
            raise TypeError(f"terms[{name!r}]: {a.dtype} is an 8-bit picture; a term is a linear float image "
                            "(rs.render(..., terms=True) gives them); draw pictures with montage([...])")
        if a.dtype == np.bool_:
            a = a.astype(np.float64)
        if not np.issubdtype(a.dtype, np.number) or not np.all(np.isfinite(a)):
            raise ValueError(f"terms[{name!r}]: expected finite numbers, got dtype {a.dtype}")
        a = a.astype(np.float64)
        stacked = a.ndim == 4 or (a.ndim == 3 and a.shape[2] != 3) or name in _FRACTIONS and a.ndim == 3
        layers = [(f"{name}[{i}]", a[i]) for i in range(a.shape[0])] if stacked else [(name, a)]
        for label, img in layers:
            if img.ndim == 3 and img.shape[2] == 3:
                panels.append((label, img, "colour"))
            elif img.ndim == 2:
                if img.min() < 0.0 or img.max() > 1.0:
                    raise ValueError(f"terms[{name!r}]: a one-channel term is a fraction in [0, 1], "
                                     f"got [{img.min():.4g}, {img.max():.4g}]")
                panels.append((label, img, "fraction"))
            else:
                raise ValueError(f"terms[{name!r}]: expected (H, W, 3), (H, W), (L, H, W) or (L, H, W, 3), "
                                 f"got shape {a.shape}")
    return panels


def terms(items, *, columns: int | None = None, panel_width: float = 3.0, vmax: float | None = None):
    """The reflectance equation's terms as labelled panels on one shared scale.

    Colour terms (``ambient``, ``diffuse``, ``specular``, ``reflected``, ...)
    are drawn linearly: a pixel of value ``vmax`` is white, 0 is black, with
    the sRGB encoding of :func:`~raycast_shade.output.tonemap.to_uint8`, and the
    colour bar reads the linear value off the grey. One ``vmax`` for all of
    them, so the panels compare: ``diffuse`` twice as bright as ``specular``
    looks it. One-channel terms (the shadow mask per light, ``keep``) are
    fractions in [0, 1] on :data:`FRACTION_MAP` (dark: shadowed, yellow: lit)
    with a colour bar of their own.

    Parameters
    ----------
    items : dict of str to ndarray
        ``frame.terms``, or any names to (H, W, 3), (H, W), (L, H, W) or
        (L, H, W, 3) arrays (a stack gives one panel per light, ``name[i]``).
    columns : int, optional
        Panels per row; up to 4 by default.
    panel_width : float
        Inches per panel.
    vmax : float, optional
        The linear value drawn white; the largest value of the colour terms
        by default (values above it are drawn white, clipped).

    Returns
    -------
    matplotlib.figure.Figure
        One image axes per panel, the colour terms first (in the dict's order),
        then the fractions; then the colour bars' axes.
    """
    if not isinstance(items, Mapping):
        raise TypeError(f"items: expected a dict of term images (frame.terms), got {type(items).__name__}")
    if not items:
        raise ValueError("items: no terms in it; the frame's terms come with rs.render(scene, ..., terms=True)")
    if columns is not None:
        columns = as_int(columns, "columns", minimum=1)
    panel_width = as_scalar(panel_width, "panel_width", minimum=0.0, exclusive=True, maximum=1000.0)
    panels = _term_panels(items)
    panels = [p for p in panels if p[2] == "colour"] + [p for p in panels if p[2] == "fraction"]  # stable
    colour = [img for _, img, kind in panels if kind == "colour"]
    if vmax is None:
        vmax = max([float(img.max()) for img in colour] + [0.0]) or 1.0
    else:
        vmax = as_scalar(vmax, "vmax", minimum=0.0, exclusive=True)
    n = len(panels)
    columns = min(n, 4) if columns is None else columns
    rows = -(-n // columns)
    h, w = panels[0][1].shape[:2]
    fig = _figure("terms", figsize=(panel_width * columns + 1.2, panel_width * rows * h / w + 0.5 * rows),
                  layout="constrained")
    mpl_colors = require("matplotlib.colors", "matplotlib", "terms", "notebook")
    from matplotlib.cm import ScalarMappable

    # The grey ramp as the panels show it: linear value -> sRGB, so the bar's ticks are linear values.
    ramp = to_uint8(np.repeat(np.linspace(0.0, 1.0, 256)[:, None], 3, axis=1)[None])[0] / 255.0
    grey = mpl_colors.ListedColormap(ramp, name="linear_srgb_grey")
    colour_axes, fraction_axes = [], []
    for i, (label, img, kind) in enumerate(panels):
        ax = fig.add_subplot(rows, columns, i + 1)
        if kind == "colour":
            ax.imshow(to_uint8(img, exposure=1.0 / vmax), interpolation="nearest")
            colour_axes.append(ax)
        else:
            ax.imshow(img, cmap=FRACTION_MAP, vmin=0.0, vmax=1.0, interpolation="nearest")
            fraction_axes.append(ax)
        ax.set_title(label)
        ax.set_xticks([])
        ax.set_yticks([])
    if colour_axes:
        fig.colorbar(ScalarMappable(mpl_colors.Normalize(0.0, vmax), grey), ax=colour_axes, shrink=0.85,
                     label="linear intensity (shared scale; brighter is clipped)")
    if fraction_axes:
        fig.colorbar(ScalarMappable(mpl_colors.Normalize(0.0, 1.0), FRACTION_MAP), ax=fraction_axes, shrink=0.85,
                     location="bottom", aspect=30, label="fraction lit (shadow: 0 blocked, 1 lit)")
    return fig
